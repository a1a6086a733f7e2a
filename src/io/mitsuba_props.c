/*
 * io/mitsuba_props.c: what every part of the Mitsuba loader reads through (mitsuba_props.h): the
 * sticky error, file names resolved against the scene's folders, the id table's lookup, the
 * properties of an object element (values parsed: numbers, points, transforms, rgb and spectra)
 * and their typed getters, which mark what a plugin read, so that the rest is reported. Below the
 * builders (mitsuba_plugins.c and the others) and the walk over the document (mitsuba_xml.c).
 */
#include "io/mitsuba_props.h"

#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/hash.h"
#include "io/mitsuba_tables.h"

/* ------------------------------------------------------------------------------------------------ */
/* errors, warnings */

spc_status mts_fail(mts_loader *L, const spc_xml_node *at, spc_status code, const char *fmt, ...)
{
    if (L->status != SPC_OK)
        return L->status;
    va_list ap;
    va_start(ap, fmt);
    spc_error_setv(L->err, code, at ? at->file : NULL, at ? at->line : 0, at ? at->col : 0, fmt, ap);
    va_end(ap);
    L->status = code;
    return code;
}

spc_status mts_nomem(mts_loader *L, const spc_xml_node *at)
{
    return mts_fail(L, at, SPC_ERR_NOMEM, "out of memory");
}

void mts_warn(const spc_xml_node *at, const char *fmt, ...)
{
    char msg[SPC_ERROR_MSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    spc_warn(at ? at->file : NULL, at ? at->line : 0, at ? at->col : 0, "%s", msg);
}

const char *mts_type(const spc_xml_node *n)
{
    const char *t = spc_xml_get(n, "type");
    return t ? t : "";
}

int mts_dialect(const spc_xml_node *n) { return n->user; }

static bool is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode) && access(path, R_OK) == 0;
}

static bool is_dir(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

static bool join_path(char *out, size_t size, const char *dir, const char *name)
{
    int n = (dir && dir[0] && name[0] != '/') ? snprintf(out, size, "%s/%s", dir, name)
                                              : snprintf(out, size, "%s", name);
    return n >= 0 && (size_t)n < size;
}

static const char *doc_dir(const mts_loader *L, const spc_xml_node *at)
{
    for (int i = 0; i < L->ndocs; ++i)
        if (at && L->docs[i].file == at->file)
            return L->docs[i].dir;
    return L->base_dir;
}

/* Every file the scene refers to is found here, so its bytes enter the scene's hash here: a
 * checkpoint is then refused when a mesh or a texture changed, not only the XML (checkpoint.h). A
 * file that cannot be read folds in as far as it was read; loading it fails anyway. */
static bool found(mts_loader *L, const char *path)
{
    (void)spc_fnv1a_file(&L->files_hash, path);
    return true;
}

bool mts_resolve(mts_loader *L, const spc_xml_node *at, const char *name, char *out, size_t size)
{
    char buf[4096];
    if (name[0] == '/') {
        if (!is_file(name) || strlen(name) >= size)
            return false;
        strcpy(out, name);
        return found(L, out);
    }
    const char *cands[3] = {doc_dir(L, at), L->base_dir, NULL};
    for (int i = 0; i < 2; ++i) {
        if (join_path(buf, sizeof buf, cands[i], name) && is_file(buf) && strlen(buf) < size) {
            strcpy(out, buf);
            return found(L, out);
        }
    }
    for (int i = L->ndirs - 1; i >= 0; --i) {
        if (join_path(buf, sizeof buf, L->dirs[i], name) && is_file(buf) && strlen(buf) < size) {
            strcpy(out, buf);
            return found(L, out);
        }
    }
    if (is_file(name) && strlen(name) < size) {
        strcpy(out, name);
        return found(L, out);
    }
    return false;
}

static const char *path_failure(const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return NULL;
    if (S_ISDIR(st.st_mode))
        return "is a directory, not a file";
    if (!S_ISREG(st.st_mode))
        return "is not a regular file";
    return access(path, R_OK) == 0 ? NULL : "cannot be read (permission denied)";
}

const char *mts_resolve_failure(mts_loader *L, const spc_xml_node *at, const char *name)
{
    char buf[4096];
    const char *why;
    if (name[0] == '/')
        return (why = path_failure(name)) ? why : "not found";
    const char *cands[2] = {doc_dir(L, at), L->base_dir};
    for (int i = 0; i < 2; ++i)
        if (join_path(buf, sizeof buf, cands[i], name) && (why = path_failure(buf)))
            return why;
    for (int i = L->ndirs - 1; i >= 0; --i)
        if (join_path(buf, sizeof buf, L->dirs[i], name) && (why = path_failure(buf)))
            return why;
    return (why = path_failure(name)) ? why : "not found";
}

const char *mts_resolve_dir(mts_loader *L, const spc_xml_node *at, const char *value, char *buf, size_t size)
{
    const char *dir = value;
    if (value[0] != '/' && join_path(buf, size, doc_dir(L, at), value) && is_dir(buf))
        dir = buf;
    /* else, as Mitsuba 3's file resolver: relative to the main file's folder or a folder named
     * before (an included file's path written relative to the scene that includes it) */
    if (value[0] != '/' && !is_dir(dir) && join_path(buf, size, L->base_dir, value) && is_dir(buf))
        dir = buf;
    for (int i = L->ndirs - 1; i >= 0 && value[0] != '/' && !is_dir(dir); --i)
        if (join_path(buf, size, L->dirs[i], value) && is_dir(buf))
            dir = buf;
    return is_dir(dir) ? dir : NULL;
}

/* ------------------------------------------------------------------------------------------------ */
/* ids */

mts_id *mts_lookup_id(mts_loader *L, const char *id)
{
    int lo = 0, hi = L->nids - 1;
    while (lo <= hi) {
        int mid = (lo + hi) / 2;
        int c = strcmp(L->ids[mid].id, id);
        if (c == 0)
            return &L->ids[mid];
        if (c < 0)
            lo = mid + 1;
        else
            hi = mid - 1;
    }
    return NULL;
}

mts_id *mts_id_of(mts_loader *L, const spc_xml_node *node)
{
    const char *id = spc_xml_get(node, "id");
    if (!id)
        return NULL;
    mts_id *e = mts_lookup_id(L, id);
    return e && e->node == node ? e : NULL;
}

bool mts_is_object_tag(const char *t)
{
    static const char *tags[] = {"bsdf",   "texture",    "shape",  "emitter", "sensor", "film",
                                 "sampler", "rfilter", "integrator", "medium", "phase",   "volume",
                                 "sdf"};
    for (size_t i = 0; i < sizeof tags / sizeof tags[0]; ++i)
        if (strcmp(t, tags[i]) == 0)
            return true;
    return false;
}

/* ------------------------------------------------------------------------------------------------ */
/* values */

static bool parse_double(const char *s, double *out)
{
    while (isspace((unsigned char)*s))
        ++s;
    if (!*s)
        return false;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || errno == ERANGE)
        return false;
    while (isspace((unsigned char)*end))
        ++end;
    if (*end || !isfinite(v))
        return false;
    *out = v;
    return true;
}

