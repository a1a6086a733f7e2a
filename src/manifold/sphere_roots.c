/*
 * manifold/sphere_roots.c: the planar problem of a chain through one sphere (sphere_roots.h).
 *
 * On the unit circle centred at the origin: x = (d, 0), d > 1, sees the arc of entry points
 * P(theta) = (cos theta, sin theta), |theta| < acos(1/d). The ray x -> P either reflects there
 * (m = -1) or refracts in (ratio 1/eta), crosses chords of length -2 t.Q (the internal angle is the
 * same at every internal vertex of a sphere), reflects at m of their ends and refracts out (ratio
 * eta). With Q the last vertex and v the final direction, the chain reaches y where
 * f(theta) = v x (y - Q) vanishes and (y - Q).v > 0. f is smooth in theta wherever the refractions
 * exist (the angle of the entry point, unlike the impact parameter, keeps the derivative finite at
 * the grazing rim).
 *
 * Root isolation (roots1d.h): f on SPC_SPHERE_GRID + 1 samples over the arc (SPC_SPHERE_GRID_NEAR
 * + 1 where x is near the sphere; ends pulled in by a relative 1e-9), sign changes, and pairs of
 * roots between samples at local extrema of the samples. With f's few features (one extremum per
 * rainbow order at most: the deviation of a ray through a sphere has one stationary point per
 * internal reflection count) the grid resolves them all but pairs of roots within one sample
 * spacing of the arc's grazing end, and, from x near the sphere, pairs closer than the coarse
 * grid's spacing anywhere on the arc (hence the finer grid there). Roots are refined to 1e-12 in
 * theta; the polish in 3D (sphere_chains.c) takes it from there.
 *
 * The outside reflection (m = -1) is Alhazen's problem and needs no grid: a quartic in
 * tan(theta / 2) with one root at most on the arc both points see (reflection_roots below); 7.5x
 * less CPU per query than the grid's search for it (bench: 116 against 870 ns), the same roots.
 *
 * From inside (spc_sphere_inside_roots: x a medium point in a glass ball, d < 1) the chain is a
 * function of its first direction from x, which sees the whole circle: f on a coarse grid of
 * directions, brackets at sign changes and at the edges where the way out turns grazing (total
 * internal reflection beyond), and the pairs of roots at the refraction's fold found where |f| falls
 * toward a sample or an edge (an extremum between them, by golden section), refined by bisection.
 * Its roots only seed randomized attempts (fit_seeds.h), so they are kept to a fraction of a degree.
 */
#include "manifold/sphere_roots.h"

#include <math.h>
#include <string.h>

#include "manifold/roots1d.h"

/* Samples of f over the arc x sees, shared by every signature (one pass computes the way in, the
 * chords, and each signature's way out). roots1d halves the cells where the chain's angles turn
 * fast, so the grid only has to see f's broad shape: 32 samples found the same roots in the tests
 * and in 40000 calls of bench_snee on the glass ball, at 1.5x the cost per call; 4 miss some; 8 and
 * 12 miss pairs of roots at the refraction's folds (test_exact_chains, 3000 configurations of one
 * or two vertices behind the sphere: 2 and 4 of 1584 roots). */
#define SPC_SPHERE_GRID 16
/* Samples where x lies within SPC_SPHERE_NEAR_D radii of the centre (a floor point beside the
 * contact of a ball resting on it): from there two roots of the refraction through (m = 0) near its
 * fold lie closer than 16 samples resolve, away from the arc's ends. In test_exact_chains
 * (planar_roots_near_the_sphere) 16 samples missed 8 of 903 roots, at d 1.04 to 1.07, and 32 missed
 * some; 64 find them all. The misses cost the default 23% of the pixel of
 * bench/check/ball_small_light.xml where that caustic's fold meets the contact. Points that near a
 * sphere are few, so the cost stays local; 1.25 leaves a margin over the misses' d. */
#define SPC_SPHERE_GRID_NEAR 64
#define SPC_SPHERE_NEAR_D 1.25

/* The plane through the centre c spanned by the unit axis e1 and y's direction w = y - c (e2: w's
 * part across e1), in units of the radius R, with x at distance d from c along e1. */
static void plane_fill(spc_vec3 e1, spc_vec3 w, spc_vec3 c, double R, double d, spc_sphere_plane *pl)
{
    spc_vec3 wp = spc_sub(w, spc_scale(e1, spc_dot(w, e1)));
    double wpl = spc_length(wp);
    /* y on the axis through x and the centre: a ring of solutions (measure zero); any plane */
    pl->e1 = e1;
    pl->e2 = wpl > 1e-12 * spc_length(w) ? spc_scale(wp, 1.0 / wpl) : spc_frame_from_n(e1).s;
    pl->c = c;
    pl->R = R;
    pl->d = d / R;
    pl->y1 = spc_dot(w, e1) / R;
    pl->y2 = spc_dot(w, pl->e2) / R;
}

