/*
 * integrator/path_snee.c: the path tracer's hooks into specular NEE (path_snee.h): the parameters
 * as a path runs them, the chain budget from the depth left, specular NEE from the camera and at
 * each receiver on streams forked from the sampler, and the exclusion track that keeps BSDF
 * sampling from counting specular NEE's paths again (specular_nee.h).
 */
#include "integrator/path_snee.h"

#include <stddef.h>
#include <string.h>

#include "integrator/path_lt.h"
#include "integrator/splat.h"
#include "manifold/flat_chains.h"
#include "manifold/plane_chains.h"
#include "manifold/snee_cost.h"
#include "manifold/specular_nee.h"

/* The rough-vertex mode (newton's "rough"): its own estimator, without MIS or camera queries. */
static bool rough_mode(const spc_snee_params *p) { return p->solver == SPC_SNEE_NEWTON && p->newton.rough; }

/* The longest chain (in vertices: k vertices make k + 1 segments) that fits in the depth left after
 * `segments` segments, at most cap. */
static int depth_left(const spc_render_ctx *ctx, int segments, int cap)
{
    if (ctx->max_depth >= 0 && ctx->max_depth - segments - 1 < cap)
        return ctx->max_depth - segments - 1;
    return cap;
}

/* The stream key of the light-traced caustics' subpath (path_lt.h), forked from the camera
 * sample's sampler. */
#define SPC_PATH_LT_STREAM 0x6c74636175737469ULL
/* And of the light seen through flat glass (path_lt_view.h). */
#define SPC_PATH_LT_VIEW_STREAM 0x6c74766965777321ULL
/* And of the light-guide caustics' subpath. */
#define SPC_PATH_LT_GUIDE_STREAM 0x6c74677569646573ULL

/* The camera's chain of j delta scatterings (cam_events, last first) retraced from x toward the
 * pinhole (wo: toward the previous vertex); false where the trace does not follow those events. */
static bool camera_chain(const spc_path_snee *s, const spc_hit *x, spc_vec3 wo, int j, spc_chain *cc)
{
    unsigned char ev[SPC_CHAIN_MAX_VERTICES];
    for (int i = 0; i < j; ++i)
        ev[i] = s->cam_events[j - 1 - i];
    spc_frame f = spc_frame_from_n(wo);
    spc_chain_opts o = spc_chain_opts_default(j);
    o.events = ev;
    o.any_surface = s->p.any_surface;
    spc_chain_trace(s->ctx->scene, x, &f, 0.0, 0.0, &o, cc);
    return cc->n == j && cc->end != SPC_CHAIN_END_TIR && cc->end != SPC_CHAIN_END_MISMATCH &&
           cc->end != SPC_CHAIN_END_DEGENERATE;
}

/* params.delta_share at the path's second receiver x (seen from wo): specular NEE's share of the
 * point light's chain c, made on psi of its calls, against light tracing (path_lt.h). */
static double lt_share(const void *user, const spc_hit *x, spc_vec3 wo, const spc_chain *c, const spc_emitter *e,
                       double psi)
{
    const spc_path_snee *s = user;
    if (c->n > spc_path_lt_area_chain_max(&s->p, c, s->lt_kmax, s->lt_kflat))
        return 1.0;
    double r = spc_path_lt_ratio_via(s->ctx, &s->p, &s->lt_x1, s->lt_w1, s->lt_mid, s->lt_nmid, x, wo, c, e) / psi;
    return 1.0 / (1.0 + r * r);
}

/* Is c (a point or spot light's chain from the path's first receiver) one the light guides make at
 * weight 1: the receiver the camera ray's hit, seen directly, and c at least
 * spc_path_lt_guide_point_min_chain vertices long (path_lt.h)? Specular NEE's share of it is 0. */
static bool guide_takes(const spc_path_snee *s, const spc_chain *c)
{
    if (!s->lg_enabled || s->receivers != 0 || s->scatterings != 0 || c->n < s->lg_point_min)
        return false;
    /* not through a normal-mapped plane: the guides leave those (path_lt.c) */
    for (int i = 0; i < c->n; ++i)
        if (spc_plane_chain_shape(c->v[i].h.shape))
            return false;
    return true;
}

/* The same at the path's first receiver x (seen from wo), reached from the camera through the
 * delta scatterings recorded in cam_events: the camera's chain retraced from x toward the pinhole. */
