/*
 * manifold/sphere_chains.h: every specular chain through one sphere, exactly.
 *
 * A chain that stays on one sphere (the light reflected off it; refracted in, reflected inside m
 * times, refracted out) lies in the plane through x, y and the sphere's centre: every normal is
 * radial, so each reflection and refraction keeps the direction in the plane that holds the
 * incoming ray and the centre. In that plane the chain is a function of one number, the angle of
 * its entry point on the circle seen from x, and a solution is a root of the signed distance
 * between y and the chain's final line. The roots are isolated on a grid over the arc x sees
 * (sign changes, and pairs of roots between samples where the samples have a local extremum that
 * crosses zero: near a fold of the caustic), refined by bracketed secant steps, and each is
 * polished in 3D by the angular solver from its direction (which also proves every segment
 * unblocked). So the chains a randomized solver finds with a heavy-tailed trial count (a glass
 * ball's second solutions near its contact point) are summed exactly, psi = 1 (specular_nee.h).
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
/* Is every point P of the unit circle's arc from p0 to p1 (counterclockwise, less than half a turn;
 * each given as (cos t, sin t)) behind its tangent line as seen from y = (y1, y2), i.e. y . P < 1
 * there (with a margin of 1e-9)? A chain that leaves the circle by an outside reflection at such a
 * point cannot reach y (the reflected ray leaves the tangent line on the far side from y), so no
 * root of that chain lies there. */
bool spc_sphere_arc_unseen(double y1, double y2, const double p0[2], const double p1[2]);

/* Every such chain from q->x to q->y (at most max_out, written to out, polished and traced: each
 * segment before the last proven unblocked; the last is checked by spc_snee_chain_value). Adds the
 * chain traces it spends to *iterations. */
int spc_sphere_chains_all(const struct spc_snee_query *q, spc_chain *out, int max_out, int *iterations);

/* The planar problem on the unit circle (exposed for tests): x at (d, 0) with d > 1, y at (y1, y2);
 * m internal reflections (-1: one external reflection); eta the relative index inside / outside.
 * Writes the roots (entry-point angles theta, the entry point (cos theta, sin theta)) of chains that
 * reach y, at most max_roots; returns their number. */
int spc_sphere_chain_roots(double d, double y1, double y2, int m, double eta, double *theta, int max_roots);

#endif
