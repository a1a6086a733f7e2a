/*
 * scene/sdfgrid.h: a signed distance function sampled on a grid, as Mitsuba 3's `sdfgrid` shape
 * defines it. Used by the shape type SPC_SHAPE_SDFGRID (scene/shape.h).
 *
 * Conventions (Mitsuba 3's, src/shapes/sdfgrid.cpp):
 * - The grid's nx x ny x nz values sit at the VERTICES of a lattice over the local box [0,1]^3:
 *   value (i, j, k) at (i / (nx - 1), j / (ny - 1), k / (nz - 1)); x varies fastest in memory.
 *   Within a voxel the field is the trilinear interpolation of its 8 corner values.
 * - f < 0 inside, f > 0 outside; the geometric normal is the field's gradient (outward), taken
 *   within the voxel the point lies in, carried to world space by the inverse transpose of
 *   to_world. It is not flipped toward the ray.
 * - Only voxels whose corners are not all of one strict sign hold surface. A ray hits the first
 *   sign change of the trilinear cubic along it inside such a voxel (found exactly: the cubic is
 *   split at its derivative's roots into monotone pieces and the first piece with a sign change is
 *   bisected to double precision). A tangential touch (a double root without a sign change) is not
 *   a hit, as in Mitsuba.
 * - Shading normals: "smooth" (Mitsuba's default; Hansson-Soderlund, Evans and Akenine-Moller,
 *   "Ray Tracing of Signed Distance Function Grids", JCGT 11(3) 2022): the unit gradients of the 8
 *   voxels around the nearest lattice vertex, trilinearly blended; voxels with a negative index are
 *   left out, while those past the upper faces are kept with the clamped field's gradient (which
 *   lacks that axis), exactly as Mitsuba does. "analytic": the geometric normal.
 * - to_world may be any invertible affine map. (Mitsuba 3 bounds each voxel by transforming its
 *   two corners only, so it loses rotated grids and warns "use instancing"; an instance's
 *   rotation renders alike in both.)
 * - No texture coordinates (uv = 0), not an area emitter (both as Mitsuba).
 */
#ifndef SPC_SCENE_SDFGRID_H
#define SPC_SCENE_SDFGRID_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "core/math.h"
#include "scene/hit.h"

/* Grids beyond this many values are refused (4 GiB of floats). */
#define SPC_SDFGRID_MAX_VALUES (1ull << 30)

typedef struct spc_sdfgrid spc_sdfgrid;

/* A grid of nx * ny * nz values (copied; x fastest) mapped from [0,1]^3 by to_world (NULL:
 * identity; any invertible affine map). smooth: the shading normals above, else analytic. Returns
 * NULL with a message in err, located at file:line:col: SPC_ERR_VALUE for a size below 2 on an
 * axis, a value that is not finite, a singular or non-finite transform; SPC_ERR_LIMIT for too many
 * values; SPC_ERR_NOMEM. Freed by spc_sdfgrid_destroy (NULL does nothing). */
spc_sdfgrid *spc_sdfgrid_create(const float *values, int nx, int ny, int nz, const spc_mat4 *to_world, bool smooth,
                                const char *file, int line, int col, spc_error *err);
void spc_sdfgrid_destroy(spc_sdfgrid *g);

/* World bounds of the occupied voxels (the shape's Embree bounds; the box [0,1]^3 if none). */
void spc_sdfgrid_bounds(const spc_sdfgrid *g, spc_vec3 *lo, spc_vec3 *hi);
/* Number of voxels that hold surface. */
size_t spc_sdfgrid_occupied(const spc_sdfgrid *g);
/* Surface area estimate: for each occupied voxel, its world volume divided by its world extent
 * along the voxel's mean gradient (the mean cross-section of a plane crossing a parallelepiped). */
double spc_sdfgrid_area(const spc_sdfgrid *g);

/* The field at a local point of [0,1]^3 (trilinear, clamped to the box). */
double spc_sdfgrid_eval_local(const spc_sdfgrid *g, spc_vec3 q);

/* The first surface crossing along r in (r->tmin, r->tmax), thread-safe. false if none. */
bool spc_sdfgrid_intersect(const spc_sdfgrid *g, const spc_ray *r, double *t);

/* Surface interaction at a world point p reached by a ray: p, ng, sh, uv = 0, dpdu/dpdv (a
 * tangent basis of ng), dndu = dndv = 0, b1 = b2 = 0, err. */
void spc_sdfgrid_fill_hit(const spc_sdfgrid *g, spc_vec3 p, bool flip_normals, spc_hit *h);

#endif
