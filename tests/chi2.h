/*
 * tests/chi2.h: chi-square goodness-of-fit of a direction sampler against its own density
 * (solid angle), in the manner of Mitsuba's ChiSquareTest and pbrt's bsdfs_test: samples are
 * binned on a (cos theta, phi) grid of a frame, expected counts come from adaptive Simpson
 * integration of the density over each cell, cells expecting fewer than 5 are pooled, and the
 * p-value comes from the regularized incomplete gamma function.
 */
#ifndef SPC_TESTS_CHI2_H
#define SPC_TESTS_CHI2_H

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/math.h"
#include "core/rng.h"

/* Regularized upper incomplete gamma Q(a, x) = Gamma(a, x) / Gamma(a): the power series of
 * P(a, x) for x < a + 1, else the continued fraction of Gamma(a, x) (modified Lentz). */
static double chi2_gamma_q(double a, double x)
{
    if (x <= 0.0)
        return 1.0;
    double lg = lgamma(a);
    if (x < a + 1.0) {
        double term = 1.0 / a, sum = term;
        for (int n = 1; n < 100000; ++n) {
            term *= x / (a + n);
            sum += term;
            if (fabs(term) < fabs(sum) * 1e-16)
                break;
        }
        return 1.0 - sum * exp(-x + a * log(x) - lg);
    }
    const double tiny = 1e-300;
    double bcf = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / bcf, hcf = d;
    for (int i = 1; i < 100000; ++i) {
        double an = -i * (i - a);
        bcf += 2.0;
        d = an * d + bcf;
        if (fabs(d) < tiny)
            d = tiny;
        c = bcf + an / c;
        if (fabs(c) < tiny)
            c = tiny;
        d = 1.0 / d;
        double del = d * c;
        hcf *= del;
        if (fabs(del - 1.0) < 1e-16)
            break;
    }
    return exp(-x + a * log(x) - lg) * hcf;
}

typedef double (*chi2_integrand_fn)(double x, void *ctx);

static double chi2_simpson_rec(chi2_integrand_fn f, void *ctx, double a, double b, double fa, double fm, double fb,
                               double whole, double eps, int depth)
{
    double m = 0.5 * (a + b), lm = 0.5 * (a + m), rm = 0.5 * (m + b);
    double flm = f(lm, ctx), frm = f(rm, ctx);
    double left = (m - a) / 6.0 * (fa + 4.0 * flm + fm), right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    double delta = left + right - whole;
    if (depth <= 0 || fabs(delta) <= 15.0 * eps)
        return left + right + delta / 15.0;
    return chi2_simpson_rec(f, ctx, a, m, fa, flm, fm, left, 0.5 * eps, depth - 1) +
           chi2_simpson_rec(f, ctx, m, b, fm, frm, fb, right, 0.5 * eps, depth - 1);
}

/* Adaptive Simpson over [a, b] split first into `pieces` intervals (so narrow peaks are seen). */
static double chi2_integrate(chi2_integrand_fn f, void *ctx, double a, double b, int pieces, double eps, int depth)
{
    double sum = 0.0, w = (b - a) / pieces;
    for (int i = 0; i < pieces; ++i) {
        double x0 = a + i * w, x1 = x0 + w, xm = 0.5 * (x0 + x1);
        double f0 = f(x0, ctx), fm = f(xm, ctx), f1 = f(x1, ctx);
        double whole = w / 6.0 * (f0 + 4.0 * fm + f1);
        sum += chi2_simpson_rec(f, ctx, x0, x1, f0, fm, f1, whole, eps / pieces, depth);
    }
    return sum;
}

/* A sampler: one direction (world space, unit) or false for "no sample". */
typedef bool (*chi2_sample_fn)(void *user, spc_rng *rng, spc_vec3 *dir);
/* Its density in solid angle (world-space direction). */
typedef double (*chi2_pdf_fn)(void *user, spc_vec3 dir);

#define CHI2_NT 16 /* cells in cos theta over [-1, 1] */
#define CHI2_NP 32 /* cells in phi over [0, 2 pi) */
#define CHI2_NCELLS (CHI2_NT * CHI2_NP + 1) /* + the "no sample" cell */
#define CHI2_MIN_EXPECTED 5.0

typedef struct chi2_pdf_ctx {
    chi2_pdf_fn pdf;
    void *user;
    const spc_frame *frame;
    double cz, phi0, phi1, eps_inner;
} chi2_pdf_ctx;

static double chi2_pdf_at(chi2_pdf_ctx *c, double cz, double phi)
{
    double sz = spc_safe_sqrt(1.0 - cz * cz);
    return c->pdf(c->user, spc_frame_to_world(c->frame, spc_v3(sz * cos(phi), sz * sin(phi), cz)));
}
static double chi2_inner(double phi, void *ctx)
{
    chi2_pdf_ctx *c = ctx;
    return chi2_pdf_at(c, c->cz, phi);
}
static double chi2_outer(double cz, void *ctx)
{
    chi2_pdf_ctx *c = ctx;
    c->cz = cz;
    return chi2_integrate(chi2_inner, c, c->phi0, c->phi1, 2, c->eps_inner, 14);
}

