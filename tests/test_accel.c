/*
 * tests/test_accel.c: the acceleration structure's hits against closed-form ones, for a mesh whose
 * positions and indices Embree reads in place, with Embree's default BVH and its compact one (a
 * scene's own limit, spc_scene.accel_compact_tris, or SPC_ACCEL_COMPACT_TRIS); the scene's budget of kept triangle frames; how rarely rays pass through the
 * cracks of a closed mesh (robust triangle test); the packets' width; coherent packets' hits
 * against single rays', in packets of 8 and of 16 lanes.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "accel/accel.h"
#include "core/rng.h"
#include "harness.h"
#include "packets.h"
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

/* A scene of grids of k[0], k[1], ... quads a side (n of them), at heights 0.25, 0.5, ..., whose
 * BVH is compact from compact_tris triangles (0: the default limit) */
static spc_scene *grids_scene_compact(const int *k, int n, size_t compact_tris)
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
    sc->accel_compact_tris = compact_tris;
    spc_error err;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

static spc_scene *grids_scene(const int *k, int n) { return grids_scene_compact(k, n, 0); }

/* Vertical and slanted rays onto the grid: each hits the triangle of its cell at the plane's
 * distance; rays beside the grid miss; a shadow ray through the plane is occluded, one stopping
 * short of it is not. */
