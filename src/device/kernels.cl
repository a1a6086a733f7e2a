/*
 * device/kernels.cl: the OpenCL C 1.2 kernels of the opencl device (src/device/opencl.c builds
 * their inputs and documents the buffer layouts, which the *_STRIDE macros below must match).
 *
 * One work item renders one camera sample: pixel (x, y) of pass p, for the passes of a batch.
 * Everything is single precision. Geometry: signed distance fields from the flat postfix
 * program of scene/sdf.c (spc_sdf_flatten) evaluated on a small value stack, analytic spheres
 * and triangles (rectangles, cubes: meshes of a few triangles, tested one by one).
 *
 * Tolerances (float has 24 bits: coordinates are known to ~6e-8 of their magnitude):
 * - RAY_EPS: a spawned ray starts RAY_EPS * (scale + |p|) off the surface along the normal, on the
 *   side it leaves to, where scale is the magnitude of the scene's bounds (scene_scale); a shadow
 *   ray stops as far before its end point. 2e-5 is ~300 times the rounding of a coordinate, and
 *   above the position error of SDF hits (below). The CPU device uses 1e-9 in double.
 * - Sphere tracing (sdf_intersect): steps of max(|f|, SDF_MIN_STEP * size), size the diagonal of
 *   the shape's bounds; rather than stopping once |f| is small, the march looks for the sign
 *   change of f (which also finds the exit of a ray that starts inside, for refraction) and
 *   bisects that bracket SDF_BISECT times (2^-24 of the step: float resolution). Features thinner
 *   than 1e-5 of the shape can be stepped over; a march of SDF_MAX_STEPS steps is a miss.
 * - SDF normals: the tetrahedral four-point gradient (paper 004) with h = SDF_GRAD_H * size: its
 *   rounding error is ~1e-4 relative and it rounds creases (CSG edges) over a band of width h.
 * Random numbers: counter-based, a hash of (pixel, pass, seed, draw counter): any pass of any
 * pixel can be rendered in any order and on any device and gives the same numbers for the same
 * kernel.
 *
 * Integrators: path (NEE with the power heuristic, as integrator/path.c) and bdpt (Veach's
 * bidirectional path tracing with the power or balance heuristic; light-tracing splats are
 * written to a per-sample record list and merged by the host in order, so the image stays
 * deterministic).
 */

#define SHAPE_SPHERE 0
#define SHAPE_SDF 1
#define SHAPE_MESH 2

#define BSDF_DIFFUSE 0
#define BSDF_CONDUCTOR 1
#define BSDF_DIELECTRIC 2

#define SDF_SPHERE 0
#define SDF_BOX 1
#define SDF_ROUNDBOX 2
#define SDF_TORUS 3
#define SDF_CAPSULE 4
#define SDF_CYLINDER 5
#define SDF_PLANE 6
#define SDF_UNION 7
#define SDF_INTERSECTION 8
#define SDF_DIFFERENCE 9
#define SDF_SMOOTH_UNION 10

#define SHAPE_I_STRIDE 8  /* type, bsdf, emitter, flip, start, count, -, - */
#define SHAPE_F_STRIDE 16 /* sphere: c r; sdf: lo hi size; mesh: area */
#define NODE_F_STRIDE 24  /* M (12), s, param (8), - */
#define TRI_STRIDE 16     /* p0 e1 e2 n cdf (within its mesh) */
#define BSDF_F_STRIDE 12
#define EMIT_F_STRIDE 8   /* radiance rgb, pmf, cdf */
#define CAM_F_STRIDE 24

#define RAY_EPS 2e-5f
#define SDF_MIN_STEP 1e-5f
#define SDF_MAX_STEPS 2048
#define SDF_BISECT 24
#define SDF_GRAD_H 1e-3f
#define SDF_STACK 16
#define PI_F 3.14159265358979f
#define INV_PI_F 0.318309886183791f
#define MAX_SPLATS 32
#define BDPT_MAX_VERTS 20

typedef struct scene_t {
    int nshapes, nemitters;
    float scale;
    __global const int *shape_i;
    __global const float *shape_f;
    __global const int *node_i;
    __global const float *node_f;
    __global const float *tri;
    __global const int *bsdf_i;
    __global const float *bsdf_f;
    __global const int *emit_i;
    __global const float *emit_f;
    uint *rays; /* rays traced by this work item (the driver's statistics) */
} scene_t;

typedef struct hit_t {
    float3 p, n; /* point, geometric (= shading) normal with flip_normals applied */
    float t;
    int shape;
} hit_t;

/* ---- random numbers ---- */

typedef struct rng_t {
    uint key, counter;
} rng_t;

