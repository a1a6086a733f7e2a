/*
 * accel/embree.c: Embree 3 device and scene. Meshes are RTC_GEOMETRY_TYPE_TRIANGLE reading the
 * scene's float positions and indices in place (spc_mesh.p_padded; copies otherwise); spheres,
 * disks and cylinders are RTC_GEOMETRY_TYPE_USER whose callbacks intersect in double precision
 * from the caller's double ray, which travels in an extended RTCIntersectContext; curves are
 * Embree's round linear and round B-spline curves reading the shape's control points in place, with
 * their back faces culled (Mitsuba 3's Embree is built so: a ray from inside a tube passes out of
 * it). The geometry ID of every shape equals its index in the scene.
 */
#include "accel/accel.h"

#include <embree3/rtcore.h>
#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "scene/curve.h"
#include "scene/scene.h"

/* Scenes of at least this many triangles get Embree's compact BVH (leaves index the shared vertex
 * buffer instead of holding copies of the vertices). Measured: a 10-million-triangle mesh loads in
 * about half the memory (1230 -> 656 MiB peak) and 20% less CPU time; one of a million triangles
 * loads and renders (128x128, 16 spp) in 16% less CPU time; the cornell box (36 triangles) renders
 * 8% slower. Hits are the same either way. */
#define SPC_ACCEL_COMPACT_TRIS (1u << 19)

struct spc_accel {
    RTCDevice device;
    RTCScene scene;
    const struct spc_scene *sc;
};

typedef struct ctx_ext {
    struct RTCIntersectContext ctx; /* must be first */
    const spc_ray *ray;
    const struct spc_scene *sc;
    /* the best analytic hit so far, in double */
    int geom;
    double t, u, v;
} ctx_ext;

static _Thread_local uint64_t rays_traced = 0;

uint64_t spc_accel_rays_traced(void) { return rays_traced; }

static void bounds_fn(const struct RTCBoundsFunctionArguments *args)
{
    const spc_shape *s = args->geometryUserPtr;
    double pad = 1e-6 * (spc_max_abs(s->bbox_min) + spc_max_abs(s->bbox_max)) + 1e-30;
    args->bounds_o->lower_x = (float)(s->bbox_min.x - pad);
    args->bounds_o->lower_y = (float)(s->bbox_min.y - pad);
    args->bounds_o->lower_z = (float)(s->bbox_min.z - pad);
    args->bounds_o->upper_x = (float)(s->bbox_max.x + pad);
    args->bounds_o->upper_y = (float)(s->bbox_max.y + pad);
    args->bounds_o->upper_z = (float)(s->bbox_max.z + pad);
}

static void intersect_fn(const struct RTCIntersectFunctionNArguments *args)
{
    if (!args->valid[0] || args->N != 1)
        return;
    ctx_ext *cx = (ctx_ext *)args->context;
    const spc_shape *s = args->geometryUserPtr;
    struct RTCRayHit *rh = (struct RTCRayHit *)args->rayhit;
    spc_ray r = *cx->ray;
    /* the current nearest hit: in double if it is our own analytic hit, else Embree's float */
    if (cx->geom >= 0 && (float)cx->t == rh->ray.tfar)
        r.tmax = spc_min(r.tmax, cx->t);
    else
        r.tmax = spc_min(r.tmax, (double)rh->ray.tfar);
    double t, u, v;
    if (!spc_shape_intersect_analytic(s, &r, &t, &u, &v))
        return;
    rh->ray.tfar = (float)t;
    rh->hit.geomID = args->geomID;
    rh->hit.primID = args->primID;
    rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rh->hit.u = (float)u;
    rh->hit.v = (float)v;
    rh->hit.Ng_x = rh->hit.Ng_y = 0.0f;
    rh->hit.Ng_z = 1.0f;
    cx->geom = (int)args->geomID;
    cx->t = t;
    cx->u = u;
    cx->v = v;
}

static void occluded_fn(const struct RTCOccludedFunctionNArguments *args)
{
    if (!args->valid[0] || args->N != 1)
        return;
    ctx_ext *cx = (ctx_ext *)args->context;
    const spc_shape *s = args->geometryUserPtr;
    struct RTCRay *ray = (struct RTCRay *)args->ray;
    double t, u, v;
    if (spc_shape_intersect_analytic(s, cx->ray, &t, &u, &v))
        ray->tfar = -INFINITY;
}

