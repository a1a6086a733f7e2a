/*
 * bench/bench_conic.c: the conic solver: cost per query against the triangle count, and
 * equal-time error of specular NEE by conic, newton and angular on single-interface scenes.
 *
 *   build/bench_conic scaling [queries]          microseconds per query and per triangle solved,
 *                                                 hierarchy vs loop, 1k .. 1M triangles
 *   build/bench_conic equal-time [seconds]       relMSE at equal time (path + each solver) against
 *                                                 a long path + conic reference
 *
 * Meshes are generated here: a water surface (a wavy grid with analytic vertex normals, x on a
 * floor below it, y on a light above, the refraction caustic of a pool) and a closed blob (a
 * displaced cube sphere, reflection and refraction queries with at least one solution each).
 * Timings are single-threaded (the solver's own cost). Results go to bench/RESULTS.md by hand.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "core/rng.h"
#include "manifold/conic.h"
#include "render/film.h"
#include "scene/scene.h"
#include "specula/specula.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }
static double rnd_in(double a, double b) { return a + (b - a) * rnd(); }

/* ---- meshes (the same generators as tests/test_conic.c) ---- */

static double blob_g(spc_vec3 d, spc_vec3 *grad)
{
    double a = sin(3.0 * d.x + 0.5), b = sin(2.0 * d.y + 1.0), c = cos(4.0 * d.z);
    *grad = spc_v3(3.0 * cos(3.0 * d.x + 0.5) * b, 2.0 * a * cos(2.0 * d.y + 1.0), -2.0 * sin(4.0 * d.z));
    return a * b + 0.5 * c;
}

static spc_mesh blob_mesh(int n, spc_vec3 center, double R, double amp)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = 6 * (size_t)(n + 1) * (n + 1);
    m.ntris = 12 * (size_t)n * n;
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.n = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    size_t v = 0, t = 0;
    for (int face = 0; face < 6; ++face) {
        int ax = face / 2, sg = face % 2 ? -1 : 1;
        size_t base = v;
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i) {
                double a = -1.0 + 2.0 * i / n, b = -1.0 + 2.0 * j / n, c[3];
                c[ax] = sg;
                c[(ax + 1) % 3] = sg > 0 ? a : b;
                c[(ax + 2) % 3] = sg > 0 ? b : a;
                spc_vec3 d = spc_normalize(spc_v3(c[0], c[1], c[2])), grad;
                double g = blob_g(d, &grad), r = R * (1.0 + amp * g);
                spc_vec3 gt = spc_sub(grad, spc_scale(d, spc_dot(grad, d)));
                spc_vec3 nn = spc_normalize(spc_sub(d, spc_scale(gt, R * amp / r)));
                spc_vec3 p = spc_madd(center, d, r);
                m.p[3 * v] = (float)p.x, m.p[3 * v + 1] = (float)p.y, m.p[3 * v + 2] = (float)p.z;
                m.n[3 * v] = (float)nn.x, m.n[3 * v + 1] = (float)nn.y, m.n[3 * v + 2] = (float)nn.z;
                ++v;
            }
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                uint32_t q00 = (uint32_t)(base + j * (n + 1) + i), q10 = q00 + 1, q01 = q00 + (uint32_t)(n + 1),
                         q11 = q01 + 1;
                uint32_t tri[6] = {q00, q10, q11, q00, q11, q01};
                memcpy(m.idx + 3 * t, tri, sizeof tri);
                t += 2;
            }
    }
    return m;
}

static double water_h(double x, double y, double *hx, double *hy)
{
    const double A = 0.04;
    double a = sin(5.0 * x + 0.3) * cos(4.0 * y), b = sin(3.0 * (x + y) + 1.0);
    *hx = A * (5.0 * cos(5.0 * x + 0.3) * cos(4.0 * y) + 0.5 * 3.0 * cos(3.0 * (x + y) + 1.0));
    *hy = A * (-4.0 * sin(5.0 * x + 0.3) * sin(4.0 * y) + 0.5 * 3.0 * cos(3.0 * (x + y) + 1.0));
    return A * (a + 0.5 * b);
}

