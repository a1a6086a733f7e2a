/*
 * medium/gridvolume.c: volume-valued medium properties as Mitsuba 3 defines them: gridvolume (a
 * grid of values over the unit cube of its local space, looked up through drjit's Texture3f:
 * texel centres at (i + 0.5) / res, trilinear or nearest, wrap clamp/repeat/mirror) and constvolume
 * (one value; its unit cube still bounds a heterogeneous medium). medium.h states the contract;
 * io/vol.c reads the grids' files.
 *
 * It also cuts a ray into the pieces on which a volume is a polynomial of the ray parameter
 * (spc_volume_pieces): between two planes of texel centres (trilinear; texel edges for nearest)
 * the interpolated value along a line is a product of three linear functions, a cubic, which is
 * what lets heterogeneous.c integrate and invert optical depths exactly.
 *
 * Mitsuba XML <volume type="gridvolume">: filename (.vol, see io/vol.c), filter_type
 *   ("trilinear" | "nearest"), wrap_mode ("clamp" | "repeat" | "mirror"), to_world, raw (no
 *   effect in RGB), use_grid_bbox (false; true maps the unit cube to the file's bounding box).
 * <volume type="constvolume">: value (float or rgb, 1), to_world.
 */
#include <math.h>
#include <stdlib.h>

#include "medium/volume_pieces.h"

/* A texel index wrapped into [0, n). */
static int wrap_index(long long i, int n, spc_volume_wrap w)
{
    switch (w) {
    case SPC_VOLUME_CLAMP:
        return i < 0 ? 0 : (i >= n ? n - 1 : (int)i);
    case SPC_VOLUME_REPEAT: {
        long long r = i % n;
        return (int)(r < 0 ? r + n : r);
    }
    case SPC_VOLUME_MIRROR: {
        long long r = i % (2LL * n);
        if (r < 0)
            r += 2LL * n;
        return (int)(r < n ? r : 2LL * n - 1 - r);
    }
    }
    return 0;
}

/* Index of a coordinate far outside the grid: clamped to what a long long holds (NaN: 0). */
static long long floor_index(double x)
{
    if (!(x == x))
        return 0;
    if (x > 4e18)
        return (long long)4e18;
    if (x < -4e18)
        return (long long)-4e18;
    return (long long)floor(x);
}

static spc_rgb texel(const spc_volume *v, int x, int y, int z)
{
    const float *p =
        v->data + (((size_t)z * (size_t)v->res[1] + (size_t)y) * (size_t)v->res[0] + (size_t)x) * (size_t)v->channels;
    return v->channels == 1 ? spc_rgb1(p[0]) : spc_rgb3(p[0], p[1], p[2]);
}

spc_rgb spc_volume_eval(const spc_volume *v, spc_vec3 p)
{
    if (!v->grid)
        return v->value;
    spc_vec3 q = spc_mat4_apply_point(&v->to_local, p);
    double c[3] = {q.x, q.y, q.z};
    if (v->nearest) {
        int i[3];
        for (int k = 0; k < 3; ++k)
            i[k] = wrap_index(floor_index(c[k] * v->res[k]), v->res[k], v->wrap);
        return texel(v, i[0], i[1], i[2]);
    }
    int i0[3], i1[3];
    double f[3];
    for (int k = 0; k < 3; ++k) {
        double s = c[k] * v->res[k] - 0.5;
        long long b = floor_index(s);
        f[k] = s - (double)b;
        if (!(f[k] >= 0.0 && f[k] <= 1.0))
            f[k] = 0.0;
        i0[k] = wrap_index(b, v->res[k], v->wrap);
        i1[k] = wrap_index(b + 1, v->res[k], v->wrap);
    }
    spc_rgb r = spc_rgb1(0.0);
    for (int corner = 0; corner < 8; ++corner) {
        int x = corner & 1 ? i1[0] : i0[0], y = corner & 2 ? i1[1] : i0[1], z = corner & 4 ? i1[2] : i0[2];
        double w =
            (corner & 1 ? f[0] : 1.0 - f[0]) * (corner & 2 ? f[1] : 1.0 - f[1]) * (corner & 4 ? f[2] : 1.0 - f[2]);
        if (w != 0.0)
            r = spc_rgb_add(r, spc_rgb_scale(texel(v, x, y, z), w));
    }
    return r;
}

