/*
 * tests/test_cli.c: end-to-end checks of the `specula` command, run as a child process
 * ($SPC_BINARY_DIR/specula) in a temporary directory with stdout and stderr captured to files:
 * error messages with file:line:col, exit codes, no output written on failure, a tiny scene that
 * renders to EXR + PNG, `diff`, `info` and the --stats JSON; --mis-balance and --strategy-images.
 */
/* ctest-labels: unit */
/* ctest-timeout: 300 */
#include <fcntl.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cli_util.h"
#include "harness.h"
#include "specula/specula.h"

/* True if s contains `prefix` directly followed by digits and ':' (a column number). */
static bool has_position(const char *s, const char *prefix)
{
    for (const char *p = s ? strstr(s, prefix) : NULL; p; p = strstr(p + 1, prefix)) {
        const char *q = p + strlen(prefix);
        const char *d = q;
        while (*d >= '0' && *d <= '9')
            ++d;
        if (d > q && *d == ':')
            return true;
    }
    return false;
}

/* A rectangle light facing down over a diffuse floor; 4 triangles in all. */
static const char *tiny_scene =
    "<scene version=\"3.0.0\">\n"
    "  <integrator type=\"path\">\n"
    "    <integer name=\"max_depth\" value=\"4\"/>\n"
    "  </integrator>\n"
    "  <sensor type=\"perspective\">\n"
    "    <float name=\"fov\" value=\"45\"/>\n"
    "    <transform name=\"to_world\">\n"
    "      <lookat origin=\"0, 0, 4\" target=\"0, 0, 0\" up=\"0, 1, 0\"/>\n"
    "    </transform>\n"
    "    <sampler type=\"independent\">\n"
    "      <integer name=\"sample_count\" value=\"8\"/>\n"
    "    </sampler>\n"
    "    <film type=\"hdrfilm\">\n"
    "      <integer name=\"width\" value=\"16\"/>\n"
    "      <integer name=\"height\" value=\"16\"/>\n"
    "    </film>\n"
    "  </sensor>\n"
    "  <shape type=\"rectangle\" id=\"floor\">\n"
    "    <bsdf type=\"diffuse\">\n"
    "      <rgb name=\"reflectance\" value=\"0.5, 0.5, 0.5\"/>\n"
    "    </bsdf>\n"
    "  </shape>\n"
    "  <shape type=\"rectangle\" id=\"light\">\n"
    "    <transform name=\"to_world\">\n"
    "      <scale x=\"0.3\" y=\"0.3\" z=\"0.3\"/>\n"
    "      <rotate x=\"1\" angle=\"180\"/>\n"
    "      <translate x=\"0\" y=\"0\" z=\"2\"/>\n"
    "    </transform>\n"
    "    <emitter type=\"area\">\n"
    "      <rgb name=\"radiance\" value=\"5, 5, 5\"/>\n"
    "    </emitter>\n"
    "  </shape>\n"
    "</scene>\n";

/* The closing tag on line 3 does not match <shape> */
static const char *malformed_scene =
    "<scene version=\"3.0.0\">\n"
    "  <shape type=\"sphere\">\n"
    "</scene>\n";

static const char *unknown_plugin_scene =
    "<scene version=\"3.0.0\">\n"
    "  <shape type=\"sphere\">\n"
    "    <float name=\"radius\" value=\"1\"/>\n"
    "    <bsdf type=\"plastik\"/>\n"
    "  </shape>\n"
    "</scene>\n";

static const char *sentinel = "sentinel: not an image\n";

TEST(usage_and_version)
{
    CHECK(run(NULL) == EXIT_USAGE);
    CHECK(run("--version", NULL) == 0);
    char *o = read_text("out.txt");
    CHECK(o && strstr(o, SPECULA_VERSION));
    free(o);
    CHECK(run("--help", NULL) == 0);
    CHECK(run("render", "--help", NULL) == 0);
    o = read_text("out.txt");
    CHECK(o && strstr(o, "--spp"));
    free(o);
    CHECK(run("frobnicate", NULL) == EXIT_USAGE);
    CHECK(run("render", "tiny.xml", "--no-such-option", NULL) == EXIT_USAGE);
    CHECK(run("render", "tiny.xml", "--spp", "many", NULL) == EXIT_USAGE);
    CHECK(run("render", "tiny.xml", "--res", "16by16", NULL) == EXIT_USAGE);
    CHECK(run("render", NULL) == EXIT_USAGE);
    CHECK(run("diff", "only-one.exr", NULL) == EXIT_USAGE);
    char *e = read_text("err.txt");
    CHECK(e && strncmp(e, "specula: ", 9) == 0);
    free(e);
}

