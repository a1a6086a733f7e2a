/*
 * tests/test_emitter.c: closed-form values of every emitter, consistency of sample_direct with
 * pdf_direct, chi-square tests of direct and emission sampling against their densities, and
 * light selection in proportion to power.
 */
/* ctest-labels: unit stat */
#include "chi2.h"
#include "harness.h"
#include "render_util.h"

#define N_CHI2 200000
#define N_CHI2_TESTS 8

/* A scene holding one emitting shape. */
static spc_scene *light_scene(int kind)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 R = spc_mat4_rotate(spc_v3(1, 0.3, 0), 40);
    spc_mat4 T = spc_mat4_translate(spc_v3(0.2, 0.1, 2.0));
    spc_mat4 S = spc_mat4_scale(spc_v3(0.8, 0.5, 1));
    spc_mat4 M = spc_mat4_mul(&T, &R);
    M = spc_mat4_mul(&M, &S);
    bool ok = false;
    switch (kind) {
    case 0: ok = spc_shape_init_rectangle(sh, &M, NULL, 0, 0, &err); break;
    case 1: ok = spc_shape_init_disk(sh, &M, NULL, 0, 0, &err); break;
    case 2: ok = spc_shape_init_sphere(sh, spc_v3(0.2, 0.1, 2.0), 0.7, NULL, NULL, 0, 0, &err); break;
    }
    CHECK(ok);
    sh->flip_normals = kind != 2; /* face the origin, where the tests look from */
    sh->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, sh, 0, 3.0);
    CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
    return sc;
}

typedef struct direct_ctx {
    const spc_scene *sc;
    spc_vec3 ref;
} direct_ctx;

static bool direct_sample(void *user, spc_rng *rng, spc_vec3 *dir)
{
    direct_ctx *c = user;
    spc_emitter_direct ds;
    if (!spc_emitter_sample_direct(c->sc->emitters[0], c->ref, spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &ds))
        return false;
    *dir = ds.wi;
    return true;
}

/* density of a direction: the first surface point along it (each of these shapes is hit at most
 * once from the front along any direction from ref... the sphere twice: the near point counts) */
static double direct_pdf(void *user, spc_vec3 dir)
{
    direct_ctx *c = user;
    spc_ray r = {c->ref, dir, 0.0, INFINITY};
    spc_hit h;
    if (!spc_scene_intersect(c->sc, &r, &h))
        return 0.0;
    if (spc_dot(h.ng, dir) >= 0.0) /* back side: one-sided lights do not emit there */
        return 0.0;
    return spc_emitter_pdf_direct(c->sc->emitters[0], c->ref, h.p, h.ng);
}

TEST(area_direct_sampling)
{
    const char *names[3] = {"rectangle", "disk", "sphere (cone)"};
    for (int k = 0; k < 3; ++k) {
        spc_scene *sc = light_scene(k);
        direct_ctx c = {sc, spc_v3(0, 0, 0)};
        /* consistency of each sample with pdf_direct and the radiance */
        spc_rng rng;
        spc_rng_seed(&rng, 5, (uint64_t)k);
        for (int i = 0; i < 1000; ++i) {
            spc_emitter_direct ds;
            if (!spc_emitter_sample_direct(sc->emitters[0], c.ref, spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &ds))
                continue;
            CHECK_REL(ds.pdf, spc_emitter_pdf_direct(sc->emitters[0], c.ref, ds.p, ds.n), 1e-9, 0);
            CHECK_NEAR(ds.L.r, 3.0, 1e-12);
            CHECK_NEAR(spc_distance(spc_madd(c.ref, ds.wi, ds.dist), ds.p), 0.0, 1e-9);
            CHECK(!ds.is_delta);
        }
        spc_frame fr = spc_frame_from_n(spc_normalize(spc_v3(0.2, 0.1, 2.0)));
        double p = chi2_direction_test(names[k], direct_sample, direct_pdf, &c, &fr, N_CHI2, 100 + (uint64_t)k, true);
        CHECK_MSG(chi2_accept(p, N_CHI2_TESTS), "%s: p = %g", names[k], p);
        spc_scene_destroy(sc);
    }
}

/* The same test with a wrong density must fail (the test has power). */
static double wrong_pdf(void *user, spc_vec3 dir)
{
    spc_vec3 l = dir;
    return direct_pdf(user, dir) * (1.0 + 0.3 * l.x);
}