bool spc_sphere_plane_of(spc_vec3 x, spc_vec3 c, double R, spc_vec3 y, spc_sphere_plane *pl)
{
    spc_vec3 e1 = spc_sub(x, c), w = spc_sub(y, c);
    double d = spc_length(e1);
    if (!(d > R) || !(spc_length(w) > R))
        return false;
    plane_fill(spc_scale(e1, 1.0 / d), w, c, R, d, pl);
    return true;
}

spc_vec3 spc_sphere_plane_point(const spc_sphere_plane *pl, double theta)
{
    spc_vec3 u = spc_add(spc_scale(pl->e1, cos(theta)), spc_scale(pl->e2, sin(theta)));
    return spc_add(pl->c, spc_scale(u, pl->R));
}

typedef struct plane_problem {
    double d, y1, y2, eta;
    int m;
} plane_problem;

/* w refracted at a boundary whose unit normal n faces against w (w.n < 0), ratio n1 / n2. */
static inline bool refract2(double wx, double wy, double nx, double ny, double ratio, double *ox, double *oy)
{
    double ci = -(wx * nx + wy * ny);
    double s2 = ratio * ratio * (1.0 - ci * ci);
    if (s2 > 1.0 + 1e-9)
        return false;
    /* up to rounding, grazing: the way out of a sphere mirrors the way in, and at the arc's ends
     * (grazing entry) sin i is within rounding of 1 */
    s2 = s2 < 1.0 ? s2 : 1.0;
    double ct = sqrt(1.0 - s2);
    *ox = ratio * wx + (ratio * ci - ct) * nx;
    *oy = ratio * wy + (ratio * ci - ct) * ny;
    return true;
}

/* The way out of the sphere at q along t (the inward normal -q, ratio eta). Every chord meets the
 * circle at the internal angle of the way in, so the way out's transmitted cosine is the way in's
 * incident cosine cos_in (Snell's law read backwards): the refraction without its square root, and
 * it always exists where the way in does. */
static inline void refract_out(double tx, double ty, double qx, double qy, double eta, double cos_in, double *ox,
                               double *oy)
{
    double k = eta * (tx * qx + ty * qy) - cos_in;
    *ox = eta * tx - k * qx;
    *oy = eta * ty - k * qy;
}

/* The angles roots1d watches (in turns): the way in, the first direction inside (the chords turn
 * with it) and the way out. */
#define SPHERE_ANGLES 3

/* f(theta) and (y - Q).v at the entry point (cos theta, sin theta) = (qx, qy) of a chain through the
 * sphere (m >= 0), and (ang, if not NULL) the angles; false where a refraction does not exist (total
 * internal reflection). */
static bool plane_eval_at(const plane_problem *pb, double qx, double qy, double *f, double *ahead, double *ang)
{
    double ux = qx - pb->d, uy = qy;
    double ul = sqrt(ux * ux + uy * uy);
    ux /= ul;
    uy /= ul;
    double vx, vy, tx, ty, cos_in = -(ux * qx + uy * qy);
    if (ang)
        ang[0] = spc_roots1d_turns(ux, uy);
    if (!refract2(ux, uy, qx, qy, 1.0 / pb->eta, &tx, &ty))
        return false;
    if (ang)
        ang[1] = spc_roots1d_turns(tx, ty);
    for (int j = 0; j <= pb->m; ++j) {
        double len = -2.0 * (tx * qx + ty * qy);
        qx += len * tx;
        qy += len * ty;
        if (j < pb->m) {
            double dn = tx * qx + ty * qy;
            tx -= 2.0 * dn * qx;
            ty -= 2.0 * dn * qy;
        }
    }
    refract_out(tx, ty, qx, qy, pb->eta, cos_in, &vx, &vy);
    if (ang)
        ang[2] = spc_roots1d_turns(vx, vy);
    double rx = pb->y1 - qx, ry = pb->y2 - qy;
    *f = vx * ry - vy * rx;
    *ahead = vx * rx + vy * ry;
    return true;
}

/* The entry point (cos th, sin th), |th| < pi / 2, from the polynomials of th / 2 and the double
 * angle: the refinement's evaluations without libm's sincos (7% of the glass ball's render,
 * callgrind). */
static inline void entry_point(double th, double *qx, double *qy)
{
    double s, c;
    spc_sincos_quarter(0.5 * th, &s, &c);
    *qx = (c - s) * (c + s);
    *qy = 2.0 * s * c;
}

static bool plane_fn(const void *ctx, double th, double *f, double *ahead, double *ang)
{
    double qx, qy;
    entry_point(th, &qx, &qy);
    return plane_eval_at(ctx, qx, qy, f, ahead, ang);
}

/* f of every signature m = mlo..mhi (0 <= mlo; those with want[m + 1] where want is not NULL) at the
 * entry point (qx, qy), sharing the way in and the chords: f[m + 1], ok[m + 1]. */
