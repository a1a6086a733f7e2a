/*
 * tests/test_determinism.c: the same image, bit for bit, for 1, 2 and 8 threads, for every
 * integrator specula has (path, ipt, bdpt), across a checkpoint and resume, and for either order of
 * the driver's work items (pass by pass, or tile by tile through groups of passes).
 *
 * The demo scene at 40x40 has nine tiles, some partial, so thread scheduling really varies; ipt and
 * bdpt splat onto other tiles' pixels, which the driver must merge in a fixed order. RGB, variance
 * and the AOVs are compared through the written EXRs, byte for byte.
 */
/* ctest-labels: scene */
/* ctest-timeout: 600 */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "file_util.h"
#include "harness.h"
#include "specula/specula.h"

#define SPP 6
#define RESUME_AT 2

static char tmpdir[64];
static char scene_path[2048];

static const char *tmp_path(const char *name)
{
    static char buf[4][512];
    static int k = 0;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

/* Renders with these options and writes an EXR with variance and AOVs; false if the integrator is
 * unknown (*missing) or anything failed. */
static bool render_to(spc_scene *sc, spc_render_options *o, const char *out, bool *missing)
{
    spc_film *film = NULL;
    spc_error err;
    spc_status st = spc_render(sc, o, &film, NULL, &err);
    if (missing)
        *missing = st == SPC_ERR_PLUGIN;
    bool ok = st == SPC_OK && film && spc_film_write_exr(film, out, true, &err) == SPC_OK;
    if (!ok && st != SPC_ERR_PLUGIN)
        printf("  %s: %s\n", out, err.msg);
    spc_film_destroy(film);
    return ok;
}

TEST(threads_and_resume)
{
    spc_define defs[2] = {{"res", "40"}, {"max_depth", "6"}};
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_scene_load(scene_path, defs, 2, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    const char *integrators[] = {"path", "ipt", "bdpt"};
    const int threads[] = {1, 2, 8};
    int tested = 0;
    for (int k = 0; k < 3; ++k) {
        char ref[64];
        snprintf(ref, sizeof ref, "%s_1.exr", integrators[k]);
        for (int t = 0; t < 3; ++t) {
            spc_render_options o;
            spc_render_options_init(&o);
            o.integrator = integrators[k];
            o.spp = SPP;
            o.seed = 42;
            o.threads = threads[t];
            o.aovs = true;
            char out[64];
            snprintf(out, sizeof out, "%s_%d.exr", integrators[k], threads[t]);
            bool ok = render_to(sc, &o, tmp_path(out), NULL);
            CHECK_MSG(ok, "%s with %d threads", integrators[k], threads[t]);
            if (t > 0)
                CHECK_MSG(same_file(tmp_path(out), tmp_path(ref)), "%s: %d threads differ from 1", integrators[k],
                          threads[t]);
            if (t == 2)
                ++tested;
        }

        /* a checkpoint after RESUME_AT passes with 8 threads, resumed with 2 */
        spc_render_options o;
        spc_render_options_init(&o);
        o.integrator = integrators[k];
        o.seed = 42;
        o.aovs = true;
        o.spp = RESUME_AT;
        o.threads = 8;
        o.checkpoint_path = tmp_path("det.ckpt");
        CHECK(render_to(sc, &o, tmp_path("partial.exr"), NULL));
        spc_checkpoint *c = NULL;
        CHECK(spc_checkpoint_load(tmp_path("det.ckpt"), &c, &err) == SPC_OK);
        o.checkpoint_path = NULL;
        o.resume = c;
        o.spp = SPP;
        o.threads = 2;
        char out[64];
        snprintf(out, sizeof out, "%s_resumed.exr", integrators[k]);
        CHECK(c && render_to(sc, &o, tmp_path(out), NULL));
        CHECK_MSG(same_file(tmp_path(out), tmp_path(ref)), "%s: resumed render differs", integrators[k]);
        spc_checkpoint_destroy(c);
    }
    CHECK(tested == 3); /* path, ipt and bdpt */
    spc_scene_destroy(sc);
}

/* The driver's items pass by pass (SPECULA_TILE_PASSES=1), tile by tile through the whole batch (0)
 * and through groups of 2 passes (6 passes: a batch of 1, then of 5 in groups of 2, 2 and 1): the
 * same image for 1 and 8 threads, with bdpt's splats onto other tiles' pixels. */
TEST(item_order)
{
    spc_define defs[2] = {{"res", "40"}, {"max_depth", "6"}};
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_scene_load(scene_path, defs, 2, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    const char *integrators[] = {"path", "bdpt"};
    const char *orders[] = {"1", "0", "2"};
    for (int k = 0; k < 2; ++k)
        for (int g = 0; g < 3; ++g)
            for (int t = 0; t < 2; ++t) {
                setenv("SPECULA_TILE_PASSES", orders[g], 1);
                spc_render_options o;
                spc_render_options_init(&o);
                o.integrator = integrators[k];
                o.spp = SPP;
                o.seed = 7;
                o.threads = t == 0 ? 1 : 8;
                o.aovs = true;
                char out[64];
                snprintf(out, sizeof out, "order_%s_%s_%d.exr", integrators[k], orders[g], o.threads);
                CHECK_MSG(render_to(sc, &o, tmp_path(out), NULL), "%s", out);
                char ref[64];
                snprintf(ref, sizeof ref, "order_%s_1_1.exr", integrators[k]);
                if (g > 0 || t > 0)
                    CHECK_MSG(same_file(tmp_path(out), tmp_path(ref)), "%s: items in order %s with %d threads differ",
                              integrators[k], orders[g], o.threads);
            }
    unsetenv("SPECULA_TILE_PASSES");
    spc_scene_destroy(sc);
}

/* Different seeds do give different images (the comparisons above could not pass vacuously). */
TEST(seeds_differ)
{
    spc_define defs[1] = {{"res", "16"}};
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_scene_load(scene_path, defs, 1, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 2;
    o.seed = 1;
    CHECK(render_to(sc, &o, tmp_path("s1.exr"), NULL));
    o.seed = 2;
    CHECK(render_to(sc, &o, tmp_path("s2.exr"), NULL));
    CHECK(!same_file(tmp_path("s1.exr"), tmp_path("s2.exr")));
    spc_scene_destroy(sc);
}

int main(void)
{
    char cwd[1024];
    if (!getcwd(cwd, sizeof cwd))
        return 1;
    const char *src = spc_test_source_dir();
    snprintf(scene_path, sizeof scene_path, "%s%s%s/scenes/demo.xml", src[0] == '/' ? "" : cwd,
             src[0] == '/' ? "" : "/", src);
    snprintf(tmpdir, sizeof tmpdir, "/tmp/spc_determinism_XXXXXX");
    if (!mkdtemp(tmpdir))
        return 1;
    RUN(threads_and_resume);
    RUN(item_order);
    RUN(seeds_differ);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", tmpdir);
    if (system(cmd) != 0)
        printf("could not remove %s\n", tmpdir);
    return spc_test_finish();
}
