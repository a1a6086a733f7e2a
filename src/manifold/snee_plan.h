/*
 * manifold/snee_plan.h: whether, and how, specular NEE runs on a scene: the one place where the
 * default is decided.
 *
 * A render's specular NEE setting comes from --specular-nee, else from the scene's integrator
 * property specular_nee, else it is chosen here from the scene ("auto"):
 *   - off unless the integrator is path, volpath or bdpt (ipt samples only by BSDF sampling), the
 *     scene has at least one caster (a smooth specular interface: spc_chain_casters_of), one
 *     receiver (a shape with a non-delta BSDF lobe that receives caustics) and one light specular
 *     NEE can draw a point on (area, point or spot);
 *   - off too if no such light is seen from a caster (no straight segment from a point of a caster
 *     to a point of the light passes through nothing but casters: a bulb inside an opaque shade),
 *     since every chain's last segment is then blocked; lights not seen are left out of the rules
 *     below;
 *   - off too if a caster is flat-faced (a disk, a mesh without vertex normals: cubes, slabs,
 *     panes) and neither a normal-mapped plane nor a mesh of few planes whose chains flat_chains.h
 *     enumerates (a disk, a faceted ball): such chains are left to the randomized attempts, and
 *     their Bernoulli trial counts were heavy-tailed there (the glass
 *     cube and silver ball at equal CPU time: relMSE 0.089 with specular NEE against 0.039 without,
 *     one pixel 94% of the error; two tilted slabs: newton -2.5% at 52x the cost; bench/RESULTS.md,
 *     "Caustics by default"), while on curved casters the attempts paid (the SDF torus 6.8x, a
 *     smooth water mesh 96x);
 *   - off too if every light subtends more than 0.03 sr at the casters' bounding sphere (point and
 *     spot lights count 0): BSDF sampling then reaches such a light through glass and mirrors often
 *     enough that specular NEE's cost does not pay (at equal CPU time, relMSE 3x that of plain path
 *     tracing on the Mitsuba 0.6 box, 0.062 sr, and 2x on the demo's Cornell box, 0.037 sr); but
 *     not if the casters (the spheres around their bounding boxes) fill a quarter or more of some
 *     light's directions (a light over a water surface, a lamp in a glass globe): most light then
 *     reaches the receivers through the casters;
 *   - off too if a caster is an SDF whose surface has creases (spc_sdf_has_creases: a box's or a
 *     cylinder's edges, a union, intersection or difference): the randomized attempts find chains
 *     near a crease with a tiny probability, and their trial counts' tail held the default's error
 *     (scenes/sdf_shapes_csg.xml; bench/RESULTS.md, "CSG: the plan"); smooth SDFs (a torus, a
 *     capsule, smooth unions of smooth primitives) keep it;
 *   - off too if a glass caster is a closed triangle mesh that no sphere fits (fit_seeds.h: a glass
 *     figure, scenes/conic_bunny.xml): the two-refraction chains through an irregular closed mesh
 *     have many solutions, the rarer ones found by a randomized attempt with a probability of a
 *     few percent or less, and without a fitted sphere to seed them their Bernoulli trial counts
 *     (1 / p) are the image's fireflies (the glass figure at equal CPU time over 16 seeds: relMSE
 *     0.354 with specular NEE, worst seed 1.51 with one pixel 96% of it, against 0.065 without;
 *     bench/RESULTS.md, "The default against none on every caster scene"); open meshes (a water
 *     surface) and tessellated balls keep it;
 *   - off too if a caster is flat-faced glass (enumerated by flat_chains.h) and the smallest light
 *     subtends more than 0.002 sr (snee_plan.c, SPC_SNEE_PLAN_FLAT_MAX_SR): flat glass does not
 *     focus the light, and the exact chains' cost paid only under a small light; a flat mirror,
 *     enumerated by flat_chains.h too, is a mirror to these rules and the slab rules below (as a
 *     mirror ball is), not flat glass;
 *   - off too, for path, where every caster is flat-faced glass under area lights in the open and
 *     the caustic pilot (snee_plan.c, caustic_gain: pinhole rays followed through the glass to
 *     their receivers, joined to the lights by straight segments) finds no receiver in view lit
 *     through the glass: the flat enumeration's cost then buys nothing in view;
 *   - otherwise the angular solver with its defaults (spc_snee_params_default) and the query from
 *     the camera (SPC_SNEE_PLAN_SETTING; by roulette if every caster is a mirror enumerated
 *     exactly: SPC_SNEE_PLAN_SETTING_MIRRORS, and without it, with the query at every
 *     first receiver, where some mirror goes to the randomized solver:
 *     SPC_SNEE_PLAN_SETTING_SOLVED_MIRRORS; for path without it too where every caster is a glass
 *     normal-mapped plane with the camera and the lights on one side: SPC_SNEE_PLAN_SETTING_WATER).
 *     Where every glass caster is enumerated exactly (below), that
 *     query is made in a fraction Q = sqrt(s) / 10 of the camera samples (up to sqrt(s) on films
 *     too small for 100 queries a pass; camera=Q), s the share of the image whose camera ray
 *     meets a glass caster first (a grid of pinhole rays): the query costs about as much as the
 *     rest of specular NEE per sample wherever the glass is, and pays only on the pixels that see
 *     it. Russian roulette with probability Q
 *     minimizes cost x variance at Q = sqrt(c V_q / (c_q V)) (c, V the cost and variance of the
 *     rest, c_q and V_q the query's); with c_q ~ c and the query's variance on a share s of the
 *     pixels, Q ~ sqrt(s). The splats of every camera sample's query pool on the few pixels that
 *     see the light's images, so V_q / V is far below s: at Q = sqrt(s) the splats held 0.0-0.1%
 *     of the variance on the glass sphere and the demo, and sqrt(s) / 10 was 1.1-1.6x better at
 *     equal CPU time than sqrt(s) (bench/RESULTS.md, "Fold 6"), which was 1.3-1.6x better than
 *     the query in every sample. Where glass goes to the randomized attempts, the query's splats
 *     already carry the Bernoulli trial counts' tail, and 1/Q on top lost: the SDF scene
 *     sdf_shapes_csg 2.2x worse at Q = 0.2 (bench/RESULTS.md, "Plan: never worse than none").
 *     Chains of up to the scene's specular_max_chain (2)
 *     vertices through and off glass and off mirrors, MIS with BSDF sampling, the
 *     longer chains with probability 0.1, and every chain on one analytic sphere, one mirror
 *     cylinder or one normal-mapped plane enumerated exactly (sphere_chains.h, cylinder_chains.h,
 *     plane_chains.h); with only such casters the randomized solver itself never runs.
 *     For path where every caster is flat glass, the query from the camera stays only where a
 *     pilot of SPC_SNEE_PLAN_CAMERA_PILOT such queries (snee_plan.c, camera_finds_light) finds a
 *     light in view through or in the glass: slabs seldom show the camera a light, and where they
 *     do not the query only costs, its splats all zero (paired CPU per sample 2% on
 *     scenes/newton_slabs.xml and caustic_slabs.xml, 7% on caustic_slabs_small_light.xml, each image
 *     the same value for value; bench/RESULTS.md, "Flat glass under sphere lights").
 *     bdpt gets its own setting (SPC_SNEE_PLAN_SETTING_BDPT, _BDPT_MIRRORS): it runs specular NEE
 *     only where its own strategies cannot reach (integrator/bdpt.c), so it needs no roulette past
 *     the first receiver, and the query from the camera pays there on one sample in ten, or on
 *     sqrt(s) / 10 (at least 0.02, no raise on small films) where every glass caster is
 *     enumerated exactly.
 *     A tessellated ball gets the query from the camera on one sample in ten and at a quarter of
 *     the first receivers where it looks small (SPC_SNEE_PLAN_SETTING_BALLS). volpath, whose
 *     receivers are medium points, weighs the chains through a tessellated ball with the stand-in
 *     psi (SPC_SNEE_PLAN_SETTING_BALLS_VOLPATH).
 * Why angular: of the solvers it has the exact enumerations with reflections and longer chains, and
 * on the caustic scenes it was the fastest unbiased choice at equal time (the pool: 96x against
 * path, conic 45x, newton 26x); newton was slow and biased on multi-interface chains (two tilted
 * slabs: -2.5% at 52x the time per sample of path; bench/RESULTS.md). "none" (or "off") turns
 * specular NEE off; any other setting (spc_snee_parse) is used as given. "auto:pilot" makes the same
 * plan and lets a pilot render keep it or turn it off (render/snee_pilot.h; plan.pilot).
 */
