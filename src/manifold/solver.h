/*
 * manifold/solver.h: what a specular solver sees and gives back, and the table that names them.
 *
 * A solver gets a query (the receiver x, the light point y, the chain budget and the user's
 * parameters) and returns chains from x to y (chain.h): one randomized attempt whose seed follows
 * the query's seed distribution (the same on every call, which specular NEE's count of trials for
 * <1/p_solve> needs), or every solution at once. The estimator (specular_nee.h) samples the light
 * point, calls a solver through the table and values the chains; the solvers (angular.c, newton.c,
 * conic_solver.c) and the exact enumerations (sphere_chains.c, cylinder_chains.c, plane_chains.c)
 * include this header and never the estimator's. Bodies: solver.c (query, seeding, one solution or
 * two), polish.c (polishing an enumeration's root), solver_table.c (the table and the parameters'
 * defaults).
 */
#ifndef SPC_MANIFOLD_SOLVER_H
#define SPC_MANIFOLD_SOLVER_H

#include <stdint.h>

#include "core/rng.h"
#include "manifold/angular.h"
#include "manifold/chain.h"
#include "manifold/newton.h"

struct spc_camera_state;
struct spc_receiver;

/* Attempts counted plainly for <1/p_solve> (the default of params.max_trials but for the angular
 * solver's); past them the count goes on by Russian roulette (spc_snee_count_trials), which stays
 * unbiased but adds variance and stops early, so most counts of solutions found with probability
 * below about 3/cap cost less than their 1/p attempts (each attempt is a full solve). */
#define SPC_SNEE_MAX_TRIALS 64

/* Solver ids (index into the solver table; 0 = specular NEE off). */
enum {
    SPC_SNEE_NONE = 0,
    SPC_SNEE_ANGULAR = 1,
    SPC_SNEE_NEWTON = 2, /* manifold NEE by Newton's method on the vertices (newton.h) */
    SPC_SNEE_CONIC = 3   /* every one-vertex chain on meshes by the coplanarity conic (conic.h) */
};

typedef enum spc_snee_seed {
    SPC_SNEE_SEED_SHAPE, /* toward a uniform point of a uniformly chosen caster shape */
    SPC_SNEE_SEED_LIGHT, /* toward y: deterministic, see above */
    SPC_SNEE_SEED_BSDF,  /* along a direction sampled from x's BSDF: the path a tracer would take (at a
                            medium point its phase function; from the camera, which samples no
                            direction here, CONE) */
    SPC_SNEE_SEED_CONE   /* uniform in the cone of directions from x to the sphere around the
                            bounding box of a uniformly chosen caster (SHAPE's area point when x is
                            inside it); the default: 1.1-1.7x less CPU than SHAPE at the same
                            variance on the caustic scenes (bench/RESULTS.md), attempts failing
                            sooner where the straight-line attempt found the solution */
} spc_snee_seed;

