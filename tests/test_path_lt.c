/*
 * tests/test_path_lt.c: the path tracer's light-traced caustics (integrator/path_lt.h, specular NEE's
 * "ltcaus"), on bench/check/point_light_ball.xml (a point light above a glass ball on a floor) and,
 * for area lights, on the same ball under a small sphere or square light.
 *
 * - Every join the light subpaths make (x2 seen by the camera directly, through the glass ball, or
 *   from the first hit x1 of a diffuse bounce) is a path specular NEE counts at x2 (the sphere
 *   enumeration there, spc_sphere_chains_all, finds the light subpath's chain toward the point
 *   light: the nearest of its chains of that length, within 1e-6 in 1 - cos of the first
 *   direction), and the two weights of the path, specular NEE's 1 / (1 + r^2) with r from the
 *   enumerated chain and light tracing's r^2 / (1 + r^2) with r from its own chain, sum to one
 *   within 1e-5 (6e-7 measured over 8 seeds: light tracing's chain is solved through the light
 *   from the rounded x2, as specular NEE's is); or it is a path specular NEE does not find (two
 *   chains meeting at the caustic's fold, or x2 past it), and light tracing's weight is 1 there.
 *   Over 8 seeds of 20000 subpaths each kind of join occurs and some joins are not enumerated.
 * - Near the caustic's fold light tracing takes the larger share (r > 1 on some joins) and far
 *   from it specular NEE does (r < 1 on some).
 * - The joins through the ball run on a share of the subpaths, counted over the share, with the
 *   share in r on both sides; those by chains longer than max_chain (internal reflections) on a
 *   share of their own.
 * - Joins through two diffuse bounces (x2 the path's third receiver) occur, their weights summing
 *   to one as the others', and the path tracer's side follows such a path's middle vertex.
 * - A render with ltcaus agrees with one without (the same estimator's two splits) by the per-pixel
 *   z-test and the image mean.
 * - The plan (snee_plan.h, SPC_SNEE_PLAN_POINT_LIGHTS, SPC_SNEE_PLAN_AREA_LIGHTS) runs it for path
 *   where a glass sphere is a caster and every light is a point or spot light or a small area light,
 *   without the caustic guide at receivers, and nowhere else.
 * - A spot light (bench/check/spot_ball_edge.xml: the ball across the beam's edge): its joins weigh
 *   as a point light's, its intensity toward the ball is Mitsuba 3's falloff, and a render with
 *   ltcaus agrees with one without and with bdpt.
 * - Area lights (a small sphere light, bench/check/ball_small_light.xml, and a small square one,
 *   bench/check/ball_rect_light.xml): every kind of join occurs, and on each the three weights of
 *   its path, specular NEE's at x2 (its enumerated chain toward the light point, its value with MIS
 *   over its value without), BSDF sampling's own at x2 and light tracing's, sum to one within 1e-5
 *   (9e-7 measured over 3 seeds each; the last with the subpaths on half of the samples, ltshare).
 *   Their joins go through no middle vertex and no camera chain longer than max_chain, and the path
 *   tracer's side puts light tracing into BSDF sampling's weight at the second receiver only.
 *   A render with ltcaus agrees with one without.
 * - The demo with its caustic guide at receivers and light tracing: the three weights of each join
 *   enumerated at x2 sum to one within 1e-5 with the guided mixture's densities at x1 and x2.
 * - A point light over two glass slabs (bench/check/two_slabs_point_light.xml): light tracing's
 *   chains through the flat faces of 1-6 vertices; each one specular NEE's flat enumeration makes
 *   (on every call, or on a share of them: flat34) it finds at x2, and its share with psi in r and
 *   light tracing's weight sum to one; the lengths it never makes are light tracing's alone. A
 *   render with ltcaus agrees with one without.
 * - Area lights inside a mirror ring (scenes/caustic_mirror_ring.xml): the floor's joins (seen
 *   directly) carry chains of 1-2 reflections off the wall; on each the three weights sum to one within
 *   1e-5, and a render with ltcaus agrees with one without.
 * - The same with ltslab: joins of the floor seen through a slab (chains of 1-2 flat faces toward the
 *   pinhole) occur, the path tracer's camera chain retraced from x2 passes the pinhole, and the two
 *   weights of each shared path sum to one; a render with it and flat34=0.3 agrees with one with
 *   it and flat34=1.
 * - A spot light's light guided along a glass slab (bench/check/spot_slab_guide.xml): the light
 *   guides' joins from the spot carry chains of 7-8 vertices at weight 1 (with the long pass up to 8
 *   vertices too), and with them the floor agrees with bdpt (with the long pass up to 8 too) where
 *   without them the pixel the guided light lands in reads low.
 */
/* ctest-labels: stat */
/* ctest-timeout: 600 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "harness.h"
#include "integrator/path_lt.h"
#include "integrator/path_snee.h"
#include "manifold/caustic_guide.h"
#include "manifold/cylinder_chains.h"
#include "manifold/flat_chains.h"
#include "manifold/plane_chains.h"
#include "manifold/snee_options.h"
#include "manifold/snee_cost.h"
#include "manifold/snee_plan.h"
#include "manifold/specular_nee.h"
#include "manifold/sphere_chains.h"
#include "path_lt_util.h"
#include "render_util.h"

#define SCENE "bench/check/point_light_ball.xml"
#define SETTING "angular:camera=0.098,first=0.1,later=0.1,ltcaus"

typedef struct tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    int joins, missing, lt_only, above, below;
    int kinds[4]; /* x2 seen directly, through the sphere, through a diffuse bounce, through two */
    double worst_gap;
} tally;

static void check_join(void *user, const spc_path_lt_join *j)
{
    tally *t = user;
    const spc_scene *sc = t->ctx->scene;
    ++t->joins;
    spc_snee_query q;
    spc_snee_query_init(&q, sc, t->p, j->x2, j->w2, t->p->max_chain);
    q.y = j->e->position;
    q.ny = spc_v3(0, 0, 0);
    q.light_size = 0.0;
    spc_chain all[16];
    int n = spc_sphere_chains_all(&q, all, 16, NULL);
    /* the enumerated chain nearest the light subpath's (two meet at the fold) */
    const spc_chain *match = NULL;
    double best = 1.0 - 1e-6;
    for (int i = 0; i < n; ++i)
        if (all[i].n == j->c->n && spc_dot(all[i].d0, j->c->d0) > best) {
            best = spc_dot(all[i].d0, j->c->d0);
            match = &all[i];
        }
    if (!match) {
        /* specular NEE does not make this path: light tracing's weight must be 1 */
        double g = fabs(spc_path_lt_weight(j->r) - 1.0);
        if (g > t->worst_gap)
            t->worst_gap = g;
        t->lt_only += g == 0.0;
        if (g > 0.0 && t->missing < 6) {
            printf("    missing: k %d ev %d %d x2 (%.4f %.4f %.4f) d0 (%.4f %.4f %.4f) n %d r %.3g", j->c->n,
                   j->c->v[0].event, j->c->n > 1 ? j->c->v[1].event : -1, j->x2->p.x, j->x2->p.y, j->x2->p.z,
                   j->c->d0.x, j->c->d0.y, j->c->d0.z, n, j->r);
            for (int i = 0; i < n; ++i)
                printf(" [%d: %.5f]", all[i].n, spc_dot(all[i].d0, j->c->d0));
            printf("\n");
        }
        ++t->missing;
        return;
    }
    double r = j->x1 ? spc_path_lt_ratio_via(t->ctx, t->p, j->x1, j->w1, j->mid, j->nmid, j->x2, j->w2, match, j->e)
                     : spc_path_lt_ratio_first(t->ctx, t->p, j->x2, j->cc, match, j->e);
    ++t->kinds[j->x1 ? (j->nmid > 0 ? 3 : 2) : j->cc ? 1 : 0];
    /* the two sides' weights of the path: specular NEE's from its chain, light tracing's from its own */
    double gap = fabs(1.0 / (1.0 + r * r) + spc_path_lt_weight(j->r) - 1.0);
    if (gap > t->worst_gap)
        t->worst_gap = gap;
    t->above += j->r > 1.0;
    t->below += j->r < 1.0;
}

/* The test scene at 16x16 with its camera prepared and the setting parsed into p; NULL (after a
 * failed CHECK) if it does not load. */
static spc_scene *lt_scene(spc_camera_state *cam, spc_snee_params *p)
{
    spc_scene *sc = tu_load(SCENE, 16);
    CHECK(sc != NULL);
    if (!sc)
        return NULL;
    CHECK(spc_camera_prepare(cam, &sc->camera, sc->film.width, sc->film.height));
    CHECK(spc_snee_parse(SETTING, 2, p));
    return sc;
}

/* Loads the scene at 16x16 with its camera prepared and the specular NEE setting parsed (NULL and
 * a failed check where any of it fails). */
static spc_scene *lt_load(const char *scene, const char *setting, spc_camera_state *cam, spc_snee_params *p)
{
    spc_scene *sc = tu_load(scene, 16);
    CHECK(sc != NULL);
    if (!sc)
        return NULL;
    CHECK(spc_camera_prepare(cam, &sc->camera, sc->film.width, sc->film.height));
    CHECK(spc_snee_parse(setting, 2, p));
    return sc;
}

TEST(joins_are_specular_nee_chains_with_the_same_ratio)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_scene(&cam, &p);
    if (!sc)
        return;
    /* every subpath joined through the sphere, the stream this tolerance was measured on (the
     * share's factor in r: through_sphere_on_a_share) */
    p.lt_through = 1.0;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_enabled(&ctx, &p));
    tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    /* several seeds: the joins specular NEE does not enumerate are rare (0-6 of 20000 subpaths) */
    int total_missing = 0, total_two = 0;
    for (int seed = 17; seed < 25; ++seed) {
        tally t;
        memset(&t, 0, sizeof t);
        t.ctx = &ctx;
        t.p = &p;
        spc_rng rng;
        spc_rng_seed(&rng, (uint64_t)seed, 3);
        for (int i = 0; i < 20000; ++i)
            spc_path_lt_joins(&ctx, &p, &rng, check_join, &t);
        printf("  seed %d: %d joins, %d not enumerated (%d of them weighed 1 by light tracing), r > 1 on %d, r < 1 on "
               "%d, largest gap of the weights' sum from 1 %.3g; x2 seen directly %d, through the sphere %d, through "
               "a diffuse bounce %d, through two %d\n",
               seed, t.joins, t.missing, t.lt_only, t.above, t.below, t.worst_gap, t.kinds[0], t.kinds[1], t.kinds[2],
               t.kinds[3]);
        CHECK(t.joins > 100 && t.kinds[0] > 10 && t.kinds[1] > 10 && t.kinds[2] > 10);
        CHECK_MSG(t.lt_only == t.missing, "seed %d: %d joins specular NEE does not enumerate weigh less than 1", seed,
                  t.missing - t.lt_only);
        CHECK_MSG(t.worst_gap < 1e-5, "seed %d: the two weights sum to 1 +- %.3g", seed, t.worst_gap);
        CHECK(t.above > 0 && t.below > 0);
        total_missing += t.missing;
        total_two += t.kinds[3];
    }
    /* x2 the path's third receiver: after two diffuse bounces (3 to 13 joins a seed) */
    CHECK_MSG(total_two > 20, "%d joins through two diffuse bounces", total_two);
    /* the case the weight 1 is for occurs */
    CHECK(total_missing > 0);
    spc_scene_destroy(sc);
}

/* path on sc with the setting `with` (seed) and `without` (seed + 1), spp each at 2 threads: the two
 * images agree by the per-pixel z-test on 0.99 of the pixels. */
static void settings_agree(spc_scene *sc, const char *with, const char *without, int spp, uint64_t seed,
                           const char *label)
{
    spc_film *a = tu_render_nee(sc, "path", with, spp, 2, seed, NULL);
    spc_film *b = tu_render_nee(sc, "path", without, spp, 2, seed + 1, NULL);
    CHECK(a && b);
    if (a && b) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(a, b, 0.99, label, &d));
        printf("    z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction, d.ztest_pixels,
               d.mean_a[0], d.mean_b[0]);
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
}

/* Loads the scene at 16x16 and compares the two settings' renders (settings_agree). */
static void scene_settings_agree(const char *scene, const char *with, const char *without, int spp, uint64_t seed,
                                 const char *label)
{
    spc_scene *sc = tu_load(scene, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    settings_agree(sc, with, without, spp, seed, label);
    spc_scene_destroy(sc);
}

TEST(render_agrees_without_it)
{
    scene_settings_agree(SCENE, SETTING, "angular:camera=0.098,first=0.1,later=0.1", 1024, 41, "ltcaus vs without");
}

typedef struct share_tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *whole; /* the same parameters with every subpath joined through the sphere */
    double share;
    bool long_chains; /* count the chains longer than max_chain (their own share), else the others */
    int through;
    double sum, sum2, worst_r; /* the through-sphere joins' contributions C (mean of r, g, b); r's gap */
} share_tally;

static void count_through(void *user, const spc_path_lt_join *j)
{
    share_tally *t = user;
    if (j->x1 || !j->cc || (j->cc->n > t->whole->max_chain) != t->long_chains)
        return;
    ++t->through;
    double v = spc_rgb_avg(j->C);
    t->sum += v;
    t->sum2 += v * v;
    /* light tracing's density of the path, and so r, carries the share (where specular NEE makes
     * the path: r is infinite, light tracing's alone, where it does not) */
    if (isinf(j->r))
        return;
    double r1 = spc_path_lt_ratio_first(t->ctx, t->whole, j->x2, j->cc, j->c, j->e);
    double gap = fabs(j->r - t->share * r1) / (t->share * r1);
    if (gap > t->worst_r)
        t->worst_r = gap;
}

/* 20000 light subpaths' joins through the sphere tallied twice (streams seed and seed + 1): t[0] with
 * every subpath's share 1, t[1] with the share `share` of the joins by chains up to max_chain
 * (lt_through) or, with long_chains, of those by longer chains (lt_long). */
static void tally_shares(spc_scene *sc, spc_camera_state *cam, const spc_snee_params *whole, bool long_chains,
                         double share, uint64_t seed, share_tally t[2])
{
    spc_render_ctx ctx = lt_ctx(sc, cam, whole);
    for (int s = 0; s < 2; ++s) {
        spc_snee_params p = *whole;
        double sh = s == 0 ? 1.0 : share;
        if (long_chains)
            p.lt_long = sh;
        else
            p.lt_through = sh;
        ctx.snee = p;
        memset(&t[s], 0, sizeof t[s]);
        t[s].ctx = &ctx;
        t[s].whole = whole;
        t[s].share = sh;
        t[s].long_chains = long_chains;
        spc_rng rng;
        spc_rng_seed(&rng, seed + (uint64_t)s, 5);
        for (int i = 0; i < 20000; ++i)
            spc_path_lt_joins(&ctx, &p, &rng, count_through, &t[s]);
        t[s].ctx = NULL; /* ctx is this function's */
    }
}

/* Joins through the sphere (the costly enumeration toward the pinhole) on a share of the light
 * subpaths: about that share of them occur, each counted over the share (the sum of their
 * contributions agrees with every subpath's), and r, on both sides from spc_path_lt_ratio_first,
 * is the share times r of every subpath's joins. */
TEST(through_sphere_on_a_share)
{
    spc_camera_state cam;
    spc_snee_params whole;
    spc_scene *sc = lt_scene(&cam, &whole);
    if (!sc)
        return;
    whole.lt_through = 1.0;
    share_tally t[2];
    tally_shares(sc, &cam, &whole, false, 0.5, 23, t);
    /* the sums' standard errors over the n subpaths (joins are few per subpath: as if independent) */
    double se0 = sqrt(t[0].sum2), se1 = sqrt(t[1].sum2);
    double z = (t[1].sum - t[0].sum) / sqrt(se0 * se0 + se1 * se1 + 1e-300);
    printf("    through the sphere: %d joins with every subpath, %d with a share 0.5; sums %.4g vs %.4g (z %.2f); "
           "r's largest relative gap from the share's %.2g\n",
           t[0].through, t[1].through, t[0].sum, t[1].sum, z, t[1].worst_r);
    CHECK(t[0].through > 100);
    double frac = (double)t[1].through / (double)(t[0].through > 0 ? t[0].through : 1);
    CHECK_MSG(frac > 0.4 && frac < 0.6, "a share 0.5 makes %.3f of the joins", frac);
    CHECK_MSG(fabs(z) < 4.0, "the contributions' sums differ by z %.2f", z);
    CHECK_MSG(t[0].worst_r < 1e-12 && t[1].worst_r < 1e-12, "r is not the share's: %.3g", t[1].worst_r);
    spc_scene_destroy(sc);
}

