/*
 * tests/chain_mis.h: the BSDF-sampled paths that specular NEE also covers, and their MIS weights,
 * for the tests of the chain MIS weights on a scene with a glass or mirror object over a floor
 * (test_sphere_chain_mis.c, test_sdf_chain_mis.c, test_cylinder_chain_mis.c).
 *
 * From a floor point, paths are sampled by the BSDFs alone and weighted by
 * spc_snee_mis_bsdf_weight where specular NEE covers them; chain_mis_zmax compares specular NEE
 * plus those weighted paths with BSDF sampling alone (every weight 1) by a z-test per point.
 */
#ifndef SPC_TESTS_CHAIN_MIS_H
#define SPC_TESTS_CHAIN_MIS_H

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/rng.h"
#include "core/warp.h"
#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "specula/specula.h"

/* The longest chain the tests weight: specular NEE's long pass of up to 6 vertices (a test of
 * longer chains defines it before the include). */
#ifndef CHAIN_MIS_LONG_MAX
#define CHAIN_MIS_LONG_MAX 6
#endif

/* The scene at `path`, with its light's radius and radiance set (the XML's defaults light_radius and
 * light_radiance) where light_radius is given; NULL (and a failed check) if it does not load. */
static inline spc_scene *chain_mis_load(const char *path, const char *light_radius, const char *light_radiance)
{
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_define defs[2] = {{"light_radius", light_radius}, {"light_radiance", light_radiance}};
    CHECK_MSG(spc_scene_load(path, defs, light_radius ? 2 : 0, &sc, &err) == SPC_OK, "%s: %s", path, err.msg);
    return sc;
}

/* The point of the floor (shape floor_index) below (px, pz). */
static inline bool chain_mis_floor_point(const spc_scene *sc, int floor_index, double px, double pz, spc_hit *x)
{
    spc_ray ray = {spc_v3(px, 0.01, pz), spc_v3(0, -1, 0), 0, INFINITY};
    return spc_scene_intersect(sc, &ray, x) && x->shape_index == floor_index;
}

/* The lobe-choice number for a BSDF sample, drawn from u; with `even`, 0 or just below 1 with
 * probability 1/2 each, so that a dielectric reflects or refracts with probability 1/2 (u_lobe
 * below or above F) instead of F and 1 - F. */
static inline double chain_mis_lobe_u(spc_rng *u, bool even)
{
    double ul = spc_rng_next(u);
    if (even)
        ul = ul < 0.5 ? 0.0 : 1.0 - 1e-12;
    return ul;
}

/* The path leaving x along d0 (x's lobe `lobe`, throughput T) through at most CHAIN_MIS_LONG_MAX
 * chain vertices, each sampled by its BSDF (its lobe chosen by chain_mis_lobe_u with `even`), to the
 * light: its luminance times its MIS weight (1 with plain, or where specular NEE does not cover it);
 * *k the chain vertices passed, *w the weight, both -1 where the path does not reach the light. */
static inline double chain_mis_trace_from(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                                          spc_vec3 d0, unsigned lobe, spc_rgb T, bool plain, bool even, spc_rng *u,
                                          int *k_out, double *w_out)
{
    *k_out = -1;
    *w_out = -1.0;
    spc_snee_track t;
    memset(&t, 0, sizeof t);
    spc_snee_track_scatter_params(&t, p, x, lobe, 2, CHAIN_MIS_LONG_MAX);
    spc_ray ray = spc_hit_spawn(x, d0);
    for (int k = 0; k <= CHAIN_MIS_LONG_MAX; ++k) {
        spc_hit h;
        int ev;
        if (!spc_scene_intersect(sc, &ray, &h))
            return 0.0;
        if (h.emitter) {
            if (k < 1)
                return 0.0; /* the light seen directly: the path tracer's own NEE, not this test's */
            double w = 1.0;
            if (!plain && spc_snee_track_covers(&t, sc, h.emitter))
                w = spc_snee_mis_bsdf_weight(sc, p, x, wo, d0, t.max_chain, t.k, t.events, &h);
            *k_out = k;
            *w_out = w;
            return w * spc_rgb_lum(spc_rgb_mul(T, spc_emitter_eval_area(h.emitter, &h, spc_neg(ray.d))));
        }
        spc_bsdf_sample b2;
        if (k == CHAIN_MIS_LONG_MAX || !spc_chain_surface(&h, false, &ev) ||
            !spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, spc_neg(ray.d), chain_mis_lobe_u(u, even),
                                 spc_v2(spc_rng_next(u), spc_rng_next(u)), &b2))
            return 0.0;
        spc_snee_track_scatter_params(&t, p, &h, b2.lobe, 0, 0);
        T = spc_rgb_mul(T, b2.weight);
        ray = spc_hit_spawn(&h, b2.wi);
    }
    return 0.0;
}

/* One BSDF-sampled path from x, as chain_mis_trace_from. */
static inline double chain_mis_bsdf_path(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                                         bool plain, spc_rng *u, int *k_out, double *w_out)
{
    *k_out = -1;
    *w_out = -1.0;
    spc_bsdf_sample bs;
    if (!spc_bsdf_sample_dir(x->bsdf, x, SPC_MODE_RADIANCE, wo, spc_rng_next(u),
                             spc_v2(spc_rng_next(u), spc_rng_next(u)), &bs))
        return 0.0;
    return chain_mis_trace_from(sc, p, x, wo, bs.wi, bs.lobe, bs.weight, plain, false, u, k_out, w_out);
}