typedef struct spc_snee_params {
    int solver;        /* SPC_SNEE_* */
    int max_chain;     /* longest chain (<= SPC_CHAIN_MAX_VERTICES) */
    spc_snee_seed seed;
    /* With SEED_SHAPE or SEED_CONE and a solver without solve_all: where the straight segment x -> y first
     * meets a refracting caster, one more attempt is seeded toward y (deterministic: Hanika et
     * al.'s MNEE seed, close to the solution through weakly curved glass). The solution it finds
     * is added exactly (no <1/p_solve>), and the shape-seeded attempt and its trials estimate the
     * other solutions: one that finds the straight-line solution again adds nothing. Unbiased
     * (sum over the other solutions of p v / p), and where the straight line finds the only
     * solution, that solution has no trial-count variance and needs no trials. */
    bool straight_first;
    int max_trials;    /* cap of the attempts counted for <1/p_solve> */
    bool any_surface;  /* ignore caustic flags (tests, benchmarks) */
    spc_angular_options angular;
    spc_newton_options newton;
    /* Biased estimator (Zeltner et al. 2020, sec. 4.4): biased_seeds attempts per light sample, every
     * distinct solution found counted once with <1/p_solve> = 1, no trials. It misses the solutions
     * no attempt finds (energy loss where solutions are hard to find) and has less variance. */
    bool biased;
    int biased_seeds;
    /* Multiple importance sampling with the caller's BSDF sampling (the path integrator sets it;
     * not with rough vertices). Every chain's contribution is weighted by the power heuristic
     * w = p_y^2 / (p_y^2 + p_b^2), p_y the light point's density (area measure, the light's choice
     * included) and p_b = pdf_bsdf(x: wo -> d0) G the density in which BSDF sampling at x reaches
     * y through the same chain (G = |dw(x) / dA(y)|, spc_chain_geometry); the caller weights the
     * BSDF-sampled paths that specular NEE covers by 1 - w (spc_snee_mis_bsdf_weight) instead of
     * dropping them. The weight pretends the solver finds every chain (p_solve = 1): any
     * deterministic pair of weights that sums to 1 keeps both estimators unbiased, and where G is
     * large (near a caustic's folds and focus, where a light sample's contribution is heavy-tailed)
     * BSDF sampling takes the path.
     * The solver's probability of finding a chain enters as a deterministic stand-in psi (any
     * function of the path keeps the weights summing to 1): p_y is replaced by psi p_y, psi = 1 for
     * the chains found exactly (solve_all's, and the straight-line solution of straight_first, which
     * the BSDF side recomputes from x and y) and psi = mis_solve for the chains a randomized attempt
     * finds, whose <1/p_solve> trial count makes them heavy-tailed where p_solve is small. */
    bool mis;
    double mis_solve;
    /* With mis: the chains of randomized attempts through tessellated balls (every vertex on a shape
     * with a sphere fit, fit_seeds.h), and those within the budget on SDFs without creases, weighed by
     * the balance heuristic with their real solve probability instead of the stand-in psi (the user's "solvemis" / "nosolvemis"; on by default;
     * not with guide; other chains keep the stand-in, which measured better on a water mesh). Specular NEE's trial count N becomes the estimate (1 - r^N) / b of
     * 1 / (p A + b), BSDF sampling's weight a roulette of the same trials (solve_mis.h): both sides
     * bounded by the BSDF-sampled value f / b where BSDF sampling reaches the chain, so the count's
     * tail N / A stays only where it cannot. */
    bool solve_mis;
    /* With reflect: the stand-in psi of a randomized attempt's chain is mis_solve times the probability
     * of the chain's events (spc_chain_events_prob), which its trial count is divided by (the user's
     * "misev" / "nomisev"; off by default: it removed a longer chain's firefly on the SDF torus but
     * made newton_pool 1.7x worse at equal samples, bench/RESULTS.md, "Guided seeds"). */
    bool mis_events;
    bool no_mis; /* the user's "nomis" option: the integrator does not set mis (covered BSDF paths
                    are then dropped, as before MIS) */
    /* the user's "nosplit" option: the path tracer does not split specular NEE at the reflection off a
     * smooth glass mesh seen from the camera (path.c, split_snee) */
    bool no_split;
    /* The reflection's probability at which the split above runs on every sample on flat-faced
     * glass (the user's "splitf=S", in (0, 1]; 0: SPC_PATH_SPLIT_F, integrator/path_snee.h): where
     * the sampled path takes the reflection with probability P_R, the split runs with probability
     * min(1, P_R / S) and counts its query 1 / that times. */
    double split_f;
    /* Reflection at dielectric vertices (the user's "reflect[=P]"): chains may reflect off glass as
     * well as refract through it (the light's reflection in a glass ball on the floor, internal
     * reflections). A randomized attempt picks the event at each dielectric vertex of its seed chain
     * (spc_chain_pick_event: reflection with probability reflect_p, whatever the geometry). The
     * probability of a solution is then that of its events (spc_chain_events_prob, exact) times
     * that of the directions leading to it given those events, which the Bernoulli trials estimate
     * with the events forced (spc_snee_query.events). conic enumerates both events on meshes. Not
     * with the rough newton mode. */
    bool reflect;
    double reflect_p;
    /* With reflect: the probability that an attempt takes the events of a chain through one convex
     * ball instead of picking each at reflect_p: refract in at the first vertex, reflect at every
     * inner one, refract out at the last (of the query's max_chain vertices;
     * spc_snee_attempt_event_u). 0 (the default) everywhere but in specular NEE's pass for the
     * longer chains on a tessellated ball, which sets it. */
    double ball_events_p;
    /* Specular NEE at the first `receivers` non-delta vertices of a camera path only (0: at all;
     * the user's "receivers=N"). Unbiased: where it does not run, BSDF sampling keeps the paths it
     * would have covered (the track starts nowhere). Deep vertices carry little of the image and
     * cost as much as the first (an enclosed pool: over half of the calls). */
    int receivers;
    /* The path tracer's extra directions at its receivers past the first (the user's
     * "deepsplit=M"; 0: none): at each such vertex M more directions from its BSDF, each followed
     * through delta vertices only (glass, mirrors) to an area light, counting only the light
     * reached through at least one of them, weighed as M + 1 BSDF samples (bsdf_n); the path's own
     * such light is counted 1 / (M + 1) (path_deep.h). Where the query runs and light tracing
     * shares none of the receiver's paths. */
    int deep_split;
    /* The number of directions the path draws from the BSDF at the receiver whose query this is
     * (0 counts as 1): deep_split + 1 where the extra directions run (path_deep.h). BSDF
     * sampling's density in the MIS weights of the paths that leave this receiver (specular NEE's
     * and BSDF sampling's, each of the directions counted 1 / bsdf_n) is times this, the balance of
     * one light sample against bsdf_n BSDF samples (Veach's n_i p_i). Set by the path tracer per
     * receiver; never where light tracing shares the receiver's paths. */
    double bsdf_n;
    /* Specular NEE from the camera too (the user's "camera"): once per camera sample, a light point
     * and a chain from the pinhole through the specular surfaces to it, splatted on the pixel its
     * first direction falls in (spc_snee_camera): the light seen through glass or in a mirror (a
     * lamp through a lens, glints on water), which camera rays find only by landing on the light's
     * tiny image. MIS against the camera rays that reach the light through the same chains (the
     * camera's density of the direction, W H / N pdf_dir, for the BSDF's; spc_snee_camera_bsdf_weight)
     * when mis is set, else those rays are dropped. Always the unbiased estimator. */
    bool camera;
    /* The probability of that camera query per camera sample ("camera=Q"; 1 by default), counted
     * 1 / Q times and in the MIS weights (like snee_p): a rippled surface's glints cost a dozen
     * randomized attempts per query but carry little of the image's variance. */
    double camera_p;
    /* Every chain that stays on one sphere (a glass or mirror ball: reflected off it, or in, m
     * internal reflections, out; sphere_chains.h) or reflects only off one mirror cylinder (the
     * inside of a cup or ring; cylinder_chains.h) enumerated exactly, each a root of a function of
     * one angle, and counted with psi = 1; the randomized solver's attempts skip them, and with one
     * such shape as the only caster it is not called at all. So are the one-vertex chains through a
     * normal-mapped plane (rippled water or mirror; plane_chains.h), except from the camera. The
     * user's "exact" (the default for every solver) / "noexact". */
    bool exact;
    /* With exact, the chains through one sphere and one flat mirror (unfold_chains.h) enumerated on
     * the sphere's mirror images and counted with psi = 1, the randomized attempts skipping them
     * (the user's "unfold", the default, / "nounfold"). */
    bool unfold;
    /* Longer chains (the user's "long=P" / "nolong"): at each call, with probability long_p, one
     * more length k, uniform in max_chain + 1 .. 6 vertices (within the caller's depth), is looked
     * for too and counted with 1 / psi, psi = long_p / (6 - max_chain): on one sphere every chain of
     * k vertices, enumerated (params.exact); with the angular solver, elsewhere one randomized
     * attempt for a chain of exactly k vertices with its <1/p_solve> (the other solvers: spheres
     * only). MIS weighs them with psi (times random_psi for a randomized attempt's chain) against
     * the BSDF-sampled paths through the same chains, which the track follows that far
     * (spc_snee_track). Light that bounces inside a glass ball or torus
     * before it leaves (three internal reflections: a single BSDF-sampled path of value 200 on a
     * pixel of 0.03) is then no longer left to BSDF sampling alone, for a fraction of the cost of a
     * longer max_chain. Needs mis (off without it), reflect for dielectrics. From the camera too
     * (params.camera): the light seen through a ball after internal reflections. */
    double long_p;
    /* The longest chain that pass looks for (the user's "longmax=K", 0: 6 vertices; the ball pass
     * and the mirror cylinders' longer chains keep to 6), for light that
     * runs along a glass tube by total internal reflection, as in a ring (a light guide): under the
     * SDF torus, 8-vertex paths (in, six reflections, out) that only BSDF sampling made added 445
     * to pixels of 0.03-0.16 (bench/RESULTS.md, part torus24). */
    int long_max;
    /* The chains on one sphere past long_max, up to 6 vertices (the user's "sphlong=Q", 0: none):
     * on a share Q of the calls, where the longer chains run, every such chain of long_max + 1 .. 6
     * vertices is enumerated in one pass toward the query's light point and counted with 1 / Q; the
     * track then follows covered paths to 6 vertices, so that BSDF sampling's density of such a
     * path carries the same Q (MIS) instead of weight 1. A glass ball's chains with three and four
     * internal reflections are a thousandth of its light, but a BSDF-sampled path that reaches a
     * small light through them added 30-100 to one pixel of the demo (bench/RESULTS.md, part demo38). */
    double sphere_long_p;
    /* The share of that pass's randomized attempts that take a light guide's events (in, reflected
     * at every inner vertex, out; the user's "longev=P", 0: none), the rest picking each event at
     * reflect_p: a k-vertex guide chain's events then have probability about P instead of
     * reflect_p^(k-2) (0.2^6 = 6.4e-5 at 8 vertices). */
    double long_events_p;
    /* The longer chains through flat faces (flat_chains.h; the user's "flat5=Q" and "flat6=Q"):
     * where the longer chains run (long_p > 0 with mis), the chains of 5 and of 6 vertices past
     * the every-call length (4) are enumerated each on its own share of the calls, flat5_p and
     * flat6_p, and counted with 1 / share; the BSDF side's density of such a path carries the same
     * share (MIS). 0: never enumerated (left to BSDF sampling, weight 1). */
    double flat5_p;
    double flat6_p;
    /* The same for the chains of 3 and 4 vertices past a budget of 2 (the user's "flat34=Q"): 1 (the
     * default) enumerates them at every call (SPC_FLAT_EVERY_CALL), Q < 1 on that share of the calls,
     * each length drawn on its own and counted with 1 / Q, the BSDF side's density carrying Q. */
    double flat34_p;
    /* Guided directions (the user's "guide[=M]" / "noguide"): besides the light sample, one
     * direction per call drawn at x inside a cone around a chain toward the light, then traced
     * through the chain's surfaces by their BSDFs as a path would be; where it reaches that light
     * through a chain specular NEE covers, it counts, weighed by MIS (power heuristic) against the
     * light sample and BSDF sampling. The cones: for a light chosen by power, the chains to its
     * point facing x that the randomized solver would look for (the straight-line attempt, or
     * solve_all's; none where the exact enumerations cover every chain), each cone's half-angle M
     * times the light's radius times sqrt of the chain's solid angle per unit area there (the
     * light's image through the chain, widened by M), at most SPC_SNEE_GUIDE_MAX_ANGLE, and kept
     * only where three probe directions land on the light where the chain's Jacobian says (a smooth
     * image). Where the light's image through a chain is such a patch (a lamp seen through a
     * mesh water surface or a slab) a direction costs one trace and reaches the light most of the
     * time, where a solved chain costs several traces and its light point's geometry term varies.
     * Not where the light has several images (a normal map's ripples, a torus): the cone holds one.
     * Needs mis (off without it); not from the camera. 0 (the default): off. The psi of the
     * straight-line solution is then random_psi's, so that a path's weight needs no solve. */
    double guide;
    /* The probability of specular NEE's light sample at a receiver whose light has a guided cone
     * (the user's "sneep=Q"; 1 by default; with guide): below 1 the light sample and its solve are
     * skipped at random and counted 1 / Q times when made, and MIS weighs them with Q p_y, so that
     * the cheaper guided directions carry the smooth image. Not from the camera. */
    double snee_p;
    /* Russian roulette on the whole query past a path's first receiver (the user's "later=P"; 1 by
     * default): at the second and later non-delta vertices of a camera path the query is made with
     * probability P and counted 1 / P times, and MIS weighs it with P p_y, so that BSDF sampling
     * takes more of the covered paths there. Unbiased for any P in (0, 1]; it spends the queries
     * where the caustic is seen rather than where it only lights the room. The caller sets
     * query_p per receiver (the path integrator: 1 at the first, after it later_p, raised near the
     * casters by spc_snee_later_prob; 0 counts as 1); not with guide, not from the camera (camera_p). */
    double later_p;
    /* Russian roulette on the query at a path's first receiver (the user's "first=P"; 1 by
     * default): as later_p, made always where the casters fill a large share of the receiver's
     * directions and with probability down to P where they look small (spc_snee_first_prob); the
     * caustic a receiver far from every caster sees is faint, and the query there costs as much as
     * near the casters. The path integrator only; not from the camera. */
    double first_p;
    /* The most probable a query is near the casters (the user's "nearp=P"; 1 by default): where
     * first_p or later_p is in (0, 1), the probability spc_snee_first_prob and spc_snee_later_prob
     * raise with the casters' share of x's directions stops at P (never below first_p or later_p),
     * so that a receiver under the casters makes the query on a share P of its visits, counted
     * 1 / P times. For casters whose query costs a hundred BSDF samples under a light BSDF sampling
     * finds through them often (flat glass under a large light). */
    double near_p;
    /* The share of a receiver's directions the casters fill, for first_p's and later_p's rule (the
     * user's "tightshare"; off by default): measured by each caster's tight sphere
     * (spc_scene_casters.bound_r: a sphere's own, a mesh's farthest vertex) instead of the sphere
     * around its bounding box, whose radius is sqrt(3) times a ball's, and certain in each tight
     * sphere's shadow from each light specular NEE samples (behind it, within its radius of the line
     * from the light's centre through the sphere's: where a glass ball focuses its caustic). The
     * query is then certain within the ball and its shadow and falls with the ball's real solid
     * angle elsewhere. A function of x alone, so the roulette stays unbiased. */
    bool tight_share;
    double query_p;
    /* Independent light points per query (0 or 1: one; the caller sets it per receiver, as query_p):
     * each is solved as a query of its own and counted 1 / light_samples times, and MIS weighs the
     * light sample with light_samples p_y, a density counted in samples per query as query_p's is.
     * Not with guide or light_u_on (one light point there). */
    int light_samples;
    /* bdpt: light_samples at the receivers the camera sees by a reflection off a glass ball (the
     * user's "reflected=N"; SPC_SNEE_REFLECTED_SAMPLES by default). Not in the path integrator. */
    int reflected_samples;
    /* bdpt: specular NEE also at the surface points the camera sees directly (the user's
     * "direct[=P]"; off by default): a caustic seen directly (camera - floor - glass - glass -
     * light), which bdpt otherwise makes by light tracing (t = 1) and by s = 0 only, is then made by
     * specular NEE at the floor point too, in a fraction P of such vertices (counted 1 / P times, as
     * query_p), and the three are weighed together through alt_ratio. Not in the path integrator. */
    bool direct;
    double direct_p;
    /* Another strategy that makes the covered paths besides specular NEE and BSDF sampling, weighed
     * in by the power heuristic: alt_ratio returns its density over BSDF sampling's for the path
     * x (seen from wo) - first direction d0 - chain - last direction d_last - light point y (unit
     * normal ny) on e, and BSDF sampling's density b becomes b sqrt(1 + ratio^2) in every MIS
     * weight of specular NEE's sample and of the covered paths, so that the BSDF side's weight is
     * the two other strategies' share together (which the caller splits between them). A function
     * of the path alone, so that both sides agree. NULL: none (bdpt sets it for "direct"). */
    double (*alt_ratio)(const void *user, const spc_hit *x, spc_vec3 wo, spc_vec3 d0, spc_vec3 d_last,
                        const spc_emitter *e, spc_vec3 y, spc_vec3 ny);
    const void *alt_user;
    /* As alt_ratio, given the covered chain c itself (its vertices, d0 = c->d0, the last direction
     * c->v[c->n - 1].d), for another strategy that makes some chains only (the path integrator's
     * light-traced caustics of area lights: integrator/path_lt.h); used instead of alt_ratio where
     * set, with alt_user. 0 where the other strategy does not make the path. */
    double (*alt_chain_ratio)(const void *user, const spc_hit *x, spc_vec3 wo, const struct spc_chain *c,
                              const spc_emitter *e, spc_vec3 y, spc_vec3 ny);
    /* The path integrator's light-traced caustics of point lights (the user's "ltcaus";
     * integrator/path_lt.h): on, specular NEE at the path's first receiver and at its second (after
     * a diffuse bounce at the camera ray's hit) shares the point-light chains that light tracing
     * also makes. delta_share returns specular NEE's power-heuristic share of the path receiver x
     * (seen from wo) - chain c - point light e (1 where the other strategy does not make it); a
     * function of the path alone, so that both sides agree. NULL: none. Not from the camera, not
     * at medium points. */
    bool lt_caustic;
    /* With lt_caustic under area lights: the long pass (long_p) leaves the chains through flat faces
     * alone that are longer than their enumeration (flat_chains.h) to light tracing and BSDF
     * sampling, psi 0 on both sides. */
    bool long_flat_lt;
    /* With lt_caustic: the share of light subpaths joined to the pinhole through a glass sphere,
     * in (0, 1]; 0: SPC_PATH_LT_THROUGH_SHARE (integrator/path_lt.h). */
    double lt_through;
    /* With lt_caustic: the share of light subpaths joined to the pinhole through a glass sphere by
     * chains longer than max_chain (0: SPC_PATH_LT_LONG_SHARE, integrator/path_lt.h) */
    double lt_long;
    /* With lt_caustic: the share of camera samples that trace a light subpath from an area light
     * (the user's "ltshare=S"), in (0, 1], counted 1/S times; 0: SPC_PATH_LT_AREA_SHARE
     * (integrator/path_lt.h). Point lights' subpaths run on every sample. */
    double lt_share;
    /* The path integrator's light-guide caustics (the user's "ltguide[=S]"; integrator/path_lt.h):
     * on a share lt_guide_share of the camera samples (default 0.5), a subpath from an
     * area light through chains longer than any specular NEE covers, joined to the pinhole at the
     * first other surface, weighed against BSDF sampling there. Any caster, any solver. */
    bool lt_guide;
    double lt_guide_share;
    /* The path integrator's light seen through flat glass (the user's "ltview[=S]";
     * integrator/path_lt_view.h): on a share lt_view_share of the camera samples (default
     * SPC_PATH_LT_VIEW_SHARE), a point on an area light joined to the pinhole by every chain through
     * flat faces (partial reflections off glass too), weighed against the camera ray that makes the
     * same path. */
    bool lt_view;
    double lt_view_share;
    /* The path integrator's camera-side split (the user's "camsplit[=K]";
     * integrator/path_camsplit.h): where the camera ray's first hit is a surface whose BSDF is
     * delta only, up to cam_split_rays more camera rays in the same pixel whose first hit is such a
     * surface too follow the delta scatterings and count only the emission they reach; the
     * camera -> delta+ -> emitter part of the sample is their mean with the camera ray's own. */
    bool cam_split;
    int cam_split_rays;
    /* With cam_split (the user's "camrecv"): those rays also sample the BSDF of the first vertex
     * whose BSDF is not delta only once and count the emission reached past it through delta
     * scatterings (a light guide or caustic seen on a floor behind the glass); that part of the
     * sample is their mean with the camera path's too (path_camsplit.h, class D). */
    bool cam_split_recv;
    int cam_split_recv_min; /* class D's paths: at least this many delta vertices in all */
    /* Specular NEE from the pinhole (params.camera) also looks for the chains of max_chain + 1 to
     * 4 vertices on a glass SDF without creases (the user's "camlong[=Q]"): on a share cam_long_p
     * of the queries one randomized attempt at a length drawn uniformly among those, its events a light
     * guide's (in, reflected at every inner vertex, out) on most attempts, weighed against the
     * camera ray by the chain's real solve probability (solve_mis.h), as the ball pass weighs a
     * tessellated ball's longer chains. The light seen through a glass torus after reflections
     * inside its tube (path_camsplit.h's class C) is otherwise the camera ray's alone. */
    bool cam_long;
    double cam_long_p;
    /* With lt_caustic (the user's "ltslab[=K]"; integrator/path_lt.h): a point light's subpath at the
     * path's first receiver x2 also joins the pinhole through every chain of 1 to lt_slab_max
     * vertices through flat faces (glass slabs: spc_flat_chains_all's chains from x2 toward the
     * pinhole), weighed against specular NEE at x2 reached by the camera ray through that chain
     * (the floor seen through a slab); an area light's subpath too, by camera chains of at most
     * max_chain vertices. Default K SPC_SNEE_LT_SLAB_MAX (solver_table.c). */
    bool lt_slab;
    int lt_slab_max;
    /* psi: the probability with which specular NEE's pass made c (below 1 only for chains through
     * flat faces enumerated on a share of the calls: spc_snee_flat_psi, specular_nee.h) */
    double (*delta_share)(const void *user, const spc_hit *x, spc_vec3 wo, const struct spc_chain *c,
                          const spc_emitter *e, double psi);
    const void *delta_user;
    /* The light sample's uniforms where the caller draws them from its stratified sample stream
     * (light_u_on; the path integrator at each receiver): light_u[0] picks the light, light_u[1]
     * and light_u[2] the point on it. Otherwise, where light_u_smp is set, they are drawn when a
     * light sample is made from a copy of that stream (its next pair gives light_u[1] and
     * light_u[2], the pair after it light_u[0]; the caller has moved its own stream past both): the
     * same values, not computed at the vertices where no query runs. Otherwise spc_snee_sample_light
     * draws them from its own generator. */
    bool light_u_on;
    double light_u[3];
    const struct spc_sampler *light_u_smp;
    /* At a surface receiver x, a share light_x of the points on a sphere light drawn uniformly in
     * the cone of directions toward it from x (the user's "lightx=A"), the rest as before (the cap
     * facing the casters); the density is the mixture's (spc_snee_sample_light). 0: off. */
    double light_x;
    /* Caustic guiding at receivers (the user's "recguide=A" / "norecguide"; caustic_guide.h): the
     * path tracer's BSDF sampling at a non-delta vertex draws, with probability A, a direction
     * toward the caustic photons' disks that x sees, and weighs every strategy with the mixture's
     * density. 0: off. cguide is the guide the render built (NULL: none) and cguide_at the guide at
     * the receiver being queried (set by the path tracer per vertex; NULL: BSDF sampling alone). */
    double recv_guide;
    const struct spc_cguide *cguide;
    const struct spc_cguide_vertex *cguide_at;
    /* Guided seeds (the user's "seedguide=A" / "noseedguide"; seed_guide.h): with SEED_SHAPE or
     * SEED_CONE, a randomized attempt at a receiver draws its seed with probability A toward the last
     * caster vertex of a light path of the render's pre-pass that landed near x, else as before. The
     * mixture is the same for every attempt of a query (the trials of <1/p_solve> included), so the
     * count stays unbiased for the mixture's p, which is larger for the chains that light x. Not from
     * the camera. 0: off. sguide is the pre-pass the render built (NULL: none, the seeds uniform). */
    double seed_guide;
    const struct spc_sguide *sguide;
    /* Seeds from the phase function at medium receivers (the user's "phaseseeds=A" /
     * "nophaseseeds"): at a medium point a randomized attempt draws its seed direction from the
     * point's phase function with probability A, else by `seed` (the straight-line attempt of
     * straight_first is made as `seed` says). The mixture is the same for every attempt of a query,
     * trials included, so the count stays unbiased for the mixture's p: the phase seeds find the
     * chains the medium scatters into (those far from the straight line, the ones that hold the
     * cone seeds' rare large counts), the cone seeds those near it. Surfaces and the camera: no
     * effect. 0: off; with `seed=bsdf` every seed at a medium point is a phase seed anyway. */
    double phase_seeds;
    /* Seeds from a fitted sphere (the user's "fitseeds" / "nofitseeds"; on by default; fit_seeds.h):
     * with SEED_SHAPE or SEED_CONE, where the caster an attempt picks is a tessellated ball, a share
     * of its seeds go toward the exact solutions of the sphere fitted to it, so that every chain
     * the ball has is found with a probability that keeps its trial count short. */
    bool fit_seeds;
    /* The share of the seeds drawn from the fitted sphere's solutions where it applies
     * (spc_fit_seed); 0 (the default): SPC_FIT_SEED_SHARE. */
    double fit_share;
} spc_snee_params;

