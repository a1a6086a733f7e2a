/*
 * emitter/emitter.c: dispatch over emitter variants, and the parts every infinite light shares
 * (emission from a disk of the scene's bounding-sphere radius).
 */
#include "emitter/emitter.h"

#include "emitter/variants.h"

bool spc_emitter_is_delta(const spc_emitter *e)
{
    switch (e->type) {
    case SPC_EMITTER_POINT:
    case SPC_EMITTER_SPOT:
    case SPC_EMITTER_PROJECTOR:
    case SPC_EMITTER_DIRECTIONAL: return true;
    case SPC_EMITTER_AREA:
    case SPC_EMITTER_CONSTANT:
    case SPC_EMITTER_ENVMAP: return false;
    }
    return false;
}

bool spc_emitter_is_infinite(const spc_emitter *e)
{
    return e->type == SPC_EMITTER_CONSTANT || e->type == SPC_EMITTER_ENVMAP;
}

bool spc_emitter_prepare(spc_emitter *e, spc_vec3 scene_center, double scene_radius)
{
    e->scene_center = scene_center;
    e->scene_radius = scene_radius;
    switch (e->type) {
    case SPC_EMITTER_POINT: return spc_point_prepare(e);
    case SPC_EMITTER_SPOT: return spc_spot_prepare(e);
    case SPC_EMITTER_PROJECTOR: return spc_projector_prepare(e);
    case SPC_EMITTER_DIRECTIONAL: return spc_directional_prepare(e);
    case SPC_EMITTER_AREA: return spc_area_prepare(e);
    case SPC_EMITTER_CONSTANT:
    case SPC_EMITTER_ENVMAP: return spc_envmap_prepare(e);
    }
    return false;
}

void spc_emitter_release(spc_emitter *e)
{
    if (!e)
        return;
    spc_envmap_release(e);
    spc_area_release(e);
}

bool spc_emitter_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_vec2 u, spc_emitter_direct *out)
{
    out->is_delta = spc_emitter_is_delta(e);
    out->is_infinite = false;
    out->err = 0.0;
    switch (e->type) {
    case SPC_EMITTER_POINT: return spc_point_sample_direct(e, ref, out);
    case SPC_EMITTER_SPOT: return spc_spot_sample_direct(e, ref, out);
    case SPC_EMITTER_PROJECTOR: return spc_projector_sample_direct(e, ref, out);
    case SPC_EMITTER_DIRECTIONAL: return spc_directional_sample_direct(e, ref, out);
    case SPC_EMITTER_AREA: return spc_area_sample_direct(e, ref, u, out);
    case SPC_EMITTER_CONSTANT:
    case SPC_EMITTER_ENVMAP: {
        spc_vec3 w;
        double pdf;
        if (!spc_envmap_sample_dir(e, u, &w, &pdf) || !(pdf > 0.0))
            return false;
        out->wi = w;
        out->dist = INFINITY;
        out->p = spc_madd(ref, w, 2.0 * e->scene_radius);
        out->n = spc_neg(w);
        out->L = spc_envmap_eval(e, w);
        out->pdf = pdf;
        out->is_infinite = true;
        return !spc_rgb_is_black(out->L);
    }
    }
    return false;
}

double spc_emitter_pdf_direct(const spc_emitter *e, spc_vec3 ref, spc_vec3 p, spc_vec3 n)
{
    return e->type == SPC_EMITTER_AREA ? spc_area_pdf_direct(e, ref, p, n) : 0.0;
}

spc_rgb spc_emitter_eval_area(const spc_emitter *e, const spc_hit *h, spc_vec3 w)
{
    if (e->type != SPC_EMITTER_AREA)
        return spc_rgb1(0.0);
    return spc_area_eval(e, h->uv, h->ng, w);
}

spc_rgb spc_emitter_eval_infinite(const spc_emitter *e, spc_vec3 d)
{
    if (!spc_emitter_is_infinite(e))
        return spc_rgb1(0.0);
    return spc_envmap_eval(e, d);
}

double spc_emitter_pdf_infinite(const spc_emitter *e, spc_vec3 d)
{
    if (!spc_emitter_is_infinite(e))
        return 0.0;
    return spc_envmap_pdf_dir(e, d);
}

