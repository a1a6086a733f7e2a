/*
 * bench/bench_solvers.c: the specular solvers on random admissible chains.
 *
 *   build/bench_solvers [chains per configuration (default 2000)] [rng seed] [scene name]
 *
 * Four scenes built in code (scale 1; all, or the one named):
 *   spheres  analytic glass and mirror spheres;
 *   mesh     a glass UV sphere and a mirror ellipsoid tessellated with vertex normals (smooth
 *            shading through interpolated normals), and a glass mesh ellipsoid;
 *   mixed    analytic spheres, a mirror disk, a glass mesh sphere and a glass cylinder;
 *   sdf      signed distance fields: a tilted glass torus, a mirror sphere, a glass rounded box.
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
 * Timings: CPU time of the thread during the solves only (bench_chains.h), one thread. Results go
 * to bench/RESULTS.md by hand.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "core/rng.h"
#include "core/warp.h"
#include "manifold/specular_nee.h"
#include "scene/scene.h"

#include "bench_chains.h"

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
    const char *scene_names[4] = {"spheres", "mesh", "mixed", "sdf"};
    const char *only = argc > 3 ? argv[3] : NULL;
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
    for (int si = 0; si < 4; ++si) {
        if (only && strcmp(only, scene_names[si]) != 0)
            continue;
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
                    double t0 = bench_thread_seconds();
                    bool conv = spc_angular_solve(sc, &hx, &tg, sd, &o, &ao, &c, &res);
                    secs += bench_thread_seconds() - t0;
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
