/*
 * tests/test_checkpoint.c: checkpoints and interruption.
 *
 * The claim under test: a render killed at any moment (SIGKILL, so nothing gets to clean up) and
 * resumed from its last checkpoint ends, at the same spp, with an image BIT-IDENTICAL to an
 * uninterrupted render of the same seed, whatever the thread counts of the pieces. The `specula`
 * binary ($SPC_BINARY_DIR/specula) is run as a child process and killed after random delays drawn
 * from a fixed-seed generator; resumes are killed too. Also: SIGINT gives exit 130 and an EXR whose
 * "spp" attribute is below the target and whose pixels equal an in-process render at that spp;
 * corrupt, truncated, foreign-scene, foreign-settings and foreign-version checkpoints are refused
 * with clear messages, also when only a file the scene references (an OBJ, an include) changed;
 * an in-process cancel stops at a pass boundary.
 */
/* ctest-labels: scene */
/* ctest-timeout: 600 */
#include <errno.h>
#include <fcntl.h>
#include <openexr.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include <zlib.h>

#include "cli_util.h"
#include "harness.h"
#include "specula/specula.h"

#define N_SPP 384        /* target of the killed renders: long enough to be killed mid-way */
#define KILL_TRIALS 5    /* independent kill / resume sequences */
#define MAX_PIECES 12    /* starts + resumes in one sequence before giving up on killing it */

static char scene[2048];
static uint64_t rng_state = 0x9e3779b97f4a7c15ull; /* fixed: the kill delays are reproducible */

