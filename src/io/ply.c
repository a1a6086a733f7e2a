/*
 * io/ply.c: PLY (Stanford polygon file) loader: ascii, binary_little_endian, binary_big_endian.
 *
 * Header: "ply", "format <ascii|binary_*> 1.0", "comment"/"obj_info" lines, "element <name> <n>",
 * "property <type> <name>", "property list <count type> <item type> <name>", "end_header".
 * Types: char/int8, uchar/uint8, short/int16, ushort/uint16, int/int32, uint/uint32,
 * float/float32, double/float64 (and int64/uint64 as an extension).
 *
 * Used: element "vertex" properties x y z (required), nx ny nz, and the uv pairs u v, s t,
 * texture_u texture_v or texture_s texture_t (each group only when complete); element "face"
 * list "vertex_indices" (or "vertex_index"). Other scalar properties of the vertex and face
 * elements become named mesh attributes where Mitsuba 3 makes them ones (assign_attrs); every
 * other property and element is read and skipped, whatever its type. Polygons are triangulated after all elements are read (a file may
 * list faces before vertices) with spc_polygon_triangulate. uvs are used as stored (Mitsuba's PLY
 * loader does not flip them).
 *
 * Robustness: element counts are checked against the bytes left in the file before anything is
 * allocated, so a corrupt header cannot trigger a huge allocation. Errors name "file:line" for the
 * header and ascii bodies, "file: <element> i" for binary bodies.
 */
#include <errno.h>
#include <float.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/image_io.h"
#include "io/mesh_io.h"

/* Largest file read (bytes). */
#define SPC_PLY_MAX_BYTES ((size_t)1 << 36)
#define MAX_PROPS 64     /* properties per element */
#define MAX_ELEMENTS 32  /* elements per file */
#define MAX_POLYGON 4096 /* vertices per face: beyond this a count is more likely corrupt */

typedef enum ptype { T_I8, T_U8, T_I16, T_U16, T_I32, T_U32, T_I64, T_U64, T_F32, T_F64 } ptype;

static const struct {
    const char *name;
    ptype type;
} type_names[] = {{"char", T_I8},     {"int8", T_I8},     {"uchar", T_U8},    {"uint8", T_U8},
                  {"short", T_I16},   {"int16", T_I16},   {"ushort", T_U16},  {"uint16", T_U16},
                  {"int", T_I32},     {"int32", T_I32},   {"uint", T_U32},    {"uint32", T_U32},
                  {"int64", T_I64},   {"uint64", T_U64},  {"float", T_F32},   {"float32", T_F32},
                  {"double", T_F64},  {"float64", T_F64}};

static size_t type_size(ptype t)
{
    switch (t) {
    case T_I8:
    case T_U8: return 1;
    case T_I16:
    case T_U16: return 2;
    case T_I32:
    case T_U32:
    case T_F32: return 4;
    case T_I64:
    case T_U64:
    case T_F64: return 8;
    }
    return 1;
}

static bool type_is_int(ptype t) { return t != T_F32 && t != T_F64; }

/* Roles of properties we use. */
enum { R_NONE = -1, R_X, R_Y, R_Z, R_NX, R_NY, R_NZ, R_U, R_V, R_INDICES, R_ATTR, R_COUNT };

typedef struct prop {
    char name[64];
    bool list;
    ptype type, count_type;
    int role;
    int attr, comp; /* R_ATTR: index in the element's attribute list, and the component */
} prop;

/* A mesh attribute being read: its values per vertex or per face (polygon). */
typedef struct attr_group {
    char name[SPC_MESH_ATTR_NAME_MAX];
    int dim;
    float *data;
} attr_group;

typedef struct element {
    char name[64];
    size_t count;
    prop props[MAX_PROPS];
    int nprops;
    int hdr_line;
    attr_group attrs[MAX_PROPS];
    int nattrs;
} element;

typedef struct ply {
    const char *path;
    spc_error *err;
    const unsigned char *data, *end; /* body */
    bool ascii, swap;
    element el[MAX_ELEMENTS];
    int nel;
    /* ascii cursor */
    const char *cur;
    int line;
} ply;

/* ---- reading values ---- */