/* Numbers separated by commas and/or white space. Returns how many tokens there were (storing at
 * most max) or -1 if one is not a number (its text in bad). */
static int parse_list(const char *s, double *out, int max, char *bad, size_t bad_size)
{
    int n = 0;
    while (*s) {
        while (*s && (isspace((unsigned char)*s) || *s == ','))
            ++s;
        if (!*s)
            break;
        const char *start = s;
        while (*s && !isspace((unsigned char)*s) && *s != ',')
            ++s;
        char tok[128];
        size_t len = (size_t)(s - start);
        if (len >= sizeof tok)
            len = sizeof tok - 1;
        memcpy(tok, start, len);
        tok[len] = '\0';
        double v;
        if (!parse_double(tok, &v)) {
            snprintf(bad, bad_size, "%s", tok);
            return -1;
        }
        if (n < max)
            out[n] = v;
        ++n;
    }
    return n;
}

static spc_status need_attr(mts_loader *L, const spc_xml_node *n, const char *attr, const char **out)
{
    *out = spc_xml_get(n, attr);
    if (!*out)
        return mts_fail(L, n, SPC_ERR_PARSE, "<%s> needs a '%s' attribute", n->name, attr);
    return SPC_OK;
}

static spc_status attr_double(mts_loader *L, const spc_xml_node *n, const char *attr, double def, double *out)
{
    const char *v = spc_xml_get(n, attr);
    if (!v) {
        *out = def;
        return SPC_OK;
    }
    if (!parse_double(v, out))
        return mts_fail(L, n, SPC_ERR_VALUE, "could not parse float value \"%s\" of attribute '%s' of <%s>", v, attr,
                        n->name);
    return SPC_OK;
}

/* x/y/z attributes (missing ones = def) or value="x, y, z" (or one value for all three). */
static spc_status parse_xyz(mts_loader *L, const spc_xml_node *n, double def, spc_vec3 *out)
{
    const char *value = spc_xml_get(n, "value");
    if (value) {
        if (spc_xml_get(n, "x") || spc_xml_get(n, "y") || spc_xml_get(n, "z"))
            return mts_fail(L, n, SPC_ERR_PARSE, "<%s> mixes the value and x/y/z attributes", n->name);
        double v[3];
        char bad[128];
        int k = parse_list(value, v, 3, bad, sizeof bad);
        if (k < 0)
            return mts_fail(L, n, SPC_ERR_VALUE, "could not parse float value \"%s\" in <%s>", bad, n->name);
        if (k == 1)
            v[1] = v[2] = v[0];
        else if (k != 3)
            return mts_fail(L, n, SPC_ERR_VALUE, "<%s> value needs 1 or 3 numbers, got %d", n->name, k);
        *out = spc_v3(v[0], v[1], v[2]);
        return SPC_OK;
    }
    double x, y, z;
    if (attr_double(L, n, "x", def, &x) || attr_double(L, n, "y", def, &y) || attr_double(L, n, "z", def, &z))
        return L->status;
    *out = spc_v3(x, y, z);
    return SPC_OK;
}

