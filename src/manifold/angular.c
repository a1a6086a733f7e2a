/*
 * manifold/angular.c: the angular solver. Optimizes the initial direction of a specular chain
 * (chain.c) so that its final segment passes through a target point, as in Dadfar 2022
 * (shared/papers/000): loss of sec. 5.1 (eq. 17-20) on the final segment, its gradient by the chain
 * rule (sec. 6.1, eq. 21-23), gradient descent with an adaptive step (sec. 6.5, eq. 54-55), and
 * the scale-invariant stopping rule proposed in sec. 9.1. Beyond the thesis: a Gauss-Newton step
 * on the 2x2 normal matrix of the endpoint Jacobian (the default; it converges quadratically where
 * gradient descent crawls along ill-conditioned valleys), gnomonic parameters re-centred after
 * every step instead of polar angles (sec. 6.4 has a pole), and the option of the residual on the
 * light's tangent plane.
 */
#include "manifold/angular.h"

#include "manifold/solver.h"

/* Defaults. Gauss-Newton converges quadratically once close; from a distant seed, damped steps
 * (often along a silhouette) take 10 to 30 traces. Beyond 48 the share of late successes is
 * negligible (test scene: +4% solutions from 32 to 48, +0.5% from 48 to 64), while failures end
 * earlier by the stagnation rule anyway. */
#define SPC_ANGULAR_MAX_ITERATIONS 48
/* 1e-7 of the scene's size: well below any visible feature, and 1000x under the tolerance with
 * which specular_nee.c identifies two solutions as the same. */
#define SPC_ANGULAR_TOL_SCENE 1e-7
/* 1e-5 of the light's size, so that the solved point stays on small lights. */
#define SPC_ANGULAR_TOL_LIGHT 1e-5
/* Largest step in gnomonic parameters (about 27 degrees): a bigger jump has left the region
 * where the linear model means anything. */
#define SPC_ANGULAR_MAX_STEP 0.5
/* beta below this (relative to its start) means no step along the current direction lowers the
 * loss: a local minimum that is not a solution, or a sequence boundary. 2^-20: twenty halvings in
 * a row; a Gauss-Newton step shortened a million times carries no information any more. */
#define SPC_ANGULAR_MIN_BETA 1e-6
/* Stagnation (thesis sec. 9.1, the relative change of the loss): this many accepted steps in a
 * row that each lower the loss by less than SPC_ANGULAR_STALL_DROP (relative) end the solve. A
 * converging Gauss-Newton iteration gains orders of magnitude per step; one that slides along a
 * fold of the chain's map toward a target it cannot reach gains a little, forever. Most targets
 * without a solution from the seed end here, well before max_iterations. */
#define SPC_ANGULAR_STALL_STEPS 3
#define SPC_ANGULAR_STALL_DROP 0.05
/* After a step rejected because it changed the chain's sequence of surfaces (a silhouette, a ray
 * missing the next surface), beta is held (not doubled) for this many accepted steps: solutions
 * near a boundary otherwise alternate between an accepted step and a doubled one across the
 * boundary. Measured on the caustic scene of tests/test_manifold.c: 7% more solutions in 17%
 * fewer traces than doubling at once. */
#define SPC_ANGULAR_BOUNDARY_HOLD 2
/* Levenberg-Marquardt damping: the first failure sets it to LM_MIN (a nearly undamped step), each
 * further failure multiplies it by 4; past LM_MAX the step is a gradient step a million times
 * shorter than the Gauss-Newton one and nothing lowers the loss. (LM finds 4 to 15% more solutions
 * than damped Gauss-Newton from the same seeds, bench/RESULTS.md, but spends 30% more traces on
 * targets it cannot reach; Gauss-Newton stays the default.) */
#define SPC_ANGULAR_LM_MIN 1e-3
#define SPC_ANGULAR_LM_MAX 1e6

