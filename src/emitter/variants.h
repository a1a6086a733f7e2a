/*
 * emitter/variants.h: per-variant entry points, dispatched by emitter.c (internal to src/emitter).
 */
#ifndef SPC_EMITTER_VARIANTS_H
#define SPC_EMITTER_VARIANTS_H

#include "emitter/emitter.h"

bool spc_point_prepare(spc_emitter *e);
bool spc_point_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out);
bool spc_point_sample_emission(const spc_emitter *e, spc_vec2 u_dir, spc_emitter_emission *out);

bool spc_spot_prepare(spc_emitter *e);
bool spc_spot_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_emitter_direct *out);
bool spc_spot_sample_emission(const spc_emitter *e, spc_vec2 u_dir, spc_emitter_emission *out);
double spc_spot_pdf_dir(const spc_emitter *e, spc_vec3 d);

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
