/*
 * tests/test_snee_split.c: the path tracer's specular NEE splitting at a smooth dielectric seen
 * from the camera (integrator/path.c, split_snee; the option "nosplit" turns it off).
 *
 * The scene: a glass ball on a diffuse floor under a small bright sphere light, which focuses a
 * caustic on the floor beside the ball, and an upright glass pane (one dielectric interface, eta
 * 1.5) facing the ball, in which the camera sees the floor and its caustic reflected. BSDF sampling
 * picks that reflection with the Fresnel probability (about 0.05-0.1 here), so without splitting
 * the caustic's specular NEE value at the reflected floor point comes with that probability and
 * its full size. The pane is a triangle mesh (a rectangle), where the split runs; the ball is an
 * analytic sphere, where it does not (spc_path_snee_splits). Checked:
 * - the render with splitting agrees per pixel (z-test, Sidak) and by image mean with the same
 *   setting with "nosplit" (the estimator as it was before the splitting, at another seed), and by
 *   image mean with `none` (no specular NEE);
 * - at the same sample count and seed its summed variance over the pixels it changed is below that
 *   of the same setting with "nosplit" (which renders as before the splitting; without the splitting the two
 *   would be the same render);
 * - the split by roulette on flat-faced glass (the pane) where F is below "splitf" (counted 1/p,
 *   p = F / splitf): at splitf=0.5 (p = 2F on the pane) it agrees per pixel with "nosplit", and at
 *   the same seed its summed variance lies below nosplit's (p = F, as the sampled reflection
 *   itself) and above the default's (p = F / 0.25) by at least as much as the two pixel sets'
 *   nosplit sums differ.
 */
/* ctest-labels: stat */
#include "harness.h"
#include "render_util.h"

#include <math.h>

#define RES 16

static spc_scene *pane_scene(void)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *floor = spc_scene_new_shape(sc);
    spc_mat4 F = spc_mat4_scale(spc_v3(3, 3, 1));
    spc_shape_init_rectangle(floor, &F, NULL, 0, 0, &err);
    floor->bsdf = tu_diffuse(sc, 0.5);
    /* the pane: the unit rectangle turned upright (the plane x = -1), 3 wide and 2 high */
    spc_shape *pane = spc_scene_new_shape(sc);
    spc_mat4 R = spc_mat4_rotate(spc_v3(0, 1, 0), 90.0), S = spc_mat4_scale(spc_v3(1, 1.5, 1));
    spc_mat4 T = spc_mat4_translate(spc_v3(-1, 0, 1));
    spc_mat4 SR = spc_mat4_mul(&S, &R);
    spc_mat4 M = spc_mat4_mul(&T, &SR);
    spc_shape_init_rectangle(pane, &M, NULL, 0, 0, &err);
    pane->bsdf = tu_glass(sc, 1.5);
    tu_sphere(sc, spc_v3(0, 0, 0.4), 0.4, tu_glass(sc, 1.5));
    spc_shape *light = tu_sphere(sc, spc_v3(1.5, 0, 2.0), 0.12, tu_diffuse(sc, 0.0));
    tu_area(sc, light, 3, 170.0);
    tu_camera(sc, spc_v3(1.8, -2.2, 1.2), spc_v3(-1, 0, 0.5), spc_v3(0, 0, 1), 40, RES, RES);
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* The summed variance (of the pixel means, over channels) of a's pixels and of b's over the pixels
 * where a and b differ: with the same seed, those whose samples met the split. */
static void var_where_differ(const spc_film *a, const spc_film *b, double *va, double *vb, int *n)
{
    *va = *vb = 0.0;
    *n = 0;
    for (int i = 0; i < a->width * a->height; ++i) {
        if (a->rgb[3 * i] == b->rgb[3 * i] && a->rgb[3 * i + 1] == b->rgb[3 * i + 1] &&
            a->rgb[3 * i + 2] == b->rgb[3 * i + 2])
            continue;
        ++*n;
        for (int c = 0; c < 3; ++c) {
            *va += a->var[3 * i + c];
            *vb += b->var[3 * i + c];
        }
    }
}

