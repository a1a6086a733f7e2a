/*
 * manifold/polyroots.c: real-root isolation and refinement for polynomials of small degree.
 *
 * Implements Freire 2021 (shared/papers/003), sec. 6.1-6.2: the Vincent-Collins-Akritas bisection
 * (algorithm 1) with Descartes' rule of signs on T_1 R P (definition 6.3, theorem 6.2, corollary
 * 6.2.1), the O(n^2) Taylor shift of the Horner pyramid (definitions 6.5-6.6, figure 23, algorithm
 * 2), Sturm sequences (definition 6.7, theorem 6.8), Horner evaluation of P and P' (algorithm 3)
 * and Newton's method started from the secant of the isolating interval (sec. 6.2.4), here
 * safeguarded by bisection so that it never leaves the interval. The report leaves the bisection
 * stage and the treatment of multiple roots unimplemented (sec. 8.1-8.2); both are here, following
 * Rouillier and Zimmermann 2004 for the bisection and Euclid's algorithm for gcd(P, P').
 *
 * Scaling: every bisection level multiplies the coefficients by up to 2^n; each level renormalizes
 * by a power of two (exact), so no coefficient overflows or underflows and no rounding is added.
 */
#include "manifold/polyroots.h"

#include <math.h>
#include <string.h>

/* Bisection depth limit of VCA: intervals of 2^-52 of the search range are at the resolution of
 * a double; a Descartes bound still above 1 there is a multiple root or an unresolvable cluster. */
#define SPC_POLY_VCA_MAX_DEPTH 52
/* Iterations of the safeguarded Newton refinement: quadratic convergence needs a handful, the
 * bisection fallback at most ~60 to reach double resolution of any interval. */
#define SPC_POLY_REFINE_ITERATIONS 100
/* A value below this fraction of the sum of the coefficients' magnitudes is zero within the
 * rounding of the Taylor shifts that produced it (a few ulps per level of the pyramid). */
#define SPC_POLY_ZERO_EPS 1e-14
/* spc_poly_roots merges refined roots closer than this fraction of the search range (the same root
 * reported from both sides of a bisection point, within the refinement's accuracy). */
#define SPC_POLY_SAME_ROOT 1e-10

double spc_poly_eval(const double *c, int n, double t)
{
    double p = c[n];
    for (int i = n - 1; i >= 0; --i)
        p = p * t + c[i];
    return p;
}

double spc_poly_eval_deriv(const double *c, int n, double t, double *d)
{
    double p = c[n], dp = 0.0;
    for (int i = n - 1; i >= 0; --i) {
        dp = dp * t + p;
        p = p * t + c[i];
    }
    *d = dp;
    return p;
}

int spc_poly_degree(const double *c, int n)
{
    while (n >= 0 && c[n] == 0.0)
        --n;
    return n;
}

int spc_poly_derivative(const double *c, int n, double *d)
{
    if (n <= 0) {
        d[0] = 0.0;
        return 0;
    }
    for (int i = 1; i <= n; ++i)
        d[i - 1] = (double)i * c[i];
    return n - 1;
}

int spc_poly_mul(const double *a, int na, const double *b, int nb, double *out)
{
    for (int k = 0; k <= na + nb; ++k)
        out[k] = 0.0;
    for (int i = 0; i <= na; ++i)
        for (int j = 0; j <= nb; ++j)
            out[i + j] += a[i] * b[j];
    return na + nb;
}

void spc_poly_taylor_shift(double *c, int n, double s)
{
    /* row i of the pyramid: c[m] takes the values h^{j}_{k} with k + j = m (report fig. 23) */
    for (int i = 1; i <= n; ++i)
        for (int m = n - i; m <= n - 1; ++m)
            c[m] += s * c[m + 1];
}

void spc_poly_scale_arg(double *c, int n, double s)
{
    double p = s;
    for (int i = 1; i <= n; ++i, p *= s)
        c[i] *= p;
}

void spc_poly_reverse(double *c, int n)
{
    for (int i = 0, j = n; i < j; ++i, --j) {
        double t = c[i];
        c[i] = c[j];
        c[j] = t;
    }
}

int spc_poly_sign_variations(const double *c, int n)
{
    int v = 0, last = 0;
    for (int i = 0; i <= n; ++i) {
        int s = c[i] > 0.0 ? 1 : (c[i] < 0.0 ? -1 : 0);
        if (s == 0)
            continue;
        if (last != 0 && s != last)
            ++v;
        last = s;
    }
    return v;
}

