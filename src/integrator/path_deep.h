/*
 * integrator/path_deep.h: more directions from the BSDF at a path's receivers past the first,
 * counted only for the light they reach through delta vertices (params.deep_split, "deepsplit=M").
 *
 * A path that has scattered off two or more diffuse surfaces under water (an enclosed pool) and
 * then samples, from its BSDF, a direction that refracts out through the water to a small area
 * light carries Le times its throughput: near a fold of the water's caustic the light's image
 * through the water is large, so specular NEE's light sample is the weaker strategy there and BSDF
 * sampling keeps nearly all of the MIS weight (0.99), and the path's Russian roulette doubles the
 * value. Such a path is rare and worth hundreds of times a dim pixel's mean: one of them held 0.98
 * of a seed's error on the pool (bench/RESULTS.md, part pool36).
 *
 * The estimator: at such a vertex x, where specular NEE's query runs and light tracing shares none
 * of x's paths (past the receivers its area-light joins reach) and the BSDF alone samples x (no
 * caustic guide), M more directions are drawn from x's BSDF (not a delta lobe), each followed
 * through vertices whose BSDF is delta only (sampled as the path samples them, with no Russian
 * roulette) for at most SPC_CHAIN_MAX_VERTICES of them; the light of an area emitter reached after
 * at least one such vertex is counted over M + 1 with the MIS weight the path gives the same light
 * when its own sample reaches it (spc_path_snee_emitter_weight on the state the path would carry).
 * The path's own light of that kind (its next vertices after x delta only, an area light reached
 * after 1 to SPC_CHAIN_MAX_VERTICES of them) is counted 1 / (M + 1) times (spc_path_deep_track).
 * Both weights, and specular NEE's at x, take BSDF sampling's density times M + 1
 * (spc_snee_params.bsdf_n, set per receiver by path_snee.c): the M + 1 directions are one strategy
 * of M + 1 samples (Veach's n_i p_i), so near a fold, where specular NEE's value stands at the power
 * heuristic's bound, its weight falls too. Every path's weights still sum to one: unbiased. The
 * draws come from a stream forked from the sampler, so no dimension moves.
 */
#ifndef SPC_INTEGRATOR_PATH_DEEP_H
#define SPC_INTEGRATOR_PATH_DEEP_H

#include <stdbool.h>

#include "core/sampler.h"
#include "integrator/context.h"
#include "integrator/path_snee.h"
#include "manifold/chain.h"

/* The stream key of the extra directions' draws (spc_sampler_fork_rng). */
#define SPC_PATH_DEEP_STREAM 0x6465657073706c74ULL

/* The path's own record of its class: the scale of the light it reaches after x through delta
 * vertices only, and how many of them it has passed. */
typedef struct spc_path_deep_track {
    double scale; /* 1 / (M + 1) after a vertex with extra directions, else 1 */
    int k;        /* delta-only vertices since that vertex */
} spc_path_deep_track;

/* Does the path draw extra directions at its vertex h (sn: the specular NEE state after h's
 * query)? Where path_snee.c set the receiver's BSDF count (params.bsdf_n) above 1. */
bool spc_path_deep_at(const spc_path_snee *sn, const spc_hit *h);

/* The extra directions' light at h (wo toward the previous vertex; segments: the path's segments
 * up to h; sn: the state after h's query), over M + 1: to be multiplied by the throughput that
 * reached h. */
spc_rgb spc_path_deep_estimate(const spc_render_ctx *ctx, const spc_path_snee *sn, const spc_hit *h, spc_vec3 wo,
                               int segments, const spc_sampler *smp);

/* The path's scattering at h by lobe: `drawn` if extra directions were drawn at h. */
void spc_path_deep_scattered(spc_path_deep_track *t, const spc_path_snee *sn, const spc_hit *h, unsigned lobe,
                             bool drawn);

/* The factor of the light the path reaches now: 1 / (M + 1) for its own sample of the class. */
static inline double spc_path_deep_factor(const spc_path_deep_track *t)
{
    return t->scale != 1.0 && t->k >= 1 && t->k <= SPC_CHAIN_MAX_VERTICES ? t->scale : 1.0;
}

#endif
