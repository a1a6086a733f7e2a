/*
 * tests/test_caustic_guide_render.c: the path tracer with caustic guiding at receivers
 * (manifold/caustic_guide.h, the "recguide" option) against the same specular NEE without it.
 *
 * Two scenes, each rendered with recguide=0.5 (half of every guided vertex's directions toward the
 * photons' disks, so that a wrong mixture density shows) and without, compared by the per-pixel
 * z-test and the image means:
 *   - lit_caustic: a glass ball focuses a small ceiling light onto a second area light lying on
 *     the floor (the photons land on that light's surface), seen from a back wall: the wall's
 *     guided directions reach an emitter, so the weight of an emitter hit by BSDF sampling against
 *     light NEE must use the mixture's density on both sides;
 *   - the demo (scenes/demo.xml): the ceiling and walls lit by the glass ball's caustic on the
 *     floor, specular NEE at the floor point weighted against BSDF sampling through the glass.
 * And the render's statistics say when the guide ran.
 *
 * The Russian roulette of guided paths: on the demo with roulette from the first bounce
 * (rr_depth 1), the guide at 0.9 of the directions must not cut the camera paths short. The
 * roulette reads the throughput BSDF sampling would have given (path.c), so guided paths last about
 * as long as unguided ones (here longer: more of them pass through the glass ball, where the
 * roulette does not thin them); reading the guided beta, which the guide's density scales down at
 * every bounce toward a caustic, it would end them early: a third of the camera rays per sample.
 */
/* ctest-labels: stat */
/* ctest-timeout: 600 */
#include <string.h>
#include <unistd.h>

#include "harness.h"
#include "render_util.h"

static spc_scene *load_text_defs(const char *text, const spc_define *defs, int ndefs)
{
    char path[64];
    snprintf(path, sizeof path, "/tmp/spc_cguide_%ld.xml", (long)getpid());
    FILE *fp = fopen(path, "w");
    if (!fp)
        return NULL;
    fputs(text, fp);
    fclose(fp);
    spc_scene *sc = NULL;
    spc_error err;
    if (spc_scene_load(path, defs, ndefs, &sc, &err) != SPC_OK)
        printf("  load failed: %s\n", err.msg);
    remove(path);
    return sc;
}

static spc_scene *load_text(const char *text) { return load_text_defs(text, NULL, 0); }

static const char *const lit_caustic_xml =
    "<scene version=\"3.0.0\">\n"
    "<integrator type=\"path\"/>\n"
    "<sensor type=\"perspective\"><float name=\"fov\" value=\"50\"/>\n"
    "  <transform name=\"to_world\"><lookat origin=\"0, 1.6, 3\" target=\"0, 1, 0\" up=\"0, 1, 0\"/></transform>\n"
    "  <film type=\"hdrfilm\"><integer name=\"width\" value=\"12\"/><integer name=\"height\" value=\"12\"/>"
    "<rfilter type=\"box\"/></film></sensor>\n"
    "<shape type=\"rectangle\"><transform name=\"to_world\"><rotate x=\"1\" angle=\"-90\"/></transform>\n"
    "  <bsdf type=\"diffuse\"/></shape>\n"
    "<shape type=\"rectangle\"><transform name=\"to_world\"><translate y=\"1\" z=\"-1\"/></transform>\n"
    "  <bsdf type=\"diffuse\"/></shape>\n"
    "<shape type=\"rectangle\"><transform name=\"to_world\"><scale x=\"0.3\" y=\"0.3\"/><rotate x=\"1\" angle=\"-90\"/>"
    "<translate y=\"0.002\" z=\"0.5\"/></transform>\n"
    "  <bsdf type=\"diffuse\"/><emitter type=\"area\"><rgb name=\"radiance\" value=\"2\"/></emitter></shape>\n"
    "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0.8\" z=\"0\"/><float name=\"radius\" value=\"0.3\"/>\n"
    "  <bsdf type=\"dielectric\"/></shape>\n"
    "<shape type=\"rectangle\"><transform name=\"to_world\"><scale x=\"0.1\" y=\"0.1\"/><rotate x=\"1\" angle=\"90\"/>"
    "<translate y=\"2\" z=\"-0.8\"/></transform>\n"
    "  <emitter type=\"area\"><rgb name=\"radiance\" value=\"60\"/></emitter></shape>\n"
    "</scene>\n";

