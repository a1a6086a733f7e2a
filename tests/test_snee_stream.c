/*
 * tests/test_snee_stream.c: specular NEE inside the path tracer draws from a sample stream of its
 * own (spc_sampler_split, integrator/path_snee.c), so that the ordinary light sample, BSDF sample
 * and Russian roulette of every vertex use the sampler dimensions they use with specular NEE off.
 * Checked:
 * - the split stream: a pure function of (pixel, seed, sample index, stream), the parent not moved,
 *   other values than the parent's, and stratified as the parent is (the first 16 sample indices of
 *   a pair put one point in each cell of a 4 x 4 grid);
 * - a scene where specular NEE runs at every vertex but finds no light: a glass ball above a small
 *   one-sided area light that faces away from it, so every chain ends on the light's dark back.
 *   `path` with specular NEE (angular, at every receiver) then renders none's image bit for bit,
 *   sums and variances: a specular NEE that took one dimension of the path's sampler moves every
 *   later light and BSDF sample and changes the image. The same scene with the ball below the
 *   light (a caustic on the floor) must differ from none's, so the comparison sees specular NEE;
 * - the image with specular NEE is the same for 1 and 2 threads.
 */
/* ctest-labels: scene */
#include "core/sampler.h"
#include "harness.h"
#include "render_util.h"

/* A floor, a small square light at height 2 facing down, and a glass ball of radius 0.4 centred at
 * height ball_z: above the light (2.6) every chain from the floor through the ball reaches the
 * light's back, which does not emit; below it (1.0) the ball focuses the light on the floor. */
static spc_scene *ball_and_light(double ball_z)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *floor = spc_scene_new_shape(sc);
    spc_mat4 M = spc_mat4_scale(spc_v3(2, 2, 1));
    spc_shape_init_rectangle(floor, &M, NULL, 0, 0, &err);
    floor->bsdf = tu_diffuse(sc, 0.7);
    tu_sphere(sc, spc_v3(0.1, 0, ball_z), 0.4, tu_glass(sc, 1.5));
    spc_shape *light = spc_scene_new_shape(sc);
    spc_mat4 T = spc_mat4_translate(spc_v3(0, 0, 2)), R = spc_mat4_rotate(spc_v3(1, 0, 0), 180.0);
    spc_mat4 S = spc_mat4_scale(spc_v3(0.3, 0.3, 1)), RS = spc_mat4_mul(&R, &S), L = spc_mat4_mul(&T, &RS);
    spc_shape_init_rectangle(light, &L, NULL, 0, 0, &err);
    light->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, light, 2, 20.0);
    tu_camera(sc, spc_v3(0, -3.5, 2.5), spc_v3(0, 0, 0.3), spc_v3(0, 0, 1), 45, 16, 16);
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

static bool same_film(const spc_film *a, const spc_film *b)
{
    size_t n = 3 * (size_t)a->width * (size_t)a->height;
    return a->width == b->width && a->height == b->height && memcmp(a->rgb, b->rgb, n * sizeof *a->rgb) == 0 &&
           memcmp(a->var, b->var, n * sizeof *a->var) == 0;
}

TEST(split_stream_is_its_own_and_stratified)
{
    spc_sampler s, t, a, b;
    spc_sampler_start(&s, 5, 9, 3, 42);
    spc_sampler_2d(&s); /* the split does not depend on how far the parent has gone */
    uint32_t dim = s.dim;
    spc_sampler_split(&s, 77, &a);
    CHECK(s.dim == dim);
    spc_sampler_start(&t, 5, 9, 3, 42);
    spc_sampler_split(&t, 77, &b);
    spc_vec2 ua = spc_sampler_2d(&a), ub = spc_sampler_2d(&b);
    CHECK(ua.x == ub.x && ua.y == ub.y);
    spc_sampler_split(&t, 78, &b);
    spc_vec2 uc = spc_sampler_2d(&b), up = spc_sampler_2d(&t);
    CHECK(uc.x != ua.x && up.x != ua.x);
    /* the first 16 indices of the split stream's first three pairs: one point per 4 x 4 cell */
    for (int pair = 0; pair < 3; ++pair) {
        int cells[16] = {0};
        for (uint32_t i = 0; i < 16; ++i) {
            spc_sampler p, q;
            spc_sampler_start(&p, 5, 9, i, 42);
            spc_sampler_split(&p, 77, &q);
            spc_vec2 u = spc_sampler_2d(&q);
            for (int k = 0; k < pair; ++k)
                u = spc_sampler_2d(&q);
            ++cells[(int)(u.x * 4) + 4 * (int)(u.y * 4)];
        }
        for (int c = 0; c < 16; ++c)
            CHECK_MSG(cells[c] == 1, "pair %d cell %d holds %d points", pair, c, cells[c]);
    }
}

TEST(no_reachable_caustic_renders_none_bit_for_bit)
{
    spc_scene *sc = ball_and_light(2.6);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_render_stats st;
    spc_film *on = tu_render_stats(sc, "path", "angular", 64, 2, 11, &st);
    spc_film *off = tu_render_nee(sc, "path", "none", 64, 2, 11, NULL);
    CHECK(on && off);
    if (on && off) {
        CHECK_MSG(strncmp(st.specular_nee, "angular", 7) == 0, "specular NEE that ran: '%s'", st.specular_nee);
        double m, se;
        tu_image_mean(off, 0, &m, &se);
        CHECK(m > 0.01); /* the floor is lit */
        CHECK_MSG(same_film(on, off), "with specular NEE on, the image is not none's");
    }
    spc_film_destroy(on);
    spc_film_destroy(off);
    spc_scene_destroy(sc);
}

TEST(reachable_caustic_differs_and_is_thread_independent)
{
    spc_scene *sc = ball_and_light(1.0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *on2 = tu_render_nee(sc, "path", "angular", 64, 2, 11, NULL);
    spc_film *on1 = tu_render_nee(sc, "path", "angular", 64, 1, 11, NULL);
    spc_film *off = tu_render_nee(sc, "path", "none", 64, 2, 11, NULL);
    CHECK(on2 && on1 && off);
    if (on2 && on1 && off) {
        CHECK_MSG(!same_film(on2, off), "specular NEE changed nothing where the ball focuses the light");
        CHECK_MSG(same_film(on2, on1), "the image depends on the thread count");
    }
    spc_film_destroy(on2);
    spc_film_destroy(on1);
    spc_film_destroy(off);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(split_stream_is_its_own_and_stratified);
    RUN(no_reachable_caustic_renders_none_bit_for_bit);
    RUN(reachable_caustic_differs_and_is_thread_independent);
    return spc_test_finish();
}
