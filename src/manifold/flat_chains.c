/*
 * manifold/flat_chains.c: every specular chain through flat faces (flat_chains.h).
 *
 * The faces of a shape are found once (flat_get: triangles grouped by plane) and kept in the
 * shape's flat_cache. A query walks the sequences of (face, side, event) of 1 to max_chain vertices
 * depth first with the pruning of flat_chains.h, and for each complete sequence minimizes the
 * optical path length L over the vertices' plane coordinates (Fermat's principle; L convex, so its
 * minimum is the sequence's one chain if there is one). Newton's method on L: gradient
 * g_i = U_i^T (eta_{i-1} e_{i-1} - eta_i e_i) (e_j the unit direction of segment j, U_i the face's
 * tangent basis) and the block-tridiagonal Hessian of the sum of eta_j |r_j|, whose terms are
 * eta_j (I - e_j e_j^T) / |r_j|; a small Levenberg term keeps the step defined where the Hessian is
 * singular (the sums of such projectors lose rank only on collinear configurations) and a
 * backtracking line search on L makes it converge from any start (Boyd and Vandenberghe, Convex
 * Optimization, 9.5). From the straight line x -> y a few steps reach machine precision.
 */
#include "manifold/flat_chains.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "manifold/solver.h"
#include "scene/scene.h"
#include "scene/shape.h"

/* Newton's steps on L itself, from the end of the smoothed stages (below): two or three as a rule
 * (quadratic convergence); the cap ends sequences that do not converge. */
#define SPC_FLAT_NEWTON_STEPS 12

/* The smoothing's stages: mu from 0.1 of the problem's size down to MU_END of it, by MU_FALL per
 * stage, at most STAGE_STEPS Newton steps each. One or two are enough once the path is followed;
 * more where the first, wide stage's minimum lies at a kink (a short segment collapsed: a total
 * internal reflection off a slab's side face near the edge with the face the path entered by) and
 * the damped steps must carry it back: with 5 a stage, a quarter of the five-vertex chains through
 * two slabs ended at the kink test (minimize) and were lost (tests/test_flat_roots.c); 20 finds
 * them all there, and costs nothing measurable where the stages converge in one or two steps
 * (bench/RESULTS.md, "flat5's deficit"). */
#define SPC_FLAT_MU_FALL 0.01
#define SPC_FLAT_MU_END 1e-7
#define SPC_FLAT_STAGE_STEPS 20

/* The line search's allowance for the rounding of L, in units of L's ulp: near the minimum a
 * Newton step lowers L by about |g|^2 / H, below double precision once |g| is near 1e-8, and a
 * strict decrease test then rejects the step that would bring |g| under the convergence test's
 * 1e-9 (1 in 300 four-vertex chains through two slabs was lost that way). */
#define SPC_FLAT_ROUNDING_ULPS 8.0

/* The line search's minimization along a Newton step (line_min): to this relative width of t, in
 * at most this many evaluations of L_mu's slope along the step (each as cheap as one of L). A
 * rough minimum is enough: the Newton step that follows lands near L_mu's minimum once the
 * collapsed segment's length is near mu. */
#define SPC_FLAT_LINE_TOL 1e-2
#define SPC_FLAT_LINE_STEPS 20

/* Converged when each vertex's tangential mismatch (a difference of unit vectors times indices)
 * is below this: the 3D polish then needs one trace. */
#define SPC_FLAT_GRAD_TOL 1e-12

/* Relative tolerances (of the problem's size): a point counts as off a plane beyond SIDE, inside a
 * face's triangle within EDGE of its edges. Both far below any sensible scene's features and far
 * above double rounding. */
#define SPC_FLAT_SIDE_REL 1e-9
#define SPC_FLAT_EDGE_REL 1e-9

/* The slack, relative to the problem's size, of the bound that ends a sequence whose minimum lies
 * outside its faces (lower_bound_on_faces): 1e3 times SPC_FLAT_EDGE_REL covers in_face's tolerance
 * on triangles with angles down to a milliradian, and L's rounding many times over. */
#define SPC_FLAT_BOUND_SLACK 1e-6

/* Distinct corners kept per face for its direction caps (a cube's face has 4; a face with more
 * is bounded by the sphere around its corners instead). */
#define SPC_FLAT_FACE_CORNERS 12

typedef struct flat_face {
    spc_vec3 n;       /* unit normal toward the exterior (the winding, flip_normals applied) */
    double d;         /* n . p for p on the plane */
    spc_vec3 o, u, v; /* a point on the plane, an orthonormal tangent basis */
    int first, count; /* its triangles: corner[3 * first ..], tri2d[6 * first ..] */
    spc_vec3 c;       /* the centre of its corners' bounding box, */
    double rad;       /* and the radius of the sphere around c that holds them */
    int ncorners;     /* its distinct corners (0: more than SPC_FLAT_FACE_CORNERS) */
    spc_vec3 corners[SPC_FLAT_FACE_CORNERS];
} flat_face;

/* ---- direction cones ----
 *
 * A set of directions bounded by a cap of the unit sphere: axis a, half-angle r (r >= pi: any
 * direction). The walk carries the cap that holds the direction of the segment leaving the last
 * vertex, and prunes a sequence where no direction of it can do what the next face asks: meet the
 * plane from the chosen side, refract out of glass without total internal reflection, point from
 * one face toward the next or toward y. Each cap is a bound (every direction a real chain can take
 * lies in it), so pruning loses nothing:
 *   - from x to a face: the directions toward its corners' bounding sphere;
 *   - reflection: an isometry of directions, the cap reflected;
 *   - refraction into a denser medium (n_in < n_out): inside the critical cone around the normal,
 *     half-angle asin(n_in / n_out); and since the map is a contraction of the sphere there (the
 *     polar angle's derivative cos ti n_in / (cos tt n_out) < 1, the azimuth's sin tt / sin ti < 1),
 *     inside the cap of the same r around the refracted axis;
 *   - refraction out (n_in > n_out): only directions within asin(n_out / n_in) of the normal pass;
 *     the polar angle out is asin(n_in / n_out sin ti) of the largest ti in the cap. */

typedef struct cone {
    spc_vec3 a;
    double r;
} cone;

/* fmin and fmax with glibc's values (a NaN argument ignored, a tie such as -0 and +0 giving the
 * second), inline: the walk and its solves ask for millions a render, and without
 * -ffinite-math-only the compiler leaves each a library call. */
static inline double dmin(double a, double b) { return b != b ? a : a != a ? b : a < b ? a : b; }
static inline double dmax(double a, double b) { return b != b ? a : a != a ? b : a > b ? a : b; }

static double angle_between(spc_vec3 a, spc_vec3 b) { return acos(dmax(-1.0, dmin(1.0, spc_dot(a, b)))); }

/* asin(x) for the critical angles: x is a ratio of the scene's indices, so one thread asks for a
 * few values over and over; the last two are kept per thread (the same value, without the call). */
static double critical_angle(double x)
{
    static _Thread_local double key[2] = {-1.0, -1.0}, val[2];
    static _Thread_local int next;
    if (x == key[0])
        return val[0];
    if (x == key[1])
        return val[1];
    int i = next;
    next ^= 1;
    key[i] = x;
    val[i] = asin(x);
    return val[i];
}

/* Does every direction of the cap (a, r), r < pi, lie within the angle crit < pi/2 of the unit
 * vector m: angle(a, m) + r <= crit? Without the acos where the answer is plain: a cap wider than
 * crit, or an axis at a right angle or more from m, is not within it (the angle is >= 0, and >=
 * pi/2 > crit there); otherwise the test reads acos(d) <= t = crit - r as d >= cos t, and cos t
 * lies between 1 - t^2/2 + t^4/24 - t^6/720 and 1 - t^2/2 + t^4/24 (Taylor's bounds, t <= pi/2):
 * outside that band widened by 1e-14 on the cosine (an angle of 1e-14 at least, far above the
 * rounding of either form) the answer is decided, inside it the angles are compared as before. */
static bool cap_within(spc_vec3 a, double r, spc_vec3 m, double crit)
{
    double d = spc_dot(a, m);
    if (r > crit || !(d > 0.0))
        return false;
    double t = crit - r, t2 = t * t, hi = 1.0 - 0.5 * t2 + t2 * t2 * (1.0 / 24.0);
    if (d >= hi + 1e-14)
        return true;
    if (d < hi - t2 * t2 * t2 * (1.0 / 720.0) - 1e-14)
        return false;
    return angle_between(a, m) + r <= crit;
}

/* The directions from the points of the sphere (c0, r0) to those of the sphere (c1, r1). */
static cone cone_between(spc_vec3 c0, double r0, spc_vec3 c1, double r1)
{
    spc_vec3 d = spc_sub(c1, c0);
    double len = spc_length(d), r = r0 + r1;
    if (!(len > r))
        return (cone){spc_v3(0, 0, 1), 4.0};
    return (cone){spc_scale(d, 1.0 / len), asin(r / len)};
}

/* Do the caps p and q share a direction? Their axes within the sum of their radii (and 1e-9): as a
 * cosine, which spares an acos per test (the walk's most frequent one); the 1e-12 on the cosine
 * keeps the test at least as wide as the angle's through the rounding of either. Most tests are
 * decided by cos's polynomial bounds, without the call. */
static inline bool cones_meet(cone p, cone q)
{
    double t = p.r + q.r + 1e-9;
    if (t >= SPC_PI)
        return true;
    /* cos t lies between 1 - t^2/2 and that plus t^4/24 (Taylor's bounds, for every t): outside
     * that band widened by 1e-14 (far above the rounding of either side) the answer is the
     * cosine's, which is computed only inside it */
    double d = spc_dot(p.a, q.a), t2 = t * t, lo = 1.0 - 0.5 * t2;
    if (d < lo - 1e-12 - 1e-14)
        return false;
    if (d >= lo + t2 * t2 * (1.0 / 24.0) - 1e-12 + 1e-14)
        return true;
    return d >= cos(t) - 1e-12;
}

static cone cone_neg(cone c) { return (cone){spc_neg(c.a), c.r}; }

/* The cap around the axis `axis` (unit) that holds the n vectors g (the generators of a convex
 * cone: the directions between two convex sets are the conic hull of their corners' differences,
 * and a cap narrower than a hemisphere is convex); any direction if some g is a right angle or more
 * from the axis. */
static cone cone_of(spc_vec3 axis, const spc_vec3 *g, int n)
{
    double cmin = 1.0;
    for (int i = 0; i < n; ++i) {
        double len = spc_length(g[i]);
        double c = len > 0.0 ? spc_dot(axis, g[i]) / len : -1.0;
        if (!(c > 1e-6))
            return (cone){spc_v3(0, 0, 1), 4.0};
        cmin = dmin(cmin, c);
    }
    return (cone){axis, acos(cmin) + 1e-9};
}

/* The directions from the points of face a to those of face b. */
static cone cone_faces(const flat_face *a, const flat_face *b)
{
    spc_vec3 d = spc_sub(b->c, a->c);
    double len = spc_length(d);
    if (a->ncorners == 0 || b->ncorners == 0 || !(len > 0.0))
        return cone_between(a->c, a->rad, b->c, b->rad);
    spc_vec3 g[SPC_FLAT_FACE_CORNERS * SPC_FLAT_FACE_CORNERS];
    int n = 0;
    for (int i = 0; i < a->ncorners; ++i)
        for (int j = 0; j < b->ncorners; ++j)
            g[n++] = spc_sub(b->corners[j], a->corners[i]);
    return cone_of(spc_scale(d, 1.0 / len), g, n);
}

/* What the walk asks of a pair of faces, one from each of two shapes' caches a and b (or both of
 * one shape), none of it depending on the query: the directions between them, and on which sides
 * of each one's plane the other's corners lie (the walk's corner_on_side tests, read as the
 * largest and least signed distance, compared with the query's tolerance). */
typedef struct flat_link {
    const struct flat_cache *to; /* b */
    struct flat_link *next;      /* the next of a's links (flat_link_get) */
    cone cap[SPC_FLAT_MAX_FACES][SPC_FLAT_MAX_FACES]; /* cone_faces(a's face i, b's face j) */
    /* max and min over the corners of a's face i of plane_dist(b's face j, corner) (top, bot),
     * and over the corners of b's face j of plane_dist(a's face i, corner) (rtop, rbot) */
    double top[SPC_FLAT_MAX_FACES][SPC_FLAT_MAX_FACES], bot[SPC_FLAT_MAX_FACES][SPC_FLAT_MAX_FACES];
    double rtop[SPC_FLAT_MAX_FACES][SPC_FLAT_MAX_FACES], rbot[SPC_FLAT_MAX_FACES][SPC_FLAT_MAX_FACES];
    /* per state of b (state_bit: b's face j and the side the path leaves it to, as bit 2 j + s, s
     * 0 interior, 1 exterior), the states of a after which a vertex may take it next: the walk's
     * rules for the sides of convex and one-sided shapes and its corner tests at tolerance 0, any
     * event (so more than the walk takes: a bound, bound_near) */
    uint32_t prev[2 * SPC_FLAT_MAX_FACES];
} flat_link;

/* A vertex's state for the walk's bound on the vertices still needed (walk_run): its face (index
 * in its shape's cache) and the side of it the path leaves to. */
static inline uint32_t state_bit(int face, int side_out) { return 1u << (2 * face + (side_out > 0)); }

