/*
 * render/driver.c: the render loop: passes of one sample per pixel, tiles, threads; below
 * spc_render (render/api.c), which settles the specular NEE plan first (driver.h).
 *
 * Work is a list of (pass, tile) items handed to threads through an atomic counter, pass by pass,
 * or in a big scene tile by tile (item_place). Every pixel's samples come from its own
 * deterministic stream (pixel, pass index, seed), each item writes only its own pixels and keeps its
 * splats in its own list, and passes are committed to the film in order with splats merged in tile
 * order. The image is therefore bit-identical for any thread count and either order of the items.
 * Passes are grouped into batches so small images keep every thread busy; with a time limit the
 * batch size follows the measured time per pass.
 *
 * Cancellation is polled before every work item, but a render only ever stops at a pass boundary:
 * the passes already started (with every pass of their group of items) are finished, later ones
 * dropped, and only whole passes reach the film. Checkpoints (render/checkpoint.h) are written
 * between batches, so they too hold whole passes, and a resumed render starts at pass index = the
 * checkpoint's pass count: the same additions in the same order as an uninterrupted render.
 */
#include <float.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "accel/accel.h"
#include "core/warp.h"
#include "device/device.h"
#include "integrator/bdpt.h"
#include "integrator/bdpt_pool.h"
#include "integrator/integrator.h"
#include "integrator/path_graze.h"
#include "integrator/path_wave.h"
#include "manifold/snee_options.h"
#include "manifold/snee_plan.h"
#include "manifold/caustic_guide.h"
#include "manifold/seed_guide.h"
#include "manifold/specular_nee.h"
#include "scene/camera.h"
#include "render/checkpoint.h"
#include "render/driver.h"
#include "render/film.h"
#include "scene/rfilter.h"
#include "scene/scene.h"
#include "specula/specula.h"

#define SPC_TILE 16                     /* tile edge in pixels */
#define SPC_MAX_SPP (1 << 24)           /* more samples per pixel than any render needs */
#define SPC_BATCH_PIXELS (1 << 22)      /* pixel-passes per batch buffer: 4M x 3 doubles = 96 MiB */
#define SPC_BATCH_TARGET_SECONDS 1.0    /* batches this long keep progress and cancellation responsive */
#define SPC_MAX_THREADS 256
/* bdpt's pool: light subpaths per batch at most (their vertices stay until the batch is committed:
 * about 2.5 KiB a subpath on the door, so 40 MiB) */
#define SPC_POOL_BATCH_PATHS (1 << 14)
/* bdpt's default: the pool with 3 connections per camera vertex where fewer than this share of the
 * camera's first hits see a light sample (spc_bdpt_pool_direct_share). Measured at 32x32, 8 seeds,
 * equal CPU time (bench/RESULTS.md): the door (share 0.009) and the lamp behind its shade (0.019)
 * gain 1.7x and 1.6x (with 2 connections); the glass-ball caustic (0.84) and the cornell box (0.64)
 * lose 1.3x and 1.5x, where light sampling already reaches most of what the camera sees. 3
 * connections against 2: the door 1.12x, the lamp 1.06x better at equal CPU time (8 seeds). */
#define SPC_POOL_AUTO_SHARE 0.25
#define SPC_POOL_AUTO_CONNECTIONS 3
/* ... and at most this many pixels in the rendered window: a pass's pool keeps every light
 * subpath's vertices (about 540 bytes each, 5 a subpath on the door: 2.7 KB a pixel, so 180 MB
 * here); larger renders would need a compact store. */
#define SPC_POOL_AUTO_MAX_PIXELS (1 << 16)
/* bdpt's light subpaths per camera sample by default (spc_render_options.bdpt_light_paths): one.
 * The extra ones serve light tracing only, at the cost of a light walk (about 2 rays on the
 * glass-ball caustic, 18% of a camera sample) and their splats. Measured at equal CPU time by the
 * error over seeds, none paid: the door (with the pool, 8 seeds, 4 CPU-s) 8 of them 1.05x worse
 * than one, the lamp behind its shade 1.02x better (noise); the glass-ball caustic (32x32, 128 spp,
 * 8 seeds, the seeds' scatter times CPU s) 2: 1.07x, 4: 1.39x worse. The film's own variance
 * estimate favoured them (0.72-0.84x on the door): it treats passes as independent, and the
 * sampler's passes are stratified, more so for one light subpath (bench/RESULTS.md, part bdpt8). */
#define SPC_BDPT_AUTO_LIGHT_PATHS 1
/* bdpt's share of area-light emission aimed at the casters by default (spc_render_options.bdpt_aim;
 * times the share of the aim's pilot rays that reach a caster, bdpt.h). The glass-ball caustic
 * (32x32, 256 spp, 16 seeds, the seeds' scatter times CPU s): 0.2 1.16x, 0.3 1.18x, 0.5 1.10x
 * better than none; the lamp, whose bulb's shade hides the glass egg, gets none from its pilot
 * (0.3 without the pilot's factor: 1.2x worse). */
#define SPC_BDPT_AUTO_AIM 0.25
/* bdpt's share of the camera's first bounce aimed at the casters by default
 * (spc_render_options.bdpt_aim_camera; times the indirect share of the casters' light, bdpt.h). The
 * glass-ball caustic, whose pilot finds half its light indirect (32x32, 256 spp, 16 seeds, one
 * thread, the seeds' scatter times CPU s, against none): a share of 0.1 1.152x, 0.2 1.153x, 0.35
 * 1.11x better. Elsewhere it costs CPU for little: at 0.3 the demo box (indirect share 0.47) 0.935x,
 * the glass sphere under a sky 0.96x, dielectrics 0.99x; 0.2 keeps the caustic's optimum with less
 * of that loss (the box 0.95x). */
#define SPC_BDPT_AUTO_AIM_CAMERA 0.2

