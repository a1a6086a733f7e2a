/*
 * tests/test_flat_default.c: the default's specular NEE on flat-faced glass (manifold/flat_chains.h)
 * agrees with specular NEE off.
 *
 * - A small-light version of scenes/newton_slabs.xml (two glass slabs over a floor: chains of four
 *   refractions; path tracing alone rarely reaches the light through them) at 16 x 16: the plan is
 *   on and enumerates the flat casters' chains (spc_snee_plan_method); the default's image against
 *   bdpt without specular NEE (light tracing reaches the floor through the slabs), per-pixel z-test
 *   (Sidak) and image means.
 * - newton_slabs itself (0.12 sr: the plan's rule for slabs alone under larger lights, light
 *   tracing on every sample, 0.9 of the sphere light's points in the cone from the receiver)
 *   against path tracing without specular NEE the same way.
 * - scenes/caustic_slabs.xml, whose plan draws 0.9 of its sphere light's points in the cone from the
 *   receiver (lightx), against path tracing without specular NEE the same way.
 * - scenes/caustic_glass_cube.xml (a tilted glass cube beside a silver ball: two refractions, total
 *   internal reflections, chains through cube and ball left to the randomized attempts), on by the
 *   plan's rule for flat casters beside a mirror: the plan's setting against path tracing without
 *   specular NEE the same way.
 * - Flat mirrors (bench/check): a glass ball resting on a square mirror (chains off the mirror,
 *   through the ball, and through both: the randomized attempts') and a tilted mirror alone that
 *   casts the light on the floor, their mirrors' chains enumerated by the plan's setting, and a
 *   mirror ball resting on the square mirror: against bdpt without specular NEE the same way.
 */
/* ctest-labels: stat */
/* ctest-timeout: 600 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "harness.h"
#include "io/mitsuba_xml.h"
#include "manifold/flat_chains.h"
#include "manifold/snee_plan.h"
#include "render_util.h"

static spc_scene *load(const char *path, const spc_define *defs, int ndefs)
{
    spc_scene *sc = NULL;
    spc_error err;
    if (spc_mitsuba_load(path, defs, ndefs, &sc, &err) != SPC_OK) {
        printf("  %s: %s\n", path, err.msg);
        return NULL;
    }
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  %s: %s\n", path, err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* The plan on sc is on, and every flat-faced glass caster's chains are enumerated. */
static bool plan_uses_flat_chains(const spc_scene *sc, const char *label)
{
    spc_snee_plan plan;
    spc_snee_plan_make(sc, "path", NULL, &plan);
    if (!plan.on) {
        printf("  %s: plan off (%s)\n", label, plan.reason);
        return false;
    }
    spc_snee_params p;
    if (!spc_snee_parse(plan.setting, 2, &p))
        return false;
    int flat = 0;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, false);
    for (int i = 0; cs && i < cs->n; ++i)
        flat += spc_snee_plan_method(&p, sc->shapes[cs->idx[i]]) == SPC_SNEE_METHOD_FLAT;
    printf("  %s: plan %s, %d flat casters\n", label, plan.setting, flat);
    return flat > 0;
}

/* setting: NULL for the plan's (which must enumerate the flat casters), else this one. */
/* ref: the reference's integrator, without specular NEE ("path": none; "bdpt" where path tracing
 * alone rarely finds the light). */
static void agrees_at(const char *path, const spc_define *defs, int ndefs, const char *setting, int spp,
                      const char *ref, int spp_none, const char *label, double min_pass)
{
    spc_scene *sc = load(path, defs, ndefs);
    CHECK(sc != NULL);
    if (!sc)
        return;
    if (!setting) {
        CHECK(plan_uses_flat_chains(sc, label));
    } else {
        /* a large light over flat glass: the plan leaves specular NEE off (snee_plan.h) */
        spc_snee_plan plan;
        spc_snee_plan_make(sc, "path", NULL, &plan);
        CHECK_MSG(!plan.on && strstr(plan.reason, "flat-faced casters under a light"), "%s: %s", label, plan.reason);
    }
    spc_film *def = tu_render_nee(sc, "path", setting, spp, 2, 11, NULL);
    spc_film *none = tu_render_nee(sc, ref, "none", spp_none, 2, 12, NULL);
    CHECK(def && none);
    if (def && none) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(def, none, min_pass, label, &d));
        double md, sd, mn, sn;
        tu_image_mean(def, 1, &md, &sd);
        tu_image_mean(none, 1, &mn, &sn);
        printf("  %s: z-test pass %.4f of %d pixels; means %.5f +- %.5f vs %.5f +- %.5f; summed variance %.3g "
               "(default, %d spp) vs %.3g (%s, %d spp)\n",
               label, d.ztest_pass_fraction, def->width * def->height, md, sd, mn, sn, tu_var_sum(def), spp,
               tu_var_sum(none), ref, spp_none);
    }
    spc_film_destroy(def);
    spc_film_destroy(none);
    spc_scene_destroy(sc);
}