#ifndef SPC_MANIFOLD_SNEE_PLAN_H
#define SPC_MANIFOLD_SNEE_PLAN_H

#include <stdbool.h>
#include <stddef.h>

#include "manifold/snee_options.h"
#include "manifold/solver.h"
#include "specula/specula.h" /* SPC_SPECULAR_NEE_MAX */

/* The setting the plan picks wherever specular NEE pays (the reasons are above): chains that
 * reflect off glass as well as refract (the light's image in a glass ball or on water, internal
 * reflections in the longer chains), and the same chains from the camera (the light seen in or
 * through glass; the plan lowers the query's probability camera=Q where glass covers little of the
 * image, snee_plan.c). Without either, those paths are left to BSDF sampling and to camera rays, which
 * find the light's small image rarely: on the SDF torus, the pool and the glass sphere one pixel
 * then held 73-99% of the error at equal CPU time, and with both the default's relMSE was 4-8x
 * lower than without specular NEE (bench/RESULTS.md, "Heavy tails of the default"). Reflections were
 * once left out as biased (random caustic scene 2 read 0.5% high against Mitsuba 3 over half its
 * pixels): the references were short, not specula; they find the light's reflection in the ball
 * in a few pixels only, and summed over 4x4 pixel blocks or the whole image the two agree, as do
 * bdpt at 65536 spp and Mitsuba 3's ptracer per pixel (bench/RESULTS.md, "Reflections off glass:
 * no bias"); reflections lose 1.5x at equal time on scenes/dielectrics.xml (a point light). Past a
 * path's first receiver the query is made with probability 0.25 (later=0.25, unbiased Russian
 * roulette): in an enclosed room most queries are at deeper vertices, where the caustic
 * only lights the room; equal-time relMSE against none went from 1.3x to 2.5x on the pool and from
 * 0.7x to 1.2x on the demo with reflections off (bench/RESULTS.md, "The per-sample cost of
 * specular NEE"). At every receiver, the first included, the query is made always only where the
 * casters' bounds fill x's directions and elsewhere with the share they fill, at least 0.1
 * (first=0.1, later=0.1, snee_cost.h): the queries far from the casters found a faint caustic at
 * full cost; 1.7x (glass sphere) and 2.0x (demo) lower relMSE x CPU than later=0.25 alone
 * (bench/RESULTS.md, "Tenx"). */
#define SPC_SNEE_PLAN_SETTING "angular:camera,first=0.1,later=0.1"

/* The setting where a glass caster is a tessellated ball (a triangle mesh with a fitted sphere,
 * fit_seeds.h): the query at a path's first receiver with probability 0.15 where the casters look
 * small (first=0.15, 1 near them: snee_cost.h), and from the camera in one camera sample in ten
 * (camera=0.1, Russian roulette). With the ball's chains cheaper and their grazing reflections
 * counted exactly, first=0.15 against 0.25 at equal CPU time (0.90x the CPU per sample): the glass
 * ball over 48 seeds mean relMSE 0.0141 against 0.0172 (none 0.079), random triangle-ball scenes
 * 338 (48 seeds) 5.8e-5 against 7.1e-5, 318 (48) 1.06e-3 against 1.12e-3, 41 (24) 3.6e-3 against
 * 4.8e-3, 8 (24) 2.38e-5 against 2.42e-5. first=0.1 (0.85x the CPU) did as well or better on all
 * but 338, where its higher sample count reached a one-sample tail that 0.25 draws alike at that
 * count (8.5e-5 over 48 seeds; bench/RESULTS.md, "The triangle glass ball's first receiver at
 * 0.15"). Earlier measurements, before those changes: the first receiver's query holds two
 * thirds of a sample's CPU there; at equal CPU time over 48 seeds of bench/check/glass_ball_mesh.xml
 * first=0.25 has mean relMSE 0.058 (median 0.013), first=0.5 0.079 (0.015), the query at every
 * first receiver 0.125 (0.023; none 0.079, median 0.068). Random caustic scene 8 over 24 seeds: 5.8e-5 (first=0.5
 * 1.0e-4) against 2.2e-4; random 41: 6.8e-3 (1.5e-3) against 2.5e-3, its worst seed one sample
 * that the query at every first receiver draws alike, reached at first=0.25's higher sample count
 * (without each one's worst seed 1.33e-3, 1.14e-3 and 1.42e-3). first=0.1 made a one-pixel
 * firefly on random 8 (bench/RESULTS.md, "The triangle glass ball's cost per sample: ...");
 * before the ball pass's seeds and the camera query's roulette it had lost here too (below). The
 * query
 * from the camera took half the CPU on bench/check/glass_ball_mesh.xml (45 against 90 spp at equal
 * time without it) while its splats held little of the error; at equal CPU time camera=0.1 against
 * the query in every sample: the glass ball over 48 seeds mean relMSE 0.142 against 0.328 (median
 * 0.028 against 0.044; none 0.079, median 0.069), random caustic scene 8 over 8 seeds 0.000226
 * against 0.000442, 41 0.00135 against 0.00330. Without the query at all, random 8 was 6.3x worse
 * (a one-pixel firefly: the light seen in the ball from the camera). With the ball's real solve
 * probability (solve_mis.h) the query's splats do not carry the trial counts' tail that made 1/Q
 * lose on randomized casters elsewhere (bench/RESULTS.md, "The triangle glass ball's worst seeds
 * traced"). On
 * bench/check/glass_ball_mesh.xml at equal CPU time over 8 seeds the mean relMSE was 0.86 (worst seed
 * 6.5, one pixel 100% of it) with first=0.1 and 0.0745 (worst 0.39) without (none: 0.125); random
 * caustic scene 31 48x none against 40x, 41 6.2x against 9.0x (bench/RESULTS.md, "The tessellated
 * ball and the first receiver's roulette"). Over 24 seeds both settings have the same one-sample
 * tail (0.62 with first=0.1, 0.78 without; medians 0.040), a BSDF-sampled path of MIS weight 1
 * that the roulette does not change; on five of seven random triangle-ball scenes first=0.1 lost
 * (bench/RESULTS.md, "The triangle glass ball's tail over 24 seeds"). */
#define SPC_SNEE_PLAN_SETTING_BALLS "angular:camera=0.1,first=0.15,later=0.1"

/* volpath's setting where a glass caster is a tessellated ball: SPC_SNEE_PLAN_SETTING_BALLS with the
 * query from the camera in every sample (camera=0.1 is not measured on volpath) and without
 * the real solve probability's MIS (nosolvemis: the stand-in psi, as on every other caster) and so
 * without the ball pass of the longer chains (specular_nee.c). volpath's receivers are medium points,
 * whose phase function's density toward a chain's first vertex is small, so the real probability's
 * count Z = (1 - r^N) / b is nearly the plain trial count N / A there (solve_mis.h), and the ball
 * pass cost 45% of the time per sample: on scenes/medium_glass.xml (a glass icosphere filled with
 * a scattering medium) at equal CPU time over 6 seeds the mean relMSE was 0.292 (worst seed 0.567)
 * with solvemis and 0.0523 (0.113) without (none: 0.455), lower in every seed (bench/RESULTS.md,
 * "The default against none on every caster scene"). The query at a path's first medium receiver
 * with probability 0.1 where the casters look small (first=0.1, 1 within their bounds: snee_cost.h),
 * as later=0.1 past it. In a fog around the ball (bench/check/medium_fog_ball.xml) most medium points
 * see the light directly and few see a caustic; a query at each cost twice none's time per sample for
 * 1.5x less variance. At equal CPU time (paired seeds) the mean relMSE there was 0.046 without the
 * roulette and 0.031 with first=0.1 over 24 seeds; over 48, 0.0335 with first=0.1 against none's
 * 0.0326, equal within the seeds' scatter (first=0.05 like 0.1, 0.25 a little worse: bench/RESULTS.md,
 * part fog16). In scenes/medium_glass.xml, whose medium points lie within the ball's bounds, the
 * query stays certain and the images are the same bit for bit (as in bench/check/medium_torus.xml,
 * whose SPC_SNEE_PLAN_SETTING has first=0.1 already). The stand-in psi 0.3 (mispsi=0.3) instead of
 * 0.1: a long phase-sampled path through the chromatic medium that left the ball by a reflection
 * inside and a refraction (b = 1.06 against specular NEE's psi p_y = 0.625) kept weight 0.74 and one
 * pixel of a seed's error; with 0.3 its weight is 0.24. On scenes/medium_glass.xml at equal CPU
 * over 48 seeds the mean relMSE was 0.0173 against 0.0247 (median 0.0125 both; seeds with one pixel
 * over 0.6 of the error 2 against 4; 1.0 over 24 of them 0.0214 against 0.0212 for 0.3); in the
 * fog around a ball (bench/check/medium_fog_ball.xml) 0.119 against 0.115 over 24 paired seeds, a
 * difference of 0.004 +- 0.004 (bench/RESULTS.md, "medium_glass's one-pixel seeds"). Where the balls
 * sit in a fog instead (outside them, none within), volpath's plan leaves specular NEE off
 * (snee_plan.c, glass_in_medium). The roulette's share by the ball's own sphere and its shadow
 * (tightshare) is not in the setting: on scenes/medium_glass.xml at equal CPU over 24 seeds it was
 * 0.0328 against 0.0323 without (the same one-pixel seed in both); it helped only in the fog, where
 * the plan is now off (bench/RESULTS.md, "the fog ball and dielectrics"). */
