/*
 * scene/sdfgrid.c: the sdfgrid shape (scene/sdfgrid.h): a vertex-based grid of signed distances
 * over [0,1]^3, trilinear within each voxel, intersected exactly voxel by voxel.
 *
 * Traversal: the ray is carried into the grid's index space (vertex (i, j, k) at (i, j, k)), clipped
 * to the box and walked voxel by voxel (Amanatides and Woo's DDA, each boundary recomputed from the
 * origin rather than accumulated); voxels whose 8 corners share one strict sign are skipped.
 * Within a voxel the trilinear field along the ray is a cubic in t (Hansson-Soderlund, Evans and
 * Akenine-Moller 2022, section 3; Marmitt et al. 2004 for the root search). Its coefficients are
 * formed around the voxel's entry point; the derivative's real roots split the segment into
 * monotone pieces, and the first piece whose ends differ in sign (or touch zero) is bisected to
 * double precision.
 *
 * Normals (Mitsuba 3's definition, so that renders agree): the gradient of a voxel at a point is the
 * difference of the (clamped) trilinear field across the voxel's faces at the point's other two
 * coordinates, i.e. the trilinear interpolant's exact gradient for the voxel the point is in.
 */
#include "scene/sdfgrid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Position error of a hit relative to the box's world size: the root is bisected to double
 * rounding, but the field is only as smooth as float data; 1e-7 of the size moves a spawned ray
 * clear of the crossing it left without skipping any feature a float grid can hold. */
#define SDFGRID_OFFSET 1e-7
/* Bisection steps: enough to halve a voxel's segment down to double rounding. */
#define SDFGRID_BISECT_MAX 80

struct spc_sdfgrid {
    int n[3];            /* vertices per axis (>= 2) */
    float *f;            /* n[0] n[1] n[2] values, x fastest */
    uint8_t *occupied;   /* (n[0]-1)(n[1]-1)(n[2]-1) voxels: 1 where the surface may pass */
    size_t noccupied;
    spc_mat4 to_world, to_local;
    bool smooth;
    int occ_lo[3], occ_hi[3]; /* index bounds of the occupied voxels (vertices occ_lo..occ_hi+1) */
    double size;         /* world diagonal of the box */
    spc_vec3 lo, hi;     /* world bounds of the occupied voxels (the box if none) */
};

static size_t vidx(const spc_sdfgrid *g, int x, int y, int z)
{
    return ((size_t)z * (size_t)g->n[1] + (size_t)y) * (size_t)g->n[0] + (size_t)x;
}

static size_t cidx(const spc_sdfgrid *g, int x, int y, int z)
{
    return ((size_t)z * (size_t)(g->n[1] - 1) + (size_t)y) * (size_t)(g->n[0] - 1) + (size_t)x;
}

static void corners(const spc_sdfgrid *g, int x, int y, int z, double s[8])
{
    for (int i = 0; i < 8; ++i)
        s[i] = g->f[vidx(g, x + (i & 1), y + ((i >> 1) & 1), z + ((i >> 2) & 1))];
}

