/*
 * explore/explore.h: the request handlers behind `specula explore` (the solver explorer), without
 * HTTP: a request is a method, a path and a JSON body; the answer a status code and a JSON text.
 * The public entry points are in specula/specula.h (spc_explore_*); the API is documented in the
 * README ("The solver explorer").
 *
 *   GET  /api/scene    the scene's shapes (triangles for meshes and signed distance fields, the
 *                      parameters of spheres, disks and cylinders), lights and camera
 *   POST /api/solve    one connection problem: receiver x (a pick ray), a light point y, solvers;
 *                      every iterate's chain, loss and gradients (analytic and finite difference),
 *                      the solutions with contribution and generalized geometry term
 *   POST /api/lossmap  the angular loss over a grid of the two direction parameters around a seed
 *
 * Requests are bounded (SPC_EXPLORE_MAX_BODY bytes, numbers range-checked, a solve's CPU time
 * bounded by its time_limit); every refusal is a 4xx with {"error": "..."}.
 */
#ifndef SPC_EXPLORE_EXPLORE_H
#define SPC_EXPLORE_EXPLORE_H

#include "specula/specula.h"

/* Iterates recorded per angular solve (its max_iterations is capped to this). */
#define SPC_EXPLORE_MAX_TRACE 200
/* Loss-map resolution cap (cells per side): 128^2 traces take ~0.1 s on the test scenes. */
#define SPC_EXPLORE_MAX_MAP 128
/* Longest time_limit a request may ask for (seconds). */
#define SPC_EXPLORE_MAX_TIME 10.0
/* Triangles sent for one signed distance field (surface nets on a grid of this many cells per
 * side). */
#define SPC_EXPLORE_SDF_GRID 48

#endif
