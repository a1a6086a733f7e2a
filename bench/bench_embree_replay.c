/*
 * bench/bench_embree_replay.c: Embree's cost per ray on the rays a render really traces, replayed
 * outside the renderer, with the scene flags and call forms that specula could choose.
 *
 *   build/bench_embree_replay SCENE.xml RAYS [-D name=value]...
 *
 * RAYS is the prefix of two files written by a build with bench/patches/dump_rays.patch applied
 * (SPECULA_DUMP_RAYS=RAYS specula render ... --threads 1): RAYS.isect and RAYS.occl, the active
 * lanes of every intersection and occlusion packet in the order traced, 8 floats a ray (origin,
 * direction, tnear, tfar), as Embree received them. Consecutive rays of a file are the packets'
 * lanes, so a packet of 16 consecutive rays here is the render's packet (or one rebuilt from two
 * where the render's had idle lanes).
 *
 * The scene's triangle meshes (every shape must be a mesh) are given to a fresh Embree device the
 * way src/accel/embree.c does (float buffers, RTC_BUILD_QUALITY_HIGH), under four scene flags:
 * robust and compact (specula's for meshes of 2^19 triangles and more), robust alone (specula's
 * below), compact alone and none (Mitsuba 3's); each scene's build CPU time is printed. Every file
 * is traced as
 * single rays (rtcIntersect1/rtcOccluded1), as packets of 16 (rtcIntersect16/rtcOccluded16, the
 * incoherent context flag, specula's calls) and as packets with the coherent flag. The time is
 * this thread's CPU time (the machine is shared), the best of three rounds; the hit counts check
 * that every form found the same hits. bench/count_rays_mitsuba.py --replay RAYS traces the same
 * files through Mitsuba 3's own scene (its bundled Embree), for the comparison per ray.
 *
 * REPLAY_SORT=W reorders the rays before tracing: each window of W consecutive rays of a file (a
 * wave's step traces up to 256 extension rays; W = 0 or more than the file: the whole file) sorted by
 * their direction's octant, then by the Morton code of their origin in the box of all origins (10
 * bits an axis), then by their direction's (7 bits an axis: a camera's rays by pixel), the order a renderer would get by sorting its rays before forming packets.
 * REPLAY_SORT_OCTANT=1 with REPLAY_SORT sorts by the octant alone (stable: the file's order within
 * an octant), the order of a wave that groups its rays in octant packets as it does its shadow rays.
 *
 * REPLAY_DIFF=1 traces nothing for time: it builds the robust and the flagless scene and traces every
 * ray of both files as a single ray (rtcIntersect1; a shadow ray's answer is whether it has a hit in
 * (tnear, tfar)) through both, then prints the rays whose answers differ (an intersection: another
 * shape or triangle; a shadow ray: blocked in one and not the other) with both hits (the first 40),
 * and the count of each file's: which rays Embree's watertight test changes.
 */
#include <embree3/rtcore.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "scene/scene.h"

typedef struct rays {
    float *r; /* 8 floats a ray */
    size_t n;
} rays;

static bool read_rays(const char *prefix, const char *ext, rays *out)
{
    char path[1024];
    snprintf(path, sizeof path, "%s.%s", prefix, ext);
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "%s: cannot open\n", path);
        return false;
    }
    fseek(f, 0, SEEK_END);
    long bytes = ftell(f);
    fseek(f, 0, SEEK_SET);
    out->n = (size_t)bytes / (8 * sizeof(float));
    out->r = malloc(out->n * 8 * sizeof(float) + 1);
    bool ok = out->r && fread(out->r, 8 * sizeof(float), out->n, f) == out->n;
    fclose(f);
    if (!ok)
        fprintf(stderr, "%s: cannot read\n", path);
    return ok;
}

/* The Morton code of x's 10 low bits spread to every third bit. */
static uint32_t spread3(uint32_t x)
{
    x &= 0x3FFu;
    x = (x | x << 16) & 0x030000FFu;
    x = (x | x << 8) & 0x0300F00Fu;
    x = (x | x << 4) & 0x030C30C3u;
    x = (x | x << 2) & 0x09249249u;
    return x;
}

typedef struct keyed {
    uint64_t key;
    size_t i;
} keyed;

static int keyed_cmp(const void *a, const void *b)
{
    const keyed *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->i < y->i ? -1 : x->i > y->i;
}

