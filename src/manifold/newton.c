/*
 * manifold/newton.c: manifold next-event estimation by Newton's method on the vertices of a
 * specular chain (contract in newton.h).
 *
 * Hanika, Droske and Kettunen 2015, "Manifold Next Event Estimation": seed by the straight segment
 * from x to the light point (sec. 4), Newton steps on the half-vector constraints with the moved
 * vertices projected back onto the surfaces by ray tracing and a step size that shrinks when that
 * fails (sec. 3.2, their algorithm 1), the block-tridiagonal constraint Jacobian (sec. 3.1, after
 * Jakob and Marschner 2012, sec. 4.1-4.2, eq. 6-8 for the generalized half vector and its
 * tangent-plane projection). Zeltner, Georgiev and Jakob 2020, "Specular Manifold Sampling": seeds
 * traced from a random point of a caster (sec. 4.1), angle-difference constraints (sec. 5), offset
 * microfacet normals for rough interfaces (sec. 4.3). The generalized geometry term from the
 * constraint Jacobian is Jakob and Marschner's (sec. 4.3): the derivative of the first vertex with
 * respect to the last by the implicit function theorem, here with the light point as the moving end.
 *
 * Derivatives are carried in forward mode (a value and 6 partials: the tangent coordinates of the
 * previous, own and next vertex), so the constraint blocks are exact for both constraint kinds,
 * offset normals included: each vertex's local frame is built from its normal and a reference
 * vector that does not move with it, so the frame's derivative follows from the normal's alone.
 */
#include "manifold/newton.h"

#include <string.h>

#include "bsdf/microfacet.h"
#include "manifold/angular.h"
#include "manifold/solver.h"

/* Projections per solve. Inside the basin Newton converges quadratically (3 to 6 steps from a
 * reasonable seed); the rest is room for the halved steps of a far seed. Measured on random chains of
 * 1-3 interfaces (bench/bench_newton.c): raising it from 24 to 64 adds under 1% of solutions. */
#define SPC_NEWTON_MAX_ITERATIONS 32
/* 1e-8 of the scene's size: 10x below the angular solver's residual tolerance, which the final
 * chain must meet (spc_newton_solve_one), so the polishing trace converges at once. */
#define SPC_NEWTON_TOL_SCENE 1e-8
/* Gauss-Newton traces allowed after Newton has converged: the first trace of the solution usually
 * meets the tolerance already; one more absorbs the ray offsets of float meshes (~1e-6). */
#define SPC_NEWTON_POLISH_ITERATIONS 4
/* Largest move of a vertex in one step, relative to its distance from the previous vertex (about
 * 27 degrees of turn, the angular solver's SPC_ANGULAR_MAX_STEP): Newton steps from far seeds can be
 * huge where the constraint Jacobian is nearly singular (silhouettes, caustics). */
#define SPC_NEWTON_MAX_TURN 0.5
/* beta below this means no step along the Newton direction lowers the constraints: 4 halvings.
 * More do not help: at 1/1024 no more seeds converged on bench_newton's chains (the stalls are
 * far seeds whose Newton direction does not lower the constraints at all), only iterations grew. */
#define SPC_NEWTON_MIN_BETA (1.0 / 16.0)
/* A 2x2 pivot block whose determinant is below this fraction of its squared largest entry is
 * singular (a chain at a caustic of the light, where the vertex is not a function of y). */
#define SPC_NEWTON_SINGULAR 1e-14
/* Below this squared tangential length the azimuthal-equidistant map uses its Taylor series
 * (theta / sin theta = 1 + theta^2 / 6 + ...): exact to double precision there. */
#define SPC_NEWTON_LOGMAP_SERIES 1e-8
/* Gram determinant of (dpdu, dpdv) below this fraction of |dpdu|^2 |dpdv|^2: the surface
 * parameterization is degenerate (a sphere's pole), the normal's derivative unknown. */
#define SPC_NEWTON_GRAM_EPS 1e-20
/* On no progress, continue once with the other constraint kind: far from the solution the two
 * Newton directions differ, and where one stalls the other often goes on. Measured on bench_newton's
 * chains (400 per row, bench/RESULTS.md): angle differences from seeds in sequence, one interface
 * 86-91% -> 87-91%, two 69-80% -> 78-85%, three 68-81% -> 78-86%; straight-line seeds on three
 * interfaces 71-77% -> 82-89%; half vectors from shape seeds on one interface 44-53% -> 58-63%.
 * Never fewer solutions; 1-2 more projections on the seeds that stall. */
#define SPC_NEWTON_SWITCH_KIND true

/* The default constraint: angle differences converge from twice as many shape seeds on single
 * interfaces (70-75% against 33-38% for half vectors), a few percent fewer on two (bench/RESULTS.md). */
#define SPC_NEWTON_DEFAULT_CONSTRAINT SPC_NEWTON_ANGLE_DIFF

void spc_newton_options_default(spc_newton_options *o)
{
    o->constraint = SPC_NEWTON_DEFAULT_CONSTRAINT;
    o->max_iterations = SPC_NEWTON_MAX_ITERATIONS;
    o->tol_scene = SPC_NEWTON_TOL_SCENE;
    o->polish_iterations = SPC_NEWTON_POLISH_ITERATIONS;
    o->min_beta = SPC_NEWTON_MIN_BETA;
    o->switch_kind = SPC_NEWTON_SWITCH_KIND;
    o->rough = false;
    o->trace = NULL;
    o->trace_user = NULL;
}

