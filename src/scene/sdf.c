/*
 * scene/sdf.c: signed distance fields: evaluation with analytic derivatives, sphere tracing,
 * bounds, area and sampling.
 *
 * Fields (paper 004, section 2, and Quilez's exact primitives): sphere |p| - r; box
 * |max(q, 0)| + min(max_i q_i, 0) with q = |p| - b; rounded box (the box of b - r, minus r);
 * torus |(|p_xz| - R, p_y)| - r; capsule |p - a - clamp(h) (b - a)| - r; capped cylinder (the 2D
 * box in (|p_xz|, |p_y|)); plane n . p - offset. Operations: min, max, max(a, -b) and the
 * polynomial smooth minimum h = clamp(1/2 + (b - a) / 2k, 0, 1),
 * smin = mix(b, a, h) - k h (1 - h).
 *
 * Derivatives. The normal is n = grad f / |grad f| and its derivative along the surface
 * dn = (I - n n^T) H dp / |grad f| (paper 000, section 9.3: the implicit function differentiated
 * twice gives normal and curvature). Every node has analytic gradient and Hessian: primitives by
 * the chain rule through their radial coordinates (|p|, |p_xz|), operations by picking a child
 * (min / max) or, for the smooth minimum, grad = h grad a + (1 - h) grad b (the terms in grad h
 * cancel) and H = h H_a + (1 - h) H_b - (grad a - grad b)(grad a - grad b)^T / 2k inside the blend.
 * No finite differences are needed; tests/test_sdf.c checks all of them against differences.
 *
 * Lipschitz bound. Every primitive is an exact distance (Lipschitz 1); min, max and negation keep
 * Lipschitz 1; the smooth minimum's gradient is a convex combination of its children's, so it
 * keeps 1 too; a similarity transform with scale s multiplies the value by s and divides the
 * gradient's argument by s, keeping 1. A 1-Lipschitz f that vanishes on the surface satisfies
 * |f(p)| <= dist(p, surface), so a step of |f| never passes a crossing even where f is only a
 * bound (CSG, smooth union). Sphere tracing therefore uses L = 1, with over-relaxation
 * (Keinert et al. 2014, "Enhanced sphere tracing": steps of omega |f|, falling back to omega = 1
 * when two consecutive unbounding spheres do not overlap) and, rather than stopping when
 * |f| < epsilon, detects a sign change of f and refines the bracket (Illinois regula falsi with
 * bisection safeguard) to the rounding level of the coordinates, which also finds exits of rays
 * that start inside (refraction).
 *
 * Area. For a single primitive (with its uniform scale) the area is exact. For a CSG tree it is
 * estimated with the Cauchy-Crofton formula: for lines uniform in direction and in a disk of
 * radius R perpendicular to it through the bounding sphere, E[#crossings] = area / (2 pi R^2);
 * SDF_AREA_LINES lines of a Halton sequence give a deterministic estimate (typically 1e-3
 * relative; the test checks 1%). Only area light power and the area-sampling density use it.
 *
 * Area sampling (BDPT light emission, specular NEE). Crofton again: crossings of uniform lines
 * are uniformly distributed on the surface with intensity proportional to area. Picking index j
 * uniformly in [0, nmax) and keeping crossing j if the line has that many is an exact rejection
 * sampler of the uniform area density, given nmax bounds the crossings of any line (sphere, box,
 * rounded box, capsule, cylinder 2; torus 4; plane 1; min / max / difference: the sum of the
 * children, as their zero sets contain the result's; smooth union: the sum plus 2, an assumption
 * that holds for the usual blends of convex pieces, not a theorem).
 *
 * Solid-angle sampling (area lights seen from a point): a direction uniform in the cone of the
 * bounding sphere (or the whole sphere from inside it) traced to the first crossing. The first
 * crossing is a function of the direction, so its density in solid angle is the cone's density:
 * unbiased for any shape; directions that miss give no sample.
 */
#include "scene/sdf.h"

#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "core/warp.h"

/* Minimum sphere-tracing step, relative to the field's size: bounds the march's cost near the
 * surface; crossing pairs closer than this (features below 1e-7 of the shape) can be missed. */
#define SDF_MIN_STEP 1e-7
/* Padding of the bounding box, relative to its diagonal: f is at least this outside the clip
 * box, so a ray entering it starts with a certain sign. */
#define SDF_BOX_PAD 1e-4
/* Over-relaxation factor of the march (Keinert et al. recommend 1.2 to 1.8; 1.6 halves the
 * steps of grazing rays in our tests and falls back to 1 when unsafe). */
#define SDF_RELAX 1.6
/* Step limit of one march: a ray passing the surface within ~1e-6 of the size needs thousands of
 * steps; beyond the limit it is reported as a miss (probability of order 1e-6 per ray). */
#define SDF_MAX_STEPS 4096
/* Refinement iterations (Illinois converges in ~10; the bisection safeguard bounds the rest). */
#define SDF_REFINE_ITERS 200
/* |f| at a ray's origin below this (relative to the coordinates' magnitude) means the origin is
 * on the surface and the sign there is not known: spawned rays are offset by 1e-9, far above. */
#define SDF_SIGN_EPS 1e-12
/* Lines of the Crofton area estimate of CSG trees (~0.2 s for a small tree). */
#define SDF_AREA_LINES 65536
/* Trials of the area sampler before it gives up (acceptance is E[crossings] / nmax, above 1% for
 * shapes not much thinner than their bounding sphere). */
#define SDF_SAMPLE_TRIALS 100000
/* Relative tolerance of the similarity test of transforms (as the sphere's in the loader). */
#define SDF_SIMILARITY_TOL 1e-5
/* Hit point error bound, relative to the coordinates and the size (the intersection is refined
 * in double to rounding level; shape.c uses the same 1e-9 for analytic shapes). */
#define SDF_OFFSET 1e-9
/* Transform entries below this (relative to the scale) are treated as zero when bounding boxes
 * are transformed, so a rotation by 90 degrees keeps a half-space's box half-bounded. */
#define SDF_SNAP 1e-12

typedef struct node {
    spc_sdf_type type;
    double r, r2, h;   /* radius / major, minor / half height, plane offset; k */
    spc_vec3 v0, v1;   /* half sizes (roundbox: inner), capsule ends, plane normal */
    int a, b;
    int nmax;          /* bound on crossings of a line */
    bool xf;           /* has a non-identity transform */
    double s;          /* uniform scale of to_world */
    spc_mat4 to_world, to_local;
} node;

struct spc_sdf {
    node *nodes;
    int n, cap;
    int root;
    bool finalized;
    spc_vec3 lo, hi;   /* padded bounds */
    double size;       /* diagonal of the unpadded bounds */
    spc_vec3 bc;       /* bounding sphere of the padded box */
    double br;
    double area;
    bool area_exact;
    bool torus; /* the root is one ring torus (R > r): rays are intersected analytically */
};

/* value, gradient, Hessian */
typedef struct jet {
    double f;
    double g[3];
    double H[3][3];
} jet;

static const char *type_names[] = {"sphere",   "box",   "roundbox", "torus",      "capsule",   "cylinder",
                                   "plane",    "union", "intersection", "difference", "smooth_union"};

const char *spc_sdf_type_name(spc_sdf_type t)
{
    return (unsigned)t < sizeof type_names / sizeof type_names[0] ? type_names[t] : "?";
}

bool spc_sdf_type_from_name(const char *name, spc_sdf_type *t)
{
    for (size_t i = 0; i < sizeof type_names / sizeof type_names[0]; ++i)
        if (strcmp(name, type_names[i]) == 0) {
            *t = (spc_sdf_type)i;
            return true;
        }
    return false;
}

void spc_sdf_desc_init(spc_sdf_desc *d, spc_sdf_type type)
{
    memset(d, 0, sizeof *d);
    d->type = type;
    d->radius = type == SPC_SDF_ROUNDBOX ? 0.1 : (type == SPC_SDF_CAPSULE ? 0.5 : 1.0);
    d->half_size = spc_v3(1, 1, 1);
    d->major = 1.0;
    d->minor = 0.25;
    d->p0 = spc_v3(0, 0, 0);
    d->p1 = spc_v3(0, 1, 0);
    d->height = 2.0;
    d->normal = spc_v3(0, 1, 0);
    d->offset = 0.0;
    d->k = 0.1;
    d->a = d->b = -1;
    d->to_world = spc_mat4_identity();
}

/* ------------------------------------------------------------------------------------------------ */
/* construction */

static bool positive(double x) { return x > 0.0 && isfinite(x); }

/* The uniform scale of a similarity, or 0 if m is not one. */
static double similarity_scale(const spc_mat4 *m)
{
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            if (!isfinite(m->m[i][j]))
                return 0.0;
    if (m->m[3][0] != 0.0 || m->m[3][1] != 0.0 || m->m[3][2] != 0.0 || m->m[3][3] != 1.0)
        return 0.0;
    spc_vec3 c[3];
    for (int j = 0; j < 3; ++j)
        c[j] = spc_v3(m->m[0][j], m->m[1][j], m->m[2][j]);
    double s = spc_length(c[0]);
    if (!(s > 0.0))
        return 0.0;
    for (int j = 1; j < 3; ++j)
        if (fabs(spc_length(c[j]) - s) > SDF_SIMILARITY_TOL * s)
            return 0.0;
    for (int a = 0; a < 3; ++a)
        for (int b = a + 1; b < 3; ++b)
            if (fabs(spc_dot(c[a], c[b])) > SDF_SIMILARITY_TOL * s * s)
                return 0.0;
    return cbrt(fabs(spc_mat4_det3(m)));
}

