/*
 * scene/scene.c: scene ownership, finalization (sampling tables, light selection by power,
 * acceleration structure) and the ray queries integrators use.
 */
#include "scene/scene.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/accel.h"
#include "bsdf/diffuse_view.h"

#define GROW(arr, n, cap, type)                                                                                      \
    do {                                                                                                              \
        if ((n) == (cap)) {                                                                                           \
            int ncap = (cap) ? 2 * (cap) : 16;                                                                        \
            type **na = realloc((arr), (size_t)ncap * sizeof(type *));                                                \
            if (!na)                                                                                                  \
                return NULL;                                                                                          \
            (arr) = na;                                                                                               \
            (cap) = ncap;                                                                                             \
        }                                                                                                             \
    } while (0)

spc_scene *spc_scene_create(void)
{
    spc_scene *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    spc_scene_set_defaults(s);
    return s;
}

bool spc_fov_tangents(double fov, spc_fov_axis axis, int width, int height, double *tan_x, double *tan_y)
{
    double t = tan(0.5 * fov * SPC_PI / 180.0);
    if (!(t > 0.0) || !isfinite(t) || width <= 0 || height <= 0)
        return false;
    double aspect = (double)width / (double)height;
    if (axis == SPC_FOV_SMALLER)
        axis = aspect > 1.0 ? SPC_FOV_Y : SPC_FOV_X;
    else if (axis == SPC_FOV_LARGER)
        axis = aspect > 1.0 ? SPC_FOV_X : SPC_FOV_Y;
    switch (axis) {
    case SPC_FOV_X:
        *tan_x = t;
        *tan_y = t / aspect;
        break;
    case SPC_FOV_Y:
        *tan_y = t;
        *tan_x = t * aspect;
        break;
    case SPC_FOV_DIAGONAL: {
        double diag = sqrt((double)width * width + (double)height * height);
        *tan_x = t * width / diag;
        *tan_y = t * height / diag;
        break;
    }
    case SPC_FOV_SMALLER:
    case SPC_FOV_LARGER: break;
    }
    return true;
}

void spc_scene_set_defaults(spc_scene *s)
{
    s->camera.type = SPC_CAMERA_PERSPECTIVE;
    s->accel_robust = true;
    s->camera.to_world = spc_mat4_identity();
    s->camera.fov = 45.0;
    s->camera.fov_axis = SPC_FOV_X;
    s->camera.near_clip = 1e-2;
    s->camera.far_clip = 1e4;
    s->film.width = 768;
    s->film.height = 576;
    s->film.crop_x = s->film.crop_y = s->film.crop_w = s->film.crop_h = 0;
    s->film.rfilter = SPC_RFILTER_GAUSSIAN;
    s->film.filter_stddev = 0.5;
    s->film.filter_radius = 2.0;
    snprintf(s->integrator.type, sizeof s->integrator.type, "path");
    s->integrator.max_depth = -1;
    s->integrator.rr_depth = 5;
    s->integrator.hide_emitters = false;
    s->integrator.specular_nee[0] = '\0';
    s->integrator.specular_max_chain = 2;
    s->spp = 4;
    s->seed = 0;
    s->camera_medium = -1;
}

void spc_scene_destroy(spc_scene *s)
{
    if (!s)
        return;
    spc_accel_destroy(s->accel);
    for (int k = 0; k < 2; ++k) {
        free(s->casters[k].idx);
        free(s->casters[k].bound_c);
        free(s->casters[k].bound_r);
    }
    for (int i = 0; i < s->nshapes; ++i) {
        spc_shape_release(s->shapes[i]);
        free(s->shapes[i]);
    }
    for (int i = 0; i < s->nbsdfs; ++i)
        free(s->bsdfs[i]);
    for (int i = 0; i < s->nemitters; ++i) {
        spc_emitter_release(s->emitters[i]);
        free(s->emitters[i]);
    }
    for (int i = 0; i < s->ntextures; ++i) {
        spc_texture_release(s->textures[i]);
        free(s->textures[i]);
    }
    for (int i = 0; i < s->nmedia; ++i) {
        spc_medium_release(s->media[i]);
        free(s->media[i]);
    }
    free(s->media);
    free(s->shapes);
    free(s->bsdfs);
    free(s->emitters);
    free(s->textures);
    spc_distrib1d_release(&s->light_distrib);
    free(s->light_pmf);
    free(s);
}