static uint32_t rnd(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (uint32_t)(rng_state >> 33);
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void sleep_ms(double ms)
{
    struct timespec ts = {(time_t)(ms / 1000.0), (long)(fmod(ms, 1000.0) * 1e6)};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
        ;
}

static void show_err(void)
{
    char *e = read_text("err.txt");
    printf("  --- stderr:\n%s  ---\n", e ? e : "(none)\n");
    free(e);
}

static bool err_contains(const char *what)
{
    char *e = read_text("err.txt");
    bool ok = e && strstr(e, what);
    free(e);
    return ok;
}

/* Both images exist, have the same size and the same bits in RGB and variance. */
static bool same_bits(const char *a, const char *b)
{
    spc_image_rgb ia, ib;
    memset(&ia, 0, sizeof ia);
    memset(&ib, 0, sizeof ib);
    spc_error err;
    bool ok = spc_image_rgb_read(a, &ia, &err) == SPC_OK && spc_image_rgb_read(b, &ib, &err) == SPC_OK &&
              ia.width == ib.width && ia.height == ib.height && ia.variance && ib.variance;
    size_t n = ok ? 3 * (size_t)ia.width * (size_t)ia.height * sizeof(float) : 0;
    ok = ok && memcmp(ia.rgb, ib.rgb, n) == 0 && memcmp(ia.variance, ib.variance, n) == 0;
    spc_image_rgb_release(&ia);
    spc_image_rgb_release(&ib);
    return ok;
}

/* The "spp" string attribute of an EXR, or -1. */
static int exr_spp(const char *path)
{
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    if (exr_start_read(&ctx, path, &init) != EXR_ERR_SUCCESS)
        return -1;
    const char *s = NULL;
    int32_t len = 0;
    int spp = -1;
    if (exr_attr_get_string(ctx, 0, "spp", &len, &s) == EXR_ERR_SUCCESS && s)
        spp = atoi(s);
    exr_finish(&ctx);
    return spp;
}

static int ckpt_spp(const char *path)
{
    spc_checkpoint *c = NULL;
    spc_error err;
    if (spc_checkpoint_load(path, &c, &err) != SPC_OK)
        return -1;
    spc_checkpoint_info info;
    spc_checkpoint_get_info(c, &info);
    int spp = info.spp_done;
    spc_checkpoint_destroy(c);
    return spp;
}

/* An in-process render of the demo at res 16 with this seed and spp, written with variance. */
static bool render_here(const char *scene_file, int spp, uint64_t seed, int threads, const char *out)
{
    spc_define defs[1] = {{"res", "16"}};
    spc_scene *sc = NULL;
    spc_film *film = NULL;
    spc_error err;
    if (spc_scene_load(scene_file, defs, 1, &sc, &err) != SPC_OK)
        return false;
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp;
    o.seed = seed;
    o.threads = threads;
    bool ok = spc_render(sc, &o, &film, NULL, &err) == SPC_OK && spc_film_write_exr(film, out, true, &err) == SPC_OK;
    spc_film_destroy(film);
    spc_scene_destroy(sc);
    return ok;
}

/* ---- the kill test ---- */

TEST(killed_and_resumed_is_bit_identical)
{
    const char *ref_args[] = {"render", scene, "-D", "res=16", "--spp", "384", "--seed", "7", "--variance",
                              "--quiet", "-o", "ref.exr", NULL};
    double t0 = now_s();
    int rc = run_v(ref_args);
    double t_full = now_s() - t0; /* only to place the kills inside the render, never asserted */
    CHECK_MSG(rc == 0, "reference render exit %d", rc);
    if (rc != 0) {
        show_err();
        return;
    }
    /* the CLI's uninterrupted image equals the library's */
    CHECK(render_here(scene, N_SPP, 7, 1, tmp_path("lib.exr")));
    CHECK(same_bits(tmp_path("lib.exr"), tmp_path("ref.exr")));

    int partial_resumes = 0, kills = 0;
    for (int trial = 0; trial < KILL_TRIALS; ++trial) {
        char ck[64], out[64];
        snprintf(ck, sizeof ck, "k%d.ckpt", trial);
        snprintf(out, sizeof out, "k%d.exr", trial);
        const char *start[] = {"render", scene,   "-D",           "res=16",   "--spp", "384", "--seed", "7",
                               "--variance", "--quiet", "--threads", "2", "-o", out, "--checkpoint", ck,
                               "--checkpoint-every", "0.02", NULL};
        const char *resume1[] = {"render", "--resume", ck, "--threads", "1", "--quiet", NULL};
        const char *resume3[] = {"render", "--resume", ck, "--threads", "3", "--quiet", NULL};
        bool finished = false;
        for (int piece = 0; piece < MAX_PIECES && !finished; ++piece) {
            bool have_ckpt = access(tmp_path(ck), F_OK) == 0;
            const char *const *args = !have_ckpt ? start : (piece % 2 ? resume1 : resume3);
            int before = have_ckpt ? ckpt_spp(tmp_path(ck)) : 0;
            CHECK_MSG(!have_ckpt || before >= 0, "trial %d: checkpoint unreadable after a kill", trial);
            pid_t pid = spawn_v(args);
            /* the last pieces run to the end */
            if (piece < MAX_PIECES - 2) {
                double ms = (0.1 + 0.8 * (rnd() / 4294967296.0)) * t_full * 1000.0;
                sleep_ms(ms);
                kill(pid, SIGKILL);
            }
            rc = wait_code(pid);
            if (rc == 128 + SIGKILL) {
                ++kills;
                if (have_ckpt && before > 0 && before < N_SPP)
                    ++partial_resumes; /* a resume that itself got killed still resumed */
                continue;
            }
            CHECK_MSG(rc == 0, "trial %d piece %d: exit %d", trial, piece, rc);
            if (rc != 0) {
                show_err();
                break;
            }
            if (have_ckpt && before > 0 && before < N_SPP)
                ++partial_resumes;
            finished = true;
        }
        CHECK_MSG(finished, "trial %d never finished", trial);
        if (!finished)
            continue;
        CHECK_MSG(same_bits(tmp_path(out), tmp_path("ref.exr")), "trial %d: resumed image differs", trial);
        CHECK(exr_spp(tmp_path(out)) == N_SPP);
        CHECK(ckpt_spp(tmp_path(ck)) == N_SPP);
    }
    printf("  %d kills, %d resumes from a partial checkpoint\n", kills, partial_resumes);
    CHECK(kills > 0);
    CHECK(partial_resumes > 0);
}

/* ---- SIGINT ---- */

TEST(sigint_writes_partial_image_and_checkpoint)
{
    const char *args[] = {"render", scene, "-D", "res=16", "--spp", "100000", "--seed", "3", "--variance",
                          "--quiet", "-o", "int.exr", "--checkpoint", "int.ckpt", "--checkpoint-every", "0.05",
                          "--stats", "int.json", NULL};
    remove(tmp_path("int.ckpt"));
    pid_t pid = spawn_v(args);
    /* interrupted soon after its first checkpoint: a render of a few hundred passes at most, so
     * the bit-for-bit comparison below always runs and stays short */
    for (int waited = 0; waited < 20000 && access(tmp_path("int.ckpt"), F_OK) != 0; waited += 10)
        sleep_ms(10);
    sleep_ms(100);
    kill(pid, SIGINT);
    int rc = wait_code(pid);
    CHECK_MSG(rc == 130, "exit %d after SIGINT", rc);
    int spp = exr_spp(tmp_path("int.exr"));
    CHECK_MSG(spp > 0 && spp < 100000, "spp attribute %d", spp);
    CHECK(ckpt_spp(tmp_path("int.ckpt")) == spp);
    char *json = read_text("int.json");
    CHECK(json && strstr(json, "\"interrupted\": true") && strstr(json, "\"invalid_samples\": 0"));
    free(json);
    /* the partial image is exactly the render at that many passes */
    CHECK(render_here(scene, spp, 3, 2, tmp_path("int_lib.exr")));
    CHECK(same_bits(tmp_path("int.exr"), tmp_path("int_lib.exr")));
    /* and resuming it to a smaller target than 100000 is allowed; to its own spp it writes it again */
    char sppbuf[32];
    snprintf(sppbuf, sizeof sppbuf, "%d", spp + 5);
    const char *res_args[] = {"render", "--resume", "int.ckpt", "--spp", sppbuf, "-o", "int2.exr", "--quiet", NULL};
    rc = run_v(res_args);
    CHECK_MSG(rc == 0, "resume exit %d", rc);
    CHECK(exr_spp(tmp_path("int2.exr")) == spp + 5);
    CHECK(render_here(scene, spp + 5, 3, 1, tmp_path("int2_lib.exr")));
    CHECK(same_bits(tmp_path("int2.exr"), tmp_path("int2_lib.exr")));
}

/* A second SIGINT ends the process at once (default action), whatever it is doing: writing the
 * image, the PNG or a checkpoint. Every file left behind is whole: atomic writes. */
TEST(second_sigint_corrupts_nothing)
{
    for (int trial = 0; trial < 6; ++trial) {
        char out[32], ck[32];
        snprintf(out, sizeof out, "twice%d.exr", trial);
        snprintf(ck, sizeof ck, "twice%d.ckpt", trial);
        const char *args[] = {"render", scene, "-D", "res=16", "--spp", "100000", "--quiet", "--variance", "-o", out,
                              "--checkpoint", ck, "--checkpoint-every", "0", NULL};
        pid_t pid = spawn_v(args);
        sleep_ms(300 + 40 * trial);
        kill(pid, SIGINT);
        sleep_ms(trial % 3); /* 0-2 ms: during the last passes or the writes */
        kill(pid, SIGINT);
        int rc = wait_code(pid);
        CHECK_MSG(rc == 130, "trial %d: exit %d", trial, rc);
        if (access(tmp_path(ck), F_OK) == 0)
            CHECK_MSG(ckpt_spp(tmp_path(ck)) > 0, "trial %d: checkpoint unreadable", trial);
        if (access(tmp_path(out), F_OK) == 0)
            CHECK_MSG(exr_spp(tmp_path(out)) > 0, "trial %d: image unreadable", trial);
    }
}

/* ---- refusals ---- */

static bool copy_file(const char *from, const char *to)
{
    FILE *a = fopen(from, "rb"), *b = fopen(to, "wb");
    bool ok = a && b;
    char buf[65536];
    for (size_t n; ok && (n = fread(buf, 1, sizeof buf, a)) > 0;)
        ok = fwrite(buf, 1, n, b) == n;
    if (a)
        fclose(a);
    if (b && fclose(b) != 0)
        ok = false;
    return ok;
}

static long file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (long)st.st_size : -1;
}

