/*
 * tests/test_path_lt_water.c: area lights' light tracing through a normal-mapped water surface
 * (integrator/path_lt.h, "ltcaus") with the camera under the water (tests/data/pool_under_water.xml:
 * the pool of scenes/caustic_pool.xml seen from inside the water, a light four times as wide).
 * There the light subpath crosses the water once and its joins reach the pinhole without crossing
 * it again (the floor and walls seen directly, their reflections in the surface's underside, a
 * second receiver seen directly): the joins carry the flux, which the crossing does not scale by
 * the radiance transport's n^2. With that factor left in (as before the fix), the pool's setting
 * read 5% brighter than --specular-nee none (z 8 at 512 spp), 18% with nearp=0.1 (light
 * tracing's share of the second receiver's paths larger); with light tracing given every path it
 * makes (its density ratio times 1e6 on both sides) 43%.
 * - The pool's setting agrees with none (per-pixel z-test, image means within 4 standard errors):
 *   the plan's setting for a camera under a water plane (SPC_SNEE_PLAN_SETTING_UNDER_WATER).
 * - So does it with nearp=0.1.
 * - So does the water's setting without light tracing (specular NEE and BSDF sampling alone, the
 *   query by roulette at every receiver: SPC_SNEE_PLAN_SETTING_WATER). Over 24 seeds of 256 spp it
 *   reads 1.0002 of none (between-seed standard error 0.0015; the variance channels' standard error
 *   of one render's image mean is 1.5x smaller than the spread of the seeds' means, so one render's
 *   z overstates a deviation by about that).
 */
/* ctest-labels: stat */
#include <stdio.h>

#include "harness.h"
#include "manifold/snee_plan.h"
#include "render_util.h"

#define SCENE "tests/data/pool_under_water.xml"
#define POOL_PLAN SPC_SNEE_PLAN_SETTING_UNDER_WATER

static void agrees_with_none(const char *setting, int spp, uint64_t seed, const char *label)
{
    spc_scene *sc = tu_load(SCENE, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    /* none: about a twentieth of the CPU per sample */
    CHECK(tu_settings_agree(sc, setting, spp, "none", 16 * spp, seed, label));
    spc_scene_destroy(sc);
}

TEST(pool_plan_agrees)
{
    agrees_with_none(POOL_PLAN, spc_test_quick() ? 128 : 256, 12056, "under water: pool's plan vs none");
}

TEST(pool_plan_nearp_agrees)
{
    agrees_with_none(POOL_PLAN ",nearp=0.1", spc_test_quick() ? 128 : 256, 12058,
                     "under water: pool's plan, nearp=0.1 vs none");
}

TEST(water_setting_agrees)
{
    agrees_with_none(SPC_SNEE_PLAN_SETTING_WATER, spc_test_quick() ? 128 : 256, 12279,
                     "under water: the water's setting without light tracing vs none");
}

int main(void)
{
    RUN(pool_plan_agrees);
    RUN(pool_plan_nearp_agrees);
    RUN(water_setting_agrees);
    return spc_test_finish();
}
