/*
 * io/obj.c: Wavefront OBJ loader.
 *
 * Supported: v x y z [w | r g b], vn x y z, vt u [v [w]], f with v, v/vt, v//vn, v/vt/vn and
 * negative (relative) indices; faces of any size are triangulated (spc_polygon_triangulate: fan
 * for convex polygons, ear clipping for concave ones). o, g, s, usemtl, mtllib, l, p and unknown
 * statements are skipped; '#' starts a comment anywhere on a line.
 *
 * OBJ indexes positions, normals and uvs separately; the mesh needs one index per vertex, so each
 * distinct (position, uv, normal) triple referenced by a face becomes one vertex, found through
 * an open-addressing hash table. Positions never referenced by a face are dropped.
 * If some face corners have normals and others do not, the normals are dropped (with a warning):
 * the mesh then uses face normals. Corners without uv get (0, 0) when other corners have one.
 * Texture coordinates are flipped (v' = 1 - v) by default, like Mitsuba's flip_tex_coords.
 *
 * The whole file is read into memory and parsed in place; numbers go through strtod, so any
 * valid C float syntax is accepted, and "nan"/"inf" are reported as invalid values. Errors name
 * file:line:col.
 */
#include <errno.h>
#include <float.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/mesh_io.h"

/* Largest file read (bytes): beyond this we would rather fail than swap. */
#define SPC_OBJ_MAX_BYTES ((size_t)1 << 34)

typedef struct fbuf {
    float *v;
    size_t n, cap;
} fbuf;

typedef struct ubuf {
    uint32_t *v;
    size_t n, cap;
} ubuf;

static bool fbuf_push(fbuf *b, const float *x, size_t k)
{
    if (b->n + k > b->cap) {
        size_t cap = b->cap ? b->cap * 2 : 1024;
        while (cap < b->n + k)
            cap *= 2;
        float *q = realloc(b->v, cap * sizeof *q);
        if (!q)
            return false;
        b->v = q;
        b->cap = cap;
    }
    memcpy(b->v + b->n, x, k * sizeof *x);
    b->n += k;
    return true;
}

static bool ubuf_push(ubuf *b, const uint32_t *x, size_t k)
{
    if (b->n + k > b->cap) {
        size_t cap = b->cap ? b->cap * 2 : 1024;
        while (cap < b->n + k)
            cap *= 2;
        uint32_t *q = realloc(b->v, cap * sizeof *q);
        if (!q)
            return false;
        b->v = q;
        b->cap = cap;
    }
    memcpy(b->v + b->n, x, k * sizeof *x);
    b->n += k;
    return true;
}

/* Distinct (position, uv + 1, normal + 1) triples; 0 means "none" for uv and normal. */
typedef struct vmap {
    ubuf keys;       /* 3 per vertex */
    uint32_t *slots; /* vertex id + 1, 0 = empty */
    size_t cap;      /* power of two */
} vmap;

static uint64_t hash3(const uint32_t *k)
{
    uint64_t h = k[0] * 0x9E3779B97F4A7C15ull;
    h ^= (k[1] + 0x632BE59BD9B4E019ull) * 0xC2B2AE3D27D4EB4Full;
    h ^= (k[2] + 0x85EBCA77C2B2AE63ull) * 0x165667B19E3779F9ull;
    return h ^ (h >> 29);
}

static bool vmap_grow(vmap *m)
{
    size_t cap = m->cap ? m->cap * 2 : 4096;
    uint32_t *slots = calloc(cap, sizeof *slots);
    if (!slots)
        return false;
    for (size_t i = 0; i < m->keys.n / 3; ++i) {
        size_t s = (size_t)hash3(m->keys.v + 3 * i) & (cap - 1);
        while (slots[s])
            s = (s + 1) & (cap - 1);
        slots[s] = (uint32_t)(i + 1);
    }
    free(m->slots);
    m->slots = slots;
    m->cap = cap;
    return true;
}

/* The vertex id of key, adding it if new; false on allocation failure or too many vertices. */
static bool vmap_get(vmap *m, const uint32_t *key, uint32_t *id)
{
    if (2 * (m->keys.n / 3 + 1) > m->cap && !vmap_grow(m))
        return false;
    size_t s = (size_t)hash3(key) & (m->cap - 1);
    while (m->slots[s]) {
        const uint32_t *k = m->keys.v + 3 * (size_t)(m->slots[s] - 1);
        if (k[0] == key[0] && k[1] == key[1] && k[2] == key[2]) {
            *id = m->slots[s] - 1;
            return true;
        }
        s = (s + 1) & (m->cap - 1);
    }
    size_t n = m->keys.n / 3;
    if (n >= UINT32_MAX - 1 || !ubuf_push(&m->keys, key, 3))
        return false;
    m->slots[s] = (uint32_t)(n + 1);
    *id = (uint32_t)n;
    return true;
}

