/*
 * tests/test_conic.c: the conic solver (src/manifold/conic*.c, polyroots.c).
 *
 * - Polynomial tools: the O(n^2) Taylor shift against binomial expansion; VCA isolation against
 *   Sturm counts on random polynomials with distinct, repeated and clustered roots; square-free
 *   parts; refinement to the known roots.
 * - The conic: coefficients against the triple product; classification of constructed conics of
 *   every type; arcs inside the triangle (every arc point on the conic and inside, every sign
 *   change of Q on a fine grid near some arc); chords within their tolerance; the chord polynomial
 *   against direct evaluation.
 * - The solver on 10^4 random configurations (random vertices, normals from nearly flat to
 *   flipping, x and y random or built around a known solution, reflection and refraction with eta
 *   in [1.1, 2.5]) against an independent dense search (a 120 x 120 grid of the residual, Newton
 *   from every local minimum, deduplication): recall 100% of the search's solutions, precision
 *   100% (every solution satisfies the law to 1e-9).
 * - Constructed cases the random ones reach only by chance: the normal field bent (keeping a known
 *   solution) until the conic is a parabola, a line pair or a point, or tangent to an edge at a
 *   solution (from inside and from outside); y on the caustic of a known solution (a double root
 *   of the law); vertex normals on both sides of the face (the interpolated normal flips). Each
 *   against the known solution and the dense search.
 * - Each culling test of the hierarchy alone (sidedness, normal cone against the half-vector cone,
 *   spindle) never culls a ball holding a solution, and does cull random balls.
 * - The Specular Polynomials refraction fixture (Fan et al. 2024, test "T #1"), which is not an
 *   admissible refraction (see the test).
 * - The hierarchy returns the same solutions as the loop over every triangle.
 * - The distance correction factor (ray differentials) against the chain's generalized geometry
 *   term, and the closed form for a flat interface.
 * - Images: path with --specular-nee conic against ipt (per-pixel z-test) on a glass bunny-like
 *   mesh (scenes/meshes/conic_bunny.obj) with a mirror blob, and a water surface (larger versions by
 *   hand: bench/conic_validate.sh).
 */
/* ctest-labels: unit stat */
/* ctest-timeout: 600 */
#include <string.h>

#include "core/rng.h"
#include "harness.h"
#include "io/mesh_io.h"
#include "manifold/conic.h"
#include "manifold/polyroots.h"
#include "manifold/specular_nee.h"
#include "render_util.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }
static double rnd_in(double a, double b) { return a + (b - a) * rnd(); }
static spc_vec3 rnd_vec(double a, double b) { return spc_v3(rnd_in(a, b), rnd_in(a, b), rnd_in(a, b)); }
static spc_vec3 rnd_unit(void)
{
    for (;;) {
        spc_vec3 v = rnd_vec(-1, 1);
        double l = spc_length(v);
        if (l > 0.1 && l <= 1.0)
            return spc_scale(v, 1.0 / l);
    }
}

/* ================= polynomial tools ================= */

TEST(taylor_shift_matches_binomial)
{
    for (int it = 0; it < 200; ++it) {
        int n = 1 + (int)(rnd() * 8);
        double c[SPC_POLY_MAX_DEGREE + 1] = {0}, s = rnd_in(-2, 2);
        for (int i = 0; i <= n; ++i)
            c[i] = rnd_in(-1, 1);
        double d[SPC_POLY_MAX_DEGREE + 1];
        memcpy(d, c, sizeof c);
        spc_poly_taylor_shift(d, n, s);
        /* naive: sum_i c_i (X + s)^i */
        double e[SPC_POLY_MAX_DEGREE + 1] = {0};
        for (int i = 0; i <= n; ++i) {
            double binom = 1.0;
            for (int k = 0; k <= i; ++k) {
                e[k] += c[i] * binom * pow(s, i - k);
                binom = binom * (i - k) / (k + 1);
            }
        }
        for (int k = 0; k <= n; ++k)
            CHECK_NEAR(d[k], e[k], 1e-11 * (1 + fabs(e[k])) * pow(1 + fabs(s), n));
        /* and evaluation agrees */
        double t = rnd_in(-1, 1);
        CHECK_NEAR(spc_poly_eval(d, n, t), spc_poly_eval(c, n, t + s), 1e-10 * pow(2 + fabs(s), n));
    }
}

/* P = lead * prod (X - r_i) */
static int poly_from_roots(const double *r, int n, double lead, double *c)
{
    c[0] = lead;
    int deg = 0;
    for (int i = 0; i < n; ++i) {
        double nc[SPC_POLY_MAX_DEGREE + 2] = {0};
        nc[0] = -r[i] * c[0];
        for (int k = 1; k <= deg; ++k)
            nc[k] = c[k - 1] - r[i] * c[k];
        nc[deg + 1] = c[deg];
        ++deg;
        memcpy(c, nc, (size_t)(deg + 1) * sizeof *c);
    }
    return deg;
}

/* Is t within tol of one of the n values? */
static bool near_any(double t, const double *r, int n, double tol)
{
    for (int i = 0; i < n; ++i)
        if (fabs(t - r[i]) <= tol)
            return true;
    return false;
}

/* How far rounding the coefficients may move the root r of P (its condition number, generously). */
static double root_tol(const double *c, int deg, double r)
{
    double d, sabs = 0.0;
    spc_poly_eval_deriv(c, deg, r, &d);
    for (int q = 0; q <= deg; ++q)
        sabs += fabs(c[q]) * pow(fmax(fabs(r), 0.1), q);
    return 1e-13 * sabs / fabs(d) + 1e-13;
}

/* Distance from t to the nearest of the n values, and that value's index. */
static double nearest(double t, const double *r, int n, int *which)
{
    double best = INFINITY;
    for (int i = 0; i < n; ++i)
        if (fabs(t - r[i]) < best) {
            best = fabs(t - r[i]);
            *which = i;
        }
    return best;
}

TEST(vca_against_sturm_and_known_roots)
{
    int cases = 0, sturm_checked = 0, dup = 0, clusters_complex = 0, sf_checked = 0;
    for (int it = 0; it < 4000; ++it) {
        int kind = it % 4;
        double r[SPC_POLY_MAX_DEGREE];
        int n = 0;
        if (kind == 0) {
            /* distinct roots in and around [0, 1], at least 1e-3 apart */
            int want = 1 + (int)(rnd() * 6);
            while (n < want) {
                double c = rnd_in(-0.5, 1.5);
                if (!near_any(c, r, n, 1e-3))
                    r[n++] = c;
            }
        } else if (kind == 1) {
            /* clusters: pairs 1e-3 .. 1e-5 apart, triples 1e-2 .. 1e-3.5 apart (closer clusters
             * may not be real any more once the coefficients are rounded: see the next test) */
            while (n < 6) {
                double c = rnd_in(0.05, 0.9);
                if (near_any(c, r, n, 0.02))
                    continue;
                int k = rnd() < 0.5 ? 2 : 3;
                double sep = k == 2 ? pow(10.0, -rnd_in(3, 5)) : pow(10.0, -rnd_in(2, 3.5));
                for (int j = 0; j < k && n < 6; ++j)
                    r[n++] = c + j * sep;
            }
        } else if (kind == 2) {
            /* exactly repeated dyadic roots (the coefficients are then exact) */
            while (n < 6) {
                double c = (double)(1 + (int)(rnd() * 63)) / 64.0;
                int k = 1 + (int)(rnd() * 3);
                for (int j = 0; j < k && n < 6; ++j)
                    r[n++] = c;
            }
        } else {
            /* roots on the ends and on bisection points (rounding puts them on either side) */
            double special[5] = {0.0, 1.0, 0.5, 0.25, 0.75};
            while (n < 5) {
                double c = rnd() < 0.5 ? special[(int)(rnd() * 5)] : rnd_in(-1, 2);
                if (!near_any(c, r, n, 1e-3))
                    r[n++] = c;
            }
        }
        double c[SPC_POLY_MAX_DEGREE + 1];
        int deg = poly_from_roots(r, n, rnd() < 0.5 ? 1.0 : -3.7, c);
        double in01[SPC_POLY_MAX_DEGREE];
        int nin = 0;
        for (int i = 0; i < n; ++i)
            if (r[i] >= 0.0 && r[i] <= 1.0 && !near_any(r[i], in01, nin, 0.0))
                in01[nin++] = r[i];
        spc_root_interval iv[16];
        int k = spc_poly_isolate(c, deg, 0.0, 1.0, iv, 16);
        ++cases;
        for (int j = 1; j < k; ++j)
            CHECK(iv[j].lo >= iv[j - 1].hi);
        if (kind == 0 || kind == 1) {
            /* simple roots: one isolating interval each, confirmed by Sturm, refined to the root */
            spc_sturm s;
            spc_poly_sturm_init(&s, c, deg, 0.0);
            int sturm = spc_poly_sturm_count(&s, 0.0, 1.0);
            /* a tight cluster may have turned complex once the coefficients were rounded: VCA must
             * then agree with Sturm on the rounded polynomial */
            CHECK_MSG(k == sturm, "kind %d: %d intervals, Sturm counts %d", kind, k, sturm);
            CHECK_MSG(kind == 1 || k == nin, "kind %d: %d intervals for %d roots", kind, k, nin);
            clusters_complex += kind == 1 && sturm < nin;
            for (int j = 0; j < k && j < 16; ++j) {
                CHECK(iv[j].bound == 1);
                if (iv[j].lo < iv[j].hi) {
                    int cnt = spc_poly_sturm_count(&s, iv[j].lo, iv[j].hi);
                    CHECK_MSG(cnt == 1, "interval [%.17g, %.17g]: Sturm counts %d", iv[j].lo, iv[j].hi, cnt);
                    ++sturm_checked;
                }
                double t = spc_poly_refine(c, deg, &iv[j]);
                int w = 0;
                double best = nearest(t, in01, nin, &w), tol = nin ? root_tol(c, deg, in01[w]) : 0.0;
                CHECK_MSG(best <= tol, "refined root %.17g off by %.3g (tolerance %.3g)", t, best, tol);
            }
        } else if (kind == 2) {
            /* repeated roots: the square-free part has exactly the distinct roots, simple, and
             * Sturm on P counts distinct roots */
            double distinct[SPC_POLY_MAX_DEGREE];
            int nd = 0;
            for (int i = 0; i < n; ++i)
                if (!near_any(r[i], distinct, nd, 0.0))
                    distinct[nd++] = r[i];
            double sf[SPC_POLY_MAX_DEGREE + 1];
            int ns = spc_poly_squarefree(c, deg, 1e-8, sf);
            /* the numerical gcd perturbs the square-free part; distinct roots closer than 1/16
             * may then merge into a complex pair (ill-conditioned: not checked) */
            double minsep = 1.0;
            for (int i = 0; i < nd; ++i)
                for (int j = i + 1; j < nd; ++j)
                    minsep = fmin(minsep, fabs(distinct[i] - distinct[j]));
            if (minsep < 1.0 / 16.0) {
                CHECK_MSG(ns == nd, "square-free degree %d, distinct roots %d", ns, nd);
                continue;
            }
            ++sf_checked;
            CHECK_MSG(ns == nd, "square-free degree %d, distinct roots %d", ns, nd);
            double roots[16];
            int m = spc_poly_roots(sf, ns, 0.0, 1.0, roots, 16);
            for (int j = 0; j < m && j < 16; ++j)
                CHECK_MSG(near_any(roots[j], in01, nin, 1e-6), "square-free root %.15g is no root", roots[j]);
            for (int i = 0; i < nin; ++i)
                CHECK_MSG(near_any(in01[i], roots, m, 1e-6), "root %.15g of the square-free part not found", in01[i]);
            CHECK_MSG(m <= nin + 1, "square-free part: %d roots in [0,1], %d expected", m, nin);
            spc_sturm s;
            spc_poly_sturm_init(&s, c, deg, 1e-8);
            int cnt = spc_poly_sturm_count(&s, -1e-9, 1.0 + 1e-9);
            CHECK_MSG(cnt == nin, "Sturm count with repeated roots: %d vs %d", cnt, nin);
        } else {
            /* roots within rounding of the ends or of bisection points: never lost (they may be
             * reported twice, in neighbouring intervals, or just outside [0, 1]) */
            for (int i = 0; i < nin; ++i) {
                bool in = in01[i] == 0.0 || in01[i] == 1.0; /* may round out of [0, 1] */
                for (int j = 0; j < k && j < 16; ++j)
                    in = in || (in01[i] >= iv[j].lo - 1e-15 && in01[i] <= iv[j].hi + 1e-15);
                CHECK_MSG(in, "root %.17g lost", in01[i]);
            }
            for (int j = 0; j < k && j < 16; ++j) {
                double t = spc_poly_refine(c, deg, &iv[j]);
                int w = 0;
                double best = nearest(t, in01, nin, &w), tol = nin ? root_tol(c, deg, in01[w]) : 0.0;
                CHECK_MSG(best <= tol, "refined root %.17g off by %.3g (tolerance %.3g)", t, best, tol);
            }
            dup += k > nin;
        }
    }
    printf("    %d polynomials, %d isolating intervals confirmed by Sturm, %d with a root reported twice, %d clusters "
           "complex after rounding (VCA agreed with Sturm), %d square-free parts checked\n",
           cases, sturm_checked, dup, clusters_complex, sf_checked);
}

