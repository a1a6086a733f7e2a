/*
 * manifold/solver_table.c: the specular solvers by id and name, and the parameters' defaults per
 * solver (solver.h). The table is the one list of solvers: the option parser (snee_options.c)
 * and the estimator (specular_nee.c) read it.
 */
#include "manifold/solver.h"

#include <string.h>

#include "manifold/conic.h"

/* Attempts per light sample of the biased estimator: enough to find both solutions of a glass
 * sphere's caustic from shape seeds most of the time (bench/RESULTS.md, Newton solver). */
#define SPC_SNEE_BIASED_SEEDS 8
/* The angular solver's progress window in specular NEE (angular.h): an attempt ends when 4 chain
 * traces have not halved the loss. Most attempts have no solution to find (a receiver outside
 * every caustic), and the solver's own stagnation rule spent 16 traces on them; with the window
 * they end after 5-6. Solutions are found 20-40% less often, so the trial count grows, but
 * specular NEE's variance x time fell 1.9-2.7x on the caustic scenes (bench_snee, bench/RESULTS.md). */
#define SPC_SNEE_ANGULAR_WINDOW 4
#define SPC_SNEE_ANGULAR_WINDOW_KEEP 0.5
/* The angular solver's cap of the trial count: its attempts end within ~6 traces, so a longer
 * count is affordable, and the window lowers the probability of hard solutions (a glass ball's
 * rim, near a fold): at 64, 0.4-0.7% of the counts were cut (bias, tests/test_manifold.c's glass
 * ball), at 256 none in that test while the mean trial count stays 2.2. Bias only below p ~ 1%. */
#define SPC_SNEE_ANGULAR_MAX_TRIALS 256
/* reflect's default probability of a reflection at a dielectric vertex of a seed chain. Measured in
 * bench/RESULTS.md ("reflections off glass, MIS with a solve-probability stand-in"). */
#define SPC_SNEE_REFLECT_P 0.2
/* The MIS weight's stand-in for the probability that a randomized attempt finds a chain (params.
 * mis_solve; measured in bench/RESULTS.md, "reflections off glass, MIS with a solve-probability
 * stand-in"). */
#define SPC_SNEE_MIS_SOLVE 0.1
/* params.long_p's default: the probability per call of the longer chains on one sphere (measured in
 * bench/RESULTS.md, "how far specular NEE can go": 0.1 against 0.25 on the glass ball). */
#define SPC_SNEE_LONG_P 0.1
/* ltguide without a value: the share of camera samples that trace a light-guide subpath
 * (integrator/path_lt.h); 0.5 and 1 gave the same error at equal CPU on the SDF torus over 8 seeds
 * (bench/RESULTS.md, "Light guides by light tracing"). */
#define SPC_SNEE_LT_GUIDE_SHARE 0.5
/* ltview without a value: the share of camera samples that draw a light point to join to the
 * pinhole through flat glass (integrator/path_lt_view.h, SPC_PATH_LT_VIEW_SHARE: the same value). */
#define SPC_SNEE_LT_VIEW_SHARE 0.25
/* ltslab without a value: the longest chain through flat faces from a receiver to the pinhole that
 * a point light's subpath joins through: 2 is the camera's view through a slab (in and out); 3
 * adds a reflection inside it, at a cube's ~6x the face sequences. */
#define SPC_SNEE_LT_SLAB_MAX 2
/* camsplit without a value: the extra camera rays per camera sample that meets delta-only glass
 * first (integrator/path_camsplit.h); K 4 beat K 16 on the SDF torus at equal CPU (snee_plan.h,
 * SPC_SNEE_PLAN_CAMERA_SPLIT). */
#define SPC_SNEE_CAM_SPLIT_RAYS 4
/* camrecv without a value: class D's paths (integrator/path_camsplit.h) have at least this many delta
 * vertices on both sides of the receiver together. The common camera - T T - floor - T T - light (4)
 * is smooth over a pixel, and the camera ray's stratified samples estimate it better than the
 * extra rays' independent ones; the rare paths are longer (light guides on either side). */
#define SPC_SNEE_CAM_SPLIT_RECV_MIN 5
/* camlong without a value: the share of the queries from the pinhole that look for a glass SDF's
 * longer chains (spc_snee_params.cam_long). */
#define SPC_SNEE_CAM_LONG_P 1.0
/* params.flat5_p and flat6_p's defaults: the shares of the calls that enumerate the 5- and 6-vertex
 * chains through flat faces. 0: those paths are left to BSDF sampling (MIS weight 1). At equal CPU
 * (16 seeds, 32x32, 1.5 s) the small-light slabs' mean relMSE fell 2.9x and two slabs under a sphere
 * light 2.9x against the shares 0.25 and 0.025 (there 60% of a sample's cost for 0.01% and 0.8% of
 * the light); the shares 0.02 down to 0.004 gave one-pixel seeds through their 1 / share
 * (bench/RESULTS.md, "The 5- and 6-vertex flat chains left to BSDF sampling"). */
