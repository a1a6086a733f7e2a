/*
 * manifold/specular_nee.h: specular next-event estimation, independent of the solver.
 *
 * At a non-delta vertex x of a camera path, one light point y is sampled (light chosen in
 * proportion to power, then uniformly by area on its shape; point and spot lights are their
 * position), a solver looks for a chain of 1..max_chain specular vertices connecting x to y
 * (chain.h), and the path x -> chain -> y adds
 *
 *     f_x(wo, d0) |cos| * prod_i T_i * Le(y, -d_k) * G(x <-> y) / p(y) * <1/p_solve>,
 *
 * T_i the delta-lobe factor at vertex i (spc_bsdf_specular_throughput), G the generalized
 * geometry term |dw(x)/dA(y)| of the whole chain (spc_chain_geometry), p(y) the light sample's area
 * density, and <1/p_solve> an unbiased estimate of the reciprocal probability that one randomized
 * solver attempt finds this very solution: the number of further independent attempts until it is
 * found again (a geometric variable of mean 1/p; Zeltner, Georgiev and Jakob 2020, "Specular
 * Manifold Sampling", sec. 4.3). Summed over solutions, the expectation is the exact sum of every
 * chain's contribution. Attempts are capped at max_trials; a capped count underestimates 1/p
 * (expectation (1 - (1-p)^cap) / p instead of 1/p): bias only for solutions found with p below
 * about 3 / cap, and counted in spc_snee_stats.capped. A deterministic seed (SEED_LIGHT) skips the
 * count (1/p = 1): unbiased only where a single solution exists, as in Hanika et al.'s MNEE.
 *
 * Which paths it produces, exactly (the path tracer drops the same paths when it reaches them by
 * BSDF sampling, spc_snee_track_*, so nothing is counted twice):
 *   - x is a receiver (shape caustic_flags & SPC_CAUSTIC_RECEIVER) whose BSDF has a non-delta lobe,
 *     and the direction leaving x is a non-delta sample;
 *   - then k vertices, 1 <= k <= max_chain (also limited by max_depth), each on a shape whose BSDF
 *     is a smooth specular interface (spc_bsdf_is_specular_interface), with no emitter, allowed in
 *     chains of k vertices (spc_chain_caster_allowed), where the light REFLECTS off conductors and
 *     REFRACTS through dielectrics; with params.reflect it may also REFLECT off dielectrics (outside
 *     or inside, total internal reflection included), otherwise such a reflection is not a chain
 *     vertex;
 *   - then the surface of an area emitter (point and spot lights cannot be hit; environment and
 *     directional lights are not handled: their chains stay with BSDF sampling).
 * With params.camera (spc_snee_camera) the same chains also start at the camera's pinhole, which
 * takes the receiver's place (the camera ray's direction is its "non-delta sample").
 */
#ifndef SPC_MANIFOLD_SPECULAR_NEE_H
#define SPC_MANIFOLD_SPECULAR_NEE_H

#include <stdint.h>

#include "core/rng.h"
#include "manifold/chain.h"
#include "manifold/receiver.h"
#include "manifold/snee_options.h"
#include "manifold/solver.h"

/* The light point of a query (shared by the solvers): a light chosen in proportion to power, then
 * a point y on it, written to q->y, q->ny, q->light_size; *e the light, *uv the point's texture
 * coordinates, *p_y its density (area measure, the light's choice included). A sphere light is
 * sampled uniformly on the cap that faces the casters' bounding sphere (no chain ends elsewhere on
 * it); other area lights uniformly by area; point and spot lights are their position. False (no
 * contribution) if no chain can reach the point: no caster, an environment or directional light,
 * or a point that faces away from every caster. */
bool spc_snee_sample_light(const spc_scene *sc, bool any_surface, spc_rng *rng, spc_snee_query *q,
                           const spc_emitter **e, spc_vec2 *uv, double *p_y);

