/*
 * emitter/direct_lanes.h: what the vector loops of light samples for many lanes (area_many.c for
 * mesh lights, sphere_many.c for sphere lights) share: the arrays their arithmetic loops write, one
 * per quantity (structure of arrays), the store of one lane's results into them, and the write-back
 * of a lane into its spc_emitter_direct record. Private to emitter/.
 *
 * The store is a macro so that it stands inside each file's loop body, which is compiled once plain
 * and once per vector target; the record is written as spc_area_sample_direct writes it, with
 * spc_area_eval's value for a constant radiance.
 */
#ifndef SPC_EMITTER_DIRECT_LANES_H
#define SPC_EMITTER_DIRECT_LANES_H

#include <stdbool.h>

#include "emitter/emitter.h"
#include "scene/texture.h"

/* The most lanes of one batch of the arithmetic loops (a call of spc_emitter_sample_direct_many
 * runs its lanes in batches of this many). A batch's arrays (about 25 of them, inputs and results)
 * take 6 KiB and stay in the L1 cache; with a call's 256 lanes they would take 50 KiB, and arrays
 * 2 KiB apart fall on the same few cache sets, so the stores of a lane's 15 inputs would evict each
 * other (measured: 32 lanes took 7-8% less CPU on the cornell box than 256; 16 and 64 as 32). */
#define SPC_DIRECT_LANES_MAX 32

/* A batch's results, lane k at index k. */
typedef struct spc_direct_lanes {
    double p[3][SPC_DIRECT_LANES_MAX];  /* the point on the light */
    double n[3][SPC_DIRECT_LANES_MAX];  /* its normal (flip_normals applied) */
    double wi[3][SPC_DIRECT_LANES_MAX]; /* unit direction from the reference point toward p */
    double dist[SPC_DIRECT_LANES_MAX], pdf[SPC_DIRECT_LANES_MAX], err[SPC_DIRECT_LANES_MAX];
    double facing[SPC_DIRECT_LANES_MAX]; /* dot(n, -wi): the light is seen from its front when > 0 */
} spc_direct_lanes;

/* Stores lane i's point (px, py, pz), direction (wx, wy, wz), distance and density into the arrays
 * *o, and the facing term of the normal (nx, ny, nz); the normal itself is stored by the caller (a
 * mesh light's is an input). */
#define SPC_DIRECT_LANES_STORE(o, i, px, py, pz, nx, ny, nz, wx, wy, wz, dist_, pdf_)                                  \
    do {                                                                                                               \
        (o)->p[0][i] = (px);                                                                                           \
        (o)->p[1][i] = (py);                                                                                           \
        (o)->p[2][i] = (pz);                                                                                           \
        (o)->wi[0][i] = (wx);                                                                                          \
        (o)->wi[1][i] = (wy);                                                                                          \
        (o)->wi[2][i] = (wz);                                                                                          \
        (o)->dist[i] = (dist_);                                                                                        \
        (o)->pdf[i] = (pdf_);                                                                                          \
        (o)->facing[i] = (nx) * -(wx) + (ny) * -(wy) + (nz) * -(wz);                                                   \
    } while (0)

/* Lane k of *a into the record *out of a light with the constant radiance `radiance`; valid: the
 * sample passed spc_area_sample_direct's tests (else only the record's flags are written). Returns
 * whether the record is a sample: valid, and the light seen from its front with a nonzero radiance. */
static inline bool spc_direct_lanes_write(const spc_direct_lanes *a, int k, bool valid, const spc_texture *radiance,
                                          spc_emitter_direct *out)
{
    out->is_delta = false;
    out->is_infinite = false;
    if (!valid)
        return false;
    out->p = spc_v3(a->p[0][k], a->p[1][k], a->p[2][k]);
    out->n = spc_v3(a->n[0][k], a->n[1][k], a->n[2][k]);
    out->wi = spc_v3(a->wi[0][k], a->wi[1][k], a->wi[2][k]);
    out->dist = a->dist[k];
    /* the radiance tested as a local value: read back from the record, it would come through a
     * store of two channels and a load of one (a stall) */
    spc_rgb L = a->facing[k] <= 0.0 ? spc_rgb1(0.0) : spc_texture_eval(radiance, spc_v2(0.0, 0.0));
    out->L = L;
    out->pdf = a->pdf[k];
    out->err = a->err[k];
    return !spc_rgb_is_black(L);
}

#endif
