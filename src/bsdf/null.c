/*
 * bsdf/null.c: an invisible surface (Mitsuba's null BSDF): light passes straight through
 * (wi = -wo) with weight 1 (or specular_transmittance where the loader sets one: Mitsuba's
 * polarizer as its RGB variants render it, half the light); the only lobe is SPC_LOBE_NULL,
 * chosen with probability 1. eval and pdf are zero (there is no smooth part).
 *
 * Mitsuba XML <bsdf type="null">: no parameters. <bsdf type="polarizer">: transmittance 1
 * (constant), theta and polarizing read and unused.
 */
#include "bsdf/variants.h"

/* A delta lobe: no value and no density for a given pair of directions (bsdf.h). */
spc_rgb spc_null_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return spc_rgb1(0.0);
}

double spc_null_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return 0.0;
}

bool spc_null_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe, spc_vec2 u,
                     spc_bsdf_sample *out)
{
    (void)mode;
    (void)u_lobe;
    (void)u;
    spc_bsdf_set_sample(out, spc_neg(wo), spc_null_null_transmission(b, h), 1.0, SPC_LOBE_NULL, 1.0);
    return true;
}

spc_rgb spc_null_null_transmission(const spc_bsdf *b, const spc_hit *h)
{
    return b->specular_transmittance ? spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0)) : spc_rgb1(1.0);
}

spc_rgb spc_null_albedo(const spc_bsdf *b, const spc_hit *h)
{
    (void)b;
    (void)h;
    return spc_rgb1(0.0);
}
