/*
 * tests/test_flat_chain_mis.c: the MIS weights of the paths that reach the light through five or six
 * vertices on flat glass (specular_nee.c, flat_psi), on bench/check/two_slabs_sphere_light.xml.
 *
 * Specular NEE's budget there is 2 vertices; where its longer chains run (long_p, the default) it
 * enumerates every chain of up to 4 vertices through flat faces at every call, and the chains of 5
 * and of 6 vertices each on a share of the calls (params.flat5_p, flat6_p), counted 1 / share; the
 * BSDF side weights those paths by the power heuristic against specular NEE's density times that
 * share. At the floor point below the two slabs where about a third of the light comes through five
 * vertices (into the lower slab, a total internal reflection off its thin side face, out, then
 * through the upper slab; test_flat_bias.c):
 * - under the scene's small light, the BSDF-sampled paths through 5 or 6 flat vertices have weight 1
 *   at the default shares (0: specular NEE never makes them), and a mean weight below 0.05 at a share
 *   of 0.01 (the light's density dwarfs the BSDF's even at the share);
 * - with a larger light (radius 0.3, the same power) and a share of 0.02, where specular NEE's
 *   density times the share is near the BSDF's (weights near 1/2: a share left out of either side
 *   moves the sum by about a sixth), specular NEE plus the BSDF-sampled paths it covers, weighted,
 *   agree with BSDF sampling alone: |z| < 4. (The enumeration makes every five-vertex chain that
 *   the MIS credits to it here: tests/test_flat_roots.c.)
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "chain_mis.h"
#include "core/rng.h"
#include "harness.h"
#include "render_util.h"
#include "manifold/snee_options.h"
#include "manifold/snee_plan.h"
#include "manifold/specular_nee.h"
#include "specula/specula.h"

#define SCENE "bench/check/two_slabs_sphere_light.xml"
#define CAMERA spc_v3(-0.4, 2.6, 3.4)
#define FLOOR 0
/* test_flat_bias.c's floor point: a third of its light through five vertices */
#define PX (-0.064)
#define PZ 0.142

/* The scene with the light's radius and radiance set (both NULL: the file's own) and, where res is
 * not NULL, the film's size. */
static spc_scene *load_res(const char *light_radius, const char *light_radiance, const char *res)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", d ? d : ".", SCENE);
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_define defs[3] = {{"light_radius", light_radius}, {"light_radiance", light_radiance}, {"res", res}};
    int n = light_radius ? (res ? 3 : 2) : 0;
    CHECK_MSG(spc_scene_load(path, defs, n, &sc, &err) == SPC_OK, "%s: %s", path, err.msg);
    return sc;
}

static spc_scene *load(const char *light_radius, const char *light_radiance)
{
    return load_res(light_radius, light_radiance, NULL);
}

/* The BSDF-sampled paths from the floor point through 5 or 6 flat vertices to the light, at most 60 of
 * 2M: their number, mean and largest MIS weight. */
static int five_six_weights(const spc_scene *sc, const spc_snee_params *p, double *mean, double *wmax)
{
    spc_hit x;
    CHECK(chain_mis_floor_point(sc, FLOOR, PX, PZ, &x));
    spc_vec3 wo = spc_normalize(spc_sub(CAMERA, x.p));
    spc_rng u;
    spc_rng_seed(&u, 5, 1);
    int n = 0;
    double wsum = 0.0;
    *wmax = 0.0;
    for (int i = 0; i < 2000000 && n < 60; ++i) {
        int k;
        double w;
        chain_mis_bsdf_path(sc, p, &x, wo, false, &u, &k, &w);
        if (k == 5 || k == 6) {
            ++n;
            wsum += w;
            *wmax = w > *wmax ? w : *wmax;
        }
    }
    *mean = n ? wsum / n : 0.0;
    return n;
}

TEST(five_vertex_weight)
{
    spc_scene *sc = load(NULL, NULL);
    if (!sc)
        return;
    spc_snee_params p;
    chain_mis_default_params(&p);
    /* the default: specular NEE never makes them, BSDF sampling carries them whole */
    double mean, wmax;
    int n = five_six_weights(sc, &p, &mean, &wmax);
    printf("    default (flat5=%g, flat6=%g): %d BSDF paths through 5-6 flat vertices, mean weight %.2g\n", p.flat5_p,
           p.flat6_p, n, mean);
    CHECK(n >= 10);
    CHECK_MSG(mean == 1.0, "mean weight %.6f at the default shares", mean);
    /* on a share of 0.01 of the calls: the small light's density times the share still dwarfs the
     * BSDF's */
    p.flat5_p = p.flat6_p = 0.01;
    n = five_six_weights(sc, &p, &mean, &wmax);
    printf("    flat5=flat6=0.01: %d paths, mean weight %.2g, largest %.2g\n", n, mean, wmax);
    CHECK(n >= 10);
    CHECK_MSG(mean < 0.05, "mean weight %.4f", mean);
    CHECK_MSG(wmax < 0.5, "largest weight %.4f", wmax);
    spc_scene_destroy(sc);
}

