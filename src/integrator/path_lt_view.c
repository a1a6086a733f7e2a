/*
 * integrator/path_lt_view.c: an area light seen from the camera through flat glass, by light
 * tracing (path_lt_view.h): a light point joined to the pinhole by the exact chains through flat
 * faces (manifold/flat_chains.h, as specular NEE solves a point-to-point chain, with the pinhole as
 * the fixed end), weighed against the camera ray by the power heuristic over the two strategies
 * (Veach 1997, ch. 9; bdpt's t = 1 join through a specular chain, its density by the generalized
 * geometry term of the chain).
 */
#include "integrator/path_lt_view.h"

#include <string.h>

#include "integrator/path_lt.h"
#include "integrator/splat.h"
#include "manifold/flat_chains.h"
#include "manifold/specular_nee.h"

/* The most chains from one light point to the pinhole a draw keeps. */
#define VIEW_CHAINS 16

static bool rough_mode(const spc_snee_params *p) { return p->solver == SPC_SNEE_NEWTON && p->newton.rough; }

static double view_share(const spc_snee_params *p)
{
    return p->lt_view_share > 0.0 && p->lt_view_share <= 1.0 ? p->lt_view_share : SPC_PATH_LT_VIEW_SHARE;
}

static bool in_window(const spc_render_ctx *ctx, double fx, double fy)
{
    return fx >= ctx->crop_x && fx < ctx->crop_x + ctx->width && fy >= ctx->crop_y && fy < ctx->crop_y + ctx->height;
}

/* The longest chain that fits in the depth left after `segments` segments, at most cap (as the
 * path tracer's specular NEE computes it). */
static int depth_left(const spc_render_ctx *ctx, int segments, int cap)
{
    if (ctx->max_depth >= 0 && ctx->max_depth - segments - 1 < cap)
        return ctx->max_depth - segments - 1;
    return cap;
}

/* A smooth dielectric's two delta lobes: where the camera ray meets one through delta vertices
 * only, the path tracer traces its reflection on every sample (emission splitting, path.c), so a
 * light hit right after that reflection is made with probability 1 there, not F. */
static bool splits_emission(const spc_bsdf *b)
{
    return b && spc_bsdf_flags(b) == (SPC_LOBE_DELTA_REFLECTION | SPC_LOBE_DELTA_TRANSMISSION);
}

/* Has the chain two or more vertices with a reflection off glass among them? Where specular NEE
 * from the pinhole runs (params.camera), its enumeration weighs the others (a chain without a
 * reflection off glass, or a reflection alone): the joins solve only these. */
static bool glass_reflect(const spc_chain *cc)
{
    if (cc->n < 2)
        return false;
    for (int i = 0; i < cc->n; ++i)
        if (cc->v[i].event == SPC_CHAIN_REFLECT && cc->v[i].h.bsdf &&
            (spc_bsdf_flags(cc->v[i].h.bsdf) & SPC_LOBE_DELTA_TRANSMISSION))
            return true;
    return false;
}

/* Not with the caustic guide at receivers (not measured with it). */
bool spc_path_lt_view_enabled(const spc_render_ctx *ctx, const spc_snee_params *p)
{
    return p->lt_view && ctx->kind == SPC_INTEGRATOR_PATH && ctx->specular_nee != SPC_SNEE_NONE &&
           spc_path_lt_area_enabled(p) && !(p->recv_guide > 0.0) && !ctx->strict_normals && !rough_mode(p) &&
           spc_camera_connectible(ctx->cam);
}

double spc_path_lt_view_ratio(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_emitter *e, spc_vec3 y,
                              spc_vec3 ny, const spc_chain *cc)
{
    int k = cc->n;
    if (!e || e->type != SPC_EMITTER_AREA || !e->shape || k < 1 || k > SPC_PATH_LT_VIEW_MAX_CHAIN ||
        (ctx->max_depth >= 0 && k + 1 > ctx->max_depth) || !spc_flat_chain_faces(cc, true))
        return 0.0;
    if (p->camera && !glass_reflect(cc))
        return 0.0; /* not solved by the joins (spc_flat_chains_all_partial's need_glass_reflect) */
    const spc_chain_vertex *last = &cc->v[k - 1];
    spc_camera_direct cd;
    if (!spc_camera_sample_direct(ctx->cam, last->h.p, &cd) || !in_window(ctx, cd.fx, cd.fy))
        return 0.0;
    double G = spc_chain_geometry(cc, ctx->cam->origin, spc_neg(last->d));
    /* the camera ray's lobe choices along the chain (the last before the light split, above) */
    double P = 1.0;
    for (int i = 0; i < k; ++i) {
        const spc_chain_vertex *v = &cc->v[i];
        if (i == 0 && v->event == SPC_CHAIN_REFLECT && splits_emission(v->h.bsdf))
            continue;
        P *= spc_bsdf_specular_prob(v->h.bsdf, &v->h, spc_neg(v->wi), v->d);
    }
    double N = (double)ctx->width * (double)ctx->height;
    double p_cam = cd.We / N * spc_absdot(cc->d0, ny) * G * P;
    double p_lt = view_share(p) * spc_snee_light_pdf(ctx->scene, p->any_surface, e, y, ny);
    if (!(p_cam > 0.0) || !(p_lt > 0.0))
        return 0.0;
    double r = p_lt / p_cam;
    return isfinite(r) ? r : 0.0;
}

