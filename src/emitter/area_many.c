/*
 * emitter/area_many.c: light samples of many reference points at once (spc_emitter_sample_direct_many),
 * for a path tracer that runs many paths side by side (integrator/path_wave.c).
 *
 * Lights on triangle meshes sampled uniformly by area with a constant radiance (the common case:
 * the cornell box's light, quad and mesh emitters without textures) go through three loops over
 * the lanes in structure-of-arrays form: the triangle and its vertices (table lookups), the point,
 * the direction and the solid-angle density (arithmetic only, compiled also for AVX2 and AVX-512
 * and chosen at run time, so 4 or 8 lanes share an instruction), and the records. A light whose mesh
 * is a parallelogram of two triangles (spc_shape.has_para: a rectangle emitter) has its own loops with
 * no triangle to pick: o + u.x e1 + u.y e2, as spc_shape_sample_area draws it. Every other
 * light is sampled one lane at a time by spc_emitter_sample_direct, except sphere lights with a constant
 * radiance, which have their own loops (emitter/sphere_many.c).
 *
 * Bit for bit: the arithmetic is spc_area_sample_direct's, spc_shape_sample_area's and fill_mesh's
 * (scene/shape.c) in their order, in double, without fused multiply-adds (ISO C11 builds do not
 * contract, and the vector targets below do not include FMA); vector lanes round as scalars do.
 * test_path_wave compares every field with spc_emitter_sample_direct's on random points, under every
 * ISA. CMakeLists.txt compiles this file without trapping math: under it GCC keeps the point's
 * division behind a branch in the AVX2 variant, which then is not vector code.
 */
#include <float.h>
#include <math.h>

/* clang contracts a * b + c into a fused multiply-add by default where the target has one (its
 * avx512f implies FMA), which would round differently from the one-lane code */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

#include "core/cpu_isa.h"
#include "emitter/direct_lanes.h"
#include "emitter/emitter.h"
#include "scene/shape.h"
#include "scene/texture.h"

/* fill_mesh's position error bound: 8 float epsilons of the largest coordinate involved */
#define AREA_MANY_FLOAT_OFFSET (8.0 * FLT_EPSILON)

bool spc_emitter_many_covers(const spc_emitter *e)
{
    if (e->type != SPC_EMITTER_AREA || e->has_cell_distrib || !spc_texture_is_constant(e->radiance))
        return false;
    const spc_shape *s = e->shape;
    /* vertex normals turn fill_mesh's ng toward the interpolated normal: left to the one-lane path */
    return s->type == SPC_SHAPE_MESH && !(s->mesh.n && !s->face_normals);
}

/* What the arithmetic loop reads and writes, one array per quantity (structure of arrays). The
 * triangle's normal is an input, in out.n. */
typedef struct soa {
    double p0[3][SPC_DIRECT_LANES_MAX], p1[3][SPC_DIRECT_LANES_MAX], p2[3][SPC_DIRECT_LANES_MAX];
    double ref[3][SPC_DIRECT_LANES_MAX];
    /* the triangle's bin of the area CDF: u.x - cdf[t] and pmf[t], whose quotient (clamped) is the
     * point's first coordinate (spc_distrib1d_sample's remap, computed in the vector loop) */
    double ux_off[SPC_DIRECT_LANES_MAX], ux_pmf[SPC_DIRECT_LANES_MAX];
    double uy[SPC_DIRECT_LANES_MAX], area[SPC_DIRECT_LANES_MAX];
    /* a parallelogram's (spc_mesh_para) u.x and corners' magnitude; its o, e1, e2 go in p0, p1, p2 */
    double ux[SPC_DIRECT_LANES_MAX], mag[SPC_DIRECT_LANES_MAX];
    /* the one parallelogram of PARA_ONE_BODY's lanes */
    struct {
        double o[3], e1[3], e2[3], ng[2][3], mag, area;
    } one;
    spc_direct_lanes out;
    int ok[SPC_DIRECT_LANES_MAX]; /* spc_area_sample_direct's tests passed */
} soa;

static inline double max2(double a, double b) { return a > b ? a : b; }

