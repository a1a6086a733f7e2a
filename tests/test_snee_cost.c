/*
 * tests/test_snee_cost.c: the exact early-outs of specular NEE (manifold/snee_cost.h).
 *
 * - spc_snee_spheres_keep_apart: true for a glass and a mirror ball with chains of up to 2
 *   vertices without reflections off glass, false with reflections, with 3 vertices, with the balls
 *   overlapping, with x inside one, with two glass balls and 4 vertices.
 * - Its premise, by randomized attempts: in a box with a glass and a mirror ball, from points on
 *   the floor and the walls to points of a ceiling light, no chain of at most 2 vertices the angular
 *   solver finds (refraction only) leaves one ball for the other; every one is a chain the sphere
 *   enumeration covers. With 3 vertices such chains are found (the test can fail).
 * - spc_sphere_arc_unseen against a dense scan of y . P over random arcs and points y.
 * - spc_snee_query_prob: later_p's probability only where it applies.
 * - spc_snee_caster_share: one ball's cone of directions in closed form; 1 within a caster's bound.
 * - spc_snee_later_prob, spc_snee_first_prob: later_p (first_p) far from the casters, 1 beside
 *   them (near_p with nearp), in between in proportion to the share, never below later_p nor above 1; 1 without
 *   roulette.
 * - tightshare: the share by each caster's own sphere (a ball's radius, not its box's sqrt(3)
 *   times it) in closed form, certain within the ball and in its shadow from the light, below 1
 *   between the ball and the light; a tessellated
 *   ball's tight sphere holds every vertex and is the ball's, not its box's.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/rng.h"
#include "harness.h"
#include "manifold/snee_cost.h"
#include "manifold/sphere_chains.h"
#include "manifold/sphere_roots.h"
#include "render_util.h"

/* A box floor (z = 0) with a glass ball and a mirror ball on it (or overlapping, if `overlap`), a
 * second glass ball in place of the mirror if `two_glass`, and a small light at z = 2 facing down. */
static spc_scene *balls(bool overlap, bool two_glass)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *floor = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 M = spc_mat4_scale(spc_v3(1, 1, 1));
    spc_shape_init_rectangle(floor, &M, NULL, 0, 0, &err);
    floor->bsdf = tu_diffuse(sc, 0.7);
    tu_sphere(sc, spc_v3(-0.42, 0.1, 0.36), 0.36, tu_glass(sc, 1.5));
    tu_sphere(sc, overlap ? spc_v3(0.1, 0.1, 0.33) : spc_v3(0.45, -0.3, 0.33), 0.33,
              two_glass ? tu_glass(sc, 1.5) : tu_mirror(sc));
    spc_shape *light = spc_scene_new_shape(sc);
    spc_mat4 T = spc_mat4_translate(spc_v3(0, 0, 2)), R = spc_mat4_rotate(spc_v3(1, 0, 0), 180.0);
    spc_mat4 S = spc_mat4_scale(spc_v3(0.1, 0.1, 1)), RS = spc_mat4_mul(&R, &S), L = spc_mat4_mul(&T, &RS);
    spc_shape_init_rectangle(light, &L, NULL, 0, 0, &err);
    light->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, light, 3, 50.0);
    tu_camera(sc, spc_v3(0, -3, 1), spc_v3(0, 0, 0.4), spc_v3(0, 0, 1), 50, 4, 4);
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

TEST(spheres_keep_apart)
{
    spc_scene *sc = balls(false, false), *ov = balls(true, false), *gg = balls(false, true);
    CHECK(sc && ov && gg);
    if (sc && ov && gg) {
        const spc_chain_casters *cs = spc_chain_casters_of(sc, false);
        CHECK(cs && cs->n == 2);
        spc_vec3 x = spc_v3(0.2, 0.6, 0.0);
        CHECK(spc_snee_spheres_keep_apart(sc, cs, x, false, 2));
        CHECK(spc_snee_spheres_keep_apart(sc, cs, x, false, 1));
        CHECK(!spc_snee_spheres_keep_apart(sc, cs, x, false, 3));
        CHECK(!spc_snee_spheres_keep_apart(sc, cs, x, true, 2));
        CHECK(!spc_snee_spheres_keep_apart(sc, cs, spc_v3(-0.42, 0.1, 0.36), false, 2)); /* x inside */
        CHECK(!spc_snee_spheres_keep_apart(ov, spc_chain_casters_of(ov, false), x, false, 2));
        const spc_chain_casters *g2 = spc_chain_casters_of(gg, false);
        CHECK(spc_snee_spheres_keep_apart(gg, g2, x, false, 3));
        CHECK(!spc_snee_spheres_keep_apart(gg, g2, x, false, 4));
        CHECK(!spc_snee_spheres_keep_apart(gg, g2, x, true, 2));
    }
    spc_scene_destroy(sc);
    spc_scene_destroy(ov);
    spc_scene_destroy(gg);
}

