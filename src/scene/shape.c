/*
 * scene/shape.c: construction, exact intersection, surface interaction and sampling of shapes.
 *
 * Surface parameters (u, v) of each shape, with respect to which hit.dpdu/dpdv/dndu/dndv are
 * given (the specular solvers differentiate through them):
 *   mesh      barycentrics (b1, b2) of the triangle's vertices 1 and 2
 *   sphere    u = phi / (2 pi), v = theta / pi in the sphere's local frame (to_world rotation),
 *             theta measured from local +z; texture uv = (u, v) as Mitsuba 3
 *   disk      u = r, v = phi / (2 pi) in local coordinates; texture uv = (u, v)
 *   cylinder  u = phi / (2 pi), v = local z in [0, 1]; texture uv = (u, v)
 *   sdf       local tangent-plane coordinates at the hit: u, v along an orthonormal tangent basis
 *             (s, t) of the normal (spc_frame_from_n), so dpdu, dpdv are unit and orthogonal and
 *             dndu, dndv are the shape operator applied to them, (I - n n^T) H t / |grad f| from
 *             the field's Hessian H (scene/sdf.c); b1 = b2 = 0 at the hit. Texture uv = spherical
 *             angles of p in the root node's frame, as the sphere's.
 *   curves    scene/curve.h (intersected by Embree in float: SPC_CURVE_OFFSET there)
 *
 * Error bounds for ray offsets: analytic shapes are intersected in double from the double ray, so
 * their points are accurate to a few double ulps; triangles are intersected by Embree in float,
 * so a new ray must leave a triangle's plane by more than float rounding of the vertices' and the
 * origin's magnitude (SPC_FLOAT_OFFSET below).
 */
#include "scene/shape.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "scene/curve.h"
#include "scene/sdf.h"
#include "scene/sdfgrid.h"

/* Relative offset for surfaces intersected in float: ~8 float ulps of the coordinates' magnitude,
 * above Embree's watertight intersection error, far below any feature a float scene can hold. */
#define SPC_FLOAT_OFFSET (8.0 * FLT_EPSILON)
/* Relative offset for analytic shapes intersected in double. */
#define SPC_DOUBLE_OFFSET 1e-9

static bool fail(spc_error *err, const char *file, int line, int col, const char *msg)
{
    spc_error_set(err, SPC_ERR_VALUE, file, line, col, "%s", msg);
    return false;
}

static bool mat_ok(const spc_mat4 *m)
{
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            if (!isfinite(m->m[i][j]))
                return false;
    return true;
}

static void free_curve(spc_shape *s)
{
    spc_curve_release(s->curve);
    free(s->curve);
    s->curve = NULL;
}

static void shape_clear(spc_shape *s, spc_shape_type type)
{
    spc_mesh_release(&s->mesh);
    spc_sdf_destroy(s->sdf);
    s->sdf = NULL;
    free_curve(s);
    spc_sdfgrid_destroy(s->sdfgrid);
    s->sdfgrid = NULL;
    s->type = type;
    s->to_world = spc_mat4_identity();
    s->to_local = spc_mat4_identity();
    s->interior_medium = s->exterior_medium = -1;
}

bool spc_shape_init_sphere(spc_shape *s, spc_vec3 center, double radius, const spc_mat4 *to_world,
                           const char *file, int line, int col, spc_error *err)
{
    shape_clear(s, SPC_SHAPE_SPHERE);
    if (!(radius > 0.0) || !isfinite(radius) || !spc_v3_finite(center))
        return fail(err, file, line, col, "sphere radius must be positive and finite, and the center finite");
    spc_mat4 M = to_world ? *to_world : spc_mat4_identity();
    if (!mat_ok(&M))
        return fail(err, file, line, col, "sphere transform has non-finite entries");
    /* The transform may carry a uniform scale, a rotation and a translation. */
    spc_vec3 ax = spc_mat4_apply_vector(&M, spc_v3(1, 0, 0));
    spc_vec3 ay = spc_mat4_apply_vector(&M, spc_v3(0, 1, 0));
    spc_vec3 az = spc_mat4_apply_vector(&M, spc_v3(0, 0, 1));
    double sx = spc_length(ax), sy = spc_length(ay), sz = spc_length(az);
    if (!(sx > 0.0) || fabs(sx - sy) > 1e-5 * sx || fabs(sx - sz) > 1e-5 * sx ||
        fabs(spc_dot(ax, ay)) > 1e-5 * sx * sy || fabs(spc_dot(ax, az)) > 1e-5 * sx * sz)
        return fail(err, file, line, col, "sphere transform must be a uniform scale, rotation and translation");
    s->center = spc_mat4_apply_point(&M, center);
    s->radius = radius * sx;
    /* orientation only (for uv) */
    spc_mat4 R = spc_mat4_identity();
    spc_vec3 cols[3] = {spc_scale(ax, 1.0 / sx), spc_scale(ay, 1.0 / sy), spc_scale(az, 1.0 / sz)};
    for (int j = 0; j < 3; ++j) {
        R.m[0][j] = cols[j].x;
        R.m[1][j] = cols[j].y;
        R.m[2][j] = cols[j].z;
    }
    s->to_world = R;
    s->to_local = spc_mat4_transpose(&R);
    return true;
}

static bool init_local_transform(spc_shape *s, const spc_mat4 *to_world, const char *what, const char *file,
                                 int line, int col, spc_error *err)
{
    s->to_world = to_world ? *to_world : spc_mat4_identity();
    if (!mat_ok(&s->to_world) || !spc_mat4_inverse(&s->to_world, &s->to_local) ||
        fabs(spc_mat4_det3(&s->to_world)) < 1e-300) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "%s transform is singular or not finite", what);
        return false;
    }
    return true;
}

bool spc_shape_init_disk(spc_shape *s, const spc_mat4 *to_world, const char *file, int line, int col, spc_error *err)
{
    shape_clear(s, SPC_SHAPE_DISK);
    return init_local_transform(s, to_world, "disk", file, line, col, err);
}

bool spc_shape_init_cylinder(spc_shape *s, spc_vec3 p0, spc_vec3 p1, double radius, const spc_mat4 *to_world,
                             const char *file, int line, int col, spc_error *err)
{
    shape_clear(s, SPC_SHAPE_CYLINDER);
    if (!(radius > 0.0) || !isfinite(radius) || !spc_v3_finite(p0) || !spc_v3_finite(p1))
        return fail(err, file, line, col, "cylinder radius must be positive and its end points finite");
    spc_vec3 axis = spc_sub(p1, p0);
    double len = spc_length(axis);
    if (!(len > 0.0))
        return fail(err, file, line, col, "cylinder end points coincide");
    /* local unit cylinder (radius 1, z in [0, 1]) -> p0 + frame * diag(r, r, len) */
    spc_frame fr = spc_frame_from_n(spc_scale(axis, 1.0 / len));
    spc_mat4 L = spc_mat4_identity();
    spc_vec3 cols[4] = {spc_scale(fr.s, radius), spc_scale(fr.t, radius), axis, p0};
    for (int j = 0; j < 4; ++j) {
        L.m[0][j] = cols[j].x;
        L.m[1][j] = cols[j].y;
        L.m[2][j] = cols[j].z;
    }
    spc_mat4 M = to_world ? spc_mat4_mul(to_world, &L) : L;
    s->radius = radius;
    s->length = len;
    return init_local_transform(s, &M, "cylinder", file, line, col, err);
}

static bool mesh_from_arrays(spc_mesh *m, const float *p, size_t nv, const float *uv, const uint32_t *idx,
                             size_t nt)
{
    memset(m, 0, sizeof *m);
    m->p = malloc(3 * nv * sizeof(float));
    m->uv = malloc(2 * nv * sizeof(float));
    m->idx = malloc(3 * nt * sizeof(uint32_t));
    if (!m->p || !m->uv || !m->idx) {
        spc_mesh_release(m);
        return false;
    }
    memcpy(m->p, p, 3 * nv * sizeof(float));
    memcpy(m->uv, uv, 2 * nv * sizeof(float));
    memcpy(m->idx, idx, 3 * nt * sizeof(uint32_t));
    m->nverts = nv;
    m->ntris = nt;
    return true;
}

