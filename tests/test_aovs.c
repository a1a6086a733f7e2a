/*
 * tests/test_aovs.c: the --aovs channels (albedo, shading normal, depth) against values known from
 * the scene, not only their bytes across thread counts.
 *
 * An orthographic camera at z = 5 looks down on three vertical stripes, each seen along -z:
 *   left   a diffuse floor at z = 0, reflectance a_floor: albedo a_floor, normal +z, depth 5;
 *   middle a mirror at z = 0.5 (specular_reflectance m) that sends the ray up to a diffuse ceiling
 *          at z = 10 (reflectance a_ceil, facing down): albedo m a_ceil, normal -z, depth 4.5;
 *   right  a glass sheet at z = 1 (ior 1.5: F = 0.04 at normal incidence) over the floor: a
 *          fraction F of the samples reflect to the ceiling, 1 - F refract to the floor, so the
 *          albedo's mean is F a_ceil + (1 - F) a_floor, the normal's z is -F + (1 - F), depth 4.
 * The path integrator follows specular surfaces to the first one that is not (a denoiser's
 * albedo); the mirror and direct stripes are exact per pixel, the glass stripe's mean is checked
 * within 6 standard errors of its Bernoulli count.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "harness.h"
#include "io/mitsuba_xml.h"
#include "render/film.h"
#include "specula/specula.h"

#define RES 48
#define SPP 256

static const char *scene_xml =
    "<scene version=\"3.0.0\">\n"
    "  <integrator type=\"path\"><integer name=\"max_depth\" value=\"4\"/></integrator>\n"
    "  <sensor type=\"orthographic\">\n"
    "    <transform name=\"to_world\">\n"
    "      <lookat origin=\"0, 0, 5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/>\n"
    "    </transform>\n"
    "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"48\"/><integer name=\"height\" value=\"48\"/>\n"
    "      <rfilter type=\"box\"/></film>\n"
    "  </sensor>\n"
    "  <emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n"
    "  <shape type=\"rectangle\">\n" /* the floor */
    "    <transform name=\"to_world\"><scale value=\"3\"/></transform>\n"
    "    <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.2, 0.4, 0.6\"/></bsdf>\n"
    "  </shape>\n"
    "  <shape type=\"rectangle\">\n" /* the ceiling, facing down */
    "    <transform name=\"to_world\"><scale value=\"30\"/><rotate x=\"1\" angle=\"180\"/>\n"
    "      <translate z=\"10\"/></transform>\n"
    "    <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5, 0.5, 0.1\"/></bsdf>\n"
    "  </shape>\n"
    "  <shape type=\"rectangle\">\n" /* the mirror: x in [-1/3, 1/3] */
    "    <transform name=\"to_world\"><scale x=\"0.333333333333\" y=\"3\" z=\"1\"/><translate z=\"0.5\"/></transform>\n"
    "    <bsdf type=\"conductor\"><string name=\"material\" value=\"none\"/>\n"
    "      <rgb name=\"specular_reflectance\" value=\"0.9, 0.8, 0.7\"/></bsdf>\n"
    "  </shape>\n"
    "  <shape type=\"rectangle\">\n" /* the glass: x in [1/3, 1] and beyond */
    "    <transform name=\"to_world\"><scale x=\"0.333333333333\" y=\"3\" z=\"1\"/>\n"
    "      <translate x=\"0.666666666667\" z=\"1\"/></transform>\n"
    "    <bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.5\"/>\n"
    "      <float name=\"ext_ior\" value=\"1\"/></bsdf>\n"
    "  </shape>\n"
    "  <shape type=\"rectangle\">\n" /* more glass beyond the view, so the stripe ends at its edge */
    "    <transform name=\"to_world\"><scale x=\"1\" y=\"3\" z=\"1\"/><translate x=\"2\" z=\"1\"/></transform>\n"
    "    <bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.5\"/>\n"
    "      <float name=\"ext_ior\" value=\"1\"/></bsdf>\n"
    "  </shape>\n"
    "</scene>\n";

/* The stripe a pixel column sees, by its AOV depth (5, 4.5, 4), or -1 on an edge. */
static int stripe_of(double depth)
{
    if (fabs(depth - 5.0) < 1e-6)
        return 0;
    if (fabs(depth - 4.5) < 1e-6)
        return 1;
    if (fabs(depth - 4.0) < 1e-6)
        return 2;
    return -1;
}