#define SPC_SNEE_PLAN_SETTING_BALLS_VOLPATH "angular:camera,first=0.1,later=0.1,nosolvemis,mispsi=0.3"

/* volpath, where some caster's chains go to the randomized attempts (a tessellated ball, an SDF, a
 * mirror mesh): 0.8 of those attempts' seeds at medium points drawn from the point's phase function,
 * the rest from the cone with the straight-line attempt as before (spc_snee_params.phase_seeds).
 * From a medium point near a glass ball's surface the chains that refract out of it, or reflect
 * inside first, lie far from the straight line to the light, where the cone seeds find them
 * rarely: their large trial counts (one count of 88 held a seed's whole error) and the weight-1
 * phase-sampled paths they leave behind were the default's tail. At equal CPU time, 32x32, mean
 * relMSE (bench/RESULTS.md, part medvol16): scenes/medium_glass.xml, cone seeds alone 0.078 over
 * seeds 25-56 and 1.50 over 57-72 (one pixel of 22.7), phase seeds 0.8 0.016 over 57-88, all
 * phase seeds (seed=bsdf, no straight-line attempt) 0.032 over the same seeds, none 0.295; a glass
 * SDF torus filled with smoke (bench/check/medium_torus.xml, heavy tails) cone 0.38 over 32 seeds,
 * 0.5 phase 0.24, seed=bsdf 0.155 (and 0.113 over 33-48, where 0.8 had 0.175), none 0.34; a glass
 * ball in a fog over a floor (bench/check/medium_fog_ball.xml) cone 0.070, 0.8 0.041, seed=bsdf
 * 0.040, none 0.033 (specular NEE does not pay there); HG g = 0.85 in medium_glass, 12 seeds, cone
 * 0.19, 0.8 0.058, 0.5 0.062, seed=bsdf 0.071, none 0.21. */
#define SPC_SNEE_PLAN_VOLPATH_PHASE_SEEDS ",phaseseeds=0.8"

/* Guided seeds for the randomized attempts (a triangle mesh with vertex normals, an SDF): a share
 * 0.8 of those attempts seeded toward the chains of light paths traced before the render that landed
 * near the receiver (seed_guide.h). Not in the plan: they lower the Bernoulli trial counts' tail but
 * do not remove it (the triangle glass ball 4.5x none in one batch of 3 seeds, 0.6x in another; the
 * SDF torus over 8 seeds 0.7x against the unguided 1.5x: bench/RESULTS.md, "Guided seeds"), so
 * they stay an option to append to a setting. */
#define SPC_SNEE_PLAN_SEED_GUIDE ",seedguide=0.8"

/* Appended to path's glass settings in a room (the casters open to the sky in less than
 * SPC_SNEE_PLAN_ROOM_OPEN of their directions, snee_plan.c's open_share: the demo's 0.109; the
 * other caustic scenes 0.4-0.67) where some glass caster is an analytic sphere (its chains
 * enumerated exactly) small enough for a cone (caustic_guide.h, spc_cguide_cone_sphere):
 * - caustic guiding at receivers (recguide=0.1), a share 0.1 of each diffuse vertex's directions
 *   toward the caustics a photon pre-pass finds and toward each glass ball. The paths it makes more
 *   likely are the caustic seen through the glass from a diffuse bounce (the demo's ceiling sees the
 *   bright spot where the glass ball touches the floor through the ball: camera - ceiling - glass -
 *   glass - floor - specular NEE), which BSDF sampling finds rarely and with a large weight; in a
 *   room that light reaches much of the image. The defensive mixture costs every other direction
 *   1 / (1 - A) in weight, so A stays small: on the demo at equal CPU time over 8 seeds A = 0.1
 *   lowered the mean relMSE 1.3x, A = 0.25 and 0.5 raised it 2.5x and 4x. In the open it was
 *   mixed (3 seeds): the glass-ball caustic 1.4x lower, dielectrics 1.2x and ball_small_light 1.2x
 *   higher (its cost per sample 1.4x), so not there;
 * - the longer chains (up to 6 vertices: internal reflections in the ball) looked for with
 *   probability 0.2 per light sample instead of 0.1 (long=0.2): their 1 / P count made the demo's
 *   remaining one-pixel seeds (a spot on the red wall beside the glass ball, lit through chains that
 *   reflect inside it);
 * - those chains only up to 4 vertices (longmax=4): the pass picks one length per light sample,
 *   uniformly from 3 to its top, so at the top of 6 a 3-vertex chain was looked for on 0.05 of the
 *   light samples and counted 20 times. The demo's one-pixel seeds of that class are 3-vertex chains
 *   (light off the mirror ball through the glass ball onto the red wall) and one 5-vertex chain;
 *   with the top at 4 the 3- and 4-vertex chains get 0.1 each and the 5- and 6-vertex ones are
 *   left to BSDF sampling (weighed 1 there). At the top of 3 the 4-vertex chains' BSDF hits made
 *   new one-pixel seeds; long=0.4 took 1.2x the CPU per sample (the bench's calibration);
 * - the chains on the glass ball of 5 and 6 vertices (three and four internal reflections) on a
 *   share 0.03 of the calls (sphlong=0.03), so that BSDF sampling's hits of them are weighed against
 *   specular NEE instead of counted 1: left to BSDF sampling they were most of the demo's remaining
 *   one-pixel seeds (floor, ceiling or back wall - glass T R R R T - light, 28-105 in a pixel of
 *   0.1-0.25). The share 0.1 cost 1.13x per sample, 0.03 1.03x, and 0.01 left 12148's pixel at
 *   1.5x its mean (bench/RESULTS.md, part demo38).
 * Together 14-15x none on the demo at equal CPU time against the plain setting's 7.5-8.3x and
 * 10.5-11.2x with the guide alone (bench/RESULTS.md, "Caustic guiding toward glass balls in the
 * default"; the longer chains' top: "The demo's longer chains up to 4 vertices"). Not for volpath
 * (which builds no guide) nor bdpt: not measured there. */
#define SPC_SNEE_PLAN_ROOM_OPEN 0.25
#define SPC_SNEE_PLAN_ROOM_GLASS_BALL ",recguide=0.1,long=0.2,sphlong=0.03,longmax=4"

/* Appended for path where every light is a point light (or a spot light, traced alike) and a glass
 * sphere is a caster: the point lights' caustics also by light tracing (integrator/path_lt.h: seen
 * directly, through the ball and through a diffuse bounce), weighed against specular NEE, whose
 * value there, the caustic's irradiance at a sampled point, has a log-divergent second moment near
 * the caustic's fold. On
 * bench/check/point_light_ball.xml at equal CPU time (bench/RESULTS.md, "Point lights' caustics by
 * light tracing"): 64x64, 4 CPU-s, 8 seeds, mean relMSE 0.0665 -> 0.0030 (worst seed 0.41 ->
 * 0.0058); 32x32, 1 CPU-s, 16 seeds, 0.016 -> 0.0051; it costs 2.2x per sample. A sky besides
 * takes no part in it: random scene 8772 (a glass sphere under a point light and a sky) 2.6x -> 3.0x
 * none over 16 seeds (the sphere's caustic tail gone, one path-tracer tail left that both share),
 * fresh point-light-and-sky scenes with glass spheres 1.1-10x lower mean relMSE on 8 of 10, one at
 * the reference's noise either way, one with no tail without it 7.5x worse (still 30x none);
 * bench/check/spot_ball.xml 6.8x lower (bench/RESULTS.md, "Light tracing (`ltcaus`) for spot
 * lights"). Not with other lights:
 * on scenes/dielectrics.xml (a point light, an area light, a water ball, a sky) 1.2x worse (its
 * cost per sample 1.14x, no gain in the error per sample). */
