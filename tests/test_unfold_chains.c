/*
 * tests/test_unfold_chains.c: every chain through one sphere and one flat mirror
 * (manifold/unfold_chains.c).
 *
 * - In scenes (a glass ball beside an upright mirror, a mirror ball beside a tilted mirror): from
 *   floor points to light points, every chain spc_unfold_chains_all enumerates ends on its light
 *   point, is of the class spc_unfold_chain_covers takes, is distinct, and obeys the law of
 *   reflection at its mirror vertex (the outgoing direction the incoming one mirrored in the
 *   mirror's plane, the vertex on that plane); every distinct chain of the class that randomized
 *   angular attempts find (up to 3 vertices) is among them; both orders (the ball first, the mirror
 *   first) occur.
 * - The early-outs (a root whose unfolded segment misses the mirror's face is not polished; an order
 *   is not solved where the back of a one-sided mirror would face its mirror vertex, or where no
 *   ray through the face from x or the mirrored light point meets the sphere) reject only roots without
 *   a chain: on random small mirrors beside a glass or mirror ball, from floor points on both sides
 *   of the mirror, the enumeration with them returns the chains it returns without them, vertex for
 *   vertex and in the same order, while rejecting most of the roots.
 * - Specular NEE with the enumeration (the default, "unfold") against "nounfold" (those chains left
 *   to the randomized attempts and the longer chains' pass), on a small render of a glass ball
 *   beside a flat mirror: a per-pixel z-test and the image means.
 */
/* ctest-labels: unit stat */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "chain_compare.h"
#include "core/rng.h"
#include "harness.h"
#include "io/mitsuba_xml.h"
#include "manifold/angular.h"
#include "manifold/flat_chains.h"
#include "manifold/snee_plan.h"
#include "manifold/specular_nee.h"
#include "manifold/unfold_chains.h"
#include "render_util.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

/* An 8 x 8 diffuse floor (z = 0, shape 0), a one-sided mirror rectangle placed by M (shape 1) and a
 * sphere (c, r) of BSDF b (shape 2); the light added by finish. */
static spc_scene *ball_and_mirror(const spc_mat4 *M, spc_vec3 c, double r, bool glass)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *floor = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 F = spc_mat4_scale(spc_v3(4, 4, 1));
    spc_shape_init_rectangle(floor, &F, NULL, 0, 0, &err);
    floor->bsdf = tu_diffuse(sc, 0.8);
    spc_shape *m = spc_scene_new_shape(sc);
    spc_shape_init_rectangle(m, M, NULL, 0, 0, &err);
    m->bsdf = tu_mirror(sc);
    tu_sphere(sc, c, r, glass ? tu_glass(sc, 1.5) : tu_mirror(sc));
    return sc;
}

/* A sphere light (radius r, radiance 5) and the scene finalized; NULL on failure. */
static spc_scene *finish(spc_scene *sc, spc_vec3 c, double r)
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

static double miss(const spc_chain *c, spc_vec3 y)
{
    const spc_chain_vertex *v = &c->v[c->n - 1];
    spc_vec3 r = spc_sub(y, v->h.p);
    double t = spc_dot(r, v->d);
    return t < 0.0 ? spc_length(r) : spc_length(spc_sub(r, spc_scale(v->d, t)));
}

typedef struct tally {
    int points, enumerated, ball_first, mirror_first, random_distinct, random_missing;
    double worst_law, worst_plane;
} tally;

typedef struct keep_ctx {
    bool reflect;
    const spc_emitter *e;
    spc_vec2 uv;
} keep_ctx;

static bool keep_unfold(const spc_snee_query *q, const spc_chain *c, void *ctx)
{
    const keep_ctx *k = ctx;
    return spc_unfold_chain_covers(c, k->reflect) && spc_snee_chain_value(q, k->e, k->uv, c).r > 0.0;
}

/* The law of reflection at the mirror's vertex v (on the mirror shape, plane through its corner
 * p0 with unit normal n): the error of the outgoing direction against the incoming one mirrored,
 * and the vertex's distance from the plane. */