/* The point on the triangle (spc_warp_uniform_triangle's, then fill_mesh's), its error bound along the ray, and the direction and
 * solid-angle density from ref: fill_mesh's p and err, then spc_area_sample_direct's tests and values. */
#define AREA_MANY_BODY                                                                                                \
    for (int i = 0; i < n; ++i) {                                                                                     \
        /* spc_warp_uniform_triangle's two branches as selects: (b1, b2) its (b0, b1) */                              \
        double r = a->ux_pmf[i] > 0.0 ? a->ux_off[i] / a->ux_pmf[i] : 0.0;                                           \
        double ux = spc_clamp(r, 0.0, 0x1.fffffffffffffp-1), uy = a->uy[i];                                           \
        int upper = uy > ux;                                                                                          \
        double half = (upper ? ux : uy) / 2.0, rx = ux - half, ry = uy - half;                                        \
        double b1 = upper ? half : rx, b2 = upper ? ry : half, b0 = 1.0 - b1 - b2;                                    \
        double px = a->p0[0][i] * b0 + a->p1[0][i] * b1 + a->p2[0][i] * b2;                                           \
        double py = a->p0[1][i] * b0 + a->p1[1][i] * b1 + a->p2[1][i] * b2;                                           \
        double pz = a->p0[2][i] * b0 + a->p1[2][i] * b1 + a->p2[2][i] * b2;                                           \
        double m0 = max2(fabs(a->p0[0][i]), max2(fabs(a->p0[1][i]), fabs(a->p0[2][i])));                              \
        double m1 = max2(fabs(a->p1[0][i]), max2(fabs(a->p1[1][i]), fabs(a->p1[2][i])));                              \
        double m2 = max2(fabs(a->p2[0][i]), max2(fabs(a->p2[1][i]), fabs(a->p2[2][i])));                              \
        double mag = max2(m0, max2(m1, m2));                                                                          \
        double mp = max2(fabs(px), max2(fabs(py), fabs(pz)));                                                         \
        double perr = AREA_MANY_FLOAT_OFFSET * max2(mag, mp);                                                         \
        double nx = a->out.n[0][i], ny = a->out.n[1][i], nz = a->out.n[2][i], area = a->area[i];                      \
        AREA_MANY_TAIL                                                                                                \
    }

/* The parallelogram's point (spc_shape_sample_area's has_para branch) and its error bound, then the
 * same direction and density. */
#define PARA_MANY_BODY                                                                                                \
    for (int i = 0; i < n; ++i) {                                                                                     \
        double ux = a->ux[i], uy = a->uy[i];                                                                          \
        double px = a->p0[0][i] + a->p1[0][i] * ux + a->p2[0][i] * uy;                                                \
        double py = a->p0[1][i] + a->p1[1][i] * ux + a->p2[1][i] * uy;                                                \
        double pz = a->p0[2][i] + a->p1[2][i] * ux + a->p2[2][i] * uy;                                                \
        double mp = max2(fabs(px), max2(fabs(py), fabs(pz)));                                                         \
        double perr = AREA_MANY_FLOAT_OFFSET * max2(a->mag[i], mp);                                                   \
        double nx = a->out.n[0][i], ny = a->out.n[1][i], nz = a->out.n[2][i], area = a->area[i];                      \
        AREA_MANY_TAIL                                                                                                \
    }

/* PARA_MANY_BODY for lanes that all sample one parallelogram, whose corner, edges, normals (flipped
 * where the shape is), magnitude and area are the soa's one record (loaded once, before the loop, so that GCC
 * vectorizes it): only u and ref per lane. */