spc_sdfgrid *spc_sdfgrid_create(const float *values, int nx, int ny, int nz, const spc_mat4 *to_world, bool smooth,
                                const char *file, int line, int col, spc_error *err)
{
    if (nx < 2 || ny < 2 || nz < 2) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col,
                      "sdfgrid of %d x %d x %d values: it needs at least 2 along each axis", nx, ny, nz);
        return NULL;
    }
    double count = (double)nx * (double)ny * (double)nz;
    if (count > (double)SPC_SDFGRID_MAX_VALUES) {
        spc_error_set(err, SPC_ERR_LIMIT, file, line, col, "sdfgrid of %d x %d x %d values is above the limit of %llu",
                      nx, ny, nz, (unsigned long long)SPC_SDFGRID_MAX_VALUES);
        return NULL;
    }
    size_t nv = (size_t)nx * (size_t)ny * (size_t)nz;
    for (size_t i = 0; i < nv; ++i)
        if (!isfinite(values[i])) {
            spc_error_set(err, SPC_ERR_VALUE, file, line, col, "sdfgrid value %zu (x %zu, y %zu, z %zu) is not finite",
                          i, i % (size_t)nx, (i / (size_t)nx) % (size_t)ny, i / ((size_t)nx * (size_t)ny));
            return NULL;
        }
    spc_mat4 M = to_world ? *to_world : spc_mat4_identity();
    spc_mat4 Mi;
    bool finite = true;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            finite &= isfinite(M.m[i][j]) != 0;
    if (!finite || !(fabs(spc_mat4_det3(&M)) > 0.0) || !spc_mat4_inverse(&M, &Mi)) {
        spc_error_set(err, SPC_ERR_VALUE, file, line, col, "sdfgrid to_world is singular or not finite");
        return NULL;
    }
    spc_sdfgrid *g = calloc(1, sizeof *g);
    size_t nc = (size_t)(nx - 1) * (size_t)(ny - 1) * (size_t)(nz - 1);
    if (g) {
        g->f = malloc(nv * sizeof *g->f);
        g->occupied = calloc(nc, 1);
    }
    if (!g || !g->f || !g->occupied) {
        spc_sdfgrid_destroy(g);
        spc_error_set(err, SPC_ERR_NOMEM, file, line, col, "out of memory for an sdfgrid of %zu values", nv);
        return NULL;
    }
    memcpy(g->f, values, nv * sizeof *g->f);
    g->n[0] = nx;
    g->n[1] = ny;
    g->n[2] = nz;
    g->to_world = M;
    g->to_local = Mi;
    g->smooth = smooth;
    /* occupied: not all 8 corners > 0 and not all < 0 (Mitsuba's test: a zero corner counts) */
    for (int a = 0; a < 3; ++a) {
        g->occ_lo[a] = g->n[a];
        g->occ_hi[a] = -1;
    }
    for (int z = 0; z + 1 < nz; ++z)
        for (int y = 0; y + 1 < ny; ++y)
            for (int x = 0; x + 1 < nx; ++x) {
                double s[8];
                corners(g, x, y, z, s);
                bool pos = true, neg = true;
                for (int i = 0; i < 8; ++i) {
                    pos &= s[i] > 0.0;
                    neg &= s[i] < 0.0;
                }
                if (!pos && !neg) {
                    g->occupied[cidx(g, x, y, z)] = 1;
                    g->noccupied++;
                    int v[3] = {x, y, z};
                    for (int a = 0; a < 3; ++a) {
                        g->occ_lo[a] = v[a] < g->occ_lo[a] ? v[a] : g->occ_lo[a];
                        g->occ_hi[a] = v[a] > g->occ_hi[a] ? v[a] : g->occ_hi[a];
                    }
                }
            }
    /* rays are clipped to the occupied voxels' box, and so are the Embree bounds */
    double blo[3] = {0, 0, 0}, bhi[3] = {1, 1, 1};
    if (g->noccupied > 0)
        for (int a = 0; a < 3; ++a) {
            blo[a] = (double)g->occ_lo[a] / (g->n[a] - 1);
            bhi[a] = (double)(g->occ_hi[a] + 1) / (g->n[a] - 1);
        }
    spc_vec3 lo = spc_v3(INFINITY, INFINITY, INFINITY), hi = spc_neg(lo), box_lo = lo, box_hi = hi;
    for (int k = 0; k < 8; ++k) {
        spc_vec3 q = spc_mat4_apply_point(&M, spc_v3(k & 1 ? bhi[0] : blo[0], (k >> 1) & 1 ? bhi[1] : blo[1],
                                                     (k >> 2) & 1 ? bhi[2] : blo[2]));
        lo = spc_vmin(lo, q);
        hi = spc_vmax(hi, q);
        spc_vec3 b = spc_mat4_apply_point(&M, spc_v3(k & 1, (k >> 1) & 1, (k >> 2) & 1));
        box_lo = spc_vmin(box_lo, b);
        box_hi = spc_vmax(box_hi, b);
    }
    g->lo = lo;
    g->hi = hi;
    g->size = spc_length(spc_sub(box_hi, box_lo));
    return g;
}

