/*
 * scene/hit.h: a ray's intersection with a surface, with what shading and the specular solvers need.
 *
 * Conventions:
 * - ng is the unit geometric normal, oriented as the shape defines it (outward for closed shapes,
 *   the triangle winding for meshes, flipped if the shape says flip_normals). It is NOT flipped
 *   toward the ray.
 * - sh is the shading frame: sh.n is the interpolated shading normal; for meshes with vertex
 *   normals ng is flipped to lie on the same side as sh.n (Mitsuba's convention). sh.s follows the
 *   texture-space tangent dP/du(texture) where the mesh has uvs (normal maps need it), else dpdu.
 * - dpdu, dpdv, dndu, dndv are derivatives of the position and of the unit shading normal with
 *   respect to the shape's SURFACE PARAMETERS (b1, b2): for triangles the barycentric coordinates
 *   of vertices 1 and 2 (p = (1-b1-b2) p0 + b1 p1 + b2 p2); for analytic shapes their (u, v)
 *   parameterization (documented in shape.c). The specular solvers rely on these.
 * - err is a bound on the absolute error of p, used by spc_hit_spawn to offset new rays.
 * - normal_mapped: the hit is a specular chain vertex whose normal map has already been applied
 *   (spc_bsdf_map_chain_hit): sh is the mapped frame, dndu/dndv its normal's derivatives, and
 *   n_unmapped the shading normal the map perturbed. False for every hit the shapes fill.
 * - Every field is filled, except in the shading records of the packet calls (scene.h): on a mesh
 *   whose BSDF reads no derivatives (spc_shape.lazy_derivs) they leave dpdu, dpdv, dndu, dndv and
 *   n_unmapped out, and spc_shape_hit_derivatives fills them on demand, the values that
 *   spc_shape_fill_hit gives. Shading reads t, p, ng, sh, uv, err, the indices and pointers.
 * - On a sphere whose BSDF and emitter read no uv (spc_shape.uv_unread) uv, b1 and b2 are zero;
 *   on such a mesh the packet calls' shading records leave uv at zero (spc_shape_hit_derivatives
 *   fills it with the derivatives).
 */
#ifndef SPC_SCENE_HIT_H
#define SPC_SCENE_HIT_H

#include "core/math.h"
#include <stdint.h>
#include <string.h>

struct spc_shape;
struct spc_bsdf;
struct spc_emitter;

/* The fields that shading reads and the packet calls fill come first, the derivatives last: a path
 * tracer that keeps many records (integrator/path_wave.c, 256 of them) walks each stage over the
 * first 26 words of every record, not over its 41. */
typedef struct spc_hit {
    double t;        /* ray distance */
    spc_vec3 p;      /* world position */
    spc_vec3 ng;     /* geometric normal */
    spc_frame sh;    /* shading frame */
    spc_vec2 uv;     /* texture coordinates */
    double err;      /* absolute error bound of p */
    double b1, b2;   /* barycentrics of vertices 1 and 2 (triangles), surface coords otherwise */
    const struct spc_shape *shape;
    const struct spc_bsdf *bsdf;       /* never NULL for a surface hit */
    const struct spc_emitter *emitter; /* area emitter attached to the shape, or NULL */
    int prim;        /* triangle index, 0 for analytic shapes */
    int shape_index; /* index in scene->shapes */
    bool normal_mapped;
    spc_vec3 dpdu, dpdv;
    spc_vec3 dndu, dndv;
    spc_vec3 n_unmapped; /* see normal_mapped */
} spc_hit;

/* The offset origin for a ray leaving h in direction d (robust against self-intersection):
 * p moved along ng, to the side d points to, by a multiple of the error bound. The sign is set by
 * flipping err's sign bit rather than by a branch: the side a new ray leaves by has no pattern
 * (a twosided wall is left on either side), and the mispredicted branch was the hottest line of
 * the path wave's own code (about 2% of a cornell-box render). -err and err with its sign bit
 * flipped are the same double; compilers turn a select or a product with -1.0 back into the branch. */
static inline spc_vec3 spc_hit_offset(const spc_hit *h, spc_vec3 d)
{
    uint64_t bits;
    double off;
    memcpy(&bits, &h->err, sizeof bits);
    bits ^= (uint64_t)(spc_dot(h->ng, d) < 0.0) << 63;
    memcpy(&off, &bits, sizeof off);
    return spc_madd(h->p, h->ng, off);
}

static inline spc_ray spc_hit_spawn(const spc_hit *h, spc_vec3 d)
{
    spc_ray r;
    r.o = spc_hit_offset(h, d);
    r.d = d;
    r.tmin = 0.0;
    r.tmax = SPC_INF;
    return r;
}

/* A ray from h toward point q (tmax stops short of q by a relative margin). */
static inline spc_ray spc_hit_spawn_to(const spc_hit *h, spc_vec3 q, double q_err)
{
    spc_vec3 o = spc_hit_offset(h, spc_sub(q, h->p));
    spc_vec3 d = spc_sub(q, o);
    double dist = spc_length(d);
    spc_ray r;
    r.o = o;
    r.d = dist > 0.0 ? spc_scale(d, 1.0 / dist) : h->ng;
    r.tmin = 0.0;
    r.tmax = dist - 2.0 * q_err - 1e-7 * dist;
    if (r.tmax < 0.0)
        r.tmax = 0.0;
    return r;
}

#endif
