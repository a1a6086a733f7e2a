/*
 * tests/test_snee_plan.c: specular NEE by default (manifold/snee_plan.h).
 *
 * - The plan: on (angular) for path and volpath on a scene with a caster, a receiver and an area
 *   light; off without casters, with a flat-faced caster no enumeration covers (a glass disk),
 *   with a glass pane under a light too large for flat glass (its chains enumerated, flat_chains.h),
 *   with ipt, with
 *   only an environment light, and when the setting says none or off; an explicit setting is kept;
 *   flat mirrors enumerated through their faces with the mirrors' setting (no slab rules);
 *   without the query from the camera where every caster is a mirror, and with it in a fraction
 *   sqrt(s) of the camera samples where glass covers a share s of the image (an analytic share)
 *   and every glass caster is enumerated exactly (in every sample for an SDF ball);
 *   on with a large light whose
 *   every direction meets a caster (a lamp in a glass globe), where it agrees with none. What ran is recorded in the render's
 *   stats and the film (EXR header), and `spc_scene_plan` lists every caster with its method.
 * - The XML property: auto and off are accepted, a misspelling is refused with file and line.
 * - The default's estimator agrees with specular NEE off: a glass ball's caustic under a large
 *   sphere light, per-pixel z-test (Sidak) and image means.
 * - The demo (scenes/demo.xml) renders with the plan on, and agrees with the query made at every
 *   receiver (later=1).
 * - The glass ball under a small sphere light with no sky (every light path to the floor below
 *   the ball passes the glass; the case where the default was once suspected of a bias): the
 *   default against bdpt, per-pixel z-test and image means.
 * - No fireflies where the camera sees a small light in and through a glass ball: the default's
 *   image means over seeds scatter little where camera rays alone find the light's images rarely.
 * - bdpt's default: its own setting from the same rules, and its estimator against bdpt without
 *   specular NEE (per-pixel z-test and image means).
 * - Random caustic scene 2's ball and light at max_depth 4 (chains of one and two vertices at the
 *   first receiver): specular NEE with reflections off glass against bdpt over pixel blocks.
 * - A light no caster sees (a bulb inside an opaque shade): the plan is off; with the shade's side
 *   toward the caster taken away, on.
 * - Caustic guiding at receivers (its cones toward glass balls) in path's default in a room where a
 *   glass caster is an analytic sphere (the demo), not in volpath's or bdpt's, not in the open; the
 *   longer chains there up to 4 vertices, whose demo render agrees with the pass's top of 6.
 * - Flat glass alone: no query from the camera where its pilot finds no light in view (the slab
 *   scenes of scenes/), kept where a light is seen through a slab; without it the image is the same.
 *   Half of a sphere light's points from the receiver's cone where the light lies outside the
 *   casters' bounding sphere and is larger than the small-light rule's.
 * - The light guides from point and spot lights in path's plan where such a light meets a slab and
 *   max_depth leaves room for a chain of 7 vertices (bench/check/spot_slab_guide.xml,
 *   bench/check/two_slabs_point_light.xml), not at max_depth 8, for volpath or bdpt, nor without a slab.
 * - One glass slab under a light of 0.002-0.0035 sr: path's plan on with the slab's longer chains;
 *   beside a mirror ball on under a cost limit of its own; off with two slabs, a larger
 *   light, for volpath and bdpt, without casters; its setting agrees with none, and beside the
 *   mirror ball with bdpt (z-test, image means).
 */
/* ctest-labels: stat */
/* ctest-timeout: 600 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "harness.h"
#include "manifold/snee_plan.h"
#include "scene/sdf.h"
#include "render_util.h"

static spc_shape *add_floor(spc_scene *sc, double half, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 M = spc_mat4_scale(spc_v3(half, half, 1));
    spc_shape_init_rectangle(s, &M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

static bool finalize(spc_scene *sc)
{
    spc_error err;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        return false;
    }
    return true;
}

/* A floor (z = 0), a glass ball of radius 0.5 on it (unless `ball` is false) and a sphere light of
 * radius rl at lp with the power of radiance 4 on a sphere of radius 0.25; res x res pixels. */
static spc_scene *ball_scene_open(bool ball, double rl, spc_vec3 lp, int res)
{
    spc_scene *sc = spc_scene_create();
    add_floor(sc, 3.0, tu_diffuse(sc, 0.7));
    if (ball)
        tu_sphere(sc, spc_v3(0, 0, 0.5), 0.5, tu_glass(sc, 1.5));
    spc_shape *light = tu_sphere(sc, lp, rl, tu_diffuse(sc, 0.0));
    tu_area(sc, light, ball ? 2 : 1, 4.0 * (0.25 / rl) * (0.25 / rl));
    tu_camera(sc, spc_v3(0.2, -2.6, 1.9), spc_v3(0, 0, 0.35), spc_v3(0, 0, 1), 50, res, res);
    return sc;
}

/* The same, finalized; NULL if that fails. */
static spc_scene *ball_scene(bool ball, double rl, spc_vec3 lp, int res)
{
    spc_scene *sc = ball_scene_open(ball, rl, lp, res);
    if (!finalize(sc)) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* Renders with the setting `snee` (NULL: the scene's, i.e. the default) and integrator; the stats'
 * setting goes to ran (96 bytes). */
static spc_film *render_ran(const spc_scene *sc, const char *integrator, const char *snee, int spp, uint64_t seed,
                            char *ran)
{
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp;
    o.threads = 2;
    o.seed = seed;
    o.integrator = integrator;
    o.specular_nee = snee;
    spc_film *f = NULL;
    spc_render_stats st;
    memset(&st, 0, sizeof st);
    spc_error err;
    if (spc_render(sc, &o, &f, &st, &err) != SPC_OK) {
        printf("  render failed: %s\n", err.msg);
        return NULL;
    }
    snprintf(ran, SPC_SPECULAR_NEE_MAX, "%s", st.specular_nee);
    return f;
}

/* A setting of the plan where a caster is glass (snee_plan.h): angular with reflections off glass,
 * the Russian roulette past the first receiver and the query from the camera, in every camera sample
 * (SPC_SNEE_PLAN_SETTING) or in a fraction sqrt(glass share) of them, at least 0.1. */
static bool glass_setting(const char *s)
{
    spc_snee_params p;
    if (!spc_snee_parse(s, 2, &p))
        return false;
    return p.solver == SPC_SNEE_ANGULAR && p.reflect && p.camera && p.camera_p >= 0.02 && p.first_p == 0.1 &&
           p.later_p == 0.1 && (p.camera_p == 1.0 ? !strcmp(s, SPC_SNEE_PLAN_SETTING) : p.camera_p < 0.95);
}

/* bdpt's setting for a glass ball (every glass caster enumerated exactly) with glass on a share
 * `share` of the image: the query from the camera on 0.17 sqrt(share) of the samples, at least 0.02,
 * on any film size (snee_plan.c's camera_prob_bdpt). */
static const char *bdpt_ball_setting(double share)
{
    static char buf[64];
    double q = 0.17 * sqrt(share);
    snprintf(buf, sizeof buf, "angular:camera=%.2g", q > 0.02 ? q : 0.02);
    return buf;
}

TEST(default_on_with_casters_only)
{
    spc_scene *with = ball_scene(true, 0.1, spc_v3(0.35, 0.25, 2.2), 4);
    spc_scene *without = ball_scene(false, 0.1, spc_v3(0.35, 0.25, 2.2), 4);
    spc_scene *large = ball_scene(true, 0.6, spc_v3(0.35, 0.25, 2.2), 4);
    CHECK(with && without);
    if (!with || !without)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(with, "path", NULL, &p);
    CHECK(p.on && p.automatic && glass_setting(p.setting) && p.casters == 1 && p.receivers == 2);
    char auto_setting[SPC_SPECULAR_NEE_MAX];
    snprintf(auto_setting, sizeof auto_setting, "%s", p.setting);
    spc_snee_plan_make(with, "volpath", "auto", &p);
    /* volpath: path's setting without caustic guiding (SPC_SNEE_PLAN_ROOM_GLASS_BALL: path's alone)
     * and without the light-traced caustics of its small light (SPC_SNEE_PLAN_AREA_LIGHTS: path's) */
    size_t nv = strlen(p.setting);
    CHECK_MSG(p.on && !strncmp(p.setting, auto_setting, nv) &&
                  (auto_setting[nv] == '\0' || !strcmp(auto_setting + nv, SPC_SNEE_PLAN_ROOM_GLASS_BALL) ||
                   !strcmp(auto_setting + nv, SPC_SNEE_PLAN_AREA_LIGHTS)),
              "volpath %s, path %s", p.setting, auto_setting);
    spc_snee_plan_make(with, "bdpt", "", &p);
    CHECK_MSG(p.on && !strcmp(p.setting, bdpt_ball_setting(p.glass_share)), "%s", p.setting);
    spc_snee_plan_make(with, "ipt", NULL, &p);
    CHECK(!p.on);
    spc_snee_plan_make(with, "path", "none", &p);
    CHECK(!p.on && !p.automatic && !strcmp(p.setting, "none"));
    spc_snee_plan_make(with, "path", "off", &p);
    CHECK(!p.on && !strcmp(p.setting, "none"));
    spc_snee_plan_make(with, "path", "newton:biased=4", &p);
    CHECK(p.on && !p.automatic && !strcmp(p.setting, "newton:biased=4"));
    spc_snee_plan_make(without, "path", NULL, &p);
    CHECK(!p.on && p.casters == 0 && strstr(p.reason, "casters") != NULL);
    /* a light that subtends 0.3 sr at the ball: off, BSDF sampling finds it */
    CHECK(large != NULL);
    if (large) {
        spc_snee_plan_make(large, "path", NULL, &p);
        CHECK_MSG(!p.on && strstr(p.reason, "every light is large") != NULL, "%s", p.reason);
        spc_scene_destroy(large);
    }

    /* what ran, in the stats and in the film (the EXR header's attributes) */
    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *f = render_ran(with, "path", NULL, 2, 1, ran);
    CHECK(f && !strcmp(ran, auto_setting) && !strcmp(f->specular_nee, auto_setting) && !strcmp(f->integrator, "path"));
    spc_film_destroy(f);
    f = render_ran(with, "path", "none", 2, 1, ran);
    CHECK(f && !strcmp(ran, "none") && !strcmp(f->specular_nee, "none"));
    spc_film_destroy(f);
    f = render_ran(with, "bdpt", NULL, 2, 1, ran);
    spc_snee_plan_make(with, "bdpt", NULL, &p);
    CHECK_MSG(f && !strcmp(ran, bdpt_ball_setting(p.glass_share)), "%s", ran);
    spc_film_destroy(f);
    f = render_ran(without, "path", NULL, 2, 1, ran);
    CHECK(f && !strcmp(ran, "none"));
    spc_film_destroy(f);
    f = render_ran(with, "path", "conic:noreflect", 2, 1, ran);
    CHECK(f && !strcmp(ran, "conic:noreflect"));
    spc_film_destroy(f);

    /* the plan as `specula info` prints it */
    char *text = spc_scene_plan(with, NULL, NULL);
    char line[SPC_SPECULAR_NEE_MAX + 32];
    snprintf(line, sizeof line, "specular NEE: %s (auto)", auto_setting);
    CHECK(text && strstr(text, line) && strstr(text, "glass seen on") &&
          strstr(text, "caster shape 1: glass sphere: every chain on the sphere enumerated exactly"));
    free(text);
    text = spc_scene_plan(without, NULL, NULL);
    CHECK(text && strstr(text, "specular NEE: none (auto: no specular casters)"));
    free(text);

    /* a flat-faced caster no exact enumeration covers (a glass disk): off by default, on when asked
     * for; a glass pane (a mesh of one plane) is enumerated through its flat faces: on */
    for (int kind = 0; kind < 2; ++kind) {
        spc_scene *pane = ball_scene_open(false, 0.1, spc_v3(0.35, 0.25, 2.2), 4);
        if (!pane) {
            CHECK(false);
            continue;
        }
        spc_shape *g = spc_scene_new_shape(pane);
        spc_error gerr;
        spc_mat4 M = spc_mat4_translate(spc_v3(0, 0, 1));
        if (kind == 0)
            spc_shape_init_disk(g, &M, NULL, 0, 0, &gerr);
        else
            spc_shape_init_rectangle(g, &M, NULL, 0, 0, &gerr);
        g->bsdf = tu_glass(pane, 1.5);
        g->caustic_flags = SPC_CAUSTIC_CASTER | SPC_CAUSTIC_RECEIVER;
        CHECK(finalize(pane));
        spc_snee_plan_make(pane, "path", NULL, &p);
        if (kind == 0) {
            CHECK_MSG(!p.on && p.casters == 1 && strstr(p.reason, "caster shape 2 is flat-faced"), "%s", p.reason);
            spc_snee_plan_make(pane, "path", "angular", &p);
            CHECK(p.on);
        } else {
            /* enumerated, but the light (0.02 sr) is too large for flat glass: off; asked for, the
             * description names the enumeration */
            CHECK_MSG(!p.on && strstr(p.reason, "flat-faced casters under a light"), "pane: %s", p.reason);
            spc_snee_plan_make(pane, "path", "angular", &p);
            CHECK(p.on);
            char buf[1024];
            spc_snee_plan_describe(pane, &p, 2, buf, sizeof buf);
            CHECK_MSG(strstr(buf, "caster shape 2: glass mesh: every chain through its flat faces"), "%s", buf);
        }
        spc_scene_destroy(pane);
    }

    /* only an environment light: nothing for specular NEE to draw */
    spc_scene *env = spc_scene_create();
    add_floor(env, 3.0, tu_diffuse(env, 0.7));
    tu_sphere(env, spc_v3(0, 0, 0.5), 0.5, tu_glass(env, 1.5));
    spc_emitter *e = spc_scene_new_emitter(env);
    e->type = SPC_EMITTER_CONSTANT;
    e->radiance = spc_scene_constant(env, spc_rgb1(1.0));
    e->shape_index = -1;
    tu_camera(env, spc_v3(0.2, -2.6, 1.9), spc_v3(0, 0, 0.35), spc_v3(0, 0, 1), 50, 4, 4);
    if (finalize(env)) {
        spc_snee_plan_make(env, "path", NULL, &p);
        CHECK(!p.on && strstr(p.reason, "light") != NULL);
    } else {
        CHECK(false);
    }
    spc_scene_destroy(env);
    spc_scene_destroy(with);
    spc_scene_destroy(without);
}

static spc_status load_text(const char *text, spc_scene **sc, spc_error *err)
{
    char path[64];
    snprintf(path, sizeof path, "/tmp/spc_snee_plan_%ld.xml", (long)getpid());
    FILE *fp = fopen(path, "w");
    if (!fp)
        return SPC_ERR_IO;
    fputs(text, fp);
    fclose(fp);
    spc_status st = spc_scene_load(path, NULL, 0, sc, err);
    remove(path);
    return st;
}

TEST(xml_setting_words)
{
    static const char *const fmt =
        "<scene version=\"3.0.0\">\n"
        "<integrator type=\"path\">\n"
        "  <string name=\"specular_nee\" value=\"%s\"/>\n"
        "</integrator>\n"
        "<shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/><bsdf type=\"dielectric\"/></shape>\n"
        "<shape type=\"rectangle\"><transform name=\"to_world\"><translate z=\"-1\"/></transform></shape>\n"
        "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0\" z=\"3\"/><float name=\"radius\" value=\"0.2\"/>"
        "<emitter type=\"area\"><rgb name=\"radiance\" value=\"5\"/></emitter></shape>\n"
        "</scene>\n";
    static const struct {
        const char *value, *runs;
    } words[] = {
        {"auto", NULL}, {"", NULL}, {"off", "none"}, {"none", "none"}, {"conic", "conic"}}; /* NULL: glass_setting */
    char text[1024];
    for (size_t i = 0; i < sizeof words / sizeof words[0]; ++i) {
        snprintf(text, sizeof text, fmt, words[i].value);
        spc_scene *sc = NULL;
        spc_error err;
        CHECK_MSG(load_text(text, &sc, &err) == SPC_OK, "'%s' refused", words[i].value);
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, sc->integrator.type, sc->integrator.specular_nee, &p);
        CHECK_MSG(words[i].runs ? !strcmp(p.setting, words[i].runs) : glass_setting(p.setting), "'%s' runs '%s'",
                  words[i].value, p.setting);
        spc_scene_destroy(sc);
    }
    snprintf(text, sizeof text, fmt, "autox");
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(load_text(text, &sc, &err) != SPC_OK && sc == NULL && err.line == 3 && strstr(err.msg, "autox"));
    spc_scene_destroy(sc);
}

/* The default's estimator against specular NEE off on a glass ball's caustic under a large light
 * (radius 0.6), where plain path tracing at 16x the samples converges; the plan itself leaves such
 * a light to BSDF sampling, so the setting is the one it picks for a small light. With smaller
 * lights (radius 0.25 or 0.26 at 1.75 to 2.1 from the ball) BSDF samples find the light's small
 * image in the ball about once in 1e5, so at 16384 spp most floor pixels have not one such path:
 * plain path tracing is 1.3% low there, with a variance that does not show it (z-test 0.95-0.97),
 * while specular NEE finds that reflection in every sample, agreeing with brute force at floor
 * points within 0.3%. */
TEST(default_agrees_with_none)
{
    spc_scene *small = ball_scene(true, 0.1, spc_v3(0.35, 0.25, 2.6), 4);
    spc_scene *sc = ball_scene(true, 0.6, spc_v3(0.35, 0.25, 2.6), 16);
    CHECK(sc && small);
    if (!sc || !small) {
        spc_scene_destroy(sc);
        spc_scene_destroy(small);
        return;
    }
    spc_snee_plan plan;
    spc_snee_plan_make(small, "path", NULL, &plan);
    spc_scene_destroy(small);
    CHECK(plan.on);
    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *ref = render_ran(sc, "path", "none", 16384, 31, ran);
    spc_film *img = render_ran(sc, "path", plan.setting, 1024, 32, ran);
    CHECK(ref && img && !strcmp(ran, plan.setting) && glass_setting(ran));
    if (ref && img) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(img, ref, 0.99, "default vs none", &d));
        printf("    z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction, d.ztest_pixels,
               d.mean_a[0], d.mean_b[0]);
        /* and it pays: the same image with less variance at a sixteenth of the samples */
        CHECK(tu_var_sum(img) < tu_var_sum(ref) * 16.0);
        printf("    summed variance: default %.4g at 1024 spp, none %.4g at 16384 spp\n", tu_var_sum(img),
               tu_var_sum(ref));
    }
    /* the plan of the same scene on a 256 x 256 film: the query from the camera on sqrt(s) / 10 of
     * the samples, counted 1 / Q times and in both MIS weights */
    spc_scene *big = ball_scene(true, 0.1, spc_v3(0.35, 0.25, 2.6), 256);
    spc_snee_plan bplan;
    bplan.on = false;
    if (big)
        spc_snee_plan_make(big, "path", NULL, &bplan);
    spc_scene_destroy(big);
    spc_snee_params bp;
    CHECK(bplan.on && spc_snee_parse(bplan.setting, 2, &bp) && bp.camera && bp.camera_p < 0.1 &&
          glass_setting(bplan.setting));
    spc_film *low = bplan.on ? render_ran(sc, "path", bplan.setting, 1024, 33, ran) : NULL;
    CHECK(low != NULL);
    if (ref && low) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(low, ref, 0.99, "default (256 x 256 plan) vs none", &d));
        printf("    %s: z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", bplan.setting, d.ztest_pass_fraction,
               d.ztest_pixels, d.mean_a[0], d.mean_b[0]);
    }
    spc_film_destroy(low);
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

