/*
 * tests/test_sphere_chain_mis.c: the sampling side's density in the MIS weights of the paths that
 * specular NEE covers through one glass sphere (specular_nee.c, chain_events_sample_prob), on
 * scenes/caustic_glass_sphere.xml.
 *
 * - spc_bsdf_specular_prob is the pdf of the sample record that BSDF sampling returns for the same
 *   delta lobe (the glass's F or 1 - F), from outside and from inside the sphere.
 * - At the floor point of that scene's worst seed (pixel (12, 20) of 32x32, seed 5), the paths that
 *   leave it toward the sphere and reach the light through 3 or more sphere vertices (reflected
 *   inside the ball) keep a small MIS weight on the BSDF side: mean below 0.02 and none above 0.05
 *   (0.0000 and 0.0006 measured). Without the events' probability in the BSDF side's density
 *   (F^3 (1 - F)^2, about 0.01 for such a path): 0.053 and 0.83, and 0.94 at the render's firefly,
 *   a path of value 217 in a pixel whose mean is 0.03.
 * - With a larger light (radius 0.4), at floor points in the caustic, at its rim and beside the ball, specular NEE
 *   plus the BSDF-sampled paths it covers (chains up to 6 vertices, weighted by
 *   spc_snee_mis_bsdf_weight) agree with BSDF sampling alone (every path weight 1, no specular NEE):
 *   |z| < 4 at every point.
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/rng.h"
#include "core/warp.h"
#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "specula/specula.h"

#define SCENE "scenes/caustic_glass_sphere.xml"
#define LONG_MAX 6
#define CAMERA spc_v3(0.0, 2.2, 3.2)
#define BALL_C spc_v3(0.0, 0.45, 0.0)
#define BALL_R 0.45

/* The floor point below (px, pz). */
static bool floor_point(const spc_scene *sc, double px, double pz, spc_hit *x)
{
    spc_ray ray = {spc_v3(px, 0.01, pz), spc_v3(0, -1, 0), 0, INFINITY};
    return spc_scene_intersect(sc, &ray, x) && x->shape_index == 1;
}

/* The path leaving x along d0 (x's lobe `lobe`, throughput T) through at most LONG_MAX chain vertices,
 * each sampled by its BSDF, to the light: its luminance times its MIS weight (1 with plain, or where
 * specular NEE does not cover it); *k the chain vertices passed, *w the weight, both -1 where the
 * path does not reach the light. */
static double trace_from(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo, spc_vec3 d0,
                         unsigned lobe, spc_rgb T, bool plain, bool even, spc_rng *u, int *k_out, double *w_out)
{
    *k_out = -1;
    *w_out = -1.0;
    spc_snee_track t;
    memset(&t, 0, sizeof t);
    spc_snee_track_scatter_params(&t, p, x, lobe, 2, LONG_MAX);
    spc_ray ray = spc_hit_spawn(x, d0);
    for (int k = 0; k <= LONG_MAX; ++k) {
        spc_hit h;
        int ev;
        if (!spc_scene_intersect(sc, &ray, &h))
            return 0.0;
        if (h.emitter) {
            if (k < 1)
                return 0.0; /* the light seen directly: the path tracer's own NEE, not this test's */
            double w = 1.0;
            if (!plain && spc_snee_track_covers(&t, sc, h.emitter))
                w = spc_snee_mis_bsdf_weight(sc, p, x, wo, d0, t.max_chain, t.k, t.events, &h);
            *k_out = k;
            *w_out = w;
            return w * spc_rgb_lum(spc_rgb_mul(T, spc_emitter_eval_area(h.emitter, &h, spc_neg(ray.d))));
        }
        spc_bsdf_sample b2;
        /* even: reflection or refraction with probability 1/2 each (u_lobe below or above F) */
        double ul = spc_rng_next(u);
        if (even)
            ul = ul < 0.5 ? 0.0 : 1.0 - 1e-12;
        if (k == LONG_MAX || !spc_chain_surface(&h, false, &ev) ||
            !spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, spc_neg(ray.d), ul,
                                 spc_v2(spc_rng_next(u), spc_rng_next(u)), &b2))
            return 0.0;
        spc_snee_track_scatter_params(&t, p, &h, b2.lobe, 0, 0);
        T = spc_rgb_mul(T, b2.weight);
        ray = spc_hit_spawn(&h, b2.wi);
    }
    return 0.0;
}

