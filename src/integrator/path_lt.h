/*
 * integrator/path_lt.h: the path tracer's light-traced caustics of point lights and area lights
 * (specular NEE's "ltcaus" option): seen through a diffuse bounce, directly, and through the glass
 * sphere; area lights' also through a tessellated glass ball and a glass SDF. A spot light is
 * traced as a point light, its subpath's throughput its intensity toward the first direction
 * (falloff and image included; zero past its cutoff), the direction's density the same cone toward
 * the casters.
 *
 * The paths (point light) - k chain vertices - x2 - m delta scatterings - x1 - camera, where x1 is
 * the camera ray's first hit and scatters along a non-delta sample, x2 is a receiver where
 * specular NEE runs (the path's second receiver) and the chain is one that specular NEE counts
 * exactly (one glass sphere, k within its budget at x2: spc_sphere_chain_covers), are made by
 * specular NEE at x2 alone in the path tracer. Their value there is the caustic's irradiance at a
 * sampled point, which near a fold grows as d^-1/2: its square is log-divergent, so that estimator
 * has an infinite variance (bench/RESULTS.md, "point_light_ball"). Light tracing makes the same
 * paths with the fold in its density instead: one light subpath per camera sample from a point
 * light toward the casters' bounding sphere, through the chain, scattered at x2 by its BSDF, through
 * m delta scatterings to x1, joined to the pinhole and splatted (bdpt's t = 1 strategy). The two are
 * weighed by the power heuristic with the ratio r of their densities over the path's two free
 * vertices (x1, x2; the light is a delta position):
 *
 *     p_lt   = pmf(e) p_dir(w0) P_chain |dw0/dA(x2)| p_x2(w2) |dw2/dA(x1)|
 *     p_path = p_cam(x1) p_x1(w1) |dw1/dA(x2)| pmf(e) q(x2)
 *
 * (p_dir the emission's direction density, P_chain the chain's lobe choices, p_cam the camera's
 * density of x1 per camera sample, p_x1, p_x2 the BSDF sampling densities at x1 and x2, q the query's
 * roulette at x2). The chain's Jacobian |dw0/dA(x2)| = cos(x2) G, G spc_chain_geometry's term toward
 * the point light, and the middle part's |dw2/dA(x1)| / |dw1/dA(x2)| = cos(x1) / cos(x2) by the
 * reciprocity of the generalized geometry term (both ends in the same medium); the middle part's
 * lobe choices are the same both ways. r is a function of the path alone, computed by the same code
 * on both sides, so that the two weights sum to one whatever its accuracy.
 *
 * The same light subpath also joins x2 to the pinhole where x2 is the path's first receiver: seen
 * directly (bdpt's t = 1), or through the glass sphere (each chain of the sphere from x2 toward the
 * pinhole, spc_sphere_chains_all, valued with its throughput and generalized geometry term). There
 * specular NEE's value, the caustic's irradiance at the point a pixel sees (through the ball: the
 * floor under it, where the caustic folds), has the same log-divergent second moment. The camera's
 * density of x2 is then We / N |dw_cam/dA(x2)| times the chain's lobe choices (which the path
 * samples), and the query's roulette first_p's:
 *
 *     r = p_dir(w0) P_chain |dw0/dA(x2)| / (q(x2) We / N |dw_cam/dA(x2)| P_cam).
 *
 * A point light's chain may also run through flat faces only (glass slabs, spc_flat_chain_covers, up
 * to SPC_FLAT_MAX_VERTICES and the depth left: spc_path_lt_point_flat_budget): specular NEE's flat
 * enumeration makes such a chain of k vertices on a share psi of its calls (spc_snee_flat_psi: 1
 * up to 4 vertices by default, flat34 below that, flat5 and flat6 past it), so its density, and
 * the r specular NEE's side reads, carries psi (r / psi; psi 0: light tracing's alone, as no other
 * strategy reaches a point light). A point light's chain may lie on a tessellated glass ball too,
 * with specular NEE's density that of an exact count (its estimate of each chain is unbiased).
 *
 * With ltslab (params.lt_slab) a point light's (and an area light's) subpath at x2 also joins the
 * pinhole through flat faces: every chain of spc_flat_chains_all from x2 toward the pinhole of 1 to
 * params.lt_slab_max vertices (the floor seen through a glass slab, in and out), on every subpath. Without it the
 * camera ray that meets x2 through such a chain leaves the path to specular NEE at x2 alone, which
 * makes the slab's 3- and 4-vertex light chains on a share of its calls (flat34) counted 1/psi and
 * the 5- and 6-vertex ones never. The camera's density of x2 through the chain is that of the
 * sphere's chains (We / N |cos(x2)| G P_cam, G the chain's generalized geometry term toward the
 * pinhole), and both sides take a camera chain as light tracing's exactly where it is one of those
 * the joins enumerate (spc_flat_chain_covers, at most lt_slab_max vertices).
 *
 * The joins through the sphere (its root search from x2, most of the strategy's cost) run on a
 * share s of the subpaths (SPC_PATH_LT_THROUGH_SHARE, or the parameters' lt_through), counted 1/s
 * times; light tracing's density of those paths, and so their r, carries the factor s.
 *
 * Area lights (with MIS against BSDF sampling; with the caustic guide at receivers too): the subpath
 * starts at a point y drawn as specular NEE draws its light points (spc_snee_sample_light: the cap
 * of a sphere light that faces the casters, other shapes by area, density p_y including the light's
 * choice), with a direction uniform in the cone toward the casters' bounding sphere, its throughput
 * Le cos(y) / (p_y p_dir). The same joins follow, except those through a middle vertex (x2 the
 * second receiver at most: the path tracer's side weighs only those paths against it); the joins
 * through the sphere's chains longer than max_chain toward the pinhole (in, reflections inside,
 * out) too, on their own share: the camera sees the floor under the ball through its rim after
 * internal reflections, where the caustic folds, and there specular NEE's and BSDF sampling's
 * values held up to 0.9 of a seed's error in one pixel in 2 of 24 seeds of
 * scenes/caustic_glass_sphere.xml (bench/RESULTS.md, "The glass balls' one-pixel seeds"); with
 * ltslab those through flat faces too (the floor seen through a slab, its camera density as for a
 * point light).
 * There the path has three strategies at x2: specular NEE (density a, its light point), BSDF
 * sampling at x2 (b) and light tracing (c), all in the measure of y given the camera's side. c / b
 * is
 *
 *     r = p_y p_dir(w0) |cos(x2, d0)| / (p_bsdf(x2 -> d0) |cos(y)|) / (camera's side)
 *
 * (the chain's G toward y and its lobe choices cancel; the camera's side as above: the camera's
 * density of x2, or p_cam(x1) p_x1(w1) cos(x2) / (p_x2(w2) cos(x1)) through a diffuse bounce), given
 * to specular NEE as params.alt_chain_ratio: its weight and BSDF sampling's take b sqrt(1 + r^2) for
 * b, and light tracing's weight is r^2 / (1 + r^2) of that joint share (spc_snee_receiver_weights),
 * evaluated on the chain solved from x2 through y as specular NEE's is. The subpaths run on a share
 * of the camera samples (params.lt_share), which c carries. With the caustic guide at receivers
 * (caustic_guide.h) the path tracer draws its directions at x1 and x2 from the guided mixture, so
 * p_bsdf(x2 -> d0) and p_x1(w1) above are the mixture's densities (the guide at that vertex,
 * spc_cguide_mix_pdf), in r on both sides and in BSDF sampling's b at x2 (the receiver's guide);
 * light tracing's own scattering at x2 stays its BSDF's. Since r holds no density of specular
 * NEE, an area light's chain at x2 may also lie on a tessellated glass ball (one triangle mesh with a
 * fitted sphere, fit_seeds.h), whose chains specular NEE does not count exactly: its weight there
 * is its own (psi, or the sampled weight of a randomized attempt's chain), the same on all three
 * sides. An area light's joins through the ball toward the pinhole stay the analytic sphere's (its
 * enumeration). So may its chain lie on one glass SDF without creases (the floor's caustic under a
 * glass torus, two refractions whose fold the randomized attempts rarely find and where BSDF
 * sampling's value is large), whose randomized attempts specular NEE weighs with their sampled solve
 * probability (solve_mis.h) on all three sides alike; its joins are x2 seen directly and through a
 * diffuse bounce (no chain through the SDF toward the pinhole).
 *
 * An area light's chain may also be reflections on a mirror cylinder (cylinder_chains.h, enumerated
 * exactly by specular NEE at x2): the floor inside a mirror ring, seen directly.
 *
 * Or one vertex on a normal-mapped plane (a water surface, plane_chains.h, enumerated exactly at
 * x2). The camera sees a pool's floor through the water: a subpath's x2 then joins the pinhole
 * through every one-vertex chain of the plane from x2 toward it (spc_plane_chains_each, the floor's
 * images in the ripples), on every subpath, the camera's density through it as through the
 * sphere's chains. At each water vertex (the subpath's and the join's) the value carried is the
 * radiance transport's throughput times the map's shading factor |w_prev.n| |w_next.N| /
 * (|w_prev.N| |w_next.n|) (n the map's normal, N the plane's, w_prev toward the light's side): the
 * refraction about n maps the rays' measure about n, the flux and the chain's geometry count it
 * about the plane. The radiance throughput's n^2 factors cancel where the join crosses the water
 * back toward the pinhole; where the path crosses it once (the camera under the water: x2 seen
 * directly, in the surface's underside or through a second receiver) the join's value is divided by
 * their product, since the subpath carries flux, which a crossing does not scale. Not where the
 * map's face-view turn applies from either side of a water vertex
 * (the camera's, the light's or x2's frame is then not the chain's): those paths are the other
 * strategies' alone, on both sides of the weights.
 *
 * Or the light off a mirror ball through one glass shape (a reflection off the ball, then two or
 * more scatterings in a glass ball or a cube: the demo's red wall, the cube's floor), longer than
 * the budget: specular NEE finds such chains by its longer chains' randomized attempts only, so the
 * subpath follows them up to the longest chain the path's track follows (as the flat chains past
 * the budget), and their weights come from spc_snee_receiver_weights on all three sides.
 *
 * A point light's chains through a tessellated glass ball are light tracing's too. Specular NEE
 * finds them by the fitted sphere's seeds and randomized attempts, each counted so that its value
 * is unbiased per chain (1 or the trial count), so any weight that is a function of the path
 * alone, the same on both sides, splits them without bias: r takes specular NEE's density as an
 * exact count's (the query's roulette). Where the retrace from x2 does not reach the light (no
 * chain through it with those events) the path is light tracing's alone. The joins through the
 * ball toward the pinhole take the chains of at most max_chain vertices that specular NEE's solver
 * converges to from the fitted sphere's solutions toward the pinhole (a deterministic function of
 * x2); the path tracer's side weighs its camera chain against light tracing only where its
 * retraced chain is one of those (spc_path_lt_ratio_first), and keeps the others at weight 1.
 */