bool spc_sdf_desc_check(const spc_sdf_desc *d, char *msg, size_t msg_size, const char **field)
{
#define BAD(f, ...)                                                                                                   \
    do {                                                                                                              \
        *field = f;                                                                                                   \
        snprintf(msg, msg_size, __VA_ARGS__);                                                                         \
        return false;                                                                                                 \
    } while (0)
    const spc_vec3 hs = d->half_size;
    if (!(similarity_scale(&d->to_world) > 0.0))
        BAD("to_world", "to_world must be a rotation, a uniform scale and a translation (a non-uniformly scaled "
                        "distance field is not a distance: scale the primitive's sizes instead)");
    switch (d->type) {
    case SPC_SDF_SPHERE:
        if (!positive(d->radius))
            BAD("radius", "radius %g must be positive", d->radius);
        break;
    case SPC_SDF_BOX:
    case SPC_SDF_ROUNDBOX:
        if (!positive(hs.x) || !positive(hs.y) || !positive(hs.z))
            BAD("half_size", "half_size (%g, %g, %g) must be positive", hs.x, hs.y, hs.z);
        if (d->type == SPC_SDF_ROUNDBOX &&
            (!(d->radius >= 0.0) || !(d->radius <= spc_min(hs.x, spc_min(hs.y, hs.z)))))
            BAD("radius", "corner radius %g must be between 0 and the smallest half size", d->radius);
        break;
    case SPC_SDF_TORUS:
        if (!positive(d->major))
            BAD("major_radius", "major_radius %g must be positive", d->major);
        if (!positive(d->minor))
            BAD("minor_radius", "minor_radius %g must be positive", d->minor);
        break;
    case SPC_SDF_CAPSULE:
        if (!positive(d->radius))
            BAD("radius", "radius %g must be positive", d->radius);
        if (!spc_v3_finite(d->p0) || !spc_v3_finite(d->p1))
            BAD("p0", "end points must be finite");
        break;
    case SPC_SDF_CYLINDER:
        if (!positive(d->radius))
            BAD("radius", "radius %g must be positive", d->radius);
        if (!positive(d->height))
            BAD("height", "height %g must be positive", d->height);
        break;
    case SPC_SDF_PLANE:
        if (!spc_v3_finite(d->normal) || !(spc_length(d->normal) > 0.0))
            BAD("normal", "normal must be finite and non-zero");
        if (!isfinite(d->offset))
            BAD("offset", "offset must be finite");
        break;
    case SPC_SDF_SMOOTH_UNION:
        if (!positive(d->k))
            BAD("k", "k %g must be positive", d->k);
        break;
    case SPC_SDF_UNION:
    case SPC_SDF_INTERSECTION:
    case SPC_SDF_DIFFERENCE:
        break;
    }
    return true;
#undef BAD
}

spc_sdf *spc_sdf_create(void)
{
    spc_sdf *s = calloc(1, sizeof *s);
    if (s)
        s->root = -1;
    return s;
}

void spc_sdf_destroy(spc_sdf *s)
{
    if (!s)
        return;
    free(s->nodes);
    free(s);
}

int spc_sdf_add(spc_sdf *s, const spc_sdf_desc *d, const char *file, int line, int col, spc_error *err)
{
    char msg[256];
    const char *field = NULL;
    if (s->finalized) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "sdf: nodes cannot be added to a finalized field");
        return -1;
    }
    if ((unsigned)d->type > (unsigned)SPC_SDF_SMOOTH_UNION) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "sdf: invalid node type %d", (int)d->type);
        return -1;
    }
    if (!spc_sdf_desc_check(d, msg, sizeof msg, &field)) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "sdf %s: %s", spc_sdf_type_name(d->type), msg);
        return -1;
    }
    bool op = spc_sdf_type_is_operation(d->type);
    if (op && (d->a < 0 || d->a >= s->n || d->b < 0 || d->b >= s->n)) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "sdf %s: children %d and %d must be existing nodes",
                      spc_sdf_type_name(d->type), d->a, d->b);
        return -1;
    }
    if (s->n == s->cap) {
        int cap = s->cap ? 2 * s->cap : 8;
        node *nn = realloc(s->nodes, (size_t)cap * sizeof *nn);
        if (!nn) {
            spc_error_set(err, SPC_ERR_NOMEM, file, line, col, "out of memory");
            return -1;
        }
        s->nodes = nn;
        s->cap = cap;
    }
    node *n = &s->nodes[s->n];
    memset(n, 0, sizeof *n);
    n->type = d->type;
    n->a = op ? d->a : -1;
    n->b = op ? d->b : -1;
    switch (d->type) {
    case SPC_SDF_SPHERE:
        n->r = d->radius;
        n->nmax = 2;
        break;
    case SPC_SDF_BOX:
        n->v0 = d->half_size;
        n->nmax = 2;
        break;
    case SPC_SDF_ROUNDBOX:
        n->r = d->radius;
        n->v0 = spc_sub(d->half_size, spc_v3(d->radius, d->radius, d->radius));
        n->nmax = 2;
        break;
    case SPC_SDF_TORUS:
        n->r = d->major;
        n->r2 = d->minor;
        n->nmax = 4;
        break;
    case SPC_SDF_CAPSULE:
        n->r = d->radius;
        n->v0 = d->p0;
        n->v1 = d->p1;
        n->nmax = 2;
        break;
    case SPC_SDF_CYLINDER:
        n->r = d->radius;
        n->h = 0.5 * d->height;
        n->nmax = 2;
        break;
    case SPC_SDF_PLANE:
        n->v0 = spc_normalize(d->normal);
        n->h = d->offset;
        n->nmax = 1;
        break;
    case SPC_SDF_UNION:
    case SPC_SDF_INTERSECTION:
    case SPC_SDF_DIFFERENCE:
        n->nmax = s->nodes[d->a].nmax + s->nodes[d->b].nmax;
        break;
    case SPC_SDF_SMOOTH_UNION:
        n->r = d->k;
        n->nmax = s->nodes[d->a].nmax + s->nodes[d->b].nmax + 2;
        break;
    }
    n->to_world = d->to_world;
    n->s = similarity_scale(&d->to_world);
    spc_mat4 I = spc_mat4_identity();
    n->xf = memcmp(&n->to_world, &I, sizeof I) != 0;
    if (!spc_mat4_inverse(&n->to_world, &n->to_local)) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "sdf %s: to_world is singular", spc_sdf_type_name(d->type));
        return -1;
    }
    return s->n++;
}

/* ------------------------------------------------------------------------------------------------ */
/* evaluation: value only (the march's hot path) */

/* sqrt(x^2 + y^2) without hypot's overflow guard (5x slower in glibc; scene coordinates are far
 * from overflowing a square) */
static inline double len2d(double x, double y) { return sqrt(x * x + y * y); }

static double dist(const spc_sdf *s, int i, spc_vec3 p);

static double prim_dist(const node *n, spc_vec3 p)
{
    switch (n->type) {
    case SPC_SDF_SPHERE: return spc_length(p) - n->r;
    case SPC_SDF_BOX:
    case SPC_SDF_ROUNDBOX: {
        double qx = fabs(p.x) - n->v0.x, qy = fabs(p.y) - n->v0.y, qz = fabs(p.z) - n->v0.z;
        double mx = spc_max(qx, 0.0), my = spc_max(qy, 0.0), mz = spc_max(qz, 0.0);
        double out = sqrt(mx * mx + my * my + mz * mz);
        double in = spc_min(spc_max(qx, spc_max(qy, qz)), 0.0);
        return out + in - (n->type == SPC_SDF_ROUNDBOX ? n->r : 0.0);
    }
    case SPC_SDF_TORUS: {
        double q1 = len2d(p.x, p.z) - n->r;
        return len2d(q1, p.y) - n->r2;
    }
    case SPC_SDF_CAPSULE: {
        spc_vec3 ba = spc_sub(n->v1, n->v0), pa = spc_sub(p, n->v0);
        double bb = spc_length2(ba);
        double hh = bb > 0.0 ? spc_clamp(spc_dot(pa, ba) / bb, 0.0, 1.0) : 0.0;
        return spc_length(spc_sub(pa, spc_scale(ba, hh))) - n->r;
    }
    case SPC_SDF_CYLINDER: {
        double q1 = len2d(p.x, p.z) - n->r, q2 = fabs(p.y) - n->h;
        double m1 = spc_max(q1, 0.0), m2 = spc_max(q2, 0.0);
        return spc_min(spc_max(q1, q2), 0.0) + len2d(m1, m2);
    }
    case SPC_SDF_PLANE: return spc_dot(n->v0, p) - n->h;
    case SPC_SDF_UNION:
    case SPC_SDF_INTERSECTION:
    case SPC_SDF_DIFFERENCE:
    case SPC_SDF_SMOOTH_UNION: break;
    }
    return INFINITY;
}

