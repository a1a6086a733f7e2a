/*
 * manifold/conic_solver.c: every reflected or refracted connection through one triangle mesh with
 * interpolated normals, by the coplanarity conic and the degree-6 chord polynomial (Freire 2021,
 * shared/papers/003), and the mesh hierarchy that keeps it below a loop over every triangle
 * (Walter, Zhao, Holzschuch and Bala 2009, "Single scattering in refractive media with triangle
 * mesh boundaries", sec. 5).
 *
 * Per triangle (spc_conic_solve_triangle):
 *  1. the coplanarity conic, its type and its arcs inside the triangle (conic.c; report sec. 5.2);
 *  2. each arc is cut into chords within SPC_CONIC_CHORD_TOL of it (sec. 5.3.2); on a chord the
 *     squared sine law with the indices of one side assignment is a polynomial of degree 6
 *     (sec. 5.1, 5.3.1); the sides of x and y change only where (x-P).n and (y-P).n vanish, so each
 *     assignment is solved only on the pieces of the chord whose sides may allow it;
 *  3. VCA bisection isolates its roots, Newton refines them (polyroots.c; sec. 6.1-6.2);
 *  4. each root is polished on the true law (the report's projection onto the conic, sec. 6.3,
 *     replaced by Gauss-Newton on n^ x (eta_x wx + eta_y wy) = 0 in (u, v): coplanarity and the
 *     unsquared vector law together) and kept if the law holds to SPC_CONIC_LAW_TOL, the point is
 *     in the triangle and the sides agree with the event and the indices used; this rejects
 *     every root squaring admitted (a ray bent to the wrong side, total internal reflection,
 *     reflection for refraction and the reverse, zero interpolated normals).
 * The report's method assumes the chord's polynomial has the arc's roots; it need not. Here the
 * arc's offset from its chord is bounded (a conic arc is convex: below err and below its end
 * tangents), which bounds f on the arc by f on the chord plus a band |D|, D the change of f to
 * the chord's offset. A chord is split again while (a) a band interval is wider than
 * SPC_CONIC_BAND_WIDTH (f varies much more across the chord than along it: the arc's roots cannot
 * be placed), (b) a band interval without a root of the chord has ends of one sign (a pair of the
 * arc's roots may hide there: a near miss), or (c) a root of the chord, classified as a true one
 * (a sign change of the unsquared law, evaluated on the arc: squaring's own roots are skipped),
 * polishes outside its band interval, onto a solution another root of the chord reached, or not
 * at all. At the depth limit the band interval itself is polished (a double root: the fold of a
 * caustic). Roots at an arc's ends are never lost: both ends of every chord lie on the conic, so
 * f has the same value there on the chord and on the arc. Double roots (y on a caustic, the fold
 * where two solutions merge) keep the band interval as wide relative to the chord at every depth,
 * so chords there are split down to rounding; on such deep chords the zeros of f' and the chord
 * ends where |f| is within rounding of zero are polished as well, and polished points of one flat
 * valley are merged (tests: constructed folds). Degenerate conics give exact segments
 * (the square-free part of f catches their double roots); isolated points (a point conic, a
 * tangency from outside, a line pair's crossing) are polished directly.
 *
 * Per mesh (spc_conic_mesh_*): a bounding volume hierarchy (median splits) whose nodes carry a
 * box and a cone bounding the unit shading normals of their triangles. A node is culled when
 * (a) x and y are surely on the wrong sides of every normal of the cone (refraction: the same
 * side; reflection: opposite sides), (b) the cone of normals misses the cone of lines of the
 * generalized half vector eta_x wx + eta_y wy over the box, or (c) (refraction) the box lies
 * outside the spindle of points from which the segment xy is seen under an angle of at least
 * pi - delta_max, delta_max = pi/2 - asin(1/eta) the largest bending refraction can do. All three
 * are conservative, so the hierarchy returns exactly the solutions of the per-triangle loop.
 * Solutions on shared edges and vertices are merged by position.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "manifold/conic.h"
#include "manifold/polyroots.h"
#include "manifold/solver.h"

/* Largest distance, in barycentric units, between a chord and its arc before it is split. Roots
 * are polished on the true law afterwards, so this only sets how close the starting points are;
 * 1e-2 of the triangle keeps Gauss-Newton well inside its basin (tested on 10^4 random
 * configurations against a dense search). */
#define SPC_CONIC_CHORD_TOL 1e-2
/* Slack (in chord parameter) of the check that a polished root stayed in its chord's band
 * interval: rounding of the band's ends. */
#define SPC_CONIC_POLISH_SLACK 1e-7
/* Widest band interval (in chord parameter) a chord may have before it is split: its roots then
 * start the polishing within a twentieth of the chord of the arc's roots. */
#define SPC_CONIC_BAND_WIDTH 0.05
/* Depth limit of chord splitting (each split at least halves the chord-to-arc distance). */
#define SPC_CONIC_MAX_SPLIT_DEPTH 40
/* A solution must satisfy the law to this relative residual (the test asks for 1e-9). */
#define SPC_CONIC_LAW_TOL 1e-10
/* Gauss-Newton iterations of the polishing step: quadratic convergence takes ~5 from a chord
 * root; the rest is for near-double roots, where convergence is linear. */
#define SPC_CONIC_POLISH_ITERATIONS 60
/* A polished point may lie this far outside the triangle (barycentric units): a root on a shared
 * edge is then found from both sides and merged, never lost between them. */
#define SPC_CONIC_INSIDE_TOL 1e-9
/* Solutions of one triangle closer than this (barycentric units) are the same. */
#define SPC_CONIC_SAME_UV 1e-8
/* Solutions of one triangle closer than this (barycentric units) are the same if the law holds
 * halfway between them as well as at them (try_candidate): the spread of polished points around a
 * double root, where the residual grows only quadratically (~1e-5 measured on constructed folds). */
#define SPC_CONIC_SAME_FOLD 1e-4
/* A candidate that starts this close (barycentric units) to a solution found before is that
 * solution: well inside the basin of any simple root, and within the spread of a double root. */
#define SPC_CONIC_SAME_START 1e-6
/* Solutions of a mesh closer than this fraction of their distance to x and y are the same. */
#define SPC_CONIC_SAME_REL 1e-8
/* The interpolated normal must keep this fraction of the vertex normals' mean length: where it
 * vanishes the shading normal is undefined (and the squared law is trivially zero). */
#define SPC_CONIC_MIN_NORMAL 1e-8
/* Where the interpolated normal is shorter than this fraction of the vertex normals' mean length,
 * its direction turns fast (it vanishes nearby): roots there are all polished, none classified. */
#define SPC_CONIC_FAST_NORMAL 0.25
/* Relative tolerance of gcd(f, f') in the square-free part of an exact segment's polynomial:
 * calibrated on polynomials with exact repeated roots (tests/test_conic.c), where remainders that
 * vanish in exact arithmetic come out near 1e-10 of the dividend. */
#define SPC_CONIC_SQUAREFREE_TOL 1e-8
/* A zero of the chord polynomial's derivative (or a chord end) where |f| is below this fraction of
 * the size of f's terms (snell_scale) may be a double root within rounding (a fold of the
 * caustic, where f grows quadratically: within ~1e-4 of it) and is polished; polishing rejects
 * what is not a solution. */
#define SPC_CONIC_DOUBLE_ROOT_TOL 1e-8
/* A chord within this distance (barycentric units) of its arc was split far below
 * SPC_CONIC_CHORD_TOL: by a fold or a near miss; its double-root candidates are polished. */
#define SPC_CONIC_DEEP_CHORD 1e-9
/* Chord-end and double-root candidates (solve_chord) polished per triangle at most, and the distance
 * (barycentric units) from a known solution within which they are taken for it: the stretch around
 * a fold where |f| stays below SPC_CONIC_DOUBLE_ROOT_TOL. */
#define SPC_CONIC_MAX_FOLD_CANDIDATES 16
#define SPC_CONIC_FOLD_REACH 1e-3
/* Inadmissible roots of the law remembered per triangle (see try_candidate). */
#define SPC_CONIC_MAX_REJECTED 16
/* A chord farther than this from its arc (barycentric units) is split when an undecided root's
 * polish wanders off (solve_chord); below it a start is close enough to its root that a wandering
 * polish means there is none. */
#define SPC_CONIC_WANDER_ERR 1e-6
/* Candidate roots kept per triangle. */
#define SPC_CONIC_MAX_CANDIDATES 256
/* Solutions per triangle (a conic and a sextic meet in at most 12 points, each arc piece is
 * polished separately). */
#define SPC_CONIC_MAX_TRI_SOLUTIONS 16
/* Triangles per hierarchy leaf. */
#define SPC_CONIC_LEAF_SIZE 4
/* Padding of the cones stored in float (radians): covers float rounding of axes and angles. */
#define SPC_CONIC_CONE_PAD 1e-5
/* Chains kept per query by spc_conic_solve_all. */
#define SPC_CONIC_MAX_MESH_SOLUTIONS 64

/* ---- the law and its Gauss-Newton polishing ---- */

typedef struct law_eval {
    spc_vec3 R, Ru, Rv; /* R = n^ x h and its derivatives in u and v */
    double cx, cy;      /* wx . n^, wy . n^ */
} law_eval;

static bool law(const spc_conic_tri *t, const spc_conic_problem *pb, double ex, double ey, double u, double v,
                bool derivs, law_eval *o)
{
    spc_vec3 P = spc_conic_tri_point(t, u, v), n = spc_conic_tri_normal(t, u, v);
    double ln = spc_length(n);
    spc_vec3 ax = spc_sub(pb->x, P), ay = spc_sub(pb->y, P);
    double lx = spc_length(ax), ly = spc_length(ay);
    if (!(ln > 0.0) || !(lx > 0.0) || !(ly > 0.0))
        return false;
    spc_vec3 nh = spc_scale(n, 1.0 / ln), wx = spc_scale(ax, 1.0 / lx), wy = spc_scale(ay, 1.0 / ly);
    spc_vec3 h = spc_add(spc_scale(wx, ex), spc_scale(wy, ey));
    o->R = spc_cross(nh, h);
    o->cx = spc_dot(wx, nh);
    o->cy = spc_dot(wy, nh);
    if (!derivs)
        return true;
    for (int j = 0; j < 2; ++j) {
        spc_vec3 e = j == 0 ? t->e1 : t->e2, dn = j == 0 ? t->dn1 : t->dn2;
        spc_vec3 dwx = spc_scale(spc_sub(e, spc_scale(wx, spc_dot(wx, e))), -1.0 / lx);
        spc_vec3 dwy = spc_scale(spc_sub(e, spc_scale(wy, spc_dot(wy, e))), -1.0 / ly);
        spc_vec3 dnh = spc_scale(spc_sub(dn, spc_scale(nh, spc_dot(nh, dn))), 1.0 / ln);
        spc_vec3 dh = spc_add(spc_scale(dwx, ex), spc_scale(dwy, ey));
        spc_vec3 dR = spc_add(spc_cross(dnh, h), spc_cross(nh, dh));
        if (j == 0)
            o->Ru = dR;
        else
            o->Rv = dR;
    }
    return true;
}