#ifndef SPC_INTEGRATOR_PATH_LT_H
#define SPC_INTEGRATOR_PATH_LT_H

#include "integrator/context.h"

/* Delta scatterings between x1 and x2 the strategy follows (a glass sphere between two floor
 * points takes two; a few more leave room for reflections inside it). */
#define SPC_PATH_LT_MID_MAX 4

/* Non-delta scatterings between x1 and x2 the strategy follows (each with up to SPC_PATH_LT_MID_MAX
 * delta scatterings after it): where x2 is the path's third receiver, specular NEE's value there
 * has the same log-divergent second moment as at the second, and on point_light_ball such paths
 * (the floor under the ball lit by the caustic, seen after two diffuse bounces) held the largest
 * pixel errors once the second receiver was light tracing's. */
#define SPC_PATH_LT_MID_VERTICES 1

/* A vertex between x1 and x2 where the path scatters by a non-delta lobe: its hit, the direction
 * toward the camera's side (a) and toward the light's (b). */
typedef struct spc_path_lt_vertex {
    spc_hit h;
    spc_vec3 a, b;
} spc_path_lt_vertex;

/* Is the strategy on for this render (the option, the path integrator with specular NEE, exact
 * enumeration, a pinhole camera, no guided cones, no strict normals, no rough vertices)? */
