/*
 * tests/test_snee_lights.c: specular NEE's chains toward the kinds of area light
 * (manifold/specular_nee.c, the last segment of a chain).
 *
 * - A small rectangle light (two triangles) a few units from the origin, a glass ball between it
 *   and the floor: the default's image of the ball's shadow and caustic against specular NEE off.
 *   A point sampled on a triangle lies off the plane the ray tracer intersects by up to its error
 *   bound; a chain's last segment that stopped short of it by less shadowed the light by itself,
 *   and about one chain in seven was lost (the image 14% low, z about -8, 94% of the pixels
 *   passing; random caustic scene 16 was 16% low on the floor in the ball's shadow). The light's size, radiance and the camera
 *   are those of that case, where the loss showed; a light three times larger lost nothing.
 */
/* ctest-labels: stat */
/* ctest-timeout: 300 */
#include <string.h>

#include "harness.h"
#include "render_util.h"

/* A floor (z = 0, half-size 4), a glass sphere of radius 0.257 resting on it, and a square light of
 * half-size ls and radiance L at (2.91, 0.822, 3.039) facing the origin; an 8x8 camera looking
 * straight down at the ball's shadow from 1.2 above. (Random caustic scene 16's small ball and light,
 * its y-up coordinates turned to z-up.) NULL if the scene cannot be made. */
static spc_scene *shadow_scene(double ls, double L)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *fl = spc_scene_new_shape(sc);
    spc_mat4 F = spc_mat4_scale(spc_v3(4, 4, 1));
    spc_shape_init_rectangle(fl, &F, NULL, 0, 0, &err);
    fl->bsdf = tu_diffuse(sc, 0.5);
    tu_sphere(sc, spc_v3(-0.516, 0.656, 0.257), 0.257, tu_glass(sc, 1.5));
    spc_shape *light = spc_scene_new_shape(sc);
    spc_mat4 look, S = spc_mat4_scale(spc_v3(ls, ls, 1));
    spc_mat4_lookat(spc_v3(2.91, 0.822, 3.039), spc_v3(0, 0, 0), spc_v3(0, -0.01, 1), &look);
    spc_mat4 M = spc_mat4_mul(&look, &S);
    spc_shape_init_rectangle(light, &M, NULL, 0, 0, &err);
    light->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, light, 2, L);
    tu_camera(sc, spc_v3(-1.0, 0.64, 1.2), spc_v3(-1.0, 0.64, 0.0), spc_v3(1, 0, 0), 30, 8, 8);
    sc->integrator.max_depth = 4;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

TEST(triangle_light_chains_not_self_shadowed)
{
    spc_scene *sc = shadow_scene(0.4, 75.0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *ref = tu_render_nee(sc, "path", "none", 65536, 2, 51, NULL);
    spc_film *img = tu_render_nee(sc, "path", NULL, 2048, 2, 52, NULL);
    CHECK(ref && img);
    if (ref && img) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(img, ref, 0.95, "default vs none", &d));
        double ma, sa, mb, sb;
        tu_image_mean(img, 1, &ma, &sa);
        tu_image_mean(ref, 1, &mb, &sb);
        printf("    z-test pass %.4f of %d pixels; green means %.5f +- %.5f vs %.5f +- %.5f (ratio %.4f)\n",
               d.ztest_pass_fraction, d.ztest_pixels, ma, sa, mb, sb, ma / mb);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(triangle_light_chains_not_self_shadowed);
    return spc_test_finish();
}
