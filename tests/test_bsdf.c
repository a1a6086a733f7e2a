/*
 * tests/test_bsdf.c: the BSDFs (src/bsdf/).
 *
 * 1. Closed-form values: Lambert, mirror, Fresnel (dielectric against Stokes reciprocity and
 *    the normal-incidence formula, conductor against complex arithmetic, diffuse Fresnel
 *    reflectance against quadrature), total internal reflection, Snell's law, thin sheets,
 *    Oren-Nayar at alpha 0, Blinn-Phong normalization, small-roughness limits, white furnaces,
 *    reciprocity (and the adjoint relation of the rough dielectric's two transport modes), the
 *    wrappers (twosided, mask, blendbsdf, normalmap, bumpmap).
 * 2. Consistency: for every smooth sample, weight == eval |cos| / pdf and pdf() == sample pdf.
 * 3. Chi-square goodness of fit of every sampling routine against its own pdf() (as Mitsuba's
 *    ChiSquareTest and pbrt's bsdfs_test): 1M samples histogrammed on a (cos theta, phi) grid of
 *    the whole sphere, expected counts from adaptive Simpson integration of pdf() over each cell,
 *    plus one extra cell for samples that failed or took a delta lobe (expected: the mass pdf()
 *    does not cover). Cells expecting fewer than 5 are pooled; the p-value comes from the
 *    regularized incomplete gamma function; significance 0.01 with Sidak's correction over all
 *    chi-square tests of this program.
 * 4. The chi-square routine rejects a wrong pdf (scaled by 1.2; a slightly different roughness).
 * 5. Lobes too narrow for that grid (alpha 0.01): the share of samples in a small cone against the
 *    quadrature of pdf() over it (test_roughconductor_narrow_lobe_cone).
 */
/* ctest-labels: unit stat */
/* ctest-timeout: 900 */
#include <complex.h>
#include <stdint.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "bsdf/microfacet.h"
#include "bsdf/variants.h"
#include "core/rng.h"
#include "core/warp.h"
#include "chi2.h"
#include "harness.h"

/* ------------------------------------------------------------------------------------------ */
/* fixtures                                                                                    */

static spc_texture tex_pool[1024];
static int tex_used;
static const spc_texture *tex3(double r, double g, double b)
{
    if (tex_used >= (int)(sizeof tex_pool / sizeof tex_pool[0]))
        abort();
    spc_texture *t = &tex_pool[tex_used++];
    spc_texture_init_constant(t, spc_rgb3(r, g, b));
    return t;
}
static const spc_texture *tex1(double v) { return tex3(v, v, v); }

static spc_bsdf bsdf_pool[512];
static int bsdf_used;
static spc_bsdf *new_bsdf(spc_bsdf_type type)
{
    if (bsdf_used >= (int)(sizeof bsdf_pool / sizeof bsdf_pool[0]))
        abort();
    spc_bsdf *b = &bsdf_pool[bsdf_used++];
    memset(b, 0, sizeof *b);
    b->type = type;
    b->reflectance = tex1(0.5);
    b->specular_reflectance = tex1(1.0);
    b->specular_transmittance = tex1(1.0);
    b->alpha_u = b->alpha_v = tex1(0.1);
    b->distribution = SPC_MICROFACET_GGX;
    b->sample_visible = true;
    b->eta = 1.5;
    b->cond_eta = spc_rgb1(0.0);
    b->cond_k = spc_rgb1(-1.0);
    b->exponent = 30.0;
    b->weight = tex1(0.5);
    b->opacity = tex1(0.5);
    b->bump_scale = 1.0;
    return b;
}

static spc_bsdf *mk_diffuse(double r, double g, double bl)
{
    spc_bsdf *b = new_bsdf(SPC_BSDF_DIFFUSE);
    b->reflectance = tex3(r, g, bl);
    return b;
}
static spc_bsdf *mk_roughdiffuse(double r, double alpha)
{
    spc_bsdf *b = new_bsdf(SPC_BSDF_ROUGHDIFFUSE);
    b->reflectance = tex3(r, 0.8 * r, 0.6 * r);
    b->alpha_u = b->alpha_v = tex1(alpha);
    return b;
}
static spc_bsdf *mk_phong(double kd, double ks, double n)
{
    spc_bsdf *b = new_bsdf(SPC_BSDF_PHONG);
    b->reflectance = tex3(kd, kd, 0.5 * kd);
    b->specular_reflectance = tex3(ks, 0.7 * ks, ks);
    b->exponent = n;
    return b;
}
static spc_bsdf *mk_roughconductor(spc_microfacet_type d, double au, double av, bool visible, bool mirror)
{
    spc_bsdf *b = new_bsdf(SPC_BSDF_ROUGHCONDUCTOR);
    b->distribution = d;
    b->alpha_u = tex1(au);
    b->alpha_v = tex1(av);
    b->sample_visible = visible;
    if (!mirror) { /* gold-ish */
        b->cond_eta = spc_rgb3(0.143, 0.374, 1.442);
        b->cond_k = spc_rgb3(3.983, 2.385, 1.603);
    }
    return b;
}
static spc_bsdf *mk_roughdielectric(spc_microfacet_type d, double au, double av, double eta, bool visible)
{
    spc_bsdf *b = new_bsdf(SPC_BSDF_ROUGHDIELECTRIC);
    b->distribution = d;
    b->alpha_u = tex1(au);
    b->alpha_v = tex1(av);
    b->eta = eta;
    b->sample_visible = visible;
    return b;
}
static spc_bsdf *mk_plastic(spc_bsdf_type type, spc_microfacet_type d, double alpha, bool nonlinear)
{
    spc_bsdf *b = new_bsdf(type);
    b->reflectance = tex3(0.7, 0.4, 0.2);
    b->distribution = d;
    b->alpha_u = b->alpha_v = tex1(alpha);
    b->eta = 1.49;
    b->nonlinear = nonlinear;
    spc_bsdf_prepare(b); /* roughplastic: the rough coating's tables, as the scene would */
    return b;
}
static spc_bsdf *mk_wrap(spc_bsdf_type type, const spc_bsdf *n0, const spc_bsdf *n1)
{
    spc_bsdf *b = new_bsdf(type);
    b->nested[0] = n0;
    b->nested[1] = n1;
    return b;
}

/* A hit with a tilted shading frame, so that world/local transforms are exercised. */
static spc_hit make_hit(spc_vec3 n)
{
    spc_hit h;
    memset(&h, 0, sizeof h);
    n = spc_normalize(n);
    h.sh = spc_frame_from_n(n);
    h.ng = n;
    h.uv = spc_v2(0.3, 0.7);
    h.dpdu = h.sh.s;
    h.dpdv = h.sh.t;
    h.prim = 0;
    return h;
}
static spc_hit default_hit(void) { return make_hit(spc_v3(0.3, -0.2, 0.9)); }

/* World direction from local spherical angles (degrees) in h's shading frame. */
static spc_vec3 dir(const spc_hit *h, double theta_deg, double phi_deg)
{
    double t = theta_deg * SPC_PI / 180.0, p = phi_deg * SPC_PI / 180.0;
    return spc_frame_to_world(&h->sh, spc_v3(sin(t) * cos(p), sin(t) * sin(p), cos(t)));
}

static double rgb_rel_diff(spc_rgb a, spc_rgb b)
{
    double m = spc_max(spc_rgb_max(spc_rgb3(fabs(a.r), fabs(a.g), fabs(a.b))),
                       spc_rgb_max(spc_rgb3(fabs(b.r), fabs(b.g), fabs(b.b))));
    double d = spc_max(fabs(a.r - b.r), spc_max(fabs(a.g - b.g), fabs(a.b - b.b)));
    return m > 0.0 ? d / m : d;
}

/* ------------------------------------------------------------------------------------------ */
/* statistics: the chi-square machinery lives in tests/chi2.h                                  */

/* What is sampled and what it is tested against. */
typedef struct chi2_case {
    const char *name;
    const spc_bsdf *b;     /* sampled */
    const spc_bsdf *pdf_b; /* whose pdf() gives the expected counts (NULL: b) */
    double pdf_scale;      /* multiplies pdf() (0 means 1): deliberately wrong variants */
    spc_vec3 wo_local;
    spc_transport mode;
} chi2_case;

typedef struct bsdf_chi2 {
    const chi2_case *cs;
    const spc_hit *h;
    spc_vec3 wo;
} bsdf_chi2;

/* the smooth part: delta-lobe samples count as "no sample" */
static bool bsdf_chi2_sample(void *user, spc_rng *rng, spc_vec3 *dir)
{
    const bsdf_chi2 *t = user;
    double ul = spc_rng_next(rng);
    spc_vec2 u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    spc_bsdf_sample s;
    if (!spc_bsdf_sample_dir(t->cs->b, t->h, t->cs->mode, t->wo, ul, u, &s) || (s.lobe & SPC_LOBE_DELTA))
        return false;
    *dir = s.wi;
    return true;
}

static double bsdf_chi2_pdf(void *user, spc_vec3 dir)
{
    const bsdf_chi2 *t = user;
    const spc_bsdf *b = t->cs->pdf_b ? t->cs->pdf_b : t->cs->b;
    double scale = t->cs->pdf_scale > 0.0 ? t->cs->pdf_scale : 1.0;
    return scale * spc_bsdf_pdf(b, t->h, t->cs->mode, t->wo, dir);
}

#define CHI_SAMPLES 1000000

static int chi2_total_tests = 1; /* set by the test before running the cases (Sidak) */

/* Runs one chi-square test (tests/chi2.h); returns the p-value. */
static double chi2_run(const chi2_case *cs, const spc_hit *h, int n_samples, uint64_t seed, bool verbose)
{
    bsdf_chi2 t = {cs, h, spc_frame_to_world(&h->sh, spc_normalize(cs->wo_local))};
    return chi2_direction_test(cs->name, bsdf_chi2_sample, bsdf_chi2_pdf, &t, &h->sh, n_samples, seed, verbose);
}

static bool bsdf_chi2_accept(double p) { return chi2_accept(p, chi2_total_tests); }

/* ------------------------------------------------------------------------------------------ */
/* 1. closed forms                                                                             */

