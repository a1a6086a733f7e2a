/*
 * scene/mesh.c: operations on indexed triangle meshes (validation, placement, clean-up, merging)
 * and the polygon triangulation shared by the OBJ and PLY loaders.
 *
 * Transforms: positions by M, normals by the inverse transpose of M's 3x3 block (normalized
 * again). A mirroring transform (det < 0) keeps the vertex order: the shape code decides what
 * orientation means.
 *
 * Triangulation: convex polygons become a fan (0, i, i+1). A polygon is convex when, projected on
 * the plane of its largest Newell normal component, every turn has the sign of its area. Concave
 * polygons are cut by ear clipping (Meisters 1975, "Polygons have ears"): repeatedly remove a
 * convex vertex whose triangle contains no other vertex; O(n^3) worst case, fine for the small
 * polygons of mesh files. A polygon without an ear (self-intersecting) falls back to the fan.
 */
#include "scene/mesh.h"

#include <stdlib.h>
#include <string.h>

static void release_attrs(spc_mesh *m)
{
    for (int i = 0; i < m->nattrs; ++i)
        free(m->attrs[i].data);
    free(m->attrs);
    m->attrs = NULL;
    m->nattrs = 0;
}

bool spc_mesh_copy_attrs(spc_mesh *dst, const spc_mesh *src)
{
    if (src->nattrs == 0)
        return true;
    dst->attrs = calloc((size_t)src->nattrs, sizeof *dst->attrs);
    if (!dst->attrs)
        return false;
    dst->nattrs = src->nattrs;
    for (int i = 0; i < src->nattrs; ++i) {
        const spc_mesh_attr *a = &src->attrs[i];
        size_t n = (size_t)a->dim * (a->face ? src->ntris : src->nverts);
        dst->attrs[i] = *a;
        dst->attrs[i].data = malloc(n * sizeof(float) + 1);
        if (!dst->attrs[i].data) {
            release_attrs(dst);
            return false;
        }
        memcpy(dst->attrs[i].data, a->data, n * sizeof(float));
    }
    return true;
}

const spc_mesh_attr *spc_mesh_find_attr(const spc_mesh *m, const char *name)
{
    for (int i = 0; i < m->nattrs; ++i)
        if (strcmp(m->attrs[i].name, name) == 0)
            return &m->attrs[i];
    return NULL;
}

void spc_mesh_release(spc_mesh *m)
{
    if (!m)
        return;
    free(m->p);
    free(m->n);
    free(m->uv);
    free(m->idx);
    release_attrs(m);
    memset(m, 0, sizeof *m);
}

spc_status spc_mesh_validate(const spc_mesh *m, const char *file, spc_error *err)
{
    if (m->nverts > 0 && !m->p)
        return spc_error_set(err, SPC_ERR_INTERNAL, file, 0, 0, "mesh has %zu vertices but no positions", m->nverts);
    if (m->ntris > 0 && !m->idx)
        return spc_error_set(err, SPC_ERR_INTERNAL, file, 0, 0, "mesh has %zu triangles but no indices", m->ntris);
    if (m->nverts > UINT32_MAX)
        return spc_error_set(err, SPC_ERR_LIMIT, file, 0, 0, "mesh has %zu vertices (at most 2^32 - 1)", m->nverts);
    for (size_t i = 0; i < m->nverts; ++i) {
        const float *p = m->p + 3 * i;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
            return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "vertex %zu: non-finite position (%g, %g, %g)", i,
                                 p[0], p[1], p[2]);
        if (m->n) {
            const float *n = m->n + 3 * i;
            if (!isfinite(n[0]) || !isfinite(n[1]) || !isfinite(n[2]))
                return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "vertex %zu: non-finite normal (%g, %g, %g)", i,
                                     n[0], n[1], n[2]);
        }
        if (m->uv) {
            const float *uv = m->uv + 2 * i;
            if (!isfinite(uv[0]) || !isfinite(uv[1]))
                return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0, "vertex %zu: non-finite uv (%g, %g)", i, uv[0],
                                     uv[1]);
        }
    }
    for (size_t t = 0; t < m->ntris; ++t)
        for (int k = 0; k < 3; ++k)
            if (m->idx[3 * t + k] >= m->nverts)
                return spc_error_set(err, SPC_ERR_VALUE, file, 0, 0,
                                     "triangle %zu: vertex index %u out of range (%zu vertices)", t,
                                     (unsigned)m->idx[3 * t + k], m->nverts);
    return SPC_OK;
}