/* Gauss-Newton with backtracking on |R|^2 from (u, v); returns the relative residual reached. */
static double polish(const spc_conic_tri *t, const spc_conic_problem *pb, double ex, double ey, double *pu,
                     double *pv)
{
    double u = *pu, v = *pv;
    law_eval L;
    if (!law(t, pb, ex, ey, u, v, true, &L))
        return INFINITY;
    double r2 = spc_length2(L.R), scale = ex + ey;
    for (int it = 0; it < SPC_CONIC_POLISH_ITERATIONS; ++it) {
        if (sqrt(r2) <= 1e-16 * scale)
            break;
        double a11 = spc_dot(L.Ru, L.Ru), a12 = spc_dot(L.Ru, L.Rv), a22 = spc_dot(L.Rv, L.Rv);
        double b1 = -spc_dot(L.Ru, L.R), b2 = -spc_dot(L.Rv, L.R);
        double det = a11 * a22 - a12 * a12;
        if (!(det > 1e-24 * a11 * a22)) {
            /* (nearly) singular: a small Levenberg-Marquardt damping */
            double lam = 1e-12 * (a11 + a22) + 1e-300;
            a11 += lam;
            a22 += lam;
            det = a11 * a22 - a12 * a12;
            if (!(det > 0.0))
                break;
        }
        double du = (a22 * b1 - a12 * b2) / det, dv = (a11 * b2 - a12 * b1) / det;
        double len = sqrt(du * du + dv * dv);
        if (!isfinite(len))
            break;
        if (len > 0.5) {
            du *= 0.5 / len;
            dv *= 0.5 / len;
        }
        bool accepted = false;
        law_eval Ln;
        for (int k = 0; k < 40; ++k) {
            if (law(t, pb, ex, ey, u + du, v + dv, true, &Ln) && spc_length2(Ln.R) < r2) {
                accepted = true;
                break;
            }
            du *= 0.5;
            dv *= 0.5;
        }
        if (!accepted)
            break;
        u += du;
        v += dv;
        L = Ln;
        r2 = spc_length2(L.R);
        if (fabs(du) + fabs(dv) <= 1e-17 * (1.0 + fabs(u) + fabs(v)))
            break;
    }
    *pu = u;
    *pv = v;
    return sqrt(r2) / scale;
}

/* The indices (eta_x, eta_y) the event uses with x on side sx of the normal; false if the sides
 * (sx, sy) cannot carry the event. */
static bool indices(const spc_conic_problem *pb, double sx, double sy, double *ex, double *ey)
{
    if (pb->event == SPC_CONIC_REFLECT) {
        *ex = *ey = 1.0;
        return pb->front_only ? sx > 0.0 && sy > 0.0 : sx * sy > 0.0;
    }
    if (!(sx * sy < 0.0))
        return false;
    *ex = sx > 0.0 ? 1.0 : pb->eta;
    *ey = sx > 0.0 ? pb->eta : 1.0;
    return true;
}

static double min_normal(const spc_conic_tri *t)
{
    double l = spc_length(t->n0) + spc_length(spc_add(t->n0, t->dn1)) + spc_length(spc_add(t->n0, t->dn2));
    return SPC_CONIC_MIN_NORMAL * l / 3.0;
}

double spc_conic_law_residual(const spc_conic_tri *t, const spc_conic_problem *pb, double u, double v)
{
    if (spc_length(spc_conic_tri_normal(t, u, v)) <= min_normal(t))
        return INFINITY;
    law_eval L;
    if (!law(t, pb, 1.0, 1.0, u, v, false, &L))
        return INFINITY;
    double ex, ey;
    if (!indices(pb, L.cx, L.cy, &ex, &ey))
        return INFINITY;
    if (!law(t, pb, ex, ey, u, v, false, &L))
        return INFINITY;
    return spc_length(L.R) / (ex + ey);
}

/* ---- per triangle ---- */

typedef struct tri_ctx {
    const spc_conic_tri *t;
    const spc_conic_problem *pb;
    const spc_conic_arcs *arcs;
    double nmin, nmean; /* smallest admissible and mean length of the interpolated normal */
    spc_conic_solution sol[SPC_CONIC_MAX_TRI_SOLUTIONS];
    int nsol;
    int ncand;
    spc_vec2 rejected[SPC_CONIC_MAX_REJECTED]; /* roots of the law on inadmissible sides */
    double rejected_ex[SPC_CONIC_MAX_REJECTED];  /* and the index assignment they were polished with */
    int nrej;
    int nfold; /* double-root candidates polished */
    spc_conic_stats *st;
} tri_ctx;

typedef enum polish_result {
    POLISH_REJECTED, /* no admissible solution from there */
    POLISH_KEPT,     /* a new solution */
    POLISH_KNOWN,    /* a solution found before */
    POLISH_BUDGET    /* not tried: the triangle's candidate budget is spent */
} polish_result;

/* Polishes a candidate with indices (ex, ey); keeps it if admissible. *end (may be NULL) receives
 * where the polish ended, *which (may be NULL) the index of the solution kept or matched. */
static polish_result try_candidate(tri_ctx *c, double u, double v, double ex, double ey, spc_vec2 *end, int *which)
{
    /* a start next to a solution found before polishes onto it (chords split down to a fold
     * end next to its double root at every level: this keeps them from spending the budget) */
    for (int i = 0; i < c->nsol; ++i)
        if (hypot(c->sol[i].u - u, c->sol[i].v - v) <= SPC_CONIC_SAME_START) {
            if (end)
                *end = spc_v2(c->sol[i].u, c->sol[i].v);
            if (which)
                *which = i;
            return POLISH_KNOWN;
        }
    /* likewise next to a root of the law found on inadmissible sides (a chain of chords split
     * toward it would otherwise polish onto it again at every depth) */
    for (int i = 0; i < c->nrej; ++i)
        if (c->rejected_ex[i] == ex && hypot(c->rejected[i].x - u, c->rejected[i].y - v) <= SPC_CONIC_SAME_START) {
            if (end)
                *end = c->rejected[i];
            return POLISH_REJECTED;
        }
    if (c->ncand >= SPC_CONIC_MAX_CANDIDATES)
        return POLISH_BUDGET;
    c->ncand++;
    if (c->st)
        c->st->candidates++;
    double res = polish(c->t, c->pb, ex, ey, &u, &v);
    if (end)
        *end = spc_v2(u, v);
    if (!(res <= SPC_CONIC_LAW_TOL))
        return POLISH_REJECTED;
    if (u < -SPC_CONIC_INSIDE_TOL || v < -SPC_CONIC_INSIDE_TOL || u + v > 1.0 + SPC_CONIC_INSIDE_TOL)
        return POLISH_REJECTED;
    spc_vec3 n = spc_conic_tri_normal(c->t, u, v);
    double ln = spc_length(n);
    if (!(ln > c->nmin))
        return POLISH_REJECTED;
    law_eval L;
    double exx, eyy;
    if (!law(c->t, c->pb, ex, ey, u, v, false, &L) || !indices(c->pb, L.cx, L.cy, &exx, &eyy) || exx != ex ||
        eyy != ey) {
        if (c->nrej < SPC_CONIC_MAX_REJECTED) {
            c->rejected_ex[c->nrej] = ex;
            c->rejected[c->nrej++] = spc_v2(u, v);
        }
        return POLISH_REJECTED;
    }
    for (int i = 0; i < c->nsol; ++i) {
        double dist = hypot(c->sol[i].u - u, c->sol[i].v - v);
        if (dist > SPC_CONIC_SAME_FOLD)
            continue;
        /* near a double root (a fold) polishing stops anywhere in a flat valley of the residual,
         * which is convex there: halfway between two such ends it is no larger than at the
         * ends. Two distinct roots have a ridge between them (the residual grows like the square
         * of the distance to both), so a midpoint residual above the ends' keeps them apart. */
        if (dist > SPC_CONIC_SAME_UV) {
            law_eval M;
            double um = 0.5 * (u + c->sol[i].u), vm = 0.5 * (v + c->sol[i].v);
            double bound = 2.0 * fmax(res, c->sol[i].residual) + 1e-15;
            if (!law(c->t, c->pb, ex, ey, um, vm, false, &M) || !(spc_length(M.R) / (ex + ey) <= bound))
                continue;
        }
        if (which)
            *which = i;
        return POLISH_KNOWN;
    }
    if (c->nsol >= SPC_CONIC_MAX_TRI_SOLUTIONS)
        return POLISH_BUDGET;
    if (which)
        *which = c->nsol;
    spc_conic_solution *s = &c->sol[c->nsol++];
    s->u = u;
    s->v = v;
    s->prim = -1;
    s->p = spc_conic_tri_point(c->t, u, v);
    s->n = spc_scale(n, 1.0 / ln);
    s->residual = res;
    return POLISH_KEPT;
}

static void try_both(tri_ctx *c, spc_vec2 p)
{
    if (c->pb->event == SPC_CONIC_REFLECT) {
        try_candidate(c, p.x, p.y, 1.0, 1.0, NULL, NULL);
    } else {
        try_candidate(c, p.x, p.y, 1.0, c->pb->eta, NULL, NULL);
        try_candidate(c, p.x, p.y, c->pb->eta, 1.0, NULL, NULL);
    }
}

/* The point of the conic on the line through q along nu nearest q (within reach of a chord of
 * error err); q itself when there is no conic (degenerate cases) or no such point. */
static spc_vec2 onto_conic(const tri_ctx *c, spc_vec2 q, spc_vec2 nu, double err)
{
    if (!c->arcs->has_curve || !(err > 0.0))
        return q;
    const spc_conic *Q = &c->arcs->curve.q;
    double c0 = spc_conic_eval(Q, q.x, q.y);
    double c1 = (2.0 * Q->A * q.x + Q->B * q.y + Q->D) * nu.x + (Q->B * q.x + 2.0 * Q->C * q.y + Q->E) * nu.y;
    double c2 = Q->A * nu.x * nu.x + Q->B * nu.x * nu.y + Q->C * nu.y * nu.y;
    double r[2];
    int k = 0;
    if (c2 == 0.0) {
        if (c1 != 0.0)
            r[k++] = -c0 / c1;
    } else {
        double disc = c1 * c1 - 4.0 * c2 * c0;
        if (disc >= 0.0) {
            double sq = sqrt(disc), qq = -0.5 * (c1 + (c1 >= 0.0 ? sq : -sq));
            r[k++] = qq / c2;
            if (qq != 0.0)
                r[k++] = c0 / qq;
        }
    }
    double best = INFINITY;
    for (int i = 0; i < k; ++i)
        if (fabs(r[i]) < fabs(best))
            best = r[i];
    if (!(fabs(best) <= 2.0 * err))
        return q;
    return spc_v2(q.x + best * nu.x, q.y + best * nu.y);
}

