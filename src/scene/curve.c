/*
 * scene/curve.c: the curve shapes' files and surface interaction (scene/curve.h). The geometry is
 * Embree's (round linear and round B-spline curves, as Mitsuba 3 uses), so a hit carries the
 * segment and its curve parameter s; the normal follows from them as Mitsuba 3 computes it:
 *   linear:   n = normalize(p - c(s)), c the centre line (Embree's s is already the foot point of
 *             the cone's normal through p, and clamps to the joint's sphere at the ends);
 *   B-spline: n = normalize((|c'|^2 - (p - c).c'') (p - c) - r r' c'), the normal of the swept
 *             tube at the point whose cross-section contains p.
 * The frame around the axis a = c'/|c'| is Mitsuba's: v_rot = the component of +z across a
 * (+y where a is +-z), v_rad = v_rot x a; the angle is atan2(v_rot.n, v_rad.n).
 */
#include "scene/curve.h"

#include <errno.h>
#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Ray offset for curve hits, relative to the magnitude of the point and the radius: Embree finds
 * curve hits in float by iteration, a few ulps less exactly than its watertight triangles (their
 * offset is 8 ulps, scene/shape.c), and the hit's p is the float t along the double ray. */
#define SPC_CURVE_OFFSET (64.0 * FLT_EPSILON)

static spc_status parse_fail(spc_error *err, spc_status code, const char *file, int line, const char *fmt,
                             const char *detail)
{
    spc_error_set(err, code, file, line, 0, fmt, detail);
    return code;
}

void spc_curve_release(spc_curve *c)
{
    if (!c)
        return;
    free(c->cp);
    free(c->seg);
    memset(c, 0, sizeof *c);
}

