/*
 * bsdf/normalmap.c: replaces the shading normal by one read from a tangent-space normal map
 * (Mitsuba 3's normalmap). The texture's RGB at the hit's uv maps to n_local = 2 rgb - 1 in the
 * frame (sh.s, sh.t, sh.n) (hit.h: sh.s follows the texture-space tangent); the new frame has
 * n = normalize(n_local in world space) and s the Gram-Schmidt projection of the old sh.s. The
 * nested BSDF is evaluated in that frame, with the side test and cosine correction described at
 * spc_bsdf_perturbed_scale and the bump-terminator shadowing of spc_bsdf_bump_shadowing
 * (variants.h), as Mitsuba 3.9. A zero or non-finite map value leaves the frame as is.
 *
 * Specular chain vertices (src/manifold/) need the mapped normal as a differentiable function of
 * the surface parameters: spc_bsdf_map_chain_hit applies the map to a hit once, with the normal's
 * derivatives through the texture's bilinear interpolant (spc_texture_eval_grad), the uv
 * parameterization and the rotation of the tangent frame (spc_shape_texture_frame), and the
 * face-view turn below; spc_bsdf_specular_throughput then applies the side test and the
 * shadowing term to the mapped hit, so a chain through a normal-mapped interface carries what BSDF
 * sampling would.
 *
 * Mitsuba XML <bsdf type="normalmap">:
 *   normalmap      texture (bitmap, raw="true")   tangent-space normals in [0,1]^3
 *   nested <bsdf>
 */
#include "bsdf/variants.h"
#include "scene/shape.h"

void spc_normalmap_hit_frame(const spc_bsdf *b, const spc_hit *h, spc_hit *out)
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
    spc_normalmap_hit_frame(b, h, out);
    spc_bsdf_perturbed_face_view(h, out, wo);
}

/* The nested BSDF in the perturbed frame (variants.h), for normalmap and bumpmap. */
spc_rgb spc_bsdf_perturbed_eval(const spc_bsdf *nested, const spc_hit *orig, const spc_hit *pert, spc_transport mode,
                                spc_vec3 wo, spc_vec3 wi)
{
    double k = spc_bsdf_perturbed_scale(orig, pert, wi);
    if (k == 0.0)
        return spc_rgb1(0.0);
    k *= spc_bsdf_bump_shadowing(orig, pert, wi); /* as Mitsuba 3.9 */
    return spc_rgb_scale(spc_bsdf_eval(nested, pert, mode, wo, wi), k);
}

double spc_bsdf_perturbed_pdf(const spc_bsdf *nested, const spc_hit *orig, const spc_hit *pert, spc_transport mode,
                              spc_vec3 wo, spc_vec3 wi)
{
    if (spc_bsdf_perturbed_scale(orig, pert, wi) == 0.0)
        return 0.0;
    return spc_bsdf_pdf(nested, pert, mode, wo, wi);
}

bool spc_bsdf_perturbed_sample(const spc_bsdf *nested, const spc_hit *orig, const spc_hit *pert, spc_transport mode,
                               spc_vec3 wo, double u_lobe, spc_vec2 u, spc_bsdf_sample *out)
{
    if (!spc_bsdf_sample_dir(nested, pert, mode, wo, u_lobe, u, out))
        return false;
    if (out->lobe & SPC_LOBE_NULL)
        return true;
    if (spc_bsdf_perturbed_scale(orig, pert, out->wi) == 0.0)
        return false;
    /* the nested weight already uses the perturbed cosine, as the rescaled eval does; the
     * shadowing term multiplies eval, so it multiplies the weight (not the pdf) */
    out->weight = spc_rgb_scale(out->weight, spc_bsdf_bump_shadowing(orig, pert, out->wi));
    return true;
}

spc_rgb spc_normalmap_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_hit ph;
    normalmap_hit(b, h, wo, &ph);
    return spc_bsdf_perturbed_eval(b->nested[0], h, &ph, mode, wo, wi);
}

double spc_normalmap_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_hit ph;
    normalmap_hit(b, h, wo, &ph);
    return spc_bsdf_perturbed_pdf(b->nested[0], h, &ph, mode, wo, wi);
}

bool spc_normalmap_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                          spc_vec2 u, spc_bsdf_sample *out)
{
    spc_hit ph;
    normalmap_hit(b, h, wo, &ph);
    return spc_bsdf_perturbed_sample(b->nested[0], h, &ph, mode, wo, u_lobe, u, out);
}

spc_rgb spc_normalmap_albedo(const spc_bsdf *b, const spc_hit *h) { return spc_bsdf_albedo(b->nested[0], h); }

bool spc_bsdf_chain_mappable(const spc_bsdf *b, int shape_type)
{
    return !b || b->type != SPC_BSDF_NORMALMAP || !b->normalmap || shape_type != SPC_SHAPE_SDF;
}

/* d(v / |v|) = (I - u u^T) dv / |v| with u = v / |v| */
static spc_vec3 dnormalize(spc_vec3 u, double len, spc_vec3 dv)
{
    return spc_scale(spc_sub(dv, spc_scale(u, spc_dot(u, dv))), 1.0 / len);
}

