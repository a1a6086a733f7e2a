/*
 * manifold/snee_options.c: the table of specular NEE's options and everything read from it: the
 * parser, the canonical text, the help and the error messages (snee_options.h). What each option
 * means for the estimator is documented with its field in solver.h (spc_snee_params).
 */
#include "manifold/snee_options.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "manifold/flat_chains.h"
#include "manifold/solver.h"

/* guide without a value: a cone as wide as the light's image through the chain to its point facing
 * x (measured in bench/RESULTS.md, "Guided directions": 1 against 1.5 and 2 on the pools). */
#define SPC_SNEE_GUIDE 1.0
/* recguide without a value: the guided share of a vertex's directions (caustic_guide.h) */
#define SPC_SNEE_RECV_GUIDE 0.25
/* seedguide without a value: the guided share of a randomized attempt's seeds (seed_guide.h) */
#define SPC_SNEE_SEED_GUIDE 0.5
/* phaseseeds without a value: the share of a randomized attempt's seeds drawn from a medium point's
 * phase function, volpath's plan's (snee_plan.h, SPC_SNEE_PLAN_VOLPATH_PHASE_SEEDS) */
#define SPC_SNEE_PHASE_SEEDS 0.8
/* The largest integer an option takes (six digits: far beyond any sensible count). */
#define SPC_SNEE_COUNT_MAX 999999

_Static_assert(sizeof(spc_snee_seed) == sizeof(int), "CHOICE options store an int");
_Static_assert(sizeof(spc_newton_constraint) == sizeof(int), "CHOICE options store an int");

static const char *const seed_choices[] = {"shape", "light", "bsdf", "cone", NULL}; /* spc_snee_seed */
static const char *const constraint_choices[] = {"half", "angle", NULL};            /* spc_newton_constraint */

#define NO SPC_SNEE_NO_FIELD
#define AT(member) offsetof(spc_snee_params, member)

/* name, negation, kind, value_optional, metavar, lo, hi, lo_open, hi_open, choices, solver, flag,
 * field, implied, default_note, help */
