/*
 * bench/bench_solvers.c: the specular solvers on random admissible chains (issue 5).
 *
 *   build/bench_solvers [chains per configuration (default 2000)] [rng seed]
 *
 * Three scenes built in code (scale 1):
 *   spheres  analytic glass and mirror spheres;
 *   mesh     a glass UV sphere and a mirror ellipsoid tessellated with vertex normals (smooth
 *            shading through interpolated normals), and a glass mesh ellipsoid;
 *   mixed    analytic spheres, a mirror disk, a glass mesh sphere and a glass cylinder.
 * An admissible chain of k = 1, 2, 3 interfaces is made by tracing from a random light point y
 * toward a random point of a random specular shape, through exactly k chain vertices (reflection at
 * mirrors, refraction through glass); x is a random point on the final segment before anything it
 * hits. The solver then connects x back to y (y on a small virtual light facing the chain: the
 * PLANE loss; the reversed path is a solution by reciprocity), seeded
 *   shape      toward a uniform random point of the shape of the chain's first vertex, or
 *   perturbed  along the true direction x -> x_1 turned by a random angle of up to 5 (or 20)
 *              degrees, uniformly over that cone.
 * A seed is "in sequence" when its chain visits the same surfaces with the same events as the
 * generating chain (seeding's share of the work); the solver's share is measured on those seeds.
 * Success: converged (residual within the solver's scale-invariant tolerance) with k vertices;
 * "same" also requires the generating solution (every vertex within 1e-4 of the scene size).
 * Timings: wall time of the solves only, one thread. Results go to bench/RESULTS.md by hand.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "core/rng.h"
#include "core/warp.h"
#include "manifold/specular_nee.h"
#include "scene/scene.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

static spc_bsdf *glass(spc_scene *sc, double eta)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_DIELECTRIC;
    b->eta = eta;
    b->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    b->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    return b;
}

static spc_bsdf *mirror(spc_scene *sc)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_CONDUCTOR;
    b->cond_k = spc_rgb1(-1.0);
    b->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    return b;
}

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

static spc_scene *make_scene(int which)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    switch (which) {
    case 0:
        sphere(sc, spc_v3(0, 0, 0), 1.0, glass(sc, 1.5));
        sphere(sc, spc_v3(2.6, 0.5, 0.3), 0.8, mirror(sc));
        sphere(sc, spc_v3(-1.5, 2.2, -0.4), 0.7, glass(sc, 1.33));
        sphere(sc, spc_v3(0.4, -2.4, 0.8), 0.9, mirror(sc));
        break;
    case 1:
        mesh_ellipsoid(sc, spc_v3(0, 0, 0), spc_v3(1, 1, 1), 64, 32, glass(sc, 1.5));
        mesh_ellipsoid(sc, spc_v3(2.6, 0.5, 0.3), spc_v3(0.8, 0.6, 0.9), 48, 24, mirror(sc));
        mesh_ellipsoid(sc, spc_v3(-1.5, 2.2, -0.4), spc_v3(0.7, 0.9, 0.5), 48, 24, glass(sc, 1.33));
        break;
    default: {
        sphere(sc, spc_v3(0, 0, 0), 1.0, glass(sc, 1.5));
        mesh_ellipsoid(sc, spc_v3(2.6, 0.5, 0.3), spc_v3(0.8, 0.8, 0.8), 48, 24, glass(sc, 1.5));
        sphere(sc, spc_v3(0.4, -2.4, 0.8), 0.9, mirror(sc));
        spc_shape *d = spc_scene_new_shape(sc);
        spc_mat4 S = spc_mat4_scale(spc_v3(2, 2, 2)), R = spc_mat4_rotate(spc_v3(1, 0, 0), 80),
                 T = spc_mat4_translate(spc_v3(-0.5, 2.8, 0));
        spc_mat4 RS = spc_mat4_mul(&R, &S), M = spc_mat4_mul(&T, &RS);
        spc_shape_init_disk(d, &M, NULL, 0, 0, &err);
        d->bsdf = mirror(sc);
        spc_shape *cy = spc_scene_new_shape(sc);
        spc_shape_init_cylinder(cy, spc_v3(-2.2, -0.8, -1.5), spc_v3(-2.0, -0.6, 1.5), 0.6, NULL, NULL, 0, 0, &err);
        cy->bsdf = glass(sc, 1.6);
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

typedef struct cfg {
    const char *name;
    spc_angular_method method;
    spc_angular_loss loss;
    int seed; /* 0: shape, else perturbed by up to this many degrees */
    int max_iterations;
} cfg;