bool spc_path_lt_enabled(const spc_render_ctx *ctx, const spc_snee_params *p);

/* With the strategy on, does it also trace area lights' caustics: MIS against BSDF sampling (whose
 * weight at x2 it shares; with the caustic guide at receivers, against the guided mixture's density
 * at x1 and x2, the path's own)? */
bool spc_path_lt_area_enabled(const spc_snee_params *p);

/* Specular NEE's chain budget at x2 when x2 is a receiver of the path with `receivers` receivers
 * before it, reached after `segments` path segments (the path tracer's, 0 where it makes no query
 * there). */
int spc_path_lt_budget(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, int segments,
                       int receivers);

/* The longest chain through flat faces only (spc_flat_chain_faces: glass slabs, any events) whose
 * paths light tracing makes for an area light at x2, reached as spc_path_lt_budget's x2: past the
 * budget, up to the longest chain the path's track follows from x2 (the longer chains' pass:
 * spc_snee_track_long_max, params.long_max), where BSDF sampling's weight of the path
 * is computed (spc_snee_receiver_weights) and so can leave light tracing its share; the budget
 * where the track stops there. 0 where specular NEE makes no query at x2. */
int spc_path_lt_flat_budget(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, int segments,
                            int receivers);

/* The longest chain through flat faces only whose paths light tracing makes for a point light at
 * x2, reached as spc_path_lt_budget's x2: past the budget, up to the depth left there (at most
 * SPC_FLAT_MAX_VERTICES). BSDF sampling never reaches a point light, so past the lengths specular
 * NEE's flat enumeration makes (spc_snee_flat_psi 0) such paths are light tracing's alone, and on
 * the lengths it makes on a share of its calls light tracing's weight is against that share. 0
 * where specular NEE makes no query at x2. */
