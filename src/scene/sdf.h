/*
 * scene/sdf.h: signed distance field shapes: a tree of primitives and CSG operations, evaluated
 * with its gradient and Hessian, intersected by sphere tracing, and sampled by area and by solid
 * angle. Used by the shape type SPC_SHAPE_SDF (scene/shape.h).
 *
 * Conventions:
 * - f < 0 inside the solid, f > 0 outside, f = 0 on the surface; the outward normal is
 *   grad f / |grad f|. Lengths are in the units of the space the function is evaluated in (world
 *   space once finalized).
 * - Every node has a to_world transform (from its own frame to its parent's; the root's parent is
 *   the world, and the shape's to_world is composed onto the root). A transform must be a
 *   similarity (rotation or mirror, uniform scale s, translation): the node's value is
 *   s * f_local(to_local(p)), which stays a distance bound. A non-uniformly scaled field is no
 *   longer a distance bound, so it is rejected.
 * - Primitive fields are exact Euclidean distances. Union (min), intersection (max), difference
 *   (max(a, -b)) and smooth union (polynomial smooth minimum with width k) are only bounds:
 *   |f(p)| <= distance from p to the surface. All are 1-Lipschitz (see sdf.c), which is what makes
 *   a sphere-tracing step of |f| safe.
 * - Local frames: torus and cylinder have their axis along local +y (the convention of the SDF
 *   literature: Quilez; paper 004's torus); the plane is n . p = offset with the solid on the
 *   side n . p < offset.
 *
 * XML (<sdf type="..."> nested in <shape type="sdf">, each with an optional <transform
 * name="to_world">); defaults in parentheses:
 *   sphere        radius (1)
 *   box           half_size (1,1,1) or size (= 2 half_size)
 *   roundbox      half_size (1,1,1) or size, radius (0.1): corner radius, 0 <= radius <= half sizes
 *   torus         major_radius (1), minor_radius (0.25); around local y
 *   capsule       p0 (0,0,0), p1 (0,1,0), radius (0.5)
 *   cylinder      radius (1), height (2); capped, centred on the origin, axis local y
 *   plane         normal (0,1,0), offset (0); only inside an intersection or difference (the whole
 *                 shape must be bounded)
 *   union, intersection, difference (first child minus the others), smooth_union (k 0.1): two or
 *                 more nested <sdf> children, folded from the left
 */
#ifndef SPC_SCENE_SDF_H
#define SPC_SCENE_SDF_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "core/math.h"
#include "scene/hit.h"

typedef enum spc_sdf_type {
    SPC_SDF_SPHERE,
    SPC_SDF_BOX,
    SPC_SDF_ROUNDBOX,
    SPC_SDF_TORUS,
    SPC_SDF_CAPSULE,
    SPC_SDF_CYLINDER,
    SPC_SDF_PLANE,
    SPC_SDF_UNION,
    SPC_SDF_INTERSECTION,
    SPC_SDF_DIFFERENCE,
    SPC_SDF_SMOOTH_UNION
} spc_sdf_type;

/* A node description (what spc_sdf_add copies). Fields not used by the type are ignored. */
typedef struct spc_sdf_desc {
    spc_sdf_type type;
    double radius;      /* sphere, capsule, cylinder; roundbox corner radius */
    spc_vec3 half_size; /* box, roundbox (outer half sizes) */
    double major, minor; /* torus */
    spc_vec3 p0, p1;    /* capsule segment */
    double height;      /* cylinder (full height) */
    spc_vec3 normal;    /* plane (need not be unit: normalized by spc_sdf_add) */
    double offset;      /* plane */
    double k;           /* smooth_union blend width (> 0) */
    int a, b;           /* operations: indices of the two children (added before this node) */
    spc_mat4 to_world;  /* node frame -> parent frame */
} spc_sdf_desc;

typedef struct spc_sdf spc_sdf;

/* Name of a type as in the XML ("sphere", "smooth_union", ...); spc_sdf_type_from_name returns
 * false for an unknown name. */
const char *spc_sdf_type_name(spc_sdf_type t);
bool spc_sdf_type_from_name(const char *name, spc_sdf_type *t);
static inline bool spc_sdf_type_is_operation(spc_sdf_type t) { return t >= SPC_SDF_UNION; }

/* The defaults listed above, identity transform, no children. */
void spc_sdf_desc_init(spc_sdf_desc *d, spc_sdf_type type);
/* Checks a description's values (not children). Returns true if valid; else writes a message to
 * msg and sets *field to the XML property at fault ("radius", "to_world", ...). */
bool spc_sdf_desc_check(const spc_sdf_desc *d, char *msg, size_t msg_size, const char **field);

/* An empty tree; NULL when out of memory. Freed (with everything it holds) by spc_sdf_destroy. */
spc_sdf *spc_sdf_create(void);
void spc_sdf_destroy(spc_sdf *s);
/* Adds a node; returns its index, or -1 with a message in err (invalid values, children that do
 * not exist yet, out of memory) located at file:line:col. */
int spc_sdf_add(spc_sdf *s, const spc_sdf_desc *d, const char *file, int line, int col, spc_error *err);
/* Makes node `root` the field, with `to_world` (NULL: identity; a similarity) composed onto the
 * root's own transform; computes the bounding box, the crossing bound and the surface area (exact
 * for a single primitive, else a deterministic Monte Carlo estimate, see sdf.c). Returns false
 * with a message for an unbounded field (a plane not cut by a bounded shape), a non-similarity
 * transform or a field with no surface. Nodes may not be added afterwards. */
bool spc_sdf_finalize(spc_sdf *s, int root, const spc_mat4 *to_world, const char *file, int line, int col,
                      spc_error *err);

/* ---- queries on a finalized field (world space); thread-safe (read-only) ---- */

