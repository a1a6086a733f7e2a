/*
 * core/sampler.h: deterministic low-discrepancy sample streams.
 *
 * Each (pixel, sample index, seed) owns its own stream of dimensions, so an image does not depend
 * on the thread count or on the tile order, and a render can resume at any sample index. Each pair
 * of dimensions is a (0,2)-sequence (the first two Sobol dimensions), with the sample index
 * shuffled and the points Owen-scrambled by a hash of (pixel, seed, dimension) (Burley 2020,
 * "Practical Hash-based Owen Scrambling"). Any prefix of the samples of a pixel is well
 * stratified, which --time needs because the final count is not known in advance.
 */
#ifndef SPC_CORE_SAMPLER_H
#define SPC_CORE_SAMPLER_H

#include <stdint.h>

#include "core/math.h"
#include "core/rng.h"

typedef struct spc_sampler {
    uint64_t pixel_seed; /* hash of (pixel, seed) */
    uint32_t index;      /* sample index within the pixel */
    uint32_t index_rev;  /* index with its bits reversed (each pair's index shuffle starts there) */
    uint32_t dim;        /* next dimension pair */
} spc_sampler;

/* Starts the stream of sample `index` of pixel (px, py) for the global `seed`. */
void spc_sampler_start(spc_sampler *s, uint32_t px, uint32_t py, uint32_t index, uint64_t seed);
/* spc_sampler_start of the n pixels (px0 + i, py), i in [0, n), into s[i], for the same index and
 * seed (a row of a tile): the same streams, their hashes computed side by side. */
void spc_sampler_start_row(spc_sampler *s, int n, uint32_t px0, uint32_t py, uint32_t index, uint64_t seed);
/* Starts a stream identified by an arbitrary key (tests, light tracing, solver seeds). */
void spc_sampler_start_key(spc_sampler *s, uint64_t key, uint32_t index);
/* Next value in [0,1). Uses one dimension pair. */
double spc_sampler_1d(spc_sampler *s);
/* Next point in [0,1)^2, stratified across the sample indices of the same stream. */
spc_vec2 spc_sampler_2d(spc_sampler *s);
/* The next npairs dimension pairs of each of the n streams s[i] (none where s[i] is NULL) at once:
 * u[i * npairs + k] is what the k-th of npairs successive spc_sampler_2d calls on s[i] returns (a
 * spc_sampler_1d call would return its x: it uses a whole pair), bit for bit, and each stream moves
 * past the pairs. Many streams at once is cheaper per pair (independent dependency chains, vector
 * instructions where the CPU has AVX2). */
void spc_sampler_2d_many(spc_sampler *const *s, int n, int npairs, spc_vec2 *u);
/* Moves the stream past npairs dimension pairs without computing them: the pairs after them are
 * the same as if each had been drawn (a pair depends only on the stream and its position), so a
 * caller may skip the draws it turns out not to need. */
static inline void spc_sampler_skip(spc_sampler *s, uint32_t npairs) { s->dim += npairs; }
/* spc_sampler_2d_many where only some of the pairs are used as 2D points: bit k of ymask set says
 * that the k-th pair of each stream needs its y (npairs <= 32); where it is clear, u[i * npairs + k].y is 0 and x
 * is spc_sampler_1d's value (the whole pair is used up all the same). Skipping those y's saves
 * about a third of the pair's work. */
void spc_sampler_draw_many(spc_sampler *const *s, int n, int npairs, unsigned ymask, spc_vec2 *u);
/* spc_sampler_draw_many where each stream reads only some of its pairs: bit k of use[i] set says
 * that stream i reads its k-th pair (use NULL: every stream reads every pair). The pairs a stream
 * does not read are not computed and u[i * npairs + k] is left as it was; every stream still moves
 * past all npairs pairs, so the pairs drawn are the same values as spc_sampler_draw_many's. */
void spc_sampler_draw_many_used(spc_sampler *const *s, const unsigned *use, int n, int npairs, unsigned ymask,
                                spc_vec2 *u);
/* spc_sampler_draw_many_used with the pairs by pair number: stream i's k-th pair in u[k * ldu + i]
 * (ldu >= n), so that each pair's values for all the streams are one array. */
void spc_sampler_draw_many_used_by_pair(spc_sampler *const *s, const unsigned *use, int n, int npairs,
                                        unsigned ymask, spc_vec2 *u, int ldu);
/* A generator of its own for a consumer of an unknown number of values (specular NEE's solver
 * attempts, an AOV's walk): seeded from the stream's state (pixel, index, next dimension) and
 * `stream`, which tells apart the forks taken at the same state. The sampler does not move, so
 * its later dimensions are the same with or without the fork. */
void spc_sampler_fork_rng(const spc_sampler *s, uint64_t stream, spc_rng *rng);

#endif
