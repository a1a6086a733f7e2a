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
    SPC_MEDIUM_HOMOGENEOUS,
    SPC_MEDIUM_HETEROGENEOUS /* sigma_t from a volume, zero outside its bounds (heterogeneous.c) */
} spc_medium_type;

typedef enum spc_volume_wrap {
    SPC_VOLUME_CLAMP,
    SPC_VOLUME_REPEAT,
    SPC_VOLUME_MIRROR
} spc_volume_wrap;

/*
 * A volume-valued property (medium/gridvolume.c): Mitsuba 3's gridvolume, a grid of res[0] x res[1]
 * x res[2] values of 1 or 3 channels over the unit cube of its local space, or its constvolume, one
 * value everywhere. A world point p is looked up at to_local p. Grid values sit at the texel
 * centres ((i + 0.5) / res) and are interpolated trilinearly (or taken from the nearest texel),
 * indices outside the grid wrapped by `wrap`, as drjit's Texture3f does for Mitsuba. lo and hi
 * bound the unit cube in world space (Mitsuba's volume bbox: a heterogeneous medium is vacuum
 * outside its sigma_t volume's).
 */
typedef struct spc_volume {
    bool grid;            /* false: constant `value` */
    spc_rgb value;        /* constvolume */
    int res[3], channels; /* grid: x varies fastest, then y, then z; 1 or 3 channels */
    float *data;          /* grid: res[0] res[1] res[2] channels values (owned; spc_medium_release) */
    bool nearest;
    spc_volume_wrap wrap;
    spc_mat4 to_world, to_local;
    spc_vec3 lo, hi;
    spc_rgb max; /* the largest value per channel */
} spc_volume;

typedef struct spc_medium {
    spc_medium_type type;
    char id[128];
    spc_rgb sigma_a, sigma_s, sigma_t; /* homogeneous, per unit length; sigma_t = sigma_a + sigma_s */
    /* heterogeneous: sigma_t(x) = scale sigma_t_vol(x); both types: with has_albedo_vol,
     * sigma_s(x) = sigma_t(x) albedo_vol(x), else albedo is constant (heterogeneous: `albedo`,
     * homogeneous: sigma_s / sigma_t) */
    spc_volume sigma_t_vol, albedo_vol;
    bool has_albedo_vol;
    spc_rgb albedo;
    double scale;
    spc_phase phase;
    bool sample_emitters; /* next-event estimation at its interactions (Mitsuba's sample_emitters) */
    int index;            /* position in scene->media */
} spc_medium;

/* Frees the volumes' grids (the scene calls it before freeing the medium). */
void spc_medium_release(spc_medium *m);

/* The volume's value at the world point p (per channel; a 1-channel grid fills all three). */
spc_rgb spc_volume_eval(const spc_volume *v, spc_vec3 p);
/* Sets v to a constant volume over the unit cube mapped by to_world (false: singular map). */
bool spc_volume_init_constant(spc_volume *v, spc_rgb value, const spc_mat4 *to_world);
/* Completes a grid volume whose res, channels, data, nearest and wrap are set: transforms, bounds
 * and maxima (false: singular to_world). */
bool spc_volume_finish_grid(spc_volume *v, const spc_mat4 *to_world);

/* Makes m heterogeneous: sigma_t = scale sigma_t_vol (moved into m), constant albedo (the caller
 * may then set albedo_vol and has_albedo_vol). The phase function is isotropic, sample_emitters
 * true. */
void spc_medium_init_heterogeneous(spc_medium *m, const spc_volume *sigma_t_vol, double scale, spc_rgb albedo);

/* The coefficients at the point x: sigma_t and sigma_s (per unit length). */
void spc_medium_coefficients(const spc_medium *m, spc_vec3 x, spc_rgb *sigma_t, spc_rgb *sigma_s);

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
    spc_rgb albedo; /* sigma_s / sigma_t at the interaction (scattered) */
} spc_medium_event;

/* ---- along a ray: every medium type (what the integrators call) ----
 * The ray is o + t d (d need not be unit: t is in its units times |d|; the integrators pass unit
 * directions). For a homogeneous medium these are the functions below with d = t |d|. For a
 * heterogeneous one the optical depth tau(t) = integral sigma_t is exact: along a line, trilinear
 * interpolation is a cubic polynomial between the planes of texel centres it crosses, so Simpson's
 * rule over each such piece integrates it exactly, and free-flight distances are drawn by
 * inverting tau (regular tracking, with the same spectral mixture as above: one channel by
 * throughput, pdf(t) = sum_c q_c sigma_t,c(t) T_c(t)). No majorant, no null collisions, no noise in
 * shadow rays' transmittance. */
spc_rgb spc_medium_transmittance_ray(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t);
bool spc_medium_sample_ray(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t_max, spc_rgb beta, double u_channel,
                           double u_dist, spc_medium_event *out);
double spc_medium_pdf_ray(const spc_medium *m, spc_vec3 o, spc_vec3 d, spc_rgb beta, double t, double t_max,
                          bool scattered);

/* ---- homogeneous media by distance alone ---- */
/* Free-flight sampling along a segment of length t_max (may be +inf) for throughput beta, from
 * two uniform numbers (u_channel picks the channel, u_dist the distance). False if neither an
 * interaction nor passing has positive probability (nothing to continue: the path ends). */
bool spc_medium_sample_distance(const spc_medium *m, double t_max, spc_rgb beta, double u_channel, double u_dist,
                                spc_medium_event *out);
/* The mixture density of that sampling: pdf(t) for an interaction at t < t_max (scattered), or
 * P(passing t_max). */
double spc_medium_pdf_distance(const spc_medium *m, spc_rgb beta, double t, double t_max, bool scattered);

#endif