/* rs's rays sorted within windows of w (0: the whole file) by octant, then (unless octant_only)
 * origin's Morton code and direction's; equal keys keep the file's order. */
static void sort_rays(rays *rs, size_t w, bool octant_only)
{
    if (rs->n == 0)
        return;
    if (w == 0 || w > rs->n)
        w = rs->n;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < rs->n; ++i)
        for (int k = 0; k < 3; ++k) {
            float o = rs->r[8 * i + k];
            lo[k] = o < lo[k] ? o : lo[k];
            hi[k] = o > hi[k] ? o : hi[k];
        }
    keyed *ks = malloc(rs->n * sizeof *ks);
    float *out = malloc(rs->n * 8 * sizeof(float) + 1);
    for (size_t i = 0; i < rs->n; ++i) {
        const float *q = rs->r + 8 * i;
        uint32_t m = 0;
        for (int k = 0; k < 3; ++k) {
            float ext = hi[k] - lo[k];
            float f = ext > 0.0f ? (q[k] - lo[k]) / ext : 0.0f;
            m |= spread3((uint32_t)(f * 1023.0f)) << (2 - k);
        }
        uint64_t oct = (uint64_t)((q[3] < 0.0f) | (q[4] < 0.0f) << 1 | (q[5] < 0.0f) << 2);
        /* rays from one origin (a camera's) by their direction's Morton code (7 bits an axis) */
        uint32_t md = 0;
        for (int k = 0; k < 3; ++k)
            md |= spread3((uint32_t)((q[3 + k] * 0.5f + 0.5f) * 127.0f)) << (2 - k);
        ks[i].key = octant_only ? oct : oct << 51 | (uint64_t)m << 21 | md;
        ks[i].i = i;
    }
    for (size_t i0 = 0; i0 < rs->n; i0 += w)
        qsort(ks + i0, (i0 + w <= rs->n ? w : rs->n - i0), sizeof *ks, keyed_cmp);
    for (size_t i = 0; i < rs->n; ++i)
        memcpy(out + 8 * i, rs->r + 8 * ks[i].i, 8 * sizeof(float));
    free(rs->r);
    free(ks);
    rs->r = out;
}

static RTCScene build(RTCDevice dev, const spc_scene *sc, enum RTCSceneFlags flags, double *seconds)
{
    double t0 = bench_thread_seconds();
    RTCScene s = rtcNewScene(dev);
    rtcSetSceneBuildQuality(s, RTC_BUILD_QUALITY_HIGH);
    rtcSetSceneFlags(s, flags);
    for (int i = 0; i < sc->nshapes; ++i) {
        const spc_shape *sh = sc->shapes[i];
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
        float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                           sh->mesh.nverts);
        unsigned *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                               sh->mesh.ntris);
        memcpy(v, sh->mesh.p, 3 * sh->mesh.nverts * sizeof(float));
        memcpy(ix, sh->mesh.idx, 3 * sh->mesh.ntris * sizeof(unsigned));
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(s, g, (unsigned)i);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(s);
    *seconds = bench_thread_seconds() - t0;
    return s;
}

enum form { SINGLE, PACKET, PACKET_COHERENT };
static const char *form_name[] = {"rtc*1", "rtc*16", "rtc*16 coherent"};

