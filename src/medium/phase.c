/*
 * medium/phase.c: phase functions (contract and direction conventions in medium.h).
 *
 * - isotropic: p = 1 / (4 pi), sampled uniformly on the sphere.
 * - hg: Henyey and Greenstein (1941),
 *       p(mu) = (1 - g^2) / (4 pi (1 + g^2 - 2 g mu)^(3/2)),   mu = cos theta = dot(-wo, wi),
 *   sampled by inverting its CDF in mu (pbrt-v4, sec. 11.3.1, with mu measured from the travel
 *   direction):
 *       mu = (1 + g^2 - ((1 - g^2) / (1 - g + 2 g u))^2) / (2 g),
 *   and phi uniform. For |g| below SPC_HG_ISOTROPIC_G the inversion loses precision (it divides
 *   by g) and the distribution is isotropic to that accuracy, so mu = 1 - 2u is used.
 *
 * Mitsuba XML <phase type="isotropic"/> (no parameters); <phase type="hg">: g (float, 0.8).
 */
#include "medium/medium.h"

/* Below this |g|, HG is sampled as isotropic: the relative change of p is about 3|g| < 3e-4, and
 * the CDF inversion's cancellation error would exceed it. eval and pdf stay the exact HG value, so
 * the sampling's density differs from pdf by that 3e-4 at most (far below any test's power). */
#define SPC_HG_ISOTROPIC_G 1e-4

static double hg(double mu, double g)
{
    double denom = 1.0 + g * g - 2.0 * g * mu;
    if (!(denom > 0.0))
        return 0.0;
    return (1.0 - g * g) / (4.0 * SPC_PI * denom * sqrt(denom));
}

double spc_phase_eval(const spc_phase *p, spc_vec3 wo, spc_vec3 wi)
{
    switch (p->type) {
    case SPC_PHASE_ISOTROPIC: return 1.0 / (4.0 * SPC_PI);
    case SPC_PHASE_HG: return hg(spc_clamp(-spc_dot(wo, wi), -1.0, 1.0), p->g);
    }
    return 0.0;
}

double spc_phase_pdf(const spc_phase *p, spc_vec3 wo, spc_vec3 wi) { return spc_phase_eval(p, wo, wi); }

bool spc_phase_sample(const spc_phase *p, spc_vec3 wo, spc_vec2 u, spc_vec3 *wi, double *pdf)
{
    if (!spc_v3_finite(wo))
        return false;
    double mu;
    switch (p->type) {
    case SPC_PHASE_ISOTROPIC: mu = 1.0 - 2.0 * u.x; break;
    case SPC_PHASE_HG: {
        double g = p->g;
        if (fabs(g) < SPC_HG_ISOTROPIC_G) {
            mu = 1.0 - 2.0 * u.x;
        } else {
            double s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.x);
            mu = (1.0 + g * g - s * s) / (2.0 * g);
        }
        break;
    }
    default: return false;
    }
    mu = spc_clamp(mu, -1.0, 1.0);
    double sin_t = spc_safe_sqrt(1.0 - mu * mu), phi = 2.0 * SPC_PI * u.y;
    spc_frame f = spc_frame_from_n(spc_neg(wo)); /* n: the travel direction */
    *wi = spc_frame_to_world(&f, spc_v3(sin_t * cos(phi), sin_t * sin(phi), mu));
    *pdf = spc_phase_eval(p, wo, *wi);
    return *pdf > 0.0;
}
