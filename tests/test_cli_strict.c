/*
 * tests/test_cli_strict.c: the `specula` command refuses what it cannot do well, before rendering,
 * and writes only what it should. Run as a child process in a temporary folder, as root (as CI
 * runs: device nodes are made with mknod; a test that cannot make one fails).
 *
 * Outputs: each kind of existing path (regular file replaced atomically; a symbolic link written
 * through to its target; a directory, character device, FIFO and socket refused before rendering,
 * left as they were); a missing folder refused before rendering; the format by the extension
 * (.exr with its PNG preview, .png, .pfm, .hdr read back and compared with the EXR; an unknown
 * extension refused); a final write that fails saves the image under a printed rescue name.
 * Arguments: numbers out of range or overflowing, -D naming no default, an unreferenced property
 * (and --lenient), specular NEE with bdpt/ipt, --specular-nee none with every integrator, volpath
 * from the command line, exit statuses in --help. diff: ratio of means, --max-relmse, --min-pass,
 * the sRGB note. --time: stops within its budget and writes a valid image, with --checkpoint too.
 */
/* ctest-labels: unit */
/* ctest-timeout: 300 */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/types.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <openexr.h>

#include "cli_util.h"
#include "harness.h"
#include "specula/specula.h"

#define EXIT_DIFFER 10 /* diff: beyond --max-relmse or --min-pass */

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
        ;
}

static bool is_exr(const char *name)
{
    size_t n = 0;
    unsigned char *b = read_bytes(name, &n);
    bool ok = b && n > 4 && b[0] == 0x76 && b[1] == 0x2f && b[2] == 0x31 && b[3] == 0x01;
    free(b);
    return ok;
}

static bool is_png(const char *name)
{
    size_t n = 0;
    unsigned char *b = read_bytes(name, &n);
    bool ok = b && n > 8 && !memcmp(b, "\x89PNG\r\n\x1a\n", 8);
    free(b);
    return ok;
}

/* The "spp" attribute of an EXR specula wrote, or -1. */
static int exr_spp(const char *name)
{
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    if (exr_start_read(&ctx, tmp_path(name), &init) != EXR_ERR_SUCCESS)
        return -1;
    const char *s = NULL;
    int32_t len = 0;
    int spp = -1;
    if (exr_attr_get_string(ctx, 0, "spp", &len, &s) == EXR_ERR_SUCCESS && s)
        spp = atoi(s);
    exr_finish(&ctx);
    return spp;
}

/* A rectangle light facing down over a diffuse floor, 16x16; $rad is the light's radiance. */
static const char *tiny_scene =
    "<scene version=\"3.0.0\">\n"
    "  <default name=\"rad\" value=\"5\"/>\n"
    "  <default name=\"res\" value=\"16\"/>\n"
    "  <integrator type=\"path\">\n"
    "    <integer name=\"max_depth\" value=\"4\"/>\n"
    "  </integrator>\n"
    "  <sensor type=\"perspective\">\n"
    "    <float name=\"fov\" value=\"45\"/>\n"
    "    <transform name=\"to_world\">\n"
    "      <lookat origin=\"0, 0, 4\" target=\"0, 0, 0\" up=\"0, 1, 0\"/>\n"
    "    </transform>\n"
    "    <sampler type=\"independent\">\n"
    "      <integer name=\"sample_count\" value=\"4\"/>\n"
    "    </sampler>\n"
    "    <film type=\"hdrfilm\">\n"
    "      <integer name=\"width\" value=\"$res\"/>\n"
    "      <integer name=\"height\" value=\"$res\"/>\n"
    "    </film>\n"
    "  </sensor>\n"
    "  <shape type=\"rectangle\">\n"
    "    <bsdf type=\"diffuse\">\n"
    "      <rgb name=\"reflectance\" value=\"0.5, 0.5, 0.5\"/>\n"
    "    </bsdf>\n"
    "  </shape>\n"
    "  <shape type=\"sphere\">\n"
    "    <point name=\"center\" value=\"0.4, 0.3, 0.5\"/>\n"
    "    <float name=\"radius\" value=\"0.3\"/>\n"
    "    <bsdf type=\"dielectric\"/>\n"
    "  </shape>\n"
    "  <shape type=\"rectangle\">\n"
    "    <transform name=\"to_world\">\n"
    "      <scale x=\"0.3\" y=\"0.3\" z=\"0.3\"/>\n"
    "      <rotate x=\"1\" angle=\"180\"/>\n"
    "      <translate x=\"0\" y=\"0\" z=\"2\"/>\n"
    "    </transform>\n"
    "    <emitter type=\"area\">\n"
    "      <rgb name=\"radiance\" value=\"$rad\"/>\n"
    "    </emitter>\n"
    "  </shape>\n"
    "</scene>\n";

