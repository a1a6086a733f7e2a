/*
 * tests/test_mitsuba_refs.c: specula against Mitsuba 3, without Mitsuba. Each scene of scenes/ in
 * the table below is rendered by specula at 32 pixels (path tracer unless the row names another
 * integrator that estimates the same image, fixed seed, so the outcome is the same on every run) and compared with a Mitsuba 3.9.1 scalar_rgb reference committed in
 * tests/data/mitsuba_refs (tests/validation/make_test_refs.py: the mean of 32 independent renders
 * of 128 spp and the variance of that mean) by the per-pixel z-test of `specula diff` (alpha 0.01,
 * Sidak-corrected over the pixels). A scene passes when at least 99.75% of its pixels do,
 * Mitsuba's own bar in its test_renders.py; with 1024 pixels that allows two.
 *
 * Together the scenes cover the loader's dialects (3.0 and 0.6 with camelCase names and spectra),
 * every shape (obj, ply ascii/binary, serialized, sphere, rectangle, disk, cube, cylinder, the
 * curves, sdfgrid), the
 * BSDFs Mitsuba 3 has, bitmap (png, jpeg, exr) and checkerboard textures, every emitter including
 * envmaps and bitmap-textured area lights (sampled in proportion to their texels), perspective
 * cameras with several fov axes and a crop window (box filters: the tails of tent and gaussian
 * filters put rare, bright samples in border pixels that a 32-pixel z-test cannot judge; they are
 * compared at full size by validate.py), and volpath's media behind thin dielectrics. The
 * full-size comparison of every scene is tests/validation/validate.py (bench/RESULTS.md).
 */
/* ctest-labels: scene */
/* ctest-timeout: 600 */
#include "harness.h"

#include "render/film.h"
#include "scene/scene.h"
#include "specula/specula.h"

#define REF_PASS_FRACTION 0.9975 /* Mitsuba's test_renders.py bar */

typedef struct ref_case {
    const char *name;       /* tests/data/mitsuba_refs/NAME.exr */
    const char *scene;      /* under scenes/ */
    int spp;                /* specula's samples per pixel */
    const char *integrator; /* -D integrator=...; NULL: path (Mitsuba's reference is always path's) */
} ref_case;

static const ref_case cases[] = {
    {"shapes", "shapes.xml", 512, NULL},
    {"textures", "textures.xml", 512, NULL},
    {"conductors", "conductors.xml", 512, NULL},
    {"envmap", "envmap.xml", 512, NULL},
    {"normal_bump", "normal_bump.xml", 512, NULL},
    {"area_textured", "area_textured.xml", 1024, NULL},
    {"lights", "lights.xml", 512, NULL},
    {"v06_box", "v06_box.xml", 512, NULL},
    {"mask_null", "mask_null.xml", 512, NULL},
    {"dielectrics", "dielectrics.xml", 1024, NULL},
    /* principled and principledthin with textured weights */
    {"principled", "principled.xml", 1024, NULL},
    /* media behind thin dielectrics: Mitsuba's null events (volpath.c) */
    {"medium_thin", "medium_thin.xml", 1024, "volpath"},
    /* a spot light projecting an image */
    {"spot_texture", "spot_texture.xml", 2048, NULL},
    /* a thin-lens camera: depth of field */
    {"thinlens", "thinlens.xml", 1024, NULL},
    /* PLY vertex and face attributes as textures */
    {"mesh_attribute", "mesh_attribute.xml", 512, NULL},
    /* projectors: an image with its aspect ratio, a constant one with a focal length (the floor
     * near the camera is lit only through the box: heavy-tailed at 1024 spp) */
    {"projector", "projector.xml", 2048, NULL},
    /* linearcurve (textured by its uv) and bsplinecurve (a rough conductor: its normals) */
    {"curves", "curves.xml", 1024, NULL},
    /* sdfgrid: exact voxel intersection, smooth (instanced, rotated) and analytic normals */
    {"sdfgrid", "sdfgrid.xml", 1024, NULL},
    /* a coarse sdfgrid ball with smooth normals beside one with analytic normals */
    {"sdfgrid_normals", "sdfgrid_normals.xml", 1024, NULL},
    /* the particle tracer against the path-traced references (the same image): area lights seen
     * directly and textured, point, spot and directional lights, a constant sky */
    {"shapes", "shapes.xml", 1024, "ptracer"},
    {"area_textured", "area_textured.xml", 1024, "ptracer"},
    {"lights", "lights.xml", 1024, "ptracer"},
};

static const char *source_dir(void)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    return d ? d : ".";
}

/* Renders one case, multiplies specula's image by `scale` (1: as rendered) and z-tests it; returns
 * the pass fraction, or -1 on failure (printed). */
static double compare_with(const ref_case *c, double scale, const spc_define *extra, int nextra);

static double compare(const ref_case *c, double scale) { return compare_with(c, scale, NULL, 0); }

