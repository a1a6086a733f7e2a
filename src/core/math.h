/*
 * core/math.h: vectors, RGB, frames and 4x4 transforms in double precision.
 *
 * Conventions (every module relies on these):
 * - All shading and geometry math is in double precision. Only the Embree interface (src/accel)
 *   and mesh vertex storage use float.
 * - Directions are unit vectors unless a name says otherwise (d_unnorm, ...).
 * - A spc_frame is orthonormal and right-handed: s x t = n. Local coordinates (x, y, z) map to
 *   x*s + y*t + z*n; the local "cos theta" of a direction is its z.
 * - spc_mat4 is row-major and acts on column vectors: p' = M p (Mitsuba's XML order).
 */
#ifndef SPC_CORE_MATH_H
#define SPC_CORE_MATH_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#define SPC_PI 3.14159265358979323846
#define SPC_INV_PI 0.31830988618379067154
#define SPC_INV_2PI 0.15915494309189533577
#define SPC_INV_4PI 0.07957747154594766788
#define SPC_INF INFINITY

typedef struct spc_vec2 {
    double x, y;
} spc_vec2;

typedef struct spc_vec3 {
    double x, y, z;
} spc_vec3;

typedef struct spc_rgb {
    double r, g, b;
} spc_rgb;

typedef struct spc_frame {
    spc_vec3 s, t, n;
} spc_frame;

typedef struct spc_mat4 {
    double m[4][4];
} spc_mat4;

typedef struct spc_ray {
    spc_vec3 o, d; /* origin, unit direction */
    double tmin, tmax;
} spc_ray;

/* ---- scalars ---- */
static inline double spc_clamp(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }
static inline double spc_sqr(double x) { return x * x; }
static inline double spc_safe_sqrt(double x) { return x > 0.0 ? sqrt(x) : 0.0; }
static inline double spc_lerp(double t, double a, double b) { return a + t * (b - a); }
static inline double spc_min(double a, double b) { return a < b ? a : b; }
static inline double spc_max(double a, double b) { return a > b ? a : b; }

/* sin and cos of x for |x| <= pi/4, by their Taylor polynomials to x^17 and x^16 (the next terms
 * are below 1e-19 there): within an ulp or two of libm's sincos, without its call, range reduction
 * and branches. The warps' angles live in this range after an exact quarter-turn reduction. */
static inline void spc_sincos_quarter(double x, double *s, double *c)
{
    double x2 = x * x;
    double ps = -1.0 / 355687428096000.0;
    ps = 1.0 / 1307674368000.0 + x2 * ps;
    ps = -1.0 / 6227020800.0 + x2 * ps;
    ps = 1.0 / 39916800.0 + x2 * ps;
    ps = -1.0 / 362880.0 + x2 * ps;
    ps = 1.0 / 5040.0 + x2 * ps;
    ps = -1.0 / 120.0 + x2 * ps;
    ps = 1.0 / 6.0 + x2 * ps;
    double pc = 1.0 / 20922789888000.0;
    pc = -1.0 / 87178291200.0 + x2 * pc;
    pc = 1.0 / 479001600.0 + x2 * pc;
    pc = -1.0 / 3628800.0 + x2 * pc;
    pc = 1.0 / 40320.0 + x2 * pc;
    pc = -1.0 / 720.0 + x2 * pc;
    pc = 1.0 / 24.0 + x2 * pc;
    pc = -0.5 + x2 * pc;
    *s = x - x * x2 * ps;
    *c = 1.0 + x2 * pc;
}
/* sin and cos of 2 pi u for finite |u| < 2^40 (a warp's phi = 2 pi u): u minus the nearest multiple
 * of 1/4 is exact, so the only rounding before the polynomials is that of 2 pi r, |r| <= 1/8
 * (libm rounds 2 pi u itself, a larger absolute error for u near 1). */
static inline void spc_sincos_2pi(double u, double *s, double *c)
{
    double k = 4.0 * u + 0.5;
    int64_t q = (int64_t)k;
    q -= (double)q > k; /* floor */
    double sr, cr;
    spc_sincos_quarter(2.0 * SPC_PI * (u - 0.25 * (double)q), &sr, &cr);
    switch (q & 3) {
    case 0: *s = sr; *c = cr; break;
    case 1: *s = cr; *c = -sr; break;
    case 2: *s = -sr; *c = -cr; break;
    default: *s = -cr; *c = sr; break;
    }
}

