/*
 * manifold/plane_chains.h: every one-vertex chain through a normal-mapped plane, exactly.
 *
 * A water surface or a rippled mirror modelled as a flat mesh under a tangent-space normal map
 * (bsdf normalmap over a smooth dielectric or conductor, a bilinear bitmap): the light at y reaches
 * x through the plane wherever the map's normal is parallel to the generalized half vector
 *
 *     h(p) = eta_x w_x(p) + eta_y w_y(p)    (w_x, w_y the unit directions from p to x and to y;
 *                                           eta the index on each side; 1, 1 for a reflection),
 *
 * one point for each image of the light in the ripples, often several. The randomized solver
 * finds them one at a time with a heavy-tailed trial count; here they are enumerated.
 *
 * The plane's points are affine in the texture's texel coordinates (s, t) (the bilinear
 * interpolant's cells are the unit squares between texel centres), and inside one cell the
 * unnormalized normal m(a, b) is the bilinear blend of the four texels' vectors (2 rgb - 1 in the
 * constant frame (S, T, N) of the plane). A cell holds a solution where F = (h_S m_N - h_N m_S,
 * h_T m_N - h_N m_T) vanishes. Cells are culled through a pyramid of bounds over the map (each
 * node: the range of m's components and of its slopes m_S / m_N, m_T / m_N over its texels, which
 * bound every blend of them), against the exact range of each component of w_x and w_y over the
 * node's rectangle of the plane; a surviving cell is split twice into quarters culled the same
 * way, and Newton's method (backtracking on |F|) on the cell's own bilinear F from each surviving
 * piece that holds no root yet finds the roots inside the cell. Where x is on the normal's side,
 * a second pass does the same for the normals the BSDF turns toward x
 * (spc_bsdf_perturbed_face_view: tangential part negated), keeping the roots where the turn
 * applies; the first pass keeps those where it does not. Each root is polished in 3D by the angular solver
 * (spc_snee_exact_polish), whose trace proves the first segment unblocked.
 *
 * What is missed: a pair of roots in one sixteenth of a cell that Newton's steps from the
 * surviving pieces reach as one (a fold of the caustic, where the pair's contribution tends to
 * zero width).
 *
 * Planes handled: a mesh whose vertices lie in one plane, with one shading normal (face normals,
 * or vertex normals all along it), texture coordinates affine in the position, no emitter; BSDF
 * normalmap over a smooth dielectric or conductor, its bitmap bilinear with a to_uv that maps u
 * and v separately (scale and offset). Chains: one vertex; a refraction where x and y are on
 * opposite sides (dielectric), a reflection where on the same side (conductor; dielectric with
 * spc_snee_params.reflect).
 */
#ifndef SPC_MANIFOLD_PLANE_CHAINS_H
#define SPC_MANIFOLD_PLANE_CHAINS_H

#include <stdbool.h>

#include "manifold/chain.h"

struct spc_snee_query;

/* Is s a normal-mapped plane these chains handle? (Builds its cull pyramid on first use.) */
bool spc_plane_chain_shape(const spc_shape *s);
/* Is c one of the chains spc_plane_chains_all enumerates (one vertex on such a plane, the event
 * its sides call for, reflect as spc_snee_params.reflect)? */
bool spc_plane_chain_covers(const spc_chain *c, bool reflect);
/* Every such chain from q->x to q->y, each passed to fn as it is found (polished and traced: the
 * first segment proven unblocked; the last is checked by spc_snee_chain_value), so that a point
 * that sees dozens of glints needs no array of chains. reflect as spc_snee_params.reflect. Adds the
 * chain traces it spends to *iterations; returns the number of chains. */
int spc_plane_chains_each(const struct spc_snee_query *q, bool reflect, void (*fn)(void *user, const spc_chain *c),
                          void *user, int *iterations);
/* The same, written to out (at most max_out). */
int spc_plane_chains_all(const struct spc_snee_query *q, bool reflect, spc_chain *out, int max_out,
                         int *iterations);

/* ---- exposed for tests ---- */

/* The unnormalized mapped normal of plane s at world point p as the enumeration models it (its
 * components along the plane's frame S, T, N, written to m[3]); false if s is not such a plane. */
bool spc_plane_chain_model_normal(const spc_shape *s, spc_vec3 p, double m[3], spc_vec3 frame[3]);
/* The roots (world points on the plane) of the half-vector condition for x and y, at most max;
 * before the 3D polish. refract: eta on each side as the BSDF's, else a reflection. */
int spc_plane_chain_roots(const spc_shape *s, spc_vec3 x, spc_vec3 y, bool refract, spc_vec3 *out, int max);
/* The same with the culling test compiled for the base ISA, whatever the CPU; *other: whether
 * spc_plane_chain_roots uses another build of it (AVX2) on this CPU. */
int spc_plane_chain_roots_base_isa(const spc_shape *s, spc_vec3 x, spc_vec3 y, bool refract, spc_vec3 *out, int max,
                                   bool *other);

#endif
