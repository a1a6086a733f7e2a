/*
 * bench/bench_newton.c: the Newton solver (manifold NEE, issue 6) next to the angular solver on the
 * random admissible chains of bench/bench_solvers.c (the same scenes and the same chains: the chain
 * generator below is that file's, with the same random streams).
 *
 *   build/bench_newton [chains per configuration (default 2000)] [rng seed]
 *
 * Scenes (scale 1): spheres (analytic glass and mirror spheres), mesh (tessellated glass and mirror
 * ellipsoids with vertex normals), mixed (spheres, a mesh, a disk, a cylinder). For k = 1, 2, 3
 * interfaces, a chain is traced from a random point y toward a random point of a random specular
 * shape through exactly k vertices; x is a random point of its final segment; the solver connects x
 * back to y (a small virtual light at y facing the chain). Seeds:
 *   shape      toward a uniform random point of the shape of the chain's first vertex (the SMS seed
 *              of specular NEE's default SEED_SHAPE);
 *   perturbed  along the true direction x -> x_1 turned by up to 5 degrees;
 *   straight   (newton only) the straight segment x -> y, every chain surface it crosses a vertex
 *              (classic MNEE; deterministic).
 * Success: the solver's own convergence, then (newton) the chain traced from x with the solution's
 * signature meeting the angular solver's tolerance after at most 4 Gauss-Newton polishing traces
 * (spc_newton_to_chain: what specular NEE evaluates), with k vertices. "same": the generating
 * solution (every vertex within 1e-4 of the scene's size). Iterations: angular, chain traces; newton,
 * projections plus polishing traces (each is one ray per vertex in both). Timings: wall time of the
 * solves only (CPU time of the thread), one thread. Results go to bench/RESULTS.md by hand.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "core/rng.h"
#include "core/warp.h"
#include "manifold/newton.h"
#include "manifold/specular_nee.h"
#include "scene/scene.h"

/* CPU time of this thread: the machine is shared, and wall time would count other processes. */
static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
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

/* Why a newton attempt failed: spc_newton_stop, then the seed and the final chain. */
enum { WHY_SEED_PATH = SPC_NEWTON_STOP_SIDES + 1, WHY_POLISH, WHY_LENGTH, NWHY };
#define WHY_SEED WHY_SEED_PATH
#define MAXFAIL 64
static char fail[MAXFAIL][256];
static int nfail;

typedef struct cfg {
    const char *name;
    int solver; /* 0 angular (Gauss-Newton, PLANE loss), 1 newton */
    spc_newton_constraint kind;
    int seed; /* 0: shape, > 0: perturbed by up to this many degrees, -1: straight line */
} cfg;

