/*
 * bsdf/roughplastic.c: a diffuse base under a rough dielectric coating (Mitsuba's roughplastic,
 * after Weidlich and Wilkie 2007): the microfacet reflection of the coating,
 *   f_s = specular_reflectance F(wo.m) D(m) G(wo, wi, m) / (4 cos_o cos_i)   (Walter et al. eq. 20),
 * plus the diffuse base of plastic (spc_bsdf_plastic_diffuse in variants.h).
 *
 * Approximation (documented difference from Mitsuba): the diffuse part is attenuated by the
 * SMOOTH-interface transmittances 1 - F(cos_o), 1 - F(cos_i); Mitsuba instead tabulates the rough
 * coating's transmittance 1 - (its directional albedo) per (cos, alpha, eta). The two agree as
 * alpha -> 0 and differ mostly at grazing angles for large alpha. The model stays reciprocal.
 *
 * Sampling: the coating's microfacet lobe (visible normals or D(m) m.z, microfacet.c; wi the
 * mirror of wo about m) with probability p = F_o s / (F_o s + (1 - F_o)(1 - s)), s as in plastic,
 * else the cosine-weighted hemisphere; pdf and weight are those of the mixture.
 *
 * Mitsuba XML <bsdf type="roughplastic">:
 *   distribution           "beckmann" | "ggx"    "beckmann"
 *   alpha                  float or texture      0.1     (alpha_u = alpha_v; anisotropy is accepted)
 *   int_ior                float or string       "polypropylene" (1.49)
 *   ext_ior                float or string       "air" (1.000277)     b->eta = int_ior / ext_ior
 *   specular_reflectance   spectrum or texture   1.0
 *   diffuse_reflectance    spectrum or texture   0.5     (read through `reflectance`)
 *   nonlinear              boolean               false
 *   sample_visible         boolean               true
 */
#include "bsdf/microfacet.h"
#include "bsdf/variants.h"

static double roughplastic_spec_prob(const spc_bsdf *b, const spc_hit *h, double cos_o)
{
    double d = spc_max(spc_rgb_avg(spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5))), 0.0);
    double s = spc_max(spc_rgb_avg(spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0))), 0.0);
    double ssw = d + s > 0.0 ? s / (d + s) : 0.5;
    double F = spc_fresnel_dielectric(cos_o, b->eta, NULL, NULL);
    double ps = F * ssw, pd = (1.0 - F) * (1.0 - ssw);
    return ps + pd > 0.0 ? ps / (ps + pd) : 0.5;
}

static spc_rgb roughplastic_f(const spc_bsdf *b, const spc_hit *h, const spc_microfacet *md, spc_vec3 lo, spc_vec3 li)
{
    spc_rgb f = spc_bsdf_plastic_diffuse(spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5)), b->eta, b->nonlinear, lo.z,
                                         li.z);
    spc_vec3 m = spc_normalize(spc_add(lo, li));
    double d = spc_microfacet_d(md, m);
    if (d > 0.0) {
        double g = spc_microfacet_g(md, lo, li, m);
        double F = spc_fresnel_dielectric(spc_dot(lo, m), b->eta, NULL, NULL);
        spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0));
        f = spc_rgb_add(f, spc_rgb_scale(ks, F * d * g / (4.0 * lo.z * li.z)));
    }
    return f;
}

static double roughplastic_pdf_local(const spc_microfacet *md, double p, spc_vec3 lo, spc_vec3 li)
{
    double pdf = (1.0 - p) * li.z * SPC_INV_PI;
    spc_vec3 m = spc_normalize(spc_add(lo, li));
    double d_om = spc_dot(lo, m);
    if (d_om > 0.0)
        pdf += p * spc_microfacet_pdf(md, lo, m) / (4.0 * d_om);
    return pdf;
}

spc_rgb spc_roughplastic_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return spc_rgb1(0.0);
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    return roughplastic_f(b, h, &md, lo, li);
}

double spc_roughplastic_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return 0.0;
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    return roughplastic_pdf_local(&md, roughplastic_spec_prob(b, h, lo.z), lo, li);
}

bool spc_roughplastic_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                             spc_vec2 u, spc_bsdf_sample *out)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z <= 0.0)
        return false;
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    double p = roughplastic_spec_prob(b, h, lo.z);
    spc_vec3 li;
    unsigned lobe;
    if (u_lobe < p) {
        double pdf_m;
        spc_vec3 m = spc_microfacet_sample(&md, lo, u, &pdf_m);
        if (!(pdf_m > 0.0) || spc_dot(lo, m) <= 0.0)
            return false;
        li = spc_reflect(lo, m);
        lobe = SPC_LOBE_GLOSSY_REFLECTION;
    } else {
        li = spc_warp_cosine_hemisphere(u);
        lobe = SPC_LOBE_DIFFUSE_REFLECTION;
    }
    if (li.z <= 0.0)
        return false;
    double pdf = roughplastic_pdf_local(&md, p, lo, li);
    if (!(pdf > 0.0))
        return false;
    spc_rgb f = roughplastic_f(b, h, &md, lo, li);
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, li), spc_rgb_scale(f, li.z / pdf), pdf, lobe, 1.0);
    return true;
}

spc_rgb spc_roughplastic_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
}
