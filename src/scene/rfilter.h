/*
 * scene/rfilter.h: the pixel reconstruction filter of the scene's film (Mitsuba's <rfilter>), used
 * by the driver to place camera samples and by the integrators to spread splats.
 */
#ifndef SPC_SCENE_RFILTER_H
#define SPC_SCENE_RFILTER_H

#include "scene/scene.h"

/* The pixel filter, per axis (filters are separable: box, tent, truncated gaussian), normalized to
 * integrate to 1 over [-radius, radius], and its CDF.
 *
 * Tent and gaussian are the step functions Mitsuba 3 splats with: its filters are evaluated from a
 * table of SPC_FILTER_RESOLUTION values at |x| = k radius / RES, looked up by rounding |x| down
 * (ReconstructionFilter's discretization), so a sample at |x| weighs f(floor(|x| RES / radius)
 * radius / RES): a slightly wider filter than f itself. Measured on an edge: Mitsuba 3.9's tent
 * gives the step filter's value to 1e-4 and the exact tent's is 3e-3 off; the gaussian is Mitsuba's
 * too, exp(-x^2 / (2 stddev^2)) - exp(-radius^2 / (2 stddev^2)). Images of scenes with sharp
 * edges failed the per-pixel z-test against Mitsuba 3 along the edges before (instances.xml,
 * 98.4% of pixels passing). spc_film_filter_prepare fills the steps (the driver calls it on its
 * copy of the film settings); the functions below need it for tent and gaussian.
 *
 * Borders, as Mitsuba's films: no sample is taken outside the rendered window [lo, hi) (the crop
 * window, in full-film pixels), so a pixel near its edge is the filter-weighted mean of the
 * radiance over the part of its support inside the window. spc_film_filter_sample draws the offset
 * from the pixel center c from the filter restricted to [lo - c, hi - c] (inverse CDF; the plain
 * filter sample, unchanged, when the support is inside); splats divide the filter value by
 * spc_film_filter_mass, the integral of the filter over that interval (1 away from the edges). */
void spc_film_filter_prepare(struct spc_film_spec *f);
double spc_film_filter_eval(const struct spc_film_spec *f, double x);
double spc_film_filter_cdf(const struct spc_film_spec *f, double x);
double spc_film_filter_sample(const struct spc_film_spec *f, double u, double c, double lo, double hi);
/* spc_film_filter_sample of n offsets in one window [lo, hi): x[i] = spc_film_filter_sample(f, u[i],
 * c[i], lo, hi), the same values, the samples away from the window's edges in a loop that shares
 * vector instructions between them (AVX2 or AVX-512 where the CPU has them). */
void spc_film_filter_sample_many(const struct spc_film_spec *f, int n, const double *u, const double *c, double lo,
                                 double hi, double *x);
double spc_film_filter_mass(const struct spc_film_spec *f, double c, double lo, double hi);

#endif
