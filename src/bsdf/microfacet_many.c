/*
 * bsdf/microfacet_many.c: the Beckmann visible x-slope of many samples at once
 * (spc_beckmann_slope_x_many), for a path tracer that runs many paths side by side
 * (integrator/path_wave.c) and, one at a time, for every other caller of spc_microfacet_sample.
 *
 * The slope is the root of F(x) = sqrt(pi)/2 erfc(-x) + tan_t/2 exp(-x^2) = u F(hi) on
 * [-10, hi], hi = min(cot_t, 10) (Heitz and d'Eon 2014, sec. 4, alpha = 1), found by Halley's method
 * safeguarded with bisection from the caller's guess, with the stopping tests of the one-lane search
 * it replaces: a Halley step ends the search when its error estimate K |step|^3,
 * K = |F'''/(6 F') - F''^2/(4 F'^2)|, is below 1e-15 (1 + |x|); so does a Newton step below
 * 1e-14 (1 + |x|), or a bracket narrower than 1e-15 (1 + |x|).
 *
 * Why a kernel of its own: libm's erfc and exp are calls with branches on the argument's range, one
 * lane at a time (per sample about 1.9 evaluations of F, each an erfc and an exp: 5% of veach-mis's
 * time). Here F comes from arithmetic only, in one loop over the lanes in structure-of-arrays form
 * whose branches are selects, compiled also for AVX2 and AVX-512 and chosen at run time, so 4 or 8
 * lanes share each instruction:
 * - exp(-x^2) by Cephes' exp (Moshier): x = k ln2 + r with ln2 in two parts, a (2,3) Pade form of
 *   exp(r), times 2^k built in the exponent field.
 * - erfc(z) for z = |x| in [0, 10] as t exp(-z^2) Q(t), t = 1 / (1 + z/2), Q a polynomial of
 *   degree 18 in t on [1/6, 1] (fitted to erfc in 40-digit arithmetic: relative error below
 *   2e-14 of erfc over the range); exp(-z^2) is the one exp(-x^2) above. erfc(-x) = 2 - erfc(x)
 *   for x > 0.
 * So the roots agree with those of the same search on libm's F: the CDF there within 5e-14 of its
 * range (test_microfacet_many measures 3e-15 over 200000 queries): the sampled normals move by
 * rounding, the distribution does not. A lane whose search has ended keeps its x (the loop runs
 * until every lane has ended), so each lane's answer depends on its own inputs only, whatever lanes
 * share its batch, and every ISA variant gives the same bits: ISO C11 builds do not contract a * b + c,
 * and the one fused multiply-add written out (exp_lane's, in the AVX2 and AVX-512 variants) rounds
 * to the plain form's value. One lane (the one-sample callers) runs a scalar variant with that fused
 * form: a single search is one chain of dependent operations, and that form's chain is shorter.
 */
/* O3 vectorizes the lanes' loops; without trapping math GCC may if-convert the divisions and the
 * other selected expressions that it otherwise moves under the selects (AVX2 has no masked
 * arithmetic to run them there). Neither changes a value (no contraction, no reassociation). A
 * pragma rather than per-function attributes, so that the inline helpers below are compiled with
 * the same options. */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("O3", "no-trapping-math")
#endif
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <string.h>

/* clang contracts a * b + c into a fused multiply-add by default where the target has one */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

#include "bsdf/microfacet.h"
#include "core/cpu_isa.h"

/* Slopes beyond this are irrelevant for the Beckmann slope CDF: exp(-10^2) is below double
 * precision relative to the distribution's mass (microfacet.c's search interval). */
#define SLOPE_LIMIT 10.0
/* Iterations of the search: from microfacet.c's tabulated guess about 1.9 on average, up to 19 in
 * the tails' end cells; the bound only guards against pathological inputs. */
#define SLOPE_MAX_ITERATIONS 60
/* lanes per pass of the loop (arrays on the stack); a pass of more than one lane is rounded up to a
 * multiple of SLOPE_VECTOR with idle lanes so that no lane runs in a scalar remainder loop */
#define SLOPE_BATCH 32
#define SLOPE_VECTOR 8

