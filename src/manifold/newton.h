/*
 * manifold/newton.h: the Newton solver of manifold next-event estimation (Hanika, Droske and
 * Kettunen 2015, "Manifold Next Event Estimation"; Jakob and Marschner 2012, "Manifold
 * Exploration"; Zeltner, Georgiev and Jakob 2020, "Specular Manifold Sampling").
 *
 * Unknowns: the positions of the k specular vertices x_1..x_k between a fixed start x (= x_0) and a
 * fixed light point y (= x_{k+1}), each moving on its own surface, described at every iteration by
 * two orthonormal coordinates of the surface's tangent plane (so no surface parameterization, uv or
 * pole enters; the normal's derivatives come from the hit's dndu/dndv, which every shape fills).
 * Constraints, two per vertex, each depending on the vertex and its two neighbours only:
 *   HALF_VECTOR  the generalized half vector h = normalize(w_i + eta w_o) (w_i, w_o unit vectors
 *                toward the neighbours, eta = n(w_o side) / n(w_i side), 1 for a reflection)
 *                projected on the vertex's tangent frame (s, t): (h.s, h.t) (Jakob and Marschner
 *                2012, sec. 4; Hanika et al. 2015, sec. 3);
 *   ANGLE_DIFF   (default) the difference between w_o and the direction the specular law sends
 *                w_i to, in azimuthal-equidistant coordinates around that side's normal:
 *                (theta cos phi, theta sin phi)(w_o) - (...)(w_s). This is Zeltner et al.'s
 *                angle-difference constraint (sec. 5) written in coordinates that have no pole at
 *                normal incidence, where their (theta, phi) difference is undefined; beyond the
 *                critical angle w_i and w_o trade roles (the refracted direction then exists).
 * The Jacobian of the stacked constraints is block tridiagonal with 2x2 blocks; a Newton step
 * solves it by block LU (the Thomas algorithm on 2x2 blocks). The moved vertices are projected
 * back onto the surfaces by tracing from the (new) previous vertex, x for the first, toward each
 * moved position. The step is first shortened so that no vertex moves by more than half its
 * distance to the previous one (a trust region), then scaled by beta, which halves when a
 * projection misses the vertex's surface, a vertex changes from transmission to reflection or back
 * (a seed vertex on the wrong sides for its event may only be set right), the specular direction
 * does not exist, or the constraints' norm does not decrease, and doubles (up to 1) after a
 * success. Stopping: converged when the full Newton step moves no vertex farther than tol_scene
 * times the scene's size (scale invariant) and every vertex has its event's sides; failed after
 * max_iterations projections or when beta falls below min_beta (no progress), unless switch_kind
 * (default): then the solve goes on once with the other constraint kind from where it stalled.
 *
 * Rough interfaces (Zeltner et al. 2020, sec. 4.3), with rough = true: isotropic roughconductor
 * and roughdielectric surfaces of constant roughness are chain vertices too. Each gets a
 * microfacet normal m drawn from D(m) cos(m) before the solve and fixed in the vertex's local frame
 * (built from the normal and a reference vector fixed for the whole estimate), and the constraint
 * uses m's world direction as the normal. The contribution then carries f_r |cos| |dw/dm| / p(m)
 * per rough vertex and the generalized geometry term of the offset-normal chain, computed from the
 * constraint Jacobian (spc_newton_geometry). Off by default; on with the setting "newton:rough"
 * (spc_snee_parse; the estimator is rough.h's), which path.c honours: a rough chain surface is then never a receiver, and the
 * glossy paths and light samples through rough casters that specular NEE covers are dropped from
 * BSDF sampling (spc_snee_track_scatter_params, spc_snee_track_covers_light). m is drawn with the
 * roughness at the seed's hit and weighted with the one at the solution: the same for constant
 * roughness (textured roughness would need one draw per surface, not done). The
 * estimator's variance grows fast with roughness (tests/test_newton.c: alpha 0.03 renders agree
 * with ipt per pixel, alpha 0.1 only in block means at 256 spp).
 *
 * Hot path: no allocation; false means no solution.
 */
#ifndef SPC_MANIFOLD_NEWTON_H
#define SPC_MANIFOLD_NEWTON_H

#include "core/rng.h"
#include "manifold/angular.h"
#include "manifold/chain.h"