/* Node i's field at p given in its own frame (its transform already applied; not its scale). */
static double dist_local(const spc_sdf *s, int i, spc_vec3 p)
{
    const node *n = &s->nodes[i];
    double f;
    switch (n->type) {
    case SPC_SDF_UNION: f = spc_min(dist(s, n->a, p), dist(s, n->b, p)); break;
    case SPC_SDF_INTERSECTION: f = spc_max(dist(s, n->a, p), dist(s, n->b, p)); break;
    case SPC_SDF_DIFFERENCE: f = spc_max(dist(s, n->a, p), -dist(s, n->b, p)); break;
    case SPC_SDF_SMOOTH_UNION: {
        double a = dist(s, n->a, p), b = dist(s, n->b, p), k = n->r;
        double h = spc_clamp(0.5 + 0.5 * (b - a) / k, 0.0, 1.0);
        f = b + h * (a - b) - k * h * (1.0 - h);
        break;
    }
    case SPC_SDF_SPHERE:
    case SPC_SDF_BOX:
    case SPC_SDF_ROUNDBOX:
    case SPC_SDF_TORUS:
    case SPC_SDF_CAPSULE:
    case SPC_SDF_CYLINDER:
    case SPC_SDF_PLANE:
    default: f = prim_dist(n, p); break;
    }
    return f;
}

static double dist(const spc_sdf *s, int i, spc_vec3 p)
{
    const node *n = &s->nodes[i];
    if (!n->xf)
        return dist_local(s, i, p);
    return n->s * dist_local(s, i, spc_mat4_apply_point(&n->to_local, p));
}

/* ------------------------------------------------------------------------------------------------ */
/* evaluation with derivatives */

static void jet_zero_h(jet *J) { memset(J->H, 0, sizeof J->H); }

static void add_outer(double H[3][3], const double a[3], const double b[3], double w)
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            H[i][j] += w * a[i] * b[j];
}

/* Box field from its per-axis excess q_i (sg_i = dq_i/dp_i = +-1, or 0 for an unused axis with
 * q_i = -inf): derivatives with respect to p where q is piecewise linear in p. */
static void box_q(const double q[3], const double sg[3], int order, jet *J)
{
    double m[3], l2 = 0.0;
    for (int i = 0; i < 3; ++i) {
        m[i] = q[i] > 0.0 ? q[i] : 0.0;
        l2 += m[i] * m[i];
    }
    jet_zero_h(J);
    J->g[0] = J->g[1] = J->g[2] = 0.0;
    if (l2 > 0.0) {
        double lm = sqrt(l2);
        J->f = lm;
        if (order < 1)
            return;
        for (int i = 0; i < 3; ++i)
            J->g[i] = sg[i] * m[i] / lm;
        if (order < 2)
            return;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                J->H[i][j] = sg[i] * sg[j] * ((i == j && m[i] > 0.0 ? 1.0 : 0.0) - m[i] * m[j] / l2) / lm;
    } else {
        int k = 0;
        for (int i = 1; i < 3; ++i)
            if (q[i] > q[k])
                k = i;
        J->f = q[k];
        J->g[k] = sg[k];
    }
}

/* A field g(rho, w) of rho = |p_xz| and w = sy * p_y with derivatives c = (g_rho, g_w) and
 * Hessian Hq (2x2), mapped to p: grad = c1 e + c2 sy ey, H = Hq in (e, sy ey) + c1 (P_xz - e e^T)
 * / rho (the curvature of rho). */
static void radial_to_p(spc_vec3 p, double rho, double sy, const double c[2], double Hq[2][2], int order, jet *J)
{
    double e[3] = {1.0, 0.0, 0.0};
    if (rho > 0.0) {
        e[0] = p.x / rho;
        e[2] = p.z / rho;
    }
    double ey[3] = {0.0, sy, 0.0};
    for (int i = 0; i < 3; ++i)
        J->g[i] = c[0] * e[i] + c[1] * ey[i];
    jet_zero_h(J);
    if (order < 2)
        return;
    add_outer(J->H, e, e, Hq[0][0]);
    add_outer(J->H, e, ey, Hq[0][1]);
    add_outer(J->H, ey, e, Hq[1][0]);
    add_outer(J->H, ey, ey, Hq[1][1]);
    if (rho > 0.0 && c[0] != 0.0) {
        double w = c[0] / rho;
        J->H[0][0] += w;
        J->H[2][2] += w;
        add_outer(J->H, e, e, -w);
    }
}

static void prim_jet(const node *n, spc_vec3 p, int order, jet *J)
{
    double pv[3] = {p.x, p.y, p.z};
    switch (n->type) {
    case SPC_SDF_SPHERE: {
        double q = spc_length(p);
        J->f = q - n->r;
        jet_zero_h(J);
        double g[3] = {0.0, 1.0, 0.0};
        if (q > 0.0)
            for (int i = 0; i < 3; ++i)
                g[i] = pv[i] / q;
        memcpy(J->g, g, sizeof g);
        if (order >= 2 && q > 0.0) {
            for (int i = 0; i < 3; ++i)
                J->H[i][i] = 1.0 / q;
            add_outer(J->H, g, g, -1.0 / q);
        }
        return;
    }
    case SPC_SDF_BOX:
    case SPC_SDF_ROUNDBOX: {
        double b[3] = {n->v0.x, n->v0.y, n->v0.z}, q[3], sg[3];
        for (int i = 0; i < 3; ++i) {
            q[i] = fabs(pv[i]) - b[i];
            sg[i] = pv[i] < 0.0 ? -1.0 : 1.0;
        }
        box_q(q, sg, order, J);
        if (n->type == SPC_SDF_ROUNDBOX)
            J->f -= n->r;
        return;
    }
    case SPC_SDF_CYLINDER: {
        double rho = len2d(p.x, p.z), sy = p.y < 0.0 ? -1.0 : 1.0;
        double q[3] = {rho - n->r, fabs(p.y) - n->h, -INFINITY}, sg[3] = {1.0, 1.0, 0.0};
        jet Jq;
        box_q(q, sg, order, &Jq);
        J->f = Jq.f;
        double c[2] = {Jq.g[0], Jq.g[1]};
        double Hq[2][2] = {{Jq.H[0][0], Jq.H[0][1]}, {Jq.H[1][0], Jq.H[1][1]}};
        radial_to_p(p, rho, sy, c, Hq, order, J);
        return;
    }
    case SPC_SDF_TORUS: {
        double rho = len2d(p.x, p.z);
        double q1 = rho - n->r, q2 = p.y, lq = len2d(q1, q2);
        J->f = lq - n->r2;
        double c[2] = {0.0, 1.0};
        if (lq > 0.0) {
            c[0] = q1 / lq;
            c[1] = q2 / lq;
        }
        double Hq[2][2] = {{0.0, 0.0}, {0.0, 0.0}};
        if (lq > 0.0) {
            Hq[0][0] = c[1] * c[1] / lq;
            Hq[0][1] = Hq[1][0] = -c[0] * c[1] / lq;
            Hq[1][1] = c[0] * c[0] / lq;
        }
        radial_to_p(p, rho, 1.0, c, Hq, order, J);
        return;
    }
    case SPC_SDF_CAPSULE: {
        spc_vec3 ba = spc_sub(n->v1, n->v0), pa = spc_sub(p, n->v0);
        double bb = spc_length2(ba);
        double hh = bb > 0.0 ? spc_clamp(spc_dot(pa, ba) / bb, 0.0, 1.0) : 0.0;
        spc_vec3 w = spc_sub(pa, spc_scale(ba, hh));
        double lw = spc_length(w);
        J->f = lw - n->r;
        jet_zero_h(J);
        double g[3] = {0.0, 1.0, 0.0};
        if (lw > 0.0) {
            g[0] = w.x / lw;
            g[1] = w.y / lw;
            g[2] = w.z / lw;
        }
        memcpy(J->g, g, sizeof g);
        if (order >= 2 && lw > 0.0) {
            for (int i = 0; i < 3; ++i)
                J->H[i][i] = 1.0 / lw;
            add_outer(J->H, g, g, -1.0 / lw);
            if (hh > 0.0 && hh < 1.0) {
                double len = sqrt(bb), t[3] = {ba.x / len, ba.y / len, ba.z / len};
                add_outer(J->H, t, t, -1.0 / lw);
            }
        }
        return;
    }
    case SPC_SDF_PLANE:
        J->f = spc_dot(n->v0, p) - n->h;
        J->g[0] = n->v0.x;
        J->g[1] = n->v0.y;
        J->g[2] = n->v0.z;
        jet_zero_h(J);
        return;
    case SPC_SDF_UNION:
    case SPC_SDF_INTERSECTION:
    case SPC_SDF_DIFFERENCE:
    case SPC_SDF_SMOOTH_UNION: break;
    }
}

static void jet_neg(jet *J)
{
    J->f = -J->f;
    for (int i = 0; i < 3; ++i) {
        J->g[i] = -J->g[i];
        for (int j = 0; j < 3; ++j)
            J->H[i][j] = -J->H[i][j];
    }
}

