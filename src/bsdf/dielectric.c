/*
 * bsdf/dielectric.c: a smooth interface between two dielectrics (glass, water). Both lobes are
 * delta: the mirror direction with probability F and the refracted direction (Snell's law) with
 * probability 1 - F, where F is the unpolarized Fresnel reflectance (fresnel.c) for the side wo is
 * on ("inside" is opposite to sh.n, relative IOR eta = int_ior / ext_ior). Under total internal
 * reflection F = 1 and the reflection is always chosen.
 *
 * Weights: reflection specular_reflectance (F / F); refraction specular_transmittance, divided by
 * eta_t^2 in radiance mode (radiance compression, eta_t = n(wi side) / n(wo side), also reported
 * as the sample's eta).
 *
 * Mitsuba XML <bsdf type="dielectric">:
 *   int_ior                  float or string       "bk7" (1.5046)
 *   ext_ior                  float or string       "air" (1.000277)   b->eta = int_ior / ext_ior
 *   specular_reflectance     spectrum or texture   1.0
 *   specular_transmittance   spectrum or texture   1.0
 */
#include "bsdf/variants.h"

/* A delta lobe: no value and no density for a given pair of directions (bsdf.h). */
spc_rgb spc_dielectric_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return spc_rgb1(0.0);
}

double spc_dielectric_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return 0.0;
}

bool spc_dielectric_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                           spc_vec2 u, spc_bsdf_sample *out)
{
    (void)u;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z == 0.0)
        return false;
    double cos_t, eta_ti;
    double F = spc_fresnel_dielectric(lo.z, b->eta, &cos_t, &eta_ti);
    if (u_lobe < F) {
        spc_bsdf_set_sample(out, spc_bsdf_to_world(h, spc_bsdf_mirror_local(lo)),
                            spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0)), F, SPC_LOBE_DELTA_REFLECTION,
                            1.0);
        return true;
    }
    spc_vec3 li = spc_refract(lo, spc_v3(0.0, 0.0, 1.0), cos_t, eta_ti);
    spc_rgb weight = spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0));
    if (mode == SPC_MODE_RADIANCE)
        weight = spc_rgb_scale(weight, 1.0 / (eta_ti * eta_ti));
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, li), weight, 1.0 - F, SPC_LOBE_DELTA_TRANSMISSION, eta_ti);
    return true;
}

spc_rgb spc_dielectric_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0));
}