typedef struct flat_cache {
    void (*destroy)(void *); /* first member: spc_shape_release calls it */
    bool ok;
    /* closed (every edge shared by two triangles) and convex (every corner on the inner side of
     * every face's plane): a glass cube, slab or prism. A path then meets such a shape's faces from
     * the inside only between two of its own vertices, and never meets it twice from outside. */
    bool convex;
    /* a one-sided mirror (a conductor, not two-sided): it reflects on its faces' exterior side
     * only (the side the BSDF calls the front), so no chain meets a face from the interior */
    bool front_only;
    double eta; /* shape_eta of the shape, read by the walk at every vertex */
    int nfaces;
    flat_face face[SPC_FLAT_MAX_FACES];
    flat_link self;    /* its faces against its own (to: itself) */
    flat_link *links;  /* against other shapes' faces, built on first use (flat_link_get) */
    int ntri;
    int *tri_face;    /* per mesh triangle: its face, or -1 (degenerate) */
    spc_vec3 *corner; /* per triangle in face order: its 3 corners */
    double *tri2d;    /* per triangle in face order: its corners in the face's (u, v) */
    /* per triangle in face order, for in_face: each edge j's vector from corner j to the next and
     * its length (3 j + 0, 1, 2), and the sign of its area (9) */
    double *tri_edge;
} flat_cache;

static void cache_destroy(void *p)
{
    flat_cache *c = p;
    if (!c)
        return;
    for (flat_link *l = c->links, *next; l; l = next) {
        next = l->next;
        free(l);
    }
    free(c->tri_face);
    free(c->corner);
    free(c->tri2d);
    free(c->tri_edge);
    free(c);
}

static spc_vec3 vert(const spc_mesh *m, uint32_t i)
{
    return spc_v3(m->p[3 * i], m->p[3 * i + 1], m->p[3 * i + 2]);
}

/* Signed distance of p from face f's plane (positive on the exterior side). */
static double plane_dist(const flat_face *f, spc_vec3 p) { return spc_dot(f->n, p) - f->d; }

/* The largest and least plane_dist(g, corner) over the corners of face f's triangles (in fc). */
static void corner_extent(const flat_cache *fc, const flat_face *f, const flat_face *g, double *top, double *bot)
{
    double hi = -INFINITY, lo = INFINITY;
    for (int t = f->first; t < f->first + f->count; ++t)
        for (int j = 0; j < 3; ++j) {
            double d = plane_dist(g, fc->corner[3 * t + j]);
            hi = dmax(hi, d);
            lo = dmin(lo, d);
        }
    *top = hi;
    *bot = lo;
}

/* l's tables from a's faces to b's (a == b: a shape against itself); l->to = b. */
static void link_fill(flat_link *l, const flat_cache *a, const flat_cache *b)
{
    l->to = b;
    for (int i = 0; i < a->nfaces; ++i)
        for (int j = 0; j < b->nfaces; ++j) {
            l->cap[i][j] = cone_faces(&a->face[i], &b->face[j]);
            corner_extent(a, &a->face[i], &b->face[j], &l->top[i][j], &l->bot[i][j]);
            corner_extent(b, &b->face[j], &a->face[i], &l->rtop[i][j], &l->rbot[i][j]);
        }
    /* the walk's rules (walk) without the query's tolerance, medium or direction caps: each
     * transition the walk takes is in prev[] */
    memset(l->prev, 0, sizeof l->prev);
    for (int i = 0; i < a->nfaces; ++i)
        for (int so = 0; so < 2; ++so) {
            int prev_out = 2 * so - 1;
            uint32_t from = state_bit(i, prev_out), m = 0;
            for (int j = 0; j < b->nfaces; ++j) {
                if (a == b && i == j)
                    continue;
                for (int side = 1; side >= -1; side -= 2) {
                    if (side < 0 && b->front_only)
                        continue;
                    if (b->convex && (side < 0 ? !(a == b && prev_out < 0) : a == b))
                        continue; /* b's inside only from its own inside; b left is not met again */
                    if (a->convex && prev_out < 0 && !(a == b && side < 0))
                        continue; /* from inside a convex shape, its own faces next */
                    if (!(side > 0 ? l->top[i][j] > 0.0 : l->bot[i][j] < 0.0) ||
                        !(prev_out > 0 ? l->rtop[i][j] > 0.0 : l->rbot[i][j] < 0.0))
                        continue;
                    /* a reflection leaves to the side it arrives from, a refraction to the other
                     * (a one-sided mirror only reflects) */
                    m |= state_bit(j, side);
                    if (!b->front_only)
                        m |= state_bit(j, -side);
                }
            }
            for (int t = 0; t < 2 * b->nfaces; ++t)
                if (m >> t & 1u)
                    l->prev[t] |= from;
        }
}

/* Is p inside the convex shape of fc, beyond tol from every face's plane? */
static bool inside_convex(const flat_cache *fc, spc_vec3 p, double tol)
{
    for (int f = 0; f < fc->nfaces; ++f)
        if (!(plane_dist(&fc->face[f], p) < -tol))
            return false;
    return true;
}

/* Does the reflection arriving along d at a face of normal n reflect totally (ratio: n(arriving
 * side) / n(other side))? */
static bool total_reflection(spc_vec3 d, spc_vec3 n, double ratio)
{
    double c = spc_dot(d, n);
    return ratio * sqrt(dmax(0.0, 1.0 - c * c)) > 1.0;
}

