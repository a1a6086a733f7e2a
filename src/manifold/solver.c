/*
 * manifold/solver.c: the solver side of specular NEE (solver.h): a query's initial state, the seed
 * directions of the randomized attempts, and when two converged chains are the same solution.
 */
#include "manifold/solver.h"

#include <limits.h>
#include <string.h>

#include "manifold/fit_seeds.h"
#include "manifold/receiver.h"
#include "manifold/seed_guide.h"
#include "manifold/solve_mis.h"
#include "medium/medium.h"

/* Cosine of the half-angle of SEED_CONE's cone around x -> y (x inside the caster's bounding sphere). */
#define SPC_SNEE_CONE_COS 0.9
/* The share of a cone seed's attempts in that cone where x lies within the caster's bounding sphere;
 * the rest toward a uniform point of the shape. */
#define SPC_SNEE_CONE_SHARE 0.5
/* The same at a medium point (a medium inside a glass ball): its chains out of the ball leave near
 * the straight line, and the ones its attempts miss are paths that phase sampling alone then finds
 * with weight 1 (the give-up at the cap), each one a firefly. On scenes/medium_glass.xml at equal
 * CPU over 32 seeds the mean relMSE was 0.073 against 0.084 with 0.5 (worst seed 0.18 against 0.28),
 * 12% more samples in the time; 0.2 gave 0.105 against 0.095 on 16 of them, 0.9 0.067 against 0.074
 * on the other 16 (bench/RESULTS.md, part medglass13). */
#define SPC_SNEE_CONE_SHARE_MEDIUM 0.8

/* Area-point seeds (SEED_SHAPE, and SEED_CONE from inside a caster's bounding sphere): points of the
 * shape drawn until one faces x, at most this many. Measured in bench/RESULTS.md ("reflections off
 * glass, MIS with a solve-probability stand-in, specular NEE from the camera"). */
#define SPC_SNEE_FACING_TRIES 16

void spc_snee_query_init(spc_snee_query *q, const spc_scene *sc, const spc_snee_params *p, const spc_hit *x,
                         spc_vec3 wo, int max_chain)
{
    memset(q, 0, sizeof *q);
    q->scene = sc;
    q->x = x;
    q->wo = wo;
    q->max_chain = max_chain;
    q->seed = p->seed;
    q->any_surface = p->any_surface;
    q->params = p;
}

/* ---- seeding ---- */

bool spc_snee_straight_hits_glass(const spc_snee_query *q)
{
    spc_vec3 d = spc_sub(q->y, q->x->p);
    double l = spc_length(d);
    if (!(l > 0.0))
        return false;
    spc_ray r = spc_hit_spawn(q->x, spc_scale(d, 1.0 / l));
    spc_hit h;
    int event;
    return spc_scene_intersect(q->scene, &r, &h) && spc_chain_surface(&h, q->any_surface, &event) &&
           event == SPC_CHAIN_REFRACT;
}

