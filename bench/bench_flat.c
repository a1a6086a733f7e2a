/*
 * bench/bench_flat.c: the cost of enumerating the chains through flat faces (manifold/flat_chains.h)
 * on a scene file, per chain length.
 *
 *   build/bench_flat SCENE.xml [-D name=value]... [--points N] [--lights M] [--seed S] [--max K]
 *
 * Receiver points x are the first hits of random camera rays on shapes that receive caustics; at
 * each, M points y are drawn on the scene's area lights (uniform by area). For each (x, y) and each
 * chain length k = 1..K (default 4) the bench calls spc_flat_chain_roots and reports per query: the
 * face sequences solved, the roots found, and the CPU time of this thread (the machine is shared:
 * CPU time, not wall time); queries per CPU second are 1 / (the sum over k of the time per query).
 * A change to the pruning that loses nothing leaves the roots column the same to the last digit.
 * Results go to bench/RESULTS.md by hand.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "core/rng.h"
#include "manifold/flat_chains.h"
#include "scene/camera.h"
#include "scene/scene.h"
#include "scene/shape.h"
#include "specula/specula.h"

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s SCENE.xml [-D name=value]... [--points N] [--lights M] [--seed S] [--max K]\n",
                argv[0]);
        return 2;
    }
    spc_define defs[BENCH_MAX_DEFINES];
    int nd = 0, npoints = 200, nlights = 5, kmax = SPC_FLAT_MAX_VERTICES;
    uint64_t seed = 1;
    for (int i = 2; i < argc; ++i) {
        if (bench_define_arg(argc, argv, &i, defs, &nd))
            continue;
        if (!strcmp(argv[i], "--points") && i + 1 < argc) {
            npoints = atoi(argv[++i]);
        } else if (!strcmp(argv[i], "--lights") && i + 1 < argc) {
            nlights = atoi(argv[++i]);
        } else if (!strcmp(argv[i], "--seed") && i + 1 < argc) {
            seed = (uint64_t)atoll(argv[++i]);
        } else if (!strcmp(argv[i], "--max") && i + 1 < argc) {
            kmax = atoi(argv[++i]);
        }
    }
    if (kmax < 1 || kmax > SPC_FLAT_MAX_VERTICES)
        kmax = SPC_FLAT_MAX_VERTICES;
    spc_scene *sc = bench_load(argv[1], defs, nd);
    if (!sc)
        return 3;
    spc_camera_state cam;
    if (!spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height))
        return 4;
    const spc_shape *light = NULL;
    for (int i = 0; i < sc->nemitters && !light; ++i)
        if (sc->emitters[i]->type == SPC_EMITTER_AREA)
            light = sc->emitters[i]->shape;
    if (!light) {
        fprintf(stderr, "no area light\n");
        return 4;
    }
    spc_rng r;
    spc_rng_seed(&r, seed, 11);
    double t[SPC_FLAT_MAX_VERTICES + 1] = {0};
    long seq[SPC_FLAT_MAX_VERTICES + 1] = {0}, roots[SPC_FLAT_MAX_VERTICES + 1] = {0};
    long queries = 0;
    spc_vec3 pts[4 * 64];
    for (int n = 0, tries = 0; n < npoints && tries < 100 * npoints; ++tries) {
        spc_ray ray = spc_camera_ray(&cam, spc_rng_next(&r) * sc->film.width, spc_rng_next(&r) * sc->film.height);
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h) || !h.shape || !(h.shape->caustic_flags & SPC_CAUSTIC_RECEIVER) ||
            h.emitter || spc_flat_chain_shape(h.shape))
            continue;
        ++n;
        spc_vec3 x = spc_hit_offset(&h, spc_neg(ray.d));
        for (int l = 0; l < nlights; ++l) {
            spc_shape_sample ss;
            spc_shape_sample_area(light, spc_v2(spc_rng_next(&r), spc_rng_next(&r)), &ss);
            ++queries;
            for (int k = 1; k <= kmax; ++k) {
                int ns = 0;
                double t0 = bench_thread_seconds();
                roots[k] += spc_flat_chain_roots(sc, false, true, x, ss.p, k, pts, NULL, 64, &ns);
                t[k] += bench_thread_seconds() - t0;
                seq[k] += ns;
            }
        }
    }
    printf("scene %s: %ld queries (x from camera rays, y on the light)\n", argv[1], queries);
    printf("| k | sequences / query | roots / query | us / query |\n|---|---|---|---|\n");
    double total = 0.0;
    for (int k = 1; k <= kmax; ++k) {
        double q = queries > 0 ? (double)queries : 1.0;
        printf("| %d | %.2f | %.4f | %.1f |\n", k, seq[k] / q, roots[k] / q, 1e6 * t[k] / q);
        total += t[k] / q;
    }
    printf("all lengths 1..%d: %.1f us / query, %.0f queries / CPU-s\n", kmax, 1e6 * total,
           total > 0.0 ? 1.0 / total : 0.0);
    spc_scene_destroy(sc);
    return 0;
}