/* ---- outputs ---- */

/* Each kind of path that is not a regular file is refused before rendering (--spp 10^7 would run
 * for hours) and left as it was; nothing is written beside it. */
TEST(refuses_non_files_before_rendering)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    CHECK(mkdir(tmp_path("sub"), 0755) == 0);

    /* a character device (the null device's numbers), a FIFO, a socket, a directory */
    int mk = mknod(tmp_path("dev.exr"), S_IFCHR | 0666, makedev(1, 3));
    CHECK_MSG(mk == 0, "mknod failed (%s): this test runs as root, as CI does", strerror(errno));
    CHECK(mkfifo(tmp_path("fifo.exr"), 0644) == 0);
    int sock = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un addr;
    memset(&addr, 0, sizeof addr);
    addr.sun_family = AF_UNIX;
    snprintf(addr.sun_path, sizeof addr.sun_path, "%s", tmp_path("sock.exr"));
    CHECK(sock >= 0 && bind(sock, (struct sockaddr *)&addr, sizeof addr) == 0);
    CHECK(mkdir(tmp_path("dir.exr"), 0755) == 0);
    CHECK(symlink("dev.exr", tmp_path("to_dev.exr")) == 0);
    CHECK(symlink("dir.exr", tmp_path("to_dir.png")) == 0);

    static const struct {
        const char *out, *says;
        mode_t kind;
    } cases[] = {
        {"dev.exr", "is a character device", S_IFCHR},  {"fifo.exr", "is a FIFO", S_IFIFO},
        {"sock.exr", "is a socket", S_IFSOCK},          {"dir.exr", "is a directory", S_IFDIR},
        {"to_dev.exr", "target of the symbolic link", S_IFLNK}, {"to_dir.png", "is a directory", S_IFLNK},
        {"sub", "is a directory", S_IFDIR},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        double t0 = now_s();
        int rc = run("render", "tiny.xml", "-o", cases[k].out, "--spp", "10000000", "--quiet", NULL);
        CHECK_MSG(rc == SPC_ERR_IO, "%s: exit %d", cases[k].out, rc);
        CHECK(err_has(cases[k].says));
        CHECK_MSG(now_s() - t0 < 30.0, "%s: refused only after %.1f s", cases[k].out, now_s() - t0);
        struct stat st;
        CHECK(lstat(tmp_path(cases[k].out), &st) == 0 && (st.st_mode & S_IFMT) == cases[k].kind);
    }
    struct stat st;
    CHECK(stat(tmp_path("dev.exr"), &st) == 0 && S_ISCHR(st.st_mode) && st.st_rdev == makedev(1, 3));
    /* no PNG preview beside a refused output, no temporary left */
    CHECK(!exists("dev.png") && !exists("fifo.png") && !exists("sock.png") && !exists("dir.png"));
    CHECK(system("ls -a /dev | grep -q '\\.tmp-'") != 0);
    char cmd[700];
    snprintf(cmd, sizeof cmd, "ls -a %s | grep -q '\\.tmp-'", tmpdir);
    CHECK(system(cmd) != 0);

    /* an EXR beside which the preview would replace a device: refused before rendering too */
    CHECK(mknod(tmp_path("prev.png"), S_IFCHR | 0666, makedev(1, 3)) == 0);
    CHECK(run("render", "tiny.xml", "-o", "prev.exr", "--spp", "10000000", "--quiet", NULL) == SPC_ERR_IO);
    CHECK(err_has("prev.png"));
    CHECK(!exists("prev.exr") && lstat(tmp_path("prev.png"), &st) == 0 && S_ISCHR(st.st_mode));
    /* --stats and --checkpoint are outputs too */
    CHECK(run("render", "tiny.xml", "-o", "s.exr", "--stats", "fifo.exr", "--quiet", NULL) == SPC_ERR_IO);
    CHECK(run("render", "tiny.xml", "-o", "s.exr", "--checkpoint", "dev.exr", "--quiet", NULL) == SPC_ERR_IO);
    CHECK(!exists("s.exr"));
    /* a folder that does not exist, or is a file */
    CHECK(run("render", "tiny.xml", "-o", "nowhere/x.exr", "--spp", "10000000", "--quiet", NULL) == SPC_ERR_IO);
    CHECK(err_has("nowhere"));
    CHECK(write_file("plain", "x"));
    CHECK(run("render", "tiny.xml", "-o", "plain/x.exr", "--spp", "10000000", "--quiet", NULL) == SPC_ERR_IO);
    if (sock >= 0)
        close(sock);
}