/* The same with nextra more defines (at most 2). */
static double compare_with(const ref_case *c, double scale, const spc_define *extra, int nextra)
{
    char scene_path[1024], ref_path[1024];
    snprintf(scene_path, sizeof scene_path, "%s/scenes/%s", source_dir(), c->scene);
    snprintf(ref_path, sizeof ref_path, "%s/tests/data/mitsuba_refs/%s.exr", source_dir(), c->name);
    spc_define defs[4] = {{"res", "32"}, {"integrator", c->integrator ? c->integrator : "path"}};
    for (int k = 0; k < nextra && k < 2; ++k)
        defs[2 + k] = extra[k];
    spc_scene *s = NULL;
    spc_error err;
    char msg[1200];
    if (spc_scene_load(scene_path, defs, 2 + (nextra < 2 ? nextra : 2), &s, &err) != SPC_OK) {
        spc_error_format(&err, msg, sizeof msg);
        printf("  %s: %s\n", c->name, msg);
        return -1.0;
    }
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = c->spp;
    o.seed = 3;
    /* plain path tracing, as Mitsuba's: specular NEE adds what Mitsuba cannot render (the point
     * light's caustic through the water sphere of dielectrics: its image 1.3% brighter) */
    o.specular_nee = "none";
    spc_film *f = NULL;
    spc_render_stats st;
    spc_status rs = spc_render(s, &o, &f, &st, &err);
    spc_scene_destroy(s);
    if (rs != SPC_OK) {
        spc_error_format(&err, msg, sizeof msg);
        printf("  %s: render: %s\n", c->name, msg);
        spc_film_destroy(f);
        return -1.0;
    }
    spc_image_rgb ref;
    if (spc_image_rgb_read(ref_path, &ref, &err) != SPC_OK) {
        spc_error_format(&err, msg, sizeof msg);
        printf("  %s: %s\n", c->name, msg);
        spc_film_destroy(f);
        return -1.0;
    }
    /* a scaled copy of the film */
    size_t n = 3 * (size_t)spc_film_width(f) * (size_t)spc_film_height(f);
    spc_image_rgb img = {spc_film_width(f), spc_film_height(f), malloc(n * sizeof(float)), malloc(n * sizeof(float))};
    const float *rgb = spc_film_rgb(f), *var = spc_film_variance(f);
    for (size_t i = 0; img.rgb && img.variance && i < n; ++i) {
        img.rgb[i] = (float)(rgb[i] * scale);
        img.variance[i] = (float)(var[i] * scale * scale);
    }
    spc_diff_result r;
    double frac = -1.0;
    if (!ref.variance) {
        printf("  %s: the reference has no variance channels\n", c->name);
    } else if (spc_image_diff(&img, &ref, &r, &err) != SPC_OK || !r.has_ztest) {
        printf("  %s: images differ in size (%dx%d vs %dx%d)\n", c->name, img.width, img.height, ref.width, ref.height);
    } else {
        frac = r.ztest_pass_fraction;
        printf("  %-14s %-7s %dx%d spp %5d  pass %6.2f%%  specula (%.4f %.4f %.4f)  mitsuba (%.4f %.4f %.4f)\n",
               c->name, c->integrator ? c->integrator : "path", img.width, img.height, c->spp, 100.0 * frac,
               r.mean_a[0], r.mean_a[1], r.mean_a[2], r.mean_b[0], r.mean_b[1], r.mean_b[2]);
    }
    spc_image_rgb_release(&ref);
    spc_image_rgb_release(&img);
    spc_film_destroy(f);
    return frac;
}

TEST(scenes_match_mitsuba)
{
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        double frac = compare(&cases[i], 1.0);
        CHECK_MSG(frac >= REF_PASS_FRACTION, "%s: %.4f of the pixels pass", cases[i].name, frac);
    }
}

/* The test has power: specula's image made 3% brighter fails it (at these sample counts the
 * z-test resolves a few percent in most lit pixels). */
TEST(detects_a_three_percent_error)
{
    double frac = compare(&cases[3], 1.03); /* envmap */
    CHECK(frac >= 0.0);
    CHECK_MSG(frac < 0.9, "3%% too bright, %.4f of the pixels still pass", frac);
}

/* ... and it sees an sdfgrid's shading normals: the two balls' modes swapped fail it. */
TEST(detects_swapped_sdfgrid_normals)
{
    const ref_case *c = NULL;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i)
        if (strcmp(cases[i].name, "sdfgrid_normals") == 0)
            c = &cases[i];
    CHECK(c != NULL);
    if (!c)
        return;
    spc_define swap[2] = {{"left_normals", "analytic"}, {"right_normals", "smooth"}};
    double frac = compare_with(c, 1.0, swap, 2);
    CHECK(frac >= 0.0);
    CHECK_MSG(frac < 0.97, "normals swapped, %.4f of the pixels still pass", frac);
}

int main(void)
{
    RUN(scenes_match_mitsuba);
    RUN(detects_a_three_percent_error);
    RUN(detects_swapped_sdfgrid_normals);
    return spc_test_finish();
}
