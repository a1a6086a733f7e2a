/*
 * manifold/polyroots.h: real roots of univariate polynomials of small degree (the conic solver's
 * degree-6 chord polynomials and their derivatives; Freire 2021, shared/papers/003, sec. 6).
 *
 * Conventions: a polynomial of degree n is the array c[0..n] in the power basis, c[i] multiplying
 * t^i. Degrees up to SPC_POLY_MAX_DEGREE. Every function works in double precision, allocates
 * nothing and is safe to call from any thread.
 *
 * Root isolation is the Vincent-Collins-Akritas bisection (report sec. 6.1.1, Rouillier and
 * Zimmermann 2004): Descartes' rule of signs applied to (X+1)^n P(1/(X+1)) bounds the number of
 * roots in (0, 1); the interval is halved (2^n P(X/2) and its Taylor shift by 1, both O(n^2)) until
 * every piece holds a bound of 0 or 1. Sturm sequences count distinct roots exactly (in exact
 * arithmetic) and serve as the cross-check in the tests. Floating point: a root where P changes
 * sign is never lost (the first and last transformed coefficients are P at the interval's ends);
 * one within rounding of a bisection point or an end is reported there, possibly also by a
 * neighbouring interval; a cluster narrower than the bisection limit comes back as one interval
 * whose Descartes bound is above 1. A multiple root is ill-conditioned: rounding may turn it into
 * a complex pair and lose it, so multiple roots are isolated on the square-free part.
 */
#ifndef SPC_MANIFOLD_POLYROOTS_H
#define SPC_MANIFOLD_POLYROOTS_H

#include <stdbool.h>

/* Largest degree handled (chord polynomials are of degree 6; products and tests go higher). */
#define SPC_POLY_MAX_DEGREE 12

/* P(t) by Horner's rule. */
double spc_poly_eval(const double *c, int n, double t);
/* P(t), and P'(t) in *d (Horner's rule for both, report algorithm 3). */
double spc_poly_eval_deriv(const double *c, int n, double t, double *d);
/* The degree once exactly-zero leading coefficients are dropped; -1 for the zero polynomial. */
int spc_poly_degree(const double *c, int n);
/* d[0..n-1] = coefficients of P'. Returns n - 1 (or 0 for a constant, with d[0] = 0). */
int spc_poly_derivative(const double *c, int n, double *d);
/* out = a * b; returns na + nb. out must hold na + nb + 1 values and may not alias a or b. */
int spc_poly_mul(const double *a, int na, const double *b, int nb, double *out);

/* In place: c <- coefficients of P(X + s), by the Horner pyramid in O(n^2) (report sec. 6.1.1,
 * figure 23). */
void spc_poly_taylor_shift(double *c, int n, double s);
/* In place: c <- coefficients of P(s X). */
void spc_poly_scale_arg(double *c, int n, double s);
/* In place: c <- coefficients of X^n P(1/X) (the coefficients reversed). */
void spc_poly_reverse(double *c, int n);
/* Number of sign changes in c[0..n], zeros skipped (report definition 6.1). */
int spc_poly_sign_variations(const double *c, int n);
/* Descartes' bound on the number of roots in the open interval (0, 1), multiplicities counted:
 * the sign variations of (X+1)^n P(1/(X+1)). Exact when 0 or 1 (report theorem 6.2). */
int spc_poly_descartes01(const double *c, int n);

typedef struct spc_root_interval {
    double lo, hi; /* lo == hi: an exact root found on a bisection point or an end */
    int bound;     /* Descartes bound of the interval: 1 isolates a simple root; above 1 only when
                      the bisection limit was reached (a multiple root or a tight cluster) */
} spc_root_interval;

/* Isolates the real roots of P in [a, b] (a < b) by VCA bisection: writes disjoint intervals in
 * increasing order, at most max_out, and returns how many (more roots than max_out are dropped).
 * Returns -1 for the zero polynomial (every point is a root). */
int spc_poly_isolate(const double *c, int n, double a, double b, spc_root_interval *out, int max_out);

/* Refines the root in an isolating interval: safeguarded Newton (bisection fallback) where P
 * changes sign, Newton from the midpoint kept inside the interval otherwise. */
double spc_poly_refine(const double *c, int n, const spc_root_interval *iv);

/* Every real root of P in [a, b] (isolated, then refined), increasing, roots within 1e-10 of the
 * range merged; returns how many (at most max_out), -1 for the zero polynomial. */
int spc_poly_roots(const double *c, int n, double a, double b, double *roots, int max_out);

/* Sturm sequence P_0 = P, P_1 = P', P_{i+1} = -rem(P_{i-1}, P_i) (report definition 6.7), a
 * remainder counted as zero once its coefficients fall below rel_tol times the sequence's scale
 * (so a polynomial with multiple roots ends at their gcd, and the count is of distinct roots). */
typedef struct spc_sturm {
    int len;                                               /* number of polynomials */
    int deg[SPC_POLY_MAX_DEGREE + 1];
    double p[SPC_POLY_MAX_DEGREE + 1][SPC_POLY_MAX_DEGREE + 1];
} spc_sturm;

void spc_poly_sturm_init(spc_sturm *s, const double *c, int n, double rel_tol);
/* Sign changes of the sequence evaluated at t. */
int spc_poly_sturm_variations(const spc_sturm *s, double t);
/* Number of distinct real roots in (a, b] (report theorem 6.8). */
int spc_poly_sturm_count(const spc_sturm *s, double a, double b);

/* Greatest common divisor by Euclid's algorithm, remainders below rel_tol of the dividend's scale
 * counted as zero; normalized to a leading coefficient of 1. Returns its degree (0: coprime). */
int spc_poly_gcd(const double *a, int na, const double *b, int nb, double rel_tol, double *g);
/* q, r with a = q b + r, deg r < deg b; returns deg q (the degree of r goes to *nr). */
int spc_poly_divide(const double *a, int na, const double *b, int nb, double *q, double *r, int *nr);
/* Square-free part P / gcd(P, P') (its roots are P's distinct roots, each simple). Returns its
 * degree. */
int spc_poly_squarefree(const double *c, int n, double rel_tol, double *out);

#endif