static const spc_snee_option options[] = {
    {"biased", "unbiased", SPC_SNEE_OPT_COUNT, true, "M", 1, SPC_SNEE_COUNT_MAX, false, false, NULL, 0, AT(biased),
     AT(biased_seeds), 0, NULL,
     "unbiased: one solution per light sample, times its Bernoulli-trial count (1/p); biased: M attempts, "
     "the distinct solutions found summed (no trials: energy lost where solutions are hard to find)"},
    {"trials", NULL, SPC_SNEE_OPT_COUNT, false, "N", 1, SPC_SNEE_COUNT_MAX, false, false, NULL, 0, NO, AT(max_trials),
     0, NULL,
     "the count's attempts; past them, with MIS at a medium point, the chain is left to phase sampling, "
     "else roulette in doubling blocks (unbiased)"},
    {"seed", NULL, SPC_SNEE_OPT_CHOICE, false, "S", 0, 0, false, false, seed_choices, 0, NO, AT(seed), 0, NULL,
     "the randomized attempts' seeds: a uniform point of a caster (shape), the straight line to the light "
     "(light: Hanika et al.'s MNEE), a direction sampled from the receiver's BSDF (bsdf; at a medium point its "
     "phase function, from the camera cone), or uniform in the cone toward a caster's bounding sphere (cone)"},
    {"constraint", NULL, SPC_SNEE_OPT_CHOICE, false, "C", 0, 0, false, false, constraint_choices, SPC_SNEE_NEWTON, NO,
     AT(newton.constraint), 0, NULL, "newton: the constraints as half vectors (half) or as angle differences (angle)"},
    {"rough", NULL, SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, SPC_SNEE_NEWTON, AT(newton.rough), NO,
     0, NULL,
     "newton: rough dielectrics and conductors are chain vertices too (refraction only, its own estimator: "
     "not with reflect or exact)"},
    {"nomis", NULL, SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(no_mis), NO, 0, NULL,
     "no MIS with BSDF sampling: the BSDF-sampled paths specular NEE covers are dropped"},
    {"nosplit", NULL, SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(no_split), NO, 0, NULL,
     "path: no specular NEE by splitting at a reflection off a smooth glass mesh seen from the camera (the "
     "receiver that the sampled reflection reaches queries instead)"},
    {"splitf", NULL, SPC_SNEE_OPT_REAL, false, "S", 0, 1, true, false, NULL, 0, NO, AT(split_f), 0, NULL,
     "path: on flat-faced glass (a cube, a slab, a pane) that split runs on every sample where the "
     "reflection's probability F (Fresnel) is at least S, else with probability F / S, counted S / F "
     "times (default 0.25; a small S splits everywhere)"},
    {"ltcaus", "noltcaus", SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(lt_caustic), NO, 0, NULL,
     "path: the caustics of point lights and (with MIS) area lights through a glass sphere "
     "also by light tracing (light subpaths joined to the camera directly, through the sphere and through a "
     "diffuse bounce), weighed against specular NEE (and BSDF sampling) at the caustic's receiver"},
    {"longflatlt", "nolongflatlt", SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(long_flat_lt), NO, 0,
     NULL,
     "with ltcaus under area lights: the longer chains' pass leaves chains through flat faces alone, past their "
     "enumeration, to light tracing and BSDF sampling"},
    {"ltshare", NULL, SPC_SNEE_OPT_REAL, false, "S", 0, 1, true, false, NULL, 0, NO, AT(lt_share), 0, NULL,
     "with ltcaus: area lights' light subpaths on a share S of the camera samples, counted 1/S times (default "
     "0.25)"},
    {"ltlong", NULL, SPC_SNEE_OPT_REAL, false, "S", 0, 1, true, false, NULL, 0, NO, AT(lt_long), 0, NULL,
     "with ltcaus: light subpaths also joined to the camera through the glass sphere by its chains longer than "
     "the budget (in, reflections inside, out) on a share S of them, counted 1/S times (default 0.05)"},
    {"ltguide", "noltguide", SPC_SNEE_OPT_REAL, true, "S", 0, 1, true, false, NULL, 0, AT(lt_guide), AT(lt_guide_share),
     0, NULL,
     "path: area lights' light through chains longer than any specular NEE covers (light guides: a glass "
     "ring's total internal reflections) also by light tracing, on a share S of the camera samples (default "
     "0.5), joined to the camera at the first diffuse surface, weighed against BSDF sampling there"},
    {"ltview", "noltview", SPC_SNEE_OPT_REAL, true, "S", 0, 1, true, false, NULL, 0, AT(lt_view), AT(lt_view_share), 0,
     NULL,
     "path: an area light seen from the camera through flat glass (slabs, cubes: 1-3 faces, partial "
     "reflections off glass too; with camera, only chains with a reflection inside the glass) also by light "
     "tracing, on a share S of the camera samples (default 0.25): a light point joined to the pinhole by "
     "every such chain, weighed against the camera ray"},
    {"camsplit", "nocamsplit", SPC_SNEE_OPT_COUNT, true, "K", 1, 64, false, false, NULL, 0, AT(cam_split),
     AT(cam_split_rays), 0, NULL,
     "path: where the camera ray first meets a surface that only reflects and refracts (smooth glass, a "
     "mirror), up to K more camera rays in the same pixel that meet such a surface first follow its "
     "reflections and refractions and count the light they reach (default K 4); the light seen through "
     "the glass is the mean of their values and the camera ray's"},
    {"camrecv", "nocamrecv", SPC_SNEE_OPT_COUNT, true, "L", 1, 64, false, false, NULL, 0, AT(cam_split_recv),
     AT(cam_split_recv_min), 0, NULL,
     "path, with camsplit (not with ltcaus): those rays also sample the first diffuse surface they meet "
     "behind the glass once and count the light they reach from it through further reflections and "
     "refractions, on paths of at least L reflections and refractions in all (a light guide, or a caustic "
     "seen through a light guide; default L 5); that part is their mean with the camera ray's too"},
    {"camlong", "nocamlong", SPC_SNEE_OPT_REAL, true, "Q", 0, 1, true, false, NULL, 0, AT(cam_long), AT(cam_long_p), 0,
     NULL,
     "with camera: from the pinhole also the chains of 3 and 4 vertices on a glass SDF (the light seen "
     "through a torus after reflections inside its tube), one randomized attempt on a share Q of the "
     "queries (default 1), weighed against the camera ray by their real solve probability"},
    {"ltslab", "noltslab", SPC_SNEE_OPT_COUNT, true, "K", 1, SPC_FLAT_MAX_VERTICES, false, false, NULL, 0, AT(lt_slab),
     AT(lt_slab_max), 0, NULL,
     "path, with ltcaus: a light subpath also joins the pinhole through the chains of 1-K flat faces "
     "(glass slabs) from its receiver (the caustic seen through a slab; default K 2), weighed against specular "
     "NEE there"},
    {"reflect", "noreflect", SPC_SNEE_OPT_REAL, true, "P", 0, 1, true, true, NULL, 0, AT(reflect), AT(reflect_p), 0,
     NULL, "chains also reflect off glass, with probability P at a dielectric vertex of a seed chain"},
    {"mispsi", NULL, SPC_SNEE_OPT_REAL, false, "Q", 0, 1, true, false, NULL, 0, NO, AT(mis_solve), 0, NULL,
     "MIS weighs the chains of randomized attempts as if found with probability Q"},
    {"solvemis", "nosolvemis", SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(solve_mis), NO, 0,
     NULL,
     "MIS weighs the chains of randomized attempts through tessellated balls by their real solve "
     "probability, sampled by Bernoulli trials (on by default; nosolvemis: the stand-in mispsi)"},
    {"misev", "nomisev", SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(mis_events), NO, 0, NULL,
     "with reflect, MIS weighs a randomized attempt's chain as if found with mispsi times its events' "
     "probability (off by default)"},
    {"receivers", NULL, SPC_SNEE_OPT_COUNT, false, "N", 1, SPC_SNEE_COUNT_MAX, false, false, NULL, 0, NO, AT(receivers),
     0, "every receiver", "specular NEE at the first N diffuse or glossy vertices of a path only"},
    {"deepsplit", NULL, SPC_SNEE_OPT_COUNT, false, "M", 1, 64, false, false, NULL, 0, NO, AT(deep_split), 0, "none",
     "path: at each diffuse or glossy vertex past a path's first (where light tracing shares none of its "
     "paths), M more directions from its BSDF, counting the light they reach through glass and mirrors only, "
     "weighed as M+1 BSDF samples against specular NEE (the path's own such light counted 1/(M+1))"},
    {"later", NULL, SPC_SNEE_OPT_REAL, false, "P", 0, 1, true, false, NULL, 0, NO, AT(later_p), 0, NULL,
     "past a path's first diffuse or glossy vertex, the whole query with probability P, counted 1/P times"},
    {"first", NULL, SPC_SNEE_OPT_REAL, false, "P", 0, 1, true, false, NULL, 0, NO, AT(first_p), 0, NULL,
     "at a path's first diffuse or glossy vertex, the query with probability P where the casters look small "
     "(always near them), counted 1/P times"},
    {"nearp", NULL, SPC_SNEE_OPT_REAL, false, "P", 0, 1, true, false, NULL, 0, NO, AT(near_p), 0, NULL,
     "with first or later below 1: near the casters the query with probability at most P (never below first "
     "or later), counted 1/P times (default 1)"},
    {"tightshare", "notightshare", SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(tight_share), NO,
     0, NULL,
     "with first or later below 1: the casters' share of a receiver's directions measured by a tight sphere "
     "per caster (a sphere's own, a mesh's farthest vertex) instead of the sphere around its bounding box, "
     "and certain in each one's shadow from a light (where a glass ball focuses its caustic)"},
    {"camera", NULL, SPC_SNEE_OPT_REAL, true, "Q", 0, 1, true, false, NULL, 0, AT(camera), AT(camera_p), 0, NULL,
     "specular NEE from the camera's pinhole too, in a fraction Q of the camera samples (lights seen through "
     "glass, glints)"},
    {"direct", NULL, SPC_SNEE_OPT_REAL, true, "P", 0, 1, true, false, NULL, 0, AT(direct), AT(direct_p), 0, NULL,
     "bdpt: specular NEE also at the surfaces the camera sees directly, at a fraction P of them, weighed "
     "against light tracing and BSDF sampling (a caustic seen directly)"},
    {"reflected", NULL, SPC_SNEE_OPT_COUNT, false, "N", 1, 64, false, false, NULL, 0, NO, AT(reflected_samples), 0,
     NULL,
     "bdpt: N light points per query at the surfaces the camera sees by a reflection off a glass ball, each "
     "counted 1/N times"},
    {"chain", NULL, SPC_SNEE_OPT_COUNT, false, "N", 1, SPC_CHAIN_MAX_VERTICES, false, false, NULL, 0, NO, AT(max_chain),
     0, "the integrator's specular_max_chain, 2", "the longest chain, in specular vertices"},
    {"exact", "noexact", SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(exact), NO, 0, NULL,
     "chains on one sphere, one mirror cylinder or one normal-mapped plane enumerated exactly, not left to "
     "the randomized attempts"},
    {"unfold", "nounfold", SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(unfold), NO, 0, NULL,
     "with exact: chains through one sphere and one flat mirror (a ball's R or T T and the mirror's R) enumerated "
     "exactly on the sphere's mirror images (on by default)"},
    {"long", "nolong", SPC_SNEE_OPT_REAL, false, "P", 0, 1, true, false, NULL, 0, NO, AT(long_p), 0, NULL,
     "with probability P per light sample, one longer chain length (up to 6 vertices) is looked for too"},
    {"longmax", NULL, SPC_SNEE_OPT_COUNT, false, "K", 3, SPC_CHAIN_MAX_VERTICES, false, false, NULL, 0, NO,
     AT(long_max), 0, "6",
     "the longest chain the longer chains' pass looks for (the ball pass and mirror cylinders keep to 6)"},
    {"sphlong", NULL, SPC_SNEE_OPT_REAL, false, "Q", 0, 1, false, false, NULL, 0, NO, AT(sphere_long_p), 0, NULL,
     "where the longer chains run, the chains on one sphere past longmax (up to 6 vertices) on a share Q of the "
     "calls, all lengths at once, counted 1/Q times (0: left to BSDF sampling)"},
    {"longev", NULL, SPC_SNEE_OPT_REAL, false, "P", 0, 1, false, false, NULL, 0, NO, AT(long_events_p), 0, NULL,
     "a share P of the longer chains' randomized attempts take a light guide's events (in, reflected at every "
     "inner vertex, out)"},
    {"flat5", NULL, SPC_SNEE_OPT_REAL, false, "Q", 0, 1, false, false, NULL, 0, NO, AT(flat5_p), 0, NULL,
     "where the longer chains run, the 5-vertex chains through flat faces on a share Q of the calls, counted "
     "1/Q times (0: left to BSDF sampling)"},
    {"flat6", NULL, SPC_SNEE_OPT_REAL, false, "Q", 0, 1, false, false, NULL, 0, NO, AT(flat6_p), 0, NULL,
     "the same for the 6-vertex chains through flat faces"},
    {"lightx", NULL, SPC_SNEE_OPT_REAL, false, "A", 0, 1, false, false, NULL, 0, NO, AT(light_x), 0, NULL,
     "at a surface receiver, a share A of the points on a sphere light drawn in the cone toward it from the "
     "receiver, the rest facing the casters (default 0: none; flat glass under a sphere light)"},
    {"flat34", NULL, SPC_SNEE_OPT_REAL, false, "Q", 0, 1, true, false, NULL, 0, NO, AT(flat34_p), 0, NULL,
     "where the longer chains run, the 3- and 4-vertex chains through flat faces (past a budget of 2) on a share "
     "Q of the calls, each length counted 1/Q times (default 1: at every call)"},
    {"guide", "noguide", SPC_SNEE_OPT_REAL, true, "M", 0, 100, true, false, NULL, 0, NO, AT(guide), SPC_SNEE_GUIDE,
     NULL, "guided directions in cones M times the light's image through a chain (guide alone: M 1)"},
    {"sneep", NULL, SPC_SNEE_OPT_REAL, false, "Q", 0, 1, true, false, NULL, 0, NO, AT(snee_p), 0, NULL,
     "with guide: the light sample (and its solve) made with probability Q where a guided cone exists"},
    {"recguide", "norecguide", SPC_SNEE_OPT_REAL, true, "A", 0, 0.9, true, false, NULL, 0, NO, AT(recv_guide),
     SPC_SNEE_RECV_GUIDE, NULL,
     "path: at a non-delta vertex, with probability A a direction toward the caustics a photon pre-pass "
     "found (recguide alone: A 0.25)"},
    {"fitseeds", "nofitseeds", SPC_SNEE_OPT_SWITCH, false, NULL, 0, 0, false, false, NULL, 0, AT(fit_seeds), NO, 0,
     NULL,
     "a share of the randomized attempts on a tessellated ball seeded toward the exact solutions of the "
     "sphere fitted to it (on by default)"},
    {"fitshare", NULL, SPC_SNEE_OPT_REAL, false, "A", 0, 1, true, false, NULL, 0, NO, AT(fit_share), 0, NULL,
     "with fitseeds, the share A of the randomized attempts' seeds drawn from the fitted sphere's (or an SDF "
     "torus's tube spheres') solutions (default 0.5; the ball pass's 0.9)"},
    {"seedguide", "noseedguide", SPC_SNEE_OPT_REAL, true, "A", 0, 1, true, true, NULL, 0, NO, AT(seed_guide),
     SPC_SNEE_SEED_GUIDE, NULL,
     "randomized attempts seeded, with probability A, toward the chains of light paths a pre-pass traced "
     "through the casters and that landed near the receiver (seedguide alone: A 0.5)"},
    {"phaseseeds", "nophaseseeds", SPC_SNEE_OPT_REAL, true, "A", 0, 1, true, false, NULL, 0, NO, AT(phase_seeds),
     SPC_SNEE_PHASE_SEEDS, NULL,
     "at a medium point, a share A of the randomized attempts' seeds sampled from its phase function, the "
     "rest by seed (phaseseeds alone: A 0.8)"},
};
#define NOPTIONS ((int)(sizeof options / sizeof options[0]))