int spc_poly_descartes01(const double *c, int n)
{
    double r[SPC_POLY_MAX_DEGREE + 1];
    for (int i = 0; i <= n; ++i)
        r[i] = c[n - i];
    spc_poly_taylor_shift(r, n, 1.0);
    return spc_poly_sign_variations(r, n);
}

static double clampd(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* Divides by the power of two nearest the largest coefficient (exact). */
static void normalize_pow2(double *c, int n)
{
    double m = 0.0;
    for (int i = 0; i <= n; ++i)
        m = fmax(m, fabs(c[i]));
    if (!(m > 0.0) || !isfinite(m))
        return;
    int e;
    frexp(m, &e);
    for (int i = 0; i <= n; ++i)
        c[i] = ldexp(c[i], -e);
}

typedef struct iso_ctx {
    spc_root_interval *out;
    int max_out, count;
} iso_ctx;

static void push(iso_ctx *x, double lo, double hi, int bound)
{
    if (x->count < x->max_out) {
        x->out[x->count].lo = lo;
        x->out[x->count].hi = hi;
        x->out[x->count].bound = bound;
    }
    x->count++;
}

/* Removes the roots at X = 0 (exact zeros of the constant coefficient); true if there was one. */
static bool deflate_zero(double *q, int *n)
{
    bool any = false;
    while (*n > 0 && q[0] == 0.0) {
        memmove(q, q + 1, (size_t)(*n) * sizeof *q);
        --*n;
        any = true;
    }
    return any;
}

/* True if q(0) is within the rounding error of evaluating q near 0: the sign of the constant
 * coefficient, on which Descartes' rule for both neighbouring intervals depends, is noise. */
static bool near_zero_at0(const double *q, int n)
{
    double s = 0.0;
    for (int i = 0; i <= n; ++i)
        s += fabs(q[i]);
    return fabs(q[0]) <= SPC_POLY_ZERO_EPS * s;
}

/* VCA on (lo, hi), q the polynomial with (lo, hi) mapped to (0, 1) (report algorithm 1). */
static void vca(const double *q, int n, double lo, double hi, int depth, iso_ctx *x)
{
    if (n <= 0)
        return;
    int v = spc_poly_descartes01(q, n);
    if (v == 0)
        return;
    if (v == 1) {
        push(x, lo, hi, 1);
        return;
    }
    double mid = 0.5 * (lo + hi);
    if (depth >= SPC_POLY_VCA_MAX_DEPTH || !(mid > lo && mid < hi)) {
        push(x, lo, hi, v);
        return;
    }
    double ql[SPC_POLY_MAX_DEGREE + 1], qr[SPC_POLY_MAX_DEGREE + 1];
    /* Q_L = 2^n P(X/2): roots of P in (0, 1/2) -> (0, 1) */
    for (int i = 0; i <= n; ++i)
        ql[i] = ldexp(q[i], n - i);
    normalize_pow2(ql, n);
    /* Q_R = Q_L(X + 1): roots of P in (1/2, 1) -> (0, 1) */
    memcpy(qr, ql, (size_t)(n + 1) * sizeof *qr);
    spc_poly_taylor_shift(qr, n, 1.0);
    vca(ql, n, lo, mid, depth + 1, x);
    int nr = n;
    if (deflate_zero(qr, &nr))
        push(x, mid, mid, 1);
    else if (near_zero_at0(qr, nr))
        push(x, mid, mid, 1); /* a root within rounding of mid: both halves may miss it */
    normalize_pow2(qr, nr);
    vca(qr, nr, mid, hi, depth + 1, x);
}

int spc_poly_isolate(const double *c, int n, double a, double b, spc_root_interval *out, int max_out)
{
    n = spc_poly_degree(c, n);
    if (n < 0)
        return -1;
    if (n == 0 || !(b > a))
        return 0;
    double q[SPC_POLY_MAX_DEGREE + 1];
    memcpy(q, c, (size_t)(n + 1) * sizeof *q);
    /* [a, b] -> [0, 1]: q(X) = P(a + (b - a) X) */
    spc_poly_taylor_shift(q, n, a);
    spc_poly_scale_arg(q, n, b - a);
    normalize_pow2(q, n);
    iso_ctx x = {out, max_out, 0};
    if (deflate_zero(q, &n) || near_zero_at0(q, n))
        push(&x, a, a, 1);
    /* a root exactly at X = 1: q(1) = sum of the coefficients; deflate by (X - 1) */
    bool at_b = false;
    if (n > 0) {
        double s = 0.0;
        for (int i = 0; i <= n; ++i)
            s += q[i];
        if (s == 0.0) {
            double d[SPC_POLY_MAX_DEGREE + 1];
            /* synthetic division by (X - 1) */
            d[n - 1] = q[n];
            for (int i = n - 1; i >= 1; --i)
                d[i - 1] = q[i] + d[i];
            memcpy(q, d, (size_t)n * sizeof *q);
            --n;
            at_b = true;
        }
    }
    if (!at_b && n > 0) {
        double s = 0.0, sa = 0.0;
        for (int i = 0; i <= n; ++i) {
            s += q[i];
            sa += fabs(q[i]);
        }
        at_b = fabs(s) <= SPC_POLY_ZERO_EPS * sa; /* within rounding of a root at b */
    }
    vca(q, n, a, b, 0, &x);
    if (at_b)
        push(&x, b, b, 1);
    return x.count < max_out ? x.count : max_out;
}

/* The rounding error of evaluating P at t by Horner's rule (a generous multiple of it). */
static double eval_noise(const double *c, int n, double t)
{
    double s = 0.0, at = fabs(t), p = 1.0;
    for (int i = 0; i <= n; ++i, p *= at)
        s += fabs(c[i]) * p;
    return SPC_POLY_ZERO_EPS * s;
}

/* Moves an end of the interval whose value is rounding noise (a root reported at or next to that
 * end) inward until the value has a reliable sign: the isolated root is strictly inside. */
static void settle_end(const double *c, int n, double *end, double *fend, double other)
{
    if (fabs(*fend) > eval_noise(c, n, *end))
        return;
    for (int k = 40; k >= 1; --k) {
        double t = *end + ldexp(other - *end, -k);
        double f = spc_poly_eval(c, n, t);
        if (fabs(f) > eval_noise(c, n, t)) {
            *end = t;
            *fend = f;
            return;
        }
    }
}

double spc_poly_refine(const double *c, int n, const spc_root_interval *iv)
{
    double lo = iv->lo, hi = iv->hi;
    if (lo == hi)
        return lo;
    double flo = spc_poly_eval(c, n, lo), fhi = spc_poly_eval(c, n, hi);
    double lo0 = lo, hi0 = hi;
    settle_end(c, n, &lo, &flo, hi);
    settle_end(c, n, &hi, &fhi, lo);
    if (flo == 0.0)
        return lo;
    if (fhi == 0.0)
        return hi;
    if ((flo < 0.0) == (fhi < 0.0) && (lo != lo0 || hi != hi0)) {
        /* no sign change once the ends have reliable signs: the root is the one within rounding
         * of an end (reported from this side of a bisection point) */
        if (lo != lo0 && hi != hi0)
            return fabs(spc_poly_eval(c, n, lo0)) <= fabs(spc_poly_eval(c, n, hi0)) ? lo0 : hi0;
        return lo != lo0 ? lo0 : hi0;
    }
    if ((flo < 0.0) != (fhi < 0.0)) {
        /* bracketed: Newton from the secant's zero (report sec. 6.2.4), bisection when a step
         * leaves the bracket or does not shrink it fast enough */
        double t = lo - flo * (hi - lo) / (fhi - flo);
        if (!(t > lo && t < hi))
            t = 0.5 * (lo + hi);
        double prev_width = hi - lo;
        for (int it = 0; it < SPC_POLY_REFINE_ITERATIONS; ++it) {
            double d, f = spc_poly_eval_deriv(c, n, t, &d);
            if (f == 0.0)
                return t;
            if ((f < 0.0) == (flo < 0.0)) {
                lo = t;
                flo = f;
            } else {
                hi = t;
            }
            double width = hi - lo;
            double tn = d != 0.0 ? t - f / d : lo - 1.0;
            if (!(tn > lo && tn < hi) || width > 0.5 * prev_width)
                tn = 0.5 * (lo + hi);
            prev_width = width;
            if (tn == t || !(tn > lo && tn < hi))
                return t;
            t = tn;
        }
        return t;
    }
    /* no sign change (a multiple root or a cluster): Newton from the midpoint, kept inside */
    double t = 0.5 * (lo + hi);
    for (int it = 0; it < SPC_POLY_REFINE_ITERATIONS; ++it) {
        double d, f = spc_poly_eval_deriv(c, n, t, &d);
        if (f == 0.0 || d == 0.0)
            break;
        double tn = clampd(t - f / d, lo, hi);
        if (tn == t)
            break;
        t = tn;
    }
    return t;
}

int spc_poly_roots(const double *c, int n, double a, double b, double *roots, int max_out)
{
    spc_root_interval iv[SPC_POLY_MAX_DEGREE + 2];
    int k = spc_poly_isolate(c, n, a, b, iv, SPC_POLY_MAX_DEGREE + 2);
    if (k < 0)
        return -1;
    /* the refined roots, and the ends of intervals where P is zero within rounding (a root on a
     * bisection point reported from the wrong side may leave its interval's refinement with the
     * other end) */
    double cand[3 * (SPC_POLY_MAX_DEGREE + 2)];
    int nc = 0;
    for (int i = 0; i < k; ++i) {
        cand[nc++] = spc_poly_refine(c, n, &iv[i]);
        if (iv[i].lo < iv[i].hi) {
            if (fabs(spc_poly_eval(c, n, iv[i].lo)) <= eval_noise(c, n, iv[i].lo))
                cand[nc++] = iv[i].lo;
            if (fabs(spc_poly_eval(c, n, iv[i].hi)) <= eval_noise(c, n, iv[i].hi))
                cand[nc++] = iv[i].hi;
        }
    }
    for (int i = 1; i < nc; ++i)
        for (int j = i; j > 0 && cand[j] < cand[j - 1]; --j) {
            double t = cand[j];
            cand[j] = cand[j - 1];
            cand[j - 1] = t;
        }
    int m = 0;
    double same = SPC_POLY_SAME_ROOT * (b - a);
    for (int i = 0; i < nc && m < max_out; ++i) {
        /* a root within rounding of a bisection point may come from two neighbouring intervals */
        if (m > 0 && fabs(cand[i] - roots[m - 1]) <= same)
            continue;
        roots[m++] = cand[i];
    }
    return m;
}

/* ---- Sturm sequences, gcd, square-free part ---- */

static double max_abs(const double *c, int n)
{
    double m = 0.0;
    for (int i = 0; i <= n; ++i)
        m = fmax(m, fabs(c[i]));
    return m;
}

int spc_poly_divide(const double *a, int na, const double *b, int nb, double *q, double *r, int *nr)
{
    nb = spc_poly_degree(b, nb);
    double w[SPC_POLY_MAX_DEGREE + 1];
    memcpy(w, a, (size_t)(na + 1) * sizeof *w);
    if (nb < 0 || na < nb) {
        q[0] = 0.0;
        memcpy(r, w, (size_t)(na + 1) * sizeof *r);
        *nr = na;
        return 0;
    }
    int nq = na - nb;
    for (int k = nq; k >= 0; --k) {
        double f = w[nb + k] / b[nb];
        q[k] = f;
        for (int j = 0; j <= nb; ++j)
            w[j + k] -= f * b[j];
        w[nb + k] = 0.0;
    }
    int d = nb - 1;
    if (d < 0) {
        r[0] = 0.0;
        *nr = 0;
    } else {
        memcpy(r, w, (size_t)(d + 1) * sizeof *r);
        *nr = d;
    }
    return nq;
}

/* Degree of r once coefficients below tol are dropped from the top (zeroing them). */
static int trim(double *r, int n, double tol)
{
    while (n >= 0 && fabs(r[n]) <= tol) {
        r[n] = 0.0;
        --n;
    }
    return n;
}

void spc_poly_sturm_init(spc_sturm *s, const double *c, int n, double rel_tol)
{
    memset(s, 0, sizeof *s);
    n = spc_poly_degree(c, n);
    if (n < 0) {
        s->len = 0;
        return;
    }
    memcpy(s->p[0], c, (size_t)(n + 1) * sizeof(double));
    s->deg[0] = n;
    s->len = 1;
    if (n == 0)
        return;
    s->deg[1] = spc_poly_derivative(c, n, s->p[1]);
    s->len = 2;
    double scale = max_abs(c, n);
    while (s->len <= SPC_POLY_MAX_DEGREE && s->deg[s->len - 1] > 0) {
        const double *a = s->p[s->len - 2], *b = s->p[s->len - 1];
        int na = s->deg[s->len - 2], nb = s->deg[s->len - 1];
        double q[SPC_POLY_MAX_DEGREE + 1], r[SPC_POLY_MAX_DEGREE + 1];
        int nr;
        spc_poly_divide(a, na, b, nb, q, r, &nr);
        /* remainders are compared with the dividend's scale, itself normalized to 1 below */
        double tol = rel_tol * fmax(max_abs(a, na), 1e-300);
        nr = trim(r, nr, tol);
        if (nr < 0)
            break; /* exact division: the last polynomial is gcd(P, P') */
        double m = max_abs(r, nr);
        for (int i = 0; i <= nr; ++i)
            s->p[s->len][i] = -r[i] / m; /* positive scaling keeps the signs */
        s->deg[s->len] = nr;
        s->len++;
    }
    (void)scale;
}

int spc_poly_sturm_variations(const spc_sturm *s, double t)
{
    int v = 0, last = 0;
    for (int i = 0; i < s->len; ++i) {
        double f = spc_poly_eval(s->p[i], s->deg[i], t);
        int sg = f > 0.0 ? 1 : (f < 0.0 ? -1 : 0);
        if (sg == 0)
            continue;
        if (last != 0 && sg != last)
            ++v;
        last = sg;
    }
    return v;
}

int spc_poly_sturm_count(const spc_sturm *s, double a, double b)
{
    return spc_poly_sturm_variations(s, a) - spc_poly_sturm_variations(s, b);
}

int spc_poly_gcd(const double *a, int na, const double *b, int nb, double rel_tol, double *g)
{
    double x[SPC_POLY_MAX_DEGREE + 1], y[SPC_POLY_MAX_DEGREE + 1];
    na = spc_poly_degree(a, na);
    nb = spc_poly_degree(b, nb);
    if (na < nb) {
        const double *t = a;
        int tn = na;
        a = b;
        na = nb;
        b = t;
        nb = tn;
    }
    if (nb < 0) {
        if (na < 0) {
            g[0] = 0.0;
            return 0;
        }
        for (int i = 0; i <= na; ++i)
            g[i] = a[i] / a[na];
        return na;
    }
    memcpy(x, a, (size_t)(na + 1) * sizeof *x);
    memcpy(y, b, (size_t)(nb + 1) * sizeof *y);
    int nx = na, ny = nb;
    double mx = max_abs(x, nx), my = max_abs(y, ny);
    for (int i = 0; i <= nx; ++i)
        x[i] /= mx;
    for (int i = 0; i <= ny; ++i)
        y[i] /= my;
    for (;;) {
        if (ny == 0) {
            g[0] = 1.0; /* a nonzero constant: coprime */
            return 0;
        }
        double q[SPC_POLY_MAX_DEGREE + 1], r[SPC_POLY_MAX_DEGREE + 1];
        int nr;
        spc_poly_divide(x, nx, y, ny, q, r, &nr);
        nr = trim(r, nr, rel_tol);
        if (nr < 0)
            break;
        double m = max_abs(r, nr);
        memcpy(x, y, (size_t)(ny + 1) * sizeof *x);
        nx = ny;
        for (int i = 0; i <= nr; ++i)
            y[i] = r[i] / m;
        ny = nr;
    }
    for (int i = 0; i <= ny; ++i)
        g[i] = y[i] / y[ny];
    return ny;
}

int spc_poly_squarefree(const double *c, int n, double rel_tol, double *out)
{
    n = spc_poly_degree(c, n);
    if (n <= 0) {
        out[0] = n < 0 ? 0.0 : c[0];
        return n < 0 ? 0 : 0;
    }
    double d[SPC_POLY_MAX_DEGREE + 1], g[SPC_POLY_MAX_DEGREE + 1], r[SPC_POLY_MAX_DEGREE + 1];
    int nd = spc_poly_derivative(c, n, d);
    int ng = spc_poly_gcd(c, n, d, nd, rel_tol, g);
    if (ng == 0) {
        memcpy(out, c, (size_t)(n + 1) * sizeof *out);
        return n;
    }
    int nr;
    return spc_poly_divide(c, n, g, ng, out, r, &nr);
}
