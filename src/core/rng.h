/*
 * core/rng.h: PCG32 (O'Neill 2014) and integer hashing used to derive deterministic streams.
 */
#ifndef SPC_CORE_RNG_H
#define SPC_CORE_RNG_H

#include <stdint.h>

typedef struct spc_rng {
    uint64_t state, inc;
} spc_rng;

static inline uint32_t spc_rng_u32(spc_rng *r)
{
    uint64_t old = r->state;
    r->state = old * 6364136223846793005ULL + r->inc;
    uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
}

static inline void spc_rng_seed(spc_rng *r, uint64_t seed, uint64_t stream)
{
    r->state = 0u;
    r->inc = (stream << 1u) | 1u;
    spc_rng_u32(r);
    r->state += seed;
    spc_rng_u32(r);
}

/* Uniform double in [0, 1) with 53 random bits. */
static inline double spc_rng_next(spc_rng *r)
{
    uint64_t hi = spc_rng_u32(r) >> 5, lo = spc_rng_u32(r) >> 6;
    return (double)(hi * 67108864ULL + lo) * (1.0 / 9007199254740992.0);
}

/* 64-bit mix (SplitMix64 finalizer). */
static inline uint64_t spc_hash64(uint64_t x)
{
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

static inline uint64_t spc_hash_combine(uint64_t a, uint64_t b) { return spc_hash64(a ^ (spc_hash64(b) + 0x9e3779b97f4a7c15ULL)); }

#endif
