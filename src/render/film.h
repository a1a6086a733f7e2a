/*
 * render/film.h: the film: per-pixel running sums of the per-pass estimates (mean and variance of
 * the mean), optional AOVs, and a per-pass splat buffer for light tracing.
 *
 * Rendering proceeds in passes of one sample per pixel. A pass's value of a pixel is its camera
 * sample plus whatever light-tracing splats the pass put on it; the film sums those values and their
 * squares, so the variance of the mean is valid for every integrator, splatting ones included.
 * Everything is double and summed in a fixed order, so images are bit-identical for any thread
 * count.
 */
#ifndef SPC_RENDER_FILM_H
#define SPC_RENDER_FILM_H

#include <stdint.h>

#include "core/error.h"
#include "core/math.h"
#include "scene/scene.h"

/* AOV channels kept per pixel: albedo rgb, shading normal xyz, depth (distance along the camera
 * ray to the first vertex), position xyz (that vertex) */
#define SPC_FILM_AOVS 10

struct spc_film {
    int width, height;           /* rendered window */
    int full_width, full_height; /* whole film (camera projection) */
    int crop_x, crop_y;
    int spp;                     /* passes accumulated */
    double *sum, *sumsq;         /* 3 per pixel */
    double *pass;                /* 3 per pixel: the current pass (camera sample + splats) */
    bool has_aovs;
    double *aov_sum;             /* SPC_FILM_AOVS per pixel: albedo rgb, normal xyz, depth, position xyz */
    /* resolved by spc_film_resolve */
    float *rgb, *var;            /* 3 per pixel */
    float *aov;                  /* SPC_FILM_AOVS per pixel */
    float *noisy;                /* 3 per pixel after spc_film_denoise: rgb before it (rgb is then the
                                  * denoised image); NULL otherwise, and again after a resolve */
    /* the AOVs a scene's aov integrator asks for (names and types as Mitsuba 3 writes them), set by
     * the renderer; none: --aovs writes albedo, normal and depth */
    int naov_out;
    spc_aov_output aov_out[SPC_MAX_AOV_OUTPUTS];
    char aov_image[48];
    uint64_t invalid_samples;
    /* bdpt strategy images (spc_render_options.strategy_images): films owned by this one, which
     * spc_film_destroy and spc_film_resolve handle with it; film 2 k is strategy k
     * (integrator/context.h: spc_strategy_index) weighted, 2 k + 1 unweighted */
    struct spc_film **strategy;
    int nstrategy;
    int strategy_s, strategy_t; /* of a strategy film */
    bool strategy_weighted;
    /* what rendered it, for the EXR header: the integrator and the specular NEE setting that ran
     * ("none" when off); "" for a film not rendered by spc_render */
    char integrator[16];
    char specular_nee[SPC_SPECULAR_NEE_MAX];
};

/* NULL on allocation failure or absurd size. */
struct spc_film *spc_film_create(int full_w, int full_h, int crop_x, int crop_y, int w, int h, bool aovs);
/* Adds the current pass buffer into the sums and clears it. */
void spc_film_commit_pass(struct spc_film *f);
/* Computes rgb/var/aov floats from the sums, also of the strategy films. false on allocation
 * failure. */
bool spc_film_resolve(struct spc_film *f);

#endif
