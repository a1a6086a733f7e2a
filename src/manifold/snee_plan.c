/*
 * manifold/snee_plan.c: the default of specular NEE, chosen from the scene (snee_plan.h), and its
 * description for `specula info`, the --stats JSON and the EXR header.
 */
#include "manifold/snee_plan.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/rng.h"
#include "emitter/emitter.h"
#include "manifold/caustic_guide.h"
#include "manifold/cylinder_chains.h"
#include "manifold/fit_seeds.h"
#include "manifold/flat_chains.h"
#include "manifold/plane_chains.h"
#include "manifold/snee_cost.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "manifold/sphere_chains.h"
#include "scene/camera.h"
#include "scene/scene.h"
#include "scene/sdf.h"

/* Off when every light subtends more than this solid angle at the casters (snee_plan.h): BSDF
 * sampling then finds the lights through glass and mirrors often enough that specular NEE's cost
 * does not pay (bench/RESULTS.md, "Caustics by default"). */
#define SPC_SNEE_PLAN_MAX_SR 0.03

/* With a flat-faced caster (its chains enumerated by flat_chains.h), on only where the smallest
 * light is below this solid angle at the casters: flat glass does not focus light, so BSDF
 * sampling reaches a light through it as often as without it, and the enumeration's cost (0.1-3 ms
 * per query through several tilted slabs) pays only where that is rare. At equal CPU time
 * (bench/RESULTS.md, "Planar: exact chains through flat faces"): scenes/caustic_slabs_small_light.xml
 * (0.00066 sr) 7.3x lower relMSE than none; scenes/caustic_slabs.xml (0.011 sr) 0.4x,
 * scenes/caustic_glass_cube.xml (0.0038 sr) 1.0x, scenes/newton_slabs.xml (0.12 sr) 0.6x: off. */
#define SPC_SNEE_PLAN_FLAT_MAX_SR 0.002
/* ... and for path, past that solid angle where the flat enumeration's cost pays (with the longer
 * chains through the faces enumerated too, SPC_SNEE_PLAN_FLAT_LONG, snee_plan.h): the face
 * sequences the enumeration solves per query (a pilot, flat_sequences_per_query) times the light's
 * solid angle at most this. The query's cost grows with the sequences (one solve per sequence,
 * about 20 us through slabs), and the gain over BSDF sampling falls as the light grows (BSDF
 * sampling reaches a light through flat glass about as often as without it, in proportion to its
 * solid angle). At equal CPU time against
 * bdpt (bench/RESULTS.md, "Slab scenes the plan left at none" and "a cost-based plan rule"), the
 * scenes that gain (4.6-40x over none: random caustic scenes 400, 409, 410, 425, 435, 438, 480,
 * 488, 489; two slabs in 490, 2.2x) have products 0.0023-0.045 sr, the two that lose 0.15 (403: one
 * slab under a light of 0.0038 sr almost straight above it, 39 sequences a query, 0.6x) and 1.2
 * (432: two slabs and a glass ball under 0.014 sr, 83 sequences, 0.07x): the limit sits between
 * them, 1.8x from either. */
#define SPC_SNEE_PLAN_FLAT_COST_SR 0.08
/* ... and at most this where a mirror (a ball or a cylinder) stands beside the flat casters. Of the
 * random scenes with a slab beside a mirror under 0.002-0.01 sr (bench/RESULTS.md, "a glass slab
 * beside a mirror"), at equal CPU time over 16 seeds against none: those at products 0.0018-0.067
 * gain (scenes/caustic_glass_cube.xml 7.7x at 0.012, random scenes 7005 124x, 7100 21x, 6251 8.7x
 * at 0.067, 6214 4.1x, 7074 2.9x, 7152 2.0x, 6223 1.5x), past them 7180 (0.069) 1.1x, 7195 (0.072)
 * 0.7x by the query's cost (18 spp against none's 2046) and 7147 (0.075) 6.9x, which no limit keeps
 * apart from 7195 (both 9.1 sequences a query under 0.008 sr): the limit sits just past 6251, a
 * threshold, not a cost model. The three that lost to none with the slab setting forced lie past
 * it (6202, 0.56; 6278, 0.28) or past SPC_SNEE_PLAN_FLAT_LONG_MAX_SR (6366); their one-pixel seeds,
 * traced, were chains inside the slab (the floor seen through it, lit through it after 3-7
 * internal reflections, or 10 vertices along a thin slab), none off the mirror. */
#define SPC_SNEE_PLAN_FLAT_MIRROR_COST_SR 0.068
/* ... and at most this where every caster is flat-faced (no glass sphere or ball beside the slabs).
 * With light tracing through the slabs (SPC_SNEE_PLAN_FLAT_LT_LONG, snee_plan.h) taking the flat
 * chains the enumeration leaves to BSDF sampling (7-8 vertices along a slab, partial reflections
 * inside the glass), whose one-pixel seeds made 9 of 13 such scenes lose to none under the earlier
 * limit 0.08, the flat-only scenes measured at equal CPU time against bdpt gain over none
 * (bench/RESULTS.md, "the slab scenes' one-pixel seeds"): over 8 seeds 25 of 26 with products
 * 0.007-0.253 sr, 1.4-37x (random scenes 113 1.4x at 0.168, 6053 2.0x at 0.253), the 26th (6038,
 * 0.060) at the reference's noise floor either way; random 1165 (0.050) loses over 24 seeds
 * (0.69x: the light seen from the camera through the slab, BSDF sampling's alone) between winners
 * of 13-22x, which no limit separates. No flat-only scene of the 900 random scenes scanned lies
 * past 0.253; the limit sits just above it, a threshold, not a cost model. */
#define SPC_SNEE_PLAN_FLAT_ALONE_COST_SR 0.26
/* ... and only up to this solid angle, the largest of a measured gain (random scene 652, one slab
 * under 0.0098 sr: 3.1x over none against bdpt): with one face or few the query's cost is small
 * under any light, but so is the gain where BSDF sampling finds the light through flat glass often
 * (scenes/caustic_slabs.xml, three slabs under 0.011 sr: 0.4x with the flat rule's setting). */
#define SPC_SNEE_PLAN_FLAT_LONG_MAX_SR 0.01
/* Flat-faced casters alone under area lights past SPC_SNEE_PLAN_FLAT_LONG_MAX_SR: on with light
 * tracing (flat_large_lights, SPC_SNEE_PLAN_FLAT_LARGE) up to this solid angle. At equal CPU time
 * against none over 16 seeds (bench/RESULTS.md, "Slabs under larger lights"), random slab scenes
 * with their lights enlarged gain under 0.015 and 0.03 sr (2.6-15x on 5 of 6; one loses, 0.7x, by
 * one pixel), are mixed under 0.06 sr (1.5x, 1.5x, two slabs 0.6x) and lose under 0.12-0.2 sr
 * (0.1-0.7x: BSDF sampling finds such a light through a slab often, and the query's cost, about a
 * hundred BSDF samples, is spent on a caustic that is a small part of the image); the limit sits
 * between 0.03 and 0.06. */
#define SPC_SNEE_PLAN_FLAT_LARGE_MAX_SR 0.045
/* ... and up to this one where the slabs fill at least SPC_SNEE_PLAN_MIN_SHARE of a light's
 * directions (the light's power mostly through them, as over scenes/newton_slabs.xml's two plates,
 * 0.12 sr, share 1: 2-3x none). */
#define SPC_SNEE_PLAN_FLAT_LARGE_SHARED_MAX_SR 0.2
/* The pilot: receivers seen by pinhole rays through the centres of a grid of this many cells a side
 * of the film (a flat caster's own faces skipped), each queried toward the centre of the smallest
 * light with chains of 1 to SPC_FLAT_MAX_VERTICES - 1 vertices (flat5's longest); 8 x 8 rays cost
 * 20-90 ms at load on the slab scenes measured, once. */
#define SPC_SNEE_PLAN_FLAT_PILOT_GRID 8

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

/* Is e a light at a point: a point light or a spot light (light tracing takes both alike,
 * integrator/path_lt.h)? */
static bool point_light(const spc_emitter *e)
{
    return e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_SPOT;
}

static double light_solid_angle(const spc_shape *s, spc_vec3 c);

/* Are the scene's lights ones the light-traced caustics of area lights pay on
 * (SPC_SNEE_PLAN_AREA_LIGHTS): some area light, every light a point or an area light (a sky
 * besides), every area light small (a solid angle at most SPC_SNEE_PLAN_LT_AREA_SR from the
 * casters' centre)? */
static bool small_area_lights(const spc_scene *sc, const spc_chain_casters *cs)
{
    bool area = false;
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        if (e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_CONSTANT || e->type == SPC_EMITTER_ENVMAP)
            continue;
        if (e->type != SPC_EMITTER_AREA || e->shape_index < 0 || e->shape_index >= sc->nshapes ||
            light_solid_angle(sc->shapes[e->shape_index], cs->center) > SPC_SNEE_PLAN_LT_AREA_SR)
            return false;
        area = true;
    }
    return area;
}

/* Is every caster a mirror cylinder whose chains cylinder_chains.h enumerates? */
static bool cylinders_only(const spc_scene *sc, const spc_chain_casters *cs, const spc_snee_params *p)
{
    for (int i = 0; i < cs->n; ++i)
        if (spc_snee_plan_method(p, sc->shapes[cs->idx[i]]) != SPC_SNEE_METHOD_CYLINDER)
            return false;
    return cs->n > 0;
}

