/*
 * integrator/context.h: what every integrator is given and returns: the render context (scene,
 * camera, depth, specular-NEE options, film geometry for splats), the tile's scratch (spc_tls: its
 * splats) and the estimate of one camera sample (spc_sample_out); the strategy numbering of bdpt's
 * strategy films, and the power heuristic. Integrators include this, never the dispatcher
 * (integrator.h), which includes them.
 *
 * Depth convention (Mitsuba's max_depth): the number of path SEGMENTS. max_depth = 1 shows only
 * emitters seen directly, 2 adds direct illumination; -1 means unbounded (Russian roulette ends
 * paths). Russian roulette starts once a path has rr_depth segments.
 */
#ifndef SPC_INTEGRATOR_CONTEXT_H
#define SPC_INTEGRATOR_CONTEXT_H

#include <math.h>
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
    /* bdpt: connections to the pass's pool of light vertices (bdpt_pool.h) instead of the camera
     * sample's own light subpath; NULL: off */
    const struct spc_bdpt_pool_model *pool_model;
    /* bdpt: light subpaths per camera sample (>= 1); the second and later serve light tracing
     * (t = 1) only, and MIS counts t = 1 that many times (bdpt.c) */
    int bdpt_light_paths;
    /* bdpt: area lights' emission partly aimed at the casters (bdpt.h, spc_bdpt_aim); NULL: off */
    const struct spc_bdpt_aim *bdpt_aim;
    /* path: grazing directions along mirror cylinders' walls (path_graze.h); NULL: off */
    const struct spc_path_graze *graze;
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
    /* bdpt with a pool (ctx->pool_model): the light subpaths this item traced for its pass (bdpt.c's
     * vertices, lv_n of them; the subpath of the tile's pixel i, in row order, starts at lv_first[i]
     * and ends at lv_first[i + 1]), the tile pixel whose camera sample runs (set by the driver), and
     * the pass's pool that its camera samples connect to */
    void *lv;
    size_t lv_n, lv_cap;
    size_t *lv_first, lv_first_cap;
    int lv_pixel;
    /* the full film's pixel whose camera sample runs (set by the driver) */
    int px, py;
    const struct spc_bdpt_pool *pool;
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

#endif