#undef NO
#undef AT

const spc_snee_option *spc_snee_options(int *n)
{
    *n = NOPTIONS;
    return options;
}

bool spc_snee_setting_is_auto(const char *s) { return !s || !s[0] || !strcmp(s, "auto") || !strcmp(s, "auto:pilot"); }
bool spc_snee_setting_pilot(const char *s) { return s && !strcmp(s, "auto:pilot"); }
bool spc_snee_setting_is_off(const char *s) { return s && (!strcmp(s, "none") || !strcmp(s, "off")); }

/* ---- field access ---- */

static bool *flag_at(spc_snee_params *p, const spc_snee_option *o) { return (bool *)((char *)p + o->flag); }
static bool flag_of(const spc_snee_params *p, const spc_snee_option *o)
{
    return *(const bool *)((const char *)p + o->flag);
}

/* The option's value field as a double (COUNT and CHOICE fields are ints). */
static double value_of(const spc_snee_params *p, const spc_snee_option *o)
{
    const char *f = (const char *)p + o->field;
    if (o->kind == SPC_SNEE_OPT_REAL)
        return *(const double *)f;
    int v;
    memcpy(&v, f, sizeof v);
    return v;
}

static void set_value(spc_snee_params *p, const spc_snee_option *o, double v)
{
    char *f = (char *)p + o->field;
    if (o->kind == SPC_SNEE_OPT_REAL) {
        *(double *)f = v;
    } else {
        int i = (int)v;
        memcpy(f, &i, sizeof i);
    }
}

