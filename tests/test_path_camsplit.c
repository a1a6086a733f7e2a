/*
 * tests/test_path_camsplit.c: the camera-side split of the light seen through glass
 * (integrator/path_camsplit.h, specular NEE's "camsplit"), on bench/check/ball_light_view.xml (a
 * small sphere light seen by the camera through a glass ball) and scenes/caustic_sdf_torus.xml.
 *
 * - The option parses within its range and prints back.
 * - Same seed with and without the split: only the pixels whose camera rays see the glass change
 *   (the split draws no dimension of the sampler; the ball: the light and the sky through it, a
 *   fifth of the image); on the ball without the camera
 *   query (the light's image through it is then the camera ray's alone, class C at weight 1) their
 *   summed variance falls; on the torus with its plan (the T R T image is the camera ray's alone)
 *   a few pixels change.
 * - The image does not depend on the thread count.
 * - Renders with the split agree with --specular-nee none (per-pixel z-test, image mean): with the
 *   camera query off (the class at weight 1) and with the plan's setting (its MIS weights kept).
 * - bench/check/ball_mirror_biglight.xml (a glass ball beside a flat mirror under a large light) with
 *   its plan's setting, the split included, agrees with none: the split's rays there follow the
 *   mirror and the ball to the light by chains of up to 9 vertices, weighed against the camera query.
 * - "camrecv" (class D: one sample of the first receiver behind the glass, then delta scatterings):
 *   the option parses; same seed with and without it only pixels that see the torus change, the
 *   image does not depend on the thread count, and the torus under a larger light (so that none
 *   converges at a test's spp) agrees with none.
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "render_util.h"

#define BALL "bench/check/ball_light_view.xml"
#define TORUS "scenes/caustic_sdf_torus.xml"
/* the scenes' plans (specula info) */
#define BALL_PLAN "angular:camera=0.04,first=0.1,later=0.1,ltcaus"
#define TORUS_PLAN "angular:camera,first=0.1,later=0.1,ltguide,nolong"
/* a glass ball beside a flat mirror under a large light, and its plan (specula info) */
#define BIGLIGHT "bench/check/ball_mirror_biglight.xml"
#define BIGLIGHT_PLAN "angular:camera=0.3,first=0.1,later=0.1,ltcaus,long=0.5,longmax=5,camsplit=16"
/* the ball without the camera query: its light's image is the camera ray's alone */
#define BALL_NOCAM "angular:first=0.1,later=0.1"

TEST(option_parses)
{
    spc_snee_params p;
    CHECK(spc_snee_parse("angular:camsplit", 2, &p));
    CHECK(p.cam_split && p.cam_split_rays == 4);
    CHECK(spc_snee_parse("angular:camsplit=16", 2, &p));
    CHECK(p.cam_split && p.cam_split_rays == 16);
    CHECK(spc_snee_parse("angular:camsplit=16,nocamsplit", 2, &p));
    CHECK(!p.cam_split);
    CHECK(!spc_snee_parse("angular:camsplit=0", 2, &p));
    CHECK(!spc_snee_parse("angular:camsplit=65", 2, &p));
    CHECK(spc_snee_parse("angular:camsplit,camrecv", 2, &p));
    CHECK(p.cam_split && p.cam_split_recv && p.cam_split_recv_min == 5);
    CHECK(spc_snee_parse("angular:camsplit,camrecv=1", 2, &p));
    CHECK(p.cam_split_recv && p.cam_split_recv_min == 1);
    CHECK(!spc_snee_parse("angular:camsplit,camrecv=0", 2, &p));
    CHECK(spc_snee_parse("angular:camsplit,camrecv,nocamrecv", 2, &p));
    CHECK(!p.cam_split_recv);
    CHECK(spc_snee_parse("angular:camsplit", 2, &p));
    CHECK(!p.cam_split_recv);
}

/* setting and setting + ",camsplit=K" at the same seed and spp: the pixels that differ, at most
 * max_changed of them and at least one, and their summed variance falls by at least `gain` (0: not
 * checked; one render's variance of a heavy tail's pixels is no measure where its rare hits may be
 * missing). */
