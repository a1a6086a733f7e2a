/*
 * tests/test_solve_mis.c: MIS with the randomized solver's real solve probability
 * (manifold/solve_mis.h) and its use in specular NEE.
 *
 * - Each side alone, against Bernoulli trials of known probability p: specular NEE's estimate has
 *   mean 1 / (p A + b) and never exceeds 1 / b; BSDF sampling's weight lies in [0, 1] and has mean
 *   b / (p A + b); where p is small and b is not, either count ends after a few attempts instead
 *   of 1 / p.
 * - On the triangle glass ball (bench/check/glass_ball_mesh.xml), at floor points in its caustic:
 *   specular NEE plus the BSDF-sampled paths it covers, each weighted by spc_snee_mis_bsdf_weight, add
 *   up to the same value with the default (the real probability and the fitted sphere's seeds,
 *   fit_seeds.h), the real probability alone and neither (the stand-in psi, nosolvemis,nofitseeds);
 *   the default's second moment is below 0.6 of the stand-in's, the real probability's alone below
 *   0.8, and its largest single sample under half the stand-in's (the trial count's tail, which the
 *   stand-in's weight lets through where BSDF sampling reaches the chain).
 * - The 5-vertex paths (in, three internal reflections, out) from one floor point: their mean
 *   BSDF-side weight is below 0.05 (the ball pass's events and seeds; 0.15 without them).
 * - The grazing (reflect, reflect) paths around the ball's rim from a floor point in its shadow: their
 *   mean BSDF-side weight is below 0.05 (fit_first's grazing seeds; 1.02 without them); those of 3 and
 *   4 reflections from floor points beside it below 0.3 (graze_long's seeds; 1 without them).
 * - The ball pass's events: the frequency of each event sequence that an attempt's uniforms pick
 *   matches the probability both MIS sides use (spc_snee_attempt_events_prob).
 * - A randomized attempt returns what solving from its seed direction returns, and a trial of its
 *   chain's count from that direction finds the chain again (a count may start from the attempt).
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/rng.h"
#include "harness.h"
#include "manifold/chain.h"
#include "manifold/fit_seeds.h"
#include "manifold/snee_options.h"
#include "manifold/solve_mis.h"
#include "manifold/specular_nee.h"
#include "render_util.h"
#include "specula/specula.h"

/* A Bernoulli trial of probability p from its own generator. */
typedef struct bern {
    double p;
    spc_rng rng;
    long calls;
} bern;

static bool bern_trial(void *user)
{
    bern *b = user;
    b->calls++;
    return spc_rng_next(&b->rng) < b->p;
}

typedef struct mis_case {
    double p, A, b;
} mis_case;

static const mis_case cases[] = {
    {0.5, 1.0, 1.0}, {0.05, 1.0, 0.2}, {0.01, 3.0, 0.05}, {0.002, 1.0, 1.0}, {0.2, 1.0, 0.0}, {0.9, 0.1, 10.0},
};
#define NCASES ((int)(sizeof cases / sizeof cases[0]))

TEST(light_side_estimates_the_reciprocal)
{
    const int N = spc_test_quick() ? 50000 : 200000;
    for (int c = 0; c < NCASES; ++c) {
        const mis_case *k = &cases[c];
        bern t = {k->p, {0, 0}, 0};
        spc_rng_seed(&t.rng, 11, (uint64_t)c);
        spc_rng rng;
        spc_rng_seed(&rng, 12, (uint64_t)c);
        double s1 = 0, s2 = 0, zmax = 0;
        for (int i = 0; i < N; ++i) {
            double z = spc_solve_mis_light(k->A, k->b, bern_trial, &t, &rng, 1 << 30, NULL, NULL);
            s1 += z;
            s2 += z * z;
            zmax = z > zmax ? z : zmax;
        }
        double m = s1 / N, se = sqrt((s2 / N - m * m) / N), want = 1.0 / (k->p * k->A + k->b);
        printf("    p %.3f A %.2f b %.2f: mean %.5g +- %.2g (1 / (p A + b) %.5g), max %.4g, %.2f attempts\n", k->p, k->A,
               k->b, m, se, want, zmax, (double)t.calls / N);
        CHECK_MSG(fabs(m - want) < 4.0 * se + 1e-12 * want, "case %d: %.6g against %.6g", c, m, want);
        if (k->b > 0.0)
            CHECK_MSG(zmax <= 1.0 / k->b * (1.0 + 1e-12), "case %d: a sample %.6g above 1 / b", c, zmax);
    }
}

