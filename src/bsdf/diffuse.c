/*
 * bsdf/diffuse.c: the Lambertian reflector, f = R / pi on the front side of the shading frame,
 * sampled with the cosine-weighted hemisphere (pdf cos / pi), so the sample weight is R.
 *
 * Mitsuba XML <bsdf type="diffuse">:
 *   reflectance   spectrum or texture   0.5   diffuse albedo R
 */
#include "bsdf/variants.h"

spc_rgb spc_diffuse_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    if (spc_dot(wo, h->sh.n) <= 0.0 || spc_dot(wi, h->sh.n) <= 0.0)
        return spc_rgb1(0.0);
    return spc_rgb_scale(spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5)), SPC_INV_PI);
}

double spc_diffuse_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return spc_bsdf_cosine_pdf(h, wo, wi);
}

bool spc_diffuse_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                        spc_vec2 u, spc_bsdf_sample *out)
{
    (void)mode;
    (void)u_lobe;
    if (spc_dot(wo, h->sh.n) <= 0.0)
        return false;
    spc_vec3 wl = spc_warp_cosine_hemisphere(u);
    if (wl.z <= 0.0)
        return false;
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, wl), spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5)),
                        wl.z * SPC_INV_PI, SPC_LOBE_DIFFUSE_REFLECTION, 1.0);
    return true;
}

spc_rgb spc_diffuse_albedo(const spc_bsdf *b, const spc_hit *h) { return spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5)); }
