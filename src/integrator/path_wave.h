/*
 * integrator/path_wave.h: plain path tracing (the path and ipt modes of path.c with specular NEE off)
 * of many camera samples at once, their rays traced in packets.
 *
 * The estimate of every sample is bit for bit spc_path_sample's: each path keeps its own sampler
 * stream and runs path.c's arithmetic in path.c's order; only the order in which the paths' rays
 * reach Embree changes (packets of 8 or 16 camera, extension and shadow rays, whose hits
 * are the single rays' hits for triangles and analytic shapes; not for Embree's curves, whose scenes
 * keep path.c). So images stay the same for any thread count, and checkpoints and
 * resumed renders mix freely with path.c's.
 */
#ifndef SPC_INTEGRATOR_PATH_WAVE_H
#define SPC_INTEGRATOR_PATH_WAVE_H

#include "integrator/context.h"

/* Does the render run plain path tracing that spc_path_wave_sample covers (ctx->kind path with
 * specular NEE off, or ipt) in a scene without curves (whose packet hits differ from single rays')? */
bool spc_path_wave_applies(const spc_render_ctx *ctx);

/* Estimates for the n camera rays rays[i] with their samplers smp[i] (moved as spc_path_sample
 * moves them): out[i] as spc_path_sample(ctx, tls, &rays[i], &smp[i], &out[i]) fills it (out[i].aovs
 * set by the caller). Requires spc_path_wave_applies(ctx). */
void spc_path_wave_sample(const spc_render_ctx *ctx, spc_tls *tls, int n, const spc_ray *rays, spc_sampler *smp,
                          spc_sample_out *out);

/* Camera samples estimated by spc_path_wave_sample since the program started (all threads). */
uint64_t spc_path_wave_samples(void);

#endif