static bool in_range(const spc_snee_option *o, double v)
{
    return (o->lo_open ? v > o->lo : v >= o->lo) && (o->hi_open ? v < o->hi : v <= o->hi);
}

/* ---- messages ---- */

/* Appends to a fixed buffer, always terminated; the length it would need is kept in *used. */
static void cat(char *buf, size_t len, size_t *used, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(*used < len ? buf + *used : NULL, *used < len ? len - *used : 0, fmt, ap);
    va_end(ap);
    if (n > 0)
        *used += (size_t)n;
}

/* The value's form: "N", "cone|shape|..." */
static void cat_value(char *buf, size_t len, size_t *used, const spc_snee_option *o)
{
    if (o->kind == SPC_SNEE_OPT_CHOICE) {
        for (int i = 0; o->choices[i]; ++i)
            cat(buf, len, used, "%s%s", i ? "|" : "", o->choices[i]);
    } else {
        cat(buf, len, used, "%s", o->metavar);
    }
}

/* How the option is written: "reflect[=P], noreflect", "seed=shape|light|bsdf|cone". */
static void cat_usage(char *buf, size_t len, size_t *used, const spc_snee_option *o)
{
    cat(buf, len, used, "%s", o->name);
    if (o->kind != SPC_SNEE_OPT_SWITCH) {
        cat(buf, len, used, o->value_optional ? "[=" : "=");
        cat_value(buf, len, used, o);
        if (o->value_optional)
            cat(buf, len, used, "]");
    }
    if (o->negation)
        cat(buf, len, used, ", %s", o->negation);
}

