/*
 * core/sampler.c: shuffled, Owen-scrambled (0,2)-sequence per dimension pair (Burley 2020).
 */
#include "core/sampler.h"
#include "core/cpu_isa.h"

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

static uint32_t reverse_bits(uint32_t x)
{
#if defined(__GNUC__)
    x = __builtin_bswap32(x);
#else
    x = (x >> 24) | ((x >> 8) & 0xff00u) | ((x << 8) & 0xff0000u) | (x << 24);
#endif
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    return ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
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

/* The second Sobol dimension, stored BIT-REVERSED so that the Owen scramble (which works on reversed
 * bits) needs one reversal less. Index bit i selects row i of the Pascal matrix mod 2, the direction
 * (1 + S)^i e (S a shift right by one, e the top bit), whose bit at distance p from the top is
 * binomial(i, p) mod 2: set where the bits of p are a subset of those of i (Lucas). So reversed bit
 * p of the result is the XOR of the index bits i whose index sets contain p's: the superset
 * transform over the five bits of a bit's position, one shift, mask and XOR per position bit. Both
 * this and the direction numbers' table are linear over GF(2); sobol1_init checks that they agree
 * on every byte. */
static uint32_t sobol_dim1_reversed(uint32_t index)
{
    uint32_t x = index;
    x ^= (x >> 1) & 0x55555555u;
    x ^= (x >> 2) & 0x33333333u;
    x ^= (x >> 4) & 0x0f0f0f0fu;
    x ^= (x >> 8) & 0x00ff00ffu;
    return x ^ (x >> 16);
}

/* The same map per byte of the index from the direction numbers (4 x 256 entries, built once;
 * read-only afterwards), for the GFNI pairs' gathers. */
static uint32_t sobol1_table[4][256];
static pthread_once_t sobol1_once = PTHREAD_ONCE_INIT;

static void sobol1_init(void)
{
    uint32_t dir[32];
    uint32_t v = 1u << 31;
    for (int i = 0; i < 32; ++i, v ^= v >> 1)
        dir[i] = v;
    for (int byte = 0; byte < 4; ++byte)
        for (int x = 0; x < 256; ++x) {
            uint32_t r = 0;
            for (int b = 0; b < 8; ++b)
                if (x & (1 << b))
                    r ^= dir[8 * byte + b];
            sobol1_table[byte][x] = reverse_bits(r); /* stored bit-reversed: see spc_sampler_2d */
            SPC_CHECK(sobol1_table[byte][x] == sobol_dim1_reversed((uint32_t)x << (8 * byte)));
        }
}

void spc_sampler_start_key(spc_sampler *s, uint64_t key, uint32_t index)
{
    pthread_once(&sobol1_once, sobol1_init);
    s->pixel_seed = spc_hash64(key);
    s->index = index;
    s->index_rev = reverse_bits(index);
    s->dim = 0;
}

void spc_sampler_start(spc_sampler *s, uint32_t px, uint32_t py, uint32_t index, uint64_t seed)
{
    uint64_t key = spc_hash_combine(((uint64_t)px << 32) | py, seed);
    spc_sampler_start_key(s, key, index);
}

/* The next dimension pair's hash (one 64-bit hash per pair: its halves and a multiplied copy seed
 * the three permutations: index shuffle, x scramble, y scramble), its shuffled index, and its first
 * coordinate as 32 bits. */
static uint32_t pair_x(spc_sampler *s, uint64_t *h, uint32_t *idx)
{
    *h = spc_hash64(s->pixel_seed + 0x9e3779b97f4a7c15ULL * (uint64_t)(++s->dim));
    /* the index's nested uniform scramble, reverse(lk(reverse(index))), from the reversal kept in
     * the sampler */
    *idx = reverse_bits(lk_permute(s->index_rev, (uint32_t)*h));
    /* the Sobol points are reversed quantities (dim 0 is reverse(idx)), so the scramble's inner
     * reversal cancels */
    return reverse_bits(lk_permute(*idx, (uint32_t)(*h >> 32)));
}

spc_vec2 spc_sampler_2d(spc_sampler *s)
{
    uint64_t h;
    uint32_t idx, x = pair_x(s, &h, &idx);
    uint32_t h3 = (uint32_t)((h * 0xda942042e4dd58b5ULL) >> 32);
    uint32_t y = reverse_bits(lk_permute(sobol_dim1_reversed(idx), h3));
    const double k = 1.0 / 4294967296.0;
    return spc_v2(x * k, y * k);
}

/* spc_sampler_2d's x alone (the same value, the same dimension pair used up). */
double spc_sampler_1d(spc_sampler *s)
{
    uint64_t h;
    uint32_t idx;
    return pair_x(s, &h, &idx) * (1.0 / 4294967296.0);
}

/* A 32-bit coordinate's value in [0, 1): the conversion and this product are exact. */
#define SAMPLER_UNIT (1.0 / 4294967296.0)

/* spc_sampler_draw_many's batch: up to MANY_LANES pairs computed side by side (the wave's 16 lanes'
 * five pairs in one batch). */
#define MANY_LANES 128

/* A batch's unhashed seeds and reversed indices: for m streams (pixel seeds pseed, first dimensions
 * dim0, reversed indices rev) and np pairs each, slot k m + q holds stream q's (dim0 + pair[k] + 1)-th
 * pair's seed, spc_sampler_2d's (the dimension a 32-bit count), and the stream's reversed index. */
static inline __attribute__((always_inline)) void pair_seeds(int m, int np, const int *pair, const uint64_t *pseed,
                                                             const uint32_t *dim0, const uint32_t *rev,
                                                             uint64_t *seed, uint32_t *rk)
{
    for (int k = 0; k < np; ++k) {
        uint32_t d = (uint32_t)pair[k] + 1u;
        for (int q = 0; q < m; ++q) {
            seed[k * m + q] = pseed[q] + 0x9e3779b97f4a7c15ULL * (uint64_t)(uint32_t)(dim0[q] + d);
            rk[k * m + q] = rev[q];
        }
    }
}

/* A batch's pairs as plain loops over arrays (pair_x's and spc_sampler_2d's arithmetic, in the same
 * order): for m streams (their pixel seeds pseed, first dimensions dim0 and reversed indices rev) and
 * np pairs each, pair number pair[k] in slot k m + q of stream q, the seeds, then the first
 * coordinates of all np m pairs into ux, then the second coordinates of the first ky m into uy.
 * Compiled twice, for the baseline ISA and vectorized (-O3) with AVX-512 (whose 64-bit multiply,
 * vpmullq, the seeds and the hash need), chosen at run time beside the intrinsic AVX2 and GFNI
 * variants below; the integer arithmetic and the conversion to [0, 1) are exact, so all give the
 * same bits. */
static inline __attribute__((always_inline)) void pairs_loops(int m, int np, int ky, const int *pair,
                                                              const uint64_t *pseed, const uint32_t *dim0,
                                                              const uint32_t *rev, double *ux, double *uy)
{
    uint64_t h[MANY_LANES];
    uint32_t idx[MANY_LANES], rk[MANY_LANES];
    pair_seeds(m, np, pair, pseed, dim0, rev, h, rk);
    const int mx = np * m, my = ky * m;
    for (int j = 0; j < mx; ++j)
        h[j] = spc_hash64(h[j]);
    for (int j = 0; j < mx; ++j)
        idx[j] = reverse_bits(lk_permute(rk[j], (uint32_t)h[j]));
    for (int j = 0; j < mx; ++j)
        ux[j] = reverse_bits(lk_permute(idx[j], (uint32_t)(h[j] >> 32))) * SAMPLER_UNIT;
    for (int j = 0; j < my; ++j)
        uy[j] =
            reverse_bits(lk_permute(sobol_dim1_reversed(idx[j]), (uint32_t)((h[j] * 0xda942042e4dd58b5ULL) >> 32))) *
            SAMPLER_UNIT;
}

#define PAIRS_ARGS                                                                                                     \
    int m, int np, int ky, const int *pair, const uint64_t *pseed, const uint32_t *dim0, const uint32_t *rev,          \
        double *ux, double *uy

static void pairs_base(PAIRS_ARGS) { pairs_loops(m, np, ky, pair, pseed, dim0, rev, ux, uy); }

#if defined(__GNUC__) && defined(__x86_64__)
#if defined(__clang__)
#define PAIRS_ATTR(t) __attribute__((target(t))) /* clang vectorizes these loops at -O2 */
#else
#define PAIRS_ATTR(t) __attribute__((target(t), optimize("O3"))) /* GCC's -O2 does not */
#endif
#define PAIRS_AVX512 "avx512f,avx512dq,avx512bw,avx512vl"
PAIRS_ATTR(PAIRS_AVX512) static void pairs_avx512(PAIRS_ARGS)
{
    pairs_loops(m, np, ky, pair, pseed, dim0, rev, ux, uy);
}

/* The same loops written with AVX-512 and GFNI intrinsics, eight pairs a step, for processors that
 * have GFNI (Ice Lake, Zen 4): a 32-bit reversal is one affine transform over GF(2) per byte (the
 * matrix that reverses a byte's bits) and one byte shuffle, where the shifts and masks of
 * reverse_bits take about fifteen operations; the pair's values stay in registers from the hash to
 * the conversion. Integer arithmetic throughout, so the same bits as pairs_loops (test_core). */
#define PAIRS_GFNI PAIRS_AVX512 ",gfni"
__attribute__((target(PAIRS_GFNI))) static inline __m256i rev32_gfni(__m256i x)
{
    const __m256i bswap = _mm256_set_epi8(12, 13, 14, 15, 8, 9, 10, 11, 4, 5, 6, 7, 0, 1, 2, 3, 12, 13, 14, 15, 8, 9,
                                          10, 11, 4, 5, 6, 7, 0, 1, 2, 3);
    x = _mm256_gf2p8affine_epi64_epi8(x, _mm256_set1_epi64x(0x8040201008040201LL), 0);
    return _mm256_shuffle_epi8(x, bswap);
}

__attribute__((target(PAIRS_GFNI))) static inline __m256i lk_permute_v(__m256i x, __m256i seed)
{
    x = _mm256_add_epi32(x, seed);
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0x6c50b47cu)));
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0xb82f1e52u)));
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0xc7afe638u)));
    return _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0x8d22f6e6u)));
}

