/*
 * device/opencl.c: the opencl render device: checks that a scene holds only what the kernels of
 * kernels.cl support, flattens it into plain arrays (SDF trees as postfix programs from
 * spc_sdf_flatten, the scene's own SDF description: no second parser), compiles the kernels and
 * renders batches of passes for the driver.
 *
 * Buffer layouts (the kernels' *_STRIDE macros):
 *   shape_i  8 ints per shape: type (0 sphere, 1 sdf, 2 mesh), bsdf, emitter (-1 none),
 *            flip_normals, first node / triangle, node / triangle count
 *   shape_f  16 floats: sphere centre, radius; sdf padded bounds lo, hi, size; mesh area
 *   node_i / node_f  one SDF instruction: type; composed world-to-node rows (12), scale, params (8)
 *   tri      16 floats: p0, e1, e2, normal (as the CPU's shading normal, flip applied), cumulative
 *            area fraction within its mesh
 *   bsdf_i / bsdf_f  type (0 diffuse, 1 conductor, 2 dielectric), 12 floats: diffuse R; conductor
 *            eta, k (k < 0: perfect mirror), specular reflectance; dielectric eta, specular
 *            reflectance, specular transmittance
 *   emit_i / emit_f  shape; radiance, pmf (the scene's power-proportional choice), cdf
 *   cam_f    camera rows (12), tan_x, tan_y, near, far, filter radius, filter type (0 box), world-to-
 *            camera rows (12), |det| of the camera's linear part, film pixels / window pixels
 *   filt     the filter's 31 step densities and 32 cumulative masses (render/film.c)
 *
 * Debugging: the environment variable SPC_CL_DEBUG adds kernel build options; "-DONLY_S=s
 * -DONLY_T=t" renders only bdpt's strategy (s, t), unweighted, or weighted with "-DWEIGHTED" (the
 * CPU's --strategy s,t [--strategy-weighted]), to compare one strategy with the CPU's.
 * SPC_CL_LAUNCH_ITEMS=n (below the default) makes the kernel launches smaller: the image must not
 * change (tests/test_opencl.c cuts passes into many launches with it).
 *
 * Built without OpenCL (CMake found no OpenCL), every entry point says so.
 */
#include "device/device.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene/scene.h"
#include "scene/sdf.h"

bool spc_device_parse(const char *name, bool *opencl, int *index)
{
    *opencl = false;
    *index = 0;
    if (!name || !name[0] || strcmp(name, "cpu") == 0)
        return true;
    if (strncmp(name, "opencl", 6) != 0)
        return false;
    if (name[6] == '\0') {
        *opencl = true;
        return true;
    }
    if (name[6] != ':' || name[7] == '\0')
        return false;
    char *end;
    long v = strtol(name + 7, &end, 10);
    if (*end != '\0' || v < 0 || v > 1000)
        return false;
    *opencl = true;
    *index = (int)v;
    return true;
}

#ifndef SPC_HAVE_OPENCL

spc_status spc_cl_create(const spc_render_ctx *ctx, int device_index, bool aovs, spc_cl_renderer **out,
                         spc_error *err)
{
    (void)ctx;
    (void)device_index;
    (void)aovs;
    *out = NULL;
    return spc_error_set(err, SPC_ERR_PLUGIN, NULL, 0, 0,
                         "opencl device: not available (specula was built without OpenCL)");
}

void spc_cl_destroy(spc_cl_renderer *r) { (void)r; }

spc_status spc_cl_render_passes(spc_cl_renderer *r, int pass0, int npasses, uint64_t seed, double *buf, int stride,
                                uint64_t *invalid, uint64_t *rays, spc_error *err)
{
    (void)r;
    (void)rays;
    (void)pass0;
    (void)npasses;
    (void)seed;
    (void)buf;
    (void)stride;
    (void)invalid;
    return spc_error_set(err, SPC_ERR_PLUGIN, NULL, 0, 0, "opencl device: not available");
}

char *spc_cl_describe_devices(void)
{
    return strdup("cpu        specula's threads (the default)\n"
                  "opencl: not available (specula was built without OpenCL)\n");
}

#else

#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#include "device/kernels_cl.h" /* generated: spc_kernels_cl[], spc_kernels_cl_len */

/* Triangles a mesh may have on the device: the kernels test them one by one (rectangles and
 * cubes, not models). */
#define CL_MAX_TRIANGLES 64
/* Instructions of one SDF program and its stack depth (the kernel's SDF_STACK). */
#define CL_MAX_SDF_NODES 256
#define CL_MAX_SDF_STACK 16
/* Longest bdpt path on the device (the kernel's BDPT_MAX_VERTS - 1 segments; max_depth -1 renders
 * paths up to it, Russian roulette making longer ones rare), and the light subpath's splats per
 * sample (MAX_SPLATS). */
#define CL_BDPT_MAX_DEPTH 19
#define CL_MAX_SPLATS 32
/* Work items per kernel launch: bounds the output and splat buffers (16 MiB of floats) and the
 * time one launch holds a GPU. */
