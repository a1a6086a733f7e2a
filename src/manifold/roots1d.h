/*
 * manifold/roots1d.h: the roots of a smooth function of one angle sampled on a grid, as the exact
 * one-shape chain enumerations use them (sphere_chains.c, cylinder_chains.c).
 *
 * Given f on grid points t[0..n] (ok[j] false where f is undefined), each cell is first halved
 * (recursively, a few levels) while the target's angle seen from the chain's final segment,
 * atan2(f, ahead), or one of the chain's own angles (its segments' directions) turns by more than
 * 0.08 turn (about half a radian) across it, or f is defined at one end only: a narrow feature of f comes from a
 * segment that swings fast (a reflection near the sharp end of an ellipse, x close to the surface),
 * and a swing shows at the cell's ends even where f's spike does not. Then a root is bracketed by a sign change between neighbours, and a pair of roots between samples by a local extremum of the samples
 * toward zero (three samples of one sign, the middle one nearest zero, and the parabola through
 * them dipping below half the middle one): a parabolic search (golden sections where the parabola is
 * no help) for the extremum between the outer two, stopped as soon as f changes sign, then one
 * bracket on each side. Brackets are refined by regula falsi with the Anderson-Bjorck scaling, first to 1e-6,
 * where a root is dropped unless the function's second output ("ahead", the target in front of the
 * chain's final segment) is positive and the caller accepts it, then to tol. A root within 1e-10 of
 * one kept before is the same.
 */
#ifndef SPC_MANIFOLD_ROOTS1D_H
#define SPC_MANIFOLD_ROOTS1D_H

#include <stdbool.h>

/* Angles per sample the refinement watches, at most. */
#define SPC_ROOTS1D_MAX_ANGLES 10

/* The direction (x, y) as a fraction of a full turn, in [0, 1): monotone in the angle (the "diamond
 * angle" over 4, within a factor 1.6 of angle / 2 pi in its rate), one division instead of atan2.
 * The angles fn reports are these. */
static inline double spc_roots1d_turns(double x, double y)
{
    double ax = x < 0.0 ? -x : x, ay = y < 0.0 ? -y : y, s = ax + ay;
    if (!(s > 0.0))
        return 0.0;
    double r = y >= 0.0 ? (x >= 0.0 ? y / s : 1.0 - x / s) : (x < 0.0 ? 2.0 - y / s : 3.0 + x / s);
    return 0.25 * r;
}

/* f(t) and ahead(t), and (if ang is not NULL) the chain's angles at t (its segments' directions, as
 * many as the caller's nang); false where f is undefined. */
typedef bool (*spc_roots1d_fn)(const void *ctx, double t, double *f, double *ahead, double *ang);

/* Writes the roots to roots (at most max_roots) and returns their number; f, ahead and the nang
 * angles (ang[j * SPC_ROOTS1D_MAX_ANGLES + i]) at the grid points, as fn gives them; tol: the bracket
 * width at
 * which refinement stops (absolute, in t); skip (NULL: none): cells (t[j], t[j + 1]) whose roots the
 * caller knows to be of no use (they are not looked for there). */
/* Whether a root (near t, to about 1e-6) is of use to the caller (a chain whose heights fit), before
 * it is refined further; NULL: every root is. */
typedef bool (*spc_roots1d_accept)(const void *ctx, double t);

int spc_roots1d(spc_roots1d_fn fn, spc_roots1d_accept accept, const void *ctx, const double *t, const double *f,
                const double *ahead, const double *ang, int nang, const bool *ok, int n, const bool *skip, double tol,
                double *roots, int max_roots);

#endif
