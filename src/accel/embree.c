/*
 * accel/embree.c: Embree 3 device and scene. Meshes are RTC_GEOMETRY_TYPE_TRIANGLE reading the
 * scene's float positions and indices in place (spc_mesh.p_padded; copies otherwise); spheres,
 * disks and cylinders are RTC_GEOMETRY_TYPE_USER whose callbacks intersect in double precision
 * from the caller's double ray, which travels in an extended RTCIntersectContext; curves are
 * Embree's round linear and round B-spline curves reading the shape's control points in place, with
 * their back faces culled (Mitsuba 3's Embree is built so: a ray from inside a tube passes out of
 * it). The geometry ID of every shape equals its index in the scene.
 *
 * The scene is built with RTC_SCENE_FLAG_ROBUST unless the scene turns it off
 * (spc_scene.accel_robust, the property embree_use_robust_intersections; Mitsuba 3 reads the same
 * property with the default false). Embree's fast triangle test takes about 9% off plain path
 * tracing of the cornell box, but rays through the shared edges of a mesh then pass the crack
 * between its triangles (test_accel's closed_mesh_cracks_are_rare: 2 to 6% of the rays aimed
 * exactly at the edges of a closed mesh instead of 0.01 to 0.04%), and a ray through a quad
 * light's center lies on its diagonal (test_emitter's rectangle chi-square test fails without the
 * flag: the quadrature's node there misses the light). bench/RESULTS.md has the measurements.
 */
#include "accel/accel.h"

#include <embree3/rtcore.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/cpu_isa.h"
#include "scene/curve.h"
#include "scene/scene.h"

struct spc_accel {
    RTCDevice device;
    RTCScene scene;
    const struct spc_scene *sc;
    /* per shape, the ray mask of a shadow ray that skips it (spc_accel_occluded_skip): all ones
     * but the shape's own geometry mask bit, or all ones where it has none */
    unsigned *skip_mask;
    int nskip; /* shapes with a mask bit of their own */
    /* those shapes (emitting spheres) for the shadow packets' cull (cull_lines): center and radius
     * in float, the sum of the center's absolute coordinates, the mask bit */
    float cull_c[SPC_ACCEL_SKIP_MAX][3], cull_r[SPC_ACCEL_SKIP_MAX], cull_c1[SPC_ACCEL_SKIP_MAX];
    unsigned cull_bit[SPC_ACCEL_SKIP_MAX];
    bool cull_avx512; /* the cull's AVX-512 variant (core/cpu_isa.h's choice) */
    bool compact;     /* built with RTC_SCENE_FLAG_COMPACT (SPC_ACCEL_COMPACT_TRIS) */
    /* octant shadow packets by the coherent traversal (SPC_ACCEL_INCOHERENT_SHADOW_TRIS) */
    bool shadows_coherent;
    bool analytic; /* some shape is user geometry (its hits come in double from the callbacks) */
    int packet_width; /* the packets' lanes, 8 or 16 (spc_accel_packet_width) */
};

int spc_accel_packet_width(const spc_accel *a) { return a->packet_width; }

bool spc_accel_skips_any(const spc_accel *a) { return a->nskip > 0; }

bool spc_accel_compact(const spc_accel *a) { return a->compact; }

bool spc_accel_shadows_coherent(const spc_accel *a) { return a->shadows_coherent; }

/* The ray mask of a shadow ray that may skip shape `skip` (-1: none). */
static unsigned skip_mask_of(const spc_accel *a, int skip)
{
    return skip >= 0 && skip < a->sc->nshapes ? a->skip_mask[skip] : 0xFFFFFFFFu;
}

/* A packet's double rays and their best analytic hits so far, per lane; a single ray is lane 0. The
 * callbacks find a ray's lane from its Embree id (Embree may call them with other packet sizes and
 * orders than the caller's). */