/* The size of the terms of the squared law f at (u, v) (conic.h): its rounding is ~1e-16 of this. */
static double snell_scale(const spc_conic_tri *t, const spc_conic_problem *pb, double ex, double ey, double u, double v)
{
    spc_vec3 P = spc_conic_tri_point(t, u, v);
    double lx = spc_length2(spc_sub(pb->x, P)), ly = spc_length2(spc_sub(pb->y, P));
    return (ex * ex + ey * ey) * lx * ly * spc_length2(spc_conic_tri_normal(t, u, v));
}

/* Squaring the sine law admits roots where the tangential parts of eta_x wx and eta_y wy have
 * equal lengths but the same direction (light bent back to the side it came from). On the conic
 * (coplanar rays) f factors as F+ F-, F+- = (eta_x wx +- eta_y wy) . tau, tau the in-plane
 * tangent: true roots are the sign changes of F+, squaring's roots those of F-. Classifies the
 * root of the chord between chord points lo and hi by the signs at their projections on the arc:
 * +1 a sign change of F+ (a true root), -1 only of F- (squaring's), 0 undecided. */
static int root_kind(const tri_ctx *c, double ex, double ey, spc_vec2 lo, spc_vec2 hi, spc_vec2 nu, double err)
{
    spc_vec2 p[2] = {onto_conic(c, lo, nu, err), onto_conic(c, hi, nu, err)};
    double fp[2], fm[2];
    spc_vec3 tau = spc_v3(0, 0, 0);
    for (int i = 0; i < 2; ++i) {
        spc_vec3 P = spc_conic_tri_point(c->t, p[i].x, p[i].y), n = spc_conic_tri_normal(c->t, p[i].x, p[i].y);
        double ln = spc_length(n);
        if (!(ln > 0.0))
            return 0;
        spc_vec3 nh = spc_scale(n, 1.0 / ln);
        spc_vec3 wx = spc_normalize(spc_sub(c->pb->x, P)), wy = spc_normalize(spc_sub(c->pb->y, P));
        if (i == 0) {
            tau = spc_sub(wx, spc_scale(nh, spc_dot(wx, nh)));
            double lt = spc_length(tau);
            if (!(lt > 1e-12))
                return 0; /* normal incidence: no tangent to compare along */
            tau = spc_scale(tau, 1.0 / lt);
        }
        spc_vec3 tp = spc_add(spc_scale(wx, ex), spc_scale(wy, ey));
        spc_vec3 tm = spc_sub(spc_scale(wx, ex), spc_scale(wy, ey));
        /* tangential parts along tau (tau is tangent at the first point; the second is close) */
        fp[i] = spc_dot(spc_sub(tp, spc_scale(nh, spc_dot(tp, nh))), tau);
        fm[i] = spc_dot(spc_sub(tm, spc_scale(nh, spc_dot(tm, nh))), tau);
    }
    if (fp[0] * fp[1] <= 0.0)
        return 1;
    if (fm[0] * fm[1] <= 0.0)
        return -1;
    return 0;
}

/* The arc near chord parameter t lies at most err w(t) from the chord, w(t) = min(1, la t,
 * lb (1 - t)): a conic arc is convex, so its offset from the chord is a concave function of t,
 * below its largest value err and below its tangents at the ends (la = clen tan(angle at a) / err,
 * lb likewise; infinite for a straight piece of unknown shape). So f on the arc differs from f on
 * the chord by at most about w(t) |D(t)|, D the change of f from the chord to its parallel offset
 * by err toward the arc; SPC_CONIC_BAND_MARGIN covers the curvature of f across the band. */
#define SPC_CONIC_BAND_MARGIN 2.0

typedef struct band {
    double la, lb; /* slopes of the end bounds (relative to err) */
    double cut[4]; /* pieces [cut[i], cut[i+1]] on which w is linear: w0[i] + w1[i] t */
    double w0[3], w1[3];
    int npieces;
} band;

static void band_init(band *bd, double la, double lb)
{
    bd->la = la;
    bd->lb = lb;
    double ta = la > 1.0 ? 1.0 / la : 1.0, tb = lb > 1.0 ? 1.0 - 1.0 / lb : 0.0;
    int n = 0;
    bd->cut[0] = 0.0;
    if (ta < tb) {
        bd->w0[n] = 0.0, bd->w1[n] = la, bd->cut[++n] = ta;
        bd->w0[n] = 1.0, bd->w1[n] = 0.0, bd->cut[++n] = tb;
        bd->w0[n] = lb, bd->w1[n] = -lb, bd->cut[++n] = 1.0;
    } else {
        double tc = isfinite(la) && isfinite(lb) ? lb / (la + lb) : (isfinite(la) ? 1.0 : 0.0);
        if (tc > 0.0)
            bd->w0[n] = 0.0, bd->w1[n] = la, bd->cut[++n] = tc;
        if (tc < 1.0)
            bd->w0[n] = lb, bd->w1[n] = -lb, bd->cut[++n] = 1.0;
    }
    bd->npieces = n;
}

static double band_w(const band *bd, double t) { return fmax(0.0, fmin(1.0, fmin(bd->la * t, bd->lb * (1.0 - t)))); }

/* Roots in (t0, t1) of p +- k w q (p, q of degree n <= 6), piecewise; appends to br. */
static int band_roots(const band *bd, const double *p, const double *q, int n, double t0, double t1, double *br,
                      int nbr, int cap)
{
    for (int i = 0; i < bd->npieces; ++i) {
        double lo = fmax(t0, bd->cut[i]), hi = fmin(t1, bd->cut[i + 1]);
        if (!(hi > lo))
            continue;
        for (int sg = -1; sg <= 1; sg += 2) {
            double w[2] = {sg * SPC_CONIC_BAND_MARGIN * bd->w0[i], sg * SPC_CONIC_BAND_MARGIN * bd->w1[i]};
            double wq[8], poly[8];
            spc_poly_mul(w, 1, q, n, wq);
            for (int j = 0; j <= n + 1; ++j)
                poly[j] = (j <= n ? p[j] : 0.0) + wq[j];
            double r[8];
            int k = spc_poly_roots(poly, n + 1, lo, hi, r, 8);
            for (int j = 0; j < k && nbr < cap; ++j)
                if (r[j] > t0 && r[j] < t1)
                    br[nbr++] = r[j];
        }
        if (bd->cut[i] > t0 && bd->cut[i] < t1 && nbr < cap)
            br[nbr++] = bd->cut[i];
    }
    return nbr;
}

static void sort_doubles(double *v, int n)
{
    for (int i = 1; i < n; ++i)
        for (int j = i; j > 0 && v[j] < v[j - 1]; --j) {
            double tmp = v[j];
            v[j] = v[j - 1];
            v[j - 1] = tmp;
        }
}

/* True if p +- k q (w <= 1, so this bounds the band) have no root in [0, 1] and p(0) lies outside
 * the band: then |p| > k w |q| on the whole chord, and the band holds nothing (one Descartes test
 * per sign, no isolation). */
static bool clear_of_band(const double *p, const double *q, int n)
{
    double a[8], b[8];
    for (int i = 0; i <= n; ++i) {
        a[i] = p[i] + SPC_CONIC_BAND_MARGIN * q[i];
        b[i] = p[i] - SPC_CONIC_BAND_MARGIN * q[i];
    }
    if (!(a[0] * b[0] > 0.0)) /* p(0) within the band, or on its edge */
        return false;
    double sa = 0.0, sb = 0.0;
    for (int i = 0; i <= n; ++i) {
        sa += a[i];
        sb += b[i];
    }
    if (!(sa * a[0] > 0.0 && sb * b[0] > 0.0)) /* a sign change between the ends */
        return false;
    return spc_poly_descartes01(a, n) == 0 && spc_poly_descartes01(b, n) == 0;
}

/* The set U of [t0, t1] where |f| <= k w |D|: where the arc's f may differ in sign from the
 * chord's. Writes its maximal intervals (at most max_out) and returns how many. A root of the arc
 * lies in the U-interval of a root of the chord; a U-interval whose ends have the same sign of f
 * and that holds no root of the chord may hide a pair of the arc's roots (a near miss). */
static int band_intervals(const band *bd, const double f[7], const double D[7], double t0, double t1,
                          double (*iv)[2], int max_out)
{
    double br[64];
    int nb = 0;
    br[nb++] = t0;
    nb = band_roots(bd, f, D, 6, t0, t1, br, nb, 62);
    br[nb++] = t1;
    sort_doubles(br, nb);
    int n = 0, run = -1; /* run: the breakpoint where the current interval of U starts */
    for (int i = 0; i + 1 < nb; ++i) {
        double m = 0.5 * (br[i] + br[i + 1]);
        double fm = spc_poly_eval(f, 6, m), dm = spc_poly_eval(D, 6, m);
        bool inU = fabs(fm) <= SPC_CONIC_BAND_MARGIN * band_w(bd, m) * fabs(dm);
        if (inU && run < 0)
            run = i;
        if ((!inU || i + 2 == nb) && run >= 0) {
            int end = inU ? i + 1 : i;
            if (n < max_out) {
                iv[n][0] = br[run];
                iv[n][1] = br[end];
                ++n;
            }
            run = -1;
        }
    }
    return n;
}

/* Side of a point relative to the normal on the arc near chord parameter t: +1 / -1 when
 * certain, 0 when the arc may lie on either side (g within its band of zero). */
static int side_status(const band *bd, const double g[3], const double dg[3], double t)
{
    double v = spc_poly_eval(g, 2, t), b = SPC_CONIC_BAND_MARGIN * band_w(bd, t) * fabs(spc_poly_eval(dg, 2, t));
    return v > b ? 1 : (v < -b ? -1 : 0);
}

