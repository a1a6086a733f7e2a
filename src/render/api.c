/*
 * render/api.c: the public API around a loaded scene: loading (through the Mitsuba XML loader),
 * the summary and the per-object description that `specula info` prints, the specular NEE plan, and
 * spc_render: the plan, the pilot render that may turn an automatic one off (snee_pilot.h), then
 * the render loop (render/driver.h). Films and images are film.c, film_io.c and diff.c.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/mitsuba_xml.h"
#include "manifold/snee_options.h"
#include "manifold/snee_plan.h"
#include "render/checkpoint.h"
#include "render/driver.h"
#include "render/film.h"
#include "render/snee_pilot.h"
#include "scene/scene.h"
#include "specula/specula.h"

spc_status spc_scene_load(const char *path, const spc_define *defs, int ndefs, spc_scene **out, spc_error *err)
{
    if (out)
        *out = NULL;
    if (!path || !out)
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "spc_scene_load: no path or output given");
    if (ndefs < 0 || (ndefs > 0 && !defs))
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "invalid list of -D definitions");
    spc_status st = spc_mitsuba_load(path, defs, ndefs, out, err);
    if (st == SPC_OK)
        /* checkpoints refuse other scenes */
        (*out)->content_hash = spc_ckpt_scene_hash(path, defs, ndefs, (*out)->files_hash);
    return st;
}

spc_status spc_render(const spc_scene *sc, const spc_render_options *o, spc_film **out, spc_render_stats *stats,
                      spc_error *err)
{
    spc_snee_plan plan;
    spc_driver_plan(sc, o, &plan);
    spc_snee_pilot pilot;
    spc_snee_pilot_run(sc, o, &plan, &pilot); /* keeps or turns off an automatic plan */
    return spc_driver_render(sc, o, &plan, out, stats, err);
}

static bool shape_is_analytic(const spc_shape *sh)
{
    switch (sh->type) {
    case SPC_SHAPE_MESH:
    case SPC_SHAPE_CURVE:
        return false;
    case SPC_SHAPE_SPHERE:
    case SPC_SHAPE_DISK:
    case SPC_SHAPE_CYLINDER:
    case SPC_SHAPE_SDF:
    case SPC_SHAPE_SDFGRID:
        return true;
    }
    return false;
}

void spc_scene_summarize(const spc_scene *s, spc_scene_summary *out)
{
    memset(out, 0, sizeof *out);
    if (!s)
        return;
    out->shapes = s->nshapes;
    out->bsdfs = s->nbsdfs;
    out->emitters = s->nemitters;
    out->textures = s->ntextures;
    bool have_box = false;
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (int i = 0; i < s->nshapes; ++i) {
        const spc_shape *sh = s->shapes[i];
        if (shape_is_analytic(sh)) {
            out->analytic_shapes++;
        } else {
            out->meshes++;
            out->triangles += (uint64_t)sh->mesh.ntris;
        }
        /* the shapes' bounds are set by spc_shape_prepare; use them when the scene's are not */
        double smin[3] = {sh->bbox_min.x, sh->bbox_min.y, sh->bbox_min.z};
        double smax[3] = {sh->bbox_max.x, sh->bbox_max.y, sh->bbox_max.z};
        if (!(smin[0] <= smax[0] && smin[1] <= smax[1] && smin[2] <= smax[2]))
            continue;
        for (int k = 0; k < 3; ++k) {
            lo[k] = have_box ? spc_min(lo[k], smin[k]) : smin[k];
            hi[k] = have_box ? spc_max(hi[k], smax[k]) : smax[k];
        }
        have_box = true;
    }
    if (s->finalized) {
        lo[0] = s->bbox_min.x, lo[1] = s->bbox_min.y, lo[2] = s->bbox_min.z;
        hi[0] = s->bbox_max.x, hi[1] = s->bbox_max.y, hi[2] = s->bbox_max.z;
    }
    for (int k = 0; k < 3; ++k) {
        out->bbox_min[k] = lo[k];
        out->bbox_max[k] = hi[k];
    }
    out->width = s->film.width;
    out->height = s->film.height;
    out->spp = s->spp;
    out->max_depth = s->integrator.max_depth;
    snprintf(out->integrator, sizeof out->integrator, "%s", s->integrator.type);
}

/* ---- description: a growable string ---- */

typedef struct strbuf {
    char *data;
    size_t len, cap;
    bool failed;
} strbuf;