static uint mix32(uint x)
{
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

static rng_t rng_start(uint px, uint py, uint pass, uint seed_lo, uint seed_hi)
{
    rng_t r;
    r.key = mix32(px ^ mix32(py ^ mix32(pass ^ mix32(seed_lo ^ mix32(seed_hi + 0x9e3779b9U)))));
    r.counter = 0;
    return r;
}

static float rnd(rng_t *r)
{
    uint v = mix32(mix32(r->key ^ (r->counter * 0x9e3779b9U)) + r->key);
    r->counter++;
    return (float)(v >> 8) * (1.0f / 16777216.0f);
}

/* ---- small math ---- */

static float maxc(float3 v) { return fmax(v.x, fmax(v.y, v.z)); }
static float max_abs3(float3 v) { return fmax(fabs(v.x), fmax(fabs(v.y), fabs(v.z))); }

static void frame(float3 n, float3 *s, float3 *t)
{
    /* Duff et al. 2017 */
    float sign = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (sign + n.z), b = n.x * n.y * a;
    *s = (float3)(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    *t = (float3)(b, sign + n.y * n.y * a, -n.y);
}

static float3 to_world(float3 n, float3 l)
{
    float3 s, t;
    frame(n, &s, &t);
    return s * l.x + t * l.y + n * l.z;
}

static float3 cosine_hemisphere(float u1, float u2)
{
    float r = sqrt(u1), phi = 2.0f * PI_F * u2;
    return (float3)(r * cos(phi), r * sin(phi), sqrt(fmax(0.0f, 1.0f - u1)));
}

static float power_heuristic(float a, float b, float beta)
{
    if (beta == 1.0f)
        return a / (a + b);
    float a2 = a * a, b2 = b * b;
    if (isinf(a2))
        return 1.0f;
    return a2 / (a2 + b2);
}

/* ---- signed distance fields ---- */

static float sdf_prim(int type, __global const float *nf, float3 pw)
{
    float3 p = (float3)(nf[0] * pw.x + nf[1] * pw.y + nf[2] * pw.z + nf[3],
                        nf[4] * pw.x + nf[5] * pw.y + nf[6] * pw.z + nf[7],
                        nf[8] * pw.x + nf[9] * pw.y + nf[10] * pw.z + nf[11]);
    float s = nf[12];
    __global const float *q = nf + 13;
    float f = 0.0f;
    switch (type) {
    case SDF_SPHERE: f = length(p) - q[0]; break;
    case SDF_BOX:
    case SDF_ROUNDBOX: {
        float3 d = fabs(p) - (float3)(q[0], q[1], q[2]);
        f = length(fmax(d, (float3)(0.0f))) + fmin(fmax(d.x, fmax(d.y, d.z)), 0.0f) - q[3];
        break;
    }
    case SDF_TORUS: {
        float a = sqrt(p.x * p.x + p.z * p.z) - q[0];
        f = sqrt(a * a + p.y * p.y) - q[1];
        break;
    }
    case SDF_CAPSULE: {
        float3 a = (float3)(q[0], q[1], q[2]), ba = (float3)(q[3], q[4], q[5]) - a, pa = p - a;
        float bb = dot(ba, ba);
        float h = bb > 0.0f ? clamp(dot(pa, ba) / bb, 0.0f, 1.0f) : 0.0f;
        f = length(pa - ba * h) - q[6];
        break;
    }
    case SDF_CYLINDER: {
        float q1 = sqrt(p.x * p.x + p.z * p.z) - q[0], q2 = fabs(p.y) - q[1];
        float m1 = fmax(q1, 0.0f), m2 = fmax(q2, 0.0f);
        f = fmin(fmax(q1, q2), 0.0f) + sqrt(m1 * m1 + m2 * m2);
        break;
    }
    case SDF_PLANE: f = q[0] * p.x + q[1] * p.y + q[2] * p.z - q[3]; break;
    default: break;
    }
    return s * f;
}

static float sdf_eval(const scene_t *sc, int start, int count, float3 p)
{
    float st[SDF_STACK];
    int sp = 0;
    for (int i = 0; i < count; ++i) {
        int type = sc->node_i[start + i];
        __global const float *nf = sc->node_f + (size_t)(start + i) * NODE_F_STRIDE;
        if (type < SDF_UNION) {
            st[sp++] = sdf_prim(type, nf, p);
            continue;
        }
        float b = st[--sp], a = st[sp - 1], f;
        switch (type) {
        case SDF_UNION: f = fmin(a, b); break;
        case SDF_INTERSECTION: f = fmax(a, b); break;
        case SDF_DIFFERENCE: f = fmax(a, -b); break;
        default: {
            float k = nf[13];
            float h = clamp(0.5f + 0.5f * (b - a) / k, 0.0f, 1.0f);
            f = b + h * (a - b) - k * h * (1.0f - h);
            break;
        }
        }
        st[sp - 1] = f;
    }
    return st[0];
}

static bool clip_box(float3 lo, float3 hi, float3 o, float3 d, float *t0, float *t1)
{
    float3 inv = 1.0f / d;
    float3 ta = (lo - o) * inv, tb = (hi - o) * inv;
    float3 tn = fmin(ta, tb), tf = fmax(ta, tb);
    float a = fmax(*t0, fmax(tn.x, fmax(tn.y, tn.z))), b = fmin(*t1, fmin(tf.x, fmin(tf.y, tf.z)));
    *t0 = a;
    *t1 = b;
    return a <= b;
}

/* First sign change of the field along o + t d (d unit) in (tmin, tmax). */
static bool sdf_intersect(const scene_t *sc, int shape, float3 o, float3 d, float tmin, float tmax, float *t_hit)
{
    __global const int *si = sc->shape_i + shape * SHAPE_I_STRIDE;
    __global const float *sf = sc->shape_f + shape * SHAPE_F_STRIDE;
    int start = si[4], count = si[5];
    float3 lo = (float3)(sf[0], sf[1], sf[2]), hi = (float3)(sf[3], sf[4], sf[5]);
    float size = sf[6];
    float t0 = tmin, t1 = tmax;
    if (!clip_box(lo, hi, o, d, &t0, &t1))
        return false;
    float min_step = SDF_MIN_STEP * size;
    float t = t0, f = sdf_eval(sc, start, count, o + d * t);
    if (f == 0.0f) {
        t += min_step;
        f = sdf_eval(sc, start, count, o + d * t);
    }
    bool pos = f > 0.0f;
    for (int it = 0; it < SDF_MAX_STEPS && t < t1; ++it) {
        float step = fmax(fabs(f), min_step);
        float tn = fmin(t + step, t1), fn = sdf_eval(sc, start, count, o + d * tn);
        if (pos ? !(fn > 0.0f) : !(fn < 0.0f)) {
            float ta = t, tb = tn;
            for (int k = 0; k < SDF_BISECT; ++k) {
                float tm = 0.5f * (ta + tb), fm = sdf_eval(sc, start, count, o + d * tm);
                if ((fm > 0.0f) == pos && fm != 0.0f)
                    ta = tm;
                else
                    tb = tm;
            }
            *t_hit = 0.5f * (ta + tb);
            return *t_hit > tmin && *t_hit < tmax;
        }
        if (tn >= t1)
            break;
        t = tn;
        f = fn;
    }
    return false;
}

static float3 sdf_normal(const scene_t *sc, int shape, float3 p)
{
    __global const int *si = sc->shape_i + shape * SHAPE_I_STRIDE;
    __global const float *sf = sc->shape_f + shape * SHAPE_F_STRIDE;
    int start = si[4], count = si[5];
    float h = SDF_GRAD_H * sf[6];
    const float3 k0 = (float3)(1, -1, -1), k1 = (float3)(-1, -1, 1), k2 = (float3)(-1, 1, -1), k3 = (float3)(1, 1, 1);
    float3 g = k0 * sdf_eval(sc, start, count, p + k0 * h) + k1 * sdf_eval(sc, start, count, p + k1 * h) +
               k2 * sdf_eval(sc, start, count, p + k2 * h) + k3 * sdf_eval(sc, start, count, p + k3 * h);
    float l = length(g);
    return l > 0.0f ? g / l : (float3)(0, 0, 1);
}

/* ---- analytic shapes ---- */

static bool sphere_intersect(float3 c, float r, float3 o, float3 d, float tmin, float tmax, float *t)
{
    /* the numerically stable form (Haines et al., Ray Tracing Gems ch. 7) */
    float3 f = o - c;
    float b = -dot(f, d);
    float3 l = f + d * b;
    float disc = r * r - dot(l, l);
    if (disc < 0.0f)
        return false;
    float sq = sqrt(disc);
    float q = b + (b >= 0.0f ? sq : -sq);
    float c2 = dot(f, f) - r * r;
    float ta = c2 / q, tb = q;
    if (q == 0.0f)
        ta = tb = 0.0f;
    float t0 = fmin(ta, tb), t1 = fmax(ta, tb);
    if (t0 > tmin && t0 < tmax) {
        *t = t0;
        return true;
    }
    if (t1 > tmin && t1 < tmax) {
        *t = t1;
        return true;
    }
    return false;
}

static bool tri_intersect(__global const float *tr, float3 o, float3 d, float tmin, float tmax, float *t)
{
    float3 p0 = (float3)(tr[0], tr[1], tr[2]), e1 = (float3)(tr[3], tr[4], tr[5]), e2 = (float3)(tr[6], tr[7], tr[8]);
    float3 pv = cross(d, e2);
    float det = dot(e1, pv);
    if (det == 0.0f)
        return false;
    float inv = 1.0f / det;
    float3 tv = o - p0;
    float u = dot(tv, pv) * inv;
    if (u < 0.0f || u > 1.0f)
        return false;
    float3 qv = cross(tv, e1);
    float v = dot(d, qv) * inv;
    if (v < 0.0f || u + v > 1.0f)
        return false;
    float tt = dot(e2, qv) * inv;
    if (!(tt > tmin && tt < tmax))
        return false;
    *t = tt;
    return true;
}

/* ---- the scene ---- */

/* Nearest hit in (tmin, tmax); with any, the first one found (shadow rays). */
static bool scene_intersect(const scene_t *sc, float3 o, float3 d, float tmin, float tmax, bool any, hit_t *h)
{
    ++*sc->rays;
    int best = -1, best_tri = -1;
    float tb = tmax;
    for (int i = 0; i < sc->nshapes; ++i) {
        __global const int *si = sc->shape_i + i * SHAPE_I_STRIDE;
        __global const float *sf = sc->shape_f + i * SHAPE_F_STRIDE;
        float t;
        switch (si[0]) {
        case SHAPE_SPHERE:
            if (sphere_intersect((float3)(sf[0], sf[1], sf[2]), sf[3], o, d, tmin, tb, &t)) {
                tb = t;
                best = i;
            }
            break;
        case SHAPE_SDF:
            if (sdf_intersect(sc, i, o, d, tmin, tb, &t)) {
                tb = t;
                best = i;
            }
            break;
        default:
            for (int k = 0; k < si[5]; ++k)
                if (tri_intersect(sc->tri + (size_t)(si[4] + k) * TRI_STRIDE, o, d, tmin, tb, &t)) {
                    tb = t;
                    best = i;
                    best_tri = si[4] + k;
                }
            break;
        }
        if (any && best >= 0)
            return true;
    }
    if (best < 0)
        return false;
    h->t = tb;
    h->shape = best;
    h->p = o + d * tb;
    __global const int *si = sc->shape_i + best * SHAPE_I_STRIDE;
    __global const float *sf = sc->shape_f + best * SHAPE_F_STRIDE;
    float3 n;
    if (si[0] == SHAPE_SPHERE) {
        float3 c = (float3)(sf[0], sf[1], sf[2]);
        n = normalize(h->p - c);
        h->p = c + n * sf[3];
        if (si[3])
            n = -n;
    } else if (si[0] == SHAPE_SDF) {
        n = sdf_normal(sc, best, h->p);
        if (si[3])
            n = -n;
    } else {
        __global const float *tr = sc->tri + (size_t)best_tri * TRI_STRIDE;
        n = (float3)(tr[9], tr[10], tr[11]); /* flip_normals applied by the host */
    }
    h->n = n;
    return true;
}

/* Spawn offset of a point: RAY_EPS relative to the scene's scale and the point's magnitude. */
static float ray_eps(const scene_t *sc, float3 p) { return RAY_EPS * (sc->scale + max_abs3(p)); }

static float3 spawn(const scene_t *sc, const hit_t *h, float3 w)
{
    float e = ray_eps(sc, h->p);
    return h->p + h->n * (dot(w, h->n) > 0.0f ? e : -e);
}

/* Is the segment from point a (leaving along normal na, or a camera point when na is 0) to b
 * (normal nb, or 0) free of occluders? */
static bool visible(const scene_t *sc, float3 a, float3 na, float3 b, float3 nb)
{
    float3 d = b - a;
    float dist = length(d);
    if (!(dist > 0.0f))
        return false;
    d /= dist;
    float ea = ray_eps(sc, a), eb = ray_eps(sc, b);
    float3 o = a;
    if (dot(na, na) > 0.0f)
        o = a + na * (dot(d, na) > 0.0f ? ea : -ea);
    float3 e = b;
    if (dot(nb, nb) > 0.0f)
        e = b + nb * (dot(-d, nb) > 0.0f ? eb : -eb);
    float3 d2 = e - o;
    float l2 = length(d2);
    if (!(l2 > 0.0f))
        return true;
    hit_t h;
    return !scene_intersect(sc, o, d2 / l2, 0.0f, l2 * (1.0f - 1e-5f), true, &h);
}

/* ---- BSDFs (bsdf/bsdf.h conventions: directions away from the surface, eval without cosine,
 * one-sided diffuse and conductor, two-sided dielectric) ---- */

typedef struct bsdf_sample_t {
    float3 wi, weight;
    float pdf, eta;
    bool delta;
} bsdf_sample_t;

static float fresnel_dielectric(float cos_i, float eta, float *cos_t, float *eta_ti)
{
    float ci = fabs(cos_i);
    float e = cos_i >= 0.0f ? eta : 1.0f / eta;
    *eta_ti = e;
    float sin2_t = (1.0f - ci * ci) / (e * e);
    if (sin2_t >= 1.0f) {
        *cos_t = 0.0f;
        return 1.0f;
    }
    float ct = sqrt(1.0f - sin2_t);
    *cos_t = cos_i >= 0.0f ? -ct : ct;
    float rs = (ci - e * ct) / (ci + e * ct);
    float rp = (e * ci - ct) / (e * ci + ct);
    return 0.5f * (rs * rs + rp * rp);
}

static float fresnel_conductor1(float cos_i, float eta, float k)
{
    float c2 = fmin(cos_i * cos_i, 1.0f);
    float s2 = 1.0f - c2, s4 = s2 * s2;
    float t0 = eta * eta - k * k - s2;
    float a2pb2 = sqrt(fmax(0.0f, t0 * t0 + 4.0f * eta * eta * k * k));
    float a = sqrt(fmax(0.0f, 0.5f * (a2pb2 + t0)));
    float t1 = a2pb2 + c2, t2 = 2.0f * fabs(cos_i) * a;
    float rs = (t1 - t2) / (t1 + t2);
    float t3 = a2pb2 * c2 + s4, t4 = t2 * s2;
    float rp = rs * (t3 - t4) / (t3 + t4);
    return 0.5f * (rs + rp);
}

static bool bsdf_is_delta(const scene_t *sc, int b) { return sc->bsdf_i[b] != BSDF_DIFFUSE; }

static float3 bsdf_eval(const scene_t *sc, int b, float3 n, float3 wo, float3 wi)
{
    if (sc->bsdf_i[b] != BSDF_DIFFUSE || dot(wo, n) <= 0.0f || dot(wi, n) <= 0.0f)
        return (float3)(0.0f);
    __global const float *bf = sc->bsdf_f + b * BSDF_F_STRIDE;
    return (float3)(bf[0], bf[1], bf[2]) * INV_PI_F;
}

static float bsdf_pdf(const scene_t *sc, int b, float3 n, float3 wo, float3 wi)
{
    float ci = dot(wi, n);
    if (sc->bsdf_i[b] != BSDF_DIFFUSE || dot(wo, n) <= 0.0f || ci <= 0.0f)
        return 0.0f;
    return ci * INV_PI_F;
}

/* radiance: mode 0 (camera paths), importance: mode 1 (light paths) */
static bool bsdf_sample(const scene_t *sc, int b, float3 n, float3 wo, int mode, float u0, float u1, float u2,
                        bsdf_sample_t *bs)
{
    __global const float *bf = sc->bsdf_f + b * BSDF_F_STRIDE;
    float cos_o = dot(wo, n);
    bs->eta = 1.0f;
    switch (sc->bsdf_i[b]) {
    case BSDF_DIFFUSE: {
        if (cos_o <= 0.0f)
            return false;
        float3 l = cosine_hemisphere(u1, u2);
        if (l.z <= 0.0f)
            return false;
        bs->wi = to_world(n, l);
        bs->weight = (float3)(bf[0], bf[1], bf[2]);
        bs->pdf = l.z * INV_PI_F;
        bs->delta = false;
        return true;
    }
    case BSDF_CONDUCTOR: {
        if (cos_o <= 0.0f)
            return false;
        float3 F = (float3)(1.0f);
        if (bf[3] >= 0.0f)
            F = (float3)(fresnel_conductor1(cos_o, bf[0], bf[3]), fresnel_conductor1(cos_o, bf[1], bf[4]),
                         fresnel_conductor1(cos_o, bf[2], bf[5]));
        bs->wi = 2.0f * cos_o * n - wo;
        bs->weight = F * (float3)(bf[6], bf[7], bf[8]);
        bs->pdf = 1.0f;
        bs->delta = true;
        return true;
    }
    default: {
        if (cos_o == 0.0f)
            return false;
        float cos_t, eta_ti;
        float F = fresnel_dielectric(cos_o, bf[0], &cos_t, &eta_ti);
        bs->delta = true;
        if (u0 < F) {
            bs->wi = 2.0f * cos_o * n - wo;
            bs->weight = (float3)(bf[1], bf[2], bf[3]);
            bs->pdf = F;
            return true;
        }
        /* refraction: tangential part scaled by 1/eta_ti and reversed, normal part cos_t */
        bs->wi = normalize(-(wo - n * cos_o) / eta_ti + n * cos_t);
        bs->weight = (float3)(bf[4], bf[5], bf[6]);
        if (mode == 0)
            bs->weight /= eta_ti * eta_ti;
        bs->pdf = 1.0f - F;
        bs->eta = eta_ti;
        return true;
    }
    }
}

/* ---- area lights: spheres by the cone they subtend (area sampling from inside), triangle
 * meshes by area ---- */

typedef struct light_sample_t {
    float3 p, n, L;
    float pdf; /* solid angle at ref */
} light_sample_t;

static int pick_emitter(const scene_t *sc, float u, float *pmf)
{
    int k = 0;
    while (k < sc->nemitters - 1 && u >= sc->emit_f[k * EMIT_F_STRIDE + 4])
        ++k;
    *pmf = sc->emit_f[k * EMIT_F_STRIDE + 3];
    return k;
}

static float emitter_pmf(const scene_t *sc, int e) { return sc->emit_f[e * EMIT_F_STRIDE + 3]; }

static float3 emitter_radiance(const scene_t *sc, int e, float3 n, float3 w)
{
    if (dot(n, w) <= 0.0f)
        return (float3)(0.0f);
    __global const float *ef = sc->emit_f + e * EMIT_F_STRIDE;
    return (float3)(ef[0], ef[1], ef[2]);
}

/* Uniform point on an emitter's shape by area; returns the area density. */
static float emitter_sample_area(const scene_t *sc, int e, float u0, float u1, float u2, float3 *p, float3 *n)
{
    int shape = sc->emit_i[e];
    __global const int *si = sc->shape_i + shape * SHAPE_I_STRIDE;
    __global const float *sf = sc->shape_f + shape * SHAPE_F_STRIDE;
    if (si[0] == SHAPE_SPHERE) {
        float z = 1.0f - 2.0f * u0, r = sqrt(fmax(0.0f, 1.0f - z * z)), phi = 2.0f * PI_F * u1;
        float3 d = (float3)(r * cos(phi), r * sin(phi), z);
        *p = (float3)(sf[0], sf[1], sf[2]) + d * sf[3];
        *n = si[3] ? -d : d;
        return 1.0f / (4.0f * PI_F * sf[3] * sf[3]);
    }
    int k = 0;
    while (k < si[5] - 1 && u2 >= sc->tri[(size_t)(si[4] + k) * TRI_STRIDE + 12])
        ++k;
    __global const float *tr = sc->tri + (size_t)(si[4] + k) * TRI_STRIDE;
    float su = sqrt(u0);
    float b1 = 1.0f - su, b2 = u1 * su;
    *p = (float3)(tr[0], tr[1], tr[2]) + (float3)(tr[3], tr[4], tr[5]) * b1 + (float3)(tr[6], tr[7], tr[8]) * b2;
    *n = (float3)(tr[9], tr[10], tr[11]);
    return 1.0f / sf[0];
}

static bool sphere_cone(const scene_t *sc, int shape, float3 ref, float *cos_max)
{
    __global const float *sf = sc->shape_f + shape * SHAPE_F_STRIDE;
    float3 dc = (float3)(sf[0], sf[1], sf[2]) - ref;
    float d2 = dot(dc, dc), r2 = sf[3] * sf[3];
    if (d2 <= r2 * (1.0f + 1e-4f))
        return false;
    *cos_max = sqrt(fmax(0.0f, 1.0f - r2 / d2));
    return true;
}

/* Solid-angle density at ref of emitter_sample_direct choosing point p (normal n). */
static float emitter_pdf_direct(const scene_t *sc, int e, float3 ref, float3 p, float3 n)
{
    int shape = sc->emit_i[e];
    float cm;
    if (sc->shape_i[shape * SHAPE_I_STRIDE] == SHAPE_SPHERE && sphere_cone(sc, shape, ref, &cm))
        return 1.0f / (2.0f * PI_F * (1.0f - cm));
    float3 d = p - ref;
    float d2 = dot(d, d), c = fabs(dot(n, d)) / sqrt(d2);
    __global const float *sf = sc->shape_f + shape * SHAPE_F_STRIDE;
    float area = sc->shape_i[shape * SHAPE_I_STRIDE] == SHAPE_SPHERE ? 4.0f * PI_F * sf[3] * sf[3] : sf[0];
    return c > 0.0f ? d2 / (c * area) : 0.0f;
}

static bool emitter_sample_direct(const scene_t *sc, int e, float3 ref, float u0, float u1, float u2,
                                  light_sample_t *ls)
{
    int shape = sc->emit_i[e];
    __global const float *sf = sc->shape_f + shape * SHAPE_F_STRIDE;
    float cm;
    if (sc->shape_i[shape * SHAPE_I_STRIDE] == SHAPE_SPHERE && sphere_cone(sc, shape, ref, &cm)) {
        float3 c = (float3)(sf[0], sf[1], sf[2]);
        float3 dc = c - ref;
        float dist = length(dc);
        float cos_t = 1.0f - u0 * (1.0f - cm), sin_t = sqrt(fmax(0.0f, 1.0f - cos_t * cos_t));
        float phi = 2.0f * PI_F * u1;
        float3 w = to_world(dc / dist, (float3)(sin_t * cos(phi), sin_t * sin(phi), cos_t));
        /* the nearer crossing of the sphere (tangent directions: the closest point of the line) */
        float b = dot(w, dc), disc = b * b - (dot(dc, dc) - sf[3] * sf[3]);
        float t = b - sqrt(fmax(0.0f, disc));
        float3 nn = normalize(ref + w * t - c);
        ls->p = c + nn * sf[3];
        ls->n = sc->shape_i[shape * SHAPE_I_STRIDE + 3] ? -nn : nn;
        ls->pdf = 1.0f / (2.0f * PI_F * (1.0f - cm));
    } else {
        float pa = emitter_sample_area(sc, e, u0, u1, u2, &ls->p, &ls->n);
        float3 d = ls->p - ref;
        float d2 = dot(d, d), c = fabs(dot(ls->n, d)) / sqrt(d2);
        if (!(c > 0.0f))
            return false;
        ls->pdf = pa * d2 / c;
    }
    float3 wi = normalize(ls->p - ref);
    ls->L = emitter_radiance(sc, e, ls->n, -wi);
    return ls->pdf > 0.0f && maxc(ls->L) > 0.0f;
}

/* ---- camera ---- */

typedef struct camera_t {
    __global const float *f; /* to_world rows (12), tan_x, tan_y, near, far, filter radius, filter type */
    __global const float *filt; /* step[31], cdf[32] */
    int width, height, crop_x, crop_y, crop_w, crop_h;
} camera_t;

#define FILTER_RES 31

static float filter_cdf(const camera_t *c, float x)
{
    float r = c->f[16];
    if (!(x > -r))
        return 0.0f;
    if (!(x < r))
        return 1.0f;
    if (c->f[17] == 0.0f)
        return (x + r) / (2.0f * r);
    float a = fabs(x), kf = a * FILTER_RES / r;
    int k = kf < FILTER_RES - 1 ? (int)kf : FILTER_RES - 1;
    float m = c->filt[FILTER_RES + k] + (a - k * r / FILTER_RES) * c->filt[k];
    return x < 0.0f ? 0.5f - m : 0.5f + m;
}

static float filter_inverse_cdf(const camera_t *c, float u)
{
    float r = c->f[16];
    if (c->f[17] == 0.0f)
        return (2.0f * u - 1.0f) * r;
    float t = fabs(u - 0.5f), h = r / FILTER_RES;
    int lo = 0, hi = FILTER_RES;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (c->filt[FILTER_RES + mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    float a = lo * h;
    if (c->filt[lo] > 0.0f)
        a += (t - c->filt[FILTER_RES + lo]) / c->filt[lo];
    a = fmin(a, r);
    return u < 0.5f ? -a : a;
}

/* The pixel filter's offset restricted to the window [lo, hi) (render/film.c). */
static float filter_sample(const camera_t *c, float u, float ctr, float lo, float hi)
{
    float r = c->f[16];
    if (ctr - r >= lo && ctr + r <= hi)
        return filter_inverse_cdf(c, u);
    float a = filter_cdf(c, lo - ctr), b = filter_cdf(c, hi - ctr);
    return clamp(filter_inverse_cdf(c, a + u * (b - a)), lo - ctr, hi - ctr);
}

static float3 cam_vec(const camera_t *c, float3 v)
{
    __global const float *m = c->f;
    return (float3)(m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
                    m[8] * v.x + m[9] * v.y + m[10] * v.z);
}

static float3 cam_origin(const camera_t *c) { return (float3)(c->f[3], c->f[7], c->f[11]); }

static void camera_ray(const camera_t *c, float fx, float fy, float3 *o, float3 *d, float *tmin, float *tmax)
{
    float x = (1.0f - 2.0f * fx / c->width) * c->f[12];
    float y = (1.0f - 2.0f * fy / c->height) * c->f[13];
    float3 dw = cam_vec(c, (float3)(x, y, 1.0f));
    float len = length(dw);
    *o = cam_origin(c);
    *d = dw / len;
    *tmin = c->f[14] * len;
    *tmax = c->f[15] * len;
}

static void camera_sample(const camera_t *c, int x, int y, rng_t *rng, float3 *o, float3 *d, float *tmin,
                          float *tmax)
{
    int fx = x + c->crop_x, fy = y + c->crop_y;
    float ux = rnd(rng), uy = rnd(rng);
    float px = fx + 0.5f + filter_sample(c, ux, fx + 0.5f, (float)c->crop_x, (float)(c->crop_x + c->crop_w));
    float py = fy + 0.5f + filter_sample(c, uy, fy + 0.5f, (float)c->crop_y, (float)(c->crop_y + c->crop_h));
    camera_ray(c, px, py, o, d, tmin, tmax);
}

#define SCENE_ARGS                                                                                                    \
    int nshapes, int nemitters, float scene_scale, __global const int *shape_i, __global const float *shape_f,        \
        __global const int *node_i, __global const float *node_f, __global const float *tri,                          \
        __global const int *bsdf_i, __global const float *bsdf_f, __global const int *emit_i,                         \
        __global const float *emit_f, __global const float *cam_f, __global const float *filt, int width, int height, \
        int crop_x, int crop_y, int crop_w, int crop_h

#define SCENE_INIT                                                                                                    \
    scene_t sc;                                                                                                       \
    sc.nshapes = nshapes;                                                                                             \
    sc.nemitters = nemitters;                                                                                         \
    sc.scale = scene_scale;                                                                                           \
    sc.shape_i = shape_i;                                                                                             \
    sc.shape_f = shape_f;                                                                                             \
    sc.node_i = node_i;                                                                                               \
    sc.node_f = node_f;                                                                                               \
    sc.tri = tri;                                                                                                     \
    sc.bsdf_i = bsdf_i;                                                                                               \
    sc.bsdf_f = bsdf_f;                                                                                               \
    sc.emit_i = emit_i;                                                                                               \
    sc.emit_f = emit_f;                                                                                               \
    uint nrays = 0;                                                                                                   \
    sc.rays = &nrays;                                                                                                 \
    camera_t cam;                                                                                                     \
    cam.f = cam_f;                                                                                                    \
    cam.filt = filt;                                                                                                  \
    cam.width = width;                                                                                                \
    cam.height = height;                                                                                              \
    cam.crop_x = crop_x;                                                                                              \
    cam.crop_y = crop_y;                                                                                              \
    cam.crop_w = crop_w;                                                                                              \
    cam.crop_h = crop_h

/* ---- path: NEE and BSDF sampling with the power heuristic (integrator/path.c) ---- */

__kernel void render_path(SCENE_ARGS, int pass0, int base, int count, uint seed_lo, uint seed_hi, int max_depth, int rr_depth,
                          int hide_emitters, float mis_beta, __global float *out, __global uint *rays_out)
{
    (void)mis_beta; /* bdpt's; the kernels share their argument list */
    SCENE_INIT;
    if ((int)get_global_id(0) >= count)
        return;
    int gid = base + get_global_id(0);
    int npix = crop_w * crop_h;
    int b = gid / npix, pix = gid % npix;
    int x = pix % crop_w, y = pix / crop_w;
    rng_t rng = rng_start((uint)(x + crop_x), (uint)(y + crop_y), (uint)(pass0 + b), seed_lo, seed_hi);
    float3 o, d;
    float tmin, tmax;
    camera_sample(&cam, x, y, &rng, &o, &d, &tmin, &tmax);
    float3 L = (float3)(0.0f), beta = (float3)(1.0f), prev_p = o;
    bool specular = true;
    float prev_pdf = 1.0f, eta_scale = 1.0f;
    for (int segments = 1;; ++segments) {
        hit_t h;
        if (!scene_intersect(&sc, o, d, tmin, tmax, false, &h))
            break;
        __global const int *si = sc.shape_i + h.shape * SHAPE_I_STRIDE;
        float3 wo = -d;
        int em = si[2];
        if (em >= 0 && !(segments == 1 && hide_emitters)) {
            float3 Le = emitter_radiance(&sc, em, h.n, wo);
            if (maxc(Le) > 0.0f) {
                float w = 1.0f;
                if (!specular)
                    w = power_heuristic(prev_pdf, emitter_pmf(&sc, em) * emitter_pdf_direct(&sc, em, prev_p, h.p, h.n),
                                        2.0f);
                L += beta * Le * w;
            }
        }
        if (max_depth >= 0 && segments + 1 > max_depth)
            break;
        int bi = si[1];
        float u_light = rnd(&rng), ul0 = rnd(&rng), ul1 = rnd(&rng), ul2 = rnd(&rng);
        if (!bsdf_is_delta(&sc, bi) && sc.nemitters > 0) {
            float pmf;
            int e = pick_emitter(&sc, u_light, &pmf);
            light_sample_t ls;
            if (emitter_sample_direct(&sc, e, h.p, ul0, ul1, ul2, &ls)) {
                float3 wi = normalize(ls.p - h.p);
                float3 f = bsdf_eval(&sc, bi, h.n, wo, wi);
                float cosi = fabs(dot(wi, h.n));
                if (maxc(f) > 0.0f && cosi > 0.0f && visible(&sc, h.p, h.n, ls.p, ls.n)) {
                    float lp = pmf * ls.pdf;
                    float w = power_heuristic(lp, bsdf_pdf(&sc, bi, h.n, wo, wi), 2.0f);
                    L += beta * f * ls.L * (cosi * w / lp);
                }
            }
        }
        float u0 = rnd(&rng), u1 = rnd(&rng), u2 = rnd(&rng), u_rr = rnd(&rng);
        bsdf_sample_t bs;
        if (!bsdf_sample(&sc, bi, h.n, wo, 0, u0, u1, u2, &bs))
            break;
        beta *= bs.weight;
        if (!(maxc(beta) > 0.0f))
            break;
        specular = bs.delta;
        prev_pdf = bs.pdf;
        prev_p = h.p;
        eta_scale *= bs.eta * bs.eta;
        o = spawn(&sc, &h, bs.wi);
        d = bs.wi;
        tmin = 0.0f;
        tmax = INFINITY;
        if (segments >= rr_depth) {
            float q = fmin(0.95f, maxc(beta) * eta_scale);
            if (!(u_rr < q))
                break;
            beta /= q;
        }
    }
    vstore3(L, get_global_id(0), out);
    rays_out[get_global_id(0)] = nrays;
}

/* ---- bdpt (Veach 1997, ch. 10; the MIS weights as ratios of forward and reverse area densities
 * along the path, as integrator/bdpt.c; the light's (1, 1) is left to (0, 2)) ---- */

#define V_CAMERA 0
#define V_LIGHT 1
#define V_SURFACE 2

typedef struct vtx_t {
    float3 p, n, beta;
    float pdf_fwd, pdf_rev; /* area densities (camera: 1 by convention, never used) */
    int kind, bsdf, emitter;
    bool delta;
} vtx_t;

/* solid-angle density at `from` -> area density at `to` (the pinhole has no area: no cosine) */
static float to_area(float pdf, float3 from, const vtx_t *to)
{
    float3 w = to->p - from;
    float d2 = dot(w, w);
    if (!(d2 > 0.0f))
        return 0.0f;
    float c = to->kind == V_CAMERA ? 1.0f : fabs(dot(to->n, w)) / sqrt(d2);
    return pdf * c / d2;
}

static float3 cam_local(const camera_t *c, float3 p)
{
    __global const float *m = c->f + 18;
    return (float3)(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                    m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}

/* Density (solid angle) of camera ray directions toward world direction w, scaled by the film's
 * pixel count over the window's (scene/camera.c: |M v|^3 / (|det M| A)); 0 outside the film. */
static float camera_pdf_dir(const camera_t *c, float3 w)
{
    float3 l = cam_local(c, cam_origin(c) + w) - cam_local(c, cam_origin(c));
    if (!(l.z > 0.0f))
        return 0.0f;
    float x = l.x / l.z, y = l.y / l.z;
    if (fabs(x) > c->f[12] || fabs(y) > c->f[13])
        return 0.0f;
    float mv = length(cam_vec(c, (float3)(x, y, 1.0f)));
    return mv * mv * mv / (c->f[30] * 4.0f * c->f[12] * c->f[13]) * c->f[31];
}

static float emitter_area(const scene_t *sc, int e)
{
    int shape = sc->emit_i[e];
    __global const float *sf = sc->shape_f + shape * SHAPE_F_STRIDE;
    return sc->shape_i[shape * SHAPE_I_STRIDE] == SHAPE_SPHERE ? 4.0f * PI_F * sf[3] * sf[3] : sf[0];
}

/* Area density at `next` of sampling it from v (whose predecessor is prev, unused for lights and
 * the camera). */
static float vtx_pdf(const scene_t *sc, const camera_t *cam, const vtx_t *v, const vtx_t *prev, const vtx_t *next)
{
    float3 wn = next->p - v->p;
    float dn = length(wn);
    if (!(dn > 0.0f))
        return 0.0f;
    wn /= dn;
    float pdf;
    if (v->kind == V_CAMERA)
        pdf = camera_pdf_dir(cam, wn);
    else if (v->kind == V_LIGHT)
        pdf = fmax(0.0f, dot(v->n, wn)) * INV_PI_F;
    else
        pdf = bsdf_pdf(sc, v->bsdf, v->n, normalize(prev->p - v->p), wn);
    return to_area(pdf, v->p, next);
}

/* Follows a subpath from vertex path[0] along (o, d) with direction density pdf (solid angle),
 * storing up to maxv further vertices; returns how many. mode 0: radiance, 1: importance. */
static int random_walk(const scene_t *sc, rng_t *rng, float3 o, float3 d, float tmin, float tmax, float3 beta,
                       float pdf, int maxv, int mode, int rr_depth, vtx_t *path)
{
    int n = 0;
    float pdf_fwd = pdf, eta_scale = 1.0f;
    float3 thr = (float3)(1.0f); /* throughput since the walk's start, for Russian roulette */
    while (n < maxv) {
        hit_t h;
        if (!scene_intersect(sc, o, d, tmin, tmax, false, &h))
            break;
        vtx_t *prev = &path[n], *v = &path[n + 1];
        __global const int *si = sc->shape_i + h.shape * SHAPE_I_STRIDE;
        v->p = h.p;
        v->n = h.n;
        v->beta = beta;
        v->kind = V_SURFACE;
        v->bsdf = si[1];
        v->emitter = si[2];
        v->delta = false;
        v->pdf_fwd = to_area(pdf_fwd, prev->p, v);
        v->pdf_rev = 0.0f;
        ++n;
        float u0 = rnd(rng), u1 = rnd(rng), u2 = rnd(rng), u_rr = rnd(rng);
        if (n >= maxv)
            break;
        float3 wo = -d;
        bsdf_sample_t bs;
        if (!bsdf_sample(sc, v->bsdf, v->n, wo, mode, u0, u1, u2, &bs))
            break;
        beta *= bs.weight;
        thr *= bs.weight;
        if (!(maxc(beta) > 0.0f))
            break;
        if (mode == 0)
            eta_scale *= bs.eta * bs.eta;
        /* Russian roulette as integrator/bdpt.c (the MIS weights ignore it: they still sum to 1) */
        if (n >= rr_depth) {
            float q = fmin(0.95f, maxc(thr) * eta_scale);
            if (!(u_rr < q))
                break;
            beta /= q;
            thr /= q;
        }
        float pdf_rev;
        if (bs.delta) {
            /* a delta lobe counts as its choice probability per unit solid angle, converted to
             * area like any lobe (as integrator/bdpt.c: exact ratios for planar mirrors, close for
             * curved glass; pbrt's density of 1 over-weights s = 0 on caustics). The reverse
             * choice has the same probability (Fresnel is symmetric). */
            v->delta = true;
            pdf_fwd = pdf_rev = bs.pdf;
        } else {
            pdf_fwd = bs.pdf;
            pdf_rev = bsdf_pdf(sc, v->bsdf, v->n, bs.wi, wo);
        }
        prev->pdf_rev = to_area(pdf_rev, v->p, prev);
        o = spawn(sc, &h, bs.wi);
        d = bs.wi;
        tmin = 0.0f;
        tmax = INFINITY;
    }
    return n;
}

static float remap0(float x) { return x != 0.0f ? x : 1.0f; }

/* The weight of strategy (s, t) for the path of light vertices ls[0..s-1] and camera vertices
 * cs[0..t-1] (the connection vertices already in place), power heuristic of exponent beta. */
static float mis_weight(const scene_t *sc, const camera_t *cam, vtx_t *ls, int s, vtx_t *cs, int t, float beta)
{
    if (s + t == 2)
        return 1.0f;
    vtx_t *qs = s > 0 ? &ls[s - 1] : 0, *pt = &cs[t - 1];
    vtx_t *qs_m = s > 1 ? &ls[s - 2] : 0, *pt_m = t > 1 ? &cs[t - 2] : 0;
    /* save what is changed */
    float pt_rev = pt->pdf_rev, ptm_rev = pt_m ? pt_m->pdf_rev : 0.0f;
    float qs_rev = qs ? qs->pdf_rev : 0.0f, qsm_rev = qs_m ? qs_m->pdf_rev : 0.0f;
    bool pt_delta = pt->delta, qs_delta = qs ? qs->delta : false;
    pt->delta = false;
    if (qs)
        qs->delta = false;
    if (s > 0)
        pt->pdf_rev = vtx_pdf(sc, cam, qs, qs_m, pt);
    else /* pt on a light: the density of emission sampling choosing it */
        pt->pdf_rev = emitter_pmf(sc, pt->emitter) / emitter_area(sc, pt->emitter);
    if (pt_m) {
        if (s > 0) {
            pt_m->pdf_rev = vtx_pdf(sc, cam, pt, qs, pt_m);
        } else {
            vtx_t lv = *pt;
            lv.kind = V_LIGHT;
            pt_m->pdf_rev = vtx_pdf(sc, cam, &lv, 0, pt_m);
        }
    }
    if (qs)
        qs->pdf_rev = vtx_pdf(sc, cam, pt, pt_m, qs);
    if (qs_m)
        qs_m->pdf_rev = vtx_pdf(sc, cam, qs, pt, qs_m);

    float sum = 0.0f, ri = 1.0f;
    for (int i = t - 1; i > 0; --i) {
        ri *= remap0(cs[i].pdf_rev) / remap0(cs[i].pdf_fwd);
        if (!cs[i].delta && !cs[i - 1].delta)
            sum += beta == 1.0f ? ri : ri * ri;
    }
    ri = 1.0f;
    for (int i = s - 1; i >= 0; --i) {
        ri *= remap0(ls[i].pdf_rev) / remap0(ls[i].pdf_fwd);
        bool prev_delta = i > 0 ? ls[i - 1].delta : false; /* area lights: no delta origin */
        if (!ls[i].delta && !prev_delta)
            sum += beta == 1.0f ? ri : ri * ri;
    }
    pt->pdf_rev = pt_rev;
    if (pt_m)
        pt_m->pdf_rev = ptm_rev;
    if (qs)
        qs->pdf_rev = qs_rev;
    if (qs_m)
        qs_m->pdf_rev = qsm_rev;
    pt->delta = pt_delta;
    if (qs)
        qs->delta = qs_delta;
    return 1.0f / (1.0f + sum);
}

static float filter_eval1(const camera_t *c, float x)
{
    float r = c->f[16];
    if (!(fabs(x) < r))
        return 0.0f;
    if (c->f[17] == 0.0f)
        return 1.0f / (2.0f * r);
    float kf = fabs(x) * FILTER_RES / r;
    int k = kf < FILTER_RES - 1 ? (int)kf : FILTER_RES - 1;
    return c->filt[k];
}

static float filter_mass(const camera_t *c, float ctr, float lo, float hi)
{
    float r = c->f[16];
    if (ctr - r >= lo && ctr + r <= hi)
        return 1.0f;
    return filter_cdf(c, hi - ctr) - filter_cdf(c, lo - ctr);
}

/* One pixel of the window along an axis for a splat at film coordinate f: chosen with probability
 * proportional to its filter weight (renormalized over the window, as scene/rfilter.h), which
 * returns the sum of the weights: the splat times it is unbiased for every pixel's share. -1 if
 * no window pixel is in reach. */
static int splat_axis(const camera_t *c, float f, int lo, int size, float u, float *wsum)
{
    float r = c->f[16];
    int x0 = (int)floor(f - r - 0.5f) + 1, x1 = (int)floor(f + r - 0.5f);
    if (c->f[17] == 0.0f && r <= 0.5f)
        x0 = x1 = (int)floor(f);
    if (x0 < lo)
        x0 = lo;
    if (x1 > lo + size - 1)
        x1 = lo + size - 1;
    float w[16], sum = 0.0f;
    int n = 0;
    for (int x = x0; x <= x1 && n < 16; ++x, ++n) {
        float wx = (c->f[17] == 0.0f && r <= 0.5f) ? 1.0f : filter_eval1(c, x + 0.5f - f);
        if (wx > 0.0f && r > 0.5f)
            wx /= filter_mass(c, x + 0.5f, (float)lo, (float)(lo + size));
        w[n] = wx;
        sum += wx;
    }
    *wsum = sum;
    if (!(sum > 0.0f))
        return -1;
    float acc = 0.0f, target = u * sum;
    for (int k = 0; k < n; ++k) {
        acc += w[k];
        if (target < acc && w[k] > 0.0f)
            return x0 + k - lo;
    }
    for (int k = n - 1; k >= 0; --k)
        if (w[k] > 0.0f)
            return x0 + k - lo;
    return -1;
}

__kernel void render_bdpt(SCENE_ARGS, int pass0, int base, int count, uint seed_lo, uint seed_hi, int max_depth, int rr_depth,
                          int hide_emitters, float mis_beta, __global float *out, __global uint *rays_out,
                          __global float *splats)
{
    SCENE_INIT;
    if ((int)get_global_id(0) >= count)
        return;
    int gid = base + get_global_id(0);
    int npix = crop_w * crop_h;
    int b = gid / npix, pix = gid % npix;
    int x = pix % crop_w, y = pix / crop_w;
    rng_t rng = rng_start((uint)(x + crop_x), (uint)(y + crop_y), (uint)(pass0 + b), seed_lo, seed_hi);
    __global float *sp = splats + (size_t)get_global_id(0) * MAX_SPLATS * 4;
    int nsplat = 0;
    float3 L = (float3)(0.0f);

    /* camera subpath */
    vtx_t cs[BDPT_MAX_VERTS], ls[BDPT_MAX_VERTS];
    float3 o, d;
    float tmin, tmax;
    camera_sample(&cam, x, y, &rng, &o, &d, &tmin, &tmax);
    cs[0].p = o;
    cs[0].n = normalize(cam_vec(&cam, (float3)(0.0f, 0.0f, 1.0f)));
    cs[0].beta = (float3)(1.0f);
    cs[0].kind = V_CAMERA;
    cs[0].delta = false;
    cs[0].pdf_fwd = 1.0f;
    cs[0].pdf_rev = 0.0f;
    cs[0].bsdf = cs[0].emitter = -1;
    /* max_depth < 0: unbounded but for the vertex arrays (paths of more than BDPT_MAX_VERTS - 1
     * segments are cut; Russian roulette makes them rare) */
    int depth = max_depth < 0 || max_depth > BDPT_MAX_VERTS - 1 ? BDPT_MAX_VERTS - 1 : max_depth;
    int nc = 1 + random_walk(&sc, &rng, o, d, tmin, tmax, (float3)(1.0f), camera_pdf_dir(&cam, d), depth, 0, rr_depth,
                             cs);

    /* light subpath: a light by power, a point by area, a cosine-weighted direction */
    int nl = 0;
    if (nemitters > 0) {
        float pmf;
        int e = pick_emitter(&sc, rnd(&rng), &pmf);
        float u0 = rnd(&rng), u1 = rnd(&rng), u2 = rnd(&rng), u3 = rnd(&rng), u4 = rnd(&rng);
        float3 p, n;
        float pdf_pos = emitter_sample_area(&sc, e, u0, u1, u2, &p, &n);
        float3 l = cosine_hemisphere(u3, u4);
        float3 w = to_world(n, l);
        float3 Le = emitter_radiance(&sc, e, n, w);
        ls[0].p = p;
        ls[0].n = n;
        ls[0].beta = (float3)(1.0f / (pmf * pdf_pos));
        ls[0].kind = V_LIGHT;
        ls[0].delta = false;
        ls[0].pdf_fwd = pmf * pdf_pos;
        ls[0].pdf_rev = 0.0f;
        ls[0].bsdf = -1;
        ls[0].emitter = e;
        nl = 1;
        float pdf_dir = l.z * INV_PI_F;
        if (depth > 1 && pdf_dir > 0.0f && maxc(Le) > 0.0f) {
            float eps = ray_eps(&sc, p);
            nl += random_walk(&sc, &rng, p + n * eps, w, 0.0f, INFINITY, Le * (l.z / (pmf * pdf_pos * pdf_dir)),
                              pdf_dir, depth - 1, 1, rr_depth, ls);
        }
    }

    for (int t = 1; t <= nc; ++t)
        for (int s = 0; s <= nl; ++s) {
            /* (1, 1), the light seen by light tracing, is left to (0, 2), which has weight 1 */
            if (s + t < 2 || s + t - 1 > depth || (s == 1 && t == 1))
                continue;
#ifdef ONLY_S
            if (s != ONLY_S || t != ONLY_T)
                continue;
#ifndef WEIGHTED
#define mis_weight(a, b, c, d, e, f, g) 1.0f
#endif
#endif
            float u_a = rnd(&rng), u_b = rnd(&rng), u_c = rnd(&rng);
            vtx_t *pt = &cs[t - 1];
            float3 c = (float3)(0.0f);
            if (s == 0) {
                /* the camera subpath found a light */
                if (pt->kind != V_SURFACE || pt->emitter < 0 || (t == 2 && hide_emitters))
                    continue;
                c = pt->beta * emitter_radiance(&sc, pt->emitter, pt->n, normalize(cs[t - 2].p - pt->p));
                if (!(maxc(c) > 0.0f))
                    continue;
                L += c * mis_weight(&sc, &cam, ls, 0, cs, t, mis_beta);
                continue;
            }
            vtx_t *qs = &ls[s - 1];
            if (qs->delta || (qs->kind == V_SURFACE && bsdf_is_delta(&sc, qs->bsdf)))
                continue;
            if (t == 1) {
                /* light tracing: qs seen by the pinhole, splatted */
                float3 lp = cam_local(&cam, qs->p);
                if (!(lp.z > 0.0f) || lp.z < cam.f[14] || lp.z > cam.f[15])
                    continue;
                float X = lp.x / lp.z, Y = lp.y / lp.z;
                float fx = (1.0f - X / cam.f[12]) * 0.5f * cam.width, fy = (1.0f - Y / cam.f[13]) * 0.5f * cam.height;
                if (!(fx >= 0.0f && fx < cam.width && fy >= 0.0f && fy < cam.height))
                    continue;
                float wx, wy;
                int px = splat_axis(&cam, fx, cam.crop_x, cam.crop_w, u_a, &wx);
                int py = splat_axis(&cam, fy, cam.crop_y, cam.crop_h, u_b, &wy);
                if (px < 0 || py < 0)
                    continue;
                float3 co = cam_origin(&cam);
                float3 wc = co - qs->p;
                float d2 = dot(wc, wc);
                wc /= sqrt(d2);
                float3 f = s == 1 ? emitter_radiance(&sc, qs->emitter, qs->n, wc)
                                  : bsdf_eval(&sc, qs->bsdf, qs->n, normalize(ls[s - 2].p - qs->p), wc);
                float We = camera_pdf_dir(&cam, -wc);
                c = qs->beta * f * (fabs(dot(qs->n, wc)) * We / d2) * (wx * wy);
                if (!(maxc(c) > 0.0f))
                    continue;
                float3 near_pt = co + (qs->p - co) * (cam.f[14] / lp.z);
                if (!visible(&sc, qs->p, qs->n, near_pt, (float3)(0.0f)))
                    continue;
                vtx_t cam0 = cs[0];
                cs[0].pdf_rev = 0.0f;
                c *= mis_weight(&sc, &cam, ls, s, cs, 1, mis_beta);
                cs[0] = cam0;
                if (nsplat < MAX_SPLATS) {
                    sp[4 * nsplat] = (float)(px + py * crop_w);
                    sp[4 * nsplat + 1] = c.x;
                    sp[4 * nsplat + 2] = c.y;
                    sp[4 * nsplat + 3] = c.z;
                    ++nsplat;
                }
                continue;
            }
            if (pt->kind != V_SURFACE || bsdf_is_delta(&sc, pt->bsdf))
                continue;
            if (s == 1) {
                /* a fresh light sample toward pt (as path's NEE); MIS sees the emission density */
                float pmf;
                int e = pick_emitter(&sc, u_a, &pmf);
                light_sample_t lsm;
                if (!emitter_sample_direct(&sc, e, pt->p, u_b, u_c, rnd(&rng), &lsm))
                    continue;
                float3 wi = normalize(lsm.p - pt->p);
                float3 f = bsdf_eval(&sc, pt->bsdf, pt->n, normalize(cs[t - 2].p - pt->p), wi);
                c = pt->beta * f * lsm.L * (fabs(dot(wi, pt->n)) / (pmf * lsm.pdf));
                if (!(maxc(c) > 0.0f) || !visible(&sc, pt->p, pt->n, lsm.p, lsm.n))
                    continue;
                vtx_t l0 = ls[0];
                ls[0].p = lsm.p;
                ls[0].n = lsm.n;
                ls[0].kind = V_LIGHT;
                ls[0].emitter = e;
                ls[0].delta = false;
                ls[0].pdf_fwd = emitter_pmf(&sc, e) / emitter_area(&sc, e);
                ls[0].pdf_rev = 0.0f;
                c *= mis_weight(&sc, &cam, ls, 1, cs, t, mis_beta);
                ls[0] = l0;
                L += c;
                continue;
            }
            /* two subpath vertices joined */
            float3 wd = pt->p - qs->p;
            float d2 = dot(wd, wd);
            wd /= sqrt(d2);
            float3 fl = bsdf_eval(&sc, qs->bsdf, qs->n, normalize(ls[s - 2].p - qs->p), wd);
            float3 fc = bsdf_eval(&sc, pt->bsdf, pt->n, normalize(cs[t - 2].p - pt->p), -wd);
            float G = fabs(dot(qs->n, wd)) * fabs(dot(pt->n, wd)) / d2;
            c = qs->beta * fl * fc * pt->beta * G;
            if (!(maxc(c) > 0.0f) || !visible(&sc, qs->p, qs->n, pt->p, pt->n))
                continue;
            L += c * mis_weight(&sc, &cam, ls, s, cs, t, mis_beta);
        }
    if (nsplat < MAX_SPLATS)
        sp[4 * nsplat] = -1.0f;
    vstore3(L, get_global_id(0), out);
    rays_out[get_global_id(0)] = nrays;
}