/* a 32-bit coordinate's value in [0, 1) (SAMPLER_UNIT) */
__attribute__((target(PAIRS_GFNI))) static inline __m512d unit_v(__m256i x)
{
    return _mm512_mul_pd(_mm512_cvtepu32_pd(x), _mm512_set1_pd(SAMPLER_UNIT));
}

PAIRS_ATTR(PAIRS_GFNI) static void pairs_gfni(PAIRS_ARGS)
{
    uint64_t seed[MANY_LANES];
    uint32_t rk[MANY_LANES];
    pair_seeds(m, np, pair, pseed, dim0, rev, seed, rk);
    const int mx = np * m, my = ky * m;
    const __m256i byte = _mm256_set1_epi32(0xff);
    for (int j = 0; j < mx; j += 8) {
        __mmask8 live = (__mmask8)(mx - j >= 8 ? 0xff : (1u << (mx - j)) - 1u);
        /* spc_hash64 */
        __m512i h = _mm512_maskz_loadu_epi64(live, seed + j);
        h = _mm512_xor_si512(h, _mm512_srli_epi64(h, 30));
        h = _mm512_mullo_epi64(h, _mm512_set1_epi64((long long)0xbf58476d1ce4e5b9ULL));
        h = _mm512_xor_si512(h, _mm512_srli_epi64(h, 27));
        h = _mm512_mullo_epi64(h, _mm512_set1_epi64((long long)0x94d049bb133111ebULL));
        h = _mm512_xor_si512(h, _mm512_srli_epi64(h, 31));
        __m256i lo = _mm512_cvtepi64_epi32(h), hi = _mm512_cvtepi64_epi32(_mm512_srli_epi64(h, 32));
        __m256i idx = rev32_gfni(lk_permute_v(_mm256_maskz_loadu_epi32(live, rk + j), lo));
        _mm512_mask_storeu_pd(ux + j, live, unit_v(rev32_gfni(lk_permute_v(idx, hi))));
        if (j >= my)
            continue;
        __mmask8 ylive = (__mmask8)(live & (my - j >= 8 ? 0xff : (1u << (my - j)) - 1u));
        /* sobol_dim1_reversed: the four bytes' table entries */
        __m256i sob = _mm256_i32gather_epi32((const int *)sobol1_table[0], _mm256_and_si256(idx, byte), 4);
        sob = _mm256_xor_si256(sob, _mm256_i32gather_epi32((const int *)sobol1_table[1],
                                                           _mm256_and_si256(_mm256_srli_epi32(idx, 8), byte), 4));
        sob = _mm256_xor_si256(sob, _mm256_i32gather_epi32((const int *)sobol1_table[2],
                                                           _mm256_and_si256(_mm256_srli_epi32(idx, 16), byte), 4));
        sob = _mm256_xor_si256(sob, _mm256_i32gather_epi32((const int *)sobol1_table[3], _mm256_srli_epi32(idx, 24), 4));
        __m256i h3 =
            _mm512_cvtepi64_epi32(_mm512_srli_epi64(_mm512_mullo_epi64(h, _mm512_set1_epi64((long long)0xda942042e4dd58b5ULL)), 32));
        _mm512_mask_storeu_pd(uy + j, ylive, unit_v(rev32_gfni(lk_permute_v(sob, h3))));
    }
}

