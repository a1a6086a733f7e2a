/*
 * manifold/flat_chains.h: every specular chain through flat faces, exactly.
 *
 * Glass slabs, cubes, prisms and flat mirrors are meshes whose triangles lie in a few planes. At a
 * plane the refracted or reflected direction depends only on the arriving direction, and a chain
 * from x through the planes of faces F1..Fk (in that order, each crossed or reflected off from a
 * given side) to y is a stationary point of its optical path length
 *
 *     L(p1..pk) = eta_0 |p1 - x| + eta_1 |p2 - p1| + ... + eta_k |y - pk|,   pi on the plane of Fi,
 *
 * eta_j the index of refraction along segment j (Fermat's principle: at each vertex the tangential
 * parts of eta_{i-1} w_in and eta_i w_out agree, which is Snell's law where the segments lie on
 * opposite sides of the plane and the mirror law where on the same side with one index). Each term
 * is the norm of an affine function of the vertices' plane coordinates, so L is convex: a chain,
 * where it exists, is L's minimum, and a sequence of faces holds at most one chain (away from
 * degenerate, collinear configurations). So the enumeration walks the sequences of faces and sides
 * that can hold a path (the pruning below), minimizes L by Newton's method (damped, with a line
 * search: global convergence on a convex function; where the refracting faces are parallel once the
 * reflections are unfolded, from a closed form's minimum, flat_chains.c), and keeps a minimum whose
 * segments have length, whose vertices lie on the sides the sequence says and inside their faces'
 * polygons. Each is polished in 3D by the angular solver (spc_snee_exact_polish_flat), whose trace
 * proves the segments before the last unblocked and that nothing else lies between.
 *
 * Faces: a shape's triangles grouped by plane (same unit normal and offset): a cube or a slab gives
 * 6, a triangular prism 5. The exterior side of a face is the side its normal points to (the winding,
 * flip_normals applied), where the dielectric's outer index is; the segments between casters take
 * index 1 and a segment inside a dielectric its eta = int_ior / ext_ior (only the ratios enter
 * Snell's law at a face, so any common exterior medium works).
 *
 * Pruning (necessary conditions only, so nothing is lost): x in front of the first face on the side
 * the chain arrives from, y in front of the last on the side it leaves to; no two consecutive faces
 * in one plane; for consecutive faces Fi, Fi+1 some corner of Fi lies on the side of Fi+1's plane the
 * path arrives from, and some corner of Fi+1 on the side of Fi's plane the path leaves to; the
 * medium between two vertices is the same as seen from both (inside one dielectric, or outside);
 * the caps of directions each segment can take (from x toward a face's corners, between two faces'
 * corners, through each event: reflections exactly, refractions within their Lipschitz bound) meet,
 * propagated from x while walking and, for a complete sequence, back from y.
 *
 * Shapes handled (spc_flat_chain_shape): a mesh without vertex normals (or face_normals) of at most
 * SPC_FLAT_MAX_FACES planes, a smooth dielectric or a smooth conductor (a flat mirror; one-sided: its
 * faces reflect on their exterior side only; or two-sided, conductors on both sides), not a normal
 * map (plane_chains.h), no emitter. Chains: 1 to SPC_FLAT_MAX_VERTICES
 * vertices, every vertex on such a shape (one shape or several: two slabs' four faces), conductor
 * vertices reflect, dielectric vertices refract, or reflect when spc_snee_params.reflect (a
 * reflection off glass alone, or a total internal reflection in a longer chain, on any of its
 * shapes).
 *
 * What is missed: chains with a segment whose medium the two faces at its ends disagree on (glass
 * touching glass of another index, a face inside another shape); spc_flat_chain_covers leaves those
 * to the randomized attempts. Chains longer than SPC_FLAT_MAX_VERTICES are the randomized
 * attempts' too.
 */
#ifndef SPC_MANIFOLD_FLAT_CHAINS_H
#define SPC_MANIFOLD_FLAT_CHAINS_H

#include <stdbool.h>

#include "manifold/chain.h"

struct spc_snee_query;

/* Planes per shape the enumeration takes (a cube 6, a prism 5): the face sequences grow as the
 * number of faces to the power of the chain's length, so a faceted ball is left to the solver. */
#define SPC_FLAT_MAX_FACES 16

/* Longest chain enumerated: up to 4 vertices (two slabs' four faces; a cube's internal reflection:
 * in, two total internal reflections, out) at every call of specular NEE (specular_nee.c,
 * flat_max), 5 and 6 each on its own share of the calls (specular_nee.c, flat_psi; 0 by default): a total
 * internal reflection off a slab's thin side face on the way through two slabs. Left to randomized
 * attempts, such a chain is found so rarely that its <1/p_solve> made a heavy tail that read 2-4% low
 * where it lands (bench/RESULTS.md, "Flat bias hunt"). */