/* The query from the camera in a fraction sqrt(s) of the camera samples on this 16 x 16 film (on a
 * larger one down to sqrt(s) / 10: snee_plan.c), s the share of the image whose camera ray meets a
 * glass caster first: the glass ball of radius 0.5 seen
 * from 3 away on the axis covers pi r^2 / (d^2 - r^2) of the image plane at distance 1, over
 * (2 tan 25 deg)^2 for the 50-degree square image: 0.1032; from 0.8 away it fills the image. */
TEST(camera_query_from_glass_share)
{
    const double d[2] = {3.0, 0.8};
    for (int i = 0; i < 2; ++i) {
        spc_scene *sc = ball_scene_open(true, 0.1, spc_v3(0.35, 0.25, 2.2), 16);
        tu_camera(sc, spc_v3(0, -d[i], 0.5), spc_v3(0, 0, 0.5), spc_v3(0, 0, 1), 50, 16, 16);
        if (!finalize(sc)) {
            spc_scene_destroy(sc);
            CHECK(false);
            continue;
        }
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        double want = i == 0 ? SPC_PI * 0.25 / (9.0 - 0.25) / pow(2.0 * tan(25.0 * SPC_PI / 180.0), 2.0) : 1.0;
        spc_snee_params sp;
        CHECK_MSG(p.on && fabs(p.glass_share - want) < 0.01 && spc_snee_parse(p.setting, 2, &sp) &&
                      fabs(sp.camera_p - spc_min(sqrt(want), 100.0 / 256.0)) < 0.01 && glass_setting(p.setting),
                  "distance %g: share %g (want %g), %s", d[i], p.glass_share, want, p.setting);
        printf("    camera %g from the ball: glass on %.4f of the image (%.4f), %s\n", d[i], p.glass_share, want,
               p.setting);
        spc_scene_destroy(sc);
    }
    /* on a 64 x 64 film 100 queries a pass take a share 0.024 of the samples, under sqrt(s) / 10 */
    spc_scene *big = ball_scene_open(true, 0.1, spc_v3(0.35, 0.25, 2.2), 16);
    tu_camera(big, spc_v3(0, -3.0, 0.5), spc_v3(0, 0, 0.5), spc_v3(0, 0, 1), 50, 64, 64);
    if (finalize(big)) {
        spc_snee_plan p;
        spc_snee_plan_make(big, "path", NULL, &p);
        spc_snee_params sp;
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp) && fabs(sp.camera_p - 0.1 * sqrt(p.glass_share)) < 0.002 &&
                      glass_setting(p.setting),
                  "64 x 64: share %g, %s", p.glass_share, p.setting);
        printf("    64 x 64 film: glass on %.4f of the image, %s\n", p.glass_share, p.setting);
    } else {
        CHECK(false);
    }
    spc_scene_destroy(big);
    /* the same ball as a signed distance field, whose chains go to the randomized attempts: the
     * query in every camera sample */
    spc_scene *sc = ball_scene_open(false, 0.1, spc_v3(0.35, 0.25, 2.2), 16);
    tu_camera(sc, spc_v3(0, -3.0, 0.5), spc_v3(0, 0, 0.5), spc_v3(0, 0, 1), 50, 16, 16);
    spc_sdf_desc sd;
    spc_sdf_desc_init(&sd, SPC_SDF_SPHERE);
    sd.radius = 0.5;
    spc_mat4 M = spc_mat4_translate(spc_v3(0, 0, 0.5));
    CHECK(tu_sdf(sc, &sd, &M, tu_glass(sc, 1.5)) != NULL);
    if (!finalize(sc)) {
        spc_scene_destroy(sc);
        CHECK(false);
        return;
    }
    spc_snee_plan p;
    spc_snee_plan_make(sc, "path", NULL, &p);
    /* an SDF's chains go to the randomized attempts; guided seeds are not in the plan (snee_plan.h);
     * under its small light the light guides' chains and its caustics go to light tracing too, and
     * the camera's query looks for its longer chains */
    CHECK_MSG(p.on && p.glass_share > 0.05 &&
                  !strcmp(p.setting, SPC_SNEE_PLAN_SETTING SPC_SNEE_PLAN_LIGHT_GUIDES SPC_SNEE_PLAN_CAMERA_SPLIT
                                         SPC_SNEE_PLAN_CAMERA_RECV SPC_SNEE_PLAN_SDF_LT SPC_SNEE_PLAN_CAMERA_LONG),
              "SDF ball: share %g, %s", p.glass_share, p.setting);
    spc_snee_params sp;
    CHECK(spc_snee_parse(p.setting, 2, &sp) && sp.seed_guide == 0.0);
    CHECK(spc_snee_parse(SPC_SNEE_PLAN_SETTING SPC_SNEE_PLAN_SEED_GUIDE, 2, &sp) && sp.seed_guide == 0.8);
    spc_snee_plan_make(sc, "bdpt", NULL, &p);
    CHECK_MSG(p.on && !strstr(p.setting, "seedguide"), "bdpt: %s", p.setting);
    spc_scene_destroy(sc);
}

/* A floor, a mirror ball of radius 0.5 on it (and a glass ball beside it if `glass`), a sphere
 * light of radius rl above; res x res pixels. */
static spc_scene *mirror_scene(bool glass, double rl, int res)
{
    spc_scene *sc = spc_scene_create();
    add_floor(sc, 3.0, tu_diffuse(sc, 0.7));
    tu_sphere(sc, spc_v3(0, 0, 0.5), 0.5, tu_mirror(sc));
    int n = 2;
    if (glass) {
        tu_sphere(sc, spc_v3(1.2, 0.3, 0.4), 0.4, tu_glass(sc, 1.5));
        ++n;
    }
    spc_shape *light = tu_sphere(sc, spc_v3(0.9, -0.6, 2.2), rl, tu_diffuse(sc, 0.0));
    tu_area(sc, light, n, 4.0 * (0.25 / rl) * (0.25 / rl));
    tu_camera(sc, spc_v3(0.2, -2.6, 1.9), spc_v3(0, 0, 0.35), spc_v3(0, 0, 1), 50, res, res);
    if (!finalize(sc)) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* Where every caster is a mirror enumerated exactly, the plan makes the query from the camera by
 * Russian roulette (SPC_SNEE_PLAN_SETTING_MIRRORS after "angular:camera=Q,"; the light's small
 * image in a mirror ball is otherwise the camera ray's alone); with a glass caster too it keeps the
 * glass setting. The mirror-only setting agrees with specular NEE off (a larger light, so that
 * plain path tracing converges). */
TEST(mirror_only_plan_camera_query_by_roulette)
{
    spc_scene *mirror = mirror_scene(false, 0.1, 4);
    spc_scene *both = mirror_scene(true, 0.1, 4);
    spc_scene *sc = mirror_scene(false, 0.6, 12);
    CHECK(mirror && both && sc);
    if (!mirror || !both || !sc) {
        spc_scene_destroy(mirror);
        spc_scene_destroy(both);
        spc_scene_destroy(sc);
        return;
    }
    spc_snee_plan p;
    spc_snee_plan_make(mirror, "path", NULL, &p);
    const size_t tail = strlen(SPC_SNEE_PLAN_SETTING_MIRRORS);
    CHECK_MSG(p.on && p.casters == 1 && !strncmp(p.setting, "angular:camera=", 15) && strlen(p.setting) > tail &&
                  !strcmp(p.setting + strlen(p.setting) - tail, SPC_SNEE_PLAN_SETTING_MIRRORS),
              "%s", p.setting);
    spc_snee_params sp;
    CHECK_MSG(spc_snee_parse(p.setting, 2, &sp) && sp.camera && sp.camera_p > 0.0 && sp.camera_p < 1.0 &&
                  sp.first_p == 0.1 && sp.later_p < 1.0,
              "%s: camera %d, camera_p %g", p.setting, sp.camera, sp.camera_p);
    char *text = spc_scene_plan(mirror, NULL, NULL);
    char want[SPC_SPECULAR_NEE_MAX + 32];
    snprintf(want, sizeof want, "specular NEE: %s (auto)", p.setting);
    CHECK(text && strstr(text, want) && strstr(text, "caster shape 1: mirror sphere"));
    free(text);
    spc_snee_plan both_plan;
    spc_snee_plan_make(both, "path", NULL, &both_plan);
    CHECK_MSG(both_plan.on && both_plan.casters == 2 && glass_setting(both_plan.setting), "%s", both_plan.setting);
    CHECK(spc_snee_parse(both_plan.setting, 2, &sp) && sp.camera);

    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *ref = render_ran(sc, "path", "none", 8192, 41, ran);
    spc_film *img = render_ran(sc, "path", p.setting, 1024, 42, ran);
    CHECK(ref && img && !strcmp(ran, p.setting));
    if (ref && img) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(img, ref, 0.99, "mirror-only default vs none", &d));
        printf("    z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction, d.ztest_pixels,
               d.mean_a[0], d.mean_b[0]);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(mirror);
    spc_scene_destroy(both);
    spc_scene_destroy(sc);
}

/* A lamp in a glass globe: a sphere light of radius 0.2 inside a glass ball of radius 0.6 above a
 * floor. The light is large (the plan's solid-angle rule alone would leave specular NEE off), but
 * every direction from it meets the glass, so the plan is on; its estimator (the light inside the
 * sphere that the chains are enumerated on) agrees with specular NEE off. */
TEST(lamp_in_glass_globe_plan_on)
{
    spc_scene *sc = spc_scene_create();
    add_floor(sc, 3.0, tu_diffuse(sc, 0.7));
    tu_sphere(sc, spc_v3(0, 0, 0.9), 0.6, tu_glass(sc, 1.5));
    spc_shape *light = tu_sphere(sc, spc_v3(0.1, 0.05, 0.95), 0.2, tu_diffuse(sc, 0.0));
    tu_area(sc, light, 2, 5.0);
    tu_camera(sc, spc_v3(0.2, -2.6, 1.9), spc_v3(0, 0, 0.6), spc_v3(0, 0, 1), 55, 12, 12);
    CHECK(finalize(sc));
    spc_snee_plan p;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && p.light_sr > 0.03 && p.caster_share >= 1.0 && glass_setting(p.setting), "%s (%s) %g sr, share %g",
              p.setting, p.reason, p.light_sr, p.caster_share);
    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *ref = render_ran(sc, "path", "none", 16384, 71, ran);
    spc_film *img = render_ran(sc, "path", NULL, 4096, 72, ran);
    CHECK(ref && img && !strcmp(ran, p.setting));
    if (ref && img) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(img, ref, 0.99, "lamp in a globe: default vs none", &d));
        printf("    z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction, d.ztest_pixels,
               d.mean_a[0], d.mean_b[0]);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

static bool blocks_agree(const spc_film *img, const spc_film *ref, int n, const char *label);

/* bdpt's default follows the plan with its own setting: on with a glass caster (the query from the
 * camera on a share of the samples), without that query where every caster is a mirror, off
 * without casters, with a large light, or when turned off; what ran is in the stats, `specula
 * info`'s text says it. Its estimator: the default (1024 spp) against bdpt without specular NEE
 * (4096 spp) on the glass ball under a small light, per-pixel z-test and image means. */
