/*
 * tests/test_opencl.c: the opencl render device (src/device/) against the CPU device.
 *
 * - Per-pixel z-tests (Sidak over pixels, alpha 0.01, spc_image_diff; at least 99% of pixels pass)
 *   and image means within 4 combined standard errors, the opencl device's path and bdpt against
 *   the CPU's: the glass SDF torus caustic (scenes/caustic_sdf_torus.xml) and every SDF primitive
 *   and operation under a sphere light, with a mirror, a glass CSG object and rectangles
 *   (scenes/sdf_shapes_csg.xml); a rectangle light over SDF shapes and a glass sphere, with the
 *   tent filter.
 * - The device is deterministic (two renders are equal bit for bit; the image does not depend on
 *   how a batch is cut into kernel launches) and keeps the driver's pass structure: a render checkpointed and resumed equals the uninterrupted one bit for bit, a
 *   checkpoint does not resume on another device, --time renders whole passes.
 * - Scenes and options it does not support are refused, naming what is missing, by the library
 *   and by `specula render --device opencl` (nonzero exit); `specula info --devices` lists an
 *   OpenCL device.
 * Needs an OpenCL implementation (PoCL on CI, which tools/build.sh installs); specula built
 * without OpenCL fails this test, as it must not pass silently.
 * ctest-labels: scene stat
 * ctest-timeout: 600
 */
#include <sys/wait.h>
#include <unistd.h>

#include "harness.h"
#include "render_util.h"

#include "io/mitsuba_xml.h"
#include "specula/specula.h"

static const char *source_dir(void)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    return d ? d : ".";
}

static spc_scene *load_scene(const char *rel, const spc_define *defs, int ndefs)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", source_dir(), rel);
    spc_scene *sc = NULL;
    spc_error err;
    if (spc_scene_load(path, defs, ndefs, &sc, &err) != SPC_OK) {
        char buf[1200];
        spc_error_format(&err, buf, sizeof buf);
        printf("  load failed: %s\n", buf);
        return NULL;
    }
    return sc;
}

static spc_film *render_on(const spc_scene *sc, const char *device, const char *integrator, int max_depth, int res,
                           int spp, uint64_t seed, spc_error *err_out)
{
    spc_render_options o;
    spc_render_options_init(&o);
    o.max_depth = max_depth;
    o.spp = spp;
    o.width = o.height = res;
    o.integrator = integrator;
    o.seed = seed;
    o.device = device;
    /* the same algorithm on both devices: the CPU's specular NEE (on by default for path on a
     * caustic scene) would smooth the caustic the device finds by BSDF sampling alone */
    o.specular_nee = "none";
    spc_film *f = NULL;
    spc_error err;
    spc_render_stats st;
    spc_status s = spc_render(sc, &o, &f, &st, &err);
    if (err_out)
        *err_out = err;
    if (s != SPC_OK) {
        if (!err_out) {
            char buf[1200];
            spc_error_format(&err, buf, sizeof buf);
            printf("  render on %s failed: %s\n", device ? device : "cpu", buf);
        }
        spc_film_destroy(f);
        return NULL;
    }
    return f;
}

/* Fraction of pixels passing the Sidak-corrected z-test of a against b (both with variance). */
static double ztest(const spc_film *a, const spc_film *b, const char *what)
{
    spc_image_rgb ia = {a->width, a->height, a->rgb, a->var};
    spc_image_rgb ib = {b->width, b->height, b->rgb, b->var};
    spc_diff_result r;
    spc_error err;
    if (spc_image_diff(&ia, &ib, &r, &err) != SPC_OK || !r.has_ztest)
        return 0.0;
    printf("  %s: z-test pass %.4f, means (%.5f %.5f %.5f) vs (%.5f %.5f %.5f)\n", what, r.ztest_pass_fraction,
           r.mean_a[0], r.mean_a[1], r.mean_a[2], r.mean_b[0], r.mean_b[1], r.mean_b[2]);
    return r.ztest_pass_fraction;
}

