/*
 * manifold/snee_cost.h: exact tests that spare specular NEE (specular_nee.h) work that cannot add
 * anything, so that its estimate stays the same, bit for bit, only cheaper; and the probabilities
 * of its Russian roulette (unbiased, not bit for bit: spc_snee_query_prob, spc_snee_later_prob).
 */
#ifndef SPC_MANIFOLD_SNEE_COST_H
#define SPC_MANIFOLD_SNEE_COST_H

#include <stdbool.h>

#include "manifold/chain.h"
#include "manifold/solver.h"

/* Does no chain of at most max_chain vertices from x visit two of the casters cs? True when every
 * caster is a sphere that sphere_chains.h enumerates (spc_sphere_chain_usable from x), no two of
 * them overlap, and the two shortest visits add up to more than max_chain vertices: a visit to a
 * convex mirror is one reflection (the ray leaves it and cannot come back), one to a glass ball two
 * refractions, in and out (one reflection if reflect: dielectric vertices may reflect). Then every
 * chain specular NEE can make from x stays on one sphere and is enumerated exactly, and the
 * randomized attempts would find nothing else (a Cornell box with a glass and a mirror ball and
 * chains of up to 2 vertices: a chain through both needs 3). */
bool spc_snee_spheres_keep_apart(const spc_scene *sc, const spc_chain_casters *cs, spc_vec3 x, bool reflect,
                                 int max_chain);

/* The probability that specular NEE makes this query (spc_snee_params.query_p, later_p): query_p
 * where it is in (0, 1) and guided directions are off, else 1. */
double spc_snee_query_prob(const spc_snee_params *p);

/* The probability of the query at a path's receiver x past its first (spc_snee_params.query_p
 * there): later_p where the casters look small from x, rising in proportion to the share of x's
 * directions they fill (spc_snee_caster_share) to 1 at a share of 0.3 (SPC_SNEE_LATER_FULL_SHARE,
 * snee_cost.c); 1 if later_p is not in (0, 1). Depends on x alone, so that the BSDF side's MIS
 * weight finds the same value from the receiver it stored. */
double spc_snee_later_prob(const spc_scene *sc, const spc_snee_params *p, spc_vec3 x);

/* The share of the directions from x that meet the casters cs: the sum over casters of the solid
 * angle of the sphere around each one's bounding box over 4 pi (1 from within such a sphere), at
 * most 1. */
double spc_snee_caster_share(const spc_scene *sc, const spc_chain_casters *cs, spc_vec3 x);

#endif