TEST(malformed_xml_names_position)
{
    CHECK(write_file("bad.xml", malformed_scene));
    int rc = run("render", "bad.xml", "--quiet", NULL);
    CHECK_MSG(rc == SPC_ERR_PARSE, "exit %d", rc);
    char *e = read_text("err.txt");
    CHECK_MSG(has_position(e, "bad.xml:3:"), "stderr: %s", e ? e : "(none)");
    CHECK(e && strncmp(e, "specula: ", 9) == 0);
    /* one line */
    CHECK(e && strchr(e, '\n') == e + strlen(e) - 1);
    free(e);
    CHECK(!exists("bad.exr") && !exists("bad.png"));
    /* info reports the same */
    CHECK(run("info", "bad.xml", NULL) == SPC_ERR_PARSE);
    e = read_text("err.txt");
    CHECK(has_position(e, "bad.xml:3:"));
    free(e);
}

TEST(unknown_plugin_names_type_and_line)
{
    CHECK(write_file("plugin.xml", unknown_plugin_scene));
    CHECK(run("render", "plugin.xml", "--quiet", NULL) == SPC_ERR_PLUGIN);
    char *e = read_text("err.txt");
    CHECK_MSG(e && strstr(e, "plastik"), "stderr: %s", e ? e : "(none)");
    CHECK_MSG(has_position(e, "plugin.xml:4:"), "stderr: %s", e ? e : "(none)");
    free(e);
}

TEST(failed_run_keeps_existing_output)
{
    CHECK(write_file("bad.xml", malformed_scene));
    CHECK(write_file("tiny.xml", tiny_scene));
    CHECK(write_file("keep.exr", sentinel));
    /* a load failure */
    CHECK(run("render", "bad.xml", "-o", "keep.exr", "--quiet", NULL) == SPC_ERR_PARSE);
    char *c = read_text("keep.exr");
    CHECK(c && !strcmp(c, sentinel));
    free(c);
    CHECK(!exists("keep.png"));
    /* an unknown --integrator is refused when the scene is read (it replaces the scene's type) */
    int rc = run("render", "tiny.xml", "-o", "keep.exr", "--integrator", "no-such-integrator", "--quiet", NULL);
    CHECK_MSG(rc == SPC_ERR_PLUGIN, "exit %d", rc);
    c = read_text("keep.exr");
    CHECK(c && !strcmp(c, sentinel));
    free(c);
    CHECK(!exists("keep.png"));
    /* a render failure: the scene loads, the film is absurdly large (each side within the limit,
     * 3.6e9 pixels beyond it) */
    rc = run("render", "tiny.xml", "-o", "keep.exr", "--res", "60000x60000", "--quiet", NULL);
    CHECK_MSG(rc == SPC_ERR_LIMIT, "exit %d", rc);
    c = read_text("keep.exr");
    CHECK(c && !strcmp(c, sentinel));
    free(c);
    CHECK(!exists("keep.png"));
    /* a malformed -D is a usage error, also before anything is written */
    CHECK(run("render", "tiny.xml", "-o", "keep.exr", "-D", "novalue", NULL) == EXIT_USAGE);
    c = read_text("keep.exr");
    CHECK(c && !strcmp(c, sentinel));
    free(c);
    /* no temporary files left behind */
    char cmd[600];
    snprintf(cmd, sizeof cmd, "ls %s | grep -q tmp", tmpdir);
    CHECK(system(cmd) != 0);
}

