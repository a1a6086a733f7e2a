/*
 * core/warp.h: mappings from [0,1)^2 to directions and points, with their densities, and discrete
 * distributions. Every pdf is stated with its measure: solid angle (sr^-1) for directions, area for
 * points on the unit disk or triangle.
 */
#ifndef SPC_CORE_WARP_H
#define SPC_CORE_WARP_H

#include <stddef.h>

#include "core/math.h"

spc_vec2 spc_warp_disk_concentric(spc_vec2 u);               /* unit disk, pdf 1/pi (area) */
spc_vec3 spc_warp_cosine_hemisphere(spc_vec2 u);             /* z >= 0 */
/* w[i] = spc_warp_cosine_hemisphere(u[i]) for i < n, bit for bit, many at once (core/warp_many.c:
 * vector instructions where the CPU has AVX2 or AVX-512) */
void spc_warp_cosine_hemisphere_many(int n, const spc_vec2 *u, spc_vec3 *w);
double spc_warp_cosine_hemisphere_pdf(spc_vec3 w);           /* cos/pi, 0 for z <= 0 */
spc_vec3 spc_warp_uniform_sphere(spc_vec2 u);                /* pdf 1/(4 pi) */
spc_vec3 spc_warp_uniform_hemisphere(spc_vec2 u);            /* z >= 0, pdf 1/(2 pi) */
spc_vec3 spc_warp_uniform_cone(spc_vec2 u, double cos_max);  /* around +z */
double spc_warp_uniform_cone_pdf(double cos_max);            /* 1/(2 pi (1-cos_max)) */
spc_vec2 spc_warp_uniform_triangle(spc_vec2 u);              /* barycentrics (b1, b2), uniform */
double spc_warp_tent(double u);                              /* [-1,1], pdf 1-|x| */
double spc_warp_gaussian_truncated(double u, double stddev, double radius); /* pdf prop. to gaussian */
double spc_erfinv(double x);

/* Discrete distribution over n non-negative weights. */
typedef struct spc_distrib1d {
    double *cdf; /* n+1 entries, cdf[0] = 0, cdf[n] = 1 */
    double *pmf; /* n entries */
    size_t n;
    double sum;     /* sum of the weights before normalization */
    bool has_empty; /* some pmf entry is 0: sampling steps over empty bins (only then) */
} spc_distrib1d;

/* Returns false (and leaves d empty) if allocation fails or every weight is zero or invalid. */
bool spc_distrib1d_init(spc_distrib1d *d, const double *w, size_t n);
void spc_distrib1d_release(spc_distrib1d *d);
/* Distributions of at most this many entries are searched by counting (spc_distrib1d_sample): a
 * scene's few lights, a quad light's two triangles; the binary search's dependent steps cost more
 * than n - 1 independent compares there. */
#define SPC_DISTRIB1D_COUNT_MAX 16
/* Samples an index; *u_remap (if not NULL) receives u rescaled to [0,1) within the chosen bin.
 * Inline: light sampling calls it per lane (a scene's lights, a mesh light's triangles). */
static inline size_t spc_distrib1d_sample(const spc_distrib1d *d, double u, double *u_remap)
{
    /* largest i with cdf[i] <= u (one index, cdf being nondecreasing), by a search without
     * branches: a light of two triangles is a coin flip to the branch predictor; then skipping
     * empty bins, where there are any (their tests' branches are as hard to predict) */
    size_t lo = 0, len = d->n;
    if (len <= SPC_DISTRIB1D_COUNT_MAX) {
        /* that index is the count of cdf[1..n-1] at or below u: independent loads and compares
         * instead of the search's chain of them */
        for (size_t k = 1; k < len; ++k)
            lo += d->cdf[k] <= u;
    } else {
        while (len > 1) {
            size_t half = len / 2;
            lo = d->cdf[lo + half] <= u ? lo + half : lo;
            len -= half;
        }
    }
    if (d->has_empty) {
        while (lo + 1 < d->n && d->pmf[lo] == 0.0)
            ++lo;
        while (lo > 0 && d->pmf[lo] == 0.0)
            --lo;
    }
    if (u_remap) {
        double r = d->pmf[lo] > 0.0 ? (u - d->cdf[lo]) / d->pmf[lo] : 0.0;
        *u_remap = spc_clamp(r, 0.0, 0x1.fffffffffffffp-1);
    }
    return lo;
}

/* 2D piecewise-constant distribution on [0,1)^2 (envmaps, textured lights). */
typedef struct spc_distrib2d {
    spc_distrib1d marginal;    /* over rows */
    spc_distrib1d *conditional; /* one per row */
    size_t w, h;
} spc_distrib2d;
bool spc_distrib2d_init(spc_distrib2d *d, const double *w, size_t width, size_t height); /* row-major */
void spc_distrib2d_release(spc_distrib2d *d);
/* Returns the point in [0,1)^2 and its density with respect to area on [0,1)^2. */
spc_vec2 spc_distrib2d_sample(const spc_distrib2d *d, spc_vec2 u, double *pdf);
double spc_distrib2d_pdf(const spc_distrib2d *d, spc_vec2 p);

#endif
