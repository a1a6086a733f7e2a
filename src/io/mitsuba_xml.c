/*
 * io/mitsuba_xml.c: loads a Mitsuba scene file (0.5/0.6, 2.x and 3.x) into a spc_scene.
 *
 * Two passes over the element tree (io/xml.h):
 *  1. preprocess, in document order: $name substitution in every attribute (the -D defines win
 *     over <default>, which only sets names not yet set; longer names match first, and a '$' left
 *     over is an error), <include> (spliced in place, each file keeping its own version), <path>,
 *     the 0.x dialect upgrade (camelCase names -> snake_case, lookAt -> lookat, diffuse's
 *     diffuse_reflectance -> reflectance, as Mitsuba 3's upgrade_tree does), and the id table.
 *  2. build, in document order: objects are made when met; a <ref> builds its target first if it
 *     was not built yet, so references may point forward. Objects with an id are built once.
 *
 * Scene-level plugins (sensor, film, rfilter, sampler) are read here, every other one by
 * its builder (mitsuba_builders.h), found in the plugin registry (mitsuba_plugin_list.c) that the
 * loader is handed; properties and their values are mitsuba_props.c's.
 *
 * XML (defaults as in Mitsuba 3):
 *   sensor      perspective | thinlens (aperture_radius, required; focus_distance far_clip) | orthographic:
 *               to_world, fov | focal_length ("50mm" when neither: 46.8 degrees along the
 *               diagonal), fov_axis (x | y | smaller | larger | diagonal), near_clip 0.01,
 *               far_clip 10000; nested film and sampler
 *   film        hdrfilm | ldrfilm: width 768, height 576, crop_offset_x/y 0, crop_width/height
 *               (rest of the film), rfilter (default gaussian)
 *   rfilter     box (radius 0.5), tent (radius 1), gaussian (stddev 0.5, radius 4 stddev);
 *               mitchell, catmullrom, lanczos become gaussian with a warning
 *   sampler     independent, stratified, multijitter, orthogonal, ldsampler, halton, hammersley,
 *               sobol: sample_count 4, seed 0 (specula has one sampler; the type is not kept)
 *   integrator  io/mitsuba_integrators.c
 */
#include "io/mitsuba_xml.h"

#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "core/hash.h"
#include "io/mitsuba_builders.h"
#include "io/mitsuba_plugin_list.h"
#include "io/mitsuba_props.h"

#define MTS_MAX_INCLUDE_DEPTH 15 /* Mitsuba 3's MI_XML_INCLUDE_MAX_RECURSION */
#define MAX_RESOLUTION 65536  /* film width/height beyond which a file is surely wrong */
#define MAX_SAMPLE_COUNT (1 << 24)

/* ------------------------------------------------------------------------------------------------ */
/* strings */

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

static char *dir_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return dup_str(".");
    if (slash == path)
        return dup_str("/");
    size_t n = (size_t)(slash - path);
    char *d = malloc(n + 1);
    if (d) {
        memcpy(d, path, n);
        d[n] = '\0';
    }
    return d;
}

/* ------------------------------------------------------------------------------------------------ */
/* parameters ($name) */

static mts_param *find_param(mts_loader *L, const char *name)
{
    for (int i = 0; i < L->nparams; ++i)
        if (strcmp(L->params[i].name, name) == 0)
            return &L->params[i];
    return NULL;
}

static bool add_param(mts_loader *L, const char *name, const char *value, bool from_define)
{
    if (L->nparams == L->cap_params) {
        int cap = L->cap_params ? 2 * L->cap_params : 16;
        mts_param *p = realloc(L->params, (size_t)cap * sizeof *p);
        if (!p)
            return false;
        L->params = p;
        L->cap_params = cap;
    }
    char *n = dup_str(name), *v = dup_str(value);
    if (!n || !v) {
        free(n);
        free(v);
        return false;
    }
    L->params[L->nparams++] = (mts_param){n, v, from_define, false, false};
    return true;
}

/* A -D that names no <default> and replaces no $name is a mistake (a typo, or a scene other than
 * the one meant): an error listing the scene's defaults, as Mitsuba 3 refuses it. Names starting
 * with '@' are specula's own settings. */
static spc_status check_defines(mts_loader *L, const spc_xml_node *root)
{
    for (int i = 0; i < L->nparams; ++i) {
        const mts_param *d = &L->params[i];
        if (!d->from_define || d->declared || d->used || d->name[0] == '@')
            continue;
        char list[512] = "";
        size_t n = 0;
        for (int k = 0; k < L->nparams && n < sizeof list; ++k)
            if (L->params[k].declared)
                n += (size_t)snprintf(list + n, sizeof list - n, "%s%s", n ? ", " : "", L->params[k].name);
        return mts_fail(L, root, SPC_ERR_VALUE, "-D %s=%s: the scene declares no <default name=\"%s\">; %s%s",
                                 d->name, d->value, d->name, n ? "its defaults are: " : "it declares no defaults",
                                 list);
    }
    return SPC_OK;
}