/* A regular file is replaced; a symbolic link is written through to its target (relative to the
 * link's folder, dangling or not), atomically in the target's folder; the link stays a link. */
TEST(regular_files_and_symlinks)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    CHECK(mkdir(tmp_path("real"), 0755) == 0 || errno == EEXIST);
    CHECK(write_file("old.exr", "not an image yet\n"));
    CHECK(run("render", "tiny.xml", "-o", "old.exr", "--spp", "1", "--quiet", NULL) == 0);
    CHECK(is_exr("old.exr") && is_png("old.png"));

    CHECK(write_file("real/target.exr", "old contents\n"));
    CHECK(symlink("real/target.exr", tmp_path("link.exr")) == 0);
    CHECK(symlink("real/new.exr", tmp_path("dangling.exr")) == 0);
    CHECK(run("render", "tiny.xml", "-o", "link.exr", "--spp", "1", "--quiet", NULL) == 0);
    CHECK(run("render", "tiny.xml", "-o", "dangling.exr", "--spp", "1", "--quiet", NULL) == 0);
    struct stat st;
    CHECK(lstat(tmp_path("link.exr"), &st) == 0 && S_ISLNK(st.st_mode));
    CHECK(lstat(tmp_path("dangling.exr"), &st) == 0 && S_ISLNK(st.st_mode));
    CHECK(is_exr("real/target.exr") && is_exr("real/new.exr"));
    CHECK(is_png("link.png") && is_png("dangling.png"));
    char cmd[700];
    snprintf(cmd, sizeof cmd, "ls -a %s %s/real | grep -q '\\.tmp-'", tmpdir, tmpdir);
    CHECK(system(cmd) != 0);
    /* a loop of links is refused */
    CHECK(symlink("loop_b.exr", tmp_path("loop_a.exr")) == 0 && symlink("loop_a.exr", tmp_path("loop_b.exr")) == 0);
    CHECK(run("render", "tiny.xml", "-o", "loop_a.exr", "--spp", "1", "--quiet", NULL) == SPC_ERR_IO);
    CHECK(err_has("symbolic links"));
}

static float f32le(const unsigned char *p)
{
    uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
    float f;
    memcpy(&f, &u, 4);
    return f;
}

/* The extension picks the format; PFM and HDR hold the EXR's values (exactly; to RGBE's 8-bit
 * mantissa); an unknown extension, or variance in a PNG, is refused before rendering. */
