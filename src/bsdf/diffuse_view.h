/*
 * bsdf/diffuse_view.h: the diffuse lobe as a path tracer that runs many paths side by side sees it
 * at one vertex (integrator/path_wave.c), without the dispatch of bsdf.c or twosided's copy of the
 * hit.
 *
 * A view exists where b is diffuse, or twosided with a diffuse side facing wo (the side that
 * twosided.c picks: the front when dot(wo, sh.n) >= 0). twosided hands its nested BSDF a copy of
 * the hit whose sh.t, sh.n and ng are negated; the view keeps h and a sign instead. Negation is
 * exact in floating point (dot(w, -n) is -dot(w, n) bit for bit, and a + (-b) is a - b), so the
 * view's eval, pdf and sample give spc_bsdf_eval's, spc_bsdf_pdf's and spc_bsdf_sample_dir's values
 * bit for bit: the same expressions as diffuse.c in the same order (test_path_wave compares them).
 */
#ifndef SPC_BSDF_DIFFUSE_VIEW_H
#define SPC_BSDF_DIFFUSE_VIEW_H

#include "bsdf/bsdf.h"
#include "core/warp.h"

typedef struct spc_diffuse_view {
    double sign;    /* +1: h's shading frame; -1: twosided's flipped frame (t, n negated) */
    spc_vec3 n;     /* the view frame's normal, sign * h->sh.n, negated once for eval, pdf and sample */
    spc_rgb albedo; /* the reflectance at h, looked up once for eval and sample */
} spc_diffuse_view;

/* The view's side toward wo: 0 where dot(wo, sh.n) >= 0 (twosided's front), else 1. */
static inline int spc_diffuse_view_side(const spc_hit *h, spc_vec3 wo) { return !(spc_dot(wo, h->sh.n) >= 0.0); }

/* The view at h from each side's sign and reflectance, where they do not depend on the hit (a
 * constant reflectance: spc_diffuse_view_const); the same view as spc_diffuse_view_of. */
static inline void spc_diffuse_view_make(const spc_hit *h, double sign, spc_rgb albedo, spc_diffuse_view *v)
{
    v->sign = sign;
    v->n = spc_v3(sign * h->sh.n.x, sign * h->sh.n.y, sign * h->sh.n.z);
    v->albedo = albedo;
}

/* Whether b is seen from either side as a diffuse lobe of constant reflectance (a diffuse BSDF
 * whose reflectance is a constant texture or its default, or twosided over such BSDFs on both
 * sides); then sign[k] and albedo[k] of side k (spc_diffuse_view_side), so that a caller shading
 * many hits of one shape takes each hit's view without the BSDF's dispatch or a texture lookup. */
static inline bool spc_diffuse_view_const(const spc_bsdf *b, double sign[2], spc_rgb albedo[2])
{
    if (!b)
        return false;
    const spc_bsdf *side[2] = {b, b};
    sign[0] = sign[1] = 1.0;
    if (b->type == SPC_BSDF_TWOSIDED) {
        side[0] = b->nested[0];
        side[1] = b->nested[1] ? b->nested[1] : b->nested[0];
        sign[1] = -1.0;
    }
    for (int k = 0; k < 2; ++k) {
        if (!side[k] || side[k]->type != SPC_BSDF_DIFFUSE)
            return false;
        const spc_texture *r = side[k]->reflectance;
        if (r && r->type != SPC_TEX_CONSTANT)
            return false;
        albedo[k] = r ? r->value : spc_rgb1(0.5);
    }
    return true;
}

/* Does b scatter from wo at h as a diffuse BSDF (itself, or twosided's side that wo sees)? */
static inline bool spc_diffuse_view_of(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo, spc_diffuse_view *v)
{
    if (!b)
        return false;
    double sign = 1.0;
    if (b->type == SPC_BSDF_TWOSIDED) {
        if (spc_dot(wo, h->sh.n) >= 0.0) {
            b = b->nested[0];
        } else {
            b = b->nested[1] ? b->nested[1] : b->nested[0];
            sign = -1.0;
        }
    }
    if (!b || b->type != SPC_BSDF_DIFFUSE)
        return false;
    spc_diffuse_view_make(h, sign, b->reflectance ? spc_texture_eval_hit(b->reflectance, h) : spc_rgb1(0.5), v);
    return true;
}