/* Defaults: SEED_CONE, max_trials SPC_SNEE_MAX_TRIALS, caustic flags respected, the angular
 * and Newton solvers' defaults, unbiased (biased_seeds SPC_SNEE_BIASED_SEEDS when switched on),
 * mis_solve SPC_SNEE_MIS_SOLVE, reflect for angular and conic, no camera, receivers 0 (all),
 * exact.
 * For the angular solver: straight_first, the angular solver's progress window and a cap of 256
 * (solver_table.c, SPC_SNEE_ANGULAR_WINDOW, SPC_SNEE_ANGULAR_MAX_TRIALS); conic (whose one-at-a-time
 * part is the angular solver) gets the window too. */
void spc_snee_params_default(spc_snee_params *p, int solver, int max_chain);

/* One connection problem: from x (wo toward the previous path vertex) to y. */
typedef struct spc_snee_query {
    const spc_scene *scene;
    const spc_hit *x;
    spc_vec3 wo;
    spc_vec3 y, ny;    /* ny: the light's unit normal at y; (0,0,0) for a point light */
    double light_size; /* sqrt(area) of the light's shape; 0 for a point light */
    double y_err;      /* absolute error bound of y (its shape sample's; 0 for a point light) */
    int max_chain;
    spc_snee_seed seed;
    bool any_surface;
    const spc_snee_params *params;
    /* Set while counting trials for <1/p_solve>: the signature of the solution being counted. A
     * solver whose attempt keeps the signature of its seed chain may stop an attempt whose seed
     * has another one (it cannot end at that solution; the outcome is the same, only sooner).
     * NULL otherwise. */
    const spc_chain_sig *want;
    double p_y; /* the light point's density (spc_snee_sample_light), for the MIS weight */
    double psi; /* the MIS weight's stand-in for the solve probability of the chain valued (params.mis;
                   0 counts as 1) */
    /* Set while counting trials with params.reflect: the events the attempts follow (the solution's;
     * SPC_CHAIN_MAX_VERTICES entries). NULL otherwise. */
    const unsigned char *events;
    /* From the camera (x the pinhole, no BSDF): the camera, and the ratio of the full film's pixels
     * to the camera samples per pass (spc_snee_camera). NULL for a surface point. */
    const struct spc_camera_state *cam;
    double cam_scale;
    /* The receiver x belongs to, with its scattering factor (receiver.h); NULL: the surface point x
     * seen from wo, or the camera's pinhole when cam is set. */
    const struct spc_receiver *receiver;
    /* The exact enumerations' shortest chain (0: 1), and the longest chain params.long_p may add
     * (0: none; spc_specular_nee_depth). */
    int min_chain, long_max;
    /* params.guide: the cones at x (built on first use per light, specular_nee.c); NULL without. */
    struct spc_snee_cones *cones;
    /* The fitted spheres' solutions toward y (fit_seeds.h), kept for the query's attempts and trials;
     * NULL: computed at each attempt. */
    struct spc_fit_roots *fit;
    /* Set: the attempt's seed direction, fixed (no draw from the seed distribution); NULL otherwise. */
    const spc_vec3 *seed_dir;
    /* Set (> 0): the only chain length the caller keeps. A solver whose attempt keeps the length of
     * its seed chain may stop an attempt whose seed chain has another (the caller would drop what it
     * ends with; the same outcome, sooner). 0 otherwise. */
    int keep_n;
} spc_snee_query;

