/*
 * tests/lanes.h: comparisons of a call that serves many lanes at once, or shares terms between two
 * results, with the plain one-at-a-time calls, bit for bit (memcmp), over random inputs.
 *
 * lanes_check_direct: spc_emitter_sample_direct_many against spc_emitter_sample_direct, in rounds
 * of LANES_N lanes with emitters drawn from the scene's (and none); the test draws each lane's
 * reference point and random numbers and counts what it needs to prove the comparisons covered.
 * lanes_check_bsdfs: rounds over the scene's shapes' BSDFs at a random shading frame, uv and wo;
 * the test draws the rest and compares.
 */
#ifndef SPC_TESTS_LANES_H
#define SPC_TESTS_LANES_H

#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "core/rng.h"
#include "core/warp.h"
#include "emitter/emitter.h"
#include "scene/hit.h"
#include "scene/scene.h"
#include "scene/shape.h"

/* Lanes per round: more than two of spc_emitter_sample_direct_many's batches, the last one partial. */
#define LANES_N 37

/* Are two light samples the same bit for bit (or both no sample)? */
static inline bool lanes_same_direct(bool ok_a, const spc_emitter_direct *a, bool ok_b, const spc_emitter_direct *b)
{
    if (ok_a != ok_b)
        return false;
    if (!ok_a)
        return true;
    return memcmp(&a->p, &b->p, sizeof a->p) == 0 && memcmp(&a->n, &b->n, sizeof a->n) == 0 &&
           memcmp(&a->wi, &b->wi, sizeof a->wi) == 0 && memcmp(&a->dist, &b->dist, sizeof a->dist) == 0 &&
           memcmp(&a->L, &b->L, sizeof a->L) == 0 && memcmp(&a->pdf, &b->pdf, sizeof a->pdf) == 0 &&
           memcmp(&a->err, &b->err, sizeof a->err) == 0 && a->is_delta == b->is_delta &&
           a->is_infinite == b->is_infinite;
}

/* A test's part of lanes_check_direct. setup draws lane i's reference point and random numbers
 * for emitter e (NULL: the lane has no light) from rng, and returns a tag of the lane's kind (for
 * tally and the failure message); tally counts a lane with an emitter after both calls. */
typedef struct lanes_direct_hooks {
    int (*setup)(void *ctx, int i, const spc_emitter *e, spc_rng *rng, spc_vec3 *ref, spc_vec2 *u);
    void (*tally)(void *ctx, const spc_emitter *e, spc_vec3 ref, int tag, bool ok_many, bool ok_one);
    void *ctx;
} lanes_direct_hooks;

/* rounds of LANES_N lanes from the random stream (seed, stream): each lane's emitter drawn
 * uniformly among sc's and none; ok[] set to a pattern the call must overwrite. Returns how many
 * lanes differ from the one-lane call (a lane without a light that reports a sample counts);
 * prints the first three. */
static inline int lanes_check_direct(const spc_scene *sc, uint64_t seed, uint64_t stream, int rounds,
                                     const lanes_direct_hooks *hk)
{
    spc_rng rng;
    spc_rng_seed(&rng, seed, stream);
    int failed = 0;
    for (int round = 0; round < rounds; ++round) {
        const spc_emitter *e[LANES_N];
        spc_vec3 ref[LANES_N];
        spc_vec2 u[LANES_N];
        spc_emitter_direct many[LANES_N], one;
        bool ok[LANES_N];
        int tag[LANES_N];
        for (int i = 0; i < LANES_N; ++i) {
            int k = (int)(spc_rng_next(&rng) * (sc->nemitters + 1));
            e[i] = k < sc->nemitters ? sc->emitters[k] : NULL;
            tag[i] = hk->setup(hk->ctx, i, e[i], &rng, &ref[i], &u[i]);
            ok[i] = !(i % 2);
        }
        spc_emitter_sample_direct_many(LANES_N, e, ref, u, many, ok);
        for (int i = 0; i < LANES_N; ++i) {
            if (!e[i]) {
                failed += ok[i];
                continue;
            }
            bool ok1 = spc_emitter_sample_direct(e[i], ref[i], u[i], &one);
            hk->tally(hk->ctx, e[i], ref[i], tag[i], ok[i], ok1);
            if (!lanes_same_direct(ok[i], &many[i], ok1, &one)) {
                if (failed < 3)
                    printf("  lane %d (emitter %d, kind %d): many %d, one %d\n", i, e[i]->index, tag[i], ok[i], ok1);
                ++failed;
            }
        }
    }
    return failed;
}

/* A test's part of lanes_check_bsdfs: draws what else it needs from rng, compares b's two forms at
 * hit h and direction wo (both of which it may change) and returns whether they agree; loud: print
 * the disagreement (the first three). */
typedef bool (*lanes_bsdf_fn)(void *ctx, int round, const spc_bsdf *b, spc_hit *h, spc_vec3 wo, spc_rng *rng,
                              bool loud);

/* rounds from the random stream (seed, stream), round r on the BSDF of sc's shape r % nshapes: a
 * hit with a uniformly random shading normal (the geometric normal the same) and uv, and a
 * uniformly random wo. Returns the number of rounds fn found different. */
static inline int lanes_check_bsdfs(const spc_scene *sc, uint64_t seed, uint64_t stream, int rounds, lanes_bsdf_fn fn,
                                    void *ctx)
{
    spc_rng rng;
    spc_rng_seed(&rng, seed, stream);
    int failed = 0;
    for (int round = 0; round < rounds; ++round) {
        const spc_bsdf *b = sc->shapes[round % sc->nshapes]->bsdf;
        spc_hit h;
        memset(&h, 0, sizeof h);
        spc_vec3 n = spc_warp_uniform_sphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)));
        h.sh = spc_frame_from_n(n);
        h.ng = n;
        h.uv = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
        h.bsdf = b;
        spc_vec3 wo = spc_warp_uniform_sphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)));
        failed += !fn(ctx, round, b, &h, wo, &rng, failed < 3);
    }
    return failed;
}

#endif
