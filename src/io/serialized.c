/*
 * io/serialized.c: Mitsuba's .serialized mesh format (versions 3 and 4), as documented in
 * Mitsuba 3's src/shapes/serialized.cpp. Everything is little endian.
 *
 *   uint16 0x041C (format), uint16 version (3 or 4), then a zlib stream holding:
 *     uint32 flags: 0x0001 normals, 0x0002 uvs, 0x0008 vertex colors, 0x0010 face normals,
 *                   0x1000 single precision, 0x2000 double precision
 *     (version 4 only) the shape's name, NUL-terminated UTF-8
 *     uint64 vertex count, uint64 triangle count
 *     positions (3 per vertex), [normals (3)], [uvs (2)], [colors (3)]: float or double
 *     indices (3 per triangle): uint32 (uint64 when the vertex count exceeds 2^32 - 1, which we
 *     refuse as we index with uint32)
 *   A file holding several meshes concatenates such records and ends with a dictionary:
 *     one offset per mesh (uint64 in version 4, uint32 in version 3), then uint32 mesh count.
 *
 * shape_index 0 starts at offset 0 and needs no dictionary. The stream is inflated in chunks
 * straight into the mesh arrays (a file of many meshes is not read whole for each shape). Counts
 * are bounded by what the compressed bytes left could hold (zlib expands at most ~1032:1) before
 * anything is allocated; truncation, a wrong magic, a bad version, non-finite values and indices
 * out of range are errors naming the file. Face normals (0x0010) drop the vertex normals, so the
 * mesh uses face normals; colors are skipped.
 */
#include <errno.h>
#include <float.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <zlib.h>

#include "io/mesh_io.h"

#define SER_FORMAT 0x041C
#define SER_HAS_NORMALS 0x0001
#define SER_HAS_UVS 0x0002
#define SER_HAS_COLORS 0x0008
#define SER_FACE_NORMALS 0x0010
#define SER_DOUBLE 0x2000
#define SER_MAX_RATIO 1040   /* bound on zlib's expansion ratio (deflate's maximum is 1032:1) */
#define SER_MAX_NAME 65536   /* longest shape name accepted */
#define SER_CHUNK 4096       /* values converted per step */

typedef struct zin {
    FILE *f;
    z_stream zs;
    unsigned char in[1 << 16];
    bool ended;
    int zret; /* last zlib result, for messages */
} zin;

/* Reads exactly n bytes of inflated data; false on a truncated or corrupt stream. */
static bool zread(zin *z, void *dst, size_t n)
{
    unsigned char *out = dst;
    while (n > 0) {
        if (z->ended)
            return false;
        uInt step = n > (1u << 30) ? (1u << 30) : (uInt)n;
        z->zs.next_out = out;
        z->zs.avail_out = step;
        while (z->zs.avail_out > 0) {
            if (z->zs.avail_in == 0) {
                size_t r = fread(z->in, 1, sizeof z->in, z->f);
                if (r == 0)
                    return false;
                z->zs.next_in = z->in;
                z->zs.avail_in = (uInt)r;
            }
            int ret = inflate(&z->zs, Z_NO_FLUSH);
            z->zret = ret;
            if (ret == Z_STREAM_END) {
                z->ended = true;
                if (z->zs.avail_out > 0)
                    return false;
                break;
            }
            if (ret != Z_OK && !(ret == Z_BUF_ERROR && z->zs.avail_in == 0))
                return false;
        }
        out += step;
        n -= step;
    }
    return true;
}

/* After the last field: the stream must end here, and inflate checks zlib's Adler-32 of the
 * whole stream on the way (so a flipped byte in the data is caught). */
static bool zfinish(zin *z)
{
    unsigned char extra;
    while (!z->ended) {
        z->zs.next_out = &extra;
        z->zs.avail_out = 1;
        if (z->zs.avail_in == 0) {
            size_t r = fread(z->in, 1, sizeof z->in, z->f);
            if (r == 0)
                return false;
            z->zs.next_in = z->in;
            z->zs.avail_in = (uInt)r;
        }
        int ret = inflate(&z->zs, Z_NO_FLUSH);
        if (z->zs.avail_out == 0)
            return false; /* more data than the header announced */
        if (ret == Z_STREAM_END)
            z->ended = true;
        else if (ret != Z_OK && !(ret == Z_BUF_ERROR && z->zs.avail_in == 0))
            return false;
    }
    return true;
}

