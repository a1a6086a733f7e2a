/*
 * tests/test_accel.c: the acceleration structure's hits against closed-form ones, for a mesh whose
 * positions and indices Embree reads in place, below and at the size where the BVH turns compact
 * (SPC_ACCEL_COMPACT_TRIS); the scene's budget of kept triangle frames.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "harness.h"
#include "scene/scene.h"

/* Adds a k x k grid of quads over [0,1]^2 at height z, two triangles per cell: cell (i, j) (x from
 * i/k, y from j/k) holds triangles 2 (j k + i) and 2 (j k + i) + 1. */
static bool add_grid(spc_scene *sc, int k, double z, const spc_bsdf *d)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    int n = k + 1;
    m.nverts = (size_t)n * (size_t)n;
    m.ntris = 2 * (size_t)k * (size_t)k;
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    if (!m.p || !m.idx) {
        spc_mesh_release(&m);
        return false;
    }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            float *v = m.p + 3 * ((size_t)j * n + i);
            v[0] = (float)i / (float)k;
            v[1] = (float)j / (float)k;
            v[2] = (float)z;
        }
    for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
            uint32_t a = (uint32_t)(j * n + i), c = (uint32_t)(2 * ((size_t)j * k + i));
            uint32_t t[6] = {a, a + 1, a + (uint32_t)n + 1, a, a + (uint32_t)n + 1, a + (uint32_t)n};
            memcpy(m.idx + 3 * c, t, sizeof t);
        }
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    if (!sh || !spc_shape_init_mesh(sh, &m, NULL, NULL, 0, 0, &err)) {
        spc_mesh_release(&m);
        return false;
    }
    sh->bsdf = d;
    return true;
}

/* A scene of grids of k[0], k[1], ... quads a side (n of them), at heights 0.25, 0.5, ... */
static spc_scene *grids_scene(const int *k, int n)
{
    spc_scene *sc = spc_scene_create();
    if (!sc)
        return NULL;
    spc_bsdf *d = spc_scene_new_bsdf(sc);
    d->type = SPC_BSDF_DIFFUSE;
    d->reflectance = spc_scene_constant(sc, spc_rgb1(0.5));
    for (int i = 0; i < n; ++i)
        if (!add_grid(sc, k[i], 0.25 * (i + 1), d)) {
            spc_scene_destroy(sc);
            return NULL;
        }
    spc_scene_set_defaults(sc);
    spc_error err;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* Vertical and slanted rays onto the grid: each hits the triangle of its cell at the plane's
 * distance; rays beside the grid miss; a shadow ray through the plane is occluded, one stopping
 * short of it is not. */
static int check_grid(int k)
{
    const double z = 0.25;
    spc_scene *sc = grids_scene(&k, 1);
    CHECK(sc != NULL);
    if (!sc)
        return 0;
    CHECK(sc->shapes[0]->mesh.p_padded);
    spc_rng rng;
    spc_rng_seed(&rng, (uint64_t)k, 7);
    int good = 0;
    const int N = 2000;
    for (int s = 0; s < N; ++s) {
        /* a target inside a cell, away from its edges and diagonal */
        int i = (int)(spc_rng_next(&rng) * k), j = (int)(spc_rng_next(&rng) * k);
        double fx = 0.1 + 0.8 * spc_rng_next(&rng), fy = 0.1 + 0.8 * spc_rng_next(&rng);
        if (fabs(fx - fy) < 0.05)
            fy = fx < 0.5 ? fx + 0.2 : fx - 0.2;
        spc_vec3 q = spc_v3((i + fx) / k, (j + fy) / k, z);
        spc_vec3 d = spc_normalize(spc_v3(0.3 * (spc_rng_next(&rng) - 0.5), 0.3 * (spc_rng_next(&rng) - 0.5), -1.0));
        double dist = 2.0;
        spc_ray r = {spc_madd(q, d, -dist), d, 0.0, SPC_INF};
        spc_hit h;
        bool hit = spc_scene_intersect(sc, &r, &h);
        int cell = 2 * (j * k + i);
        /* below the diagonal (fx > fy) the cell's first triangle */
        int want = fx > fy ? cell : cell + 1;
        bool ok = hit && h.prim == want && fabs(h.t - dist) < 1e-5 && fabs(h.p.z - z) < 1e-6 &&
                  fabs(h.p.x - q.x) < 1e-5 && fabs(h.p.y - q.y) < 1e-5 && fabs(fabs(h.ng.z) - 1.0) < 1e-12;
        spc_ray through = r, shy = r;
        through.tmax = dist + 0.1;
        shy.tmax = dist - 0.1;
        ok = ok && spc_scene_occluded(sc, &through) && !spc_scene_occluded(sc, &shy);
        spc_ray beside = {spc_v3(1.5, 0.5, 1.0), spc_v3(0, 0, -1), 0.0, SPC_INF};
        ok = ok && !spc_scene_intersect(sc, &beside, &h);
        good += ok;
    }
    CHECK(good == N);
    spc_scene_destroy(sc);
    return good;
}

TEST(grid_hits_small) { CHECK(check_grid(16) == 2000); }

/* The kept triangle frames' budget (SPC_MESH_FRAME_MAX_TRIS) holds for the scene: of three meshes
 * of 2 * 110^2 = 24200 triangles the first two keep them, the third would pass the budget with
 * them; a mesh over the budget alone keeps none. */
TEST(kept_frames_budget)
{
    int k[3] = {110, 110, 110};
    spc_scene *sc = grids_scene(k, 3);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(2 * 2 * 110 * 110 <= SPC_MESH_FRAME_MAX_TRIS && 3 * 2 * 110 * 110 > SPC_MESH_FRAME_MAX_TRIS);
    CHECK(sc->shapes[0]->tri_frame && sc->shapes[1]->tri_frame && !sc->shapes[2]->tri_frame);
    spc_scene_destroy(sc);
    int big = 200; /* 80000 triangles */
    sc = grids_scene(&big, 1);
    CHECK(sc && !sc->shapes[0]->tri_frame);
    spc_scene_destroy(sc);
}

/* 2 * 512^2 = 524288 triangles: the compact BVH (SPC_ACCEL_COMPACT_TRIS) */
TEST(grid_hits_compact) { CHECK(check_grid(512) == 2000); }

int main(void)
{
    RUN(grid_hits_small);
    RUN(kept_frames_budget);
    RUN(grid_hits_compact);
    return spc_test_finish();
}