/* Is every caster a normal-mapped plane whose chains plane_chains.h enumerates (a water surface)? */
static bool water_planes_only(const spc_scene *sc, const spc_chain_casters *cs, const spc_snee_params *p)
{
    for (int i = 0; i < cs->n; ++i)
        if (spc_snee_plan_method(p, sc->shapes[cs->idx[i]]) != SPC_SNEE_METHOD_PLANE)
            return false;
    return cs->n > 0;
}

/* Is every caster a mirror whose chains the flat enumeration takes (a conductor mesh of few planes)? */
static bool flat_mirrors_only(const spc_scene *sc, const spc_chain_casters *cs)
{
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        if (!spc_flat_chain_shape(s) || (spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0))
            return false;
    }
    return cs->n > 0;
}

/* Is some caster a ball whose chains are enumerated exactly (a glass or mirror sphere), and some
 * other a mirror whose chains the flat enumeration takes? (Chains through flat glass and off a
 * flat mirror are the flat enumeration's.) */
static bool ball_beside_flat_mirror(const spc_scene *sc, const spc_chain_casters *cs, const spc_snee_params *p)
{
    bool ball = false, flat_mirror = false;
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        if (spc_snee_plan_method(p, s) == SPC_SNEE_METHOD_SPHERE)
            ball = true;
        else if (!(spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0))
            flat_mirror = flat_mirror || spc_flat_chain_shape(s);
    }
    return ball && flat_mirror;
}

/* Does a ball whose chains are enumerated exactly (an analytic glass or mirror sphere) rest on a
 * flat mirror: the gap between the sphere and the mirror's bounding box at most
 * SPC_SNEE_PLAN_BALL_ON_MIRROR_GAP of its radius (snee_plan.h)? */
static bool ball_on_flat_mirror(const spc_scene *sc, const spc_chain_casters *cs, const spc_snee_params *p)
{
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *b = sc->shapes[cs->idx[i]];
        if (b->type != SPC_SHAPE_SPHERE || spc_snee_plan_method(p, b) != SPC_SNEE_METHOD_SPHERE)
            continue;
        for (int j = 0; j < cs->n; ++j) {
            const spc_shape *m = sc->shapes[cs->idx[j]];
            double eta = 0.0;
            if (j == i || !spc_flat_chain_shape(m) || (spc_bsdf_is_specular_interface(m->bsdf, &eta) && eta > 0.0))
                continue;
            /* the distance from the ball's centre to the mirror's box */
            spc_vec3 c = b->center, lo = m->bbox_min, hi = m->bbox_max;
            spc_vec3 q = spc_v3(spc_max(lo.x, spc_min(c.x, hi.x)), spc_max(lo.y, spc_min(c.y, hi.y)),
                                spc_max(lo.z, spc_min(c.z, hi.z)));
            if (spc_length(spc_sub(c, q)) - b->radius <= SPC_SNEE_PLAN_BALL_ON_MIRROR_GAP * b->radius)
                return true;
        }
    }
    return false;
}

/* Flat-faced casters under small area lights, for path (no caustic guide at receivers): light
 * tracing makes their caustics too (,ltcaus where no other rule added it) and the flat
 * enumeration's longer chains run on a share of the calls (snee_plan.h, SPC_SNEE_PLAN_FLAT_LT and
 * SPC_SNEE_PLAN_FLAT_LT_LONG where the 5-vertex chains ran at every call). */
static void flat_light_tracing(const spc_scene *sc, const spc_chain_casters *cs, int nflat, const char *integrator,
                               spc_snee_plan *out)
{
    if (nflat == 0 || strcmp(integrator, "path") || strstr(out->setting, "recguide") || !small_area_lights(sc, cs))
        return;
    size_t n = strlen(out->setting);
    snprintf(out->setting + n, sizeof out->setting - n, "%s%s",
             strstr(out->setting, "ltcaus") ? "" : SPC_SNEE_PLAN_AREA_LIGHTS,
             strstr(out->setting, SPC_SNEE_PLAN_FLAT_LONG) ? SPC_SNEE_PLAN_FLAT_LT_LONG : SPC_SNEE_PLAN_FLAT_LT);
}

/* Closed flat-faced glass casters alone (slabs: no mirror, no other caster, no open pane) under area
 * lights (a sky besides), the smallest past SPC_SNEE_PLAN_FLAT_LONG_MAX_SR and every one at most
 * SPC_SNEE_PLAN_FLAT_LARGE_MAX_SR from the casters' centre (SPC_SNEE_PLAN_FLAT_LARGE_SHARED_MAX_SR
 * where the casters fill a share of some light's directions of at least SPC_SNEE_PLAN_MIN_SHARE),
 * for path: the flat rules leave them off, this one turns them on with light tracing on every
 * sample (SPC_SNEE_PLAN_FLAT_LARGE). */
static bool flat_large_lights(const spc_scene *sc, const spc_chain_casters *cs, int nflat, bool mirror,
                              const char *integrator, double light_sr, double caster_share)
{
    if (nflat == 0 || nflat != cs->n || mirror || strcmp(integrator, "path") ||
        !(light_sr > SPC_SNEE_PLAN_FLAT_LONG_MAX_SR))
        return false;
    const double max_sr = caster_share >= SPC_SNEE_PLAN_MIN_SHARE ? SPC_SNEE_PLAN_FLAT_LARGE_SHARED_MAX_SR
                                                                  : SPC_SNEE_PLAN_FLAT_LARGE_MAX_SR;
    for (int i = 0; i < cs->n; ++i)
        if (!spc_flat_chain_closed(sc->shapes[cs->idx[i]]))
            return false;
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        if (e->type == SPC_EMITTER_CONSTANT || e->type == SPC_EMITTER_ENVMAP)
            continue;
        if (e->type != SPC_EMITTER_AREA || e->shape_index < 0 || e->shape_index >= sc->nshapes ||
            light_solid_angle(sc->shapes[e->shape_index], cs->center) > max_sr)
            return false;
    }
    return true;
}

/* Is every light of the scene a point or spot light, a sky besides (some point or spot light)? */
static bool point_lights_sky(const spc_scene *sc)
{
    bool point = false;
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        if (e->type == SPC_EMITTER_CONSTANT || e->type == SPC_EMITTER_ENVMAP)
            continue;
        if (!point_light(e))
            return false;
        point = true;
    }
    return point;
}

/* Flat-faced casters under point lights (a sky besides), for path (no caustic guide at receivers):
 * light tracing makes the point lights' caustics through the slabs too (snee_plan.h,
 * SPC_SNEE_PLAN_FLAT_POINT_LIGHTS, where no other rule added it). */
static void flat_point_light_tracing(const spc_scene *sc, int nflat, const char *integrator, spc_snee_plan *out)
{
    if (nflat == 0 || strcmp(integrator, "path") || strstr(out->setting, "recguide") ||
        strstr(out->setting, "ltcaus") || !point_lights_sky(sc))
        return;
    size_t n = strlen(out->setting);
    snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_FLAT_POINT_LIGHTS);
}

/* Is some caster a mirror ball (a sphere that is no glass interface)? */
static bool mirror_ball(const spc_scene *sc, const spc_chain_casters *cs)
{
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        if (s->type == SPC_SHAPE_SPHERE && !(spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0))
            return true;
    }
    return false;
}

/* Flat-faced casters under point lights (a sky besides), for path with light tracing's point-light
 * chains on (ltcaus: from the rule above, the sphere's or the ball's), without the caustic guide at
 * receivers: light tracing joins the receivers seen through a slab to the pinhole too
 * (SPC_SNEE_PLAN_FLAT_POINT_JOINS), and where no mirror ball is a caster the flat enumeration makes
 * its 3- and 4-vertex chains on a share of its calls (SPC_SNEE_PLAN_FLAT_POINT_SHARE, where no rule
 * set that share). */
static void flat_point_light_joins(const spc_scene *sc, const spc_chain_casters *cs, int nflat,
                                   const char *integrator, spc_snee_plan *out)
{
    if (nflat == 0 || strcmp(integrator, "path") || strstr(out->setting, "recguide") ||
        !strstr(out->setting, "ltcaus") || !point_lights_sky(sc))
        return;
    size_t n = strlen(out->setting);
    snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_FLAT_POINT_JOINS);
    if (mirror_ball(sc, cs) || strstr(out->setting, "flat34"))
        return;
    n = strlen(out->setting);
    snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_FLAT_POINT_SHARE);
}

/* A closed flat-faced glass caster (a slab) under point or spot lights (a sky besides), for path
 * with light tracing's point-light chains on (ltcaus) and no caustic guide at receivers, where the
 * path's depth leaves room for a chain past SPC_FLAT_MAX_VERTICES: the light guides from the point
 * lights too (snee_plan.h, SPC_SNEE_PLAN_POINT_GUIDES), where no rule turned them on. */
static void point_light_guides(const spc_scene *sc, const spc_chain_casters *cs, const char *integrator,
                               spc_snee_plan *out)
{
    const int depth = sc->integrator.max_depth;
    if (strcmp(integrator, "path") || strstr(out->setting, "recguide") || !strstr(out->setting, "ltcaus") ||
        strstr(out->setting, "ltguide") || (depth >= 0 && depth < SPC_FLAT_MAX_VERTICES + 3) ||
        !point_lights_sky(sc))
        return;
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        if (spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0 && spc_flat_chain_closed(s)) {
            size_t n = strlen(out->setting);
            snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_POINT_GUIDES);
            return;
        }
    }
}

