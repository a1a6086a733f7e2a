/*
 * bench/bench_chains.h: the random admissible specular chains that bench_solvers and bench_newton
 * share (one definition, so both benchmarks solve exactly the same chains from the same random
 * streams): the three scenes built in code, the chain generator (traced from a light point through
 * exactly k specular interfaces). Header-only; include once per benchmark program.
 */
#ifndef SPC_BENCH_CHAINS_H
#define SPC_BENCH_CHAINS_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h" /* bench_thread_seconds: the solves are timed by this thread's CPU time */
#include "core/rng.h"
#include "core/warp.h"
#include "manifold/specular_nee.h"
#include "render_util.h" /* tu_glass, tu_mirror (tests/) */
#include "scene/scene.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

static void sphere(spc_scene *sc, spc_vec3 c, double r, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_sphere(s, c, r, NULL, NULL, 0, 0, &err);
    s->bsdf = b;
}

/* UV sphere (nu x nv quads) with vertex normals, scaled by (sx, sy, sz) about c (an ellipsoid: the
 * normals are the ellipsoid's). */
static void mesh_ellipsoid(spc_scene *sc, spc_vec3 c, spc_vec3 r, int nu, int nv, const spc_bsdf *b)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = (size_t)(nu * (nv + 1));
    m.ntris = (size_t)(2 * nu * nv);
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.n = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    for (int j = 0; j <= nv; ++j)
        for (int i = 0; i < nu; ++i) {
            double th = SPC_PI * j / nv, ph = 2 * SPC_PI * i / nu;
            spc_vec3 l = spc_v3(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
            spc_vec3 n = spc_normalize(spc_v3(l.x / r.x, l.y / r.y, l.z / r.z));
            size_t k = (size_t)(j * nu + i);
            m.p[3 * k] = (float)(c.x + r.x * l.x);
            m.p[3 * k + 1] = (float)(c.y + r.y * l.y);
            m.p[3 * k + 2] = (float)(c.z + r.z * l.z);
            m.n[3 * k] = (float)n.x;
            m.n[3 * k + 1] = (float)n.y;
            m.n[3 * k + 2] = (float)n.z;
        }
    size_t t = 0;
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            uint32_t a = (uint32_t)(j * nu + i), bb = (uint32_t)(j * nu + (i + 1) % nu);
            uint32_t cc = (uint32_t)((j + 1) * nu + i), dd = (uint32_t)((j + 1) * nu + (i + 1) % nu);
            uint32_t tri[6] = {a, cc, bb, bb, cc, dd};
            memcpy(m.idx + 3 * t, tri, sizeof tri);
            t += 2;
        }
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    if (!spc_shape_init_mesh(s, &m, NULL, NULL, 0, 0, &err))
        fprintf(stderr, "mesh: %s\n", err.msg);
    s->bsdf = b;
}

/* An SDF shape: a torus (major 1, minor 0.4), a sphere (radius 0.8) or a rounded box (half sizes
 * 0.6, 0.5, 0.7, rounding 0.15), placed by M. */
static void sdf_shape(spc_scene *sc, spc_sdf_type type, const spc_mat4 *M, const spc_bsdf *b)
{
    spc_sdf_desc d;
    spc_sdf_desc_init(&d, type);
    if (type == SPC_SDF_TORUS) {
        d.major = 1.0;
        d.minor = 0.4;
    } else if (type == SPC_SDF_ROUNDBOX) {
        d.half_size = spc_v3(0.6, 0.5, 0.7);
        d.radius = 0.15;
    } else {
        d.radius = 0.8;
    }
    if (!tu_sdf(sc, &d, M, b))
        exit(3);
}

