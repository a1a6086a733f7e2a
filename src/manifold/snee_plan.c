/*
 * manifold/snee_plan.c: the default of specular NEE, chosen from the scene (snee_plan.h), and its
 * description for `specula info`, the --stats JSON and the EXR header.
 */
#include "manifold/snee_plan.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "emitter/emitter.h"
#include "manifold/cylinder_chains.h"
#include "manifold/plane_chains.h"
#include "manifold/snee_options.h"
#include "manifold/sphere_chains.h"
#include "scene/scene.h"

/* Off when every light subtends more than this solid angle at the casters (snee_plan.h): BSDF
 * sampling then finds the lights through glass and mirrors often enough that specular NEE's cost
 * does not pay (bench/RESULTS.md, "Caustics by default"). */
#define SPC_SNEE_PLAN_MAX_SR 0.03

/* ... unless the casters fill at least this share of a light's directions (the light within or
 * close over the spheres around them, as over a water surface): most light then reaches the
 * receivers through the casters, and specular NEE paid even with a larger light (newton_pool, 0.075
 * sr, share 1: at equal CPU time relMSE 1.9x lower than without, 5.9x with `angular:camera`; the
 * Mitsuba 0.6 box, 0.062 sr, share 0.05: 5x higher with `angular:camera`; bench/RESULTS.md, "Plan
 * rules from the scene"). */
#define SPC_SNEE_PLAN_MIN_SHARE 0.25

static bool is_auto(const char *s) { return spc_snee_setting_is_auto(s); }
static bool is_off(const char *s) { return spc_snee_setting_is_off(s); }

/* A shape specular NEE may start at: a receiver with a non-delta lobe. */
static bool receiver(const spc_shape *s)
{
    return s->bsdf && (s->caustic_flags & SPC_CAUSTIC_RECEIVER) && spc_bsdf_has_smooth(s->bsdf);
}

/* A light specular NEE draws points on (spc_snee_sample_light). */
static bool snee_light(const spc_emitter *e)
{
    return e->type == SPC_EMITTER_AREA || e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_SPOT;
}

/* The solid angle (sr, at most 2 pi) an area light's shape subtends at c: area / d^2 for a distant
 * light (d its bounding sphere's distance), 2 pi from within that sphere. */
static double light_solid_angle(const spc_shape *s, spc_vec3 c)
{
    spc_vec3 lc = spc_scale(spc_add(s->bbox_min, s->bbox_max), 0.5);
    double lr = 0.5 * spc_length(spc_sub(s->bbox_max, s->bbox_min));
    double d = spc_length(spc_sub(lc, c));
    if (!(d > lr))
        return 2.0 * SPC_PI;
    double area = s->type == SPC_SHAPE_SPHERE ? SPC_PI * s->radius * s->radius : 0.5 * s->area;
    return spc_min(2.0 * SPC_PI, area / (d * d));
}

/* The share of the directions from light e's centre (a point or spot light's position) that meet
 * the casters: the sum over casters of the solid angle of the sphere around each one's bounding box
 * over 4 pi (1 from within such a sphere), at most 1. */
static double caster_share(const spc_emitter *e, const spc_scene *sc, const spc_chain_casters *cs)
{
    spc_vec3 lc;
    if (e->type == SPC_EMITTER_AREA && e->shape_index >= 0 && e->shape_index < sc->nshapes) {
        const spc_shape *s = sc->shapes[e->shape_index];
        lc = spc_scale(spc_add(s->bbox_min, s->bbox_max), 0.5);
    } else if (e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_SPOT) {
        lc = e->position;
    } else {
        return 0.0;
    }
    double share = 0.0;
    for (int i = 0; i < cs->n && share < 1.0; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        spc_vec3 c = spc_scale(spc_add(s->bbox_min, s->bbox_max), 0.5);
        double R = 0.5 * spc_length(spc_sub(s->bbox_max, s->bbox_min));
        double d = spc_length(spc_sub(c, lc));
        share += d > R ? 0.5 * (1.0 - sqrt(1.0 - (R / d) * (R / d))) : 1.0;
    }
    return spc_min(share, 1.0);
}

