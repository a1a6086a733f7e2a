/*
 * manifold/cylinder_chains.c: every chain of reflections on one mirror cylinder (cylinder_chains.h).
 *
 * The projected problem: the cross-section ellipse E(phi) = u cos(phi) + v sin(phi) (the local unit
 * circle mapped by the cylinder's transform, projected along its axis), with the point on the unit
 * circle (a, b) = (cos phi, sin phi) as its coordinates. The outward normal at (a, b) is
 * M^-T (a, b) normalized, M = [u v]; from P along d the chord ends at (a, b) + s (alpha, beta) with
 * (alpha, beta) = M^-1 d and s = -2 (a alpha + b beta) / (alpha^2 + beta^2) (the line through the
 * unit circle), which is positive only for a ray that goes inward. For k reflections: x -> E(phi)
 * (the first vertex, met from either side), reflect, k - 1 chords, reflecting at each end; then
 * f = d x (y - P_k) and ahead = d . (y - P_k). One pass computes every k up to the longest.
 */
#include "manifold/cylinder_chains.h"

#include <math.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "manifold/roots1d.h"
#include "manifold/solver.h"
#include "scene/scene.h"

/* Samples of the first vertex's angle over the whole ellipse (shared by every chain length). */
#define SPC_CYL_GRID 32
/* Roots kept per chain length. */
#define SPC_CYL_MAX_ROOTS 16

bool spc_cylinder_chain_shape(const spc_shape *s)
{
    if (!s || s->type != SPC_SHAPE_CYLINDER || s->emitter || !s->bsdf)
        return false;
    const spc_bsdf *b = s->bsdf;
    if (b->type == SPC_BSDF_TWOSIDED)
        return b->nested[0] && b->nested[0]->type == SPC_BSDF_CONDUCTOR &&
               (!b->nested[1] || b->nested[1]->type == SPC_BSDF_CONDUCTOR);
    return b->type == SPC_BSDF_CONDUCTOR;
}

bool spc_cylinder_chain_covers(const spc_chain *c)
{
    if (c->n < 1 || !spc_cylinder_chain_shape(c->v[0].h.shape))
        return false;
    for (int i = 0; i < c->n; ++i)
        if (c->v[i].h.shape != c->v[0].h.shape || c->v[i].event != SPC_CHAIN_REFLECT)
            return false;
    return true;
}

/* ---- the projected problem ---- */

typedef struct cyl_problem {
    double u[2], v[2], x[2], y[2];
    double det, mi[2][2]; /* det M and M^-1, M = [u v] */
    int k;                /* the chain length the single-k evaluation computes */
    /* heights along the axis (has_axial): of x (offset) and y; the local x and y axes' axial
     * components (a sheared cylinder); the axis' length (local z from 0 to 1) */
    bool has_axial;
    double hx, hy, Ua, Va, alen;
} cyl_problem;

static void problem_init(cyl_problem *pb)
{
    pb->det = pb->u[0] * pb->v[1] - pb->u[1] * pb->v[0];
    pb->mi[0][0] = pb->v[1] / pb->det;
    pb->mi[0][1] = -pb->v[0] / pb->det;
    pb->mi[1][0] = -pb->u[1] / pb->det;
    pb->mi[1][1] = pb->u[0] / pb->det;
}

/* The local z of the wall point at unit-circle coordinates (a, b) and axial height h. */
static double wall_z(const cyl_problem *pb, double a, double b, double h)
{
    return (h - pb->Ua * a - pb->Va * b) / pb->alen;
}

static void normal_at(const cyl_problem *pb, double a, double b, double *nx, double *ny)
{
    /* M^-T (a, b) */
    double x = pb->mi[0][0] * a + pb->mi[1][0] * b, y = pb->mi[0][1] * a + pb->mi[1][1] * b;
    double l = sqrt(x * x + y * y);
    *nx = x / l;
    *ny = y / l;
}

/* The chains of 1..kmax reflections whose first vertex is at unit-circle coordinates (a, b):
 * f[k - 1], ahead[k - 1], ok[k - 1]; z1 (if not NULL, with has_axial): the first vertex's local z
 * for each k; len (if not NULL): the projected length from x to vertex j (len[j]) and, in *total,
 * to y past vertex kmax. */