static void plane_eval_all(const plane_problem *pb, int mlo, int mhi, const bool *want, double qx, double qy,
                           double *f, double *ahead, double (*ang)[SPHERE_ANGLES], bool *ok)
{
    for (int m = mlo; m <= mhi; ++m)
        ok[m + 1] = false;
    double ux = qx - pb->d, uy = qy;
    double ul = sqrt(ux * ux + uy * uy);
    ux /= ul;
    uy /= ul;
    double a_in = spc_roots1d_turns(ux, uy);
    double tx, ty, cos_in = -(ux * qx + uy * qy);
    if (!refract2(ux, uy, qx, qy, 1.0 / pb->eta, &tx, &ty))
        return;
    double a_t = spc_roots1d_turns(tx, ty);
    for (int j = 0; j <= mhi; ++j) {
        double len = -2.0 * (tx * qx + ty * qy);
        qx += len * tx;
        qy += len * ty;
        if (j >= mlo && (!want || want[j + 1])) {
            double vx, vy;
            refract_out(tx, ty, qx, qy, pb->eta, cos_in, &vx, &vy);
            f[j + 1] = vx * (pb->y2 - qy) - vy * (pb->y1 - qx);
            ahead[j + 1] = vx * (pb->y1 - qx) + vy * (pb->y2 - qy);
            ang[j + 1][0] = a_in;
            ang[j + 1][1] = a_t;
            ang[j + 1][2] = spc_roots1d_turns(vx, vy);
            ok[j + 1] = true;
        }
        double dn = tx * qx + ty * qy;
        tx -= 2.0 * dn * qx;
        ty -= 2.0 * dn * qy;
    }
}

/* ---- the outside reflection: Alhazen's problem as a quartic ---- */

/* P(t) = c[0] + c[1] t + ... + c[n] t^n by Horner's rule, and P'(t) in *dp. */
static inline double poly_eval_d(const double *c, int n, double t, double *dp)
{
    double p = c[n], d = 0.0;
    for (int i = n - 1; i >= 0; --i) {
        d = d * t + p;
        p = p * t + c[i];
    }
    *dp = d;
    return p;
}

/* The root of P in (lo, hi), where P(lo) = flo and P(hi) = fhi have opposite signs and P has one
 * simple root: Newton's method from the secant's point, each step kept inside the bracket (a halving
 * where it leaves it; the bracket shrinks by the sign at every step), until a step moves t by less
 * than tol (near the root a step is rounding noise, which tol must stay above: it is relative to the
 * whole interval searched, not to t). */
static double bracketed_root(const double *c, int n, double lo, double flo, double hi, double fhi, double tol)
{
    double t = (lo * fhi - hi * flo) / (fhi - flo);
    if (!(t > lo && t < hi))
        t = 0.5 * (lo + hi);
    for (int it = 0; it < 100; ++it) {
        double dp, p = poly_eval_d(c, n, t, &dp);
        if (p == 0.0)
            return t;
        if ((p > 0.0) == (flo > 0.0))
            lo = t;
        else
            hi = t;
        double tn = t - p / dp;
        if (!(tn > lo && tn < hi))
            tn = 0.5 * (lo + hi);
        if (fabs(tn - t) <= tol || tn == lo || tn == hi)
            return tn;
        t = tn;
    }
    return t;
}

/* The outside reflection's roots (m = -1) on the arc |theta| < tmax x sees. With the circle's points
 * as complex numbers, x = d, y = y1 + i y2 and P = e^(i theta), the law of reflection at P with y
 * ahead says that (x - P) / P and (y - P) / P are mirror images about the real axis up to a positive
 * factor: w = (x - P)(y - P) / P^2 is real and positive (negative: y on the reflected line behind
 * P). Im w = 0 reads
 *     g(theta) = d (y2 cos 2theta - y1 sin 2theta) - y2 cos theta + (d + y1) sin theta = 0,
 * and with t = tan(theta / 2) (cos theta = (1 - t^2) / (1 + t^2), sin theta = 2 t / (1 + t^2)),
 * times (1 + t^2)^2, the quartic (Alhazen's problem)
 *     y2 (d + 1) t^4 + (4 d y1 + 2 (d + y1)) t^3 - 6 d y2 t^2 + (2 (d + y1) - 4 d y1) t + y2 (d - 1).
 * Of its up to four real roots one at most is a chain: a root with y ahead lies on the arc that
 * both x and y see (the reflected ray leaves P outward, so y = P + s v has y.P > 1), and there the
 * path length |x - P| + |y - P| is strictly convex in theta (d^2/dtheta^2 |x - P| =
 * d (d cos theta - 1)(d - cos theta) / |x - P|^3 > 0 where x sees P, the same for y), so it has one
 * stationary point at most, a simple root where g changes sign (g and the length's derivative are
 * sin((a_x + a_y) / 2) times positive factors there, a_x, a_y the angles of x - P and y - P to the
 * normal). So: the quartic on that arc's t-interval (|t| < tan(tmax / 2) <= 1: well conditioned),
 * a root where its ends' signs differ, by bracketed Newton steps, then one Newton step on g in
 * theta (its value and slope from t, no libm but the one atan); kept where y is ahead (the same
 * arc up to rounding). */