TEST(format_follows_extension)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    const char *common[] = {"--spp", "2", "--seed", "5", "--quiet"};
    (void)common;
    CHECK(run("render", "tiny.xml", "-o", "f.exr", "--spp", "2", "--seed", "5", "--quiet", NULL) == 0);
    CHECK(run("render", "tiny.xml", "-o", "f1.png", "--spp", "2", "--seed", "5", "--quiet", NULL) == 0);
    CHECK(run("render", "tiny.xml", "-o", "f2.PFM", "--spp", "2", "--seed", "5", "--quiet", NULL) == 0);
    CHECK(run("render", "tiny.xml", "-o", "f3.hdr", "--spp", "2", "--seed", "5", "--quiet", NULL) == 0);
    CHECK(is_exr("f.exr") && is_png("f.png") && is_png("f1.png"));
    CHECK(!exists("f1.png.png") && !exists("f2.png") && !exists("f3.png") && !exists("f2.PFM.png"));
    /* the PNG is the EXR's preview, byte for byte */
    size_t na = 0, nb = 0;
    unsigned char *a = read_bytes("f.png", &na), *b = read_bytes("f1.png", &nb);
    CHECK(a && b && na == nb && !memcmp(a, b, na));
    free(a);
    free(b);

    spc_image_rgb ref;
    spc_error err;
    CHECK(spc_image_rgb_read(tmp_path("f.exr"), &ref, &err) == SPC_OK && ref.width == 16 && ref.height == 16);
    size_t n = 0;
    unsigned char *pfm = read_bytes("f2.PFM", &n);
    const char *hdr = "PF\n16 16\n-1.0\n";
    size_t hl = strlen(hdr);
    CHECK(pfm && n == hl + 16 * 16 * 12 && !memcmp(pfm, hdr, hl));
    int bad = 0;
    double mean = 0.0;
    if (pfm && n == hl + 16 * 16 * 12 && ref.rgb)
        for (int y = 0; y < 16; ++y) /* PFM rows run bottom to top */
            for (int i = 0; i < 16 * 3; ++i) {
                float v = f32le(pfm + hl + 4 * ((size_t)(15 - y) * 48 + (size_t)i));
                bad += v != ref.rgb[(size_t)y * 48 + (size_t)i];
                mean += v;
            }
    CHECK_MSG(bad == 0 && mean > 0.0, "%d PFM values differ from the EXR's", bad);
    free(pfm);

    unsigned char *rgbe = read_bytes("f3.hdr", &n);
    const char *rh = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16 +X 16\n";
    hl = strlen(rh);
    CHECK(rgbe && n == hl + 16 * 16 * 4 && !memcmp(rgbe, rh, hl));
    bad = 0;
    if (rgbe && n == hl + 16 * 16 * 4 && ref.rgb)
        for (size_t p = 0; p < 256; ++p) {
            const unsigned char *q = rgbe + hl + 4 * p;
            double m = 0.0;
            for (int c = 0; c < 3; ++c)
                m = fmax(m, ref.rgb[3 * p + (size_t)c]);
            for (int c = 0; c < 3; ++c) {
                double v = q[3] ? ldexp(q[c] + 0.5, q[3] - 136) : 0.0; /* decoded at the bin's centre */
                bad += fabs(v - ref.rgb[3 * p + (size_t)c]) > m / 128.0 + 1e-30;
            }
        }
    CHECK_MSG(bad == 0, "%d RGBE values further than 1/128 of the pixel's maximum from the EXR's", bad);
    free(rgbe);
    spc_image_rgb_release(&ref);

    /* unknown or missing extensions; channels only EXR holds */
    const char *refused[] = {"f.jpg", "f", "f.exr.txt", "f.tiff"};
    for (size_t k = 0; k < sizeof refused / sizeof refused[0]; ++k) {
        CHECK(run("render", "tiny.xml", "-o", refused[k], "--spp", "10000000", "--quiet", NULL) == EXIT_USAGE);
        CHECK(err_has("unknown image format"));
        CHECK(!exists(refused[k]));
    }
    CHECK(run("render", "tiny.xml", "-o", "v.png", "--variance", "--quiet", NULL) == EXIT_USAGE);
    CHECK(run("render", "tiny.xml", "-o", "v.hdr", "--aovs", "--quiet", NULL) == EXIT_USAGE);
    CHECK(!exists("v.png") && !exists("v.hdr"));
}