/* The joins by chains through the sphere longer than max_chain (the camera's paths with internal
 * reflections in the ball) on a share of their own (lt_long): about that share of them occur, each
 * counted over the share, and r is the share times r with every subpath's. */
TEST(long_camera_chains_on_their_own_share)
{
    spc_camera_state cam;
    spc_snee_params whole;
    spc_scene *sc = lt_scene(&cam, &whole);
    if (!sc)
        return;
    whole.lt_long = 1.0;
    share_tally t[2];
    tally_shares(sc, &cam, &whole, true, 0.25, 29, t);
    double z = (t[1].sum - t[0].sum) / sqrt(t[0].sum2 + t[1].sum2 + 1e-300);
    printf("    longer chains through the sphere: %d joins with every subpath, %d with a share 0.25; sums %.4g vs "
           "%.4g (z %.2f); r's largest relative gap from the share's %.2g\n",
           t[0].through, t[1].through, t[0].sum, t[1].sum, z, t[1].worst_r);
    CHECK(t[0].through > 100);
    double frac = (double)t[1].through / (double)(t[0].through > 0 ? t[0].through : 1);
    CHECK_MSG(frac > 0.15 && frac < 0.35, "a share 0.25 makes %.3f of the joins", frac);
    CHECK_MSG(fabs(z) < 4.0, "the contributions' sums differ by z %.2f", z);
    CHECK_MSG(t[0].worst_r < 1e-12 && t[1].worst_r < 1e-12, "r is not the share's: %.3g", t[1].worst_r);
    spc_scene_destroy(sc);
}

/* The path tracer's side follows the vertices light tracing joins through: the camera ray's first
 * hit x1, then one more non-delta scattering (with delta scatterings around it); a second one ends
 * it, as does a first hit after a delta scattering. */
TEST(path_side_follows_a_middle_vertex)
{
    spc_path_snee s;
    memset(&s, 0, sizeof s);
    s.lt_enabled = true;
    spc_hit h;
    memset(&h, 0, sizeof h);
    h.p = spc_v3(1, 0, 0);
    spc_vec3 wo = spc_v3(0, 1, 0), wi = spc_v3(0, 0, 1);
    spc_path_snee_scattered(&s, &h, wo, wi, SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK(s.lt_on && s.lt_nmid == 0 && s.receivers == 1);
    spc_path_snee_scattered(&s, &h, wo, wi, SPC_LOBE_DELTA_TRANSMISSION);
    CHECK(s.lt_on && s.lt_m == 1);
    h.p = spc_v3(2, 0, 0);
    spc_path_snee_scattered(&s, &h, wo, wi, SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK_MSG(s.lt_on && s.lt_nmid == 1 && s.lt_m == 0 && s.receivers == 1 + s.lt_nmid,
              "after the second non-delta scattering: on %d, %d middle vertices", s.lt_on, s.lt_nmid);
    CHECK(s.lt_mid[0].h.p.x == 2.0 && s.lt_mid[0].a.y == 1.0 && s.lt_mid[0].b.z == 1.0);
    spc_path_snee_scattered(&s, &h, wo, wi, SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK(!s.lt_on);
    spc_path_snee t;
    memset(&t, 0, sizeof t);
    t.lt_enabled = true;
    spc_path_snee_scattered(&t, &h, wo, wi, SPC_LOBE_DELTA_REFLECTION);
    spc_path_snee_scattered(&t, &h, wo, wi, SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK(!t.lt_on);
}

/* The plan runs it for path where a glass sphere is a caster and every light is a point light or a
 * small area light (a sky besides), without the caustic guide at receivers: on the point-light
 * ball, its small sphere-light twin, the ball under a small sphere light and scenes/
 * caustic_glass_sphere.xml (a sky besides); not with a point light and a sky (scenes/
 * dielectrics.xml), nor on the demo (its plan guides caustics at receivers), nor for volpath. */
TEST(plan_with_point_lights_and_small_area_lights)
{
    const char *files[] = {SCENE,
                           "bench/check/point_light_ball_sphere.xml",
                           "bench/check/ball_small_light.xml",
                           "scenes/caustic_glass_sphere.xml",
                           "scenes/dielectrics.xml",
                           "scenes/demo.xml",
                           "bench/check/spot_ball.xml"};
    const bool want[] = {true, true, true, true, false, false, true};
    for (int i = 0; i < 7; ++i) {
        spc_scene *sc = tu_load(files[i], 8);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_snee_plan plan;
        spc_snee_plan_make(sc, "path", NULL, &plan);
        bool lt = strstr(plan.setting, "ltcaus") != NULL;
        CHECK_MSG(plan.on && lt == want[i], "%s: %s", files[i], plan.setting);
        spc_snee_plan_make(sc, "volpath", NULL, &plan);
        CHECK_MSG(!strstr(plan.setting, "ltcaus"), "%s, volpath: %s", files[i], plan.setting);
        spc_scene_destroy(sc);
    }
}

/* ---- area lights ---- */

#define AREA_SETTING "angular:camera=0.098,first=0.1,later=0.1,ltcaus"

typedef struct area_tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    bool mesh;     /* a tessellated ball: specular NEE's chain at x2 is the join's own (no enumeration) */
    bool flat;     /* slabs: specular NEE's chains at x2 by the flat enumeration, of the join's length */
    bool cylinder; /* a mirror cylinder: specular NEE's chains at x2 by the cylinder's enumeration */
    bool plane;    /* a normal-mapped plane: specular NEE's chains at x2 by the plane's enumeration */
    int exact;     /* joins whose three weights sum to one within 1e-5 */
    int joins, matched, kinds[3];
    /* joins toward the pinhole through a camera chain of flat faces (ltslab), and those of them whose
     * light chain the enumeration at x2 finds (their three weights checked) */
    int through_flat, through_flat_matched;
    /* slabs: joins by chains through flat faces that the enumeration leaves to BSDF sampling (a
     * partial reflection inside the glass, or longer than it goes), and the largest gap of BSDF
     * sampling's and light tracing's weights' sum from 1 on them */
    int unlisted, unlisted_partial, unlisted_long;
    double unlisted_gap;
    int by_length[SPC_CHAIN_MAX_VERTICES + 1]; /* joins by the light chain's vertices */
    /* joins through a camera chain longer than max_chain: all, enumerated at x2, and those on which
     * light tracing takes the larger share */
    int longer, longer_matched, longer_above;
    double worst_gap, lt_sum, above, below;
    /* with the caustic guide at receivers: joins whose x2 the guide runs at (a > 0), and joins through
     * a diffuse bounce whose ratio r the guided mixture's densities moved (against the BSDF's) */
    int guided, guided_r;
} area_tally;

/* The three weights of an area light's join: specular NEE's at x2 toward y (its enumerated chain,
 * the value with MIS over the value without), BSDF sampling's own at x2 and light tracing's. */
static void check_area_join(void *user, const spc_path_lt_join *j)
{
    area_tally *t = user;
    const spc_scene *sc = t->ctx->scene;
    ++t->joins;
    ++t->kinds[j->x1 ? 2 : j->cc ? 1 : 0];
    t->through_flat += !j->x1 && j->cc && spc_flat_chain_covers(j->cc, t->p->reflect);
    /* (on the tessellated ball a randomized attempt's chain has a sampled weight, which may pass 1;
     * elsewhere the weight, a quotient of products, may round a few ulps above 1) */
    CHECK_MSG(j->e->type == SPC_EMITTER_AREA && j->w > 0.0 && (t->mesh || j->w <= 1.0 + 1e-15),
              "light tracing's weight %.17g", j->w);
    int segments = j->x1 ? 2 : j->cc ? j->cc->n + 1 : 1;
    int kmax = spc_path_lt_budget(t->ctx, t->p, j->x2, segments, j->x1 ? 1 : 0);
    int kflat = spc_path_lt_flat_budget(t->ctx, t->p, j->x2, segments, j->x1 ? 1 : 0);
    CHECK_MSG(j->c->n <= spc_path_lt_area_chain_max(t->p, j->c, kmax, kflat), "a join by a chain of %d vertices",
              j->c->n);
    if (j->c->n <= SPC_CHAIN_MAX_VERTICES)
        ++t->by_length[j->c->n];
    area_cam side = {t->ctx, t->p, j, kmax, kflat};
    spc_snee_params pp = *t->p;
    pp.mis = true;
    pp.query_p = j->x1 ? spc_snee_later_prob(sc, t->p, j->x2->p) : spc_snee_first_prob(sc, t->p, j->x2->p);
    pp.alt_chain_ratio = area_cam_ratio;
    pp.alt_user = &side;
    /* the path's guided mixture at x2 where the render has a caustic guide (spc_path_snee_guide_at):
     * specular NEE's weight and BSDF sampling's at x2 read its density */
    spc_cguide_vertex gv;
    gv.a = 0.0;
    if (pp.cguide && pp.recv_guide > 0.0)
        spc_cguide_vertex_init(&gv, pp.cguide, j->x2, j->w2);
    pp.cguide_at = gv.a > 0.0 ? &gv : NULL;
    t->guided += gv.a > 0.0;
    if (pp.cguide && pp.recv_guide > 0.0 && j->x1) {
        spc_snee_params p0 = *t->p;
        p0.recv_guide = 0.0;
        double r0 = spc_path_lt_area_ratio(t->ctx, &p0, j->x1, j->w1, j->x2, j->w2, j->cc, j->c, j->e, j->y, j->ny);
        double r1 = spc_path_lt_area_ratio(t->ctx, t->p, j->x1, j->w1, j->x2, j->w2, j->cc, j->c, j->e, j->y, j->ny);
        t->guided_r += r0 > 0.0 && fabs(r1 / r0 - 1.0) > 1e-3;
    }
    /* specular NEE's query at x2 toward y, as the path tracer makes it */
    spc_snee_query q;
    spc_snee_query_init(&q, sc, &pp, j->x2, j->w2, kmax);
    q.y = j->y;
    q.ny = j->ny;
    q.light_size = sqrt(j->e->shape->area);
    q.y_err = 1e-6 * sc->radius; /* a light point's rounding off its surface, as a sampled point has */
    q.p_y = spc_snee_light_pdf_at(sc, &pp, j->e, j->y, j->ny, j->x2->p) * spc_snee_query_prob(&pp);
    q.psi = 1.0;
    spc_chain all[16];
    int n = 0;
    if (t->flat) {
        /* past the budget as the longer chains' pass asks for them (one length) */
        if (j->c->n > q.max_chain)
            q.min_chain = q.max_chain = j->c->n;
        n = spc_flat_chains_all(&q, all, 16, NULL);
    } else if (t->cylinder) {
        n = spc_cylinder_chains_all(&q, all, 16, NULL);
    } else if (t->plane) {
        n = spc_plane_chains_all(&q, pp.reflect, all, 16, NULL);
    } else if (!t->mesh) {
        n = spc_sphere_chains_all(&q, all, 16, NULL);
    }
    /* beside a ball, a light chain off a flat mirror is the flat enumeration's */
    if (!t->flat && !t->mesh && !t->cylinder && !t->plane && spc_flat_chain_covers(j->c, pp.reflect) &&
        !spc_sphere_chain_covers(j->c, pp.reflect) && j->c->n <= q.max_chain)
        n = spc_flat_chains_all(&q, all, 16, NULL);
    const spc_chain *match = t->mesh ? j->c : NULL;
    double best = 1.0 - 1e-6;
    for (int i = 0; i < n; ++i)
        if (all[i].n == j->c->n && spc_dot(all[i].d0, j->c->d0) > best) {
            best = spc_dot(all[i].d0, j->c->d0);
            match = &all[i];
        }
    if (!match && t->flat && !spc_flat_chain_covers(j->c, pp.reflect)) {
        /* specular NEE never makes this path (its psi is 0): BSDF sampling's own weight and light
         * tracing's sum to one */
        CHECK(spc_flat_chain_faces(j->c, pp.reflect));
        ++t->unlisted;
        t->unlisted_long += j->c->n > SPC_FLAT_MAX_VERTICES;
        t->unlisted_partial += j->c->n <= SPC_FLAT_MAX_VERTICES;
        double w_alt;
        double w_own = join_receiver_weights(sc, &pp, j, kmax, &w_alt);
        double gap = fabs(w_own + j->w - 1.0);
        if (gap > t->unlisted_gap)
            t->unlisted_gap = gap;
        return;
    }
    bool longer = j->cc && j->cc->n > t->p->max_chain;
    t->longer += longer;
    if (!match)
        return;
    ++t->matched;
    t->through_flat_matched += !j->x1 && j->cc && spc_flat_chain_covers(j->cc, t->p->reflect);
    t->longer_matched += longer;
    t->longer_above += longer && j->w > 0.5;
    spc_rgb v_mis = spc_snee_chain_value(&q, j->e, spc_v2(0, 0), match);
    spc_snee_params pn = pp;
    pn.mis = false;
    q.params = &pn;
    spc_rgb v_all = spc_snee_chain_value(&q, j->e, spc_v2(0, 0), match);
    double w_nee = spc_rgb_avg(v_all) > 0.0 ? spc_rgb_avg(v_mis) / spc_rgb_avg(v_all) : 0.0;
    /* BSDF sampling's own weight at x2 of the same path, and the other strategy's (light tracing's) */
    double w_alt;
    double w_own = join_receiver_weights(sc, &pp, j, kmax, &w_alt);
    double gap = fabs(w_nee + w_own + j->w - 1.0);
    t->exact += gap < 1e-5;
    /* on the tessellated ball specular NEE's psi is 1 for its fitted roots' chains only (q.psi
     * above); a randomized attempt's chain has its own, and its gap is not counted */
    if (t->mesh && gap >= 1e-5)
        return;
    CHECK(j->w <= 1.0);
    if (gap > t->worst_gap) {
        t->worst_gap = gap;
        if (gap > 1e-5)
            printf("    gap %.3g: k %d kind %d w_nee %.6f w_own %.6f w_lt %.6f (alt %.6f) r %.3g\n", gap, j->c->n,
                   j->x1   ? 2
                   : j->cc ? 1
                           : 0,
                   w_nee, w_own, j->w, w_alt, j->r);
    }
    t->lt_sum += j->w;
    t->above += j->w > 0.5;
    t->below += j->w < 0.5;
}

/* Area lights (a small sphere light, a small square light over the ball): the light subpaths start
 * on the light where specular NEE samples its points and make every kind of join; on each, specular
 * NEE's weight at x2 (with light tracing in its power heuristic), BSDF sampling's and light
 * tracing's sum to one, and light tracing takes the larger share on some joins, specular NEE or
 * BSDF sampling on others. */
TEST(area_light_weights_sum_to_one)
{
    const char *files[] = {"bench/check/ball_small_light.xml", "bench/check/ball_rect_light.xml"};
    for (int f = 0; f < 2; ++f) {
        spc_scene *sc = tu_load(files[f], 16);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_camera_state cam;
        spc_snee_params p;
        CHECK(spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height));
        CHECK(spc_snee_parse(AREA_SETTING, 2, &p));
        p.lt_through = 1.0;
        spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
        CHECK(spc_path_lt_enabled(&ctx, &p) && spc_path_lt_area_enabled(&p));
        for (int seed = 31; seed < 34; ++seed) {
            /* every sample traces an area subpath, the last seed half of them (the share in both
             * sides' r) */
            p.lt_share = seed == 33 ? 0.5 : 1.0;
            ctx.snee = p;
            area_tally t;
            memset(&t, 0, sizeof t);
            t.ctx = &ctx;
            t.p = &p;
            spc_rng rng;
            spc_rng_seed(&rng, (uint64_t)seed, 7);
            for (int i = 0; i < 20000; ++i)
                spc_path_lt_joins(&ctx, &p, &rng, check_area_join, &t);
            printf("  %s seed %d: %d joins (%d enumerated at x2; directly %d, through the sphere %d, through a "
                   "diffuse bounce %d), light tracing's weight above 1/2 on %.0f, below on %.0f, largest gap of "
                   "the three weights' sum from 1 %.3g\n",
                   files[f], seed, t.joins, t.matched, t.kinds[0], t.kinds[1], t.kinds[2], t.above, t.below,
                   t.worst_gap);
            CHECK(t.joins > 50 && t.kinds[0] > 10 && t.kinds[1] > 10 && t.kinds[2] > 10);
            CHECK(t.matched > t.joins * 9 / 10);
            CHECK_MSG(t.worst_gap < 1e-5, "%s seed %d: the three weights sum to 1 +- %.3g", files[f], seed,
                      t.worst_gap);
            CHECK(t.above > 0 && t.below > 0);
        }
        spc_scene_destroy(sc);
    }
}

/* The demo (a glass ball and a mirror ball in a room under a small square light) with its plan's
 * caustic guide at receivers and light tracing: the path tracer draws its directions at x1 and x2
 * from the guided mixture, so light tracing's ratio r and BSDF sampling's density at x2 are the
 * mixture's. On each join enumerated at x2, specular NEE's weight (with the guide at x2),
 * BSDF sampling's own and light tracing's sum to one; the guide runs at x2 on most joins and moves
 * r on some joins through a diffuse bounce (the ceiling seeing the floor under the ball through
 * it). */
#define DEMO_GUIDED_SETTING "angular:camera=0.022,first=0.1,later=0.1,recguide=0.1,long=0.2,longmax=4,ltcaus"

TEST(area_light_weights_sum_to_one_guided)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load("scenes/demo.xml", DEMO_GUIDED_SETTING, &cam, &p);
    if (!sc)
        return;
    spc_cguide *g = spc_cguide_build(sc, SPC_CGUIDE_MIN_PHOTONS, SPC_CGUIDE_STREAM, p.recv_guide);
    CHECK(g != NULL && g->cones > 0);
    p.cguide = g;
    p.lt_share = 1.0;
    p.lt_through = 1.0;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_enabled(&ctx, &p) && spc_path_lt_area_enabled(&p));
    area_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    spc_rng rng;
    spc_rng_seed(&rng, 12081, 7);
    int n = spc_test_quick() ? 20000 : 60000;
    for (int i = 0; i < n; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_area_join, &t);
    printf("    %d joins (%d enumerated at x2; directly %d, through the sphere %d, through a diffuse bounce %d), "
           "the guide at x2 on %d, r moved by it on %d; light tracing's weight above 1/2 on %.0f, below on %.0f, "
           "largest gap of the three weights' sum from 1 %.3g\n",
           t.joins, t.matched, t.kinds[0], t.kinds[1], t.kinds[2], t.guided, t.guided_r, t.above, t.below,
           t.worst_gap);
    CHECK(t.matched > 100 && t.kinds[2] > 10);
    CHECK(t.guided > t.joins / 2 && t.guided_r > 10);
    CHECK_MSG(t.worst_gap < 1e-5, "the three weights sum to 1 +- %.3g", t.worst_gap);
    CHECK(t.above > 0 && t.below > 0);
    spc_cguide_destroy(g);
    spc_scene_destroy(sc);
}