/* ---- forward-mode derivatives ---- */

#define ND 6 /* partials: previous vertex (0, 1), this vertex (2, 3), next vertex (4, 5) */

/* The dual helpers take and return 56- and 168-byte structs by value; inlined, the compiler keeps
 * them in registers (the constraints are 5x faster than with calls, which gcc -O2 keeps). */
#if defined(__GNUC__)
#define DUAL_FN static inline __attribute__((always_inline))
#else
#define DUAL_FN static inline
#endif

typedef struct dnum {
    double v, d[ND];
} dnum;

typedef struct dvec {
    dnum x, y, z;
} dvec;

DUAL_FN dnum dn_const(double v)
{
    dnum r;
    r.v = v;
    for (int i = 0; i < ND; ++i)
        r.d[i] = 0.0;
    return r;
}

DUAL_FN dnum dn_add(dnum a, dnum b)
{
    a.v += b.v;
    for (int i = 0; i < ND; ++i)
        a.d[i] += b.d[i];
    return a;
}

DUAL_FN dnum dn_sub(dnum a, dnum b)
{
    a.v -= b.v;
    for (int i = 0; i < ND; ++i)
        a.d[i] -= b.d[i];
    return a;
}

DUAL_FN dnum dn_mul(dnum a, dnum b)
{
    dnum r;
    r.v = a.v * b.v;
    for (int i = 0; i < ND; ++i)
        r.d[i] = a.d[i] * b.v + a.v * b.d[i];
    return r;
}

DUAL_FN dnum dn_scale(dnum a, double s)
{
    a.v *= s;
    for (int i = 0; i < ND; ++i)
        a.d[i] *= s;
    return a;
}

/* f(a) given f and f' at a.v */
DUAL_FN dnum dn_chain(dnum a, double f, double df)
{
    dnum r;
    r.v = f;
    for (int i = 0; i < ND; ++i)
        r.d[i] = df * a.d[i];
    return r;
}

DUAL_FN dnum dn_sqrt(dnum a)
{
    double s = sqrt(a.v);
    return dn_chain(a, s, 0.5 / s);
}

DUAL_FN dvec dv_const(spc_vec3 v)
{
    dvec r = {dn_const(v.x), dn_const(v.y), dn_const(v.z)};
    return r;
}

/* v with partials d0, d1 in slots (slot, slot + 1) */
DUAL_FN dvec dv_var(spc_vec3 v, int slot, spc_vec3 d0, spc_vec3 d1)
{
    dvec r = dv_const(v);
    r.x.d[slot] = d0.x;
    r.y.d[slot] = d0.y;
    r.z.d[slot] = d0.z;
    r.x.d[slot + 1] = d1.x;
    r.y.d[slot + 1] = d1.y;
    r.z.d[slot + 1] = d1.z;
    return r;
}

DUAL_FN spc_vec3 dv_val(dvec a) { return spc_v3(a.x.v, a.y.v, a.z.v); }

DUAL_FN dvec dv_add(dvec a, dvec b)
{
    dvec r = {dn_add(a.x, b.x), dn_add(a.y, b.y), dn_add(a.z, b.z)};
    return r;
}

DUAL_FN dvec dv_sub(dvec a, dvec b)
{
    dvec r = {dn_sub(a.x, b.x), dn_sub(a.y, b.y), dn_sub(a.z, b.z)};
    return r;
}

DUAL_FN dvec dv_mul(dvec a, dnum s)
{
    dvec r = {dn_mul(a.x, s), dn_mul(a.y, s), dn_mul(a.z, s)};
    return r;
}

DUAL_FN dvec dv_scale(dvec a, double s)
{
    dvec r = {dn_scale(a.x, s), dn_scale(a.y, s), dn_scale(a.z, s)};
    return r;
}

DUAL_FN dnum dv_dot(dvec a, dvec b) { return dn_add(dn_add(dn_mul(a.x, b.x), dn_mul(a.y, b.y)), dn_mul(a.z, b.z)); }

DUAL_FN dvec dv_cross(dvec a, dvec b)
{
    dvec r = {dn_sub(dn_mul(a.y, b.z), dn_mul(a.z, b.y)), dn_sub(dn_mul(a.z, b.x), dn_mul(a.x, b.z)),
              dn_sub(dn_mul(a.x, b.y), dn_mul(a.y, b.x))};
    return r;
}

DUAL_FN dvec dv_normalize(dvec a)
{
    dnum l = dn_sqrt(dv_dot(a, a));
    return dv_mul(a, dn_chain(l, 1.0 / l.v, -1.0 / (l.v * l.v)));
}

/* ---- geometry of one vertex ---- */

/* Orthonormal tangent basis of the geometric tangent plane and the shading normal's derivative
 * along each basis vector (dp = e_j solved for the surface parameters, least squares on the Gram
 * matrix, then dn = dndu du + dndv dv: works for every shape that fills the hit's derivatives). */
static bool tangent_basis(const spc_hit *h, spc_vec3 e[2], spc_vec3 dn[2])
{
    spc_frame f = spc_frame_from_n(h->ng);
    e[0] = f.s;
    e[1] = f.t;
    double g11 = spc_dot(h->dpdu, h->dpdu), g12 = spc_dot(h->dpdu, h->dpdv), g22 = spc_dot(h->dpdv, h->dpdv);
    double det = g11 * g22 - g12 * g12;
    if (!(det > SPC_NEWTON_GRAM_EPS * g11 * g22))
        return false;
    for (int j = 0; j < 2; ++j) {
        double r1 = spc_dot(h->dpdu, e[j]), r2 = spc_dot(h->dpdv, e[j]);
        double du = (g22 * r1 - g12 * r2) / det, dv = (g11 * r2 - g12 * r1) / det;
        dn[j] = spc_add(spc_scale(h->dndu, du), spc_scale(h->dndv, dv));
    }
    return true;
}

