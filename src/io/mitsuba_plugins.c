/*
 * io/mitsuba_plugins.c: the Mitsuba plugins specula knows, from their XML properties to shapes,
 * BSDFs, textures and emitters of the scene. Defaults are Mitsuba 3's unless noted (0.x files get
 * 0.x defaults where they differ: conductor material Cu).
 *
 * Shapes: sphere (center 0, radius 1, to_world: uniform scale, rotation, translation), rectangle,
 *   disk, cube, cylinder (p0 0, p1 (0,0,1), radius 1), obj / ply / serialized (filename,
 *   face_normals false, flip_tex_coords true (obj), shape_index 0 (serialized); a file without
 *   normals gets angle-weighted vertex normals from its world-space positions unless face_normals,
 *   as in Mitsuba 3); all: to_world,
 *   flip_normals false, a nested or referenced bsdf (default diffuse 0.5; black for a shape with an
 *   area emitter, as Mitsuba 3), a nested area emitter,
 *   caustic_caster / caustic_receiver / caustic_caster_single / caustic_caster_multi, and media
 *   (name="interior" / "exterior", nested or referenced; io/mitsuba_media.c).
 *   shapegroup holds shapes; instance (a ref to a shapegroup, to_world) copies them, placed.
 *   linearcurve, bsplinecurve: filename (io/mitsuba_curves.c, scene/curve.h).
 *   sdf: one nested <sdf type="sphere | box | roundbox | torus | capsule | cylinder | plane | union |
 *   intersection | difference | smooth_union"> tree, each node with its own to_world (properties
 *   and defaults in scene/sdf.h); operations take two or more nested <sdf> and fold from the left.
 * BSDFs: diffuse (reflectance 0.5), roughdiffuse (reflectance 0.5, alpha 0.2), phong (exponent 30,
 *   specular_reflectance 0.2, diffuse_reflectance 0.5), conductor (material "none" = perfect
 *   mirror, or eta + k; ext_eta 1; specular_reflectance 1), roughconductor (+ alpha | alpha_u,
 *   alpha_v 0.1, distribution beckmann, sample_visible true), dielectric, thindielectric,
 *   roughdielectric (int_ior bk7 1.5046, ext_ior air 1.000277, names or numbers; specular_
 *   reflectance and _transmittance 1; rough: alpha 0.1, distribution beckmann), plastic,
 *   roughplastic (int_ior, ext_ior, diffuse_reflectance 0.5, specular_reflectance 1, nonlinear
 *   false; rough: alpha 0.1, distribution beckmann), twosided (one or two bsdfs), normalmap (a
 *   texture "normalmap" + bsdf), bumpmap (texture + bsdf, scale 1), null, mask (opacity 0.5 +
 *   bsdf), blendbsdf (weight 0.5 + two bsdfs).
 * Textures: bitmap (filename, filter_type bilinear | nearest, wrap_mode repeat | mirror | clamp,
 *   raw false, to_uv; 0.x uoffset/voffset/uscale/vscale), checkerboard (color0 0.4, color1 0.2,
 *   to_uv), mesh_attribute (name, scale 1). Any texture-valued property also takes rgb, spectrum or
 *   float constants.
 * Emitters: point (intensity 1, position | to_world), spot (intensity 1, cutoff_angle 20,
 *   beam_width 3/4 cutoff_angle, texture (none), to_world), directional (irradiance 1, direction | to_world),
 *   area (radiance 1, rgb or texture; inside a shape), constant (radiance 1), envmap (filename,
 *   scale 1, to_world), projector (irradiance 1, rgb or texture; scale 1; fov, fov_axis "x" or
 *   focal_length "50mm"; to_world).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "io/mesh_io.h"
#include "io/mitsuba_builders.h"
#include "io/mitsuba_tables.h"
#include "scene/curve.h"
#include "scene/sdf.h"
#include "scene/sdfgrid.h"

#define UNIFORM_SCALE_TOL 1e-5 /* relative: sphere to_world columns must agree this well */
/* Nesting limit of <sdf> nodes: far beyond hand-written trees, and it bounds the recursion a
 * fuzzed file can cause. */
#define MTS_SDF_MAX_DEPTH 64

/* ------------------------------------------------------------------------------------------------ */
/* helpers */

static const spc_texture *constant(mts_loader *L, const spc_xml_node *at, spc_rgb v)
{
    const spc_texture *t = spc_scene_constant(L->scene, v);
    if (!t)
        mts_fail(L, at, SPC_ERR_NOMEM, "out of memory");
    return t;
}

/* Guards objects with an id against being built twice and against reference cycles. */
static bool cache_get(mts_loader *L, spc_xml_node *node, void **obj, mts_id **entry)
{
    *entry = mts_id_of(L, node);
    if (!*entry)
        return false;
    if ((*entry)->state == 2) {
        *obj = (*entry)->obj;
        return true;
    }
    if ((*entry)->state == 1) {
        mts_fail(L, node, SPC_ERR_VALUE, "reference cycle through id '%s'", (*entry)->id);
        *obj = NULL;
        return true;
    }
    (*entry)->state = 1;
    return false;
}

static void cache_put(mts_id *entry, void *obj)
{
    if (entry) {
        entry->obj = obj;
        entry->state = obj ? 2 : 0;
    }
}

static void set_to_uv(spc_texture *t, const spc_mat4 *m)
{
    t->to_uv[0][0] = m->m[0][0];
    t->to_uv[0][1] = m->m[0][1];
    t->to_uv[0][2] = m->m[0][3];
    t->to_uv[1][0] = m->m[1][0];
    t->to_uv[1][1] = m->m[1][1];
    t->to_uv[1][2] = m->m[1][3];
}

static spc_mat4 mul(const spc_mat4 *a, const spc_mat4 *b) { return spc_mat4_mul(a, b); }

/* ------------------------------------------------------------------------------------------------ */
/* textures */

/* The builder of a type in the table's category, or NULL (the type is not read). */
static mts_build_fn builder(const mts_loader *L, const char *category, const char *type)
{
    const mts_plugin *p = mts_plugin_find(L, category, type);
    return p ? p->build : NULL;
}

/* ---- the texture builders: one per texture row of the plugin table (mitsuba_plugin_list.c) ---- */

/* A new texture of the scene for builder a, or NULL after mts_fail. */
static spc_texture *new_texture(const mts_build *a)
{
    spc_texture *t = spc_scene_new_texture(a->L->scene);
    if (!t)
        mts_fail(a->L, a->node, SPC_ERR_NOMEM, "out of memory");
    return t;
}

void mts_texture_bitmap(const mts_build *a)
{
    mts_loader *L = a->L;
    mts_props *P = a->P;
    const char *fname = mts_get_string(L, P, "filename", NULL);
    bool raw = mts_get_bool(L, P, "raw", false);
    const char *filter = mts_get_string(L, P, "filter_type", "bilinear");
    const char *wrap = mts_get_string(L, P, "wrap_mode", "repeat");
    mts_ignore(P, "max_anisotropy");
    mts_ignore(P, "cache");
    mts_ignore(P, "format"); /* Mitsuba's storage precision of the texels; specula keeps float */
    bool nearest = false;
    spc_wrap_mode wm = SPC_WRAP_REPEAT;
    if (strcmp(filter, "nearest") == 0)
        nearest = true;
    else if (strcmp(filter, "bilinear") != 0 && strcmp(filter, "ewa") != 0 && strcmp(filter, "trilinear") != 0)
        mts_fail(L, mts_where(P, "filter_type"), SPC_ERR_VALUE, "unknown filter_type '%s' (bilinear, nearest)", filter);
    if (strcmp(wrap, "mirror") == 0)
        wm = SPC_WRAP_MIRROR;
    else if (strcmp(wrap, "clamp") == 0)
        wm = SPC_WRAP_CLAMP;
    else if (strcmp(wrap, "zero") == 0 || strcmp(wrap, "one") == 0) {
        mts_warn(mts_where(P, "wrap_mode"), "wrap_mode '%s' is read as 'clamp'", wrap);
        wm = SPC_WRAP_CLAMP;
    } else if (strcmp(wrap, "repeat") != 0)
        mts_fail(L, mts_where(P, "wrap_mode"), SPC_ERR_VALUE, "unknown wrap_mode '%s' (repeat, mirror, clamp)", wrap);
    char path[4096];
    if (L->status == SPC_OK && !fname)
        mts_fail(L, a->node, SPC_ERR_VALUE, "bitmap texture needs a filename");
    else if (L->status == SPC_OK && !mts_resolve(L, mts_where(P, "filename"), fname, path, sizeof path))
        mts_fail(L, mts_where(P, "filename"), SPC_ERR_IO, "texture file '%s' %s", fname,
                 mts_resolve_failure(L, mts_where(P, "filename"), fname));
    if (L->status != SPC_OK)
        return;
    spc_texture *t = new_texture(a);
    if (!t)
        return;
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    if (spc_texture_load_bitmap(t, path, raw, &sub) != SPC_OK) {
        char msg[SPC_ERROR_MSG_MAX];
        spc_error_format(&sub, msg, sizeof msg);
        mts_fail(L, a->node, sub.code ? sub.code : SPC_ERR_IO, "cannot load texture '%s': %s", fname, msg);
        return;
    }
    t->nearest = nearest;
    t->wrap = wm;
    set_to_uv(t, a->transform);
    *(spc_texture **)a->object = t;
}