/* The same loops written with AVX2 intrinsics, eight pairs a step, for AVX2 processors without
 * AVX-512 (Haswell to Alder Lake, Zen 1-3), where GCC's vectorized pairs_loops spend most of their
 * work on the 32-bit reversals (a byte swap and three rounds of shifts and masks each, three per
 * pair), on the second dimension's table lookups (scalar loads: a gather is slower on Zen 3) and
 * on a general unsigned conversion to double. Here a reversal is two 16-entry table lookups of each
 * byte's nibbles (vpshufb) and a byte swap; the second dimension is sobol_dim1_reversed's five
 * shifts, masks and XORs; a 64-bit product by a constant is three 32-bit products (AVX2 has no
 * 64-bit multiply); a 32-bit value becomes a double as the signed conversion of it minus 2^31, plus
 * 2^31 (both steps exact). Integer arithmetic and exact conversions throughout, so the same bits as
 * pairs_loops (test_core runs both). */
__attribute__((target("avx2"))) static inline __m256i rev32_avx2(__m256i x)
{
    /* a low nibble v becomes the reversed byte's high nibble, a high nibble its low one */
    const __m256i lo_tab = _mm256_setr_epi8(0x00, (char)0x80, 0x40, (char)0xc0, 0x20, (char)0xa0, 0x60, (char)0xe0,
                                            0x10, (char)0x90, 0x50, (char)0xd0, 0x30, (char)0xb0, 0x70, (char)0xf0,
                                            0x00, (char)0x80, 0x40, (char)0xc0, 0x20, (char)0xa0, 0x60, (char)0xe0,
                                            0x10, (char)0x90, 0x50, (char)0xd0, 0x30, (char)0xb0, 0x70, (char)0xf0);
    const __m256i hi_tab = _mm256_setr_epi8(0x0, 0x8, 0x4, 0xc, 0x2, 0xa, 0x6, 0xe, 0x1, 0x9, 0x5, 0xd, 0x3, 0xb, 0x7,
                                            0xf, 0x0, 0x8, 0x4, 0xc, 0x2, 0xa, 0x6, 0xe, 0x1, 0x9, 0x5, 0xd, 0x3, 0xb,
                                            0x7, 0xf);
    const __m256i bswap = _mm256_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12, 3, 2, 1, 0, 7, 6, 5,
                                           4, 11, 10, 9, 8, 15, 14, 13, 12);
    const __m256i nibble = _mm256_set1_epi8(0x0f);
    __m256i lo = _mm256_and_si256(x, nibble), hi = _mm256_and_si256(_mm256_srli_epi16(x, 4), nibble);
    x = _mm256_or_si256(_mm256_shuffle_epi8(lo_tab, lo), _mm256_shuffle_epi8(hi_tab, hi));
    return _mm256_shuffle_epi8(x, bswap);
}