spc_status spc_curve_parse(const char *text, size_t len, const char *file, spc_curve_basis basis,
                           const spc_mat4 *to_world, spc_curve *c, spc_error *err)
{
    memset(c, 0, sizeof *c);
    c->basis = basis;
    const uint32_t min_points = basis == SPC_CURVE_LINEAR ? 2u : 4u;
    const char *what = basis == SPC_CURVE_LINEAR ? "a linear curve" : "a B-spline curve";
    spc_mat4 M = to_world ? *to_world : spc_mat4_identity();
    size_t cap = 0, segcap = 0;
    uint32_t first = 0; /* first point of the curve being read */
    int first_line = 0;
    bool in_curve = false;
    int line = 0;
    size_t pos = 0;
    spc_status st = SPC_OK;
    while (pos <= len && st == SPC_OK) {
        size_t end = pos;
        while (end < len && text[end] != '\n')
            ++end;
        ++line;
        char buf[1024];
        size_t n = end - pos;
        if (n >= sizeof buf) {
            st = parse_fail(err, SPC_ERR_PARSE, file, line, "%s", "line too long (over 1023 characters)");
            break;
        }
        memcpy(buf, text + pos, n);
        buf[n] = '\0';
        if (memchr(buf, '\0', n)) {
            st = parse_fail(err, SPC_ERR_PARSE, file, line, "%s", "a NUL byte in a curve file");
            break;
        }
        const char *cur = buf;
        while (*cur == ' ' || *cur == '\t' || *cur == '\r')
            ++cur;
        bool blank = *cur == '\0';
        bool last = end >= len;
        if (!blank) {
            double v[4];
            char *next = (char *)cur;
            for (int k = 0; k < 4 && st == SPC_OK; ++k) {
                const char *orig = next;
                errno = 0;
                v[k] = strtod(orig, &next);
                if (next == orig)
                    st = parse_fail(err, SPC_ERR_PARSE, file, line,
                                    "expected four numbers 'x y z radius', got '%s'", buf);
            }
            if (st != SPC_OK)
                break;
            while (*next == ' ' || *next == '\t' || *next == '\r')
                ++next;
            if (*next != '\0') {
                st = parse_fail(err, SPC_ERR_PARSE, file, line, "expected four numbers 'x y z radius', got '%s'",
                                buf);
                break;
            }
            spc_vec3 p = spc_mat4_apply_point(&M, spc_v3(v[0], v[1], v[2]));
            if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2]) || !spc_v3_finite(p) ||
                fabs(p.x) > FLT_MAX || fabs(p.y) > FLT_MAX || fabs(p.z) > FLT_MAX) {
                st = parse_fail(err, SPC_ERR_VALUE, file, line, "control point position is not finite: '%s'", buf);
                break;
            }
            if (!(v[3] >= 0.0) || !(v[3] <= FLT_MAX)) {
                st = parse_fail(err, SPC_ERR_VALUE, file, line,
                                "control point radius must be finite and not negative: '%s'", buf);
                break;
            }
            if (c->ncp >= (1u << 31)) {
                st = parse_fail(err, SPC_ERR_LIMIT, file, line, "%s", "more than 2^31 control points");
                break;
            }
            if (c->ncp == cap) {
                size_t nc = cap ? 2 * cap : 64;
                float *q = realloc(c->cp, 4 * nc * sizeof(float));
                if (!q) {
                    st = parse_fail(err, SPC_ERR_NOMEM, file, line, "%s", "out of memory");
                    break;
                }
                c->cp = q;
                cap = nc;
            }
            if (!in_curve) {
                in_curve = true;
                first = c->ncp;
                first_line = line;
            }
            float *q = c->cp + 4 * (size_t)c->ncp++;
            q[0] = (float)p.x;
            q[1] = (float)p.y;
            q[2] = (float)p.z;
            q[3] = (float)v[3];
        }
        if ((blank || last) && in_curve) {
            /* the curve ends: its segments start at first .. ncp - min_points */
            uint32_t npts = c->ncp - first;
            if (npts < min_points) {
                spc_error_set(err, SPC_ERR_PARSE, file, first_line, 0,
                              "%s needs at least %u control points, this one (lines %d-%d) has %u", what,
                              min_points, first_line, blank ? line - 1 : line, npts);
                st = SPC_ERR_PARSE;
                break;
            }
            uint32_t add = npts - min_points + 1;
            if (c->nseg + (size_t)add > segcap) {
                size_t nc = segcap ? 2 * segcap : 64;
                while (nc < c->nseg + (size_t)add)
                    nc *= 2;
                uint32_t *q = realloc(c->seg, nc * sizeof(uint32_t));
                if (!q) {
                    st = parse_fail(err, SPC_ERR_NOMEM, file, line, "%s", "out of memory");
                    break;
                }
                c->seg = q;
                segcap = nc;
            }
            for (uint32_t j = 0; j < add; ++j)
                c->seg[c->nseg++] = first + j;
            in_curve = false;
        }
        pos = end + 1;
    }
    if (st == SPC_OK && c->nseg == 0)
        st = parse_fail(err, SPC_ERR_PARSE, file, line, "%s", "no control points in the curve file");
    if (st == SPC_OK) {
        /* room for Embree's 16-byte loads past the last element of a shared buffer */
        float *q = realloc(c->cp, (4 * (size_t)c->ncp + 4) * sizeof(float));
        uint32_t *g = q ? realloc(c->seg, ((size_t)c->nseg + 4) * sizeof(uint32_t)) : NULL;
        if (q)
            c->cp = q;
        if (g)
            c->seg = g;
        if (!q || !g)
            st = parse_fail(err, SPC_ERR_NOMEM, file, line, "%s", "out of memory");
        else {
            memset(c->cp + 4 * (size_t)c->ncp, 0, 4 * sizeof(float));
            memset(c->seg + c->nseg, 0, 4 * sizeof(uint32_t));
        }
    }
    if (st != SPC_OK)
        spc_curve_release(c);
    return st;
}

spc_status spc_curve_read(const char *path, spc_curve_basis basis, const spc_mat4 *to_world, spc_curve *c,
                          spc_error *err)
{
    memset(c, 0, sizeof *c);
    FILE *f = fopen(path, "rb");
    if (!f)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open curve file: %s", strerror(errno));
    size_t cap = 1 << 16, len = 0;
    char *text = malloc(cap);
    spc_status st = SPC_OK;
    while (text) {
        size_t got = fread(text + len, 1, cap - len, f);
        len += got;
        if (len < cap)
            break;
        char *q = cap > ((size_t)1 << 40) ? NULL : realloc(text, 2 * cap);
        if (!q) {
            free(text);
            text = NULL;
            break;
        }
        text = q;
        cap *= 2;
    }
    if (!text)
        st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading the curve file");
    else if (ferror(f))
        st = spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot read curve file");
    fclose(f);
    if (st == SPC_OK)
        st = spc_curve_parse(text, len, path, basis, to_world, c, err);
    free(text);
    return st;
}