#define SPC_SNEE_PLAN_POINT_LIGHTS ",ltcaus"

/* Not appended by the plan: the longer chains' pass to 8 vertices inside a glass SDF without creases
 * (",longmax=8,longev=0.9": light that runs along a glass tube by total internal reflection makes 7-
 * and 8-vertex chains). On scenes/caustic_sdf_torus.xml it removed one BSDF-sampled firefly but
 * added new tails on about one fresh seed in ten at 1.22x the CPU per sample (80 fresh seeds;
 * bench/RESULTS.md, part torus25 and the merged main's check), so the light guides go to light
 * tracing alone (SPC_SNEE_PLAN_LIGHT_GUIDES). */

/* Appended for path where some caster is flat-faced (a slab; beside glass or mirrors), the smallest
 * light subtends more than SPC_SNEE_PLAN_FLAT_MAX_SR at the casters, and the flat enumeration's
 * face sequences per query times that solid angle is at most SPC_SNEE_PLAN_FLAT_COST_SR (a pilot,
 * snee_plan.c; SPC_SNEE_PLAN_FLAT_ALONE_COST_SR where every caster is flat-faced,
 * SPC_SNEE_PLAN_FLAT_MIRROR_COST_SR beside a mirror): the longer chains on (long), so that the slabs' chains of up to 4 vertices are
 * enumerated at every call, and their 5-vertex chains (in, three total internal reflections, out: the slab as a light
 * guide) on every call too. Without them only BSDF sampling makes those chains, and the query's cost
 * per sample turns each such hit into a firefly (bench/RESULTS.md, "Glass sphere beside a flat
 * slab"). Measured in bench/RESULTS.md, "Slab scenes the plan left at none", "a cost-based plan
 * rule" and "the slab plan never worse than none". */
#define SPC_SNEE_PLAN_FLAT_LONG ",long=0.3,flat5=1"

/* Appended after SPC_SNEE_PLAN_FLAT_LONG where a mirror stands beside the flat casters: the query at
 * every first receiver. With the first receiver's query by roulette (probability 0.1-0.3 there), a
 * BSDF-sampled path through the glass and then off the mirror to the light keeps an MIS weight
 * near 1 and is the image's one-pixel seeds; with the query certain specular NEE takes those paths.
 * At equal CPU time (bench/RESULTS.md, "The split by roulette on flat glass" and "the glass cube
 * queried at every first receiver"):
 * scenes/caustic_glass_cube.xml over 48 seeds 1.15x none's mean relMSE without it (4 one-pixel
 * seeds, the worst at 0.71) and 9.6x with it; random scene 9304 (a glass cube beside a mirror
 * cylinder) 15.4x -> 21.2x over 32 seeds. Not without a mirror: 9312 (glass cube and glass sphere)
 * 51x -> 27x, 8504 (a tessellated ball beside slabs) 14.3x -> 10.1x. */
#define SPC_SNEE_PLAN_FLAT_MIRROR_FIRST ",first=1"

/* Appended for path where some caster is flat-faced (a slab) and the lights are small area lights
 * (as SPC_SNEE_PLAN_AREA_LIGHTS; ",ltcaus" first where no other rule added it), without the caustic
 * guide at receivers: light tracing makes the slabs' caustics too (chains through flat faces of up
 * to 6 vertices, integrator/path_lt.h), so specular NEE's flat chains past the budget, whose
 * enumeration held most of a sample's cost, run on a share of the calls (flat34; and flat5 where
 * SPC_SNEE_PLAN_FLAT_LONG put the 5-vertex chains on every call): without light tracing those
 * shares made one-pixel seeds (BSDF sampling's paths at weight near 1), with it light tracing
 * takes the larger part of those paths. Measured in bench/RESULTS.md, "Light tracing of caustics
 * through flat glass slabs". The path's track and light tracing's flat chains go to 8 vertices
 * (longmax=8; specular NEE's own chains through slabs stay within the enumeration's 6): a chain
 * along a slab (in, five total internal reflections, out of its side face) is then light
 * tracing's and BSDF sampling's; at 6 it was BSDF sampling's alone, a one-pixel seed at the
 * query's cost per sample (bench/RESULTS.md, "the slab scenes' one-pixel seeds"). */
#define SPC_SNEE_PLAN_FLAT_LT ",flat34=0.3,longmax=8"
#define SPC_SNEE_PLAN_FLAT_LT_LONG ",flat34=0.3,flat5=0.3,longmax=8"

/* Appended for path where every caster is closed flat-faced glass (slabs, no mirror) and every light
 * is an area light larger than the flat rules' SPC_SNEE_PLAN_FLAT_LONG_MAX_SR up to
 * SPC_SNEE_PLAN_FLAT_LARGE_MAX_SR (snee_plan.c), without the caustic guide at receivers: the plan's
 * setting for slabs under small lights, with light tracing on every camera sample (ltshare=1). The
 * flat enumeration's query costs about a hundred BSDF samples there and carries the caustic with
 * little variance; light tracing on every sample takes more of the chains BSDF sampling and the
 * query share. Measured at equal CPU time against none (bench/RESULTS.md, "Slabs under larger
 * lights"). The 3- and 4-vertex chains on a tenth of the calls: with light tracing on every sample
 * they were half the query's cost for little of its variance (at equal CPU, 1.3-2x more samples;
 * mean relMSE over 16-32 seeds: scenes/caustic_slabs.xml 2.6-2.8x lower, fresh slab scenes under
 * 0.031-0.035 sr 1.4x and 2.5x; bench/RESULTS.md, "the 3- and 4-vertex chains on a tenth of the
 * calls"); a share of 0.05 made one-pixel seeds. The long pass on 0.4 of the calls (long=0.4:
 * psi 0.1 for each length past the budget, where 0.1 gave 0.025): its randomized 7- and 8-vertex
 * chains through the slabs (partial and total reflections, out of a side face), counted with
 * 1 / psi, were scenes/newton_slabs.xml's one-pixel seeds (a sample of 361 at seed 11021 against a
 * pixel of 0.3), and the pass costs little (instructions per render +2.3% there, +0.2% on
 * scenes/caustic_slabs.xml; bench/RESULTS.md, "The long pass's own light point under lightx"). And
 * the chains through the slabs alone that are longer than their enumeration left to light tracing
 * and BSDF sampling (longflatlt): the long pass's count of them (events drawn at 0.2 a reflection,
 * four reflections, 1/p estimates of 5-7 x 10^4 with its density and BSDF sampling's within 1.6x of
 * each other) was newton_slabs' one-pixel seed; without it, over 3 x 24 seeds at equal CPU time,
 * newton_slabs' mean relMSE 1.26x lower (no seed's worst pixel above 0.29 of it), caustic_slabs' the
 * same (25.8x against 26.3x none). */
#define SPC_SNEE_PLAN_FLAT_LARGE ",ltcaus,ltshare=1,flat34=0.1,longmax=8,long=0.4,longflatlt"

/* SPC_SNEE_PLAN_FLAT_LARGE with the long pass on 0.2 of the calls (psi 0.05 for each length past the
 * budget) where the scene's chain budget is SPC_SNEE_PLAN_FLAT_LARGE_DEEP vertices or more: the
 * enumeration then holds the 3- and 4-vertex chains at every call and the pass has only the 5- to
 * 8-vertex ones, which carry little of the image. On scenes/newton_slabs.xml (budget 4) the same
 * variance per sample at 0.2 as at 0.4 over 72 seeds (0.644 / 0.653, 0.574 / 0.576, 0.707 / 0.705)
 * for 2.1% fewer instructions per sample, and no one-pixel seed from the pass (bench/RESULTS.md,
 * "the long pass on 0.2 of the calls where the chain budget is 4"); scenes/caustic_slabs.xml
 * (budget 2) read the same at 0.2 and 0.4 and keeps 0.4. */
#define SPC_SNEE_PLAN_FLAT_LARGE_DEEP_LONG ",ltcaus,ltshare=1,flat34=0.1,longmax=8,long=0.2,longflatlt"
#define SPC_SNEE_PLAN_FLAT_LARGE_DEEP 4