static void eval_jet(const spc_sdf *s, int i, spc_vec3 p, int order, jet *J)
{
    const node *n = &s->nodes[i];
    spc_vec3 pl = n->xf ? spc_mat4_apply_point(&n->to_local, p) : p;
    switch (n->type) {
    case SPC_SDF_UNION:
    case SPC_SDF_INTERSECTION:
    case SPC_SDF_DIFFERENCE:
    case SPC_SDF_SMOOTH_UNION: {
        jet A, B;
        eval_jet(s, n->a, pl, order, &A);
        eval_jet(s, n->b, pl, order, &B);
        if (n->type == SPC_SDF_UNION)
            *J = A.f <= B.f ? A : B;
        else if (n->type == SPC_SDF_INTERSECTION)
            *J = A.f >= B.f ? A : B;
        else if (n->type == SPC_SDF_DIFFERENCE) {
            jet_neg(&B);
            *J = A.f >= B.f ? A : B;
        } else {
            double k = n->r, d = B.f - A.f;
            double h = spc_clamp(0.5 + 0.5 * d / k, 0.0, 1.0);
            J->f = B.f + h * (A.f - B.f) - k * h * (1.0 - h);
            double dg[3];
            for (int a = 0; a < 3; ++a) {
                J->g[a] = h * A.g[a] + (1.0 - h) * B.g[a];
                dg[a] = A.g[a] - B.g[a];
                for (int b = 0; b < 3; ++b)
                    J->H[a][b] = h * A.H[a][b] + (1.0 - h) * B.H[a][b];
            }
            if (h > 0.0 && h < 1.0)
                add_outer(J->H, dg, dg, -0.5 / k);
        }
        break;
    }
    case SPC_SDF_SPHERE:
    case SPC_SDF_BOX:
    case SPC_SDF_ROUNDBOX:
    case SPC_SDF_TORUS:
    case SPC_SDF_CAPSULE:
    case SPC_SDF_CYLINDER:
    case SPC_SDF_PLANE: prim_jet(n, pl, order, J); break;
    }
    if (!n->xf)
        return;
    /* f = s f_l(A p + c): grad = s A^T grad_l, H = s A^T H_l A */
    double A[3][3], g[3] = {0, 0, 0}, H[3][3];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            A[a][b] = n->to_local.m[a][b];
    J->f *= n->s;
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k < 3; ++k)
            g[a] += n->s * A[k][a] * J->g[k];
    memcpy(J->g, g, sizeof g);
    if (order < 2)
        return;
    double T[3][3]; /* H_l A */
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            T[a][b] = J->H[a][0] * A[0][b] + J->H[a][1] * A[1][b] + J->H[a][2] * A[2][b];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            H[a][b] = n->s * (A[0][a] * T[0][b] + A[1][a] * T[1][b] + A[2][a] * T[2][b]);
    memcpy(J->H, H, sizeof H);
}

double spc_sdf_eval(const spc_sdf *s, spc_vec3 p) { return dist(s, s->root, p); }

double spc_sdf_eval_grad(const spc_sdf *s, spc_vec3 p, spc_vec3 *grad)
{
    jet J;
    eval_jet(s, s->root, p, 1, &J);
    *grad = spc_v3(J.g[0], J.g[1], J.g[2]);
    return J.f;
}

double spc_sdf_eval_hessian(const spc_sdf *s, spc_vec3 p, spc_vec3 *grad, double H[3][3])
{
    jet J;
    eval_jet(s, s->root, p, 2, &J);
    *grad = spc_v3(J.g[0], J.g[1], J.g[2]);
    memcpy(H, J.H, sizeof J.H);
    return J.f;
}

/* ------------------------------------------------------------------------------------------------ */
/* bounds */

/* Box of the region {f_i < eps} in node i's parent frame (conservative; may be infinite). */
static void node_box(const spc_sdf *s, int i, double eps, spc_vec3 *lo, spc_vec3 *hi)
{
    const node *n = &s->nodes[i];
    double e = n->xf ? eps / n->s : eps;
    spc_vec3 l = spc_v3(-INFINITY, -INFINITY, -INFINITY), h = spc_v3(INFINITY, INFINITY, INFINITY);
    switch (n->type) {
    case SPC_SDF_SPHERE: h = spc_v3(n->r + e, n->r + e, n->r + e); break;
    case SPC_SDF_BOX: h = spc_add(n->v0, spc_v3(e, e, e)); break;
    case SPC_SDF_ROUNDBOX: h = spc_add(n->v0, spc_v3(n->r + e, n->r + e, n->r + e)); break;
    case SPC_SDF_TORUS: h = spc_v3(n->r + n->r2 + e, n->r2 + e, n->r + n->r2 + e); break;
    case SPC_SDF_CYLINDER: h = spc_v3(n->r + e, n->h + e, n->r + e); break;
    case SPC_SDF_CAPSULE: {
        double r = n->r + e;
        l = spc_sub(spc_vmin(n->v0, n->v1), spc_v3(r, r, r));
        h = spc_add(spc_vmax(n->v0, n->v1), spc_v3(r, r, r));
        break;
    }
    case SPC_SDF_PLANE: {
        /* a half-space: bounded along an axis-aligned normal only */
        double nv[3] = {n->v0.x, n->v0.y, n->v0.z}, lv[3] = {-INFINITY, -INFINITY, -INFINITY},
               hv[3] = {INFINITY, INFINITY, INFINITY};
        for (int k = 0; k < 3; ++k)
            if (nv[(k + 1) % 3] == 0.0 && nv[(k + 2) % 3] == 0.0) {
                if (nv[k] > 0.0)
                    hv[k] = n->h + e;
                else
                    lv[k] = -(n->h + e);
            }
        l = spc_v3(lv[0], lv[1], lv[2]);
        h = spc_v3(hv[0], hv[1], hv[2]);
        break;
    }
    case SPC_SDF_UNION:
    case SPC_SDF_INTERSECTION:
    case SPC_SDF_DIFFERENCE:
    case SPC_SDF_SMOOTH_UNION: {
        spc_vec3 la, ha, lb, hb;
        /* smin >= min - k/4, so {smin < e} lies in {a < e + k/4} U {b < e + k/4} */
        double ec = n->type == SPC_SDF_SMOOTH_UNION ? e + 0.25 * n->r : e;
        node_box(s, n->a, ec, &la, &ha);
        if (n->type == SPC_SDF_DIFFERENCE) {
            l = la;
            h = ha;
            break;
        }
        node_box(s, n->b, ec, &lb, &hb);
        if (n->type == SPC_SDF_INTERSECTION) {
            l = spc_vmax(la, lb);
            h = spc_vmin(ha, hb);
        } else {
            l = spc_vmin(la, lb);
            h = spc_vmax(ha, hb);
        }
        break;
    }
    }
    if (n->type == SPC_SDF_SPHERE || n->type == SPC_SDF_BOX || n->type == SPC_SDF_ROUNDBOX ||
        n->type == SPC_SDF_TORUS || n->type == SPC_SDF_CYLINDER)
        l = spc_neg(h);
    if (!n->xf || l.x > h.x || l.y > h.y || l.z > h.z) {
        *lo = l;
        *hi = h;
        return;
    }
    /* transformed box (Arvo), with infinite extents kept where the transform does not mix them in */
    double lv[3] = {l.x, l.y, l.z}, hv[3] = {h.x, h.y, h.z}, ol[3], oh[3];
    for (int a = 0; a < 3; ++a) {
        ol[a] = oh[a] = n->to_world.m[a][3];
        for (int b = 0; b < 3; ++b) {
            double m = n->to_world.m[a][b];
            if (fabs(m) <= SDF_SNAP * n->s)
                continue;
            double x = m * lv[b], y = m * hv[b];
            ol[a] += spc_min(x, y);
            oh[a] += spc_max(x, y);
        }
    }
    *lo = spc_v3(ol[0], ol[1], ol[2]);
    *hi = spc_v3(oh[0], oh[1], oh[2]);
}

static double prim_area(const node *n)
{
    switch (n->type) {
    case SPC_SDF_SPHERE: return 4.0 * SPC_PI * n->r * n->r;
    case SPC_SDF_BOX: {
        spc_vec3 b = n->v0;
        return 8.0 * (b.x * b.y + b.y * b.z + b.z * b.x);
    }
    case SPC_SDF_ROUNDBOX: {
        spc_vec3 b = n->v0; /* inner half sizes: faces, quarter-cylinder edges, eighth-sphere corners */
        return 8.0 * (b.x * b.y + b.y * b.z + b.z * b.x) + 4.0 * SPC_PI * n->r * (b.x + b.y + b.z) +
               4.0 * SPC_PI * n->r * n->r;
    }
    case SPC_SDF_TORUS: return n->r2 <= n->r ? 4.0 * SPC_PI * SPC_PI * n->r * n->r2 : 0.0; /* spindle: estimate */
    case SPC_SDF_CAPSULE:
        return 4.0 * SPC_PI * n->r * n->r + 2.0 * SPC_PI * n->r * spc_distance(n->v0, n->v1);
    case SPC_SDF_CYLINDER: return 2.0 * SPC_PI * n->r * (2.0 * n->h) + 2.0 * SPC_PI * n->r * n->r;
    case SPC_SDF_PLANE:
    case SPC_SDF_UNION:
    case SPC_SDF_INTERSECTION:
    case SPC_SDF_DIFFERENCE:
    case SPC_SDF_SMOOTH_UNION: break;
    }
    return 0.0;
}