static int reflection_roots(double d, double y1, double y2, double tmax, double *theta, int max_roots)
{
    double c[5] = {y2 * (d - 1.0), 2.0 * (d + y1) - 4.0 * d * y1, -6.0 * d * y2, 4.0 * d * y1 + 2.0 * (d + y1),
                   y2 * (d + 1.0)};
    double T = sqrt((d - 1.0) / (d + 1.0)), t[4];
    int nt = 0, n = 0;
    /* y sees the arc between its tangent points P+- = (y +- s (-y2, y1)) / r^2, s = sqrt(r^2 - 1),
     * at the angles phi +- acos(1 / r) about y's; t = P.y / (1 + P.x) */
    double r2 = y1 * y1 + y2 * y2, s = sqrt(r2 - 1.0);
    double pmx = (y1 + s * y2) / r2, pmy = (y2 - s * y1) / r2, ppx = (y1 - s * y2) / r2, ppy = (y2 + s * y1) / r2;
    double tm = 1.0 + pmx > 0.0 ? pmy / (1.0 + pmx) : -INFINITY, tp = 1.0 + ppx > 0.0 ? ppy / (1.0 + ppx) : INFINITY;
    double lo[2], hi[2];
    int npieces = 0;
    if (tm <= tp) {
        lo[npieces] = fmax(tm, -T);
        hi[npieces++] = fmin(tp, T);
    } else {
        /* y's arc holds theta = pi: t from tm up and from tp down */
        lo[npieces] = fmax(tm, -T);
        hi[npieces++] = T;
        lo[npieces] = -T;
        hi[npieces++] = fmin(tp, T);
    }
    for (int k = 0; k < npieces; ++k) {
        if (!(lo[k] < hi[k]))
            continue;
        double dp, flo = poly_eval_d(c, 4, lo[k], &dp), fhi = poly_eval_d(c, 4, hi[k], &dp);
        if (flo != 0.0 && fhi != 0.0 && (flo > 0.0) != (fhi > 0.0))
            t[nt++] = bracketed_root(c, 4, lo[k], flo, hi[k], fhi, 1e-15 * T);
    }
    for (int i = 0; i < nt && n < max_roots; ++i) {
        double t2 = t[i] * t[i], inv = 1.0 / (1.0 + t2);
        double ct = (1.0 - t2) * inv, st = 2.0 * t[i] * inv;
        double c2 = (ct - st) * (ct + st), s2 = 2.0 * st * ct;
        double g = d * (y2 * c2 - y1 * s2) - y2 * ct + (d + y1) * st;
        double dg = -2.0 * d * (y2 * s2 + y1 * c2) + y2 * st + (d + y1) * ct;
        double th = 2.0 * atan(t[i]);
        if (dg != 0.0 && fabs(g / dg) < 1e-6)
            th -= g / dg;
        if (!(fabs(th) < tmax))
            continue;
        /* y ahead of the reflected ray: (y - Q).v > 0, with v = u - 2 (u.Q) Q, u the unit x -> Q */
        double ux = ct - d, uy = st, dn = ux * ct + uy * st;
        double vx = ux - 2.0 * dn * ct, vy = uy - 2.0 * dn * st;
        if (!(vx * (y1 - ct) + vy * (y2 - st) > 0.0))
            continue;
        bool same = false;
        for (int j = 0; j < n; ++j)
            same |= fabs(theta[j] - th) < 1e-10;
        if (!same)
            theta[n++] = th;
    }
    return n;
}

/* The roots of the signatures m = mlo..mhi (0 <= mlo; those with want[m + 1] where want is not NULL)
 * on one arc (|theta| < tmax): theta[m + 1][...], n[m + 1]. */