/* Q(t) = erfc(z) exp(z^2) / t, t = 1 / (1 + z/2), as a polynomial of degree 18 in
 * s = (t - Q_MID) / Q_HALF in [-1, 1] (t in [1/6, 1], z in [0, 10]): Chebyshev interpolation at 19
 * nodes in 40-digit arithmetic (mpmath), converted to powers of s there. Summed in double as
 * below, t exp(-z^2) Q(t) is within 2e-14 of erfc(z) relative on the range. */
#define Q_MID 0.5833333333333334
#define Q_HALF 0.4166666666666667
static const double q_poly[19] = {
    0.5720119757853606,     0.3262225208900769,     0.10202978097940316,     0.005962389355702233,
    -0.006154109072060389,  -0.000617104109034194,  0.0005960201117785315,   -1.570687366950846e-06,
    -6.58034543084785e-05,  1.3612671159168829e-05, 4.964118972050812e-06,   -3.191370296687649e-06,
    3.0324319019343806e-07, 3.707709889265226e-07,  -1.7932399000454458e-07, -1.148415179060192e-09,
    2.7317509667868494e-08, -4.604287271113589e-09, -1.4743862181642865e-09};

/* exp(a) for a in [-700, 0] (Cephes' exp.c: Pade form and ln2 split). With fused set (a variant
 * compiled for FMA and SSE4.1) the same value by a shorter chain: floor(y) in one rounding
 * instruction instead of truncation and a correction, and (1 + 2 p/(q - p)) 2^k as one fused
 * multiply-add, d (2 s) + s with d = p/(q - p), s = 2^k: 2 d and the scalings by 2^k are exact
 * (every value here is normal), so the one rounding of s (2 d + 1) is s times the rounding of
 * 1 + 2 d, the plain form's. */
static inline __attribute__((always_inline)) double exp_lane(double a, const int fused)
{
    const double log2e = 1.4426950408889634073599, c1 = 6.93145751953125E-1, c2 = 1.42860682030941723212E-6;
    double y = log2e * a + 0.5;
    int k;
    double kd;
    if (fused) {
        kd = floor(y);
        k = (int)kd;
    } else {
        k = (int)y; /* truncation, then down to floor(y) for negative y */
        k -= (double)k > y;
        kd = k;
    }
    double r = a - kd * c1;
    r = r - kd * c2;
    double rr = r * r;
    double p = r * ((1.26177193074810590878E-4 * rr + 3.02994407707441961300E-2) * rr + 9.99999999999999999910E-1);
    double q = ((3.00198505138664455042E-6 * rr + 2.52448340349684104192E-3) * rr + 2.27265548208155028766E-1) * rr +
               2.00000000000000000009E0;
    double d = p / (q - p);
    uint64_t bits = (uint64_t)(int64_t)(k + 1023) << 52; /* 2^k, k in [-1010, 0] */
    double s;
    memcpy(&s, &bits, sizeof s);
    if (fused)
        return fma(d, 2.0 * s, s);
    return (1.0 + 2.0 * d) * s;
}

/* erfc(-x) for |x| <= 10, given e = exp(-x^2). The polynomial in four interleaved Horner chains in
 * s^4 (its terms of degree 0, 1, 2 and 3 mod 4): each is short, so their latencies overlap. */
static inline __attribute__((always_inline)) double erfc_neg_lane(double x, double e)
{
    const double *c = q_poly;
    double z = fabs(x);
    double t = 1.0 / (1.0 + 0.5 * z);
    double s = (t - Q_MID) * (1.0 / Q_HALF), s2 = s * s, s4 = s2 * s2;
    double p0 = (((c[16] * s4 + c[12]) * s4 + c[8]) * s4 + c[4]) * s4 + c[0];
    double p1 = (((c[17] * s4 + c[13]) * s4 + c[9]) * s4 + c[5]) * s4 + c[1];
    double p2 = (((c[18] * s4 + c[14]) * s4 + c[10]) * s4 + c[6]) * s4 + c[2];
    double p3 = ((c[15] * s4 + c[11]) * s4 + c[7]) * s4 + c[3];
    double q = (p0 + s * p1) + s2 * (p2 + s * p3);
    double erfc_z = t * e * q;
    return x > 0.0 ? 2.0 - erfc_z : erfc_z;
}

/* F(x) written out, given e = exp(-x^2) */
static inline __attribute__((always_inline)) double cdf_lane(double x, double e, double tan_t)
{
    return 0.5 * sqrt(SPC_PI) * erfc_neg_lane(x, e) + 0.5 * tan_t * e;
}