__attribute__((target("avx2"))) static inline __m256i lk_permute_avx2(__m256i x, __m256i seed)
{
    x = _mm256_add_epi32(x, seed);
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0x6c50b47cu)));
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0xb82f1e52u)));
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0xc7afe638u)));
    return _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32((int)0x8d22f6e6u)));
}

/* sobol_dim1_reversed of eight lanes */
__attribute__((target("avx2"))) static inline __m256i sobol_dim1_reversed_avx2(__m256i x)
{
    x = _mm256_xor_si256(x, _mm256_and_si256(_mm256_srli_epi32(x, 1), _mm256_set1_epi32(0x55555555)));
    x = _mm256_xor_si256(x, _mm256_and_si256(_mm256_srli_epi32(x, 2), _mm256_set1_epi32(0x33333333)));
    x = _mm256_xor_si256(x, _mm256_and_si256(_mm256_srli_epi32(x, 4), _mm256_set1_epi32(0x0f0f0f0f)));
    x = _mm256_xor_si256(x, _mm256_and_si256(_mm256_srli_epi32(x, 8), _mm256_set1_epi32(0x00ff00ff)));
    return _mm256_xor_si256(x, _mm256_srli_epi32(x, 16));
}

/* x c mod 2^64 in each 64-bit lane: lo(x) lo(c) + ((hi(x) lo(c) + lo(x) hi(c)) << 32) */
__attribute__((target("avx2"))) static inline __m256i mul64_avx2(__m256i x, uint64_t c)
{
    const __m256i clo = _mm256_set1_epi64x((long long)(c & 0xffffffffu)), chi = _mm256_set1_epi64x((long long)(c >> 32));
    __m256i cross = _mm256_add_epi64(_mm256_mul_epu32(_mm256_srli_epi64(x, 32), clo), _mm256_mul_epu32(x, chi));
    return _mm256_add_epi64(_mm256_mul_epu32(x, clo), _mm256_slli_epi64(cross, 32));
}

