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
 * Emission splitting (split_emission): with specular NEE on, at a smooth dielectric reached through
 * delta vertices only from the camera, the reflected ray is traced on every sample and its emitter
 * hit counted with the reflection's factor F; the sampled path drops its own emission after a
 * reflection chosen there. path_wave.c runs only with specular NEE off, so it has no such step.
 *
 * The camera-side split (params.cam_split, path_camsplit.h): where the camera ray's first hit is a
 * delta-only surface, extra camera rays in the pixel that also meet such a surface first take the
 * emission reached through delta scatterings only (class C); the sample counts the mean of theirs
 * and its own (cs_scale on its class C terms); with "camrecv" also of class D, the emission
 * reached past the first receiver behind the glass through delta scatterings. Draws no sampler
 * dimension.
 *
 * Caustic guiding at receivers (params.recv_guide, manifold/caustic_guide.h): where the render's
 * photon pre-pass found caustics a vertex sees, its continuation is drawn from a defensive mixture
 * of directions toward them and the BSDF's sample (spc_cguide_sample_mix), and the mixture's
 * density replaces the BSDF's in the throughput and in every MIS weight of that bounce (light NEE,
 * the emitter hit, specular NEE through path_snee's receiver).
 *
 * Grazing directions along a mirror cylinder's wall (ctx->graze, path_graze.h): at a receiver near
 * the foot of a circular mirror cylinder's wall, one more direction is drawn nearly along the wall
 * and followed through the wall's reflections; a path that creeps along the wall to an area light
 * through 9 to 64 reflections (past every chain specular NEE makes) is weighted against BSDF
 * sampling's by the power heuristic on both sides. Draws no sampler dimension.
 *
 * Throughput with Russian roulette: after rr_depth segments a path survives with probability
 * q = min(0.95, max(beta) * eta_scale^2 * guide_scale), where eta_scale undoes the radiance scaling
 * of refraction so that paths inside glass are not killed for it (pbrt-v4), and guide_scale undoes
 * the caustic guide's reweighting (the product of mixture / BSDF density over the guided bounces):
 * a path the guide sent toward a caustic carries a small beta because the guide draws such
 * directions often, not because it carries little light, so the roulette reads the throughput BSDF
 * sampling would have given it. Otherwise the roulette kills most guided paths and scales the
 * survivors' beta back up, and the caustic each survivor reaches (specular NEE near the caster, or
 * the light hit through it) is counted at a throughput near 1: the guide's samples come back as
 * the rare, bright ones it was built to avoid. Any q that depends only on the path so far keeps
 * the estimate unbiased.
 */
#include "integrator/path.h"

#include <math.h>

#include "integrator/aov.h"
#include "integrator/path_camsplit.h"
#include "integrator/path_deep.h"
#include "integrator/path_graze.h"
#include "integrator/path_snee.h"

static bool depth_allows(int max_depth, int segments) { return max_depth < 0 || segments <= max_depth; }

/* The factor by which the guided mixture at gv changed the throughput of the sample bs drawn at h:
 * the mixture's density of bs.wi over the BSDF's own; for a delta lobe, which the mixture picks
 * with probability 1 - a times the BSDF's, 1 - a. 1 where no guide ran or the BSDF's density is
 * not positive. */
static double guide_rr_factor(const spc_cguide_vertex *gv, const spc_hit *h, spc_vec3 wo, const spc_bsdf_sample *bs)
{
    if (!gv || !(gv->a > 0.0))
        return 1.0;
    if (bs->lobe & SPC_LOBE_DELTA)
        return 1.0 - gv->a;
    double pdf_bsdf = spc_bsdf_pdf(h->bsdf, h, SPC_MODE_RADIANCE, wo, bs->wi);
    return pdf_bsdf > 0.0 && isfinite(bs->pdf) ? bs->pdf / pdf_bsdf : 1.0;
}