typedef struct slope_lanes {
    double tan_t[SLOPE_BATCH], target[SLOPE_BATCH], x[SLOPE_BATCH], lo[SLOPE_BATCH], hi[SLOPE_BATCH];
    int done[SLOPE_BATCH];
} slope_lanes;

/* The search's interval, target and start for m lanes (x holds the guess, target u). The CDF at
 * hi has a loop of its own: GCC vectorizes it, not the rest. */
static inline __attribute__((always_inline)) void slope_start(int m, slope_lanes *a, const double *cot_t, const int fused)
{
    double f_hi[SLOPE_BATCH];
    int flat_end[SLOPE_BATCH], steep = 0;
    /* the CDF at lo is below 1e-43 and at hi is sqrt(pi) where hi is in the flat end
     * (microfacet.h): the target is u F(hi), F(hi) computed only where some lane needs it */
    for (int i = 0; i < m; ++i) {
        double hi = cot_t[i] < SLOPE_LIMIT ? cot_t[i] : SLOPE_LIMIT;
        a->hi[i] = hi;
        f_hi[i] = sqrt(SPC_PI);
        flat_end[i] = (hi >= SPC_BECKMANN_SLOPE_CDF_FLAT) & (a->tan_t[i] <= 1.0 / SPC_BECKMANN_SLOPE_CDF_FLAT);
        steep |= !flat_end[i];
    }
    if (steep)
        for (int i = 0; i < m; ++i)
            f_hi[i] = cdf_lane(a->hi[i], exp_lane(-a->hi[i] * a->hi[i], fused), a->tan_t[i]);
    for (int i = 0; i < m; ++i) {
        double lo = -SLOPE_LIMIT, hi = a->hi[i];
        a->target[i] *= flat_end[i] ? sqrt(SPC_PI) : f_hi[i];
        double x = a->x[i];
        x = x < lo ? lo : x;
        x = x > hi ? hi : x;
        a->x[i] = ((x > lo) & (x < hi)) ? x : 0.5 * (lo + hi);
        a->lo[i] = lo;
        a->done[i] = 0;
    }
}

/* One step of every lane whose search has not ended; returns how many have not ended after it. */
static inline __attribute__((always_inline)) int slope_step(int m, slope_lanes *a, const int fused)
{
    int open = 0;
    for (int i = 0; i < m; ++i) {
        double x = a->x[i], tan_t = a->tan_t[i], lo = a->lo[i], hi = a->hi[i];
        double e = exp_lane(-x * x, fused);
        double F = cdf_lane(x, e, tan_t) - a->target[i];
        int root = F == 0.0;
        double lo1 = F > 0.0 ? lo : x, hi1 = F > 0.0 ? x : hi;
        double mid = 0.5 * (lo1 + hi1);
        double c = 1.0 - x * tan_t;
        double d1 = c * e; /* F' */
        int flat = !(d1 > 0.0);
        double d2 = (-tan_t - 2.0 * x * c) * e; /* F'' */
        double inv_d1 = 1.0 / d1;
        double newton = F * inv_d1, r = d2 * inv_d1;
        double den = 1.0 - 0.5 * newton * r;
        int halley = den > 0.5; /* else the Newton step */
        double next = x - (halley ? newton / den : newton);
        double scale = 1.0 + fabs(x);
        int newton_small = fabs(newton) <= 1e-14 * scale;
        int inside = (next > lo1) & (next < hi1);
        double d3 = (-2.0 + 6.0 * x * tan_t + 4.0 * x * x - 4.0 * x * x * x * tan_t) * e; /* F''' */
        double step = fabs(next - x);
        double K = fabs(d3 * inv_d1 * (1.0 / 6.0) - 0.25 * r * r);
        int halley_small = inside & halley & ((1.0 + K) * step * step * step <= 1e-15 * scale);
        double next2 = inside ? next : mid;
        int narrow = hi1 - lo1 <= 1e-15 * scale;
        /* the one-lane search's order: a root ends it at x; a vanishing F' bisects; a small Newton
         * step ends it at next; a small Halley step inside the bracket too; else the step (or the
         * bisection) ends it where the bracket is narrow */
        double xn = root ? x : flat ? mid : newton_small ? next : next2;
        int end = root | ((!flat) & (newton_small | halley_small | narrow));
        int was = a->done[i];
        a->x[i] = was ? x : xn;
        a->lo[i] = was | root ? lo : lo1;
        a->hi[i] = was | root ? hi : hi1;
        a->done[i] = was | end;
        open += !(was | end);
    }
    return open;
}