/* A query from x (wo toward the previous path vertex) with chains of up to max_chain vertices, the
 * params' seed and caustic-flag setting; the light point and the rest zero. */
void spc_snee_query_init(spc_snee_query *q, const spc_scene *sc, const spc_snee_params *p, const spc_hit *x,
                         spc_vec3 wo, int max_chain);

/* A solver: one randomized attempt from the query's seed distribution (the same distribution on
 * every call, which <1/p_solve> requires), or the set of all solutions. */
typedef struct spc_specular_solver {
    const char *name;
    bool (*solve_one)(const spc_snee_query *q, spc_rng *rng, spc_chain *out, int *iterations);
    /* NULL unless the solver enumerates every solution (then no probability is estimated);
     * returns the number written to out (at most max_out). */
    int (*solve_all)(const spc_snee_query *q, spc_chain *out, int max_out, int *iterations);
    /* With both solve_all and solve_one: the chains solve_all enumerates (their exact sum is
     * added; solve_one's estimate then skips them), and whether those are every chain of the
     * query (then solve_one is not called). NULL: solve_all covers everything. */
    bool (*covers)(const spc_chain *c);
    bool (*covers_all)(const spc_snee_query *q);
    /* solve_one draws from rng only its seed direction (spc_snee_seed_direction) where the query fixes
     * the events (q->events, or no params.reflect): what it returns is then a function of the query
     * and that direction, so a trial count may reuse the answer for a direction it drew before.
     * Where it draws the events too, it draws the seed direction first, and a chain it returns is
     * what it returns from that direction with the chain's events fixed (the seed chain's events
     * are the solution's), so a count may start from the attempt that found the chain. */
    bool seed_decides;
} spc_specular_solver;