/* spc_hash64 of four 64-bit lanes */
__attribute__((target("avx2"))) static inline __m256i hash64_avx2(__m256i x)
{
    x = _mm256_xor_si256(x, _mm256_srli_epi64(x, 30));
    x = mul64_avx2(x, 0xbf58476d1ce4e5b9ULL);
    x = _mm256_xor_si256(x, _mm256_srli_epi64(x, 27));
    x = mul64_avx2(x, 0x94d049bb133111ebULL);
    return _mm256_xor_si256(x, _mm256_srli_epi64(x, 31));
}

/* The low (high: 1) 32-bit halves of the eight 64-bit lanes of a and b, in order. */
__attribute__((target("avx2"))) static inline __m256i halves_avx2(__m256i a, __m256i b, int high)
{
    __m256 s = high ? _mm256_shuffle_ps(_mm256_castsi256_ps(a), _mm256_castsi256_ps(b), _MM_SHUFFLE(3, 1, 3, 1))
                    : _mm256_shuffle_ps(_mm256_castsi256_ps(a), _mm256_castsi256_ps(b), _MM_SHUFFLE(2, 0, 2, 0));
    /* s holds a0 a1 b0 b1 | a2 a3 b2 b3 */
    return _mm256_permute4x64_epi64(_mm256_castps_si256(s), _MM_SHUFFLE(3, 1, 2, 0));
}

