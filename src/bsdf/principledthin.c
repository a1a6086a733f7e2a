/*
 * bsdf/principledthin.c: Mitsuba 3's principledthin, the Disney BSDF's thin-surface mode (Burley
 * 2015, "Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering", sec. 4 thin
 * surfaces), term for term as Mitsuba 3.9 defines it. Both sides behave alike: directions are
 * mirrored to the side of wi (Mitsuba's wi; specula's wo, named lo below) first. A transmission
 * is a reflection off the sheet's microfacets mirrored through the surface (wo_r: wo with |z|),
 * so one half vector wh = normalize(wi + wo_r) serves every lobe:
 *
 *   f = spec_trans F_thin D G / (4 cos_i cos_o)                       reflection, alpha(roughness)
 *     + spec_trans base (1 - F) D' G' / (4 cos_i |cos_o|)             transmission, alpha of the
 *                                         roughness scaled by (0.65 eta - 0.35) (Burley 2015 eq. 3)
 *     + (1 - spec_trans)(1 - dt) [base/pi lerp(f_diff + f_retro, f_ss, flatness) + sheen]  (reflection)
 *     + (1 - spec_trans) dt base / pi                                  diffuse transmission
 *
 * dt = diff_trans / 2 (the parameter runs over 0..2), F the dielectric Fresnel of eta at wh,
 * F_thin = lerp(F, Schlick(tint R0(eta)), spec_tint). As in Mitsuba, without spec_trans there is no
 * specular reflection at all, and the (microfacet) transmission counts only where wh lies on the
 * far side of -wo (its mac_mic_compatibility): the sheet's masking, kept for agreement.
 *
 * Sampling: specular reflection, specular transmission, diffuse reflection, diffuse transmission
 * in proportion to spec_trans rate_spec / 2 : spec_trans rate_spec_trans / 2 :
 * (1 - spec_trans)(1 - dt) rate_diffuse : (1 - spec_trans) dt rate_diff_trans; GGX visible normals
 * for the first two, cosine-weighted for the others.
 *
 * Mitsuba XML <bsdf type="principledthin"> (float or texture unless said):
 *   base_color 0.5 (rgb or texture), roughness 0.5, anisotropic 0, spec_trans 0, eta 1.5,
 *   spec_tint 0, sheen 0, sheen_tint 0, flatness 0, diff_trans 0 (0..2),
 *   specular_reflectance_sampling_rate 1, specular_transmittance_sampling_rate 1,
 *   diffuse_reflectance_sampling_rate 1, diffuse_transmittance_sampling_rate 1.
 */
#include "bsdf/principled.h"

typedef struct params {
    spc_rgb base;
    double roughness, anisotropic, spec_trans, eta, dt;
} params;

static params read_params(const spc_bsdf *b, const spc_hit *h)
{
    const spc_principled_params *p = &b->pr;
    params q;
    q.base = spc_bsdf_tex(p->base_color, h, spc_rgb1(0.5));
    q.roughness = spc_bsdf_tex1(p->roughness, h, 0.5);
    q.anisotropic = spc_bsdf_tex1(p->anisotropic, h, 0.0);
    q.spec_trans = spc_bsdf_tex1(p->spec_trans, h, 0.0);
    q.eta = spc_bsdf_tex1(p->eta_thin, h, 1.5);
    q.dt = 0.5 * spc_bsdf_tex1(p->diff_trans, h, 0.0);
    return q;
}

/* The transmission lobe's distribution: the roughness scaled by the sheet's IOR. */
static spc_microfacet trans_ggx(const params *q)
{
    return spc_principled_ggx((0.65 * q->eta - 0.35) * q->roughness, q->anisotropic);
}

/* Mitsuba's mac_mic_compatibility for wi above the surface. */
static bool compatible(spc_vec3 m, spc_vec3 wi, spc_vec3 wo, bool reflect)
{
    double c = spc_dot(wo, m);
    return spc_dot(wi, m) > 0.0 && (reflect ? c > 0.0 : c < 0.0);
}

/* wi (z > 0) and wo moved to wi's side; wh from wo mirrored up. */
static spc_vec3 thin_half(spc_vec3 wi, spc_vec3 wo)
{
    return spc_normalize(spc_add(wi, spc_v3(wo.x, wo.y, fabs(wo.z))));
}