/* Emission splitting at a smooth dielectric seen through delta vertices only.
 *
 * At such a vertex h BSDF sampling picks the reflection with probability F (the Fresnel term), so a
 * light seen in the reflection (a glint on water, seen from the camera) is found by a few samples
 * in a hundred, each counting it 1/F times: with a small bright light, one pixel of a seed. Here
 * every sample traces the reflected ray and counts the emitter it hits with the reflection's factor
 * f = F * specular_reflectance (its sample weight times its probability) and the emitter hit's
 * usual weights; the sampled path then drops its own emission at the hit after a reflection chosen
 * at h (and nothing else: its later vertices, light samples and specular NEE stay as they were).
 * Unbiased: the dropped term's expectation over the lobe choice is F * (beta f / F Le w) = beta f
 * Le w, which is exactly the split term, counted with probability 1; both use the same MIS weight
 * of the emitter hit (the same path, same strategies), so the weights of every path still sum to
 * one. Only where specular NEE runs (its camera track gives the weight) and at vertices whose only
 * lobes are one delta reflection and one delta transmission (dielectric, thindielectric, under a
 * twosided or normalmap), chosen by u_lobe below the reflection's probability: u_lobe = 0 yields
 * the reflection wherever F > 0. Draws no sampler dimension, so the streams stay as they are. */
static bool splits_emission(const spc_bsdf *b)
{
    return spc_bsdf_flags(b) == (SPC_LOBE_DELTA_REFLECTION | SPC_LOBE_DELTA_TRANSMISSION);
}

/* The reflection both splits at a smooth dielectric h trace: its sample bs (the delta reflection
 * lobe, chosen at the lobe's own point so no sampler dimension is used), its factor f = F *
 * specular reflectance and the ray r leaving h. False where the reflection is not taken: another
 * lobe, a direction strict normals reject, or a black factor. */
static bool split_reflection(const spc_render_ctx *ctx, const spc_hit *h, spc_vec3 wo, spc_bsdf_sample *bs,
                             spc_rgb *f, spc_ray *r)
{
    if (!spc_bsdf_sample_dir(h->bsdf, h, SPC_MODE_RADIANCE, wo, 0.0, spc_v2(0.5, 0.5), bs) ||
        bs->lobe != SPC_LOBE_DELTA_REFLECTION)
        return false;
    if (ctx->strict_normals && !(spc_dot(bs->wi, h->ng) * spc_dot(bs->wi, h->sh.n) > 0.0))
        return false;
    *f = spc_rgb_scale(bs->weight, bs->pdf);
    if (spc_rgb_is_black(*f))
        return false;
    *r = spc_hit_spawn(h, bs->wi);
    return true;
}

/* The split term at h (wo toward the previous vertex; sn the specular NEE state before h's
 * scattering), to be multiplied by the throughput that reached h. */
static spc_rgb split_emission(const spc_render_ctx *ctx, const spc_path_snee *sn, const spc_hit *h, spc_vec3 wo)
{
    const spc_scene *sc = ctx->scene;
    spc_bsdf_sample bs;
    spc_rgb f;
    spc_ray ray;
    if (!split_reflection(ctx, h, wo, &bs, &f, &ray))
        return spc_rgb1(0.0);
    spc_hit hr;
    if (!spc_scene_intersect(sc, &ray, &hr)) {
        /* after a delta vertex the environment's weight is 1, as in spc_path_sample */
        if (!sc->env)
            return spc_rgb1(0.0);
        return spc_rgb_mul(f, spc_emitter_eval_infinite(sc->env, ray.d));
    }
    if (!hr.emitter)
        return spc_rgb1(0.0);
    spc_rgb Le = spc_emitter_eval_area(hr.emitter, &hr, spc_neg(ray.d));
    if (spc_rgb_is_black(Le))
        return spc_rgb1(0.0);
    spc_path_snee snr = *sn;
    spc_path_snee_scattered(&snr, h, wo, bs.wi, bs.lobe);
    double w = spc_path_snee_emitter_weight(&snr, ctx, &hr);
    return spc_rgb_scale(spc_rgb_mul(f, Le), w);
}