static unsigned char *slurp(const char *path, long *size)
{
    *size = file_size(path);
    FILE *fp = fopen(path, "rb");
    unsigned char *b = *size > 0 && fp ? malloc((size_t)*size) : NULL;
    if (b && fread(b, 1, (size_t)*size, fp) != (size_t)*size) {
        free(b);
        b = NULL;
    }
    if (fp)
        fclose(fp);
    return b;
}

static bool spit(const char *path, const unsigned char *b, long size)
{
    FILE *fp = fopen(path, "wb");
    bool ok = fp && fwrite(b, 1, (size_t)size, fp) == (size_t)size;
    return fp && fclose(fp) == 0 && ok;
}

/* A checkpoint of the demo copy "own.xml" at 16 spp. */
static bool make_checkpoint(const char *name)
{
    const char *args[] = {"render", "own.xml", "-D", "res=16", "--spp", "16", "--quiet", "-o", "own.exr",
                          "--checkpoint", name, NULL};
    return run_v(args) == 0 && access(tmp_path(name), F_OK) == 0;
}

static spc_status load_status(const char *path, char *msg, size_t size)
{
    spc_checkpoint *c = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = spc_checkpoint_load(path, &c, &err);
    spc_error_format(&err, msg, (int)size);
    CHECK(st == SPC_OK ? c != NULL : c == NULL);
    spc_checkpoint_destroy(c);
    return st;
}

