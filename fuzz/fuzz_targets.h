/*
 * fuzz/fuzz_targets.h: one function per loader that feeds it an arbitrary byte string, shared by
 * the libFuzzer harnesses (fuzz/fuzz_<name>.c) and by tests/test_fuzz_regressions.c, which replays
 * every input that once crashed a loader (tests/data/fuzz_regressions/<name>/).
 *
 * Loaders that take a path read the bytes from a memfd through /proc/self/fd/N: no disk traffic,
 * and the loader's own file handling (fopen, fstat, seeks) is exercised. The XML loader reads from
 * memory with a base directory that holds nothing, so references to meshes and images fail the way
 * a missing file does. A target returns 0; a loader that crashes, leaks or trips a sanitizer is
 * the finding. Loaders must also never accept a NaN or infinite vertex, which the mesh targets
 * check (abort() makes it a finding).
 */
#ifndef SPC_FUZZ_TARGETS_H
#define SPC_FUZZ_TARGETS_H

#ifndef _GNU_SOURCE
#define _GNU_SOURCE /* memfd_create; include this header before any other */
#endif
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "io/image_io.h"
#include "io/mesh_io.h"
#include "io/mitsuba_xml.h"
#include "io/vol.h"
#include "scene/curve.h"
#include "scene/sdfgrid.h"
#include "specula/specula.h"

/* A memfd holding the input; *path receives its /proc name. -1 on failure. */
static inline int spc_fuzz_memfile(const uint8_t *data, size_t size, char *path, size_t pathsize)
{
    static int fd = -1;
    if (fd < 0) {
        fd = memfd_create("spc_fuzz", 0);
        spc_warn_set_quiet(1); /* loaders' warnings about bad input would flood the fuzzer's log */
    }
    if (fd < 0)
        return -1;
    if (ftruncate(fd, 0) != 0 || (size > 0 && pwrite(fd, data, size, 0) != (ssize_t)size))
        return -1;
    snprintf(path, pathsize, "/proc/self/fd/%d", fd);
    return fd;
}

static inline void spc_fuzz_check_mesh(const spc_mesh *m)
{
    for (size_t i = 0; i < 3 * (size_t)m->nverts; ++i)
        if (!isfinite(m->p[i]))
            abort(); /* a loader let a non-finite position through */
    for (size_t i = 0; i < 3 * (size_t)m->ntris; ++i)
        if (m->idx[i] >= (uint32_t)m->nverts)
            abort(); /* an index out of range */
}

static inline int spc_fuzz_obj(const uint8_t *data, size_t size)
{
    char path[64];
    if (spc_fuzz_memfile(data, size, path, sizeof path) < 0)
        return 0;
    spc_mesh m;
    memset(&m, 0, sizeof m);
    spc_error err;
    if (spc_obj_load(path, &m, &err) == SPC_OK)
        spc_fuzz_check_mesh(&m);
    spc_mesh_release(&m);
    return 0;
}

static inline int spc_fuzz_ply(const uint8_t *data, size_t size)
{
    char path[64];
    if (spc_fuzz_memfile(data, size, path, sizeof path) < 0)
        return 0;
    spc_mesh m;
    memset(&m, 0, sizeof m);
    spc_error err;
    if (spc_ply_load(path, &m, &err) == SPC_OK)
        spc_fuzz_check_mesh(&m);
    spc_mesh_release(&m);
    return 0;
}

static inline int spc_fuzz_serialized(const uint8_t *data, size_t size)
{
    char path[64];
    if (spc_fuzz_memfile(data, size, path, sizeof path) < 0)
        return 0;
    /* the first byte picks the shape index, so multi-mesh dictionaries get explored too */
    int index = size > 0 ? data[0] % 4 : 0;
    spc_mesh m;
    memset(&m, 0, sizeof m);
    spc_error err;
    if (spc_serialized_load(path, index, &m, &err) == SPC_OK)
        spc_fuzz_check_mesh(&m);
    spc_mesh_release(&m);
    return 0;
}

/* Mitsuba .vol volume grids (io/vol.c), then the grid's lookups over its whole range. */
static inline int spc_fuzz_vol(const uint8_t *data, size_t size)
{
    char path[64];
    if (spc_fuzz_memfile(data, size, path, sizeof path) < 0)
        return 0;
    spc_volume v;
    memset(&v, 0, sizeof v);
    spc_error err;
    if (spc_vol_read(path, &v, NULL, &err) == SPC_OK) {
        spc_mat4 id = spc_mat4_identity();
        v.wrap = size > 0 ? (spc_volume_wrap)(data[size - 1] % 3) : SPC_VOLUME_CLAMP;
        if (spc_volume_finish_grid(&v, &id))
            for (int i = 0; i < 27; ++i)
                (void)spc_volume_eval(&v, spc_v3(0.75 * (i % 3) - 0.25, 0.75 * (i / 3 % 3) - 0.25, 0.75 * (i / 9) - 0.25));
        /* the same values as an sdfgrid shape (scene/sdfgrid.h): rays from 27 points around the box */
        spc_sdfgrid *g = v.channels == 1 ? spc_sdfgrid_create(v.data, v.res[0], v.res[1], v.res[2], NULL, true,
                                                              path, 0, 0, &err)
                                         : NULL;
        for (int i = 0; g && i < 27; ++i) {
            spc_vec3 o = spc_v3(1.5 * (i % 3) - 0.8, 1.5 * (i / 3 % 3) - 0.7, 1.5 * (i / 9) - 0.9);
            spc_ray r = {o, spc_normalize(spc_sub(spc_v3(0.5, 0.5, 0.5), o)), 0.0, INFINITY};
            double t;
            if (spc_sdfgrid_intersect(g, &r, &t)) {
                spc_hit h;
                memset(&h, 0, sizeof h);
                spc_sdfgrid_fill_hit(g, spc_madd(r.o, r.d, t), false, &h);
            }
        }
        spc_sdfgrid_destroy(g);
        free(v.data);
    }
    return 0;
}

