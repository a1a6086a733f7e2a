/*
 * integrator/path_camsplit.c: the camera-side split of the light seen through glass
 * (path_camsplit.h): extra camera rays in the pixel that follow delta scatterings only.
 */
#include "integrator/path_camsplit.h"

#include "integrator/path_snee.h"
#include "scene/rfilter.h"

static bool depth_allows(int max_depth, int segments) { return max_depth < 0 || segments <= max_depth; }

bool spc_path_camsplit_enabled(const spc_render_ctx *ctx)
{
    const spc_snee_params *p = &ctx->snee;
    return ctx->kind == SPC_INTEGRATOR_PATH && ctx->specular_nee != SPC_SNEE_NONE && p->cam_split &&
           p->cam_split_rays >= 1 && !(p->recv_guide > 0.0);
}

bool spc_path_camsplit_first(const spc_hit *h) { return h->bsdf && spc_bsdf_is_delta_only(h->bsdf); }

/* Class C's terms of the camera path that starts with ray0, whose first hit h0 is delta-only
 * glass, and with recv (params.cam_split_recv) class D's: path.c's loop restricted to delta-only
 * vertices, with recv one sample of the first receiver x's BSDF and the delta-only vertices after
 * it (the same depth, strict normals and Russian roulette rules), its lobe choices, directions and
 * roulette drawn from rng. */
static spc_rgb trace_view(const spc_render_ctx *ctx, const spc_ray *ray0, const spc_hit *h0, bool recv, spc_rng *rng)
{
    const spc_scene *sc = ctx->scene;
    spc_path_snee sn;
    spc_path_snee_begin_view(&sn, ctx, ray0);
    spc_rgb L = spc_rgb1(0.0), beta = spc_rgb1(1.0);
    double eta_scale = 1.0;
    spc_ray ray = *ray0;
    spc_hit h = *h0;
    /* past x (the first vertex that is not delta only), and the delta-only vertices since */
    bool past_x = false;
    int before = 0, after = 0;
    const int min_len = ctx->snee.cam_split_recv_min;
    for (int segments = 1;; ++segments) {
        if (segments > 1) {
            /* class C before x; class D past x once a delta-only vertex came between, on paths of
             * at least min_len delta vertices */
            const bool counts = !past_x || (after >= 1 && before + after >= min_len);
            if (!spc_scene_intersect(sc, &ray, &h)) {
                /* after a delta vertex the environment's weight is 1, as in spc_path_sample */
                if (sc->env && counts)
                    L = spc_rgb_add(L, spc_rgb_mul(beta, spc_emitter_eval_infinite(sc->env, ray.d)));
                break;
            }
            if (h.emitter && counts) {
                spc_rgb Le = spc_emitter_eval_area(h.emitter, &h, spc_neg(ray.d));
                if (!spc_rgb_is_black(Le)) {
                    double w = spc_path_snee_emitter_weight(&sn, ctx, &h);
                    if (w > 0.0)
                        L = spc_rgb_add(L, spc_rgb_scale(spc_rgb_mul(beta, Le), w));
                }
            }
        }
        spc_vec3 wo = spc_neg(ray.d);
        if (!depth_allows(ctx->max_depth, segments + 1))
            break;
        if (ctx->strict_normals && spc_dot(wo, h.ng) * spc_dot(wo, h.sh.n) < 0.0)
            break;
        if (spc_path_camsplit_first(&h)) {
            if (past_x)
                ++after;
            else
                ++before;
            spc_path_snee_delta_vertex(&sn, ctx, segments);
        } else if (recv && !past_x) {
            /* x: its state as the camera path's (no query), then one sample of its BSDF */
            past_x = true;
            spc_path_snee_receiver_view(&sn, ctx, &h, segments);
        } else {
            break; /* the classes end at the first vertex that is not delta only (recv: the second) */
        }
        double u_lobe = spc_rng_next(rng);
        spc_vec2 u_dir;
        u_dir.x = spc_rng_next(rng);
        u_dir.y = spc_rng_next(rng);
        spc_bsdf_sample bs;
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, wo, u_lobe, u_dir, &bs))
            break;
        if (ctx->strict_normals && !(spc_dot(bs.wi, h.ng) * spc_dot(bs.wi, h.sh.n) > 0.0))
            break;
        spc_path_snee_scattered(&sn, &h, wo, bs.wi, bs.lobe);
        beta = spc_rgb_mul(beta, bs.weight);
        if (spc_rgb_is_black(beta))
            break;
        if (bs.lobe & (SPC_LOBE_DELTA_TRANSMISSION | SPC_LOBE_GLOSSY_TRANSMISSION | SPC_LOBE_DIFFUSE_TRANSMISSION))
            eta_scale *= bs.eta * bs.eta;
        ray = spc_hit_spawn(&h, bs.wi);
        if (segments >= ctx->rr_depth) {
            double q = spc_min(0.95, spc_rgb_max(beta) * eta_scale);
            if (!(spc_rng_next(rng) < q))
                break;
            beta = spc_rgb_scale(beta, 1.0 / q);
        }
    }
    return L;
}

bool spc_path_camsplit_recv(const spc_render_ctx *ctx)
{
    return spc_path_camsplit_enabled(ctx) && ctx->snee.cam_split_recv;
}

int spc_path_camsplit_rays(const spc_render_ctx *ctx, const spc_tls *tls, const spc_sampler *smp, spc_rgb *sum)
{
    const int K = ctx->snee.cam_split_rays;
    spc_rng rng;
    spc_sampler_fork_rng(smp, SPC_PATH_CAMSPLIT_STREAM, &rng);
    const double cx = tls->px + 0.5, cy = tls->py + 0.5;
    const bool recv = spc_path_camsplit_recv(ctx);
    int kept = 0;
    for (int t = 0; t < SPC_PATH_CAMSPLIT_TRIALS * K && kept < K; ++t) {
        /* a film position in the pixel as the driver draws the camera sample's (camera_samples_tile) */
        double ux = spc_rng_next(&rng), uy = spc_rng_next(&rng);
        double fx = cx + spc_film_filter_sample(ctx->film, ux, cx, ctx->crop_x, ctx->crop_x + ctx->width);
        double fy = cy + spc_film_filter_sample(ctx->film, uy, cy, ctx->crop_y, ctx->crop_y + ctx->height);
        spc_ray ray;
        if (spc_camera_has_lens(ctx->cam)) {
            spc_vec2 ul;
            ul.x = spc_rng_next(&rng);
            ul.y = spc_rng_next(&rng);
            ray = spc_camera_ray_lens(ctx->cam, fx, fy, ul);
        } else {
            ray = spc_camera_ray(ctx->cam, fx, fy);
        }
        spc_hit h;
        if (!spc_scene_intersect(ctx->scene, &ray, &h) || !spc_path_camsplit_first(&h))
            continue;
        ++kept;
        spc_rgb c = trace_view(ctx, &ray, &h, recv, &rng);
        *sum = spc_rgb_add(*sum, c);
    }
    return kept;
}