/* The value's range in words: "an integer from 1 to 6", "a number in (0, 1]". */
static void cat_range(char *buf, size_t len, size_t *used, const spc_snee_option *o)
{
    switch (o->kind) {
    case SPC_SNEE_OPT_COUNT:
        cat(buf, len, used, "an integer from %g to %g", o->lo, o->hi);
        break;
    case SPC_SNEE_OPT_REAL:
        cat(buf, len, used, "a number in %c%g, %g%c", o->lo_open ? '(' : '[', o->lo, o->hi, o->hi_open ? ')' : ']');
        break;
    case SPC_SNEE_OPT_CHOICE:
        cat(buf, len, used, "one of ");
        cat_value(buf, len, used, o);
        break;
    case SPC_SNEE_OPT_SWITCH:
        break;
    }
}

static void cat_valid(char *buf, size_t len, size_t *used)
{
    cat(buf, len, used, "; valid options: ");
    for (int i = 0; i < NOPTIONS; ++i) {
        if (i)
            cat(buf, len, used, ", ");
        cat_usage(buf, len, used, &options[i]);
    }
}

static spc_snee_parse_result refuse(char *why, size_t why_len, const char *fmt, ...)
{
    if (why && why_len) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(why, why_len, fmt, ap);
        va_end(ap);
    }
    return SPC_SNEE_PARSE_BAD_OPTION;
}