/* Specular NEE splitting at the same vertices as split_emission where the glass is a triangle mesh
 * (spc_path_snee_splits): at a smooth dielectric h seen from the camera through delta vertices
 * only, the reflected ray is traced and specular NEE made at the receiver it hits (hr) with the
 * reflection's factor f = F * specular_reflectance, on every sample where F is large and by
 * roulette (probability p, counted 1/p) where it is small (spc_path_snee_split_prob); the sampled
 * path skips its own query at that receiver after a reflection chosen at h
 * (spc_path_snee.skip_query), and nothing else. Without it a caustic seen in the glass
 * (the floor's caustic of a tessellated glass ball, reflected in the ball) is reached by a few
 * samples in a hundred, each counting its full brightness: on random caustic scenes those samples
 * held most of a seed's error (bench/RESULTS.md, part tails30). Unbiased as split_emission is: the
 * skipped term's expectation over the lobe choice is F times the query's at hr, which the split
 * adds with probability p, counted 1/p (the roulette's uniform from a fork of the sampler, apart
 * from the lobe choice and the query), and the query at hr is the same estimator either way (the state the
 * path would carry there, spc_path_snee_scattered's, and the sampler's dimensions that the path's
 * next vertex would draw its query from: the three pairs of BSDF sampling at h, the two of light
 * sampling at hr), so the MIS weights of the paths it covers stay as they are. sn: the specular
 * NEE state before h's scattering; segments: the path's segments up to h. The result is to be
 * multiplied by the throughput that reached h. */
static spc_rgb split_snee(const spc_render_ctx *ctx, const spc_path_snee *sn, const spc_hit *h, spc_vec3 wo,
                          int segments, const spc_sampler *smp)
{
    const spc_scene *sc = ctx->scene;
    /* the receiver's query runs where the path's next vertex could run it */
    if (!depth_allows(ctx->max_depth, segments + 2))
        return spc_rgb1(0.0);
    spc_bsdf_sample bs;
    spc_rgb f;
    spc_ray ray;
    if (!split_reflection(ctx, h, wo, &bs, &f, &ray))
        return spc_rgb1(0.0);
    /* by roulette where the reflection is unlikely (spc_path_snee_split_prob): its own stream, so
     * that the sampler's dimensions stay as they are */
    double p = spc_path_snee_split_prob(sn, h, bs.pdf);
    if (p < 1.0) {
        spc_rng rng;
        spc_sampler_fork_rng(smp, SPC_PATH_SPLIT_STREAM, &rng);
        if (!(spc_rng_next(&rng) < p))
            return spc_rgb1(0.0);
        f = spc_rgb_scale(f, 1.0 / p);
    }
    spc_hit hr;
    if (!spc_scene_intersect(sc, &ray, &hr))
        return spc_rgb1(0.0);
    spc_vec3 wr = spc_neg(ray.d);
    if (ctx->strict_normals && spc_dot(wr, hr.ng) * spc_dot(wr, hr.sh.n) < 0.0)
        return spc_rgb1(0.0);
    spc_path_snee snr = *sn;
    spc_path_snee_scattered(&snr, h, wo, bs.wi, bs.lobe);
    spc_path_snee_guide_at(&snr, &hr, wr);
    spc_sampler sr = *smp;
    spc_sampler_skip(&sr, 5);
    spc_rgb c = spc_path_snee_at_vertex(&snr, ctx, &hr, wr, segments + 1, &sr);
    return spc_rgb_is_black(c) ? c : spc_rgb_mul(f, c);
}

