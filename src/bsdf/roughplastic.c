/*
 * bsdf/roughplastic.c: a diffuse base under a rough dielectric coating (Mitsuba's roughplastic,
 * after Weidlich and Wilkie 2007): the microfacet reflection of the coating,
 *   f_s = specular_reflectance F(wo.m) D(m) G(wo, wi, m) / (4 cos_o cos_i)   (Walter et al. eq. 20),
 * plus the diffuse base of plastic (spc_bsdf_plastic_diffuse in variants.h).
 *
 * The diffuse part is attenuated by the ROUGH coating, as Mitsuba 3 does (its roughplastic.cpp;
 * Weidlich and Wilkie 2007 sec. 3): light enters and leaves through the microfacet interface with
 * the directional transmittance
 *   T(mu) = E over visible normals m seen from w [(1 - F(w.m)) G1(w_t, m)],  w.z = mu,
 * w_t the refraction of w about m, and the internal reflections sum a geometric series with the
 * coating's cosine-weighted internal reflectance
 *   fdr_int = 2 integral_0^1 R'(mu) mu dmu,  R'(mu) = E[F'(w.m) G1(w_r, m)] for eta' = 1 / eta,
 * so f_d = R / (1 - fdr_int) T(cos_o) T(cos_i) / (pi eta^2). spc_roughplastic_prepare evaluates
 * T at SPC_ROUGHPLASTIC_TABLE_RES cosines and fdr_int with Gauss-Legendre quadrature over the
 * visible-normal sample space (the integrand is then just F G1), and eval interpolates T linearly
 * between entries (Mitsuba 3 does the same with 64 entries, and averages R' mu over them for
 * fdr_int: matched here). A textured or anisotropic alpha (Mitsuba 3's roughplastic takes one
 * float) keeps the smooth-interface terms 1 - F(cos) and fdr_int of plastic. For alpha -> 0 both
 * reduce to plastic's.
 *
 * Sampling: the coating's microfacet lobe (visible normals or D(m) m.z, microfacet.c; wi the
 * mirror of wo about m) with probability p = F_o s / (F_o s + (1 - F_o)(1 - s)), s as in plastic,
 * else the cosine-weighted hemisphere; pdf and weight are those of the mixture.
 *
 * Mitsuba XML <bsdf type="roughplastic">:
 *   distribution           "beckmann" | "ggx"    "beckmann"
 *   alpha                  float or texture      0.1     (alpha_u = alpha_v; anisotropy is accepted)
 *   int_ior                float or string       "polypropylene" (1.49)
 *   ext_ior                float or string       "air" (1.000277)     b->eta = int_ior / ext_ior
 *   specular_reflectance   spectrum or texture   1.0
 *   diffuse_reflectance    spectrum or texture   0.5     (read through `reflectance`)
 *   nonlinear              boolean               false
 *   sample_visible         boolean               true
 */
#include "bsdf/microfacet.h"
#include "bsdf/variants.h"

/* Gauss-Legendre order per dimension of both quadratures (64 x 32^2 samples of the visible
 * normals each, ~0.1 s per BSDF for Beckmann, whose sampling inverts a CDF numerically). The
 * internal reflectance's integrand has the edge of total internal reflection, where Gauss-Legendre
 * converges slowly; measured against 128 nodes its error is 2e-4 (fdr ~0.4-0.6), below 0.05% of
 * the diffuse part, and the whole eval agrees with Mitsuba 3.9's to 0.07% (GGX) and 0.003%
 * (Beckmann) at alpha 0.05 and 0.3. */
#define COAT_NODES_EXT 32
#define COAT_NODES_INT 32

/* Nodes and weights of n-point Gauss-Legendre quadrature on [-1, 1]: the roots of the Legendre
 * polynomial P_n by Newton's method from the usual cosine guesses, w = 2 / ((1 - x^2) P_n'(x)^2). */