TEST(corrupt_checkpoints_refused)
{
    CHECK(copy_file(scene, tmp_path("own.xml")));
    CHECK(make_checkpoint("good.ckpt"));
    long size = 0;
    unsigned char *b = slurp(tmp_path("good.ckpt"), &size);
    CHECK(b && size > 200);
    if (!b)
        return;
    char msg[2048];
    CHECK(load_status(tmp_path("good.ckpt"), msg, sizeof msg) == SPC_OK);
    /* one flipped bit anywhere: header, text, sums, checksum */
    const long where[] = {0, 9, 30, 45, 70, 99, 120, size / 2, size - 5, size - 1};
    for (size_t k = 0; k < sizeof where / sizeof where[0]; ++k) {
        b[where[k]] ^= 0x10;
        CHECK(spit(tmp_path("bad.ckpt"), b, size));
        b[where[k]] ^= 0x10;
        spc_status st = load_status(tmp_path("bad.ckpt"), msg, sizeof msg);
        CHECK_MSG(st == SPC_ERR_PARSE || st == SPC_ERR_VALUE, "bit flip at %ld: %s", where[k], spc_status_name(st));
    }
    /* torn: every kind of truncation, and an appended tail */
    const long cut[] = {0, 7, 50, 100, size / 3, size - 4, size - 1};
    for (size_t k = 0; k < sizeof cut / sizeof cut[0]; ++k) {
        CHECK(spit(tmp_path("bad.ckpt"), b, cut[k]));
        CHECK_MSG(load_status(tmp_path("bad.ckpt"), msg, sizeof msg) == SPC_ERR_PARSE, "cut at %ld", cut[k]);
    }
    unsigned char *longer = malloc((size_t)size + 8);
    memcpy(longer, b, (size_t)size);
    memset(longer + size, 0, 8);
    CHECK(spit(tmp_path("bad.ckpt"), longer, size + 8));
    CHECK(load_status(tmp_path("bad.ckpt"), msg, sizeof msg) == SPC_ERR_PARSE);
    free(longer);
    CHECK(load_status(tmp_path("missing.ckpt"), msg, sizeof msg) == SPC_ERR_IO);

    /* the command line says so and writes nothing */
    b[size / 2] ^= 1;
    CHECK(spit(tmp_path("bad.ckpt"), b, size));
    const char *args[] = {"render", "--resume", "bad.ckpt", "-o", "bad.exr", "--quiet", NULL};
    int rc = run_v(args);
    CHECK_MSG(rc == SPC_ERR_PARSE, "exit %d", rc);
    CHECK(err_contains("bad.ckpt: not a usable checkpoint (checksum mismatch)"));
    CHECK(access(tmp_path("bad.exr"), F_OK) != 0);
    free(b);
}

TEST(other_version_refused)
{
    CHECK(make_checkpoint("ver.ckpt"));
    long size = 0;
    unsigned char *b = slurp(tmp_path("ver.ckpt"), &size);
    if (!b)
        return;
    /* version at offset 12 (16 bytes), CRC-32 of everything before the last 4 bytes */
    memset(b + 12, 0, 16);
    memcpy(b + 12, "0.0.1", 5);
    uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), b, (uInt)(size - 4));
    for (int i = 0; i < 4; ++i)
        b[size - 4 + i] = (unsigned char)(crc >> (8 * i));
    CHECK(spit(tmp_path("ver.ckpt"), b, size));
    free(b);
    char msg[2048];
    CHECK(load_status(tmp_path("ver.ckpt"), msg, sizeof msg) == SPC_ERR_VALUE);
    CHECK_MSG(strstr(msg, "written by specula 0.0.1") != NULL, "%s", msg);
    const char *args[] = {"render", "--resume", "ver.ckpt", "--quiet", NULL};
    CHECK(run_v(args) == SPC_ERR_VALUE);
    CHECK(err_contains("written by specula 0.0.1"));
}

