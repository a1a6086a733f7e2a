/*
 * core/math.c: 4x4 transform construction, products and inversion (row-major, column vectors).
 */
#include "core/math.h"

#include <string.h>

spc_mat4 spc_mat4_identity(void)
{
    spc_mat4 r;
    memset(&r, 0, sizeof r);
    for (int i = 0; i < 4; ++i)
        r.m[i][i] = 1.0;
    return r;
}

spc_mat4 spc_mat4_mul(const spc_mat4 *a, const spc_mat4 *b)
{
    spc_mat4 r;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            double s = 0.0;
            for (int k = 0; k < 4; ++k)
                s += a->m[i][k] * b->m[k][j];
            r.m[i][j] = s;
        }
    return r;
}

spc_mat4 spc_mat4_transpose(const spc_mat4 *a)
{
    spc_mat4 r;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            r.m[i][j] = a->m[j][i];
    return r;
}

/* Gauss-Jordan elimination with partial pivoting. */
bool spc_mat4_inverse(const spc_mat4 *a, spc_mat4 *out)
{
    double m[4][8];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            m[i][j] = a->m[i][j];
            m[i][j + 4] = (i == j) ? 1.0 : 0.0;
        }
    double scale = 0.0;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            scale = spc_max(scale, fabs(a->m[i][j]));
    if (!(scale > 0.0) || !isfinite(scale))
        return false;
    for (int c = 0; c < 4; ++c) {
        int piv = c;
        for (int r = c + 1; r < 4; ++r)
            if (fabs(m[r][c]) > fabs(m[piv][c]))
                piv = r;
        if (fabs(m[piv][c]) <= 1e-14 * scale)
            return false;
        if (piv != c)
            for (int j = 0; j < 8; ++j) {
                double t = m[c][j];
                m[c][j] = m[piv][j];
                m[piv][j] = t;
            }
        double inv = 1.0 / m[c][c];
        for (int j = 0; j < 8; ++j)
            m[c][j] *= inv;
        for (int r = 0; r < 4; ++r) {
            if (r == c)
                continue;
            double f = m[r][c];
            if (f != 0.0)
                for (int j = 0; j < 8; ++j)
                    m[r][j] -= f * m[c][j];
        }
    }
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            out->m[i][j] = m[i][j + 4];
    return true;
}

spc_mat4 spc_mat4_translate(spc_vec3 t)
{
    spc_mat4 r = spc_mat4_identity();
    r.m[0][3] = t.x;
    r.m[1][3] = t.y;
    r.m[2][3] = t.z;
    return r;
}

spc_mat4 spc_mat4_scale(spc_vec3 s)
{
    spc_mat4 r = spc_mat4_identity();
    r.m[0][0] = s.x;
    r.m[1][1] = s.y;
    r.m[2][2] = s.z;
    return r;
}

/* Rotation by `degrees` about `axis` (right-handed, Rodrigues). */
spc_mat4 spc_mat4_rotate(spc_vec3 axis, double degrees) { return spc_mat4_rodrigues(spc_normalize(axis), degrees); }

spc_mat4 spc_mat4_rodrigues(spc_vec3 a, double degrees)
{
    double th = degrees * SPC_PI / 180.0;
    double c = cos(th), s = sin(th), ic = 1.0 - c;
    spc_mat4 r = spc_mat4_identity();
    r.m[0][0] = a.x * a.x * ic + c;
    r.m[0][1] = a.x * a.y * ic - a.z * s;
    r.m[0][2] = a.x * a.z * ic + a.y * s;
    r.m[1][0] = a.y * a.x * ic + a.z * s;
    r.m[1][1] = a.y * a.y * ic + c;
    r.m[1][2] = a.y * a.z * ic - a.x * s;
    r.m[2][0] = a.z * a.x * ic - a.y * s;
    r.m[2][1] = a.z * a.y * ic + a.x * s;
    r.m[2][2] = a.z * a.z * ic + c;
    return r;
}

bool spc_mat4_lookat(spc_vec3 origin, spc_vec3 target, spc_vec3 up, spc_mat4 *out)
{
    spc_vec3 dir = spc_sub(target, origin);
    if (!(spc_length(dir) > 0.0))
        return false;
    dir = spc_normalize(dir);
    spc_vec3 left = spc_cross(up, dir);
    if (!(spc_length(left) > 1e-12 * spc_length(up)))
        return false;
    left = spc_normalize(left);
    spc_vec3 nup = spc_cross(dir, left);
    spc_mat4 r = spc_mat4_identity();
    spc_vec3 cols[4] = {left, nup, dir, origin};
    for (int j = 0; j < 4; ++j) {
        r.m[0][j] = cols[j].x;
        r.m[1][j] = cols[j].y;
        r.m[2][j] = cols[j].z;
    }
    *out = r;
    return true;
}

spc_vec3 spc_mat4_apply_point(const spc_mat4 *m, spc_vec3 p)
{
    double x = m->m[0][0] * p.x + m->m[0][1] * p.y + m->m[0][2] * p.z + m->m[0][3];
    double y = m->m[1][0] * p.x + m->m[1][1] * p.y + m->m[1][2] * p.z + m->m[1][3];
    double z = m->m[2][0] * p.x + m->m[2][1] * p.y + m->m[2][2] * p.z + m->m[2][3];
    double w = m->m[3][0] * p.x + m->m[3][1] * p.y + m->m[3][2] * p.z + m->m[3][3];
    if (w != 1.0 && w != 0.0) {
        x /= w;
        y /= w;
        z /= w;
    }
    return spc_v3(x, y, z);
}

spc_vec3 spc_mat4_apply_vector(const spc_mat4 *m, spc_vec3 v)
{
    return spc_v3(m->m[0][0] * v.x + m->m[0][1] * v.y + m->m[0][2] * v.z,
                  m->m[1][0] * v.x + m->m[1][1] * v.y + m->m[1][2] * v.z,
                  m->m[2][0] * v.x + m->m[2][1] * v.y + m->m[2][2] * v.z);
}

spc_vec3 spc_mat4_apply_normal(const spc_mat4 *inv, spc_vec3 n)
{
    return spc_v3(inv->m[0][0] * n.x + inv->m[1][0] * n.y + inv->m[2][0] * n.z,
                  inv->m[0][1] * n.x + inv->m[1][1] * n.y + inv->m[2][1] * n.z,
                  inv->m[0][2] * n.x + inv->m[1][2] * n.y + inv->m[2][2] * n.z);
}

double spc_mat4_det3(const spc_mat4 *a)
{
    const double(*m)[4] = a->m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}
