/*
 * bsdf/variants.h: private interface between the dispatcher (bsdf.c) and the variant files. Not
 * for use outside src/bsdf/.
 *
 * Every variant implements the four functions of the public contract in bsdf.h with the same
 * parameters and the same meaning (world-space directions, eval without the cosine, pdf in solid
 * angle over the smooth lobes, sample weight f |cos| / pdf):
 *   spc_<variant>_eval, spc_<variant>_pdf, spc_<variant>_sample, spc_<variant>_albedo.
 */
#ifndef SPC_BSDF_VARIANTS_H
#define SPC_BSDF_VARIANTS_H

#include "bsdf/bsdf.h"
#include "core/warp.h"

/* Cosine-weighted hemispherical average of the dielectric Fresnel reflectance for light arriving
 * on the side where eta = n_other / n_incident (fresnel.c). */
double spc_fresnel_diffuse_reflectance(double eta);

/* ---- small helpers shared by the variants ---- */
static inline spc_vec3 spc_bsdf_to_local(const spc_hit *h, spc_vec3 w) { return spc_frame_to_local(&h->sh, w); }
static inline spc_vec3 spc_bsdf_to_world(const spc_hit *h, spc_vec3 w) { return spc_frame_to_world(&h->sh, w); }
static inline spc_rgb spc_bsdf_tex(const spc_texture *t, const spc_hit *h, spc_rgb fallback)
{
    return t ? spc_texture_eval_hit(t, h) : fallback;
}
static inline double spc_bsdf_tex1(const spc_texture *t, const spc_hit *h, double fallback)
{
    return t ? spc_texture_eval1_hit(t, h) : fallback;
}
/* The cosine-weighted hemisphere's density of wi about sh.n (solid angle), 0 unless wo and wi are
 * both above the surface (diffuse, roughdiffuse). */
static inline double spc_bsdf_cosine_pdf(const spc_hit *h, spc_vec3 wo, spc_vec3 wi)
{
    double cos_i = spc_dot(wi, h->sh.n);
    if (spc_dot(wo, h->sh.n) <= 0.0 || cos_i <= 0.0)
        return 0.0;
    return cos_i * SPC_INV_PI;
}
/* Mirror direction about the local z axis. */
static inline spc_vec3 spc_bsdf_mirror_local(spc_vec3 w) { return spc_v3(-w.x, -w.y, w.z); }

/* Reflectance of a conductor (conductor, roughconductor) for the cosine cos_i: a perfect mirror
 * when the loader marked it with cond_k.r < 0 (material "none"). */
static inline spc_rgb spc_bsdf_conductor_fresnel(const spc_bsdf *b, double cos_i)
{
    if (b->cond_k.r < 0.0)
        return spc_rgb1(1.0);
    return spc_fresnel_conductor(cos_i, b->cond_eta, b->cond_k);
}

/* Diffuse base of plastic and roughplastic (Mitsuba's model): light refracts into the coating,
 * scatters diffusely with albedo R, and is partly reflected back by the coating from inside
 * (average reflectance fdr_int = spc_fresnel_diffuse_reflectance(1/eta)), summed as a geometric
 * series: R / (1 - fdr_int), or R / (1 - R fdr_int) if nonlinear. With the two smooth Fresnel
 * transmissions and the 1/eta^2 of entering/leaving the denser medium:
 *   f_d = R' (1 - F(cos_o)) (1 - F(cos_i)) / (pi eta^2),
 * whose albedo is exactly R (1 - F(cos_o)) in the linear case. spc_bsdf_coated_diffuse takes the
 * coating's terms as arguments (internal reflectance fdr_int, transmittances t_o, t_i in place of
 * 1 - F): roughplastic passes its rough coating's tables; spc_bsdf_plastic_diffuse is the smooth
 * interface. */
static inline spc_rgb spc_bsdf_coated_diffuse(spc_rgb R, double eta, bool nonlinear, double fdr_int, double t_o,
                                              double t_i)
{
    spc_rgb denom = nonlinear ? spc_rgb_sub(spc_rgb1(1.0), spc_rgb_scale(R, fdr_int)) : spc_rgb1(1.0 - fdr_int);
    spc_rgb Rp = spc_rgb_div(R, denom);
    return spc_rgb_scale(Rp, t_o * t_i * SPC_INV_PI / (eta * eta));
}