static void roots_on_arc(double d, double y1, double y2, double eta, int mlo, int mhi, const bool *want,
                         double tmax, double theta[][SPC_SPHERE_MAX_ROOTS], int *n)
{
    enum { G = SPC_SPHERE_GRID_NEAR };
    int g = d < SPC_SPHERE_NEAR_D ? SPC_SPHERE_GRID_NEAR : SPC_SPHERE_GRID;
    double th[G + 1], f[G + 1][SPC_SPHERE_SIGNATURES], ah[G + 1][SPC_SPHERE_SIGNATURES];
    double an[G + 1][SPC_SPHERE_SIGNATURES][SPHERE_ANGLES];
    bool ok[G + 1][SPC_SPHERE_SIGNATURES];
    /* the entry points by rotation from the first (cos and sin once) */
    double step = 2.0 * tmax / g, cs, sn, cx, cy;
    spc_sincos_quarter(step, &sn, &cs); /* step < pi / g <= pi / 4 */
    entry_point(tmax, &cx, &cy);
    cy = -cy;
    plane_problem pb = {d, y1, y2, eta, 0};
    for (int j = 0; j <= g; ++j) {
        th[j] = -tmax + step * j;
        plane_eval_all(&pb, mlo, mhi, want, cx, cy, f[j], ah[j], an[j], ok[j]);
        double nx = cx * cs - cy * sn, ny = cx * sn + cy * cs;
        cx = nx;
        cy = ny;
    }
    for (int m = mlo; m <= mhi; ++m) {
        if (want && !want[m + 1])
            continue;
        double fm[G + 1], am[G + 1], angm[G + 1][SPC_ROOTS1D_MAX_ANGLES];
        bool okm[G + 1];
        for (int j = 0; j <= g; ++j) {
            fm[j] = f[j][m + 1];
            am[j] = ah[j][m + 1];
            okm[j] = ok[j][m + 1];
            for (int i = 0; i < SPHERE_ANGLES; ++i)
                angm[j][i] = an[j][m + 1][i];
        }
        pb.m = m;
        /* to 1e-12: the 3D polish (spc_sphere_chains_all) converges from there in one trace */
        n[m + 1] = spc_roots1d(plane_fn, NULL, &pb, th, fm, am, &angm[0][0], SPHERE_ANGLES, okm, g, NULL, 1e-12 * tmax,
                               theta[m + 1], SPC_SPHERE_MAX_ROOTS);
    }
}

/* spc_sphere_chain_roots_all for m = mlo..mhi, those with want[m + 1] where want is not NULL. */
static void chain_roots(double d, double y1, double y2, double eta, int mlo, int mhi, const bool *want,
                        double theta[][SPC_SPHERE_MAX_ROOTS], int *n)
{
    for (int m = mlo; m <= mhi; ++m)
        n[m + 1] = 0;
    if (!(d > 1.0) || !(y1 * y1 + y2 * y2 > 1.0) || (mhi >= 0 && !(eta > 0.0)))
        return;
    double tmax = acos(1.0 / d) * (1.0 - 1e-9);
    if (mlo < 0) {
        /* the outside reflection in closed form; the grid serves the signatures through the sphere */
        if (!want || want[0])
            n[0] = reflection_roots(d, y1, y2, tmax, theta[0], SPC_SPHERE_MAX_ROOTS);
        mlo = 0;
        if (mhi < 0)
            return;
    }
    if (eta < 1.0) {
        /* a bubble (inside the lower index): the way in exists where sin i = d sin(theta) / |P - x|
         * stays below eta, i.e. cos(theta) above (eta^2 + sqrt((d^2 - eta^2)(1 - eta^2))) / d; the
         * way out then always does (it mirrors the way in). The outside reflection keeps the arc. */
        double c = (eta * eta + sqrt((d * d - eta * eta) * (1.0 - eta * eta))) / d;
        double tin = acos(c < 1.0 ? c : 1.0) * (1.0 - 1e-9);
        roots_on_arc(d, y1, y2, eta, mlo, mhi, want, tin < tmax ? tin : tmax, theta, n);
        return;
    }
    roots_on_arc(d, y1, y2, eta, mlo, mhi, want, tmax, theta, n);
}

void spc_sphere_chain_roots_all(double d, double y1, double y2, double eta, int mlo, int mhi,
                                double theta[][SPC_SPHERE_MAX_ROOTS], int *n)
{
    chain_roots(d, y1, y2, eta, mlo, mhi, NULL, theta, n);
}

void spc_sphere_chain_roots_some(double d, double y1, double y2, double eta, const bool want[SPC_SPHERE_SIGNATURES],
                                 double theta[][SPC_SPHERE_MAX_ROOTS], int *n)
{
    int mlo = SPC_SPHERE_MAX_M + 1, mhi = -2;
    for (int m = -1; m <= SPC_SPHERE_MAX_M; ++m) {
        n[m + 1] = 0;
        if (want[m + 1]) {
            mlo = m < mlo ? m : mlo;
            mhi = m;
        }
    }
    if (mlo <= mhi)
        chain_roots(d, y1, y2, eta, mlo, mhi, want, theta, n);
}

int spc_sphere_chain_roots(double d, double y1, double y2, int m, double eta, double *theta, int max_roots)
{
    if (m < -1 || m > SPC_SPHERE_MAX_M)
        return 0;
    double all[SPC_SPHERE_SIGNATURES][SPC_SPHERE_MAX_ROOTS];
    int n[SPC_SPHERE_SIGNATURES];
    spc_sphere_chain_roots_all(d, y1, y2, eta, m, m, all, n);
    int k = n[m + 1] < max_roots ? n[m + 1] : max_roots;
    memcpy(theta, all[m + 1], (size_t)k * sizeof *theta);
    return k;
}

