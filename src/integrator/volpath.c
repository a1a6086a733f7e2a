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
 * Specular connections through one interface (ctx->specular_nee set; Walter et al. 2009,
 * "Single scattering in refractive media with triangle mesh boundaries", for the idea of
 * connecting medium points to a light through a refractive boundary). At every medium interaction
 * x (medium with sample_emitters), one light point y is sampled (light by power, point uniform by
 * area; point and spot lights are their position) and the solver finds the chains x -> P -> y with
 * one specular vertex P (refraction through a dielectric, reflection off a conductor, as
 * spc_chain_surface says; caster flags honoured, single-vertex chains). Each solution adds
 *
 *     beta * phase(wo, d0) T_m(x, P) * T_spec(P) * T_m'(P, y) * Le(y, -d1) * G(x <-> y) / p(y) * <1/p_solve>,
 *
 * T_m the transmittance of x's medium, m' the medium after P, T_spec spc_bsdf_specular_throughput
 * (Fresnel transmittance / eta^2 or conductor reflectance), G the chain's generalized geometry term
 * |dw(x)/dA(y)| (spc_chain_geometry), and <1/p_solve> 1 for a solver that returns every solution
 * (solve_all, e.g. "conic" on meshes), else the count of further attempts until the same solution
 * reappears (specular_nee.h; attempts are seeded from a mixture of the light point and the
 * solver's usual seeds, SPC_VOLPATH_SEED_LIGHT_PROB). A solver with both (conic) sums what
 * solve_all covers and estimates the rest, as spc_specular_nee does. The last segment P -> y must
 * be unblocked (no null crossing either). Connections are made at every medium vertex (every
 * scattering order: connecting single scattering only left the multiple-scattering fireflies of
 * phase sampling in place, bench/RESULTS.md) when max_depth allows the two more segments; surface
 * vertices do not run specular NEE in volpath. Of the setting's options (snee_options.h) these
 * connections use the solver's, trials and seed (the mixture's other half); their chains have one
 * vertex, refract through glass and are estimated one at a time, whatever reflect, exact, chain and
 * rough say.
 *
 * Nothing is counted twice. The paths both strategies produce are those that continue from such an
 * x by phase sampling, cross x's medium without interaction to the first surface P, take there the
 * delta lobe of the chain event (spc_snee_track_scatter), cross the next medium without
 * interaction and without any null surface, and hit an area emitter with nonzero light-selection
 * probability (tracked by spc_snee_track with a budget of one vertex). For such a path:
 *   - if its chain is one the solver enumerates (solve_all, and covers() if the solver has it), the
 *     two strategies are combined by the power heuristic on their densities in solid angle at x:
 *     phase(wo, d0) for phase sampling, p(y) / G for the connection (p(y) = pmf(light) / area, the
 *     connection's uniform area density); the emitter hit traces the chain from x once to get G;
 *   - otherwise (a solution found one at a time, with no density to weigh) phase sampling drops
 *     the emission: exclusion.
 * Every other path keeps its usual weight.
 */
#include <string.h>

#include "integrator/aov.h"
#include "integrator/volpath.h"
#include "manifold/specular_nee.h"
#include "medium/medium.h"

/* Pure null surfaces crossed in a row (by a path or a shadow ray) before giving up: beyond any
 * sensible nesting of index-matched boundaries, and it bounds the work of a ray that grazes along
 * a null surface and keeps re-hitting it. */
#define SPC_VOLPATH_MAX_NULL_CROSSINGS 256
/* Probability that a solve_one attempt from a medium point is seeded toward the light point
 * instead of a uniform point on a caster shape. From inside a dielectric most uniform seeds meet
 * the boundary beyond the critical angle (total internal reflection) and fail, so solutions were
 * found with p of a few percent, where the capped count of attempts is biased (measured: 5-40% low
 * on a glass slab and sphere); the straight line to the light lies near the solution and converges
 * almost always, so p >= 1/2 for that solution, while the other half of the seeds still reaches
 * every other solution. */
#define SPC_VOLPATH_SEED_LIGHT_PROB 0.5
/* Solutions kept from a solver that enumerates them all: one refraction through a closed mesh
 * seldom has more than a few; the rest would be dropped (bias), so the cap is generous. */
#define SPC_VOLPATH_MAX_SOLUTIONS 16

static bool depth_allows(int max_depth, int segments) { return max_depth < 0 || segments <= max_depth; }

static bool is_null_surface(const spc_hit *h) { return h->bsdf && spc_bsdf_flags(h->bsdf) == SPC_LOBE_NULL; }

/* The medium (index, -1 vacuum) of a ray leaving the surface of h along d, coming from `cur`. */
static int medium_after(const spc_hit *h, spc_vec3 d, int cur)
{
    const spc_shape *s = h->shape;
    if (!s || (s->interior_medium < 0 && s->exterior_medium < 0))
        return cur;
    return spc_dot(d, h->ng) < 0.0 ? s->interior_medium : s->exterior_medium;
}

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

/* ---- specular connections from medium points ---- */

typedef struct conn_query {
    const spc_scene *sc;
    const spc_medium *m;
    int med;
    spc_vec3 x, wo;
    const spc_emitter *e;
    spc_vec2 uv;
    double y_err; /* position error bound of the light point (its shape sample's) */
} conn_query;

/* The value of one solved chain x -> P -> y (without p(y) and <1/p_solve>): zero unless it is a
 * one-vertex chain with the event its surface's BSDF has, the caster may be in single chains, and
 * the last segment is unblocked. */
static spc_rgb chain_value(const conn_query *cq, const spc_snee_query *q, const spc_chain *c, double *G_out,
                           double *phase_out)
{
    const spc_rgb zero = spc_rgb1(0.0);
    if (c->n != 1)
        return zero;
    const spc_chain_vertex *v = &c->v[0];
    int event;
    if (!spc_chain_surface(&v->h, q->any_surface, &event) || event != v->event ||
        !(q->any_surface || spc_chain_caster_allowed(v->h.shape->caustic_flags, 1)))
        return zero;
    const spc_scene *sc = cq->sc;
    spc_vec3 d = v->d;
    /* the light point's own error bound: a float triangle's sampled point may sit ~1e-7 relative
     * off the surface Embree intersects, and a tighter margin lets the light shadow itself */
    double y_err = spc_max(cq->y_err, 1e-9 * (spc_max_abs(q->y) + sc->radius));
    spc_ray sr = spc_hit_spawn_to(&v->h, q->y, y_err);
    if (spc_scene_occluded(sc, &sr))
        return zero;
    spc_vec3 ny;
    spc_rgb Le = spc_snee_light_radiance(cq->e, q->y, q->ny, cq->uv, v->h.p, d, &ny);
    if (spc_rgb_is_black(Le))
        return zero;
    double ph = spc_phase_eval(&cq->m->phase, cq->wo, c->d0);
    spc_rgb Ts = spc_bsdf_specular_throughput(v->h.bsdf, &v->h, SPC_MODE_RADIANCE, spc_neg(v->wi), d);
    if (!(ph > 0.0) || spc_rgb_is_black(Ts))
        return zero;
    double d_in = spc_distance(cq->x, v->h.p), d_out = spc_distance(v->h.p, q->y);
    spc_rgb Tin = d_in > 0.0 ? spc_medium_transmittance_ray(cq->m, cq->x, spc_scale(spc_sub(v->h.p, cq->x), 1.0 / d_in),
                                                            d_in)
                             : spc_rgb1(1.0);
    spc_rgb Tout = d_out > 0.0 ? tr_of(sc, medium_after(&v->h, d, cq->med), v->h.p,
                                       spc_scale(spc_sub(q->y, v->h.p), 1.0 / d_out), d_out)
                               : spc_rgb1(1.0);
    double G = spc_chain_geometry(c, q->y, ny);
    if (!(G > 0.0) || !isfinite(G))
        return zero;
    spc_rgb T = spc_rgb_mul(spc_rgb_mul(Tin, Tout), Ts);
    *G_out = G;
    *phase_out = ph;
    return spc_rgb_scale(spc_rgb_mul(T, Le), ph * G);
}

/* One randomized attempt of a solver that finds one solution at a time, seeded from a mixture:
 * toward the light point y with probability SPC_VOLPATH_SEED_LIGHT_PROB, else the solver's usual
 * seed (a uniform point on a caster). The mixture is the same distribution on every call, as the
 * <1/p_solve> count requires. */
static bool attempt(const spc_snee_query *q0, const spc_specular_solver *solver, spc_rng *rng, spc_chain *out,
                    int *iterations)
{
    spc_snee_query q = *q0;
    if (spc_rng_next(rng) < SPC_VOLPATH_SEED_LIGHT_PROB)
        q.seed = SPC_SNEE_SEED_LIGHT;
    return solver->solve_one(&q, rng, out, iterations);
}

/* The specular connection at the medium point x (contract at the top of the file), without beta. */
static spc_rgb medium_connection(const spc_scene *sc, const spc_snee_params *snp, const spc_specular_solver *solver,
                                 int med, spc_vec3 x, spc_vec3 wo, spc_rng *rng)
{
    const spc_rgb zero = spc_rgb1(0.0);
    double pmf;
    const spc_emitter *e = spc_scene_sample_emitter(sc, spc_rng_next(rng), &pmf);
    if (!e)
        return zero;
    conn_query cq = {sc, sc->media[med], med, x, wo, e, spc_v2(0, 0), 0.0};
    spc_hit xh; /* a free point: no offset, no surface */
    memset(&xh, 0, sizeof xh);
    xh.p = x;
    xh.ng = spc_neg(wo);
    xh.sh = spc_frame_from_n(xh.ng);
    xh.err = 0.0;
    xh.shape_index = -1;
    spc_snee_query q;
    memset(&q, 0, sizeof q);
    q.scene = sc;
    q.x = &xh;
    q.wo = wo;
    q.max_chain = 1;
    q.seed = snp->seed;
    q.any_surface = snp->any_surface;
    q.params = snp;
    double p_y;
    switch (e->type) {
    case SPC_EMITTER_AREA: {
        spc_shape_sample ss;
        spc_shape_sample_area(e->shape, spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &ss);
        q.y = ss.p;
        q.ny = ss.n;
        q.light_size = sqrt(e->shape->area);
        cq.uv = ss.uv;
        cq.y_err = ss.err;
        p_y = pmf * ss.pdf;
        break;
    }
    case SPC_EMITTER_POINT:
    case SPC_EMITTER_SPOT:
        q.y = e->position;
        q.ny = spc_v3(0, 0, 0);
        q.light_size = 0.0;
        p_y = pmf;
        break;
    case SPC_EMITTER_DIRECTIONAL:
    case SPC_EMITTER_CONSTANT:
    case SPC_EMITTER_ENVMAP:
    case SPC_EMITTER_PROJECTOR:
    default: return zero;
    }
    if (!(p_y > 0.0))
        return zero;
    /* a solver that enumerates solutions: their exact sum (chains traced from x, with their
     * derivatives); a solver that also estimates (conic: meshes exactly, other shapes by the
     * angular estimate) adds solve_one's estimate for the chains solve_all does not cover */
    spc_rgb total = zero;
    if (solver->solve_all) {
        spc_chain sols[SPC_VOLPATH_MAX_SOLUTIONS];
        int iterations = 0;
        int n = solver->solve_all(&q, sols, SPC_VOLPATH_MAX_SOLUTIONS, &iterations);
        for (int i = 0; i < n; ++i) {
            double G = 0.0, ph = 0.0;
            spc_rgb v = chain_value(&cq, &q, &sols[i], &G, &ph);
            if (spc_rgb_is_black(v))
                continue;
            /* MIS against phase sampling: this strategy's density in solid angle at x is p_y / G */
            double w = e->type == SPC_EMITTER_AREA ? spc_mis_power(p_y / G, ph) : 1.0;
            total = spc_rgb_add(total, spc_rgb_scale(v, w));
        }
        total = spc_rgb_scale(total, 1.0 / p_y);
        if (!solver->solve_one || !solver->covers || (solver->covers_all && solver->covers_all(&q)))
            return total;
    }
    if (!solver->solve_one)
        return total;
    spc_chain sol;
    int iterations = 0;
    if (!attempt(&q, solver, rng, &sol, &iterations))
        return total;
    if (solver->solve_all && solver->covers(&sol))
        return total; /* counted exactly above */
    double G, ph;
    spc_rgb v = chain_value(&cq, &q, &sol, &G, &ph);
    if (spc_rgb_is_black(v))
        return total;
    bool capped;
    int trials = spc_snee_count_same(&q, solver, attempt, rng, &sol, snp->max_trials, &capped, &iterations);
    return spc_rgb_add(total, spc_rgb_scale(v, (double)trials / p_y));
}

/* The weight of an emitter hit by a path that left the medium vertex x along d0 (phase density
 * pdf_phase), crossed one chain vertex and reached the area emitter e at h: the path is one the
 * connection at x produces too. Chains the solver enumerates are weighted by the power heuristic
 * against the connection (density pmf(e) / area(e) / G in solid angle at x, G of the chain traced
 * from x along d0); those it estimates one at a time (solve_one: no density) are excluded (0). */
static double covered_weight(const spc_scene *sc, const spc_specular_solver *solver, spc_vec3 x, spc_vec3 d0,
                             double pdf_phase, const spc_hit *h)
{
    if (!solver->solve_all)
        return 0.0;
    spc_hit xh;
    memset(&xh, 0, sizeof xh);
    xh.p = x;
    xh.ng = d0;
    xh.sh = spc_frame_from_n(d0);
    xh.shape_index = -1;
    spc_frame fr = spc_frame_from_n(d0);
    spc_chain_opts o = spc_chain_opts_default(1);
    spc_chain c;
    spc_chain_trace(sc, &xh, &fr, 0.0, 0.0, &o, &c);
    if (c.n != 1)
        return 1.0; /* the tracer does not reproduce the chain: neither would the solver's chains */
    if (solver->covers && !solver->covers(&c))
        return 0.0; /* left to solve_one's estimate */
    double G = spc_chain_geometry(&c, h->p, h->ng);
    double area = h->emitter->shape ? h->emitter->shape->area : 0.0;
    if (!(G > 0.0) || !isfinite(G) || !(area > 0.0))
        return 1.0;
    return spc_mis_power(pdf_phase, spc_scene_emitter_pmf(sc, h->emitter) / area / G);
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
    /* specular connections from medium vertices */
    const spc_specular_solver *solver = ctx->specular_nee ? spc_specular_solver_get(ctx->specular_nee) : NULL;
    spc_snee_params snp = ctx->snee; /* the user's options: trials, seed, the solvers' own */
    snp.max_chain = 1;
    snp.reflect = false; /* the connections below refract (or reflect off conductors) only, as the
                            exclusion here assumes */
    snp.exact = false;   /* its own estimate from medium vertices (below), not spc_specular_nee's */
    snp.newton.rough = false;
    spc_snee_track track;
    memset(&track, 0, sizeof track);
    spc_vec3 conn_x = spc_v3(0, 0, 0), conn_d0 = spc_v3(0, 0, 1); /* the vertex tracked and its direction */
    double conn_pdf = 0.0;
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
                bool connected = false;
                if (solver && nee && depth_allows(ctx->max_depth, segments + 2)) {
                    /* its own deterministic stream: the sampler's dimensions stay as without it */
                    spc_rng rng;
                    spc_sampler_fork_rng(smp, (uint64_t)segments, &rng);
                    spc_rgb c = medium_connection(sc, &snp, solver, med, x, wo, &rng);
                    L = spc_rgb_add(L, spc_rgb_mul(beta, c));
                    connected = true;
                }
                spc_vec2 u_dir = spc_sampler_2d(smp);
                double u_rr = spc_sampler_1d(smp);
                spc_vec3 wi;
                double pdf;
                if (!spc_phase_sample(&m->phase, wo, u_dir, &wi, &pdf))
                    break;
                /* a new receiver for the exclusion of the connection's paths */
                track.live = connected;
                track.k = 0;
                track.max_chain = 1;
                track.single_ok = track.multi_ok = true;
                track.any_surface = snp.any_surface;
                conn_x = x;
                conn_d0 = wi;
                conn_pdf = pdf;
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
                    w = covered_weight(sc, solver, conn_x, conn_d0, conn_pdf, &h);
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
        spc_snee_track_scatter(&track, &h, bs.lobe, 0, snp.any_surface, false);
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