static uint32_t le32(const unsigned char *b)
{
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

static uint64_t le64(const unsigned char *b) { return (uint64_t)le32(b) | (uint64_t)le32(b + 4) << 32; }

/* Reads count values (float or double on file) into dst as float (dst may be NULL: skip). false
 * on truncation; *bad is set to the first non-finite value's index (or SIZE_MAX). */
static bool read_reals(zin *z, bool dbl, float *dst, size_t count, size_t *bad)
{
    unsigned char buf[SER_CHUNK * 8];
    size_t size = dbl ? 8 : 4;
    for (size_t done = 0; done < count;) {
        size_t k = count - done < SER_CHUNK ? count - done : SER_CHUNK;
        if (!zread(z, buf, k * size))
            return false;
        if (dst)
            for (size_t i = 0; i < k; ++i) {
                double v;
                if (dbl) {
                    uint64_t u = le64(buf + 8 * i);
                    memcpy(&v, &u, 8);
                } else {
                    uint32_t u = le32(buf + 4 * i);
                    float fv;
                    memcpy(&fv, &u, 4);
                    v = fv;
                }
                if ((!isfinite(v) || fabs(v) > FLT_MAX) && *bad == SIZE_MAX)
                    *bad = done + i;
                dst[done + i] = (float)v;
            }
        done += k;
    }
    return true;
}

spc_status spc_serialized_load(const char *path, int shape_index, spc_mesh *out, spc_error *err)
{
    memset(out, 0, sizeof *out);
    if (shape_index < 0)
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "negative shape_index %d", shape_index);
    FILE *f = fopen(path, "rb");
    if (!f)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open: %s", strerror(errno));
    zin *z = calloc(1, sizeof *z);
    if (!z) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    }
    z->f = f;
    bool z_init = false;
    spc_status st = SPC_OK;
    unsigned char b[16];
    float *p = NULL, *n = NULL, *uv = NULL;
    uint32_t *idx = NULL;
    char *name = NULL;

    long fsize = -1;
    if (fseek(f, 0, SEEK_END) == 0)
        fsize = ftell(f);
    if (fsize < 0 || fseek(f, 0, SEEK_SET) != 0) {
        st = spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot seek in the file");
        goto done;
    }
    if (fread(b, 1, 4, f) != 4) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "file too short for a .serialized header");
        goto done;
    }
    unsigned format = (unsigned)b[0] | (unsigned)b[1] << 8, version = (unsigned)b[2] | (unsigned)b[3] << 8;
    if (format != SER_FORMAT) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "not a .serialized file (format 0x%04x, expected 0x041c)",
                           format);
        goto done;
    }
    if (version != 3 && version != 4) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "unsupported .serialized version %u (3 or 4)", version);
        goto done;
    }

    /* Find the requested mesh through the end-of-file dictionary. */
    uint64_t start = 0, stop = (uint64_t)fsize;
    if (shape_index > 0) {
        size_t osize = version == 4 ? 8 : 4;
        uint32_t count = 0;
        if (fsize < 8 || fseek(f, fsize - 4, SEEK_SET) != 0 || fread(b, 1, 4, f) != 4) {
            st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "no mesh dictionary at the end of the file");
            goto done;
        }
        count = le32(b);
        uint64_t dict = (uint64_t)count * osize + 4;
        if (count == 0 || dict > (uint64_t)fsize) {
            st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "corrupt mesh dictionary (%u meshes)", (unsigned)count);
            goto done;
        }
        if ((uint32_t)shape_index >= count) {
            st = spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "shape_index %d out of range (the file has %u meshes)",
                               shape_index, (unsigned)count);
            goto done;
        }
        long at = (long)((uint64_t)fsize - dict + (uint64_t)shape_index * osize);
        if (fseek(f, at, SEEK_SET) != 0 || fread(b, 1, osize, f) != osize) {
            st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "cannot read the mesh dictionary");
            goto done;
        }
        start = osize == 8 ? le64(b) : le32(b);
        stop = (uint64_t)fsize - dict;
        if (start + 4 > stop) {
            st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "mesh %d: offset %llu beyond the data", shape_index,
                               (unsigned long long)start);
            goto done;
        }
        if (fseek(f, (long)start, SEEK_SET) != 0 || fread(b, 1, 4, f) != 4 ||
            ((unsigned)b[0] | (unsigned)b[1] << 8) != SER_FORMAT || ((unsigned)b[2] | (unsigned)b[3] << 8) != version) {
            st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "mesh %d: no mesh header at offset %llu", shape_index,
                               (unsigned long long)start);
            goto done;
        }
    }

    if (inflateInit(&z->zs) != Z_OK) {
        st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "cannot initialize zlib");
        goto done;
    }
    z_init = true;