#define CL_LAUNCH_ITEMS (1 << 18)
#define CL_LAUNCH_ITEMS_BDPT (1 << 15)
/* Work-group size: the implementation's own choice can be large enough for PoCL to run out of
 * stack with bdpt's two vertex arrays per work item; 64 also suits GPUs (two warps or one
 * wavefront). */
#define CL_GROUP 64

enum { SHAPE_I = 8, SHAPE_F = 16, NODE_F = 24, TRI_F = 16, BSDF_F = 12, EMIT_F = 8, CAM_F = 32, FILT_F = 63 };

typedef struct grow {
    void *p;
    size_t n, cap, elem;
} grow;

static void *grow_add(grow *g, size_t count)
{
    if (g->n + count > g->cap) {
        size_t cap = g->cap ? g->cap : 16;
        while (cap < g->n + count)
            cap *= 2;
        void *np = realloc(g->p, cap * g->elem);
        if (!np)
            return NULL;
        g->p = np;
        g->cap = cap;
    }
    void *at = (char *)g->p + g->n * g->elem;
    memset(at, 0, count * g->elem);
    g->n += count;
    return at;
}

typedef struct host_scene {
    grow shape_i, shape_f, node_i, node_f, tri, bsdf_i, bsdf_f, emit_i, emit_f;
    float cam_f[CAM_F];
    float filt[FILT_F + 1];
    float scale;
    int nshapes, nemitters;
} host_scene;

static void host_scene_release(host_scene *h)
{
    grow *all[] = {&h->shape_i, &h->shape_f, &h->node_i, &h->node_f, &h->tri,
                   &h->bsdf_i, &h->bsdf_f, &h->emit_i, &h->emit_f};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; ++i)
        free(all[i]->p);
}

static const char *emitter_name(spc_emitter_type t)
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

#define REFUSE(...) spc_error_set(err, SPC_ERR_PLUGIN, file, 0, 0, "opencl device: " __VA_ARGS__)

/* A constant texture's value, or false (textures are not on the device). NULL: the fallback. */
static bool constant(const spc_texture *t, spc_rgb fallback, float out[3])
{
    spc_rgb v = fallback;
    if (t) {
        if (t->type != SPC_TEX_CONSTANT)
            return false;
        v = t->value;
    }
    out[0] = (float)v.r;
    out[1] = (float)v.g;
    out[2] = (float)v.b;
    return true;
}

static spc_status add_bsdf(host_scene *hs, const spc_bsdf *b, const char *file, spc_error *err)
{
    int *bi = grow_add(&hs->bsdf_i, 1);
    float *bf = grow_add(&hs->bsdf_f, BSDF_F);
    if (!bi || !bf)
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
    const char *tex = NULL;
    switch (b->type) {
    case SPC_BSDF_DIFFUSE:
        *bi = 0;
        if (!constant(b->reflectance, spc_rgb1(0.5), bf))
            tex = "reflectance";
        break;
    case SPC_BSDF_CONDUCTOR:
        *bi = 1;
        bf[0] = (float)b->cond_eta.r;
        bf[1] = (float)b->cond_eta.g;
        bf[2] = (float)b->cond_eta.b;
        bf[3] = (float)b->cond_k.r;
        bf[4] = (float)b->cond_k.g;
        bf[5] = (float)b->cond_k.b;
        if (b->cond_k.r < 0.0)
            bf[3] = -1.0f;
        if (!constant(b->specular_reflectance, spc_rgb1(1.0), bf + 6))
            tex = "specular_reflectance";
        break;
    case SPC_BSDF_DIELECTRIC:
        *bi = 2;
        bf[0] = (float)b->eta;
        if (!constant(b->specular_reflectance, spc_rgb1(1.0), bf + 1))
            tex = "specular_reflectance";
        if (!constant(b->specular_transmittance, spc_rgb1(1.0), bf + 4))
            tex = "specular_transmittance";
        break;
    case SPC_BSDF_ROUGHDIFFUSE:
    case SPC_BSDF_PHONG:
    case SPC_BSDF_ROUGHCONDUCTOR:
    case SPC_BSDF_THINDIELECTRIC:
    case SPC_BSDF_ROUGHDIELECTRIC:
    case SPC_BSDF_PLASTIC:
    case SPC_BSDF_ROUGHPLASTIC:
    case SPC_BSDF_PPLASTIC:
    case SPC_BSDF_PRINCIPLED:
    case SPC_BSDF_PRINCIPLEDTHIN:
    case SPC_BSDF_TWOSIDED:
    case SPC_BSDF_NORMALMAP:
    case SPC_BSDF_BUMPMAP:
    case SPC_BSDF_NULL:
    case SPC_BSDF_MASK:
    case SPC_BSDF_BLENDBSDF:
        return REFUSE("bsdf '%s' not supported (diffuse, conductor, dielectric)", spc_bsdf_type_name(b->type));
    }
    if (tex)
        return REFUSE("bsdf '%s' with a textured %s not supported (constant values only)", spc_bsdf_type_name(b->type),
                      tex);
    return SPC_OK;
}