TEST(bdpt_default_follows_the_plan)
{
    spc_scene *with = ball_scene(true, 0.1, spc_v3(0.35, 0.25, 2.2), 12);
    spc_scene *without = ball_scene(false, 0.1, spc_v3(0.35, 0.25, 2.2), 4);
    spc_scene *large = ball_scene(true, 0.6, spc_v3(0.35, 0.25, 2.2), 4);
    spc_scene *mirror = mirror_scene(false, 0.1, 4);
    CHECK(with && without && large && mirror);
    if (!with || !without || !large || !mirror) {
        spc_scene_destroy(with);
        spc_scene_destroy(without);
        spc_scene_destroy(large);
        spc_scene_destroy(mirror);
        return;
    }
    spc_snee_plan p;
    spc_snee_plan_make(with, "bdpt", NULL, &p);
    /* the query from the camera on 0.17 sqrt(s) of the samples (at least 0.02), not path's share,
     * which a small film raises (0.1 or more here) */
    char bdpt_setting[64];
    snprintf(bdpt_setting, sizeof bdpt_setting, "%s", bdpt_ball_setting(p.glass_share));
    CHECK_MSG(p.on && p.automatic && !strcmp(p.setting, bdpt_setting), "%s (glass share %.3f)", p.setting,
              p.glass_share);
    spc_snee_params sp;
    CHECK(spc_snee_parse(p.setting, 2, &sp) && sp.camera && sp.camera_p >= 0.02 && sp.camera_p < 0.1);
    const double q_bdpt = sp.camera_p;
    spc_snee_plan path_plan;
    spc_snee_plan_make(with, "path", NULL, &path_plan);
    spc_snee_params path_sp;
    CHECK_MSG(spc_snee_parse(path_plan.setting, 2, &path_sp) && path_sp.camera_p > sp.camera_p, "path %s, bdpt %s",
              path_plan.setting, p.setting);
    spc_snee_plan_make(mirror, "bdpt", NULL, &p);
    CHECK_MSG(p.on && !strcmp(p.setting, SPC_SNEE_PLAN_SETTING_BDPT_MIRRORS), "%s", p.setting);
    CHECK(spc_snee_parse(p.setting, 2, &sp) && !sp.camera);
    spc_snee_plan_make(without, "bdpt", NULL, &p);
    CHECK(!p.on && strstr(p.reason, "casters") != NULL);
    spc_snee_plan_make(large, "bdpt", NULL, &p);
    CHECK_MSG(!p.on && strstr(p.reason, "every light is large") != NULL, "%s", p.reason);
    spc_snee_plan_make(with, "bdpt", "none", &p);
    CHECK(!p.on && !p.automatic);
    spc_snee_plan_make(with, "ptracer", NULL, &p);
    CHECK(!p.on);
    char *text = spc_scene_plan(with, "bdpt", NULL);
    char want_setting[SPC_SPECULAR_NEE_MAX], want_share[SPC_SPECULAR_NEE_MAX];
    snprintf(want_setting, sizeof want_setting, "specular NEE: %s (auto)", bdpt_setting);
    snprintf(want_share, sizeof want_share, "from the camera on a share %g of the samples", q_bdpt);
    CHECK_MSG(text && strstr(text, want_setting) && strstr(text, want_share), "%s", text ? text : "(null)");
    free(text);

    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *img = render_ran(with, "bdpt", NULL, 1024, 61, ran);
    CHECK_MSG(img && !strcmp(ran, bdpt_setting), "%s", ran);
    spc_film *ref = render_ran(with, "bdpt", "none", 4096, 62, ran);
    CHECK(ref && !strcmp(ran, "none"));
    if (img && ref) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(img, ref, 0.99, "bdpt default vs bdpt none", &d));
        printf("    z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction, d.ztest_pixels,
               d.mean_a[0], d.mean_b[0]);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(with);
    spc_scene_destroy(without);
    spc_scene_destroy(large);
    spc_scene_destroy(mirror);
}

/* The glass ball under a small sphere light (radius 0.05) with no sky: the default (reflections
 * off glass and the query from the camera included) against bdpt, whose light paths reach the
 * caustic directly, with specular NEE at its receivers (camera=0.1): plain bdpt at 8192 spp misses
 * the light's reflection in the ball on the floor of block (1, 1) (0.3948 +- 0.0005, at 65536 spp
 * 0.4076 +- 0.0041: one rare path of large weight; the default 0.4008-0.4019 +- 0.001 over three
 * renders, bench/RESULTS.md, "Tails of the default"). bdpt weighs those chains against its own
 * strategies, not as the path tracer does. */
TEST(small_light_ball_agrees_with_bdpt)
{
    spc_scene *sc = ball_scene(true, 0.05, spc_v3(0.3, 0.4, 2.0), 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *ref = render_ran(sc, "bdpt", "angular:camera=0.1", 8192, 41, ran);
    spc_film *img = render_ran(sc, "path", NULL, 2048, 42, ran);
    CHECK(ref && img && glass_setting(ran));
    if (ref && img) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        /* per pixel for the record; the check is over 4 x 4 blocks: bdpt reaches the light's
         * reflection in the ball about once per pixel (see blocks_agree); the image means too */
        CHECK(tu_image_agrees(img, ref, 0.0, "default vs bdpt (image means)", &d));
        printf("    z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction, d.ztest_pixels,
               d.mean_a[0], d.mean_b[0]);
        CHECK(blocks_agree(img, ref, 4, "default vs bdpt"));
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

/* The scene at `rel` under the source tree, its "res" set to `res`; NULL (and a failed check) if it
 * does not load. */
static spc_scene *load_at(const char *rel, const char *res)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s", spc_test_source_dir(), rel);
    spc_define defs[1] = {{"res", res}};
    spc_scene *sc = NULL;
    spc_error err;
    CHECK_MSG(spc_scene_load(path, defs, 1, &sc, &err) == SPC_OK, "%s: %s", rel, err.msg);
    return sc;
}

/* The README's first command: scenes/demo.xml (a Cornell box with a glass and a mirror ball under a
 * small ceiling light) renders with the plan's specular NEE, whose Russian roulette past the first
 * receiver and at it far from the casters (first=0.1, later=0.1) agrees with the query made at every
 * receiver. */
TEST(demo_plan_on)
{
    spc_scene *sc = load_at("scenes/demo.xml", "16");
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(sc, sc->integrator.type, sc->integrator.specular_nee, &p);
    CHECK_MSG(p.on && p.automatic && glass_setting(p.setting) && p.casters == 2 && p.light_sr < 0.03, "%s: %s (%g sr)",
              p.setting, p.reason, p.light_sr);
    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *img = render_ran(sc, "path", NULL, 512, 51, ran);
    CHECK(img && !strcmp(ran, p.setting));
    spc_film *all = render_ran(sc, "path", "angular:camera", 512, 52, ran);
    CHECK(img && all);
    if (img && all) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(img, all, 0.99, "default vs later=1", &d));
        printf("    vs later=1: z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction,
               d.ztest_pixels, d.mean_a[0], d.mean_b[0]);
    }
    spc_film_destroy(img);
    spc_film_destroy(all);
    spc_scene_destroy(sc);
}

/* The image mean (luminance) of each of `n` renders of spp samples (seeds seed0 + i), their mean
 * *mean and relative standard deviation *rel (0 if the mean is 0). False if a render failed. */
static bool seed_means(const spc_scene *sc, const char *snee, int spp, uint64_t seed0, int n, double *mean, double *rel)
{
    double s = 0.0, s2 = 0.0;
    char ran[SPC_SPECULAR_NEE_MAX];
    for (int i = 0; i < n; ++i) {
        spc_film *f = render_ran(sc, "path", snee, spp, seed0 + (uint64_t)i, ran);
        if (!f)
            return false;
        double m = 0.0;
        for (int c = 0; c < 3; ++c) {
            double mc, se;
            tu_image_mean(f, c, &mc, &se);
            m += mc / 3.0;
        }
        spc_film_destroy(f);
        s += m;
        s2 += m * m;
    }
    *mean = s / n;
    double var = (s2 - s * s / n) / (n - 1);
    *rel = *mean > 0.0 ? sqrt(var > 0.0 ? var : 0.0) / *mean : 0.0;
    return true;
}

/* bench/check/ball_small_light.xml's ball and light (radius 0.05) over a black floor, 16x16: an image
 * of nothing but the light's images in and through the ball. NULL on failure. */
static spc_scene *light_images_scene(void)
{
    spc_scene *sc = spc_scene_create();
    add_floor(sc, 3.0, tu_diffuse(sc, 0.0));
    tu_sphere(sc, spc_v3(0, 0, 0.5), 0.5, tu_glass(sc, 1.5));
    spc_shape *light = tu_sphere(sc, spc_v3(0.3, 0.4, 2.0), 0.05, tu_diffuse(sc, 0.0));
    tu_area(sc, light, 2, 2000.0);
    tu_camera(sc, spc_v3(0, -3, 2), spc_v3(0, 0, 0.2), spc_v3(0, 0, 1), 40, 16, 16);
    if (!finalize(sc)) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* The default has no fireflies where the camera sees a small light in and through a glass ball:
 * bench/check/ball_small_light.xml's ball and light (radius 0.05) over a black floor, so that the
 * image is nothing but the light's images in the ball. Camera rays find those only by landing on
 * them (without specular NEE from the camera and reflections off glass, as angular:noreflect, the
 * earlier default, or none: not once in 8 x 16 spp, and at 4096 spp two seeds' image means differ
 * 4x), while the default's query from the camera finds them in every sample: over 8 seeds of 16
 * spp the image means scatter by 1.6% (bench/RESULTS.md, "Heavy tails of the default"). */
TEST(default_has_no_fireflies_through_glass)
{
    spc_scene *sc = light_images_scene();
    CHECK(sc != NULL);
    if (!sc)
        return;
    double m, rel, m_nr, rel_nr;
    CHECK(seed_means(sc, NULL, 16, 61, 8, &m, &rel));
    CHECK(seed_means(sc, "angular:noreflect", 16, 61, 8, &m_nr, &rel_nr));
    printf("    image mean over 8 seeds of 16 spp: default %.5g (scatter %.3f), angular:noreflect %.5g (%.3f)\n", m,
           rel, m_nr, rel_nr);
    CHECK(m > 0.0 && rel < 0.05);
    /* what the bound catches: the estimator without those chains */
    CHECK(!(m_nr > 0.5 * m && rel_nr < 0.05));
    spc_scene_destroy(sc);
}

/* The query from the camera at the Q a large film's plan gives (sqrt(s) / 10), counted 1 / Q times
 * and in both MIS weights, against the query in every camera sample, on an image of nothing but the
 * light's images in and through a glass ball (default_has_no_fireflies_through_glass's scene): per
 * pixel z-test and image means. */
TEST(low_camera_q_agrees_on_light_images)
{
    spc_scene *sc = light_images_scene();
    CHECK(sc != NULL);
    if (!sc)
        return;
    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *low = render_ran(sc, "path", "angular:camera=0.037,first=0.1,later=0.1", 1024, 71, ran);
    spc_film *all = render_ran(sc, "path", "angular:camera,first=0.1,later=0.1", 256, 72, ran);
    CHECK(low && all);
    if (low && all) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(low, all, 0.99, "camera=0.037 vs camera", &d));
        double ml, sl, ma, sa;
        tu_image_mean(low, 0, &ml, &sl);
        tu_image_mean(all, 0, &ma, &sa);
        CHECK_MSG(fabs(ml - ma) < 4.0 * sqrt(sl * sl + sa * sa), "means %g +- %g vs %g +- %g", ml, sl, ma, sa);
        printf("    z-test pass %.4f of %d pixels; means %.6f +- %.6f vs %.6f +- %.6f\n", d.ztest_pass_fraction,
               d.ztest_pixels, ml, sl, ma, sa);
    }
    spc_film_destroy(low);
    spc_film_destroy(all);
    spc_scene_destroy(sc);
}

/* Sums of img and ref over n x n pixel blocks agree: per block and channel z = (a - b) / sqrt(var_a +
 * var_b), two-sided, Sidak-corrected at 0.01 over every block and channel. A bias over a region
 * stays in its blocks' sums, while a path one estimator samples rarely (a reference that reaches
 * a light's reflection in a glass ball once per pixel or less) averages out over a block. Prints
 * each failing block after `label`. */
static bool blocks_agree(const spc_film *img, const spc_film *ref, int n, const char *label)
{
    int bw = ref->width / n, bh = ref->height / n, tests = 3 * bw * bh;
    double alpha = -expm1(log1p(-0.01) / tests);
    bool ok = img->width == ref->width && img->height == ref->height && tests > 0;
    for (int by = 0; ok && by < bh; ++by)
        for (int bx = 0; bx < bw; ++bx)
            for (int c = 0; c < 3; ++c) {
                double a = 0.0, b = 0.0, v = 0.0;
                for (int y = by * n; y < (by + 1) * n; ++y)
                    for (int x = bx * n; x < (bx + 1) * n; ++x) {
                        size_t i = 3 * ((size_t)y * ref->width + x) + c;
                        a += img->rgb[i];
                        b += ref->rgb[i];
                        v += img->var[i] + ref->var[i];
                    }
                double z = v > 0.0 ? (a - b) / sqrt(v) : (a == b ? 0.0 : INFINITY);
                if (!(erfc(fabs(z) / sqrt(2.0)) >= alpha)) {
                    printf("  %s: block (%d, %d) channel %d: %.6g vs %.6g, z %.1f\n", label, bx, by, c, a, b, z);
                    ok = false;
                }
            }
    return ok;
}

/* Random caustic scene 2's glass ball and small sphere light, scaled to the ball above, at
 * max_depth 4, where a receiver's chains of one vertex (the light's reflection in the ball) and of
 * two (through it) both run: specular NEE with reflections off glass against bdpt. Per pixel
 * bdpt is the wrong judge here: its light paths reach the floor near the camera by the ball's
 * reflection about once per pixel at 8192 spp (strategy s = 3, t = 1), so most of those pixels
 * read 1% low with a variance that does not show it, and such a z-test passes 97-98% of pixels
 * with the failures moving between seeds. Over 8 x 8 pixel blocks those misses average out (|z|
 * at most 2.6 over four pairs of seeds), while the light's reflection in the ball counted 1.5
 * times (the image 0.3% brighter) puts three of the four blocks at z 5.0 to 6.1 (bench/RESULTS.md,
 * "Reflections off glass: no bias"). */
