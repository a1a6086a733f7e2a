/*
 * bsdf/principled.c: Mitsuba 3's principled BSDF, its reading of Burley's Disney BRDF (Burley 2012,
 * "Physically Based Shading at Disney", and the 2015 notes "Extending the Disney BRDF to a BSDF
 * with Integrated Subsurface Scattering" for the transmission), term for term as Mitsuba 3.9
 * defines it so that scenes render the same:
 *
 *   f = brdf base/pi [lerp(f_diff + f_retro, f_ss, flatness)]                  (front side only)
 *     + sheen (1 - metallic) (1 - cos_d)^5 lerp(1, tint, sheen_tint)             (front side only)
 *     + F_p D G / (4 |cos_i cos_o|)                         main GGX reflection, both sides
 *     + sqrt(base) bsdf (1 - F) D G eta'^2 |wi.h wo.h| / (|cos_i cos_o| (wi.h + eta' wo.h)^2)
 *                                                            GGX refraction (Walter et al. eq. 21)
 *     + 0.25 clearcoat F_cc D_cc G_cc                        GTR1 clearcoat (front side only)
 *
 * with brdf = (1 - metallic)(1 - spec_trans), bsdf = (1 - metallic) spec_trans, cos_d = wh . wi,
 * F the dielectric Fresnel of eta at the microfacet, and on the front side
 * F_p = (1 - metallic)(1 - spec_tint) F + metallic Schlick(base) + (1 - metallic) spec_tint
 * Schlick(tint R0(eta)); from inside F_p = bsdf F. The clearcoat (Burley sec. B.2) has GTR1 with
 * alpha = lerp(0.1, 0.001, clearcoat_gloss), Schlick's Fresnel with R0 0.04 and separable Smith
 * GGX masking with alpha 0.25; Mitsuba's clearcoat term has no 1 / (4 cos_i cos_o), kept. A
 * refraction in radiance mode is divided by eta'^2 (bsdf.h). (Here wi, wo are Mitsuba's: wi toward
 * the previous vertex, which is specula's wo; the code names them lo and li.)
 *
 * Sampling (Mitsuba's lobe probabilities): on the front side diffuse (cosine-weighted), clearcoat
 * (GTR1 normals, D cos) and the main GGX lobe (visible normals) in proportion to
 * brdf rate_diffuse : 0.25 clearcoat rate_clearcoat : rate_spec; a main-lobe microfacet m then
 * reflects with probability 1 - bsdf (1 - F(m)) and refracts otherwise. From inside only the main
 * lobe, reflecting with probability F(m). pdf() is exactly the density of that procedure, so a
 * sample's weight is eval cos / pdf.
 *
 * Mitsuba XML <bsdf type="principled"> (every parameter but eta/specular a float or texture):
 *   base_color 0.5 (rgb or texture), roughness 0.5, anisotropic 0, metallic 0, spec_trans 0,
 *   eta (float) or specular 0.5 (eta = 2 / (1 - sqrt(0.08 specular)) - 1; not both), spec_tint 0,
 *   sheen 0, sheen_tint 0, flatness 0, clearcoat 0, clearcoat_gloss 0,
 *   main_specular_sampling_rate 1, clearcoat_sampling_rate 1, diffuse_reflectance_sampling_rate 1.
 *   With spec_trans given, eta 1 reads 1.001 and specular 0 reads 0.001 (as Mitsuba).
 */
#include "bsdf/principled.h"

double spc_principled_schlick(double r0, double cos_i, double eta)
{
    double eta_it = cos_i >= 0.0 ? eta : 1.0 / eta, eta_ti = 1.0 / eta_it;
    double c = fabs(cos_i);
    if (!(eta_it > 1.0))
        c = spc_safe_sqrt(1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti);
    return r0 + (1.0 - r0) * spc_principled_schlick_weight(c);
}