typedef enum spc_newton_constraint {
    SPC_NEWTON_HALF_VECTOR,
    SPC_NEWTON_ANGLE_DIFF
} spc_newton_constraint;

struct spc_newton_path;

typedef struct spc_newton_options {
    spc_newton_constraint constraint;
    int max_iterations;    /* projections (one ray per vertex each) per solve */
    double tol_scene;      /* converged when the Newton step moves every vertex less than this times
                              the scene's size */
    int polish_iterations; /* traces allowed to the final chain (see spc_newton_solve_one) */
    double min_beta;       /* no progress when the step scale falls below this */
    bool switch_kind;      /* on no progress, continue once with the other constraint kind */
    bool rough;            /* rough interfaces as chain vertices (see above; off by default) */
    /* Optional observer (NULL in rendering; `specula explore` records iterates with it): called
     * with the seed path (accepted) and with every projected trial path, accepted when taken, with
     * E the squared norm of its constraints (infinite if they are undefined there). It changes
     * nothing the solve does. */
    void (*trace)(void *user, const struct spc_newton_path *p, double E, bool accepted);
    void *trace_user;
} spc_newton_options;

/* ANGLE_DIFF (SPC_NEWTON_DEFAULT_CONSTRAINT), SPC_NEWTON_MAX_ITERATIONS, tol_scene
 * SPC_NEWTON_TOL_SCENE, polish SPC_NEWTON_POLISH_ITERATIONS, min_beta SPC_NEWTON_MIN_BETA, rough off
 * (newton.c). */
void spc_newton_options_default(spc_newton_options *o);

typedef struct spc_newton_vertex {
    spc_hit h;     /* the vertex on its surface (shape_index fixes the surface) */
    int event;     /* spc_chain_event */
    double eta;    /* the BSDF's n_inside / n_outside for a refraction; 1 for a reflection */
    bool rough;    /* rough interface with the microfacet normal m */
    spc_vec3 m;    /* microfacet normal in the local frame (s, t, n); (0, 0, 1) for a smooth one */
} spc_newton_vertex;

typedef struct spc_newton_path {
    int n; /* vertices, 1..SPC_CHAIN_MAX_VERTICES */
    spc_newton_vertex v[SPC_CHAIN_MAX_VERTICES];
    /* Reference of the local frames: s = normalize(ref - n (n . ref)), t = n x s. (0,0,0): a tangent
     * of each vertex's geometric tangent plane at the current iterate (smooth chains, where the
     * frame's rotation does not change the solutions). Rough chains need one fixed vector. */
    spc_vec3 ref;
} spc_newton_path;

/* Why a solve stopped (for benchmarks and diagnostics). */
typedef enum spc_newton_stop {
    SPC_NEWTON_CONVERGED,
    SPC_NEWTON_STOP_SEED,       /* the constraints are undefined at the seed */
    SPC_NEWTON_STOP_SINGULAR,   /* a singular pivot block (a caustic of the light) */
    SPC_NEWTON_STOP_ITERATIONS, /* max_iterations projections */
    SPC_NEWTON_STOP_PROGRESS,   /* beta below its minimum: no step lowered the constraints */
    SPC_NEWTON_STOP_SIDES       /* converged with a vertex on the wrong sides for its event */
} spc_newton_stop;

typedef struct spc_newton_result {
    int iterations;  /* projections done */
    double step;     /* length of the last full Newton step (largest vertex move) */
    bool converged;
    spc_newton_stop stop;
} spc_newton_result;

/* Builds a seed path (classic MNEE): every chain surface the straight segment from x to y crosses
 * becomes a vertex, with its BSDF's event. False if the segment is blocked by another surface, or
 * crosses no chain surface or more than max_vertices. rough_u (NULL for smooth chains only): two
 * uniform numbers per vertex index for the microfacet normals of rough vertices. */
bool spc_newton_seed_straight(const spc_scene *sc, const spc_hit *x, spc_vec3 y, int max_vertices, bool any_surface,
                              const double (*rough_u)[2], spc_vec3 ref, spc_newton_path *p);
