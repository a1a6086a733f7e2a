/*
 * emitter/point.c: isotropic point light.
 * XML: <emitter type="point"> intensity (rgb, W/sr, default 1), position (point) or to_world
 * (its translation).
 */
#include "emitter/variants.h"

bool spc_point_prepare(spc_emitter *e)
{
    e->power = 4.0 * SPC_PI * spc_rgb_avg(e->intensity);
    return e->power > 0.0;
}

bool spc_point_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out)
{
    double dist2 = spc_emitter_at_point(e, ref, out);
    if (dist2 == 0.0)
        return false;
    out->L = spc_rgb_scale(e->intensity, 1.0 / dist2);
    return true;
}

bool spc_point_sample_emission(const spc_emitter *e, spc_vec2 u_dir, spc_emitter_emission *out)
{
    spc_vec3 d = spc_warp_uniform_sphere(u_dir);
    out->p = e->position;
    out->d = d;
    out->n = d;
    out->pdf_pos = 1.0;
    out->pdf_dir = SPC_INV_4PI;
    out->weight = spc_rgb_scale(e->intensity, 4.0 * SPC_PI);
    out->delta_pos = true;
    out->err = 1e-9 * spc_max_abs(e->position);
    return true;
}