static double lt_share_first(const void *user, const spc_hit *x, spc_vec3 wo, const spc_chain *c, const spc_emitter *e,
                             double psi)
{
    const spc_path_snee *s = user;
    if (guide_takes(s, c))
        return 0.0;
    int j = s->scatterings;
    if (c->n > spc_path_lt_area_chain_max(&s->p, c, s->lt_kmax, s->lt_kflat) ||
        j > spc_path_lt_camera_max_chain(&s->p) || j > SPC_CHAIN_MAX_VERTICES)
        return 1.0;
    double r;
    if (j == 0) {
        r = spc_path_lt_ratio_first(s->ctx, &s->p, x, NULL, c, e);
    } else {
        spc_chain cc;
        if (!camera_chain(s, x, wo, j, &cc))
            return 1.0;
        r = spc_path_lt_ratio_first(s->ctx, &s->p, x, &cc, c, e);
    }
    r /= psi;
    return 1.0 / (1.0 + r * r);
}

/* params.delta_share at the camera ray's hit seen directly where light tracing's caustics do not
 * run but the light guides do: 0 on their chains (guide_takes), 1 on the others. */
static double guide_share_first(const void *user, const spc_hit *x, spc_vec3 wo, const spc_chain *c,
                                const spc_emitter *e, double psi)
{
    (void)x, (void)wo, (void)e, (void)psi;
    return guide_takes(user, c) ? 0.0 : 1.0;
}

/* params.alt_chain_ratio at the path's second receiver x (seen from wo): light tracing's density
 * of the area light's path x1 - x - chain c - y over BSDF sampling's at x (path_lt.h). */
static double lt_alt(const void *user, const spc_hit *x, spc_vec3 wo, const spc_chain *c, const spc_emitter *e,
                     spc_vec3 y, spc_vec3 ny)
{
    const spc_path_snee *s = user;
    if (c->n > spc_path_lt_area_chain_max(&s->p, c, s->alt_kmax, s->alt_kflat) || !s->alt_x1_set)
        return 0.0;
    return spc_path_lt_area_ratio(s->ctx, &s->p, &s->alt_x1, s->alt_w1, x, wo, NULL, c, e, y, ny);
}

/* The same at the path's first receiver x, the camera's chain retraced as lt_share_first does. */
static double lt_alt_first(const void *user, const spc_hit *x, spc_vec3 wo, const spc_chain *c, const spc_emitter *e,
                           spc_vec3 y, spc_vec3 ny)
{
    const spc_path_snee *s = user;
    int j = s->alt_scatterings;
    if (c->n > spc_path_lt_area_chain_max(&s->p, c, s->alt_kmax, s->alt_kflat) || s->alt_x1_set ||
        j > spc_path_lt_camera_max_chain(&s->p) || j > SPC_CHAIN_MAX_VERTICES)
        return 0.0;
    if (j == 0)
        return spc_path_lt_area_ratio(s->ctx, &s->p, NULL, spc_v3(0, 0, 0), x, wo, NULL, c, e, y, ny);
    spc_chain cc;
    if (!camera_chain(s, x, wo, j, &cc))
        return 0.0;
    return spc_path_lt_area_ratio(s->ctx, &s->p, NULL, spc_v3(0, 0, 0), x, wo, &cc, c, e, y, ny);
}

/* Film positions the driver takes camera samples at (the rendered window). */
static bool in_window(const spc_render_ctx *ctx, double fx, double fy)
{
    return fx >= ctx->crop_x && fx < ctx->crop_x + ctx->width && fy >= ctx->crop_y && fy < ctx->crop_y + ctx->height;
}

/* The light sample's uniforms for the query at a receiver from smp's stratified stream
 * (spc_snee_params.light_u): over a pixel's samples the light points then cover the light evenly.
 * Where the query's value is smooth in its light point (a large light, a water surface) stratified
 * points converge faster than independent ones: at equal spp relMSE fell 2.4x on
 * scenes/newton_pool.xml (bench/RESULTS.md, "Tails 2"). Their two dimension pairs are used up at
 * every vertex, so that the dimensions stay aligned across the pixel's samples, but computed only
 * where a light sample is made (params.light_u_smp, from the copy s->light_smp): most vertices make
 * no query (the budget, the query's roulette). Not for the query from the camera: its splats land
 * on other pixels, and no gain showed there. */
static void skip_light_u(spc_path_snee *s, spc_sampler *smp)
{
    s->light_smp = *smp;
    s->p.light_u_smp = &s->light_smp;
    spc_sampler_skip(smp, 2);
}

