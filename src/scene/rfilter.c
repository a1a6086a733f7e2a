/*
 * scene/rfilter.c: the pixel filter's steps, density, CDF, sampling and mass over a window
 * (rfilter.h).
 */
#include "scene/rfilter.h"

#include <math.h>

#include "core/cpu_isa.h"

/* clang contracts a * b + c into a fused multiply-add by default where the target has one, which
 * would round the vector loop's offsets differently from the one-sample code */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

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
        f->filter_guide[b] = k;
    }
    /* for t in bucket b < GUIDE the step is at most bucket b + 1's guide (t is below that bucket's
     * lower end); bucket GUIDE holds t = 1/2 alone, whose step is its guide */
    f->filter_guide_scan = 0;
    for (int b = 0; b < SPC_FILTER_GUIDE; ++b)
        f->filter_guide_scan = f->filter_guide[b + 1] - f->filter_guide[b] > f->filter_guide_scan
                                   ? f->filter_guide[b + 1] - f->filter_guide[b]
                                   : f->filter_guide_scan;
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

/* filter_inverse_cdf for the tent and the gaussian, n samples, where the scan moves at most
 * FILTER_MANY_SCAN steps past a guide (filter_guide_scan): the scan as that many steps that each
 * move on while the next step's CDF is <= t (a step that stops stays stopped: the CDF does not
 * decrease), and the branches as selects; the same arithmetic in the same order. */
#define FILTER_MANY_SCAN 2
#define FILTER_MANY_BODY                                                                                               \
    {                                                                                                                  \
        double r = f->filter_radius, h = r / SPC_FILTER_RESOLUTION;                                                    \
        for (int i = 0; i < n; ++i) {                                                                                  \
            double ui = u[i];                                                                                          \
            double t = fabs(ui - 0.5);                                                                                 \
            int b = (int)(t * (2.0 * SPC_FILTER_GUIDE));                                                               \
            int k = f->filter_guide[b < SPC_FILTER_GUIDE ? b : SPC_FILTER_GUIDE];                                      \
            k += (k < SPC_FILTER_RESOLUTION - 1) & (f->filter_step_cdf[k + 1] <= t);                                   \
            k += (k < SPC_FILTER_RESOLUTION - 1) & (f->filter_step_cdf[k + 1] <= t);                                   \
            double a = k * h, st = f->filter_step[k];                                                                  \
            double a1 = a + (t - f->filter_step_cdf[k]) / st;                                                          \
            a = st > 0.0 ? a1 : a;                                                                                     \
            a = a < r ? a : r;                                                                                         \
            x[i] = ui < 0.5 ? -a : a;                                                                                  \
        }                                                                                                              \
    }

/* O3 vectorizes the loop; without trapping math GCC may run the division on every lane and select
 * (no value changes: no contraction, no reassociation) */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC push_options
#pragma GCC optimize("O3", "no-trapping-math")
#endif
static void filter_many_base(const spc_film_spec *restrict f, int n, const double *restrict u, double *restrict x)
    FILTER_MANY_BODY

#if defined(__x86_64__) && defined(__GNUC__)
#define FILTER_MANY_VECTOR 1
/* GCC 12's generic tuning vectorizes no loop that needs gathers (the tables' lookups); a tuning for
 * a processor whose gathers are fast lets it (clang's cost model vectorizes them as they are) */
#if defined(__clang__)
#define FILTER_MANY_TUNE(t) ""
#else
#define FILTER_MANY_TUNE(t) ",tune=" t
#endif
__attribute__((target("avx2" FILTER_MANY_TUNE("skylake"))))
static void filter_many_avx2(const spc_film_spec *restrict f, int n, const double *restrict u, double *restrict x)
    FILTER_MANY_BODY
__attribute__((target("avx512f,avx512dq,avx512bw,avx512vl" FILTER_MANY_TUNE("icelake-server"))))
static void filter_many_avx512(const spc_film_spec *restrict f, int n, const double *restrict u, double *restrict x)
    FILTER_MANY_BODY
#endif
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC pop_options
#endif

void spc_film_filter_sample_many(const spc_film_spec *f, int n, const double *u, const double *c, double lo, double hi,
                                 double *x)
{
    double r = f->filter_radius;
    if (f->rfilter == SPC_RFILTER_BOX || f->filter_guide_scan > FILTER_MANY_SCAN) {
        for (int i = 0; i < n; ++i)
            x[i] = spc_film_filter_sample(f, u[i], c[i], lo, hi);
        return;
    }
#ifdef FILTER_MANY_VECTOR
    int isa = spc_vector_isa(); /* the variants give the same values */
    if (isa == SPC_ISA_AVX512)
        filter_many_avx512(f, n, u, x);
    else if (isa == SPC_ISA_AVX2)
        filter_many_avx2(f, n, u, x);
    else
        filter_many_base(f, n, u, x);
#else
    filter_many_base(f, n, u, x);
#endif
    /* the samples whose support crosses the window's edges: the restricted filter */
    for (int i = 0; i < n; ++i)
        if (!(c[i] - r >= lo && c[i] + r <= hi))
            x[i] = spc_film_filter_sample(f, u[i], c[i], lo, hi);
}

double spc_film_filter_mass(const spc_film_spec *f, double c, double lo, double hi)
{
    double r = f->filter_radius;
    if (c - r >= lo && c + r <= hi)
        return 1.0;
    return spc_film_filter_cdf(f, hi - c) - spc_film_filter_cdf(f, lo - c);
}