#define SPC_FLAT_MAX_VERTICES 6
/* Where the longer chains run, the chains of up to this many vertices are enumerated at every call
 * (specular_nee.c, flat_max): two slabs' four interfaces, a slab's total internal reflections, each
 * chain counted once (psi 1), instead of with 1 / psi on the long pass's few calls, whose tail held
 * most of the small-light slabs' error (bench/RESULTS.md, "Planar" and "Flat 2"). The longer ones
 * on the shares spc_snee_params.flat5_p and flat6_p. */
#define SPC_FLAT_EVERY_CALL 4

/* Is s a flat-faced shape these chains handle? (Groups its faces on first use.) */
bool spc_flat_chain_shape(const spc_shape *s);
/* Is s such a shape, closed and convex (a slab: a cube's mesh, not an open pane)? */
bool spc_flat_chain_closed(const spc_shape *s);
/* The planes of such a shape's faces: unit normal n[i] toward the exterior and offset d[i] (n . p for
 * p on the plane), at most max (SPC_FLAT_MAX_FACES holds all); returns their number, 0 where s is not
 * such a shape. */
int spc_flat_shape_planes(const spc_shape *s, spc_vec3 *n, double *d, int max);
/* Does face i of such a shape (spc_flat_shape_planes' i-th plane) hold the point p of its plane,
 * within tol (a distance) of one of its triangles? false where s is not such a shape. */
bool spc_flat_shape_face_holds(const spc_shape *s, int i, spc_vec3 p, double tol);
/* May a ray from the point a through face i of such a shape (within margin of its triangles' side
 * planes through a) meet the sphere (c, R)? false only where every triangle's pyramid from a lies
 * more than margin from the sphere; true where s is not such a shape. */
bool spc_flat_shape_face_cone_meets(const spc_shape *s, int i, spc_vec3 a, spc_vec3 c, double R, double margin);
/* Is face i of such a shape s hidden from the point z by another closed convex flat caster of sc
 * (spc_chain_casters_of(sc, any_surface)): does every segment from z to the face cross the inside
 * of one face of one such caster? The walk's test of a first and a last vertex's face, at its
 * tolerance for a problem of size `scale`. false where s is not such a shape. */
bool spc_flat_shape_face_shadowed(const spc_scene *sc, bool any_surface, const spc_shape *s, int i, spc_vec3 z,
                                  double scale);
/* Is such a shape a one-sided mirror (its faces reflect on their exterior side only)? */
bool spc_flat_shape_front_only(const spc_shape *s);
/* Is c one of the chains spc_flat_chains_all enumerates (1 to SPC_FLAT_MAX_VERTICES vertices, all
 * on such shapes, the events above, each segment's medium agreed on by its two ends; reflect as
 * spc_snee_params.reflect)? */
bool spc_flat_chain_covers(const spc_chain *c, bool reflect);
/* The same through flat faces alone, of up to SPC_CHAIN_MAX_VERTICES vertices and with partial
 * reflections off glass anywhere in the chain: the paths light tracing makes through slabs
 * (path_lt.h), of which the enumeration counts only those spc_flat_chain_covers takes. */
bool spc_flat_chain_faces(const spc_chain *c, bool reflect);
/* Every such chain from q->x to q->y of q->min_chain (0: 1) to q->max_chain vertices, at most
 * max_out, written to out (polished and traced: each segment before the last proven unblocked; the
 * last is checked by spc_snee_chain_value). Adds the chain traces it spends to *iterations. */
int spc_flat_chains_all(const struct spc_snee_query *q, spc_chain *out, int max_out, int *iterations);
/* The roots of the longer lengths a walk met, kept to be polished later (spc_flat_chains_all_later,
 * spc_flat_chains_later); storage the caller owns. */
#define SPC_FLAT_LATER_MAX 48
typedef struct spc_flat_later_root {
    const spc_shape *shapes[SPC_FLAT_MAX_VERTICES];
    unsigned char ev[SPC_FLAT_MAX_VERTICES];
    spc_vec3 dir; /* the first segment's direction, from x offset off its surface */
    int k;
} spc_flat_later_root;
typedef struct spc_flat_later {
    unsigned lengths; /* the lengths kept (bit k: k vertices) */
    bool overflow;    /* more roots than SPC_FLAT_LATER_MAX: spc_flat_chains_later walks again */
    int n;
    spc_flat_later_root root[SPC_FLAT_LATER_MAX];
} spc_flat_later;
/* spc_flat_chains_all, and in the same walk the roots of each further length k with bit k of
 * later_lengths set (past q's lengths), kept in *later: a call that also wants the chains of 3 and
 * 4 vertices walks the faces once, the longer sequences growing from the shorter ones. */