static bool same_point(spc_vec3 a, spc_vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

/* Is the mesh closed (each triangle edge met, reversed, by exactly one other triangle edge, by
 * position: a cube's faces have vertices of their own) and convex (every corner within tol of the
 * inner side of every face's plane)? At most SPC_FLAT_CONVEX_TRIS triangles are checked. */
#define SPC_FLAT_CONVEX_TRIS 512
static bool closed_convex(const flat_cache *c, const spc_mesh *m, double scale)
{
    if (c->ntri == 0 || c->ntri > SPC_FLAT_CONVEX_TRIS || (size_t)c->ntri != m->ntris)
        return false;
    for (int f = 0; f < c->nfaces; ++f)
        for (int j = 0; j < 3 * c->ntri; ++j)
            if (plane_dist(&c->face[f], c->corner[j]) > 1e-7 * scale)
                return false;
    /* corner[] holds each triangle's corners in its winding order (the mesh's) */
    for (int t = 0; t < c->ntri; ++t)
        for (int e = 0; e < 3; ++e) {
            spc_vec3 a = c->corner[3 * t + e], b = c->corner[3 * t + (e + 1) % 3];
            int twins = 0;
            for (int u = 0; u < c->ntri; ++u)
                for (int g = 0; g < 3 && u != t; ++g)
                    twins += same_point(c->corner[3 * u + g], b) && same_point(c->corner[3 * u + (g + 1) % 3], a);
            if (twins != 1)
                return false;
        }
    return true;
}

/* Groups s's triangles by plane; c->ok false if they make more than SPC_FLAT_MAX_FACES planes or
 * memory runs out. */
static void cache_build(const spc_shape *s, flat_cache *c)
{
    const spc_mesh *m = &s->mesh;
    size_t nt = m->ntris;
    double scale = spc_length(spc_sub(s->bbox_max, s->bbox_min));
    if (nt == 0 || !(scale > 0.0) || !isfinite(scale))
        return;
    c->tri_face = malloc(nt * sizeof *c->tri_face);
    c->corner = malloc(3 * nt * sizeof *c->corner);
    c->tri2d = malloc(6 * nt * sizeof *c->tri2d);
    c->tri_edge = malloc(10 * nt * sizeof *c->tri_edge);
    if (!c->tri_face || !c->corner || !c->tri2d || !c->tri_edge)
        return;
    for (size_t t = 0; t < nt; ++t) {
        spc_vec3 a = vert(m, m->idx[3 * t]), b = vert(m, m->idx[3 * t + 1]), e = vert(m, m->idx[3 * t + 2]);
        spc_vec3 n = spc_cross(spc_sub(b, a), spc_sub(e, a));
        double len = spc_length(n);
        c->tri_face[t] = -1;
        if (!(len > 1e-14 * scale * scale))
            continue;
        n = spc_scale(n, (s->flip_normals ? -1.0 : 1.0) / len);
        double d = spc_dot(n, a);
        int f = 0;
        for (; f < c->nfaces; ++f)
            if (spc_dot(n, c->face[f].n) > 1.0 - 1e-10 && fabs(d - c->face[f].d) < 1e-7 * scale)
                break;
        if (f == c->nfaces) {
            if (c->nfaces == SPC_FLAT_MAX_FACES)
                return;
            flat_face *F = &c->face[c->nfaces++];
            memset(F, 0, sizeof *F);
            F->n = n;
            F->d = d;
            F->o = a;
            spc_frame fr = spc_frame_from_n(n);
            F->u = fr.s;
            F->v = fr.t;
        }
        c->tri_face[t] = f;
        c->face[f].count++;
    }
    /* the triangles in face order */
    int at = 0;
    for (int f = 0; f < c->nfaces; ++f) {
        c->face[f].first = at;
        at += c->face[f].count;
        c->face[f].count = 0;
    }
    for (size_t t = 0; t < nt; ++t) {
        int f = c->tri_face[t];
        if (f < 0)
            continue;
        flat_face *F = &c->face[f];
        int slot = F->first + F->count++;
        for (int j = 0; j < 3; ++j) {
            spc_vec3 p = vert(m, m->idx[3 * t + j]);
            c->corner[3 * slot + j] = p;
            spc_vec3 r = spc_sub(p, F->o);
            c->tri2d[6 * slot + 2 * j] = spc_dot(r, F->u);
            c->tri2d[6 * slot + 2 * j + 1] = spc_dot(r, F->v);
        }
        const double *tc = c->tri2d + 6 * slot;
        double *te = c->tri_edge + 10 * slot;
        for (int j = 0; j < 3; ++j) {
            const double *a = tc + 2 * j, *b = tc + 2 * ((j + 1) % 3);
            te[3 * j] = b[0] - a[0];
            te[3 * j + 1] = b[1] - a[1];
            te[3 * j + 2] = sqrt(te[3 * j] * te[3 * j] + te[3 * j + 1] * te[3 * j + 1]);
        }
        double area = (tc[2] - tc[0]) * (tc[5] - tc[1]) - (tc[4] - tc[0]) * (tc[3] - tc[1]);
        te[9] = area < 0.0 ? -1.0 : 1.0;
    }
    c->ntri = at;
    for (int f = 0; f < c->nfaces; ++f) {
        flat_face *F = &c->face[f];
        spc_vec3 lo = spc_v3(INFINITY, INFINITY, INFINITY), hi = spc_neg(lo);
        for (int j = 3 * F->first; j < 3 * (F->first + F->count); ++j) {
            lo = spc_v3(dmin(lo.x, c->corner[j].x), dmin(lo.y, c->corner[j].y), dmin(lo.z, c->corner[j].z));
            hi = spc_v3(dmax(hi.x, c->corner[j].x), dmax(hi.y, c->corner[j].y), dmax(hi.z, c->corner[j].z));
        }
        F->c = spc_scale(spc_add(lo, hi), 0.5);
        F->rad = 0.0;
        F->ncorners = 0;
        bool all = true;
        for (int j = 3 * F->first; j < 3 * (F->first + F->count); ++j) {
            F->rad = dmax(F->rad, spc_distance(F->c, c->corner[j]));
            bool seen = false;
            for (int q = 0; q < F->ncorners && !seen; ++q)
                seen = same_point(F->corners[q], c->corner[j]);
            if (seen || !all)
                continue;
            if (F->ncorners == SPC_FLAT_FACE_CORNERS)
                all = false;
            else
                F->corners[F->ncorners++] = c->corner[j];
        }
        if (!all)
            F->ncorners = 0;
    }
    c->ok = c->nfaces > 0;
    c->convex = closed_convex(c, m, scale);
    c->front_only = s->bsdf->type == SPC_BSDF_CONDUCTOR;
    link_fill(&c->self, c, c);
}

/* May s be a flat chain shape at all (before its faces are counted)? */
static bool flat_kind(const spc_shape *s)
{
    if (!s || s->type != SPC_SHAPE_MESH || s->emitter || !s->bsdf || (s->mesh.n && !s->face_normals))
        return false;
    const spc_bsdf *b = s->bsdf;
    if (b->type == SPC_BSDF_TWOSIDED) {
        /* a mirror on both sides: smooth conductors only (a normal map is plane_chains.h's) */
        for (int i = 0; i < 2; ++i)
            if (b->nested[i] && b->nested[i]->type != SPC_BSDF_CONDUCTOR)
                return false;
        return b->nested[0] != NULL;
    }
    return b->type == SPC_BSDF_DIELECTRIC || b->type == SPC_BSDF_CONDUCTOR;
}

/* eta = int_ior / ext_ior of a dielectric, 0 for a conductor. */
static double shape_eta(const spc_shape *s)
{
    double eta = 0.0;
    spc_bsdf_is_specular_interface(s->bsdf, &eta);
    return eta;
}

/* The shape's faces, built on first use and published atomically (as plane_chains.c's map); NULL
 * if s is not a shape these chains handle. A cache is only ever built for a shape of flat_kind (a
 * property of the shape that does not change), so a published one answers without that test: the
 * walk asks for every caster at every vertex. flat_build builds and publishes it (s not NULL and
 * not yet published); flat_get reads it. */
static const flat_cache *flat_build(const spc_shape *s)
{
    void **slot = (void **)&((spc_shape *)s)->flat_cache;
    if (!flat_kind(s))
        return NULL;
    flat_cache *fc = calloc(1, sizeof *fc);
    if (!fc)
        return NULL;
    fc->destroy = cache_destroy;
    fc->eta = shape_eta(s);
    cache_build(s, fc);
    flat_cache *cur;
    void *expected = NULL;
    if (__atomic_compare_exchange_n(slot, &expected, (void *)fc, false, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE)) {
        cur = fc;
    } else {
        cache_destroy(fc); /* another thread won */
        cur = expected;
    }
    return cur->ok ? cur : NULL;
}

/* The published cache read inline (the walk asks at every vertex, for every caster); the first
 * call per shape, and every call for a shape of another kind, goes to flat_build. */
static inline const flat_cache *flat_get(const spc_shape *s)
{
    if (!s)
        return NULL;
    const flat_cache *cur = __atomic_load_n((void *const *)&s->flat_cache, __ATOMIC_ACQUIRE);
    if (cur)
        return cur->ok ? cur : NULL;
    return flat_build(s);
}

bool spc_flat_chain_shape(const spc_shape *s) { return flat_get(s) != NULL; }

bool spc_flat_chain_closed(const spc_shape *s)
{
    const flat_cache *fc = flat_get(s);
    return fc && fc->convex;
}

int spc_flat_shape_planes(const spc_shape *s, spc_vec3 *n, double *d, int max)
{
    const flat_cache *fc = flat_get(s);
    int k = 0;
    for (int i = 0; fc && i < fc->nfaces && k < max; ++i, ++k) {
        n[k] = fc->face[i].n;
        d[k] = fc->face[i].d;
    }
    return k;
}

/* The index of refraction on side `side` (+1 exterior, -1 interior) of a face of a shape whose eta
 * is eta (0: a conductor, whose sides have no index of their own: -1). */
static double side_index(double eta, int side)
{
    if (!(eta > 0.0))
        return -1.0;
    return side > 0 ? 1.0 : eta;
}

/* ---- the convex problem ---- */

/* One vertex of a face sequence. */
typedef struct flat_vertex {
    const spc_shape *s;
    int shape_index;
    int slot;         /* the caster's slot in the walk */
    const flat_cache *fc;
    const flat_face *f;
    int side_in;  /* side of the face the path arrives from: +1 exterior, -1 interior */
    int side_out; /* side it leaves to */
    unsigned char event;
    double eta;  /* the shape's (0: conductor) */
    double tir;  /* > 0: a reflection off glass in a longer chain, which must be total: the ratio
                    n(arriving side) / n(other side) that sin(incidence) times must exceed 1 */
} flat_vertex;

typedef struct flat_problem {
    spc_vec3 x, y;
    int k;
    flat_vertex v[SPC_FLAT_MAX_VERTICES];
    double seg[SPC_FLAT_MAX_VERTICES + 1]; /* index along each segment */
    double scale;                          /* |y - x| and the faces' extent */
    double uu[SPC_FLAT_MAX_VERTICES][2][2]; /* U_i^T U_{i+1}: consecutive faces' tangents (minimize) */
    bool bound;                             /* end a solve by lower_bound_on_faces (tests switch it off) */
    bool parallel;                          /* start from parallel_start where it applies (tests switch it off) */
} flat_problem;

static spc_vec3 point_of(const flat_face *f, const double *s) { return spc_add(f->o, spc_add(spc_scale(f->u, s[0]), spc_scale(f->v, s[1]))); }

/* L at the plane coordinates s (2 k numbers), each |r| smoothed to sqrt(|r|^2 + mu^2) (mu 0: L
 * itself); the points written to p[0..k+1] (x and y at the ends). */
static double path_length(const flat_problem *P, const double *s, double mu, spc_vec3 *p)
{
    p[0] = P->x;
    for (int i = 0; i < P->k; ++i)
        p[i + 1] = point_of(P->v[i].f, s + 2 * i);
    p[P->k + 1] = P->y;
    double L = 0.0;
    for (int j = 0; j <= P->k; ++j) {
        spc_vec3 r = spc_sub(p[j + 1], p[j]);
        L += P->seg[j] * sqrt(spc_dot(r, r) + mu * mu);
    }
    return L;
}

/* Solves A z = b for the symmetric positive definite n x n matrix A (row-major, destroyed) by
 * Cholesky; false if A is not positive definite. A is block tridiagonal with 2x2 blocks (a vertex
 * couples to its neighbours only), and so is its factor: the loops run over those blocks alone, the
 * same operations in the same order as the dense factorization less its products with zeros. */
static bool cholesky_solve(double *A, int n, const double *b, double *z)
{
#define BAND_LO(i) ((i) >= 4 ? 2 * ((i) / 2 - 1) : 0) /* the first column of row i in the band */
    for (int j = 0; j < n; ++j) {
        double dsum = A[j * n + j];
        for (int k = BAND_LO(j); k < j; ++k)
            dsum -= A[j * n + k] * A[j * n + k];
        if (!(dsum > 0.0))
            return false;
        double l = sqrt(dsum);
        A[j * n + j] = l;
        int last = 2 * (j / 2) + 3 < n ? 2 * (j / 2) + 3 : n - 1; /* the band's last row in column j */
        for (int i = j + 1; i <= last; ++i) {
            double v = A[i * n + j];
            for (int k = BAND_LO(i); k < j; ++k)
                v -= A[i * n + k] * A[j * n + k];
            A[i * n + j] = v / l;
        }
    }
    for (int i = 0; i < n; ++i) {
        double v = b[i];
        for (int k = BAND_LO(i); k < i; ++k)
            v -= A[i * n + k] * z[k];
        z[i] = v / A[i * n + i];
    }
    for (int i = n - 1; i >= 0; --i) {
        double v = z[i];
        int last = 2 * (i / 2) + 3 < n ? 2 * (i / 2) + 3 : n - 1;
        for (int k = i + 1; k <= last; ++k)
            v -= A[k * n + i] * z[k];
        z[i] = v / A[i * n + i];
    }
#undef BAND_LO
    return true;
}

/* The 2x2 block c (U_a^T U_b - (U_a^T e)(U_b^T e)^T) of a segment's Hessian term c U_a^T (I - e
 * e^T) U_b (c = its index over its length, e its unit direction) between the tangent bases of two
 * faces: uu = U_a^T U_b (the identity for one face), ae = U_a^T e, be = U_b^T e. */
static void block(double c, const double uu[2][2], const double ae[2], const double be[2], double out[2][2])
{
    for (int r = 0; r < 2; ++r)
        for (int q = 0; q < 2; ++q)
            out[r][q] = c * (uu[r][q] - ae[r] * be[q]);
}

/* A lower bound on L (mu 0) over the box C of the sequence: the points whose every vertex lies in
 * the convex hull of its face's corners. For any vectors lambda_j with |lambda_j| <= eta_j,
 * eta_j |r_j(c)| >= lambda_j . r_j(c) (Cauchy-Schwarz), and the sum of the right sides is affine
 * in c. With lambda_j = eta_j r_j(s) / len_j (len_j = sqrt(|r_j(s)|^2 + mu^2), the smoothed
 * terms' gradients at s), that sum is
 *
 *     L_mu(s) - sum_j eta_j mu^2 / len_j + g . (c - s),
 *
 * g the gradient of L_mu at s, and a linear function takes its minimum over the hull at a corner
 * (per vertex: C is a product of polygons). So
 *
 *     min over C of L  >=  L_mu(s) - mu^2 sum_j eta_j / len_j + sum_i min over corners c of face i of g_i . (c - s_i).
 *
 * (the smoothing's term is mu^2 eta_j / len_j <= mu eta_j, and far smaller on the segments longer
 * than mu; `smooth` holds mu^2 sum_j eta_j / len_j). The corners are those of the face's triangles
 * in its (u, v) coordinates, the same coordinates s uses. Each vertex's term is lowered by |g_i|
 * times SPC_FLAT_BOUND_SLACK of the problem's size: a root is accepted up to SPC_FLAT_EDGE_REL
 * outside its triangles' edges (in_face), which moves it that far from the hull at most by that
 * distance over the sine of half the triangles' sharpest angle. */
static double lower_bound_on_faces(const flat_problem *P, double smooth, const double *s, const double *g, double L)
{
    double lb = L - smooth;
    for (int i = 0; i < P->k; ++i) {
        const flat_face *f = P->v[i].f;
        const double *c = P->v[i].fc->tri2d + 6 * f->first;
        double gu = g[2 * i], gv = g[2 * i + 1], su = s[2 * i], sv = s[2 * i + 1];
        double m = INFINITY;
        for (int j = 0; j < 3 * f->count; ++j)
            m = dmin(m, gu * (c[2 * j] - su) + gv * (c[2 * j + 1] - sv));
        lb += m - sqrt(gu * gu + gv * gv) * SPC_FLAT_BOUND_SLACK * P->scale;
    }
    return lb;
}

/* The t in (0, 1] that minimizes L_mu along the Newton step `step` (in the faces' coordinates)
 * from the points p, to a relative SPC_FLAT_LINE_TOL. The segments are affine in t, r_j + t dr_j,
 * so phi(t) = sum_j eta_j sqrt(|r_j + t dr_j|^2 + mu^2) is convex in t with phi'(0) < 0 (a descent
 * direction), and each term of phi' changes sign where its segment is shortest along the line, at
 * t_j = -r_j . dr_j / |dr_j|^2: phi' < 0 below the least t_j and > 0 above the largest, a bracket
 * that safeguarded Newton steps on phi' (bisection where they leave it) narrow. Where a segment has
 * collapsed to the smoothing's width, Newton's full step overshoots by up to (|r_j| / mu)^2 (the
 * smoothed |r_j| has curvature mu^2 / len^3 along r_j), and halving from 1 took a dozen tries and
 * left the other vertices where they were. */
static double line_min(const flat_problem *P, const spc_vec3 *p, const double *step, double mu)
{
    const int k = P->k;
    spc_vec3 r[SPC_FLAT_MAX_VERTICES + 1], dr[SPC_FLAT_MAX_VERTICES + 1], dp[SPC_FLAT_MAX_VERTICES + 2];
    dp[0] = dp[k + 1] = spc_v3(0, 0, 0);
    for (int i = 0; i < k; ++i)
        dp[i + 1] = spc_add(spc_scale(P->v[i].f->u, step[2 * i]), spc_scale(P->v[i].f->v, step[2 * i + 1]));
    double lo = 0.0, hi = 1.0, tmin = INFINITY, tmax = -INFINITY;
    for (int j = 0; j <= k; ++j) {
        r[j] = spc_sub(p[j + 1], p[j]);
        dr[j] = spc_sub(dp[j + 1], dp[j]);
        double dd = spc_dot(dr[j], dr[j]);
        if (dd > 0.0) {
            double tj = -spc_dot(r[j], dr[j]) / dd;
            tmin = dmin(tmin, tj);
            tmax = dmax(tmax, tj);
        }
    }
    if (tmax > 0.0 && tmax < hi)
        hi = tmax;
    if (tmin > 0.0 && tmin < hi)
        lo = tmin;
    double t = 0.5 * (lo + hi);
    for (int it = 0; it < SPC_FLAT_LINE_STEPS && hi - lo > SPC_FLAT_LINE_TOL * hi; ++it) {
        double d1 = 0.0, d2 = 0.0;
        for (int j = 0; j <= k; ++j) {
            spc_vec3 q = spc_add(r[j], spc_scale(dr[j], t));
            double len2 = spc_dot(q, q) + mu * mu, len = sqrt(len2), a = spc_dot(q, dr[j]);
            d1 += P->seg[j] * a / len;
            d2 += P->seg[j] * (spc_dot(dr[j], dr[j]) * len2 - a * a) / (len2 * len);
        }
        if (d1 > 0.0)
            hi = t;
        else
            lo = t;
        double tn = d2 > 0.0 ? t - d1 / d2 : -1.0;
        t = tn > lo && tn < hi ? tn : 0.5 * (lo + hi);
    }
    return lo > 0.0 ? lo : t;
}

/* Does the minimum of L over C (lower_bound_on_faces) provably have a segment shorter than the kink
 * test's 1e3 SPC_FLAT_SIDE_REL of the problem's size (minimize), so that the sequence has no chain?
 * At the smoothed problem's iterate s, with lambda_j = eta_j r_j / len_j (|lambda_j| < eta_j),
 * lower_bound_on_faces's argument bounds sum_j lambda_j . r_j(c) from below by lb (the bound at s)
 * for every c in C, and for each j
 *
 *     L(c) - sum_i lambda_i . r_i(c) = sum_i (eta_i |r_i(c)| - lambda_i . r_i(c))
 *                                    >= (eta_j - |lambda_j|) |r_j(c)|.
 *
 * L's minimum is at most L_mu(s), so there (eta_j - |lambda_j|) |r_j| <= gap = L_mu(s) - lb, with
 * eta_j - |lambda_j| = eta_j mu^2 / (len_j (len_j + |r_j|)): a segment collapsed to the smoothing's
 * width mu has at most a few mu at the minimum once the gradient is small. With the last stage's
 * mu (1e-7 of the size) this ends the sequences whose minimum is a kink (most of those solved
 * through two slabs) in a few steps instead of the stage's full count: the gradient's rounding
 * (unit vectors of segments 1e-7 long) kept them above the stage's tolerance. */
static bool kink_certain(const flat_problem *P, const spc_vec3 *p, double mu, double gap)
{
    const double limit = 1e3 * SPC_FLAT_SIDE_REL * P->scale;
    for (int j = 0; j <= P->k; ++j) {
        spc_vec3 r = spc_sub(p[j + 1], p[j]);
        double r2 = spc_dot(r, r), len = sqrt(r2 + mu * mu);
        if (gap * len * (len + sqrt(r2)) < limit * P->seg[j] * mu * mu)
            return true;
    }
    return false;
}

/* Newton's steps on L smoothed by mu from s (updated, with p and *L) until each vertex's mismatch
 * is below tol or `steps` are spent; returns the last mismatch (the largest component of the
 * gradient), or -1 where the step is undefined or the line search finds no decrease. *lb holds the
 * largest lower bound on L over the faces' box C seen so far (lower_bound_on_faces, updated at
 * every step); L's minimum is at most L_mu at every iterate, so where the bound exceeds that, the
 * minimum lies outside C, no root of this sequence passes in_face, and newton returns -2 (where
 * P->bound); -3 where the same bound proves that the minimum over C is a kink (kink_certain). */
static double newton(const flat_problem *P, double mu, double *s, spc_vec3 *p, double *L, int steps, double tol,
                     double *lb)
{
    const int k = P->k, n = 2 * k;
    double gmax = 0.0;
    for (int it = 0; it <= steps; ++it) {
        spc_vec3 e[SPC_FLAT_MAX_VERTICES + 1];
        double cj[SPC_FLAT_MAX_VERTICES + 1];
        for (int j = 0; j <= k; ++j) {
            spc_vec3 r = spc_sub(p[j + 1], p[j]);
            double len = sqrt(spc_dot(r, r) + mu * mu);
            if (!(len > 0.0))
                return -1.0;
            e[j] = spc_scale(r, 1.0 / len);
            cj[j] = P->seg[j] / len;
        }
        double g[2 * SPC_FLAT_MAX_VERTICES], smooth = 0.0;
        for (int j = 0; j <= k; ++j)
            smooth += cj[j];
        smooth *= mu * mu;
        gmax = 0.0;
        for (int i = 0; i < k; ++i) {
            spc_vec3 t = spc_sub(spc_scale(e[i], P->seg[i]), spc_scale(e[i + 1], P->seg[i + 1]));
            g[2 * i] = spc_dot(t, P->v[i].f->u);
            g[2 * i + 1] = spc_dot(t, P->v[i].f->v);
            gmax = dmax(gmax, dmax(fabs(g[2 * i]), fabs(g[2 * i + 1])));
        }
        double lb_here = lower_bound_on_faces(P, smooth, s, g, *L);
        *lb = dmax(*lb, lb_here);
        if (P->bound && *lb > *L + SPC_FLAT_BOUND_SLACK * P->scale)
            return -2.0; /* every point of C is longer than this one: the minimum lies outside C */
        if (P->bound && mu > 0.0 && kink_certain(P, p, mu, *L - lb_here))
            return -3.0; /* the minimum over C has a segment shorter than the kink test's */
        if (gmax < tol || it == steps)
            return gmax;
        double H[4 * SPC_FLAT_MAX_VERTICES * SPC_FLAT_MAX_VERTICES], diag = 0.0;
        memset(H, 0, sizeof H);
        /* each face's tangents against the segments arriving at (ea) and leaving (el) its vertex */
        double ea[SPC_FLAT_MAX_VERTICES][2], el[SPC_FLAT_MAX_VERTICES][2];
        for (int i = 0; i < k; ++i) {
            const flat_face *f = P->v[i].f;
            ea[i][0] = spc_dot(f->u, e[i]);
            ea[i][1] = spc_dot(f->v, e[i]);
            el[i][0] = spc_dot(f->u, e[i + 1]);
            el[i][1] = spc_dot(f->v, e[i + 1]);
        }
        static const double eye[2][2] = {{1.0, 0.0}, {0.0, 1.0}};
        for (int i = 0; i < k; ++i) {
            double B[2][2], B2[2][2];
            block(cj[i], eye, ea[i], ea[i], B);
            block(cj[i + 1], eye, el[i], el[i], B2);
            for (int r = 0; r < 2; ++r)
                for (int c = 0; c < 2; ++c) {
                    B[r][c] += B2[r][c];
                    H[(2 * i + r) * n + 2 * i + c] = B[r][c];
                }
            diag = dmax(diag, B[0][0] + B[1][1]);
            if (i + 1 < k) {
                block(cj[i + 1], P->uu[i], el[i], ea[i + 1], B);
                for (int r = 0; r < 2; ++r)
                    for (int c = 0; c < 2; ++c) {
                        H[(2 * i + r) * n + 2 * (i + 1) + c] = -B[r][c];
                        H[(2 * (i + 1) + c) * n + 2 * i + r] = -B[r][c];
                    }
            }
        }
        for (int i = 0; i < n; ++i)
            H[i * n + i] += 1e-12 * diag;
        double step[2 * SPC_FLAT_MAX_VERTICES], rhs[2 * SPC_FLAT_MAX_VERTICES];
        for (int i = 0; i < n; ++i)
            rhs[i] = -g[i];
        if (!cholesky_solve(H, n, rhs, step))
            return -1.0;
        double slope = 0.0;
        for (int i = 0; i < n; ++i)
            slope += g[i] * step[i];
        /* backtracking: the full step near the minimum; where it fails, first the step to L_mu's
         * minimum along the line (line_min), then halves of it */
        double t = 1.0, s2[2 * SPC_FLAT_MAX_VERTICES], L2 = *L;
        spc_vec3 p2[SPC_FLAT_MAX_VERTICES + 2];
        int tries = 0;
        for (; tries < 40; ++tries, t *= 0.5) {
            if (tries == 1)
                t = line_min(P, p, step, mu);
            for (int i = 0; i < n; ++i)
                s2[i] = s[i] + t * step[i];
            L2 = path_length(P, s2, mu, p2);
            if (L2 <= *L + 1e-4 * t * slope + SPC_FLAT_ROUNDING_ULPS * DBL_EPSILON * fabs(*L))
                break;
        }
        if (tries == 40)
            return gmax; /* no decrease left to find in double precision */
        memcpy(s, s2, sizeof(double) * (size_t)n);
        memcpy(p, p2, sizeof(spc_vec3) * (size_t)(k + 2));
        *L = L2;
    }
    return gmax;
}

/* ---- the closed form where the refracting faces are parallel ----
 *
 * A reflection at a plane mirrors the rest of the path, which keeps every segment's length: with
 * the path after each reflecting vertex mirrored across its plane (unfolded), L is the optical
 * length of a path from x to y' (y mirrored by every reflection) that only refracts, and the
 * reflecting planes are where it crosses them. Where the refracting planes are then parallel (a
 * slab's two faces, a box's top and bottom with total internal reflections off its sides, stacked
 * parallel slabs), Snell's law at each says that the tangential part tau of eta_j e_j is the same
 * on every segment (e_j its unit direction), so segment j, of height h_j across the planes, moves
 *
 *     w_j(a) = |h_j| a / sqrt(eta_j^2 - a^2)      (a = |tau| < the least eta_j)
 *
 * along the tangential offset D of y' from x, and the sum of the w_j, increasing in a from 0 to
 * infinity, equals |D|: one equation in a. Its root gives every vertex, a stationary point of L
 * and so (L convex) its minimum; minimize takes it as the start of Newton's steps on L itself,
 * which certify it (the gradient test) or, where they do not converge, leave the sequence to the
 * smoothed stages as before. A few dozen flops instead of a dozen Newton steps on the k-vertex
 * system: a slab's chains, its total internal reflections, and stacked slabs' four interfaces.
 *
 * A chain of the sequence crosses each reflecting plane between its neighbours, which lie on
 * opposite sides of the plane once unfolded, and its refracting vertices are then a stationary point
 * of the problem without the reflecting planes, whose only one is the closed form's. So where both
 * ends of the closed form's segment lie on one side of a reflecting plane, beyond the error that
 * faces parallel only to SPC_FLAT_PARALLEL_COS leave in it (SPC_FLAT_CROSS_REL), the sequence has no
 * chain: most of a slab's sequences with total internal reflections off its sides, which the smoothed
 * stages took a dozen steps each to end. */

/* An isometry p -> R p + t (R orthogonal, by its rows). */
typedef struct flat_iso {
    spc_vec3 r[3], t;
} flat_iso;

static spc_vec3 iso_apply(const flat_iso *T, spc_vec3 p)
{
    return spc_v3(spc_dot(T->r[0], p) + T->t.x, spc_dot(T->r[1], p) + T->t.y, spc_dot(T->r[2], p) + T->t.z);
}

static spc_vec3 iso_linear(const flat_iso *T, spc_vec3 v)
{
    return spc_v3(spc_dot(T->r[0], v), spc_dot(T->r[1], v), spc_dot(T->r[2], v));
}

/* The point q of the unfolded space taken back: R^T (q - t). */
static spc_vec3 iso_invert(const flat_iso *T, spc_vec3 q)
{
    spc_vec3 d = spc_sub(q, T->t);
    return spc_add(spc_add(spc_scale(T->r[0], d.x), spc_scale(T->r[1], d.y)), spc_scale(T->r[2], d.z));
}

/* T followed after the reflection across the plane n . p = d: p -> T(p - 2 (n . p - d) n). */
static void iso_reflect(flat_iso *T, spc_vec3 n, double d)
{
    spc_vec3 c = iso_linear(T, spc_scale(n, 2.0 * d));
    for (int i = 0; i < 3; ++i)
        T->r[i] = spc_sub(T->r[i], spc_scale(n, 2.0 * spc_dot(T->r[i], n)));
    T->t = spc_add(T->t, c);
}

/* Refracting planes' normals count as parallel within this (their cosine's distance from 1: angles
 * to 1.4e-6): far above the rounding of a cube's normals from single-precision vertices (1e-7 of
 * an angle, 1e-14 of the cosine). Newton's steps on L absorb the rest (SPC_FLAT_CLOSED_STEPS). */
#define SPC_FLAT_PARALLEL_COS 1e-12

/* The closed form's vertices move by at most a few times that angle times the problem's size from
 * the exact minimum's (each segment's tangential part changes by at most the change of the total
 * offset): a reflecting plane that both ends of a segment lie beyond by this share of the size is
 * not crossed by the exact minimum either (70 times that error). */
#define SPC_FLAT_CROSS_REL 1e-4

/* Newton's steps on L from the closed form: none where the faces are parallel to the last bit, one or
 * two where single-precision vertices tilt them by 1e-7; past these the sequence goes to the
 * smoothed stages. */
#define SPC_FLAT_CLOSED_STEPS 3

/* The vertices' plane coordinates s (2 k numbers) of the minimum of L where the refracting faces
 * of P's sequence are parallel once unfolded (above): returns 1; -1 where a reflecting plane is not
 * crossed (no chain); 0 where the faces are not parallel or the closed form does not apply (a
 * segment within the planes, a reflecting plane crossed too near an end). */
static int parallel_start(const flat_problem *P, double *s)
{
    const int k = P->k;
    const double tiny = SPC_FLAT_SIDE_REL * P->scale;
    flat_iso T = {{spc_v3(1, 0, 0), spc_v3(0, 1, 0), spc_v3(0, 0, 1)}, spc_v3(0, 0, 0)};
    flat_iso Tv[SPC_FLAT_MAX_VERTICES];
    spc_vec3 N = spc_v3(0, 0, 0);
    /* the refracting vertices' heights along N, and the merged segments' indices */
    double z[SPC_FLAT_MAX_VERTICES + 2], eta[SPC_FLAT_MAX_VERTICES + 1];
    int m = 0, seg_of[SPC_FLAT_MAX_VERTICES]; /* per vertex: the merged segment it lies on (a reflection) or ends */
    eta[0] = P->seg[0];
    for (int i = 0; i < k; ++i) {
        const flat_face *f = P->v[i].f;
        Tv[i] = T;
        spc_vec3 n = iso_linear(&T, f->n);
        if (P->v[i].event == SPC_CHAIN_REFLECT) {
            seg_of[i] = m;
            iso_reflect(&T, f->n, f->d);
            continue;
        }
        if (m == 0)
            N = n;
        else if (!(fabs(spc_dot(n, N)) > 1.0 - SPC_FLAT_PARALLEL_COS))
            return 0;
        seg_of[i] = m;
        z[++m] = spc_dot(N, iso_apply(&T, f->o));
        eta[m] = P->seg[i + 1];
    }
    spc_vec3 y = iso_apply(&T, P->y), xy = spc_sub(y, P->x);
    /* the path in the unfolded space: q[0] = x, q[j] on the j-th refracting plane, q[m + 1] = y' */
    spc_vec3 q[SPC_FLAT_MAX_VERTICES + 2];
    q[0] = P->x;
    if (m == 0) {
        q[1] = y;
    } else {
        z[0] = spc_dot(N, P->x);
        z[m + 1] = spc_dot(N, y);
        double emin = INFINITY, h[SPC_FLAT_MAX_VERTICES + 1];
        for (int j = 0; j <= m; ++j) {
            h[j] = fabs(z[j + 1] - z[j]);
            if (!(h[j] > tiny) || !(eta[j] > 0.0))
                return 0;
            emin = dmin(emin, eta[j]);
        }
        spc_vec3 D = spc_sub(xy, spc_scale(N, spc_dot(N, xy)));
        double dl = spc_length(D), a = 0.0;
        spc_vec3 Dh = spc_v3(0, 0, 0);
        if (dl > tiny) {
            Dh = spc_scale(D, 1.0 / dl);
            /* sum_j w_j(a) = dl: increasing and convex in a on [0, emin); Newton's steps kept in
             * the bracket, bisection where they leave it */
            double lo = 0.0, hi = emin;
            a = 0.5 * emin;
            for (int it = 0; it < 100; ++it) {
                double F = -dl, dF = 0.0;
                for (int j = 0; j <= m; ++j) {
                    double c2 = eta[j] * eta[j] - a * a, c = sqrt(c2);
                    F += h[j] * a / c;
                    dF += h[j] * eta[j] * eta[j] / (c2 * c);
                }
                if (F > 0.0)
                    hi = a;
                else
                    lo = a;
                double an = a - F / dF;
                if (!(an > lo && an < hi))
                    an = 0.5 * (lo + hi);
                if (fabs(an - a) <= 1e-15 * emin || hi - lo <= 1e-15 * emin) {
                    a = an;
                    break;
                }
                a = an;
            }
            if (!(a < emin))
                return 0;
        }
        for (int j = 0; j <= m; ++j) {
            double w = h[j] * a / sqrt(eta[j] * eta[j] - a * a);
            q[j + 1] = spc_add(q[j], spc_add(spc_scale(Dh, w), spc_scale(N, z[j + 1] - z[j])));
        }
    }
    for (int i = 0, r = 0; i < k; ++i) {
        const flat_face *f = P->v[i].f;
        spc_vec3 pt;
        if (P->v[i].event == SPC_CHAIN_REFLECT) {
            /* where the merged segment crosses the (unfolded) reflecting plane */
            spc_vec3 a = q[seg_of[i]], b = q[seg_of[i] + 1];
            spc_vec3 n = iso_linear(&Tv[i], f->n), o = iso_apply(&Tv[i], f->o);
            double da = spc_dot(n, spc_sub(a, o)), db = spc_dot(n, spc_sub(b, o));
            double far = SPC_FLAT_CROSS_REL * P->scale;
            if ((da > far && db > far) || (da < -far && db < -far))
                return -1;
            if (!(fabs(da) > tiny && fabs(db) > tiny && (da > 0.0) != (db > 0.0)))
                return 0;
            pt = iso_invert(&Tv[i], spc_add(a, spc_scale(spc_sub(b, a), da / (da - db))));
        } else {
            pt = iso_invert(&Tv[i], q[++r]);
        }
        spc_vec3 d = spc_sub(pt, f->o);
        s[2 * i] = spc_dot(d, f->u);
        s[2 * i + 1] = spc_dot(d, f->v);
    }
    return 1;
}

/* Minimizes L from the straight line x -> y; writes the vertices to p[1..k] (p[0] = x, p[k+1] =
 * y). False if it did not converge or a segment has no length (the minimum is a kink: no chain).
 * L is not smooth where a segment vanishes, and Newton's method stalls near such a kink on its way
 * (a vertex crossing the edge where two faces' planes meet); so it runs on L with each |r|
 * smoothed to sqrt(|r|^2 + mu^2), a smooth, strictly convex function, for mu falling from a tenth
 * of the problem's size by SPC_FLAT_MU_FALL per stage (a path-following homotopy), then on L.
 * Adds 1 to t->bound_ends where a bound (newton: the minimum outside the faces, or a kink) ended it,
 * and to t->closed where parallel_start settled it (its vertices certified by at most
 * SPC_FLAT_CLOSED_STEPS Newton steps, or no chain). */
typedef struct flat_tally {
    int bound_ends;
    int closed;
} flat_tally;

static bool in_face(const flat_cache *fc, const flat_face *f, spc_vec3 p, double tol);

static bool minimize(flat_problem *P, spc_vec3 *p, flat_tally *t)
{
    const int k = P->k;
    for (int i = 0; i + 1 < k; ++i) {
        const flat_face *a = P->v[i].f, *b = P->v[i + 1].f;
        const spc_vec3 A[2] = {a->u, a->v}, B[2] = {b->u, b->v};
        for (int r = 0; r < 2; ++r)
            for (int q = 0; q < 2; ++q)
                P->uu[i][r][q] = a == b ? (r == q ? 1.0 : 0.0) : spc_dot(A[r], B[q]);
    }
    double s[2 * SPC_FLAT_MAX_VERTICES];
    const double min_len = SPC_FLAT_SIDE_REL * P->scale;
    int closed = P->parallel ? parallel_start(P, s) : 0;
    if (closed < 0) {
        ++t->closed;
        return false;
    }
    if (closed > 0) {
        /* the closed form's minimum, certified by Newton's steps on L; where they do not converge,
         * the smoothed stages below from the straight line */
        double lb = -INFINITY, L = path_length(P, s, 0.0, p);
        /* a vertex outside its face by more than the closed form's error (SPC_FLAT_CROSS_REL, as
         * for the reflecting planes above): the minimum, L's only one, is outside the faces too,
         * which solve_sequence would find after the steps below */
        for (int i = 0; i < k; ++i)
            if (!in_face(P->v[i].fc, P->v[i].f, p[i + 1], SPC_FLAT_CROSS_REL * P->scale)) {
                ++t->closed;
                return false;
            }
        bool apart = true;
        for (int j = 0; j <= k && apart; ++j)
            apart = spc_length(spc_sub(p[j + 1], p[j])) > 1e3 * min_len;
        double g = apart ? newton(P, 0.0, s, p, &L, SPC_FLAT_CLOSED_STEPS, SPC_FLAT_GRAD_TOL, &lb) : -1.0;
        if (g < -1.5) {
            ++t->bound_ends;
            return false;
        }
        if (g >= 0.0 && g < 1e3 * SPC_FLAT_GRAD_TOL) {
            ++t->closed;
            for (int j = 0; j <= k; ++j)
                if (!(spc_length(spc_sub(p[j + 1], p[j])) > min_len))
                    return false;
            return true;
        }
    }
    for (int i = 0; i < k; ++i) {
        /* the point of the straight line at fraction (i+1)/(k+1), projected onto the face's plane */
        spc_vec3 q = spc_add(P->x, spc_scale(spc_sub(P->y, P->x), (i + 1.0) / (k + 1.0)));
        spc_vec3 r = spc_sub(q, P->v[i].f->o);
        s[2 * i] = spc_dot(r, P->v[i].f->u);
        s[2 * i + 1] = spc_dot(r, P->v[i].f->v);
    }
    double mu = 0.1 * P->scale, lb = -INFINITY;
    double L = path_length(P, s, mu, p);
    for (; mu > SPC_FLAT_MU_END * P->scale; mu *= SPC_FLAT_MU_FALL) {
        L = path_length(P, s, mu, p);
        double g = newton(P, mu, s, p, &L, SPC_FLAT_STAGE_STEPS, 1e-3 * mu / P->scale, &lb);
        if (g < 0.0) {
            t->bound_ends += g < -1.5;
            return false;
        }
    }
    L = path_length(P, s, 0.0, p);
    for (int j = 0; j <= k; ++j)
        if (!(spc_length(spc_sub(p[j + 1], p[j])) > 1e3 * min_len))
            return false; /* a kink: no chain through this sequence */
    double g = newton(P, 0.0, s, p, &L, SPC_FLAT_NEWTON_STEPS, SPC_FLAT_GRAD_TOL, &lb);
    t->bound_ends += g < -1.5;
    if (!(g >= 0.0 && g < 1e3 * SPC_FLAT_GRAD_TOL))
        return false;
    for (int j = 0; j <= k; ++j)
        if (!(spc_length(spc_sub(p[j + 1], p[j])) > min_len))
            return false;
    return true;
}

/* Is p (on face f's plane) inside one of its triangles? */
static bool in_face(const flat_cache *fc, const flat_face *f, spc_vec3 p, double tol)
{
    spc_vec3 r = spc_sub(p, f->o);
    double pu = spc_dot(r, f->u), pv = spc_dot(r, f->v);
    for (int t = f->first; t < f->first + f->count; ++t) {
        const double *c = fc->tri2d + 6 * t, *e = fc->tri_edge + 10 * t;
        bool in = true;
        for (int j = 0; j < 3 && in; ++j) {
            const double *a = c + 2 * j;
            double cr = e[9] * (e[3 * j] * (pv - a[1]) - e[3 * j + 1] * (pu - a[0]));
            in = cr >= -tol * e[3 * j + 2];
        }
        if (in)
            return true;
    }
    return false;
}

bool spc_flat_shape_face_holds(const spc_shape *s, int i, spc_vec3 p, double tol)
{
    const flat_cache *fc = flat_get(s);
    return fc && i >= 0 && i < fc->nfaces && in_face(fc, &fc->face[i], p, tol);
}

bool spc_flat_shape_face_cone_meets(const spc_shape *s, int i, spc_vec3 a, spc_vec3 c, double R, double margin)
{
    const flat_cache *fc = flat_get(s);
    if (!fc || i < 0 || i >= fc->nfaces)
        return true;
    const flat_face *f = &fc->face[i];
    for (int t = f->first; t < f->first + f->count; ++t) {
        const spc_vec3 *p = fc->corner + 3 * t;
        bool outside = false;
        for (int j = 0; j < 3 && !outside; ++j) {
            /* the plane through a and the edge p[j] p[j + 1], its normal toward the third corner */
            spc_vec3 n = spc_cross(spc_sub(p[j], a), spc_sub(p[(j + 1) % 3], a));
            double nl = spc_length(n);
            if (!(nl > 0.0))
                break; /* a on the edge's line: this triangle is not decided here */
            if (spc_dot(n, spc_sub(p[(j + 2) % 3], a)) < 0.0)
                nl = -nl;
            outside = spc_dot(n, spc_sub(c, a)) / nl < -(R + margin);
        }
        if (!outside)
            return true;
    }
    return false;
}

bool spc_flat_shape_front_only(const spc_shape *s)
{
    const flat_cache *fc = flat_get(s);
    return fc && fc->front_only;
}


/* Is the segment a -> b clear of every face of the flat-faced casters but those its ends lie on
 * (fa, fb; NULL for x and y)? A root whose path passes through another face of its own shape or of
 * another flat caster is no chain (the path would meet that face first). */
static bool segment_clear(const spc_scene *sc, const spc_chain_casters *cs, spc_vec3 a, spc_vec3 b,
                          const flat_face *fa, const flat_face *fb, double tol)
{
    for (int j = 0; j < cs->n; ++j) {
        const flat_cache *fc = flat_get(sc->shapes[cs->idx[j]]);
        if (!fc)
            continue;
        for (int fi = 0; fi < fc->nfaces; ++fi) {
            const flat_face *f = &fc->face[fi];
            if (f == fa || f == fb)
                continue;
            double da = plane_dist(f, a), db = plane_dist(f, b);
            if (!((da > tol && db < -tol) || (da < -tol && db > tol)))
                continue;
            spc_vec3 q = spc_add(a, spc_scale(spc_sub(b, a), da / (da - db)));
            if (in_face(fc, f, q, -tol))
                return false;
        }
    }
    return true;
}

/* The problem's sequence solved and checked: the minimum's vertices on the sides the sequence says
 * and inside their faces, its segments clear of the other flat faces. */
static bool solve_sequence(const spc_scene *sc, const spc_chain_casters *cs, flat_problem *P, spc_vec3 *p,
                           flat_tally *t)
{
    /* the segments' indices: a conductor's both sides take the known index next to it, 1 if none */
    const int k = P->k;
    for (int i = k - 1; i >= 0; --i)
        if (P->seg[i] < 0.0 && !(P->v[i].eta > 0.0))
            P->seg[i] = P->seg[i + 1];
    for (int i = 0; i < k; ++i)
        if (P->seg[i + 1] < 0.0 && !(P->v[i].eta > 0.0))
            P->seg[i + 1] = P->seg[i];
    for (int j = 0; j <= k; ++j)
        if (P->seg[j] < 0.0)
            P->seg[j] = 1.0;
    if (!minimize(P, p, t))
        return false;
    double tol = SPC_FLAT_SIDE_REL * P->scale;
    for (int i = 0; i < k; ++i) {
        const flat_face *f = P->v[i].f;
        if (!(P->v[i].side_in * plane_dist(f, p[i]) > tol) || !(P->v[i].side_out * plane_dist(f, p[i + 2]) > tol))
            return false;
        if (!in_face(P->v[i].fc, f, p[i + 1], SPC_FLAT_EDGE_REL * P->scale))
            return false;
        if (P->v[i].tir > 0.0 && !total_reflection(spc_normalize(spc_sub(p[i + 1], p[i])), f->n, P->v[i].tir))
            return false;
    }
    for (int j = 0; j <= k; ++j)
        if (!segment_clear(sc, cs, p[j], p[j + 1], j > 0 ? P->v[j - 1].f : NULL, j < k ? P->v[j].f : NULL, tol))
            return false;
    return true;
}

/* Does some corner of face f lie strictly on side `side` of face g's plane? */
static bool corner_on_side(const flat_cache *fc, const flat_face *f, const flat_face *g, int side, double tol)
{
    for (int t = f->first; t < f->first + f->count; ++t)
        for (int j = 0; j < 3; ++j)
            if (side * plane_dist(g, fc->corner[3 * t + j]) > tol)
                return true;
    return false;
}

/* Is every segment from a point of face b (of a shape with cache fb) to the point z blocked by
 * another closed convex flat caster (every such segment crossing the inside of one of its faces)?
 * The segments from z to b meet a plane that separates them in b's central projection from z, a
 * convex polygon (b is one: a face of a convex shape, or a triangle list whose hull is tested)
 * held by the face when its corners' images are. */
static bool shadowed(const spc_scene *sc, const spc_chain_casters *cs, const flat_cache *fb, const flat_face *b,
                     spc_vec3 z, double tol)
{
    for (int j = 0; j < cs->n; ++j) {
        const flat_cache *fc = flat_get(sc->shapes[cs->idx[j]]);
        if (!fc || fc == fb || !fc->convex)
            continue;
        for (int fi = 0; fi < fc->nfaces; ++fi) {
            const flat_face *f = &fc->face[fi];
            double dz = plane_dist(f, z);
            if (fabs(dz) <= tol)
                continue;
            /* b's distinct corners where it keeps them (each triangle corner is one of them, so
             * the test over all of them is the same; a quad's 4 in place of its triangles' 6) */
            const spc_vec3 *corner = b->ncorners > 0 ? b->corners : fb->corner + 3 * b->first;
            const int ncorner = b->ncorners > 0 ? b->ncorners : 3 * b->count;
            bool all = true;
            for (int t = 0; t < ncorner && all; ++t) {
                spc_vec3 c = corner[t];
                double dc = plane_dist(f, c);
                if (!(dc * dz < 0.0 && fabs(dc) > tol)) {
                    all = false;
                    break;
                }
                spc_vec3 q = spc_add(c, spc_scale(spc_sub(z, c), dc / (dc - dz)));
                all = in_face(fc, f, q, -tol);
            }
            if (all)
                return true;
        }
    }
    return false;
}

bool spc_flat_shape_face_shadowed(const spc_scene *sc, bool any_surface, const spc_shape *s, int i, spc_vec3 z,
                                  double scale)
{
    const flat_cache *fc = flat_get(s);
    const spc_chain_casters *cs = spc_chain_casters_of(sc, any_surface);
    if (!fc || !cs || i < 0 || i >= fc->nfaces)
        return false;
    return shadowed(sc, cs, fc, &fc->face[i], z, SPC_FLAT_SIDE_REL * scale);
}

/* The directions from the point z to the points of face f (from its corners; from the sphere
 * around them where f keeps none). */
static cone cone_point_face(spc_vec3 z, const flat_face *f)
{
    spc_vec3 d = spc_sub(f->c, z);
    double len = spc_length(d);
    if (f->ncorners == 0 || !(len > 0.0))
        return cone_between(z, 0.0, f->c, f->rad);
    spc_vec3 g[SPC_FLAT_FACE_CORNERS];
    for (int i = 0; i < f->ncorners; ++i)
        g[i] = spc_sub(f->corners[i], z);
    return cone_of(spc_scale(d, 1.0 / len), g, f->ncorners);
}

/* The link from a's faces to b's: a's own where a == b, else found in a's list or built and added
 * to it (atomically: threads that build the same one at once keep the first published); NULL where
 * memory runs out (the caller computes what it needs itself). */
static const flat_link *flat_link_get(const flat_cache *a, const flat_cache *b)
{
    if (a == b)
        return &a->self;
    flat_link **head = (flat_link **)&((flat_cache *)a)->links;
    flat_link *mine = NULL;
    for (;;) {
        flat_link *first = __atomic_load_n(head, __ATOMIC_ACQUIRE);
        for (flat_link *l = first; l; l = l->next)
            if (l->to == b) {
                free(mine);
                return l;
            }
        if (!mine) {
            mine = malloc(sizeof *mine);
            if (!mine)
                return NULL;
            link_fill(mine, a, b);
        }
        mine->next = first;
        if (__atomic_compare_exchange_n(head, &first, mine, false, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE))
            return mine;
    }
}

/* The directions from the points of face a (of the shape cached as ca) to those of face b (cb). */
static cone faces_cap(const flat_cache *ca, const flat_face *a, const flat_cache *cb, const flat_face *b)
{
    const flat_link *l = flat_link_get(ca, cb);
    return l ? l->cap[a - ca->face][b - cb->face] : cone_faces(a, b);
}

/* The axis a refracted through the plane of unit normal m (toward the side it arrives from) from
 * index n_in to n_out (its tangential part scaled by n_in / n_out; no total reflection). */
static spc_vec3 refract_axis(spc_vec3 a, spc_vec3 m, double n_in, double n_out)
{
    spc_vec3 down = spc_neg(m);
    spc_vec3 tan = spc_add(a, spc_scale(m, spc_dot(a, down)));
    spc_vec3 tt = spc_scale(tan, n_in / n_out);
    double st2 = spc_dot(tt, tt);
    return spc_normalize(spc_add(tt, spc_scale(down, sqrt(dmax(0.0, 1.0 - st2)))));
}

/* cth < -sin(x) - 1e-12 (cone_through's test), for x <= pi/2: most calls are decided by sin's
 * polynomial bounds x - x^3/6 <= sin x <= x - x^3/6 + x^5/120 (x >= 0; Taylor's, for every such
 * x) outside that band widened by 1e-14 (far above the rounding of either side), the sine computed
 * only inside it, so the answer is the same. */
static inline bool away(double cth, double x)
{
    if (x >= 0.0) {
        double x2 = x * x, lo = x - x * x2 * (1.0 / 6.0), hi = lo + x * x2 * x2 * (1.0 / 120.0);
        if (cth < -hi - 1e-12 - 1e-14)
            return true;
        if (cth >= -lo - 1e-12 + 1e-14)
            return false;
    }
    return cth < -sin(x) - 1e-12;
}

/* The cap of the directions leaving a vertex on the plane of unit normal m (toward the side the
 * path arrives from) with the event given, from the cap c of the arriving ones; false if none can
 * arrive (or, refracting out, pass). n_in, n_out the indices (equal for a reflection). Where the
 * cap is narrower than a hemisphere and its axis arrives, refraction is bounded by its Lipschitz
 * constant on the cap (the largest stretch of the map's differential: polar n_in cos ti / (n_out
 * cos to), azimuthal sin to / sin ti = n_in / n_out; both at most n_in / n_out into a denser
 * medium, largest at the cap's widest incidence out of one): the image lies within r L of the
 * refracted axis. */
static bool cone_through(const cone *cp, spc_vec3 m, bool reflect, double n_in, double n_out, cone *out)
{
    const cone c = *cp;
    spc_vec3 down = spc_neg(m); /* the direction straight into the plane */
    /* th, the axis's angle from straight in, is needed only refracting out of a denser medium;
     * elsewhere its two tests read on the cosine (the test below: th >= c.r + pi/2 - 1e-12, as
     * cos th <= -sin(c.r - 1e-12), with 1e-12 more on the cosine so that it is never wider) */
    double cth = spc_dot(c.a, down), th = 0.0;
    /* cth >= 0 passes without the sine: sin(c.r - 1e-12) >= -1e-12 for the radii c.r >= 0 */
    if (cth < 0.0 && c.r < SPC_PI && c.r < 0.5 * SPC_PI + 1e-12 && away(cth, c.r - 1e-12))
        return false; /* every direction runs parallel to the plane or away from it */
    if (reflect) {
        if (c.r >= SPC_PI) {
            *out = c;
            return true;
        }
        *out = (cone){spc_sub(c.a, spc_scale(m, 2.0 * spc_dot(c.a, m))), c.r};
        return true;
    }
    if (n_in == n_out) {
        *out = c;
        return true;
    }
    bool narrow = c.r < 0.5 * SPC_PI && cth > 0.0;
    if (n_in < n_out) {
        double crit = critical_angle(n_in / n_out), r = c.r * (n_in / n_out);
        *out = narrow && r < crit ? (cone){refract_axis(c.a, m, n_in, n_out), r} : (cone){down, crit};
        return true;
    }
    if (c.r < SPC_PI)
        th = acos(dmax(-1.0, dmin(1.0, cth)));
    double crit = critical_angle(n_out / n_in), ti = dmin(0.5 * SPC_PI, th + c.r);
    if (c.r < SPC_PI && th - c.r >= crit)
        return false; /* total internal reflection for every direction */
    double so = dmin(1.0, n_in / n_out * sin(ti));
    *out = (cone){down, c.r >= SPC_PI ? 0.5 * SPC_PI : asin(so)};
    if (narrow && ti < crit) {
        double L = n_in * cos(ti) / (n_out * sqrt(dmax(1e-300, 1.0 - so * so)));
        if (c.r * L < out->r)
            *out = (cone){refract_axis(c.a, m, n_in, n_out), c.r * L};
    }
    return true;
}

/* ---- the walk over face sequences ---- */

/* Shapes whose shadow tests a walk caches (more are tested each time). */
#define SPC_FLAT_WALK_SHAPES 32

/* Casters up to which a walk bounds the vertices a sequence still needs (walk_run): its tables cost
 * the square of their number per walk. */
#define SPC_FLAT_BOUND_SHAPES 8

typedef struct flat_walk {
    const spc_scene *sc;
    const spc_chain_casters *cs;
    bool any_surface, reflect;
    unsigned lengths; /* the chain lengths solved (bit k: k vertices) */
    int hi;           /* the longest */
    flat_problem P; /* P.k: the vertices chosen so far, while walking */
    cone cap[SPC_FLAT_MAX_VERTICES + 1]; /* the caps of the segments arriving at the vertices chosen */
    /* shadowed() from x and from y, per caster slot and face: 0 not yet known, 1 no, 2 yes */
    unsigned char shadow[2][SPC_FLAT_WALK_SHAPES][SPC_FLAT_MAX_FACES];
    /* whether ends[][][] (below) is known */
    unsigned char ends_known[2][SPC_FLAT_WALK_SHAPES][SPC_FLAT_MAX_FACES];
    /* per complete sequence: */
    bool (*found)(void *user, const flat_problem *P, const spc_vec3 *p);
    void *user;
    int sequences;
    long nodes; /* the vertices chosen (the walk's tree, for tests) */
    flat_tally tally; /* solves ended by the bounds (newton), settled by the closed form (minimize) */
    bool stop;
    bool partial; /* reflections off glass inside a longer chain may be partial (reflect implied) */
    bool need_glass_reflect; /* with partial: solve only the sequences of 2+ vertices with a reflection off glass */
    /* cone_point_face from x (end 0) and from y (end 1), per caster slot and face: read only where
     * ends_known, so it stays out of the walk's clearing (32 kB; it is last) */
    cone ends[2][SPC_FLAT_WALK_SHAPES][SPC_FLAT_MAX_FACES];
    /* with bounded: near[q][j], the states (state_bit) of the caster in slot j from which some
     * sequence of at most q more vertices can reach y, by the walk's rules (flat_link.prev) and its
     * tests of a last vertex; a vertex whose state is outside near[hi - k][j] (k vertices chosen)
     * completes no sequence and grows none, and is skipped */
    bool bounded;
    uint32_t near[SPC_FLAT_MAX_VERTICES][SPC_FLAT_BOUND_SHAPES];
} flat_walk;

/* shadowed() of face fi of the caster in slot j from x (end 0) or y (end 1), cached. */
static bool walk_shadowed(flat_walk *w, int end, int j, const flat_cache *fc, int fi, double tol)
{
    if (j >= SPC_FLAT_WALK_SHAPES)
        return shadowed(w->sc, w->cs, fc, &fc->face[fi], end ? w->P.y : w->P.x, tol);
    unsigned char *c = &w->shadow[end][j][fi];
    if (!*c)
        *c = shadowed(w->sc, w->cs, fc, &fc->face[fi], end ? w->P.y : w->P.x, tol) ? 2 : 1;
    return *c == 2;
}

/* cone_point_face of face fi of the caster in slot j from x (end 0) or y (end 1), cached. */
static cone walk_end_cap(flat_walk *w, int end, int j, const flat_cache *fc, int fi)
{
    spc_vec3 z = end ? w->P.y : w->P.x;
    if (j >= SPC_FLAT_WALK_SHAPES)
        return cone_point_face(z, &fc->face[fi]);
    if (!w->ends_known[end][j][fi]) {
        w->ends[end][j][fi] = cone_point_face(z, &fc->face[fi]);
        w->ends_known[end][j][fi] = 1;
    }
    return w->ends[end][j][fi];
}

/* The sequence of P's first k vertices seen from y: the caps of its segments propagated back from
 * the directions toward y through each vertex's event (reversed, the same maps), each narrowed by
 * the directions between its faces and checked against the cap fwd[j] the walk from x found for
 * segment j. False if some segment has no direction both ends allow (no chain). */
static bool backward_meets(flat_walk *w, int k)
{
    const flat_problem *P = &w->P;
    const cone *fwd = w->cap;
    const flat_vertex *last = &P->v[k - 1];
    cone b = cone_neg(walk_end_cap(w, 1, last->slot, last->fc, (int)(last->f - last->fc->face)));
    if (!cones_meet(b, fwd[k]))
        return false;
    for (int i = k - 1; i >= 0; --i) {
        const flat_vertex *v = &P->v[i];
        spc_vec3 m = spc_scale(v->f->n, v->side_out); /* toward the side the reversed path arrives from */
        if (v->tir > 0.0 && b.r < SPC_PI && cap_within(b.a, b.r, m, critical_angle(1.0 / v->tir)))
            return false; /* every direction within the critical angle: no total reflection */
        double n_in = P->seg[i] >= 0.0 ? P->seg[i] : 1.0, n_out = P->seg[i + 1] >= 0.0 ? P->seg[i + 1] : 1.0;
        cone back;
        cone rb = cone_neg(b);
        if (!cone_through(&rb, m, v->event == SPC_CHAIN_REFLECT, n_out, n_in, &back))
            return false;
        b = cone_neg(back);
        cone between = i > 0 ? faces_cap(P->v[i - 1].fc, P->v[i - 1].f, v->fc, v->f)
                             : walk_end_cap(w, 0, v->slot, v->fc, (int)(v->f - v->fc->face));
        if (!cones_meet(b, between))
            return false;
        if (between.r < b.r)
            b = between;
        if (!cones_meet(b, fwd[i]))
            return false;
    }
    return true;
}

/* i: the vertex to choose; medium: the index of the segment arriving there (-1: not known); dirp:
 * the cap of that segment's directions. Each sequence of lo to hi vertices that passes the
 * pruning is solved as it is completed, and longer ones grow from it. */
static void walk(flat_walk *w, int i, double medium, const cone *dirp)
{
    const cone dir = *dirp;
    flat_problem *P = &w->P;
    double tol = SPC_FLAT_SIDE_REL * P->scale;
    const flat_vertex *prev = i > 0 ? &P->v[i - 1] : NULL;
    /* the convex shapes' rules below, for whole casters: inside one, only its own faces come next;
     * having left one, none of its faces does */
    bool inside = prev && prev->fc->convex && prev->side_out < 0;
    for (int j = 0; j < w->cs->n && !w->stop; ++j) {
        const spc_shape *s = w->sc->shapes[w->cs->idx[j]];
        if (prev && (inside ? s != prev->s : s == prev->s && prev->fc->convex))
            continue;
        const flat_cache *fc = flat_get(s);
        if (!fc)
            continue;
        /* the last vertex's face against this caster's faces (NULL: out of memory, computed here) */
        const flat_link *lk = prev ? flat_link_get(prev->fc, fc) : NULL;
        const int pf = prev ? (int)(prev->f - prev->fc->face) : 0;
        double eta = fc->eta;
        /* the faces to try, as bit 2 fi (state_bit's exterior-or-interior pair folded onto its
         * even bit), in order: where bounded, only those through which some sequence of at most
         * hi vertices reaches y */
        uint32_t faces_left = 0x55555555u & (fc->nfaces >= 16 ? ~0u : (1u << 2 * fc->nfaces) - 1u);
        if (w->bounded) {
            uint32_t m = w->near[w->hi - i - 1][j];
            faces_left &= m | m >> 1;
        }
        for (; faces_left && !w->stop; faces_left &= faces_left - 1u) {
            const int fi = __builtin_ctz(faces_left) >> 1;
            const flat_face *f = &fc->face[fi];
            if (prev) {
                if (prev->f == f)
                    continue;
                if (fabs(spc_dot(prev->f->n, f->n)) > 1.0 - 1e-12 && fabs(plane_dist(f, prev->f->o)) < tol)
                    continue; /* one plane: a segment between them would lie in it */
            }
            cone arrive = dir;
            bool have_arrive = false;
            for (int side = 1; side >= -1; side -= 2) {
                if (side < 0 && fc->front_only)
                    continue;
                if (fc->convex) {
                    if (side < 0) { /* from the inside: only from a vertex of the same shape, or x inside */
                        if (prev ? !(prev->s == s && prev->side_out < 0) : !inside_convex(fc, P->x, tol))
                            continue;
                    } else if (prev && prev->s == s) {
                        continue; /* a path that left a convex shape does not meet it again */
                    }
                }
                if (prev && prev->fc->convex && prev->side_out < 0 && !(prev->s == s && side < 0))
                    continue; /* a path inside a convex shape meets its faces next */
                if (!prev) {
                    if (!(side * plane_dist(f, P->x) > tol))
                        continue;
                    if (side > 0 && walk_shadowed(w, 0, j, fc, fi, tol))
                        continue;
                } else if (lk ? !(side > 0 ? lk->top[pf][fi] > tol : lk->bot[pf][fi] < -tol) ||
                                    !(prev->side_out > 0 ? lk->rtop[pf][fi] > tol : lk->rbot[pf][fi] < -tol)
                              : !corner_on_side(prev->fc, prev->f, f, side, tol) ||
                                    !corner_on_side(fc, f, prev->f, prev->side_out, tol)) {
                    continue; /* some corner of each face on the side of the other's plane it needs */
                }
                double in = side_index(eta, side);
                if (in >= 0.0 && medium >= 0.0 && fabs(in - medium) > 1e-9 * in)
                    continue; /* the two ends of the segment disagree on its medium */
                if (!have_arrive) {
                    /* the directions that can arrive at f: from x, or those leaving the last
                     * vertex that point from its face toward f */
                    have_arrive = true;
                    if (!prev) {
                        arrive = walk_end_cap(w, 0, j, fc, fi);
                    } else {
                        cone between = lk ? lk->cap[pf][fi] : cone_faces(prev->f, f);
                        if (!cones_meet(dir, between))
                            break;
                        if (between.r < arrive.r)
                            arrive = between;
                    }
                }
                double m_in = in >= 0.0 ? in : medium;
                for (int ev = 0; ev < 2 && !w->stop; ++ev) {
                    unsigned char event = ev ? SPC_CHAIN_REFRACT : SPC_CHAIN_REFLECT;
                    if (eta > 0.0 ? (event == SPC_CHAIN_REFLECT && !w->reflect) : event == SPC_CHAIN_REFRACT)
                        continue;
                    /* off glass: one reflection alone (the light's image in a pane), or a total
                     * internal reflection in a longer chain (flat_chains.h) */
                    double tir = 0.0;
                    bool tir_ok = true; /* may be a total internal reflection in a longer chain */
                    if (eta > 0.0 && event == SPC_CHAIN_REFLECT) {
                        tir = side_index(eta, side) / side_index(eta, -side);
                        tir_ok = tir > 1.0 &&
                                 !(arrive.r < SPC_PI &&
                                   cap_within(arrive.a, arrive.r, spc_scale(f->n, -side), critical_angle(1.0 / tir)));
                        if (w->partial) {
                            tir_ok = true; /* any reflection, total or not */
                            tir = 0.0;
                        } else if (i > 0 && !tir_ok) {
                            continue;
                        }
                    }
                    int side_out = event == SPC_CHAIN_REFRACT ? -side : side;
                    double m_out = eta > 0.0 ? side_index(eta, side_out) : m_in;
                    double n_in = m_in >= 0.0 ? m_in : 1.0, n_out = m_out >= 0.0 ? m_out : 1.0;
                    int k = i + 1;
                    if (w->bounded && !(w->near[w->hi - k][j] & state_bit(fi, side_out)))
                        continue;
                    /* the tests of a complete sequence that need no cap first (y on the side the path
                     * leaves to, inside the shape where it stays inside, not shadowed): a vertex that
                     * can neither complete the sequence nor grow it needs no cap (the last vertex of
                     * the longest sequences, most of the walk's nodes) */
                    bool reach = (w->lengths >> k & 1u) && side_out * plane_dist(f, P->y) > tol &&
                                 !(fc->convex && side_out < 0 && !inside_convex(fc, P->y, tol)) &&
                                 !(side_out > 0 && walk_shadowed(w, 1, j, fc, fi, tol));
                    bool grow = k < w->hi && tir_ok;
                    if (!reach && !grow)
                        continue;
                    cone leave;
                    if (!cone_through(&arrive, spc_scale(f->n, side), event == SPC_CHAIN_REFLECT, n_in, n_out, &leave))
                        continue;
                    ++w->nodes;
                    flat_vertex *v = &P->v[i];
                    w->cap[i] = arrive;
                    v->s = s;
                    v->slot = j;
                    v->shape_index = w->cs->idx[j];
                    v->fc = fc;
                    v->f = f;
                    v->side_in = side;
                    v->side_out = side_out;
                    v->event = event;
                    v->eta = eta;
                    v->tir = tir;
                    P->seg[i] = m_in;
                    P->seg[i + 1] = m_out;
                    /* complete at k vertices: the last segment reaches y */
                    bool finish = reach && cones_meet(leave, cone_neg(walk_end_cap(w, 1, j, fc, fi)));
                    for (int q = 0; q < k && finish && !w->any_surface; ++q)
                        finish = spc_chain_caster_allowed(P->v[q].s->caustic_flags, k);
                    if (finish && w->need_glass_reflect) {
                        bool glass_reflect = false;
                        for (int q = 0; q < k; ++q)
                            glass_reflect = glass_reflect || (P->v[q].eta > 0.0 && P->v[q].event == SPC_CHAIN_REFLECT);
                        finish = glass_reflect && k > 1;
                    }
                    if (finish) {
                        w->cap[k] = leave;
                        finish = backward_meets(w, k);
                    }
                    if (finish) {
                        flat_problem Q = *P;
                        Q.k = k;
                        /* a reflection off glass alone is no total internal reflection */
                        if (k == 1)
                            Q.v[0].tir = 0.0;
                        spc_vec3 p[SPC_FLAT_MAX_VERTICES + 2];
                        ++w->sequences;
                        if (w->found && solve_sequence(w->sc, w->cs, &Q, p, &w->tally) &&
                            !w->found(w->user, &Q, p))
                            w->stop = true;
                    }
                    if (grow)
                        walk(w, k, m_out, &leave);
                }
            }
        }
    }
}

/* Fills w->near (flat_walk) and sets w->bounded, for a walk of up to w->hi vertices from w->P.x to
 * w->P.y: near[0] holds the states in which a last vertex passes the walk's tests of y (y on the
 * side the path leaves to, inside a convex shape it stays in, the face not shadowed from y), and
 * near[q] adds those with a next state in near[q - 1] (flat_link.prev). Each holds at least the
 * states the walk could complete a sequence from within q more vertices, so skipping the others
 * leaves the sequences solved, and their order, as they were. Not bounded (every state kept) for
 * more than SPC_FLAT_BOUND_SHAPES casters or where a link cannot be allocated. */
static void bound_near(flat_walk *w)
{
    const spc_chain_casters *cs = w->cs;
    const int n = cs->n, hi = w->hi;
    w->bounded = false;
    if (n > SPC_FLAT_BOUND_SHAPES)
        return;
    const flat_cache *fc[SPC_FLAT_BOUND_SHAPES];
    const flat_link *lk[SPC_FLAT_BOUND_SHAPES][SPC_FLAT_BOUND_SHAPES];
    for (int j = 0; j < n; ++j)
        fc[j] = flat_get(w->sc->shapes[cs->idx[j]]);
    for (int j = 0; j < n; ++j)
        for (int b = 0; b < n; ++b) {
            lk[j][b] = NULL;
            if (fc[j] && fc[b] && !(lk[j][b] = flat_link_get(fc[j], fc[b])))
                return;
        }
    double tol = SPC_FLAT_SIDE_REL * w->P.scale;
    for (int j = 0; j < n; ++j) {
        uint32_t m = 0;
        for (int fi = 0; fc[j] && fi < fc[j]->nfaces; ++fi)
            for (int so = 1; so >= -1; so -= 2) {
                /* walk's tests of y for a last vertex (reach), but the lengths */
                const flat_face *f = &fc[j]->face[fi];
                if (so * plane_dist(f, w->P.y) > tol &&
                    !(fc[j]->convex && so < 0 && !inside_convex(fc[j], w->P.y, tol)) &&
                    !(so > 0 && walk_shadowed(w, 1, j, fc[j], fi, tol)))
                    m |= state_bit(fi, so);
            }
        w->near[0][j] = m;
    }
    /* breadth first from near[0]: the states first reached at q more vertices, front[], lead
     * back to those first reached at q + 1 */
    uint32_t front[SPC_FLAT_BOUND_SHAPES], next[SPC_FLAT_BOUND_SHAPES];
    for (int j = 0; j < n; ++j)
        front[j] = w->near[0][j];
    for (int q = 1; q < hi; ++q) {
        bool any = false;
        for (int j = 0; j < n; ++j)
            next[j] = 0;
        for (int b = 0; b < n; ++b)
            for (uint32_t f = front[b]; f; f &= f - 1) {
                int t = __builtin_ctz(f);
                for (int j = 0; j < n; ++j)
                    if (fc[j])
                        next[j] |= lk[j][b]->prev[t];
            }
        for (int j = 0; j < n; ++j) {
            front[j] = next[j] & ~w->near[q - 1][j];
            w->near[q][j] = w->near[q - 1][j] | front[j];
            any = any || front[j];
        }
        if (!any) { /* nothing new: the longer bounds are the same */
            for (int r = q + 1; r < hi; ++r)
                for (int j = 0; j < n; ++j)
                    w->near[r][j] = w->near[q][j];
            break;
        }
    }
    w->bounded = true;
}

/* Walks every face sequence of lo to hi vertices, and of the lengths k with bit k of extra set, from
 * x to y (the longer sequences grow from the shorter ones); found() is called with each root
 * and returns false to stop (found NULL: the sequences are counted, not solved). partial: 0 the
 * enumeration's events, 1 any reflection off glass (total or partial), 2 the same, solving only the
 * sequences of two or more vertices with a reflection off glass among them. Returns the number
 * of sequences solved; bound: whether a solve may end early by the bound on the faces (the minimum
 * outside them, or a kink), *bound_ends (may be NULL) the solves it ended; parallel: whether a solve
 * starts from the closed form where it applies, *closed (may be NULL) the solves it settled; near:
 * whether the walk skips the vertices bound_near rules out, *nodes (may be NULL) the vertices it
 * chose. */
static int walk_run(const spc_scene *sc, bool any_surface, bool reflect, int partial, spc_vec3 x, spc_vec3 y, int lo,
                    int hi, unsigned extra, bool (*found)(void *, const flat_problem *, const spc_vec3 *), void *user,
                    bool bound, bool parallel, int *bound_ends, int *closed, bool near, long *nodes)
{
    if (lo < 1)
        lo = 1;
    if (hi > SPC_FLAT_MAX_VERTICES)
        hi = SPC_FLAT_MAX_VERTICES;
    unsigned lengths = extra & ((2u << SPC_FLAT_MAX_VERTICES) - 2u);
    for (int k = lo; k <= hi; ++k)
        lengths |= 1u << k;
    if (!lengths)
        return 0;
    for (hi = SPC_FLAT_MAX_VERTICES; !(lengths >> hi & 1u); --hi)
        ;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, any_surface);
    if (!cs || cs->n == 0)
        return 0;
    /* no flat-faced caster: nothing to walk, and the walk's caches (several kB) are not cleared */
    int flat = 0;
    for (int j = 0; j < cs->n && !flat; ++j)
        flat = flat_get(sc->shapes[cs->idx[j]]) != NULL;
    if (!flat)
        return 0;
    flat_walk w;
    memset(&w, 0, offsetof(flat_walk, ends));
    w.sc = sc;
    w.cs = cs;
    w.any_surface = any_surface;
    w.reflect = reflect || partial > 0;
    w.partial = partial > 0;
    w.need_glass_reflect = partial > 1;
    w.lengths = lengths;
    w.hi = hi;
    w.P.x = x;
    w.P.y = y;
    w.P.scale = spc_length(spc_sub(y, x)) + 2.0 * cs->radius;
    w.P.bound = bound;
    w.P.parallel = parallel;
    w.found = found;
    w.user = user;
    w.bounded = false;
    if (near)
        bound_near(&w);
    const cone any = {spc_v3(0, 0, 1), 4.0};
    walk(&w, 0, -1.0, &any);
    if (bound_ends)
        *bound_ends = w.tally.bound_ends;
    if (closed)
        *closed = w.tally.closed;
    if (nodes)
        *nodes = w.nodes;
    return w.sequences;
}

