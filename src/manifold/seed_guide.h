/*
 * manifold/seed_guide.h: seeds for the randomized specular solvers from light paths traced before
 * the render (after Fan et al. 2023, "Manifold Path Guiding", sec. 4: a chain found by a light path
 * that lands near the receiver is a good starting point for the solve there).
 *
 * Why: a randomized attempt (angular.c, newton.c) starts from a seed direction at the receiver x and
 * converges to one chain; specular NEE counts that chain 1/p times by Bernoulli trials (solver.h),
 * the number of further attempts until it is found again, of mean 1/p and variance (1 - p) / p^2.
 * With seeds uniform over the casters p is a few percent through a triangle ball or an SDF torus,
 * and the count is heavy-tailed. Light paths through the casters that land near x carry the chains
 * that light x, in proportion to the light they bring: seeding toward their last caster vertex
 * raises p of exactly the chains that matter.
 *
 *   - the pre-pass (spc_sguide_build) traces `photons` light paths from the lights toward the
 *     casters' bounding spheres (a uniform direction in the cone of a uniformly chosen caster), through
 *     chain surfaces (their delta lobes sampled in importance mode) to the first non-delta hit, and
 *     keeps, per landing point, the last caster vertex and the number of caster vertices k; the
 *     records are binned in a hash grid over the landing points (cells 1/32 of the scene's radius,
 *     seed_guide.c);
 *   - a seed at x for chains of kmin..kmax vertices (spc_sguide_seed) picks one record uniformly
 *     among those with k in range in the 2 x 2 x 2 cells nearest to x, and a direction uniform in a
 *     cone around the line from x to the record's vertex.
 * The records and the cells depend on the scene and the stream only (one thread, a fixed stream per
 * photon), so the seed distribution at x is a fixed function of x and the chain lengths: the same
 * for the first attempt and for every trial that counts it, as <1/p_solve> requires. The solver's
 * caller mixes it with the uniform seeds (share a, solver.c), so that a chain no light path found is
 * still found (defensive mixture: p >= (1 - a) p_uniform).
 */
#ifndef SPC_MANIFOLD_SEED_GUIDE_H
#define SPC_MANIFOLD_SEED_GUIDE_H

#include <stdbool.h>
#include <stdint.h>

#include "core/rng.h"
#include "scene/scene.h"

/* The pre-pass's stream: fixed, so that every seed and thread count gets the same records. */
#define SPC_SGUIDE_STREAM 0x7365656473ULL

/* Light paths of the render's pre-pass (spc_sguide_photons): aimed at the casters, so most of them
 * pass one; 65536 cost about 0.05-0.1 CPU-s on the triangle glass ball (a few traces each). */
#define SPC_SGUIDE_PHOTONS 65536

typedef struct spc_sguide spc_sguide;

/* Traces `photons` light paths (stream `seed`) through the casters (spc_chain_casters_of with
 * any_surface) and bins them. NULL where no light path lands after a caster vertex, the scene has no
 * caster or emitter, or memory runs out: the caller then seeds uniformly. Free with
 * spc_sguide_destroy. */
spc_sguide *spc_sguide_build(const spc_scene *sc, long photons, uint64_t seed, bool any_surface);
void spc_sguide_destroy(spc_sguide *g);

/* Records kept (light paths that landed after 1..SPC_CHAIN_MAX_VERTICES caster vertices). */
long spc_sguide_records(const spc_sguide *g);

/* Records with kmin <= k <= kmax in the cells the seed at x draws from (0: no guided seed there). */
long spc_sguide_count(const spc_sguide *g, spc_vec3 x, int kmin, int kmax);

/* A guided seed direction at x for chains of kmin..kmax vertices: a record near x (u picks it), and a
 * direction uniform in a cone around x -> its vertex (u2). False where no record is near x (for
 * every u), or x is the record's vertex itself: the caller then seeds uniformly. Hot path. */
bool spc_sguide_seed(const spc_sguide *g, spc_vec3 x, int kmin, int kmax, double u, spc_vec2 u2, spc_vec3 *dir);

#endif