int spc_path_lt_point_flat_budget(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, int segments,
                                  int receivers);

/* The longest light chain c of an area light that light tracing makes at a receiver with these
 * budgets (spc_path_lt_budget's kmax, spc_path_lt_flat_budget's kflat): kflat for a chain through
 * flat faces only (with exact enumeration), kmax for the others. Both sides read it. */
int spc_path_lt_area_chain_max(const spc_snee_params *p, const spc_chain *c, int kmax, int kflat);

/* The density ratio r = p_lt / p_path of the path x1 (left toward w1) - x2 (left toward w2 on the
 * x1 side) - chain c from x2 - point light e; 0 where light tracing does not make it. */
double spc_path_lt_ratio(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x1, spc_vec3 w1,
                         const spc_hit *x2, spc_vec3 w2, const spc_chain *c, const spc_emitter *e);

/* The same ratio with the non-delta vertices mid[0..nmid) (in any order) between x1 and x2: each
 * adds its BSDF's densities both ways and the cosines of its two directions (the generalized
 * geometry terms of the segments cancel by reciprocity), as in bdpt's ratio of two strategies:
 *
 *     r *= p_v(b -> a) |cos(v, b)| / (p_v(a -> b) |cos(v, a)|)
 *
 * (p_v the BSDF's sampling density at v, light tracing's toward a, the path tracer's toward b). */
double spc_path_lt_ratio_via(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x1, spc_vec3 w1,
                             const spc_path_lt_vertex *mid, int nmid, const spc_hit *x2, spc_vec3 w2,
                             const spc_chain *c, const spc_emitter *e);

/* The same ratio where x is the path's first receiver, seen by the camera directly (cc NULL) or
 * through the chain cc from x toward the pinhole (one glass sphere, a tessellated glass ball's
 * chain of at most max_chain vertices that light tracing's joins find from x, or with ltslab flat
 * faces' chain of at most lt_slab_max vertices): light tracing's density over the camera's and
 * specular NEE's at x; 0 for a chain the joins do not find. */