bool spc_sphere_plane_inside(spc_vec3 x, spc_vec3 c, double R, spc_vec3 y, spc_sphere_plane *pl)
{
    spc_vec3 e1 = spc_sub(x, c), w = spc_sub(y, c);
    double d = spc_length(e1), wl = spc_length(w);
    if (!(d < R) || !(wl > R))
        return false;
    /* x at the centre: the axis at right angles to y's direction, so that y keeps a component on e2 */
    e1 = d > 1e-9 * R ? spc_scale(e1, 1.0 / d) : spc_frame_from_n(spc_scale(w, 1.0 / wl)).s;
    plane_fill(e1, w, c, R, d, pl);
    return true;
}

/* Samples of the inside problem's f over the directions from x, and the bisection steps that refine
 * a root or the edge of the range where the way out exists. The roots seed attempts (fit_seeds.h),
 * which start in a cone of a few degrees around them, so 2 pi / 32 / 2^6 (0.2 degrees) is plenty.
 * By direction rather than by the first vertex's angle: from x near the sphere the directions
 * toward the nearest part of the circle crowd into a few degrees of vertex angle, where a grid of
 * vertex angles missed roots. */
#define SPC_SPHERE_INSIDE_GRID 32
#define SPC_SPHERE_INSIDE_STEPS 6
/* The edge where the way out turns grazing, to 2 pi / 32 / 2^24: a root by the edge lies within
 * 1e-3 radians of it (f falls like the square root of the distance to the edge), and six steps
 * stopped short of it (test_exact_chains, inside_roots_against_dense_scan). */
#define SPC_SPHERE_INSIDE_EDGE_STEPS 24
/* Samples within a cell between total reflection and y behind, where the range between them can be
 * narrower than a cell (a way out after internal reflections, test_exact_chains). */
#define SPC_SPHERE_INSIDE_SUB 8
/* Golden-section steps for the extremum between two cells that may hide a pair of roots (inside_pair):
 * 0.618^12 of two cells, 0.07 degrees, well within the seeds' cone of 5 degrees. */
#define SPC_SPHERE_INSIDE_PAIR_STEPS 12

/* The inside problem along the first direction (ux, uy) from x = (d, 0): f = v x (y - Q) at the last
 * vertex Q with the way out v, *th0 the first vertex's angle (if th0 is not NULL). Returns 0 where f
 * is set, 1 where the way out is totally reflected, 2 where y lies behind the last vertex. */
static int inside_eval(double d, double y1, double y2, int m, double eta, double ux, double uy, double *f,
                       double *th0)
{
    double b = d * ux, disc = b * b - (d * d - 1.0);
    double t = -b + sqrt(disc > 0.0 ? disc : 0.0);
    double qx = d + t * ux, qy = t * uy;
    double ql = sqrt(qx * qx + qy * qy);
    if (!(ql > 0.0))
        return 1;
    qx /= ql;
    qy /= ql;
    if (th0)
        *th0 = atan2(qy, qx);
    double tx = ux, ty = uy;
    /* every chord meets the circle at the same angle: cos i = t.Q at each vertex */
    for (int j = 0; j < m; ++j) {
        double c = tx * qx + ty * qy;
        tx -= 2.0 * c * qx;
        ty -= 2.0 * c * qy;
        qx += 2.0 * c * tx; /* the chord, 2 cos i long, along the reflected direction (t.Q = -c) */
        qy += 2.0 * c * ty;
        double nl = sqrt(qx * qx + qy * qy);
        qx /= nl;
        qy /= nl;
    }
    double ci = tx * qx + ty * qy;
    double s2 = eta * eta * (1.0 - ci * ci);
    if (!(ci > 0.0) || s2 > 1.0)
        return 1;
    double k = sqrt(1.0 - s2) - eta * ci;
    double vx = eta * tx + k * qx, vy = eta * ty + k * qy;
    double ex = y1 - qx, ey = y2 - qy;
    if (!(vx * ex + vy * ey > 0.0))
        return 2;
    *f = vx * ey - vy * ex;
    return 0;
}

static int inside_eval_at(double d, double y1, double y2, int m, double eta, double phi, double *f, double *th0)
{
    return inside_eval(d, y1, y2, m, eta, cos(phi), sin(phi), f, th0);
}

typedef struct inside_problem {
    double d, y1, y2, eta;
    int m;
    double *theta;
    int n, max;
    double edge_p, edge_f; /* the last cell's edge and f there, where f kept one sign up to it (NAN: none) */
} inside_problem;

/* The pair of roots that an extremum of f in (pa, pc) may hide where f has the same sign sgn at
 * both ends (fa, fc): the extremum of sgn f by golden section; where f there has crossed zero, the
 * root on each side of it by bisection (inside_cell). At the refraction's fold the two ways out to y
 * lie a few degrees apart, inside one cell of the grid or between the edge of total reflection and
 * the first sample past it, and f has one sign at the cell's ends: a medium point low in
 * scenes/medium_glass.xml's ball had its pair 8 degrees apart in an 11-degree cell, its mesh chains
 * found by cone seeds alone and counted up to 124 times (bench/RESULTS.md, "medium_glass's worst
 * seed was a counted one-vertex chain at the refraction's fold"). */