bool spc_mesh_transform(spc_mesh *m, const spc_mat4 *to_world)
{
    spc_mat4 inv;
    if (!spc_mat4_inverse(to_world, &inv) || spc_mat4_det3(to_world) == 0.0)
        return false;
    for (size_t i = 0; i < m->nverts; ++i) {
        float *p = m->p + 3 * i;
        spc_vec3 q = spc_mat4_apply_point(to_world, spc_v3(p[0], p[1], p[2]));
        p[0] = (float)q.x, p[1] = (float)q.y, p[2] = (float)q.z;
        if (m->n) {
            float *n = m->n + 3 * i;
            spc_vec3 r = spc_normalize(spc_mat4_apply_normal(&inv, spc_v3(n[0], n[1], n[2])));
            n[0] = (float)r.x, n[1] = (float)r.y, n[2] = (float)r.z;
        }
    }
    return true;
}

size_t spc_mesh_drop_degenerate(spc_mesh *m)
{
    size_t kept = 0;
    for (size_t t = 0; t < m->ntris; ++t) {
        const uint32_t *id = m->idx + 3 * t;
        bool ok = id[0] != id[1] && id[1] != id[2] && id[0] != id[2];
        if (ok) {
            spc_vec3 a = spc_mesh_p(m, id[0]), b = spc_mesh_p(m, id[1]), c = spc_mesh_p(m, id[2]);
            double area2 = spc_length2(spc_cross(spc_sub(b, a), spc_sub(c, a)));
            ok = area2 > 0.0 && isfinite(area2);
        }
        if (ok) {
            if (kept != t) {
                memmove(m->idx + 3 * kept, id, 3 * sizeof *id);
                for (int a = 0; a < m->nattrs; ++a) /* face attributes follow their triangles */
                    if (m->attrs[a].face) {
                        int d = m->attrs[a].dim;
                        memmove(m->attrs[a].data + (size_t)d * kept, m->attrs[a].data + (size_t)d * t,
                                (size_t)d * sizeof(float));
                    }
            }
            ++kept;
        }
    }
    size_t dropped = m->ntris - kept;
    m->ntris = kept;
    return dropped;
}

/* Grows *arr to count elements of size bytes; false (and *arr unchanged) on failure. */
static bool grow(void *arr, size_t count, size_t size)
{
    void **pa = arr;
    if (count == 0)
        return true;
    void *q = realloc(*pa, count * size);
    if (!q)
        return false;
    *pa = q;
    return true;
}

bool spc_mesh_compute_vertex_normals(spc_mesh *m)
{
    if (m->n || m->nverts == 0)
        return true;
    double *acc = calloc(3 * m->nverts, sizeof(double));
    float *n = malloc(3 * m->nverts * sizeof(float));
    spc_vec3 *first = calloc(m->nverts, sizeof(spc_vec3));
    if (!acc || !n || !first) {
        free(acc);
        free(n);
        free(first);
        return false;
    }
    for (size_t t = 0; t < m->ntris; ++t) {
        const uint32_t *id = m->idx + 3 * t;
        spc_vec3 p[3] = {spc_mesh_p(m, id[0]), spc_mesh_p(m, id[1]), spc_mesh_p(m, id[2])};
        spc_vec3 fn = spc_cross(spc_sub(p[1], p[0]), spc_sub(p[2], p[0]));
        double len = spc_length(fn);
        if (!(len > 0.0))
            continue;
        fn = spc_scale(fn, 1.0 / len);
        for (int k = 0; k < 3; ++k) {
            spc_vec3 e1 = spc_normalize(spc_sub(p[(k + 1) % 3], p[k]));
            spc_vec3 e2 = spc_normalize(spc_sub(p[(k + 2) % 3], p[k]));
            double angle = acos(spc_clamp(spc_dot(e1, e2), -1.0, 1.0));
            double *a = acc + 3 * (size_t)id[k];
            a[0] += angle * fn.x;
            a[1] += angle * fn.y;
            a[2] += angle * fn.z;
            if (spc_length2(first[id[k]]) == 0.0)
                first[id[k]] = fn;
        }
    }
    for (size_t i = 0; i < m->nverts; ++i) {
        spc_vec3 v = spc_v3(acc[3 * i], acc[3 * i + 1], acc[3 * i + 2]);
        double len = spc_length(v);
        v = len > 1e-12 ? spc_scale(v, 1.0 / len) : first[i];
        if (spc_length2(v) == 0.0)
            v = spc_v3(0, 0, 1); /* a vertex of no triangle: never shaded */
        n[3 * i] = (float)v.x;
        n[3 * i + 1] = (float)v.y;
        n[3 * i + 2] = (float)v.z;
    }
    free(acc);
    free(first);
    m->n = n;
    return true;
}