/* walk_run with the enumeration's own events: a reflection off glass inside a longer chain total. */
static int walk_all(const spc_scene *sc, bool any_surface, bool reflect, spc_vec3 x, spc_vec3 y, int lo, int hi,
                    bool (*found)(void *, const flat_problem *, const spc_vec3 *), void *user, bool bound,
                    bool parallel, int *bound_ends, int *closed)
{
    return walk_run(sc, any_surface, reflect, 0, x, y, lo, hi, 0u, found, user, bound, parallel, bound_ends, closed,
                    true, NULL);
}

typedef struct roots_out {
    int k, n, max;
    spc_vec3 *pts;
    unsigned char *events;
} roots_out;

static bool roots_found(void *user, const flat_problem *P, const spc_vec3 *p)
{
    roots_out *o = user;
    if (o->n >= o->max)
        return false;
    for (int i = 0; i < o->k; ++i) {
        o->pts[o->k * o->n + i] = p[i + 1];
        if (o->events)
            o->events[o->k * o->n + i] = P->v[i].event;
    }
    ++o->n;
    return true;
}

int spc_flat_chain_roots_solve(const spc_scene *sc, bool any_surface, bool reflect, spc_vec3 x, spc_vec3 y, int k,
                               spc_vec3 *pts, unsigned char *events, int max, int *sequences, bool bound,
                               bool parallel, int *bound_ends, int *closed)
{
    roots_out o = {k, 0, max, pts, events};
    int seq =
        walk_all(sc, any_surface, reflect, x, y, k, k, roots_found, &o, bound, parallel, bound_ends, closed);
    if (sequences)
        *sequences = seq;
    return o.n;
}