TEST(chi2_rejects_wrong_density)
{
    spc_scene *sc = light_scene(0);
    direct_ctx c = {sc, spc_v3(0, 0, 0)};
    spc_frame fr = spc_frame_from_n(spc_normalize(spc_v3(0.2, 0.1, 2.0)));
    double p = chi2_direction_test("rectangle, wrong pdf", direct_sample, wrong_pdf, &c, &fr, N_CHI2, 7, true);
    CHECK(!chi2_accept(p, N_CHI2_TESTS));
    spc_scene_destroy(sc);
}

typedef struct emission_ctx {
    const spc_emitter *e;
} emission_ctx;

static bool emission_sample(void *user, spc_rng *rng, spc_vec3 *dir)
{
    emission_ctx *c = user;
    spc_emitter_emission em;
    spc_vec2 up = spc_v2(0.3, 0.6); /* a fixed point: the direction density is conditional on it */
    if (!spc_emitter_sample_emission(c->e, up, spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &em))
        return false;
    *dir = em.d;
    return true;
}

static double emission_pdf(void *user, spc_vec3 dir)
{
    emission_ctx *c = user;
    spc_emitter_emission em;
    spc_emitter_sample_emission(c->e, spc_v2(0.3, 0.6), spc_v2(0.5, 0.5), &em);
    double pp, pd;
    spc_emitter_pdf_emission(c->e, em.p, em.n, dir, &pp, &pd);
    return pd;
}

TEST(emission_sampling)
{
    /* area light: cosine-weighted directions; weight = Le pi area */
    spc_scene *sc = light_scene(0);
    const spc_emitter *e = sc->emitters[0];
    spc_emitter_emission em;
    CHECK(spc_emitter_sample_emission(e, spc_v2(0.3, 0.6), spc_v2(0.2, 0.7), &em));
    CHECK_REL(em.weight.r, 3.0 * SPC_PI * e->shape->area, 1e-9, 0);
    double pp, pd;
    spc_emitter_pdf_emission(e, em.p, em.n, em.d, &pp, &pd);
    CHECK_REL(pp, em.pdf_pos, 1e-12, 0);
    CHECK_REL(pd, em.pdf_dir, 1e-12, 0);
    emission_ctx c = {e};
    spc_frame fr = spc_frame_from_n(em.n);
    double p = chi2_direction_test("area emission", emission_sample, emission_pdf, &c, &fr, N_CHI2, 11, true);
    CHECK_MSG(chi2_accept(p, N_CHI2_TESTS), "p = %g", p);
    spc_scene_destroy(sc);

    /* point light: uniform sphere, weight 4 pi I */
    spc_emitter pt;
    memset(&pt, 0, sizeof pt);
    pt.type = SPC_EMITTER_POINT;
    pt.intensity = spc_rgb1(2.0);
    pt.position = spc_v3(1, 2, 3);
    CHECK(spc_emitter_prepare(&pt, spc_v3(0, 0, 0), 10));
    CHECK(spc_emitter_sample_emission(&pt, spc_v2(0, 0), spc_v2(0.2, 0.7), &em));
    CHECK_REL(em.weight.g, 8.0 * SPC_PI, 1e-12, 0);
    CHECK(em.delta_pos);
    emission_ctx cp = {&pt};
    spc_frame f2 = spc_frame_from_n(spc_v3(0, 0, 1));
    p = chi2_direction_test("point emission", emission_sample, emission_pdf, &cp, &f2, N_CHI2, 12, true);
    CHECK_MSG(chi2_accept(p, N_CHI2_TESTS), "p = %g", p);
}

/* A projector at the origin looking down -z (lookat), fov 90 along x, over a 2 x 2 image (nearest):
 * closed forms of sample_direct (Mitsuba's pi scale E / (z^2 cos)), the image's orientation (its
 * left column toward the projector's left, local +x, as a camera there would see it), emission
 * sampling against its density (chi-square) and its weight against sample_direct's intensity. */