/* The long pass's own light point (params.long_p's longer chains) for the query q, whose point
 * spc_snee_sample_light drew on e with the density *p_y: where params.light_x applies at q (a surface
 * receiver, a sphere light), a point drawn from the cap facing the casters' sphere alone (rng: two
 * numbers), at the density it had without light_x; lq (a copy of q) gets the point (y, ny, y_err,
 * p_y; fit, the caller's storage, emptied, as its cache of the fitted spheres' solutions toward it),
 * *uv its texture coordinates, *p_y q's density over the mixture's times the cap's (the query's
 * other factors kept). Where light_x does not apply: true, nothing drawn, lq, *uv and *p_y as they
 * were. False where the cap's point faces away from every caster (no chain: the long pass makes no
 * attempt; the cap's density is 0 there, as spc_snee_light_pdf has it). */
struct spc_fit_roots;
bool spc_snee_sample_long_light(const spc_snee_query *q, const spc_emitter *e, spc_rng *rng, spc_snee_query *lq,
                                struct spc_fit_roots *fit, spc_vec2 *uv, double *p_y);

/* The density in which spc_snee_sample_light draws the point y (normal ny) on emitter e: the
 * light's probability times the point's area density; 0 where it never draws y. */
double spc_snee_light_pdf(const spc_scene *sc, bool any_surface, const spc_emitter *e, spc_vec3 y, spc_vec3 ny);
/* The same for a query at a surface receiver at xp with the parameters p (params.light_x: a share of a
 * sphere light's points drawn in the cone from xp, the density the mixture's); spc_snee_light_pdf
 * where light_x is 0 or does not apply. */
double spc_snee_light_pdf_at(const spc_scene *sc, const spc_snee_params *p, const spc_emitter *e, spc_vec3 y,
                             spc_vec3 ny, spc_vec3 xp);

/* The power-heuristic weight of specular NEE's light sample against BSDF sampling (params.mis):
 * p_y and p_b as there. */
static inline double spc_snee_mis_weight(double p_y, double p_b)
{
    double a = p_y * p_y, b = p_b * p_b;
    return a + b > 0.0 ? a / (a + b) : 0.0;
}

/* For the path integrator with params.mis: the weight of a BSDF-sampled path that specular NEE
 * covers (spc_snee_track_covers), which left the receiver x (toward wo, specular NEE's budget there
 * max_chain) along d0 and reached the area emitter e at the hit `light` through `k` chain vertices
 * with these events (the track's; NULL: the BSDFs' own). Retraces the chain from x for its geometry
 * term, and for psi the straight-line solution from x to the light point where specular NEE would
 * have looked for one; 0 (the path dropped, as without MIS) if the retrace does not reproduce it. */
double spc_snee_mis_bsdf_weight(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                                spc_vec3 d0, int max_chain, int k, const unsigned char *events, const spc_hit *light);
/* The same for any receiver r (receiver.h): a path its own sampling (BSDF, phase function, camera
 * ray) sent along d0. */
double spc_snee_receiver_weight(const spc_scene *sc, const spc_snee_params *p, const spc_receiver *r, spc_vec3 d0,
                                int max_chain, int k, const unsigned char *events, const spc_hit *light);
/* The same where another strategy makes the path too (params.alt_ratio or alt_chain_ratio):
 * returns the receiver's own sampling's weight and writes the other strategy's to *w_alt; with
 * specular NEE's weight of the same path the three sum to one. Without another strategy *w_alt is 0
 * and the return spc_snee_receiver_weight's. */
double spc_snee_receiver_weights(const spc_scene *sc, const spc_snee_params *p, const spc_receiver *r, spc_vec3 d0,
                                 int max_chain, int k, const unsigned char *events, const spc_hit *light,
                                 double *w_alt);

/* Does params.exact's enumeration (sphere_chains.h, cylinder_chains.h, plane_chains.h) hold every
 * chain of the query: one caster, a sphere x is outside of, a mirror cylinder, or (not from the
 * camera) a normal-mapped plane? */