int spc_flat_chain_roots_near(const spc_scene *sc, bool any_surface, bool reflect, int partial, spc_vec3 x, spc_vec3 y,
                              int k, spc_vec3 *pts, unsigned char *events, int max, int *sequences, bool near,
                              long *nodes)
{
    roots_out o = {k, 0, max, pts, events};
    int seq = walk_run(sc, any_surface, reflect, partial, x, y, k, k, 0u, roots_found, &o, true, true, NULL, NULL, near,
                       nodes);
    if (sequences)
        *sequences = seq;
    return o.n;
}

int spc_flat_chain_roots_bound(const spc_scene *sc, bool any_surface, bool reflect, spc_vec3 x, spc_vec3 y, int k,
                               spc_vec3 *pts, unsigned char *events, int max, int *sequences, bool bound,
                               int *bound_ends)
{
    return spc_flat_chain_roots_solve(sc, any_surface, reflect, x, y, k, pts, events, max, sequences, bound, true,
                                      bound_ends, NULL);
}

int spc_flat_chain_sequences(const spc_scene *sc, bool any_surface, bool reflect, spc_vec3 x, spc_vec3 y, int k)
{
    return walk_all(sc, any_surface, reflect, x, y, k, k, NULL, NULL, true, true, NULL, NULL);
}

