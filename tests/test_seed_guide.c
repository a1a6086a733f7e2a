/*
 * tests/test_seed_guide.c: guided seeds of the randomized solvers (manifold/seed_guide.h).
 *
 * - The pre-pass on the triangle glass ball (bench/check/glass_ball_mesh.xml): deterministic (two
 *   builds give the same seeds), records near the caustic under the ball, none far from it.
 * - The trial count stays unbiased for the mixture: at floor points in the caustic, for the chains
 *   that 4000 attempts from the mixture (seedguide=0.8, without the fitted sphere's seeds:
 *   fit_seeds.h) find most often, the mean of 300 Bernoulli trial counts (spc_snee_count_same, the
 *   estimator's <1/p_solve>) times the measured frequency p is 1 within 4 standard errors. It fails
 *   if the trials drew their seeds from another distribution than the first attempt (the guide on
 *   in one and off in the other).
 * - The guide pays where it should: the same chains' frequency under the mixture is higher than
 *   under uniform seeds alone (seedguide off), summed over the points.
 * - The guide as the plan would append it (not by default: snee_plan.h) on that scene: its render agrees with specular NEE off
 *   (under a wider light) and with the same setting unguided (per-pixel z-test, image means).
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "core/rng.h"
#include "chain_compare.h"
#include "harness.h"
#include "manifold/seed_guide.h"
#include "manifold/snee_plan.h"
#include "manifold/specular_nee.h"
#include "render_util.h"
#include "specula/specula.h"

#define SCENE "bench/check/glass_ball_mesh.xml"

TEST(prepass_deterministic_and_local)
{
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_sguide *a = spc_sguide_build(sc, 16384, SPC_SGUIDE_STREAM, false);
    spc_sguide *b = spc_sguide_build(sc, 16384, SPC_SGUIDE_STREAM, false);
    CHECK(a && b);
    if (!a || !b) {
        spc_sguide_destroy(a);
        spc_sguide_destroy(b);
        spc_scene_destroy(sc);
        return;
    }
    printf("    %ld of 16384 light paths landed after a caster vertex\n", spc_sguide_records(a));
    CHECK(spc_sguide_records(a) == spc_sguide_records(b) && spc_sguide_records(a) > 4000);
    /* the same seeds from both builds, at points around the ball */
    int same = 0, tried = 0;
    for (int i = 0; i < 64; ++i) {
        spc_vec3 x = spc_v3(-0.6 + 0.02 * i, 0.0, 0.1 + 0.005 * i);
        spc_vec3 da, db;
        bool oa = spc_sguide_seed(a, x, 1, 2, 0.37, spc_v2(0.2, 0.7), &da);
        bool ob = spc_sguide_seed(b, x, 1, 2, 0.37, spc_v2(0.2, 0.7), &db);
        tried += oa ? 1 : 0;
        same += oa == ob && (!oa || spc_distance(da, db) == 0.0) ? 1 : 0;
    }
    CHECK_MSG(same == 64 && tried > 0, "same %d of 64, %d with records", same, tried);
    /* the caustic: the light at (0.4, 2.2, -0.6) above the ball at (0, 0.5, 0) focuses below and
     * beyond the ball's centre; a far corner of the floor receives no light through the ball */
    long under = spc_sguide_count(a, spc_v3(-0.1, 0.0, 0.15), 1, 2);
    long far = spc_sguide_count(a, spc_v3(2.5, 0.0, 2.5), 1, 2);
    printf("    records near the caustic %ld, at a far corner %ld\n", under, far);
    CHECK(under > 20 && far == 0);
    spc_sguide_destroy(a);
    spc_sguide_destroy(b);
    spc_scene_destroy(sc);
}


TEST(trial_count_unbiased_for_the_mixture)
{
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_sguide *g = spc_sguide_build(sc, SPC_SGUIDE_PHOTONS, SPC_SGUIDE_STREAM, false);
    CHECK(g != NULL);
    spc_snee_params pm, pu;
    CHECK(spc_snee_parse("angular:noreflect,seedguide=0.8,nofitseeds", 2, &pm));
    CHECK(spc_snee_parse("angular:noreflect,nofitseeds", 2, &pu));
    pm.sguide = g;
    const int attempts = spc_test_quick() ? 1000 : 4000, counts = spc_test_quick() ? 100 : 300;
    /* floor points in and around the caustic under the ball */
    double px[9], pz[9];
    for (int i = 0; i < 9; ++i) {
        px[i] = -0.25 + 0.08 * (i % 3);
        pz[i] = 0.12 + 0.08 * (i / 3);
    }
    chain_seeds_cmp r;
    chain_seeds_cmp_init(&r);
    spc_rng rng;
    spc_rng_seed(&rng, 7, 11);
    for (int i = 0; i < 9 && g; ++i) {
        spc_hit x;
        if (!chain_floor_point(sc, 1, px[i], pz[i], &x))
            continue;
        spc_snee_query qm, qu;
        spc_snee_query_init(&qm, sc, &pm, &x, spc_v3(0, 1, 0), 2);
        const spc_emitter *e;
        spc_vec2 uv;
        double p_y;
        pm.light_u_on = true;
        pm.light_u[0] = 0.5;
        pm.light_u[1] = 0.3 + 0.2 * i;
        pm.light_u[2] = 0.6;
        if (!spc_snee_sample_light(sc, false, &rng, &qm, &e, &uv, &p_y))
            continue;
        pm.light_u_on = false;
        qu = qm;
        qu.params = &pu;
        chain_seeds_compare(&qm, &qu, e, uv, sc->radius, &rng, attempts, counts, 0.02, i, &r);
    }
    CHECK_MSG(r.checked >= 3, "%d chains checked", r.checked);
    printf("    second moment of the chains' estimates: mixture %.4g, uniform %.4g\n", r.m2_a, r.m2_b);
    CHECK_MSG(r.m2_a < 0.7 * r.m2_b, "second moment: mixture %g, uniform %g", r.m2_a, r.m2_b);
    spc_sguide_destroy(g);
    spc_scene_destroy(sc);
}