void mts_texture_checkerboard(const mts_build *a)
{
    spc_rgb c0 = mts_get_rgb(a->L, a->P, "color0", spc_rgb1(0.4));
    spc_rgb c1 = mts_get_rgb(a->L, a->P, "color1", spc_rgb1(0.2));
    spc_texture *t = a->L->status == SPC_OK ? new_texture(a) : NULL;
    if (!t)
        return;
    spc_texture_init_checkerboard(t, c0, c1);
    set_to_uv(t, a->transform);
    *(spc_texture **)a->object = t;
}

/* a constant read as is (no colour conversion): a float or a 3-vector */
void mts_texture_rawconstant(const mts_build *a)
{
    mts_prop *v = mts_find(a->P, "value");
    spc_rgb c = spc_rgb1(1.0);
    if (v && v->kind == MTS_POINT)
        c = spc_rgb3(v->v.x, v->v.y, v->v.z);
    else
        c = spc_rgb1(mts_get_float(a->L, a->P, "value", 1.0));
    spc_texture *t = a->L->status == SPC_OK ? new_texture(a) : NULL;
    if (!t)
        return;
    spc_texture_init_constant(t, c);
    *(spc_texture **)a->object = t;
}

void mts_texture_mesh_attribute(const mts_build *a)
{
    mts_loader *L = a->L;
    const char *name = mts_get_string(L, a->P, "name", NULL);
    double scale = mts_get_float(L, a->P, "scale", 1.0);
    if (L->status == SPC_OK && !name)
        mts_fail(L, a->node, SPC_ERR_VALUE, "mesh_attribute texture needs a name");
    spc_texture *t = L->status == SPC_OK ? new_texture(a) : NULL;
    if (!t)
        return;
    if (!spc_texture_init_mesh_attribute(t, name, scale)) {
        mts_fail(L, mts_where(a->P, "name"), SPC_ERR_VALUE,
                 "mesh attribute name '%s' must start with 'vertex_' or 'face_' (at most 63 characters)", name);
        return;
    }
    *(spc_texture **)a->object = t;
}

const spc_texture *mts_build_texture(mts_loader *L, spc_xml_node *node)
{
    void *cached;
    mts_id *entry;
    if (cache_get(L, node, &cached, &entry))
        return cached;
    mts_props P;
    if (mts_props_collect(L, node, &P)) {
        cache_put(entry, NULL);
        return NULL;
    }
    const char *type = mts_type(node);
    spc_texture *t = NULL;
    spc_mat4 to_uv = mts_get_transform(L, &P, "to_uv");
    if (mts_has(&P, "uoffset") || mts_has(&P, "voffset") || mts_has(&P, "uscale") || mts_has(&P, "vscale")) {
        /* 0.x: as Mitsuba 3's upgrade, translate by the offset, then scale */
        spc_vec3 off = spc_v3(mts_get_float(L, &P, "uoffset", 0), mts_get_float(L, &P, "voffset", 0), 0);
        spc_vec3 sc = spc_v3(mts_get_float(L, &P, "uscale", 1), mts_get_float(L, &P, "vscale", 1), 1);
        spc_mat4 T = spc_mat4_translate(off), S = spc_mat4_scale(sc);
        spc_mat4 ST = mul(&S, &T);
        to_uv = mul(&ST, &to_uv);
    }
    mts_build_fn build = builder(L, "texture", type);
    if (build) {
        mts_build a = {.L = L, .node = node, .type = type, .P = &P, .object = &t, .transform = &to_uv};
        build(&a);
    } else {
        mts_fail_plugin(L, node, "texture", type);
    }
    if (L->status != SPC_OK)
        t = NULL;
    mts_props_end(&P);
    cache_put(entry, t);
    return t;
}

const spc_texture *mts_get_texture(mts_loader *L, mts_props *P, const char *name, spc_rgb def)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return constant(L, P->owner, def);
    switch (p->kind) {
    case MTS_RGB: return constant(L, p->node, p->rgb);
    case MTS_FLOAT:
    case MTS_INT: return constant(L, p->node, spc_rgb1(p->f));
    case MTS_OBJECT:
        if (strcmp(p->obj->name, "texture") == 0)
            return mts_build_texture(L, p->obj);
        break;
    case MTS_BOOL:
    case MTS_STRING:
    case MTS_POINT:
    case MTS_TRANSFORM: break;
    }
    mts_fail(L, p->node, SPC_ERR_VALUE, "property '%s' must be a texture, rgb, spectrum or float", name);
    return NULL;
}

/* The first texture among named property `name` and the unnamed nested textures. */
static const spc_texture *any_texture(mts_loader *L, mts_props *P, const char *name)
{
    if (mts_has(P, name))
        return mts_get_texture(L, P, name, spc_rgb1(0));
    for (int i = 0; i < P->n; ++i) {
        mts_prop *p = &P->p[i];
        if (p->kind == MTS_OBJECT && strcmp(p->obj->name, "texture") == 0) {
            p->used = true;
            return mts_build_texture(L, p->obj);
        }
    }
    return NULL;
}

/* ------------------------------------------------------------------------------------------------ */
/* BSDFs */

static double get_ior(mts_loader *L, mts_props *P, const char *name, double def)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return def;
    double v = def;
    if (p->kind == MTS_FLOAT || p->kind == MTS_INT) {
        v = p->f;
    } else if (p->kind == MTS_STRING) {
        if (!mts_named_ior(p->s, &v)) {
            mts_fail(L, p->node, SPC_ERR_VALUE, "unknown IOR name '%s' for '%s' (known: %s)", p->s, name,
                     mts_ior_names());
            return def;
        }
    } else {
        mts_fail(L, p->node, SPC_ERR_VALUE, "property '%s' must be a float or an IOR name", name);
        return def;
    }
    if (!(v > 0.0))
        mts_fail(L, p->node, SPC_ERR_VALUE, "%s %g must be positive", name, v);
    return v;
}

static void roughness(mts_loader *L, mts_props *P, spc_bsdf *b, double def, bool anisotropic)
{
    if (mts_has(P, "alpha") || !anisotropic) {
        if (anisotropic && (mts_has(P, "alpha_u") || mts_has(P, "alpha_v")))
            mts_fail(L, mts_where(P, "alpha"), SPC_ERR_VALUE, "give either alpha or alpha_u/alpha_v, not both");
        b->alpha_u = b->alpha_v = mts_get_texture(L, P, "alpha", spc_rgb1(def));
    } else {
        b->alpha_u = mts_get_texture(L, P, "alpha_u", spc_rgb1(def));
        b->alpha_v = mts_get_texture(L, P, "alpha_v", spc_rgb1(def));
    }
    const char *dist = mts_get_string(L, P, "distribution", "beckmann");
    if (strcmp(dist, "beckmann") == 0)
        b->distribution = SPC_MICROFACET_BECKMANN;
    else if (strcmp(dist, "ggx") == 0)
        b->distribution = SPC_MICROFACET_GGX;
    else
        mts_fail(L, mts_where(P, "distribution"), SPC_ERR_VALUE, "unknown microfacet distribution '%s' (beckmann, ggx)",
                 dist);
    b->sample_visible = mts_get_bool(L, P, "sample_visible", true);
}

