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
 * Scene-level plugins handled here; shapes, BSDFs, textures and emitters in mitsuba_plugins.c.
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
 *   integrator  path, prb (-> path), volpath, volpathmis (-> volpath), direct (-> path, max_depth
 *               2), bdpt, ipt, ptracer: max_depth -1, rr_depth 5, hide_emitters false, specular_nee ("" or auto:
 *               chosen from the scene, manifold/snee_plan.h; none or off; angular | newton | conic,
 *               optionally with options as "newton:biased=8,rough": the grammar of
 *               manifold/snee_options.h), specular_max_chain, mis_balance (false; bdpt: the balance
 *               heuristic instead of the power heuristic); aov, moment, stokes: the nested integrator.
 *               The define "@integrator" replaces the file's integrator type (its properties are
 *               still read), so that a scene made for another renderer's integrator can load.
 */
#include "io/mitsuba_xml.h"

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
#include "io/mitsuba_internal.h"
#include "manifold/snee_options.h"

#define MAX_RESOLUTION 65536  /* film width/height beyond which a file is surely wrong */
#define MAX_SAMPLE_COUNT (1 << 24)

/* ------------------------------------------------------------------------------------------------ */
/* errors, warnings, small helpers */

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

static spc_status nomem(mts_loader *L, const spc_xml_node *at)
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
            return nomem(L, node);
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
                    return nomem(L, node);
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
        return nomem(L, node);
    const char *name = spc_xml_get(node, "name");
    if (name && strcmp(node->name, "default") != 0) {
        char snake[256];
        if (camel_to_snake(name, snake, sizeof snake) && strcmp(snake, name) != 0 &&
            !spc_xml_set(node, "name", snake))
            return nomem(L, node);
    }
    /* diffuse's diffuse_reflectance became reflectance */
    if (node->parent && strcmp(node->parent->name, "bsdf") == 0 && strcmp(mts_type(node->parent), "diffuse") == 0) {
        name = spc_xml_get(node, "name");
        if (name && strcmp(name, "diffuse_reflectance") == 0 && !spc_xml_set(node, "name", "reflectance"))
            return nomem(L, node);
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
            return nomem(L, node);
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

/* ------------------------------------------------------------------------------------------------ */
/* preprocessing */

static bool is_object_tag(const char *t)
{
    static const char *tags[] = {"bsdf",   "texture",    "shape",  "emitter", "sensor", "film",
                                 "sampler", "rfilter", "integrator", "medium", "phase",   "volume",
                                 "sdf"};
    for (size_t i = 0; i < sizeof tags / sizeof tags[0]; ++i)
        if (strcmp(t, tags[i]) == 0)
            return true;
    return false;
}

static spc_status preprocess_children(mts_loader *L, spc_xml_node *node, int dialect, int depth);

static spc_status add_doc(mts_loader *L, const char *file, const char *dir, spc_xml_node *root, mts_doc **out)
{
    if (L->ndocs == L->cap_docs) {
        int cap = L->cap_docs ? 2 * L->cap_docs : 4;
        mts_doc *d = realloc(L->docs, (size_t)cap * sizeof *d);
        if (!d)
            return nomem(L, NULL);
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
        return nomem(L, NULL);
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
            return nomem(L, inc);
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
            return nomem(L, inc);
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
            return nomem(L, node);
        (known ? known : &L->params[L->nparams - 1])->declared = true;
        return SPC_OK;
    }
    if (strcmp(node->name, "path") == 0) {
        const char *value = spc_xml_get(node, "value");
        if (!value)
            return mts_fail(L, node, SPC_ERR_PARSE, "<path> needs a value attribute");
        char buf[4096];
        const char *dir = value;
        if (value[0] != '/' && join_path(buf, sizeof buf, doc_dir(L, node), value) && is_dir(buf))
            dir = buf;
        /* else, as Mitsuba 3's file resolver: relative to the main file's folder or a folder named
         * before (an included file's path written relative to the scene that includes it) */
        if (value[0] != '/' && !is_dir(dir) && join_path(buf, sizeof buf, L->base_dir, value) && is_dir(buf))
            dir = buf;
        for (int i = L->ndirs - 1; i >= 0 && value[0] != '/' && !is_dir(dir); --i)
            if (join_path(buf, sizeof buf, L->dirs[i], value) && is_dir(buf))
                dir = buf;
        if (!is_dir(dir))
            return mts_fail(L, node, SPC_ERR_IO, "<path>: folder '%s' not found", value);
        char **d = realloc(L->dirs, (size_t)(L->ndirs + 1) * sizeof *d);
        if (!d)
            return nomem(L, node);
        L->dirs = d;
        if (!(L->dirs[L->ndirs] = dup_str(dir)))
            return nomem(L, node);
        ++L->ndirs;
        return SPC_OK;
    }
    const char *id = spc_xml_get(node, "id");
    if (id && is_object_tag(node->name) && register_id(L, node, id) != SPC_OK)
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

/* Mitsuba 3's <rotate>: Rodrigues' matrix with the axis as written, not normalized (Mitsuba 3
 * builds it with drjit's rotate, which does not normalize), so an axis such as (0, 1, 1) rotates
 * and also stretches; the same scene must give the same geometry in both renderers. For a unit
 * axis this is the rotation of spc_mat4_rotate. */
static spc_mat4 mitsuba_rotate(spc_vec3 a, double degrees)
{
    double th = degrees * SPC_PI / 180.0;
    double c = cos(th), s = sin(th), ic = 1.0 - c;
    spc_mat4 r = spc_mat4_identity();
    r.m[0][0] = a.x * a.x * ic + c;
    r.m[0][1] = a.x * a.y * ic - a.z * s;
    r.m[0][2] = a.x * a.z * ic + a.y * s;
    r.m[1][0] = a.y * a.x * ic + a.z * s;
    r.m[1][1] = a.y * a.y * ic + c;
    r.m[1][2] = a.y * a.z * ic - a.x * s;
    r.m[2][0] = a.z * a.x * ic - a.y * s;
    r.m[2][1] = a.z * a.y * ic + a.x * s;
    r.m[2][2] = a.z * a.z * ic + c;
    return r;
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
            A = mitsuba_rotate(axis, angle);
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
            st = nomem(L, n);
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
        return nomem(L, p->node);
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
        bool is_object = is_object_tag(tag) || (strcmp(tag, "spectrum") == 0 && spc_xml_get(c, "type"));
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

/* ------------------------------------------------------------------------------------------------ */
/* sensor, film, sampler, rfilter */

static void parse_rfilter(mts_loader *L, spc_xml_node *node, spc_film_spec *film)
{
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return;
    const char *type = mts_type(node);
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
    } else if (strcmp(type, "mitchell") == 0 || strcmp(type, "catmullrom") == 0 || strcmp(type, "lanczos") == 0) {
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
    if (strcmp(type, "hdrfilm") != 0 && strcmp(type, "ldrfilm") != 0) {
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
    static const char *types[] = {"independent", "stratified", "multijitter", "orthogonal",
                                  "ldsampler",   "halton",     "hammersley",  "sobol"};
    const char *type = mts_type(node);
    bool known = false;
    for (size_t i = 0; i < sizeof types / sizeof types[0]; ++i)
        known |= strcmp(type, types[i]) == 0;
    if (!known) {
        mts_fail(L, node, SPC_ERR_PLUGIN, "unknown sampler type '%s'", type);
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
/* integrator */

/* The aov integrator's "aovs": comma-separated name:type pairs (Mitsuba 3's aov.cpp), of the types
 * specula keeps per pixel. */
static void parse_aovs(mts_loader *L, mts_props *P, const spc_xml_node *node)
{
    static const struct {
        const char *name;
        spc_aov_type type;
    } types[] = {{"albedo", SPC_AOV_ALBEDO},
                 {"depth", SPC_AOV_DEPTH},
                 {"position", SPC_AOV_POSITION},
                 {"sh_normal", SPC_AOV_SH_NORMAL}};
    spc_integrator_spec *it = &L->scene->integrator;
    const char *list = mts_get_string(L, P, "aovs", "");
    const spc_xml_node *at = mts_where(P, "aovs");
    if (!at)
        at = node;
    it->naovs = 0;
    for (const char *p = list; L->status == SPC_OK && *p;) {
        while (*p == ' ' || *p == ',')
            ++p;
        if (!*p)
            break;
        const char *end = p;
        while (*end && *end != ',')
            ++end;
        const char *colon = memchr(p, ':', (size_t)(end - p));
        size_t nlen = colon ? (size_t)(colon - p) : 0;
        while (nlen > 0 && p[nlen - 1] == ' ')
            --nlen;
        const char *t = colon ? colon + 1 : end;
        while (t < end && *t == ' ')
            ++t;
        size_t tlen = (size_t)(end - t);
        while (tlen > 0 && t[tlen - 1] == ' ')
            --tlen;
        if (!colon || nlen == 0 || tlen == 0 || nlen >= sizeof it->aovs[0].name) {
            mts_fail(L, at, SPC_ERR_VALUE, "aovs: expected name:type pairs separated by commas, got \"%.*s\"",
                     (int)(end - p), p);
            break;
        }
        int found = -1;
        for (size_t i = 0; i < sizeof types / sizeof types[0]; ++i)
            if (strlen(types[i].name) == tlen && strncmp(types[i].name, t, tlen) == 0)
                found = (int)i;
        if (found < 0) {
            mts_fail(L, at, SPC_ERR_PLUGIN, "aov type '%.*s' is not supported (albedo, depth, position, sh_normal)",
                     (int)tlen, t);
            break;
        }
        if (it->naovs == SPC_MAX_AOV_OUTPUTS) {
            mts_fail(L, at, SPC_ERR_LIMIT, "more than %d aovs", SPC_MAX_AOV_OUTPUTS);
            break;
        }
        spc_aov_output *o = &it->aovs[it->naovs++];
        snprintf(o->name, sizeof o->name, "%.*s", (int)nlen, p);
        o->type = types[found].type;
        p = end;
    }
}

static void parse_integrator(mts_loader *L, spc_xml_node *node, int depth)
{
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return;
    spc_integrator_spec *it = &L->scene->integrator;
    const char *type = mts_type(node);
    if (strcmp(type, "aov") == 0 || strcmp(type, "moment") == 0 || strcmp(type, "stokes") == 0) {
        if (strcmp(type, "aov") == 0)
            parse_aovs(L, &P, node);
        spc_xml_node *inner = mts_object(&P, "integrator", 0, NULL);
        if (inner && strcmp(type, "aov") == 0 && spc_xml_get(inner, "name"))
            snprintf(it->aov_image, sizeof it->aov_image, "%s", spc_xml_get(inner, "name"));
        if (inner && depth < 8) {
            parse_integrator(L, inner, depth + 1);
        } else {
            mts_warn(node, "integrator '%s' without a nested integrator: using path", type);
            snprintf(it->type, sizeof it->type, "path");
        }
        mts_props_end(&P);
        return;
    }
    const char *ours = NULL;
    int max_depth = -1;
    if (L->integrator_override)
        type = L->integrator_override;
    if (strcmp(type, "path") == 0 || strcmp(type, "prb") == 0) {
        ours = "path";
    } else if (strcmp(type, "ptracer") == 0) {
        ours = "ptracer";
        mts_ignore(&P, "samples_per_pass"); /* how Mitsuba splits its work; the image is the same */
    } else if (strcmp(type, "volpath") == 0 || strcmp(type, "volpathmis") == 0) {
        ours = "volpath";
    } else if (strcmp(type, "direct") == 0) {
        ours = "path";
        max_depth = 2;
        mts_ignore(&P, "emitter_samples");
        mts_ignore(&P, "bsdf_samples");
        mts_ignore(&P, "shading_samples");
    } else if (strcmp(type, "bdpt") == 0) {
        ours = "bdpt";
    } else if (strcmp(type, "ipt") == 0) {
        ours = "ipt";
    } else {
        if (mts_plugin_find("integrator", type))
            mts_fail_plugin(L, node, "integrator", type);
        else
            mts_fail(L, node, SPC_ERR_PLUGIN,
                     "unknown integrator '%s'; choose one of specula's with --integrator path or -D integrator=path",
                     type);
        mts_props_end(&P);
        return;
    }
    snprintf(it->type, sizeof it->type, "%s", ours);
    it->max_depth = max_depth == 2 ? 2 : mts_get_int(L, &P, "max_depth", -1);
    it->rr_depth = mts_get_int(L, &P, "rr_depth", 5);
    it->hide_emitters = mts_get_bool(L, &P, "hide_emitters", false);
    /* specula's own (bdpt); read for every type so that --integrator path on a bdpt scene is quiet */
    it->mis_balance = mts_get_bool(L, &P, "mis_balance", false);
    it->strict_normals = mts_get_bool(L, &P, "strict_normals", false);
    if (it->strict_normals && strcmp(ours, "path") != 0)
        mts_warn(mts_where(&P, "strict_normals"), "strict_normals is honoured by the path integrator only");
    if (mts_has(&P, "specular_nee")) {
        const char *nee = mts_get_string(L, &P, "specular_nee", "");
        char why[SPC_SNEE_WHY_MAX];
        if (strlen(nee) >= sizeof it->specular_nee)
            mts_fail(L, mts_where(&P, "specular_nee"), SPC_ERR_VALUE, "specular_nee is longer than %d characters",
                     (int)sizeof it->specular_nee - 1);
        else if (spc_snee_setting_check(nee, why, sizeof why) != SPC_SNEE_PARSE_OK)
            mts_fail(L, mts_where(&P, "specular_nee"), SPC_ERR_VALUE, "specular_nee '%s': %s", nee, why);
        snprintf(it->specular_nee, sizeof it->specular_nee, "%s", nee);
    }
    if (mts_has(&P, "specular_max_chain"))
        it->specular_max_chain = mts_get_int(L, &P, "specular_max_chain", it->specular_max_chain);
    if (L->status == SPC_OK && it->max_depth < -1)
        mts_fail(L, mts_where(&P, "max_depth"), SPC_ERR_VALUE, "max_depth %d must be -1 (no limit) or >= 0",
                 it->max_depth);
    if (L->status == SPC_OK && it->rr_depth < 1)
        mts_fail(L, mts_where(&P, "rr_depth"), SPC_ERR_VALUE, "rr_depth %d must be at least 1", it->rr_depth);
    snprintf(it->decl_file, sizeof it->decl_file, "%s", node->file ? node->file : "");
    it->decl_line = node->line;
    it->decl_col = node->col;
    mts_props_end(&P);
}

/* ------------------------------------------------------------------------------------------------ */
/* the scene */

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
                parse_integrator(L, c, 0);
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
    L.files_hash = SPC_FNV_OFFSET;
    L.base_dir = dup_str(dir ? dir : ".");
    mts_doc *doc = NULL;
    if (!L.base_dir) {
        nomem(&L, NULL);
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
                nomem(&L, NULL);
                goto done;
            }
            free(p->value);
            p->value = v;
        } else if (!add_param(&L, defs[i].name, defs[i].value, true)) {
            nomem(&L, NULL);
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
        nomem(&L, NULL);
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
