/*
 * integrator/volpath.c: volumetric path tracing (Mitsuba's volpath): path.c's estimator (NEE +
 * BSDF sampling with the power heuristic, Russian roulette) in scenes with homogeneous
 * participating media (medium/medium.h), homogeneous or heterogeneous (the medium's functions along
 * a ray: transmittance and free flight through volumes are the medium's business).
 *
 * Media. The medium a ray travels in is tracked along the path: the camera's (scene->camera_medium),
 * then, at every surface that is a medium transition (its shape names an interior or exterior
 * medium), the medium of the side the new ray goes to (interior: opposite to the geometric normal;
 * Mitsuba's rule). Other surfaces do not change it. Along each segment in a medium, free-flight
 * sampling (spectral, one channel by throughput with the mixture density; medium.h) either places
 * an interaction before the next surface (beta *= sigma_s T / pdf) or crosses the segment
 * (beta *= T / P). At an interaction the path scatters by the phase function (sampled exactly:
 * weight 1) and does NEE toward a light sample.
 *
 * Shadow rays carry transmittance: the analytic T of each segment in its medium, through surfaces
 * with a null component (Mitsuba's BSDFFlags::Null: the null BSDF of index-matched boundaries of
 * media, a mask's holes, a thin dielectric's straight transmission) times its null transmission
 * (1, 1 - opacity, 1 - R'; spc_bsdf_null_transmission); any other surface blocks, so NEE never
 * crosses a refractive boundary: light reaches a medium behind glass by BSDF/phase sampling only
 * (or by the specular connection below). A path crossing a pure null surface, or taking a null
 * component by sampling, is not a new vertex either (Mitsuba's volpath does not count it as a
 * bounce): no segment is counted and the MIS state of the last real vertex is kept, so an emitter
 * hit behind null surfaces is weighted against the NEE of that vertex, which reaches it through
 * the same surfaces. Both strategies' MIS densities are the
 * directional ones only (BSDF or phase pdf against the light's solid-angle pdf), without the
 * free-flight probabilities; since both strategies use the same pair, the weights still sum to 1.
 * In a scene without media and null surfaces the estimator and its sample dimensions are path.c's.
 *
 * Specular NEE from medium points (ctx->specular_nee set). At every medium interaction x (medium
 * with sample_emitters) the path tracer's own specular NEE runs with x as a medium receiver
 * (manifold/receiver.h): the same light sample, solvers, trial counts and MIS as at a surface in
 * path.c, with the user's options, the phase function in the place of the BSDF and the
 * transmittance of the media the chain crosses (x's medium, then at each medium transition the
 * medium of the side the chain goes to) in the chain's value (specular_nee.h). Chains fit in the
 * depth left (k vertices add k + 1 segments). Surface vertices do not run specular NEE in volpath;
 * the rough-vertex mode's own estimator does not run from medium points (its smooth chains do).
 * "receivers=N", "first=P" and "later=P" count medium vertices as a path's receivers.
 *
 * Nothing is counted twice. A path that continues from such an x by phase sampling, crosses x's
 * medium without interaction to the first surface, follows the chain events there as specular
 * NEE's chains do (spc_snee_track), crosses the media without interaction and without any null
 * surface, and hits an area emitter with nonzero light-selection probability is one specular NEE
 * produces too: its emission is weighted against specular NEE's light sample by
 * spc_snee_receiver_weight (the power heuristic with the phase function's density; 0, the path
 * dropped, with "nomis"). Free-flight sampling along the chain's segments leaves the expected
 * weight the transmittance, the factor specular NEE's value has. Every other path keeps its usual
 * weight.
 */
#include <string.h>

#include "integrator/aov.h"
#include "integrator/volpath.h"
#include "manifold/snee_cost.h"
#include "manifold/specular_nee.h"
#include "medium/medium.h"

/* Pure null surfaces crossed in a row (by a path or a shadow ray) before giving up: beyond any
 * sensible nesting of index-matched boundaries, and it bounds the work of a ray that grazes along
 * a null surface and keeps re-hitting it. */
#define SPC_VOLPATH_MAX_NULL_CROSSINGS 256