/* Randomized attempts from receivers on the floor toward light points: how many chains of at most
 * max_chain vertices they find, and how many of those visit both balls. */
static void attempts(const spc_scene *sc, int max_chain, int *found, int *across)
{
    spc_snee_params p;
    CHECK(spc_snee_parse("angular:noreflect", max_chain, &p));
    p.any_surface = true;
    spc_rng r;
    spc_rng_seed(&r, 7, 1);
    *found = *across = 0;
    for (int i = 0; i < 40; ++i) {
        spc_vec3 above = spc_v3(2.0 * spc_rng_next(&r) - 1.0, 2.0 * spc_rng_next(&r) - 1.0, 1.9);
        spc_hit x;
        spc_ray ray = {above, spc_v3(0, 0, -1), 0, INFINITY};
        if (!spc_scene_intersect(sc, &ray, &x) || x.shape_index != 0)
            continue;
        spc_snee_query q;
        spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 0, 1), max_chain);
        const spc_emitter *e;
        spc_vec2 uv;
        double p_y;
        if (!spc_snee_sample_light(sc, true, &r, &q, &e, &uv, &p_y))
            continue;
        for (int a = 0; a < 200; ++a) {
            spc_chain c;
            int it = 0;
            if (!spc_angular_solve_one(&q, &r, &c, &it))
                continue;
            ++*found;
            bool both = false;
            for (int v = 1; v < c.n; ++v)
                both = both || c.v[v].h.shape != c.v[0].h.shape;
            *across += both ? 1 : 0;
            if (!both && c.n <= 2)
                CHECK(spc_sphere_chain_covers(&c, false));
        }
    }
}

TEST(no_chain_visits_two_balls)
{
    spc_scene *sc = balls(false, false);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int found, across;
    attempts(sc, 2, &found, &across);
    printf("    chains of at most 2 vertices: %d found, %d through both balls\n", found, across);
    CHECK(found > 100 && across == 0);
    attempts(sc, 3, &found, &across);
    printf("    chains of at most 3 vertices: %d found, %d through both balls\n", found, across);
    CHECK(across > 0);
    spc_scene_destroy(sc);
}

TEST(arc_unseen_against_a_scan)
{
    spc_rng r;
    spc_rng_seed(&r, 11, 2);
    int unseen = 0, seen = 0;
    for (int i = 0; i < 20000; ++i) {
        double rho = 1.0 + 4.0 * spc_rng_next(&r), phi = 2.0 * SPC_PI * spc_rng_next(&r);
        double y1 = rho * cos(phi), y2 = rho * sin(phi);
        double t0 = -1.5 + 3.0 * spc_rng_next(&r), t1 = t0 + 0.4 * spc_rng_next(&r);
        if (t1 > 1.5)
            t1 = 1.5;
        double p0[2] = {cos(t0), sin(t0)}, p1[2] = {cos(t1), sin(t1)};
        double most = -INFINITY;
        for (int k = 0; k <= 400; ++k) {
            double t = t0 + (t1 - t0) * k / 400.0;
            most = fmax(most, y1 * cos(t) + y2 * sin(t));
        }
        bool u = spc_sphere_arc_unseen(y1, y2, p0, p1);
        if (u) {
            ++unseen;
            CHECK_MSG(most < 1.0, "y (%g %g), arc %g..%g: seen (%g) but reported unseen", y1, y2, t0, t1, most);
        } else {
            ++seen;
            CHECK_MSG(most > 1.0 - 1e-3, "y (%g %g), arc %g..%g: unseen (%g) but reported seen", y1, y2, t0, t1, most);
        }
    }
    printf("    %d arcs unseen, %d seen\n", unseen, seen);
    CHECK(unseen > 1000 && seen > 1000);
}

TEST(query_prob)
{
    spc_snee_params p;
    CHECK(spc_snee_parse("angular:later=0.25", 2, &p) && p.later_p == 0.25);
    CHECK(spc_snee_query_prob(&p) == 1.0); /* query_p not set by a caller */
    p.query_p = p.later_p;
    CHECK(spc_snee_query_prob(&p) == 0.25);
    p.guide = 1.0;
    CHECK(spc_snee_query_prob(&p) == 1.0);
    CHECK(!spc_snee_parse("angular:later=0", 2, &p) && !spc_snee_parse("angular:later=1.5", 2, &p));
    CHECK(spc_snee_parse("angular", 2, &p) && p.later_p == 1.0);
}

