/*
 * manifold/roots1d.c: the roots of a function of one angle sampled on a grid (roots1d.h).
 */
#include "manifold/roots1d.h"

#include <math.h>
#include <stddef.h>

/* Samples after refinement, at most; levels of halving per grid cell, at most (a vertex of a chain
 * of three reflections sweeping past the sharp end of a long ellipse needs cells of 1/4096 of the
 * grid's; with 8 levels the tests missed 1 root in 2251); and the largest turn of an angle across a
 * cell that is not halved (in turns, as spc_roots1d_turns measures them). */
#define SPC_ROOTS1D_MAX_SAMPLES 1024
#define SPC_ROOTS1D_MAX_DEPTH 12
#define SPC_ROOTS1D_MAX_TURN 0.08
/* The bracket width (in t) at which a root is first judged (y ahead, the caller's accept). */
#define SPC_ROOTS1D_COARSE 1e-6

/* Regula falsi on [*a, *b] (f of opposite signs at the ends) until the bracket is narrower than
 * tol, with the Anderson-Bjorck scaling of the end that stays twice in a row (Anderson and Bjorck
 * 1973: its value times 1 - fc / fb, or a half where that is not positive, the Illinois factor):
 * on the glass ball's render 12% fewer evaluations than the Illinois halving alone (callgrind).
 * *pha, *phb: fn's "ahead" at the ends, kept with them (the scaling changes *pfa and *pfb, never
 * the ends' ahead), so that the caller's test of a root at an end needs no evaluation. */
static void regula_falsi(spc_roots1d_fn fn, const void *ctx, double *pa, double *pfa, double *pha, double *pb,
                         double *pfb, double *phb, double tol)
{
    double a = *pa, fa = *pfa, ha = *pha, b = *pb, fb = *pfb, hb = *phb;
    int side = 0;
    for (int it = 0; it < 100 && fabs(b - a) > tol; ++it) {
        double c = (a * fb - b * fa) / (fb - fa);
        if (!(c > fmin(a, b) && c < fmax(a, b)))
            c = 0.5 * (a + b);
        double fc, ahead;
        if (!fn(ctx, c, &fc, &ahead, NULL))
            break; /* cannot happen inside a defined bracket; stay safe */
        if (fc == 0.0) {
            a = b = c;
            fa = fb = 0.0;
            ha = hb = ahead;
            break;
        }
        if ((fc > 0.0) == (fb > 0.0)) {
            if (side == -1) {
                double m = 1.0 - fc / fb;
                fa *= m > 0.0 ? m : 0.5;
            }
            b = c;
            fb = fc;
            hb = ahead;
            side = -1;
        } else {
            if (side == 1) {
                double m = 1.0 - fc / fa;
                fb *= m > 0.0 ? m : 0.5;
            }
            a = c;
            fa = fc;
            ha = ahead;
            side = 1;
        }
    }
    *pa = a;
    *pfa = fa;
    *pha = ha;
    *pb = b;
    *pfb = fb;
    *phb = hb;
}

/* The root of f in [a, b] (fa, fb of opposite signs, both defined; ha, hb fn's "ahead" there) added
 * to theta: refined to SPC_ROOTS1D_COARSE, then dropped if y is behind the chain (ahead at the end
 * kept, which regula_falsi evaluated there) or accept (if any) refuses it, else refined to tol; kept
 * unless within 1e-10 of a root kept before. */
static void add_root(spc_roots1d_fn fn, spc_roots1d_accept accept, const void *ctx, double a, double fa, double ha,
                     double b, double fb, double hb, double tol, double *theta, int *n, int max_roots)
{
    if (*n >= max_roots)
        return;
    regula_falsi(fn, ctx, &a, &fa, &ha, &b, &fb, &hb, tol > SPC_ROOTS1D_COARSE ? tol : SPC_ROOTS1D_COARSE);
    bool at_a = fabs(fa) < fabs(fb);
    double th = at_a ? a : b, ahead = at_a ? ha : hb;
    if (!(ahead > 0.0) || (accept && !accept(ctx, th)))
        return;
    if (tol < SPC_ROOTS1D_COARSE && fa != 0.0 && fb != 0.0) {
        regula_falsi(fn, ctx, &a, &fa, &ha, &b, &fb, &hb, tol);
        th = fabs(fa) < fabs(fb) ? a : b;
    }
    for (int i = 0; i < *n; ++i)
        if (fabs(theta[i] - th) < 1e-10)
            return;
    theta[(*n)++] = th;
}