static spc_mesh water_mesh(int n, double s, double z0)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = (size_t)(n + 1) * (n + 1);
    m.ntris = 2 * (size_t)n * n;
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.n = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    size_t v = 0, t = 0;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            double x = -s + 2.0 * s * i / n, y = -s + 2.0 * s * j / n, hx, hy;
            double z = z0 + water_h(x, y, &hx, &hy);
            spc_vec3 nn = spc_normalize(spc_v3(-hx, -hy, 1.0));
            m.p[3 * v] = (float)x, m.p[3 * v + 1] = (float)y, m.p[3 * v + 2] = (float)z;
            m.n[3 * v] = (float)nn.x, m.n[3 * v + 1] = (float)nn.y, m.n[3 * v + 2] = (float)nn.z;
            ++v;
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            uint32_t q00 = (uint32_t)(j * (n + 1) + i), q10 = q00 + 1, q01 = q00 + (uint32_t)(n + 1), q11 = q01 + 1;
            uint32_t tri[6] = {q00, q10, q11, q00, q11, q01};
            memcpy(m.idx + 3 * t, tri, sizeof tri);
            t += 2;
        }
    return m;
}

/* ---- scaling ---- */

typedef struct timing {
    double us_query, us_tri, tris, nodes, sols;
} timing;

static timing run_queries(const spc_conic_mesh *cm, const spc_conic_problem *pbs, int nq, bool brute)
{
    spc_conic_stats st;
    memset(&st, 0, sizeof st);
    long sols = 0;
    spc_conic_solution out[64];
    double t0 = bench_thread_seconds();
    for (int i = 0; i < nq; ++i)
        sols += spc_conic_mesh_solve(cm, &pbs[i], out, 64, brute, &st);
    double dt = bench_thread_seconds() - t0;
    timing r;
    r.us_query = 1e6 * dt / nq;
    r.tris = (double)st.triangles / nq;
    r.us_tri = st.triangles ? 1e6 * dt / (double)st.triangles : 0.0;
    r.nodes = (double)st.nodes / nq;
    r.sols = (double)sols / nq;
    return r;
}