/* the first `live` (1-8) of eight 32-bit coordinates' values in [0, 1) (SAMPLER_UNIT) into dst */
__attribute__((target("avx2"))) static inline void store_unit_avx2(double *dst, __m256i x, int live)
{
    const __m256d two31 = _mm256_set1_pd(2147483648.0), unit = _mm256_set1_pd(SAMPLER_UNIT);
    x = _mm256_xor_si256(x, _mm256_set1_epi32(INT32_MIN));
    __m256d a = _mm256_mul_pd(_mm256_add_pd(_mm256_cvtepi32_pd(_mm256_castsi256_si128(x)), two31), unit);
    __m256d b = _mm256_mul_pd(_mm256_add_pd(_mm256_cvtepi32_pd(_mm256_extracti128_si256(x, 1)), two31), unit);
    if (live == 8) {
        _mm256_storeu_pd(dst, a);
        _mm256_storeu_pd(dst + 4, b);
        return;
    }
    const __m256i first = _mm256_setr_epi64x(0, 1, 2, 3), n = _mm256_set1_epi64x(live);
    _mm256_maskstore_pd(dst, _mm256_cmpgt_epi64(n, first), a);
    _mm256_maskstore_pd(dst + 4, _mm256_cmpgt_epi64(n, _mm256_add_epi64(first, _mm256_set1_epi64x(4))), b);
}

PAIRS_ATTR("avx2") static void pairs_avx2(PAIRS_ARGS)
{
    /* rounded up to whole steps of eight, the slots past the batch zero (read, never stored) */
    uint64_t seed[MANY_LANES];
    uint32_t rk[MANY_LANES];
    pair_seeds(m, np, pair, pseed, dim0, rev, seed, rk);
    const int mx = np * m, my = ky * m;
    for (int j = mx; j < MANY_LANES && (j & 7); ++j) {
        seed[j] = 0;
        rk[j] = 0;
    }
    for (int j = 0; j < mx; j += 8) {
        const int live = mx - j < 8 ? mx - j : 8;
        __m256i ha = hash64_avx2(_mm256_loadu_si256((const __m256i *)(seed + j)));
        __m256i hb = hash64_avx2(_mm256_loadu_si256((const __m256i *)(seed + j + 4)));
        __m256i lo = halves_avx2(ha, hb, 0), hi = halves_avx2(ha, hb, 1);
        __m256i idx = rev32_avx2(lk_permute_avx2(_mm256_loadu_si256((const __m256i *)(rk + j)), lo));
        store_unit_avx2(ux + j, rev32_avx2(lk_permute_avx2(idx, hi)), live);
        if (j >= my)
            continue;
        __m256i sob = sobol_dim1_reversed_avx2(idx);
        __m256i h3 = halves_avx2(mul64_avx2(ha, 0xda942042e4dd58b5ULL), mul64_avx2(hb, 0xda942042e4dd58b5ULL), 1);
        store_unit_avx2(uy + j, rev32_avx2(lk_permute_avx2(sob, h3)), my - j < live ? my - j : live);
    }
}
#endif

typedef void (*pairs_fn)(PAIRS_ARGS);

/* The best variant under cpu_isa.h's choice. */
static pairs_fn pairs = pairs_base;
static pthread_once_t pairs_once = PTHREAD_ONCE_INIT;

static void pairs_init(void)
{
#if defined(__GNUC__) && defined(__x86_64__)
    int isa = spc_vector_isa();
    if (isa == SPC_ISA_AVX512)
        pairs = spc_vector_gfni() ? pairs_gfni : pairs_avx512;
    else if (isa == SPC_ISA_AVX2)
        pairs = pairs_avx2;
#endif
}

/* spc_sampler_draw_many_used for the streams s[idx[k]], k in [0, n) (none NULL), all of whose use
 * bits (of the npairs pairs) are `mask`, pair k of stream i into u[i is + k ks] (is, ks: the layout's
 * strides). A batch of m streams, its pairs grouped by pair number: first the pairs of mask that need
 * their y (pair[k] of stream q in slot k m + q), then the others, so that the pairs' loops cover them
 * all and their last loop the first group, and the per-pair bookkeeping is plain loops over the
 * batch's streams. */