TEST(test_flags)
{
    spc_bsdf *d = mk_diffuse(0.5, 0.5, 0.5);
    spc_bsdf *rc = mk_roughconductor(SPC_MICROFACET_GGX, 0.2, 0.2, true, true);
    CHECK(spc_bsdf_flags(d) == SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK(spc_bsdf_has_smooth(rc) && !spc_bsdf_is_delta_only(rc));
    spc_bsdf *c = new_bsdf(SPC_BSDF_CONDUCTOR), *g = new_bsdf(SPC_BSDF_DIELECTRIC);
    CHECK(spc_bsdf_is_delta_only(c) && spc_bsdf_is_delta_only(g));
    CHECK(spc_bsdf_flags(g) == (SPC_LOBE_DELTA_REFLECTION | SPC_LOBE_DELTA_TRANSMISSION));
    spc_bsdf *m = mk_wrap(SPC_BSDF_MASK, d, NULL);
    CHECK(spc_bsdf_flags(m) == (SPC_LOBE_DIFFUSE_REFLECTION | SPC_LOBE_NULL));
    CHECK(spc_bsdf_flags(mk_wrap(SPC_BSDF_BLENDBSDF, d, c)) == (SPC_LOBE_DIFFUSE_REFLECTION | SPC_LOBE_DELTA_REFLECTION));
    double eta = -1.0;
    CHECK(spc_bsdf_is_specular_interface(g, &eta) && eta == 1.5);
    CHECK(spc_bsdf_is_specular_interface(c, &eta) && eta == 0.0);
    CHECK(spc_bsdf_is_specular_interface(mk_wrap(SPC_BSDF_TWOSIDED, c, NULL), &eta));
    CHECK(!spc_bsdf_is_specular_interface(d, &eta) && !spc_bsdf_is_specular_interface(rc, &eta));
    /* which BSDFs read the hit's derivatives (normal and bump maps, nested anywhere) */
    spc_bsdf *nm = mk_wrap(SPC_BSDF_NORMALMAP, d, NULL), *bm = mk_wrap(SPC_BSDF_BUMPMAP, rc, NULL);
    CHECK(!spc_bsdf_reads_derivatives(d) && !spc_bsdf_reads_derivatives(m) && !spc_bsdf_reads_derivatives(NULL));
    CHECK(!spc_bsdf_reads_derivatives(mk_wrap(SPC_BSDF_TWOSIDED, d, rc)));
    CHECK(spc_bsdf_reads_derivatives(nm) && spc_bsdf_reads_derivatives(bm));
    CHECK(spc_bsdf_reads_derivatives(mk_wrap(SPC_BSDF_TWOSIDED, d, nm)));
    CHECK(spc_bsdf_reads_derivatives(mk_wrap(SPC_BSDF_BLENDBSDF, d, mk_wrap(SPC_BSDF_MASK, bm, NULL))));
}

TEST(test_diffuse_closed_form)
{
    spc_hit h = default_hit();
    spc_bsdf *b = mk_diffuse(0.2, 0.5, 0.8);
    spc_vec3 wo = dir(&h, 30, 10), wi = dir(&h, 60, 200);
    spc_rgb f = spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, wi);
    CHECK_NEAR(f.r, 0.2 / SPC_PI, 1e-12);
    CHECK_NEAR(f.g, 0.5 / SPC_PI, 1e-12);
    CHECK_NEAR(f.b, 0.8 / SPC_PI, 1e-12);
    CHECK_NEAR(spc_bsdf_pdf(b, &h, SPC_MODE_RADIANCE, wo, wi), cos(60 * SPC_PI / 180) / SPC_PI, 1e-12);
    /* one-sided */
    CHECK(spc_rgb_is_black(spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, dir(&h, 120, 0))));
    CHECK(spc_rgb_is_black(spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, dir(&h, 100, 0), wi)));
    CHECK(spc_bsdf_pdf(b, &h, SPC_MODE_RADIANCE, wo, dir(&h, 91, 0)) == 0.0);
    spc_bsdf_sample s;
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.3, spc_v2(0.4, 0.7), &s));
    CHECK_NEAR(s.weight.g, 0.5, 1e-12);
    CHECK(s.lobe == SPC_LOBE_DIFFUSE_REFLECTION && s.eta == 1.0);
    CHECK(!spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, dir(&h, 100, 0), 0.3, spc_v2(0.4, 0.7), &s));
    CHECK_NEAR(spc_bsdf_albedo(b, &h).b, 0.8, 1e-12);
}

/* White Lambert integrates to one (uniform hemisphere estimator, independent of its sampler). */
TEST(test_diffuse_energy)
{
    spc_hit h = default_hit();
    spc_bsdf *b = mk_diffuse(1.0, 1.0, 1.0);
    spc_rng rng;
    spc_rng_seed(&rng, 7, 1);
    const int n = 200000;
    double sum = 0.0;
    spc_vec3 wo = dir(&h, 45, 30);
    for (int i = 0; i < n; ++i) {
        spc_vec3 wl = spc_warp_uniform_hemisphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)));
        spc_vec3 wi = spc_frame_to_world(&h.sh, wl);
        sum += spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, wi).r * wl.z * 2.0 * SPC_PI;
    }
    CHECK_NEAR(sum / n, 1.0, 0.01); /* sd of the mean: 0.0013 */
}

TEST(test_fresnel_dielectric)
{
    double ct, eti;
    double F = spc_fresnel_dielectric(1.0, 1.5, &ct, &eti);
    CHECK_NEAR(F, 0.04, 1e-12);
    CHECK_NEAR(ct, -1.0, 1e-12);
    CHECK_NEAR(eti, 1.5, 1e-15);
    F = spc_fresnel_dielectric(-1.0, 1.5, &ct, &eti);
    CHECK_NEAR(F, 0.04, 1e-12);
    CHECK_NEAR(ct, 1.0, 1e-12);
    CHECK_NEAR(eti, 1.0 / 1.5, 1e-15);
    /* Stokes: the same ray pair has the same reflectance from both sides */
    double ci = cos(50 * SPC_PI / 180);
    double F1 = spc_fresnel_dielectric(ci, 1.33, &ct, &eti);
    double ct2, eti2;
    double F2 = spc_fresnel_dielectric(ct, 1.33, &ct2, &eti2);
    CHECK_NEAR(F1, F2, 1e-12);
    CHECK_NEAR(ct2, ci, 1e-12);
    /* Snell */
    CHECK_NEAR(sqrt(1 - ct * ct) * 1.33, sin(50 * SPC_PI / 180), 1e-12);
    /* total internal reflection beyond the critical angle */
    double crit = asin(1.0 / 1.5);
    CHECK(spc_fresnel_dielectric(-cos(crit + 0.01), 1.5, &ct, &eti) == 1.0);
    CHECK(spc_fresnel_dielectric(-cos(crit - 0.01), 1.5, &ct, &eti) < 1.0);
    /* grazing from outside reflects everything */
    CHECK_NEAR(spc_fresnel_dielectric(1e-9, 1.5, NULL, NULL), 1.0, 1e-6);
    /* refraction direction */
    spc_vec3 n = spc_v3(0, 0, 1), w = spc_v3(sin(0.7), 0, cos(0.7));
    F = spc_fresnel_dielectric(w.z, 1.5, &ct, &eti);
    spc_vec3 t = spc_refract(w, n, ct, eti);
    CHECK_NEAR(spc_length(t), 1.0, 1e-12);
    CHECK_NEAR(t.x, -sin(0.7) / 1.5, 1e-12);
    CHECK(t.z < 0.0);
}

TEST(test_fresnel_conductor)
{
    const double eta = 0.2, k = 3.9;
    spc_rgb e3 = spc_rgb3(eta, 1.0, 1.5), k3 = spc_rgb3(k, 0.0, 0.5);
    double angles[] = {0.0, 20.0, 45.0, 70.0, 85.0, 89.9};
    for (int i = 0; i < 6; ++i) {
        double ci = cos(angles[i] * SPC_PI / 180), si2 = 1 - ci * ci;
        spc_rgb F = spc_fresnel_conductor(ci, e3, k3);
        /* complex Fresnel: r_s = (ci - s)/(ci + s), r_p = (n^2 ci - s)/(n^2 ci + s), s = sqrt(n^2 - sin^2) */
        double etas[3] = {eta, 1.0, 1.5}, ks[3] = {k, 0.0, 0.5}, got[3] = {F.r, F.g, F.b};
        for (int c = 0; c < 3; ++c) {
            double complex nc = etas[c] + ks[c] * I;
            double complex s = csqrt(nc * nc - si2);
            double complex rs = (ci - s) / (ci + s), rp = (nc * nc * ci - s) / (nc * nc * ci + s);
            double ref = 0.5 * (cabs(rs) * cabs(rs) + cabs(rp) * cabs(rp));
            CHECK_NEAR(got[c], ref, 1e-10);
        }
    }
    /* normal incidence: ((n-1)^2 + k^2) / ((n+1)^2 + k^2) */
    spc_rgb F0 = spc_fresnel_conductor(1.0, e3, k3);
    CHECK_NEAR(F0.r, (spc_sqr(eta - 1) + k * k) / (spc_sqr(eta + 1) + k * k), 1e-12);
    /* k = 0 reduces to the dielectric */
    CHECK_NEAR(spc_fresnel_conductor(0.6, spc_rgb1(1.5), spc_rgb1(0.0)).g,
               spc_fresnel_dielectric(0.6, 1.5, NULL, NULL), 1e-12);
}

static double fresnel_hemi_avg(double eta)
{
    const int n = 200000;
    double s = 0.0;
    for (int i = 0; i < n; ++i) {
        double mu = (i + 0.5) / n;
        s += spc_fresnel_dielectric(mu, eta, NULL, NULL) * 2.0 * mu;
    }
    return s / n;
}

TEST(test_fresnel_diffuse_reflectance)
{
    double etas[] = {1.33, 1.5, 2.4, 1.0 / 1.33, 1.0 / 1.49, 1.02, 1.0005, 1.0 / 1.0005, 1.00005, 1.0 / 1.00005};
    for (int i = 0; i < 10; ++i)
        CHECK_NEAR(spc_fresnel_diffuse_reflectance(etas[i]), fresnel_hemi_avg(etas[i]), 2e-6);
}