TEST(reflections_at_depth_4_agree_with_bdpt)
{
    spc_scene *sc = ball_scene(true, 0.0666, spc_v3(-1.068, 0.340, 2.953), 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    sc->integrator.max_depth = 4;
    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *ref = render_ran(sc, "bdpt", "none", 8192, 51, ran);
    spc_film *img = render_ran(sc, "path", "angular", 2048, 52, ran);
    CHECK(ref && img && !strcmp(ran, "angular"));
    if (ref && img) {
        CHECK(blocks_agree(img, ref, 8, "angular vs bdpt at max_depth 4"));
        double ma, sa, mb, sb;
        tu_image_mean(img, 0, &ma, &sa);
        tu_image_mean(ref, 0, &mb, &sb);
        CHECK_MSG(fabs(ma - mb) <= 3.0 * sqrt(sa * sa + sb * sb), "means %.6f vs %.6f", ma, mb);
        printf("    image means %.6f +- %.6f vs %.6f +- %.6f\n", ma, sa, mb, sb);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

/* A rectangle ([-1, 1]^2 in z = 0 under M) with BSDF b. */
static void add_rect(spc_scene *sc, spc_mat4 T, spc_mat4 R, spc_vec3 scale, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 S = spc_mat4_scale(scale);
    spc_mat4 RS = spc_mat4_mul(&R, &S);
    spc_mat4 M = spc_mat4_mul(&T, &RS);
    spc_shape_init_rectangle(s, &M, NULL, 0, 0, &err);
    s->bsdf = b;
}

/* The glass ball of ball_scene and a small light (a sphere of radius 0.05, or a point light) at
 * (1.5, 0, 1.2) inside an opaque housing open at the top (a box 0.4 x 0.4, z from 1.0 to 1.6),
 * whose side toward the ball (x = 1.3) is left out unless `closed`. */
static spc_scene *housing_scene(bool closed, bool point)
{
    spc_scene *sc = spc_scene_create();
    add_floor(sc, 3.0, tu_diffuse(sc, 0.7));
    tu_sphere(sc, spc_v3(0, 0, 0.5), 0.5, tu_glass(sc, 1.5));
    spc_vec3 lp = spc_v3(1.5, 0, 1.2);
    if (point) {
        spc_emitter *e = spc_scene_new_emitter(sc);
        e->type = SPC_EMITTER_POINT;
        e->position = lp;
        e->intensity = spc_rgb1(1.0);
    } else {
        tu_area(sc, tu_sphere(sc, lp, 0.05, tu_diffuse(sc, 0.0)), 2, 100.0);
    }
    const spc_bsdf *shade = tu_diffuse(sc, 0.5);
    spc_mat4 I = spc_mat4_identity();
    spc_mat4 Ry = spc_mat4_rotate(spc_v3(0, 1, 0), 90), Rx = spc_mat4_rotate(spc_v3(1, 0, 0), 90);
    add_rect(sc, spc_mat4_translate(spc_v3(1.5, 0, 1.0)), I, spc_v3(0.2, 0.2, 1), shade);
    add_rect(sc, spc_mat4_translate(spc_v3(1.7, 0, 1.3)), Ry, spc_v3(0.3, 0.2, 1), shade);
    if (closed)
        add_rect(sc, spc_mat4_translate(spc_v3(1.3, 0, 1.3)), Ry, spc_v3(0.3, 0.2, 1), shade);
    add_rect(sc, spc_mat4_translate(spc_v3(1.5, 0.2, 1.3)), Rx, spc_v3(0.2, 0.3, 1), shade);
    add_rect(sc, spc_mat4_translate(spc_v3(1.5, -0.2, 1.3)), Rx, spc_v3(0.2, 0.3, 1), shade);
    tu_camera(sc, spc_v3(0.2, -2.6, 1.9), spc_v3(0, 0, 0.35), spc_v3(0, 0, 1), 50, 8, 8);
    if (!finalize(sc)) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* A light no caster sees (a bulb inside an opaque shade, below its rim): every chain's last
 * segment is blocked, so the plan is off (specular NEE there cost 6x per sample and found nothing:
 * scenes/indirect_lamp_glass.xml); with the shade's side toward the ball taken away it is on. The
 * same for a point light. */
TEST(light_in_housing_plan_off)
{
    for (int point = 0; point < 2; ++point)
        for (int closed = 0; closed < 2; ++closed) {
            spc_scene *sc = housing_scene(closed, point);
            CHECK(sc != NULL);
            if (!sc)
                continue;
            spc_snee_plan p;
            spc_snee_plan_make(sc, "path", NULL, &p);
            if (closed)
                CHECK_MSG(!p.on && strstr(p.reason, "seen"), "%s light in a closed housing: %s (%s)",
                          point ? "point" : "sphere", p.setting, p.reason);
            else
                CHECK_MSG(p.on && !strncmp(p.setting, "angular:camera", 14),
                          "%s light, housing open to the ball: %s (%s)", point ? "point" : "sphere", p.setting,
                          p.reason);
            spc_scene_destroy(sc);
        }
    char path[1200];
    snprintf(path, sizeof path, "%s/scenes/indirect_lamp_glass.xml", spc_test_source_dir());
    spc_define defs[2] = {{"res", "8"}, {"integrator", "path"}};
    spc_scene *sc = NULL;
    spc_error err;
    CHECK_MSG(spc_scene_load(path, defs, 2, &sc, &err) == SPC_OK, "%s", err.msg);
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(sc, sc->integrator.type, sc->integrator.specular_nee, &p);
    CHECK_MSG(!p.on && p.casters == 1 && strstr(p.reason, "seen"), "indirect_lamp_glass: %s (%s)", p.setting, p.reason);
    char ran[SPC_SPECULAR_NEE_MAX];
    spc_film *img = render_ran(sc, "path", NULL, 4, 61, ran);
    CHECK_MSG(img && !strcmp(ran, "none"), "indirect_lamp_glass ran %s", ran);
    spc_film_destroy(img);
    spc_scene_destroy(sc);
}

/* scenes/caustic_sdf_torus.xml (a glass SDF torus under a small light): the plan is on, with the
 * query from the camera in every sample (the torus's chains go to the randomized attempts, so no
 * roulette on that query) and the SDF left to the solver. Its one-pixel tails were measured against
 * the variants a plan rule could pick (no query from the camera, no longer chains, chains of one
 * vertex, first=1, receivers=1, a smaller mispsi): none of them lowered the mean relMSE or the
 * worst pixel's share at equal CPU time, and the default beat none over 24 seeds
 * (bench/RESULTS.md, "Torus: the plan"). Under its small light the light guides' chains go to
 * light tracing too (ltguide), the longer chains' pass is off (nolong, snee_plan.h), and the light
 * seen through the torus from the camera takes the camera-side split (camsplit), whose rays also
 * sample the floor behind the torus once (camrecv), the torus's caustics go to light tracing
 * too (ltcaus), and specular NEE from the pinhole looks for its chains of 3 and 4 vertices too,
 * on a quarter of its queries (camlong=0.25). */
TEST(sdf_torus_plan)
{
    spc_scene *sc = load_at("scenes/caustic_sdf_torus.xml", "8");
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(sc, sc->integrator.type, sc->integrator.specular_nee, &p);
    CHECK_MSG(p.on && p.automatic &&
                  !strcmp(p.setting, SPC_SNEE_PLAN_SETTING SPC_SNEE_PLAN_LIGHT_GUIDES SPC_SNEE_PLAN_CAMERA_SPLIT
                                         SPC_SNEE_PLAN_CAMERA_RECV SPC_SNEE_PLAN_SDF_LT SPC_SNEE_PLAN_CAMERA_LONG) &&
                  p.casters == 1 && p.receivers == 2 && p.light_sr > 0.0 && p.light_sr < 0.03,
              "caustic_sdf_torus: %s (%s, %g sr)", p.setting, p.reason, p.light_sr);
    spc_snee_params sp;
    CHECK(spc_snee_parse(p.setting, 2, &sp));
    /* no longer chains' pass: its counted 3- and 4-vertex chains on the torus were a tail */
    CHECK(sp.long_p == 0.0);
    /* the camera-side split: the light seen through the torus after a reflection inside it */
    CHECK(sp.cam_split && sp.cam_split_rays == 4);
    /* and its rays' one sample of the receiver behind the glass: light guides seen through the torus */
    CHECK(sp.cam_split_recv);
    /* the torus's caustics of the light by light tracing too */
    CHECK(sp.lt_caustic);
    /* the light seen through the torus after reflections inside its tube from the pinhole too */
    CHECK(sp.cam_long && sp.cam_long_p == 0.25);
    int sdf = 0;
    for (int i = 0; i < sc->nshapes; ++i)
        if (sc->shapes[i]->type == SPC_SHAPE_SDF) {
            ++sdf;
            CHECK(spc_snee_plan_method(&sp, sc->shapes[i]) == SPC_SNEE_METHOD_SOLVER);
        }
    CHECK(sdf == 1);
    spc_scene_destroy(sc);
}

/* scenes/sdf_shapes_csg.xml (a glass box minus a sphere and a mirror capsule, SDFs): the plan is
 * off, since the glass caster's surface has creases, where the randomized attempts' solve
 * probability is tiny and the trial counts' tail held the default's error (bench/RESULTS.md, "CSG:
 * the plan"); the smooth SDFs (the capsule, the torus of caustic_sdf_torus.xml) have none. */
TEST(sdf_csg_plan_off)
{
    spc_scene *sc = load_at("scenes/sdf_shapes_csg.xml", "8");
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(sc, sc->integrator.type, sc->integrator.specular_nee, &p);
    CHECK_MSG(!p.on && p.automatic && !strcmp(p.setting, "none") && p.casters == 2 &&
                  strstr(p.reason, "SDF with creases") != NULL,
              "sdf_shapes_csg: %s (%s)", p.setting, p.reason);
    int creased = 0, smooth = 0;
    for (int i = 0; i < sc->nshapes; ++i) {
        const spc_shape *s = sc->shapes[i];
        if (s->type != SPC_SHAPE_SDF)
            continue;
        if (!strcmp(s->id, "glass_csg") || !strcmp(s->id, "half_torus") || !strcmp(s->id, "pillar")) {
            CHECK_MSG(spc_sdf_has_creases(s->sdf), "%s has creases", s->id);
            ++creased;
        } else if (!strcmp(s->id, "blob") || !strcmp(s->id, "mirror_capsule")) {
            CHECK_MSG(!spc_sdf_has_creases(s->sdf), "%s is smooth", s->id);
            ++smooth;
        }
    }
    CHECK(creased == 3 && smooth == 2);
    /* an explicit setting is used as given */
    spc_snee_plan_make(sc, sc->integrator.type, SPC_SNEE_PLAN_SETTING, &p);
    CHECK(p.on && !strcmp(p.setting, SPC_SNEE_PLAN_SETTING));
    spc_scene_destroy(sc);
}

/* The triangle glass ball (bench/check/glass_ball_mesh.xml, a tessellated sphere: fit_seeds.h) gets
 * the setting with the first receiver's query at probability 0.15 where the ball looks small and the
 * query from the camera on one camera sample in ten (SPC_SNEE_PLAN_SETTING_BALLS), and under its
 * small square light the light-traced caustics (SPC_SNEE_PLAN_AREA_LIGHTS, path only); the same
 * scene's ball as an analytic sphere keeps its own roulette (SPC_SNEE_PLAN_SETTING or its camera
 * fraction). */
TEST(tessellated_ball_plan)
{
    spc_scene *sc = load_at("bench/check/glass_ball_mesh.xml", "8");
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(sc, "path", NULL, &p);
    spc_snee_params sp;
    CHECK_MSG(p.on && !strncmp(p.setting, SPC_SNEE_PLAN_SETTING_BALLS, strlen(SPC_SNEE_PLAN_SETTING_BALLS)) &&
                  strstr(p.setting, SPC_SNEE_PLAN_AREA_LIGHTS) && spc_snee_parse(p.setting, 2, &sp) &&
                  sp.first_p == 0.15 && sp.later_p == 0.1 && sp.camera && sp.camera_p == 0.1 && sp.lt_caustic,
              "glass_ball_mesh: %s (%s)", p.setting, p.reason);
    /* not for bdpt, whose own light tracing makes these paths */
    spc_snee_plan_make(sc, "bdpt", NULL, &p);
    CHECK_MSG(p.on && !strstr(p.setting, "ltcaus"), "glass_ball_mesh, bdpt: %s", p.setting);
    spc_scene_destroy(sc);
    sc = load_at("scenes/caustic_glass_sphere.xml", "8");
    if (!sc)
        return;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && glass_setting(p.setting), "caustic_glass_sphere: %s", p.setting);
    spc_scene_destroy(sc);
}

/* Where every caster is a mirror, one whose chains go to the randomized solver (the mirror bowl,
 * bench/check/mirror_bowl.xml, a triangle mesh with vertex normals) gets the query at every first
 * receiver (SPC_SNEE_PLAN_SETTING_SOLVED_MIRRORS: no first=P roulette, whose P in the query's side of
 * MIS left BSDF-sampled hits of the light through the bowl near weight 1); mirrors enumerated
 * exactly (the mirror ring's cylinder) keep the roulette and make the query from the camera by
 * roulette too (SPC_SNEE_PLAN_SETTING_MIRRORS), and under its small light light tracing
 * (SPC_SNEE_PLAN_CYLINDER_LT); the bowl's setting has no query from the camera. */
TEST(solved_mirror_plan_no_first_roulette)
{
    static const struct {
        const char *scene, *setting;
        double first_p;
        bool camera;
    } cases[] = {
        {"bench/check/mirror_bowl.xml", SPC_SNEE_PLAN_SETTING_SOLVED_MIRRORS, 1.0, false},
        {"scenes/caustic_mirror_ring.xml", SPC_SNEE_PLAN_SETTING_MIRRORS SPC_SNEE_PLAN_CYLINDER_LT, 0.1, true},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_scene *sc = load_at(cases[i].scene, "8");
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        spc_snee_params sp;
        const size_t n = strlen(p.setting), tail = strlen(cases[i].setting);
        CHECK_MSG(p.on && n >= tail && !strcmp(p.setting + n - tail, cases[i].setting) &&
                      spc_snee_parse(p.setting, 2, &sp) && sp.first_p == cases[i].first_p && sp.later_p == 0.1 &&
                      sp.camera == cases[i].camera && (!sp.camera || sp.camera_p < 1.0),
                  "%s: %s (%s)", cases[i].scene, p.setting, p.reason);
        spc_scene_destroy(sc);
    }
}

/* Flat mirrors (a conductor rectangle) are enumerated through their flat faces (flat_chains.h) and
 * take the mirrors' setting, not the flat glass's: a tilted mirror alone under a small light gets
 * the query from the camera by roulette and light tracing, nothing of the slab rules (no longer
 * chains, no 3-4-vertex shares); a glass ball on a mirror gets the glass ball's setting, without the
 * slab rules' 3-5-vertex shares and queries at every first receiver, and with the longer chains'
 * pass on a larger share of the calls (SPC_SNEE_PLAN_BALL_FLAT_MIRROR_LONG: the chains through the
 * ball and off the mirror) and the query from the camera on at least 0.3 of the samples, as does a
 * mirror ball on the mirror; the mirror alone gets neither, nor does a glass cube beside a mirror. */
TEST(flat_mirror_plan)
{
    static const char *const scenes[3] = {"bench/check/mirror_tilt.xml", "bench/check/ball_mirror_floor.xml",
                                          "bench/check/mirrorball_mirror_floor.xml"};
    for (int i = 0; i < 3; ++i) {
        spc_scene *sc = load_at(scenes[i], "8");
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        spc_snee_params sp;
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp), "%s: %s (%s)", scenes[i], p.setting, p.reason);
        int flat = 0;
        const spc_chain_casters *cs = spc_chain_casters_of(sc, false);
        for (int j = 0; cs && j < cs->n; ++j) {
            const spc_shape *s = sc->shapes[cs->idx[j]];
            if (s->bsdf && s->bsdf->type == SPC_BSDF_CONDUCTOR && s->type == SPC_SHAPE_MESH) {
                CHECK(spc_snee_plan_method(&sp, s) == SPC_SNEE_METHOD_FLAT);
                ++flat;
            }
        }
        CHECK(flat == 1);
        CHECK_MSG(sp.camera && sp.camera_p < 1.0 && sp.first_p == 0.1 && sp.later_p == 0.1 &&
                      !strstr(p.setting, "flat34") && !strstr(p.setting, "flat5") && !strstr(p.setting, "first=1"),
                  "%s: %s", scenes[i], p.setting);
        /* beside the glass or mirror ball the query from the camera on at least its share, and the
         * longer chains on theirs; neither for the mirror alone (its camera share is the mirrors' rule) */
        CHECK_MSG(i == 0 || sp.camera_p >= SPC_SNEE_PLAN_BALL_FLAT_MIRROR_CAMERA, "%s: %s", scenes[i], p.setting);
        spc_snee_params lw;
        CHECK(spc_snee_parse(i == 0 ? "angular:later=0.1" : "angular:later=0.1" SPC_SNEE_PLAN_BALL_FLAT_MIRROR_LONG, 2,
                             &lw));
        CHECK_MSG(sp.long_p == lw.long_p && sp.long_max == lw.long_max &&
                      (i == 0) == !strstr(p.setting, SPC_SNEE_PLAN_BALL_FLAT_MIRROR_LONG),
                  "%s: %s (long %g, %d; want %g, %d)", scenes[i], p.setting, sp.long_p, sp.long_max, lw.long_p,
                  lw.long_max);
        if (i == 0) {
            /* the mirrors' setting, then light tracing (flat mirrors alone under a small light) */
            char want[256];
            snprintf(want, sizeof want, "%s%s", SPC_SNEE_PLAN_SETTING_MIRRORS, SPC_SNEE_PLAN_FLAT_MIRRORS_LT);
            const size_t n = strlen(p.setting), tail = strlen(want);
            CHECK_MSG(n >= tail && !strcmp(p.setting + n - tail, want) && sp.lt_caustic, "%s: %s", scenes[i],
                      p.setting);
        }
        spc_scene_destroy(sc);
    }
    /* a glass cube beside a flat mirror: their mixed chains are the flat enumeration's, so the
     * glass ball's rule (the camera query's share) is not applied */
    spc_scene *sc = load_at("bench/check/slab_mirror.xml", "64"); /* a film where its own Q is under 0.3 */
    if (sc) {
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        spc_snee_params sp;
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp) && sp.camera_p < SPC_SNEE_PLAN_BALL_FLAT_MIRROR_CAMERA &&
                      !strstr(p.setting, SPC_SNEE_PLAN_BALL_FLAT_MIRROR_LONG),
                  "slab_mirror: %s (%s)", p.setting, p.reason);
        spc_scene_destroy(sc);
    }
}