/* Traces every ray of rs in the form given; returns the hits (or occluded rays) and the CPU time. */
static size_t trace(RTCScene s, const rays *rs, bool occlusion, enum form form, double *seconds)
{
    size_t hits = 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    if (form == PACKET_COHERENT)
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    double t0 = bench_thread_seconds();
    if (form == SINGLE) {
        for (size_t i = 0; i < rs->n; ++i) {
            const float *q = rs->r + 8 * i;
            struct RTCRayHit rh;
            rh.ray.org_x = q[0], rh.ray.org_y = q[1], rh.ray.org_z = q[2];
            rh.ray.dir_x = q[3], rh.ray.dir_y = q[4], rh.ray.dir_z = q[5];
            rh.ray.tnear = q[6], rh.ray.tfar = q[7];
            rh.ray.time = 0.0f, rh.ray.mask = 0xFFFFFFFFu, rh.ray.id = 0, rh.ray.flags = 0;
            if (occlusion) {
                rtcOccluded1(s, &ctx, &rh.ray);
                hits += rh.ray.tfar < 0.0f;
            } else {
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(s, &ctx, &rh);
                hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
            }
        }
    } else {
        for (size_t i0 = 0; i0 < rs->n; i0 += 16) {
            _Alignas(64) struct RTCRayHit16 rh;
            _Alignas(64) int valid[16];
            for (int k = 0; k < 16; ++k) {
                size_t i = i0 + (size_t)k;
                valid[k] = i < rs->n ? -1 : 0;
                const float *q = rs->r + 8 * (i < rs->n ? i : i0);
                rh.ray.org_x[k] = q[0], rh.ray.org_y[k] = q[1], rh.ray.org_z[k] = q[2];
                rh.ray.dir_x[k] = q[3], rh.ray.dir_y[k] = q[4], rh.ray.dir_z[k] = q[5];
                rh.ray.tnear[k] = q[6], rh.ray.tfar[k] = valid[k] ? q[7] : -INFINITY;
                rh.ray.time[k] = 0.0f, rh.ray.mask[k] = 0xFFFFFFFFu, rh.ray.id[k] = (unsigned)k;
                rh.ray.flags[k] = 0;
                rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
            }
            if (occlusion) {
                rtcOccluded16(valid, s, &ctx, &rh.ray);
                for (int k = 0; k < 16; ++k)
                    hits += valid[k] && rh.ray.tfar[k] < 0.0f;
            } else {
                rtcIntersect16(valid, s, &ctx, &rh);
                for (int k = 0; k < 16; ++k)
                    hits += valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
            }
        }
    }
    *seconds = bench_thread_seconds() - t0;
    return hits;
}

/* REPLAY_DIFF: the rays of rs whose single-ray answers differ between the robust scene and the
 * flagless one, printed (the first 40) and counted. */
