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
 *   (0.0003 and 0.013 measured). Without the events' probability in the BSDF side's density
 *   (F^3 (1 - F)^2, about 0.01 for such a path): 0.053 and 0.83, and 0.94 at the render's firefly,
 *   a path of value 217 in a pixel whose mean is 0.03.
 * - With a larger light (radius 0.4), at floor points in the caustic, at its rim and beside the ball, specular NEE
 *   plus the BSDF-sampled paths it covers (chains up to 6 vertices, weighted by
 *   spc_snee_mis_bsdf_weight) agree with BSDF sampling alone (every path weight 1, no specular NEE):
 *   |z| < 4 at every point.
 * - Past the long pass's top (longmax=4), the chains on the sphere of 5 and 6 vertices (three and
 *   four internal reflections) are enumerated on a share of the calls (sphlong=Q): the BSDF-sampled
 *   paths through them then keep a small weight (every one 1 without sphlong), the shorter paths'
 *   weights do not move, and specular NEE plus the weighted paths agree with BSDF sampling alone.
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/rng.h"
#include "core/warp.h"
#include "chain_mis.h"
#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "specula/specula.h"

#define SCENE "scenes/caustic_glass_sphere.xml"
#define CAMERA spc_v3(0.0, 2.2, 3.2)
#define BALL_C spc_v3(0.0, 0.45, 0.0)
#define BALL_R 0.45

TEST(specular_prob_matches_sampling)
{
    spc_scene *sc = chain_mis_load(SCENE, NULL, NULL);
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
    spc_scene *sc = chain_mis_load(SCENE, NULL, NULL);
    if (!sc)
        return;
    spc_snee_params p;
    chain_mis_default_params(&p);
    spc_hit x;
    CHECK(chain_mis_floor_point(sc, 1, -0.2823, 0.2163, &x));
    spc_vec3 wo = spc_normalize(spc_sub(CAMERA, x.p));
    /* directions toward the ball: the weight is a function of the path, whatever drew its first
     * direction */
    int n;
    double wsum, wmax;
    chain_mis_long_weights(sc, &p, &x, wo, BALL_C, BALL_R, 800000, 200, true, &n, &wsum, &wmax);
    printf("    %d paths through 3+ sphere vertices: mean weight %.4f, largest %.4f\n", n, n ? wsum / n : 0.0, wmax);
    CHECK(n >= 20);
    CHECK_MSG(n > 0 && wsum / n < 0.02, "mean weight %.4f", n ? wsum / n : 0.0);
    CHECK_MSG(wmax < 0.05, "largest weight %.4f", wmax);
    spc_scene_destroy(sc);
}

TEST(weighted_sum_agrees_with_bsdf_sampling)
{
    /* a light of radius 0.4 (the same power), which BSDF sampling alone finds through the ball often
     * enough for a z-test; points in the caustic, at its rim, beside the ball */
    static const double pts[3][2] = {{0.2, 0.15}, {0.35, 0.35}, {-0.2823, 0.2163}};
    chain_mis_check_agrees(SCENE, "0.4", "19.8, 18, 15.3", 1, pts, 3, CAMERA, 20000);
}

/* The weights of the paths from the floor point at (px, pz) whose first direction is drawn toward the
 * ball and that reach the light through k vertices (k = 3 .. 6, lobes drawn evenly), under the
 * setting s: n[k] paths, their weights' sum ws[k] and largest wm[k]; the same directions under every
 * setting (a fixed stream). */
static void weights_by_length(spc_scene *sc, const char *s, double px, double pz, int draws, int n[7], double ws[7],
                              double wm[7])
{
    spc_snee_params p;
    CHECK(spc_snee_parse(s, 2, &p));
    p.mis = true;
    spc_hit x;
    CHECK(chain_mis_floor_point(sc, 1, px, pz, &x));
    spc_vec3 wo = spc_normalize(spc_sub(CAMERA, x.p));
    spc_vec3 axis = spc_sub(BALL_C, x.p);
    double dist = spc_length(axis), cos_max = sqrt(1.0 - BALL_R * BALL_R / (dist * dist));
    spc_frame fr = spc_frame_from_n(spc_scale(axis, 1.0 / dist));
    spc_rng u;
    spc_rng_seed(&u, 17, 1);
    for (int k = 0; k < 7; ++k) {
        n[k] = 0;
        ws[k] = wm[k] = 0.0;
    }
    for (int i = 0; i < draws; ++i) {
        spc_vec3 d0 =
            spc_frame_to_world(&fr, spc_warp_uniform_cone(spc_v2(spc_rng_next(&u), spc_rng_next(&u)), cos_max));
        if (!(spc_dot(d0, x.ng) > 0.0))
            continue;
        int k;
        double w;
        chain_mis_trace_from(sc, &p, &x, wo, d0, SPC_LOBE_DIFFUSE_REFLECTION, spc_rgb1(1.0), false, true, &u, &k, &w);
        if (k >= 3 && k <= 6) {
            ++n[k];
            ws[k] += w;
            wm[k] = w > wm[k] ? w : wm[k];
        }
    }
}