/* The local frame of a (unit) normal: s = normalize(ref - n (n . ref)), t = n x s. */
DUAL_FN void dual_frame(const dvec *n, spc_vec3 ref, dvec *s, dvec *t)
{
    dvec r = dv_const(ref);
    *s = dv_normalize(dv_sub(r, dv_mul(*n, dv_dot(*n, r))));
    *t = dv_cross(*n, *s);
}

/* Azimuthal-equidistant coordinates of the unit vector w around z in the frame (s, t, z):
 * theta (cos phi, sin phi) = (w.s, w.t) * atan2(rho, w.z) / rho, rho = |(w.s, w.t)|. False at z's
 * antipode, where the map is singular. */
DUAL_FN bool logmap(const dvec *w, const dvec *s, const dvec *t, const dvec *z, dnum out[2])
{
    dnum a = dv_dot(*w, *s), b = dv_dot(*w, *t), cz = dv_dot(*w, *z);
    dnum q = dn_add(dn_mul(a, a), dn_mul(b, b));
    double qv = q.v, c = cz.v, g, gq, gc = -1.0 / (qv + c * c);
    if (qv < SPC_NEWTON_LOGMAP_SERIES) {
        if (!(c > 0.0))
            return false;
        g = (1.0 - qv / (3.0 * c * c)) / c;
        gq = -1.0 / (3.0 * c * c * c);
    } else {
        double rho = sqrt(qv);
        g = atan2(rho, c) / rho;
        gq = (c / (qv + c * c) - g) / (2.0 * qv);
    }
    dnum G;
    G.v = g;
    for (int i = 0; i < ND; ++i)
        G.d[i] = gq * q.d[i] + gc * cz.d[i];
    out[0] = dn_mul(G, a);
    out[1] = dn_mul(G, b);
    return true;
}

/* The angle-difference constraint: w_o against the specular direction of w_i about the normal Nm
 * (frame S, T), in azimuthal-equidistant coordinates around the normal on w_o's side. eta = n(w_o
 * side) / n(w_i side). Where w_i is on the denser side beyond the critical angle the refracted
 * direction does not exist, and the roles of w_i and w_o are exchanged: the constraint is then
 * measured on the denser side, from the thinner one where refraction always exists (far seeds reach
 * such configurations; near a solution the thinner side's measure converges more often,
 * bench/RESULTS.md). */
DUAL_FN bool angle_difference(const dvec *wi_, const dvec *wo_, const dvec *Nm, const dvec *S, const dvec *T,
                              int event, double eta, dnum c[2])
{
    const dvec *wi = wi_, *wo = wo_;
    for (int pass = 0; pass < 2; ++pass) {
        dnum ci = dv_dot(*wi, *Nm);
        dvec nn = *Nm;
        if (ci.v < 0.0) {
            nn = dv_scale(*Nm, -1.0);
            ci = dn_scale(ci, -1.0);
        }
        dvec ws, z;
        if (event == SPC_CHAIN_REFLECT) {
            ws = dv_sub(dv_mul(nn, dn_scale(ci, 2.0)), *wi);
            z = nn;
        } else {
            double r = 1.0 / eta; /* n_i / n_t */
            dnum k = dn_sub(dn_const(1.0), dn_scale(dn_sub(dn_const(1.0), dn_mul(ci, ci)), r * r));
            if (!(k.v > 0.0)) {
                /* total internal reflection: no specular direction; the other way round */
                wi = wo_;
                wo = wi_;
                eta = 1.0 / eta;
                continue;
            }
            dnum m = dn_sub(dn_scale(ci, r), dn_sqrt(k));
            ws = dv_add(dv_scale(*wi, -r), dv_mul(nn, m));
            z = dv_scale(nn, -1.0);
        }
        dnum lo[2], ls[2];
        if (!logmap(wo, S, T, &z, lo) || !logmap(&ws, S, T, &z, ls))
            return false;
        c[0] = dn_sub(lo[0], ls[0]);
        c[1] = dn_sub(lo[1], ls[1]);
        return true;
    }
    return false;
}

/* The two constraints of vertex v at P (normal N) between P0 and P2; *wrong is set when the
 * neighbours are not on the sides the vertex's event needs (the constraints are still defined). */