#define ZREAD(dst, size, what)                                                                                        \
    do {                                                                                                              \
        if (!zread(z, (dst), (size))) {                                                                               \
            st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "mesh %d: truncated or corrupt data in %s (%s)",       \
                               shape_index, (what), z->zs.msg ? z->zs.msg : "unexpected end of stream");             \
            goto done;                                                                                                \
        }                                                                                                             \
    } while (0)

    ZREAD(b, 4, "flags");
    uint32_t flags = le32(b);
    if (version == 4) {
        size_t cap = 64, len = 0;
        name = malloc(cap);
        for (;;) {
            if (!name) {
                st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
                goto done;
            }
            ZREAD(b, 1, "name");
            if (b[0] == 0)
                break;
            if (len + 2 > cap) {
                if (cap >= SER_MAX_NAME) {
                    st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "mesh %d: name longer than %d bytes",
                                       shape_index, SER_MAX_NAME);
                    goto done;
                }
                cap *= 2;
                char *q = realloc(name, cap);
                if (!q)
                    free(name);
                name = q;
                if (!name)
                    continue;
            }
            name[len++] = (char)b[0];
        }
    }
    ZREAD(b, 16, "counts");
    uint64_t nv = le64(b), nt = le64(b + 8);
    bool dbl = (flags & SER_DOUBLE) != 0;
    size_t rsize = dbl ? 8 : 4;
    if (nv > UINT32_MAX) {
        st = spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "mesh %d: %llu vertices (at most 2^32 - 1)", shape_index,
                           (unsigned long long)nv);
        goto done;
    }
    /* Bytes the stream must inflate to, against what the compressed bytes left could hold. */
    uint64_t per_v = 3 + ((flags & SER_HAS_NORMALS) ? 3 : 0) + ((flags & SER_HAS_UVS) ? 2 : 0) +
                     ((flags & SER_HAS_COLORS) ? 3 : 0);
    uint64_t avail = (stop - start) * SER_MAX_RATIO + 4096;
    if (nt > avail / 12 || nv * per_v * rsize > avail || nv * per_v * rsize + nt * 12 > avail) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0,
                           "mesh %d: %llu vertices and %llu triangles cannot fit in the file (truncated or corrupt)",
                           shape_index, (unsigned long long)nv, (unsigned long long)nt);
        goto done;
    }
    if (nv == 0 || nt == 0) {
        st = spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "mesh %d is empty (%llu vertices, %llu triangles)",
                           shape_index, (unsigned long long)nv, (unsigned long long)nt);
        goto done;
    }
    bool keep_n = (flags & SER_HAS_NORMALS) && !(flags & SER_FACE_NORMALS);
    p = malloc((size_t)nv * 3 * sizeof *p);
    n = keep_n ? malloc((size_t)nv * 3 * sizeof *n) : NULL;
    uv = (flags & SER_HAS_UVS) ? malloc((size_t)nv * 2 * sizeof *uv) : NULL;
    idx = malloc((size_t)nt * 3 * sizeof *idx);
    if (!p || (keep_n && !n) || ((flags & SER_HAS_UVS) && !uv) || !idx) {
        st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for mesh %d", shape_index);
        goto done;
    }

    static const char *const what[4] = {"positions", "normals", "texture coordinates", "colors"};
    static const unsigned dims[4] = {3, 3, 2, 3};
    float *dsts[4] = {p, n, uv, NULL};
    bool present[4] = {true, (flags & SER_HAS_NORMALS) != 0, (flags & SER_HAS_UVS) != 0,
                       (flags & SER_HAS_COLORS) != 0};
    for (int a = 0; a < 4; ++a) {
        if (!present[a])
            continue;
        size_t bad = SIZE_MAX;
        if (!read_reals(z, dbl, dsts[a], (size_t)nv * dims[a], &bad)) {
            st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "mesh %d: truncated or corrupt data in %s",
                               shape_index, what[a]);
            goto done;
        }
        if (bad != SIZE_MAX) {
            st = spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "mesh %d: vertex %zu: non-finite value in %s",
                               shape_index, bad / dims[a], what[a]);
            goto done;
        }
    }
    for (size_t done_i = 0; done_i < (size_t)nt * 3;) {
        unsigned char ib[SER_CHUNK * 4];
        size_t k = (size_t)nt * 3 - done_i < SER_CHUNK ? (size_t)nt * 3 - done_i : SER_CHUNK;
        ZREAD(ib, k * 4, "indices");
        for (size_t i = 0; i < k; ++i) {
            uint32_t v = le32(ib + 4 * i);
            if (v >= nv) {
                st = spc_error_set(err, SPC_ERR_VALUE, path, 0, 0,
                                   "mesh %d: triangle %zu: vertex index %u out of range (%llu vertices)", shape_index,
                                   (done_i + i) / 3, (unsigned)v, (unsigned long long)nv);
                goto done;
            }
            idx[done_i + i] = v;
        }
        done_i += k;
    }
#undef ZREAD
    if (!zfinish(z)) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "mesh %d: corrupt data (%s)", shape_index,
                           z->zs.msg ? z->zs.msg : "the stream does not end where the header says");
        goto done;
    }
    out->nverts = (size_t)nv;
    out->ntris = (size_t)nt;
    out->p = p;
    out->n = n;
    out->uv = uv;
    out->idx = idx;
    p = n = uv = NULL;
    idx = NULL;

done:
    if (z_init)
        inflateEnd(&z->zs);
    free(z);
    fclose(f);
    free(name);
    free(p);
    free(n);
    free(uv);
    free(idx);
    return st;
}
