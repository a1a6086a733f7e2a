/*
 * bsdf/normalmap.c: replaces the shading normal by one read from a tangent-space normal map
 * (Mitsuba 3's normalmap). The texture's RGB at the hit's uv maps to n_local = 2 rgb - 1 in the
 * frame (sh.s, sh.t, sh.n) (hit.h: sh.s follows the texture-space tangent); the new frame has
 * n = normalize(n_local in world space) and s the Gram-Schmidt projection of the old sh.s. The
 * nested BSDF is evaluated in that frame, with the side test and cosine correction described at
 * spc_bsdf_perturbed_scale and the bump-terminator shadowing of spc_bsdf_bump_shadowing
 * (variants.h), as Mitsuba 3.9. A zero or non-finite map value leaves the frame as is.
 *
 * Mitsuba XML <bsdf type="normalmap">:
 *   normalmap      texture (bitmap, raw="true")   tangent-space normals in [0,1]^3
 *   nested <bsdf>
 */
#include "bsdf/variants.h"

static void normalmap_hit_frame(const spc_bsdf *b, const spc_hit *h, spc_hit *out)
{
    *out = *h;
    if (!b->normalmap)
        return;
    spc_rgb c = spc_texture_eval(b->normalmap, h->uv);
    spc_vec3 nl = spc_v3(2.0 * c.r - 1.0, 2.0 * c.g - 1.0, 2.0 * c.b - 1.0);
    spc_vec3 n = spc_frame_to_world(&h->sh, nl);
    double len = spc_length(n);
    if (!(len > 1e-12) || !spc_v3_finite(n))
        return;
    out->sh = spc_frame_from_ns(spc_scale(n, 1.0 / len), h->sh.s);
}

/* The perturbed hit as Mitsuba 3.9 sees it from wo (variants.h). */
static void normalmap_hit(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo, spc_hit *out)
{
    normalmap_hit_frame(b, h, out);
    spc_bsdf_perturbed_face_view(h, out, wo);
}

spc_rgb spc_normalmap_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_hit ph;
    normalmap_hit(b, h, wo, &ph);
    double k = spc_bsdf_perturbed_scale(h, &ph, wi);
    if (k == 0.0)
        return spc_rgb1(0.0);
    k *= spc_bsdf_bump_shadowing(h, &ph, wi); /* as Mitsuba 3.9 (variants.h) */
    return spc_rgb_scale(spc_bsdf_eval(b->nested[0], &ph, mode, wo, wi), k);
}

double spc_normalmap_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_hit ph;
    normalmap_hit(b, h, wo, &ph);
    if (spc_bsdf_perturbed_scale(h, &ph, wi) == 0.0)
        return 0.0;
    return spc_bsdf_pdf(b->nested[0], &ph, mode, wo, wi);
}

bool spc_normalmap_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                          spc_vec2 u, spc_bsdf_sample *out)
{
    spc_hit ph;
    normalmap_hit(b, h, wo, &ph);
    if (!spc_bsdf_sample_dir(b->nested[0], &ph, mode, wo, u_lobe, u, out))
        return false;
    if (out->lobe & SPC_LOBE_NULL)
        return true;
    if (spc_bsdf_perturbed_scale(h, &ph, out->wi) == 0.0)
        return false;
    /* the nested weight already uses the perturbed cosine, as the rescaled eval does; the
     * shadowing term multiplies eval, so it multiplies the weight (not the pdf) */
    out->weight = spc_rgb_scale(out->weight, spc_bsdf_bump_shadowing(h, &ph, out->wi));
    return true;
}

spc_rgb spc_normalmap_albedo(const spc_bsdf *b, const spc_hit *h) { return spc_bsdf_albedo(b->nested[0], h); }