/* The state every camera sample starts from: the fields before p cleared (those after it are
 * written before they are read, path_snee.h), the camera ray's direction and the film's scale;
 * the options copied where specular NEE is on. Returns s->on. */
static bool begin_state(spc_path_snee *s, const spc_render_ctx *ctx, const spc_ray *ray0)
{
    memset(s, 0, offsetof(spc_path_snee, p));
    s->mis_gv.a = 0.0;
    s->mis_wo = s->mis_d0 = spc_v3(0, 0, 1);
    s->cam_d0 = ray0->d;
    s->cam_scale = (double)ctx->cam->width * (double)ctx->cam->height / ((double)ctx->width * (double)ctx->height);
    s->on = ctx->kind == SPC_INTEGRATOR_PATH && ctx->specular_nee != SPC_SNEE_NONE;
    if (!s->on)
        return false;
    s->p = ctx->snee;
    s->p.mis = !s->p.no_mis && !rough_mode(&s->p);
    s->ctx = ctx;
    return true;
}

/* The chain budgets of the query from the camera and of the camera ray's track: false where that
 * query does not run (off, the rough mode, a camera it cannot connect to, no vertex left). */
static bool camera_budgets(const spc_path_snee *s, const spc_render_ctx *ctx, int *budget, int *long_budget)
{
    if (!s->p.camera || rough_mode(&s->p) || !spc_camera_connectible(ctx->cam))
        return false;
    *budget = depth_left(ctx, 0, ctx->specular_max_chain);
    if (*budget > s->p.max_chain)
        *budget = s->p.max_chain;
    *long_budget = ctx->max_depth >= 0 ? ctx->max_depth - 1 : SPC_CHAIN_MAX_VERTICES;
    return *budget >= 1;
}

void spc_path_snee_begin(spc_path_snee *s, const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray0,
                         const spc_sampler *smp)
{
    if (!begin_state(s, ctx, ray0))
        return;
    s->lt_enabled = spc_path_lt_enabled(ctx, &s->p);
    if (s->lt_enabled) {
        spc_rng lrng;
        spc_sampler_fork_rng(smp, SPC_PATH_LT_STREAM, &lrng);
        spc_path_lt_trace(ctx, &s->p, tls, &lrng);
    }
    s->lg_enabled = spc_path_lt_guide_enabled(ctx, &s->p);
    if (s->lg_enabled) {
        s->lg_min = spc_path_lt_guide_min_chain(ctx, &s->p);
        s->lg_point_min = spc_path_lt_guide_point_min_chain(ctx, &s->p);
        spc_rng grng;
        spc_sampler_fork_rng(smp, SPC_PATH_LT_GUIDE_STREAM, &grng);
        spc_path_lt_guide_trace(ctx, &s->p, tls, &grng);
    }
    s->lv_enabled = spc_path_lt_view_enabled(ctx, &s->p);
    if (s->lv_enabled) {
        s->lv_on = true;
        spc_rng vrng;
        spc_sampler_fork_rng(smp, SPC_PATH_LT_VIEW_STREAM, &vrng);
        spc_path_lt_view_trace(ctx, &s->p, tls, &vrng);
    }
    /* from the pinhole: its splats, and the camera ray tracked as from a receiver until its first
     * non-delta scattering */
    int budget, long_budget;
    if (!camera_budgets(s, ctx, &budget, &long_budget))
        return;
    spc_rng rng;
    spc_sampler_fork_rng(smp, 0, &rng);
    spc_snee_splat sp[SPC_SNEE_CAMERA_SPLATS];
    int n = spc_snee_camera(ctx->scene, &s->p, ctx->cam, s->cam_scale, budget, long_budget, &rng, NULL, sp,
                            SPC_SNEE_CAMERA_SPLATS);
    for (int i = 0; i < n; ++i)
        if (in_window(ctx, sp[i].fx, sp[i].fy))
            spc_splat_add(ctx, tls, sp[i].fx, sp[i].fy, sp[i].value);
    spc_snee_track_begin(&s->track, &s->p, budget, long_budget);
    s->track.long_max = spc_snee_camera_long_max(&s->p, long_budget, s->track.long_max);
    s->cam_track = true;
}

