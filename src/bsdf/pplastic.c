/*
 * bsdf/pplastic.c: Mitsuba 3's pplastic ("polarized plastic") as its unpolarized variants
 * evaluate it: a rough dielectric coating's specular reflection plus a diffuse base seen through
 * two Fresnel transmissions, with no interreflection between them (unlike roughplastic):
 *
 *   f(wo, wi) = ks F(wo.m) D(m) G(wo, wi, m) / (4 cos_o cos_i)
 *             + (1 - F(cos_o)) (1 - F(cos_i)) kd / pi,       m = normalize(wo + wi),
 *
 * F the dielectric Fresnel reflectance for eta = int_ior / ext_ior; front side only. The
 * polarization of the reflections is not tracked (as in Mitsuba's RGB variants).
 *
 * Sampling: the specular lobe (m from the visible normals seen from wo, or from D(m) m.z, and
 * wi its mirror) with probability p_s = mean(ks) / (mean(kd) + mean(ks)), else cosine-weighted;
 * pdf = p_s pdf_spec + (1 - p_s) cos_i / pi, weight f cos_i / pdf.
 *
 * Mitsuba XML <bsdf type="pplastic">:
 *   diffuse_reflectance    spectrum or texture   0.5
 *   specular_reflectance   spectrum or texture   1.0
 *   distribution           "beckmann" | "ggx"    "beckmann"
 *   alpha, alpha_u/v       float or texture      0.1
 *   int_ior, ext_ior       float or string       "polypropylene" (1.49), "air"
 *   sample_visible         boolean               true
 */
#include "bsdf/microfacet.h"
#include "bsdf/variants.h"

static double specular_probability(const spc_bsdf *b)
{
    double d = spc_rgb_avg(spc_texture_mean(b->reflectance));
    double s = b->specular_reflectance ? spc_rgb_avg(spc_texture_mean(b->specular_reflectance)) : 1.0;
    return d + s > 0.0 ? s / (d + s) : 0.5;
}

spc_rgb spc_pplastic_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return spc_rgb1(0.0);
    spc_vec3 m = spc_normalize(spc_add(lo, li));
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    double spec = spc_microfacet_d(&md, m) * spc_microfacet_g(&md, lo, li, m) *
                  spc_fresnel_dielectric(spc_dot(lo, m), b->eta, NULL, NULL) / (4.0 * lo.z * li.z);
    spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0));
    spc_rgb kd = spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
    double t = (1.0 - spc_fresnel_dielectric(lo.z, b->eta, NULL, NULL)) *
               (1.0 - spc_fresnel_dielectric(li.z, b->eta, NULL, NULL));
    return spc_rgb_add(spc_rgb_scale(ks, spec), spc_rgb_scale(kd, t / SPC_PI));
}

double spc_pplastic_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return 0.0;
    double ps = specular_probability(b);
    spc_vec3 m = spc_normalize(spc_add(lo, li));
    double d_om = spc_dot(lo, m), p_spec = 0.0;
    if (d_om > 0.0 && spc_dot(li, m) > 0.0) {
        spc_microfacet md = spc_microfacet_from_bsdf(b, h);
        p_spec = spc_microfacet_pdf(&md, lo, m) / (4.0 * d_om);
    }
    return ps * p_spec + (1.0 - ps) * li.z / SPC_PI;
}

bool spc_pplastic_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                         spc_vec2 u, spc_bsdf_sample *out)
{
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z <= 0.0)
        return false;
    double ps = specular_probability(b);
    spc_vec3 li;
    unsigned lobe;
    if (u_lobe < ps) {
        spc_microfacet md = spc_microfacet_from_bsdf(b, h);
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
    spc_vec3 wi = spc_bsdf_to_world(h, li);
    double pdf = spc_pplastic_pdf(b, h, mode, wo, wi);
    if (!(pdf > 0.0))
        return false;
    spc_rgb f = spc_pplastic_eval(b, h, mode, wo, wi);
    spc_bsdf_set_sample(out, wi, spc_rgb_scale(f, li.z / pdf), pdf, lobe, 1.0);
    return true;
}

spc_rgb spc_pplastic_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
}