#define PARA_ONE_BODY                                                                                                 \
    const double o0 = a->one.o[0], o1 = a->one.o[1], o2 = a->one.o[2];                                                \
    const double e10 = a->one.e1[0], e11 = a->one.e1[1], e12 = a->one.e1[2];                                          \
    const double e20 = a->one.e2[0], e21 = a->one.e2[1], e22 = a->one.e2[2];                                          \
    const double n00 = a->one.ng[0][0], n01 = a->one.ng[0][1], n02 = a->one.ng[0][2];                                 \
    const double n10 = a->one.ng[1][0], n11 = a->one.ng[1][1], n12 = a->one.ng[1][2];                                 \
    const double mag = a->one.mag, area = a->one.area;                                                                \
    for (int i = 0; i < n; ++i) {                                                                                     \
        double ux = a->ux[i], uy = a->uy[i];                                                                          \
        int t = ux + uy > 1.0;                                                                                        \
        double nx = t ? n10 : n00, ny = t ? n11 : n01, nz = t ? n12 : n02;                                            \
        a->out.n[0][i] = nx;                                                                                          \
        a->out.n[1][i] = ny;                                                                                          \
        a->out.n[2][i] = nz;                                                                                          \
        double px = o0 + e10 * ux + e20 * uy;                                                                         \
        double py = o1 + e11 * ux + e21 * uy;                                                                         \
        double pz = o2 + e12 * ux + e22 * uy;                                                                         \
        double mp = max2(fabs(px), max2(fabs(py), fabs(pz)));                                                         \
        double perr = AREA_MANY_FLOAT_OFFSET * max2(mag, mp);                                                         \
        AREA_MANY_TAIL                                                                                                \
    }

/* From the point (px, py, pz), its error bound perr, the normal (nx, ny, nz) and the area:
 * spc_area_sample_direct's tests and values. */
#define AREA_MANY_TAIL                                                                                                \
        double dx = px - a->ref[0][i], dy = py - a->ref[1][i], dz = pz - a->ref[2][i];                                \
        double dist2 = dx * dx + dy * dy + dz * dz;                                                                   \
        double cosl = fabs(nx * dx + ny * dy + nz * dz) / sqrt(dist2);                                                \
        double pdf = 1.0 / area * dist2 / cosl;                                                                       \
        a->out.err[i] = perr / max2(cosl, SPC_AREA_GRAZING_COS); /* along the ray (emitter.h) */                      \
        double dist = sqrt(dist2);                                                                                    \
        double inv = 1.0 / dist;                                                                                      \
        double wx = dx * inv, wy = dy * inv, wz = dz * inv;                                                           \
        SPC_DIRECT_LANES_STORE(&a->out, i, px, py, pz, nx, ny, nz, wx, wy, wz, dist, pdf);                            \
        a->ok[i] = (cosl > 0.0) & (dist2 > 0.0) & (dist > 0.0) & (pdf > 0.0) & (pdf <= DBL_MAX);

static void body_default(soa *a, int n) { AREA_MANY_BODY }
static void para_default(soa *a, int n) { PARA_MANY_BODY }
static void para_one_default(soa *a, int n) { PARA_ONE_BODY }

#if defined(__x86_64__) && defined(__GNUC__)
#define AREA_MANY_VECTOR 1
#if defined(__clang__)
#define AREA_MANY_ATTR(t) __attribute__((target(t)))
#else
#define AREA_MANY_ATTR(t) __attribute__((target(t), optimize("O3"))) /* GCC's -O2 does not vectorize */
#endif
AREA_MANY_ATTR("avx2") static void body_avx2(soa *a, int n) { AREA_MANY_BODY }
AREA_MANY_ATTR("avx512f") static void body_avx512(soa *a, int n) { AREA_MANY_BODY }
AREA_MANY_ATTR("avx2") static void para_avx2(soa *a, int n) { PARA_MANY_BODY }
AREA_MANY_ATTR("avx512f") static void para_avx512(soa *a, int n) { PARA_MANY_BODY }
AREA_MANY_ATTR("avx2") static void para_one_avx2(soa *a, int n) { PARA_ONE_BODY }
AREA_MANY_ATTR("avx512f") static void para_one_avx512(soa *a, int n) { PARA_ONE_BODY }
#endif

static void body(soa *a, int n)
{
#ifdef AREA_MANY_VECTOR
    int isa = spc_vector_isa(); /* the variants give the same results */
    if (isa == SPC_ISA_AVX512)
        body_avx512(a, n);
    else if (isa == SPC_ISA_AVX2)
        body_avx2(a, n);
    else
        body_default(a, n);
#else
    body_default(a, n);
#endif
}