bool spc_snee_exact_covers_all(const spc_snee_query *q);

/* The specular NEE estimate at the path vertex x (to be multiplied by the path throughput), with
 * chains of at most max_chain vertices (the caller's budget, <= params->max_chain). st may be
 * NULL. */
spc_rgb spc_specular_nee(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                         int max_chain, spc_rng *rng, spc_snee_stats *st);
/* The same with the longer chains of params.long_p bounded by long_max vertices (the path's depth
 * left; spc_specular_nee: SPC_CHAIN_MAX_VERTICES). */
spc_rgb spc_specular_nee_depth(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                               int max_chain, int long_max, spc_rng *rng, spc_snee_stats *st);

/* The same at any receiver (receiver.h): a surface point as spc_specular_nee_depth; a medium point
 * (volpath) with chains of at most max_chain vertices, the media's transmittance in the chain's
 * value and the phase function in its place of the BSDF (not with rough vertices: 0). The camera's
 * pinhole has its own entry, spc_snee_camera. */
spc_rgb spc_specular_nee_at(const spc_scene *sc, const spc_snee_params *p, const spc_receiver *r, int max_chain,
                            int long_max, spc_rng *rng, spc_snee_stats *st);

/* The contribution of one solved chain toward the light point of q on emitter e (uv: the
 * point's texture coordinates), without p(y) and <1/p_solve>: zero if the chain is not one specular
 * NEE produces (length, caustic flags), its last segment is blocked, or any factor vanishes. */
spc_rgb spc_snee_chain_value(const spc_snee_query *q, const spc_emitter *e, spc_vec2 uv, const spc_chain *c);

/* Contributions one spc_snee_camera call can return: the straight-line solution, solve_all's and one
 * more. */
#define SPC_SNEE_CAMERA_SPLATS 18

/* A contribution of specular NEE from the camera: film position (continuous pixels of the full film)
 * and value (to splat as it is: the camera's importance and the samples per pass are in it). */
typedef struct spc_snee_splat {
    double fx, fy;
    spc_rgb value;
} spc_snee_splat;

/* Specular NEE from the pinhole of cam (perspective; nothing for other cameras): one light point,
 * chains of 1..max_chain vertices to it (the solver's estimate, unbiased; params.long_p's longer
 * chains on a sphere up to long_max vertices), each written to out (at most max_out) with its film
 * position. cam_scale: the full film's pixel count over the camera samples per pass (the rendered
 * window's pixels). Returns the number written. Chains whose first vertex the camera's rays cannot
 * reach (before the near plane, off the film) are dropped. */
int spc_snee_camera(const spc_scene *sc, const spc_snee_params *p, const struct spc_camera_state *cam,
                    double cam_scale, int max_chain, int long_max, spc_rng *rng, spc_snee_stats *st,
                    spc_snee_splat *out, int max_out);
/* The longest chain the track from the pinhole follows (spc_snee_track.long_max), where the track
 * would follow track_long_max: with params.cam_long the camera query's longer chains on a glass
 * SDF too, within the depth's long_max. */
int spc_snee_camera_long_max(const spc_snee_params *p, int long_max, int track_long_max);

/* The MIS weight of a camera ray along d0 that reached the area emitter at the hit `light` through
 * k chain vertices with these events (params.camera and mis; the path integrator's track from the
 * camera), against spc_snee_camera's light sample: 0 if the retrace from the pinhole does not
 * reproduce the path; 1 if params.camera is off. */
double spc_snee_camera_bsdf_weight(const spc_scene *sc, const spc_snee_params *p, const struct spc_camera_state *cam,
                                   double cam_scale, spc_vec3 d0, int max_chain, int k, const unsigned char *events,
                                   const spc_hit *light);

