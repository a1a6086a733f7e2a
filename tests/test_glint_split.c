/*
 * tests/test_glint_split.c: the path tracer's emission splitting at a smooth dielectric seen from
 * the camera (integrator/path.c, split_emission).
 *
 * The scene: a flat water surface (a dielectric rectangle, eta 1.33) over a diffuse floor (so
 * specular NEE runs), a small bright sphere light out of view, placed so that its mirror image in
 * the water lies on the camera's axis: the light's reflection fills the centre pixel of the 9 x 9
 * image. BSDF sampling picks that reflection with the Fresnel probability (about 0.03), so without
 * splitting the centre pixel's samples are Le with probability F and the rest of the time the floor.
 * Specular NEE runs without its camera queries (angular:first=0.1,later=0.1), so the reflection's
 * emitter hit is the only strategy for that path. Checked:
 * - the render with splitting agrees with `none` (no specular NEE, no splitting) per pixel
 *   (z-test, Sidak) and by image mean;
 * - at the centre pixel its variance of the mean at the same sample count is at least 8 times
 *   lower than none's (every sample finds the glint at F times its value); without the splitting
 *   the two are equal in expectation.
 */
/* ctest-labels: stat */
#include "harness.h"
#include "render_util.h"

static spc_scene *glint_water(void)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *floor = spc_scene_new_shape(sc);
    spc_mat4 T = spc_mat4_translate(spc_v3(0, 0, -0.5)), S = spc_mat4_scale(spc_v3(3, 3, 1));
    spc_mat4 M = spc_mat4_mul(&T, &S);
    spc_shape_init_rectangle(floor, &M, NULL, 0, 0, &err);
    floor->bsdf = tu_diffuse(sc, 0.5);
    spc_shape *water = spc_scene_new_shape(sc);
    spc_shape_init_rectangle(water, &S, NULL, 0, 0, &err);
    water->bsdf = tu_glass(sc, 1.33);
    spc_shape *light = tu_sphere(sc, spc_v3(0, 2, 1), 0.3, tu_diffuse(sc, 0.0));
    tu_area(sc, light, 2, 10.0);
    tu_camera(sc, spc_v3(0, -2, 1), spc_v3(0, 0, 0), spc_v3(0, 0, 1), 20, 9, 9);
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

TEST(split_agrees_with_none_and_lowers_the_glint_variance)
{
    spc_scene *sc = glint_water();
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *def = tu_render_nee(sc, "path", "angular:first=0.1,later=0.1", 1024, 2, 41, NULL);
    spc_film *none = tu_render_nee(sc, "path", "none", 4096, 2, 42, NULL);
    CHECK(def && none);
    if (def && none) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(def, none, 0.99, "split vs none", &d));
        printf("    z-test pass %.4f of %d pixels; means %.5f vs %.5f\n", d.ztest_pass_fraction, d.ztest_pixels,
               d.mean_a[0], d.mean_b[0]);
        /* the centre pixel; none's variance of the mean scaled to 1024 spp (it renders 4096) */
        size_t c = (size_t)none->width * none->height / 2;
        double vn = 4.0 * none->var[3 * c], vd = def->var[3 * c];
        printf("    centre pixel: variance of the mean at 1024 spp none %.4g, split %.4g (ratio %.1f); "
               "values %.4f, %.4f\n",
               vn, vd, vn / vd, none->rgb[3 * c], def->rgb[3 * c]);
        CHECK(vd * 8.0 < vn);
    }
    spc_film_destroy(def);
    spc_film_destroy(none);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(split_agrees_with_none_and_lowers_the_glint_variance);
    return spc_test_finish();
}