void spc_angular_options_default(spc_angular_options *o)
{
    o->method = SPC_ANGULAR_GAUSS_NEWTON;
    o->loss = SPC_ANGULAR_LOSS_PLANE;
    o->max_iterations = SPC_ANGULAR_MAX_ITERATIONS;
    o->tol_scene = SPC_ANGULAR_TOL_SCENE;
    o->tol_light = SPC_ANGULAR_TOL_LIGHT;
    o->stall_steps = SPC_ANGULAR_STALL_STEPS;
    o->stall_drop = SPC_ANGULAR_STALL_DROP;
    o->window = 0;
    o->window_keep = 1.0;
    o->trace = NULL;
    o->trace_user = NULL;
}

/* Residual r and its Jacobian J (columns d r / da, d r / db) for the loss. */
static void residual(const spc_chain *c, const spc_angular_target *tg, spc_angular_loss loss, spc_vec3 *r,
                     spc_vec3 J[2])
{
    if (loss == SPC_ANGULAR_LOSS_PLANE && spc_length2(tg->ny) > 0.0) {
        spc_vec3 q, dq[2];
        if (spc_chain_plane_hit(c, tg->y, tg->ny, &q, dq, NULL)) {
            *r = spc_sub(q, tg->y);
            J[0] = dq[0];
            J[1] = dq[1];
            return;
        }
        /* parallel to the plane or meeting it behind: the segment loss still pulls the right way */
    }
    spc_vec3 o, d, dO[2], dd[2];
    spc_chain_final_segment(c, &o, dO, &d, dd);
    spc_vec3 w = spc_sub(o, tg->y);
    double s = -spc_dot(w, d); /* t* of eq. 19 (|d| = 1) */
    if (s > 0.0) {
        *r = spc_madd(w, d, s);
        for (int j = 0; j < 2; ++j) {
            double ds = -(spc_dot(dO[j], d) + spc_dot(w, dd[j])); /* eq. 23 */
            J[j] = spc_madd(spc_madd(dO[j], d, ds), dd[j], s);  /* eq. 22 */
        }
    } else {
        *r = w; /* t* clamped at 0: the closest point is the segment's start */
        J[0] = dO[0];
        J[1] = dO[1];
    }
}

void spc_angular_residual(const spc_chain *c, const spc_angular_target *tg, spc_angular_loss loss, spc_vec3 *r,
                          spc_vec3 J[2])
{
    residual(c, tg, loss, r, J);
}

static bool chain_ok(const spc_chain *c) { return c->end == SPC_CHAIN_END_ESCAPED || c->end == SPC_CHAIN_END_SURFACE; }

/* spc_angular_solve; with want != NULL it gives up at once if the seed chain's signature differs
 * (the solve keeps the seed's signature, so it could not end on a chain with signature want), and
 * with keep_n > 0 if the seed chain does not have keep_n vertices (the same reason). */
