/*
 * tests/denoise_util.h: what test_denoise and bench_denoise share: rendering a scene file at a
 * given size, and the error of an image against a noisy reference.
 */
#ifndef SPC_TESTS_DENOISE_UTIL_H
#define SPC_TESTS_DENOISE_UTIL_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "specula/specula.h"

/* Renders the scene file at res x res with spp samples; snee: NULL (the scene's) or a specular NEE
 * setting ("" for none). NULL on failure (printed). The caller destroys the film. */
static inline spc_film *du_render(const char *path, int res, int spp, uint64_t seed, const char *snee, bool aovs)
{
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_scene_load(path, NULL, 0, &sc, &err) != SPC_OK) {
        printf("  %s: %s\n", path, err.msg);
        return NULL;
    }
    spc_render_options o;
    spc_render_options_init(&o);
    o.width = o.height = res;
    o.spp = spp;
    o.seed = seed;
    o.specular_nee = snee;
    o.aovs = aovs;
    spc_film *f = NULL;
    spc_render_stats st;
    if (spc_render(sc, &o, &f, &st, &err) != SPC_OK) {
        printf("  %s: render failed: %s\n", path, err.msg);
        spc_film_destroy(f);
        f = NULL;
    }
    spc_scene_destroy(sc);
    return f;
}

/* relMSE of a (3 floats per pixel, npix pixels) against a reference r with the variance of its mean
 * rv, less the reference's own noise: the mean over pixels and channels of
 * ((a - r)^2 - rv) / (r^2 + 0.01). spc_image_diff's relMSE is the same without "- rv"; since
 * E[(a - r)^2] = (a - truth)^2 + Var(r) for an unbiased r independent of a, this one estimates the
 * error against the truth. *worst_share (may be NULL): the largest one pixel's part of the sum. */
static inline double du_relmse(const float *a, const float *r, const float *rv, size_t npix, double *worst_share)
{
    double sum = 0.0, worst = 0.0;
    for (size_t p = 0; p < npix; ++p) {
        double e = 0.0;
        for (int c = 0; c < 3; ++c) {
            size_t i = 3 * p + (size_t)c;
            double d = (double)a[i] - (double)r[i];
            e += (d * d - (double)rv[i]) / ((double)r[i] * (double)r[i] + 0.01);
        }
        sum += e;
        if (e > worst)
            worst = e;
    }
    if (worst_share)
        *worst_share = sum > 0.0 ? worst / sum : 0.0;
    return sum / (3.0 * (double)npix);
}

#endif