typedef struct parser {
    const char *path;
    spc_error *err;
    int line;
    const char *ls; /* start of the current line (for columns) */
    const char *le; /* end of the current line */
} parser;

static int col(const parser *ps, const char *at) { return (int)(at - ps->ls) + 1; }

static bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

static const char *skip_blank(const parser *ps, const char *s)
{
    while (s < ps->le && is_blank(*s))
        ++s;
    return s;
}

/* True when s is at the end of a token. */
static bool token_end(const parser *ps, const char *s) { return s >= ps->le || is_blank(*s) || *s == '#'; }

static bool at_eol(const parser *ps, const char *s) { return s >= ps->le || *s == '#'; }

/* Parses one number token at *s (blanks skipped first). Returns SPC_OK, or an error. */
static spc_status parse_num(parser *ps, const char **s, double *out, const char *what)
{
    const char *t = skip_blank(ps, *s);
    if (at_eol(ps, t))
        return spc_error_set(ps->err, SPC_ERR_PARSE, ps->path, ps->line, col(ps, t), "missing %s", what);
    char *endp;
    double v = strtod(t, &endp);
    if (endp == t || endp > ps->le || !token_end(ps, endp)) {
        const char *e = t;
        while (!token_end(ps, e))
            ++e;
        return spc_error_set(ps->err, SPC_ERR_PARSE, ps->path, ps->line, col(ps, t), "invalid number '%.*s' for %s",
                             (int)(e - t > 40 ? 40 : e - t), t, what);
    }
    if (!isfinite(v) || fabs(v) > FLT_MAX)
        return spc_error_set(ps->err, SPC_ERR_VALUE, ps->path, ps->line, col(ps, t), "non-finite %s '%.*s'", what,
                             (int)(endp - t > 40 ? 40 : endp - t), t);
    *out = v;
    *s = endp;
    return SPC_OK;
}

/* Parses the rest of a line as optional numbers (and fails on anything else). */
static spc_status parse_optional_nums(parser *ps, const char *s, double *out, int max, int *count, const char *what)
{
    *count = 0;
    for (;;) {
        s = skip_blank(ps, s);
        if (at_eol(ps, s))
            return SPC_OK;
        double v;
        spc_status st = parse_num(ps, &s, &v, what);
        if (st != SPC_OK)
            return st;
        if (*count < max)
            out[*count] = v;
        ++*count;
    }
}

/* Parses an OBJ index (nonzero integer, possibly negative) and resolves it against count. On
 * success *idx is 0-based. */
static spc_status parse_index(parser *ps, const char **s, size_t count, const char *what, uint32_t *idx)
{
    const char *t = *s, *p = t;
    bool neg = false;
    if (p < ps->le && (*p == '-' || *p == '+')) {
        neg = *p == '-';
        ++p;
    }
    uint64_t v = 0;
    const char *digits = p;
    while (p < ps->le && *p >= '0' && *p <= '9') {
        if (v < ((uint64_t)1 << 40))
            v = v * 10 + (uint64_t)(*p - '0');
        ++p;
    }
    if (p == digits)
        return spc_error_set(ps->err, SPC_ERR_PARSE, ps->path, ps->line, col(ps, t), "invalid %s index", what);
    if (v == 0)
        return spc_error_set(ps->err, SPC_ERR_VALUE, ps->path, ps->line, col(ps, t),
                             "%s index 0 (OBJ indices start at 1)", what);
    if (v > count)
        return spc_error_set(ps->err, SPC_ERR_VALUE, ps->path, ps->line, col(ps, t),
                             "%s index %s%llu out of range (%zu defined so far)", what, neg ? "-" : "",
                             (unsigned long long)v, count);
    *idx = (uint32_t)(neg ? count - v : v - 1);
    *s = p;
    return SPC_OK;
}

static spc_status read_file(const char *path, char **buf, size_t *size, spc_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open: %s", strerror(errno));
    size_t cap = 1 << 20, n = 0;
    char *b = malloc(cap + 1);
    while (b) {
        size_t r = fread(b + n, 1, cap - n, f);
        n += r;
        if (n < cap) {
            if (ferror(f)) {
                int e = errno;
                free(b);
                fclose(f);
                return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "read error: %s", strerror(e));
            }
            break;
        }
        if (cap >= SPC_OBJ_MAX_BYTES) {
            free(b);
            fclose(f);
            return spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "file larger than %zu bytes", SPC_OBJ_MAX_BYTES);
        }
        cap *= 2;
        char *q = realloc(b, cap + 1);
        if (!q)
            free(b);
        b = q;
    }
    fclose(f);
    if (!b)
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading the file");
    b[n] = '\0';
    *buf = b;
    *size = n;
    return SPC_OK;
}