static void inside_cell(inside_problem *pb, double p0, int s0, double f0, double p1, int s1, double f1, int depth);

static void inside_pair(inside_problem *pb, double pa, double fa, double pc, double fc)
{
    const double g = 0.6180339887498949, sgn = fa < 0.0 ? -1.0 : 1.0;
    double a = pa, c = pc, u = c - g * (c - a), v = a + g * (c - a), fu = 0.0, fv = 0.0;
    if (inside_eval_at(pb->d, pb->y1, pb->y2, pb->m, pb->eta, u, &fu, NULL) != 0 ||
        inside_eval_at(pb->d, pb->y1, pb->y2, pb->m, pb->eta, v, &fv, NULL) != 0)
        return;
    for (int it = 0; it < SPC_SPHERE_INSIDE_PAIR_STEPS && sgn * fu > 0.0 && sgn * fv > 0.0; ++it) {
        if (sgn * fu < sgn * fv) {
            c = v;
            v = u;
            fv = fu;
            u = c - g * (c - a);
            if (inside_eval_at(pb->d, pb->y1, pb->y2, pb->m, pb->eta, u, &fu, NULL) != 0)
                return;
        } else {
            a = u;
            u = v;
            fu = fv;
            v = a + g * (c - a);
            if (inside_eval_at(pb->d, pb->y1, pb->y2, pb->m, pb->eta, v, &fv, NULL) != 0)
                return;
        }
    }
    double pm = sgn * fu < sgn * fv ? u : v, fm = sgn * fu < sgn * fv ? fu : fv;
    if (!(sgn * fm < 0.0))
        return; /* no pair: an extremum short of zero */
    inside_cell(pb, pa, 0, fa, pm, 0, fm, 1);
    inside_cell(pb, pm, 0, fm, pc, 0, fc, 1);
}

/* The root in the cell (p0, p1) of directions with states s0, s1 and values f0, f1 (inside_eval), if
 * the cell brackets one, added to pb's roots; a cell that begins and ends where f is not defined for
 * different reasons (total reflection on one side, y behind on the other) may hold a range where it
 * is between them, narrower than the cell: it is searched on a finer grid of its own (depth 1). */
static void inside_cell(inside_problem *pb, double p0, int s0, double f0, double p1, int s1, double f1, int depth)
{
    if (pb->n >= pb->max)
        return;
    double a = p0, b = p1, fa = f0;
    bool have = false;
    if (s0 == 0 && s1 == 0) {
        have = (f0 < 0.0) != (f1 < 0.0);
    } else if ((s0 == 0) != (s1 == 0)) {
        /* the edge of the valid range, by bisection; a root by the edge where the way out turns
         * grazing (the light seen at the ball's rim from inside) lies within it */
        double good = s0 == 0 ? p0 : p1, bad = s0 == 0 ? p1 : p0, fg = s0 == 0 ? f0 : f1;
        for (int it = 0; it < SPC_SPHERE_INSIDE_EDGE_STEPS; ++it) {
            double mid = 0.5 * (good + bad), fm = 0.0;
            if (inside_eval_at(pb->d, pb->y1, pb->y2, pb->m, pb->eta, mid, &fm, NULL) == 0) {
                good = mid;
                fg = fm;
            } else {
                bad = mid;
            }
        }
        if ((fg < 0.0) != ((s0 == 0 ? f0 : f1) < 0.0)) {
            a = s0 == 0 ? p0 : good;
            fa = s0 == 0 ? f0 : fg;
            b = s0 == 0 ? good : p1;
            have = true;
        } else if (depth == 0) {
            /* one sign from the edge to the sample: the caller may look for a pair between them */
            pb->edge_p = good;
            pb->edge_f = fg;
        }
    } else if (s0 != s1 && depth == 0) {
        int sp = s0;
        double pp = p0, fp = f0;
        for (int j = 1; j <= SPC_SPHERE_INSIDE_SUB; ++j) {
            double pj = p0 + (p1 - p0) * j / SPC_SPHERE_INSIDE_SUB, fj = 0.0;
            int sj = j == SPC_SPHERE_INSIDE_SUB ? s1 : inside_eval_at(pb->d, pb->y1, pb->y2, pb->m, pb->eta, pj, &fj, NULL);
            if (j == SPC_SPHERE_INSIDE_SUB)
                fj = f1;
            inside_cell(pb, pp, sp, fp, pj, sj, fj, 1);
            pp = pj;
            sp = sj;
            fp = fj;
        }
        return;
    }
    if (!have)
        return;
    for (int it = 0; it < SPC_SPHERE_INSIDE_STEPS; ++it) {
        double mid = 0.5 * (a + b), fm = 0.0;
        if (inside_eval_at(pb->d, pb->y1, pb->y2, pb->m, pb->eta, mid, &fm, NULL) != 0)
            break;
        if ((fm < 0.0) == (fa < 0.0)) {
            a = mid;
            fa = fm;
        } else {
            b = mid;
        }
    }
    double f, th;
    if (inside_eval_at(pb->d, pb->y1, pb->y2, pb->m, pb->eta, 0.5 * (a + b), &f, &th) == 0 ||
        inside_eval_at(pb->d, pb->y1, pb->y2, pb->m, pb->eta, a, &f, &th) == 0)
        pb->theta[pb->n++] = th;
}