/* Culls a curve's back faces: a hit whose geometric normal (outward) faces along the ray. */
static void curve_filter_fn(const struct RTCFilterFunctionNArguments *args)
{
    for (unsigned i = 0; i < args->N; ++i) {
        if (!args->valid[i])
            continue;
        /* the SoA layouts of rtcore_ray.h (its accessors are C++ only): hit Ng_x,y,z at 0, N, 2N;
         * ray dir_x,y,z at 4N, 5N, 6N */
        const float *hit = (const float *)args->hit, *ray = (const float *)args->ray;
        unsigned N = args->N;
        float nx = hit[i], ny = hit[N + i], nz = hit[2 * N + i];
        float dx = ray[4 * N + i], dy = ray[5 * N + i], dz = ray[6 * N + i];
        if (nx * dx + ny * dy + nz * dz > 0.0f)
            args->valid[i] = 0;
    }
}

static void error_fn(void *user, enum RTCError code, const char *str)
{
    (void)user;
    (void)code;
    (void)str;
}

spc_accel *spc_accel_create(const struct spc_scene *sc, spc_error *err)
{
    spc_accel *a = calloc(1, sizeof *a);
    if (!a) {
        spc_error_set(err, SPC_ERR_NOMEM, NULL, 0, 0, "out of memory building the acceleration structure");
        return NULL;
    }
    a->sc = sc;
    a->device = rtcNewDevice("verbose=0");
    if (!a->device) {
        spc_error_set(err, SPC_ERR_ACCEL, NULL, 0, 0, "Embree: cannot create a device (error %d)",
                      (int)rtcGetDeviceError(NULL));
        free(a);
        return NULL;
    }
    rtcSetDeviceErrorFunction(a->device, error_fn, NULL);
    a->scene = rtcNewScene(a->device);
    rtcSetSceneBuildQuality(a->scene, RTC_BUILD_QUALITY_HIGH);
    size_t ntris = 0;
    for (int i = 0; i < sc->nshapes; ++i)
        if (sc->shapes[i]->type == SPC_SHAPE_MESH)
            ntris += sc->shapes[i]->mesh.ntris;
    rtcSetSceneFlags(a->scene, RTC_SCENE_FLAG_ROBUST | (ntris >= SPC_ACCEL_COMPACT_TRIS ? RTC_SCENE_FLAG_COMPACT : 0));
    for (int i = 0; i < sc->nshapes; ++i) {
        const spc_shape *s = sc->shapes[i];
        RTCGeometry g;
        if (s->type == SPC_SHAPE_MESH) {
            g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_TRIANGLE);
            /* the scene's own arrays where the positions are padded for Embree's loads (the
             * scene outlives the accel and does not change), else copies */
            const void *vb, *ib;
            if (s->mesh.p_padded) {
                rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, s->mesh.p, 0,
                                           3 * sizeof(float), s->mesh.nverts);
                rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, s->mesh.idx, 0,
                                           3 * sizeof(unsigned), s->mesh.ntris);
                vb = s->mesh.p;
                ib = s->mesh.idx;
            } else {
                float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                   s->mesh.nverts);
                unsigned *i3 = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                       3 * sizeof(unsigned), s->mesh.ntris);
                if (v)
                    memcpy(v, s->mesh.p, 3 * s->mesh.nverts * sizeof(float));
                if (i3)
                    memcpy(i3, s->mesh.idx, 3 * s->mesh.ntris * sizeof(unsigned));
                vb = v;
                ib = i3;
            }
            if (!vb || !ib || rtcGetDeviceError(a->device) != RTC_ERROR_NONE) {
                rtcReleaseGeometry(g);
                spc_accel_destroy(a);
                spc_error_set(err, SPC_ERR_NOMEM, NULL, 0, 0, "Embree: cannot take mesh '%s' (out of memory)", s->id);
                return NULL;
            }
        } else if (s->type == SPC_SHAPE_CURVE) {
            const spc_curve *c = s->curve;
            g = rtcNewGeometry(a->device, c->basis == SPC_CURVE_LINEAR ? RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE
                                                                       : RTC_GEOMETRY_TYPE_ROUND_BSPLINE_CURVE);
            rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, (void *)c->cp, 0, 4 * sizeof(float),
                                       c->ncp);
            rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, (void *)c->seg, 0, sizeof(uint32_t),
                                       c->nseg);
            rtcSetGeometryIntersectFilterFunction(g, curve_filter_fn);
            rtcSetGeometryOccludedFilterFunction(g, curve_filter_fn);
            if (rtcGetDeviceError(a->device) != RTC_ERROR_NONE) {
                rtcReleaseGeometry(g);
                spc_accel_destroy(a);
                spc_error_set(err, SPC_ERR_ACCEL, NULL, 0, 0, "Embree: cannot take curve '%s'", s->id);
                return NULL;
            }
        } else {
            g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_USER);
            rtcSetGeometryUserPrimitiveCount(g, 1);
            rtcSetGeometryUserData(g, (void *)s);
            rtcSetGeometryBoundsFunction(g, bounds_fn, NULL);
            rtcSetGeometryIntersectFunction(g, intersect_fn);
            rtcSetGeometryOccludedFunction(g, occluded_fn);
        }
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(a->scene, g, (unsigned)i);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(a->scene);
    enum RTCError e = rtcGetDeviceError(a->device);
    if (e != RTC_ERROR_NONE) {
        spc_accel_destroy(a);
        spc_error_set(err, e == RTC_ERROR_OUT_OF_MEMORY ? SPC_ERR_NOMEM : SPC_ERR_ACCEL, NULL, 0, 0,
                      "Embree: scene build failed (error %d)", (int)e);
        return NULL;
    }
    return a;
}

