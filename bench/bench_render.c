/*
 * bench/bench_render.c: path tracing throughput against a raw Embree loop, in one run.
 *
 *   build/bench_render SCENE.xml [spp] [-D name=value]...
 *
 * Renders SCENE with `path` at 1 and 2 threads (Mrays/s from the renderer's own ray count), then
 * traces the same number of rays per thread-count through the same acceleration structure with
 * bare rtcIntersect1 calls (1 thread; rays: camera rays and random rays from the scene's interior,
 * a mix close to a path tracer's), and prints the ratios. Results go to bench/RESULTS.md by hand.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/accel.h"
#include "bench_util.h"
#include "core/rng.h"
#include "core/warp.h"
#include "scene/camera.h"
#include "scene/scene.h"
#include "specula/specula.h"

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s SCENE.xml [spp] [-D name=value]...\n", argv[0]);
        return 2;
    }
    int spp = 16;
    spc_define defs[BENCH_MAX_DEFINES];
    int nd = 0;
    for (int i = 2; i < argc; ++i) {
        if (!bench_define_arg(argc, argv, &i, defs, &nd))
            spp = atoi(argv[i]);
    }
    spc_scene *sc = bench_load(argv[1], defs, nd);
    if (!sc)
        return 3;
    spc_error err;
    printf("scene %s, %dx%d, %d spp, integrator path\n", argv[1], sc->film.width, sc->film.height, spp);
    for (int threads = 1; threads <= 2; ++threads) {
        spc_render_options o;
        spc_render_options_init(&o);
        o.spp = spp;
        o.threads = threads;
        o.integrator = "path";
        spc_film *f;
        spc_render_stats st;
        if (spc_render(sc, &o, &f, &st, &err) != SPC_OK) {
            fprintf(stderr, "render failed: %s\n", err.msg);
            return 4;
        }
        spc_film_destroy(f);
        /* the same number of rays through bare Embree, one thread */
        size_t n = (size_t)st.rays_traced;
        spc_ray *rays = malloc(n * sizeof *rays);
        spc_camera_state cam;
        spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height);
        spc_rng r;
        spc_rng_seed(&r, 1, 2);
        spc_vec3 lo = sc->bbox_min, hi = sc->bbox_max;
        for (size_t i = 0; i < n; ++i) {
            if (i % 4 == 0) {
                rays[i] = spc_camera_ray(&cam, spc_rng_next(&r) * sc->film.width, spc_rng_next(&r) * sc->film.height);
            } else {
                spc_vec3 p = spc_v3(spc_lerp(spc_rng_next(&r), lo.x, hi.x), spc_lerp(spc_rng_next(&r), lo.y, hi.y),
                                    spc_lerp(spc_rng_next(&r), lo.z, hi.z));
                rays[i].o = p;
                rays[i].d = spc_warp_uniform_sphere(spc_v2(spc_rng_next(&r), spc_rng_next(&r)));
                rays[i].tmin = 0;
                rays[i].tmax = INFINITY;
            }
        }
        double t0 = bench_wall_seconds();
        uint64_t hits = spc_accel_raw_loop(sc->accel, rays, n);
        double raw = bench_wall_seconds() - t0;
        double raw_mrays = n / raw * 1e-6;
        printf("threads %d: specula %.3f Mrays/s (%llu rays, %.2f s); raw Embree loop (1 thread) %.3f Mrays/s "
               "(%llu hits); ratio specula/raw = %.3f\n",
               threads, st.mrays_per_second, (unsigned long long)st.rays_traced, st.wall_seconds, raw_mrays,
               (unsigned long long)hits, st.mrays_per_second / raw_mrays);
        free(rays);
    }
    spc_scene_destroy(sc);
    return 0;
}