static bool depth_allows(int max_depth, int segments) { return max_depth < 0 || segments <= max_depth; }

static bool is_null_surface(const spc_hit *h) { return h->bsdf && spc_bsdf_flags(h->bsdf) == SPC_LOBE_NULL; }

/* The medium (index, -1 vacuum) of a ray leaving the surface of h along d, coming from `cur`. */
static int medium_after(const spc_hit *h, spc_vec3 d, int cur) { return spc_receiver_medium_after(h, d, cur); }

/* A scene whose shadow rays are plain occlusion queries: no media, no null surfaces. */
static bool scene_is_plain(const spc_scene *sc)
{
    if (sc->nmedia > 0 || sc->camera_medium >= 0)
        return false;
    for (int i = 0; i < sc->nbsdfs; ++i)
        if (spc_bsdf_has_null(sc->bsdfs[i]))
            return false;
    return true;
}

/* Transmittance of medium med (-1: vacuum) along o + t dir, t in [0, d] (dir a unit vector). */
static spc_rgb tr_of(const spc_scene *sc, int med, spc_vec3 o, spc_vec3 dir, double d)
{
    return med >= 0 ? spc_medium_transmittance_ray(sc->media[med], o, dir, d) : spc_rgb1(1.0);
}

/* Transmittance along r from its origin to r.tmax, starting in medium med: products of the media's
 * transmittances and of the null transmission of each surface crossed (spc_bsdf_null_transmission:
 * 1 for null, 1 - opacity for a mask, 1 - R' for a thin dielectric), zero if anything else
 * blocks. */
static spc_rgb shadow_transmittance(const spc_scene *sc, spc_ray r, int med, bool plain)
{
    const spc_rgb zero = spc_rgb1(0.0);
    if (plain)
        return spc_scene_occluded(sc, &r) ? zero : spc_rgb1(1.0);
    spc_rgb T = spc_rgb1(1.0);
    spc_vec3 end = isinf(r.tmax) ? spc_v3(0, 0, 0) : spc_madd(r.o, r.d, r.tmax);
    for (int i = 0; i <= SPC_VOLPATH_MAX_NULL_CROSSINGS; ++i) {
        spc_hit h;
        bool hit = spc_scene_intersect(sc, &r, &h);
        T = spc_rgb_mul(T, tr_of(sc, med, r.o, r.d, hit ? h.t : r.tmax));
        if (!hit)
            return T;
        if (!spc_bsdf_has_null(h.bsdf))
            return zero;
        T = spc_rgb_mul(T, spc_bsdf_null_transmission(h.bsdf, &h, spc_neg(r.d)));
        if (spc_rgb_is_black(T))
            return zero;
        med = medium_after(&h, r.d, med);
        spc_ray n;
        n.o = spc_hit_offset(&h, r.d);
        n.d = r.d;
        n.tmin = 0.0;
        n.tmax = isinf(r.tmax) ? r.tmax : spc_dot(spc_sub(end, n.o), r.d);
        if (!(n.tmax > 0.0))
            return T;
        r = n;
    }
    return zero;
}

/* NEE at a surface vertex h (phase NULL) or at a medium point p (phase set), in medium med (for a
 * surface: the medium the path arrived in). Returns the contribution without beta. */
