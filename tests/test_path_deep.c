/*
 * tests/test_path_deep.c: the path tracer's extra directions at its receivers past the first
 * (path_deep.h, "deepsplit=M"), weighed as M + 1 BSDF samples against specular NEE's.
 * - The option: off in every plan's setting, M parsed and written back, 0 and 65 refused.
 * - The pool with the camera under the water and a wide light (tests/data/pool_under_water.xml),
 *   specular NEE past the first receiver by roulette at 0.02-0.1 (later=0.02, nearp=0.1), so that
 *   BSDF sampling holds a large share of the light the later receivers get through the water:
 *   deepsplit=4 agrees with the same setting without it (per-pixel z-test, image means within 4
 *   standard errors). Counting the path's own sample of that light whole as well as the extra
 *   ones (no 1 / (M + 1)) reads 13% brighter, z 18 at 1024 spp (checked once by hand).
 * - scenes/caustic_pool.xml: its plan with deepsplit=8 agrees with the plan (light tracing at the
 *   first two receivers, the extra directions past them).
 */
/* ctest-labels: stat */
#include <stdio.h>
#include <string.h>

#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/solver.h"
#include "render_util.h"

#define POOL_PLAN "angular:first=0.1,later=0.1,ltcaus,ltshare=0.5"
/* specular NEE past the first receiver on 2-10% of the calls: BSDF sampling's share large there */
#define UNDER_PLAN "angular:first=0.1,later=0.02,nearp=0.1"

TEST(option_parses)
{
    spc_snee_params p;
    CHECK(spc_snee_parse(POOL_PLAN, 2, &p) && p.deep_split == 0);
    CHECK(spc_snee_parse(POOL_PLAN ",deepsplit=3", 2, &p) && p.deep_split == 3);
    char buf[512];
    spc_snee_options_format(&p, buf, sizeof buf);
    CHECK_MSG(strstr(buf, "deepsplit=3") != NULL, "canonical setting: %s", buf);
    spc_snee_params q;
    CHECK(spc_snee_parse(buf, 2, &q) && q.deep_split == 3);
    CHECK(!spc_snee_parse(POOL_PLAN ",deepsplit=0", 2, &p));
    CHECK(!spc_snee_parse(POOL_PLAN ",deepsplit=65", 2, &p));
}

TEST(under_water_agrees)
{
    spc_scene *sc = tu_load("tests/data/pool_under_water.xml", 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int spp = spc_test_quick() ? 256 : 1024;
    CHECK(tu_settings_agree(sc, UNDER_PLAN ",deepsplit=4", spp, UNDER_PLAN, spp, 11754,
                            "under water: deepsplit=4 vs without"));
    spc_scene_destroy(sc);
}

TEST(pool_plan_agrees)
{
    spc_scene *sc = tu_load("scenes/caustic_pool.xml", 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int spp = spc_test_quick() ? 64 : 256;
    CHECK(tu_settings_agree(sc, POOL_PLAN ",deepsplit=8", spp, POOL_PLAN, spp, 11753, "pool: deepsplit=8 vs plan"));
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(option_parses);
    RUN(under_water_agrees);
    RUN(pool_plan_agrees);
    return spc_test_finish();
}