TEST(split_agrees_with_nosplit_and_none_and_lowers_the_variance)
{
    spc_scene *sc = pane_scene();
    CHECK(sc != NULL);
    if (!sc)
        return;
    const char *on = "angular:first=0.1,later=0.1", *off = "angular:first=0.1,later=0.1,nosplit";
    /* under the sanitizers (SPC_TEST_QUICK) half the samples: the same checks at lower precision */
    int spp = spc_test_quick() ? 512 : 1024;
    spc_film *split = tu_render_nee(sc, "path", on, spp, 2, 41, NULL);
    spc_film *nosplit = tu_render_nee(sc, "path", off, spp, 2, 43, NULL);
    spc_film *paired = tu_render_nee(sc, "path", off, spp, 2, 41, NULL);
    spc_film *none = tu_render_nee(sc, "path", "none", 16 * spp, 2, 42, NULL);
    CHECK(split && nosplit && paired && none);
    if (split && nosplit && paired && none) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(split, nosplit, 0.99, "split vs nosplit", &d));
        printf("    split vs nosplit: z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction,
               d.ztest_pixels, d.mean_a[0], d.mean_b[0]);
        /* against none the image means (none's per-pixel variances of the caustic are too rough at
         * this sample count for a per-pixel test) */
        for (int c = 0; c < 3; ++c) {
            double ms, ss, mn, sn;
            tu_image_mean(split, c, &ms, &ss);
            tu_image_mean(none, c, &mn, &sn);
            printf("    channel %d: split %.5f +- %.5f, none %.5f +- %.5f\n", c, ms, ss, mn, sn);
            CHECK(fabs(ms - mn) <= 3.0 * sqrt(ss * ss + sn * sn));
        }
        /* the same seed: the same camera paths, each reflection's caustic split or sampled */
        double vs, vn;
        int n;
        var_where_differ(split, paired, &vs, &vn, &n);
        printf("    summed variance at %d spp, seed 41, over the %d pixels the split changed: split %.4g, nosplit "
               "%.4g (ratio %.2f)\n",
               spp, n, vs, vn, vn / vs);
        CHECK(n > 0);
        CHECK(vs < vn);
    }
    spc_film_destroy(split);
    spc_film_destroy(nosplit);
    spc_film_destroy(paired);
    spc_film_destroy(none);
    spc_scene_destroy(sc);
}

TEST(split_by_roulette_agrees_with_nosplit_and_ranks_by_its_probability)
{
    spc_scene *sc = pane_scene();
    CHECK(sc != NULL);
    if (!sc)
        return;
    const char *on = "angular:first=0.1,later=0.1", *half = "angular:first=0.1,later=0.1,splitf=0.5";
    const char *off = "angular:first=0.1,later=0.1,nosplit";
    int spp = spc_test_quick() ? 512 : 1024;
    spc_film *rl = tu_render_nee(sc, "path", half, spp, 2, 41, NULL);
    spc_film *nosplit = tu_render_nee(sc, "path", off, spp, 2, 43, NULL);
    spc_film *paired = tu_render_nee(sc, "path", off, spp, 2, 41, NULL);
    spc_film *split = tu_render_nee(sc, "path", on, spp, 2, 41, NULL);
    CHECK(rl && nosplit && paired && split);
    if (rl && nosplit && paired && split) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(rl, nosplit, 0.99, "splitf=0.5 vs nosplit", &d));
        printf("    splitf=0.5 vs nosplit: z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction,
               d.ztest_pixels, d.mean_a[0], d.mean_b[0]);
        /* the same seed, so the same camera paths: the pixels each split changed */
        double vr, vn, vs, vn2;
        int n, n2;
        var_where_differ(rl, paired, &vr, &vn, &n);
        var_where_differ(split, paired, &vs, &vn2, &n2);
        printf("    summed variance at %d spp, seed 41: splitf=0.5 %.4g over %d pixels (nosplit %.4g), default "
               "%.4g over %d pixels (nosplit %.4g)\n",
               spp, vr, n, vn, vs, n2, vn2);
        CHECK(n > 0 && n2 > 0);
        CHECK(vr < vn);
        CHECK(vs < vr + (vn2 - vn));
    }
    spc_film_destroy(rl);
    spc_film_destroy(nosplit);
    spc_film_destroy(paired);
    spc_film_destroy(split);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(split_agrees_with_nosplit_and_none_and_lowers_the_variance);
    RUN(split_by_roulette_agrees_with_nosplit_and_ranks_by_its_probability);
    return spc_test_finish();
}