TEST(sampled_side_weight)
{
    const int N = spc_test_quick() ? 50000 : 200000;
    for (int c = 0; c < NCASES; ++c) {
        const mis_case *k = &cases[c];
        bern t = {k->p, {0, 0}, 0};
        spc_rng_seed(&t.rng, 21, (uint64_t)c);
        spc_rng rng;
        spc_rng_seed(&rng, 22, (uint64_t)c);
        double s1 = 0, s2 = 0;
        bool in01 = true;
        for (int i = 0; i < N; ++i) {
            double w = spc_solve_mis_sampled(k->A, k->b, bern_trial, &t, &rng, 1 << 30, NULL);
            s1 += w;
            s2 += w * w;
            in01 = in01 && w >= 0.0 && w <= 1.0;
        }
        double m = s1 / N, want = k->b / (k->p * k->A + k->b), se = sqrt(spc_max(s2 / N - m * m, 0.0) / N);
        CHECK(in01);
        printf("    p %.3f A %.2f b %.2f: mean weight %.5f (b / (p A + b) %.5f), %.2f attempts\n", k->p, k->A, k->b, m,
               want, (double)t.calls / N);
        CHECK_MSG(fabs(m - want) <= 4.0 * se + 1e-12, "case %d: %.6f against %.6f", c, m, want);
    }
}

/* The per-query cost: where p is 1e-4 and b equals A, each side's count ends after a few attempts
 * on average (the plain count: 10^4). */
TEST(count_ends_where_bsdf_sampling_takes_over)
{
    const int N = 20000;
    bern t = {1e-4, {0, 0}, 0};
    spc_rng_seed(&t.rng, 31, 1);
    spc_rng rng;
    spc_rng_seed(&rng, 32, 1);
    for (int i = 0; i < N; ++i)
        spc_solve_mis_light(1.0, 1.0, bern_trial, &t, &rng, 1 << 30, NULL, NULL);
    double light = (double)t.calls / N;
    t.calls = 0;
    for (int i = 0; i < N; ++i)
        spc_solve_mis_sampled(1.0, 1.0, bern_trial, &t, &rng, 1 << 30, NULL);
    double sampled = (double)t.calls / N;
    printf("    attempts per estimate: light side %.2f, sampled side %.2f\n", light, sampled);
    CHECK(light < 8.0 && sampled < 8.0);
}

#define SCENE "bench/check/glass_ball_mesh.xml"

/* The floor point below (px, pz). */
static bool floor_point(const spc_scene *sc, double px, double pz, spc_hit *x)
{
    spc_ray ray = {spc_v3(px, 0.05, pz), spc_v3(0, -1, 0), 0, INFINITY};
    return spc_scene_intersect(sc, &ray, x) && x->shape_index == 1;
}

/* Specular NEE (params p, chains of at most 2 vertices, longer ones to long_max) plus the
 * BSDF-sampled paths from x that reach the light through at most long_max chain vertices, weighted
 * by spc_snee_mis_bsdf_weight where specular NEE covers them: N samples of the luminance; mean,
 * standard error, the largest sample. */
static void combined(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo, int long_max, int N,
                     uint64_t seed, double *mean, double *se, double *vmax)
{
    spc_rng r, u;
    spc_rng_seed(&r, seed, 1);
    spc_rng_seed(&u, seed, 2);
    double s1 = 0, s2 = 0;
    *vmax = 0.0;
    for (int i = 0; i < N; ++i) {
        double v = spc_rgb_lum(spc_specular_nee_depth(sc, p, x, wo, 2, long_max, &r, NULL));
        spc_bsdf_sample bs;
        if (spc_bsdf_sample_dir(x->bsdf, x, SPC_MODE_RADIANCE, wo, spc_rng_next(&u),
                                spc_v2(spc_rng_next(&u), spc_rng_next(&u)), &bs)) {
            spc_snee_track t;
            memset(&t, 0, sizeof t);
            spc_snee_track_scatter_params(&t, p, x, bs.lobe, 2, long_max);
            spc_ray ray = spc_hit_spawn(x, bs.wi);
            spc_rgb T = bs.weight;
            for (int k = 0; k <= long_max; ++k) {
                spc_hit h;
                int ev;
                if (!spc_scene_intersect(sc, &ray, &h))
                    break;
                if (h.emitter) {
                    double w = 1.0;
                    if (spc_snee_track_covers(&t, sc, h.emitter))
                        w = spc_snee_mis_bsdf_weight(sc, p, x, wo, bs.wi, t.max_chain, t.k, t.events, &h);
                    if (k >= 1)
                        v += w * spc_rgb_lum(spc_rgb_mul(T, spc_emitter_eval_area(h.emitter, &h, spc_neg(ray.d))));
                    break;
                }
                spc_bsdf_sample b2;
                if (k == long_max || !spc_chain_surface(&h, false, &ev) ||
                    !spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, spc_neg(ray.d), spc_rng_next(&u),
                                         spc_v2(spc_rng_next(&u), spc_rng_next(&u)), &b2))
                    break;
                spc_snee_track_scatter_params(&t, p, &h, b2.lobe, 0, 0);
                T = spc_rgb_mul(T, b2.weight);
                ray = spc_hit_spawn(&h, b2.wi);
            }
        }
        s1 += v;
        s2 += v * v;
        *vmax = v > *vmax ? v : *vmax;
    }
    *mean = s1 / N;
    *se = sqrt(spc_max(s2 / N - *mean * *mean, 0.0) / N);
}