static inline __attribute__((always_inline)) void slope_solve(int m, slope_lanes *a, const double *cot_t, const int fused)
{
    slope_start(m, a, cot_t, fused);
    for (int it = 0; it < SLOPE_MAX_ITERATIONS; ++it)
        if (slope_step(m, a, fused) == 0)
            break;
}

static void solve_base(int m, slope_lanes *a, const double *cot_t) { slope_solve(m, a, cot_t, 0); }

#if defined(__GNUC__) && defined(__x86_64__)
#define SLOPE_MANY_VECTOR 1
#define SLOPE_ATTR(t) __attribute__((target(t)))
SLOPE_ATTR("avx2,fma") static void solve_avx2(int m, slope_lanes *a, const double *cot_t) { slope_solve(m, a, cot_t, 1); }
SLOPE_ATTR("avx512f,avx512dq,avx512vl,fma")
static void solve_avx512(int m, slope_lanes *a, const double *cot_t) { slope_solve(m, a, cot_t, 1); }
/* for one lane: scalar code (no 256-bit instructions, which some processors run slowly for a while
 * after a pause in their use), with exp_lane's fused form; GCC is told not to vectorize it, clang is
 * left to its own choice (the values are the same either way) */
#if defined(__clang__)
#define SLOPE_SCALAR
#else
#define SLOPE_SCALAR __attribute__((optimize("no-tree-vectorize", "no-tree-slp-vectorize")))
#endif
SLOPE_ATTR("avx2,fma") SLOPE_SCALAR
static void solve_scalar_fma(int m, slope_lanes *a, const double *cot_t) { slope_solve(m, a, cot_t, 1); }
#endif

typedef void (*solve_fn)(int, slope_lanes *, const double *);
/* solve_one: for one lane, whose search is one chain of dependent operations (its time is that
 * chain's latency): the scalar loop with exp_lane's shorter fused form */
static solve_fn solve_vector = solve_base, solve_one = solve_base;
static pthread_once_t solve_once = PTHREAD_ONCE_INIT;

/* The best variant under cpu_isa.h's choice; the vector variants also need FMA (exp_lane's fused
 * form), which every AVX-512 and nearly every AVX2 processor has. */
static void solve_init(void)
{
#ifdef SLOPE_MANY_VECTOR
    int isa = spc_vector_isa();
    if (!__builtin_cpu_supports("fma"))
        return;
    if (isa == SPC_ISA_AVX512)
        solve_vector = solve_avx512;
    else if (isa == SPC_ISA_AVX2)
        solve_vector = solve_avx2;
    if (isa == SPC_ISA_AVX512 || isa == SPC_ISA_AVX2)
        solve_one = solve_scalar_fma;
#endif
}

void spc_beckmann_slope_x_many(int n, const double *u, const double *tan_t, const double *cot_t, double *x)
{
    slope_lanes a;
    double cot[SLOPE_BATCH];
    pthread_once(&solve_once, solve_init);
    if (n == 1) { /* one lane: no idle lanes */
        a.tan_t[0] = tan_t[0];
        a.target[0] = u[0];
        a.x[0] = x[0];
        solve_one(1, &a, cot_t);
        x[0] = a.x[0];
        return;
    }
    for (int i0 = 0; i0 < n; i0 += SLOPE_BATCH) {
        int m = n - i0 < SLOPE_BATCH ? n - i0 : SLOPE_BATCH;
        int mv = (m + SLOPE_VECTOR - 1) / SLOPE_VECTOR * SLOPE_VECTOR;
        for (int j = 0; j < mv; ++j) {
            /* idle lanes: normal incidence's median, which the first step ends */
            bool on = j < m;
            a.tan_t[j] = on ? tan_t[i0 + j] : 0.0;
            cot[j] = on ? cot_t[i0 + j] : SPC_INF;
            a.target[j] = on ? u[i0 + j] : 0.5;
            a.x[j] = on ? x[i0 + j] : 0.0;
        }
        solve_vector(mv, &a, cot);
        for (int j = 0; j < m; ++j)
            x[i0 + j] = a.x[j];
    }
}