TEST(aovs_match_the_scene)
{
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = spc_mitsuba_load_string(scene_xml, strlen(scene_xml), "aovs.xml", ".", NULL, 0, &sc, &err);
    CHECK_MSG(st == SPC_OK, "%s", err.msg);
    if (st != SPC_OK)
        return;
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = SPP;
    o.aovs = true;
    o.seed = 11;
    o.specular_nee = ""; /* the AOVs do not depend on it; keep the render small */
    spc_film *f = NULL;
    spc_render_stats stats;
    st = spc_render(sc, &o, &f, &stats, &err);
    CHECK_MSG(st == SPC_OK && f && f->aov, "%s", err.msg);
    if (st != SPC_OK || !f || !f->aov) {
        spc_film_destroy(f);
        spc_scene_destroy(sc);
        return;
    }
    const double a_floor[3] = {0.2, 0.4, 0.6}, a_ceil[3] = {0.5, 0.5, 0.1}, m[3] = {0.9, 0.8, 0.7};
    const double F = 0.04; /* ((1.5 - 1) / (1.5 + 1))^2 */
    int count[3] = {0, 0, 0}, bad[3] = {0, 0, 0}, edge = 0;
    double glass_albedo[3] = {0, 0, 0}, glass_nz = 0.0;
    for (int y = 0; y < f->height; ++y)
        for (int x = 0; x < f->width; ++x) {
            const float *a = f->aov + SPC_FILM_AOVS * ((size_t)y * (size_t)f->width + (size_t)x);
            int s = stripe_of(a[6]);
            if (s < 0) {
                ++edge;
                continue;
            }
            ++count[s];
            bool ok = true;
            if (s == 0) {
                for (int c = 0; c < 3; ++c)
                    ok = ok && fabs(a[c] - a_floor[c]) < 1e-5;
                ok = ok && fabs(a[3]) < 1e-6 && fabs(a[4]) < 1e-6 && fabs(a[5] - 1.0) < 1e-6;
            } else if (s == 1) {
                for (int c = 0; c < 3; ++c)
                    ok = ok && fabs(a[c] - m[c] * a_ceil[c]) < 1e-5;
                ok = ok && fabs(a[3]) < 1e-6 && fabs(a[4]) < 1e-6 && fabs(a[5] + 1.0) < 1e-6;
            } else {
                for (int c = 0; c < 3; ++c)
                    glass_albedo[c] += a[c];
                glass_nz += a[5];
                ok = fabs(a[3]) < 1e-6 && fabs(a[4]) < 1e-6;
            }
            if (!ok && bad[s]++ < 3)
                printf("  pixel (%d, %d), stripe %d: albedo (%g, %g, %g) normal (%g, %g, %g) depth %g\n", x, y, s,
                       a[0], a[1], a[2], a[3], a[4], a[5], a[6]);
        }
    /* each stripe holds about a third of the image; only the columns on the stripes' edges mix */
    for (int s = 0; s < 3; ++s) {
        CHECK_MSG(count[s] > RES * RES / 4, "stripe %d: %d pixels", s, count[s]);
        CHECK_MSG(bad[s] == 0, "stripe %d: %d of %d pixels wrong", s, bad[s], count[s]);
    }
    CHECK_MSG(edge <= 4 * RES, "%d pixels on no stripe", edge);
    if (count[2] > 0) {
        /* the reflected fraction over n pixels x SPP samples: standard error sqrt(F (1 - F) / (n SPP)) */
        double n = count[2], se = sqrt(F * (1.0 - F) / (n * SPP));
        double frac = 0.0;
        for (int c = 0; c < 3; ++c) {
            double mean = glass_albedo[c] / n, want = F * a_ceil[c] + (1.0 - F) * a_floor[c];
            double tol = 6.0 * se * fabs(a_ceil[c] - a_floor[c]) + 1e-6;
            CHECK_MSG(fabs(mean - want) < tol, "glass albedo %c: %.5f, want %.5f +- %.5f", "RGB"[c], mean, want, tol);
        }
        frac = (1.0 - glass_nz / n) / 2.0; /* nz = (1 - f) - f */
        CHECK_MSG(fabs(frac - F) < 6.0 * se, "glass: %.4f of the samples reflected, want %.4f +- %.4f", frac, F,
                  6.0 * se);
    }
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(aovs_match_the_scene);
    return spc_test_finish();
}
