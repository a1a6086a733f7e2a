/*
 * integrator/path_graze.h: grazing directions along a mirror cylinder's wall, a second strategy for
 * the path tracer's paths receiver -> many reflections on the wall -> area light (the whispering
 * gallery).
 *
 * Inside a mirror cylinder (the mirror ring's open cup) a ray that leaves a receiver close to the
 * wall nearly along it creeps along the wall: each reflection keeps its grazing angle alpha (the
 * ray's distance to the axis is kept) and its axial direction, so it climbs the wall in chords of
 * 2 R sin(alpha) and leaves over the rim after about L / (2 R sin(alpha) tan(theta)) reflections
 * (theta: its elevation over the plane normal to the axis). From a point at distance eps of the
 * wall only alpha >= acos(1 - eps / R) exists, so the light comes to the wall's foot through chains
 * of 9 to dozens of reflections, each a thin, bright image of the light that BSDF sampling finds
 * about once in 1e4-1e5 samples with value Le * albedo (hundreds); specular NEE enumerates at most
 * SPC_CHAIN_MAX_VERTICES vertices (the cylinder's longer chains: six), so those paths had weight 1
 * and held the mirror ring's one-pixel seeds (bench/RESULTS.md, "The mirror ring's whispering
 * gallery").
 *
 * The strategy: at a receiver x within eps_g of the wall of such a cylinder (and inside it, between
 * its ends), one direction d is drawn from p_g: one of the two tangent directions at the nearest
 * wall point (probability 1/2 each), turned by beta uniform in [-beta_max, beta_max] toward or away
 * from the wall (beta_max: the largest angle whose grazing angle at the wall stays below alpha_max),
 * at an elevation theta uniform in [theta_lo, theta_hi] (the elevations under which a wall point
 * whose tangent points near a light sees that light's bounding sphere: the elevation of a ray is
 * kept by the reflections, and its last reflection leaves it nearly along the wall's tangent);
 * p_g = 1 / (2 * 2 beta_max * (theta_hi - theta_lo) * cos(theta)) in solid angle. The ray is
 * followed through delta reflections on that cylinder only; if it reaches an area light after
 * SPC_GRAZE_MIN_REFLECTIONS to SPC_GRAZE_MAX_REFLECTIONS of them, the path counts f cos / p_g *
 * (the reflections' weights) * Le with the power heuristic's weight p_g^2 / (p_g^2 + p_b^2), p_b the
 * receiver's BSDF density of d. BSDF sampling's own paths of that kind (the same receiver, the same
 * cylinder, the same reflection counts) get p_b^2 / (p_g^2 + p_b^2) (spc_path_graze_track). Every
 * other path is this strategy's 0 and BSDF sampling's weight as before. The counts start past
 * SPC_CHAIN_MAX_VERTICES, beyond any chain specular NEE makes or its exclusion track follows, so
 * those paths have no other strategy (the light guides' light tracing, which follows chains from a
 * receiver too, turns this off). Unbiased for any p_g: the two weights of each path sum to one.
 * The draws come from a stream forked from the sampler, so no dimension moves.
 */
#ifndef SPC_INTEGRATOR_PATH_GRAZE_H
#define SPC_INTEGRATOR_PATH_GRAZE_H

#include "integrator/context.h"
#include "manifold/chain.h"

/* Mirror cylinders the strategy serves (the first ones among the scene's shapes). */
#define SPC_GRAZE_MAX_CYLINDERS 4
/* Reflection counts of the paths it makes: past the chains specular NEE makes or follows. */
#define SPC_GRAZE_MIN_REFLECTIONS (SPC_CHAIN_MAX_VERTICES + 1)
/* And at most: a ray closer to the wall creeps on for hundreds of reflections (one ray each); past
 * this count BSDF sampling keeps them alone. At eps = 0.1 mm on the mirror ring (R 0.8, L 0.45)
 * chains of about 45 reflections reach the light. */
#define SPC_GRAZE_MAX_REFLECTIONS 64
/* The stream key of the grazing draws (spc_sampler_fork_rng). */
#define SPC_GRAZE_STREAM 0x6772617a696e6721ULL

typedef struct spc_graze_cylinder {
    const spc_shape *shape;
    spc_vec3 o, a;          /* the axis: base point and unit direction */
    double len, radius;     /* the axis' length, the circular section's radius */
    double theta_lo, theta_hi; /* the elevation band, over the plane normal to a */
    double alpha_max;       /* the largest grazing angle drawn */
    double eps_max;         /* receivers within this distance of the wall: radius (1 - cos alpha_max) */
} spc_graze_cylinder;

typedef struct spc_path_graze {
    int n;
    spc_graze_cylinder c[SPC_GRAZE_MAX_CYLINDERS];
} spc_path_graze;

/* Fills g from the scene (finalized): the circular mirror cylinders (cylinder_chains.h's kind:
 * a conductor, or twosided over conductors) with an elevation band toward the area lights that
 * lies strictly above or below the normal plane. Returns whether there is one. */
bool spc_path_graze_init(spc_path_graze *g, const spc_scene *sc);

/* The grazing state of a path: the receiver it left last, the cylinder and densities of the
 * direction it left along, and the reflections on that cylinder since. */
typedef struct spc_graze_track {
    bool live;
    int cyl;   /* index into spc_path_graze.c */
    int k;     /* reflections on it since the receiver */
    double pg; /* p_g of the direction left along */
    double pb; /* the BSDF's density of it */
} spc_graze_track;

/* Does the strategy run in this render (ctx->graze set, the path integrator with specular NEE and
 * without the light guides' light tracing)? */
bool spc_path_graze_enabled(const spc_render_ctx *ctx, bool lg_enabled);

/* p_g of direction d at the receiver x (0 where x is not within eps_max of a served cylinder's wall
 * or d is outside its band). */
double spc_path_graze_pdf(const spc_path_graze *g, const spc_hit *x, spc_vec3 d);
/* A direction d drawn from p_g at the receiver x, with its density; false where x is not within
 * eps_max of a served cylinder's wall. Three numbers from rng. */
bool spc_path_graze_sample(const spc_path_graze *g, const spc_hit *x, spc_rng *rng, spc_vec3 *d, double *pdf);

/* The strategy's term at the receiver h (wo toward the previous vertex; segments: the path's
 * segments up to h), to be multiplied by the throughput that reached h; zero where h is not
 * within eps_max of a served cylinder's wall. rng: a stream of its own. */
spc_rgb spc_path_graze_estimate(const spc_render_ctx *ctx, const spc_hit *h, spc_vec3 wo, int segments, spc_rng *rng);

/* The track after the path scattered at h (wo toward the previous vertex) along wi (its lobe;
 * guided: drawn from the caustic guide's mixture, where the strategy does not run). */
void spc_path_graze_scattered(const spc_render_ctx *ctx, spc_graze_track *t, const spc_hit *h, spc_vec3 wo,
                              spc_vec3 wi, unsigned lobe, bool guided);

/* BSDF sampling's weight at an emitter hit (h) of the path the track describes: p_b^2 / (p_g^2 +
 * p_b^2) where the strategy makes that path too, else 1. */
double spc_path_graze_bsdf_weight(const spc_render_ctx *ctx, const spc_graze_track *t, const spc_hit *h);

#endif