/* The solver of an id; NULL for none or an id outside the table. */
const spc_specular_solver *spc_specular_solver_get(int id);
/* Parses a solver name: "" and "none" give SPC_SNEE_NONE. False for an unknown name. */
bool spc_specular_solver_parse(const char *name, int *id);
/* The valid names, for error messages: "none, angular". */
const char *spc_specular_solver_names(void);

/* Does the straight segment from x toward y first meet a refracting caster (params->straight_first
 * applies)? Toward a mirror, or past every caster, the straight line leads nowhere. One ray. */
bool spc_snee_straight_hits_glass(const spc_snee_query *q);

/* A seed direction for the query (shared by the solvers); false if none (no caster shape). */
bool spc_snee_seed_direction(const spc_snee_query *q, spc_rng *rng, spc_vec3 *dir);

/* The uniforms that pick a randomized attempt's events (spc_chain_opts.event_u, one per vertex, for
 * spc_chain_pick_event at q->params->reflect_p): independent uniforms, or with probability
 * params.ball_events_p (one more uniform, drawn only where it is positive) the ball's events:
 * refraction at the first and last of q->max_chain vertices, reflection between. */
void spc_snee_attempt_event_u(const spc_snee_query *q, spc_rng *rng, double event_u[SPC_CHAIN_MAX_VERTICES]);
/* The probability that an attempt for q picks the events of sig (spc_snee_attempt_event_u): the ball's
 * share where sig has the ball's events at its dielectric vertices, plus the rest times
 * spc_chain_events_prob at reflect_p. */