/* ---- vec2 ---- */
static inline spc_vec2 spc_v2(double x, double y) { return (spc_vec2){x, y}; }

/* ---- vec3 ---- */
static inline spc_vec3 spc_v3(double x, double y, double z) { return (spc_vec3){x, y, z}; }
static inline spc_vec3 spc_add(spc_vec3 a, spc_vec3 b) { return spc_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline spc_vec3 spc_sub(spc_vec3 a, spc_vec3 b) { return spc_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline spc_vec3 spc_mul(spc_vec3 a, spc_vec3 b) { return spc_v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline spc_vec3 spc_scale(spc_vec3 a, double s) { return spc_v3(a.x * s, a.y * s, a.z * s); }
static inline spc_vec3 spc_neg(spc_vec3 a) { return spc_v3(-a.x, -a.y, -a.z); }
static inline spc_vec3 spc_madd(spc_vec3 a, spc_vec3 b, double s) /* a + b*s */
{
    return spc_v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s);
}
static inline double spc_dot(spc_vec3 a, spc_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline double spc_absdot(spc_vec3 a, spc_vec3 b) { return fabs(spc_dot(a, b)); }
static inline spc_vec3 spc_cross(spc_vec3 a, spc_vec3 b)
{
    return spc_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double spc_length2(spc_vec3 a) { return spc_dot(a, a); }
static inline double spc_length(spc_vec3 a) { return sqrt(spc_dot(a, a)); }
static inline spc_vec3 spc_normalize(spc_vec3 a)
{
    double l = spc_length(a);
    return l > 0.0 ? spc_scale(a, 1.0 / l) : a;
}
static inline double spc_distance(spc_vec3 a, spc_vec3 b) { return spc_length(spc_sub(a, b)); }
static inline double spc_max_abs(spc_vec3 a) { return spc_max(fabs(a.x), spc_max(fabs(a.y), fabs(a.z))); }
static inline double spc_v3_get(spc_vec3 a, int i) { return i == 0 ? a.x : (i == 1 ? a.y : a.z); }
static inline bool spc_v3_finite(spc_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
static inline spc_vec3 spc_vmin(spc_vec3 a, spc_vec3 b)
{
    return spc_v3(spc_min(a.x, b.x), spc_min(a.y, b.y), spc_min(a.z, b.z));
}
static inline spc_vec3 spc_vmax(spc_vec3 a, spc_vec3 b)
{
    return spc_v3(spc_max(a.x, b.x), spc_max(a.y, b.y), spc_max(a.z, b.z));
}
/* Mirror reflection of w (pointing away from the surface) about n. */
static inline spc_vec3 spc_reflect(spc_vec3 w, spc_vec3 n) { return spc_sub(spc_scale(n, 2.0 * spc_dot(w, n)), w); }

/* ---- rgb ---- */
static inline spc_rgb spc_rgb1(double v) { return (spc_rgb){v, v, v}; }
static inline spc_rgb spc_rgb3(double r, double g, double b) { return (spc_rgb){r, g, b}; }
static inline spc_rgb spc_rgb_add(spc_rgb a, spc_rgb b) { return spc_rgb3(a.r + b.r, a.g + b.g, a.b + b.b); }
static inline spc_rgb spc_rgb_sub(spc_rgb a, spc_rgb b) { return spc_rgb3(a.r - b.r, a.g - b.g, a.b - b.b); }
static inline spc_rgb spc_rgb_mul(spc_rgb a, spc_rgb b) { return spc_rgb3(a.r * b.r, a.g * b.g, a.b * b.b); }
static inline spc_rgb spc_rgb_scale(spc_rgb a, double s) { return spc_rgb3(a.r * s, a.g * s, a.b * s); }
static inline spc_rgb spc_rgb_div(spc_rgb a, spc_rgb b)
{
    return spc_rgb3(b.r != 0 ? a.r / b.r : 0, b.g != 0 ? a.g / b.g : 0, b.b != 0 ? a.b / b.b : 0);
}
static inline double spc_rgb_max(spc_rgb a) { return spc_max(a.r, spc_max(a.g, a.b)); }
static inline double spc_rgb_avg(spc_rgb a) { return (a.r + a.g + a.b) / 3.0; }
static inline double spc_rgb_lum(spc_rgb a) { return 0.212671 * a.r + 0.715160 * a.g + 0.072169 * a.b; }
static inline bool spc_rgb_is_black(spc_rgb a) { return a.r == 0.0 && a.g == 0.0 && a.b == 0.0; }
static inline bool spc_rgb_finite(spc_rgb a) { return isfinite(a.r) && isfinite(a.g) && isfinite(a.b); }

/* ---- frames ---- */
/* Orthonormal basis around unit n (Duff et al. 2017, branchless). */
static inline spc_frame spc_frame_from_n(spc_vec3 n)
{
    double sign = copysign(1.0, n.z);
    double a = -1.0 / (sign + n.z);
    double b = n.x * n.y * a;
    spc_frame f;
    f.s = spc_v3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    f.t = spc_v3(b, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}
/* The unit tangent *s of spc_frame_from_ns(n, dpdu): dpdu with its n component removed,
 * normalized; false (s untouched) where dpdu is (nearly) parallel to n. The same for -n. */
static inline bool spc_frame_tangent(spc_vec3 n, spc_vec3 dpdu, spc_vec3 *s)
{
    spc_vec3 d = spc_sub(dpdu, spc_scale(n, spc_dot(n, dpdu)));
    double l = spc_length(d);
    if (!(l > 1e-12 * (spc_length(dpdu) + 1e-300)))
        return false;
    *s = spc_scale(d, 1.0 / l);
    return true;
}
/* Frame with n and the tangent s as close to dpdu as possible (Gram-Schmidt). */
static inline spc_frame spc_frame_from_ns(spc_vec3 n, spc_vec3 dpdu)
{
    spc_frame f;
    if (!spc_frame_tangent(n, dpdu, &f.s))
        return spc_frame_from_n(n);
    f.n = n;
    f.t = spc_cross(n, f.s);
    return f;
}
static inline spc_vec3 spc_frame_to_local(const spc_frame *f, spc_vec3 v)
{
    return spc_v3(spc_dot(v, f->s), spc_dot(v, f->t), spc_dot(v, f->n));
}
static inline spc_vec3 spc_frame_to_world(const spc_frame *f, spc_vec3 v)
{
    return spc_add(spc_add(spc_scale(f->s, v.x), spc_scale(f->t, v.y)), spc_scale(f->n, v.z));
}

/* ---- 4x4 transforms (src/core/math.c) ---- */
spc_mat4 spc_mat4_identity(void);
spc_mat4 spc_mat4_mul(const spc_mat4 *a, const spc_mat4 *b); /* a * b */
bool spc_mat4_inverse(const spc_mat4 *a, spc_mat4 *out);     /* false if singular */
spc_mat4 spc_mat4_transpose(const spc_mat4 *a);
spc_mat4 spc_mat4_translate(spc_vec3 t);
spc_mat4 spc_mat4_scale(spc_vec3 s);
spc_mat4 spc_mat4_rotate(spc_vec3 axis, double degrees);
/* Rodrigues' matrix for `degrees` about a, as written (not normalized): for a unit a the rotation
 * of spc_mat4_rotate; a longer or shorter a also scales (Mitsuba 3's <rotate>, io/mitsuba_props.c). */
spc_mat4 spc_mat4_rodrigues(spc_vec3 a, double degrees);
/* Mitsuba's lookat: the camera looks along +z toward target, up is +y; +x = up x dir. */
bool spc_mat4_lookat(spc_vec3 origin, spc_vec3 target, spc_vec3 up, spc_mat4 *out);
spc_vec3 spc_mat4_apply_point(const spc_mat4 *m, spc_vec3 p);
spc_vec3 spc_mat4_apply_vector(const spc_mat4 *m, spc_vec3 v);
/* Normals transform with the inverse transpose: pass the inverse of the point transform. */
spc_vec3 spc_mat4_apply_normal(const spc_mat4 *inverse, spc_vec3 n);
double spc_mat4_det3(const spc_mat4 *m); /* determinant of the upper-left 3x3 block */

#endif
