/*
 * bsdf/bsdf.h: the BSDF contract. One tagged union, dispatched by a switch in bsdf.c; one file
 * per variant named as Mitsuba names the plugin (diffuse.c, dielectric.c, roughconductor.c, ...).
 *
 * Conventions (every variant and every integrator relies on these):
 * - Directions are WORLD-space unit vectors pointing AWAY from the surface: wo toward the
 *   previous vertex of the path being traced (the camera side for camera paths), wi the other one.
 *   The variant transforms them into the local shading frame h->sh (normalmap and bumpmap first
 *   perturb that frame, twosided flips it for the back side).
 * - eval() returns f(wo, wi) WITHOUT the cosine factor. It is zero for delta lobes.
 * - pdf() is the solid-angle density with which sample() produces wi, counting only the non-delta
 *   lobes (and the probability of choosing them). Zero when wi cannot be sampled.
 * - sample() returns false for "no sample" (absorbed, below the horizon, total internal reflection
 *   where only refraction was asked). On success: wi, weight = f |cos(wi, sh.n)| / pdf (the whole
 *   estimator factor), pdf (solid angle; for a delta lobe, the discrete probability of choosing
 *   it), the one lobe it sampled, and eta.
 * - eta in a sample record: for a transmission, the relative IOR n(wi side) / n(wo side); 1 for
 *   reflection and null passage. Integrators multiply it into Russian roulette's throughput
 *   correction as pbrt-v4 does.
 * - Transport mode: SPC_MODE_RADIANCE on camera paths, SPC_MODE_IMPORTANCE on light paths. For a
 *   refraction in radiance mode f is divided by eta^2 (radiance compression, as pbrt-v4).
 *   Shading-normal asymmetry (Veach 1997, eq. 5.20) is NOT applied here; BDPT applies it.
 * - Sidedness: one-sided BSDFs (diffuse, conductors, ... without twosided) are black when
 *   wo is below the shading horizon (Mitsuba 3's convention). Dielectrics are two-sided by nature;
 *   "inside" is the side opposite to sh.n.
 * - Hot path: no error codes, no allocation.
 */
#ifndef SPC_BSDF_BSDF_H
#define SPC_BSDF_BSDF_H

#include "core/math.h"
#include "scene/hit.h"
#include "scene/texture.h"

typedef enum spc_transport {
    SPC_MODE_RADIANCE = 0,
    SPC_MODE_IMPORTANCE = 1
} spc_transport;

/* Lobe flags: a sample reports exactly one; spc_bsdf_flags() reports the union. */
enum {
    SPC_LOBE_DIFFUSE_REFLECTION = 1u << 0,
    SPC_LOBE_GLOSSY_REFLECTION = 1u << 1,
    SPC_LOBE_DELTA_REFLECTION = 1u << 2,
    SPC_LOBE_DIFFUSE_TRANSMISSION = 1u << 3,
    SPC_LOBE_GLOSSY_TRANSMISSION = 1u << 4,
    SPC_LOBE_DELTA_TRANSMISSION = 1u << 5,
    SPC_LOBE_NULL = 1u << 6 /* passes straight through (null, mask): wi = -wo */
};
#define SPC_LOBE_DELTA (SPC_LOBE_DELTA_REFLECTION | SPC_LOBE_DELTA_TRANSMISSION | SPC_LOBE_NULL)
#define SPC_LOBE_SMOOTH                                                                                              \
    (SPC_LOBE_DIFFUSE_REFLECTION | SPC_LOBE_GLOSSY_REFLECTION | SPC_LOBE_DIFFUSE_TRANSMISSION |                       \
     SPC_LOBE_GLOSSY_TRANSMISSION)
#define SPC_LOBE_REFLECTION (SPC_LOBE_DIFFUSE_REFLECTION | SPC_LOBE_GLOSSY_REFLECTION | SPC_LOBE_DELTA_REFLECTION)
#define SPC_LOBE_TRANSMISSION                                                                                        \
    (SPC_LOBE_DIFFUSE_TRANSMISSION | SPC_LOBE_GLOSSY_TRANSMISSION | SPC_LOBE_DELTA_TRANSMISSION | SPC_LOBE_NULL)

