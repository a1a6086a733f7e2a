/*
 * manifold/cylinder_chains.h: every chain of reflections on one mirror cylinder, exactly (the
 * coffee-cup caustic: the inside wall of a cup or ring focusing a lamp on the floor).
 *
 * A cylinder's normals are perpendicular to its axis, so a reflection keeps the direction's axial
 * component and reflects the transverse one in the cross-section: projected along the axis, a
 * chain is a billiard path in the cross-section's ellipse (a circle for a round cylinder), and the
 * axial height grows in proportion to the projected length, the same slope on every segment. The
 * projected problem is a function of one angle, the first vertex's on the ellipse (over the whole
 * ellipse: from inside every point is in view, and from outside a segment may pass over the rim
 * and meet the wall from inside); its roots (roots1d.h) give the chains, whose vertex heights
 * follow from the slope and must lie on the wall. Each is polished in 3D by the angular solver,
 * whose trace proves the segments before the last unblocked (a projected crossing of the wall below
 * the rim is a hit there: another chain). Chains: k = 1 .. max_chain reflections, all on one
 * cylinder whose BSDF is a smooth conductor (or a two-sided one); reflections off the outside end a
 * chain (convex), those inside follow the chords.
 */
#ifndef SPC_MANIFOLD_CYLINDER_CHAINS_H
#define SPC_MANIFOLD_CYLINDER_CHAINS_H

#include <stdbool.h>

#include "manifold/chain.h"

struct spc_snee_query;

/* Is s a cylinder these chains handle? */
bool spc_cylinder_chain_shape(const spc_shape *s);
/* Is c one of the chains spc_cylinder_chains_all enumerates (every vertex a reflection on one such
 * cylinder)? */
bool spc_cylinder_chain_covers(const spc_chain *c);
/* Every such chain from q->x to q->y (at most max_out, written to out, polished and traced); adds the
 * chain traces it spends to *iterations. */
int spc_cylinder_chains_all(const struct spc_snee_query *q, spc_chain *out, int max_out, int *iterations);

/* The projected problem (exposed for tests): the ellipse E(phi) = u cos(phi) + v sin(phi) (2D,
 * centred at the origin), x and y projected (x2, y2), k reflections. Writes the roots phi (in
 * [0, 2 pi)) at most max_roots, with for each the projected lengths from x to every vertex
 * (len[r * k + j], j < k) and the total to y (total[r]); returns their number. */
int spc_cylinder_chain_roots(const double u[2], const double v[2], const double x2[2], const double y2[2], int k,
                             double *phi, double *len, double *total, int max_roots);

#endif