/* A root exactly at a sample. */
static void add_exact(spc_roots1d_fn fn, spc_roots1d_accept accept, const void *ctx, double th, double *theta, int *n,
                      int max_roots)
{
    double f, ahead;
    if (*n >= max_roots || !fn(ctx, th, &f, &ahead, NULL) || !(ahead > 0.0) || (accept && !accept(ctx, th)))
        return;
    for (int i = 0; i < *n; ++i)
        if (fabs(theta[i] - th) < 1e-10)
            return;
    theta[(*n)++] = th;
}

/* The refined samples. */
typedef struct samples {
    double t[SPC_ROOTS1D_MAX_SAMPLES], f[SPC_ROOTS1D_MAX_SAMPLES], a[SPC_ROOTS1D_MAX_SAMPLES];
    double target[SPC_ROOTS1D_MAX_SAMPLES]; /* the target's angle seen from the final segment (turns) */
    double ang[SPC_ROOTS1D_MAX_SAMPLES][SPC_ROOTS1D_MAX_ANGLES];
    bool ok[SPC_ROOTS1D_MAX_SAMPLES], skip[SPC_ROOTS1D_MAX_SAMPLES]; /* skip: the cell from this sample */
    int n;
} samples;

static void push(samples *S, double t, double f, double a, const double *ang, int nang, bool ok, bool skip)
{
    for (int i = 0; i < nang; ++i)
        S->ang[S->n][i] = ang[i];
    S->t[S->n] = t;
    S->f[S->n] = f;
    S->a[S->n] = a;
    S->target[S->n] = ok ? spc_roots1d_turns(a, f) : 0.0;
    S->ok[S->n] = ok;
    S->skip[S->n] = skip;
    S->n++;
}

/* |a1 - a0| for two angles in turns (spc_roots1d_turns), the shorter way round. */
static double turn(double a0, double a1)
{
    double d = a1 - a0;
    if (d > 0.5)
        d -= 1.0;
    if (d < -0.5)
        d += 1.0;
    return fabs(d);
}

/* The largest turn across a cell: of the target seen from the final segment (f and ahead are its
 * sine and cosine, times the distance) and of the chain's own angles. */
static double cell_turn(const samples *S, int i, double f1, double a1, const double *ang1, int nang)
{
    double m = turn(S->target[i], spc_roots1d_turns(a1, f1));
    for (int k = 0; k < nang; ++k) {
        double d = turn(S->ang[i][k], ang1[k]);
        m = d > m ? d : m;
    }
    return m;
}

/* After the sample S->n - 1 (the cell's start), the samples strictly inside the cell up to t1, in
 * order: the cell is halved while an angle turns by more than SPC_ROOTS1D_MAX_TURN across it, or f
 * is defined at one end only (to find where). */
static void subdivide(spc_roots1d_fn fn, const void *ctx, samples *S, int nang, double t1, double f1, double a1,
                      const double *ang1, bool ok1, int depth)
{
    int i = S->n - 1;
    bool ok0 = S->ok[i];
    bool split = ok0 != ok1 || (ok0 && ok1 && cell_turn(S, i, f1, a1, ang1, nang) > SPC_ROOTS1D_MAX_TURN);
    /* room for this sample and the cells still to come (at most one per level above) */
    if (!split || depth >= SPC_ROOTS1D_MAX_DEPTH || S->n + 2 + depth >= SPC_ROOTS1D_MAX_SAMPLES)
        return;
    double tm = 0.5 * (S->t[i] + t1), fm = 0.0, am = 0.0, angm[SPC_ROOTS1D_MAX_ANGLES];
    bool okm = fn(ctx, tm, &fm, &am, angm);
    subdivide(fn, ctx, S, nang, tm, fm, am, angm, okm, depth + 1);
    push(S, tm, fm, am, angm, nang, okm, false);
    subdivide(fn, ctx, S, nang, t1, f1, a1, ang1, ok1, depth + 1);
}