static void gauss_legendre(int n, double *x, double *w)
{
    for (int i = 0; i < (n + 1) / 2; ++i) {
        double z = cos(SPC_PI * (i + 0.75) / (n + 0.5)), dp = 1.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = z;
            for (int k = 2; k <= n; ++k) {
                double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (z * p1 - p0) / (z * z - 1.0);
            double dz = p1 / dp;
            z -= dz;
            if (fabs(dz) < 1e-15)
                break;
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = w[n - 1 - i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
}

/* Energy the interface of relative IOR eta reflects (*R) and transmits (*T) for light from the
 * direction (sqrt(1 - mu^2), 0, mu): the mean over visible normals of F G1(w_r) and
 * (1 - F) G1(w_t), by an n x n product rule over the sampler's unit square. */
static void coat_albedo(const spc_microfacet *md, double eta, double mu, int n, const double *x, const double *wq,
                        double *R, double *T)
{
    spc_vec3 w = spc_v3(sqrt(spc_max(0.0, 1.0 - mu * mu)), 0.0, mu);
    double r = 0.0, t = 0.0;
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            double pdf_m;
            spc_vec3 m = spc_microfacet_sample(md, w, spc_v2(0.5 * (x[i] + 1.0), 0.5 * (x[j] + 1.0)), &pdf_m);
            double c = spc_dot(w, m);
            if (!(pdf_m > 0.0) || c <= 0.0)
                continue;
            double wgt = 0.25 * wq[i] * wq[j], cos_t, eta_ti;
            double F = spc_fresnel_dielectric(c, eta, &cos_t, &eta_ti);
            r += wgt * F * spc_microfacet_g1(md, spc_reflect(w, m), m);
            if (F < 1.0)
                t += wgt * (1.0 - F) * spc_microfacet_g1(md, spc_refract(w, m, cos_t, eta_ti), m);
        }
    }
    *R = r;
    *T = t;
}

/* The constant alpha of b, or -1 when it is textured or anisotropic. */
static double constant_alpha(const spc_bsdf *b)
{
    const spc_texture *u = b->alpha_u, *v = b->alpha_v;
    if (u && u->type != SPC_TEX_CONSTANT)
        return -1.0;
    if (v && (v->type != SPC_TEX_CONSTANT || !u || spc_rgb_avg(v->value) != spc_rgb_avg(u->value)))
        return -1.0;
    return u ? spc_rgb_avg(u->value) : 0.1;
}

void spc_roughplastic_prepare(spc_bsdf *b)
{
    b->coat_ready = false;
    double alpha = constant_alpha(b);
    if (!(alpha >= 0.0) || !(b->eta > 0.0) || b->eta == 1.0)
        return;
    /* the tables are of the distribution itself: visible-normal sampling is how they integrate */
    spc_microfacet md = spc_microfacet_make(b->distribution, alpha, alpha, true);
    double xe[COAT_NODES_EXT], we[COAT_NODES_EXT], xi[COAT_NODES_INT], wi[COAT_NODES_INT];
    gauss_legendre(COAT_NODES_EXT, xe, we);
    gauss_legendre(COAT_NODES_INT, xi, wi);
    double fdr = 0.0;
    for (int k = 0; k < SPC_ROUGHPLASTIC_TABLE_RES; ++k) {
        /* the entries' cosines; the first is kept off 0, where the direction lies in the surface */
        double mu = spc_max(1e-6, (double)k / (SPC_ROUGHPLASTIC_TABLE_RES - 1)), R, T;
        coat_albedo(&md, b->eta, mu, COAT_NODES_EXT, xe, we, &R, &T);
        b->coat_t[k] = (float)T;
        coat_albedo(&md, 1.0 / b->eta, mu, COAT_NODES_INT, xi, wi, &R, &T);
        fdr += R * mu;
    }
    /* 2 integral R' mu dmu as the mean over the entries (Mitsuba 3's rule, kept for agreement) */
    b->coat_fdr_int = 2.0 * fdr / SPC_ROUGHPLASTIC_TABLE_RES;
    b->coat_ready = true;
}

/* The coating's transmittance for the cosine mu: linear interpolation between the entries. */
static double coat_transmittance(const spc_bsdf *b, double mu)
{
    double x = spc_clamp(mu, 0.0, 1.0) * (SPC_ROUGHPLASTIC_TABLE_RES - 1);
    int i = x < SPC_ROUGHPLASTIC_TABLE_RES - 2 ? (int)x : SPC_ROUGHPLASTIC_TABLE_RES - 2;
    double a = x - i;
    return (1.0 - a) * b->coat_t[i] + a * b->coat_t[i + 1];
}

/* Probability of the coating's lobe: its share of the energy (1 - T, or F for the smooth
 * stand-in) weighted by the specular/diffuse reflectances, as Mitsuba. */
static double roughplastic_spec_prob(const spc_bsdf *b, const spc_hit *h, double cos_o)
{
    double d = spc_max(spc_rgb_avg(spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5))), 0.0);
    double s = spc_max(spc_rgb_avg(spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0))), 0.0);
    double ssw = d + s > 0.0 ? s / (d + s) : 0.5;
    double F = b->coat_ready ? 1.0 - coat_transmittance(b, cos_o) : spc_fresnel_dielectric(cos_o, b->eta, NULL, NULL);
    double ps = F * ssw, pd = (1.0 - F) * (1.0 - ssw);
    return ps + pd > 0.0 ? ps / (ps + pd) : 0.5;
}