double spc_path_lt_ratio_first(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x,
                               const spc_chain *cc, const spc_chain *c, const spc_emitter *e);

/* For an area light e: light tracing's density over BSDF sampling's at x2 (params.alt_chain_ratio)
 * of the path x1 (left toward w1; NULL: x2 is the first receiver, seen directly or through the
 * chain cc toward the pinhole) - x2 (left toward wo2 on the camera's side) - chain c from x2 - the
 * light's point y (unit normal ny); 0 where light tracing does not make it (not one glass sphere's
 * chain, the camera does not see x1 or x2 so). */
double spc_path_lt_area_ratio(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x1, spc_vec3 w1,
                              const spc_hit *x2, spc_vec3 wo2, const spc_chain *cc, const spc_chain *c,
                              const spc_emitter *e, spc_vec3 y, spc_vec3 ny);

/* Chains of the glass sphere from x2 toward the pinhole that one join enumerates. */
#define SPC_PATH_LT_CAMERA_CHAINS 16

/* The longest chain through the sphere from x2 toward the pinhole that the joins enumerate (at
 * least the parameters' max_chain): the camera's paths through the ball with internal reflections
 * (in, m reflections, out) reach the floor under it too, and where they end near the caustic's
 * fold specular NEE's value there is as heavy-tailed as through the plain refraction. */
#define SPC_PATH_LT_CAMERA_MAX_CHAIN 6

/* The share of light subpaths joined to the pinhole through the sphere by chains longer than the
 * parameters' max_chain. Their root search for the signatures with internal reflections costs about
 * as much as the rest of a sample (1.92x a sample on point_light_ball with it on every subpath);
 * at 0.1 and 0.05 the image's error at equal spp was the same over 12 seeds (the joins matter
 * only near the caustic's fold, where r is large), and 0.05 cost 0.91x 0.1's CPU. */
#define SPC_PATH_LT_LONG_SHARE 0.05

static inline int spc_path_lt_camera_max_chain(const spc_snee_params *p)
{
    return p->max_chain > SPC_PATH_LT_CAMERA_MAX_CHAIN ? p->max_chain : SPC_PATH_LT_CAMERA_MAX_CHAIN;
}

/* The share of light subpaths joined to the pinhole through the sphere (join 2). On
 * point_light_ball 0.25 against 0.5 gave the same relMSE at equal spp over 12 seeds (0.001104 and
 * 0.001103) at 0.93x the CPU; with the longer chains' share too (0.25 and 0.05 against 0.5 and
 * 0.1), over 24 seeds 0.001018 against 0.001016, the same worst seed, at 0.85x the CPU. */
#define SPC_PATH_LT_THROUGH_SHARE 0.25

/* The share of camera samples that trace an area light's subpath (params.lt_share 0), counted 1/S
 * times. The subpath and its joins cost 0.8-0.9 of a base sample; per sample the error hardly grew
 * on the share (bench/RESULTS.md, "Area lights' caustics by light tracing": caustic_glass_sphere at
 * equal CPU 5.6x lower relMSE than without with S = 1, 6.4x with 0.5, 7.9x with 0.25, 6.8x with 0.1;
 * ball_small_light 2.5x, 2.9x (0.25), 2.8x (0.1)). */
#define SPC_PATH_LT_AREA_SHARE 0.25

/* The share of an area light's subpaths aimed at a mirror ball (uniform in the cone toward one of
 * them) where the casters hold a mirror ball and glass and the longer chains' pass is on: the light
 * off the mirror ball through the glass (the demo's, the cube's) takes 0.8% and 0.015% of the
 * subpaths aimed at the casters' bounding sphere. The value is the first tried, not tuned. */
#define SPC_PATH_LT_MIRROR_SHARE 0.5

/* One join of a light subpath to the pinhole: the path's vertices as path_lt.h names them (x1
 * left toward w1 on the light's side, x2 toward w2 on the camera's, the chain c retraced from x2
 * to the point light e), the film position, the contribution C before the weight, and r (infinite
 * where specular NEE cannot make the path: no chain from x2 passes through the light, or its
 * enumeration at x2 does not find c). */
