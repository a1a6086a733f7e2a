/*
 * bsdf/specular.c: the factor a smooth specular interface applies to light that follows one of
 * its delta lobes, for callers that construct the lobe's direction themselves (the specular
 * connections of src/manifold/) instead of sampling it. For a delta lobe, f |cos| integrates to
 * this factor, which is what BSDF sampling returns as the sample weight times the probability of
 * choosing the lobe:
 *   conductor               F_conductor(cos_o) specular_reflectance   (one-sided: 0 behind)
 *   dielectric, reflection  F(cos_o) specular_reflectance
 *   dielectric, refraction  (1 - F(cos_o)) specular_transmittance / eta_t^2 in radiance mode
 *                           (radiance compression, eta_t = n(wi side) / n(wo side), as
 *                           dielectric.c), no 1/eta_t^2 in importance mode
 *   twosided                the nested BSDF of wo's side, in the flipped frame on the back
 *   normalmap               the nested BSDF's in the mapped frame (mapped here unless the hit is
 *                           already), 0 if wi lies on different sides of the two frames, times
 *                           the shadowing term (spc_normalmap_specular_throughput)
 * where F is the unpolarized Fresnel reflectance of fresnel.c. Also the probability with which
 * BSDF sampling picks that lobe (spc_bsdf_specular_prob): the sampling side's density of a path
 * through the interface, for the MIS weights of specular connections.
 */
#include "bsdf/variants.h"

/* The probability with which dielectric.c's sampling picks the delta lobe that takes wo to wi,
 * given their cosines co, ci with the shading normal: reflection with F(co), refraction with
 * 1 - F(co); 0 when either direction is grazing. *eta_ti receives eta_t as fresnel.c defines it. */
static double dielectric_event_prob(const spc_bsdf *b, double co, double ci, double *eta_ti)
{
    *eta_ti = 1.0;
    if (co == 0.0 || ci == 0.0)
        return 0.0;
    double cos_t;
    double F = spc_fresnel_dielectric(co, b->eta, &cos_t, eta_ti);
    return co * ci > 0.0 ? F : 1.0 - F;
}

/* The nested BSDF of a twosided one that serves the side of wo (cosine co with the shading
 * normal), and in *side the hit in that BSDF's frame: as given in front, flipped behind. */
static const spc_bsdf *twosided_side(const spc_bsdf *b, const spc_hit *h, double co, spc_hit *side)
{
    *side = *h;
    if (co >= 0.0)
        return b->nested[0];
    side->sh.t = spc_neg(h->sh.t);
    side->sh.n = spc_neg(h->sh.n);
    side->ng = spc_neg(h->ng);
    return b->nested[1] ? b->nested[1] : b->nested[0];
}

spc_rgb spc_bsdf_specular_throughput(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo,
                                     spc_vec3 wi)
{
    if (!b)
        return spc_rgb1(0.0);
    double co = spc_dot(wo, h->sh.n), ci = spc_dot(wi, h->sh.n);
    switch (b->type) {
    case SPC_BSDF_CONDUCTOR:
        if (!(co > 0.0) || !(ci > 0.0))
            return spc_rgb1(0.0);
        return spc_rgb_mul(spc_bsdf_conductor_fresnel(b, co), spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0)));
    case SPC_BSDF_DIELECTRIC: {
        if (co == 0.0 || ci == 0.0)
            return spc_rgb1(0.0);
        double eta_ti;
        double p = dielectric_event_prob(b, co, ci, &eta_ti);
        if (co * ci > 0.0)
            return spc_rgb_scale(spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0)), p);
        if (p <= 0.0)
            return spc_rgb1(0.0); /* total internal reflection: nothing is transmitted */
        spc_rgb T = spc_rgb_scale(spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0)), p);
        if (mode == SPC_MODE_RADIANCE)
            T = spc_rgb_scale(T, 1.0 / (eta_ti * eta_ti));
        return T;
    }
    case SPC_BSDF_NORMALMAP:
        return spc_normalmap_specular_throughput(b, h, mode, wo, wi);
    case SPC_BSDF_TWOSIDED: {
        spc_hit side;
        const spc_bsdf *nested = twosided_side(b, h, co, &side);
        return spc_bsdf_specular_throughput(nested, &side, mode, wo, wi);
    }
    case SPC_BSDF_DIFFUSE:
    case SPC_BSDF_ROUGHDIFFUSE:
    case SPC_BSDF_PHONG:
    case SPC_BSDF_ROUGHCONDUCTOR:
    case SPC_BSDF_THINDIELECTRIC:
    case SPC_BSDF_ROUGHDIELECTRIC:
    case SPC_BSDF_PLASTIC:
    case SPC_BSDF_ROUGHPLASTIC:
    case SPC_BSDF_PPLASTIC:
    case SPC_BSDF_PRINCIPLED:
    case SPC_BSDF_PRINCIPLEDTHIN:
    case SPC_BSDF_BUMPMAP:
    case SPC_BSDF_NULL:
    case SPC_BSDF_MASK:
    case SPC_BSDF_BLENDBSDF:
        return spc_rgb1(0.0);
    }
    return spc_rgb1(0.0);
}

double spc_bsdf_specular_prob(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo, spc_vec3 wi)
{
    if (!b)
        return 0.0;
    double co = spc_dot(wo, h->sh.n), ci = spc_dot(wi, h->sh.n);
    switch (b->type) {
    case SPC_BSDF_CONDUCTOR:
        return co > 0.0 && ci > 0.0 ? 1.0 : 0.0;
    case SPC_BSDF_DIELECTRIC: {
        double eta_ti;
        return dielectric_event_prob(b, co, ci, &eta_ti);
    }
    case SPC_BSDF_NORMALMAP:
        return spc_normalmap_specular_prob(b, h, wo, wi);
    case SPC_BSDF_TWOSIDED: {
        spc_hit side;
        const spc_bsdf *nested = twosided_side(b, h, co, &side);
        return spc_bsdf_specular_prob(nested, &side, wo, wi);
    }
    case SPC_BSDF_DIFFUSE:
    case SPC_BSDF_ROUGHDIFFUSE:
    case SPC_BSDF_PHONG:
    case SPC_BSDF_ROUGHCONDUCTOR:
    case SPC_BSDF_THINDIELECTRIC:
    case SPC_BSDF_ROUGHDIELECTRIC:
    case SPC_BSDF_PLASTIC:
    case SPC_BSDF_ROUGHPLASTIC:
    case SPC_BSDF_PPLASTIC:
    case SPC_BSDF_PRINCIPLED:
    case SPC_BSDF_PRINCIPLEDTHIN:
    case SPC_BSDF_BUMPMAP:
    case SPC_BSDF_NULL:
    case SPC_BSDF_MASK:
    case SPC_BSDF_BLENDBSDF:
        return 0.0;
    }
    return 0.0;
}