TEST(test_conductor)
{
    spc_hit h = default_hit();
    spc_bsdf *b = new_bsdf(SPC_BSDF_CONDUCTOR);
    b->specular_reflectance = tex3(0.9, 0.5, 0.25);
    spc_vec3 wo = dir(&h, 35, 80);
    spc_bsdf_sample s;
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.7, spc_v2(0.1, 0.9), &s));
    CHECK(s.lobe == SPC_LOBE_DELTA_REFLECTION && s.pdf == 1.0);
    CHECK_NEAR(s.weight.r, 0.9, 1e-12);
    CHECK_NEAR(s.weight.b, 0.25, 1e-12);
    spc_vec3 mirror = dir(&h, 35, 260);
    CHECK_NEAR(spc_distance(s.wi, mirror), 0.0, 1e-12);
    CHECK(spc_rgb_is_black(spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, mirror)));
    CHECK(spc_bsdf_pdf(b, &h, SPC_MODE_RADIANCE, wo, mirror) == 0.0);
    CHECK(!spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, dir(&h, 95, 0), 0.5, spc_v2(0.5, 0.5), &s));
    /* with a complex IOR */
    b->cond_eta = spc_rgb3(0.2, 0.9, 1.1);
    b->cond_k = spc_rgb3(3.9, 2.4, 1.6);
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.7, spc_v2(0.1, 0.9), &s));
    spc_rgb F = spc_fresnel_conductor(cos(35 * SPC_PI / 180), b->cond_eta, b->cond_k);
    CHECK_NEAR(s.weight.r, 0.9 * F.r, 1e-12);
    CHECK_NEAR(s.weight.g, 0.5 * F.g, 1e-12);
}

TEST(test_dielectric)
{
    spc_hit h = default_hit();
    spc_bsdf *b = new_bsdf(SPC_BSDF_DIELECTRIC);
    b->eta = 1.5;
    spc_bsdf_sample s;
    const double F0 = spc_sqr((1.5 - 1) / (1.5 + 1));
    spc_vec3 wo = h.sh.n;
    /* normal incidence: reflection with probability F0, transmission straight through */
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.5 * F0, spc_v2(0.3, 0.3), &s));
    CHECK(s.lobe == SPC_LOBE_DELTA_REFLECTION);
    CHECK_NEAR(s.pdf, F0, 1e-12);
    CHECK_NEAR(s.weight.r, 1.0, 1e-12);
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.5, spc_v2(0.3, 0.3), &s));
    CHECK(s.lobe == SPC_LOBE_DELTA_TRANSMISSION);
    CHECK_NEAR(s.pdf, 1.0 - F0, 1e-12);
    CHECK_NEAR(spc_distance(s.wi, spc_neg(wo)), 0.0, 1e-12);
    CHECK_NEAR(s.weight.g, 1.0 / (1.5 * 1.5), 1e-12); /* radiance compression */
    CHECK_NEAR(s.eta, 1.5, 1e-15);
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_IMPORTANCE, wo, 0.5, spc_v2(0.3, 0.3), &s));
    CHECK_NEAR(s.weight.g, 1.0, 1e-12);
    /* from inside at 30 degrees: Snell's law and eta of the wi side over the wo side */
    spc_vec3 wo_in = dir(&h, 150, 40);
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo_in, 0.999, spc_v2(0.3, 0.3), &s));
    CHECK(s.lobe == SPC_LOBE_DELTA_TRANSMISSION);
    CHECK_NEAR(s.eta, 1.0 / 1.5, 1e-15);
    spc_vec3 wl = spc_frame_to_local(&h.sh, s.wi);
    CHECK(wl.z > 0.0);
    CHECK_NEAR(sqrt(wl.x * wl.x + wl.y * wl.y), 1.5 * sin(30 * SPC_PI / 180), 1e-12);
    CHECK_NEAR(atan2(wl.y, wl.x), (40.0 - 180.0) * SPC_PI / 180, 1e-12);
    CHECK_NEAR(s.weight.r, 1.5 * 1.5, 1e-9);
    /* total internal reflection: always reflected, weight 1, probability 1 */
    spc_vec3 wo_tir = dir(&h, 180 - 50, 0); /* 50 degrees > critical 41.8 */
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo_tir, 0.999999, spc_v2(0.3, 0.3), &s));
    CHECK(s.lobe == SPC_LOBE_DELTA_REFLECTION);
    CHECK_NEAR(s.pdf, 1.0, 1e-15);
    CHECK_NEAR(s.weight.r, 1.0, 1e-15);
    CHECK_NEAR(spc_distance(s.wi, dir(&h, 180 - 50, 180)), 0.0, 1e-12);
    /* tints */
    b->specular_reflectance = tex1(0.5);
    b->specular_transmittance = tex1(0.25);
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_IMPORTANCE, dir(&h, 60, 0), 0.0, spc_v2(0.3, 0.3), &s));
    CHECK_NEAR(s.weight.r, 0.5, 1e-12);
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_IMPORTANCE, dir(&h, 60, 0), 0.99, spc_v2(0.3, 0.3), &s));
    CHECK_NEAR(s.weight.r, 0.25, 1e-12);
    CHECK(spc_rgb_is_black(spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, spc_neg(wo))));
}

TEST(test_thindielectric)
{
    spc_hit h = default_hit();
    spc_bsdf *b = new_bsdf(SPC_BSDF_THINDIELECTRIC);
    b->eta = 1.5;
    spc_vec3 wo = dir(&h, 40, 10);
    double R = spc_fresnel_dielectric(cos(40 * SPC_PI / 180), 1.5, NULL, NULL), T = 1 - R;
    double Rt = R + T * T * R / (1 - R * R);
    spc_bsdf_sample s;
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.999 * Rt, spc_v2(0.5, 0.5), &s));
    CHECK(s.lobe == SPC_LOBE_DELTA_REFLECTION);
    CHECK_NEAR(s.pdf, Rt, 1e-12);
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 1.001 * Rt, spc_v2(0.5, 0.5), &s));
    CHECK(s.lobe == SPC_LOBE_DELTA_TRANSMISSION);
    CHECK_NEAR(s.pdf, 1 - Rt, 1e-12);
    CHECK_NEAR(s.weight.r, 1.0, 1e-15);
    CHECK(s.eta == 1.0);
    CHECK_NEAR(spc_distance(s.wi, spc_neg(wo)), 0.0, 1e-15);
    /* the same from the back */
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, spc_neg(wo), 0.999 * Rt, spc_v2(0.5, 0.5), &s));
    CHECK_NEAR(s.pdf, Rt, 1e-12);
}

TEST(test_roughdiffuse)
{
    spc_hit h = default_hit();
    spc_bsdf *on = mk_roughdiffuse(0.8, 0.0), *lam = mk_diffuse(0.8, 0.64, 0.48);
    spc_rng rng;
    spc_rng_seed(&rng, 3, 3);
    for (int i = 0; i < 100; ++i) {
        spc_vec3 wo = spc_frame_to_world(&h.sh, spc_warp_cosine_hemisphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng))));
        spc_vec3 wi = spc_frame_to_world(&h.sh, spc_warp_cosine_hemisphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng))));
        CHECK(rgb_rel_diff(spc_bsdf_eval(on, &h, SPC_MODE_RADIANCE, wo, wi), spc_bsdf_eval(lam, &h, SPC_MODE_RADIANCE, wo, wi)) < 1e-12);
    }
    /* rough: brighter toward the light in retro-reflection than Lambert at grazing angles */
    spc_bsdf *r = mk_roughdiffuse(0.8, 0.6);
    spc_vec3 wo = dir(&h, 70, 0);
    double back = spc_bsdf_eval(r, &h, SPC_MODE_RADIANCE, wo, dir(&h, 70, 0)).r;
    double fwd = spc_bsdf_eval(r, &h, SPC_MODE_RADIANCE, wo, dir(&h, 70, 180)).r;
    CHECK(back > 0.8 / SPC_PI && back > fwd);
    /* the albedo stays below one for white */
    spc_bsdf *w = mk_roughdiffuse(1.0, 1.0);
    double sum = 0.0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        spc_bsdf_sample s;
        if (spc_bsdf_sample_dir(w, &h, SPC_MODE_RADIANCE, dir(&h, 20, 0), 0.5,
                                spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &s))
            sum += s.weight.r;
    }
    CHECK(sum / n < 1.0 && sum / n > 0.8);
}

TEST(test_phong_normalization)
{
    spc_hit h = default_hit();
    /* n = 0: the glossy lobe is Lambertian */
    spc_bsdf *b0 = mk_phong(0.0, 1.0, 0.0);
    CHECK_NEAR(spc_bsdf_eval(b0, &h, SPC_MODE_RADIANCE, dir(&h, 10, 0), dir(&h, 50, 70)).r, 1.0 / SPC_PI, 1e-12);
    /* normal-incidence albedo of the glossy lobe is ks, and it decreases toward grazing */
    double exps[] = {5.0, 30.0, 300.0};
    for (int e = 0; e < 3; ++e) {
        spc_bsdf *b = mk_phong(0.0, 1.0, exps[e]);
        spc_rng rng;
        spc_rng_seed(&rng, 11, (uint64_t)e);
        double a0 = 0.0, a60 = 0.0;
        const int n = 200000;
        for (int i = 0; i < n; ++i) {
            spc_bsdf_sample s;
            spc_vec2 u = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
            if (spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, h.sh.n, 0.0, u, &s))
                a0 += s.weight.r;
            if (spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, dir(&h, 60, 0), 0.0, u, &s))
                a60 += s.weight.r;
        }
        CHECK_NEAR(a0 / n, 1.0, 0.01);
        CHECK(a60 / n < a0 / n);
    }
}

/* Small roughness approaches the smooth conductor's Fresnel reflectance. */
TEST(test_roughconductor_smooth_limit)
{
    spc_hit h = default_hit();
    spc_microfacet_type types[2] = {SPC_MICROFACET_GGX, SPC_MICROFACET_BECKMANN};
    for (int t = 0; t < 2; ++t) {
        spc_bsdf *b = mk_roughconductor(types[t], 0.005, 0.005, true, false);
        double theta = 50.0;
        spc_vec3 wo = dir(&h, theta, 30);
        spc_rgb F = spc_fresnel_conductor(cos(theta * SPC_PI / 180), b->cond_eta, b->cond_k);
        spc_rng rng;
        spc_rng_seed(&rng, 5, (uint64_t)t);
        spc_rgb sum = spc_rgb1(0.0);
        const int n = 20000;
        int far = 0;
        for (int i = 0; i < n; ++i) {
            spc_bsdf_sample s;
            if (spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.5, spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &s)) {
                sum = spc_rgb_add(sum, s.weight);
                far += spc_distance(s.wi, dir(&h, theta, 210)) > 0.2; /* GGX tail: ~0.3 % */
            }
        }
        CHECK_NEAR(sum.r / n, F.r, 0.005);
        CHECK_NEAR(sum.b / n, F.b, 0.005);
        CHECK_MSG(far < n / 100, "%d of %d samples far from the mirror direction", far, n);
    }
}