/* Can (certain = must) the sides (sx, sy) carry the event with x on side want_x? */
static bool sides_allow(const spc_conic_problem *pb, int sx, int sy, int want_x, bool certain)
{
    if (certain && (sx == 0 || sy == 0))
        return false;
    if (pb->event == SPC_CONIC_REFLECT && pb->front_only)
        return sx >= 0 && sy >= 0;
    if (pb->event == SPC_CONIC_REFLECT)
        return sx == 0 || sy == 0 || sx == sy;
    /* refraction: x on side want_x, y on the other */
    return (sx == 0 || sx == want_x) && (sy == 0 || sy == -want_x);
}

/* Solves one chord from a to b at distance err from its arc, the arc on the side of the point s.
 * Returns false if the chord must be split first (a near miss, a band too wide to place roots, or
 * a root that polished away from its own); splittable says it can be. */
static bool solve_chord(tri_ctx *c, spc_vec2 a, spc_vec2 b, double err, spc_vec2 s, bool straight, bool splittable)
{
    const spc_conic_tri *t = c->t;
    const spc_conic_problem *pb = c->pb;
    if (c->st)
        c->st->chords++;
    spc_vec2 d = spc_v2(b.x - a.x, b.y - a.y);
    double clen = sqrt(d.x * d.x + d.y * d.y);
    /* the unit normal of the chord toward its arc, and the chord offset by err along it */
    spc_vec2 nu = clen > 0.0 ? spc_v2(-d.y / clen, d.x / clen) : spc_v2(0.0, 0.0);
    if (nu.x * (s.x - a.x) + nu.y * (s.y - a.y) < 0.0)
        nu = spc_v2(-nu.x, -nu.y);
    spc_vec2 ao = spc_v2(a.x + err * nu.x, a.y + err * nu.y), bo = spc_v2(b.x + err * nu.x, b.y + err * nu.y);
    /* sidedness quadratics (X - P(t)) . n(t) on the chord, and their change to the offset chord */
    double gq[2][3], dg[2][3];
    for (int pass = 0; pass < 2; ++pass) {
        spc_vec2 aa = pass == 0 ? a : ao;
        spc_vec3 Pa = spc_conic_tri_point(t, aa.x, aa.y), na = spc_conic_tri_normal(t, aa.x, aa.y);
        spc_vec3 dP = spc_add(spc_scale(t->e1, d.x), spc_scale(t->e2, d.y));
        spc_vec3 dn = spc_add(spc_scale(t->dn1, d.x), spc_scale(t->dn2, d.y));
        for (int i = 0; i < 2; ++i) {
            spc_vec3 c0 = spc_sub(i == 0 ? pb->x : pb->y, Pa), c1 = spc_neg(dP);
            double g[3] = {spc_dot(c0, na), spc_dot(c0, dn) + spc_dot(c1, na), spc_dot(c1, dn)};
            for (int j = 0; j < 3; ++j) {
                if (pass == 0)
                    gq[i][j] = g[j];
                else
                    dg[i][j] = g[j] - gq[i][j];
            }
        }
    }
    /* the band's profile: end slopes from the angle between the chord and the conic's tangent */
    band bd;
    {
        double la = INFINITY, lb = INFINITY;
        if (err > 0.0 && c->arcs->has_curve && !straight) {
            const spc_conic *q = &c->arcs->curve.q;
            for (int e = 0; e < 2; ++e) {
                spc_vec2 pe = e == 0 ? a : b;
                double gx = 2.0 * q->A * pe.x + q->B * pe.y + q->D, gy = q->B * pe.x + 2.0 * q->C * pe.y + q->E;
                double gl = sqrt(gx * gx + gy * gy), sn = gl > 0.0 ? fabs(gx * d.x + gy * d.y) / (gl * clen) : 1.0;
                double cs = sqrt(fmax(0.0, 1.0 - sn * sn));
                double slope = cs > 0.0 ? sn / cs * clen / err : INFINITY;
                if (e == 0)
                    la = slope * 1.01;
                else
                    lb = slope * 1.01;
            }
        }
        band_init(&bd, la, lb);
    }
    /* breakpoints of the side statuses: where g = +-k w dg (none when g keeps a sign by more
     * than its band everywhere: the common case of x and y well off the surface) */
    double br[64];
    int nbr = 0;
    br[nbr++] = 0.0;
    if (err > 0.0) {
        for (int i = 0; i < 2; ++i)
            if (!clear_of_band(gq[i], dg[i], 2))
                nbr = band_roots(&bd, gq[i], dg[i], 2, 0.0, 1.0, br, nbr, 62);
    } else {
        for (int i = 0; i < 2; ++i) {
            double r[4];
            int k = spc_poly_roots(gq[i], 2, 0.0, 1.0, r, 4);
            for (int j = 0; j < k; ++j)
                if (r[j] > 0.0 && r[j] < 1.0)
                    br[nbr++] = r[j];
        }
    }
    br[nbr++] = 1.0;
    sort_doubles(br, nbr);
    int first = c->nsol; /* solutions from here on were found on this chord */
    int nslots = pb->event == SPC_CONIC_REFLECT ? 1 : 2;
    for (int slot = 0; slot < nslots; ++slot) {
        int want_x = slot == 0 ? 1 : -1; /* refraction: x in front (ex = 1) or behind (ex = eta) */
        double ex = pb->event == SPC_CONIC_REFLECT ? 1.0 : (slot == 0 ? 1.0 : pb->eta);
        double ey = pb->event == SPC_CONIC_REFLECT ? 1.0 : (slot == 0 ? pb->eta : 1.0);
        double fp[7], D[7];
        bool built = false;
        /* maximal runs of pieces where the sides may allow this assignment */
        for (int i = 0; i + 1 < nbr;) {
            double tm = 0.5 * (br[i] + br[i + 1]);
            if (!(br[i + 1] > br[i]) ||
                !sides_allow(pb, side_status(&bd, gq[0], dg[0], tm), side_status(&bd, gq[1], dg[1], tm), want_x, false)) {
                ++i;
                continue;
            }
            int j = i + 1;
            while (j + 1 < nbr) {
                double tn = 0.5 * (br[j] + br[j + 1]);
                if (br[j + 1] > br[j] &&
                    !sides_allow(pb, side_status(&bd, gq[0], dg[0], tn), side_status(&bd, gq[1], dg[1], tn), want_x, false))
                    break;
                ++j;
            }
            double t0 = br[i], t1 = br[j];
            i = j;
            if (!built) {
                spc_conic_chord_poly(t, pb->x, pb->y, ex, ey, a, b, fp);
                if (err > 0.0) {
                    spc_conic_chord_poly(t, pb->x, pb->y, ex, ey, ao, bo, D);
                    for (int q = 0; q <= 6; ++q)
                        D[q] -= fp[q];
                }
                built = true;
            }
            double roots[8];
            int k = spc_poly_roots(fp, 6, t0, t1, roots, 8);
            if (k < 0) {
                /* f vanishes along the whole chord: polish from a few of its points */
                for (int q = 0; q <= 4; ++q) {
                    double tt = t0 + (t1 - t0) * q / 4.0;
                    try_candidate(c, a.x + tt * d.x, a.y + tt * d.y, ex, ey, NULL, NULL);
                }
                continue;
            }
            double U[16][2];
            int nU = err > 0.0 && (k > 0 || !clear_of_band(fp, D, 6)) ? band_intervals(&bd, fp, D, t0, t1, U, 16) : 0;
            /* a chord whose f is too coarse to place the arc's roots (a wide band interval: f
             * varies much across the chord compared with along it, near a tangency of the conic
             * and the curve f = 0) is split before its roots are trusted */
            for (int q = 0; q < nU && splittable; ++q)
                if (U[q][1] - U[q][0] > SPC_CONIC_BAND_WIDTH)
                    return false;
            /* near misses: a chord that may lack a pair of the arc's roots is split */
            for (int q = 0; q < nU; ++q) {
                bool has_root = false;
                for (int r = 0; r < k; ++r)
                    has_root = has_root || (roots[r] >= U[q][0] && roots[r] <= U[q][1]);
                if (has_root || spc_poly_eval(fp, 6, U[q][0]) * spc_poly_eval(fp, 6, U[q][1]) <= 0.0)
                    continue;
                if (splittable)
                    return false;
                /* at the depth limit: a double root, polished directly */
                double tm2 = 0.5 * (U[q][0] + U[q][1]);
                try_candidate(c, a.x + tm2 * d.x, a.y + tm2 * d.y, ex, ey, NULL, NULL);
            }
            for (int r = 0; r < k; ++r) {
                spc_vec2 q = spc_v2(a.x + roots[r] * d.x, a.y + roots[r] * d.y);
                int sx = side_status(&bd, gq[0], dg[0], roots[r]), sy = side_status(&bd, gq[1], dg[1], roots[r]);
                if (!sides_allow(pb, sx, sy, want_x, false))
                    continue;
                if (spc_length(spc_conic_tri_normal(t, q.x, q.y)) <= 10.0 * c->nmin)
                    continue; /* f vanishes with the normal: no law to polish */
                /* the root's band interval, or a sliver around it */
                double lo = roots[r], hi = roots[r];
                for (int q2 = 0; q2 < nU; ++q2)
                    if (roots[r] >= U[q2][0] && roots[r] <= U[q2][1]) {
                        lo = U[q2][0];
                        hi = U[q2][1];
                    }
                double dl = fmax(1e-9, 1e-6 * (t1 - t0));
                double qlo = fmax(t0, fmin(lo, roots[r] - dl)), qhi = fmin(t1, fmax(hi, roots[r] + dl));
                /* near a zero of the interpolated normal its direction turns too fast for the
                 * classification below: every root is polished there, none trusted for splits */
                bool singular = spc_length(spc_conic_tri_normal(t, q.x, q.y)) < SPC_CONIC_FAST_NORMAL * c->nmean;
                int kind = singular ? 0
                                    : root_kind(c, ex, ey, spc_v2(a.x + qlo * d.x, a.y + qlo * d.y),
                                                spc_v2(a.x + qhi * d.x, a.y + qhi * d.y), nu, err);
                if (kind < 0)
                    continue; /* a root squaring made: nothing to polish */
                bool certain = kind > 0 && sides_allow(pb, sx, sy, want_x, true);
                spc_vec2 p;
                int which = -1;
                polish_result pr = try_candidate(c, q.x, q.y, ex, ey, &p, &which);
                /* a root at an end of the chord (a solution on an edge, or at a split point) has
                 * half its band interval cut off, so the parity of the arc's roots in it is
                 * unknown: another root of the arc may share it (seen: a conic tangent to an edge,
                 * turning sharply there, with a second solution 2e-4 from the first). The
                 * interval's other end is polished too. */
                if ((roots[r] <= 1e-9 || roots[r] >= 1.0 - 1e-9) && hi > lo) {
                    double tf = roots[r] <= 1e-9 ? hi : lo;
                    try_candidate(c, a.x + tf * d.x, a.y + tf * d.y, ex, ey, NULL, NULL);
                }
                if (!splittable || pr == POLISH_BUDGET)
                    continue;
                /* a true root, surely on admissible sides, that does not polish, or polishes onto a
                 * solution another root of this chord reached, was started too far from its own */
                if ((pr == POLISH_REJECTED && certain) || (pr == POLISH_KNOWN && which >= first))
                    return false;
                if (pr == POLISH_REJECTED) {
                    /* an undecided root (sides or kind unknown) whose polish wandered beyond its band
                     * interval left the basin of whatever the arc holds there: the chord is split
                     * while it is coarse (seen: two roots near the tangent plane of x, both
                     * polished out of the triangle, the solution between them lost) */
                    double reach = (hi - lo) * clen + 2.0 * err + 1e-9;
                    if (err > SPC_CONIC_WANDER_ERR && hypot(p.x - q.x, p.y - q.y) > reach)
                        return false;
                    continue;
                }
                /* the arc's root lies in the band interval of the chord's root: one polished
                 * outside it went to another root and may have left its own unvisited */
                double tp = ((p.x - a.x) * d.x + (p.y - a.y) * d.y) / (clen * clen);
                double off = fabs((p.x - a.x) * nu.x + (p.y - a.y) * nu.y); /* distance to the chord */
                double slack = SPC_CONIC_POLISH_SLACK;
                if (tp < lo - slack || tp > hi + slack || off > 1.5 * err + slack * clen)
                    return false;
            }
            /* roots the isolation may not report: (a) a root at an end of the chord (a solution on
             * an edge, where a conic tangent to the edge from inside meets it) sits at the interval's
             * end, where rounding may put f on either side; (b) double roots (y on a caustic, where
             * two solutions merge: the fold) need not show as roots of the chord's f: rounding turns
             * them into a complex pair or two roots a rounding apart, the chord's offset from the
             * arc may lift them off zero below the band's resolution, and a root that touches zero
             * without a sign change fails the classification above. Near a fold f is flat, so the
             * band intervals stay as wide relative to the chord at every depth and the chords there
             * are split down to rounding. So the run's ends where |f| is within rounding of zero
             * (the chord's ends are on the conic), and on deep chords (and at the depth limit) the
             * zeros of f' where |f| is within rounding or the band of zero, are polished too.
             * Elsewhere |f| is far from zero there, so this costs a polish only near such roots. */
            {
                double df[6], dr[10];
                int kd = 0;
                if (!splittable || err < SPC_CONIC_DEEP_CHORD) {
                    int nd = spc_poly_derivative(fp, 6, df);
                    kd = nd > 0 ? spc_poly_roots(df, nd, t0, t1, dr, 8) : 0;
                    if (kd < 0)
                        kd = 0;
                }
                int kderiv = kd;
                dr[kd++] = t0;
                dr[kd++] = t1;
                for (int q = 0; q < kd; ++q) {
                    double tt = dr[q];
                    double mag = snell_scale(t, pb, ex, ey, a.x + tt * d.x, a.y + tt * d.y);
                    double band_f = err > 0.0 && q < kderiv
                                        ? SPC_CONIC_BAND_MARGIN * band_w(&bd, tt) * fabs(spc_poly_eval(D, 6, tt))
                                        : 0.0;
                    if (!(fabs(spc_poly_eval(fp, 6, tt)) <= SPC_CONIC_DOUBLE_ROOT_TOL * mag + band_f))
                        continue;
                    /* f stays within the tolerance over a stretch around a fold, which many short
                     * chords cover: a start next to a solution found before is that fold, and the
                     * count is capped so that these never spend the candidates of true roots */
                    spc_vec2 st = spc_v2(a.x + tt * d.x, a.y + tt * d.y);
                    bool near_known = false;
                    for (int i = 0; i < c->nsol && !near_known; ++i)
                        near_known = hypot(c->sol[i].u - st.x, c->sol[i].v - st.y) <= SPC_CONIC_FOLD_REACH;
                    if (!near_known && c->nfold < SPC_CONIC_MAX_FOLD_CANDIDATES) {
                        c->nfold++;
                        try_candidate(c, st.x, st.y, ex, ey, NULL, NULL);
                    }
                }
            }
            if (err == 0.0) {
                /* an exact segment: only a multiple root of f itself can hide (rounding may turn a
                 * double root into a complex pair); the roots of its square-free part, where f has
                 * one, are polished too */
                double sf[7], sr[8];
                int ns = spc_poly_squarefree(fp, 6, SPC_CONIC_SQUAREFREE_TOL, sf);
                if (ns < spc_poly_degree(fp, 6)) {
                    int ks = spc_poly_roots(sf, ns, t0, t1, sr, 8);
                    for (int q = 0; q < ks; ++q)
                        try_candidate(c, a.x + sr[q] * d.x, a.y + sr[q] * d.y, ex, ey, NULL, NULL);
                }
            }
        }
    }
    return true;
}

