/*
 * manifold/conic.h: the conic solver for specular connections through one interface on triangle
 * meshes with interpolated normals (Freire 2021, shared/papers/003, sec. 4-7, completed here).
 *
 * Problem: given two points x and y and a triangle with vertex positions p0, p1, p2 and vertex
 * shading normals n0, n1, n2, find EVERY point P of the triangle where a ray from x reflects or
 * refracts toward y about the interpolated shading normal n(u, v) = (1-u-v) n0 + u n1 + v n2
 * (unnormalized, as scene/shape.c interpolates it; (u, v) the barycentrics of p1 and p2).
 *
 * The law at P, with wx = (x-P)/|x-P|, wy = (y-P)/|y-P| and n^ = n/|n|:
 *   reflection   wx, wy on the same side of n^ and  wx + wy parallel to n^;
 *   refraction   wx, wy on opposite sides and  eta_x wx + eta_y wy parallel to n^, where eta_x is
 *                the index on x's side: 1 if x is on the side n^ points to (the outside of the
 *                dielectric BSDF), eta otherwise, and eta_y the other one.
 * It splits into coplanarity, n . ((x-P) x (y-P)) = 0, a quadratic form in (u, v): a conic
 * (report sec. 5.2.1); and the sine law, which squared and multiplied out reads
 *     f = eta_x^2 |y-P|^2 |(x-P) x n|^2 - eta_y^2 |x-P|^2 |(y-P) x n|^2 = 0      (report sec. 5.1)
 * and on a straight chord P(t) of the conic is a polynomial of degree 6 in t (sec. 5.3.1).
 *
 * This header: the conic and its classification (sec. 5.2.2), its arcs inside the triangle
 * (sec. 5.2.3-5.2.4), their chords (sec. 5.3.2), the chord polynomial, and the solver built on
 * them (conic_solver.c): per triangle, and per mesh through a hierarchy with culling.
 *
 * Units: (u, v) are dimensionless barycentrics; positions in scene units. Hot paths allocate
 * nothing; "no solution" is a count of 0.
 */
#ifndef SPC_MANIFOLD_CONIC_H
#define SPC_MANIFOLD_CONIC_H

#include "core/math.h"
#include "scene/shape.h"

/* ---- the conic ---- */

/* Q(u, v) = A u^2 + B u v + C v^2 + D u + E v + F. */
typedef struct spc_conic {
    double A, B, C, D, E, F;
} spc_conic;

/* One triangle of a mesh in the form the solver uses. */
typedef struct spc_conic_tri {
    spc_vec3 p0, e1, e2;   /* P(u, v) = p0 + u e1 + v e2 */
    spc_vec3 n0, dn1, dn2; /* n(u, v) = n0 + u dn1 + v dn2 (unnormalized shading normal) */
} spc_conic_tri;

/* From vertices and vertex normals (flip_normals already applied by the caller). */
spc_conic_tri spc_conic_tri_make(spc_vec3 p0, spc_vec3 p1, spc_vec3 p2, spc_vec3 n0, spc_vec3 n1, spc_vec3 n2);
spc_vec3 spc_conic_tri_point(const spc_conic_tri *t, double u, double v);
spc_vec3 spc_conic_tri_normal(const spc_conic_tri *t, double u, double v);

/* The coplanarity conic of x, y and the triangle: Q = n(u,v) . ((y-x) x (P(u,v)-x)), which is
 * n . ((x-P) x (y-P)) written around x (report sec. 5.2.1, there around the origin). */
spc_conic spc_conic_coplanarity(const spc_conic_tri *t, spc_vec3 x, spc_vec3 y);
double spc_conic_eval(const spc_conic *q, double u, double v);

typedef enum spc_conic_type {
    SPC_CONIC_ELLIPSE,        /* real ellipse */
    SPC_CONIC_HYPERBOLA,
    SPC_CONIC_PARABOLA,
    SPC_CONIC_LINE,           /* no quadratic part over the triangle: one line */
    SPC_CONIC_LINE_PAIR,      /* two real lines crossing */
    SPC_CONIC_PARALLEL_LINES, /* two real parallel lines */
    SPC_CONIC_DOUBLE_LINE,    /* one line counted twice */
    SPC_CONIC_POINT,          /* one real point (two complex lines crossing) */
    SPC_CONIC_EMPTY,          /* no real point: imaginary ellipse, complex parallel lines, Q = const */
    SPC_CONIC_PLANE           /* Q = 0 everywhere: every point is coplanar */
} spc_conic_type;

/* Classification by the determinants of the 3x3 and 2x2 matrices of Q (report fig. 18), with
 * tolerances on the scale of the unit triangle: a conic within rounding of a degenerate one is
 * degenerate; one whose quadratic part bends it by less than ~1e-10 over the triangle is a LINE. */
spc_conic_type spc_conic_classify(const spc_conic *q);
const char *spc_conic_type_name(spc_conic_type t);

/* ---- arcs inside the triangle u >= 0, v >= 0, u + v <= 1 ---- */