static spc_status add_sdf(host_scene *hs, const spc_shape *s, int *si, float *sf, const char *file, spc_error *err)
{
    spc_sdf_flat prog[CL_MAX_SDF_NODES];
    int depth = 0;
    int n = spc_sdf_flatten(s->sdf, prog, CL_MAX_SDF_NODES, &depth);
    if (n < 0 || n > CL_MAX_SDF_NODES)
        return REFUSE("sdf shape '%s' with %d nodes not supported (at most %d)", s->id, n, CL_MAX_SDF_NODES);
    if (depth > CL_MAX_SDF_STACK)
        return REFUSE("sdf shape '%s' nested %d deep not supported (at most %d)", s->id, depth, CL_MAX_SDF_STACK);
    si[4] = (int)hs->node_i.n;
    si[5] = n;
    int *ni = grow_add(&hs->node_i, (size_t)n);
    if (!ni)
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
    float *nf = grow_add(&hs->node_f, (size_t)n * NODE_F);
    if (!nf)
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
    for (int i = 0; i < n; ++i) {
        ni[i] = (int)prog[i].type;
        float *f = nf + (size_t)i * NODE_F;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                f[4 * r + c] = (float)prog[i].M[r][c];
        f[12] = (float)prog[i].s;
        for (int k = 0; k < 8; ++k)
            f[13 + k] = (float)prog[i].param[k];
    }
    spc_vec3 lo, hi;
    spc_sdf_bounds(s->sdf, &lo, &hi);
    sf[0] = (float)lo.x;
    sf[1] = (float)lo.y;
    sf[2] = (float)lo.z;
    sf[3] = (float)hi.x;
    sf[4] = (float)hi.y;
    sf[5] = (float)hi.z;
    sf[6] = (float)spc_sdf_size(s->sdf);
    return SPC_OK;
}

static spc_status add_mesh(host_scene *hs, const spc_shape *s, int *si, float *sf, const char *file, spc_error *err)
{
    const spc_mesh *m = &s->mesh;
    if (m->ntris > CL_MAX_TRIANGLES)
        return REFUSE("mesh '%s' of %zu triangles not supported (at most %d: rectangles, cubes)", s->id, m->ntris,
                      CL_MAX_TRIANGLES);
    si[4] = (int)(hs->tri.n / TRI_F);
    si[5] = (int)m->ntris;
    float *t = grow_add(&hs->tri, m->ntris * TRI_F);
    if (!t)
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
    double total = 0.0, *areas = malloc(m->ntris * sizeof *areas);
    if (!areas)
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
    for (size_t k = 0; k < m->ntris; ++k) {
        uint32_t i0 = m->idx[3 * k], i1 = m->idx[3 * k + 1], i2 = m->idx[3 * k + 2];
        spc_vec3 p0 = spc_mesh_p(m, i0), e1 = spc_sub(spc_mesh_p(m, i1), p0), e2 = spc_sub(spc_mesh_p(m, i2), p0);
        spc_vec3 c = spc_cross(e1, e2);
        areas[k] = 0.5 * spc_length(c);
        total += areas[k];
        spc_vec3 n = spc_normalize(c);
        if (m->n && !s->face_normals) {
            /* the CPU shades with the interpolated vertex normal: only flat ones are the same here */
            spc_vec3 n0 = spc_normalize(spc_mesh_n(m, i0));
            for (int j = 0; j < 3; ++j) {
                spc_vec3 nj = spc_normalize(spc_mesh_n(m, m->idx[3 * k + j]));
                if (fabs(fabs(spc_dot(nj, n)) - 1.0) > 1e-5 || spc_dot(nj, n0) < 0.0) {
                    free(areas);
                    return REFUSE("mesh '%s' with smooth vertex normals not supported (flat faces only)", s->id);
                }
            }
            if (spc_dot(n0, n) < 0.0)
                n = spc_neg(n);
        }
        if (s->flip_normals)
            n = spc_neg(n);
        float *f = t + k * TRI_F;
        spc_vec3 v[4] = {p0, e1, e2, n};
        for (int j = 0; j < 4; ++j) {
            f[3 * j] = (float)v[j].x;
            f[3 * j + 1] = (float)v[j].y;
            f[3 * j + 2] = (float)v[j].z;
        }
    }
    double acc = 0.0;
    for (size_t k = 0; k < m->ntris; ++k) {
        acc += areas[k];
        t[k * TRI_F + 12] = k + 1 == m->ntris ? 2.0f : (float)(acc / total);
    }
    free(areas);
    sf[0] = (float)total;
    return SPC_OK;
}