/* ================= the conic ================= */

static spc_conic_tri random_tri(double spread)
{
    spc_vec3 p[3], n[3];
    for (int k = 0; k < 3; ++k)
        p[k] = rnd_vec(-1, 1);
    spc_vec3 ng = spc_normalize(spc_cross(spc_sub(p[1], p[0]), spc_sub(p[2], p[0])));
    for (int k = 0; k < 3; ++k)
        n[k] = spc_normalize(spc_add(ng, rnd_vec(-spread, spread)));
    return spc_conic_tri_make(p[0], p[1], p[2], n[0], n[1], n[2]);
}

TEST(conic_coefficients_and_chord_polynomial)
{
    double worst_q = 0.0, worst_f = 0.0;
    for (int it = 0; it < 2000; ++it) {
        spc_conic_tri t = random_tri(0.8);
        spc_vec3 x = rnd_vec(-3, 3), y = rnd_vec(-3, 3);
        spc_conic q = spc_conic_coplanarity(&t, x, y);
        double u = rnd_in(-0.5, 1.5), v = rnd_in(-0.5, 1.5);
        spc_vec3 P = spc_conic_tri_point(&t, u, v), n = spc_conic_tri_normal(&t, u, v);
        spc_vec3 ax = spc_sub(x, P), ay = spc_sub(y, P);
        double direct = spc_dot(n, spc_cross(ax, ay));
        double scale = spc_length(n) * spc_length(ax) * spc_length(ay);
        worst_q = fmax(worst_q, fabs(spc_conic_eval(&q, u, v) - direct) / scale);
        /* the chord polynomial against the squared law evaluated in 3D */
        spc_vec2 a = spc_v2(rnd(), rnd()), b = spc_v2(rnd(), rnd());
        double ex = rnd_in(1, 2.5), ey = rnd_in(1, 2.5), f[7];
        spc_conic_chord_poly(&t, x, y, ex, ey, a, b, f);
        double tt = rnd_in(-0.2, 1.2);
        double fd = spc_conic_snell_eval(&t, x, y, ex, ey, a.x + tt * (b.x - a.x), a.y + tt * (b.y - a.y));
        double fs = ex * ex * spc_length2(ay) * spc_length2(ax) * spc_length2(n) + ey * ey * spc_length2(ax) * spc_length2(ay) *
                                                                                           spc_length2(n);
        worst_f = fmax(worst_f, fabs(spc_poly_eval(f, 6, tt) - fd) / (fs + 1e-300));
    }
    printf("    largest relative error: conic %.2g, chord polynomial %.2g\n", worst_q, worst_f);
    CHECK(worst_q < 1e-13);
    CHECK(worst_f < 1e-11);
}

/* Q from a matrix form, randomly rescaled (the classification must not depend on the scale). */
static spc_conic conic_of(double A, double B, double C, double D, double E, double F)
{
    double s = pow(10.0, rnd_in(-8, 8)) * (rnd() < 0.5 ? -1 : 1);
    return (spc_conic){A * s, B * s, C * s, D * s, E * s, F * s};
}

/* (u - a)(v - b) style products of lines a1 u + b1 v + c1 and a2 u + b2 v + c2 */
static spc_conic line_product(double a1, double b1, double c1, double a2, double b2, double c2)
{
    return conic_of(a1 * a2, a1 * b2 + a2 * b1, b1 * b2, a1 * c2 + a2 * c1, b1 * c2 + b2 * c1, c1 * c2);
}

TEST(conic_classification)
{
    typedef struct {
        spc_conic q;
        spc_conic_type want;
        const char *what;
    } conic_case;
    conic_case cases[16];
    int n = 0;
    for (int rep = 0; rep < 20; ++rep) {
        n = 0;
        /* (u-.3)^2/.01 + (v-.3)^2/.04 = 1, rotated by expanding a rotated quadratic form */
        cases[n++] = (conic_case){conic_of(1 / 0.01, 0, 1 / 0.04, -0.6 / 0.01, -0.6 / 0.04, 0.09 / 0.01 + 0.09 / 0.04 - 1),
                                        SPC_CONIC_ELLIPSE, "ellipse"};
        cases[n++] = (conic_case){conic_of(1, 0, 1, -0.6, -0.6, 0.18 + 1), SPC_CONIC_EMPTY, "imaginary ellipse"};
        cases[n++] = (conic_case){conic_of(1, 0, -1, -0.6, 0.6, -0.01), SPC_CONIC_HYPERBOLA, "hyperbola"};
        cases[n++] = (conic_case){conic_of(-1, 0, 0, 0.8, 1, -0.16 - 0.1), SPC_CONIC_PARABOLA, "parabola"};
        cases[n++] = (conic_case){conic_of(1, 2, 1, -0.3, -0.7, 0.05), SPC_CONIC_PARABOLA, "oblique parabola"};
        cases[n++] = (conic_case){line_product(1, 0, -0.2, 0, 1, -0.3), SPC_CONIC_LINE_PAIR, "line pair"};
        cases[n++] = (conic_case){line_product(1, 2, -0.5, 3, -1, 0.2), SPC_CONIC_LINE_PAIR, "oblique line pair"};
        cases[n++] = (conic_case){line_product(1, 0, -0.2, 1, 0, -0.5), SPC_CONIC_PARALLEL_LINES, "parallel lines"};
        cases[n++] = (conic_case){line_product(1, 1, -0.5, 1, 1, -0.5), SPC_CONIC_DOUBLE_LINE, "double line"};
        cases[n++] = (conic_case){conic_of(1, 0, 1, -0.4, -0.6, 0.13), SPC_CONIC_POINT, "point"};
        cases[n++] = (conic_case){conic_of(1, 0, 0, -0.4, 0, 0.05), SPC_CONIC_EMPTY, "complex parallel lines"};
        cases[n++] = (conic_case){conic_of(0, 0, 0, 1, 2, -0.5), SPC_CONIC_LINE, "line"};
        cases[n++] = (conic_case){conic_of(0, 0, 0, 0, 0, 1), SPC_CONIC_EMPTY, "constant"};
        cases[n++] = (conic_case){(spc_conic){0, 0, 0, 0, 0, 0}, SPC_CONIC_PLANE, "zero"};
        for (int i = 0; i < n; ++i) {
            spc_conic_type got = spc_conic_classify(&cases[i].q);
            CHECK_MSG(got == cases[i].want, "%s classified as %s", cases[i].what, spc_conic_type_name(got));
        }
    }
}

/* Distance from p to the segment ab. */
static double seg_dist(spc_vec2 p, spc_vec2 a, spc_vec2 b)
{
    double dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
    double t = l2 > 0 ? ((p.x - a.x) * dx + (p.y - a.y) * dy) / l2 : 0.0;
    t = spc_clamp(t, 0.0, 1.0);
    return hypot(p.x - a.x - t * dx, p.y - a.y - t * dy);
}

/* Arcs and chords of a conic: every chord end on the conic and in the triangle, every chord
 * within its tolerance of the arc, and every sign change of Q on a fine grid near some chord (the
 * chords cover the conic's part in the triangle). Returns false on the first failure. */
static bool check_arcs(const spc_conic *q0, double tol, int *nchords, char *why, size_t whylen)
{
    spc_conic_arcs arcs;
    spc_conic_find_arcs(q0, &arcs);
    double s = fmax(fmax(fmax(fabs(q0->A), fabs(q0->B)), fmax(fabs(q0->C), fabs(q0->D))), fmax(fabs(q0->E), fabs(q0->F)));
    spc_conic q = *q0;
    if (s > 0)
        q = (spc_conic){q0->A / s, q0->B / s, q0->C / s, q0->D / s, q0->E / s, q0->F / s};
    static spc_conic_arc ch[4096];
    int nc = 0;
    for (int i = 0; i < arcs.narcs; ++i)
        nc += spc_conic_chords(&arcs, &arcs.arc[i], tol, ch + nc, 4096 - nc);
    *nchords = nc;
    for (int i = 0; i < nc; ++i) {
        spc_vec2 e[2] = {ch[i].a, ch[i].b};
        for (int k = 0; k < 2; ++k) {
            spc_vec2 g = spc_v2(2 * q.A * e[k].x + q.B * e[k].y + q.D, q.B * e[k].x + 2 * q.C * e[k].y + q.E);
            double dist = fabs(spc_conic_eval(&q, e[k].x, e[k].y)) / fmax(hypot(g.x, g.y), 1e-300);
            if (dist > 1e-9 || e[k].x < -1e-9 || e[k].y < -1e-9 || e[k].x + e[k].y > 1 + 1e-9) {
                snprintf(why, whylen, "%s: chord end (%g, %g) off the conic by %g or outside", spc_conic_type_name(arcs.type),
                         e[k].x, e[k].y, dist);
                return false;
            }
        }
        if (!ch[i].segment && ch[i].err > tol * (1 + 1e-9)) {
            snprintf(why, whylen, "chord error %g above %g", ch[i].err, tol);
            return false;
        }
    }
    /* sign changes of Q along the edges of a fine grid clipped to the triangle */
    const int N = 300;
    double h = 1.0 / N;
    for (int i = 0; i <= N; ++i)
        for (int j = 0; i + j <= N; ++j) {
            double u = i * h, v = j * h, q00 = spc_conic_eval(&q, u, v);
            for (int dir = 0; dir < 2; ++dir) {
                int i2 = i + (dir == 0), j2 = j + (dir == 1);
                if (i2 + j2 > N)
                    continue;
                double u2 = i2 * h, v2 = j2 * h, q11 = spc_conic_eval(&q, u2, v2);
                if (!(q00 * q11 < 0))
                    continue;
                double tz = q00 / (q00 - q11);
                spc_vec2 z = spc_v2(u + tz * (u2 - u), v + tz * (v2 - v));
                double best = INFINITY;
                for (int k = 0; k < nc; ++k)
                    best = fmin(best, seg_dist(z, ch[k].a, ch[k].b));
                for (int k = 0; k < arcs.npoints; ++k)
                    best = fmin(best, hypot(z.x - arcs.point[k].x, z.y - arcs.point[k].y));
                if (best > tol + 2 * h) {
                    snprintf(why, whylen, "%s: the conic crosses (%g, %g), %g from every chord",
                             spc_conic_type_name(arcs.type), z.x, z.y, best);
                    return false;
                }
            }
        }
    return true;
}