static double load_scalar(const unsigned char *p, ptype t, bool swap)
{
    unsigned char b[8];
    size_t n = type_size(t);
    for (size_t i = 0; i < n; ++i)
        b[i] = swap ? p[n - 1 - i] : p[i];
    switch (t) {
    case T_I8: { int8_t v; memcpy(&v, b, 1); return v; }
    case T_U8: { uint8_t v; memcpy(&v, b, 1); return v; }
    case T_I16: { int16_t v; memcpy(&v, b, 2); return v; }
    case T_U16: { uint16_t v; memcpy(&v, b, 2); return v; }
    case T_I32: { int32_t v; memcpy(&v, b, 4); return v; }
    case T_U32: { uint32_t v; memcpy(&v, b, 4); return v; }
    case T_I64: { int64_t v; memcpy(&v, b, 8); return (double)v; }
    case T_U64: { uint64_t v; memcpy(&v, b, 8); return (double)v; }
    case T_F32: { float v; memcpy(&v, b, 4); return v; }
    case T_F64: { double v; memcpy(&v, b, 8); return v; }
    }
    return 0.0;
}

/* Reads the next value of the body, binary or ascii. what/index name it for errors. */
static spc_status next_value(ply *f, ptype t, double *out, const char *what, size_t index)
{
    if (!f->ascii) {
        size_t n = type_size(t);
        if ((size_t)(f->end - f->data) < n)
            return spc_error_set(f->err, SPC_ERR_PARSE, f->path, 0, 0, "%s %zu: unexpected end of file", what, index);
        *out = load_scalar(f->data, t, f->swap);
        f->data += n;
        return SPC_OK;
    }
    const char *s = f->cur;
    while (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\n' || *s == '\f' || *s == '\v') {
        if (*s == '\n')
            f->line++;
        ++s;
    }
    if (!*s)
        return spc_error_set(f->err, SPC_ERR_PARSE, f->path, f->line, 0, "%s %zu: unexpected end of file", what,
                             index);
    char *endp;
    double v = strtod(s, &endp);
    if (endp == s || (*endp && *endp != ' ' && *endp != '\t' && *endp != '\r' && *endp != '\n')) {
        const char *e = s;
        while (*e && *e != ' ' && *e != '\t' && *e != '\r' && *e != '\n')
            ++e;
        return spc_error_set(f->err, SPC_ERR_PARSE, f->path, f->line, 0, "%s %zu: invalid number '%.*s'", what, index,
                             (int)(e - s > 40 ? 40 : e - s), s);
    }
    if (type_is_int(t) && v != floor(v))
        return spc_error_set(f->err, SPC_ERR_PARSE, f->path, f->line, 0, "%s %zu: '%.*s' is not an integer", what,
                             index, (int)(endp - s > 40 ? 40 : endp - s), s);
    f->cur = endp;
    *out = v;
    return SPC_OK;
}

/* ---- header ---- */

static bool parse_type(const char *s, ptype *t)
{
    for (size_t i = 0; i < sizeof type_names / sizeof type_names[0]; ++i)
        if (strcmp(s, type_names[i].name) == 0) {
            *t = type_names[i].type;
            return true;
        }
    return false;
}

/* Splits a header line (modified in place) into at most max tokens. */
static int split(char *line, char **tok, int max)
{
    int n = 0;
    char *s = line;
    while (*s && n < max) {
        while (*s == ' ' || *s == '\t' || *s == '\r')
            ++s;
        if (!*s)
            break;
        tok[n++] = s;
        while (*s && *s != ' ' && *s != '\t' && *s != '\r')
            ++s;
        if (*s)
            *s++ = '\0';
    }
    return n;
}