TEST(tiny_scene_renders_and_diffs)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    int rc = run("render", "tiny.xml", "-o", "out.exr", "--spp", "4", "--variance", "--quiet", NULL);
    CHECK(rc == 0);
    if (rc != 0)
        show_output();
    CHECK(exists("out.exr"));
    CHECK(exists("out.png"));
    char *c = read_text("out.exr");
    CHECK(c && (unsigned char)c[0] == 0x76 && c[1] == 0x2f && c[2] == 0x31 && c[3] == 0x01);
    free(c);

    CHECK(run("diff", "out.exr", "out.exr", NULL) == 0);
    char *o = read_text("out.txt");
    CHECK_MSG(o && strstr(o, "MSE: 0\n"), "stdout: %s", o ? o : "(none)");
    CHECK(o && strstr(o, "relMSE: 0\n"));
    CHECK(o && strstr(o, "z-test: 100.0000% of 256 pixels"));
    free(o);

    CHECK(run("diff", "out.exr", "out.exr", "--json", NULL) == 0);
    o = read_text("out.txt");
    CHECK(o && strstr(o, "\"mse\": 0"));
    CHECK(o && strstr(o, "\"pass_fraction\": 1"));
    /* the floor is lit: the mean is not black */
    const char *m = o ? strstr(o, "\"mean_a\": [") : NULL;
    CHECK(m && atof(m + strlen("\"mean_a\": [")) > 0.0);
    free(o);

    /* the PNG is comparable too; its size matches */
    CHECK(run("diff", "out.png", "out.exr", NULL) == 0);
    o = read_text("out.txt");
    CHECK(o && strstr(o, "16x16"));
    free(o);

    /* another seed gives a different image of the same size */
    CHECK(run("render", "tiny.xml", "-o", "seed.exr", "--spp", "4", "--seed", "7", "--quiet", NULL) == 0);
    CHECK(run("diff", "seed.exr", "out.exr", "--json", NULL) == 0);
    o = read_text("out.txt");
    CHECK(o && !strstr(o, "\"mse\": 0,"));
    free(o);

    /* --res changes the size; mismatched sizes are an input error for diff */
    CHECK(run("render", "tiny.xml", "-o", "small.exr", "--spp", "1", "--res", "8x4", "--quiet", NULL) == 0);
    rc = run("diff", "small.exr", "out.exr", NULL);
    CHECK_MSG(rc == SPC_ERR_VALUE, "exit %d", rc);
}

/* The mean squared difference `specula diff A B --json` reports, or -1. */
static double diff_mse(const char *a, const char *b)
{
    if (run("diff", a, b, "--json", NULL) != 0)
        return -1.0;
    char *o = read_text("out.txt");
    const char *m = o ? strstr(o, "\"mse\": ") : NULL;
    double v = m ? atof(m + strlen("\"mse\": ")) : -1.0;
    free(o);
    return v;
}

/* --mis-balance reaches bdpt (the image changes, the mean does not move far), the integrator
 * property mis_balance does the same, and a checkpoint keeps it for --resume. */
TEST(mis_balance_flag)
{
    CHECK(run("render", "--help", NULL) == 0);
    char *o = read_text("out.txt");
    CHECK(o && strstr(o, "--mis-balance"));
    free(o);
    CHECK(write_file("tiny.xml", tiny_scene));
    CHECK(run("render", "tiny.xml", "--integrator", "bdpt", "--spp", "8", "--seed", "3", "--quiet", "-o",
              "power.exr", NULL) == 0);
    int rc = run("render", "tiny.xml", "--integrator", "bdpt", "--mis-balance", "--spp", "8", "--seed", "3", "--quiet",
                 "-o", "balance.exr", NULL);
    CHECK_MSG(rc == 0, "exit %d", rc);
    if (rc != 0)
        show_output();
    CHECK(diff_mse("balance.exr", "power.exr") > 0.0);

    /* the same through the scene: <boolean name="mis_balance" value="true"/> */
    const char *at = strstr(tiny_scene, "  </integrator>");
    CHECK(at != NULL);
    if (!at)
        return;
    char xml[4096];
    snprintf(xml, sizeof xml, "%.*s    <boolean name=\"mis_balance\" value=\"true\"/>\n%s", (int)(at - tiny_scene),
             tiny_scene, at);
    CHECK(write_file("tiny_balance.xml", xml));
    CHECK(run("render", "tiny_balance.xml", "--integrator", "bdpt", "--spp", "8", "--seed", "3", "--quiet", "-o",
              "balance_xml.exr", NULL) == 0);
    CHECK(diff_mse("balance_xml.exr", "balance.exr") == 0.0);

    /* recorded in the checkpoint: the resumed render uses it, and it cannot be changed there */
    CHECK(run("render", "tiny.xml", "--integrator", "bdpt", "--mis-balance", "--spp", "5", "--seed", "3", "--quiet",
              "-o", "resumed.exr", "--checkpoint", "balance.ckpt", NULL) == 0);
    CHECK(run("render", "--resume", "balance.ckpt", "--mis-balance", "--quiet", NULL) == EXIT_USAGE);
    rc = run("render", "--resume", "balance.ckpt", "--spp", "8", "--quiet", NULL);
    CHECK_MSG(rc == 0, "exit %d", rc);
    CHECK(diff_mse("resumed.exr", "balance.exr") == 0.0);
}

/* --strategy-images DIR: every strategy of lengths 1..max_depth, weighted and unweighted, as EXR
 * and PNG, in one bdpt render; refused with --strategy, --checkpoint or another integrator. */