/* One BSDF-sampled path from x, as trace_from. */
static double bsdf_path(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo, bool plain,
                        spc_rng *u, int *k_out, double *w_out)
{
    *k_out = -1;
    *w_out = -1.0;
    spc_bsdf_sample bs;
    if (!spc_bsdf_sample_dir(x->bsdf, x, SPC_MODE_RADIANCE, wo, spc_rng_next(u),
                             spc_v2(spc_rng_next(u), spc_rng_next(u)), &bs))
        return 0.0;
    return trace_from(sc, p, x, wo, bs.wi, bs.lobe, bs.weight, plain, false, u, k_out, w_out);
}

/* The scene, with its light's radius and radiance set where light_radius is given (NULL: as the
 * file has them). */
static spc_scene *load(const char *light_radius, const char *light_radiance)
{
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_define defs[2] = {{"light_radius", light_radius}, {"light_radiance", light_radiance}};
    CHECK_MSG(spc_scene_load(SCENE, defs, light_radius ? 2 : 0, &sc, &err) == SPC_OK, "%s: %s", SCENE, err.msg);
    return sc;
}

static void default_params(spc_snee_params *p)
{
    CHECK(spc_snee_parse("angular", 2, p));
    p->mis = true;
}

TEST(specular_prob_matches_sampling)
{
    spc_scene *sc = load(NULL, NULL);
    if (!sc)
        return;
    /* the ball's top, hit from above */
    spc_ray ray = {spc_v3(0.0, 2.0, 0.0), spc_v3(0, -1, 0), 0, INFINITY};
    spc_hit h;
    CHECK(spc_scene_intersect(sc, &ray, &h) && h.shape_index == 2);
    spc_rng u;
    spc_rng_seed(&u, 3, 1);
    int n[2] = {0, 0};
    double worst = 0.0;
    for (int i = 0; i < 2000; ++i) {
        /* wo from outside (i even) and from inside the glass */
        spc_vec3 wo = spc_warp_uniform_sphere(spc_v2(spc_rng_next(&u), spc_rng_next(&u)));
        if ((spc_dot(wo, h.sh.n) > 0.0) != (i % 2 == 0))
            wo = spc_neg(wo);
        spc_bsdf_sample bs;
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, wo, spc_rng_next(&u),
                                 spc_v2(spc_rng_next(&u), spc_rng_next(&u)), &bs))
            continue;
        double P = spc_bsdf_specular_prob(h.bsdf, &h, wo, bs.wi);
        double err = fabs(P - bs.pdf) / bs.pdf;
        worst = err > worst ? err : worst;
        ++n[(bs.lobe & SPC_LOBE_DELTA_REFLECTION) ? 0 : 1];
    }
    printf("    %d reflections, %d refractions: largest relative difference %.2g\n", n[0], n[1], worst);
    CHECK(n[0] > 20 && n[1] > 20);
    CHECK_MSG(worst < 1e-9, "relative difference %.3g", worst);
    spc_scene_destroy(sc);
}