/* A glass ball resting on a flat mirror under a light of more than
 * SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT_SR (bench/check/ball_mirror_biglight.xml, 0.018 sr) takes the
 * camera-side split on top of the ball-and-mirror setting (the query from the camera on 0.3 of the
 * samples, the longer chains on half of the calls); a ball under a light as large beside an upright
 * mirror that stands apart from it (the two other scenes of that name, 0.016 sr) does not, nor does
 * the same scene under the smaller light (ball_mirror_floor, 0.005 sr), the mirror ball on the
 * mirror, a ball beside an upright mirror under a small light, or bdpt. */
TEST(ball_flat_mirror_large_light_split)
{
    static const struct {
        const char *scene, *integrator;
        bool split;
    } cases[] = {
        {"bench/check/ball_mirror_biglight.xml", "path", true},
        {"bench/check/ball_mirror_wall_biglight.xml", "path", false},
        {"bench/check/flat_mirror_ball_focus_biglight.xml", "path", false},
        {"bench/check/ball_mirror_biglight.xml", "bdpt", false},
        {"bench/check/ball_mirror_floor.xml", "path", false},
        {"bench/check/mirrorball_mirror_floor.xml", "path", false},
        {"bench/check/ball_mirror_wall.xml", "path", false},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_scene *sc = load_at(cases[i].scene, "16");
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        spc_snee_params sp;
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp), "%s: %s (%s)", cases[i].scene, p.setting, p.reason);
        CHECK_MSG((p.light_sr > SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT_SR) ==
                      (strstr(cases[i].scene, "biglight") != NULL),
                  "%s: light %g sr", cases[i].scene, p.light_sr);
        CHECK_MSG(sp.cam_split == cases[i].split && (!cases[i].split || strstr(p.setting, SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT)),
                  "%s, %s: %s", cases[i].scene, cases[i].integrator, p.setting);
        if (cases[i].split)
            CHECK_MSG(sp.camera && sp.camera_p >= SPC_SNEE_PLAN_BALL_FLAT_MIRROR_CAMERA &&
                          strstr(p.setting, SPC_SNEE_PLAN_BALL_FLAT_MIRROR_LONG),
                      "%s: %s", cases[i].scene, p.setting);
        spc_scene_destroy(sc);
    }
}

/* A ball beside a flat mirror under small area lights (at most SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT_SR)
 * takes light tracing's joins through the mirror toward the pinhole (ltslab) on top of the ball's and
 * the mirror's setting: the glass ball on the mirror, beside an upright mirror and seen in it; not
 * under the large lights, nor for bdpt, nor the mirror ball (no light tracing), nor the mirror alone. */
TEST(ball_flat_mirror_small_light_joins)
{
    static const struct {
        const char *scene, *integrator;
        bool joins;
    } cases[] = {
        {"bench/check/ball_mirror_floor.xml", "path", true},
        {"bench/check/ball_mirror_wall.xml", "path", true},
        {"bench/check/caustic_in_mirror.xml", "path", true},
        {"bench/check/flat_mirror_ball_focus.xml", "path", true},
        {"bench/check/ball_mirror_floor.xml", "bdpt", false},
        {"bench/check/ball_mirror_biglight.xml", "path", false},
        {"bench/check/ball_mirror_wall_biglight.xml", "path", false},
        {"bench/check/mirrorball_mirror_floor.xml", "path", false},
        {"bench/check/mirror_tilt.xml", "path", false},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_scene *sc = load_at(cases[i].scene, "16");
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        spc_snee_params sp;
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp), "%s: %s (%s)", cases[i].scene, p.setting, p.reason);
        CHECK_MSG(sp.lt_slab == cases[i].joins &&
                      (!cases[i].joins || (sp.lt_caustic && p.light_sr <= SPC_SNEE_PLAN_BALL_FLAT_MIRROR_SPLIT_SR &&
                                           strstr(p.setting, SPC_SNEE_PLAN_BALL_FLAT_MIRROR_LONG))),
                  "%s, %s: %s", cases[i].scene, cases[i].integrator, p.setting);
        spc_scene_destroy(sc);
    }
}

/* Caustic guiding at receivers and the longer chains with probability 0.2, up to 4 vertices (on the
 * sphere up to 6 on a share 0.03 of the calls), in a
 * room where a glass caster is an analytic sphere small enough for a cone (snee_plan.h,
 * SPC_SNEE_PLAN_ROOM_GLASS_BALL): on in path's default on the demo, not in volpath's nor bdpt's, not
 * in the open (the glass-ball caustic, the mirror ring, the pool). */
TEST(recv_guide_with_glass_balls)
{
    static const struct {
        const char *scene, *integrator;
        bool guided;
        double long_p;
        int long_max; /* 0: unset (SPC_SNEE_LONG_MAX) */
        double sphere_long_p;
    } cases[] = {
        {"scenes/demo.xml", "path", true, 0.2, 4, 0.03},
        {"scenes/demo.xml", "volpath", false, 0.1, 0, 0.0},
        {"scenes/demo.xml", "bdpt", false, 0.1, 0, 0.0},
        {"scenes/caustic_glass_sphere.xml", "path", false, 0.1, 0, 0.0},
        {"scenes/caustic_mirror_ring.xml", "path", false, 0.1, 0, 0.0},
        {"scenes/caustic_pool.xml", "path", false, 0.1, 0, 0.0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_scene *sc = load_at(cases[i].scene, "16");
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        spc_snee_params sp;
        bool parsed = p.on && spc_snee_parse(p.setting, 2, &sp);
        CHECK_MSG(parsed && sp.recv_guide == (cases[i].guided ? 0.1 : 0.0) && sp.long_p == cases[i].long_p &&
                      sp.long_max == cases[i].long_max && sp.sphere_long_p == cases[i].sphere_long_p,
                  "%s, %s: %s", cases[i].scene, cases[i].integrator, p.setting);
        spc_scene_destroy(sc);
    }
}

/* The demo's plan with the longer chains up to 4 vertices agrees with the same plan up to 6 (the
 * pass's own top): the 5- and 6-vertex chains the pass no longer makes are BSDF sampling's alone
 * (weighed 1 there) but on the sphere, which sphlong's share enumerates, so the image stays the same
 * estimate. Per-pixel z-test on 99% of the pixels and
 * the image means within 4 standard errors. */
TEST(demo_long_max)
{
    spc_scene *sc = load_at("scenes/demo.xml", "16");
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(sc, "path", NULL, &p);
    char top6[SPC_SPECULAR_NEE_MAX];
    const char *cut = strstr(p.setting, ",longmax=4");
    CHECK_MSG(p.on && cut && cut[strlen(",longmax=4")] == '\0', "demo: %s", p.setting);
    if (cut && (size_t)(cut - p.setting) < sizeof top6) {
        snprintf(top6, sizeof top6, "%.*s", (int)(cut - p.setting), p.setting);
        int q = spc_test_quick() ? 2 : 1;
        CHECK(tu_settings_agree(sc, p.setting, 1024 / q, top6, 1024 / q, 71, "demo: longmax=4 vs 6"));
    }
    spc_scene_destroy(sc);
}

/* scenes/conic_bunny.xml (a closed, irregular glass mesh with vertex normals that no sphere fits)
 * renders without specular NEE by default: its rarer two-refraction chains' trial counts were the
 * image's fireflies (at equal CPU time the plan's angular 5.4x and the scene's former conic 100x the
 * relMSE of none; bench/RESULTS.md, "The default against none on every caster scene"). Closed meshes
 * a sphere fits (the triangle glass ball) and open ones (newton_pool's water surface) keep it, and
 * an explicit setting is used as given. */
TEST(closed_glass_mesh_plan_off)
{
    spc_scene *sc = load_at("scenes/conic_bunny.xml", "8");
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(sc, sc->integrator.type, sc->integrator.specular_nee, &p);
    CHECK_MSG(!p.on && p.automatic && !strcmp(p.setting, "none") && p.casters == 1 &&
                  strstr(p.reason, "closed glass mesh") != NULL,
              "conic_bunny: %s (%s)", p.setting, p.reason);
    spc_snee_plan_make(sc, sc->integrator.type, "conic", &p);
    CHECK(p.on && !strcmp(p.setting, "conic"));
    spc_scene_destroy(sc);
    const char *on[] = {"bench/check/glass_ball_mesh.xml", "scenes/newton_pool.xml"};
    for (int i = 0; i < 2; ++i) {
        sc = load_at(on[i], "8");
        if (!sc)
            return;
        spc_snee_plan_make(sc, sc->integrator.type, sc->integrator.specular_nee, &p);
        CHECK_MSG(p.on && p.automatic, "%s: %s (%s)", on[i], p.setting, p.reason);
        spc_scene_destroy(sc);
    }
}

/* volpath on a tessellated glass ball (scenes/medium_glass.xml: a glass icosphere filled with a
 * scattering medium, its receivers medium points) weighs the ball's chains with the stand-in psi
 * (SPC_SNEE_PLAN_SETTING_BALLS_VOLPATH, nosolvemis: no real solve probability, no ball pass; mispsi
 * 0.3) and
 * seeds most randomized attempts from the phase function (SPC_SNEE_PLAN_VOLPATH_PHASE_SEEDS), with
 * the query at a path's first medium receiver by first=0.1's roulette; path on the same scene keeps
 * SPC_SNEE_PLAN_SETTING_BALLS, without phase seeds, with the light-traced caustics of its small
 * light (SPC_SNEE_PLAN_AREA_LIGHTS). */
TEST(volpath_ball_plan)
{
    spc_scene *sc = load_at("scenes/medium_glass.xml", "8");
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(sc, sc->integrator.type, sc->integrator.specular_nee, &p);
    spc_snee_params sp;
    CHECK_MSG(!strcmp(sc->integrator.type, "volpath") && p.on && p.automatic &&
                  !strcmp(p.setting, SPC_SNEE_PLAN_SETTING_BALLS_VOLPATH SPC_SNEE_PLAN_VOLPATH_PHASE_SEEDS) &&
                  spc_snee_parse(p.setting, 2, &sp) && !sp.solve_mis && sp.fit_seeds && sp.camera &&
                  sp.first_p == 0.1 && sp.later_p == 0.1 && sp.seed == SPC_SNEE_SEED_CONE && sp.phase_seeds == 0.8 &&
                  sp.mis_solve == 0.3 && !sp.tight_share,
              "medium_glass: %s (%s)", p.setting, p.reason);
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && !strcmp(p.setting, SPC_SNEE_PLAN_SETTING_BALLS SPC_SNEE_PLAN_AREA_LIGHTS) &&
                  spc_snee_parse(p.setting, 2, &sp) && sp.solve_mis && sp.phase_seeds == 0.0 && !sp.tight_share,
              "medium_glass with path: %s", p.setting);
    spc_scene_destroy(sc);
}

/* volpath with a tessellated glass ball that sits in a fog (bench/check/medium_fog_ball.xml: the
 * ball's outside is the fog, its inside empty) leaves specular NEE off; the same ball filled with
 * the medium (medium_glass, above) keeps it, and so does path on the fog ball (the fog's rule is
 * volpath's). */
TEST(volpath_ball_in_fog_plan_off)
{
    spc_scene *sc = load_at("bench/check/medium_fog_ball.xml", "8");
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_plan_make(sc, sc->integrator.type, sc->integrator.specular_nee, &p);
    CHECK_MSG(!strcmp(sc->integrator.type, "volpath") && !p.on && p.automatic && !strcmp(p.setting, "none") &&
                  strstr(p.reason, "sit in a medium"),
              "fog ball: %s (%s)", p.setting, p.reason);
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on, "fog ball with path: %s (%s)", p.setting, p.reason);
    spc_scene_destroy(sc);
}

/* A water surface (a glass normal-mapped plane: scenes/caustic_pool.xml; triangles:
 * scenes/newton_pool.xml) with the camera and the light above it: path's plan has no query from the
 * camera (from there the plane's chains are the
 * light's glints, which the path tracer's emission splitting traces at every camera sample;
 * SPC_SNEE_PLAN_SETTING_WATER); over the normal-mapped plane under its small sphere light, light
 * tracing through the water (SPC_SNEE_PLAN_WATER_LT), not over the triangles (their chains are the
 * randomized solver's) nor for volpath and bdpt, nor under a light of 0.028 sr. volpath and bdpt, which do not split, keep the query, and so does
 * path with the light under the water, where chains from the camera refract to it. */
TEST(water_plane_plan_no_camera_query)
{
    spc_scene *sc = load_at("scenes/caustic_pool.xml", "16");
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_params sp;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && !strcmp(p.setting, SPC_SNEE_PLAN_SETTING_WATER SPC_SNEE_PLAN_WATER_LT) &&
                  spc_snee_parse(p.setting, 2, &sp) && !sp.camera && sp.exact && sp.lt_caustic &&
                  sp.deep_split == 8,
              "pool, path: %s (%s)", p.setting, p.reason);
    printf("    pool, path: %s\n", p.setting);
    static const char *const others[] = {"volpath", "bdpt"};
    for (int i = 0; i < 2; ++i) {
        spc_snee_plan_make(sc, others[i], NULL, &p);
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp) && sp.camera && !sp.lt_caustic, "pool, %s: %s", others[i],
                  p.setting);
    }
    spc_scene_destroy(sc);
    /* a water surface made of triangles (the randomized solver's), the camera and the light above
     * every triangle's plane: the same */
    sc = load_at("scenes/newton_pool.xml", "16");
    if (!sc)
        return;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && !strcmp(p.setting, SPC_SNEE_PLAN_SETTING_WATER) && spc_snee_parse(p.setting, 2, &sp) &&
                  !sp.camera && sp.deep_split == 0,
              "newton_pool, path: %s (%s)", p.setting, p.reason);
    printf("    newton_pool, path: %s\n", p.setting);
    for (int i = 0; i < 2; ++i) {
        spc_snee_plan_make(sc, others[i], NULL, &p);
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp) && sp.camera, "newton_pool, %s: %s", others[i], p.setting);
    }
    spc_scene_destroy(sc);
    /* the same pool with the light under the water */
    char path[1200];
    snprintf(path, sizeof path, "%s/scenes/caustic_pool.xml", spc_test_source_dir());
    FILE *fp = fopen(path, "rb");
    CHECK(fp != NULL);
    if (!fp)
        return;
    static char text[16384], moved[20000];
    size_t n = fread(text, 1, sizeof text - 1, fp);
    fclose(fp);
    text[n] = 0;
    const char *light = "x=\"0.6\" y=\"3\" z=\"-0.8\"", *map = "textures/waves_normal.png";
    char *a = strstr(text, light), *b = strstr(text, map);
    CHECK(a && b && a < b);
    if (!(a && b && a < b))
        return;
    *a = 0;
    *b = 0;
    snprintf(moved, sizeof moved, "%sx=\"0.6\" y=\"-0.5\" z=\"-0.8\"%s%s/scenes/%s%s", text, a + strlen(light),
             spc_test_source_dir(), map, b + strlen(map));
    spc_error err;
    sc = NULL;
    CHECK_MSG(load_text(moved, &sc, &err) == SPC_OK, "moved light: %s", err.msg);
    if (!sc)
        return;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp) && sp.camera, "light under the water, path: %s (%s)", p.setting,
              p.reason);
    printf("    light under the water, path: %s\n", p.setting);
    spc_scene_destroy(sc);
    /* the pool under a larger light (radius 0.3: 0.028 sr from the water's centre): no light tracing */
    fp = fopen(path, "rb");
    CHECK(fp != NULL);
    if (!fp)
        return;
    n = fread(text, 1, sizeof text - 1, fp);
    fclose(fp);
    text[n] = 0;
    const char *radius = "name=\"radius\" value=\"0.15\"";
    a = strstr(text, radius);
    b = strstr(text, map);
    CHECK(a && b && a < b);
    if (!(a && b && a < b))
        return;
    *a = 0;
    *b = 0;
    snprintf(moved, sizeof moved, "%sname=\"radius\" value=\"0.3\"%s%s/scenes/%s%s", text, a + strlen(radius),
             spc_test_source_dir(), map, b + strlen(map));
    sc = NULL;
    CHECK_MSG(load_text(moved, &sc, &err) == SPC_OK, "larger light: %s", err.msg);
    if (!sc)
        return;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && !strcmp(p.setting, SPC_SNEE_PLAN_SETTING_WATER), "larger light, path: %s (%s)", p.setting,
              p.reason);
    printf("    larger light, path: %s\n", p.setting);
    spc_scene_destroy(sc);
}