/* Curve files (scene/curve.h) as both bases; a curve that parses has its bounds, area and a hit
 * on every segment computed. */
static inline int spc_fuzz_curve(const uint8_t *data, size_t size)
{
    for (int basis = 0; basis < 2; ++basis) {
        spc_curve c;
        spc_error err;
        if (spc_curve_parse((const char *)data, size, "fuzz.txt", (spc_curve_basis)basis, NULL, &c, &err) != SPC_OK)
            continue;
        spc_vec3 lo, hi;
        spc_curve_bounds(&c, &lo, &hi);
        (void)spc_curve_area(&c);
        for (uint32_t k = 0; k < c.nseg && k < 64; ++k) {
            spc_ray r = {spc_v3(0, 0, 10), spc_v3(0, 0, -1), 0.0, INFINITY};
            spc_hit h;
            memset(&h, 0, sizeof h);
            spc_curve_fill_hit(&c, (int)k, 0.5, &r, 10.0, k & 1, &h);
        }
        spc_curve_release(&c);
    }
    return 0;
}

/* EXR, PNG and JPEG all go through spc_image_read (chosen by magic bytes); the EXR target also
 * reads named channels the way `specula diff` does. */
static inline int spc_fuzz_image(const uint8_t *data, size_t size)
{
    char path[64];
    if (spc_fuzz_memfile(data, size, path, sizeof path) < 0)
        return 0;
    spc_image img;
    memset(&img, 0, sizeof img);
    spc_error err;
    if (spc_image_read(path, &img, &err) == SPC_OK &&
        (img.width <= 0 || img.height <= 0 || !img.data || (img.channels != 1 && img.channels != 3 && img.channels != 4)))
        abort(); /* success must mean a usable image */
    spc_image_release(&img);
    return 0;
}

static inline int spc_fuzz_exr(const uint8_t *data, size_t size)
{
    spc_fuzz_image(data, size);
    char path[64];
    if (spc_fuzz_memfile(data, size, path, sizeof path) < 0)
        return 0;
    const char *names[] = {"R", "G", "B", "variance.R", "depth.Z"};
    int w = 0, h = 0;
    float *px = NULL;
    bool found[5];
    spc_error err;
    if (spc_exr_read_channels(path, 5, names, &w, &h, &px, found, &err) == SPC_OK) {
        volatile float sink = 0.0f;
        for (size_t i = 0; i < 5 * (size_t)w * (size_t)h; ++i)
            sink += px[i]; /* every value must be readable */
        (void)sink;
    }
    free(px);
    spc_image_rgb img;
    memset(&img, 0, sizeof img);
    spc_image_rgb_read(path, &img, &err);
    spc_image_rgb_release(&img);
    return 0;
}

static inline int spc_fuzz_png(const uint8_t *data, size_t size) { return spc_fuzz_image(data, size); }
/* JPEG: the same reader entry, its own seed corpus of baseline, progressive, gray and CMYK files */
static inline int spc_fuzz_jpeg(const uint8_t *data, size_t size) { return spc_fuzz_image(data, size); }

/* A directory with nothing in it: every file a scene names is missing. Removed at exit. */
static char spc_fuzz_dir[64];

static inline void spc_fuzz_remove_dir(void) { rmdir(spc_fuzz_dir); }

static inline const char *spc_fuzz_empty_dir(void)
{
    if (!spc_fuzz_dir[0]) {
        snprintf(spc_fuzz_dir, sizeof spc_fuzz_dir, "/tmp/spc_fuzz_empty_XXXXXX");
        if (mkdtemp(spc_fuzz_dir))
            atexit(spc_fuzz_remove_dir);
        else
            snprintf(spc_fuzz_dir, sizeof spc_fuzz_dir, "/nonexistent-spc-fuzz");
    }
    return spc_fuzz_dir;
}

static inline int spc_fuzz_xml(const uint8_t *data, size_t size)
{
    spc_warn_set_quiet(1);
    /* two fixed defines so that $-substitution and <default> overrides are reached */
    spc_define defs[2] = {{"spp", "4"}, {"res", "8"}};
    spc_scene *sc = NULL;
    spc_error err;
    if (spc_mitsuba_load_string((const char *)data, size, "fuzz.xml", spc_fuzz_empty_dir(), defs, 2, &sc, &err) ==
            SPC_OK &&
        !sc)
        abort();
    spc_scene_destroy(sc);
    return 0;
}

static inline int spc_fuzz_checkpoint(const uint8_t *data, size_t size)
{
    char path[64];
    if (spc_fuzz_memfile(data, size, path, sizeof path) < 0)
        return 0;
    spc_checkpoint *c = NULL;
    spc_error err;
    if (spc_checkpoint_load(path, &c, &err) == SPC_OK) {
        spc_checkpoint_info info;
        spc_checkpoint_get_info(c, &info);
        if (!info.settings || !info.user || info.width <= 0 || info.height <= 0)
            abort();
    }
    spc_checkpoint_destroy(c);
    return 0;
}

#endif
