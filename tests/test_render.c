/*
 * tests/test_render.c: the estimators against closed forms (white furnace, a point light in a
 * diffuse sphere, a glass slab over a uniform emitter), robustness at scales 1e-3 and 1e3, and
 * bit-identical images for 1 and 2 threads, and the pixel filters on an edge (as Mitsuba 3).
 */
/* ctest-labels: stat */
/* ctest-timeout: 600 */
#include <string.h>
#include <unistd.h>

#include "harness.h"
#include "io/image_io.h"
#include "io/mitsuba_xml.h"
#include "render_util.h"

/* |mean - expected| within k standard errors (plus a tiny absolute slack for float storage). */
static void check_mean(const spc_film *f, double expected, double k)
{
    for (int c = 0; c < 3; ++c) {
        double m, se;
        tu_image_mean(f, c, &m, &se);
        CHECK_MSG(fabs(m - expected) <= k * se + 1e-6 * expected, "channel %d: mean %.6f expected %.6f (se %.2g)", c, m,
                  expected, se);
        CHECK_MSG(se > 0.0 && se < 0.02 * expected, "channel %d: standard error %.3g is not small", c, se);
    }
}

/* A closed sphere (normals inward) of albedo a emitting Le inside: L = Le / (1 - a). */
static spc_scene *furnace_sphere(double a, double Le, double scale)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_sphere(sh, spc_v3(0.3 * scale, -0.2 * scale, 0.1 * scale), scale, NULL, NULL, 0, 0, &err);
    sh->flip_normals = true;
    sh->bsdf = tu_diffuse(sc, a);
    tu_area(sc, sh, 0, Le);
    tu_camera(sc, spc_v3(0.3 * scale, -0.2 * scale, 0.1 * scale), spc_v3(0.3 * scale, -0.2 * scale, 1.1 * scale),
              spc_v3(0, 1, 0), 90, 8, 8);
    sc->camera.near_clip = 1e-4 * scale;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* A closed cube (a triangle mesh, normals inward) of albedo a emitting Le, at any scale. */
static spc_scene *furnace_cube(double a, double Le, double scale)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 M = spc_mat4_scale(spc_v3(scale, 0.7 * scale, 1.3 * scale));
    spc_mat4 T = spc_mat4_translate(spc_v3(2 * scale, 0, -scale));
    M = spc_mat4_mul(&T, &M);
    spc_shape_init_cube(sh, &M, NULL, 0, 0, &err);
    sh->flip_normals = true;
    sh->bsdf = tu_diffuse(sc, a);
    tu_area(sc, sh, 0, Le);
    tu_camera(sc, spc_v3(2.2 * scale, 0.1 * scale, -scale), spc_v3(1.5 * scale, -0.3 * scale, -0.2 * scale),
              spc_v3(0, 1, 0), 100, 8, 8);
    sc->camera.near_clip = 1e-4 * scale;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

