/*
 * tests/test_flat_bias.c: specular NEE through two glass slabs against brute force, at one floor
 * point (manifold/flat_chains.c, specular_nee.c).
 *
 * Under bench/check/two_slabs_sphere_light.xml's two tilted slabs, at the floor point below
 * pixel (15, 19) of the 32x32 image, the light arrives through four interfaces (both slabs) and
 * through five: into the lower slab, a total internal reflection off its thin side face, out, then
 * through the upper slab (about a third of the caustic there). The path integrator's split of
 * these paths is checked against brute force on the same point: specular NEE's estimate (its MIS
 * weight applied) must equal the BSDF-sampled paths' value times one minus the weight the MIS
 * leaves them. A chain the MIS credits to specular NEE that specular NEE never makes shows as a
 * deficit (here, before total internal reflections in chains across shapes were enumerated, 38%).
 * And no call may carry much more than its share: the five-vertex chains come with 1 / psi, psi their
 * probability per call.
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "bsdf/bsdf.h"
#include "core/rng.h"
#include "emitter/emitter.h"
#include "harness.h"
#include "manifold/chain.h"
#include "manifold/specular_nee.h"
#include "specula/specula.h"

static spc_scene *load(const char *rel)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", d ? d : ".", rel);
    spc_scene *sc = NULL;
    spc_error err;
    if (spc_scene_load(path, NULL, 0, &sc, &err) != SPC_OK) {
        char msg[1200];
        spc_error_format(&err, msg, sizeof msg);
        printf("  %s\n", msg);
        return NULL;
    }
    return sc;
}

/* One BSDF-sampled path from x through smooth glass to the light: its value (throughput times
 * radiance, green channel) and the part of it the MIS leaves to BSDF sampling; *k its specular
 * vertices (0 if it reaches no light through at least one). */
static void bsdf_path(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo, spc_rng *r,
                      double *value, double *bsdf_share, int *k_out)
{
    *value = *bsdf_share = 0.0;
    *k_out = 0;
    spc_bsdf_sample bs;
    if (!spc_bsdf_sample_dir(x->bsdf, x, SPC_MODE_RADIANCE, wo, spc_rng_next(r),
                             spc_v2(spc_rng_next(r), spc_rng_next(r)), &bs))
        return;
    double thr = bs.weight.g;
    spc_hit h = *x;
    spc_vec3 d = bs.wi;
    unsigned char ev[SPC_CHAIN_MAX_VERTICES];
    for (int k = 0;; ++k) {
        spc_ray ray = {spc_hit_offset(&h, d), d, 0, INFINITY};
        spc_hit nh;
        if (!spc_scene_intersect(sc, &ray, &nh))
            return;
        if (nh.emitter) {
            if (k < 1)
                return;
            *value = thr * spc_emitter_eval_area(nh.emitter, &nh, spc_neg(d)).g;
            double w = spc_snee_mis_bsdf_weight(sc, p, x, wo, bs.wi, 2, k, ev, &nh);
            *bsdf_share = *value * w;
            *k_out = k;
            return;
        }
        if (!spc_bsdf_is_delta_only(nh.bsdf) || k == SPC_CHAIN_MAX_VERTICES)
            return;
        spc_bsdf_sample s2;
        if (!spc_bsdf_sample_dir(nh.bsdf, &nh, SPC_MODE_RADIANCE, spc_neg(d), spc_rng_next(r),
                                 spc_v2(spc_rng_next(r), spc_rng_next(r)), &s2))
            return;
        thr *= s2.weight.g;
        ev[k] = (s2.lobe & SPC_LOBE_DELTA_TRANSMISSION) ? SPC_CHAIN_REFRACT : SPC_CHAIN_REFLECT;
        d = s2.wi;
        h = nh;
    }
}

TEST(two_slabs_side_face_reflection)
{
    spc_scene *sc = load("bench/check/two_slabs_sphere_light.xml");
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_vec3 cam = spc_v3(-0.4, 2.6, 3.4);
    spc_ray down = {spc_v3(-0.064, 0.2, 0.142), spc_v3(0, -1, 0), 0, INFINITY};
    spc_hit x;
    CHECK(spc_scene_intersect(sc, &down, &x) && x.shape_index == 0);
    spc_vec3 wo = spc_normalize(spc_sub(cam, x.p));
    spc_snee_params p;
    spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 2);
    p.any_surface = true;
    p.mis = true; /* as the path integrator runs it */
    /* the five- and six-vertex chains on a quarter and a fortieth of the calls (flat5=0.25,
     * flat6=0.025): shares at which this point's split is checked and a call's tail bounded */
    p.flat5_p = 0.25;
    p.flat6_p = 0.025;

    spc_rng r;
    spc_rng_seed(&r, 11, 3);
    const int calls = 3000;
    double s1 = 0.0, s2 = 0.0, vmax = 0.0;
    for (int i = 0; i < calls; ++i) {
        double v = spc_specular_nee_depth(sc, &p, &x, wo, 2, 9, &r, NULL).g;
        s1 += v;
        s2 += v * v;
        vmax = fmax(vmax, v);
    }
    double nee = s1 / calls, var_nee = fmax(0.0, s2 / calls - nee * nee) / calls;

    const long samples = 4000000;
    double b1 = 0.0, d1 = 0.0, d2 = 0.0, five = 0.0;
    for (long i = 0; i < samples; ++i) {
        double v, share;
        int k;
        bsdf_path(sc, &p, &x, wo, &r, &v, &share, &k);
        b1 += v;
        d1 += v - share;
        d2 += (v - share) * (v - share);
        five += k == 5 ? v : 0.0;
    }
    double brute = b1 / samples, want = d1 / samples;
    double var_want = fmax(0.0, d2 / samples - want * want) / samples;
    double z = (nee - want) / sqrt(var_nee + var_want);
    printf("  specular NEE %.4f +- %.4f (largest call %.1f x the mean), brute force's share for it %.4f +- %.4f "
           "(all %.4f, 5 vertices %.4f): z %.2f\n",
           nee, sqrt(var_nee), nee > 0.0 ? vmax / nee : 0.0, want, sqrt(var_want), brute, five / samples, z);
    CHECK(five / samples > 0.2 * brute); /* the five-vertex chains carry a good part here */
    CHECK(want > 0.9 * brute);           /* the MIS credits nearly all of it to specular NEE */
    CHECK_MSG(fabs(z) < 4.0, "specular NEE off the brute-force estimate by %.2f sigma", z);
    /* the five-vertex chains with their own probability per call (flat_psi), here 1/4, not the long
     * pass's 1 / 40: there one call in 40 carried 40x their third (the largest call 46x the mean) */
    CHECK_MSG(vmax < 15.0 * nee, "the largest call %.1f x the mean: a heavy tail", nee > 0.0 ? vmax / nee : 0.0);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(two_slabs_side_face_reflection);
    return spc_test_finish();
}
