/*
 * scene/curve.h: Mitsuba 3's curve shapes, tubes swept along polylines or cubic B-splines with a
 * radius per control point, in world space. Embree intersects them natively (accel/embree.c: round
 * linear curves, cones joined and ended by spheres; round B-spline curves, as Mitsuba 3 builds them)
 * in float; this module reads their files and fills the hit record.
 *
 * XML (Mitsuba 3):
 *   linearcurve   filename (required), to_world (positions only: radii are not scaled)
 *   bsplinecurve  the same
 * File: one control point a line, "x y z radius"; blank lines separate curves; a linear curve
 * needs at least 2 points, a B-spline 4 (segments: n - 1 and n - 3 per curve).
 *
 * Surface parameters (b1, b2) of a hit, as Mitsuba 3's uv:
 *   linearcurve   b1 = angle around the segment's axis / (2 pi), b2 = (s + segment) / segments, s the
 *                 segment's curve parameter; the normal points from the axis point at s to the hit
 *   bsplinecurve  b1 = (s + segment + 1.5) / points, rescaled to [0, 1] by (b1 - 1.5/n) / (1 - 3/n),
 *                 b2 = angle / (2 pi); the normal is the tube's, corrected for the varying radius and
 *                 the curvature of the centre line
 * Curves cannot be emitters and are never specular chain vertices (no normal derivatives).
 */
#ifndef SPC_SCENE_CURVE_H
#define SPC_SCENE_CURVE_H

#include <stdint.h>

#include "core/error.h"
#include "core/math.h"
#include "scene/hit.h"

typedef enum spc_curve_basis {
    SPC_CURVE_LINEAR, /* linearcurve */
    SPC_CURVE_BSPLINE /* bsplinecurve */
} spc_curve_basis;

typedef struct spc_curve {
    spc_curve_basis basis;
    float *cp;     /* 4 floats a control point: world x, y, z, radius (Embree reads it in place) */
    uint32_t ncp;
    uint32_t *seg; /* index of each segment's first control point */
    uint32_t nseg;
} spc_curve;

/* Reads a curve file and transforms its positions by to_world (NULL: identity). Errors:
 * SPC_ERR_IO (cannot open), SPC_ERR_PARSE (a line that is not four numbers, a curve with too few
 * points, no points at all), SPC_ERR_VALUE (NaN, infinite or negative values), SPC_ERR_LIMIT (more
 * than 2^31 points), SPC_ERR_NOMEM; err names the file and line. On failure *c is empty. The caller
 * frees *c with spc_curve_release. */
spc_status spc_curve_read(const char *path, spc_curve_basis basis, const spc_mat4 *to_world, spc_curve *c,
                          spc_error *err);
/* The same from text in memory (file is only named in errors). */
spc_status spc_curve_parse(const char *text, size_t len, const char *file, spc_curve_basis basis,
                           const spc_mat4 *to_world, spc_curve *c, spc_error *err);
void spc_curve_release(spc_curve *c);

/* Axis-aligned bounds of the control points grown by their radii (a B-spline lies in its control
 * points' convex hull, its radius below their maximum). */
void spc_curve_bounds(const spc_curve *c, spc_vec3 *lo, spc_vec3 *hi);
/* Lateral area (linear: exact cones; B-spline: 64-step midpoint rule of 2 pi r |c'|), for
 * statistics only. */
double spc_curve_area(const spc_curve *c);
/* Fills the geometric fields of h for the hit of r at t on segment prim at curve parameter s in
 * [0, 1] (Embree's u): p, ng (outward, negated if flip), sh, uv, b1, b2, dpdu, dpdv, dndu, dndv
 * (those of the tube's circle through p, zero along the curve), err. */
void spc_curve_fill_hit(const spc_curve *c, int prim, double s, const spc_ray *r, double t, bool flip, spc_hit *h);

#endif