static void split_lowers_variance(const char *scene, const char *setting, int K, int spp, double max_changed,
                                  double gain)
{
    spc_scene *sc = tu_load(scene, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    char with[128];
    snprintf(with, sizeof with, "%s,camsplit=%d", setting, K);
    spc_film *a = tu_render_nee(sc, "path", setting, spp, 2, 41, NULL);
    spc_film *b = tu_render_nee(sc, "path", with, spp, 2, 41, NULL);
    CHECK(a && b);
    if (a && b) {
        int n = a->width * a->height, changed = 0;
        double va = 0.0, vb = 0.0;
        for (int i = 0; i < n; ++i) {
            bool d = false;
            for (int c = 0; c < 3; ++c)
                d = d || a->rgb[3 * i + c] != b->rgb[3 * i + c];
            if (!d)
                continue;
            ++changed;
            for (int c = 0; c < 3; ++c) {
                va += a->var[3 * i + c];
                vb += b->var[3 * i + c];
            }
        }
        printf("    %s, %s: %d of %d pixels changed; their summed variance %.4g without, %.4g with camsplit=%d\n",
               scene, setting, changed, n, va, vb, K);
        CHECK(changed >= 1 && changed <= max_changed * n);
        if (gain > 0.0)
            CHECK(vb * gain < va);
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_scene_destroy(sc);
}

TEST(only_the_light_through_glass_changes)
{
    int q = spc_test_quick() ? 2 : 1;
    split_lowers_variance(BALL, BALL_NOCAM, 8, 128 / q, 0.3, 3.0);
    split_lowers_variance(TORUS, TORUS_PLAN, 8, 64 / q, 0.2, 0.0);
}

TEST(thread_count_independent)
{
    spc_scene *sc = tu_load(TORUS, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *a = tu_render_nee(sc, "path", TORUS_PLAN ",camsplit=8", 8, 1, 7, NULL);
    spc_film *b = tu_render_nee(sc, "path", TORUS_PLAN ",camsplit=8", 8, 2, 7, NULL);
    CHECK(a && b);
    if (a && b)
        CHECK(!memcmp(a->rgb, b->rgb, sizeof(float) * 3 * (size_t)a->width * (size_t)a->height));
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_scene_destroy(sc);
}

/* path with `with` (seed) against none (seed + 1, spp_none): the images agree by the per-pixel
 * z-test on 0.99 of the pixels and their means within 4 standard errors. */
static void agrees_with_none(const char *scene, const char *with, int spp, int spp_none, uint64_t seed,
                             const char *label)
{
    spc_scene *sc = tu_load(scene, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(tu_settings_agree(sc, with, spp, "none", spp_none, seed, label));
    spc_scene_destroy(sc);
}

TEST(render_agrees_with_none)
{
    int q = spc_test_quick() ? 2 : 1;
    agrees_with_none(BALL, BALL_NOCAM ",camsplit=8", 512 / q, 8192 / q, 51, "ball, no camera query, camsplit=8");
    agrees_with_none(BALL, BALL_PLAN ",camsplit=8", 512 / q, 8192 / q, 53, "ball, plan, camsplit=8");
    agrees_with_none(BIGLIGHT, BIGLIGHT_PLAN, 256 / q, 4096 / q, 55, "ball beside a mirror, large light, plan");
}

/* The torus under a sphere light of radius 0.3 (its power kept: radiance scaled by (0.08 / 0.3)^2),
 * res x res: the floor's caustic and the light seen through the torus spread wide enough that none
 * converges at a test's spp. */
static spc_scene *torus_large_light(int res)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    char path[1024], r[16];
    snprintf(path, sizeof path, "%s/%s", d ? d : ".", TORUS);
    snprintf(r, sizeof r, "%d", res);
    spc_define defs[3] = {{"res", r}, {"light_radius", "0.3"}, {"light_radiance", "28.44, 27.02, 24.18"}};
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_scene_load(path, defs, 3, &sc, &err) != SPC_OK)
        return NULL;
    return sc;
}

/* camrecv=1 (every class D path; the default's paths of 5 delta vertices or more are too rare to
 * show at a test's spp), under the larger light (under the small one a class D path is rare too) */
TEST(recv_changes_only_the_glass)
{
    spc_scene *sc = torus_large_light(16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int spp = spc_test_quick() ? 16 : 32;
    spc_film *a = tu_render_nee(sc, "path", TORUS_PLAN ",camsplit=4", spp, 2, 43, NULL);
    spc_film *b = tu_render_nee(sc, "path", TORUS_PLAN ",camsplit=4,camrecv=1", spp, 2, 43, NULL);
    spc_film *c = tu_render_nee(sc, "path", TORUS_PLAN ",camsplit=4,camrecv=1", spp, 1, 43, NULL);
    CHECK(a && b && c);
    if (a && b && c) {
        int n = a->width * a->height, changed = 0;
        for (int i = 0; i < n; ++i) {
            bool d = false;
            for (int k = 0; k < 3; ++k)
                d = d || a->rgb[3 * i + k] != b->rgb[3 * i + k];
            changed += d;
        }
        /* the torus covers about a fifth of the image (specula info: glass seen on 0.207) */
        printf("    torus, camrecv=1: %d of %d pixels changed\n", changed, n);
        CHECK(changed >= 1 && changed <= 0.3 * n);
        CHECK(!memcmp(b->rgb, c->rgb, sizeof(float) * 3 * (size_t)n));
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_film_destroy(c);
    spc_scene_destroy(sc);
}

TEST(recv_agrees_with_none)
{
    int q = spc_test_quick() ? 2 : 1;
    spc_scene *sc = torus_large_light(16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    /* camrecv=1: every class D path, the common ones too, so that their weights are tested */
    CHECK(tu_settings_agree(sc, TORUS_PLAN ",camsplit=8,camrecv=1", 256 / q, "none", 4096 / q, 61,
                            "torus, large light, camrecv=1"));
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(option_parses);
    RUN(only_the_light_through_glass_changes);
    RUN(thread_count_independent);
    RUN(render_agrees_with_none);
    RUN(recv_changes_only_the_glass);
    RUN(recv_agrees_with_none);
    return spc_test_finish();
}