static void para_body(soa *a, int n, bool one)
{
#ifdef AREA_MANY_VECTOR
    int isa = spc_vector_isa();
    if (isa == SPC_ISA_AVX512)
        one ? para_one_avx512(a, n) : para_avx512(a, n);
    else if (isa == SPC_ISA_AVX2)
        one ? para_one_avx2(a, n) : para_avx2(a, n);
    else
        one ? para_one_default(a, n) : para_default(a, n);
#else
    one ? para_one_default(a, n) : para_default(a, n);
#endif
}

/* Up to SPC_DIRECT_LANES_MAX lanes whose emitters all pass spc_emitter_many_covers and whose shapes
 * are parallelograms (spc_shape.has_para): no triangle to pick. */
static void sample_para_lights(int n, const int *lane, const spc_emitter *const e[], const spc_vec3 ref[],
                               const spc_vec2 u[], spc_emitter_direct out[], bool ok[])
{
    soa a;
    /* one light's lanes (a room's one quad light, the common case): its record once, no per-lane copies */
    const spc_shape *s0 = e[lane[0]]->shape;
    bool one = true;
    for (int k = 1; k < n; ++k)
        one &= e[lane[k]]->shape == s0;
    if (one) {
        const spc_mesh_para *q = &s0->para;
        for (int j = 0; j < 3; ++j) {
            a.one.o[j] = spc_v3_get(q->o, j);
            a.one.e1[j] = spc_v3_get(q->e1, j);
            a.one.e2[j] = spc_v3_get(q->e2, j);
            for (int t = 0; t < 2; ++t)
                a.one.ng[t][j] = spc_v3_get(s0->flip_normals ? spc_neg(q->ng[t]) : q->ng[t], j);
        }
        a.one.mag = q->mag;
        a.one.area = s0->area;
        for (int k = 0; k < n; ++k) {
            int i = lane[k];
            for (int j = 0; j < 3; ++j)
                a.ref[j][k] = spc_v3_get(ref[i], j);
            a.ux[k] = u[i].x;
            a.uy[k] = u[i].y;
        }
    }
    for (int k = 0; k < n && !one; ++k) {
        int i = lane[k];
        const spc_shape *s = e[i]->shape;
        const spc_mesh_para *q = &s->para;
        /* spc_shape_sample_area's triangle test, for the normal */
        spc_vec3 ng = q->ng[u[i].x + u[i].y > 1.0];
        if (s->flip_normals)
            ng = spc_neg(ng);
        for (int j = 0; j < 3; ++j) {
            a.p0[j][k] = spc_v3_get(q->o, j);
            a.p1[j][k] = spc_v3_get(q->e1, j);
            a.p2[j][k] = spc_v3_get(q->e2, j);
            a.out.n[j][k] = spc_v3_get(ng, j);
            a.ref[j][k] = spc_v3_get(ref[i], j);
        }
        a.ux[k] = u[i].x;
        a.uy[k] = u[i].y;
        a.mag[k] = q->mag;
        a.area[k] = s->area;
    }
    para_body(&a, n, one);
    for (int k = 0; k < n; ++k) {
        int i = lane[k];
        ok[i] = spc_direct_lanes_write(&a.out, k, a.ok[k], e[i]->radiance, &out[i]);
    }
}