TEST(other_scene_refused)
{
    CHECK(copy_file(scene, tmp_path("own.xml")));
    CHECK(make_checkpoint("scene.ckpt"));
    /* the scene file changes: one light's colour */
    long size = 0;
    unsigned char *x = slurp(tmp_path("own.xml"), &size);
    CHECK(x != NULL);
    if (!x)
        return;
    char *p = strstr((char *)x, "153, 108, 36");
    CHECK(p != NULL);
    if (p)
        p[11] = '7';
    CHECK(spit(tmp_path("own.xml"), x, size));
    free(x);
    const char *args[] = {"render", "--resume", "scene.ckpt", "-o", "scene.exr", "--quiet", NULL};
    CHECK(run_v(args) == SPC_ERR_VALUE);
    CHECK(err_contains("belongs to another scene"));
    CHECK(access(tmp_path("scene.exr"), F_OK) != 0);

    /* through the API: another scene, other defines, other settings */
    spc_checkpoint *c = NULL;
    spc_error err;
    CHECK(spc_checkpoint_load(tmp_path("scene.ckpt"), &c, &err) == SPC_OK);
    spc_define d16[1] = {{"res", "16"}}, d16b[2] = {{"res", "16"}, {"spp", "8"}};
    spc_scene *orig = NULL, *other = NULL;
    CHECK(copy_file(scene, tmp_path("own.xml")));
    CHECK(spc_scene_load(tmp_path("own.xml"), d16, 1, &orig, &err) == SPC_OK);
    CHECK(spc_scene_load(tmp_path("own.xml"), d16b, 2, &other, &err) == SPC_OK);
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 20;
    o.resume = c;
    spc_film *film = NULL;
    if (orig && other && c) {
        CHECK(spc_render(other, &o, &film, NULL, &err) == SPC_ERR_VALUE && !film);
        CHECK(strstr(err.msg, "another scene") != NULL);
        o.seed = 5;
        CHECK(spc_render(orig, &o, &film, NULL, &err) == SPC_ERR_VALUE && !film);
        CHECK_MSG(strstr(err.msg, "seed=5 now, seed=0 in the checkpoint") != NULL, "%s", err.msg);
        o.seed = 0;
        o.max_depth = 3;
        CHECK(spc_render(orig, &o, &film, NULL, &err) == SPC_ERR_VALUE && !film);
        CHECK_MSG(strstr(err.msg, "max_depth=3 now") != NULL, "%s", err.msg);
        o.max_depth = 0;
        o.aovs = true;
        CHECK(spc_render(orig, &o, &film, NULL, &err) == SPC_ERR_VALUE && !film);
        o.aovs = false;
        spc_render_stats st;
        CHECK(spc_render(orig, &o, &film, &st, &err) == SPC_OK && film && st.spp == 20);
    }
    spc_film_destroy(film);
    spc_scene_destroy(orig);
    spc_scene_destroy(other);
    spc_checkpoint_destroy(c);

    /* options that the checkpoint fixes cannot be changed on --resume */
    CHECK(make_checkpoint("fixed.ckpt"));
    const char *bad1[] = {"render", "--resume", "fixed.ckpt", "--seed", "2", NULL};
    CHECK(run_v(bad1) == 64 /* a bad command line */);
    const char *bad2[] = {"render", "--resume", "fixed.ckpt", "own.xml", NULL};
    CHECK(run_v(bad2) == 64);
}

/* A floor read from floor.obj, lit by a rectangle light from an included light.xml; bdpt. */
static const char *mesh_scene =
    "<scene version=\"3.0.0\">\n"
    "  <integrator type=\"bdpt\"><integer name=\"max_depth\" value=\"3\"/></integrator>\n"
    "  <sensor type=\"perspective\">\n"
    "    <float name=\"fov\" value=\"45\"/>\n"
    "    <transform name=\"to_world\"><lookat origin=\"0, 0, 4\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>\n"
    "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"12\"/><integer name=\"height\" value=\"12\"/>"
    "<rfilter type=\"box\"/></film>\n"
    "  </sensor>\n"
    "  <shape type=\"obj\"><string name=\"filename\" value=\"floor.obj\"/>\n"
    "    <bsdf type=\"diffuse\"/></shape>\n"
    "  <include filename=\"light.xml\"/>\n"
    "</scene>\n";