int main(int argc, char **argv)
{
    int nchains = argc > 1 ? atoi(argv[1]) : 2000;
    uint64_t seed = argc > 2 ? strtoull(argv[2], NULL, 10) : 1;
    spc_rng_seed(&rng, seed, 5);
    const char *scene_names[3] = {"spheres", "mesh", "mixed"};
    const cfg cfgs[] = {
        {"angular GN, shape", 0, SPC_NEWTON_HALF_VECTOR, 0},
        {"newton half vector, shape", 1, SPC_NEWTON_HALF_VECTOR, 0},
        {"newton angle diff, shape", 1, SPC_NEWTON_ANGLE_DIFF, 0},
        {"angular GN, perturbed 5 deg", 0, SPC_NEWTON_HALF_VECTOR, 5},
        {"newton half vector, perturbed 5 deg", 1, SPC_NEWTON_HALF_VECTOR, 5},
        {"newton angle diff, perturbed 5 deg", 1, SPC_NEWTON_ANGLE_DIFF, 5},
        {"newton half vector, straight", 1, SPC_NEWTON_HALF_VECTOR, -1},
        {"newton angle diff, straight", 1, SPC_NEWTON_ANGLE_DIFF, -1},
    };
    const int ncfg = (int)(sizeof cfgs / sizeof cfgs[0]);
    printf("| scene | k | solver, seed | seed in sequence | success (all seeds) | success (in sequence) | "
           "generating solution (in sequence) | iterations (successes) | iterations (all) | us / solve |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|\n");
    for (int si = 0; si < 3; ++si) {
        spc_scene *sc = make_scene(si);
        for (int k = 1; k <= 3; ++k) {
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
                spc_newton_options no;
                spc_newton_options_default(&no);
                no.constraint = cf->kind;
                /* for experiments: SPC_NEWTON_MAX_ITERATIONS, SPC_NEWTON_MIN_BETA override the defaults */
                if (getenv("SPC_NEWTON_MAX_ITERATIONS"))
                    no.max_iterations = atoi(getenv("SPC_NEWTON_MAX_ITERATIONS"));
                if (getenv("SPC_NEWTON_MIN_BETA"))
                    no.min_beta = atof(getenv("SPC_NEWTON_MIN_BETA"));
                if (getenv("SPC_NEWTON_SWITCH_KIND"))
                    no.switch_kind = atoi(getenv("SPC_NEWTON_SWITCH_KIND")) != 0;
                int ok = 0, same = 0, inseq = 0, ok_inseq = 0;
                int why[NWHY] = {0}; /* newton: why seeds in sequence failed */
                long it_ok = 0, it_all = 0;
                double secs = 0;
                spc_rng seeds;
                spc_rng_seed(&seeds, seed + 17, (uint64_t)(si * 10 + k));
                for (int i = 0; i < n; ++i) {
                    spc_hit hx = free_point(xs[i]);
                    spc_vec3 d1 = spc_normalize(spc_sub(gen[i].v[0].h.p, xs[i]));
                    spc_vec3 sd = d1;
                    if (cf->seed == 0) {
                        spc_shape_sample ss;
                        spc_shape_sample_area(gen[i].v[0].h.shape, spc_v2(spc_rng_next(&seeds), spc_rng_next(&seeds)),
                                              &ss);
                        sd = spc_normalize(spc_sub(ss.p, xs[i]));
                    } else if (cf->seed > 0) {
                        spc_frame f = spc_frame_from_n(d1);
                        double cmax = cos(cf->seed * SPC_PI / 180.0);
                        sd = spc_frame_to_world(
                            &f, spc_warp_uniform_cone(spc_v2(spc_rng_next(&seeds), spc_rng_next(&seeds)), cmax));
                    }
                    spc_angular_target tg;
                    tg.y = ys[i];
                    tg.ny = spc_neg(gen[i].v[k - 1].d);
                    tg.scale = sc->radius;
                    tg.light_size = 0.0;
                    spc_chain_opts o = spc_chain_opts_default(k);
                    o.any_surface = true;
                    spc_chain c;
                    spc_chain_sig s1, s2;
                    spc_chain_signature(&gen[i], &s2);
                    /* is the seed in the generating chain's sequence? (not timed) */
                    spc_newton_path np;
                    bool seeded;
                    if (cf->seed < 0) {
                        seeded = spc_newton_seed_straight(sc, &hx, ys[i], k, true, NULL, spc_v3(0, 0, 0), &np);
                    } else {
                        spc_frame sf = spc_frame_from_n(sd);
                        spc_chain_trace(sc, &hx, &sf, 0, 0, &o, &c);
                        spc_newton_path_from_chain(&c, &np);
                        seeded = c.n >= 1;
                    }
                    memset(&s1, 0, sizeof s1);
                    s1.n = seeded ? np.n : 0;
                    for (int j = 0; j < s1.n; ++j) {
                        s1.shape[j] = np.v[j].h.shape_index;
                        s1.event[j] = (unsigned char)np.v[j].event;
                    }
                    bool in = spc_chain_sig_equal(&s1, &s2);
                    inseq += in;
                    int iters = 0;
                    bool conv;
                    double t0 = now();
                    if (cf->solver == 0) {
                        spc_angular_result res;
                        conv = spc_angular_solve(sc, &hx, &tg, sd, &o, &ao, &c, &res);
                        iters = res.iterations;
                    } else {
                        spc_newton_result res;
                        spc_newton_path p;
                        conv = cf->seed < 0 ? spc_newton_seed_straight(sc, &hx, ys[i], k, true, NULL, spc_v3(0, 0, 0), &p)
                                            : spc_newton_seed_trace(sc, &hx, sd, k, true, NULL, spc_v3(0, 0, 0), &p);
                        int w = WHY_SEED;
                        if (conv) {
                            conv = spc_newton_solve(sc, &hx, ys[i], &p, &no, &res);
                            iters = res.iterations;
                            w = (int)res.stop;
                            if (conv) {
                                conv = spc_newton_to_chain(sc, &hx, &p, &tg, &ao, no.polish_iterations, true, &c, &iters);
                                w = !conv ? WHY_POLISH : c.n != k ? WHY_LENGTH : (int)SPC_NEWTON_CONVERGED;
                            }
                        }
                        if (in)
                            why[w]++;
                    }
                    secs += now() - t0;
                    it_all += iters;
                    if (conv && c.n == k) {
                        ++ok;
                        ok_inseq += in;
                        it_ok += iters;
                        if (in && spc_snee_same_solution(&c, &gen[i], sc->radius))
                            ++same;
                    }
                }
                printf("| %s | %d | %s | %.1f%% | %.1f%% | %.1f%% | %.1f%% | %.1f | %.1f | %.1f |\n", scene_names[si], k,
                       cf->name, 100.0 * inseq / n, 100.0 * ok / n, inseq ? 100.0 * ok_inseq / inseq : 0.0,
                       inseq ? 100.0 * same / inseq : 0.0, ok ? (double)it_ok / ok : 0.0, (double)it_all / n,
                       1e6 * secs / n);
                fflush(stdout);
                if (cf->solver == 1 && inseq > 0 && nfail < MAXFAIL) {
                    int len = snprintf(fail[nfail], sizeof fail[nfail], "| %s | %d | %s |", scene_names[si], k, cf->name);
                    for (int r = 1; r < NWHY; ++r)
                        len += snprintf(fail[nfail] + len, sizeof fail[nfail] - (size_t)len, " %.1f%% |",
                                        100.0 * why[r] / inseq);
                    ++nfail;
                }
            }
            free(ys);
            free(xs);
            free(gen);
        }
        spc_scene_destroy(sc);
    }
    printf("\nNewton's failures from seeds in the generating chain's sequence (share of those seeds):\n\n");
    printf("| scene | k | solver, seed | constraints undefined at the seed | singular | iteration cap | no progress | "
           "wrong sides | no seed path | polish | other length |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (int i = 0; i < nfail; ++i)
        printf("%s\n", fail[i]);
    return 0;
}