/* ------------------------------------------------------------------------------------------------ */
/* sphere tracing */

typedef struct walker {
    const spc_sdf *s;
    spc_vec3 o, d;
    /* the ray in the root's frame (its transforms are similarities: o + t d maps to lo + t ld) and
     * the root's scale, so that a step evaluates no transform at the root */
    spc_vec3 lo, ld;
    double rs;
    double dl;       /* |d| */
    double t, f;     /* current point and its value (never 0) */
    double t1;       /* end of the clipped segment */
    double min_step; /* in t */
    double tol_mag;  /* magnitude of the coordinates, for the refinement tolerance */
    bool done;
} walker;

static inline double ray_f(const walker *w, double t)
{
    return w->rs * dist_local(w->s, w->s->root, spc_madd(w->lo, w->ld, t));
}

static bool clip_box(const spc_sdf *s, spc_vec3 o, spc_vec3 d, double *t0, double *t1)
{
    double ov[3] = {o.x, o.y, o.z}, dv[3] = {d.x, d.y, d.z};
    double lv[3] = {s->lo.x, s->lo.y, s->lo.z}, hv[3] = {s->hi.x, s->hi.y, s->hi.z};
    double a = *t0, b = *t1;
    for (int k = 0; k < 3; ++k) {
        if (dv[k] == 0.0) {
            if (ov[k] < lv[k] || ov[k] > hv[k])
                return false;
            continue;
        }
        double inv = 1.0 / dv[k];
        double ta = (lv[k] - ov[k]) * inv, tb = (hv[k] - ov[k]) * inv;
        if (ta > tb) {
            double tmp = ta;
            ta = tb;
            tb = tmp;
        }
        a = spc_max(a, ta);
        b = spc_min(b, tb);
    }
    *t0 = a;
    *t1 = b;
    return a < b;
}

/* Sets up a walk along r in (tmin, tmax); false if the ray misses the bounds. */
static bool walker_init(walker *w, const spc_sdf *s, const spc_ray *r)
{
    w->s = s;
    w->o = r->o;
    w->d = r->d;
    w->dl = spc_length(r->d);
    w->done = true;
    if (!(w->dl > 0.0) || !s->finalized)
        return false;
    double t0 = r->tmin, t1 = r->tmax;
    if (!clip_box(s, r->o, r->d, &t0, &t1))
        return false;
    const node *rn = &s->nodes[s->root];
    w->lo = rn->xf ? spc_mat4_apply_point(&rn->to_local, r->o) : r->o;
    w->ld = rn->xf ? spc_mat4_apply_vector(&rn->to_local, r->d) : r->d;
    w->rs = rn->xf ? rn->s : 1.0;
    w->min_step = SDF_MIN_STEP * s->size / w->dl;
    w->tol_mag = spc_max_abs(r->o) + spc_max(spc_max_abs(s->lo), spc_max_abs(s->hi));
    w->t1 = t1;
    w->t = t0;
    w->f = ray_f(w, t0);
    if (fabs(w->f) <= SDF_SIGN_EPS * w->tol_mag) {
        /* the origin is on the surface: its own crossing is not a hit */
        w->t = t0 + w->min_step;
        if (!(w->t < t1))
            return false;
        w->f = ray_f(w, w->t);
        if (w->f == 0.0)
            return false;
    }
    if (isnan(w->f))
        return false;
    w->done = false;
    return true;
}

/* Illinois regula falsi on a bracket [ta, tb] (f(ta) of one sign, f(tb) of the other or zero),
 * bisecting whenever three steps did not halve the bracket. Returns the root; *tb_out is the end
 * of the final bracket beyond it and *fb_out f there (the walk continues from it). */
static double refine(const walker *w, double ta, double fa, double tb, double fb, double *tb_out, double *fb_out)
{
    double ga = fa, gb = fb, width0 = tb - ta;
    int side = 0;
    for (int it = 0; it < SDF_REFINE_ITERS && fb != 0.0; ++it) {
        double tol = 4.0 * DBL_EPSILON * (fabs(tb) + w->tol_mag / w->dl);
        if (!(tb - ta > tol))
            break;
        double tc;
        if (it % 3 == 2) {
            bool halved = tb - ta <= 0.5 * width0;
            width0 = tb - ta;
            tc = halved ? (ta * gb - tb * ga) / (gb - ga) : 0.5 * (ta + tb);
        } else {
            tc = (ta * gb - tb * ga) / (gb - ga);
        }
        if (!(tc > ta && tc < tb))
            tc = 0.5 * (ta + tb);
        double fc = ray_f(w, tc);
        if (fc != 0.0 && (fc > 0.0) == (fa > 0.0)) {
            ta = tc;
            fa = ga = fc;
            if (side == -1)
                gb *= 0.5;
            side = -1;
        } else {
            tb = tc;
            fb = gb = fc;
            if (side == 1)
                ga *= 0.5;
            side = 1;
        }
    }
    *tb_out = tb;
    *fb_out = fb;
    if (fb == 0.0)
        return tb;
    return fabs(fa) < fabs(fb) ? ta : tb;
}

static bool torus_next(walker *w, double *t_hit);

/* The next crossing along the walk, or false at the end of the segment. */
static bool walker_next(walker *w, double *t_hit)
{
    if (w->done)
        return false;
    if (w->s->torus)
        return torus_next(w, t_hit);
    const double dl = w->dl, t1 = w->t1, min_step = w->min_step;
    double t = w->t, f = w->f, r = fabs(f) / dl, omega = SDF_RELAX;
    bool pos = f > 0.0;
    for (int it = 0; it < SDF_MAX_STEPS; ++it) {
        double step = spc_max(omega * r, min_step);
        bool last = false;
        if (t + step >= t1) {
            step = t1 - t;
            last = true;
        }
        double tn = t + step, fn = ray_f(w, tn), rn = fabs(fn) / dl;
        bool crossed = pos ? !(fn > 0.0) : !(fn < 0.0);
        /* a relaxed step is verified only up to r; beyond it, the unbounding spheres must overlap
         * (Keinert et al. 2014), and a crossing there may not be the first: redo the step plainly */
        if (omega > 1.0 && step > spc_max(r, min_step) && (crossed || step > r + rn)) {
            omega = 1.0;
            continue;
        }
        if (crossed) {
            if (isnan(fn))
                break;
            double tb;
            *t_hit = refine(w, t, f, tn, fn, &tb, &w->f);
            /* continue from the far end of the bracket (f there has the other sign, or is 0) */
            w->t = tb;
            if (w->f == 0.0) {
                w->t = tb + min_step;
                w->f = w->t < t1 ? ray_f(w, w->t) : 0.0;
            }
            w->done = !(w->t < t1) || w->f == 0.0 || isnan(w->f);
            return true;
        }
        if (last)
            break;
        t = tn;
        f = fn;
        r = rn;
    }
    w->done = true;
    return false;
}

/* ------------------------------------------------------------------------------------------------ */
/* analytic ray-torus crossings */

/* A ring torus (major R > minor r) around the local y axis is the zero set of the quartic
 * q(p) = (|p|^2 + R^2 - r^2)^2 - 4 R^2 (p_x^2 + p_z^2) = ((rho - R)^2 + y^2 - r^2) ((rho + R)^2 + y^2 - r^2)
 * with rho = |p_xz|; the second factor is at least R^2 - r^2 > 0, so q has the sign of the exact
 * distance f. Along the ray p = o + s d (s = t - t_start, the walk's current point as origin, which
 * keeps the coefficients near the torus's scale),
 * q(s) = a^2 s^4 + 4ab s^3 + (4b^2 + 2ac - 4R^2 e) s^2 + (4bc - 8R^2 g) s + c^2 - 4R^2 h
 * with a = d.d, b = o.d, c = o.o + R^2 - r^2, e = d_x^2 + d_z^2, g = o_x d_x + o_z d_z,
 * h = o_x^2 + o_z^2. Between consecutive critical points of q (the roots of the cubic q', each
 * found by safeguarded Newton between consecutive roots of the quadratic q'', found the same way
 * between q'''s closed-form root) q is monotone, so f changes sign at most once there. The walk
 * evaluates f at those points and refines the first sign change with the same regula falsi as
 * sphere tracing, started from a bracket of 1e-9 of the size around the quartic's root in that
 * piece when f changes sign across it: no crossing is missed at grazing angles (a pair of crossings
 * is separated by a critical point), and the hit is refined on the exact distance. */

/* Steps of the safeguarded Newton iteration for a root of q or its derivatives (it converges in a few;
 * bisection bounds the rest, halving the bracket to the rounding level well before this). */
#define SDF_TORUS_BISECT 200
/* Half width, relative to the size, of the bracket around the quartic's root that the exact
 * distance refines (the quartic's root is good to ~1e-13 of the size away from tangency). */
