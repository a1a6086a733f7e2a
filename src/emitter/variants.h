/*
 * emitter/variants.h: per-variant entry points, dispatched by emitter.c (internal to src/emitter).
 */
#ifndef SPC_EMITTER_VARIANTS_H
#define SPC_EMITTER_VARIANTS_H

#include "emitter/emitter.h"

/* The record toward a light at the point e->position from ref (point, spot, projector): p, wi,
 * n = -wi, dist, pdf 1 (a delta position) and err; the caller sets L. Returns dist^2, or 0 where
 * ref is at the light (no sample). */
static inline double spc_emitter_at_point(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out)
{
    spc_vec3 d = spc_sub(e->position, ref);
    double dist2 = spc_length2(d);
    if (!(dist2 > 0.0))
        return 0.0;
    double dist = sqrt(dist2);
    out->p = e->position;
    out->wi = spc_scale(d, 1.0 / dist);
    out->n = spc_neg(out->wi);
    out->dist = dist;
    out->pdf = 1.0;
    out->err = 1e-9 * spc_max_abs(e->position);
    return dist2;
}

bool spc_point_prepare(spc_emitter *e);
bool spc_point_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out);
bool spc_point_sample_emission(const spc_emitter *e, spc_vec2 u_dir, spc_emitter_emission *out);

bool spc_spot_prepare(spc_emitter *e);
bool spc_spot_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out);
bool spc_spot_sample_emission(const spc_emitter *e, spc_vec2 u_dir, spc_emitter_emission *out);
double spc_spot_pdf_dir(const spc_emitter *e, spc_vec3 d);
/* The spot's radiant intensity toward the unit world direction d (falloff and image included). */
spc_rgb spc_spot_eval_intensity(const spc_emitter *e, spc_vec3 d);

bool spc_projector_prepare(spc_emitter *e);
bool spc_projector_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out);
bool spc_projector_sample_emission(const spc_emitter *e, spc_vec2 u_dir, spc_emitter_emission *out);
double spc_projector_pdf_dir(const spc_emitter *e, spc_vec3 d);

bool spc_directional_prepare(spc_emitter *e);
bool spc_directional_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out);
bool spc_directional_sample_emission(const spc_emitter *e, spc_vec2 u_pos, spc_emitter_emission *out);

bool spc_area_prepare(spc_emitter *e);
void spc_area_release(spc_emitter *e);
bool spc_area_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_vec2 u, spc_emitter_direct *out);
double spc_area_pdf_direct(const spc_emitter *e, spc_vec3 ref, spc_vec3 p, spc_vec3 n);
spc_rgb spc_area_eval(const spc_emitter *e, spc_vec2 uv, spc_vec3 n, spc_vec3 w);
bool spc_area_sample_emission(const spc_emitter *e, spc_vec2 u_pos, spc_vec2 u_dir, spc_emitter_emission *out);
void spc_area_pdf_emission(const spc_emitter *e, spc_vec3 p, spc_vec3 n, spc_vec3 d, double *pdf_pos,
                           double *pdf_dir);

/* constant and envmap share the infinite-light machinery; every direction argument points from
 * the scene TOWARD the environment (an escaping ray's direction) */
bool spc_envmap_prepare(spc_emitter *e);
void spc_envmap_release(spc_emitter *e);
spc_rgb spc_envmap_eval(const spc_emitter *e, spc_vec3 d);
double spc_envmap_pdf_dir(const spc_emitter *e, spc_vec3 w_to_light);
bool spc_envmap_sample_dir(const spc_emitter *e, spc_vec2 u, spc_vec3 *w_to_light, double *pdf);

#endif