void spc_path_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray0, spc_sampler *smp,
                     spc_sample_out *out)
{
    const spc_scene *sc = ctx->scene;
    const bool nee = ctx->kind == SPC_INTEGRATOR_PATH;
    spc_rgb L = spc_rgb1(0.0), beta = spc_rgb1(1.0);
    spc_ray ray = *ray0;
    bool specular = true;       /* the last scattering was a delta lobe (or it is the camera) */
    bool all_delta = true;      /* every scattering so far was a delta lobe */
    bool drop_emission = false; /* the emission at the next hit was counted by splitting */
    double prev_pdf = 1.0, eta_scale = 1.0;
    double guide_scale = 1.0; /* beta * guide_scale: the throughput without the guide's reweighting */
    /* the camera-side split (path_camsplit.h): while every vertex so far is delta-only (cs_class),
     * the emission reached is class C's, counted cs_scale times (1 / (1 + M) where M extra rays
     * took the class; 1 without the split) */
    const bool camsplit = spc_path_camsplit_enabled(ctx);
    bool cs_class = true;
    double cs_scale = 1.0;
    /* and class D (camsplit's recv): the vertices whose BSDF is not delta only so far, and the
     * delta-only ones before and after the first of them */
    const bool cs_recv = camsplit && spc_path_camsplit_recv(ctx);
    int cs_nd = 0, cs_before = 0, cs_after = 0;
    spc_vec3 prev_p = ray.o;
    out->albedo = spc_rgb1(0.0);
    out->normal = spc_v3(0, 0, 0);
    out->depth = 0.0;
    /* specular NEE (path_snee.h): its state, and its queries from the camera */
    spc_path_snee sn;
    spc_path_snee_begin(&sn, ctx, tls, ray0, smp);
    /* grazing directions along mirror cylinders (path_graze.h) */
    const bool graze = nee && sn.on && spc_path_graze_enabled(ctx, sn.lg_enabled);
    spc_graze_track gt = {.live = false};
    /* more directions at the receivers past the first (path_deep.h) */
    spc_path_deep_track dt = {.scale = 1.0, .k = 0};

    for (int segments = 1;; ++segments) {
        /* segments: the number of path segments once this ray is traced */
        /* the emission reached now is the split's class C or D (counted cs_scale times) */
        const bool cs_term = cs_class || (cs_recv && cs_nd == 1 && cs_after >= 1 &&
                                          cs_before + cs_after >= ctx->snee.cam_split_recv_min);
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h)) {
            if (sc->env && !(segments == 1 && ctx->hide_emitters) && !drop_emission) {
                spc_rgb Le = spc_emitter_eval_infinite(sc->env, ray.d);
                double w = 1.0;
                if (nee && !specular) {
                    double lp = spc_scene_emitter_pmf(sc, sc->env) * spc_emitter_pdf_infinite(sc->env, ray.d);
                    w = spc_mis_power(prev_pdf, lp);
                }
                if (cs_scale != 1.0 && cs_term)
                    w *= cs_scale;
                L = spc_rgb_add(L, spc_rgb_scale(spc_rgb_mul(beta, Le), w));
            }
            break;
        }
        spc_vec3 wo = spc_neg(ray.d);
        if (segments == 1 && out->aovs)
            spc_aov_from_hit(ctx, &h, wo, smp, out);
        /* the camera-side split: class C's extra rays where the first hit is delta-only glass */
        if (segments == 1 && camsplit && sn.on && spc_path_camsplit_first(&h)) {
            spc_rgb cs_sum = spc_rgb1(0.0);
            int m = spc_path_camsplit_rays(ctx, tls, smp, &cs_sum);
            if (m > 0) {
                cs_scale = 1.0 / (1.0 + m);
                L = spc_rgb_add(L, spc_rgb_scale(cs_sum, cs_scale));
            }
        }
        if (h.emitter && !(segments == 1 && ctx->hide_emitters) && !drop_emission) {
            spc_rgb Le = spc_emitter_eval_area(h.emitter, &h, wo);
            /* a path specular NEE covers: weighted against its light sample, or dropped */
            double w = spc_rgb_is_black(Le) ? 1.0 : spc_path_snee_emitter_weight(&sn, ctx, &h);
            if (graze && gt.live)
                w *= spc_path_graze_bsdf_weight(ctx, &gt, &h);
            if (w > 0.0 && !spc_rgb_is_black(Le)) {
                if (nee && !specular) {
                    double lp = spc_scene_emitter_pmf(sc, h.emitter) *
                                spc_emitter_pdf_direct(h.emitter, prev_p, h.p, h.ng);
                    w = spc_mis_power(prev_pdf, lp);
                }
                if (cs_scale != 1.0 && cs_term && segments > 1)
                    w *= cs_scale;
                w *= spc_path_deep_factor(&dt);
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
        /* caustic guiding (caustic_guide.h): the continuation's mixture, NULL for the BSDF alone */
        const spc_cguide_vertex *gv = spc_path_snee_guide_at(&sn, &h, wo);

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
                    bool snee_has = spc_path_snee_light_covered(&sn, sc, &h, wo, ds.wi, e);
                    if (!snee_has && !spc_scene_occluded_light(sc, &sr, e)) {
                        double lp = pmf * ds.pdf;
                        /* against the continuation's density: the BSDF's, or the guided mixture's */
                        double w = 1.0;
                        if (!ds.is_delta)
                            w = spc_mis_power(lp, spc_cguide_mix_pdf(
                                                      gv, spc_bsdf_pdf(b, &h, SPC_MODE_RADIANCE, wo, ds.wi), ds.wi));
                        spc_rgb c = spc_rgb_mul(spc_rgb_mul(beta, f), ds.L);
                        L = spc_rgb_add(L, spc_rgb_scale(c, cosi * w / lp));
                    }
                }
            }
        }

        /* specular NEE: chains of at most the budget, within max_depth */
        spc_rgb c_snee = spc_path_snee_at_vertex(&sn, ctx, &h, wo, segments, smp);
        if (!spc_rgb_is_black(c_snee))
            L = spc_rgb_add(L, spc_rgb_mul(beta, c_snee));

        /* the grazing directions along a mirror cylinder's wall, at a receiver near it */
        if (graze && !gv && spc_bsdf_has_smooth(b)) {
            spc_rng grng;
            spc_sampler_fork_rng(smp, SPC_GRAZE_STREAM, &grng);
            spc_rgb c_graze = spc_path_graze_estimate(ctx, &h, wo, segments, &grng);
            if (!spc_rgb_is_black(c_graze))
                L = spc_rgb_add(L, spc_rgb_mul(beta, c_graze));
        }

        /* the extra directions at a receiver past the first (path_deep.h) */
        const bool deep = spc_path_deep_at(&sn, &h);
        if (deep) {
            spc_rgb c_deep = spc_path_deep_estimate(ctx, &sn, &h, wo, segments, smp);
            if (!spc_rgb_is_black(c_deep))
                L = spc_rgb_add(L, spc_rgb_mul(beta, c_deep));
        }

        /* emission splitting (split_emission) */
        const bool split = nee && sn.on && all_delta && !gv && splits_emission(b);
        if (split) {
            spc_rgb c_split = split_emission(ctx, &sn, &h, wo);
            if (cs_scale != 1.0 && cs_class && spc_path_camsplit_first(&h))
                c_split = spc_rgb_scale(c_split, cs_scale);
            if (!spc_rgb_is_black(c_split))
                L = spc_rgb_add(L, spc_rgb_mul(beta, c_split));
        }

        /* specular NEE at the reflection's receiver, by splitting (split_snee) */
        const bool split_q = split && spc_path_snee_splits(&sn, &h);
        if (split_q) {
            spc_rgb c_rs = split_snee(ctx, &sn, &h, wo, segments, smp);
            if (!spc_rgb_is_black(c_rs))
                L = spc_rgb_add(L, spc_rgb_mul(beta, c_rs));
        }

        if (!spc_path_camsplit_first(&h)) {
            cs_class = false;
            ++cs_nd;
            cs_after = 0;
        } else if (cs_nd == 1) {
            ++cs_after;
        } else if (cs_nd == 0) {
            ++cs_before;
        }

        /* BSDF sampling */
        double u_lobe = spc_sampler_1d(smp);
        spc_vec2 u_dir = spc_sampler_2d(smp);
        double u_rr = spc_sampler_1d(smp);
        spc_bsdf_sample bs;
        if (!spc_cguide_sample_mix(gv, &h, wo, u_lobe, u_dir, &bs))
            break;
        if (ctx->strict_normals && !(spc_dot(bs.wi, h.ng) * spc_dot(bs.wi, h.sh.n) > 0.0))
            break;
        spc_path_snee_scattered(&sn, &h, wo, bs.wi, bs.lobe);
        spc_path_deep_scattered(&dt, &sn, &h, bs.lobe, deep);
        if (graze)
            spc_path_graze_scattered(ctx, &gt, &h, wo, bs.wi, bs.lobe, gv != NULL);
        beta = spc_rgb_mul(beta, bs.weight);
        guide_scale *= guide_rr_factor(gv, &h, wo, &bs);
        if (spc_rgb_is_black(beta))
            break;
        specular = (bs.lobe & SPC_LOBE_DELTA) != 0;
        all_delta = all_delta && specular;
        drop_emission = split && bs.lobe == SPC_LOBE_DELTA_REFLECTION;
        sn.skip_query = split_q && bs.lobe == SPC_LOBE_DELTA_REFLECTION;
        prev_pdf = bs.pdf;
        prev_p = h.p;
        if (bs.lobe & (SPC_LOBE_DELTA_TRANSMISSION | SPC_LOBE_GLOSSY_TRANSMISSION | SPC_LOBE_DIFFUSE_TRANSMISSION))
            eta_scale *= bs.eta * bs.eta;
        ray = spc_hit_spawn(&h, bs.wi);

        if (segments >= ctx->rr_depth) {
            double q = spc_min(0.95, spc_rgb_max(beta) * eta_scale * guide_scale);
            if (!(u_rr < q))
                break;
            beta = spc_rgb_scale(beta, 1.0 / q);
        }
    }
    out->L = L;
}