/* The output's folder disappears during the render: the image is saved under a printed name. */
TEST(failed_final_write_keeps_the_image)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    CHECK(mkdir(tmp_path("gone"), 0755) == 0);
    remove(tmp_path("r.ckpt"));
    const char *args[] = {"render", "tiny.xml", "-o", "gone/out.exr", "--spp", "10000000", "--checkpoint", "r.ckpt",
                          "--checkpoint-every", "0", "--quiet", NULL};
    pid_t pid = spawn_v(args);
    for (int waited = 0; waited < 20000 && !exists("r.ckpt"); waited += 10)
        sleep_ms(10);
    CHECK(rmdir(tmp_path("gone")) == 0);
    kill(pid, SIGINT);
    int rc = wait_code(pid);
    CHECK_MSG(rc == SPC_ERR_IO, "exit %d", rc);
    char *e = read_text("err.txt");
    const char *at = e ? strstr(e, "saved as ") : NULL;
    CHECK_MSG(at != NULL, "stderr: %s", e ? e : "(none)");
    if (at) {
        char name[600];
        CHECK(sscanf(at + strlen("saved as "), "%599s", name) == 1);
        char full[700];
        snprintf(full, sizeof full, "%s%s", name[0] == '/' ? "" : tmpdir, name[0] == '/' ? name : name + 1);
        spc_image_rgb img;
        spc_error err;
        CHECK_MSG(spc_image_rgb_read(full, &img, &err) == SPC_OK && img.width == 16, "%s: %s", full, err.msg);
        spc_image_rgb_release(&img);
        remove(full);
    }
    free(e);
}

/* ---- arguments ---- */

TEST(numbers_are_range_checked)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    static const char *const bad[][2] = {
        {"--res", "4294967312x4294967312"}, {"--res", "0x16"},      {"--res", "16x-1"},
        {"--res", "16x16x16"},              {"--res", "x16"},       {"--res", "70000x16"},
        {"--spp", "99999999999"},           {"--spp", "0"},         {"--spp", "-4"},
        {"--spp", " 4"},                    {"--seed", "-1"},       {"--seed", " 1"},
        {"--seed", "18446744073709551616"}, {"--time", "1e400"},    {"--time", "nan"},
        {"--time", "0"},                    {"--time", "1e30"},     {"--threads", "5000"},
        {"--max-depth", "-2"},              {"--strategy", "1,99999999999"},
        {"--checkpoint-every", "-1"},       {"--max-depth", "2147483648"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
        int rc = run("render", "tiny.xml", "-o", "n.exr", bad[k][0], bad[k][1], "--quiet", NULL);
        CHECK_MSG(rc == EXIT_USAGE, "%s %s: exit %d", bad[k][0], bad[k][1], rc);
    }
    CHECK(!exists("n.exr"));
    CHECK(run("render", "tiny.xml", "-o", "n.exr", "--res", "8x4", "--seed", "18446744073709551615", "--spp", "1",
              "--quiet", NULL) == 0);
    spc_image_rgb img;
    spc_error err;
    CHECK(spc_image_rgb_read(tmp_path("n.exr"), &img, &err) == SPC_OK && img.width == 8 && img.height == 4);
    spc_image_rgb_release(&img);
    /* numbers in the scene: an integer property beyond int */
    int rc = run("render", "tiny.xml", "-o", "n2.exr", "-D", "res=99999999999", "--quiet", NULL);
    CHECK_MSG(rc == SPC_ERR_LIMIT, "exit %d", rc);
    CHECK(err_has("property 'width': 99999999999 is out of range"));
    CHECK(!exists("n2.exr"));
}