static bool solve(const spc_scene *sc, const spc_hit *x, const spc_angular_target *tg, spc_vec3 seed_dir,
                  const spc_chain_opts *opts, const spc_angular_options *ao, const spc_chain_sig *want,
                  int keep_n, spc_chain *out, spc_angular_result *res)
{
    res->iterations = 1;
    res->converged = false;
    res->residual = INFINITY;
    res->stop = SPC_ANGULAR_STOP_SEED;
    spc_frame fr = spc_frame_from_n(seed_dir);
    /* the hits without what only shading reads while the solve runs, the chain it ends with filled
     * in (a trace callback sees whole records) */
    spc_chain_opts so = *opts;
    so.slim = !ao->trace;
    spc_chain_trace(sc, x, &fr, 0.0, 0.0, &so, out);
    /* a seed whose final segment runs into one more chain surface (LIMIT) still fixes a sequence
     * of max_vertices surfaces; the solved chain's last segment is checked for visibility later */
    if (out->n < 1 || !(chain_ok(out) || out->end == SPC_CHAIN_END_LIMIT)) {
        if (so.slim)
            spc_chain_complete(out);
        return false;
    }
    double tol = ao->tol_scene * tg->scale;
    if (tg->light_size > 0.0)
        tol = spc_min(tol, ao->tol_light * tg->light_size);

    spc_chain_sig sig;
    spc_chain_signature(out, &sig);
    if ((want && !spc_chain_sig_equal(&sig, want)) || (keep_n > 0 && sig.n != keep_n)) {
        if (so.slim)
            spc_chain_complete(out);
        return false;
    }
    if (ao->trace)
        ao->trace(ao->trace_user, out, true);
    spc_chain_opts fo = so;
    fo.fixed = &sig;
    fo.events = NULL;
    fo.find_end = false;

    /* the kept chain and the step's, swapped on an accepted step (out holds the kept one at the end) */
    spc_chain other, *cur = out, *trial = &other;
    spc_vec3 r, J[2];
    residual(cur, tg, ao->loss, &r, J);
    double L = spc_length2(r);
    double beta = 1.0, beta0 = 1.0;
    bool gd_init = false;
    int stall = 0, hold = 0;
    const bool lm = ao->method == SPC_ANGULAR_LEVENBERG_MARQUARDT;
    double lambda = 0.0; /* Levenberg-Marquardt damping, relative to the mean of diag(J^T J) */
    spc_angular_stop stop = SPC_ANGULAR_STOP_CONVERGED;
    double L_ref = L;
    int ref_iter = res->iterations;
    while (L > tol * tol) {
        if (res->iterations >= ao->max_iterations) {
            stop = SPC_ANGULAR_STOP_MAX_ITER;
            break;
        }
        if (ao->window > 0 && res->iterations - ref_iter >= ao->window) {
            if (L > ao->window_keep * L_ref) {
                stop = SPC_ANGULAR_STOP_STALL;
                break;
            }
            L_ref = L;
            ref_iter = res->iterations;
        }
        /* g = J^T r (half the gradient of L, eq. 21), A = J^T J */
        double g0 = spc_dot(J[0], r), g1 = spc_dot(J[1], r);
        double a00 = spc_dot(J[0], J[0]), a01 = spc_dot(J[0], J[1]), a11 = spc_dot(J[1], J[1]);
        double da, db;
        double det = a00 * a11 - a01 * a01;
        if (lm) {
            double mu = 0.5 * (a00 + a11) * lambda;
            double b00 = a00 + mu, b11 = a11 + mu, dl = b00 * b11 - a01 * a01;
            if (!(dl > 0.0)) {
                stop = SPC_ANGULAR_STOP_SINGULAR;
                break;
            }
            da = -(b11 * g0 - a01 * g1) / dl;
            db = -(b00 * g1 - a01 * g0) / dl;
        } else if (ao->method == SPC_ANGULAR_GAUSS_NEWTON && det > 1e-14 * a00 * a11) {
            da = -(a11 * g0 - a01 * g1) / det;
            db = -(a00 * g1 - a01 * g0) / det;
            da *= beta;
            db *= beta;
        } else {
            double gg = g0 * g0 + g1 * g1;
            if (!(gg > 0.0)) {
                stop = SPC_ANGULAR_STOP_SINGULAR;
                break;
            }
            if (!gd_init) {
                /* first step a quarter of the distance the linearized loss says is left: the
                 * scale-free start of eq. 54 (L / |grad L| has the units of the parameters) */
                beta = beta0 = 0.25 * L / gg;
                gd_init = true;
            }
            da = -beta * g0;
            db = -beta * g1;
        }
        double len = sqrt(da * da + db * db);
        if (len > SPC_ANGULAR_MAX_STEP) {
            da *= SPC_ANGULAR_MAX_STEP / len;
            db *= SPC_ANGULAR_MAX_STEP / len;
        }
        spc_chain_trace(sc, x, &cur->frame, cur->a + da, cur->b + db, &fo, trial);
        res->iterations++;
        bool accepted = false;
        if (!chain_ok(trial) || trial->n != sig.n) {
            hold = SPC_ANGULAR_BOUNDARY_HOLD;
        } else {
            spc_vec3 r2, J2[2];
            residual(trial, tg, ao->loss, &r2, J2);
            double L2 = spc_length2(r2);
            if (L2 < L && spc_chain_recenter(trial)) {
                stall = L2 > (1.0 - ao->stall_drop) * L ? stall + 1 : 0;
                spc_chain *kept = trial;
                trial = cur;
                cur = kept;
                residual(cur, tg, ao->loss, &r, J); /* in the re-centred parameters */
                L = spc_length2(r);
                accepted = true;
            }
        }
        if (ao->trace)
            ao->trace(ao->trace_user, accepted ? cur : trial, accepted);
        if (lm) {
            /* the damping takes the place of beta: a failed step turns the next toward the
             * gradient and shortens it, a good one turns it back toward Gauss-Newton */
            if (accepted) {
                if (stall >= ao->stall_steps) {
                    stop = SPC_ANGULAR_STOP_STALL;
                    break;
                }
                lambda = lambda < SPC_ANGULAR_LM_MIN ? 0.0 : lambda * 0.25;
            } else {
                lambda = lambda > 0.0 ? lambda * 4.0 : SPC_ANGULAR_LM_MIN;
                if (lambda > SPC_ANGULAR_LM_MAX) {
                    stop = SPC_ANGULAR_STOP_MIN_BETA;
                    break;
                }
            }
            continue;
        }
        if (accepted) {
            if (stall >= ao->stall_steps && ao->method == SPC_ANGULAR_GAUSS_NEWTON) {
                stop = SPC_ANGULAR_STOP_STALL;
                break;
            }
            if (hold > 0)
                --hold;
            else
                beta *= 2.0;
            if (ao->method == SPC_ANGULAR_GAUSS_NEWTON && beta > 1.0 && det > 1e-14 * a00 * a11)
                beta = 1.0;
        } else {
            beta *= 0.5;
            if (beta < SPC_ANGULAR_MIN_BETA * beta0) {
                stop = SPC_ANGULAR_STOP_MIN_BETA;
                break;
            }
        }
    }
    if (cur != out)
        *out = *cur;
    if (out->a != 0.0 || out->b != 0.0)
        spc_chain_recenter(out);
    if (so.slim)
        spc_chain_complete(out);
    res->residual = sqrt(L);
    res->converged = L <= tol * tol;
    res->stop = res->converged ? SPC_ANGULAR_STOP_CONVERGED : stop;
    return res->converged;
}