bool spc_snee_seed_direction(const spc_snee_query *q, spc_rng *rng, spc_vec3 *dir)
{
    const spc_scene *sc = q->scene;
    if (q->seed_dir) {
        *dir = *q->seed_dir;
        return true;
    }
    /* SEED_BSDF at a start point with no BSDF: a medium point samples its phase function (below), the
     * camera's pinhole, which samples no direction of its own here, takes the cone seeds. An attempt
     * with no seed finds nothing, while MIS still hands specular NEE its share of the paths that only
     * the attempts find: those paths would lose that share (scenes/medium_glass.xml read 8% low;
     * bench/RESULTS.md, part seedbsdf15). */
    spc_snee_seed seed = q->seed;
    bool medium = q->receiver && q->receiver->kind == SPC_RECEIVER_MEDIUM;
    /* at a medium point inside a glass ball with a sphere fit (a ball filled with a medium), a share
     * of the seeds toward the fitted sphere's way out from inside (fit_seeds.h) first: a chain that
     * leaves the ball near its rim (the way out near grazing) lies far from the straight line and
     * from the phase function's directions, where the cone and phase seeds found it in 1-4 of 1000
     * attempts (test_fit_seeds); its counts ran to the cap, and the phase-sampled paths of weight 1
     * left beside it once the count was given up held one pixel of two of 24 seeds of
     * scenes/medium_glass.xml. A function of the query alone (x, y, the lengths), as the seeds
     * below. */
    if (medium && q->params && q->params->fit_seeds && (seed == SPC_SNEE_SEED_SHAPE || seed == SPC_SNEE_SEED_CONE)) {
        const spc_chain_casters *cs = spc_chain_casters_of(sc, q->any_surface);
        for (int j = 0; cs && j < cs->n; ++j) {
            const spc_shape *s = sc->shapes[cs->idx[j]];
            spc_vec3 c;
            double R;
            if (spc_fit_sphere(s, &c, &R) && spc_distance(q->x->p, c) < R) {
                if (spc_fit_seed(q, s, rng, dir))
                    return true;
                break;
            }
        }
    }
    /* at a medium point a share of the random seeds from its phase function
     * (spc_snee_params.phase_seeds; the straight-line attempt's SEED_LIGHT stays as it is) */
    double ps = q->params ? q->params->phase_seeds : 0.0;
    if (medium && ps > 0.0 && (seed == SPC_SNEE_SEED_SHAPE || seed == SPC_SNEE_SEED_CONE) &&
        (ps >= 1.0 || spc_rng_next(rng) < ps))
        seed = SPC_SNEE_SEED_BSDF;
    if (seed == SPC_SNEE_SEED_BSDF && !medium && !q->x->bsdf)
        seed = SPC_SNEE_SEED_CONE;
    switch (seed) {
    case SPC_SNEE_SEED_LIGHT: {
        spc_vec3 d = spc_sub(q->y, q->x->p);
        double l = spc_length(d);
        if (!(l > 0.0))
            return false;
        *dir = spc_scale(d, 1.0 / l);
        return true;
    }
    case SPC_SNEE_SEED_BSDF: {
        if (medium) {
            double pdf;
            spc_vec2 u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
            return spc_phase_sample(q->receiver->phase, q->wo, u, dir, &pdf) && pdf > 0.0;
        }
        spc_bsdf_sample bs;
        double ul = spc_rng_next(rng);
        spc_vec2 u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
        if (!spc_bsdf_sample_dir(q->x->bsdf, q->x, SPC_MODE_RADIANCE, q->wo, ul, u, &bs))
            return false;
        *dir = bs.wi;
        return true;
    }
    case SPC_SNEE_SEED_SHAPE:
    case SPC_SNEE_SEED_CONE: {
        /* guided seeds (seed_guide.h) with probability seed_guide, where a light path landed near x */
        const spc_snee_params *p = q->params;
        if (p->sguide && p->seed_guide > 0.0 && !q->cam) {
            double ug = spc_rng_next(rng), u = spc_rng_next(rng);
            spc_vec2 u2 = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
            if (ug < p->seed_guide && spc_sguide_seed(p->sguide, q->x->p, q->min_chain > 0 ? q->min_chain : 1,
                                                     q->max_chain, u, u2, dir))
                return true;
        }
        /* uniform over the caster shapes, by one pass of reservoir sampling over their list (the
         * random streams of the seeds as they were when the pass went over every shape) */
        const spc_shape *pick = NULL;
        const spc_chain_casters *cs = spc_chain_casters_of(sc, q->any_surface);
        for (int j = 0; cs && j < cs->n; ++j)
            if (spc_rng_next(rng) * (j + 1) < 1.0)
                pick = sc->shapes[cs->idx[j]];
        if (!pick)
            return false;
        /* a share toward the solutions of the sphere fitted to a tessellated ball (fit_seeds.h) */
        if (p->fit_seeds && spc_fit_seed(q, pick, rng, dir))
            return true;
        if (seed == SPC_SNEE_SEED_CONE) {
            /* uniform in the cone of the sphere around the shape's bounding box, unless x is inside
             * it. (The exact cone of a sphere caster was measured worse: 1.6x the CPU at the same
             * variance on caustic_glass_sphere; seeds that miss fail at once.) */
            spc_vec3 c = spc_scale(spc_add(pick->bbox_min, pick->bbox_max), 0.5), d = spc_sub(c, q->x->p);
            double r = 0.5 * spc_distance(pick->bbox_min, pick->bbox_max), l = spc_length(d);
            if (l > r * 1.000001) {
                double sin_max = r / l, cos_max = sqrt(spc_max(0.0, 1.0 - sin_max * sin_max));
                spc_frame f = spc_frame_from_n(spc_scale(d, 1.0 / l));
                spc_vec3 w = spc_warp_uniform_cone(spc_v2(spc_rng_next(rng), spc_rng_next(rng)), cos_max);
                *dir = spc_frame_to_world(&f, w);
                return true;
            }
            /* x inside: a share of the seeds in a cone around the straight line toward y (a large
             * caster over x, such as a water surface: the solutions lie near that line), the rest
             * toward a uniform point of the shape (below) */
            if (spc_rng_next(rng) < (medium ? SPC_SNEE_CONE_SHARE_MEDIUM : SPC_SNEE_CONE_SHARE)) {
                spc_vec3 dy = spc_sub(q->y, q->x->p);
                double ly = spc_length(dy);
                if (ly > 0.0) {
                    spc_frame f = spc_frame_from_n(spc_scale(dy, 1.0 / ly));
                    spc_vec2 u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
                    *dir = spc_frame_to_world(&f, spc_warp_uniform_cone(u, SPC_SNEE_CONE_COS));
                    return true;
                }
            }
        }
        /* a uniform point of the shape, preferably one that faces x (a closed caster's first hit
         * from outside does; an open one seen from behind has none, and keeps the last point) */
        spc_shape_sample ss;
        for (int i = 0; i < SPC_SNEE_FACING_TRIES; ++i) {
            spc_shape_sample_area(pick, spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &ss);
            if (spc_dot(ss.n, spc_sub(q->x->p, ss.p)) > 0.0)
                break;
        }
        spc_vec3 d = spc_sub(ss.p, q->x->p);
        double l = spc_length(d);
        if (!(l > 0.0))
            return false;
        *dir = spc_scale(d, 1.0 / l);
        return true;
    }
    }
    return false;
}