spc_microfacet spc_principled_ggx(double roughness, double anisotropic)
{
    double r2 = roughness * roughness, aspect = sqrt(spc_max(0.0, 1.0 - 0.9 * anisotropic));
    double au = aspect > 0.0 ? r2 / aspect : r2, av = r2 * aspect;
    return spc_microfacet_make(SPC_MICROFACET_GGX, spc_max(SPC_PRINCIPLED_MIN_ALPHA, au),
                               spc_max(SPC_PRINCIPLED_MIN_ALPHA, av), true);
}

double spc_principled_diffuse(double ci, double co, double cos_d, double roughness, double flatness)
{
    ci = fabs(ci);
    co = fabs(co);
    double Fo = spc_principled_schlick_weight(co), Fi = spc_principled_schlick_weight(ci);
    double f_diff = (1.0 - 0.5 * Fi) * (1.0 - 0.5 * Fo);
    double Rr = 2.0 * roughness * cos_d * cos_d;
    double f_retro = Rr * (Fo + Fi + Fo * Fi * (Rr - 1.0));
    double f = f_diff + f_retro;
    if (flatness != 0.0) {
        double Fss90 = 0.5 * Rr;
        double Fss = (1.0 + Fo * (Fss90 - 1.0)) * (1.0 + Fi * (Fss90 - 1.0));
        double f_ss = 1.25 * (Fss * (1.0 / (co + ci) - 0.5) + 0.5);
        f = (1.0 - flatness) * f + flatness * f_ss;
    }
    return f;
}

spc_rgb spc_principled_sheen(spc_rgb base, double sheen, double sheen_tint, double cos_d)
{
    spc_rgb tint = spc_principled_tint(base);
    spc_rgb c = spc_rgb_add(spc_rgb1(1.0 - sheen_tint), spc_rgb_scale(tint, sheen_tint));
    return spc_rgb_scale(c, sheen * spc_principled_schlick_weight(fabs(cos_d)));
}

/* The parameters at a hit. */
typedef struct params {
    spc_rgb base;
    double roughness, anisotropic, metallic, spec_trans, clearcoat;
    double brdf, bsdf; /* weights of the diffuse base and of the transmitting dielectric */
} params;

static params read_params(const spc_bsdf *b, const spc_hit *h)
{
    const spc_principled_params *p = &b->pr;
    params q;
    q.base = spc_bsdf_tex(p->base_color, h, spc_rgb1(0.5));
    q.roughness = spc_bsdf_tex1(p->roughness, h, 0.5);
    q.anisotropic = spc_bsdf_tex1(p->anisotropic, h, 0.0);
    q.metallic = spc_bsdf_tex1(p->metallic, h, 0.0);
    q.spec_trans = spc_bsdf_tex1(p->spec_trans, h, 0.0);
    q.clearcoat = spc_bsdf_tex1(p->clearcoat, h, 0.0);
    q.brdf = (1.0 - q.metallic) * (1.0 - q.spec_trans);
    q.bsdf = (1.0 - q.metallic) * q.spec_trans;
    return q;
}

static double clearcoat_alpha(const spc_bsdf *b, const spc_hit *h)
{
    double g = spc_bsdf_tex1(b->pr.clearcoat_gloss, h, 0.0);
    return 0.1 + g * (0.001 - 0.1);
}

/* GTR1 (Burley 2012, eq. 4, normalized): D(m) = (a^2 - 1) / (pi ln(a^2) (1 + (a^2 - 1) cos^2)). */
static double gtr1_d(double a, spc_vec3 m)
{
    double a2 = a * a, c2 = m.z * m.z;
    double d = (a2 - 1.0) / (SPC_PI * log(a2) * (1.0 + (a2 - 1.0) * c2));
    return d * m.z > 1e-20 ? d : 0.0;
}

/* A GTR1 normal with density D(m) m.z. */
static spc_vec3 gtr1_sample(double a, spc_vec2 u)
{
    double a2 = a * a, phi = 2.0 * SPC_PI * u.x;
    double c2 = (1.0 - pow(a2, 1.0 - u.y)) / (1.0 - a2);
    double s = sqrt(spc_max(0.0, 1.0 - c2)), c = sqrt(spc_max(0.0, c2));
    return spc_v3(cos(phi) * s, sin(phi) * s, c);
}