typedef struct spc_path_lt_join {
    const spc_hit *x1, *x2;
    spc_vec3 w1, w2;
    const spc_chain *c;
    const spc_emitter *e;
    double fx, fy;
    spc_rgb C;
    double r;
    const spc_chain *cc; /* x2 is the first receiver (x1 NULL): the chain toward the pinhole, or NULL */
    const spc_path_lt_vertex *mid; /* the non-delta vertices between x1 and x2, from x2's side */
    int nmid;
    spc_vec3 y, ny;      /* the light's point and its unit normal (a point light: its position, 0) */
    double w;            /* light tracing's MIS weight: spc_path_lt_weight(r) for a point light; for an
                            area light its share of the BSDF side's weight at x2 (path_lt.h, top) */
} spc_path_lt_join;

/* Traces one light subpath (rng: a stream of this camera sample) and hands each of its joins with
 * a positive r and an unblocked view of the pinhole to sink (the records live for the call). */
void spc_path_lt_joins(const spc_render_ctx *ctx, const spc_snee_params *p, spc_rng *rng,
                       void (*sink)(void *user, const spc_path_lt_join *j), void *user);

/* Light tracing's power-heuristic weight r^2 / (1 + r^2) of a join with ratio r (1 where r is
 * infinite). */
static inline double spc_path_lt_weight(double r)
{
    return r > 0.0 ? 1.0 / (1.0 + 1.0 / (r * r)) : 0.0;
}

/* The light-traced estimate of one camera sample: spc_path_lt_joins's joins splatted
 * (spc_splat_add), each weighted spc_path_lt_weight(r). */
void spc_path_lt_trace(const spc_render_ctx *ctx, const spc_snee_params *p, spc_tls *tls, spc_rng *rng);

/* ---- long chains: the light guides ----
 *
 * The paths camera - x - k delta scatterings at chain surfaces - a point y on an area light, where
 * x is the camera ray's hit (seen directly) and k is longer than any chain specular NEE covers
 * (spc_path_lt_guide_min_chain), are made by BSDF sampling at x alone in the path tracer: a glass
 * ring guides light around itself by total internal reflection and leaves it onto the floor after
 * 6 or 10 reflections, and the rare BSDF sample from x that enters the ring and leaves it toward a
 * small light adds hundreds to a pixel. Light tracing makes them with the light's own density: a
 * subpath from y (spc_snee_sample_light's point, a direction uniform in the cone toward the
 * casters' bounding sphere) through every delta scattering it meets, up to SPC_PATH_LT_GUIDE_MAX,
 * to the first other surface x, joined to the pinhole. The two are weighed by the power heuristic
 * with the ratio r of their densities in the measure of x and y:
 *
 *     p_lt   = S p_y p_dir(w_y) P |dw_y/dA(x)|,   p_path = p_cam(x) p_x(wo -> d0) P |dw0/dA(y)|
 *     r      = S p_y p_dir(w_y) |cos(x, d0)| / (p_cam(x) p_x(wo -> d0) |cos(y, d_last)|)
 *
 * (S the share of camera samples that trace such a subpath, p_y including the light's choice, P the
 * lobe choices, the same both ways for dielectrics; the chain's generalized geometry term cancels
 * by reciprocity, which leaves the cosines at its two ends). r needs no solved chain: only the
 * path's two ends and its first and last directions, computed by the same function on both sides,
 * so the two weights sum to one on every path whatever the chain. Any caster and any solver: the
 * chains are those specular NEE never makes, so the two strategies share them. The path tracer's
 * Russian roulette and the chain's lobe choices are left out of r (a function of the path alone
 * keeps the estimate unbiased; only the weights' optimality depends on it).
 *
 * A point or spot light's subpath (its start as light tracing's caustics', the cone toward the
 * casters) follows the same walk: a spot's light led along a glass slab by total internal
 * reflection (in at one end, 5 reflections, out at the other: 7 vertices) is longer than the chains
 * light tracing's caustics follow from such a light (SPC_FLAT_MAX_VERTICES) and than any specular
 * NEE makes, and BSDF sampling never meets the light, so past both (at least
 * spc_path_lt_guide_point_min_chain vertices) such a path is light tracing's alone, its weight 1. */

