/*
 * tests/test_aov.c: the albedo and normal AOVs follow Open Image Denoise's definitions (aov.c):
 * the features of the first surface with a non-delta lobe, seen through mirrors and smooth glass.
 *
 * - A mirror facing the camera shows the wall behind the camera: every pixel's albedo is the wall's
 *   and its normal the wall's, for path, bdpt and volpath (not the mirror's own albedo, 1).
 * - A glass ball (eta 1.5) seen head-on through a narrow field of view, between a red wall behind
 *   it and a blue wall behind the camera: a ray is reflected with F = 0.04 at each crossing, so it
 *   ends on the red wall with probability (1 - F)^2 (1 + F^2 + F^4 + ...) = (1 - F) / (1 + F)
 *   and on the blue one otherwise; the albedo averaged over the pixel's samples is that blend,
 *   within 5 standard errors of the per-sample Bernoulli spread.
 * - A diffuse surface seen directly keeps its own albedo; the beauty image is bit for bit the same
 *   with and without AOVs (the walk through delta surfaces uses a random stream of its own).
 */
/* ctest-labels: unit */
/* ctest-timeout: 120 */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "io/mitsuba_xml.h"
#include "render/film.h"
#include "specula/specula.h"

static const char *const red_wall = "0.9, 0.1, 0.1", *const blue_wall = "0.1, 0.2, 0.9";

/* A camera at the origin looking down +z (fov degrees, n x n pixels), a `front` surface at z = 5
 * (mirror rectangle or glass ball), a red diffuse wall at z = 12 facing the camera and a blue one at
 * z = -12 facing +z, each 200 wide, and a point light. */
static char *scene_xml(const char *integrator, double fov, int n, const char *front)
{
    const char *fmt =
        "<scene version=\"3.0.0\"><integrator type=\"%s\"/>"
        "<sensor type=\"perspective\"><float name=\"fov\" value=\"%g\"/>"
        "<transform name=\"to_world\"><lookat origin=\"0,0,0\" target=\"0,0,1\" up=\"0,1,0\"/></transform>"
        "<film type=\"hdrfilm\"><integer name=\"width\" value=\"%d\"/><integer name=\"height\" value=\"%d\"/>"
        "<rfilter type=\"box\"/></film></sensor>"
        "%s"
        "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"100\"/><rotate y=\"1\" angle=\"180\"/>"
        "<translate z=\"12\"/></transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"%s\"/></bsdf>"
        "</shape>"
        "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"100\"/><translate z=\"-12\"/>"
        "</transform><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"%s\"/></bsdf></shape>"
        "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"3\" z=\"0\"/>"
        "<rgb name=\"intensity\" value=\"10\"/></emitter>"
        "</scene>";
    size_t len = strlen(fmt) + strlen(front) + strlen(integrator) + 256;
    char *s = malloc(len);
    if (s)
        snprintf(s, len, fmt, integrator, fov, n, n, front, red_wall, blue_wall);
    return s;
}

static const char *const mirror =
    "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"100\"/><rotate y=\"1\" angle=\"180\"/>"
    "<translate z=\"5\"/></transform><bsdf type=\"conductor\"/></shape>";
static const char *const glass_ball =
    "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0\" z=\"5\"/><float name=\"radius\" value=\"1\"/>"
    "<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.5\"/><float name=\"ext_ior\" value=\"1\"/>"
    "</bsdf></shape>";

static spc_film *render(const char *integrator, double fov, int n, const char *front, int spp, bool aovs)
{
    char *xml = scene_xml(integrator, fov, n, front);
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_film *film = NULL;
    if (!xml || spc_mitsuba_load_string(xml, strlen(xml), "aov.xml", ".", NULL, 0, &sc, &err) != SPC_OK) {
        printf("  load failed: %s\n", err.msg);
        free(xml);
        return NULL;
    }
    free(xml);
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp;
    o.threads = 2;
    o.aovs = aovs;
    spc_render_stats st;
    if (spc_render(sc, &o, &film, &st, &err) != SPC_OK) {
        printf("  render failed: %s\n", err.msg);
        spc_film_destroy(film);
        film = NULL;
    }
    spc_scene_destroy(sc);
    return film;
}

static void parse_rgb(const char *s, double c[3]) { sscanf(s, "%lf, %lf, %lf", &c[0], &c[1], &c[2]); }