/* Appended after SPC_SNEE_PLAN_FLAT_LARGE where the camera sees glass on at least
 * SPC_SNEE_PLAN_FLAT_LARGE_GUIDE_GLASS of the image (snee_plan.c, glass_image_share): the two path
 * classes that then held the mean's one-pixel seeds, both BSDF sampling's alone, get light tracing
 * too: the light guides (ltguide: light led along a slab by total internal reflection, out of a
 * side face onto the floor, 9-10 vertices, past the track's 8) and the floor seen through a slab
 * (ltslab: the area light's subpaths joined to the pinhole through 1-2 flat faces, so the chains
 * with a partial reflection inside the glass, which the enumeration leaves out, are light
 * tracing's there too). At equal CPU time (bench/RESULTS.md, "the slabs' light guides"):
 * scenes/caustic_slabs.xml over 32 seeds mean relMSE 0.00672 -> 0.00111 (3.0x -> 18.5x none),
 * worst seed 0.063 -> 0.0018; scenes/newton_slabs.xml 3.8x -> 4.0x; a fresh slab under 0.022 sr
 * with glass on 0.13 of the image 1.7x -> 5.4x. Their joins through the slab cost 1.06-1.4x per
 * sample (the flat walk toward the pinhole from every receiver the light reaches through glass),
 * which does not pay where little of the image looks through glass: a fresh slab with glass on
 * 0.029 of the image lost 1.3x with them and 1.2x with the light guides alone (7.4x none without). */
#define SPC_SNEE_PLAN_FLAT_LARGE_GUIDES ",ltguide,ltslab"
#define SPC_SNEE_PLAN_FLAT_LARGE_GUIDE_GLASS 0.05

/* Appended for path where a glass caster is a tessellated ball (a triangle mesh with a fitted
 * sphere) and every light is a point light (a sky besides), without the caustic guide at receivers:
 * light tracing makes the ball's point-light chains too and joins them to the pinhole directly,
 * through a diffuse bounce and through the ball (the chains specular NEE's solver finds from the
 * fitted sphere's solutions toward the pinhole), weighed against specular NEE's unbiased count of
 * them (integrator/path_lt.h). At equal CPU time against bdpt over 24 seeds, without the pixels
 * that see the point light through the glass (bench/RESULTS.md, "Point lights through flat glass
 * by light tracing", part 3): bench/check/point_light_ball_mesh.xml 2.3x lower mean relMSE than
 * without, random triangle-ball scenes 1.15-1.23x on four of five and 0.90x on one; without the
 * joins through the ball 0.77-1.11x (geometric mean 0.96x), which kept it out before. */
#define SPC_SNEE_PLAN_BALL_POINT_LIGHTS ",ltcaus"

/* Appended for path where some caster is flat-faced (a slab) and every light is a point light (a
 * sky besides), without the caustic guide at receivers, where no other rule added it: light
 * tracing makes the point lights' chains through flat faces of up to 6 vertices too
 * (integrator/path_lt.h), weighed against specular NEE's flat enumeration; the 5- and 6-vertex ones,
 * which specular NEE does not make by default, no other strategy makes. At equal CPU time against
 * bdpt over 32 seeds, without the pixels that see the point light through the glass (bench/
 * RESULTS.md, "Point lights through flat glass by light tracing"), 1.05-9.3x lower mean relMSE than
 * without on 7 of 9 slab scenes under a point light, 0.96-0.97x on the other two. The flat
 * enumeration's 3- and 4-vertex chains on a share of the calls besides (SPC_SNEE_PLAN_FLAT_LT, as
 * under small area lights) was lower on 8 of 9 (1.4-13x) but made one-pixel seeds on two (random
 * scenes 1057 and 6101: shares 0.94 and 0.99, 6101 3x worse than without): light tracing did not
 * join the pixels that see the floor through a slab (the joins below do now:
 * SPC_SNEE_PLAN_FLAT_POINT_JOINS). */
#define SPC_SNEE_PLAN_FLAT_POINT_LIGHTS ",ltcaus"

/* Appended for path where some caster is flat-faced, every light is a point light (a sky besides)
 * and light tracing runs (ltcaus, by the rule above or the sphere's or the ball's), without the
 * caustic guide at receivers: light tracing also joins the receivers seen through a slab to the
 * pinhole (chains of 1-2 flat faces, integrator/path_lt.h), paths that only specular NEE at the
 * receiver made, and the 5- and 6-vertex light chains onto them none did (0.37% of
 * bench/check/two_slabs_point_light.xml's image). 0.96-1.0x the CPU per sample; at equal CPU time
 * over 16 seeds (bench/RESULTS.md, part rcvslab30) within the seeds' scatter of the setting
 * without it where no pixel sees a floor through a slab, lower where some do (random scenes 8066
 * 3.7x, 8037 1.5x). */
#define SPC_SNEE_PLAN_FLAT_POINT_JOINS ",ltslab"

/* Appended after it where no caster is a mirror ball and no rule set flat34: the flat enumeration
 * makes its 3- and 4-vertex chains on a share of 0.1 of its calls, counted 10 times (at every call
 * it enumerates every face sequence of up to 4 vertices at every query: 67x none's CPU per sample on
 * random scene 7812), weighed against light tracing, which with the joins above makes those paths
 * at every receiver the camera sees directly or through a slab. At equal CPU time over 16 seeds
 * (bench/RESULTS.md, part rcvslab30), against the setting without it: 2.3-97x lower mean relMSE on
 * 11 of 12 slab scenes (two beside a mirror ring), 0.83x on one whose every setting had one-pixel
 * seeds (a triangle ball beside the slab; 1.3x over 32 seeds); 0.1 below 0.3 on 10 of the 12 (0.3
 * the safer tail: one scene fewer with one-pixel seeds). Beside a mirror ball (random scenes
 * 6101 made point-lit, 8009) the share made one-pixel seeds at 0.1 and 0.3 alike, with the joins
 * or without: specular NEE's 4-vertex chains at the floor seen in the ball (no light tracing in
 * it), so it is left out there. */
#define SPC_SNEE_PLAN_FLAT_POINT_SHARE ",flat34=0.1"

/* Appended for path where a caster is a closed flat-faced glass shape (a slab), every light is a
 * point or spot light (a sky besides) and light tracing's caustics run (ltcaus), without the caustic
 * guide at receivers, where max_depth leaves room for a chain of SPC_FLAT_MAX_VERTICES + 1 vertices
 * (or is unlimited): the light guides from the point and spot lights (integrator/path_lt.h), the
 * light led along the slab by total internal reflections onto a surface the camera sees (in at one
 * end, 5 reflections, out at the other: 7 vertices), which light tracing's caustics (at most
 * SPC_FLAT_MAX_VERTICES) and specular NEE within its budget do not make and BSDF sampling never
 * meets: without it bench/check/spot_slab_guide.xml reads a third low where that light lands
 * (bench/RESULTS.md, "A spot light's light guided along a glass slab"). */
#define SPC_SNEE_PLAN_POINT_GUIDES ",ltguide"

/* Appended for path where the lights are small area lights (and point lights, and a sky) and a
 * glass sphere or a tessellated glass ball is a caster, without the caustic guide at receivers: the
 * area lights' caustics also by light tracing from a point on the light (integrator/path_lt.h),
 * weighed against specular NEE and BSDF sampling at the caustic's receiver. Measured in
 * bench/RESULTS.md, "Area lights' caustics by light tracing" and "Light tracing of caustics through
 * the triangle glass ball". */
#define SPC_SNEE_PLAN_AREA_LIGHTS ",ltcaus"
/* The largest solid angle (sr, from the casters' centre) of an area light for that rule: the lights
 * measured subtend 0.003-0.009 sr. */
#define SPC_SNEE_PLAN_LT_AREA_SR 0.02

/* Appended for path where a glass caster is a smooth SDF (the randomized attempts' shape) and the
 * lights are small area lights (SPC_SNEE_PLAN_LT_AREA_SR; point lights and a sky besides), without
 * the caustic guide at receivers: the light guides' chains, longer than any specular NEE makes
 * (a glass ring's total internal reflections), also by light tracing from a point on the light
 * (integrator/path_lt.h), weighed against BSDF sampling at the camera ray's hit. On
 * scenes/caustic_sdf_torus.xml each such BSDF-sampled path was a one-pixel firefly in a few seeds
 * of 48; light tracing removes them at 2% of the CPU: over 96 fresh seeds at equal CPU the mean
 * relMSE fell 0.149 -> 0.105 (bench/RESULTS.md, "Light guides by light tracing"). On the triangle
 * glass ball it changed no pixel and cost 5.5%, so meshes are left out.
 * Without the longer chains' pass (nolong): on the SDF its randomized 3- and 4-vertex chains (two
 * reflections picked at reflect_p, P(events) 0.0256) come with a trial count of a hundred or more,
 * so a rare counted sample is thousands of times a pixel's value, while MIS takes those paths from
 * BSDF sampling on every other sample: most renders read the floor in front of the torus about
 * 0.8% low and one in several far high. Left to BSDF sampling (and the light guides' light
 * tracing) those chains are bounded by BSDF sampling's own values (bench/RESULTS.md, part
 * torus29). */