spc_shape *spc_scene_new_shape(spc_scene *s)
{
    GROW(s->shapes, s->nshapes, s->cap_shapes, spc_shape);
    spc_shape *o = calloc(1, sizeof *o);
    if (!o)
        return NULL;
    o->interior_medium = o->exterior_medium = -1;
    o->to_world = o->to_local = spc_mat4_identity();
    o->caustic_flags = SPC_CAUSTIC_CASTER | SPC_CAUSTIC_RECEIVER;
    s->shapes[s->nshapes++] = o;
    return o;
}

spc_bsdf *spc_scene_new_bsdf(spc_scene *s)
{
    GROW(s->bsdfs, s->nbsdfs, s->cap_bsdfs, spc_bsdf);
    spc_bsdf *o = calloc(1, sizeof *o);
    if (!o)
        return NULL;
    o->sample_visible = true;
    o->eta = 1.5046 / 1.000277;
    s->bsdfs[s->nbsdfs++] = o;
    return o;
}

spc_emitter *spc_scene_new_emitter(spc_scene *s)
{
    GROW(s->emitters, s->nemitters, s->cap_emitters, spc_emitter);
    spc_emitter *o = calloc(1, sizeof *o);
    if (!o)
        return NULL;
    o->to_world = o->to_local = spc_mat4_identity();
    o->scale = 1.0;
    o->shape_index = -1;
    o->index = s->nemitters;
    s->emitters[s->nemitters++] = o;
    return o;
}

spc_texture *spc_scene_new_texture(spc_scene *s)
{
    GROW(s->textures, s->ntextures, s->cap_textures, spc_texture);
    spc_texture *o = calloc(1, sizeof *o);
    if (!o)
        return NULL;
    spc_texture_init_constant(o, spc_rgb1(0.0));
    s->textures[s->ntextures++] = o;
    return o;
}

spc_medium *spc_scene_new_medium(spc_scene *s)
{
    GROW(s->media, s->nmedia, s->cap_media, spc_medium);
    spc_medium *o = calloc(1, sizeof *o);
    if (!o)
        return NULL;
    spc_medium_init_homogeneous(o, spc_rgb1(0.0), spc_rgb1(0.0));
    o->index = s->nmedia;
    s->media[s->nmedia++] = o;
    return o;
}

const spc_texture *spc_scene_constant(spc_scene *s, spc_rgb value)
{
    spc_texture *t = spc_scene_new_texture(s);
    if (t)
        spc_texture_init_constant(t, value);
    return t;
}

bool spc_scene_caster_allowed(unsigned flags, int k)
{
    bool single = (flags & SPC_CAUSTIC_CASTER_SINGLE) != 0, multi = (flags & SPC_CAUSTIC_CASTER_MULTI) != 0;
    if (single || multi)
        return k == 1 ? single : multi;
    return (flags & SPC_CAUSTIC_CASTER) != 0;
}

bool spc_scene_shape_is_caster(const spc_shape *s, bool any_surface, double *eta)
{
    double e;
    /* curves: Embree's float hits and no normal derivatives along them; sdfgrid: its normal has no
     * derivatives (piecewise trilinear); so neither is ever a chain vertex */
    if (!s || s->emitter || s->type == SPC_SHAPE_CURVE || s->type == SPC_SHAPE_SDFGRID ||
        !spc_bsdf_is_specular_interface(s->bsdf, &e) || !spc_bsdf_chain_mappable(s->bsdf, s->type))
        return false;
    if (eta)
        *eta = e;
    if (any_surface)
        return true;
    return spc_scene_caster_allowed(s->caustic_flags, 1) || spc_scene_caster_allowed(s->caustic_flags, 2);
}