static void reflection_law(const spc_chain_vertex *v, spc_vec3 n, spc_vec3 p0, double *law, double *plane)
{
    spc_vec3 want = spc_sub(v->wi, spc_scale(n, 2.0 * spc_dot(v->wi, n)));
    *law = spc_distance(want, v->d);
    *plane = fabs(spc_dot(spc_sub(v->h.p, p0), n));
}

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
    spc_chain all[32];
    int it = 0;
    int n = spc_unfold_chains_all(&q, all, 32, &it);
    t->enumerated += n;
    spc_vec3 nm[SPC_FLAT_MAX_FACES];
    double dm[SPC_FLAT_MAX_FACES];
    int np = spc_flat_shape_planes(sc->shapes[1], nm, dm, SPC_FLAT_MAX_FACES);
    CHECK(np == 1);
    for (int i = 0; i < n; ++i) {
        const spc_chain *c = &all[i];
        CHECK_MSG(miss(c, q.y) < 1e-6, "chain %d of %d vertices misses y by %g", i, c->n, miss(c, q.y));
        CHECK(spc_unfold_chain_covers(c, p->reflect));
        for (int j = 0; j < i; ++j)
            CHECK(!spc_snee_same_solution(c, &all[j], sc->radius));
        int im = c->v[0].h.shape == sc->shapes[1] ? 0 : c->n - 1;
        CHECK(c->v[im].h.shape == sc->shapes[1] && c->v[im].event == SPC_CHAIN_REFLECT);
        if (im == 0)
            ++t->mirror_first;
        else
            ++t->ball_first;
        double law, plane;
        reflection_law(&c->v[im], nm[0], spc_scale(nm[0], dm[0]), &law, &plane);
        t->worst_law = spc_max(t->worst_law, law);
        t->worst_plane = spc_max(t->worst_plane, plane);
    }
    keep_ctx kc = {p->reflect, e, uv};
    chain_compare_random(&q, &r, 1500, all, n, sc->radius, keep_unfold, &kc, "ball and mirror", &t->random_distinct,
                         &t->random_missing);
}

static void run_scene(spc_scene *sc, const char *label, int points, int min_distinct, double cx, double cy, double h)
{
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(spc_unfold_mirror_shape(sc->shapes[1]));
    CHECK(!spc_unfold_mirror_shape(sc->shapes[2]));
    spc_rng_seed(&rng, 41, 7);
    spc_snee_params p;
    spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 3);
    p.any_surface = true;
    tally t;
    memset(&t, 0, sizeof t);
    for (int i = 0; i < points; ++i)
        compare_at(sc, &p, spc_v3(cx + h * (2.0 * rnd() - 1.0), cy + h * (2.0 * rnd() - 1.0), 5.0), 100 + (uint64_t)i,
                   &t);
    printf("  %s: %d points, %d chains enumerated (ball first %d, mirror first %d), %d distinct randomized, %d "
           "missing; law of reflection to %.3g, the mirror's plane to %.3g\n",
           label, t.points, t.enumerated, t.ball_first, t.mirror_first, t.random_distinct, t.random_missing,
           t.worst_law, t.worst_plane);
    CHECK(t.points >= points / 2);
    CHECK(t.ball_first > 0 && t.mirror_first > 0);
    CHECK(t.random_distinct >= min_distinct);
    CHECK(t.random_missing == 0);
    CHECK(t.worst_law < 1e-9 && t.worst_plane < 1e-9);
    spc_scene_destroy(sc);
}

/* A glass ball beside an upright one-sided mirror facing it: T T then R, R then T T, and the ball's
 * outside reflection with the mirror's (reflections off glass are chain events by default). */
TEST(glass_ball_and_mirror_chains)
{
    spc_mat4 M = tu_place(spc_v3(1.0, 1.5, 1.0), spc_v3(0, 1, 0), -90.0, spc_v3(1.2, 0.0, 1.0));
    spc_scene *sc = ball_and_mirror(&M, spc_v3(0.4, 0.0, 0.5), 0.4, true);
    sc = finish(sc, spc_v3(-0.4, 0.3, 2.4), 0.2);
    run_scene(sc, "glass ball beside an upright mirror", 40, 20, 0.3, 0.0, 1.2);
}

/* A mirror ball beside a mirror tilted 10 degrees from upright, leaning over it: R off the ball then the mirror, and
 * the mirror then the ball. */
TEST(mirror_ball_and_tilted_mirror_chains)
{
    spc_mat4 M = tu_place(spc_v3(1.0, 1.5, 1.0), spc_v3(0, 1, 0), -100.0, spc_v3(1.1, 0.0, 1.0));
    spc_scene *sc = ball_and_mirror(&M, spc_v3(0.2, -0.2, 0.6), 0.35, false);
    sc = finish(sc, spc_v3(-0.5, 0.4, 2.2), 0.2);
    run_scene(sc, "mirror ball beside a tilted mirror", 40, 10, 0.2, 0.0, 1.2);
}

/* Random small one-sided mirrors beside a ball (glass or mirror, by scene), floor points on both
 * sides of them, light points on a sphere light: spc_unfold_chains_cull with the early-outs against
 * without, chain for chain. */