void spc_accel_destroy(spc_accel *a)
{
    if (!a)
        return;
    if (a->scene)
        rtcReleaseScene(a->scene);
    if (a->device)
        rtcReleaseDevice(a->device);
    free(a);
}

static void to_embree_ray(const spc_ray *r, struct RTCRay *er)
{
    er->org_x = (float)r->o.x;
    er->org_y = (float)r->o.y;
    er->org_z = (float)r->o.z;
    er->dir_x = (float)r->d.x;
    er->dir_y = (float)r->d.y;
    er->dir_z = (float)r->d.z;
    er->tnear = (float)r->tmin;
    er->tfar = r->tmax >= (double)FLT_MAX ? INFINITY : (float)r->tmax;
    er->time = 0.0f;
    er->mask = 0xFFFFFFFFu;
    er->id = 0;
    er->flags = 0;
}

bool spc_accel_intersect(const spc_accel *a, const spc_ray *r, int *shape, int *prim, double *u, double *v,
                         double *t)
{
    ++rays_traced;
    if (!(r->tmax > r->tmin))
        return false;
    ctx_ext cx;
    rtcInitIntersectContext(&cx.ctx);
    cx.ray = r;
    cx.sc = a->sc;
    cx.geom = -1;
    struct RTCRayHit rh;
    to_embree_ray(r, &rh.ray);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(a->scene, &cx.ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return false;
    *shape = (int)rh.hit.geomID;
    *prim = (int)rh.hit.primID;
    if (cx.geom == (int)rh.hit.geomID) {
        *t = cx.t;
        *u = cx.u;
        *v = cx.v;
    } else {
        *t = rh.ray.tfar;
        *u = rh.hit.u;
        *v = rh.hit.v;
    }
    return true;
}

bool spc_accel_occluded(const spc_accel *a, const spc_ray *r)
{
    ++rays_traced;
    if (!(r->tmax > r->tmin))
        return false;
    ctx_ext cx;
    rtcInitIntersectContext(&cx.ctx);
    cx.ray = r;
    cx.sc = a->sc;
    cx.geom = -1;
    struct RTCRay er;
    to_embree_ray(r, &er);
    rtcOccluded1(a->scene, &cx.ctx, &er);
    return er.tfar < 0.0f;
}

uint64_t spc_accel_raw_loop(const spc_accel *a, const spc_ray *rays, size_t n)
{
    uint64_t hits = 0;
    ctx_ext cx;
    rtcInitIntersectContext(&cx.ctx);
    cx.sc = a->sc;
    for (size_t i = 0; i < n; ++i) {
        struct RTCRayHit rh;
        cx.ray = &rays[i];
        cx.geom = -1;
        to_embree_ray(&rays[i], &rh.ray);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(a->scene, &cx.ctx, &rh);
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    return hits;
}