static void cyl_eval_at(const cyl_problem *pb, int kmax, double a, double b, double *f, double *ahead, bool *ok,
                        double *z1, double *len, double *total, double *ang)
{
    for (int k = 0; k < kmax; ++k)
        ok[k] = false;
    double a1 = a, b1 = b;
    double px = pb->u[0] * a + pb->v[0] * b, py = pb->u[1] * a + pb->v[1] * b;
    double dx = px - pb->x[0], dy = py - pb->x[1];
    double L = sqrt(dx * dx + dy * dy), L1 = L;
    if (!(L > 1e-12 * (fabs(px) + fabs(py) + 1e-300)))
        return; /* x on the wall */
    dx /= L;
    dy /= L;
    if (ang)
        ang[0] = spc_roots1d_turns(dx, dy);
    for (int j = 0; j < kmax; ++j) {
        if (len)
            len[j] = L;
        double nx, ny;
        normal_at(pb, a, b, &nx, &ny);
        double dn = dx * nx + dy * ny;
        dx -= 2.0 * dn * nx;
        dy -= 2.0 * dn * ny;
        if (ang)
            ang[j + 1] = spc_roots1d_turns(dx, dy);
        double rx = pb->y[0] - px, ry = pb->y[1] - py;
        f[j] = dx * ry - dy * rx;
        ahead[j] = dx * rx + dy * ry;
        ok[j] = true;
        double tot = L + sqrt(rx * rx + ry * ry);
        if (z1 && pb->has_axial)
            z1[j] = wall_z(pb, a1, b1, pb->hx + (pb->hy - pb->hx) * L1 / tot);
        if (total && j == kmax - 1)
            *total = tot;
        if (j == kmax - 1)
            break;
        /* the chord: (alpha, beta) = M^-1 d */
        double al = pb->mi[0][0] * dx + pb->mi[0][1] * dy, be = pb->mi[1][0] * dx + pb->mi[1][1] * dy;
        double s = -2.0 * (a * al + b * be) / (al * al + be * be);
        if (!(s > 1e-9))
            return; /* leaving the ellipse (a reflection off the outside): no further vertex */
        a += s * al;
        b += s * be;
        double r = sqrt(a * a + b * b);
        a /= r;
        b /= r;
        px = pb->u[0] * a + pb->v[0] * b;
        py = pb->u[1] * a + pb->v[1] * b;
        L += s;
    }
}

static bool cyl_fn(const void *ctx, double phi, double *f, double *ahead, double *ang)
{
    const cyl_problem *pb = ctx;
    double fs[SPC_CHAIN_MAX_VERTICES], as[SPC_CHAIN_MAX_VERTICES];
    bool ok[SPC_CHAIN_MAX_VERTICES];
    cyl_eval_at(pb, pb->k, cos(phi), sin(phi), fs, as, ok, NULL, NULL, NULL, ang);
    *f = fs[pb->k - 1];
    *ahead = as[pb->k - 1];
    return ok[pb->k - 1];
}

/* The first vertex's local z at the chain of pb->k reflections through phi is on the wall (to 1e-3:
 * the root is known to about 1e-6; chain_fits decides exactly). */
static bool cyl_accept(const void *ctx, double phi)
{
    const cyl_problem *pb = ctx;
    double f[SPC_CHAIN_MAX_VERTICES], ah[SPC_CHAIN_MAX_VERTICES], z[SPC_CHAIN_MAX_VERTICES];
    bool ok[SPC_CHAIN_MAX_VERTICES];
    cyl_eval_at(pb, pb->k, cos(phi), sin(phi), f, ah, ok, z, NULL, NULL, NULL);
    return ok[pb->k - 1] && z[pb->k - 1] >= -1e-3 && z[pb->k - 1] <= 1.0 + 1e-3;
}

/* Roots for k = kmin..kmax (none below kmin): phi[k - 1][...], n[k - 1]. With has_axial, grid
 * cells where the first vertex's height stays off the wall are not searched (their roots are not
 * chains): both ends off on one side by more than z's possible bulge between them (z is smooth in
 * phi; the neighbouring second differences bound it, with a factor 4 to spare). */
