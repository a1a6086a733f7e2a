/*
 * manifold/unfold_chains.h: every specular chain through one sphere and one flat mirror, exactly.
 *
 * A flat mirror is an isometry: mirrored across its plane, the part of a chain past the mirror's
 * vertex continues the part before it in a straight line. So a chain x - sphere - mirror - y (the
 * sphere's vertices first) is, unfolded, a chain on the same sphere from x to y', the light point
 * mirrored, whose last segment crosses the mirror's plane inside its face; and a chain
 * x - mirror - sphere - y is a chain from x on the mirrored sphere to y', whose first segment crosses
 * the plane there. Both are the one-sphere problem (sphere_roots.h), solved exactly on the images;
 * each root's first direction is the real chain's first direction (the path before the mirror is not
 * moved), and the angular solver's polish traces it in the real scene (spc_snee_exact_polish_shapes),
 * which proves the mirror vertex inside its face, the events, and every segment before the last
 * unblocked. Every chain of the class is found: a real chain unfolds to one of the image problem's
 * roots, and the planar enumeration finds them all.
 *
 * Most image problems have no chain (on bench/check/ball_mirror_wall.xml the polish of roots that
 * cross the plane outside the face was 30% of the render), so exact early-outs come first: an order
 * whose mirror vertex would face a one-sided mirror's back, or where no ray from x (mirror first) or
 * y' (sphere first) through the face meets the sphere's image or the sphere, is not solved; a root
 * whose unfolded segment crosses the plane outside the face is not polished. Each rejects only
 * roots without a chain (margins far above the roots' error).
 *
 * Class (spc_unfold_chain_covers): 2 to SPC_UNFOLD_MAX_VERTICES vertices, one on a flat mirror (a
 * conductor that flat_chains.h takes) and first or last, the others on one sphere that
 * sphere_chains.h takes, forming one of its chains of at most two vertices: a mirror ball's R, a
 * glass ball's T T, and with reflections off glass (spc_snee_params.reflect) its R; the receiver
 * outside the sphere's image in the order's frame. Longer mixed chains (the glass ball's foot on
 * the mirror, T T R T T) stay with the randomized attempts.
 */
#ifndef SPC_MANIFOLD_UNFOLD_CHAINS_H
#define SPC_MANIFOLD_UNFOLD_CHAINS_H

#include <stdbool.h>

#include "manifold/chain.h"

struct spc_snee_query;

/* The longest chain of the class: two vertices on the sphere (a glass ball's way through) and the
 * mirror's. */
#define SPC_UNFOLD_MAX_VERTICES 3

/* Is s a flat mirror these chains take (flat_chains.h's shape, a conductor)? */
bool spc_unfold_mirror_shape(const spc_shape *s);
/* Is c one of the chains spc_unfold_chains_all enumerates (the class above; reflect as
 * spc_snee_params.reflect)? */
bool spc_unfold_chain_covers(const spc_chain *c, bool reflect);
/* Every such chain from q->x to q->y of q->min_chain (0: 2) to q->max_chain vertices (capped at
 * SPC_UNFOLD_MAX_VERTICES), at most max_out, written to out (polished and traced: each segment before
 * the last proven unblocked; the last is checked by spc_snee_chain_value). Adds the chain traces it
 * spends to *iterations. */
int spc_unfold_chains_all(const struct spc_snee_query *q, spc_chain *out, int max_out, int *iterations);

/* ---- exposed for tests ---- */

/* What one enumeration did: the planar roots it met, those it polished into chains, and those it
 * rejected unpolished (their unfolded segment misses the mirror's face), with the orders it skipped
 * before solving (the mirror's back faces the chain, or no ray through the face from x, or from the
 * mirrored light point, meets the sphere or its image). */
typedef struct spc_unfold_tally {
    long roots, chains, roots_culled, orders_culled;
} spc_unfold_tally;
/* spc_unfold_chains_all (cull true) or the same without its early-outs (cull false: every root
 * polished, every order solved); the chains are the same. Adds to *tally (may be NULL). */
int spc_unfold_chains_cull(const struct spc_snee_query *q, spc_chain *out, int max_out, int *iterations, bool cull,
                           spc_unfold_tally *tally);

/* p mirrored across the plane n . p = d (n a unit vector). */
spc_vec3 spc_unfold_mirror_point(spc_vec3 p, spc_vec3 n, double d);

#endif