/* A non-degenerate conic parameterized by the pencil of lines through one of its points:
 * the line through `base` along cos(psi) T + sin(psi) N meets the conic again at
 *     P(psi) = base + r(psi) (cos psi T + sin psi N),
 *     r(psi) = -g sin psi / (alpha cos^2 psi + 2 beta sin psi cos psi + gamma sin^2 psi),
 * T, N the unit tangent and normal at base, g = |grad Q(base)|, (alpha, beta, gamma) the quadratic
 * part of Q in the frame (T, N). psi covers the whole conic once over a period of pi, in the order
 * of the curve (psi = 0 is base); zeros of the denominator are its points at infinity. Unlike the
 * report's affine map to a unit circle or hyperbola (appendix A) it covers parabolas, and keeps
 * full relative precision on nearly straight conics (centre far away), the common case on finely
 * tessellated smooth meshes. */
typedef struct spc_conic_curve {
    spc_conic q;
    spc_vec2 base, T, N;
    double g, alpha, beta, gamma;
} spc_conic_curve;

spc_vec2 spc_conic_curve_point(const spc_conic_curve *c, double psi);
/* psi of a point on the conic, in (-pi/2, pi/2]. */
double spc_conic_curve_param(const spc_conic_curve *c, spc_vec2 p);

/* A piece of the conic inside the triangle. */
typedef struct spc_conic_arc {
    bool segment;        /* a straight piece (degenerate conic, or LINE): exact, no chords */
    spc_vec2 a, b;       /* endpoints */
    double psi_a, psi_b; /* curved arcs: parameters with psi_a < psi_b, psi_b - psi_a < pi */
    double err;          /* segment: distance to the true conic (0 unless a near-degenerate conic
                            was replaced by its lines) */
} spc_conic_arc;

/* Up to 3 arcs of a conic, each split into at most 2, plus the halves of whole ellipses. */
#define SPC_CONIC_MAX_ARCS 8
#define SPC_CONIC_MAX_POINTS 8

typedef struct spc_conic_arcs {
    spc_conic_type type;
    bool has_curve;
    spc_conic_curve curve; /* the parameterization of every curved arc */
    int narcs;
    spc_conic_arc arc[SPC_CONIC_MAX_ARCS];
    int npoints;           /* isolated points of the conic in the triangle: a POINT conic, a
                              tangency from outside, the crossing of near-degenerate line pairs */
    spc_vec2 point[SPC_CONIC_MAX_POINTS];
} spc_conic_arcs;

/* The pieces of the conic inside the closed triangle (report sec. 5.2.3-5.2.4): boundary
 * crossings on the three edges ordered along the curve by psi; the piece between two consecutive
 * crossings is inside when it has no point at infinity and its middle is inside (so tangencies
 * need no special case); an ellipse with no crossing is inside when one of its points is. */
void spc_conic_find_arcs(const spc_conic *q, spc_conic_arcs *out);

/* The point of a curved arc farthest from its chord: where the tangent is parallel to the chord,
 * i.e. on the diameter conjugate to the chord's direction (for central conics the point of the
 * mean angle or hyperbolic parameter, report sec. 5.3.2). Writes the point, its psi and its
 * distance to the chord. False if it could not be found (then the mean psi is a fallback). */
bool spc_conic_farthest(const spc_conic_curve *c, const spc_conic_arc *arc, spc_vec2 *p, double *psi, double *dist);

/* Splits an arc into chords no farther than tol from it (recursively at the farthest point).
 * Writes up to max_out chords (as arcs: a, b, psi_a, psi_b, err = their distance) and returns
 * the count; segments come back as one chord. */
int spc_conic_chords(const spc_conic_arcs *arcs, const spc_conic_arc *arc, double tol, spc_conic_arc *out, int max_out);

/* ---- the chord polynomial (report sec. 5.3.1) ---- */

/* f(t) of the squared sine law on the line (u, v) = a + t (b - a):
 *   f = eta_x^2 |y-P|^2 |(x-P) x n|^2 - eta_y^2 |x-P|^2 |(y-P) x n|^2,  coefficients f[0..6]. */
void spc_conic_chord_poly(const spc_conic_tri *t, spc_vec3 x, spc_vec3 y, double eta_x, double eta_y, spc_vec2 a,
                          spc_vec2 b, double f[7]);
/* The same function at one point (u, v). */
double spc_conic_snell_eval(const spc_conic_tri *t, spc_vec3 x, spc_vec3 y, double eta_x, double eta_y, double u,
                            double v);

/* ---- the solver (conic_solver.c) ---- */

typedef enum spc_conic_event {
    SPC_CONIC_REFLECT = 0, /* same values as spc_chain_event */
    SPC_CONIC_REFRACT = 1
} spc_conic_event;

/* One connection problem through one interface. */
typedef struct spc_conic_problem {
    spc_vec3 x, y;
    int event;  /* spc_conic_event */
    double eta; /* refraction: n_inside / n_outside, the inside opposite to the shading normal */
    bool front_only; /* reflection: only on the side the shading normal points to (a one-sided
                        conductor reflects nothing from behind), which also culls more */
} spc_conic_problem;