static spc_status build_scene(const spc_render_ctx *ctx, host_scene *hs, spc_error *err)
{
    const spc_scene *sc = ctx->scene;
    const char *file = sc->path[0] ? sc->path : NULL;
    hs->shape_i.elem = hs->node_i.elem = hs->bsdf_i.elem = hs->emit_i.elem = sizeof(int);
    hs->shape_f.elem = hs->node_f.elem = hs->tri.elem = hs->bsdf_f.elem = hs->emit_f.elem = sizeof(float);
    if (ctx->kind != SPC_INTEGRATOR_PATH && ctx->kind != SPC_INTEGRATOR_BDPT)
        return REFUSE("integrator '%s' not supported (path, bdpt)", spc_integrator_kind_name(ctx->kind));
    if (ctx->specular_nee != 0)
        return REFUSE("specular NEE not supported");
    if (ctx->strategy_s >= 0 || ctx->strategy_t >= 0 || ctx->strategy_images_depth > 0)
        return REFUSE("single strategies and strategy images not supported");
    if (ctx->kind == SPC_INTEGRATOR_BDPT && ctx->max_depth > CL_BDPT_MAX_DEPTH)
        return REFUSE("bdpt with max_depth %d not supported (1 to %d, or -1: paths up to %d segments)",
                      ctx->max_depth, CL_BDPT_MAX_DEPTH, CL_BDPT_MAX_DEPTH);
    if (sc->nmedia > 0)
        return REFUSE("participating media not supported");
    if (sc->camera.type != SPC_CAMERA_PERSPECTIVE)
        return REFUSE("sensor 'orthographic' not supported (perspective)");
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        if (e->type != SPC_EMITTER_AREA)
            return REFUSE("emitter '%s' not supported (area lights on spheres and meshes)", emitter_name(e->type));
        if (e->shape->type == SPC_SHAPE_SDF)
            return REFUSE("area emitter on sdf shape '%s' not supported (area lights on spheres and meshes)",
                          e->shape->id);
        if (e->radiance && e->radiance->type != SPC_TEX_CONSTANT)
            return REFUSE("area emitter with a textured radiance not supported");
    }
    /* BSDFs by their index in the scene */
    for (int i = 0; i < sc->nbsdfs; ++i) {
        bool used = false;
        for (int j = 0; j < sc->nshapes && !used; ++j)
            used = sc->shapes[j]->bsdf == sc->bsdfs[i];
        if (!used) { /* a BSDF no shape uses (nested in a wrapper, or unreferenced): an empty slot keeps
                        the device's BSDF indices equal to the scene's */
            if (!grow_add(&hs->bsdf_i, 1) || !grow_add(&hs->bsdf_f, BSDF_F))
                return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
            continue;
        }
        spc_status st = add_bsdf(hs, sc->bsdfs[i], file, err);
        if (st != SPC_OK)
            return st;
    }
    double mag = spc_max(spc_max_abs(sc->bbox_min), spc_max_abs(sc->bbox_max));
    hs->scale = (float)spc_max(mag, 1e-3);
    for (int i = 0; i < sc->nshapes; ++i) {
        const spc_shape *s = sc->shapes[i];
        int *si = grow_add(&hs->shape_i, SHAPE_I);
        float *sf = grow_add(&hs->shape_f, SHAPE_F);
        if (!si || !sf)
            return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
        if (s->interior_medium >= 0 || s->exterior_medium >= 0)
            return REFUSE("media on shape '%s' not supported", s->id);
        int bi = -1;
        for (int j = 0; j < sc->nbsdfs; ++j)
            if (sc->bsdfs[j] == s->bsdf)
                bi = j;
        if (bi < 0)
            return spc_error_set(err, SPC_ERR_INTERNAL, file, 0, 0, "opencl device: shape '%s' has no BSDF", s->id);
        si[1] = bi;
        si[2] = s->emitter ? s->emitter->index : -1;
        si[3] = s->flip_normals ? 1 : 0;
        spc_status st = SPC_OK;
        switch (s->type) {
        case SPC_SHAPE_SPHERE:
            si[0] = 0;
            sf[0] = (float)s->center.x;
            sf[1] = (float)s->center.y;
            sf[2] = (float)s->center.z;
            sf[3] = (float)s->radius;
            break;
        case SPC_SHAPE_SDF:
            si[0] = 1;
            st = add_sdf(hs, s, si, sf, file, err);
            break;
        case SPC_SHAPE_MESH:
            si[0] = 2;
            st = add_mesh(hs, s, si, sf, file, err);
            break;
        case SPC_SHAPE_DISK:
        case SPC_SHAPE_CYLINDER:
        case SPC_SHAPE_CURVE:
            return REFUSE("shape '%s' of type %s not supported (sdf, sphere, rectangle, cube)", s->id,
                          s->type == SPC_SHAPE_DISK ? "disk" : s->type == SPC_SHAPE_CURVE ? "curve" : "cylinder");
        case SPC_SHAPE_SDFGRID:
            return REFUSE("shape '%s' of type sdfgrid not supported (sdf, sphere, rectangle, cube)", s->id);
        }
        if (st != SPC_OK)
            return st;
    }
    hs->nshapes = sc->nshapes;
    double cdf = 0.0;
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        int *ei = grow_add(&hs->emit_i, 1);
        float *ef = grow_add(&hs->emit_f, EMIT_F);
        if (!ei || !ef)
            return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
        *ei = e->shape_index;
        constant(e->radiance, spc_rgb1(1.0), ef);
        ef[3] = (float)sc->light_pmf[i];
        cdf += sc->light_pmf[i];
        ef[4] = i + 1 == sc->nemitters ? 2.0f : (float)cdf;
    }
    hs->nemitters = sc->nemitters;
    /* camera and filter */
    const spc_camera_state *cs = ctx->cam;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            hs->cam_f[4 * r + c] = (float)cs->to_world.m[r][c];
    hs->cam_f[12] = (float)cs->tan_x;
    hs->cam_f[13] = (float)cs->tan_y;
    hs->cam_f[14] = (float)cs->near_clip;
    hs->cam_f[15] = (float)cs->far_clip;
    hs->cam_f[16] = (float)ctx->film->filter_radius;
    hs->cam_f[17] = ctx->film->rfilter == SPC_RFILTER_BOX ? 0.0f : 1.0f;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            hs->cam_f[18 + 4 * r + c] = (float)cs->to_local.m[r][c];
    hs->cam_f[30] = (float)fabs(spc_mat4_det3(&cs->to_world));
    /* light-tracing splats: the film's pixels over the window's (camera.h's normalization) */
    hs->cam_f[31] = (float)((double)cs->width * cs->height / ((double)ctx->width * ctx->height));
    for (int k = 0; k < SPC_FILTER_RESOLUTION; ++k)
        hs->filt[k] = (float)ctx->film->filter_step[k];
    for (int k = 0; k <= SPC_FILTER_RESOLUTION; ++k)
        hs->filt[SPC_FILTER_RESOLUTION + k] = (float)ctx->film->filter_step_cdf[k];
    return SPC_OK;
}