/* Builds a seed path by tracing from x along dir (unit) through the chain surfaces (reflecting or
 * refracting about each vertex's normal, its microfacet normal for rough ones), as specular manifold
 * sampling does. The seed ends after max_vertices vertices, at the first surface that is not a chain
 * surface, on escaping, or at a vertex where the refraction is totally reflected (that vertex
 * included). False if there is no vertex. */
bool spc_newton_seed_trace(const spc_scene *sc, const spc_hit *x, spc_vec3 dir, int max_vertices, bool any_surface,
                           const double (*rough_u)[2], spc_vec3 ref, spc_newton_path *p);
/* Is h on a rough chain surface (the shape's own BSDF an isotropic roughconductor, reflecting, or
 * roughdielectric, refracting; no emitter; a caster unless any_surface)? event: its chain event. */
bool spc_newton_rough_surface(const spc_hit *h, bool any_surface, int *event);

/* The Newton path of a traced chain (smooth vertices). */
void spc_newton_path_from_chain(const spc_chain *c, spc_newton_path *p);

/* Solves in place: p holds the seed and, on success, the solution. x->err and x->ng offset the
 * first projection ray (a free point may pass err = 0). */
bool spc_newton_solve(const spc_scene *sc, const spc_hit *x, spc_vec3 y, spc_newton_path *p,
                      const spc_newton_options *o, spc_newton_result *res);

/* The constraints of p between x and y (c[i], 2 per vertex) and the blocks of their Jacobian with
 * respect to the tangent coordinates of the previous, own and next vertex: A[i] (A[0] is zero),
 * B[i], C[i], where C[n-1] is the derivative with respect to y moving in the plane of normal ny
 * (coordinates along spc_frame_from_n(ny).s, .t; zero if ny is (0,0,0)). The tangent coordinates
 * of vertex i run along basis[i][0], basis[i][1] (orthonormal, in the geometric tangent plane).
 * False if a vertex is on the wrong side for its event, its specular direction does not exist
 * (ANGLE_DIFF), or a surface parameterization is degenerate. */
bool spc_newton_constraints(spc_vec3 x, const spc_newton_path *p, spc_vec3 y, spc_vec3 ny,
                            spc_newton_constraint kind, double c[][2], double A[][2][2], double B[][2][2],
                            double C[][2][2], spc_vec3 basis[][2]);

/* Solves the block-tridiagonal system A[i] X[i-1] + B[i] X[i] + C[i] X[i+1] = R[i] (i = 0..n-1;
 * A[0] and C[n-1] unused) by block LU without pivoting between blocks (Thomas algorithm). False if
 * a pivot block is singular. */
bool spc_newton_block_solve(int n, const double A[][2][2], const double B[][2][2], const double C[][2][2],
                            const double R[][2], double X[][2]);

/* Generalized geometry term |dw(x) / dA(y)| of the solved path toward y on a surface of unit normal
 * ny (point light: ny = unit vector from y to the last vertex) from the constraint Jacobian (Jakob
 * and Marschner 2012, sec. 4.3: the derivative of the first vertex with respect to y by the
 * implicit function theorem). 0 if degenerate. */
double spc_newton_geometry(spc_vec3 x, const spc_newton_path *p, spc_vec3 y, spc_vec3 ny,
                           spc_newton_constraint kind);

/* The chain (chain.h) of a solved path: traced from x toward its first vertex with its signature
 * and refined by at most `polish` Gauss-Newton steps in direction space (spc_angular_solve with the
 * target tg), which absorbs the ray offsets the tracer applies at every vertex. False if that does
 * not converge. */
bool spc_newton_to_chain(const spc_scene *sc, const spc_hit *x, const spc_newton_path *p,
                         const spc_angular_target *tg, const spc_angular_options *ao, int polish, bool any_surface,
                         spc_chain *out, int *iterations);

struct spc_snee_query;
/* The solver-table entry (solver.h): seed from the query's seed mode, Newton solve, then
 * spc_newton_to_chain with polish_iterations; the interface computes the contribution from that
 * chain. */
bool spc_newton_solve_one(const struct spc_snee_query *q, spc_rng *rng, spc_chain *out, int *iterations);

/* The world direction of the (offset) normal of v: the shading normal, or for a rough vertex its
 * microfacet normal in the local frame built from the normal and ref. */
spc_vec3 spc_newton_vertex_normal(const spc_newton_vertex *v, spc_vec3 ref);

#endif