/* Smith's G1 for isotropic GGX of alpha a, zero for the back of m. */
static double smith_ggx1(spc_vec3 v, spc_vec3 m, double a)
{
    if (spc_dot(v, m) * v.z <= 0.0)
        return 0.0;
    double c2 = v.z * v.z;
    if (c2 >= 1.0)
        return 1.0;
    double t2 = (1.0 - c2) / c2;
    return 2.0 / (1.0 + sqrt(1.0 + a * a * t2));
}

/* Does m face both directions the way a reflection (or, with reflect false, a refraction) from
 * the side of cos_i needs (Mitsuba's mac_mic_compatibility)? */
static bool compatible(spc_vec3 m, spc_vec3 lo, spc_vec3 li, double cos_i, bool reflect)
{
    spc_vec3 ms = cos_i >= 0.0 ? m : spc_neg(m);
    double a = spc_dot(lo, ms), c = spc_dot(li, ms);
    return a > 0.0 && (reflect ? c > 0.0 : c < 0.0);
}

/* The half vector of (lo, li), on the side of +z; for a refraction the generalized one. */
static spc_vec3 half_vector(spc_vec3 lo, spc_vec3 li, double eta_path, bool reflect)
{
    spc_vec3 wh = spc_normalize(spc_add(lo, spc_scale(li, reflect ? 1.0 : eta_path)));
    return wh.z < 0.0 ? spc_neg(wh) : wh;
}

/* f cos_o (Mitsuba's eval). */
static spc_rgb principled_f_cos(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 lo, spc_vec3 li)
{
    double ci = lo.z, co = li.z;
    if (ci == 0.0 || co == 0.0)
        return spc_rgb1(0.0);
    params q = read_params(b, h);
    bool reflect = ci * co > 0.0, front = ci > 0.0;
    double eta = b->eta, eta_path = front ? eta : 1.0 / eta;
    spc_vec3 wh = half_vector(lo, li, eta_path, reflect);
    double dih = spc_dot(lo, wh), doh = spc_dot(li, wh);
    double F = spc_fresnel_dielectric(dih, eta, NULL, NULL);
    spc_microfacet md = spc_principled_ggx(q.roughness, q.anisotropic);
    double D = spc_microfacet_d(&md, wh), G = spc_microfacet_g(&md, lo, li, wh);
    spc_rgb v = spc_rgb1(0.0);
    bool compat = compatible(wh, lo, li, ci, reflect);
    if (reflect && compat && F > 0.0 && D > 0.0) {
        spc_rgb Fp;
        if (front) {
            double spec_tint = spc_bsdf_tex1(b->pr.spec_tint, h, 0.0);
            double eta_it = dih >= 0.0 ? eta : 1.0 / eta;
            spc_rgb tint = spc_principled_tint(q.base), fs;
            fs.r =
                q.metallic * spc_principled_schlick(q.base.r, dih, eta) +
                (1.0 - q.metallic) * spec_tint * spc_principled_schlick(tint.r * spc_principled_r0(eta_it), dih, eta);
            fs.g =
                q.metallic * spc_principled_schlick(q.base.g, dih, eta) +
                (1.0 - q.metallic) * spec_tint * spc_principled_schlick(tint.g * spc_principled_r0(eta_it), dih, eta);
            fs.b =
                q.metallic * spc_principled_schlick(q.base.b, dih, eta) +
                (1.0 - q.metallic) * spec_tint * spc_principled_schlick(tint.b * spc_principled_r0(eta_it), dih, eta);
            Fp = spc_rgb_add(spc_rgb1((1.0 - q.metallic) * (1.0 - spec_tint) * F), fs);
        } else {
            Fp = spc_rgb1(q.bsdf * F);
        }
        v = spc_rgb_add(v, spc_rgb_scale(Fp, D * G / (4.0 * fabs(ci))));
    }
    if (!reflect && q.bsdf > 0.0 && compat && F < 1.0 && D > 0.0) {
        double scale = mode == SPC_MODE_RADIANCE ? 1.0 / (eta_path * eta_path) : 1.0;
        double den = dih + eta_path * doh;
        double t = fabs(scale * (1.0 - F) * D * G * eta_path * eta_path * dih * doh / (ci * den * den));
        spc_rgb sq = spc_rgb3(sqrt(spc_max(0.0, q.base.r)), sqrt(spc_max(0.0, q.base.g)), sqrt(spc_max(0.0, q.base.b)));
        v = spc_rgb_add(v, spc_rgb_scale(sq, q.bsdf * t));
    }
    if (reflect && front && q.clearcoat > 0.0 && compat) {
        double Fcc = spc_principled_schlick(0.04, dih, eta);
        double Dcc = gtr1_d(clearcoat_alpha(b, h), wh);
        double Gcc = smith_ggx1(lo, wh, 0.25) * smith_ggx1(li, wh, 0.25);
        v = spc_rgb_add(v, spc_rgb1(q.clearcoat * 0.25 * Fcc * Dcc * Gcc * fabs(co)));
    }
    if (reflect && front && q.brdf > 0.0) {
        double flatness = spc_bsdf_tex1(b->pr.flatness, h, 0.0);
        double fd = spc_principled_diffuse(ci, co, doh, q.roughness, flatness);
        v = spc_rgb_add(v, spc_rgb_scale(q.base, q.brdf * fabs(co) * SPC_INV_PI * fd));
        double sheen = spc_bsdf_tex1(b->pr.sheen, h, 0.0);
        if (sheen > 0.0 && q.metallic < 1.0) {
            double sheen_tint = spc_bsdf_tex1(b->pr.sheen_tint, h, 0.0);
            spc_rgb s = spc_principled_sheen(q.base, sheen, sheen_tint, doh);
            v = spc_rgb_add(v, spc_rgb_scale(s, (1.0 - q.metallic) * fabs(co)));
        }
    }
    return v;
}

