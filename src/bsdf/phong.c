/*
 * bsdf/phong.c: a diffuse base plus an energy-normalized Blinn-Phong glossy lobe,
 *   f = kd / pi + ks c(n) cos^n(theta_h),   h = normalize(wo + wi),
 * both on the front side only. It is reciprocal.
 *
 * Normalization (our choice, documented): c(n) = 1 / (8 pi A(n)) with
 *   A(n) = 2 (1 - 2^-(n+4)/2) / (n+4) - (1 - 2^-(n+2)/2) / (n+2),
 * the exact value for which the glossy lobe reflects exactly ks at normal incidence
 * (integral of cos^n(theta_h) cos(theta_i) over the hemisphere, with theta_i = 2 theta_h and
 * d(omega_i) = 4 cos(theta_h) d(omega_h)). Its albedo decreases toward grazing angles, so the lobe
 * never creates energy; c(0) = 1/pi (Lambertian). The popular (n+8)/(8 pi) (Akenine-Moeller et
 * al., Real-Time Rendering) approximates the same quantity but exceeds it: its normal-incidence
 * albedo is n(n+8)/((n+2)(n+4)) + O(2^-n/2), 1.05 at n = 30.
 * Note: Mitsuba 0.6's `phong` is Lafortune's modified Phong (lobe around the mirror direction),
 * which has a different highlight shape; this file implements the half-vector form.
 *
 * Sampling: a mixture of the cosine-weighted hemisphere and the half-vector lobe
 * p(h) = (n+1)/(2 pi) cos^n(theta_h) (p(wi) = p(h) / (4 wo.h)), chosen with probabilities
 * proportional to the mean diffuse and specular reflectances; the sample weight is the mixture's
 * f cos / pdf.
 *
 * Mitsuba XML <bsdf type="phong">:
 *   exponent               float                 30    n (read from `exponent`)
 *   specular_reflectance   spectrum or texture   0.2   ks
 *   diffuse_reflectance    spectrum or texture   0.5   kd (read through `reflectance`)
 */
#include "bsdf/variants.h"

static double phong_norm(double n)
{
    double a = 2.0 * (1.0 - pow(2.0, -0.5 * (n + 4.0))) / (n + 4.0) - (1.0 - pow(2.0, -0.5 * (n + 2.0))) / (n + 2.0);
    return 1.0 / (8.0 * SPC_PI * a);
}

static double phong_exponent(const spc_bsdf *b) { return isfinite(b->exponent) ? spc_max(b->exponent, 0.0) : 0.0; }

/* Probability of choosing the glossy lobe when sampling. */
static double phong_spec_prob(spc_rgb kd, spc_rgb ks)
{
    double d = spc_max(spc_rgb_avg(kd), 0.0), s = spc_max(spc_rgb_avg(ks), 0.0);
    return d + s > 0.0 ? s / (d + s) : 0.5;
}

static spc_rgb phong_f(spc_rgb kd, spc_rgb ks, double n, spc_vec3 lo, spc_vec3 li)
{
    spc_vec3 hv = spc_normalize(spc_add(lo, li));
    double spec = hv.z > 0.0 ? phong_norm(n) * pow(hv.z, n) : 0.0;
    return spc_rgb_add(spc_rgb_scale(kd, SPC_INV_PI), spc_rgb_scale(ks, spec));
}

static double phong_pdf_local(double p_spec, double n, spc_vec3 lo, spc_vec3 li)
{
    spc_vec3 hv = spc_normalize(spc_add(lo, li));
    double d_oh = spc_dot(lo, hv);
    double pdf = (1.0 - p_spec) * li.z * SPC_INV_PI;
    if (hv.z > 0.0 && d_oh > 0.0)
        pdf += p_spec * (n + 1.0) * SPC_INV_2PI * pow(hv.z, n) / (4.0 * d_oh);
    return pdf;
}

spc_rgb spc_phong_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return spc_rgb1(0.0);
    spc_rgb kd = spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
    spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(0.2));
    return phong_f(kd, ks, phong_exponent(b), lo, li);
}

double spc_phong_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return 0.0;
    spc_rgb kd = spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
    spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(0.2));
    return phong_pdf_local(phong_spec_prob(kd, ks), phong_exponent(b), lo, li);
}

bool spc_phong_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                      spc_vec2 u, spc_bsdf_sample *out)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z <= 0.0)
        return false;
    spc_rgb kd = spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
    spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(0.2));
    double n = phong_exponent(b), p_spec = phong_spec_prob(kd, ks);
    spc_vec3 li;
    unsigned lobe;
    if (u_lobe < p_spec) {
        double cos_h = pow(u.x, 1.0 / (n + 1.0)), sin_h = spc_safe_sqrt(1.0 - cos_h * cos_h);
        double phi = 2.0 * SPC_PI * u.y;
        spc_vec3 hv = spc_v3(sin_h * cos(phi), sin_h * sin(phi), cos_h);
        li = spc_reflect(lo, hv);
        lobe = SPC_LOBE_GLOSSY_REFLECTION;
    } else {
        li = spc_warp_cosine_hemisphere(u);
        lobe = SPC_LOBE_DIFFUSE_REFLECTION;
    }
    if (li.z <= 0.0)
        return false;
    double pdf = phong_pdf_local(p_spec, n, lo, li);
    if (!(pdf > 0.0))
        return false;
    spc_rgb f = phong_f(kd, ks, n, lo, li);
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, li), spc_rgb_scale(f, li.z / pdf), pdf, lobe, 1.0);
    return true;
}

spc_rgb spc_phong_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_rgb_add(spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5)),
                       spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(0.2)));
}