/* Replaces every $name in the node's attribute values. */
static spc_status substitute(mts_loader *L, spc_xml_node *node)
{
    for (int a = 0; a < node->nattrs; ++a) {
        const char *v = node->attrs[a].value;
        if (!strchr(v, '$'))
            continue;
        size_t cap = strlen(v) + 64, n = 0;
        char *out = malloc(cap);
        if (!out)
            return mts_nomem(L, node);
        for (const char *s = v; *s;) {
            const char *piece = s;
            size_t len = 1;
            if (*s == '$') {
                mts_param *best = NULL;
                size_t best_len = 0;
                for (int i = 0; i < L->nparams; ++i) {
                    size_t l = strlen(L->params[i].name);
                    if (l > best_len && strncmp(s + 1, L->params[i].name, l) == 0) {
                        best = &L->params[i];
                        best_len = l;
                    }
                }
                if (!best) {
                    free(out);
                    return mts_fail(L, node, SPC_ERR_VALUE,
                                    "undefined parameter in \"%s\" (attribute '%s' of <%s>): declare it with "
                                    "<default name=... value=...> or -D name=value",
                                    v, node->attrs[a].name, node->name);
                }
                best->used = true;
                piece = best->value;
                len = strlen(piece);
                s += 1 + best_len;
            } else {
                ++s;
            }
            if (n + len + 1 > cap) {
                cap = 2 * (n + len + 1);
                char *o = realloc(out, cap);
                if (!o) {
                    free(out);
                    return mts_nomem(L, node);
                }
                out = o;
            }
            memcpy(out + n, piece, len);
            n += len;
        }
        out[n] = '\0';
        free(node->attrs[a].value);
        node->attrs[a].value = out;
    }
    return SPC_OK;
}

/* ------------------------------------------------------------------------------------------------ */
/* dialects */

static int parse_version(const char *v, int *major)
{
    char *end;
    errno = 0;
    long m = strtol(v, &end, 10);
    if (end == v || errno || m < 0 || m > 100 || (*end != '.' && *end != '\0'))
        return 0;
    *major = (int)m;
    return 1;
}

/* Mitsuba 3's upgrade of 0.x names: "intIOR" -> "int_ior", "toWorld" -> "to_world". */
static bool camel_to_snake(const char *in, char *out, size_t size)
{
    size_t n = 0;
    for (size_t i = 0; in[i]; ++i) {
        if (n + 3 >= size)
            return false;
        unsigned char c = (unsigned char)in[i];
        if (isupper(c) && i > 0 && islower((unsigned char)in[i - 1])) {
            out[n++] = '_';
            out[n++] = (char)tolower(c);
            while (in[i + 1] && isupper((unsigned char)in[i + 1])) {
                if (n + 2 >= size)
                    return false;
                out[n++] = (char)tolower((unsigned char)in[++i]);
            }
        } else {
            out[n++] = (char)c;
        }
    }
    out[n] = '\0';
    return true;
}

static spc_status upgrade_v0(mts_loader *L, spc_xml_node *node)
{
    if (strcmp(node->name, "lookAt") == 0 && !spc_xml_rename(node, "lookat"))
        return mts_nomem(L, node);
    const char *name = spc_xml_get(node, "name");
    if (name && strcmp(node->name, "default") != 0) {
        char snake[256];
        if (camel_to_snake(name, snake, sizeof snake) && strcmp(snake, name) != 0 &&
            !spc_xml_set(node, "name", snake))
            return mts_nomem(L, node);
    }
    /* diffuse's diffuse_reflectance became reflectance */
    if (node->parent && strcmp(node->parent->name, "bsdf") == 0 && strcmp(mts_type(node->parent), "diffuse") == 0) {
        name = spc_xml_get(node, "name");
        if (name && strcmp(name, "diffuse_reflectance") == 0 && !spc_xml_set(node, "name", "reflectance"))
            return mts_nomem(L, node);
    }
    return SPC_OK;
}

/* ------------------------------------------------------------------------------------------------ */
/* ids */

static spc_status register_id(mts_loader *L, spc_xml_node *node, const char *id)
{
    if (L->nids == L->cap_ids) {
        int cap = L->cap_ids ? 2 * L->cap_ids : 64;
        mts_id *p = realloc(L->ids, (size_t)cap * sizeof *p);
        if (!p)
            return mts_nomem(L, node);
        L->ids = p;
        L->cap_ids = cap;
    }
    L->ids[L->nids] = (mts_id){id, node, NULL, 0, L->nids};
    ++L->nids;
    return SPC_OK;
}