static const char *mesh_light =
    "<scene version=\"3.0.0\">\n"
    "  <shape type=\"rectangle\">\n"
    "    <transform name=\"to_world\"><scale x=\"0.3\" y=\"0.3\" z=\"0.3\"/><rotate x=\"1\" angle=\"180\"/>"
    "<translate z=\"2\"/></transform>\n"
    "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"5, 5, 5\"/></emitter>\n"
    "  </shape>\n"
    "</scene>\n";

static const char *floor_obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n";

static bool put_text(const char *name, const char *text)
{
    return spit(tmp_path(name), (const unsigned char *)text, (long)strlen(text));
}

/* A checkpoint holds the hash of every file the scene references, not only of the scene file: a
 * mesh, an included file or a texture that changed between checkpoint and resume is refused. */
TEST(referenced_files_refused)
{
    CHECK(put_text("mesh.xml", mesh_scene) && put_text("light.xml", mesh_light) && put_text("floor.obj", floor_obj));
    const char *start[] = {"render", "mesh.xml", "--spp", "4", "--quiet", "-o", "mesh.exr", "--checkpoint",
                           "mesh.ckpt", NULL};
    int rc = run_v(start);
    CHECK_MSG(rc == 0, "exit %d", rc);
    if (rc != 0) {
        show_err();
        return;
    }
    /* the same bytes written again (a new modification time) are the same scene */
    CHECK(put_text("floor.obj", floor_obj));
    const char *resume[] = {"render", "--resume", "mesh.ckpt", "--spp", "6", "--quiet", NULL};
    rc = run_v(resume);
    CHECK_MSG(rc == 0, "resume of an unchanged scene: exit %d", rc);
    if (rc != 0)
        show_err();
    CHECK(ckpt_spp(tmp_path("mesh.ckpt")) == 6);
    long before = file_size(tmp_path("mesh.exr"));

    /* one vertex of the OBJ moves: refused, exit 3, nothing written */
    CHECK(copy_file(tmp_path("mesh.exr"), tmp_path("mesh_kept.exr")));
    CHECK(put_text("floor.obj", "v -1 -1 0\nv 1 -1 0\nv 1 1 0.01\nv -1 1 0\nf 1 2 3\nf 1 3 4\n"));
    const char *resume8[] = {"render", "--resume", "mesh.ckpt", "--spp", "8", "--quiet", NULL};
    rc = run_v(resume8);
    CHECK_MSG(rc == SPC_ERR_VALUE, "resume after the mesh changed: exit %d", rc);
    CHECK(err_contains("belongs to another scene"));
    CHECK(err_contains("a file it references (mesh"));
    CHECK(ckpt_spp(tmp_path("mesh.ckpt")) == 6);
    long sa = 0, sb = 0;
    unsigned char *a = slurp(tmp_path("mesh.exr"), &sa), *b = slurp(tmp_path("mesh_kept.exr"), &sb);
    CHECK(a && b && sa == before && sa == sb && memcmp(a, b, (size_t)sa) == 0);
    free(a);
    free(b);

    /* the OBJ back as it was, the included file changes: refused too */
    CHECK(put_text("floor.obj", floor_obj));
    char *light = strdup(mesh_light);
    char *v = light ? strstr(light, "5, 5, 5") : NULL;
    CHECK(v != NULL);
    if (v)
        v[0] = '6';
    CHECK(light && put_text("light.xml", light));
    free(light);
    rc = run_v(resume8);
    CHECK_MSG(rc == SPC_ERR_VALUE, "resume after the included file changed: exit %d", rc);
    CHECK(err_contains("belongs to another scene"));
    /* and both as they were: accepted again */
    CHECK(put_text("light.xml", mesh_light));
    rc = run_v(resume8);
    CHECK_MSG(rc == 0, "exit %d", rc);
    CHECK(ckpt_spp(tmp_path("mesh.ckpt")) == 8);

    /* a bitmap texture: two PNGs specula wrote (the previews of two renders) take turns */
    const char *other[] = {"render", "mesh.xml", "--spp", "1", "--seed", "9", "--quiet", "-o", "other.exr", NULL};
    CHECK(run_v(other) == 0);
    long sp = 0, so = 0;
    unsigned char *png = slurp(tmp_path("mesh.png"), &sp), *png2 = slurp(tmp_path("other.png"), &so);
    CHECK_MSG(png && png2 && (sp != so || memcmp(png, png2, (size_t)sp) != 0), "the two PNGs are the same");
    char *xml = strdup(mesh_scene);
    char *bsdf = xml ? strstr(xml, "<bsdf type=\"diffuse\"/>") : NULL;
    CHECK(bsdf != NULL);
    if (png && png2 && bsdf) {
        *bsdf = '\0';
        char textured[4096];
        snprintf(textured, sizeof textured,
                 "%s<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
                 "<string name=\"filename\" value=\"tex.png\"/></texture></bsdf>%s",
                 xml, bsdf + strlen("<bsdf type=\"diffuse\"/>"));
        CHECK(put_text("tex.xml", textured) && spit(tmp_path("tex.png"), png, sp));
        const char *tstart[] = {"render", "tex.xml", "--spp", "2", "--quiet", "-o", "tex.exr", "--checkpoint",
                                "tex.ckpt", NULL};
        rc = run_v(tstart);
        CHECK_MSG(rc == 0, "textured scene: exit %d", rc);
        if (rc != 0)
            show_err();
        CHECK(spit(tmp_path("tex.png"), png2, so));
        const char *tresume[] = {"render", "--resume", "tex.ckpt", "--spp", "4", "--quiet", NULL};
        rc = run_v(tresume);
        CHECK_MSG(rc == SPC_ERR_VALUE, "resume after the texture changed: exit %d", rc);
        CHECK(err_contains("belongs to another scene"));
        CHECK(spit(tmp_path("tex.png"), png, sp));
        rc = run_v(tresume);
        CHECK_MSG(rc == 0, "resume with the texture restored: exit %d", rc);
        CHECK(ckpt_spp(tmp_path("tex.ckpt")) == 4);
    }
    free(xml);
    free(png);
    free(png2);
}

