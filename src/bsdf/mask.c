/*
 * bsdf/mask.c: an opacity mask (Mitsuba's mask): with probability `opacity` the surface is the
 * nested BSDF, otherwise light passes straight through. As a BSDF:
 *   f = opacity f_nested (+ a null lobe of weight 1 - opacity),
 * pdf = opacity pdf_nested. Sampling picks the nested BSDF with probability opacity (the sample's
 * pdf, smooth or discrete, is multiplied by it and the weight is unchanged), else the null lobe
 * (wi = -wo, weight 1, pdf 1 - opacity).
 *
 * Mitsuba XML <bsdf type="mask">:
 *   opacity        float or texture   0.5   (mean of the channels)
 *   nested <bsdf>                           the opaque part
 */
#include "bsdf/variants.h"

static double mask_opacity(const spc_bsdf *b, const spc_hit *h)
{
    double o = spc_bsdf_tex1(b->opacity, h, 0.5);
    return isfinite(o) ? spc_clamp(o, 0.0, 1.0) : 0.0;
}

spc_rgb spc_mask_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    double o = mask_opacity(b, h);
    if (o <= 0.0)
        return spc_rgb1(0.0);
    return spc_rgb_scale(spc_bsdf_eval(b->nested[0], h, mode, wo, wi), o);
}

double spc_mask_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    double o = mask_opacity(b, h);
    if (o <= 0.0)
        return 0.0;
    return o * spc_bsdf_pdf(b->nested[0], h, mode, wo, wi);
}

bool spc_mask_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe, spc_vec2 u,
                     spc_bsdf_sample *out)
{
    double o = mask_opacity(b, h);
    if (u_lobe < o) {
        if (!spc_bsdf_sample_dir(b->nested[0], h, mode, wo, u_lobe / o, u, out))
            return false;
        out->pdf *= o;
        return true;
    }
    spc_bsdf_set_sample(out, spc_neg(wo), spc_rgb1(1.0), 1.0 - o, SPC_LOBE_NULL, 1.0);
    return true;
}

spc_rgb spc_mask_null_transmission(const spc_bsdf *b, const spc_hit *h)
{
    return spc_rgb1(1.0 - mask_opacity(b, h));
}

spc_rgb spc_mask_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_rgb_scale(spc_bsdf_albedo(b->nested[0], h), mask_opacity(b, h));
}