double spc_snee_attempt_events_prob(const spc_snee_query *q, const spc_chain_sig *sig);

/* For the exact enumerations (sphere_chains.h, cylinder_chains.h): the chain of k vertices on shape s
 * with these events that leaves x along dir (a root of a planar problem), polished by the angular
 * solver toward q's light point (its trace proves the segments before the last unblocked: another
 * surface first gives another signature); written to out[n] and true if it converged with the
 * signature and is not one of out[0..n). Adds its traces to *iterations. */
bool spc_snee_exact_polish(const spc_snee_query *q, const spc_shape *s, int k, const unsigned char *events,
                           spc_vec3 dir, spc_chain *out, int n, int *iterations);
/* The same for a chain whose vertex j lies on shapes[j] (flat_chains.h: a chain through two slabs). */
bool spc_snee_exact_polish_shapes(const spc_snee_query *q, const spc_shape *const *shapes, int k,
                                  const unsigned char *events, spc_vec3 dir, spc_chain *out, int n, int *iterations);
/* The tolerances of the polish of a flat root (of the scene's size and of the light's, the smaller
 * one applies; the other enumerations keep the angular solver's). A flat root is its chain to double
 * rounding (flat_chains.c converges to 1e-12); the seed's trace misses the light point only by the
 * rays' spawn offsets off each surface (8 float ulps of the coordinates), carried along the chain and
 * stretched where the final segment meets the light's tangent plane obliquely: on newton_slabs'
 * four-vertex chains 2.4e-7 of the scene's size at the median, 1.6e-6 at the 90th percentile, 1.4e-5
 * at the 99th, where the angular solver's own 1e-7 took a second trace for 3 roots in 4. A chain's
 * value moves by at most a few 1e-5 of itself (test_flat_chains: 3.5e-5; bench/RESULTS.md, "flat roots
 * polished in one trace"). */