static void conductor(mts_loader *L, mts_props *P, spc_bsdf *b, const spc_xml_node *node)
{
    const char *def_material = mts_dialect(node) < 2 ? "Cu" : "none";
    bool given = mts_has(P, "eta") || mts_has(P, "k");
    if (given && mts_has(P, "material"))
        mts_fail(L, mts_where(P, "material"), SPC_ERR_VALUE, "give either material or eta and k, not both");
    spc_rgb eta = spc_rgb1(0), k = spc_rgb1(-1);
    if (given) {
        if (!mts_has(P, "eta") || !mts_has(P, "k"))
            mts_fail(L, node, SPC_ERR_VALUE, "a conductor needs both eta and k");
        eta = mts_get_rgb(L, P, "eta", spc_rgb1(0));
        k = mts_get_rgb(L, P, "k", spc_rgb1(0));
        if (L->status == SPC_OK && (eta.r < 0 || eta.g < 0 || eta.b < 0 || k.r < 0 || k.g < 0 || k.b < 0))
            mts_fail(L, mts_where(P, "eta"), SPC_ERR_VALUE, "conductor eta and k must not be negative");
    } else {
        const char *material = mts_get_string(L, P, "material", def_material);
        if (strcmp(material, "none") != 0 && !mts_conductor_preset(material, &eta, &k))
            mts_fail(L, mts_where(P, "material"), SPC_ERR_VALUE, "unknown conductor material '%s' (known: %s)",
                     material, mts_conductor_names());
    }
    double ext = mts_get_float(L, P, "ext_eta", 1.0);
    if (L->status == SPC_OK && !(ext > 0.0))
        mts_fail(L, mts_where(P, "ext_eta"), SPC_ERR_VALUE, "ext_eta %g must be positive", ext);
    if (k.r >= 0.0 && ext > 0.0) {
        eta = spc_rgb_scale(eta, 1.0 / ext);
        k = spc_rgb_scale(k, 1.0 / ext);
    }
    b->cond_eta = eta;
    b->cond_k = k; /* k < 0: perfect mirror (material "none") */
    b->specular_reflectance = mts_get_texture(L, P, "specular_reflectance", spc_rgb1(1));
}

static const spc_bsdf *nested_bsdf(mts_loader *L, mts_props *P, int k)
{
    spc_xml_node *n = mts_object(P, "bsdf", k, NULL);
    return n ? mts_build_bsdf(L, n) : NULL;
}

/* ---- the BSDF builders: one per bsdf row of the plugin table (mitsuba_plugin_list.c) ---- */

void mts_bsdf_diffuse(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_DIFFUSE;
    b->reflectance = mts_get_texture(a->L, a->P, "reflectance", spc_rgb1(0.5));
}

void mts_bsdf_roughdiffuse(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_ROUGHDIFFUSE;
    b->reflectance = mts_get_texture(a->L, a->P, "reflectance", spc_rgb1(0.5));
    b->alpha_u = b->alpha_v = mts_get_texture(a->L, a->P, "alpha", spc_rgb1(0.2));
    mts_ignore(a->P, "use_fast_approx");
}

void mts_bsdf_phong(const mts_build *a)
{
    mts_loader *L = a->L;
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_PHONG;
    b->exponent = mts_get_float(L, a->P, "exponent", 30.0);
    b->specular_reflectance = mts_get_texture(L, a->P, "specular_reflectance", spc_rgb1(0.2));
    b->reflectance = mts_get_texture(L, a->P, "diffuse_reflectance", spc_rgb1(0.5));
    if (L->status == SPC_OK && !(b->exponent > 0.0))
        mts_fail(L, mts_where(a->P, "exponent"), SPC_ERR_VALUE, "phong exponent %g must be positive", b->exponent);
}

void mts_bsdf_conductor(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_CONDUCTOR;
    conductor(a->L, a->P, b, a->node);
}

void mts_bsdf_roughconductor(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_ROUGHCONDUCTOR;
    conductor(a->L, a->P, b, a->node);
    roughness(a->L, a->P, b, 0.1, true);
}

/* dielectric, thindielectric, roughdielectric */
static void dielectric(const mts_build *a, spc_bsdf_type type)
{
    spc_bsdf *b = a->object;
    b->type = type;
    double in = get_ior(a->L, a->P, "int_ior", 1.5046), ext = get_ior(a->L, a->P, "ext_ior", 1.000277);
    b->eta = in / ext;
    b->specular_reflectance = mts_get_texture(a->L, a->P, "specular_reflectance", spc_rgb1(1));
    b->specular_transmittance = mts_get_texture(a->L, a->P, "specular_transmittance", spc_rgb1(1));
    if (type == SPC_BSDF_ROUGHDIELECTRIC)
        roughness(a->L, a->P, b, 0.1, true);
}
void mts_bsdf_dielectric(const mts_build *a) { dielectric(a, SPC_BSDF_DIELECTRIC); }
void mts_bsdf_thindielectric(const mts_build *a) { dielectric(a, SPC_BSDF_THINDIELECTRIC); }
void mts_bsdf_roughdielectric(const mts_build *a) { dielectric(a, SPC_BSDF_ROUGHDIELECTRIC); }

/* plastic, roughplastic */
static void plastic(const mts_build *a, spc_bsdf_type type)
{
    spc_bsdf *b = a->object;
    b->type = type;
    double in = get_ior(a->L, a->P, "int_ior", 1.49), ext = get_ior(a->L, a->P, "ext_ior", 1.000277);
    b->eta = in / ext;
    b->reflectance = mts_get_texture(a->L, a->P, "diffuse_reflectance", spc_rgb1(0.5));
    b->specular_reflectance = mts_get_texture(a->L, a->P, "specular_reflectance", spc_rgb1(1));
    b->nonlinear = mts_get_bool(a->L, a->P, "nonlinear", false);
    if (type == SPC_BSDF_ROUGHPLASTIC)
        roughness(a->L, a->P, b, 0.1, false);
}
void mts_bsdf_plastic(const mts_build *a) { plastic(a, SPC_BSDF_PLASTIC); }
void mts_bsdf_roughplastic(const mts_build *a) { plastic(a, SPC_BSDF_ROUGHPLASTIC); }

void mts_bsdf_pplastic(const mts_build *a)
{
    mts_loader *L = a->L;
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_PPLASTIC;
    double in = get_ior(L, a->P, "int_ior", 1.49), ext = get_ior(L, a->P, "ext_ior", 1.000277);
    b->eta = in / ext;
    b->reflectance = mts_get_texture(L, a->P, "diffuse_reflectance", spc_rgb1(0.5));
    b->specular_reflectance = mts_get_texture(L, a->P, "specular_reflectance", spc_rgb1(1));
    roughness(L, a->P, b, 0.1, true);
    if (L->status == SPC_OK && !(in > 0.0 && ext > 0.0 && in != ext))
        mts_fail(L, a->node, SPC_ERR_VALUE, "pplastic: int_ior and ext_ior must be positive and differ");
}

void mts_bsdf_twosided(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_TWOSIDED;
    if (a->nested < 1 || a->nested > 2)
        mts_fail(a->L, a->node, SPC_ERR_VALUE, "twosided needs one or two nested bsdfs, got %d", a->nested);
    else {
        b->nested[0] = nested_bsdf(a->L, a->P, 0);
        b->nested[1] = a->nested == 2 ? nested_bsdf(a->L, a->P, 1) : b->nested[0];
    }
}

void mts_bsdf_normalmap(const mts_build *a)
{
    mts_loader *L = a->L;
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_NORMALMAP;
    b->normalmap = any_texture(L, a->P, "normalmap");
    if (a->nested != 1)
        mts_fail(L, a->node, SPC_ERR_VALUE, "normalmap needs exactly one nested bsdf, got %d", a->nested);
    else if (L->status == SPC_OK && !b->normalmap)
        mts_fail(L, a->node, SPC_ERR_VALUE, "normalmap needs a texture named 'normalmap'");
    else
        b->nested[0] = nested_bsdf(L, a->P, 0);
}

void mts_bsdf_bumpmap(const mts_build *a)
{
    mts_loader *L = a->L;
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_BUMPMAP;
    b->bump = any_texture(L, a->P, "bumpmap");
    b->bump_scale = mts_get_float(L, a->P, "scale", 1.0);
    if (a->nested != 1)
        mts_fail(L, a->node, SPC_ERR_VALUE, "bumpmap needs exactly one nested bsdf, got %d", a->nested);
    else if (L->status == SPC_OK && !b->bump)
        mts_fail(L, a->node, SPC_ERR_VALUE, "bumpmap needs a nested texture");
    else
        b->nested[0] = nested_bsdf(L, a->P, 0);
}

