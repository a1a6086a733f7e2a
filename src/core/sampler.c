/*
 * core/sampler.c: shuffled, Owen-scrambled (0,2)-sequence per dimension pair (Burley 2020).
 */
#include "core/sampler.h"

#include "core/rng.h"

static uint32_t reverse_bits(uint32_t x)
{
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* Laine-Karras style hash: each bit only depends on lower bits, so on reversed bits it is an
 * Owen scramble (a nested uniform permutation). */
static uint32_t lk_permute(uint32_t x, uint32_t seed)
{
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

static uint32_t nested_uniform_scramble(uint32_t x, uint32_t seed)
{
    return reverse_bits(lk_permute(reverse_bits(x), seed));
}

static uint32_t sobol_dim0(uint32_t index) { return reverse_bits(index); }

static uint32_t sobol_dim1(uint32_t index)
{
    uint32_t r = 0;
    for (uint32_t v = 1u << 31; index != 0; index >>= 1, v ^= v >> 1)
        if (index & 1u)
            r ^= v;
    return r;
}

void spc_sampler_start_key(spc_sampler *s, uint64_t key, uint32_t index)
{
    s->pixel_seed = spc_hash64(key);
    s->index = index;
    s->dim = 0;
}

void spc_sampler_start(spc_sampler *s, uint32_t px, uint32_t py, uint32_t index, uint64_t seed)
{
    uint64_t key = spc_hash_combine(((uint64_t)px << 32) | py, seed);
    spc_sampler_start_key(s, key, index);
}

spc_vec2 spc_sampler_2d(spc_sampler *s)
{
    uint64_t h = spc_hash_combine(s->pixel_seed, s->dim++);
    uint32_t idx = nested_uniform_scramble(s->index, (uint32_t)h);
    uint32_t x = nested_uniform_scramble(sobol_dim0(idx), (uint32_t)(h >> 32));
    uint32_t y = nested_uniform_scramble(sobol_dim1(idx), (uint32_t)spc_hash64(h));
    const double k = 1.0 / 4294967296.0;
    return spc_v2(x * k, y * k);
}

double spc_sampler_1d(spc_sampler *s) { return spc_sampler_2d(s).x; }