static void diff_rays(RTCScene robust, RTCScene fast, const rays *rs, bool occlusion)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCScene scenes[2] = {robust, fast};
    size_t differ = 0;
    for (size_t i = 0; i < rs->n; ++i) {
        const float *q = rs->r + 8 * i;
        struct RTCRayHit rh[2];
        for (int k = 0; k < 2; ++k) {
            rh[k].ray.org_x = q[0], rh[k].ray.org_y = q[1], rh[k].ray.org_z = q[2];
            rh[k].ray.dir_x = q[3], rh[k].ray.dir_y = q[4], rh[k].ray.dir_z = q[5];
            rh[k].ray.tnear = q[6], rh[k].ray.tfar = q[7];
            rh[k].ray.time = 0.0f, rh[k].ray.mask = 0xFFFFFFFFu, rh[k].ray.id = 0, rh[k].ray.flags = 0;
            rh[k].hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh[k].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scenes[k], &ctx, &rh[k]);
        }
        bool hit0 = rh[0].hit.geomID != RTC_INVALID_GEOMETRY_ID, hit1 = rh[1].hit.geomID != RTC_INVALID_GEOMETRY_ID;
        bool d = occlusion ? hit0 != hit1 : rh[0].hit.geomID != rh[1].hit.geomID || (hit0 && rh[0].hit.primID != rh[1].hit.primID);
        if (!d)
            continue;
        if (differ++ < 40) {
            printf("%s ray %zu: o (%.9g, %.9g, %.9g) d (%.9g, %.9g, %.9g) t in (%.9g, %.9g)\n", occlusion ? "shadow" : "isect", i,
                   q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7]);
            for (int k = 0; k < 2; ++k)
                printf("  %s: shape %d triangle %d t %.9g u %.9g v %.9g\n", k ? "flagless" : "robust  ", (int)rh[k].hit.geomID,
                       (int)rh[k].hit.primID, rh[k].ray.tfar, rh[k].hit.u, rh[k].hit.v);
        }
    }
    printf("%s rays: %zu of %zu answer differently\n", occlusion ? "shadow" : "intersection", differ, rs->n);
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: %s SCENE.xml RAYS [-D name=value]...\n", argv[0]);
        return 2;
    }
    spc_define defs[BENCH_MAX_DEFINES];
    int nd = 0;
    for (int i = 3; i < argc; ++i)
        if (!bench_define_arg(argc, argv, &i, defs, &nd)) {
            fprintf(stderr, "unknown argument '%s'\n", argv[i]);
            return 2;
        }
    spc_scene *sc = bench_load(argv[1], defs, nd);
    if (!sc)
        return 3;
    size_t ntris = 0;
    for (int i = 0; i < sc->nshapes; ++i) {
        if (sc->shapes[i]->type != SPC_SHAPE_MESH) {
            fprintf(stderr, "%s: shape %d is not a triangle mesh (this benchmark takes meshes only)\n", argv[1], i);
            return 3;
        }
        ntris += sc->shapes[i]->mesh.ntris;
    }
    rays rs[2];
    if (!read_rays(argv[2], "isect", &rs[0]) || !read_rays(argv[2], "occl", &rs[1]))
        return 1;
    printf("scene %s: %zu triangles; %zu intersection rays, %zu shadow rays\n", argv[1], ntris, rs[0].n, rs[1].n);
    const char *sort = getenv("REPLAY_SORT");
    if (sort) {
        size_t w = (size_t)strtoull(sort, NULL, 10);
        bool oct = getenv("REPLAY_SORT_OCTANT") != NULL;
        sort_rays(&rs[0], w, oct);
        sort_rays(&rs[1], w, oct);
        printf("rays sorted in windows of %zu by %s\n", w, oct ? "octant" : "octant and origin");
    }
    printf("| scene flags | call | intersection ns/ray | hits | shadow ns/ray | occluded | build CPU s |\n"
           "|---|---|---|---|---|---|---|\n");
    /* REPLAY_EMBREE_CONFIG, if set, is the device's configuration (e.g. tri_builder=sah_fast_spatial) */
    const char *config = getenv("REPLAY_EMBREE_CONFIG");
    RTCDevice dev = rtcNewDevice(config ? config : "verbose=0");
    if (getenv("REPLAY_DIFF")) {
        double build_s;
        RTCScene robust = build(dev, sc, RTC_SCENE_FLAG_ROBUST, &build_s);
        RTCScene fast = build(dev, sc, RTC_SCENE_FLAG_NONE, &build_s);
        diff_rays(robust, fast, &rs[0], false);
        diff_rays(robust, fast, &rs[1], true);
        rtcReleaseScene(robust);
        rtcReleaseScene(fast);
        rtcReleaseDevice(dev);
        free(rs[0].r);
        free(rs[1].r);
        spc_scene_destroy(sc);
        return 0;
    }
    /* specula's flags for big meshes first (robust and compact: Embree's BVH4 over triangle4i leaves,
     * robust traversal), then robust alone (BVH8, triangle4v), compact alone (BVH4, triangle4i) and
     * none (Mitsuba 3's: BVH8, triangle4, Moeller-Trumbore, the high-quality spatial-split build) */
    static const struct {
        enum RTCSceneFlags flags;
        const char *name;
    } variants[] = {{RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_COMPACT, "robust+compact"},
                    {RTC_SCENE_FLAG_ROBUST, "robust"},
                    {RTC_SCENE_FLAG_COMPACT, "compact"},
                    {RTC_SCENE_FLAG_NONE, "none"}};
    const char *only = getenv("REPLAY_FORMS"); /* e.g. "1": packets of 16 only (0 single, 1, 2 coherent) */
    const char *vonly = getenv("REPLAY_VARIANTS"); /* e.g. "1": robust alone (0-3 in the order above) */
    for (size_t vi = 0; vi < sizeof variants / sizeof variants[0]; ++vi) {
        if (vonly && !strchr(vonly, '0' + (int)vi))
            continue;
        double build_s;
        RTCScene s = build(dev, sc, variants[vi].flags, &build_s);
        for (int f = SINGLE; f <= PACKET_COHERENT; ++f) {
            if (only && !strchr(only, '0' + f))
                continue;
            double best[2] = {1e30, 1e30};
            size_t hits[2] = {0, 0};
            for (int round = 0; round < 3; ++round)
                for (int k = 0; k < 2; ++k) {
                    double sec;
                    hits[k] = trace(s, &rs[k], k == 1, (enum form)f, &sec);
                    if (sec < best[k])
                        best[k] = sec;
                }
            printf("| %s | %s | %.1f | %zu | %.1f | %zu | %.2f |\n", variants[vi].name, form_name[f],
                   1e9 * best[0] / (double)rs[0].n, hits[0], 1e9 * best[1] / (double)rs[1].n, hits[1], build_s);
            fflush(stdout);
        }
        rtcReleaseScene(s);
    }
    rtcReleaseDevice(dev);
    free(rs[0].r);
    free(rs[1].r);
    spc_scene_destroy(sc);
    return 0;
}
