/*
 * tests/test_microfacet_fast.c: the Beckmann shortcuts of bsdf/microfacet.c give the full formulas'
 * bits. Where a = cot(theta) / alpha >= 6, spc_microfacet_lambda returns 0 without its exp and erfc;
 * G1 = 1 / (1 + Lambda) must then equal 1 / (1 + the full Lambda) (memcmp), which the test checks
 * over a dense sweep of a from 0.5 to 1e4 (both sides of the limit), isotropic and anisotropic, and
 * at random directions. Where the visible slope's upper end x >= SPC_BECKMANN_SLOPE_CDF_FLAT (6), the
 * slope CDF's value there is taken as sqrt(pi): the full expression must give exactly that, checked
 * over a dense sweep of x from that limit to 10 and of tan_t up to its inverse.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "bsdf/microfacet.h"
#include "core/rng.h"
#include "harness.h"

/* microfacet.c's Lambda for Beckmann, in full (Heitz 2014, eq. 72) */
static double lambda_full(const spc_microfacet *md, spc_vec3 w)
{
    double z2 = w.z * w.z;
    if (z2 <= 0.0)
        return SPC_INF;
    double a2t2 = (w.x * w.x * md->alpha_u * md->alpha_u + w.y * w.y * md->alpha_v * md->alpha_v) / z2;
    if (a2t2 <= 0.0)
        return 0.0;
    double a = 1.0 / sqrt(a2t2);
    return 0.5 * (exp(-a * a) / (a * sqrt(SPC_PI)) - erfc(a));
}

static double g1_full(const spc_microfacet *md, spc_vec3 w, spc_vec3 m)
{
    if (spc_dot(w, m) * w.z <= 0.0)
        return 0.0;
    return 1.0 / (1.0 + lambda_full(md, w));
}

static bool same_bits(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

TEST(g1_sweep)
{
    const double alphas[][2] = {{0.01, 0.01}, {0.1, 0.1}, {0.25, 0.25}, {1.0, 1.0}, {0.05, 0.4}};
    const spc_vec3 m = spc_v3(0.0, 0.0, 1.0);
    int n = 0, bad = 0, at_one = 0;
    for (size_t k = 0; k < sizeof alphas / sizeof alphas[0]; ++k) {
        spc_microfacet md = spc_microfacet_make(SPC_MICROFACET_BECKMANN, alphas[k][0], alphas[k][1], true);
        for (int i = 0; i < 400000; ++i) {
            /* a from 0.5 to 1e4, log-spaced, at an azimuth that mixes both alphas */
            double a = 0.5 * pow(2e4, i / 399999.0);
            double phi = 0.7 + 1e-3 * (i % 13);
            double ca = cos(phi), sa = sin(phi);
            double alpha = sqrt(ca * ca * md.alpha_u * md.alpha_u + sa * sa * md.alpha_v * md.alpha_v);
            double tan_t = 1.0 / (a * alpha);
            spc_vec3 w = spc_normalize(spc_v3(tan_t * ca, tan_t * sa, 1.0));
            double g = spc_microfacet_g1(&md, w, m), ref = g1_full(&md, w, m);
            ++n;
            at_one += g == 1.0;
            if (!same_bits(g, ref) && bad++ < 5)
                printf("  alpha (%g, %g) a %.17g: G1 %.17g, full %.17g\n", md.alpha_u, md.alpha_v, a, g, ref);
        }
    }
    printf("  %d directions, %d with G1 = 1, %d differ\n", n, at_one, bad);
    CHECK(bad == 0);
    CHECK(at_one > n / 4); /* the shortcut's range was swept */
}

TEST(g1_random)
{
    spc_rng rng;
    spc_rng_seed(&rng, 7, 0);
    int bad = 0;
    for (int i = 0; i < 200000; ++i) {
        double au = 0.005 + 0.6 * spc_rng_next(&rng), av = i % 2 ? au : 0.005 + 0.6 * spc_rng_next(&rng);
        spc_microfacet md = spc_microfacet_make(SPC_MICROFACET_BECKMANN, au, av, true);
        double z = spc_rng_next(&rng), phi = 2.0 * SPC_PI * spc_rng_next(&rng);
        double s = sqrt(1.0 - z * z);
        spc_vec3 w = spc_v3(s * cos(phi), s * sin(phi), i % 3 ? z : -z);
        double mz = 0.2 + 0.8 * spc_rng_next(&rng), mphi = 2.0 * SPC_PI * spc_rng_next(&rng);
        double ms = sqrt(1.0 - mz * mz);
        spc_vec3 m = spc_v3(ms * cos(mphi), ms * sin(mphi), mz);
        double g = spc_microfacet_g1(&md, w, m), ref = g1_full(&md, w, m);
        if (!same_bits(g, ref) && bad++ < 5)
            printf("  G1 %.17g, full %.17g\n", g, ref);
    }
    CHECK(bad == 0);
}

TEST(slope_cdf_flat)
{
    /* microfacet.c's beckmann_slope_cdf at the upper end x = min(cot_t, 10) >= the flat limit */
    const double lim = SPC_BECKMANN_SLOPE_CDF_FLAT;
    const double flat = sqrt(SPC_PI);
    int bad = 0, n = 0;
    for (int i = 0; i < 200000; ++i) {
        double x = lim + (10.0 - lim) * i / 199999.0;
        for (int j = 0; j < 5; ++j) {
            /* tan_t from 1 / lim (x = cot_t = lim) down to 1e-8 */
            double tan_t = j == 0 ? 1.0 / lim : (j == 1 ? 1.0 / x : pow(10.0, -2.0 * j));
            if (tan_t > 1.0 / lim)
                continue;
            double F = 0.5 * sqrt(SPC_PI) * erfc(-x) + 0.5 * tan_t * exp(-x * x);
            ++n;
            if (!same_bits(F, flat) && bad++ < 5)
                printf("  x %.17g tan_t %.17g: F %.17g, sqrt(pi) %.17g\n", x, tan_t, F, flat);
        }
    }
    printf("  %d points, %d differ\n", n, bad);
    CHECK(bad == 0);
}

int main(void)
{
    RUN(g1_sweep);
    RUN(g1_random);
    RUN(slope_cdf_flat);
    return spc_test_finish();
}