/* ---- OpenCL ---- */

struct spc_cl_renderer {
    const spc_render_ctx *ctx;
    cl_context context;
    cl_command_queue queue;
    cl_program program;
    cl_kernel kernel;
    cl_mem mem[11];
    cl_mem out, splats, rays;
    float *host_out, *host_splats;
    cl_uint *host_rays;
    int launch_items;
    bool bdpt;
};

static const char *cl_err_name(cl_int e)
{
    switch (e) {
    case CL_DEVICE_NOT_FOUND: return "CL_DEVICE_NOT_FOUND";
    case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
    case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
    case -1001: return "CL_PLATFORM_NOT_FOUND_KHR (no OpenCL platform installed)";
    default: return "error";
    }
}

/* Every device of every platform, in order; *n their count. The caller frees *devs. */
static cl_int all_devices(cl_device_id **devs, cl_uint *n)
{
    *devs = NULL;
    *n = 0;
    cl_uint np = 0;
    cl_int e = clGetPlatformIDs(0, NULL, &np);
    if (e != CL_SUCCESS)
        return e;
    if (np == 0)
        return CL_SUCCESS;
    cl_platform_id *pl = malloc(np * sizeof *pl);
    if (!pl)
        return CL_OUT_OF_HOST_MEMORY;
    clGetPlatformIDs(np, pl, NULL);
    for (cl_uint i = 0; i < np; ++i) {
        cl_uint nd = 0;
        if (clGetDeviceIDs(pl[i], CL_DEVICE_TYPE_ALL, 0, NULL, &nd) != CL_SUCCESS || nd == 0)
            continue;
        cl_device_id *nds = realloc(*devs, (*n + nd) * sizeof *nds);
        if (!nds) {
            free(pl);
            return CL_OUT_OF_HOST_MEMORY;
        }
        *devs = nds;
        clGetDeviceIDs(pl[i], CL_DEVICE_TYPE_ALL, nd, *devs + *n, NULL);
        *n += nd;
    }
    free(pl);
    return CL_SUCCESS;
}

char *spc_cl_describe_devices(void)
{
    cl_device_id *devs;
    cl_uint n;
    cl_int e = all_devices(&devs, &n);
    size_t cap = 256 + (size_t)n * 600, len = 0;
    char *s = malloc(cap);
    if (!s) {
        free(devs);
        return NULL;
    }
    s[0] = '\0';
    len += (size_t)snprintf(s, cap, "cpu        specula's threads (the default)\n");
    if (e != CL_SUCCESS || n == 0)
        snprintf(s + len, cap - len, "opencl: no platform or device found (%s)\n",
                 e != CL_SUCCESS ? cl_err_name(e) : "install an OpenCL driver, e.g. pocl-opencl-icd");
    for (cl_uint i = 0; i < n; ++i) {
        char name[256] = "", ver[128] = "", pname[256] = "";
        cl_platform_id p;
        cl_uint cu = 0;
        clGetDeviceInfo(devs[i], CL_DEVICE_NAME, sizeof name, name, NULL);
        clGetDeviceInfo(devs[i], CL_DEVICE_VERSION, sizeof ver, ver, NULL);
        clGetDeviceInfo(devs[i], CL_DEVICE_MAX_COMPUTE_UNITS, sizeof cu, &cu, NULL);
        if (clGetDeviceInfo(devs[i], CL_DEVICE_PLATFORM, sizeof p, &p, NULL) == CL_SUCCESS)
            clGetPlatformInfo(p, CL_PLATFORM_NAME, sizeof pname, pname, NULL);
        len += (size_t)snprintf(s + len, cap - len, "opencl:%-3u %s / %s (%s, %u compute units)\n", i, pname, name,
                                ver, cu);
    }
    free(devs);
    return s;
}

