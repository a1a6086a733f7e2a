/*
 * integrator/splat.h: contributions that land on another pixel than the camera sample's (light
 * tracing's t = 1 strategies, specular NEE from the camera), stored in the tile's scratch
 * (spc_tls) and merged by the driver in tile order (splat.c).
 */
#ifndef SPC_INTEGRATOR_SPLAT_H
#define SPC_INTEGRATOR_SPLAT_H

#include "integrator/context.h"

/* Splat value v at continuous film position (fx, fy) of the full film, spread by the pixel
 * filter (normalized), into tls. */
void spc_splat_add(const spc_render_ctx *ctx, spc_tls *tls, double fx, double fy, spc_rgb v);
/* The same into film `film` (spc_splat.film). Only film 0 counts invalid values: the others hold
 * parts of the image's estimate, which counts them once. */
void spc_splat_add_to(const spc_render_ctx *ctx, spc_tls *tls, int film, double fx, double fy, spc_rgb v);

#endif