typedef struct ctx_ext {
    struct RTCIntersectContext ctx; /* must be first */
    const spc_ray *const *rays;     /* per lane; NULL for an inactive lane */
    const struct spc_scene *sc;
    /* the best analytic hit so far, in double */
    int geom[SPC_ACCEL_PACKET];
    double t[SPC_ACCEL_PACKET], u[SPC_ACCEL_PACKET], v[SPC_ACCEL_PACKET];
} ctx_ext;

/* The SoA layouts of rtcore_ray.h (its accessors are C++ only), for N rays: field k of lane i at
 * k N + i, in 32-bit words; a ray's fields, then (RTCRayHitN) the hit's. N = 1 is RTCRayHit. */
enum {
    RAY_ORG_X,
    RAY_ORG_Y,
    RAY_ORG_Z,
    RAY_TNEAR,
    RAY_DIR_X,
    RAY_DIR_Y,
    RAY_DIR_Z,
    RAY_TIME,
    RAY_TFAR,
    RAY_MASK,
    RAY_ID,
    RAY_FLAGS,
    HIT_NG_X,
    HIT_NG_Y,
    HIT_NG_Z,
    HIT_U,
    HIT_V,
    HIT_PRIM,
    HIT_GEOM,
    HIT_INST,
    RAYHIT_WORDS
};

static _Thread_local uint64_t rays_traced = 0;

uint64_t spc_accel_rays_traced(void) { return rays_traced; }

static _Thread_local uint64_t shadow_rays_traced = 0;

uint64_t spc_accel_shadow_rays_traced(void) { return shadow_rays_traced; }

static _Thread_local uint64_t analytic_tests = 0;

uint64_t spc_accel_analytic_tests(void) { return analytic_tests; }

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
    ctx_ext *cx = (ctx_ext *)args->context;
    const spc_shape *s = args->geometryUserPtr;
    const unsigned N = args->N;
    float *f = (float *)args->rayhit;
    unsigned *w = (unsigned *)args->rayhit;
    for (unsigned i = 0; i < N; ++i) {
        if (!args->valid[i])
            continue;
        ++analytic_tests;
        unsigned lane = w[RAY_ID * N + i];
        spc_ray r = *cx->rays[lane];
        /* the current nearest hit: in double if it is our own analytic hit, else Embree's float */
        float tfar = f[RAY_TFAR * N + i];
        if (cx->geom[lane] >= 0 && (float)cx->t[lane] == tfar)
            r.tmax = spc_min(r.tmax, cx->t[lane]);
        else
            r.tmax = spc_min(r.tmax, (double)tfar);
        double t, u, v;
        if (!spc_shape_intersect_analytic(s, &r, &t, &u, &v))
            continue;
        f[RAY_TFAR * N + i] = (float)t;
        w[HIT_GEOM * N + i] = args->geomID;
        w[HIT_PRIM * N + i] = args->primID;
        w[HIT_INST * N + i] = RTC_INVALID_GEOMETRY_ID;
        f[HIT_U * N + i] = (float)u;
        f[HIT_V * N + i] = (float)v;
        f[HIT_NG_X * N + i] = f[HIT_NG_Y * N + i] = 0.0f;
        f[HIT_NG_Z * N + i] = 1.0f;
        cx->geom[lane] = (int)args->geomID;
        cx->t[lane] = t;
        cx->u[lane] = u;
        cx->v[lane] = v;
    }
}