TEST(conic_arcs_and_chords)
{
    char why[256];
    int total_chords = 0, checked = 0;
    /* constructed cases: a whole ellipse inside, one tangent to two edges, a parabola, line
     * pairs crossing inside and on an edge, parallel lines, a line through a vertex */
    spc_conic special[] = {
        {1 / 0.01, 0, 1 / 0.04, -0.6 / 0.01, -0.6 / 0.04, 0.09 / 0.01 + 0.09 / 0.04 - 1},
        {1, 0, 1, -0.6, -0.6, 0.09}, /* circle (0.3, 0.3) radius 0.3: tangent to u = 0 and v = 0 */
        {-1, 0, 0, 0.8, 1, -0.26},
        {1, 0, -1, -0.6, 0.6, -0.01},
        {0, 1, 0, -0.3, -0.2, 0.06}, /* (u - 0.2)(v - 0.3) */
        {0, 1, 0, 0, -0.2, 0},       /* u (v - 0.2): one line on the edge u = 0 */
        {1, 0, 0, -0.7, 0, 0.1},     /* (u - 0.2)(u - 0.5) */
        {0, 0, 0, 1, -1, 0},         /* u = v through the vertex (0, 0) */
        {1, 2, 1, -0.3, -0.7, 0.05},
    };
    for (size_t i = 0; i < sizeof special / sizeof special[0]; ++i) {
        int nc;
        bool ok = check_arcs(&special[i], 1e-3, &nc, why, sizeof why);
        CHECK_MSG(ok, "special case %zu: %s", i, why);
        total_chords += nc;
        ++checked;
    }
    /* the whole ellipse inside gives a closed chain of chords */
    {
        spc_conic_arcs arcs;
        spc_conic_find_arcs(&special[0], &arcs);
        CHECK(arcs.type == SPC_CONIC_ELLIPSE && arcs.narcs >= 2);
    }
    /* random conics, and conics of random triangles (nearly straight ones included) */
    for (int it = 0; it < 3000; ++it) {
        spc_conic q;
        if (it % 2) {
            q = (spc_conic){rnd_in(-1, 1), rnd_in(-1, 1), rnd_in(-1, 1), rnd_in(-1, 1), rnd_in(-1, 1), rnd_in(-0.3, 0.3)};
        } else {
            spc_conic_tri t = random_tri(it % 4 == 0 ? 0.02 : 0.7);
            q = spc_conic_coplanarity(&t, rnd_vec(-3, 3), rnd_vec(-3, 3));
        }
        int nc;
        bool ok = check_arcs(&q, 1e-3, &nc, why, sizeof why);
        CHECK_MSG(ok, "random conic %d: %s", it, why);
        if (!ok)
            break;
        total_chords += nc;
        ++checked;
    }
    printf("    %d conics, %d chords (tolerance 1e-3) covering every sign change of Q on a 300 x 300 grid\n", checked,
           total_chords);
}

/* ================= the solver against a dense search ================= */

/* The law, written independently of the solver: the side-correct indices and the residual
 * |n^ x (ex wx + ey wy)| / (ex + ey); +inf where the sides cannot carry the event. */
static double bf_law(const spc_conic_tri *t, const spc_conic_problem *pb, double u, double v, double *ex,
                     double *ey, spc_vec3 *R)
{
    spc_vec3 P = spc_add(t->p0, spc_add(spc_scale(t->e1, u), spc_scale(t->e2, v)));
    spc_vec3 n = spc_add(t->n0, spc_add(spc_scale(t->dn1, u), spc_scale(t->dn2, v)));
    double ln = spc_length(n);
    if (!(ln > 1e-9))
        return INFINITY;
    spc_vec3 nh = spc_scale(n, 1.0 / ln);
    spc_vec3 wx = spc_normalize(spc_sub(pb->x, P)), wy = spc_normalize(spc_sub(pb->y, P));
    double cx = spc_dot(wx, nh), cy = spc_dot(wy, nh);
    if (pb->event == SPC_CONIC_REFLECT) {
        if (!(cx * cy > 0.0) || (pb->front_only && !(cx > 0.0)))
            return INFINITY;
        *ex = *ey = 1.0;
    } else {
        if (!(cx * cy < 0.0))
            return INFINITY;
        *ex = cx > 0.0 ? 1.0 : pb->eta;
        *ey = cx > 0.0 ? pb->eta : 1.0;
    }
    *R = spc_cross(nh, spc_add(spc_scale(wx, *ex), spc_scale(wy, *ey)));
    return spc_length(*R) / (*ex + *ey);
}

/* R with fixed indices (for Newton). */
static bool bf_R(const spc_conic_tri *t, const spc_conic_problem *pb, double u, double v, double ex, double ey,
                 spc_vec3 *R)
{
    spc_vec3 P = spc_add(t->p0, spc_add(spc_scale(t->e1, u), spc_scale(t->e2, v)));
    spc_vec3 n = spc_add(t->n0, spc_add(spc_scale(t->dn1, u), spc_scale(t->dn2, v)));
    double ln = spc_length(n);
    if (!(ln > 0.0))
        return false;
    spc_vec3 nh = spc_scale(n, 1.0 / ln);
    spc_vec3 wx = spc_normalize(spc_sub(pb->x, P)), wy = spc_normalize(spc_sub(pb->y, P));
    *R = spc_cross(nh, spc_add(spc_scale(wx, ex), spc_scale(wy, ey)));
    return true;
}

/* Newton (Gauss-Newton, central-difference Jacobian, step halving) from (u, v). */
static bool bf_newton(const spc_conic_tri *t, const spc_conic_problem *pb, double ex, double ey, double *pu,
                      double *pv)
{
    double u = *pu, v = *pv;
    spc_vec3 R;
    if (!bf_R(t, pb, u, v, ex, ey, &R))
        return false;
    for (int it = 0; it < 80; ++it) {
        double r2 = spc_length2(R);
        if (sqrt(r2) < 1e-15 * (ex + ey))
            break;
        double h = 1e-7;
        spc_vec3 a, b, Ju, Jv;
        if (!bf_R(t, pb, u + h, v, ex, ey, &a) || !bf_R(t, pb, u - h, v, ex, ey, &b))
            return false;
        Ju = spc_scale(spc_sub(a, b), 0.5 / h);
        if (!bf_R(t, pb, u, v + h, ex, ey, &a) || !bf_R(t, pb, u, v - h, ex, ey, &b))
            return false;
        Jv = spc_scale(spc_sub(a, b), 0.5 / h);
        double a11 = spc_dot(Ju, Ju), a12 = spc_dot(Ju, Jv), a22 = spc_dot(Jv, Jv);
        double b1 = -spc_dot(Ju, R), b2 = -spc_dot(Jv, R), det = a11 * a22 - a12 * a12;
        if (!(det > 0.0))
            return false;
        double du = (a22 * b1 - a12 * b2) / det, dv = (a11 * b2 - a12 * b1) / det;
        double len = hypot(du, dv);
        if (len > 0.3) {
            du *= 0.3 / len;
            dv *= 0.3 / len;
        }
        bool ok = false;
        for (int k = 0; k < 30 && !ok; ++k) {
            spc_vec3 Rn;
            if (bf_R(t, pb, u + du, v + dv, ex, ey, &Rn) && spc_length2(Rn) < r2) {
                u += du;
                v += dv;
                R = Rn;
                ok = true;
            } else {
                du *= 0.5;
                dv *= 0.5;
            }
        }
        if (!ok)
            break;
    }
    *pu = u;
    *pv = v;
    return spc_length(R) / (ex + ey) < 1e-11;
}

#define BF_GRID 120
#define BF_MAX 64

/* Every solution the dense search finds: Newton from every local minimum of the residual on a
 * BF_GRID x BF_GRID barycentric grid, kept if converged, admissible and inside (within 1e-9). */
static int brute_force(const spc_conic_tri *t, const spc_conic_problem *pb, double (*out)[2], int max_out)
{
    static double val[BF_GRID + 1][BF_GRID + 1];
    const int N = BF_GRID;
    for (int i = 0; i <= N; ++i)
        for (int j = 0; i + j <= N; ++j) {
            double ex, ey;
            spc_vec3 R;
            val[i][j] = bf_law(t, pb, (double)i / N, (double)j / N, &ex, &ey, &R);
        }
    int n = 0;
    for (int i = 0; i <= N; ++i)
        for (int j = 0; i + j <= N; ++j) {
            double f = val[i][j];
            if (!isfinite(f))
                continue;
            bool minimum = true;
            for (int di = -1; di <= 1 && minimum; ++di)
                for (int dj = -1; dj <= 1; ++dj) {
                    int a = i + di, b = j + dj;
                    if ((di || dj) && a >= 0 && b >= 0 && a + b <= N && val[a][b] < f) {
                        minimum = false;
                        break;
                    }
                }
            if (!minimum)
                continue;
            double u = (double)i / N, v = (double)j / N, ex, ey;
            spc_vec3 R;
            bf_law(t, pb, u, v, &ex, &ey, &R);
            if (!bf_newton(t, pb, ex, ey, &u, &v))
                continue;
            double ex2, ey2;
            double res = bf_law(t, pb, u, v, &ex2, &ey2, &R);
            if (!(res < 1e-11) || ex2 != ex || u < -1e-9 || v < -1e-9 || u + v > 1 + 1e-9)
                continue;
            bool dup = false;
            for (int k = 0; k < n; ++k)
                dup = dup || hypot(out[k][0] - u, out[k][1] - v) < 1e-7;
            if (!dup && n < max_out) {
                out[n][0] = u;
                out[n][1] = v;
                ++n;
            }
        }
    return n;
}

