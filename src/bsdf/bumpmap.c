/*
 * bsdf/bumpmap.c: perturbs the shading normal with a height texture (Blinn 1978, "Simulation of
 * Wrinkled Surfaces"; the construction of Mitsuba 3's bumpmap). With the height
 * H(u, v) = scale * texture(u, v) (channel mean) and the position's derivatives along the
 * texture coordinates, the displaced surface p + H n has the tangents
 *   dp/du' = dp/du + n (dH/du - n . dp/du),   dp/dv' likewise,
 * (the term H dn/du is neglected, as Mitsuba does), so n' = normalize(dp/du' x dp/dv'), oriented
 * to the side of the unperturbed sh.n, and s' is dp/du' made orthogonal to n'. (For reliefs so
 * steep that dp/du' x dp/dv' turns past the tangent plane, Mitsuba 3.9.1's eval sometimes
 * negates the normal, as its source says and we do, and sometimes mirrors it about the tangent
 * plane; we found no rule for the latter.) The nested BSDF is
 * evaluated in that frame with the side test and cosine correction of spc_bsdf_perturbed_scale
 * and the bump-terminator shadowing of spc_bsdf_bump_shadowing (variants.h), as Mitsuba 3.9.
 *
 * Gradient: spc_texture_eval1_grad, the exact gradient of the bilinear interpolant in the cell
 * holding the hit's uv (through to_uv), as Mitsuba 3's eval_1_grad; zero for nearest bitmaps and
 * piecewise-constant textures, as there. (A central difference over a texel, which this replaced,
 * averages the gradients of neighbouring cells: a visibly smoother relief than Mitsuba's.)
 * Derivatives along the texture coordinates: the hit's dpdu/dpdv are derivatives along the shape's
 * surface parameters (hit.h), which equal the texture coordinates except for meshes with uvs; for
 * those the texture-space tangents are rebuilt from the triangle's vertex uvs through h->shape.
 *
 * Mitsuba XML <bsdf type="bumpmap">:
 *   nested <texture>   height map (mean of the channels)
 *   scale              float   1.0   (b->bump_scale; the loader sets the default)
 *   nested <bsdf>
 */
#include "bsdf/variants.h"
#include "scene/shape.h"

/* dp/du and dp/dv along the TEXTURE coordinates at h. */
static void texture_tangents(const spc_hit *h, spc_vec3 *dpdu, spc_vec3 *dpdv)
{
    *dpdu = h->dpdu;
    *dpdv = h->dpdv;
    const spc_shape *s = h->shape;
    if (!s || s->type != SPC_SHAPE_MESH || !s->mesh.uv || !s->mesh.idx || h->prim < 0)
        return;
    double duv[4];
    spc_mesh_tri_duv(&s->mesh, (size_t)h->prim, duv);
    /* h->dpdu, h->dpdv are dp/db1 = e1 and dp/db2 = e2 */
    spc_uv_tangents(h->dpdu, h->dpdv, duv, 1e-20, dpdu, dpdv);
}

void spc_bumpmap_hit_frame(const spc_bsdf *b, const spc_hit *h, spc_hit *out)
{
    *out = *h;
    if (!b->bump)
        return;
    spc_vec2 g = spc_texture_eval1_grad(b->bump, h->uv);
    double dhdu = b->bump_scale * g.x, dhdv = b->bump_scale * g.y;
    spc_vec3 dpdu, dpdv, n = h->sh.n;
    texture_tangents(h, &dpdu, &dpdv);
    dpdu = spc_madd(dpdu, n, dhdu - spc_dot(n, dpdu));
    dpdv = spc_madd(dpdv, n, dhdv - spc_dot(n, dpdv));
    spc_vec3 np = spc_cross(dpdu, dpdv);
    double len = spc_length(np);
    if (!(len > 1e-30) || !spc_v3_finite(np))
        return;
    np = spc_scale(np, 1.0 / len);
    if (spc_dot(np, n) < 0.0)
        np = spc_neg(np);
    out->sh = spc_frame_from_ns(np, dpdu);
}

/* The perturbed hit as Mitsuba 3.9 sees it from wo (variants.h). */
static void bumpmap_hit(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo, spc_hit *out)
{
    spc_bumpmap_hit_frame(b, h, out);
    spc_bsdf_perturbed_face_view(h, out, wo);
}

spc_rgb spc_bumpmap_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_hit ph;
    bumpmap_hit(b, h, wo, &ph);
    return spc_bsdf_perturbed_eval(b->nested[0], h, &ph, mode, wo, wi);
}

double spc_bumpmap_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_hit ph;
    bumpmap_hit(b, h, wo, &ph);
    return spc_bsdf_perturbed_pdf(b->nested[0], h, &ph, mode, wo, wi);
}

bool spc_bumpmap_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                        spc_vec2 u, spc_bsdf_sample *out)
{
    spc_hit ph;
    bumpmap_hit(b, h, wo, &ph);
    return spc_bsdf_perturbed_sample(b->nested[0], h, &ph, mode, wo, u_lobe, u, out);
}

spc_rgb spc_bumpmap_albedo(const spc_bsdf *b, const spc_hit *h) { return spc_bsdf_albedo(b->nested[0], h); }
