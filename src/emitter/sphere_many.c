/*
 * emitter/sphere_many.c: light samples of many reference points on sphere lights at once, for
 * spc_emitter_sample_direct_many (emitter/area_many.c) and so for the packet path tracer
 * (integrator/path_wave.c).
 *
 * A sphere light with a constant radiance seen from outside is sampled by the cone it subtends
 * (spc_shape_sample_solid_angle, pbrt-v4's Sphere::Sample): two square roots, three divisions, a
 * polynomial sine and cosine and a frame per sample, a chain of long-latency operations that one
 * lane at a time cannot overlap. Here the lanes' inputs are gathered into arrays (structure of
 * arrays), one loop without branches computes every lane's point, normal, direction, distance and
 * density, compiled also for AVX2 and AVX-512 and chosen at run time (4 or 8 lanes per
 * instruction), and a last loop writes the records.
 *
 * Bit for bit: the loop is spc_shape_sample_solid_angle's, spc_sincos_2pi's, spc_frame_from_n's and
 * spc_area_sample_direct's arithmetic in their order, in double, without fused multiply-adds (ISO
 * C11 builds do not contract, and the vector targets do not include FMA). The branches become
 * selects that give the same values: spc_sincos_2pi's integer quarter turn is floor() of the same
 * double (exact below 2^53), its switch on the quadrant a choice among the same four pairs;
 * spc_safe_sqrt(x) is sqrt of x where x > 0 and of 0 elsewhere (0 either way). test_sphere_many
 * compares every field with spc_emitter_sample_direct's using memcmp.
 */
/* O3 vectorizes the loop; without trapping math GCC may if-convert the divisions and square roots
 * that it otherwise moves under the selects. Neither changes a value (no contraction, no
 * reassociation). A pragma rather than per-function attributes, so the header's inline helpers
 * (spc_sincos_quarter) are compiled with the same options and inlined into the vector loops. */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("O3", "no-trapping-math")
#endif
/* clang contracts a * b + c into a fused multiply-add by default where the target has one (its
 * avx512f implies FMA), which would round differently from the one-lane code */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif
#include <float.h>
#include <math.h>

#include "core/cpu_isa.h"
#include "emitter/direct_lanes.h"
#include "emitter/emitter.h"
#include "scene/shape.h"
#include "scene/texture.h"

bool spc_emitter_many_covers_sphere(const spc_emitter *e)
{
    return e->type == SPC_EMITTER_AREA && !e->has_cell_distrib && spc_texture_is_constant(e->radiance) &&
           e->shape->type == SPC_SHAPE_SPHERE;
}

/* What the arithmetic loop reads and writes, one array per quantity. */
typedef struct soa {
    double c[3][SPC_DIRECT_LANES_N], ref[3][SPC_DIRECT_LANES_N];
    double R[SPC_DIRECT_LANES_N], flip[SPC_DIRECT_LANES_N]; /* flip: -1 where flip_normals, else 1 */
    double ux[SPC_DIRECT_LANES_N], uy[SPC_DIRECT_LANES_N];
    spc_direct_lanes out; /* err is set with the inputs */
} soa;

/* spc_safe_sqrt as a select on the argument (the same value, NaN included: both give 0) */
#define SPHERE_MANY_SAFE_SQRT(x) sqrt((x) > 0.0 ? (x) : 0.0)

#define SPHERE_MANY_BODY                                                                                               \
    for (int i = 0; i < n; ++i) {                                                                                      \
        double cx = a->c[0][i], cy = a->c[1][i], cz = a->c[2][i];                                                      \
        double rx = a->ref[0][i], ry = a->ref[1][i], rz = a->ref[2][i];                                                \
        /* spc_shape_sample_solid_angle: the cone's direction, then the point by the angle at the center */            \
        double dcx = cx - rx, dcy = cy - ry, dcz = cz - rz;                                                            \
        double dist2 = dcx * dcx + dcy * dcy + dcz * dcz, inv_dist = 1.0 / sqrt(dist2);                                \
        double R = a->R[i];                                                                                            \
        double sin2_max = R * R / dist2;                                                                               \
        double cm2 = 1.0 - sin2_max;                                                                                   \
        double cos_max = sqrt(0.0 > cm2 ? 0.0 : cm2);                                                                  \
        double one_minus_cos = a->ux[i] * (1.0 - cos_max);                                                             \
        double cos_t = 1.0 - one_minus_cos, sin2_t = one_minus_cos * (2.0 - one_minus_cos);                            \
        double ca2 = 1.0 - sin2_t / sin2_max;                                                                          \
        double cos_a = sin2_t / (R * inv_dist) + cos_t * SPHERE_MANY_SAFE_SQRT(ca2);                                   \
        cos_a = cos_a < 1.0 ? cos_a : 1.0;                                                                             \
        double sa2 = 1.0 - cos_a * cos_a;                                                                              \
        double sin_a = SPHERE_MANY_SAFE_SQRT(sa2);                                                                     \
        /* spc_sincos_2pi(u.y): the quarter turn q = floor(4 u + 1/2), its quadrant q mod 4 */                         \
        double uy = a->uy[i];                                                                                          \
        double q = floor(4.0 * uy + 0.5);                                                                              \
        double quad = q - 4.0 * floor(q * 0.25);                                                                       \
        double sr, cr;                                                                                                 \
        spc_sincos_quarter(2.0 * SPC_PI * (uy - 0.25 * q), &sr, &cr);                                                  \
        double sp = quad == 0.0 ? sr : quad == 1.0 ? cr : quad == 2.0 ? -sr : -cr;                                     \
        double cp = quad == 0.0 ? cr : quad == 1.0 ? -sr : quad == 2.0 ? -cr : sr;                                     \
        /* spc_frame_from_n(dc / |dc|) */                                                                              \
        double fnx = dcx * inv_dist, fny = dcy * inv_dist, fnz = dcz * inv_dist;                                       \
        double sign = copysign(1.0, fnz);                                                                              \
        double fa = -1.0 / (sign + fnz);                                                                               \
        double fb = fnx * fny * fa;                                                                                    \
        double sx = 1.0 + sign * fnx * fnx * fa, sy = sign * fb, sz = -sign * fnx;                                     \
        double tx = fb, ty = sign + fny * fny * fa, tz = -fny;                                                         \
        /* spc_frame_to_world(v), v = (-sin_a cp, -sin_a sp, -cos_a) */                                                \
        double vx = -sin_a * cp, vy = -sin_a * sp, vz = -cos_a;                                                        \
        double nx = sx * vx + tx * vy + fnx * vz;                                                                      \
        double ny = sy * vx + ty * vy + fny * vz;                                                                      \
        double nz = sz * vx + tz * vy + fnz * vz;                                                                      \
        double px = cx + nx * R, py = cy + ny * R, pz = cz + nz * R;                                                   \
        double f = a->flip[i];                                                                                         \
        double onx = f < 0.0 ? -nx : nx, ony = f < 0.0 ? -ny : ny, onz = f < 0.0 ? -nz : nz;                           \
        double pdf = 1.0 / (2.0 * SPC_PI * (1.0 - cos_max)); /* spc_warp_uniform_cone_pdf */                           \
        /* spc_area_sample_direct */                                                                                   \
        double dx = px - rx, dy = py - ry, dz = pz - rz;                                                               \
        double dist = sqrt(dx * dx + dy * dy + dz * dz);                                                               \
        double inv = 1.0 / dist;                                                                                       \
        double wx = dx * inv, wy = dy * inv, wz = dz * inv;                                                            \
        a->out.n[0][i] = onx;                                                                                          \
        a->out.n[1][i] = ony;                                                                                          \
        a->out.n[2][i] = onz;                                                                                          \
        SPC_DIRECT_LANES_STORE(&a->out, i, px, py, pz, onx, ony, onz, wx, wy, wz, dist, pdf);                          \
    }