TEST(mirror_shows_the_albedo_behind_the_camera)
{
    const char *integrators[] = {"path", "bdpt", "volpath"};
    double blue[3];
    parse_rgb(blue_wall, blue);
    for (int k = 0; k < 3; ++k) {
        spc_film *f = render(integrators[k], 40.0, 8, mirror, 4, true);
        CHECK(f && f->aov);
        if (!f || !f->aov)
            continue;
        double worst = 0.0;
        for (int i = 0; i < f->width * f->height; ++i) {
            const float *a = f->aov + SPC_FILM_AOVS * (size_t)i;
            for (int c = 0; c < 3; ++c)
                worst = fmax(worst, fabs(a[c] - blue[c]));
            worst = fmax(worst, fabs(a[3]) + fabs(a[4]) + fabs(a[5] - 1.0));
        }
        CHECK_MSG(worst < 1e-5, "%s: albedo or normal off by %g from the wall's seen in the mirror", integrators[k],
                  worst);
        spc_film_destroy(f);
    }
}

TEST(glass_ball_blends_reflection_and_transmission)
{
    const int spp = 4096;
    spc_film *f = render("path", 0.5, 2, glass_ball, spp, true);
    CHECK(f && f->aov);
    if (!f || !f->aov)
        return;
    double red[3], blue[3];
    parse_rgb(red_wall, red);
    parse_rgb(blue_wall, blue);
    const double F = 0.04; /* ((1.5 - 1) / (1.5 + 1))^2, at normal incidence */
    const double p_red = (1.0 - F) / (1.0 + F);
    const int npix = f->width * f->height;
    for (int c = 0; c < 3; ++c) {
        double mean = 0.0;
        for (int i = 0; i < npix; ++i)
            mean += f->aov[SPC_FILM_AOVS * (size_t)i + (size_t)c] / npix;
        double expect = p_red * red[c] + (1.0 - p_red) * blue[c];
        /* each sample's albedo is red or blue: a Bernoulli spread over npix * spp samples */
        double se = fabs(red[c] - blue[c]) * sqrt(p_red * (1.0 - p_red) / ((double)npix * spp));
        CHECK_MSG(fabs(mean - expect) < 5.0 * se + 1e-6, "channel %d: albedo %.5f, expected %.5f (se %.5f)", c, mean,
                  expect, se);
    }
    /* the normal is the wall's: -z on the red one, +z on the blue one */
    double nz = 0.0;
    for (int i = 0; i < npix; ++i)
        nz += f->aov[SPC_FILM_AOVS * (size_t)i + 5] / npix;
    double expect_nz = -p_red + (1.0 - p_red);
    CHECK_MSG(fabs(nz - expect_nz) < 5.0 * 2.0 * sqrt(p_red * (1.0 - p_red) / ((double)npix * spp)) + 1e-6,
              "normal z %.5f, expected %.5f", nz, expect_nz);
    spc_film_destroy(f);
}

TEST(diffuse_first_hit_and_beauty_unchanged)
{
    /* a wide view: the ball, and the red wall around it */
    spc_film *with = render("path", 40.0, 16, glass_ball, 8, true);
    spc_film *without = render("path", 40.0, 16, glass_ball, 8, false);
    CHECK(with && without && with->aov);
    if (with && without && with->aov) {
        size_t n = 3 * (size_t)with->width * (size_t)with->height;
        CHECK(memcmp(with->rgb, without->rgb, n * sizeof(float)) == 0);
        double red[3];
        parse_rgb(red_wall, red);
        /* the corner pixel sees the red wall directly */
        const float *a = with->aov;
        CHECK_MSG(fabs(a[0] - red[0]) < 1e-6 && fabs(a[1] - red[1]) < 1e-6 && fabs(a[2] - red[2]) < 1e-6,
                  "corner albedo (%g, %g, %g)", a[0], a[1], a[2]);
        CHECK_MSG(fabs(a[5] + 1.0) < 1e-6, "corner normal z %g", a[5]);
        CHECK(a[6] > 12.0); /* depth: the slant distance to the wall */
    }
    spc_film_destroy(with);
    spc_film_destroy(without);
}

int main(void)
{
    RUN(mirror_shows_the_albedo_behind_the_camera);
    RUN(glass_ball_blends_reflection_and_transmission);
    RUN(diffuse_first_hit_and_beauty_unchanged);
    return spc_test_finish();
}