typedef enum spc_bsdf_type {
    SPC_BSDF_DIFFUSE,
    SPC_BSDF_ROUGHDIFFUSE,   /* Oren-Nayar */
    SPC_BSDF_PHONG,          /* energy-normalized modified Blinn-Phong */
    SPC_BSDF_CONDUCTOR,      /* smooth metal: perfect mirror, or Fresnel from eta/k */
    SPC_BSDF_ROUGHCONDUCTOR, /* GGX / Beckmann microfacets (Walter et al. 2007) */
    SPC_BSDF_DIELECTRIC,     /* smooth glass */
    SPC_BSDF_THINDIELECTRIC, /* thin sheet: reflection and straight transmission */
    SPC_BSDF_ROUGHDIELECTRIC,
    SPC_BSDF_PLASTIC,
    SPC_BSDF_ROUGHPLASTIC,
    SPC_BSDF_PPLASTIC,  /* Mitsuba 3's pplastic, unpolarized: coating + base, no interreflection */
    SPC_BSDF_TWOSIDED,  /* nested[0] on the front, nested[1] (or nested[0]) on the back */
    SPC_BSDF_NORMALMAP, /* nested[0] with the shading normal from a tangent-space map */
    SPC_BSDF_BUMPMAP,   /* nested[0] with the shading normal from a height texture */
    SPC_BSDF_NULL,      /* invisible: null lobe only */
    SPC_BSDF_MASK,      /* opacity blend between nested[0] and null */
    SPC_BSDF_BLENDBSDF, /* weight blend: (1-w) nested[0] + w nested[1] */
    SPC_BSDF_PRINCIPLED,    /* Mitsuba 3's Disney-style principled BSDF (principled.c) */
    SPC_BSDF_PRINCIPLEDTHIN /* its thin-sheet variant (principledthin.c) */
} spc_bsdf_type;

typedef enum spc_microfacet_type {
    SPC_MICROFACET_GGX,
    SPC_MICROFACET_BECKMANN
} spc_microfacet_type;

/*
 * Parameters of every variant (unused fields are ignored). Textures are never NULL where a variant
 * reads them: the loader supplies Mitsuba's defaults as constant textures.
 */
/* Entries of roughplastic's coating transmittance table over cos in [0, 1]: Mitsuba 3's
 * MI_ROUGH_TRANSMITTANCE_RES, so that the linear interpolation between entries matches too. */
#define SPC_ROUGHPLASTIC_TABLE_RES 64

/* principled and principledthin: Mitsuba 3's parameters, each a float texture read with
 * spc_texture_eval1 (NULL reads as Mitsuba's default). Sampling rates are the plugins' relative
 * lobe-selection weights (1 by default). */
typedef struct spc_principled_params {
    const spc_texture *base_color; /* rgb */
    const spc_texture *roughness, *anisotropic, *metallic, *spec_trans, *spec_tint, *sheen, *sheen_tint, *flatness,
        *clearcoat, *clearcoat_gloss;
    const spc_texture *diff_trans, *eta_thin; /* principledthin only */
    /* principled: rate_spec (main_specular_sampling_rate), rate_clearcoat, rate_diffuse
     * (diffuse_reflectance_sampling_rate). principledthin: rate_spec (specular_reflectance_...),
     * rate_spec_trans, rate_diffuse, rate_diff_trans (diffuse_transmittance_...). */
    double rate_spec, rate_spec_trans, rate_clearcoat, rate_diffuse, rate_diff_trans;
} spc_principled_params;

typedef struct spc_bsdf {
    spc_bsdf_type type;
    const spc_texture *reflectance;            /* diffuse, roughdiffuse; plastic/phong: diffuse part */
    const spc_texture *specular_reflectance;   /* conductors, dielectrics, plastic, phong */
    const spc_texture *specular_transmittance; /* dielectrics */
    const spc_texture *alpha_u, *alpha_v;      /* roughness (roughdiffuse: alpha_u is sigma-like alpha) */
    spc_microfacet_type distribution;
    bool sample_visible; /* visible-normal sampling (Heitz 2018); default true */
    double eta;          /* dielectrics, plastic: int_ior / ext_ior */
    spc_rgb cond_eta, cond_k; /* conductors: complex IOR relative to ext_ior; k < 0 means perfect mirror */
    double exponent;          /* phong */
    bool nonlinear;           /* plastic */
    const spc_texture *weight;  /* blendbsdf */
    const spc_texture *opacity; /* mask */
    const spc_texture *normalmap; /* normalmap: tangent-space normal, RGB in [0,1] -> [-1,1] */
    const spc_texture *bump;      /* bumpmap height */
    double bump_scale;
    const struct spc_bsdf *nested[2];
    spc_principled_params pr; /* principled, principledthin (the former's eta is b->eta) */
    /* roughplastic: the rough coating's directional transmittance at cos = i / (RES - 1) and its
     * cosine-weighted internal reflectance, as Mitsuba 3 tabulates them; filled by
     * spc_bsdf_prepare. coat_ready false (textured or anisotropic alpha, or not prepared): the
     * smooth-interface Fresnel terms stand in. */
    bool coat_ready;
    double coat_fdr_int;
    float coat_t[SPC_ROUGHPLASTIC_TABLE_RES];
} spc_bsdf;