/* scenes/caustic_pool.xml with each from[i] replaced by to[i] (each found once, in order) and its
 * normal map's path made absolute, loaded; NULL (and a failed check) where that fails. */
static spc_scene *pool_variant(const char *const *from, const char *const *to, int n)
{
    static const char *const map = "textures/waves_normal.png";
    char path[1200];
    snprintf(path, sizeof path, "%s/scenes/caustic_pool.xml", spc_test_source_dir());
    FILE *fp = fopen(path, "rb");
    CHECK(fp != NULL);
    if (!fp)
        return NULL;
    static char text[24000], out[24000];
    size_t len = fread(text, 1, sizeof text - 1, fp);
    fclose(fp);
    text[len] = 0;
    char mapto[1300];
    snprintf(mapto, sizeof mapto, "%s/scenes/%s", spc_test_source_dir(), map);
    for (int i = 0; i <= n; ++i) {
        const char *f = i < n ? from[i] : map, *t = i < n ? to[i] : mapto;
        char *a = strstr(text, f);
        CHECK_MSG(a != NULL, "caustic_pool.xml has no %s", f);
        if (!a)
            return NULL;
        size_t head = (size_t)(a - text), lt = strlen(t), lf = strlen(f), tail = strlen(a + lf);
        CHECK(head + lt + tail < sizeof out);
        if (!(head + lt + tail < sizeof out))
            return NULL;
        memcpy(out, text, head);
        memcpy(out + head, t, lt);
        memcpy(out + head + lt, a + lf, tail + 1);
        memcpy(text, out, head + lt + tail + 1);
    }
    spc_scene *sc = NULL;
    spc_error err;
    CHECK_MSG(load_text(text, &sc, &err) == SPC_OK, "pool variant: %s", err.msg);
    return sc;
}

/* The pool with the camera under the water (every caster a normal-mapped water plane, the pinhole on
 * its far side from the small sphere light): path's plan traces the light through the water and
 * joins it to the pinhole without the query from the camera (SPC_SNEE_PLAN_SETTING_UNDER_WATER);
 * volpath and bdpt keep theirs; with the camera above the water or the light under it too, or under
 * a light of 0.11 sr (tests/data/pool_under_water.xml), the plan is what it was. */
TEST(water_plane_plan_camera_under_water)
{
    static const char *const cam_from[] = {"origin=\"0, 2.6, 2.4\" target=\"0, -0.8, 0\""};
    static const char *const cam_to[] = {"origin=\"0, -0.3, 1.3\" target=\"0, -0.9, -0.8\""};
    spc_scene *sc = pool_variant(cam_from, cam_to, 1);
    if (!sc)
        return;
    spc_snee_plan p;
    spc_snee_params sp;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && !strcmp(p.setting, SPC_SNEE_PLAN_SETTING_UNDER_WATER) && spc_snee_parse(p.setting, 2, &sp) &&
                  !sp.camera && sp.exact && sp.lt_caustic,
              "camera under the water, path: %s (%s)", p.setting, p.reason);
    printf("    camera under the water, path: %s\n", p.setting);
    static const char *const others[] = {"volpath", "bdpt"};
    for (int i = 0; i < 2; ++i) {
        spc_snee_plan_make(sc, others[i], NULL, &p);
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp) && !sp.lt_caustic, "camera under the water, %s: %s",
                  others[i], p.setting);
    }
    spc_scene_destroy(sc);
    /* the light under the water too: the camera and the light on one side */
    static const char *const both_from[] = {"x=\"0.6\" y=\"3\" z=\"-0.8\"", cam_from[0]};
    static const char *const both_to[] = {"x=\"0.6\" y=\"-0.5\" z=\"-0.8\"", cam_to[0]};
    sc = pool_variant(both_from, both_to, 2);
    if (!sc)
        return;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && strcmp(p.setting, SPC_SNEE_PLAN_SETTING_UNDER_WATER) && spc_snee_parse(p.setting, 2, &sp) &&
                  !sp.lt_caustic,
              "camera and light under the water, path: %s (%s)", p.setting, p.reason);
    printf("    camera and light under the water, path: %s\n", p.setting);
    spc_scene_destroy(sc);
    /* the camera above the water: the water's plan */
    sc = pool_variant(NULL, NULL, 0);
    if (!sc)
        return;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(p.on && !strcmp(p.setting, SPC_SNEE_PLAN_SETTING_WATER SPC_SNEE_PLAN_WATER_LT), "pool, path: %s (%s)",
              p.setting, p.reason);
    spc_scene_destroy(sc);
    /* a light of 0.11 sr: none */
    sc = load_at("tests/data/pool_under_water.xml", "16");
    if (!sc)
        return;
    spc_snee_plan_make(sc, "path", NULL, &p);
    CHECK_MSG(!p.on && !strcmp(p.setting, "none"), "pool_under_water, path: %s (%s)", p.setting, p.reason);
    spc_scene_destroy(sc);
}

/* Glass slabs (cubes scaled thin, their chains enumerated through flat faces) on a floor under a
 * square light whose size is given: a slab and the light of random caustic scene 435, a second slab
 * beside it, or a mirror ball, where asked. */
/* An 8x8 path scene looked at from above and to the side: a diffuse floor (half size 4) and then
 * `objects` (casters and lights, Mitsuba XML). */
static void floor_scene_text(char *text, size_t n, const char *objects)
{
    snprintf(text, n,
             "<scene version=\"3.0.0\">"
             "<integrator type=\"path\"><integer name=\"max_depth\" value=\"8\"/></integrator>"
             "<sensor type=\"perspective\"><float name=\"fov\" value=\"35\"/>"
             "<transform name=\"to_world\"><lookat origin=\"2.2, 3.5, 1.0\" target=\"0, 0.3, 0\" "
             "up=\"0, 1, 0\"/></transform><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/>"
             "<integer name=\"height\" value=\"8\"/></film></sensor>"
             "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"4\"/><rotate x=\"1\" "
             "angle=\"-90\"/></transform><bsdf type=\"diffuse\"/></shape>"
             "%s</scene>",
             objects);
}

static spc_scene *slab_scene(double light_scale, bool two, bool slab, bool mirror, bool ball)
{
    char text[3584];
    snprintf(text, sizeof text,
             "<scene version=\"3.0.0\">"
             "<integrator type=\"path\"><integer name=\"max_depth\" value=\"6\"/></integrator>"
             "<sensor type=\"perspective\"><float name=\"fov\" value=\"31.5\"/>"
             "<transform name=\"to_world\"><lookat origin=\"2.209, 3.502, 0.971\" target=\"0, 0.3, 0\" "
             "up=\"0, 1, 0\"/></transform>"
             "<sampler type=\"independent\"><integer name=\"sample_count\" value=\"4\"/></sampler>"
             "<film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/><integer name=\"height\" "
             "value=\"8\"/></film></sensor>"
             "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"4\"/><rotate x=\"1\" "
             "angle=\"-90\"/></transform><bsdf type=\"diffuse\"/></shape>"
             "%s%s%s%s"
             "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"%g\"/><lookat "
             "origin=\"-0.632, 1.658, 2.044\" target=\"0, 0, 0\" up=\"0, 1, 0.01\"/></transform>"
             "<emitter type=\"area\"><rgb name=\"radiance\" value=\"100\"/></emitter></shape></scene>",
             slab ? "<shape type=\"cube\"><transform name=\"to_world\"><scale x=\"0.465\" y=\"0.112\" "
                    "z=\"0.369\"/><rotate x=\"1\" angle=\"1.8\"/><rotate y=\"1\" angle=\"47.9\"/><translate "
                    "x=\"0.885\" y=\"0.387\" z=\"-1.075\"/></transform><bsdf type=\"dielectric\"><float "
                    "name=\"int_ior\" value=\"1.8\"/></bsdf></shape>"
                  : "",
             two ? "<shape type=\"cube\"><transform name=\"to_world\"><scale x=\"0.3\" y=\"0.08\" "
                   "z=\"0.3\"/><rotate x=\"1\" angle=\"10\"/><translate x=\"-0.3\" y=\"0.5\" "
                   "z=\"-0.6\"/></transform><bsdf type=\"dielectric\"><float name=\"int_ior\" "
                   "value=\"1.5\"/></bsdf></shape>"
                 : "",
             mirror ? "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0.46\" z=\"-0.16\"/><float "
                      "name=\"radius\" value=\"0.46\"/><bsdf type=\"conductor\"/></shape>"
                    : "",
             ball ? "<shape type=\"sphere\"><point name=\"center\" x=\"-0.9\" y=\"0.35\" z=\"0.6\"/><float "
                    "name=\"radius\" value=\"0.35\"/><bsdf type=\"dielectric\"/></shape>"
                  : "",
             light_scale);
    spc_scene *sc = NULL;
    spc_error err;
    CHECK_MSG(load_text(text, &sc, &err) == SPC_OK, "slab scene: %s", err.msg);
    return sc;
}

/* Slabs under small area lights, for path: light tracing makes their caustics too (",ltcaus") and
 * the flat enumeration's 3- and 4-vertex chains run on a share of the calls (flat34=0.3), the
 * 5-vertex ones too where the cost rule put them on every call (flat5=0.3), the path's track and
 * light tracing's flat chains up to 8 vertices (longmax=8); not for volpath or
 * bdpt, and not where no caster is flat (the glass sphere keeps every chain at every call). */
TEST(slab_plan_light_tracing)
{
    static const struct {
        double scale;
        const char *integrator;
        int want; /* 0 no light tracing, 1 ltcaus with flat34, 2 with flat34 and flat5 */
    } cases[] = {
        {0.125, "path", 2},
        {0.05, "path", 1},
        {0.05, "volpath", 0},
        {0.05, "bdpt", 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_scene *sc = slab_scene(cases[i].scale, false, true, false, false);
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        spc_snee_params sp;
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp), "case %zu: %s (%s)", i, p.setting, p.reason);
        if (cases[i].want == 0)
            CHECK_MSG(!strstr(p.setting, "ltcaus") && sp.flat34_p == 1.0, "case %zu (%s): %s", i, cases[i].integrator,
                      p.setting);
        else
            CHECK_MSG(sp.lt_caustic && sp.flat34_p == 0.3 && sp.flat5_p == (cases[i].want == 2 ? 0.3 : 0.0) &&
                          sp.long_p > 0.0 && sp.long_max == 8,
                      "case %zu: %s", i, p.setting);
        spc_scene_destroy(sc);
    }
    spc_scene *sc = load_at("scenes/caustic_slabs_small_light.xml", "8");
    if (sc) {
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        CHECK_MSG(p.on && strstr(p.setting, SPC_SNEE_PLAN_AREA_LIGHTS SPC_SNEE_PLAN_FLAT_LT),
                  "caustic_slabs_small_light: %s", p.setting);
        spc_scene_destroy(sc);
    }
    /* a curved glass caster's plan keeps the query without the pilot */
    sc = load_at("scenes/caustic_glass_sphere.xml", "8");
    if (sc) {
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        CHECK_MSG(p.on && strstr(p.setting, "ltcaus") && !strstr(p.setting, "flat34"), "caustic_glass_sphere: %s",
                  p.setting);
        spc_scene_destroy(sc);
    }
}

/* Slabs under point lights (a sky besides), for path: light tracing makes their caustics too
 * (",ltcaus") and joins the receivers seen through a slab (SPC_SNEE_PLAN_FLAT_POINT_JOINS), and
 * without a mirror ball among the casters the flat enumeration makes its 3- and 4-vertex chains on a
 * share of its calls (SPC_SNEE_PLAN_FLAT_POINT_SHARE, flat34 below 1): on
 * bench/check/two_slabs_point_light.xml and on one slab under a point light and a sky (also beside a
 * mirror ring; beside a mirror ball without the share); not for volpath or bdpt, and not where a large area light is a
 * light too. The point light over the triangle glass ball has ltcaus by the ball's rule
 * (SPC_SNEE_PLAN_BALL_POINT_LIGHTS), for path only, without the joins (no flat caster). */