TEST(defines_and_unreferenced_properties)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    int rc = run("render", "tiny.xml", "-o", "d.exr", "-D", "nosuch=3", "--quiet", NULL);
    CHECK_MSG(rc == SPC_ERR_VALUE, "exit %d", rc);
    CHECK(err_has("-D nosuch=3") && err_has("its defaults are: rad, res"));
    CHECK(run("info", "tiny.xml", "-D", "nosuch=3", NULL) == SPC_ERR_VALUE);

    char *typo = malloc(strlen(tiny_scene) + 1);
    CHECK(typo != NULL);
    if (!typo)
        return;
    strcpy(typo, tiny_scene);
    char *r = strstr(typo, "\"radius\"");
    CHECK(r != NULL);
    if (r)
        memcpy(r, "\"radiu\" ", 8); /* same length: one space more */
    CHECK(write_file("typo.xml", typo));
    free(typo);
    rc = run("render", "typo.xml", "-o", "t.exr", "--spp", "1", "--quiet", NULL);
    CHECK_MSG(rc == SPC_ERR_VALUE, "exit %d", rc);
    CHECK(err_has("typo.xml:27:5: unreferenced property 'radiu'") && err_has("did you mean 'radius'?"));
    CHECK(!exists("t.exr"));
    rc = run("render", "typo.xml", "-o", "t.exr", "--spp", "1", "--lenient", "--quiet", NULL);
    CHECK_MSG(rc == 0, "exit %d", rc);
    CHECK(err_has("warning: unreferenced property 'radiu'"));
    CHECK(run("info", "typo.xml", "--lenient", NULL) == 0);
}

/* Specular NEE is refused where it does nothing (ipt); none is accepted by every integrator; volpath
 * and specular NEE run from the command line. */
TEST(integrators_and_specular_nee)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    /* ipt samples every path by its BSDFs alone: specular NEE would do nothing there */
    int rc0 = run("render", "tiny.xml", "-o", "i.exr", "--integrator", "ipt", "--specular-nee", "angular", "--spp", "1",
                  "--quiet", NULL);
    CHECK_MSG(rc0 == SPC_ERR_VALUE, "ipt: exit %d", rc0);
    CHECK(err_has("does nothing"));
    CHECK(!exists("i.exr"));
    /* bdpt uses it at the camera's first vertex seen through glass or mirrors */
    rc0 = run("render", "tiny.xml", "-o", "b.exr", "--integrator", "bdpt", "--specular-nee", "angular", "--spp", "1",
              "--quiet", NULL);
    CHECK_MSG(rc0 == 0 && is_exr("b.exr"), "bdpt --specular-nee angular: exit %d", rc0);
    const char *all[] = {"path", "ipt", "bdpt", "volpath"};
    for (int k = 0; k < 4; ++k) {
        char out[32];
        snprintf(out, sizeof out, "none_%s.exr", all[k]);
        int rc = run("render", "tiny.xml", "-o", out, "--integrator", all[k], "--specular-nee", "none", "--spp", "2",
                     "--quiet", NULL);
        CHECK_MSG(rc == 0 && is_exr(out), "%s --specular-nee none: exit %d", all[k], rc);
    }
    int rc = run("render", "tiny.xml", "-o", "vol_angular.exr", "--integrator", "volpath", "--specular-nee", "angular",
                 "--spp", "2", "--quiet", NULL);
    CHECK_MSG(rc == 0 && is_exr("vol_angular.exr"), "volpath --specular-nee angular: exit %d", rc);
    /* volpath without media agrees with path on the mean (both unbiased; 64 spp of a 16x16 image) */
    CHECK(run("render", "tiny.xml", "-o", "vp.exr", "--integrator", "volpath", "--spp", "64", "--variance", "--quiet",
              NULL) == 0);
    CHECK(run("render", "tiny.xml", "-o", "pp.exr", "--integrator", "path", "--spp", "64", "--variance", "--seed", "9",
              "--quiet", NULL) == 0);
    CHECK(run("diff", "vp.exr", "pp.exr", "--min-pass", "0.99", NULL) == 0);
    CHECK(run("render", "tiny.xml", "--specular-nee", "bogus", "-o", "b.exr", "--quiet", NULL) == SPC_ERR_PLUGIN);
}