bool spc_shape_init_rectangle(spc_shape *s, const spc_mat4 *to_world, const char *file, int line, int col,
                              spc_error *err)
{
    static const float p[12] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
    static const float uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    static const uint32_t idx[6] = {0, 1, 2, 2, 3, 0};
    spc_mesh m;
    if (!mesh_from_arrays(&m, p, 4, uv, idx, 2)) {
        spc_error_set(err, SPC_ERR_NOMEM, file, line, col, "out of memory");
        return false;
    }
    return spc_shape_init_mesh(s, &m, to_world, file, line, col, err);
}

bool spc_shape_init_cube(spc_shape *s, const spc_mat4 *to_world, const char *file, int line, int col, spc_error *err)
{
    /* Mitsuba 3's cube, vertex for vertex (its uvs are part of what a scene sees): 6 faces of 4
     * vertices, face f = (-y, +y, +x, +z, -x, -z) with corners c0..c3 and uvs (0,1), (1,1),
     * (1,0), (0,0), triangles (c0, c1, c2) and (c3, c0, c2), wound outward. */
    static const float P[72] = {1,  -1, -1, 1,  -1, 1,  -1, -1, 1,  -1, -1, -1, /* -y */
                                1,  1,  -1, -1, 1,  -1, -1, 1,  1,  1,  1,  1,  /* +y */
                                1,  -1, -1, 1,  1,  -1, 1,  1,  1,  1,  -1, 1,  /* +x */
                                1,  -1, 1,  1,  1,  1,  -1, 1,  1,  -1, -1, 1,  /* +z */
                                -1, -1, 1,  -1, 1,  1,  -1, 1,  -1, -1, -1, -1, /* -x */
                                1,  1,  -1, 1,  -1, -1, -1, -1, -1, -1, 1,  -1}; /* -z */
    static const float corner_uv[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    float p[72], uv[48];
    uint32_t idx[36];
    memcpy(p, P, sizeof p);
    for (uint32_t f = 0; f < 6; ++f) {
        uint32_t b = 4 * f;
        memcpy(uv + 8 * f, corner_uv, sizeof corner_uv);
        uint32_t tri[6] = {b, b + 1, b + 2, b + 3, b, b + 2};
        memcpy(idx + 6 * f, tri, sizeof tri);
    }
    spc_mesh m;
    if (!mesh_from_arrays(&m, p, 24, uv, idx, 12)) {
        spc_error_set(err, SPC_ERR_NOMEM, file, line, col, "out of memory");
        return false;
    }
    return spc_shape_init_mesh(s, &m, to_world, file, line, col, err);
}

bool spc_shape_init_mesh(spc_shape *s, spc_mesh *m, const spc_mat4 *to_world, const char *file, int line, int col,
                         spc_error *err)
{
    shape_clear(s, SPC_SHAPE_MESH);
    s->mesh = *m;
    memset(m, 0, sizeof *m);
    if (spc_mesh_validate(&s->mesh, file, err) != SPC_OK) {
        if (err && line > 0 && err->line == 0) {
            /* point at the XML element as well */
            err->line = line;
            err->col = col;
        }
        return false;
    }
    if (to_world) {
        if (!mat_ok(to_world) || !spc_mesh_transform(&s->mesh, to_world))
            return fail(err, file, line, col, "mesh transform is singular or not finite");
        s->to_world = *to_world;
        /* a mirroring transform flips the winding: restore outward-facing normals */
        if (spc_mat4_det3(to_world) < 0.0)
            for (size_t i = 0; i < s->mesh.ntris; ++i) {
                uint32_t tmp = s->mesh.idx[3 * i + 1];
                s->mesh.idx[3 * i + 1] = s->mesh.idx[3 * i + 2];
                s->mesh.idx[3 * i + 2] = tmp;
            }
    }
    spc_mesh_drop_degenerate(&s->mesh);
    if (s->mesh.ntris == 0)
        return fail(err, file, line, col, "mesh has no triangle of non-zero area");
    /* the padding Embree needs to read the positions in place (spc_mesh.p_padded) */
    float *p = realloc(s->mesh.p, (3 * s->mesh.nverts + 1) * sizeof(float));
    if (!p) {
        spc_error_set(err, SPC_ERR_NOMEM, file, line, col, "out of memory");
        return false;
    }
    p[3 * s->mesh.nverts] = 0.0f;
    s->mesh.p = p;
    s->mesh.p_padded = true;
    return true;
}

bool spc_shape_init_sdf(spc_shape *s, struct spc_sdf *sdf, int root, const spc_mat4 *to_world, const char *file,
                        int line, int col, spc_error *err)
{
    shape_clear(s, SPC_SHAPE_SDF);
    s->sdf = sdf;
    if (!sdf)
        return fail(err, file, line, col, "sdf shape without a field");
    if (!spc_sdf_finalize(sdf, root, to_world, file, line, col, err)) {
        spc_sdf_destroy(sdf);
        s->sdf = NULL;
        return false;
    }
    if (to_world)
        s->to_world = *to_world;
    return true;
}

bool spc_shape_init_curve(spc_shape *s, struct spc_curve *curve, const char *file, int line, int col,
                          spc_error *err)
{
    shape_clear(s, SPC_SHAPE_CURVE);
    s->curve = curve;
    if (!curve || curve->nseg == 0)
        return fail(err, file, line, col, "curve shape without segments");
    return true;
}

bool spc_shape_init_sdfgrid(spc_shape *s, struct spc_sdfgrid *grid, const char *file, int line, int col,
                            spc_error *err)
{
    shape_clear(s, SPC_SHAPE_SDFGRID);
    s->sdfgrid = grid;
    if (!grid)
        return fail(err, file, line, col, "sdfgrid shape without a grid");
    return true;
}

void spc_shape_release(spc_shape *s)
{
    if (!s)
        return;
    free_curve(s);
    spc_mesh_release(&s->mesh);
    spc_sdf_destroy(s->sdf);
    s->sdf = NULL;
    spc_sdfgrid_destroy(s->sdfgrid);
    s->sdfgrid = NULL;
    spc_distrib1d_release(&s->tri_distrib);
    free(s->tri_frame);
    s->tri_frame = NULL;
    if (s->solver_cache) {
        void (**destroy)(void *) = s->solver_cache;
        (*destroy)(s->solver_cache);
        s->solver_cache = NULL;
    }
    if (s->plane_cache) {
        void (**destroy)(void *) = s->plane_cache;
        (*destroy)(s->plane_cache);
        s->plane_cache = NULL;
    }
    if (s->flat_cache) {
        void (**destroy)(void *) = s->flat_cache;
        (*destroy)(s->flat_cache);
        s->flat_cache = NULL;
    }
    if (s->fit_cache) {
        void (**destroy)(void *) = s->fit_cache;
        (*destroy)(s->fit_cache);
        s->fit_cache = NULL;
    }
}

static double tri_area(const spc_mesh *m, size_t i)
{
    spc_vec3 a = spc_mesh_p(m, m->idx[3 * i]), b = spc_mesh_p(m, m->idx[3 * i + 1]), c = spc_mesh_p(m, m->idx[3 * i + 2]);
    return 0.5 * spc_length(spc_cross(spc_sub(b, a), spc_sub(c, a)));
}

/* The texture-space tangent of a triangle (edges e1, e2 from vertex i0): dP/du(texture) where the
 * mesh has uvs that span the triangle, else e1. */
static spc_vec3 tri_tangent(const spc_mesh *m, uint32_t i0, uint32_t i1, uint32_t i2, spc_vec3 e1, spc_vec3 e2)
{
    if (m->uv) {
        double u0 = m->uv[2 * i0], v0 = m->uv[2 * i0 + 1];
        double du1 = m->uv[2 * i1] - u0, dv1 = m->uv[2 * i1 + 1] - v0;
        double du2 = m->uv[2 * i2] - u0, dv2 = m->uv[2 * i2 + 1] - v0;
        double det = du1 * dv2 - dv1 * du2;
        if (fabs(det) > 1e-20) /* dP/du(texture) = (dv2 e1 - dv1 e2) / det */
            return spc_scale(spc_sub(spc_scale(e1, dv2), spc_scale(e2, dv1)), 1.0 / det);
    }
    return e1;
}

void spc_shape_drop_frames(spc_shape *s)
{
    free(s->tri_frame);
    s->tri_frame = NULL;
}

/* Whether the two triangles of m form a parallelogram (spc_mesh_para): they share two vertex
 * positions exactly and triangle 1's third corner is o + e1 + e2 within SPC_PARA_TOL. Each
 * triangle keeps its own normal (as a hit on it has it), so a pair wound either way qualifies. */
static bool find_parallelogram(const spc_mesh *m, spc_mesh_para *q)
{
    if (m->ntris != 2)
        return false;
    spc_vec3 v[2][3];
    for (int t = 0; t < 2; ++t)
        for (int j = 0; j < 3; ++j)
            v[t][j] = spc_mesh_p(m, m->idx[3 * t + j]);
    /* match[j]: the vertex of triangle 1 at triangle 0's vertex j, or -1 */
    int match[3] = {-1, -1, -1}, shared = 0, used = 0;
    for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
            if (match[j] < 0 && !(used & (1 << k)) && v[0][j].x == v[1][k].x && v[0][j].y == v[1][k].y &&
                v[0][j].z == v[1][k].z) {
                match[j] = k;
                used |= 1 << k;
                ++shared;
            }
    if (shared != 2)
        return false;
    int a0 = match[0] < 0 ? 0 : match[1] < 0 ? 1 : 2;
    int a1 = !(used & 1) ? 0 : !(used & 2) ? 1 : 2;
    int d0 = (a0 + 1) % 3, d1 = (a0 + 2) % 3;
    q->o = v[0][a0];
    q->e1 = spc_sub(v[0][d0], q->o);
    q->e2 = spc_sub(v[0][d1], q->o);
    double mag = 0.0;
    for (int t = 0; t < 2; ++t)
        for (int j = 0; j < 3; ++j)
            mag = spc_max(mag, spc_max_abs(v[t][j]));
    q->mag = mag;
    spc_vec3 off = spc_sub(v[1][a1], spc_add(spc_add(q->o, q->e1), q->e2));
    if (!(spc_max_abs(off) <= SPC_PARA_TOL * mag))
        return false;
    for (int t = 0; t < 2; ++t)
        q->ng[t] = spc_normalize(spc_cross(spc_sub(v[t][1], v[t][0]), spc_sub(v[t][2], v[t][0])));
    q->role[0][a0] = 0;
    q->role[0][d0] = 1;
    q->role[0][d1] = 2;
    q->role[1][a1] = 0;
    q->role[1][match[d0]] = 1;
    q->role[1][match[d1]] = 2;
    return true;
}

spc_status spc_shape_prepare(spc_shape *s)
{
    switch (s->type) {
    case SPC_SHAPE_MESH: {
        const spc_mesh *m = &s->mesh;
        double *w = malloc(m->ntris * sizeof(double));
        if (!w)
            return SPC_ERR_NOMEM;
        double area = 0.0;
        for (size_t i = 0; i < m->ntris; ++i)
            area += (w[i] = tri_area(m, i));
        if (!(area > 0.0) || !isfinite(area)) {
            free(w);
            return SPC_ERR_VALUE;
        }
        /* the weights are valid and not all zero, so only an allocation can fail here */
        bool ok = spc_distrib1d_init(&s->tri_distrib, w, m->ntris);
        free(w);
        if (!ok)
            return SPC_ERR_NOMEM;
        s->area = area;
        free(s->tri_frame);
        s->tri_frame = NULL;
        if (m->ntris <= SPC_MESH_FRAME_MAX_TRIS) {
            double *c = malloc(SPC_TRI_FRAME_STRIDE * m->ntris * sizeof(double));
            if (!c)
                return SPC_ERR_NOMEM;
            for (size_t i = 0; i < m->ntris; ++i) {
                uint32_t i0 = m->idx[3 * i], i1 = m->idx[3 * i + 1], i2 = m->idx[3 * i + 2];
                spc_vec3 p0 = spc_mesh_p(m, i0), p1 = spc_mesh_p(m, i1), p2 = spc_mesh_p(m, i2);
                spc_vec3 e1 = spc_sub(p1, p0), e2 = spc_sub(p2, p0);
                spc_vec3 ng = spc_normalize(spc_cross(e1, e2)), t = spc_v3(0, 0, 0);
                spc_vec3 n = s->flip_normals ? spc_neg(ng) : ng;
                spc_frame_tangent(n, tri_tangent(m, i0, i1, i2, e1, e2), &t);
                /* fill_mesh's expressions for the bitangent and the vertices' magnitude */
                spc_vec3 b = spc_cross(n, t);
                double mag = spc_max(spc_max_abs(p0), spc_max(spc_max_abs(p1), spc_max_abs(p2)));
                double v[SPC_TRI_FRAME_STRIDE] = {ng.x, ng.y, ng.z, t.x, t.y, t.z, b.x, b.y, b.z, mag,
                                                  p0.x, p0.y, p0.z, p1.x, p1.y, p1.z, p2.x, p2.y, p2.z};
                memcpy(c + SPC_TRI_FRAME_STRIDE * i, v, sizeof v);
            }
            s->tri_frame = c;
            s->tri_frame_flip = s->flip_normals;
        }
        /* vertex normals turn a sample's normal toward the interpolated one (fill_mesh): not here */
        s->has_para = !(m->n && !s->face_normals) && find_parallelogram(m, &s->para);
        spc_vec3 lo = spc_v3(INFINITY, INFINITY, INFINITY), hi = spc_neg(lo);
        for (size_t i = 0; i < m->nverts; ++i) {
            lo = spc_vmin(lo, spc_mesh_p(m, (uint32_t)i));
            hi = spc_vmax(hi, spc_mesh_p(m, (uint32_t)i));
        }
        s->bbox_min = lo;
        s->bbox_max = hi;
        return SPC_OK;
    }
    case SPC_SHAPE_SPHERE:
        s->area = 4.0 * SPC_PI * s->radius * s->radius;
        s->bbox_min = spc_sub(s->center, spc_v3(s->radius, s->radius, s->radius));
        s->bbox_max = spc_add(s->center, spc_v3(s->radius, s->radius, s->radius));
        return SPC_OK;
    case SPC_SHAPE_DISK:
    case SPC_SHAPE_CYLINDER: {
        /* area of the transformed surface: integrate |dp/du x dp/dv| numerically would be exact
         * only for similarity transforms; Mitsuba makes the same assumption for sampling */
        spc_vec3 ex = spc_mat4_apply_vector(&s->to_world, spc_v3(1, 0, 0));
        spc_vec3 ey = spc_mat4_apply_vector(&s->to_world, spc_v3(0, 1, 0));
        spc_vec3 ez = spc_mat4_apply_vector(&s->to_world, spc_v3(0, 0, 1));
        if (s->type == SPC_SHAPE_DISK)
            s->area = SPC_PI * spc_length(spc_cross(ex, ey));
        else
            s->area = 2.0 * SPC_PI * sqrt(spc_length(ex) * spc_length(ey)) * spc_length(ez);
        spc_vec3 lo = spc_v3(INFINITY, INFINITY, INFINITY), hi = spc_neg(lo);
        for (int k = 0; k < 8; ++k) {
            double z0 = s->type == SPC_SHAPE_DISK ? 0.0 : (double)((k >> 2) & 1);
            spc_vec3 q = spc_mat4_apply_point(&s->to_world, spc_v3((k & 1) ? 1 : -1, (k & 2) ? 1 : -1, z0));
            lo = spc_vmin(lo, q);
            hi = spc_vmax(hi, q);
        }
        s->bbox_min = lo;
        s->bbox_max = hi;
        return s->area > 0.0 && isfinite(s->area) ? SPC_OK : SPC_ERR_VALUE;
    }
    case SPC_SHAPE_SDF:
        /* exact for one primitive, else a Crofton estimate (scene/sdf.c) */
        if (!s->sdf)
            return SPC_ERR_VALUE;
        s->area = spc_sdf_area(s->sdf);
        spc_sdf_bounds(s->sdf, &s->bbox_min, &s->bbox_max);
        return s->area > 0.0 && isfinite(s->area) ? SPC_OK : SPC_ERR_VALUE;
    case SPC_SHAPE_CURVE:
        if (!s->curve)
            return SPC_ERR_VALUE;
        s->area = spc_curve_area(s->curve);
        spc_curve_bounds(s->curve, &s->bbox_min, &s->bbox_max);
        return isfinite(s->area) ? SPC_OK : SPC_ERR_VALUE;
    case SPC_SHAPE_SDFGRID:
        /* an estimate (scene/sdfgrid.h): the shape is never an emitter nor a chain vertex, so no
         * density depends on it; a grid without surface is allowed (Mitsuba renders nothing) */
        if (!s->sdfgrid)
            return SPC_ERR_VALUE;
        s->area = spc_sdfgrid_area(s->sdfgrid);
        spc_sdfgrid_bounds(s->sdfgrid, &s->bbox_min, &s->bbox_max);
        return isfinite(s->area) ? SPC_OK : SPC_ERR_VALUE;
    }
    return SPC_ERR_INTERNAL;
}

/* ---- exact intersection of analytic shapes ---- */

/* Roots of a t^2 + b t + c = 0 (stable form). */
static bool solve_quadratic(double a, double b, double c, double *t0, double *t1)
{
    if (a == 0.0) {
        if (b == 0.0)
            return false;
        *t0 = *t1 = -c / b;
        return true;
    }
    double disc = b * b - 4.0 * a * c;
    if (disc < 0.0)
        return false;
    double r = sqrt(disc);
    double q = b < 0.0 ? -0.5 * (b - r) : -0.5 * (b + r);
    double x0 = q / a, x1 = q != 0.0 ? c / q : x0;
    if (x0 > x1) {
        double tmp = x0;
        x0 = x1;
        x1 = tmp;
    }
    *t0 = x0;
    *t1 = x1;
    return true;
}

static bool intersect_sphere(const spc_shape *s, const spc_ray *r, double *t)
{
    /* relative to the center, with the discriminant in the form of Hearn-Baker / RTG2 ch. 7 for
     * precision far from the sphere */
    spc_vec3 f = spc_sub(r->o, s->center);
    double b = spc_dot(f, r->d);
    double R = s->radius;
    spc_vec3 l = spc_sub(f, spc_scale(r->d, b));
    double disc = R * R - spc_length2(l);
    if (disc < 0.0)
        return false;
    double c = spc_length2(f) - R * R;
    double sq = sqrt(disc);
    double q = b > 0.0 ? -(b + sq) : -(b - sq);
    double t0 = q, t1 = q != 0.0 ? c / q : q;
    if (t0 > t1) {
        double tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    if (t0 > r->tmin && t0 < r->tmax) {
        *t = t0;
        return true;
    }
    if (t1 > r->tmin && t1 < r->tmax) {
        *t = t1;
        return true;
    }
    return false;
}

bool spc_shape_intersect_analytic(const spc_shape *s, const spc_ray *r, double *t, double *u, double *v)
{
    switch (s->type) {
    case SPC_SHAPE_SPHERE:
        *u = *v = 0.0;
        return intersect_sphere(s, r, t);
    case SPC_SHAPE_DISK: {
        spc_vec3 o = spc_mat4_apply_point(&s->to_local, r->o);
        spc_vec3 d = spc_mat4_apply_vector(&s->to_local, r->d);
        if (d.z == 0.0)
            return false;
        double th = -o.z / d.z;
        if (!(th > r->tmin && th < r->tmax))
            return false;
        double x = o.x + th * d.x, y = o.y + th * d.y;
        if (x * x + y * y > 1.0)
            return false;
        *t = th;
        *u = x;
        *v = y;
        return true;
    }
    case SPC_SHAPE_CYLINDER: {
        spc_vec3 o = spc_mat4_apply_point(&s->to_local, r->o);
        spc_vec3 d = spc_mat4_apply_vector(&s->to_local, r->d);
        double a = d.x * d.x + d.y * d.y, b = 2.0 * (o.x * d.x + o.y * d.y), c = o.x * o.x + o.y * o.y - 1.0;
        double t0, t1;
        if (a == 0.0 || !solve_quadratic(a, b, c, &t0, &t1))
            return false;
        double ts[2] = {t0, t1};
        for (int k = 0; k < 2; ++k) {
            double th = ts[k];
            if (!(th > r->tmin && th < r->tmax))
                continue;
            double z = o.z + th * d.z;
            if (z < 0.0 || z > 1.0)
                continue;
            *t = th;
            *u = o.x + th * d.x;
            *v = o.y + th * d.y;
            return true;
        }
        return false;
    }
    case SPC_SHAPE_SDF:
        *u = *v = 0.0;
        return spc_sdf_intersect(s->sdf, r, t);
    case SPC_SHAPE_SDFGRID:
        *u = *v = 0.0;
        return spc_sdfgrid_intersect(s->sdfgrid, r, t);
    case SPC_SHAPE_CURVE: /* Embree's own curves */
    case SPC_SHAPE_MESH:
        return false;
    }
    return false;
}

/* ---- surface interaction ---- */

/* The derivatives of the shading normal n = nr / |nr| (nr = b0 n0 + b1 n1 + b2 n2, len = |nr|) along
 * the barycentrics b1, b2: d(nr/|nr|) = (I - n n^T) d(nr) / |nr|, negated under flip_normals. */
static void mesh_normal_derivatives(const spc_shape *s, spc_vec3 n, spc_vec3 n0, spc_vec3 n1, spc_vec3 n2, double len,
                                    spc_hit *h)
{
    spc_vec3 d1 = spc_sub(n1, n0), d2 = spc_sub(n2, n0);
    h->dndu = spc_scale(spc_sub(d1, spc_scale(n, spc_dot(n, d1))), 1.0 / len);
    h->dndv = spc_scale(spc_sub(d2, spc_scale(n, spc_dot(n, d2))), 1.0 / len);
    if (s->flip_normals) {
        h->dndu = spc_neg(h->dndu);
        h->dndv = spc_neg(h->dndv);
    }
}

/* What fill_mesh fills: MESH_LIGHT what a light sample needs (p, ng with its orientation, uv, err,
 * b1, b2, dpdu, dpdv: no shading frame, no normal derivatives); MESH_SHADING what shading reads
 * (p, ng, sh, uv, err, b1, b2: no derivatives; uv zero where the shape's materials read none,
 * spc_shape.uv_unread); MESH_CHAIN what a specular chain's vertex reads
 * while a solver steps (every field but uv and the tangents sh.s, sh.t, which are zero); MESH_ALL
 * every field. */
typedef enum mesh_fill { MESH_LIGHT, MESH_SHADING, MESH_CHAIN, MESH_ALL } mesh_fill;

/* The texture coordinates at barycentrics (b1, b2) of the triangle (i0, i1, i2): the vertices' uvs
 * interpolated, or (b1, b2) where the mesh has none. */
static spc_vec2 mesh_uv(const spc_mesh *m, uint32_t i0, uint32_t i1, uint32_t i2, double b1, double b2)
{
    if (!m->uv)
        return spc_v2(b1, b2);
    double u0 = m->uv[2 * i0], v0 = m->uv[2 * i0 + 1];
    double du1 = m->uv[2 * i1] - u0, dv1 = m->uv[2 * i1 + 1] - v0;
    double du2 = m->uv[2 * i2] - u0, dv2 = m->uv[2 * i2 + 1] - v0;
    return spc_v2(u0 + b1 * du1 + b2 * du2, v0 + b1 * dv1 + b2 * dv2);
}

/* A triangle's hit at barycentrics (b1, b2), the fields that `what` names (fill_mesh is its call;
 * the shading fill inlines it with `what` constant). The values filled are
 * the same whatever else is filled, and the same with or without the shape's tri_frame (which holds
 * this function's own per-triangle normal and tangent); mesh_derivatives computes the derivatives
 * that MESH_SHADING leaves out with the same expressions. */
static inline __attribute__((always_inline)) void fill_mesh_inline(const spc_shape *s, int prim, double b1, double b2,
                                                                   mesh_fill what, spc_hit *h)
{
    const spc_mesh *m = &s->mesh;
    /* the vertex indices, read only where the kept frame does not hold what they lead to */
    const uint32_t *vi = m->idx + 3 * (size_t)prim;
    const double *c = s->tri_frame ? s->tri_frame + SPC_TRI_FRAME_STRIDE * (size_t)prim : NULL;
    spc_vec3 p0, p1, p2;
    if (c) {
        p0 = spc_v3(c[10], c[11], c[12]);
        p1 = spc_v3(c[13], c[14], c[15]);
        p2 = spc_v3(c[16], c[17], c[18]);
    } else {
        p0 = spc_mesh_p(m, vi[0]);
        p1 = spc_mesh_p(m, vi[1]);
        p2 = spc_mesh_p(m, vi[2]);
    }
    double b0 = 1.0 - b1 - b2;
    h->p = spc_add(spc_add(spc_scale(p0, b0), spc_scale(p1, b1)), spc_scale(p2, b2));
    spc_vec3 e1 = spc_sub(p1, p0), e2 = spc_sub(p2, p0);
    h->ng = c ? spc_v3(c[0], c[1], c[2]) : spc_normalize(spc_cross(e1, e2));
    if (what != MESH_SHADING) {
        h->dpdu = e1;
        h->dpdv = e2;
    }
    h->b1 = b1;
    h->b2 = b2;
    double mag = c ? c[9] : spc_max(spc_max_abs(p0), spc_max(spc_max_abs(p1), spc_max_abs(p2)));
    h->err = SPC_FLOAT_OFFSET * spc_max(mag, spc_max_abs(h->p));
    h->uv = what == MESH_CHAIN || (what == MESH_SHADING && s->uv_unread) ? spc_v2(0.0, 0.0)
                                                                         : mesh_uv(m, vi[0], vi[1], vi[2], b1, b2);
    if (m->n && !s->face_normals) {
        spc_vec3 n0 = spc_mesh_n(m, vi[0]), n1 = spc_mesh_n(m, vi[1]), n2 = spc_mesh_n(m, vi[2]);
        spc_vec3 nr = spc_add(spc_add(spc_scale(n0, b0), spc_scale(n1, b1)), spc_scale(n2, b2));
        double len = spc_length(nr);
        if (len > 1e-12) {
            spc_vec3 n = spc_scale(nr, 1.0 / len);
            if (what == MESH_LIGHT) {
                /* ng on the side of the (flipped) shading normal */
                if (s->flip_normals)
                    n = spc_neg(n);
                if (spc_dot(n, h->ng) < 0.0)
                    h->ng = spc_neg(h->ng);
                return;
            }
            if (what == MESH_ALL || what == MESH_CHAIN)
                mesh_normal_derivatives(s, n, n0, n1, n2, len, h);
            if (s->flip_normals)
                n = spc_neg(n);
            if (spc_dot(n, h->ng) < 0.0)
                h->ng = spc_neg(h->ng);
            if (what == MESH_CHAIN) {
                /* spc_frame_from_ns keeps n as its normal */
                h->sh.n = n;
                h->sh.s = h->sh.t = spc_v3(0, 0, 0);
                return;
            }
            h->sh = spc_frame_from_ns(n, tri_tangent(m, vi[0], vi[1], vi[2], e1, e2));
            return;
        }
    }
    if (s->flip_normals)
        h->ng = spc_neg(h->ng);
    if (what == MESH_LIGHT)
        return;
    if (what == MESH_ALL || what == MESH_CHAIN)
        h->dndu = h->dndv = spc_v3(0, 0, 0);
    if (what == MESH_CHAIN) {
        h->sh.n = h->ng;
        h->sh.s = h->sh.t = spc_v3(0, 0, 0);
        return;
    }
    if (c && s->tri_frame_flip == s->flip_normals && !(c[3] == 0.0 && c[4] == 0.0 && c[5] == 0.0)) {
        /* spc_frame_from_ns(ng, tangent) with the kept tangent and bitangent (the cross product of
         * this ng, which flip_normals has turned as it was when they were kept, and the tangent) */
        h->sh.n = h->ng;
        h->sh.s = spc_v3(c[3], c[4], c[5]);
        h->sh.t = spc_v3(c[6], c[7], c[8]);
    } else {
        h->sh = spc_frame_from_ns(h->ng, tri_tangent(m, vi[0], vi[1], vi[2], e1, e2));
    }
}

static void fill_mesh(const spc_shape *s, int prim, double b1, double b2, mesh_fill what, spc_hit *h)
{
    fill_mesh_inline(s, prim, b1, b2, what, h);
}

/* The fields that fill_mesh's MESH_SHADING leaves out (dpdu, dpdv, dndu, dndv, and uv where
 * uv_unread), with fill_mesh's expressions, so the same values. */
static void mesh_derivatives(const spc_shape *s, int prim, double b1, double b2, spc_hit *h)
{
    const spc_mesh *m = &s->mesh;
    uint32_t i0 = m->idx[3 * prim], i1 = m->idx[3 * prim + 1], i2 = m->idx[3 * prim + 2];
    if (s->uv_unread)
        h->uv = mesh_uv(m, i0, i1, i2, b1, b2);
    spc_vec3 p0 = spc_mesh_p(m, i0);
    h->dpdu = spc_sub(spc_mesh_p(m, i1), p0);
    h->dpdv = spc_sub(spc_mesh_p(m, i2), p0);
    h->dndu = h->dndv = spc_v3(0, 0, 0);
    if (!m->n || s->face_normals)
        return;
    double b0 = 1.0 - b1 - b2;
    spc_vec3 n0 = spc_mesh_n(m, i0), n1 = spc_mesh_n(m, i1), n2 = spc_mesh_n(m, i2);
    spc_vec3 nr = spc_add(spc_add(spc_scale(n0, b0), spc_scale(n1, b1)), spc_scale(n2, b2));
    double len = spc_length(nr);
    if (!(len > 1e-12))
        return;
    mesh_normal_derivatives(s, spc_scale(nr, 1.0 / len), n0, n1, n2, len, h);
}

/* A sphere's (u, v) = (phi / 2 pi, theta / pi) of the unit direction l in its local frame. */
static spc_vec2 sphere_uv_local(spc_vec3 l)
{
    double theta = acos(spc_clamp(l.z, -1.0, 1.0));
    double phi = atan2(l.y, l.x);
    if (phi < 0.0)
        phi += 2.0 * SPC_PI;
    return spc_v2(phi * SPC_INV_2PI, theta * SPC_INV_PI);
}

spc_vec2 spc_sphere_uv(const spc_shape *s, spc_vec3 dir)
{
    if (s->uv_unread)
        return spc_v2(0.0, 0.0);
    return sphere_uv_local(spc_mat4_apply_vector(&s->to_local, dir));
}

/* The sphere's hit from the unit direction l of the point in the shape's local frame: its
 * parameterization p = R (sin theta cos phi, sin theta sin phi, cos theta), u = phi / 2 pi,
 * v = theta / pi, whose sines and cosines are l's coordinates (sin theta = |l.xy|), so the
 * derivatives and the frame need no trigonometry; uv (acos, atan2) only where the shape's
 * materials read it (uv_unread: zero). */
static void fill_sphere(const spc_shape *s, const spc_ray *r, double t, spc_hit *h)
{
    spc_vec3 p = spc_madd(r->o, r->d, t);
    spc_vec3 dir = spc_normalize(spc_sub(p, s->center));
    double R = s->radius;
    h->p = spc_madd(s->center, dir, R);
    h->err = SPC_DOUBLE_OFFSET * (spc_max_abs(s->center) + R);
    spc_vec3 l = spc_mat4_apply_vector(&s->to_local, dir);
    h->uv = s->uv_unread ? spc_v2(0.0, 0.0) : sphere_uv_local(l);
    h->b1 = h->uv.x;
    h->b2 = h->uv.y;
    double st = sqrt(l.x * l.x + l.y * l.y), ct = l.z, sp = 0.0, cp = 1.0; /* at a pole atan2 gives phi = 0 */
    if (st > 0.0) {
        cp = l.x / st;
        sp = l.y / st;
    }
    spc_vec3 dpdu_l = spc_v3(-2.0 * SPC_PI * R * st * sp, 2.0 * SPC_PI * R * st * cp, 0.0);
    spc_vec3 dpdv_l = spc_v3(SPC_PI * R * ct * cp, SPC_PI * R * ct * sp, -SPC_PI * R * st);
    h->dpdu = spc_mat4_apply_vector(&s->to_world, dpdu_l);
    h->dpdv = spc_mat4_apply_vector(&s->to_world, dpdv_l);
    double sgn = s->flip_normals ? -1.0 : 1.0;
    h->ng = spc_scale(dir, sgn);
    h->dndu = spc_scale(h->dpdu, sgn / R);
    h->dndv = spc_scale(h->dpdv, sgn / R);
    spc_vec3 tangent = st > 1e-9 ? h->dpdu : spc_cross(h->ng, h->dpdv);
    h->sh = spc_frame_from_ns(h->ng, tangent);
}

static void fill_disk(const spc_shape *s, double x, double y, spc_hit *h)
{
    double r = sqrt(x * x + y * y);
    double phi = atan2(y, x);
    if (phi < 0.0)
        phi += 2.0 * SPC_PI;
    h->p = spc_mat4_apply_point(&s->to_world, spc_v3(x, y, 0.0));
    h->uv = spc_v2(r, phi * SPC_INV_2PI);
    h->b1 = h->uv.x;
    h->b2 = h->uv.y;
    double cp = cos(phi), sp = sin(phi);
    h->dpdu = spc_mat4_apply_vector(&s->to_world, spc_v3(cp, sp, 0.0));
    h->dpdv = spc_mat4_apply_vector(&s->to_world, spc_v3(-2.0 * SPC_PI * r * sp, 2.0 * SPC_PI * r * cp, 0.0));
    spc_vec3 n = spc_normalize(spc_mat4_apply_normal(&s->to_local, spc_v3(0, 0, 1)));
    if (s->flip_normals)
        n = spc_neg(n);
    h->ng = n;
    h->dndu = h->dndv = spc_v3(0, 0, 0);
    h->err = SPC_DOUBLE_OFFSET * (spc_max_abs(h->p) + spc_max_abs(spc_mat4_apply_point(&s->to_world, spc_v3(0, 0, 0))) +
                                  spc_length(h->dpdu));
    spc_vec3 ex = spc_mat4_apply_vector(&s->to_world, spc_v3(1, 0, 0));
    h->sh = spc_frame_from_ns(n, r > 1e-9 ? h->dpdu : ex);
}

static void fill_cylinder(const spc_shape *s, const spc_ray *r, double t, spc_hit *h)
{
    spc_vec3 o = spc_mat4_apply_point(&s->to_local, r->o);
    spc_vec3 d = spc_mat4_apply_vector(&s->to_local, r->d);
    spc_vec3 l = spc_madd(o, d, t);
    double phi = atan2(l.y, l.x);
    if (phi < 0.0)
        phi += 2.0 * SPC_PI;
    double cp = cos(phi), sp = sin(phi);
    l = spc_v3(cp, sp, spc_clamp(l.z, 0.0, 1.0));
    h->p = spc_mat4_apply_point(&s->to_world, l);
    h->uv = spc_v2(phi * SPC_INV_2PI, l.z);
    h->b1 = h->uv.x;
    h->b2 = h->uv.y;
    h->dpdu = spc_mat4_apply_vector(&s->to_world, spc_v3(-2.0 * SPC_PI * sp, 2.0 * SPC_PI * cp, 0.0));
    h->dpdv = spc_mat4_apply_vector(&s->to_world, spc_v3(0.0, 0.0, 1.0));
    spc_vec3 nl = spc_v3(cp, sp, 0.0);
    spc_vec3 nu = spc_mat4_apply_normal(&s->to_local, nl);
    double len = spc_length(nu);
    spc_vec3 n = spc_scale(nu, 1.0 / len);
    /* dn/du: derivative of normalize(N^T nl) with nl' = 2 pi (-sp, cp, 0) */
    spc_vec3 dnu = spc_scale(spc_mat4_apply_normal(&s->to_local, spc_v3(-2.0 * SPC_PI * sp, 2.0 * SPC_PI * cp, 0.0)),
                             1.0 / len);
    h->dndu = spc_sub(dnu, spc_scale(n, spc_dot(n, dnu)));
    h->dndv = spc_v3(0, 0, 0);
    if (s->flip_normals) {
        n = spc_neg(n);
        h->dndu = spc_neg(h->dndu);
    }
    h->ng = n;
    h->err = SPC_DOUBLE_OFFSET * (spc_max_abs(h->p) + spc_length(h->dpdu) + spc_length(h->dpdv));
    h->sh = spc_frame_from_ns(n, h->dpdu);
}

bool spc_shape_texture_frame(const spc_hit *h, spc_vec2 duv[2], spc_vec3 *T, spc_vec3 dT[2])
{
    const spc_shape *s = h->shape;
    if (!s)
        return false;
    /* analytic shapes: uv are the surface parameters, T = dpdu */
    duv[0] = spc_v2(1.0, 0.0);
    duv[1] = spc_v2(0.0, 1.0);
    *T = h->dpdu;
    switch (s->type) {
    case SPC_SHAPE_MESH: {
        const spc_mesh *m = &s->mesh;
        dT[0] = dT[1] = spc_v3(0, 0, 0);
        if (!m->uv)
            return true;
        double d[4];
        spc_mesh_tri_duv(m, (size_t)h->prim, d);
        duv[0] = spc_v2(d[0], d[1]);
        duv[1] = spc_v2(d[2], d[3]);
        spc_vec3 tv;
        spc_uv_tangents(h->dpdu, h->dpdv, d, 1e-20, T, &tv); /* as fill_mesh */
        return true;
    }
    case SPC_SHAPE_SPHERE: {
        double theta = SPC_PI * h->b2, phi = 2.0 * SPC_PI * h->b1;
        double st = sin(theta), ct = cos(theta), sp = sin(phi), cp = cos(phi), R = s->radius;
        if (!(st > 1e-9))
            return false; /* fill_sphere's pole tangent: probability zero */
        dT[0] = spc_mat4_apply_vector(&s->to_world, spc_v3(-4.0 * SPC_PI * SPC_PI * R * st * cp,
                                                          -4.0 * SPC_PI * SPC_PI * R * st * sp, 0.0));
        dT[1] = spc_mat4_apply_vector(&s->to_world, spc_v3(-2.0 * SPC_PI * SPC_PI * R * ct * sp,
                                                          2.0 * SPC_PI * SPC_PI * R * ct * cp, 0.0));
        return true;
    }
    case SPC_SHAPE_DISK: {
        double phi = 2.0 * SPC_PI * h->b2;
        if (!(h->b1 > 1e-9))
            return false; /* fill_disk's centre tangent */
        dT[0] = spc_v3(0, 0, 0);
        dT[1] = spc_mat4_apply_vector(&s->to_world, spc_v3(-2.0 * SPC_PI * sin(phi), 2.0 * SPC_PI * cos(phi), 0.0));
        return true;
    }
    case SPC_SHAPE_CYLINDER: {
        double phi = 2.0 * SPC_PI * h->b1;
        dT[0] = spc_mat4_apply_vector(&s->to_world,
                                      spc_v3(-4.0 * SPC_PI * SPC_PI * cos(phi), -4.0 * SPC_PI * SPC_PI * sin(phi), 0.0));
        dT[1] = spc_v3(0, 0, 0);
        return true;
    }
    case SPC_SHAPE_SDF:
    case SPC_SHAPE_SDFGRID:
        return false; /* its uv are not its surface parameters */
    case SPC_SHAPE_CURVE:
        return false; /* never a chain vertex */
    }
    return false;
}

/* The fields every shape fills alike. */
static void fill_common(const spc_shape *s, int prim, double t, spc_hit *h)
{
    h->t = t;
    h->prim = prim;
    h->shape = s;
    h->bsdf = s->bsdf;
    h->emitter = s->emitter;
    h->normal_mapped = false;
}

void spc_shape_prefetch_hit(const spc_shape *s, int prim)
{
    if (s->type == SPC_SHAPE_MESH && !s->tri_frame)
        __builtin_prefetch(s->mesh.idx + 3 * (size_t)prim, 0, 3);
}

void spc_shape_prefetch_vertices(const spc_shape *s, int prim)
{
    if (s->type != SPC_SHAPE_MESH || s->tri_frame)
        return;
    const spc_mesh *m = &s->mesh;
    const uint32_t *vi = m->idx + 3 * (size_t)prim;
    for (int k = 0; k < 3; ++k) {
        size_t i = vi[k];
        __builtin_prefetch(m->p + 3 * i, 0, 3);
        if (m->n && !s->face_normals)
            __builtin_prefetch(m->n + 3 * i, 0, 3);
        if (m->uv && !s->uv_unread)
            __builtin_prefetch(m->uv + 2 * i, 0, 3);
    }
}

/* fill_mesh_inline's MESH_SHADING fill where the triangle's kept frame holds every field shading
 * reads: a mesh with tri_frame, no vertex normals in use, its frame kept under the shape's
 * flip_normals and the triangle's tangent kept (not zero). The same expressions on the same values,
 * so the same record; straight-line code with no position edges (e1, e2) or vertex indices, which
 * fill_mesh_inline computes for its other branches: there GCC kept them, with 240 bytes of spills,
 * on every hit (about 150 instructions a hit on the cornell box, whose walls and boxes all come
 * here). false: the triangle does not qualify and *h is untouched. */
static inline __attribute__((always_inline)) bool fill_mesh_kept_shading(const spc_shape *s, int prim, double b1,
                                                                         double b2, double t, spc_hit *h)
{
    const spc_mesh *m = &s->mesh;
    if (!s->tri_frame || (m->n && !s->face_normals) || s->tri_frame_flip != s->flip_normals)
        return false;
    const double *c = s->tri_frame + SPC_TRI_FRAME_STRIDE * (size_t)prim;
    if (c[3] == 0.0 && c[4] == 0.0 && c[5] == 0.0)
        return false;
    fill_common(s, prim, t, h);
    spc_vec3 p0 = spc_v3(c[10], c[11], c[12]), p1 = spc_v3(c[13], c[14], c[15]), p2 = spc_v3(c[16], c[17], c[18]);
    double b0 = 1.0 - b1 - b2;
    h->p = spc_add(spc_add(spc_scale(p0, b0), spc_scale(p1, b1)), spc_scale(p2, b2));
    spc_vec3 ng = spc_v3(c[0], c[1], c[2]);
    h->ng = s->flip_normals ? spc_neg(ng) : ng;
    h->b1 = b1;
    h->b2 = b2;
    h->err = SPC_FLOAT_OFFSET * spc_max(c[9], spc_max_abs(h->p));
    if (s->uv_unread) {
        h->uv = spc_v2(0.0, 0.0);
    } else {
        const uint32_t *vi = m->idx + 3 * (size_t)prim;
        h->uv = mesh_uv(m, vi[0], vi[1], vi[2], b1, b2);
    }
    h->sh.n = h->ng;
    h->sh.s = spc_v3(c[3], c[4], c[5]);
    h->sh.t = spc_v3(c[6], c[7], c[8]);
    return true;
}

/* spc_shape_fill_hit_shading where fill_mesh_kept_shading does not apply; apart, so that the kept
 * frames' fill runs without this one's register saves and stack frame */
static __attribute__((noinline)) void fill_hit_shading_other(const spc_shape *s, int prim, double u, double v,
                                                            const spc_ray *r, double t, spc_hit *h)
{
    if (!s->lazy_derivs) {
        spc_shape_fill_hit(s, prim, u, v, r, t, h);
        return;
    }
    fill_common(s, prim, t, h);
    /* inlined with `what` constant: every hit a path tracer shades comes here, and the call and the
     * tests of the other fill kinds were about a tenth of this fill's instructions (bench/RESULTS.md) */
    fill_mesh_inline(s, prim, u, v, MESH_SHADING, h);
}

void spc_shape_fill_hit_shading(const spc_shape *s, int prim, double u, double v, const spc_ray *r, double t,
                                spc_hit *h)
{
    if (s->lazy_derivs && fill_mesh_kept_shading(s, prim, u, v, t, h))
        return;
    fill_hit_shading_other(s, prim, u, v, r, t, h);
}

void spc_shape_fill_hit_chain(const spc_shape *s, int prim, double u, double v, const spc_ray *r, double t,
                              spc_hit *h)
{
    if (s->type != SPC_SHAPE_MESH) {
        spc_shape_fill_hit(s, prim, u, v, r, t, h);
        return;
    }
    fill_common(s, prim, t, h);
    h->n_unmapped = spc_v3(0, 0, 0);
    fill_mesh(s, prim, u, v, MESH_CHAIN, h);
}

void spc_shape_hit_complete(spc_hit *h)
{
    const spc_shape *s = h->shape;
    if (s && s->type == SPC_SHAPE_MESH)
        fill_mesh(s, h->prim, h->b1, h->b2, MESH_ALL, h);
}

void spc_shape_hit_derivatives(spc_hit *h)
{
    const spc_shape *s = h->shape;
    if (!s || !s->lazy_derivs)
        return;
    h->n_unmapped = spc_v3(0, 0, 0);
    mesh_derivatives(s, h->prim, h->b1, h->b2, h);
}

void spc_shape_fill_hit(const spc_shape *s, int prim, double u, double v, const spc_ray *r, double t, spc_hit *h)
{
    fill_common(s, prim, t, h);
    h->n_unmapped = spc_v3(0, 0, 0);
    switch (s->type) {
    case SPC_SHAPE_MESH: fill_mesh(s, prim, u, v, MESH_ALL, h); break;
    case SPC_SHAPE_SPHERE: fill_sphere(s, r, t, h); break;
    case SPC_SHAPE_DISK: fill_disk(s, u, v, h); break;
    case SPC_SHAPE_CYLINDER: fill_cylinder(s, r, t, h); break;
    case SPC_SHAPE_SDF: spc_sdf_fill_hit(s->sdf, spc_madd(r->o, r->d, t), s->flip_normals, h); break;
    case SPC_SHAPE_CURVE: spc_curve_fill_hit(s->curve, prim, u, r, t, s->flip_normals, h); break;
    case SPC_SHAPE_SDFGRID: spc_sdfgrid_fill_hit(s->sdfgrid, spc_madd(r->o, r->d, t), s->flip_normals, h); break;
    }
}

/* ---- sampling ---- */

void spc_shape_sample_area(const spc_shape *s, spc_vec2 u, spc_shape_sample *out)
{
    out->pdf = 1.0 / s->area;
    out->prim = 0;
    switch (s->type) {
    case SPC_SHAPE_MESH: {
        if (s->has_para) {
            /* the parallelogram (spc_mesh_para); the batch in emitter/area_many.c repeats this
             * arithmetic in this order, bit for bit */
            const spc_mesh_para *q = &s->para;
            double a = u.x, b = u.y;
            int t = a + b > 1.0;
            out->p = spc_add(spc_add(q->o, spc_scale(q->e1, a)), spc_scale(q->e2, b));
            out->n = s->flip_normals ? spc_neg(q->ng[t]) : q->ng[t];
            out->err = SPC_FLOAT_OFFSET * spc_max(q->mag, spc_max_abs(out->p));
            /* the point's weights on the triangle's corners, for its uv */
            double w[3] = {1.0 - a - b, a, b};
            if (t) {
                w[0] = a + b - 1.0;
                w[1] = 1.0 - b;
                w[2] = 1.0 - a;
            }
            const uint32_t *vi = s->mesh.idx + 3 * t;
            out->uv = mesh_uv(&s->mesh, vi[0], vi[1], vi[2], w[q->role[t][1]], w[q->role[t][2]]);
            out->prim = t;
            return;
        }
        double ux;
        size_t i = spc_distrib1d_sample(&s->tri_distrib, u.x, &ux);
        spc_vec2 b = spc_warp_uniform_triangle(spc_v2(ux, u.y));
        spc_hit h; /* the fields read below are all filled */
        fill_mesh(s, (int)i, b.x, b.y, MESH_LIGHT, &h);
        out->p = h.p;
        out->n = h.ng;
        out->uv = h.uv;
        out->err = h.err;
        out->prim = (int)i;
        return;
    }
    case SPC_SHAPE_SPHERE: {
        spc_vec3 d = spc_warp_uniform_sphere(u);
        out->p = spc_madd(s->center, d, s->radius);
        out->n = s->flip_normals ? spc_neg(d) : d;
        out->uv = spc_sphere_uv(s, d); /* as fill_sphere: only where the shape's materials read it */
        out->err = SPC_DOUBLE_OFFSET * (spc_max_abs(s->center) + s->radius);
        return;
    }
    case SPC_SHAPE_DISK: {
        spc_vec2 d = spc_warp_disk_concentric(u);
        spc_hit h;
        memset(&h, 0, sizeof h);
        fill_disk(s, d.x, d.y, &h);
        out->p = h.p;
        out->n = h.ng;
        out->uv = h.uv;
        out->err = h.err;
        return;
    }
    case SPC_SHAPE_CYLINDER: {
        double phi = 2.0 * SPC_PI * u.x;
        spc_vec3 l = spc_v3(cos(phi), sin(phi), u.y);
        spc_hit h;
        memset(&h, 0, sizeof h);
        spc_ray r;
        /* a ray from the axis to the point, so fill_cylinder lands on it */
        r.o = spc_mat4_apply_point(&s->to_world, spc_v3(0, 0, u.y));
        r.d = spc_sub(spc_mat4_apply_point(&s->to_world, l), r.o);
        r.tmin = 0;
        r.tmax = INFINITY;
        fill_cylinder(s, &r, 1.0, &h);
        out->p = h.p;
        out->n = h.ng;
        out->uv = h.uv;
        out->err = h.err;
        return;
    }
    case SPC_SHAPE_SDF: {
        /* uniform by line sampling with rejection (scene/sdf.c); failure needs a surface far
         * smaller than its bounding sphere and is reported as a zero density */
        spc_vec3 p;
        spc_hit h;
        memset(&h, 0, sizeof h);
        if (!spc_sdf_sample_area(s->sdf, u, &p)) {
            p = spc_scale(spc_add(s->bbox_min, s->bbox_max), 0.5);
            out->pdf = 0.0;
        }
        spc_sdf_fill_hit(s->sdf, p, s->flip_normals, &h);
        out->p = p;
        out->n = h.ng;
        out->uv = h.uv;
        out->err = h.err;
        return;
    }
    case SPC_SHAPE_CURVE:
        /* curves are not emitters (the loader refuses them): no sample */
        memset(out, 0, sizeof *out);
        out->n = spc_v3(0, 0, 1);
        return;
    case SPC_SHAPE_SDFGRID:
        /* not sampled (never an emitter, as in Mitsuba): no sample */
        out->p = spc_scale(spc_add(s->bbox_min, s->bbox_max), 0.5);
        out->n = spc_v3(0, 0, 1);
        out->uv = spc_v2(0, 0);
        out->err = 0.0;
        out->pdf = 0.0;
        return;
    }
}

bool spc_shape_sample_solid_angle(const spc_shape *s, spc_vec3 ref, spc_vec2 u, bool with_uv, spc_shape_sample *out)
{
    if (!spc_shape_has_solid_angle_sampling(s, ref))
        return false;
    if (s->type == SPC_SHAPE_SDF) {
        spc_vec3 p;
        double pdf;
        memset(out, 0, sizeof *out);
        if (!spc_sdf_sample_direction(s->sdf, ref, u, &p, &pdf)) {
            out->p = spc_add(ref, spc_v3(1, 0, 0)); /* no sample: pdf 0 */
            out->n = spc_v3(0, 0, 1);
            return true;
        }
        spc_hit h;
        memset(&h, 0, sizeof h);
        spc_sdf_fill_hit(s->sdf, p, s->flip_normals, &h);
        out->p = p;
        out->n = h.ng;
        out->uv = h.uv;
        out->err = h.err;
        out->pdf = pdf;
        return true;
    }
    /* A direction uniform in the cone toward the sphere, as spc_warp_uniform_cone draws it, turned
     * into the point it sees by the angle alpha at the center between the reference point and
     * that point (pbrt-v4's Sphere::Sample): no ray-sphere intersection and no normalization on
     * the dependency chain. cos_max, 1 - cos_theta and thus the density are the cone warp's. */
    spc_vec3 dc = spc_sub(s->center, ref);
    double dist2 = spc_length2(dc), inv_dist = 1.0 / sqrt(dist2);
    double R = s->radius;
    double sin2_max = R * R / dist2;
    double cos_max = sqrt(spc_max(0.0, 1.0 - sin2_max));
    double one_minus_cos = u.x * (1.0 - cos_max);
    double cos_t = 1.0 - one_minus_cos, sin2_t = one_minus_cos * (2.0 - one_minus_cos);
    /* law of sines in the triangle (ref, center, point), the near intersection; clamped to the
     * tangent point where rounding puts the direction past the cone */
    double cos_a = sin2_t / (R * inv_dist) + cos_t * spc_safe_sqrt(1.0 - sin2_t / sin2_max);
    cos_a = spc_min(cos_a, 1.0);
    double sin_a = spc_safe_sqrt(1.0 - cos_a * cos_a);
    double sp, cp;
    spc_sincos_2pi(u.y, &sp, &cp);
    /* the normal: from the center, turned by alpha from the direction back toward ref */
    spc_frame fr = spc_frame_from_n(spc_scale(dc, inv_dist));
    spc_vec3 n = spc_frame_to_world(&fr, spc_v3(-sin_a * cp, -sin_a * sp, -cos_a));
    out->p = spc_madd(s->center, n, R);
    out->n = s->flip_normals ? spc_neg(n) : n;
    out->uv = with_uv ? spc_sphere_uv(s, n) : spc_v2(0.0, 0.0);
    out->pdf = spc_warp_uniform_cone_pdf(cos_max);
    out->err = SPC_DOUBLE_OFFSET * (spc_max_abs(s->center) + R);
    out->prim = 0;
    return true;
}

double spc_shape_pdf_solid_angle(const spc_shape *s, spc_vec3 ref, spc_vec3 p)
{
    (void)p;
    if (!spc_shape_has_solid_angle_sampling(s, ref))
        return 0.0;
    if (s->type == SPC_SHAPE_SDF)
        return spc_sdf_pdf_direction(s->sdf, ref);
    double dist2 = spc_length2(spc_sub(s->center, ref));
    double cos_max = sqrt(spc_max(0.0, 1.0 - s->radius * s->radius / dist2));
    return spc_warp_uniform_cone_pdf(cos_max);
}