static spc_status parse_named_vec(mts_loader *L, const spc_xml_node *n, const char *attr, spc_vec3 *out)
{
    const char *v = spc_xml_get(n, attr);
    double xyz[3];
    char bad[128];
    int k = parse_list(v, xyz, 3, bad, sizeof bad);
    if (k < 0)
        return mts_fail(L, n, SPC_ERR_VALUE, "could not parse float value \"%s\" in attribute '%s' of <%s>", bad,
                        attr, n->name);
    if (k != 3)
        return mts_fail(L, n, SPC_ERR_VALUE, "attribute '%s' of <%s> needs 3 numbers, got %d", attr, n->name, k);
    *out = spc_v3(xyz[0], xyz[1], xyz[2]);
    return SPC_OK;
}

static spc_status parse_transform(mts_loader *L, const spc_xml_node *t, spc_mat4 *out)
{
    spc_mat4 M = spc_mat4_identity();
    for (int i = 0; i < t->nchildren; ++i) {
        const spc_xml_node *c = t->children[i];
        spc_mat4 A;
        if (strcmp(c->name, "translate") == 0) {
            spc_vec3 v;
            if (parse_xyz(L, c, 0.0, &v))
                return L->status;
            A = spc_mat4_translate(v);
        } else if (strcmp(c->name, "scale") == 0) {
            spc_vec3 v;
            if (parse_xyz(L, c, 1.0, &v))
                return L->status;
            A = spc_mat4_scale(v);
        } else if (strcmp(c->name, "rotate") == 0) {
            spc_vec3 axis;
            double angle;
            const char *a;
            if (parse_xyz(L, c, 0.0, &axis) || need_attr(L, c, "angle", &a) || attr_double(L, c, "angle", 0, &angle))
                return L->status;
            if (!(spc_length(axis) > 0.0))
                return mts_fail(L, c, SPC_ERR_VALUE, "<rotate> needs a non-zero axis");
            if (fabs(spc_length(axis) - 1.0) > 1e-6)
                mts_warn(c, "<rotate> axis of length %g: used as written, as Mitsuba 3 does (the matrix also scales)",
                         spc_length(axis));
            /* Mitsuba 3's <rotate>: the axis as written, not normalized (Mitsuba 3 builds it with
             * drjit's rotate, which does not normalize), so an axis such as (0, 1, 1) rotates and
             * also stretches; the same scene must give the same geometry in both renderers */
            A = spc_mat4_rodrigues(axis, angle);
        } else if (strcmp(c->name, "lookat") == 0) {
            spc_vec3 o, tg, up = spc_v3(0, 0, 0);
            const char *s;
            if (need_attr(L, c, "origin", &s) || need_attr(L, c, "target", &s) || parse_named_vec(L, c, "origin", &o) ||
                parse_named_vec(L, c, "target", &tg))
                return L->status;
            if (spc_xml_get(c, "up") && parse_named_vec(L, c, "up", &up))
                return L->status;
            if (spc_length2(up) == 0.0) {
                spc_vec3 d = spc_normalize(spc_sub(tg, o));
                up = spc_frame_from_n(d).s;
            }
            if (!spc_mat4_lookat(o, tg, up, &A))
                return mts_fail(L, c, SPC_ERR_VALUE,
                                "invalid <lookat>: origin equals target, or up is parallel to the view direction");
        } else if (strcmp(c->name, "matrix") == 0) {
            const char *value;
            if (need_attr(L, c, "value", &value))
                return L->status;
            double v[16];
            char bad[128];
            int k = parse_list(value, v, 16, bad, sizeof bad);
            if (k < 0)
                return mts_fail(L, c, SPC_ERR_VALUE, "could not parse float value \"%s\" in <matrix>", bad);
            A = spc_mat4_identity();
            if (k == 16) {
                for (int r = 0; r < 4; ++r)
                    for (int q = 0; q < 4; ++q)
                        A.m[r][q] = v[4 * r + q];
            } else if (k == 9) {
                for (int r = 0; r < 3; ++r)
                    for (int q = 0; q < 3; ++q)
                        A.m[r][q] = v[3 * r + q];
            } else {
                return mts_fail(L, c, SPC_ERR_VALUE, "<matrix> needs 16 (or 9) values, got %d", k);
            }
        } else {
            return mts_fail(L, c, SPC_ERR_PARSE,
                            "unexpected <%s> in <transform> (expected translate, scale, rotate, lookat, matrix)",
                            c->name);
        }
        M = spc_mat4_mul(&A, &M);
    }
    *out = M;
    return SPC_OK;
}