/* A random triangle configuration; kind picks how. */
static void random_config(int cfg, spc_conic_tri *t, spc_conic_problem *pb)
{
    spc_vec3 p[3], n[3];
    for (int k = 0; k < 3; ++k)
        p[k] = rnd_vec(-1, 1);
    spc_vec3 ng = spc_normalize(spc_cross(spc_sub(p[1], p[0]), spc_sub(p[2], p[0])));
    int nk = cfg % 5;
    for (int k = 0; k < 3; ++k) {
        if (nk == 0) /* face normals: the conic is a line */
            n[k] = ng;
        else if (nk == 1) /* nearly flat smooth surface */
            n[k] = spc_normalize(spc_add(ng, rnd_vec(-0.05, 0.05)));
        else if (nk == 2 || nk == 3) /* strongly curved */
            n[k] = spc_normalize(spc_add(ng, rnd_vec(-0.6, 0.6)));
        else /* anything, flips included */
            n[k] = rnd_unit();
    }
    *t = spc_conic_tri_make(p[0], p[1], p[2], n[0], n[1], n[2]);
    pb->event = (cfg / 5) % 2 ? SPC_CONIC_REFRACT : SPC_CONIC_REFLECT;
    pb->eta = rnd_in(1.1, 2.5);
    pb->front_only = pb->event == SPC_CONIC_REFLECT && (cfg / 30) % 2; /* a one-sided mirror */
    int xk = (cfg / 10) % 3;
    if (xk == 0) {
        /* x and y anywhere around */
        pb->x = rnd_vec(-3, 3);
        pb->y = rnd_vec(-3, 3);
        return;
    }
    /* built around a known solution at a random point of the triangle */
    double a = rnd(), b = rnd();
    if (a + b > 1.0) {
        a = 1.0 - a;
        b = 1.0 - b;
    }
    spc_vec3 P = spc_conic_tri_point(t, a, b), nh = spc_normalize(spc_conic_tri_normal(t, a, b));
    for (int tries = 0; tries < 100; ++tries) {
        spc_vec3 wx = rnd_unit();
        if (fabs(spc_dot(wx, nh)) < 0.05)
            continue;
        pb->x = spc_madd(P, wx, rnd_in(0.3, 4.0));
        spc_vec3 d = spc_neg(wx), out;
        if (pb->event == SPC_CONIC_REFLECT) {
            out = spc_sub(d, spc_scale(nh, 2.0 * spc_dot(d, nh)));
        } else {
            double c = -spc_dot(d, nh), r = c > 0.0 ? 1.0 / pb->eta : pb->eta;
            spc_vec3 m = c > 0.0 ? nh : spc_neg(nh);
            c = fabs(c);
            double k = 1.0 - r * r * (1.0 - c * c);
            if (!(k > 0.0))
                continue;
            out = spc_add(spc_scale(d, r), spc_scale(m, r * c - sqrt(k)));
        }
        pb->y = spc_madd(P, out, rnd_in(0.3, 4.0));
        if (xk == 2 && nk == 0 && tries == 0) {
            /* y - x along the constant normal: every point is coplanar (the PLANE case) */
            pb->y = spc_madd(pb->x, ng, -rnd_in(1.0, 4.0) * (spc_dot(spc_sub(pb->x, P), ng) > 0 ? 1 : -1));
        }
        return;
    }
    pb->x = rnd_vec(-3, 3);
    pb->y = rnd_vec(-3, 3);
}

TEST(solver_against_dense_search)
{
    /* CONIC_CONFIGS / CONIC_SEED: longer or different runs by hand */
    const int configs = getenv("CONIC_CONFIGS") ? atoi(getenv("CONIC_CONFIGS")) : spc_test_quick() ? 1000 : 10000;
    if (getenv("CONIC_SEED"))
        spc_rng_seed(&rng, (uint64_t)atoll(getenv("CONIC_SEED")), 7);
    long brute_total = 0, brute_inner = 0, found_inner = 0, conic_total = 0, conic_only = 0, bad_law = 0;
    int type_count[SPC_CONIC_PLANE + 1] = {0};
    spc_conic_stats st;
    memset(&st, 0, sizeof st);
    int reported = 0;
    for (int cfg = 0; cfg < configs; ++cfg) {
        spc_conic_tri t;
        spc_conic_problem pb;
        random_config(cfg, &t, &pb);
        spc_conic q = spc_conic_coplanarity(&t, pb.x, pb.y);
        type_count[spc_conic_classify(&q)]++;
        spc_conic_solution sol[32];
        int ns = spc_conic_solve_triangle(&t, &pb, sol, 32, &st);
        double bf[BF_MAX][2];
        int nb = brute_force(&t, &pb, bf, BF_MAX);
        brute_total += nb;
        conic_total += ns;
        /* precision: every solution satisfies the law, admissibly, inside */
        for (int i = 0; i < ns; ++i) {
            double ex, ey;
            spc_vec3 R;
            double res = bf_law(&t, &pb, sol[i].u, sol[i].v, &ex, &ey, &R);
            bool inside = sol[i].u >= -1e-9 && sol[i].v >= -1e-9 && sol[i].u + sol[i].v <= 1 + 1e-9;
            if (!(res <= 1e-9) || !inside) {
                ++bad_law;
                if (reported++ < 10)
                    printf("    config %d: solution (%.12g, %.12g) residual %.3g inside %d\n", cfg, sol[i].u, sol[i].v,
                           res, inside);
            }
            bool in_bf = false;
            for (int j = 0; j < nb; ++j)
                in_bf = in_bf || hypot(bf[j][0] - sol[i].u, bf[j][1] - sol[i].v) < 1e-6;
            conic_only += !in_bf;
        }
        /* recall: every solution of the search strictly inside the triangle is found */
        for (int j = 0; j < nb; ++j) {
            double u = bf[j][0], v = bf[j][1];
            if (u < 1e-7 || v < 1e-7 || u + v > 1 - 1e-7)
                continue; /* on an edge: the neighbour may own it */
            ++brute_inner;
            bool found = false;
            for (int i = 0; i < ns; ++i)
                found = found || hypot(sol[i].u - u, sol[i].v - v) < 1e-6;
            found_inner += found;
            if (!found && reported++ < 10)
                printf("    config %d (%s, %s, eta %.3f): missed (%.12g, %.12g); conic found %d, search %d\n", cfg,
                       spc_conic_type_name(spc_conic_classify(&q)), pb.event ? "refract" : "reflect", pb.eta, u, v, ns,
                       nb);
        }
    }
    printf("    %d configurations: conics", configs);
    for (int k = 0; k <= SPC_CONIC_PLANE; ++k)
        if (type_count[k])
            printf(" %s %d,", spc_conic_type_name((spc_conic_type)k), type_count[k]);
    printf("\n    dense search %ld solutions (%ld strictly inside), conic %ld; recall %ld/%ld, precision failures %ld, "
           "found by conic only %ld\n",
           brute_total, brute_inner, conic_total, found_inner, brute_inner, bad_law, conic_only);
    printf("    per configuration: %.2f chords, %.2f candidates polished\n", (double)st.chords / configs,
           (double)st.candidates / configs);
    CHECK(found_inner == brute_inner);
    CHECK(bad_law == 0);
    CHECK(brute_inner > configs / 2);
    CHECK(type_count[SPC_CONIC_ELLIPSE] > 0 && type_count[SPC_CONIC_HYPERBOLA] > 0 && type_count[SPC_CONIC_LINE] > 0 &&
          type_count[SPC_CONIC_PLANE] > 0);
}

/* ================= constructed special cases ================= */

static spc_vec2 conic_grad_of(const spc_conic *q, double u, double v)
{
    return spc_v2(2.0 * q->A * u + q->B * v + q->D, q->B * u + 2.0 * q->C * v + q->E);
}

/* The scattered direction of -wx about the unit normal nh (reflection, or refraction with the
 * solver's convention: index 1 on the side nh points to, eta behind); false on total internal
 * reflection. */
static bool scatter_dir(const spc_conic_problem *pb, spc_vec3 wx, spc_vec3 nh, spc_vec3 *out)
{
    spc_vec3 d = spc_neg(wx);
    if (pb->event == SPC_CONIC_REFLECT) {
        *out = spc_sub(d, spc_scale(nh, 2.0 * spc_dot(d, nh)));
        return true;
    }
    double c = -spc_dot(d, nh), r = c > 0.0 ? 1.0 / pb->eta : pb->eta;
    spc_vec3 m = c > 0.0 ? nh : spc_neg(nh);
    c = fabs(c);
    double k = 1.0 - r * r * (1.0 - c * c);
    if (!(k > 0.0))
        return false;
    *out = spc_add(spc_scale(d, r), spc_scale(m, r * c - sqrt(k)));
    return true;
}

/* A random triangle (vertex normals within `spread` of the face normal) with x and y built around
 * a solution at (us, vs); false if the scattered ray could not be built. */
static bool config_with_solution(int event, double spread, double us, double vs, spc_conic_tri *t,
                                 spc_conic_problem *pb)
{
    spc_vec3 p[3], n[3];
    for (int k = 0; k < 3; ++k)
        p[k] = rnd_vec(-1, 1);
    spc_vec3 ng = spc_normalize(spc_cross(spc_sub(p[1], p[0]), spc_sub(p[2], p[0])));
    for (int k = 0; k < 3; ++k)
        n[k] = spc_normalize(spc_add(ng, rnd_vec(-spread, spread)));
    *t = spc_conic_tri_make(p[0], p[1], p[2], n[0], n[1], n[2]);
    pb->event = event;
    pb->eta = rnd_in(1.1, 2.5);
    pb->front_only = false;
    spc_vec3 P = spc_conic_tri_point(t, us, vs), nh = spc_normalize(spc_conic_tri_normal(t, us, vs));
    for (int tries = 0; tries < 100; ++tries) {
        spc_vec3 wx = rnd_unit(), out;
        if (fabs(spc_dot(wx, nh)) < 0.1 || !scatter_dir(pb, wx, nh, &out))
            continue;
        pb->x = spc_madd(P, wx, rnd_in(0.5, 3.0));
        pb->y = spc_madd(P, out, rnd_in(0.5, 3.0));
        return true;
    }
    return false;
}

/* The triangle with the normal field changed by tau (w (u - us) or w (v - vs) for dir 0 or 1):
 * the normal at (us, vs), hence the solution there, is unchanged. */
static spc_conic_tri bend_normals(const spc_conic_tri *t0, int dir, spc_vec3 w, double us, double vs, double tau)
{
    spc_conic_tri t = *t0;
    if (dir == 0) {
        t.dn1 = spc_madd(t.dn1, w, tau);
        t.n0 = spc_madd(t.n0, w, -us * tau);
    } else {
        t.dn2 = spc_madd(t.dn2, w, tau);
        t.n0 = spc_madd(t.n0, w, -vs * tau);
    }
    return t;
}

static double det3_of(const spc_conic *q)
{
    double a = q->A, b = 0.5 * q->B, c = q->C, d = 0.5 * q->D, e = 0.5 * q->E, f = q->F;
    return a * (c * f - e * e) - b * (b * f - e * d) + d * (b * e - c * d);
}

/* A root of g on [lo, hi] from a sign change on a grid of 400 cells, bisected to the last bit;
 * false without a sign change. */
static bool bracket_root(double (*g)(double, void *), void *ctx, double lo, double hi, double *root)
{
    const int N = 400;
    double a = lo, ga = g(lo, ctx);
    for (int i = 1; i <= N; ++i) {
        double b = lo + (hi - lo) * i / N, gb = g(b, ctx);
        if (isfinite(ga) && isfinite(gb) && ga * gb <= 0.0) {
            for (int k = 0; k < 200 && b - a > 0.0; ++k) {
                double m = 0.5 * (a + b), gm = g(m, ctx);
                if (m <= a || m >= b)
                    break;
                if (ga * gm <= 0.0) {
                    b = m;
                    gb = gm;
                } else {
                    a = m;
                    ga = gm;
                }
            }
            *root = fabs(ga) < fabs(gb) ? a : b;
            return true;
        }
        a = b;
        ga = gb;
    }
    return false;
}

typedef struct bend_ctx {
    const spc_conic_tri *t;
    const spc_conic_problem *pb;
    int dir, what; /* what: 0 the parabola discriminant, 1 det of the 3x3 matrix, 2 dQ/du at (us, 0) */
    spc_vec3 w;
    double us, vs;
} bend_ctx;

static double bend_g(double tau, void *p)
{
    const bend_ctx *b = p;
    spc_conic_tri t = bend_normals(b->t, b->dir, b->w, b->us, b->vs, tau);
    spc_conic q = spc_conic_coplanarity(&t, b->pb->x, b->pb->y);
    double s = fmax(fmax(fmax(fabs(q.A), fabs(q.B)), fmax(fabs(q.C), fabs(q.D))), fmax(fabs(q.E), fabs(q.F)));
    if (!(s > 0.0))
        return NAN;
    if (b->what == 0)
        return (q.B * q.B - 4.0 * q.A * q.C) / (s * s);
    if (b->what == 1)
        return det3_of(&q) / (s * s * s);
    return (2.0 * q.A * b->us + q.B * b->vs + q.D) / s;
}

