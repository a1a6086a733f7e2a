/*
 * manifold/conic.c: the coplanarity conic of a triangle with interpolated normals, its
 * classification, its arcs inside the triangle, their chords, and the chord polynomial of the
 * squared sine law.
 *
 * Implements Freire 2021 (shared/papers/003): the conic's six coefficients (sec. 5.2.1, here
 * expanded around x for precision), the classification by |A_Q| and |A_33| (sec. 5.2.2, fig. 18),
 * triangle-conic intersections and their pairing into arcs by a parameter along the conic (sec.
 * 5.2.3-5.2.4), chord subdivision at the point farthest from the chord (sec. 5.3.2) and the
 * degree-6 chord polynomial f = eta^2 g_L h_V - g_V h_L (sec. 5.3.1).
 *
 * Completed where the report stops (sec. 8.2): parabolas and every degenerate conic (lines,
 * line pairs, parallel and double lines, a point, nothing, the whole plane) are classified and
 * handled; tangency to an edge needs no classification of crossing patterns, because an arc
 * between consecutive crossings is kept when its middle is inside, and a conic that touches an edge
 * from outside (a discriminant within rounding of zero, either sign) leaves the touching point as
 * an isolated point to polish; and the parameter along the
 * conic is the pencil of lines through a point of it (conic.h), which unlike the report's affine
 * normalization (appendix A) covers parabolas and stays accurate for nearly straight conics.
 */
#include "manifold/conic.h"

#include <string.h>

/* A conic whose quadratic part is below this fraction of its linear part bends by less than
 * ~1e-10 of the triangle's size over it: it is a line (within what the polishing step removes). */
#define SPC_CONIC_LINE_TOL 1e-10
/* |A_Q| (coefficients normalized to a largest magnitude of 1, the triangle of size 1) below this
 * is a degenerate conic within rounding: the coefficients carry relative errors of ~1e-16, which
 * give |A_Q| ~ 1e-16 for an exactly degenerate conic; above it the pencil parameterization of
 * conic.h is well conditioned (the branches are at least ~1e-7 apart). */
#define SPC_CONIC_DEGENERATE_TOL 1e-14
/* |A_33| / (largest quadratic coefficient)^2 below this counts as zero (parabolic). */
#define SPC_CONIC_PARABOLIC_TOL 1e-12
/* Slack of the inside test and of edge parameters, in barycentric units: points within rounding
 * of an edge count as on it. */
#define SPC_CONIC_INSIDE_EPS 1e-12
/* Two boundary crossings closer than this (barycentric units) are one (a vertex shared by two
 * edges, or a tangency found twice). */
#define SPC_CONIC_SAME_POINT 1e-12
/* A coefficient of the conic below this multiple of its terms' magnitudes is rounding noise:
 * each triple product carries a relative error of a few ulps of its factors' magnitudes. */
#define SPC_CONIC_ROUNDING 3e-15
/* Distance (barycentric units) within which a conic that misses an edge by rounding counts as
 * touching it: far above the ~1e-12 the coefficients' rounding can move it, far below any
 * triangle. */
#define SPC_CONIC_TOUCH 1e-7
/* Chord subdivision depth limit: 2^-40 of an arc is far below any tolerance asked for. */
#define SPC_CONIC_MAX_CHORD_DEPTH 40

/* ---- small 2D helpers ---- */

static spc_vec2 v2add(spc_vec2 a, spc_vec2 b) { return spc_v2(a.x + b.x, a.y + b.y); }
static spc_vec2 v2sub(spc_vec2 a, spc_vec2 b) { return spc_v2(a.x - b.x, a.y - b.y); }
static spc_vec2 v2scale(spc_vec2 a, double s) { return spc_v2(a.x * s, a.y * s); }
static double v2dot(spc_vec2 a, spc_vec2 b) { return a.x * b.x + a.y * b.y; }
static double v2cross(spc_vec2 a, spc_vec2 b) { return a.x * b.y - a.y * b.x; }
static double v2len(spc_vec2 a) { return sqrt(a.x * a.x + a.y * a.y); }

static bool inside_tri(spc_vec2 p, double eps) { return p.x >= -eps && p.y >= -eps && p.x + p.y <= 1.0 + eps; }

/* ---- the triangle and the conic ---- */

spc_conic_tri spc_conic_tri_make(spc_vec3 p0, spc_vec3 p1, spc_vec3 p2, spc_vec3 n0, spc_vec3 n1, spc_vec3 n2)
{
    spc_conic_tri t;
    t.p0 = p0;
    t.e1 = spc_sub(p1, p0);
    t.e2 = spc_sub(p2, p0);
    t.n0 = n0;
    t.dn1 = spc_sub(n1, n0);
    t.dn2 = spc_sub(n2, n0);
    return t;
}

