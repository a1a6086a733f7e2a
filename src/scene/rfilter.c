/*
 * scene/rfilter.c: the pixel filter's steps, density, CDF, sampling and mass over a window
 * (rfilter.h).
 */
#include "scene/rfilter.h"

#include <math.h>
#include <pthread.h>
#include <string.h>

#include "core/cpu_isa.h"

/* Mitsuba 3's filter profiles (unnormalized) at |x| = a. */
static double filter_shape(const spc_film_spec *f, double a)
{
    double r = f->filter_radius;
    switch (f->rfilter) {
    case SPC_RFILTER_BOX: return 1.0;
    case SPC_RFILTER_TENT: return spc_max(0.0, 1.0 - a / r);
    case SPC_RFILTER_GAUSSIAN: {
        double k = -1.0 / (2.0 * f->filter_stddev * f->filter_stddev);
        return spc_max(0.0, exp(k * a * a) - exp(k * r * r));
    }
    }
    return 0.0;
}

void spc_film_filter_prepare(spc_film_spec *f)
{
    double h = f->filter_radius / SPC_FILTER_RESOLUTION, sum = 0.0;
    for (int k = 0; k < SPC_FILTER_RESOLUTION; ++k) {
        f->filter_step[k] = filter_shape(f, k * h);
        sum += f->filter_step[k];
    }
    double Z = 2.0 * h * sum; /* both sides */
    f->filter_step_cdf[0] = 0.0;
    for (int k = 0; k < SPC_FILTER_RESOLUTION; ++k) {
        f->filter_step[k] = Z > 0.0 ? f->filter_step[k] / Z : 0.0;
        f->filter_step_cdf[k + 1] = f->filter_step_cdf[k] + h * f->filter_step[k];
    }
    /* the guide: for bucket b, the last step k <= RES - 1 with cdf[k] <= b / (2 GUIDE) */
    int k = 0;
    for (int b = 0; b <= SPC_FILTER_GUIDE; ++b) {
        double t = b / (2.0 * SPC_FILTER_GUIDE);
        while (k < SPC_FILTER_RESOLUTION - 1 && f->filter_step_cdf[k + 1] <= t)
            ++k;
        f->filter_guide[b] = (unsigned char)k;
    }
}

/* The step holding |x| = a < radius. */
static int filter_step_index(const spc_film_spec *f, double a)
{
    double k = a * SPC_FILTER_RESOLUTION / f->filter_radius;
    return k < SPC_FILTER_RESOLUTION - 1 ? (int)k : SPC_FILTER_RESOLUTION - 1;
}

double spc_film_filter_eval(const spc_film_spec *f, double x)
{
    double r = f->filter_radius;
    if (!(fabs(x) < r))
        return 0.0;
    if (f->rfilter == SPC_RFILTER_BOX)
        return 1.0 / (2.0 * r);
    return f->filter_step[filter_step_index(f, fabs(x))];
}

double spc_film_filter_cdf(const spc_film_spec *f, double x)
{
    double r = f->filter_radius;
    if (!(x > -r))
        return 0.0;
    if (!(x < r))
        return 1.0;
    if (f->rfilter == SPC_RFILTER_BOX)
        return (x + r) / (2.0 * r);
    double a = fabs(x);
    int k = filter_step_index(f, a);
    double m = f->filter_step_cdf[k] + (a - k * r / SPC_FILTER_RESOLUTION) * f->filter_step[k];
    return x < 0.0 ? 0.5 - m : 0.5 + m;
}

_Static_assert(SPC_FILTER_RESOLUTION <= 255, "filter_guide holds step indices in bytes");

/* The inverse CDF, for u in [0, 1]: the step, then linear within it (the density is constant
 * there). The step is the last k <= RES - 1 with filter_step_cdf[k] <= t: the guide table gives it
 * at the lower end of t's bucket, and a short scan (no step for most t; the tent's and the
 * Gaussian's outer steps are narrower than a bucket) finishes it. */