int spc_sphere_inside_roots(double d, double y1, double y2, int m, double eta, double *theta, int max_roots)
{
    if (m < 0 || m > SPC_SPHERE_MAX_M || !(d >= 0.0 && d < 1.0) || !(y1 * y1 + y2 * y2 > 1.0) || !(eta > 0.0))
        return 0;
    inside_problem pb = {d, y1, y2, eta, m, theta, 0, max_roots, NAN, 0.0};
    const double step = 2.0 * SPC_PI / SPC_SPHERE_INSIDE_GRID, cs = cos(step), sn = sin(step);
    /* the grid's directions by rotation, from phi = -pi */
    double ux = -1.0, uy = 0.0;
    double p0 = -SPC_PI, f0 = 0.0;
    int s0 = inside_eval(d, y1, y2, m, eta, ux, uy, &f0, NULL);
    /* the sample before p0 (state sm, value fm at pm): where three valid samples of one sign have
     * the middle one nearest zero, a pair of roots may lie between the outer two (inside_pair) */
    double pm = p0, fm = 0.0;
    int sm = 1;
    /* an edge just before p0 with f of one sign from it to p0 (pending_p: NAN where none) */
    double pending_p = NAN, pending_f = 0.0;
    for (int i = 1; i <= SPC_SPHERE_INSIDE_GRID; ++i) {
        double nx = ux * cs - uy * sn, ny = ux * sn + uy * cs;
        ux = nx;
        uy = ny;
        double p1 = -SPC_PI + i * step, f1 = 0.0;
        int s1 = inside_eval(d, y1, y2, m, eta, ux, uy, &f1, NULL);
        pb.edge_p = NAN;
        inside_cell(&pb, p0, s0, f0, p1, s1, f1, 0);
        /* where |f| falls toward a sample between two of the same sign, or toward an edge (a
         * sample with no way out next), the pair the extremum may hide: a fold inside the cells
         * of three valid samples, or in the valid cell or the edge's cell beside an edge */
        if (pb.n < pb.max && s0 == 0) {
            bool falls_from_m = sm == 0 && (fm < 0.0) == (f0 < 0.0) && fabs(f0) < fabs(fm);
            bool falls_from_1 = s1 == 0 && (f1 < 0.0) == (f0 < 0.0) && fabs(f0) < fabs(f1);
            if (falls_from_m && falls_from_1) {
                inside_pair(&pb, pm, fm, p1, f1);
            } else if (falls_from_m && s1 != 0) {
                inside_pair(&pb, pm, fm, p0, f0);
                if (!isnan(pb.edge_p) && pb.n < pb.max)
                    inside_pair(&pb, p0, f0, pb.edge_p, pb.edge_f);
            } else if (falls_from_1 && sm != 0) {
                inside_pair(&pb, p0, f0, p1, f1);
                if (!isnan(pending_p) && pb.n < pb.max)
                    inside_pair(&pb, pending_p, pending_f, p0, f0);
            } else if (sm != 0 && s1 != 0) { /* a lone valid sample: both edges' cells */
                if (!isnan(pending_p))
                    inside_pair(&pb, pending_p, pending_f, p0, f0);
                if (!isnan(pb.edge_p) && pb.n < pb.max)
                    inside_pair(&pb, p0, f0, pb.edge_p, pb.edge_f);
            }
        }
        pending_p = s0 != 0 && s1 == 0 ? pb.edge_p : NAN;
        pending_f = pb.edge_f;
        pm = p0;
        fm = f0;
        sm = s0;
        p0 = p1;
        f0 = f1;
        s0 = s1;
    }
    return pb.n;
}

bool spc_sphere_arc_unseen(double y1, double y2, const double p0[2], const double p1[2])
{
    /* y . P(t) = |y| cos(t - phi) on an arc shorter than half a turn: its largest value is |y| > 1
     * where its derivative y2 cos t - y1 sin t turns from positive to negative inside, else at an
     * end */
    if (y2 * p0[0] - y1 * p0[1] > 0.0 && y2 * p1[0] - y1 * p1[1] < 0.0)
        return false;
    return fmax(y1 * p0[0] + y2 * p0[1], y1 * p1[0] + y2 * p1[1]) < 1.0 - 1e-9;
}
