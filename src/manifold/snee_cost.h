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

/* The share of a receiver's directions that the casters' bounds fill (spc_snee_caster_share) from
 * which specular NEE's query is always made; below it the query's probability is the share over
 * this, down to first_p or later_p (Russian roulette, unbiased). 1: always only within a caster's
 * bounding sphere, elsewhere in proportion to the solid angle. A receiver close to a caster can lie
 * at its caustic's focus, where one query holds much of a pixel's value; far away the caustic is
 * faint or a convex reflection's small image, and the query costs as much. Measured at equal CPU
 * time (bench/RESULTS.md, "Tenx"): with floors first=0.1, later=0.1, a full share of 1 against
 * 0.3 (and later=0.25 only) cut the CPU per sample 1.40 -> 0.81 s on the glass sphere and 1.46 ->
 * 0.71 on the demo with the same variance per sample (1.7x and 2.0x less relMSE x CPU); 3 cut
 * further (0.73, 0.51) but the variance doubled; 0.7 and 1.5 lay between. (Before: 0.3, where
 * 0.5 and 0.9 with the floor 0.25 alone left a demo seed with one pixel 85% of its error.) */
#define SPC_SNEE_QUERY_FULL_SHARE 1.0

/* The probability of the query at a path's receiver x past its first (spc_snee_params.query_p
 * there): later_p where the casters look small from x, rising in proportion to the share of x's
 * directions they fill (spc_snee_caster_share) to 1 at SPC_SNEE_QUERY_FULL_SHARE; 1 if later_p
 * is not in (0, 1). Depends on x alone, so that the BSDF side's MIS weight finds the same value
 * from the receiver it stored. */
double spc_snee_later_prob(const spc_scene *sc, const spc_snee_params *p, spc_vec3 x);

/* The same at a path's first receiver, with first_p for later_p (1 if first_p is not in (0, 1)). */
double spc_snee_first_prob(const spc_scene *sc, const spc_snee_params *p, spc_vec3 x);

/* The share of the directions from x that meet the casters cs: the sum over casters of the solid
 * angle of the sphere around each one's bounding box over 4 pi (1 from within such a sphere), at
 * most 1. */
double spc_snee_caster_share(const spc_scene *sc, const spc_chain_casters *cs, spc_vec3 x);

#endif