/* A narrow lobe against a small light: the share of samples that land in a small cone next to the
 * mirror direction, cutting the lobe, equals pdf() integrated over the cone, and their mean weight
 * equals eval |cos| integrated over it. The configuration is veach-mis's rare caustic: a plate of alpha
 * 0.01 seen at 71 degrees reflecting a sphere light of radius 0.05 at distance 1.93 (a cone of half
 * angle 0.026), where a path tracer finds that light by BSDF sampling about once in four. The
 * whole-sphere chi-square tests cannot resolve lobes this narrow. Quadrature: a 600 x 600 grid on
 * the cone's tangent square (spacing 9e-5 rad, a twentieth of the lobe's width or less). */
TEST(test_roughconductor_narrow_lobe_cone)
{
    spc_hit h = default_hit();
    spc_microfacet_type types[2] = {SPC_MICROFACET_BECKMANN, SPC_MICROFACET_GGX};
    const double theta = 71.0, cone = 0.026;
    /* cone centres: off the mirror direction out of and within the plane of incidence */
    const double centre[2][2] = {{theta, 181.5}, {theta - 2.0, 180.0}};
    for (int t = 0; t < 2; ++t) {
        spc_bsdf *b = mk_roughconductor(types[t], 0.01, 0.01, true, false);
        spc_vec3 wo = dir(&h, theta, 0.0);
        for (int c = 0; c < 2; ++c) {
            spc_vec3 cd = dir(&h, centre[c][0], centre[c][1]);
            spc_frame F = spc_frame_from_n(cd);
            double cos_cone = cos(cone), R = tan(cone), da = 2.0 * R / 600.0, p_int = 0.0, f_int = 0.0;
            for (int i = 0; i < 600; ++i)
                for (int j = 0; j < 600; ++j) {
                    double a = -R + (i + 0.5) * da, e = -R + (j + 0.5) * da;
                    spc_vec3 w = spc_normalize(spc_add(cd, spc_add(spc_scale(F.s, a), spc_scale(F.t, e))));
                    if (spc_dot(w, cd) < cos_cone)
                        continue;
                    double J = da * da / pow(1.0 + a * a + e * e, 1.5); /* solid angle of the cell */
                    p_int += spc_bsdf_pdf(b, &h, SPC_MODE_RADIANCE, wo, w) * J;
                    f_int += spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, w).r * spc_absdot(w, h.sh.n) * J;
                }
            spc_rng rng;
            spc_rng_seed(&rng, 71, (uint64_t)(2 * t + c));
            const int n = 400000;
            int in = 0;
            double w_in = 0.0;
            for (int k = 0; k < n; ++k) {
                spc_bsdf_sample s;
                if (spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.5,
                                        spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &s) &&
                    spc_dot(s.wi, cd) >= cos_cone) {
                    ++in;
                    w_in += s.weight.r;
                }
            }
            double share = (double)in / n, se = sqrt(share * (1.0 - share) / n);
            CHECK_MSG(p_int > 0.05 && p_int < 0.95, "type %d cone %d: pdf integral %g (the cone should cut the lobe)",
                      t, c, p_int);
            CHECK_MSG(fabs(share - p_int) < 4.5 * se, "type %d cone %d: sampled share %g, pdf integral %g (se %g)", t,
                      c, share, p_int, se);
            /* weights vary by less than their mean inside the cone: 4.5 standard errors of the share
             * bound the weighted sum's error too, with a margin */
            CHECK_MSG(fabs(w_in / n - f_int) < 4.5 * se * (f_int / p_int) * 1.5 + 1e-4,
                      "type %d cone %d: sampled weight %g, f cos integral %g", t, c, w_in / n, f_int);
        }
    }
}

/* Energy: a perfect-mirror microfacet surface reflects at most everything, nearly everything when
 * smooth; the eval() integral (uniform hemisphere) agrees with the sampler's mean weight. */
TEST(test_roughconductor_furnace)
{
    spc_hit h = default_hit();
    spc_microfacet_type types[2] = {SPC_MICROFACET_GGX, SPC_MICROFACET_BECKMANN};
    double alphas[3] = {0.05, 0.3, 1.0};
    for (int t = 0; t < 2; ++t) {
        for (int a = 0; a < 3; ++a) {
            spc_bsdf *b = mk_roughconductor(types[t], alphas[a], alphas[a], true, true);
            spc_vec3 wo = dir(&h, 40, 0);
            spc_rng rng;
            spc_rng_seed(&rng, 17, (uint64_t)(10 * t + a));
            const int n = 200000;
            double sw = 0.0, sw2 = 0.0, se = 0.0;
            for (int i = 0; i < n; ++i) {
                spc_bsdf_sample s;
                spc_vec2 u = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
                if (spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.5, u, &s)) {
                    sw += s.weight.r;
                    sw2 += s.weight.r * s.weight.r;
                }
                spc_vec3 wl = spc_warp_uniform_hemisphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)));
                se += spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, spc_frame_to_world(&h.sh, wl)).r * wl.z * 2 * SPC_PI;
            }
            double mean = sw / n, sd = sqrt(spc_max(sw2 / n - mean * mean, 0.0) / n);
            CHECK_MSG(mean <= 1.0 + 4.0 * sd, "type %d alpha %g albedo %g", t, alphas[a], mean);
            if (alphas[a] <= 0.05)
                CHECK_MSG(mean > 0.98, "type %d alpha %g albedo %g", t, alphas[a], mean);
            else /* single scattering loses much at alpha 1 (about 60 % for GGX, Kulla and Conty 2017) */
                CHECK_MSG(mean > 0.3, "type %d alpha %g albedo %g", t, alphas[a], mean);
            if (alphas[a] >= 0.3) /* narrow lobes make the uniform estimator too noisy */
                CHECK_MSG(fabs(se / n - mean) < 0.02, "type %d alpha %g: eval integral %g vs sampled %g", t,
                          alphas[a], se / n, mean);
        }
    }
}

/* Rough dielectric in importance mode with white tints: reflection + transmission <= 1,
 * close to 1 when smooth (no absorption, little masking). */
TEST(test_roughdielectric_energy)
{
    spc_hit h = default_hit();
    double etas[2] = {1.5, 1.0 / 1.5};
    for (int e = 0; e < 2; ++e) {
        spc_bsdf *b = mk_roughdielectric(SPC_MICROFACET_GGX, 0.02, 0.02, etas[e], true);
        spc_rng rng;
        spc_rng_seed(&rng, 23, (uint64_t)e);
        double sum = 0.0;
        const int n = 100000;
        for (int i = 0; i < n; ++i) {
            spc_bsdf_sample s;
            if (spc_bsdf_sample_dir(b, &h, SPC_MODE_IMPORTANCE, dir(&h, 30, 0), spc_rng_next(&rng),
                                    spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &s))
                sum += s.weight.r;
        }
        CHECK_MSG(sum / n > 0.98 && sum / n <= 1.0 + 1e-9, "eta %g albedo %g", etas[e], sum / n);
    }
}

TEST(test_reciprocity)
{
    spc_hit h = default_hit();
    const spc_bsdf *list[] = {
        mk_diffuse(0.3, 0.6, 0.9),
        mk_roughdiffuse(0.9, 0.7),
        mk_phong(0.4, 0.5, 20.0),
        mk_roughconductor(SPC_MICROFACET_GGX, 0.15, 0.45, true, false),
        mk_roughconductor(SPC_MICROFACET_BECKMANN, 0.3, 0.3, true, false),
        mk_plastic(SPC_BSDF_PLASTIC, SPC_MICROFACET_GGX, 0.1, false),
        mk_plastic(SPC_BSDF_PLASTIC, SPC_MICROFACET_GGX, 0.1, true),
        mk_plastic(SPC_BSDF_ROUGHPLASTIC, SPC_MICROFACET_GGX, 0.2, false),
        mk_plastic(SPC_BSDF_ROUGHPLASTIC, SPC_MICROFACET_BECKMANN, 0.4, true),
    };
    spc_rng rng;
    spc_rng_seed(&rng, 29, 0);
    for (size_t k = 0; k < sizeof list / sizeof list[0]; ++k) {
        double worst = 0.0;
        int nonzero = 0;
        for (int i = 0; i < 200; ++i) {
            spc_vec3 wo = spc_frame_to_world(&h.sh, spc_warp_uniform_hemisphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng))));
            spc_vec3 wi = spc_frame_to_world(&h.sh, spc_warp_uniform_hemisphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng))));
            spc_rgb a = spc_bsdf_eval(list[k], &h, SPC_MODE_RADIANCE, wo, wi);
            spc_rgb b = spc_bsdf_eval(list[k], &h, SPC_MODE_RADIANCE, wi, wo);
            worst = spc_max(worst, rgb_rel_diff(a, b));
            nonzero += !spc_rgb_is_black(a);
        }
        CHECK_MSG(worst < 1e-9, "bsdf %zu: eval(wo, wi) != eval(wi, wo), rel %g", k, worst);
        CHECK(nonzero > 100);
    }
}

/* The rough dielectric's importance-mode BSDF is the adjoint of its radiance-mode one:
 * f_importance(wo, wi) = f_radiance(wi, wo), for reflection and transmission. */
TEST(test_roughdielectric_adjoint)
{
    spc_hit h = default_hit();
    spc_bsdf *b = mk_roughdielectric(SPC_MICROFACET_BECKMANN, 0.3, 0.2, 1.5, true);
    spc_rng rng;
    spc_rng_seed(&rng, 31, 0);
    double worst = 0.0;
    int trans = 0;
    for (int i = 0; i < 1000; ++i) {
        /* wi sampled from the BSDF (so that most pairs have a nonzero value), or uniform */
        spc_vec3 wo = spc_frame_to_world(&h.sh, spc_warp_uniform_sphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng))));
        spc_vec3 wi = spc_frame_to_world(&h.sh, spc_warp_uniform_sphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng))));
        spc_bsdf_sample s;
        if (i % 4 != 0 && spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, spc_rng_next(&rng),
                                              spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &s))
            wi = s.wi;
        spc_rgb a = spc_bsdf_eval(b, &h, SPC_MODE_IMPORTANCE, wo, wi);
        spc_rgb c = spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wi, wo);
        worst = spc_max(worst, rgb_rel_diff(a, c));
        if (!spc_rgb_is_black(a) && spc_dot(wo, h.sh.n) * spc_dot(wi, h.sh.n) < 0)
            ++trans;
    }
    CHECK_MSG(worst < 1e-9, "rel %g", worst);
    CHECK(trans > 200);
    /* radiance mode differs from importance mode by eta^2 on transmission */
    spc_vec3 wo = dir(&h, 20, 0), wi = dir(&h, 160, 180);
    spc_rgb fr = spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, wi), fi = spc_bsdf_eval(b, &h, SPC_MODE_IMPORTANCE, wo, wi);
    CHECK(fr.r > 0.0);
    CHECK_NEAR(fi.r / fr.r, 1.5 * 1.5, 1e-9);
}