static void occluded_fn(const struct RTCOccludedFunctionNArguments *args)
{
    ctx_ext *cx = (ctx_ext *)args->context;
    const spc_shape *s = args->geometryUserPtr;
    const unsigned N = args->N;
    float *f = (float *)args->ray;
    const unsigned *w = (const unsigned *)args->ray;
    for (unsigned i = 0; i < N; ++i) {
        if (!args->valid[i])
            continue;
        ++analytic_tests;
        double t, u, v;
        if (spc_shape_intersect_analytic(s, cx->rays[w[RAY_ID * N + i]], &t, &u, &v))
            f[RAY_TFAR * N + i] = -INFINITY;
    }
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
    a->cull_avx512 = spc_vector_isa() == SPC_ISA_AVX512;
    /* SPECULA_EMBREE_CONFIG, if set, is Embree's device configuration: tests force an instruction
     * set with it ("isa=avx2"), under which Embree's packet calls take other code paths */
    const char *config = getenv("SPECULA_EMBREE_CONFIG");
    a->device = rtcNewDevice(config ? config : "verbose=0");
    if (!a->device) {
        spc_error_set(err, SPC_ERR_ACCEL, NULL, 0, 0, "Embree: cannot create a device (error %d)",
                      (int)rtcGetDeviceError(NULL));
        free(a);
        return NULL;
    }
    rtcSetDeviceErrorFunction(a->device, error_fn, NULL);
    /* 16 lanes where Embree traces 16-wide packets natively (AVX-512), else 8 where it traces 8-wide
     * ones natively (AVX2), else 16: on an AVX2 host Embree's stream fallback copies a 16-wide packet
     * into two native 8-wide ones (1% of the cornell box's instructions, bench/RESULTS.md).
     * SPECULA_PACKET_WIDTH (8 or 16), if set, overrides the choice, so that tests run both widths on
     * any host (Embree traces either width on any host, a width that is not native more slowly). */
    a->packet_width = rtcGetDeviceProperty(a->device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED)  ? 16
                      : rtcGetDeviceProperty(a->device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) ? 8
                                                                                                   : 16;
    const char *width = getenv("SPECULA_PACKET_WIDTH");
    if (width && (strcmp(width, "8") == 0 || strcmp(width, "16") == 0))
        a->packet_width = atoi(width);
    a->scene = rtcNewScene(a->device);
    rtcSetSceneBuildQuality(a->scene, RTC_BUILD_QUALITY_HIGH);
    size_t ntris = 0;
    for (int i = 0; i < sc->nshapes; ++i)
        if (sc->shapes[i]->type == SPC_SHAPE_MESH)
            ntris += sc->shapes[i]->mesh.ntris;
    a->compact = ntris >= (sc->accel_compact_tris ? sc->accel_compact_tris : SPC_ACCEL_COMPACT_TRIS);
    a->shadows_coherent = ntris < SPC_ACCEL_INCOHERENT_SHADOW_TRIS;
    rtcSetSceneFlags(a->scene, (sc->accel_robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE) |
                                   (a->compact ? RTC_SCENE_FLAG_COMPACT : 0));
    a->skip_mask = malloc((sc->nshapes > 0 ? (size_t)sc->nshapes : 1) * sizeof(unsigned));
    if (!a->skip_mask) {
        spc_accel_destroy(a);
        spc_error_set(err, SPC_ERR_NOMEM, NULL, 0, 0, "out of memory building the acceleration structure");
        return NULL;
    }
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
            a->analytic = true;
            g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_USER);
            rtcSetGeometryUserPrimitiveCount(g, 1);
            rtcSetGeometryUserData(g, (void *)s);
            rtcSetGeometryBoundsFunction(g, bounds_fn, NULL);
            rtcSetGeometryIntersectFunction(g, intersect_fn);
            rtcSetGeometryOccludedFunction(g, occluded_fn);
        }
        /* every geometry is in every ray's mask (Embree's default mask is all ones) except the
         * emitting spheres, each on a bit of its own that its shadow rays leave out */
        a->skip_mask[i] = 0xFFFFFFFFu;
        if (s->type == SPC_SHAPE_SPHERE && s->emitter && a->nskip < SPC_ACCEL_SKIP_MAX) {
            int k = a->nskip++;
            unsigned bit = 1u << (1 + k);
            rtcSetGeometryMask(g, bit);
            a->skip_mask[i] = ~bit;
            a->cull_c[k][0] = (float)s->center.x;
            a->cull_c[k][1] = (float)s->center.y;
            a->cull_c[k][2] = (float)s->center.z;
            a->cull_r[k] = (float)s->radius;
            a->cull_c1[k] = fabsf(a->cull_c[k][0]) + fabsf(a->cull_c[k][1]) + fabsf(a->cull_c[k][2]);
            a->cull_bit[k] = bit;
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
    free(a->skip_mask);
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
    cx.rays = &r;
    cx.sc = a->sc;
    cx.geom[0] = -1;
    struct RTCRayHit rh;
    to_embree_ray(r, &rh.ray);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(a->scene, &cx.ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return false;
    *shape = (int)rh.hit.geomID;
    *prim = (int)rh.hit.primID;
    if (cx.geom[0] == (int)rh.hit.geomID) {
        *t = cx.t[0];
        *u = cx.u[0];
        *v = cx.v[0];
    } else {
        *t = rh.ray.tfar;
        *u = rh.hit.u;
        *v = rh.hit.v;
    }
    return true;
}

bool spc_accel_occluded(const spc_accel *a, const spc_ray *r) { return spc_accel_occluded_skip(a, r, -1); }

bool spc_accel_occluded_skip(const spc_accel *a, const spc_ray *r, int skip)
{
    ++rays_traced;
    ++shadow_rays_traced;
    if (!(r->tmax > r->tmin))
        return false;
    ctx_ext cx;
    rtcInitIntersectContext(&cx.ctx);
    cx.rays = &r;
    cx.sc = a->sc;
    cx.geom[0] = -1;
    struct RTCRay er;
    to_embree_ray(r, &er);
    er.mask = skip_mask_of(a, skip);
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
        const spc_ray *r = &rays[i];
        cx.rays = &r;
        cx.geom[0] = -1;
        to_embree_ray(&rays[i], &rh.ray);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(a->scene, &cx.ctx, &rh);
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    return hits;
}

/* A packet of N rays (RTCRayHitN or RTCRayN, N = 8 or 16, the accel's packet_width) as 32-bit
 * words in the layout of the enum above; its code is written once for both widths, inlined into a
 * function per width where N is a constant. */
typedef union pk_word {
    float f;
    unsigned u;
} pk_word;
#define PK_F(pk, N, k, i) ((pk)[(k) * (N) + (i)].f)
#define PK_U(pk, N, k, i) ((pk)[(k) * (N) + (i)].u)
_Static_assert(sizeof(struct RTCRayHit8) == RAYHIT_WORDS * 8 * sizeof(pk_word), "RTCRayHit8's layout");
_Static_assert(sizeof(struct RTCRayHit16) == RAYHIT_WORDS * 16 * sizeof(pk_word), "RTCRayHit16's layout");
_Static_assert(SPC_ACCEL_PACKET == 16, "the widest packet");

/* An inactive lane: besides the valid mask, marked inactive the way Embree's stream fallback (a
 * packet wider than the CPU's native one) tells them, by tnear > tfar, with finite data. */
static inline __attribute__((always_inline)) void embree_lane_off(pk_word *er, const int N, int i)
{
    PK_F(er, N, RAY_ORG_X, i) = PK_F(er, N, RAY_ORG_Y, i) = PK_F(er, N, RAY_ORG_Z, i) = 0.0f;
    PK_F(er, N, RAY_DIR_X, i) = PK_F(er, N, RAY_DIR_Y, i) = 0.0f;
    PK_F(er, N, RAY_DIR_Z, i) = 1.0f;
    PK_F(er, N, RAY_TNEAR, i) = 0.0f;
    PK_F(er, N, RAY_TFAR, i) = -INFINITY;
    PK_F(er, N, RAY_TIME, i) = 0.0f;
    PK_U(er, N, RAY_MASK, i) = 0u;
    PK_U(er, N, RAY_ID, i) = (unsigned)i;
    PK_U(er, N, RAY_FLAGS, i) = 0;
}

/* One lane of a packet from a double ray, as to_embree_ray; the lane's id is its index. */
static inline __attribute__((always_inline)) void to_embree_lane(const spc_ray *r, pk_word *er, const int N, int i)
{
    PK_F(er, N, RAY_ORG_X, i) = (float)r->o.x;
    PK_F(er, N, RAY_ORG_Y, i) = (float)r->o.y;
    PK_F(er, N, RAY_ORG_Z, i) = (float)r->o.z;
    PK_F(er, N, RAY_DIR_X, i) = (float)r->d.x;
    PK_F(er, N, RAY_DIR_Y, i) = (float)r->d.y;
    PK_F(er, N, RAY_DIR_Z, i) = (float)r->d.z;
    PK_F(er, N, RAY_TNEAR, i) = (float)r->tmin;
    PK_F(er, N, RAY_TFAR, i) = r->tmax >= (double)FLT_MAX ? INFINITY : (float)r->tmax;
    PK_F(er, N, RAY_TIME, i) = 0.0f;
    PK_U(er, N, RAY_MASK, i) = 0xFFFFFFFFu;
    PK_U(er, N, RAY_ID, i) = (unsigned)i;
    PK_U(er, N, RAY_FLAGS, i) = 0;
}

/* Clears, in each lane's ray mask, the bit of every emitting sphere whose line the lane's ray passes
 * clearly outside of, so that Embree does not call the sphere's callback for that lane. Embree's
 * packet traversal hands a user geometry's callback every lane still active in the packet, not
 * only those whose ray meets the geometry's box (veach-mis: 98.5% of the lanes in the spheres'
 * callbacks miss the box), and a callback costs far more than this test.
 *
 * The test is exact in its answer: a lane keeps its bit unless its float ray's distance to the
 * center's float line exceeds the radius by 2^-12 (1 + |d|_1^2) (|o|_1 + |c|_1 + r). The float
 * rounding of origin, direction, center and radius and the float arithmetic move that distance by
 * at most a few tens of float roundings (2^-24 each) of those sizes, a hundredth of the margin, so
 * the double ray's line also passes outside the sphere by more than the margin's half, the double
 * test's discriminant (spc_shape_intersect_analytic: r^2 minus the squared distance, rounded
 * by 2^-52 of the same sizes squared) is negative and the callback would have answered "no hit".
 * Lanes with an infinite or NaN origin or direction keep every bit (the comparison is false). The
 * margin grows with the distance from the world's origin: far from it (coordinates 10^4 times a
 * light's radius) little is culled, and the callbacks answer as before. Written in GCC vector
 * types over 8 lanes at a time (two SSE registers, or one AVX register). */
typedef float cull_v8 __attribute__((vector_size(32)));
typedef int cull_v8i __attribute__((vector_size(32)));

/* cull_lines' body, inlined into each instruction set's variant: a packet of n lanes (8 or 16). */
static inline __attribute__((always_inline)) void cull_loop(const spc_accel *a, pk_word *er, int n)
{
    for (int c = 0; c < n; c += 8) {
        cull_v8 ox, oy, oz, dx, dy, dz;
        cull_v8i mask;
        memcpy(&ox, &er[RAY_ORG_X * n + c], sizeof ox);
        memcpy(&oy, &er[RAY_ORG_Y * n + c], sizeof oy);
        memcpy(&oz, &er[RAY_ORG_Z * n + c], sizeof oz);
        memcpy(&dx, &er[RAY_DIR_X * n + c], sizeof dx);
        memcpy(&dy, &er[RAY_DIR_Y * n + c], sizeof dy);
        memcpy(&dz, &er[RAY_DIR_Z * n + c], sizeof dz);
        memcpy(&mask, &er[RAY_MASK * n + c], sizeof mask);
        float o1a[8], d1a[8];
        for (int i = 0; i < 8; ++i) {
            o1a[i] = fabsf(ox[i]) + fabsf(oy[i]) + fabsf(oz[i]);
            d1a[i] = fabsf(dx[i]) + fabsf(dy[i]) + fabsf(dz[i]);
        }
        cull_v8 o1, d1;
        memcpy(&o1, o1a, sizeof o1);
        memcpy(&d1, d1a, sizeof d1);
        const cull_v8 scale = (1.0f + d1 * d1) * 0x1p-12f;
        for (int k = 0; k < a->nskip; ++k) {
            const cull_v8 fx = ox - a->cull_c[k][0], fy = oy - a->cull_c[k][1], fz = oz - a->cull_c[k][2];
            const cull_v8 b = fx * dx + fy * dy + fz * dz;
            const cull_v8 lx = fx - dx * b, ly = fy - dy * b, lz = fz - dz * b;
            const cull_v8 l2 = lx * lx + ly * ly + lz * lz;
            const cull_v8 m = a->cull_r[k] + scale * (o1 + (a->cull_c1[k] + a->cull_r[k]));
            const cull_v8i out = l2 > m * m; /* -1 where the line is clearly outside; 0 for NaN */
            mask &= ~(out & (int)a->cull_bit[k]);
        }
        memcpy(&er[RAY_MASK * n + c], &mask, sizeof mask);
    }
}

static void cull_base(const spc_accel *a, pk_word *er, int n) { cull_loop(a, er, n); }

#if defined(__GNUC__) && defined(__x86_64__)
#define CULL_AVX512 1
__attribute__((target("avx512f"))) static void cull_avx512(const spc_accel *a, pk_word *er, int n)
{
    cull_loop(a, er, n);
}
#endif

static void cull_lines(const spc_accel *a, pk_word *er, int n)
{
    if (a->nskip == 0)
        return;
#ifdef CULL_AVX512
    if (a->cull_avx512) {
        cull_avx512(a, er, n);
        return;
    }
#endif
    cull_base(a, er, n);
}

/* A packet's answers where every hit is Embree's (a scene without user geometry), the values of
 * intersect_packet's general pick: shape[i] the geometry (-1 for a miss or an inactive lane, whose
 * geomID stays invalid), prim[i] and the float distance and surface coordinates in double, all 0
 * for a miss. In GCC vector types over 8 lanes at a time, the misses cleared with a mask: no branch
 * per lane, and none of the general pick's per-lane tables (0.8% of the cornell box's instructions,
 * bench/RESULTS.md). */
typedef double ans_v8d __attribute__((vector_size(64)));
typedef long long ans_v8l __attribute__((vector_size(64)));
static inline __attribute__((always_inline)) void answers_float(const pk_word *rh, const int N, int *shape, int *prim,
                                                                double *u, double *v, double *t)
{
    for (int c = 0; c < N; c += 8) {
        cull_v8i g, pr;
        cull_v8 tf, uf, vf;
        memcpy(&g, &rh[HIT_GEOM * N + c], sizeof g);
        memcpy(&pr, &rh[HIT_PRIM * N + c], sizeof pr);
        memcpy(&tf, &rh[RAY_TFAR * N + c], sizeof tf);
        memcpy(&uf, &rh[HIT_U * N + c], sizeof uf);
        memcpy(&vf, &rh[HIT_V * N + c], sizeof vf);
        const cull_v8i hit = g >= 0; /* -1 where the lane hit */
        const ans_v8l m = __builtin_convertvector(hit, ans_v8l);
        const ans_v8d td = __builtin_convertvector(tf, ans_v8d), ud = __builtin_convertvector(uf, ans_v8d),
                      vd = __builtin_convertvector(vf, ans_v8d);
        const ans_v8l tb = (ans_v8l)td & m, ub = (ans_v8l)ud & m, vb = (ans_v8l)vd & m;
        pr &= hit;
        memcpy(shape + c, &g, sizeof g);
        memcpy(prim + c, &pr, sizeof pr);
        memcpy(t + c, &tb, sizeof tb);
        memcpy(u + c, &ub, sizeof ub);
        memcpy(v + c, &vb, sizeof vb);
    }
}

/* spc_accel_intersect_packet with the context's coherence flag (RTC_INTERSECT_CONTEXT_FLAG_*), in
 * packets of N lanes */
static inline __attribute__((always_inline)) void intersect_packet(const spc_accel *a, const spc_ray *const *r,
                                                                   enum RTCIntersectContextFlags flags, int *shape,
                                                                   int *prim, double *u, double *v, double *t,
                                                                   const int N)
{
    ctx_ext cx;
    rtcInitIntersectContext(&cx.ctx);
    cx.ctx.flags = flags;
    cx.rays = r;
    cx.sc = a->sc;
    _Alignas(64) pk_word rh[RAYHIT_WORDS * SPC_ACCEL_PACKET];
    _Alignas(64) int valid[SPC_ACCEL_PACKET];
    int nvalid = 0, nrays = 0;
    for (int i = 0; i < N; ++i) {
        shape[i] = -1;
        cx.geom[i] = -1;
        valid[i] = r[i] && r[i]->tmax > r[i]->tmin ? -1 : 0;
        nrays += r[i] != NULL;
        PK_U(rh, N, HIT_GEOM, i) = RTC_INVALID_GEOMETRY_ID;
        PK_U(rh, N, HIT_INST, i) = RTC_INVALID_GEOMETRY_ID;
        /* what Embree leaves unwritten (a miss's primitive and uv, a lane no analytic shape
         * answered) reads as 0 in the answers below; set here, in the lanes' loop: a loop of its
         * own compiled to `rep stos`, a fifth of this function's time on the cornell box (perf) */
        PK_U(rh, N, HIT_PRIM, i) = 0;
        PK_F(rh, N, HIT_U, i) = PK_F(rh, N, HIT_V, i) = 0.0f;
        cx.t[i] = cx.u[i] = cx.v[i] = 0.0;
        if (valid[i]) {
            to_embree_lane(r[i], rh, N, i);
            ++nvalid;
        } else
            embree_lane_off(rh, N, i);
    }
    rays_traced += (uint64_t)nrays;
    if (nvalid == 0) {
        for (int i = 0; i < N; ++i) {
            prim[i] = 0;
            t[i] = u[i] = v[i] = 0.0;
        }
        return;
    }
    if (N == 8)
        rtcIntersect8(valid, a->scene, &cx.ctx, (struct RTCRayHit8 *)rh);
    else
        rtcIntersect16(valid, a->scene, &cx.ctx, (struct RTCRayHit16 *)rh);
    if (!a->analytic) {
        answers_float(rh, N, shape, prim, u, v, t);
        return;
    }
    /* The answers without a branch per lane (whether a lane hit and whether an analytic shape's
     * double answer or Embree's float one holds are coin flips in a path tracer's packets; GCC turns
     * conditional expressions here back into branches, so the values are picked by index). An
     * inactive lane's geomID stays invalid, and RTC_INVALID_GEOMETRY_ID as int is -1. */
    for (int i = 0; i < N; ++i) {
        int g = (int)PK_U(rh, N, HIT_GEOM, i);
        int k = (g >= 0) + ((g >= 0) & (cx.geom[i] == g)); /* 0 miss, 1 Embree's answer, 2 ours */
        const double tk[3] = {0.0, PK_F(rh, N, RAY_TFAR, i), cx.t[i]};
        const double uk[3] = {0.0, PK_F(rh, N, HIT_U, i), cx.u[i]};
        const double vk[3] = {0.0, PK_F(rh, N, HIT_V, i), cx.v[i]};
        shape[i] = g;
        prim[i] = (int)PK_U(rh, N, HIT_PRIM, i);
        t[i] = tk[k];
        u[i] = uk[k];
        v[i] = vk[k];
    }
}

static void intersect_packet8(const spc_accel *a, const spc_ray *const *r, enum RTCIntersectContextFlags flags,
                              int *shape, int *prim, double *u, double *v, double *t)
{
    intersect_packet(a, r, flags, shape, prim, u, v, t, 8);
}

static void intersect_packet16(const spc_accel *a, const spc_ray *const *r, enum RTCIntersectContextFlags flags,
                               int *shape, int *prim, double *u, double *v, double *t)
{
    intersect_packet(a, r, flags, shape, prim, u, v, t, 16);
}

void spc_accel_intersect_packet(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                                int shape[SPC_ACCEL_PACKET], int prim[SPC_ACCEL_PACKET], double u[SPC_ACCEL_PACKET],
                                double v[SPC_ACCEL_PACKET], double t[SPC_ACCEL_PACKET])
{
    (a->packet_width == 8 ? intersect_packet8 : intersect_packet16)(a, r, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, shape,
                                                                    prim, u, v, t);
}

void spc_accel_intersect_packet_coherent(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                                         int shape[SPC_ACCEL_PACKET], int prim[SPC_ACCEL_PACKET],
                                         double u[SPC_ACCEL_PACKET], double v[SPC_ACCEL_PACKET],
                                         double t[SPC_ACCEL_PACKET])
{
    (a->packet_width == 8 ? intersect_packet8 : intersect_packet16)(a, r, RTC_INTERSECT_CONTEXT_FLAG_COHERENT, shape,
                                                                    prim, u, v, t);
}

void spc_accel_occluded_packet(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                               bool occluded[SPC_ACCEL_PACKET])
{
    spc_accel_occluded_packet_skip(a, r, NULL, occluded);
}

/* spc_accel_occluded_packet_skip with the context's coherence flag (RTC_INTERSECT_CONTEXT_FLAG_*), in
 * packets of N lanes */
static inline __attribute__((always_inline)) void occluded_packet(const spc_accel *a, const spc_ray *const *r,
                                                                  const int *skip, enum RTCIntersectContextFlags flags,
                                                                  bool *occluded, const int N)
{
    ctx_ext cx;
    rtcInitIntersectContext(&cx.ctx);
    cx.ctx.flags = flags;
    cx.rays = r;
    cx.sc = a->sc;
    _Alignas(64) pk_word er[RAYHIT_WORDS * SPC_ACCEL_PACKET];
    _Alignas(64) int valid[SPC_ACCEL_PACKET];
    int nvalid = 0, nrays = 0;
    for (int i = 0; i < N; ++i) {
        occluded[i] = false;
        valid[i] = r[i] && r[i]->tmax > r[i]->tmin ? -1 : 0;
        nrays += r[i] != NULL;
        if (valid[i]) {
            to_embree_lane(r[i], er, N, i);
            if (skip)
                PK_U(er, N, RAY_MASK, i) = skip_mask_of(a, skip[i]);
            ++nvalid;
        } else
            embree_lane_off(er, N, i);
    }
    rays_traced += (uint64_t)nrays;
    shadow_rays_traced += (uint64_t)nrays;
    if (nvalid == 0)
        return;
    cull_lines(a, er, N);
    if (N == 8)
        rtcOccluded8(valid, a->scene, &cx.ctx, (struct RTCRay8 *)er);
    else
        rtcOccluded16(valid, a->scene, &cx.ctx, (struct RTCRay16 *)er);
    for (int i = 0; i < N; ++i)
        occluded[i] = (valid[i] != 0) & (PK_F(er, N, RAY_TFAR, i) < 0.0f);
}

static void occluded_packet8(const spc_accel *a, const spc_ray *const *r, const int *skip,
                             enum RTCIntersectContextFlags flags, bool *occluded)
{
    occluded_packet(a, r, skip, flags, occluded, 8);
}

static void occluded_packet16(const spc_accel *a, const spc_ray *const *r, const int *skip,
                              enum RTCIntersectContextFlags flags, bool *occluded)
{
    occluded_packet(a, r, skip, flags, occluded, 16);
}

void spc_accel_occluded_packet_skip(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                                    const int skip[SPC_ACCEL_PACKET], bool occluded[SPC_ACCEL_PACKET])
{
    (a->packet_width == 8 ? occluded_packet8 : occluded_packet16)(a, r, skip, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
                                                                  occluded);
}

void spc_accel_occluded_packet_skip_coherent(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                                             const int skip[SPC_ACCEL_PACKET], bool occluded[SPC_ACCEL_PACKET])
{
    (a->packet_width == 8 ? occluded_packet8 : occluded_packet16)(
        a, r, skip, a->shadows_coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
        occluded);
}