/* Flat faces: a disk, or a mesh without vertex normals (a cube, a rectangle, face_normals). */
static bool flat(const spc_shape *s)
{
    return s->type == SPC_SHAPE_DISK || (s->type == SPC_SHAPE_MESH && (s->face_normals || !s->mesh.n));
}

static void off(spc_snee_plan *out, const char *why)
{
    out->on = false;
    snprintf(out->setting, sizeof out->setting, "none");
    snprintf(out->reason, sizeof out->reason, "%s", why);
}

void spc_snee_plan_make(const spc_scene *sc, const char *integrator, const char *setting, spc_snee_plan *out)
{
    memset(out, 0, sizeof *out);
    const spc_chain_casters *cs = sc ? spc_chain_casters_of(sc, false) : NULL;
    out->casters = cs ? cs->n : 0;
    for (int i = 0; sc && i < sc->nshapes; ++i)
        out->receivers += receiver(sc->shapes[i]) ? 1 : 0;
    out->automatic = is_auto(setting);
    if (is_off(setting)) {
        off(out, "turned off");
        return;
    }
    if (!out->automatic) {
        out->on = true;
        snprintf(out->setting, sizeof out->setting, "%s", setting);
        return;
    }
    const bool bdpt = integrator && !strcmp(integrator, "bdpt");
    if (!integrator || (strcmp(integrator, "path") && strcmp(integrator, "volpath") && !bdpt)) {
        off(out, "only path, volpath and bdpt use it");
        return;
    }
    if (out->casters == 0) {
        off(out, "no specular casters");
        return;
    }
    if (out->receivers == 0) {
        off(out, "no receivers");
        return;
    }
    bool lit = false;
    out->light_sr = 0.0;
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        if (!snee_light(e))
            continue;
        double sr = e->type == SPC_EMITTER_AREA && e->shape_index >= 0 && e->shape_index < sc->nshapes
                        ? light_solid_angle(sc->shapes[e->shape_index], cs->center)
                        : 0.0;
        if (!lit || sr < out->light_sr)
            out->light_sr = sr;
        double share = caster_share(e, sc, cs);
        if (share > out->caster_share)
            out->caster_share = share;
        lit = true;
    }
    if (!lit) {
        off(out, "no area, point or spot light");
        return;
    }
    if (out->light_sr > SPC_SNEE_PLAN_MAX_SR && out->caster_share < SPC_SNEE_PLAN_MIN_SHARE) {
        snprintf(out->reason, sizeof out->reason, "every light is large: %.2g sr from the casters (share %.2g)", out->light_sr, out->caster_share);
        out->on = false;
        snprintf(out->setting, sizeof out->setting, "none");
        return;
    }
    /* not with flat-faced casters no enumeration covers (snee_plan.h) */
    spc_snee_params p;
    if (!spc_snee_parse(SPC_SNEE_PLAN_SETTING, 2, &p)) {
        off(out, "no solver");
        return;
    }
    for (int i = 0; i < cs->n; ++i)
        if (flat(sc->shapes[cs->idx[i]]) &&
            spc_snee_plan_method(&p, sc->shapes[cs->idx[i]]) == SPC_SNEE_METHOD_SOLVER) {
            snprintf(out->reason, sizeof out->reason, "caster shape %d is flat-faced", cs->idx[i]);
            out->on = false;
            snprintf(out->setting, sizeof out->setting, "none");
            return;
        }
    /* the query from the camera only where some caster is glass (snee_plan.h) */
    bool glass = false;
    for (int i = 0; i < cs->n && !glass; ++i) {
        double eta = 0.0;
        glass = spc_bsdf_is_specular_interface(sc->shapes[cs->idx[i]]->bsdf, &eta) && eta > 0.0;
    }
    out->on = true;
    const char *chosen = bdpt ? (glass ? SPC_SNEE_PLAN_SETTING_BDPT : SPC_SNEE_PLAN_SETTING_BDPT_MIRRORS)
                               : (glass ? SPC_SNEE_PLAN_SETTING : SPC_SNEE_PLAN_SETTING_MIRRORS);
    snprintf(out->setting, sizeof out->setting, "%s", chosen);
}