static spc_status parse_rgb(mts_loader *L, const spc_xml_node *n, bool srgb, spc_rgb *out)
{
    const char *value;
    if (need_attr(L, n, "value", &value))
        return L->status;
    const char *s = value;
    while (isspace((unsigned char)*s))
        ++s;
    if (*s == '#') {
        /* #rrggbb: 8-bit sRGB-encoded, as everywhere else hex colours are */
        unsigned r, g, b;
        char tail;
        if (strlen(s) < 7 || sscanf(s, "#%2x%2x%2x%c", &r, &g, &b, &tail) != 3 || !isxdigit((unsigned char)s[6]))
            return mts_fail(L, n, SPC_ERR_VALUE, "could not parse hex colour \"%s\" (expected #rrggbb)", value);
        *out = spc_rgb3(mts_srgb_to_linear(r / 255.0), mts_srgb_to_linear(g / 255.0), mts_srgb_to_linear(b / 255.0));
        return SPC_OK;
    }
    double v[3];
    char bad[128];
    int k = parse_list(value, v, 3, bad, sizeof bad);
    if (k < 0)
        return mts_fail(L, n, SPC_ERR_VALUE, "could not parse <%s> value \"%s\"", n->name, value);
    if (k == 1)
        v[1] = v[2] = v[0];
    else if (k != 3)
        return mts_fail(L, n, SPC_ERR_VALUE, "<%s> needs one or three values, got %d in \"%s\"", n->name, k, value);
    if (srgb)
        for (int c = 0; c < 3; ++c)
            v[c] = mts_srgb_to_linear(v[c]);
    *out = spc_rgb3(v[0], v[1], v[2]);
    return SPC_OK;
}

/* Appends a wavelength:value pair list; grows the arrays. */
static bool push_pair(double **wl, double **val, int *n, int *cap, double w, double v)
{
    if (*n == *cap) {
        int c = *cap ? 2 * *cap : 32;
        double *a = realloc(*wl, (size_t)c * sizeof *a);
        if (!a)
            return false;
        *wl = a;
        double *b = realloc(*val, (size_t)c * sizeof *b);
        if (!b)
            return false;
        *val = b;
        *cap = c;
    }
    (*wl)[*n] = w;
    (*val)[*n] = v;
    ++*n;
    return true;
}

static spc_status parse_spectrum(mts_loader *L, const spc_xml_node *n, spc_rgb *out, spc_rgb *out_emission)
{
    if (spc_xml_get(n, "type"))
        return mts_fail(L, n, SPC_ERR_PLUGIN, "unknown spectrum type '%s' (specula reads constant and sampled spectra)",
                        mts_type(n));
    const char *value = spc_xml_get(n, "value"), *fname = spc_xml_get(n, "filename");
    if (!value == !fname)
        return mts_fail(L, n, SPC_ERR_PARSE, "<spectrum> needs exactly one of the value and filename attributes");
    double *wl = NULL, *val = NULL;
    int cnt = 0, cap = 0;
    char *text = NULL;
    spc_status st = SPC_OK;
    if (value && !strchr(value, ':')) {
        double v[2];
        char bad[128];
        int k = parse_list(value, v, 1, bad, sizeof bad);
        if (k != 1)
            return mts_fail(L, n, SPC_ERR_VALUE,
                            "could not parse spectrum \"%s\" (expected one value or wavelength:value pairs)", value);
        *out = spc_rgb1(v[0]);
        *out_emission = mts_spectrum_to_rgb_emission(NULL, v, 1);
        return SPC_OK;
    }
    const char *src = value;
    if (fname) {
        char path[4096];
        if (!mts_resolve(L, n, fname, path, sizeof path))
            return mts_fail(L, n, SPC_ERR_IO, "spectrum file '%s' not found", fname);
        size_t len;
        spc_error sub;
        if (spc_xml_read_file(path, &text, &len, &sub) != SPC_OK)
            return mts_fail(L, n, sub.code, "cannot read spectrum file '%s'", path);
        src = text;
    }
    /* value: "w:v, w:v, ..."; file: lines "w v", '#' comments */
    const char *s = src;
    while (*s && st == SPC_OK) {
        while (*s && (isspace((unsigned char)*s) || *s == ','))
            ++s;
        if (!*s)
            break;
        if (*s == '#') {
            while (*s && *s != '\n')
                ++s;
            continue;
        }
        char *end;
        double w = strtod(s, &end);
        if (end == s) {
            st = mts_fail(L, n, SPC_ERR_VALUE, "could not parse spectrum near \"%.20s\"", s);
            break;
        }
        s = end;
        while (*s == ' ' || *s == '\t')
            ++s;
        if (*s == ':')
            ++s;
        double v = strtod(s, &end);
        if (end == s || !isfinite(w) || !isfinite(v)) {
            st = mts_fail(L, n, SPC_ERR_VALUE, "could not parse spectrum near \"%.20s\"", s);
            break;
        }
        s = end;
        if (cnt > 0 && !(w > wl[cnt - 1])) {
            st = mts_fail(L, n, SPC_ERR_VALUE, "spectrum wavelengths must increase (%g after %g)", w, wl[cnt - 1]);
            break;
        }
        if (!push_pair(&wl, &val, &cnt, &cap, w, v)) {
            st = mts_nomem(L, n);
            break;
        }
    }
    if (st == SPC_OK && cnt == 0)
        st = mts_fail(L, n, SPC_ERR_VALUE, "empty spectrum");
    if (st == SPC_OK) {
        *out = mts_spectrum_to_rgb(wl, val, cnt);
        *out_emission = mts_spectrum_to_rgb_emission(wl, val, cnt);
    }
    free(wl);
    free(val);
    free(text);
    return st;
}

/* ------------------------------------------------------------------------------------------------ */
/* properties */

static spc_status push_prop(mts_loader *L, mts_props *P, const mts_prop *p)
{
    mts_prop *np = realloc(P->p, (size_t)(P->n + 1) * sizeof *np);
    if (!np)
        return mts_nomem(L, p->node);
    P->p = np;
    P->p[P->n++] = *p;
    return SPC_OK;
}