spc_vec3 spc_conic_tri_point(const spc_conic_tri *t, double u, double v)
{
    return spc_add(t->p0, spc_add(spc_scale(t->e1, u), spc_scale(t->e2, v)));
}

spc_vec3 spc_conic_tri_normal(const spc_conic_tri *t, double u, double v)
{
    return spc_add(t->n0, spc_add(spc_scale(t->dn1, u), spc_scale(t->dn2, v)));
}

spc_conic spc_conic_coplanarity(const spc_conic_tri *t, spc_vec3 x, spc_vec3 y)
{
    /* Q = s . (a x n), s = y - x, a = P - x = a0 + u e1 + v e2, n = n0 + u dn1 + v dn2 */
    spc_vec3 s = spc_sub(y, x), a0 = spc_sub(t->p0, x);
    spc_conic q;
    q.A = spc_dot(s, spc_cross(t->e1, t->dn1));
    q.B = spc_dot(s, spc_add(spc_cross(t->e1, t->dn2), spc_cross(t->e2, t->dn1)));
    q.C = spc_dot(s, spc_cross(t->e2, t->dn2));
    q.D = spc_dot(s, spc_add(spc_cross(t->e1, t->n0), spc_cross(a0, t->dn1)));
    q.E = spc_dot(s, spc_add(spc_cross(t->e2, t->n0), spc_cross(a0, t->dn2)));
    q.F = spc_dot(s, spc_cross(a0, t->n0));
    /* a coefficient within the rounding of its triple products is zero (e.g. y - x parallel to a
     * constant normal: every coefficient is noise and the conic is the whole plane) */
    double ls = spc_length(s), la = spc_length(a0), le1 = spc_length(t->e1), le2 = spc_length(t->e2);
    double ln = spc_length(t->n0), ld1 = spc_length(t->dn1), ld2 = spc_length(t->dn2);
    double bound[6] = {le1 * ld1, le1 * ld2 + le2 * ld1, le2 * ld2, le1 * ln + la * ld1, le2 * ln + la * ld2, la * ln};
    double *c[6] = {&q.A, &q.B, &q.C, &q.D, &q.E, &q.F};
    for (int i = 0; i < 6; ++i)
        if (fabs(*c[i]) <= SPC_CONIC_ROUNDING * ls * bound[i])
            *c[i] = 0.0;
    return q;
}

double spc_conic_eval(const spc_conic *q, double u, double v)
{
    return (q->A * u + q->B * v + q->D) * u + (q->C * v + q->E) * v + q->F;
}

static spc_vec2 conic_grad(const spc_conic *q, spc_vec2 p)
{
    return spc_v2(2.0 * q->A * p.x + q->B * p.y + q->D, q->B * p.x + 2.0 * q->C * p.y + q->E);
}

/* x^T M y with M = [[A, B/2], [B/2, C]] */
static double quad_form(const spc_conic *q, spc_vec2 a, spc_vec2 b)
{
    return q->A * a.x * b.x + 0.5 * q->B * (a.x * b.y + a.y * b.x) + q->C * a.y * b.y;
}

static spc_conic normalized(const spc_conic *q, double *scale)
{
    double s = fmax(fmax(fmax(fabs(q->A), fabs(q->B)), fmax(fabs(q->C), fabs(q->D))), fmax(fabs(q->E), fabs(q->F)));
    *scale = s;
    spc_conic n = *q;
    if (s > 0.0) {
        n.A /= s;
        n.B /= s;
        n.C /= s;
        n.D /= s;
        n.E /= s;
        n.F /= s;
    }
    return n;
}

static double det3(const spc_conic *q)
{
    double a = q->A, b = 0.5 * q->B, c = q->C, d = 0.5 * q->D, e = 0.5 * q->E, f = q->F;
    return a * (c * f - e * e) - b * (b * f - e * d) + d * (b * e - c * d);
}

