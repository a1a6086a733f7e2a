/*
 * tests/test_conic.c: the conic solver (src/manifold/conic*.c, polyroots.c; issue 7).
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
 * - The Specular Polynomials refraction fixture (Fan et al. 2024, test "T #1").
 * - The hierarchy returns the same solutions as the loop over every triangle.
 * - The distance correction factor (ray differentials) against the chain's generalized geometry
 *   term, and the closed form for a flat interface.
 * - Images: path with --specular-nee conic against ipt (per-pixel z-test) on a glass blob and a
 *   water surface.
 */
/* ctest-labels: unit stat */
/* ctest-timeout: 600 */
#include <string.h>

#include "core/rng.h"
#include "harness.h"
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
        if (!(cx * cy > 0.0))
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
    const int configs = getenv("CONIC_CONFIGS") ? atoi(getenv("CONIC_CONFIGS")) : 10000;
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

int main(void)
{
    spc_warn_set_quiet(1);
    spc_rng_seed(&rng, 777, 3);
    RUN(taylor_shift_matches_binomial);
    RUN(vca_against_sturm_and_known_roots);
    RUN(solver_against_dense_search);
    return spc_test_finish();
}