typedef struct spc_bsdf_sample {
    spc_vec3 wi;
    spc_rgb weight; /* f |cos| / pdf */
    double pdf;     /* solid angle, or discrete probability for a delta lobe */
    unsigned lobe;  /* exactly one SPC_LOBE_* */
    double eta;     /* relative IOR of a transmission, else 1 */
} spc_bsdf_sample;

/* Precomputes what a BSDF tabulates from its parameters (roughplastic's coating terms); the
 * scene calls it for every BSDF in spc_scene_finalize. Call again after changing parameters. */
void spc_bsdf_prepare(spc_bsdf *b);

unsigned spc_bsdf_flags(const spc_bsdf *b);
/* Does evaluating or sampling b read the hit's derivatives dpdu, dpdv, dndu, dndv (a normalmap or
 * bumpmap anywhere in it)? Where not, a hit record may leave them out (scene/hit.h). */
bool spc_bsdf_reads_derivatives(const spc_bsdf *b);
/* Whether b (or a BSDF nested in it) reads a hit's uv (or its surface coordinates b1, b2): a texture
 * that is not a constant, a normal or bump map. False: uv does not change what it returns. */
bool spc_bsdf_reads_uv(const spc_bsdf *b);
static inline bool spc_bsdf_has_smooth(const spc_bsdf *b) { return (spc_bsdf_flags(b) & SPC_LOBE_SMOOTH) != 0; }
static inline bool spc_bsdf_is_delta_only(const spc_bsdf *b) { return (spc_bsdf_flags(b) & SPC_LOBE_SMOOTH) == 0; }

spc_rgb spc_bsdf_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi);
double spc_bsdf_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi);
bool spc_bsdf_sample_dir(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                         spc_vec2 u, spc_bsdf_sample *out);
/* spc_bsdf_sample_dir of n lanes at once (lane i: b[i], h[i], wo[i], u_lobe[i], u[i] into out[i],
 * ok[i]; none where b[i] is NULL), the same values: for a path tracer that runs many paths side by
 * side. Rough metals (also
 * under twosided) share one search for their Beckmann visible normals (bsdf/microfacet.h). */
void spc_bsdf_sample_dir_many(int n, const spc_bsdf *const b[], const spc_hit *const h[], spc_transport mode,
                              const spc_vec3 wo[], const double u_lobe[], const spc_vec2 u[], spc_bsdf_sample out[],
                              bool ok[]);
/* spc_bsdf_eval and, in *pdf, spc_bsdf_pdf of the same directions, bit for bit the two calls' values:
 * for next-event estimation, which needs both. Variants whose eval and pdf share terms compute them
 * once (roughconductor: D(m) and G1(wo, m); twosided: the side and its flipped hit); the others
 * make the two calls. */
spc_rgb spc_bsdf_eval_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi,
                          double *pdf);
/* Diffuse-like albedo at the hit for the albedo AOV and for light-path heuristics. */
spc_rgb spc_bsdf_albedo(const spc_bsdf *b, const spc_hit *h);
/* Mitsuba 3's null component (BSDFFlags::Null): the part of a surface that light passes straight
 * through (wi = -wo) without scattering: all of `null`, 1 - opacity of a `mask`, the transmission
 * of a `thindielectric` (1 - R'). Mitsuba's volpath does not count crossing it as a bounce and
 * lets shadow rays through it with this factor (its eval_null_transmission).
 * spc_bsdf_has_null: can the BSDF have such a part. spc_bsdf_null_transmission: its factor for a
 * ray arriving from wo (per channel; zero where there is none). spc_bsdf_sample_is_null: did this
 * sample of b take it. */
bool spc_bsdf_has_null(const spc_bsdf *b);
spc_rgb spc_bsdf_null_transmission(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo);
bool spc_bsdf_sample_is_null(const spc_bsdf *b, const spc_bsdf_sample *bs);
/* True if the BSDF behaves as a perfect specular interface (conductor or dielectric, smooth,
 * possibly under a twosided or a normalmap): the specular solvers treat such surfaces as chain
 * vertices. *eta receives int_ior/ext_ior (0 for a reflector). */
bool spc_bsdf_is_specular_interface(const spc_bsdf *b, double *eta);
/* A normal-mapped chain vertex: if h->bsdf is a normalmap (and h not yet mapped), replaces h->sh by
 * the mapped frame as the BSDF sees it from wo (toward the previous vertex), h->dndu/dndv by the
 * mapped normal's derivatives with respect to the surface parameters, keeps the old normal in
 * h->n_unmapped and sets h->normal_mapped (normalmap.c; also where the map's value leaves the
 * frame as is). True with h unchanged for other BSDFs and normalmaps without a texture; false
 * where the shape has no texture-frame derivatives (spc_shape_texture_frame). */
bool spc_bsdf_map_chain_hit(spc_hit *h, spc_vec3 wo);
/* Veach's adjoint correction for a shading normal ns against the normal ng that the measure counts
 * (1997, eq. 5.20): |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|), wo toward the light's side, wi toward the
 * camera's; 0 where it is undefined. Inline: bdpt asks it at every join. */