double spc_sdf_eval(const spc_sdf *s, spc_vec3 p);
/* Value and gradient (analytic for every node: one-sided at creases, where min/max pick a child). */
double spc_sdf_eval_grad(const spc_sdf *s, spc_vec3 p, spc_vec3 *grad);
/* Value, gradient and Hessian H[i][j] = d2f / dp_i dp_j (analytic; zero on flat pieces). */
double spc_sdf_eval_hessian(const spc_sdf *s, spc_vec3 p, spc_vec3 *grad, double H[3][3]);

/* Axis-aligned bounds (padded so that f > 0 outside them), their diagonal length (the scale every
 * tolerance is relative to) and the surface area. */
void spc_sdf_bounds(const spc_sdf *s, spc_vec3 *lo, spc_vec3 *hi);
double spc_sdf_size(const spc_sdf *s);
double spc_sdf_area(const spc_sdf *s);
bool spc_sdf_area_is_exact(const spc_sdf *s);
/* Whether the surface may have creases, where its normal jumps: a box's or a capped cylinder's
 * edges, a roundbox of radius 0, a plane's cut, or any union, intersection or difference (the
 * min/max meets its children's surfaces at an angle unless they happen not to touch). false where
 * every primitive is smooth (sphere, roundbox with radius > 0, torus, capsule) and they are joined
 * only by smooth unions. */
bool spc_sdf_has_creases(const spc_sdf *s);

/* The first surface crossing of f along r in (r->tmin, r->tmax), in either direction (a ray that
 * starts inside finds its exit). false if none. A ray starting on the surface itself (|f| at the
 * origin below rounding level) ignores crossings closer than the minimum step (1e-7 of the size).
 * The returned t is refined to the rounding level of the coordinates. */
bool spc_sdf_intersect(const spc_sdf *s, const spc_ray *r, double *t);
/* All crossings along r in (tmin, tmax), in order, at most max of them stored; returns how many
 * were found (which may exceed max: counting stops at max + 1). */
int spc_sdf_crossings(const spc_sdf *s, const spc_ray *r, double *t, int max);
/* A field that is one ring torus (major radius above minor) finds its crossings analytically: the
 * critical points of the ray's quartic split the segment into pieces with at most one crossing,
 * and the first piece whose ends differ in sign is refined on the exact distance as sphere tracing
 * refines its brackets. On by default after spc_sdf_finalize; off (on = false), or for any other
 * field, the rays are sphere traced (tests and benchmarks compare the two). */
void spc_sdf_set_analytic(spc_sdf *s, bool on);
/* The root in [a, b] of the polynomial c[0] + c[1] x + ... + c[deg] x^deg (deg 1 to 4), which must
 * be monotone there and change sign, as the analytic torus finds its crossings; *steps gets the
 * Newton or bisection steps it took (for tests). */
double spc_sdf_poly_root(const double *c, int deg, double a, double b, int *steps);
/* Walks that the calling thread's analytic tori have solved so far (their quartic's critical points
 * found): those that the cheap bounds (the torus's slab and cylinders) could not reject. For tests. */
uint64_t spc_sdf_torus_solves(void);

/* Surface interaction at a point p on the surface reached by a ray (see shape.c for the surface
 * parameters): fills p (as given), ng, sh, uv, dpdu, dpdv, dndu, dndv, b1 = b2 = 0 and err. */
void spc_sdf_fill_hit(const spc_sdf *s, spc_vec3 p, bool flip_normals, spc_hit *h);

/* Uniformly distributed point on the surface (density 1 / spc_sdf_area), by line sampling with
 * rejection; u seeds the internal random stream. If the trial budget runs out (a surface whose
 * lines are accepted less than ~1e-4 of the time) it returns some crossing found on the way, and
 * false only if there was none. */
bool spc_sdf_sample_area(const spc_sdf *s, spc_vec2 u, spc_vec3 *p);
/* A direction from ref, uniform in the cone subtended by the bounding sphere (or the whole
 * sphere of directions when ref is inside it), traced to the first surface crossing *p. *pdf is
 * that direction density in solid angle (also the density of *p, in solid angle at ref, as the
 * first crossing is a function of the direction). Returns false if the ray misses the surface. */
bool spc_sdf_sample_direction(const spc_sdf *s, spc_vec3 ref, spc_vec2 u, spc_vec3 *p, double *pdf);
/* The density above, for any first-crossing point seen from ref. */
double spc_sdf_pdf_direction(const spc_sdf *s, spc_vec3 ref);

/* ---- the field as a flat program (for devices that cannot recurse: src/device/) ---- */

/* One instruction of a postfix program over a value stack: a primitive pushes its field value at
 * the world point p, s * f_local(M p) (M the composed world-to-node transform, s the composed
 * scale); an operation pops its two operands (b on top) and pushes the result in world units
 * (min and max commute with the positive scale, and the smooth minimum's width is k s). */
typedef struct spc_sdf_flat {
    spc_sdf_type type;
    double M[3][4];   /* primitives: world -> node frame (rows of the affine map) */
    double s;         /* primitives: world length of a unit of the node frame */
    double param[8];  /* sphere r; box hx hy hz; roundbox inner hx hy hz, r; torus R, r; capsule
                       * ax ay az bx by bz r; cylinder r, half height; plane nx ny nz offset;
                       * smooth_union k (world units) */
} spc_sdf_flat;

/* Writes the postfix program of a finalized field into out (at most max instructions) and the
 * stack depth it needs into *depth. Returns the instruction count (which may exceed max: then
 * only the first max were written), or -1 if s is not finalized. */
int spc_sdf_flatten(const spc_sdf *s, spc_sdf_flat *out, int max, int *depth);

#endif