TEST(triangle_ball_tail)
{
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    /* 0: the default (the real probability, the fitted sphere's seeds), 1: the real probability alone,
     * 2: neither (the stand-in psi, the cone's seeds) */
    static const char *const settings[3] = {"angular", "angular:nofitseeds", "angular:nosolvemis,nofitseeds"};
    spc_snee_params p[3];
    for (int j = 0; j < 3; ++j) {
        CHECK(spc_snee_parse(settings[j], 2, &p[j]));
        p[j].mis = true;
    }
    const int N = 20000; /* also under SPC_TEST_QUICK: the second moments' ratios need it */
    double m2[3] = {0, 0, 0}, vmax[3] = {0, 0, 0}, zmax = 0.0;
    int lit = 0;
    for (int i = 0; i < 12; ++i) {
        spc_hit x;
        double px = -0.33 + 0.06 * (i % 4), pz = 0.06 + 0.08 * (i / 4);
        if (!floor_point(sc, px, pz, &x))
            continue;
        double m[3], se[3], mx[3];
        for (int j = 0; j < 3; ++j)
            combined(sc, &p[j], &x, spc_v3(0, 1, 0), 4, N, 100 * (uint64_t)(j + 1) + (uint64_t)i, &m[j], &se[j], &mx[j]);
        printf("    (%.2f, %.2f):", px, pz);
        for (int j = 0; j < 3; ++j)
            printf(" %.4f +- %.4f (largest %.4g)%s", m[j], se[j], mx[j], j < 2 ? " |" : "\n");
        for (int j = 0; j < 2; ++j) {
            double z = (m[j] - m[2]) / hypot(se[j], se[2]);
            zmax = fabs(z) > zmax ? fabs(z) : zmax;
        }
        if (m[2] > 1.0) { /* in the caustic */
            ++lit;
            for (int j = 0; j < 3; ++j) {
                m2[j] += se[j] * se[j] * N + m[j] * m[j];
                vmax[j] = mx[j] > vmax[j] ? mx[j] : vmax[j];
            }
        }
    }
    printf("    %d points in the caustic: second moment against the stand-in's: default %.3f, real probability "
           "alone %.3f; largest sample %.4g, %.4g, %.4g\n",
           lit, m2[0] / m2[2], m2[1] / m2[2], vmax[0], vmax[1], vmax[2]);
    CHECK_MSG(zmax < 4.0, "the weightings disagree: |z| %.2f", zmax);
    CHECK(lit >= 4);
    CHECK_MSG(m2[0] < 0.6 * m2[2], "default: second moment %.4g against the stand-in's %.4g", m2[0], m2[2]);
    CHECK_MSG(m2[1] < 0.8 * m2[2], "real probability: second moment %.4g against the stand-in's %.4g", m2[1], m2[2]);
    /* The stand-in's chains on one shape are given up at the count where its weighted sample would pass
     * f / b (specular_nee.c, give_up_cap), so its largest sample is bounded like the real probability's;
     * counted on by roulette it reached 4532, 4x the default's. */
    CHECK_MSG(vmax[2] < 2.0 * vmax[0], "largest sample: stand-in %.4g against the default's %.4g", vmax[2], vmax[0]);
    spc_scene_destroy(sc);
}