DUAL_FN bool vertex_constraint(const dvec *P0, const dvec *P, const dvec *N, const dvec *P2, spc_vec3 ref,
                               const spc_newton_vertex *v, spc_newton_constraint kind, dnum c[2], bool *wrong)
{
    dvec wi = dv_normalize(dv_sub(*P0, *P)), wo = dv_normalize(dv_sub(*P2, *P));
    spc_vec3 n = dv_val(*N);
    double si = spc_dot(dv_val(wi), n), so = spc_dot(dv_val(wo), n);
    /* the event is part of the solution: reflection keeps both directions on one side */
    *wrong = v->event == SPC_CHAIN_REFLECT ? !(si * so > 0.0) : !(si * so < 0.0);
    /* eta = n(wo side) / n(wi side); "inside" is opposite to the shading normal */
    double eta = v->event == SPC_CHAIN_REFLECT ? 1.0 : (si > 0.0 ? v->eta : 1.0 / v->eta);
    dvec S, T;
    dual_frame(N, ref, &S, &T);
    dvec Nm = *N;
    if (v->rough) {
        /* the offset normal, fixed in the local frame; its own frame for the projections */
        Nm = dv_add(dv_add(dv_scale(S, v->m.x), dv_scale(T, v->m.y)), dv_scale(*N, v->m.z));
        dvec S2 = dv_normalize(dv_sub(S, dv_mul(Nm, dv_dot(Nm, S))));
        T = dv_cross(Nm, S2);
        S = S2;
    }
    if (kind == SPC_NEWTON_HALF_VECTOR) {
        dvec h = dv_normalize(dv_add(wi, dv_scale(wo, eta)));
        c[0] = dv_dot(h, S);
        c[1] = dv_dot(h, T);
        return true;
    }
    /* angle difference: w_o against the specular direction of w_i about Nm */
    return angle_difference(&wi, &wo, &Nm, &S, &T, v->event, eta, c);
}

/* spc_newton_constraints, with the vertices whose neighbours are on the wrong sides for their event
 * flagged in *wrong (bit i for vertex i) instead of failing. */
static bool constraints(spc_vec3 x, const spc_newton_path *p, spc_vec3 y, spc_vec3 ny, spc_newton_constraint kind,
                        double c[][2], double A[][2][2], double B[][2][2], double C[][2][2], spc_vec3 basis[][2],
                        unsigned *wrong)
{
    *wrong = 0;
    int k = p->n;
    if (k < 1 || k > SPC_CHAIN_MAX_VERTICES)
        return false;
    spc_vec3 dn[SPC_CHAIN_MAX_VERTICES][2];
    for (int i = 0; i < k; ++i)
        if (!tangent_basis(&p->v[i].h, basis[i], dn[i]))
            return false;
    spc_vec3 yb[2] = {spc_v3(0, 0, 0), spc_v3(0, 0, 0)};
    if (spc_length2(ny) > 0.0) {
        spc_frame fy = spc_frame_from_n(ny);
        yb[0] = fy.s;
        yb[1] = fy.t;
    }
    bool fixed_ref = spc_length2(p->ref) > 0.0;
    for (int i = 0; i < k; ++i) {
        const spc_newton_vertex *v = &p->v[i];
        dvec P0 = i == 0 ? dv_const(x) : dv_var(p->v[i - 1].h.p, 0, basis[i - 1][0], basis[i - 1][1]);
        dvec P = dv_var(v->h.p, 2, basis[i][0], basis[i][1]);
        dvec N = dv_var(v->h.sh.n, 2, dn[i][0], dn[i][1]);
        dvec P2 = i == k - 1 ? dv_var(y, 4, yb[0], yb[1]) : dv_var(p->v[i + 1].h.p, 4, basis[i + 1][0], basis[i + 1][1]);
        dnum cc[2];
        bool w;
        if (!vertex_constraint(&P0, &P, &N, &P2, fixed_ref ? p->ref : basis[i][0], v, kind, cc, &w))
            return false;
        if (w)
            *wrong |= 1u << i;
        for (int r = 0; r < 2; ++r) {
            c[i][r] = cc[r].v;
            for (int j = 0; j < 2; ++j) {
                A[i][r][j] = cc[r].d[j];
                B[i][r][j] = cc[r].d[2 + j];
                C[i][r][j] = cc[r].d[4 + j];
            }
            if (!isfinite(c[i][r]))
                return false;
        }
    }
    return true;
}

bool spc_newton_constraints(spc_vec3 x, const spc_newton_path *p, spc_vec3 y, spc_vec3 ny,
                            spc_newton_constraint kind, double c[][2], double A[][2][2], double B[][2][2],
                            double C[][2][2], spc_vec3 basis[][2])
{
    unsigned wrong;
    return constraints(x, p, y, ny, kind, c, A, B, C, basis, &wrong) && wrong == 0;
}

/* ---- block tridiagonal solve ---- */

static bool inv2(const double M[2][2], double I[2][2])
{
    double det = M[0][0] * M[1][1] - M[0][1] * M[1][0];
    double mx = spc_max(spc_max(fabs(M[0][0]), fabs(M[0][1])), spc_max(fabs(M[1][0]), fabs(M[1][1])));
    if (!(fabs(det) > SPC_NEWTON_SINGULAR * mx * mx) || !isfinite(det))
        return false;
    I[0][0] = M[1][1] / det;
    I[0][1] = -M[0][1] / det;
    I[1][0] = -M[1][0] / det;
    I[1][1] = M[0][0] / det;
    return true;
}

static void mul2(const double a[2][2], const double b[2][2], double out[2][2])
{
    for (int r = 0; r < 2; ++r)
        for (int c = 0; c < 2; ++c)
            out[r][c] = a[r][0] * b[0][c] + a[r][1] * b[1][c];
}

static void mulv2(const double a[2][2], const double v[2], double out[2])
{
    double o0 = a[0][0] * v[0] + a[0][1] * v[1], o1 = a[1][0] * v[0] + a[1][1] * v[1];
    out[0] = o0;
    out[1] = o1;
}