void spc_sdfgrid_destroy(spc_sdfgrid *g)
{
    if (!g)
        return;
    free(g->f);
    free(g->occupied);
    free(g);
}

void spc_sdfgrid_bounds(const spc_sdfgrid *g, spc_vec3 *lo, spc_vec3 *hi)
{
    *lo = g->lo;
    *hi = g->hi;
}

size_t spc_sdfgrid_occupied(const spc_sdfgrid *g) { return g->noccupied; }

/* ---- the field ---- */

/* Trilinear interpolation at index-space coordinates, clamped to the grid (a texture's clamp). */
static double eval_index(const spc_sdfgrid *g, double X, double Y, double Z)
{
    double c[3] = {X, Y, Z};
    int i0[3];
    double w[3];
    for (int a = 0; a < 3; ++a) {
        double v = spc_clamp(c[a], 0.0, (double)(g->n[a] - 1));
        int i = (int)floor(v);
        if (i > g->n[a] - 2)
            i = g->n[a] - 2;
        i0[a] = i;
        w[a] = v - i;
    }
    double s[8];
    corners(g, i0[0], i0[1], i0[2], s);
    double x = w[0], y = w[1], z = w[2];
    double c00 = s[0] + x * (s[1] - s[0]), c10 = s[2] + x * (s[3] - s[2]);
    double c01 = s[4] + x * (s[5] - s[4]), c11 = s[6] + x * (s[7] - s[6]);
    double c0 = c00 + y * (c10 - c00), c1 = c01 + y * (c11 - c01);
    return c0 + z * (c1 - c0);
}

double spc_sdfgrid_eval_local(const spc_sdfgrid *g, spc_vec3 q)
{
    return eval_index(g, q.x * (g->n[0] - 1), q.y * (g->n[1] - 1), q.z * (g->n[2] - 1));
}

/* Gradient in local ([0,1]^3) units of voxel v's trilinear field at index-space point Q: the
 * differences across v's faces at Q's other coordinates (Mitsuba's voxel_grad). */
static spc_vec3 voxel_grad(const spc_sdfgrid *g, const double Q[3], const int v[3])
{
    double d[3];
    for (int a = 0; a < 3; ++a) {
        double q1[3] = {Q[0], Q[1], Q[2]}, q0[3] = {Q[0], Q[1], Q[2]};
        q1[a] = v[a] + 1.0;
        q0[a] = v[a];
        d[a] = (eval_index(g, q1[0], q1[1], q1[2]) - eval_index(g, q0[0], q0[1], q0[2])) * (g->n[a] - 1);
    }
    return spc_v3(d[0], d[1], d[2]);
}

double spc_sdfgrid_area(const spc_sdfgrid *g)
{
    /* world edges of a voxel and its world volume */
    spc_vec3 e[3];
    for (int a = 0; a < 3; ++a) {
        double h = 1.0 / (g->n[a] - 1);
        e[a] = spc_mat4_apply_vector(&g->to_world, spc_v3(a == 0 ? h : 0.0, a == 1 ? h : 0.0, a == 2 ? h : 0.0));
    }
    double vol = fabs(spc_dot(e[0], spc_cross(e[1], e[2])));
    double area = 0.0;
    for (int z = 0; z + 1 < g->n[2]; ++z)
        for (int y = 0; y + 1 < g->n[1]; ++y)
            for (int x = 0; x + 1 < g->n[0]; ++x) {
                if (!g->occupied[cidx(g, x, y, z)])
                    continue;
                double Q[3] = {x + 0.5, y + 0.5, z + 0.5};
                int v[3] = {x, y, z};
                spc_vec3 n = spc_mat4_apply_normal(&g->to_local, voxel_grad(g, Q, v));
                double l = spc_length(n);
                if (!(l > 0.0))
                    continue;
                n = spc_scale(n, 1.0 / l);
                double extent = fabs(spc_dot(n, e[0])) + fabs(spc_dot(n, e[1])) + fabs(spc_dot(n, e[2]));
                area += vol / extent;
            }
    return area;
}