spc_conic_type spc_conic_classify(const spc_conic *q0)
{
    double scale;
    spc_conic q = normalized(q0, &scale);
    if (!(scale > 0.0))
        return SPC_CONIC_PLANE;
    double qm = fmax(fmax(fabs(q.A), fabs(q.B)), fabs(q.C));
    double lm = fmax(fabs(q.D), fabs(q.E));
    if (qm == 0.0 && lm == 0.0)
        return SPC_CONIC_EMPTY; /* Q = F != 0 */
    if (qm <= SPC_CONIC_LINE_TOL * lm)
        return SPC_CONIC_LINE;
    double d2 = (q.A * q.C - 0.25 * q.B * q.B) / (qm * qm);
    double d3 = det3(&q);
    if (fabs(d3) <= SPC_CONIC_DEGENERATE_TOL) {
        if (d2 < -SPC_CONIC_PARABOLIC_TOL)
            return SPC_CONIC_LINE_PAIR;
        if (d2 > SPC_CONIC_PARABOLIC_TOL)
            return SPC_CONIC_POINT;
        /* rank-1 quadratic part: Q = lambda z^2 + kz z + F along w; lines where that vanishes */
        double lambda = q.A + q.C;
        spc_vec2 w = fabs(q.A) >= fabs(q.C) ? spc_v2(q.A, 0.5 * q.B) : spc_v2(0.5 * q.B, q.C);
        w = v2scale(w, 1.0 / v2len(w));
        double kz = q.D * w.x + q.E * w.y;
        double disc = kz * kz - 4.0 * lambda * q.F;
        double tol = 1e-12 * (kz * kz + fabs(4.0 * lambda * q.F));
        if (disc > tol)
            return SPC_CONIC_PARALLEL_LINES;
        if (disc >= -tol)
            return SPC_CONIC_DOUBLE_LINE;
        return SPC_CONIC_EMPTY;
    }
    if (d2 > SPC_CONIC_PARABOLIC_TOL)
        return (q.A + q.C) * d3 < 0.0 ? SPC_CONIC_ELLIPSE : SPC_CONIC_EMPTY;
    if (d2 < -SPC_CONIC_PARABOLIC_TOL)
        return SPC_CONIC_HYPERBOLA;
    return SPC_CONIC_PARABOLA;
}

const char *spc_conic_type_name(spc_conic_type t)
{
    switch (t) {
    case SPC_CONIC_ELLIPSE: return "ellipse";
    case SPC_CONIC_HYPERBOLA: return "hyperbola";
    case SPC_CONIC_PARABOLA: return "parabola";
    case SPC_CONIC_LINE: return "line";
    case SPC_CONIC_LINE_PAIR: return "line pair";
    case SPC_CONIC_PARALLEL_LINES: return "parallel lines";
    case SPC_CONIC_DOUBLE_LINE: return "double line";
    case SPC_CONIC_POINT: return "point";
    case SPC_CONIC_EMPTY: return "empty";
    case SPC_CONIC_PLANE: return "plane";
    }
    return "?";
}

/* ---- the pencil parameterization ---- */

static void curve_init(spc_conic_curve *c, const spc_conic *q, spc_vec2 base)
{
    c->q = *q;
    c->base = base;
    spc_vec2 g = conic_grad(q, base);
    c->g = v2len(g);
    c->N = c->g > 0.0 ? v2scale(g, 1.0 / c->g) : spc_v2(0.0, 1.0);
    c->T = spc_v2(-c->N.y, c->N.x);
    c->alpha = quad_form(q, c->T, c->T);
    c->beta = quad_form(q, c->T, c->N);
    c->gamma = quad_form(q, c->N, c->N);
}

spc_vec2 spc_conic_curve_point(const spc_conic_curve *c, double psi)
{
    double cs = cos(psi), sn = sin(psi);
    double den = c->alpha * cs * cs + 2.0 * c->beta * sn * cs + c->gamma * sn * sn;
    double r = -c->g * sn / den;
    return v2add(c->base, v2scale(v2add(v2scale(c->T, cs), v2scale(c->N, sn)), r));
}

static double fold_psi(double psi)
{
    while (psi > 0.5 * SPC_PI)
        psi -= SPC_PI;
    while (psi <= -0.5 * SPC_PI)
        psi += SPC_PI;
    return psi;
}

double spc_conic_curve_param(const spc_conic_curve *c, spc_vec2 p)
{
    spc_vec2 d = v2sub(p, c->base);
    if (d.x == 0.0 && d.y == 0.0)
        return 0.0;
    return fold_psi(atan2(v2dot(d, c->N), v2dot(d, c->T)));
}

/* Points at infinity: alpha + 2 beta m + gamma m^2 = 0, m = tan psi. Returns how many (0..2). */
static int curve_poles(const spc_conic_curve *c, double pole[2])
{
    double a = c->gamma, b = 2.0 * c->beta, cc = c->alpha;
    if (a == 0.0) {
        int k = 0;
        pole[k++] = 0.5 * SPC_PI; /* m = infinity */
        if (b != 0.0)
            pole[k++] = atan(-cc / b);
        return k;
    }
    double disc = b * b - 4.0 * a * cc;
    if (disc < 0.0)
        return 0;
    double sq = sqrt(disc);
    double qq = -0.5 * (b + (b >= 0.0 ? sq : -sq));
    int k = 0;
    pole[k++] = atan(qq / a);
    pole[k++] = qq != 0.0 ? atan(cc / qq) : 0.0;
    return k;
}

/* True if some pole (mod pi) lies strictly inside (lo, hi). */
static bool interval_has_pole(const double *pole, int np, double lo, double hi)
{
    for (int i = 0; i < np; ++i)
        for (int k = -1; k <= 2; ++k) {
            double p = pole[i] + k * SPC_PI;
            if (p > lo && p < hi)
                return true;
        }
    return false;
}

