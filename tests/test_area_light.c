/*
 * tests/test_area_light.c: area lights whose radiance is a bitmap texture, sampled in proportion
 * to their texels (emitter/area.c): the density sample_direct reports is the one pdf_direct and
 * pdf_emission compute for the same point; the irradiance estimated with it at a point matches a
 * deterministic quadrature of the same integral; it has less variance than uniform sampling; and
 * meshes too large for it, or untextured lights, keep uniform sampling; and a light does not shadow
 * its own samples where shadow rays graze it.
 * (Image agreement with Mitsuba 3 for such lights: tests/test_mitsuba_refs.c, scene area_textured.)
 */
/* ctest-labels: unit */
#include "harness.h"

#include "core/rng.h"
#include "emitter/emitter.h"
#include "io/mitsuba_xml.h"
#include "scene/scene.h"
#include "scene/shape.h"

static const char *source_dir(void)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    return d ? d : ".";
}

/* A scene of one light shape (given as XML) over a diffuse floor. */
static spc_scene *load_light(const char *shape_xml)
{
    char xml[4096], dir[1024];
    snprintf(dir, sizeof dir, "%s/scenes", source_dir());
    snprintf(xml, sizeof xml,
             "<scene version=\"3.0.0\">\n"
             "  <shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"5\"/>"
             "<rotate x=\"1\" angle=\"-90\"/></transform></shape>\n"
             "  %s\n"
             "</scene>\n",
             shape_xml);
    spc_scene *s = NULL;
    spc_error err;
    if (spc_mitsuba_load_string(xml, strlen(xml), "light.xml", dir, NULL, 0, &s, &err) != SPC_OK) {
        char msg[512];
        spc_error_format(&err, msg, sizeof msg);
        printf("  load failed: %s\n", msg);
        return NULL;
    }
    if (!s->finalized && spc_scene_finalize(s, &err) != SPC_OK) {
        spc_scene_destroy(s);
        return NULL;
    }
    return s;
}

/* A 1.2 x 0.8 rectangle 1.5 above the origin facing down, radiance emit.exr (a dark texture with
 * three bright cells), nearest filtering: the light of scenes/area_textured.xml. */
static const char *quad_light =
    "<shape type=\"rectangle\"><transform name=\"to_world\"><scale x=\"1.2\" y=\"0.8\"/>"
    "<rotate x=\"1\" angle=\"90\"/><translate y=\"1.5\"/></transform>"
    "<emitter type=\"area\"><texture type=\"bitmap\" name=\"radiance\">"
    "<string name=\"filename\" value=\"textures/emit.exr\"/><string name=\"filter_type\" value=\"%s\"/>"
    "<transform name=\"to_uv\"><scale x=\"%g\" y=\"1\"/></transform>"
    "</texture></emitter></shape>";

static const spc_emitter *the_light(const spc_scene *s)
{
    for (int i = 0; i < s->nemitters; ++i)
        if (s->emitters[i]->type == SPC_EMITTER_AREA)
            return s->emitters[i];
    return NULL;
}

static spc_scene *quad_scene(const char *filter, double uscale)
{
    char buf[1024];
    snprintf(buf, sizeof buf, quad_light, filter, uscale);
    return load_light(buf);
}

/* The density reported with each sample is the density of the point, recomputed. */
TEST(pdf_matches_sample)
{
    const char *filters[2] = {"nearest", "bilinear"};
    for (int f = 0; f < 2; ++f) {
        spc_scene *s = quad_scene(filters[f], f ? 2.5 : 1.0);
        CHECK(s != NULL);
        if (!s)
            continue;
        const spc_emitter *e = the_light(s);
        CHECK(e && e->has_cell_distrib);
        spc_rng rng;
        spc_rng_seed(&rng, 7, (uint64_t)f);
        spc_vec3 ref = spc_v3(0.3, 0.01, -0.2);
        int n = 0, bad = 0, bad_emission = 0;
        for (int i = 0; i < 20000; ++i) {
            spc_emitter_direct ds;
            spc_vec2 u = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
            if (!spc_emitter_sample_direct(e, ref, u, &ds))
                continue;
            ++n;
            double pdf = spc_emitter_pdf_direct(e, ref, ds.p, ds.n);
            if (!(fabs(pdf - ds.pdf) <= 1e-9 * ds.pdf))
                ++bad;
            spc_emitter_emission em;
            spc_vec2 u2 = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
            if (spc_emitter_sample_emission(e, u, u2, &em)) {
                double pp, pd;
                spc_emitter_pdf_emission(e, em.p, em.n, em.d, &pp, &pd);
                if (!(fabs(pp - em.pdf_pos) <= 1e-9 * em.pdf_pos && fabs(pd - em.pdf_dir) <= 1e-9 * em.pdf_dir))
                    ++bad_emission;
            }
        }
        CHECK(n > 19000);
        CHECK_MSG(bad == 0, "%d of %d direct densities differ (%s)", bad, n, filters[f]);
        CHECK_MSG(bad_emission == 0, "%d emission densities differ (%s)", bad_emission, filters[f]);
        spc_scene_destroy(s);
    }
}

