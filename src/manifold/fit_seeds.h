/*
 * manifold/fit_seeds.h: seeds of the randomized attempts from a fitted sphere.
 *
 * A triangle mesh that approximates a ball (a tessellated glass or mirror ball) has its chains close
 * to those of the sphere that fits it, which sphere_chains.h enumerates exactly. Seeded uniformly in
 * the cone toward the mesh, an attempt finds the ball's second caustic sheet, its rim and its
 * reflections with probabilities of a few percent, and their Bernoulli trial counts (1 / p) are
 * the triangle ball's fireflies. With the fit, a share of the attempts (SPC_FIT_SEED_SHARE, only
 * where the caster drawn has a fit) start along the direction toward an exact solution on the fitted
 * sphere, one of them uniformly, and the solver converges to the mesh's chain nearby: every chain
 * the sphere has then has a probability of at least about the share over the number of solutions.
 *
 * The seed mixture is a function of the query's x, y, chain lengths and the scene alone (not of the
 * events or the chain being counted), so the first attempt and every Bernoulli trial that counts its
 * chain draw from the same distribution and the count stays an unbiased 1 / p of the mixture's p
 * (as for seed_guide.h). The fitted sphere's solutions are computed once per query (spc_fit_roots,
 * shared by the query's copies) and reused by its trials.
 */
#ifndef SPC_MANIFOLD_FIT_SEEDS_H
#define SPC_MANIFOLD_FIT_SEEDS_H

#include <stdbool.h>

#include "core/math.h"
#include "core/rng.h"
#include "manifold/chain.h"
#include "manifold/sphere_roots.h"
#include "scene/shape.h"

struct spc_snee_query;

/* The share of a randomized attempt's seeds drawn from the fitted sphere's solutions where the caster
 * picked has a fit and solutions exist: at floor points in the triangle ball's caustic the rare sheet's
 * p goes from 0.02-0.05 to 0.17-0.19 and the main chain's from 0.6 to 0.47 (test_fit_seeds; other
 * shares not measured; bench/RESULTS.md, "Tails 3"). */
#define SPC_FIT_SEED_SHARE 0.5
/* From a point inside a fitted ball (a medium inside a glass ball), the seeds drawn uniformly in a
 * cone of this cosine (5 degrees) around the fitted sphere's solution: the mesh's chain that leaves
 * near the rim (the way out near grazing) lies 1.4-2.4 degrees from the sphere's on
 * scenes/medium_glass.xml, where the exact direction found it in none of 200 solves and cones of 4-8
 * degrees in 17-31% of them. */
#define SPC_FIT_INSIDE_COS 0.99619469809174553
/* Directions kept per shape and query. */
#define SPC_FIT_MAX_DIRS 16
/* Fitted shapes and chain lengths (the long pass's copies of a query) whose directions a query keeps
 * (more: recomputed at each attempt). */
#define SPC_FIT_MAX_SHAPES 4

/* The fitted sphere's solution directions from a query's x to its y, per shape and chain lengths,
 * filled on first use (the caller zeroes nshapes and points spc_snee_query.fit at it for the query
 * and its copies, which share its x and y). */
typedef struct spc_fit_roots {
    int nshapes;
    struct {
        const spc_shape *s;
        int min_chain, max_chain;
        int n;
        spc_vec3 dir[SPC_FIT_MAX_DIRS];
        signed char m[SPC_FIT_MAX_DIRS]; /* each solution's internal reflections; -1: one reflection */
        /* the planar roots (sphere_roots.h) of the signatures computed with this entry (bit m + 1 of
         * have), which a later entry for the same shape takes instead of computing them again */
        unsigned have;
        int nr[SPC_SPHERE_SIGNATURES];
        double theta[SPC_SPHERE_SIGNATURES][SPC_SPHERE_MAX_ROOTS];
    } e[SPC_FIT_MAX_SHAPES];
} spc_fit_roots;

/* The sphere fitted to s (a triangle mesh with a smooth specular interface whose vertices all lie
 * within a few percent of one sphere, filling its bounding box as a ball does): true with its centre
 * and radius, false for every other shape. Built on first use and kept in s (thread-safe). */
bool spc_fit_sphere(const spc_shape *s, spc_vec3 *center, double *radius);
/* The longest edge of s over the radius of the sphere fitted to it (about the angle an edge
 * subtends at the centre; a UV sphere of 48 x 25 faces: 0.18), 0 where s has no fit: how far a
 * facet's plane tilts against its interpolated normals. */
double spc_fit_edge_angle(const spc_shape *s);

/* A seed direction for q's attempt toward caster s from the fitted sphere's solutions: with
 * probability SPC_FIT_SEED_SHARE, or q's params.fit_share where set (one uniform from rng, drawn
 * only where s has a fit) one of those solutions' first directions, uniformly (a second uniform).
 * False where the attempt seeds as before (no fit, no solution, or the other share). */
bool spc_fit_seed(const struct spc_snee_query *q, const spc_shape *s, spc_rng *rng, spc_vec3 *dir);

/* A smooth specular SDF whose field is one torus (a glass SDF torus): true with its centre, unit
 * axis, major and minor radii in world units, false for every other shape. Its seeds (spc_fit_seed)
 * are the exact solutions of spheres of the tube's radius on its core circle near the query (kept in
 * q->fit like a ball's), for chains of at most two vertices; spc_fit_root_count and
 * spc_fit_roots_of stay 0 for it (no ball pass, no chains counted exactly). Built on first use and
 * kept in s (thread-safe). */
bool spc_fit_torus(const spc_shape *s, spc_vec3 *center, spc_vec3 *axis, double *major, double *minor);

/* The number of the fitted sphere's solutions that spc_fit_seed draws from for q and caster s (of
 * q's chain lengths, from its x to its y; kept in q->fit like them): 0 where s has no fit. */
int spc_fit_root_count(const struct spc_snee_query *q, const spc_shape *s);
/* spc_fit_root_count, with the roots of chains of min_chain..max_chain vertices computed on the same
 * grid and kept in q->fit for the query of those lengths that shares q's x and y (the query whose
 * longer chains q looks for): one pass over the arc for both (the same roots). */
int spc_fit_root_count_with(const struct spc_snee_query *q, const spc_shape *s, int min_chain, int max_chain);

/* The fitted sphere's solutions of spc_fit_root_count: at most max first directions written to dir
 * and their events to m (the internal reflections between the way in and the way out; -1 for one
 * reflection off the outside). Returns their number, 0 where s has no fit. */
int spc_fit_roots_of(const struct spc_snee_query *q, const spc_shape *s, spc_vec3 *dir, int *m, int max);

/* The chain of one of spc_fit_roots_of's solutions, whose events are m (its internal reflections;
 * -1 for one reflection off the outside): returns its number of vertices (1 for m = -1, else m + 2)
 * and, where that is at most SPC_CHAIN_MAX_VERTICES, writes its events to ev (a reflection or
 * the way in and out by refraction; refractions past the chain), the events a solver's attempt
 * seeded along that solution is held to. */
int spc_fit_root_events(int m, unsigned char ev[SPC_CHAIN_MAX_VERTICES]);

#endif
