/*
 * bsdf/principled.h: the pieces principled.c and principledthin.c share, after Mitsuba 3's
 * definitions (its principledhelpers.h) of Burley's 2012 Disney BRDF ("Physically Based Shading at
 * Disney", SIGGRAPH course notes, sec. 5: the Schlick weight (1 - cos)^5, the diffuse with retro-
 * reflection, the Hanrahan-Krueger "flatness", the sheen; the roughness-to-alpha mapping
 * alpha = roughness^2 and the anisotropic aspect sqrt(1 - 0.9 anisotropic), Addendum sec. B.2).
 * Private to src/bsdf/. Every vector is in the local shading frame (z the normal).
 */
#ifndef SPC_BSDF_PRINCIPLED_H
#define SPC_BSDF_PRINCIPLED_H

#include "bsdf/microfacet.h"
#include "bsdf/variants.h"

/* Mitsuba's smallest alpha for the principled lobes (calc_dist_params). */
#define SPC_PRINCIPLED_MIN_ALPHA 0.001

/* (1 - c)^5 with c clamped to [0, 1]. */
static inline double spc_principled_schlick_weight(double c)
{
    double m = spc_clamp(1.0 - c, 0.0, 1.0), m2 = m * m;
    return m2 * m2 * m;
}

/* Normal-incidence reflectance of an interface of relative IOR eta. */
static inline double spc_principled_r0(double eta)
{
    double r = (eta - 1.0) / (eta + 1.0);
    return r * r;
}

/* Luminance of a linear sRGB colour, as Mitsuba's RGB variants weigh it. */
static inline double spc_principled_luminance(spc_rgb c) { return 0.212671 * c.r + 0.715160 * c.g + 0.072169 * c.b; }

/* base_color normalized by its luminance (white when the luminance is not positive): the tint. */
static inline spc_rgb spc_principled_tint(spc_rgb base)
{
    double lum = spc_principled_luminance(base);
    return lum > 0.0 ? spc_rgb_scale(base, 1.0 / lum) : spc_rgb1(1.0);
}

/* Schlick's Fresnel R0 + (1 - R0) (1 - cos)^5 for the microfacet cosine cos_i (negative: arriving
 * from inside) and the interface eta (inside over outside); where light arrives from the denser
 * side the transmitted cosine replaces cos_i (zero under total internal reflection), as Mitsuba's
 * calc_schlick. */
double spc_principled_schlick(double r0, double cos_i, double eta);

/* The GGX distribution of a lobe: alpha = max(0.001, roughness^2), stretched by the anisotropy's
 * aspect a = sqrt(1 - 0.9 anisotropic) into alpha / a along the tangent and alpha a along the
 * bitangent; visible-normal sampling. */
spc_microfacet spc_principled_ggx(double roughness, double anisotropic);

/* Burley's diffuse with retro-reflection, blended toward the Hanrahan-Krueger fake subsurface by
 * `flatness`, WITHOUT base_color / pi: the factor of (base / pi) for the cosines ci, co (absolute
 * values are taken), the roughness and cos_d = wh . wi. */
double spc_principled_diffuse(double ci, double co, double cos_d, double roughness, double flatness);

/* The sheen's colour factor: sheen (1 - cos_d)^5 lerp(1, tint, sheen_tint). */
spc_rgb spc_principled_sheen(spc_rgb base, double sheen, double sheen_tint, double cos_d);

#endif