static double filter_inverse_cdf(const spc_film_spec *f, double u)
{
    double r = f->filter_radius;
    if (f->rfilter == SPC_RFILTER_BOX)
        return (2.0 * u - 1.0) * r;
    double t = fabs(u - 0.5), h = r / SPC_FILTER_RESOLUTION;
    int b = (int)(t * (2.0 * SPC_FILTER_GUIDE));
    int lo = f->filter_guide[b < SPC_FILTER_GUIDE ? b : SPC_FILTER_GUIDE];
    while (lo < SPC_FILTER_RESOLUTION - 1 && f->filter_step_cdf[lo + 1] <= t)
        ++lo;
    double a = lo * h;
    if (f->filter_step[lo] > 0.0)
        a += (t - f->filter_step_cdf[lo]) / f->filter_step[lo];
    a = spc_min(a, r);
    return u < 0.5 ? -a : a;
}

double spc_film_filter_sample(const spc_film_spec *f, double u, double c, double lo, double hi)
{
    double r = f->filter_radius;
    if (c - r >= lo && c + r <= hi)
        return filter_inverse_cdf(f, u);
    double a = spc_film_filter_cdf(f, lo - c), b = spc_film_filter_cdf(f, hi - c);
    double x = filter_inverse_cdf(f, a + u * (b - a));
    return spc_clamp(x, lo - c, hi - c);
}

/* filter_inverse_cdf for n values of u, x[i] for u[i]: one at a time, or in the vector variants
 * below. */
typedef void (*inverse_cdf_fn)(const spc_film_spec *f, int n, const double *u, double *x);

