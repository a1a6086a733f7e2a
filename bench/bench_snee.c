/*
 * bench/bench_snee.c: where specular NEE's time goes, and its efficiency per receiver point, on a
 * scene file (the angular solver's seeding and trial counting).
 *
 *   build/bench_snee SCENE.xml [-D name=value]... [--solver NAME] [--points N] [--calls M]
 *                    [--seed S] [--profile] CONFIG...
 *
 * Receiver points are collected from camera paths: a random film position, then BSDF sampling
 * through up to 6 bounces; every vertex where specular NEE runs (spc_snee_budget > 0) is kept, up to
 * N points (default 400). At each point the specular NEE estimate is drawn M times (default 200)
 * per configuration, and the bench reports the solver's counters (first attempts that converge,
 * trials per solution, capped counts, chain traces per call), the CPU time per call (of this
 * thread: the machine is shared), the mean estimate summed over the points (an unbiased change
 * leaves it within its standard error) and the mean per-point variance. The efficiency of a
 * configuration is 1 / (variance x time per call): at equal time, the variance of specular NEE's
 * part of the image scales with its inverse. The ratio to the first configuration is printed.
 * Every configuration uses the same random stream per (point, call), so the light points are the
 * same and the ratios are not drowned by the caustic's heavy tail (values near the focus).
 *
 * --profile: only the first attempts (light point, seed, angular solve) as specular NEE makes them,
 * with why they end, their traces and CPU time, and what the converged ones are worth.
 *
 * CONFIG: a seed name (shape, light, bsdf) and options after colons: trials=N (the cap),
 * straight / nostraight (spc_snee_params.straight_first), window=N, keep=F, stall=N, drop=F,
 * iters=N, lm (angular solver options), biased (the biased estimator), reflect=P (chains reflect
 * off dielectrics, spc_snee_params.reflect), cone (the default seed), noexact (chains on one sphere,
 * mirror cylinder or normal-mapped plane left to the randomized attempts, spc_snee_params.exact),
 * mis (weighted against BSDF sampling as the path integrator has it: the BSDF's share is then not
 * in the sums), guide=M and sneep=Q (guided directions, the light sample's probability; with mis).
 * Defaults: those of spc_snee_params_default (without mis). Results go to bench/RESULTS.md by hand.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "core/rng.h"
#include "manifold/specular_nee.h"
#include "scene/camera.h"
#include "scene/scene.h"
#include "specula/specula.h"

typedef struct point {
    spc_hit h;
    spc_vec3 wo;
    int budget;
} point;

/* Receiver points along camera paths (BSDF sampling, no Russian roulette). */
static int collect_points(const spc_scene *sc, int max_chain, bool any_surface, point *pts, int n, uint64_t seed)
{
    spc_camera_state cam;
    if (!spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height))
        return 0;
    spc_rng r;
    spc_rng_seed(&r, seed, 7);
    int np = 0;
    for (int path = 0; path < 100 * n && np < n; ++path) {
        spc_ray ray = spc_camera_ray(&cam, spc_rng_next(&r) * sc->film.width, spc_rng_next(&r) * sc->film.height);
        for (int depth = 0; depth < 6 && np < n; ++depth) {
            spc_hit h;
            if (!spc_scene_intersect(sc, &ray, &h) || !h.bsdf)
                break;
            spc_vec3 wo = spc_neg(ray.d);
            int budget = spc_snee_budget(&h, max_chain, any_surface);
            if (budget > 0) {
                pts[np].h = h;
                pts[np].wo = wo;
                pts[np].budget = budget;
                ++np;
            }
            spc_bsdf_sample bs;
            double ul = spc_rng_next(&r);
            spc_vec2 u = spc_v2(spc_rng_next(&r), spc_rng_next(&r));
            if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, wo, ul, u, &bs))
                break;
            ray = spc_hit_spawn(&h, bs.wi);
        }
    }
    return np;
}

/* --profile: first attempts only, as spc_specular_nee makes them (light point, seed, solve), with
 * why each ends and what a converged chain is worth. */
