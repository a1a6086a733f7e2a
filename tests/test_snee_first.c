/*
 * tests/test_snee_first.c: specular NEE's Russian roulette at a path's first receiver (the option
 * first=P, snee_cost.h spc_snee_first_prob), which the plan's setting uses.
 *
 * The scene: a glass ball of radius 0.25 high over a diffuse floor (its centre 5 radii up), under a
 * square area light. On the floor the ball's caustic has passed its focus and spread over the
 * ball's shadow, where it is most of the light; from there the ball's bound fills a share of about
 * 0.03 of the directions, so the query is made with probability first_p = 0.1 and counted 10
 * times. Checked:
 * - the probability at the floor is the floor value and 1 beside the ball (so the roulette runs);
 * - first=0.1 against the query at every receiver (`angular`) and against no specular NEE at all
 *   (`none`), per pixel (z-test, Sidak) and by image mean: a roulette whose weight missed the
 *   1/first_p, or whose MIS weight on the BSDF side read another probability than the query's,
 *   moves the shadow's caustic.
 */
/* ctest-labels: stat */
#include "harness.h"
#include "manifold/snee_cost.h"
#include "manifold/solver.h"
#include "render_util.h"

static spc_scene *high_ball(void)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *floor = spc_scene_new_shape(sc);
    spc_mat4 M = spc_mat4_scale(spc_v3(2, 2, 1));
    spc_shape_init_rectangle(floor, &M, NULL, 0, 0, &err);
    floor->bsdf = tu_diffuse(sc, 0.7);
    tu_sphere(sc, spc_v3(0, 0, 1.25), 0.25, tu_glass(sc, 1.5));
    spc_shape *light = spc_scene_new_shape(sc);
    spc_mat4 T = spc_mat4_translate(spc_v3(0.3, 0, 3)), R = spc_mat4_rotate(spc_v3(1, 0, 0), 180.0);
    spc_mat4 S = spc_mat4_scale(spc_v3(0.6, 0.6, 1)), RS = spc_mat4_mul(&R, &S), L = spc_mat4_mul(&T, &RS);
    spc_shape_init_rectangle(light, &L, NULL, 0, 0, &err);
    light->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, light, 2, 5.0);
    tu_camera(sc, spc_v3(0, -2.2, 2.2), spc_v3(-0.15, 0, 0), spc_v3(0, 0, 1), 40, 12, 12);
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

TEST(first_prob_in_the_scene)
{
    spc_scene *sc = high_ball();
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params p;
    CHECK(spc_snee_parse("angular:first=0.1", 2, &p));
    CHECK(spc_snee_first_prob(sc, &p, spc_v3(-0.15, 0, 0)) == 0.1);
    CHECK(spc_snee_first_prob(sc, &p, spc_v3(0, 0, 0.9)) == 1.0);
    spc_scene_destroy(sc);
}

TEST(first_roulette_agrees_with_every_query_and_none)
{
    spc_scene *sc = high_ball();
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *first = tu_render_nee(sc, "path", "angular:first=0.1", 2048, 2, 71, NULL);
    spc_film *every = tu_render_nee(sc, "path", "angular", 1024, 2, 72, NULL);
    spc_film *none = tu_render_nee(sc, "path", "none", 16384, 2, 73, NULL);
    CHECK(first && every && none);
    if (first && every && none) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(first, every, 0.99, "first=0.1 vs angular", &d));
        printf("    vs angular: z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction,
               d.ztest_pixels, d.mean_a[0], d.mean_b[0]);
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(first, none, 0.99, "first=0.1 vs none", &d));
        printf("    vs none: z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction,
               d.ztest_pixels, d.mean_a[0], d.mean_b[0]);
    }
    spc_film_destroy(first);
    spc_film_destroy(every);
    spc_film_destroy(none);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(first_prob_in_the_scene);
    RUN(first_roulette_agrees_with_every_query_and_none);
    return spc_test_finish();
}