double spc_path_lt_view_camera_weight(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *h,
                                      spc_vec3 dlast, int k, const unsigned char *events, double w_base)
{
    if (!(w_base == 1.0) || k < 1 || k > SPC_PATH_LT_VIEW_MAX_CHAIN || !h->emitter ||
        h->emitter->type != SPC_EMITTER_AREA)
        return w_base;
    /* the camera's chain retraced from the light point toward the pinhole, its events reversed */
    unsigned char ev[SPC_PATH_LT_VIEW_MAX_CHAIN];
    for (int i = 0; i < k; ++i)
        ev[i] = events[k - 1 - i];
    spc_frame f = spc_frame_from_n(spc_neg(dlast));
    spc_chain_opts o = spc_chain_opts_default(k);
    o.events = ev;
    o.any_surface = p->any_surface;
    spc_chain cc;
    spc_chain_trace(ctx->scene, h, &f, 0.0, 0.0, &o, &cc);
    if (cc.n != k || cc.end == SPC_CHAIN_END_TIR || cc.end == SPC_CHAIN_END_MISMATCH ||
        cc.end == SPC_CHAIN_END_DEGENERATE)
        return w_base;
    double r = spc_path_lt_view_ratio(ctx, p, h->emitter, h->p, h->ng, &cc);
    return r > 0.0 ? 1.0 / (1.0 + r * r) : w_base;
}

/* The camera ray's weight of the path y - cc - pinhole without this strategy, as the path tracer
 * computes it at the light hit (path_snee.c): specular NEE from the pinhole's where its track from
 * the camera covers the path (params.camera), else 1. */
static double query_weight(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_emitter *e, spc_vec3 y,
                           spc_vec3 ny, const spc_chain *cc)
{
    spc_snee_params pp = *p;
    pp.mis = !pp.no_mis && !rough_mode(&pp);
    if (!pp.camera || rough_mode(&pp) || !spc_camera_connectible(ctx->cam))
        return 1.0;
    int budget = depth_left(ctx, 0, ctx->specular_max_chain);
    if (budget > pp.max_chain)
        budget = pp.max_chain;
    if (budget < 1)
        return 1.0;
    int long_budget = ctx->max_depth >= 0 ? ctx->max_depth - 1 : SPC_CHAIN_MAX_VERTICES;
    spc_snee_track t;
    spc_snee_track_begin(&t, &pp, budget, long_budget);
    int n = cc->n;
    for (int i = 0; i < n; ++i) {
        const spc_chain_vertex *v = &cc->v[n - 1 - i];
        unsigned lobe = v->event == SPC_CHAIN_REFLECT ? SPC_LOBE_DELTA_REFLECTION : SPC_LOBE_DELTA_TRANSMISSION;
        spc_snee_track_scatter_params(&t, &pp, &v->h, lobe, 0, depth_left(ctx, i + 1, SPC_CHAIN_MAX_VERTICES));
    }
    if (!spc_snee_track_covers(&t, ctx->scene, e))
        return 1.0;
    spc_hit lh;
    memset(&lh, 0, sizeof lh);
    lh.p = y;
    lh.ng = ny;
    lh.emitter = e;
    lh.shape = e->shape;
    double cam_scale = (double)ctx->cam->width * (double)ctx->cam->height / ((double)ctx->width * (double)ctx->height);
    return spc_snee_camera_bsdf_weight(ctx->scene, &pp, ctx->cam, cam_scale, spc_neg(cc->v[n - 1].d), t.max_chain, t.k,
                                       t.events, &lh);
}