static spc_status parse_header(ply *f, const unsigned char *buf, size_t size, size_t *body)
{
    size_t off = 0;
    int line = 0;
    bool have_format = false;
    char text[512];
    for (;;) {
        ++line;
        if (off >= size)
            return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "header ends without end_header");
        const unsigned char *nl = memchr(buf + off, '\n', size - off);
        if (!nl)
            return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "header ends without end_header");
        size_t len = (size_t)(nl - (buf + off));
        if (len >= sizeof text)
            return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "header line too long");
        memcpy(text, buf + off, len);
        text[len] = '\0';
        off += len + 1;
        if (memchr(text, '\0', len))
            return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "binary data in the header");
        char *tok[8];
        int n = split(text, tok, 8);
        if (line == 1) {
            if (n != 1 || strcmp(tok[0], "ply") != 0)
                return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "not a PLY file (no 'ply' magic)");
            continue;
        }
        if (n == 0)
            continue;
        if (strcmp(tok[0], "comment") == 0 || strcmp(tok[0], "obj_info") == 0)
            continue;
        if (strcmp(tok[0], "format") == 0) {
            if (n != 3 || have_format)
                return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "bad format line");
            if (strcmp(tok[2], "1.0") != 0)
                return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "unknown PLY version '%s'", tok[2]);
            bool host_le = (union { uint16_t u; unsigned char c[2]; }){.u = 1}.c[0] == 1;
            if (strcmp(tok[1], "ascii") == 0)
                f->ascii = true;
            else if (strcmp(tok[1], "binary_little_endian") == 0)
                f->swap = !host_le;
            else if (strcmp(tok[1], "binary_big_endian") == 0)
                f->swap = host_le;
            else
                return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "unknown PLY format '%s'", tok[1]);
            have_format = true;
        } else if (strcmp(tok[0], "element") == 0) {
            if (n != 3)
                return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "bad element line");
            if (f->nel == MAX_ELEMENTS)
                return spc_error_set(f->err, SPC_ERR_LIMIT, f->path, line, 0, "more than %d elements", MAX_ELEMENTS);
            char *endp;
            errno = 0;
            unsigned long long c = strtoull(tok[2], &endp, 10);
            if (*endp || tok[2][0] == '-' || errno)
                return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "bad element count '%s'", tok[2]);
            element *e = &f->el[f->nel++];
            memset(e, 0, sizeof *e);
            snprintf(e->name, sizeof e->name, "%s", tok[1]);
            e->count = (size_t)c;
            e->hdr_line = line;
        } else if (strcmp(tok[0], "property") == 0) {
            if (f->nel == 0)
                return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "property before any element");
            element *e = &f->el[f->nel - 1];
            if (e->nprops == MAX_PROPS)
                return spc_error_set(f->err, SPC_ERR_LIMIT, f->path, line, 0, "more than %d properties", MAX_PROPS);
            prop *p = &e->props[e->nprops];
            memset(p, 0, sizeof *p);
            p->role = R_NONE;
            if (n == 5 && strcmp(tok[1], "list") == 0) {
                p->list = true;
                if (!parse_type(tok[2], &p->count_type) || !parse_type(tok[3], &p->type))
                    return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "unknown type in list property");
                if (!type_is_int(p->count_type))
                    return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "list count type must be an integer");
                snprintf(p->name, sizeof p->name, "%s", tok[4]);
            } else if (n == 3) {
                if (!parse_type(tok[1], &p->type))
                    return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "unknown property type '%s'",
                                         tok[1]);
                snprintf(p->name, sizeof p->name, "%s", tok[2]);
            } else {
                return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "bad property line");
            }
            e->nprops++;
        } else if (strcmp(tok[0], "end_header") == 0) {
            if (!have_format)
                return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "no format line before end_header");
            *body = off;
            f->line = line + 1;
            return SPC_OK;
        } else {
            return spc_error_set(f->err, SPC_ERR_PARSE, f->path, line, 0, "unknown header keyword '%s'", tok[0]);
        }
    }
}