static inline double spc_bsdf_shading_adjoint(spc_vec3 wo, spc_vec3 wi, spc_vec3 ng, spc_vec3 ns)
{
    double den = spc_absdot(wo, ng) * spc_absdot(wi, ns);
    if (!(den > 0.0))
        return 0.0;
    return spc_absdot(wo, ns) * spc_absdot(wi, ng) / den;
}
/* Does b shade with a normal of its own (a normalmap or a bumpmap, possibly under a twosided),
 * rather than h->sh.n? Such BSDFs turn their frame with the viewer and shadow the light-side
 * direction, so their importance-mode value is not the radiance-mode one transposed. Inline:
 * bdpt asks it at every vertex of a light subpath. */
static inline bool spc_bsdf_is_map(const spc_bsdf *b)
{
    return b && (b->type == SPC_BSDF_NORMALMAP || b->type == SPC_BSDF_BUMPMAP);
}
static inline bool spc_bsdf_perturbs(const spc_bsdf *b)
{
    if (b && b->type == SPC_BSDF_TWOSIDED)
        return spc_bsdf_is_map(b->nested[0]) || spc_bsdf_is_map(b->nested[1]);
    return spc_bsdf_is_map(b);
}
/* The factor that turns a light subpath's importance-mode value at h (the weight of a sample from
 * wo, toward the light, to wi, toward the camera; or eval times |wi.sh.n|) into the adjoint of the
 * radiance-mode value the camera's paths carry. Where h->bsdf (or twosided's side for wo) is a
 * normalmap or a bumpmap, the shading normal is the map's, not h->sh.n: the radiance value is
 * f |wo.n_c| G1(wo), the importance one f |wi.n_o| G1(wi), n_c and n_o the map's normal turned as
 * the two calls see it from wi and from wo (the face-view turn, variants.h), G1 the bump shadowing,
 * so the factor is |wo.n_c| |wi.ng| G1(wo) / (|wo.ng| |wi.n_o| G1(wi)); exact for a diffuse nested
 * BSDF, and for any nested BSDF where neither direction turns the normal. Elsewhere
 * spc_bsdf_shading_adjoint with h->sh.n. 0 where undefined. */
double spc_bsdf_adjoint_factor(const spc_hit *h, spc_vec3 wo, spc_vec3 wi);
/* Is a shape with this BSDF a usable chain vertex as far as normal maps go (the shape can
 * differentiate its texture frame)? */
bool spc_bsdf_chain_mappable(const spc_bsdf *b, int shape_type);
/* The factor of a delta lobe for a direction pair the caller constructed (specular.c): wi must be
 * the exact mirror (or refracted) direction of wo about h->sh.n. Reflection F * specular_
 * reflectance, refraction (1 - F) * specular_transmittance / eta_t^2 (radiance mode), the same
 * as BSDF sampling's weight times the lobe's probability. Zero where the BSDF has no such lobe. */
spc_rgb spc_bsdf_specular_throughput(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo,
                                     spc_vec3 wi);
/* The probability with which sample() chooses the delta lobe that carries wo to wi, for the same
 * constructed direction pair (specular.c): F for a dielectric's reflection, 1 - F for its refraction,
 * 1 for a conductor; the nested BSDF's under a twosided or a normalmap. The density of a path that
 * BSDF sampling traces through specular vertices includes this factor at each of them (it is the
 * pdf of spc_bsdf_sample's record for that lobe). Zero where the BSDF has no such lobe. */
double spc_bsdf_specular_prob(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo, spc_vec3 wi);

/* Fresnel helpers shared by the variants and the specular solvers (src/bsdf/fresnel.c). */
/* Unpolarized dielectric reflectance for cos_i (signed: < 0 means wi on the inside) and
 * eta = n_inside / n_outside. *cos_t receives the signed cosine of the transmitted direction
 * (opposite sign to cos_i), *eta_ti the relative IOR n_t/n_i. Returns 1 under total internal
 * reflection. */
double spc_fresnel_dielectric(double cos_i, double eta, double *cos_t, double *eta_ti);
/* Conductor reflectance per channel for a complex IOR eta + i k. */
spc_rgb spc_fresnel_conductor(double cos_i, spc_rgb eta, spc_rgb k);
/* Refraction of w (away from surface) about n with relative IOR eta = n_inside/n_outside, given
 * cos_t from spc_fresnel_dielectric. */
spc_vec3 spc_refract(spc_vec3 w, spc_vec3 n, double cos_t, double eta_ti);

/* The BSDF type's Mitsuba plugin name ("diffuse", "roughplastic", ...), for messages. */
const char *spc_bsdf_type_name(spc_bsdf_type t);

#endif