static void inverse_cdf_base(const spc_film_spec *f, int n, const double *u, double *x)
{
    for (int i = 0; i < n; ++i)
        x[i] = filter_inverse_cdf(f, u[i]);
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define RFILTER_VECTOR 1
/* filter_inverse_cdf over many u, 8 at a time in GCC's vector types, the same values. Its step k is
 * the last one with filter_step_cdf[k] <= t (k <= RES - 1); as the CDF does not decrease, a binary
 * search finds it: over the CDF padded to 32 entries with +inf at the end, held in four vectors and
 * read per lane by shuffles (an AVX-512 vpermt2pd for each pair of vectors), without a table read
 * or a branch that depends on t. The step's quotient is computed in every lane and kept where the
 * step's density is positive, as filter_inverse_cdf adds it. Compiled for AVX2 and AVX-512 (chosen
 * at run time), without fused multiply-adds (ISO C11 builds do not contract, and the targets do not
 * include FMA). Tent and gaussian only. */
typedef double v8d __attribute__((vector_size(64)));
typedef long long v8l __attribute__((vector_size(64)));

/* x in every lane; m ? a : b per lane (m all ones or all zeros); entry i[lane] of the 32-entry
 * table v[0..3] (i in [0, 32)). Macros: a function returning a 64-byte vector warns of its ABI in
 * the AVX2 variant. */
#define SPLAT(x) ((v8d){(x), (x), (x), (x), (x), (x), (x), (x)})
#define SPLATL(x) ((v8l){(x), (x), (x), (x), (x), (x), (x), (x)})
#define SELECT8(m, a, b) ((v8d)(((m) & (v8l)(a)) | (~(m) & (v8l)(b))))
#define LOOKUP32(v, i)                                                                                                \
    SELECT8((i) < SPLATL(16), __builtin_shuffle((v)[0], (v)[1], (i) & SPLATL(15)),                                      \
            __builtin_shuffle((v)[2], (v)[3], (i) & SPLATL(15)))

static inline __attribute__((always_inline)) void inverse_cdf_loop(const spc_film_spec *f, int n, const double *u,
                                                                   double *x)
{
    enum { LANES = 8 };
    _Static_assert(SPC_FILTER_RESOLUTION < 32, "the search's table holds 32 entries");
    const double r = f->filter_radius, h = r / SPC_FILTER_RESOLUTION;
    double c32[32], s32[32];
    for (int i = 0; i < 32; ++i) {
        c32[i] = i < SPC_FILTER_RESOLUTION ? f->filter_step_cdf[i] : INFINITY; /* never <= t: k <= RES - 1 */
        s32[i] = i < SPC_FILTER_RESOLUTION ? f->filter_step[i] : 0.0;
    }
    v8d cv[4], sv[4];
    memcpy(cv, c32, sizeof cv);
    memcpy(sv, s32, sizeof sv);
    const v8l abs_mask = SPLATL(0x7fffffffffffffffLL);
    for (int j0 = 0; j0 < n; j0 += LANES) {
        double uj[LANES], xj[LANES];
        for (int j = 0; j < LANES; ++j)
            uj[j] = j0 + j < n ? u[j0 + j] : 0.5; /* lanes past n: any u, dropped */
        v8d uv;
        memcpy(&uv, uj, sizeof uv);
        v8d t = (v8d)((v8l)(uv - SPLAT(0.5)) & abs_mask);
        v8l k = SPLATL(0);
        for (long long w = 16; w > 0; w /= 2) {
            v8l cand = k + SPLATL(w);
            v8l in = LOOKUP32(cv, cand) <= t;
            k = (in & cand) | (~in & k);
        }
        v8d ck = LOOKUP32(cv, k), sk = LOOKUP32(sv, k);
        v8d q = (t - ck) / sk;
        v8d a = __builtin_convertvector(k, v8d) * SPLAT(h);
        a = SELECT8(sk > SPLAT(0.0), a + q, a);
        a = SELECT8(a < SPLAT(r), a, SPLAT(r));
        v8d xv = SELECT8(uv < SPLAT(0.5), -a, a);
        memcpy(xj, &xv, sizeof xv);
        for (int j = 0; j < LANES && j0 + j < n; ++j)
            x[j0 + j] = xj[j];
    }
}

__attribute__((target("avx2"))) static void inverse_cdf_avx2(const spc_film_spec *f, int n, const double *u,
                                                              double *x)
{
    inverse_cdf_loop(f, n, u, x);
}
__attribute__((target("avx512f"))) static void inverse_cdf_avx512(const spc_film_spec *f, int n, const double *u,
                                                                   double *x)
{
    inverse_cdf_loop(f, n, u, x);
}
#endif

static inverse_cdf_fn inverse_cdf_many = inverse_cdf_base;
static pthread_once_t inverse_cdf_once = PTHREAD_ONCE_INIT;

/* The best variant under cpu_isa.h's choice. */
static void inverse_cdf_init(void)
{
#ifdef RFILTER_VECTOR
    int isa = spc_vector_isa();
    if (isa == SPC_ISA_AVX512)
        inverse_cdf_many = inverse_cdf_avx512;
    else if (isa == SPC_ISA_AVX2)
        inverse_cdf_many = inverse_cdf_avx2;
#endif
}

void spc_film_filter_sample_many(const spc_film_spec *f, int n, const double *u, const double *c, double lo,
                                 double hi, double *x)
{
    double r = f->filter_radius;
    if (f->rfilter != SPC_RFILTER_BOX) {
        pthread_once(&inverse_cdf_once, inverse_cdf_init);
        inverse_cdf_many(f, n, u, x);
    }
    for (int i = 0; i < n; ++i)
        if (f->rfilter == SPC_RFILTER_BOX || !(c[i] - r >= lo && c[i] + r <= hi))
            x[i] = spc_film_filter_sample(f, u[i], c[i], lo, hi);
}

double spc_film_filter_mass(const spc_film_spec *f, double c, double lo, double hi)
{
    double r = f->filter_radius;
    if (c - r >= lo && c + r <= hi)
        return 1.0;
    return spc_film_filter_cdf(f, hi - c) - spc_film_filter_cdf(f, lo - c);
}