void spc_cl_destroy(spc_cl_renderer *r)
{
    if (!r)
        return;
    for (int i = 0; i < 11; ++i)
        if (r->mem[i])
            clReleaseMemObject(r->mem[i]);
    if (r->out)
        clReleaseMemObject(r->out);
    if (r->splats)
        clReleaseMemObject(r->splats);
    if (r->rays)
        clReleaseMemObject(r->rays);
    if (r->kernel)
        clReleaseKernel(r->kernel);
    if (r->program)
        clReleaseProgram(r->program);
    if (r->queue)
        clReleaseCommandQueue(r->queue);
    if (r->context)
        clReleaseContext(r->context);
    free(r->host_out);
    free(r->host_splats);
    free(r->host_rays);
    free(r);
}

static cl_mem upload(spc_cl_renderer *r, const void *p, size_t bytes, cl_int *e)
{
    static const float zero[4] = {0};
    if (bytes == 0) {
        p = zero;
        bytes = sizeof zero;
    }
    return clCreateBuffer(r->context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes, (void *)p, e);
}

spc_status spc_cl_create(const spc_render_ctx *ctx, int device_index, bool aovs, spc_cl_renderer **out,
                         spc_error *err)
{
    *out = NULL;
    const char *file = ctx->scene->path[0] ? ctx->scene->path : NULL;
    if (aovs)
        return REFUSE("AOVs not supported");
    host_scene hs;
    memset(&hs, 0, sizeof hs);
    spc_status st = build_scene(ctx, &hs, err);
    if (st != SPC_OK) {
        host_scene_release(&hs);
        return st;
    }
    cl_device_id *devs;
    cl_uint n;
    cl_int e = all_devices(&devs, &n);
    if (e != CL_SUCCESS || n == 0 || (cl_uint)device_index >= n) {
        free(devs);
        host_scene_release(&hs);
        if (e != CL_SUCCESS || n == 0)
            return REFUSE("no OpenCL platform or device found (%s)", e != CL_SUCCESS ? cl_err_name(e) : "none");
        return REFUSE("no device opencl:%d (%u found: see specula info --devices)", device_index, n);
    }
    cl_device_id dev = devs[device_index];
    free(devs);
    spc_cl_renderer *r = calloc(1, sizeof *r);
    if (!r) {
        host_scene_release(&hs);
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
    }
    r->ctx = ctx;
    r->bdpt = ctx->kind == SPC_INTEGRATOR_BDPT;
#define CHECK(what)                                                                                                   \
    do {                                                                                                              \
        if (e != CL_SUCCESS) {                                                                                        \
            st = spc_error_set(err, SPC_ERR_ACCEL, file, 0, 0, "opencl device: %s failed: %s (%d)", what,            \
                               cl_err_name(e), (int)e);                                                               \
            goto fail;                                                                                                \
        }                                                                                                             \
    } while (0)
    r->context = clCreateContext(NULL, 1, &dev, NULL, NULL, &e);
    CHECK("clCreateContext");
    r->queue = clCreateCommandQueue(r->context, dev, 0, &e);
    CHECK("clCreateCommandQueue");
    const char *src = (const char *)spc_kernels_cl;
    size_t src_len = spc_kernels_cl_len;
    r->program = clCreateProgramWithSource(r->context, 1, &src, &src_len, &e);
    CHECK("clCreateProgramWithSource");
    char opts[256];
    snprintf(opts, sizeof opts, "-cl-std=CL1.2 %s", getenv("SPC_CL_DEBUG") ? getenv("SPC_CL_DEBUG") : "");
    e = clBuildProgram(r->program, 1, &dev, opts, NULL, NULL);
    if (e != CL_SUCCESS) {
        char log[4096] = "";
        clGetProgramBuildInfo(r->program, dev, CL_PROGRAM_BUILD_LOG, sizeof log - 1, log, NULL);
        st = spc_error_set(err, SPC_ERR_ACCEL, file, 0, 0, "opencl device: kernel build failed: %s", log);
        goto fail;
    }
    r->kernel = clCreateKernel(r->program, r->bdpt ? "render_bdpt" : "render_path", &e);
    CHECK("clCreateKernel");
    {
        const grow *g[] = {&hs.shape_i, &hs.shape_f, &hs.node_i, &hs.node_f, &hs.tri,
                           &hs.bsdf_i, &hs.bsdf_f, &hs.emit_i, &hs.emit_f};
        for (int i = 0; i < 9; ++i) {
            r->mem[i] = upload(r, g[i]->p, g[i]->n * g[i]->elem, &e);
            CHECK("clCreateBuffer");
        }
        r->mem[9] = upload(r, hs.cam_f, sizeof hs.cam_f, &e);
        CHECK("clCreateBuffer");
        r->mem[10] = upload(r, hs.filt, sizeof hs.filt, &e);
        CHECK("clCreateBuffer");
    }
    r->launch_items = r->bdpt ? CL_LAUNCH_ITEMS_BDPT : CL_LAUNCH_ITEMS;
    const char *li = getenv("SPC_CL_LAUNCH_ITEMS");
    if (li && atoi(li) > 0 && atoi(li) < r->launch_items)
        r->launch_items = atoi(li);
    r->out = clCreateBuffer(r->context, CL_MEM_WRITE_ONLY, (size_t)r->launch_items * 3 * sizeof(float), NULL, &e);
    CHECK("clCreateBuffer");
    r->host_out = malloc((size_t)r->launch_items * 3 * sizeof(float));
    r->rays = clCreateBuffer(r->context, CL_MEM_WRITE_ONLY, (size_t)r->launch_items * sizeof(cl_uint), NULL, &e);
    CHECK("clCreateBuffer");
    r->host_rays = malloc((size_t)r->launch_items * sizeof(cl_uint));
    if (r->bdpt) {
        size_t bytes = (size_t)r->launch_items * CL_MAX_SPLATS * 4 * sizeof(float);
        r->splats = clCreateBuffer(r->context, CL_MEM_WRITE_ONLY, bytes, NULL, &e);
        CHECK("clCreateBuffer");
        r->host_splats = malloc(bytes);
    }
    if (!r->host_out || !r->host_rays || (r->bdpt && !r->host_splats)) {
        st = spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory");
        goto fail;
    }
    {
        cl_int nshapes = hs.nshapes, nemitters = hs.nemitters;
        cl_float scale = hs.scale;
        const spc_render_ctx *c = ctx;
        cl_int dims[6] = {c->cam->width, c->cam->height, c->crop_x, c->crop_y, c->width, c->height};
        cl_uint a = 0;
        e = clSetKernelArg(r->kernel, a++, sizeof nshapes, &nshapes);
        e |= clSetKernelArg(r->kernel, a++, sizeof nemitters, &nemitters);
        e |= clSetKernelArg(r->kernel, a++, sizeof scale, &scale);
        for (int i = 0; i < 11; ++i)
            e |= clSetKernelArg(r->kernel, a++, sizeof(cl_mem), &r->mem[i]);
        for (int i = 0; i < 6; ++i)
            e |= clSetKernelArg(r->kernel, a++, sizeof(cl_int), &dims[i]);
        CHECK("clSetKernelArg");
    }
    host_scene_release(&hs);
    uint64_t none = 0, no_rays = 0;
    st = spc_cl_render_passes(r, 0, 0, 0, NULL, 0, &none, &no_rays, err);
    if (st != SPC_OK) {
        spc_cl_destroy(r);
        return st;
    }
    *out = r;
    return SPC_OK;
fail:
    host_scene_release(&hs);
    spc_cl_destroy(r);
    return st;
#undef CHECK
}