static void check_means_agree(const spc_film *a, const spc_film *b, double k)
{
    for (int c = 0; c < 3; ++c) {
        double ma, sa, mb, sb;
        tu_image_mean(a, c, &ma, &sa);
        tu_image_mean(b, c, &mb, &sb);
        double se = sqrt(sa * sa + sb * sb);
        printf("    channel %d: means %.5f and %.5f, %.2f standard errors apart\n", c, ma, mb, fabs(ma - mb) / se);
        CHECK_MSG(fabs(ma - mb) <= k * se, "channel %d: image means %.6f and %.6f differ by %.2f standard errors", c,
                  ma, mb, se > 0.0 ? fabs(ma - mb) / se : INFINITY);
        CHECK_MSG(ma > 0.0 && se < 0.1 * ma, "channel %d: mean %.4g with standard error %.3g: not meaningful", c, ma,
                  se);
    }
}

/* The torus caustic with a larger light of the same power (path finds its caustic often enough
 * for the image mean to be meaningful at a thousand samples). */
static const spc_define big_light[] = {{"light_radius", "0.25"}, {"light_radiance", "40.96, 38.912, 34.816"}};

static void compare(const char *scene, const spc_define *defs, int ndefs, const char *integrator, int max_depth,
                    int res, int spp_cl, int spp_cpu)
{
    spc_scene *sc = load_scene(scene, defs, ndefs);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *cl = render_on(sc, "opencl", integrator, max_depth, res, spp_cl, 1, NULL);
    spc_film *cpu = render_on(sc, "cpu", integrator, max_depth, res, spp_cpu, 2, NULL);
    CHECK(cl && cpu);
    if (cl && cpu) {
        char what[256];
        snprintf(what, sizeof what, "%s, %s, opencl %d spp vs cpu %d spp", scene, integrator, spp_cl, spp_cpu);
        double pass = ztest(cl, cpu, what);
        CHECK_MSG(pass >= 0.99, "%s: only %.4f of pixels pass the z-test", what, pass);
        check_means_agree(cl, cpu, 4.0);
    }
    spc_film_destroy(cl);
    spc_film_destroy(cpu);
    spc_scene_destroy(sc);
}

TEST(torus_path_matches_cpu) { compare("scenes/caustic_sdf_torus.xml", big_light, 2, "path", 0, 24, 1024, 1024); }
TEST(shapes_csg_path_matches_cpu) { compare("scenes/sdf_shapes_csg.xml", NULL, 0, "path", 0, 24, 512, 512); }
/* max_depth -1 (the scene's): Russian roulette on both subpaths */
TEST(torus_bdpt_matches_cpu) { compare("scenes/caustic_sdf_torus.xml", NULL, 0, "bdpt", 0, 24, 1024, 1024); }
TEST(shapes_csg_bdpt_matches_cpu) { compare("scenes/sdf_shapes_csg.xml", NULL, 0, "bdpt", 8, 24, 256, 256); }


/* A rectangle light (a two-triangle mesh, sampled by area) over SDF shapes and a glass sphere
 * (analytic), path and bdpt. */
static const char *rect_light_xml =
    "<scene version=\"3.0.0\">"
    "<sensor type=\"perspective\"><float name=\"fov\" value=\"50\"/><transform name=\"to_world\">"
    "<lookat origin=\"0,2,4\" target=\"0,0.4,0\" up=\"0,1,0\"/></transform>"
    "<film type=\"hdrfilm\"><rfilter type=\"tent\"/></film></sensor>"
    "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"3\"/><rotate x=\"1\" angle=\"-90\"/>"
    "</transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.6,0.6,0.6\"/></bsdf></shape>"
    "<shape type=\"sdf\"><sdf type=\"smooth_union\"><float name=\"k\" value=\"0.2\"/>"
    "<sdf type=\"roundbox\"><vector name=\"half_size\" x=\"0.4\" y=\"0.3\" z=\"0.4\"/></sdf>"
    "<sdf type=\"capsule\"><point name=\"p0\" x=\"0\" y=\"0\" z=\"0\"/><point name=\"p1\" x=\"0\" y=\"0.8\" z=\"0\"/>"
    "<float name=\"radius\" value=\"0.15\"/></sdf></sdf>"
    "<transform name=\"to_world\"><translate x=\"-0.6\" y=\"0.3\"/></transform>"
    "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.7,0.4,0.3\"/></bsdf></shape>"
    "<shape type=\"sphere\"><point name=\"center\" x=\"0.6\" y=\"0.4\" z=\"0.2\"/><float name=\"radius\" value=\"0.4\"/>"
    "<bsdf type=\"dielectric\"/></shape>"
    "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"0.5\"/><rotate x=\"1\" angle=\"90\"/>"
    "<translate y=\"2.5\"/></transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"12,11,10\"/></emitter>"
    "</shape></scene>";