/* ---- arcs ---- */

/* Real roots of a s^2 + b s + c in [0, 1] (slack eps), a double root where the discriminant is
 * within rounding of zero. Returns how many (0..2). */
static int quad_roots01(double a, double b, double c, double r[2])
{
    double m = fmax(fabs(a), fmax(fabs(b), fabs(c)));
    if (m == 0.0)
        return 0;
    a /= m;
    b /= m;
    c /= m;
    double s[2];
    int k = 0;
    if (a == 0.0) {
        if (b == 0.0)
            return 0;
        s[k++] = -c / b;
    } else {
        double disc = b * b - 4.0 * a * c;
        double tol = 1e-14 * (b * b + fabs(4.0 * a * c));
        if (disc < -tol)
            return 0;
        if (disc <= tol) {
            s[k++] = -b / (2.0 * a);
        } else {
            double sq = sqrt(disc);
            double qq = -0.5 * (b + (b >= 0.0 ? sq : -sq));
            s[k++] = qq / a;
            if (qq != 0.0)
                s[k++] = c / qq;
        }
    }
    int n = 0;
    for (int i = 0; i < k; ++i)
        if (s[i] >= -SPC_CONIC_INSIDE_EPS && s[i] <= 1.0 + SPC_CONIC_INSIDE_EPS)
            r[n++] = spc_clamp(s[i], 0.0, 1.0);
    return n;
}

static void add_point(spc_conic_arcs *out, spc_vec2 p)
{
    for (int i = 0; i < out->npoints; ++i)
        if (v2len(v2sub(out->point[i], p)) <= SPC_CONIC_SAME_POINT)
            return;
    if (out->npoints < SPC_CONIC_MAX_POINTS)
        out->point[out->npoints++] = p;
}

static void add_segment(spc_conic_arcs *out, spc_vec2 a, spc_vec2 b, double err)
{
    if (out->narcs >= SPC_CONIC_MAX_ARCS)
        return;
    spc_conic_arc *s = &out->arc[out->narcs++];
    memset(s, 0, sizeof *s);
    s->segment = true;
    s->a = a;
    s->b = b;
    s->err = err;
}

/* Clips the line o + t w to the triangle (Liang-Barsky on u >= 0, v >= 0, 1 - u - v >= 0). */
static void clip_line(spc_conic_arcs *out, spc_vec2 o, spc_vec2 w, double err)
{
    double lo = -INFINITY, hi = INFINITY;
    /* each half-plane k . p + k0 >= 0 */
    const double K[3][3] = {{1, 0, 0}, {0, 1, 0}, {-1, -1, 1}};
    for (int i = 0; i < 3; ++i) {
        double h0 = K[i][0] * o.x + K[i][1] * o.y + K[i][2] + SPC_CONIC_INSIDE_EPS;
        double h1 = K[i][0] * w.x + K[i][1] * w.y;
        if (h1 == 0.0) {
            if (h0 < 0.0)
                return;
            continue;
        }
        double t = -h0 / h1;
        if (h1 > 0.0)
            lo = fmax(lo, t);
        else
            hi = fmin(hi, t);
    }
    if (!(lo <= hi) || !isfinite(lo) || !isfinite(hi))
        return;
    spc_vec2 a = v2add(o, v2scale(w, lo)), b = v2add(o, v2scale(w, hi));
    if (v2len(v2sub(a, b)) <= SPC_CONIC_SAME_POINT)
        add_point(out, a);
    else
        add_segment(out, a, b, err);
}

/* The point of the line through o along w (unit) where Q vanishes nearest to o, measured along
 * the line's normal: puts a line of a degenerate conic exactly on the zero set. */
static spc_vec2 settle_on_line(const spc_conic *q, spc_vec2 o, spc_vec2 w)
{
    spc_vec2 nrm = spc_v2(-w.y, w.x);
    double c0 = spc_conic_eval(q, o.x, o.y), c1 = v2dot(conic_grad(q, o), nrm), c2 = quad_form(q, nrm, nrm);
    double r[2];
    int k;
    /* roots of c2 s^2 + c1 s + c0, without the [0, 1] window */
    if (c2 == 0.0) {
        if (c1 == 0.0)
            return o;
        r[0] = -c0 / c1;
        k = 1;
    } else {
        double disc = c1 * c1 - 4.0 * c2 * c0;
        if (disc < 0.0)
            return o;
        double sq = sqrt(disc), qq = -0.5 * (c1 + (c1 >= 0.0 ? sq : -sq));
        r[0] = qq / c2;
        r[1] = qq != 0.0 ? c0 / qq : r[0];
        k = 2;
    }
    double best = r[0];
    for (int i = 1; i < k; ++i)
        if (fabs(r[i]) < fabs(best))
            best = r[i];
    return isfinite(best) ? v2add(o, v2scale(nrm, best)) : o;
}