void mts_bsdf_null(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_NULL;
}

/* As Mitsuba 3's RGB variants render it: a null surface passing half the light times its
 * transmittance (polarization is not tracked; theta and polarizing change nothing there). */
void mts_bsdf_polarizer(const mts_build *a)
{
    mts_loader *L = a->L;
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_NULL;
    mts_warn(a->node, "polarizer: polarization is not tracked; half the light passes, as in Mitsuba 3's RGB variants");
    const spc_texture *t = mts_get_texture(L, a->P, "transmittance", spc_rgb1(1));
    mts_ignore(a->P, "theta");
    mts_ignore(a->P, "polarizing");
    spc_texture *half = L->status == SPC_OK ? spc_scene_new_texture(L->scene) : NULL;
    if (L->status == SPC_OK && (!t || !spc_texture_is_constant(t)))
        mts_fail(L, mts_where(a->P, "transmittance"), SPC_ERR_VALUE,
                 "polarizer: only a constant transmittance is supported");
    else if (L->status == SPC_OK && !half)
        mts_fail(L, a->node, SPC_ERR_NOMEM, "out of memory");
    else if (L->status == SPC_OK) {
        spc_texture_init_constant(half, spc_rgb_scale(t->value, 0.5));
        b->specular_transmittance = half;
    }
}

void mts_bsdf_mask(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_MASK;
    b->opacity = mts_get_texture(a->L, a->P, "opacity", spc_rgb1(0.5));
    if (a->nested != 1)
        mts_fail(a->L, a->node, SPC_ERR_VALUE, "mask needs exactly one nested bsdf, got %d", a->nested);
    else
        b->nested[0] = nested_bsdf(a->L, a->P, 0);
}

void mts_bsdf_blendbsdf(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_BLENDBSDF;
    b->weight = mts_get_texture(a->L, a->P, "weight", spc_rgb1(0.5));
    if (a->nested != 2)
        mts_fail(a->L, a->node, SPC_ERR_VALUE, "blendbsdf needs exactly two nested bsdfs, got %d", a->nested);
    else {
        b->nested[0] = nested_bsdf(a->L, a->P, 0);
        b->nested[1] = nested_bsdf(a->L, a->P, 1);
    }
}

const spc_bsdf *mts_build_bsdf(mts_loader *L, spc_xml_node *node)
{
    void *cached;
    mts_id *entry;
    if (cache_get(L, node, &cached, &entry))
        return cached;
    mts_props P;
    if (mts_props_collect(L, node, &P)) {
        cache_put(entry, NULL);
        return NULL;
    }
    const char *type = mts_type(node);
    spc_bsdf *b = spc_scene_new_bsdf(L->scene);
    if (!b) {
        mts_fail(L, node, SPC_ERR_NOMEM, "out of memory");
        goto out;
    }
    b->sample_visible = true;
    b->eta = 1.0;
    b->bump_scale = 1.0;
    mts_build_fn build = builder(L, "bsdf", type);
    if (build) {
        mts_build a = {
            .L = L, .node = node, .type = type, .P = &P, .object = b, .nested = mts_count_objects(&P, "bsdf")};
        build(&a);
    } else {
        mts_fail_plugin(L, node, "bsdf", type);
    }
out:
    if (L->status != SPC_OK)
        b = NULL;
    mts_props_end(&P);
    cache_put(entry, b);
    return b;
}

/* ------------------------------------------------------------------------------------------------ */
/* meshes */

static bool mesh_copy(spc_mesh *dst, const spc_mesh *src)
{
    memset(dst, 0, sizeof *dst);
    dst->nverts = src->nverts;
    dst->ntris = src->ntris;
    dst->p = malloc(3 * src->nverts * sizeof(float) + 1);
    dst->idx = malloc(3 * src->ntris * sizeof(uint32_t) + 1);
    if (src->n)
        dst->n = malloc(3 * src->nverts * sizeof(float) + 1);
    if (src->uv)
        dst->uv = malloc(2 * src->nverts * sizeof(float) + 1);
    if (!dst->p || !dst->idx || (src->n && !dst->n) || (src->uv && !dst->uv)) {
        spc_mesh_release(dst);
        memset(dst, 0, sizeof *dst);
        return false;
    }
    memcpy(dst->p, src->p, 3 * src->nverts * sizeof(float));
    memcpy(dst->idx, src->idx, 3 * src->ntris * sizeof(uint32_t));
    if (src->n)
        memcpy(dst->n, src->n, 3 * src->nverts * sizeof(float));
    if (src->uv)
        memcpy(dst->uv, src->uv, 2 * src->nverts * sizeof(float));
    if (!spc_mesh_copy_attrs(dst, src)) {
        spc_mesh_release(dst);
        return false;
    }
    return true;
}

void mts_mesh_cache_release(mts_loader *L)
{
    for (int i = 0; i < L->nmeshes; ++i) {
        free(L->meshes[i].key);
        spc_mesh_release(&L->meshes[i].mesh);
    }
    free(L->meshes);
    L->meshes = NULL;
    L->nmeshes = 0;
}

typedef enum mesh_format { MESH_OBJ, MESH_PLY, MESH_SERIALIZED } mesh_format;

/* Loads a mesh file in object space into *m (which the caller then owns). Shapes inside a
 * shapegroup go through a cache so that each instance does not read the file again. type: the
 * plugin's name, for the cache key and messages. */

static void load_mesh(mts_loader *L, const spc_xml_node *node, const char *type, mesh_format format, const char *path,
                      int shape_index, bool flip_tex, bool cached, spc_mesh *m)
{
    memset(m, 0, sizeof *m);
    char key[4200];
    snprintf(key, sizeof key, "%s|%d|%d|%s", type, shape_index, flip_tex ? 1 : 0, path);
    if (cached) {
        for (int i = 0; i < L->nmeshes; ++i) {
            if (strcmp(L->meshes[i].key, key) == 0) {
                if (!mesh_copy(m, &L->meshes[i].mesh))
                    mts_fail(L, node, SPC_ERR_NOMEM, "out of memory");
                return;
            }
        }
    }
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    spc_status st = SPC_ERR_INTERNAL;
    switch (format) {
    case MESH_OBJ:
        st = spc_obj_load_ex(path, flip_tex, m, &sub);
        break;
    case MESH_PLY:
        st = spc_ply_load(path, m, &sub);
        break;
    case MESH_SERIALIZED:
        st = spc_serialized_load(path, shape_index, m, &sub);
        break;
    }
    if (st != SPC_OK) {
        char msg[SPC_ERROR_MSG_MAX];
        spc_error_format(&sub, msg, sizeof msg);
        mts_fail(L, node, st, "cannot load %s mesh: %s", type, msg);
        spc_mesh_release(m);
        memset(m, 0, sizeof *m);
        return;
    }
    if (cached) {
        mts_mesh_entry *e = realloc(L->meshes, (size_t)(L->nmeshes + 1) * sizeof *e);
        if (!e) {
            mts_fail(L, node, SPC_ERR_NOMEM, "out of memory");
            return;
        }
        L->meshes = e;
        char *k = malloc(strlen(key) + 1);
        spc_mesh copy;
        if (!k || !mesh_copy(&copy, m)) {
            free(k);
            mts_fail(L, node, SPC_ERR_NOMEM, "out of memory");
            return;
        }
        strcpy(k, key);
        L->meshes[L->nmeshes].key = k;
        L->meshes[L->nmeshes].mesh = copy;
        ++L->nmeshes;
    }
}

/* ------------------------------------------------------------------------------------------------ */
/* shapes */

/* The BSDF of a shape that names none: diffuse 0.5, or, for a shape with an area emitter, diffuse
 * 0 (black), as Mitsuba 3 does (an emitter without a BSDF reflects nothing). */