static void compare_xml(const char *xml, const char *integrator, int spp)
{
    spc_scene *sc = NULL;
    spc_error err;
    spc_status st = spc_mitsuba_load_string(xml, strlen(xml), "rect_light.xml", NULL, NULL, 0, &sc, &err);
    CHECK_MSG(st == SPC_OK, "%s", err.msg);
    if (st != SPC_OK)
        return;
    spc_film *cl = render_on(sc, "opencl", integrator, 8, 16, spp, 3, NULL);
    spc_film *cpu = render_on(sc, "cpu", integrator, 8, 16, spp, 4, NULL);
    CHECK(cl && cpu);
    if (cl && cpu) {
        char what[128];
        snprintf(what, sizeof what, "rectangle light, %s, %d spp each", integrator, spp);
        double pass = ztest(cl, cpu, what);
        CHECK_MSG(pass >= 0.99, "%s: only %.4f of pixels pass the z-test", what, pass);
        check_means_agree(cl, cpu, 4.0);
    }
    spc_film_destroy(cl);
    spc_film_destroy(cpu);
    spc_scene_destroy(sc);
}

TEST(rectangle_light_matches_cpu)
{
    compare_xml(rect_light_xml, "path", 512);
    compare_xml(rect_light_xml, "bdpt", 256);
}