/* The joins of an area light's subpaths to the pinhole through the sphere's longer chains (the
 * floor under the ball seen through it after reflections inside it, where the caustic folds): on
 * each, specular NEE's weight at x2, BSDF sampling's own (with light tracing in its ratio, through
 * the camera's chain of 3-6 vertices) and light tracing's sum to one, and light tracing takes the
 * larger share on some of them. */
TEST(area_light_long_camera_chains_weights_sum_to_one)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load("bench/check/ball_small_light.xml", AREA_SETTING, &cam, &p);
    if (!sc)
        return;
    p.lt_through = 1.0;
    p.lt_long = 1.0;
    p.lt_share = 1.0;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    area_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    spc_rng rng;
    spc_rng_seed(&rng, 47, 7);
    for (int i = 0; i < 40000; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_area_join, &t);
    printf("    %d joins, %d through longer camera chains (%d enumerated at x2, light tracing's weight above 1/2 on "
           "%d); largest gap of the three weights' sum from 1 %.3g\n",
           t.joins, t.longer, t.longer_matched, t.longer_above, t.worst_gap);
    CHECK(t.longer > 50);
    CHECK(t.longer_matched > t.longer * 9 / 10);
    CHECK(t.longer_above > 0);
    CHECK_MSG(t.worst_gap < 1e-5, "the three weights sum to 1 +- %.3g", t.worst_gap);
    spc_scene_destroy(sc);
}

/* One run of light tracing's joins under an area light: the scene with the setting, its subpaths on
 * every sample (ltshare=1), each join tallied by check_area_join with the casters' kind (area_tally's
 * flags, set by the caller after area_run_start). */
typedef struct area_run {
    spc_camera_state cam;
    spc_snee_params p;
    spc_render_ctx ctx;
    spc_scene *sc;
    spc_rng rng;
    bool mesh, flat, cylinder, plane;
    area_tally t;
} area_run;

static bool area_run_start(area_run *r, const char *scene, const char *setting, uint64_t seed)
{
    memset(r, 0, sizeof *r);
    r->sc = lt_load(scene, setting, &r->cam, &r->p);
    if (!r->sc)
        return false;
    r->ctx = lt_ctx(r->sc, &r->cam, &r->p);
    CHECK(spc_path_lt_enabled(&r->ctx, &r->p) && spc_path_lt_area_enabled(&r->p));
    r->p.lt_share = 1.0;
    r->ctx.snee = r->p;
    spc_rng_seed(&r->rng, seed, 7);
    return true;
}

/* Tallies the joins of n more subpaths afresh, with the run's present parameters. */
static void area_run_joins(area_run *r, int n)
{
    r->ctx.snee = r->p;
    memset(&r->t, 0, sizeof r->t);
    r->t.ctx = &r->ctx;
    r->t.p = &r->p;
    r->t.mesh = r->mesh;
    r->t.flat = r->flat;
    r->t.cylinder = r->cylinder;
    r->t.plane = r->plane;
    for (int i = 0; i < n; ++i)
        spc_path_lt_joins(&r->ctx, &r->p, &r->rng, check_area_join, &r->t);
}

#define MESH_SCENE "bench/check/glass_ball_mesh.xml"
#define MESH_SETTING "angular:camera=0.1,first=0.15,later=0.1,ltcaus"

/* The triangle glass ball under a small square light: light tracing's joins through the
 * tessellated ball (specular NEE's chains there are not enumerated exactly; the ratio against BSDF
 * sampling needs no count). On most joins (the chains of the fitted sphere's roots, which specular
 * NEE counts with psi 1) specular NEE's weight, BSDF sampling's own and light tracing's sum to
 * one; every kind of join but the one through the ball toward the pinhole is made, and light
 * tracing takes the larger share on some joins, the other two on others. */
TEST(mesh_ball_area_weights_sum_to_one)
{
    area_run r;
    if (!area_run_start(&r, MESH_SCENE, MESH_SETTING, 35))
        return;
    r.mesh = true;
    area_run_joins(&r, 20000);
    const area_tally t = r.t;
    printf("  %s: %d joins (directly %d, through the ball %d, through a diffuse bounce %d), the three weights "
           "summing to 1 on %d, light tracing's weight above 1/2 on %.0f, below on %.0f, largest gap of those %.3g\n",
           MESH_SCENE, t.joins, t.kinds[0], t.kinds[1], t.kinds[2], t.exact, t.above, t.below, t.worst_gap);
    CHECK(t.joins > 50 && t.kinds[0] > 10 && t.kinds[2] > 10 && t.kinds[1] == 0);
    CHECK_MSG(t.exact > t.joins * 8 / 10, "the three weights sum to 1 on %d of %d joins", t.exact, t.joins);
    CHECK(t.worst_gap < 1e-5);
    CHECK(t.above > 0 && t.below > 0);
    spc_scene_destroy(r.sc);
}

/* On the triangle glass ball the render with ltcaus agrees with one without. */
TEST(mesh_ball_render_agrees_without_it)
{
    scene_settings_agree(MESH_SCENE, MESH_SETTING, "angular:camera=0.1,first=0.15,later=0.1", 1024, 45,
                         "mesh ball: ltcaus vs without");
}

#define MESH_POINT_SCENE "bench/check/point_light_ball_mesh.xml"

typedef struct mesh_point_tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    int joins, lt_only, solved, kinds[4];
    double worst_gap, above, below;
} mesh_point_tally;

/* A point light's join through the tessellated ball: specular NEE's solver at x2, seeded along the
 * join's first direction with its events, toward the point light, solves the join's chain, and
 * specular NEE's share 1 / (1 + r^2) with r from that chain and light tracing's weight sum to one;
 * or the join is light tracing's alone (weight 1, r infinite). */
static void check_mesh_point_join(void *user, const spc_path_lt_join *j)
{
    mesh_point_tally *t = user;
    ++t->joins;
    CHECK(j->e->type == SPC_EMITTER_POINT && j->w > 0.0 && j->w <= 1.0);
    if (isinf(j->r)) {
        ++t->lt_only;
        CHECK(j->w == 1.0);
        return;
    }
    ++t->kinds[j->x1 ? (j->nmid > 0 ? 3 : 2) : j->cc ? 1 : 0];
    /* through the ball toward the pinhole: the camera's chain as the path tracer retraces it from
     * x2 (its events, along its first direction), which the camera's side weighs with */
    spc_chain rc;
    if (j->cc) {
        unsigned char cev[SPC_CHAIN_MAX_VERTICES];
        for (int i = 0; i < j->cc->n && i < SPC_CHAIN_MAX_VERTICES; ++i)
            cev[i] = j->cc->v[i].event;
        spc_frame f = spc_frame_from_n(j->cc->d0);
        spc_chain_opts o = spc_chain_opts_default(j->cc->n);
        o.events = cev;
        o.any_surface = t->p->any_surface;
        spc_chain_trace(t->ctx->scene, j->x2, &f, 0.0, 0.0, &o, &rc);
        if (rc.n != j->cc->n)
            return;
    }
    spc_snee_query q;
    spc_snee_query_init(&q, t->ctx->scene, t->p, j->x2, j->w2, j->c->n);
    q.y = j->e->position;
    q.ny = spc_v3(0, 0, 0);
    q.light_size = 0.0;
    unsigned char ev[SPC_CHAIN_MAX_VERTICES];
    for (int i = 0; i < SPC_CHAIN_MAX_VERTICES; ++i)
        ev[i] = i < j->c->n ? j->c->v[i].event : SPC_CHAIN_REFRACT;
    q.events = ev;
    q.keep_n = j->c->n;
    q.seed_dir = &j->c->d0;
    spc_rng rng;
    spc_rng_seed(&rng, 1, 2);
    spc_chain c;
    int it = 0;
    const spc_specular_solver *solver = spc_specular_solver_get(t->p->solver);
    if (!solver || !solver->solve_one(&q, &rng, &c, &it) || c.n != j->c->n ||
        !spc_snee_same_solution(&c, j->c, t->ctx->scene->radius))
        return;
    ++t->solved;
    double r = j->x1 ? spc_path_lt_ratio_via(t->ctx, t->p, j->x1, j->w1, j->mid, j->nmid, j->x2, j->w2, &c, j->e)
                     : spc_path_lt_ratio_first(t->ctx, t->p, j->x2, j->cc ? &rc : NULL, &c, j->e);
    double gap = fabs(1.0 / (1.0 + r * r) + j->w - 1.0);
    if (gap > t->worst_gap)
        t->worst_gap = gap;
    t->above += j->r > 1.0;
    t->below += j->r < 1.0;
}

/* The triangle glass ball under a point light: light tracing makes the ball's point-light chains
 * and joins x2 to the pinhole directly, through the ball (the chains it solves from the fitted
 * sphere's roots toward the pinhole), through a diffuse bounce and through two; specular NEE's
 * solver finds the same chain from x2, and the two weights of each such path sum to one (through
 * the ball with the camera's chain as the path tracer retraces it); light tracing takes the larger
 * share on some joins (near the caustic's fold), specular NEE on others. */
TEST(mesh_ball_point_weights_sum_to_one)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load(MESH_POINT_SCENE, MESH_SETTING, &cam, &p);
    if (!sc)
        return;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_enabled(&ctx, &p));
    mesh_point_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    spc_rng rng;
    spc_rng_seed(&rng, 37, 7);
    int n = spc_test_quick() ? 5000 : 20000;
    for (int i = 0; i < n; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_mesh_point_join, &t);
    printf("  %s: %d joins (light tracing's alone %d; directly %d, through the ball %d, through a diffuse bounce %d, "
           "through two %d), specular NEE's solve from x2 finds the chain on %d, light tracing's weight above 1/2 on "
           "%.0f, below on %.0f, largest gap of the two weights' sum from 1 %.3g\n",
           MESH_POINT_SCENE, t.joins, t.lt_only, t.kinds[0], t.kinds[1], t.kinds[2], t.kinds[3], t.solved, t.above,
           t.below, t.worst_gap);
    CHECK(t.joins > 50 && t.kinds[0] > 10 && t.kinds[1] > 10 && t.kinds[2] > 10);
    CHECK_MSG(t.solved > (t.joins - t.lt_only) * 9 / 10, "specular NEE solves %d of %d joins' chains", t.solved,
              t.joins - t.lt_only);
    CHECK_MSG(t.worst_gap < 1e-5, "the two weights sum to 1 +- %.3g", t.worst_gap);
    CHECK(t.above > 0 && t.below > 0);
    spc_scene_destroy(sc);
}

#define SLAB_SCENE "bench/check/two_slabs_sphere_light.xml"
#define SLAB_SETTING "angular:camera=0.036,first=0.1,later=0.1,long=0.3,flat5=1,flat6=1,ltcaus"
/* Joins through flat glass: the flat enumeration polishes its roots to SPC_SNEE_FLAT_POLISH_TOL_SCENE
 * of the scene and SPC_SNEE_FLAT_POLISH_TOL_LIGHT of the light (exact roots, missed only by the rays'
 * spawn offsets), so the strategies' densities of one path agree to that polish, not to the other
 * enumerations' tighter one: their weights' sum is held to 1e-4 (measured up to 1.9e-5; a missing factor
 * or density moves it by far more). */
#define FLAT_WEIGHT_GAP 1e-4

/* A run on the slabs: their joins by the flat enumeration. */
static bool slab_run_start(area_run *r, const char *setting, uint64_t seed)
{
    if (!area_run_start(r, SLAB_SCENE, setting, seed))
        return false;
    r->flat = true;
    return true;
}

/* Two glass slabs under a small sphere light: light tracing's joins by chains through flat faces,
 * of the budget's two vertices (one slab) and past it (two slabs' four, and the total internal
 * reflections off their sides), up to the longest chain the path's track follows. Specular NEE's
 * flat enumeration at x2 finds each join's chain (its psi 1 with flat5 and flat6 at every call),
 * and its weight there, BSDF sampling's own and light tracing's sum to one. */
static void slab_area_weights(const char *setting)
{
    area_run r;
    if (!slab_run_start(&r, setting, 39))
        return;
    CHECK(r.p.max_chain == 2);
    area_run_joins(&r, spc_test_quick() ? 10000 : 40000);
    const area_tally t = r.t;
    printf("  %s: %d joins (%d found by the flat enumeration; directly %d, through a diffuse bounce %d; chains of "
           "1-6 vertices %d %d %d %d %d %d), the three weights summing to 1 on %d, light tracing's weight above 1/2 "
           "on %.0f, below on %.0f, largest gap %.3g\n",
           SLAB_SCENE, t.joins, t.matched, t.kinds[0], t.kinds[2], t.by_length[1], t.by_length[2], t.by_length[3],
           t.by_length[4], t.by_length[5], t.by_length[6], t.exact, t.above, t.below, t.worst_gap);
    CHECK(t.joins > 50 && t.kinds[0] > 10 && t.kinds[2] > 0 && t.kinds[1] == 0);
    CHECK_MSG(t.by_length[2] > 10 && t.by_length[4] > 10, "joins by 2 and 4 vertices: %d, %d", t.by_length[2],
              t.by_length[4]);
    CHECK_MSG(t.matched > t.joins * 95 / 100, "the flat enumeration finds %d of %d joins' chains", t.matched, t.joins);
    CHECK_MSG(t.worst_gap < FLAT_WEIGHT_GAP, "the three weights sum to 1 +- %.3g", t.worst_gap);
    CHECK(t.above > 0 && t.below > 0);
    printf("  %d joins by chains the enumeration leaves to BSDF sampling (%d with a partial reflection, %d longer), "
           "BSDF sampling's and light tracing's weights summing to 1 +- %.3g\n",
           t.unlisted, t.unlisted_partial, t.unlisted_long, t.unlisted_gap);
    CHECK_MSG(t.unlisted_partial > 0, "joins through a partial reflection: %d", t.unlisted_partial);
    CHECK_MSG(t.unlisted_gap < 1e-5, "BSDF sampling's and light tracing's weights sum to 1 +- %.3g", t.unlisted_gap);
    CHECK(t.matched + t.unlisted == t.joins);
    spc_scene_destroy(r.sc);
}

