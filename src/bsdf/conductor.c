/*
 * bsdf/conductor.c: a smooth metal, a perfect mirror on the front side. The reflected direction is
 * the mirror of wo about sh.n; the weight is F(cos) times specular_reflectance, with F the exact
 * conductor Fresnel reflectance for the complex IOR eta + i k (fresnel.c), or 1 when the loader
 * marked a perfect mirror (cond_k.r < 0, Mitsuba's material "none").
 *
 * Mitsuba XML <bsdf type="conductor">:
 *   material               string                "none"   named IOR data ("none": perfect mirror);
 *                                                          resolved by the loader into eta/k
 *   eta, k                 spectrum              -        complex IOR (overrides material)
 *   ext_ior                float or string       "air"    eta and k are divided by it
 *   specular_reflectance   spectrum or texture   1.0      multiplies the Fresnel reflectance
 */
#include "bsdf/variants.h"

/* A delta lobe: no value and no density for a given pair of directions (bsdf.h). */
spc_rgb spc_conductor_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return spc_rgb1(0.0);
}

double spc_conductor_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return 0.0;
}

bool spc_conductor_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                          spc_vec2 u, spc_bsdf_sample *out)
{
    (void)mode;
    (void)u_lobe;
    (void)u;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z <= 0.0)
        return false;
    spc_rgb weight = spc_rgb_mul(spc_bsdf_conductor_fresnel(b, lo.z),
                                 spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0)));
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, spc_bsdf_mirror_local(lo)), weight, 1.0,
                        SPC_LOBE_DELTA_REFLECTION, 1.0);
    return true;
}

spc_rgb spc_conductor_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_rgb_mul(spc_bsdf_conductor_fresnel(b, 1.0), spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0)));
}