/* ---- intersection ---- */

static double cubic(const double c[4], double u) { return ((c[3] * u + c[2]) * u + c[1]) * u + c[0]; }

/* Product of two polynomials of degree <= 1 and <= 2 (coefficients low to high) into out[0..3]. */
static void mul_lin(const double a[4], double l0, double l1, double out[4])
{
    out[0] = a[0] * l0;
    out[1] = a[1] * l0 + a[0] * l1;
    out[2] = a[2] * l0 + a[1] * l1;
    out[3] = a[3] * l0 + a[2] * l1;
}

/* The first u in [0, L] where the voxel's cubic changes sign (or is zero at a piece's end). */
static bool first_root(const double c[4], double L, double *u)
{
    double cut[4] = {0.0, 0.0, 0.0, L};
    int ncut = 1;
    /* derivative 3 c3 u^2 + 2 c2 u + c1 */
    double a = 3.0 * c[3], b = 2.0 * c[2], cc = c[1];
    double r[2];
    int nr = 0;
    if (a != 0.0) {
        double disc = b * b - 4.0 * a * cc;
        if (disc > 0.0) {
            double q = -0.5 * (b + copysign(sqrt(disc), b));
            r[0] = q / a;
            r[1] = q != 0.0 ? cc / q : r[0];
            nr = 2;
        }
    } else if (b != 0.0) {
        r[0] = -cc / b;
        nr = 1;
    }
    if (nr == 2 && r[1] < r[0]) {
        double t = r[0];
        r[0] = r[1];
        r[1] = t;
    }
    for (int k = 0; k < nr; ++k)
        if (r[k] > cut[ncut - 1] && r[k] < L)
            cut[ncut++] = r[k];
    cut[ncut++] = L;
    for (int k = 0; k + 1 < ncut; ++k) {
        double lo = cut[k], hi = cut[k + 1];
        double flo = cubic(c, lo), fhi = cubic(c, hi);
        if (flo == 0.0) {
            *u = lo;
            return true;
        }
        if (flo * fhi > 0.0)
            continue;
        for (int it = 0; it < SDFGRID_BISECT_MAX; ++it) {
            double mid = 0.5 * (lo + hi);
            if (mid <= lo || mid >= hi)
                break;
            double fm = cubic(c, mid);
            if (fm == 0.0) {
                lo = hi = mid;
                break;
            }
            if ((fm < 0.0) == (flo < 0.0)) {
                lo = mid;
                flo = fm;
            } else
                hi = mid;
        }
        *u = 0.5 * (lo + hi);
        return true;
    }
    return false;
}

/* The cubic in u = t - ta of voxel v's trilinear field along the index-space ray O + D t. */
static void voxel_cubic(const spc_sdfgrid *g, const int v[3], const double O[3], const double D[3], double ta,
                        double c[4])
{
    double s[8];
    corners(g, v[0], v[1], v[2], s);
    /* f = k0 + k1 x + k2 y + k3 z + k4 xy + k5 xz + k6 yz + k7 xyz in the voxel's [0,1]^3 */
    double k0 = s[0], k1 = s[1] - s[0], k2 = s[2] - s[0], k3 = s[4] - s[0];
    double k4 = s[3] - s[1] - s[2] + s[0];
    double k5 = s[5] - s[1] - s[4] + s[0];
    double k6 = s[6] - s[2] - s[4] + s[0];
    double k7 = s[7] - s[6] - s[5] - s[3] + s[1] + s[2] + s[4] - s[0];
    double p[3], d[3];
    for (int a = 0; a < 3; ++a) {
        p[a] = O[a] + D[a] * ta - v[a];
        d[a] = D[a];
    }
    double X[4] = {p[0], d[0], 0, 0}, XY[4], XZ[4], XYZ[4];
    mul_lin(X, p[1], d[1], XY);
    mul_lin(X, p[2], d[2], XZ);
    double Y[4] = {p[1], d[1], 0, 0}, YZ[4];
    mul_lin(Y, p[2], d[2], YZ);
    mul_lin(XY, p[2], d[2], XYZ);
    c[0] = k0 + k1 * p[0] + k2 * p[1] + k3 * p[2] + k4 * XY[0] + k5 * XZ[0] + k6 * YZ[0] + k7 * XYZ[0];
    c[1] = k1 * d[0] + k2 * d[1] + k3 * d[2] + k4 * XY[1] + k5 * XZ[1] + k6 * YZ[1] + k7 * XYZ[1];
    c[2] = k4 * XY[2] + k5 * XZ[2] + k6 * YZ[2] + k7 * XYZ[2];
    c[3] = k7 * XYZ[3];
}