int spc_flat_chain_roots(const spc_scene *sc, bool any_surface, bool reflect, spc_vec3 x, spc_vec3 y, int k,
                         spc_vec3 *pts, unsigned char *events, int max, int *sequences)
{
    return spc_flat_chain_roots_bound(sc, any_surface, reflect, x, y, k, pts, events, max, sequences, true, NULL);
}

typedef struct chains_out {
    const spc_snee_query *q;
    spc_chain *out;
    int n, max;
    int *iterations;
} chains_out;

static bool chains_found(void *user, const flat_problem *P, const spc_vec3 *p)
{
    chains_out *o = user;
    if (o->n >= o->max)
        return false;
    const spc_shape *shapes[SPC_FLAT_MAX_VERTICES];
    unsigned char ev[SPC_FLAT_MAX_VERTICES];
    for (int i = 0; i < P->k; ++i) {
        shapes[i] = P->v[i].s;
        ev[i] = P->v[i].event;
    }
    /* from the point the chain's first ray leaves from (x offset off its surface, as the trace
     * spawns it) */
    spc_vec3 xo = spc_hit_offset(o->q->x, spc_sub(p[1], o->q->x->p));
    spc_vec3 dir = spc_normalize(spc_sub(p[1], xo));
    if (spc_snee_exact_polish_flat(o->q, shapes, P->k, ev, dir, o->out, o->n, o->iterations))
        ++o->n;
    return true;
}