static void draw_group(spc_sampler *const *s, const int *idx, int n, unsigned mask, int npairs, unsigned ymask,
                       spc_vec2 *u, ptrdiff_t is, ptrdiff_t ks)
{
    uint64_t pseed[MANY_LANES];
    uint32_t rev[MANY_LANES], dim0[MANY_LANES];
    double ux[MANY_LANES], uy[MANY_LANES];
    ptrdiff_t base[MANY_LANES];
    int pair[32];
    int ky = 0, np = 0;
    for (int p = 0; p < npairs; ++p)
        if ((mask & ymask) >> p & 1u)
            pair[ky++] = p;
    np = ky;
    for (int p = 0; p < npairs; ++p)
        if ((mask & ~ymask) >> p & 1u)
            pair[np++] = p;
    if (np == 0) {
        for (int k = 0; k < n; ++k)
            s[idx[k]]->dim += (uint32_t)npairs;
        return;
    }
    const int per_batch = MANY_LANES / np;
    for (int k0 = 0; k0 < n; k0 += per_batch) {
        const int m = n - k0 < per_batch ? n - k0 : per_batch;
        for (int q = 0; q < m; ++q) {
            const int i = idx[k0 + q];
            spc_sampler *si = s[i];
            base[q] = i * is;
            pseed[q] = si->pixel_seed;
            dim0[q] = si->dim;
            rev[q] = si->index_rev;
            si->dim += (uint32_t)npairs;
        }
        pairs(m, np, ky, pair, pseed, dim0, rev, ux, uy);
        for (int k = 0; k < ky; ++k) {
            const double *xk = ux + k * m, *yk = uy + k * m;
            spc_vec2 *uk = u + pair[k] * ks;
            for (int q = 0; q < m; ++q)
                uk[base[q]] = spc_v2(xk[q], yk[q]);
        }
        for (int k = ky; k < np; ++k) {
            const double *xk = ux + k * m;
            spc_vec2 *uk = u + pair[k] * ks;
            for (int q = 0; q < m; ++q)
                uk[base[q]] = spc_v2(xk[q], 0.0);
        }
    }
}

/* The streams are taken GROUP_CHUNK at a time, grouped there by their use bits (a pair's values do
 * not depend on the group it is drawn in; a path wave's lanes take a few different masks): the
 * chunk's streams listed once, then each group but the last split off the list in one branch-free
 * pass over what is left of it (the group of the list's first stream, the rest kept in order), so
 * that the draws read only their own group's streams. A wave's 256 lanes are one chunk. */
enum { GROUP_CHUNK = 256 };

/* spc_sampler_draw_many_used and spc_sampler_draw_many_used_by_pair: pair k of stream i into
 * u[i is + k ks] */
static void draw_many_used(spc_sampler *const *s, const unsigned *use, int n, int npairs, unsigned ymask,
                           spc_vec2 *u, ptrdiff_t is, ptrdiff_t ks)
{
    if (npairs <= 0)
        return;
    pthread_once(&pairs_once, pairs_init);
    const unsigned all = npairs >= 32 ? ~0u : (1u << npairs) - 1u;
    int left[GROUP_CHUNK], group[GROUP_CHUNK];
    for (int i0 = 0; i0 < n; i0 += GROUP_CHUNK) {
        const int c = n - i0 < GROUP_CHUNK ? n - i0 : GROUP_CHUNK;
        int nl = 0;
        if (!use) {
            for (int j = 0; j < c; ++j) {
                left[nl] = i0 + j;
                nl += s[i0 + j] != NULL;
            }
            draw_group(s, left, nl, all, npairs, ymask, u, is, ks);
            continue;
        }
        /* up to 5 pairs the masks present are the bits of a word, so the last group needs no pass of
         * its own: it is what is left */
        uint32_t seen = 0;
        for (int j = 0; j < c; ++j) {
            const bool has = s[i0 + j] != NULL;
            left[nl] = i0 + j;
            nl += has;
            if (npairs <= 5)
                seen |= (uint32_t)has << (use[i0 + j] & all);
        }
        int groups = npairs <= 5 ? 0 : GROUP_CHUNK;
        for (; seen; seen &= seen - 1u)
            ++groups;
        while (nl > 0) {
            const unsigned mk = use[left[0]] & all;
            if (groups-- == 1) {
                draw_group(s, left, nl, mk, npairs, ymask, u, is, ks);
                break;
            }
            int ng = 0, nr = 0;
            /* (the rest is written over the list itself: nr <= k) */
            for (int k = 0; k < nl; ++k) {
                const int i = left[k];
                const int in = (use[i] & all) == mk;
                group[ng] = i;
                left[nr] = i;
                ng += in;
                nr += !in;
            }
            draw_group(s, group, ng, mk, npairs, ymask, u, is, ks);
            nl = nr;
        }
    }
}