#define SPC_SNEE_PLAN_LIGHT_GUIDES ",ltguide,nolong"

/* Appended with SPC_SNEE_PLAN_LIGHT_GUIDES (path, a glass SDF under small area lights): the
 * camera-side split (integrator/path_camsplit.h), 4 more camera rays where the camera ray meets the
 * glass first. The light seen through the SDF after a reflection inside it (camera - T R T -
 * light, T T T T) is the camera ray's alone (specular NEE from the pinhole takes 1-2 vertices,
 * light tracing joins the pinhole through spheres and flat faces only), and on
 * scenes/caustic_sdf_torus.xml it held most of the worst seeds' error. At equal CPU over 48 seeds
 * the torus's mean relMSE fell 0.121 -> 0.095 with K 4 (none 0.240), without its one worst seed (a
 * tail of another class) 0.083 -> 0.049; K 16 did worse (its rays cost 26% of the samples, K 4's
 * 7%). On 6 fresh glass tori (24 seeds) 1.03-2.2x lower on five, 0.74x on one: a one-pixel seed
 * of another class, whose squared error grows as the split's 10-15% of the samples go (0.95x
 * without it). On analytic spheres and glass meshes the camera query already weighs those paths:
 * the split changed no variance there (bench/RESULTS.md, "The light seen through a glass SDF from the
 * camera, split"). */
#define SPC_SNEE_PLAN_CAMERA_SPLIT ",camsplit=4"

/* Appended with SPC_SNEE_PLAN_CAMERA_SPLIT: the split's rays also take one sample of the first
 * receiver behind the glass and the light it reaches through further delta scatterings
 * (integrator/path_camsplit.h, class D): a light guide seen on the floor through the torus (camera
 * - T T - floor - T R R R T - light) and the floor's caustic reached by a light guide from the
 * camera (camera - T R...R T - floor - T T - light), BSDF sampling's alone at weight 1, held 0.85
 * of the torus's summed error over 24 seeds. At equal CPU over 48 seeds the torus's mean relMSE
 * fell 0.164 -> 0.054 (none 0.232; the three worst seeds 21x, 19x, 17x lower) for 6% of the
 * samples. On fresh glass SDFs, where the class is rarer, it costs its 2-9% of the samples and
 * its rays' own events of the class: 0.82x and 1.01x by mean over 48 seeds on two fresh tori,
 * 0.82-0.93x over 16 on four (bench/RESULTS.md, "The light guides and caustics seen through a
 * glass SDF, split"). */
#define SPC_SNEE_PLAN_CAMERA_RECV ",camrecv"

/* Appended with SPC_SNEE_PLAN_CAMERA_RECV: the glass SDF's caustics of area lights by light tracing
 * too (integrator/path_lt.h), weighed against specular NEE and BSDF sampling at the receiver: the
 * floor's caustic under the torus seen directly (two refractions near the caustic's fold, which
 * the randomized attempts rarely find and where BSDF sampling's value is large) is light
 * tracing's densest part. On scenes/caustic_sdf_torus.xml at equal CPU over 24 seeds (9851-9874)
 * the mean relMSE fell 0.119 -> 0.069 (none 0.427; median 0.055 -> 0.021), over 48 fresh seeds
 * 0.073 -> 0.055; on four fresh glass tori 1.4-3.7x lower over 16 seeds each, on a fresh capsule
 * 1.14x (its one one-pixel seed the same pixel in both). The share of samples that trace a
 * subpath, ltshare, stays 0.25: 0.1, 0.5 and 1 did worse on the torus (bench/RESULTS.md, "The
 * glass SDF's caustics by light tracing"). */
#define SPC_SNEE_PLAN_SDF_LT ",ltcaus"

/* Appended with SPC_SNEE_PLAN_CAMERA_SPLIT: specular NEE from the pinhole also looks for the glass
 * SDF's chains of 3 and 4 vertices (camlong: in, reflected inside the tube, out) on a quarter of its
 * queries, weighed against the camera ray by their real solve probability: the light seen through
 * the torus after a reflection inside its tube, a thin image of the light worth hundreds a hit, was
 * the camera ray's alone (the camera-side split's class C) and held a seed's whole error where one
 * ray met it. On every query the pass cost 23% of the CPU a sample, on a quarter too little to
 * measure; at equal CPU scenes/caustic_sdf_torus.xml's mean relMSE over 24 fresh seeds fell
 * 0.0171 -> 0.0132 (every query: 0.0170), over 9851-9874 it was 0.0315 (every query: 0.0354), and
 * on a fresh torus 0.0591 against main's 0.0626 (every query: 0.0566) (bench/RESULTS.md, "The light
 * seen through the glass torus's tube from the pinhole"). */
#define SPC_SNEE_PLAN_CAMERA_LONG ",camlong=0.25"

/* Appended for path where every caster is a flat mirror (a conductor mesh of few planes,
 * flat_chains.h) and the lights are small area lights: the mirrors' caustics also by light tracing
 * from a point on the light (integrator/path_lt.h), as for glass balls (SPC_SNEE_PLAN_AREA_LIGHTS).
 * At equal CPU time over 16 seeds (bench/RESULTS.md, "Flat mirrors enumerated exactly"):
 * bench/check/mirror_tilt.xml 554x none without it, 1057x with it (seeds 10017-10032); random scene 10007
 * with two flat mirrors for its mirror objects 102x without, 96x with it (seeds 10001-10016). */
#define SPC_SNEE_PLAN_FLAT_MIRRORS_LT ",ltcaus"

/* Path where a ball whose chains are enumerated exactly (a glass or mirror sphere) stands beside a
 * flat mirror (a conductor mesh of few planes, flat_chains.h; chains through flat glass and off the
 * mirror are that enumeration's). No enumeration takes a chain that mixes the ball and the mirror
 * (off the mirror and through or off the ball: the light's images seen in the mirror's view of the
 * ball, the ball's caustic thrown on the floor by the mirror; 2-5 vertices), so the randomized
 * attempts (the longer chains' on a tenth of the calls by default) and BSDF sampling make them,
 * and from the camera, where the light's images in the ball and in the mirror's view of it are
 * small and bright, a BSDF-sampled hit was the image's one-pixel seed. So: the query from the
 * camera on at least SPC_SNEE_PLAN_BALL_FLAT_MIRROR_CAMERA of the samples (the share rule,
 * snee_plan.c's camera_prob, gives 0.024 to a ball that fills little of the image), and, where no
 * other rule set them, the longer chains on SPC_SNEE_PLAN_BALL_FLAT_MIRROR_LONG (half of the calls,
 * lengths 3-5: the 3-vertex chains through the ball and off the mirror, the 5-vertex ones through
 * the ball twice at its foot). Measured in bench/RESULTS.md, "A glass ball beside a flat mirror":
 * lower medians on five glass scenes and the mirror ball's, 0.82x on one without one-pixel seeds (an
 * upright mirror behind the ball: the queries only cost); the longer chains' randomized attempts
 * keep one-pixel seeds of their own (a trial count at the mirror's edge). */
#define SPC_SNEE_PLAN_BALL_FLAT_MIRROR_CAMERA 0.3
#define SPC_SNEE_PLAN_BALL_FLAT_MIRROR_LONG ",long=0.5,longmax=5"

/* Appended for path where a ball enumerated exactly rests on a flat mirror (the gap between the
 * sphere and the mirror's bounding box at most SPC_SNEE_PLAN_BALL_ON_MIRROR_GAP of its radius: the
 * ball and its mirror image touch) under a light of more than
 * SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT_SR from the casters (where no caustic guide runs at
 * receivers): the camera-side split (integrator/path_camsplit.h), K more camera rays in a pixel
 * whose camera ray meets the mirror or the ball first, following their reflections and refractions
 * to the light. Under a large light BSDF sampling reaches it from the camera by all-specular
 * chains of 6 and 9 vertices, off the mirror and through the ball twice, longer than any specular
 * NEE strategy takes (weight 1, a sample worth 160-190 times the pixel): the same path at the same
 * probability per sample as --specular-nee none, but the default costs 15-26 times none's CPU a
 * sample, so at equal CPU those paths' variance was 15-26 times none's and three of 24 seeds of
 * bench/check/ball_mirror_biglight.xml were one-pixel seeds. The split counts each such path
 * 1/(K+1) for a fifth more CPU a sample. Measured in bench/RESULTS.md, "A glass ball resting on a
 * flat mirror under a large light". Where the mirror stands apart from the ball
 * (bench/check/ball_mirror_wall_biglight.xml and flat_mirror_ball_focus_biglight.xml: gaps of 0.85
 * and 0.64 radii by the box) no such seed showed and the split only cost: 1.27x higher mean relMSE
 * at equal CPU over 24 seeds on both. */