/* A sphere (c, r) that holds shape sh (spc_scene_casters.bound_c, bound_r). */
static void caster_bound(const spc_shape *sh, spc_vec3 *c, double *r)
{
    *c = spc_scale(spc_add(sh->bbox_min, sh->bbox_max), 0.5);
    *r = 0.5 * spc_length(spc_sub(sh->bbox_max, sh->bbox_min));
    if (sh->type == SPC_SHAPE_SPHERE) {
        *c = sh->center;
        *r = sh->radius;
    } else if (sh->type == SPC_SHAPE_MESH && sh->mesh.nverts > 0 && sh->mesh.p) {
        double d2 = 0.0;
        for (size_t v = 0; v < sh->mesh.nverts; ++v) {
            spc_vec3 q = spc_v3(sh->mesh.p[3 * v], sh->mesh.p[3 * v + 1], sh->mesh.p[3 * v + 2]);
            d2 = fmax(d2, spc_length2(spc_sub(q, *c)));
        }
        /* float vertices: a relative margin so that no vertex lies outside */
        *r = fmin(*r, sqrt(d2) * (1.0 + 1e-6));
    }
}

/* The caster list of one any_surface setting (spc_scene_casters); false if memory runs out. */
static bool casters_build(const spc_scene *s, bool any_surface, spc_scene_casters *c)
{
    free(c->idx);
    free(c->bound_c);
    free(c->bound_r);
    memset(c, 0, sizeof *c);
    size_t cap = (size_t)(s->nshapes > 0 ? s->nshapes : 1);
    c->idx = malloc(cap * sizeof *c->idx);
    c->bound_c = malloc(cap * sizeof *c->bound_c);
    c->bound_r = malloc(cap * sizeof *c->bound_r);
    if (!c->idx || !c->bound_c || !c->bound_r)
        return false;
    spc_vec3 lo = spc_v3(INFINITY, INFINITY, INFINITY), hi = spc_neg(lo);
    for (int i = 0; i < s->nshapes; ++i) {
        const spc_shape *sh = s->shapes[i];
        if (!spc_scene_shape_is_caster(sh, any_surface, NULL))
            continue;
        caster_bound(sh, &c->bound_c[c->n], &c->bound_r[c->n]);
        c->idx[c->n++] = i;
        lo = spc_vmin(lo, sh->bbox_min);
        hi = spc_vmax(hi, sh->bbox_max);
    }
    if (c->n > 0) {
        c->center = spc_scale(spc_add(lo, hi), 0.5);
        c->radius = 0.5 * spc_length(spc_sub(hi, lo));
    }
    return true;
}

