/*
 * bsdf/roughdielectric.c: a rough interface between two dielectrics, Walter et al. 2007,
 * "Microfacet Models for Refraction through Rough Surfaces".
 *
 * With eta_p = n(wi side) / n(wo side) (1 for reflection) the generalized half vector is
 * m = +-normalize(wo + eta_p wi) oriented to m.z > 0 (eq. 16). Then
 *   reflection   f = F D G / (4 |cos_o cos_i|)                                             (eq. 20)
 *   transmission f = (1 - F) D G |wi.m| |wo.m| / (|cos_i| |cos_o| (wi.m + wo.m / eta_p)^2)
 * which is the importance-mode BTDF; radiance mode divides it by eta_p^2 (eq. 21 has n_o^2 in the
 * numerator: radiance compression). F = F(wo.m) for the side wo is on; G = G1(wo) G1(wi) with
 * each G1 zero when the direction sees the back of m from its own side (which also rejects
 * half vectors that are not between wo and wi).
 *
 * Sampling (Walter sec. 5.3, with visible normals as Heitz 2018): m from the visible normals seen
 * from wo flipped to the upper hemisphere, then reflection with probability F(wo.m), else
 * refraction about m. Densities: p(m) F / (4 |wo.m|) for reflection (eq. 14) and
 * p(m) (1 - F) |wi.m| / (wi.m + wo.m / eta_p)^2 for refraction (eq. 17). Weights in closed form:
 * (specular_reflectance or specular_transmittance) G1(wi, m), divided by eta_p^2 for a refraction
 * in radiance mode (with D(m) m.z sampling: G |wo.m| / (|cos_o| m.z) instead of G1(wi, m)).
 *
 * Mitsuba XML <bsdf type="roughdielectric">:
 *   distribution             "beckmann" | "ggx"    "beckmann"
 *   alpha, alpha_u, alpha_v  float or texture      0.1
 *   int_ior                  float or string       "bk7" (1.5046)
 *   ext_ior                  float or string       "air" (1.000277)   b->eta = int_ior / ext_ior
 *   specular_reflectance     spectrum or texture   1.0
 *   specular_transmittance   spectrum or texture   1.0
 *   sample_visible           boolean               true
 */
#include "bsdf/microfacet.h"
#include "bsdf/variants.h"

/* The half vector of (wo, wi) and the relative IOR eta_p; false if undefined. */
static bool half_vector(double eta, spc_vec3 lo, spc_vec3 li, spc_vec3 *m, double *eta_p)
{
    bool reflect = lo.z * li.z > 0.0;
    double e = reflect ? 1.0 : (lo.z > 0.0 ? eta : 1.0 / eta);
    spc_vec3 hv = spc_add(lo, spc_scale(li, e));
    double len = spc_length(hv);
    if (!(len > 0.0))
        return false;
    hv = spc_scale(hv, 1.0 / len);
    if (hv.z < 0.0)
        hv = spc_neg(hv);
    /* microfacets seen from the back by either direction do not contribute */
    if (spc_dot(lo, hv) * lo.z <= 0.0 || spc_dot(li, hv) * li.z <= 0.0)
        return false;
    *m = hv;
    *eta_p = e;
    return true;
}

spc_rgb spc_roughdielectric_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z == 0.0 || li.z == 0.0)
        return spc_rgb1(0.0);
    spc_vec3 m;
    double eta_p;
    if (!half_vector(b->eta, lo, li, &m, &eta_p))
        return spc_rgb1(0.0);
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    double d = spc_microfacet_d(&md, m);
    if (d == 0.0)
        return spc_rgb1(0.0);
    double g = spc_microfacet_g(&md, lo, li, m);
    double d_om = spc_dot(lo, m), d_im = spc_dot(li, m);
    double F = spc_fresnel_dielectric(d_om, b->eta, NULL, NULL);
    if (lo.z * li.z > 0.0) {
        spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0));
        return spc_rgb_scale(ks, F * d * g / (4.0 * fabs(lo.z * li.z)));
    }
    double denom = d_im + d_om / eta_p;
    double v = (1.0 - F) * d * g * fabs(d_im * d_om) / (fabs(lo.z * li.z) * denom * denom);
    if (mode == SPC_MODE_RADIANCE)
        v /= eta_p * eta_p;
    return spc_rgb_scale(spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0)), v);
}

double spc_roughdielectric_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z == 0.0 || li.z == 0.0)
        return 0.0;
    spc_vec3 m;
    double eta_p;
    if (!half_vector(b->eta, lo, li, &m, &eta_p))
        return 0.0;
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    double pdf_m = spc_microfacet_pdf(&md, lo, m);
    double d_om = spc_dot(lo, m), d_im = spc_dot(li, m);
    double F = spc_fresnel_dielectric(d_om, b->eta, NULL, NULL);
    if (lo.z * li.z > 0.0)
        return pdf_m * F / (4.0 * fabs(d_om));
    double denom = d_im + d_om / eta_p;
    return pdf_m * (1.0 - F) * fabs(d_im) / (denom * denom);
}

bool spc_roughdielectric_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                                spc_vec2 u, spc_bsdf_sample *out)
{
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z == 0.0)
        return false;
    spc_vec3 lo_up = lo.z > 0.0 ? lo : spc_neg(lo);
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    double pdf_m;
    spc_vec3 m = spc_microfacet_sample(&md, lo_up, u, &pdf_m);
    if (!(pdf_m > 0.0))
        return false;
    double d_om = spc_dot(lo, m);
    if (d_om * lo.z <= 0.0)
        return false;
    double cos_t, eta_ti;
    double F = spc_fresnel_dielectric(d_om, b->eta, &cos_t, &eta_ti);
    spc_vec3 li;
    double pdf, w;
    spc_rgb tint;
    unsigned lobe;
    double eta_s;
    if (u_lobe < F) {
        li = spc_reflect(lo, m);
        if (li.z * lo.z <= 0.0)
            return false;
        pdf = pdf_m * F / (4.0 * fabs(d_om));
        tint = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0));
        lobe = SPC_LOBE_GLOSSY_REFLECTION;
        eta_s = 1.0;
    } else {
        li = spc_refract(lo, m, cos_t, eta_ti);
        if (li.z * lo.z >= 0.0)
            return false;
        double d_im = spc_dot(li, m);
        double denom = d_im + d_om / eta_ti;
        pdf = pdf_m * (1.0 - F) * fabs(d_im) / (denom * denom);
        tint = spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0));
        if (mode == SPC_MODE_RADIANCE)
            tint = spc_rgb_scale(tint, 1.0 / (eta_ti * eta_ti));
        lobe = SPC_LOBE_GLOSSY_TRANSMISSION;
        eta_s = eta_ti;
    }
    if (md.sample_visible)
        w = spc_microfacet_g1(&md, li, m);
    else
        w = spc_microfacet_g(&md, lo, li, m) * fabs(d_om) / (fabs(lo.z) * m.z);
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, li), spc_rgb_scale(tint, w), pdf, lobe, eta_s);
    return true;
}

spc_rgb spc_roughdielectric_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0));
}