static int check_grid(int k, size_t compact_tris)
{
    const double z = 0.25;
    spc_scene *sc = grids_scene_compact(&k, 1, compact_tris);
    CHECK(sc != NULL);
    if (!sc)
        return 0;
    CHECK(sc->shapes[0]->mesh.p_padded);
    /* compact exactly from the limit on */
    size_t limit = compact_tris ? compact_tris : SPC_ACCEL_COMPACT_TRIS;
    CHECK(spc_accel_compact(sc->accel) == (sc->shapes[0]->mesh.ntris >= limit));
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

TEST(grid_hits_small) { CHECK(check_grid(16, 0) == 2000); }

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

/* 2 * 512^2 = 524288 triangles: Embree's default BVH (below SPC_ACCEL_COMPACT_TRIS), then a grid
 * of 2 * 96^2 = 18432 triangles with the compact BVH by the scene's own limit, at it and one
 * triangle above it */
TEST(grid_hits_compact)
{
    CHECK(2u * 512 * 512 < SPC_ACCEL_COMPACT_TRIS);
    CHECK(check_grid(512, 0) == 2000);
    CHECK(check_grid(96, 2 * 96 * 96) == 2000);
    CHECK(check_grid(96, 2 * 96 * 96 + 1) == 2000);
}

/* A point drawn uniformly in the cube [-1/2, 1/2]^3 (offsets and unnormalized directions). */
static spc_vec3 centred_draw(spc_rng *r)
{
    double x = spc_rng_next(r) - 0.5, y = spc_rng_next(r) - 0.5;
    return spc_v3(x, y, spc_rng_next(r) - 0.5);
}

/* A closed UV sphere (nlat bands, nlon sectors, shared vertices, poles as fans) rotated, scaled
 * unevenly and moved off the origin, so its float vertices are not round numbers; the center is
 * returned in c. */
static spc_scene *closed_sphere_scene(int nlat, int nlon, spc_vec3 *c, bool fast)
{
    spc_scene *sc = spc_scene_create();
    if (!sc)
        return NULL;
    spc_bsdf *d = spc_scene_new_bsdf(sc);
    d->type = SPC_BSDF_DIFFUSE;
    d->reflectance = spc_scene_constant(sc, spc_rgb1(0.5));
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = (size_t)(nlat - 1) * nlon + 2;
    m.ntris = 2 * (size_t)(nlat - 1) * nlon;
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    if (!m.p || !m.idx) {
        spc_mesh_release(&m);
        spc_scene_destroy(sc);
        return NULL;
    }
    *c = spc_v3(0.3137, -1.2719, 2.0411);
    const double ca = cos(0.7), sa = sin(0.7), cb = cos(-0.4), sb = sin(-0.4);
    for (size_t v = 0; v < m.nverts; ++v) {
        double th, ph;
        if (v + 2 >= m.nverts)
            th = v + 2 == m.nverts ? 0.0 : SPC_PI, ph = 0.0;
        else
            th = SPC_PI * (double)(v / nlon + 1) / nlat, ph = 2.0 * SPC_PI * (double)(v % nlon) / nlon;
        double x = 1.37 * sin(th) * cos(ph), y = 0.91 * sin(th) * sin(ph), z = 1.13 * cos(th);
        double x1 = ca * x - sa * y, y1 = sa * x + ca * y;
        double y2 = cb * y1 - sb * z, z2 = sb * y1 + cb * z;
        m.p[3 * v] = (float)(x1 + c->x);
        m.p[3 * v + 1] = (float)(y2 + c->y);
        m.p[3 * v + 2] = (float)(z2 + c->z);
    }
    uint32_t north = (uint32_t)m.nverts - 2, south = (uint32_t)m.nverts - 1;
    uint32_t *t = m.idx;
    for (int j = 0; j < nlon; ++j) {
        uint32_t j1 = (uint32_t)((j + 1) % nlon);
        *t++ = north, *t++ = (uint32_t)j, *t++ = j1;
        uint32_t last = (uint32_t)((nlat - 2) * nlon);
        *t++ = south, *t++ = last + j1, *t++ = last + (uint32_t)j;
        for (int i = 0; i + 2 < nlat; ++i) {
            uint32_t a = (uint32_t)(i * nlon + j), b = (uint32_t)(i * nlon) + j1;
            uint32_t a2 = a + (uint32_t)nlon, b2 = b + (uint32_t)nlon;
            *t++ = a, *t++ = a2, *t++ = b2;
            *t++ = a, *t++ = b2, *t++ = b;
        }
    }
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    if (!sh || !spc_shape_init_mesh(sh, &m, NULL, NULL, 0, 0, &err)) {
        spc_mesh_release(&m);
        spc_scene_destroy(sc);
        return NULL;
    }
    sh->bsdf = d;
    spc_scene_set_defaults(sc);
    if (fast)
        sc->accel_robust = false; /* else the scene's default */
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* Watertightness of the triangle test (Embree's robust one, RTC_SCENE_FLAG_ROBUST). Rays aimed
 * exactly at the shared edges and vertices of a closed mesh, from inside it and from outside
 * through the edge toward a point inside: a miss is a ray that passes through the crack between two
 * triangles. Measured (1702 triangles, 24000 rays): intersection 3 misses, occlusion 10 (without the
 * robust flag: 510 and 1368, 2.1% and 5.7%); the bounds below are 0.1% and 0.2%. Random rays from
 * inside a fine closed mesh (187 thousand triangles, 2 x 1 million rays) never escaped (2 without
 * the flag). Single rays and packets (of the native width) give the same hits. */
TEST(closed_mesh_cracks_are_rare)
{
    spc_vec3 c;
    spc_scene *sc = closed_sphere_scene(24, 37, &c, false);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const spc_mesh *m = &sc->shapes[0]->mesh;
    spc_rng rng;
    spc_rng_seed(&rng, 11, 3);
    enum { N = 16 * 1500 };
    int leaks = 0, leaks_occluded = 0, packet_differs = 0;
    spc_ray pr[SPC_SCENE_PACKET];
    bool single_hit[SPC_SCENE_PACKET];
    double single_t[SPC_SCENE_PACKET];
    const spc_ray *rp[SPC_SCENE_PACKET];
    spc_hit h[SPC_SCENE_PACKET];
    bool hit[SPC_SCENE_PACKET];
    for (int s = 0; s < N; ++s) {
        /* an edge of a random triangle, a point on it (its start vertex one time in eight) */
        size_t tri = (size_t)(spc_rng_next(&rng) * m->ntris) % m->ntris;
        int e = (int)(spc_rng_next(&rng) * 3) % 3;
        const float *a = m->p + 3 * m->idx[3 * tri + e], *b = m->p + 3 * m->idx[3 * tri + (e + 1) % 3];
        double f = spc_rng_next(&rng) < 0.125 ? 0.0 : spc_rng_next(&rng);
        spc_vec3 q = spc_v3(a[0] + f * ((double)b[0] - a[0]), a[1] + f * ((double)b[1] - a[1]),
                            a[2] + f * ((double)b[2] - a[2]));
        /* from a point inside, near the center, or from outside: on the line from the inside point
         * through q, beyond q; the shadow ray ends beyond q (from inside) or at the inside point */
        spc_vec3 j = centred_draw(&rng);
        spc_vec3 in = spc_madd(c, j, 0.8);
        spc_vec3 o = s % 2 ? in : spc_madd(q, spc_sub(q, in), 0.5 + 4.0 * spc_rng_next(&rng));
        spc_vec3 dq = spc_sub(s % 2 ? q : in, o);
        spc_ray r = {o, spc_normalize(dq), 0.0, SPC_INF};
        spc_hit hs;
        int lane = s % SPC_SCENE_PACKET;
        single_hit[lane] = spc_scene_intersect(sc, &r, &hs);
        single_t[lane] = single_hit[lane] ? hs.t : 0.0;
        leaks += !single_hit[lane];
        spc_ray sr = r;
        sr.tmax = s % 2 ? spc_length(dq) * 1.5 : spc_length(dq);
        leaks_occluded += !spc_scene_occluded(sc, &sr);
        pr[lane] = r;
        rp[lane] = &pr[lane];
        if (lane == SPC_SCENE_PACKET - 1) {
            packets_intersect(sc, rp, h, hit, false);
            for (int i = 0; i < SPC_SCENE_PACKET; ++i)
                packet_differs += hit[i] != single_hit[i] || (hit[i] && h[i].t != single_t[i]);
        }
    }
    /* random rays from inside a fine closed mesh */
    spc_scene_destroy(sc);
    sc = closed_sphere_scene(300, 313, &c, false);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const int M = 1000000;
    int escapes = 0;
    for (int s = 0; s < M; ++s) {
        spc_vec3 j = centred_draw(&rng);
        spc_vec3 d = centred_draw(&rng);
        spc_ray r = {spc_madd(c, j, 0.8), spc_normalize(d), 0.0, SPC_INF};
        spc_hit hs;
        escapes += !spc_scene_intersect(sc, &r, &hs);
        r.tmax = 10.0;
        escapes += !spc_scene_occluded(sc, &r);
    }
    printf("  %d rays at edges and vertices: %d pass (intersection), %d (occlusion), %d packet lanes differ; "
           "%d of 2 x %d random rays from inside %zu triangles escape\n",
           N, leaks, leaks_occluded, packet_differs, escapes, M, sc->shapes[0]->mesh.ntris);
    CHECK(leaks < N / 1000);
    CHECK(leaks_occluded < N / 500);
    CHECK(packet_differs == 0);
    CHECK(escapes <= 2);
    spc_scene_destroy(sc);
}

/* The scene's accel_robust (the property embree_use_robust_intersections) reaches Embree, and the
 * default is the robust test: rays aimed exactly at a closed mesh's shared edges pass between the
 * triangles only when the scene turns the flag off. Measured on 2400 rays: default 0 pass, fast 68
 * (intersection). */
TEST(fast_traversal_only_when_asked)
{
    int leaks[2] = {0, 0};
    for (int robust = 0; robust < 2; ++robust) {
        spc_vec3 c;
        spc_scene *sc = closed_sphere_scene(24, 37, &c, robust == 0);
        CHECK(sc != NULL);
        if (!sc)
            return;
        const spc_mesh *m = &sc->shapes[0]->mesh;
        spc_rng rng;
        spc_rng_seed(&rng, 5, 1);
        for (int s = 0; s < 2400; ++s) {
            /* from the center through a point of a random triangle's edge */
            size_t tri = (size_t)(spc_rng_next(&rng) * m->ntris) % m->ntris;
            int e = (int)(spc_rng_next(&rng) * 3) % 3;
            const float *a = m->p + 3 * m->idx[3 * tri + e], *b = m->p + 3 * m->idx[3 * tri + (e + 1) % 3];
            double f = spc_rng_next(&rng);
            spc_vec3 q = spc_v3(a[0] + f * ((double)b[0] - a[0]), a[1] + f * ((double)b[1] - a[1]),
                                a[2] + f * ((double)b[2] - a[2]));
            spc_ray r = {c, spc_normalize(spc_sub(q, c)), 0.0, SPC_INF};
            spc_hit h;
            leaks[robust] += !spc_scene_intersect(sc, &r, &h);
        }
        spc_scene_destroy(sc);
    }
    printf("  2400 rays through shared edges from inside: %d pass (fast), %d (default)\n", leaks[0], leaks[1]);
    CHECK(leaks[0] > 0);
    CHECK(leaks[1] <= 2);
}

/* The packets' width (scene.h): Embree's native 8 or 16 lanes, or SPECULA_PACKET_WIDTH's where it
 * is 8 or 16; any other value leaves the native width. */
TEST(packet_width_native_or_asked)
{
    const int k[1] = {2};
    packets_set_width(0);
    spc_scene *sc = grids_scene(k, 1);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const int native = spc_scene_packet_width(sc);
    printf("  native packet width %d\n", native);
    CHECK(native == 8 || native == 16);
    spc_scene_destroy(sc);
    const char *asked[3] = {"8", "16", "12"};
    const int expect[3] = {8, 16, native};
    for (int i = 0; i < 3; ++i) {
        setenv("SPECULA_PACKET_WIDTH", asked[i], 1);
        sc = grids_scene(k, 1);
        CHECK(sc != NULL);
        if (!sc)
            break;
        CHECK_MSG(spc_scene_packet_width(sc) == expect[i], "SPECULA_PACKET_WIDTH=%s gives %d", asked[i],
                  spc_scene_packet_width(sc));
        spc_scene_destroy(sc);
    }
    packets_set_width(0);
}

/* The width the packet tests below expect their scenes to have (SPECULA_PACKET_WIDTH). */
static int packet_width = 16;

/* Coherent packets (spc_scene_intersect_packet_coherent, Embree's coherent traversal, which the
 * packet path tracer uses for a tile's camera rays) give the single rays' hits bit for bit, in packets
 * of 8 and of 16 lanes: fans of 16 rays from one point through a 4 x 4 block of neighbouring directions (a camera's pixels), from
 * outside and inside a closed mesh, some lanes inactive, and packets of scattered directions. The
 * same packets traced with spc_scene_trace_packet_coherent and filled lane by lane
 * (spc_scene_fill_answer, as the path tracer fills its camera hits) give the same records, byte for
 * byte. */
TEST(coherent_packets_match_single_rays)
{
    spc_vec3 c;
    spc_scene *sc = closed_sphere_scene(24, 37, &c, false);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(spc_scene_packet_width(sc) == packet_width);
    spc_rng rng;
    spc_rng_seed(&rng, 5, 9);
    int lanes = 0, differs = 0, hits = 0, answers_differ = 0;
    for (int s = 0; s < 3000; ++s) {
        spc_vec3 j = centred_draw(&rng);
        bool inside = s % 3 == 0, fan = s % 3 != 2;
        spc_vec3 o = inside ? spc_madd(c, j, 0.8) : spc_madd(c, spc_normalize(j), 3.0 + 4.0 * spc_rng_next(&rng));
        spc_vec3 toward = spc_normalize(spc_sub(c, o));
        spc_frame f = spc_frame_from_n(toward);
        double step = 1e-3 + 0.05 * spc_rng_next(&rng);
        spc_ray pr[SPC_SCENE_PACKET];
        const spc_ray *rp[SPC_SCENE_PACKET];
        for (int i = 0; i < SPC_SCENE_PACKET; ++i) {
            spc_vec3 d = fan ? spc_add(toward, spc_add(spc_scale(f.s, step * (i % 4 - 1.5)), spc_scale(f.t, step * (i / 4 - 1.5))))
                             : centred_draw(&rng);
            pr[i] = (spc_ray){o, spc_normalize(d), 0.0, SPC_INF};
            rp[i] = (s + i) % 7 == 0 ? NULL : &pr[i];
        }
        spc_hit h[SPC_SCENE_PACKET], ha[SPC_SCENE_PACKET];
        bool hit[SPC_SCENE_PACKET];
        spc_scene_answer a[SPC_SCENE_PACKET];
        /* zeroed, so that whole records (their padding too) compare with memcmp */
        memset(h, 0, sizeof h);
        memset(ha, 0, sizeof ha);
        packets_intersect(sc, rp, h, hit, true);
        packets_trace_coherent(sc, rp, a);
        for (int i = 0; i < SPC_SCENE_PACKET; ++i) {
            /* the answers traced ahead and filled one by one give the same records */
            bool filled = spc_scene_fill_answer(sc, &pr[i], &a[i], &ha[i]);
            answers_differ += filled != hit[i] || (filled && memcmp(&ha[i], &h[i], sizeof ha[i]) != 0);
            /* a miss's or an inactive lane's answer is written in full, as zeros */
            answers_differ += !filled && (a[i].shape != -1 || a[i].prim != 0 || a[i].u != 0.0 || a[i].v != 0.0 ||
                                          a[i].t != 0.0);
            if (!rp[i]) {
                differs += hit[i];
                continue;
            }
            spc_hit hs;
            bool single = spc_scene_intersect(sc, rp[i], &hs);
            ++lanes;
            hits += single;
            /* a shading record on a mesh whose materials read no uv leaves it at zero (hit.h) */
            const spc_shape *shp = single ? sc->shapes[hs.shape_index] : NULL;
            spc_vec2 uv = shp && shp->type == SPC_SHAPE_MESH && shp->lazy_derivs && shp->uv_unread ? spc_v2(0.0, 0.0)
                                                                                               : hs.uv;
            differs += single != hit[i] ||
                       (single && (hs.t != h[i].t || hs.prim != h[i].prim || hs.shape_index != h[i].shape_index ||
                                   memcmp(&hs.p, &h[i].p, sizeof hs.p) != 0 || memcmp(&uv, &h[i].uv, sizeof uv) != 0));
        }
    }
    printf("  %d lanes (%d hits): %d differ from single rays; %d answers filled one by one differ from the "
           "packet's records\n",
           lanes, hits, differs, answers_differ);
    CHECK(lanes > 40000 && hits > 20000);
    CHECK(differs == 0);
    CHECK(answers_differ == 0);
    spc_scene_destroy(sc);
}

/* Shadow packets whose rays share an octant (spc_scene_occluded_light_packet_coherent, the packet
 * path tracer's shadow rays) answer as single rays do: segments between random points inside and
 * outside a closed mesh, some lanes inactive, each packet's directions turned into one octant (sign
 * flips of the components); a mesh below SPC_ACCEL_INCOHERENT_SHADOW_TRIS (Embree's coherent
 * traversal) and one above it (its incoherent one). */
static void check_octant_shadow_packets(int nlat, int nlon)
{
    spc_vec3 c;
    spc_scene *sc = closed_sphere_scene(nlat, nlon, &c, false);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(spc_scene_packet_width(sc) == packet_width);
    CHECK(spc_accel_shadows_coherent(sc->accel) == (sc->shapes[0]->mesh.ntris < SPC_ACCEL_INCOHERENT_SHADOW_TRIS));
    spc_rng rng;
    spc_rng_seed(&rng, 5, 13);
    int lanes = 0, occluded = 0, differs = 0;
    for (int s = 0; s < 2000; ++s) {
        const int oct = s % 8;
        spc_ray pr[SPC_SCENE_PACKET];
        const spc_ray *rp[SPC_SCENE_PACKET];
        const spc_emitter *le[SPC_SCENE_PACKET];
        for (int i = 0; i < SPC_SCENE_PACKET; ++i) {
            spc_vec3 o = spc_madd(c, centred_draw(&rng), (s / 8) % 2 ? 0.8 : 4.0);
            spc_vec3 d = centred_draw(&rng);
            d = spc_v3((oct & 1) ? -fabs(d.x) : fabs(d.x), (oct & 2) ? -fabs(d.y) : fabs(d.y),
                       (oct & 4) ? -fabs(d.z) : fabs(d.z));
            double len = spc_length(d);
            pr[i] = (spc_ray){o, spc_scale(d, 1.0 / len), 0.0, 5.0 * len};
            rp[i] = (s + i) % 5 == 0 ? NULL : &pr[i];
            le[i] = NULL;
        }
        bool occ[SPC_SCENE_PACKET];
        packets_occluded_light(sc, rp, le, occ, true);
        for (int i = 0; i < SPC_SCENE_PACKET; ++i) {
            if (!rp[i]) {
                differs += occ[i];
                continue;
            }
            ++lanes;
            bool single = spc_scene_occluded_light(sc, rp[i], NULL);
            occluded += single;
            differs += single != occ[i];
        }
    }
    printf("  %zu triangles, %d lanes (%d occluded): %d answers differ from single rays\n", sc->shapes[0]->mesh.ntris,
           lanes, occluded, differs);
    CHECK(lanes > 20000 && occluded > 5000 && occluded < lanes - 5000);
    CHECK(differs == 0);
    spc_scene_destroy(sc);
}

TEST(octant_shadow_packets_match_single_rays)
{
    check_octant_shadow_packets(24, 37); /* 1702 triangles */
    check_octant_shadow_packets(64, 80); /* 10080 triangles */
    CHECK(2 * 23 * 37 < SPC_ACCEL_INCOHERENT_SHADOW_TRIS && 2 * 63 * 80 >= SPC_ACCEL_INCOHERENT_SHADOW_TRIS);
}

/* spc_scene_trace's answer, filled with spc_shape_fill_hit (as the chains fill their hits), is
 * spc_scene_intersect's record byte for byte, and a miss is an answer of shape -1: rays from outside
 * and inside a closed mesh, some of which miss it. */
TEST(single_trace_matches_intersect)
{
    spc_vec3 c;
    spc_scene *sc = closed_sphere_scene(24, 37, &c, false);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_rng rng;
    spc_rng_seed(&rng, 5, 11);
    int hits = 0, misses = 0, differs = 0;
    for (int s = 0; s < 4000; ++s) {
        spc_vec3 j = centred_draw(&rng);
        spc_vec3 o = s % 3 == 0 ? spc_madd(c, j, 0.8) : spc_madd(c, spc_normalize(j), 3.0);
        spc_vec3 d = centred_draw(&rng);
        spc_ray r = {o, spc_normalize(d), 0.0, SPC_INF};
        spc_hit h, ha;
        /* zeroed, so that whole records (their padding too) compare with memcmp */
        memset(&h, 0, sizeof h);
        memset(&ha, 0, sizeof ha);
        bool hit = spc_scene_intersect(sc, &r, &h);
        spc_scene_answer a;
        spc_scene_trace(sc, &r, &a);
        if (a.shape < 0) {
            ++misses;
            differs += hit;
            continue;
        }
        ++hits;
        ha.shape_index = a.shape;
        spc_shape_fill_hit(sc->shapes[a.shape], a.prim, a.u, a.v, &r, a.t, &ha);
        differs += !hit || memcmp(&ha, &h, sizeof h) != 0;
    }
    printf("  %d hits, %d misses: %d differ from spc_scene_intersect\n", hits, misses, differs);
    CHECK(hits > 1000 && misses > 500);
    CHECK(differs == 0);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(grid_hits_small);
    RUN(kept_frames_budget);
    RUN(grid_hits_compact);
    RUN(closed_mesh_cracks_are_rare);
    RUN(fast_traversal_only_when_asked);
    RUN(packet_width_native_or_asked);
    /* the packets' comparisons with single rays at both widths, whichever is native here */
    for (packet_width = 8; packet_width <= 16; packet_width += 8) {
        packets_set_width(packet_width);
        printf("packets of %d lanes\n", packet_width);
        RUN(coherent_packets_match_single_rays);
        RUN(octant_shadow_packets_match_single_rays);
    }
    packets_set_width(0);
    RUN(single_trace_matches_intersect);
    return spc_test_finish();
}