/* Assigns roles; returns the vertex and face elements (or NULL). */
static void assign_roles(ply *f, element **vert, element **face, bool *has_n, bool *has_uv)
{
    static const char *const uv_names[4][2] = {
        {"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
    *vert = *face = NULL;
    *has_n = *has_uv = false;
    for (int i = 0; i < f->nel; ++i) {
        element *e = &f->el[i];
        if (strcmp(e->name, "vertex") == 0 && !*vert) {
            *vert = e;
            int found[R_COUNT] = {0};
            int uv_pair = -1;
            for (int k = 0; k < 4 && uv_pair < 0; ++k) {
                int a = -1, b = -1;
                for (int j = 0; j < e->nprops; ++j)
                    if (!e->props[j].list) {
                        if (strcmp(e->props[j].name, uv_names[k][0]) == 0)
                            a = j;
                        if (strcmp(e->props[j].name, uv_names[k][1]) == 0)
                            b = j;
                    }
                if (a >= 0 && b >= 0) {
                    uv_pair = k;
                    e->props[a].role = R_U;
                    e->props[b].role = R_V;
                }
            }
            static const char *const xyz[6] = {"x", "y", "z", "nx", "ny", "nz"};
            for (int j = 0; j < e->nprops; ++j) {
                if (e->props[j].list)
                    continue;
                for (int r = 0; r < 6; ++r)
                    if (strcmp(e->props[j].name, xyz[r]) == 0 && !found[r]) {
                        e->props[j].role = r;
                        found[r] = 1;
                    }
            }
            *has_n = found[R_NX] && found[R_NY] && found[R_NZ];
            if (!*has_n)
                for (int j = 0; j < e->nprops; ++j)
                    if (e->props[j].role == R_NX || e->props[j].role == R_NY || e->props[j].role == R_NZ)
                        e->props[j].role = R_NONE;
            *has_uv = uv_pair >= 0;
        } else if (strcmp(e->name, "face") == 0 && !*face) {
            *face = e;
            for (int j = 0; j < e->nprops; ++j)
                if (e->props[j].list &&
                    (strcmp(e->props[j].name, "vertex_indices") == 0 || strcmp(e->props[j].name, "vertex_index") == 0)) {
                    e->props[j].role = R_INDICES;
                    break;
                }
        }
    }
}

/* ---- mesh attributes ---- */

/* Mitsuba 3's PLY loader exposes a vertex or face element's other scalar properties as named
 * attributes (mesh_attribute textures read them):
 *  - r g b [a] (or red green blue [alpha]), anywhere in the element: "<element>_color";
 *  - then, in file order, runs of consecutive properties "<prefix>_<c>" whose one-letter postfixes
 *    follow one of the sequences x y z w, r g b a, 0 1 2 3 or 1 2 3 4, of length 1 or 3:
 *    "<element>_<prefix>", with "_color" appended for the r g b sequence.
 * Other properties (no postfix, other lengths, a prefix seen before) are skipped. Integer
 * properties are normalized to [0, 1] by their type's largest value and sRGB-decoded, as
 * Mitsuba's struct conversion flags them (Normalized | Gamma). */
static const char *const POSTFIXES[4] = {"xr01", "yg12", "zb23", "wa34"};

static int find_prop(element *e, const char *name)
{
    for (int j = 0; j < e->nprops; ++j)
        if (!e->props[j].list && e->props[j].role == R_NONE && strcmp(e->props[j].name, name) == 0)
            return j;
    return -1;
}

static void add_group(element *e, const char *elname, const char *prefix, const char *suffix, const int *props, int dim)
{
    if (e->nattrs >= MAX_PROPS)
        return;
    attr_group *g = &e->attrs[e->nattrs];
    int len = snprintf(g->name, sizeof g->name, "%s_%s%s", elname, prefix, suffix);
    if (len < 0 || len >= (int)sizeof g->name)
        return;
    for (int k = 0; k < e->nattrs; ++k)
        if (strcmp(e->attrs[k].name, g->name) == 0)
            return;
    g->dim = dim;
    g->data = NULL;
    for (int c = 0; c < dim; ++c) {
        e->props[props[c]].role = R_ATTR;
        e->props[props[c]].attr = e->nattrs;
        e->props[props[c]].comp = c;
    }
    ++e->nattrs;
}

static void assign_attrs(element *e, const char *elname)
{
    static const char *const rgba[2][4] = {{"r", "g", "b", "a"}, {"red", "green", "blue", "alpha"}};
    for (int s = 0; s < 2; ++s) {
        int id[4];
        for (int c = 0; c < 4; ++c)
            id[c] = find_prop(e, rgba[s][c]);
        if (id[0] >= 0 && id[1] >= 0 && id[2] >= 0) {
            add_group(e, elname, "color", "", id, id[3] >= 0 ? 4 : 3);
            break;
        }
    }
    for (int j = 0; j < e->nprops;) {
        const prop *pr = &e->props[j];
        const char *us = strrchr(pr->name, '_');
        int seq = -1;
        if (!pr->list && pr->role == R_NONE && us && us != pr->name && us[1] && !us[2]) {
            const char *hit = strchr(POSTFIXES[0], us[1]);
            seq = hit ? (int)(hit - POSTFIXES[0]) : -1;
        }
        if (seq < 0) {
            ++j;
            continue;
        }
        size_t plen = (size_t)(us - pr->name);
        int ids[4] = {j, -1, -1, -1}, n = 1;
        while (n < 4 && j + n < e->nprops) {
            const prop *q = &e->props[j + n];
            if (q->list || q->role != R_NONE || strlen(q->name) != plen + 2 || strncmp(q->name, pr->name, plen) != 0 ||
                q->name[plen] != '_' || q->name[plen + 1] != POSTFIXES[n][seq])
                break;
            ids[n] = j + n;
            ++n;
        }
        if (n == 1 || n == 3) {
            char prefix[64];
            snprintf(prefix, sizeof prefix, "%.*s", (int)plen, pr->name);
            add_group(e, elname, prefix, seq == 1 ? "_color" : "", ids, n);
        }
        j += n;
    }
}

/* The value an attribute stores for a raw property value of type t. */
static float attr_value(double v, ptype t)
{
    double max = 1.0;
    switch (t) {
    case T_I8: max = 127.0; break;
    case T_U8: max = 255.0; break;
    case T_I16: max = 32767.0; break;
    case T_U16: max = 65535.0; break;
    case T_I32: max = 2147483647.0; break;
    case T_U32: max = 4294967295.0; break;
    case T_I64: max = 9223372036854775807.0; break;
    case T_U64: max = 18446744073709551615.0; break;
    case T_F32:
    case T_F64: return (float)v;
    }
    return (float)spc_srgb_to_linear(v / max);
}

static void free_attrs(ply *f)
{
    for (int i = 0; i < f->nel; ++i)
        for (int k = 0; k < f->el[i].nattrs; ++k) {
            free(f->el[i].attrs[k].data);
            f->el[i].attrs[k].data = NULL;
        }
}

/* ---- body ---- */

typedef struct ubuf {
    uint32_t *v;
    size_t n, cap;
} ubuf;

static bool ubuf_push(ubuf *b, uint32_t x)
{
    if (b->n == b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 4096;
        uint32_t *q = realloc(b->v, cap * sizeof *q);
        if (!q)
            return false;
        b->v = q;
        b->cap = cap;
    }
    b->v[b->n++] = x;
    return true;
}

/* The smallest number of body bytes one instance of e can take (to bound counts before
 * allocating): binary sizes, or 2 characters per value in ascii. */
static size_t min_instance_bytes(const element *e, bool ascii)
{
    size_t n = 0;
    for (int j = 0; j < e->nprops; ++j)
        n += ascii ? 2 : (e->props[j].list ? type_size(e->props[j].count_type) : type_size(e->props[j].type));
    return n;
}

spc_status spc_ply_load(const char *path, spc_mesh *out, spc_error *err)
{
    memset(out, 0, sizeof *out);
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open: %s", strerror(errno));
    size_t cap = 1 << 20, size = 0;
    unsigned char *buf = malloc(cap + 1);
    while (buf) {
        size += fread(buf + size, 1, cap - size, fp);
        if (size < cap)
            break;
        if (cap >= SPC_PLY_MAX_BYTES) {
            free(buf);
            fclose(fp);
            return spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "file too large");
        }
        cap *= 2;
        unsigned char *q = realloc(buf, cap + 1);
        if (!q)
            free(buf);
        buf = q;
    }
    bool read_error = ferror(fp) != 0;
    fclose(fp);
    if (!buf)
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading the file");
    if (read_error) {
        free(buf);
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "read error");
    }
    buf[size] = '\0';

    ply *f = calloc(1, sizeof *f);
    if (!f) {
        free(buf);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    }
    f->path = path;
    f->err = err;
    size_t body = 0;
    ubuf polys = {0};
    float *p = NULL, *n = NULL, *uv = NULL;
    spc_status st = parse_header(f, buf, size, &body);
    element *ve = NULL, *fe = NULL;
    bool has_n = false, has_uv = false;
    if (st == SPC_OK) {
        assign_roles(f, &ve, &fe, &has_n, &has_uv);
        if (!ve || !fe)
            st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "no '%s' element", ve ? "face" : "vertex");
    }
    if (st == SPC_OK) {
        bool xyz[3] = {false, false, false};
        for (int j = 0; j < ve->nprops; ++j)
            if (ve->props[j].role >= R_X && ve->props[j].role <= R_Z)
                xyz[ve->props[j].role] = true;
        bool idx = false, idx_int = true;
        for (int j = 0; j < fe->nprops; ++j)
            if (fe->props[j].role == R_INDICES) {
                idx = true;
                idx_int = type_is_int(fe->props[j].type);
            }
        if (!xyz[0] || !xyz[1] || !xyz[2])
            st = spc_error_set(err, SPC_ERR_PARSE, path, ve->hdr_line, 0, "vertex element lacks x, y or z");
        else if (!idx)
            st = spc_error_set(err, SPC_ERR_PARSE, path, fe->hdr_line, 0,
                               "face element lacks a vertex_indices list");
        else if (!idx_int)
            st = spc_error_set(err, SPC_ERR_PARSE, path, fe->hdr_line, 0, "vertex indices must be integers");
        else if (ve->count > UINT32_MAX)
            st = spc_error_set(err, SPC_ERR_LIMIT, path, ve->hdr_line, 0, "%zu vertices (at most 2^32 - 1)",
                               ve->count);
    }
    /* Bound every count by the bytes left before allocating. */
    if (st == SPC_OK) {
        size_t left = size - body;
        for (int i = 0; i < f->nel && st == SPC_OK; ++i) {
            size_t mb = min_instance_bytes(&f->el[i], f->ascii);
            if (mb > 0 && f->el[i].count > left / mb)
                st = spc_error_set(err, SPC_ERR_PARSE, path, f->el[i].hdr_line, 0,
                                   "element '%s' claims %zu entries but the file is too short", f->el[i].name,
                                   f->el[i].count);
        }
    }
    if (st == SPC_OK) {
        assign_attrs(ve, "vertex");
        assign_attrs(fe, "face");
        for (int pass = 0; pass < 2 && st == SPC_OK; ++pass) {
            element *e = pass ? fe : ve;
            for (int k = 0; k < e->nattrs && st == SPC_OK; ++k) {
                e->attrs[k].data = malloc(((size_t)e->attrs[k].dim * e->count + 1) * sizeof(float));
                if (!e->attrs[k].data)
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for attribute '%s'",
                                       e->attrs[k].name);
            }
        }
    }
    if (st == SPC_OK) {
        size_t nv = ve->count;
        p = malloc((3 * nv + 1) * sizeof *p);
        n = has_n ? malloc((3 * nv + 1) * sizeof *n) : NULL;
        uv = has_uv ? malloc((2 * nv + 1) * sizeof *uv) : NULL;
        if (!p || (has_n && !n) || (has_uv && !uv))
            st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for %zu vertices", nv);
    }
    f->data = buf + body;
    f->end = buf + size;
    f->cur = (const char *)buf + body;

    for (int i = 0; i < f->nel && st == SPC_OK; ++i) {
        element *e = &f->el[i];
        const char *what = e->name;
        for (size_t k = 0; k < e->count && st == SPC_OK; ++k) {
            for (int j = 0; j < e->nprops && st == SPC_OK; ++j) {
                prop *pr = &e->props[j];
                if (!pr->list) {
                    double v;
                    st = next_value(f, pr->type, &v, what, k);
                    if (st == SPC_OK && pr->role == R_ATTR && (e == ve || e == fe)) {
                        attr_group *g = &e->attrs[pr->attr];
                        float a = attr_value(v, pr->type);
                        if (!isfinite(a))
                            st = spc_error_set(err, SPC_ERR_VALUE, path, f->ascii ? f->line : 0, 0,
                                               "%s %zu: non-finite %s", what, k, pr->name);
                        else
                            g->data[(size_t)g->dim * k + (size_t)pr->comp] = a;
                        continue;
                    }
                    if (st != SPC_OK || e != ve || pr->role == R_NONE)
                        continue;
                    if (!isfinite(v) || fabs(v) > FLT_MAX) {
                        st = spc_error_set(err, SPC_ERR_VALUE, path, f->ascii ? f->line : 0, 0,
                                           "vertex %zu: non-finite %s", k, pr->name);
                        continue;
                    }
                    if (pr->role <= R_Z)
                        p[3 * k + (size_t)(pr->role - R_X)] = (float)v;
                    else if (pr->role <= R_NZ)
                        n[3 * k + (size_t)(pr->role - R_NX)] = (float)v;
                    else
                        uv[2 * k + (size_t)(pr->role - R_U)] = (float)v;
                    continue;
                }
                double c;
                st = next_value(f, pr->count_type, &c, what, k);
                if (st != SPC_OK)
                    continue;
                bool use = e == fe && pr->role == R_INDICES;
                if (c < 0 || c > MAX_POLYGON) {
                    st = spc_error_set(err, SPC_ERR_PARSE, path, f->ascii ? f->line : 0, 0, "%s %zu: bad list length %g",
                                       what, k, c);
                    continue;
                }
                size_t cnt = (size_t)c;
                if (use && cnt < 3) {
                    st = spc_error_set(err, SPC_ERR_VALUE, path, f->ascii ? f->line : 0, 0,
                                       "face %zu has %zu vertices (at least 3 needed)", k, cnt);
                    continue;
                }
                if (use && (!ubuf_push(&polys, (uint32_t)cnt))) {
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
                    continue;
                }
                for (size_t q = 0; q < cnt && st == SPC_OK; ++q) {
                    double v;
                    st = next_value(f, pr->type, &v, what, k);
                    if (st != SPC_OK || !use)
                        continue;
                    if (v < 0 || v >= (double)ve->count) {
                        st = spc_error_set(err, SPC_ERR_VALUE, path, f->ascii ? f->line : 0, 0,
                                           "face %zu: vertex index %.0f out of range (%zu vertices)", k, v, ve->count);
                        continue;
                    }
                    if (!ubuf_push(&polys, (uint32_t)v))
                        st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
                }
            }
        }
    }

    /* Triangulate (every polygon of c vertices gives c - 2 triangles). */
    uint32_t *idx = NULL;
    size_t ntris = 0;
    if (st == SPC_OK) {
        size_t total = 0;
        for (size_t i = 0; i < polys.n; i += 1 + polys.v[i])
            total += polys.v[i] - 2;
        if (total == 0) {
            st = spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "PLY file has no faces");
        } else {
            idx = malloc(3 * total * sizeof *idx);
            if (!idx)
                st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for %zu triangles", total);
            for (size_t i = 0; idx && i < polys.n; i += 1 + polys.v[i])
                ntris += spc_polygon_triangulate(p, polys.v + i + 1, polys.v[i], idx + 3 * ntris);
        }
    }
    /* The mesh's attributes: vertex ones as read, face ones repeated for each triangle of their
     * polygon (triangulated again polygon by polygon for the counts). */
    spc_mesh_attr *attrs = NULL;
    int nattrs = 0;
    if (st == SPC_OK && ve->nattrs + fe->nattrs > 0) {
        attrs = calloc((size_t)(ve->nattrs + fe->nattrs), sizeof *attrs);
        if (!attrs)
            st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
        for (int k = 0; st == SPC_OK && k < ve->nattrs; ++k) {
            attr_group *g = &ve->attrs[k];
            spc_mesh_attr *a = &attrs[nattrs++];
            snprintf(a->name, sizeof a->name, "%s", g->name);
            a->dim = g->dim;
            a->data = g->data;
            g->data = NULL;
        }
        uint32_t tri_scratch[3 * (MAX_POLYGON - 2)];
        for (int k = 0; st == SPC_OK && k < fe->nattrs; ++k) {
            attr_group *g = &fe->attrs[k];
            spc_mesh_attr *a = &attrs[nattrs++];
            snprintf(a->name, sizeof a->name, "%s", g->name);
            a->dim = g->dim;
            a->face = true;
            a->data = malloc(((size_t)g->dim * ntris + 1) * sizeof(float));
            if (!a->data) {
                st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
                break;
            }
            size_t t = 0, face = 0;
            for (size_t i = 0; i < polys.n; i += 1 + polys.v[i], ++face) {
                size_t nt = spc_polygon_triangulate(p, polys.v + i + 1, polys.v[i], tri_scratch);
                for (size_t q = 0; q < nt && t < ntris; ++q, ++t)
                    memcpy(a->data + (size_t)g->dim * t, g->data + (size_t)g->dim * face, (size_t)g->dim * sizeof(float));
            }
        }
    }
    if (st == SPC_OK) {
        out->nverts = ve->count;
        out->ntris = ntris;
        out->p = p;
        out->n = n;
        out->uv = uv;
        out->idx = idx;
        out->attrs = attrs;
        out->nattrs = nattrs;
    } else {
        for (int k = 0; k < nattrs; ++k)
            free(attrs[k].data);
        free(attrs);
        free(p);
        free(n);
        free(uv);
        free(idx);
    }
    free(polys.v);
    free_attrs(f);
    free(f);
    free(buf);
    return st;
}
