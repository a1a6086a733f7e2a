/*
 * integrator/integrator.h: what the render driver asks of an integrator: its kind by name, and one
 * estimate of the measurement of a camera ray, plus splats on the film for strategies that connect
 * to the camera (integrator.c dispatches to path.c, bdpt.c, volpath.c). The types an integrator
 * is given and returns are context.h's.
 */
#ifndef SPC_INTEGRATOR_INTEGRATOR_H
#define SPC_INTEGRATOR_INTEGRATOR_H

#include "integrator/context.h"

/* Parses an integrator name; false if unknown. */
bool spc_integrator_kind_from_name(const char *name, spc_integrator_kind *kind);
const char *spc_integrator_kind_name(spc_integrator_kind kind);
/* Every integrator name, comma-separated ("path, ipt, ..."), into buf (cut short to size). */
void spc_integrator_kind_names(char *buf, size_t size);

/* One estimate for a camera ray. out->L must be finite (the driver checks and counts). */
void spc_integrator_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                           spc_sample_out *out);

#endif