TEST(projector)
{
    static float px[12] = {1, 0, 0, 0, 1, 0, /* top row: red, green */
                           0, 0, 1, 0.5f, 0.5f, 0.5f}; /* bottom row: blue, grey */
    spc_texture img;
    spc_texture_init_constant(&img, spc_rgb1(0));
    img.type = SPC_TEX_BITMAP;
    img.width = img.height = 2;
    img.data = px;
    img.nearest = true;
    img.wrap = SPC_WRAP_CLAMP;
    spc_emitter pr;
    memset(&pr, 0, sizeof pr);
    pr.type = SPC_EMITTER_PROJECTOR;
    pr.texture = &img;
    pr.scale = 3.0;
    CHECK(spc_fov_tangents(90.0, SPC_FOV_X, 2, 2, &pr.tan_x, &pr.tan_y));
    CHECK_NEAR(pr.tan_x, 1.0, 1e-12);
    CHECK_NEAR(pr.tan_y, 1.0, 1e-12);
    spc_mat4_lookat(spc_v3(0, 0, 0), spc_v3(0, 0, -1), spc_v3(0, 1, 0), &pr.to_world);
    CHECK(spc_emitter_prepare(&pr, spc_v3(0, 0, 0), 10));
    CHECK(spc_emitter_is_delta(&pr));
    /* flux: pi scale A mean(E), A = 4 */
    CHECK_NEAR(pr.power, SPC_PI * 3.0 * 4.0 * (1 + 1 + 1 + 1.5) / 12.0, 1e-9);
    spc_vec3 left = spc_mat4_apply_vector(&pr.to_world, spc_v3(1, 0, 0));
    spc_vec3 up = spc_mat4_apply_vector(&pr.to_world, spc_v3(0, 1, 0));
    spc_emitter_direct ds;
    /* up and to the left at z = 2: top-left texel (red); cos = 2 / |(1, 1, 2)| */
    spc_vec3 q = spc_add(spc_v3(0, 0, -2), spc_add(left, up));
    CHECK(spc_emitter_sample_direct(&pr, q, spc_v2(0, 0), &ds));
    double cosq = 2.0 / sqrt(6.0);
    CHECK_NEAR(ds.L.r, SPC_PI * 3.0 / (4.0 * cosq), 1e-9);
    CHECK(ds.L.g == 0.0 && ds.L.b == 0.0 && ds.is_delta);
    CHECK_NEAR(ds.dist, sqrt(6.0), 1e-12);
    /* down and to the right: bottom-right texel (grey) */
    q = spc_sub(spc_v3(0, 0, -2), spc_add(left, up));
    CHECK(spc_emitter_sample_direct(&pr, q, spc_v2(0, 0), &ds));
    CHECK_NEAR(ds.L.g, 0.5 * SPC_PI * 3.0 / (4.0 * cosq), 1e-9);
    /* outside the frustum, and behind */
    CHECK(!spc_emitter_sample_direct(&pr, spc_v3(2.5, 0, -2), spc_v2(0, 0), &ds));
    CHECK(!spc_emitter_sample_direct(&pr, spc_v3(0, 0, 2), spc_v2(0, 0), &ds));

    /* emission: the weight is the intensity over the direction's density */
    spc_rng rng;
    spc_rng_seed(&rng, 5, 1);
    int bad = 0;
    for (int i = 0; i < 200; ++i) {
        spc_emitter_emission em;
        if (!spc_emitter_sample_emission(&pr, spc_v2(0, 0), spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &em))
            continue;
        double pp, pd;
        spc_emitter_pdf_emission(&pr, em.p, em.n, em.d, &pp, &pd);
        bad += !(fabs(pd - em.pdf_dir) <= 1e-9 * em.pdf_dir) || !em.delta_pos;
        if (!spc_emitter_sample_direct(&pr, spc_madd(em.p, em.d, 2.0), spc_v2(0, 0), &ds))
            continue; /* a texel's edge */
        double I = ds.L.r * 4.0;
        bad += !(fabs(em.weight.r - I / em.pdf_dir) <= 1e-6 * (I / em.pdf_dir) + 1e-9);
    }
    CHECK_MSG(bad == 0, "%d emission samples disagree with sample_direct or pdf_emission", bad);
    emission_ctx c = {&pr};
    spc_frame fr = spc_frame_from_n(spc_v3(0, 0, -1));
    double p = chi2_direction_test("projector emission", emission_sample, emission_pdf, &c, &fr, N_CHI2, 13, true);
    CHECK_MSG(chi2_accept(p, N_CHI2_TESTS), "p = %g", p);
    img.data = NULL;
    spc_emitter_release(&pr);
}