/* A <default> inside a plugin element that names one of specula's own properties of that plugin
 * (mts_own_property_find): the property, with the default's value (Mitsuba 3 accepts the default
 * and ignores it). *p->name stays NULL for any other default. */
static spc_status own_default(mts_loader *L, const spc_xml_node *owner, const spc_xml_node *c, mts_prop *p)
{
    const char *name = spc_xml_get(c, "name"), *value = spc_xml_get(c, "value");
    const mts_own_property *o = name && value ? mts_own_property_find(owner->name, name) : NULL;
    if (!o)
        return SPC_OK;
    p->node = c;
    p->kind = o->kind;
    switch (o->kind) {
    case MTS_BOOL:
        if (strcasecmp(value, "true") == 0 || strcmp(value, "1") == 0)
            p->b = true;
        else if (!(strcasecmp(value, "false") == 0 || strcmp(value, "0") == 0))
            return mts_fail(L, c, SPC_ERR_VALUE, "could not parse boolean value \"%s\" of property '%s' (true or false)",
                            value, name);
        break;
    case MTS_INT: {
        char *end;
        errno = 0;
        p->i = strtoll(value, &end, 10);
        if (end == value || *end || errno)
            return mts_fail(L, c, SPC_ERR_VALUE, "could not parse integer value \"%s\" of property '%s'", value, name);
        p->f = (double)p->i;
        break;
    }
    case MTS_STRING: p->s = value; break;
    case MTS_FLOAT:
    case MTS_RGB:
    case MTS_POINT:
    case MTS_TRANSFORM:
    case MTS_OBJECT: return mts_fail(L, c, SPC_ERR_INTERNAL, "property '%s' has no <default> form", name);
    }
    p->name = name;
    return SPC_OK;
}

static spc_status collect(mts_loader *L, const spc_xml_node *owner, mts_props *P)
{
    for (int i = 0; i < owner->nchildren; ++i) {
        spc_xml_node *c = owner->children[i];
        const char *tag = c->name;
        if (strcmp(tag, "default") == 0 && strcmp(owner->name, "scene") != 0) {
            mts_prop p;
            memset(&p, 0, sizeof p);
            if (own_default(L, owner, c, &p) != SPC_OK)
                return L->status;
            if (p.name && push_prop(L, P, &p) != SPC_OK)
                return L->status;
            continue;
        }
        if (strcmp(tag, "default") == 0 || strcmp(tag, "path") == 0)
            continue;
        mts_prop p;
        memset(&p, 0, sizeof p);
        p.node = c;
        p.name = spc_xml_get(c, "name");
        bool is_object = mts_is_object_tag(tag) || (strcmp(tag, "spectrum") == 0 && spc_xml_get(c, "type"));
        if (is_object) {
            p.kind = MTS_OBJECT;
            p.obj = c;
        } else if (strcmp(tag, "ref") == 0) {
            const char *id;
            if (need_attr(L, c, "id", &id))
                return L->status;
            mts_id *e = mts_lookup_id(L, id);
            if (!e)
                return mts_fail(L, c, SPC_ERR_VALUE, "reference to unknown id '%s'", id);
            p.kind = MTS_OBJECT;
            p.obj = e->node;
        } else {
            if (!p.name)
                return mts_fail(L, c, SPC_ERR_PARSE, "<%s> needs a 'name' attribute", tag);
            const char *value = spc_xml_get(c, "value");
            if (strcmp(tag, "float") == 0) {
                p.kind = MTS_FLOAT;
                if (need_attr(L, c, "value", &value))
                    return L->status;
                if (!parse_double(value, &p.f))
                    return mts_fail(L, c, SPC_ERR_VALUE, "could not parse float value \"%s\" of property '%s'", value,
                                    p.name);
            } else if (strcmp(tag, "integer") == 0) {
                p.kind = MTS_INT;
                if (need_attr(L, c, "value", &value))
                    return L->status;
                char *end;
                errno = 0;
                p.i = strtoll(value, &end, 10);
                while (isspace((unsigned char)*end))
                    ++end;
                if (end == value || *end || errno)
                    return mts_fail(L, c, SPC_ERR_VALUE, "could not parse integer value \"%s\" of property '%s'",
                                    value, p.name);
                p.f = (double)p.i;
            } else if (strcmp(tag, "boolean") == 0) {
                p.kind = MTS_BOOL;
                if (need_attr(L, c, "value", &value))
                    return L->status;
                if (strcasecmp(value, "true") == 0 || strcmp(value, "1") == 0)
                    p.b = true;
                else if (strcasecmp(value, "false") == 0 || strcmp(value, "0") == 0)
                    p.b = false;
                else
                    return mts_fail(L, c, SPC_ERR_VALUE,
                                    "could not parse boolean value \"%s\" of property '%s' (true or false)", value,
                                    p.name);
            } else if (strcmp(tag, "string") == 0) {
                p.kind = MTS_STRING;
                if (need_attr(L, c, "value", &p.s))
                    return L->status;
            } else if (strcmp(tag, "rgb") == 0 || strcmp(tag, "srgb") == 0) {
                p.kind = MTS_RGB;
                if (parse_rgb(L, c, strcmp(tag, "srgb") == 0, &p.rgb))
                    return L->status;
            } else if (strcmp(tag, "spectrum") == 0) {
                p.kind = MTS_RGB;
                p.spectral = true;
                if (parse_spectrum(L, c, &p.rgb, &p.rgb_emission))
                    return L->status;
            } else if (strcmp(tag, "point") == 0 || strcmp(tag, "vector") == 0) {
                p.kind = MTS_POINT;
                if (parse_xyz(L, c, 0.0, &p.v))
                    return L->status;
            } else if (strcmp(tag, "transform") == 0) {
                p.kind = MTS_TRANSFORM;
                if (parse_transform(L, c, &p.m))
                    return L->status;
            } else if (strcmp(tag, "translate") == 0 || strcmp(tag, "scale") == 0 || strcmp(tag, "rotate") == 0 ||
                       strcmp(tag, "lookat") == 0 || strcmp(tag, "matrix") == 0) {
                return mts_fail(L, c, SPC_ERR_PARSE, "<%s> can only occur inside a <transform>", tag);
            } else if (strcmp(tag, "blackbody") == 0) {
                return mts_fail(L, c, SPC_ERR_PLUGIN, "blackbody spectra are not supported; give an <rgb> value");
            } else {
                return mts_fail(L, c, SPC_ERR_PARSE, "unexpected element <%s> in <%s>", tag, owner->name);
            }
        }
        if (p.name && p.kind != MTS_OBJECT) {
            for (int j = 0; j < P->n; ++j)
                if (P->p[j].name && strcmp(P->p[j].name, p.name) == 0)
                    return mts_fail(L, c, SPC_ERR_VALUE, "property '%s' is given twice (first at line %d)", p.name,
                                    P->p[j].node->line);
        }
        if (push_prop(L, P, &p))
            return L->status;
    }
    return SPC_OK;
}