static spc_scene *make_scene(int which)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    switch (which) {
    case 0:
        sphere(sc, spc_v3(0, 0, 0), 1.0, tu_glass(sc, 1.5));
        sphere(sc, spc_v3(2.6, 0.5, 0.3), 0.8, tu_mirror(sc));
        sphere(sc, spc_v3(-1.5, 2.2, -0.4), 0.7, tu_glass(sc, 1.33));
        sphere(sc, spc_v3(0.4, -2.4, 0.8), 0.9, tu_mirror(sc));
        break;
    case 1:
        mesh_ellipsoid(sc, spc_v3(0, 0, 0), spc_v3(1, 1, 1), 64, 32, tu_glass(sc, 1.5));
        mesh_ellipsoid(sc, spc_v3(2.6, 0.5, 0.3), spc_v3(0.8, 0.6, 0.9), 48, 24, tu_mirror(sc));
        mesh_ellipsoid(sc, spc_v3(-1.5, 2.2, -0.4), spc_v3(0.7, 0.9, 0.5), 48, 24, tu_glass(sc, 1.33));
        break;
    case 3: {
        /* signed distance fields: a tilted glass torus, a mirror sphere, a glass rounded box */
        spc_mat4 R = spc_mat4_rotate(spc_v3(1, 0, 0), 35), T = spc_mat4_translate(spc_v3(0, 0, 0));
        spc_mat4 M = spc_mat4_mul(&T, &R);
        sdf_shape(sc, SPC_SDF_TORUS, &M, tu_glass(sc, 1.5));
        M = spc_mat4_translate(spc_v3(2.6, 0.5, 0.3));
        sdf_shape(sc, SPC_SDF_SPHERE, &M, tu_mirror(sc));
        spc_mat4 R2 = spc_mat4_rotate(spc_v3(0, 0, 1), 25), T2 = spc_mat4_translate(spc_v3(-1.6, 2.2, -0.4));
        M = spc_mat4_mul(&T2, &R2);
        sdf_shape(sc, SPC_SDF_ROUNDBOX, &M, tu_glass(sc, 1.33));
        break;
    }
    case 2: {
        sphere(sc, spc_v3(0, 0, 0), 1.0, tu_glass(sc, 1.5));
        mesh_ellipsoid(sc, spc_v3(2.6, 0.5, 0.3), spc_v3(0.8, 0.8, 0.8), 48, 24, tu_glass(sc, 1.5));
        sphere(sc, spc_v3(0.4, -2.4, 0.8), 0.9, tu_mirror(sc));
        spc_shape *d = spc_scene_new_shape(sc);
        spc_mat4 S = spc_mat4_scale(spc_v3(2, 2, 2)), R = spc_mat4_rotate(spc_v3(1, 0, 0), 80),
                 T = spc_mat4_translate(spc_v3(-0.5, 2.8, 0));
        spc_mat4 RS = spc_mat4_mul(&R, &S), M = spc_mat4_mul(&T, &RS);
        spc_shape_init_disk(d, &M, NULL, 0, 0, &err);
        d->bsdf = tu_mirror(sc);
        spc_shape *cy = spc_scene_new_shape(sc);
        spc_shape_init_cylinder(cy, spc_v3(-2.2, -0.8, -1.5), spc_v3(-2.0, -0.6, 1.5), 0.6, NULL, NULL, 0, 0, &err);
        cy->bsdf = tu_glass(sc, 1.6);
        break;
    }
    }
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        fprintf(stderr, "finalize: %s\n", err.msg);
        exit(3);
    }
    return sc;
}

static spc_hit free_point(spc_vec3 p)
{
    spc_hit h;
    memset(&h, 0, sizeof h);
    h.p = p;
    h.ng = spc_v3(0, 0, 1);
    h.sh = spc_frame_from_n(h.ng);
    return h;
}

/* A random admissible chain of exactly k vertices: y, x, the generating chain from x (reversed),
 * and the direction x -> x_1. False if this attempt did not produce one. */
static bool make_chain(const spc_scene *sc, int k, spc_vec3 *y, spc_vec3 *x, spc_chain *from_x)
{
    /* y: a random point of the scene's bounding sphere outside every shape */
    spc_vec3 p = spc_madd(sc->center, spc_warp_uniform_sphere(spc_v2(rnd(), rnd())), sc->radius * cbrt(rnd()));
    int ns = sc->nshapes;
    const spc_shape *s = sc->shapes[(int)(rnd() * ns) % ns];
    spc_shape_sample ss;
    spc_shape_sample_area(s, spc_v2(rnd(), rnd()), &ss);
    spc_vec3 d = spc_sub(ss.p, p);
    if (!(spc_length(d) > 0.0))
        return false;
    spc_hit hy = free_point(p);
    spc_frame fr = spc_frame_from_n(spc_normalize(d));
    spc_chain_opts o = spc_chain_opts_default(k);
    o.any_surface = true;
    spc_chain c;
    spc_chain_trace(sc, &hy, &fr, 0, 0, &o, &c);
    if (c.n != k || !(c.end == SPC_CHAIN_END_ESCAPED || c.end == SPC_CHAIN_END_SURFACE || c.end == SPC_CHAIN_END_LIMIT))
        return false;
    /* y must be outside every closed shape: its first segment must start in air (the first
     * vertex is entered from outside, or reflects off the outside) */
    if (spc_dot(c.v[0].wi, c.v[0].h.ng) > 0.0)
        return false;
    const spc_chain_vertex *last = &c.v[k - 1];
    double tmax = c.has_end_hit ? c.end_hit.t : sc->radius;
    double t = (0.05 + 0.9 * rnd()) * tmax;
    if (!(t > 1e-3 * sc->radius))
        return false;
    *y = p;
    *x = spc_madd(last->h.p, last->d, t);
    /* the generating solution from x: trace back along -d with the same events */
    spc_hit hx = free_point(*x);
    spc_frame fb = spc_frame_from_n(spc_neg(last->d));
    spc_chain_opts ob = spc_chain_opts_default(k);
    ob.any_surface = true;
    spc_chain_trace(sc, &hx, &fb, 0, 0, &ob, from_x);
    return from_x->n == k && spc_distance(from_x->v[k - 1].h.p, c.v[0].h.p) < 1e-6 * sc->radius;
}

#endif /* SPC_BENCH_CHAINS_H */