TEST(exit_statuses_documented)
{
    CHECK(run("--help", NULL) == 0);
    char *o = read_text("out.txt");
    CHECK(o && strstr(o, "exit status") && strstr(o, "64 bad command line") && strstr(o, "130 interrupted"));
    free(o);
    CHECK(run("render", "--help", NULL) == 0);
    o = read_text("out.txt");
    CHECK(o && strstr(o, "1 I/O error, 2 parse error, 3 unknown") && strstr(o, "--lenient"));
    free(o);
    CHECK(run(NULL) == EXIT_USAGE);
    CHECK(spc_status_name(SPC_ERR_IO) != NULL);
}

/* ---- diff ---- */

TEST(diff_ratio_and_thresholds)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    CHECK(run("render", "tiny.xml", "-o", "one.exr", "--spp", "8", "--seed", "1", "--variance", "--quiet", NULL) == 0);
    CHECK(run("render", "tiny.xml", "-o", "two.exr", "--spp", "8", "--seed", "1", "-D", "rad=10", "--quiet", NULL) ==
          0);
    /* twice the light, the same samples: twice the image */
    CHECK(run("diff", "two.exr", "one.exr", NULL) == 0);
    char *o = read_text("out.txt");
    const char *r = o ? strstr(o, "ratio of means a/b: ") : NULL;
    CHECK_MSG(r && fabs(atof(r + strlen("ratio of means a/b: ")) - 2.0) < 1e-5, "stdout: %s", o ? o : "(none)");
    free(o);
    CHECK(run("diff", "two.exr", "one.exr", "--json", NULL) == 0);
    o = read_text("out.txt");
    r = o ? strstr(o, "\"ratio_mean\": ") : NULL;
    CHECK(r && fabs(atof(r + strlen("\"ratio_mean\": ")) - 2.0) < 1e-5);
    free(o);
    /* thresholds set the exit status */
    CHECK(run("diff", "two.exr", "one.exr", "--max-relmse", "0.01", NULL) == EXIT_DIFFER);
    CHECK(err_has("exceeds --max-relmse"));
    CHECK(run("diff", "two.exr", "one.exr", "--max-relmse", "1000", NULL) == 0);
    CHECK(run("diff", "one.exr", "one.exr", "--max-relmse", "0", "--min-pass", "1", NULL) == 0);
    CHECK(run("diff", "two.exr", "one.exr", "--min-pass", "0.99", NULL) == EXIT_DIFFER);
    CHECK(run("diff", "two.exr", "one.exr", "--min-pass", "1.5", NULL) == EXIT_USAGE);
    CHECK(run("diff", "two.exr", "one.exr", "--max-relmse", "-1", NULL) == EXIT_USAGE);
    /* no variance channel in either: --min-pass cannot be judged */
    CHECK(run("diff", "two.exr", "two.exr", "--min-pass", "0.5", NULL) == SPC_ERR_VALUE);
    /* a PNG is decoded from sRGB, and the comparison says so */
    CHECK(run("diff", "one.png", "one.exr", NULL) == 0);
    CHECK(err_has("note: one.png is 8-bit sRGB"));
    CHECK(run("diff", "one.exr", "one.exr", NULL) == 0);
    char *e = read_text("err.txt");
    CHECK(e && !strstr(e, "note:"));
    free(e);
}

/* ---- --time ---- */

/* The render's own clock (--stats wall_seconds) against the budget: the passes stop in time, at
 * most one batch late. A batch is sized by the passes timed so far, so a machine whose load jumps
 * makes it late: at load 30 one ran 3.2 s past a 1 s budget (1.0-1.03 s when the load is steady),
 * hence the 5 s slack. A render that ignored --time would run for an hour (the spp cap is 10^6).
 * The process's wall time adds loading and writing and is only bounded loosely. */