/* The most delta scatterings a light-guide subpath follows, and the path tracer's side weighs: on
 * the SDF torus the BSDF-sampled paths that held a seed's error ran through chains of 8, 12 and 31
 * vertices (the light led around the ring more than once; the path tracer's roulette keeps such
 * paths at 0.95 per segment), and a cap of 16 left the 31-vertex one at weight 1. */
#define SPC_PATH_LT_GUIDE_MAX 64

/* Is the light-guide strategy on for this render ("ltguide": the path integrator with specular
 * NEE, a pinhole camera, no caustic guide at receivers, no strict normals, no rough vertices)? */
bool spc_path_lt_guide_enabled(const spc_render_ctx *ctx, const spc_snee_params *p);

/* The fewest chain vertices of a light-guide path: one more than any chain specular NEE's track
 * covers (the parameters' max_chain, the render's chain cap, and with "long" its bound). */
int spc_path_lt_guide_min_chain(const spc_render_ctx *ctx, const spc_snee_params *p);

/* The fewest chain vertices of a point or spot light's light-guide path: past specular NEE's
 * budget (the larger of params.max_chain and the render's chain cap; light tracing's caustics from
 * such a light keep within it) and past SPC_FLAT_MAX_VERTICES (the longest chain through flat faces
 * specular NEE's flat enumeration and light tracing's caustics from such a light make). Not past the
 * long pass's bound: its chains of a point or spot light at the camera ray's hit as long as this
 * or longer are the light guides' alone, specular NEE weighs them 0 (params.delta_share,
 * integrator/path_snee.c), so that with the long pass up to 8 vertices the 7- and 8-vertex chains
 * its randomized attempts rarely find are made by light tracing at every length. */
int spc_path_lt_guide_point_min_chain(const spc_render_ctx *ctx, const spc_snee_params *p);

/* r = p_lt / p_path of the path camera - x (left toward the camera along wo, toward the chain
 * along d0) - chain - the area light e's point y (normal ny), the chain's last segment d_last
 * (toward y); 0 where light tracing does not make it (not an area light, y outside the light's
 * sampled cap, d_last outside the cone toward the casters, the camera does not see x). */
double spc_path_lt_guide_ratio(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                               spc_vec3 d0, spc_vec3 d_last, const spc_emitter *e, spc_vec3 y, spc_vec3 ny);

/* One join of a light-guide subpath to the pinhole: the surface x the camera sees (left toward the
 * pinhole along wo, arrived at along -d0), the k chain vertices from the light's side (v[0] the
 * first the light's point y meets, d_last = -(the direction from y)), the light e and its point's
 * unit normal ny, the film position, the contribution C before the weight, r and light tracing's
 * weight w = spc_path_lt_weight(r). */
typedef struct spc_path_lt_guide_join {
    const spc_hit *x;
    spc_vec3 wo, d0, d_last;
    const spc_hit *v;
    int k;
    const spc_emitter *e;
    spc_vec3 y, ny;
    double fx, fy;
    spc_rgb C;
    double r, w;
} spc_path_lt_guide_join;

/* On a share of the camera samples, traces one subpath from an area light (rng: a stream of this
 * camera sample) and hands its join to sink where its chain is a light guide's, the camera sees x
 * unblocked and r is positive (the record lives for the call). */
void spc_path_lt_guide_joins(const spc_render_ctx *ctx, const spc_snee_params *p, spc_rng *rng,
                             void (*sink)(void *user, const spc_path_lt_guide_join *j), void *user);

/* The light-guide strategy's estimate of one camera sample: spc_path_lt_guide_joins's join
 * splatted (spc_splat_add) with its weight. */
void spc_path_lt_guide_trace(const spc_render_ctx *ctx, const spc_snee_params *p, spc_tls *tls, spc_rng *rng);

#endif