static void solve_piece(tri_ctx *c, spc_conic_arc piece, int depth)
{
    if (piece.segment) {
        /* exact (err 0) unless a near-degenerate conic was replaced by lines: then both sides of
         * the segment may hold the conic, and it is halved when in doubt */
        bool can = piece.err > 1e-15 && depth < SPC_CONIC_MAX_SPLIT_DEPTH;
        spc_vec2 m = spc_v2(0.5 * (piece.a.x + piece.b.x), 0.5 * (piece.a.y + piece.b.y));
        spc_vec2 d = spc_v2(piece.b.x - piece.a.x, piece.b.y - piece.a.y);
        spc_vec2 s1 = spc_v2(m.x - d.y, m.y + d.x), s2 = spc_v2(m.x + d.y, m.y - d.x);
        int nsol0 = c->nsol;
        if (piece.err == 0.0 ? solve_chord(c, piece.a, piece.b, 0.0, s1, true, false)
                             : (solve_chord(c, piece.a, piece.b, piece.err, s1, true, can) &&
                                solve_chord(c, piece.a, piece.b, piece.err, s2, true, can)))
            return;
        c->nsol = nsol0; /* the halves solve it again */
        spc_conic_arc l = piece, r = piece;
        l.b = m;
        r.a = m;
        l.err = r.err = 0.25 * piece.err;
        solve_piece(c, l, depth + 1);
        solve_piece(c, r, depth + 1);
        return;
    }
    spc_vec2 s;
    double psi, dist;
    spc_conic_farthest(&c->arcs->curve, &piece, &s, &psi, &dist);
    bool can = depth < SPC_CONIC_MAX_SPLIT_DEPTH && dist > 1e-15;
    if (!can || dist <= SPC_CONIC_CHORD_TOL) {
        int nsol0 = c->nsol;
        if (solve_chord(c, piece.a, piece.b, dist, s, false, can))
            return;
        c->nsol = nsol0; /* the halves solve it again */
    }
    spc_conic_arc l = piece, r = piece;
    l.b = s;
    l.psi_b = psi;
    r.a = s;
    r.psi_a = psi;
    solve_piece(c, l, depth + 1);
    solve_piece(c, r, depth + 1);
}