/* Probabilities of the diffuse, clearcoat and main lobes (summing to 1); false when nothing can be
 * sampled from this side. */
static bool lobe_probs(const spc_bsdf *b, const params *q, bool front, double *p_diff, double *p_cc, double *p_main)
{
    if (!front) {
        *p_diff = *p_cc = 0.0;
        *p_main = 1.0;
        return q->bsdf > 0.0;
    }
    double d = spc_max(0.0, q->brdf * b->pr.rate_diffuse), c = spc_max(0.0, 0.25 * q->clearcoat * b->pr.rate_clearcoat),
           s = spc_max(0.0, b->pr.rate_spec), tot = d + c + s;
    if (!(tot > 0.0))
        return false;
    *p_diff = d / tot;
    *p_cc = c / tot;
    *p_main = s / tot;
    return true;
}

static double principled_pdf_local(const spc_bsdf *b, const spc_hit *h, spc_vec3 lo, spc_vec3 li)
{
    double ci = lo.z, co = li.z;
    if (ci == 0.0 || co == 0.0)
        return 0.0;
    params q = read_params(b, h);
    bool reflect = ci * co > 0.0, front = ci > 0.0;
    double p_diff, p_cc, p_main;
    if (!lobe_probs(b, &q, front, &p_diff, &p_cc, &p_main))
        return 0.0;
    double eta = b->eta, eta_path = front ? eta : 1.0 / eta;
    spc_vec3 wh = half_vector(lo, li, eta_path, reflect);
    double dih = spc_dot(lo, wh), doh = spc_dot(li, wh);
    double F = spc_fresnel_dielectric(dih, eta, NULL, NULL);
    double p_refl = front ? 1.0 - q.bsdf * (1.0 - F) : F;
    double dwh_dwo;
    if (reflect)
        dwh_dwo = 1.0 / (4.0 * fabs(doh));
    else {
        double den = dih + eta_path * doh;
        dwh_dwo = fabs(eta_path * eta_path * doh / (den * den));
    }
    bool compat = compatible(wh, lo, li, ci, reflect);
    double pdf = 0.0;
    if (compat) {
        spc_microfacet md = spc_principled_ggx(q.roughness, q.anisotropic);
        double pm = spc_microfacet_pdf(&md, lo, wh);
        pdf += p_main * (reflect ? p_refl : 1.0 - p_refl) * pm * dwh_dwo;
        if (reflect && p_cc > 0.0)
            pdf += p_cc * wh.z * gtr1_d(clearcoat_alpha(b, h), wh) * dwh_dwo;
    }
    if (reflect && front)
        pdf += p_diff * co * SPC_INV_PI;
    return pdf;
}

