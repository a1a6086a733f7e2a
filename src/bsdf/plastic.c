/*
 * bsdf/plastic.c: a diffuse base under a smooth dielectric coating, Mitsuba's plastic model:
 * a delta specular reflection F(cos_o) specular_reflectance at the coating, plus the diffuse base
 * seen through the coating with internal reflections (spc_bsdf_plastic_diffuse in variants.h:
 * Fresnel transmission in and out, the 1/eta^2 factor, and the geometric series of internal
 * reflections with the diffuse Fresnel reflectance of the coating's inside).
 *
 * Sampling: the specular lobe with probability p = F_o s / (F_o s + (1 - F_o)(1 - s)), where
 * s = mean(specular_reflectance) / (mean(specular_reflectance) + mean(diffuse_reflectance)) and
 * F_o = F(cos_o); else the cosine-weighted hemisphere. pdf() counts the diffuse part only:
 * (1 - p) cos_i / pi.
 *
 * Mitsuba XML <bsdf type="plastic">:
 *   int_ior                float or string       "polypropylene" (1.49)
 *   ext_ior                float or string       "air" (1.000277)     b->eta = int_ior / ext_ior
 *   specular_reflectance   spectrum or texture   1.0
 *   diffuse_reflectance    spectrum or texture   0.5                  (read through `reflectance`)
 *   nonlinear              boolean               false
 */
#include "bsdf/variants.h"

/* Probability of sampling the coating's reflection for the cosine cos_o. */
static double plastic_spec_prob(const spc_bsdf *b, const spc_hit *h, double cos_o)
{
    double d = spc_max(spc_rgb_avg(spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5))), 0.0);
    double s = spc_max(spc_rgb_avg(spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0))), 0.0);
    double ssw = d + s > 0.0 ? s / (d + s) : 0.5;
    double F = spc_fresnel_dielectric(cos_o, b->eta, NULL, NULL);
    double ps = F * ssw, pd = (1.0 - F) * (1.0 - ssw);
    return ps + pd > 0.0 ? ps / (ps + pd) : 0.5;
}

spc_rgb spc_plastic_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    double cos_o = spc_dot(wo, h->sh.n), cos_i = spc_dot(wi, h->sh.n);
    if (cos_o <= 0.0 || cos_i <= 0.0)
        return spc_rgb1(0.0);
    return spc_bsdf_plastic_diffuse(spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5)), b->eta, b->nonlinear, cos_o, cos_i);
}

double spc_plastic_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    double cos_o = spc_dot(wo, h->sh.n), cos_i = spc_dot(wi, h->sh.n);
    if (cos_o <= 0.0 || cos_i <= 0.0)
        return 0.0;
    return (1.0 - plastic_spec_prob(b, h, cos_o)) * cos_i * SPC_INV_PI;
}

bool spc_plastic_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                        spc_vec2 u, spc_bsdf_sample *out)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z <= 0.0)
        return false;
    double p = plastic_spec_prob(b, h, lo.z);
    if (u_lobe < p) {
        double F = spc_fresnel_dielectric(lo.z, b->eta, NULL, NULL);
        spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0));
        spc_bsdf_set_sample(out, spc_bsdf_to_world(h, spc_bsdf_mirror_local(lo)), spc_rgb_scale(ks, F / p), p,
                            SPC_LOBE_DELTA_REFLECTION, 1.0);
        return true;
    }
    spc_vec3 li = spc_warp_cosine_hemisphere(u);
    if (li.z <= 0.0)
        return false;
    spc_rgb f = spc_bsdf_plastic_diffuse(spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5)), b->eta, b->nonlinear, lo.z,
                                         li.z);
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, li), spc_rgb_scale(f, SPC_PI / (1.0 - p)),
                        (1.0 - p) * li.z * SPC_INV_PI, SPC_LOBE_DIFFUSE_REFLECTION, 1.0);
    return true;
}

spc_rgb spc_plastic_albedo(const spc_bsdf *b, const spc_hit *h) { return spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5)); }