/* Is some caster a glass sphere (its chains enumerated, sphere_chains.h)? */
static bool glass_sphere(const spc_scene *sc, const spc_chain_casters *cs)
{
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        if (spc_sphere_chain_shape(s) && spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0)
            return true;
    }
    return false;
}

/* Do the glass casters sit in a medium: every glass caster with a medium on its outside and none
 * within it (a glass ball in a fog)? Its medium points then mostly see the lights directly, and the
 * chains through the glass carry a small part of their light: at equal CPU time over 24 seeds
 * volpath's ball setting was 0.62-1.01x none on bench/check/medium_fog_ball.xml and six fresh
 * fog-ball scenes (0.88-1.05x with tightshare), where a medium inside the glass
 * (scenes/medium_glass.xml: every medium point lit through the glass) gains 16-34x
 * (bench/RESULTS.md, "The fog ball and dielectrics"). */
static bool glass_in_medium(const spc_scene *sc, const spc_chain_casters *cs)
{
    bool any = false;
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        if (!(spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0))
            continue;
        if (s->exterior_medium < 0 || s->interior_medium >= 0)
            return false;
        any = true;
    }
    return any;
}

/* Is some caster a glass SDF (smooth: creased ones turn the plan off)? */
static bool glass_sdf(const spc_scene *sc, const spc_chain_casters *cs)
{
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        if (s->type == SPC_SHAPE_SDF && spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0)
            return true;
    }
    return false;
}

/* A light specular NEE draws points on (spc_snee_sample_light). */
static bool snee_light(const spc_emitter *e)
{
    return e->type == SPC_EMITTER_AREA || e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_SPOT;
}

/* Does specular NEE draw on some sphere light (an area light on a sphere with its normals out)? */
static bool sphere_lights(const spc_scene *sc)
{
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        if (e->type != SPC_EMITTER_AREA || e->shape_index < 0 || e->shape_index >= sc->nshapes)
            continue;
        const spc_shape *s = sc->shapes[e->shape_index];
        if (s->type == SPC_SHAPE_SPHERE && !s->flip_normals)
            return true;
    }
    return false;
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
    return spc_snee_caster_share(sc, cs, lc);
}

/* Segments drawn from points of the casters to points of a light to tell whether the light is seen
 * from any caster at all. Where it is not (a bulb inside an opaque lamp shade), every chain's last
 * segment to it is blocked: specular NEE finds nothing and only costs (scenes/indirect_lamp_glass.xml:
 * 6x the CPU time per sample of plain path tracing, the same variance per sample; bench/RESULTS.md,
 * "Lamp: where the default disagrees"). With 1024 segments a light seen along a share s of them
 * is missed with probability (1 - s)^1024: 3.4e-5 for s = 1%. Turning specular NEE off is never
 * a bias, so a miss costs time only. */
#define SPC_SNEE_PLAN_SIGHT_SEGMENTS 1024

/* Crossings of casters a sight segment passes through before it counts as blocked (each caster
 * surface it meets continues it: chains pass through and off casters). */
#define SPC_SNEE_PLAN_SIGHT_CROSSINGS 16

/* Directions open_share traces from the casters' centre (a Fibonacci sphere: the share to about
 * 1/256), and the caster or light surfaces one of its rays passes before it counts as stopped. */
#define SPC_SNEE_PLAN_OPEN_DIRS 256
#define SPC_SNEE_PLAN_OPEN_PASSES 16

static bool is_caster(const spc_chain_casters *cs, int shape_index)
{
    for (int k = 0; k < cs->n; ++k)
        if (cs->idx[k] == shape_index)
            return true;
    return false;
}

/* Is light e (an area, point or spot light) seen from a caster: does some straight segment from a
 * uniform point of a caster to a uniform point of the light (a point or spot light's position)
 * reach the light through nothing but casters? Deterministic (a fixed seed per light). */
static bool light_seen(const spc_emitter *e, int ei, const spc_scene *sc, const spc_chain_casters *cs)
{
    const spc_shape *ls = NULL;
    if (e->type == SPC_EMITTER_AREA) {
        if (e->shape_index < 0 || e->shape_index >= sc->nshapes)
            return true;
        ls = sc->shapes[e->shape_index];
    }
    spc_rng rng;
    spc_rng_seed(&rng, 0x51647ull, (uint64_t)ei);
    for (int i = 0; i < SPC_SNEE_PLAN_SIGHT_SEGMENTS; ++i) {
        spc_shape_sample xs, ys;
        spc_vec2 u = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
        spc_shape_sample_area(sc->shapes[cs->idx[i % cs->n]], u, &xs);
        u = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
        spc_vec3 y = e->position;
        if (ls) {
            spc_shape_sample_area(ls, u, &ys);
            if (!(ys.pdf > 0.0))
                continue;
            y = ys.p;
        }
        if (!(xs.pdf > 0.0))
            continue;
        spc_vec3 d = spc_sub(y, xs.p);
        double dist = spc_length(d);
        if (!(dist > 0.0))
            continue;
        d = spc_scale(d, 1.0 / dist);
        spc_hit h;
        memset(&h, 0, sizeof h);
        h.p = xs.p;
        h.ng = xs.n;
        h.err = xs.err;
        spc_ray r = spc_hit_spawn(&h, d);
        if (!ls)
            r.tmax = dist * (1.0 - 1e-6);
        for (int k = 0; k < SPC_SNEE_PLAN_SIGHT_CROSSINGS; ++k) {
            if (!spc_scene_intersect(sc, &r, &h)) {
                if (!ls)
                    return true; /* nothing before the point light */
                break;           /* an area light's point missed (grazing): not counted */
            }
            if (ls && h.shape_index == e->shape_index)
                return true;
            if (!is_caster(cs, h.shape_index))
                break; /* blocked */
            double left = r.tmax - h.t;
            r = spc_hit_spawn(&h, d);
            if (!ls)
                r.tmax = left;
        }
    }
    return false;
}

/* The share of the directions from the casters' centre along which a ray leaves the scene, passing
 * casters and lights but no other surface: about 1/2 over an open floor, near 0 in a closed room.
 * 0 where the scene is not finalized. Deterministic. */
static double open_share(const spc_scene *sc, const spc_chain_casters *cs)
{
    if (!sc->finalized)
        return 0.0;
    const int n = SPC_SNEE_PLAN_OPEN_DIRS;
    const double golden = SPC_PI * (3.0 - sqrt(5.0));
    int open = 0;
    for (int i = 0; i < n; ++i) {
        double z = 1.0 - (2.0 * i + 1.0) / n, r = sqrt(spc_max(0.0, 1.0 - z * z));
        spc_vec3 d = spc_v3(r * cos(golden * i), r * sin(golden * i), z);
        spc_ray ray = {cs->center, d, 0.0, SPC_INF};
        for (int k = 0; k < SPC_SNEE_PLAN_OPEN_PASSES; ++k) {
            spc_hit h;
            if (!spc_scene_intersect(sc, &ray, &h)) {
                ++open;
                break;
            }
            if (!h.emitter && !is_caster(cs, h.shape_index))
                break;
            ray = spc_hit_spawn(&h, d);
        }
    }
    return (double)open / n;
}

/* Flat faces: a disk, or a mesh without vertex normals (a cube, a rectangle, face_normals). */
static bool flat(const spc_shape *s)
{
    return s->type == SPC_SHAPE_DISK || (s->type == SPC_SHAPE_MESH && (s->face_normals || !s->mesh.n));
}

static int edge_cmp(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Is s a closed triangle mesh: every edge (a pair of vertex indices) shared by exactly two
 * triangles? A mesh whose vertices are split along seams reads as open (false), as does one whose
 * edge list cannot be allocated. */
static bool closed_mesh(const spc_shape *s)
{
    if (s->type != SPC_SHAPE_MESH || s->mesh.ntris == 0 || !s->mesh.idx)
        return false;
    size_t n = 3 * s->mesh.ntris;
    uint64_t *e = malloc(n * sizeof *e);
    if (!e)
        return false;
    for (size_t t = 0; t < s->mesh.ntris; ++t)
        for (int k = 0; k < 3; ++k) {
            uint64_t a = s->mesh.idx[3 * t + k], b = s->mesh.idx[3 * t + (k + 1) % 3];
            e[3 * t + k] = a < b ? a << 32 | b : b << 32 | a;
        }
    qsort(e, n, sizeof *e, edge_cmp);
    bool closed = true;
    for (size_t i = 0; i < n && closed;) {
        size_t j = i;
        while (j < n && e[j] == e[i])
            ++j;
        closed = j - i == 2;
        i = j;
    }
    free(e);
    return closed;
}

/* Pinhole rays per side of the grid glass_image_share traces: 32 x 32 rays (a few ms at load) find
 * a caster that covers 1/1000 of the image. */
#define SPC_SNEE_PLAN_SHARE_GRID 32

/* The share of the image whose camera ray meets a glass caster first: pinhole rays through the
 * centres of a grid of SPC_SNEE_PLAN_SHARE_GRID^2 cells of the scene's film. 1 where that cannot
 * be traced (the scene not finalized, a camera that does not prepare). Deterministic. */
static double caster_image_share(const spc_scene *sc, const spc_chain_casters *cs, bool glass);

static double glass_image_share(const spc_scene *sc, const spc_chain_casters *cs)
{
    return caster_image_share(sc, cs, true);
}

/* The share of the image whose camera ray meets first a caster of the kind asked: glass (a
 * dielectric interface) or a mirror. */
static double caster_image_share(const spc_scene *sc, const spc_chain_casters *cs, bool glass)
{
    spc_camera_state cam;
    if (!sc->finalized || !spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height))
        return 1.0;
    const int g = SPC_SNEE_PLAN_SHARE_GRID;
    int seen = 0;
    for (int j = 0; j < g; ++j)
        for (int i = 0; i < g; ++i) {
            spc_ray r = spc_camera_ray(&cam, (i + 0.5) * cam.width / g, (j + 0.5) * cam.height / g);
            spc_hit h;
            if (!spc_scene_intersect(sc, &r, &h))
                continue;
            double eta = 0.0;
            seen += is_caster(cs, h.shape_index) && h.shape &&
                    (spc_bsdf_is_specular_interface(h.shape->bsdf, &eta) && eta > 0.0) == glass;
        }
    return (double)seen / (g * g);
}