bool spc_newton_block_solve(int n, const double A[][2][2], const double B[][2][2], const double C[][2][2],
                            const double R[][2], double X[][2])
{
    if (n < 1 || n > SPC_CHAIN_MAX_VERTICES)
        return false;
    double Binv[SPC_CHAIN_MAX_VERTICES][2][2], Rp[SPC_CHAIN_MAX_VERTICES][2];
    double Bp[2][2];
    memcpy(Bp, B[0], sizeof Bp);
    Rp[0][0] = R[0][0];
    Rp[0][1] = R[0][1];
    if (!inv2((const double(*)[2])Bp, Binv[0]))
        return false;
    for (int i = 1; i < n; ++i) {
        /* eliminate A[i]: L = A[i] Bp[i-1]^-1, Bp[i] = B[i] - L C[i-1], R'[i] = R[i] - L R'[i-1] */
        double L[2][2], LC[2][2], LR[2];
        mul2(A[i], (const double(*)[2])Binv[i - 1], L);
        mul2((const double(*)[2])L, C[i - 1], LC);
        mulv2((const double(*)[2])L, Rp[i - 1], LR);
        for (int r = 0; r < 2; ++r) {
            for (int c = 0; c < 2; ++c)
                Bp[r][c] = B[i][r][c] - LC[r][c];
            Rp[i][r] = R[i][r] - LR[r];
        }
        if (!inv2((const double(*)[2])Bp, Binv[i]))
            return false;
    }
    mulv2((const double(*)[2])Binv[n - 1], Rp[n - 1], X[n - 1]);
    for (int i = n - 2; i >= 0; --i) {
        double t[2], cx[2];
        mulv2(C[i], X[i + 1], cx);
        t[0] = Rp[i][0] - cx[0];
        t[1] = Rp[i][1] - cx[1];
        mulv2((const double(*)[2])Binv[i], t, X[i]);
    }
    for (int i = 0; i < n; ++i)
        if (!isfinite(X[i][0]) || !isfinite(X[i][1]))
            return false;
    return true;
}

/* ---- chain surfaces and seeds ---- */

/* Is h a chain vertex (smooth specular interface, or with rough an isotropic rough one)? Fills the
 * vertex's event, eta and roughness; m is left to the caller. */
static bool vertex_surface(const spc_hit *h, bool any_surface, bool rough, spc_newton_vertex *v)
{
    int event;
    double eta;
    v->h = *h;
    v->rough = false;
    v->m = spc_v3(0, 0, 1);
    if (!spc_chain_hit_ready(h))
        return false;
    if (spc_chain_surface(h, any_surface, &event)) {
        spc_bsdf_is_specular_interface(h->bsdf, &eta);
        v->event = event;
        v->eta = event == SPC_CHAIN_REFRACT ? eta : 1.0;
        return event == SPC_CHAIN_REFLECT || eta > 0.0;
    }
    if (!rough || !spc_newton_rough_surface(h, any_surface, &event))
        return false;
    v->event = event;
    v->eta = event == SPC_CHAIN_REFRACT ? h->bsdf->eta : 1.0;
    v->rough = true;
    return true;
}

bool spc_newton_rough_surface(const spc_hit *h, bool any_surface, int *event)
{
    const spc_shape *s = h->shape;
    const spc_bsdf *b = h->bsdf;
    if (!s || s->emitter || !b || b != s->bsdf)
        return false;
    if (!any_surface && !spc_chain_caster_allowed(s->caustic_flags, 1) && !spc_chain_caster_allowed(s->caustic_flags, 2))
        return false;
    int ev;
    if (b->type == SPC_BSDF_ROUGHCONDUCTOR)
        ev = SPC_CHAIN_REFLECT;
    else if (b->type == SPC_BSDF_ROUGHDIELECTRIC && b->eta > 0.0)
        ev = SPC_CHAIN_REFRACT;
    else
        return false;
    spc_microfacet md = spc_microfacet_from_bsdf(b, h);
    if (md.alpha_u != md.alpha_v)
        return false; /* anisotropic: the local frame's rotation would matter (newton.h) */
    if (event)
        *event = ev;
    return true;
}

/* The microfacet normal of a rough vertex from two uniform numbers: D(m) cos(m) sampling. */
static void rough_normal(spc_newton_vertex *v, const double u[2])
{
    spc_microfacet md = spc_microfacet_from_bsdf(v->h.bsdf, &v->h);
    md.sample_visible = false;
    double pdf;
    v->m = spc_microfacet_sample(&md, spc_v3(0, 0, 1), spc_v2(u[0], u[1]), &pdf);
}

static spc_vec3 vertex_normal(const spc_newton_vertex *v, spc_vec3 ref)
{
    spc_vec3 n = v->h.sh.n;
    if (!v->rough)
        return n;
    spc_vec3 s = spc_normalize(spc_sub(ref, spc_scale(n, spc_dot(n, ref))));
    spc_vec3 t = spc_cross(n, s);
    return spc_add(spc_add(spc_scale(s, v->m.x), spc_scale(t, v->m.y)), spc_scale(n, v->m.z));
}

bool spc_newton_seed_straight(const spc_scene *sc, const spc_hit *x, spc_vec3 y, int max_vertices, bool any_surface,
                              const double (*rough_u)[2], spc_vec3 ref, spc_newton_path *p)
{
    p->n = 0;
    p->ref = ref;
    double y_err = 1e-9 * (spc_max_abs(y) + sc->radius);
    spc_ray r = spc_hit_spawn_to(x, y, y_err);
    spc_hit h;
    while (spc_chain_intersect(sc, &r, &h)) {
        if (p->n >= max_vertices || p->n >= SPC_CHAIN_MAX_VERTICES)
            return false;
        spc_newton_vertex *v = &p->v[p->n];
        if (!vertex_surface(&h, any_surface, rough_u != NULL, v))
            return false; /* blocked by a surface that is not a chain surface */
        if (v->rough)
            rough_normal(v, rough_u[p->n]);
        ++p->n;
        r = spc_hit_spawn_to(&v->h, y, y_err);
    }
    return p->n >= 1;
}