void spc_path_snee_begin_view(spc_path_snee *s, const spc_render_ctx *ctx, const spc_ray *ray0)
{
    if (!begin_state(s, ctx, ray0))
        return;
    /* the light seen through flat glass: its weight reads the camera ray's scatterings */
    s->lv_enabled = spc_path_lt_view_enabled(ctx, &s->p);
    s->lv_on = s->lv_enabled;
    /* the light-traced caustics' weights at the first receiver read the delta scatterings before it
     * (cam_events, spc_path_snee_scattered), recorded as the camera path records them; no subpath */
    s->lt_enabled = spc_path_lt_enabled(ctx, &s->p);
    int budget, long_budget;
    if (!camera_budgets(s, ctx, &budget, &long_budget))
        return;
    spc_snee_track_begin(&s->track, &s->p, budget, long_budget);
    s->track.long_max = spc_snee_camera_long_max(&s->p, long_budget, s->track.long_max);
    s->cam_track = true;
}

void spc_path_snee_delta_vertex(spc_path_snee *s, const spc_render_ctx *ctx, int segments)
{
    s->skip_query = false;
    s->budget = 0;
    s->long_budget = depth_left(ctx, segments, SPC_CHAIN_MAX_VERTICES);
}

/* spc_path_snee_emitter_weight without the light seen through flat glass. */
static double emitter_weight_base(const spc_path_snee *s, const spc_render_ctx *ctx, const spc_hit *h)
{
    const spc_snee_track *t = &s->track;
    if (!s->on)
        return 1.0;
    if (!spc_snee_track_covers(t, ctx->scene, h->emitter)) {
        /* a light guide's path: weighed against light tracing (path_lt.h) */
        if (!s->lg_on || s->lg_k < s->lg_min)
            return 1.0;
        double r =
            spc_path_lt_guide_ratio(ctx, &s->p, &s->lg_x, s->lg_wo, s->lg_d0, s->lg_dlast, h->emitter, h->p, h->ng);
        return 1.0 / (1.0 + r * r);
    }
    if (s->cam_track)
        return spc_snee_camera_bsdf_weight(ctx->scene, &s->p, ctx->cam, s->cam_scale, s->cam_d0, t->max_chain, t->k,
                                           t->events, h);
    /* the receiver's density: the guided mixture's where the scatter there was guided */
    spc_snee_params p = s->p;
    p.cguide_at = s->mis_gv.a > 0.0 ? &s->mis_gv : NULL;
    if (p.alt_chain_ratio) {
        /* light tracing makes these paths too: BSDF sampling's own part of the two's share */
        spc_receiver r;
        spc_receiver_surface(&r, &s->mis_x, s->mis_wo);
        r.guide = p.cguide_at;
        double w_alt;
        return spc_snee_receiver_weights(ctx->scene, &p, &r, s->mis_d0, t->max_chain, t->k, t->events, h, &w_alt);
    }
    return spc_snee_mis_bsdf_weight(ctx->scene, &p, &s->mis_x, s->mis_wo, s->mis_d0, t->max_chain, t->k, t->events,
                                    h);
}

double spc_path_snee_emitter_weight(const spc_path_snee *s, const spc_render_ctx *ctx, const spc_hit *h)
{
    double w = emitter_weight_base(s, ctx, h);
    /* the light seen from the camera through flat glass: light tracing's too (path_lt_view.h) */
    if (s->on && s->lv_on && s->lv_k >= 1)
        w = spc_path_lt_view_camera_weight(ctx, &s->p, h, s->lv_dlast, s->lv_k, s->lv_ev, w);
    return w;
}

bool spc_path_snee_light_covered(const spc_path_snee *s, const spc_scene *sc, const spc_hit *h, spc_vec3 wo,
                                 spc_vec3 wi, const spc_emitter *e)
{
    return s->on && spc_snee_track_covers_light(&s->track, &s->p, sc, h, wo, wi, e);
}

/* The state specular NEE leaves at the path vertex h reached after `segments` segments, which the
 * MIS weights of the paths leaving h read: the chain budgets, the query's probability and light
 * tracing's shares. False where no query runs at h (budget 0). */