TEST(later_prob_from_the_casters_share)
{
    spc_scene *sc = balls(false, false);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, false);
    CHECK(cs && cs->n == 2);
    /* a point on the axis through the glass ball's centre and the mirror ball's, beyond the glass
     * ball: both bounds' cones from it in closed form (each ball's bounding box sphere, radius
     * sqrt(3) times the ball's) */
    spc_vec3 cg = spc_v3(-0.42, 0.1, 0.36), cm = spc_v3(0.45, -0.3, 0.33);
    spc_vec3 x = spc_v3(-6.0, 0.5, 2.0);
    double want = 0.0;
    const spc_vec3 c[2] = {cg, cm};
    const double r[2] = {0.36, 0.33};
    for (int i = 0; i < 2; ++i) {
        double R = sqrt(3.0) * r[i], d = spc_distance(x, c[i]);
        want += 0.5 * (1.0 - sqrt(1.0 - R * R / (d * d)));
    }
    double got = spc_snee_caster_share(sc, cs, x);
    CHECK_MSG(fabs(got - want) < 1e-9 * want, "share %g, closed form %g", got, want);
    CHECK(spc_snee_caster_share(sc, cs, spc_v3(-0.42, 0.1, 0.0)) == 1.0); /* under the glass ball */

    spc_snee_params p;
    CHECK(spc_snee_parse("angular:later=0.25", 2, &p));
    CHECK(spc_snee_later_prob(sc, &p, spc_v3(-0.42, 0.1, 0.0)) == 1.0);
    CHECK(spc_snee_later_prob(sc, &p, spc_v3(40.0, 0.0, 0.0)) == 0.25);
    /* along a line away from the balls: from 1 down to later_p, never rising, and in between
     * equal to the share over SPC_SNEE_QUERY_FULL_SHARE */
    double last = 2.0;
    int between = 0;
    for (int i = 0; i <= 2000; ++i) {
        spc_vec3 y = spc_v3(-0.42 - 0.005 * i, 0.1, 0.0);
        double q = spc_snee_later_prob(sc, &p, y), s = spc_snee_caster_share(sc, cs, y);
        CHECK_MSG(q >= 0.25 && q <= 1.0 && q <= last + 1e-12, "at %g: q %g after %g", y.x, q, last);
        if (q > 0.25 && q < 1.0) {
            ++between;
            CHECK_MSG(fabs(q - s / SPC_SNEE_QUERY_FULL_SHARE) < 1e-12, "at %g: q %g, share %g", y.x, q, s);
        }
        last = q;
    }
    CHECK(last == 0.25 && between > 5);
    CHECK(spc_snee_parse("angular", 2, &p) && spc_snee_later_prob(sc, &p, spc_v3(40.0, 0.0, 0.0)) == 1.0);
    /* the first receiver's: the same rule with first_p, independent of later_p */
    CHECK(spc_snee_first_prob(sc, &p, spc_v3(40.0, 0.0, 0.0)) == 1.0);
    CHECK(spc_snee_parse("angular:first=0.1,later=0.5", 2, &p) && p.first_p == 0.1 && p.later_p == 0.5);
    CHECK(spc_snee_first_prob(sc, &p, spc_v3(-0.42, 0.1, 0.0)) == 1.0);
    CHECK(spc_snee_first_prob(sc, &p, spc_v3(40.0, 0.0, 0.0)) == 0.1);
    CHECK(spc_snee_later_prob(sc, &p, spc_v3(40.0, 0.0, 0.0)) == 0.5);
    spc_vec3 y = spc_v3(-1.2, 0.1, 0.0);
    double s = spc_snee_caster_share(sc, cs, y) / SPC_SNEE_QUERY_FULL_SHARE;
    CHECK_MSG(s > 0.1 && s < 1.0 && fabs(spc_snee_first_prob(sc, &p, y) - s) < 1e-12, "share %g", s);
    CHECK(!spc_snee_parse("angular:first=0", 2, &p) && !spc_snee_parse("angular:first=1.5", 2, &p));
    /* nearp: the raised probability stops at near_p (under the ball and between), never below
     * first_p or later_p; without first or later below 1 it does nothing */
    CHECK(spc_snee_parse("angular:first=0.1,later=0.5,nearp=0.3", 2, &p) && p.near_p == 0.3);
    CHECK(spc_snee_first_prob(sc, &p, spc_v3(-0.42, 0.1, 0.0)) == 0.3);
    CHECK(spc_snee_later_prob(sc, &p, spc_v3(-0.42, 0.1, 0.0)) == 0.5);
    CHECK(spc_snee_first_prob(sc, &p, spc_v3(40.0, 0.0, 0.0)) == 0.1);
    CHECK_MSG(fabs(spc_snee_first_prob(sc, &p, y) - fmin(s, 0.3)) < 1e-12, "share %g", s);
    CHECK(spc_snee_parse("angular:nearp=0.3", 2, &p) && spc_snee_first_prob(sc, &p, spc_v3(-0.42, 0.1, 0.0)) == 1.0);
    CHECK(!spc_snee_parse("angular:nearp=0", 2, &p) && !spc_snee_parse("angular:nearp=2", 2, &p));
    spc_scene_destroy(sc);
}