spc_status mts_props_collect(mts_loader *L, const spc_xml_node *owner, mts_props *P)
{
    P->L = L;
    P->owner = owner;
    P->p = NULL;
    P->n = 0;
    if (collect(L, owner, P) != SPC_OK) {
        free(P->p);
        P->p = NULL;
        P->n = 0;
        return L->status;
    }
    return SPC_OK;
}

void mts_props_end(mts_props *P)
{
    for (int i = 0; i < P->n && P->L->status == SPC_OK; ++i) {
        const mts_prop *p = &P->p[i];
        if (p->used)
            continue;
        const char *type = mts_type(P->owner);
        if (p->kind == MTS_OBJECT)
            mts_warn(p->node, "unused nested <%s%s%s%s> in <%s type=\"%s\">: ignored", p->obj->name,
                     p->name ? " name=\"" : "", p->name ? p->name : "", p->name ? "\"" : "", P->owner->name, type);
        else if (P->L->lenient)
            mts_warn(p->node, "unreferenced property '%s' of <%s type=\"%s\">%s%s%s: ignored", p->name,
                     P->owner->name, type, p->closest[0] ? " (did you mean '" : "", p->closest,
                     p->closest[0] ? "'?)" : "");
        else
            mts_fail(P->L, p->node, SPC_ERR_VALUE,
                     "unreferenced property '%s' of <%s type=\"%s\">%s%s%s; -D " SPC_DEFINE_UNREFERENCED
                     "=warn (specula render --lenient) only warns",
                     p->name, P->owner->name, type, p->closest[0] ? " (did you mean '" : "", p->closest,
                     p->closest[0] ? "'?)" : "");
    }
    free(P->p);
    P->p = NULL;
    P->n = 0;
}

/* Levenshtein distance of two short names (longer ones count as far apart). */
static int edit_distance(const char *a, const char *b)
{
    enum { MAX = 47 };
    size_t na = strlen(a), nb = strlen(b);
    if (na > MAX || nb > MAX)
        return MAX + 1;
    int row[MAX + 1];
    for (size_t j = 0; j <= nb; ++j)
        row[j] = (int)j;
    for (size_t i = 1; i <= na; ++i) {
        int diag = row[0];
        row[0] = (int)i;
        for (size_t j = 1; j <= nb; ++j) {
            int up = row[j];
            int best = diag + (a[i - 1] != b[j - 1]);
            if (up + 1 < best)
                best = up + 1;
            if (row[j - 1] + 1 < best)
                best = row[j - 1] + 1;
            row[j] = best;
            diag = up;
        }
    }
    return row[nb];
}

mts_prop *mts_find(mts_props *P, const char *name)
{
    mts_prop *found = NULL;
    for (int i = 0; i < P->n; ++i) {
        mts_prop *p = &P->p[i];
        if (!p->name)
            continue;
        if (strcmp(p->name, name) == 0) {
            p->used = true;
            found = p;
        } else if (!p->used && p->kind != MTS_OBJECT && strlen(name) < sizeof p->closest) {
            /* a name is worth suggesting when at most a third of it (and at least 2 letters) differs */
            int d = edit_distance(p->name, name), n = (int)strlen(name);
            int limit = n / 3 > 2 ? n / 3 : 2;
            if (d <= limit && (!p->closest[0] || d < p->closest_distance)) {
                snprintf(p->closest, sizeof p->closest, "%s", name);
                p->closest_distance = d;
            }
        }
    }
    return found;
}