/* Infinite lights emit from a disk of the scene's radius, perpendicular to the direction, placed
 * outside the bounding sphere (pbrt's convention for infinite-light emission). */
static void infinite_origin(const spc_emitter *e, spc_vec3 d, spc_vec2 u, spc_vec3 *o)
{
    spc_frame fr = spc_frame_from_n(d);
    spc_vec2 q = spc_warp_disk_concentric(u);
    double R = e->scene_radius;
    *o = spc_add(spc_madd(e->scene_center, d, -R), spc_scale(spc_add(spc_scale(fr.s, q.x), spc_scale(fr.t, q.y)), R));
}

bool spc_emitter_sample_emission(const spc_emitter *e, spc_vec2 u_pos, spc_vec2 u_dir, spc_emitter_emission *out)
{
    out->delta_pos = out->delta_dir = out->is_infinite = false;
    out->err = 0.0;
    switch (e->type) {
    case SPC_EMITTER_POINT: return spc_point_sample_emission(e, u_dir, out);
    case SPC_EMITTER_SPOT: return spc_spot_sample_emission(e, u_dir, out);
    case SPC_EMITTER_PROJECTOR: return spc_projector_sample_emission(e, u_dir, out);
    case SPC_EMITTER_DIRECTIONAL: return spc_directional_sample_emission(e, u_pos, out);
    case SPC_EMITTER_AREA: return spc_area_sample_emission(e, u_pos, u_dir, out);
    case SPC_EMITTER_CONSTANT:
    case SPC_EMITTER_ENVMAP: {
        spc_vec3 w;
        double pdf_dir;
        if (!spc_envmap_sample_dir(e, u_dir, &w, &pdf_dir) || !(pdf_dir > 0.0))
            return false;
        spc_vec3 d = spc_neg(w);
        infinite_origin(e, d, u_pos, &out->p);
        out->d = d;
        out->n = d;
        double R = e->scene_radius;
        out->pdf_pos = 1.0 / (SPC_PI * R * R);
        out->pdf_dir = pdf_dir;
        out->weight = spc_rgb_scale(spc_envmap_eval(e, w), 1.0 / (out->pdf_pos * pdf_dir));
        out->is_infinite = true;
        return !spc_rgb_is_black(out->weight);
    }
    }
    return false;
}

spc_rgb spc_emitter_eval_intensity(const spc_emitter *e, spc_vec3 d)
{
    switch (e->type) {
    case SPC_EMITTER_POINT: return e->intensity;
    case SPC_EMITTER_SPOT: return spc_spot_eval_intensity(e, d);
    case SPC_EMITTER_PROJECTOR:
    case SPC_EMITTER_DIRECTIONAL:
    case SPC_EMITTER_AREA:
    case SPC_EMITTER_CONSTANT:
    case SPC_EMITTER_ENVMAP: return spc_rgb1(0.0);
    }
    return spc_rgb1(0.0);
}

void spc_emitter_pdf_emission(const spc_emitter *e, spc_vec3 p, spc_vec3 n, spc_vec3 d, double *pdf_pos,
                              double *pdf_dir)
{
    *pdf_pos = *pdf_dir = 0.0;
    switch (e->type) {
    case SPC_EMITTER_POINT:
        *pdf_pos = 1.0;
        *pdf_dir = SPC_INV_4PI;
        return;
    case SPC_EMITTER_SPOT:
        *pdf_pos = 1.0;
        *pdf_dir = spc_spot_pdf_dir(e, d);
        return;
    case SPC_EMITTER_PROJECTOR:
        *pdf_pos = 1.0;
        *pdf_dir = spc_projector_pdf_dir(e, d);
        return;
    case SPC_EMITTER_DIRECTIONAL:
        *pdf_pos = 1.0 / (SPC_PI * e->scene_radius * e->scene_radius);
        *pdf_dir = 1.0;
        return;
    case SPC_EMITTER_AREA: spc_area_pdf_emission(e, p, n, d, pdf_pos, pdf_dir); return;
    case SPC_EMITTER_CONSTANT:
    case SPC_EMITTER_ENVMAP:
        *pdf_pos = 1.0 / (SPC_PI * e->scene_radius * e->scene_radius);
        *pdf_dir = spc_envmap_pdf_dir(e, spc_neg(d));
        return;
    }
}