/* Specular NEE at the floor point under the larger light (radius 0.3, the same power), against the
 * part of the BSDF-sampled paths' value that the MIS credits to it, (1 - w) v, w the path's weight
 * (test_flat_bias.c's split): the z of their difference; *share_k the BSDF paths' value through
 * exactly k flat vertices over all of it, *n_k their number and *w_k their mean weight. */
static double snee_against_bsdf_share(const spc_snee_params *p, int k_of, double *share_k, int *n_k, double *w_k)
{
    spc_scene *sc = load("0.3", "17.8, 17, 16");
    if (!sc)
        return 1e9;
    spc_hit x;
    CHECK(chain_mis_floor_point(sc, FLOOR, PX, PZ, &x));
    spc_vec3 wo = spc_normalize(spc_sub(CAMERA, x.p));
    /* specular NEE's calls cost ~50x a BSDF path's */
    const int calls = 6000;
    const long paths = 1500000;
    spc_rng r, u;
    spc_rng_seed(&r, 11, 1);
    spc_rng_seed(&u, 13, 1);
    double s1 = 0.0, s2 = 0.0;
    for (int i = 0; i < calls; ++i) {
        double v = spc_rgb_lum(spc_specular_nee_depth(sc, p, &x, wo, 2, CHAIN_MIS_LONG_MAX, &r, NULL));
        s1 += v;
        s2 += v * v;
    }
    double nee = s1 / calls, var_nee = fmax(0.0, s2 / calls - nee * nee) / calls;
    double b1 = 0.0, d1 = 0.0, d2 = 0.0, f1 = 0.0, wk = 0.0;
    int nk = 0;
    for (long i = 0; i < paths; ++i) {
        int k;
        double w;
        spc_rng u0 = u;
        double v = chain_mis_bsdf_path(sc, p, &x, wo, true, &u, &k, &w); /* plain: its whole value */
        if (!(v > 0.0))
            continue;
        chain_mis_bsdf_path(sc, p, &x, wo, false, &u0, &k, &w); /* the same draws: its weight */
        double d = (1.0 - w) * v;
        b1 += v;
        d1 += d;
        d2 += d * d;
        if (k == k_of) {
            f1 += v;
            ++nk;
            wk += w;
        }
    }
    double want = d1 / paths, var_want = fmax(0.0, d2 / paths - want * want) / paths;
    double z = (nee - want) / sqrt(var_nee + var_want);
    printf("    specular NEE %.4f +- %.4f, the BSDF paths' share for it %.4f +- %.4f (all %.4f, %d vertices %.4f; "
           "%d paths through %d, mean weight %.2f): z %+.2f\n",
           nee, sqrt(var_nee), want, sqrt(var_want), b1 / paths, k_of, f1 / paths, nk, k_of, nk ? wk / nk : 0.0, z);
    *share_k = b1 > 0.0 ? f1 / b1 : 0.0;
    *n_k = nk;
    *w_k = nk ? wk / nk : 0.0;
    spc_scene_destroy(sc);
    return z;
}

TEST(weighted_sum_agrees_with_bsdf_sampling)
{
    spc_snee_params p;
    chain_mis_default_params(&p);
    p.flat5_p = p.flat6_p = 0.02;
    double share5, w5;
    int n5;
    double z = snee_against_bsdf_share(&p, 5, &share5, &n5, &w5);
    CHECK(share5 > 0.15);                  /* the five-vertex chains carry a good part here */
    CHECK(n5 > 0 && w5 > 0.2 && w5 < 0.8); /* and are weighted near 1/2 at this share */
    CHECK_MSG(fabs(z) < 4.0, "specular NEE off the BSDF paths' share for it by %.2f sigma", z);
}

/* The chains of 3 and 4 vertices on a share of the calls (params.flat34_p, "flat34=Q"): specular
 * NEE counts them 1 / Q times and the BSDF side weighs the paths through them against its density
 * times Q, so the weights of the BSDF paths through 4 flat vertices rise from the default's (every
 * call) and the sum still agrees. A share left out of the BSDF side would take the four-vertex
 * paths' part, most of the light here (three quarters), from the sum: 5 sigma. */
