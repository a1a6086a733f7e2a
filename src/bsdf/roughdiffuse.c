/*
 * bsdf/roughdiffuse.c: Oren-Nayar reflectance of a rough diffuse surface (Oren and Nayar 1994,
 * "Generalization of Lambert's Reflectance Model"): the full qualitative model, single scattering
 * with the coefficients C1, C2, C3 (eqs. 27-30 of the paper) plus the interreflection term of
 * eq. 31 (the 0.17 rho^2 term), as Mitsuba 0.6's roughdiffuse does by default
 * (use_fast_approx = false).
 *
 * Roughness: Mitsuba's `alpha` is the RMS slope of the facets (Beckmann-style); the model's sigma
 * (standard deviation of the facet angle, radians) is sigma = alpha / sqrt(2), Mitsuba's
 * conversion. alpha = 0 gives exactly the Lambertian R / pi. The model is reciprocal (it depends
 * on max/min of the two angles and on cos(phi_i - phi_o)).
 * Sampling: cosine-weighted hemisphere (the lobe is close to Lambertian).
 *
 * Mitsuba XML <bsdf type="roughdiffuse">:
 *   reflectance       spectrum or texture   0.5    diffuse albedo rho
 *   alpha             float or texture      0.2    RMS facet slope (read through alpha_u)
 *   use_fast_approx   boolean               false  not supported: the full model is always used
 */
#include "bsdf/variants.h"

/* Conversion of Mitsuba's RMS slope alpha into Oren-Nayar's sigma (Mitsuba 0.6's fit). */
#define ROUGHDIFFUSE_SIGMA_PER_ALPHA 0.70710678118654752440

static spc_rgb oren_nayar(spc_rgb rho, double alpha, spc_vec3 wo, spc_vec3 wi)
{
    double sigma = alpha * ROUGHDIFFUSE_SIGMA_PER_ALPHA;
    double s2 = sigma * sigma;
    double sin_o = spc_safe_sqrt(1.0 - wo.z * wo.z), sin_i = spc_safe_sqrt(1.0 - wi.z * wi.z);
    double cos_phi = 0.0;
    if (sin_o > 1e-12 && sin_i > 1e-12)
        cos_phi = spc_clamp((wo.x * wi.x + wo.y * wi.y) / (sin_o * sin_i), -1.0, 1.0);
    double theta_o = acos(spc_clamp(wo.z, -1.0, 1.0)), theta_i = acos(spc_clamp(wi.z, -1.0, 1.0));
    double a = spc_max(theta_o, theta_i), be = spc_min(theta_o, theta_i);
    double sin_a = sin(a), tan_b = tan(be);
    double k09 = s2 / (s2 + 0.09);
    double two_b_pi = 2.0 * be * SPC_INV_PI;
    double c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
    double c2 = 0.45 * k09 * (cos_phi >= 0.0 ? sin_a : sin_a - two_b_pi * two_b_pi * two_b_pi);
    double ab = 4.0 * a * be * SPC_INV_PI * SPC_INV_PI;
    double c3 = 0.125 * k09 * ab * ab;
    double single = c1 + cos_phi * c2 * tan_b + (1.0 - fabs(cos_phi)) * c3 * tan(0.5 * (a + be));
    double inter = 0.17 * s2 / (s2 + 0.13) * (1.0 - cos_phi * two_b_pi * two_b_pi);
    return spc_rgb_scale(spc_rgb_add(spc_rgb_scale(rho, single), spc_rgb_scale(spc_rgb_mul(rho, rho), inter)),
                         SPC_INV_PI);
}

spc_rgb spc_roughdiffuse_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return spc_rgb1(0.0);
    spc_rgb rho = spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
    return oren_nayar(rho, spc_bsdf_tex1(b->alpha_u, h, 0.2), lo, li);
}

double spc_roughdiffuse_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return spc_bsdf_cosine_pdf(h, wo, wi);
}

bool spc_roughdiffuse_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                             spc_vec2 u, spc_bsdf_sample *out)
{
    (void)u_lobe;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z <= 0.0)
        return false;
    spc_vec3 li = spc_warp_cosine_hemisphere(u);
    if (li.z <= 0.0)
        return false;
    spc_rgb rho = spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
    spc_rgb f = oren_nayar(rho, spc_bsdf_tex1(b->alpha_u, h, 0.2), lo, li);
    (void)mode;
    /* weight f cos / (cos / pi) */
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, li), spc_rgb_scale(f, SPC_PI), li.z * SPC_INV_PI,
                        SPC_LOBE_DIFFUSE_REFLECTION, 1.0);
    return true;
}

spc_rgb spc_roughdiffuse_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
}
