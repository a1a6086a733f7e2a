/*
 * bsdf/twosided.c: makes one-sided BSDFs two-sided (Mitsuba's twosided). When wo is on the front
 * of the shading frame (wo . sh.n >= 0) the first nested BSDF is used unchanged; on the back, the
 * second nested BSDF (or the first if there is only one) is evaluated in the flipped frame
 * (s, -t, -n), still right-handed, with ng flipped too so that nested bump maps orient their
 * normal consistently. Directions on opposite sides get whatever the nested BSDF says (zero for
 * the one-sided reflectors it is meant for).
 *
 * Mitsuba XML <bsdf type="twosided">:
 *   one or two nested <bsdf>   front (and back) BSDF
 */
#include "bsdf/variants.h"

const spc_bsdf *spc_twosided_side(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo, spc_hit *flip,
                                  const spc_hit **hs)
{
    if (spc_dot(wo, h->sh.n) >= 0.0) {
        *hs = h;
        return b->nested[0];
    }
    *flip = *h;
    flip->sh.t = spc_neg(h->sh.t);
    flip->sh.n = spc_neg(h->sh.n);
    flip->ng = spc_neg(h->ng);
    *hs = flip;
    return b->nested[1] ? b->nested[1] : b->nested[0];
}

spc_rgb spc_twosided_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_hit flip;
    const spc_hit *hs;
    const spc_bsdf *nb = spc_twosided_side(b, h, wo, &flip, &hs);
    return spc_bsdf_eval(nb, hs, mode, wo, wi);
}

double spc_twosided_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_hit flip;
    const spc_hit *hs;
    const spc_bsdf *nb = spc_twosided_side(b, h, wo, &flip, &hs);
    return spc_bsdf_pdf(nb, hs, mode, wo, wi);
}

spc_rgb spc_twosided_eval_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi,
                              double *pdf)
{
    spc_hit flip;
    const spc_hit *hs;
    const spc_bsdf *nb = spc_twosided_side(b, h, wo, &flip, &hs);
    return spc_bsdf_eval_pdf(nb, hs, mode, wo, wi, pdf);
}

bool spc_twosided_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                         spc_vec2 u, spc_bsdf_sample *out)
{
    spc_hit flip;
    const spc_hit *hs;
    const spc_bsdf *nb = spc_twosided_side(b, h, wo, &flip, &hs);
    return spc_bsdf_sample_dir(nb, hs, mode, wo, u_lobe, u, out);
}

spc_rgb spc_twosided_albedo(const spc_bsdf *b, const spc_hit *h) { return spc_bsdf_albedo(b->nested[0], h); }