spc_status spc_scene_finalize(spc_scene *s, spc_error *err)
{
    if (s->finalized)
        return SPC_OK;
    const char *file = s->path[0] ? s->path : NULL;
    spc_bsdf *default_bsdf = NULL;
    spc_vec3 lo = spc_v3(INFINITY, INFINITY, INFINITY), hi = spc_neg(lo);
    for (int i = 0; i < s->nbsdfs; ++i)
        spc_bsdf_prepare(s->bsdfs[i]);
    size_t kept_frames = 0; /* triangles whose frames the meshes keep (SPC_MESH_FRAME_MAX_TRIS) */
    for (int i = 0; i < s->nshapes; ++i) {
        spc_shape *sh = s->shapes[i];
        if (!sh->bsdf) {
            if (!default_bsdf) {
                default_bsdf = spc_scene_new_bsdf(s);
                const spc_texture *r = default_bsdf ? spc_scene_constant(s, spc_rgb1(0.5)) : NULL;
                if (!r)
                    return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
                default_bsdf->type = SPC_BSDF_DIFFUSE;
                default_bsdf->reflectance = r;
            }
            sh->bsdf = default_bsdf;
        }
        sh->lazy_derivs = sh->type == SPC_SHAPE_MESH && !spc_bsdf_reads_derivatives(sh->bsdf);
        sh->uv_unread = (sh->type == SPC_SHAPE_SPHERE || sh->type == SPC_SHAPE_MESH) && !spc_bsdf_reads_uv(sh->bsdf) &&
                        !(sh->emitter && sh->emitter->radiance && sh->emitter->radiance->type != SPC_TEX_CONSTANT);
        sh->diffuse_const = spc_diffuse_view_const(sh->bsdf, sh->diffuse_sign, sh->diffuse_albedo);
        if (sh->interior_medium >= s->nmedia || sh->exterior_medium >= s->nmedia)
            return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "shape %d ('%s') refers to a medium that does not exist",
                                 i, sh->id);
        spc_status ps = spc_shape_prepare(sh);
        if (ps == SPC_ERR_NOMEM)
            return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0,
                                 "out of memory for the area sampling table of shape %d ('%s')", i, sh->id);
        if (ps != SPC_OK)
            return spc_error_set(err, ps, file, 0, 0, "shape %d ('%s') has zero area or invalid geometry", i, sh->id);
        /* the kept triangle frames' budget is the scene's, not each mesh's */
        if (sh->tri_frame) {
            if (sh->mesh.ntris > SPC_MESH_FRAME_MAX_TRIS - kept_frames)
                spc_shape_drop_frames(sh);
            else
                kept_frames += sh->mesh.ntris;
        }
        lo = spc_vmin(lo, sh->bbox_min);
        hi = spc_vmax(hi, sh->bbox_max);
    }
    if (s->camera_medium >= s->nmedia)
        return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "the camera's medium %d does not exist", s->camera_medium);
    if (s->nshapes == 0) {
        lo = spc_v3(-1, -1, -1);
        hi = spc_v3(1, 1, 1);
    }
    s->bbox_min = lo;
    s->bbox_max = hi;
    s->center = spc_scale(spc_add(lo, hi), 0.5);
    s->radius = spc_max(0.5 * spc_length(spc_sub(hi, lo)), 1e-6 * (spc_max_abs(s->center) + 1e-30));
    if (!(s->radius > 0.0) || !isfinite(s->radius))
        s->radius = 1.0;

    s->env = NULL;
    double *power = s->nemitters ? malloc((size_t)s->nemitters * sizeof(double)) : NULL;
    s->light_pmf = s->nemitters ? calloc((size_t)s->nemitters, sizeof(double)) : NULL;
    if (s->nemitters && (!power || !s->light_pmf)) {
        free(power);
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
    }
    for (int i = 0; i < s->nemitters; ++i) {
        spc_emitter *e = s->emitters[i];
        e->index = i;
        if (e->type == SPC_EMITTER_AREA) {
            if (e->shape_index < 0 || e->shape_index >= s->nshapes) {
                free(power);
                return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "area emitter %d is not attached to a shape", i);
            }
            e->shape = s->shapes[e->shape_index];
        }
        if (spc_emitter_is_infinite(e)) {
            if (s->env) {
                free(power);
                return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                                     "a scene may hold one environment emitter (constant or envmap); found two");
            }
            s->env = e;
        }
        bool lit = spc_emitter_prepare(e, s->center, s->radius);
        if (isnan(e->power) || e->power < 0.0 || isinf(e->power)) {
            /* a negative or overflowing radiance would silently black out or break light selection */
            double p = e->power;
            free(power);
            return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                                 "emitter %d has power %g: its radiance, intensity or irradiance must be finite, "
                                 "non-negative and small enough for its size",
                                 i, p);
        }
        if (!lit)
            e->power = 0.0; /* zero-power light: visible, never sampled */
        power[i] = (e->power > 0.0 && isfinite(e->power)) ? e->power : 0.0;
    }
    if (s->nemitters && spc_distrib1d_init(&s->light_distrib, power, (size_t)s->nemitters)) {
        for (int i = 0; i < s->nemitters; ++i)
            s->light_pmf[i] = s->light_distrib.pmf[i];
    }
    free(power);

    for (int k = 0; k < 2; ++k)
        if (!casters_build(s, k == 1, &s->casters[k]))
            return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");

    s->accel = spc_accel_create(s, err);
    if (!s->accel)
        return err ? err->code : SPC_ERR_ACCEL;
    s->packet_width = spc_accel_packet_width(s->accel);
    s->prefetch_hits = false;
    for (int i = 0; i < s->nshapes; ++i)
        if (s->shapes[i]->type == SPC_SHAPE_MESH && !s->shapes[i]->tri_frame)
            s->prefetch_hits = true;
    s->finalized = true;
    return SPC_OK;
}