static void cyl_roots(cyl_problem *pb, int kmin, int kmax, double phi[][SPC_CYL_MAX_ROOTS], int *n)
{
    enum { G = SPC_CYL_GRID };
    double t[G + 1], f[G + 1][SPC_CHAIN_MAX_VERTICES], ah[G + 1][SPC_CHAIN_MAX_VERTICES],
        z[G + 1][SPC_CHAIN_MAX_VERTICES];
    double ang[G + 1][SPC_ROOTS1D_MAX_ANGLES]; /* the segments' directions: shared by every k */
    bool ok[G + 1][SPC_CHAIN_MAX_VERTICES];
    /* the samples by rotation from (1, 0) (cos and sin once) */
    double cs = cos(2.0 * SPC_PI / G), sn = sin(2.0 * SPC_PI / G), a = 1.0, b = 0.0;
    for (int j = 0; j <= G; ++j) {
        t[j] = 2.0 * SPC_PI * j / G;
        cyl_eval_at(pb, kmax, a, b, f[j], ah[j], ok[j], z[j], NULL, NULL, ang[j]);
        double na = a * cs - b * sn, nb = a * sn + b * cs;
        a = na;
        b = nb;
    }
    for (int k = 1; k < kmin && k <= kmax; ++k)
        n[k - 1] = 0;
    for (int k = kmin > 1 ? kmin : 1; k <= kmax; ++k) {
        double fk[G + 1], ak[G + 1];
        bool okk[G + 1], skip[G];
        for (int j = 0; j <= G; ++j) {
            fk[j] = f[j][k - 1];
            ak[j] = ah[j][k - 1];
            okk[j] = ok[j][k - 1];
        }
        for (int j = 0; j < G && pb->has_axial; ++j) {
            skip[j] = false;
            if (!okk[j] || !okk[j + 1])
                continue;
            double z0 = z[j][k - 1], z1 = z[j + 1][k - 1];
            /* z leaves the chord between the cell's ends by at most |z''| dt^2 / 8; the second
             * differences of the neighbouring samples estimate |z''| dt^2, taken four times over */
            double bulge = 0.0;
            if (j > 0 && okk[j - 1])
                bulge += fabs(z[j - 1][k - 1] - 2.0 * z0 + z1);
            if (j + 2 <= G && okk[j + 2])
                bulge += fabs(z0 - 2.0 * z1 + z[j + 2][k - 1]);
            double margin = 0.5 * bulge + 1e-6;
            skip[j] = (z0 > 1.0 + margin && z1 > 1.0 + margin) || (z0 < -margin && z1 < -margin);
        }
        pb->k = k;
        double r[SPC_CYL_MAX_ROOTS];
        int nr = spc_roots1d(cyl_fn, pb->has_axial ? cyl_accept : NULL, pb, t, fk, ak, &ang[0][0], k + 1, okk, G,
                             pb->has_axial ? skip : NULL, 1e-12, r, SPC_CYL_MAX_ROOTS);
        /* the period: a root at 0 and at 2 pi is one */
        int m = 0;
        for (int i = 0; i < nr; ++i) {
            double p = r[i] >= 2.0 * SPC_PI ? r[i] - 2.0 * SPC_PI : r[i];
            bool dup = false;
            for (int j = 0; j < m && !dup; ++j)
                dup = fabs(phi[k - 1][j] - p) < 1e-10 || fabs(fabs(phi[k - 1][j] - p) - 2.0 * SPC_PI) < 1e-10;
            if (!dup)
                phi[k - 1][m++] = p;
        }
        n[k - 1] = m;
    }
}

int spc_cylinder_chain_roots(const double u[2], const double v[2], const double x2[2], const double y2[2], int k,
                             double *phi, double *len, double *total, int max_roots)
{
    if (k < 1 || k > SPC_CHAIN_MAX_VERTICES)
        return 0;
    cyl_problem pb;
    memset(&pb, 0, sizeof pb);
    memcpy(pb.u, u, sizeof pb.u);
    memcpy(pb.v, v, sizeof pb.v);
    memcpy(pb.x, x2, sizeof pb.x);
    memcpy(pb.y, y2, sizeof pb.y);
    if (!(fabs(u[0] * v[1] - u[1] * v[0]) > 1e-300))
        return 0;
    problem_init(&pb);
    double roots[SPC_CHAIN_MAX_VERTICES][SPC_CYL_MAX_ROOTS];
    int n[SPC_CHAIN_MAX_VERTICES];
    cyl_roots(&pb, 1, k, roots, n);
    int m = n[k - 1] < max_roots ? n[k - 1] : max_roots;
    for (int i = 0; i < m; ++i) {
        phi[i] = roots[k - 1][i];
        double f[SPC_CHAIN_MAX_VERTICES], ah[SPC_CHAIN_MAX_VERTICES];
        bool ok[SPC_CHAIN_MAX_VERTICES];
        cyl_eval_at(&pb, k, cos(phi[i]), sin(phi[i]), f, ah, ok, NULL, len + (size_t)i * k, total + i, NULL);
    }
    return m;
}