TEST(slab_plan_point_light_tracing)
{
    static const char *const lights[] = {
        "<emitter type=\"point\"><point name=\"position\" x=\"-0.6\" y=\"2.5\" z=\"1.9\"/><rgb "
        "name=\"intensity\" value=\"20\"/></emitter><emitter type=\"constant\"><rgb name=\"radiance\" "
        "value=\"0.02\"/></emitter>",
        "<emitter type=\"point\"><point name=\"position\" x=\"-0.6\" y=\"2.5\" z=\"1.9\"/><rgb "
        "name=\"intensity\" value=\"20\"/></emitter><shape type=\"rectangle\"><transform "
        "name=\"to_world\"><translate y=\"3\"/><rotate x=\"1\" angle=\"90\"/></transform><emitter "
        "type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>",
        "<emitter type=\"point\"><point name=\"position\" x=\"-0.6\" y=\"2.5\" z=\"1.9\"/><rgb "
        "name=\"intensity\" value=\"20\"/></emitter><shape type=\"sphere\"><point name=\"center\" "
        "x=\"0.9\" y=\"0.3\" z=\"-0.6\"/><float name=\"radius\" value=\"0.3\"/><bsdf "
        "type=\"conductor\"/></shape>",
        "<emitter type=\"point\"><point name=\"position\" x=\"-0.6\" y=\"2.5\" z=\"1.9\"/><rgb "
        "name=\"intensity\" value=\"20\"/></emitter><shape type=\"cylinder\"><float name=\"radius\" "
        "value=\"0.45\"/><point name=\"p0\" x=\"0.9\" y=\"0\" z=\"-0.6\"/><point name=\"p1\" x=\"0.9\" "
        "y=\"0.3\" z=\"-0.6\"/><bsdf type=\"twosided\"><bsdf type=\"conductor\"/></bsdf></shape>",
    };
    const int want[] = {2, 0, 1, 2}; /* 0 no light tracing, 1 ltcaus with the joins, 2 and the share */
    for (int i = 0; i < 4; ++i) {
        char text[2048];
        char objects[1536];
        snprintf(objects, sizeof objects,
                 "<shape type=\"cube\"><transform name=\"to_world\"><scale x=\"0.4\" y=\"0.06\" z=\"0.3\"/>"
                 "<rotate x=\"1\" angle=\"8\"/><translate y=\"0.6\"/></transform><bsdf type=\"dielectric\"/>"
                 "</shape>%s",
                 lights[i]);
        floor_scene_text(text, sizeof text, objects);
        spc_scene *sc = NULL;
        spc_error err;
        CHECK_MSG(load_text(text, &sc, &err) == SPC_OK, "slab scene %d: %s", i, err.msg);
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        spc_snee_params sp;
        bool parsed = spc_snee_parse(p.setting, 2, &sp);
        printf("  slab under %s: %s\n",
               i == 0   ? "a point light and a sky"
               : i == 1 ? "a point and an area light"
               : i == 2 ? "a point light, beside a mirror ball"
                        : "a point light, beside a mirror ring",
               p.setting);
        if (want[i] > 0)
            CHECK_MSG(p.on && parsed && sp.lt_caustic && sp.lt_slab &&
                          strstr(p.setting, SPC_SNEE_PLAN_FLAT_POINT_JOINS) &&
                          (want[i] == 2 ? sp.flat34_p < 1.0 && strstr(p.setting, SPC_SNEE_PLAN_FLAT_POINT_SHARE)
                                        : sp.flat34_p == 1.0),
                      "slab, point light (case %d): %s (%s)", i, p.setting, p.reason);
        else
            CHECK_MSG(!strstr(p.setting, "ltcaus") && !strstr(p.setting, "flat34") && !strstr(p.setting, "ltslab"),
                      "slab, point and area light: %s", p.setting);
        spc_scene_destroy(sc);
    }
    static const struct {
        const char *file, *integrator;
        bool want, share; /* ltcaus; with the slab joins and the flat share */
    } cases[] = {
        {"bench/check/two_slabs_point_light.xml", "path", true, true},
        {"bench/check/two_slabs_point_light.xml", "volpath", false, false},
        {"bench/check/two_slabs_point_light.xml", "bdpt", false, false},
        {"bench/check/point_light_ball_mesh.xml", "path", true, false},
        {"bench/check/point_light_ball_mesh.xml", "volpath", false, false},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_scene *sc = load_at(cases[i].file, "8");
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        spc_snee_params sp;
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp), "%s, %s: %s (%s)", cases[i].file, cases[i].integrator,
                  p.setting, p.reason);
        CHECK_MSG(cases[i].want == sp.lt_caustic && cases[i].share == sp.lt_slab &&
                      (cases[i].share ? sp.flat34_p < 1.0 : sp.flat34_p == 1.0),
                  "%s, %s: %s", cases[i].file, cases[i].integrator, p.setting);
        spc_scene_destroy(sc);
    }
}

/* The light guides from point and spot lights (SPC_SNEE_PLAN_POINT_GUIDES): in path's plan on
 * bench/check/spot_slab_guide.xml (a spot light led along a glass slab by total internal reflections
 * onto the floor) and bench/check/two_slabs_point_light.xml (two slabs under a point light), also
 * at an unlimited depth; not at max_depth 8 (no room for a chain of 7), not for volpath or bdpt, and
 * not without a slab (bench/check/point_light_ball.xml, bench/check/spot_ball.xml: a glass sphere). */
TEST(point_light_guides_plan)
{
    static const struct {
        const char *file, *integrator, *depth;
        bool want;
    } cases[] = {
        {"bench/check/spot_slab_guide.xml", "path", "10", true},
        {"bench/check/spot_slab_guide.xml", "path", "-1", true},
        {"bench/check/spot_slab_guide.xml", "path", "8", false},
        {"bench/check/spot_slab_guide.xml", "volpath", "10", false},
        {"bench/check/spot_slab_guide.xml", "bdpt", "10", false},
        {"bench/check/two_slabs_point_light.xml", "path", "10", true},
        {"bench/check/point_light_ball.xml", "path", "10", false},
        {"bench/check/spot_ball.xml", "path", "10", false},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        char path[1200];
        snprintf(path, sizeof path, "%s/%s", spc_test_source_dir(), cases[i].file);
        spc_define defs[2] = {{"res", "32"}, {"max_depth", cases[i].depth}};
        spc_scene *sc = NULL;
        spc_error err;
        CHECK_MSG(spc_scene_load(path, defs, 2, &sc, &err) == SPC_OK, "%s: %s", cases[i].file, err.msg);
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        spc_snee_params sp;
        bool parsed = p.on && spc_snee_parse(p.setting, 2, &sp);
        printf("  %s, %s, max_depth %s: %s\n", cases[i].file, cases[i].integrator, cases[i].depth, p.setting);
        CHECK_MSG(parsed && sp.lt_guide == cases[i].want && sp.lt_caustic == (strcmp(cases[i].integrator, "path") == 0),
                  "%s, %s, max_depth %s: %s", cases[i].file, cases[i].integrator, cases[i].depth, p.setting);
        spc_scene_destroy(sc);
    }
}

/* A glass sphere under a point light or a spot light with a sky besides: path's plan adds light
 * tracing (SPC_SNEE_PLAN_POINT_LIGHTS; the sky takes no part in it), as without the sky; not with a
 * large area light besides. */
TEST(point_light_sky_plan)
{
    static const char *const lights[] = {
        "<emitter type=\"point\"><point name=\"position\" x=\"-1.2\" y=\"2.8\" z=\"1.5\"/><rgb name=\"intensity\" "
        "value=\"30\"/></emitter><emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.02\"/></emitter>",
        "<emitter type=\"spot\"><transform name=\"to_world\"><lookat origin=\"-1.2, 2.8, 1.5\" target=\"0, 0.4, 0\" "
        "up=\"0, 1, 0\"/></transform><rgb name=\"intensity\" value=\"30\"/></emitter><emitter type=\"constant\">"
        "<rgb name=\"radiance\" value=\"0.02\"/></emitter>",
        "<emitter type=\"point\"><point name=\"position\" x=\"-1.2\" y=\"2.8\" z=\"1.5\"/><rgb name=\"intensity\" "
        "value=\"30\"/></emitter><emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.02\"/></emitter>"
        "<shape type=\"rectangle\"><transform name=\"to_world\"><translate y=\"3\"/><rotate x=\"1\" angle=\"90\"/>"
        "</transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>",
    };
    const bool want[] = {true, true, false};
    for (int i = 0; i < 3; ++i) {
        char text[2048];
        char objects[1536];
        snprintf(objects, sizeof objects,
                 "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0.4\" z=\"0\"/><float name=\"radius\" "
                 "value=\"0.4\"/><bsdf type=\"dielectric\"/></shape>%s",
                 lights[i]);
        floor_scene_text(text, sizeof text, objects);
        spc_scene *sc = NULL;
        spc_error err;
        CHECK_MSG(load_text(text, &sc, &err) == SPC_OK, "sky scene %d: %s", i, err.msg);
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        printf("  glass sphere under %s: %s\n",
               i == 0   ? "a point light and a sky"
               : i == 1 ? "a spot light and a sky"
                        : "a point light, a sky and a large area light",
               p.setting);
        CHECK_MSG(p.on && (strstr(p.setting, "ltcaus") != NULL) == want[i], "sky scene %d: %s (%s)", i, p.setting,
                  p.reason);
        spc_snee_plan_make(sc, "volpath", NULL, &p);
        CHECK_MSG(!strstr(p.setting, "ltcaus"), "sky scene %d, volpath: %s", i, p.setting);
        spc_scene_destroy(sc);
    }
}

/* Spot lights count as point lights in the plan's light-tracing rules (light tracing takes them
 * alike, integrator/path_lt.h): a spot over a glass sphere (bench/check/spot_ball.xml) gets ltcaus for
 * path (SPC_SNEE_PLAN_POINT_LIGHTS), not for volpath or bdpt; a spot over a slab gets the slab rules'
 * ltcaus and joins; beside an area light neither. */
TEST(spot_plan_light_tracing)
{
    static const struct {
        const char *integrator;
        bool want;
    } cases[] = {{"path", true}, {"volpath", false}, {"bdpt", false}};
    spc_scene *sc = load_at("bench/check/spot_ball.xml", "8");
    for (size_t i = 0; sc && i < sizeof cases / sizeof cases[0]; ++i) {
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        printf("  spot_ball, %s: %s\n", cases[i].integrator, p.setting);
        CHECK_MSG(p.on && (strstr(p.setting, "ltcaus") != NULL) == cases[i].want, "spot_ball, %s: %s (%s)",
                  cases[i].integrator, p.setting, p.reason);
    }
    spc_scene_destroy(sc);
    sc = NULL;
    static const char *const lights[] = {
        "",
        "<shape type=\"rectangle\"><transform name=\"to_world\"><translate y=\"3\"/><rotate x=\"1\" angle=\"90\"/>"
        "</transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>",
    };
    for (int i = 0; i < 2; ++i) {
        char text[2048];
        char objects[1536];
        snprintf(objects, sizeof objects,
                 "<shape type=\"cube\"><transform name=\"to_world\"><scale x=\"0.4\" y=\"0.06\" z=\"0.3\"/>"
                 "<rotate x=\"1\" angle=\"8\"/><translate y=\"0.6\"/></transform><bsdf type=\"dielectric\"/>"
                 "</shape><emitter type=\"spot\"><transform name=\"to_world\"><lookat origin=\"-0.6, 2.5, 1.9\" "
                 "target=\"0, 0.6, 0\" up=\"0, 1, 0\"/></transform><float name=\"cutoff_angle\" value=\"25\"/>"
                 "<rgb name=\"intensity\" value=\"20\"/></emitter>%s",
                 lights[i]);
        floor_scene_text(text, sizeof text, objects);
        spc_error err;
        CHECK_MSG(load_text(text, &sc, &err) == SPC_OK, "spot slab scene %d: %s", i, err.msg);
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        printf("  slab under a spot%s: %s\n", i ? " and an area light" : "", p.setting);
        if (i == 0)
            CHECK_MSG(p.on && strstr(p.setting, "ltcaus") && strstr(p.setting, SPC_SNEE_PLAN_FLAT_POINT_JOINS),
                      "slab under a spot: %s (%s)", p.setting, p.reason);
        else
            CHECK_MSG(!strstr(p.setting, "ltcaus"), "slab under a spot and an area light: %s", p.setting);
        spc_scene_destroy(sc);
        sc = NULL;
    }
}

/* Flat-faced casters under a light larger than the flat rule's (SPC_SNEE_PLAN_FLAT_MAX_SR): path's
 * plan is on with the longer chains (SPC_SNEE_PLAN_FLAT_LONG) where the pilot's face sequences per
 * query times the light's solid angle (from the casters' centre) is at most
 * SPC_SNEE_PLAN_FLAT_COST_SR (0.08) beside a glass sphere or a mirror ball, at most SPC_SNEE_PLAN_FLAT_ALONE_COST_SR
 * (0.26) where the flat casters are alone, off past it, and off past SPC_SNEE_PLAN_FLAT_LONG_MAX_SR.
 * One slab (12 sequences a query): alone on under 0.0023, 0.003, 0.0059 and 0.0071 sr (past 0.08),
 * off under 0.013 and 0.037 sr (the light's size); beside a glass ball on under 0.003 sr, off under
 * 0.0059 sr (the cost); under 0.00037 sr on without the longer chains. Two slabs (28 sequences a
 * query): beside the ball on under 0.0025 sr, off under 0.005 sr; alone on under 0.0025 sr, off
 * past the limit under 0.0096 sr. Beside a mirror ball (SPC_SNEE_PLAN_FLAT_MIRROR_COST_SR, 0.068),
 * one slab on under 0.0031 and 0.004 sr, off under 0.0079 sr (the cost); two slabs on under 0.0024
 * sr, off under 0.0029 sr (0.077: within the glass limit, past the mirror's); under 0.002 sr on
 * without the longer chains; with the longer chains the query at every first receiver beside a
 * mirror, by roulette elsewhere. Off for volpath and bdpt, and without casters. */
TEST(one_slab_plan_long_chains)
{
    static const struct {
        double scale;
        bool two, slab, mirror, ball;
        const char *integrator;
        int want; /* 0 off, 1 on, 2 on with the longer chains */
    } cases[] = {
        {0.143, false, true, false, true, "path", 2},  {0.143, false, true, false, false, "path", 2},
        {0.125, false, true, false, false, "path", 2}, {0.05, false, true, false, false, "path", 1},
        {0.2, false, true, false, true, "path", 0},    {0.2, false, true, false, false, "path", 2},
        {0.22, false, true, false, true, "path", 0},   {0.3, false, true, false, true, "path", 0},
        {0.5, false, true, false, true, "path", 0},    {0.1, true, true, false, true, "path", 2},
        {0.12, true, true, false, false, "path", 2},   {0.143, true, true, false, true, "path", 0},
        {0.235, true, true, false, false, "path", 0},  {0.22, false, true, false, false, "path", 2},
        {0.143, false, true, true, false, "path", 2},  {0.143, false, true, false, true, "volpath", 0},
        {0.1, false, true, true, false, "path", 1},    {0.125, false, true, true, false, "path", 2},
        {0.2, false, true, true, false, "path", 0},    {0.125, false, true, true, false, "volpath", 0},
        {0.11, true, true, true, false, "path", 2},    {0.12, true, true, true, false, "path", 0},
        {0.143, false, true, false, true, "bdpt", 0},  {0.143, false, false, false, false, "path", 0},
    };
    int alone_past_ball = 0; /* flat-only cases on past the limit beside a ball */
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_scene *sc = slab_scene(cases[i].scale, cases[i].two, cases[i].slab, cases[i].mirror, cases[i].ball);
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        bool flat_long = strstr(p.setting, SPC_SNEE_PLAN_FLAT_LONG) != NULL;
        int got = !p.on ? 0 : flat_long ? 2 : 1;
        double product = p.flat_sequences * p.light_sr;
        /* beside a mirror the query at every first receiver (SPC_SNEE_PLAN_FLAT_MIRROR_FIRST), by
         * roulette without one */
        spc_snee_params sp;
        if (got == 2)
            CHECK_MSG(spc_snee_parse(p.setting, 2, &sp) && (sp.first_p == 1.0) == cases[i].mirror, "case %zu: %s", i,
                      p.setting);
        CHECK_MSG(got == cases[i].want, "case %zu (%s, light %.3g sr, %.3g sequences a query): %s (%s)", i,
                  cases[i].integrator, p.light_sr, p.flat_sequences, p.setting, p.reason);
        /* the flat casters not alone: the limit 0.08 beside glass, 0.068 beside a mirror */
        double limit = cases[i].mirror ? 0.068 : cases[i].ball ? 0.08 : 0.26;
        if (cases[i].want == 2)
            CHECK_MSG(p.light_sr > 0.002 && p.flat_sequences > 0.0 && product <= limit, "%.3g sr, %.3g sequences",
                      p.light_sr, p.flat_sequences);
        if (cases[i].want == 0 && cases[i].slab && !strcmp(cases[i].integrator, "path") && p.light_sr <= 0.01)
            CHECK_MSG(product > limit && strstr(p.reason, "sequences a query"), "%s", p.reason);
        if (!cases[i].slab)
            CHECK_MSG(p.casters == 0 && strstr(p.reason, "no specular casters"), "%s", p.reason);
        if (cases[i].mirror)
            CHECK_MSG(p.casters == (cases[i].two ? 3 : 2), "%d casters", p.casters);
        /* flat-faced casters alone: their own limit, past it off with the reason saying so, and on past
         * the limit beside a ball */
        if (cases[i].want == 0 && !cases[i].ball && cases[i].slab && !cases[i].mirror && p.light_sr <= 0.01)
            CHECK_MSG(product > 0.26 && strstr(p.reason, "casters alone"), "%s", p.reason);
        if (cases[i].want == 2 && !cases[i].ball)
            CHECK_MSG(product <= 0.26, "%.3g sr, %.3g sequences", p.light_sr, p.flat_sequences);
        alone_past_ball += cases[i].want == 2 && !cases[i].ball && product > 0.08;
        spc_scene_destroy(sc);
    }
    CHECK_MSG(alone_past_ball > 0, "flat-only cases on past 0.08: %d", alone_past_ball);
    /* the settings it picks for the slabs alone (SPC_SNEE_PLAN_FLAT_LONG with light tracing through
     * the slabs, SPC_SNEE_PLAN_FLAT_LT_LONG) agree with specular NEE off: per-pixel z-test (Sidak)
     * and image means, one slab, two, and one beside a mirror ball; that one against bdpt, since
     * none's paths off the mirror to the light are rare enough that its variance estimate misses
     * them (at 65536 spp none read 2-5% low on the floor pixels lit through the mirror, |z| up to 26
     * against bdpt, where the plan's setting agreed with bdpt within |z| 2.4) */
    for (int k = 0; k < 3; ++k) {
        bool two = k == 1, mirror = k == 2;
        const char *name = two ? "two slabs" : mirror ? "slab beside a mirror ball" : "one slab";
        spc_scene *sc = slab_scene(two ? 0.12 : mirror ? 0.125 : 0.143, two, true, mirror, false);
        if (!sc)
            return;
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        CHECK_MSG(p.on && strstr(p.setting, SPC_SNEE_PLAN_FLAT_LT_LONG), "%s", p.setting);
        spc_film *def = tu_render_nee(sc, "path", p.setting, two ? 256 : 512, 2, 21 + 10 * k, NULL);
        spc_film *none = mirror ? tu_render_nee(sc, "bdpt", "none", 8192, 2, 22 + 10 * k, NULL)
                                : tu_render_nee(sc, "path", "none", 16384, 2, 22 + 10 * k, NULL);
        CHECK(def && none);
        if (def && none) {
            spc_diff_result d;
            memset(&d, 0, sizeof d);
            CHECK(tu_image_agrees(def, none, 0.99, name, &d));
            double md, sd, mn, sn;
            tu_image_mean(def, 1, &md, &sd);
            tu_image_mean(none, 1, &mn, &sn);
            printf("    %s: z-test pass %.4f of %d pixels; means %.5f +- %.5f vs %.5f +- %.5f\n", name,
                   d.ztest_pass_fraction, def->width * def->height, md, sd, mn, sn);
        }
        spc_film_destroy(def);
        spc_film_destroy(none);
        spc_scene_destroy(sc);
    }
}