static int cmp_id(const void *a, const void *b)
{
    const mts_id *x = a, *y = b;
    int c = strcmp(x->id, y->id);
    return c ? c : (x->seq > y->seq) - (x->seq < y->seq);
}

/* ------------------------------------------------------------------------------------------------ */
/* preprocessing */


static spc_status preprocess_children(mts_loader *L, spc_xml_node *node, int dialect, int depth);

static spc_status add_doc(mts_loader *L, const char *file, const char *dir, spc_xml_node *root, mts_doc **out)
{
    if (L->ndocs == L->cap_docs) {
        int cap = L->cap_docs ? 2 * L->cap_docs : 4;
        mts_doc *d = realloc(L->docs, (size_t)cap * sizeof *d);
        if (!d)
            return mts_nomem(L, NULL);
        L->docs = d;
        L->cap_docs = cap;
    }
    mts_doc *d = &L->docs[L->ndocs];
    d->file = dup_str(file);
    d->dir = dir ? dup_str(dir) : dir_of(file);
    d->root = root;
    if (!d->file || !d->dir) {
        free(d->file);
        free(d->dir);
        return mts_nomem(L, NULL);
    }
    ++L->ndocs;
    *out = d;
    return SPC_OK;
}

static spc_status do_include(mts_loader *L, spc_xml_node *parent, int i, int depth, int *count)
{
    spc_xml_node *inc = parent->children[i];
    *count = 0;
    const char *fname = spc_xml_get(inc, "filename");
    if (!fname)
        return mts_fail(L, inc, SPC_ERR_PARSE, "<include> needs a filename attribute");
    if (depth + 1 > MTS_MAX_INCLUDE_DEPTH)
        return mts_fail(L, inc, SPC_ERR_LIMIT, "<include> nested more than %d deep (a cycle?) at '%s'",
                        MTS_MAX_INCLUDE_DEPTH, fname);
    char path[4096];
    if (!mts_resolve(L, inc, fname, path, sizeof path))
        return mts_fail(L, inc, SPC_ERR_IO, "included file '%s' not found", fname);
    char *text;
    size_t len;
    spc_error sub;
    spc_status st = spc_xml_read_file(path, &text, &len, &sub);
    if (st != SPC_OK)
        return mts_fail(L, inc, st, "cannot read included file '%s': %s", path, sub.msg);
    mts_doc *doc;
    if (add_doc(L, path, NULL, NULL, &doc) != SPC_OK) {
        free(text);
        return L->status;
    }
    int doc_index = (int)(doc - L->docs); /* L->docs may move while nested files are added */
    spc_xml_node *root;
    st = spc_xml_parse(text, len, doc->file, &root, L->err);
    free(text);
    if (st != SPC_OK) {
        L->status = st;
        return st;
    }
    doc->root = root;
    if (strcmp(root->name, "include") == 0)
        return mts_fail(L, root, SPC_ERR_PARSE, "an included file cannot consist of an <include>");
    int dialect = mts_dialect(inc);
    const char *ver = spc_xml_get(root, "version");
    if (ver && !parse_version(ver, &dialect))
        return mts_fail(L, root, SPC_ERR_VALUE, "cannot parse version number \"%s\"", ver);
    if (strcmp(root->name, "scene") == 0) {
        root->user = dialect;
        if (preprocess_children(L, root, dialect, depth + 1) != SPC_OK)
            return L->status;
        *count = root->nchildren;
        if (!spc_xml_splice(parent, i, root))
            return mts_nomem(L, inc);
    } else {
        /* A file holding one object: it takes the place of the include. */
        spc_xml_node holder = {0};
        spc_xml_node *kids[1] = {root};
        holder.children = kids;
        holder.nchildren = holder.cap_children = 1;
        if (preprocess_children(L, &holder, dialect, depth + 1) != SPC_OK)
            return L->status;
        *count = holder.nchildren;
        if (!spc_xml_splice(parent, i, &holder))
            return mts_nomem(L, inc);
        L->docs[doc_index].root = NULL; /* now owned by the main tree */
    }
    return SPC_OK;
}