TEST(test_plastic)
{
    spc_hit h = default_hit();
    spc_bsdf *b = mk_plastic(SPC_BSDF_PLASTIC, SPC_MICROFACET_GGX, 0.1, false);
    b->reflectance = tex1(1.0);
    /* linear model: the diffuse albedo is exactly R (1 - F(cos_o)) */
    spc_vec3 wo = dir(&h, 30, 0);
    double Fo = spc_fresnel_dielectric(cos(30 * SPC_PI / 180), 1.49, NULL, NULL);
    const int n = 2000;
    double sum = 0.0;
    for (int i = 0; i < n; ++i) { /* midpoint rule in cos theta (the lobe is azimuthally uniform) */
        double mu = (i + 0.5) / n;
        sum += spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, wo, spc_frame_to_world(&h.sh, spc_v3(sqrt(1 - mu * mu), 0, mu))).r * mu;
    }
    CHECK_NEAR(sum / n * 2 * SPC_PI, 1.0 - Fo, 1e-5);
    /* the specular sample's weight times its probability is F */
    spc_bsdf_sample s;
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.0, spc_v2(0.5, 0.5), &s));
    CHECK(s.lobe == SPC_LOBE_DELTA_REFLECTION);
    CHECK_NEAR(s.weight.r * s.pdf, Fo, 1e-12);
    CHECK_NEAR(spc_distance(s.wi, dir(&h, 30, 180)), 0.0, 1e-12);
    /* pdf() is the diffuse part only: it integrates to 1 - p_spec */
    CHECK(spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, wo, 0.9999, spc_v2(0.5, 0.5), &s));
    CHECK(s.lobe == SPC_LOBE_DIFFUSE_REFLECTION);
}

/* Energy a rough dielectric interface (roughdielectric, an independent path: its own sampling
 * and weights) transmits (want_t) or reflects for light from the cosine mu, by Monte Carlo in
 * importance mode (no 1/eta^2 on transmission). */
static double interface_albedo(const spc_bsdf *b, double mu, bool want_t, int n, uint64_t seed)
{
    spc_hit h = make_hit(spc_v3(0, 0, 1));
    spc_vec3 wo = spc_frame_to_world(&h.sh, spc_v3(sqrt(1 - mu * mu), 0, mu));
    spc_rng rng;
    spc_rng_seed(&rng, 41, seed);
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
        spc_bsdf_sample s;
        if (spc_bsdf_sample_dir(b, &h, SPC_MODE_IMPORTANCE, wo, spc_rng_next(&rng),
                                spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &s) &&
            ((s.lobe & SPC_LOBE_TRANSMISSION) != 0) == want_t)
            sum += s.weight.r;
    }
    return sum / n;
}

/* roughplastic's coating tables (Mitsuba 3's model): the transmittance T(mu) is the energy a rough
 * dielectric interface transmits, checked against roughdielectric's own sampling; the internal
 * reflectance is the cosine-weighted reflected energy from inside (1/eta), within the error of
 * the 64-entry mean that Mitsuba uses for the integral; both reduce to plastic's smooth terms as
 * alpha -> 0; and a textured alpha keeps the smooth terms. Before the tables, roughplastic used
 * the smooth terms at any alpha: 2% too bright on plastics.xml against Mitsuba 3. */
TEST(test_roughplastic_coating)
{
    const double eta = 1.49;
    spc_microfacet_type types[2] = {SPC_MICROFACET_GGX, SPC_MICROFACET_BECKMANN};
    for (int d = 0; d < 2; ++d) {
        spc_bsdf *b = mk_plastic(SPC_BSDF_ROUGHPLASTIC, types[d], 0.4, false);
        CHECK(b->coat_ready);
        const spc_bsdf *outside = mk_roughdielectric(types[d], 0.4, 0.4, eta, true);
        const spc_bsdf *inside = mk_roughdielectric(types[d], 0.4, 0.4, 1.0 / eta, true);
        const int idx[4] = {8, 32, 50, 63};
        for (int k = 0; k < 4; ++k) {
            double mu = (double)idx[k] / (SPC_ROUGHPLASTIC_TABLE_RES - 1);
            double t = interface_albedo(outside, mu, true, 200000, (uint64_t)(10 * d + k));
            /* MC standard deviation below 1e-3 (weights in [0, 1]); at alpha 0.4 T differs from
             * the smooth 1 - F(mu) by more than the tolerance at grazing cosines */
            CHECK_MSG(fabs(b->coat_t[idx[k]] - t) < 4e-3, "dist %d mu %.3f table %.5f MC %.5f", d, mu,
                      b->coat_t[idx[k]], t);
        }
        double smooth8 = 1.0 - spc_fresnel_dielectric(8.0 / 63.0, eta, NULL, NULL);
        CHECK_MSG(fabs(b->coat_t[8] - smooth8) > 0.02, "alpha 0.4 T(0.127) %.4f equals smooth %.4f", b->coat_t[8],
                  smooth8);
        /* internal reflectance: cosine-weighted mean over mu ~ 2 mu of the reflected energy */
        spc_rng rng;
        spc_rng_seed(&rng, 43, (uint64_t)d);
        double fdr = 0.0;
        const int nmu = 400;
        for (int i = 0; i < nmu; ++i)
            fdr += interface_albedo(inside, sqrt(spc_rng_next(&rng)), false, 2000, (uint64_t)(100 + i));
        fdr /= nmu;
        CHECK_MSG(fabs(b->coat_fdr_int - fdr) < 0.02, "dist %d fdr table %.4f MC %.4f", d, b->coat_fdr_int, fdr);
        /* smooth limit */
        spc_bsdf *s = mk_plastic(SPC_BSDF_ROUGHPLASTIC, types[d], 1e-3, false);
        CHECK(s->coat_ready);
        for (int k = 4; k < SPC_ROUGHPLASTIC_TABLE_RES; k += 8) {
            double mu = (double)k / (SPC_ROUGHPLASTIC_TABLE_RES - 1);
            CHECK_NEAR(s->coat_t[k], 1.0 - spc_fresnel_dielectric(mu, eta, NULL, NULL), 2e-3);
        }
        CHECK_NEAR(s->coat_fdr_int, spc_fresnel_diffuse_reflectance(1.0 / eta), 0.02);
    }
    /* eval uses the tables: the diffuse part at normal incidence both ways */
    spc_hit h = make_hit(spc_v3(0, 0, 1));
    spc_bsdf *b = mk_plastic(SPC_BSDF_ROUGHPLASTIC, SPC_MICROFACET_GGX, 0.3, false);
    b->specular_reflectance = tex1(0.0);
    spc_vec3 n = h.sh.n;
    double want = 0.7 / (1.0 - b->coat_fdr_int) * b->coat_t[63] * b->coat_t[63] / (SPC_PI * eta * eta);
    CHECK_NEAR(spc_bsdf_eval(b, &h, SPC_MODE_RADIANCE, n, n).r, want, 1e-9);
    /* a textured alpha: no tables */
    spc_texture *checker = &tex_pool[tex_used++];
    *checker = *tex1(0.3);
    checker->type = SPC_TEX_CHECKERBOARD;
    b->alpha_u = b->alpha_v = checker;
    spc_bsdf_prepare(b);
    CHECK(!b->coat_ready);
}

TEST(test_twosided)
{
    spc_hit h = default_hit();
    spc_bsdf *rc = mk_roughconductor(SPC_MICROFACET_GGX, 0.1, 0.4, true, false);
    spc_bsdf *d = mk_diffuse(0.2, 0.2, 0.2);
    spc_bsdf *ts1 = mk_wrap(SPC_BSDF_TWOSIDED, rc, NULL), *ts2 = mk_wrap(SPC_BSDF_TWOSIDED, rc, d);
    spc_rng rng;
    spc_rng_seed(&rng, 37, 0);
    for (int i = 0; i < 50; ++i) {
        spc_vec3 lo = spc_warp_uniform_hemisphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)));
        spc_vec3 li = spc_warp_uniform_hemisphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)));
        spc_vec3 wo = spc_frame_to_world(&h.sh, lo), wi = spc_frame_to_world(&h.sh, li);
        /* the back-side image of a local direction (x, y, z) in the flipped frame (s, -t, -n) */
        spc_vec3 wob = spc_frame_to_world(&h.sh, spc_v3(lo.x, -lo.y, -lo.z));
        spc_vec3 wib = spc_frame_to_world(&h.sh, spc_v3(li.x, -li.y, -li.z));
        spc_rgb front = spc_bsdf_eval(rc, &h, SPC_MODE_RADIANCE, wo, wi);
        CHECK(rgb_rel_diff(spc_bsdf_eval(ts1, &h, SPC_MODE_RADIANCE, wo, wi), front) < 1e-12);
        CHECK(rgb_rel_diff(spc_bsdf_eval(ts1, &h, SPC_MODE_RADIANCE, wob, wib), front) < 1e-12);
        CHECK_NEAR(spc_bsdf_pdf(ts1, &h, SPC_MODE_RADIANCE, wob, wib), spc_bsdf_pdf(rc, &h, SPC_MODE_RADIANCE, wo, wi), 1e-9);
        CHECK_NEAR(spc_bsdf_eval(ts2, &h, SPC_MODE_RADIANCE, wob, wib).r, 0.2 / SPC_PI, 1e-12);
        CHECK(spc_rgb_is_black(spc_bsdf_eval(ts2, &h, SPC_MODE_RADIANCE, wob, wi)));
    }
    spc_bsdf_sample s;
    CHECK(spc_bsdf_sample_dir(ts1, &h, SPC_MODE_RADIANCE, dir(&h, 120, 0), 0.5, spc_v2(0.5, 0.5), &s));
    CHECK(spc_dot(s.wi, h.sh.n) < 0.0);
}

