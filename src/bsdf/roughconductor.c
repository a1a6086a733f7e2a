/*
 * bsdf/roughconductor.c: a rough metal, the microfacet reflection model of Walter et al. 2007
 * (eq. 20): f = F(wo.m) D(m) G(wo, wi, m) / (4 cos_o cos_i), m = normalize(wo + wi), on the front
 * side only, with GGX or Beckmann D, anisotropic roughness and Smith's separable G
 * (microfacet.c), and F the conductor Fresnel reflectance (or 1 for a perfect mirror,
 * cond_k.r < 0).
 *
 * Sampling: m from the visible normals seen from wo (or D(m) m.z), wi the mirror of wo about m;
 * p(wi) = p(m) / (4 wo.m) (Walter eq. 14). Weights in closed form: F G1(wi, m) for visible
 * sampling, F G (wo.m) / (cos_o m.z) otherwise.
 *
 * Mitsuba XML <bsdf type="roughconductor">:
 *   distribution           "beckmann" | "ggx"    "beckmann"
 *   alpha                  float or texture      0.1      isotropic roughness (alpha_u = alpha_v)
 *   alpha_u, alpha_v       float or texture      0.1      anisotropic roughness along sh.s, sh.t
 *   material, eta, k       as for conductor      "none"   complex IOR (cond_k.r < 0: mirror)
 *   ext_ior                float or string       "air"
 *   specular_reflectance   spectrum or texture   1.0
 *   sample_visible         boolean               true
 */
#include "bsdf/microfacet.h"
#include "bsdf/variants.h"

spc_rgb spc_roughconductor_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return spc_rgb1(0.0);
    spc_vec3 m = spc_normalize(spc_add(lo, li));
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    double d = spc_microfacet_d(&md, m);
    if (d == 0.0)
        return spc_rgb1(0.0);
    double g = spc_microfacet_g(&md, lo, li, m);
    spc_rgb F = spc_bsdf_conductor_fresnel(b, spc_dot(lo, m));
    spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0));
    return spc_rgb_scale(spc_rgb_mul(F, ks), d * g / (4.0 * lo.z * li.z));
}

double spc_roughconductor_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return 0.0;
    spc_vec3 m = spc_normalize(spc_add(lo, li));
    double d_om = spc_dot(lo, m);
    if (d_om <= 0.0)
        return 0.0;
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    return spc_microfacet_pdf(&md, lo, m) / (4.0 * d_om);
}

/* eval and pdf at once: D(m) and G1(wo, m) computed once, each value as the two functions give it */
spc_rgb spc_roughconductor_eval_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi,
                                    double *pdf)
{
    (void)mode;
    *pdf = 0.0;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return spc_rgb1(0.0);
    spc_vec3 m = spc_normalize(spc_add(lo, li));
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    double d = spc_microfacet_d(&md, m);
    if (d == 0.0)
        return spc_rgb1(0.0);
    double g1o = spc_microfacet_g1(&md, lo, m);
    double d_om = spc_dot(lo, m);
    if (d_om > 0.0)
        *pdf = spc_microfacet_pdf_given(&md, lo, m, d, g1o) / (4.0 * d_om);
    double g = g1o * spc_microfacet_g1(&md, li, m);
    spc_rgb F = spc_bsdf_conductor_fresnel(b, spc_dot(lo, m));
    spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0));
    return spc_rgb_scale(spc_rgb_mul(F, ks), d * g / (4.0 * lo.z * li.z));
}

/* The sample's second half, from the microfacet normal m and its density pdf_m (microfacet.h) */
static bool sample_end(const spc_bsdf *b, const spc_hit *h, spc_vec3 lo, const spc_microfacet *md, spc_vec3 m,
                       double pdf_m, spc_bsdf_sample *out)
{
    double d_om = spc_dot(lo, m);
    if (!(pdf_m > 0.0) || d_om <= 0.0)
        return false;
    spc_vec3 li = spc_reflect(lo, m);
    if (li.z <= 0.0)
        return false;
    double w;
    if (md->sample_visible)
        w = spc_microfacet_g1(md, li, m);
    else
        w = spc_microfacet_g(md, lo, li, m) * d_om / (lo.z * m.z);
    spc_rgb F = spc_bsdf_conductor_fresnel(b, d_om);
    spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0));
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, li), spc_rgb_scale(spc_rgb_mul(F, ks), w), pdf_m / (4.0 * d_om),
                        SPC_LOBE_GLOSSY_REFLECTION, 1.0);
    return true;
}

bool spc_roughconductor_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                               spc_vec2 u, spc_bsdf_sample *out)
{
    (void)mode;
    (void)u_lobe;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z <= 0.0)
        return false;
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    double pdf_m;
    spc_vec3 m = spc_microfacet_sample(&md, lo, u, &pdf_m);
    return sample_end(b, h, lo, &md, m, pdf_m, out);
}

void spc_roughconductor_sample_many(int n, const spc_bsdf *const b[], const spc_hit *const h[], const spc_vec3 wo[],
                                    const spc_vec2 u[], spc_bsdf_sample out[], bool ok[])
{
    enum { BATCH = 16 };
    spc_vec3 lo[BATCH], m[BATCH];
    spc_microfacet md[BATCH];
    spc_vec2 um[BATCH];
    double pdf_m[BATCH];
    int lane[BATCH];
    for (int i0 = 0; i0 < n; i0 += BATCH) {
        int k = 0;
        for (int i = i0; i < n && i < i0 + BATCH; ++i) {
            ok[i] = false;
            lo[k] = spc_bsdf_to_local(h[i], wo[i]);
            if (lo[k].z <= 0.0)
                continue;
            md[k] = spc_microfacet_from_bsdf(b[i], h[i]);
            um[k] = u[i];
            lane[k++] = i;
        }
        spc_microfacet_sample_many(k, md, lo, um, m, pdf_m);
        for (int j = 0; j < k; ++j) {
            int i = lane[j];
            ok[i] = sample_end(b[i], h[i], lo[j], &md[j], m[j], pdf_m[j], &out[i]);
        }
    }
}

spc_rgb spc_roughconductor_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_rgb_mul(spc_bsdf_conductor_fresnel(b, 1.0), spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0)));
}