TEST(point_and_spot_closed_forms)
{
    spc_emitter pt;
    memset(&pt, 0, sizeof pt);
    pt.type = SPC_EMITTER_POINT;
    pt.intensity = spc_rgb3(1, 2, 4);
    pt.position = spc_v3(0, 0, 2);
    CHECK(spc_emitter_prepare(&pt, spc_v3(0, 0, 0), 10));
    CHECK_NEAR(pt.power, 4 * SPC_PI * 7.0 / 3.0, 1e-12);
    spc_emitter_direct ds;
    CHECK(spc_emitter_sample_direct(&pt, spc_v3(0, 0, 0), spc_v2(0.5, 0.5), &ds));
    CHECK_NEAR(ds.L.b, 4.0 / 4.0, 1e-12);
    CHECK_NEAR(ds.dist, 2.0, 1e-12);
    CHECK(ds.is_delta && ds.pdf == 1.0);
    CHECK_NEAR(ds.wi.z, 1.0, 1e-12);

    /* spot at the origin looking down -z (to_world: lookat), cutoff 30, beam 20 degrees */
    spc_emitter sp;
    memset(&sp, 0, sizeof sp);
    sp.type = SPC_EMITTER_SPOT;
    sp.intensity = spc_rgb1(5.0);
    sp.cutoff_angle = 30;
    sp.beam_width = 20;
    spc_mat4_lookat(spc_v3(0, 0, 0), spc_v3(0, 0, -1), spc_v3(0, 1, 0), &sp.to_world);
    CHECK(spc_emitter_prepare(&sp, spc_v3(0, 0, 0), 10));
    CHECK(spc_emitter_sample_direct(&sp, spc_v3(0, 0, -2), spc_v2(0, 0), &ds));
    CHECK_NEAR(ds.L.r, 5.0 / 4.0, 1e-12); /* inside the beam: full intensity */
    double th = 25.0 * SPC_PI / 180.0;     /* halfway through the falloff */
    CHECK(spc_emitter_sample_direct(&sp, spc_v3(sin(th), 0, -cos(th)), spc_v2(0, 0), &ds));
    CHECK_NEAR(ds.L.r, 5.0 * 0.5, 1e-9);
    CHECK(!spc_emitter_sample_direct(&sp, spc_v3(1, 0, -1), spc_v2(0, 0), &ds)); /* 45 degrees: outside */

    /* directional: irradiance arriving along -direction */
    spc_emitter dl;
    memset(&dl, 0, sizeof dl);
    dl.type = SPC_EMITTER_DIRECTIONAL;
    dl.direction = spc_v3(0, -2, 0);
    dl.irradiance = spc_rgb1(3.0);
    CHECK(spc_emitter_prepare(&dl, spc_v3(0, 0, 0), 1));
    CHECK(spc_emitter_sample_direct(&dl, spc_v3(0, 0, 0), spc_v2(0, 0), &ds));
    CHECK_NEAR(ds.wi.y, 1.0, 1e-12);
    CHECK(ds.is_infinite && ds.L.r == 3.0);
}

TEST(area_light_is_one_sided)
{
    spc_scene *sc = light_scene(0);
    const spc_emitter *e = sc->emitters[0];
    /* the rectangle's normal: +z rotated; a point behind it sees nothing */
    spc_shape_sample ss;
    spc_shape_sample_area(e->shape, spc_v2(0.5, 0.5), &ss);
    CHECK(ss.n.z < 0.0); /* flipped toward the origin */
    spc_vec3 behind = spc_madd(ss.p, ss.n, -1.0), front = spc_madd(ss.p, ss.n, 1.0);
    spc_emitter_direct ds;
    CHECK(!spc_emitter_sample_direct(e, behind, spc_v2(0.5, 0.5), &ds));
    CHECK(spc_emitter_sample_direct(e, front, spc_v2(0.5, 0.5), &ds));
    CHECK_NEAR(e->power, SPC_PI * e->shape->area * 3.0, 1e-9);
    spc_scene_destroy(sc);
}

/* An environment map: directions follow the texel distribution, the density matches, and the
 * lat-long orientation puts the top row of the image at local +y. */
static bool env_sample(void *user, spc_rng *rng, spc_vec3 *dir)
{
    const spc_emitter *e = user;
    spc_emitter_direct ds;
    if (!spc_emitter_sample_direct(e, spc_v3(0, 0, 0), spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &ds))
        return false;
    *dir = ds.wi;
    return true;
}

