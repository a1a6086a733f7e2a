/*
 * core/warp_many.c: warps of many independent samples at once, for a path tracer that runs many
 * paths side by side (integrator/path_wave.c).
 *
 * One at a time, the cosine-weighted hemisphere (Shirley-Chiu's concentric disk lifted to the
 * hemisphere) is a chain of long-latency steps: a division, the sin/cos polynomials, a square root,
 * and a branch on the octant that the predictor cannot learn. Here the samples go through one loop
 * in structure-of-arrays form with the octant as a select, compiled also for AVX2 and AVX-512 and
 * chosen at run time, so 4 or 8 samples share each instruction and their latencies overlap.
 *
 * Bit for bit: the arithmetic is spc_warp_disk_concentric's and spc_warp_cosine_hemisphere's
 * (core/warp.c) in their order, in double, without fused multiply-adds (ISO C11 builds do not
 * contract, and the vector targets do not include FMA); a select picks the same product the branch
 * would compute. test_core compares every sample with the one-at-a-time warp under every ISA.
 * CMakeLists.txt compiles this file without trapping math: under it GCC keeps the selects' division
 * and products behind a branch in the AVX2 variant, which then is not vector code.
 */
#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "core/warp.h"
#include "core/cpu_isa.h"

/* samples per pass of the loop (arrays on the stack) */
#define WARP_MANY_BATCH 64

static inline __attribute__((always_inline)) void cosine_loop(int m, const double *ux, const double *uy, double *wx,
                                                              double *wy, double *wz)
{
    for (int j = 0; j < m; ++j) {
        double a = 2.0 * ux[j] - 1.0, b = 2.0 * uy[j] - 1.0;
        bool zero = a == 0.0 && b == 0.0;
        /* |a| > |b|: phi = (pi/4)(b/a), the point (a cos, a sin); else the point (b sin, b cos) of
         * the angle (pi/4)(a/b) */
        bool big = fabs(a) > fabs(b);
        double num = big ? b : a, r = big ? a : b;
        double s, c;
        spc_sincos_quarter((SPC_PI / 4.0) * (num / (zero ? 1.0 : r)), &s, &c);
        double dx = zero ? 0.0 : r * (big ? c : s), dy = zero ? 0.0 : r * (big ? s : c);
        double t = 1.0 - dx * dx - dy * dy;
        wx[j] = dx;
        wy[j] = dy;
        wz[j] = t > 0.0 ? sqrt(t) : 0.0;
    }
}

static void cosine_base(int m, const double *ux, const double *uy, double *wx, double *wy, double *wz)
{
    cosine_loop(m, ux, uy, wx, wy, wz);
}

#if defined(__GNUC__) && defined(__x86_64__)
#define WARP_MANY_VECTOR 1
#if defined(__clang__)
#define WARP_MANY_ATTR(t) __attribute__((target(t)))
#else
#define WARP_MANY_ATTR(t) __attribute__((target(t), optimize("O3"))) /* GCC's -O2 does not vectorize */
#endif
WARP_MANY_ATTR("avx2")
static void cosine_avx2(int m, const double *ux, const double *uy, double *wx, double *wy, double *wz)
{
    cosine_loop(m, ux, uy, wx, wy, wz);
}
WARP_MANY_ATTR("avx512f")
static void cosine_avx512(int m, const double *ux, const double *uy, double *wx, double *wy, double *wz)
{
    cosine_loop(m, ux, uy, wx, wy, wz);
}
#endif

typedef void (*cosine_fn)(int, const double *, const double *, double *, double *, double *);
static cosine_fn cosine = cosine_base;
static pthread_once_t cosine_once = PTHREAD_ONCE_INIT;

/* The best variant under cpu_isa.h's choice. */
static void cosine_init(void)
{
#ifdef WARP_MANY_VECTOR
    int isa = spc_vector_isa();
    if (isa == SPC_ISA_AVX512)
        cosine = cosine_avx512;
    else if (isa == SPC_ISA_AVX2)
        cosine = cosine_avx2;
#endif
}

void spc_warp_cosine_hemisphere_many(int n, const spc_vec2 *u, spc_vec3 *w)
{
    double ux[WARP_MANY_BATCH], uy[WARP_MANY_BATCH], wx[WARP_MANY_BATCH], wy[WARP_MANY_BATCH], wz[WARP_MANY_BATCH];
    pthread_once(&cosine_once, cosine_init);
    for (int i0 = 0; i0 < n; i0 += WARP_MANY_BATCH) {
        int m = n - i0 < WARP_MANY_BATCH ? n - i0 : WARP_MANY_BATCH;
        for (int j = 0; j < m; ++j) {
            ux[j] = u[i0 + j].x;
            uy[j] = u[i0 + j].y;
        }
        cosine(m, ux, uy, wx, wy, wz);
        for (int j = 0; j < m; ++j)
            w[i0 + j] = spc_v3(wx[j], wy[j], wz[j]);
    }
}
