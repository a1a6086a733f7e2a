/*
 * manifold/rough.c: specular NEE through rough interfaces (newton.h's rough vertices; Zeltner,
 * Georgiev and Jakob 2020, "Specular Manifold Sampling", sec. 4.3), the estimator of the setting
 * "newton:rough" (rough.h). Per light sample the microfacet normals of the rough vertices are drawn
 * once and kept for every attempt, so that the attempts that count <1/p_solve> look for the same
 * offset-normal chain; the value of a solved chain carries f_r |cos| |dw/dm| / p(m) per rough
 * vertex and the chain's generalized geometry term (spc_newton_geometry).
 */
#include "manifold/rough.h"

#include <string.h>

#include "bsdf/microfacet.h"

/* Distinct solutions the biased estimator of rough chains keeps per light sample (as specular_nee.c
 * keeps for smooth ones): later ones are still counted, only not remembered for deduplication. */
#define SPC_ROUGH_BIASED_MAX_SOLUTIONS 8

typedef struct rough_query {
    const spc_scene *sc;
    const spc_hit *x;
    spc_vec3 wo, y, ny;
    int max_chain;
    bool any_surface;
    spc_snee_seed seed;
    const spc_newton_options *o;
    double u[SPC_CHAIN_MAX_VERTICES][2]; /* microfacet normals, fixed for the whole estimate */
    spc_vec3 ref;                        /* local frames' reference, fixed for the whole estimate */
    const spc_snee_query *q;             /* for the seed directions */
} rough_query;

/* May the shape hold a vertex of a rough chain (a smooth caster, or a rough one)? */
static bool rough_caster_shape(const spc_shape *s, bool any_surface)
{
    if (spc_chain_shape_is_caster(s, any_surface, NULL))
        return true;
    const spc_bsdf *b = s->bsdf;
    if (s->emitter || !b || (b->type != SPC_BSDF_ROUGHCONDUCTOR && b->type != SPC_BSDF_ROUGHDIELECTRIC))
        return false;
    return any_surface || spc_chain_caster_allowed(s->caustic_flags, 1) || spc_chain_caster_allowed(s->caustic_flags, 2);
}

/* Seed directions of rough chains: SEED_SHAPE and SEED_CONE pick among rough casters too (a uniform
 * point of the chosen one). */
static bool rough_seed_direction(const rough_query *rq, spc_rng *rng, spc_vec3 *dir)
{
    if (rq->seed != SPC_SNEE_SEED_SHAPE && rq->seed != SPC_SNEE_SEED_CONE)
        return spc_snee_seed_direction(rq->q, rng, dir);
    const spc_shape *pick = NULL;
    int seen = 0;
    for (int i = 0; i < rq->sc->nshapes; ++i) {
        if (!rough_caster_shape(rq->sc->shapes[i], rq->any_surface))
            continue;
        ++seen;
        if (spc_rng_next(rng) * seen < 1.0)
            pick = rq->sc->shapes[i];
    }
    if (!pick)
        return false;
    spc_shape_sample ss;
    spc_shape_sample_area(pick, spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &ss);
    spc_vec3 d = spc_sub(ss.p, rq->x->p);
    double l = spc_length(d);
    if (!(l > 0.0))
        return false;
    *dir = spc_scale(d, 1.0 / l);
    return true;
}

static bool rough_attempt(const rough_query *rq, spc_rng *rng, spc_newton_path *p, int *iterations)
{
    if (rq->seed == SPC_SNEE_SEED_LIGHT) {
        if (!spc_newton_seed_straight(rq->sc, rq->x, rq->y, rq->max_chain, rq->any_surface,
                                      (const double(*)[2])rq->u, rq->ref, p))
            return false;
    } else {
        spc_vec3 dir;
        if (!rough_seed_direction(rq, rng, &dir) ||
            !spc_newton_seed_trace(rq->sc, rq->x, dir, rq->max_chain, rq->any_surface, (const double(*)[2])rq->u,
                                   rq->ref, p))
            return false;
    }
    spc_newton_result res;
    bool ok = spc_newton_solve(rq->sc, rq->x, rq->y, p, rq->o, &res);
    *iterations += res.iterations;
    return ok;
}

static bool same_path(const spc_newton_path *a, const spc_newton_path *b, double scene_size)
{
    if (a->n != b->n)
        return false;
    /* the same tolerance as spc_snee_same_solution */
    double tol2 = spc_sqr(1e-4 * scene_size);
    for (int i = 0; i < a->n; ++i)
        if (a->v[i].h.shape_index != b->v[i].h.shape_index || a->v[i].event != b->v[i].event ||
            spc_length2(spc_sub(a->v[i].h.p, b->v[i].h.p)) > tol2)
            return false;
    return true;
}