/* Runs one test of n samples; returns the p-value (0 if a sample fell where the density is 0).
 * `frame` orients the grid (put its n where the density peaks). */
static double chi2_direction_test(const char *name, chi2_sample_fn sample, chi2_pdf_fn pdf, void *user,
                                  const spc_frame *frame, int n, uint64_t seed, bool verbose)
{
    static double obs[CHI2_NCELLS], expct[CHI2_NCELLS];
    memset(obs, 0, sizeof obs);
    spc_rng rng;
    spc_rng_seed(&rng, seed, 0x5eed);
    int n_hist = 0;
    for (int i = 0; i < n; ++i) {
        spc_vec3 d;
        if (!sample(user, &rng, &d))
            continue;
        spc_vec3 wl = spc_frame_to_local(frame, d);
        int it = (int)floor((spc_clamp(wl.z, -1.0, 1.0) + 1.0) * 0.5 * CHI2_NT);
        double phi = atan2(wl.y, wl.x);
        if (phi < 0.0)
            phi += 2.0 * SPC_PI;
        int ip = (int)floor(phi / (2.0 * SPC_PI) * CHI2_NP);
        it = it < 0 ? 0 : (it >= CHI2_NT ? CHI2_NT - 1 : it);
        ip = ip < 0 ? 0 : (ip >= CHI2_NP ? CHI2_NP - 1 : ip);
        obs[it * CHI2_NP + ip] += 1.0;
        ++n_hist;
    }
    obs[CHI2_NCELLS - 1] = n - n_hist;

    chi2_pdf_ctx c = {pdf, user, frame, 0.0, 0.0, 0.0, 0.0};
    double total = 0.0;
    for (int it = 0; it < CHI2_NT; ++it) {
        double c0 = -1.0 + 2.0 * it / CHI2_NT, c1 = -1.0 + 2.0 * (it + 1) / CHI2_NT;
        for (int ip = 0; ip < CHI2_NP; ++ip) {
            c.phi0 = 2.0 * SPC_PI * ip / CHI2_NP;
            c.phi1 = 2.0 * SPC_PI * (ip + 1) / CHI2_NP;
            c.eps_inner = 1e-7;
            double v = chi2_integrate(chi2_outer, &c, c0, c1, 2, 1e-8, 14);
            expct[it * CHI2_NP + ip] = v * n;
            total += v;
        }
    }
    expct[CHI2_NCELLS - 1] = (1.0 - total) * n;

    for (int i = 0; i < CHI2_NCELLS - 1; ++i) {
        if (expct[i] <= 0.0 && obs[i] > 0.0) {
            printf("  chi2 %s: %g samples in cell %d whose expected count is %g\n", name, obs[i], i, expct[i]);
            return 0.0;
        }
    }
    /* pool the cells expecting fewer than CHI2_MIN_EXPECTED, in increasing order of expectation */
    static int order[CHI2_NCELLS];
    for (int i = 0; i < CHI2_NCELLS; ++i)
        order[i] = i;
    for (int i = 1; i < CHI2_NCELLS; ++i) {
        int k = order[i], j = i - 1;
        while (j >= 0 && expct[order[j]] > expct[k]) {
            order[j + 1] = order[j];
            --j;
        }
        order[j + 1] = k;
    }
    double chi2 = 0.0, pool_obs = 0.0, pool_exp = 0.0;
    int dof = -1, pooled = 0;
    for (int r = 0; r < CHI2_NCELLS; ++r) {
        int i = order[r];
        double e = spc_max(expct[i], 0.0);
        if (e < CHI2_MIN_EXPECTED) {
            pool_obs += obs[i];
            pool_exp += e;
            ++pooled;
            if (pool_exp >= CHI2_MIN_EXPECTED) {
                chi2 += spc_sqr(pool_obs - pool_exp) / pool_exp;
                ++dof;
                pool_obs = pool_exp = 0.0;
            }
            continue;
        }
        chi2 += spc_sqr(obs[i] - e) / e;
        ++dof;
    }
    if (pool_exp > 0.0 || pool_obs > 0.0) {
        double e = spc_max(pool_exp, 1e-3);
        chi2 += spc_sqr(pool_obs - e) / e;
        ++dof;
    }
    if (dof < 1)
        dof = 1;
    double p = chi2_gamma_q(0.5 * dof, 0.5 * chi2);
    if (verbose)
        printf("  chi2 %-44s chi2 %9.1f dof %4d p %.4f (mass %.5f, pooled %d)\n", name, chi2, dof, p, total, pooled);
    return p;
}

/* Sidak-corrected acceptance at significance 0.01 over `ntests` tests. */
static bool chi2_accept(double p, int ntests)
{
    double alpha = 1.0 - pow(1.0 - 0.01, 1.0 / ntests);
    return p > alpha;
}

#endif
