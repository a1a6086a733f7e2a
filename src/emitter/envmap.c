/*
 * emitter/envmap.c: infinite lights: `constant` (uniform radiance) and `envmap` (lat-long image).
 *
 * Lat-long convention (Mitsuba 3's): for a unit direction w TOWARD the environment, in the
 * emitter's local frame (to_world^-1 w): u = atan2(w.x, -w.z) / (2 pi) wrapped to [0, 1),
 * v = acos(w.y) / pi; v = 0 is the top row of the image (local +y is up). Radiance is the bilinear
 * interpolation of the texels times `scale`, placed as Mitsuba 3's envmap places them (checked
 * against its eval to 1e-6): texel column i is centered at u = (i + 1/2) / width (wrapping), but
 * row j at v = j / (height - 1), so the first and last rows sit on the poles; a lookup is at
 * x = u width - 1/2, y = v (height - 1). Directions are sampled from a piecewise-constant
 * distribution over texel cells [i, i+1]/width x [j, j+1]/height whose weight is the largest
 * luminance among texel (i, j) and its 8 neighbours (the bilinear lookup anywhere in the cell reads
 * only texels among those, so every direction with radiance has density)
 * times sin(theta); the solid-angle density is pdf_uv / (2 pi^2 sin theta).
 *
 * XML: <emitter type="constant"> radiance (1); <emitter type="envmap"> filename, scale (1),
 * to_world.
 */
#include "emitter/variants.h"

#include <stdlib.h>

static spc_rgb texel(const spc_texture *t, int x, int y)
{
    /* u wraps, v clamps */
    x %= t->width;
    if (x < 0)
        x += t->width;
    if (y < 0)
        y = 0;
    if (y >= t->height)
        y = t->height - 1;
    const float *p = t->data + 3 * ((size_t)y * (size_t)t->width + (size_t)x);
    return spc_rgb3(p[0], p[1], p[2]);
}

static spc_rgb lookup(const spc_texture *t, double u, double v)
{
    double x = u * t->width - 0.5, y = v * (t->height > 1 ? t->height - 1 : 1);
    double fx = floor(x), fy = floor(y);
    int x0 = (int)fx, y0 = (int)fy;
    double ax = x - fx, ay = y - fy;
    spc_rgb a = spc_rgb_add(spc_rgb_scale(texel(t, x0, y0), 1 - ax), spc_rgb_scale(texel(t, x0 + 1, y0), ax));
    spc_rgb b = spc_rgb_add(spc_rgb_scale(texel(t, x0, y0 + 1), 1 - ax), spc_rgb_scale(texel(t, x0 + 1, y0 + 1), ax));
    return spc_rgb_add(spc_rgb_scale(a, 1 - ay), spc_rgb_scale(b, ay));
}

static spc_vec2 dir_to_uv(const spc_emitter *e, spc_vec3 w, double *sin_theta)
{
    spc_vec3 l = spc_normalize(spc_mat4_apply_vector(&e->to_local, w));
    double u = atan2(l.x, -l.z) * SPC_INV_2PI;
    if (u < 0.0)
        u += 1.0;
    if (u >= 1.0)
        u -= 1.0;
    double ct = spc_clamp(l.y, -1.0, 1.0);
    *sin_theta = sqrt(spc_max(0.0, 1.0 - ct * ct));
    return spc_v2(u, acos(ct) * SPC_INV_PI);
}

static spc_vec3 uv_to_dir(const spc_emitter *e, spc_vec2 uv, double *sin_theta)
{
    double phi = uv.x * 2.0 * SPC_PI, theta = uv.y * SPC_PI;
    double st = sin(theta);
    *sin_theta = st;
    spc_vec3 l = spc_v3(st * sin(phi), cos(theta), -st * cos(phi));
    return spc_normalize(spc_mat4_apply_vector(&e->to_world, l));
}

static bool is_image(const spc_emitter *e)
{
    return e->type == SPC_EMITTER_ENVMAP && e->radiance && e->radiance->type == SPC_TEX_BITMAP && e->radiance->data;
}

bool spc_envmap_prepare(spc_emitter *e)
{
    double R = e->scene_radius;
    if (!spc_mat4_inverse(&e->to_world, &e->to_local))
        return false;
    if (!is_image(e)) {
        if (!e->radiance)
            return false;
        e->power = 4.0 * SPC_PI * SPC_PI * R * R * e->scale * spc_rgb_avg(spc_texture_mean(e->radiance));
        return e->power > 0.0;
    }
    const spc_texture *t = e->radiance;
    int w = t->width, h = t->height;
    double *wt = malloc((size_t)w * (size_t)h * sizeof(double));
    if (!wt)
        return false;
    double total = 0.0;
    for (int y = 0; y < h; ++y) {
        double st = sin(SPC_PI * (y + 0.5) / h);
        for (int x = 0; x < w; ++x) {
            double m = 0.0;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    spc_rgb c = texel(t, x + dx, y + dy);
                    m = spc_max(m, spc_max(spc_rgb_avg(c), 0.0));
                }
            wt[(size_t)y * w + x] = m * st;
            total += spc_rgb_avg(texel(t, x, y)) * st;
        }
    }
    e->has_tex_distrib = spc_distrib2d_init(&e->tex_distrib, wt, (size_t)w, (size_t)h);
    free(wt);
    /* flux ~ pi R^2 * integral of L over the sphere */
    e->power = SPC_PI * R * R * e->scale * total * (2.0 * SPC_PI * SPC_PI) / ((double)w * h);
    return e->has_tex_distrib && e->power > 0.0;
}

void spc_envmap_release(spc_emitter *e)
{
    if (e->has_tex_distrib)
        spc_distrib2d_release(&e->tex_distrib);
    e->has_tex_distrib = false;
}

spc_rgb spc_envmap_eval(const spc_emitter *e, spc_vec3 w)
{
    /* a constant radiance (the constant emitter) needs no uv: the two inverse trigonometric calls
     * of dir_to_uv were 2.5% of a glass ball's render under a constant sky (perf) */
    if (spc_texture_is_constant(e->radiance))
        return spc_rgb_scale(e->radiance->value, e->scale);
    double st;
    spc_vec2 uv = dir_to_uv(e, w, &st);
    if (!is_image(e))
        return spc_rgb_scale(spc_texture_eval(e->radiance, uv), e->scale);
    return spc_rgb_scale(lookup(e->radiance, uv.x, uv.y), e->scale);
}

double spc_envmap_pdf_dir(const spc_emitter *e, spc_vec3 w)
{
    if (!is_image(e))
        return SPC_INV_4PI;
    if (!e->has_tex_distrib)
        return 0.0;
    double st;
    spc_vec2 uv = dir_to_uv(e, w, &st);
    if (!(st > 0.0))
        return 0.0;
    return spc_distrib2d_pdf(&e->tex_distrib, uv) / (2.0 * SPC_PI * SPC_PI * st);
}

bool spc_envmap_sample_dir(const spc_emitter *e, spc_vec2 u, spc_vec3 *w, double *pdf)
{
    if (!is_image(e)) {
        *w = spc_warp_uniform_sphere(u);
        *pdf = SPC_INV_4PI;
        return true;
    }
    if (!e->has_tex_distrib)
        return false;
    double pdf_uv, st;
    spc_vec2 uv = spc_distrib2d_sample(&e->tex_distrib, u, &pdf_uv);
    *w = uv_to_dir(e, uv, &st);
    if (!(st > 0.0) || !(pdf_uv > 0.0))
        return false;
    *pdf = pdf_uv / (2.0 * SPC_PI * SPC_PI * st);
    return true;
}