/* The centre of SCENE's light, and the half-width of the azimuths around the centre's direction, seen
 * from the floor, of ball_paths_mean_weight's grazing rays (the light's side of the rim). */
#define LIGHT_CENTRE spc_v3(0.4, 2.2, -0.6)
#define RIM_PHI 0.15

/* Uniform directions from the floor point (fx, 0, fz) toward the tessellated ball's fitted sphere (rim
 * 0), or with rim > 0 the directions that pass its centre at R (1 - delta), delta uniform in [0, rim),
 * their azimuth about the centre's direction uniform within RIM_PHI of the light's (the grazing rays
 * on the light's side), traced through the chain of events ev (k vertices); over the
 * first `want` that reach the light, the mean MIS weight on the BSDF side (-1 if none did). *n: how
 * many reached it. */
static double ball_paths_mean_weight(spc_scene *sc, double fx, double fz, const unsigned char *ev, int k,
                                     uint64_t stream, int want, double rim, int *n)
{
    spc_snee_params p;
    CHECK(spc_snee_parse("angular", 2, &p));
    p.mis = true;
    spc_vec3 c = spc_v3(0, 0, 0);
    double R = 0.0;
    bool ball = false;
    for (int i = 0; i < sc->nshapes && !ball; ++i)
        ball = spc_fit_sphere(sc->shapes[i], &c, &R);
    spc_hit x;
    CHECK(ball);
    *n = 0;
    if (!ball || !floor_point(sc, fx, fz, &x)) {
        CHECK_MSG(false, "no floor point at (%g, 0, %g)", fx, fz);
        return -1.0;
    }
    spc_rng r;
    spc_rng_seed(&r, 7, stream);
    double sw = 0.0;
    for (int i = 0; i < 200000 && *n < want; ++i) {
        spc_vec3 d0;
        if (rim > 0.0) {
            spc_vec3 oc = spc_sub(c, x.p);
            double D = spc_length(oc), sn = R * (1.0 - rim * spc_rng_next(&r)) / D;
            spc_vec3 oh = spc_scale(oc, 1.0 / D), to_l = spc_sub(LIGHT_CENTRE, x.p);
            spc_vec3 e1 = spc_normalize(spc_sub(to_l, spc_scale(oh, spc_dot(to_l, oh)))), e2 = spc_cross(oh, e1);
            double phi = RIM_PHI * (2.0 * spc_rng_next(&r) - 1.0);
            spc_vec3 side = spc_add(spc_scale(e1, cos(phi)), spc_scale(e2, sin(phi)));
            d0 = spc_add(spc_scale(oh, sqrt(1.0 - sn * sn)), spc_scale(side, sn));
        } else {
            spc_vec3 u;
            do
                u = spc_v3(2 * spc_rng_next(&r) - 1, 2 * spc_rng_next(&r) - 1, 2 * spc_rng_next(&r) - 1);
            while (spc_dot(u, u) > 1.0);
            d0 = spc_normalize(spc_sub(spc_add(c, spc_scale(u, R)), x.p));
        }
        spc_frame fr = spc_frame_from_n(d0);
        spc_chain_opts o = spc_chain_opts_default(k);
        o.events = ev;
        spc_chain ch;
        if (spc_chain_trace(sc, &x, &fr, 0.0, 0.0, &o, &ch) != SPC_CHAIN_END_SURFACE || ch.n != k || !ch.has_end_hit ||
            !ch.end_hit.emitter)
            continue;
        sw += spc_snee_mis_bsdf_weight(sc, &p, &x, spc_v3(0, 1, 0), d0, 2, k, ev, &ch.end_hit);
        ++*n;
    }
    double mean = *n > 0 ? sw / *n : -1.0;
    printf("    %d %d-vertex paths, mean BSDF-side weight %.3f\n", *n, k, mean);
    return mean;
}

/* On SCENE, at least 50 of ball_paths_mean_weight's paths (at most `want`) from the floor point
 * (fx, 0, fz) through the event sequence ev[0..k), and their mean BSDF-side weight below 0.05. */
static void check_ball_weight_small(double fx, double fz, const unsigned char *ev, int k, uint64_t stream, int want,
                                    double rim)
{
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int n;
    double w = ball_paths_mean_weight(sc, fx, fz, ev, k, stream, want, rim, &n);
    CHECK(n >= 50);
    CHECK_MSG(n > 0 && w < 0.05, "mean weight %.3f", w);
    spc_scene_destroy(sc);
}

