/*
 * tests/test_microfacet_many.c: the Beckmann visible-slope search of bsdf/microfacet_many.c and the
 * batches built on it.
 * - Its roots equal those of the same search on libm's erfc and exp (the one-lane search it
 *   replaced, copied below): the CDF there within 5e-14 of its range (the roots within 1e-11
 *   (1 + |x|): farther apart only where the density is small, in the tails), over random
 *   incidences, u and guesses, and over the tails' end cells.
 * - Each lane's answer is the same bits alone (n = 1) and in batches of any size and mix, under
 *   every vector instruction set (children of this program with SPECULA_VECTOR_ISA); and the base
 *   variant (exp in its plain form) and the vector ones (its fused form) give the same roots.
 * - spc_microfacet_sample_many and spc_roughconductor_sample_many (through spc_bsdf_sample_dir_many,
 *   also under twosided from the back) give their one-at-a-time functions' values bit for bit.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bsdf/bsdf.h"
#include "bsdf/microfacet.h"
#include "core/rng.h"
#include "core/warp.h"
#include "harness.h"

/* The one-lane search on libm's erfc and exp (microfacet.c before the lanes' kernel). */
static double ref_cdf(double x, double tan_t) { return 0.5 * sqrt(SPC_PI) * erfc(-x) + 0.5 * tan_t * exp(-x * x); }

static double ref_search(double u, double tan_t, double cot_t, double x)
{
    double lo = -10.0, hi = spc_min(cot_t, 10.0);
    double f_lo = ref_cdf(lo, tan_t);
    double f_hi = hi >= SPC_BECKMANN_SLOPE_CDF_FLAT && tan_t <= 1.0 / SPC_BECKMANN_SLOPE_CDF_FLAT ? sqrt(SPC_PI)
                                                                                                  : ref_cdf(hi, tan_t);
    double target = f_lo + u * (f_hi - f_lo);
    x = spc_clamp(x, lo, hi);
    if (!(x > lo && x < hi))
        x = 0.5 * (lo + hi);
    for (int it = 0; it < 60; ++it) {
        double e = exp(-x * x);
        double F = ref_cdf(x, tan_t) - target;
        if (F == 0.0)
            return x;
        if (F > 0.0)
            hi = x;
        else
            lo = x;
        double a = 1.0 - x * tan_t, d1 = a * e;
        if (!(d1 > 0.0)) {
            x = 0.5 * (lo + hi);
            continue;
        }
        double d2 = (-tan_t - 2.0 * x * a) * e, newton = F / d1, den = 1.0 - 0.5 * newton * d2 / d1;
        bool halley = den > 0.5;
        double next = x - (halley ? newton / den : newton), scale = 1.0 + fabs(x);
        if (fabs(newton) <= 1e-14 * scale)
            return next;
        if (next > lo && next < hi) {
            double d3 = (-2.0 + 6.0 * x * tan_t + 4.0 * x * x - 4.0 * x * x * x * tan_t) * e;
            double r = d2 / d1, step = fabs(next - x), K = fabs(d3 / (6.0 * d1) - 0.25 * r * r);
            if (halley && (1.0 + K) * step * step * step <= 1e-15 * scale)
                return next;
        } else {
            next = 0.5 * (lo + hi);
        }
        if (hi - lo <= 1e-15 * scale)
            return next;
        x = next;
    }
    return x;
}

