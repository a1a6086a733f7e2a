/*
 * integrator/path.h: unidirectional path tracing, with next-event estimation and MIS (path) or
 * without (ipt), by ctx->kind (path.c).
 */
#ifndef SPC_INTEGRATOR_PATH_H
#define SPC_INTEGRATOR_PATH_H

#include "integrator/context.h"

/* One estimate for a camera ray (integrator.h: spc_integrator_sample). */
void spc_path_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                     spc_sample_out *out);

#endif