/* Scenes of at least this many triangles render a batch's items tile by tile (a tile's passes one
 * after the other), smaller ones pass by pass. A tile's next pass traces its rays through the BVH
 * nodes and triangles its last pass left in the cache; pass by pass, the whole image runs between
 * two visits of a tile. Paired CPU time, one thread, plain path at 256x256 (bench/RESULTS.md, part
 * mesh30): the lit height field of 10k triangles -2%, 100k -4%, 1M -14%; the cornell box -1.1%,
 * veach-mis +0.6% (5 of 6 rounds): small scenes, whose BVH stays in cache, keep the pass order. */
#define SPC_TILE_PASSES_TRIS 8192

typedef struct tile {
    int x0, y0, x1, y1; /* in the rendered window */
} tile;

typedef struct job {
    const spc_render_ctx *ctx;
    const tile *tiles;
    int ntiles;
    int pass0, npasses; /* passes in this batch */
    int group;          /* passes per group of items: a group's items take its passes tile by tile */
    int stride;         /* doubles per pixel in a batch buffer: base, then 3 per strategy film */
    int base;           /* 3, or 10 with AOVs */
    int nfilms;         /* strategy films (spc_render_options.strategy_images), 0 without */
    bool wave;          /* plain path tracing by tiles in packets (path_wave.h) */
    bool pool_phase;    /* bdpt's pool: the items trace the passes' light subpaths (no camera samples) */
    double *buf;        /* npasses * width * height * stride */
    spc_tls *tls;       /* npasses * ntiles */
    uint64_t seed;
    atomic_int next;
    atomic_int limit;       /* items below it are rendered: all of them, or up to the end of the group
                             * of passes already started when a cancel was seen */
    volatile int *cancel;
    atomic_ullong rays;
    atomic_ullong shadow_rays; /* of rays, the shadow rays */
} job;

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}


/* A camera sample's estimate is kept only if every channel is finite and within float range: the
 * image is stored as float, and a larger value would become infinite there (its square, in the
 * variance sums, stays finite in double). Others are counted as invalid and replaced by zero. */
#define SPC_MAX_ESTIMATE ((double)FLT_MAX)

static bool estimate_ok(spc_rgb L)
{
    return fabs(L.r) <= SPC_MAX_ESTIMATE && fabs(L.g) <= SPC_MAX_ESTIMATE && fabs(L.b) <= SPC_MAX_ESTIMATE;
}

/* AOVs are not estimates that can be discarded: a non-finite one is stored as zero. */
static double finite_or_zero(double v) { return fabs(v) <= SPC_MAX_ESTIMATE ? v : 0.0; }

/* The camera samples of every pixel of tile t of the rendered window in pass `pass`: each pixel's
 * sampler started and moved past the camera's dimensions (the filter's pair, and a lens pair only
 * for a thin lens), and its ray; the samplers' pixel pairs drawn together and the pinhole rays
 * computed together. Returns the pixel count; the samples run row by row. */
static int camera_samples_tile(const job *jb, int pass, const tile *t, spc_ray *rays, spc_sampler *smp)
{
    const spc_render_ctx *ctx = jb->ctx;
    spc_sampler *ps[SPC_TILE * SPC_TILE];
    spc_vec2 u[SPC_TILE * SPC_TILE];
    double px[SPC_TILE * SPC_TILE], py[SPC_TILE * SPC_TILE];
    int n = 0;
    for (int y = t->y0; y < t->y1; ++y) {
        spc_sampler_start_row(&smp[n], t->x1 - t->x0, (uint32_t)(t->x0 + ctx->crop_x), (uint32_t)(y + ctx->crop_y),
                              (uint32_t)pass, jb->seed);
        for (int x = t->x0; x < t->x1; ++x, ++n)
            ps[n] = &smp[n];
    }
    spc_sampler_2d_many(ps, n, 1, u);
    /* the filter's offsets from the pixel centres cx, cy, both axes in one call each */
    double ux[SPC_TILE * SPC_TILE], uy[SPC_TILE * SPC_TILE], cx[SPC_TILE * SPC_TILE], cy[SPC_TILE * SPC_TILE];
    n = 0;
    for (int y = t->y0; y < t->y1; ++y)
        for (int x = t->x0; x < t->x1; ++x, ++n) {
            ux[n] = u[n].x;
            uy[n] = u[n].y;
            cx[n] = x + ctx->crop_x + 0.5;
            cy[n] = y + ctx->crop_y + 0.5;
        }
    spc_film_filter_sample_many(ctx->film, n, ux, cx, ctx->crop_x, ctx->crop_x + ctx->width, px);
    spc_film_filter_sample_many(ctx->film, n, uy, cy, ctx->crop_y, ctx->crop_y + ctx->height, py);
    for (int i = 0; i < n; ++i) {
        px[i] = cx[i] + px[i];
        py[i] = cy[i] + py[i];
    }
    if (spc_camera_has_lens(ctx->cam))
        for (int i = 0; i < n; ++i)
            rays[i] = spc_camera_ray_lens(ctx->cam, px[i], py[i], spc_sampler_2d(&smp[i]));
    else
        spc_camera_ray_many(ctx->cam, n, px, py, rays);
    return n;
}

/* Stores the estimate `out` of pixel (x, y) (camera ray cam_ray) in a pass's buffer. */
static void store_sample(const job *jb, spc_tls *tls, double *buf, int x, int y, const spc_ray *cam_ray,
                         spc_sample_out *out, const spc_rgb *strategy_L)
{
    const spc_render_ctx *ctx = jb->ctx;
    if (!estimate_ok(out->L)) {
        tls->invalid++;
        out->L = spc_rgb1(0.0);
    }
    double *d = buf + ((size_t)y * ctx->width + x) * jb->stride;
    d[0] = out->L.r;
    d[1] = out->L.g;
    d[2] = out->L.b;
    for (int j = 0; j < jb->nfilms; ++j) {
        /* the rule of the image, so a strategy film equals a single-strategy render */
        spc_rgb v = estimate_ok(strategy_L[j]) ? strategy_L[j] : spc_rgb1(0.0);
        d[jb->base + 3 * j] = v.r;
        d[jb->base + 3 * j + 1] = v.g;
        d[jb->base + 3 * j + 2] = v.b;
    }
    if (jb->base == 3 + SPC_FILM_AOVS) {
        spc_vec3 pos = out->depth > 0.0 ? spc_madd(cam_ray->o, cam_ray->d, out->depth) : spc_v3(0, 0, 0);
        d[10] = finite_or_zero(pos.x);
        d[11] = finite_or_zero(pos.y);
        d[12] = finite_or_zero(pos.z);
        d[3] = finite_or_zero(out->albedo.r);
        d[4] = finite_or_zero(out->albedo.g);
        d[5] = finite_or_zero(out->albedo.b);
        d[6] = finite_or_zero(out->normal.x);
        d[7] = finite_or_zero(out->normal.y);
        d[8] = finite_or_zero(out->normal.z);
        d[9] = finite_or_zero(out->depth);
    }
}