static void scaling(int nq)
{
    printf("| mesh | triangles | queries | us / query | triangles solved / query | nodes / query | us / triangle "
           "solved | solutions / query | loop us / query |\n|---|---|---|---|---|---|---|---|---|\n");
    const int water_n[] = {22, 45, 90, 179, 358, 707};
    const int blob_n[] = {9, 18, 37, 73, 146, 289};
    int levels = getenv("BENCH_CONIC_LEVELS") ? atoi(getenv("BENCH_CONIC_LEVELS")) : 6;
    for (int kind = 0; kind < 2; ++kind)
        for (int li = 0; li < levels; ++li) {
            spc_shape shape;
            memset(&shape, 0, sizeof shape);
            spc_mesh m = kind == 0 ? water_mesh(water_n[li], 1.5, 0.5) : blob_mesh(blob_n[li], spc_v3(0, 0, 0), 1.0, 0.15);
            spc_error err;
            if (!spc_shape_init_mesh(&shape, &m, NULL, NULL, 0, 0, &err) || spc_shape_prepare(&shape) != SPC_OK) {
                fprintf(stderr, "mesh failed\n");
                return;
            }
            double tb = bench_thread_seconds();
            spc_conic_mesh *cm = spc_conic_mesh_build(&shape);
            double build = bench_thread_seconds() - tb;
            spc_rng_seed(&rng, 7, (uint64_t)li);
            spc_conic_problem *pbs = malloc((size_t)nq * sizeof *pbs);
            for (int i = 0; i < nq; ++i) {
                spc_conic_problem *pb = &pbs[i];
                pb->front_only = false;
                if (kind == 0) {
                    /* the pool: x on the floor below, y on a 0.6 x 0.6 light 1.7 above the water */
                    pb->x = spc_v3(rnd_in(-1.4, 1.4), rnd_in(-1.4, 1.4), 0.0);
                    pb->y = spc_v3(0.3 + rnd_in(-0.3, 0.3), 0.2 + rnd_in(-0.3, 0.3), 2.2);
                    pb->event = SPC_CONIC_REFRACT;
                    pb->eta = 1.33;
                } else {
                    /* around the blob: x and y on a sphere of radius 2.5, reflection or refraction */
                    for (int k = 0; k < 2; ++k) {
                        spc_vec3 d;
                        do
                            d = spc_v3(rnd_in(-1, 1), rnd_in(-1, 1), rnd_in(-1, 1));
                        while (spc_length(d) > 1.0 || spc_length(d) < 0.1);
                        spc_vec3 p = spc_scale(spc_normalize(d), 2.5);
                        if (k == 0)
                            pb->x = p;
                        else
                            pb->y = p;
                    }
                    pb->event = i % 2 ? SPC_CONIC_REFRACT : SPC_CONIC_REFLECT;
                    pb->eta = 1.5;
                }
            }
            timing h = run_queries(cm, pbs, nq, false);
            double loop = -1.0;
            if (shape.mesh.ntris <= 20000 && !getenv("BENCH_CONIC_NO_LOOP")) {
                int nl = nq < 200 ? nq : 200;
                loop = run_queries(cm, pbs, nl, true).us_query;
            }
            printf("| %s | %zu | %d | %.1f | %.1f | %.1f | %.2f | %.2f | ", kind == 0 ? "water" : "blob", shape.mesh.ntris,
                   nq, h.us_query, h.tris, h.nodes, h.us_tri, h.sols);
            if (loop >= 0)
                printf("%.0f |\n", loop);
            else
                printf("- |\n");
            fprintf(stderr, "  (%s %zu triangles: hierarchy built in %.2f s)\n", kind == 0 ? "water" : "blob",
                    shape.mesh.ntris, build);
            free(pbs);
            spc_conic_mesh_destroy(cm);
            spc_shape_release(&shape);
        }
}

/* ---- equal time ---- */

static spc_bsdf *diffuse(spc_scene *sc, double a)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_DIFFUSE;
    b->reflectance = spc_scene_constant(sc, spc_rgb1(a));
    return b;
}