/* One trial of <1/p_solve>: a fresh attempt that finds the solution sol again. */
typedef struct rough_trial {
    const rough_query *rq;
    spc_rng *rng;
    const spc_newton_path *sol;
    int *iterations;
    double scene_size;
} rough_trial;

static bool rough_trial_same(void *user)
{
    rough_trial *t = user;
    spc_newton_path trial;
    return rough_attempt(t->rq, t->rng, &trial, t->iterations) && same_path(t->sol, &trial, t->scene_size);
}

/* f_x |cos| prod(vertex factors) Le G for a solved (possibly rough) path; zero if it is not one
 * specular NEE produces or its last segment is blocked. */
static spc_rgb rough_value(const rough_query *rq, const spc_emitter *e, spc_vec2 uv, const spc_newton_path *p)
{
    const spc_rgb zero = spc_rgb1(0.0);
    int k = p->n;
    if (k < 1 || k > rq->max_chain)
        return zero;
    if (!rq->any_surface)
        for (int i = 0; i < k; ++i)
            if (!spc_chain_caster_allowed(p->v[i].h.shape->caustic_flags, k))
                return zero;
    const spc_hit *last = &p->v[k - 1].h;
    double y_err = 1e-9 * (spc_max_abs(rq->y) + rq->sc->radius);
    spc_ray sr = spc_hit_spawn_to(last, rq->y, y_err);
    if (spc_scene_occluded(rq->sc, &sr))
        return zero;
    spc_vec3 d = spc_normalize(spc_sub(rq->y, last->p));
    spc_vec3 ny;
    spc_rgb Le = spc_snee_light_radiance(e, rq->y, rq->ny, uv, last->p, d, &ny);
    if (spc_rgb_is_black(Le))
        return zero;
    const spc_hit *x = rq->x;
    spc_vec3 d0 = spc_normalize(spc_sub(p->v[0].h.p, x->p));
    spc_rgb f = spc_bsdf_eval(x->bsdf, x, SPC_MODE_RADIANCE, rq->wo, d0);
    double cosx = spc_absdot(d0, x->sh.n);
    if (spc_rgb_is_black(f) || !(cosx > 0.0))
        return zero;
    f = spc_rgb_scale(f, cosx);
    for (int i = 0; i < k; ++i) {
        const spc_newton_vertex *v = &p->v[i];
        spc_vec3 prev = i == 0 ? x->p : p->v[i - 1].h.p, next = i == k - 1 ? rq->y : p->v[i + 1].h.p;
        spc_vec3 wp = spc_normalize(spc_sub(prev, v->h.p)), wn = spc_normalize(spc_sub(next, v->h.p));
        if (!v->rough) {
            f = spc_rgb_mul(f, spc_bsdf_specular_throughput(v->h.bsdf, &v->h, SPC_MODE_RADIANCE, wp, wn));
        } else {
            /* f_r |cos| times |dw_n / dm|, the inverse of Walter et al. 2007's half-vector Jacobians
             * (eq. 14 and 17), over p(m) = D(m) cos(m) */
            spc_vec3 m = spc_newton_vertex_normal(v, p->ref);
            double jac;
            if (v->event == SPC_CHAIN_REFLECT) {
                jac = 4.0 * spc_absdot(wn, m);
            } else {
                bool outside = spc_dot(wp, v->h.sh.n) > 0.0;
                double ep = outside ? 1.0 : v->eta, en = outside ? v->eta : 1.0;
                double den = ep * spc_dot(wp, m) + en * spc_dot(wn, m);
                jac = den * den / (en * en * spc_absdot(wn, m));
            }
            spc_microfacet md = spc_microfacet_from_bsdf(v->h.bsdf, &v->h);
            double pm = spc_microfacet_d(&md, v->m) * v->m.z;
            spc_rgb fr = spc_bsdf_eval(v->h.bsdf, &v->h, SPC_MODE_RADIANCE, wp, wn);
            if (!(pm > 0.0))
                return zero;
            f = spc_rgb_mul(f, spc_rgb_scale(fr, spc_absdot(wn, v->h.sh.n) * jac / pm));
        }
        if (spc_rgb_is_black(f))
            return zero;
    }
    double G = spc_newton_geometry(x->p, p, rq->y, ny, rq->o->constraint);
    if (!(G > 0.0) || !isfinite(G))
        return zero;
    return spc_rgb_scale(spc_rgb_mul(f, Le), G);
}