void spc_sampler_draw_many_used(spc_sampler *const *s, const unsigned *use, int n, int npairs, unsigned ymask,
                                spc_vec2 *u)
{
    draw_many_used(s, use, n, npairs, ymask, u, npairs, 1);
}

void spc_sampler_draw_many_used_by_pair(spc_sampler *const *s, const unsigned *use, int n, int npairs,
                                        unsigned ymask, spc_vec2 *u, int ldu)
{
    draw_many_used(s, use, n, npairs, ymask, u, 1, ldu);
}

void spc_sampler_draw_many(spc_sampler *const *s, int n, int npairs, unsigned ymask, spc_vec2 *u)
{
    spc_sampler_draw_many_used(s, NULL, n, npairs, ymask, u);
}

void spc_sampler_2d_many(spc_sampler *const *s, int n, int npairs, spc_vec2 *u)
{
    spc_sampler_draw_many(s, n, npairs, ~0u, u);
}

/* spc_sampler_start's pixel seeds of a row, hash64(hash64(((px0 + i) << 32 | py) ^ hs)) with
 * hs = hash64(seed) + the golden-ratio constant (spc_hash_combine's), as a plain loop compiled like
 * the pairs' (exact integer arithmetic: the same bits in every variant). */
static inline __attribute__((always_inline)) void row_seeds_loop(int n, uint32_t px0, uint32_t py, uint64_t hs,
                                                                 uint64_t *out)
{
    for (int i = 0; i < n; ++i)
        out[i] = spc_hash64(spc_hash64(((uint64_t)(px0 + (uint32_t)i) << 32 | py) ^ hs));
}

static void row_seeds_base(int n, uint32_t px0, uint32_t py, uint64_t hs, uint64_t *out)
{
    row_seeds_loop(n, px0, py, hs, out);
}

#if defined(__GNUC__) && defined(__x86_64__)
PAIRS_ATTR(PAIRS_AVX512) static void row_seeds_avx512(int n, uint32_t px0, uint32_t py, uint64_t hs, uint64_t *out)
{
    row_seeds_loop(n, px0, py, hs, out);
}
#endif

/* a row's streams per pass of spc_sampler_start_row */
#define ROW_CHUNK 64

void spc_sampler_start_row(spc_sampler *s, int n, uint32_t px0, uint32_t py, uint32_t index, uint64_t seed)
{
    pthread_once(&sobol1_once, sobol1_init);
    uint64_t hs = spc_hash64(seed) + 0x9e3779b97f4a7c15ULL, ps[ROW_CHUNK];
    uint32_t rev = reverse_bits(index);
    for (int i0 = 0; i0 < n; i0 += ROW_CHUNK) {
        int m = n - i0 < ROW_CHUNK ? n - i0 : ROW_CHUNK;
#if defined(__GNUC__) && defined(__x86_64__)
        if (spc_vector_isa() == SPC_ISA_AVX512)
            row_seeds_avx512(m, px0 + (uint32_t)i0, py, hs, ps);
        else
#endif
            row_seeds_base(m, px0 + (uint32_t)i0, py, hs, ps);
        for (int i = 0; i < m; ++i) {
            spc_sampler *t = &s[i0 + i];
            t->pixel_seed = ps[i];
            t->index = index;
            t->index_rev = rev;
            t->dim = 0;
        }
    }
}

void spc_sampler_fork_rng(const spc_sampler *s, uint64_t stream, spc_rng *rng)
{
    spc_rng_seed(rng, spc_hash_combine(s->pixel_seed, ((uint64_t)s->index << 32) | s->dim), stream);
}