/* ---- parsing ---- */

static bool word_is(const char *s, size_t n, const char *word)
{
    return word && strlen(word) == n && !strncmp(s, word, n);
}

/* Parses the whole of s[0..n) as the option's value into *v; false if it is not one or out of range. */
static bool parse_value(const spc_snee_option *o, const char *s, size_t n, double *v)
{
    char buf[32];
    if (n == 0 || n >= sizeof buf)
        return false;
    memcpy(buf, s, n);
    buf[n] = '\0';
    switch (o->kind) {
    case SPC_SNEE_OPT_COUNT: {
        long c = 0;
        for (size_t i = 0; i < n; ++i) {
            if (buf[i] < '0' || buf[i] > '9' || i >= 6)
                return false;
            c = 10 * c + (buf[i] - '0');
        }
        *v = (double)c;
        return in_range(o, *v);
    }
    case SPC_SNEE_OPT_REAL: {
        char *end;
        *v = strtod(buf, &end);
        return end == buf + n && in_range(o, *v);
    }
    case SPC_SNEE_OPT_CHOICE:
        for (int i = 0; o->choices[i]; ++i)
            if (!strcmp(buf, o->choices[i])) {
                *v = i;
                return true;
            }
        return false;
    case SPC_SNEE_OPT_SWITCH:
        break;
    }
    return false;
}

spc_snee_parse_result spc_snee_options_parse(const char *spec, int max_chain, spc_snee_params *p, char *why,
                                             size_t why_len)
{
    if (!spec)
        spec = "";
    const char *colon = strchr(spec, ':');
    size_t nlen = colon ? (size_t)(colon - spec) : strlen(spec);
    char name[32];
    int id = SPC_SNEE_NONE;
    if (nlen < sizeof name) {
        memcpy(name, spec, nlen);
        name[nlen] = '\0';
    }
    if (nlen >= sizeof name || !spc_specular_solver_parse(name, &id)) {
        refuse(why, why_len, "unknown specular NEE solver '%.*s'; valid: auto, auto:pilot, off, %s", (int)(nlen < 64 ? nlen : 64),
               spec, spc_specular_solver_names());
        return SPC_SNEE_PARSE_BAD_SOLVER;
    }
    spc_snee_params_default(p, id, max_chain);
    if (!colon)
        return SPC_SNEE_PARSE_OK;
    if (id == SPC_SNEE_NONE)
        return refuse(why, why_len, "specular NEE options need a solver, not none (%s)", spc_specular_solver_names());
    /* options switched on explicitly that the rough mode excludes */
    bool reflect_on = false, exact_on = false;
    for (const char *s = colon + 1;;) {
        const char *end = strchr(s, ',');
        size_t n = end ? (size_t)(end - s) : strlen(s);
        const char *eq = memchr(s, '=', n);
        size_t kn = eq ? (size_t)(eq - s) : n;
        const char *val = eq ? eq + 1 : NULL;
        size_t vn = eq ? n - kn - 1 : 0;
        const spc_snee_option *o = NULL;
        bool negated = false;
        for (int i = 0; i < NOPTIONS && !o; ++i) {
            if (word_is(s, kn, options[i].name)) {
                o = &options[i];
            } else if (word_is(s, kn, options[i].negation)) {
                o = &options[i];
                negated = true;
            }
        }
        char bad[SPC_SNEE_WHY_MAX];
        size_t used = 0;
        if (!o) {
            cat(bad, sizeof bad, &used, "unknown specular NEE option '%.*s'", (int)(n < 64 ? n : 64), s);
            cat_valid(bad, sizeof bad, &used);
            return refuse(why, why_len, "%s", bad);
        }
        if (o->solver && o->solver != id)
            return refuse(why, why_len, "specular NEE option '%s' is the %s solver's, not %s's", o->name,
                          spc_specular_solver_get(o->solver)->name, name);
        if (negated || o->kind == SPC_SNEE_OPT_SWITCH) {
            if (val)
                return refuse(why, why_len, "specular NEE option '%s' takes no value", negated ? o->negation : o->name);
            if (negated && o->flag != SPC_SNEE_NO_FIELD)
                *flag_at(p, o) = false;
            else if (negated)
                set_value(p, o, 0.0);
            else
                *flag_at(p, o) = true;
        } else {
            double v = o->implied;
            if (!val && !o->value_optional) {
                cat(bad, sizeof bad, &used, "specular NEE option '%s' needs a value: %s=", o->name, o->name);
                cat_value(bad, sizeof bad, &used, o);
                return refuse(why, why_len, "%s", bad);
            }
            if (val && !parse_value(o, val, vn, &v)) {
                cat(bad, sizeof bad, &used, "bad value '%.*s' of specular NEE option '%s': ", (int)(vn < 32 ? vn : 32),
                    val, o->name);
                cat_range(bad, sizeof bad, &used, o);
                return refuse(why, why_len, "%s", bad);
            }
            if (o->flag != SPC_SNEE_NO_FIELD)
                *flag_at(p, o) = true;
            if (val || o->flag == SPC_SNEE_NO_FIELD)
                set_value(p, o, v);
        }
        if (!strcmp(o->name, "reflect"))
            reflect_on = !negated;
        if (!strcmp(o->name, "exact"))
            exact_on = !negated;
        if (!end)
            break;
        s = end + 1;
    }
    if (p->newton.rough) {
        /* the rough mode's chains refract through glass, and it has its own estimator (newton.h) */
        if (reflect_on || exact_on)
            return refuse(why, why_len, "specular NEE option 'rough' excludes '%s'", reflect_on ? "reflect" : "exact");
        p->reflect = false;
        p->exact = false;
    }
    return SPC_SNEE_PARSE_OK;
}