TEST(deterministic)
{
    spc_scene *sc = load_scene("scenes/sdf_shapes_csg.xml", NULL, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *a = render_on(sc, "opencl:0", "path", 0, 16, 8, 7, NULL);
    spc_film *b = render_on(sc, "opencl", "path", 0, 16, 8, 7, NULL);
    spc_film *c = render_on(sc, "opencl", "path", 0, 16, 8, 8, NULL);
    CHECK(a && b && c);
    if (a && b && c) {
        CHECK(memcmp(a->rgb, b->rgb, sizeof(float) * 3 * 16 * 16) == 0);
        CHECK(memcmp(a->rgb, c->rgb, sizeof(float) * 3 * 16 * 16) != 0); /* the seed matters */
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_film_destroy(c);
    spc_scene_destroy(sc);
}

/* How the device cuts a batch into kernel launches does not change the image: bdpt's light-tracing
 * splats reach pixels whose camera samples another launch renders, earlier or later (on a fast GPU
 * the driver's batches hold many passes, so a pass often spans two launches). SPC_CL_LAUNCH_ITEMS
 * makes the launches small: 100 items cut each 24x24 pass into six, 1000 hold one pass each. The
 * sums are of floats in double, equal but for rounding. */
TEST(launch_size_does_not_change_image)
{
    spc_scene *sc = load_scene("scenes/sdf_shapes_csg.xml", NULL, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const char *integrators[] = {"bdpt", "path"};
    for (int i = 0; i < 2; ++i) {
        unsetenv("SPC_CL_LAUNCH_ITEMS");
        spc_film *ref = render_on(sc, "opencl", integrators[i], 8, 24, 6, 5, NULL);
        CHECK(ref != NULL);
        const char *sizes[] = {"100", "1000"};
        for (int k = 0; k < 2 && ref; ++k) {
            setenv("SPC_CL_LAUNCH_ITEMS", sizes[k], 1);
            spc_film *f = render_on(sc, "opencl", integrators[i], 8, 24, 6, 5, NULL);
            CHECK(f != NULL);
            if (!f)
                continue;
            int differ = 0;
            double sum_ref = 0.0, sum = 0.0;
            for (int p = 0; p < 3 * 24 * 24; ++p) {
                double a = ref->rgb[p], b = f->rgb[p];
                sum_ref += a;
                sum += b;
                if (!(fabs(a - b) <= 1e-6 * fabs(a) + 1e-30))
                    ++differ;
            }
            printf("  %s, launches of %s items: %d of %d values differ, image sums %.6f and %.6f\n", integrators[i],
                   sizes[k], differ, 3 * 24 * 24, sum_ref, sum);
            CHECK_MSG(differ == 0, "%s, launches of %s items: %d values differ", integrators[i], sizes[k], differ);
            CHECK(f->spp == ref->spp && ref->spp == 6);
            spc_film_destroy(f);
        }
        unsetenv("SPC_CL_LAUNCH_ITEMS");
        spc_film_destroy(ref);
    }
    spc_scene_destroy(sc);
}

/* A scene file with one thing the device lacks is refused with a message naming it. */
static void check_refused(const char *xml, const char *integrator, const char *device, const char *expect)
{
    spc_scene *sc = NULL;
    spc_error err;
    spc_status st = spc_mitsuba_load_string(xml, strlen(xml), "refuse.xml", NULL, NULL, 0, &sc, &err);
    CHECK_MSG(st == SPC_OK, "%s", err.msg);
    if (st != SPC_OK)
        return;
    spc_film *f = render_on(sc, device, integrator, 0, 8, 1, 0, &err);
    CHECK(f == NULL);
    CHECK_MSG(err.code == SPC_ERR_PLUGIN || err.code == SPC_ERR_VALUE, "code %d", (int)err.code);
    CHECK_MSG(strstr(err.msg, expect) != NULL, "message '%s' does not say '%s'", err.msg, expect);
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

#define SCENE_HEAD                                                                                                    \
    "<scene version=\"3.0.0\"><sensor type=\"perspective\"><transform name=\"to_world\">"                            \
    "<lookat origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/></transform></sensor>"
#define LIGHT                                                                                                         \
    "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"3\" z=\"0\"/><float name=\"radius\" value=\"0.5\"/>"  \
    "<emitter type=\"area\"><rgb name=\"radiance\" value=\"5\"/></emitter></shape>"
#define SDF_BALL "<shape type=\"sdf\"><sdf type=\"sphere\"/>"

TEST(unsupported_scenes_refused)
{
    check_refused(SCENE_HEAD LIGHT SDF_BALL "<bsdf type=\"roughplastic\"/></shape></scene>", "path", "opencl",
                  "opencl device: bsdf 'roughplastic' not supported");
    check_refused(SCENE_HEAD LIGHT SDF_BALL
                  "<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\"/></bsdf></shape></scene>",
                  "path", "opencl", "textured reflectance not supported");
    check_refused(SCENE_HEAD SDF_BALL "</shape><emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"2\" "
                                      "z=\"0\"/></emitter></scene>",
                  "path", "opencl", "emitter 'point' not supported");
    check_refused(SCENE_HEAD LIGHT SDF_BALL "</shape><emitter type=\"constant\"/></scene>", "path", "opencl",
                  "emitter 'constant' not supported");
    check_refused(SCENE_HEAD LIGHT "<shape type=\"disk\"/></scene>", "path", "opencl",
                  "of type disk not supported");
    check_refused(SCENE_HEAD SDF_BALL "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
                                      "</shape></scene>",
                  "path", "opencl", "area emitter on sdf shape");
    check_refused(SCENE_HEAD LIGHT SDF_BALL "</shape></scene>", "ipt", "opencl", "integrator 'ipt' not supported");
    check_refused(SCENE_HEAD LIGHT SDF_BALL "</shape></scene>", "volpath", "opencl",
                  "integrator 'volpath' not supported");
    check_refused(SCENE_HEAD LIGHT SDF_BALL "</shape></scene>", "path", "opencl:999", "no device opencl:999");
    check_refused(SCENE_HEAD LIGHT SDF_BALL "</shape></scene>", "path", "vulkan", "unknown device 'vulkan'");
}

TEST(devices_listed)
{
    char *s = spc_devices_describe();
    CHECK(s != NULL);
    if (s) {
        printf("%s", s);
        CHECK_MSG(strstr(s, "opencl:0") != NULL, "no OpenCL device found: %s", s);
    }
    free(s);
}


/* The driver's passes on the device: a render checkpointed after 3 passes and resumed to 6 equals
 * an uninterrupted render of 6, bit for bit; a device's checkpoint does not resume on another
 * device; a time limit renders whole passes. */
TEST(checkpoint_resume_and_time_limit)
{
    spc_scene *sc = load_scene("scenes/sdf_shapes_csg.xml", NULL, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    char ck[] = "/tmp/spc_test_opencl_XXXXXX";
    int fd = mkstemp(ck);
    CHECK(fd >= 0);
    if (fd < 0) {
        spc_scene_destroy(sc);
        return;
    }
    close(fd);
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 3;
    o.width = o.height = 16;
    o.integrator = "bdpt";
    o.max_depth = 6;
    o.seed = 11;
    o.device = "opencl";
    o.checkpoint_path = ck;
    spc_film *part = NULL, *resumed = NULL, *whole = NULL, *other = NULL;
    spc_error err;
    CHECK(spc_render(sc, &o, &part, NULL, &err) == SPC_OK);
    spc_checkpoint *c = NULL;
    CHECK(spc_checkpoint_load(ck, &c, &err) == SPC_OK);
    if (c) {
        spc_render_options r = o;
        r.spp = 6;
        r.checkpoint_path = NULL;
        r.resume = c;
        CHECK(spc_render(sc, &r, &resumed, NULL, &err) == SPC_OK);
        r.device = "cpu";
        spc_status st = spc_render(sc, &r, &other, NULL, &err);
        CHECK_MSG(st == SPC_ERR_VALUE, "resumed on the cpu: status %d", (int)st);
        CHECK(other == NULL);
    }
    o.spp = 6;
    o.checkpoint_path = NULL;
    CHECK(spc_render(sc, &o, &whole, NULL, &err) == SPC_OK);
    if (resumed && whole) {
        CHECK(resumed->spp == 6 && whole->spp == 6);
        CHECK(memcmp(resumed->rgb, whole->rgb, sizeof(float) * 3 * 16 * 16) == 0);
        CHECK(memcmp(resumed->var, whole->var, sizeof(float) * 3 * 16 * 16) == 0);
    }
    spc_film_destroy(part);
    spc_film_destroy(resumed);
    spc_film_destroy(whole);
    spc_film_destroy(other);
    spc_checkpoint_destroy(c);
    unlink(ck);

    spc_render_options t;
    spc_render_options_init(&t);
    t.width = t.height = 16;
    t.time_limit = 1.0;
    t.device = "opencl";
    spc_film *f = NULL;
    spc_render_stats stats;
    CHECK(spc_render(sc, &t, &f, &stats, &err) == SPC_OK);
    CHECK(f && f->spp >= 1 && stats.spp == f->spp);
    CHECK(stats.rays_traced >= (uint64_t)stats.spp * 16 * 16); /* at least the camera rays */
    printf("  time limit 1 s: %d passes in %.2f s\n", stats.spp, stats.wall_seconds);
    CHECK(stats.wall_seconds < 10.0); /* loose: the machine may be shared */
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* The command line: --device opencl on a scene the device lacks exits nonzero naming it. */
TEST(cli_refuses_by_name)
{
    const char *bin = getenv("SPC_BINARY_DIR");
    char path[] = "/tmp/spc_test_opencl_XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0 && bin);
    if (fd < 0 || !bin)
        return;
    const char *xml = SCENE_HEAD LIGHT SDF_BALL "<bsdf type=\"plastic\"/></shape></scene>";
    CHECK(write(fd, xml, strlen(xml)) == (ssize_t)strlen(xml));
    close(fd);
    char cmd[4096], out[4096] = "";
    snprintf(cmd, sizeof cmd, "%s/specula render %s --device opencl --quiet -o %s.exr 2>&1", bin, path, path);
    FILE *p = popen(cmd, "r");
    CHECK(p != NULL);
    if (p) {
        size_t n = fread(out, 1, sizeof out - 1, p);
        out[n] = '\0';
        int rc = pclose(p);
        CHECK_MSG(WIFEXITED(rc) && WEXITSTATUS(rc) != 0, "exit status %d", rc);
        CHECK_MSG(strstr(out, "opencl device: bsdf 'plastic' not supported") != NULL, "output: %s", out);
    }
    snprintf(cmd, sizeof cmd, "%s/specula info --devices 2>&1", bin);
    p = popen(cmd, "r");
    if (p) {
        size_t n = fread(out, 1, sizeof out - 1, p);
        out[n] = '\0';
        CHECK(pclose(p) == 0);
        CHECK_MSG(strstr(out, "cpu") && strstr(out, "opencl:0"), "output: %s", out);
    }
    unlink(path);
}

int main(void)
{
    RUN(devices_listed);
    RUN(unsupported_scenes_refused);
    RUN(deterministic);
    RUN(launch_size_does_not_change_image);
    RUN(checkpoint_resume_and_time_limit);
    RUN(cli_refuses_by_name);
    RUN(torus_path_matches_cpu);
    RUN(shapes_csg_path_matches_cpu);
    RUN(torus_bdpt_matches_cpu);
    RUN(shapes_csg_bdpt_matches_cpu);
    RUN(rectangle_light_matches_cpu);
    return spc_test_finish();
}