/* The MIS weight on the BSDF side of the paths from the floor point (-0.23, 0, 0.72) under the
 * triangle glass ball that reach the light through five chain vertices (in, three internal
 * reflections, out): specular NEE finds them on its ball pass at every call (0.25 per length, the
 * reflections picked with 0.5 each), so BSDF sampling's share is below 0.5 on average (0.15); with the
 * general long pass's 1 / 40 per length and 0.2 per reflection it was 0.82, and one such path held
 * a 24-seed benchmark's worst seed (bench/RESULTS.md, "The triangle glass ball's 5-vertex tail"). */
TEST(ball_long_chain_weight)
{
    static const unsigned char ev[5] = {SPC_CHAIN_REFRACT, SPC_CHAIN_REFLECT, SPC_CHAIN_REFLECT, SPC_CHAIN_REFLECT,
                                        SPC_CHAIN_REFRACT};
    check_ball_weight_small(-0.23, 0.72, ev, 5, 1, 200, 0.0);
}

/* The 2-vertex paths (in, out) from the floor point (-0.097, 0, 0.323) near the fold of the ball's
 * caustic, where the fitted sphere has three 2-vertex chains to the light: uniform directions into
 * the ball that reach the light, their mean BSDF-side weight. Each chain is counted exactly from its
 * fitted solution's seed (fit_first in specular_nee.c), so the weight is the stand-in's b / (p_y + b):
 * 0.012 over 100 paths; with the randomized attempts' solve probability (about 0.19 per chain) it was
 * 0.135. */
TEST(ball_fold_chain_weight)
{
    static const unsigned char ev[2] = {SPC_CHAIN_REFRACT, SPC_CHAIN_REFRACT};
    check_ball_weight_small(-0.097, 0.323, ev, 2, 2, 100, 0.0);
}

/* The grazing double reflections: from the floor point (-0.727, 0, 0.599) in the ball's shadow near
 * its edge, rays that meet a facet at a grazing angle, are reflected under it, meet the next facet
 * and are reflected again (reflect, reflect) toward the light, which the fitted sphere has no chain
 * for. Counted exactly from fit_first's grazing seeds, their mean BSDF-side weight is 0.044; left to
 * the randomized attempts (p about 1e-3, the weights sampled by trial counts) it was 1.02, and one
 * such path held 0.95 of a 48-seed benchmark's worst seed (bench/RESULTS.md, "grazing double
 * reflections"). */
TEST(ball_grazing_reflections_weight)
{
    static const unsigned char ev[2] = {SPC_CHAIN_REFLECT, SPC_CHAIN_REFLECT};
    check_ball_weight_small(-0.727, 0.599, ev, 2, 3, 100, 0.006);
}

/* The rim's longer reflection chains: from floor points beside the ball, rays that graze its rim and
 * are reflected from facet to facet three times (from (0.239, 0, 0.578)) or four times (from
 * (0.329, 0, 0.217)) toward the light: chains the fitted sphere has none of, so the ball pass never
 * looked for them and BSDF sampling alone made them (weight 1). Two such paths (values 1050 and 1500
 * on pixels of 0.02) held 0.78 of a 48-seed benchmark's mean relMSE under the triangle glass ball
 * (bench/RESULTS.md, "the rim's reflection chains"). Counted exactly from graze_long's grazing seeds
 * of those lengths on a share of the calls (specular_nee.c), their mean BSDF-side weight falls below
 * 0.3 (0.017 and 0.000). */
TEST(ball_rim_reflections_weight)
{
    static const unsigned char ev[4] = {SPC_CHAIN_REFLECT, SPC_CHAIN_REFLECT, SPC_CHAIN_REFLECT, SPC_CHAIN_REFLECT};
    static const double at[2][2] = {{0.2385, 0.5781}, {0.3291, 0.2167}};
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    for (int k = 3; k <= 4; ++k) {
        int n;
        double w = ball_paths_mean_weight(sc, at[k - 3][0], at[k - 3][1], ev, k, (uint64_t)k, 60, 0.006, &n);
        CHECK_MSG(n >= 20, "%d paths of %d vertices", n, k);
        CHECK_MSG(n > 0 && w < 0.3, "%d vertices: mean weight %.3f", k, w);
    }
    spc_scene_destroy(sc);
}