bool spc_bsdf_map_chain_hit(spc_hit *h, spc_vec3 wo)
{
    const spc_bsdf *b = h->bsdf;
    if (!b || b->type != SPC_BSDF_NORMALMAP || h->normal_mapped || !b->normalmap)
        return true;
    spc_vec2 duv[2];
    spc_vec3 T, dT[2];
    if (!spc_shape_texture_frame(h, duv, &T, dT))
        return false;
    /* the unmapped frame: S = normalize(T - N (N.T)), Tt = N x S (spc_frame_from_ns) */
    spc_vec3 N = h->sh.n, dN[2] = {h->dndu, h->dndv};
    double NT = spc_dot(N, T);
    spc_vec3 su = spc_sub(T, spc_scale(N, NT));
    double ls = spc_length(su);
    if (!(ls > 1e-12 * spc_length(T)))
        return false;
    spc_vec3 S = spc_scale(su, 1.0 / ls), Tt = spc_cross(N, S);
    spc_rgb g[2];
    spc_rgb c = spc_texture_eval_grad(b->normalmap, h->uv, g);
    spc_vec3 nl = spc_v3(2.0 * c.r - 1.0, 2.0 * c.g - 1.0, 2.0 * c.b - 1.0);
    spc_vec3 m = spc_add(spc_add(spc_scale(S, nl.x), spc_scale(Tt, nl.y)), spc_scale(N, nl.z));
    double lm = spc_length(m);
    if (!(lm > 1e-12) || !spc_v3_finite(m)) {
        /* the BSDF leaves such a frame as is (spc_normalmap_hit_frame) */
        h->n_unmapped = N;
        h->normal_mapped = true;
        return true;
    }
    spc_vec3 n = spc_scale(m, 1.0 / lm), dn[2];
    for (int j = 0; j < 2; ++j) {
        spc_vec3 dsu = spc_sub(spc_sub(dT[j], spc_scale(dN[j], NT)),
                               spc_scale(N, spc_dot(dN[j], T) + spc_dot(N, dT[j])));
        spc_vec3 dS = dnormalize(S, ls, dsu);
        spc_vec3 dTt = spc_add(spc_cross(dN[j], S), spc_cross(N, dS));
        spc_rgb dc = spc_rgb_add(spc_rgb_scale(g[0], duv[j].x), spc_rgb_scale(g[1], duv[j].y));
        spc_vec3 dnl = spc_v3(2.0 * dc.r, 2.0 * dc.g, 2.0 * dc.b);
        spc_vec3 dm = spc_add(spc_add(spc_scale(S, dnl.x), spc_scale(dS, nl.x)),
                              spc_add(spc_scale(Tt, dnl.y), spc_scale(dTt, nl.y)));
        dm = spc_add(dm, spc_add(spc_scale(N, dnl.z), spc_scale(dN[j], nl.z)));
        dn[j] = dnormalize(n, lm, dm);
    }
    /* the face-view turn of spc_bsdf_perturbed_face_view, differentiated */
    if (spc_dot(wo, N) > 0.0 && spc_dot(wo, n) < 0.0) {
        double nN = spc_dot(n, N);
        spc_vec3 r = spc_sub(spc_scale(N, 2.0 * nN), n);
        double lr = spc_length(r);
        if (lr > 1e-12) {
            spc_vec3 nr = spc_scale(r, 1.0 / lr);
            for (int j = 0; j < 2; ++j) {
                double dnN = spc_dot(dn[j], N) + spc_dot(n, dN[j]);
                spc_vec3 dr = spc_sub(spc_add(spc_scale(N, 2.0 * dnN), spc_scale(dN[j], 2.0 * nN)), dn[j]);
                dn[j] = dnormalize(nr, lr, dr);
            }
            n = nr;
        }
    }
    h->n_unmapped = N;
    h->sh = spc_frame_from_ns(n, h->sh.s);
    h->dndu = dn[0];
    h->dndv = dn[1];
    h->normal_mapped = true;
    return true;
}

spc_rgb spc_normalmap_specular_throughput(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo,
                                          spc_vec3 wi)
{
    spc_hit m = *h;
    if (!spc_bsdf_map_chain_hit(&m, wo))
        return spc_rgb1(0.0);
    if (!m.normal_mapped)
        return spc_bsdf_specular_throughput(b->nested[0], &m, mode, wo, wi);
    /* as spc_normalmap_sample: wi on the same side of both frames, times the shadowing term */
    spc_hit orig = m;
    orig.sh.n = m.n_unmapped;
    if (spc_bsdf_perturbed_scale(&orig, &m, wi) == 0.0)
        return spc_rgb1(0.0);
    return spc_rgb_scale(spc_bsdf_specular_throughput(b->nested[0], &m, mode, wo, wi),
                         spc_bsdf_bump_shadowing(&orig, &m, wi));
}

double spc_normalmap_specular_prob(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo, spc_vec3 wi)
{
    /* spc_normalmap_sample draws the nested BSDF's lobe in the mapped frame */
    spc_hit m = *h;
    if (!spc_bsdf_map_chain_hit(&m, wo))
        return 0.0;
    return spc_bsdf_specular_prob(b->nested[0], &m, wo, wi);
}