static spc_status preprocess_node(mts_loader *L, spc_xml_node *node, int dialect, int depth)
{
    if (substitute(L, node) != SPC_OK)
        return L->status;
    node->user = dialect;
    if (dialect < 2 && upgrade_v0(L, node) != SPC_OK)
        return L->status;
    if (strcmp(node->name, "default") == 0) {
        const char *name = spc_xml_get(node, "name"), *value = spc_xml_get(node, "value");
        if (!name || !name[0] || !value)
            return mts_fail(L, node, SPC_ERR_PARSE, "<default> needs non-empty name and value attributes");
        mts_param *known = find_param(L, name);
        if (!known && !add_param(L, name, value, false))
            return mts_nomem(L, node);
        (known ? known : &L->params[L->nparams - 1])->declared = true;
        return SPC_OK;
    }
    if (strcmp(node->name, "path") == 0) {
        const char *value = spc_xml_get(node, "value");
        if (!value)
            return mts_fail(L, node, SPC_ERR_PARSE, "<path> needs a value attribute");
        char buf[4096];
        const char *dir = mts_resolve_dir(L, node, value, buf, sizeof buf);
        if (!dir)
            return mts_fail(L, node, SPC_ERR_IO, "<path>: folder '%s' not found", value);
        char **d = realloc(L->dirs, (size_t)(L->ndirs + 1) * sizeof *d);
        if (!d)
            return mts_nomem(L, node);
        L->dirs = d;
        if (!(L->dirs[L->ndirs] = dup_str(dir)))
            return mts_nomem(L, node);
        ++L->ndirs;
        return SPC_OK;
    }
    const char *id = spc_xml_get(node, "id");
    if (id && mts_is_object_tag(node->name) && register_id(L, node, id) != SPC_OK)
        return L->status;
    if (strcmp(node->name, "alias") == 0) {
        const char *from = spc_xml_get(node, "id"), *as = spc_xml_get(node, "as");
        if (!from || !as)
            return mts_fail(L, node, SPC_ERR_PARSE, "<alias> needs id and as attributes");
    }
    return preprocess_children(L, node, dialect, depth);
}

static spc_status preprocess_children(mts_loader *L, spc_xml_node *node, int dialect, int depth)
{
    for (int i = 0; i < node->nchildren; ++i) {
        spc_xml_node *c = node->children[i];
        if (strcmp(c->name, "include") == 0) {
            c->user = dialect;
            if (substitute(L, c) != SPC_OK)
                return L->status;
            int count;
            if (do_include(L, node, i, depth, &count) != SPC_OK)
                return L->status;
            i += count - 1;
            continue;
        }
        if (preprocess_node(L, c, dialect, depth) != SPC_OK)
            return L->status;
    }
    return SPC_OK;
}

/* Sorts the id table, refuses duplicates, adds aliases. */
static spc_status finish_ids(mts_loader *L, spc_xml_node *root)
{
    if (L->nids > 1)
        qsort(L->ids, (size_t)L->nids, sizeof *L->ids, cmp_id);
    for (int i = 1; i < L->nids; ++i) {
        if (strcmp(L->ids[i].id, L->ids[i - 1].id) == 0) {
            const spc_xml_node *a = L->ids[i - 1].node, *b = L->ids[i].node;
            if (b->line < a->line && a->file == b->file) {
                const spc_xml_node *t = a;
                a = b;
                b = t;
            }
            return mts_fail(L, b, SPC_ERR_VALUE, "duplicate id '%s' (first declared at %s:%d:%d)", L->ids[i].id,
                            a->file, a->line, a->col);
        }
    }
    /* <alias id="a" as="b"/> at the top level */
    int added = 0;
    for (int i = 0; i < root->nchildren; ++i) {
        spc_xml_node *c = root->children[i];
        if (strcmp(c->name, "alias") != 0)
            continue;
        mts_id *target = mts_lookup_id(L, spc_xml_get(c, "id"));
        if (!target)
            return mts_fail(L, c, SPC_ERR_VALUE, "<alias>: unknown id '%s'", spc_xml_get(c, "id"));
        if (mts_lookup_id(L, spc_xml_get(c, "as")))
            return mts_fail(L, c, SPC_ERR_VALUE, "<alias>: id '%s' is already used", spc_xml_get(c, "as"));
        if (register_id(L, target->node, spc_xml_get(c, "as")) != SPC_OK)
            return L->status;
        ++added;
    }
    if (added)
        qsort(L->ids, (size_t)L->nids, sizeof *L->ids, cmp_id);
    return SPC_OK;
}

/* ------------------------------------------------------------------------------------------------ */
/* sensor, film, sampler, rfilter */

/* The registry's row of a plugin the loader reads, or NULL (unknown, or marked not read). */
static const mts_plugin *read_row(const mts_loader *L, const char *category, const char *type)
{
    const mts_plugin *row = mts_plugin_find(L, category, type);
    return row && row->status != MTS_PLUGIN_NO ? row : NULL;
}