spc_rgb spc_principled_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (li.z == 0.0)
        return spc_rgb1(0.0);
    return spc_rgb_scale(principled_f_cos(b, h, mode, lo, li), 1.0 / fabs(li.z));
}

double spc_principled_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    return principled_pdf_local(b, h, spc_bsdf_to_local(h, wo), spc_bsdf_to_local(h, wi));
}

bool spc_principled_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                           spc_vec2 u, spc_bsdf_sample *out)
{
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    double ci = lo.z;
    if (ci == 0.0)
        return false;
    params q = read_params(b, h);
    bool front = ci > 0.0;
    double p_diff, p_cc, p_main;
    if (!lobe_probs(b, &q, front, &p_diff, &p_cc, &p_main))
        return false;
    spc_vec3 li;
    unsigned lobe;
    double eta_s = 1.0;
    if (u_lobe < p_diff) {
        li = spc_warp_cosine_hemisphere(u);
        lobe = SPC_LOBE_DIFFUSE_REFLECTION;
    } else if (u_lobe < p_diff + p_cc) {
        spc_vec3 m = gtr1_sample(clearcoat_alpha(b, h), u);
        li = spc_reflect(lo, m);
        if (!compatible(m, lo, li, ci, true))
            return false;
        lobe = SPC_LOBE_GLOSSY_REFLECTION;
    } else {
        /* the main lobe; the rest of u_lobe chooses reflection or refraction */
        double ur = p_main > 0.0 ? spc_clamp((u_lobe - p_diff - p_cc) / p_main, 0.0, 1.0) : 0.0;
        spc_microfacet md = spc_principled_ggx(q.roughness, q.anisotropic);
        double pdf_m;
        spc_vec3 m = spc_microfacet_sample(&md, front ? lo : spc_neg(lo), u, &pdf_m);
        if (!(pdf_m > 0.0))
            return false;
        double dih = spc_dot(lo, m), cos_t, eta_ti;
        double F = spc_fresnel_dielectric(dih, b->eta, &cos_t, &eta_ti);
        double p_refl = front ? 1.0 - q.bsdf * (1.0 - F) : F;
        if (ur < p_refl) {
            li = spc_reflect(lo, m);
            if (!compatible(m, lo, li, ci, true))
                return false;
            lobe = SPC_LOBE_GLOSSY_REFLECTION;
        } else {
            if (F >= 1.0)
                return false;
            li = spc_refract(lo, m, cos_t, eta_ti);
            if (!compatible(m, lo, li, ci, false))
                return false;
            lobe = SPC_LOBE_GLOSSY_TRANSMISSION;
            eta_s = eta_ti;
        }
    }
    bool reflect = lobe != SPC_LOBE_GLOSSY_TRANSMISSION;
    if (reflect ? !(ci * li.z > 0.0) : !(ci * li.z < 0.0))
        return false;
    double pdf = principled_pdf_local(b, h, lo, li);
    if (!(pdf > 0.0))
        return false;
    spc_rgb fc = principled_f_cos(b, h, mode, lo, li);
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, li), spc_rgb_scale(fc, 1.0 / pdf), pdf, lobe, eta_s);
    return true;
}

spc_rgb spc_principled_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_bsdf_tex(b->pr.base_color, h, spc_rgb1(0.5));
}