/* ---- in the scene ---- */

static bool on_wall(double z) { return z >= -1e-9 && z <= 1.0 + 1e-9; }

/* Does the projected segment from p (2D) along unit d over (0, L) cross the wall at a height that
 * lies on it (h0 + slope t at distance t)? Its ends are excluded (the chain's vertices). */
static bool segment_blocked(const cyl_problem *pb, const double p[2], const double d[2], double L, double h0,
                            double slope)
{
    /* unit-circle coordinates: X = M^-1 p, D = M^-1 d; |X + t D| = 1 */
    double X0 = pb->mi[0][0] * p[0] + pb->mi[0][1] * p[1], X1 = pb->mi[1][0] * p[0] + pb->mi[1][1] * p[1];
    double D0 = pb->mi[0][0] * d[0] + pb->mi[0][1] * d[1], D1 = pb->mi[1][0] * d[0] + pb->mi[1][1] * d[1];
    double A = D0 * D0 + D1 * D1, B = X0 * D0 + X1 * D1, Cc = X0 * X0 + X1 * X1 - 1.0;
    double disc = B * B - A * Cc;
    if (!(disc > 0.0) || !(A > 0.0))
        return false;
    double sq = sqrt(disc);
    double ts[2] = {(-B - sq) / A, (-B + sq) / A};
    double eps = 1e-7 * (L + 1.0);
    for (int i = 0; i < 2; ++i) {
        double t = ts[i];
        if (!(t > eps && t < L - eps))
            continue;
        if (on_wall(wall_z(pb, X0 + t * D0, X1 + t * D1, h0 + slope * t)))
            return true;
    }
    return false;
}

/* The chain of k reflections whose first vertex is at angle phi, in the projection and in height:
 * every vertex on the wall, the first and last segments not through it; false otherwise. Writes
 * the first vertex's unit-circle coordinates and local z. */
static bool chain_fits(const cyl_problem *pb, int k, double phi, double *a1, double *b1, double *z1)
{
    double f[SPC_CHAIN_MAX_VERTICES], ahd[SPC_CHAIN_MAX_VERTICES], len[SPC_CHAIN_MAX_VERTICES], total = 0.0;
    bool ok[SPC_CHAIN_MAX_VERTICES];
    cyl_eval_at(pb, k, cos(phi), sin(phi), f, ahd, ok, NULL, len, &total, NULL);
    if (!ok[k - 1] || !(total > 0.0))
        return false;
    double slope = (pb->hy - pb->hx) / total;
    /* walk the chain again for the vertices' coordinates */
    double a = cos(phi), b = sin(phi), px = 0.0, py = 0.0, dx = 0.0, dy = 0.0;
    for (int j = 0; j < k; ++j) {
        px = pb->u[0] * a + pb->v[0] * b;
        py = pb->u[1] * a + pb->v[1] * b;
        if (j == 0) {
            dx = px - pb->x[0];
            dy = py - pb->x[1];
            double l = sqrt(dx * dx + dy * dy);
            dx /= l;
            dy /= l;
            double p0[2] = {pb->x[0], pb->x[1]}, d0[2] = {dx, dy};
            if (segment_blocked(pb, p0, d0, len[0], pb->hx, slope))
                return false;
            *a1 = a;
            *b1 = b;
            *z1 = wall_z(pb, a, b, pb->hx + slope * len[0]);
        }
        if (!on_wall(wall_z(pb, a, b, pb->hx + slope * len[j])))
            return false;
        double nx, ny;
        normal_at(pb, a, b, &nx, &ny);
        double dn = dx * nx + dy * ny;
        dx -= 2.0 * dn * nx;
        dy -= 2.0 * dn * ny;
        if (j < k - 1) {
            double al = pb->mi[0][0] * dx + pb->mi[0][1] * dy, be = pb->mi[1][0] * dx + pb->mi[1][1] * dy;
            double s = -2.0 * (a * al + b * be) / (al * al + be * be);
            a += s * al;
            b += s * be;
            double r = sqrt(a * a + b * b);
            a /= r;
            b /= r;
        }
    }
    double p[2] = {px, py}, d[2] = {dx, dy};
    return !segment_blocked(pb, p, d, total - len[k - 1], pb->hx + slope * len[k - 1], slope);
}

