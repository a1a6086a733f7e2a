/*
 * integrator/aov.h: the auxiliary images (albedo, shading normal, depth) of a camera sample, for
 * the denoiser (aov.c).
 */
#ifndef SPC_INTEGRATOR_AOV_H
#define SPC_INTEGRATOR_AOV_H

#include "integrator/context.h"

/* The AOVs of a camera sample whose ray first hit h0 (wo0 toward the camera): depth h0->t; albedo
 * and shading normal of the first surface with a non-delta lobe, found by sampling delta lobes from
 * h0 on with a random stream of its own (aov.c; only with ctx->aovs, else h0's own features). */
void spc_aov_from_hit(const spc_render_ctx *ctx, const spc_hit *h0, spc_vec3 wo0, const spc_sampler *smp,
                      spc_sample_out *out);

#endif