/* Glass slabs alone under area lights past the flat rules' 0.01 sr, for path: on with light tracing
 * on every sample (SPC_SNEE_PLAN_FLAT_LARGE) up to 0.045 sr: scenes/caustic_slabs.xml (0.011 sr, and
 * 0.03 sr with a larger light; off under 0.066 sr); up to 0.2 sr where the slabs fill most
 * of the light's directions: scenes/newton_slabs.xml (0.12 sr, and 0.17 sr with a larger light; off
 * under 0.22 sr); off for volpath and bdpt, and beside a mirror (scenes/caustic_glass_cube.xml); the
 * small-light slab scene keeps its own setting (light tracing on a quarter of the samples). */
TEST(slab_plan_large_lights)
{
    static const struct {
        const char *path, *radius, *integrator;
        bool on;
    } cases[] = {
        {"scenes/caustic_slabs.xml", NULL, "path", true},       {"scenes/caustic_slabs.xml", "0.2", "path", true},
        {"scenes/caustic_slabs.xml", "0.3", "path", false},     {"scenes/newton_slabs.xml", NULL, "path", true},
        {"scenes/newton_slabs.xml", "0.36", "path", true},      {"scenes/newton_slabs.xml", "0.4", "path", false},
        {"scenes/newton_slabs.xml", NULL, "volpath", false},    {"scenes/newton_slabs.xml", NULL, "bdpt", false},
        {"scenes/caustic_glass_cube.xml", NULL, "path", false},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        char path[1200];
        snprintf(path, sizeof path, "%s/%s", spc_test_source_dir(), cases[i].path);
        spc_define defs[2] = {{"res", "8"}, {"light_radius", cases[i].radius}};
        spc_scene *sc = NULL;
        spc_error err;
        CHECK_MSG(spc_scene_load(path, defs, cases[i].radius ? 2 : 1, &sc, &err) == SPC_OK, "%s: %s", path, err.msg);
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        spc_snee_params sp;
        if (cases[i].on) {
            /* the long pass on 0.2 of the calls where the chain budget is 4 (newton_slabs), else 0.4 */
            const bool deep = sc->integrator.specular_max_chain >= 4;
            const char *large = deep ? SPC_SNEE_PLAN_FLAT_LARGE_DEEP_LONG : SPC_SNEE_PLAN_FLAT_LARGE;
            CHECK_MSG(deep == !strcmp(cases[i].path, "scenes/newton_slabs.xml"), "case %zu: budget %d", i,
                      sc->integrator.specular_max_chain);
            CHECK_MSG(p.on && strstr(p.setting, large) && spc_snee_parse(p.setting, 2, &sp) && sp.lt_caustic &&
                          sp.lt_share == 1.0 && sp.flat34_p == 0.1 && sp.long_max == 8 &&
                          sp.long_p == (deep ? 0.2 : 0.4),
                      "case %zu (%.3g sr): %s (%s)", i, p.light_sr, p.setting, p.reason);
            CHECK_MSG(p.light_sr > 0.01 && p.light_sr <= (p.caster_share >= 0.25 ? 0.2 : 0.045),
                      "case %zu: %.3g sr, share %.3g", i, p.light_sr, p.caster_share);
            /* the light guides and the joins through a slab where glass covers enough of the image:
             * both scenes (0.11 and 0.16) */
            CHECK_MSG(strstr(p.setting, large) && strstr(p.setting, SPC_SNEE_PLAN_FLAT_LARGE_GUIDES) &&
                          p.glass_share >= SPC_SNEE_PLAN_FLAT_LARGE_GUIDE_GLASS,
                      "case %zu: glass on %.3g of the image: %s", i, p.glass_share, p.setting);
        } else
            CHECK_MSG(!p.on || !strstr(p.setting, "ltshare"), "case %zu (%s, %.3g sr): %s", i, cases[i].integrator,
                      p.light_sr, p.setting);
        spc_scene_destroy(sc);
    }
    spc_scene *sc = load_at("scenes/caustic_slabs_small_light.xml", "8");
    if (sc) {
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        CHECK_MSG(p.on && !strstr(p.setting, "ltshare") && strstr(p.setting, SPC_SNEE_PLAN_FLAT_LT), "%s", p.setting);
        spc_scene_destroy(sc);
    }
}

/* A glass slab over the floor under a small area light, for path: where the slab's caustic falls
 * outside the image (the slab high over the floor's middle, the light low behind it: its light
 * goes to the floor beyond the view), the caustic pilot finds no receiver in view lit through the
 * glass (caustic_gain 0) and the plan is off; with the slab low at the side, the caustic in view,
 * it stays on (caustic_gain above 0); under a point light at the same place (a point light's
 * caustic is none's bias, not its variance) and with a glass ball in the slab's place (curved
 * glass: its small images of the light are the camera query's) the pilot does not run (-1) and
 * the plan stays on. */
TEST(caustic_out_of_view_plan_off)
{
    static const struct {
        const char *slab;  /* translate x y z; NULL: a glass ball at the first case's place */
        bool point;        /* a point light instead of the square one */
        const char *integrator;
        bool on;
    } cases[] = {
        {"x=\"0.5\" y=\"1.0\" z=\"0\"", false, "path", false},
        {"x=\"0.885\" y=\"0.387\" z=\"-1.075\"", false, "path", true},
        {"x=\"0.5\" y=\"1.0\" z=\"0\"", true, "path", true},
        {NULL, false, "path", true},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        char objects[1536], text[3072];
        char caster[512];
        if (cases[i].slab)
            snprintf(caster, sizeof caster,
                     "<shape type=\"cube\"><transform name=\"to_world\"><scale x=\"0.465\" y=\"0.112\" "
                     "z=\"0.369\"/><rotate x=\"1\" angle=\"1.8\"/><rotate y=\"1\" angle=\"47.9\"/><translate "
                     "%s/></transform><bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.8\"/></bsdf></shape>",
                     cases[i].slab);
        else
            snprintf(caster, sizeof caster,
                     "<shape type=\"sphere\"><point name=\"center\" x=\"0.5\" y=\"1.0\" z=\"0\"/><float "
                     "name=\"radius\" value=\"0.3\"/><bsdf type=\"dielectric\"/></shape>");
        snprintf(objects, sizeof objects, "%s%s", caster,
                 cases[i].point ? "<emitter type=\"point\"><point name=\"position\" x=\"-0.632\" y=\"1.658\" "
                                  "z=\"2.044\"/><rgb name=\"intensity\" value=\"10\"/></emitter>"
                                : "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"0.125\"/>"
                                  "<lookat origin=\"-0.632, 1.658, 2.044\" target=\"0, 0, 0\" up=\"0, 1, 0.01\"/>"
                                  "</transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"100\"/>"
                                  "</emitter></shape>");
        floor_scene_text(text, sizeof text, objects);
        spc_scene *sc = NULL;
        spc_error err;
        CHECK_MSG(load_text(text, &sc, &err) == SPC_OK, "case %zu: %s", i, err.msg);
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, cases[i].integrator, NULL, &p);
        CHECK_MSG(p.on == cases[i].on, "case %zu: %s (%s), caustic_gain %g", i, p.setting, p.reason, p.caustic_gain);
        if (!cases[i].on)
            CHECK_MSG(p.caustic_gain == 0.0 && strstr(p.reason, "no caustic in view"), "case %zu: %s, %g", i,
                      p.reason, p.caustic_gain);
        else if (!cases[i].point && cases[i].slab)
            CHECK_MSG(p.caustic_gain > 0.0, "case %zu: caustic_gain %g", i, p.caustic_gain);
        else
            CHECK_MSG(p.caustic_gain == -1.0, "case %zu: caustic_gain %g", i, p.caustic_gain);
        printf("    case %zu (%s%s): %s, caustic_gain %g\n", i, cases[i].integrator, cases[i].point ? ", point light" : "",
               p.setting, p.caustic_gain);
        spc_scene_destroy(sc);
    }
}

/* Flat glass alone: the query from the camera only where its pilot finds a light in view
 * (snee_plan.c, camera_finds_light). scenes/newton_slabs.xml, caustic_slabs.xml and
 * caustic_slabs_small_light.xml (the camera sees no light through or in the slabs) lose it;
 * bench/check/slab_light_view.xml (a light seen through its slab) keeps it, and the pilot found
 * chains there. Where it was dropped, the query made on every camera sample leaves newton_slabs'
 * image as it is without the query, value for value: it finds nothing in view. */
TEST(flat_camera_query_pilot)
{
    static const struct {
        const char *path;
        bool kept;
    } cases[] = {
        {"scenes/newton_slabs.xml", false},
        {"scenes/caustic_slabs.xml", false},
        {"scenes/caustic_slabs_small_light.xml", false},
        {"bench/check/slab_light_view.xml", true},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_scene *sc = load_at(cases[i].path, "8");
        if (!sc)
            continue;
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        spc_snee_params sp;
        CHECK_MSG(p.on && spc_snee_parse(p.setting, 2, &sp), "%s: %s (%s)", cases[i].path, p.setting, p.reason);
        if (cases[i].kept)
            CHECK_MSG(sp.camera && sp.camera_p < 1.0 && p.camera_pilot > 0, "%s: %s, pilot %d", cases[i].path,
                      p.setting, p.camera_pilot);
        else
            CHECK_MSG(!sp.camera && !strstr(p.setting, "camera") && p.camera_pilot == 0, "%s: %s, pilot %d",
                      cases[i].path, p.setting, p.camera_pilot);
        /* 0.9 of a sphere light's points from the receiver's cone under sphere lights outside the
         * casters' sphere (caustic_slabs) and inside it (newton_slabs), not under the small-light
         * rule's lights (caustic_slabs_small_light) nor a square light (slab_light_view) */
        bool lx = strstr(cases[i].path, "caustic_slabs.xml") != NULL || strstr(cases[i].path, "newton_slabs.xml");
        CHECK_MSG(lx ? sp.light_x == 0.9 : sp.light_x == 0.0, "%s: %s", cases[i].path, p.setting);
        printf("    %s: %s (pilot: %d found)\n", cases[i].path, p.setting, p.camera_pilot);
        spc_scene_destroy(sc);
    }
    /* newton_slabs with the query on every camera sample: the same values */
    spc_scene *sc = load_at("scenes/newton_slabs.xml", "8");
    if (sc) {
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        char with[2048];
        snprintf(with, sizeof with, "angular:camera,%s", p.setting + strlen("angular:"));
        spc_film *a = tu_render_nee(sc, "path", NULL, 4, 1, 3, NULL);
        spc_film *b = tu_render_nee(sc, "path", with, 4, 1, 3, NULL);
        CHECK(a && b);
        if (a && b) {
            int differ = 0;
            for (int k = 0; k < 3 * a->width * a->height; ++k)
                differ += a->rgb[k] != b->rgb[k];
            CHECK_MSG(differ == 0, "%d values differ with '%s'", differ, with);
            double m;
            double se;
            tu_image_mean(a, 0, &m, &se);
            CHECK(m > 0.0);
        }
        spc_film_destroy(a);
        spc_film_destroy(b);
        spc_scene_destroy(sc);
    }
    sc = load_at("scenes/caustic_glass_sphere.xml", "8");
    if (sc) {
        spc_snee_plan p;
        spc_snee_plan_make(sc, "path", NULL, &p);
        CHECK_MSG(p.camera_pilot == -1 && strstr(p.setting, "camera"), "%s, pilot %d", p.setting, p.camera_pilot);
        spc_scene_destroy(sc);
    }
}

int main(void)
{
    RUN(demo_plan_on);
    RUN(default_on_with_casters_only);
    RUN(xml_setting_words);
    RUN(default_agrees_with_none);
    RUN(camera_query_from_glass_share);
    RUN(mirror_only_plan_camera_query_by_roulette);
    RUN(lamp_in_glass_globe_plan_on);
    RUN(small_light_ball_agrees_with_bdpt);
    RUN(bdpt_default_follows_the_plan);
    RUN(default_has_no_fireflies_through_glass);
    RUN(low_camera_q_agrees_on_light_images);
    RUN(reflections_at_depth_4_agree_with_bdpt);
    RUN(light_in_housing_plan_off);
    RUN(sdf_torus_plan);
    RUN(sdf_csg_plan_off);
    RUN(tessellated_ball_plan);
    RUN(recv_guide_with_glass_balls);
    RUN(demo_long_max);
    RUN(closed_glass_mesh_plan_off);
    RUN(solved_mirror_plan_no_first_roulette);
    RUN(flat_mirror_plan);
    RUN(ball_flat_mirror_large_light_split);
    RUN(ball_flat_mirror_small_light_joins);
    RUN(volpath_ball_plan);
    RUN(volpath_ball_in_fog_plan_off);
    RUN(water_plane_plan_no_camera_query);
    RUN(water_plane_plan_camera_under_water);
    RUN(one_slab_plan_long_chains);
    RUN(slab_plan_light_tracing);
    RUN(slab_plan_point_light_tracing);
    RUN(spot_plan_light_tracing);
    RUN(point_light_sky_plan);
    RUN(point_light_guides_plan);
    RUN(slab_plan_large_lights);
    RUN(caustic_out_of_view_plan_off);
    RUN(flat_camera_query_pilot);
    return spc_test_finish();
}