/* Index of the first per-batch argument (after the scene's 20). */
#define ARG_BATCH 20

static bool finite_rgb(const float *v)
{
    return fabsf(v[0]) <= 3.0e38f && fabsf(v[1]) <= 3.0e38f && fabsf(v[2]) <= 3.0e38f;
}

spc_status spc_cl_render_passes(spc_cl_renderer *r, int pass0, int npasses, uint64_t seed, double *buf, int stride,
                                uint64_t *invalid, uint64_t *rays, spc_error *err)
{
    const spc_render_ctx *ctx = r->ctx;
    const char *file = ctx->scene->path[0] ? ctx->scene->path : NULL;
    size_t npix = (size_t)ctx->width * (size_t)ctx->height;
    size_t total = npix * (size_t)npasses;
    cl_uint seed_lo = (cl_uint)seed, seed_hi = (cl_uint)(seed >> 32);
    cl_int p0 = pass0, max_depth = ctx->max_depth, rr_depth = ctx->rr_depth, hide = ctx->hide_emitters ? 1 : 0;
    cl_float beta = ctx->mis_balance ? 1.0f : 2.0f;
    if (r->bdpt && npix > ((size_t)1 << 24))
        return spc_error_set(err, SPC_ERR_LIMIT, file, 0, 0,
                             "opencl device: bdpt's light-tracing splats index at most 2^24 pixels, the image has %zu",
                             npix);
    /* Launches hold whole passes where a pass fits in one (the most that fit), else one part of a
     * pass each, cut at the same pixels in every pass: where the launches start depends on the
     * pass structure alone, not on the batch, so a pixel's sum below (its camera sample and the
     * splats it receives, added in launch and work-item order) is the same in every batching (a
     * resumed render equals an uninterrupted one bit for bit). */
    size_t per_launch = (size_t)r->launch_items;
    if (npix > 0 && npix <= per_launch)
        per_launch = per_launch / npix * npix;
    /* Splats reach any pixel of their pass, also one whose camera sample a later launch renders:
     * every value is added to a zeroed batch, none assigned (an assignment would erase the splats
     * that arrived before it). */
    for (size_t g = 0; g < total; ++g) {
        double *d = buf + g * (size_t)stride;
        d[0] = d[1] = d[2] = 0.0;
    }
    /* total == 0: one empty launch, which makes implementations that compile on first use (PoCL
     * specializes kernels for the work-group size then) do it before the render's clock starts */
    size_t start = 0;
    do {
        size_t count = per_launch;
        if (npix > per_launch && npix - start % npix < count)
            count = npix - start % npix; /* the pass's last part */
        if (count > total - start)
            count = total - start;
        cl_int base = (cl_int)start;
        cl_uint a = ARG_BATCH;
        cl_int e = clSetKernelArg(r->kernel, a++, sizeof p0, &p0);
        e |= clSetKernelArg(r->kernel, a++, sizeof base, &base);
        cl_int cnt = (cl_int)count;
        e |= clSetKernelArg(r->kernel, a++, sizeof cnt, &cnt);
        e |= clSetKernelArg(r->kernel, a++, sizeof seed_lo, &seed_lo);
        e |= clSetKernelArg(r->kernel, a++, sizeof seed_hi, &seed_hi);
        e |= clSetKernelArg(r->kernel, a++, sizeof max_depth, &max_depth);
        e |= clSetKernelArg(r->kernel, a++, sizeof rr_depth, &rr_depth);
        e |= clSetKernelArg(r->kernel, a++, sizeof hide, &hide);
        e |= clSetKernelArg(r->kernel, a++, sizeof beta, &beta);
        e |= clSetKernelArg(r->kernel, a++, sizeof(cl_mem), &r->out);
        e |= clSetKernelArg(r->kernel, a++, sizeof(cl_mem), &r->rays);
        if (r->bdpt)
            e |= clSetKernelArg(r->kernel, a++, sizeof(cl_mem), &r->splats);
        if (e != CL_SUCCESS)
            return spc_error_set(err, SPC_ERR_ACCEL, file, 0, 0, "opencl device: clSetKernelArg failed (%d)", (int)e);
        size_t lsize = CL_GROUP, gsize = count == 0 ? CL_GROUP : (count + CL_GROUP - 1) / CL_GROUP * CL_GROUP;
        e = clEnqueueNDRangeKernel(r->queue, r->kernel, 1, NULL, &gsize, &lsize, 0, NULL, NULL);
        if (e == CL_SUCCESS && count == 0)
            e = clFinish(r->queue);
        if (e == CL_SUCCESS && count > 0)
            e = clEnqueueReadBuffer(r->queue, r->out, CL_TRUE, 0, count * 3 * sizeof(float), r->host_out, 0, NULL,
                                    NULL);
        if (e == CL_SUCCESS && count > 0)
            e = clEnqueueReadBuffer(r->queue, r->rays, CL_TRUE, 0, count * sizeof(cl_uint), r->host_rays, 0, NULL,
                                    NULL);
        if (e == CL_SUCCESS && r->bdpt && count > 0)
            e = clEnqueueReadBuffer(r->queue, r->splats, CL_TRUE, 0, count * CL_MAX_SPLATS * 4 * sizeof(float),
                                    r->host_splats, 0, NULL, NULL);
        if (e != CL_SUCCESS)
            return spc_error_set(err, SPC_ERR_ACCEL, file, 0, 0, "opencl device: kernel run failed: %s (%d)",
                                 cl_err_name(e), (int)e);
        for (size_t k = 0; k < count; ++k)
            *rays += r->host_rays[k];
        for (size_t k = 0; k < count; ++k) {
            size_t g = start + k;
            double *d = buf + ((g / npix) * npix + g % npix) * (size_t)stride;
            const float *v = r->host_out + 3 * k;
            if (!finite_rgb(v)) {
                ++*invalid;
                continue;
            }
            d[0] += v[0];
            d[1] += v[1];
            d[2] += v[2];
        }
        if (r->bdpt) {
            /* splats in work-item order: deterministic; each record is the pixel index in the window
             * as a float (exact below 2^24 pixels; an int's bits stored in a float would be a
             * denormal that a device flushing denormals may turn into 0) and rgb; a negative index
             * ends the item's list */
            for (size_t k = 0; k < count; ++k) {
                size_t g = start + k, b = g / npix;
                const float *s = r->host_splats + k * CL_MAX_SPLATS * 4;
                for (int j = 0; j < CL_MAX_SPLATS; ++j) {
                    float fpix = s[4 * j];
                    if (!(fpix >= 0.0f) || (double)fpix >= (double)npix)
                        break;
                    size_t pix = (size_t)fpix;
                    const float *v = s + 4 * j + 1;
                    if (!finite_rgb(v)) {
                        ++*invalid;
                        continue;
                    }
                    double *d = buf + (b * npix + (size_t)pix) * (size_t)stride;
                    d[0] += v[0];
                    d[1] += v[1];
                    d[2] += v[2];
                }
            }
        }
        start += count;
    } while (start < total);
    return SPC_OK;
}

#endif

char *spc_devices_describe(void) { return spc_cl_describe_devices(); }
