/*
 * medium/variants.h: private interface between the medium dispatcher (medium.c) and the medium
 * variants (homogeneous.c, heterogeneous.c). Not for use outside src/medium/.
 */
#ifndef SPC_MEDIUM_VARIANTS_H
#define SPC_MEDIUM_VARIANTS_H

#include "medium/medium.h"

/* The channel distance sampling follows for the probabilities q and the uniform u: the first
 * whose cumulative probability exceeds u, never one of probability zero; -1 if none. */
int spc_medium_pick_channel(const double q[3], double u);

/* heterogeneous.c: spc_medium_transmittance_ray, _sample_ray and _pdf_ray of a heterogeneous
 * medium (same contracts). */
spc_rgb spc_heterogeneous_transmittance(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t);
bool spc_heterogeneous_sample(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t_max, spc_rgb beta, double u_channel,
                              double u_dist, spc_medium_event *out);
double spc_heterogeneous_pdf(const spc_medium *m, spc_vec3 o, spc_vec3 d, spc_rgb beta, double t, double t_max,
                             bool scattered);

#endif