/* The caustic pilot (caustic_gain): pinhole rays through the centres of a grid of this many cells
 * a side of the film, followed through the glass casters to the receiver they reach, each joined
 * by straight segments to this many points a side of a stratified grid on every area light. */
#define SPC_SNEE_PLAN_CAUSTIC_GRID 32
#define SPC_SNEE_PLAN_CAUSTIC_LIGHT_GRID 4
/* Specular vertices a pinhole ray of the caustic pilot passes before it is dropped. */
#define SPC_SNEE_PLAN_CAUSTIC_BOUNCES 8

/* The direction a ray along d leaves the specular caster hit h by: refracted by the glass's eta
 * (reflected where it cannot: total internal reflection), reflected off a mirror (eta 0), about
 * the shading normal. The pilot follows the refracted branch, which carries most of the light. */
static spc_vec3 pilot_continue(const spc_hit *h, spc_vec3 d, double eta)
{
    spc_vec3 wi = spc_neg(d), n = h->sh.n;
    double c = spc_dot(wi, n);
    if (c < 0.0) {
        n = spc_neg(n);
        c = -c;
        eta = eta > 0.0 ? 1.0 / eta : 0.0;
    }
    double s2 = eta > 0.0 ? (1.0 - c * c) / (eta * eta) : 1.0;
    if (s2 >= 1.0)
        return spc_reflect(wi, n);
    return spc_normalize(spc_add(spc_scale(wi, -1.0 / eta), spc_scale(n, c / eta - sqrt(1.0 - s2))));
}

/* Does the segment from the receiver hit x toward the point y of the area light e reach it, and
 * through some caster (*through)? Casters are passed straight (the segment stands for the chain
 * that bends through them), any other surface blocks. */
static bool pilot_reaches(const spc_scene *sc, const spc_chain_casters *cs, const spc_hit *x, const spc_emitter *e,
                          spc_vec3 d, bool *through)
{
    spc_ray r = spc_hit_spawn(x, d);
    spc_hit h;
    *through = false;
    for (int k = 0; k < SPC_SNEE_PLAN_SIGHT_CROSSINGS; ++k) {
        if (!spc_scene_intersect(sc, &r, &h))
            return false;
        if (h.shape_index == e->shape_index)
            return true;
        if (!is_caster(cs, h.shape_index))
            return false;
        *through = true;
        r = spc_hit_spawn(&h, d);
    }
    return false;
}

/* none's relative variance per camera sample from the area lights' caustics, averaged over the
 * image, as the caustic pilot predicts it. Each pinhole ray of a grid (SPC_SNEE_PLAN_CAUSTIC_GRID)
 * is followed through the casters to its receiver x; each area light's points of a stratified grid
 * are joined to x by straight segments: a segment that reaches the light through a caster stands
 * for a caustic chain (glass moves the light it passes, it does not create it: the caustic's
 * irradiance summed over the shadow it falls in is about the irradiance that segment carries), one
 * that reaches it directly for direct light. For light l, C_l is the caustic irradiance at x and
 * P_l = Omega_l cos / pi the chance that x's cosine-weighted BSDF sample (none's only way to the
 * light through glass) meets the part of the light seen through the casters; the pixel's relative
 * variance is sum_l C_l^2 / P_l over (D + sum_l C_l)^2, D the direct irradiance. Pixels that see no
 * receiver count 0 (the image mean). Only where every light specular NEE draws is an area light
 * (point lights' caustics are none's bias, not its variance) and every caster is glass (a
 * mirror's caustic falls outside its shadow): -1 otherwise, or where the camera does not prepare.
 * The sky is left out of D (it makes the gain look larger, never smaller). Deterministic. */
static double caustic_gain(const spc_scene *sc, const spc_chain_casters *cs)
{
    spc_camera_state cam;
    if (!sc->finalized || !spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height))
        return -1.0;
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        if (snee_light(e) && (e->type != SPC_EMITTER_AREA || e->shape_index < 0 || e->shape_index >= sc->nshapes))
            return -1.0;
    }
    for (int i = 0; i < cs->n; ++i) {
        double eta = 0.0;
        if (!(spc_bsdf_is_specular_interface(sc->shapes[cs->idx[i]]->bsdf, &eta) && eta > 0.0))
            return -1.0;
    }
    const int g = SPC_SNEE_PLAN_CAUSTIC_GRID, m = SPC_SNEE_PLAN_CAUSTIC_LIGHT_GRID;
    double sum = 0.0;
    for (int j = 0; j < g; ++j)
        for (int i = 0; i < g; ++i) {
            spc_ray r = spc_camera_ray(&cam, (i + 0.5) * cam.width / g, (j + 0.5) * cam.height / g);
            spc_hit x;
            bool found = false;
            for (int k = 0; k < SPC_SNEE_PLAN_CAUSTIC_BOUNCES; ++k) {
                if (!spc_scene_intersect(sc, &r, &x) || x.emitter || !x.shape)
                    break;
                if (!is_caster(cs, x.shape_index)) {
                    found = receiver(x.shape);
                    break;
                }
                double eta = 0.0;
                spc_bsdf_is_specular_interface(x.shape->bsdf, &eta);
                r = spc_hit_spawn(&x, pilot_continue(&x, r.d, eta));
            }
            if (!found)
                continue;
            spc_vec3 nx = spc_dot(x.sh.n, r.d) > 0.0 ? spc_neg(x.sh.n) : x.sh.n;
            double direct = 0.0, caustic = 0.0, var = 0.0;
            for (int l = 0; l < sc->nemitters; ++l) {
                const spc_emitter *e = sc->emitters[l];
                if (!snee_light(e))
                    continue;
                const spc_shape *ls = sc->shapes[e->shape_index];
                double radiance = ls->area > 0.0 ? e->power / (SPC_PI * ls->area) : 0.0;
                double c_l = 0.0, p_l = 0.0;
                for (int b = 0; b < m * m; ++b) {
                    spc_shape_sample ys;
                    spc_shape_sample_area(ls, spc_v2((b % m + 0.5) / m, (b / m + 0.5) / m), &ys);
                    spc_vec3 d = spc_sub(ys.p, x.p);
                    double d2 = spc_dot(d, d);
                    if (!(ys.pdf > 0.0) || !(d2 > 0.0))
                        continue;
                    d = spc_scale(d, 1.0 / sqrt(d2));
                    double cx = spc_dot(nx, d), cy = -spc_dot(ys.n, d);
                    bool through;
                    if (!(cx > 0.0) || !(cy > 0.0) || !pilot_reaches(sc, cs, &x, e, d, &through))
                        continue;
                    double omega = cy / (ys.pdf * d2 * (m * m)); /* this point's share of the light's solid angle */
                    if (through) {
                        c_l += radiance * cx * omega;
                        p_l += cx * omega / SPC_PI;
                    } else
                        direct += radiance * cx * omega;
                }
                if (c_l > 0.0 && p_l > 0.0) {
                    caustic += c_l;
                    var += c_l * c_l / p_l;
                }
            }
            double v = direct + caustic;
            if (v > 0.0)
                sum += var / (v * v);
        }
    return sum / (g * g);
}

/* The query from the camera is made in a fraction Q of the camera samples where every glass caster
 * is enumerated exactly (snee_plan.h), Q = sqrt(s) / 10 for glass on a share s of the image, but
 * up to sqrt(s) where that leaves fewer than PASS queries a pass on the scene's film, at least
 * MIN, and in every sample from ALL up. The query's splats from every camera sample pool on the
 * few pixels that see the light in or through the glass: at Q = sqrt(s) they held 0.0-0.1% of the
 * variance on the glass sphere and the demo while the query took 42% and 19% of the CPU, and at equal
 * CPU time Q = sqrt(s) / 10 lowered relMSE on the glass sphere, the demo, the pool and dielectrics
 * (bench/RESULTS.md, "Fold 6"). On a small film the light's images through glass are a pixel or
 * less, which camera rays hit as fireflies unless the query takes them (test_snee_plan's
 * default_has_no_fireflies_through_glass, 16 x 16: the image means' scatter over seeds 1.2% at
 * Q = sqrt(s), 14% at sqrt(s) / 10; 2.8% at sqrt(s) / 10 on 64 x 64). */
