/*
 * integrator/integrator.h: what the render driver asks of an integrator: one estimate of the
 * measurement of a camera ray, plus splats on the film for strategies that connect to the camera.
 *
 * Depth convention (Mitsuba's max_depth): the number of path SEGMENTS. max_depth = 1 shows only
 * emitters seen directly, 2 adds direct illumination; -1 means unbounded (Russian roulette ends
 * paths). Russian roulette starts once a path has rr_depth segments.
 */
#ifndef SPC_INTEGRATOR_INTEGRATOR_H
#define SPC_INTEGRATOR_INTEGRATOR_H

#include <stddef.h>
#include <stdint.h>

#include "core/sampler.h"
#include "manifold/specular_nee.h"
#include "scene/camera.h"
#include "scene/scene.h"

typedef enum spc_integrator_kind {
    SPC_INTEGRATOR_PATH, /* NEE + BSDF sampling, power heuristic */
    SPC_INTEGRATOR_IPT,  /* implicit: light counts only when a path hits it */
    SPC_INTEGRATOR_BDPT, /* bidirectional path tracing with Veach's MIS (bdpt.c) */
    SPC_INTEGRATOR_VOLPATH, /* path tracing through participating media (volpath.c) */
    SPC_INTEGRATOR_PTRACER  /* particle (light) tracing: bdpt's t = 1 strategies alone (bdpt.c) */
} spc_integrator_kind;

typedef struct spc_render_ctx {
    const spc_scene *scene;
    const spc_camera_state *cam;
    spc_integrator_kind kind;
    int max_depth, rr_depth;
    bool hide_emitters;
    bool aovs; /* the film keeps AOVs: spc_aov_from_hit looks through delta surfaces */
    int strategy_s, strategy_t; /* bdpt debug: >= 0 keeps only this strategy */
    bool strategy_weighted;
    bool mis_balance; /* bdpt: balance heuristic instead of the power heuristic */
    bool strict_normals; /* path: directions on different sides of the geometric and shading normals carry nothing */
    /* bdpt debug: > 0 also fills spc_sample_out.strategy_L for every strategy with s + t - 1 <= this
     * (spc_strategy_index) and splats t = 1 into the strategy films too */
    int strategy_images_depth;
    /* specular NEE (src/manifold/specular_nee.h): solver id SPC_SNEE_* (0: off) and the longest
     * chain of specular vertices it connects through */
    int specular_nee;
    int specular_max_chain;
    /* the options of the specular_nee setting (spc_snee_parse: estimator, seeds, rough vertices),
     * solver and max_chain as above; path.c uses them, volpath.c only the solver */
    spc_snee_params snee;
    /* film geometry for splats: the rendered window within the full film */
    int crop_x, crop_y, width, height;
    const spc_film_spec *film;
} spc_render_ctx;

typedef struct spc_splat {
    int32_t x, y; /* pixel in the rendered window */
    float r, g, b;
    int32_t film; /* 0: the image; 1 + j: strategy film j (spc_sample_out.strategy_L's slots) */
} spc_splat;

/* Per-work-item scratch: splats produced while rendering one tile of one pass. */
typedef struct spc_tls {
    spc_splat *splats;
    size_t nsplats, cap;
    bool oom; /* a splat could not be stored (reported as invalid samples) */
    uint64_t invalid;
} spc_tls;

typedef struct spc_sample_out {
    spc_rgb L;
    spc_rgb albedo;
    spc_vec3 normal;
    double depth;
    /* Set by the driver before the call: NULL, or (with ctx->strategy_images_depth > 0) room for
     * 2 spc_strategy_count(depth) values that bdpt fills: slot 2 k holds the MIS-weighted and slot
     * 2 k + 1 the unweighted contribution of strategy k = spc_strategy_index(s, t) to L (zero for
     * t = 1, which splats instead). Other integrators leave it alone. */
    spc_rgb *strategy_L;
    /* Set by the driver before the call: whether albedo, normal and depth are wanted (the film has
     * AOVs); when false an integrator may leave them zero. */
    bool aovs;
} spc_sample_out;

/* Strategies (s, t), t >= 1, of lengths k = s + t - 1 = 1 .. depth, numbered by length, then by s:
 * (0, 2) (1, 1), (0, 3) (1, 2) (2, 1), ...; depth (depth + 3) / 2 of them. */
static inline int spc_strategy_count(int depth) { return depth * (depth + 3) / 2; }
static inline int spc_strategy_index(int s, int t)
{
    int k = s + t - 1;
    return (k - 1) * (k + 2) / 2 + s;
}

/* The AOVs of a camera sample whose ray first hit h0 (wo0 toward the camera): depth h0->t; albedo
 * and shading normal of the first surface with a non-delta lobe, found by sampling delta lobes from
 * h0 on with a random stream of its own (aov.c; only with ctx->aovs, else h0's own features). */
void spc_aov_from_hit(const spc_render_ctx *ctx, const spc_hit *h0, spc_vec3 wo0, const spc_sampler *smp,
                      spc_sample_out *out);

/* Parses an integrator name; false if unknown. */
bool spc_integrator_kind_from_name(const char *name, spc_integrator_kind *kind);
const char *spc_integrator_kind_name(spc_integrator_kind kind);

/* One estimate for a camera ray. out->L must be finite (the driver checks and counts). */
void spc_integrator_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                           spc_sample_out *out);

/* Splat value v at continuous film position (fx, fy) of the full film, spread by the pixel
 * filter (normalized), into tls. */
void spc_splat_add(const spc_render_ctx *ctx, spc_tls *tls, double fx, double fy, spc_rgb v);
/* The same into film `film` (spc_splat.film). Only film 0 counts invalid values: the others hold
 * parts of the image's estimate, which counts them once. */
void spc_splat_add_to(const spc_render_ctx *ctx, spc_tls *tls, int film, double fx, double fy, spc_rgb v);

/* Power heuristic (beta = 2) for two strategies with densities a (the one used) and b. */
static inline double spc_mis_power(double a, double b)
{
    if (!(a > 0.0))
        return 0.0;
    if (isinf(a))
        return 1.0;
    double a2 = a * a, b2 = b * b;
    return a2 / (a2 + b2);
}

void spc_path_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                     spc_sample_out *out);

/* Volumetric path tracing (volpath.c): path's estimator plus free-flight sampling, phase
 * scattering and transmittance along shadow rays; specular connections through one interface
 * from medium vertices when ctx->specular_nee is set. */
void spc_volpath_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                        spc_sample_out *out);

/* Bidirectional path tracing (bdpt.c): one camera subpath for this ray and one light subpath, every
 * (s, t) strategy; t = 1 strategies splat into tls. With ctx->kind SPC_INTEGRATOR_PTRACER only
 * the light subpath is traced and each of its vertices is joined to the camera (t = 1, unweighted:
 * the one strategy for each path length), as Mitsuba 3's ptracer: out->L is zero, the image is in
 * the splats. */
void spc_bdpt_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                     spc_sample_out *out);
/* Subpaths cut short by the fixed vertex arrays of bdpt.c since the program started (a path
 * that long only occurs with max_depth -1, and Russian roulette makes it astronomically rare). */
uint64_t spc_bdpt_truncated_paths(void);

#endif