static void parse_rfilter(mts_loader *L, spc_xml_node *node, spc_film_spec *film)
{
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return;
    const char *type = mts_type(node);
    const mts_plugin *row = read_row(L, "rfilter", type);
    if (strcmp(type, "box") == 0) {
        film->rfilter = SPC_RFILTER_BOX;
        film->filter_radius = mts_get_float(L, &P, "radius", 0.5);
    } else if (strcmp(type, "tent") == 0) {
        film->rfilter = SPC_RFILTER_TENT;
        film->filter_radius = mts_get_float(L, &P, "radius", 1.0);
    } else if (strcmp(type, "gaussian") == 0) {
        film->rfilter = SPC_RFILTER_GAUSSIAN;
        film->filter_stddev = mts_get_float(L, &P, "stddev", 0.5);
        film->filter_radius = 4.0 * film->filter_stddev;
    } else if (row && row->status == MTS_PLUGIN_STANDIN) {
        mts_warn(node, "rfilter '%s' is not supported: using gaussian (stddev 0.5)", type);
        for (int i = 0; i < P.n; ++i)
            P.p[i].used = true;
        film->rfilter = SPC_RFILTER_GAUSSIAN;
        film->filter_stddev = 0.5;
        film->filter_radius = 2.0;
    } else {
        mts_fail_plugin(L, node, "rfilter", type);
    }
    if (L->status == SPC_OK && !(film->filter_radius > 0.0))
        mts_fail(L, node, SPC_ERR_VALUE, "rfilter '%s': radius must be positive", type);
    mts_props_end(&P);
}

static void parse_film(mts_loader *L, spc_xml_node *node, spc_film_spec *film)
{
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return;
    const char *type = mts_type(node);
    if (!read_row(L, "film", type)) {
        mts_fail_plugin(L, node, "film", type);
        mts_props_end(&P);
        return;
    }
    /* output format choices: the command line decides what is written */
    static const char *ignored[] = {"file_format", "pixel_format", "component_format", "banner",
                                    "high_quality_edges", "attach_log", "compensate", "sample_border",
                                    "tonemap_method", "gamma", "exposure", "key", "burn", "dithering"};
    for (size_t i = 0; i < sizeof ignored / sizeof ignored[0]; ++i)
        mts_ignore(&P, ignored[i]);
    int w = mts_get_int(L, &P, "width", 768), h = mts_get_int(L, &P, "height", 576);
    if (L->status == SPC_OK && (w <= 0 || h <= 0))
        mts_fail(L, node, SPC_ERR_VALUE, "film size %d x %d must be positive", w, h);
    else if (L->status == SPC_OK && (w > MAX_RESOLUTION || h > MAX_RESOLUTION))
        mts_fail(L, node, SPC_ERR_LIMIT, "film size %d x %d exceeds %d", w, h, MAX_RESOLUTION);
    film->width = w;
    film->height = h;
    bool crop = mts_has(&P, "crop_offset_x") || mts_has(&P, "crop_offset_y") || mts_has(&P, "crop_width") ||
                mts_has(&P, "crop_height");
    int cx = mts_get_int(L, &P, "crop_offset_x", 0), cy = mts_get_int(L, &P, "crop_offset_y", 0);
    int cw = mts_get_int(L, &P, "crop_width", w - cx), ch = mts_get_int(L, &P, "crop_height", h - cy);
    if (crop && L->status == SPC_OK) {
        if (cx < 0 || cy < 0 || cw <= 0 || ch <= 0 || cx + cw > w || cy + ch > h)
            mts_fail(L, node, SPC_ERR_VALUE, "crop window %d,%d %dx%d does not fit the %dx%d film", cx, cy, cw, ch, w,
                     h);
        film->crop_x = cx;
        film->crop_y = cy;
        film->crop_w = cw;
        film->crop_h = ch;
    } else {
        film->crop_x = film->crop_y = film->crop_w = film->crop_h = 0;
    }
    film->rfilter = SPC_RFILTER_GAUSSIAN;
    film->filter_stddev = 0.5;
    film->filter_radius = 2.0;
    spc_xml_node *rf = mts_object(&P, "rfilter", 0, NULL);
    if (rf && L->status == SPC_OK)
        parse_rfilter(L, rf, film);
    mts_props_end(&P);
}

