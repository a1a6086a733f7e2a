/*
 * tests/test_degenerate.c: degenerate and absurd input gives a clear error or a clean image, never a
 * crash, a NaN in the film or a silently wrong light.
 *
 * Zero-radius spheres, zero-area and singular shapes, negative, NaN, infinite and overflowing
 * emitters are refused with a message; zero-power lights, zero-area triangles, coincident vertices
 * and zero-length normals render to finite images with every integrator; estimates that are not
 * finite (or beyond float range) never reach the film and are counted as invalid samples, also in
 * `specula render --stats`; absurd film sizes and sample counts are refused.
 */
/* ctest-labels: unit */
/* ctest-timeout: 300 */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "harness.h"
#include "io/mitsuba_xml.h"
#include "specula/specula.h"

static char tmpdir[64];

static const char *tmp_path(const char *name)
{
    static char buf[4][512];
    static int k = 0;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

static bool write_text(const char *name, const char *text)
{
    FILE *fp = fopen(tmp_path(name), "wb");
    if (!fp)
        return false;
    bool ok = fputs(text, fp) >= 0;
    return fclose(fp) == 0 && ok;
}

/* An 8x8 camera looking at a 6x6 diffuse wall at z = -3, plus `body`. */
static char *scene_xml(const char *body)
{
    static const char *head =
        "<scene version=\"3.0.0\"><integrator type=\"path\"/>"
        "<sensor type=\"perspective\"><float name=\"fov\" value=\"60\"/>"
        "<transform name=\"to_world\"><lookat origin=\"0,0,4\" target=\"0,0,0\" up=\"0,1,0\"/></transform>"
        "<film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"8\"/></film>"
        "</sensor>"
        "<shape type=\"rectangle\"><transform name=\"to_world\"><translate z=\"-1\"/><scale value=\"3\"/></transform>"
        "</shape>";
    size_t n = strlen(head) + strlen(body) + 16;
    char *s = malloc(n);
    snprintf(s, n, "%s%s</scene>", head, body);
    return s;
}

static spc_status load(const char *body, spc_scene **sc, spc_error *err)
{
    char *xml = scene_xml(body);
    spc_status st = spc_mitsuba_load_string(xml, strlen(xml), "degenerate.xml", tmpdir, NULL, 0, sc, err);
    free(xml);
    return st;
}

/* Loading fails with this status and a message containing `what`. */
static void expect_refused(const char *body, spc_status code, const char *what)
{
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = load(body, &sc, &err);
    CHECK_MSG(st == code && !sc, "%s: got %s (%s)", what, spc_status_name(st), err.msg);
    CHECK_MSG(strstr(err.msg, what) != NULL, "message '%s' does not say '%s'", err.msg, what);
    spc_scene_destroy(sc);
}

typedef struct result {
    bool ok, finite;
    double mean;
    uint64_t invalid;
} result;

/* Renders body at 8x8 with `integrator`; ok false if loading or rendering failed. */
static result render(const char *body, const char *integrator, int spp)
{
    result r = {false, false, 0.0, 0};
    spc_scene *sc = NULL;
    spc_error err;
    if (load(body, &sc, &err) != SPC_OK) {
        printf("  load failed: %s\n", err.msg);
        return r;
    }
    spc_render_options o;
    spc_render_options_init(&o);
    o.integrator = integrator;
    o.spp = spp;
    o.threads = 2;
    o.aovs = true;
    spc_film *film = NULL;
    spc_render_stats st;
    if (spc_render(sc, &o, &film, &st, &err) == SPC_OK && film) {
        r.ok = true;
        r.finite = true;
        const float *rgb = spc_film_rgb(film), *var = spc_film_variance(film);
        size_t n = 3 * (size_t)spc_film_width(film) * (size_t)spc_film_height(film);
        for (size_t i = 0; i < n; ++i) {
            if (!isfinite(rgb[i]) || !isfinite(var[i]) || var[i] < 0.0f)
                r.finite = false;
            r.mean += rgb[i] / (double)n;
        }
        r.invalid = st.invalid_samples;
    } else {
        printf("  render failed: %s\n", err.msg);
    }
    spc_film_destroy(film);
    spc_scene_destroy(sc);
    return r;
}

static const char *const integrators[] = {"path", "ipt", "bdpt"};
#define NINTEGRATORS 3

TEST(degenerate_shapes_refused)
{
    expect_refused("<shape type=\"sphere\"><float name=\"radius\" value=\"0\"/></shape>", SPC_ERR_VALUE, "radius");
    expect_refused("<shape type=\"sphere\"><float name=\"radius\" value=\"-1\"/></shape>", SPC_ERR_VALUE, "radius");
    expect_refused("<shape type=\"rectangle\"><transform name=\"to_world\"><scale x=\"0\" y=\"1\" z=\"1\"/></transform>"
                   "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>",
                   SPC_ERR_VALUE, "singular");
    expect_refused("<shape type=\"sphere\"><float name=\"radius\" value=\"nan\"/></shape>", SPC_ERR_VALUE, "nan");
    expect_refused("<shape type=\"obj\"><string name=\"filename\" value=\"nan.obj\"/></shape>", SPC_ERR_VALUE, "nan.obj");
}

TEST(bad_emitters_refused)
{
    expect_refused("<emitter type=\"point\"><rgb name=\"intensity\" value=\"-1\"/></emitter>", SPC_ERR_VALUE, "power");
    expect_refused("<emitter type=\"point\"><rgb name=\"intensity\" value=\"1e308\"/></emitter>", SPC_ERR_VALUE,
                   "power inf");
    expect_refused("<shape type=\"sphere\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"-2\"/></emitter>"
                   "</shape>",
                   SPC_ERR_VALUE, "power");
    expect_refused("<emitter type=\"constant\"><rgb name=\"radiance\" value=\"-1\"/></emitter>", SPC_ERR_VALUE,
                   "power");
    expect_refused("<emitter type=\"point\"><rgb name=\"intensity\" value=\"inf\"/></emitter>", SPC_ERR_VALUE,
                   "inf");
}

TEST(zero_power_lights_render_black)
{
    const char *bodies[] = {
        "<shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/><emitter type=\"area\">"
        "<rgb name=\"radiance\" value=\"0\"/></emitter></shape>",
        "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"2\"/><rgb name=\"intensity\" value=\"0\"/>"
        "</emitter>",
        "", /* no light at all */
    };
    for (size_t b = 0; b < sizeof bodies / sizeof bodies[0]; ++b)
        for (int k = 0; k < NINTEGRATORS; ++k) {
            result r = render(bodies[b], integrators[k], 8);
            CHECK_MSG(r.ok && r.finite && r.mean == 0.0 && r.invalid == 0, "body %zu %s: ok %d finite %d mean %g", b,
                      integrators[k], r.ok, r.finite, r.mean);
        }
    /* a zero-power light beside a lit one does not disturb light selection */
    result lit = render("<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"2\"/></emitter>", "path",
                        16);
    result both = render("<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"2\"/></emitter>"
                         "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"1\" z=\"2\"/>"
                         "<rgb name=\"intensity\" value=\"0\"/></emitter>",
                         "path", 16);
    CHECK(lit.ok && both.ok && lit.mean > 0.0);
    CHECK_REL(both.mean, lit.mean, 1e-12, 0.0);
}

/* A mesh with a zero-length normal, a tiny one, a point triangle, a line triangle and a repeated
 * vertex, as a diffuse surface, as glass and as an area light. */
static const char *degenerate_obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nv 0 0 0\nv 1 1 0\n"
                                    "vn 0 0 0\nvn 0 0 1\nvn 1e-30 0 0\nvn 1e30 1e30 0\n"
                                    "f 1//1 2//1 3//1\nf 1//2 3//3 4//2\nf 5//2 5//2 5//2\nf 1//2 2//2 1//2\n"
                                    "f 3//4 6//4 4//4\nf 1//2 3//2 5//2\n";

TEST(degenerate_meshes_render)
{
    CHECK(write_text("degenerate.obj", degenerate_obj));
    const char *bodies[] = {
        "<shape type=\"obj\"><string name=\"filename\" value=\"degenerate.obj\"/><bsdf type=\"diffuse\"/></shape>"
        "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"2\"/></emitter>",
        "<shape type=\"obj\"><string name=\"filename\" value=\"degenerate.obj\"/><bsdf type=\"dielectric\"/></shape>"
        "<emitter type=\"constant\"/>",
        "<shape type=\"obj\"><string name=\"filename\" value=\"degenerate.obj\"/><emitter type=\"area\">"
        "<rgb name=\"radiance\" value=\"1\"/></emitter></shape>",
        "<shape type=\"obj\"><string name=\"filename\" value=\"degenerate.obj\"/><bsdf type=\"roughconductor\">"
        "<float name=\"alpha\" value=\"0\"/></bsdf></shape><shape type=\"sphere\"><point name=\"center\" x=\"1\" "
        "y=\"1\" z=\"1\"/><float name=\"radius\" value=\"1e-6\"/><emitter type=\"area\"><rgb name=\"radiance\" "
        "value=\"1e6\"/></emitter></shape>",
    };
    for (size_t b = 0; b < sizeof bodies / sizeof bodies[0]; ++b)
        for (int k = 0; k < NINTEGRATORS; ++k) {
            result r = render(bodies[b], integrators[k], 16);
            CHECK_MSG(r.ok && r.finite && r.invalid == 0, "body %zu %s: ok %d finite %d invalid %llu", b,
                      integrators[k], r.ok, r.finite, (unsigned long long)r.invalid);
            if (b != 3 && !(b == 0 && k == 1)) /* ipt cannot reach a point light */
                CHECK_MSG(r.mean > 0.0, "body %zu %s: black", b, integrators[k]);
        }
}

/* A point light 1e300 bright a hair from the wall: some estimates overflow float range. They are
 * dropped and counted, and the image stays finite. */
static const char *overflow_body = "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"-2.999\"/>"
                                   "<rgb name=\"intensity\" value=\"1e300\"/></emitter>";

TEST(invalid_samples_never_reach_the_film)
{
    for (int k = 0; k < NINTEGRATORS; ++k) {
        if (k == 1)
            continue; /* ipt never reaches a point light */
        result r = render(overflow_body, integrators[k], 8);
        CHECK_MSG(r.ok && r.finite, "%s", integrators[k]);
        CHECK_MSG(r.invalid > 0, "%s: %llu invalid", integrators[k], (unsigned long long)r.invalid);
    }
}

TEST(invalid_samples_in_stats_json)
{
    char *xml = scene_xml(overflow_body);
    CHECK(write_text("overflow.xml", xml));
    free(xml);
    const char *bin = getenv("SPC_BINARY_DIR");
    char binary[1024];
    snprintf(binary, sizeof binary, "%s/specula", bin ? bin : ".");
    if (access(binary, X_OK) != 0) {
        printf("  no specula binary at %s\n", binary);
        CHECK(0);
        return;
    }
    pid_t pid = fork();
    if (pid == 0) {
        if (chdir(tmpdir) != 0)
            _exit(126);
        execl(binary, binary, "render", "overflow.xml", "--spp", "4", "--quiet", "-o", "overflow.exr", "--stats",
              "overflow.json", (char *)NULL);
        _exit(127);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    FILE *fp = fopen(tmp_path("overflow.json"), "r");
    char buf[4096] = "";
    if (fp) {
        buf[fread(buf, 1, sizeof buf - 1, fp)] = '\0';
        fclose(fp);
    }
    const char *p = strstr(buf, "\"invalid_samples\": ");
    CHECK(p != NULL);
    if (p)
        CHECK_MSG(atoll(p + strlen("\"invalid_samples\": ")) > 0, "%s", buf);
    spc_image_rgb img;
    spc_error err;
    CHECK(spc_image_rgb_read(tmp_path("overflow.exr"), &img, &err) == SPC_OK);
    for (int i = 0; i < 3 * img.width * img.height; ++i)
        if (!isfinite(img.rgb[i])) {
            CHECK_MSG(0, "pixel value %d is %g", i, img.rgb[i]);
            break;
        }
    spc_image_rgb_release(&img);
}

TEST(absurd_sizes_refused)
{
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(load("", &sc, &err) == SPC_OK);
    if (!sc)
        return;
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 1;
    spc_film *film = NULL;
    o.width = o.height = 100000;
    CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_ERR_LIMIT && !film);
    CHECK(strstr(err.msg, "100000x100000") != NULL);
    o.width = 65536;
    o.height = 65536; /* each side allowed, the pixel count is not */
    CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_ERR_LIMIT && !film);
    o.width = o.height = 0;
    o.spp = 2147483647;
    CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_ERR_LIMIT && !film);
    CHECK(strstr(err.msg, "2147483647") != NULL);
    o.spp = 1;
    o.time_limit = 1e300; /* a time limit caps nothing absurd: one pass, stopped by the spp cap */
    CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_OK && film);
    spc_film_destroy(film);
    film = NULL;
    spc_scene_destroy(sc);
    sc = NULL;

    /* the scene itself asks for the absurd */
    const char *big = "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\">"
                      "<integer name=\"width\" value=\"100000\"/><integer name=\"height\" value=\"100000\"/>"
                      "</film><sampler type=\"independent\"><integer name=\"sample_count\" value=\"2147483647\"/>"
                      "</sampler></sensor></scene>";
    spc_status st = spc_mitsuba_load_string(big, strlen(big), "big.xml", tmpdir, NULL, 0, &sc, &err);
    if (st == SPC_OK) {
        spc_render_options_init(&o);
        CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_ERR_LIMIT && !film);
        o.width = o.height = 4;
        CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_ERR_LIMIT && !film); /* the spp */
        o.spp = 2;
        CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_OK && film);
        spc_film_destroy(film);
    } else {
        CHECK_MSG(st == SPC_ERR_LIMIT || st == SPC_ERR_VALUE, "%s", err.msg);
    }
    spc_scene_destroy(sc);
}

int main(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/spc_degenerate_XXXXXX");
    if (!mkdtemp(tmpdir))
        return 1;
    spc_warn_set_quiet(1);
    CHECK(write_text("nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n"));
    RUN(degenerate_shapes_refused);
    RUN(bad_emitters_refused);
    RUN(zero_power_lights_render_black);
    RUN(degenerate_meshes_render);
    RUN(invalid_samples_never_reach_the_film);
    RUN(invalid_samples_in_stats_json);
    RUN(absurd_sizes_refused);
    const char *files[] = {"nan.obj", "degenerate.obj", "overflow.xml", "overflow.json", "overflow.exr", "overflow.png"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; ++i)
        unlink(tmp_path(files[i]));
    rmdir(tmpdir);
    return spc_test_finish();
}
