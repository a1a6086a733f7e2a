/*
 * tests/test_path_deep.c: the path tracer's extra directions at its receivers past the first
 * (path_deep.h, "deepsplit=M").
 * - The option: off in every plan's setting, M parsed and written back, 0 and 65 refused.
 * - The pool with the camera under the water (tests/data/pool_under_water.xml) and specular NEE at
 *   the first receiver only (receivers=1), so that BSDF sampling alone carries the light the later
 *   receivers get through the water (about a fifth of the image): deepsplit=4 agrees with the same
 *   setting without it (per-pixel z-test, image means within 4 standard errors) with at most half
 *   its variance. Counting the path's own sample of the class whole as well as the extra ones
 *   (no 1 / (M + 1)) moves the image mean by about 20%, far past those bounds.
 * - scenes/caustic_pool.xml: its plan with deepsplit=8 agrees with the plan (MIS against specular
 *   NEE at every receiver).
 */
/* ctest-labels: stat */
#include <stdio.h>
#include <string.h>

#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/solver.h"
#include "render_util.h"

#define POOL_PLAN "angular:first=0.1,later=0.1,ltcaus,ltshare=0.5"

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

TEST(under_water_agrees_with_less_variance)
{
    spc_scene *sc = tu_load("tests/data/pool_under_water.xml", 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int spp = spc_test_quick() ? 256 : 1024;
    spc_film *a = tu_render_nee(sc, "path", POOL_PLAN ",receivers=1,deepsplit=4", spp, 2, 11751, NULL);
    spc_film *b = tu_render_nee(sc, "path", POOL_PLAN ",receivers=1", spp, 2, 11752, NULL);
    CHECK(a && b);
    if (a && b) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(a, b, 0.99, "under water, deepsplit=4 vs without", &d));
        double ma, sa, mb, sb;
        tu_image_mean(a, 0, &ma, &sa);
        tu_image_mean(b, 0, &mb, &sb);
        double z = (ma - mb) / sqrt(sa * sa + sb * sb);
        double va = tu_var_sum(a), vb = tu_var_sum(b);
        printf("    z-test pass %.4f of %d pixels; means %.5f +- %.5f vs %.5f +- %.5f (z %.2f); variance ratio %.3f\n",
               d.ztest_pass_fraction, d.ztest_pixels, ma, sa, mb, sb, z, va / vb);
        CHECK_MSG(fabs(z) < 4.0, "image means z %.2f", z);
        CHECK_MSG(va < 0.5 * vb, "variance %.4g against %.4g without", va, vb);
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
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
    RUN(under_water_agrees_with_less_variance);
    RUN(pool_plan_agrees);
    return spc_test_finish();
}