/* The ball pass's events: over the 32 event sequences of a 5-vertex chain through the glass ball, the
 * frequency with which spc_snee_attempt_event_u's uniforms pick each (spc_chain_pick_event at
 * reflect_p 0.5) matches spc_snee_attempt_events_prob within 4 standard errors, the probabilities sum
 * to 1, and the ball's own sequence (in, three reflections, out) has 0.9 + 0.1 / 32; without the
 * ball's share (ball_events_p 0) every sequence has 1 / 32. */
TEST(ball_events_probability)
{
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int glass = -1;
    for (int i = 0; i < sc->nshapes && glass < 0; ++i) {
        spc_vec3 c;
        double R;
        if (spc_fit_sphere(sc->shapes[i], &c, &R))
            glass = i;
    }
    CHECK(glass >= 0);
    const int N = spc_test_quick() ? 20000 : 100000;
    for (int pass = 0; pass < 2 && glass >= 0; ++pass) {
        spc_snee_params p;
        CHECK(spc_snee_parse("angular", 2, &p));
        p.reflect_p = 0.5;
        p.ball_events_p = pass == 0 ? 0.9 : 0.0;
        spc_hit x;
        memset(&x, 0, sizeof x);
        spc_snee_query q;
        spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 1, 0), 5);
        q.min_chain = 5;
        int count[32] = {0};
        spc_rng r;
        spc_rng_seed(&r, 41, (uint64_t)pass);
        for (int i = 0; i < N; ++i) {
            double u[SPC_CHAIN_MAX_VERTICES];
            spc_snee_attempt_event_u(&q, &r, u);
            int k = 0;
            for (int v = 0; v < 5; ++v)
                k |= (spc_chain_pick_event(SPC_CHAIN_REFRACT, u[v], p.reflect_p, NULL) == SPC_CHAIN_REFLECT) << v;
            count[k]++;
        }
        double sum = 0.0, ball = 0.0;
        for (int k = 0; k < 32; ++k) {
            spc_chain_sig sig;
            memset(&sig, 0, sizeof sig);
            sig.n = 5;
            for (int v = 0; v < 5; ++v) {
                sig.shape[v] = glass;
                sig.event[v] = (k >> v) & 1 ? SPC_CHAIN_REFLECT : SPC_CHAIN_REFRACT;
            }
            double P = spc_snee_attempt_events_prob(&q, &sig), f = (double)count[k] / N,
                   se = sqrt(P * (1.0 - P) / N);
            sum += P;
            if (k == 0xe) /* refract, reflect x 3, refract */
                ball = P;
            CHECK_MSG(fabs(f - P) <= 4.0 * se + 1e-12, "pass %d, events %d: frequency %.5f, probability %.5f", pass, k,
                      f, P);
        }
        printf("    ball_events_p %.1f: probabilities sum to %.6f, the ball's sequence %.5f\n", p.ball_events_p, sum,
               ball);
        CHECK(fabs(sum - 1.0) < 1e-9);
        CHECK(fabs(ball - (pass == 0 ? 0.9 + 0.1 / 32.0 : 1.0 / 32.0)) < 1e-9);
    }
    spc_scene_destroy(sc);
}

/* Bitwise the same chain: vertices, events, directions and parameters. */
static bool chains_identical(const spc_chain *a, const spc_chain *b)
{
    if (a->n != b->n || a->end != b->end || memcmp(&a->a, &b->a, sizeof a->a) != 0 ||
        memcmp(&a->b, &b->b, sizeof a->b) != 0 || memcmp(&a->d0, &b->d0, sizeof a->d0) != 0)
        return false;
    for (int i = 0; i < a->n; ++i)
        if (a->v[i].event != b->v[i].event || a->v[i].h.shape_index != b->v[i].h.shape_index ||
            memcmp(&a->v[i].h.p, &b->v[i].h.p, sizeof a->v[i].h.p) != 0 ||
            memcmp(&a->v[i].d, &b->v[i].d, sizeof a->v[i].d) != 0)
            return false;
    return true;
}