bool mts_has(const mts_props *P, const char *name)
{
    for (int i = 0; i < P->n; ++i)
        if (P->p[i].name && strcmp(P->p[i].name, name) == 0)
            return true;
    return false;
}

void mts_ignore(mts_props *P, const char *name) { (void)mts_find(P, name); }

const spc_xml_node *mts_where(const mts_props *P, const char *name)
{
    for (int i = 0; i < P->n; ++i)
        if (P->p[i].name && strcmp(P->p[i].name, name) == 0)
            return P->p[i].node;
    return P->owner;
}

spc_xml_node *mts_object(mts_props *P, const char *category, int k, const spc_xml_node **at)
{
    for (int i = 0; i < P->n; ++i) {
        mts_prop *p = &P->p[i];
        if (p->kind == MTS_OBJECT && strcmp(p->obj->name, category) == 0 && k-- == 0) {
            p->used = true;
            if (at)
                *at = p->node;
            return p->obj;
        }
    }
    return NULL;
}

int mts_count_objects(const mts_props *P, const char *category)
{
    int n = 0;
    for (int i = 0; i < P->n; ++i)
        if (P->p[i].kind == MTS_OBJECT && strcmp(P->p[i].obj->name, category) == 0)
            ++n;
    return n;
}

static const char *kind_name(mts_kind k)
{
    switch (k) {
    case MTS_BOOL: return "boolean";
    case MTS_INT: return "integer";
    case MTS_FLOAT: return "float";
    case MTS_STRING: return "string";
    case MTS_RGB: return "rgb";
    case MTS_POINT: return "point";
    case MTS_TRANSFORM: return "transform";
    case MTS_OBJECT: return "object";
    }
    return "?";
}

/* "a" or "an" before a word, by its first letter (every kind name here follows that rule) */
static const char *article(const char *word) { return strchr("aeiouAEIOU", word[0]) && word[0] ? "an" : "a"; }

static void wrong_kind(mts_loader *L, const mts_prop *p, const char *want)
{
    const char *got = p->kind == MTS_OBJECT ? p->obj->name : kind_name(p->kind);
    mts_fail(L, p->node, SPC_ERR_VALUE, "property '%s' must be %s %s, not %s %s", p->name, article(want), want,
             article(got), got);
}

double mts_get_float(mts_loader *L, mts_props *P, const char *name, double def)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return def;
    if (p->kind == MTS_FLOAT || p->kind == MTS_INT)
        return p->f;
    wrong_kind(L, p, "float");
    return def;
}

int mts_get_int(mts_loader *L, mts_props *P, const char *name, int def)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return def;
    if (p->kind == MTS_INT || (p->kind == MTS_FLOAT && p->f == floor(p->f))) {
        if (p->f >= (double)INT_MIN && p->f <= (double)INT_MAX)
            return (int)p->f;
        mts_fail(L, p->node, SPC_ERR_LIMIT, "property '%s': %.17g is out of range (%d to %d)", p->name, p->f, INT_MIN,
                 INT_MAX);
        return def;
    }
    if (p->kind == MTS_FLOAT)
        mts_fail(L, p->node, SPC_ERR_VALUE, "property '%s' must be an integer, not %.17g", p->name, p->f);
    else
        wrong_kind(L, p, "integer");
    return def;
}

bool mts_get_bool(mts_loader *L, mts_props *P, const char *name, bool def)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return def;
    if (p->kind == MTS_BOOL)
        return p->b;
    wrong_kind(L, p, "boolean");
    return def;
}

const char *mts_get_string(mts_loader *L, mts_props *P, const char *name, const char *def)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return def;
    if (p->kind == MTS_STRING)
        return p->s;
    wrong_kind(L, p, "string");
    return def;
}

spc_rgb mts_get_rgb(mts_loader *L, mts_props *P, const char *name, spc_rgb def)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return def;
    if (p->kind == MTS_RGB)
        return p->rgb;
    if (p->kind == MTS_FLOAT || p->kind == MTS_INT)
        return spc_rgb1(p->f);
    wrong_kind(L, p, "constant rgb or spectrum");
    return def;
}

spc_vec3 mts_get_point(mts_loader *L, mts_props *P, const char *name, spc_vec3 def)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return def;
    if (p->kind == MTS_POINT)
        return p->v;
    wrong_kind(L, p, "point");
    return def;
}

spc_mat4 mts_get_transform(mts_loader *L, mts_props *P, const char *name)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return spc_mat4_identity();
    if (p->kind == MTS_TRANSFORM)
        return p->m;
    wrong_kind(L, p, "transform");
    return spc_mat4_identity();
}