TEST(slab_area_weights_sum_to_one) { slab_area_weights(SLAB_SETTING); }

/* The same with half of the sphere light's points drawn in the cone from the receiver (lightx=0.5;
 * the plan draws 0.9 for flat glass under sphere lights): specular NEE's density there is the
 * mixture's, in its own weight and in the path tracer's and light tracing's (spc_snee_light_pdf_at). */
TEST(slab_area_weights_sum_to_one_lightx) { slab_area_weights(SLAB_SETTING ",lightx=0.5"); }

/* The same with the path's track and light tracing's chains up to 8 vertices (longmax=8): chains
 * of 7 and 8 vertices through the slabs (total internal reflections along a slab, out of its side)
 * are light tracing's and BSDF sampling's, whose two weights sum to one. */
TEST(slab_area_weights_sum_to_one_long)
{
    area_run r;
    if (!slab_run_start(&r, SLAB_SETTING ",longmax=8", 41))
        return;
    area_run_joins(&r, spc_test_quick() ? 20000 : 60000);
    const area_tally t = r.t;
    printf("  %s, longmax=8: %d joins, chains of 7 and 8 vertices %d %d; %d the enumeration leaves to BSDF sampling "
           "(%d with a partial reflection, %d longer): weights summing to 1 +- %.3g; the others' three +- %.3g\n",
           SLAB_SCENE, t.joins, t.by_length[7], t.by_length[8], t.unlisted, t.unlisted_partial, t.unlisted_long,
           t.unlisted_gap, t.worst_gap);
    CHECK_MSG(t.unlisted_long > 0, "joins by chains of 7-8 vertices: %d", t.unlisted_long);
    /* (an 8-vertex chain of total internal reflections is retraced from x2 to within about 1e-5 of
     * light tracing's own directions) */
    CHECK_MSG(t.unlisted_gap < 1e-4, "BSDF sampling's and light tracing's weights sum to 1 +- %.3g", t.unlisted_gap);
    CHECK_MSG(t.worst_gap < FLAT_WEIGHT_GAP, "the three weights sum to 1 +- %.3g", t.worst_gap);
    CHECK(t.matched + t.unlisted == t.joins);
    spc_scene_destroy(r.sc);
}

/* The same with the long pass leaving chains through flat faces past their enumeration to light
 * tracing and BSDF sampling (longflatlt) and with lightx: the 7- and 8-vertex joins weigh light
 * tracing against BSDF sampling alone, their two weights summing to one, and specular NEE's chains
 * of the others (its own light point's density included) with the three. */
TEST(slab_area_weights_sum_to_one_long_flat_lt)
{
    area_run r;
    if (!slab_run_start(&r, SLAB_SETTING ",longmax=8,long=0.4,lightx=0.9,longflatlt", 41))
        return;
    CHECK(r.p.long_flat_lt);
    area_run_joins(&r, spc_test_quick() ? 20000 : 60000);
    const area_tally t = r.t;
    printf("  %s, longflatlt: %d joins, chains of 7 and 8 vertices %d %d; %d left to BSDF sampling (%d longer): "
           "weights summing to 1 +- %.3g; the others' three +- %.3g\n",
           SLAB_SCENE, t.joins, t.by_length[7], t.by_length[8], t.unlisted, t.unlisted_long, t.unlisted_gap,
           t.worst_gap);
    CHECK_MSG(t.unlisted_long > 0, "joins by chains of 7-8 vertices: %d", t.unlisted_long);
    CHECK_MSG(t.unlisted_gap < 1e-4, "BSDF sampling's and light tracing's weights sum to 1 +- %.3g", t.unlisted_gap);
    CHECK_MSG(t.worst_gap < FLAT_WEIGHT_GAP, "the three weights sum to 1 +- %.3g", t.worst_gap);
    CHECK(t.matched + t.unlisted == t.joins);
    spc_scene_destroy(r.sc);
}

/* The same slabs with ltslab: an area light's subpaths also join the pinhole through flat faces
 * (the floor seen through a slab, camera chains of 1-2 vertices within max_chain); on each such join
 * specular NEE's weight at x2, BSDF sampling's own (the camera's side through that chain) and light
 * tracing's sum to one, and on those by chains the enumeration leaves to BSDF sampling (a partial
 * reflection inside the glass) BSDF sampling's and light tracing's do. Without ltslab no area
 * light's join goes through a slab. */
TEST(slab_area_camera_weights_sum_to_one)
{
    area_run r;
    if (!slab_run_start(&r, SLAB_SETTING ",ltslab", 43))
        return;
    CHECK(r.p.lt_slab && r.p.max_chain == 2);
    int subpaths = spc_test_quick() ? 10000 : 40000;
    area_run_joins(&r, subpaths);
    const area_tally *t = &r.t;
    printf("  %s, ltslab: %d joins (directly %d, through a slab %d, through a diffuse bounce %d), found by the flat "
           "enumeration %d, left to BSDF sampling %d (%d with a partial reflection); largest gap of the three "
           "weights' sum from 1 %.3g, of the two's %.3g\n",
           SLAB_SCENE, t->joins, t->kinds[0], t->kinds[1], t->kinds[2], t->matched, t->unlisted, t->unlisted_partial,
           t->worst_gap, t->unlisted_gap);
    CHECK_MSG(t->kinds[1] > 20, "joins through a slab toward the pinhole: %d", t->kinds[1]);
    CHECK_MSG(t->matched > (t->joins - t->unlisted) * 95 / 100, "the flat enumeration finds %d of %d joins' chains",
              t->matched, t->joins - t->unlisted);
    CHECK_MSG(t->worst_gap < FLAT_WEIGHT_GAP, "the three weights sum to 1 +- %.3g", t->worst_gap);
    CHECK_MSG(t->unlisted_gap < 1e-5, "BSDF sampling's and light tracing's weights sum to 1 +- %.3g", t->unlisted_gap);
    /* without ltslab: none through a slab */
    r.p.lt_slab = false;
    area_run_joins(&r, subpaths / 4);
    CHECK_MSG(t->joins > 0 && t->kinds[1] == 0, "without ltslab: %d joins, %d through a slab", t->joins, t->kinds[1]);
    spc_scene_destroy(r.sc);
}

#define MIRROR_BALL_SCENE "bench/check/ball_mirror_wall.xml"
#define MIRROR_BALL_SETTING "angular:camera=0.3,first=0.1,later=0.1,ltcaus,long=0.5,longmax=5"

/* A glass ball before an upright flat mirror under a small light with ltslab: an area light's
 * subpaths also join the pinhole through the mirror (the ball's caustic seen in it: camera chains of
 * one flat mirror vertex); on each join whose light chain the sphere enumeration (or, off the mirror,
 * the flat one) makes at x2, specular NEE's weight there, BSDF sampling's own (the camera's side
 * through the mirror) and light tracing's sum to one, within the flat enumeration's polish
 * (FLAT_WEIGHT_GAP). Without ltslab no join goes through the mirror. */
TEST(mirror_ball_area_camera_weights_sum_to_one)
{
    area_run r;
    if (!area_run_start(&r, MIRROR_BALL_SCENE, MIRROR_BALL_SETTING ",ltslab", 47))
        return;
    CHECK(r.p.lt_slab);
    int subpaths = spc_test_quick() ? 10000 : 40000;
    area_run_joins(&r, subpaths);
    const area_tally *t = &r.t;
    printf("  %s, ltslab: %d joins (directly %d, through a camera chain %d, %d of them off the mirror, through a "
           "diffuse bounce %d), found by the enumerations at x2 %d (through the mirror %d); largest gap of the three "
           "weights' sum from 1 %.3g\n",
           MIRROR_BALL_SCENE, t->joins, t->kinds[0], t->kinds[1], t->through_flat, t->kinds[2], t->matched,
           t->through_flat_matched, t->worst_gap);
    CHECK_MSG(t->through_flat_matched > 20, "joins through the mirror toward the pinhole: %d (%d found at x2)",
              t->through_flat, t->through_flat_matched);
    CHECK_MSG(t->matched > t->joins * 9 / 10, "the enumerations find %d of %d joins' chains", t->matched, t->joins);
    CHECK_MSG(t->worst_gap < FLAT_WEIGHT_GAP, "the three weights sum to 1 +- %.3g", t->worst_gap);
    /* without ltslab: none through the mirror */
    r.p.lt_slab = false;
    area_run_joins(&r, subpaths / 4);
    CHECK_MSG(t->joins > 0 && t->through_flat == 0, "without ltslab: %d joins, %d through the mirror", t->joins,
              t->through_flat);
    spc_scene_destroy(r.sc);
}

/* With ltslab the glass ball before the mirror renders as without it (the caustic seen in the mirror:
 * the same paths split three ways instead of two). */
TEST(mirror_ball_area_camera_render_agrees_without_it)
{
    scene_settings_agree(MIRROR_BALL_SCENE, MIRROR_BALL_SETTING ",ltslab", MIRROR_BALL_SETTING, 512, 71,
                         "glass ball before a mirror, area light, ltslab vs without");
}

/* With an area light and ltslab the slabs render as without light tracing (the floor seen through a
 * slab: the same paths split three ways). */
TEST(slab_area_camera_render_agrees_without_it)
{
    scene_settings_agree(SLAB_SCENE, "angular:camera=0.036,first=0.1,later=0.1,ltcaus,ltshare=1,ltslab",
                         "angular:camera=0.036,first=0.1,later=0.1", 512, 67,
                         "slabs, area light, ltslab vs without ltcaus");
}

/* On the triangle glass ball under a point light the render with ltcaus agrees with one without. */
TEST(mesh_ball_point_render_agrees_without_it)
{
    scene_settings_agree(MESH_POINT_SCENE, MESH_SETTING, "angular:camera=0.1,first=0.15,later=0.1", 1024, 47,
                         "mesh ball, point light: ltcaus vs without");
}

/* ---- spot lights ---- */

/* The glass ball of bench/check/spot_ball.xml under its spot aimed 15 degrees off the ball: the
 * ball (4.8 degrees in radius from the light) spans the beam's edge, the falloff and the cutoff. */
#define SPOT_SCENE "bench/check/spot_ball_edge.xml"
#define SPOT_SETTING "angular:camera=0.024,first=0.1,later=0.1,ltcaus"

/* A spot light's subpaths (path_lt.h: a point light's, their throughput the spot's intensity toward
 * the first direction): every kind of join occurs, each a path specular NEE counts at x2 with the
 * two weights summing to one within 1e-5 or one it does not make with light tracing's weight 1,
 * as for the point light; and the spot's intensity toward directions around the ball, which spans
 * its full beam, its falloff and past its cutoff, is Mitsuba 3's. */
TEST(spot_joins_weigh_as_specular_nee)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load(SPOT_SCENE, SPOT_SETTING, &cam, &p);
    if (!sc)
        return;
    CHECK(sc->nemitters == 1 && sc->emitters[0]->type == SPC_EMITTER_SPOT);
    p.lt_through = 1.0;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_enabled(&ctx, &p));
    const spc_emitter *e = sc->emitters[0];
    spc_vec3 axis = spc_normalize(spc_mat4_apply_vector(&e->to_world, spc_v3(0, 0, 1)));
    double cos_beam = cos(e->beam_width * SPC_PI / 180.0), cos_cut = cos(e->cutoff_angle * SPC_PI / 180.0);
    int beam = 0, falloff = 0, past = 0;
    int n = spc_test_quick() ? 10000 : 20000;
    for (int seed = 31; seed < 33; ++seed) {
        tally t;
        memset(&t, 0, sizeof t);
        t.ctx = &ctx;
        t.p = &p;
        spc_rng rng;
        spc_rng_seed(&rng, (uint64_t)seed, 3);
        for (int i = 0; i < n; ++i)
            spc_path_lt_joins(&ctx, &p, &rng, check_join, &t);
        printf("  spot, seed %d: %d joins, %d not enumerated (%d weighed 1), largest gap of the weights' sum from 1 "
               "%.3g; x2 seen directly %d, through the sphere %d, through a diffuse bounce %d\n",
               seed, t.joins, t.missing, t.lt_only, t.worst_gap, t.kinds[0], t.kinds[1], t.kinds[2]);
        CHECK(t.joins > 100 && t.kinds[0] > 10 && t.kinds[1] > 10 && t.kinds[2] > 10);
        CHECK_MSG(t.lt_only == t.missing, "spot, seed %d: %d joins specular NEE does not enumerate weigh less than 1",
                  seed, t.missing - t.lt_only);
        CHECK_MSG(t.worst_gap < 1e-5, "spot, seed %d: the two weights sum to 1 +- %.3g", seed, t.worst_gap);
    }
    /* the emission toward the ball (a circle of radius 0.6 around its centre, 9 degrees from the
     * light): the spot's intensity with Mitsuba 3's falloff, linear in the angle from the beam's
     * edge to the cutoff, zero past it */
    for (int i = 0; i < 64; ++i) {
        double a = (i + 0.5) / 64.0 * 2.0 * SPC_PI;
        spc_vec3 c = spc_v3(0.271 + 0.6 * cos(a), 0.318 + 0.6 * sin(a), 0.580);
        spc_vec3 w = spc_normalize(spc_sub(c, e->position));
        double ct = spc_dot(w, axis), I = spc_rgb_avg(spc_emitter_eval_intensity(e, w));
        double want = ct >= cos_beam  ? spc_rgb_avg(e->intensity)
                      : ct <= cos_cut ? 0.0
                                      : spc_rgb_avg(e->intensity) * (e->cutoff_angle * SPC_PI / 180.0 - acos(ct)) /
                                            ((e->cutoff_angle - e->beam_width) * SPC_PI / 180.0);
        CHECK_MSG(fabs(I - want) <= 1e-9 * spc_rgb_avg(e->intensity), "spot intensity %.6g, want %.6g", I, want);
        beam += ct >= cos_beam;
        falloff += ct < cos_beam && ct > cos_cut;
        past += ct <= cos_cut;
    }
    printf("  spot: of 64 directions around the ball %d in the beam, %d in the falloff, %d past the cutoff\n", beam,
           falloff, past);
    CHECK(beam > 0 && falloff > 0 && past > 0);
    spc_scene_destroy(sc);
}

/* Does every one of 4 x 4 camera rays across pixel (x, y) first meet a surface with a smooth lobe
 * (the floor seen directly, not through the glass)? */
static bool pixel_sees_smooth(const spc_scene *sc, const spc_camera_state *cam, int x, int y)
{
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            spc_ray r = spc_camera_ray(cam, x + (i + 0.5) / 4.0, y + (j + 0.5) / 4.0);
            spc_hit h;
            if (!spc_scene_intersect(sc, &r, &h) || !h.bsdf || spc_bsdf_is_delta_only(h.bsdf))
                return false;
        }
    return true;
}

/* The per-pixel z-test (Sidak over the pixels tested, alpha 0.01, every channel) of a against b
 * over the pixels that see the floor directly (pixel_sees_smooth) and where b is at least `floor`
 * times its image mean in every channel. bdpt cannot make a delta light's caustic seen through
 * the glass (the path's one non-delta vertex, the floor, joins neither the light nor the camera),
 * and it finds the far floor's light (1e-4 of the image, through the ball) by rare light subpaths,
 * so at these sample counts many of those pixels read zero with a zero variance estimate, which
 * says nothing. The fraction of the tested pixels that pass (0 where fewer than 32 are tested);
 * their count in *tested_out and their sums over a and b in sums[0], sums[1] (mean of r, g, b),
 * with the standard errors in sums[2], sums[3]. */