/* What lets a trial count start from the randomized attempt that found its chain (specular NEE's
 * attempt and attempt_memo; solver.h, seed_decides), and the ball pass stop an attempt whose seed
 * chain has another length than it keeps (keep_n): under the triangle glass ball, from floor points
 * in its caustic, shadow and rim, with the ball pass's events and seeds (ball_events_p 0.9, fit share
 * 0.9, reflections at 0.5) for chains of 1 to 5 vertices, an attempt (seed and events drawn) returns
 * bit for bit what solving from its seed direction, drawn first from the same stream, returns, after
 * the same draws and iterations; and where it finds a chain, solving from that direction with the
 * chain's events and signature fixed (a trial of its count) finds the same chain, in as many
 * iterations, drawing nothing. With keep_n set to the length, an attempt from the same stream
 * returns that chain where it has the length, else nothing, after the same draws. */
TEST(attempt_is_its_seeds_trial)
{
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params p;
    CHECK(spc_snee_parse("angular", 2, &p));
    p.mis = true;
    p.reflect = true;
    p.reflect_p = 0.5;
    p.ball_events_p = 0.9;
    p.fit_share = 0.9;
    const spc_specular_solver *solver = spc_specular_solver_get(p.solver);
    CHECK(solver && solver->solve_one && solver->seed_decides);
    static const double pts[4][2] = {{-0.097, 0.323}, {-0.23, 0.72}, {-0.727, 0.599}, {0.2, 0.5}};
    int found = 0, tried = 0, bad = 0;
    for (int k = 0; k < 4 && solver; ++k) {
        spc_hit x;
        CHECK(floor_point(sc, pts[k][0], pts[k][1], &x));
        for (int len = 1; len <= 5; ++len)
            for (int i = 0; i < 40; ++i) {
                spc_snee_query q;
                spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 1, 0), len);
                q.min_chain = len;
                spc_fit_roots fit;
                memset(&fit, 0, sizeof fit);
                q.fit = &fit;
                spc_rng r;
                spc_rng_seed(&r, 1000u + (uint64_t)k, (uint64_t)(len * 100 + i));
                const spc_emitter *e;
                spc_vec2 uv;
                double p_y;
                if (!spc_snee_sample_light(sc, false, &r, &q, &e, &uv, &p_y))
                    continue;
                ++tried;
                spc_rng ra = r, rb = r;
                spc_chain A, B;
                int ita = 0, itb = 0;
                bool oka = solver->solve_one(&q, &ra, &A, &ita);
                spc_vec3 seed;
                bool okb = false;
                if (spc_snee_seed_direction(&q, &rb, &seed)) {
                    spc_snee_query sq = q;
                    sq.seed_dir = &seed;
                    okb = solver->solve_one(&sq, &rb, &B, &itb);
                } else {
                    itb = ita; /* solve_one stops at the seed too */
                    B = A;
                }
                bool same = oka == okb && ita == itb && ra.state == rb.state && ra.inc == rb.inc &&
                            (!oka || chains_identical(&A, &B));
                /* with the kept length set (keep_n): the chain where it has that length, else none */
                spc_snee_query kq = q;
                kq.keep_n = len;
                spc_rng rk = r;
                spc_chain K;
                int itk = 0;
                bool okk = solver->solve_one(&kq, &rk, &K, &itk);
                same = same && okk == (oka && A.n == len) && rk.state == ra.state && (!okk || chains_identical(&A, &K));
                if (same && oka) {
                    spc_chain_sig sig;
                    spc_chain_signature(&A, &sig);
                    spc_snee_query tq = q;
                    tq.seed_dir = &seed;
                    tq.events = sig.event;
                    tq.want = &sig;
                    spc_rng rc = r, rc0 = r;
                    spc_chain C;
                    int itc = 0;
                    bool okc = solver->solve_one(&tq, &rc, &C, &itc);
                    same = okc && itc == ita && chains_identical(&A, &C) && rc.state == rc0.state;
                    ++found;
                }
                if (!same && bad++ < 5)
                    CHECK_MSG(false, "point %d, %d vertices, stream %d: the attempt and its seed's solve differ", k,
                              len, i);
            }
    }
    printf("    %d attempts, %d chains found, %d differ\n", tried, found, bad);
    CHECK(bad == 0);
    CHECK(found >= 50);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(light_side_estimates_the_reciprocal);
    RUN(sampled_side_weight);
    RUN(count_ends_where_bsdf_sampling_takes_over);
    RUN(triangle_ball_tail);
    RUN(ball_long_chain_weight);
    RUN(ball_events_probability);
    RUN(ball_fold_chain_weight);
    RUN(ball_grazing_reflections_weight);
    RUN(ball_rim_reflections_weight);
    RUN(attempt_is_its_seeds_trial);
    return spc_test_finish();
}