/* ---- the exclusion that keeps BSDF sampling from counting specular NEE's paths again ---- */
typedef struct spc_snee_track {
    bool live;      /* the path since the last receiver may still be one specular NEE covers */
    int k;          /* chain vertices passed */
    int max_chain;  /* specular NEE's budget at the receiver */
    bool single_ok; /* every vertex allowed in chains of one vertex */
    bool multi_ok;  /* every vertex allowed in chains of more than one */
    bool any_surface;
    bool reflect;   /* dielectric vertices may reflect (params.reflect) */
    int long_max;   /* followed up to this many vertices (params.long_p; <= max_chain: none) */
    unsigned char events[SPC_CHAIN_MAX_VERTICES]; /* the chain event at each vertex passed */
} spc_snee_track;

/* The track of the paths leaving a receiver (a medium point, the pinhole) by its own sampling, where
 * specular NEE ran with chain budget `budget` (0: it did not, and the track is dead) and the longer
 * chains' depth bound long_max (spc_snee_track_long_max). */
void spc_snee_track_begin(spc_snee_track *t, const spc_snee_params *p, int budget, int long_max);

/* Specular NEE's chain budget at x: max_chain if x is a receiver with a non-delta lobe, else 0. */
int spc_snee_budget(const spc_hit *x, int max_chain, bool any_surface);

/* With rough vertices (params->newton.rough and the newton solver; newton.h) specular NEE also
 * covers paths through rough conductors (a glossy reflection) and rough dielectrics (a glossy
 * transmission), which BSDF sampling reaches through glossy lobes and which the path tracer's own
 * light sample at such a vertex reaches too. The three calls below take the params and reduce to
 * the ones above without rough vertices:
 *   - the budget is 0 at a rough chain surface (it is a chain vertex, never a receiver: the paths
 *     through it would be counted by the specular NEE of both of its ends);
 *   - the track follows glossy lobes of the chain event on rough chain surfaces;
 *   - spc_snee_track_covers_light: at a vertex h reached along a tracked path (the track as it is
 *     before scattering at h), is the path that the light sample at h closes toward e (direction wi)
 *     one specular NEE already counted? (h a rough chain surface one vertex within the budget, wi on
 *     the side of its chain event, e an area, point or spot light.) */
int spc_snee_budget_params(const spc_snee_params *p, const spc_hit *x, int max_chain);
void spc_snee_track_scatter_params(spc_snee_track *t, const spc_snee_params *p, const spc_hit *h, unsigned lobe,
                                   int snee_budget, int long_max);
/* How far a track follows chains for params.long_p, given the caller's depth bound long_max (0: not
 * past its max_chain): what the track's long_max is at a receiver, or from the camera. */
int spc_snee_track_long_max(const spc_snee_params *p, int long_max);
/* The probability with which specular NEE's query at a receiver, with chain budget max_chain and
 * the longer chains' depth bound long_max (as spc_specular_nee_depth takes them), enumerates the
 * chains of k vertices through flat faces (flat_chains.h, params.exact): 1 up to the lengths it
 * enumerates at every call, params.flat34_p, flat5_p or flat6_p past them (where the longer chains
 * run: params.mis and long_p), 0 where it never does. Light tracing of point lights
 * (integrator/path_lt.h) weighs its flat chains against specular NEE's with it. */
double spc_snee_flat_psi(const spc_snee_params *p, int max_chain, int long_max, int k);
bool spc_snee_track_covers_light(const spc_snee_track *t, const spc_snee_params *p, const spc_scene *sc,
                                 const spc_hit *h, spc_vec3 wo, spc_vec3 wi, const spc_emitter *e);

/* After BSDF sampling at a path vertex: `snee_budget` is the max_chain specular NEE used there (0 if
 * it did not run: then the path is not tracked), `lobe` the sampled lobe; any_surface and reflect
 * as the params have them. */
void spc_snee_track_scatter(spc_snee_track *t, const spc_hit *h, unsigned lobe, int snee_budget, bool any_surface,
                            bool reflect);
/* At an emitter hit: true if specular NEE already counted this path (drop it). */
bool spc_snee_track_covers(const spc_snee_track *t, const spc_scene *sc, const spc_emitter *e);

#endif