/* Lobe probabilities: specular reflection, specular transmission, diffuse reflection, diffuse
 * transmission; false when all are zero. */
static bool lobe_probs(const spc_bsdf *b, const params *q, double p[4])
{
    const spc_principled_params *r = &b->pr;
    p[0] = spc_max(0.0, q->spec_trans * r->rate_spec * 0.5);
    p[1] = spc_max(0.0, q->spec_trans * r->rate_spec_trans * 0.5);
    p[2] = spc_max(0.0, r->rate_diffuse * (1.0 - q->spec_trans) * (1.0 - q->dt));
    p[3] = spc_max(0.0, r->rate_diff_trans * (1.0 - q->spec_trans) * q->dt);
    double tot = p[0] + p[1] + p[2] + p[3];
    if (!(tot > 0.0))
        return false;
    for (int k = 0; k < 4; ++k)
        p[k] /= tot;
    return true;
}

/* f |cos_o| for wi above the surface (Mitsuba's eval). */
static spc_rgb thin_f_cos(const spc_bsdf *b, const spc_hit *h, const params *q, spc_vec3 wi, spc_vec3 wo)
{
    double ci = wi.z, co = wo.z;
    spc_rgb v = spc_rgb1(0.0);
    if (!(ci > 0.0) || co == 0.0)
        return v;
    bool reflect = co > 0.0;
    spc_vec3 wh = thin_half(wi, wo);
    double st = q->spec_trans;
    if (st > 0.0 && compatible(wh, wi, wo, reflect)) {
        double F = spc_fresnel_dielectric(spc_dot(wi, wh), q->eta, NULL, NULL);
        if (reflect) {
            spc_microfacet md = spc_principled_ggx(q->roughness, q->anisotropic);
            double spec_tint = spc_bsdf_tex1(b->pr.spec_tint, h, 0.0);
            spc_rgb tint = spc_principled_tint(q->base), Ft;
            double dih = spc_dot(wi, wh), r0 = spc_principled_r0(q->eta);
            Ft.r = (1.0 - spec_tint) * F + spec_tint * spc_principled_schlick(tint.r * r0, dih, q->eta);
            Ft.g = (1.0 - spec_tint) * F + spec_tint * spc_principled_schlick(tint.g * r0, dih, q->eta);
            Ft.b = (1.0 - spec_tint) * F + spec_tint * spc_principled_schlick(tint.b * r0, dih, q->eta);
            double DG = spc_microfacet_d(&md, wh) * spc_microfacet_g(&md, wi, wo, wh);
            v = spc_rgb_add(v, spc_rgb_scale(Ft, st * DG / (4.0 * ci)));
        } else {
            spc_microfacet md = trans_ggx(q);
            double DG = spc_microfacet_d(&md, wh) * spc_microfacet_g(&md, wi, wo, wh);
            v = spc_rgb_add(v, spc_rgb_scale(q->base, st * (1.0 - F) * DG / (4.0 * ci)));
        }
    }
    if (reflect && st < 1.0 && q->dt < 1.0) {
        double cos_d = spc_dot(wh, wo), flatness = spc_bsdf_tex1(b->pr.flatness, h, 0.0);
        double fd = spc_principled_diffuse(ci, co, cos_d, q->roughness, flatness);
        double w = (1.0 - st) * (1.0 - q->dt);
        v = spc_rgb_add(v, spc_rgb_scale(q->base, w * co * SPC_INV_PI * fd));
        double sheen = spc_bsdf_tex1(b->pr.sheen, h, 0.0);
        if (sheen > 0.0) {
            spc_rgb s = spc_principled_sheen(q->base, sheen, spc_bsdf_tex1(b->pr.sheen_tint, h, 0.0), cos_d);
            v = spc_rgb_add(v, spc_rgb_scale(s, w * co));
        }
    }
    if (!reflect && st < 1.0 && q->dt > 0.0)
        v = spc_rgb_add(v, spc_rgb_scale(q->base, (1.0 - st) * q->dt * SPC_INV_PI * fabs(co)));
    return v;
}

