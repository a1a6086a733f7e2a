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

/* The length of every per-lane array of a batch: a cache line (8 doubles) more than the lanes. At
 * exactly SPC_EMITTER_MANY_MAX the arrays lie 2 KiB apart, so lane k of all of them (the 15 to 20
 * arrays that a lane's gather writes and the vector loop reads) falls into the same two sets of a
 * 32 KiB 8-way L1 cache, which then evicts lines before their 8 lanes are used; the extra line
 * staggers the arrays across sets. */
#define SPC_DIRECT_LANES_N (SPC_EMITTER_MANY_MAX + 8)

/* A batch's results, lane k at index k. */
typedef struct spc_direct_lanes {
    double p[3][SPC_DIRECT_LANES_N];  /* the point on the light */
    double n[3][SPC_DIRECT_LANES_N];  /* its normal (flip_normals applied) */
    double wi[3][SPC_DIRECT_LANES_N]; /* unit direction from the reference point toward p */
    double dist[SPC_DIRECT_LANES_N], pdf[SPC_DIRECT_LANES_N], err[SPC_DIRECT_LANES_N];
    double facing[SPC_DIRECT_LANES_N]; /* dot(n, -wi): the light is seen from its front when > 0 */
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
    out->L = a->facing[k] <= 0.0 ? spc_rgb1(0.0) : spc_texture_eval(radiance, spc_v2(0.0, 0.0));
    out->pdf = a->pdf[k];
    out->err = a->err[k];
    return !spc_rgb_is_black(out->L);
}

#endif
