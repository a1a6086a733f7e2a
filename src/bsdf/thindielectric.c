/*
 * bsdf/thindielectric.c: a thin dielectric sheet (window pane, soap film) whose two parallel
 * interfaces are collapsed into one surface, as Mitsuba's thindielectric. Summing the light
 * bouncing between the two interfaces gives the total reflectance R' = R + T^2 R / (1 - R^2)
 * (T = 1 - R, R the Fresnel reflectance of one interface at the incident angle); the rest,
 * 1 - R', passes straight through (wi = -wo: the two refractions cancel), so the transmission
 * reports eta = 1 and needs no radiance scaling. Both lobes are delta and chosen with probabilities
 * R' and 1 - R'. The transmission is what Mitsuba 3 calls a null component: its volpath does not
 * count it as a bounce and lets shadow rays through with the factor 1 - R' (spc_bsdf_null_*).
 *
 * Mitsuba XML <bsdf type="thindielectric">:
 *   int_ior                  float or string       "bk7" (1.5046)
 *   ext_ior                  float or string       "air" (1.000277)   b->eta = int_ior / ext_ior
 *   specular_reflectance     spectrum or texture   1.0
 *   specular_transmittance   spectrum or texture   1.0
 */
#include "bsdf/variants.h"

/* A delta lobe: no value and no density for a given pair of directions (bsdf.h). */
spc_rgb spc_thindielectric_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return spc_rgb1(0.0);
}

double spc_thindielectric_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    return 0.0;
}

/* R' at the incident cosine |cos|: the sheet's total reflectance */
static double sheet_reflectance(const spc_bsdf *b, double cos)
{
    double R = spc_fresnel_dielectric(fabs(cos), b->eta, NULL, NULL);
    if (R < 1.0) {
        double T = 1.0 - R;
        R += T * T * R / (1.0 - R * R);
    }
    return R;
}

spc_rgb spc_thindielectric_null_transmission(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo)
{
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z == 0.0)
        return spc_rgb1(0.0);
    double t = 1.0 - sheet_reflectance(b, lo.z);
    return spc_rgb_scale(spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0)), t);
}

bool spc_thindielectric_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                               spc_vec2 u, spc_bsdf_sample *out)
{
    (void)mode;
    (void)u;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z == 0.0)
        return false;
    /* the sheet is symmetric: the entering interface is seen from outside either way */
    double R = sheet_reflectance(b, lo.z);
    if (u_lobe < R) {
        spc_bsdf_set_sample(out, spc_bsdf_to_world(h, spc_bsdf_mirror_local(lo)),
                            spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0)), R, SPC_LOBE_DELTA_REFLECTION,
                            1.0);
        return true;
    }
    spc_bsdf_set_sample(out, spc_neg(wo), spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0)), 1.0 - R,
                        SPC_LOBE_DELTA_TRANSMISSION, 1.0);
    return true;
}

spc_rgb spc_thindielectric_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_bsdf_tex(b->specular_transmittance, h, spc_rgb1(1.0));
}
