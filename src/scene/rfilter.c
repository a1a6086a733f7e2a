/*
 * scene/rfilter.c: the pixel filter's steps, density, CDF, sampling and mass over a window
 * (rfilter.h).
 */
#include "scene/rfilter.h"

#include <math.h>

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

double spc_film_filter_mass(const spc_film_spec *f, double c, double lo, double hi)
{
    double r = f->filter_radius;
    if (c - r >= lo && c + r <= hi)
        return 1.0;
    return spc_film_filter_cdf(f, hi - c) - spc_film_filter_cdf(f, lo - c);
}