bool spc_sdfgrid_intersect(const spc_sdfgrid *g, const spc_ray *r, double *t)
{
    if (g->noccupied == 0)
        return false;
    spc_vec3 o = spc_mat4_apply_point(&g->to_local, r->o);
    spc_vec3 dl = spc_mat4_apply_vector(&g->to_local, r->d);
    double O[3] = {o.x * (g->n[0] - 1), o.y * (g->n[1] - 1), o.z * (g->n[2] - 1)};
    double D[3] = {dl.x * (g->n[0] - 1), dl.y * (g->n[1] - 1), dl.z * (g->n[2] - 1)};
    /* clip to the box of the occupied voxels */
    double t0 = r->tmin, t1 = r->tmax, inv[3];
    for (int a = 0; a < 3; ++a) {
        double lo = g->occ_lo[a], hi = g->occ_hi[a] + 1.0;
        inv[a] = D[a] != 0.0 ? 1.0 / D[a] : 0.0;
        if (D[a] == 0.0) {
            if (O[a] < lo || O[a] > hi)
                return false;
            continue;
        }
        double ta = (lo - O[a]) * inv[a], tb = (hi - O[a]) * inv[a];
        if (ta > tb) {
            double tmp = ta;
            ta = tb;
            tb = tmp;
        }
        t0 = spc_max(t0, ta);
        t1 = spc_min(t1, tb);
    }
    if (!(t0 <= t1))
        return false;
    /* the voxel of the entry point */
    int v[3], step[3];
    double tc = t0;
    for (int a = 0; a < 3; ++a) {
        double pa = O[a] + D[a] * t0;
        int i = (int)floor(spc_clamp(pa, (double)g->occ_lo[a], g->occ_hi[a] + 1.0));
        if (i > g->occ_hi[a])
            i = g->occ_hi[a];
        /* on a boundary, going down: start in the lower voxel */
        if (D[a] < 0.0 && pa == (double)i && i > g->occ_lo[a])
            i -= 1;
        v[a] = i;
        step[a] = D[a] > 0.0 ? 1 : (D[a] < 0.0 ? -1 : 0);
    }
    for (;;) {
        /* the voxel's exit */
        double tn = INFINITY;
        int axis = -1;
        for (int a = 0; a < 3; ++a) {
            if (step[a] == 0)
                continue;
            double b = step[a] > 0 ? v[a] + 1.0 : (double)v[a];
            double ta = (b - O[a]) * inv[a];
            if (ta < tn) {
                tn = ta;
                axis = a;
            }
        }
        double te = spc_min(tn, t1);
        if (te >= tc && g->occupied[cidx(g, v[0], v[1], v[2])]) {
            double c[4], u;
            voxel_cubic(g, v, O, D, tc, c);
            if (first_root(c, te - tc, &u)) {
                double th = tc + u;
                if (th > r->tmin && th < r->tmax) {
                    *t = th;
                    return true;
                }
            }
        }
        if (axis < 0 || tn >= t1)
            return false;
        v[axis] += step[axis];
        if (v[axis] < g->occ_lo[axis] || v[axis] > g->occ_hi[axis])
            return false;
        tc = spc_max(tc, tn);
    }
}