void spc_path_lt_view_joins(const spc_render_ctx *ctx, const spc_snee_params *p, spc_rng *rng,
                            void (*sink)(void *user, const spc_path_lt_view_join *j), void *user)
{
    const spc_scene *sc = ctx->scene;
    double S = view_share(p);
    if (S < 1.0 && !(spc_rng_next(rng) < S))
        return;
    /* the light point as specular NEE draws it */
    spc_snee_params lp = *p;
    lp.light_u_on = true;
    lp.light_u[0] = spc_rng_next(rng);
    lp.light_u[1] = spc_rng_next(rng);
    lp.light_u[2] = spc_rng_next(rng);
    spc_snee_query q;
    memset(&q, 0, sizeof q);
    q.params = &lp;
    const spc_emitter *e = NULL;
    spc_vec2 uv;
    double p_y;
    if (!spc_snee_sample_light(sc, p->any_surface, rng, &q, &e, &uv, &p_y) || !e || e->type != SPC_EMITTER_AREA ||
        !e->shape || !(p_y > 0.0))
        return;
    spc_hit yh;
    memset(&yh, 0, sizeof yh);
    yh.p = q.y;
    yh.ng = q.ny;
    yh.sh.n = q.ny;
    yh.err = spc_max(q.y_err, 1e-9 * (spc_max_abs(q.y) + sc->radius));
    yh.shape = e->shape;
    yh.emitter = e;
    /* the chains through flat faces from y to the pinhole */
    spc_snee_query cq;
    spc_snee_query_init(&cq, sc, p, &yh, q.ny, SPC_PATH_LT_VIEW_MAX_CHAIN);
    cq.min_chain = 1;
    cq.y = ctx->cam->origin;
    cq.ny = spc_v3(0, 0, 0);
    cq.light_size = 0.0;
    spc_chain all[VIEW_CHAINS];
    /* where specular NEE from the pinhole runs, it weighs the chains its enumeration makes (no
     * reflection off glass, or one alone): only the others are solved */
    int n = spc_flat_chains_all_partial(&cq, p->camera, all, VIEW_CHAINS, NULL);
    double N = (double)ctx->width * (double)ctx->height;
    for (int i = 0; i < n; ++i) {
        const spc_chain *cc = &all[i];
        double r = spc_path_lt_view_ratio(ctx, p, e, q.y, q.ny, cc);
        if (!(r > 0.0) || !(query_weight(ctx, p, e, q.y, q.ny, cc) == 1.0))
            continue;
        const spc_chain_vertex *last = &cc->v[cc->n - 1];
        spc_camera_direct cd;
        if (!spc_camera_sample_direct(ctx->cam, last->h.p, &cd))
            continue;
        spc_vec3 nyo;
        spc_rgb Le = spc_snee_light_radiance(e, q.y, q.ny, uv, cc->v[0].h.p, spc_neg(cc->d0), &nyo);
        spc_rgb T = spc_rgb1(1.0);
        for (int v = 0; v < cc->n; ++v)
            T = spc_rgb_mul(T, spc_bsdf_specular_throughput(cc->v[v].h.bsdf, &cc->v[v].h, SPC_MODE_RADIANCE, cc->v[v].d,
                                                            spc_neg(cc->v[v].wi)));
        double G = spc_chain_geometry(cc, ctx->cam->origin, spc_neg(last->d));
        double g = spc_absdot(cc->d0, q.ny) * G * cd.We / N / (S * p_y);
        spc_rgb C = spc_rgb_scale(spc_rgb_mul(Le, T), g);
        if (spc_rgb_is_black(C) || !isfinite(g))
            continue;
        spc_ray sr = spc_hit_spawn_to(&last->h, cd.p_near, 0.0);
        if (spc_scene_occluded(sc, &sr))
            continue;
        spc_path_lt_view_join j = {cd.fx, cd.fy, C, r, spc_path_lt_weight(r), cc, e, q.y, q.ny};
        sink(user, &j);
    }
}

typedef struct splat_sink {
    const spc_render_ctx *ctx;
    spc_tls *tls;
} splat_sink;

static void splat_join(void *user, const spc_path_lt_view_join *j)
{
    const splat_sink *s = user;
    spc_splat_add(s->ctx, s->tls, j->fx, j->fy, spc_rgb_scale(j->C, j->w));
}

void spc_path_lt_view_trace(const spc_render_ctx *ctx, const spc_snee_params *p, spc_tls *tls, spc_rng *rng)
{
    splat_sink s = {ctx, tls};
    spc_path_lt_view_joins(ctx, p, rng, splat_join, &s);
}