static double stats_wall(const char *name)
{
    char *j = read_text(name);
    const char *w = j ? strstr(j, "\"wall_seconds\": ") : NULL;
    double v = w ? atof(w + strlen("\"wall_seconds\": ")) : -1.0;
    free(j);
    return v;
}

TEST(time_budget)
{
    CHECK(write_file("tiny.xml", tiny_scene));
    double t0 = now_s();
    /* specular NEE off: its passes (the glass ball under an area light turns it on by default)
     * vary so much in cost that the batch after the timed first pass overran by 7 s */
    int rc = run("render", "tiny.xml", "-o", "t.exr", "--time", "1", "--spp", "1000000", "--variance",
                 "--specular-nee", "none", "--stats", "t.json", "--quiet", NULL);
    double wall = now_s() - t0, rw = stats_wall("t.json");
    CHECK_MSG(rc == 0, "exit %d", rc);
    CHECK_MSG(rw >= 0.9 && rw < 1.0 + 5.0, "--time 1 rendered for %.3f s", rw);
    CHECK_MSG(wall < 60.0, "--time 1 took %.2f s in all", wall);
    int spp = exr_spp("t.exr");
    CHECK_MSG(spp > 4, "spp %d: the time budget, not the scene's 4 spp, decides", spp);
    spc_image_rgb img;
    spc_error err;
    CHECK(spc_image_rgb_read(tmp_path("t.exr"), &img, &err) == SPC_OK && img.variance != NULL);
    bool finite = true;
    for (int i = 0; img.rgb && i < 3 * img.width * img.height; ++i)
        finite = finite && isfinite(img.rgb[i]) && img.rgb[i] >= 0.0f;
    CHECK(finite);
    spc_image_rgb_release(&img);
    /* with --spp as a cap */
    CHECK(run("render", "tiny.xml", "-o", "tc.exr", "--time", "30", "--spp", "3", "--quiet", NULL) == 0);
    CHECK(exr_spp("tc.exr") == 3);
    /* with a checkpoint: it holds what the image holds */
    t0 = now_s();
    rc = run("render", "tiny.xml", "-o", "tk.exr", "--time", "1", "--specular-nee", "none", "--checkpoint", "tk.ckpt",
             "--stats", "tk.json", "--quiet", NULL);
    wall = now_s() - t0;
    rw = stats_wall("tk.json");
    /* the render's clock here includes the final checkpoint's write and fsync */
    CHECK_MSG(rc == 0 && rw >= 0.9 && rw < 1.0 + 6.0 && wall < 60.0, "exit %d after %.2f s (render %.3f s)", rc, wall,
              rw);
    spp = exr_spp("tk.exr");
    spc_checkpoint *ck = NULL;
    CHECK(spc_checkpoint_load(tmp_path("tk.ckpt"), &ck, &err) == SPC_OK);
    if (ck) {
        spc_checkpoint_info info;
        spc_checkpoint_get_info(ck, &info);
        CHECK_MSG(info.spp_done == spp && spp > 4, "checkpoint %d spp, image %d", info.spp_done, spp);
        spc_checkpoint_destroy(ck);
    }
}

int main(void)
{
    if (!cli_init("test_strict")) {
        printf("0 passed, 1 failed\n");
        return 1;
    }
    RUN(refuses_non_files_before_rendering);
    RUN(regular_files_and_symlinks);
    RUN(format_follows_extension);
    RUN(failed_final_write_keeps_the_image);
    RUN(numbers_are_range_checked);
    RUN(defines_and_unreferenced_properties);
    RUN(integrators_and_specular_nee);
    RUN(exit_statuses_documented);
    RUN(diff_ratio_and_thresholds);
    RUN(time_budget);
    int rc = cli_finish(spc_test_finish());
    return rc;
}