static void degenerate_arcs(const spc_conic *q, spc_conic_type type, spc_conic_arcs *out)
{
    double det2 = q->A * q->C - 0.25 * q->B * q->B;
    spc_vec2 centroid = spc_v2(1.0 / 3.0, 1.0 / 3.0);
    switch (type) {
    case SPC_CONIC_LINE: {
        double lm = fmax(fabs(q->D), fabs(q->E)), qm = fmax(fmax(fabs(q->A), fabs(q->B)), fabs(q->C));
        spc_vec2 nrm = spc_v2(q->D, q->E);
        double l = v2len(nrm);
        if (!(l > 0.0))
            return;
        spc_vec2 w = spc_v2(-nrm.y / l, nrm.x / l);
        /* the point of the line nearest the centroid, then onto the zero set of the full Q */
        double off = (spc_conic_eval(&(spc_conic){0, 0, 0, q->D, q->E, q->F}, centroid.x, centroid.y)) / l;
        spc_vec2 o = v2sub(centroid, v2scale(nrm, off / l));
        o = settle_on_line(q, o, w);
        clip_line(out, o, w, 2.0 * qm / fmax(lm, 1e-300));
        return;
    }
    case SPC_CONIC_LINE_PAIR: {
        /* centre: M c = -(D, E)/2; lines along the real isotropic directions of M */
        spc_vec2 c = spc_v2((-0.5 * q->D * q->C + 0.25 * q->B * q->E) / det2,
                            (-0.5 * q->E * q->A + 0.25 * q->B * q->D) / det2);
        spc_vec2 dir[2];
        int nd = 0;
        if (fabs(q->A) >= fabs(q->C)) {
            /* A + B m + C m^2 = 0 for directions (1, m)... solved as directions (1, m) or (m, 1) */
            double a = q->C, b = q->B, cc = q->A; /* in m for (1, m): A + B m + C m^2 */
            double disc = b * b - 4.0 * a * cc;
            double sq = sqrt(fmax(disc, 0.0));
            if (a == 0.0) {
                dir[nd++] = spc_v2(0.0, 1.0);
                if (b != 0.0)
                    dir[nd++] = spc_v2(1.0, -cc / b);
            } else {
                double qq = -0.5 * (b + (b >= 0.0 ? sq : -sq));
                dir[nd++] = spc_v2(1.0, qq / a);
                dir[nd++] = qq != 0.0 ? spc_v2(1.0, cc / qq) : spc_v2(1.0, 0.0);
            }
        } else {
            double a = q->A, b = q->B, cc = q->C; /* in m for (m, 1): A m^2 + B m + C */
            double disc = b * b - 4.0 * a * cc;
            double sq = sqrt(fmax(disc, 0.0));
            if (a == 0.0) {
                dir[nd++] = spc_v2(1.0, 0.0);
                if (b != 0.0)
                    dir[nd++] = spc_v2(-cc / b, 1.0);
            } else {
                double qq = -0.5 * (b + (b >= 0.0 ? sq : -sq));
                dir[nd++] = spc_v2(qq / a, 1.0);
                dir[nd++] = qq != 0.0 ? spc_v2(cc / qq, 1.0) : spc_v2(0.0, 1.0);
            }
        }
        for (int i = 0; i < nd; ++i) {
            spc_vec2 w = v2scale(dir[i], 1.0 / v2len(dir[i]));
            /* the line's point nearest the centroid, settled onto Q = 0 (the centre may be far) */
            spc_vec2 o = v2add(c, v2scale(w, v2dot(v2sub(centroid, c), w)));
            o = settle_on_line(q, o, w);
            clip_line(out, o, w, 0.0);
        }
        if (inside_tri(c, SPC_CONIC_INSIDE_EPS))
            add_point(out, c);
        return;
    }
    case SPC_CONIC_PARALLEL_LINES:
    case SPC_CONIC_DOUBLE_LINE: {
        double lambda = q->A + q->C;
        spc_vec2 w = fabs(q->A) >= fabs(q->C) ? spc_v2(q->A, 0.5 * q->B) : spc_v2(0.5 * q->B, q->C);
        w = v2scale(w, 1.0 / v2len(w));
        double kz = q->D * w.x + q->E * w.y;
        double disc = kz * kz - 4.0 * lambda * q->F;
        double z[2];
        int nz = 0;
        if (type == SPC_CONIC_DOUBLE_LINE || disc <= 0.0) {
            z[nz++] = -kz / (2.0 * lambda);
        } else {
            double sq = sqrt(disc), qq = -0.5 * (kz + (kz >= 0.0 ? sq : -sq));
            z[nz++] = qq / lambda;
            if (qq != 0.0)
                z[nz++] = q->F / qq;
        }
        spc_vec2 along = spc_v2(-w.y, w.x);
        for (int i = 0; i < nz; ++i) {
            spc_vec2 o = v2add(v2scale(w, z[i]), v2scale(along, v2dot(centroid, along)));
            if (type != SPC_CONIC_DOUBLE_LINE)
                o = settle_on_line(q, o, along);
            clip_line(out, o, along, 0.0);
        }
        return;
    }
    case SPC_CONIC_POINT: {
        spc_vec2 c = spc_v2((-0.5 * q->D * q->C + 0.25 * q->B * q->E) / det2,
                            (-0.5 * q->E * q->A + 0.25 * q->B * q->D) / det2);
        if (inside_tri(c, SPC_CONIC_INSIDE_EPS))
            add_point(out, c);
        return;
    }
    case SPC_CONIC_ELLIPSE:
    case SPC_CONIC_HYPERBOLA:
    case SPC_CONIC_PARABOLA:
    case SPC_CONIC_EMPTY:
    case SPC_CONIC_PLANE:
        return;
    }
}