/* The triangle glass ball of SCENE under a light `scale` times as wide (the same power), res x res
 * pixels. */
static spc_scene *ball_under_light(double scale, int res)
{
    char xml[4096], path[1200], obj[1200];
    snprintf(obj, sizeof obj, "%s/bench/check/glass_ball_mesh.obj", spc_test_source_dir());
    snprintf(xml, sizeof xml,
             "<scene version=\"3.0.0\">\n"
             "<integrator type=\"path\"><integer name=\"max_depth\" value=\"8\"/></integrator>\n"
             "<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>\n"
             "<transform name=\"to_world\"><lookat origin=\"0, 2.0, 3.0\" target=\"0, 0.2, 0\" up=\"0, 1, 0\"/>"
             "</transform>\n"
             "<film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/><integer name=\"height\" value=\"%d\"/>"
             "<rfilter type=\"box\"/></film></sensor>\n"
             "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"%g\"/>"
             "<lookat origin=\"0.4, 2.2, -0.6\" target=\"0, 0, 0.1\" up=\"0, 1, 0.01\"/></transform>\n"
             "<emitter type=\"area\"><rgb name=\"radiance\" value=\"%g\"/></emitter></shape>\n"
             "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"3\"/>"
             "<rotate x=\"1\" angle=\"-90\"/></transform>\n"
             "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.7\"/></bsdf></shape>\n"
             "<shape type=\"obj\"><string name=\"filename\" value=\"%s\"/>"
             "<transform name=\"to_world\"><translate y=\"0.5\"/></transform>\n"
             "<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.5\"/></bsdf></shape>\n"
             "</scene>\n",
             res, res, 0.08 * scale, 1500.0 / (scale * scale), obj);
    snprintf(path, sizeof path, "/tmp/spc_seed_guide_%ld.xml", (long)getpid());
    FILE *fp = fopen(path, "w");
    if (!fp)
        return NULL;
    fputs(xml, fp);
    fclose(fp);
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_scene_load(path, NULL, 0, &sc, &err) != SPC_OK)
        printf("    %s\n", err.msg);
    remove(path);
    return sc;
}

/* Guided seeds as the plan would append them (snee_plan.h) on the triangle glass ball against specular NEE off under a light
 * four times as wide (so that path tracing alone converges: under the scene's own light it misses
 * the light's image in the ball in short runs), and against the same setting unguided under the
 * scene's light, by per-pixel z-test and image means (12 x 12 pixels). At twice the width the
 * reference misses its tail: the floor near the camera gets the ball's caustic from rare
 * BSDF-sampled hits of the light (about 0.004 of a pixel's 0.70 each at 65536 samples, about one per
 * pixel), so a run that draws none there has 0.7053 +- 0.0002 where the mean is 0.714 +- 0.002, and a
 * default whose own error there is 0.002 fails the z-test on those pixels (bench/RESULTS.md, "the
 * reference's tail"). Four times as wide, the hits are four times as frequent at a quarter of the value. */
TEST(guided_render_agrees_with_none)
{
    const int q = spc_test_quick() ? 4 : 1;
    for (int wide = 1; wide >= 0; --wide) {
        spc_scene *sc = ball_under_light(wide ? 4.0 : 1.0, 12);
        CHECK(sc != NULL);
        if (!sc)
            return;
        spc_render_stats st;
        spc_film *img = tu_render_stats(sc, "path", SPC_SNEE_PLAN_SETTING SPC_SNEE_PLAN_SEED_GUIDE, 1024 / q, 2, 21, &st);
        CHECK_MSG(img && strstr(st.specular_nee, "seedguide="), "the render ran %s", img ? st.specular_nee : "-");
        spc_film *ref = wide ? tu_render_nee(sc, "path", "none", 65536 / q, 2, 22, NULL)
                             : tu_render_nee(sc, "path", "angular:camera,later=0.25", 1024 / q, 2, 23, NULL);
        const char *label = wide ? "default vs none, light 4x wider" : "default vs unguided";
        CHECK(img && ref);
        if (img && ref) {
            spc_diff_result d;
            memset(&d, 0, sizeof d);
            CHECK(tu_image_agrees(img, ref, 0.99, label, &d));
            double m[2], se[2];
            tu_image_mean(img, 0, &m[0], &se[0]);
            tu_image_mean(ref, 0, &m[1], &se[1]);
            printf("    %s: z-test pass %.4f of %d pixels; means %.5f (se %.2g) vs %.5f (%.2g)\n", label,
                   d.ztest_pass_fraction, d.ztest_pixels, m[0], se[0], m[1], se[1]);
        }
        spc_film_destroy(img);
        spc_film_destroy(ref);
        spc_scene_destroy(sc);
    }
}

int main(void)
{
    RUN(prepass_deterministic_and_local);
    RUN(trial_count_unbiased_for_the_mixture);
    RUN(guided_render_agrees_with_none);
    return spc_test_finish();
}