/* Checks one constructed case: the known solution (us, vs) is returned (within `near` in
 * barycentrics), every returned solution satisfies the law, and every solution of the dense search
 * strictly inside is returned. Returns false (and says why) on a failure. */
static bool check_case(const spc_conic_tri *t, const spc_conic_problem *pb, double us, double vs, double near,
                       const char *what, int *inner)
{
    spc_conic_solution sol[32];
    int ns = spc_conic_solve_triangle(t, pb, sol, 32, NULL);
    bool found = false;
    for (int i = 0; i < ns; ++i) {
        double ex, ey;
        spc_vec3 R;
        double res = bf_law(t, pb, sol[i].u, sol[i].v, &ex, &ey, &R);
        if (!(res <= 1e-9)) {
            printf("    %s: solution (%.12g, %.12g) residual %.3g\n", what, sol[i].u, sol[i].v, res);
            return false;
        }
        found = found || hypot(sol[i].u - us, sol[i].v - vs) < near;
    }
    if (!found) {
        printf("    %s: the known solution (%.12g, %.12g) missed (%d returned)\n", what, us, vs, ns);
        return false;
    }
    double bf[BF_MAX][2];
    int nb = brute_force(t, pb, bf, BF_MAX);
    for (int j = 0; j < nb; ++j) {
        double u = bf[j][0], v = bf[j][1];
        if (u < 1e-7 || v < 1e-7 || u + v > 1 - 1e-7)
            continue;
        ++*inner;
        bool got = false;
        for (int i = 0; i < ns; ++i)
            got = got || hypot(sol[i].u - u, sol[i].v - v) < fmax(near, 1e-6);
        if (!got) {
            printf("    %s: the dense search's (%.12g, %.12g) missed (%.3g from the known one)\n", what, u, v,
                   hypot(u - us, v - vs));
            return false;
        }
    }
    return true;
}

/* Conics the random configurations reach only by chance: the normal field is bent, keeping a known
 * solution, until the conic is a parabola, a line pair or a point (the solution then the point
 * itself), or tangent to an edge at a solution on it; each case against the known solution and
 * the dense search. */
TEST(constructed_degenerate_conics_and_tangency)
{
    int made[SPC_CONIC_PLANE + 1] = {0}, tangent = 0, tangent_outside = 0, crossing = 0, inner = 0, fails = 0;
    for (int it = 0; it < 1200 && fails < 5; ++it) {
        /* 0 parabola, 1 line pair (det = 0 by bisection), 2 tangency to the edge v = 0, 3 the
         * conic singular at the solution: a line pair crossing there, or a point conic */
        int kind = it % 4;
        int event = (it / 3) % 2 ? SPC_CONIC_REFRACT : SPC_CONIC_REFLECT;
        double us = rnd_in(0.1, 0.8), vs = kind == 2 ? 0.0 : rnd_in(0.05, 0.9 - us);
        spc_conic_tri t0, t;
        spc_conic_problem pb;
        if (!config_with_solution(event, 0.5, us, vs, &t0, &pb))
            continue;
        if (kind == 3) {
            /* bending by tau1 w1 (u - us) + tau2 w2 (v - vs) adds tau1 s.((P-x) x w1) (u - us) +
             * tau2 s.((P-x) x w2) (v - vs) to Q: the gradient at the solution is cancelled exactly */
            spc_vec3 w1 = rnd_unit(), w2 = rnd_unit(), sv = spc_sub(pb.y, pb.x);
            spc_vec3 ax = spc_sub(spc_conic_tri_point(&t0, us, vs), pb.x);
            spc_conic q0 = spc_conic_coplanarity(&t0, pb.x, pb.y);
            spc_vec2 g0 = conic_grad_of(&q0, us, vs);
            double k1 = spc_dot(sv, spc_cross(ax, w1)), k2 = spc_dot(sv, spc_cross(ax, w2));
            if (fabs(k1) < 1e-3 || fabs(k2) < 1e-3)
                continue;
            spc_conic_tri t1 = bend_normals(&t0, 0, w1, us, vs, -g0.x / k1);
            t = bend_normals(&t1, 1, w2, us, vs, -g0.y / k2);
        } else {
            bend_ctx b = {&t0, &pb, kind == 2 ? 0 : 1, kind, rnd_unit(), us, vs};
            double tau;
            if (!bracket_root(bend_g, &b, -4.0, 4.0, &tau))
                continue;
            t = bend_normals(&t0, b.dir, b.w, us, vs, tau);
        }
        /* the solution is kept: the normal at (us, vs) did not change */
        if (!(spc_conic_law_residual(&t, &pb, us, vs) < 1e-12))
            continue;
        spc_conic q = spc_conic_coplanarity(&t, pb.x, pb.y);
        spc_conic_type type = spc_conic_classify(&q);
        char what[96];
        if (kind == 2) {
            /* tangent to the edge v = 0 at (us, 0): from inside the triangle or from outside (then
             * that point is the only one of the conic in the closed triangle near it) */
            spc_vec2 g = conic_grad_of(&q, us, 0.0);
            if (!(fabs(g.x) <= 1e-9 * fabs(g.y)))
                continue;
            double curv = q.A; /* Q along the edge: A (u - us)^2 */
            bool outside = (curv > 0) == (g.y > 0); /* Q >= 0 on the edge, the conic bends to v < 0 */
            ++tangent;
            tangent_outside += outside;
            snprintf(what, sizeof what, "tangent to an edge (%s, %s)", outside ? "outside" : "inside",
                     event ? "refract" : "reflect");
        } else {
            if (kind == 0 && type != SPC_CONIC_PARABOLA)
                continue;
            if (kind == 1 && type != SPC_CONIC_LINE_PAIR)
                continue;
            if (kind == 3) {
                /* the singular point is the solution: the crossing of the pair, or the point */
                spc_vec2 g = conic_grad_of(&q, us, vs);
                double qs = fmax(fmax(fabs(q.A), fabs(q.B)), fabs(q.C));
                if (!(hypot(g.x, g.y) <= 1e-9 * qs) || (type != SPC_CONIC_LINE_PAIR && type != SPC_CONIC_POINT))
                    continue;
                crossing += type == SPC_CONIC_LINE_PAIR;
            }
            made[type]++;
            snprintf(what, sizeof what, "%s (%s)", spc_conic_type_name(type), event ? "refract" : "reflect");
        }
        /* a conic singular at the solution makes it a double root of the 2D system too (coplanarity
         * holds to second order there): solutions then agree to ~1e-6, so matched to 1e-4 */
        if (!check_case(&t, &pb, us, vs, kind == 3 ? 1e-4 : 1e-6, what, &inner))
            ++fails;
    }
    printf("    constructed: %d parabolas, %d line pairs (%d crossing at the solution), %d points (the solution), %d "
           "tangent to an edge (%d from outside); %d dense-search solutions inside\n",
           made[SPC_CONIC_PARABOLA], made[SPC_CONIC_LINE_PAIR], crossing, made[SPC_CONIC_POINT], tangent,
           tangent_outside, inner);
    CHECK(fails == 0);
    /* (a point conic cannot be built this way: every conic made singular at a solution came out a
     * line pair; point conics are covered by conic_classification and conic_arcs_and_chords) */
    CHECK(made[SPC_CONIC_PARABOLA] >= 50 && made[SPC_CONIC_LINE_PAIR] >= 50 && crossing >= 20);
    CHECK(tangent >= 50 && tangent_outside > 0 && tangent_outside < tangent);
}

typedef struct fold_ctx {
    const spc_conic_tri *t;
    spc_conic_problem pb;
    spc_vec3 P, out;
    double us, vs, ex, ey;
} fold_ctx;

/* The derivative of the squared law f along the conic at the known solution, for y at distance d
 * along the scattered ray (f(us, vs) = 0 for every d); it vanishes where y is on the caustic. */
static double fold_g(double d, void *p)
{
    fold_ctx *c = p;
    spc_vec3 y = spc_madd(c->P, c->out, d);
    spc_conic q = spc_conic_coplanarity(c->t, c->pb.x, y);
    spc_vec2 g = conic_grad_of(&q, c->us, c->vs);
    double lg = hypot(g.x, g.y);
    if (!(lg > 0.0))
        return NAN;
    spc_vec2 a = spc_v2(c->us, c->vs), b = spc_v2(c->us - g.y / lg, c->vs + g.x / lg);
    double f[7];
    spc_conic_chord_poly(c->t, c->pb.x, y, c->ex, c->ey, a, b, f);
    double scale = 0.0;
    for (int k = 0; k < 7; ++k)
        scale = fmax(scale, fabs(f[k]));
    return scale > 0.0 ? f[1] / scale : NAN;
}

/* Repeated roots: y placed exactly on the caustic of the known solution (the fold, where two
 * solutions merge), so the law has a double root there; and triangles whose interpolated normal
 * flips (vanishes on a line inside the triangle). */