/* Item i's pass of the batch (*b) and tile (*ti). The items run in groups of jb->group passes (the
 * last group may hold fewer), and inside a group tile by tile: a tile's passes one after the other,
 * so the rays of the next pass meet the BVH nodes and triangles the last one left in the cache. Which
 * item renders a (pass, tile) changes no value: each writes its own pixels of its pass's buffer. */
static void item_place(const job *jb, int i, int *b, int *ti)
{
    int per = jb->group * jb->ntiles, g = i / per, j = i % per;
    int gs = jb->npasses - g * jb->group;
    if (gs > jb->group)
        gs = jb->group;
    *b = g * jb->group + j % gs;
    *ti = j / gs;
}

static void render_item(job *jb, int item)
{
    const spc_render_ctx *ctx = jb->ctx;
    int b, ti;
    item_place(jb, item, &b, &ti);
    const tile *t = &jb->tiles[ti];
    spc_tls *tls = &jb->tls[(size_t)b * jb->ntiles + ti];
    int pass = jb->pass0 + b;
    size_t npix = (size_t)ctx->width * (size_t)ctx->height;
    double *buf = jb->buf + (size_t)b * npix * (size_t)jb->stride;
    if (jb->pool_phase) {
        if (!spc_bdpt_pool_trace(ctx, tls, pass, jb->seed, t->x0, t->y0, t->x1, t->y1)) {
            tls->oom = true;
            tls->invalid += (uint64_t)(t->x1 - t->x0) * (uint64_t)(t->y1 - t->y0);
            tls->lv_n = 0;
        }
        return;
    }
    if (jb->wave) {
        /* the whole tile's camera samples at once, their rays traced in packets (path_wave.h) */
        spc_ray rays[SPC_TILE * SPC_TILE];
        spc_sampler smp[SPC_TILE * SPC_TILE];
        spc_sample_out out[SPC_TILE * SPC_TILE];
        int n = camera_samples_tile(jb, pass, t, rays, smp);
        for (int i = 0; i < n; ++i) {
            out[i].strategy_L = NULL;
            out[i].aovs = jb->base == 3 + SPC_FILM_AOVS;
        }
        spc_path_wave_sample(ctx, tls, n, rays, smp, out);
        n = 0;
        for (int y = t->y0; y < t->y1; ++y)
            for (int x = t->x0; x < t->x1; ++x, ++n)
                store_sample(jb, tls, buf, x, y, &rays[n], &out[n], NULL);
        return;
    }
    /* the tile's camera samples at once, as the packet path takes them (the rays and streams of
     * each pixel, computed side by side), then each path */
    spc_ray rays[SPC_TILE * SPC_TILE];
    spc_sampler smps[SPC_TILE * SPC_TILE];
    camera_samples_tile(jb, pass, t, rays, smps);
    int n = 0;
    for (int y = t->y0; y < t->y1; ++y)
        for (int x = t->x0; x < t->x1; ++x, ++n) {
            spc_sampler smp = smps[n];
            spc_ray ray = rays[n];
            spc_sample_out out;
            spc_rgb strategy_L[2 * SPC_STRATEGY_IMAGES_MAX];
            out.strategy_L = jb->nfilms > 0 ? strategy_L : NULL;
            out.aovs = jb->base == 3 + SPC_FILM_AOVS;
            const spc_ray cam_ray = ray;
            tls->lv_pixel = (y - t->y0) * (t->x1 - t->x0) + (x - t->x0);
            tls->px = x + ctx->crop_x;
            tls->py = y + ctx->crop_y;
            spc_integrator_sample(ctx, tls, &ray, &smp, &out);
            store_sample(jb, tls, buf, x, y, &cam_ray, &out, strategy_L);
        }
}

static void *worker(void *arg)
{
    job *jb = arg;
    uint64_t r0 = spc_accel_rays_traced(), s0 = spc_accel_shadow_rays_traced();
    for (;;) {
        int i = atomic_fetch_add(&jb->next, 1);
        if (i >= atomic_load(&jb->limit))
            break;
        if (jb->cancel && *jb->cancel && !jb->pool_phase) {
            /* items below i were all handed out: finish their groups' passes, start none after them */
            int per = jb->group * jb->ntiles;
            int end = (i + per - 1) / per * per;
            int cur = atomic_load(&jb->limit);
            while (end < cur && !atomic_compare_exchange_weak(&jb->limit, &cur, end))
                ;
            if (i >= atomic_load(&jb->limit))
                break;
        }
        render_item(jb, i);
    }
    atomic_fetch_add(&jb->rays, (unsigned long long)(spc_accel_rays_traced() - r0));
    atomic_fetch_add(&jb->shadow_rays, (unsigned long long)(spc_accel_shadow_rays_traced() - s0));
    return NULL;
}