static double floor_pixels_agree(const spc_scene *sc, const spc_film *a, const spc_film *b, double floor,
                                 int *tested_out, double sums[4])
{
    spc_camera_state cam;
    if (!spc_camera_prepare(&cam, &sc->camera, b->width, b->height))
        return 0.0;
    double mean[3] = {0, 0, 0};
    size_t npix = (size_t)b->width * b->height;
    for (size_t i = 0; i < npix; ++i)
        for (int c = 0; c < 3; ++c)
            mean[c] += b->rgb[3 * i + c] / (double)npix;
    bool use[64 * 64];
    size_t tested = 0, passed = 0;
    for (size_t i = 0; i < npix && i < 64 * 64; ++i) {
        use[i] = pixel_sees_smooth(sc, &cam, (int)(i % (size_t)b->width), (int)(i / (size_t)b->width));
        for (int c = 0; c < 3; ++c)
            use[i] = use[i] && b->rgb[3 * i + c] >= floor * mean[c];
        tested += use[i];
    }
    double alpha = -expm1(log1p(-0.01) / (double)(tested ? tested : 1));
    sums[0] = sums[1] = sums[2] = sums[3] = 0.0;
    for (size_t i = 0; i < npix && i < 64 * 64; ++i) {
        if (!use[i])
            continue;
        double p_min = 1.0;
        for (int c = 0; c < 3; ++c) {
            double v = (double)a->var[3 * i + c] + b->var[3 * i + c];
            double z = v > 0.0 ? (a->rgb[3 * i + c] - b->rgb[3 * i + c]) / sqrt(v) : 0.0;
            double pz = erfc(fabs(z) / sqrt(2.0));
            p_min = pz < p_min ? pz : p_min;
            sums[0] += a->rgb[3 * i + c] / 3.0;
            sums[1] += b->rgb[3 * i + c] / 3.0;
            sums[2] += a->var[3 * i + c] / 9.0;
            sums[3] += b->var[3 * i + c] / 9.0;
        }
        if (-expm1(3.0 * log1p(-p_min)) >= alpha)
            ++passed;
    }
    sums[2] = sqrt(sums[2]);
    sums[3] = sqrt(sums[3]);
    *tested_out = (int)tested;
    return tested >= 32 ? (double)passed / (double)tested : 0.0;
}

/* Under the spot the render with ltcaus agrees with one without (the same estimator's two splits:
 * the per-pixel z-test on 0.99 of the pixels and the image means) and with bdpt (the spot's
 * emission sampled by the light's own routine) over the floor seen directly where bdpt reads at
 * least 0.01 of its mean: the z-test on 0.99 of those pixels, their sums within 3 standard errors. */
TEST(spot_render_agrees_without_it_and_with_bdpt)
{
    spc_scene *sc = tu_load(SPOT_SCENE, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    settings_agree(sc, SPOT_SETTING, "angular:camera=0.024,first=0.1,later=0.1", 1024, 53, "spot: ltcaus vs without");
    spc_film *a = tu_render_nee(sc, "path", SPOT_SETTING, 1024, 2, 55, NULL);
    spc_film *b = tu_render_nee(sc, "bdpt", "none", 2048, 2, 56, NULL);
    CHECK(a && b);
    if (a && b) {
        int tested = 0;
        double sums[4];
        double pass = floor_pixels_agree(sc, a, b, 0.01, &tested, sums);
        double se = sqrt(sums[2] * sums[2] + sums[3] * sums[3]);
        printf("    spot vs bdpt: z-test pass %.4f of %d floor pixels; their sums %.5f vs %.5f (se %.2g)\n", pass,
               tested, sums[0], sums[1], se);
        CHECK_MSG(pass >= 0.99, "spot: ltcaus vs bdpt, z-test pass %.4f", pass);
        CHECK_MSG(fabs(sums[0] - sums[1]) <= 3.0 * se, "spot: floor sum %.5f vs bdpt %.5f (se %.2g)", sums[0], sums[1],
                  se);
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_scene_destroy(sc);
}

/* Under the two slabs the render with ltcaus (light tracing's chains of 1-6 vertices through the
 * flat faces) agrees with one without. */
TEST(slab_render_agrees_without_it)
{
    scene_settings_agree(SLAB_SCENE, "angular:camera=0.036,first=0.1,later=0.1,ltcaus",
                         "angular:camera=0.036,first=0.1,later=0.1", 512, 47, "slabs: ltcaus vs without");
}

#define SLAB_POINT_SCENE "bench/check/two_slabs_point_light.xml"
#define SLAB_POINT_PLAN "angular:camera=0.036,first=0.1,later=0.1"

typedef struct slab_point_tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    int joins, lt_only, matched, kinds[3], shared_psi;
    int by_length[SPC_CHAIN_MAX_VERTICES + 1];
    double worst_gap, above, below;
} slab_point_tally;

/* A point light's join through flat faces: where specular NEE's flat enumeration makes chains of
 * its length at x2 (spc_snee_flat_psi above 0), it finds the join's chain there, and its share
 * 1 / (1 + (r / psi)^2) (r from its chain, psi its enumeration's probability) and light tracing's
 * weight sum to one; where it never does (psi 0), the join is light tracing's alone (weight 1). */
/* The flat enumeration's chain from a join's receiver x2 to its point light that is the join's own
 * (the same vertex count, the same first direction within 1e-6), copied to *out; NULL where the
 * enumeration does not make it. */
static const spc_chain *point_light_flat_match(const spc_scene *sc, const spc_snee_params *p, const spc_path_lt_join *j,
                                               spc_chain *out)
{
    spc_snee_query q;
    spc_snee_query_init(&q, sc, p, j->x2, j->w2, j->c->n);
    q.min_chain = j->c->n;
    q.y = j->e->position;
    q.ny = spc_v3(0, 0, 0);
    q.light_size = 0.0;
    spc_chain all[16];
    int n = spc_flat_chains_all(&q, all, 16, NULL);
    int match = -1;
    double best = 1.0 - 1e-6;
    for (int i = 0; i < n; ++i)
        if (all[i].n == j->c->n && spc_dot(all[i].d0, j->c->d0) > best) {
            best = spc_dot(all[i].d0, j->c->d0);
            match = i;
        }
    if (match < 0)
        return NULL;
    *out = all[match];
    return out;
}

static void check_slab_point_join(void *user, const spc_path_lt_join *j)
{
    slab_point_tally *t = user;
    const spc_scene *sc = t->ctx->scene;
    ++t->joins;
    CHECK(j->e->type == SPC_EMITTER_POINT && j->w > 0.0 && j->w <= 1.0 && spc_flat_chain_covers(j->c, t->p->reflect));
    ++t->kinds[j->x1 ? 2 : j->cc ? 1 : 0];
    if (j->c->n <= SPC_CHAIN_MAX_VERTICES)
        ++t->by_length[j->c->n];
    /* max_depth -1: the budget and the depth left do not depend on the segments before x2 */
    int kmax = spc_path_lt_budget(t->ctx, t->p, j->x2, 1, j->x1 ? 1 : 0);
    double psi = spc_snee_flat_psi(t->p, kmax, SPC_CHAIN_MAX_VERTICES, j->c->n);
    if (!(psi > 0.0)) {
        ++t->lt_only;
        CHECK_MSG(isinf(j->r) && j->w == 1.0, "a join of %d vertices no enumeration makes: r %g, w %g", j->c->n, j->r,
                  j->w);
        return;
    }
    t->shared_psi += psi < 1.0;
    spc_chain found;
    const spc_chain *match = point_light_flat_match(sc, t->p, j, &found);
    if (!match)
        return;
    ++t->matched;
    double r = (j->x1 ? spc_path_lt_ratio_via(t->ctx, t->p, j->x1, j->w1, j->mid, j->nmid, j->x2, j->w2, match, j->e)
                      : spc_path_lt_ratio_first(t->ctx, t->p, j->x2, j->cc, match, j->e)) /
               psi;
    double gap = fabs(1.0 / (1.0 + r * r) + j->w - 1.0);
    if (gap > t->worst_gap)
        t->worst_gap = gap;
    t->above += j->w > 0.5;
    t->below += j->w < 0.5;
}

/* Two glass slabs under a point light: light tracing makes the chains through their flat faces of
 * 1-6 vertices (the budget's two, past it the two slabs' four, and the total internal reflections
 * along their sides); with the 3- and 4-vertex chains enumerated on a share of specular NEE's calls
 * (flat34=0.3) and the 5- and 6-vertex ones never, the joins of each kind occur, specular NEE's
 * flat enumeration at x2 finds the chain of every join it makes, and the two weights of each path
 * sum to one; the 5- and 6-vertex ones (a total internal reflection inside a slab on the way
 * through both) are light tracing's alone. */
TEST(slab_point_weights_sum_to_one)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load(SLAB_POINT_SCENE, SLAB_POINT_PLAN ",ltcaus,flat34=0.3", &cam, &p);
    if (!sc)
        return;
    p.mis = true; /* as the path tracer runs specular NEE (spc_path_snee_begin): the longer chains' pass */
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_enabled(&ctx, &p) && p.max_chain == 2);
    slab_point_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    spc_rng rng;
    spc_rng_seed(&rng, 43, 7);
    int n = spc_test_quick() ? 10000 : 40000;
    for (int i = 0; i < n; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_slab_point_join, &t);
    printf("  %s: %d joins (directly %d, through a diffuse bounce %d; chains of 1-6 vertices %d %d %d %d %d %d; "
           "light tracing's alone %d), found by the flat enumeration %d (on a share of its calls %d), light "
           "tracing's weight above 1/2 on %.0f, below on %.0f, largest gap of the two weights' sum from 1 %.3g\n",
           SLAB_POINT_SCENE, t.joins, t.kinds[0], t.kinds[2], t.by_length[1], t.by_length[2], t.by_length[3],
           t.by_length[4], t.by_length[5], t.by_length[6], t.lt_only, t.matched, t.shared_psi, t.above, t.below,
           t.worst_gap);
    CHECK(t.joins > 50 && t.kinds[0] > 10 && t.kinds[2] > 10 && t.kinds[1] == 0);
    CHECK_MSG(t.by_length[2] > 10 && t.by_length[4] > 10, "joins by 2 and 4 vertices: %d, %d", t.by_length[2],
              t.by_length[4]);
    CHECK_MSG(t.shared_psi > 10, "joins of chains enumerated on a share of the calls: %d", t.shared_psi);
    CHECK_MSG(t.matched > (t.joins - t.lt_only) * 95 / 100, "the flat enumeration finds %d of %d joins' chains",
              t.matched, t.joins - t.lt_only);
    CHECK_MSG(t.worst_gap < 1e-5, "the two weights sum to 1 +- %.3g", t.worst_gap);
    CHECK_MSG(t.lt_only > 10 && t.by_length[5] > 10, "light tracing's alone %d, by 5 vertices %d", t.lt_only,
              t.by_length[5]);
    /* flat glass does not focus: light tracing's density toward the casters passes the camera's
     * spread over the film times the query's roulette on every join measured */
    CHECK(t.above > 0);
    spc_scene_destroy(sc);
}

/* Under the two slabs and a point light the render with ltcaus (light tracing's chains of 1-6
 * vertices through the flat faces, specular NEE's 3- and 4-vertex ones on a share of its calls)
 * agrees with one without (specular NEE's chains of 1-4 vertices at every call; the 6-vertex ones,
 * light tracing's alone, carry too little light to show at this count). */
TEST(slab_point_render_agrees_without_it)
{
    scene_settings_agree(SLAB_POINT_SCENE, SLAB_POINT_PLAN ",ltcaus,flat34=0.3", SLAB_POINT_PLAN, 512, 49,
                         "slabs, point light: ltcaus vs without");
}

/* A join through flat faces toward the pinhole (ltslab): the camera's chain from x2, retraced along
 * the join's direction with its events as the path tracer retraces the camera ray's (path_snee.c),
 * reaches the pinhole; specular NEE's flat enumeration at x2 finds the light chain; its share there
 * 1 / (1 + (r / psi)^2), r from the path tracer's side (the retraced camera chain, the enumerated
 * light chain), and light tracing's weight sum to one. */
typedef struct slab_camera_tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    int joins, through, lt_only, matched, shared_psi, missed_camera;
    int by_length[SPC_CHAIN_MAX_VERTICES + 1];
    double worst_gap, worst_miss;
} slab_camera_tally;

static void check_slab_camera_join(void *user, const spc_path_lt_join *j)
{
    slab_camera_tally *t = user;
    const spc_scene *sc = t->ctx->scene;
    ++t->joins;
    if (!j->cc)
        return;
    ++t->through;
    CHECK(j->e->type == SPC_EMITTER_POINT && j->w > 0.0 && j->w <= 1.0 && j->x1 == NULL);
    int kc = j->cc->n;
    CHECK(spc_flat_chain_covers(j->cc, t->p->reflect) && kc >= 1 && kc <= t->p->lt_slab_max);
    if (kc < 1 || kc > SPC_CHAIN_MAX_VERTICES)
        return;
    if (j->c->n <= SPC_CHAIN_MAX_VERTICES)
        ++t->by_length[j->c->n];
    /* the path tracer's camera chain: retraced from x2 toward the camera with the join's events */
    unsigned char ev[SPC_CHAIN_MAX_VERTICES];
    for (int i = 0; i < kc; ++i)
        ev[i] = j->cc->v[i].event;
    spc_frame f = spc_frame_from_n(j->cc->d0);
    spc_chain_opts o = spc_chain_opts_default(j->cc->n);
    o.events = ev;
    o.any_surface = t->p->any_surface;
    spc_chain cam;
    spc_chain_trace(sc, j->x2, &f, 0.0, 0.0, &o, &cam);
    if (cam.n != j->cc->n || cam.end == SPC_CHAIN_END_TIR || cam.end == SPC_CHAIN_END_MISMATCH ||
        cam.end == SPC_CHAIN_END_DEGENERATE) {
        ++t->missed_camera;
        return;
    }
    /* its last segment passes the pinhole */
    spc_vec3 o_last = cam.v[cam.n - 1].h.p, d_last = cam.v[cam.n - 1].d;
    spc_vec3 to_cam = spc_sub(t->ctx->cam->origin, o_last);
    double miss = spc_length(spc_sub(to_cam, spc_scale(d_last, spc_dot(to_cam, d_last)))) / sc->radius;
    if (miss > t->worst_miss)
        t->worst_miss = miss;
    int kmax = spc_path_lt_budget(t->ctx, t->p, j->x2, j->cc->n + 1, 0);
    double psi = spc_snee_flat_psi(t->p, kmax, SPC_CHAIN_MAX_VERTICES, j->c->n);
    if (!(psi > 0.0)) {
        ++t->lt_only;
        CHECK_MSG(isinf(j->r) && j->w == 1.0, "a join of %d vertices no enumeration makes: r %g, w %g", j->c->n, j->r,
                  j->w);
        return;
    }
    t->shared_psi += psi < 1.0;
    spc_chain found;
    const spc_chain *match = point_light_flat_match(sc, t->p, j, &found);
    if (!match)
        return;
    ++t->matched;
    double r = spc_path_lt_ratio_first(t->ctx, t->p, j->x2, &cam, match, j->e) / psi;
    double gap = fabs(1.0 / (1.0 + r * r) + j->w - 1.0);
    if (gap > t->worst_gap)
        t->worst_gap = gap;
}

#define RING_SCENE "scenes/caustic_mirror_ring.xml"
#define RING_PLAN "angular:camera=0.035,first=0.1,later=0.1"

/* The mirror ring (an open mirror cylinder on a floor under a small sphere light): the area light's
 * subpaths reflected by the wall onto the floor join the pinhole directly; on each join the three
 * weights of its path (specular NEE's through the cylinder's enumerated chain toward y, BSDF
 * sampling's own, light tracing's) sum to one, and light tracing takes the larger share on some. */
TEST(ring_area_weights_sum_to_one)
{
    area_run r;
    if (!area_run_start(&r, RING_SCENE, RING_PLAN ",ltcaus", 73))
        return;
    r.cylinder = true;
    int n = spc_test_quick() ? 2000 : 8000;
    area_run_joins(&r, n);
    const area_tally t = r.t;
    printf("  %s: %d joins (%d enumerated at x2; directly %d, through a diffuse bounce %d; light chains of 1 and 2 "
           "reflections %d %d), light tracing's weight above 1/2 on %.0f, below on %.0f, largest gap of the three "
           "weights' sum from 1 %.3g\n",
           RING_SCENE, t.joins, t.matched, t.kinds[0], t.kinds[2], t.by_length[1], t.by_length[2], t.above, t.below,
           t.worst_gap);
    CHECK_MSG(t.kinds[0] > n / 20, "joins of the floor seen directly: %d of %d subpaths", t.kinds[0], n);
    CHECK_MSG(t.matched > t.joins * 95 / 100, "the cylinder's enumeration at x2 finds %d of %d joins' chains",
              t.matched, t.joins);
    CHECK_MSG(t.worst_gap < 1e-5, "the three weights sum to 1 +- %.3g", t.worst_gap);
    CHECK(t.above > 0 && t.below > 0);
    spc_scene_destroy(r.sc);
}

/* The ring's render with light tracing agrees with the render without it. */
TEST(ring_render_agrees_without_it)
{
    scene_settings_agree(RING_SCENE, RING_PLAN ",ltcaus", RING_PLAN, 256, 79, "ring: ltcaus vs without");
}

#define POOL_SCENE "scenes/caustic_pool.xml"
#define POOL_PLAN "angular:first=0.1,later=0.1"