TEST(long_chain_weight)
{
    spc_scene *sc = load(NULL, NULL);
    if (!sc)
        return;
    spc_snee_params p;
    default_params(&p);
    spc_hit x;
    CHECK(floor_point(sc, -0.2823, 0.2163, &x));
    spc_vec3 wo = spc_normalize(spc_sub(CAMERA, x.p));
    /* directions toward the ball: the weight is a function of the path, whatever drew its first
     * direction */
    spc_vec3 axis = spc_sub(BALL_C, x.p);
    double dist = spc_length(axis), cos_max = sqrt(1.0 - BALL_R * BALL_R / (dist * dist));
    spc_frame fr = spc_frame_from_n(spc_scale(axis, 1.0 / dist));
    spc_rng u;
    spc_rng_seed(&u, 7, 1);
    int n = 0;
    double wsum = 0.0, wmax = 0.0;
    for (int i = 0; i < 800000 && n < 200; ++i) {
        spc_vec3 d0 =
            spc_frame_to_world(&fr, spc_warp_uniform_cone(spc_v2(spc_rng_next(&u), spc_rng_next(&u)), cos_max));
        if (!(spc_dot(d0, x.ng) > 0.0))
            continue;
        int k;
        double w;
        trace_from(sc, &p, &x, wo, d0, SPC_LOBE_DIFFUSE_REFLECTION, spc_rgb1(1.0), false, true, &u, &k, &w);
        if (k >= 3) {
            ++n;
            wsum += w;
            wmax = w > wmax ? w : wmax;
        }
    }
    printf("    %d paths through 3+ sphere vertices: mean weight %.4f, largest %.4f\n", n, n ? wsum / n : 0.0, wmax);
    CHECK(n >= 20);
    CHECK_MSG(n > 0 && wsum / n < 0.02, "mean weight %.4f", n ? wsum / n : 0.0);
    CHECK_MSG(wmax < 0.05, "largest weight %.4f", wmax);
    spc_scene_destroy(sc);
}

TEST(weighted_sum_agrees_with_bsdf_sampling)
{
    /* a light of radius 0.4 (the same power), which BSDF sampling alone finds through the ball often
     * enough for a z-test */
    spc_scene *sc = load("0.4", "19.8, 18, 15.3");
    if (!sc)
        return;
    spc_snee_params p;
    default_params(&p);
    /* in the caustic, at its rim, beside the ball */
    static const double pts[3][2] = {{0.2, 0.15}, {0.35, 0.35}, {-0.2823, 0.2163}};
    const int N = 20000;
    double zmax = 0.0;
    for (int i = 0; i < 3; ++i) {
        spc_hit x;
        CHECK(floor_point(sc, pts[i][0], pts[i][1], &x));
        spc_vec3 wo = spc_normalize(spc_sub(CAMERA, x.p));
        double s[2][2] = {{0, 0}, {0, 0}};
        for (int j = 0; j < 2; ++j) {
            spc_rng r, u;
            spc_rng_seed(&r, 11 + (uint64_t)i, 1 + (uint64_t)j);
            spc_rng_seed(&u, 13 + (uint64_t)i, 1 + (uint64_t)j);
            for (int n = 0; n < N; ++n) {
                int k;
                double w, v = bsdf_path(sc, &p, &x, wo, j == 1, &u, &k, &w);
                if (j == 0)
                    v += spc_rgb_lum(spc_specular_nee_depth(sc, &p, &x, wo, 2, LONG_MAX, &r, NULL));
                s[j][0] += v;
                s[j][1] += v * v;
            }
        }
        double m[2], se[2];
        for (int j = 0; j < 2; ++j) {
            m[j] = s[j][0] / N;
            se[j] = sqrt(spc_max(s[j][1] / N - m[j] * m[j], 0.0) / N);
        }
        double z = (m[0] - m[1]) / hypot(se[0], se[1]);
        printf("    (%.2f, %.2f): specular NEE + weighted %.4f +- %.4f, BSDF sampling alone %.4f +- %.4f, z %+.2f\n",
               pts[i][0], pts[i][1], m[0], se[0], m[1], se[1], z);
        zmax = fabs(z) > zmax ? fabs(z) : zmax;
    }
    CHECK_MSG(zmax < 4.0, "|z| %.2f", zmax);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(specular_prob_matches_sampling);
    RUN(long_chain_weight);
    RUN(weighted_sum_agrees_with_bsdf_sampling);
    return spc_test_finish();
}