static spc_rgb roughplastic_f(const spc_bsdf *b, const spc_hit *h, const spc_microfacet *md, spc_vec3 lo, spc_vec3 li)
{
    spc_rgb R = spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
    spc_rgb f = b->coat_ready ? spc_bsdf_coated_diffuse(R, b->eta, b->nonlinear, b->coat_fdr_int,
                                                        coat_transmittance(b, lo.z), coat_transmittance(b, li.z))
                              : spc_bsdf_plastic_diffuse(R, b->eta, b->nonlinear, lo.z, li.z);
    spc_vec3 m = spc_normalize(spc_add(lo, li));
    double d = spc_microfacet_d(md, m);
    if (d > 0.0) {
        double g = spc_microfacet_g(md, lo, li, m);
        double F = spc_fresnel_dielectric(spc_dot(lo, m), b->eta, NULL, NULL);
        spc_rgb ks = spc_bsdf_tex(b->specular_reflectance, h, spc_rgb1(1.0));
        f = spc_rgb_add(f, spc_rgb_scale(ks, F * d * g / (4.0 * lo.z * li.z)));
    }
    return f;
}

static double roughplastic_pdf_local(const spc_microfacet *md, double p, spc_vec3 lo, spc_vec3 li)
{
    double pdf = (1.0 - p) * li.z * SPC_INV_PI;
    spc_vec3 m = spc_normalize(spc_add(lo, li));
    double d_om = spc_dot(lo, m);
    if (d_om > 0.0)
        pdf += p * spc_microfacet_pdf(md, lo, m) / (4.0 * d_om);
    return pdf;
}

spc_rgb spc_roughplastic_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return spc_rgb1(0.0);
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    return roughplastic_f(b, h, &md, lo, li);
}

double spc_roughplastic_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo), li = spc_bsdf_to_local(h, wi);
    if (lo.z <= 0.0 || li.z <= 0.0)
        return 0.0;
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    return roughplastic_pdf_local(&md, roughplastic_spec_prob(b, h, lo.z), lo, li);
}

bool spc_roughplastic_sample(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                             spc_vec2 u, spc_bsdf_sample *out)
{
    (void)mode;
    spc_vec3 lo = spc_bsdf_to_local(h, wo);
    if (lo.z <= 0.0)
        return false;
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    double p = roughplastic_spec_prob(b, h, lo.z);
    spc_vec3 li;
    unsigned lobe;
    if (u_lobe < p) {
        double pdf_m;
        spc_vec3 m = spc_microfacet_sample(&md, lo, u, &pdf_m);
        if (!(pdf_m > 0.0) || spc_dot(lo, m) <= 0.0)
            return false;
        li = spc_reflect(lo, m);
        lobe = SPC_LOBE_GLOSSY_REFLECTION;
    } else {
        li = spc_warp_cosine_hemisphere(u);
        lobe = SPC_LOBE_DIFFUSE_REFLECTION;
    }
    if (li.z <= 0.0)
        return false;
    double pdf = roughplastic_pdf_local(&md, p, lo, li);
    if (!(pdf > 0.0))
        return false;
    spc_rgb f = roughplastic_f(b, h, &md, lo, li);
    spc_bsdf_set_sample(out, spc_bsdf_to_world(h, li), spc_rgb_scale(f, li.z / pdf), pdf, lobe, 1.0);
    return true;
}

spc_rgb spc_roughplastic_albedo(const spc_bsdf *b, const spc_hit *h)
{
    return spc_bsdf_tex(b->reflectance, h, spc_rgb1(0.5));
}
