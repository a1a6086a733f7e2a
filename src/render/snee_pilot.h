/*
 * render/snee_pilot.h: a short pilot render that measures, before a render starts, whether the
 * automatic specular NEE plan (manifold/snee_plan.h) pays on this scene, and keeps it or turns it
 * off. It runs where the setting is `auto:pilot` (not by default: bench/RESULTS.md, "The pilot
 * render", has why).
 *
 * The plan's rules read the scene (light solid angles, caster kinds, the image's share of glass);
 * they cannot see the estimator's variance or cost. The pilot renders the whole image at a low
 * resolution (SPC_SNEE_PILOT_EDGE pixels on its longer side), one thread, fixed seeds, with each
 * candidate setting (`none`, the plan's) in SPC_SNEE_PILOT_GROUPS groups (each group its own seed,
 * the candidates interleaved group by group, so that a change of the machine's load falls on both).
 * A first group of two samples per pixel measures each candidate's CPU seconds per sample (the
 * thread's CPU clock); the later groups give each candidate an equal share of the pilot's CPU time.
 * Per pixel and channel it then has, for each candidate c, its mean m_c over n_c samples and its
 * per-sample variance v_c, and it predicts the relMSE of the render at equal CPU time (N_c samples
 * per pixel: the render's own count for the plan, as many more for none as its lower cost allows):
 *     sum over pixels of [ v_c / N_c + D_c sqrt(n_c / N_c) ] / (m^2 + 0.01),
 * m the mean over both candidates (both estimate the same image; the guard 0.01 as
 * bench/bench_default.py scores relMSE) and D_c the square of c's deficit below the other's mean
 * beyond both means' noise. The deficit is the tail-aware part: a candidate whose mean lies below
 * the other's has mass its tail has not yet shown (path tracing's rare paths to a small light through
 * glass, or a firefly specular NEE has not yet thrown), found with a probability p under about
 * 1/n_c; a render of N_c samples keeps between n_c / N_c (p ~ 1 / n_c) and all (p << 1 / N_c) of
 * its square, sqrt(n_c / N_c) of it is the geometric middle. The plan is kept only where its
 * prediction is below none's by the margin SPC_SNEE_PILOT_MARGIN; otherwise specular NEE is off.
 *
 * Cost: SPC_SNEE_PILOT_SHARE of the render's CPU time as estimated from the first group (its
 * samples x the cheaper candidate's seconds per sample; for a time limit, the limit x threads),
 * at least SPC_SNEE_PILOT_MIN_SECONDS and at most SPC_SNEE_PILOT_MAX_SECONDS, and at least two
 * samples per pixel per group. The seeds are fixed, but the groups' sizes follow from measured
 * times, so the choice can differ between runs where the two predictions lie near the margin. The
 * render itself then runs the chosen setting (the same image for any thread count: the pilot runs
 * on one thread whatever the render's). The setting that ran and what the pilot measured go to
 * --stats and `specula info`.
 */
#ifndef SPC_RENDER_SNEE_PILOT_H
#define SPC_RENDER_SNEE_PILOT_H

#include <stdbool.h>

#include "manifold/snee_plan.h"
#include "specula/specula.h"

/* The pilot image's longer side, in pixels: enough to resolve a caustic's region (a 32x32 image's
 * caustic under a glass ball covers tens of pixels), few enough that each pixel gets several
 * samples from a budget of a few percent of the render. */
#define SPC_SNEE_PILOT_EDGE 16
/* Groups (seeds) per candidate: the first measures the costs, the others share the budget. */
#define SPC_SNEE_PILOT_GROUPS 4
/* The pilot's share of the render's estimated CPU time. */
#define SPC_SNEE_PILOT_SHARE 0.03
/* The pilot's CPU time at least, seconds: enough for a few samples per pixel with specular NEE and
 * tens without (2% of the 1.5 CPU-s renders of bench/bench_default.py). */
#define SPC_SNEE_PILOT_MIN_SECONDS 0.05
/* The pilot's CPU time at most, seconds, whatever the render's size. */
#define SPC_SNEE_PILOT_MAX_SECONDS 2.0
/* Specular NEE is kept only where its score (variance x time per sample) is below none's divided by
 * this: with four groups a score is uncertain by tens of percent, and a wrong `on` costs more than
 * a wrong `off` (heavy tails are underestimated by a short pilot, never overestimated). */
#define SPC_SNEE_PILOT_MARGIN 1.25

#define SPC_SNEE_PILOT_CANDIDATES 2

typedef struct spc_snee_pilot_candidate {
    char setting[SPC_SPECULAR_NEE_MAX];
    double sec_per_sample; /* CPU seconds per camera sample */
    int spp;               /* samples per pixel, all groups */
    double rel_var_plain;  /* relative variance per sample, from the sample variance */
    double tail;           /* its largest group's variance over the groups' mean (snee_pilot.c) */
    double deficit;        /* relative squared deficit of its mean below the other's (snee_pilot.c) */
    double score;          /* the render's relMSE predicted at equal CPU time (snee_pilot.c) */
} spc_snee_pilot_candidate;

typedef struct spc_snee_pilot {
    bool ran;
    int width, height;   /* the pilot image */
    int groups;
    int ncand;           /* candidate 0 is none, 1 the plan's setting */
    spc_snee_pilot_candidate cand[SPC_SNEE_PILOT_CANDIDATES];
    int chosen;          /* index into cand */
    double seconds;      /* the pilot's CPU time */
} spc_snee_pilot;

/* Runs the pilot for the render of sc with options o (its integrator, size, spp, time limit and
 * threads are read; its specular_nee is not) where the plan is automatic, on and allows it
 * (plan->pilot); otherwise leaves the plan alone and out->ran false. When it ran, plan->setting,
 * plan->on and plan->reason follow its choice and plan->pilot_note describes what it measured.
 * Never fails: a pilot render that fails keeps the plan as it was. */
void spc_snee_pilot_run(const spc_scene *sc, const spc_render_options *o, spc_snee_plan *plan, spc_snee_pilot *out);

#endif
