/*
 * scene/mesh.h: an indexed triangle mesh as loaded (object space) or placed (world space).
 *
 * Positions, normals and uvs are float (the layout Embree reads); every computation on them is
 * done in double. normals and uvs are NULL when the file has none. Ownership: the mesh owns its
 * arrays; spc_mesh_release frees them (NULL-safe).
 */
#ifndef SPC_SCENE_MESH_H
#define SPC_SCENE_MESH_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "core/math.h"

/* A named per-vertex or per-face value of a mesh (Mitsuba's mesh attributes, read from PLY files:
 * "vertex_color", "face_weight", ...). Face attributes hold one value per TRIANGLE (a polygon's
 * value is repeated for each triangle it is split into). */
#define SPC_MESH_ATTR_NAME_MAX 64
typedef struct spc_mesh_attr {
    char name[SPC_MESH_ATTR_NAME_MAX]; /* "vertex_<prefix>" or "face_<prefix>" */
    bool face;                         /* per triangle (else per vertex) */
    int dim;                           /* values per vertex or triangle: 1 to 4 */
    float *data;                       /* dim * (face ? ntris : nverts), owned */
} spc_mesh_attr;

typedef struct spc_mesh {
    size_t nverts, ntris;
    float *p;     /* 3 * nverts */
    float *n;     /* 3 * nverts, or NULL: face normals are used */
    float *uv;    /* 2 * nverts, or NULL */
    uint32_t *idx; /* 3 * ntris */
    /* p holds one float more than 3 * nverts (zero), so that a 16-byte load at the last vertex
     * stays inside it: Embree then reads p and idx in place instead of copies
     * (spc_shape_init_mesh pads every mesh it places) */
    bool p_padded;
    spc_mesh_attr *attrs; /* nattrs attributes, owned (NULL when none) */
    int nattrs;
} spc_mesh;

void spc_mesh_release(spc_mesh *m);
/* Checks every value: finite positions/normals/uvs, indices < nverts. Names the first bad one. */
spc_status spc_mesh_validate(const spc_mesh *m, const char *file, spc_error *err);
/* Applies a transform (normals by the inverse transpose, renormalized). Returns false if the
 * transform is singular. */
bool spc_mesh_transform(spc_mesh *m, const spc_mat4 *to_world);
/* Removes triangles of zero area (they cannot be hit and break area sampling); returns how many. */
size_t spc_mesh_drop_degenerate(spc_mesh *m);
/* Gives a mesh without normals smooth vertex normals, as Mitsuba 3 does for mesh files without
 * them (unless face_normals): each vertex gets the sum of the unit normals of the triangles around
 * it weighted by the triangle's angle at the vertex, normalized (Thuermer and Wuethrich 1998);
 * a vertex whose sum vanishes gets the normal of its first triangle. Does nothing when the mesh
 * has normals. Returns false on allocation failure (the mesh is unchanged). */
bool spc_mesh_compute_vertex_normals(spc_mesh *m);
/* Copies src's attributes onto dst (which has none; same vertex and triangle counts); false on
 * allocation failure (dst then has none). */
bool spc_mesh_copy_attrs(spc_mesh *dst, const spc_mesh *src);
/* The attribute named name, or NULL. */
const spc_mesh_attr *spc_mesh_find_attr(const spc_mesh *m, const char *name);
/* Appends src to dst (for shapegroups and merging); false on allocation failure. Attributes are
 * dropped from the result (they could differ between the parts). */
bool spc_mesh_append(spc_mesh *dst, const spc_mesh *src);

/* Triangulates the polygon ids[0..n-1] (vertex indices into positions p, 3 floats each): a fan
 * for convex polygons, ear clipping in the polygon's dominant plane for concave ones (a fan
 * again if no ear can be found: self-intersecting input). Triangles keep the polygon's winding.
 * Writes up to 3*(n-2) indices to tris and returns the number of triangles (0 if n < 3). */
size_t spc_polygon_triangulate(const float *p, const uint32_t *ids, size_t n, uint32_t *tris);

static inline spc_vec3 spc_mesh_p(const spc_mesh *m, uint32_t i)
{
    return spc_v3(m->p[3 * i], m->p[3 * i + 1], m->p[3 * i + 2]);
}
static inline spc_vec3 spc_mesh_n(const spc_mesh *m, uint32_t i)
{
    return spc_v3(m->n[3 * i], m->n[3 * i + 1], m->n[3 * i + 2]);
}

/* The uv differences of triangle t's second and third vertices from its first: duv = (du1, dv1,
 * du2, dv2). The mesh has uvs. */
static inline void spc_mesh_tri_duv(const spc_mesh *m, size_t t, double duv[4])
{
    uint32_t i0 = m->idx[3 * t], i1 = m->idx[3 * t + 1], i2 = m->idx[3 * t + 2];
    double u0 = m->uv[2 * i0], v0 = m->uv[2 * i0 + 1];
    duv[0] = m->uv[2 * i1] - u0;
    duv[1] = m->uv[2 * i1 + 1] - v0;
    duv[2] = m->uv[2 * i2] - u0;
    duv[3] = m->uv[2 * i2 + 1] - v0;
}

/* dp/du and dp/dv of a triangle from its edges e1, e2 (second and third vertex minus the first)
 * and their uv differences (spc_mesh_tri_duv): the inverse of the uv Jacobian. False (outputs
 * untouched) where |det| <= min_det. */
static inline bool spc_uv_tangents(spc_vec3 e1, spc_vec3 e2, const double duv[4], double min_det, spc_vec3 *dpdu,
                                   spc_vec3 *dpdv)
{
    double det = duv[0] * duv[3] - duv[1] * duv[2];
    if (!(fabs(det) > min_det))
        return false;
    *dpdu = spc_scale(spc_sub(spc_scale(e1, duv[3]), spc_scale(e2, duv[1])), 1.0 / det);
    *dpdv = spc_scale(spc_sub(spc_scale(e2, duv[0]), spc_scale(e1, duv[2])), 1.0 / det);
    return true;
}

#endif
