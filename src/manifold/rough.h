/*
 * manifold/rough.h: specular NEE with rough vertices (the setting "newton:rough"; newton.h describes
 * the rough vertices and what the path tracer does with them). Its own estimator: the light point
 * uniform by area on a light chosen by power, the Newton solver's attempts with microfacet normals
 * fixed per light sample, no MIS with BSDF sampling (the covered paths are dropped there).
 */
#ifndef SPC_MANIFOLD_ROUGH_H
#define SPC_MANIFOLD_ROUGH_H

#include "manifold/solver.h"

/* The estimate at the path vertex x (wo toward the previous vertex), to be multiplied by the path
 * throughput, like spc_specular_nee's: with the microfacet normals drawn once per light sample and
 * kept for every attempt that estimates <1/p_solve>. max_chain is specular NEE's budget at x
 * (spc_snee_budget_params: 0 at a rough chain surface). st may be NULL. */
spc_rgb spc_rough_nee(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo, int max_chain,
                      spc_rng *rng, spc_snee_stats *st);

#endif