int spc_conic_solve_triangle(const spc_conic_tri *t, const spc_conic_problem *pb, spc_conic_solution *out,
                             int max_out, spc_conic_stats *st)
{
    if (st)
        st->triangles++;
    spc_conic q = spc_conic_coplanarity(t, pb->x, pb->y);
    spc_conic_arcs arcs;
    spc_conic_find_arcs(&q, &arcs);
    tri_ctx c;
    c.t = t;
    c.pb = pb;
    c.arcs = &arcs;
    c.nmin = min_normal(t);
    c.nmean = c.nmin / SPC_CONIC_MIN_NORMAL;
    c.nsol = 0;
    c.ncand = 0;
    c.nrej = 0;
    c.nfold = 0;
    c.st = st;
    if (arcs.type == SPC_CONIC_PLANE) {
        /* every point is coplanar: n is constant and parallel to y - x (or x lies in the plane);
         * the only candidate is where the line xy crosses the plane (normal incidence) */
        spc_vec3 ng = spc_cross(t->e1, t->e2);
        spc_vec3 s = spc_sub(pb->y, pb->x);
        double den = spc_dot(ng, s);
        if (den != 0.0) {
            double tt = spc_dot(ng, spc_sub(t->p0, pb->x)) / den;
            spc_vec3 P = spc_madd(pb->x, s, tt);
            /* barycentrics of P */
            spc_vec3 w = spc_sub(P, t->p0);
            double g11 = spc_dot(t->e1, t->e1), g12 = spc_dot(t->e1, t->e2), g22 = spc_dot(t->e2, t->e2);
            double r1 = spc_dot(w, t->e1), r2 = spc_dot(w, t->e2), det = g11 * g22 - g12 * g12;
            if (det > 0.0)
                try_both(&c, spc_v2((g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det));
        }
        try_both(&c, spc_v2(1.0 / 3.0, 1.0 / 3.0));
    } else {
        for (int i = 0; i < arcs.narcs; ++i)
            solve_piece(&c, arcs.arc[i], 0);
        for (int i = 0; i < arcs.npoints; ++i)
            try_both(&c, arcs.point[i]);
    }
    if (st)
        st->solutions += c.nsol;
    int n = c.nsol < max_out ? c.nsol : max_out;
    memcpy(out, c.sol, (size_t)n * sizeof *out);
    return n;
}

/* ---- the mesh hierarchy ---- */

typedef struct cnode {
    float lo[3], hi[3];
    float axis[3];
    float cos_a, sin_a; /* half-angle of the normal cone, padded; cos_a < -1: every direction */
    int32_t index; /* leaf: first entry of order[]; inner: the right child (the left is this + 1) */
    int32_t count; /* leaf: number of triangles (> 0); inner: 0 */
} cnode;

struct spc_conic_mesh {
    void (*destroy)(void *self); /* first member: the destructor spc_shape_release calls */
    const spc_mesh *mesh;
    bool vertex_normals, flip;
    int ntris, nnodes;
    uint32_t *order;
    cnode *nodes;
};

int spc_conic_mesh_ntris(const spc_conic_mesh *m) { return m ? m->ntris : 0; }

static void tri_vertices(const spc_conic_mesh *m, int prim, spc_vec3 p[3])
{
    const uint32_t *idx = m->mesh->idx + 3 * (size_t)prim;
    for (int k = 0; k < 3; ++k)
        p[k] = spc_mesh_p(m->mesh, idx[k]);
}

spc_conic_tri spc_conic_mesh_triangle(const spc_conic_mesh *m, int prim)
{
    spc_vec3 p[3], n[3];
    tri_vertices(m, prim, p);
    const uint32_t *idx = m->mesh->idx + 3 * (size_t)prim;
    if (m->vertex_normals) {
        for (int k = 0; k < 3; ++k)
            n[k] = spc_mesh_n(m->mesh, idx[k]);
    } else {
        spc_vec3 g = spc_normalize(spc_cross(spc_sub(p[1], p[0]), spc_sub(p[2], p[0])));
        n[0] = n[1] = n[2] = g;
    }
    if (m->flip)
        for (int k = 0; k < 3; ++k)
            n[k] = spc_neg(n[k]);
    return spc_conic_tri_make(p[0], p[1], p[2], n[0], n[1], n[2]);
}

typedef struct cone {
    spc_vec3 axis;
    double angle; /* >= pi: every direction */
} cone;

static double angle_between(spc_vec3 a, spc_vec3 b)
{
    /* atan2 form: accurate for small and large angles alike */
    return atan2(spc_length(spc_cross(a, b)), spc_dot(a, b));
}

static cone tri_cone(const spc_conic_tri *t)
{
    spc_vec3 n[3] = {t->n0, spc_add(t->n0, t->dn1), spc_add(t->n0, t->dn2)};
    cone c = {spc_v3(0, 0, 1), SPC_PI};
    spc_vec3 s = spc_v3(0, 0, 0);
    for (int k = 0; k < 3; ++k) {
        double l = spc_length(n[k]);
        if (!(l > 0.0))
            return c;
        n[k] = spc_scale(n[k], 1.0 / l);
        s = spc_add(s, n[k]);
    }
    double ls = spc_length(s);
    if (!(ls > 1e-6))
        return c;
    spc_vec3 a = spc_scale(s, 1.0 / ls);
    double th = 0.0;
    for (int k = 0; k < 3; ++k)
        th = fmax(th, angle_between(a, n[k]));
    /* interpolated normals stay in the cone of the vertex normals only while it is convex */
    if (th >= 0.5 * SPC_PI - 1e-6)
        return c;
    c.axis = a;
    c.angle = th;
    return c;
}

static cone cone_union(cone a, cone b)
{
    cone full = {spc_v3(0, 0, 1), SPC_PI};
    if (a.angle >= SPC_PI || b.angle >= SPC_PI)
        return full;
    double phi = angle_between(a.axis, b.axis);
    if (phi + b.angle <= a.angle)
        return a;
    if (phi + a.angle <= b.angle)
        return b;
    double th = 0.5 * (a.angle + phi + b.angle);
    if (th >= SPC_PI || phi >= SPC_PI - 1e-9)
        return full;
    spc_vec3 w = spc_sub(b.axis, spc_scale(a.axis, spc_dot(a.axis, b.axis)));
    double lw = spc_length(w);
    if (!(lw > 0.0))
        return full;
    w = spc_scale(w, 1.0 / lw);
    double rot = th - a.angle;
    cone c;
    c.axis = spc_normalize(spc_add(spc_scale(a.axis, cos(rot)), spc_scale(w, sin(rot))));
    c.angle = th;
    return c;
}

static void tri_bounds(const spc_conic_mesh *m, int prim, spc_vec3 *lo, spc_vec3 *hi)
{
    spc_vec3 p[3];
    tri_vertices(m, prim, p);
    *lo = spc_vmin(p[0], spc_vmin(p[1], p[2]));
    *hi = spc_vmax(p[0], spc_vmax(p[1], p[2]));
}

typedef struct build_ctx {
    spc_conic_mesh *m;
    float *cent; /* centroids, 3 per triangle */
} build_ctx;

/* Partially sorts order[lo..hi) so that order[k] has the k-th centroid coordinate on axis
 * (quickselect, Hoare partition around the median of three). */
static void select_nth(build_ctx *b, int lo, int hi, int k, int axis)
{
    uint32_t *o = b->m->order;
    const float *c = b->cent;
    while (hi - lo > 2) {
        int mid = lo + (hi - lo) / 2;
        float x0 = c[3 * o[lo] + axis], x1 = c[3 * o[mid] + axis], x2 = c[3 * o[hi - 1] + axis];
        float piv = x0 < x1 ? (x1 < x2 ? x1 : (x0 < x2 ? x2 : x0)) : (x0 < x2 ? x0 : (x1 < x2 ? x2 : x1));
        int i = lo - 1, j = hi;
        for (;;) {
            do
                ++i;
            while (c[3 * o[i] + axis] < piv);
            do
                --j;
            while (c[3 * o[j] + axis] > piv);
            if (i >= j)
                break;
            uint32_t t = o[i];
            o[i] = o[j];
            o[j] = t;
        }
        /* [lo, j] <= piv <= [j+1, hi) */
        if (k <= j)
            hi = j + 1;
        else
            lo = j + 1;
    }
    if (hi - lo == 2 && c[3 * o[lo] + axis] > c[3 * o[lo + 1] + axis]) {
        uint32_t t = o[lo];
        o[lo] = o[lo + 1];
        o[lo + 1] = t;
    }
}

static int build_node(build_ctx *b, int lo, int hi)
{
    spc_conic_mesh *m = b->m;
    int id = m->nnodes++;
    cnode *nd = &m->nodes[id];
    spc_vec3 blo = spc_v3(INFINITY, INFINITY, INFINITY), bhi = spc_neg(blo);
    spc_vec3 clo = blo, chi = bhi;
    for (int i = lo; i < hi; ++i) {
        spc_vec3 a, z;
        tri_bounds(m, (int)m->order[i], &a, &z);
        blo = spc_vmin(blo, a);
        bhi = spc_vmax(bhi, z);
        const float *c = b->cent + 3 * m->order[i];
        spc_vec3 cc = spc_v3(c[0], c[1], c[2]);
        clo = spc_vmin(clo, cc);
        chi = spc_vmax(chi, cc);
    }
    nd->lo[0] = (float)blo.x;
    nd->lo[1] = (float)blo.y;
    nd->lo[2] = (float)blo.z;
    nd->hi[0] = (float)bhi.x;
    nd->hi[1] = (float)bhi.y;
    nd->hi[2] = (float)bhi.z;
    if (hi - lo <= SPC_CONIC_LEAF_SIZE) {
        nd->index = lo;
        nd->count = hi - lo;
        return id;
    }
    spc_vec3 ext = spc_sub(chi, clo);
    int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
    int mid = lo + (hi - lo) / 2;
    select_nth(b, lo, hi, mid, axis);
    build_node(b, lo, mid);
    int right = build_node(b, mid, hi);
    m->nodes[id].index = right;
    m->nodes[id].count = 0;
    return id;
}

static void store_cone(cnode *nd, cone c)
{
    nd->axis[0] = (float)c.axis.x;
    nd->axis[1] = (float)c.axis.y;
    nd->axis[2] = (float)c.axis.z;
    double a = c.angle + SPC_CONIC_CONE_PAD;
    if (c.angle >= SPC_PI || a >= SPC_PI) {
        nd->cos_a = -2.0f;
        nd->sin_a = 0.0f;
    } else {
        nd->cos_a = (float)cos(a);
        nd->sin_a = (float)sin(a);
    }
}

static cone load_cone(const cnode *nd)
{
    cone c;
    c.axis = spc_normalize(spc_v3(nd->axis[0], nd->axis[1], nd->axis[2]));
    c.angle = nd->cos_a < -1.5f ? SPC_PI : atan2(nd->sin_a, nd->cos_a);
    return c;
}

/* A cone for the culling tests: its half-angle by cosine and sine (no inverse trigonometry per
 * test); full: every direction. */
typedef struct qcone {
    spc_vec3 axis;
    double c, s;
    bool full;
} qcone;

static qcone node_qcone(const cnode *nd)
{
    /* the axis was unit before rounding to float: its length differs from 1 by ~1e-7, far inside
     * the cone's padding */
    qcone q;
    q.axis = spc_v3(nd->axis[0], nd->axis[1], nd->axis[2]);
    q.full = nd->cos_a < -1.5f;
    q.c = nd->cos_a;
    q.s = nd->sin_a;
    return q;
}

/* The cone of a triangle's shading normals: the axis of the mean unit vertex normal, the smallest
 * cosine to a vertex normal (interpolated normals stay inside while the cone is convex). */
static qcone tri_qcone(const spc_conic_tri *t)
{
    spc_vec3 n[3] = {t->n0, spc_add(t->n0, t->dn1), spc_add(t->n0, t->dn2)};
    qcone q = {spc_v3(0, 0, 1), -1.0, 0.0, true};
    spc_vec3 sum = spc_v3(0, 0, 0);
    for (int k = 0; k < 3; ++k) {
        double l = spc_length(n[k]);
        if (!(l > 0.0))
            return q;
        n[k] = spc_scale(n[k], 1.0 / l);
        sum = spc_add(sum, n[k]);
    }
    double ls = spc_length(sum);
    if (!(ls > 1e-6))
        return q;
    q.axis = spc_scale(sum, 1.0 / ls);
    double c = 1.0;
    for (int k = 0; k < 3; ++k)
        c = fmin(c, spc_dot(q.axis, n[k]));
    c -= 1e-9; /* rounding */
    if (!(c > 1e-6))
        return q;
    q.full = false;
    q.c = c;
    q.s = sqrt(fmax(0.0, 1.0 - c * c));
    return q;
}

static void mesh_destroy_void(void *p) { spc_conic_mesh_destroy(p); }

spc_conic_mesh *spc_conic_mesh_build(const spc_shape *s)
{
    if (!s || s->type != SPC_SHAPE_MESH || s->mesh.ntris == 0 || s->mesh.ntris > (size_t)INT32_MAX / 2)
        return NULL;
    spc_conic_mesh *m = calloc(1, sizeof *m);
    if (!m)
        return NULL;
    m->destroy = mesh_destroy_void;
    m->mesh = &s->mesh;
    m->vertex_normals = s->mesh.n && !s->face_normals;
    m->flip = s->flip_normals;
    m->ntris = (int)s->mesh.ntris;
    size_t cap = 2 * (size_t)m->ntris + 1;
    m->order = malloc((size_t)m->ntris * sizeof *m->order);
    m->nodes = malloc(cap * sizeof *m->nodes);
    float *cent = malloc(3 * (size_t)m->ntris * sizeof *cent);
    if (!m->order || !m->nodes || !cent) {
        free(cent);
        spc_conic_mesh_destroy(m);
        return NULL;
    }
    for (int i = 0; i < m->ntris; ++i) {
        spc_vec3 p[3];
        tri_vertices(m, i, p);
        spc_vec3 c = spc_scale(spc_add(p[0], spc_add(p[1], p[2])), 1.0 / 3.0);
        cent[3 * i] = (float)c.x;
        cent[3 * i + 1] = (float)c.y;
        cent[3 * i + 2] = (float)c.z;
        m->order[i] = (uint32_t)i;
    }
    build_ctx b = {m, cent};
    build_node(&b, 0, m->ntris);
    free(cent);
    /* cones bottom-up: children have larger indices than their parent */
    for (int i = m->nnodes - 1; i >= 0; --i) {
        cnode *nd = &m->nodes[i];
        cone c;
        if (nd->count > 0) {
            spc_conic_tri t = spc_conic_mesh_triangle(m, (int)m->order[nd->index]);
            c = tri_cone(&t);
            for (int k = 1; k < nd->count; ++k) {
                t = spc_conic_mesh_triangle(m, (int)m->order[nd->index + k]);
                c = cone_union(c, tri_cone(&t));
            }
        } else {
            c = cone_union(load_cone(&m->nodes[i + 1]), load_cone(&m->nodes[nd->index]));
        }
        store_cone(nd, c);
    }
    return m;
}

void spc_conic_mesh_destroy(spc_conic_mesh *m)
{
    if (!m)
        return;
    free(m->order);
    free(m->nodes);
    free(m);
}

const spc_conic_mesh *spc_conic_mesh_get(const spc_shape *s)
{
    if (!s || s->type != SPC_SHAPE_MESH)
        return NULL;
    /* the cache is logically part of the frozen shape: written once, atomically */
    void **slot = (void **)&((spc_shape *)s)->solver_cache;
    void *cur = __atomic_load_n(slot, __ATOMIC_ACQUIRE);
    if (cur)
        return cur;
    spc_conic_mesh *m = spc_conic_mesh_build(s);
    if (!m)
        return NULL;
    void *expected = NULL;
    if (__atomic_compare_exchange_n(slot, &expected, (void *)m, false, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE))
        return m;
    spc_conic_mesh_destroy(m); /* another thread won */
    return expected;
}

/* ---- culling (Walter et al. 2009, sec. 5) ---- */

typedef struct query {
    const spc_conic_problem *pb;
    bool refract;
    /* spindle: points P with (rho + sc)^2 + z^2 <= sR^2, rho, z cylindrical about the segment xy */
    bool spindle;
    spc_vec3 mid, axis;
    double sc, sR;
} query;

static void query_init(query *q, const spc_conic_problem *pb)
{
    memset(q, 0, sizeof *q);
    q->pb = pb;
    q->refract = pb->event == SPC_CONIC_REFRACT;
    if (q->refract) {
        double eta = pb->eta >= 1.0 ? pb->eta : 1.0 / pb->eta;
        double dmax = 0.5 * SPC_PI - asin(1.0 / eta); /* largest bending of a refraction */
        spc_vec3 s = spc_sub(pb->y, pb->x);
        double l = 0.5 * spc_length(s);
        if (l > 0.0 && dmax < 0.5 * SPC_PI - 1e-9) {
            double beta = SPC_PI - dmax; /* smallest angle x P y */
            q->spindle = true;
            q->mid = spc_scale(spc_add(pb->x, pb->y), 0.5);
            q->axis = spc_scale(s, 0.5 / l);
            q->sR = l / sin(beta);
            q->sc = -q->sR * cos(beta);
        }
    }
}

/* The cone of unit directions from the ball (c, r) toward X; false if X is inside the ball. */
static bool dir_cone(spc_vec3 X, spc_vec3 c, double r, qcone *o)
{
    spc_vec3 d = spc_sub(X, c);
    double l = spc_length(d);
    if (!(l > r))
        return false;
    o->axis = spc_scale(d, 1.0 / l);
    o->s = r / l;
    o->c = sqrt(fmax(0.0, 1.0 - o->s * o->s));
    o->full = false;
    return true;
}

/* Side of X relative to every normal of the cone: +1 surely in front, -1 surely behind, 0 unknown.
 * With phi the angle between the axes and sigma the sum of the half-angles: in front if
 * phi + sigma < pi/2, behind if phi - sigma > pi/2 (angle sums by cosines and sines). */
static int side(const qcone *dx, const qcone *nc)
{
    double cp = spc_dot(dx->axis, nc->axis), sp = spc_length(spc_cross(dx->axis, nc->axis));
    double cs = dx->c * nc->c - dx->s * nc->s, ss = dx->s * nc->c + dx->c * nc->s;
    if (ss < 0.0)
        return 0; /* sigma > pi */
    double c1 = cp * cs - sp * ss, s1 = sp * cs + cp * ss; /* phi + sigma */
    if (c1 > 0.0 && s1 >= 0.0)
        return 1;
    double c2 = cp * cs + sp * ss, s2 = sp * cs - cp * ss; /* phi - sigma */
    if (c2 < 0.0 && s2 > 0.0)
        return -1;
    return 0;
}

/* Which culling tests reject a ball (c, r) whose unit shading normals lie in the cone nc
 * (SPC_CONIC_CULL_* bits; 0: it may hold a solution). all: evaluate every test (the tests check
 * each one alone); otherwise return at the first that culls (the traversal). */
static unsigned cull_mask(const query *q, spc_vec3 c, double r, const qcone *nc, bool all)
{
    unsigned mask = 0;
    if (q->spindle) {
        spc_vec3 w = spc_sub(c, q->mid);
        double z = spc_dot(w, q->axis);
        double rho = spc_length(spc_sub(w, spc_scale(q->axis, z)));
        if (sqrt((rho + q->sc) * (rho + q->sc) + z * z) - r > q->sR) {
            mask |= SPC_CONIC_CULL_SPINDLE;
            if (!all)
                return mask;
        }
    }
    if (nc->full)
        return mask;
    qcone cx, cy;
    if (!dir_cone(q->pb->x, c, r, &cx) || !dir_cone(q->pb->y, c, r, &cy))
        return mask;
    int sx = side(&cx, nc), sy = side(&cy, nc);
    if ((sx && sy && (q->refract ? sx == sy : sx != sy)) || (!q->refract && q->pb->front_only && (sx < 0 || sy < 0))) {
        mask |= SPC_CONIC_CULL_SIDES;
        if (!all)
            return mask;
    }
    /* generalized half vector h = ex wx + ey wy, for the index assignments the sides allow */
    double as[2][2];
    int na = 0;
    if (!q->refract) {
        as[na][0] = as[na][1] = 1.0;
        ++na;
    } else {
        if (sx >= 0 && sy <= 0) { /* x in front: (1, eta) */
            as[na][0] = 1.0;
            as[na][1] = q->pb->eta;
            ++na;
        }
        if (sx <= 0 && sy >= 0) {
            as[na][0] = q->pb->eta;
            as[na][1] = 1.0;
            ++na;
        }
    }
    /* |w - axis| <= 2 sin(theta / 2) = sqrt(2 - 2 cos theta) over a cone of directions */
    double ex_ = sqrt(fmax(0.0, 2.0 - 2.0 * cx.c)), ey_ = sqrt(fmax(0.0, 2.0 - 2.0 * cy.c));
    for (int i = 0; i < na; ++i) {
        spc_vec3 h0 = spc_add(spc_scale(cx.axis, as[i][0]), spc_scale(cy.axis, as[i][1]));
        double lh = spc_length(h0), rho = as[i][0] * ex_ + as[i][1] * ey_;
        if (!(lh > rho))
            return mask;
        /* theta_h = asin(rho / lh); the line of h within theta_h + theta_n of the normal axis */
        double sh = rho / lh, ch = sqrt(fmax(0.0, 1.0 - sh * sh));
        double cpsi = ch * nc->c - sh * nc->s, spsi = sh * nc->c + ch * nc->s;
        if (cpsi <= 0.0 || spsi < 0.0)
            return mask; /* theta_h + theta_n >= pi/2: every line */
        if (fabs(spc_dot(h0, nc->axis)) / lh >= cpsi)
            return mask;
    }
    /* every half-vector cone missed (none to test: refraction with x and y surely on one side,
     * which the sides test has culled) */
    if (na > 0)
        mask |= SPC_CONIC_CULL_CONES;
    return mask;
}

/* Can a ball (c, r) whose shading normals lie in the cone nc hold a solution? */
static bool may_hold(const query *q, spc_vec3 c, double r, const qcone *nc) { return cull_mask(q, c, r, nc, false) == 0; }

unsigned spc_conic_cull_tests(const spc_conic_problem *pb, spc_vec3 c, double r, spc_vec3 axis, double angle)
{
    query q;
    query_init(&q, pb);
    qcone nc = {spc_normalize(axis), cos(angle), sin(angle), angle >= SPC_PI};
    return cull_mask(&q, c, r, &nc, true);
}

static bool node_may_hold(const query *q, const cnode *nd)
{
    spc_vec3 lo = spc_v3(nd->lo[0], nd->lo[1], nd->lo[2]), hi = spc_v3(nd->hi[0], nd->hi[1], nd->hi[2]);
    spc_vec3 c = spc_scale(spc_add(lo, hi), 0.5);
    double r = 0.5 * spc_length(spc_sub(hi, lo)) * (1.0 + 1e-9) + 1e-12 * spc_max_abs(c);
    qcone nc = node_qcone(nd);
    return may_hold(q, c, r, &nc);
}

static bool tri_may_hold(const query *q, const spc_conic_tri *t)
{
    spc_vec3 p1 = spc_add(t->p0, t->e1), p2 = spc_add(t->p0, t->e2);
    spc_vec3 lo = spc_vmin(t->p0, spc_vmin(p1, p2)), hi = spc_vmax(t->p0, spc_vmax(p1, p2));
    spc_vec3 c = spc_scale(spc_add(lo, hi), 0.5);
    double r = 0.5 * spc_length(spc_sub(hi, lo)) * (1.0 + 1e-9) + 1e-12 * spc_max_abs(c);
    qcone nc = tri_qcone(t);
    return may_hold(q, c, r, &nc);
}

typedef struct mesh_out {
    spc_conic_solution *out;
    int max_out, n;
} mesh_out;

static void add_mesh_solutions(const spc_conic_problem *pb, mesh_out *mo, const spc_conic_solution *s, int ns, int prim)
{
    for (int i = 0; i < ns; ++i) {
        spc_vec3 p = s[i].p;
        double tol = SPC_CONIC_SAME_REL * (spc_distance(p, pb->x) + spc_distance(p, pb->y));
        bool dup = false;
        for (int j = 0; j < mo->n && j < mo->max_out; ++j)
            if (spc_distance(mo->out[j].p, p) <= tol) {
                dup = true;
                break;
            }
        if (dup)
            continue;
        if (mo->n < mo->max_out) {
            mo->out[mo->n] = s[i];
            mo->out[mo->n].prim = prim;
        }
        mo->n++;
    }
}

int spc_conic_mesh_solve(const spc_conic_mesh *m, const spc_conic_problem *pb, spc_conic_solution *out, int max_out,
                         bool brute, spc_conic_stats *st)
{
    if (!m)
        return 0;
    mesh_out mo = {out, max_out, 0};
    spc_conic_solution ts[SPC_CONIC_MAX_TRI_SOLUTIONS];
    if (brute) {
        for (int i = 0; i < m->ntris; ++i) {
            spc_conic_tri t = spc_conic_mesh_triangle(m, i);
            int k = spc_conic_solve_triangle(&t, pb, ts, SPC_CONIC_MAX_TRI_SOLUTIONS, st);
            add_mesh_solutions(pb, &mo, ts, k, i);
        }
        return mo.n < max_out ? mo.n : max_out;
    }
    query q;
    query_init(&q, pb);
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        int id = stack[--top];
        const cnode *nd = &m->nodes[id];
        if (st)
            st->nodes++;
        if (!node_may_hold(&q, nd))
            continue;
        if (nd->count > 0) {
            for (int k = 0; k < nd->count; ++k) {
                int prim = (int)m->order[nd->index + k];
                spc_conic_tri t = spc_conic_mesh_triangle(m, prim);
                if (!tri_may_hold(&q, &t))
                    continue;
                int ns = spc_conic_solve_triangle(&t, pb, ts, SPC_CONIC_MAX_TRI_SOLUTIONS, st);
                add_mesh_solutions(pb, &mo, ts, ns, prim);
            }
            continue;
        }
        if (top + 2 > (int)(sizeof stack / sizeof stack[0]))
            continue; /* cannot happen for median splits (depth ~ log2 n) */
        stack[top++] = nd->index;
        stack[top++] = id + 1;
    }
    return mo.n < max_out ? mo.n : max_out;
}