static spc_scene *pool_scene(int mirror_blob, double light_r, int size)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_mat4 S = spc_mat4_scale(spc_v3(1.5, 1.5, 1)), M = S;
    spc_shape *fl = spc_scene_new_shape(sc);
    spc_shape_init_rectangle(fl, &M, NULL, 0, 0, &err);
    fl->bsdf = diffuse(sc, 0.7);
    spc_bsdf *spec = spc_scene_new_bsdf(sc);
    if (mirror_blob) {
        spec->type = SPC_BSDF_CONDUCTOR;
        spec->cond_k = spc_rgb1(-1.0);
        spec->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    } else {
        spec->type = SPC_BSDF_DIELECTRIC;
        spec->eta = 1.33;
        spec->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
        spec->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    }
    spc_mesh m = mirror_blob ? blob_mesh(24, spc_v3(0.2, 0.1, 0.45), 0.4, 0.15) : water_mesh(60, 1.5, 0.5);
    spc_shape *ms = spc_scene_new_shape(sc);
    spc_shape_init_mesh(ms, &m, NULL, NULL, 0, 0, &err);
    ms->bsdf = spec;
    spc_shape *light = spc_scene_new_shape(sc);
    spc_shape_init_sphere(light, mirror_blob ? spc_v3(-0.6, 0.3, 1.6) : spc_v3(0.3, 0.2, 2.2), light_r, NULL, NULL, 0, 0,
                          &err);
    light->bsdf = diffuse(sc, 0.0);
    spc_emitter *e = spc_scene_new_emitter(sc);
    e->type = SPC_EMITTER_AREA;
    e->radiance = spc_scene_constant(sc, spc_rgb1(0.5 / (light_r * light_r))); /* the same power for every size */
    e->shape_index = 2;
    light->emitter = e;
    spc_mat4_lookat(spc_v3(0.0, -2.6, 2.4), spc_v3(0, 0, 0.2), spc_v3(0, 0, 1), &sc->camera.to_world);
    sc->camera.fov = 45;
    sc->camera.fov_axis = SPC_FOV_X;
    sc->film.width = sc->film.height = size;
    sc->film.rfilter = SPC_RFILTER_BOX;
    sc->film.filter_radius = 0.5;
    sc->integrator.specular_max_chain = 1;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        fprintf(stderr, "finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

static spc_film *render(const spc_scene *sc, const char *snee, int spp, uint64_t seed, double *cpu)
{
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp;
    o.threads = 2;
    o.seed = seed;
    o.integrator = "path";
    o.specular_nee = snee;
    spc_film *f = NULL;
    spc_error err;
    spc_render_stats st;
    double c0 = bench_process_seconds();
    if (spc_render(sc, &o, &f, &st, &err) != SPC_OK) {
        fprintf(stderr, "render failed: %s\n", err.msg);
        return NULL;
    }
    *cpu = bench_process_seconds() - c0;
    return f;
}

static double rel_mse(const spc_film *a, const spc_film *ref)
{
    spc_image_rgb ia = {a->width, a->height, a->rgb, NULL}, ib = {ref->width, ref->height, ref->rgb, NULL};
    spc_diff_result d;
    spc_error err;
    if (spc_image_diff(&ia, &ib, &d, &err) != SPC_OK)
        return -1.0;
    return d.rel_mse;
}

/* relMSE against a long reference at the spp each solver reaches in budget CPU-seconds: measured
 * at a fixed spp, then scaled to the budget (variance falls as 1/time); the machine is shared, so
 * CPU time, not wall time, is the budget. */
static void equal_time(double budget)
{
    const char *solvers[] = {"conic", "newton", "angular", "none"};
    const int spp = 256, ref_spp = 4096;
    printf("| scene | light radius | solver | spp measured | CPU s | relMSE measured | relMSE at %.0f CPU-s |\n"
           "|---|---|---|---|---|---|---|\n",
           budget);
    for (int k = 0; k < 4; ++k) {
        int mirror = k >= 2;
        double light_r = mirror ? (k == 2 ? 0.2 : 0.06) : (k == 0 ? 0.25 : 0.08);
        spc_scene *sc = pool_scene(mirror, light_r, 32);
        if (!sc)
            return;
        double cref;
        spc_film *ref = render(sc, "conic", ref_spp, 99, &cref);
        fprintf(stderr, "  reference (%s, light %.2f): path + conic %d spp, %.1f CPU-s\n", mirror ? "mirror blob" : "pool",
                light_r, ref_spp, cref);
        for (int i = 0; i < 4; ++i) {
            double cpu;
            spc_film *f = render(sc, solvers[i], spp, 5, &cpu);
            if (!f || !ref)
                continue;
            double r = rel_mse(f, ref);
            printf("| %s | %.2f | %s | %d | %.1f | %.4g | %.4g |\n", mirror ? "mirror blob (reflection)" : "pool (refraction)",
                   light_r, solvers[i], spp, cpu, r, r * cpu / budget);
            fflush(stdout);
            spc_film_destroy(f);
        }
        spc_film_destroy(ref);
        spc_scene_destroy(sc);
    }
}

int main(int argc, char **argv)
{
    spc_warn_set_quiet(1);
    if (argc >= 2 && !strcmp(argv[1], "scaling")) {
        scaling(argc >= 3 ? atoi(argv[2]) : 2000);
        return 0;
    }
    if (argc >= 2 && !strcmp(argv[1], "equal-time")) {
        equal_time(argc >= 3 ? atof(argv[2]) : 60.0);
        return 0;
    }
    fprintf(stderr, "usage: %s scaling [queries] | equal-time [CPU seconds]\n", argv[0]);
    return 2;
}