/* The pool (a sphere light over a normal-mapped water plane, the floor seen through it): the area
 * light's subpaths refracted by the water onto the floor join the pinhole through the plane's
 * one-vertex chains toward it; on each join the three weights of its path (specular NEE's at x2
 * through its enumerated chain toward y, BSDF sampling's own with light tracing in its ratio through
 * the camera's chain, light tracing's) sum to one, light tracing takes the larger share on some and
 * not on others. */
TEST(pool_area_weights_sum_to_one)
{
    area_run r;
    if (!area_run_start(&r, POOL_SCENE, POOL_PLAN ",ltcaus", 67))
        return;
    r.plane = true;
    int n = spc_test_quick() ? 1000 : 4000;
    area_run_joins(&r, n);
    const area_tally t = r.t;
    printf("  %s: %d joins (%d enumerated at x2; through the water %d, directly %d, through a diffuse bounce %d), "
           "light tracing's weight above 1/2 on %.0f, below on %.0f, largest gap of the three weights' sum from 1 "
           "%.3g\n",
           POOL_SCENE, t.joins, t.matched, t.kinds[1], t.kinds[0], t.kinds[2], t.above, t.below, t.worst_gap);
    CHECK_MSG(t.kinds[1] > n / 8, "joins through the water: %d of %d subpaths", t.kinds[1], n);
    CHECK_MSG(t.matched > t.kinds[1] * 95 / 100, "the plane's enumeration at x2 finds %d of %d joins' chains",
              t.matched, t.kinds[1]);
    CHECK_MSG(t.worst_gap < 1e-5, "the three weights sum to 1 +- %.3g", t.worst_gap);
    CHECK(t.above > 0 && t.below > 0);
    spc_scene_destroy(r.sc);
}

/* Does the path tracer's BSDF sampling at the normal-mapped surface seen from o along w (the first
 * hit) send a delta sample along want? Both lobes are tried (u_lobe at either end). *found: whether
 * the ray met a normal-mapped surface at all. */
static bool traced_delta_matches(const spc_scene *sc, spc_vec3 o, spc_vec3 w, spc_vec3 at, spc_vec3 want, bool *found)
{
    spc_ray r = {.o = o, .d = w, .tmin = 1e-5, .tmax = SPC_INF};
    spc_hit h;
    *found = spc_scene_intersect(sc, &r, &h) && h.bsdf && h.bsdf->type == SPC_BSDF_NORMALMAP &&
             spc_length(spc_sub(h.p, at)) < 1e-6 * (1.0 + spc_length(spc_sub(at, o)));
    if (!*found)
        return false;
    const double u_lobe[2] = {1e-3, 1.0 - 1e-3};
    for (int i = 0; i < 2; ++i) {
        spc_bsdf_sample bs;
        if (spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, spc_neg(w), u_lobe[i], spc_v2(0.5, 0.5), &bs) &&
            (bs.lobe & SPC_LOBE_DELTA) && spc_dot(bs.wi, want) > 1.0 - 1e-7)
            return true;
    }
    return false;
}

/* The pool's joins through the water, seen from the path tracer's side. */
typedef struct pool_paths {
    const spc_render_ctx *ctx;
    int camera_joins, camera_checked, camera_miss; /* the camera's vertex on the water */
    int light_checked, light_miss;                 /* the light chain's vertices on the water */
} pool_paths;

static void check_pool_path(void *user, const spc_path_lt_join *j)
{
    pool_paths *t = user;
    const spc_scene *sc = t->ctx->scene;
    bool found;
    if (!j->x1 && j->cc && j->cc->n == 1 && j->cc->v[0].h.bsdf && j->cc->v[0].h.bsdf->type == SPC_BSDF_NORMALMAP) {
        /* the camera's ray through the chain's vertex, sampled by the path tracer toward x2 */
        const spc_chain_vertex *v = &j->cc->v[0];
        spc_vec3 o = t->ctx->cam->origin;
        ++t->camera_joins;
        bool ok = traced_delta_matches(sc, o, spc_normalize(spc_sub(v->h.p, o)), v->h.p, spc_neg(v->wi), &found);
        t->camera_checked += found;
        t->camera_miss += found && !ok;
    }
    /* the light chain from x2: at each vertex on the water, the path tracer's sample from x2's side */
    spc_vec3 o = j->x2->p;
    for (int i = 0; i < j->c->n; ++i) {
        const spc_chain_vertex *v = &j->c->v[i];
        if (v->h.bsdf && v->h.bsdf->type == SPC_BSDF_NORMALMAP) {
            bool ok = traced_delta_matches(sc, o, v->wi, v->h.p, v->d, &found);
            t->light_checked += found;
            t->light_miss += found && !ok;
        }
        o = v->h.p;
    }
}

/* Every join light tracing makes through the pool's water is a path the path tracer makes: at the
 * camera chain's vertex, BSDF sampling from the camera's side (where the normal map's face-view turn
 * is decided by the camera's direction) sends the ray on toward x2, and at the light chain's
 * vertices, sampling from x2's side sends it on toward the light. Where either direction turns the
 * map's normal, the chain solved from the other side is not the path tracer's, and a join there
 * would carry light along a path no other strategy makes. */
TEST(pool_joins_are_path_tracer_paths)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load(POOL_SCENE, POOL_PLAN ",ltcaus", &cam, &p);
    if (!sc)
        return;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    p.lt_share = 1.0;
    ctx.snee = p;
    pool_paths t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    spc_rng rng;
    spc_rng_seed(&rng, 83, 7);
    int n = spc_test_quick() ? 1000 : 4000;
    for (int i = 0; i < n; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_pool_path, &t);
    printf("  %s: %d joins through the water (%d retraced from the camera, %d not the path tracer's); light chains' "
           "vertices on the water %d (%d not the path tracer's)\n",
           POOL_SCENE, t.camera_joins, t.camera_checked, t.camera_miss, t.light_checked, t.light_miss);
    CHECK_MSG(t.camera_joins > n / 8, "joins through the water: %d of %d subpaths", t.camera_joins, n);
    CHECK_MSG(t.camera_checked > t.camera_joins * 9 / 10, "camera rays retraced: %d of %d", t.camera_checked,
              t.camera_joins);
    CHECK_MSG(t.light_checked > n / 8, "light chains' vertices retraced: %d", t.light_checked);
    CHECK_MSG(t.camera_miss == 0, "joins whose camera vertex the path tracer samples elsewhere: %d", t.camera_miss);
    CHECK_MSG(t.light_miss == 0, "joins whose light vertex the path tracer samples elsewhere: %d", t.light_miss);
    spc_scene_destroy(sc);
}

/* The converse, on the path tracer's side: a camera ray refracted by the water onto x2, weighed
 * against light tracing through the camera's chain retraced from x2 (as the path tracer's
 * alt_chain_ratio does). Where the retraced chain does not leave the water toward the pinhole (the
 * camera's direction turned the map's normal there, so the chain solved from x2 is not the camera's
 * path), light tracing, which joins x2 by chains solved from x2, never makes the path and must get no
 * share of it (ratio 0); elsewhere it gets one. A grid of camera rays over the water's far half, toward each
 * ray's floor point the area light's chains through the water from its point nearest x2. */
TEST(pool_turned_camera_paths_not_light_tracings)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load(POOL_SCENE, POOL_PLAN ",ltcaus", &cam, &p);
    if (!sc)
        return;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    p.lt_share = 1.0;
    ctx.snee = p;
    const spc_emitter *e = NULL;
    for (int i = 0; i < sc->nemitters; ++i)
        if (sc->emitters[i]->type == SPC_EMITTER_AREA)
            e = sc->emitters[i];
    CHECK(e != NULL && e->shape != NULL);
    if (!e || !e->shape) {
        spc_scene_destroy(sc);
        return;
    }
    spc_vec3 o = ctx.cam->origin, lc = e->shape->center;
    double lr = e->shape->radius;
    int m = spc_test_quick() ? 100 : 160, turned = 0, turned_shared = 0, straight = 0, straight_shared = 0;
    for (int a = 0; a < m; ++a)
        for (int b = 0; b < m; ++b) {
            /* the far half, where the camera sees the water at its most oblique */
            spc_vec3 target = spc_v3(-1.5 + 3.0 * (a + 0.5) / m, 0.0, -1.5 + 1.5 * (b + 0.5) / m);
            spc_ray r = {.o = o, .d = spc_normalize(spc_sub(target, o)), .tmin = 0.0, .tmax = SPC_INF};
            spc_hit hb;
            if (!spc_scene_intersect(sc, &r, &hb) || !hb.bsdf || hb.bsdf->type != SPC_BSDF_NORMALMAP)
                continue;
            spc_bsdf_sample bs;
            bool refracted = false;
            for (int i = 0; i < 2 && !refracted; ++i)
                refracted = spc_bsdf_sample_dir(hb.bsdf, &hb, SPC_MODE_RADIANCE, spc_neg(r.d), i ? 0.999 : 0.001,
                                                spc_v2(0.5, 0.5), &bs) &&
                            bs.lobe == SPC_LOBE_DELTA_TRANSMISSION;
            spc_hit x2;
            spc_ray r2 = spc_hit_spawn(&hb, bs.wi);
            if (!refracted || !spc_scene_intersect(sc, &r2, &x2) || !x2.bsdf || x2.bsdf->type != SPC_BSDF_DIFFUSE)
                continue;
            spc_vec3 wo2 = spc_neg(bs.wi);
            /* the camera's chain retraced from x2, as the path tracer's side does */
            unsigned char ev[1] = {SPC_CHAIN_REFRACT};
            spc_frame f = spc_frame_from_n(wo2);
            spc_chain_opts co = spc_chain_opts_default(1);
            co.events = ev;
            co.any_surface = p.any_surface;
            spc_chain cc;
            spc_chain_trace(sc, &x2, &f, 0.0, 0.0, &co, &cc);
            if (cc.n != 1 || cc.end == SPC_CHAIN_END_TIR || cc.end == SPC_CHAIN_END_MISMATCH ||
                cc.end == SPC_CHAIN_END_DEGENERATE)
                continue;
            bool is_turned = spc_dot(cc.v[0].d, spc_neg(r.d)) < 1.0 - 1e-4; /* past the retrace's rounding */
            /* the light's point nearest x2, and specular NEE's chains from x2 toward it */
            spc_vec3 ny = spc_normalize(spc_sub(x2.p, lc));
            spc_vec3 y = spc_add(lc, spc_scale(ny, lr));
            spc_snee_query q;
            spc_snee_query_init(&q, sc, &p, &x2, wo2, 1);
            q.y = y;
            q.ny = ny;
            spc_chain all[16];
            int n = spc_plane_chains_all(&q, p.reflect, all, 16, NULL);
            bool shared = false;
            for (int i = 0; i < n; ++i)
                shared = shared || spc_path_lt_area_ratio(&ctx, &p, NULL, spc_v3(0, 0, 0), &x2, wo2, &cc, &all[i], e, y,
                                                          ny) > 0.0;
            if (n < 1)
                continue;
            turned += is_turned;
            turned_shared += is_turned && shared;
            straight += !is_turned;
            straight_shared += !is_turned && shared;
        }
    printf("  %s: camera paths through the water with light chains at x2: %d where the camera turns the map's "
           "normal (%d given to light tracing), %d elsewhere (%d given)\n",
           POOL_SCENE, turned, turned_shared, straight, straight_shared);
    CHECK_MSG(turned > 0, "no camera path through a turned normal (%d)", turned);
    CHECK_MSG(turned_shared == 0, "light tracing shares %d of %d camera paths it never makes", turned_shared, turned);
    CHECK_MSG(straight_shared > straight / 4, "light tracing shares %d of %d camera paths", straight_shared, straight);
    spc_scene_destroy(sc);
}

/* A ray from o along w refracted by the normal-mapped water it meets first (BSDF sampling in mode,
 * the transmission lobe), then to the plane through q of normal nq: the point there, and in *eta the
 * sample's relative index. False where it does not go so. */
static bool refract_to_plane(const spc_scene *sc, spc_vec3 o, spc_vec3 w, spc_transport mode, spc_vec3 q, spc_vec3 nq,
                             spc_vec3 *out, double *eta)
{
    spc_ray r = {.o = o, .d = w, .tmin = 1e-5, .tmax = SPC_INF};
    spc_hit h;
    if (!spc_scene_intersect(sc, &r, &h) || !h.bsdf || h.bsdf->type != SPC_BSDF_NORMALMAP)
        return false;
    for (int i = 0; i < 2; ++i) {
        spc_bsdf_sample bs;
        if (!spc_bsdf_sample_dir(h.bsdf, &h, mode, spc_neg(w), i ? 0.999 : 0.001, spc_v2(0.5, 0.5), &bs) ||
            bs.lobe != SPC_LOBE_DELTA_TRANSMISSION)
            continue;
        double den = spc_dot(bs.wi, nq);
        if (!(fabs(den) > 1e-12))
            return false;
        *out = spc_add(h.p, spc_scale(bs.wi, spc_dot(spc_sub(q, h.p), nq) / den));
        *eta = bs.eta;
        return true;
    }
    return false;
}

/* |dA / dw| of the map from the direction w at o, through the water, to the plane (q, nq): central
 * differences over two orthogonal turns of w by eps; 0 where a ray fails. *eta as refract_to_plane. */
static double area_per_solid_angle_eps(const spc_scene *sc, spc_vec3 o, spc_vec3 w, spc_transport mode, spc_vec3 q,
                                       spc_vec3 nq, double eps, double *eta)
{
    spc_frame f = spc_frame_from_n(w);
    spc_vec3 p[4];
    const spc_vec3 axes[2] = {f.s, f.t};
    for (int k = 0; k < 4; ++k) {
        spc_vec3 wk = spc_normalize(spc_add(w, spc_scale(axes[k / 2], k % 2 ? -eps : eps)));
        if (!refract_to_plane(sc, o, wk, mode, q, nq, &p[k], eta))
            return 0.0;
    }
    spc_vec3 da = spc_scale(spc_sub(p[0], p[1]), 0.5 / eps), db = spc_scale(spc_sub(p[2], p[3]), 0.5 / eps);
    return fabs(spc_dot(spc_cross(da, db), nq));
}

/* The same at eps 1e-4 (past the hits' rounding: 1e-6 gives 3% noise), where the differences at half
 * that agree within 1e-3 (not across an edge of the map's bilinear cells, where the normal's
 * derivative jumps); 0 elsewhere. */
static double area_per_solid_angle(const spc_scene *sc, spc_vec3 o, spc_vec3 w, spc_transport mode, spc_vec3 q,
                                   spc_vec3 nq, double *eta)
{
    double a = area_per_solid_angle_eps(sc, o, w, mode, q, nq, 1e-4, eta);
    double b = area_per_solid_angle_eps(sc, o, w, mode, q, nq, 5e-5, eta);
    return a > 0.0 && fabs(b / a - 1.0) < 1e-3 ? a : 0.0;
}

/* The shading normal's factor |w_prev.n| |w_next.N| / (|w_prev.N| |w_next.n|) at a chain vertex on the
 * water (n the map's normal, N the plane's), w_prev toward the light's side of the flux. */
static double water_fix(const spc_chain_vertex *v, spc_vec3 w_prev, spc_vec3 w_next)
{
    spc_vec3 n = v->h.sh.n, N = v->h.n_unmapped;
    return spc_absdot(w_prev, n) * spc_absdot(w_next, N) / (spc_absdot(w_prev, N) * spc_absdot(w_next, n));
}

typedef struct water_jacobians {
    const spc_render_ctx *ctx;
    int camera, camera_ok, camera_fix_matters; /* camera chains checked, agreeing within 1e-3, |fix - 1| > 1% */
    int light, light_ok, light_fix_matters;
    double camera_worst, light_worst;
} water_jacobians;