#define SDF_TORUS_BRACKET 1e-9
/* Half width, in units of the rounding of t (eps (|t| + the coordinates' magnitude / |d|)), of the
 * bracket around the Newton step from the quartic's root: 3 in all, below refine's stopping width
 * of 4, so that refine takes the bracket as it is. On scenes/caustic_sdf_torus.xml 99.2% of the
 * crossings' brackets hold the sign change (151,594 of 152,847 at 10 spp). */
#define SDF_TORUS_NEWTON_HALF 1.5

static double poly_eval(const double *c, int deg, double s)
{
    double v = c[deg];
    for (int k = deg - 1; k >= 0; --k)
        v = v * s + c[k];
    return v;
}

/* The root of polynomial c (degree deg) in the bracket [a, b] where it is monotone and
 * changes sign (fa = c(a)): Newton's method from the middle, bisecting whenever a step leaves the
 * bracket, until the bracket or the step falls below the rounding level, or c(x) itself does: where
 * |c(x)| is within the rounding error of its evaluation (4 deg eps sum |c_k| |x|^k) its sign says
 * nothing more, and the steps that followed only halved the bracket, one bit each. On the SDF
 * torus's quartics that was 7% of the calls at 11-60 steps, 0.29 of all steps (mean 7.6 steps a
 * call; stopped at the rounding level 5.6, and 0.1% above 10); the root moves within that level,
 * far inside the 1e-9 bracket that refine then narrows on the exact distance. *steps gets the
 * steps run. */
static double poly_root_monotone(const double *c, int deg, double a, double b, double fa, int *steps)
{
    double dc[4];
    for (int k = 1; k <= deg; ++k)
        dc[k - 1] = k * c[k];
    double x = 0.5 * (a + b);
    for (int it = 0; it < SDF_TORUS_BISECT; ++it) {
        *steps = it + 1;
        double fx = poly_eval(c, deg, x);
        if (fx == 0.0)
            return x;
        double ax = fabs(x), bound = fabs(c[deg]);
        for (int k = deg - 1; k >= 0; --k)
            bound = bound * ax + fabs(c[k]);
        if (fabs(fx) <= 4.0 * deg * DBL_EPSILON * bound)
            return x;
        if ((fx > 0.0) == (fa > 0.0))
            a = x;
        else
            b = x;
        double tol = 4.0 * DBL_EPSILON * (fabs(a) + fabs(b));
        if (!(b - a > tol))
            break;
        double xn = x - fx / poly_eval(dc, deg - 1, x);
        if (!(xn > a && xn < b))
            xn = 0.5 * (a + b);
        if (fabs(xn - x) <= tol)
            return xn;
        x = xn;
    }
    return 0.5 * (a + b);
}

double spc_sdf_poly_root(const double *c, int deg, double a, double b, int *steps)
{
    return poly_root_monotone(c, deg, a, b, poly_eval(c, deg, a), steps);
}

/* The roots of the polynomial c (degree deg, c[deg] != 0) in (lo, hi), sorted, into out; the pieces
 * between the sorted roots of its derivative are monotone, so each holds at most one root. */
static int poly_roots_in(const double *c, int deg, double lo, double hi, double *out)
{
    double cut[4], dc[4];
    int nc = 0;
    if (deg == 1) {
        double s = -c[0] / c[1];
        if (s > lo && s < hi)
            out[nc++] = s;
        return nc;
    }
    for (int k = 1; k <= deg; ++k)
        dc[k - 1] = k * c[k];
    nc = poly_roots_in(dc, deg - 1, lo, hi, cut);
    double ends[6];
    int ne = 0, n = 0;
    ends[ne++] = lo;
    for (int k = 0; k < nc; ++k)
        ends[ne++] = cut[k];
    ends[ne++] = hi;
    double fa = poly_eval(c, deg, lo);
    for (int k = 0; k + 1 < ne; ++k) {
        double a = ends[k], b = ends[k + 1];
        double fb = poly_eval(c, deg, b);
        if (fa == 0.0) {
            if (a > lo && (n == 0 || out[n - 1] < a))
                out[n++] = a;
        } else if (fb != 0.0 && (fa > 0.0) != (fb > 0.0)) {
            int steps;
            out[n++] = poly_root_monotone(c, deg, a, b, fa, &steps);
        }
        fa = fb;
    }
    return n;
}

/* Margin, relative to R + r, by which torus_misses widens the torus's slab and cylinders: far
 * above the rounding of the exact distance's sign (1e-16 of the size), so that a segment it rejects
 * holds no point where f is computed as 0 or negative. */
#define SDF_TORUS_MISS_MARGIN 1e-6

static _Thread_local uint64_t torus_solves = 0;

uint64_t spc_sdf_torus_solves(void) { return torus_solves; }

/* Whether the segment [t, t1] of the walk stays outside the ring torus (major R, minor r, around
 * the local y axis): every point of the tube has |y| <= r and R - r <= rho <= R + r (rho = |p_xz|).
 * The segment is clipped to the slab |y| <= r, and rejected if what is left is empty, or stays
 * outside the cylinder rho = R + r (rho^2 is a quadratic in t: its minimum on the piece), or inside
 * the hole's cylinder rho = R - r (its maximum, at an end). All three widened by the margin, so a
 * rejected segment is one on which f never changes sign: the crossings are those the quartic would
 * have found (none), and a ray that misses (13% of the walks on scenes/caustic_sdf_torus.xml, a
 * world box around a tilted ring is loose) skips the quartic's critical points. */
static bool torus_misses(const walker *w, double R, double r)
{
    const spc_vec3 o = w->lo, d = w->ld;
    const double m = SDF_TORUS_MISS_MARGIN * (R + r), ys = r + m;
    double ta = w->t, tb = w->t1;
    if (d.y != 0.0) {
        double u = (-ys - o.y) / d.y, v = (ys - o.y) / d.y;
        ta = spc_max(ta, spc_min(u, v));
        tb = spc_min(tb, spc_max(u, v));
        if (!(ta < tb))
            return true;
    } else if (!(fabs(o.y) <= ys)) {
        return true;
    }
    /* rho^2(t) = A t^2 + 2 B t + C */
    double A = d.x * d.x + d.z * d.z, B = o.x * d.x + o.z * d.z, C = o.x * o.x + o.z * o.z;
    double ra = (A * ta + 2.0 * B) * ta + C, rb = (A * tb + 2.0 * B) * tb + C;
    double lo = spc_min(ra, rb), hi = spc_max(ra, rb);
    if (A > 0.0 && -B > A * ta && -B < A * tb)
        lo = C - B * B / A;
    double out = R + r + m, in = R - r - m;
    return lo > out * out || (in > 0.0 && hi < in * in);
}

/* The roots of the cubic c (c[3] != 0) in (lo, hi) one at a time, in order, as poly_roots_in finds
 * them (the same numbers): the walk needs the critical points of its quartic only up to the piece
 * where f changes sign, usually the first, so the later ones are not solved for. */
typedef struct crit_walk {
    const double *c;
    double ends[4]; /* lo, the roots of c' in (lo, hi), hi */
    int ne, k, n;   /* ends, the next piece, roots returned */
    double fa, last, lo;
} crit_walk;

static void crit_walk_init(crit_walk *cw, const double *c, double lo, double hi)
{
    double dc[3] = {c[1], 2.0 * c[2], 3.0 * c[3]}, cut[2];
    int nc = poly_roots_in(dc, 2, lo, hi, cut);
    cw->c = c;
    cw->ne = 0;
    cw->ends[cw->ne++] = lo;
    for (int k = 0; k < nc; ++k)
        cw->ends[cw->ne++] = cut[k];
    cw->ends[cw->ne++] = hi;
    cw->k = 0;
    cw->n = 0;
    cw->lo = lo;
    cw->last = lo;
    cw->fa = poly_eval(c, 3, lo);
}

static bool crit_walk_next(crit_walk *cw, double *x)
{
    while (cw->k + 1 < cw->ne) {
        double a = cw->ends[cw->k], b = cw->ends[cw->k + 1], fa = cw->fa;
        double fb = poly_eval(cw->c, 3, b);
        cw->fa = fb;
        ++cw->k;
        if (fa == 0.0) {
            if (a > cw->lo && (cw->n == 0 || cw->last < a)) {
                cw->last = *x = a;
                ++cw->n;
                return true;
            }
        } else if (fb != 0.0 && (fa > 0.0) != (fb > 0.0)) {
            int steps;
            cw->last = *x = poly_root_monotone(cw->c, 3, a, b, fa, &steps);
            ++cw->n;
            return true;
        }
    }
    return false;
}

/* f along the walk at t and its slope df/dt, for the ring torus at the root (prim_dist's torus and
 * its gradient along ld). */
static double torus_f_slope(const walker *w, double R, double r, double t, double *slope)
{
    spc_vec3 p = spc_madd(w->lo, w->ld, t), d = w->ld;
    double rho = len2d(p.x, p.z), q1 = rho - R, L = len2d(q1, p.y);
    *slope = w->rs * (q1 / L * (p.x * d.x + p.z * d.z) / rho + p.y * d.y / L);
    return w->rs * (L - r);
}