#define SPC_SNEE_FLAT_POLISH_TOL_SCENE 1e-5
#define SPC_SNEE_FLAT_POLISH_TOL_LIGHT 1e-3
/* The same for a root of flat_chains.c, to the tolerances above (the polished chain's final segment
 * meets the light's tangent plane within their smaller one of the light point). */
bool spc_snee_exact_polish_flat(const spc_snee_query *q, const spc_shape *const *shapes, int k,
                                const unsigned char *events, spc_vec3 dir, spc_chain *out, int n, int *iterations);

/* Two converged chains with the same signature are the same solution when every vertex agrees to
 * this fraction of the scene's size: far above the solver's tolerance (angular.c, 1e-7), far below
 * the distance between distinct solutions of any sensible scene. */
#define SPC_SNEE_SAME_REL 1e-4
/* Same solution: same signature and every vertex within SPC_SNEE_SAME_REL of the scene's size. */
bool spc_snee_same_solution(const spc_chain *a, const spc_chain *b, double scene_size);

typedef struct spc_snee_stats {
    uint64_t calls;         /* light samples tried */
    uint64_t solved;        /* first attempts that converged */
    uint64_t contributions; /* nonzero contributions */
    uint64_t trials;        /* further attempts for <1/p_solve> */
    uint64_t capped;        /* counts cut at max_trials */
    uint64_t iterations;    /* solver iterations, trials included */
    uint64_t trial_iterations; /* of which in the attempts counted for <1/p_solve> */
    uint64_t straight;      /* straight-line solutions (straight_first), counted exactly */
    uint64_t guided;        /* guided directions traced (params.guide) */
    uint64_t guided_hits;   /* of which reached the light through a covered chain */
} spc_snee_stats;