#define SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT_SR 0.01
#define SPC_SNEE_PLAN_BALL_ON_MIRROR_GAP 0.25
#define SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT ",camsplit=16"

/* Appended for path where a ball enumerated exactly stands beside a flat mirror under small area
 * lights (at most SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT_SR from the casters, light tracing on, no
 * caustic guide at receivers): light tracing's subpaths also join the pinhole through the mirror
 * (integrator/path_lt.h, ltslab: camera chains through flat faces), so the ball's caustic on the
 * floor seen in the mirror is light tracing's too. Without it that caustic was specular NEE's and
 * BSDF sampling's alone, and where a light point put the floor point seen in the mirror on the
 * caustic's fold, the sphere enumeration's two coalescing chains each carried the power heuristic's
 * largest value, about the floor's albedo times the light's radiance over 2 (a sample worth 1000
 * times the pixel): the one-pixel seeds of bench/check/hand_caustic_scenes.py's
 * hb_flatmirror_ball. At equal CPU time over 24 seeds its mean relMSE fell 2.3x (27.6x none's ->
 * 63.6x, the median 1.7x) for 5% fewer samples, and 1.1-1.25x over 16 seeds on three more scenes
 * where the floor is seen in an upright mirror; where the mirror lies under the ball
 * (bench/check/ball_mirror_floor.xml, ball_mirror_lifted.xml, ball_mirror_tilt.xml) few or no joins
 * go through it and the samples' 1-9% are paid for nothing (0.93-0.99x none's ratio).
 * Measured in bench/RESULTS.md, "hb_flatmirror_ball's tail is not a BSDF hit". */
#define SPC_SNEE_PLAN_BALL_FLAT_MIRROR_JOINS ",ltslab"

/* The setting where every caster is a mirror whose chains are enumerated exactly (a sphere, a
 * cylinder), after the query from the camera: that query by Russian roulette in a fraction Q of the
 * camera samples, Q from the share of the image that sees a mirror first as for glass (snee_plan.c,
 * camera_prob; "angular:camera=Q," before this). On every sample the query doubled relMSE on
 * scenes/caustic_mirror_ring.xml at equal CPU time (bench/RESULTS.md, "Plan rules from the scene"),
 * but without it the light's small image in a convex mirror is the camera ray's alone, a one-pixel
 * seed at the default's sample count: over 16 seeds at equal CPU time random scene 9878 (a mirror
 * ball under a sphere light) 3.6x none without the query, far below the reference's noise with Q
 * 0.024 (2300x), 9924 16.9x -> 71x (Q 0.03), 9904 62x -> 69x; where no such image is in view the
 * query costs 3-9% (9908 70x -> 64x, 9910 10.8x -> 10.3x, the mirror ring 22.9x -> 22.3x)
 * (bench/RESULTS.md, "mirror balls get the query from the camera by roulette"). */
#define SPC_SNEE_PLAN_SETTING_MIRRORS "first=0.1,later=0.1"

/* The setting where every caster is a mirror and some mirror's chains go to the randomized solver (a
 * mirror mesh with vertex normals, a smooth mirror SDF): the same with the query at every path's
 * first receiver (no first=P roulette). A BSDF-sampled path that reaches the light by a chain the
 * query covers is weighed by the power heuristic against the query's density times P; with P = 0.1
 * its weight there stays near 1, and such a hit of a small bright light is one sample hundreds of
 * times its pixel's mean. On bench/check/mirror_bowl.xml (a mirror bowl focusing a small light onto
 * the floor) at equal CPU time over 24 seeds, mean relMSE 0.0074 (worst seed 0.135, one pixel 99% of
 * it; median 0.0015) with first=0.1 against 0.0009 (worst 0.0021; median 0.0008) without, none
 * 0.032: the query costs 2.5-2.7x per sample there and still pays (bench/RESULTS.md, "The default
 * against none on every caster scene at 8 seeds", and part mirror10). Where the mirrors' chains are
 * enumerated exactly (a sphere, a cylinder) the roulette stays: on scenes/caustic_mirror_ring.xml the
 * query at every first receiver cost 1.1x on the median over 24 seeds and left the same one-pixel
 * seeds, which are not the roulette's. */
#define SPC_SNEE_PLAN_SETTING_SOLVED_MIRRORS "angular:later=0.1"

/* path's setting where every caster is a glass normal-mapped plane (a water surface), or a glass
 * triangle mesh the randomized solver serves, and the camera and every light are on one side of each
 * plane (of each triangle's plane): the same without the query from the camera. From
 * the camera such a plane's chains are reflections only (the light's glints on the water), which
 * the path tracer's emission splitting (integrator/path.c) traces at every camera sample, and the
 * query from the camera would find them by the randomized attempts (the plane's enumeration runs at
 * receivers only: from the camera the glints are dozens), whose trial counts put fireflies on the
 * image: on scenes/caustic_pool.xml at equal CPU time over 16 seeds, mean relMSE 0.0181 (worst seed
 * 0.034) without the query against 0.0414 (worst 0.208, one pixel 86% of it) with it on 0.089 of
 * the samples; none 0.209 (bench/RESULTS.md, "The pool without the query from the camera"). On a
 * water surface made of triangles (scenes/newton_pool.xml) the query's chains go to the randomized
 * solver too, and its trial counts put one-pixel seeds on the image: at equal CPU over 24 seeds
 * mean relMSE 0.00097 (worst seed 0.00115) without it against 0.00179 (0.00223) with it on every
 * sample (bench/RESULTS.md, "The mirror ring's whispering gallery"). */
#define SPC_SNEE_PLAN_SETTING_WATER "angular:first=0.1,later=0.1"
/* Appended for path where every caster is a mirror cylinder (cylinder_chains.h) under small area
 * lights: the area light's subpaths reflected by the wall onto the floor, joined to the pinhole
 * (integrator/path_lt.h), weighed against specular NEE and BSDF sampling at the floor, where the
 * wall's caustic folds. scenes/caustic_mirror_ring.xml at equal CPU over 24 seeds: mean relMSE
 * 0.00464 -> 0.00335 (median 0.00303 -> 0.00176; none 0.147), bench/check/rings_square_light.xml
 * over 16 seeds 0.000146 -> 0.000121 (bench/RESULTS.md, "Light tracing through the pool's water"). */
#define SPC_SNEE_PLAN_CYLINDER_LT ",ltcaus,ltshare=0.5"
/* path where every caster is a glass normal-mapped plane (plane_chains.h), every light a small area
 * light (a sky besides; SPC_SNEE_PLAN_LT_AREA_SR) and the pinhole under the water (on the far side
 * of each plane from the lights): the water's setting and the area light's subpaths refracted by
 * the water onto the floor and walls, joined to the pinhole directly, in the underside's reflection
 * and through a second receiver (integrator/path_lt.h); no query from the camera (the plan's
 * setting there before, angular:camera=Q,first=0.1,later=0.1). At equal CPU, three views from under
 * scenes/caustic_pool.xml's water: mean relMSE 0.0651 -> 0.0539 and 0.0914 -> 0.0711 over 48 seeds,
 * 0.1136 -> 0.1008 over 40 (one seed's pixel, the worst of both, 0.65 -> 0.95 in the first 16);
 * medians 1.12-1.47x lower (bench/RESULTS.md, "A camera under the water"). */