TEST(constructed_double_roots_and_flipping_normals)
{
    int folds = 0, fold_found = 0, inner = 0, fails = 0;
    double worst_fold = 0.0;
    for (int it = 0; it < 1500 && folds < 150; ++it) {
        int event = it % 2 ? SPC_CONIC_REFRACT : SPC_CONIC_REFLECT;
        double us = rnd_in(0.1, 0.7), vs = rnd_in(0.1, 0.9 - us);
        spc_conic_tri t;
        spc_conic_problem pb;
        if (!config_with_solution(event, 0.6, us, vs, &t, &pb))
            continue;
        fold_ctx c = {&t, pb, spc_conic_tri_point(&t, us, vs), spc_v3(0, 0, 0), us, vs, 1.0, 1.0};
        c.out = spc_normalize(spc_sub(pb.y, c.P));
        spc_vec3 nh = spc_normalize(spc_conic_tri_normal(&t, us, vs));
        if (event == SPC_CONIC_REFRACT) {
            bool front = spc_dot(spc_sub(pb.x, c.P), nh) > 0.0;
            c.ex = front ? 1.0 : pb.eta;
            c.ey = front ? pb.eta : 1.0;
        }
        double d;
        if (!bracket_root(fold_g, &c, 0.05, 6.0, &d))
            continue;
        pb.y = spc_madd(c.P, c.out, d);
        if (!(spc_conic_law_residual(&t, &pb, us, vs) < 1e-12))
            continue;
        ++folds;
        /* at a double root the law's residual grows quadratically: a solution to 1e-10 may sit
         * ~1e-5 away, so the known one is matched to 1e-4 */
        spc_conic_solution sol[32];
        int ns = spc_conic_solve_triangle(&t, &pb, sol, 32, NULL);
        double best = INFINITY;
        for (int i = 0; i < ns; ++i)
            best = fmin(best, hypot(sol[i].u - us, sol[i].v - vs));
        fold_found += best < 1e-4;
        if (best < 1e-4)
            worst_fold = fmax(worst_fold, best);
        char what[64];
        snprintf(what, sizeof what, "fold (%s, d %.4g)", event ? "refract" : "reflect", d);
        if (!check_case(&t, &pb, us, vs, 1e-4, what, &inner))
            ++fails;
    }
    printf("    %d configurations with y on the caustic (a double root): the merged solution found in %d (within "
           "%.2g)\n",
           folds, fold_found, worst_fold);
    CHECK(folds >= 100);
    CHECK(fold_found == folds);
    /* flipping normals: n0 and n1 on opposite sides of the face, so the interpolated normal
     * vanishes on a line across the triangle and points to the other side beyond it */
    int flips = 0, flip_fails = 0, flip_inner = 0;
    for (int it = 0; it < 400; ++it) {
        spc_vec3 p[3], n[3];
        for (int k = 0; k < 3; ++k)
            p[k] = rnd_vec(-1, 1);
        spc_vec3 ng = spc_normalize(spc_cross(spc_sub(p[1], p[0]), spc_sub(p[2], p[0])));
        n[0] = spc_normalize(spc_add(ng, rnd_vec(-0.5, 0.5)));
        n[1] = spc_normalize(spc_add(spc_neg(ng), rnd_vec(-0.5, 0.5)));
        n[2] = spc_normalize(spc_add(rnd() < 0.5 ? ng : spc_neg(ng), rnd_vec(-0.5, 0.5)));
        spc_conic_tri t = spc_conic_tri_make(p[0], p[1], p[2], n[0], n[1], n[2]);
        spc_conic_problem pb = {spc_v3(0, 0, 0), spc_v3(0, 0, 0), it % 2 ? SPC_CONIC_REFRACT : SPC_CONIC_REFLECT,
                                rnd_in(1.1, 2.5), false};
        /* a known solution on the far side of the flip half the time */
        double us = rnd_in(0.02, 0.9), vs = rnd_in(0.02, 0.95 - us);
        spc_vec3 nn = spc_conic_tri_normal(&t, us, vs);
        if (spc_length(nn) < 0.05)
            continue;
        spc_vec3 nh = spc_normalize(nn), P = spc_conic_tri_point(&t, us, vs), wx, out;
        int tries = 0;
        do {
            wx = rnd_unit();
        } while (++tries < 100 && (fabs(spc_dot(wx, nh)) < 0.1 || !scatter_dir(&pb, wx, nh, &out)));
        if (tries >= 100)
            continue;
        pb.x = spc_madd(P, wx, rnd_in(0.5, 3.0));
        pb.y = spc_madd(P, out, rnd_in(0.5, 3.0));
        ++flips;
        char what[64];
        snprintf(what, sizeof what, "flipping normals (%s, n . ng %+.2f)", pb.event ? "refract" : "reflect",
                 spc_dot(nh, ng));
        if (!check_case(&t, &pb, us, vs, 1e-6, what, &flip_inner))
            ++flip_fails;
    }
    printf("    %d triangles with flipping normals: %d dense-search solutions inside, %d failures\n", flips, flip_inner,
           flip_fails);
    CHECK(flips >= 300 && flip_fails == 0);
    CHECK(fails == 0);
}

/* ================= culling ================= */

/* Each culling test alone never culls a ball that holds a solution: random problems with a known
 * solution P (normal n), balls holding P (often on their boundary) with cones holding n (often on
 * their boundary), from tiny to larger than the scene, reflection (two- and one-sided) and
 * refraction (eta above and below 1). And each test does cull: random balls and cones without a
 * known solution are culled by each test alone some of the time. */
TEST(culling_never_prunes_a_solution)
{
    const char *name[3] = {"sides", "cones", "spindle"};
    long wrong[3] = {0, 0, 0}, culls[3] = {0, 0, 0}, balls = 0, tries = 0;
    for (int it = 0; it < 60000; ++it) {
        spc_conic_problem pb;
        pb.event = it % 3 ? SPC_CONIC_REFRACT : SPC_CONIC_REFLECT;
        pb.eta = it % 6 == 5 ? rnd_in(0.4, 0.9) : rnd_in(1.05, 2.5);
        pb.front_only = pb.event == SPC_CONIC_REFLECT && it % 2;
        spc_vec3 P = rnd_vec(-1, 1), n = rnd_unit(), wx = rnd_unit(), out;
        if (fabs(spc_dot(wx, n)) < 1e-3)
            continue;
        if (pb.front_only && spc_dot(wx, n) < 0.0)
            wx = spc_neg(wx);
        if (!scatter_dir(&pb, wx, n, &out))
            continue;
        double L = rnd_in(0.2, 3.0);
        pb.x = spc_madd(P, wx, L);
        pb.y = spc_madd(P, out, L * rnd_in(0.2, 3.0));
        /* the ball: P inside, on the boundary half the time */
        double r = L * pow(10.0, rnd_in(-4, 0.5));
        spc_vec3 c = spc_madd(P, rnd_unit(), r * (rnd() < 0.5 ? 1.0 - 1e-9 : rnd()));
        /* the cone: n inside, on the boundary half the time */
        double angle = rnd() < 0.3 ? pow(10.0, rnd_in(-4, -1)) : rnd_in(0.0, 0.98 * SPC_PI);
        spc_vec3 perp = spc_normalize(spc_cross(n, rnd_unit()));
        double a = angle * (rnd() < 0.5 ? 1.0 - 1e-9 : rnd());
        spc_vec3 axis = spc_add(spc_scale(n, cos(a)), spc_scale(perp, sin(a)));
        unsigned m = spc_conic_cull_tests(&pb, c, r, axis, angle);
        ++balls;
        for (int k = 0; k < 3; ++k)
            if (m & (1u << k)) {
                if (wrong[k]++ < 5)
                    printf("    %s culled a ball holding a solution (%s, eta %.3f, r %.3g, cone %.3g)\n", name[k],
                           pb.event ? "refract" : "reflect", pb.eta, r, angle);
            }
        /* effectiveness: the same problem, a ball and a cone anywhere */
        spc_vec3 c2 = rnd_vec(-3, 3);
        double r2 = L * pow(10.0, rnd_in(-3, -0.5)), angle2 = rnd_in(0.0, 1.0);
        unsigned m2 = spc_conic_cull_tests(&pb, c2, r2, rnd_unit(), angle2);
        ++tries;
        for (int k = 0; k < 3; ++k)
            culls[k] += (m2 >> k) & 1u;
    }
    printf("    %ld balls holding a solution: culled by sides %ld, cones %ld, spindle %ld; %ld random balls: culled "
           "by sides %ld, cones %ld, spindle %ld\n",
           balls, wrong[0], wrong[1], wrong[2], tries, culls[0], culls[1], culls[2]);
    for (int k = 0; k < 3; ++k) {
        CHECK_MSG(wrong[k] == 0, "%s culled %ld balls holding a solution", name[k], wrong[k]);
        CHECK_MSG(culls[k] > tries / 100, "%s culled only %ld of %ld random balls", name[k], culls[k], tries);
    }
}

/* ================= meshes: the hierarchy, the cache ================= */

/* The displacement of the blob and its gradient (in 3D, at the unit direction d). */
static double blob_g(spc_vec3 d, spc_vec3 *grad)
{
    double a = sin(3.0 * d.x + 0.5), b = sin(2.0 * d.y + 1.0), c = cos(4.0 * d.z);
    *grad = spc_v3(3.0 * cos(3.0 * d.x + 0.5) * b, 2.0 * a * cos(2.0 * d.y + 1.0), -2.0 * sin(4.0 * d.z));
    return a * b + 0.5 * c;
}

/* A closed blob ("bunny-like"): a cube sphere of 12 n^2 triangles displaced radially,
 * r(d) = R (1 + amp g(d)), with its exact (analytic) vertex normals. Seam vertices are computed
 * from the same cube points, so the surface is watertight and its normals continuous. */
static spc_mesh blob_mesh(int n, spc_vec3 center, double R, double amp)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = 6 * (size_t)(n + 1) * (n + 1);
    m.ntris = 12 * (size_t)n * n;
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.n = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    size_t v = 0, t = 0;
    for (int face = 0; face < 6; ++face) {
        int ax = face / 2, sg = face % 2 ? -1 : 1;
        size_t base = v;
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i) {
                double a = -1.0 + 2.0 * i / n, b = -1.0 + 2.0 * j / n, c[3];
                c[ax] = sg;
                c[(ax + 1) % 3] = sg > 0 ? a : b;
                c[(ax + 2) % 3] = sg > 0 ? b : a;
                spc_vec3 d = spc_normalize(spc_v3(c[0], c[1], c[2])), grad;
                double g = blob_g(d, &grad), r = R * (1.0 + amp * g);
                spc_vec3 gt = spc_sub(grad, spc_scale(d, spc_dot(grad, d)));
                spc_vec3 nn = spc_normalize(spc_sub(d, spc_scale(gt, R * amp / r)));
                spc_vec3 p = spc_madd(center, d, r);
                m.p[3 * v] = (float)p.x, m.p[3 * v + 1] = (float)p.y, m.p[3 * v + 2] = (float)p.z;
                m.n[3 * v] = (float)nn.x, m.n[3 * v + 1] = (float)nn.y, m.n[3 * v + 2] = (float)nn.z;
                ++v;
            }
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                uint32_t q00 = (uint32_t)(base + j * (n + 1) + i), q10 = q00 + 1, q01 = q00 + (uint32_t)(n + 1),
                         q11 = q01 + 1;
                uint32_t tri[6] = {q00, q10, q11, q00, q11, q01};
                memcpy(m.idx + 3 * t, tri, sizeof tri);
                t += 2;
            }
    }
    return m;
}

/* The water surface: an n x n grid over [-s, s]^2 at height z0 with waves, analytic normals. */
static double water_h(double x, double y, double *hx, double *hy)
{
    const double A = 0.04;
    double a = sin(5.0 * x + 0.3) * cos(4.0 * y), b = sin(3.0 * (x + y) + 1.0);
    *hx = A * (5.0 * cos(5.0 * x + 0.3) * cos(4.0 * y) + 0.5 * 3.0 * cos(3.0 * (x + y) + 1.0));
    *hy = A * (-4.0 * sin(5.0 * x + 0.3) * sin(4.0 * y) + 0.5 * 3.0 * cos(3.0 * (x + y) + 1.0));
    return A * (a + 0.5 * b);
}

static spc_mesh water_mesh(int n, double s, double z0)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = (size_t)(n + 1) * (n + 1);
    m.ntris = 2 * (size_t)n * n;
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.n = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    size_t v = 0, t = 0;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            double x = -s + 2.0 * s * i / n, y = -s + 2.0 * s * j / n, hx, hy;
            double z = z0 + water_h(x, y, &hx, &hy);
            spc_vec3 nn = spc_normalize(spc_v3(-hx, -hy, 1.0));
            m.p[3 * v] = (float)x, m.p[3 * v + 1] = (float)y, m.p[3 * v + 2] = (float)z;
            m.n[3 * v] = (float)nn.x, m.n[3 * v + 1] = (float)nn.y, m.n[3 * v + 2] = (float)nn.z;
            ++v;
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            uint32_t q00 = (uint32_t)(j * (n + 1) + i), q10 = q00 + 1, q01 = q00 + (uint32_t)(n + 1), q11 = q01 + 1;
            uint32_t tri[6] = {q00, q10, q11, q00, q11, q01};
            memcpy(m.idx + 3 * t, tri, sizeof tri);
            t += 2;
        }
    return m;
}