spc_snee_parse_result spc_snee_setting_check(const char *setting, char *why, size_t why_len)
{
    if (spc_snee_setting_is_auto(setting) || spc_snee_setting_is_off(setting))
        return SPC_SNEE_PARSE_OK;
    spc_snee_params p;
    return spc_snee_options_parse(setting, 2, &p, why, why_len);
}

/* ---- the canonical text ---- */

/* The option as it reads for p ("reflect=0.2", "noexact", "seed=cone"), or nothing where it is off
 * and has no negation; nothing for another solver's option. */
static void cat_option(char *buf, size_t len, size_t *used, const spc_snee_params *p, const spc_snee_option *o,
                       bool exact)
{
    if (o->solver && o->solver != p->solver)
        return;
    bool on =
        o->flag != SPC_SNEE_NO_FIELD ? flag_of(p, o) : in_range(o, value_of(p, o)) || o->kind == SPC_SNEE_OPT_CHOICE;
    if (!on) {
        if (o->negation)
            cat(buf, len, used, "%s", o->negation);
        return;
    }
    cat(buf, len, used, "%s", o->name);
    switch (o->kind) {
    case SPC_SNEE_OPT_COUNT:
        cat(buf, len, used, "=%d", (int)value_of(p, o));
        break;
    case SPC_SNEE_OPT_REAL:
        cat(buf, len, used, exact ? "=%.17g" : "=%g", value_of(p, o));
        break;
    case SPC_SNEE_OPT_CHOICE:
        cat(buf, len, used, "=%s", o->choices[(int)value_of(p, o)]);
        break;
    case SPC_SNEE_OPT_SWITCH:
        break;
    }
}

int spc_snee_options_format(const spc_snee_params *p, char *buf, size_t len)
{
    size_t used = 0;
    if (len)
        buf[0] = '\0';
    const spc_specular_solver *s = spc_specular_solver_get(p->solver);
    cat(buf, len, &used, "%s", s ? s->name : "none");
    if (!s)
        return (int)used;
    char sep = ':';
    for (int i = 0; i < NOPTIONS; ++i) {
        char tok[64];
        size_t tn = 0;
        cat_option(tok, sizeof tok, &tn, p, &options[i], true);
        if (tn) {
            cat(buf, len, &used, "%c%s", sep, tok);
            sep = ',';
        }
    }
    return (int)used;
}

/* ---- the help ---- */

typedef struct text {
    char *s;
    size_t n, cap;
    bool failed;
} text;

static void text_add(text *t, const char *s, size_t n)
{
    if (t->failed)
        return;
    if (t->n + n + 1 > t->cap) {
        size_t cap = 2 * (t->n + n + 1);
        char *g = realloc(t->s, cap);
        if (!g) {
            t->failed = true;
            return;
        }
        t->s = g;
        t->cap = cap;
    }
    memcpy(t->s + t->n, s, n);
    t->n += n;
    t->s[t->n] = '\0';
}