#define SPC_SNEE_PLAN_CAMERA_SCALE 0.1
#define SPC_SNEE_PLAN_CAMERA_MIN 0.02
/* bdpt's Q = SCALE_BDPT sqrt(s) (camera_prob_bdpt). On the glass-ball caustic at 32 x 32 (s = 0.09)
 * 0.17 gives Q = 0.05, where 0.1 gave 0.03: with bdpt's rim receivers' four light points
 * (reflected_samples) the one sample left that held over a quarter of a seed's error was s = 0
 * reaching the light through the ball (seed 14: 27-31% over four 16-seed runs at 0.03, 6.8-7.6%
 * at 0.05, every seed's worst pixel at most 21.3%), for 2% more mean relMSE at equal CPU over 16
 * seeds; on the demo, the glass sphere and dielectrics (32 x 32, 64 spp, 8 seeds, one thread) 0.17
 * against 0.1 was 1.00x, 1.06x and 0.99x at equal CPU (bench/RESULTS.md, part bcaus13). */
#define SPC_SNEE_PLAN_CAMERA_SCALE_BDPT 0.17
#define SPC_SNEE_PLAN_CAMERA_PASS 100.0
#define SPC_SNEE_PLAN_CAMERA_ALL 0.95

/* Do the pinhole o and every light specular NEE draws on (an area light's bounding box whole) lie
 * strictly on one side of the plane through q with normal n? */
static bool lights_on_side(const spc_scene *sc, spc_vec3 o, spc_vec3 q, spc_vec3 n)
{
    double side = spc_dot(spc_sub(o, q), n);
    if (side == 0.0)
        return false;
    for (int k = 0; k < sc->nemitters; ++k) {
        const spc_emitter *e = sc->emitters[k];
        if (!snee_light(e))
            continue;
        if (e->type != SPC_EMITTER_AREA) {
            if (!(side * spc_dot(spc_sub(e->position, q), n) > 0.0))
                return false;
            continue;
        }
        if (e->shape_index < 0 || e->shape_index >= sc->nshapes)
            return false;
        const spc_shape *ls = sc->shapes[e->shape_index];
        for (int c = 0; c < 8; ++c) {
            spc_vec3 b = spc_v3(c & 1 ? ls->bbox_max.x : ls->bbox_min.x, c & 2 ? ls->bbox_max.y : ls->bbox_min.y,
                                c & 4 ? ls->bbox_max.z : ls->bbox_min.z);
            if (!(side * spc_dot(spc_sub(b, q), n) > 0.0))
                return false;
        }
    }
    return true;
}

/* A glass triangle mesh that the randomized solver serves with the pinhole and the lights on one
 * side of each of its triangles' planes (lights_on_side): an open sheet the camera and the lights
 * see from one side only (a water surface made of triangles). */
static bool mesh_sheet_faces_lights(const spc_scene *sc, const spc_shape *s, spc_vec3 o)
{
    const spc_mesh *m = &s->mesh;
    if (m->ntris < 1)
        return false;
    for (size_t t = 0; t < m->ntris; ++t) {
        const float *a = m->p + 3 * m->idx[3 * t], *b = m->p + 3 * m->idx[3 * t + 1], *c = m->p + 3 * m->idx[3 * t + 2];
        spc_vec3 pa = spc_v3(a[0], a[1], a[2]), pb = spc_v3(b[0], b[1], b[2]), pc = spc_v3(c[0], c[1], c[2]);
        spc_vec3 n = spc_cross(spc_sub(pb, pa), spc_sub(pc, pa));
        if (!(spc_length(n) > 0.0) || !lights_on_side(sc, o, pa, n))
            return false;
    }
    return true;
}

/* Are the chains from the camera to a light through one caster reflections off glass, which the
 * path tracer splits at every camera sample (SPC_SNEE_PLAN_SETTING_WATER)? Every caster is a glass
 * normal-mapped plane, or a glass triangle mesh the randomized solver serves, and the pinhole and
 * every light specular NEE draws on lie strictly on one side of each plane (of each triangle's
 * plane; an area light's bounding box whole): a path that refracts through a plane stays on its far
 * side unless another caster turns it back. False where it cannot tell (the camera does not
 * prepare, a plane's frame is not found). Only the choice of the query: without it the other
 * strategies' MIS weights still sum to one. */
/* Is s a glass triangle mesh (a specular interface with vertices)? */
static bool glass_mesh(const spc_shape *s)
{
    double eta = 0.0;
    return spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0 && s->type == SPC_SHAPE_MESH &&
           s->mesh.nverts > 0;
}

/* The plane of a glass normal-mapped plane s: a point o on it (its first vertex) and the frame whose
 * third axis is the model's normal; false where s is not a glass mesh or the frame is not found. */
static bool glass_plane_frame(const spc_shape *s, spc_vec3 *o, spc_vec3 frame[3])
{
    double m[3];
    if (!glass_mesh(s))
        return false;
    *o = spc_v3(s->mesh.p[0], s->mesh.p[1], s->mesh.p[2]);
    return spc_plane_chain_model_normal(s, *o, m, frame);
}

static bool camera_chains_split(const spc_scene *sc, const spc_chain_casters *cs, const spc_snee_params *p)
{
    spc_camera_state cam;
    if (!sc->finalized || !spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height))
        return false;
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        spc_vec3 o, frame[3];
        if (!glass_mesh(s))
            return false;
        if (spc_snee_plan_method(p, s) == SPC_SNEE_METHOD_SOLVER) {
            if (!mesh_sheet_faces_lights(sc, s, cam.origin))
                return false;
            continue;
        }
        if (spc_snee_plan_method(p, s) != SPC_SNEE_METHOD_PLANE)
            return false;
        if (!glass_plane_frame(s, &o, frame) || !lights_on_side(sc, cam.origin, o, frame[2]))
            return false;
    }
    return cs->n > 0;
}

/* Is the pinhole under the water: every caster a glass normal-mapped plane whose chains
 * plane_chains.h enumerates (water_planes_only), with the pinhole strictly on one side of each plane
 * and every light specular NEE draws on (an area light's bounding box whole) strictly on the other?
 * Then the light reaches the receivers the camera sees through one crossing of the water, light
 * tracing's subpaths join them without crossing back (integrator/path_lt.c, plane_flux_value), and
 * the chains from the camera are refractions toward the light, which no split traces. False where
 * it cannot tell (the camera does not prepare, a plane's frame is not found). */
static bool camera_under_water(const spc_scene *sc, const spc_chain_casters *cs, const spc_snee_params *p)
{
    spc_camera_state cam;
    if (!water_planes_only(sc, cs, p) || !sc->finalized ||
        !spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height))
        return false;
    for (int i = 0; i < cs->n; ++i) {
        spc_vec3 o, frame[3];
        if (!glass_plane_frame(sc->shapes[cs->idx[i]], &o, frame))
            return false;
        /* the pinhole mirrored in the plane: the lights on its side are on the far side of the
         * pinhole's */
        spc_vec3 n = frame[2];
        double side = spc_dot(spc_sub(cam.origin, o), n) / spc_dot(n, n);
        spc_vec3 mirrored = spc_sub(cam.origin, spc_scale(n, 2.0 * side));
        if (side == 0.0 || !lights_on_side(sc, mirrored, o, n))
            return false;
    }
    return cs->n > 0;
}

/* The face sequences the flat enumeration solves per query (chains of 1 to 5 vertices, reflections
 * off glass included; counted by spc_flat_chain_sequences, not solved) from the receivers that
 * pinhole rays through a grid of SPC_SNEE_PLAN_FLAT_PILOT_GRID^2 cells of the film hit first, to
 * the point y; -1 where nothing can be traced (the scene not finalized, a camera that does not
 * prepare, no receiver seen). Deterministic. */
static double flat_sequences_per_query(const spc_scene *sc, spc_vec3 y)
{
    spc_camera_state cam;
    if (!sc->finalized || !spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height))
        return -1.0;
    const int g = SPC_SNEE_PLAN_FLAT_PILOT_GRID;
    long sequences = 0;
    int queries = 0;
    for (int j = 0; j < g; ++j)
        for (int i = 0; i < g; ++i) {
            spc_ray r = spc_camera_ray(&cam, (i + 0.5) * cam.width / g, (j + 0.5) * cam.height / g);
            spc_hit h;
            if (!spc_scene_intersect(sc, &r, &h) || !h.shape || h.emitter || !receiver(h.shape) ||
                spc_flat_chain_shape(h.shape))
                continue;
            spc_vec3 x = spc_hit_offset(&h, spc_neg(r.d));
            for (int k = 1; k <= 5; ++k)
                sequences += spc_flat_chain_sequences(sc, false, true, x, y, k);
            ++queries;
        }
    return queries > 0 ? (double)sequences / queries : -1.0;
}

/* bdpt's query from the camera where every glass caster is enumerated exactly: Q = SCALE_BDPT
 * sqrt(s) (0.17 sqrt(s)), at least MIN, without path's raise on small films. bdpt's query competes with s = 0 alone (light
 * tracing cannot reach the light through glass either), as path's with BSDF sampling, but its
 * samples cost more, so the query's share of their time is smaller for the same Q; on the glass-ball
 * caustic (32 x 32, where path's rule gives 0.098) Q from 0.003 to 0.03 was 1.1x better at equal CPU
 * time than 0.1 over 8 seeds, the worst pixel's share the same (bench/RESULTS.md, part caustic7 and
 * part bcaus12), and bench/check/ball_small_light.xml at 16 x 16 (the small film where path's
 * fireflies through glass need the raise) 1.09x better at 0.03 than at 0.1, its image means'
 * scatter over 8 seeds 0.60% and 0.55%: bdpt's fireflies through glass do not come back. */
