/*
 * integrator/path_deep.c: more directions from the BSDF at a path's receivers past the first
 * (path_deep.h): the draws, each followed through delta-only vertices to an area light with the
 * path's own MIS weight, and the path's record of its own sample of that class.
 */
#include "integrator/path_deep.h"

#include "bsdf/bsdf.h"
#include "emitter/emitter.h"
#include "scene/scene.h"

static bool depth_allows(const spc_render_ctx *ctx, int segments)
{
    return ctx->max_depth < 0 || segments <= ctx->max_depth;
}

bool spc_path_deep_at(const spc_path_snee *sn, const spc_hit *h)
{
    return sn->on && sn->p.bsdf_n > 1.0 && h->bsdf && spc_bsdf_has_smooth(h->bsdf);
}

/* One extra direction's light: x's BSDF sampled with the stream rng, then delta-only vertices as
 * spc_path_sample follows them (its depth and strict-normal tests), the state s carried as the
 * path carries it; an area light after 1 to SPC_CHAIN_MAX_VERTICES of them is counted with its
 * weight. */
static spc_rgb one_direction(const spc_render_ctx *ctx, const spc_path_snee *sn, const spc_hit *x, spc_vec3 wo,
                             int segments, spc_rng *rng)
{
    const spc_scene *sc = ctx->scene;
    spc_bsdf_sample bs;
    double u_lobe = spc_rng_next(rng);
    spc_vec2 u_dir = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    if (!spc_bsdf_sample_dir(x->bsdf, x, SPC_MODE_RADIANCE, wo, u_lobe, u_dir, &bs) || (bs.lobe & SPC_LOBE_DELTA))
        return spc_rgb1(0.0);
    if (ctx->strict_normals && !(spc_dot(bs.wi, x->ng) * spc_dot(bs.wi, x->sh.n) > 0.0))
        return spc_rgb1(0.0);
    spc_rgb t = bs.weight;
    if (spc_rgb_is_black(t))
        return spc_rgb1(0.0);
    spc_path_snee s = *sn;
    spc_path_snee_scattered(&s, x, wo, bs.wi, bs.lobe);
    spc_ray ray = spc_hit_spawn(x, bs.wi);
    /* seg: the path's segments once ray is traced; k: the delta-only vertices passed */
    for (int seg = segments + 1, k = 0;; ++seg, ++k) {
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h))
            return spc_rgb1(0.0);
        spc_vec3 wh = spc_neg(ray.d);
        if (h.emitter) {
            if (k < 1)
                return spc_rgb1(0.0); /* the light seen directly: the path's own, with light sampling */
            spc_rgb Le = spc_emitter_eval_area(h.emitter, &h, wh);
            if (spc_rgb_is_black(Le))
                return Le;
            double w = spc_path_snee_emitter_weight(&s, ctx, &h);
            return w > 0.0 ? spc_rgb_scale(spc_rgb_mul(t, Le), w) : spc_rgb1(0.0);
        }
        if (k >= SPC_CHAIN_MAX_VERTICES || !depth_allows(ctx, seg + 1) || !h.bsdf ||
            !spc_bsdf_is_delta_only(h.bsdf))
            return spc_rgb1(0.0);
        if (ctx->strict_normals && spc_dot(wh, h.ng) * spc_dot(wh, h.sh.n) < 0.0)
            return spc_rgb1(0.0);
        spc_path_snee_receiver_view(&s, ctx, &h, seg);
        u_lobe = spc_rng_next(rng);
        u_dir = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, wh, u_lobe, u_dir, &bs))
            return spc_rgb1(0.0);
        if (ctx->strict_normals && !(spc_dot(bs.wi, h.ng) * spc_dot(bs.wi, h.sh.n) > 0.0))
            return spc_rgb1(0.0);
        spc_path_snee_scattered(&s, &h, wh, bs.wi, bs.lobe);
        t = spc_rgb_mul(t, bs.weight);
        if (spc_rgb_is_black(t))
            return t;
        ray = spc_hit_spawn(&h, bs.wi);
    }
}

spc_rgb spc_path_deep_estimate(const spc_render_ctx *ctx, const spc_path_snee *sn, const spc_hit *h, spc_vec3 wo,
                               int segments, const spc_sampler *smp)
{
    const int m = (int)sn->p.bsdf_n - 1;
    spc_rng rng;
    spc_sampler_fork_rng(smp, SPC_PATH_DEEP_STREAM, &rng);
    spc_rgb sum = spc_rgb1(0.0);
    for (int i = 0; i < m; ++i)
        sum = spc_rgb_add(sum, one_direction(ctx, sn, h, wo, segments, &rng));
    return spc_rgb_scale(sum, 1.0 / (m + 1));
}

void spc_path_deep_scattered(spc_path_deep_track *t, const spc_path_snee *sn, const spc_hit *h, unsigned lobe,
                             bool drawn)
{
    if (drawn && !(lobe & SPC_LOBE_DELTA)) {
        t->scale = 1.0 / sn->p.bsdf_n;
        t->k = 0;
    } else if (t->scale != 1.0 && (lobe & SPC_LOBE_DELTA) && h->bsdf && spc_bsdf_is_delta_only(h->bsdf)) {
        ++t->k;
    } else {
        t->scale = 1.0;
        t->k = 0;
    }
}