bool spc_mesh_append(spc_mesh *dst, const spc_mesh *src)
{
    if (src->nverts == 0 && src->ntris == 0)
        return true;
    size_t nv = dst->nverts + src->nverts, nt = dst->ntris + src->ntris;
    if (nv > UINT32_MAX || nv < dst->nverts || nt < dst->ntris)
        return false;
    bool dst_empty = dst->nverts == 0 && dst->ntris == 0;
    /* Normals survive only if both parts have them (face normals cannot be mixed with vertex
     * normals per vertex); missing uvs are filled with (0, 0). */
    bool keep_n = dst_empty ? src->n != NULL : (dst->n != NULL && src->n != NULL);
    bool keep_uv = dst_empty ? src->uv != NULL : (dst->uv != NULL || src->uv != NULL);

    if (!grow(&dst->p, 3 * nv, sizeof(float)) || !grow(&dst->idx, 3 * nt, sizeof(uint32_t)))
        return false;
    if (keep_n && !grow(&dst->n, 3 * nv, sizeof(float)))
        return false;
    if (keep_uv) {
        bool had_uv = dst->uv != NULL;
        if (!grow(&dst->uv, 2 * nv, sizeof(float)))
            return false;
        if (!had_uv && dst->nverts > 0)
            memset(dst->uv, 0, 2 * dst->nverts * sizeof(float));
    }
    /* Every allocation succeeded: from here on nothing can fail. */
    if (src->nverts > 0)
        memcpy(dst->p + 3 * dst->nverts, src->p, 3 * src->nverts * sizeof(float));
    if (keep_n) {
        if (src->nverts > 0)
            memcpy(dst->n + 3 * dst->nverts, src->n, 3 * src->nverts * sizeof(float));
    } else {
        free(dst->n);
        dst->n = NULL;
    }
    if (keep_uv && src->nverts > 0) {
        if (src->uv)
            memcpy(dst->uv + 2 * dst->nverts, src->uv, 2 * src->nverts * sizeof(float));
        else
            memset(dst->uv + 2 * dst->nverts, 0, 2 * src->nverts * sizeof(float));
    }
    release_attrs(dst);
    uint32_t base = (uint32_t)dst->nverts;
    for (size_t i = 0; i < 3 * src->ntris; ++i)
        dst->idx[3 * dst->ntris + i] = src->idx[i] + base;
    dst->nverts = nv;
    dst->ntris = nt;
    return true;
}

/* ---- polygon triangulation ---- */

