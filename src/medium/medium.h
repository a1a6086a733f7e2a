/*
 * medium/medium.h: participating media and their phase functions: the contract the volumetric
 * path tracer (integrator/volpath.c) relies on.
 *
 * Conventions:
 * - Coefficients are RGB, per unit of scene length: sigma_a (absorption), sigma_s (scattering),
 *   sigma_t = sigma_a + sigma_s (extinction). Transmittance over a distance d in a homogeneous
 *   medium is T(d) = exp(-sigma_t d) per channel; T(inf) = 0 where sigma_t > 0 and 1 where it is 0.
 * - Phase functions use the BSDF's direction convention (bsdf/bsdf.h): wo points back toward the
 *   previous path vertex, wi toward the next one, both away from the scattering point. The
 *   scattering angle is the angle between the travel directions -wo and wi, cos theta =
 *   dot(-wo, wi); an asymmetry g > 0 scatters forward. p(wo, wi) is normalized over the sphere of
 *   wi (unit: 1/sr) and is reciprocal. spc_phase_sample draws wi with density exactly p, so the
 *   sample's weight p / pdf is 1 and only the pdf is reported.
 * - Distance sampling (free flight) is spectral: the three channels have different sigma_t. One
 *   channel c is chosen with probability q_c proportional to the path throughput beta (uniform if
 *   beta is black or not finite) and a distance drawn from sigma_t[c] exp(-sigma_t[c] t); the
 *   estimator divides by the density of the whole mixture,
 *       pdf(t)      = sum_c q_c sigma_t[c] exp(-sigma_t[c] t)     (an interaction at t < t_max)
 *       P(passing)  = sum_c q_c exp(-sigma_t[c] t_max)            (no interaction before t_max),
 *   which is the one-sample MIS of the channels' strategies with the balance heuristic (Veach 1997,
 *   sec. 9.2.4; the "average pdf" of Miller, Georgiev and Jarosz 2019, sec. 5). Every channel's
 *   estimate is then unbiased, whichever channel drove the sample. Weights:
 *       interaction  beta *= sigma_s T(t) / pdf(t)
 *       passing      beta *= T(t_max) / P(passing).
 * - Hot path: no allocation, no error codes; "false" means no sample.
 *
 * XML (the loader, io/mitsuba_plugins.c, fills these):
 *   <medium type="homogeneous">  sigma_a, sigma_s (rgb/float/spectrum; a missing one is 0), or
 *       Mitsuba 3's albedo (0.75) + sigma_t (1); scale (1) multiplies the coefficients;
 *       sample_emitters (true); a nested <phase>, isotropic by default.
 *   <phase type="isotropic"/>, <phase type="hg"> g (0.8, in (-1, 1)).
 * Shapes name their media "interior" (the side opposite to the shape's normal, after
 * flip_normals) and "exterior"; a shape that names either is a medium transition (Mitsuba's rule:
 * crossing it enters the medium of the side the ray goes to, "none" being vacuum).
 */
#ifndef SPC_MEDIUM_MEDIUM_H
#define SPC_MEDIUM_MEDIUM_H

#include "core/math.h"

typedef enum spc_phase_type {
    SPC_PHASE_ISOTROPIC, /* 1 / (4 pi) */
    SPC_PHASE_HG         /* Henyey and Greenstein 1941 */
} spc_phase_type;

typedef struct spc_phase {
    spc_phase_type type;
    double g; /* HG asymmetry, mean cosine of the scattering angle, in (-1, 1) */
} spc_phase;

/* Phase function value p(wo, wi) (1/sr); equal to spc_phase_pdf. */
double spc_phase_eval(const spc_phase *p, spc_vec3 wo, spc_vec3 wi);
/* Solid-angle density of spc_phase_sample producing wi. */
double spc_phase_pdf(const spc_phase *p, spc_vec3 wo, spc_vec3 wi);
/* Samples wi exactly proportional to p (weight 1); *pdf receives its density. False only for a
 * degenerate input (wo not finite). */
bool spc_phase_sample(const spc_phase *p, spc_vec3 wo, spc_vec2 u, spc_vec3 *wi, double *pdf);

typedef enum spc_medium_type {
    SPC_MEDIUM_HOMOGENEOUS
} spc_medium_type;

typedef struct spc_medium {
    spc_medium_type type;
    char id[128];
    spc_rgb sigma_a, sigma_s, sigma_t; /* per unit length; sigma_t = sigma_a + sigma_s */
    spc_phase phase;
    bool sample_emitters; /* next-event estimation at its interactions (Mitsuba's sample_emitters) */
    int index;            /* position in scene->media */
} spc_medium;

/* Sets the coefficients (sigma_t = sigma_a + sigma_s), an isotropic phase function and
 * sample_emitters. Returns false if a coefficient is negative or not finite. */
bool spc_medium_init_homogeneous(spc_medium *m, spc_rgb sigma_a, spc_rgb sigma_s);

/* True if light crosses the medium unchanged (sigma_t = 0 in every channel). */
bool spc_medium_is_vacuum(const spc_medium *m);

/* Transmittance over a distance d >= 0 (d may be +inf). */
spc_rgb spc_medium_transmittance(const spc_medium *m, double d);

/* The channel probabilities q_c of distance sampling for a path throughput beta (see above). */
void spc_medium_channel_pmf(spc_rgb beta, double q[3]);

typedef struct spc_medium_event {
    bool scattered; /* an interaction at t < t_max; else the segment is crossed */
    double t;       /* the interaction's distance (scattered), else t_max */
    spc_rgb weight; /* the factor for beta (see above) */
    double pdf;     /* pdf(t) for an interaction, P(passing) otherwise */
} spc_medium_event;

/* Free-flight sampling along a segment of length t_max (may be +inf) for throughput beta, from
 * two uniform numbers (u_channel picks the channel, u_dist the distance). False if neither an
 * interaction nor passing has positive probability (nothing to continue: the path ends). */
bool spc_medium_sample_distance(const spc_medium *m, double t_max, spc_rgb beta, double u_channel, double u_dist,
                                spc_medium_event *out);
/* The mixture density of that sampling: pdf(t) for an interaction at t < t_max (scattered), or
 * P(passing t_max). */
double spc_medium_pdf_distance(const spc_medium *m, spc_rgb beta, double t, double t_max, bool scattered);

#endif
