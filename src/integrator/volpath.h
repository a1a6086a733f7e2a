/*
 * integrator/volpath.h: path tracing through participating media (volpath.c).
 */
#ifndef SPC_INTEGRATOR_VOLPATH_H
#define SPC_INTEGRATOR_VOLPATH_H

#include "integrator/context.h"

/* Volumetric path tracing (volpath.c): path's estimator plus free-flight sampling, phase
 * scattering and transmittance along shadow rays; specular connections through one interface
 * from medium vertices when ctx->specular_nee is set. */
void spc_volpath_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                        spc_sample_out *out);

#endif