int spc_flat_chains_all(const spc_snee_query *q, spc_chain *out, int max_out, int *iterations)
{
    const spc_snee_params *p = q->params;
    bool reflect = p && p->reflect;
    int lo = q->min_chain > 1 ? q->min_chain : 1;
    int hi = q->max_chain < SPC_FLAT_MAX_VERTICES ? q->max_chain : SPC_FLAT_MAX_VERTICES;
    chains_out o = {q, out, 0, max_out, iterations};
    walk_all(q->scene, q->any_surface, reflect, q->x->p, q->y, lo, hi, chains_found, &o, true, true, NULL, NULL);
    return o.n;
}

/* One walk for q's lengths and longer ones: q's chains polished as found (spc_flat_chains_all's,
 * those past max_out dropped as that call stops there), the longer ones' roots kept in the order
 * found, to be polished by spc_flat_chains_later as their own walks would polish them. */
typedef struct later_out {
    chains_out now; /* the lengths of q (lo to hi) */
    int lo, hi;
    spc_flat_later *later; /* the longer ones' roots */
} later_out;

static bool later_found(void *user, const flat_problem *P, const spc_vec3 *p)
{
    later_out *o = user;
    if (P->k >= o->lo && P->k <= o->hi)
        return o->now.n >= o->now.max || chains_found(&o->now, P, p); /* past the limit: dropped */
    spc_flat_later *l = o->later;
    if (l->n == SPC_FLAT_LATER_MAX) {
        l->overflow = true;
        return true;
    }
    spc_flat_later_root *r = &l->root[l->n++];
    r->k = P->k;
    for (int i = 0; i < P->k; ++i) {
        r->shapes[i] = P->v[i].s;
        r->ev[i] = P->v[i].event;
    }
    spc_vec3 xo = spc_hit_offset(o->now.q->x, spc_sub(p[1], o->now.q->x->p));
    r->dir = spc_normalize(spc_sub(p[1], xo));
    return true;
}