static void profile(const spc_scene *sc, const spc_snee_params *p, const point *pts, int np, int calls, uint64_t seed)
{
    static const char *const names[] = {"converged", "seed", "max_iter", "stall", "min_beta", "singular"};
    uint64_t count[6] = {0}, iters[6] = {0}, no_light = 0, zero_back = 0, zero_other = 0, nonzero = 0, total = 0;
    uint64_t seed_n[SPC_CHAIN_MAX_VERTICES + 1] = {0};
    double t_all = 0.0, t_stop[6] = {0};
    for (int i = 0; i < np; ++i) {
        spc_rng r;
        spc_rng_seed(&r, seed * 1000003u + (uint64_t)i, 99);
        for (int k = 0; k < calls; ++k) {
            spc_snee_query q;
            memset(&q, 0, sizeof q);
            q.scene = sc;
            q.x = &pts[i].h;
            q.wo = pts[i].wo;
            q.max_chain = pts[i].budget;
            q.seed = p->seed;
            q.params = p;
            const spc_emitter *e;
            spc_vec2 uv;
            double p_y;
            ++total;
            if (!spc_snee_sample_light(sc, false, &r, &q, &e, &uv, &p_y)) {
                ++no_light;
                continue;
            }
            spc_vec3 dir;
            if (!spc_snee_seed_direction(&q, &r, &dir))
                continue;
            spc_chain_opts o = spc_chain_opts_default(q.max_chain);
            spc_angular_target tg = {q.y, q.ny, sc->radius, q.light_size};
            spc_chain c;
            spc_angular_result res;
            double t0 = bench_thread_seconds();
            spc_angular_solve(sc, q.x, &tg, dir, &o, &p->angular, &c, &res);
            double dt = bench_thread_seconds() - t0;
            t_all += dt;
            t_stop[res.stop] += dt;
            count[res.stop]++;
            iters[res.stop] += (uint64_t)res.iterations;
            if (res.stop != SPC_ANGULAR_STOP_SEED)
                seed_n[c.n < SPC_CHAIN_MAX_VERTICES ? c.n : SPC_CHAIN_MAX_VERTICES]++;
            if (res.converged) {
                spc_rgb v = spc_snee_chain_value(&q, e, uv, &c);
                if (!spc_rgb_is_black(v))
                    ++nonzero;
                else if (spc_dot(c.v[c.n - 1].d, q.ny) >= 0.0)
                    ++zero_back;
                else
                    ++zero_other;
            }
        }
    }
    printf("light samples: %llu, no chain possible %.2f%%; first attempts %.1f us each (CPU)\n",
           (unsigned long long)total, 100.0 * no_light / total, t_all / (double)(total - no_light) * 1e6);
    for (int s = 0; s < 6; ++s)
        if (count[s])
            printf("  %-10s %6.2f%%  %5.1f traces  %5.1f%% of the time\n", names[s], 100.0 * count[s] / (total - no_light),
                   (double)iters[s] / count[s], 100.0 * t_stop[s] / t_all);
    printf("  converged: nonzero %.2f%% of attempts, zero (light seen from behind) %.2f%%, zero (other) %.2f%%\n",
           100.0 * nonzero / (total - no_light), 100.0 * zero_back / (total - no_light),
           100.0 * zero_other / (total - no_light));
    printf("  chain vertices at the end (usable seeds):");
    for (int n = 0; n <= SPC_CHAIN_MAX_VERTICES; ++n)
        if (seed_n[n])
            printf(" %d: %.1f%%", n, 100.0 * seed_n[n] / (total - no_light));
    printf("\n");
}

