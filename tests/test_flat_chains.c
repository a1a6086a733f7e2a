/*
 * tests/test_flat_chains.c: every specular chain through flat faces (manifold/flat_chains.c).
 *
 * - Closed forms: a horizontal glass slab between x and y (the chain in, out: the lateral shift,
 *   the entry angle found by bisection on the horizontal distance), a triangular glass prism
 *   (Snell's law's tangential condition at both vertices, the light bent toward the prism's base),
 *   a flat mirror (the vertex where the line from x to y's mirror image meets the plane).
 * - Faces: a cube gives 6, a prism 5, a smooth-normal mesh or a faceted ball none.
 * - In scenes (a tilted glass cube, a prism, two separated tilted slabs of different index, the
 *   slabs beside an upright mirror, a cube beside a tilted mirror): from floor points to light
 *   points, every chain spc_flat_chains_all enumerates
 *   ends on its light point and is distinct, and every distinct chain that randomized angular
 *   attempts find (reflections off glass included, up to 4 vertices) is among them.
 * - The chains through two slabs (four vertices) counted at every call of specular NEE with the
 *   path integrator's budget of 2, not on the longer chains' few calls.
 * - The bound that ends a solve whose minimum lies outside its faces loses no root: on random
 *   slabs, cubes and prisms, the roots of every length to 5 with it are those without it, bit for
 *   bit, and it does end solves.
 * - The closed form for faces that are parallel once reflections are unfolded loses no root and
 *   moves none: on random stacked parallel slabs (and one tilted slab), the roots with it are
 *   those without it, and it settles a share of the solves by itself.
 * - One walk for several lengths (spc_flat_chains_all_later, spc_flat_chains_later) gives the
 *   chains of one walk per length, bit for bit.
 * - The walk's bound on the vertices a sequence still needs moves no root and no sequence solved.
 * - The polish's seed traced without its final segment ends on the same chain, bit for bit.
 * - A flat root polished to the flat tolerances gives the chain and value of the angular solver's
 *   own tolerance, to 1e-4, in fewer traces.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "chain_compare.h"
#include "harness.h"
#include "manifold/angular.h"
#include "manifold/flat_chains.h"
#include "manifold/solver.h"
#include "manifold/specular_nee.h"
#include "render_util.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

/* An 8 x 8 diffuse floor (z = 0), shape 0. */
static spc_scene *floor_scene(void)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *floor = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 M = spc_mat4_scale(spc_v3(4, 4, 1));
    spc_shape_init_rectangle(floor, &M, NULL, 0, 0, &err);
    floor->bsdf = tu_diffuse(sc, 0.8);
    return sc;
}

