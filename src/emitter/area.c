/*
 * emitter/area.c: area light on any shape, one-sided (emits on the side of the shape's normal).
 * Spheres seen from outside are sampled by the cone of directions they subtend; every other shape
 * by uniform area, converted to solid angle (pdf_area * dist^2 / |cos_light|).
 * XML: <emitter type="area"> radiance (rgb or texture, default 1), nested in a <shape>.
 */
#include "emitter/variants.h"

#include "scene/shape.h"

bool spc_area_prepare(spc_emitter *e)
{
    if (!e->shape || !e->radiance)
        return false;
    e->power = SPC_PI * e->shape->area * spc_rgb_avg(spc_texture_mean(e->radiance));
    return e->power > 0.0;
}

spc_rgb spc_area_eval(const spc_emitter *e, spc_vec2 uv, spc_vec3 n, spc_vec3 w)
{
    if (spc_dot(n, w) <= 0.0)
        return spc_rgb1(0.0);
    return spc_texture_eval(e->radiance, uv);
}

bool spc_area_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_vec2 u, spc_emitter_direct *out)
{
    const spc_shape *s = e->shape;
    spc_shape_sample ss;
    double pdf;
    if (spc_shape_sample_solid_angle(s, ref, u, &ss)) {
        pdf = ss.pdf;
    } else {
        spc_shape_sample_area(s, u, &ss);
        spc_vec3 d = spc_sub(ss.p, ref);
        double dist2 = spc_length2(d);
        double cosl = fabs(spc_dot(ss.n, d)) / sqrt(dist2);
        if (!(cosl > 0.0) || !(dist2 > 0.0))
            return false;
        pdf = ss.pdf * dist2 / cosl;
    }
    spc_vec3 d = spc_sub(ss.p, ref);
    double dist = spc_length(d);
    if (!(dist > 0.0) || !(pdf > 0.0) || !isfinite(pdf))
        return false;
    out->p = ss.p;
    out->n = ss.n;
    out->wi = spc_scale(d, 1.0 / dist);
    out->dist = dist;
    out->L = spc_area_eval(e, ss.uv, ss.n, spc_neg(out->wi));
    out->pdf = pdf;
    out->err = ss.err;
    return !spc_rgb_is_black(out->L);
}

double spc_area_pdf_direct(const spc_emitter *e, spc_vec3 ref, spc_vec3 p, spc_vec3 n)
{
    const spc_shape *s = e->shape;
    if (spc_shape_has_solid_angle_sampling(s, ref))
        return spc_shape_pdf_solid_angle(s, ref, p);
    spc_vec3 d = spc_sub(p, ref);
    double dist2 = spc_length2(d);
    double cosl = fabs(spc_dot(n, d)) / sqrt(dist2);
    if (!(cosl > 0.0))
        return 0.0;
    return dist2 / (cosl * s->area);
}

bool spc_area_sample_emission(const spc_emitter *e, spc_vec2 u_pos, spc_vec2 u_dir, spc_emitter_emission *out)
{
    spc_shape_sample ss;
    spc_shape_sample_area(e->shape, u_pos, &ss);
    spc_vec3 l = spc_warp_cosine_hemisphere(u_dir);
    if (!(l.z > 0.0))
        return false;
    spc_frame fr = spc_frame_from_n(ss.n);
    out->p = ss.p;
    out->n = ss.n;
    out->d = spc_frame_to_world(&fr, l);
    out->pdf_pos = ss.pdf;
    out->pdf_dir = l.z * SPC_INV_PI;
    out->err = ss.err;
    spc_rgb Le = spc_texture_eval(e->radiance, ss.uv);
    out->weight = spc_rgb_scale(Le, SPC_PI / ss.pdf); /* Le cos / (pdf_pos cos/pi) */
    return !spc_rgb_is_black(out->weight);
}

void spc_area_pdf_emission(const spc_emitter *e, spc_vec3 p, spc_vec3 n, spc_vec3 d, double *pdf_pos,
                           double *pdf_dir)
{
    (void)p;
    *pdf_pos = 1.0 / e->shape->area;
    double c = spc_dot(n, d);
    *pdf_dir = c > 0.0 ? c * SPC_INV_PI : 0.0;
}