TEST(strategy_images_flag)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    int rc = run("render", "tiny.xml", "--integrator", "bdpt", "--max-depth", "2", "--spp", "2", "--quiet", "-o",
                 "strat.exr", "--strategy-images", "strat", "--variance", NULL);
    CHECK_MSG(rc == 0, "exit %d", rc);
    if (rc != 0)
        show_output();
    int found = 0;
    for (int k = 1; k <= 2; ++k)
        for (int s = 0; s <= k; ++s)
            for (int w = 0; w < 2; ++w)
                for (int png = 0; png < 2; ++png) {
                    char name[64];
                    snprintf(name, sizeof name, "strat/s%d_t%d_%s.%s", s, k + 1 - s, w ? "weighted" : "unweighted",
                             png ? "png" : "exr");
                    bool there = exists(name);
                    CHECK_MSG(there, "%s missing", name);
                    found += there;
                }
    CHECK(found == 20);
    /* the direct light at length 2 comes from NEE and light tracing: both unweighted images see it */
    CHECK(run("diff", "strat/s1_t2_unweighted.exr", "strat/s2_t1_unweighted.exr", "--json", NULL) == 0);
    char *o = read_text("out.txt");
    const char *m = o ? strstr(o, "\"mean_a\": [") : NULL, *mb = o ? strstr(o, "\"mean_b\": [") : NULL;
    CHECK(m && mb && atof(m + strlen("\"mean_a\": [")) > 0.0 && atof(mb + strlen("\"mean_b\": [")) > 0.0);
    free(o);
    CHECK(run("render", "tiny.xml", "--integrator", "bdpt", "--max-depth", "2", "--strategy", "1,1",
              "--strategy-images", "strat2", "--quiet", NULL) == EXIT_USAGE);
    CHECK(run("render", "tiny.xml", "--integrator", "bdpt", "--max-depth", "2", "--checkpoint", "s.ckpt",
              "--strategy-images", "strat2", "--quiet", NULL) == EXIT_USAGE);
    CHECK(run("render", "tiny.xml", "--integrator", "path", "--max-depth", "2", "--spp", "1", "-o", "p.exr",
              "--strategy-images", "strat2", "--quiet", NULL) == SPC_ERR_VALUE);
    char *e = read_text("err.txt");
    CHECK_MSG(e && strstr(e, "bdpt"), "stderr: %s", e ? e : "(none)");
    free(e);
    CHECK(!exists("p.exr"));
}

TEST(default_output_name)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    remove(tmp_path("tiny.exr"));
    remove(tmp_path("tiny.png"));
    CHECK(run("render", tmp_path("tiny.xml"), "--spp", "1", "--quiet", NULL) == 0);
    CHECK(exists("tiny.exr"));
    CHECK(exists("tiny.png"));
}

TEST(info_prints_triangles)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    CHECK(run("info", "tiny.xml", NULL) == 0);
    char *o = read_text("out.txt");
    CHECK_MSG(o && strstr(o, "triangles: 4\n"), "stdout: %s", o ? o : "(none)");
    CHECK(o && strstr(o, "film: 16x16"));
    CHECK(o && strstr(o, "emitters: 1\n"));
    CHECK(o && strstr(o, "id='floor'"));
    CHECK(o && strstr(o, "emitter 0: area"));
    free(o);
}

TEST(stats_json)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    CHECK(run("render", "tiny.xml", "-o", "stats.exr", "--spp", "2", "--threads", "1", "--stats", "stats.json",
              "--quiet", NULL) == 0);
    char *s = read_text("stats.json");
    CHECK(s != NULL);
    const char *keys[] = {"\"mrays_per_second\": ", "\"wall_seconds\": ", "\"rays_traced\": ", "\"threads\": 1",
                          "\"samples\": ", "\"invalid_samples\": ", "\"width\": 16", "\"height\": 16",
                          "\"spp\": 2", "\"integrator\": \"path\""};
    for (size_t k = 0; k < sizeof keys / sizeof keys[0]; ++k)
        CHECK_MSG(s && strstr(s, keys[k]), "missing %s in %s", keys[k], s ? s : "(none)");
    const char *r = s ? strstr(s, "\"rays_traced\": ") : NULL;
    CHECK(r && atof(r + strlen("\"rays_traced\": ")) >= 16 * 16 * 2);
    free(s);
}

int main(void)
{
    if (!cli_init("test_cli")) {
        printf("0 passed, 1 failed\n");
        return 1;
    }
    RUN(usage_and_version);
    RUN(malformed_xml_names_position);
    RUN(unknown_plugin_names_type_and_line);
    RUN(failed_run_keeps_existing_output);
    RUN(tiny_scene_renders_and_diffs);
    RUN(default_output_name);
    RUN(mis_balance_flag);
    RUN(strategy_images_flag);
    RUN(info_prints_triangles);
    RUN(stats_json);
    int rc = cli_finish(spc_test_finish());
    return rc;
}