static void parse_sampler(mts_loader *L, spc_xml_node *node)
{
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return;
    const char *type = mts_type(node);
    if (!read_row(L, "sampler", type)) {
        mts_fail_plugin(L, node, "sampler", type);
        mts_props_end(&P);
        return;
    }
    static const char *ignored[] = {"jitter", "scramble", "dimension", "strength"};
    for (size_t i = 0; i < sizeof ignored / sizeof ignored[0]; ++i)
        mts_ignore(&P, ignored[i]);
    int spp = mts_get_int(L, &P, "sample_count", 4);
    int seed = mts_get_int(L, &P, "seed", 0);
    if (L->status == SPC_OK && spp < 1)
        mts_fail(L, mts_where(&P, "sample_count"), SPC_ERR_VALUE, "sample_count %d must be at least 1", spp);
    else if (L->status == SPC_OK && spp > MAX_SAMPLE_COUNT)
        mts_fail(L, mts_where(&P, "sample_count"), SPC_ERR_LIMIT, "sample_count %d exceeds %d", spp,
                 MAX_SAMPLE_COUNT);
    else if (L->status == SPC_OK && seed < 0)
        mts_fail(L, mts_where(&P, "seed"), SPC_ERR_VALUE, "seed %d must not be negative", seed);
    L->scene->spp = spp;
    L->scene->seed = (uint64_t)seed;
    mts_props_end(&P);
}

static void parse_sensor(mts_loader *L, spc_xml_node *node)
{
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return;
    spc_scene *s = L->scene;
    spc_camera *cam = &s->camera;
    const char *type = mts_type(node);
    bool persp = strcmp(type, "perspective") == 0, thin = strcmp(type, "thinlens") == 0;
    if (persp || thin) {
        cam->type = SPC_CAMERA_PERSPECTIVE;
    } else if (strcmp(type, "orthographic") == 0) {
        cam->type = SPC_CAMERA_ORTHOGRAPHIC;
    } else {
        mts_fail_plugin(L, node, "sensor", type);
        mts_props_end(&P);
        return;
    }
    mts_ignore(&P, "shutter_open");
    mts_ignore(&P, "shutter_close");
    cam->to_world = mts_get_transform(L, &P, "to_world");
    cam->near_clip = mts_get_float(L, &P, "near_clip", 0.01);
    cam->far_clip = mts_get_float(L, &P, "far_clip", 10000.0);
    cam->aperture_radius = 0.0;
    if (thin) {
        /* Mitsuba 3: aperture_radius is required (0 becomes a tiny lens), focus_distance defaults
         * to far_clip */
        if (L->status == SPC_OK && !mts_has(&P, "aperture_radius"))
            mts_fail(L, node, SPC_ERR_VALUE, "sensor 'thinlens' needs an aperture_radius");
        cam->aperture_radius = mts_get_float(L, &P, "aperture_radius", 0.0);
        cam->focus_distance = mts_get_float(L, &P, "focus_distance", cam->far_clip);
        if (L->status == SPC_OK && !(cam->aperture_radius >= 0.0 && isfinite(cam->aperture_radius)))
            mts_fail(L, mts_where(&P, "aperture_radius"), SPC_ERR_VALUE, "aperture_radius %g must be >= 0",
                     cam->aperture_radius);
        if (L->status == SPC_OK && !(cam->focus_distance > 0.0 && isfinite(cam->focus_distance)))
            mts_fail(L, mts_where(&P, "focus_distance"), SPC_ERR_VALUE, "focus_distance %g must be > 0",
                     cam->focus_distance);
        if (cam->aperture_radius == 0.0)
            cam->aperture_radius = 1e-7; /* Mitsuba's "zero aperture": a float epsilon */
    } else {
        /* Mitsuba's perspective sensor accepts focus_distance too (it only matters for a lens) */
        mts_ignore(&P, "focus_distance");
    }
    if (L->status == SPC_OK && !(cam->near_clip > 0.0 && cam->far_clip > cam->near_clip))
        mts_fail(L, node, SPC_ERR_VALUE, "need 0 < near_clip < far_clip (got %g, %g)", cam->near_clip, cam->far_clip);
    if (cam->type == SPC_CAMERA_PERSPECTIVE)
        mts_get_fov(L, &P, &cam->fov, &cam->fov_axis);
    spc_film_spec *film = &s->film;
    film->width = 768;
    film->height = 576;
    film->crop_x = film->crop_y = film->crop_w = film->crop_h = 0;
    film->rfilter = SPC_RFILTER_GAUSSIAN;
    film->filter_stddev = 0.5;
    film->filter_radius = 2.0;
    s->spp = 4;
    spc_xml_node *f = mts_object(&P, "film", 0, NULL);
    if (f && L->status == SPC_OK)
        parse_film(L, f, film);
    spc_xml_node *smp = mts_object(&P, "sampler", 0, NULL);
    if (smp && L->status == SPC_OK)
        parse_sampler(L, smp);
    spc_xml_node *med = mts_object(&P, "medium", 0, NULL); /* the camera's medium */
    if (med && L->status == SPC_OK)
        s->camera_medium = mts_build_medium(L, med);
    mts_props_end(&P);
}

/* ------------------------------------------------------------------------------------------------ */
/* the scene */

