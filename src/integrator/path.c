/*
 * integrator/path.c: unidirectional path tracing, in two modes.
 *
 * - path: next-event estimation (one light chosen in proportion to power, one point on it) and
 *   BSDF sampling, combined by multiple importance sampling with the power heuristic (Veach 1997,
 *   ch. 9). Emitters hit by BSDF sampling are weighted against the NEE density of the same point
 *   (solid angle: light pmf times spc_emitter_pdf_direct / pdf_infinite).
 * - ipt: the implicit path tracer of the lecture note (shared/papers 001): no NEE; a path counts
 *   emission only when it hits an emitter. Unbiased with Russian roulette; our ground truth.
 *
 * Specular NEE (ctx->specular_nee, src/manifold/specular_nee.h): at every vertex with a non-delta
 * lobe, one more light sample connected through chains of 1..specular_max_chain specular vertices
 * by the chosen solver. The paths it covers (receiver -> non-delta sample -> k caster vertices with
 * the solver's events -> area emitter, k within the budget; exact condition in specular_nee.h) are
 * weighted against specular NEE's light sample by the power heuristic when BSDF sampling reaches
 * them (spc_snee_params.mis, spc_snee_mis_bsdf_weight: the chain retraced from the receiver for its
 * geometry term), so nothing is counted twice; every other path keeps its usual weight. With rough chain vertices (newton's "rough" option) the covered
 * paths may also end with the light sample taken at a rough vertex: that sample is dropped too
 * (spc_snee_track_covers_light), as is the emitter it would be weighted against by MIS.
 *
 * Throughput with Russian roulette: after rr_depth segments a path survives with probability
 * q = min(0.95, max(beta) * eta_scale^2), where eta_scale undoes the radiance scaling of
 * refraction so that paths inside glass are not killed for it (pbrt-v4).
 */
#include <string.h>

#include "integrator/integrator.h"
#include "manifold/specular_nee.h"

static bool depth_allows(int max_depth, int segments) { return max_depth < 0 || segments <= max_depth; }

/* Film positions the driver takes camera samples at (the rendered window). */
static bool in_window(const spc_render_ctx *ctx, double fx, double fy)
{
    return fx >= ctx->crop_x && fx < ctx->crop_x + ctx->width && fy >= ctx->crop_y && fy < ctx->crop_y + ctx->height;
}