/* ---- the events of an attempt ---- */

/* Does the ball's event at vertex i of a k-vertex chain reflect (every vertex but the first and the
 * last)? */
static bool ball_reflects(int i, int k) { return i > 0 && i < k - 1; }

void spc_snee_attempt_event_u(const spc_snee_query *q, spc_rng *rng, double event_u[SPC_CHAIN_MAX_VERTICES])
{
    const spc_snee_params *p = q->params;
    if (p->ball_events_p > 0.0 && spc_rng_next(rng) < p->ball_events_p) {
        /* u = 0 reflects and u = 1 refracts at any reflect_p in (0, 1] (spc_chain_pick_event) */
        for (int i = 0; i < SPC_CHAIN_MAX_VERTICES; ++i)
            event_u[i] = ball_reflects(i, q->max_chain) ? 0.0 : 1.0;
        return;
    }
    for (int i = 0; i < SPC_CHAIN_MAX_VERTICES; ++i)
        event_u[i] = spc_rng_next(rng);
}

double spc_snee_attempt_events_prob(const spc_snee_query *q, const spc_chain_sig *sig)
{
    const spc_snee_params *p = q->params;
    double P = spc_chain_events_prob(q->scene, sig, p->any_surface, p->reflect_p);
    if (!(p->ball_events_p > 0.0))
        return P;
    bool ball = sig->n == q->max_chain;
    for (int i = 0; i < sig->n && ball; ++i) {
        int ev = SPC_CHAIN_REFLECT;
        if (sig->shape[i] < 0 || sig->shape[i] >= q->scene->nshapes ||
            !spc_chain_shape_is_caster(q->scene->shapes[sig->shape[i]], p->any_surface, &ev))
            return 0.0;
        if (ev == SPC_CHAIN_REFRACT)
            ball = (sig->event[i] == SPC_CHAIN_REFLECT) == ball_reflects(i, q->max_chain);
    }
    return (1.0 - p->ball_events_p) * P + (ball ? p->ball_events_p : 0.0);
}

