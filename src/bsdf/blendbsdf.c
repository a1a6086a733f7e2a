/*
 * bsdf/blendbsdf.c: a linear blend of two BSDFs (Mitsuba's blendbsdf),
 *   f = (1 - w) f_0 + w f_1,   pdf = (1 - w) pdf_0 + w pdf_1.
 * Sampling picks nested[1] with probability w (the lobe random number is rescaled and passed
 * on). A smooth sample gets the pdf and weight of the whole mixture (so sample() agrees with eval()
 * and pdf()); a delta sample keeps its weight and its probability is multiplied by the choice's.
 *
 * Mitsuba XML <bsdf type="blendbsdf">:
 *   weight           float or texture   0.5   blend weight w of the SECOND nested BSDF
 *   two nested <bsdf>
 */
#include "bsdf/variants.h"

static double blend_weight(const spc_bsdf *b, const spc_hit *h)
{
    double w = spc_bsdf_tex1(b->weight, h, 0.5);
    return isfinite(w) ? spc_clamp(w, 0.0, 1.0) : 0.5;
}

spc_rgb spc_blendbsdf_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    double w = blend_weight(b, h);
    spc_rgb f = spc_rgb1(0.0);
    if (w < 1.0)
        f = spc_rgb_scale(spc_bsdf_eval(b->nested[0], h, mode, wo, wi), 1.0 - w);
    if (w > 0.0)
        f = spc_rgb_add(f, spc_rgb_scale(spc_bsdf_eval(b->nested[1], h, mode, wo, wi), w));
    return f;
}

double spc_blendbsdf_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    double w = blend_weight(b, h), p = 0.0;
    if (w < 1.0)
        p += (1.0 - w) * spc_bsdf_pdf(b->nested[0], h, mode, wo, wi);
    if (w > 0.0)
        p += w * spc_bsdf_pdf(b->nested[1], h, mode, wo, wi);
    return p;
}

bool spc_blendbsdf_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                          spc_vec2 u, spc_bsdf_sample *out)
{
    double w = blend_weight(b, h);
    int idx;
    double prob;
    if (u_lobe < w) {
        idx = 1;
        prob = w;
        u_lobe /= w;
    } else {
        idx = 0;
        prob = 1.0 - w;
        u_lobe = (u_lobe - w) / (1.0 - w);
    }
    u_lobe = spc_clamp(u_lobe, 0.0, 0x1.fffffffffffffp-1);
    if (!spc_bsdf_sample_dir(b->nested[idx], h, mode, wo, u_lobe, u, out))
        return false;
    if (out->lobe & SPC_LOBE_DELTA) {
        out->pdf *= prob;
        return true;
    }
    double pdf = spc_blendbsdf_pdf(b, h, mode, wo, out->wi);
    if (!(pdf > 0.0))
        return false;
    spc_rgb f = spc_blendbsdf_eval(b, h, mode, wo, out->wi);
    out->weight = spc_rgb_scale(f, spc_absdot(out->wi, h->sh.n) / pdf);
    out->pdf = pdf;
    return true;
}

spc_rgb spc_blendbsdf_albedo(const spc_bsdf *b, const spc_hit *h)
{
    double w = blend_weight(b, h);
    return spc_rgb_add(spc_rgb_scale(spc_bsdf_albedo(b->nested[0], h), 1.0 - w),
                       spc_rgb_scale(spc_bsdf_albedo(b->nested[1], h), w));
}