/* The integrand of the irradiance at ref from the light, at a point of the light given by its
 * uv: L(uv) cos_ref cos_light / r^2 per unit area. The rectangle: p = (1.2 (2u - 1), 1.5,
 * -0.8 (2v - 1))... read back through the shape rather than assumed: we sample the area
 * uniformly on a fine grid of the triangles instead. */
static double quadrature(const spc_emitter *e, spc_vec3 ref, int n)
{
    const spc_shape *sh = e->shape;
    const spc_mesh *m = &sh->mesh;
    double sum = 0.0;
    for (size_t t = 0; t < m->ntris; ++t) {
        spc_vec3 p0 = spc_mesh_p(m, m->idx[3 * t]), p1 = spc_mesh_p(m, m->idx[3 * t + 1]),
                 p2 = spc_mesh_p(m, m->idx[3 * t + 2]);
        double area = 0.5 * spc_length(spc_cross(spc_sub(p1, p0), spc_sub(p2, p0)));
        /* midpoints of the n^2 congruent sub-triangles (centroids), each of area area / n^2 */
        for (int i = 0; i < n; ++i)
            for (int j = 0; i + j < n; ++j)
                for (int up = 0; up < 2; ++up) {
                    if (!up && i + j > n - 2)
                        continue;
                    double b1 = up ? (i + 1.0 / 3) / n : (i + 2.0 / 3) / n;
                    double b2 = up ? (j + 1.0 / 3) / n : (j + 2.0 / 3) / n;
                    spc_hit h;
                    memset(&h, 0, sizeof h);
                    spc_shape_fill_hit(sh, (int)t, b1, b2, NULL, 0.0, &h);
                    spc_vec3 d = spc_sub(h.p, ref);
                    double r2 = spc_length2(d);
                    spc_vec3 w = spc_scale(d, 1.0 / sqrt(r2));
                    spc_rgb L = spc_emitter_eval_area(e, &h, spc_neg(w));
                    double cr = fabs(w.y), cl = fabs(spc_dot(h.ng, w));
                    sum += spc_rgb_avg(L) * cr * cl / r2 * area / ((double)n * n);
                }
    }
    return sum;
}

/* Irradiance from the textured light: texel-proportional sampling vs quadrature, and its
 * variance vs uniform area sampling of the same light. */
TEST(irradiance_unbiased_and_lower_variance)
{
    spc_scene *s = quad_scene("nearest", 1.0);
    CHECK(s != NULL);
    if (!s)
        return;
    const spc_emitter *e = the_light(s);
    CHECK(e && e->has_cell_distrib);
    if (!e || !e->has_cell_distrib) {
        spc_scene_destroy(s);
        return;
    }
    spc_vec3 ref = spc_v3(-0.4, 0.0, 0.3);
    double exact = quadrature(e, ref, 512);
    const int N = 200000;
    spc_rng rng;
    spc_rng_seed(&rng, 11, 0);
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < N; ++i) {
        spc_emitter_direct ds;
        double v = 0.0;
        if (spc_emitter_sample_direct(e, ref, spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &ds))
            v = spc_rgb_avg(ds.L) * fabs(ds.wi.y) / ds.pdf;
        sum += v;
        sum2 += v * v;
    }
    double mean = sum / N, var = (sum2 / N - mean * mean) / (N - 1);
    CHECK_MSG(fabs(mean - exact) < 4.0 * sqrt(var) + 1e-4 * exact, "estimate %g +- %g, quadrature %g", mean, sqrt(var),
              exact);
    /* uniform area sampling of the same light (the shape's own sampler) */
    spc_rng_seed(&rng, 12, 0);
    double usum = 0.0, usum2 = 0.0;
    for (int i = 0; i < N; ++i) {
        spc_shape_sample ss;
        spc_shape_sample_area(e->shape, spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &ss);
        spc_vec3 d = spc_sub(ss.p, ref);
        double r2 = spc_length2(d);
        spc_vec3 w = spc_scale(d, 1.0 / sqrt(r2));
        spc_hit h;
        memset(&h, 0, sizeof h);
        h.uv = ss.uv;
        h.ng = ss.n;
        double v = spc_rgb_avg(spc_emitter_eval_area(e, &h, spc_neg(w))) * fabs(w.y) * fabs(spc_dot(ss.n, w)) / r2 /
                   ss.pdf;
        usum += v;
        usum2 += v * v;
    }
    double umean = usum / N, uvar = (usum2 / N - umean * umean) / (N - 1);
    CHECK_MSG(fabs(umean - exact) < 4.0 * sqrt(uvar) + 1e-4 * exact, "uniform %g +- %g, quadrature %g", umean,
              sqrt(uvar), exact);
    CHECK_MSG(var < 0.25 * uvar, "texel sampling variance %g, uniform %g", var, uvar);
    spc_scene_destroy(s);
}