int spc_cylinder_chains_all(const spc_snee_query *q, spc_chain *out, int max_out, int *iterations)
{
    const spc_scene *sc = q->scene;
    int n = 0;
    int kmax = q->max_chain < SPC_CHAIN_MAX_VERTICES ? q->max_chain : SPC_CHAIN_MAX_VERTICES;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, q->any_surface);
    for (int j = 0; cs && j < cs->n && n < max_out && kmax >= 1; ++j) {
        const spc_shape *s = sc->shapes[cs->idx[j]];
        if (!spc_cylinder_chain_shape(s))
            continue;
        const spc_mat4 *M = &s->to_world;
        spc_vec3 U = spc_mat4_apply_vector(M, spc_v3(1, 0, 0)), V = spc_mat4_apply_vector(M, spc_v3(0, 1, 0));
        spc_vec3 A = spc_mat4_apply_vector(M, spc_v3(0, 0, 1)), C = spc_mat4_apply_point(M, spc_v3(0, 0, 0));
        double alen = spc_length(A);
        if (!(alen > 0.0))
            continue;
        spc_vec3 ah = spc_scale(A, 1.0 / alen);
        spc_frame fr = spc_frame_from_n(ah);
        /* the point the first ray leaves from (x offset off its surface, as spc_chain_trace spawns it)
         * toward the axis */
        spc_vec3 xo = spc_hit_offset(q->x, spc_sub(spc_add(C, spc_scale(A, 0.5)), q->x->p));
        spc_vec3 xr = spc_sub(xo, C), yr = spc_sub(q->y, C);
        cyl_problem cp;
        memset(&cp, 0, sizeof cp);
        cyl_problem *pb = &cp;
        pb->u[0] = spc_dot(U, fr.s);
        pb->u[1] = spc_dot(U, fr.t);
        pb->v[0] = spc_dot(V, fr.s);
        pb->v[1] = spc_dot(V, fr.t);
        pb->x[0] = spc_dot(xr, fr.s);
        pb->x[1] = spc_dot(xr, fr.t);
        pb->y[0] = spc_dot(yr, fr.s);
        pb->y[1] = spc_dot(yr, fr.t);
        double det = pb->u[0] * pb->v[1] - pb->u[1] * pb->v[0];
        double scale = fabs(pb->u[0]) + fabs(pb->u[1]) + fabs(pb->v[0]) + fabs(pb->v[1]);
        if (!(fabs(det) > 1e-12 * scale * scale))
            continue; /* a degenerate cross-section */
        problem_init(pb);
        int kk = kmax;
        pb->has_axial = true;
        pb->hx = spc_dot(xr, ah);
        pb->hy = spc_dot(yr, ah);
        pb->Ua = spc_dot(U, ah);
        pb->Va = spc_dot(V, ah);
        pb->alen = alen;
        double roots[SPC_CHAIN_MAX_VERTICES][SPC_CYL_MAX_ROOTS];
        int nroots[SPC_CHAIN_MAX_VERTICES];
        cyl_roots(pb, q->min_chain, kk, roots, nroots);
        for (int k = q->min_chain > 1 ? q->min_chain : 1; k <= kk && n < max_out; ++k) {
            if (!q->any_surface && !spc_chain_caster_allowed(s->caustic_flags, k))
                continue;
            unsigned char ev[SPC_CHAIN_MAX_VERTICES];
            for (int j = 0; j < k; ++j)
                ev[j] = SPC_CHAIN_REFLECT;
            for (int r = 0; r < nroots[k - 1] && n < max_out; ++r) {
                double a, b, z;
                if (!chain_fits(pb, k, roots[k - 1][r], &a, &b, &z))
                    continue;
                spc_vec3 P = spc_add(spc_add(C, spc_scale(U, a)), spc_add(spc_scale(V, b), spc_scale(A, z)));
                spc_vec3 dir = spc_normalize(spc_sub(P, xo));
                if (spc_snee_exact_polish(q, s, k, ev, dir, out, n, iterations))
                    ++n;
            }
        }
    }
    return n;
}
