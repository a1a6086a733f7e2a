/*
 * emitter/spot.c: spot light (Mitsuba 3's falloff: full intensity inside beam_width, falling
 * linearly in angle to zero at cutoff_angle), optionally projecting an image: the intensity toward
 * a local direction d is multiplied by the texture at Mitsuba 3's uv,
 * (1/2 + d.x / (2 d.z tan(cutoff)), 1/2 + d.y / (2 d.z tan(cutoff))): the image spans the square
 * around the cone's base.
 * XML: <emitter type="spot"> intensity (1), cutoff_angle (20 degrees), beam_width
 * (3/4 of cutoff_angle), texture (a bitmap; none), to_world (the light looks along local +z).
 */
#include "emitter/variants.h"

/* intensity toward the world direction d_world (before the falloff) */
static spc_rgb intensity_toward(const spc_emitter *e, spc_vec3 d_world)
{
    if (!e->texture)
        return e->intensity;
    spc_vec3 l = spc_normalize(spc_mat4_apply_vector(&e->to_local, d_world));
    if (!(l.z > 0.0))
        return spc_rgb1(0.0);
    double k = 0.5 / (l.z * tan(e->cutoff_angle * SPC_PI / 180.0));
    spc_vec2 uv = {0.5 + k * l.x, 0.5 + k * l.y};
    return spc_rgb_mul(e->intensity, spc_texture_eval(e->texture, uv));
}

static double falloff(const spc_emitter *e, spc_vec3 d_world)
{
    spc_vec3 l = spc_normalize(spc_mat4_apply_vector(&e->to_local, d_world));
    double cut = e->cutoff_angle * SPC_PI / 180.0, beam = e->beam_width * SPC_PI / 180.0;
    double th = acos(spc_clamp(l.z, -1.0, 1.0));
    if (th >= cut)
        return 0.0;
    if (th <= beam)
        return 1.0;
    return (cut - th) / (cut - beam);
}

bool spc_spot_prepare(spc_emitter *e)
{
    if (!(e->cutoff_angle > 0.0))
        e->cutoff_angle = 20.0;
    if (!(e->beam_width > 0.0) || e->beam_width > e->cutoff_angle)
        e->beam_width = 0.75 * e->cutoff_angle;
    e->position = spc_mat4_apply_point(&e->to_world, spc_v3(0, 0, 0));
    if (!spc_mat4_inverse(&e->to_world, &e->to_local))
        return false;
    double mid = 0.5 * (e->cutoff_angle + e->beam_width) * SPC_PI / 180.0;
    e->power = 2.0 * SPC_PI * (1.0 - cos(mid)) * spc_rgb_avg(e->intensity);
    if (e->texture) /* a light-selection weight: the image's mean stands in for its beam */
        e->power *= spc_rgb_avg(spc_texture_mean(e->texture));
    return e->power > 0.0;
}

bool spc_spot_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out)
{
    double dist2 = spc_emitter_at_point(e, ref, out);
    if (dist2 == 0.0)
        return false;
    double f = falloff(e, spc_neg(out->wi));
    if (!(f > 0.0))
        return false;
    out->L = spc_rgb_scale(intensity_toward(e, spc_neg(out->wi)), f / dist2);
    return !spc_rgb_is_black(out->L);
}

bool spc_spot_sample_emission(const spc_emitter *e, spc_vec2 u_dir, spc_emitter_emission *out)
{
    double cos_max = cos(e->cutoff_angle * SPC_PI / 180.0);
    spc_vec3 l = spc_warp_uniform_cone(u_dir, cos_max);
    spc_vec3 d = spc_normalize(spc_mat4_apply_vector(&e->to_world, l));
    double pdf = spc_warp_uniform_cone_pdf(cos_max);
    out->p = e->position;
    out->d = d;
    out->n = d;
    out->pdf_pos = 1.0;
    out->pdf_dir = pdf;
    double f = falloff(e, d);
    out->weight = f > 0.0 ? spc_rgb_scale(intensity_toward(e, d), f / pdf) : spc_rgb1(0.0);
    out->delta_pos = true;
    out->err = 1e-9 * spc_max_abs(e->position);
    return !spc_rgb_is_black(out->weight);
}

double spc_spot_pdf_dir(const spc_emitter *e, spc_vec3 d)
{
    double cos_max = cos(e->cutoff_angle * SPC_PI / 180.0);
    spc_vec3 l = spc_normalize(spc_mat4_apply_vector(&e->to_local, d));
    return l.z >= cos_max ? spc_warp_uniform_cone_pdf(cos_max) : 0.0;
}

spc_rgb spc_spot_eval_intensity(const spc_emitter *e, spc_vec3 d)
{
    double f = falloff(e, d);
    return f > 0.0 ? spc_rgb_scale(intensity_toward(e, d), f) : spc_rgb1(0.0);
}