static const spc_bsdf *default_bsdf(mts_loader *L, const spc_xml_node *at, bool emitter)
{
    if (emitter) {
        spc_bsdf *b = spc_scene_new_bsdf(L->scene);
        if (!b) {
            mts_fail(L, at, SPC_ERR_NOMEM, "out of memory");
            return NULL;
        }
        b->type = SPC_BSDF_DIFFUSE;
        b->reflectance = constant(L, at, spc_rgb1(0.0));
        b->sample_visible = true;
        b->eta = 1.0;
        b->bump_scale = 1.0;
        return b;
    }
    if (L->default_bsdf)
        return L->default_bsdf;
    spc_bsdf *b = spc_scene_new_bsdf(L->scene);
    if (!b) {
        mts_fail(L, at, SPC_ERR_NOMEM, "out of memory");
        return NULL;
    }
    b->type = SPC_BSDF_DIFFUSE;
    b->reflectance = constant(L, at, spc_rgb1(0.5));
    b->sample_visible = true;
    b->eta = 1.0;
    b->bump_scale = 1.0;
    L->default_bsdf = b;
    return b;
}

static bool uniform_scale(const spc_mat4 *m)
{
    spc_vec3 c[3];
    for (int j = 0; j < 3; ++j)
        c[j] = spc_v3(m->m[0][j], m->m[1][j], m->m[2][j]);
    double l0 = spc_length(c[0]);
    if (!(l0 > 0.0))
        return false;
    for (int j = 1; j < 3; ++j)
        if (fabs(spc_length(c[j]) - l0) > UNIFORM_SCALE_TOL * l0)
            return false;
    for (int a = 0; a < 3; ++a)
        for (int b = a + 1; b < 3; ++b)
            if (fabs(spc_dot(c[a], c[b])) > UNIFORM_SCALE_TOL * l0 * l0)
                return false;
    return m->m[3][0] == 0.0 && m->m[3][1] == 0.0 && m->m[3][2] == 0.0 && m->m[3][3] == 1.0;
}

static void caustic_flags(mts_loader *L, mts_props *P, spc_shape *s)
{
    static const struct {
        const char *name;
        unsigned bit;
    } flags[] = {{"caustic_caster", SPC_CAUSTIC_CASTER},
                 {"caustic_receiver", SPC_CAUSTIC_RECEIVER},
                 {"caustic_caster_single", SPC_CAUSTIC_CASTER_SINGLE},
                 {"caustic_caster_multi", SPC_CAUSTIC_CASTER_MULTI}};
    /* As in the specular manifold sampling code these properties come from: once a shape says
     * anything, it has exactly the roles it sets to true. */
    for (size_t i = 0; i < sizeof flags / sizeof flags[0]; ++i) {
        if (!mts_has(P, flags[i].name))
            continue;
        if (!(s->caustic_flags & SPC_CAUSTIC_FLAGS_EXPLICIT))
            s->caustic_flags = SPC_CAUSTIC_FLAGS_EXPLICIT;
        if (mts_get_bool(L, P, flags[i].name, false))
            s->caustic_flags |= flags[i].bit;
    }
}

/* A size: a vector, or one float for all three axes. */
static spc_vec3 get_size(mts_loader *L, mts_props *P, const char *name, spc_vec3 def)
{
    mts_prop *p = mts_find(P, name);
    if (!p)
        return def;
    if (p->kind == MTS_FLOAT || p->kind == MTS_INT)
        return spc_v3(p->f, p->f, p->f);
    p->used = false;
    return mts_get_point(L, P, name, def);
}

/* Builds the <sdf> element `node` (and its children) into sdf; returns its node index, or -1 after
 * mts_fail. */
static int build_sdf(mts_loader *L, spc_sdf *sdf, spc_xml_node *node, int depth)
{
    if (depth > MTS_SDF_MAX_DEPTH) {
        mts_fail(L, node, SPC_ERR_LIMIT, "<sdf> nodes nested deeper than %d", MTS_SDF_MAX_DEPTH);
        return -1;
    }
    const char *type = mts_type(node);
    spc_sdf_type t;
    if (!spc_sdf_type_from_name(type, &t)) {
        mts_fail(L, node, SPC_ERR_PLUGIN,
                 "unknown sdf type '%s' (sphere, box, roundbox, torus, capsule, cylinder, plane, union, "
                 "intersection, difference, smooth_union)",
                 type);
        return -1;
    }
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return -1;
    spc_sdf_desc d;
    spc_sdf_desc_init(&d, t);
    d.to_world = mts_get_transform(L, &P, "to_world");
    const char *size_name = "half_size";
    switch (t) {
    case SPC_SDF_SPHERE: d.radius = mts_get_float(L, &P, "radius", d.radius); break;
    case SPC_SDF_BOX:
    case SPC_SDF_ROUNDBOX:
        if (mts_has(&P, "size") && mts_has(&P, "half_size")) {
            mts_fail(L, mts_where(&P, "size"), SPC_ERR_VALUE, "sdf %s: give size or half_size, not both", type);
        } else if (mts_has(&P, "size")) {
            d.half_size = spc_scale(get_size(L, &P, "size", d.half_size), 0.5);
            size_name = "size";
        } else {
            d.half_size = get_size(L, &P, "half_size", d.half_size);
        }
        if (t == SPC_SDF_ROUNDBOX)
            d.radius = mts_get_float(L, &P, "radius", d.radius);
        break;
    case SPC_SDF_TORUS:
        d.major = mts_get_float(L, &P, "major_radius", d.major);
        d.minor = mts_get_float(L, &P, "minor_radius", d.minor);
        break;
    case SPC_SDF_CAPSULE:
        d.p0 = mts_get_point(L, &P, "p0", d.p0);
        d.p1 = mts_get_point(L, &P, "p1", d.p1);
        d.radius = mts_get_float(L, &P, "radius", d.radius);
        break;
    case SPC_SDF_CYLINDER:
        d.radius = mts_get_float(L, &P, "radius", d.radius);
        d.height = mts_get_float(L, &P, "height", d.height);
        break;
    case SPC_SDF_PLANE:
        d.normal = mts_get_point(L, &P, "normal", d.normal);
        d.offset = mts_get_float(L, &P, "offset", d.offset);
        break;
    case SPC_SDF_SMOOTH_UNION: d.k = mts_get_float(L, &P, "k", d.k); break;
    case SPC_SDF_UNION:
    case SPC_SDF_INTERSECTION:
    case SPC_SDF_DIFFERENCE: break;
    }
    char msg[256];
    const char *field = NULL;
    if (L->status == SPC_OK && !spc_sdf_desc_check(&d, msg, sizeof msg, &field))
        mts_fail(L, mts_where(&P, strcmp(field, "half_size") == 0 ? size_name : field), SPC_ERR_VALUE, "sdf %s: %s",
                 type, msg);
    int nchildren = mts_count_objects(&P, "sdf"), idx = -1;
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    if (L->status != SPC_OK) {
        /* reported */
    } else if (!spc_sdf_type_is_operation(t)) {
        if (nchildren > 0)
            mts_fail(L, node, SPC_ERR_VALUE, "sdf %s is a primitive: it takes no nested <sdf>", type);
        else if ((idx = spc_sdf_add(sdf, &d, node->file, node->line, node->col, &sub)) < 0)
            mts_fail(L, node, sub.code ? sub.code : SPC_ERR_VALUE, "%s", sub.msg);
    } else if (nchildren < 2) {
        mts_fail(L, node, SPC_ERR_VALUE, "sdf %s needs two or more nested <sdf>, got %d", type, nchildren);
    } else {
        /* ((c0 op c1) op c2) ...: the node's transform applies to the outermost fold */
        spc_mat4 to_world = d.to_world;
        for (int c = 0; c < nchildren && L->status == SPC_OK; ++c) {
            int ci = build_sdf(L, sdf, mts_object(&P, "sdf", c, NULL), depth + 1);
            if (ci < 0)
                break;
            if (c == 0) {
                idx = ci;
                continue;
            }
            d.a = idx;
            d.b = ci;
            d.to_world = c == nchildren - 1 ? to_world : spc_mat4_identity();
            if ((idx = spc_sdf_add(sdf, &d, node->file, node->line, node->col, &sub)) < 0)
                mts_fail(L, node, sub.code ? sub.code : SPC_ERR_VALUE, "%s", sub.msg);
        }
    }
    mts_props_end(&P);
    return L->status == SPC_OK ? idx : -1;
}