/* Lights the method does not apply to keep uniform area or solid-angle sampling. */
TEST(fallbacks)
{
    spc_scene *s = load_light("<shape type=\"obj\"><string name=\"filename\" value=\"meshes/icosphere.obj\"/>"
                              "<emitter type=\"area\"><texture type=\"bitmap\" name=\"radiance\">"
                              "<string name=\"filename\" value=\"textures/emit.exr\"/></texture></emitter></shape>");
    CHECK(s != NULL);
    if (s) {
        const spc_emitter *e = the_light(s);
        CHECK(e && !e->has_cell_distrib); /* 320 triangles: more than the linear search allows */
        spc_scene_destroy(s);
    }
    s = load_light("<shape type=\"rectangle\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"2\"/>"
                   "</emitter></shape>");
    CHECK(s != NULL);
    if (s) {
        const spc_emitter *e = the_light(s);
        CHECK(e && !e->has_cell_distrib);
        spc_vec3 ref = spc_v3(0.1, 0.2, 1.5);
        spc_emitter_direct ds;
        CHECK(spc_emitter_sample_direct(e, ref, spc_v2(0.3, 0.7), &ds));
        CHECK_NEAR(ds.pdf, spc_emitter_pdf_direct(e, ref, ds.p, ds.n), 1e-9 * ds.pdf);
        spc_scene_destroy(s);
    }
}

/* A light does not shadow its own samples where the shadow ray grazes it. A square light standing
 * on its edge above the floor (its plane x = 0, facing +x), seen from floor points 0.002-0.05 in
 * front of its plane: the shadow rays meet the light's plane at 0.1-3 degrees, where the
 * accelerator's single-precision plane lies off p by far more along the ray than p's own error
 * bound; nothing else is between, so no ray may be occluded. */
TEST(grazing_samples_not_self_shadowed)
{
    spc_scene *s = load_light("<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"0.5\"/>"
                              "<rotate y=\"1\" angle=\"90\"/><translate x=\"0.3\" y=\"1\" z=\"-0.2\"/></transform>"
                              "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>");
    CHECK(s != NULL);
    if (!s)
        return;
    const spc_emitter *e = the_light(s);
    CHECK(e != NULL);
    const double front[4] = {0.002, 0.005, 0.02, 0.05};
    spc_rng rng;
    spc_rng_seed(&rng, 13, 0);
    for (int k = 0; e && k < 4; ++k) {
        spc_hit h;
        memset(&h, 0, sizeof h);
        h.p = spc_v3(0.3 + front[k], 0.0, -0.2 + 0.3 * k - 0.4);
        h.ng = spc_v3(0.0, 1.0, 0.0);
        h.err = 1e-7;
        int n = 0, shadowed = 0;
        for (int i = 0; i < 20000; ++i) {
            spc_emitter_direct ds;
            if (!spc_emitter_sample_direct(e, h.p, spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &ds))
                continue;
            spc_ray r = spc_hit_spawn_to(&h, ds.p, ds.err);
            ++n;
            shadowed += spc_scene_occluded(s, &r);
        }
        CHECK_MSG(n > 19000 && shadowed == 0, "%g in front: %d of %d samples shadowed by the light itself", front[k],
                  shadowed, n);
    }
    spc_scene_destroy(s);
}

int main(void)
{
    RUN(pdf_matches_sample);
    RUN(irradiance_unbiased_and_lower_variance);
    RUN(fallbacks);
    RUN(grazing_samples_not_self_shadowed);
    return spc_test_finish();
}
