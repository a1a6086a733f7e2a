/*
 * bench/bench_newton.c: the Newton solver (manifold NEE) next to the angular solver on the
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

#include "bench_chains.h"

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
                    double t0 = bench_thread_seconds();
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
                    secs += bench_thread_seconds() - t0;
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