int main(int argc, char **argv)
{
    int nchains = argc > 1 ? atoi(argv[1]) : 2000;
    uint64_t seed = argc > 2 ? strtoull(argv[2], NULL, 10) : 1;
    spc_rng_seed(&rng, seed, 5);
    const char *scene_names[3] = {"spheres", "mesh", "mixed"};
    const cfg cfgs[] = {
        {"GN, shape", SPC_ANGULAR_GAUSS_NEWTON, SPC_ANGULAR_LOSS_PLANE, 0, 0},
        {"LM, shape", SPC_ANGULAR_LEVENBERG_MARQUARDT, SPC_ANGULAR_LOSS_PLANE, 0, 0},
        {"GN, perturbed 5 deg", SPC_ANGULAR_GAUSS_NEWTON, SPC_ANGULAR_LOSS_PLANE, 5, 0},
        {"GN, perturbed 5 deg, SEGMENT loss", SPC_ANGULAR_GAUSS_NEWTON, SPC_ANGULAR_LOSS_SEGMENT, 5, 0},
        {"LM, perturbed 5 deg", SPC_ANGULAR_LEVENBERG_MARQUARDT, SPC_ANGULAR_LOSS_PLANE, 5, 0},
        {"GN, perturbed 20 deg", SPC_ANGULAR_GAUSS_NEWTON, SPC_ANGULAR_LOSS_PLANE, 20, 0},
        {"GD (thesis), perturbed 5 deg", SPC_ANGULAR_GRADIENT, SPC_ANGULAR_LOSS_SEGMENT, 5, 500},
    };
    const int ncfg = (int)(sizeof cfgs / sizeof cfgs[0]);
    printf("| scene | k | solver, seed | seed in sequence | success (all seeds) | success (in sequence) | "
           "generating solution (in sequence) | iterations (successes) | iterations (all) | us / solve |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|\n");
    for (int si = 0; si < 3; ++si) {
        spc_scene *sc = make_scene(si);
        for (int k = 1; k <= 3; ++k) {
            /* the chains, made once per (scene, k) and shared by the configurations */
            spc_vec3 *ys = malloc((size_t)nchains * sizeof *ys), *xs = malloc((size_t)nchains * sizeof *xs);
            spc_chain *gen = malloc((size_t)nchains * sizeof *gen);
            int n = 0;
            for (long tries = 0; n < nchains && tries < 2000L * nchains; ++tries)
                if (make_chain(sc, k, &ys[n], &xs[n], &gen[n]))
                    ++n;
            for (int ci = 0; ci < ncfg; ++ci) {
                const cfg *cf = &cfgs[ci];
                spc_angular_options ao;
                spc_angular_options_default(&ao);
                ao.method = cf->method;
                ao.loss = cf->loss;
                if (cf->max_iterations)
                    ao.max_iterations = cf->max_iterations;
                int ok = 0, same = 0, inseq = 0, ok_inseq = 0;
                long it_ok = 0, it_all = 0;
                double secs = 0;
                spc_rng seeds;
                spc_rng_seed(&seeds, seed + 17, (uint64_t)(si * 10 + k));
                for (int i = 0; i < n; ++i) {
                    spc_hit hx = free_point(xs[i]);
                    spc_vec3 d1 = spc_normalize(spc_sub(gen[i].v[0].h.p, xs[i]));
                    spc_vec3 sd;
                    if (cf->seed == 0) {
                        spc_shape_sample ss;
                        spc_shape_sample_area(gen[i].v[0].h.shape, spc_v2(spc_rng_next(&seeds), spc_rng_next(&seeds)),
                                              &ss);
                        sd = spc_normalize(spc_sub(ss.p, xs[i]));
                    } else {
                        spc_frame f = spc_frame_from_n(d1);
                        double cmax = cos(cf->seed * SPC_PI / 180.0);
                        sd = spc_frame_to_world(
                            &f, spc_warp_uniform_cone(spc_v2(spc_rng_next(&seeds), spc_rng_next(&seeds)), cmax));
                    }
                    /* the light's plane at y faces the chain's last segment */
                    spc_angular_target tg;
                    tg.y = ys[i];
                    tg.ny = spc_neg(gen[i].v[k - 1].d);
                    tg.scale = sc->radius;
                    tg.light_size = 0.0;
                    spc_chain_opts o = spc_chain_opts_default(k);
                    o.any_surface = true;
                    spc_chain c;
                    /* is the seed in the generating chain's sequence? (not timed) */
                    spc_frame sf = spc_frame_from_n(sd);
                    spc_chain_trace(sc, &hx, &sf, 0, 0, &o, &c);
                    spc_chain_sig s1, s2;
                    spc_chain_signature(&c, &s1);
                    spc_chain_signature(&gen[i], &s2);
                    bool in = spc_chain_sig_equal(&s1, &s2);
                    inseq += in;
                    spc_angular_result res;
                    double t0 = now();
                    bool conv = spc_angular_solve(sc, &hx, &tg, sd, &o, &ao, &c, &res);
                    secs += now() - t0;
                    it_all += res.iterations;
                    if (conv && c.n == k) {
                        ++ok;
                        ok_inseq += in;
                        it_ok += res.iterations;
                        if (in && spc_snee_same_solution(&c, &gen[i], sc->radius))
                            ++same;
                    }
                }
                printf("| %s | %d | %s | %.1f%% | %.1f%% | %.1f%% | %.1f%% | %.1f | %.1f | %.1f |\n", scene_names[si], k,
                       cf->name, 100.0 * inseq / n, 100.0 * ok / n, inseq ? 100.0 * ok_inseq / inseq : 0.0,
                       inseq ? 100.0 * same / inseq : 0.0, ok ? (double)it_ok / ok : 0.0, (double)it_all / n,
                       1e6 * secs / n);
                fflush(stdout);
            }
            free(ys);
            free(xs);
            free(gen);
        }
        spc_scene_destroy(sc);
    }
    return 0;
}