TEST(test_mask_null_blend)
{
    spc_hit h = default_hit();
    spc_bsdf *d = mk_diffuse(0.6, 0.6, 0.6);
    spc_bsdf *m = mk_wrap(SPC_BSDF_MASK, d, NULL);
    m->opacity = tex1(0.3);
    spc_vec3 wo = dir(&h, 20, 0), wi = dir(&h, 50, 100);
    CHECK_NEAR(spc_bsdf_eval(m, &h, SPC_MODE_RADIANCE, wo, wi).r, 0.3 * 0.6 / SPC_PI, 1e-12);
    CHECK_NEAR(spc_bsdf_pdf(m, &h, SPC_MODE_RADIANCE, wo, wi), 0.3 * cos(50 * SPC_PI / 180) / SPC_PI, 1e-12);
    spc_bsdf_sample s;
    CHECK(spc_bsdf_sample_dir(m, &h, SPC_MODE_RADIANCE, wo, 0.5, spc_v2(0.5, 0.5), &s));
    CHECK(s.lobe == SPC_LOBE_NULL && s.weight.r == 1.0 && s.eta == 1.0);
    CHECK_NEAR(s.pdf, 0.7, 1e-12);
    CHECK_NEAR(spc_distance(s.wi, spc_neg(wo)), 0.0, 1e-15);
    CHECK(spc_bsdf_sample_dir(m, &h, SPC_MODE_RADIANCE, wo, 0.1, spc_v2(0.5, 0.5), &s));
    CHECK(s.lobe == SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK_NEAR(s.weight.r, 0.6, 1e-12);
    CHECK_NEAR(s.pdf, 0.3 * spc_dot(s.wi, h.sh.n) / SPC_PI, 1e-12);
    /* null */
    spc_bsdf *nb = new_bsdf(SPC_BSDF_NULL);
    CHECK(spc_bsdf_sample_dir(nb, &h, SPC_MODE_RADIANCE, wo, 0.5, spc_v2(0.5, 0.5), &s));
    CHECK(s.lobe == SPC_LOBE_NULL && s.pdf == 1.0 && s.weight.g == 1.0);
    CHECK(spc_bsdf_flags(nb) == SPC_LOBE_NULL && spc_bsdf_is_delta_only(nb));
    /* blend of a diffuse and a mirror: eval is the weighted diffuse, delta samples keep their weight */
    spc_bsdf *c = new_bsdf(SPC_BSDF_CONDUCTOR);
    spc_bsdf *bl = mk_wrap(SPC_BSDF_BLENDBSDF, d, c);
    bl->weight = tex1(0.25);
    CHECK_NEAR(spc_bsdf_eval(bl, &h, SPC_MODE_RADIANCE, wo, wi).r, 0.75 * 0.6 / SPC_PI, 1e-12);
    CHECK(spc_bsdf_sample_dir(bl, &h, SPC_MODE_RADIANCE, wo, 0.1, spc_v2(0.5, 0.5), &s));
    CHECK(s.lobe == SPC_LOBE_DELTA_REFLECTION);
    CHECK_NEAR(s.pdf, 0.25, 1e-12);
    CHECK_NEAR(s.weight.r, 1.0, 1e-12);
    CHECK(spc_bsdf_sample_dir(bl, &h, SPC_MODE_RADIANCE, wo, 0.6, spc_v2(0.5, 0.5), &s));
    CHECK(s.lobe == SPC_LOBE_DIFFUSE_REFLECTION);
    CHECK_NEAR(s.weight.r, 0.6, 1e-12);
    /* the mean sample weight is the mixture of the albedos, 0.75 * 0.6 + 0.25 * 1 (Mitsuba 3.9.1's
     * blend mixes the diffuse density into the delta sample's pdf and falls below it:
     * tests/validation/blendbsdf_delta_mitsuba.py) */
    spc_rng rng;
    spc_rng_seed(&rng, 11, 0);
    double sum = 0.0;
    const int N = 20000;
    for (int i = 0; i < N; ++i) {
        double ul = spc_rng_next(&rng);
        spc_vec2 u = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
        if (spc_bsdf_sample_dir(bl, &h, SPC_MODE_RADIANCE, wo, ul, u, &s))
            sum += s.weight.r;
    }
    CHECK_NEAR(sum / N, 0.75 * 0.6 + 0.25 * 1.0, 0.005); /* standard error 0.0012 */
}

/* Mitsuba 3.9's bump-terminator shadowing G1(w) for perturbed normals (Conty Estevez et al. 2019):
 * alpha^2 = tan^2(delta) / 8 (delta between the normals, clamped to 1), G1 = 2 / (1 + sqrt(1 +
 * alpha^2 tan^2 theta_w)), theta_w measured from the original normal. */
static double bump_g1(spc_vec3 n, spc_vec3 np, spc_vec3 w)
{
    double cd = spc_dot(n, np), a2 = (1 - cd * cd) / (8 * cd * cd), c = fabs(spc_dot(w, n));
    if (a2 > 1)
        a2 = 1;
    return 2 / (1 + sqrt(1 + a2 * (1 - c * c) / (c * c)));
}

/* A tangent-space normal (0,0,1) changes nothing; a tilted one evaluates the nested BSDF in the
 * tilted frame, rescaled by the cosine ratio and Mitsuba 3.9's shadowing term; a viewer below the
 * tilted normal (but above the surface) sees it turned by 180 degrees about the surface normal. */
TEST(test_normalmap)
{
    spc_hit h = default_hit();
    spc_bsdf *rc = mk_roughconductor(SPC_MICROFACET_GGX, 0.3, 0.3, true, false);
    spc_bsdf *flat = mk_wrap(SPC_BSDF_NORMALMAP, rc, NULL);
    flat->normalmap = tex3(0.5, 0.5, 1.0);
    spc_vec3 wo = dir(&h, 30, 20), wi = dir(&h, 40, 210);
    CHECK(rgb_rel_diff(spc_bsdf_eval(flat, &h, SPC_MODE_RADIANCE, wo, wi), spc_bsdf_eval(rc, &h, SPC_MODE_RADIANCE, wo, wi)) < 1e-12);
    spc_bsdf *tilt = mk_wrap(SPC_BSDF_NORMALMAP, rc, NULL);
    double nx = 0.4, nz = sqrt(1 - nx * nx);
    tilt->normalmap = tex3(0.5 * (nx + 1), 0.5, 0.5 * (nz + 1));
    spc_hit ht = h;
    ht.sh = spc_frame_from_ns(spc_normalize(spc_add(spc_scale(h.sh.s, nx), spc_scale(h.sh.n, nz))), h.sh.s);
    spc_rgb expect = spc_rgb_scale(spc_bsdf_eval(rc, &ht, SPC_MODE_RADIANCE, wo, wi),
                                   spc_dot(wi, ht.sh.n) / spc_dot(wi, h.sh.n) * bump_g1(h.sh.n, ht.sh.n, wi));
    CHECK(bump_g1(h.sh.n, ht.sh.n, wi) < 0.999);
    CHECK(rgb_rel_diff(spc_bsdf_eval(tilt, &h, SPC_MODE_RADIANCE, wo, wi), expect) < 1e-9);
    /* below the perturbed horizon but above the original one: zero */
    spc_vec3 w_edge = spc_normalize(spc_add(spc_scale(h.sh.s, -0.9), spc_scale(h.sh.n, 0.2)));
    CHECK(spc_rgb_is_black(spc_bsdf_eval(tilt, &h, SPC_MODE_RADIANCE, wo, w_edge)));
    /* the viewer below the tilted normal: the normal tilts the other way, (-nx, 0, nz) */
    spc_hit hr = h;
    hr.sh = spc_frame_from_ns(spc_normalize(spc_add(spc_scale(h.sh.s, -nx), spc_scale(h.sh.n, nz))), h.sh.s);
    spc_vec3 wi2 = dir(&h, 30, 180);
    spc_rgb expect2 = spc_rgb_scale(spc_bsdf_eval(rc, &hr, SPC_MODE_RADIANCE, w_edge, wi2),
                                    spc_dot(wi2, hr.sh.n) / spc_dot(wi2, h.sh.n) * bump_g1(h.sh.n, hr.sh.n, wi2));
    spc_rgb got2 = spc_bsdf_eval(tilt, &h, SPC_MODE_RADIANCE, w_edge, wi2);
    CHECK(!spc_rgb_is_black(got2));
    CHECK_MSG(rgb_rel_diff(got2, expect2) < 1e-9, "got %g expected %g", got2.r, expect2.r);
}

/* The light side's correction under a normal map (spc_bsdf_adjoint_factor): where neither
 * direction turns the map's normal, the importance-mode value from l (toward the light) to c
 * (toward the camera), times |c.N| and the factor, is the radiance-mode value the camera's paths
 * carry from c to l, times |l.N| |c.ng| / |l.ng| (Veach 1997, eq. 5.20, with the map's normal
 * and its shadowing term); the surface's own normal in the correction misses it. Under a twosided
 * too. spc_bsdf_perturbs: normalmap and bumpmap, also under a twosided; not a plain diffuse. */
TEST(test_normalmap_adjoint)
{
    spc_hit h = default_hit();
    h.ng = spc_normalize(spc_add(h.sh.n, spc_scale(h.sh.t, 0.15))); /* a smooth-shaded surface */
    spc_bsdf *d = mk_diffuse(0.6, 0.5, 0.4);
    spc_bsdf *nm = mk_wrap(SPC_BSDF_NORMALMAP, d, NULL);
    double nx = 0.35, nz = sqrt(1 - nx * nx);
    nm->normalmap = tex3(0.5 * (nx + 1), 0.5, 0.5 * (nz + 1));
    spc_bsdf *ts = mk_wrap(SPC_BSDF_TWOSIDED, nm, NULL);
    CHECK(spc_bsdf_perturbs(nm) && spc_bsdf_perturbs(ts) && !spc_bsdf_perturbs(d) && !spc_bsdf_perturbs(NULL));
    spc_bsdf *bsdfs[2] = {nm, ts};
    const double ang[4][4] = {{20, 10, 50, 200}, {60, 0, 15, 90}, {35, 300, 70, 160}, {10, 45, 40, 20}};
    int checked = 0, plain_off = 0;
    for (int k = 0; k < 2; ++k)
        for (int i = 0; i < 4; ++i) {
            h.bsdf = bsdfs[k]; /* the factor reads the hit's BSDF, as a scene's hit carries it */
            spc_vec3 l = dir(&h, ang[i][0], ang[i][1]), c = dir(&h, ang[i][2], ang[i][3]);
            spc_rgb fr = spc_bsdf_eval(bsdfs[k], &h, SPC_MODE_RADIANCE, c, l);
            spc_rgb fi = spc_bsdf_eval(bsdfs[k], &h, SPC_MODE_IMPORTANCE, l, c);
            if (spc_rgb_is_black(fr) || spc_rgb_is_black(fi))
                continue;
            spc_rgb want = spc_rgb_scale(fr, spc_absdot(l, h.sh.n) * spc_absdot(c, h.ng) / spc_absdot(l, h.ng));
            spc_rgb got = spc_rgb_scale(fi, spc_absdot(c, h.sh.n) * spc_bsdf_adjoint_factor(&h, l, c));
            spc_rgb plain = spc_rgb_scale(fi, spc_absdot(c, h.sh.n) * spc_bsdf_shading_adjoint(l, c, h.ng, h.sh.n));
            CHECK_MSG(rgb_rel_diff(got, want) < 1e-9, "case %d/%d: got %g want %g", k, i, got.r, want.r);
            plain_off += rgb_rel_diff(plain, want) > 0.02;
            ++checked;
        }
    CHECK_MSG(checked >= 6 && plain_off >= checked - 1, "%d pairs checked, the plain correction off on %d", checked,
              plain_off);
}

/* Bump map with a height ramp along u: slope 2 scale in uv, flat hit with dpdu = s, dpdv = t. */
TEST(test_bumpmap)
{
    spc_hit h = make_hit(spc_v3(0, 0, 1));
    h.uv = spc_v2(0.5, 0.5);
    static float data[6] = {0, 0, 0, 1, 1, 1};
    spc_texture ramp;
    memset(&ramp, 0, sizeof ramp);
    ramp.type = SPC_TEX_BITMAP;
    ramp.width = 2;
    ramp.height = 1;
    ramp.data = data;
    ramp.wrap = SPC_WRAP_CLAMP;
    ramp.to_uv[0][0] = ramp.to_uv[1][1] = 1.0;
    spc_bsdf *rc = mk_roughconductor(SPC_MICROFACET_BECKMANN, 0.2, 0.2, true, true);
    spc_bsdf *bm = mk_wrap(SPC_BSDF_BUMPMAP, rc, NULL);
    bm->bump = &ramp;
    bm->bump_scale = 0.1;
    /* H = 0.1 * (2 u - 0.5) near u = 0.5: dH/du = 0.2; n' ~ (-0.2, 0, 1) */
    spc_hit ht = h;
    ht.sh = spc_frame_from_ns(spc_normalize(spc_sub(h.sh.n, spc_scale(h.sh.s, 0.2))), h.sh.s);
    spc_vec3 wo = dir(&h, 30, 0), wi = dir(&h, 35, 180);
    spc_rgb expect = spc_rgb_scale(spc_bsdf_eval(rc, &ht, SPC_MODE_RADIANCE, wo, wi),
                                   spc_dot(wi, ht.sh.n) / spc_dot(wi, h.sh.n) * bump_g1(h.sh.n, ht.sh.n, wi));
    spc_rgb got = spc_bsdf_eval(bm, &h, SPC_MODE_RADIANCE, wo, wi);
    CHECK_MSG(rgb_rel_diff(got, expect) < 1e-9, "got %g expected %g", got.r, expect.r);
    CHECK(rgb_rel_diff(got, spc_bsdf_eval(rc, &h, SPC_MODE_RADIANCE, wo, wi)) > 1e-3);
    /* a constant height changes nothing */
    bm->bump = tex1(0.7);
    CHECK(rgb_rel_diff(spc_bsdf_eval(bm, &h, SPC_MODE_RADIANCE, wo, wi), spc_bsdf_eval(rc, &h, SPC_MODE_RADIANCE, wo, wi)) < 1e-12);
}

/* ------------------------------------------------------------------------------------------ */
/* 2 and 3: consistency and chi-square over a list of configurations                          */

#define MAX_CASES 64
static chi2_case cases[MAX_CASES];
static int n_cases;

static void add_case(const char *name, const spc_bsdf *b, double theta_deg, double phi_deg, spc_transport mode)
{
    double t = theta_deg * SPC_PI / 180, p = phi_deg * SPC_PI / 180;
    chi2_case c = {name, b, NULL, 0.0, spc_v3(sin(t) * cos(p), sin(t) * sin(p), cos(t)), mode};
    cases[n_cases++] = c;
}

static void build_cases(void)
{
    if (n_cases)
        return;
    spc_microfacet_type G = SPC_MICROFACET_GGX, B = SPC_MICROFACET_BECKMANN;
    spc_transport R = SPC_MODE_RADIANCE;
    add_case("diffuse wo 30", mk_diffuse(0.5, 0.5, 0.5), 30, 20, R);
    add_case("diffuse wo 85", mk_diffuse(0.5, 0.5, 0.5), 85, 200, R);
    add_case("roughdiffuse alpha 0.6", mk_roughdiffuse(0.7, 0.6), 60, 0, R);
    add_case("phong n 30", mk_phong(0.5, 0.3, 30.0), 40, 10, R);
    add_case("phong n 200 grazing", mk_phong(0.2, 0.6, 200.0), 80, 10, R);
    add_case("phong n 2", mk_phong(0.2, 0.6, 2.0), 20, 90, R);
    add_case("roughconductor ggx 0.1", mk_roughconductor(G, 0.1, 0.1, true, false), 40, 30, R);
    add_case("roughconductor ggx 0.5 wo 75", mk_roughconductor(G, 0.5, 0.5, true, false), 75, 30, R);
    add_case("roughconductor ggx aniso 0.08/0.4", mk_roughconductor(G, 0.08, 0.4, true, false), 50, 60, R);
    add_case("roughconductor ggx 1.0 normal", mk_roughconductor(G, 1.0, 1.0, true, true), 0, 0, R);
    add_case("roughconductor ggx 0.3 all normals", mk_roughconductor(G, 0.3, 0.3, false, true), 60, 45, R);
    add_case("roughconductor beckmann 0.1", mk_roughconductor(B, 0.1, 0.1, true, false), 40, 30, R);
    add_case("roughconductor beckmann 0.5 wo 80", mk_roughconductor(B, 0.5, 0.5, true, false), 80, 120, R);
    add_case("roughconductor beckmann aniso 0.4/0.1", mk_roughconductor(B, 0.4, 0.1, true, true), 55, 20, R);
    add_case("roughconductor beckmann 0.3 all normals", mk_roughconductor(B, 0.3, 0.2, false, true), 30, 300, R);
    add_case("roughdielectric ggx 0.3 eta 1.5 out", mk_roughdielectric(G, 0.3, 0.3, 1.5, true), 40, 0, R);
    add_case("roughdielectric ggx 0.3 eta 1.5 in", mk_roughdielectric(G, 0.3, 0.3, 1.5, true), 140, 0, R);
    add_case("roughdielectric ggx 0.2 eta 1/1.5 out", mk_roughdielectric(G, 0.2, 0.2, 1 / 1.5, true), 30, 70, R);
    add_case("roughdielectric ggx 0.2 eta 1/1.5 in", mk_roughdielectric(G, 0.2, 0.2, 1 / 1.5, true), 120, 70, R);
    add_case("roughdielectric ggx aniso eta 1.33 in grazing", mk_roughdielectric(G, 0.1, 0.5, 1.33, true), 100, 10, R);
    add_case("roughdielectric beckmann 0.2 eta 1.5 out", mk_roughdielectric(B, 0.2, 0.2, 1.5, true), 60, 0, R);
    add_case("roughdielectric beckmann 0.4 eta 1.5 in", mk_roughdielectric(B, 0.4, 0.4, 1.5, true), 170, 0, R);
    add_case("roughdielectric beckmann all normals", mk_roughdielectric(B, 0.3, 0.3, 1.5, false), 50, 0, R);
    add_case("roughdielectric ggx all normals in", mk_roughdielectric(G, 0.3, 0.3, 1.5, false), 130, 0, R);
    add_case("plastic (smooth part)", mk_plastic(SPC_BSDF_PLASTIC, G, 0.1, false), 50, 0, R);
    add_case("roughplastic ggx 0.2", mk_plastic(SPC_BSDF_ROUGHPLASTIC, G, 0.2, false), 45, 0, R);
    add_case("roughplastic beckmann 0.1 nonlinear", mk_plastic(SPC_BSDF_ROUGHPLASTIC, B, 0.1, true), 70, 0, R);
    add_case("pplastic ggx 0.2", mk_plastic(SPC_BSDF_PPLASTIC, G, 0.2, false), 45, 0, R);
    add_case("pplastic beckmann 0.06 grazing", mk_plastic(SPC_BSDF_PPLASTIC, B, 0.06, false), 75, 30, R);
    spc_bsdf *bl = mk_wrap(SPC_BSDF_BLENDBSDF, mk_diffuse(0.5, 0.5, 0.5), mk_roughconductor(G, 0.2, 0.2, true, false));
    bl->weight = tex1(0.7);
    add_case("blendbsdf diffuse/ggx", bl, 35, 0, R);
    spc_bsdf *bl2 = mk_wrap(SPC_BSDF_BLENDBSDF, mk_roughdielectric(B, 0.3, 0.3, 1.5, true), new_bsdf(SPC_BSDF_CONDUCTOR));
    add_case("blendbsdf roughdielectric/mirror", bl2, 25, 0, R);
    add_case("twosided back ggx", mk_wrap(SPC_BSDF_TWOSIDED, mk_roughconductor(G, 0.2, 0.5, true, false), NULL), 130, 40, R);
    add_case("twosided back diffuse", mk_wrap(SPC_BSDF_TWOSIDED, mk_roughconductor(G, 0.2, 0.2, true, false),
                                              mk_diffuse(0.5, 0.5, 0.5)), 160, 40, R);
    spc_bsdf *mk = mk_wrap(SPC_BSDF_MASK, mk_roughconductor(B, 0.3, 0.3, true, false), NULL);
    mk->opacity = tex1(0.6);
    add_case("mask beckmann", mk, 45, 0, R);
    spc_bsdf *nm = mk_wrap(SPC_BSDF_NORMALMAP, mk_roughconductor(G, 0.3, 0.3, true, false), NULL);
    nm->normalmap = tex3(0.7, 0.4, 0.9);
    add_case("normalmap ggx", nm, 30, 180, R);
    spc_bsdf *nmd = mk_wrap(SPC_BSDF_NORMALMAP, mk_plastic(SPC_BSDF_ROUGHPLASTIC, G, 0.3, false), NULL);
    nmd->normalmap = tex3(0.3, 0.6, 0.8);
    add_case("normalmap roughplastic", nmd, 60, 90, R);
    /* a height ramp along u (2 texels, bilinear): dH/du = 2 scale at the default hit's uv */
    static float ramp_data[6] = {0, 0, 0, 1, 1, 1};
    static spc_texture ramp;
    memset(&ramp, 0, sizeof ramp);
    ramp.type = SPC_TEX_BITMAP;
    ramp.width = 2;
    ramp.height = 1;
    ramp.data = ramp_data;
    ramp.wrap = SPC_WRAP_CLAMP;
    ramp.to_uv[0][0] = ramp.to_uv[1][1] = 1.0;
    spc_bsdf *bm = mk_wrap(SPC_BSDF_BUMPMAP, mk_roughconductor(B, 0.25, 0.25, true, false), NULL);
    bm->bump = &ramp;
    bm->bump_scale = 0.3;
    add_case("bumpmap beckmann", bm, 50, 0, R);
}

TEST(test_sample_consistency)
{
    build_cases();
    spc_hit h = default_hit();
    for (int k = 0; k < n_cases; ++k) {
        const chi2_case *c = &cases[k];
        /* the case's wo and two more on the same side */
        spc_vec3 wos[3];
        wos[0] = spc_frame_to_world(&h.sh, spc_normalize(c->wo_local));
        double side = c->wo_local.z >= 0 ? 1.0 : -1.0;
        wos[1] = spc_frame_to_world(&h.sh, spc_normalize(spc_v3(0.2, 0.1, side)));
        wos[2] = spc_frame_to_world(&h.sh, spc_normalize(spc_v3(-0.8, 0.5, 0.3 * side)));
        spc_rng rng;
        spc_rng_seed(&rng, 41, (uint64_t)k);
        double worst_w = 0.0, worst_p = 0.0;
        int smooth = 0, bad_lobe = 0;
        unsigned flags = spc_bsdf_flags(c->b);
        for (int j = 0; j < 3; ++j) {
            for (int i = 0; i < 3000; ++i) {
                spc_bsdf_sample s;
                if (!spc_bsdf_sample_dir(c->b, &h, c->mode, wos[j], spc_rng_next(&rng),
                                         spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &s))
                    continue;
                if (!(s.lobe & flags) || (s.lobe & (s.lobe - 1)))
                    ++bad_lobe;
                if (s.lobe & SPC_LOBE_DELTA)
                    continue;
                ++smooth;
                spc_rgb f = spc_bsdf_eval(c->b, &h, c->mode, wos[j], s.wi);
                double pdf = spc_bsdf_pdf(c->b, &h, c->mode, wos[j], s.wi);
                spc_rgb w = spc_rgb_scale(f, spc_absdot(s.wi, h.sh.n) / pdf);
                worst_w = spc_max(worst_w, rgb_rel_diff(w, s.weight));
                worst_p = spc_max(worst_p, fabs(pdf - s.pdf) / s.pdf);
            }
        }
        CHECK_MSG(worst_w < 1e-6, "%s: weight vs eval cos / pdf, rel %g", c->name, worst_w);
        CHECK_MSG(worst_p < 1e-6, "%s: pdf() vs sample pdf, rel %g", c->name, worst_p);
        CHECK_MSG(bad_lobe == 0, "%s: %d samples with a lobe outside the flags", c->name, bad_lobe);
        CHECK_MSG(smooth > 1000, "%s: only %d smooth samples", c->name, smooth);
    }
}

/* The Beckmann visible-normal sample inverts its CDFs exactly (to double precision), so that the
 * pdf MIS uses is the density of what is drawn: for alpha 1 the sampled normal's slopes, rotated
 * into the incidence's azimuth, give back u. The visible x-slope's CDF
 * F(x) = sqrt(pi)/2 erfc(-x) + tan(t)/2 exp(-x^2) (from the search's lower end, normalized by its
 * mass up to min(cot t, 10)) at x equals u.x, and erf(y) = 2 u.y - 1, within 1e-11 of the mass,
 * from normal to grazing incidence and at u in the body and in the tails' end cells. */
TEST(test_beckmann_visible_inversion_exact)
{
    spc_microfacet md = spc_microfacet_make(SPC_MICROFACET_BECKMANN, 1.0, 1.0, true);
    spc_rng rng;
    spc_rng_seed(&rng, 43, 1);
    const double thetas[] = {0.01, 0.3, 0.8, 1.2, 1.5, 1.569};
    const double ends[] = {1e-9, 1e-4, 0.002, 0.9977, 0.9999, 1.0 - 1e-9};
    double worst_x = 0.0, worst_y = 0.0;
    for (int k = 0; k < 6; ++k) {
        double st = sin(thetas[k]), ct = cos(thetas[k]), tan_t = st / ct;
        for (int i = 0; i < 4000; ++i) {
            double phi = 2.0 * SPC_PI * spc_rng_next(&rng);
            spc_vec3 w = spc_v3(st * cos(phi), st * sin(phi), ct);
            spc_vec2 u = spc_v2(i < 6 ? ends[i] : spc_rng_next(&rng), spc_rng_next(&rng));
            double pdf;
            spc_vec3 m = spc_microfacet_sample(&md, w, u, &pdf);
            CHECK(pdf > 0.0 && m.z > 0.0);
            double sx = -m.x / m.z, sy = -m.y / m.z, c = w.x / st, s = w.y / st;
            double x = c * sx + s * sy, y = -s * sx + c * sy;
            double lo = -10.0, hi = fmin(ct / st, 10.0);
            double F_lo = 0.5 * sqrt(SPC_PI) * erfc(-lo) + 0.5 * tan_t * exp(-lo * lo);
            double F_hi = 0.5 * sqrt(SPC_PI) * erfc(-hi) + 0.5 * tan_t * exp(-hi * hi);
            double F_x = 0.5 * sqrt(SPC_PI) * erfc(-x) + 0.5 * tan_t * exp(-x * x);
            worst_x = fmax(worst_x, fabs((F_x - F_lo) / (F_hi - F_lo) - u.x));
            double uy = spc_clamp(u.y, 1e-12, 1.0 - 1e-12);
            worst_y = fmax(worst_y, fabs(0.5 * (1.0 + erf(y)) - uy));
        }
    }
    CHECK_MSG(worst_x < 1e-11, "visible x-slope CDF off by %g", worst_x);
    CHECK_MSG(worst_y < 1e-11, "y-slope CDF off by %g", worst_y);
}

TEST(test_chi2_sampling)
{
    build_cases();
    spc_hit h = default_hit();
    int stride = spc_test_stride(n_cases);
    chi2_total_tests = (n_cases + stride - 1) / stride + 3; /* + the three checks of the rejection test */
    for (int k = 0; k < n_cases; k += stride) {
        double p = chi2_run(&cases[k], &h, CHI_SAMPLES, 1000 + (uint64_t)k, true);
        CHECK_MSG(bsdf_chi2_accept(p), "%s: sampling does not follow pdf(), p = %g", cases[k].name, p);
    }
}

/* The chi-square routine must be able to fail: a pdf 20% too large, a slightly wrong roughness,
 * and the wrong distribution are all rejected. */
TEST(test_chi2_rejects_wrong_pdf)
{
    spc_hit h = default_hit();
    chi2_total_tests = n_cases + 3;
    spc_bsdf *a = mk_roughconductor(SPC_MICROFACET_GGX, 0.3, 0.3, true, false);
    spc_bsdf *a2 = mk_roughconductor(SPC_MICROFACET_GGX, 0.33, 0.33, true, false);
    spc_bsdf *bk = mk_roughconductor(SPC_MICROFACET_BECKMANN, 0.3, 0.3, true, false);
    spc_vec3 wo = spc_v3(sin(0.6), 0, cos(0.6));
    chi2_case scaled = {"ggx pdf x 1.2", a, NULL, 1.2, wo, SPC_MODE_RADIANCE};
    chi2_case shifted = {"ggx samples 0.3, pdf 0.33", a, a2, 0.0, wo, SPC_MODE_RADIANCE};
    chi2_case other = {"ggx samples, beckmann pdf", a, bk, 0.0, wo, SPC_MODE_RADIANCE};
    chi2_case right = {"ggx control", a, NULL, 0.0, wo, SPC_MODE_RADIANCE};
    CHECK(!bsdf_chi2_accept(chi2_run(&scaled, &h, CHI_SAMPLES, 77, true)));
    CHECK(!bsdf_chi2_accept(chi2_run(&shifted, &h, CHI_SAMPLES, 78, true)));
    CHECK(!bsdf_chi2_accept(chi2_run(&other, &h, CHI_SAMPLES, 79, true)));
    CHECK(bsdf_chi2_accept(chi2_run(&right, &h, CHI_SAMPLES, 80, true)));
    /* the incomplete gamma function itself: Q(1, x) = e^-x, Q(0.5, x) = erfc(sqrt x) */
    CHECK_NEAR(chi2_gamma_q(1.0, 0.7), exp(-0.7), 1e-12);
    CHECK_NEAR(chi2_gamma_q(1.0, 7.0), exp(-7.0), 1e-14);
    CHECK_NEAR(chi2_gamma_q(0.5, 2.3), erfc(sqrt(2.3)), 1e-12);
    CHECK_NEAR(chi2_gamma_q(0.5, 0.1), erfc(sqrt(0.1)), 1e-12);
    CHECK_NEAR(chi2_gamma_q(50.0, 50.0), 0.481191684528, 1e-9);
}

int main(void)
{
    RUN(test_flags);
    RUN(test_diffuse_closed_form);
    RUN(test_diffuse_energy);
    RUN(test_fresnel_dielectric);
    RUN(test_fresnel_conductor);
    RUN(test_fresnel_diffuse_reflectance);
    RUN(test_conductor);
    RUN(test_dielectric);
    RUN(test_thindielectric);
    RUN(test_roughdiffuse);
    RUN(test_phong_normalization);
    RUN(test_roughconductor_smooth_limit);
    RUN(test_roughconductor_furnace);
    RUN(test_roughconductor_narrow_lobe_cone);
    RUN(test_roughdielectric_energy);
    RUN(test_reciprocity);
    RUN(test_roughdielectric_adjoint);
    RUN(test_plastic);
    RUN(test_roughplastic_coating);
    RUN(test_twosided);
    RUN(test_mask_null_blend);
    RUN(test_normalmap);
    RUN(test_normalmap_adjoint);
    RUN(test_bumpmap);
    RUN(test_sample_consistency);
    RUN(test_beckmann_visible_inversion_exact);
    RUN(test_chi2_sampling);
    RUN(test_chi2_rejects_wrong_pdf);
    return spc_test_finish();
}