/* spc_newton_seed_trace; with events, the event at each smooth vertex is forced (a mismatch ends
 * the seed); else with event_u, the event at each smooth dielectric vertex is picked as
 * spc_chain_pick_event does. */
static bool seed_trace(const spc_scene *sc, const spc_hit *x, spc_vec3 dir, int max_vertices, bool any_surface,
                       const double (*rough_u)[2], spc_vec3 ref, const unsigned char *events, const double *event_u,
                       double reflect_p, spc_newton_path *p)
{
    p->n = 0;
    p->ref = ref;
    spc_ray r = spc_hit_spawn(x, dir);
    spc_vec3 d = dir;
    spc_hit h;
    for (;;) {
        if (!spc_chain_intersect(sc, &r, &h))
            return p->n >= 1;
        spc_newton_vertex *v = &p->v[p->n];
        if (!vertex_surface(&h, any_surface, rough_u != NULL, v))
            return p->n >= 1;
        /* one chain surface too many: the first max_vertices still fix a sequence (as angular.c) */
        if (p->n >= max_vertices || p->n >= SPC_CHAIN_MAX_VERTICES)
            return p->n >= 1;
        if (v->rough)
            rough_normal(v, rough_u[p->n]);
        else if (events) {
            if (events[p->n] != v->event) {
                if (v->event != SPC_CHAIN_REFRACT)
                    return p->n >= 1; /* a conductor cannot refract: the seed ends before it */
                v->event = SPC_CHAIN_REFLECT;
                v->eta = 1.0;
            }
        } else if (event_u && v->event == SPC_CHAIN_REFRACT) {
            v->event = spc_chain_pick_event(v->event, event_u[p->n], reflect_p, NULL);
            if (v->event == SPC_CHAIN_REFLECT)
                v->eta = 1.0;
        }
        spc_vec3 n = vertex_normal(v, ref), wi = spc_neg(d);
        double c = spc_dot(wi, n);
        if (v->event == SPC_CHAIN_REFLECT) {
            d = spc_sub(spc_scale(n, 2.0 * c), wi);
        } else {
            /* sides by the macro normal, as the constraints have them */
            double eta = spc_dot(wi, v->h.sh.n) > 0.0 ? v->eta : 1.0 / v->eta, rr = 1.0 / eta;
            spc_vec3 nn = c < 0.0 ? spc_neg(n) : n;
            c = fabs(c);
            double k = 1.0 - rr * rr * (1.0 - c * c);
            if (!(k > 0.0)) {
                /* total internal reflection: the vertex still seeds a chain that ends here (from
                 * inside a dense medium most directions toward a caster are beyond the critical
                 * angle; the solution they lead to is usually inside it) */
                ++p->n;
                return true;
            }
            d = spc_add(spc_scale(wi, -rr), spc_scale(nn, rr * c - sqrt(k)));
        }
        ++p->n;
        r = spc_hit_spawn(&v->h, d);
    }
}

bool spc_newton_seed_trace(const spc_scene *sc, const spc_hit *x, spc_vec3 dir, int max_vertices, bool any_surface,
                           const double (*rough_u)[2], spc_vec3 ref, spc_newton_path *p)
{
    return seed_trace(sc, x, dir, max_vertices, any_surface, rough_u, ref, NULL, NULL, 0.0, p);
}

void spc_newton_path_from_chain(const spc_chain *c, spc_newton_path *p)
{
    p->n = c->n;
    p->ref = spc_v3(0, 0, 0);
    for (int i = 0; i < c->n; ++i) {
        spc_newton_vertex *v = &p->v[i];
        v->h = c->v[i].h;
        v->event = c->v[i].event;
        double eta = 0.0;
        spc_bsdf_is_specular_interface(v->h.bsdf, &eta);
        v->eta = v->event == SPC_CHAIN_REFRACT ? eta : 1.0;
        v->rough = false;
        v->m = spc_v3(0, 0, 1);
    }
}

/* ---- the solver ---- */

/* Moves every vertex by beta D[i] in its tangent coordinates and projects it back onto its surface
 * by tracing from the new previous vertex (x for the first) toward the moved position. False if a
 * ray misses the vertex's surface. */
static bool project(const spc_scene *sc, const spc_hit *x, const spc_newton_path *cur, spc_vec3 basis[][2],
                    double D[][2], double beta, spc_newton_path *out)
{
    out->n = cur->n;
    out->ref = cur->ref;
    const spc_hit *prev = x;
    for (int i = 0; i < cur->n; ++i) {
        const spc_newton_vertex *v = &cur->v[i];
        spc_vec3 target = spc_add(v->h.p, spc_add(spc_scale(basis[i][0], beta * D[i][0]),
                                                   spc_scale(basis[i][1], beta * D[i][1])));
        /* aimed from the offset origin, so the ray passes through the target itself: a target on a
         * flat surface is hit exactly, and the projection adds no error of the offset's size */
        spc_ray r;
        r.o = spc_hit_offset(prev, spc_sub(target, prev->p));
        spc_vec3 d = spc_sub(target, r.o);
        double len = spc_length(d);
        if (!(len > 0.0))
            return false;
        r.d = spc_scale(d, 1.0 / len);
        r.tmin = 0.0;
        r.tmax = SPC_INF;
        spc_newton_vertex *nv = &out->v[i];
        *nv = *v;
        if (!spc_chain_intersect(sc, &r, &nv->h) || nv->h.shape_index != v->h.shape_index)
            return false;
        prev = &nv->h;
    }
    return true;
}