static spc_shape *add_mesh(spc_scene *sc, spc_mesh m, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_mesh(s, &m, NULL, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

/* A query with a known solution on the mesh: x random, y along the scattered ray through a
 * random point of a random triangle (and, half the time, x and y anywhere instead). */
static void mesh_query(const spc_conic_mesh *cm, spc_vec3 lo, spc_vec3 hi, int event, spc_conic_problem *pb)
{
    pb->event = event;
    pb->eta = rnd_in(1.1, 2.5);
    pb->front_only = event == SPC_CONIC_REFLECT && rnd() < 0.5;
    spc_vec3 ext = spc_sub(hi, lo);
    double size = spc_length(ext);
    if (rnd() < 0.3) {
        pb->x = spc_add(lo, spc_mul(ext, rnd_vec(-0.5, 1.5)));
        pb->y = spc_add(lo, spc_mul(ext, rnd_vec(-0.5, 1.5)));
        return;
    }
    int prim = (int)(rnd() * spc_conic_mesh_ntris(cm));
    spc_conic_tri t = spc_conic_mesh_triangle(cm, prim);
    double a = rnd(), b = rnd();
    if (a + b > 1) {
        a = 1 - a;
        b = 1 - b;
    }
    spc_vec3 P = spc_conic_tri_point(&t, a, b), nh = spc_normalize(spc_conic_tri_normal(&t, a, b));
    for (;;) {
        spc_vec3 wx = rnd_unit();
        if (fabs(spc_dot(wx, nh)) < 0.1)
            continue;
        pb->x = spc_madd(P, wx, size * rnd_in(0.2, 1.0));
        spc_vec3 d = spc_neg(wx), out;
        if (event == SPC_CONIC_REFLECT) {
            out = spc_sub(d, spc_scale(nh, 2 * spc_dot(d, nh)));
        } else {
            double c = -spc_dot(d, nh), r = c > 0 ? 1 / pb->eta : pb->eta;
            spc_vec3 mm = c > 0 ? nh : spc_neg(nh);
            c = fabs(c);
            double k = 1 - r * r * (1 - c * c);
            if (!(k > 0))
                continue;
            out = spc_add(spc_scale(d, r), spc_scale(mm, r * c - sqrt(k)));
        }
        pb->y = spc_madd(P, out, size * rnd_in(0.2, 1.0));
        return;
    }
}

TEST(hierarchy_matches_triangle_loop)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *shapes[3];
    shapes[0] = add_mesh(sc, blob_mesh(14, spc_v3(0, 0, 0), 1.0, 0.15), NULL);   /* 2352 triangles */
    shapes[1] = add_mesh(sc, water_mesh(34, 1.0, 0.0), NULL);                    /* 2312 triangles */
    shapes[2] = add_mesh(sc, blob_mesh(6, spc_v3(0, 0, 0), 1.0, 0.6), NULL);     /* strongly curved */
    long total = 0, same = 0, nodes = 0, tris_h = 0, tris_b = 0, queries = 0;
    for (int k = 0; k < 3; ++k) {
        spc_shape *s = shapes[k];
        CHECK(spc_shape_prepare(s) == SPC_OK);
        spc_conic_mesh *cm = spc_conic_mesh_build(s);
        CHECK(cm != NULL);
        if (!cm)
            continue;
        for (int it = 0; it < 150; ++it) {
            spc_conic_problem pb;
            mesh_query(cm, s->bbox_min, s->bbox_max, it % 2 ? SPC_CONIC_REFRACT : SPC_CONIC_REFLECT, &pb);
            spc_conic_solution a[64], b[64];
            spc_conic_stats sa, sb;
            memset(&sa, 0, sizeof sa);
            memset(&sb, 0, sizeof sb);
            int na = spc_conic_mesh_solve(cm, &pb, a, 64, false, &sa);
            int nb = spc_conic_mesh_solve(cm, &pb, b, 64, true, &sb);
            ++queries;
            nodes += sa.nodes;
            tris_h += sa.triangles;
            tris_b += sb.triangles;
            total += nb;
            CHECK_MSG(na == nb, "mesh %d query %d: hierarchy %d solutions, loop %d", k, it, na, nb);
            for (int i = 0; i < nb; ++i) {
                bool found = false;
                for (int j = 0; j < na; ++j)
                    found = found || spc_distance(a[j].p, b[i].p) <= 1e-9 * (1 + spc_length(b[i].p));
                same += found;
                CHECK(found);
                /* and every solution satisfies the law on its triangle */
                spc_conic_tri t = spc_conic_mesh_triangle(cm, b[i].prim);
                CHECK(spc_conic_law_residual(&t, &pb, b[i].u, b[i].v) <= 1e-9);
            }
        }
        spc_conic_mesh_destroy(cm);
    }
    printf("    %ld queries on 3 meshes: %ld solutions, %ld found by both; triangles solved %.1f (hierarchy, %.1f nodes "
           "visited) vs %.1f (loop) per query\n",
           queries, total, same, (double)tris_h / queries, (double)nodes / queries, (double)tris_b / queries);
    CHECK(total > queries / 2);
    CHECK(tris_h * 10 < tris_b);
    /* the lazy cache: built once, the same pointer after, freed with the scene */
    const spc_conic_mesh *c1 = spc_conic_mesh_get(shapes[0]), *c2 = spc_conic_mesh_get(shapes[0]);
    CHECK(c1 != NULL && c1 == c2 && shapes[0]->solver_cache == (void *)c1);
    spc_scene_destroy(sc);
}

/* ================= the distance correction factor ================= */

static spc_shape *add_rect(spc_scene *sc, spc_vec3 scale, spc_vec3 pos, const spc_bsdf *b)
{
    spc_mat4 S = spc_mat4_scale(scale), T = spc_mat4_translate(pos), M = spc_mat4_mul(&T, &S);
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_rectangle(s, &M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

static bool finalize(spc_scene *sc)
{
    spc_error err;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        return false;
    }
    return true;
}

/* Chains from spc_conic_solve_all toward light points: the distance correction factor D by ray
 * differentials (report sec. 7, appendix C) gives |cos theta_y| / D, which must equal the
 * chain's generalized geometry term (derivatives of the traced chain, chain.c). */
static void dcf_against_chains(spc_scene *sc, int mesh_shape, const spc_shape *floor_shape, int *compared,
                               double *worst)
{
    const spc_shape *ms = sc->shapes[mesh_shape];
    const spc_conic_mesh *cm = spc_conic_mesh_get(ms);
    int event;
    double eta = 0.0;
    spc_chain_shape_is_caster(ms, true, &event);
    spc_bsdf_is_specular_interface(ms->bsdf, &eta);
    for (int it = 0; it < 300; ++it) {
        /* x on the floor (hit from below), y on a plane of light points above */
        spc_ray r;
        r.o = spc_v3(rnd_in(-0.8, 0.8), rnd_in(-0.8, 0.8), floor_shape->bbox_min.z - 1.0);
        r.d = spc_v3(0, 0, 1);
        r.tmin = 0;
        r.tmax = INFINITY;
        spc_hit x;
        if (!spc_scene_intersect(sc, &r, &x) || x.shape != floor_shape)
            continue;
        /* a free point just above the floor: the chain then starts exactly at x (a surface point's
         * ray offset moves the start by ~1e-6, and the chain with it) */
        x.p.z += 1e-5;
        x.err = 0.0;
        spc_snee_query q;
        memset(&q, 0, sizeof q);
        q.scene = sc;
        q.x = &x;
        q.wo = spc_v3(0, 0, 1);
        q.y = spc_v3(rnd_in(-1.5, 1.5), rnd_in(-1.5, 1.5), 2.5);
        q.ny = spc_normalize(spc_v3(rnd_in(-0.3, 0.3), rnd_in(-0.3, 0.3), -1.0));
        q.max_chain = 1;
        q.any_surface = true;
        spc_chain ch[16];
        int it2 = 0;
        int nc = spc_conic_solve_all(&q, ch, 16, &it2);
        spc_conic_problem pb = {x.p, q.y, event == SPC_CHAIN_REFRACT ? SPC_CONIC_REFRACT : SPC_CONIC_REFLECT, eta, false};
        spc_conic_solution sol[64];
        int ns = spc_conic_mesh_solve(cm, &pb, sol, 64, false, NULL);
        for (int i = 0; i < nc; ++i) {
            double G = spc_chain_geometry(&ch[i], q.y, q.ny);
            for (int j = 0; j < ns; ++j) {
                if (spc_distance(sol[j].p, ch[i].v[0].h.p) > 1e-6)
                    continue;
                spc_conic_tri t = spc_conic_mesh_triangle(cm, sol[j].prim);
                double D = spc_conic_dcf(&t, &pb, &sol[j]);
                double Gd = spc_absdot(ch[i].v[0].d, q.ny) / D;
                if (!(G > 0) || !(D > 0))
                    continue;
                double rel = fabs(Gd - G) / G;
                *worst = fmax(*worst, rel);
                ++*compared;

                break;
            }
        }
    }
}

TEST(dcf_against_generalized_geometry_term)
{
    int compared = 0;
    double worst = 0.0;
    /* a water surface (refraction from the floor below it) */
    {
        spc_scene *sc = spc_scene_create();
        spc_shape *fl = add_rect(sc, spc_v3(1.2, 1.2, 1), spc_v3(0, 0, -0.6), tu_diffuse(sc, 0.5));
        add_mesh(sc, water_mesh(24, 1.0, 0.0), tu_glass(sc, 1.33));
        CHECK(finalize(sc));
        dcf_against_chains(sc, 1, fl, &compared, &worst);
        spc_scene_destroy(sc);
    }
    int after_water = compared;
    /* a mirror blob over the floor (reflection) */
    {
        spc_scene *sc = spc_scene_create();
        spc_shape *fl = add_rect(sc, spc_v3(1.2, 1.2, 1), spc_v3(0, 0, -0.6), tu_diffuse(sc, 0.5));
        add_mesh(sc, blob_mesh(10, spc_v3(0, 0, 0.5), 0.5, 0.15), tu_mirror(sc));
        CHECK(finalize(sc));
        dcf_against_chains(sc, 1, fl, &compared, &worst);
        spc_scene_destroy(sc);
    }
    printf("    %d refracted and %d reflected chains: largest relative difference %.2g\n", after_water,
           compared - after_water, worst);
    CHECK(after_water > 20 && compared - after_water > 20);
    CHECK(worst < 1e-7);

    /* a flat interface with a constant normal: the closed form, V (= x) in the medium of index eta:
     * D = (dV + eta dL) (dV cos_L / cos_V + eta dL cos_V / cos_L). The report prints the second
     * term with cos_L / cos_V (a typo: the sagittal and tangential spreads are checked here). */
    double worst_flat = 0.0, paper_off = 0.0;
    for (int it = 0; it < 200; ++it) {
        spc_vec3 p0 = spc_v3(-10, -10, 0), p1 = spc_v3(30, -10, 0), p2 = spc_v3(-10, 30, 0), nz = spc_v3(0, 0, 1);
        spc_conic_tri t = spc_conic_tri_make(p0, p1, p2, nz, nz, nz);
        double eta = rnd_in(1.1, 2.5);
        spc_conic_problem pb = {spc_v3(rnd_in(-1, 1), rnd_in(-1, 1), -rnd_in(0.2, 2)),
                                spc_v3(rnd_in(-1, 1), rnd_in(-1, 1), rnd_in(0.2, 2)), SPC_CONIC_REFRACT, eta, false};
        spc_conic_solution sol[4];
        int ns = spc_conic_solve_triangle(&t, &pb, sol, 4, NULL);
        CHECK(ns == 1);
        if (ns != 1)
            continue;
        double D = spc_conic_dcf(&t, &pb, &sol[0]);
        spc_vec3 P = sol[0].p;
        double dV = spc_distance(P, pb.x), dL = spc_distance(P, pb.y);
        double cV = fabs(pb.x.z - P.z) / dV, cL = fabs(pb.y.z - P.z) / dL;
        double closed = (dV + eta * dL) * (dV * cL / cV + eta * dL * cV / cL);
        double printed = (dV + eta * dL) * (cL / cV * dV + eta * cL / cV * dL);
        worst_flat = fmax(worst_flat, fabs(D - closed) / closed);
        paper_off = fmax(paper_off, fabs(printed - closed) / closed);
    }
    printf("    flat interface: ray differentials vs closed form %.2g; the report's printed form is off by up to %.2g\n",
           worst_flat, paper_off);
    CHECK(worst_flat < 1e-9);
    CHECK(paper_off > 1e-2);
}

/* ================= the Specular Polynomials fixture ================= */

/* Fan et al. 2024, "Specular Polynomials" (SIGGRAPH), public code, test case "T #1" (single
 * refraction, eta = 1.5041833): the triangle x1 = p10 + p11 u + p12 v with normal
 * n = n10 + n11 u + n12 v (p11, p12 edge vectors, n11, n12 normal differences), endpoints
 * pD = (0, -2.6, -1.1) and pL = (1, 2.5, 2), and the answer u = 0.301126, alpha = 0.310013,
 * v = 1 - alpha - u = 0.388861 (the data are given to 6 digits).
 * What holds there: coplanarity (to 4e-6) and eta sin(theta_D) = sin(theta_L); polishing the
 * unsquared vector law eta wD + wL || n^ from it converges to (0.300399, 0.389131), 7e-4 away (the
 * interpolated normal nearly cancels there, |n| = 0.23, so 6-digit data move the root that much).
 * Admissibility: at that root both endpoints lie on the SAME side of the shading normal
 * (cos = -0.772 and -0.294) while on opposite sides of the geometric normal, so no refraction
 * about that shading normal connects them (the dielectric BSDF would call this pair a
 * reflection): a root that squaring (and the unsigned law) admits but physics does not. It is not
 * total internal reflection: with eta on D's side, eta sin(theta_D) = 0.96 < 1 (checked below), so
 * the only obstacle is sidedness. The conic solver must not return it. */
TEST(specular_polynomials_fixture)
{
    spc_conic_tri t;
    t.p0 = spc_v3(-0.933849, 0.091093, -1.07752);
    t.e1 = spc_v3(-0.025211, -0.021542, 0.0107059);
    t.e2 = spc_v3(-0.023945, -0.022294, 0.011972);
    t.n0 = spc_v3(-0.80496, 0.081929, 0.587645);
    t.dn1 = spc_v3(-0.048272, 0.020128, -1.09909);
    t.dn2 = spc_v3(1.71536, 0.1286, -0.943807);
    spc_conic_problem pb = {spc_v3(0, -2.6, -1.1), spc_v3(1, 2.5, 2), SPC_CONIC_REFRACT, 1.5041833, false};
    double u = 0.301126, v = 1.0 - 0.310013 - 0.301126;
    spc_conic q = spc_conic_coplanarity(&t, pb.x, pb.y);
    spc_vec3 P = spc_conic_tri_point(&t, u, v), n = spc_conic_tri_normal(&t, u, v);
    spc_vec3 wD = spc_normalize(spc_sub(pb.x, P)), wL = spc_normalize(spc_sub(pb.y, P)), nh = spc_normalize(n);
    double cop = spc_dot(nh, spc_cross(wD, wL));
    double ratio = spc_length(spc_cross(wD, nh)) / spc_length(spc_cross(wL, nh));
    printf("    fixture: coplanarity %.2g, Q %.2g, sin D / sin L = %.6f (1/eta = %.6f), |n| = %.3f\n", cop,
           spc_conic_eval(&q, u, v), ratio, 1.0 / pb.eta, spc_length(n));
    CHECK(fabs(cop) < 1e-5);
    CHECK(fabs(ratio * pb.eta - 1.0) < 5e-3);
    /* the unsquared law with eta on D's side, polished from the fixture */
    double pu = u, pv = v;
    bool conv = bf_newton(&t, &pb, pb.eta, 1.0, &pu, &pv);
    P = spc_conic_tri_point(&t, pu, pv);
    nh = spc_normalize(spc_conic_tri_normal(&t, pu, pv));
    wD = spc_normalize(spc_sub(pb.x, P));
    wL = spc_normalize(spc_sub(pb.y, P));
    spc_vec3 ng = spc_normalize(spc_cross(t.e1, t.e2));
    printf("    exact root of the data at (%.6f, %.6f) (alpha %.6f), %.1e from the fixture; cos to the shading normal "
           "%.3f and %.3f, to the geometric normal %.3f and %.3f\n",
           pu, pv, 1 - pu - pv, hypot(pu - u, pv - v), spc_dot(wD, nh), spc_dot(wL, nh), spc_dot(wD, ng), spc_dot(wL, ng));
    CHECK(conv);
    CHECK(hypot(pu - u, pv - v) < 2e-3);
    CHECK(spc_dot(wD, nh) * spc_dot(wL, nh) > 0.0); /* same side of the shading normal */
    CHECK(spc_dot(wD, ng) * spc_dot(wL, ng) < 0.0); /* opposite sides of the triangle */
    double sinD = spc_length(spc_cross(wD, nh));
    printf("    eta sin(theta_D) = %.3f: no total internal reflection, only the sides forbid it\n", pb.eta * sinD);
    CHECK(pb.eta * sinD < 1.0);
    CHECK(!isfinite(spc_conic_law_residual(&t, &pb, pu, pv))); /* not admissible */
    /* the solver returns nothing there */
    spc_conic_solution sol[16];
    int ns = spc_conic_solve_triangle(&t, &pb, sol, 16, NULL);
    bool near = false;
    for (int i = 0; i < ns; ++i)
        near = near || hypot(sol[i].u - pu, sol[i].v - pv) < 1e-2;
    printf("    the conic solver returns %d admissible refraction(s) on this triangle, none at the fixture\n", ns);
    CHECK(!near);
    for (int i = 0; i < ns; ++i)
        CHECK(spc_conic_law_residual(&t, &pb, sol[i].u, sol[i].v) <= 1e-9);
}

/* ================= images: path + conic against ipt ================= */

static spc_film *render_with(const spc_scene *sc, const char *integrator, const char *snee, int spp, uint64_t seed,
                             double *seconds)
{
    return tu_render_nee(sc, integrator, snee, spp, 2, seed, seconds);
}

/* path with specular NEE by the conic solver against ipt: per-pixel z-test (Sidak, alpha 0.01)
 * on at least 99% of the pixels, and the mean of every channel within 3 standard errors. */
static void image_test(spc_scene *sc, const char *name, int ipt_spp, int path_spp)
{
    double t_ref, t_img;
    spc_film *ref = render_with(sc, "ipt", "none", ipt_spp, 21, &t_ref);
    spc_film *img = render_with(sc, "path", "conic", path_spp, 22, &t_img);
    CHECK(ref && img);
    if (ref && img) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(img, ref, 0.99, name, &d));
        double ma, sa, mb, sb;
        tu_image_mean(img, 0, &ma, &sa);
        tu_image_mean(ref, 0, &mb, &sb);
        printf("    %s: ipt %d spp %.1f s, path + conic %d spp %.1f s; z-test pass %.4f of %d pixels; image means "
               "%.5f +- %.5f (path + conic) and %.5f +- %.5f (ipt)\n",
               name, ipt_spp, t_ref, path_spp, t_img, d.ztest_pass_fraction, d.ztest_pixels, ma, sa, mb, sb);
    }
    spc_film_destroy(ref);
    spc_film_destroy(img);
}