static bool same_bits(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* A random query: incidence from normal (the y-slope's search) to grazing, u anywhere (also in the tails' end cells), a
 * guess near the root, or far from it, or the Gaussian's. */
static void random_query(spc_rng *r, double *u, double *tan_t, double *cot_t, double *guess)
{
    /* one in ten at tan_t = 0: the y-slope's search (erf(x) = 2u - 1) */
    double theta = spc_rng_next(r) < 0.1 ? 0.0 : spc_rng_next(r) * 1.55 + 1e-4;
    *tan_t = tan(theta);
    *cot_t = theta > 0.0 ? 1.0 / *tan_t : SPC_INF;
    double k = spc_rng_next(r);
    *u = k < 0.1 ? spc_rng_next(r) * 0.004 : k < 0.2 ? 1.0 - spc_rng_next(r) * 0.004 : spc_rng_next(r);
    double g = spc_erfinv(2.0 * spc_clamp(*u, 1e-12, 1.0 - 1e-12) - 1.0);
    double m = spc_rng_next(r);
    *guess = m < 0.4   ? g
             : m < 0.8 ? ref_search(*u, *tan_t, *cot_t, g) + (spc_rng_next(r) - 0.5) * 0.01
                       : (spc_rng_next(r) - 0.5) * 8.0;
}

TEST(slope_matches_libm_search)
{
    spc_rng r;
    spc_rng_seed(&r, 11, 2);
    int bad = 0;
    double worst_x = 0.0, worst_f = 0.0;
    for (int i = 0; i < 200000; ++i) {
        double u, tan_t, cot_t, g;
        random_query(&r, &u, &tan_t, &cot_t, &g);
        double x = g, xr = ref_search(u, tan_t, cot_t, g);
        spc_beckmann_slope_x_many(1, &u, &tan_t, &cot_t, &x);
        double hi = spc_min(cot_t, 10.0);
        double range = ref_cdf(hi, tan_t) - ref_cdf(-10.0, tan_t);
        double dx = fabs(x - xr) / (1.0 + fabs(xr)), df = fabs(ref_cdf(x, tan_t) - ref_cdf(xr, tan_t)) / range;
        worst_x = spc_max(worst_x, dx);
        worst_f = spc_max(worst_f, df);
        if (!(df <= 5e-14 && dx <= 1e-11)) {
            if (bad < 5)
                printf("  u %.17g tan_t %.17g guess %.17g: x %.17g, libm's search %.17g\n", u, tan_t, g, x, xr);
            ++bad;
        }
    }
    printf("  200000 queries: largest |x - x_libm| / (1 + |x|) %.3g, CDF difference / range %.3g\n", worst_x, worst_f);
    CHECK_MSG(bad == 0, "%d roots differ from libm's search", bad);
}

TEST(slope_batches_match_one_lane)
{
    spc_rng r;
    spc_rng_seed(&r, 12, 3);
    int bad = 0;
    for (int t = 0; t < 3000; ++t) {
        enum { N = 40 };
        double u[N], tan_t[N], cot_t[N], g[N], x[N];
        int n = 1 + (int)(spc_rng_next(&r) * N);
        for (int i = 0; i < n; ++i) {
            random_query(&r, &u[i], &tan_t[i], &cot_t[i], &g[i]);
            x[i] = g[i];
        }
        spc_beckmann_slope_x_many(n, u, tan_t, cot_t, x);
        for (int i = 0; i < n; ++i) {
            double x1 = g[i];
            spc_beckmann_slope_x_many(1, &u[i], &tan_t[i], &cot_t[i], &x1);
            bad += !same_bits(x[i], x1);
        }
    }
    CHECK_MSG(bad == 0, "%d lanes differ from their one-lane answers", bad);
}

static spc_vec3 random_dir_up(spc_rng *r)
{
    double z = spc_rng_next(r) * 0.999 + 0.0005, phi = 2.0 * SPC_PI * spc_rng_next(r), s = sqrt(1.0 - z * z);
    return spc_v3(s * cos(phi), s * sin(phi), z);
}

TEST(microfacet_sample_many_matches_one_at_a_time)
{
    spc_rng r;
    spc_rng_seed(&r, 13, 4);
    int bad = 0;
    for (int t = 0; t < 2000; ++t) {
        enum { N = 37 };
        spc_microfacet md[N];
        spc_vec3 w[N], m[N];
        spc_vec2 u[N];
        double pdf[N];
        int n = 1 + (int)(spc_rng_next(&r) * N);
        for (int i = 0; i < n; ++i) {
            /* mostly visible Beckmann (isotropic and anisotropic), some GGX and some without
             * visible-normal sampling, some directions at normal incidence or below the horizon */
            double k = spc_rng_next(&r);
            spc_microfacet_type type = k < 0.8 ? SPC_MICROFACET_BECKMANN : SPC_MICROFACET_GGX;
            double au = 0.005 + spc_rng_next(&r) * 0.6, av = spc_rng_next(&r) < 0.5 ? au : 0.005 + spc_rng_next(&r);
            md[i] = spc_microfacet_make(type, au, av, spc_rng_next(&r) < 0.9);
            double d = spc_rng_next(&r);
            w[i] = d < 0.05 ? spc_v3(0, 0, 1) : d < 0.1 ? spc_neg(random_dir_up(&r)) : random_dir_up(&r);
            u[i] = spc_v2(spc_rng_next(&r), spc_rng_next(&r));
        }
        spc_microfacet_sample_many(n, md, w, u, m, pdf);
        for (int i = 0; i < n; ++i) {
            double p1;
            spc_vec3 m1 = spc_microfacet_sample(&md[i], w[i], u[i], &p1);
            bad += !(same_bits(m[i].x, m1.x) && same_bits(m[i].y, m1.y) && same_bits(m[i].z, m1.z) &&
                     same_bits(pdf[i], p1));
        }
    }
    CHECK_MSG(bad == 0, "%d normals or densities differ", bad);
}

/* a hit with a frame of its own at the origin */
static spc_hit frame_hit(spc_rng *r, const spc_bsdf *b)
{
    spc_hit h;
    memset(&h, 0, sizeof h);
    spc_vec3 n = random_dir_up(r);
    if (spc_rng_next(r) < 0.5)
        n = spc_v3(n.x, n.z, n.y);
    h.sh = spc_frame_from_n(n);
    h.ng = n;
    h.bsdf = b;
    return h;
}

TEST(bsdf_sample_many_matches_one_at_a_time)
{
    /* a Beckmann rough metal (alone and under twosided, seen from both sides), a GGX one and a
     * diffuse BSDF: the batch takes the Beckmann lanes, the others go one at a time */
    spc_bsdf beck, ggx, diff, two;
    memset(&beck, 0, sizeof beck);
    beck.type = SPC_BSDF_ROUGHCONDUCTOR;
    beck.distribution = SPC_MICROFACET_BECKMANN;
    beck.sample_visible = true;
    beck.cond_eta = spc_rgb3(0.2, 0.92, 1.1);
    beck.cond_k = spc_rgb3(3.9, 2.45, 2.14);
    ggx = beck;
    ggx.distribution = SPC_MICROFACET_GGX;
    memset(&diff, 0, sizeof diff);
    diff.type = SPC_BSDF_DIFFUSE;
    memset(&two, 0, sizeof two);
    two.type = SPC_BSDF_TWOSIDED;
    two.nested[0] = &beck;
    const spc_bsdf *kinds[] = {&beck, &two, &two, &ggx, &diff};
    spc_rng r;
    spc_rng_seed(&r, 14, 5);
    int bad = 0, batched = 0;
    for (int t = 0; t < 2000; ++t) {
        enum { N = 24 };
        const spc_bsdf *b[N];
        spc_hit hit[N];
        const spc_hit *h[N];
        spc_vec3 wo[N];
        double ul[N];
        spc_vec2 u[N];
        spc_bsdf_sample out[N];
        bool ok[N];
        int n = 1 + (int)(spc_rng_next(&r) * N);
        for (int i = 0; i < n; ++i) {
            b[i] = spc_rng_next(&r) < 0.05 ? NULL : kinds[(int)(spc_rng_next(&r) * 5)];
            hit[i] = frame_hit(&r, b[i]);
            h[i] = &hit[i];
            spc_vec3 l = random_dir_up(&r);
            if (spc_rng_next(&r) < 0.3)
                l = spc_neg(l); /* the back side: twosided flips, the others sample nothing */
            wo[i] = spc_frame_to_world(&hit[i].sh, l);
            ul[i] = spc_rng_next(&r);
            u[i] = spc_v2(spc_rng_next(&r), spc_rng_next(&r));
            batched += b[i] && b[i] != &ggx && b[i] != &diff;
        }
        spc_bsdf_sample_dir_many(n, b, h, SPC_MODE_RADIANCE, wo, ul, u, out, ok);
        for (int i = 0; i < n; ++i) {
            spc_bsdf_sample o1;
            bool ok1 = spc_bsdf_sample_dir(b[i], h[i], SPC_MODE_RADIANCE, wo[i], ul[i], u[i], &o1);
            bool same = ok[i] == ok1;
            if (same && ok1)
                same = same_bits(out[i].wi.x, o1.wi.x) && same_bits(out[i].wi.y, o1.wi.y) &&
                       same_bits(out[i].wi.z, o1.wi.z) && same_bits(out[i].weight.r, o1.weight.r) &&
                       same_bits(out[i].weight.g, o1.weight.g) && same_bits(out[i].weight.b, o1.weight.b) &&
                       same_bits(out[i].pdf, o1.pdf) && out[i].lobe == o1.lobe && same_bits(out[i].eta, o1.eta);
            bad += !same;
        }
    }
    printf("  %d lanes through the rough metals' batch\n", batched);
    CHECK_MSG(bad == 0, "%d samples differ", bad);
}

/* The same under the other instruction sets the kernel is compiled for (SPECULA_VECTOR_ISA caps the
 * one the process picks, so each runs in a child process of this program). */
TEST(batches_every_isa)
{
    const char *const isas[] = {"base", "avx2", "avx512"};
    spc_t_under_isas("slope_batches_match_one_lane,microfacet_sample_many_matches_one_at_a_time", isas, 3);
}

/* A digest of the bits of many roots, one lane at a time and in batches of 16. */
static unsigned long long slope_digest_value(void)
{
    spc_rng r;
    spc_rng_seed(&r, 13, 4);
    unsigned long long h = 1469598103934665603ull; /* FNV-1a over the roots' bytes */
    for (int t = 0; t < 2000; ++t) {
        enum { N = 16 };
        double u[N], tan_t[N], cot_t[N], g[N], x[N];
        for (int i = 0; i < N; ++i) {
            random_query(&r, &u[i], &tan_t[i], &cot_t[i], &g[i]);
            x[i] = g[i];
        }
        spc_beckmann_slope_x_many(N, u, tan_t, cot_t, x);
        double x1 = g[0];
        spc_beckmann_slope_x_many(1, &u[0], &tan_t[0], &cot_t[0], &x1);
        for (int i = 0; i <= N; ++i) {
            unsigned char b[sizeof(double)];
            memcpy(b, i < N ? &x[i] : &x1, sizeof b);
            for (size_t k = 0; k < sizeof b; ++k)
                h = (h ^ b[k]) * 1099511628211ull;
        }
    }
    return h;
}

/* In a child (SPC_SLOPE_DIGEST names a file): writes slope_digest_value() there. */
TEST(slope_digest)
{
    const char *path = getenv("SPC_SLOPE_DIGEST");
    if (!path)
        return;
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (f) {
        fprintf(f, "%llx\n", slope_digest_value());
        fclose(f);
    }
}

/* The same roots, bit for bit, under every instruction set: the base variant's exp in its plain
 * form (truncation and correction, 1 + 2 d then times 2^k), the AVX2 and AVX-512 variants' (and
 * the one-lane search's) in the fused form (floor, one fused multiply-add). */
TEST(same_roots_every_isa)
{
    char exe[4096];
    if (!spc_t_self_exe(exe, sizeof exe))
        return;
    unsigned long long own = slope_digest_value();
    const char *isas[] = {"base", "avx2", "avx512"};
    for (int i = 0; i < 3; ++i) {
        char path[256], cmd[4600];
        snprintf(path, sizeof path, "/tmp/spc_test_slope_digest_%d_%s", (int)getpid(), isas[i]);
        snprintf(cmd, sizeof cmd, "SPECULA_VECTOR_ISA=%s SPC_SLOPE_DIGEST=%s SPC_TEST_ONLY=slope_digest '%s' >/dev/null",
                 isas[i], path, exe);
        int rc = system(cmd);
        CHECK_MSG(rc == 0, "%s: exit status %d", isas[i], rc);
        unsigned long long h = 0;
        FILE *f = fopen(path, "r");
        CHECK_MSG(f != NULL && fscanf(f, "%llx", &h) == 1, "%s: no digest", isas[i]);
        if (f)
            fclose(f);
        remove(path);
        CHECK_MSG(h == own, "%s: roots' digest %llx, this process's %llx", isas[i], h, own);
    }
}

int main(void)
{
    RUN(slope_matches_libm_search);
    RUN(slope_batches_match_one_lane);
    RUN(microfacet_sample_many_matches_one_at_a_time);
    RUN(bsdf_sample_many_matches_one_at_a_time);
    RUN(batches_every_isa);
    RUN(slope_digest);
    RUN(same_roots_every_isa);
    return spc_test_finish();
}
