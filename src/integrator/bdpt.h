/*
 * integrator/bdpt.h: bidirectional path tracing and the particle tracer (bdpt.c).
 */
#ifndef SPC_INTEGRATOR_BDPT_H
#define SPC_INTEGRATOR_BDPT_H

#include "integrator/context.h"

/* Bidirectional path tracing (bdpt.c): one camera subpath for this ray and one light subpath, every
 * (s, t) strategy; t = 1 strategies splat into tls. With ctx->kind SPC_INTEGRATOR_PTRACER only
 * the light subpath is traced and each of its vertices is joined to the camera (t = 1, unweighted:
 * the one strategy for each path length), as Mitsuba 3's ptracer: out->L is zero, the image is in
 * the splats. */
void spc_bdpt_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                     spc_sample_out *out);
/* Subpaths cut short by the fixed vertex arrays of bdpt.c since the program started (a path
 * that long only occurs with max_depth -1, and Russian roulette makes it astronomically rare). */
uint64_t spc_bdpt_truncated_paths(void);

#endif
