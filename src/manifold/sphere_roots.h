/*
 * manifold/sphere_roots.h: the planar problem of a specular chain through one sphere.
 *
 * A chain that stays on one sphere (the light reflected off it; refracted in, reflected inside m
 * times, refracted out) lies in the plane through x, y and the sphere's centre: every normal is
 * radial, so each reflection and refraction keeps the direction in the plane that holds the
 * incoming ray and the centre. In that plane, scaled to the unit circle, the chain is a function of
 * one number, the angle of its entry point on the circle seen from x, and a solution is a root of
 * the signed distance between y and the chain's final line. The outside reflection's roots are a
 * quartic's (Alhazen's problem); the others' are isolated on a grid over
 * the arc x sees (sign changes, and pairs of roots between samples where the samples have a local
 * extremum that crosses zero: near a fold of the caustic) and refined by bracketed secant steps.
 * Pure geometry: the scene's chains (sphere_chains.h) and the fitted sphere's seeds (fit_seeds.h)
 * polish and trace these in 3D.
 */
#ifndef SPC_MANIFOLD_SPHERE_ROOTS_H
#define SPC_MANIFOLD_SPHERE_ROOTS_H

#include <stdbool.h>

#include "core/math.h"

/* Roots kept per planar problem. */
#define SPC_SPHERE_MAX_ROOTS 16
/* Internal reflections at most (a chain of m + 2 vertices: SPC_CHAIN_MAX_VERTICES - 2), and the
 * signatures m = -1 .. SPC_SPHERE_MAX_M. */
#define SPC_SPHERE_MAX_M 6
#define SPC_SPHERE_SIGNATURES (SPC_SPHERE_MAX_M + 2)

/* The plane of a chain from x to y through the sphere (c, R): x on the axis e1 at distance d (in
 * radii), y at (y1, y2) in the frame (e1, e2) (in radii). */
typedef struct spc_sphere_plane {
    spc_vec3 c, e1, e2;
    double R, d, y1, y2;
} spc_sphere_plane;

/* The plane for x and y, both outside the sphere; false where one is not (no chain). */
bool spc_sphere_plane_of(spc_vec3 x, spc_vec3 c, double R, spc_vec3 y, spc_sphere_plane *pl);
/* The point on the sphere at entry angle theta in that plane. */
spc_vec3 spc_sphere_plane_point(const spc_sphere_plane *pl, double theta);

/* The planar problem on the unit circle: x at (d, 0) with d > 1, y at (y1, y2); m internal
 * reflections (-1: one external reflection); eta the relative index inside / outside. Writes the
 * roots (entry-point angles theta, the entry point (cos theta, sin theta)) of chains that reach y,
 * at most max_roots; returns their number. */
int spc_sphere_chain_roots(double d, double y1, double y2, int m, double eta, double *theta, int max_roots);
/* The same for every signature m = mlo..mhi at once (-1 <= mlo <= mhi <= SPC_SPHERE_MAX_M), sharing
 * the way in and the chords: theta[m + 1][...], n[m + 1]. */
void spc_sphere_chain_roots_all(double d, double y1, double y2, double eta, int mlo, int mhi,
                                double theta[][SPC_SPHERE_MAX_ROOTS], int *n);
/* The same for the signatures m with want[m + 1] set (n[m + 1] = 0 for the others), on one grid: each
 * signature's roots are those spc_sphere_chain_roots_all finds for it, bit for bit. */
void spc_sphere_chain_roots_some(double d, double y1, double y2, double eta, const bool want[SPC_SPHERE_SIGNATURES],
                                 double theta[][SPC_SPHERE_MAX_ROOTS], int *n);

/* The plane for x inside the sphere and y outside it: as spc_sphere_plane_of, with d < 1 (x at the
 * centre: e1 any direction at right angles to y's); false where x is not inside or y not outside. */
bool spc_sphere_plane_inside(spc_vec3 x, spc_vec3 c, double R, spc_vec3 y, spc_sphere_plane *pl);

/* The planar problem from inside: x at (d, 0) with 0 <= d < 1, y at (y1, y2) outside the unit
 * circle; the chain leaves x toward the circle, reflects inside m times (m >= 0) and refracts out
 * (eta: the relative index inside / outside): m + 1 vertices. Writes the roots (the first vertex's
 * angles theta, the point (cos theta, sin theta)) of chains that reach y, at most max_roots;
 * returns their number. */
int spc_sphere_inside_roots(double d, double y1, double y2, int m, double eta, double *theta, int max_roots);

/* Is every point P of the unit circle's arc from p0 to p1 (counterclockwise, less than half a turn;
 * each given as (cos t, sin t)) behind its tangent line as seen from y = (y1, y2), i.e. y . P < 1
 * there (with a margin of 1e-9)? A chain that leaves the circle by an outside reflection at such a
 * point cannot reach y (the reflected ray leaves the tangent line on the far side from y), so no
 * root of that chain lies there. */
bool spc_sphere_arc_unseen(double y1, double y2, const double p0[2], const double p1[2]);

#endif