static bool torus_next(walker *w, double *t_hit)
{
    const node *n = &w->s->nodes[w->s->root];
    const double R = n->r, r = n->r2, t0 = w->t, t1 = w->t1;
    if (torus_misses(w, R, r)) {
        w->done = true;
        return false;
    }
    ++torus_solves;
    spc_vec3 o = spc_madd(w->lo, w->ld, t0), d = w->ld;
    double a = spc_dot(d, d), b = spc_dot(o, d), c = spc_dot(o, o) + R * R - r * r;
    double e = d.x * d.x + d.z * d.z, g = o.x * d.x + o.z * d.z, h = o.x * o.x + o.z * o.z;
    /* q / a^2, so that the leading coefficient is 1 */
    double q[5] = {(c * c - 4.0 * R * R * h) / (a * a), (4.0 * b * c - 8.0 * R * R * g) / (a * a),
                   (4.0 * b * b + 2.0 * a * c - 4.0 * R * R * e) / (a * a), 4.0 * b / a, 1.0};
    double dq[4] = {q[1], 2.0 * q[2], 3.0 * q[3], 4.0 * q[4]}, crit;
    crit_walk cw;
    crit_walk_init(&cw, dq, 0.0, t1 - t0);
    double ta = t0, fa = w->f;
    for (bool more = true; more;) {
        more = crit_walk_next(&cw, &crit);
        double tb = more ? t0 + crit : t1;
        if (!(tb > ta))
            continue;
        double fb = ray_f(w, tb);
        if (isnan(fb))
            break;
        if ((fa > 0.0) ? !(fb > 0.0) : !(fb < 0.0)) {
            /* narrow the bracket to the quartic's root when f changes sign across it */
            double qa = poly_eval(q, 4, ta - t0), qb = poly_eval(q, 4, tb - t0);
            if (qa != 0.0 && qb != 0.0 && (qa > 0.0) != (qb > 0.0)) {
                int steps;
                double tq = t0 + poly_root_monotone(q, 4, ta - t0, tb - t0, qa, &steps);
                double dt = SDF_TORUS_BRACKET * w->s->size / w->dl;
                if (tq - dt > ta && tq + dt < tb) {
                    /* one Newton step on the exact distance from the quartic's root, and a bracket of
                     * refine's final width around it (99% of the crossings: one exact distance and
                     * two values instead of two values and four regula falsi steps); where its ends
                     * do not differ in sign (grazing rays, rounding), the bracket of 1e-9 */
                    double slope, fq = torus_f_slope(w, R, r, tq, &slope);
                    double tn = tq - fq / slope;
                    double h = SDF_TORUS_NEWTON_HALF * DBL_EPSILON * (fabs(tn) + w->tol_mag / w->dl);
                    bool tight = false;
                    if (fabs(tn - tq) < dt && tn - h > ta && tn + h < tb) {
                        double fl = ray_f(w, tn - h), fr = ray_f(w, tn + h);
                        if ((fl > 0.0) == (fa > 0.0) && ((fa > 0.0) ? !(fr > 0.0) : !(fr < 0.0))) {
                            ta = tn - h;
                            fa = fl;
                            tb = tn + h;
                            fb = fr;
                            tight = true;
                        }
                    }
                    double fl = 0.0, fr = 0.0;
                    if (!tight) {
                        fl = ray_f(w, tq - dt);
                        fr = ray_f(w, tq + dt);
                    }
                    if (!tight && (fl > 0.0) == (fa > 0.0) && ((fa > 0.0) ? !(fr > 0.0) : !(fr < 0.0))) {
                        ta = tq - dt;
                        fa = fl;
                        tb = tq + dt;
                        fb = fr;
                    }
                }
            }
            double tend;
            *t_hit = refine(w, ta, fa, tb, fb, &tend, &w->f);
            w->t = tend;
            if (w->f == 0.0) {
                w->t = tend + w->min_step;
                w->f = w->t < t1 ? ray_f(w, w->t) : 0.0;
            }
            w->done = !(w->t < t1) || w->f == 0.0 || isnan(w->f);
            return true;
        }
        ta = tb;
        fa = fb;
    }
    w->done = true;
    return false;
}

void spc_sdf_set_analytic(spc_sdf *s, bool on)
{
    const node *rn = s->finalized ? &s->nodes[s->root] : NULL;
    s->torus = on && rn && rn->type == SPC_SDF_TORUS && rn->r > rn->r2 && rn->r2 > 0.0;
}

bool spc_sdf_intersect(const spc_sdf *s, const spc_ray *r, double *t)
{
    walker w;
    if (!walker_init(&w, s, r))
        return false;
    double th;
    if (!walker_next(&w, &th) || !(th > r->tmin && th < r->tmax))
        return false;
    *t = th;
    return true;
}

int spc_sdf_crossings(const spc_sdf *s, const spc_ray *r, double *t, int max)
{
    walker w;
    if (!walker_init(&w, s, r))
        return 0;
    int n = 0;
    double th;
    while (n <= max && walker_next(&w, &th)) {
        if (n < max && t)
            t[n] = th;
        ++n;
    }
    return n;
}

/* ------------------------------------------------------------------------------------------------ */
/* finalize: bounds and area */

static double radical_inverse(unsigned base, uint64_t i)
{
    double inv = 1.0 / base, f = inv, x = 0.0;
    while (i > 0) {
        x += f * (double)(i % base);
        i /= base;
        f *= inv;
    }
    return x;
}

/* A line uniform in direction and in the disk of the bounding sphere perpendicular to it, from
 * four uniform numbers, as a ray spanning the sphere. */
static spc_ray random_line(const spc_sdf *s, double u0, double u1, double u2, double u3)
{
    spc_vec3 w = spc_warp_uniform_sphere(spc_v2(u0, u1));
    spc_vec2 dk = spc_warp_disk_concentric(spc_v2(u2, u3));
    spc_frame fr = spc_frame_from_n(w);
    spc_ray r;
    r.o = spc_madd(spc_add(s->bc, spc_add(spc_scale(fr.s, dk.x * s->br), spc_scale(fr.t, dk.y * s->br))), w, -s->br);
    r.d = w;
    r.tmin = 0.0;
    r.tmax = 2.0 * s->br;
    return r;
}

bool spc_sdf_finalize(spc_sdf *s, int root, const spc_mat4 *to_world, const char *file, int line, int col,
                      spc_error *err)
{
    if (s->finalized) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "sdf: already finalized");
        return false;
    }
    if (root < 0 || root >= s->n) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "sdf: no root node");
        return false;
    }
    node *rn = &s->nodes[root];
    if (to_world) {
        spc_mat4 M = spc_mat4_mul(to_world, &rn->to_world);
        double sc = similarity_scale(&M);
        if (!(sc > 0.0) || !spc_mat4_inverse(&M, &rn->to_local)) {
            spc_error_set(err, SPC_ERR_VALUE, file, line, col,
                          "to_world must be a rotation, a uniform scale and a translation (a non-uniformly "
                          "scaled distance field is not a distance)");
            return false;
        }
        rn->to_world = M;
        rn->s = sc;
        rn->xf = true;
    }
    s->root = root;
    spc_vec3 lo, hi;
    node_box(s, root, 0.0, &lo, &hi);
    if (!spc_v3_finite(lo) || !spc_v3_finite(hi)) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col,
                      "the field is unbounded (a plane must be intersected with, or subtracted from, a bounded "
                      "shape)");
        return false;
    }
    if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "the field is empty (its intersection has no volume)");
        return false;
    }
    s->size = spc_length(spc_sub(hi, lo));
    if (!(s->size > 0.0) || !isfinite(s->size)) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "the field has zero size");
        return false;
    }
    node_box(s, root, SDF_BOX_PAD * s->size, &s->lo, &s->hi);
    s->bc = spc_scale(spc_add(s->lo, s->hi), 0.5);
    s->br = 0.5 * spc_length(spc_sub(s->hi, s->lo));
    s->finalized = true;
    spc_sdf_set_analytic(s, true);

    double a = spc_sdf_type_is_operation(rn->type) ? 0.0 : prim_area(rn) * rn->s * rn->s;
    s->area_exact = a > 0.0;
    if (!s->area_exact) {
        /* Cauchy-Crofton: area = 2 pi R^2 E[#crossings] */
        uint64_t total = 0;
        for (uint64_t i = 1; i <= SDF_AREA_LINES; ++i) {
            spc_ray r = random_line(s, radical_inverse(2, i), radical_inverse(3, i), radical_inverse(5, i),
                                    radical_inverse(7, i));
            total += (uint64_t)spc_sdf_crossings(s, &r, NULL, 1 << 20);
        }
        a = 2.0 * SPC_PI * s->br * s->br * (double)total / (double)SDF_AREA_LINES;
    }
    s->area = a;
    if (!(a > 0.0) || !isfinite(a)) {
        s->finalized = false;
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "the field has no surface");
        return false;
    }
    return true;
}

void spc_sdf_bounds(const spc_sdf *s, spc_vec3 *lo, spc_vec3 *hi)
{
    *lo = s->lo;
    *hi = s->hi;
}

double spc_sdf_size(const spc_sdf *s) { return s->size; }
double spc_sdf_area(const spc_sdf *s) { return s->area; }
bool spc_sdf_area_is_exact(const spc_sdf *s) { return s->area_exact; }