/* The scene's own property: Embree's watertight triangle test (spc_scene.accel_robust). Mitsuba 3
 * reads it with the default false; specula's default is true. */
#define SCENE_PROP_ROBUST "embree_use_robust_intersections"

/* A <boolean> at the top level of the scene: true/1 or false/0 (any case), as in objects. */
static void read_scene_bool(mts_loader *L, const spc_xml_node *c, bool *out)
{
    const char *v = spc_xml_get(c, "value");
    if (!v)
        mts_fail(L, c, SPC_ERR_PARSE, "<boolean name=\"%s\"> needs a 'value' attribute", spc_xml_get(c, "name"));
    else if (strcasecmp(v, "true") == 0 || strcmp(v, "1") == 0)
        *out = true;
    else if (strcasecmp(v, "false") == 0 || strcmp(v, "0") == 0)
        *out = false;
    else
        mts_fail(L, c, SPC_ERR_VALUE, "could not parse boolean value \"%s\" of property '%s' (true or false)", v,
                 spc_xml_get(c, "name"));
}

static void build_scene(mts_loader *L, spc_xml_node *root)
{
    for (int i = 0; i < root->nchildren && L->status == SPC_OK; ++i) {
        spc_xml_node *c = root->children[i];
        const char *t = c->name;
        if (strcmp(t, "default") == 0 || strcmp(t, "path") == 0 || strcmp(t, "alias") == 0) {
            continue;
        } else if (strcmp(t, "integrator") == 0) {
            if (L->have_integrator)
                mts_fail(L, c, SPC_ERR_VALUE, "more than one <integrator>");
            else
                mts_build_integrator(L, c, 0);
            L->have_integrator = true;
        } else if (strcmp(t, "sensor") == 0) {
            if (L->have_sensor)
                mts_warn(c, "only the first <sensor> is used; this one is ignored");
            else
                parse_sensor(L, c);
            L->have_sensor = true;
        } else if (strcmp(t, "shape") == 0) {
            mts_build_shape(L, c, NULL, false);
        } else if (strcmp(t, "bsdf") == 0) {
            mts_build_bsdf(L, c);
        } else if (strcmp(t, "texture") == 0) {
            mts_build_texture(L, c);
        } else if (strcmp(t, "emitter") == 0) {
            /* an area emitter with an id is built by each shape that refers to it (<ref id=.../>);
             * one no shape refers to emits nothing, as in Mitsuba 3 */
            if (!(strcmp(mts_type(c), "area") == 0 && spc_xml_get(c, "id")))
                mts_build_emitter(L, c, NULL, -1);
        } else if (strcmp(t, "sampler") == 0 || strcmp(t, "film") == 0 || strcmp(t, "rfilter") == 0) {
            /* read where a sensor (or film) refers to it by id; unreferenced, it does nothing, as
             * in Mitsuba 3 */
            if (!spc_xml_get(c, "id"))
                mts_warn(c, "<%s> at the top level without an id: no sensor can use it; ignored", t);
        } else if (strcmp(t, "medium") == 0) {
            mts_build_medium(L, c); /* mitsuba_media.c */
        } else if (strcmp(t, "phase") == 0) {
            spc_phase unused;
            mts_build_phase(L, c, &unused); /* checked here, built where a medium refers to it */
        } else if (strcmp(t, "volume") == 0) {
            mts_fail(L, c, SPC_ERR_PLUGIN, "<%s type=\"%s\">: heterogeneous media are not supported", t, mts_type(c));
        } else if (strcmp(t, "boolean") == 0 && spc_xml_get(c, "name") &&
                   strcmp(spc_xml_get(c, "name"), SCENE_PROP_ROBUST) == 0) {
            read_scene_bool(L, c, &L->scene->accel_robust);
        } else {
            mts_fail(L, c, SPC_ERR_PARSE, "unexpected <%s> at the top level of the scene", t);
        }
    }
}

static void loader_release(mts_loader *L)
{
    for (int i = 0; i < L->nparams; ++i) {
        free(L->params[i].name);
        free(L->params[i].value);
    }
    free(L->params);
    for (int i = 0; i < L->ndirs; ++i)
        free(L->dirs[i]);
    free(L->dirs);
    /* Trees first (the main one holds spliced nodes whose file names live in later docs). */
    for (int i = 0; i < L->ndocs; ++i)
        spc_xml_free(L->docs[i].root);
    for (int i = 0; i < L->ndocs; ++i) {
        free(L->docs[i].file);
        free(L->docs[i].dir);
    }
    free(L->docs);
    free(L->ids);
    mts_mesh_cache_release(L);
    free(L->base_dir);
}