typedef struct spc_conic_solution {
    double u, v;     /* barycentrics on the triangle */
    int prim;        /* triangle index (mesh solves) */
    spc_vec3 p;      /* position */
    spc_vec3 n;      /* unit shading normal */
    double residual; /* |n^ x (eta_x wx + eta_y wy)| / (eta_x + eta_y): 0 for an exact solution */
} spc_conic_solution;

typedef struct spc_conic_stats {
    long long triangles;   /* triangles whose conic was built */
    long long nodes;       /* hierarchy nodes visited */
    long long chords;      /* chord polynomials solved */
    long long candidates;  /* roots polished */
    long long solutions;   /* admissible solutions (before deduplication across triangles) */
} spc_conic_stats;

/* The residual of the law at (u, v) (see spc_conic_solution), or +inf where the configuration
 * is not admissible for the event (wrong sides, zero normal). Also the test's precision measure. */
double spc_conic_law_residual(const spc_conic_tri *t, const spc_conic_problem *pb, double u, double v);

/* Every admissible solution on one triangle; returns how many were written (at most max_out).
 * st may be NULL. */
int spc_conic_solve_triangle(const spc_conic_tri *t, const spc_conic_problem *pb, spc_conic_solution *out,
                             int max_out, spc_conic_stats *st);

/* The per-mesh hierarchy: a bounding volume hierarchy of triangles with boxes and cones of
 * shading normals (Walter et al. 2009, sec. 5), culled per query by sidedness, the normal cone
 * against the cone of generalized half vectors, and (refraction) the spindle test. Read-only
 * after construction, so any number of threads may query it. */
typedef struct spc_conic_mesh spc_conic_mesh;

/* Builds the hierarchy of a mesh shape (vertex normals if it has them and face_normals is off,
 * else face normals; flip_normals applied). NULL on allocation failure or a non-mesh shape. The
 * caller owns it: spc_conic_mesh_destroy (NULL-safe). */
spc_conic_mesh *spc_conic_mesh_build(const spc_shape *s);
void spc_conic_mesh_destroy(spc_conic_mesh *m);
/* The shape's hierarchy, built on first use and kept in s->solver_cache (freed with the shape);
 * concurrent first uses are safe (one build wins, the others are freed). NULL on failure. */
const spc_conic_mesh *spc_conic_mesh_get(const spc_shape *s);
/* The triangle of a mesh in solver form. */
spc_conic_tri spc_conic_mesh_triangle(const spc_conic_mesh *m, int prim);
int spc_conic_mesh_ntris(const spc_conic_mesh *m);

/* Every admissible solution on the mesh, deduplicated across shared edges and vertices; returns
 * the count (at most max_out). brute: visit every triangle instead of the hierarchy (tests). */
int spc_conic_mesh_solve(const spc_conic_mesh *m, const spc_conic_problem *pb, spc_conic_solution *out, int max_out,
                         bool brute, spc_conic_stats *st);

/* The culling tests of the hierarchy, one bit each (the traversal culls a node when any is set). */
typedef enum spc_conic_cull {
    SPC_CONIC_CULL_SIDES = 1,  /* x and y surely on sides of every normal that the event excludes
                                  (refraction: one side; reflection: two; one-sided: behind) */
    SPC_CONIC_CULL_CONES = 2,  /* the normal cone misses every line of the generalized half vector */
    SPC_CONIC_CULL_SPINDLE = 4 /* refraction: outside the spindle where x P y can bend by refraction */
} spc_conic_cull;

/* Which tests cull a ball (centre c, radius r) whose unit shading normals all lie within `angle`
 * radians of the unit vector `axis` (angle >= pi: any normal), for problem pb: the same code the
 * traversal runs on each node's bounding ball and padded cone, here with every test evaluated.
 * A ball that holds a solution must get 0 (tests/test_conic.c checks each bit alone). */
unsigned spc_conic_cull_tests(const spc_conic_problem *pb, spc_vec3 c, double r, spc_vec3 axis, double angle);

/* The distance correction factor of Walter et al. 2009 by ray differentials (report sec. 7.1,
 * appendix C, with its typos fixed): the area at y, perpendicular to the final direction, swept
 * per unit solid angle of directions leaving x, D = |dA_perp(y) / dw(x)|, through the solution
 * s of problem pb on triangle t. The generalized geometry term is |cos theta_y| / D. 0 if
 * degenerate. */
double spc_conic_dcf(const spc_conic_tri *t, const spc_conic_problem *pb, const spc_conic_solution *s);

struct spc_snee_query;
struct spc_chain;
/* The solver-table entry (solver.h): every chain of exactly one vertex on a mesh shape that
 * may be a caster, traced from x (so the chain carries its derivatives and the first segment is
 * known unblocked); returns the count written (at most max_out). */
int spc_conic_solve_all(const struct spc_snee_query *q, struct spc_chain *out, int max_out, int *iterations);
/* Which chains spc_conic_solve_all enumerates: one vertex, on a triangle mesh. */
bool spc_conic_covers(const struct spc_chain *c);
/* Whether those are all the chains of the query: its budget is one vertex and every shape that may
 * be a one-vertex caster is a mesh. */
bool spc_conic_covers_all(const struct spc_snee_query *q);

#endif