static inline spc_rgb spc_bsdf_plastic_diffuse(spc_rgb R, double eta, bool nonlinear, double cos_o, double cos_i)
{
    return spc_bsdf_coated_diffuse(R, eta, nonlinear, spc_fresnel_diffuse_reflectance(1.0 / eta),
                                   1.0 - spc_fresnel_dielectric(cos_o, eta, NULL, NULL),
                                   1.0 - spc_fresnel_dielectric(cos_i, eta, NULL, NULL));
}

/* roughplastic.c: fills b->coat_t and b->coat_fdr_int (see bsdf.h). */
void spc_roughplastic_prepare(spc_bsdf *b);

/* normalmap and bumpmap evaluate their nested BSDF in a perturbed frame (hit copy `pert`). As
 * Mitsuba 3 does, a direction wi counts only if it lies on the same side of both frames, and the
 * nested f (which assumes the perturbed cosine) is rescaled so that the integrators, which
 * multiply by |wi . sh.n| of the ORIGINAL frame, get f_nested |wi . n_pert|: this factor is what
 * spc_bsdf_perturbed_scale returns (0 when the sides differ). */
static inline double spc_bsdf_perturbed_scale(const spc_hit *orig, const spc_hit *pert, spc_vec3 wi)
{
    double c0 = spc_dot(wi, orig->sh.n), c1 = spc_dot(wi, pert->sh.n);
    if (!(c0 * c1 > 0.0))
        return 0.0;
    return c1 / c0;
}

/* Mitsuba 3.9's normalmap and bumpmap turn a perturbed normal that faces away from the viewer:
 * when wo (toward the previous vertex) is above the original shading normal N but below the
 * perturbed n', n' is rotated by 180 degrees about N (n' <- 2 (n'.N) N - n': the tangential part
 * changes sign), which puts wo above it again. Observed on Mitsuba 3.9.1's eval (the published
 * source only negates normals below the tangent plane); matched to 1e-6 on sampled rays. */
static inline void spc_bsdf_perturbed_face_view(const spc_hit *orig, spc_hit *pert, spc_vec3 wo)
{
    spc_vec3 N = orig->sh.n, n = pert->sh.n;
    if (!(spc_dot(wo, N) > 0.0 && spc_dot(wo, n) < 0.0))
        return;
    spc_vec3 r = spc_sub(spc_scale(N, 2.0 * spc_dot(n, N)), n);
    double len = spc_length(r);
    if (len > 1e-12)
        pert->sh = spc_frame_from_ns(spc_scale(r, 1.0 / len), pert->sh.s);
}

/* The bump-terminator shadowing that Mitsuba 3.9's normalmap and bumpmap multiply into eval and
 * into sample weights (not into the pdf): Smith's G1 of the direction w toward the light about the
 * ORIGINAL shading normal, for a GGX-like spread of the perturbed normals alpha^2 =
 * clamp(tan^2(delta) / 8, 0, 1), delta the angle between the original and perturbed normals
 * (Conty Estevez, Lecocq and Stein 2019, "A Microfacet-Based Shadowing Function to Solve the Bump
 * Terminator Problem", Ray Tracing Gems ch. 12, eqs. 3-4): G1 = 2 / (1 + sqrt(1 + alpha^2
 * tan^2(theta_w))). Matches Mitsuba 3.9.1's eval to 1e-7 on tested points. 1 when the normal is
 * unperturbed. */
static inline double spc_bsdf_bump_shadowing(const spc_hit *orig, const spc_hit *pert, spc_vec3 w)
{
    double cd = spc_dot(orig->sh.n, pert->sh.n), cd2 = cd * cd;
    if (!(cd2 < 1.0))
        return 1.0;
    if (!(cd2 > 0.0))
        return 0.0;
    double a2 = spc_clamp((1.0 - cd2) / (8.0 * cd2), 0.0, 1.0);
    double ci = spc_max(fabs(spc_dot(w, orig->sh.n)), 1e-6), ci2 = ci * ci;
    return 2.0 / (1.0 + sqrt(1.0 + a2 * (1.0 - ci2) / ci2));
}

/* The nested BSDF of normalmap and bumpmap at the perturbed hit pert of orig (after
 * spc_bsdf_perturbed_face_view): its f rescaled by spc_bsdf_perturbed_scale and shadowed by
 * spc_bsdf_bump_shadowing, its pdf where both frames put wi on one side, and its sample (a null
 * lobe's as it is; otherwise none where the sides differ, and the shadowing in the weight).
 * normalmap.c; bumpmap.c uses them too. */
