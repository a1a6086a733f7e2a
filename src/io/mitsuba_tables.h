/*
 * io/mitsuba_tables.h: spectra to RGB (CIE 1931), Mitsuba's named IORs and conductor presets.
 */
#ifndef SPC_IO_MITSUBA_TABLES_H
#define SPC_IO_MITSUBA_TABLES_H

#include <stdbool.h>

#include "core/math.h"

/* Linear sRGB of a piecewise-linear spectrum (wavelengths in nm, increasing; zero outside),
 * integrated against the CIE 1931 2-degree observer and normalized so that a constant spectrum
 * of 1 gives (1, 1, 1). Negative channels are clamped to 0. */
spc_rgb mts_spectrum_to_rgb(const double *wavelengths, const double *values, int n);
/* The same spectrum as an emitter's radiance, as Mitsuba 3's RGB variants read it: XYZ divided by
 * the integral of y-bar, then linear sRGB, with no white normalization, so a constant spectrum of
 * 1 is the equal-energy illuminant, (1.2048, 0.9483, 0.9089) in sRGB. */
spc_rgb mts_spectrum_to_rgb_emission(const double *wavelengths, const double *values, int n);
double mts_srgb_to_linear(double v);
/* Mitsuba's named IORs ("bk7", "water", ...); false if unknown. */
bool mts_named_ior(const char *name, double *ior);
/* RGB complex IOR of a conductor preset ("Au", "Cu", ...); false if unknown. */
bool mts_conductor_preset(const char *name, spc_rgb *eta, spc_rgb *k);
/* Comma-separated lists of the known names, for error messages. */
const char *mts_ior_names(void);
const char *mts_conductor_names(void);

#endif