static void build_instance(mts_loader *L, spc_xml_node *node, mts_props *P, const spc_mat4 *prefix, bool in_group)
{
    const spc_xml_node *at = node;
    spc_xml_node *group = mts_object(P, "shape", 0, &at);
    if (in_group) {
        mts_fail(L, node, SPC_ERR_VALUE, "an instance cannot be inside a shapegroup");
        return;
    }
    if (!group || strcmp(mts_type(group), "shapegroup") != 0 || mts_count_objects(P, "shape") != 1) {
        mts_fail(L, at, SPC_ERR_VALUE, "an instance needs exactly one reference to a shapegroup");
        return;
    }
    spc_mat4 local = mts_get_transform(L, P, "to_world");
    spc_mat4 M = prefix ? mul(prefix, &local) : local;
    for (int i = 0; i < group->nchildren && L->status == SPC_OK; ++i) {
        spc_xml_node *c = group->children[i];
        if (strcmp(c->name, "shape") == 0)
            mts_build_shape(L, c, &M, true);
        else if (strcmp(c->name, "ref") == 0) {
            mts_id *e = mts_lookup_id(L, spc_xml_get(c, "id") ? spc_xml_get(c, "id") : "");
            if (!e)
                mts_fail(L, c, SPC_ERR_VALUE, "reference to unknown id '%s'",
                         spc_xml_get(c, "id") ? spc_xml_get(c, "id") : "");
            else if (strcmp(e->node->name, "shape") != 0)
                mts_fail(L, c, SPC_ERR_VALUE, "a shapegroup holds only shapes, not <%s>", e->node->name);
            else
                mts_build_shape(L, e->node, &M, true);
        } else if (strcmp(c->name, "default") != 0 && strcmp(c->name, "path") != 0)
            mts_fail(L, c, SPC_ERR_VALUE, "a shapegroup holds only shapes, not <%s>", c->name);
    }
}

/* ---- the shape builders: one per shape row of the plugin table (mitsuba_plugin_list.c) ---- */

/* What every geometric shape reads around its own parameters. */
typedef struct geometry {
    mts_props P;
    spc_mat4 M;             /* the prefix times the shape's to_world */
    int interior, exterior; /* media (mitsuba_media.c), -1: none */
    bool flip;
    bool mesh; /* a mesh file: smooth vertex normals unless face_normals */
    bool face_normals;
} geometry;

/* Collects the element's properties and reads media, to_world and flip_normals; false after
 * mts_fail (nothing to release). */
static bool geometry_begin(const mts_build *a, geometry *g)
{
    mts_loader *L = a->L;
    memset(g, 0, sizeof *g);
    if (mts_props_collect(L, a->node, &g->P))
        return false;
    if (!mts_shape_media(L, &g->P, &g->interior, &g->exterior)) {
        mts_props_end(&g->P);
        return false;
    }
    spc_mat4 local = mts_get_transform(L, &g->P, "to_world");
    g->M = a->prefix ? mul(a->prefix, &local) : local;
    g->flip = mts_get_bool(L, &g->P, "flip_normals", false);
    return true;
}

/* A new shape in the scene, its index in *index, once the shape's parameters were read without
 * error; NULL when they were not, or out of memory (geometry_end reports it). */
static spc_shape *geometry_shape(const mts_build *a, int *index)
{
    *index = -1;
    if (a->L->status != SPC_OK)
        return NULL;
    spc_shape *s = spc_scene_new_shape(a->L->scene);
    if (!s)
        return NULL;
    *index = a->L->scene->nshapes - 1;
    s->interior_medium = s->exterior_medium = -1;
    return s;
}

/* After the shape's init (built: it succeeded; sub: its error otherwise): the id, media, normals,
 * caustic roles, bsdf and emitter; ends g->P. s NULL: the parameters failed, or out of memory. */
static void geometry_end(const mts_build *a, geometry *g, spc_shape *s, int index, bool built, const spc_error *sub)
{
    mts_loader *L = a->L;
    spc_xml_node *node = a->node;
    if (L->status != SPC_OK) {
        mts_props_end(&g->P);
        return;
    }
    if (!s) {
        mts_props_end(&g->P);
        mts_fail(L, node, SPC_ERR_NOMEM, "out of memory");
        return;
    }
    if (!built) {
        mts_props_end(&g->P);
        mts_fail(L, node, sub->code ? sub->code : SPC_ERR_VALUE, "%s shape: %s", a->type, sub->msg);
        return;
    }
    /* as Mitsuba 3: a mesh file without normals gets smooth vertex normals (unless face_normals),
     * computed from the WORLD-space positions (they differ under a non-uniform scale) */
    if (g->mesh && !g->face_normals && !spc_mesh_compute_vertex_normals(&s->mesh)) {
        mts_props_end(&g->P);
        mts_fail(L, node, SPC_ERR_NOMEM, "out of memory");
        return;
    }
    const char *id = spc_xml_get(node, "id");
    if (id)
        snprintf(s->id, sizeof s->id, "%s", id);
    s->interior_medium = g->interior; /* after init, which clears them */
    s->exterior_medium = g->exterior;
    s->flip_normals = g->flip;
    s->face_normals = g->face_normals;
    caustic_flags(L, &g->P, s);

    int nbsdf = mts_count_objects(&g->P, "bsdf"), nem = mts_count_objects(&g->P, "emitter");
    if (nbsdf > 1)
        mts_fail(L, node, SPC_ERR_VALUE, "a shape takes one bsdf, got %d", nbsdf);
    else if (nem > 1)
        mts_fail(L, node, SPC_ERR_VALUE, "a shape takes one emitter, got %d", nem);
    else {
        spc_xml_node *bn = mts_object(&g->P, "bsdf", 0, NULL);
        spc_xml_node *en = mts_object(&g->P, "emitter", 0, NULL);
        s->bsdf = bn ? mts_build_bsdf(L, bn) : default_bsdf(L, node, en != NULL);
        if (en && L->status == SPC_OK)
            mts_build_emitter(L, en, s, index);
    }
    mts_props_end(&g->P);
}

/* sphere and cylinder: radius 1, positive */
static double get_radius(const mts_build *a, geometry *g)
{
    double radius = mts_get_float(a->L, &g->P, "radius", 1.0);
    if (a->L->status == SPC_OK && !(radius > 0.0))
        mts_fail(a->L, mts_where(&g->P, "radius"), SPC_ERR_VALUE, "%s radius %g must be positive", a->type, radius);
    return radius;
}

void mts_shape_sphere(const mts_build *a)
{
    mts_loader *L = a->L;
    geometry g;
    if (!geometry_begin(a, &g))
        return;
    double radius = get_radius(a, &g);
    spc_vec3 center = mts_get_point(L, &g.P, "center", spc_v3(0, 0, 0));
    if (L->status == SPC_OK && !(spc_length(spc_v3(g.M.m[0][0], g.M.m[1][0], g.M.m[2][0])) > 0.0))
        mts_fail(L, mts_where(&g.P, "to_world"), SPC_ERR_VALUE,
                 "a sphere's to_world scales it to a point (a scale of 0): the sphere would vanish");
    else if (L->status == SPC_OK && !uniform_scale(&g.M))
        mts_fail(L, mts_where(&g.P, "to_world"), SPC_ERR_VALUE,
                 "a sphere's to_world may only rotate, translate and scale uniformly");
    int index;
    spc_shape *s = geometry_shape(a, &index);
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    const spc_xml_node *n = a->node;
    bool built = s && spc_shape_init_sphere(s, center, radius, &g.M, n->file, n->line, n->col, &sub);
    geometry_end(a, &g, s, index, built, &sub);
}

void mts_shape_cylinder(const mts_build *a)
{
    mts_loader *L = a->L;
    geometry g;
    if (!geometry_begin(a, &g))
        return;
    double radius = get_radius(a, &g);
    spc_vec3 p0 = mts_get_point(L, &g.P, "p0", spc_v3(0, 0, 0));
    spc_vec3 p1 = mts_get_point(L, &g.P, "p1", spc_v3(0, 0, 1));
    if (L->status == SPC_OK && !(spc_distance(p0, p1) > 0.0))
        mts_fail(L, a->node, SPC_ERR_VALUE, "cylinder p0 and p1 must differ");
    int index;
    spc_shape *s = geometry_shape(a, &index);
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    const spc_xml_node *n = a->node;
    bool built = s && spc_shape_init_cylinder(s, p0, p1, radius, &g.M, n->file, n->line, n->col, &sub);
    geometry_end(a, &g, s, index, built, &sub);
}