spc_status spc_obj_load(const char *path, spc_mesh *out, spc_error *err)
{
    return spc_obj_load_ex(path, true, out, err);
}

spc_status spc_obj_load_ex(const char *path, bool flip_tex_coords, spc_mesh *out, spc_error *err)
{
    memset(out, 0, sizeof *out);
    char *buf = NULL;
    size_t size = 0;
    spc_status st = read_file(path, &buf, &size, err);
    if (st != SPC_OK)
        return st;

    fbuf pos = {0}, nrm = {0}, tex = {0};
    ubuf tris = {0}, face = {0};
    vmap map = {0};
    bool any_n = false, missing_n = false, any_uv = false;
    float poly_p[3 * 64];
    float *poly = poly_p;
    size_t poly_cap = 64;
    uint32_t local[64], *loc = local;
    uint32_t tri_small[3 * 62], *tri_buf = tri_small;
    parser ps = {path, err, 0, NULL, NULL};
    const char *s = buf, *end = buf + size;

    while (s < end && st == SPC_OK) {
        ps.line++;
        ps.ls = s;
        const char *nl = memchr(s, '\n', (size_t)(end - s));
        ps.le = nl ? nl : end;
        const char *next = nl ? nl + 1 : end;
        s = skip_blank(&ps, s);
        if (at_eol(&ps, s)) {
            s = next;
            continue;
        }
        const char *kw = s;
        while (!token_end(&ps, s))
            ++s;
        size_t kwlen = (size_t)(s - kw);

        if (kwlen == 1 && kw[0] == 'v') {
            double x[3];
            int extra = 0;
            double ign[4];
            for (int k = 0; k < 3 && st == SPC_OK; ++k)
                st = parse_num(&ps, &s, &x[k], "vertex coordinate");
            if (st == SPC_OK)
                st = parse_optional_nums(&ps, s, ign, 4, &extra, "vertex coordinate");
            if (st == SPC_OK) {
                float f[3] = {(float)x[0], (float)x[1], (float)x[2]};
                if (!fbuf_push(&pos, f, 3))
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, ps.line, 0, "out of memory");
            }
        } else if (kwlen == 2 && kw[0] == 'v' && kw[1] == 'n') {
            double x[3];
            int extra = 0;
            double ign[1];
            for (int k = 0; k < 3 && st == SPC_OK; ++k)
                st = parse_num(&ps, &s, &x[k], "normal coordinate");
            if (st == SPC_OK)
                st = parse_optional_nums(&ps, s, ign, 1, &extra, "normal coordinate");
            if (st == SPC_OK && extra > 0)
                st = spc_error_set(err, SPC_ERR_PARSE, path, ps.line, 0, "vn takes 3 numbers, got %d", 3 + extra);
            if (st == SPC_OK) {
                float f[3] = {(float)x[0], (float)x[1], (float)x[2]};
                if (!fbuf_push(&nrm, f, 3))
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, ps.line, 0, "out of memory");
            }
        } else if (kwlen == 2 && kw[0] == 'v' && kw[1] == 't') {
            double u = 0.0, vw[2] = {0.0, 0.0};
            int extra = 0;
            st = parse_num(&ps, &s, &u, "texture coordinate");
            if (st == SPC_OK)
                st = parse_optional_nums(&ps, s, vw, 2, &extra, "texture coordinate");
            if (st == SPC_OK && extra > 2)
                st = spc_error_set(err, SPC_ERR_PARSE, path, ps.line, 0, "vt takes at most 3 numbers, got %d",
                                   1 + extra);
            if (st == SPC_OK) {
                double v = extra > 0 ? vw[0] : 0.0;
                float f[2] = {(float)u, (float)(flip_tex_coords ? 1.0 - v : v)};
                if (!fbuf_push(&tex, f, 2))
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, ps.line, 0, "out of memory");
            }
        } else if (kwlen == 1 && kw[0] == 'f') {
            face.n = 0;
            size_t np = pos.n / 3, nt = tex.n / 2, nn = nrm.n / 3;
            for (;;) {
                s = skip_blank(&ps, s);
                if (at_eol(&ps, s))
                    break;
                uint32_t key[3] = {0, 0, 0};
                uint32_t ix;
                st = parse_index(&ps, &s, np, "vertex", &ix);
                if (st != SPC_OK)
                    break;
                key[0] = ix;
                if (s < ps.le && *s == '/') {
                    ++s;
                    if (s < ps.le && *s != '/') {
                        st = parse_index(&ps, &s, nt, "texture coordinate", &ix);
                        if (st != SPC_OK)
                            break;
                        key[1] = ix + 1;
                    }
                    if (s < ps.le && *s == '/') {
                        ++s;
                        st = parse_index(&ps, &s, nn, "normal", &ix);
                        if (st != SPC_OK)
                            break;
                        key[2] = ix + 1;
                    }
                }
                if (!token_end(&ps, s)) {
                    st = spc_error_set(err, SPC_ERR_PARSE, path, ps.line, col(&ps, s),
                                       "unexpected character '%c' in face vertex", *s);
                    break;
                }
                any_uv |= key[1] != 0;
                any_n |= key[2] != 0;
                missing_n |= key[2] == 0;
                uint32_t id;
                if (!vmap_get(&map, key, &id) || !ubuf_push(&face, &id, 1)) {
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, ps.line, 0, "out of memory (or 2^32 vertices)");
                    break;
                }
                /* remember the position index next to the vertex id for triangulation */
                if (!ubuf_push(&face, &key[0], 1)) {
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, ps.line, 0, "out of memory");
                    break;
                }
            }
            if (st != SPC_OK)
                break;
            size_t n = face.n / 2;
            if (n < 3) {
                st = spc_error_set(err, SPC_ERR_PARSE, path, ps.line, col(&ps, kw),
                                   "face with %zu vertices (at least 3 needed)", n);
                break;
            }
            if (n == 3) {
                uint32_t t[3] = {face.v[0], face.v[2], face.v[4]};
                if (!ubuf_push(&tris, t, 3))
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, ps.line, 0, "out of memory");
            } else {
                if (n > poly_cap) {
                    float *np2 = malloc(3 * n * sizeof *np2);
                    uint32_t *nl2 = malloc(n * sizeof *nl2);
                    uint32_t *nt2 = malloc(3 * (n - 2) * sizeof *nt2);
                    if (!np2 || !nl2 || !nt2) {
                        free(np2), free(nl2), free(nt2);
                        st = spc_error_set(err, SPC_ERR_NOMEM, path, ps.line, 0, "out of memory");
                        break;
                    }
                    if (poly != poly_p)
                        free(poly), free(loc), free(tri_buf);
                    poly = np2, loc = nl2, tri_buf = nt2;
                    poly_cap = n;
                }
                for (size_t i = 0; i < n; ++i) {
                    memcpy(poly + 3 * i, pos.v + 3 * (size_t)face.v[2 * i + 1], 3 * sizeof(float));
                    loc[i] = (uint32_t)i;
                }
                size_t k = spc_polygon_triangulate(poly, loc, n, tri_buf);
                for (size_t i = 0; i < 3 * k; ++i)
                    tri_buf[i] = face.v[2 * tri_buf[i]];
                if (!ubuf_push(&tris, tri_buf, 3 * k))
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, ps.line, 0, "out of memory");
            }
        }
        /* everything else (o, g, s, usemtl, mtllib, l, p, ...) is skipped */
        s = next;
    }

    if (st == SPC_OK && tris.n == 0)
        st = spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "OBJ file has no faces");
    if (st == SPC_OK) {
        size_t nv = map.keys.n / 3;
        bool keep_n = any_n && !missing_n;
        if (any_n && missing_n)
            spc_warn(path, 0, 0, "some faces have normals and others do not: using face normals");
        out->p = malloc(3 * nv * sizeof(float));
        out->n = keep_n ? malloc(3 * nv * sizeof(float)) : NULL;
        out->uv = any_uv ? malloc(2 * nv * sizeof(float)) : NULL;
        if (!out->p || (keep_n && !out->n) || (any_uv && !out->uv)) {
            st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
        } else {
            for (size_t i = 0; i < nv; ++i) {
                const uint32_t *k = map.keys.v + 3 * i;
                memcpy(out->p + 3 * i, pos.v + 3 * (size_t)k[0], 3 * sizeof(float));
                if (keep_n)
                    memcpy(out->n + 3 * i, nrm.v + 3 * (size_t)(k[2] - 1), 3 * sizeof(float));
                if (any_uv) {
                    if (k[1])
                        memcpy(out->uv + 2 * i, tex.v + 2 * (size_t)(k[1] - 1), 2 * sizeof(float));
                    else
                        out->uv[2 * i] = out->uv[2 * i + 1] = 0.0f;
                }
            }
            out->nverts = nv;
            out->ntris = tris.n / 3;
            out->idx = tris.v;
            tris.v = NULL;
        }
    }
    if (st != SPC_OK)
        spc_mesh_release(out);
    if (poly != poly_p)
        free(poly), free(loc), free(tri_buf);
    free(buf);
    free(pos.v);
    free(nrm.v);
    free(tex.v);
    free(tris.v);
    free(face.v);
    free(map.keys.v);
    free(map.slots);
    return st;
}
