/*
 * manifold/sphere_chains.h: every specular chain through one sphere, exactly.
 *
 * The chains' planar roots (sphere_roots.h), each polished in 3D by the angular solver from its
 * direction (which also proves every segment unblocked). So the chains a randomized solver finds
 * with a heavy-tailed trial count (a glass ball's second solutions near its contact point) are
 * summed exactly, psi = 1 (specular_nee.h).
 *
 * Spheres handled: SPC_SHAPE_SPHERE with outward normals, a smooth dielectric or conductor (a
 * two-sided conductor too), no normal map, no emitter; x outside the sphere. Chains per sphere:
 * conductor: R (one reflection); dielectric: T T, and with reflections at dielectric vertices
 * (spc_snee_params.reflect) also R and T R^m T, up to the query's max_chain vertices.
 */
#ifndef SPC_MANIFOLD_SPHERE_CHAINS_H
#define SPC_MANIFOLD_SPHERE_CHAINS_H

#include <stdbool.h>

#include "manifold/chain.h"

struct spc_snee_query;

/* Is s a sphere these chains handle? */
bool spc_sphere_chain_shape(const spc_shape *s);
/* Is c one of the chains spc_sphere_chains_all enumerates (all vertices on one such sphere, x
 * outside it, events R or T R^m T; reflect: whether reflections at dielectric vertices are chain
 * events)? */
bool spc_sphere_chain_covers(const spc_chain *c, bool reflect);
/* Is s such a sphere, and x outside it (the chains from x it enumerates are every chain on s)? */
bool spc_sphere_chain_usable(const spc_shape *s, spc_vec3 x);
/* Every such chain from q->x to q->y (at most max_out, written to out, polished and traced: each
 * segment before the last proven unblocked; the last is checked by spc_snee_chain_value). Adds the
 * chain traces it spends to *iterations. */
int spc_sphere_chains_all(const struct spc_snee_query *q, spc_chain *out, int max_out, int *iterations);

#endif
