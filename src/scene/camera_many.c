/*
 * scene/camera_many.c: the camera rays of many film points at once (a tile of the packet path
 * tracer, render/driver.c).
 *
 * A pinhole ray is a short chain with a square root and a division (spc_camera_ray); one at a time
 * their latencies add up. Here the film points go through one loop in structure-of-arrays form,
 * compiled also for AVX2 and AVX-512 and chosen at run time, so 4 or 8 rays share an instruction.
 * Bit for bit: spc_camera_ray's arithmetic in its order, in double, without fused multiply-adds
 * (ISO C11 builds do not contract, and the vector targets do not include FMA); test_rfilter compares
 * every ray with spc_camera_ray's under every ISA.
 */
#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "scene/camera.h"
#include "core/cpu_isa.h"

/* rays per pass of the loop (arrays on the stack) */
#define CAMERA_MANY_BATCH 64

typedef struct pinhole {
    double d0[3], dfx[3], dfy[3], near_clip, far_clip;
} pinhole;

static inline __attribute__((always_inline)) void pinhole_loop(const pinhole *c, int m, const double *fx,
                                                               const double *fy, double (*d)[CAMERA_MANY_BATCH],
                                                               double *tmin, double *tmax)
{
    /* the camera's terms in locals: read through c inside the loop, they might alias the outputs as
     * far as GCC can tell, and the run-time checks for that are more than it makes (the loop stayed
     * scalar in every variant) */
    const double d0x = c->d0[0], d0y = c->d0[1], d0z = c->d0[2];
    const double fxx = c->dfx[0], fxy = c->dfx[1], fxz = c->dfx[2];
    const double fyx = c->dfy[0], fyy = c->dfy[1], fyz = c->dfy[2];
    const double near_clip = c->near_clip, far_clip = c->far_clip;
    for (int j = 0; j < m; ++j) {
        /* spc_madd(spc_madd(d0, dfx, fx), dfy, fy), spc_length, spc_scale(dw, 1 / len) */
        double x = (d0x + fxx * fx[j]) + fyx * fy[j];
        double y = (d0y + fxy * fx[j]) + fyy * fy[j];
        double z = (d0z + fxz * fx[j]) + fyz * fy[j];
        double len = sqrt(x * x + y * y + z * z);
        double inv = 1.0 / len;
        d[0][j] = x * inv;
        d[1][j] = y * inv;
        d[2][j] = z * inv;
        tmin[j] = near_clip * len;
        tmax[j] = far_clip * len;
    }
}

static void pinhole_base(const pinhole *c, int m, const double *fx, const double *fy,
                         double (*d)[CAMERA_MANY_BATCH], double *tmin, double *tmax)
{
    pinhole_loop(c, m, fx, fy, d, tmin, tmax);
}

#if defined(__GNUC__) && defined(__x86_64__)
#define CAMERA_MANY_VECTOR 1
#if defined(__clang__)
#define CAMERA_MANY_ATTR(t) __attribute__((target(t)))
#else
#define CAMERA_MANY_ATTR(t) __attribute__((target(t), optimize("O3"))) /* GCC's -O2 does not vectorize */
#endif
CAMERA_MANY_ATTR("avx2")
static void pinhole_avx2(const pinhole *c, int m, const double *fx, const double *fy,
                         double (*d)[CAMERA_MANY_BATCH], double *tmin, double *tmax)
{
    pinhole_loop(c, m, fx, fy, d, tmin, tmax);
}
CAMERA_MANY_ATTR("avx512f")
static void pinhole_avx512(const pinhole *c, int m, const double *fx, const double *fy,
                           double (*d)[CAMERA_MANY_BATCH], double *tmin, double *tmax)
{
    pinhole_loop(c, m, fx, fy, d, tmin, tmax);
}
#endif

typedef void (*pinhole_fn)(const pinhole *, int, const double *, const double *, double (*)[CAMERA_MANY_BATCH],
                           double *, double *);
static pinhole_fn pinhole_rays = pinhole_base;
static pthread_once_t pinhole_once = PTHREAD_ONCE_INIT;

/* The best variant under cpu_isa.h's choice. */
static void pinhole_init(void)
{
#ifdef CAMERA_MANY_VECTOR
    int isa = spc_vector_isa();
    if (isa == SPC_ISA_AVX512)
        pinhole_rays = pinhole_avx512;
    else if (isa == SPC_ISA_AVX2)
        pinhole_rays = pinhole_avx2;
#endif
}

void spc_camera_ray_many(const spc_camera_state *cs, int n, const double *fx, const double *fy, spc_ray *out)
{
    if (cs->type == SPC_CAMERA_ORTHOGRAPHIC) {
        for (int i = 0; i < n; ++i)
            out[i] = spc_camera_ray(cs, fx[i], fy[i]);
        return;
    }
    pthread_once(&pinhole_once, pinhole_init);
    pinhole c = {{cs->ray_d0.x, cs->ray_d0.y, cs->ray_d0.z},
                 {cs->ray_dfx.x, cs->ray_dfx.y, cs->ray_dfx.z},
                 {cs->ray_dfy.x, cs->ray_dfy.y, cs->ray_dfy.z},
                 cs->near_clip,
                 cs->far_clip};
    double d[3][CAMERA_MANY_BATCH], tmin[CAMERA_MANY_BATCH], tmax[CAMERA_MANY_BATCH];
    for (int i0 = 0; i0 < n; i0 += CAMERA_MANY_BATCH) {
        int m = n - i0 < CAMERA_MANY_BATCH ? n - i0 : CAMERA_MANY_BATCH;
        pinhole_rays(&c, m, fx + i0, fy + i0, d, tmin, tmax);
        for (int j = 0; j < m; ++j) {
            spc_ray *r = &out[i0 + j];
            r->o = cs->origin;
            r->d = spc_v3(d[0][j], d[1][j], d[2][j]);
            r->tmin = tmin[j];
            r->tmax = tmax[j];
        }
    }
}
