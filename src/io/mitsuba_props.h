/*
 * io/mitsuba_props.h: the loader's state and what its parts read through (not a public interface):
 * the sticky error, file names resolved against the scene's folders, the id table, the properties
 * of an object element with typed getters, and the plugin registry's row. The builders
 * (mitsuba_builders.h) include this and nothing above it; the walk over the document
 * (mitsuba_xml.c) sits on both.
 *
 * Errors are sticky: the first mts_fail() fills the caller's spc_error and sets L->status; later
 * ones are ignored, so value getters can return a default and let the builder check L->status
 * once.
 */
#ifndef SPC_IO_MITSUBA_PROPS_H
#define SPC_IO_MITSUBA_PROPS_H

#include <stdio.h>

#include "core/error.h"
#include "core/math.h"
#include "io/xml.h"
#include "scene/scene.h"

typedef enum mts_kind {
    MTS_BOOL,
    MTS_INT,
    MTS_FLOAT,
    MTS_STRING,
    MTS_RGB,       /* rgb, srgb and spectrum (converted to linear RGB) */
    MTS_POINT,     /* point and vector */
    MTS_TRANSFORM,
    MTS_OBJECT     /* a nested object element, or the target of a <ref> */
} mts_kind;

typedef struct mts_prop {
    const char *name; /* NULL for unnamed nested objects */
    mts_kind kind;
    bool b;
    long long i;
    double f;
    const char *s;
    spc_rgb rgb;
    spc_rgb rgb_emission; /* <spectrum>: its color as an emitter's (see mts_spectrum_to_rgb_emission) */
    bool spectral;        /* the value came from a <spectrum> tag */
    spc_vec3 v;
    spc_mat4 m;
    const spc_xml_node *node; /* the property element (for messages) */
    spc_xml_node *obj;        /* MTS_OBJECT: the object element */
    bool used;
    /* the name a plugin asked for that is closest to this one (for "did you mean"), and its
     * edit distance; "" while none was asked for */
    char closest[48];
    int closest_distance;
} mts_prop;

struct mts_loader;
struct mts_plugin;

typedef struct mts_props {
    struct mts_loader *L; /* no warnings once loading has failed */
    const spc_xml_node *owner;
    mts_prop *p;
    int n;
} mts_props;

typedef struct mts_id {
    const char *id;
    spc_xml_node *node;
    void *obj;     /* built object (bsdf, texture), once built */
    int state;     /* 0 not built, 1 building (cycle guard), 2 built */
    int seq;       /* registration order (duplicates are reported in document order) */
} mts_id;

typedef struct mts_param {
    char *name, *value;
    bool from_define;
    bool declared; /* a <default> names it */
    bool used;     /* a $name was replaced by it */
} mts_param;

typedef struct mts_doc {
    char *file;        /* label used in messages (owned) */
    char *dir;         /* directory relative file names start from (owned) */
    spc_xml_node *root;
} mts_doc;

typedef struct mts_mesh_entry {
    char *key;
    spc_mesh mesh; /* object space */
} mts_mesh_entry;

typedef struct mts_loader {
    spc_scene *scene;
    spc_error *err;
    spc_status status;

    mts_param *params;
    int nparams, cap_params;
    char **dirs; /* <path> directories, in declaration order */
    int ndirs;
    char *base_dir;
    mts_doc *docs;
    int ndocs, cap_docs;
    uint64_t files_hash; /* of every file mts_resolve found, in order: becomes spc_scene.files_hash */

    mts_id *ids;
    int nids, cap_ids;

    mts_mesh_entry *meshes; /* object-space meshes used by shapegroups */
    int nmeshes;

    const struct mts_plugin *plugins; /* the plugin registry (mitsuba_plugin_list.c), nplugins rows */
    int nplugins;

    const char *integrator_override; /* the "@integrator" define, or NULL */
    const spc_bsdf *default_bsdf;
    bool have_sensor, have_integrator;
    bool lenient; /* the "@unreferenced" define is "warn": properties no plugin reads only warn */
} mts_loader;