static spc_rgb next_event(const spc_scene *sc, const spc_hit *h, spc_vec3 p, const spc_phase *phase, spc_vec3 wo,
                          int med, bool plain, double u_light, spc_vec2 u_lpos)
{
    const spc_rgb zero = spc_rgb1(0.0);
    double pmf;
    const spc_emitter *e = spc_scene_sample_emitter(sc, u_light, &pmf);
    spc_emitter_direct ds;
    if (!e || !spc_emitter_sample_direct(e, p, u_lpos, &ds))
        return zero;
    spc_rgb f;
    double pdf_s;
    spc_ray sr;
    int m0 = med;
    if (h) {
        f = spc_bsdf_eval(h->bsdf, h, SPC_MODE_RADIANCE, wo, ds.wi);
        double cosi = spc_absdot(ds.wi, h->sh.n);
        if (spc_rgb_is_black(f) || !(cosi > 0.0))
            return zero;
        f = spc_rgb_scale(f, cosi);
        pdf_s = ds.is_delta ? 0.0 : spc_bsdf_pdf(h->bsdf, h, SPC_MODE_RADIANCE, wo, ds.wi);
        sr = ds.is_infinite ? spc_hit_spawn(h, ds.wi) : spc_hit_spawn_to(h, ds.p, ds.err);
        m0 = medium_after(h, ds.wi, med);
    } else {
        double ph = spc_phase_eval(phase, wo, ds.wi);
        if (!(ph > 0.0))
            return zero;
        f = spc_rgb1(ph);
        pdf_s = ph;
        sr.o = p;
        sr.d = ds.wi;
        sr.tmin = 0.0;
        sr.tmax = ds.is_infinite ? INFINITY : spc_max(ds.dist - 2.0 * ds.err - 1e-7 * ds.dist, 0.0);
    }
    spc_rgb T = shadow_transmittance(sc, sr, m0, plain);
    if (spc_rgb_is_black(T))
        return zero;
    double lp = pmf * ds.pdf;
    double w = ds.is_delta ? 1.0 : spc_mis_power(lp, pdf_s);
    return spc_rgb_scale(spc_rgb_mul(spc_rgb_mul(f, T), ds.L), w / lp);
}

/* ---- specular NEE from medium points ---- */

/* The longest chain (k vertices make k + 1 segments) that fits in the depth left after `segments`
 * segments, at most cap. */
static int depth_left(const spc_render_ctx *ctx, int segments, int cap)
{
    if (ctx->max_depth >= 0 && ctx->max_depth - segments - 1 < cap)
        return ctx->max_depth - segments - 1;
    return cap;
}

/* ---- the path ---- */