bool spc_scene_intersect(const spc_scene *s, const spc_ray *r, spc_hit *h)
{
    int shape, prim;
    double u, v, t;
    if (!spc_accel_intersect(s->accel, r, &shape, &prim, &u, &v, &t))
        return false;
    h->shape_index = shape;
    spc_shape_fill_hit(s->shapes[shape], prim, u, v, r, t, h);
    return true;
}

bool spc_scene_occluded(const spc_scene *s, const spc_ray *r) { return spc_accel_occluded(s->accel, r); }

_Static_assert(SPC_SCENE_PACKET == SPC_ACCEL_PACKET, "one packet size");

int spc_scene_packet_width(const spc_scene *s) { return s->packet_width; }

/* Asks for the lanes' triangle records, then their vertices, before the first fill: on a big mesh
 * each hit's reads miss the cache, and asking for all lanes at once overlaps those misses. */
static void prefetch_packet(const spc_scene *s, const int *shape, const int *prim)
{
    if (!s->prefetch_hits)
        return;
    const int n = s->packet_width;
    for (int i = 0; i < n; ++i)
        if (shape[i] >= 0)
            spc_shape_prefetch_hit(s->shapes[shape[i]], prim[i]);
    for (int i = 0; i < n; ++i)
        if (shape[i] >= 0)
            spc_shape_prefetch_vertices(s->shapes[shape[i]], prim[i]);
}

/* The hit records of a packet's n lanes from Embree's answers: n the scene's packet width, a constant
 * in each inlined copy (fill_packet). */
static inline __attribute__((always_inline)) void fill_lanes(const spc_scene *s, const spc_ray *const *r,
                                                             const int *shape, const int *prim, const double *u,
                                                             const double *v, const double *t, spc_hit *h, bool *hit,
                                                             const int n)
{
    for (int i = 0; i < n; ++i) {
        hit[i] = shape[i] >= 0;
        if (!hit[i])
            continue;
        h[i].shape_index = shape[i];
        spc_shape_fill_hit_shading(s->shapes[shape[i]], prim[i], u[i], v[i], r[i], t[i], &h[i]);
    }
}

/* The hit records of a packet's lanes from Embree's answers. */
static void fill_packet(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET], const int *shape, const int *prim,
                        const double *u, const double *v, const double *t, spc_hit h[SPC_SCENE_PACKET],
                        bool hit[SPC_SCENE_PACKET])
{
    prefetch_packet(s, shape, prim);
    if (s->packet_width == 8)
        fill_lanes(s, r, shape, prim, u, v, t, h, hit, 8);
    else
        fill_lanes(s, r, shape, prim, u, v, t, h, hit, 16);
}

void spc_scene_intersect_packet(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET], spc_hit h[SPC_SCENE_PACKET],
                                bool hit[SPC_SCENE_PACKET])
{
    int shape[SPC_ACCEL_PACKET], prim[SPC_ACCEL_PACKET];
    double u[SPC_ACCEL_PACKET], v[SPC_ACCEL_PACKET], t[SPC_ACCEL_PACKET];
    spc_accel_intersect_packet(s->accel, r, shape, prim, u, v, t);
    fill_packet(s, r, shape, prim, u, v, t, h, hit);
}