bool spc_snee_same_solution(const spc_chain *a, const spc_chain *b, double scene_size)
{
    if (a->n != b->n)
        return false;
    double tol2 = spc_sqr(SPC_SNEE_SAME_REL * scene_size);
    for (int i = 0; i < a->n; ++i) {
        if (a->v[i].h.shape_index != b->v[i].h.shape_index || a->v[i].event != b->v[i].event)
            return false;
        if (spc_length2(spc_sub(a->v[i].h.p, b->v[i].h.p)) > tol2)
            return false;
    }
    return true;
}

double spc_snee_count_trials(bool (*trial)(void *user), void *user, int cap, spc_rng *rng, int *attempts,
                             bool *capped)
{
    if (cap < 1)
        cap = 1;
    *capped = false;
    for (int n = 1; n <= cap; ++n)
        if (trial(user)) {
            *attempts = n;
            return n;
        }
    /* past the cap: the roulette (solve_mis.h) */
    *capped = true;
    int more = 0;
    double count = cap + spc_trial_count_on(trial, user, rng, cap, &more);
    *attempts = more < INT_MAX - cap ? cap + more : INT_MAX;
    return count;
}

typedef struct trial_ctx {
    const spc_snee_query *q;
    const spc_specular_solver *solver;
    spc_snee_attempt attempt;
    const spc_chain *target;
    spc_rng *rng;
    spc_chain scratch;
    int *iterations;
} trial_ctx;

static bool trial_same(void *user)
{
    trial_ctx *t = user;
    bool found = t->attempt ? t->attempt(t->q, t->solver, t->rng, &t->scratch, t->iterations)
                            : t->solver->solve_one(t->q, t->rng, &t->scratch, t->iterations);
    return found && spc_snee_same_solution(t->target, &t->scratch, t->q->scene->radius);
}

double spc_snee_count_same(const spc_snee_query *q, const spc_specular_solver *solver, spc_snee_attempt attempt,
                           spc_rng *rng, const spc_chain *target, int cap, int *attempts, bool *capped,
                           int *iterations)
{
    trial_ctx tc;
    tc.q = q;
    tc.solver = solver;
    tc.attempt = attempt;
    tc.target = target;
    tc.rng = rng;
    tc.iterations = iterations;
    return spc_snee_count_trials(trial_same, &tc, cap, rng, attempts, capped);
}

spc_rgb spc_snee_light_radiance(const spc_emitter *e, spc_vec3 y, spc_vec3 ny, spc_vec2 uv, spc_vec3 p, spc_vec3 d,
                                spc_vec3 *ny_out)
{
    *ny_out = ny;
    if (e->type == SPC_EMITTER_AREA) {
        spc_hit yh;
        memset(&yh, 0, sizeof yh);
        yh.p = y;
        yh.ng = ny;
        yh.uv = uv;
        return spc_emitter_eval_area(e, &yh, spc_neg(d));
    }
    /* point and spot: the intensity toward p, on a virtual patch facing it */
    spc_emitter_direct ds;
    *ny_out = spc_neg(d);
    if (!spc_emitter_sample_direct(e, p, spc_v2(0.5, 0.5), &ds))
        return spc_rgb1(0.0);
    return spc_rgb_scale(ds.L, ds.dist * ds.dist);
}
