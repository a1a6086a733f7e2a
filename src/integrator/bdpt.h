/*
 * integrator/bdpt.h: bidirectional path tracing and the particle tracer (bdpt.c).
 */
#ifndef SPC_INTEGRATOR_BDPT_H
#define SPC_INTEGRATOR_BDPT_H

#include "integrator/context.h"

/* Bidirectional path tracing (bdpt.c): one camera subpath for this ray and one light subpath, every
 * (s, t) strategy; t = 1 strategies splat into tls. With ctx->kind SPC_INTEGRATOR_PTRACER only
 * the light subpath is traced and each of its vertices is joined to the camera (t = 1, unweighted:
 * the one strategy for each path length), as Mitsuba 3's ptracer: out->L is zero, the image is in
 * the splats. */
void spc_bdpt_sample(const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray, spc_sampler *smp,
                     spc_sample_out *out);
/* Subpaths cut short by the fixed vertex arrays of bdpt.c since the program started (a path
 * that long only occurs with max_depth -1, and Russian roulette makes it astronomically rare). */
uint64_t spc_bdpt_truncated_paths(void);

/* The pool of light vertices (bdpt_pool.h), with ctx->pool_model set. Before a pass's camera
 * samples: spc_bdpt_pool_trace traces the light subpaths of pixels [x0, x1) x [y0, y1) of pass
 * `pass` (the streams bdpt's camera samples there would use), splats their light tracing (t = 1)
 * into tls and keeps their vertices in tls->lv; spc_bdpt_pool_index then gathers the connectible
 * vertices of a pass's items, in item order, into its pool, which the pass's tls->pool points to
 * while its camera samples run. Both false if out of memory. */
bool spc_bdpt_pool_trace(const spc_render_ctx *ctx, spc_tls *tls, int pass, uint64_t seed, int x0, int y0, int x1,
                         int y1);
struct spc_bdpt_pool;
bool spc_bdpt_pool_index(const spc_render_ctx *ctx, const spc_tls *items, int nitems, struct spc_bdpt_pool *pool);
/* The share of the camera's first hits (non-delta surfaces, film positions uniform over the rendered
 * window, SPC_BDPT_PROBE_RAYS of them, fixed streams from seed) whose light sample is unoccluded and
 * nonzero: low where the camera sees mostly indirectly lit surfaces (1 if nothing is hit). */
double spc_bdpt_pool_direct_share(const spc_render_ctx *ctx, uint64_t seed);
/* The pool's selection model for ctx's scene and camera from a pilot seeded by `seed` (one thread,
 * deterministic); M = connections per camera vertex. false if out of memory (then release m). */
struct spc_bdpt_pool_model;
bool spc_bdpt_pool_learn(const spc_render_ctx *ctx, uint64_t seed, int connections, struct spc_bdpt_pool_model *m);

/* Light subpaths aimed at the glass and mirror casters (bdpt.c). At a point p (normal n) of an area
 * light the emission direction is drawn from the mixture
 *     p(w) = (1 - a) cos(n, w) / pi + a (1 / m) sum_i [w in cone_i] / omega_i,
 * cone_i the directions from p toward caster i's sphere (solid angle omega_i), over the m cones whose
 * sphere p lies outside of and whose centre lies above p's horizon (a = 0 where there is none). In an
 * open scene few of a small light's cosine-distributed directions meet a glass ball, yet the light
 * tracing (t = 1) of its caustic and of the light it refracts into its shadow needs exactly those;
 * every MIS weight uses the mixture's density, so the estimate stays unbiased for any a. */
/* The camera subpath's first hit z1 (a surface without delta lobes, seen from the camera) draws its
 * direction from the same cones in the mixture
 *     p(w) = (1 - cam) pdf_bsdf(w) + cam (1 / m) sum_i [w in cone_i] / omega_i,
 * cone_i from z1 above its surface (the side the camera sees). It serves the caustics of light that
 * reached a caster after a diffuse bounce (a wall lit by a nearby light, focused by a glass ball onto the floor): the light
 * subpath finds those only after a random bounce into the caster, and the camera subpath after a
 * random bounce from the floor; cam scales with that indirect light's share of the casters' light.
 * Every MIS weight uses the mixture's density at z1 (not with the pool, nor where specular NEE
 * runs at z1). */
#define SPC_BDPT_AIM_CONES 8
typedef struct spc_bdpt_aim {
    double a; /* the cones' share of the mixture (0: emission by the light's own cosine law) */
    double cam; /* the cones' share at the camera's first hit (0: its BSDF alone) */
    int n;    /* casters' spheres: centres and radii */
    spc_vec3 c[SPC_BDPT_AIM_CONES];
    double r[SPC_BDPT_AIM_CONES];
} spc_bdpt_aim;
/* The aim for ctx's scene: the spheres around the first SPC_BDPT_AIM_CONES casters (a sphere's own,
 * else the fitted or bounding sphere, as the caustic guide's cones), and a = share times the fraction
 * of pilot rays drawn from the mixture's cones (SPC_BDPT_AIM_PILOT rays, a fixed stream) whose first
 * hit is a caster: near 0 where the casters are hidden from the lights (a bulb in a shade); cam =
 * camera_share times the share of the power reaching the casters after a bounce off a non-delta
 * surface (a pilot of light walks, a fixed stream), where a > 0, and 0 unless a pilot of camera rays
 * finds that the light coming through the cones after a bounce holds a share of the second moment of
 * what the camera's first hits reflect worth aiming for (the casters show those hits something much
 * brighter than the rest of what they see: a wall's hot spot next to the light, through a glass
 * ball). false (a = 0, cam = 0) where no area light, no caster or no pilot ray reaches one. */
bool spc_bdpt_aim_init(const spc_render_ctx *ctx, double share, double camera_share, spc_bdpt_aim *aim);

/* ---- exposed for tests ---- */
/* With ctx->pool_model set: traces `paths` light subpaths and camera subpaths (through uniform film
 * positions of the rendered window; fixed streams from seed), joins every pair of their connectible
 * vertices (s, t >= 2), and returns the largest relative difference between the connection's MIS
 * weight from the subpaths' precomputed sums (what bdpt uses with the pool) and the same weight
 * walked over the whole path, with and without the pick's numerator; *joins gets the pairs
 * compared. */
double spc_bdpt_pool_weight_gap(const spc_render_ctx *ctx, uint64_t seed, int paths, long *joins);

#endif