static bool parse_config(const char *s, spc_snee_params *p)
{
    char buf[128];
    snprintf(buf, sizeof buf, "%s", s);
    char *save = NULL;
    for (char *tok = strtok_r(buf, ":", &save); tok; tok = strtok_r(NULL, ":", &save)) {
        if (!strcmp(tok, "shape"))
            p->seed = SPC_SNEE_SEED_SHAPE;
        else if (!strcmp(tok, "light"))
            p->seed = SPC_SNEE_SEED_LIGHT;
        else if (!strcmp(tok, "bsdf"))
            p->seed = SPC_SNEE_SEED_BSDF;
        else if (!strncmp(tok, "trials=", 7))
            p->max_trials = atoi(tok + 7);
        else if (!strcmp(tok, "straight"))
            p->straight_first = true;
        else if (!strcmp(tok, "nostraight"))
            p->straight_first = false;
        else if (!strncmp(tok, "stall=", 6))
            p->angular.stall_steps = atoi(tok + 6);
        else if (!strncmp(tok, "drop=", 5))
            p->angular.stall_drop = atof(tok + 5);
        else if (!strncmp(tok, "iters=", 6))
            p->angular.max_iterations = atoi(tok + 6);
        else if (!strncmp(tok, "window=", 7))
            p->angular.window = atoi(tok + 7);
        else if (!strncmp(tok, "keep=", 5))
            p->angular.window_keep = atof(tok + 5);
        else if (!strcmp(tok, "lm"))
            p->angular.method = SPC_ANGULAR_LEVENBERG_MARQUARDT;
        else if (!strcmp(tok, "biased"))
            p->biased = true;
        else if (!strcmp(tok, "mis"))
            p->mis = true;
        else if (!strncmp(tok, "guide=", 6))
            p->guide = atof(tok + 6);
        else if (!strncmp(tok, "sneep=", 6))
            p->snee_p = atof(tok + 6);
        else if (!strncmp(tok, "reflect=", 8)) {
            p->reflect = true;
            p->reflect_p = atof(tok + 8);
        } else if (!strcmp(tok, "cone"))
            p->seed = SPC_SNEE_SEED_CONE;
        else if (!strcmp(tok, "noexact"))
            p->exact = false;
        else
            return false;
    }
    return true;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s SCENE.xml [-D name=value]... [--solver NAME] [--points N] [--calls M] [--seed S] "
                        "CONFIG...\n",
                argv[0]);
        return 2;
    }
    spc_define defs[BENCH_MAX_DEFINES];
    int nd = 0, npoints = 400, calls = 200, solver = SPC_SNEE_ANGULAR;
    uint64_t seed = 1;
    bool prof = false;
    const char *configs[32];
    int nc = 0;
    for (int i = 2; i < argc; ++i) {
        if (bench_define_arg(argc, argv, &i, defs, &nd))
            continue;
        if (!strcmp(argv[i], "--points") && i + 1 < argc) {
            npoints = atoi(argv[++i]);
        } else if (!strcmp(argv[i], "--calls") && i + 1 < argc) {
            calls = atoi(argv[++i]);
        } else if (!strcmp(argv[i], "--seed") && i + 1 < argc) {
            seed = (uint64_t)atoll(argv[++i]);
        } else if (!strcmp(argv[i], "--profile")) {
            prof = true;
        } else if (!strcmp(argv[i], "--solver") && i + 1 < argc) {
            if (!spc_specular_solver_parse(argv[++i], &solver)) {
                fprintf(stderr, "unknown solver %s\n", argv[i]);
                return 2;
            }
        } else if (nc < 32) {
            configs[nc++] = argv[i];
        }
    }
    if (nc == 0)
        configs[nc++] = "shape";
    spc_scene *sc = bench_load(argv[1], defs, nd);
    if (!sc)
        return 3;
    int max_chain = sc->integrator.specular_max_chain > 0 ? sc->integrator.specular_max_chain : 2;
    point *pts = malloc((size_t)npoints * sizeof *pts);
    double *mean = malloc((size_t)npoints * sizeof *mean);
    double *var = malloc((size_t)npoints * sizeof *var);
    if (!pts || !mean || !var)
        return 4;
    int np = collect_points(sc, max_chain, false, pts, npoints, seed);
    printf("scene %s, solver %s, max_chain %d, %d receiver points, %d calls each\n", argv[1],
           spc_specular_solver_get(solver) ? spc_specular_solver_get(solver)->name : "?", max_chain, np, calls);
    printf("| config | solved / call | straight / call | nonzero / call | trials / solution | capped / solution | traces / call | of which trials | "
           "us / call | sum of means | mean variance | efficiency vs first |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    double eff0 = 0.0;
    for (int c = 0; c < nc; ++c) {
        spc_snee_params p;
        spc_snee_params_default(&p, solver, max_chain);
        if (!parse_config(configs[c], &p)) {
            fprintf(stderr, "bad config %s\n", configs[c]);
            return 2;
        }
        if (prof) {
            printf("%s:\n", configs[c]);
            profile(sc, &p, pts, np, calls, seed);
            continue;
        }
        spc_snee_stats st;
        memset(&st, 0, sizeof st);
        double t0 = bench_thread_seconds(), sum_mean = 0.0, sum_var = 0.0, sum_se2 = 0.0;
        for (int i = 0; i < np; ++i) {
            double s1 = 0.0, s2 = 0.0;
            for (int k = 0; k < calls; ++k) {
                /* the same stream per (point, call) in every configuration: the light point is
                 * drawn first, so configurations differ only in what the solver does with it
                 * (common random numbers: the caustic's heavy-tailed values are shared) */
                spc_rng r;
                spc_rng_seed(&r, seed * 1000003u + (uint64_t)i, (uint64_t)k);
                spc_rgb v = spc_specular_nee(sc, &p, &pts[i].h, pts[i].wo, pts[i].budget, &r, &st);
                double y = (v.r + v.g + v.b) / 3.0;
                s1 += y;
                s2 += y * y;
            }
            mean[i] = s1 / calls;
            var[i] = spc_max(s2 / calls - mean[i] * mean[i], 0.0) * calls / (calls - 1.0);
            sum_mean += mean[i];
            sum_var += var[i];
            sum_se2 += var[i] / calls;
        }
        double secs = bench_thread_seconds() - t0;
        double us = secs / ((double)np * calls) * 1e6;
        double mvar = sum_var / np;
        double eff = mvar > 0.0 ? 1.0 / (mvar * us) : 0.0;
        if (c == 0)
            eff0 = eff;
        double ncall = (double)np * calls;
        double nsol = st.contributions > 0 ? (double)st.contributions : 1.0;
        printf("| %s | %.3f | %.3f | %.3f | %.2f | %.4f | %.1f | %.1f | %.1f | %.5g +- %.2g | %.4g | %.2f |\n", configs[c],
               (double)st.solved / ncall, (double)st.straight / ncall, (double)st.contributions / ncall, (double)st.trials / nsol,
               (double)st.capped / nsol, (double)st.iterations / ncall,
               (double)st.trial_iterations / ncall, us, sum_mean, sqrt(sum_se2), mvar,
               eff0 > 0.0 ? eff / eff0 : 0.0);
        fflush(stdout);
    }
    free(pts);
    free(mean);
    free(var);
    spc_scene_destroy(sc);
    return 0;
}