static void agrees(const char *path, const spc_define *defs, int ndefs, const char *setting, int spp, const char *ref,
                   int spp_none, const char *label)
{
    agrees_at(path, defs, ndefs, setting, spp, ref, spp_none, label, 0.99);
}

TEST(slabs_default_agrees_with_none)
{
    const spc_define d[2] = {{"res", "16"}, {"spp", "1"}};
    agrees("scenes/newton_slabs.xml", d, 2, NULL, 256, "path", 8192, "newton_slabs");
}

TEST(small_light_slabs_default_agrees_with_none)
{
    /* a light of radius 0.02 (0.00055 sr at the casters) and the same power */
    const spc_define d[4] = {{"res", "16"}, {"spp", "1"}, {"light_radius", "0.02"},
                             {"light_radiance", "6750, 6300, 5400"}};
    agrees("scenes/newton_slabs.xml", d, 4, NULL, 256, "bdpt", 2048, "newton_slabs, small light");
}

/* scenes/caustic_slabs.xml (three slabs under a sphere light outside their bounding sphere): the
 * plan draws 0.9 of the light's points in the cone from the receiver (lightx=0.9). */
TEST(caustic_slabs_default_agrees_with_none)
{
    const spc_define d[2] = {{"res", "16"}, {"spp", "1"}};
    char path[1024];
    snprintf(path, sizeof path, "%s/scenes/caustic_slabs.xml", spc_test_source_dir());
    spc_scene *sc = load(path, d, 2);
    if (sc) {
        spc_snee_plan plan;
        spc_snee_plan_make(sc, "path", NULL, &plan);
        CHECK_MSG(strstr(plan.setting, "lightx=0.9"), "%s", plan.setting);
        spc_scene_destroy(sc);
    }
    agrees("scenes/caustic_slabs.xml", d, 2, NULL, 256, "path", 8192, "caustic_slabs");
}

TEST(glass_cube_default_agrees_with_none)
{
    const spc_define d[2] = {{"res", "16"}, {"spp", "1"}};
    agrees("scenes/caustic_glass_cube.xml", d, 2, NULL, 256, "path", 8192, "caustic_glass_cube");
}

TEST(mirror_floor_ball_default_agrees_with_none)
{
    const spc_define d[2] = {{"res", "16"}, {"spp", "1"}};
    /* 0.98: in the mirror's view of the ball, two or three pixels where bdpt (and path) without
     * specular NEE reach the light through mirror and ball so rarely that at 2048 spp they read a
     * tenth of the mean, with a variance that does not show it; the default, whose chains there are
     * enumerated exactly, has a small enough variance to fail against that reference there (with a
     * larger light, where path tracing converges, they agree; bench/RESULTS.md, part unfold35). The
     * default against the randomized attempts on the same chains: test_unfold_chains. */
    agrees_at("bench/check/ball_mirror_floor.xml", d, 2, NULL, 256, "bdpt", 2048, "ball_mirror_floor", 0.98);
}

/* A mirror ball resting on the square mirror: the plan's rule for a ball beside a flat mirror (the
 * camera query on 0.3 of the samples, the longer chains on half of the calls: snee_plan.h) */
TEST(mirror_ball_on_mirror_default_agrees_with_none)
{
    const spc_define d[2] = {{"res", "16"}, {"spp", "1"}};
    agrees("bench/check/mirrorball_mirror_floor.xml", d, 2, NULL, 256, "bdpt", 2048, "mirrorball_mirror_floor");
}

TEST(tilted_mirror_default_agrees_with_none)
{
    const spc_define d[2] = {{"res", "16"}, {"spp", "1"}};
    agrees("bench/check/mirror_tilt.xml", d, 2, NULL, 256, "bdpt", 2048, "mirror_tilt");
}

int main(void)
{
    RUN(slabs_default_agrees_with_none);
    RUN(small_light_slabs_default_agrees_with_none);
    RUN(caustic_slabs_default_agrees_with_none);
    RUN(glass_cube_default_agrees_with_none);
    RUN(mirror_floor_ball_default_agrees_with_none);
    RUN(mirror_ball_on_mirror_default_agrees_with_none);
    RUN(tilted_mirror_default_agrees_with_none);
    return spc_test_finish();
}