static spc_vec3 cp_p(const spc_curve *c, uint32_t i)
{
    const float *q = c->cp + 4 * (size_t)i;
    return spc_v3(q[0], q[1], q[2]);
}

static double cp_r(const spc_curve *c, uint32_t i) { return c->cp[4 * (size_t)i + 3]; }

void spc_curve_bounds(const spc_curve *c, spc_vec3 *lo, spc_vec3 *hi)
{
    *lo = spc_v3(INFINITY, INFINITY, INFINITY);
    *hi = spc_neg(*lo);
    for (uint32_t i = 0; i < c->ncp; ++i) {
        double r = cp_r(c, i);
        spc_vec3 p = cp_p(c, i), d = spc_v3(r, r, r);
        *lo = spc_vmin(*lo, spc_sub(p, d));
        *hi = spc_vmax(*hi, spc_add(p, d));
    }
}

/* Uniform cubic B-spline of segment i at s: centre, its first and second derivatives, radius and
 * its derivative. */
static void bspline_eval(const spc_curve *c, uint32_t i, double s, spc_vec3 *p, spc_vec3 *dp, spc_vec3 *ddp,
                         double *r, double *dr)
{
    double s2 = s * s, s3 = s2 * s;
    double b[4] = {(1.0 - 3.0 * s + 3.0 * s2 - s3) / 6.0, (4.0 - 6.0 * s2 + 3.0 * s3) / 6.0,
                   (1.0 + 3.0 * s + 3.0 * s2 - 3.0 * s3) / 6.0, s3 / 6.0};
    double db[4] = {(-3.0 + 6.0 * s - 3.0 * s2) / 6.0, (-12.0 * s + 9.0 * s2) / 6.0,
                    (3.0 + 6.0 * s - 9.0 * s2) / 6.0, 3.0 * s2 / 6.0};
    double ddb[4] = {1.0 - s, 3.0 * s - 2.0, 1.0 - 3.0 * s, s};
    *p = *dp = *ddp = spc_v3(0, 0, 0);
    *r = *dr = 0.0;
    for (int k = 0; k < 4; ++k) {
        spc_vec3 q = cp_p(c, i + (uint32_t)k);
        double rk = cp_r(c, i + (uint32_t)k);
        *p = spc_madd(*p, q, b[k]);
        *dp = spc_madd(*dp, q, db[k]);
        *ddp = spc_madd(*ddp, q, ddb[k]);
        *r += b[k] * rk;
        *dr += db[k] * rk;
    }
}

double spc_curve_area(const spc_curve *c)
{
    double A = 0.0;
    for (uint32_t k = 0; k < c->nseg; ++k) {
        uint32_t i = c->seg[k];
        if (c->basis == SPC_CURVE_LINEAR) {
            double r0 = cp_r(c, i), r1 = cp_r(c, i + 1), l = spc_distance(cp_p(c, i), cp_p(c, i + 1));
            A += SPC_PI * (r0 + r1) * sqrt(l * l + (r1 - r0) * (r1 - r0));
        } else {
            for (int j = 0; j < 64; ++j) {
                spc_vec3 p, dp, ddp;
                double r, dr;
                bspline_eval(c, i, (j + 0.5) / 64.0, &p, &dp, &ddp, &r, &dr);
                A += 2.0 * SPC_PI * r * spc_length(dp) / 64.0;
            }
        }
    }
    return A;
}

/* Mitsuba 3's frame around the unit axis a: v_rot from +z, v_rad = v_rot x a. */
static void axis_frame(spc_vec3 a, spc_vec3 *v_rot, spc_vec3 *v_rad)
{
    spc_vec3 g = spc_v3(0, 0, 1);
    spc_vec3 w = spc_sub(g, spc_scale(a, spc_dot(a, g)));
    double l = spc_length(w);
    *v_rot = l > 1e-12 ? spc_scale(w, 1.0 / l) : spc_v3(0, 1, 0);
    *v_rad = spc_cross(*v_rot, a);
}

static double angle01(spc_vec3 v_rot, spc_vec3 v_rad, spc_vec3 n)
{
    double phi = atan2(spc_dot(v_rot, n), spc_dot(v_rad, n));
    if (phi < 0.0)
        phi += 2.0 * SPC_PI;
    return phi * SPC_INV_2PI;
}

