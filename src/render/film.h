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
     * (integrator.h: spc_strategy_index) weighted, 2 k + 1 unweighted */
    struct spc_film **strategy;
    int nstrategy;
    int strategy_s, strategy_t; /* of a strategy film */
    bool strategy_weighted;
    /* what rendered it, for the EXR header: the integrator and the specular NEE setting that ran
     * ("none" when off); "" for a film not rendered by spc_render */
    char integrator[16];
    char specular_nee[96];
};

/* NULL on allocation failure or absurd size. */
struct spc_film *spc_film_create(int full_w, int full_h, int crop_x, int crop_y, int w, int h, bool aovs);
/* Adds the current pass buffer into the sums and clears it. */
void spc_film_commit_pass(struct spc_film *f);
/* Computes rgb/var/aov floats from the sums, also of the strategy films. false on allocation
 * failure. */
bool spc_film_resolve(struct spc_film *f);

/* The pixel filter, per axis (filters are separable: box, tent, truncated gaussian), normalized to
 * integrate to 1 over [-radius, radius], and its CDF.
 *
 * Tent and gaussian are the step functions Mitsuba 3 splats with: its filters are evaluated from a
 * table of SPC_FILTER_RESOLUTION values at |x| = k radius / RES, looked up by rounding |x| down
 * (ReconstructionFilter's discretization), so a sample at |x| weighs f(floor(|x| RES / radius)
 * radius / RES): a slightly wider filter than f itself. Measured on an edge: Mitsuba 3.9's tent
 * gives the step filter's value to 1e-4 and the exact tent's is 3e-3 off; the gaussian is Mitsuba's
 * too, exp(-x^2 / (2 stddev^2)) - exp(-radius^2 / (2 stddev^2)). Images of scenes with sharp
 * edges failed the per-pixel z-test against Mitsuba 3 along the edges before (instances.xml,
 * 98.4% of pixels passing). spc_film_filter_prepare fills the steps (the driver calls it on its
 * copy of the film settings); the functions below need it for tent and gaussian.
 *
 * Borders, as Mitsuba's films: no sample is taken outside the rendered window [lo, hi) (the crop
 * window, in full-film pixels), so a pixel near its edge is the filter-weighted mean of the
 * radiance over the part of its support inside the window. spc_film_filter_sample draws the offset
 * from the pixel center c from the filter restricted to [lo - c, hi - c] (inverse CDF; the plain
 * filter sample, unchanged, when the support is inside); splats divide the filter value by
 * spc_film_filter_mass, the integral of the filter over that interval (1 away from the edges). */
struct spc_film_spec;
void spc_film_filter_prepare(struct spc_film_spec *f);
double spc_film_filter_eval(const struct spc_film_spec *f, double x);
double spc_film_filter_cdf(const struct spc_film_spec *f, double x);
double spc_film_filter_sample(const struct spc_film_spec *f, double u, double c, double lo, double hi);
double spc_film_filter_mass(const struct spc_film_spec *f, double c, double lo, double hi);

#endif