static void check_water_jacobians(void *user, const spc_path_lt_join *j)
{
    water_jacobians *t = user;
    const spc_scene *sc = t->ctx->scene;
    if (j->x1 || !j->cc || j->cc->n != 1 || j->c->n != 1 || !j->cc->v[0].h.normal_mapped || !j->c->v[0].h.normal_mapped)
        return;
    spc_vec3 q = j->x2->p, nq = j->x2->ng;
    double cos_x2 = spc_absdot(j->cc->d0, nq), eta = 0.0;
    /* the camera's side: |dw_camera / dA(x2)| = eta^2 fix(B) cos(x2) |dw(x2) / dA(camera)| */
    const spc_chain_vertex *b = &j->cc->v[0];
    spc_vec3 o = t->ctx->cam->origin;
    double a = area_per_solid_angle(sc, o, spc_normalize(spc_sub(b->h.p, o)), SPC_MODE_RADIANCE, q, nq, &eta);
    if (a > 0.0) {
        double fix = water_fix(b, spc_neg(b->wi), b->d);
        double want = eta * eta * fix * cos_x2 * spc_chain_geometry(j->cc, o, spc_neg(b->d));
        double gap = fabs(want * a - 1.0);
        ++t->camera;
        t->camera_ok += gap < 1e-3;
        t->camera_fix_matters += fabs(fix - 1.0) > 0.01;
        if (gap > t->camera_worst)
            t->camera_worst = gap;
    }
    /* the light's side: the flux carried past A, (1 / eta^2) fix(A), is cos(x2) |dw(x2) / dA(y)| |dA(x2) / dw0| */
    const spc_chain_vertex *v = &j->c->v[0];
    a = area_per_solid_angle(sc, j->y, spc_normalize(spc_sub(v->h.p, j->y)), SPC_MODE_IMPORTANCE, q, nq, &eta);
    if (a > 0.0) {
        double fix = water_fix(v, v->d, spc_neg(v->wi));
        double want = fix / (eta * eta);
        double got = spc_absdot(j->c->d0, nq) * spc_chain_geometry(j->c, j->y, spc_neg(v->d)) * a;
        double gap = fabs(got / want - 1.0);
        ++t->light;
        t->light_ok += gap < 1e-3;
        t->light_fix_matters += fabs(fix - 1.0) > 0.01;
        if (gap > t->light_worst)
            t->light_worst = gap;
    }
}

/* The measure light tracing's joins through the water convert by, checked against finite differences
 * of the path tracer's own refractions: on the camera's side, the solid angle at the pinhole per unit
 * area at x2 is eta^2 times the normal map's shading factor at the water vertex times cos(x2) times
 * the chain's geometry term from x2 (which the joins carry); on the light's side, the flux a light
 * subpath carries past the water, over the radiance throughput, is the shading factor over eta^2.
 * Both shading factors differ from 1 by more than 1% on most joins: without them (pool34's build)
 * light tracing's estimate through the water was biased low. */
TEST(pool_water_jacobians)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load(POOL_SCENE, POOL_PLAN ",ltcaus", &cam, &p);
    if (!sc)
        return;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    p.lt_share = 1.0;
    ctx.snee = p;
    water_jacobians t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    spc_rng rng;
    spc_rng_seed(&rng, 89, 7);
    int n = spc_test_quick() ? 500 : 2000;
    for (int i = 0; i < n; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_water_jacobians, &t);
    printf("  %s: camera side %d joins, %d within 1e-3 (worst %.3g), shading factor past 1%% on %d; light side %d, "
           "%d within 1e-3 (worst %.3g), factor past 1%% on %d\n",
           POOL_SCENE, t.camera, t.camera_ok, t.camera_worst, t.camera_fix_matters, t.light, t.light_ok, t.light_worst,
           t.light_fix_matters);
    CHECK_MSG(t.camera > n / 10 && t.light > n / 10, "joins checked: %d, %d", t.camera, t.light);
    CHECK_MSG(t.camera_ok >= t.camera * 98 / 100, "camera side: %d of %d agree", t.camera_ok, t.camera);
    CHECK_MSG(t.light_ok >= t.light * 98 / 100, "light side: %d of %d agree", t.light_ok, t.light);
    CHECK_MSG(t.camera_fix_matters > t.camera / 4 && t.light_fix_matters > t.light / 4,
              "the shading factors matter on %d and %d joins", t.camera_fix_matters, t.light_fix_matters);
    spc_scene_destroy(sc);
}

/* The pool's render with light tracing through the water agrees with the render without it. */
TEST(pool_render_agrees_without_it)
{
    scene_settings_agree(POOL_SCENE, POOL_PLAN ",ltcaus", POOL_PLAN, 256, 71, "pool: ltcaus vs without");
}

/* Two glass slabs under a point light with ltslab: the floor seen through a slab gets joins (chains
 * of 1-2 flat faces toward the pinhole) carrying light chains of every length light tracing makes,
 * the 3- and 4-vertex ones on a share of specular NEE's calls (flat34=0.3) and the 5- and 6-vertex
 * ones light tracing's alone; on each shared one the path tracer's weight (from the camera chain it
 * retraces) and light tracing's sum to one. Without ltslab no join goes through a flat chain. */
TEST(slab_camera_point_weights_sum_to_one)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load(SLAB_POINT_SCENE, SLAB_POINT_PLAN ",ltcaus,flat34=0.3,ltslab", &cam, &p);
    if (!sc)
        return;
    p.mis = true;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_enabled(&ctx, &p) && p.lt_slab && p.lt_slab_max == 2);
    slab_camera_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    spc_rng rng;
    spc_rng_seed(&rng, 59, 3);
    int n = spc_test_quick() ? 10000 : 40000;
    for (int i = 0; i < n; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_slab_camera_join, &t);
    printf("  %s, ltslab: %d joins, %d through flat faces toward the pinhole (light chains of 1-6 vertices %d %d "
           "%d %d %d %d; light tracing's alone %d), found by the flat enumeration %d (on a share of its calls %d), "
           "camera chains not retraced %d, the retraced chain's largest miss of the pinhole %.3g (scene radii), "
           "largest gap of the two weights' sum from 1 %.3g\n",
           SLAB_POINT_SCENE, t.joins, t.through, t.by_length[1], t.by_length[2], t.by_length[3], t.by_length[4],
           t.by_length[5], t.by_length[6], t.lt_only, t.matched, t.shared_psi, t.missed_camera, t.worst_miss,
           t.worst_gap);
    CHECK_MSG(t.through > 50, "joins through flat faces toward the pinhole: %d", t.through);
    CHECK_MSG(t.shared_psi > 10 && t.lt_only > 0, "shared on a share of the calls %d, light tracing's alone %d",
              t.shared_psi, t.lt_only);
    CHECK_MSG(t.missed_camera == 0 && t.worst_miss < SPC_SNEE_FLAT_POLISH_TOL_SCENE, "camera chains not retraced %d, miss %.3g", t.missed_camera,
              t.worst_miss);
    CHECK_MSG(t.matched > (t.through - t.lt_only) * 95 / 100, "the flat enumeration finds %d of %d joins' chains",
              t.matched, t.through - t.lt_only);
    CHECK_MSG(t.worst_gap < 1e-5, "the two weights sum to 1 +- %.3g", t.worst_gap);
    /* without ltslab: none */
    p.lt_slab = false;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    for (int i = 0; i < n / 4; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_slab_camera_join, &t);
    CHECK_MSG(t.joins > 0 && t.through == 0, "without ltslab: %d joins, %d through flat faces", t.joins, t.through);
    spc_scene_destroy(sc);
}

/* Under the two slabs and a point light the render with ltslab and the 3- and 4-vertex light chains
 * on a share of specular NEE's calls (flat34=0.3: light tracing's weight of the floor seen through
 * a slab carries psi) agrees with ltslab and those chains at every call. Not against a render
 * without ltslab: that one lacks the 5- and 6-vertex light chains onto the floor seen through a
 * slab (light tracing's alone), 0.3% of this image, which fail the z-test in its pixels at 512 spp
 * (both agree with specular NEE's enumeration of every length at every call, long=1,flat5=1,flat6=1:
 * bench/RESULTS.md, part rcvslab30). */
TEST(slab_camera_point_render_agrees_with_the_share)
{
    scene_settings_agree(SLAB_POINT_SCENE, SLAB_POINT_PLAN ",ltcaus,flat34=0.3,ltslab",
                         SLAB_POINT_PLAN ",ltcaus,ltslab", 512, 61, "slabs, point light, ltslab: flat34=0.3 vs 1");
}

/* The same with the track and light tracing's flat chains up to 8 vertices (longmax=8): the chains
 * the enumeration leaves out (partial reflections inside the glass, 7-8 vertices) split between
 * BSDF sampling and light tracing. */
TEST(slab_render_long_agrees_without_it)
{
    scene_settings_agree(SLAB_SCENE, "angular:camera=0.036,first=0.1,later=0.1,long=0.3,flat5=0.3,longmax=8,ltcaus",
                         "angular:camera=0.036,first=0.1,later=0.1,long=0.3,flat5=0.3,longmax=8", 512, 53,
                         "slabs, longmax=8: ltcaus vs without");
}

/* With an area light the render with ltcaus agrees with one without (the same paths, split three
 * ways instead of two). */
TEST(area_light_render_agrees_without_it)
{
    spc_scene *sc = tu_load("bench/check/ball_small_light.xml", 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *a = tu_render_nee(sc, "path", AREA_SETTING, 512, 2, 43, NULL);
    spc_film *b = tu_render_nee(sc, "path", "angular:camera=0.098,first=0.1,later=0.1", 512, 2, 44, NULL);
    CHECK(a && b);
    if (a && b) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(a, b, 0.99, "area light: ltcaus vs without", &d));
        printf("    z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction, d.ztest_pixels,
               d.mean_a[0], d.mean_b[0]);
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_scene_destroy(sc);
}

/* The same with every camera sample's subpath joined through the sphere's longer chains too
 * (ltlong=1): the floor under the ball seen through it after reflections inside it is made by light
 * tracing as well, and the render still agrees with one without ltcaus. */
TEST(area_light_long_render_agrees_without_it)
{
    scene_settings_agree("bench/check/ball_small_light.xml", AREA_SETTING ",ltshare=1,ltlong=1",
                         "angular:camera=0.098,first=0.1,later=0.1", 512, 45,
                         "area light, ltlong=1: ltcaus vs without");
}

/* An area light's subpaths join through no middle vertex (those joins are point lights' only: the
 * path tracer's side weighs area lights' paths against light tracing at the first and second
 * receiver), and with the longer chains on every subpath they join the pinhole through the sphere's
 * chains longer than max_chain (in, reflections inside, out). */
static void count_area_extra(void *user, const spc_path_lt_join *j)
{
    int *n = user;
    ++n[0];
    if (j->nmid > 0)
        ++n[1];
    if (j->cc && j->cc->n > 2)
        ++n[2];
}

TEST(area_light_joins_only_at_the_first_two_receivers)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load("bench/check/ball_small_light.xml", AREA_SETTING, &cam, &p);
    if (!sc)
        return;
    CHECK(p.max_chain == 2);
    p.lt_through = 1.0;
    p.lt_long = 1.0;
    p.lt_share = 1.0;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    int n[3] = {0, 0, 0};
    spc_rng rng;
    spc_rng_seed(&rng, 37, 7);
    for (int i = 0; i < 40000; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, count_area_extra, n);
    printf("    %d joins, %d through a middle vertex, %d through a chain longer than max_chain\n", n[0], n[1], n[2]);
    CHECK(n[0] > 1000);
    CHECK_MSG(n[1] == 0 && n[2] > 10, "%d joins through a middle vertex, %d through longer chains", n[1], n[2]);

    /* the path tracer's side: at the second receiver light tracing is in BSDF sampling's weight
     * (params.alt_chain_ratio), at the third (after a middle vertex) only point lights' delta
     * share is */
    spc_hit h;
    spc_ray ray = {.o = spc_v3(1.0, 1.0, 1.0), .d = spc_v3(0, -1, 0), .tmin = 0.0, .tmax = SPC_INF};
    CHECK(spc_scene_intersect(sc, &ray, &h));
    for (int nmid = 0; nmid < 2; ++nmid) {
        spc_path_snee s;
        memset(&s, 0, sizeof s);
        s.on = true;
        s.p = p;
        s.ctx = &ctx;
        s.lt_enabled = s.lt_on = true;
        s.lt_x1 = h;
        s.lt_w1 = spc_v3(0, 1, 0);
        s.lt_nmid = nmid;
        s.receivers = 1 + nmid;
        if (nmid > 0)
            s.lt_mid[0] = (spc_path_lt_vertex){h, spc_v3(0, 1, 0), spc_v3(0, 1, 0)};
        spc_sampler smp;
        spc_sampler_start(&smp, 0, 0, 0, 1);
        (void)spc_path_snee_at_vertex(&s, &ctx, &h, spc_v3(0, 1, 0), 2 + nmid, &smp);
        CHECK_MSG(s.p.delta_share != NULL && (s.p.alt_chain_ratio != NULL) == (nmid == 0),
                  "%d middle vertices: delta share %d, light tracing in BSDF sampling's weight %d", nmid,
                  s.p.delta_share != NULL, s.p.alt_chain_ratio != NULL);
    }
    spc_scene_destroy(sc);
}

/* ---- the light guides ---- */

#define GUIDE_SCENE "scenes/caustic_sdf_torus.xml"
#define GUIDE_SETTING "angular:camera,first=0.1,later=0.1,ltguide=1"

typedef struct guide_tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    int joins, kmin, kmax, above, below;
    double worst_gap;
} guide_tally;

/* A light-guide join's two weights: light tracing's, and BSDF sampling's as the path tracer's
 * hooks (path_snee.h) give it when fed the same path from the camera's side: x's non-delta
 * scattering toward the chain, each chain vertex's delta scattering, the light's hit. */
static void check_guide_join(void *user, const spc_path_lt_guide_join *j)
{
    guide_tally *t = user;
    ++t->joins;
    t->kmin = j->k < t->kmin ? j->k : t->kmin;
    t->kmax = j->k > t->kmax ? j->k : t->kmax;
    CHECK(j->w > 0.0 && j->w <= 1.0 && j->e->type == SPC_EMITTER_AREA);
    spc_path_snee s;
    memset(&s, 0, sizeof s);
    s.on = true;
    s.p = *t->p;
    s.ctx = t->ctx;
    s.lg_enabled = spc_path_lt_guide_enabled(t->ctx, t->p);
    s.lg_min = spc_path_lt_guide_min_chain(t->ctx, t->p);
    spc_path_snee_scattered(&s, j->x, j->wo, j->d0, SPC_LOBE_DIFFUSE_REFLECTION);
    for (int i = j->k - 1; i >= 0; --i) {
        const spc_hit *h = &j->v[i];
        spc_vec3 prev = i == j->k - 1 ? j->x->p : j->v[i + 1].p, next = i == 0 ? j->y : j->v[i - 1].p;
        spc_vec3 wo = spc_normalize(spc_sub(prev, h->p)), wi = spc_normalize(spc_sub(next, h->p));
        bool refl = spc_dot(wo, h->ng) * spc_dot(wi, h->ng) > 0.0;
        spc_path_snee_scattered(&s, h, wo, wi, refl ? SPC_LOBE_DELTA_REFLECTION : SPC_LOBE_DELTA_TRANSMISSION);
    }
    spc_hit lh;
    memset(&lh, 0, sizeof lh);
    lh.p = j->y;
    lh.ng = j->ny;
    lh.emitter = j->e;
    lh.shape = j->e->shape;
    double w_path = spc_path_snee_emitter_weight(&s, t->ctx, &lh);
    double gap = fabs(w_path + j->w - 1.0);
    if (gap > t->worst_gap) {
        t->worst_gap = gap;
        if (gap > 1e-6)
            printf("    gap %.3g: k %d, w_path %.6f, w_lt %.6f (r %.4g)\n", gap, j->k, w_path, j->w, j->r);
    }
    t->above += j->r > 1.0;
    t->below += j->r < 1.0;
}

/* The light guides of the glass SDF torus: every join is a chain longer than any specular NEE's
 * (here 6 vertices, the longer chains' bound), the ring's internal-reflection chains of 8 vertices
 * and more among them,
 * and on each join light tracing's weight and the one the path tracer's hooks give BSDF sampling
 * for the same path sum to one (the ratio r from the path's ends, the same function on both
 * sides). Under this small light light tracing takes the larger share (r > 1) on the joins. */
TEST(guide_weights_sum_to_one)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load(GUIDE_SCENE, GUIDE_SETTING, &cam, &p);
    if (!sc)
        return;
    p.mis = true; /* as the path tracer runs the parameters (path_snee.c) */
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_guide_enabled(&ctx, &p) && !spc_path_lt_enabled(&ctx, &p));
    /* past the longer chains' 6 vertices, which specular NEE's randomized attempts make (long) */
    CHECK(spc_path_lt_guide_min_chain(&ctx, &p) == 7);
    guide_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    t.kmin = SPC_PATH_LT_GUIDE_MAX + 1;
    spc_rng rng;
    spc_rng_seed(&rng, 51, 7);
    for (int i = 0; i < 120000; ++i)
        spc_path_lt_guide_joins(&ctx, &p, &rng, check_guide_join, &t);
    printf("  %d joins, chains of %d to %d vertices, light tracing's share above 1/2 on %d, below on %d, largest "
           "gap of the two weights' sum from 1 %.3g\n",
           t.joins, t.kmin, t.kmax, t.above, t.below, t.worst_gap);
    CHECK(t.joins > 30 && t.kmin >= 7 && t.kmax >= 8);
    CHECK_MSG(t.worst_gap < 1e-6, "the two weights sum to 1 +- %.3g", t.worst_gap);
    CHECK(t.above > t.joins / 2);
    spc_scene_destroy(sc);
}