/* A cube [-1, 1]^3 placed by M with BSDF b. */
static spc_shape *add_cube(spc_scene *sc, const spc_mat4 *M, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_cube(s, M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

/* A triangular prism along y (length 2), its cross-section the triangle (-1, 0), (1, 0), (0, 1.4) in
 * (x, z), placed by M, with BSDF b: 6 vertices, 8 triangles wound outward. */
static spc_shape *add_prism(spc_scene *sc, const spc_mat4 *M, const spc_bsdf *b)
{
    static const float P[18] = {-1, -1, 0, 1, -1, 0, 0, -1, 1.4f, -1, 1, 0, 1, 1, 0, 0, 1, 1.4f};
    /* ends: y = -1 facing -y, y = 1 facing +y; sides: base z = 0, and the two slanted faces */
    static const uint32_t I[24] = {0, 1, 2, 3, 5, 4, 0, 3, 4, 0, 4, 1, 1, 4, 5, 1, 5, 2, 2, 5, 3, 2, 3, 0};
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.p = malloc(sizeof P + sizeof(float));
    m.idx = malloc(sizeof I);
    memcpy(m.p, P, sizeof P);
    m.p[18] = 0.0f;
    memcpy(m.idx, I, sizeof I);
    m.nverts = 6;
    m.ntris = 8;
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_mesh(s, &m, M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

/* A sphere light (radius r, radiance 5) and the scene finalized; NULL on failure. */
static spc_scene *add_light_finish(spc_scene *sc, spc_vec3 c, double r)
{
    spc_shape *light = tu_sphere(sc, c, r, tu_diffuse(sc, 0.0));
    tu_area(sc, light, sc->nshapes - 1, 5.0);
    spc_error err;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* ---- closed forms ---- */

/* The horizontal distance a ray entering at angle t1 covers between heights 0 and zy through a slab
 * [z0, z1] of index eta. */
static double slab_distance(double t1, double eta, double z0, double z1, double zy)
{
    double t2 = asin(sin(t1) / eta);
    return (zy - (z1 - z0)) * tan(t1) + (z1 - z0) * tan(t2);
}

TEST(slab_lateral_shift)
{
    spc_scene *sc = floor_scene();
    const double eta = 1.5, zy = 2.0;
    spc_mat4 M = tu_place(spc_v3(3, 3, 0.1), spc_v3(0, 0, 1), 0.0, spc_v3(0, 0, 1.0));
    add_cube(sc, &M, tu_glass(sc, eta));
    sc = add_light_finish(sc, spc_v3(0, 0, 3.5), 0.2);
    CHECK(sc != NULL);
    if (!sc)
        return;
    /* the slab's faces as the mesh has them (float vertices) */
    const spc_shape *slab = sc->shapes[1];
    const double h0 = slab->bbox_min.z, h1 = slab->bbox_max.z;
    spc_rng_seed(&rng, 21, 1);
    double worst = 0.0;
    int tried = 0;
    for (int i = 0; i < 200; ++i) {
        double D = 2.5 * rnd(), a = 2 * SPC_PI * rnd();
        spc_vec3 x = spc_v3(0.3 * rnd(), 0.3 * rnd(), 0.0);
        spc_vec3 y = spc_add(x, spc_v3(D * cos(a), D * sin(a), zy));
        spc_vec3 pts[8];
        unsigned char ev[8];
        int n = spc_flat_chain_roots(sc, true, false, x, y, 2, pts, ev, 4, NULL);
        CHECK_MSG(n == 1, "D %g: %d roots", D, n);
        if (n != 1)
            continue;
        /* the entry angle by bisection on the horizontal distance */
        double lo = 0.0, hi = 0.5 * SPC_PI - 1e-9;
        for (int it = 0; it < 200; ++it) {
            double mid = 0.5 * (lo + hi);
            if (slab_distance(mid, eta, h0, h1, zy) < D)
                lo = mid;
            else
                hi = mid;
        }
        double t1 = 0.5 * (lo + hi), t2 = asin(sin(t1) / eta);
        spc_vec3 dir = spc_v3(cos(a), sin(a), 0.0);
        spc_vec3 p0 = spc_add(x, spc_add(spc_scale(dir, h0 * tan(t1)), spc_v3(0, 0, h0)));
        spc_vec3 p1 = spc_add(p0, spc_add(spc_scale(dir, (h1 - h0) * tan(t2)), spc_v3(0, 0, h1 - h0)));
        worst = spc_max(worst, spc_max(spc_distance(p0, pts[0]), spc_distance(p1, pts[1])));
        CHECK(ev[0] == SPC_CHAIN_REFRACT && ev[1] == SPC_CHAIN_REFRACT);
        /* the exit direction is the entry direction */
        spc_vec3 d0 = spc_normalize(spc_sub(pts[0], x)), d2 = spc_normalize(spc_sub(y, pts[1]));
        CHECK(spc_distance(d0, d2) < 1e-9);
        /* no one-vertex chain: x and y on opposite sides of every face's plane or behind it */
        CHECK(spc_flat_chain_roots(sc, true, true, x, y, 1, pts, ev, 4, NULL) == 0);
        ++tried;
    }
    printf("  slab: %d configurations, worst vertex error %.3g\n", tried, worst);
    CHECK(tried == 200 && worst < 1e-9);
    spc_scene_destroy(sc);
}

TEST(mirror_image)
{
    spc_scene *sc = floor_scene();
    /* the plane x = 2 facing -x, 3 x 3 */
    spc_shape *m = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 M = tu_place(spc_v3(1.5, 1.5, 1.0), spc_v3(0, 1, 0), -90.0, spc_v3(2.0, 0.0, 1.5));
    spc_shape_init_rectangle(m, &M, NULL, 0, 0, &err);
    m->bsdf = tu_mirror(sc);
    sc = add_light_finish(sc, spc_v3(0.5, 0.5, 2.5), 0.2);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(spc_flat_chain_shape(sc->shapes[1]));
    spc_rng_seed(&rng, 22, 1);
    double worst = 0.0;
    int tried = 0;
    for (int i = 0; i < 200; ++i) {
        spc_vec3 x = spc_v3(-1.0 + 2.5 * rnd(), -1.0 + 2.0 * rnd(), 0.01);
        spc_vec3 y = spc_v3(-0.5 + 2.0 * rnd(), -1.0 + 2.0 * rnd(), 1.0 + 2.0 * rnd());
        spc_vec3 yi = spc_v3(4.0 - y.x, y.y, y.z); /* y mirrored in x = 2 */
        double t = (2.0 - x.x) / (yi.x - x.x);
        spc_vec3 want = spc_add(x, spc_scale(spc_sub(yi, x), t));
        bool inside = fabs(want.y) < 1.5 && fabs(want.z - 1.5) < 1.5;
        spc_vec3 pts[4];
        unsigned char ev[4];
        int n = spc_flat_chain_roots(sc, true, true, x, y, 1, pts, ev, 4, NULL);
        CHECK_MSG(n == (inside ? 1 : 0), "%d roots, %s the mirror", n, inside ? "inside" : "outside");
        if (n == 1 && inside) {
            worst = spc_max(worst, spc_distance(pts[0], want));
            CHECK(ev[0] == SPC_CHAIN_REFLECT);
            ++tried;
        }
    }
    printf("  mirror: %d reflections, worst vertex error %.3g\n", tried, worst);
    CHECK(tried > 100 && worst < 1e-9);
    spc_scene_destroy(sc);
}

/* Snell's law's tangential condition at a vertex on plane normal n: eta_i (n x wi) = eta_o (n x wo). */
static double snell_residual(spc_vec3 n, spc_vec3 wi, double eta_i, spc_vec3 wo, double eta_o)
{
    return spc_length(spc_sub(spc_scale(spc_cross(n, wi), eta_i), spc_scale(spc_cross(n, wo), eta_o)));
}

/* The outward unit normal of the prism's face (base or slanted: triangles 2, 4, 6) nearest to p. */
static spc_vec3 face_normal_at(const spc_shape *pr, spc_vec3 p)
{
    const int tris[3] = {2, 4, 6};
    spc_vec3 best = spc_v3(0, 0, 0);
    double dmin = INFINITY;
    for (int i = 0; i < 3; ++i) {
        const uint32_t *t = pr->mesh.idx + 3 * tris[i];
        spc_vec3 v[3];
        for (int j = 0; j < 3; ++j)
            v[j] = spc_v3(pr->mesh.p[3 * t[j]], pr->mesh.p[3 * t[j] + 1], pr->mesh.p[3 * t[j] + 2]);
        spc_vec3 n = spc_normalize(spc_cross(spc_sub(v[1], v[0]), spc_sub(v[2], v[0])));
        double d = fabs(spc_dot(n, spc_sub(p, v[0])));
        if (d < dmin) {
            dmin = d;
            best = n;
        }
    }
    return dmin < 1e-9 ? best : spc_v3(0, 0, 0);
}

TEST(prism_bends_toward_base)
{
    spc_scene *sc = floor_scene();
    /* the prism lying along y at height 1, its apex up; the light to one side, a little higher */
    spc_mat4 M = tu_place(spc_v3(0.6, 1.5, 0.6), spc_v3(0, 0, 1), 0.0, spc_v3(0, 0, 1.0));
    add_prism(sc, &M, tu_glass(sc, 1.5));
    sc = add_light_finish(sc, spc_v3(-2.0, 0.0, 1.3), 0.1);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const spc_shape *pr = sc->shapes[1];
    CHECK(spc_flat_chain_shape(pr));
    spc_rng_seed(&rng, 23, 1);
    int chains = 0;
    double worst = 0.0;
    for (int i = 0; i < 400; ++i) {
        spc_vec3 x = spc_v3(4.0 * rnd(), -1.0 + 2.0 * rnd(), 0.0);
        spc_vec3 y = spc_v3(-2.0 + 0.1 * (rnd() - 0.5), 0.1 * (rnd() - 0.5), 1.3);
        spc_vec3 pts[16];
        unsigned char ev[8];
        int n = spc_flat_chain_roots(sc, true, false, x, y, 2, pts, ev, 8, NULL);
        CHECK(n <= 1);
        for (int r = 0; r < n; ++r) {
            spc_vec3 a = pts[2 * r], b = pts[2 * r + 1];
            spc_vec3 w0 = spc_normalize(spc_sub(a, x)), w1 = spc_normalize(spc_sub(b, a)), w2 = spc_normalize(spc_sub(y, b));
            /* the face each vertex lies on: the nearest of the base and the two slanted faces
             * (their planes from the mesh's own vertices) */
            spc_vec3 na = face_normal_at(pr, a), nb = face_normal_at(pr, b);
            CHECK(spc_length(na) > 0.5 && spc_length(nb) > 0.5);
            worst = spc_max(worst, snell_residual(na, w0, 1.0, w1, 1.5));
            worst = spc_max(worst, snell_residual(nb, w1, 1.5, w2, 1.0));
            /* the light (travelling from y to x) leaves the prism turned toward its base (-z) */
            CHECK(ev[2 * r] == SPC_CHAIN_REFRACT && ev[2 * r + 1] == SPC_CHAIN_REFRACT);
            CHECK(-w0.z < -w2.z);
            ++chains;
        }
    }
    printf("  prism: %d chains, worst Snell residual %.3g\n", chains, worst);
    CHECK(chains > 20 && worst < 1e-9);
    spc_scene_destroy(sc);
}

TEST(faces_of_shapes)
{
    spc_scene *sc = floor_scene();
    spc_mat4 M = tu_place(spc_v3(0.5, 0.4, 0.3), spc_v3(1, 1, 0), 30.0, spc_v3(0, 0, 1.0));
    spc_shape *cube = add_cube(sc, &M, tu_glass(sc, 1.5));
    spc_shape *ball = tu_sphere(sc, spc_v3(2, 0, 1), 0.5, tu_glass(sc, 1.5));
    sc = add_light_finish(sc, spc_v3(0, 0, 3), 0.2);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(spc_flat_chain_shape(cube));
    CHECK(!spc_flat_chain_shape(ball));
    CHECK(!spc_flat_chain_shape(sc->shapes[0])); /* the diffuse floor */
    spc_scene_destroy(sc);
}

/* ---- in scenes, against randomized attempts ---- */

static double miss(const spc_chain *c, spc_vec3 y)
{
    const spc_chain_vertex *v = &c->v[c->n - 1];
    spc_vec3 r = spc_sub(y, v->h.p);
    double t = spc_dot(r, v->d);
    return t < 0.0 ? spc_length(r) : spc_length(spc_sub(r, spc_scale(v->d, t)));
}

typedef struct tally {
    int points, enumerated, random_distinct, random_missing, by_len[5];
} tally;

/* A randomized chain counts where the enumeration covers it and it carries light to x. */
typedef struct keep_ctx {
    bool reflect;
    const spc_emitter *e;
    spc_vec2 uv;
} keep_ctx;

static bool keep_flat(const spc_snee_query *q, const spc_chain *c, void *ctx)
{
    const keep_ctx *k = ctx;
    return spc_flat_chain_covers(c, k->reflect) && spc_snee_chain_value(q, k->e, k->uv, c).r > 0.0;
}

/* From the floor point below `above` to a light point: the enumeration against randomized attempts. */
static void compare_at(spc_scene *sc, const spc_snee_params *p, spc_vec3 above, uint64_t stream, tally *t)
{
    spc_hit x;
    spc_snee_query q;
    const spc_emitter *e;
    spc_vec2 uv;
    spc_rng r;
    spc_rng_seed(&r, 3, stream);
    if (!chain_compare_floor_query(sc, p, above, p->max_chain, &r, &x, &q, &e, &uv))
        return;
    ++t->points;
    CHECK(spc_snee_exact_covers_all(&q));
    spc_chain all[32];
    int it = 0;
    int n = spc_flat_chains_all(&q, all, 32, &it);
    t->enumerated += n;
    for (int i = 0; i < n; ++i) {
        ++t->by_len[all[i].n];
        CHECK_MSG(miss(&all[i], q.y) < SPC_SNEE_FLAT_POLISH_TOL_SCENE * sc->radius, "chain %d of %d vertices misses y by %g",
                  i, all[i].n, miss(&all[i], q.y));
        CHECK(spc_flat_chain_covers(&all[i], p->reflect));
        for (int j = 0; j < i; ++j)
            CHECK(!spc_snee_same_solution(&all[i], &all[j], sc->radius));
    }
    keep_ctx kc = {p->reflect, e, uv};
    chain_compare_random(&q, &r, 2000, all, n, sc->radius, keep_flat, &kc, "flat faces", &t->random_distinct,
                         &t->random_missing);
}

/* Floor points uniform in the square of half-side h around (cx, cy). */
static void run_scene(spc_scene *sc, const char *label, int max_chain, int points, int min_distinct, double cx,
                      double cy, double h)
{
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_rng_seed(&rng, 31, (uint64_t)max_chain);
    spc_snee_params p;
    spc_snee_params_default(&p, SPC_SNEE_ANGULAR, max_chain);
    p.any_surface = true;
    tally t;
    memset(&t, 0, sizeof t);
    for (int i = 0; i < points; ++i)
        compare_at(sc, &p, spc_v3(cx + h * (2.0 * rnd() - 1.0), cy + h * (2.0 * rnd() - 1.0), 5.0), 100 + (uint64_t)i, &t);
    printf("  %s: %d points, %d chains enumerated (1-4 vertices: %d %d %d %d), %d distinct randomized, %d "
           "missing\n",
           label, t.points, t.enumerated, t.by_len[1], t.by_len[2], t.by_len[3], t.by_len[4], t.random_distinct,
           t.random_missing);
    CHECK(t.points >= points / 2);
    CHECK(t.random_distinct >= min_distinct);
    CHECK(t.random_missing == 0);
    spc_scene_destroy(sc);
}

TEST(tilted_cube_contains_randomized_solutions)
{
    spc_scene *sc = floor_scene();
    spc_mat4 M = tu_place(spc_v3(0.5, 0.35, 0.4), spc_v3(1, 0.4, 0.2), 25.0, spc_v3(-0.3, 0.1, 0.8));
    add_cube(sc, &M, tu_glass(sc, 1.5));
    sc = add_light_finish(sc, spc_v3(-0.6, 0.4, 2.6), 0.2);
    run_scene(sc, "tilted cube, up to 4 vertices", 4, 60, 10, 0.0, 0.0, 2.0);
}

TEST(prism_contains_randomized_solutions)
{
    spc_scene *sc = floor_scene();
    spc_mat4 M = tu_place(spc_v3(0.6, 1.2, 0.6), spc_v3(1, 0, 0), 15.0, spc_v3(0, 0, 1.0));
    add_prism(sc, &M, tu_glass(sc, 1.5));
    sc = add_light_finish(sc, spc_v3(-1.8, 0.2, 1.4), 0.2);
    run_scene(sc, "prism, up to 3 vertices", 3, 60, 5, 1.2, 0.0, 1.2);
}

TEST(two_slabs_contain_randomized_solutions)
{
    spc_scene *sc = floor_scene();
    spc_mat4 A = tu_place(spc_v3(0.8, 0.8, 0.06), spc_v3(1, 0, 0), 12.0, spc_v3(-0.3, 0, 1.0));
    spc_mat4 B = tu_place(spc_v3(0.8, 0.8, 0.06), spc_v3(0, 1, 0), -10.0, spc_v3(0.2, 0.1, 1.6));
    add_cube(sc, &A, tu_glass(sc, 1.5));
    add_cube(sc, &B, tu_glass(sc, 1.33));
    sc = add_light_finish(sc, spc_v3(0.0, 0.2, 2.8), 0.25);
    run_scene(sc, "two slabs, up to 4 vertices", 4, 40, 10, 0.0, 0.0, 2.0);
}

TEST(two_slabs_and_mirror_contain_randomized_solutions)
{
    spc_scene *sc = floor_scene();
    spc_mat4 A = tu_place(spc_v3(0.8, 0.8, 0.06), spc_v3(1, 0, 0), 12.0, spc_v3(-0.3, 0, 1.0));
    spc_mat4 B = tu_place(spc_v3(0.8, 0.8, 0.06), spc_v3(0, 1, 0), -10.0, spc_v3(0.2, 0.1, 1.6));
    add_cube(sc, &A, tu_glass(sc, 1.5));
    add_cube(sc, &B, tu_glass(sc, 1.33));
    /* an upright one-sided mirror facing the slabs */
    spc_shape *m = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 M = tu_place(spc_v3(1.0, 1.0, 1.0), spc_v3(0, 1, 0), -80.0, spc_v3(1.8, 0.0, 1.2));
    spc_shape_init_rectangle(m, &M, NULL, 0, 0, &err);
    m->bsdf = tu_mirror(sc);
    sc = add_light_finish(sc, spc_v3(0.0, 0.2, 2.8), 0.25);
    run_scene(sc, "two slabs and a mirror, up to 4 vertices", 4, 40, 20, 0.0, 0.0, 2.0);
}

/* A tilted glass cube beside a tilted one-sided mirror that faces it and the floor: chains off the
 * mirror, through the cube, off the mirror then through the cube, and through the cube then off
 * the mirror. */
TEST(cube_and_mirror_contain_randomized_solutions)
{
    spc_scene *sc = floor_scene();
    spc_shape *m = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 F = tu_place(spc_v3(0.7, 0.9, 1.0), spc_v3(0, 1, 0), -60.0, spc_v3(1.1, 0.0, 0.8));
    spc_shape_init_rectangle(m, &F, NULL, 0, 0, &err);
    m->bsdf = tu_mirror(sc);
    spc_mat4 M = tu_place(spc_v3(0.3, 0.3, 0.3), spc_v3(1, 0.3, 0.2), 20.0, spc_v3(0.0, 0.0, 0.9));
    add_cube(sc, &M, tu_glass(sc, 1.5));
    sc = add_light_finish(sc, spc_v3(-0.6, 0.3, 2.4), 0.25);
    run_scene(sc, "cube and a mirror, up to 4 vertices", 4, 60, 10, 0.0, 0.0, 2.0);
}

/* Below two separated horizontal slabs under a small light the floor point is lit only through
 * four interfaces. With the path integrator's parameters (budget 2, the longer chains on) those
 * chains are enumerated at every call, psi 1: every light point on the half of the light facing x
 * gives a contribution, and none is far above the mean (on the long pass's calls only, 1 in 40
 * would, each counted 40 times: the largest about 100 times the mean). */
TEST(four_vertex_chains_every_call)
{
    spc_scene *sc = floor_scene();
    spc_mat4 A = tu_place(spc_v3(1.0, 1.0, 0.05), spc_v3(1, 0, 0), 0.0, spc_v3(0, 0, 1.0));
    spc_mat4 B = tu_place(spc_v3(1.0, 1.0, 0.08), spc_v3(1, 0, 0), 0.0, spc_v3(0.05, 0, 1.8));
    add_cube(sc, &A, tu_glass(sc, 1.5));
    add_cube(sc, &B, tu_glass(sc, 1.4));
    sc = add_light_finish(sc, spc_v3(0.1, 0.0, 3.0), 0.05);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_hit x;
    spc_ray ray = {spc_v3(0.02, 0.01, 0.5), spc_v3(0, 0, -1), 0, INFINITY};
    CHECK(spc_scene_intersect(sc, &ray, &x) && x.shape_index == 0);
    spc_snee_params p;
    spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 2);
    p.any_surface = true;
    p.mis = true; /* as the path integrator runs it */
    CHECK(p.exact && p.long_p > 0.0 && p.long_p < 1.0);
    spc_rng r;
    spc_rng_seed(&r, 5, 9);
    const int calls = 400;
    int nonzero = 0;
    double s1 = 0.0, vmax = 0.0;
    for (int i = 0; i < calls; ++i) {
        double v = spc_specular_nee_depth(sc, &p, &x, spc_v3(0, 0, 1), 2, SPC_CHAIN_MAX_VERTICES, &r, NULL).r;
        nonzero += v > 0.0;
        s1 += v;
        vmax = fmax(vmax, v);
    }
    double mean = s1 / calls;
    printf("  %d of %d calls nonzero, the largest %.2f times the mean\n", nonzero, calls, mean > 0.0 ? vmax / mean : 0.0);
    CHECK(nonzero >= calls * 4 / 10);
    CHECK(mean > 0.0 && vmax < 10.0 * mean);
    spc_scene_destroy(sc);
}

/* Random configurations: two or three glass cubes or slabs and a prism, each scaled, tilted and
 * placed at random over the floor, x on the floor and y above the casters. For each, the roots of
 * each length 1 to 5 found with the bounds on the faces and without them agree exactly, and the
 * bounds end a share of the solves that only their tight forms reach: most sequences here have a
 * kink for their minimum (a segment of no length on an edge), which the kink bound proves in the
 * last smoothing stage. */
TEST(face_bound_loses_no_root)
{
    spc_rng_seed(&rng, 41, 3);
    int scenes = 0, queries = 0, roots = 0, ended = 0, solved_on = 0, solved_off = 0, differ = 0;
    enum { MAXR = 64 };
    for (int t = 0; t < 6; ++t) {
        spc_scene *sc = floor_scene();
        int n = 2 + (int)(rnd() * 2.0);
        for (int i = 0; i < n; ++i) {
            spc_vec3 scale = spc_v3(0.3 + 0.5 * rnd(), 0.3 + 0.5 * rnd(), rnd() < 0.6 ? 0.03 + 0.05 * rnd() : 0.2 + 0.3 * rnd());
            spc_vec3 axis = spc_v3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
            spc_vec3 at = spc_v3(1.6 * rnd() - 0.8, 1.6 * rnd() - 0.8, 0.6 + 0.5 * i + 0.3 * rnd());
            spc_mat4 M = tu_place(scale, axis, 60.0 * rnd() - 30.0, at);
            if (i == n - 1 && t % 2)
                add_prism(sc, &M, tu_glass(sc, 1.4 + 0.2 * rnd()));
            else
                add_cube(sc, &M, tu_glass(sc, 1.33 + 0.2 * rnd()));
        }
        sc = add_light_finish(sc, spc_v3(0.4 * rnd() - 0.2, 0.4 * rnd() - 0.2, 3.2), 0.1);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        ++scenes;
        for (int qi = 0; qi < 12; ++qi) {
            spc_vec3 x = spc_v3(2.4 * rnd() - 1.2, 2.4 * rnd() - 1.2, 0.0);
            spc_vec3 y = spc_v3(0.4 * rnd() - 0.2, 0.4 * rnd() - 0.2, 3.1);
            for (int k = 1; k <= 5; ++k) {
                spc_vec3 pa[5 * MAXR], pb[5 * MAXR];
                unsigned char ea[5 * MAXR], eb[5 * MAXR];
                int sa = 0, sb = 0, ends = 0, ends_off = 0;
                bool reflect = qi % 3 == 0;
                /* the smoothed stages alone (no closed form), whose solves the bound ends */
                int na = spc_flat_chain_roots_solve(sc, false, reflect, x, y, k, pa, ea, MAXR, &sa, true, false, &ends,
                                                    NULL);
                int nb = spc_flat_chain_roots_solve(sc, false, reflect, x, y, k, pb, eb, MAXR, &sb, false, false,
                                                    &ends_off, NULL);
                ++queries;
                roots += nb;
                ended += ends;
                solved_on += sa;
                solved_off += sb;
                CHECK(ends_off == 0);
                if (na != nb || sa != sb || memcmp(pa, pb, sizeof(spc_vec3) * (size_t)(k * nb)) != 0 ||
                    memcmp(ea, eb, (size_t)(k * nb)) != 0)
                    ++differ;
            }
        }
        spc_scene_destroy(sc);
    }
    printf("  %d scenes, %d queries: %d roots, %d of %d solves ended by the bound, %d queries differ\n", scenes,
           queries, roots, ended, solved_on, differ);
    CHECK(scenes == 6);
    CHECK(roots >= 20);
    /* the bounds end half of the solves here or more (2891 of 4523; the bound on the faces alone
     * 681, 568 with 5 Newton steps a stage, 466 there where the smoothing's term is taken as mu
     * eta_j for every segment, the looser form) */
    CHECK(ended * 2 >= solved_on);
    CHECK(solved_on == solved_off);
    CHECK(differ == 0);
}

/* Orders roots (k points each) for comparison as sets. */
static int k_cmp;
static int root_cmp(const void *a, const void *b)
{
    const spc_vec3 *p = a, *q = b;
    for (int i = 0; i < k_cmp; ++i) {
        double d[3] = {p[i].x - q[i].x, p[i].y - q[i].y, p[i].z - q[i].z};
        for (int c = 0; c < 3; ++c)
            if (d[c] != 0.0)
                return d[c] < 0.0 ? -1 : 1;
    }
    return 0;
}

/* Four glass slabs and cubes placed at random, loaded in one order and in the reverse: the walk
 * visits the casters in their order (and caches the direction caps between faces of different
 * casters by their slots), but the chains and the pruning are the scene's, so the roots of each
 * length 1 to 4 agree as sets, bit for bit, and so does the number of face sequences solved (a
 * wrong cap moves it long before it loses a root). */
TEST(roots_do_not_depend_on_caster_order)
{
    spc_rng_seed(&rng, 77, 5);
    int queries = 0, roots = 0, solved = 0, differ = 0;
    enum { MAXR = 64, CASTERS = 4 };
    for (int t = 0; t < 8; ++t) {
        spc_mat4 M[CASTERS];
        double eta[CASTERS];
        for (int i = 0; i < CASTERS; ++i) {
            double sx = 0.3 + 0.3 * rnd(), sy = 0.3 + 0.3 * rnd();
            spc_vec3 scale = spc_v3(sx, sy, rnd() < 0.6 ? 0.03 + 0.05 * rnd() : 0.2 + 0.2 * rnd());
            spc_vec3 axis = spc_v3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
            spc_vec3 at = spc_v3(1.2 * rnd() - 0.6, 1.2 * rnd() - 0.6, 0.6 + 0.45 * i + 0.2 * rnd());
            M[i] = tu_place(scale, axis, 60.0 * rnd() - 30.0, at);
            eta[i] = 1.33 + 0.2 * rnd();
        }
        spc_vec3 light = spc_v3(0.4 * rnd() - 0.2, 0.4 * rnd() - 0.2, 3.2);
        spc_scene *sc[2];
        for (int o = 0; o < 2; ++o) {
            sc[o] = floor_scene();
            for (int i = 0; i < CASTERS; ++i) {
                int c = o ? CASTERS - 1 - i : i;
                add_cube(sc[o], &M[c], tu_glass(sc[o], eta[c]));
            }
            sc[o] = add_light_finish(sc[o], light, 0.1);
            CHECK(sc[o] != NULL);
        }
        if (!sc[0] || !sc[1]) {
            spc_scene_destroy(sc[0]);
            spc_scene_destroy(sc[1]);
            continue;
        }
        for (int qi = 0; qi < 16; ++qi) {
            spc_vec3 x = spc_v3(2.0 * rnd() - 1.0, 2.0 * rnd() - 1.0, 0.0);
            spc_vec3 y = spc_v3(0.4 * rnd() - 0.2, 0.4 * rnd() - 0.2, 3.1);
            for (int k = 1; k <= 4; ++k) {
                spc_vec3 pa[4 * MAXR], pb[4 * MAXR];
                int sa = 0, sb = 0;
                int na = spc_flat_chain_roots(sc[0], false, false, x, y, k, pa, NULL, MAXR, &sa);
                int nb = spc_flat_chain_roots(sc[1], false, false, x, y, k, pb, NULL, MAXR, &sb);
                k_cmp = k;
                qsort(pa, (size_t)na, sizeof(spc_vec3) * (size_t)k, root_cmp);
                qsort(pb, (size_t)nb, sizeof(spc_vec3) * (size_t)k, root_cmp);
                ++queries;
                roots += na;
                solved += sa;
                if (na != nb || sa != sb || memcmp(pa, pb, sizeof(spc_vec3) * (size_t)(k * na)) != 0)
                    ++differ;
            }
        }
        spc_scene_destroy(sc[0]);
        spc_scene_destroy(sc[1]);
    }
    printf("  %d queries: %d roots, %d sequences solved, %d queries differ\n", queries, roots, solved, differ);
    CHECK(roots >= 50);
    CHECK(differ == 0);
}

/* Random configurations of parallel faces: two or three glass slabs and cubes sharing one tilt
 * (stacked, as newton_slabs'), in every other scene one more tilted its own way. For each x on the
 * floor, y above and each length 1 to 5 (reflections off glass on every other query: a slab's total
 * internal reflections), the roots found with the closed form for parallel faces are those without
 * it: as many, from the same sequences, each within 1e-9 of the scene's size of its counterpart;
 * and the closed form settles a share of the solves by itself (where it applies: a slab's two
 * faces, stacked slabs, a box's total internal reflections off its sides; not the tilted slab's
 * sequences with the others): within SPC_FLAT_CLOSED_STEPS Newton steps, or by a reflecting face
 * that the path cannot cross. */
TEST(parallel_closed_form_same_roots)
{
    spc_rng_seed(&rng, 83, 7);
    int queries = 0, roots = 0, solved = 0, exact = 0, differ = 0;
    double worst = 0.0;
    enum { MAXR = 64 };
    for (int t = 0; t < 8; ++t) {
        spc_scene *sc = floor_scene();
        int n = 2 + (int)(rnd() * 2.0);
        spc_vec3 axis = spc_v3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
        double degrees = 50.0 * rnd() - 25.0;
        for (int i = 0; i < n; ++i) {
            spc_vec3 scale =
                spc_v3(0.3 + 0.5 * rnd(), 0.3 + 0.5 * rnd(), rnd() < 0.7 ? 0.03 + 0.05 * rnd() : 0.2 + 0.3 * rnd());
            spc_vec3 at = spc_v3(1.2 * rnd() - 0.6, 1.2 * rnd() - 0.6, 0.6 + 0.5 * i + 0.3 * rnd());
            spc_mat4 M = tu_place(scale, axis, degrees, at);
            add_cube(sc, &M, tu_glass(sc, 1.33 + 0.2 * rnd()));
        }
        if (t % 2) {
            spc_mat4 M = tu_place(spc_v3(0.4, 0.5, 0.05), spc_v3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5),
                               40.0 * rnd() - 20.0, spc_v3(0.8 * rnd() - 0.4, 0.8 * rnd() - 0.4, 2.3));
            add_cube(sc, &M, tu_glass(sc, 1.5));
        }
        sc = add_light_finish(sc, spc_v3(0.4 * rnd() - 0.2, 0.4 * rnd() - 0.2, 3.4), 0.1);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        for (int qi = 0; qi < 16; ++qi) {
            spc_vec3 x = spc_v3(2.4 * rnd() - 1.2, 2.4 * rnd() - 1.2, 0.0);
            spc_vec3 y = spc_v3(0.4 * rnd() - 0.2, 0.4 * rnd() - 0.2, 3.3);
            bool reflect = qi % 2 == 0;
            for (int k = 1; k <= 5; ++k) {
                spc_vec3 pa[5 * MAXR], pb[5 * MAXR];
                unsigned char ea[5 * MAXR], eb[5 * MAXR];
                int sa = 0, sb = 0, ex = 0;
                int na =
                    spc_flat_chain_roots_solve(sc, false, reflect, x, y, k, pa, ea, MAXR, &sa, true, true, NULL, &ex);
                int nb =
                    spc_flat_chain_roots_solve(sc, false, reflect, x, y, k, pb, eb, MAXR, &sb, true, false, NULL, NULL);
                ++queries;
                roots += nb;
                solved += sa;
                exact += ex;
                bool same = na == nb && sa == sb && memcmp(ea, eb, (size_t)(k * nb)) == 0;
                for (int i = 0; same && i < k * nb; ++i)
                    worst = fmax(worst, spc_distance(pa[i], pb[i]));
                differ += !same;
            }
        }
        spc_scene_destroy(sc);
    }
    printf("  %d queries: %d roots, %d sequences solved, %d settled by the closed form, %d queries differ, "
           "largest distance %.3g\n",
           queries, roots, solved, exact, differ, worst);
    CHECK(roots >= 60);
    CHECK(differ == 0);
    CHECK(worst < 1e-9 * 8.0);
    /* 9003 of 28204 here: the others mix the tilted slab's faces, or a side face's with a top's */
    CHECK(exact * 4 >= solved);
}

/* One walk for several lengths: on random slabs and cubes (each tilted its own way) from floor points
 * to light points, spc_flat_chains_all_later for lengths 1-2 with 3 and 4 kept, then
 * spc_flat_chains_later for 3 and 4, give the chains that three calls of spc_flat_chains_all give
 * (lengths 1-2, 3, 4): as many, in the same order, every vertex bit for bit. */
TEST(one_walk_for_several_lengths)
{
    spc_rng_seed(&rng, 91, 3);
    int points = 0, chains[5] = {0}, differ = 0;
    enum { MAXC = 16 };
    for (int t = 0; t < 6; ++t) {
        spc_scene *sc = floor_scene();
        int n = 2 + (int)(rnd() * 2.0);
        for (int i = 0; i < n; ++i) {
            spc_vec3 scale =
                spc_v3(0.3 + 0.5 * rnd(), 0.3 + 0.5 * rnd(), rnd() < 0.7 ? 0.03 + 0.05 * rnd() : 0.2 + 0.3 * rnd());
            spc_vec3 axis = spc_v3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
            spc_vec3 at = spc_v3(1.2 * rnd() - 0.6, 1.2 * rnd() - 0.6, 0.6 + 0.5 * i + 0.3 * rnd());
            spc_mat4 M = tu_place(scale, axis, 50.0 * rnd() - 25.0, at);
            add_cube(sc, &M, tu_glass(sc, 1.33 + 0.2 * rnd()));
        }
        sc = add_light_finish(sc, spc_v3(0.4 * rnd() - 0.2, 0.4 * rnd() - 0.2, 3.4), 0.3);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_snee_params p;
        spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 2);
        p.any_surface = true;
        p.reflect = true;
        for (int qi = 0; qi < 40; ++qi) {
            spc_hit x;
            spc_snee_query q;
            spc_vec3 above = spc_v3(2.0 * rnd() - 1.0, 2.0 * rnd() - 1.0, 5.0);
            spc_rng r;
            spc_rng_seed(&r, 5, (uint64_t)(100 * t + qi));
            if (!chain_compare_floor_query(sc, &p, above, 2, &r, &x, &q, NULL, NULL))
                continue;
            ++points;
            static spc_chain a[3][MAXC], b[3][MAXC];
            int na[3], nb[3], it = 0;
            na[0] = spc_flat_chains_all(&q, a[0], MAXC, &it);
            spc_flat_later later;
            nb[0] = spc_flat_chains_all_later(&q, 1u << 3 | 1u << 4, &later, b[0], MAXC, &it);
            CHECK(!later.overflow);
            for (int k = 3; k <= 4; ++k) {
                spc_snee_query lq = q;
                lq.min_chain = lq.max_chain = k;
                na[k - 2] = spc_flat_chains_all(&lq, a[k - 2], MAXC, &it);
                nb[k - 2] = spc_flat_chains_later(&lq, &later, k, b[k - 2], MAXC, &it);
            }
            for (int g = 0; g < 3; ++g) {
                bool same = na[g] == nb[g];
                for (int i = 0; same && i < na[g]; ++i) {
                    same = a[g][i].n == b[g][i].n;
                    for (int j = 0; same && j < a[g][i].n; ++j)
                        same = memcmp(&a[g][i].v[j].h.p, &b[g][i].v[j].h.p, sizeof(spc_vec3)) == 0;
                    chains[a[g][i].n] += same;
                }
                differ += !same;
            }
        }
        spc_scene_destroy(sc);
    }
    printf("  %d points: chains of 1-4 vertices %d %d %d %d, %d groups differ\n", points, chains[1], chains[2],
           chains[3], chains[4], differ);
    CHECK(points >= 100);
    CHECK(chains[2] >= 20 && chains[3] + chains[4] >= 5);
    CHECK(differ == 0);
}

/* The walk's bound on the vertices a sequence still needs (bound_near) skips only vertices from
 * which no sequence reaches y: on random scenes of two or three glass slabs, cubes and prisms, one
 * with a one-sided mirror beside them, and on newton_slabs' two stacked slabs wider than the floor,
 * the roots of each length 1 to 5 with the bound are those without it, bit for bit, in the same
 * order, and so are the sequences solved, for the enumeration's events and with partial reflections
 * (path_lt_view's walk). A bound that ruled out one vertex too many loses a root or a sequence; one
 * that rules out too few walks as many vertices: on the stacked slabs, where four interfaces are the
 * only way up, it must skip most of them. */
TEST(vertex_bound_same_roots)
{
    spc_rng_seed(&rng, 57, 3);
    int queries = 0, roots = 0, seqs = 0, differ = 0;
    long nodes_on = 0, nodes_off = 0, stacked_on = 0, stacked_off = 0;
    enum { MAXR = 64 };
    for (int t = 0; t < 7; ++t) {
        spc_scene *sc = floor_scene();
        spc_vec3 light = spc_v3(0.4 * rnd() - 0.2, 0.4 * rnd() - 0.2, 3.2);
        if (t == 6) { /* newton_slabs: slabs 5 wide and 0.16 thick at 0.55 and 0.9 under a light at 2.2 */
            spc_mat4 A = tu_place(spc_v3(2.5, 2.5, 0.08), spc_v3(1, 0, 0), 0.0, spc_v3(0, 0, 0.55));
            spc_mat4 B = tu_place(spc_v3(2.5, 2.5, 0.08), spc_v3(1, 0, 0), 0.0, spc_v3(0, 0, 0.9));
            add_cube(sc, &A, tu_glass(sc, 1.5));
            add_cube(sc, &B, tu_glass(sc, 1.5));
            light = spc_v3(0.3, 0.2, 2.2);
        } else {
            int n = 2 + (int)(rnd() * 2.0);
            for (int i = 0; i < n; ++i) {
                spc_vec3 scale =
                    spc_v3(0.3 + 0.5 * rnd(), 0.3 + 0.5 * rnd(), rnd() < 0.6 ? 0.03 + 0.05 * rnd() : 0.2 + 0.3 * rnd());
                spc_vec3 axis = spc_v3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
                spc_vec3 at = spc_v3(1.6 * rnd() - 0.8, 1.6 * rnd() - 0.8, 0.6 + 0.5 * i + 0.3 * rnd());
                spc_mat4 M = tu_place(scale, axis, 60.0 * rnd() - 30.0, at);
                if (i == n - 1 && t % 2)
                    add_prism(sc, &M, tu_glass(sc, 1.4 + 0.2 * rnd()));
                else
                    add_cube(sc, &M, tu_glass(sc, 1.33 + 0.2 * rnd()));
            }
            if (t == 5) { /* an upright one-sided mirror facing the glass */
                spc_shape *m = spc_scene_new_shape(sc);
                spc_error err;
                spc_mat4 M = tu_place(spc_v3(1.0, 1.0, 1.0), spc_v3(0, 1, 0), -80.0, spc_v3(1.8, 0.0, 1.2));
                spc_shape_init_rectangle(m, &M, NULL, 0, 0, &err);
                m->bsdf = tu_mirror(sc);
            }
        }
        sc = add_light_finish(sc, light, 0.1);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        for (int qi = 0; qi < 12; ++qi) {
            spc_vec3 x = spc_v3(2.4 * rnd() - 1.2, 2.4 * rnd() - 1.2, 0.0);
            spc_vec3 y = spc_v3(light.x + 0.1 * rnd() - 0.05, light.y + 0.1 * rnd() - 0.05, light.z - 0.1);
            for (int k = 1; k <= 5; ++k) {
                spc_vec3 pa[5 * MAXR], pb[5 * MAXR];
                unsigned char ea[5 * MAXR], eb[5 * MAXR];
                int sa = 0, sb = 0, partial = qi % 3;
                bool reflect = qi % 2 == 0;
                long na_nodes = 0, nb_nodes = 0;
                int na = spc_flat_chain_roots_near(sc, false, reflect, partial, x, y, k, pa, ea, MAXR, &sa, true,
                                                   &na_nodes);
                int nb = spc_flat_chain_roots_near(sc, false, reflect, partial, x, y, k, pb, eb, MAXR, &sb, false,
                                                   &nb_nodes);
                ++queries;
                roots += nb;
                seqs += sb;
                nodes_on += na_nodes;
                nodes_off += nb_nodes;
                if (t == 6) {
                    stacked_on += na_nodes;
                    stacked_off += nb_nodes;
                }
                if (na != nb || sa != sb || memcmp(pa, pb, sizeof(spc_vec3) * (size_t)(k * nb)) != 0 ||
                    memcmp(ea, eb, (size_t)(k * nb)) != 0)
                    ++differ;
            }
        }
        spc_scene_destroy(sc);
    }
    printf("  %d queries: %d roots, %d sequences solved; vertices walked %ld with the bound, %ld without (the "
           "stacked slabs %ld, %ld); %d queries differ\n",
           queries, roots, seqs, nodes_on, nodes_off, stacked_on, stacked_off, differ);
    CHECK(roots >= 50);
    CHECK(differ == 0);
    CHECK(nodes_on < nodes_off);
    CHECK(stacked_on * 4 < stacked_off);
}

/* The polish of a root (polish.c) traces its seed chain without the final segment (skip_end): the
 * solve takes the seed whatever that segment meets, so the chain it ends with must be the one it
 * ends with when the segment is traced. Two stacked slabs (newton_slabs' four refractions), floor
 * points to points on the light's lower half: from each root's first direction (as the walk hands
 * it to the polish), the angular solve with the polish's options, the end traced and not: the same
 * convergence, traces, residual, parameters and vertices bit for bit, and the seed's trace without
 * its end stops at the last vertex with no end hit. */
static bool same_bits(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }
static bool same_vec(spc_vec3 a, spc_vec3 b) { return same_bits(a.x, b.x) && same_bits(a.y, b.y) && same_bits(a.z, b.z); }

TEST(polish_without_end_same_chain)
{
    spc_scene *sc = floor_scene();
    spc_mat4 A = tu_place(spc_v3(2.5, 2.5, 0.08), spc_v3(1, 0, 0), 0.0, spc_v3(0, 0, 0.55));
    spc_mat4 B = tu_place(spc_v3(2.5, 2.5, 0.08), spc_v3(1, 0, 0), 0.0, spc_v3(0, 0, 0.9));
    add_cube(sc, &A, tu_glass(sc, 1.5));
    add_cube(sc, &B, tu_glass(sc, 1.5));
    const spc_vec3 lc = spc_v3(0.3, -0.2, 2.2);
    const double lr = 0.3;
    sc = add_light_finish(sc, lc, lr);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_rng_seed(&rng, 36, 1);
    spc_angular_options ao;
    spc_angular_options_default(&ao);
    ao.window = 0; /* the polish's options */
    ao.max_iterations = 8;
    int roots = 0, converged = 0, ends = 0, stepped = 0, differ = 0;
    for (int i = 0; i < 80; ++i) {
        spc_hit x;
        spc_ray ray = {spc_v3(2.0 * rnd() - 1.0, 2.0 * rnd() - 1.0, 0.3), spc_v3(0, 0, -1), 0, INFINITY};
        if (!spc_scene_intersect(sc, &ray, &x) || x.shape_index != 0)
            continue;
        /* a point on the light's lower half */
        double z = -rnd(), phi = 2.0 * M_PI * rnd(), rho = sqrt(fmax(0.0, 1.0 - z * z));
        spc_vec3 ny = spc_v3(rho * cos(phi), rho * sin(phi), z);
        spc_vec3 y = spc_madd(lc, ny, lr);
        spc_vec3 pts[4 * 8];
        unsigned char ev[4 * 8];
        int n = spc_flat_chain_roots(sc, false, false, x.p, y, 4, pts, ev, 8, NULL);
        for (int j = 0; j < n; ++j) {
            ++roots;
            spc_vec3 xo = spc_hit_offset(&x, spc_sub(pts[4 * j], x.p));
            spc_vec3 dir = spc_normalize(spc_sub(pts[4 * j], xo));
            spc_angular_target tg = {y, ny, sc->radius, sqrt(4.0 * M_PI) * lr};
            spc_chain c[2];
            spc_angular_result res[2];
            bool conv[2];
            /* every other point's roots at a tolerance that the seed itself meets (the polish's
             * seeds meet its own in a share of the calls) */
            spc_angular_options aj = ao;
            if (i % 2) {
                aj.tol_scene = 1e-4;
                aj.tol_light = 1e-2;
            }
            for (int e = 0; e < 2; ++e) {
                spc_chain_opts o = spc_chain_opts_default(4);
                o.events = &ev[4 * j];
                o.skip_end = e == 1;
                conv[e] = spc_angular_solve(sc, &x, &tg, dir, &o, &aj, &c[e], &res[e]);
            }
            converged += conv[0];
            ends += conv[0] && res[0].iterations == 1 && c[0].has_end_hit;
            stepped += res[0].iterations > 1;
            bool same = conv[0] == conv[1] && res[0].iterations == res[1].iterations &&
                        same_bits(res[0].residual, res[1].residual) && c[0].n == c[1].n &&
                        same_bits(c[0].a, c[1].a) && same_bits(c[0].b, c[1].b) && same_vec(c[0].d0, c[1].d0);
            for (int v = 0; same && v < c[0].n; ++v)
                same = same_vec(c[0].v[v].h.p, c[1].v[v].h.p) && same_vec(c[0].v[v].d, c[1].v[v].d) &&
                       same_vec(c[0].v[v].h.ng, c[1].v[v].h.ng) && c[0].v[v].event == c[1].v[v].event &&
                       c[0].v[v].h.shape_index == c[1].v[v].h.shape_index;
            differ += !same;
            /* the seed alone: four vertices, no end hit */
            spc_chain_opts o = spc_chain_opts_default(4);
            o.events = &ev[4 * j];
            o.skip_end = true;
            spc_chain sd;
            spc_frame fr = spc_frame_from_n(dir);
            CHECK(spc_chain_trace(sc, &x, &fr, 0.0, 0.0, &o, &sd) == SPC_CHAIN_END_SURFACE && sd.n == 4 &&
                  !sd.has_end_hit);
        }
    }
    printf("  %d roots, %d polished (%d on the seed, its end traced; %d took a step), %d differ\n", roots, converged,
           ends, stepped, differ);
    CHECK(roots >= 40 && converged >= roots * 9 / 10);
    CHECK(stepped >= roots / 4 && ends >= roots / 4);
    CHECK(differ == 0);
    spc_scene_destroy(sc);
}

/* The polish of a flat root to its own tolerances (spc_snee_exact_polish_flat) against the angular
 * solver's (spc_snee_exact_polish_shapes), from the same root: newton_slabs' two stacked slabs, floor
 * points under light points drawn as the renderer draws them. Each root polishes to the same
 * solution either way, its value (spc_snee_chain_value) within 1e-4 relative, its final segment
 * within the flat tolerance of the light point, in fewer traces. */
TEST(flat_polish_same_values)
{
    spc_scene *sc = floor_scene();
    spc_mat4 A = tu_place(spc_v3(2.5, 2.5, 0.08), spc_v3(1, 0, 0), 0.0, spc_v3(0, 0, 0.55));
    spc_mat4 B = tu_place(spc_v3(2.5, 2.5, 0.08), spc_v3(1, 0, 0), 0.0, spc_v3(0, 0, 0.9));
    add_cube(sc, &A, tu_glass(sc, 1.5));
    add_cube(sc, &B, tu_glass(sc, 1.5));
    sc = add_light_finish(sc, spc_v3(0.3, -0.2, 2.2), 0.3);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params p;
    spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 4);
    p.any_surface = true;
    spc_rng_seed(&rng, 36, 2);
    int roots = 0, both = 0, same = 0, close = 0, tight_traces = 0, flat_traces = 0;
    double worst = 0.0;
    for (int i = 0; i < 80; ++i) {
        spc_hit x;
        spc_snee_query q;
        const spc_emitter *e;
        spc_vec2 uv;
        spc_vec3 above = spc_v3(2.0 * rnd() - 1.0, 2.0 * rnd() - 1.0, 0.3);
        spc_rng r;
        spc_rng_seed(&r, 7, (uint64_t)i);
        if (!chain_compare_floor_query(sc, &p, above, 4, &r, &x, &q, &e, &uv))
            continue;
        spc_vec3 pts[4 * 8];
        unsigned char ev[4 * 8];
        int n = spc_flat_chain_roots(sc, true, false, x.p, q.y, 4, pts, ev, 8, NULL);
        for (int j = 0; j < n; ++j) {
            ++roots;
            const spc_shape *shapes[4];
            for (int v = 0; v < 4; ++v)
                shapes[v] = NULL;
            spc_vec3 xo = spc_hit_offset(&x, spc_sub(pts[4 * j], x.p));
            spc_vec3 dir = spc_normalize(spc_sub(pts[4 * j], xo));
            /* the shapes the root's vertices lie on: those of a first trace along its events */
            spc_chain_opts o = spc_chain_opts_default(4);
            o.events = &ev[4 * j];
            o.any_surface = true;
            o.skip_end = true;
            spc_chain sd;
            spc_frame fr = spc_frame_from_n(dir);
            if (spc_chain_trace(sc, &x, &fr, 0.0, 0.0, &o, &sd) != SPC_CHAIN_END_SURFACE || sd.n != 4)
                continue;
            for (int v = 0; v < 4; ++v)
                shapes[v] = sc->shapes[sd.v[v].h.shape_index];
            spc_chain c[2];
            int it[2] = {0, 0};
            bool ok0 = spc_snee_exact_polish_shapes(&q, shapes, 4, &ev[4 * j], dir, c, 0, &it[0]);
            bool ok1 = spc_snee_exact_polish_flat(&q, shapes, 4, &ev[4 * j], dir, c + 1, 0, &it[1]);
            if (!(ok0 && ok1))
                continue;
            ++both;
            tight_traces += it[0];
            flat_traces += it[1];
            same += spc_snee_same_solution(&c[0], &c[1], sc->radius);
            spc_rgb v0 = spc_snee_chain_value(&q, e, uv, &c[0]), v1 = spc_snee_chain_value(&q, e, uv, &c[1]);
            double rel = v0.r > 0.0 ? fabs(v1.r - v0.r) / v0.r : fabs(v1.r);
            worst = fmax(worst, rel);
            close += rel < 1e-4 && miss(&c[1], q.y) < SPC_SNEE_FLAT_POLISH_TOL_SCENE * sc->radius;
        }
    }
    printf("  %d roots, %d polished both ways: %d the same solution, %d values within 1e-4 (worst %.2e); "
           "traces %d (the angular solver's tolerance) against %d\n",
           roots, both, same, close, worst, tight_traces, flat_traces);
    CHECK(roots >= 40 && both >= roots * 9 / 10);
    CHECK(same == both && close == both);
    CHECK(flat_traces < tight_traces);
    spc_scene_destroy(sc);
}

/* The walk's test of a face hidden by another convex caster (spc_flat_shape_face_shadowed), from
 * points below, between, above and beside three slabs, against the same test written out here over
 * the face's corners found from the mesh's vertices on its plane: the same answer for every face and
 * point, and both answers among them. */
TEST(face_shadow_test_same_answer)
{
    spc_scene *sc = floor_scene();
    spc_mat4 A = tu_place(spc_v3(1.5, 1.5, 0.06), spc_v3(1, 0, 0), 0.0, spc_v3(0.0, 0.0, 1.0));
    spc_mat4 B = tu_place(spc_v3(1.5, 1.5, 0.06), spc_v3(1, 0, 0), 0.0, spc_v3(0.0, 0.0, 1.6));
    spc_mat4 C = tu_place(spc_v3(0.4, 0.4, 0.05), spc_v3(0, 1, 0), 25.0, spc_v3(0.9, 0.3, 0.5));
    add_cube(sc, &A, tu_glass(sc, 1.5));
    add_cube(sc, &B, tu_glass(sc, 1.5));
    add_cube(sc, &C, tu_glass(sc, 1.33));
    sc = add_light_finish(sc, spc_v3(0.3, -0.2, 2.6), 0.2);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const double scale = 4.0, tol = 1e-9 * scale; /* SPC_FLAT_SIDE_REL of the problem's size */
    spc_rng_seed(&rng, 38, 1);
    int tests = 0, hidden = 0, seen = 0, differ = 0;
    for (int n = 0; n < 400; ++n) {
        double h = n % 4 == 0   ? 0.05 + 0.9 * rnd()
                   : n % 4 == 1 ? 1.1 + 0.4 * rnd()
                   : n % 4 == 2 ? 1.7 + 1.3 * rnd()
                                : 0.5 + 1.5 * rnd();
        double spread = n % 4 == 3 ? 4.0 : 2.0;
        spc_vec3 z = spc_v3(spread * (2.0 * rnd() - 1.0), spread * (2.0 * rnd() - 1.0), h);
        for (int si = 1; si <= 3; ++si) {
            const spc_shape *s = sc->shapes[si];
            spc_vec3 nb[SPC_FLAT_MAX_FACES];
            double db[SPC_FLAT_MAX_FACES];
            int nfb = spc_flat_shape_planes(s, nb, db, SPC_FLAT_MAX_FACES);
            for (int b = 0; b < nfb; ++b) {
                /* the face's corners: the mesh's vertices on its plane (the shape is convex) */
                spc_vec3 corner[64];
                int nc = 0;
                for (size_t v = 0; v < s->mesh.nverts && nc < 64; ++v) {
                    spc_vec3 p = spc_v3(s->mesh.p[3 * v], s->mesh.p[3 * v + 1], s->mesh.p[3 * v + 2]);
                    if (fabs(spc_dot(nb[b], p) - db[b]) < 1e-6)
                        corner[nc++] = p;
                }
                bool want = false;
                for (int ci = 1; ci <= 3 && !want; ++ci) {
                    const spc_shape *c = sc->shapes[ci];
                    if (ci == si || !spc_flat_chain_closed(c))
                        continue;
                    spc_vec3 nf[SPC_FLAT_MAX_FACES];
                    double df[SPC_FLAT_MAX_FACES];
                    int nff = spc_flat_shape_planes(c, nf, df, SPC_FLAT_MAX_FACES);
                    for (int f = 0; f < nff && !want; ++f) {
                        double dz = spc_dot(nf[f], z) - df[f];
                        if (fabs(dz) <= tol)
                            continue;
                        bool all = nc > 0;
                        for (int k = 0; k < nc && all; ++k) {
                            double dc = spc_dot(nf[f], corner[k]) - df[f];
                            if (!(dc * dz < 0.0 && fabs(dc) > tol)) {
                                all = false;
                                break;
                            }
                            spc_vec3 q = spc_add(corner[k], spc_scale(spc_sub(z, corner[k]), dc / (dc - dz)));
                            all = spc_flat_shape_face_holds(c, f, q, -tol);
                        }
                        want = all;
                    }
                }
                bool got = spc_flat_shape_face_shadowed(sc, true, s, b, z, scale);
                ++tests;
                hidden += got;
                seen += !got;
                differ += got != want;
            }
        }
    }
    printf("  %d faces tested: %d hidden, %d not; %d differ from the test over the mesh's corners\n", tests, hidden,
           seen, differ);
    CHECK(differ == 0);
    CHECK(hidden >= 50 && seen >= 50);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(slab_lateral_shift);
    RUN(mirror_image);
    RUN(prism_bends_toward_base);
    RUN(faces_of_shapes);
    RUN(tilted_cube_contains_randomized_solutions);
    RUN(prism_contains_randomized_solutions);
    RUN(two_slabs_contain_randomized_solutions);
    RUN(two_slabs_and_mirror_contain_randomized_solutions);
    RUN(cube_and_mirror_contain_randomized_solutions);
    RUN(four_vertex_chains_every_call);
    RUN(face_bound_loses_no_root);
    RUN(roots_do_not_depend_on_caster_order);
    RUN(parallel_closed_form_same_roots);
    RUN(one_walk_for_several_lengths);
    RUN(vertex_bound_same_roots);
    RUN(polish_without_end_same_chain);
    RUN(flat_polish_same_values);
    RUN(face_shadow_test_same_answer);
    return spc_test_finish();
}