/* Up to SPC_DIRECT_LANES_MAX lanes whose emitters all pass spc_emitter_many_covers. */
static void sample_mesh_lights(int n, const int *lane, const spc_emitter *const e[], const spc_vec3 ref[],
                               const spc_vec2 u[], spc_emitter_direct out[], bool ok[])
{
    soa a;
    for (int k = 0; k < n; ++k) {
        int i = lane[k];
        const spc_shape *s = e[i]->shape;
        const spc_mesh *m = &s->mesh;
        /* spc_shape_sample_area: the triangle by area, a point uniformly in it */
        const spc_distrib1d *td = &s->tri_distrib;
        size_t t = spc_distrib1d_sample(td, u[i].x, NULL);
        spc_vec3 ng;
        if (s->tri_frame) {
            /* the normal and the vertices kept with the triangle (shape.h) */
            const double *c = s->tri_frame + SPC_TRI_FRAME_STRIDE * t;
            ng = spc_v3(c[0], c[1], c[2]);
            for (int j = 0; j < 3; ++j) {
                a.p0[j][k] = c[10 + j];
                a.p1[j][k] = c[13 + j];
                a.p2[j][k] = c[16 + j];
            }
        } else {
            const uint32_t *idx = m->idx + 3 * t;
            const float *q0 = m->p + 3 * (size_t)idx[0], *q1 = m->p + 3 * (size_t)idx[1];
            const float *q2 = m->p + 3 * (size_t)idx[2];
            spc_vec3 p0 = spc_v3(q0[0], q0[1], q0[2]);
            ng = spc_normalize(spc_cross(spc_sub(spc_v3(q1[0], q1[1], q1[2]), p0), spc_sub(spc_v3(q2[0], q2[1], q2[2]), p0)));
            for (int j = 0; j < 3; ++j) {
                a.p0[j][k] = q0[j];
                a.p1[j][k] = q1[j];
                a.p2[j][k] = q2[j];
            }
        }
        if (s->flip_normals)
            ng = spc_neg(ng);
        for (int j = 0; j < 3; ++j) {
            a.out.n[j][k] = spc_v3_get(ng, j);
            a.ref[j][k] = spc_v3_get(ref[i], j);
        }
        a.ux_off[k] = u[i].x - td->cdf[t];
        a.ux_pmf[k] = td->pmf[t];
        a.uy[k] = u[i].y;
        a.area[k] = s->area;
    }
    body(&a, n);
    for (int k = 0; k < n; ++k) {
        int i = lane[k];
        ok[i] = spc_direct_lanes_write(&a.out, k, a.ok[k], e[i]->radiance, &out[i]);
    }
}

void spc_emitter_sample_direct_many(int n, const spc_emitter *const e[], const spc_vec3 ref[], const spc_vec2 u[],
                                    spc_emitter_direct out[], bool ok[])
{
    /* the lanes of each kind in batches of SPC_DIRECT_LANES_MAX (direct_lanes.h) */
    int lane[SPC_DIRECT_LANES_MAX], m = 0;
    int sphere_lane[SPC_DIRECT_LANES_MAX], ms = 0;
    int para_lane[SPC_DIRECT_LANES_MAX], mp = 0;
    /* the kind of the last lane's light (1 mesh, 2 sphere, 3 parallelogram, 0 other), kept for the next lanes of the
     * same light: the tests read the light, its texture and its shape, and most lanes share a light */
    const spc_emitter *last = NULL;
    int kind = 0;
    for (int i = 0; i < n; ++i) {
        if (e[i] && e[i] != last) {
            last = e[i];
            kind = spc_emitter_many_covers(last) ? (last->shape->has_para ? 3 : 1)
                   : spc_emitter_many_covers_sphere(last) ? 2
                                                          : 0;
        }
        if (!e[i]) {
            ok[i] = false;
        } else if (kind == 1) {
            lane[m++] = i;
            if (m == SPC_DIRECT_LANES_MAX) {
                sample_mesh_lights(m, lane, e, ref, u, out, ok);
                m = 0;
            }
        } else if (kind == 3) {
            para_lane[mp++] = i;
            if (mp == SPC_DIRECT_LANES_MAX) {
                sample_para_lights(mp, para_lane, e, ref, u, out, ok);
                mp = 0;
            }
        } else if (kind == 2) {
            sphere_lane[ms++] = i;
            if (ms == SPC_DIRECT_LANES_MAX) {
                spc_emitter_sample_spheres_many(ms, sphere_lane, e, ref, u, out, ok);
                ms = 0;
            }
        } else {
            ok[i] = spc_emitter_sample_direct(e[i], ref[i], u[i], &out[i]);
        }
    }
    if (m > 0)
        sample_mesh_lights(m, lane, e, ref, u, out, ok);
    if (ms > 0)
        spc_emitter_sample_spheres_many(ms, sphere_lane, e, ref, u, out, ok);
    if (mp > 0)
        sample_para_lights(mp, para_lane, e, ref, u, out, ok);
}