int spc_roots1d(spc_roots1d_fn fn, spc_roots1d_accept accept, const void *ctx, const double *t, const double *f0,
                const double *ahead, const double *ang, int nang, const bool *ok0, int grid, const bool *skip,
                double tol, double *theta, int max_roots)
{
    static _Thread_local samples S;
    S.n = 0;
    if (nang > SPC_ROOTS1D_MAX_ANGLES)
        nang = SPC_ROOTS1D_MAX_ANGLES;
    for (int j = 0; j <= grid && S.n < SPC_ROOTS1D_MAX_SAMPLES - 1; ++j) {
        bool sk = j < grid && skip && skip[j];
        push(&S, t[j], f0[j], ahead[j], ang + (size_t)j * SPC_ROOTS1D_MAX_ANGLES, nang, ok0[j], sk);
        if (j < grid && !sk)
            subdivide(fn, ctx, &S, nang, t[j + 1], f0[j + 1], ahead[j + 1],
                      ang + (size_t)(j + 1) * SPC_ROOTS1D_MAX_ANGLES, ok0[j + 1], 0);
    }
    const double *th = S.t, *f = S.f;
    const bool *ok = S.ok;
    int last = S.n - 1;
    int n = 0;
    for (int j = 0; j < last; ++j) {
        if (!ok[j] || !ok[j + 1] || S.skip[j])
            continue;
        if (f[j] == 0.0)
            add_exact(fn, accept, ctx, th[j], theta, &n, max_roots);
        else if ((f[j] > 0.0) != (f[j + 1] > 0.0) && f[j + 1] != 0.0)
            add_root(fn, accept, ctx, th[j], f[j], S.a[j], th[j + 1], f[j + 1], S.a[j + 1], tol, theta, &n, max_roots);
    }
    if (ok[last] && f[last] == 0.0)
        add_exact(fn, accept, ctx, th[last], theta, &n, max_roots);
    /* pairs of roots between samples: a local extremum of the samples toward zero */
    for (int j = 1; j < last; ++j) {
        if (!ok[j - 1] || !ok[j] || !ok[j + 1] || (S.skip[j - 1] && S.skip[j]))
            continue;
        double s = f[j] > 0.0 ? 1.0 : -1.0;
        if (!(s * f[j - 1] > s * f[j] && s * f[j + 1] > s * f[j] && s * f[j - 1] > 0.0 && s * f[j + 1] > 0.0 &&
              s * f[j] > 0.0))
            continue;
        /* the parabola through the three samples: where its lowest point stays above half the middle
         * sample, f would have to leave it by more than that within two cells to reach zero, which
         * the refinement above (the target's angle turns little across a cell) rules out */
        {
            double ta = th[j - 1], tb = th[j], tc = th[j + 1];
            double fa = s * f[j - 1], fb = s * f[j], fc = s * f[j + 1];
            double dab = (fb - fa) / (tb - ta), dbc = (fc - fb) / (tc - tb), dabc = (dbc - dab) / (tc - ta);
            if (dabc > 0.0) {
                double ts = 0.5 * (ta + tb) - dab / (2.0 * dabc);
                double pmin = ts <= ta ? fa : ts >= tc ? fc : fa + dab * (ts - ta) + dabc * (ts - ta) * (ts - tb);
                if (pmin > 0.5 * fb)
                    continue;
            }
        }
        /* the minimum of s f on [th[j-1], th[j+1]] by successive parabolic interpolation (golden
         * sections where the parabola is no help), stopped as soon as f changes sign */
        double a = th[j - 1], b = th[j], c = th[j + 1];
        double fa = s * f[j - 1], fb = s * f[j], fc = s * f[j + 1];
        double hb = S.a[j], tm = b, fm = fb, hm = hb; /* hb, hm: ahead at b and tm */
        for (int it = 0; it < 40 && fm > 0.0; ++it) {
            double p1 = (b - a) * (fb - fc), p2 = (b - c) * (fb - fa);
            double den = 2.0 * (p1 - p2), t = b - ((b - a) * p1 - (b - c) * p2) / den;
            if (!(den != 0.0) || !(t > a && t < c) || fabs(t - b) < 1e-3 * (c - a)) {
                /* golden section of the larger side */
                const double g = 0.3819660112501051;
                t = (c - b > b - a) ? b + g * (c - b) : b - g * (b - a);
            }
            double ft, ahead;
            if (!fn(ctx, t, &ft, &ahead, NULL))
                break;
            ft *= s;
            if (ft < fb) {
                if (t < b) {
                    c = b;
                    fc = fb;
                } else {
                    a = b;
                    fa = fb;
                }
                b = t;
                fb = ft;
                hb = ahead;
            } else if (t < b) {
                a = t;
                fa = ft;
            } else {
                c = t;
                fc = ft;
            }
            tm = b;
            fm = fb;
            hm = hb;
            if (c - a < tol)
                break;
        }
        if (!(fm < 0.0))
            continue; /* the extremum does not cross zero (or touches it: a double root, measure zero) */
        fm *= s;
        add_root(fn, accept, ctx, th[j - 1], f[j - 1], S.a[j - 1], tm, fm, hm, tol, theta, &n, max_roots);
        add_root(fn, accept, ctx, tm, fm, hm, th[j + 1], f[j + 1], S.a[j + 1], tol, theta, &n, max_roots);
    }
    return n;
}