/* ---- hits ---- */

static spc_vec3 smooth_normal(const spc_sdfgrid *g, const double Q[3])
{
    int v111[3];
    double w[3];
    for (int a = 0; a < 3; ++a) {
        v111[a] = (int)lround(Q[a]);
        w[a] = Q[a] - v111[a] + 0.5;
    }
    spc_vec3 n[8];
    bool ok[8];
    for (int i = 0; i < 8; ++i) {
        int v[3] = {v111[0] - 1 + (i & 1), v111[1] - 1 + ((i >> 1) & 1), v111[2] - 1 + ((i >> 2) & 1)};
        ok[i] = v[0] >= 0 && v[1] >= 0 && v[2] >= 0;
        n[i] = spc_v3(0, 0, 0);
        if (ok[i]) {
            spc_vec3 gr = voxel_grad(g, Q, v);
            double l = spc_length(gr);
            if (l > 0.0)
                n[i] = spc_scale(gr, 1.0 / l);
        }
    }
    /* an axis whose lower (upper) layer of voxels is all outside the grid takes the other layer */
    for (int a = 0; a < 3; ++a) {
        bool any0 = false, any1 = false;
        for (int i = 0; i < 8; ++i) {
            if (((i >> a) & 1) == 0)
                any0 |= ok[i];
            else
                any1 |= ok[i];
        }
        if (!any0)
            w[a] = 1.0;
        if (!any1)
            w[a] = 0.0;
    }
    spc_vec3 sum = spc_v3(0, 0, 0);
    for (int i = 0; i < 8; ++i) {
        double wi = ((i & 1) ? w[0] : 1.0 - w[0]) * (((i >> 1) & 1) ? w[1] : 1.0 - w[1]) *
                    (((i >> 2) & 1) ? w[2] : 1.0 - w[2]);
        sum = spc_madd(sum, n[i], wi);
    }
    return sum;
}

void spc_sdfgrid_fill_hit(const spc_sdfgrid *g, spc_vec3 p, bool flip_normals, spc_hit *h)
{
    spc_vec3 q = spc_mat4_apply_point(&g->to_local, p);
    double Q[3] = {q.x * (g->n[0] - 1), q.y * (g->n[1] - 1), q.z * (g->n[2] - 1)};
    int v[3];
    for (int a = 0; a < 3; ++a) {
        int i = (int)floor(spc_clamp(Q[a], 0.0, (double)(g->n[a] - 1)));
        v[a] = i > g->n[a] - 2 ? g->n[a] - 2 : i;
    }
    spc_vec3 gl = spc_mat4_apply_normal(&g->to_local, voxel_grad(g, Q, v));
    double l = spc_length(gl);
    spc_vec3 n = l > 0.0 ? spc_scale(gl, 1.0 / l) : spc_v3(0, 0, 1);
    double sgn = flip_normals ? -1.0 : 1.0;
    spc_vec3 ns = n;
    if (g->smooth) {
        spc_vec3 sm = spc_mat4_apply_normal(&g->to_local, smooth_normal(g, Q));
        double sl = spc_length(sm);
        if (sl > 0.0 && isfinite(sl))
            ns = spc_scale(sm, 1.0 / sl);
    }
    spc_frame fr = spc_frame_from_n(n);
    h->p = p;
    h->ng = spc_scale(n, sgn);
    h->dpdu = fr.s;
    h->dpdv = fr.t;
    h->dndu = h->dndv = spc_v3(0, 0, 0);
    h->sh = spc_frame_from_ns(spc_scale(ns, sgn), fr.s);
    h->b1 = h->b2 = 0.0;
    h->uv = spc_v2(0.0, 0.0);
    h->err = SDFGRID_OFFSET * (spc_max_abs(p) + g->size);
}