/* rectangle, disk, cube: no parameters of their own */
typedef bool (*plain_init)(spc_shape *s, const spc_mat4 *to_world, const char *file, int line, int col, spc_error *err);
static void plain_shape(const mts_build *a, plain_init init)
{
    geometry g;
    if (!geometry_begin(a, &g))
        return;
    int index;
    spc_shape *s = geometry_shape(a, &index);
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    const spc_xml_node *n = a->node;
    bool built = s && init(s, &g.M, n->file, n->line, n->col, &sub);
    geometry_end(a, &g, s, index, built, &sub);
}
void mts_shape_rectangle(const mts_build *a) { plain_shape(a, spc_shape_init_rectangle); }
void mts_shape_disk(const mts_build *a) { plain_shape(a, spc_shape_init_disk); }
void mts_shape_cube(const mts_build *a) { plain_shape(a, spc_shape_init_cube); }

/* obj, ply, serialized */
static void mesh_shape(const mts_build *a, mesh_format format)
{
    mts_loader *L = a->L;
    geometry g;
    if (!geometry_begin(a, &g))
        return;
    g.mesh = true;
    g.face_normals = mts_get_bool(L, &g.P, "face_normals", false);
    const char *fname = mts_get_string(L, &g.P, "filename", NULL);
    int shape_index = format == MESH_SERIALIZED ? mts_get_int(L, &g.P, "shape_index", 0) : 0;
    bool flip_tex = format == MESH_OBJ ? mts_get_bool(L, &g.P, "flip_tex_coords", true) : true;
    char path[4096];
    spc_mesh m;
    memset(&m, 0, sizeof m);
    if (L->status == SPC_OK && !fname)
        mts_fail(L, a->node, SPC_ERR_VALUE, "%s shape needs a filename", a->type);
    else if (L->status == SPC_OK && shape_index < 0)
        mts_fail(L, mts_where(&g.P, "shape_index"), SPC_ERR_VALUE, "shape_index %d must not be negative", shape_index);
    else if (L->status == SPC_OK && !mts_resolve(L, mts_where(&g.P, "filename"), fname, path, sizeof path))
        mts_fail(L, mts_where(&g.P, "filename"), SPC_ERR_IO, "mesh file '%s' %s", fname,
                 mts_resolve_failure(L, mts_where(&g.P, "filename"), fname));
    if (L->status == SPC_OK)
        load_mesh(L, mts_where(&g.P, "filename"), a->type, format, path, shape_index, flip_tex, a->in_group, &m);
    int index;
    spc_shape *s = geometry_shape(a, &index);
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    const spc_xml_node *n = a->node;
    bool built = s && spc_shape_init_mesh(s, &m, &g.M, n->file, n->line, n->col, &sub);
    spc_mesh_release(&m); /* emptied by init_mesh on success */
    geometry_end(a, &g, s, index, built, &sub);
}
void mts_shape_obj(const mts_build *a) { mesh_shape(a, MESH_OBJ); }
void mts_shape_ply(const mts_build *a) { mesh_shape(a, MESH_PLY); }
void mts_shape_serialized(const mts_build *a) { mesh_shape(a, MESH_SERIALIZED); }

void mts_shape_sdf(const mts_build *a)
{
    mts_loader *L = a->L;
    geometry g;
    if (!geometry_begin(a, &g))
        return;
    spc_sdf *sdf = NULL;
    int sdf_root = -1;
    int nsdf = mts_count_objects(&g.P, "sdf");
    if (L->status != SPC_OK) {
        /* reported */
    } else if (nsdf != 1)
        mts_fail(L, a->node, SPC_ERR_VALUE, "an sdf shape takes one nested <sdf> tree, got %d", nsdf);
    else if (!(sdf = spc_sdf_create()))
        mts_fail(L, a->node, SPC_ERR_NOMEM, "out of memory");
    else
        sdf_root = build_sdf(L, sdf, mts_object(&g.P, "sdf", 0, NULL), 1);
    int index;
    spc_shape *s = geometry_shape(a, &index);
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    const spc_xml_node *n = a->node;
    bool built = false;
    if (s)
        built = spc_shape_init_sdf(s, sdf, sdf_root, &g.M, n->file, n->line, n->col, &sub); /* owns sdf */
    else
        spc_sdf_destroy(sdf);
    geometry_end(a, &g, s, index, built, &sub);
}

/* sdfgrid: a signed distance grid over [0,1]^3 (io/mitsuba_sdfgrid.c); never an area emitter */
void mts_shape_sdfgrid(const mts_build *a)
{
    mts_loader *L = a->L;
    geometry g;
    if (!geometry_begin(a, &g))
        return;
    struct spc_sdfgrid *grid = NULL;
    if (L->status != SPC_OK) {
        /* reported */
    } else if (mts_count_objects(&g.P, "emitter") > 0)
        mts_fail(L, a->node, SPC_ERR_VALUE, "an sdfgrid cannot be an area emitter (as in Mitsuba 3)");
    else
        grid = mts_load_sdfgrid(L, &g.P, a->node, &g.M);
    int index;
    spc_shape *s = geometry_shape(a, &index);
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    const spc_xml_node *n = a->node;
    bool built = false;
    if (s)
        built = spc_shape_init_sdfgrid(s, grid, n->file, n->line, n->col, &sub); /* owns grid */
    else
        spc_sdfgrid_destroy(grid);
    geometry_end(a, &g, s, index, built, &sub);
}

/* linearcurve, bsplinecurve: control points with radii from a file (io/mitsuba_curves.c) */
void mts_shape_curve(const mts_build *a)
{
    mts_loader *L = a->L;
    geometry g;
    if (!geometry_begin(a, &g))
        return;
    spc_curve *curve = L->status == SPC_OK ? mts_load_curve(L, a->node, &g.P, a->type, &g.M) : NULL;
    int index;
    spc_shape *s = geometry_shape(a, &index);
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    const spc_xml_node *n = a->node;
    bool built = false;
    if (s)
        built = spc_shape_init_curve(s, curve, n->file, n->line, n->col, &sub); /* owns curve */
    else if (curve) {
        spc_curve_release(curve);
        free(curve);
    }
    geometry_end(a, &g, s, index, built, &sub);
}

/* A shapegroup's shapes are made by the instances that refer to it. */
void mts_shape_shapegroup(const mts_build *a)
{
    if (a->in_group)
        mts_fail(a->L, a->node, SPC_ERR_VALUE, "shapegroups cannot be nested");
}

void mts_shape_instance(const mts_build *a)
{
    mts_props P;
    if (mts_props_collect(a->L, a->node, &P))
        return;
    build_instance(a->L, a->node, &P, a->prefix, a->in_group);
    mts_props_end(&P);
}

spc_status mts_build_shape(mts_loader *L, spc_xml_node *node, const spc_mat4 *prefix, bool in_group)
{
    const char *type = mts_type(node);
    mts_build_fn build = builder(L, "shape", type);
    if (build) {
        mts_build a = {.L = L, .node = node, .type = type, .prefix = prefix, .in_group = in_group};
        build(&a);
        return L->status;
    }
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return L->status;
    mts_fail_plugin(L, node, "shape", type);
    mts_props_end(&P);
    return L->status;
}

/* ------------------------------------------------------------------------------------------------ */
/* emitters */

/* An emitter's color property: a <spectrum> is read as an illuminant (mts_spectrum_to_rgb_emission),
 * as Mitsuba 3's RGB variants do; rgb and float values are taken as they are. */
static spc_rgb emission_rgb(mts_loader *L, mts_props *P, const char *name, spc_rgb def)
{
    mts_prop *p = mts_find(P, name);
    if (p && p->kind == MTS_RGB && p->spectral) {
        p->used = true;
        return p->rgb_emission;
    }
    return mts_get_rgb(L, P, name, def);
}

static const spc_texture *emission_texture(mts_loader *L, mts_props *P, const char *name, spc_rgb def)
{
    mts_prop *p = mts_find(P, name);
    if (p && p->kind == MTS_RGB && p->spectral) {
        p->used = true;
        return constant(L, p->node, p->rgb_emission);
    }
    return mts_get_texture(L, P, name, def);
}

/* A projector's image on the plane z = 1: the camera's frustum for its field of view with the
 * image's aspect ratio (a constant irradiance is a 1 x 1 image, as in Mitsuba). */