int spc_flat_chains_all_later(const spc_snee_query *q, unsigned later_lengths, spc_flat_later *later,
                              spc_chain *out, int max_out, int *iterations)
{
    const spc_snee_params *p = q->params;
    bool reflect = p && p->reflect;
    int lo = q->min_chain > 1 ? q->min_chain : 1;
    int hi = q->max_chain < SPC_FLAT_MAX_VERTICES ? q->max_chain : SPC_FLAT_MAX_VERTICES;
    unsigned extra = later_lengths & ((2u << SPC_FLAT_MAX_VERTICES) - 2u);
    for (int k = lo; k <= hi; ++k)
        extra &= ~(1u << k);
    later->lengths = extra;
    later->overflow = false;
    later->n = 0;
    later_out o = {{q, out, 0, max_out, iterations}, lo, hi, later};
    walk_run(q->scene, q->any_surface, reflect, 0, q->x->p, q->y, lo, hi, extra, later_found, &o, true, true, NULL,
             NULL, true, NULL);
    return o.now.n;
}

int spc_flat_chains_later(const spc_snee_query *q, const spc_flat_later *later, int k, spc_chain *out, int max_out,
                          int *iterations)
{
    if (k < 1 || k > SPC_FLAT_MAX_VERTICES || !(later->lengths >> k & 1u) || later->overflow) {
        spc_snee_query lq = *q;
        lq.min_chain = lq.max_chain = k;
        return spc_flat_chains_all(&lq, out, max_out, iterations);
    }
    int n = 0;
    for (int i = 0; i < later->n && n < max_out; ++i) {
        const spc_flat_later_root *r = &later->root[i];
        if (r->k == k && spc_snee_exact_polish_flat(q, r->shapes, k, r->ev, r->dir, out, n, iterations))
            ++n;
    }
    return n;
}

int spc_flat_chains_all_partial(const spc_snee_query *q, bool need_glass_reflect, spc_chain *out, int max_out,
                                int *iterations)
{
    int lo = q->min_chain > 1 ? q->min_chain : 1;
    int hi = q->max_chain < SPC_FLAT_MAX_VERTICES ? q->max_chain : SPC_FLAT_MAX_VERTICES;
    chains_out o = {q, out, 0, max_out, iterations};
    walk_run(q->scene, q->any_surface, true, need_glass_reflect ? 2 : 1, q->x->p, q->y, lo, hi, 0u, chains_found, &o,
             true, true, NULL, NULL, true, NULL);
    return o.n;
}

/* Is c a chain of 1 to nmax vertices, all on flat-faced casters, with the events the enumeration
 * takes (reflect as spc_snee_params.reflect) and each segment's medium agreed on by its two ends?
 * total_only: a reflection off glass in a chain of more than one vertex must be total. */
static bool flat_faces_chain(const spc_chain *c, bool reflect, int nmax, bool total_only)
{
    int n = c->n;
    if (n < 1 || n > nmax)
        return false;
    double medium = -1.0;
    for (int i = 0; i < n; ++i) {
        const spc_chain_vertex *v = &c->v[i];
        const spc_shape *s = v->h.shape;
        const flat_cache *fc = flat_get(s);
        if (!fc || v->h.prim < 0 || (size_t)v->h.prim >= s->mesh.ntris || fc->tri_face[v->h.prim] < 0)
            return false;
        double eta = fc->eta;
        if (eta > 0.0 ? (v->event == SPC_CHAIN_REFLECT && !reflect) : v->event != SPC_CHAIN_REFLECT)
            return false;
        const flat_face *f = &fc->face[fc->tri_face[v->h.prim]];
        int side = spc_dot(v->wi, f->n) < 0.0 ? 1 : -1;
        if (total_only && eta > 0.0 && v->event == SPC_CHAIN_REFLECT && n > 1) {
            double ratio = side_index(eta, side) / side_index(eta, -side);
            if (!(ratio > 1.0) || !total_reflection(v->wi, f->n, ratio))
                return false; /* a partial reflection off glass in a longer chain: not enumerated */
        }
        double in = side_index(eta, side);
        if (in >= 0.0 && medium >= 0.0 && fabs(in - medium) > 1e-9 * in)
            return false;
        double m_in = in >= 0.0 ? in : medium;
        int side_out = v->event == SPC_CHAIN_REFRACT ? -side : side;
        medium = eta > 0.0 ? side_index(eta, side_out) : m_in;
    }
    return true;
}

bool spc_flat_chain_covers(const spc_chain *c, bool reflect)
{
    return flat_faces_chain(c, reflect, SPC_FLAT_MAX_VERTICES, true);
}

bool spc_flat_chain_faces(const spc_chain *c, bool reflect)
{
    return flat_faces_chain(c, reflect, SPC_CHAIN_MAX_VERTICES, false);
}