/* Settings that change pixel values are recorded, and a resume with another value is refused. */
TEST(bdpt_settings_recorded)
{
    CHECK(put_text("mesh.xml", mesh_scene) && put_text("light.xml", mesh_light) && put_text("floor.obj", floor_obj));
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_scene_load(tmp_path("mesh.xml"), NULL, 0, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 3;
    o.mis_balance = true;
    o.checkpoint_path = tmp_path("balance.ckpt");
    spc_film *film = NULL, *full = NULL;
    CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_OK);
    spc_film_destroy(film);
    film = NULL;
    spc_checkpoint *c = NULL;
    CHECK(spc_checkpoint_load(tmp_path("balance.ckpt"), &c, &err) == SPC_OK);
    if (c) {
        spc_checkpoint_info info;
        spc_checkpoint_get_info(c, &info);
        CHECK_MSG(strstr(info.settings, "mis_balance=1;") != NULL, "%s", info.settings);
        CHECK_MSG(strstr(info.settings, "specular_max_chain=2;") != NULL, "%s", info.settings);
        o.checkpoint_path = NULL;
        o.resume = c;
        o.spp = 5;
        o.mis_balance = false; /* the power heuristic now */
        CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_ERR_VALUE && !film);
        CHECK_MSG(strstr(err.msg, "mis_balance=0 now, mis_balance=1 in the checkpoint") != NULL, "%s", err.msg);
        o.mis_balance = true;
        CHECK(spc_render(sc, &o, &film, NULL, &err) == SPC_OK);
        /* equal to an uninterrupted balance-heuristic render */
        o.resume = NULL;
        CHECK(spc_render(sc, &o, &full, NULL, &err) == SPC_OK);
        if (film && full)
            CHECK(memcmp(spc_film_rgb(film), spc_film_rgb(full), 3 * 12 * 12 * sizeof(float)) == 0);
    }
    spc_film_destroy(film);
    spc_film_destroy(full);
    spc_checkpoint_destroy(c);
    spc_scene_destroy(sc);
}

/* ---- in-process: resume through the API, cancel at a pass boundary ---- */

static void *cancel_later(void *arg)
{
    sleep_ms(300);
    *(volatile int *)arg = 1;
    return NULL;
}