/* Transforms and the world bounds of the unit cube. */
static bool set_transform(spc_volume *v, const spc_mat4 *to_world)
{
    v->to_world = to_world ? *to_world : spc_mat4_identity();
    if (!spc_mat4_inverse(&v->to_world, &v->to_local))
        return false;
    v->lo = spc_v3(INFINITY, INFINITY, INFINITY);
    v->hi = spc_v3(-INFINITY, -INFINITY, -INFINITY);
    for (int corner = 0; corner < 8; ++corner) {
        spc_vec3 p = spc_mat4_apply_point(&v->to_world, spc_v3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1));
        v->lo = spc_v3(fmin(v->lo.x, p.x), fmin(v->lo.y, p.y), fmin(v->lo.z, p.z));
        v->hi = spc_v3(fmax(v->hi.x, p.x), fmax(v->hi.y, p.y), fmax(v->hi.z, p.z));
    }
    return true;
}

bool spc_volume_init_constant(spc_volume *v, spc_rgb value, const spc_mat4 *to_world)
{
    v->grid = false;
    v->value = value;
    v->res[0] = v->res[1] = v->res[2] = 1;
    v->channels = 3;
    v->data = NULL;
    v->nearest = false;
    v->wrap = SPC_VOLUME_CLAMP;
    v->max = value;
    return set_transform(v, to_world);
}

bool spc_volume_finish_grid(spc_volume *v, const spc_mat4 *to_world)
{
    v->grid = true;
    size_t n = (size_t)v->res[0] * (size_t)v->res[1] * (size_t)v->res[2];
    double m[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            double x = v->data[i * (size_t)v->channels + (size_t)(v->channels == 1 ? 0 : c)];
            m[c] = fmax(m[c], x);
        }
    v->max = spc_rgb3(m[0], m[1], m[2]);
    return set_transform(v, to_world);
}

/* ---- pieces ---- */

void spc_volume_pieces_begin(spc_volume_pieces *it, const spc_volume *v, spc_vec3 o, spc_vec3 d, double t0, double t1)
{
    it->v = v;
    it->t = t0;
    it->t1 = t1;
    it->steps = 0;
    spc_vec3 ol = v->grid ? spc_mat4_apply_point(&v->to_local, o) : o;
    spc_vec3 dl = v->grid ? spc_mat4_apply_vector(&v->to_local, d) : d;
    double oo[3] = {ol.x, ol.y, ol.z}, dd[3] = {dl.x, dl.y, dl.z};
    double off = v->nearest ? 0.0 : 0.5;
    for (int k = 0; k < 3; ++k) {
        it->next[k] = INFINITY;
        if (!v->grid || dd[k] == 0.0 || !isfinite(t0))
            continue;
        /* the grid coordinate g(t) = (o + t d) res - off crosses integers at t_n = ((n + off) / res - o) / d */
        double g = (oo[k] + t0 * dd[k]) * v->res[k] - off;
        double n = dd[k] > 0.0 ? floor(g) + 1.0 : ceil(g) - 1.0;
        it->o[k] = oo[k];
        it->d[k] = dd[k];
        it->res[k] = v->res[k];
        it->off = off;
        it->n[k] = n;
        it->dir[k] = dd[k] > 0.0 ? 1.0 : -1.0;
        it->next[k] = ((n + off) / v->res[k] - oo[k]) / dd[k];
    }
}

bool spc_volume_pieces_next(spc_volume_pieces *it, double *a, double *b)
{
    while (it->t < it->t1 && it->steps <= SPC_VOLUME_MAX_PIECES) {
        double tn = fmin(it->t1, fmin(it->next[0], fmin(it->next[1], it->next[2])));
        for (int k = 0; k < 3; ++k) {
            /* advance every axis whose crossing this piece reaches (several may coincide) */
            while (it->next[k] <= tn) {
                it->n[k] += it->dir[k];
                double t = ((it->n[k] + it->off) / it->res[k] - it->o[k]) / it->d[k];
                it->next[k] = t > it->next[k] ? t : nextafter(it->next[k], INFINITY);
            }
        }
        ++it->steps;
        if (tn > it->t) {
            *a = it->t;
            *b = tn;
            it->t = tn;
            return true;
        }
    }
    return false;
}