static double thin_pdf(const params *q, const double p[4], spc_vec3 wi, spc_vec3 wo)
{
    double co = wo.z;
    if (!(wi.z > 0.0) || co == 0.0)
        return 0.0;
    bool reflect = co > 0.0;
    spc_vec3 wh = thin_half(wi, wo);
    double pdf = 0.0;
    if (compatible(wh, wi, wo, reflect)) {
        double dwh_dwo = 1.0 / (4.0 * fabs(spc_dot(spc_v3(wo.x, wo.y, fabs(wo.z)), wh)));
        if (reflect && p[0] > 0.0) {
            spc_microfacet md = spc_principled_ggx(q->roughness, q->anisotropic);
            pdf += p[0] * spc_microfacet_pdf(&md, wi, wh) * dwh_dwo;
        }
        if (!reflect && p[1] > 0.0) {
            spc_microfacet md = trans_ggx(q);
            pdf += p[1] * spc_microfacet_pdf(&md, wi, wh) * dwh_dwo;
        }
    }
    pdf += (reflect ? p[2] : p[3]) * fabs(co) * SPC_INV_PI;
    return pdf;
}

/* The local directions moved to the side of wo (specula's; Mitsuba's wi): false for grazing. */
static bool to_upper(const spc_hit *h, spc_vec3 wo, spc_vec3 wi, spc_vec3 *lo, spc_vec3 *li)
{
    *lo = spc_bsdf_to_local(h, wo);
    *li = spc_bsdf_to_local(h, wi);
    if (lo->z == 0.0)
        return false;
    if (lo->z < 0.0) {
        *lo = spc_neg(*lo);
        *li = spc_neg(*li);
    }
    return true;
}

spc_rgb spc_principledthin_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo, li;
    if (!to_upper(h, wo, wi, &lo, &li) || li.z == 0.0)
        return spc_rgb1(0.0);
    params q = read_params(b, h);
    return spc_rgb_scale(thin_f_cos(b, h, &q, lo, li), 1.0 / fabs(li.z));
}

double spc_principledthin_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo, li;
    if (!to_upper(h, wo, wi, &lo, &li))
        return 0.0;
    params q = read_params(b, h);
    double p[4];
    if (!lobe_probs(b, &q, p))
        return 0.0;
    return thin_pdf(&q, p, lo, li);
}

bool spc_principledthin_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                               spc_vec2 u, spc_bsdf_sample *out)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z == 0.0)
        return false;
    double side = lo.z > 0.0 ? 1.0 : -1.0;
    lo = spc_scale(lo, side);
    params q = read_params(b, h);
    double p[4];
    if (!lobe_probs(b, &q, p))
        return false;
    spc_vec3 li;
    unsigned lobe;
    if (u_lobe < p[0] + p[1]) {
        bool refl = u_lobe < p[0];
        spc_microfacet md = refl ? spc_principled_ggx(q.roughness, q.anisotropic) : trans_ggx(&q);
        double pdf_m;
        spc_vec3 m = spc_microfacet_sample(&md, lo, u, &pdf_m);
        if (!(pdf_m > 0.0))
            return false;
        li = spc_reflect(lo, m);
        if (!refl)
            li.z = -li.z;
        if (refl ? !(li.z > 0.0) : !(li.z < 0.0))
            return false;
        if (!compatible(m, lo, li, refl))
            return false;
        lobe = refl ? SPC_LOBE_GLOSSY_REFLECTION : SPC_LOBE_GLOSSY_TRANSMISSION;
    } else if (u_lobe < p[0] + p[1] + p[2]) {
        li = spc_warp_cosine_hemisphere(u);
        lobe = SPC_LOBE_DIFFUSE_REFLECTION;
    } else {
        li = spc_neg(spc_warp_cosine_hemisphere(u));
        lobe = SPC_LOBE_DIFFUSE_TRANSMISSION;
    }
    if (li.z == 0.0)
        return false;
    double pdf = thin_pdf(&q, p, lo, li);
    if (!(pdf > 0.0))
        return false;
    spc_rgb fc = thin_f_cos(b, h, &q, lo, li);
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, spc_scale(li, side)), spc_rgb_scale(fc, 1.0 / pdf), pdf, lobe, 1.0);
    return true;
}

spc_rgb spc_principledthin_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_bsdf_tex(b->pr.base_color, h, spc_rgb1(0.5));
}
