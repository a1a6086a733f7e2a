/*
 * manifold/angular.h: the angular solver (Dadfar 2022, sec. 6.5 and 9.1): find the initial
 * direction at x whose specular chain ends on the target point y, by minimizing over the two
 * direction parameters of a chain (chain.h) the squared distance between y and the chain's final
 * segment.
 *
 * Losses (the residual r is a 3-vector, the loss |r|^2):
 *   SEGMENT  r = y's offset from the closest point of the final segment, a half-line (thesis eq.
 *            17-20 restricted to the last segment; t* is clamped at 0 as the thesis clamps it).
 *   PLANE    r = offset between y and the point where the final segment meets the tangent plane
 *            of the light's surface at y (needs the light's normal; points use SEGMENT).
 * Methods:
 *   GAUSS_NEWTON  step -(J^T J)^-1 J^T r on the 3x2 Jacobian of the endpoint, scaled by beta;
 *   GRADIENT      the thesis' gradient descent, step -beta grad L (eq. 54-55);
 *   LEVENBERG_MARQUARDT  -(J^T J + lambda mean(diag) I)^-1 J^T r: Gauss-Newton that bends toward
 *                 the gradient after a failed step instead of only shortening it;
 * In the first two, beta doubles after a step that lowers the loss (up to 1 for Gauss-Newton) and
 * halves after one that raises it or changes the chain's sequence of surfaces and events (which is
 * part of the solution: such steps are shortened, never taken; after one, beta is held for two
 * accepted steps). After each accepted step the chain is re-expressed around its new direction
 * (spc_chain_recenter), so the parameters never approach the gnomonic chart's horizon.
 * Stopping: converged when |r| <= tol_scene * scene size and, for a light of linear size s > 0,
 * |r| <= tol_light * s, so the same settings hold at every scale (thesis sec. 9.1); failed after
 * max_iterations traces, when beta (or LM's damping) says no step lowers the loss, or (Gauss-Newton,
 * LM) after three accepted steps in a row that each lower the loss by less than 5% (stagnation
 * against a fold or silhouette, sec. 9.1's relative change of the loss).
 */
#ifndef SPC_MANIFOLD_ANGULAR_H
#define SPC_MANIFOLD_ANGULAR_H

#include "core/rng.h"
#include "manifold/chain.h"

typedef enum spc_angular_method {
    SPC_ANGULAR_GAUSS_NEWTON,
    SPC_ANGULAR_GRADIENT,
    SPC_ANGULAR_LEVENBERG_MARQUARDT
} spc_angular_method;

typedef enum spc_angular_loss {
    SPC_ANGULAR_LOSS_SEGMENT,
    SPC_ANGULAR_LOSS_PLANE
} spc_angular_loss;

typedef struct spc_angular_options {
    spc_angular_method method;
    spc_angular_loss loss;
    int max_iterations; /* chain traces per solve, the seed's included */
    double tol_scene;   /* residual tolerance relative to the scene's size */
    double tol_light;   /* residual tolerance relative to the light's linear size */
    /* Stagnation: stall_steps accepted steps in a row that each lower the loss by less than the
     * fraction stall_drop end the solve; and (progress window, 0 = off) the solve ends when
     * window traces have not brought the loss below window_keep times its value before them. */
    int stall_steps;
    double stall_drop;
    int window;
    double window_keep;
    /* Optional observer (NULL in rendering; `specula explore` records iterates with it): called
     * with every chain the solve traces, the seed's first, then each trial step's, with accepted
     * true for the seed and for steps taken (such a chain is re-centred, a = b = 0). It sees the
     * chains only and changes nothing the solve does. */
    void (*trace)(void *user, const spc_chain *c, bool accepted);
    void *trace_user;
} spc_angular_options;

/* Gauss-Newton, PLANE loss, 48 iterations, tol_scene 1e-7, tol_light 1e-5 (see angular.c). */
void spc_angular_options_default(spc_angular_options *o);

typedef struct spc_angular_target {
    spc_vec3 y;        /* the point to reach */
    spc_vec3 ny;       /* unit normal of the light's surface at y; (0,0,0) for a point */
    double scale;      /* the scene's size (scene->radius) */
    double light_size; /* the light's linear size (sqrt of its area); 0 for a point */
} spc_angular_target;

/* The residual r of the loss (|r|^2 the loss) of chain c toward the target, and its Jacobian J
 * (columns dr/da, dr/db at c's parameters): the quantities the solver steps with. */
void spc_angular_residual(const spc_chain *c, const spc_angular_target *tg, spc_angular_loss loss, spc_vec3 *r,
                          spc_vec3 J[2]);

/* Why a solve ended (for profiling). */
typedef enum spc_angular_stop {
    SPC_ANGULAR_STOP_CONVERGED,
    SPC_ANGULAR_STOP_SEED,      /* the seed's chain is unusable (no vertex, TIR, degenerate) */
    SPC_ANGULAR_STOP_MAX_ITER,  /* max_iterations traces */
    SPC_ANGULAR_STOP_STALL,     /* accepted steps that barely lower the loss */
    SPC_ANGULAR_STOP_MIN_BETA,  /* no step along the current direction lowers the loss */
    SPC_ANGULAR_STOP_SINGULAR   /* zero gradient or singular damped system */
} spc_angular_stop;

typedef struct spc_angular_result {
    int iterations;  /* chain traces done */
    double residual; /* |r| at the end */
    bool converged;
    spc_angular_stop stop;
} spc_angular_result;

/* Traces the seed chain from x along seed_dir (unit) with opts (its signature becomes the one to
 * keep; it needs 1 or more vertices and a final segment that is not blocked by another chain
 * surface), then iterates. On success *out holds the solved chain, re-centred (a = b = 0). The
 * chain's final segment is not checked for visibility. Hot path: false means no solution. */
bool spc_angular_solve(const spc_scene *sc, const spc_hit *x, const spc_angular_target *tg, spc_vec3 seed_dir,
                       const spc_chain_opts *opts, const spc_angular_options *ao, spc_chain *out,
                       spc_angular_result *res);

struct spc_snee_query;
/* The solver-table entry (solver.h): one seeded attempt for the query. */
bool spc_angular_solve_one(const struct spc_snee_query *q, spc_rng *rng, spc_chain *out, int *iterations);

#endif