/* The radiance the light e sends from its point y (unit normal ny; texture coordinates uv) along -d
 * to a chain's last vertex at p (d: the unit direction from p to y): an area light's emitted
 * radiance, *ny_out = ny; a point or spot light's intensity toward p as the radiance of a virtual
 * patch at y facing p (times the squared distance), *ny_out = -d. Black where nothing arrives. */
spc_rgb spc_snee_light_radiance(const spc_emitter *e, spc_vec3 y, spc_vec3 ny, spc_vec2 uv, spc_vec3 p, spc_vec3 d,
                                spc_vec3 *ny_out);

/* Counts independent trials until the first success: the geometric estimator of 1/p, unbiased for
 * every p > 0. The first `cap` trials are counted plainly (the value is then the integer count);
 * where they all fail the count goes on by Russian roulette (solve_mis.h, SPC_TRIAL_GO_ON), so
 * the value can then be any real >= cap. rng draws the roulette only past the cap. *attempts gets
 * the trials run; *capped is set if the first cap failed. */
double spc_snee_count_trials(bool (*trial)(void *user), void *user, int cap, spc_rng *rng, int *attempts,
                             bool *capped);

/* One randomized attempt of solver for q (the same distribution on every call); adds its
 * iterations to *iterations. */
typedef bool (*spc_snee_attempt)(const spc_snee_query *q, const spc_specular_solver *solver, spc_rng *rng,
                                 spc_chain *out, int *iterations);
/* The trial count that estimates <1/p_solve> for the solution `target` of q: independent attempts
 * (attempt; NULL: solver->solve_one) until one finds the same solution (spc_snee_same_solution),
 * counted by spc_snee_count_trials with this cap (*attempts, *capped as there). Adds the attempts'
 * iterations to *iterations. */
double spc_snee_count_same(const spc_snee_query *q, const spc_specular_solver *solver, spc_snee_attempt attempt,
                           spc_rng *rng, const spc_chain *target, int cap, int *attempts, bool *capped,
                           int *iterations);

#endif