void spc_curve_fill_hit(const spc_curve *c, int prim, double s, const spc_ray *r, double t, bool flip, spc_hit *h)
{
    uint32_t k = (uint32_t)prim < c->nseg ? (uint32_t)prim : 0;
    uint32_t i = c->seg[k];
    s = spc_clamp(s, 0.0, 1.0);
    spc_vec3 p = spc_madd(r->o, r->d, t);
    spc_vec3 n, axis, dpdu, dpdv, dndu;
    double radius;
    if (c->basis == SPC_CURVE_LINEAR) {
        spc_vec3 p0 = cp_p(c, i), p1 = cp_p(c, i + 1);
        double r0 = cp_r(c, i), r1 = cp_r(c, i + 1);
        spc_vec3 d = spc_sub(p1, p0);
        double dl = spc_length(d);
        axis = dl > 0.0 ? spc_scale(d, 1.0 / dl) : spc_v3(0, 0, 1);
        spc_vec3 cc = spc_madd(p0, d, s);
        spc_vec3 rv = spc_sub(p, cc);
        double rl = spc_length(rv);
        radius = (1.0 - s) * r0 + s * r1;
        spc_vec3 v_rot, v_rad;
        axis_frame(axis, &v_rot, &v_rad);
        n = rl > 0.0 ? spc_scale(rv, 1.0 / rl) : v_rad;
        h->b1 = angle01(v_rot, v_rad, n);
        h->b2 = (s + (double)k) / (double)c->nseg;
        h->uv = spc_v2(h->b1, h->b2);
        dpdu = spc_scale(spc_cross(axis, rv), 2.0 * SPC_PI);
        dpdv = spc_scale(spc_madd(d, n, r1 - r0), (double)c->nseg);
        dndu = spc_scale(spc_cross(axis, n), 2.0 * SPC_PI);
        h->dpdu = dpdu;
        h->dpdv = dpdv;
        h->dndu = dndu;
        h->dndv = spc_v3(0, 0, 0);
    } else {
        spc_vec3 cc, dc, ddc;
        double dr;
        bspline_eval(c, i, s, &cc, &dc, &ddc, &radius, &dr);
        double dl = spc_length(dc);
        axis = dl > 0.0 ? spc_scale(dc, 1.0 / dl) : spc_v3(0, 0, 1);
        spc_vec3 rv = spc_sub(p, cc);
        double rl = spc_length(rv);
        spc_vec3 v_rot, v_rad;
        axis_frame(axis, &v_rot, &v_rad);
        spc_vec3 rn = rl > 0.0 ? spc_scale(rv, 1.0 / rl) : v_rad;
        spc_vec3 m = spc_sub(spc_scale(rv, dl * dl - spc_dot(rv, ddc)), spc_scale(dc, radius * dr));
        double ml = spc_length(m);
        n = ml > 0.0 ? spc_scale(m, 1.0 / ml) : rn;
        double ncp = (double)c->ncp;
        double ug = (s + (double)k + 1.5) / ncp;
        h->b1 = (ug - 1.5 / ncp) / (1.0 - 3.0 / ncp);
        h->b2 = angle01(v_rot, v_rad, rn);
        h->uv = spc_v2(h->b1, h->b2);
        dpdu = spc_scale(spc_madd(dc, rn, dr), 1.0 / (1.0 - 3.0 / ncp));
        dpdv = spc_scale(spc_cross(rn, axis), 2.0 * SPC_PI * radius);
        h->dpdu = dpdu;
        h->dpdv = dpdv;
        h->dndu = spc_v3(0, 0, 0);
        h->dndv = spc_scale(spc_cross(rn, axis), 2.0 * SPC_PI);
    }
    if (flip) {
        n = spc_neg(n);
        h->dndu = spc_neg(h->dndu);
        h->dndv = spc_neg(h->dndv);
    }
    h->p = p;
    h->ng = n;
    /* tangent: dpdu (around the tube for linear curves, along it for B-splines, as Mitsuba's) */
    h->sh = spc_frame_from_ns(n, h->dpdu);
    h->err = SPC_CURVE_OFFSET * (spc_max_abs(p) + radius);
}