static void projector_frustum(mts_loader *L, mts_props *P, spc_emitter *e)
{
    double fov = 45.0;
    spc_fov_axis axis = SPC_FOV_X;
    mts_get_fov(L, P, &fov, &axis);
    bool image = e->texture && e->texture->type == SPC_TEX_BITMAP && e->texture->width > 0 && e->texture->height > 0;
    if (L->status == SPC_OK && !spc_fov_tangents(fov, axis, image ? e->texture->width : 1,
                                                  image ? e->texture->height : 1, &e->tan_x, &e->tan_y))
        mts_fail(L, mts_where(P, "fov"), SPC_ERR_VALUE, "projector field of view %g is invalid", fov);
}

/* ---- the emitter builders: one per emitter row of the plugin table (mitsuba_plugin_list.c) ---- */

/* The emitter's origin in the world (its to_world applied to 0). */
static spc_vec3 emitter_origin(const spc_emitter *e) { return spc_mat4_apply_point(&e->to_world, spc_v3(0, 0, 0)); }

void mts_emitter_area(const mts_build *a)
{
    spc_emitter *e = a->object;
    e->type = SPC_EMITTER_AREA;
    e->radiance = emission_texture(a->L, a->P, "radiance", spc_rgb1(1));
    e->shape = a->shape;
    e->shape_index = a->shape_index;
}

void mts_emitter_point(const mts_build *a)
{
    mts_loader *L = a->L;
    spc_emitter *e = a->object;
    e->type = SPC_EMITTER_POINT;
    e->intensity = emission_rgb(L, a->P, "intensity", spc_rgb1(1));
    if (mts_has(a->P, "position") && mts_has(a->P, "to_world"))
        mts_fail(L, mts_where(a->P, "position"), SPC_ERR_VALUE, "give either position or to_world, not both");
    e->position = mts_get_point(L, a->P, "position", emitter_origin(e));
}

void mts_emitter_spot(const mts_build *a)
{
    mts_loader *L = a->L;
    spc_emitter *e = a->object;
    e->type = SPC_EMITTER_SPOT;
    e->intensity = emission_rgb(L, a->P, "intensity", spc_rgb1(1));
    e->cutoff_angle = mts_get_float(L, a->P, "cutoff_angle", 20.0);
    e->beam_width = mts_get_float(L, a->P, "beam_width", 0.75 * e->cutoff_angle);
    e->position = emitter_origin(e);
    if (mts_has(a->P, "texture"))
        e->texture = mts_get_texture(L, a->P, "texture", spc_rgb1(1));
    if (L->status == SPC_OK && !(e->cutoff_angle > 0.0 && e->cutoff_angle <= 90.0))
        mts_fail(L, mts_where(a->P, "cutoff_angle"), SPC_ERR_VALUE, "cutoff_angle %g must be in (0, 90]",
                 e->cutoff_angle);
    if (L->status == SPC_OK && !(e->beam_width > 0.0 && e->beam_width <= e->cutoff_angle))
        mts_fail(L, mts_where(a->P, "beam_width"), SPC_ERR_VALUE, "beam_width %g must be in (0, cutoff_angle]",
                 e->beam_width);
}

void mts_emitter_projector(const mts_build *a)
{
    spc_emitter *e = a->object;
    e->type = SPC_EMITTER_PROJECTOR;
    e->texture = emission_texture(a->L, a->P, "irradiance", spc_rgb1(1));
    e->scale = mts_get_float(a->L, a->P, "scale", 1.0);
    e->position = emitter_origin(e);
    projector_frustum(a->L, a->P, e);
}

void mts_emitter_directional(const mts_build *a)
{
    mts_loader *L = a->L;
    spc_emitter *e = a->object;
    e->type = SPC_EMITTER_DIRECTIONAL;
    e->irradiance = emission_rgb(L, a->P, "irradiance", spc_rgb1(1));
    spc_vec3 d = spc_mat4_apply_vector(&e->to_world, spc_v3(0, 0, 1));
    d = mts_get_point(L, a->P, "direction", d);
    if (L->status == SPC_OK && !(spc_length(d) > 0.0))
        mts_fail(L, mts_where(a->P, "direction"), SPC_ERR_VALUE, "directional emitter needs a non-zero direction");
    e->direction = spc_normalize(d);
}

void mts_emitter_constant(const mts_build *a)
{
    spc_emitter *e = a->object;
    e->type = SPC_EMITTER_CONSTANT;
    e->radiance = emission_texture(a->L, a->P, "radiance", spc_rgb1(1));
}

void mts_emitter_envmap(const mts_build *a)
{
    mts_loader *L = a->L;
    spc_emitter *e = a->object;
    e->type = SPC_EMITTER_ENVMAP;
    e->scale = mts_get_float(L, a->P, "scale", 1.0);
    const char *fname = mts_get_string(L, a->P, "filename", NULL);
    char path[4096];
    if (L->status == SPC_OK && !fname)
        mts_fail(L, a->node, SPC_ERR_VALUE, "envmap needs a filename");
    else if (L->status == SPC_OK && !mts_resolve(L, mts_where(a->P, "filename"), fname, path, sizeof path))
        mts_fail(L, mts_where(a->P, "filename"), SPC_ERR_IO, "envmap file '%s' %s", fname,
                 mts_resolve_failure(L, mts_where(a->P, "filename"), fname));
    if (L->status != SPC_OK)
        return;
    spc_texture *t = spc_scene_new_texture(L->scene);
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    if (!t) {
        mts_fail(L, a->node, SPC_ERR_NOMEM, "out of memory");
    } else if (spc_texture_load_bitmap(t, path, false, &sub) != SPC_OK) {
        char msg[SPC_ERROR_MSG_MAX];
        spc_error_format(&sub, msg, sizeof msg);
        mts_fail(L, mts_where(a->P, "filename"), sub.code ? sub.code : SPC_ERR_IO, "cannot load envmap '%s': %s", fname,
                 msg);
    }
    e->radiance = t;
}

/* Emitters other than area ones stand alone; an area emitter is nested in the shape it lights. */
spc_status mts_build_emitter(mts_loader *L, spc_xml_node *node, spc_shape *shape, int shape_index)
{
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return L->status;
    const char *type = mts_type(node);
    mts_build_fn build = builder(L, "emitter", type);
    bool area = build == mts_emitter_area;
    if (!build) {
        mts_fail_plugin(L, node, "emitter", type);
    } else if (shape && !area) {
        mts_fail(L, node, SPC_ERR_VALUE, "only area emitters can be attached to a shape, not '%s'", type);
    } else if (!shape && area) {
        mts_fail(L, node, SPC_ERR_VALUE, "an area emitter must be nested inside a <shape>");
    }
    if (L->status != SPC_OK) {
        mts_props_end(&P);
        return L->status;
    }
    spc_mat4 to_world = mts_get_transform(L, &P, "to_world");
    spc_emitter tmp;
    memset(&tmp, 0, sizeof tmp);
    tmp.scale = 1.0;
    tmp.to_world = to_world;
    tmp.to_local = spc_mat4_identity();
    tmp.shape_index = -1;
    if (!spc_mat4_inverse(&to_world, &tmp.to_local))
        mts_fail(L, mts_where(&P, "to_world"), SPC_ERR_VALUE, "emitter to_world is singular");
    mts_build a = {
        .L = L, .node = node, .type = type, .P = &P, .object = &tmp, .shape = shape, .shape_index = shape_index};
    build(&a);
    if (L->status == SPC_OK && tmp.radiance && tmp.radiance->type == SPC_TEX_MESH_ATTRIBUTE)
        mts_fail(L, mts_where(&P, "radiance"), SPC_ERR_VALUE, "a mesh_attribute texture cannot be an emitter's radiance");
    if (L->status == SPC_OK && tmp.texture && tmp.texture->type == SPC_TEX_MESH_ATTRIBUTE)
        mts_fail(L, node, SPC_ERR_VALUE, "a mesh_attribute texture cannot be an emitter's image");
    if (L->status == SPC_OK) {
        spc_emitter *e = spc_scene_new_emitter(L->scene);
        if (!e) {
            mts_fail(L, node, SPC_ERR_NOMEM, "out of memory");
        } else {
            *e = tmp;
            e->index = L->scene->nemitters - 1;
            if (shape)
                shape->emitter = e;
        }
    }
    mts_props_end(&P);
    return L->status;
}