void spc_volpath_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray0, spc_sampler *smp,
                        spc_sample_out *out)
{
    (void)tls;
    const spc_scene *sc = ctx->scene;
    const bool plain = scene_is_plain(sc);
    spc_rgb L = spc_rgb1(0.0), beta = spc_rgb1(1.0);
    spc_ray ray = *ray0;
    int med = sc->camera_medium;
    /* MIS state of the last vertex: NEE ran there and the sampled direction was not a delta lobe
     * (then an emitter hit is weighted against that NEE with the densities prev_pdf and the
     * light's pdf from prev_p) */
    bool prev_nee = false;
    double prev_pdf = 1.0, eta_scale = 1.0;
    spc_vec3 prev_p = ray.o;
    /* specular NEE from medium vertices: the user's options, MIS with phase sampling unless
     * "nomis", smooth chains only (the rough-vertex estimator needs a surface receiver) */
    const bool snee_on = ctx->specular_nee != SPC_SNEE_NONE;
    spc_snee_params snp = ctx->snee;
    snp.mis = !snp.no_mis;
    snp.newton.rough = false;
    int receivers = 0;
    spc_snee_track track;
    memset(&track, 0, sizeof track);
    spc_receiver conn; /* the medium receiver the track started at */
    spc_vec3 conn_d0 = spc_v3(0, 0, 1); /* and the direction phase sampling took there */
    memset(&conn, 0, sizeof conn);
    bool first = true;
    int nulls = 0;
    out->albedo = spc_rgb1(0.0);
    out->normal = spc_v3(0, 0, 0);
    out->depth = 0.0;

    for (int segments = 1;;) {
        /* segments: the number of path segments once this ray reaches its next vertex */
        spc_hit h;
        bool hit = spc_scene_intersect(sc, &ray, &h);
        const spc_medium *m = med >= 0 ? sc->media[med] : NULL;
        if (m && !spc_medium_is_vacuum(m)) {
            spc_vec2 u = spc_sampler_2d(smp);
            spc_medium_event ev;
            if (!spc_medium_sample_ray(m, ray.o, ray.d, hit ? h.t : ray.tmax, beta, u.x, u.y, &ev))
                break;
            beta = spc_rgb_mul(beta, ev.weight);
            if (spc_rgb_is_black(beta))
                break;
            if (ev.scattered) {
                /* ---- a medium vertex ---- */
                spc_vec3 x = spc_madd(ray.o, ray.d, ev.t), wo = spc_neg(ray.d);
                if (first) {
                    out->albedo = ev.albedo;
                    out->depth = ev.t;
                    first = false;
                }
                nulls = 0;
                if (!depth_allows(ctx->max_depth, segments + 1))
                    break;
                double u_light = spc_sampler_1d(smp);
                spc_vec2 u_lpos = spc_sampler_2d(smp);
                const bool nee = m->sample_emitters;
                if (nee) {
                    spc_rgb c = next_event(sc, NULL, x, &m->phase, wo, med, plain, u_light, u_lpos);
                    L = spc_rgb_add(L, spc_rgb_mul(beta, c));
                }
                int budget = 0, long_budget = depth_left(ctx, segments, SPC_CHAIN_MAX_VERTICES);
                spc_receiver_medium(&conn, x, wo, &m->phase, med);
                if (snee_on && nee && !(snp.receivers > 0 && receivers >= snp.receivers)) {
                    budget = depth_left(ctx, segments, ctx->specular_max_chain);
                    if (budget > snp.max_chain)
                        budget = snp.max_chain;
                }
                if (nee)
                    ++receivers;
                if (budget > 0) {
                    /* the query by Russian roulette, counted 1 / query_p times, as path.c has it:
                     * first_p at the path's first medium receiver, later_p past it, each raised to 1
                     * where the casters fill x's directions (snee_cost.h). The covered paths' MIS
                     * weight (spc_snee_receiver_weight) reads the same snp.query_p, which stays
                     * until the next medium vertex restarts the track. Its own deterministic
                     * stream: the sampler's dimensions stay as without it. */
                    snp.query_p = receivers > 1 ? spc_snee_later_prob(sc, &snp, x) : spc_snee_first_prob(sc, &snp, x);
                    spc_rng rng;
                    spc_sampler_fork_rng(smp, (uint64_t)segments, &rng);
                    spc_rgb c = spc_specular_nee_at(sc, &snp, &conn, budget, long_budget, &rng, NULL);
                    L = spc_rgb_add(L, spc_rgb_mul(beta, c));
                }
                spc_vec2 u_dir = spc_sampler_2d(smp);
                double u_rr = spc_sampler_1d(smp);
                spc_vec3 wi;
                double pdf;
                if (!spc_phase_sample(&m->phase, wo, u_dir, &wi, &pdf))
                    break;
                /* a new receiver for the exclusion of specular NEE's paths */
                spc_snee_track_begin(&track, &snp, budget, long_budget);
                conn_d0 = wi;
                prev_nee = nee;
                prev_pdf = pdf;
                prev_p = x;
                ray.o = x;
                ray.d = wi;
                ray.tmin = 0.0;
                ray.tmax = INFINITY;
                if (segments >= ctx->rr_depth) {
                    double q = spc_min(0.95, spc_rgb_max(beta) * eta_scale);
                    if (!(u_rr < q))
                        break;
                    beta = spc_rgb_scale(beta, 1.0 / q);
                }
                ++segments;
                continue;
            }
        }

        if (!hit) {
            if (sc->env && !(segments == 1 && ctx->hide_emitters)) {
                spc_rgb Le = spc_emitter_eval_infinite(sc->env, ray.d);
                double w = 1.0;
                if (prev_nee) {
                    double lp = spc_scene_emitter_pmf(sc, sc->env) * spc_emitter_pdf_infinite(sc->env, ray.d);
                    w = spc_mis_power(prev_pdf, lp);
                }
                L = spc_rgb_add(L, spc_rgb_scale(spc_rgb_mul(beta, Le), w));
            }
            break;
        }
        /* ---- a surface ---- */
        if (first && !is_null_surface(&h)) {
            spc_aov_from_hit(ctx, &h, spc_neg(ray.d), smp, out);
            first = false;
        }
        spc_vec3 wo = spc_neg(ray.d);
        bool covered = track.live && spc_snee_track_covers(&track, sc, h.emitter);
        if (h.emitter && !(segments == 1 && ctx->hide_emitters)) {
            spc_rgb Le = spc_emitter_eval_area(h.emitter, &h, wo);
            if (!spc_rgb_is_black(Le)) {
                double w = 1.0;
                if (covered) {
                    w = spc_snee_receiver_weight(sc, &snp, &conn, conn_d0, track.max_chain, track.k, track.events, &h);
                } else if (prev_nee) {
                    double lp = spc_scene_emitter_pmf(sc, h.emitter) *
                                spc_emitter_pdf_direct(h.emitter, prev_p, h.p, h.ng);
                    w = spc_mis_power(prev_pdf, lp);
                }
                L = spc_rgb_add(L, spc_rgb_scale(spc_rgb_mul(beta, Le), w));
            }
        }
        if (is_null_surface(&h)) {
            /* crossed, not a vertex: no segment, the MIS state stays the last vertex's */
            if (++nulls > SPC_VOLPATH_MAX_NULL_CROSSINGS)
                break;
            beta = spc_rgb_mul(beta, spc_bsdf_null_transmission(h.bsdf, &h, wo));
            if (spc_rgb_is_black(beta))
                break;
            med = medium_after(&h, ray.d, med);
            ray = spc_hit_spawn(&h, ray.d);
            track.live = false;
            continue;
        }
        const spc_bsdf *b = h.bsdf;
        /* every continuation adds at least one segment, but a null event (below) */
        const bool more = depth_allows(ctx->max_depth, segments + 1);
        if (!more && !spc_bsdf_has_null(b))
            break;

        /* next-event estimation (always draw the same dimensions, as path.c) */
        double u_light = spc_sampler_1d(smp);
        spc_vec2 u_lpos = spc_sampler_2d(smp);
        const bool nee = spc_bsdf_has_smooth(b) && more;
        if (nee) {
            spc_rgb c = next_event(sc, &h, h.p, NULL, wo, med, plain, u_light, u_lpos);
            L = spc_rgb_add(L, spc_rgb_mul(beta, c));
        }

        /* BSDF sampling */
        double u_lobe = spc_sampler_1d(smp);
        spc_vec2 u_dir = spc_sampler_2d(smp);
        double u_rr = spc_sampler_1d(smp);
        spc_bsdf_sample bs;
        if (!spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, u_lobe, u_dir, &bs))
            break;
        if (spc_bsdf_sample_is_null(b, &bs)) {
            /* Mitsuba's null event (a thin sheet's transmission, a mask's hole): crossed as a pure
             * null surface is, not a vertex; NEE reaches past it with its null transmission */
            beta = spc_rgb_mul(beta, bs.weight);
            if (spc_rgb_is_black(beta) || ++nulls > SPC_VOLPATH_MAX_NULL_CROSSINGS)
                break;
            med = medium_after(&h, bs.wi, med);
            ray = spc_hit_spawn(&h, bs.wi);
            track.live = false;
            continue;
        }
        if (!more)
            break;
        nulls = 0;
        spc_snee_track_scatter(&track, &h, bs.lobe, 0, snp.any_surface, snp.reflect);
        beta = spc_rgb_mul(beta, bs.weight);
        if (spc_rgb_is_black(beta))
            break;
        prev_nee = nee && !(bs.lobe & SPC_LOBE_DELTA);
        prev_pdf = bs.pdf;
        prev_p = h.p;
        if (bs.lobe & (SPC_LOBE_DELTA_TRANSMISSION | SPC_LOBE_GLOSSY_TRANSMISSION | SPC_LOBE_DIFFUSE_TRANSMISSION))
            eta_scale *= bs.eta * bs.eta;
        med = medium_after(&h, bs.wi, med);
        ray = spc_hit_spawn(&h, bs.wi);

        if (segments >= ctx->rr_depth) {
            double q = spc_min(0.95, spc_rgb_max(beta) * eta_scale);
            if (!(u_rr < q))
                break;
            beta = spc_rgb_scale(beta, 1.0 / q);
        }
        ++segments;
    }
    out->L = L;
}