#define SPC_SNEE_FLAT5_P 0.0
#define SPC_SNEE_FLAT6_P 0.0
/* params.reflected_samples's default: bdpt's light points per query at a receiver the camera sees by
 * a reflection off a glass ball. A glass ball's rim shows, by its Fresnel reflection, the floor around the
 * ball where the ball's own caustic lies, minified: a query there draws its light point where the
 * chain's geometry term varies steeply, and on the glass-ball caustic (32x32) three such rim pixels
 * held 28% of bdpt's variance, nearly all of it from the light point (two light points on the same
 * receiver differ far more than receivers do). Such receivers are few (the reflection's Fresnel
 * share: 0.7% of the camera samples there). Measured at fixed samples (256 spp, one thread, the
 * seeds' scatter times CPU s; bench/RESULTS.md, "bdpt's receivers seen in a glass ball's rim"): over
 * 16 seeds 4 is 1.18x better than 1 (1.5% more CPU), and 2, 3 and 6 are 0.94x, 0.98x and 0.98x of
 * 4; over 8 seeds 8 and 16 were 0.96x and 0.92x of 4, and 4 light points at every receiver seen
 * through glass (refraction too) 0.94x of 1. */
#define SPC_SNEE_REFLECTED_SAMPLES 4

/* ---- solver table ---- */

static const spc_specular_solver solvers[] = {
    {"none", NULL, NULL, NULL, NULL, false},
    {"angular", spc_angular_solve_one, NULL, NULL, NULL, true},
    {"newton", spc_newton_solve_one, NULL, NULL, NULL, false},
    /* conic: every one-vertex chain on meshes exactly, the angular estimate for the rest */
    {"conic", spc_angular_solve_one, spc_conic_solve_all, spc_conic_covers, spc_conic_covers_all, true},
};
#define NSOLVERS ((int)(sizeof solvers / sizeof solvers[0]))

const spc_specular_solver *spc_specular_solver_get(int id)
{
    if (id <= SPC_SNEE_NONE || id >= NSOLVERS || (!solvers[id].solve_one && !solvers[id].solve_all))
        return NULL;
    return &solvers[id];
}

bool spc_specular_solver_parse(const char *name, int *id)
{
    if (!name || !name[0] || !strcmp(name, "none")) {
        *id = SPC_SNEE_NONE;
        return true;
    }
    for (int i = 1; i < NSOLVERS; ++i)
        if (!strcmp(name, solvers[i].name) && (solvers[i].solve_one || solvers[i].solve_all)) {
            *id = i;
            return true;
        }
    return false;
}

const char *spc_specular_solver_names(void) { return "none, angular, newton, conic"; }

void spc_snee_params_default(spc_snee_params *p, int solver, int max_chain)
{
    memset(p, 0, sizeof *p);
    p->solver = solver;
    p->max_chain = max_chain < SPC_CHAIN_MAX_VERTICES ? max_chain : SPC_CHAIN_MAX_VERTICES;
    p->seed = SPC_SNEE_SEED_CONE;
    p->max_trials = SPC_SNEE_MAX_TRIALS;
    p->any_surface = false;
    spc_angular_options_default(&p->angular);
    spc_newton_options_default(&p->newton);
    p->biased = false;
    p->biased_seeds = SPC_SNEE_BIASED_SEEDS;
    /* reflections off glass: on for angular (and conic's angular part), off for newton, whose
     * attempts cost more and which they made worse on multi-interface chains (bench/RESULTS.md,
     * "reflections off glass, MIS with a solve-probability stand-in") */
    p->reflect = solver == SPC_SNEE_ANGULAR || solver == SPC_SNEE_CONIC;
    p->reflect_p = SPC_SNEE_REFLECT_P;
    p->mis_solve = SPC_SNEE_MIS_SOLVE;
    p->solve_mis = true;
    p->fit_seeds = true;
    if (solver != SPC_SNEE_NEWTON) {
        p->angular.window = SPC_SNEE_ANGULAR_WINDOW;
        p->angular.window_keep = SPC_SNEE_ANGULAR_WINDOW_KEEP;
    }
    p->straight_first = solver == SPC_SNEE_ANGULAR;
    p->exact = true;
    p->unfold = true;
    p->mis_events = false;
    p->long_p = SPC_SNEE_LONG_P;
    p->lt_guide_share = SPC_SNEE_LT_GUIDE_SHARE;
    p->lt_view_share = SPC_SNEE_LT_VIEW_SHARE;
    p->lt_slab_max = SPC_SNEE_LT_SLAB_MAX;
    p->cam_split_rays = SPC_SNEE_CAM_SPLIT_RAYS;
    p->cam_split_recv_min = SPC_SNEE_CAM_SPLIT_RECV_MIN;
    p->cam_long_p = SPC_SNEE_CAM_LONG_P;
    p->long_max = 0;
    p->long_events_p = 0.0;
    p->flat5_p = SPC_SNEE_FLAT5_P;
    p->flat6_p = SPC_SNEE_FLAT6_P;
    p->flat34_p = 1.0;
    p->guide = 0.0;
    p->snee_p = 1.0;
    p->later_p = 1.0;
    p->first_p = 1.0;
    p->near_p = 1.0;
    p->recv_guide = 0.0;
    p->seed_guide = 0.0;
    p->sguide = NULL;
    p->camera_p = 1.0;
    p->direct_p = 1.0;
    p->light_samples = 1;
    p->reflected_samples = SPC_SNEE_REFLECTED_SAMPLES;
    if (solver == SPC_SNEE_ANGULAR)
        p->max_trials = SPC_SNEE_ANGULAR_MAX_TRIALS;
}