TEST(image_water_surface)
{
    /* a wavy water surface over a floor, lit from above: every caustic path on the floor is one
     * refraction through the mesh, which the conic solver enumerates exactly (max chain 1) */
    spc_scene *sc = spc_scene_create();
    add_rect(sc, spc_v3(1.5, 1.5, 1), spc_v3(0, 0, 0), tu_diffuse(sc, 0.7));
    add_mesh(sc, water_mesh(40, 1.5, 0.5), tu_glass(sc, 1.33));
    spc_shape *light = tu_sphere(sc, spc_v3(0.3, 0.2, 2.2), 0.3, tu_diffuse(sc, 0.0));
    tu_area(sc, light, 2, 6.0);
    tu_camera(sc, spc_v3(0.0, -2.6, 2.4), spc_v3(0, 0, 0.2), spc_v3(0, 0, 1), 45, 24, 24);
    sc->integrator.specular_max_chain = 1;
    CHECK(finalize(sc));
    image_test(sc, "water surface", 8192, 128);
    spc_scene_destroy(sc);
}

TEST(image_glass_blob)
{
    /* a closed glass "bunny" on a floor (scenes/meshes/conic_bunny.obj: irregular, non-convex, 5120
     * triangles; turned z-up): its caustic needs two refractions (in and out), which the conic
     * mode leaves to the angular estimate, while the one-vertex chains (reflections off its
     * surface, several where it is concave) are enumerated; a mirror blob beside it casts
     * one-reflection caustics the conic solver enumerates exactly */
    spc_scene *sc = spc_scene_create();
    add_rect(sc, spc_v3(2, 2, 1), spc_v3(0, 0, 0), tu_diffuse(sc, 0.7));
    char path[1024];
    snprintf(path, sizeof path, "%s/scenes/meshes/conic_bunny.obj", spc_test_source_dir());
    spc_mesh bunny;
    memset(&bunny, 0, sizeof bunny);
    spc_error err;
    CHECK(spc_obj_load(path, &bunny, &err) == SPC_OK);
    if (!bunny.p || !bunny.n) {
        printf("  %s: %s\n", path, err.msg);
        spc_scene_destroy(sc);
        return;
    }
    for (size_t i = 0; i < bunny.nverts; ++i) {
        /* (x, y, z) y-up -> (x - 0.45, -z, y) z-up, scaled by 0.8: a rotation, normals alike */
        float *p = bunny.p + 3 * i, *n = bunny.n + 3 * i;
        float px = p[0], py = p[1], pz = p[2], nx = n[0], ny = n[1], nz = n[2];
        p[0] = 0.8f * px - 0.45f, p[1] = -0.8f * pz, p[2] = 0.8f * py;
        n[0] = nx, n[1] = -nz, n[2] = ny;
    }
    add_mesh(sc, bunny, tu_glass(sc, 1.5));
    add_mesh(sc, blob_mesh(8, spc_v3(0.55, 0.1, 0.4), 0.3, 0.2), tu_mirror(sc));
    spc_shape *light = tu_sphere(sc, spc_v3(0.1, 0.3, 2.2), 0.3, tu_diffuse(sc, 0.0));
    tu_area(sc, light, 3, 6.0);
    tu_camera(sc, spc_v3(0.2, -2.8, 2.2), spc_v3(0, 0, 0.3), spc_v3(0, 0, 1), 50, 24, 24);
    sc->integrator.specular_max_chain = 2;
    CHECK(finalize(sc));
    image_test(sc, "glass and mirror blobs", 8192, 128);
    spc_scene_destroy(sc);
}

int main(void)
{
    spc_warn_set_quiet(1);
    spc_rng_seed(&rng, 777, 3);
    RUN(taylor_shift_matches_binomial);
    RUN(vca_against_sturm_and_known_roots);
    RUN(conic_coefficients_and_chord_polynomial);
    RUN(conic_classification);
    RUN(conic_arcs_and_chords);
    RUN(solver_against_dense_search);
    RUN(constructed_degenerate_conics_and_tangency);
    RUN(constructed_double_roots_and_flipping_normals);
    RUN(culling_never_prunes_a_solution);
    RUN(specular_polynomials_fixture);
    RUN(hierarchy_matches_triangle_loop);
    RUN(dcf_against_generalized_geometry_term);
    RUN(image_water_surface);
    RUN(image_glass_blob);
    return spc_test_finish();
}