/* ---- the distance correction factor by ray differentials (report sec. 7.1, appendix C) ---- */

double spc_conic_dcf(const spc_conic_tri *t, const spc_conic_problem *pb, const spc_conic_solution *s)
{
    spc_vec3 P = spc_conic_tri_point(t, s->u, s->v);
    spc_vec3 n = spc_conic_tri_normal(t, s->u, s->v);
    double ln = spc_length(n);
    spc_vec3 nh = spc_scale(n, 1.0 / ln);
    spc_vec3 ng = spc_normalize(spc_cross(t->e1, t->e2));
    spc_vec3 d0 = spc_sub(P, pb->x);
    double dV = spc_length(d0);
    spc_vec3 d = spc_scale(d0, 1.0 / dV); /* travel direction leaving x */
    spc_vec3 toy = spc_sub(pb->y, P);
    double dL = spc_length(toy);
    double dn_g = spc_dot(d, ng);
    if (!(fabs(dn_g) > 1e-12) || !(dL > 0.0))
        return 0.0;
    spc_frame fr = spc_frame_from_n(d);
    double g11 = spc_dot(t->e1, t->e1), g12 = spc_dot(t->e1, t->e2), g22 = spc_dot(t->e2, t->e2);
    double gdet = g11 * g22 - g12 * g12;
    /* the event at P, with the normal turned toward the incident side */
    double c = -spc_dot(d, nh), sgn_n = 1.0, r = 1.0;
    if (c < 0.0) {
        sgn_n = -1.0;
        c = -c;
    }
    spc_vec3 nn = spc_scale(nh, sgn_n);
    bool refl = pb->event == SPC_CONIC_REFLECT;
    if (!refl)
        r = sgn_n > 0.0 ? 1.0 / pb->eta : pb->eta; /* incident from the side nh points to: outside */
    double k = 1.0 - r * r * (1.0 - c * c);
    if (!refl && !(k > 0.0))
        return 0.0;
    double sk = refl ? 0.0 : sqrt(k);
    spc_vec3 dout = refl ? spc_add(d, spc_scale(nn, 2.0 * c)) : spc_add(spc_scale(d, r), spc_scale(nn, r * c - sk));
    spc_vec3 dLp[2];
    for (int j = 0; j < 2; ++j) {
        spc_vec3 dd = j == 0 ? fr.s : fr.t; /* unit perturbation of the direction at x */
        /* transfer x -> P: P moves in the triangle's plane */
        spc_vec3 dP = spc_scale(spc_sub(dd, spc_scale(d, spc_dot(dd, ng) / dn_g)), dV);
        /* barycentric derivatives, then the normal's */
        double r1 = spc_dot(dP, t->e1), r2 = spc_dot(dP, t->e2);
        double du = (g22 * r1 - g12 * r2) / gdet, dv = (g11 * r2 - g12 * r1) / gdet;
        spc_vec3 dnr = spc_add(spc_scale(t->dn1, du), spc_scale(t->dn2, dv));
        spc_vec3 dnh = spc_scale(spc_sub(dnr, spc_scale(nh, spc_dot(nh, dnr))), sgn_n / ln);
        /* scattering */
        double dc = -(spc_dot(dd, nn) + spc_dot(d, dnh));
        spc_vec3 ddout;
        if (refl) {
            ddout = spc_add(dd, spc_add(spc_scale(nn, 2.0 * dc), spc_scale(dnh, 2.0 * c)));
        } else {
            double dsk = r * r * c * dc / sk;
            ddout = spc_add(spc_add(spc_scale(dd, r), spc_scale(nn, r * dc - dsk)), spc_scale(dnh, r * c - sk));
        }
        /* transfer P -> y, projected on the plane perpendicular to the final direction */
        spc_vec3 w = spc_add(dP, spc_scale(ddout, dL));
        dLp[j] = spc_sub(w, spc_scale(dout, spc_dot(w, dout)));
    }
    return spc_length(spc_cross(dLp[0], dLp[1]));
}