static void body_default(soa *a, int n){SPHERE_MANY_BODY}

#if defined(__x86_64__) && defined(__GNUC__)
#define SPHERE_MANY_VECTOR 1
#define SPHERE_MANY_ATTR(t) __attribute__((target(t)))
SPHERE_MANY_ATTR("avx2") static void body_avx2(soa *a, int n){
    SPHERE_MANY_BODY} SPHERE_MANY_ATTR("avx512f") static void body_avx512(soa *a, int n)
{
    SPHERE_MANY_BODY
}
#endif

static int isa_forced = -1; /* spc_emitter_spheres_many_isa's choice; -1: the best the CPU has */

/* 2: AVX-512, 1: AVX2, 0: the plain loop (the same results) */
static int isa_best(void)
{
#ifdef SPHERE_MANY_VECTOR
    return spc_vector_isa();
#else
    return 0;
#endif
}

int spc_emitter_spheres_many_isa(int isa)
{
    int best = isa_best();
    isa_forced = isa < 0 ? -1 : isa < best ? isa : best;
    return isa_forced < 0 ? best : isa_forced;
}

static void body(soa *a, int n)
{
    int isa = isa_forced >= 0 ? isa_forced : isa_best();
#ifdef SPHERE_MANY_VECTOR
    if (isa == 2)
        body_avx512(a, n);
    else if (isa == 1)
        body_avx2(a, n);
    else
        body_default(a, n);
#else
    (void)isa;
    body_default(a, n);
#endif
}

void spc_emitter_sample_spheres_many(int n, const int *lane, const spc_emitter *const e[], const spc_vec3 ref[],
                                     const spc_vec2 u[], spc_emitter_direct out[], bool ok[])
{
    soa a;
    int k = 0, slot[SPC_EMITTER_MANY_MAX];
    for (int j = 0; j < n; ++j) {
        int i = lane[j];
        const spc_shape *s = e[i]->shape;
        if (!spc_shape_has_solid_angle_sampling(s, ref[i])) {
            /* inside the sphere: area sampling, one lane */
            ok[i] = spc_emitter_sample_direct(e[i], ref[i], u[i], &out[i]);
            continue;
        }
        a.c[0][k] = s->center.x;
        a.c[1][k] = s->center.y;
        a.c[2][k] = s->center.z;
        a.ref[0][k] = ref[i].x;
        a.ref[1][k] = ref[i].y;
        a.ref[2][k] = ref[i].z;
        a.R[k] = s->radius;
        a.flip[k] = s->flip_normals ? -1.0 : 1.0;
        a.out.err[k] = 1e-9 * (spc_max_abs(s->center) + s->radius); /* the sphere's SPC_DOUBLE_OFFSET bound */
        a.ux[k] = u[i].x;
        a.uy[k] = u[i].y;
        slot[k++] = i;
    }
    if (k == 0)
        return;
    body(&a, k);
    for (int j = 0; j < k; ++j) {
        int i = slot[j];
        /* spc_area_sample_direct's tests, outside the loop: a flag computed there lets GCC thread it
         * through cos_max's select and give up vectorizing */
        bool valid = a.out.dist[j] > 0.0 && a.out.pdf[j] > 0.0 && a.out.pdf[j] <= DBL_MAX;
        ok[i] = spc_direct_lanes_write(&a.out, j, valid, e[i]->radiance, &out[i]);
    }
}
