/*
 * render/film.c: accumulation of passes and the mean / variance-of-the-mean resolve; the pixel
 * filter's density, CDF and sampling restricted to the rendered window (see film.h).
 */
#include "render/film.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/warp.h"
#include "scene/scene.h"
#include "specula/specula.h"

#define SPC_FILM_MAX_PIXELS (1LL << 28) /* 268M pixels: ~13 GiB of sums; refuse anything larger */

struct spc_film *spc_film_create(int full_w, int full_h, int crop_x, int crop_y, int w, int h, bool aovs)
{
    if (w <= 0 || h <= 0 || full_w <= 0 || full_h <= 0 || (long long)w * h > SPC_FILM_MAX_PIXELS)
        return NULL;
    struct spc_film *f = calloc(1, sizeof *f);
    if (!f)
        return NULL;
    size_t n = (size_t)w * (size_t)h;
    f->width = w;
    f->height = h;
    f->full_width = full_w;
    f->full_height = full_h;
    f->crop_x = crop_x;
    f->crop_y = crop_y;
    f->sum = calloc(3 * n, sizeof(double));
    f->sumsq = calloc(3 * n, sizeof(double));
    f->pass = calloc(3 * n, sizeof(double));
    f->has_aovs = aovs;
    if (aovs)
        f->aov_sum = calloc(SPC_FILM_AOVS * n, sizeof(double));
    if (!f->sum || !f->sumsq || !f->pass || (aovs && !f->aov_sum)) {
        spc_film_destroy(f);
        return NULL;
    }
    return f;
}

void spc_film_destroy(struct spc_film *f)
{
    if (!f)
        return;
    free(f->sum);
    free(f->sumsq);
    free(f->pass);
    free(f->aov_sum);
    free(f->rgb);
    free(f->var);
    free(f->aov);
    free(f->noisy);
    for (int j = 0; j < f->nstrategy; ++j)
        spc_film_destroy(f->strategy[j]);
    free(f->strategy);
    free(f);
}

void spc_film_commit_pass(struct spc_film *f)
{
    size_t n = 3 * (size_t)f->width * (size_t)f->height;
    for (size_t i = 0; i < n; ++i) {
        double v = f->pass[i];
        f->sum[i] += v;
        f->sumsq[i] += v * v;
    }
    memset(f->pass, 0, n * sizeof(double));
    f->spp++;
}

bool spc_film_resolve(struct spc_film *f)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    if (!f->rgb)
        f->rgb = malloc(3 * n * sizeof(float));
    if (!f->var)
        f->var = malloc(3 * n * sizeof(float));
    if (f->has_aovs && !f->aov)
        f->aov = malloc(SPC_FILM_AOVS * n * sizeof(float));
    if (!f->rgb || !f->var || (f->has_aovs && !f->aov))
        return false;
    free(f->noisy); /* rgb is the sums' mean again */
    f->noisy = NULL;
    double N = f->spp > 0 ? (double)f->spp : 1.0;
    for (size_t i = 0; i < 3 * n; ++i) {
        double mean = f->sum[i] / N;
        double var = 0.0;
        if (f->spp > 1) {
            /* unbiased sample variance, divided by N: the variance of the mean */
            double s2 = (f->sumsq[i] - f->sum[i] * mean) / (N - 1.0);
            var = s2 > 0.0 ? s2 / N : 0.0;
        }
        f->rgb[i] = (float)mean;
        f->var[i] = (float)var;
    }
    if (f->has_aovs)
        for (size_t i = 0; i < SPC_FILM_AOVS * n; ++i)
            f->aov[i] = (float)(f->aov_sum[i] / N);
    for (int j = 0; j < f->nstrategy; ++j)
        if (!spc_film_resolve(f->strategy[j]))
            return false;
    return true;
}

int spc_film_width(const struct spc_film *f) { return f->width; }
int spc_film_height(const struct spc_film *f) { return f->height; }
const float *spc_film_rgb(const struct spc_film *f) { return f->rgb; }
const float *spc_film_variance(const struct spc_film *f) { return f->var; }
const float *spc_film_noisy_rgb(const struct spc_film *f) { return f->noisy; }

int spc_film_strategy_count(const struct spc_film *f) { return f ? f->nstrategy : 0; }

const struct spc_film *spc_film_strategy(const struct spc_film *f, int i, int *s, int *t, bool *weighted)
{
    if (!f || i < 0 || i >= f->nstrategy)
        return NULL;
    const struct spc_film *g = f->strategy[i];
    if (s)
        *s = g->strategy_s;
    if (t)
        *t = g->strategy_t;
    if (weighted)
        *weighted = g->strategy_weighted;
    return g;
}
