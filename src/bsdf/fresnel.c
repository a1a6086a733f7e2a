/*
 * bsdf/fresnel.c: Fresnel reflectance of dielectric and conducting interfaces, refraction, and
 * the hemispherical average of the dielectric reflectance used by the plastic models.
 *
 * - Dielectric: the unpolarized average (r_s^2 + r_p^2)/2 of the Fresnel amplitude coefficients
 *   (Born and Wolf, sec. 1.5.2; pbrt-v4 eq. 9.5) with Snell's law for cos_t.
 * - Conductor: the exact unpolarized reflectance for a complex IOR eta + i k, written with real
 *   arithmetic as in Born and Wolf sec. 14.2 (a^2 + b^2 = sqrt((eta^2 - k^2 - sin^2)^2 +
 *   4 eta^2 k^2), the s-polarized term, then R_p = R_s (a^2+b^2 cos^2 + sin^4 - 2 a cos sin^2) /
 *   (... + 2 a cos sin^2)).
 * - Diffuse Fresnel reflectance: the exact closed form of the cosine-weighted hemispherical
 *   average of the dielectric reflectance for a relative IOR n > 1 (Stern 1964; quoted by d'Eon
 *   and Irving 2011, eq. 32), and the reciprocity relation 1 - r(1/n) = (1 - r(n)) / n^2 for
 *   n < 1. Mitsuba uses polynomial fits of the same integral (within about 1e-3).
 */
#include "bsdf/variants.h"

double spc_fresnel_dielectric(double cos_i, double eta, double *cos_t, double *eta_ti)
{
    double ci = fabs(cos_i);
    double e = cos_i >= 0.0 ? eta : 1.0 / eta; /* n_t / n_i */
    if (eta_ti)
        *eta_ti = e;
    double sin2_t = (1.0 - ci * ci) / (e * e);
    if (sin2_t >= 1.0) {
        if (cos_t)
            *cos_t = 0.0;
        return 1.0;
    }
    double ct = sqrt(1.0 - sin2_t);
    if (cos_t)
        *cos_t = cos_i >= 0.0 ? -ct : ct;
    double rs = (ci - e * ct) / (ci + e * ct);
    double rp = (e * ci - ct) / (e * ci + ct);
    return 0.5 * (rs * rs + rp * rp);
}

/* The three channels as one loop, which -O3 vectorizes: each square root and division as a packed
 * pair and a scalar instead of three scalars (a fourth, dummy channel would be built through two
 * 8-byte stores and a 16-byte load, a stall). Each lane's arithmetic is the one-channel formula's,
 * in its order, so the values are those of the plain form (packed square roots and divisions round
 * as scalar ones do). */
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("O3")))
#endif
spc_rgb spc_fresnel_conductor(double cos_i, spc_rgb eta, spc_rgb k)
{
    const double ev[3] = {eta.r, eta.g, eta.b}, kv[3] = {k.r, k.g, k.b};
    double r[3];
    double c2 = spc_min(cos_i * cos_i, 1.0);
    double s2 = 1.0 - c2, s4 = s2 * s2, ac = fabs(cos_i);
    for (int i = 0; i < 3; ++i) {
        double e = ev[i], kk = kv[i];
        double t0 = e * e - kk * kk - s2;
        double a2pb2 = spc_safe_sqrt(t0 * t0 + 4.0 * e * e * kk * kk);
        double a = spc_safe_sqrt(0.5 * (a2pb2 + t0));
        double t1 = a2pb2 + c2, t2 = 2.0 * ac * a;
        double rs = (t1 - t2) / (t1 + t2);
        double t3 = a2pb2 * c2 + s4, t4 = t2 * s2;
        double rp = rs * (t3 - t4) / (t3 + t4);
        r[i] = 0.5 * (rs + rp);
    }
    return spc_rgb3(r[0], r[1], r[2]);
}

spc_vec3 spc_refract(spc_vec3 w, spc_vec3 n, double cos_t, double eta_ti)
{
    /* tangential part scaled by n_i/n_t and reversed, normal part of length |cos_t| on the far side */
    double inv = 1.0 / eta_ti;
    return spc_sub(spc_scale(n, spc_dot(w, n) * inv + cos_t), spc_scale(w, inv));
}

/* Closed form for n > 1 (external incidence, no total internal reflection). Within 1e-4 of n = 1
 * its terms cancel (each is O(1/(n-1)) while the sum is O(n-1)); there the leading term
 * (n - 1)/3 is used instead, accurate to 3e-8. */
static double diffuse_reflectance_external(double n)
{
    if (n - 1.0 < 1e-4)
        return (n - 1.0) / 3.0;
    double n2 = n * n, n4 = n2 * n2;
    double n2p1 = n2 + 1.0, n4m1 = n4 - 1.0;
    return 0.5 + (n - 1.0) * (3.0 * n + 1.0) / (6.0 * (n + 1.0) * (n + 1.0)) +
           n2 * (n2 - 1.0) * (n2 - 1.0) / (n2p1 * n2p1 * n2p1) * log((n - 1.0) / (n + 1.0)) -
           2.0 * n2 * n * (n2 + 2.0 * n - 1.0) / (n2p1 * n4m1) +
           8.0 * n4 * (n4 + 1.0) / (n2p1 * n4m1 * n4m1) * log(n);
}

double spc_fresnel_diffuse_reflectance(double eta)
{
    if (!(eta > 0.0) || eta == 1.0)
        return 0.0;
    if (eta > 1.0)
        return diffuse_reflectance_external(eta);
    return 1.0 - (1.0 - diffuse_reflectance_external(1.0 / eta)) * eta * eta;
}