spc_status mts_fail(mts_loader *L, const spc_xml_node *at, spc_status code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
void mts_warn(const spc_xml_node *at, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
const char *mts_type(const spc_xml_node *n); /* the type attribute, or "" */
int mts_dialect(const spc_xml_node *n);      /* major version of the file the node came from */

/* Collects the children of an object element; warns about unused ones in mts_props_end. */
spc_status mts_props_collect(mts_loader *L, const spc_xml_node *owner, mts_props *P);
/* Fails on the first property no plugin read ("unreferenced property", with the closest name that
 * was read), or only warns when the loader is lenient; warns for unused nested objects; frees. */
void mts_props_end(mts_props *P);
mts_prop *mts_find(mts_props *P, const char *name); /* marks it used */
bool mts_has(const mts_props *P, const char *name);
void mts_ignore(mts_props *P, const char *name); /* known and deliberately unused: no warning */
/* Nested objects of a category ("bsdf", "texture", ...), in order; index k, marks it used. */
spc_xml_node *mts_object(mts_props *P, const char *category, int k, const spc_xml_node **at);
int mts_count_objects(const mts_props *P, const char *category);

double mts_get_float(mts_loader *L, mts_props *P, const char *name, double def);
int mts_get_int(mts_loader *L, mts_props *P, const char *name, int def);
bool mts_get_bool(mts_loader *L, mts_props *P, const char *name, bool def);
const char *mts_get_string(mts_loader *L, mts_props *P, const char *name, const char *def);
spc_rgb mts_get_rgb(mts_loader *L, mts_props *P, const char *name, spc_rgb def);
spc_vec3 mts_get_point(mts_loader *L, mts_props *P, const char *name, spc_vec3 def);
spc_mat4 mts_get_transform(mts_loader *L, mts_props *P, const char *name);
/* fov (degrees) and fov_axis, or focal_length ("50mm" by default: diagonal), as Mitsuba reads them
 * for perspective sensors and projectors; on failure L's error is set. */
void mts_get_fov(mts_loader *L, mts_props *P, double *fov, spc_fov_axis *axis);
/* The element that set a property (for messages), or the owner. */
const spc_xml_node *mts_where(const mts_props *P, const char *name);

/* Resolves a file name used at node `at`: absolute as is; else the directory of the file that
 * holds `at`, the scene's directory, the <path> directories (latest first), the working
 * directory. Returns false (out unchanged) if no such readable file exists. */
bool mts_resolve(mts_loader *L, const spc_xml_node *at, const char *name, char *out, size_t size);
/* Why mts_resolve found no file of that name: "is a directory", "is not a regular file", "cannot
 * be read" (for the first candidate path that exists) or "not found". */
const char *mts_resolve_failure(mts_loader *L, const spc_xml_node *at, const char *name);

/* Id table. */
mts_id *mts_lookup_id(mts_loader *L, const char *id);
mts_id *mts_id_of(mts_loader *L, const spc_xml_node *node); /* NULL if node has no id */
/* Out of memory at `at` (mts_fail with SPC_ERR_NOMEM). */
spc_status mts_nomem(mts_loader *L, const spc_xml_node *at);
/* A <path> directory written at `at`: as written if absolute; else relative to the directory of the
 * file that holds `at`, the scene's directory, the <path> directories (latest first). The
 * directory (value itself, or buf filled), or NULL if none exists. */
const char *mts_resolve_dir(mts_loader *L, const spc_xml_node *at, const char *value, char *buf, size_t size);
/* Is t the tag of an object element (bsdf, shape, ...; not a property)? */
bool mts_is_object_tag(const char *t);

/* A row of the plugin registry (mitsuba_plugin_list.c, handed to the loader as L->plugins): what the
 * loader reads, for docs/PLUGINS.md and for the errors on plugins it does not read. */
typedef enum mts_plugin_status {
    MTS_PLUGIN_YES, /* read */
    MTS_PLUGIN_NO,  /* a Mitsuba 3 plugin the loader refuses (SPC_ERR_PLUGIN naming it) */
    MTS_PLUGIN_OWN, /* read; specula's own or Mitsuba 0.6's, not in Mitsuba 3 */
    MTS_PLUGIN_STANDIN /* loads, rendered with a stand-in the note names (the loader warns) */
} mts_plugin_status;

/* What a plugin's builder reads and fills, per category:
 *   bsdf     P collected by mts_build_bsdf; object: the spc_bsdf, with the loader's defaults set;
 *            nested: the number of nested bsdfs. The builder sets the type and its parameters.
 *   shape    P NULL: the builder collects the element's properties itself (a shapegroup has none
 *            to read); prefix: the transform before its own to_world (NULL at the top level);
 *            in_group: inside a shapegroup.
 *   emitter  P collected by mts_build_emitter; object: the spc_emitter being filled (to_world,
 *            to_local, scale 1 set); shape, shape_index: the shape an area emitter is nested in.
 *   texture  P collected by mts_build_texture; transform: to_uv (0.x offsets and scales applied);
 *            object: a spc_texture * the builder sets to the texture it adds to the scene.
 *   medium   P collected by mts_build_medium; object: a spc_medium * the builder sets to the
 *            medium it adds to the scene.
 *   phase    P collected by mts_build_phase; object: the spc_phase to fill (isotropic set).
 *   volume   P collected by mts_get_volume; transform: to_world; object: the spc_volume to fill
 *            (zeroed).
 *   integrator  P collected by mts_build_integrator; type: the type read (the "@integrator"
 *            define's where it applies); nested: how deep the element is nested in aov, moment
 *            or stokes. The builder fills L->scene->integrator.
 * A builder reports failure through mts_fail (L->status). */
typedef struct mts_build {
    mts_loader *L;
    spc_xml_node *node;
    const char *type;
    mts_props *P;
    void *object;
    int nested;
    const spc_mat4 *prefix;
    bool in_group;
    spc_shape *shape;
    int shape_index;
    const spc_mat4 *transform;
} mts_build;
typedef void (*mts_build_fn)(const mts_build *a);

/* One row per plugin: the one place its name is written. A row whose build is NULL is read by
 * code outside this registry's categories (textures, sensors, ...) or not read at all. */
typedef struct mts_plugin {
    const char *category; /* the XML tag: bsdf, emitter, shape, ... */
    const char *name;     /* the type attribute */
    mts_plugin_status status;
    const char *params;   /* parameters read, with defaults */
    const char *note;
    mts_build_fn build; /* bsdf, shape, emitter: what the loader calls for this type */
} mts_plugin;

/* The row of L's registry for a plugin, or NULL. */
const mts_plugin *mts_plugin_find(const mts_loader *L, const char *category, const char *name);
/* Fails with SPC_ERR_PLUGIN at node: a Mitsuba 3 plugin the loader does not read is named as such
 * (with the registry's note), anything else is "unknown <category> type", followed by the names of
 * the category the registry marks read. */
spc_status mts_fail_plugin(mts_loader *L, const spc_xml_node *node, const char *category, const char *type);

/* specula's own plugin properties, which Mitsuba 3 refuses as unreferenced. A scene may give them
 * as <default name="..." value="..."/> inside the plugin element instead, which Mitsuba 3 accepts
 * and ignores: the loader reads such a default as the property, of the kind listed here. */
typedef struct mts_own_property {
    const char *category, *name;
    mts_kind kind;
    const char *meaning;
} mts_own_property;
/* The row named name, or NULL. */
const mts_own_property *mts_own_property_find(const char *category, const char *name);
/* The whole list (*n rows). */
const mts_own_property *mts_own_property_list(int *n);

#endif