/* ---- the specular NEE solver-table entry ---- */

/* Meshes whose normals are interpolated: a normal map is not (the angular estimate covers it). */
static bool conic_shape(const spc_shape *s)
{
    return s && s->type == SPC_SHAPE_MESH && !(s->bsdf && s->bsdf->type == SPC_BSDF_NORMALMAP);
}

bool spc_conic_covers(const spc_chain *c) { return c->n == 1 && conic_shape(c->v[0].h.shape); }

bool spc_conic_covers_all(const spc_snee_query *q)
{
    const spc_scene *sc = q->scene;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, q->any_surface);
    if (!cs)
        return false;
    for (int j = 0; j < cs->n; ++j) {
        const spc_shape *s = sc->shapes[cs->idx[j]];
        if (q->max_chain > 1 && (q->any_surface || spc_chain_caster_allowed(s->caustic_flags, 2)))
            return false; /* longer chains: the angular estimate */
        if (!conic_shape(s) && (q->any_surface || spc_chain_caster_allowed(s->caustic_flags, 1)))
            return false;
    }
    return true;
}

int spc_conic_solve_all(const spc_snee_query *q, spc_chain *out, int max_out, int *iterations)
{
    const spc_scene *sc = q->scene;
    int n = 0;
    spc_conic_solution sol[SPC_CONIC_MAX_MESH_SOLUTIONS];
    spc_conic_stats st;
    memset(&st, 0, sizeof st);
    const spc_chain_casters *cs = spc_chain_casters_of(sc, q->any_surface);
    for (int j = 0; cs && j < cs->n && n < max_out; ++j) {
        const spc_shape *s = sc->shapes[cs->idx[j]];
        int event;
        if (!conic_shape(s) || !spc_chain_shape_is_caster(s, q->any_surface, &event))
            continue;
        if (!q->any_surface && !spc_chain_caster_allowed(s->caustic_flags, 1))
            continue;
        double eta = 0.0;
        spc_bsdf_is_specular_interface(s->bsdf, &eta);
        const spc_conic_mesh *m = spc_conic_mesh_get(s);
        if (!m)
            continue;
        /* a dielectric's reflections too where chains may reflect off glass (params.reflect) */
        bool both = event == SPC_CHAIN_REFRACT && q->params && q->params->reflect;
        for (int pass = 0; pass < (both ? 2 : 1); ++pass) {
            if (pass == 1)
                event = SPC_CHAIN_REFLECT;
            spc_conic_problem pb;
            pb.x = q->x->p;
            pb.y = q->y;
            pb.event = event == SPC_CHAIN_REFRACT ? SPC_CONIC_REFRACT : SPC_CONIC_REFLECT;
            pb.eta = eta;
            pb.front_only = s->bsdf && s->bsdf->type == SPC_BSDF_CONDUCTOR; /* not a twosided one */
            int ns = spc_conic_mesh_solve(m, &pb, sol, SPC_CONIC_MAX_MESH_SOLUTIONS, false, &st);
            for (int k = 0; k < ns && n < max_out; ++k) {
                /* trace x -> P: the first hit must be this shape at P, which gives the chain its
                 * derivatives and proves the first segment unblocked */
                /* aimed from the offset origin the ray will leave from, so that it meets P itself */
                spc_vec3 dir = spc_sub(sol[k].p, pb.x);
                dir = spc_sub(sol[k].p, spc_hit_offset(q->x, dir));
                double dist = spc_length(dir);
                if (!(dist > 0.0))
                    continue;
                spc_frame fr = spc_frame_from_n(spc_scale(dir, 1.0 / dist));
                spc_chain_sig sig;
                memset(&sig, 0, sizeof sig);
                sig.n = 1;
                sig.shape[0] = cs->idx[j];
                sig.event[0] = (unsigned char)event;
                spc_chain_opts opts = spc_chain_opts_default(1);
                opts.fixed = &sig;
                opts.any_surface = q->any_surface;
                spc_chain *c = &out[n];
                if (spc_chain_trace(sc, q->x, &fr, 0.0, 0.0, &opts, c) != SPC_CHAIN_END_SURFACE || c->n != 1)
                    continue;
                const spc_chain_vertex *v = &c->v[0];
                if (spc_distance(v->h.p, sol[k].p) > 1e-6 * dist + 1e-6 * spc_distance(sol[k].p, pb.y))
                    continue; /* hit elsewhere first (the same mesh in front) */
                spc_vec3 toy = spc_normalize(spc_sub(pb.y, v->h.p));
                if (spc_length(spc_sub(v->d, toy)) > 1e-5)
                    continue; /* a normal discontinuity at an edge sent the ray elsewhere */
                ++n;
            }
        }
    }
    if (iterations)
        *iterations += (int)st.candidates;
    return n;
}