TEST(past_long_max_weight)
{
    spc_scene *sc = chain_mis_load(SCENE, NULL, NULL);
    if (!sc)
        return;
    static const char *set[2] = {"angular:long=0.2,longmax=4", "angular:long=0.2,longmax=4,sphlong=0.1"};
    int n[2][7];
    double ws[2][7], wm[2][7];
    int draws = spc_test_quick() ? 200000 : 800000;
    for (int j = 0; j < 2; ++j)
        weights_by_length(sc, set[j], -0.2823, 0.2163, draws, n[j], ws[j], wm[j]);
    for (int j = 0; j < 2; ++j)
        for (int k = 3; k <= 6; ++k)
            printf("    %s: %d paths through %d sphere vertices, mean weight %.4g, largest %.4g\n", set[j], n[j][k], k,
                   n[j][k] ? ws[j][k] / n[j][k] : 0.0, wm[j][k]);
    int n56 = n[1][5] + n[1][6];
    double w56 = ws[1][5] + ws[1][6], m56 = wm[1][5] > wm[1][6] ? wm[1][5] : wm[1][6];
    CHECK_MSG(n56 >= 10, "%d paths through 5-6 vertices", n56);
    /* without sphlong BSDF sampling alone carries them: weight 1, every one */
    CHECK_MSG(n[0][5] + n[0][6] == n56 && ws[0][5] + ws[0][6] == (double)n56, "weights without sphlong %.6g of %d",
              ws[0][5] + ws[0][6], n[0][5] + n[0][6]);
    /* with it the small light's density times the share dwarfs BSDF sampling's */
    CHECK_MSG(n56 > 0 && w56 / n56 < 0.05, "mean weight at 5-6 vertices %.4f", n56 ? w56 / n56 : 0.0);
    CHECK_MSG(m56 < 0.5, "largest weight at 5-6 vertices %.4f", m56);
    /* the long pass's own lengths keep their weights */
    for (int k = 3; k <= 4; ++k)
        CHECK_MSG(n[0][k] == n[1][k] && fabs(ws[0][k] - ws[1][k]) <= 1e-12 * (1.0 + ws[0][k]),
                  "%d vertices: %.12g against %.12g", k, ws[0][k], ws[1][k]);
    spc_scene_destroy(sc);
}

TEST(past_long_max_agrees_with_bsdf_sampling)
{
    /* the larger light, as weighted_sum_agrees_with_bsdf_sampling; the 5-6-vertex chains on every
     * other call */
    spc_scene *sc = chain_mis_load(SCENE, "0.4", "19.8, 18, 15.3");
    if (!sc)
        return;
    spc_snee_params p;
    CHECK(spc_snee_parse("angular:long=0.2,longmax=4,sphlong=0.5", 2, &p));
    p.mis = true;
    static const double pts[3][2] = {{0.2, 0.15}, {0.35, 0.35}, {-0.2823, 0.2163}};
    /* 20,000 in quick mode too: at 10,000 BSDF sampling alone can find no path at the third point,
     * an estimate of 0 with no variance */
    double zmax = chain_mis_zmax(sc, &p, 1, pts, 3, CAMERA, 20000);
    CHECK_MSG(zmax < 4.0, "|z| %.2f", zmax);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(specular_prob_matches_sampling);
    RUN(long_chain_weight);
    RUN(weighted_sum_agrees_with_bsdf_sampling);
    RUN(past_long_max_weight);
    RUN(past_long_max_agrees_with_bsdf_sampling);
    return spc_test_finish();
}