static bool vertex_state(spc_path_snee *s, const spc_render_ctx *ctx, const spc_hit *h, int segments)
{
    /* one BSDF direction at a receiver unless the extra ones run there (below); a delta-only vertex
     * keeps the receiver's count for the paths that pass it */
    if (h->bsdf && spc_bsdf_has_smooth(h->bsdf))
        s->p.bsdf_n = 1.0;
    s->budget = spc_snee_budget_params(&s->p, h, depth_left(ctx, segments, ctx->specular_max_chain));
    if (s->p.receivers > 0 && s->receivers >= s->p.receivers)
        s->budget = 0; /* past the vertices specular NEE runs at */
    if (s->budget <= 0)
        return false;
    /* spc_snee_params.later_p: past the first receiver, the query by Russian roulette, made always
     * near the casters (spc_snee_later_prob); a covered BSDF path's MIS weight reads the same query_p
     * (a vertex with a smooth lobe is no chain vertex: a live track started at the last such vertex) */
    s->p.query_p = s->receivers > 0 ? spc_snee_later_prob(ctx->scene, &s->p, h->p)
                                    : spc_snee_first_prob(ctx->scene, &s->p, h->p);
    /* the path's second receiver after only delta scatterings from the camera ray's hit: its
     * point-light chains are light tracing's too */
    s->p.delta_share = NULL;
    s->p.alt_chain_ratio = NULL;
    bool area = spc_path_lt_area_enabled(&s->p);
    if (s->lt_on && s->receivers == 1 + s->lt_nmid) {
        s->lt_kmax = spc_path_lt_budget(ctx, &s->p, h, segments, s->receivers);
        s->lt_kflat = spc_path_lt_point_flat_budget(ctx, &s->p, h, segments, s->receivers);
        s->p.delta_share = lt_share;
        s->p.delta_user = s;
        /* area lights' subpaths join through no middle vertex: their paths are light tracing's at
         * the second receiver only */
        area = area && s->lt_nmid == 0;
        s->p.alt_chain_ratio = area ? lt_alt : NULL;
        s->p.alt_user = s;
        if (area) {
            s->alt_x1 = s->lt_x1;
            s->alt_w1 = s->lt_w1;
            s->alt_x1_set = true;
            s->alt_kmax = s->lt_kmax;
            s->alt_kflat = spc_path_lt_flat_budget(ctx, &s->p, h, segments, s->receivers);
        }
    } else if (s->lt_enabled && s->receivers == 0) {
        /* the first receiver, seen directly or through delta scatterings only */
        s->lt_kmax = spc_path_lt_budget(ctx, &s->p, h, segments, 0);
        s->lt_kflat = spc_path_lt_point_flat_budget(ctx, &s->p, h, segments, 0);
        s->p.delta_share = lt_share_first;
        s->p.delta_user = s;
        s->p.alt_chain_ratio = area ? lt_alt_first : NULL;
        s->p.alt_user = s;
        s->alt_x1_set = false;
        s->alt_scatterings = s->scatterings;
        s->alt_kmax = s->lt_kmax;
        s->alt_kflat = spc_path_lt_flat_budget(ctx, &s->p, h, segments, 0);
    } else if (s->lg_enabled && s->receivers == 0 && s->scatterings == 0) {
        /* the camera ray's hit: the point and spot lights' chains the light guides make */
        s->p.delta_share = guide_share_first;
        s->p.delta_user = s;
    }
    /* the extra directions past the first receiver (path_deep.h), where light tracing shares none
     * of the receiver's paths and the BSDF alone samples (no caustic guide): BSDF sampling's
     * density counted deep_split + 1 times */
    if (s->p.deep_split > 0 && s->receivers >= 1 && !s->p.delta_share && !s->p.alt_chain_ratio && !s->p.cguide_at)
        s->p.bsdf_n = s->p.deep_split + 1;
    return true;
}

void spc_path_snee_receiver_view(spc_path_snee *s, const spc_render_ctx *ctx, const spc_hit *h, int segments)
{
    s->skip_query = false;
    s->budget = 0;
    s->long_budget = depth_left(ctx, segments, SPC_CHAIN_MAX_VERTICES);
    s->p.cguide_at = NULL;
    if (s->on)
        vertex_state(s, ctx, h, segments);
}

spc_rgb spc_path_snee_at_vertex(spc_path_snee *s, const spc_render_ctx *ctx, const spc_hit *h, spc_vec3 wo,
                                int segments, spc_sampler *smp)
{
    bool skip = s->skip_query;
    s->skip_query = false;
    s->budget = 0;
    s->long_budget = depth_left(ctx, segments, SPC_CHAIN_MAX_VERTICES);
    if (!s->on)
        return spc_rgb1(0.0);
    skip_light_u(s, smp);
    if (!vertex_state(s, ctx, h, segments) || skip)
        return spc_rgb1(0.0);
    spc_rng rng;
    spc_sampler_fork_rng(smp, (uint64_t)segments, &rng);
    return spc_specular_nee_depth(ctx->scene, &s->p, h, wo, s->budget, s->long_budget, &rng, NULL);
}