void mts_get_fov(mts_loader *L, mts_props *P, double *fov, spc_fov_axis *axis_out)
{
    if (mts_has(P, "fov") && mts_has(P, "focal_length")) {
        mts_fail(L, mts_where(P, "focal_length"), SPC_ERR_VALUE, "give either fov or focal_length, not both");
    } else if (mts_has(P, "fov")) {
        *fov = mts_get_float(L, P, "fov", 45.0);
        const char *axis = mts_get_string(L, P, "fov_axis", "x");
        static const struct {
            const char *name;
            spc_fov_axis axis;
        } axes[] = {{"x", SPC_FOV_X},
                    {"y", SPC_FOV_Y},
                    {"smaller", SPC_FOV_SMALLER},
                    {"larger", SPC_FOV_LARGER},
                    {"diagonal", SPC_FOV_DIAGONAL}};
        bool ok = false;
        for (size_t i = 0; i < sizeof axes / sizeof axes[0]; ++i) {
            if (strcasecmp(axis, axes[i].name) == 0) {
                *axis_out = axes[i].axis;
                ok = true;
            }
        }
        if (!ok)
            mts_fail(L, mts_where(P, "fov_axis"), SPC_ERR_VALUE,
                     "unknown fov_axis '%s' (x, y, smaller, larger, diagonal)", axis);
        if (L->status == SPC_OK && !(*fov > 0.0 && *fov < 180.0))
            mts_fail(L, mts_where(P, "fov"), SPC_ERR_VALUE, "fov %g must be in (0, 180) degrees", *fov);
    } else {
        /* Mitsuba: a focal length on a 36 x 24 mm film gives the diagonal field of view. */
        const char *fl = mts_get_string(L, P, "focal_length", "50mm");
        char buf[64];
        snprintf(buf, sizeof buf, "%s", fl);
        size_t n = strlen(buf);
        if (n > 2 && strcmp(buf + n - 2, "mm") == 0)
            buf[n - 2] = '\0';
        double f;
        if (!parse_double(buf, &f) || !(f > 0.0))
            mts_fail(L, mts_where(P, "focal_length"), SPC_ERR_VALUE,
                     "could not parse focal_length \"%s\" (expected e.g. \"50mm\")", fl);
        else {
            *fov = 2.0 * atan(sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2.0 * f)) * 180.0 / SPC_PI;
            *axis_out = SPC_FOV_DIAGONAL;
        }
    }
}

/* ------------------------------------------------------------------------------------------------ */
/* specula's own properties */

static const mts_own_property own_properties[] = {
    {"integrator", "specular_nee", MTS_STRING,
     "specular next-event estimation: auto, none, angular, newton, conic[:options]"},
    {"integrator", "specular_max_chain", MTS_INT, "longest chain of specular vertices specular NEE connects through"},
    {"integrator", "mis_balance", MTS_BOOL, "bdpt: the balance heuristic instead of the power heuristic"},
    {"shape", "caustic_caster", MTS_BOOL, "specular NEE: the shape casts caustics"},
    {"shape", "caustic_receiver", MTS_BOOL, "specular NEE: the shape receives caustics"},
    {"shape", "caustic_caster_single", MTS_BOOL, "specular NEE: a caster of single-bounce chains"},
    {"shape", "caustic_caster_multi", MTS_BOOL, "specular NEE: a caster of multi-bounce chains"},
};

const mts_own_property *mts_own_property_list(int *n)
{
    *n = (int)(sizeof own_properties / sizeof own_properties[0]);
    return own_properties;
}

const mts_own_property *mts_own_property_find(const char *category, const char *name)
{
    for (size_t i = 0; i < sizeof own_properties / sizeof own_properties[0]; ++i)
        if (strcmp(own_properties[i].category, category) == 0 && strcmp(own_properties[i].name, name) == 0)
            return &own_properties[i];
    return NULL;
}

/* ------------------------------------------------------------------------------------------------ */
/* the plugin registry the walk hands in (L->plugins) */

const mts_plugin *mts_plugin_find(const mts_loader *L, const char *category, const char *name)
{
    for (int i = 0; i < L->nplugins; ++i)
        if (strcmp(L->plugins[i].category, category) == 0 && strcmp(L->plugins[i].name, name) == 0)
            return &L->plugins[i];
    return NULL;
}

/* The names of a category the loader reads (every row not marked no), comma-separated, in buf. */
static void known_names(const mts_loader *L, const char *category, char *buf, size_t len)
{
    size_t used = 0;
    buf[0] = '\0';
    for (int i = 0; i < L->nplugins; ++i) {
        const mts_plugin *p = &L->plugins[i];
        if (strcmp(p->category, category) != 0 || p->status == MTS_PLUGIN_NO)
            continue;
        int n = snprintf(buf + used, len - used, "%s%s", used ? ", " : "", p->name);
        if (n < 0 || (size_t)n >= len - used)
            break;
        used += (size_t)n;
    }
}

spc_status mts_fail_plugin(mts_loader *L, const spc_xml_node *node, const char *category, const char *type)
{
    char known[1024];
    known_names(L, category, known, sizeof known);
    const mts_plugin *p = mts_plugin_find(L, category, type);
    if (p && p->status == MTS_PLUGIN_NO)
        return mts_fail(L, node, SPC_ERR_PLUGIN, "%s '%s' (a Mitsuba 3 plugin) is not supported by specula%s%s",
                        category, type, p->note[0] ? ": " : "", p->note);
    return mts_fail(L, node, SPC_ERR_PLUGIN, "unknown %s type '%s' (%s)", category, type, known);
}