/* Adds a paragraph: `head` padded to `col`, then `body` wrapped at width, each line indented. */
static void text_paragraph(text *t, int indent, int col, int width, const char *head, const char *body)
{
    char line[256];
    int pos = snprintf(line, sizeof line, "%*s%s", indent, "", head);
    if (pos >= col - 1) { /* a long head gets a line of its own */
        text_add(t, line, (size_t)pos);
        text_add(t, "\n", 1);
        pos = 0;
    }
    pos += snprintf(line + pos, sizeof line - (size_t)pos, "%*s", col - pos, "");
    for (const char *w = body; *w;) {
        while (*w == ' ')
            ++w;
        size_t wn = strcspn(w, " ");
        if (!wn)
            break;
        if (pos + (int)wn + 1 > width && pos > col) {
            text_add(t, line, (size_t)pos);
            text_add(t, "\n", 1);
            pos = snprintf(line, sizeof line, "%*s", col, "");
        }
        if (pos > col)
            line[pos++] = ' ';
        if (pos + wn >= sizeof line)
            wn = sizeof line - (size_t)pos - 1;
        memcpy(line + pos, w, wn);
        pos += (int)wn;
        w += wn;
    }
    text_add(t, line, (size_t)pos);
    text_add(t, "\n", 1);
}

/* The option's default for each solver, grouped: "256 (angular), 64 (newton, conic)". */
static void cat_default(char *buf, size_t len, size_t *used, const spc_snee_option *o)
{
    if (o->default_note) {
        cat(buf, len, used, "%s", o->default_note);
        return;
    }
    char tokens[SPC_SNEE_CONIC + 1][64];
    int ids[SPC_SNEE_CONIC + 1], n = 0;
    for (int id = SPC_SNEE_NONE + 1; id <= SPC_SNEE_CONIC; ++id) {
        if (!spc_specular_solver_get(id) || (o->solver && o->solver != id))
            continue;
        spc_snee_params p;
        spc_snee_params_default(&p, id, 2);
        size_t tn = 0;
        tokens[n][0] = '\0';
        cat_option(tokens[n], sizeof tokens[n], &tn, &p, o, false);
        if (!tn)
            cat(tokens[n], sizeof tokens[n], &tn, "off");
        if (!o->negation && o->flag == SPC_SNEE_NO_FIELD) /* a plain value: "64", not "trials=64" */
            memmove(tokens[n], tokens[n] + strlen(o->name) + 1, strlen(tokens[n] + strlen(o->name) + 1) + 1);
        else if (o->flag != SPC_SNEE_NO_FIELD && o->field != SPC_SNEE_NO_FIELD && !flag_of(&p, o))
            cat(tokens[n], sizeof tokens[n], &tn, o->kind == SPC_SNEE_OPT_REAL ? ", %s %g" : ", %s %.0f", o->metavar,
                value_of(&p, o)); /* the value it would take: "unbiased, M 8" */
        ids[n++] = id;
    }
    bool all_same = true;
    for (int i = 1; i < n; ++i)
        all_same = all_same && !strcmp(tokens[i], tokens[0]);
    if (all_same || o->solver) {
        cat(buf, len, used, "%s", n ? tokens[0] : "off");
        return;
    }
    bool done[SPC_SNEE_CONIC + 1] = {false};
    for (int i = 0; i < n; ++i) {
        if (done[i])
            continue;
        cat(buf, len, used, "%s%s (", i ? ", " : "", tokens[i]);
        for (int j = i, first = 1; j < n; ++j)
            if (!done[j] && !strcmp(tokens[j], tokens[i])) {
                cat(buf, len, used, "%s%s", first ? "" : ", ", spc_specular_solver_get(ids[j])->name);
                done[j] = true;
                first = 0;
            }
        cat(buf, len, used, ")");
    }
}

char *spc_snee_options_help(int indent, int width)
{
    text t = {NULL, 0, 0, false};
    const int col = indent + 23;
    for (int i = 0; i < NOPTIONS; ++i) {
        const spc_snee_option *o = &options[i];
        char head[96], body[SPC_SNEE_WHY_MAX];
        size_t hn = 0, bn = 0;
        cat_usage(head, sizeof head, &hn, o);
        cat(body, sizeof body, &bn, "%s", o->help);
        if (o->kind == SPC_SNEE_OPT_COUNT || o->kind == SPC_SNEE_OPT_REAL) {
            cat(body, sizeof body, &bn, "; %s ", o->metavar);
            cat_range(body, sizeof body, &bn, o);
        }
        cat(body, sizeof body, &bn, " (default: ");
        cat_default(body, sizeof body, &bn, o);
        cat(body, sizeof body, &bn, ")");
        text_paragraph(&t, indent, col, width, head, body);
    }
    if (t.failed || !t.s) {
        free(t.s);
        return NULL;
    }
    return t.s;
}

bool spc_snee_parse(const char *spec, int max_chain, spc_snee_params *p)
{
    return spc_snee_options_parse(spec, max_chain, p, NULL, 0) == SPC_SNEE_PARSE_OK;
}