bool spc_angular_solve(const spc_scene *sc, const spc_hit *x, const spc_angular_target *tg, spc_vec3 seed_dir,
                       const spc_chain_opts *opts, const spc_angular_options *ao, spc_chain *out,
                       spc_angular_result *res)
{
    return solve(sc, x, tg, seed_dir, opts, ao, NULL, 0, out, res);
}

bool spc_angular_solve_one(const struct spc_snee_query *q, spc_rng *rng, spc_chain *out, int *iterations)
{
    spc_vec3 seed;
    if (!spc_snee_seed_direction(q, rng, &seed))
        return false;
    spc_chain_opts o = spc_chain_opts_default(q->max_chain);
    o.any_surface = q->any_surface;
    double event_u[SPC_CHAIN_MAX_VERTICES];
    if (q->events) {
        o.events = q->events; /* trials for <1/p_solve> with reflect: the solution's events */
    } else if (q->params->reflect && q->seed != SPC_SNEE_SEED_LIGHT) {
        /* the events of the seed chain's dielectric vertices (the straight-line seed keeps the
         * BSDFs' events: it is deterministic) */
        spc_snee_attempt_event_u(q, rng, event_u);
        o.event_u = event_u;
        o.reflect_p = q->params->reflect_p;
    }
    spc_angular_target tg;
    tg.y = q->y;
    tg.ny = q->ny;
    tg.scale = q->scene->radius;
    tg.light_size = q->light_size;
    spc_angular_result res;
    bool ok = solve(q->scene, q->x, &tg, seed, &o, &q->params->angular, q->want, q->keep_n, out, &res);
    if (iterations)
        *iterations += res.iterations;
    return ok;
}