static int default_threads(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

void spc_render_options_init(spc_render_options *o)
{
    memset(o, 0, sizeof *o);
    o->integrator = NULL;
    o->specular_nee = NULL;
    o->progress = NULL;
    o->progress_user = NULL;
    o->cancel = NULL;
    o->strategy_s = -1;
    o->strategy_t = -1;
    o->strategy_weighted = false;
    o->seed = 0;
    o->checkpoint_every = 60.0;
}

void spc_driver_plan(const spc_scene *sc, const spc_render_options *o, spc_snee_plan *plan)
{
    const char *iname = (o->integrator && o->integrator[0]) ? o->integrator : sc->integrator.type;
    /* the given setting, or the scene's, or the default chosen from the scene (snee_plan.h); the
     * OpenCL device has no specular NEE, so there the default is off (an explicit setting is still
     * refused by the device, by name) */
    const char *given = o->specular_nee ? o->specular_nee : sc->integrator.specular_nee;
    bool dev_cl = false;
    int dev_index = 0;
    if (spc_device_parse(o->device, &dev_cl, &dev_index) && dev_cl && spc_snee_setting_is_auto(given))
        given = "none";
    spc_snee_plan_make(sc, iname, given, plan);
}

spc_status spc_driver_render(const spc_scene *sc, const spc_render_options *o, const spc_snee_plan *plan,
                             spc_film **out, spc_render_stats *stats, spc_error *err)
{
    *out = NULL;
    const char *file = sc->path[0] ? sc->path : NULL;
    spc_render_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = sc;
    const char *iname = (o->integrator && o->integrator[0]) ? o->integrator : sc->integrator.type;
    if (!spc_integrator_kind_from_name(iname, &ctx.kind)) {
        char names[128];
        spc_integrator_kind_names(names, sizeof names);
        return spc_error_set(err, SPC_ERR_PLUGIN, file, 0, 0, "unknown integrator '%s'; specula has: %s", iname, names);
    }
    ctx.max_depth = o->max_depth != 0 ? o->max_depth : sc->integrator.max_depth;
    if (ctx.max_depth < -1 || ctx.max_depth == 0)
        ctx.max_depth = -1;
    ctx.rr_depth = sc->integrator.rr_depth > 0 ? sc->integrator.rr_depth : 5;
    ctx.hide_emitters = sc->integrator.hide_emitters;
    ctx.aovs = o->aovs;
    ctx.strategy_s = o->strategy_s;
    ctx.strategy_t = o->strategy_t;
    ctx.strategy_weighted = o->strategy_weighted;
    /* a longer setting would have been cut in the plan: refused, never run cut */
    if (o->specular_nee && strlen(o->specular_nee) >= SPC_SPECULAR_NEE_MAX)
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "--specular-nee is %zu characters long (at most %d)",
                             strlen(o->specular_nee), SPC_SPECULAR_NEE_MAX - 1);
    const char *sname = plan->setting;
    ctx.specular_max_chain = sc->integrator.specular_max_chain > 0 ? sc->integrator.specular_max_chain : 2;
    char why[SPC_SNEE_WHY_MAX];
    spc_snee_parse_result parsed = spc_snee_options_parse(sname, ctx.specular_max_chain, &ctx.snee, why, sizeof why);
    if (parsed != SPC_SNEE_PARSE_OK) {
        spc_status code = parsed == SPC_SNEE_PARSE_BAD_SOLVER ? SPC_ERR_PLUGIN : SPC_ERR_VALUE;
        if (o->specular_nee)
            return spc_error_set(err, code, NULL, 0, 0, "--specular-nee '%s': %s", sname, why);
        return spc_error_set(err, code, sc->integrator.decl_file[0] ? sc->integrator.decl_file : file,
                             sc->integrator.decl_line, sc->integrator.decl_col, "specular_nee '%s': %s", sname, why);
    }
    ctx.specular_nee = ctx.snee.solver;
    ctx.specular_max_chain = ctx.snee.max_chain; /* the setting's chain=N, if given */
    /* an option that would change nothing is refused rather than silently ignored */
    if (o->specular_nee && ctx.snee.solver != SPC_SNEE_NONE &&
        (ctx.kind == SPC_INTEGRATOR_IPT || ctx.kind == SPC_INTEGRATOR_PTRACER))
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                             "specular NEE '%s' does nothing with the %s integrator (path, volpath and bdpt use "
                             "it); drop it or give none",
                             o->specular_nee, iname);
    ctx.mis_balance = o->mis_balance || sc->integrator.mis_balance; /* either asks for it */
    if (o->bdpt_pool < -1 || o->bdpt_pool > 64)
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "bdpt pool connections %d are outside -1..64",
                             o->bdpt_pool);
    if (o->bdpt_pool > 0 && ctx.kind != SPC_INTEGRATOR_BDPT)
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                             "a pool of light vertices needs the bdpt integrator, not '%s'", iname);
    if (o->bdpt_pool > 0 && (o->strategy_images || ctx.strategy_s >= 0 || ctx.strategy_t >= 0))
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                             "a pool of light vertices and strategy images or a single strategy exclude each other");
    if (o->bdpt_light_paths < 0 || o->bdpt_light_paths > 64)
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "bdpt light subpaths per sample %d are outside 0..64",
                             o->bdpt_light_paths);
    if (o->bdpt_light_paths > 0 && ctx.kind != SPC_INTEGRATOR_BDPT)
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                             "light subpaths per sample need the bdpt integrator, not '%s'", iname);
    ctx.bdpt_light_paths = o->bdpt_light_paths > 0 ? o->bdpt_light_paths : SPC_BDPT_AUTO_LIGHT_PATHS;
    if (!(o->bdpt_aim < 1.0) || isnan(o->bdpt_aim))
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "bdpt's aimed share of emission %g is not below 1",
                             o->bdpt_aim);
    if (o->bdpt_aim > 0.0 && ctx.kind != SPC_INTEGRATOR_BDPT)
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "emission aimed at casters needs the bdpt integrator, not '%s'",
                             iname);
    if (!(o->bdpt_aim_camera < 1.0) || isnan(o->bdpt_aim_camera))
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "bdpt's aimed share of the camera's bounce %g is not below 1",
                             o->bdpt_aim_camera);
    if (o->bdpt_aim_camera > 0.0 && ctx.kind != SPC_INTEGRATOR_BDPT)
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "a camera bounce aimed at casters needs the bdpt integrator, not '%s'",
                             iname);
    ctx.strict_normals = sc->integrator.strict_normals;
    if (o->strategy_images) {
        if (ctx.kind != SPC_INTEGRATOR_BDPT)
            return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "strategy images need the bdpt integrator, not '%s'",
                                 iname);
        if (ctx.max_depth < 1 || ctx.max_depth > SPC_STRATEGY_IMAGES_MAX_DEPTH)
            return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                                 "strategy images need a max_depth from 1 to %d (two images per strategy, %d "
                                 "strategies at %d), not %d",
                                 SPC_STRATEGY_IMAGES_MAX_DEPTH, SPC_STRATEGY_IMAGES_MAX, SPC_STRATEGY_IMAGES_MAX_DEPTH,
                                 ctx.max_depth);
        if (ctx.strategy_s >= 0 || ctx.strategy_t >= 0)
            return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                                 "strategy images and a single strategy (strategy_s, strategy_t) exclude each other");
        if (o->checkpoint_path || o->resume)
            return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                                 "strategy images are not kept in checkpoints: render them without one");
        ctx.strategy_images_depth = ctx.max_depth;
    }

    spc_film_spec fs = sc->film;
    if (o->width > 0 && o->height > 0) {
        fs.width = o->width;
        fs.height = o->height;
        fs.crop_x = fs.crop_y = fs.crop_w = fs.crop_h = 0;
    }
    if (fs.width <= 0 || fs.height <= 0 || fs.width > 65536 || fs.height > 65536 ||
        (long long)fs.width * fs.height > (1LL << 28))
        return spc_error_set(err, SPC_ERR_LIMIT, file, 0, 0, "film size %dx%d is outside 1..65536 per side and 2^28 pixels",
                             fs.width, fs.height);
    if (fs.crop_w <= 0 || fs.crop_h <= 0) {
        fs.crop_x = fs.crop_y = 0;
        fs.crop_w = fs.width;
        fs.crop_h = fs.height;
    }
    if (fs.crop_x < 0 || fs.crop_y < 0 || fs.crop_x + fs.crop_w > fs.width || fs.crop_y + fs.crop_h > fs.height)
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "film crop window lies outside the film");
    if (!(fs.filter_radius > 0.0))
        fs.filter_radius = 0.5;
    spc_film_filter_prepare(&fs);
    ctx.film = &fs;
    ctx.crop_x = fs.crop_x;
    ctx.crop_y = fs.crop_y;
    ctx.width = fs.crop_w;
    ctx.height = fs.crop_h;

    spc_camera_state cam;
    if (!spc_camera_prepare(&cam, &sc->camera, fs.width, fs.height))
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "invalid camera (singular transform or field of view)");
    ctx.cam = &cam;
    /* bdpt's pool of light vertices: as asked, or by default where the camera sees mostly
     * indirectly lit surfaces (bdpt_pool.h; SPC_POOL_AUTO_SHARE) */
    int pool_m = o->bdpt_pool > 0 ? o->bdpt_pool : 0;
    bool dev_cl = false;
    int dev_index = 0;
    const long long npix_window = (long long)ctx.width * ctx.height;
    if (o->bdpt_pool == 0 && ctx.kind == SPC_INTEGRATOR_BDPT && !o->strategy_images && ctx.strategy_s < 0 &&
        ctx.strategy_t < 0 && !spc_camera_has_lens(&cam) && npix_window <= SPC_POOL_AUTO_MAX_PIXELS &&
        !(spc_device_parse(o->device, &dev_cl, &dev_index) && dev_cl) &&
        spc_bdpt_pool_direct_share(&ctx, o->seed) < SPC_POOL_AUTO_SHARE)
        pool_m = SPC_POOL_AUTO_CONNECTIONS;

    long long spp = o->spp > 0 ? o->spp : sc->spp;
    if (o->time_limit > 0.0 && o->spp <= 0)
        spp = SPC_MAX_SPP;
    if (spp <= 0 || spp > SPC_MAX_SPP)
        return spc_error_set(err, SPC_ERR_LIMIT, file, 0, 0, "sample count %lld is outside 1..%d", spp, SPC_MAX_SPP);
    int threads = o->threads > 0 ? o->threads : default_threads();
    if (threads > SPC_MAX_THREADS)
        threads = SPC_MAX_THREADS;

    const bool aovs = o->aovs || sc->integrator.naovs > 0;
    struct spc_film *film = spc_film_create(fs.width, fs.height, fs.crop_x, fs.crop_y, fs.crop_w, fs.crop_h, aovs);
    if (!film)
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory for a %dx%d film", fs.crop_w, fs.crop_h);
    snprintf(film->integrator, sizeof film->integrator, "%s", spc_integrator_kind_name(ctx.kind));
    snprintf(film->specular_nee, sizeof film->specular_nee, "%s", ctx.specular_nee ? sname : "none");
    /* what the render owns besides the film, freed at `cleanup` on every path (NULL: not made yet),
     * and what the statistics read there */
    tile *tiles = NULL;
    double *buf = NULL;
    spc_tls *tls = NULL;
    pthread_t *th = NULL;
    spc_cl_renderer *cl = NULL;
    spc_cguide *cguide = NULL;
    spc_sguide *sguide = NULL;
    spc_bdpt_pool *pools = NULL;
    spc_bdpt_pool_model pool_model;
    spc_bdpt_aim aim;
    spc_path_graze graze;
    memset(&pool_model, 0, sizeof pool_model);
    spc_status status = SPC_OK;
    bool rendered = false; /* the passes ran: the film goes to the caller, with status */
    uint64_t rays = 0, shadow_rays = 0, invalid = 0;
    double wall = 0.0, guide_seconds = 0.0;
    int guide_entries = 0, guide_cones = 0;

    int tx = (ctx.width + SPC_TILE - 1) / SPC_TILE, ty = (ctx.height + SPC_TILE - 1) / SPC_TILE;
    int ntiles = tx * ty;
    tiles = malloc((size_t)ntiles * sizeof *tiles);
    size_t npix = (size_t)ctx.width * (size_t)ctx.height;
    int max_batch = (int)spc_max(1.0, spc_min((double)SPC_BATCH_PIXELS / (double)npix, 4096.0));
    film->naov_out = sc->integrator.naovs;
    memcpy(film->aov_out, sc->integrator.aovs, sizeof film->aov_out);
    snprintf(film->aov_image, sizeof film->aov_image, "%s", sc->integrator.aov_image);
    const int base = aovs ? 3 + SPC_FILM_AOVS : 3;
    const int nfilms = ctx.strategy_images_depth > 0 ? 2 * spc_strategy_count(ctx.strategy_images_depth) : 0;
    const int stride = base + 3 * nfilms;
    if (pool_m > 0)
        max_batch = (int)spc_max(1.0, spc_min(max_batch, (double)SPC_POOL_BATCH_PATHS / (double)npix));
    if (nfilms > 0) /* keep the batch buffer near its usual size (3 doubles per pixel-pass) */
        max_batch = (int)spc_max(1.0, spc_min(max_batch, 3.0 * SPC_BATCH_PIXELS / ((double)npix * stride)));
    if (nfilms > 0) {
        /* owned by the image, which frees them with itself on every path below */
        film->strategy = calloc((size_t)nfilms, sizeof *film->strategy);
        bool ok = film->strategy != NULL;
        for (int j = 0; ok && j < nfilms; ++j) {
            film->strategy[j] = spc_film_create(fs.width, fs.height, fs.crop_x, fs.crop_y, fs.crop_w, fs.crop_h, false);
            ok = film->strategy[j] != NULL;
            if (ok)
                film->nstrategy = j + 1;
        }
        if (!ok) {
            status = spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory for %d strategy films of %dx%d",
                                   nfilms, fs.crop_w, fs.crop_h);
            goto cleanup;
        }
        for (int k = 1; k <= ctx.strategy_images_depth; ++k)
            for (int s = 0; s <= k; ++s)
                for (int wt = 0; wt < 2; ++wt) {
                    struct spc_film *f = film->strategy[2 * spc_strategy_index(s, k + 1 - s) + wt];
                    f->strategy_s = s;
                    f->strategy_t = k + 1 - s;
                    f->strategy_weighted = wt == 0;
                }
    }
    buf = malloc((size_t)max_batch * npix * (size_t)stride * sizeof(double));
    tls = calloc((size_t)max_batch * (size_t)ntiles, sizeof *tls);
    th = malloc((size_t)threads * sizeof *th);
    if (!tiles || !buf || !tls || !th) {
        status = spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory for render buffers");
        goto cleanup;
    }
    for (int j = 0; j < ty; ++j)
        for (int i = 0; i < tx; ++i) {
            tile *t = &tiles[j * tx + i];
            t->x0 = i * SPC_TILE;
            t->y0 = j * SPC_TILE;
            t->x1 = t->x0 + SPC_TILE < ctx.width ? t->x0 + SPC_TILE : ctx.width;
            t->y1 = t->y0 + SPC_TILE < ctx.height ? t->y0 + SPC_TILE : ctx.height;
        }

    /* another device renders the batches (device/device.h); everything else stays the same */
    bool use_cl = false;
    int cl_index = 0;
    if (!spc_device_parse(o->device, &use_cl, &cl_index)) {
        status = spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "unknown device '%s'; specula has: cpu, opencl[:N]",
                               o->device);
        goto cleanup;
    }
    if (use_cl && ctx.bdpt_light_paths > 1) {
        if (o->bdpt_light_paths > 1) {
            status = spc_error_set(err, SPC_ERR_PLUGIN, file, 0, 0,
                                   "the opencl device traces one light subpath per camera sample");
            goto cleanup;
        }
        ctx.bdpt_light_paths = 1;
    }
    if (use_cl && pool_m > 0) {
        status = spc_error_set(err, SPC_ERR_PLUGIN, file, 0, 0, "the opencl device has no pool of light vertices");
        goto cleanup;
    }
    if (use_cl && (status = spc_cl_create(&ctx, cl_index, aovs, &cl, err)) != SPC_OK)
        goto cleanup;

    /* bdpt's emission aimed at the casters (bdpt.h): its pilot, once (a fixed stream); the opencl
     * device keeps the lights' own emission */
    if (ctx.kind == SPC_INTEGRATOR_BDPT && !use_cl && o->bdpt_aim >= 0.0 &&
        spc_bdpt_aim_init(&ctx, o->bdpt_aim > 0.0 ? o->bdpt_aim : SPC_BDPT_AUTO_AIM,
                          o->bdpt_aim_camera > 0.0   ? o->bdpt_aim_camera
                          : o->bdpt_aim_camera < 0.0 ? 0.0
                                                     : SPC_BDPT_AUTO_AIM_CAMERA,
                          &aim))
        ctx.bdpt_aim = &aim;

    char settings[1024];
    spc_ckpt_settings_text(&ctx, sname, o->seed, aovs, settings, sizeof settings);
    if (ctx.bdpt_aim) /* the aim changes the image */
        snprintf(settings + strlen(settings), sizeof settings - strlen(settings), ";bdpt_aim=%.17g", aim.a);
    if (ctx.bdpt_aim && aim.cam > 0.0)
        snprintf(settings + strlen(settings), sizeof settings - strlen(settings), ";bdpt_aim_camera=%.17g", aim.cam);
    if (pool_m > 0) /* the pool changes the image */
        snprintf(settings + strlen(settings), sizeof settings - strlen(settings), ";bdpt_pool=%d", pool_m);
    if (ctx.kind == SPC_INTEGRATOR_BDPT && ctx.bdpt_light_paths > 1) /* so do more light subpaths */
        snprintf(settings + strlen(settings), sizeof settings - strlen(settings), ";bdpt_light_paths=%d",
                 ctx.bdpt_light_paths);
    if (use_cl) /* a checkpoint resumes only on the device that began it */
        snprintf(settings + strlen(settings), sizeof settings - strlen(settings), ";device=opencl:%d", cl_index);
    if (o->resume && (status = spc_ckpt_restore(o->resume, sc->content_hash, settings, film, err)) != SPC_OK)
        goto cleanup;
    spc_ckpt_meta meta = {sc->content_hash, settings, (int)spp, sc->path, o->checkpoint_user};

    double t_start = now_seconds();
    invalid = film->invalid_samples;
    /* caustic guiding at receivers (caustic_guide.h): its photon pre-pass, once, on this thread */
    if (ctx.kind == SPC_INTEGRATOR_PATH && ctx.specular_nee != SPC_SNEE_NONE && ctx.snee.recv_guide > 0.0 && !use_cl)
        cguide = spc_cguide_build(sc, spc_cguide_photons((double)ctx.width * ctx.height), SPC_CGUIDE_STREAM,
                                  ctx.snee.recv_guide);
    ctx.snee.cguide = cguide;
    /* grazing directions along mirror cylinders' walls (path_graze.h): the path tracer with
     * specular NEE */
    if (ctx.kind == SPC_INTEGRATOR_PATH && ctx.specular_nee != SPC_SNEE_NONE && !use_cl &&
        spc_path_graze_init(&graze, sc))
        ctx.graze = &graze;
    /* bdpt's pool: the selection model from its pilot, once (deterministic: the same for any thread
     * count and on resuming), and a pool per pass of a batch */
    if (pool_m > 0) {
        pools = calloc((size_t)max_batch, sizeof *pools);
        if (!pools || !spc_bdpt_pool_learn(&ctx, o->seed, pool_m, &pool_model)) {
            status = spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory for the pool of light vertices");
            goto cleanup;
        }
        ctx.pool_model = &pool_model;
    }
    /* guided seeds of the randomized solvers (seed_guide.h): their light paths, once, on this thread */
    if (ctx.specular_nee != SPC_SNEE_NONE && ctx.snee.seed_guide > 0.0 && !use_cl)
        sguide = spc_sguide_build(sc, SPC_SGUIDE_PHOTONS, SPC_SGUIDE_STREAM, ctx.snee.any_surface);
    ctx.snee.sguide = sguide;
    guide_seconds = cguide ? now_seconds() - t_start : 0.0;
    const int start = film->spp;
    int done = start;
    size_t ntris = 0;
    for (int i = 0; i < sc->nshapes; ++i)
        if (sc->shapes[i]->type == SPC_SHAPE_MESH)
            ntris += sc->shapes[i]->mesh.ntris;
    double sec_per_pass = 0.0, last_ckpt = t_start;
    while (done < spp) {
        if (o->cancel && *o->cancel) {
            status = SPC_ERR_INTERRUPTED;
            break;
        }
        double elapsed = now_seconds() - t_start;
        int batch = max_batch;
        if (batch > spp - done)
            batch = (int)(spp - done);
        if (done == start) {
            batch = 1; /* measure */
        } else if (sec_per_pass > 0.0) {
            double target = SPC_BATCH_TARGET_SECONDS;
            if (o->checkpoint_path && o->checkpoint_every < target)
                target = o->checkpoint_every > 0.0 ? o->checkpoint_every : 0.0;
            int by_time = (int)(target / sec_per_pass);
            if (o->time_limit > 0.0) {
                double left = o->time_limit - elapsed;
                int fit = (int)(left / sec_per_pass);
                if (fit < 1)
                    break;
                if (by_time > fit)
                    by_time = fit;
            }
            if (by_time < 1)
                by_time = 1;
            if (batch > by_time)
                batch = by_time;
        }
        job jb;
        jb.ctx = &ctx;
        jb.tiles = tiles;
        jb.ntiles = ntiles;
        jb.pass0 = done;
        jb.npasses = batch;
        /* a big scene's items tile by tile through the whole batch (SPC_TILE_PASSES_TRIS);
         * SPECULA_TILE_PASSES=N sets groups of N passes (0: the batch), the same image either way */
        const char *group_env = getenv("SPECULA_TILE_PASSES");
        jb.group = group_env ? atoi(group_env) : ntris >= SPC_TILE_PASSES_TRIS ? 0 : 1;
        if (jb.group < 1 || jb.group > batch)
            jb.group = batch;
        jb.stride = stride;
        jb.base = base;
        jb.nfilms = nfilms;
        /* the same image either way; SPECULA_PATH_WAVE=0 keeps path.c (benchmarks, checks) */
        const char *wave_env = getenv("SPECULA_PATH_WAVE");
        jb.wave = nfilms == 0 && spc_path_wave_applies(&ctx) && !(wave_env && strcmp(wave_env, "0") == 0);
        jb.buf = buf;
        jb.tls = tls;
        jb.seed = o->seed;
        atomic_init(&jb.next, 0);
        atomic_init(&jb.limit, batch * ntiles);
        jb.cancel = o->cancel;
        atomic_init(&jb.rays, 0);
        atomic_init(&jb.shadow_rays, 0);
        double t0 = now_seconds();
        jb.pool_phase = false;
        if (pools) {
            /* the batch's pools first: every pass's light subpaths, then each pass's pool in tile
             * order, before any camera sample of the batch */
            jb.pool_phase = true;
            int np = threads < batch * ntiles ? threads : batch * ntiles, started = 0;
            for (int i = 1; i < np; ++i) {
                if (pthread_create(&th[i], NULL, worker, &jb) != 0)
                    break;
                ++started;
            }
            worker(&jb);
            for (int i = 1; i <= started; ++i)
                pthread_join(th[i], NULL);
            for (int b = 0; b < batch; ++b) {
                if (!spc_bdpt_pool_index(&ctx, &tls[(size_t)b * ntiles], ntiles, &pools[b])) {
                    status =
                        spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory for the pool of light vertices");
                    break;
                }
                for (int ti = 0; ti < ntiles; ++ti)
                    tls[(size_t)b * ntiles + ti].pool = &pools[b];
            }
            if (status != SPC_OK)
                break;
            jb.pool_phase = false;
            atomic_store(&jb.next, 0);
        }
        if (cl) {
            status = spc_cl_render_passes(cl, done, batch, o->seed, buf, stride, &invalid, &rays, err);
            if (status != SPC_OK)
                break;
            atomic_store(&jb.limit, batch * ntiles);
        }
        int nt = cl ? 0 : threads;
        if (nt > batch * ntiles)
            nt = batch * ntiles;
        int started = 0;
        for (int i = 1; i < nt; ++i) {
            if (pthread_create(&th[i], NULL, worker, &jb) != 0)
                break;
            ++started;
        }
        if (!cl)
            worker(&jb);
        for (int i = 1; i <= started; ++i)
            pthread_join(th[i], NULL);
        rays += atomic_load(&jb.rays);
        shadow_rays += atomic_load(&jb.shadow_rays);
        int whole = atomic_load(&jb.limit) / ntiles; /* passes rendered in full */
        /* commit the passes in order, splats merged in tile order; drop the unfinished ones */
        for (int b = whole; b < batch; ++b)
            for (int ti = 0; ti < ntiles; ++ti) {
                tls[(size_t)b * ntiles + ti].nsplats = 0;
                tls[(size_t)b * ntiles + ti].invalid = 0;
            }
        batch = whole;
        for (int b = 0; b < batch; ++b) {
            double *pb = buf + (size_t)b * npix * stride;
            for (size_t p = 0; p < npix; ++p) {
                film->pass[3 * p] += pb[p * stride];
                film->pass[3 * p + 1] += pb[p * stride + 1];
                film->pass[3 * p + 2] += pb[p * stride + 2];
                if (base == 3 + SPC_FILM_AOVS)
                    for (int k = 0; k < SPC_FILM_AOVS; ++k)
                        film->aov_sum[SPC_FILM_AOVS * p + k] += pb[p * stride + 3 + k];
                for (int j = 0; j < nfilms; ++j)
                    for (int c = 0; c < 3; ++c)
                        film->strategy[j]->pass[3 * p + c] += pb[p * stride + base + 3 * j + c];
            }
            for (int ti = 0; ti < ntiles; ++ti) {
                spc_tls *t = &tls[(size_t)b * ntiles + ti];
                for (size_t k = 0; k < t->nsplats; ++k) {
                    const spc_splat *s = &t->splats[k];
                    size_t p = (size_t)s->y * ctx.width + (size_t)s->x;
                    struct spc_film *dst = s->film == 0 ? film : film->strategy[s->film - 1];
                    dst->pass[3 * p] += s->r;
                    dst->pass[3 * p + 1] += s->g;
                    dst->pass[3 * p + 2] += s->b;
                }
                t->nsplats = 0;
                invalid += t->invalid;
                t->invalid = 0;
            }
            spc_film_commit_pass(film);
            for (int j = 0; j < nfilms; ++j)
                spc_film_commit_pass(film->strategy[j]);
        }
        done += batch;
        double dt = now_seconds() - t0;
        if (batch > 0)
            sec_per_pass = dt / batch;
        film->invalid_samples = invalid;
        if (o->checkpoint_path && done < spp && !(o->cancel && *o->cancel) &&
            now_seconds() - last_ckpt >= o->checkpoint_every) {
            status = spc_ckpt_write(o->checkpoint_path, film, &meta, err);
            if (status != SPC_OK)
                break;
            last_ckpt = now_seconds();
        }
        if (o->progress)
            o->progress(o->progress_user, (double)done / (double)spp, done, (int)spp, now_seconds() - t_start);
        if (o->time_limit > 0.0 && now_seconds() - t_start + sec_per_pass > o->time_limit)
            break;
    }
    if (status == SPC_OK && o->cancel && *o->cancel && done < spp)
        status = SPC_ERR_INTERRUPTED;
    film->invalid_samples = invalid;
    if (o->checkpoint_path && status != SPC_ERR_IO && status != SPC_ERR_LIMIT) { /* not again after a failed write */
        spc_status cs = spc_ckpt_write(o->checkpoint_path, film, &meta, err);
        if (cs != SPC_OK)
            status = cs;
    }
    wall = now_seconds() - t_start;
    guide_entries = cguide ? cguide->n : 0;
    guide_cones = cguide ? cguide->cones : 0;
    rendered = true;