TEST(early_outs_reject_no_chain)
{
    spc_rng_seed(&rng, 43, 5);
    spc_snee_params p;
    spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 3);
    p.any_surface = true;
    spc_unfold_tally with, without;
    memset(&with, 0, sizeof with);
    memset(&without, 0, sizeof without);
    long queries = 0, differ = 0;
    for (int scene = 0; scene < 12; ++scene) {
        double w = 0.25 + 0.6 * rnd(), h = 0.25 + 0.6 * rnd();
        spc_mat4 M = tu_place(spc_v3(w, h, 1.0), spc_v3(0, 1, 0), -70.0 - 40.0 * rnd(),
                              spc_v3(0.9 + 0.5 * rnd(), 1.2 * rnd() - 0.6, 0.3 + 0.6 * rnd()));
        spc_scene *sc = ball_and_mirror(&M, spc_v3(0.3, 0.0, 0.5), 0.4, scene % 2 == 0);
        sc = finish(sc, spc_v3(-0.4 + 0.8 * rnd(), 1.0 * rnd() - 0.5, 2.0 + 0.6 * rnd()), 0.2);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        for (int i = 0; i < 60; ++i) {
            spc_hit x;
            spc_snee_query q;
            spc_vec3 above = spc_v3(3.0 * rnd() - 1.2, 3.0 * rnd() - 1.5, 5.0);
            spc_rng r;
            spc_rng_seed(&r, 5, 1000 * (uint64_t)scene + (uint64_t)i);
            if (!chain_compare_floor_query(sc, &p, above, p.max_chain, &r, &x, &q, NULL, NULL))
                continue;
            ++queries;
            spc_chain a[32], b[32];
            int ia = 0, ib = 0;
            int na = spc_unfold_chains_cull(&q, a, 32, &ia, true, &with);
            int nb = spc_unfold_chains_cull(&q, b, 32, &ib, false, &without);
            bool same = na == nb;
            for (int c = 0; same && c < na; ++c) {
                same = a[c].n == b[c].n;
                for (int v = 0; same && v < a[c].n; ++v)
                    same = a[c].v[v].h.shape == b[c].v[v].h.shape && a[c].v[v].h.p.x == b[c].v[v].h.p.x &&
                           a[c].v[v].h.p.y == b[c].v[v].h.p.y && a[c].v[v].h.p.z == b[c].v[v].h.p.z;
            }
            differ += !same;
        }
        spc_scene_destroy(sc);
    }
    printf("  %ld queries: %ld differ; without the early-outs %ld roots polished, %ld chains; with them %ld "
           "orders skipped unsolved, %ld roots rejected unpolished, %ld polished, %ld chains\n",
           queries, differ, without.roots, without.chains, with.orders_culled, with.roots_culled,
           with.roots - with.roots_culled, with.chains);
    CHECK(queries >= 400);
    CHECK(differ == 0);
    CHECK(with.chains == without.chains && without.chains >= 100);
    /* the early-outs act: most roots on small mirrors miss the face, and both kinds reject some */
    CHECK((with.roots - with.roots_culled) * 2 < without.roots && with.orders_culled > 0 && with.roots_culled > 0);
}

/* The plan's setting on a bench/check scene (a ball beside a flat mirror) against the same setting
 * with nounfold, at 16 x 16 and spp samples a side: per-pixel z-test (Sidak) and image means. */
static void agrees_without_unfold(const char *file, int spp, const char *label)
{
    const spc_define d[2] = {{"res", "16"}, {"spp", "1"}};
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", spc_test_source_dir(), file);
    spc_scene *sc = NULL;
    spc_error err;
    if (spc_mitsuba_load(path, d, 2, &sc, &err) != SPC_OK || spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  %s: %s\n", path, err.msg);
        CHECK(false);
        spc_scene_destroy(sc);
        return;
    }
    spc_snee_plan plan;
    spc_snee_plan_make(sc, "path", NULL, &plan);
    CHECK(plan.on);
    char old[sizeof plan.setting + 16];
    snprintf(old, sizeof old, "%s,nounfold", plan.setting);
    spc_film *def = tu_render_nee(sc, "path", plan.setting, spp, 2, 11, NULL);
    spc_film *prev = tu_render_nee(sc, "path", old, spp, 2, 12, NULL);
    CHECK(def && prev);
    if (def && prev) {
        spc_diff_result r;
        memset(&r, 0, sizeof r);
        CHECK(tu_image_agrees(def, prev, 0.99, label, &r));
        double md, sd, mp, sp;
        tu_image_mean(def, 1, &md, &sd);
        tu_image_mean(prev, 1, &mp, &sp);
        printf("  %s (%s): z-test pass %.4f of %d pixels; means %.5f +- %.5f vs %.5f +- %.5f (nounfold); summed "
               "variance %.3g vs %.3g\n",
               label, plan.setting, r.ztest_pass_fraction, def->width * def->height, md, sd, mp, sp, tu_var_sum(def),
               tu_var_sum(prev));
        CHECK(fabs(md - mp) < 4.0 * sqrt(sd * sd + sp * sp));
    }
    spc_film_destroy(def);
    spc_film_destroy(prev);
    spc_scene_destroy(sc);
}

TEST(ball_mirror_floor_agrees_without_unfold)
{
    agrees_without_unfold("bench/check/ball_mirror_floor.xml", 1024, "ball_mirror_floor");
}

TEST(flat_mirror_ball_focus_agrees_without_unfold)
{
    agrees_without_unfold("bench/check/flat_mirror_ball_focus.xml", 1024, "flat_mirror_ball_focus");
}

int main(void)
{
    RUN(glass_ball_and_mirror_chains);
    RUN(mirror_ball_and_tilted_mirror_chains);
    RUN(early_outs_reject_no_chain);
    RUN(ball_mirror_floor_agrees_without_unfold);
    RUN(flat_mirror_ball_focus_agrees_without_unfold);
    return spc_test_finish();
}