/* The path tracer's side follows a light guide from the camera ray's hit only, through delta
 * scatterings at chain surfaces only: a first hit after a delta scattering, or a second non-delta
 * scattering, ends it. */
TEST(guide_path_side_from_the_first_hit)
{
    spc_path_snee s;
    memset(&s, 0, sizeof s);
    s.lg_enabled = true;
    spc_hit h;
    memset(&h, 0, sizeof h);
    spc_bsdf diffuse;
    memset(&diffuse, 0, sizeof diffuse);
    diffuse.type = SPC_BSDF_DIFFUSE;
    h.bsdf = &diffuse;
    spc_vec3 wo = spc_v3(0, 1, 0), wi = spc_v3(0, 0, 1);
    spc_path_snee_scattered(&s, &h, wo, wi, SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK(s.lg_on && s.lg_k == 0);
    spc_path_snee_scattered(&s, &h, wo, wi, SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK(!s.lg_on);
    spc_path_snee t;
    memset(&t, 0, sizeof t);
    t.lg_enabled = true;
    spc_path_snee_scattered(&t, &h, wo, wi, SPC_LOBE_DELTA_REFLECTION);
    spc_path_snee_scattered(&t, &h, wo, wi, SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK(!t.lg_on);
}

/* With the light guides the torus renders as without (the same paths, split two ways), under a
 * larger light whose guided light BSDF sampling also finds often. */
TEST(guide_render_agrees_without_it)
{
    char path[1024];
    const char *d = getenv("SPC_SOURCE_DIR");
    snprintf(path, sizeof path, "%s/%s", d ? d : ".", GUIDE_SCENE);
    spc_define defs[3] = {{"res", "16"}, {"light_radius", "0.3"}, {"light_radiance", "40, 38, 34"}};
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    CHECK(spc_scene_load(path, defs, 3, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    settings_agree(sc, GUIDE_SETTING, "angular:camera,first=0.1,later=0.1", 256, 45, "light guides vs without");
    spc_scene_destroy(sc);
}

/* The slabs' light guides: scenes/caustic_slabs.xml (max_depth 12) with the plan's setting for slabs
 * under larger lights and the light guides. Light tracing through flat faces (ltcaus) stops at the
 * track's 8 vertices; the light guides start one past it, at 9, so the two strategies' subpaths are
 * disjoint. slab_a guides light along itself by total internal reflection between its two large
 * faces and leaves it onto the floor through a side face after 10 vertices: on each such join the
 * two weights (light tracing's and the one the path tracer's hooks give BSDF sampling for the same
 * path) sum to one. */
#define SLAB_GUIDE_SCENE "scenes/caustic_slabs.xml"
#define SLAB_GUIDE_SETTING "angular:camera=0.033,first=0.1,later=0.1" SPC_SNEE_PLAN_FLAT_LARGE ",ltguide=1"

TEST(slab_guide_weights_sum_to_one)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = lt_load(SLAB_GUIDE_SCENE, SLAB_GUIDE_SETTING, &cam, &p);
    if (!sc)
        return;
    p.mis = true;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    ctx.max_depth = sc->integrator.max_depth;
    CHECK(ctx.max_depth == 12);
    CHECK(spc_path_lt_guide_enabled(&ctx, &p) && spc_path_lt_enabled(&ctx, &p));
    CHECK(spc_path_lt_guide_min_chain(&ctx, &p) == 9);
    guide_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    t.kmin = SPC_PATH_LT_GUIDE_MAX + 1;
    spc_rng rng;
    spc_rng_seed(&rng, 53, 7);
    int n = getenv("SPC_TEST_QUICK") ? 100000 : 400000;
    for (int i = 0; i < n; ++i)
        spc_path_lt_guide_joins(&ctx, &p, &rng, check_guide_join, &t);
    printf("  %d joins, chains of %d to %d vertices, light tracing's share above 1/2 on %d, below on %d, largest "
           "gap of the two weights' sum from 1 %.3g\n",
           t.joins, t.kmin, t.kmax, t.above, t.below, t.worst_gap);
    CHECK(t.joins > 20 && t.kmin >= 9 && t.kmax <= 10);
    CHECK_MSG(t.worst_gap < 1e-6, "the two weights sum to 1 +- %.3g", t.worst_gap);
    spc_scene_destroy(sc);
}

/* With the light guides the slabs render as with specular NEE off: per-pixel z-test and image
 * means, 8 x 8, under a light of radius 0.4 (the same power), whose guided light BSDF sampling
 * finds often enough for the reference. */
TEST(slab_guide_render_agrees_with_none)
{
    char path[1024];
    const char *d = getenv("SPC_SOURCE_DIR");
    snprintf(path, sizeof path, "%s/%s", d ? d : ".", SLAB_GUIDE_SCENE);
    spc_define defs[3] = {{"res", "8"}, {"light_radius", "0.4"}, {"light_radiance", "10.8, 10.35, 9.45"}};
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    CHECK(spc_scene_load(path, defs, 3, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    bool quick = getenv("SPC_TEST_QUICK") != NULL;
    spc_film *img = tu_render_nee(sc, "path", SLAB_GUIDE_SETTING, quick ? 64 : 256, 2, 47, NULL);
    spc_film *ref = tu_render_nee(sc, "path", "none", quick ? 4096 : 16384, 2, 48, NULL);
    CHECK(img && ref);
    if (img && ref) {
        spc_diff_result r;
        memset(&r, 0, sizeof r);
        CHECK(tu_image_agrees(img, ref, 0.99, "slab light guides vs none", &r));
        double mi, si, mr, sr;
        tu_image_mean(img, 1, &mi, &si);
        tu_image_mean(ref, 1, &mr, &sr);
        CHECK_MSG(fabs(mi - mr) < 4.0 * sqrt(si * si + sr * sr), "image means %.5f +- %.5f vs %.5f +- %.5f", mi, si, mr,
                  sr);
        printf("    z-test pass %.4f of %d pixels; means %.5f +- %.5f vs %.5f +- %.5f\n", r.ztest_pass_fraction,
               img->width * img->height, mi, si, mr, sr);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

/* A spot light's light guided through a glass slab (bench/check/spot_slab_guide.xml, max_depth 10):
 * in through the slab's near end, five total internal reflections, out through its far end onto the
 * floor, 7 vertices, longer than the chains light tracing's caustics follow from a point light
 * (SPC_FLAT_MAX_VERTICES) and than any specular NEE makes, and never met by BSDF sampling. The light
 * guides' joins from the spot carry chains of 7 and 8 vertices, each weighed 1; with them the floor
 * seen directly agrees with bdpt (floor_pixels_agree: the z-test on 0.99 of the pixels where bdpt
 * reads at least 0.01 of its mean, their sums within 3 standard errors), and so does pixel (1, 12)
 * at 16 x 16, where the guided light lands (within 3 standard errors), which without them reads low
 * by more than 5 (the test sees the light they add: a fifth of that pixel). With the long pass up to 8
 * vertices (long=1,longmax=8) the guides still start at 7 and specular NEE weighs its point-light
 * chains of 7 and 8 at the camera ray's hit 0: the same joins, and the render agrees with bdpt too
 * (a length counted twice would read high, one left to the long pass's rare finds low). */
#define SPOT_GUIDE_SCENE "bench/check/spot_slab_guide.xml"
#define SPOT_GUIDE_PLAN "angular:camera=0.025,first=0.1,later=0.1,ltcaus,ltslab,flat34=0.1"

static void tally_spot_guide(void *user, const spc_path_lt_guide_join *j)
{
    guide_tally *t = user;
    ++t->joins;
    t->kmin = j->k < t->kmin ? j->k : t->kmin;
    t->kmax = j->k > t->kmax ? j->k : t->kmax;
    double gap = fabs(j->w - 1.0);
    t->worst_gap = gap > t->worst_gap ? gap : t->worst_gap;
}

TEST(spot_slab_guide_joins_weigh_one)
{
    /* with the long pass up to 8 vertices too: its point-light chains of 7 and 8 at the camera ray's
     * hit are the guides' (weighed 0 on specular NEE's side), so the guides still start at 7 */
    static const char *const settings[] = {SPOT_GUIDE_PLAN ",ltguide", SPOT_GUIDE_PLAN ",ltguide,long=1,longmax=8"};
    for (int s = 0; s < 2; ++s) {
        spc_camera_state cam;
        spc_snee_params p;
        spc_scene *sc = lt_load(SPOT_GUIDE_SCENE, settings[s], &cam, &p);
        if (!sc)
            return;
        CHECK(sc->nemitters == 1 && sc->emitters[0]->type == SPC_EMITTER_SPOT);
        spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
        ctx.max_depth = sc->integrator.max_depth;
        CHECK(ctx.max_depth == 10);
        CHECK(spc_path_lt_guide_enabled(&ctx, &p) && spc_path_lt_enabled(&ctx, &p));
        CHECK(spc_path_lt_guide_point_min_chain(&ctx, &p) == SPC_FLAT_MAX_VERTICES + 1);
        /* an area light's guides start past the long pass (as the path runs it, with MIS) */
        spc_snee_params pm = p;
        pm.mis = true;
        CHECK(spc_path_lt_guide_min_chain(&ctx, &pm) == (s == 0 ? SPC_FLAT_MAX_VERTICES + 1 : 9));
        guide_tally t;
        memset(&t, 0, sizeof t);
        t.kmin = SPC_PATH_LT_GUIDE_MAX + 1;
        spc_rng rng;
        spc_rng_seed(&rng, 57, 7);
        int n = getenv("SPC_TEST_QUICK") ? 100000 : 400000;
        for (int i = 0; i < n; ++i)
            spc_path_lt_guide_joins(&ctx, &p, &rng, tally_spot_guide, &t);
        printf("  %s: %d joins, chains of %d to %d vertices, largest gap of the weight from 1 %.3g\n", settings[s],
               t.joins, t.kmin, t.kmax, t.worst_gap);
        CHECK(t.joins > 20 && t.kmin == SPC_FLAT_MAX_VERTICES + 1 && t.kmax <= 8);
        CHECK(t.worst_gap == 0.0);
        spc_scene_destroy(sc);
    }
}

/* The floor seen directly against bdpt (floor_pixels_agree) and pixel (1, 12)'s z, the mean of r, g, b. */
static void spot_guide_vs_bdpt(const spc_scene *sc, const spc_film *img, const spc_film *ref, const char *label,
                               double *pass, double *z)
{
    int tested = 0;
    double sums[4];
    *pass = floor_pixels_agree(sc, img, ref, 0.01, &tested, sums);
    double se = sqrt(sums[2] * sums[2] + sums[3] * sums[3]);
    size_t i = 12 * (size_t)ref->width + 1;
    *z = 0.0;
    for (int c = 0; c < 3; ++c)
        *z += (img->rgb[3 * i + c] - ref->rgb[3 * i + c]) / sqrt((double)img->var[3 * i + c] + ref->var[3 * i + c]) / 3.0;
    printf("    %s vs bdpt: z-test pass %.4f of %d floor pixels; sums %.5f vs %.5f (se %.2g); pixel (1, 12) %.4f vs "
           "%.4f (z %.2f)\n",
           label, *pass, tested, sums[0], sums[1], se, img->rgb[3 * i + 1], ref->rgb[3 * i + 1], *z);
    if (strncmp(label, "without", 7)) {
        CHECK_MSG(*pass >= 0.99, "%s vs bdpt, z-test pass %.4f", label, *pass);
        CHECK_MSG(fabs(sums[0] - sums[1]) <= 3.0 * se, "%s: floor sum %.5f vs bdpt %.5f (se %.2g)", label, sums[0],
                  sums[1], se);
        CHECK_MSG(fabs(*z) < 3.0, "%s: pixel (1, 12) z %.2f against bdpt", label, *z);
    }
}

TEST(spot_slab_guide_render_agrees_with_bdpt)
{
    spc_scene *sc = tu_load(SPOT_GUIDE_SCENE, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    bool quick = getenv("SPC_TEST_QUICK") != NULL;
    int spp = quick ? 256 : 1024;
    spc_film *with = tu_render_nee(sc, "path", SPOT_GUIDE_PLAN ",ltguide", spp, 2, 61, NULL);
    spc_film *without = tu_render_nee(sc, "path", SPOT_GUIDE_PLAN, spp, 2, 62, NULL);
    /* the long pass up to 8 vertices: no chain length counted twice (by it and the guides) or missed */
    spc_film *with_long = tu_render_nee(sc, "path", SPOT_GUIDE_PLAN ",ltguide,long=1,longmax=8", spp, 2, 64, NULL);
    spc_film *ref = tu_render_nee(sc, "bdpt", "none", quick ? 2048 : 8192, 2, 63, NULL);
    CHECK(with && without && with_long && ref);
    if (with && without && with_long && ref) {
        double pass, z, pass0, z0, passl, zl;
        spot_guide_vs_bdpt(sc, with, ref, "with the spot's light guides", &pass, &z);
        spot_guide_vs_bdpt(sc, with_long, ref, "with them and long=1,longmax=8", &passl, &zl);
        spot_guide_vs_bdpt(sc, without, ref, "without them", &pass0, &z0);
        /* the test sees the light they add: without them the pixel reads low */
        CHECK_MSG(z0 < -5.0, "pixel (1, 12) without the guides: z %.2f against bdpt", z0);
    }
    spc_film_destroy(with);
    spc_film_destroy(without);
    spc_film_destroy(with_long);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(joins_are_specular_nee_chains_with_the_same_ratio);
    RUN(render_agrees_without_it);
    RUN(through_sphere_on_a_share);
    RUN(long_camera_chains_on_their_own_share);
    RUN(path_side_follows_a_middle_vertex);
    RUN(plan_with_point_lights_and_small_area_lights);
    RUN(area_light_weights_sum_to_one);
    RUN(area_light_weights_sum_to_one_guided);
    RUN(area_light_long_camera_chains_weights_sum_to_one);
    RUN(mesh_ball_area_weights_sum_to_one);
    RUN(mesh_ball_render_agrees_without_it);
    RUN(mesh_ball_point_weights_sum_to_one);
    RUN(mesh_ball_point_render_agrees_without_it);
    RUN(spot_joins_weigh_as_specular_nee);
    RUN(spot_render_agrees_without_it_and_with_bdpt);
    RUN(slab_area_weights_sum_to_one);
    RUN(slab_area_weights_sum_to_one_lightx);
    RUN(slab_area_weights_sum_to_one_long_flat_lt);
    RUN(slab_area_weights_sum_to_one_long);
    RUN(slab_area_camera_weights_sum_to_one);
    RUN(slab_area_camera_render_agrees_without_it);
    RUN(mirror_ball_area_camera_weights_sum_to_one);
    RUN(mirror_ball_area_camera_render_agrees_without_it);
    RUN(slab_render_agrees_without_it);
    RUN(slab_point_weights_sum_to_one);
    RUN(slab_point_render_agrees_without_it);
    RUN(slab_camera_point_weights_sum_to_one);
    RUN(slab_camera_point_render_agrees_with_the_share);
    RUN(ring_area_weights_sum_to_one);
    RUN(ring_render_agrees_without_it);
    RUN(pool_area_weights_sum_to_one);
    RUN(pool_joins_are_path_tracer_paths);
    RUN(pool_turned_camera_paths_not_light_tracings);
    RUN(pool_water_jacobians);
    RUN(pool_render_agrees_without_it);
    RUN(slab_render_long_agrees_without_it);
    RUN(area_light_render_agrees_without_it);
    RUN(area_light_long_render_agrees_without_it);
    RUN(area_light_joins_only_at_the_first_two_receivers);
    RUN(guide_weights_sum_to_one);
    RUN(guide_path_side_from_the_first_hit);
    RUN(guide_render_agrees_without_it);
    RUN(slab_guide_weights_sum_to_one);
    RUN(slab_guide_render_agrees_with_none);
    RUN(spot_slab_guide_joins_weigh_one);
    RUN(spot_slab_guide_render_agrees_with_bdpt);
    return spc_test_finish();
}