void spc_scene_intersect_packet_coherent(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                                         spc_hit h[SPC_SCENE_PACKET], bool hit[SPC_SCENE_PACKET])
{
    int shape[SPC_ACCEL_PACKET], prim[SPC_ACCEL_PACKET];
    double u[SPC_ACCEL_PACKET], v[SPC_ACCEL_PACKET], t[SPC_ACCEL_PACKET];
    spc_accel_intersect_packet_coherent(s->accel, r, shape, prim, u, v, t);
    fill_packet(s, r, shape, prim, u, v, t, h, hit);
}

void spc_scene_trace(const spc_scene *s, const spc_ray *r, spc_scene_answer *a)
{
    if (!spc_accel_intersect(s->accel, r, &a->shape, &a->prim, &a->u, &a->v, &a->t))
        a->shape = -1;
}

void spc_scene_trace_packet_coherent(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                                     spc_scene_answer a[SPC_SCENE_PACKET])
{
    int shape[SPC_ACCEL_PACKET], prim[SPC_ACCEL_PACKET];
    double u[SPC_ACCEL_PACKET], v[SPC_ACCEL_PACKET], t[SPC_ACCEL_PACKET];
    spc_accel_intersect_packet_coherent(s->accel, r, shape, prim, u, v, t);
    const int n = s->packet_width;
    for (int i = 0; i < n; ++i)
        a[i] = (spc_scene_answer){shape[i], prim[i], u[i], v[i], t[i]};
    prefetch_packet(s, shape, prim);
}

bool spc_scene_fill_answer(const spc_scene *s, const spc_ray *r, const spc_scene_answer *a, spc_hit *h)
{
    if (a->shape < 0)
        return false;
    h->shape_index = a->shape;
    spc_shape_fill_hit_shading(s->shapes[a->shape], a->prim, a->u, a->v, r, a->t, h);
    return true;
}

void spc_scene_occluded_packet(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                               bool occluded[SPC_SCENE_PACKET])
{
    spc_accel_occluded_packet(s->accel, r, occluded);
}

bool spc_scene_occluded_light(const spc_scene *s, const spc_ray *r, const spc_emitter *e)
{
    return spc_accel_occluded_skip(s->accel, r, spc_scene_light_skip(e));
}

void spc_scene_occluded_light_packet_coherent(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                                              const spc_emitter *const e[SPC_SCENE_PACKET],
                                              bool occluded[SPC_SCENE_PACKET])
{
    int skip[SPC_SCENE_PACKET];
    const int n = s->packet_width;
    for (int i = 0; i < n; ++i)
        skip[i] = r[i] ? spc_scene_light_skip(e[i]) : -1;
    spc_accel_occluded_packet_skip_coherent(s->accel, r, skip, occluded);
}

void spc_scene_occluded_light_packet(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                                     const spc_emitter *const e[SPC_SCENE_PACKET], bool occluded[SPC_SCENE_PACKET])
{
    if (!spc_accel_skips_any(s->accel)) {
        spc_accel_occluded_packet(s->accel, r, occluded);
        return;
    }
    int skip[SPC_SCENE_PACKET];
    const int n = s->packet_width;
    for (int i = 0; i < n; ++i)
        skip[i] = r[i] ? spc_scene_light_skip(e[i]) : -1;
    spc_accel_occluded_packet_skip(s->accel, r, skip, occluded);
}

const spc_emitter *spc_scene_sample_emitter(const spc_scene *s, double u, double *pmf)
{
    if (s->light_distrib.n == 0)
        return NULL;
    size_t i = spc_distrib1d_sample(&s->light_distrib, u, NULL);
    *pmf = s->light_distrib.pmf[i];
    return *pmf > 0.0 ? s->emitters[i] : NULL;
}

double spc_scene_emitter_pmf(const spc_scene *s, const spc_emitter *e)
{
    if (!e || !s->light_pmf || e->index < 0 || e->index >= s->nemitters)
        return 0.0;
    return s->light_pmf[e->index];
}

uint64_t spc_scene_rays_traced(void) { return spc_accel_rays_traced(); }