TEST(white_furnace_sphere_ipt)
{
    spc_scene *sc = furnace_sphere(0.5, 1.0, 1.0);
    CHECK(sc != NULL);
    spc_film *f = sc ? tu_render(sc, "ipt", 512, 2, 1) : NULL;
    CHECK(f != NULL);
    if (f)
        check_mean(f, 2.0, 3.5);
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

TEST(white_furnace_sphere_path)
{
    spc_scene *sc = furnace_sphere(0.5, 1.0, 1.0);
    CHECK(sc != NULL);
    spc_film *f = sc ? tu_render(sc, "path", 512, 2, 2) : NULL;
    CHECK(f != NULL);
    if (f)
        check_mean(f, 2.0, 3.5);
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* Shadow acne would darken, light leaks brighten: the furnace must hold at every scale. */
TEST(white_furnace_cube_scales)
{
    double scales[3] = {1e-3, 1.0, 1e3};
    for (int i = 0; i < 3; ++i) {
        spc_scene *sc = furnace_cube(0.6, 0.5, scales[i]);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_film *f = tu_render(sc, "path", 256, 2, 3);
        CHECK(f != NULL);
        if (f)
            check_mean(f, 0.5 / (1.0 - 0.6), 3.5);
        spc_film_destroy(f);
        spc_scene_destroy(sc);
    }
}

/* A point light of intensity I at the centre of a diffuse sphere (radius r, albedo a):
 * L = (a / pi) (I / r^2) / (1 - a). */
TEST(point_light_in_sphere)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    double r = 2.0, a = 0.5, I = 3.0;
    spc_shape_init_sphere(sh, spc_v3(0, 0, 0), r, NULL, NULL, 0, 0, &err);
    sh->flip_normals = true;
    sh->bsdf = tu_diffuse(sc, a);
    spc_emitter *e = spc_scene_new_emitter(sc);
    e->type = SPC_EMITTER_POINT;
    e->intensity = spc_rgb1(I);
    e->position = spc_v3(0, 0, 0);
    tu_camera(sc, spc_v3(0, 0, 0.5), spc_v3(0, 1, 0.5), spc_v3(0, 0, 1), 90, 8, 8);
    CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
    spc_film *f = tu_render(sc, "path", 512, 2, 4);
    CHECK(f != NULL);
    /* the camera is off-centre but on every wall point the irradiance from the light is I/r^2 */
    if (f)
        check_mean(f, (a / SPC_PI) * (I / (r * r)) / (1.0 - a), 3.5);
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* A glass slab (IOR eta) seen at normal incidence in front of a uniform emitter Le: with every
 * internal reflection, L = Le (1 - R)^2 / (1 - R^2) = Le (1 - R) / (1 + R), R = ((eta-1)/(eta+1))^2. */
static spc_scene *glass_slab(double eta, double Le)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *slab = spc_scene_new_shape(sc);
    spc_mat4 M = spc_mat4_scale(spc_v3(10, 10, 0.2));
    spc_shape_init_cube(slab, &M, NULL, 0, 0, &err);
    spc_bsdf *g = spc_scene_new_bsdf(sc);
    g->type = SPC_BSDF_DIELECTRIC;
    g->eta = eta;
    g->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    g->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    slab->bsdf = g;
    spc_shape *light = spc_scene_new_shape(sc);
    spc_mat4 S = spc_mat4_scale(spc_v3(30, 30, 1));
    spc_mat4 T = spc_mat4_translate(spc_v3(0, 0, -3));
    spc_mat4 L = spc_mat4_mul(&T, &S);
    spc_shape_init_rectangle(light, &L, NULL, 0, 0, &err);
    light->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, light, 1, Le);
    /* orthographic camera at z = 5 looking down -z, a 1x1 window */
    sc->camera.type = SPC_CAMERA_ORTHOGRAPHIC;
    spc_mat4 V;
    spc_mat4_lookat(spc_v3(0, 0, 5), spc_v3(0, 0, 0), spc_v3(0, 1, 0), &V);
    spc_mat4 Sc = spc_mat4_scale(spc_v3(0.5, 0.5, 1));
    sc->camera.to_world = spc_mat4_mul(&V, &Sc);
    sc->film.width = sc->film.height = 8;
    sc->film.rfilter = SPC_RFILTER_BOX;
    sc->film.filter_radius = 0.5;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

TEST(glass_slab_transmission)
{
    double eta = 1.5, Le = 2.0;
    double R = spc_sqr((eta - 1) / (eta + 1));
    double expected = Le * (1 - R) / (1 + R);
    const char *names[2] = {"ipt", "path"};
    for (int k = 0; k < 2; ++k) {
        spc_scene *sc = glass_slab(eta, Le);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_film *f = tu_render(sc, names[k], 1024, 2, 5);
        CHECK(f != NULL);
        if (f)
            check_mean(f, expected, 3.5);
        spc_film_destroy(f);
        spc_scene_destroy(sc);
    }
}

TEST(same_image_for_any_thread_count)
{
    spc_scene *sc = glass_slab(1.33, 1.0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *a = tu_render(sc, "path", 16, 1, 7);
    spc_film *b = tu_render(sc, "path", 16, 2, 7);
    spc_film *c = tu_render(sc, "path", 16, 2, 8);
    CHECK(a && b && c);
    if (a && b && c) {
        size_t n = 3 * (size_t)a->width * a->height;
        CHECK(memcmp(a->rgb, b->rgb, n * sizeof(float)) == 0);
        CHECK(memcmp(a->var, b->var, n * sizeof(float)) == 0);
        CHECK(memcmp(a->rgb, c->rgb, n * sizeof(float)) != 0); /* the seed matters */
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_film_destroy(c);
    spc_scene_destroy(sc);
}

/* Mitsuba 3's pixel filters are step functions (render/film.h): the profile at |x| is looked up at
 * floor(|x| RES / r) r / RES. Computed here on its own (fine midpoint grid), not from film.c. */
static double mitsuba_filter_profile(spc_rfilter_type t, double r, double x, bool steps)
{
    double a = fabs(x);
    if (a >= r)
        return 0.0;
    if (steps)
        a = floor(a * SPC_FILTER_RESOLUTION / r) * r / SPC_FILTER_RESOLUTION;
    if (t == SPC_RFILTER_TENT)
        return 1.0 - a / r;
    return exp(-a * a / (2 * 0.25)) - exp(-r * r / (2 * 0.25)); /* gaussian, stddev 0.5 */
}

/* Share of the filter's mass at offsets x > d. */
static double filter_mass_beyond(spc_rfilter_type t, double r, double d, bool steps)
{
    const int n = 400000;
    double in = 0.0, all = 0.0;
    for (int i = 0; i < n; ++i) {
        double x = -r + 2 * r * (i + 0.5) / n, w = mitsuba_filter_profile(t, r, x, steps);
        all += w;
        in += x > d ? w : 0.0;
    }
    return in / all;
}

/* An orthographic view of a vertical edge of an emitter (radiance 1 for x > 0.03, black left of
 * it): pixel column i sees the share of the pixel filter beyond the edge, which for Mitsuba 3's
 * step-function filters differs measurably from the smooth tent's (0.0368 against 0.0338 one and a
 * half pixels away). Mitsuba 3 images failed the z-test along edges before the step filters. */
TEST(filter_edge_as_mitsuba)
{
    spc_rfilter_type types[2] = {SPC_RFILTER_TENT, SPC_RFILTER_GAUSSIAN};
    double radii[2] = {1.0, 2.0};
    for (int k = 0; k < 2; ++k) {
        spc_scene *sc = spc_scene_create();
        spc_error err;
        spc_shape *light = spc_scene_new_shape(sc);
        spc_mat4 S = spc_mat4_scale(spc_v3(5, 5, 1));
        spc_mat4 T = spc_mat4_translate(spc_v3(5.03, 0, 0));
        spc_mat4 L = spc_mat4_mul(&T, &S);
        spc_shape_init_rectangle(light, &L, NULL, 0, 0, &err);
        light->bsdf = tu_diffuse(sc, 0.0);
        tu_area(sc, light, 0, 1.0);
        sc->camera.type = SPC_CAMERA_ORTHOGRAPHIC;
        spc_mat4_lookat(spc_v3(0, 0, 5), spc_v3(0, 0, 0), spc_v3(0, 1, 0), &sc->camera.to_world);
        const int W = 16;
        sc->film.width = sc->film.height = W;
        sc->film.rfilter = types[k];
        sc->film.filter_radius = radii[k];
        sc->film.filter_stddev = 0.5;
        CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
        spc_film *f = tu_render(sc, "path", 8192, 2, 3);
        CHECK(f != NULL);
        if (f) {
            /* film x in [-1, 1] spans the W pixels: the edge lies at pixel coordinate 8.24 */
            double edge = (0.03 + 1.0) / 2.0 * W;
            const float *rgb = spc_film_rgb(f), *var = spc_film_variance(f);
            for (int col = 6; col <= 9; ++col) {
                double m = 0.0, v = 0.0;
                for (int row = 2; row < W - 2; ++row) {
                    m += rgb[3 * (row * W + col)];
                    v += var[3 * (row * W + col)];
                }
                int rows = W - 4;
                m /= rows;
                double se = sqrt(v) / rows;
                double want = filter_mass_beyond(types[k], radii[k], edge - (col + 0.5), true);
                CHECK_MSG(fabs(m - want) <= 4 * se + 1e-6, "filter %d column %d: %.5f, steps %.5f (se %.2g)", k, col, m,
                          want, se);
                /* the test can tell the smooth tent from the steps */
                double smooth = filter_mass_beyond(types[k], radii[k], edge - (col + 0.5), false);
                if (k == 0 && col == 7)
                    CHECK_MSG(fabs(m - smooth) > 4 * se, "tent column 7: %.5f is as close to the smooth tent %.5f", m,
                              smooth);
            }
        }
        spc_film_destroy(f);
        spc_scene_destroy(sc);
    }
}

/* Mitsuba 3's aov integrator: its outputs come out as EXR channels named as Mitsuba names them,
 * with the values of the first vertex: a plane facing the camera at distance 2 (depth 2, normal
 * -z, position on z = 2, albedo its reflectance), the nested integrator's image again. */
TEST(aov_integrator_channels)
{
    static const char xml[] =
        "<scene version=\"3.0.0\">"
        "<integrator type=\"aov\"><string name=\"aovs\" value=\"dd:depth, nn:sh_normal,pos:position,a:albedo\"/>"
        "<integrator type=\"path\" name=\"image\"/></integrator>"
        "<sensor type=\"perspective\"><float name=\"fov\" value=\"10\"/>"
        "<film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/><integer name=\"height\" value=\"4\"/>"
        "<rfilter type=\"box\"/></film></sensor>"
        "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"10\"/><rotate y=\"1\" angle=\"180\"/>"
        "<translate z=\"2\"/></transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.25, 0.5, 0.75\"/>"
        "</bsdf></shape><emitter type=\"constant\"/></scene>";
    spc_scene *s = NULL;
    spc_error err;
    if (spc_mitsuba_load_string(xml, sizeof xml - 1, "aov.xml", ".", NULL, 0, &s, &err) != SPC_OK) {
        char msg[1200];
        spc_error_format(&err, msg, sizeof msg);
        CHECK_MSG(false, "%s", msg);
        return;
    }
    CHECK(s->integrator.naovs == 4 && strcmp(s->integrator.aov_image, "image") == 0);
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 4;
    o.threads = 1;
    spc_film *f = NULL;
    spc_render_stats st;
    CHECK(spc_render(s, &o, &f, &st, &err) == SPC_OK);
    char path[] = "/tmp/specula_aov_XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd >= 0)
        close(fd);
    CHECK(f && spc_film_write_exr(f, path, false, &err) == SPC_OK);
    static const char *const names[] = {"dd.T",  "nn.X",  "nn.Y", "nn.Z", "pos.X",   "pos.Y",  "pos.Z",
                                        "a.R",   "a.G",   "a.B",  "R",    "image.R", "image.B"};
    const int nn = (int)(sizeof names / sizeof names[0]);
    int w = 0, h = 0;
    float *px = NULL;
    bool found[sizeof names / sizeof names[0]];
    CHECK(spc_exr_read_channels(path, nn, names, &w, &h, &px, found, &err) == SPC_OK);
    for (int k = 0; k < nn; ++k)
        CHECK_MSG(found[k], "channel %s missing", names[k]);
    for (int i = 0; px && i < w * h; ++i) {
        const float *v = px + (size_t)i * nn;
        /* distance to the plane z = 2 along rays within 5 degrees of the axis */
        CHECK(v[0] > 2.0 && v[0] < 2.0 / cos(6.0 * SPC_PI / 180.0));
        CHECK_NEAR(fabs(v[3]), 1.0, 1e-6);
        CHECK_NEAR(v[6], 2.0, 1e-5);
        CHECK(fabs(v[4]) < 0.2 && fabs(v[5]) < 0.2);
        CHECK_NEAR(v[7], 0.25, 1e-6);
        CHECK_NEAR(v[8], 0.5, 1e-6);
        CHECK_NEAR(v[9], 0.75, 1e-6);
        CHECK_NEAR(v[10], v[11], 1e-7); /* the nested image equals the image */
        CHECK(v[12] > 0.0);
    }
    free(px);
    remove(path);
    spc_film_destroy(f);
    spc_scene_destroy(s);
}

/* strict_normals (Mitsuba 0.6's strictNormals): a diffuse plane whose vertex normals lean 70
 * degrees from its geometric normal, under a constant sky of radiance 1, seen from the side the
 * shading normal leans to. Without strict normals the pixel is rho (the whole hemisphere around the
 * shading normal is lit, some of it from below the plane); with them only the directions above
 * both normals count: rho/pi times the integral of cos over that lune, by quadrature here. */
TEST(strict_normals_drop_light_below_the_surface)
{
    const double tilt = 70.0 * SPC_PI / 180.0, rho = 0.5;
    const spc_vec3 sn = spc_v3(sin(tilt), 0.0, cos(tilt));
    double lune = 0.0;
    const int nt = 600, np = 1200;
    for (int i = 0; i < nt; ++i)
        for (int j = 0; j < np; ++j) {
            double th = (i + 0.5) * SPC_PI / nt, ph = (j + 0.5) * 2.0 * SPC_PI / np;
            spc_vec3 w = spc_v3(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
            double c = spc_dot(w, sn);
            if (w.z > 0.0 && c > 0.0)
                lune += c * sin(th) * (SPC_PI / nt) * (2.0 * SPC_PI / np);
        }
    const double want_strict = rho * lune / SPC_PI;
    char dir[] = "/tmp/specula_strict_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char obj[600];
    snprintf(obj, sizeof obj, "%s/plane.obj", dir);
    FILE *fp = fopen(obj, "w");
    CHECK(fp != NULL);
    if (!fp)
        return;
    fprintf(fp, "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvn %.17g 0 %.17g\nf 1//1 2//1 3//1\nf 1//1 3//1 4//1\n", sn.x,
            sn.z);
    fclose(fp);
    for (int strict = 0; strict < 2; ++strict) {
        char xml[2000];
        snprintf(xml, sizeof xml,
                 "<scene version=\"3.0.0\"><integrator type=\"path\"><integer name=\"max_depth\" value=\"2\"/>"
                 "<boolean name=\"strict_normals\" value=\"%s\"/></integrator>"
                 "<sensor type=\"perspective\"><float name=\"fov\" value=\"5\"/><transform name=\"to_world\">"
                 "<lookat origin=\"3, 0, 3\" target=\"0, 0, 0\" up=\"0, 0, 1\"/></transform>"
                 "<film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/><integer name=\"height\" value=\"4\"/>"
                 "<rfilter type=\"box\"/></film></sensor>"
                 "<shape type=\"obj\"><string name=\"filename\" value=\"plane.obj\"/><transform name=\"to_world\">"
                 "<scale value=\"10\"/></transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"%g\"/>"
                 "</bsdf></shape><emitter type=\"constant\"/></scene>",
                 strict ? "true" : "false", rho);
        spc_scene *s = NULL;
        spc_error err;
        CHECK(spc_mitsuba_load_string(xml, strlen(xml), "strict.xml", dir, NULL, 0, &s, &err) == SPC_OK);
        if (!s)
            continue;
        spc_render_options o;
        spc_render_options_init(&o);
        o.spp = 4096;
        o.threads = 2;
        spc_film *f = NULL;
        spc_render_stats st;
        CHECK(spc_render(s, &o, &f, &st, &err) == SPC_OK);
        if (f)
            check_mean(f, strict ? want_strict : rho, 5.0);
        spc_film_destroy(f);
        spc_scene_destroy(s);
    }
    CHECK(want_strict < 0.8 * rho); /* the two cases differ */
    remove(obj);
    rmdir(dir);
}

/* A polarizer as Mitsuba 3's RGB variants render it: the sky seen through it is half as bright
 * times its transmittance, by path (a null lobe) and by volpath (a null surface crossed). */
TEST(polarizer_passes_half)
{
    for (int vol = 0; vol < 2; ++vol) {
        char xml[1500];
        snprintf(xml, sizeof xml,
                 "<scene version=\"3.0.0\"><integrator type=\"%s\"/>"
                 "<sensor type=\"perspective\"><float name=\"fov\" value=\"10\"/>"
                 "<film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/><integer name=\"height\" value=\"4\"/>"
                 "<rfilter type=\"box\"/></film></sensor>"
                 "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"10\"/><translate z=\"2\"/>"
                 "</transform><bsdf type=\"polarizer\"><float name=\"transmittance\" value=\"0.6\"/></bsdf></shape>"
                 "<emitter type=\"constant\"/></scene>",
                 vol ? "volpath" : "path");
        spc_scene *s = NULL;
        spc_error err;
        CHECK(spc_mitsuba_load_string(xml, strlen(xml), "pol.xml", ".", NULL, 0, &s, &err) == SPC_OK);
        if (!s)
            continue;
        spc_render_options o;
        spc_render_options_init(&o);
        o.spp = 16;
        spc_film *f = NULL;
        spc_render_stats st;
        CHECK(spc_render(s, &o, &f, &st, &err) == SPC_OK);
        for (int i = 0; f && i < 3 * spc_film_width(f) * spc_film_height(f); ++i)
            CHECK_NEAR(spc_film_rgb(f)[i], 0.3, 1e-6);
        spc_film_destroy(f);
        spc_scene_destroy(s);
    }
}

int main(void)
{
    spc_warn_set_quiet(1);
    RUN(white_furnace_sphere_ipt);
    RUN(white_furnace_sphere_path);
    RUN(white_furnace_cube_scales);
    RUN(point_light_in_sphere);
    RUN(glass_slab_transmission);
    RUN(same_image_for_any_thread_count);
    RUN(filter_edge_as_mitsuba);
    RUN(aov_integrator_channels);
    RUN(strict_normals_drop_light_below_the_surface);
    RUN(polarizer_passes_half);
    return spc_test_finish();
}
