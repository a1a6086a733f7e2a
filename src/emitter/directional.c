/*
 * emitter/directional.c: a distant light of given irradiance arriving along one direction.
 * XML: <emitter type="directional"> irradiance (1), direction (vector the light travels along) or
 * to_world (local +z).
 */
#include "emitter/variants.h"

bool spc_directional_prepare(spc_emitter *e)
{
    e->direction = spc_normalize(e->direction);
    if (!(spc_length(e->direction) > 0.5))
        return false;
    e->power = SPC_PI * e->scene_radius * e->scene_radius * spc_rgb_avg(e->irradiance);
    return e->power > 0.0;
}

bool spc_directional_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out)
{
    out->wi = spc_neg(e->direction);
    out->dist = INFINITY;
    out->p = spc_madd(ref, out->wi, 2.0 * e->scene_radius);
    out->n = e->direction;
    out->L = e->irradiance;
    out->pdf = 1.0;
    out->is_infinite = true;
    return true;
}

bool spc_directional_sample_emission(const spc_emitter *e, spc_vec2 u_pos, spc_emitter_emission *out)
{
    spc_vec3 d = e->direction;
    spc_frame fr = spc_frame_from_n(d);
    spc_vec2 q = spc_warp_disk_concentric(u_pos);
    double R = e->scene_radius;
    out->p = spc_add(spc_madd(e->scene_center, d, -R), spc_scale(spc_add(spc_scale(fr.s, q.x), spc_scale(fr.t, q.y)), R));
    out->d = d;
    out->n = d;
    out->pdf_pos = 1.0 / (SPC_PI * R * R);
    out->pdf_dir = 1.0;
    out->weight = spc_rgb_scale(e->irradiance, SPC_PI * R * R);
    out->delta_dir = true;
    out->is_infinite = true;
    return true;
}