static bool node_has_creases(const spc_sdf *s, int i)
{
    if (i < 0 || i >= s->n)
        return false;
    const node *n = &s->nodes[i];
    switch (n->type) {
    case SPC_SDF_SPHERE:
    case SPC_SDF_TORUS:
    case SPC_SDF_CAPSULE: return false;
    case SPC_SDF_ROUNDBOX: return !(n->r > 0.0);
    case SPC_SDF_SMOOTH_UNION: return node_has_creases(s, n->a) || node_has_creases(s, n->b);
    case SPC_SDF_BOX:
    case SPC_SDF_CYLINDER:
    case SPC_SDF_PLANE:
    case SPC_SDF_UNION:
    case SPC_SDF_INTERSECTION:
    case SPC_SDF_DIFFERENCE: return true;
    }
    return true;
}

bool spc_sdf_has_creases(const spc_sdf *s) { return node_has_creases(s, s->root); }

/* ------------------------------------------------------------------------------------------------ */
/* surface interaction and sampling */

void spc_sdf_fill_hit(const spc_sdf *s, spc_vec3 p, bool flip_normals, spc_hit *h)
{
    spc_vec3 g;
    double H[3][3];
    spc_sdf_eval_hessian(s, p, &g, H);
    double gl = spc_length(g);
    spc_vec3 n = gl > 0.0 ? spc_scale(g, 1.0 / gl) : spc_v3(0, 0, 1);
    spc_frame fr = spc_frame_from_n(n);
    /* surface parameters: coordinates in the tangent plane along fr.s, fr.t (unit speed) */
    spc_vec3 T[2] = {fr.s, fr.t}, dn[2];
    double sgn = flip_normals ? -1.0 : 1.0;
    for (int k = 0; k < 2; ++k) {
        double t[3] = {T[k].x, T[k].y, T[k].z}, v[3];
        for (int i = 0; i < 3; ++i)
            v[i] = H[i][0] * t[0] + H[i][1] * t[1] + H[i][2] * t[2];
        spc_vec3 Ht = spc_v3(v[0], v[1], v[2]);
        /* dn = (I - n n^T) H dp / |grad f| */
        dn[k] = gl > 0.0 ? spc_scale(spc_sub(Ht, spc_scale(n, spc_dot(n, Ht))), sgn / gl) : spc_v3(0, 0, 0);
    }
    h->p = p;
    h->ng = spc_scale(n, sgn);
    h->dpdu = T[0];
    h->dpdv = T[1];
    h->dndu = dn[0];
    h->dndv = dn[1];
    h->sh = spc_frame_from_ns(h->ng, T[0]);
    h->b1 = h->b2 = 0.0;
    /* texture coordinates: spherical angles of p in the root's frame, as the sphere shape's */
    spc_vec3 l = spc_normalize(spc_mat4_apply_point(&s->nodes[s->root].to_local, p));
    double phi = atan2(l.y, l.x);
    if (phi < 0.0)
        phi += 2.0 * SPC_PI;
    h->uv = spc_v2(phi * SPC_INV_2PI, acos(spc_clamp(l.z, -1.0, 1.0)) * SPC_INV_PI);
    h->err = SDF_OFFSET * (spc_max_abs(p) + s->size);
}

bool spc_sdf_sample_area(const spc_sdf *s, spc_vec2 u, spc_vec3 *p)
{
    uint64_t bx, by;
    memcpy(&bx, &u.x, sizeof bx);
    memcpy(&by, &u.y, sizeof by);
    spc_rng rng;
    spc_rng_seed(&rng, spc_hash_combine(bx, by), 0x5df5df5dull);
    int nmax = s->nodes[s->root].nmax;
    bool have_fallback = false;
    for (int trial = 0; trial < SDF_SAMPLE_TRIALS; ++trial) {
        double u0 = spc_rng_next(&rng), u1 = spc_rng_next(&rng), u2 = spc_rng_next(&rng), u3 = spc_rng_next(&rng);
        spc_ray r = random_line(s, u0, u1, u2, u3);
        int j = (int)(spc_rng_next(&rng) * nmax);
        if (j >= nmax)
            j = nmax - 1;
        walker w;
        if (!walker_init(&w, s, &r))
            continue;
        double t;
        int k = 0;
        while (walker_next(&w, &t)) {
            if (k++ == j) {
                *p = spc_madd(r.o, r.d, t);
                return true;
            }
            if (!have_fallback) {
                *p = spc_madd(r.o, r.d, t);
                have_fallback = true;
            }
        }
    }
    /* out of trials (acceptance below ~1e-4): some surface point rather than none, so that
     * callers dividing by the density stay finite (a bias only for such degenerate shapes) */
    return have_fallback;
}

double spc_sdf_pdf_direction(const spc_sdf *s, spc_vec3 ref)
{
    double dist2 = spc_length2(spc_sub(s->bc, ref));
    if (dist2 <= s->br * s->br)
        return SPC_INV_4PI;
    double cos_max = sqrt(spc_max(0.0, 1.0 - s->br * s->br / dist2));
    return spc_warp_uniform_cone_pdf(cos_max);
}

bool spc_sdf_sample_direction(const spc_sdf *s, spc_vec3 ref, spc_vec2 u, spc_vec3 *p, double *pdf)
{
    spc_vec3 dc = spc_sub(s->bc, ref);
    double dist2 = spc_length2(dc);
    spc_vec3 w;
    if (dist2 <= s->br * s->br) {
        w = spc_warp_uniform_sphere(u);
    } else {
        double cos_max = sqrt(spc_max(0.0, 1.0 - s->br * s->br / dist2));
        spc_frame fr = spc_frame_from_n(spc_scale(dc, 1.0 / sqrt(dist2)));
        w = spc_frame_to_world(&fr, spc_warp_uniform_cone(u, cos_max));
    }
    *pdf = spc_sdf_pdf_direction(s, ref);
    spc_ray r = {ref, w, 0.0, INFINITY};
    double t;
    if (!spc_sdf_intersect(s, &r, &t))
        return false;
    *p = spc_madd(ref, w, t);
    return true;
}

/* ------------------------------------------------------------------------------------------------ */
/* flat program */

typedef struct flat_state {
    const spc_sdf *s;
    spc_sdf_flat *out;
    int max, n, sp, depth;
} flat_state;

static void affine_rows(const spc_mat4 *m, double M[3][4])
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 4; ++j)
            M[i][j] = m->m[i][j];
}

/* Node i under the world-to-parent map W (a similarity of scale ws, world per parent unit). */
static void flatten_node(flat_state *st, int i, const spc_mat4 *W, double ws)
{
    const node *n = &st->s->nodes[i];
    spc_mat4 Wn = n->xf ? spc_mat4_mul(&n->to_local, W) : *W;
    double sn = n->xf ? ws * n->s : ws;
    if (spc_sdf_type_is_operation(n->type)) {
        flatten_node(st, n->a, &Wn, sn);
        flatten_node(st, n->b, &Wn, sn);
    }
    if (st->n < st->max) {
        spc_sdf_flat *f = &st->out[st->n];
        memset(f, 0, sizeof *f);
        f->type = n->type;
        affine_rows(&Wn, f->M);
        f->s = sn;
        double *q = f->param;
        switch (n->type) {
        case SPC_SDF_SPHERE: q[0] = n->r; break;
        case SPC_SDF_BOX:
        case SPC_SDF_ROUNDBOX:
            q[0] = n->v0.x;
            q[1] = n->v0.y;
            q[2] = n->v0.z;
            q[3] = n->type == SPC_SDF_ROUNDBOX ? n->r : 0.0;
            break;
        case SPC_SDF_TORUS:
            q[0] = n->r;
            q[1] = n->r2;
            break;
        case SPC_SDF_CAPSULE:
            q[0] = n->v0.x;
            q[1] = n->v0.y;
            q[2] = n->v0.z;
            q[3] = n->v1.x;
            q[4] = n->v1.y;
            q[5] = n->v1.z;
            q[6] = n->r;
            break;
        case SPC_SDF_CYLINDER:
            q[0] = n->r;
            q[1] = n->h;
            break;
        case SPC_SDF_PLANE:
            q[0] = n->v0.x;
            q[1] = n->v0.y;
            q[2] = n->v0.z;
            q[3] = n->h;
            break;
        case SPC_SDF_SMOOTH_UNION: q[0] = n->r * sn; break;
        case SPC_SDF_UNION:
        case SPC_SDF_INTERSECTION:
        case SPC_SDF_DIFFERENCE: break;
        }
    }
    st->n++;
    st->sp += spc_sdf_type_is_operation(n->type) ? -1 : 1;
    if (st->sp > st->depth)
        st->depth = st->sp;
}

int spc_sdf_flatten(const spc_sdf *s, spc_sdf_flat *out, int max, int *depth)
{
    if (!s->finalized)
        return -1;
    flat_state st = {s, out, max, 0, 0, 0};
    spc_mat4 I = spc_mat4_identity();
    flatten_node(&st, s->root, &I, 1.0);
    *depth = st.depth;
    return st.n;
}