static double norm2(int k, double c[][2])
{
    double s = 0.0;
    for (int i = 0; i < k; ++i)
        s += c[i][0] * c[i][0] + c[i][1] * c[i][1];
    return s;
}

bool spc_newton_solve(const spc_scene *sc, const spc_hit *x, spc_vec3 y, spc_newton_path *p,
                      const spc_newton_options *o, spc_newton_result *res)
{
    res->iterations = 0;
    res->step = INFINITY;
    res->converged = false;
    res->stop = SPC_NEWTON_STOP_SEED;
    int k = p->n;
    if (k < 1 || k > SPC_CHAIN_MAX_VERTICES)
        return false;
    const spc_vec3 zero = spc_v3(0, 0, 0);
    double c[SPC_CHAIN_MAX_VERTICES][2], A[SPC_CHAIN_MAX_VERTICES][2][2], B[SPC_CHAIN_MAX_VERTICES][2][2],
        C[SPC_CHAIN_MAX_VERTICES][2][2], R[SPC_CHAIN_MAX_VERTICES][2], D[SPC_CHAIN_MAX_VERTICES][2];
    spc_vec3 basis[SPC_CHAIN_MAX_VERTICES][2];
    double c2[SPC_CHAIN_MAX_VERTICES][2], A2[SPC_CHAIN_MAX_VERTICES][2][2], B2[SPC_CHAIN_MAX_VERTICES][2][2],
        C2[SPC_CHAIN_MAX_VERTICES][2][2];
    spc_vec3 basis2[SPC_CHAIN_MAX_VERTICES][2];
    unsigned wrong, wrong2;
    spc_newton_constraint kind = o->constraint;
    bool switched = false;
    if (!constraints(x->p, p, y, zero, kind, c, A, B, C, basis, &wrong))
        return false;
    double E = norm2(k, c), beta = 1.0, tol = o->tol_scene * sc->radius;
    spc_newton_path trial;
    if (o->trace)
        o->trace(o->trace_user, p, E, true);
    for (;;) {
        for (int i = 0; i < k; ++i) {
            R[i][0] = -c[i][0];
            R[i][1] = -c[i][1];
        }
        if (!spc_newton_block_solve(k, (const double(*)[2][2])A, (const double(*)[2][2])B,
                                    (const double(*)[2][2])C, (const double(*)[2])R, D)) {
            res->stop = SPC_NEWTON_STOP_SINGULAR;
            return false;
        }
        double step = 0.0;
        for (int i = 0; i < k; ++i)
            step = spc_max(step, hypot(D[i][0], D[i][1]));
        res->step = step;
        /* a trust region: no vertex moves by more than SPC_NEWTON_MAX_TURN of its distance to the
         * previous one (a step that turns the segment further has left the region where the
         * linearization means anything; the whole step is scaled, keeping its direction) */
        double scale = 1.0;
        for (int i = 0; i < k; ++i) {
            double d = spc_distance(p->v[i].h.p, i == 0 ? x->p : p->v[i - 1].h.p), m = hypot(D[i][0], D[i][1]);
            if (m > SPC_NEWTON_MAX_TURN * d)
                scale = spc_min(scale, SPC_NEWTON_MAX_TURN * d / m);
        }
        for (int i = 0; i < k; ++i) {
            D[i][0] *= scale;
            D[i][1] *= scale;
        }
        if (step <= tol) {
            /* a solution of the constraints with a vertex on the wrong sides is not a path */
            res->converged = wrong == 0;
            res->stop = res->converged ? SPC_NEWTON_CONVERGED : SPC_NEWTON_STOP_SIDES;
            return res->converged;
        }
        for (;;) {
            if (res->iterations >= o->max_iterations) {
                res->stop = SPC_NEWTON_STOP_ITERATIONS;
                return false;
            }
            res->iterations++;
            bool projected = project(sc, x, p, basis, D, beta, &trial);
            if (projected && constraints(x->p, &trial, y, zero, kind, c2, A2, B2, C2, basis2, &wrong2)) {
                double E2 = norm2(k, c2);
                if (o->trace)
                    o->trace(o->trace_user, &trial, E2, E2 < E && (wrong2 & ~wrong) == 0);
                /* no vertex may change from transmission to reflection or back (one that starts on
                 * the wrong sides, as a seed may, can only be set right) */
                if (E2 < E && (wrong2 & ~wrong) == 0) {
                    *p = trial;
                    memcpy(c, c2, sizeof c);
                    memcpy(A, A2, sizeof A);
                    memcpy(B, B2, sizeof B);
                    memcpy(C, C2, sizeof C);
                    memcpy(basis, basis2, sizeof basis);
                    E = E2;
                    wrong = wrong2;
                    beta = spc_min(1.0, 2.0 * beta);
                    break;
                }
            } else if (projected && o->trace) {
                o->trace(o->trace_user, &trial, INFINITY, false);
            }
            beta *= 0.5;
            if (beta < o->min_beta) {
                /* stalled: once, the other constraint kind from here (its Newton direction differs
                 * far from the solution; both vanish at the same paths) */
                if (o->switch_kind && !switched) {
                    switched = true;
                    kind = kind == SPC_NEWTON_ANGLE_DIFF ? SPC_NEWTON_HALF_VECTOR : SPC_NEWTON_ANGLE_DIFF;
                    if (constraints(x->p, p, y, zero, kind, c, A, B, C, basis, &wrong)) {
                        E = norm2(k, c);
                        beta = 1.0;
                        break;
                    }
                }
                res->stop = SPC_NEWTON_STOP_PROGRESS;
                return false;
            }
        }
    }
}