/* dir points toward the environment, like an escaping ray */
static double env_pdf(void *user, spc_vec3 dir) { return spc_emitter_pdf_infinite(user, dir); }

TEST(envmap_sampling_and_orientation)
{
    spc_texture t;
    memset(&t, 0, sizeof t);
    t.type = SPC_TEX_BITMAP;
    t.width = 16;
    t.height = 8;
    t.data = calloc(3 * 16 * 8, sizeof(float));
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 16; ++x)
            for (int c = 0; c < 3; ++c)
                t.data[3 * (y * 16 + x) + c] = 0.1f + (y == 0 ? 5.0f : 0.0f) + (x == 5 && y == 3 ? 20.0f : 0.0f);
    spc_emitter e;
    memset(&e, 0, sizeof e);
    e.type = SPC_EMITTER_ENVMAP;
    e.radiance = &t;
    e.scale = 2.0;
    e.to_world = spc_mat4_identity();
    CHECK(spc_emitter_prepare(&e, spc_v3(0, 0, 0), 1.0));
    /* a ray escaping upward (+y) sees the top row of the image, one escaping downward the bottom */
    spc_rgb top = spc_emitter_eval_infinite(&e, spc_v3(0, 1, 0));
    spc_rgb bottom = spc_emitter_eval_infinite(&e, spc_v3(0, -1, 0));
    CHECK_NEAR(top.r, 2.0 * 5.1, 1e-5);
    CHECK_NEAR(bottom.r, 2.0 * 0.1, 1e-6);
    /* u = atan2(x, -z) / 2 pi: texel column 5 is centred at u = 5.5/16; rows sit on
     * v = j / (height - 1) (Mitsuba 3's placement: the first and last rows on the poles), so row 3
     * is at theta = 3/7 pi */
    double phi = 2 * SPC_PI * 5.5 / 16, th = SPC_PI * 3.0 / 7.0;
    spc_vec3 spot = spc_v3(sin(th) * sin(phi), cos(th), -sin(th) * cos(phi));
    CHECK_NEAR(spc_emitter_eval_infinite(&e, spot).r, 2.0 * 20.1, 1e-4);
    spc_emitter_direct ds;
    CHECK(spc_emitter_sample_direct(&e, spc_v3(0, 0, 0), spc_v2(0.3, 0.3), &ds));
    CHECK_NEAR(ds.L.r, spc_emitter_eval_infinite(&e, ds.wi).r, 1e-9);
    CHECK_REL(ds.pdf, spc_emitter_pdf_infinite(&e, ds.wi), 1e-9, 0);
    spc_frame fr = spc_frame_from_n(spc_v3(1, 0, 0));
    double p = chi2_direction_test("envmap", env_sample, env_pdf, &e, &fr, N_CHI2, 21, true);
    CHECK_MSG(chi2_accept(p, N_CHI2_TESTS), "p = %g", p);
    spc_emitter_release(&e);
    free(t.data);
}

TEST(lights_chosen_by_power)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    for (int i = 0; i < 2; ++i) {
        spc_shape *sh = spc_scene_new_shape(sc);
        spc_mat4 T = spc_mat4_translate(spc_v3(3.0 * i, 0, 0));
        CHECK(spc_shape_init_rectangle(sh, &T, NULL, 0, 0, &err));
        sh->bsdf = tu_diffuse(sc, 0.5);
        tu_area(sc, sh, i, i == 0 ? 1.0 : 3.0);
    }
    CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
    CHECK_NEAR(spc_scene_emitter_pmf(sc, sc->emitters[0]), 0.25, 1e-12);
    CHECK_NEAR(spc_scene_emitter_pmf(sc, sc->emitters[1]), 0.75, 1e-12);
    double pmf;
    CHECK(spc_scene_sample_emitter(sc, 0.1, &pmf) == sc->emitters[0]);
    CHECK(spc_scene_sample_emitter(sc, 0.3, &pmf) == sc->emitters[1]);
    CHECK_NEAR(pmf, 0.75, 1e-12);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(point_and_spot_closed_forms);
    RUN(area_light_is_one_sided);
    RUN(area_direct_sampling);
    RUN(chi2_rejects_wrong_density);
    RUN(emission_sampling);
    RUN(envmap_sampling_and_orientation);
    RUN(lights_chosen_by_power);
    RUN(projector);
    return spc_test_finish();
}