TEST(api_resume_and_cancel)
{
    spc_define defs[1] = {{"res", "16"}};
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_scene_load(scene, defs, 1, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    const char *integrators[] = {"path", "ipt"};
    for (int k = 0; k < 2; ++k) {
        spc_render_options o;
        spc_render_options_init(&o);
        o.integrator = integrators[k];
        o.aovs = true;
        o.seed = 11;
        o.threads = 2;
        o.spp = 40;
        spc_film *full = NULL, *half = NULL, *rest = NULL;
        CHECK(spc_render(sc, &o, &full, NULL, &err) == SPC_OK);
        o.spp = 17;
        o.checkpoint_path = tmp_path("api.ckpt");
        o.checkpoint_every = 0.0;
        CHECK(spc_render(sc, &o, &half, NULL, &err) == SPC_OK);
        spc_checkpoint *c = NULL;
        CHECK(spc_checkpoint_load(tmp_path("api.ckpt"), &c, &err) == SPC_OK);
        spc_checkpoint_info info;
        spc_checkpoint_get_info(c, &info);
        CHECK(info.spp_done == 17 && info.spp_target == 17 && info.width == 16);
        CHECK(strstr(info.settings, "seed=11") != NULL);
        o.spp = 40;
        o.threads = 1;
        o.resume = c;
        o.checkpoint_path = NULL;
        spc_render_stats st;
        CHECK(spc_render(sc, &o, &rest, &st, &err) == SPC_OK);
        CHECK(st.spp == 40);
        if (full && rest) {
            size_t n = 3 * (size_t)spc_film_width(full) * (size_t)spc_film_height(full) * sizeof(float);
            CHECK_MSG(memcmp(spc_film_rgb(full), spc_film_rgb(rest), n) == 0, "%s", integrators[k]);
            CHECK(memcmp(spc_film_variance(full), spc_film_variance(rest), n) == 0);
            /* the AOVs travel too: the EXRs are identical byte for byte */
            CHECK(spc_film_write_exr(full, tmp_path("full.exr"), true, &err) == SPC_OK);
            CHECK(spc_film_write_exr(rest, tmp_path("rest.exr"), true, &err) == SPC_OK);
            long sa = 0, sb = 0;
            unsigned char *a = slurp(tmp_path("full.exr"), &sa), *b = slurp(tmp_path("rest.exr"), &sb);
            CHECK(a && b && sa == sb && memcmp(a, b, (size_t)sa) == 0);
            free(a);
            free(b);
        }
        spc_checkpoint_destroy(c);
        spc_film_destroy(full);
        spc_film_destroy(half);
        spc_film_destroy(rest);
    }

    /* cancel from another thread: whole passes only, equal to a render of that many */
    volatile int flag = 0;
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 1 << 20;
    o.seed = 2;
    o.threads = 2;
    o.cancel = &flag;
    o.checkpoint_path = tmp_path("cancel.ckpt");
    pthread_t th;
    spc_film *film = NULL, *again = NULL;
    spc_render_stats st;
    CHECK(pthread_create(&th, NULL, cancel_later, (void *)&flag) == 0);
    spc_status s = spc_render(sc, &o, &film, &st, &err);
    pthread_join(th, NULL);
    CHECK(s == SPC_ERR_INTERRUPTED && film && st.spp > 0 && st.spp < (1 << 20));
    CHECK(ckpt_spp(tmp_path("cancel.ckpt")) == st.spp);
    if (film && st.spp > 0 && st.spp < 20000) {
        o.spp = st.spp;
        o.cancel = NULL;
        o.checkpoint_path = NULL;
        CHECK(spc_render(sc, &o, &again, NULL, &err) == SPC_OK);
        size_t n = 3 * 16 * 16 * sizeof(float);
        CHECK(again && memcmp(spc_film_rgb(film), spc_film_rgb(again), n) == 0);
    }
    spc_film_destroy(film);
    spc_film_destroy(again);
    spc_scene_destroy(sc);
}

/* ---- setup ---- */

int main(void)
{
    if (!cli_init("ckpt"))
        return 1;
    char cwd[1024];
    if (!getcwd(cwd, sizeof cwd))
        return 1;
    const char *src = spc_test_source_dir();
    snprintf(scene, sizeof scene, "%s/%s/scenes/demo.xml", src[0] == '/' ? "" : cwd, src);
    RUN(killed_and_resumed_is_bit_identical);
    RUN(sigint_writes_partial_image_and_checkpoint);
    RUN(second_sigint_corrupts_nothing);
    RUN(corrupt_checkpoints_refused);
    RUN(other_version_refused);
    RUN(other_scene_refused);
    RUN(referenced_files_refused);
    RUN(bdpt_settings_recorded);
    RUN(api_resume_and_cancel);
    return cli_finish(spc_test_finish());
}