void spc_path_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray0, spc_sampler *smp,
                     spc_sample_out *out)
{
    const spc_scene *sc = ctx->scene;
    const bool nee = ctx->kind == SPC_INTEGRATOR_PATH;
    spc_rgb L = spc_rgb1(0.0), beta = spc_rgb1(1.0);
    spc_ray ray = *ray0;
    bool specular = true; /* the last scattering was a delta lobe (or it is the camera) */
    double prev_pdf = 1.0, eta_scale = 1.0;
    spc_vec3 prev_p = ray.o;
    /* ---- specular NEE state ---- */
    const bool snee = nee && ctx->specular_nee != SPC_SNEE_NONE;
    spc_snee_params snp = {0};
    spc_snee_track track = {0};
    spc_hit mis_x;      /* the receiver the track started at, with its wo and sampled direction */
    spc_vec3 mis_wo = spc_v3(0, 0, 1), mis_d0 = spc_v3(0, 0, 1);
    memset(&mis_x, 0, sizeof mis_x);
    if (snee) {
        snp = ctx->snee;
        snp.mis = !snp.no_mis && !(snp.solver == SPC_SNEE_NEWTON && snp.newton.rough);
    }
    out->albedo = spc_rgb1(0.0);
    out->normal = spc_v3(0, 0, 0);
    out->depth = 0.0;
    /* specular NEE from the camera (spc_snee_params.camera): its splats, and the camera ray tracked
     * from the pinhole as from a receiver (cam_track) until its first non-delta scattering */
    bool cam_track = false;
    const double cam_scale = (double)ctx->cam->width * (double)ctx->cam->height /
                             ((double)ctx->width * (double)ctx->height);
    if (snee && snp.camera && !(snp.solver == SPC_SNEE_NEWTON && snp.newton.rough) &&
        spc_camera_connectible(ctx->cam)) {
        int budget = ctx->specular_max_chain; /* k vertices: k + 1 segments */
        if (ctx->max_depth >= 0 && ctx->max_depth - 1 < budget)
            budget = ctx->max_depth - 1;
        if (budget > snp.max_chain)
            budget = snp.max_chain;
        if (budget >= 1) {
            spc_rng rng;
            spc_rng_seed(&rng, spc_hash_combine(smp->pixel_seed, ((uint64_t)smp->index << 32) | smp->dim), 0);
            spc_snee_splat sp[SPC_SNEE_CAMERA_SPLATS];
            int long_budget = ctx->max_depth >= 0 ? ctx->max_depth - 1 : SPC_CHAIN_MAX_VERTICES;
            int n = spc_snee_camera(sc, &snp, ctx->cam, cam_scale, budget, long_budget, &rng, NULL, sp,
                                    SPC_SNEE_CAMERA_SPLATS);
            for (int i = 0; i < n; ++i)
                if (in_window(ctx, sp[i].fx, sp[i].fy))
                    spc_splat_add(ctx, tls, sp[i].fx, sp[i].fy, sp[i].value);
            track.live = true;
            track.k = 0;
            track.max_chain = budget;
            track.single_ok = track.multi_ok = true;
            track.any_surface = snp.any_surface;
            track.reflect = snp.reflect;
            track.long_max = spc_snee_track_long_max(&snp, long_budget);
            cam_track = true;
        }
    }

    int receivers = 0; /* non-delta vertices so far (spc_snee_params.receivers) */
    for (int segments = 1;; ++segments) {
        /* segments: the number of path segments once this ray is traced */
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h)) {
            if (sc->env && !(segments == 1 && ctx->hide_emitters)) {
                spc_rgb Le = spc_emitter_eval_infinite(sc->env, ray.d);
                double w = 1.0;
                if (nee && !specular) {
                    double lp = spc_scene_emitter_pmf(sc, sc->env) * spc_emitter_pdf_infinite(sc->env, ray.d);
                    w = spc_mis_power(prev_pdf, lp);
                }
                L = spc_rgb_add(L, spc_rgb_scale(spc_rgb_mul(beta, Le), w));
            }
            break;
        }
        spc_vec3 wo = spc_neg(ray.d);
        if (segments == 1 && out->aovs)
            spc_aov_from_hit(ctx, &h, wo, smp, out);
        /* specular NEE hook: an emitter hit through a chain it covers (see above) */
        bool covered = snee && spc_snee_track_covers(&track, sc, h.emitter);
        if (h.emitter && !(segments == 1 && ctx->hide_emitters)) {
            spc_rgb Le = spc_emitter_eval_area(h.emitter, &h, wo);
            /* a covered path: weighted against specular NEE's light sample, or dropped */
            double w = 1.0;
            if (covered && !spc_rgb_is_black(Le))
                w = cam_track ? spc_snee_camera_bsdf_weight(sc, &snp, ctx->cam, cam_scale, ray0->d, track.max_chain,
                                                            track.k, track.events, &h)
                              : spc_snee_mis_bsdf_weight(sc, &snp, &mis_x, mis_wo, mis_d0, track.max_chain, track.k,
                                                         track.events, &h);
            if (w > 0.0 && !spc_rgb_is_black(Le)) {
                if (nee && !specular) {
                    double lp = spc_scene_emitter_pmf(sc, h.emitter) *
                                spc_emitter_pdf_direct(h.emitter, prev_p, h.p, h.ng);
                    w = spc_mis_power(prev_pdf, lp);
                }
                L = spc_rgb_add(L, spc_rgb_scale(spc_rgb_mul(beta, Le), w));
            }
        }
        /* every continuation adds at least one segment */
        if (!depth_allows(ctx->max_depth, segments + 1))
            break;
        /* strict normals (Mitsuba 0.6): arriving on the other side of the shading normal than of
         * the geometric one ends the path */
        if (ctx->strict_normals && spc_dot(wo, h.ng) * spc_dot(wo, h.sh.n) < 0.0)
            break;
        const spc_bsdf *b = h.bsdf;

        /* next-event estimation (always draw the same dimensions, so streams stay aligned) */
        double u_light = spc_sampler_1d(smp);
        spc_vec2 u_lpos = spc_sampler_2d(smp);
        if (nee && spc_bsdf_has_smooth(b)) {
            double pmf;
            const spc_emitter *e = spc_scene_sample_emitter(sc, u_light, &pmf);
            spc_emitter_direct ds;
            if (e && spc_emitter_sample_direct(e, h.p, u_lpos, &ds)) {
                spc_rgb f = spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, ds.wi);
                double cosi = spc_absdot(ds.wi, h.sh.n);
                if (ctx->strict_normals && !(spc_dot(ds.wi, h.ng) * spc_dot(ds.wi, h.sh.n) > 0.0))
                    cosi = 0.0;
                if (!spc_rgb_is_black(f) && cosi > 0.0) {
                    spc_ray sr = ds.is_infinite ? spc_hit_spawn(&h, ds.wi) : spc_hit_spawn_to(&h, ds.p, ds.err);
                    /* with rough chain vertices, specular NEE may have counted this path already */
                    bool snee_has = snee && spc_snee_track_covers_light(&track, &snp, sc, &h, wo, ds.wi, e);
                    if (!snee_has && !spc_scene_occluded(sc, &sr)) {
                        double lp = pmf * ds.pdf;
                        double w = ds.is_delta ? 1.0
                                               : spc_mis_power(lp, spc_bsdf_pdf(b, &h, SPC_MODE_RADIANCE, wo, ds.wi));
                        spc_rgb c = spc_rgb_mul(spc_rgb_mul(beta, f), ds.L);
                        L = spc_rgb_add(L, spc_rgb_scale(c, cosi * w / lp));
                    }
                }
            }
        }

        /* specular NEE hook: chains of at most the budget, within max_depth */
        int snee_budget = 0;
        /* the longer chains' bound (spc_snee_params.long_p): the depth left */
        int long_budget = SPC_CHAIN_MAX_VERTICES;
        if (ctx->max_depth >= 0 && ctx->max_depth - segments - 1 < long_budget)
            long_budget = ctx->max_depth - segments - 1;
        if (snee) {
            int budget = ctx->specular_max_chain;
            if (ctx->max_depth >= 0 && ctx->max_depth - segments - 1 < budget)
                budget = ctx->max_depth - segments - 1;
            snee_budget = spc_snee_budget_params(&snp, &h, budget);
            if (snp.receivers > 0 && receivers >= snp.receivers)
                snee_budget = 0; /* past the vertices specular NEE runs at */
            if (snee_budget > 0) {
                /* spc_snee_params.later_p: past the first receiver, the query by Russian roulette;
                 * a covered BSDF path's MIS weight reads the same query_p (a vertex with a smooth
                 * lobe is no chain vertex: a live track started at the last such vertex) */
                snp.query_p = receivers > 0 ? snp.later_p : 1.0;
                /* its own deterministic stream: the sampler's dimensions stay as without it */
                spc_rng rng;
                spc_rng_seed(&rng, spc_hash_combine(smp->pixel_seed, ((uint64_t)smp->index << 32) | smp->dim),
                             (uint64_t)segments);
                spc_rgb c = spc_specular_nee_depth(sc, &snp, &h, wo, snee_budget, long_budget, &rng, NULL);
                L = spc_rgb_add(L, spc_rgb_mul(beta, c));
            }
        }

        /* BSDF sampling */
        double u_lobe = spc_sampler_1d(smp);
        spc_vec2 u_dir = spc_sampler_2d(smp);
        double u_rr = spc_sampler_1d(smp);
        spc_bsdf_sample bs;
        if (!spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, u_lobe, u_dir, &bs))
            break;
        if (ctx->strict_normals && !(spc_dot(bs.wi, h.ng) * spc_dot(bs.wi, h.sh.n) > 0.0))
            break;
        if (snee) {
            spc_snee_track_scatter_params(&track, &snp, &h, bs.lobe, snee_budget, long_budget);
            if (snp.mis && !(bs.lobe & SPC_LOBE_DELTA) && snee_budget > 0) {
                mis_x = h;
                mis_wo = wo;
                mis_d0 = bs.wi;
            }
        }
        if (!(bs.lobe & SPC_LOBE_DELTA)) {
            ++receivers;
            cam_track = false;
        }
        beta = spc_rgb_mul(beta, bs.weight);
        if (spc_rgb_is_black(beta))
            break;
        specular = (bs.lobe & SPC_LOBE_DELTA) != 0;
        prev_pdf = bs.pdf;
        prev_p = h.p;
        if (bs.lobe & (SPC_LOBE_DELTA_TRANSMISSION | SPC_LOBE_GLOSSY_TRANSMISSION | SPC_LOBE_DIFFUSE_TRANSMISSION))
            eta_scale *= bs.eta * bs.eta;
        ray = spc_hit_spawn(&h, bs.wi);

        if (segments >= ctx->rr_depth) {
            double q = spc_min(0.95, spc_rgb_max(beta) * eta_scale);
            if (!(u_rr < q))
                break;
            beta = spc_rgb_scale(beta, 1.0 / q);
        }
    }
    out->L = L;
}