static spc_status load(const char *xml, size_t len, const char *name, const char *dir, const spc_define *defs,
                       int ndefs, spc_scene **out, spc_error *err)
{
    *out = NULL;
    mts_loader L;
    memset(&L, 0, sizeof L);
    L.err = err;
    L.plugins = mts_plugin_list(&L.nplugins);
    L.files_hash = SPC_FNV_OFFSET;
    L.base_dir = dup_str(dir ? dir : ".");
    mts_doc *doc = NULL;
    if (!L.base_dir) {
        mts_nomem(&L, NULL);
        goto done;
    }
    for (int i = 0; i < ndefs; ++i) {
        if (!defs[i].name || !defs[i].value || !defs[i].name[0]) {
            mts_fail(&L, NULL, SPC_ERR_VALUE, "-D define %d has no name or value", i);
            goto done;
        }
        mts_param *p = find_param(&L, defs[i].name);
        if (p) { /* a later -D of the same name wins */
            char *v = dup_str(defs[i].value);
            if (!v) {
                mts_nomem(&L, NULL);
                goto done;
            }
            free(p->value);
            p->value = v;
        } else if (!add_param(&L, defs[i].name, defs[i].value, true)) {
            mts_nomem(&L, NULL);
            goto done;
        }
    }
    const mts_param *ov = find_param(&L, SPC_MITSUBA_INTEGRATOR_DEFINE);
    L.integrator_override = ov ? ov->value : NULL;
    const mts_param *unref = find_param(&L, SPC_DEFINE_UNREFERENCED);
    if (unref && strcmp(unref->value, "warn") != 0 && strcmp(unref->value, "error") != 0) {
        mts_fail(&L, NULL, SPC_ERR_VALUE, "-D " SPC_DEFINE_UNREFERENCED "=%s: the value must be warn or error",
                 unref->value);
        goto done;
    }
    L.lenient = unref && strcmp(unref->value, "warn") == 0;
    if (add_doc(&L, name, L.base_dir, NULL, &doc) != SPC_OK)
        goto done;
    spc_xml_node *root;
    spc_status st = spc_xml_parse(xml, len, doc->file, &root, err);
    if (st != SPC_OK) {
        L.status = st;
        goto done;
    }
    doc->root = root;
    if (strcmp(root->name, "scene") != 0) {
        mts_fail(&L, root, SPC_ERR_PARSE, "the root element must be <scene>, not <%s>", root->name);
        goto done;
    }
    int dialect = 3;
    const char *ver = spc_xml_get(root, "version");
    if (!ver)
        mts_warn(root, "<scene> has no version attribute: reading it as Mitsuba 3");
    else if (!parse_version(ver, &dialect)) {
        mts_fail(&L, root, SPC_ERR_VALUE, "cannot parse version number \"%s\"", ver);
        goto done;
    }
    root->user = dialect;
    if (preprocess_children(&L, root, dialect, 0) != SPC_OK || finish_ids(&L, root) != SPC_OK ||
        check_defines(&L, root) != SPC_OK)
        goto done;

    L.scene = spc_scene_create();
    if (!L.scene) {
        mts_nomem(&L, NULL);
        goto done;
    }
    spc_scene_set_defaults(L.scene);
    spc_integrator_spec *it = &L.scene->integrator;
    snprintf(it->type, sizeof it->type, "path");
    it->max_depth = -1;
    it->rr_depth = 5;
    it->hide_emitters = false;
    snprintf(L.scene->path, sizeof L.scene->path, "%s", name);
    build_scene(&L, root);
    L.scene->files_hash = L.files_hash;
    if (L.status == SPC_OK) {
        st = spc_scene_finalize(L.scene, err);
        if (st != SPC_OK)
            L.status = st;
    }
done:
    if (L.status != SPC_OK) {
        spc_scene_destroy(L.scene);
        L.scene = NULL;
    }
    loader_release(&L);
    *out = L.scene;
    return L.status;
}

spc_status spc_mitsuba_load_string(const char *xml, size_t len, const char *name, const char *base_dir,
                                   const spc_define *defs, int ndefs, spc_scene **out, spc_error *err)
{
    return load(xml, len, name ? name : "<string>", base_dir, defs, ndefs, out, err);
}

spc_status spc_mitsuba_load(const char *path, const spc_define *defs, int ndefs, spc_scene **out, spc_error *err)
{
    *out = NULL;
    char *text;
    size_t len;
    spc_status st = spc_xml_read_file(path, &text, &len, err);
    if (st != SPC_OK)
        return st;
    char *dir = dir_of(path);
    if (!dir) {
        free(text);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    }
    st = load(text, len, path, dir, defs, ndefs, out, err);
    free(dir);
    free(text);
    return st;
}