int spc_flat_chains_all_later(const struct spc_snee_query *q, unsigned later_lengths, spc_flat_later *later,
                              spc_chain *out, int max_out, int *iterations);
/* The chains of exactly k vertices from the roots *later kept, polished: those
 * spc_flat_chains_all writes for q with min_chain = max_chain = k, in the same order (at most
 * max_out); where k was not kept, or the roots overflowed, that call itself. */
int spc_flat_chains_later(const struct spc_snee_query *q, const spc_flat_later *later, int k, spc_chain *out,
                          int max_out, int *iterations);
/* The same with every reflection off glass allowed, total or partial, anywhere in the chain
 * (q->params.reflect not read): the chains spc_flat_chain_faces takes, up to SPC_FLAT_MAX_VERTICES
 * vertices; need_glass_reflect: only those of two or more vertices with a reflection off glass
 * among them (the others are spc_flat_chains_all's). Light tracing's joins of a light point to the
 * pinhole (integrator/path_lt_view.h) use it. */
int spc_flat_chains_all_partial(const struct spc_snee_query *q, bool need_glass_reflect, spc_chain *out, int max_out,
                                int *iterations);
/* The face sequences of exactly k vertices from x to y through the flat-faced casters of sc that pass
 * the pruning (any_surface and reflect as spc_flat_chain_roots's): the number that function solves,
 * counted without solving them (a plan's cost estimate, snee_plan.c). */
int spc_flat_chain_sequences(const spc_scene *sc, bool any_surface, bool reflect, spc_vec3 x, spc_vec3 y, int k);

/* ---- exposed for tests ---- */

/* The roots of the planar problem, before the 3D polish: for each chain of exactly k vertices from
 * x to y through the flat-faced casters of sc (any_surface as spc_snee_query's; reflect as
 * spc_snee_params.reflect), its vertices (k points each, written to pts[k * i ..]) and events; at
 * most max roots; returns their number. *sequences (may be NULL) receives the number of face
 * sequences solved. */
int spc_flat_chain_roots(const spc_scene *sc, bool any_surface, bool reflect, spc_vec3 x, spc_vec3 y, int k,
                         spc_vec3 *pts, unsigned char *events, int max, int *sequences);
/* spc_flat_chain_roots with the bound that ends a sequence's solve once L over the sequence's faces
 * provably exceeds L's minimum (the minimum lies outside the faces: no root), or once it proves
 * that the minimum over the faces has a segment of no length (a kink: no root), on or off (bound;
 * spc_flat_chain_roots and the renderer keep it on); *bound_ends (may be NULL) receives the number
 * of solves it ended. The roots are the same either way. */
int spc_flat_chain_roots_bound(const spc_scene *sc, bool any_surface, bool reflect, spc_vec3 x, spc_vec3 y, int k,
                               spc_vec3 *pts, unsigned char *events, int max, int *sequences, bool bound,
                               int *bound_ends);
/* spc_flat_chain_roots_bound with the closed form for sequences whose refracting faces are parallel
 * once the reflections are unfolded (flat_chains.c, parallel_start: the start of the Newton steps on
 * L, which certify it, or the proof that a reflecting face is not crossed) on or off (parallel; the
 * renderer keeps it on); *closed (may be NULL) receives the number of solves it settled. The roots
 * are the same either way, to the convergence test's precision. */
int spc_flat_chain_roots_solve(const spc_scene *sc, bool any_surface, bool reflect, spc_vec3 x, spc_vec3 y, int k,
                               spc_vec3 *pts, unsigned char *events, int max, int *sequences, bool bound, bool parallel,
                               int *bound_ends, int *closed);
/* spc_flat_chain_roots with partial as spc_flat_chains_all_partial's (0: the enumeration's events;
 * 1: any reflection off glass; 2: the same, only sequences of 2 or more vertices with one) and the
 * walk's bound on the vertices a sequence still needs to reach y (flat_chains.c, bound_near) on or
 * off (near; the renderer keeps it on): it skips the vertices from which no sequence of at most k
 * vertices can reach y by the walk's own rules, so the sequences solved, their order and the roots
 * are the same either way. *nodes (may be NULL) receives the number of vertices the walk chose. */
int spc_flat_chain_roots_near(const spc_scene *sc, bool any_surface, bool reflect, int partial, spc_vec3 x, spc_vec3 y,
                              int k, spc_vec3 *pts, unsigned char *events, int max, int *sequences, bool near,
                              long *nodes);

#endif