static double camera_prob_bdpt(double s)
{
    return spc_max(SPC_SNEE_PLAN_CAMERA_MIN, SPC_SNEE_PLAN_CAMERA_SCALE_BDPT * sqrt(s));
}

/* The query from the camera's probability (above) for glass on a share s of the image. */
static double camera_prob(const spc_scene *sc, double s)
{
    double pixels = (double)sc->film.width * (double)sc->film.height;
    double small = pixels > 0.0 ? spc_min(sqrt(s), SPC_SNEE_PLAN_CAMERA_PASS / pixels) : sqrt(s);
    return spc_max(SPC_SNEE_PLAN_CAMERA_MIN, spc_max(SPC_SNEE_PLAN_CAMERA_SCALE * sqrt(s), small));
}

/* The camera query's pilot (camera_finds_light): queries from the pinhole with the plan's setting,
 * each toward a light point of its own, from one fixed stream. A light whose image through the
 * glass lands in view from a share f of its points is missed with probability (1 - f)^1024 (0.6% at
 * f = 0.005); the queries take a few milliseconds on the slab scenes (`specula info` 0.01 s). */
#define SPC_SNEE_PLAN_CAMERA_PILOT 1024

/* Does the query from the camera (params.camera) find any chain to a light that lands on the film?
 * SPC_SNEE_PLAN_CAMERA_PILOT queries as the render makes them (spc_snee_camera, on every call, the
 * scene's chain budget), counting the contributions that are not zero; the number found is written
 * to *found. Where none is found the query only costs: the paths it covers (the light seen through
 * or reflected in the glass) are then not in view, and BSDF sampling and the camera rays weigh the
 * same paths by 1 where the query is off, so leaving it out changes no image but by the rare chain
 * the pilot missed. */
static bool camera_finds_light(const spc_scene *sc, const char *setting, int *found)
{
    *found = 0;
    int max_chain = sc->integrator.specular_max_chain > 0 ? sc->integrator.specular_max_chain : 2;
    spc_snee_params p;
    spc_camera_state cam;
    if (!spc_snee_parse(setting, max_chain, &p) || !p.camera ||
        !spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height))
        return true; /* not known: kept */
    p.camera_p = 1.0;
    int budget = max_chain < p.max_chain ? max_chain : p.max_chain;
    int long_max = sc->integrator.max_depth >= 0 ? sc->integrator.max_depth - 1 : SPC_CHAIN_MAX_VERTICES;
    spc_rng rng;
    spc_rng_seed(&rng, 0x5eed0ca3e7aULL, 7);
    for (int i = 0; i < SPC_SNEE_PLAN_CAMERA_PILOT; ++i) {
        spc_snee_splat sp[SPC_SNEE_CAMERA_SPLATS];
        int n = spc_snee_camera(sc, &p, &cam, 1.0, budget, long_max, &rng, NULL, sp, SPC_SNEE_CAMERA_SPLATS);
        for (int j = 0; j < n; ++j)
            if (sp[j].value.r > 0.0 || sp[j].value.g > 0.0 || sp[j].value.b > 0.0)
                ++*found;
    }
    return *found > 0;
}

/* The setting without its "camera=Q," (or "camera,") option. */
static void drop_camera(char *setting)
{
    char *c = strstr(setting, "camera");
    if (!c || (c != setting && c[-1] != ':' && c[-1] != ','))
        return;
    char *end = c + strlen("camera");
    if (*end == '=')
        end += strcspn(end, ",");
    if (*end == ',')
        ++end;
    else if (c[-1] == ',')
        --c; /* the last option: its comma before it goes */
    memmove(c, end, strlen(end) + 1);
}

static void off(spc_snee_plan *out, const char *why)
{
    out->on = false;
    snprintf(out->setting, sizeof out->setting, "none");
    snprintf(out->reason, sizeof out->reason, "%s", why);
}

/* Specular NEE is left off where the caustic pilot finds no caustic on the image (caustic_gain 0: no
 * pinhole ray of its grid, through the glass or not, reaches a receiver lit through a caster), for
 * path, every light it draws an area light, every caster flat-faced glass (slabs, panes, cubes:
 * enumerated by flat_chains.h) and the casters open to the sky in at least SPC_SNEE_PLAN_ROOM_OPEN
 * of their directions (in a room a caustic out of view still lights the walls in view). There the
 * query buys nothing in view but the light seen through or in the glass, an image of the light's
 * own size behind flat faces, which camera rays find as they find the light itself, while the
 * flat enumeration costs about ten of none's samples per sample: random scene 9299 (a glass slab
 * whose caustic falls outside the image) at equal CPU time 0.04x none over 16 seeds
 * (bench/RESULTS.md, "No caustic in view"). Curved glass is left to the other rules: its images of
 * a light are small and bright, the camera query's to find. Where a caustic is in view, however
 * faint, the plan stays: random scene 435 (a slab, caustic_gain 1.9) gains 18-37x. Returns true
 * (and sets out off) where the rule turns specular NEE off; out->caustic_gain records the pilot's
 * value where it ran. */
static bool caustic_out_of_view(const spc_scene *sc, const spc_chain_casters *cs, const char *integrator,
                                spc_snee_plan *out)
{
    if (strcmp(integrator, "path"))
        return false;
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        if (!spc_flat_chain_shape(s) || !(spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0))
            return false;
    }
    out->caustic_gain = caustic_gain(sc, cs);
    if (out->caustic_gain != 0.0 || open_share(sc, cs) < SPC_SNEE_PLAN_ROOM_OPEN)
        return false;
    off(out, "no caustic in view: the caustic pilot found no receiver in view lit through the glass");
    return true;
}