static void add_arc(spc_conic_arcs *out, spc_vec2 a, spc_vec2 b, double pa, double pb)
{
    /* arcs spanning more than pi/2 are halved, so every chord is a proper secant */
    if (pb - pa > 0.5 * SPC_PI) {
        double pm = 0.5 * (pa + pb);
        spc_vec2 m = spc_conic_curve_point(&out->curve, pm);
        add_arc(out, a, m, pa, pm);
        add_arc(out, m, b, pm, pb);
        return;
    }
    if (out->narcs >= SPC_CONIC_MAX_ARCS)
        return;
    spc_conic_arc *s = &out->arc[out->narcs++];
    memset(s, 0, sizeof *s);
    s->a = a;
    s->b = b;
    s->psi_a = pa;
    s->psi_b = pb;
}

void spc_conic_find_arcs(const spc_conic *q0, spc_conic_arcs *out)
{
    memset(out, 0, sizeof *out);
    spc_conic_type type = spc_conic_classify(q0);
    out->type = type;
    double scale;
    spc_conic q = normalized(q0, &scale);
    if (type != SPC_CONIC_ELLIPSE && type != SPC_CONIC_HYPERBOLA && type != SPC_CONIC_PARABOLA) {
        degenerate_arcs(&q, type, out);
        return;
    }

    /* boundary crossings on the three edges, each edge p0 + s (p1 - p0) with Q = a s^2 + b s + c */
    spc_vec2 bp[6];
    int nb = 0;
    const spc_vec2 E0[3] = {{0.0, 0.0}, {1.0, 0.0}, {0.0, 1.0}}, E1[3] = {{1.0, 0.0}, {0.0, 1.0}, {0.0, 0.0}};
    const double ec[3][3] = {{q.A, q.D, q.F},
                             {q.A - q.B + q.C, -2.0 * q.A + q.B - q.D + q.E, q.A + q.D + q.F},
                             {q.C, -2.0 * q.C - q.E, q.C + q.E + q.F}};
    for (int e = 0; e < 3; ++e) {
        double r[2];
        spc_vec2 dir = v2sub(E1[e], E0[e]);
        int k = quad_roots01(ec[e][0], ec[e][1], ec[e][2], r);
        for (int i = 0; i < k; ++i)
            bp[nb++] = v2add(E0[e], v2scale(dir, r[i]));
        /* a conic tangent to the edge from outside touches it at one point, where the
         * discriminant is zero; the coefficients' rounding (relative to their terms, not to
         * themselves) may leave it slightly negative, so a vertex of the parabola s -> Q within
         * SPC_CONIC_TOUCH of the conic is kept as an isolated point (polishing decides) */
        if (k == 0 && ec[e][0] != 0.0) {
            double s0 = -ec[e][1] / (2.0 * ec[e][0]);
            if (s0 >= 0.0 && s0 <= 1.0) {
                spc_vec2 p = v2add(E0[e], v2scale(dir, s0));
                double g = v2len(conic_grad(&q, p));
                if (g > 0.0 && fabs(spc_conic_eval(&q, p.x, p.y)) <= SPC_CONIC_TOUCH * g)
                    add_point(out, p);
            }
        }
    }
    /* merge duplicates (vertices) */
    int m = 0;
    for (int i = 0; i < nb; ++i) {
        bool dup = false;
        for (int j = 0; j < m; ++j)
            if (v2len(v2sub(bp[i], bp[j])) <= SPC_CONIC_SAME_POINT)
                dup = true;
        if (!dup)
            bp[m++] = bp[i];
    }
    nb = m;

    if (nb == 0) {
        /* no crossing: only a whole ellipse can be inside */
        if (type != SPC_CONIC_ELLIPSE)
            return;
        double det2 = q.A * q.C - 0.25 * q.B * q.B;
        spc_vec2 c = spc_v2((-0.5 * q.D * q.C + 0.25 * q.B * q.E) / det2, (-0.5 * q.E * q.A + 0.25 * q.B * q.D) / det2);
        if (!inside_tri(c, 0.0))
            return;
        double qc = spc_conic_eval(&q, c.x, c.y);
        if (!(q.A != 0.0) || !(-qc / q.A > 0.0))
            return;
        spc_vec2 base = spc_v2(c.x + sqrt(-qc / q.A), c.y);
        if (!inside_tri(base, 0.0))
            return;
        out->has_curve = true;
        curve_init(&out->curve, &q, base);
        spc_vec2 opp = spc_conic_curve_point(&out->curve, 0.5 * SPC_PI);
        add_arc(out, base, opp, 0.0, 0.5 * SPC_PI);
        add_arc(out, opp, base, 0.5 * SPC_PI, SPC_PI);
        return;
    }

    out->has_curve = true;
    curve_init(&out->curve, &q, bp[0]);
    double psi[6];
    int order[6];
    for (int i = 0; i < nb; ++i) {
        psi[i] = i == 0 ? 0.0 : spc_conic_curve_param(&out->curve, bp[i]);
        order[i] = i;
    }
    for (int i = 1; i < nb; ++i) /* insertion sort by psi */
        for (int j = i; j > 0 && psi[order[j]] < psi[order[j - 1]]; --j) {
            int t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    double pole[2];
    int np = curve_poles(&out->curve, pole);
    bool used[6] = {false};
    for (int i = 0; i < nb; ++i) {
        int ia = order[i], ib = order[(i + 1) % nb];
        double pa = psi[ia], pb = i + 1 < nb ? psi[ib] : psi[ib] + SPC_PI;
        if (!(pb > pa) || interval_has_pole(pole, np, pa, pb))
            continue;
        spc_vec2 mid = spc_conic_curve_point(&out->curve, 0.5 * (pa + pb));
        if (!inside_tri(mid, SPC_CONIC_INSIDE_EPS))
            continue;
        add_arc(out, bp[ia], bp[ib], pa, pb);
        used[ia] = used[ib] = true;
    }
    /* crossings that bound no inside arc: the conic touches the triangle there */
    for (int i = 0; i < nb; ++i)
        if (!used[i])
            add_point(out, bp[i]);
}

/* ---- chords ---- */

static bool psi_in(double psi, double lo, double hi, double *unwrapped)
{
    for (int k = -1; k <= 2; ++k) {
        double p = psi + k * SPC_PI;
        if (p > lo && p < hi) {
            *unwrapped = p;
            return true;
        }
    }
    return false;
}

static double chord_distance(spc_vec2 a, spc_vec2 b, spc_vec2 p)
{
    spc_vec2 c = v2sub(b, a);
    double l = v2len(c);
    if (!(l > 0.0))
        return v2len(v2sub(p, a));
    return fabs(v2cross(c, v2sub(p, a))) / l;
}

bool spc_conic_farthest(const spc_conic_curve *cv, const spc_conic_arc *arc, spc_vec2 *p, double *psi, double *dist)
{
    const spc_conic *q = &cv->q;
    spc_vec2 c = v2sub(arc->b, arc->a);
    /* the conjugate diameter: grad Q(p) . c = 0, i.e. 2 (M c) . p + (D, E) . c = 0 */
    spc_vec2 nl = spc_v2(2.0 * q->A * c.x + q->B * c.y, q->B * c.x + 2.0 * q->C * c.y);
    double nl2 = v2dot(nl, nl);
    if (nl2 > 0.0 && isfinite(nl2)) {
        /* written around the chord's first end for precision */
        double k0 = v2dot(conic_grad(q, arc->a), c);
        spc_vec2 o = v2sub(arc->a, v2scale(nl, k0 / nl2));
        spc_vec2 w = v2scale(spc_v2(-nl.y, nl.x), 1.0 / sqrt(nl2));
        double c0 = spc_conic_eval(q, o.x, o.y), c1 = v2dot(conic_grad(q, o), w), c2 = quad_form(q, w, w);
        double s[2];
        int ns = 0;
        if (c2 == 0.0) {
            if (c1 != 0.0)
                s[ns++] = -c0 / c1;
        } else {
            double disc = c1 * c1 - 4.0 * c2 * c0;
            if (disc >= 0.0) {
                double sq = sqrt(disc), qq = -0.5 * (c1 + (c1 >= 0.0 ? sq : -sq));
                s[ns++] = qq / c2;
                if (qq != 0.0)
                    s[ns++] = c0 / qq;
            }
        }
        for (int i = 0; i < ns; ++i) {
            spc_vec2 cand = v2add(o, v2scale(w, s[i]));
            double pc;
            if (isfinite(cand.x) && psi_in(spc_conic_curve_param(cv, cand), arc->psi_a, arc->psi_b, &pc)) {
                *p = cand;
                *psi = pc;
                *dist = chord_distance(arc->a, arc->b, cand);
                return true;
            }
        }
    }
    *psi = 0.5 * (arc->psi_a + arc->psi_b);
    *p = spc_conic_curve_point(cv, *psi);
    *dist = chord_distance(arc->a, arc->b, *p);
    return false;
}

int spc_conic_chords(const spc_conic_arcs *arcs, const spc_conic_arc *arc, double tol, spc_conic_arc *out, int max_out)
{
    if (arc->segment) {
        if (max_out > 0)
            out[0] = *arc;
        return 1;
    }
    spc_conic_arc stack[SPC_CONIC_MAX_CHORD_DEPTH + 2];
    int depth[SPC_CONIC_MAX_CHORD_DEPTH + 2];
    int top = 0, n = 0;
    stack[top] = *arc;
    depth[top++] = 0;
    while (top > 0) {
        spc_conic_arc a = stack[--top];
        int d = depth[top];
        spc_vec2 p;
        double psi, dist;
        spc_conic_farthest(&arcs->curve, &a, &p, &psi, &dist);
        if (dist <= tol || d >= SPC_CONIC_MAX_CHORD_DEPTH) {
            a.err = dist;
            if (n < max_out)
                out[n] = a;
            ++n;
            continue;
        }
        spc_conic_arc l = a, r = a;
        l.b = p;
        l.psi_b = psi;
        r.a = p;
        r.psi_a = psi;
        /* depth-first, left first: the output follows the arc */
        stack[top] = r;
        depth[top++] = d + 1;
        stack[top] = l;
        depth[top++] = d + 1;
    }
    return n < max_out ? n : max_out;
}

/* ---- the chord polynomial ---- */

/* |w0 + w1 t + w2 t^2|^2 */
static void sqnorm_quadratic(spc_vec3 w0, spc_vec3 w1, spc_vec3 w2, double h[5])
{
    h[0] = spc_dot(w0, w0);
    h[1] = 2.0 * spc_dot(w0, w1);
    h[2] = spc_dot(w1, w1) + 2.0 * spc_dot(w0, w2);
    h[3] = 2.0 * spc_dot(w1, w2);
    h[4] = spc_dot(w2, w2);
}

void spc_conic_chord_poly(const spc_conic_tri *t, spc_vec3 x, spc_vec3 y, double eta_x, double eta_y, spc_vec2 a,
                          spc_vec2 b, double f[7])
{
    double du = b.x - a.x, dv = b.y - a.y;
    spc_vec3 Pa = spc_conic_tri_point(t, a.x, a.y);
    spc_vec3 dP = spc_add(spc_scale(t->e1, du), spc_scale(t->e2, dv));
    spc_vec3 na = spc_conic_tri_normal(t, a.x, a.y);
    spc_vec3 dn = spc_add(spc_scale(t->dn1, du), spc_scale(t->dn2, dv));
    double g[2][3], h[2][5];
    for (int i = 0; i < 2; ++i) {
        spc_vec3 X = i == 0 ? x : y;
        /* X - P(t) = c0 + t c1 */
        spc_vec3 c0 = spc_sub(X, Pa), c1 = spc_neg(dP);
        g[i][0] = spc_dot(c0, c0);
        g[i][1] = 2.0 * spc_dot(c0, c1);
        g[i][2] = spc_dot(c1, c1);
        sqnorm_quadratic(spc_cross(c0, na), spc_add(spc_cross(c0, dn), spc_cross(c1, na)), spc_cross(c1, dn), h[i]);
    }
    double ex2 = eta_x * eta_x, ey2 = eta_y * eta_y;
    for (int k = 0; k <= 6; ++k)
        f[k] = 0.0;
    for (int i = 0; i <= 2; ++i)
        for (int j = 0; j <= 4; ++j)
            f[i + j] += ex2 * g[1][i] * h[0][j] - ey2 * g[0][i] * h[1][j];
}

double spc_conic_snell_eval(const spc_conic_tri *t, spc_vec3 x, spc_vec3 y, double eta_x, double eta_y, double u,
                            double v)
{
    spc_vec3 P = spc_conic_tri_point(t, u, v), n = spc_conic_tri_normal(t, u, v);
    spc_vec3 ax = spc_sub(x, P), ay = spc_sub(y, P);
    return eta_x * eta_x * spc_length2(ay) * spc_length2(spc_cross(ax, n)) -
           eta_y * eta_y * spc_length2(ax) * spc_length2(spc_cross(ay, n));
}