cleanup:
    spc_cguide_destroy(cguide);
    spc_sguide_destroy(sguide);
    spc_cl_destroy(cl);
    for (int b = 0; pools && b < max_batch; ++b)
        spc_bdpt_pool_release(&pools[b]);
    free(pools);
    spc_bdpt_pool_model_release(&pool_model);
    for (size_t i = 0; tls && i < (size_t)max_batch * ntiles; ++i) {
        free(tls[i].splats);
        free(tls[i].lv);
        free(tls[i].lv_first);
    }
    free(tls);
    free(buf);
    free(tiles);
    free(th);
    if (!rendered) {
        spc_film_destroy(film);
        return status;
    }
    if (!spc_film_resolve(film)) {
        spc_film_destroy(film);
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory resolving the film");
    }
    if (stats) {
        stats->spp = film->spp;
        stats->wall_seconds = wall;
        stats->rays_traced = rays;
        stats->shadow_rays_traced = shadow_rays;
        stats->mrays_per_second = wall > 0.0 ? (double)rays / wall * 1e-6 : 0.0;
        stats->threads = threads;
        stats->samples = (uint64_t)film->spp * npix;
        stats->invalid_samples = invalid;
        snprintf(stats->specular_nee, sizeof stats->specular_nee, "%s", ctx.specular_nee ? sname : "none");
        snprintf(stats->specular_nee_pilot, sizeof stats->specular_nee_pilot, "%s", plan->pilot_note);
        stats->caustic_guide_entries = guide_entries;
        stats->caustic_guide_cones = guide_cones;
        stats->caustic_guide_seconds = guide_seconds;
        stats->bdpt_aim = ctx.bdpt_aim ? ctx.bdpt_aim->a : 0.0;
        stats->bdpt_aim_camera = ctx.bdpt_aim ? ctx.bdpt_aim->cam : 0.0;
    }
    *out = film; /* also with a checkpoint write error: the image rendered so far is valid */
    if (status == SPC_ERR_INTERRUPTED)
        spc_error_set(err, SPC_ERR_INTERRUPTED, file, 0, 0, "render interrupted after %d samples per pixel", film->spp);
    return status;
}