void spc_snee_plan_make(const spc_scene *sc, const char *integrator, const char *setting, spc_snee_plan *out)
{
    memset(out, 0, sizeof *out);
    out->caustic_gain = -1.0;
    out->camera_pilot = -1;
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
    bool lit = false, seen = false;
    spc_vec3 smallest = spc_v3(0, 0, 0); /* the centre of the smallest light seen */
    out->light_sr = 0.0;
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        if (!snee_light(e))
            continue;
        lit = true;
        if (!light_seen(e, i, sc, cs))
            continue; /* no chain can end on it: left out of the rules below */
        double sr = e->type == SPC_EMITTER_AREA && e->shape_index >= 0 && e->shape_index < sc->nshapes
                        ? light_solid_angle(sc->shapes[e->shape_index], cs->center)
                        : 0.0;
        if (!seen || sr < out->light_sr) {
            out->light_sr = sr;
            smallest =
                e->type == SPC_EMITTER_AREA && e->shape_index >= 0 && e->shape_index < sc->nshapes
                    ? spc_scale(spc_add(sc->shapes[e->shape_index]->bbox_min, sc->shapes[e->shape_index]->bbox_max),
                                0.5)
                    : e->position;
        }
        double share = caster_share(e, sc, cs);
        if (share > out->caster_share)
            out->caster_share = share;
        seen = true;
    }
    if (!lit) {
        off(out, "no area, point or spot light");
        return;
    }
    if (!seen) {
        off(out, "no light is seen from the casters (a light inside its housing)");
        return;
    }
    /* nflat: the flat-faced glass casters, which the slab rules below are for; a flat mirror
     * (enumerated by flat_chains.h too) is a mirror to them, as a mirror ball is: it guides no
     * light by total internal reflection and holds no longer chains of its own, and the slab
     * settings' longer chains, queries at every first receiver and light tracing only cost there
     * (bench/RESULTS.md, "Flat mirrors enumerated exactly": 0.3x none on a glass ball resting on
     * a flat mirror with them, 1.7x without) */
    int nflat = 0;
    bool mirror = false;
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        bool glass = spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0;
        nflat += glass && spc_flat_chain_shape(s) ? 1 : 0; /* the others: below */
        mirror = mirror || !glass;
    }
    /* flat-faced casters under a light larger than the flat rule's (beside glass or mirrors): on,
     * with their longer chains, where the enumeration's cost pays (the pilot) */
    bool flat_long = false;
    double flat_cost_limit = nflat == cs->n ? SPC_SNEE_PLAN_FLAT_ALONE_COST_SR
                             : mirror       ? SPC_SNEE_PLAN_FLAT_MIRROR_COST_SR
                                            : SPC_SNEE_PLAN_FLAT_COST_SR;
    if (nflat > 0 && !strcmp(integrator, "path") && out->light_sr > SPC_SNEE_PLAN_FLAT_MAX_SR &&
        out->light_sr <= SPC_SNEE_PLAN_FLAT_LONG_MAX_SR) {
        out->flat_sequences = flat_sequences_per_query(sc, smallest);
        flat_long = out->flat_sequences >= 0.0 && out->flat_sequences * out->light_sr <= flat_cost_limit;
    }
    const bool flat_large = flat_large_lights(sc, cs, nflat, mirror, integrator, out->light_sr, out->caster_share);
    if (nflat > 0 && out->light_sr > SPC_SNEE_PLAN_FLAT_MAX_SR && !flat_long && !flat_large) {
        if (out->flat_sequences > 0.0)
            snprintf(out->reason, sizeof out->reason, "flat-faced casters%s: light %.2g sr x %.3g sequences a query > %g",
                     nflat == cs->n ? " alone" : "", out->light_sr, out->flat_sequences, flat_cost_limit);
        else
            snprintf(out->reason, sizeof out->reason, "flat-faced casters under a light of %.2g sr (over %g)",
                     out->light_sr, SPC_SNEE_PLAN_FLAT_MAX_SR);
        out->on = false;
        snprintf(out->setting, sizeof out->setting, "none");
        return;
    }
    if (out->light_sr > SPC_SNEE_PLAN_MAX_SR && out->caster_share < SPC_SNEE_PLAN_MIN_SHARE && !flat_large) {
        snprintf(out->reason, sizeof out->reason, "every light is large: %.2g sr from the casters (share %.2g)",
                 out->light_sr, out->caster_share);
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
    /* not with an SDF caster whose surface has creases (a box's edges, a CSG cut: spc_sdf_has_creases):
     * near a crease the randomized attempts' solve probability is tiny, so the Bernoulli trial
     * counts have a heavy tail that BSDF sampling's MIS does not bound (scenes/sdf_shapes_csg.xml,
     * a glass box minus a sphere: bench/RESULTS.md, "CSG: the plan") */
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        if (s->type == SPC_SHAPE_SDF && s->sdf && spc_sdf_has_creases(s->sdf)) {
            snprintf(out->reason, sizeof out->reason, "caster shape %d is an SDF with creases", cs->idx[i]);
            out->on = false;
            snprintf(out->setting, sizeof out->setting, "none");
            return;
        }
    }
    /* not with a closed glass mesh that no sphere fits (snee_plan.h): its rarer two-refraction
     * chains' trial counts are the image's fireflies */
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        spc_vec3 c;
        double r;
        if (s->type == SPC_SHAPE_MESH && spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0 &&
            spc_snee_plan_method(&p, s) == SPC_SNEE_METHOD_SOLVER && !spc_fit_sphere(s, &c, &r) && closed_mesh(s)) {
            snprintf(out->reason, sizeof out->reason, "caster shape %d is a closed glass mesh no sphere fits",
                     cs->idx[i]);
            out->on = false;
            snprintf(out->setting, sizeof out->setting, "none");
            return;
        }
    }
    /* the query from the camera only where some caster is glass, by Russian roulette only where
     * every glass caster's chains are enumerated exactly (snee_plan.h) */
    bool glass = false, exact = true, ball = false, cone = false, solved_mirror = false;
    for (int i = 0; i < cs->n; ++i) {
        double eta = 0.0;
        const spc_shape *s = sc->shapes[cs->idx[i]];
        if (!(spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0))
            solved_mirror = solved_mirror || spc_snee_plan_method(&p, s) == SPC_SNEE_METHOD_SOLVER;
        else {
            glass = true;
            spc_vec3 cc;
            double cr;
            cone = cone ||
                   (spc_snee_plan_method(&p, s) == SPC_SNEE_METHOD_SPHERE && spc_cguide_cone_sphere(sc, s, &cc, &cr));
            exact = exact && spc_snee_plan_method(&p, s) != SPC_SNEE_METHOD_SOLVER;
            spc_vec3 c;
            double r;
            ball = ball || (spc_snee_plan_method(&p, s) == SPC_SNEE_METHOD_SOLVER && spc_fit_sphere(s, &c, &r));
        }
    }
    /* volpath: not with tessellated glass balls that sit in a medium (glass_in_medium) */
    if (!strcmp(integrator, "volpath") && ball && glass_in_medium(sc, cs)) {
        off(out, "volpath: the glass balls sit in a medium (most of its light arrives directly)");
        return;
    }
    /* path in the open, glass casters under area lights: not where no caustic falls in view */
    if (caustic_out_of_view(sc, cs, integrator, out))
        return;
    out->on = true;
    out->glass_share = glass ? glass_image_share(sc, cs) : 0.0;
    out->open_share = open_share(sc, cs);
    double q = exact ? camera_prob(sc, out->glass_share) : 1.0;
    /* path, a ball beside a flat mirror: the query from the camera at least as often as
     * SPC_SNEE_PLAN_BALL_FLAT_MIRROR_CAMERA (snee_plan.h) */
    const bool ball_flat_mirror =
        !strcmp(integrator, "path") && exact && !solved_mirror && ball_beside_flat_mirror(sc, cs, &p);
    if (ball_flat_mirror)
        q = spc_max(q, SPC_SNEE_PLAN_BALL_FLAT_MIRROR_CAMERA);
    if (bdpt && glass && exact)
        snprintf(out->setting, sizeof out->setting, "angular:camera=%.2g", camera_prob_bdpt(out->glass_share));
    else if (bdpt)
        snprintf(out->setting, sizeof out->setting, "%s",
                 glass ? SPC_SNEE_PLAN_SETTING_BDPT : SPC_SNEE_PLAN_SETTING_BDPT_MIRRORS);
    else if (!glass && solved_mirror)
        snprintf(out->setting, sizeof out->setting, "%s", SPC_SNEE_PLAN_SETTING_SOLVED_MIRRORS);
    else if (!glass) {
        /* mirrors enumerated exactly: the query from the camera by roulette, as for glass, with
         * the share of the image that sees a mirror first (SPC_SNEE_PLAN_SETTING_MIRRORS) */
        double qm = camera_prob(sc, caster_image_share(sc, cs, false));
        if (ball_flat_mirror)
            qm = spc_max(qm, SPC_SNEE_PLAN_BALL_FLAT_MIRROR_CAMERA);
        if (qm < SPC_SNEE_PLAN_CAMERA_ALL)
            snprintf(out->setting, sizeof out->setting, "angular:camera=%.2g,%s", qm, SPC_SNEE_PLAN_SETTING_MIRRORS);
        else
            snprintf(out->setting, sizeof out->setting, "angular:camera,%s", SPC_SNEE_PLAN_SETTING_MIRRORS);
    }
    else if (ball)
        snprintf(out->setting, sizeof out->setting, "%s",
                 strcmp(integrator, "volpath") ? SPC_SNEE_PLAN_SETTING_BALLS : SPC_SNEE_PLAN_SETTING_BALLS_VOLPATH);
    else if (!strcmp(integrator, "path") && camera_chains_split(sc, cs, &p))
        snprintf(out->setting, sizeof out->setting, "%s", SPC_SNEE_PLAN_SETTING_WATER);
    else if (!strcmp(integrator, "path") && camera_under_water(sc, cs, &p) && small_area_lights(sc, cs))
        snprintf(out->setting, sizeof out->setting, "%s", SPC_SNEE_PLAN_SETTING_UNDER_WATER);
    else if (q < SPC_SNEE_PLAN_CAMERA_ALL)
        snprintf(out->setting, sizeof out->setting, "angular:camera=%.2g,first=0.1,later=0.1", q);
    else
        snprintf(out->setting, sizeof out->setting, "%s", SPC_SNEE_PLAN_SETTING);
    /* path in a room: caustic guiding at receivers, with a cone toward each glass ball, and the
     * longer chains more often (snee_plan.h) */
    if (!strcmp(integrator, "path") && glass && cone && out->open_share < SPC_SNEE_PLAN_ROOM_OPEN) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_ROOM_GLASS_BALL);
    }
    /* path over water planes alone under small area lights: the caustic on the floor also by light
     * tracing through the water (snee_plan.h, SPC_SNEE_PLAN_WATER_LT) */
    if (!strcmp(integrator, "path") && !strcmp(out->setting, SPC_SNEE_PLAN_SETTING_WATER) &&
        water_planes_only(sc, cs, &p) && small_area_lights(sc, cs)) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_WATER_LT);
    }
    /* path lit by point lights (a sky besides), with a glass sphere among the casters: the point
     * lights' caustics also by light tracing (snee_plan.h, SPC_SNEE_PLAN_POINT_LIGHTS) */
    if (!strcmp(integrator, "path") && glass && exact && point_lights_sky(sc) && glass_sphere(sc, cs)) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_POINT_LIGHTS);
    }
    /* the same with small area lights, where no caustic guide runs at receivers (the light
     * tracing of area lights does not run with it: integrator/path_lt.h) */
    else if (!strcmp(integrator, "path") && glass && exact && !strstr(out->setting, "recguide") &&
             glass_sphere(sc, cs) && small_area_lights(sc, cs)) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_AREA_LIGHTS);
    }
    /* path lit by point lights (a sky besides), with a tessellated glass ball among the casters: the
     * ball's point-light chains by light tracing too, joined to the pinhole through the ball as well,
     * weighed against specular NEE's unbiased count of them (path_lt.h; snee_plan.h,
     * SPC_SNEE_PLAN_BALL_POINT_LIGHTS) */
    else if (!strcmp(integrator, "path") && glass && ball && !strstr(out->setting, "recguide") &&
             point_lights_sky(sc)) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_BALL_POINT_LIGHTS);
    }
    /* and with a tessellated glass ball among the casters: light tracing's ratio for an area light
     * is against BSDF sampling alone, so the ball's chains need no exact count (path_lt.h) */
    else if (!strcmp(integrator, "path") && glass && ball && !strstr(out->setting, "recguide") &&
             small_area_lights(sc, cs)) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_AREA_LIGHTS);
    }
    /* a glass SDF under small area lights: the light guides' long chains also by light tracing, the
     * light seen through it and the light guides and caustics seen behind it by the camera-side
     * split, and its caustics by light tracing too (snee_plan.h, SPC_SNEE_PLAN_LIGHT_GUIDES,
     * SPC_SNEE_PLAN_CAMERA_SPLIT, SPC_SNEE_PLAN_CAMERA_RECV, SPC_SNEE_PLAN_SDF_LT; ltcaus where no
     * other rule added it), and the light seen through it after reflections inside it by specular NEE
     * from the pinhole too (SPC_SNEE_PLAN_CAMERA_LONG) */
    if (!strcmp(integrator, "path") && glass && !strstr(out->setting, "recguide") && glass_sdf(sc, cs) &&
        small_area_lights(sc, cs)) {
        bool lt = strstr(out->setting, "ltcaus") != NULL;
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s%s%s%s%s", SPC_SNEE_PLAN_LIGHT_GUIDES,
                 SPC_SNEE_PLAN_CAMERA_SPLIT, SPC_SNEE_PLAN_CAMERA_RECV, lt ? "" : SPC_SNEE_PLAN_SDF_LT,
                 SPC_SNEE_PLAN_CAMERA_LONG);
    }
    /* path where every caster is a flat mirror (flat_chains.h) and the lights are small area lights:
     * the mirrors' caustics also by light tracing (snee_plan.h, SPC_SNEE_PLAN_FLAT_MIRRORS_LT) */
    if (!strcmp(integrator, "path") && !glass && !solved_mirror && flat_mirrors_only(sc, cs) &&
        small_area_lights(sc, cs)) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_FLAT_MIRRORS_LT);
    }
    /* path where every caster is a mirror cylinder (cylinder_chains.h) under small area lights: the
     * caustic on the floor also by light tracing (snee_plan.h, SPC_SNEE_PLAN_CYLINDER_LT) */
    if (!strcmp(integrator, "path") && !glass && !solved_mirror && cylinders_only(sc, cs, &p) &&
        small_area_lights(sc, cs) && !strstr(out->setting, "ltcaus")) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_CYLINDER_LT);
    }
    /* path, a ball enumerated exactly beside a flat mirror: the longer chains more often, where no
     * other rule set them (snee_plan.h) */
    if (ball_flat_mirror && !flat_long && !strstr(out->setting, "long=")) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_BALL_FLAT_MIRROR_LONG);
    }
    /* and where the ball rests on the mirror under a large light the camera-side split, for BSDF
     * sampling's long all-specular chains from the camera to the light (snee_plan.h) */
    if (ball_flat_mirror && out->light_sr > SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT_SR &&
        !strstr(out->setting, "recguide") && !strstr(out->setting, "camsplit") && ball_on_flat_mirror(sc, cs, &p)) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT);
    }
    /* and under small area lights light tracing's joins through the mirror toward the pinhole
     * (snee_plan.h) */
    if (ball_flat_mirror && out->light_sr <= SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT_SR && small_area_lights(sc, cs) &&
        strstr(out->setting, "ltcaus") && !strstr(out->setting, "ltslab") && !strstr(out->setting, "recguide")) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_BALL_FLAT_MIRROR_JOINS);
    }
    /* flat casters under a light past SPC_SNEE_PLAN_FLAT_MAX_SR: their chains of up to 4 vertices at
     * every call and the 5-vertex ones (total internal reflections inside a slab) too, and beside a
     * mirror the query at every first receiver (snee_plan.h) */
    if (flat_long) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s%s", SPC_SNEE_PLAN_FLAT_LONG,
                 mirror ? SPC_SNEE_PLAN_FLAT_MIRROR_FIRST : "");
    }
    if (flat_large && !strstr(out->setting, "recguide")) {
        size_t n = strlen(out->setting);
        const bool deep = sc->integrator.specular_max_chain >= SPC_SNEE_PLAN_FLAT_LARGE_DEEP;
        snprintf(out->setting + n, sizeof out->setting - n, "%s%s",
                 deep ? SPC_SNEE_PLAN_FLAT_LARGE_DEEP_LONG : SPC_SNEE_PLAN_FLAT_LARGE,
                 out->glass_share >= SPC_SNEE_PLAN_FLAT_LARGE_GUIDE_GLASS ? SPC_SNEE_PLAN_FLAT_LARGE_GUIDES : "");
    } else
        flat_light_tracing(sc, cs, nflat, integrator, out);
    flat_point_light_tracing(sc, nflat, integrator, out);
    flat_point_light_joins(sc, cs, nflat, integrator, out);
    point_light_guides(sc, cs, integrator, out);
    /* path, every caster flat glass: the query from the camera only where its pilot finds a light
     * in view (snee_plan.h) */
    if (!strcmp(integrator, "path") && nflat == cs->n && !mirror && strstr(out->setting, "camera") &&
        !camera_finds_light(sc, out->setting, &out->camera_pilot))
        drop_camera(out->setting);
    /* and under sphere lights larger than the small-light rule's, half of their points drawn from
     * the receiver's cone (snee_plan.h) */
    if (!strcmp(integrator, "path") && nflat == cs->n && !mirror && out->light_sr > SPC_SNEE_PLAN_FLAT_MAX_SR &&
        sphere_lights(sc)) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_FLAT_LIGHT_X);
    }
    /* volpath: a share of the random seeds at medium points from the phase function, where some
     * caster's chains go to the randomized attempts (snee_plan.h) */
    if (!strcmp(integrator, "volpath") && (!exact || solved_mirror)) {
        size_t n = strlen(out->setting);
        snprintf(out->setting + n, sizeof out->setting - n, "%s", SPC_SNEE_PLAN_VOLPATH_PHASE_SEEDS);
    }
    out->pilot = spc_snee_setting_pilot(setting);
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
        if (spc_flat_chain_shape(s))
            return SPC_SNEE_METHOD_FLAT;
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
        if (plan->pilot_note[0])
            put(&b, "  %s\n", plan->pilot_note);
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
    if (plan->pilot_note[0])
        put(&b, "  %s\n", plan->pilot_note);
    if (plan->automatic && p.camera)
        put(&b, "  glass seen on %.3g of the image\n", plan->glass_share);
    if (plan->automatic && plan->camera_pilot == 0)
        put(&b, "  no query from the camera: %d pilot queries found no light in view\n", SPC_SNEE_PLAN_CAMERA_PILOT);
    if (plan->automatic && plan->flat_sequences > 0.0)
        put(&b, "  flat enumeration: %.3g face sequences a query (pilot), times the light's solid angle %.3g sr\n",
            plan->flat_sequences, plan->flat_sequences * plan->light_sr);
    if (plan->automatic)
        put(&b, "  open to the sky in %.3g of the directions from the casters\n", plan->open_share);
    if (plan->automatic && plan->caustic_gain >= 0.0)
        put(&b, "  caustic pilot: none's relative variance per sample from the area lights' caustics %.3g\n",
            plan->caustic_gain);
    if (p.first_p < 1.0)
        put(&b, "  at a path's first receiver with probability %g (Russian roulette), up to 1 near the casters\n",
            p.first_p);
    if (p.later_p < 1.0)
        put(&b, "  past a path's first receiver with probability %g (Russian roulette), up to 1 near the casters\n",
            p.later_p);
    if (p.camera && p.camera_p < 1.0)
        put(&b, "  from the camera on a share %g of the samples\n", p.camera_p);
    if (p.light_x > 0.0)
        put(&b, "  a share %g of a sphere light's points drawn in the cone toward it from the receiver\n", p.light_x);
    if (p.seed_guide > 0.0)
        put(&b, "  guided seeds: a share %g of the randomized attempts seeded toward the chains of light paths "
                "traced at render start that land near the receiver\n",
            p.seed_guide);
    if (p.phase_seeds > 0.0)
        put(&b, "  phase seeds: a share %g of the randomized attempts at medium points seeded from the phase function\n",
            p.phase_seeds);
    if (p.recv_guide > 0.0)
        put(&b,
            "  caustic guiding at receivers (path): a share %g of a vertex's directions toward the caustics "
            "a photon pre-pass finds at render start and toward the glass casters their light passed\n",
            p.recv_guide);
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
        case SPC_SNEE_METHOD_FLAT: {
            /* past the budget where the longer chains run: up to SPC_FLAT_EVERY_CALL vertices at every
             * call, 5 and 6 on their shares of the calls (specular_nee.c, flat_max and flat_psi) */
            bool lng = p.long_p > 0.0 && !p.no_mis;
            int every =
                p.max_chain < SPC_FLAT_EVERY_CALL && lng && p.flat34_p >= 1.0 ? SPC_FLAT_EVERY_CALL : p.max_chain;
            if (every > SPC_FLAT_MAX_VERTICES)
                every = SPC_FLAT_MAX_VERTICES;
            put(&b, "every chain through its flat faces (and other flat casters') enumerated exactly, 1-%d vertices",
                every);
            for (int k = every + 1; lng && k <= SPC_FLAT_MAX_VERTICES; ++k) {
                double share = k == 5 ? p.flat5_p : k == 6 ? p.flat6_p : k <= SPC_FLAT_EVERY_CALL ? p.flat34_p : 0.0;
                if (share > 0.0)
                    put(&b, "; %d on a share %g of the calls", k, share);
                else
                    put(&b, "; %d left to BSDF sampling", k);
            }
            if (p.max_chain > SPC_FLAT_MAX_VERTICES)
                put(&b, "; longer chains by %s", solver ? solver->name : "?");
            break;
        }
        case SPC_SNEE_METHOD_SOLVER:
            put(&b, "%s, 1-%d vertices%s", solver ? solver->name : "?", p.max_chain,
                p.biased ? " (biased)" : solver && solver->solve_all ? "" : " (unbiased: Bernoulli trial count)");
            break;
        }
        put(&b, "\n");
    }
    return (int)b.used;
}