const spc_cguide_vertex *spc_path_snee_guide_at(spc_path_snee *s, const spc_hit *h, spc_vec3 wo)
{
    s->p.cguide_at = NULL;
    if (!s->on || !s->p.cguide || !(s->p.recv_guide > 0.0))
        return NULL;
    spc_cguide_vertex_init(&s->gv, s->p.cguide, h, wo);
    if (!(s->gv.a > 0.0))
        return NULL;
    s->p.cguide_at = &s->gv;
    return &s->gv;
}

void spc_path_snee_scattered(spc_path_snee *s, const spc_hit *h, spc_vec3 wo, spc_vec3 wi, unsigned lobe)
{
    if (s->on) {
        spc_snee_track_scatter_params(&s->track, &s->p, h, lobe, s->budget, s->long_budget);
        if (s->p.mis && !(lobe & SPC_LOBE_DELTA) && s->budget > 0) {
            s->mis_x = *h;
            s->mis_wo = wo;
            s->mis_d0 = wi;
            if (s->p.cguide_at)
                s->mis_gv = s->gv;
            else
                s->mis_gv.a = 0.0;
        }
    }
    if (!(lobe & SPC_LOBE_DELTA)) {
        ++s->receivers;
        s->cam_track = false;
    }
    /* the light-guide caustics' x: the camera ray's hit left along a non-delta sample, then the
     * delta scatterings at chain surfaces (as the light subpath follows them) */
    if (s->lg_enabled) {
        if (!(lobe & SPC_LOBE_DELTA)) {
            s->lg_on = s->scatterings == 0 && spc_bsdf_has_smooth(h->bsdf);
            s->lg_x = *h;
            s->lg_wo = wo;
            s->lg_d0 = wi;
            s->lg_k = 0;
        } else if (s->lg_on) {
            int ev;
            if (s->lg_k >= SPC_PATH_LT_GUIDE_MAX || !spc_chain_surface(h, s->p.any_surface, &ev) ||
                !spc_bsdf_is_delta_only(h->bsdf))
                s->lg_on = false;
            else
                ++s->lg_k;
        }
        s->lg_dlast = wi;
    }
    /* the light seen through flat glass: the camera ray's delta scatterings on flat faces */
    if (s->lv_on) {
        if ((lobe & SPC_LOBE_DELTA) && s->lv_k < SPC_PATH_LT_VIEW_MAX_CHAIN && spc_flat_chain_shape(h->shape)) {
            s->lv_ev[s->lv_k++] = lobe == SPC_LOBE_DELTA_REFLECTION ? SPC_CHAIN_REFLECT : SPC_CHAIN_REFRACT;
            s->lv_dlast = wi;
        } else {
            s->lv_on = false;
        }
    }
    /* the light-traced caustics' x1: the camera ray's hit left along a non-delta sample; and the
     * delta scatterings from the camera before the first receiver */
    if (s->lt_enabled) {
        if (s->receivers == 0 && (lobe & SPC_LOBE_DELTA) && s->scatterings < SPC_CHAIN_MAX_VERTICES)
            s->cam_events[s->scatterings] = lobe == SPC_LOBE_DELTA_REFLECTION ? SPC_CHAIN_REFLECT : SPC_CHAIN_REFRACT;
        if (!(lobe & SPC_LOBE_DELTA) && s->scatterings == 0) {
            s->lt_on = true;
            s->lt_x1 = *h;
            s->lt_w1 = wi;
            s->lt_m = 0;
            s->lt_nmid = 0;
        } else if (!(lobe & SPC_LOBE_DELTA)) {
            if (s->lt_on && s->lt_nmid < SPC_PATH_LT_MID_VERTICES)
                s->lt_mid[s->lt_nmid++] = (spc_path_lt_vertex){*h, wo, wi};
            else
                s->lt_on = false;
            s->lt_m = 0;
        } else if (s->lt_on && ++s->lt_m > SPC_PATH_LT_MID_MAX) {
            s->lt_on = false;
        }
    }
    ++s->scatterings;
}

bool spc_path_snee_splits(const spc_path_snee *s, const spc_hit *h)
{
    return s->on && !s->p.no_split && h->shape && h->shape->type == SPC_SHAPE_MESH;
}

double spc_path_snee_split_prob(const spc_path_snee *s, const spc_hit *h, double pr)
{
    if (!spc_flat_chain_shape(h->shape))
        return 1.0;
    double f = s->p.split_f > 0.0 && s->p.split_f <= 1.0 ? s->p.split_f : SPC_PATH_SPLIT_F;
    return pr >= f ? 1.0 : pr / f;
}