spc_snee_method spc_snee_plan_method(const spc_snee_params *p, const spc_shape *s)
{
    if (p->exact) {
        if (spc_sphere_chain_shape(s))
            return SPC_SNEE_METHOD_SPHERE;
        if (spc_cylinder_chain_shape(s))
            return SPC_SNEE_METHOD_CYLINDER;
        if (spc_plane_chain_shape(s))
            return SPC_SNEE_METHOD_PLANE;
    }
    return SPC_SNEE_METHOD_SOLVER;
}

typedef struct out_buf {
    char *p;
    size_t len, used;
} out_buf;

static void put(out_buf *b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    size_t room = b->used < b->len ? b->len - b->used : 0;
    int n = vsnprintf(room ? b->p + b->used : NULL, room, fmt, ap);
    va_end(ap);
    if (n > 0)
        b->used += (size_t)n;
}

static const char *shape_name(const spc_shape *s)
{
    switch (s->type) {
    case SPC_SHAPE_MESH: return "mesh";
    case SPC_SHAPE_SPHERE: return "sphere";
    case SPC_SHAPE_DISK: return "disk";
    case SPC_SHAPE_CYLINDER: return "cylinder";
    case SPC_SHAPE_SDF: return "sdf";
    case SPC_SHAPE_CURVE: return "curve";
    case SPC_SHAPE_SDFGRID: return "sdfgrid";
    }
    return "?";
}

int spc_snee_plan_describe(const spc_scene *sc, const spc_snee_plan *plan, int max_chain, char *buf, size_t len)
{
    out_buf b = {buf, len, 0};
    if (len)
        buf[0] = '\0';
    if (!plan->on) {
        put(&b, "specular NEE: none (%s%s); %d casters, %d receivers\n", plan->automatic ? "auto: " : "",
            plan->reason, plan->casters, plan->receivers);
        return (int)b.used;
    }
    spc_snee_params p;
    if (!spc_snee_parse(plan->setting, max_chain, &p)) {
        put(&b, "specular NEE: '%s' is not a valid setting\n", plan->setting);
        return (int)b.used;
    }
    const spc_specular_solver *solver = spc_specular_solver_get(p.solver);
    put(&b, "specular NEE: %s%s; chains of 1-%d vertices%s%s; %d casters, %d receivers; smallest light %.2g sr\n",
        plan->setting, plan->automatic ? " (auto)" : "", p.max_chain, p.reflect ? ", reflections off glass" : "",
        !p.no_mis ? "" : ", no MIS", plan->casters, plan->receivers, plan->light_sr);
    if (p.later_p < 1.0)
        put(&b, "  past a path's first receiver with probability %g (Russian roulette)\n", p.later_p);
    if (p.camera && p.camera_p < 1.0)
        put(&b, "  from the camera on a share %g of the samples\n", p.camera_p);
    const spc_chain_casters *cs = spc_chain_casters_of(sc, p.any_surface);
    for (int i = 0; cs && i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        const char *kind = spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0 ? "glass" : "mirror";
        put(&b, "  caster shape %d: %s %s%s%s: ", cs->idx[i], kind, shape_name(s), s->id[0] ? " id=" : "", s->id);
        switch (spc_snee_plan_method(&p, s)) {
        case SPC_SNEE_METHOD_SPHERE:
            put(&b, "every chain on the sphere enumerated exactly, 1-%d vertices", p.max_chain);
            if (p.long_p > 0.0 && !p.no_mis)
                put(&b, " (up to 6 with probability %g)", p.long_p);
            break;
        case SPC_SNEE_METHOD_CYLINDER:
            put(&b, "every reflection on the mirror cylinder enumerated exactly, 1-%d vertices", p.max_chain);
            break;
        case SPC_SNEE_METHOD_PLANE:
            put(&b, "every chain through the normal-mapped plane enumerated exactly, 1 vertex");
            if (p.max_chain > 1)
                put(&b, "; longer chains by %s", solver ? solver->name : "?");
            break;
        case SPC_SNEE_METHOD_SOLVER:
            put(&b, "%s, 1-%d vertices%s", solver ? solver->name : "?", p.max_chain,
                p.biased ? " (biased)" : solver && solver->solve_all ? "" : " (unbiased: Bernoulli trial count)");
            break;
        }
        put(&b, "\n");
    }
    return (int)b.used;
}