spc_rgb spc_bsdf_perturbed_eval(const spc_bsdf *nested, const spc_hit *orig, const spc_hit *pert, spc_transport mode,
                                spc_vec3 wo, spc_vec3 wi);
double spc_bsdf_perturbed_pdf(const spc_bsdf *nested, const spc_hit *orig, const spc_hit *pert, spc_transport mode,
                              spc_vec3 wo, spc_vec3 wi);
bool spc_bsdf_perturbed_sample(const spc_bsdf *nested, const spc_hit *orig, const spc_hit *pert, spc_transport mode,
                               spc_vec3 wo, double u_lobe, spc_vec2 u, spc_bsdf_sample *out);

/* Fills a sample record (wi given in world space). */
static inline void spc_bsdf_set_sample(spc_bsdf_sample *s, spc_vec3 wi, spc_rgb weight, double pdf, unsigned lobe,
                                       double eta)
{
    s->wi = wi;
    s->weight = weight;
    s->pdf = pdf;
    s->lobe = lobe;
    s->eta = eta;
}

#define SPC_BSDF_VARIANT(name)                                                                                       \
    spc_rgb spc_##name##_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi);   \
    double spc_##name##_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi);     \
    bool spc_##name##_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,   \
                             spc_vec2 u, spc_bsdf_sample *out);                                                      \
    spc_rgb spc_##name##_albedo(const spc_bsdf *b, const spc_hit *h)

/* One line per file, named as the file and the Mitsuba plugin. */
SPC_BSDF_VARIANT(diffuse);
SPC_BSDF_VARIANT(roughdiffuse);
SPC_BSDF_VARIANT(phong);
SPC_BSDF_VARIANT(conductor);
SPC_BSDF_VARIANT(roughconductor);
spc_rgb spc_roughconductor_eval_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo,
                                    spc_vec3 wi, double *pdf);
/* spc_roughconductor_sample of n lanes at once (b[i], h[i], wo[i], u[i] into out[i], ok[i]; the mode
 * and u_lobe do not matter): the same values, the visible-normal searches shared
 * (spc_microfacet_sample_many). */
void spc_roughconductor_sample_many(int n, const spc_bsdf *const b[], const spc_hit *const h[], const spc_vec3 wo[],
                                    const spc_vec2 u[], spc_bsdf_sample out[], bool ok[]);
SPC_BSDF_VARIANT(dielectric);
SPC_BSDF_VARIANT(thindielectric);
spc_rgb spc_thindielectric_null_transmission(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo);
SPC_BSDF_VARIANT(roughdielectric);
SPC_BSDF_VARIANT(plastic);
SPC_BSDF_VARIANT(roughplastic);
SPC_BSDF_VARIANT(pplastic);
SPC_BSDF_VARIANT(twosided);
spc_rgb spc_twosided_eval_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi,
                              double *pdf);
/* The nested BSDF that twosided b uses for wo at h, and in *hs the hit it sees: h, or *flip (the hit
 * with sh.t, sh.n and ng negated) on the back side. */
const spc_bsdf *spc_twosided_side(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo, spc_hit *flip, const spc_hit **hs);
SPC_BSDF_VARIANT(normalmap);
spc_rgb spc_normalmap_specular_throughput(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo,
                                          spc_vec3 wi);
double spc_normalmap_specular_prob(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo, spc_vec3 wi);
SPC_BSDF_VARIANT(bumpmap);
/* The map's perturbed hit of normalmap (bumpmap) b at h before the face-view turn: a copy of h with
 * sh replaced (h's frame where the map leaves it as is). */
void spc_normalmap_hit_frame(const spc_bsdf *b, const spc_hit *h, spc_hit *out);
void spc_bumpmap_hit_frame(const spc_bsdf *b, const spc_hit *h, spc_hit *out);
SPC_BSDF_VARIANT(null);
spc_rgb spc_null_null_transmission(const spc_bsdf *b, const spc_hit *h);
SPC_BSDF_VARIANT(mask);
spc_rgb spc_mask_null_transmission(const spc_bsdf *b, const spc_hit *h);
SPC_BSDF_VARIANT(blendbsdf);
SPC_BSDF_VARIANT(principled);
SPC_BSDF_VARIANT(principledthin);

#undef SPC_BSDF_VARIANT

#endif