TEST(share_of_three_and_four_vertex_chains_agrees)
{
    spc_snee_params p;
    chain_mis_default_params(&p);
    double share4, w4_every, w4_share;
    int n4;
    double z = snee_against_bsdf_share(&p, 4, &share4, &n4, &w4_every);
    CHECK_MSG(fabs(z) < 4.0, "every call: specular NEE off the BSDF paths' share for it by %.2f sigma", z);
    p.flat34_p = 0.05;
    z = snee_against_bsdf_share(&p, 4, &share4, &n4, &w4_share);
    CHECK(share4 > 0.1 && n4 > 100);
    CHECK_MSG(w4_share > w4_every + 0.1, "four-vertex weights %.3f at the share, %.3f at every call", w4_share,
              w4_every);
    CHECK_MSG(fabs(z) < 4.0, "flat34=0.05: specular NEE off the BSDF paths' share for it by %.2f sigma", z);
}

/* The whole image at flat34=0.3 (and the longer chains' other shares, flat5=0.3) against specular
 * NEE off: per-pixel z-test (Sidak) and image means, 8 x 8, under a light of radius 0.1 (the same
 * power). */
TEST(share_render_agrees_with_none)
{
    spc_scene *sc = load_res("0.1", "160, 153, 144", "8");
    if (!sc)
        return;
    bool quick = getenv("SPC_TEST_QUICK") != NULL;
    spc_film *img = tu_render_nee(sc, "path", "angular:camera=0.1,first=0.1,later=0.1,long=0.3,flat34=0.3,flat5=0.3",
                                  quick ? 64 : 256, 2, 41, NULL);
    spc_film *ref = tu_render_nee(sc, "path", "none", quick ? 4096 : 16384, 2, 42, NULL);
    CHECK(img && ref);
    if (img && ref) {
        spc_diff_result r;
        memset(&r, 0, sizeof r);
        CHECK(tu_image_agrees(img, ref, 0.99, "flat34=0.3 vs none", &r));
        double mi, si, mr, sr;
        tu_image_mean(img, 1, &mi, &si);
        tu_image_mean(ref, 1, &mr, &sr);
        printf("    flat34=0.3: z-test pass %.4f of %d pixels; means %.5f +- %.5f vs %.5f +- %.5f\n",
               r.ztest_pass_fraction, img->width * img->height, mi, si, mr, sr);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

/* The plan's setting for slabs under larger lights (SPC_SNEE_PLAN_FLAT_LARGE: light tracing on every
 * sample, the 3- and 4-vertex chains on a share of the calls) against specular NEE off: per-pixel
 * z-test (Sidak) and image means, 8 x 8, under a light of radius 0.25 (the same power). */
TEST(large_light_setting_agrees_with_none)
{
    spc_scene *sc = load_res("0.25", "25.6, 24.5, 23.0", "8");
    if (!sc)
        return;
    bool quick = getenv("SPC_TEST_QUICK") != NULL;
    spc_film *img = tu_render_nee(
        sc, "path", "angular:camera=0.1,first=0.1,later=0.1" SPC_SNEE_PLAN_FLAT_LARGE SPC_SNEE_PLAN_FLAT_LARGE_GUIDES,
        quick ? 64 : 256, 2, 43, NULL);
    spc_film *ref = tu_render_nee(sc, "path", "none", quick ? 4096 : 16384, 2, 44, NULL);
    CHECK(img && ref);
    if (img && ref) {
        spc_diff_result r;
        memset(&r, 0, sizeof r);
        CHECK(tu_image_agrees(img, ref, 0.99, "large-light setting vs none", &r));
        double mi, si, mr, sr;
        tu_image_mean(img, 1, &mi, &si);
        tu_image_mean(ref, 1, &mr, &sr);
        CHECK_MSG(fabs(mi - mr) < 4.0 * sqrt(si * si + sr * sr), "image means %.5f +- %.5f vs %.5f +- %.5f", mi, si, mr,
                  sr);
        printf("    %s: z-test pass %.4f of %d pixels; means %.5f +- %.5f vs %.5f +- %.5f\n",
               SPC_SNEE_PLAN_FLAT_LARGE SPC_SNEE_PLAN_FLAT_LARGE_GUIDES, r.ztest_pass_fraction,
               img->width * img->height, mi, si, mr, sr);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(five_vertex_weight);
    RUN(weighted_sum_agrees_with_bsdf_sampling);
    RUN(share_of_three_and_four_vertex_chains_agrees);
    RUN(share_render_agrees_with_none);
    RUN(large_light_setting_agrees_with_none);
    return spc_test_finish();
}