/* The MIS weights of the paths from x (seen along wo) whose first direction is drawn uniformly in
 * the cone toward the sphere (centre, radius) and that reach the light through 3 or more chain
 * vertices (chain_mis_trace_from with `even`): at most `draws` directions, stopping at nmax such
 * paths; *n their count, *wsum and *wmax the sum and the largest of their weights. */
static inline void chain_mis_long_weights(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                                          spc_vec3 centre, double radius, int draws, int nmax, bool even, int *n,
                                          double *wsum, double *wmax)
{
    spc_vec3 axis = spc_sub(centre, x->p);
    double dist = spc_length(axis), cos_max = sqrt(1.0 - radius * radius / (dist * dist));
    spc_frame fr = spc_frame_from_n(spc_scale(axis, 1.0 / dist));
    spc_rng u;
    spc_rng_seed(&u, 7, 1);
    *n = 0;
    *wsum = *wmax = 0.0;
    for (int i = 0; i < draws && *n < nmax; ++i) {
        spc_vec3 d0 =
            spc_frame_to_world(&fr, spc_warp_uniform_cone(spc_v2(spc_rng_next(&u), spc_rng_next(&u)), cos_max));
        if (!(spc_dot(d0, x->ng) > 0.0))
            continue;
        int k;
        double w;
        chain_mis_trace_from(sc, p, x, wo, d0, SPC_LOBE_DIFFUSE_REFLECTION, spc_rgb1(1.0), false, even, &u, &k, &w);
        if (k >= 3) {
            ++*n;
            *wsum += w;
            *wmax = w > *wmax ? w : *wmax;
        }
    }
}

/* Specular NEE with MIS on angular chains of up to 2 vertices, the parameters both tests use. */
static inline void chain_mis_default_params(spc_snee_params *p)
{
    CHECK(spc_snee_parse("angular", 2, p));
    p->mis = true;
}

/* At each of the floor points pts[0..npts) (floor shape floor_index), seen from `camera`: N
 * samples of specular NEE plus the BSDF-sampled paths it covers, weighted, against N of BSDF
 * sampling alone; each point's means printed. Returns the largest |z| of their difference. */
static inline double chain_mis_zmax(const spc_scene *sc, const spc_snee_params *p, int floor_index,
                                    const double (*pts)[2], int npts, spc_vec3 camera, int N)
{
    double zmax = 0.0;
    for (int i = 0; i < npts; ++i) {
        spc_hit x;
        CHECK(chain_mis_floor_point(sc, floor_index, pts[i][0], pts[i][1], &x));
        spc_vec3 wo = spc_normalize(spc_sub(camera, x.p));
        double s[2][2] = {{0, 0}, {0, 0}};
        for (int j = 0; j < 2; ++j) {
            spc_rng r, u;
            spc_rng_seed(&r, 11 + (uint64_t)i, 1 + (uint64_t)j);
            spc_rng_seed(&u, 13 + (uint64_t)i, 1 + (uint64_t)j);
            for (int n = 0; n < N; ++n) {
                int k;
                double w, v = chain_mis_bsdf_path(sc, p, &x, wo, j == 1, &u, &k, &w);
                if (j == 0)
                    v += spc_rgb_lum(spc_specular_nee_depth(sc, p, &x, wo, 2, CHAIN_MIS_LONG_MAX, &r, NULL));
                s[j][0] += v;
                s[j][1] += v * v;
            }
        }
        double m[2], se[2];
        for (int j = 0; j < 2; ++j) {
            m[j] = s[j][0] / N;
            se[j] = sqrt(spc_max(s[j][1] / N - m[j] * m[j], 0.0) / N);
        }
        double z = (m[0] - m[1]) / hypot(se[0], se[1]);
        printf("    (%.2f, %.2f): specular NEE + weighted %.4f +- %.4f, BSDF sampling alone %.4f +- %.4f, z %+.2f\n",
               pts[i][0], pts[i][1], m[0], se[0], m[1], se[1], z);
        zmax = fabs(z) > zmax ? fabs(z) : zmax;
    }
    return zmax;
}

/* chain_mis_zmax on the scene at `path` (its light set as chain_mis_load sets it) with
 * chain_mis_default_params: |z| < 4 at every point. */
static inline void chain_mis_check_agrees(const char *path, const char *light_radius, const char *light_radiance,
                                          int floor_index, const double (*pts)[2], int npts, spc_vec3 camera, int N)
{
    spc_scene *sc = chain_mis_load(path, light_radius, light_radiance);
    if (!sc)
        return;
    spc_snee_params p;
    chain_mis_default_params(&p);
    double zmax = chain_mis_zmax(sc, &p, floor_index, pts, npts, camera, N);
    CHECK_MSG(zmax < 4.0, "|z| %.2f", zmax);
    spc_scene_destroy(sc);
}

#endif