static void sb_printf(strbuf *b, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

static void sb_printf(strbuf *b, const char *fmt, ...)
{
    if (b->failed)
        return;
    for (;;) {
        size_t room = b->cap - b->len;
        va_list ap;
        va_start(ap, fmt);
        int n = room > 0 ? vsnprintf(b->data + b->len, room, fmt, ap) : vsnprintf(NULL, 0, fmt, ap);
        va_end(ap);
        if (n < 0) {
            b->failed = true;
            return;
        }
        if ((size_t)n < room) {
            b->len += (size_t)n;
            return;
        }
        size_t cap = b->cap ? b->cap : 256;
        while (cap <= b->len + (size_t)n)
            cap *= 2;
        char *p = realloc(b->data, cap);
        if (!p) {
            b->failed = true;
            return;
        }
        b->data = p;
        b->cap = cap;
    }
}

static const char *shape_type_name(const spc_shape *sh)
{
    switch (sh->type) {
    case SPC_SHAPE_MESH: return "mesh";
    case SPC_SHAPE_SPHERE: return "sphere";
    case SPC_SHAPE_DISK: return "disk";
    case SPC_SHAPE_CYLINDER: return "cylinder";
    case SPC_SHAPE_SDF: return "sdf";
    case SPC_SHAPE_CURVE: return "curve";
    case SPC_SHAPE_SDFGRID: return "sdfgrid";
    }
    return "?";
}

static const char *emitter_type_name(spc_emitter_type t)
{
    switch (t) {
    case SPC_EMITTER_POINT: return "point";
    case SPC_EMITTER_SPOT: return "spot";
    case SPC_EMITTER_DIRECTIONAL: return "directional";
    case SPC_EMITTER_AREA: return "area";
    case SPC_EMITTER_CONSTANT: return "constant";
    case SPC_EMITTER_ENVMAP: return "envmap";
    case SPC_EMITTER_PROJECTOR: return "projector";
    }
    return "?";
}

static int bsdf_index(const spc_scene *s, const spc_bsdf *b)
{
    for (int i = 0; i < s->nbsdfs; ++i)
        if (s->bsdfs[i] == b)
            return i;
    return -1;
}

static int shape_index(const spc_scene *s, const spc_shape *sh)
{
    for (int i = 0; i < s->nshapes; ++i)
        if (s->shapes[i] == sh)
            return i;
    return -1;
}

/* "diffuse" or "twosided(#1 diffuse)": nested BSDFs by index and type (a second nested BSDF only
 * when it differs from the first), depth-limited against cycles. */
static void describe_bsdf_type(strbuf *b, const spc_scene *s, const spc_bsdf *bsdf, int depth)
{
    if (!bsdf) {
        sb_printf(b, "none");
        return;
    }
    sb_printf(b, "%s", spc_bsdf_type_name(bsdf->type));
    if (depth >= 4 || (!bsdf->nested[0] && !bsdf->nested[1]))
        return;
    sb_printf(b, "(");
    for (int k = 0; k < 2; ++k) {
        const spc_bsdf *n = bsdf->nested[k];
        if (k == 1 && (!n || n == bsdf->nested[0]))
            break;
        if (k == 1)
            sb_printf(b, ", ");
        int ni = n ? bsdf_index(s, n) : -1;
        if (ni >= 0)
            sb_printf(b, "#%d ", ni);
        describe_bsdf_type(b, s, n, depth + 1);
    }
    sb_printf(b, ")");
}

static void describe_texture(strbuf *b, const char *name, const spc_texture *t)
{
    if (!t)
        return;
    switch (t->type) {
    case SPC_TEX_CONSTANT:
        sb_printf(b, " %s=(%.4g, %.4g, %.4g)", name, t->value.r, t->value.g, t->value.b);
        break;
    case SPC_TEX_BITMAP:
        sb_printf(b, " %s=bitmap %dx%d", name, t->width, t->height);
        break;
    case SPC_TEX_CHECKERBOARD:
        sb_printf(b, " %s=checkerboard", name);
        break;
    case SPC_TEX_MESH_ATTRIBUTE:
        sb_printf(b, " %s=mesh attribute '%s'", name, t->attribute);
        break;
    }
}

char *spc_scene_describe(const spc_scene *s)
{
    strbuf b = {0};
    sb_printf(&b, "%s", ""); /* an empty scene still gets a (empty) string */
    for (int i = 0; s && i < s->nshapes; ++i) {
        const spc_shape *sh = s->shapes[i];
        sb_printf(&b, "shape %d: %s", i, shape_type_name(sh));
        if (sh->id[0])
            sb_printf(&b, " id='%s'", sh->id);
        if (sh->type == SPC_SHAPE_MESH)
            sb_printf(&b, " triangles %zu vertices %zu%s%s", sh->mesh.ntris, sh->mesh.nverts,
                      sh->mesh.n && !sh->face_normals ? " normals" : "", sh->mesh.uv ? " uvs" : "");
        else if (sh->type == SPC_SHAPE_SPHERE)
            sb_printf(&b, " center (%.4g, %.4g, %.4g) radius %.4g", sh->center.x, sh->center.y, sh->center.z,
                      sh->radius);
        sb_printf(&b, " bsdf ");
        int bi = bsdf_index(s, sh->bsdf);
        if (bi >= 0)
            sb_printf(&b, "#%d ", bi);
        describe_bsdf_type(&b, s, sh->bsdf, 0);
        if (sh->emitter)
            sb_printf(&b, " emitter #%d %s", sh->emitter->index, emitter_type_name(sh->emitter->type));
        if (sh->flip_normals)
            sb_printf(&b, " flip_normals");
        if (sh->interior_medium >= 0)
            sb_printf(&b, " interior medium #%d", sh->interior_medium);
        if (sh->exterior_medium >= 0)
            sb_printf(&b, " exterior medium #%d", sh->exterior_medium);
        sb_printf(&b, "\n");
    }
    for (int i = 0; s && i < s->nmedia; ++i) {
        const spc_medium *m = s->media[i];
        sb_printf(&b, "medium %d: %s", i, m->type == SPC_MEDIUM_HETEROGENEOUS ? "heterogeneous" : "homogeneous");
        if (m->id[0])
            sb_printf(&b, " id='%s'", m->id);
        if (m->type == SPC_MEDIUM_HETEROGENEOUS)
            sb_printf(&b, " sigma_t grid %dx%dx%d (largest values below)", m->sigma_t_vol.res[0], m->sigma_t_vol.res[1],
                      m->sigma_t_vol.res[2]);
        if (m->has_albedo_vol)
            sb_printf(&b, " albedo grid %dx%dx%d", m->albedo_vol.res[0], m->albedo_vol.res[1], m->albedo_vol.res[2]);
        sb_printf(&b, " sigma_a=(%.4g, %.4g, %.4g) sigma_s=(%.4g, %.4g, %.4g) phase %s", m->sigma_a.r, m->sigma_a.g,
                  m->sigma_a.b, m->sigma_s.r, m->sigma_s.g, m->sigma_s.b, m->phase.type == SPC_PHASE_HG ? "hg" : "isotropic");
        if (m->phase.type == SPC_PHASE_HG)
            sb_printf(&b, " g=%.4g", m->phase.g);
        sb_printf(&b, "%s\n", i == s->camera_medium ? " (the camera's)" : "");
    }
    for (int i = 0; s && i < s->nbsdfs; ++i) {
        const spc_bsdf *bsdf = s->bsdfs[i];
        sb_printf(&b, "bsdf %d: ", i);
        describe_bsdf_type(&b, s, bsdf, 0);
        switch (bsdf->type) {
        case SPC_BSDF_DIFFUSE:
        case SPC_BSDF_ROUGHDIFFUSE:
            describe_texture(&b, "reflectance", bsdf->reflectance);
            break;
        case SPC_BSDF_DIELECTRIC:
        case SPC_BSDF_THINDIELECTRIC:
        case SPC_BSDF_ROUGHDIELECTRIC:
        case SPC_BSDF_PLASTIC:
        case SPC_BSDF_ROUGHPLASTIC:
        case SPC_BSDF_PPLASTIC:
            sb_printf(&b, " eta=%.4g", bsdf->eta);
            break;
        case SPC_BSDF_CONDUCTOR:
        case SPC_BSDF_ROUGHCONDUCTOR:
            if (bsdf->cond_k.r < 0.0)
                sb_printf(&b, " mirror");
            else
                sb_printf(&b, " eta=(%.3g, %.3g, %.3g) k=(%.3g, %.3g, %.3g)", bsdf->cond_eta.r, bsdf->cond_eta.g,
                          bsdf->cond_eta.b, bsdf->cond_k.r, bsdf->cond_k.g, bsdf->cond_k.b);
            break;
        case SPC_BSDF_PHONG:
            sb_printf(&b, " exponent=%.4g", bsdf->exponent);
            break;
        case SPC_BSDF_PRINCIPLED:
            sb_printf(&b, " eta=%.4g", bsdf->eta);
            describe_texture(&b, "base_color", bsdf->pr.base_color);
            break;
        case SPC_BSDF_PRINCIPLEDTHIN:
            describe_texture(&b, "base_color", bsdf->pr.base_color);
            break;
        case SPC_BSDF_TWOSIDED:
        case SPC_BSDF_NORMALMAP:
        case SPC_BSDF_BUMPMAP:
        case SPC_BSDF_NULL:
        case SPC_BSDF_MASK:
        case SPC_BSDF_BLENDBSDF:
            break;
        }
        switch (bsdf->type) {
        case SPC_BSDF_ROUGHCONDUCTOR:
        case SPC_BSDF_ROUGHDIELECTRIC:
        case SPC_BSDF_ROUGHPLASTIC:
        case SPC_BSDF_PPLASTIC:
            sb_printf(&b, " %s", bsdf->distribution == SPC_MICROFACET_GGX ? "ggx" : "beckmann");
            describe_texture(&b, "alpha_u", bsdf->alpha_u);
            if (bsdf->alpha_v != bsdf->alpha_u)
                describe_texture(&b, "alpha_v", bsdf->alpha_v);
            break;
        case SPC_BSDF_DIFFUSE:
        case SPC_BSDF_ROUGHDIFFUSE:
        case SPC_BSDF_PHONG:
        case SPC_BSDF_CONDUCTOR:
        case SPC_BSDF_DIELECTRIC:
        case SPC_BSDF_THINDIELECTRIC:
        case SPC_BSDF_PLASTIC:
        case SPC_BSDF_TWOSIDED:
        case SPC_BSDF_NORMALMAP:
        case SPC_BSDF_BUMPMAP:
        case SPC_BSDF_NULL:
        case SPC_BSDF_MASK:
        case SPC_BSDF_BLENDBSDF:
        case SPC_BSDF_PRINCIPLED:
        case SPC_BSDF_PRINCIPLEDTHIN:
            break;
        }
        sb_printf(&b, "\n");
    }
    for (int i = 0; s && i < s->nemitters; ++i) {
        const spc_emitter *e = s->emitters[i];
        sb_printf(&b, "emitter %d: %s", i, emitter_type_name(e->type));
        switch (e->type) {
        case SPC_EMITTER_POINT:
        case SPC_EMITTER_SPOT:
            sb_printf(&b, " position (%.4g, %.4g, %.4g) intensity (%.4g, %.4g, %.4g)", e->position.x, e->position.y,
                      e->position.z, e->intensity.r, e->intensity.g, e->intensity.b);
            break;
        case SPC_EMITTER_PROJECTOR:
            sb_printf(&b, " position (%.4g, %.4g, %.4g) scale %.4g image %.4g x %.4g at z = 1", e->position.x,
                      e->position.y, e->position.z, e->scale, 2.0 * e->tan_x, 2.0 * e->tan_y);
            describe_texture(&b, "irradiance", e->texture);
            break;
        case SPC_EMITTER_DIRECTIONAL:
            sb_printf(&b, " direction (%.4g, %.4g, %.4g) irradiance (%.4g, %.4g, %.4g)", e->direction.x,
                      e->direction.y, e->direction.z, e->irradiance.r, e->irradiance.g, e->irradiance.b);
            break;
        case SPC_EMITTER_AREA: {
            int si = e->shape ? shape_index(s, e->shape) : e->shape_index;
            sb_printf(&b, " shape #%d", si);
            if (e->shape && e->shape->id[0])
                sb_printf(&b, " '%s'", e->shape->id);
            describe_texture(&b, "radiance", e->radiance);
            break;
        }
        case SPC_EMITTER_CONSTANT:
            describe_texture(&b, "radiance", e->radiance);
            break;
        case SPC_EMITTER_ENVMAP:
            describe_texture(&b, "radiance", e->radiance);
            sb_printf(&b, " scale %.4g", e->scale);
            break;
        }
        if (e->power > 0.0)
            sb_printf(&b, " power %.4g", e->power);
        if (s->light_pmf)
            sb_printf(&b, " pmf %.4g", s->light_pmf[i]);
        sb_printf(&b, "\n");
    }
    if (b.failed) {
        free(b.data);
        return NULL;
    }
    return b.data;
}

char *spc_scene_plan(const spc_scene *s, const char *integrator, const char *specular_nee)
{
    /* the plan and the pilot render a render at the scene's own size, samples and all cores would
     * make */
    spc_render_options o;
    spc_render_options_init(&o);
    o.integrator = integrator;
    o.specular_nee = specular_nee;
    spc_snee_plan plan;
    spc_driver_plan(s, &o, &plan);
    spc_snee_pilot pilot;
    spc_snee_pilot_run(s, &o, &plan, &pilot);
    int chain = s->integrator.specular_max_chain > 0 ? s->integrator.specular_max_chain : 2;
    int n = spc_snee_plan_describe(s, &plan, chain, NULL, 0);
    char *buf = malloc((size_t)n + 1);
    if (buf)
        spc_snee_plan_describe(s, &plan, chain, buf, (size_t)n + 1);
    return buf;
}

char *spc_specular_nee_help(int indent, int width) { return spc_snee_options_help(indent, width); }