spc_rgb spc_rough_nee(const spc_scene *sc, const spc_snee_params *prm, const spc_hit *x, spc_vec3 wo, int max_chain,
                      spc_rng *rng, spc_snee_stats *st)
{
    const spc_rgb zero = spc_rgb1(0.0);
    if (max_chain > prm->max_chain)
        max_chain = prm->max_chain;
    if (max_chain < 1)
        return zero;
    double pmf;
    const spc_emitter *e = spc_scene_sample_emitter(sc, spc_rng_next(rng), &pmf);
    if (!e)
        return zero;
    spc_snee_query q;
    spc_snee_query_init(&q, sc, prm, x, wo, max_chain);
    double p_y;
    spc_vec2 uv = spc_v2(0, 0);
    if (e->type == SPC_EMITTER_AREA) {
        spc_shape_sample ss;
        spc_shape_sample_area(e->shape, spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &ss);
        q.y = ss.p;
        q.ny = ss.n;
        q.light_size = sqrt(e->shape->area);
        uv = ss.uv;
        p_y = pmf * ss.pdf;
    } else if (e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_SPOT) {
        q.y = e->position;
        p_y = pmf;
    } else {
        return zero;
    }
    if (!(p_y > 0.0))
        return zero;
    if (st)
        st->calls++;

    rough_query rq;
    rq.sc = sc;
    rq.x = x;
    rq.wo = wo;
    rq.y = q.y;
    rq.ny = q.ny;
    rq.max_chain = max_chain;
    rq.any_surface = prm->any_surface;
    rq.seed = prm->seed;
    rq.o = &prm->newton;
    rq.q = &q;
    for (int i = 0; i < SPC_CHAIN_MAX_VERTICES; ++i) {
        rq.u[i][0] = spc_rng_next(rng);
        rq.u[i][1] = spc_rng_next(rng);
    }
    rq.ref = spc_warp_uniform_sphere(spc_v2(spc_rng_next(rng), spc_rng_next(rng)));

    spc_newton_path sol, trial;
    int iterations = 0;
    if (prm->biased) {
        /* the biased estimator (specular_nee.h): the distinct solutions of biased_seeds attempts */
        spc_newton_path found[SPC_ROUGH_BIASED_MAX_SOLUTIONS];
        int nfound = 0, seeds = prm->biased_seeds > 0 ? prm->biased_seeds : 1;
        spc_rgb sum = zero;
        for (int s = 0; s < seeds; ++s) {
            if (!rough_attempt(&rq, rng, &trial, &iterations))
                continue;
            bool seen = false;
            for (int i = 0; i < nfound && !seen; ++i)
                seen = same_path(&found[i], &trial, sc->radius);
            if (seen)
                continue;
            if (nfound < SPC_ROUGH_BIASED_MAX_SOLUTIONS)
                found[nfound++] = trial;
            spc_rgb v = rough_value(&rq, e, uv, &trial);
            if (st)
                st->solved++;
            if (!spc_rgb_is_black(v)) {
                sum = spc_rgb_add(sum, v);
                if (st)
                    st->contributions++;
            }
        }
        if (st)
            st->iterations += (uint64_t)iterations;
        return spc_rgb_scale(sum, 1.0 / p_y);
    }
    bool ok = rough_attempt(&rq, rng, &sol, &iterations);
    if (st)
        st->iterations += (uint64_t)iterations;
    if (!ok)
        return zero;
    if (st)
        st->solved++;
    spc_rgb v = rough_value(&rq, e, uv, &sol);
    if (spc_rgb_is_black(v))
        return zero;
    double inv_p = 1.0;
    if (prm->seed != SPC_SNEE_SEED_LIGHT) {
        int cap = prm->max_trials > 0 ? prm->max_trials : 64, n = 0;
        bool capped = false;
        iterations = 0;
        rough_trial t = {&rq, rng, &sol, &iterations, sc->radius};
        inv_p = spc_snee_count_trials(rough_trial_same, &t, cap, rng, &n, &capped);
        if (st) {
            st->trials += (uint64_t)n;
            st->iterations += (uint64_t)iterations;
            st->capped += capped ? 1u : 0u;
        }
    }
    if (st)
        st->contributions++;
    return spc_rgb_scale(v, inv_p / p_y);
}