#define SPC_SNEE_PLAN_SETTING_UNDER_WATER "angular:first=0.1,later=0.1,ltcaus,ltshare=0.5"
/* Appended to SPC_SNEE_PLAN_SETTING_WATER for path where every caster is a normal-mapped plane
 * (plane_chains.h) and every light a small area light (a sky besides; SPC_SNEE_PLAN_LT_AREA_SR):
 * the area light's subpaths refracted by the water onto the floor, joined to the pinhole through
 * the plane's one-vertex chains, on every camera sample (integrator/path_lt.h). Where the light's
 * image through the ripples is stretched (a fold of the caustic network) specular NEE's density
 * falls and BSDF sampling's value is the light's full radiance; light tracing's density is largest
 * there. The joins carry the normal map's shading factor at both water vertices (path_lt.c,
 * plane_shading_fix), without which the image was 1-2% dark in the far water. scenes/caustic_pool.xml
 * at equal CPU: mean relMSE 0.147 -> 0.118 over 9851-9874 (median 0.057 -> 0.033), 0.0613 -> 0.0379
 * over 24 fresh seeds (bench/RESULTS.md, "The pool's light tracing through the water, unbiased").
 * Past the first two receivers (light tracing's), 8 more BSDF directions a receiver toward the
 * light through the water, weighed as 9 BSDF samples against specular NEE's (deepsplit=8,
 * integrator/path_deep.h): the paths that reach the light through the water from the third receiver
 * on, BSDF sampling's near a fold and specular NEE's at its power-heuristic bound beside one, held
 * the pool's one-pixel seeds (9860 (6,5), 9852 (20,1)). At equal CPU mean relMSE 0.0522 -> 0.0430
 * over 9851-9874 and 0.0589 -> 0.0426 over 11751-11774, the worst seed 0.29 -> 0.058 and 0.35 ->
 * 0.063 (deepsplit=24: 0.0542 and 0.0529, its 1.7x cost per sample too high; bench/RESULTS.md,
 * part pool36). */
#define SPC_SNEE_PLAN_WATER_LT ",ltcaus,ltshare=0.5,deepsplit=8"

/* Appended for path where every caster is flat glass under lights over SPC_SNEE_PLAN_FLAT_MAX_SR and
 * specular NEE draws on some sphere light: 0.9 of the light's points drawn in the cone of directions
 * toward the light from the receiver (params.light_x), the rest as before, on the cap facing the
 * casters' sphere. Flat glass bends a chain little, so a chain from the receiver ends on the side of
 * the light the receiver sees: on scenes/caustic_slabs.xml one query's second moment over its
 * squared mean at floor points 17.3 -> 7.2 at the same cost (bench/RESULTS.md, "Flat glass under
 * sphere lights"). The rest keeps every point a chain can reach drawn, at (1 - share) of the old
 * density where the receiver's cone misses it; the long pass's chains (params.long_p) draw their own
 * point from the cap alone (spc_snee_sample_long_light). Where a light lies inside the casters'
 * sphere (slabs wider than the light's height: scenes/newton_slabs.xml) chains off a slab's side
 * face reach it from outside the cone, and the long pass's 7-vertex chains, counted with 1 / psi,
 * at 1 - share of the density made one-pixel seeds (share 0.5: seed 9863, pixel (25, 20) 4.2
 * against 0.33; 0.9: one pixel 82% of the variance at 16 x 16, 4096 spp); with their own point
 * neither shows. At equal CPU time over 2 x 24 seeds (with long=0.4, SPC_SNEE_PLAN_FLAT_LARGE)
 * scenes/caustic_slabs.xml 21.8x -> 28.5x and 21.2x -> 27.3x none by mean relMSE; newton_slabs
 * 1.1-1.2x lower relMSE per sample by medians, by means over 5 x 24 seeds as before (the long pass's
 * own one-pixel seeds; bench/RESULTS.md, "The long pass's own light point under lightx").
 * Not under lights of at most SPC_SNEE_PLAN_FLAT_MAX_SR (the small-light setting): on
 * scenes/caustic_slabs_small_light.xml (0.00066 sr) one of five renders at 16 x 16, 4096 spp had a
 * pixel holding all of its variance with the share 0.5 (none of five without it; not traced). */
#define SPC_SNEE_PLAN_FLAT_LIGHT_X ",lightx=0.9"

/* bdpt's setting where some caster is glass: specular NEE at the camera vertices whose paths have
 * no BDPT strategy but s = 0 (and at corners), and the query from the camera on one sample in ten;
 * where every glass caster is enumerated exactly, the query on 0.17 sqrt(s) of the samples instead
 * (at least 0.02; snee_plan.c's camera_prob_bdpt), "angular:camera=Q".
 * The paths it covers (a caustic seen through glass, the light seen in or through glass) are
 * single samples hundreds of times their pixel's mean for s = 0 alone: on the glass-ball caustic at
 * equal CPU time bdpt's mean relMSE over 8 seeds was 2.1x lower with this setting than without
 * specular NEE (the worst pixel's share 60% -> 20%) and 1.1x lower than with `angular` (no query
 * from the camera; the query on every sample cost 2.2x per sample and lost); on the lamp with a
 * glass egg, whose caustic paths are a small part of the image, it cost 1.08x (8% more time per
 * sample for nothing); bench/RESULTS.md, "Issue 21, continued" and "Issue 21, part 4". */
#define SPC_SNEE_PLAN_SETTING_BDPT "angular:camera=0.1"

/* bdpt's setting where every caster is a mirror: without the query from the camera (path's mirror
 * setting takes it by roulette, SPC_SNEE_PLAN_SETTING_MIRRORS; not measured for bdpt). */
#define SPC_SNEE_PLAN_SETTING_BDPT_MIRRORS "angular"

/* How the chains of one caster are found under a plan. */
typedef enum spc_snee_method {
    SPC_SNEE_METHOD_SPHERE,   /* every chain on the sphere enumerated (sphere_chains.h) */
    SPC_SNEE_METHOD_CYLINDER, /* every reflection chain on the mirror cylinder (cylinder_chains.h) */
    SPC_SNEE_METHOD_PLANE,    /* every one-vertex chain through the normal-mapped plane (plane_chains.h) */
    SPC_SNEE_METHOD_FLAT,     /* every chain through the flat faces of such casters (flat_chains.h) */
    SPC_SNEE_METHOD_SOLVER    /* the plan's solver (randomized attempts, or conic's enumeration) */
} spc_snee_method;

typedef struct spc_snee_plan {
    bool automatic;   /* chosen from the scene, not given */
    bool on;          /* specular NEE runs */
    char setting[SPC_SPECULAR_NEE_MAX]; /* what runs, as spc_snee_parse reads it: "none", "angular", "newton:biased=8", ... */
    char reason[96];  /* why it is off, or "" */
    int casters;      /* caster shapes (spc_chain_casters_of) */
    int receivers;    /* shapes specular NEE may start at */
    double light_sr;  /* the smallest solid angle (sr) a light subtends at the casters (0: a point) */
    double caster_share; /* the largest share of a light's directions that meet the casters (snee_plan.c) */
    double glass_share;  /* the share of the image whose camera ray meets a glass caster first (snee_plan.c) */
    double open_share;   /* the share of directions from the casters that leave the scene (snee_plan.c) */
    double flat_sequences; /* face sequences the flat enumeration solves per query (the pilot, snee_plan.c;
                              0 where it did not run, -1 where it found no receiver) */
    double caustic_gain; /* none's relative variance per sample from the area lights' caustics on the image,
                            as the caustic pilot predicts it (snee_plan.c, caustic_gain; -1 where it did
                            not run) */
    int camera_pilot;    /* the query from the camera's contributions in view that its pilot found where every
                            caster is flat glass (snee_plan.c, camera_finds_light; 0: the query left out;
                            -1 where it did not run) */
    bool pilot;          /* automatic and on, and the pilot render (render/snee_pilot.h) may check it */
    char pilot_note[SPC_SPECULAR_NEE_NOTE_MAX]; /* what the pilot measured and chose, or "" */
} spc_snee_plan;

/* The plan for rendering sc with integrator `integrator` ("path", "volpath", "bdpt", "ipt") and the
 * given setting (NULL, "" or "auto": choose; "none" or "off": off; anything else: as given). Never
 * fails: a bad explicit setting is copied as given and refused by spc_snee_parse later. */
void spc_snee_plan_make(const spc_scene *sc, const char *integrator, const char *setting, spc_snee_plan *out);

/* The method a plan's params p use for the caster shape s. */
spc_snee_method spc_snee_plan_method(const spc_snee_params *p, const spc_shape *s);

/* Writes a description of the plan (one line, a line on later_p if it is below 1, then one line per
 * caster: shape index, its BSDF, the method and the chain lengths it covers) to buf (always terminated); max_chain the scene's. Returns
 * the length it needed (as snprintf). */
int spc_snee_plan_describe(const spc_scene *sc, const spc_snee_plan *plan, int max_chain, char *buf, size_t len);

#endif
