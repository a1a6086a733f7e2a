/*
 * bsdf/microfacet.h: anisotropic GGX and Beckmann microfacet distributions (Walter et al. 2007,
 * "Microfacet Models for Refraction through Rough Surfaces"), shared by roughconductor,
 * roughdielectric and roughplastic.
 *
 * Conventions:
 * - Every vector is in the LOCAL shading frame: z is the macro-normal, x the direction of alpha_u,
 *   y the direction of alpha_v. Microfacet normals m always have m.z > 0.
 * - D is normalized so that the projected microfacet area is one: integral of D(m) m.z dm = 1.
 * - The masking-shadowing term is Smith's separable form G = G1(wo) G1(wi) (as Mitsuba), with the
 *   anisotropic Lambda functions of Heitz 2014 ("Understanding the Masking-Shadowing Function").
 * - Sampling draws m either from the distribution of visible normals seen from w,
 *   D_w(m) = G1(w, m) max(0, w.m) D(m) / w.z (Heitz 2018 for GGX; Heitz and d'Eon 2014 with a
 *   numerical inversion of the slope CDF for Beckmann), or, with sample_visible false, from
 *   D(m) m.z. Densities are with respect to solid angle of m.
 */
#ifndef SPC_BSDF_MICROFACET_H
#define SPC_BSDF_MICROFACET_H

#include "bsdf/bsdf.h"

/* Roughness below this is clamped: the distributions become numerically singular (Mitsuba uses
 * the same floor). */
#define SPC_MICROFACET_MIN_ALPHA 1e-4

/* The Beckmann visible x-slope's unnormalized CDF, sqrt(pi)/2 erfc(-x) + tan_t/2 exp(-x^2), is
 * sqrt(pi) in double at its upper end x >= this (with tan_t <= 1 / this, as x <= cot_t there):
 * erfc(-x) = 2 - erfc(x) rounds to 2 (erfc(6) = 2.2e-17, half an ulp of 2 is 2.2e-16), and the
 * second term is below 2e-17, under half an ulp of sqrt(pi) (1.1e-16). The sampler takes that value
 * without its exp and erfc; test_microfacet_fast checks the expression's bits over [this, 10]. */
#define SPC_BECKMANN_SLOPE_CDF_FLAT 6.0

typedef struct spc_microfacet {
    spc_microfacet_type type;
    double alpha_u, alpha_v;
    bool sample_visible;
} spc_microfacet;

/* A distribution with alphas clamped to [SPC_MICROFACET_MIN_ALPHA, inf). */
spc_microfacet spc_microfacet_make(spc_microfacet_type type, double alpha_u, double alpha_v, bool sample_visible);
/* The distribution of a rough variant at a hit: alpha_u, alpha_v (alpha_u if NULL) textures. */
spc_microfacet spc_microfacet_from_bsdf(const spc_bsdf *b, const spc_hit *h);

/* Normal distribution D(m) (solid angle of m); 0 for m.z <= 0. */
double spc_microfacet_d(const spc_microfacet *md, spc_vec3 m);
/* Smith's Lambda(w) for the direction w (any hemisphere; uses |w.z|). Beckmann's values below 2e-19
 * are returned as 0 (they leave G1 = 1 / (1 + Lambda) unchanged in double). */
double spc_microfacet_lambda(const spc_microfacet *md, spc_vec3 w);
/* Smith's G1(w, m): 0 when w is on the back of m relative to its side of the macro-surface. */
double spc_microfacet_g1(const spc_microfacet *md, spc_vec3 w, spc_vec3 m);
/* Separable masking-shadowing G1(wo, m) G1(wi, m). */
double spc_microfacet_g(const spc_microfacet *md, spc_vec3 wo, spc_vec3 wi, spc_vec3 m);
/* Samples a microfacet normal for the direction w (w.z > 0 required; callers flip w to the upper
 * hemisphere first). Returns m (m.z > 0) and its density in *pdf (0 means no sample). */
spc_vec3 spc_microfacet_sample(const spc_microfacet *md, spc_vec3 w, spc_vec2 u, double *pdf);
/* spc_microfacet_sample of n samples at once, lane i with md[i], w[i], u[i] into m[i], pdf[i]: the
 * same values. The Beckmann visible-normal samples among them share one slope search (below). */
void spc_microfacet_sample_many(int n, const spc_microfacet *md, const spc_vec3 *w, const spc_vec2 *u, spc_vec3 *m,
                                double *pdf);
/* The Beckmann visible x-slope for alpha = 1 of n samples (microfacet_many.c): x[i], on input the
 * search's guess, receives the root of F(x) = sqrt(pi)/2 erfc(-x) + tan_t/2 exp(-x^2) = u[i] F(hi)
 * on [-10, hi], hi = min(cot_t[i], 10) (F there within 5e-14 of its range of the exact root's). With
 * tan_t 0 and cot_t infinite that is the y-slope, erfinv(2u - 1). Each answer depends on its lane's
 * inputs only (the same bits for n = 1 and in any batch, under every vector ISA). */
void spc_beckmann_slope_x_many(int n, const double *u, const double *tan_t, const double *cot_t, double *x);
/* Density of spc_microfacet_sample producing m for the direction w (w may be in either
 * hemisphere; it is flipped to the upper one). */
double spc_microfacet_pdf(const spc_microfacet *md, spc_vec3 w, spc_vec3 m);
/* spc_microfacet_pdf for w with w.z > 0, given d = D(m) != 0 and, for visible-normal sampling,
 * g1w = G1(w, m) (unused otherwise): the same value, for callers that have both already. */
double spc_microfacet_pdf_given(const spc_microfacet *md, spc_vec3 w, spc_vec3 m, double d, double g1w);

#endif
