/*
 * emitter/projector.c: a projector (Mitsuba 3's src/emitters/projector.cpp): a point light at the
 * origin of to_world that throws an image along local +z, the reciprocal of a perspective camera.
 *
 * The image spans the rectangle [-tan_x, tan_x] x [-tan_y, tan_y] of the plane z = 1 (tan_x from
 * the fov and fov_axis, tan_y = tan_x / aspect, the aspect being the image's width over height; a
 * constant irradiance is a 1x1 image); the local direction (x, y, z) meets it at uv
 *   u = 1/2 - x / (2 z tan_x),  v = 1/2 - y / (2 z tan_y),
 * so uv (0, 0) is the top-left corner as a camera at the same place would see it. The intensity
 * toward a local unit direction d with d.z = cos(theta) > 0 whose uv lies in [0, 1]^2 is
 *   I(d) = pi scale E(uv) / cos^3(theta),
 * E the irradiance texture: E is the irradiance on the plane z = 1 (times pi, as Mitsuba defines
 * it), so a constant image lights a plane facing the projector evenly. A point p at local
 * coordinates p_l receives I / |p_l|^2 = pi scale E / (z_l^2 cos(theta)), Mitsuba's
 * sample_direction. Its flux is pi scale A mean(E), A = 4 tan_x tan_y.
 *
 * Emission sampling (bdpt, ptracer): uv from a piecewise-constant distribution over texel cells
 * weighted by the largest texel mean among each texel and its 8 neighbours (a bilinear lookup in
 * the cell reads no others, so every lit uv has density; uniform for a constant image or a bitmap
 * with a to_uv map); the solid-angle density of the direction is pdf_uv / (A cos^3 theta) and the
 * weight I / pdf = pi scale E A / pdf_uv (Mitsuba's sample_ray).
 *
 * XML: <emitter type="projector"> irradiance (texture or rgb, 1), scale (1), fov (degrees) and
 * fov_axis ("x"), or focal_length ("50mm"), to_world.
 */
#include <stdlib.h>

#include "emitter/variants.h"

static bool has_image_distrib(const spc_emitter *e) { return e->has_tex_distrib; }

/* uv of the local direction l, false outside the image or behind the projector */
static bool local_uv(const spc_emitter *e, spc_vec3 l, spc_vec2 *uv)
{
    if (!(l.z > 0.0))
        return false;
    uv->x = 0.5 - l.x / (2.0 * l.z * e->tan_x);
    uv->y = 0.5 - l.y / (2.0 * l.z * e->tan_y);
    return uv->x >= 0.0 && uv->x <= 1.0 && uv->y >= 0.0 && uv->y <= 1.0;
}

static spc_rgb irradiance(const spc_emitter *e, spc_vec2 uv)
{
    return spc_rgb_scale(spc_texture_eval(e->texture, uv), e->scale);
}

bool spc_projector_prepare(spc_emitter *e)
{
    if (!e->texture || !(e->tan_x > 0.0) || !(e->tan_y > 0.0))
        return false;
    if (!spc_mat4_inverse(&e->to_world, &e->to_local))
        return false;
    e->position = spc_mat4_apply_point(&e->to_world, spc_v3(0, 0, 0));
    double area = 4.0 * e->tan_x * e->tan_y;
    e->power = SPC_PI * e->scale * area * spc_rgb_avg(spc_texture_mean(e->texture));
    const spc_texture *t = e->texture;
    const double(*m)[3] = t->to_uv;
    bool identity =
        m[0][0] == 1.0 && m[0][1] == 0.0 && m[0][2] == 0.0 && m[1][0] == 0.0 && m[1][1] == 1.0 && m[1][2] == 0.0;
    if (t->type == SPC_TEX_BITMAP && t->data && t->width > 0 && t->height > 0 && identity) {
        int w = t->width, h = t->height;
        double *wt = malloc((size_t)w * (size_t)h * sizeof(double));
        if (!wt)
            return false;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                double mx = 0.0;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx)
                        mx = spc_max(mx, spc_rgb_avg(spc_texture_texel(t, x + dx, y + dy)));
                wt[(size_t)y * (size_t)w + (size_t)x] = mx;
            }
        e->has_tex_distrib = spc_distrib2d_init(&e->tex_distrib, wt, (size_t)w, (size_t)h);
        free(wt);
        if (!e->has_tex_distrib)
            return false;
    }
    return e->power > 0.0;
}

bool spc_projector_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out)
{
    spc_vec3 l = spc_mat4_apply_point(&e->to_local, ref);
    spc_vec2 uv;
    if (!local_uv(e, l, &uv) || spc_emitter_at_point(e, ref, out) == 0.0)
        return false;
    double cos_l = l.z / spc_length(l);
    out->L = spc_rgb_scale(irradiance(e, uv), SPC_PI / (l.z * l.z * cos_l));
    return !spc_rgb_is_black(out->L);
}

/* density in uv of the emission sampling */
static double pdf_uv(const spc_emitter *e, spc_vec2 uv)
{
    return has_image_distrib(e) ? spc_distrib2d_pdf(&e->tex_distrib, uv) : 1.0;
}

bool spc_projector_sample_emission(const spc_emitter *e, spc_vec2 u_dir, spc_emitter_emission *out)
{
    double p_uv = 1.0;
    spc_vec2 uv = has_image_distrib(e) ? spc_distrib2d_sample(&e->tex_distrib, u_dir, &p_uv) : u_dir;
    if (!(p_uv > 0.0))
        return false;
    spc_vec3 l = spc_v3((1.0 - 2.0 * uv.x) * e->tan_x, (1.0 - 2.0 * uv.y) * e->tan_y, 1.0);
    double cos_l = 1.0 / spc_length(l);
    double area = 4.0 * e->tan_x * e->tan_y;
    out->p = e->position;
    out->d = spc_normalize(spc_mat4_apply_vector(&e->to_world, l));
    out->n = out->d;
    out->pdf_pos = 1.0;
    out->pdf_dir = p_uv / (area * cos_l * cos_l * cos_l);
    out->weight = spc_rgb_scale(irradiance(e, uv), SPC_PI * area / p_uv);
    out->delta_pos = true;
    out->err = 1e-9 * spc_max_abs(e->position);
    return !spc_rgb_is_black(out->weight);
}

double spc_projector_pdf_dir(const spc_emitter *e, spc_vec3 d)
{
    spc_vec3 l = spc_normalize(spc_mat4_apply_vector(&e->to_local, d));
    spc_vec2 uv;
    if (!local_uv(e, l, &uv))
        return 0.0;
    double area = 4.0 * e->tan_x * e->tan_y;
    return pdf_uv(e, uv) / (area * l.z * l.z * l.z);
}