/* the shading normal of the view's frame */
static inline spc_vec3 spc_diffuse_view_n(const spc_diffuse_view *v, const spc_hit *h)
{
    (void)h;
    return v->n;
}

static inline spc_rgb spc_diffuse_view_albedo(const spc_diffuse_view *v, const spc_hit *h)
{
    (void)h;
    return v->albedo;
}

/* spc_bsdf_eval (diffuse.c: R / pi where wo and wi are above the horizon) */
static inline spc_rgb spc_diffuse_view_eval(const spc_diffuse_view *v, const spc_hit *h, spc_vec3 wo, spc_vec3 wi)
{
    spc_vec3 n = spc_diffuse_view_n(v, h);
    if (spc_dot(wo, n) <= 0.0 || spc_dot(wi, n) <= 0.0)
        return spc_rgb1(0.0);
    return spc_rgb_scale(spc_diffuse_view_albedo(v, h), SPC_INV_PI);
}

/* spc_diffuse_view_eval, and where its value is not zero *cos_i = dot(wi, n), the cosine that
 * spc_diffuse_view_pdf divides by pi (then |dot(wi, h->sh.n)| bit for bit: n is sh.n times +1 or -1,
 * and negation is exact); *cos_i is untouched where the value is zero */
static inline spc_rgb spc_diffuse_view_eval_cos(const spc_diffuse_view *v, const spc_hit *h, spc_vec3 wo, spc_vec3 wi,
                                                double *cos_i)
{
    spc_vec3 n = spc_diffuse_view_n(v, h);
    if (spc_dot(wo, n) <= 0.0)
        return spc_rgb1(0.0);
    double c = spc_dot(wi, n);
    if (c <= 0.0)
        return spc_rgb1(0.0);
    *cos_i = c;
    return spc_rgb_scale(spc_diffuse_view_albedo(v, h), SPC_INV_PI);
}

/* spc_bsdf_pdf (cosine-weighted hemisphere) */
static inline double spc_diffuse_view_pdf(const spc_diffuse_view *v, const spc_hit *h, spc_vec3 wo, spc_vec3 wi)
{
    spc_vec3 n = spc_diffuse_view_n(v, h);
    double cos_i = spc_dot(wi, n);
    if (spc_dot(wo, n) <= 0.0 || cos_i <= 0.0)
        return 0.0;
    return cos_i * SPC_INV_PI;
}

/* spc_bsdf_sample_dir, with its guard on the record, from wl = spc_warp_cosine_hemisphere(u) (the
 * local direction, computed beforehand for many lanes at once) */
static inline bool spc_diffuse_view_sample_warped(const spc_diffuse_view *v, const spc_hit *h, spc_vec3 wo,
                                                  spc_vec3 wl, spc_bsdf_sample *out)
{
    spc_vec3 n = spc_diffuse_view_n(v, h);
    if (spc_dot(wo, n) <= 0.0)
        return false;
    if (wl.z <= 0.0)
        return false;
    spc_frame f = h->sh;
    f.t = spc_v3(v->sign * f.t.x, v->sign * f.t.y, v->sign * f.t.z);
    f.n = n;
    out->wi = spc_frame_to_world(&f, wl);
    out->weight = spc_diffuse_view_albedo(v, h);
    out->pdf = wl.z * SPC_INV_PI;
    out->lobe = SPC_LOBE_DIFFUSE_REFLECTION;
    out->eta = 1.0;
    return out->pdf > 0.0 && spc_rgb_finite(out->weight) && spc_v3_finite(out->wi);
}

/* spc_bsdf_sample_dir, with its guard on the record */
static inline bool spc_diffuse_view_sample(const spc_diffuse_view *v, const spc_hit *h, spc_vec3 wo, spc_vec2 u,
                                           spc_bsdf_sample *out)
{
    return spc_diffuse_view_sample_warped(v, h, wo, spc_warp_cosine_hemisphere(u), out);
}

#endif