/* Renders sc with `base` and with base + ",recguide=0.5" (spp each, seeds apart) and compares them. */
static void guided_agrees(const spc_scene *sc, const char *base, int spp, const char *label)
{
    char guided[128];
    snprintf(guided, sizeof guided, "%s,recguide=0.5", base);
    spc_render_stats sg, sb;
    spc_film *img = tu_render_stats(sc, "path", guided, spp, 2, 71, &sg);
    spc_film *ref = tu_render_stats(sc, "path", base, spp, 2, 72, &sb);
    CHECK(img && ref);
    if (img && ref) {
        /* the statistics say which render had the guide */
        CHECK_MSG(sg.caustic_guide_entries > 0 && sb.caustic_guide_entries == 0, "%s: entries %d, %d", label,
                  sg.caustic_guide_entries, sb.caustic_guide_entries);
        CHECK(strstr(sg.specular_nee, "recguide=0.5") && !strstr(sb.specular_nee, "recguide"));
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(img, ref, 0.99, label, &d));
        printf("    %s: z-test pass %.4f of %d pixels; means %.5f vs %.5f; guide: %d entries, %.3f s\n", label,
               d.ztest_pass_fraction, d.ztest_pixels, d.mean_a[0], d.mean_b[0], sg.caustic_guide_entries,
               sg.caustic_guide_seconds);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
}

TEST(lit_caustic)
{
    spc_scene *sc = load_text(lit_caustic_xml);
    CHECK(sc);
    if (sc)
        guided_agrees(sc, "angular:later=1", 2048, "lit caustic: recguide vs none");
    spc_scene_destroy(sc);
}

TEST(demo)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/scenes/demo.xml", spc_test_source_dir());
    spc_define defs[1] = {{"res", "16"}};
    spc_scene *sc = NULL;
    spc_error err;
    CHECK_MSG(spc_scene_load(path, defs, 1, &sc, &err) == SPC_OK, "%s", err.msg);
    if (sc)
        guided_agrees(sc, "angular:camera=0.22,later=0.25", 512, "demo: recguide vs without");
    spc_scene_destroy(sc);
}

/* Rays traced from the camera (shadow rays left out) per camera sample. */
static double camera_rays_per_sample(const spc_scene *sc, const char *snee, uint64_t seed)
{
    spc_render_stats st;
    spc_film *f = tu_render_stats(sc, "path", snee, 32, 2, seed, &st);
    spc_film_destroy(f);
    return f && st.samples > 0 ? (double)(st.rays_traced - st.shadow_rays_traced) / (double)st.samples : 0.0;
}

TEST(guided_paths_survive_roulette)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/scenes/demo.xml", spc_test_source_dir());
    FILE *fp = fopen(path, "rb");
    CHECK(fp);
    if (!fp)
        return;
    static char text[16384];
    size_t n = fread(text, 1, sizeof text - 1, fp);
    fclose(fp);
    text[n] = 0;
    /* the demo at 8x8, its roulette from the first bounce */
    const char *at = "<integer name=\"max_depth\" value=\"$max_depth\"/>";
    char *hit = strstr(text, at);
    CHECK(hit);
    if (!hit)
        return;
    static char edited[16600];
    snprintf(edited, sizeof edited, "%.*s%s<integer name=\"rr_depth\" value=\"1\"/>%s", (int)(hit - text), text, at,
             hit + strlen(at));
    spc_define defs[1] = {{"res", "8"}};
    spc_scene *sc = load_text_defs(edited, defs, 1);
    CHECK(sc);
    if (sc) {
        double plain = camera_rays_per_sample(sc, "angular:later=1", 5);
        double guided = camera_rays_per_sample(sc, "angular:later=1,recguide=0.9", 5);
        /* guided / plain: 0.56 with the guided beta read by the roulette, 1.69 with the unguided one */
        CHECK_MSG(plain > 0.0 && guided >= 0.9 * plain, "camera rays per sample: guided %.3f, plain %.3f", guided,
                  plain);
        printf("    camera rays per sample: guided %.3f, plain %.3f (ratio %.2f)\n", guided, plain,
               plain > 0.0 ? guided / plain : 0.0);
    }
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(guided_paths_survive_roulette);
    RUN(lit_caustic);
    RUN(demo);
    return spc_test_finish();
}