TEST(tight_share_by_each_casters_sphere)
{
    spc_scene *sc = balls(false, false);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, false);
    CHECK(cs && cs->n == 2 && cs->bound_c && cs->bound_r);
    spc_snee_params p, q;
    CHECK(spc_snee_parse("angular:first=0.1,later=0.1,tightshare", 2, &p) && p.tight_share);
    CHECK(spc_snee_parse("angular:first=0.1,later=0.1", 2, &q) && !q.tight_share);
    /* beside the glass ball, within its box's sphere: both balls' own cones in closed form */
    spc_vec3 cg = spc_v3(-0.42, 0.1, 0.36), cm = spc_v3(0.45, -0.3, 0.33);
    const spc_vec3 c[2] = {cg, cm};
    const double r[2] = {0.36, 0.33};
    spc_vec3 x = spc_v3(-0.92, 0.1, 0.36);
    double want = 0.0;
    for (int i = 0; i < 2; ++i) {
        double d = spc_distance(x, c[i]);
        want += 0.5 * (1.0 - sqrt(1.0 - r[i] * r[i] / (d * d)));
    }
    double got = spc_snee_later_prob(sc, &p, x);
    CHECK_MSG(want > 0.1 && fabs(got - want) < 1e-9, "tight share %g, closed form %g", got, want);
    CHECK_MSG(spc_snee_later_prob(sc, &q, x) == 1.0, "box share %g", spc_snee_later_prob(sc, &q, x));
    /* 1.3 r from the glass ball's centre toward the light (the light's centre at (0, 0, 2)) and as far
     * behind it, in its shadow: the box's sphere holds both; with tightshare the query is certain
     * only in the shadow, where the ball focuses the light */
    spc_vec3 a = spc_normalize(spc_sub(cg, spc_v3(0, 0, 2)));
    spc_vec3 up = spc_madd(cg, a, -1.3 * 0.36), behind = spc_madd(cg, a, 1.3 * 0.36);
    CHECK(spc_snee_first_prob(sc, &q, up) == 1.0 && spc_snee_first_prob(sc, &q, behind) == 1.0);
    double t = spc_snee_first_prob(sc, &p, up);
    CHECK_MSG(t > 0.1 && t < 1.0, "tight first_prob toward the light %g", t);
    CHECK(spc_snee_first_prob(sc, &p, behind) == 1.0);
    CHECK(spc_snee_first_prob(sc, &p, spc_madd(cg, a, 6.0)) == 1.0);
    CHECK(spc_snee_first_prob(sc, &p, spc_madd(cg, spc_v3(0, 1, 0), 0.9 * 0.36)) == 1.0);
    CHECK(spc_snee_first_prob(sc, &p, spc_v3(40.0, 0.0, 0.0)) == 0.1);
    spc_scene_destroy(sc);

    /* a tessellated ball (the icosphere, radius 0.5 about (0, 0.9, 0)): its tight sphere holds
     * every vertex, within float rounding of the ball's radius, well inside its box's sqrt(3) */
    sc = tu_load("bench/check/medium_fog_ball.xml", 8);
    CHECK(sc != NULL);
    if (!sc)
        return;
    cs = spc_chain_casters_of(sc, false);
    CHECK(cs && cs->n == 1);
    if (cs && cs->n == 1) {
        const spc_shape *s = sc->shapes[cs->idx[0]];
        CHECK(s->type == SPC_SHAPE_MESH);
        double far = 0.0;
        for (size_t v = 0; v < s->mesh.nverts; ++v) {
            spc_vec3 w = spc_v3(s->mesh.p[3 * v], s->mesh.p[3 * v + 1], s->mesh.p[3 * v + 2]);
            far = fmax(far, spc_distance(w, cs->bound_c[0]));
        }
        CHECK_MSG(far <= cs->bound_r[0] && cs->bound_r[0] < 0.5 * (1.0 + 1e-5) && cs->bound_r[0] > 0.49,
                  "bound %g, farthest vertex %g", cs->bound_r[0], far);
        CHECK_MSG(spc_distance(cs->bound_c[0], spc_v3(0, 0.9, 0)) < 1e-6, "bound centre");
    }
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(spheres_keep_apart);
    RUN(no_chain_visits_two_balls);
    RUN(arc_unseen_against_a_scan);
    RUN(query_prob);
    RUN(later_prob_from_the_casters_share);
    RUN(tight_share_by_each_casters_sphere);
    return spc_test_finish();
}