/* Twice the signed area of the 2D triangle (a, b, c). */
static double orient2(const double *a, const double *b, const double *c)
{
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

static size_t fan(const uint32_t *ids, size_t n, uint32_t *tris)
{
    for (size_t i = 1; i + 1 < n; ++i) {
        tris[3 * (i - 1) + 0] = ids[0];
        tris[3 * (i - 1) + 1] = ids[i];
        tris[3 * (i - 1) + 2] = ids[i + 1];
    }
    return n - 2;
}

/* Ear clipping on the 2D points q (polygon order) with orientation sign s (+1 or -1). */
static size_t ear_clip(const double (*q)[2], const uint32_t *ids, size_t n, double s, size_t *live, uint32_t *tris)
{
    size_t m = n, ntri = 0;
    for (size_t i = 0; i < n; ++i)
        live[i] = i;
    while (m > 3) {
        bool found = false;
        for (size_t k = 0; k < m && !found; ++k) {
            size_t ia = live[(k + m - 1) % m], ib = live[k], ic = live[(k + 1) % m];
            if (s * orient2(q[ia], q[ib], q[ic]) <= 0.0)
                continue; /* reflex or flat corner */
            bool empty = true;
            for (size_t j = 0; j < m && empty; ++j) {
                size_t ip = live[j];
                if (ip == ia || ip == ib || ip == ic)
                    continue;
                /* inside or on the boundary of the candidate ear */
                if (s * orient2(q[ia], q[ib], q[ip]) >= 0.0 && s * orient2(q[ib], q[ic], q[ip]) >= 0.0 &&
                    s * orient2(q[ic], q[ia], q[ip]) >= 0.0)
                    empty = false;
            }
            if (!empty)
                continue;
            tris[3 * ntri + 0] = ids[ia];
            tris[3 * ntri + 1] = ids[ib];
            tris[3 * ntri + 2] = ids[ic];
            ++ntri;
            memmove(live + k, live + k + 1, (m - k - 1) * sizeof *live);
            --m;
            found = true;
        }
        if (!found)
            return 0;
    }
    tris[3 * ntri + 0] = ids[live[0]];
    tris[3 * ntri + 1] = ids[live[1]];
    tris[3 * ntri + 2] = ids[live[2]];
    return ntri + 1;
}

size_t spc_polygon_triangulate(const float *p, const uint32_t *ids, size_t n, uint32_t *tris)
{
    if (n < 3)
        return 0;
    if (n == 3) {
        tris[0] = ids[0], tris[1] = ids[1], tris[2] = ids[2];
        return 1;
    }
    /* Newell's normal picks the projection plane. */
    double nx = 0.0, ny = 0.0, nz = 0.0;
    for (size_t i = 0; i < n; ++i) {
        const float *a = p + 3 * (size_t)ids[i], *b = p + 3 * (size_t)ids[(i + 1) % n];
        nx += ((double)a[1] - b[1]) * ((double)a[2] + b[2]);
        ny += ((double)a[2] - b[2]) * ((double)a[0] + b[0]);
        nz += ((double)a[0] - b[0]) * ((double)a[1] + b[1]);
    }
    int ax0, ax1;
    double s;
    if (fabs(nx) >= fabs(ny) && fabs(nx) >= fabs(nz))
        ax0 = 1, ax1 = 2, s = nx;
    else if (fabs(ny) >= fabs(nz))
        ax0 = 2, ax1 = 0, s = ny;
    else
        ax0 = 0, ax1 = 1, s = nz;
    if (!(s != 0.0) || !isfinite(s))
        return fan(ids, n, tris); /* degenerate polygon: no plane to work in */
    s = s > 0.0 ? 1.0 : -1.0;

    enum { SMALL = 64 };
    double small_q[SMALL][2];
    size_t small_live[SMALL];
    double (*q)[2] = small_q;
    size_t *live = small_live;
    if (n > SMALL) {
        q = malloc(n * sizeof *q);
        live = malloc(n * sizeof *live);
        if (!q || !live) {
            free(q);
            free(live);
            return fan(ids, n, tris);
        }
    }
    for (size_t i = 0; i < n; ++i) {
        const float *a = p + 3 * (size_t)ids[i];
        q[i][0] = a[ax0];
        q[i][1] = a[ax1];
    }
    bool convex = true;
    for (size_t i = 0; i < n && convex; ++i)
        if (s * orient2(q[i], q[(i + 1) % n], q[(i + 2) % n]) < 0.0)
            convex = false;
    size_t ntri = convex ? fan(ids, n, tris) : ear_clip((const double (*)[2])q, ids, n, s, live, tris);
    if (ntri == 0)
        ntri = fan(ids, n, tris);
    if (n > SMALL) {
        free(q);
        free(live);
    }
    return ntri;
}