double spc_newton_geometry(spc_vec3 x, const spc_newton_path *p, spc_vec3 y, spc_vec3 ny,
                           spc_newton_constraint kind)
{
    int k = p->n;
    double c[SPC_CHAIN_MAX_VERTICES][2], A[SPC_CHAIN_MAX_VERTICES][2][2], B[SPC_CHAIN_MAX_VERTICES][2][2],
        C[SPC_CHAIN_MAX_VERTICES][2][2], R[SPC_CHAIN_MAX_VERTICES][2], X[2][SPC_CHAIN_MAX_VERTICES][2];
    spc_vec3 basis[SPC_CHAIN_MAX_VERTICES][2];
    if (!(spc_length2(ny) > 0.0) || !spc_newton_constraints(x, p, y, ny, kind, c, A, B, C, basis))
        return 0.0;
    /* J dalpha/dy = -dC/dy, where only the last vertex's constraints see y (C[k-1]) */
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < k; ++i)
            R[i][0] = R[i][1] = 0.0;
        R[k - 1][0] = -C[k - 1][0][j];
        R[k - 1][1] = -C[k - 1][1][j];
        if (!spc_newton_block_solve(k, (const double(*)[2][2])A, (const double(*)[2][2])B, (const double(*)[2][2])C,
                                    (const double(*)[2])R, X[j]))
            return 0.0;
    }
    /* dA(x_1) / dA(y): the determinant of d(alpha_1) / d(y coordinates), both orthonormal */
    double det = X[0][0][0] * X[1][0][1] - X[1][0][0] * X[0][0][1];
    spc_vec3 w = spc_sub(p->v[0].h.p, x);
    double d2 = spc_length2(w);
    double cos1 = spc_absdot(w, p->v[0].h.ng) / sqrt(d2);
    double G = fabs(det) * cos1 / d2;
    return isfinite(G) ? G : 0.0;
}

/* ---- the specular-NEE entry ---- */

bool spc_newton_to_chain(const spc_scene *sc, const spc_hit *x, const spc_newton_path *p,
                         const spc_angular_target *tg, const spc_angular_options *ao, int polish, bool any_surface,
                         spc_chain *out, int *iterations)
{
    spc_chain_sig sig;
    memset(&sig, 0, sizeof sig);
    sig.n = p->n;
    for (int i = 0; i < p->n; ++i) {
        sig.shape[i] = p->v[i].h.shape_index;
        sig.event[i] = (unsigned char)p->v[i].event;
    }
    spc_chain_opts co = spc_chain_opts_default(p->n);
    co.fixed = &sig;
    co.any_surface = any_surface;
    spc_angular_options po = *ao;
    po.method = SPC_ANGULAR_GAUSS_NEWTON;
    po.max_iterations = polish;
    spc_angular_result ar;
    bool ok = spc_angular_solve(sc, x, tg, spc_normalize(spc_sub(p->v[0].h.p, x->p)), &co, &po, out, &ar);
    if (iterations)
        *iterations += ar.iterations;
    return ok && out->n == p->n;
}

bool spc_newton_solve_one(const struct spc_snee_query *q, spc_rng *rng, spc_chain *out, int *iterations)
{
    const spc_newton_options *o = &q->params->newton;
    spc_newton_path p;
    const spc_vec3 noref = spc_v3(0, 0, 0);
    if (q->seed == SPC_SNEE_SEED_LIGHT) {
        if (!spc_newton_seed_straight(q->scene, q->x, q->y, q->max_chain, q->any_surface, NULL, noref, &p))
            return false;
    } else {
        spc_vec3 dir;
        double event_u[SPC_CHAIN_MAX_VERTICES];
        bool reflect = q->params->reflect && !q->events;
        if (reflect)
            spc_snee_attempt_event_u(q, rng, event_u);
        if (!spc_snee_seed_direction(q, rng, &dir) ||
            !seed_trace(q->scene, q->x, dir, q->max_chain, q->any_surface, NULL, noref, q->events,
                        reflect ? event_u : NULL, q->params->reflect_p, &p))
            return false;
    }
    spc_newton_result res;
    bool ok = spc_newton_solve(q->scene, q->x, q->y, &p, o, &res);
    if (iterations)
        *iterations += res.iterations;
    if (!ok)
        return false;
    spc_angular_target tg;
    tg.y = q->y;
    tg.ny = q->ny;
    tg.scale = q->scene->radius;
    tg.light_size = q->light_size;
    return spc_newton_to_chain(q->scene, q->x, &p, &tg, &q->params->angular, o->polish_iterations, q->any_surface,
                               out, iterations);
}

spc_vec3 spc_newton_vertex_normal(const spc_newton_vertex *v, spc_vec3 ref) { return vertex_normal(v, ref); }
