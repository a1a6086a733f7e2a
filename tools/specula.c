/*
 * tools/specula.c: the `specula` command: render a Mitsuba scene, compare two images, describe a
 * scene, serve the solver explorer (tools/explore_server.c). It uses nothing but the public header
 * specula/specula.h, which proves the API suffices.
 *
 * Exit status: 0 success; otherwise the spc_status of the failure (specula.h: 1 I/O, 2 parse,
 * 3 plugin, 4 value, 5 out of memory, 6 limit, 7 Embree, 8 internal), 64 for a bad command line
 * (sysexits' EX_USAGE, which no status uses) and 130 for an interrupted render (128 + SIGINT, as
 * shells report it; the image so far is written). Errors are one line on stderr,
 * "specula: file:line:col: message". Images are written atomically by the library, and never
 * when loading or rendering failed, so an existing image is never replaced by a broken one; only
 * regular files (or a symbolic link's target) are ever replaced, and outputs are checked before
 * rendering.
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "explore_server.h"
#include "specula/specula.h"

enum {
    EXIT_USAGE = 64,       /* bad command line (EX_USAGE) */
    EXIT_DIFFER = 10,      /* diff: the images differ beyond --max-relmse or --min-pass */
    EXIT_INTERRUPTED = 130 /* SIGINT/SIGTERM: 128 + SIGINT, as shells report it */
};

/* The exit status of a failure: its status code, so scripts and the API read one table. */
static int exit_code(spc_status st)
{
    if (st == SPC_OK)
        return 0;
    return st == SPC_ERR_INTERRUPTED ? EXIT_INTERRUPTED : (int)st;
}

#define EXIT_NOMEM ((int)SPC_ERR_NOMEM)
#define EXIT_IO ((int)SPC_ERR_IO)

/* The most --time and --checkpoint-every accept: a year, far beyond any render, far below what
 * the driver's clock arithmetic could overflow on. */
#define MAX_SECONDS (366.0 * 24 * 3600)
#define MAX_FILM_SIDE 65536 /* the renderer's own limit per side (it also caps the pixel count) */

#define PROGRESS_INTERVAL_S 0.1 /* redraw the progress bar at most ten times a second */
#define PROGRESS_BAR_WIDTH 30

/* ---- messages ---- */

static void fail(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

static void fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("specula: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

static void fail_error(const spc_error *err)
{
    char buf[SPC_ERROR_MSG_MAX + 600];
    spc_error_format(err, buf, (int)sizeof buf);
    fail("%s", buf);
}

static const char *const usage_main =
    "usage: specula <command> [options]\n"
    "\n"
    "commands:\n"
    "  render SCENE.xml [options]   render a Mitsuba scene to an EXR (and a PNG preview)\n"
    "  diff A.exr B.exr [--json]    compare image A against reference B\n"
    "  info SCENE.xml [-D n=v]...   describe a scene\n"
    "  denoise IN.exr -o OUT.exr    denoise a render (Intel Open Image Denoise)\n"
    "  explore SCENE.xml [--port N] watch the specular solvers in the browser\n"
    "\n"
    "  specula --version            print the version\n"
    "  specula <command> --help     options of a command\n";

static const char *const usage_render =
    "usage: specula render SCENE.xml [options]\n"
    "\n"
    "  -o, --output OUT.exr   output image (default: the scene's name with .exr, in the current\n"
    "                         directory); the extension picks the format: .exr (a PNG preview\n"
    "                         OUT.png is written beside it), .png (8-bit sRGB, clamped), .pfm,\n"
    "                         .hdr (Radiance RGBE). Only a regular file is replaced (a symbolic\n"
    "                         link's target is written through it); a directory, device, FIFO or\n"
    "                         socket is refused before rendering. If the image cannot be written\n"
    "                         at the end, it is saved under a name that is printed\n"
    "  --spp N                samples per pixel (default: the scene's)\n"
    "  --time SECONDS         render whole passes until the time is up (--spp then caps)\n"
    "  --threads N            worker threads (default: all cores)\n"
    "  --seed S               random seed (default 0)\n"
    "  --res WxH              film size (default: the scene's)\n"
    "  --integrator NAME      path, ipt, bdpt, volpath or ptracer (default: the scene's)\n"
    "  --specular-nee NAME[:OPTS]  auto, none, angular, newton, conic (default: the scene's, else\n"
    "                         auto: chosen from the scene, as `specula info` shows, for path,\n"
    "                         volpath and bdpt; ipt never: there only none and auto); OPTS,\n"
    "                         comma-separated, e.g. newton:biased=8,seed=light (below)\n"
    ;

/* the options after --specular-nee (one string would pass the 4095 characters C99 promises) */
static const char *const usage_render_more =
    "  --max-depth N          longest path, Mitsuba's meaning; -1 for no limit\n"
    "  -D name=value          override a <default name=... value=...> of the scene (repeatable);\n"
    "                         a name the scene does not declare is an error\n"
    "  --lenient              a property no plugin reads is a warning, not an error (scenes\n"
    "                         written for other renderers)\n"
    "  --variance             also write the variance of the mean (variance.R/G/B)\n"
    "  --aovs                 also write albedo, normal and depth channels\n"
    "  --denoise              denoise the image (see below)\n"
    "  --stats FILE.json      write render statistics as JSON\n"
    "  --strategy S,T         bdpt: render only the (s, t) strategy, unweighted\n"
    "  --strategy-weighted    with --strategy: apply the MIS weight\n"
    "  --strategy-images DIR  bdpt: in the same render, also write every strategy (s, t) of\n"
    "                         length s + t - 1 <= max_depth (1..8) as DIR/sS_tT_weighted.exr and\n"
    "                         DIR/sS_tT_unweighted.exr (+ .png); the weighted ones sum to the image\n"
    "  --mis-balance          bdpt: weight strategies by the balance heuristic instead of the\n"
    "                         power heuristic (also the integrator property mis_balance)\n"
    "  --bdpt-pool M          bdpt: join each camera vertex also to M light vertices picked by\n"
    "                         importance from a pool of the pass's light subpaths (the first\n"
    "                         vertex to 10 M, the third and later to M / 3); -1: off; 0\n"
    "                         (default): 3 where the camera sees mostly indirectly lit surfaces\n"
    "  --bdpt-light-paths K   bdpt: trace K light subpaths per camera sample, the first for every\n"
    "                         strategy, the others for light tracing only (1..64; 0\n"
    "                         (default): 1)\n"
    "  --bdpt-aim A           bdpt: draw a share A (below 1) of the area lights' emission toward\n"
    "                         the glass and mirror casters, scaled by how much of it a pilot sees\n"
    "                         reach them; 0 (default): 0.25; -1: off\n"
    "  --bdpt-aim-camera C    bdpt: draw a share C (below 1) of the camera's first bounce toward\n"
    "                         the same casters, scaled by the share of their light that came\n"
    "                         off a diffuse surface; 0 (default): 0.2; -1: off\n"
    "  --device cpu|opencl[:N]  (info --devices)\n"
    "  --quiet                no progress bar or summary\n"
    "  --checkpoint FILE      save the render state to FILE (atomically) every --checkpoint-every\n"
    "                         seconds, and when the render ends or is interrupted\n"
    "  --checkpoint-every S   seconds between checkpoints (default 60; 0: after every pass)\n"
    "\n";

/* the second half of `render --help` (one string would pass the 4095 characters C99 promises) */
static const char *const usage_render_resume =
    "usage: specula render --resume FILE [-o OUT.exr] [--spp N] [--time S] [--threads N]\n"
    "                      [--stats FILE] [--checkpoint FILE] [--checkpoint-every S] [--quiet]\n"
    "\n"
    "  continues a checkpointed render with the options it was started with (scene, -D, seed,\n"
    "  integrator, ...) and keeps checkpointing to FILE; the image is bit-identical to an\n"
    "  uninterrupted render. A checkpoint of another scene, other settings or another specula\n"
    "  version is refused.\n"
    "\n"
    "Ctrl-C stops after the passes in flight and writes the image so far (and the checkpoint)\n"
    "(exit 130); a second Ctrl-C quits at once without writing.\n";

/* The options of --specular-nee, generated from the one table of them (after usage_render_more). */
static void put_specular_nee_help(void)
{
    char *s = spc_specular_nee_help(2, 96);
    if (s) {
        fputs("specular NEE options (--specular-nee SOLVER:OPT,OPT,...; the integrator's specular_nee):\n", stdout);
        fputs(s, stdout);
    }
    free(s);
}

/* printed after each command's usage */
static const char *const usage_exit =
    "\n"
    "exit status: 0 success; otherwise the API's spc_status: 1 I/O error, 2 parse error, 3 unknown\n"
    "plugin, 4 invalid value, 5 out of memory, 6 beyond a limit, 7 Embree failure, 8 internal\n"
    "error; 64 bad command line; 130 interrupted (the image so far is written); diff: 10 when the\n"
    "images differ beyond --max-relmse or --min-pass.\n";

static const char *const usage_diff =
    "usage: specula diff A.exr B.exr [--json] [--max-relmse X] [--min-pass F]\n"
    "\n"
    "Compares image A against the reference B: per-channel means and their ratio A/B, MSE, relMSE\n"
    "(mean of (a-b)^2 / (b^2 + 0.01)) and, when either image has variance channels, the fraction\n"
    "of pixels passing a z-test at alpha 0.01 (Sidak-corrected for the pixel count). PNG and JPEG\n"
    "images are 8-bit sRGB: they are decoded to linear values (clamped to 1 when written) before\n"
    "the comparison, and a note says so.\n"
    "  --json                 print the result as JSON\n"
    "  --max-relmse X         exit 10 when relMSE exceeds X\n"
    "  --min-pass F           exit 10 when fewer than the fraction F (0..1) of pixels pass the\n"
    "                         z-test (needs variance channels: render with --variance)\n";

/* printed after usage_render (one string would pass the 4095 characters C guarantees) */
static const char *const usage_render_denoise =
    "\n"
    "--denoise runs Intel Open Image Denoise on the final image, guided by the albedo and normal\n"
    "AOVs (it implies --aovs; the library: `pip install pyoidn`, see specula denoise --help). The\n"
    "EXR's R, G, B and the PNG are then the denoised image; the noisy one is kept in the same EXR\n"
    "as noisy.R/G/B (its variance, with --variance, as noisy.variance.R/G/B).\n";

static const char *const usage_denoise =
    "usage: specula denoise IN.exr -o OUT.exr [--threads N] [--quiet]\n"
    "\n"
    "Denoises an EXR written by specula with Intel Open Image Denoise (RT filter, HDR), guided by\n"
    "its albedo and normal channels (render with --aovs; without them the image is denoised alone,\n"
    "with a warning). OUT.exr: R, G, B denoised, the input's image as noisy.R/G/B, its AOVs.\n"
    "The library is the PyPI package pyoidn (`pip install pyoidn`), the system's\n"
    "libOpenImageDenoise.so.2, or the file named by SPECULA_OIDN_LIBRARY.\n"
    "  -o, --output OUT.exr   output image (required)\n"
    "  --threads N            denoiser threads (default: all cores)\n"
    "  --quiet                no progress or summary\n";

static const char *const usage_info =
    "usage: specula info SCENE.xml [-D name=value]... [--lenient] [--specular-nee S]\n"
    "       specula info --devices   list the render devices (cpu, OpenCL platforms and devices)\n"
    "\n"
    "Prints the scene's shapes, triangles, BSDFs, emitters, bounding box, film and integrator,\n"
    "what specular NEE will do (the setting, and for each caster how its chains are found and\n"
    "their lengths; with --specular-nee, for that setting: auto:pilot runs the pilot render a\n"
    "render at the scene's size and samples would), then one line per shape, BSDF and emitter.\n";

static int usage_error(const char *usage, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

static int usage_error(const char *usage, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("specula: ", stderr);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    /* one line, like every other error; the full usage is one --help away */
    if (usage == usage_render)
        fputs(" (see specula render --help)\n", stderr);
    else if (usage == usage_diff)
        fputs(" (see specula diff --help)\n", stderr);
    else if (usage == usage_info)
        fputs(" (see specula info --help)\n", stderr);
    else if (usage == usage_denoise)
        fputs(" (see specula denoise --help)\n", stderr);
    else
        fputs(" (see specula --help)\n", stderr);
    return EXIT_USAGE;
}

/* ---- argument parsing ---- */

/* An option with a value: "--name VALUE" or "--name=VALUE" (and "-DVALUE" for -D). Returns true
 * if argv[*i] is this option; *value is NULL if the value is missing. Advances *i past it. */
static bool opt_value(int argc, char **argv, int *i, const char *name, const char *alias, const char **value)
{
    const char *a = argv[*i];
    const char *names[2] = {name, alias};
    for (int k = 0; k < 2; ++k) {
        const char *n = names[k];
        if (!n)
            continue;
        size_t len = strlen(n);
        if (strncmp(a, n, len) != 0)
            continue;
        if (a[len] == '\0') {
            *value = *i + 1 < argc ? argv[*i + 1] : NULL;
            *i += *value ? 2 : 1;
            return true;
        }
        if (a[len] == '=' || (n[1] != '-' && len == 2)) { /* --name=value, or -Xvalue for short options */
            *value = a + len + (a[len] == '=' && n[1] == '-' ? 1 : 0);
            *i += 1;
            return true;
        }
    }
    return false;
}

static bool parse_int(const char *s, long lo, long hi, int *out)
{
    if (!s || !*s || (*s != '-' && !(*s >= '0' && *s <= '9')))
        return false;
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || *end || v < lo || v > hi)
        return false;
    *out = (int)v;
    return true;
}

static bool parse_u64(const char *s, uint64_t *out)
{
    /* strtoull skips white space and accepts a sign, and wraps "-1" to 2^64 - 1: only digits */
    if (!s || !(*s >= '0' && *s <= '9'))
        return false;
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 0);
    if (errno || *end)
        return false;
    *out = (uint64_t)v;
    return true;
}

static bool parse_double(const char *s, double *out)
{
    if (!s || !*s)
        return false;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || *end || !isfinite(v))
        return false;
    *out = v;
    return true;
}

/* "AxB" with sep between two integers in lo..hi (as parse_int: no overflow, nothing else). */
static bool parse_pair(const char *s, char sep, long lo, long hi, int *a, int *b)
{
    const char *mid = s ? strchr(s, sep) : NULL;
    if (!mid || mid == s || mid - s > 31)
        return false;
    char first[32];
    memcpy(first, s, (size_t)(mid - s));
    first[mid - s] = '\0';
    return parse_int(first, lo, hi, a) && parse_int(mid + 1, lo, hi, b);
}

/* "name=value" -> a define whose strings live in the argument (name is copied). */
typedef struct defines {
    spc_define *defs;
    char **names;
    int n;
} defines;

static bool defines_add(defines *d, const char *arg)
{
    const char *eq = arg ? strchr(arg, '=') : NULL;
    if (!eq || eq == arg)
        return false;
    size_t len = (size_t)(eq - arg);
    char *name = malloc(len + 1);
    if (!name)
        return false;
    memcpy(name, arg, len);
    name[len] = '\0';
    d->names[d->n] = name;
    d->defs[d->n].name = name;
    d->defs[d->n].value = eq + 1;
    d->n++;
    return true;
}

static bool defines_init(defines *d, int argc)
{
    d->n = 0;
    d->defs = calloc((size_t)argc + 1, sizeof *d->defs);
    d->names = calloc((size_t)argc + 1, sizeof *d->names);
    return d->defs && d->names;
}

static void defines_release(defines *d)
{
    for (int i = 0; i < d->n; ++i)
        free(d->names[i]);
    free(d->names);
    free(d->defs);
}

static bool is_help(const char *a) { return !strcmp(a, "-h") || !strcmp(a, "--help"); }

/* ---- paths ---- */

/* The scene's basename with its extension replaced by ext (".exr"); the caller frees. */
static char *default_output(const char *scene, const char *ext)
{
    const char *base = strrchr(scene, '/');
    base = base ? base + 1 : scene;
    size_t len = strlen(base);
    const char *dot = strrchr(base, '.');
    if (dot && dot != base)
        len = (size_t)(dot - base);
    if (len == 0) {
        base = "render";
        len = strlen(base);
    }
    char *out = malloc(len + strlen(ext) + 1);
    if (!out)
        return NULL;
    memcpy(out, base, len);
    strcpy(out + len, ext);
    return out;
}

/* The PNG preview beside OUT.exr: OUT.png. The caller frees. */
static char *png_path(const char *out)
{
    size_t len = strlen(out);
    if (len >= 4 && !strcasecmp(out + len - 4, ".exr"))
        len -= 4;
    char *p = malloc(len + 5);
    if (!p)
        return NULL;
    memcpy(p, out, len);
    strcpy(p + len, ".png");
    return p;
}

/* Checked before rendering, so a long render is not wasted on a typo and nothing but a regular
 * file is ever replaced: path names a regular file or nothing yet (after symbolic links), in a
 * writable folder. Prints the reason and returns false otherwise. */
static bool output_ok(const char *path)
{
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_output_check(path, &err) == SPC_OK)
        return true;
    fail_error(&err);
    return false;
}

/* Writes the film to out (format by its extension) and, for an EXR, the PNG preview. When the
 * image itself cannot be written, it is saved as an EXR under a rescue name, in the current folder
 * or else in $TMPDIR or /tmp, and that name is printed: a finished render is never lost. Returns
 * the status of the write of out (or of the preview). */
static spc_status write_outputs(const spc_film *film, const char *out, const char *png, bool variance)
{
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = spc_film_write(film, out, variance, &err);
    if (st == SPC_OK) {
        if (png && (st = spc_film_write_png(film, png, &err)) != SPC_OK)
            fail_error(&err);
        return st;
    }
    fail_error(&err);
    const char *tmpdir = getenv("TMPDIR");
    const char *dirs[] = {".", tmpdir && *tmpdir ? tmpdir : "/tmp", "/tmp"};
    for (size_t k = 0; k < sizeof dirs / sizeof dirs[0]; ++k) {
        char rescue[4200];
        snprintf(rescue, sizeof rescue, "%s/specula-rescue-%ld-%ld.exr", dirs[k], (long)getpid(), (long)time(NULL));
        spc_error e2;
        memset(&e2, 0, sizeof e2);
        if (spc_film_write_exr(film, rescue, variance, &e2) == SPC_OK) {
            fail("the rendered image is saved as %s instead", rescue);
            return st;
        }
    }
    fail("the rendered image could not be saved anywhere");
    return st;
}

/* Writes every strategy film of `film` into dir (created if missing) as sS_tT_{weighted,unweighted}
 * .exr and .png; false with a message on stderr at the first failure. */
static bool write_strategy_images(const spc_film *film, const char *dir, bool variance)
{
    int n = spc_film_strategy_count(film);
    size_t len = strlen(dir) + 64;
    char *path = malloc(len);
    if (!path) {
        fail("out of memory");
        return false;
    }
    bool ok = true;
    for (int i = 0; ok && i < n; ++i) {
        int s = 0, t = 0;
        bool weighted = false;
        const spc_film *f = spc_film_strategy(film, i, &s, &t, &weighted);
        spc_error err;
        memset(&err, 0, sizeof err);
        const char *kind = weighted ? "weighted" : "unweighted";
        snprintf(path, len, "%s/s%d_t%d_%s.exr", dir, s, t, kind);
        ok = f && spc_film_write_exr(f, path, variance, &err) == SPC_OK;
        if (ok) {
            snprintf(path, len, "%s/s%d_t%d_%s.png", dir, s, t, kind);
            ok = spc_film_write_png(f, path, &err) == SPC_OK;
        }
        if (!ok)
            fail_error(&err);
    }
    free(path);
    return ok;
}

/* ---- JSON output ---- */

static void json_string(FILE *fp, const char *s)
{
    fputc('"', fp);
    for (const unsigned char *p = (const unsigned char *)(s ? s : ""); *p; ++p) {
        if (*p == '"' || *p == '\\')
            fprintf(fp, "\\%c", *p);
        else if (*p == '\n')
            fputs("\\n", fp);
        else if (*p == '\t')
            fputs("\\t", fp);
        else if (*p < 0x20)
            fprintf(fp, "\\u%04x", *p);
        else
            fputc(*p, fp);
    }
    fputc('"', fp);
}

/* JSON has no NaN or infinity: those become null. */
static void json_number(FILE *fp, double v)
{
    if (isfinite(v))
        fprintf(fp, "%.17g", v);
    else
        fputs("null", fp);
}

/* ---- signals ---- */

/* The render polls this between passes. The API takes a volatile int *, so sig_atomic_t must be
 * int (it is on every platform specula builds on). */
_Static_assert(_Generic((sig_atomic_t)0, int: 1, default: 0), "sig_atomic_t must be int");
static volatile sig_atomic_t cancel_flag = 0;
static volatile sig_atomic_t quiet_flag = 0;

static void on_signal(int sig)
{
    (void)sig;
    cancel_flag = 1;
    if (!quiet_flag) {
        static const char msg[] = "\nspecula: interrupted; finishing the current pass (again to quit at once)\n";
        ssize_t r = write(STDERR_FILENO, msg, sizeof msg - 1);
        (void)r;
    }
}

static void install_signal_handlers(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    /* SA_RESETHAND: the handler runs once; the next signal of that kind has its default action
     * and ends the process at once (no half-written image: every write is atomic) */
    sa.sa_flags = SA_RESETHAND;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

static void restore_signal_handlers(void)
{
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
}

/* ---- progress ---- */

typedef struct progress {
    pthread_mutex_t mu;
    double last_drawn;
    bool drawn;
} progress;

static void format_duration(char *buf, size_t size, double s)
{
    if (!(s >= 0.0) || s > 1e8) {
        snprintf(buf, size, "--:--");
        return;
    }
    long t = (long)(s + 0.5);
    if (t >= 3600)
        snprintf(buf, size, "%ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
    else
        snprintf(buf, size, "%ld:%02ld", t / 60, t % 60);
}

/* Called by the renderer, possibly from a worker thread: draws at most every PROGRESS_INTERVAL_S
 * and skips an update rather than wait for another thread's. */
static void on_progress(void *user, double fraction, int spp_done, int spp_total, double elapsed_s)
{
    progress *p = user;
    if (pthread_mutex_trylock(&p->mu) != 0)
        return;
    bool done = fraction >= 1.0;
    if (p->drawn && !done && elapsed_s - p->last_drawn < PROGRESS_INTERVAL_S) {
        pthread_mutex_unlock(&p->mu);
        return;
    }
    p->last_drawn = elapsed_s;
    p->drawn = true;
    double f = fraction < 0.0 ? 0.0 : (fraction > 1.0 ? 1.0 : fraction);
    char bar[PROGRESS_BAR_WIDTH + 1];
    int filled = (int)(f * PROGRESS_BAR_WIDTH + 0.5);
    for (int i = 0; i < PROGRESS_BAR_WIDTH; ++i)
        bar[i] = i < filled ? '#' : '-';
    bar[PROGRESS_BAR_WIDTH] = '\0';
    char el[32], eta[32];
    format_duration(el, sizeof el, elapsed_s);
    if (f > 0.0)
        format_duration(eta, sizeof eta, elapsed_s * (1.0 - f) / f);
    else
        snprintf(eta, sizeof eta, "--:--");
    char spp[48] = "";
    if (spp_total > 0)
        snprintf(spp, sizeof spp, "  %d/%d spp", spp_done, spp_total);
    else
        snprintf(spp, sizeof spp, "  %d spp", spp_done);
    fprintf(stderr, "\r[%s] %5.1f%%%s  elapsed %s  ETA %s  \x1b[K", bar, 100.0 * f, spp, el, eta);
    fflush(stderr);
    pthread_mutex_unlock(&p->mu);
}

#define DENOISE_PROGRESS_MIN_PIXELS (512 * 512) /* smaller images denoise in well under a second */

static double monotonic_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The denoiser's progress (from its threads): "denoising [###---]  45.0%". */
static void on_denoise_progress(void *user, double fraction)
{
    progress *p = user;
    if (pthread_mutex_trylock(&p->mu) != 0)
        return;
    double t = monotonic_seconds();
    if (!p->drawn || t - p->last_drawn >= PROGRESS_INTERVAL_S || fraction >= 1.0) {
        p->last_drawn = t;
        p->drawn = true;
        double f = fraction < 0.0 ? 0.0 : (fraction > 1.0 ? 1.0 : fraction);
        char bar[PROGRESS_BAR_WIDTH + 1];
        int filled = (int)(f * PROGRESS_BAR_WIDTH + 0.5);
        for (int i = 0; i < PROGRESS_BAR_WIDTH; ++i)
            bar[i] = i < filled ? '#' : '-';
        bar[PROGRESS_BAR_WIDTH] = '\0';
        fprintf(stderr, "\rdenoising [%s] %5.1f%%  \x1b[K", bar, 100.0 * f);
        fflush(stderr);
    }
    pthread_mutex_unlock(&p->mu);
}

/* Denoises film (progress on a terminal for large images); false with a message on failure. */
static bool denoise_film(spc_film *film, int threads, bool quiet)
{
    spc_denoise_options dopt;
    spc_denoise_options_init(&dopt);
    dopt.threads = threads;
    progress prog;
    memset(&prog, 0, sizeof prog);
    pthread_mutex_init(&prog.mu, NULL);
    if (!quiet && isatty(STDERR_FILENO) &&
        (long)spc_film_width(film) * spc_film_height(film) >= DENOISE_PROGRESS_MIN_PIXELS) {
        dopt.progress = on_denoise_progress;
        dopt.progress_user = &prog;
    }
    spc_denoise_stats ds;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = spc_film_denoise(film, &dopt, &ds, &err);
    if (prog.drawn)
        fputc('\n', stderr);
    pthread_mutex_destroy(&prog.mu);
    if (st != SPC_OK) {
        fail_error(&err);
        return false;
    }
    if (ds.nonfinite_pixels)
        fprintf(stderr, "specula: warning: %llu pixels had NaN or infinite values; the denoiser got them as 0\n",
                (unsigned long long)ds.nonfinite_pixels);
    if (!quiet)
        fprintf(stderr, "denoised: Open Image Denoise, %s, %.2f s (%s)\n",
                ds.used_aux ? "albedo and normal prefiltered" : "image alone", ds.seconds, ds.library);
    return true;
}

/* ---- stats ---- */

typedef struct stats_info {
    const char *scene, *output, *integrator;
    uint64_t seed;
    int width, height;
    bool interrupted;
} stats_info;

static bool write_stats(const char *given, const spc_render_stats *st, const stats_info *in, char *why,
                        size_t whylen)
{
    /* like the images: only a regular file is replaced, a symbolic link's target through it */
    char path[4096];
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_output_resolve(given, path, sizeof path, &err) != SPC_OK) {
        snprintf(why, whylen, "%s", err.msg);
        return false;
    }
    size_t len = strlen(path);
    char *tmp = malloc(len + 32);
    if (!tmp) {
        snprintf(why, whylen, "out of memory");
        return false;
    }
    snprintf(tmp, len + 32, "%s.tmp-%ld", path, (long)getpid());
    FILE *fp = fopen(tmp, "w");
    if (!fp) {
        snprintf(why, whylen, "%s", strerror(errno));
        free(tmp);
        return false;
    }
    fprintf(fp, "{\n  \"renderer\": ");
    json_string(fp, "specula " SPECULA_VERSION);
    fprintf(fp, ",\n  \"scene\": ");
    json_string(fp, in->scene);
    fprintf(fp, ",\n  \"output\": ");
    json_string(fp, in->output);
    fprintf(fp, ",\n  \"integrator\": ");
    json_string(fp, in->integrator);
    fprintf(fp, ",\n  \"width\": %d,\n  \"height\": %d", in->width, in->height);
    fprintf(fp, ",\n  \"spp\": %d,\n  \"seed\": %llu", st->spp, (unsigned long long)in->seed);
    fprintf(fp, ",\n  \"wall_seconds\": ");
    json_number(fp, st->wall_seconds);
    fprintf(fp, ",\n  \"rays_traced\": %llu", (unsigned long long)st->rays_traced);
    fprintf(fp, ",\n  \"shadow_rays\": %llu", (unsigned long long)st->shadow_rays_traced);
    fprintf(fp, ",\n  \"mrays_per_second\": ");
    json_number(fp, st->mrays_per_second);
    fprintf(fp, ",\n  \"threads\": %d", st->threads);
    fprintf(fp, ",\n  \"samples\": %llu", (unsigned long long)st->samples);
    fprintf(fp, ",\n  \"invalid_samples\": %llu", (unsigned long long)st->invalid_samples);
    fprintf(fp, ",\n  \"specular_nee\": ");
    json_string(fp, st->specular_nee);
    fprintf(fp, ",\n  \"specular_nee_pilot\": ");
    json_string(fp, st->specular_nee_pilot);
    fprintf(fp, ",\n  \"caustic_guide_entries\": %d,\n  \"caustic_guide_cones\": %d,\n  \"caustic_guide_seconds\": ",
            st->caustic_guide_entries, st->caustic_guide_cones);
    json_number(fp, st->caustic_guide_seconds);
    fprintf(fp, ",\n  \"bdpt_aim\": ");
    json_number(fp, st->bdpt_aim);
    fprintf(fp, ",\n  \"bdpt_aim_camera\": ");
    json_number(fp, st->bdpt_aim_camera);
    fprintf(fp, ",\n  \"interrupted\": %s\n}\n", in->interrupted ? "true" : "false");
    bool ok = !ferror(fp);
    if (fflush(fp) != 0 || fsync(fileno(fp)) != 0)
        ok = false;
    if (fclose(fp) != 0)
        ok = false;
    if (ok && rename(tmp, path) != 0)
        ok = false;
    if (!ok) {
        snprintf(why, whylen, "%s", strerror(errno ? errno : EIO));
        remove(tmp);
    }
    free(tmp);
    return ok;
}

/* ---- render ---- */

/* Options of a render that are not recorded in its checkpoint: a resumed render may set them anew
 * (the output, scene and checkpoint paths are recorded separately, made absolute). */
static bool option_is_unrecorded(const char *a)
{
    static const char *const names[] = {"--output", "-o", "--threads", "--quiet", "-q", "--stats",
                                        "--checkpoint-every", "--checkpoint", "--resume"};
    if (a[0] != '-' || a[1] == '\0')
        return true; /* the scene */
    for (size_t k = 0; k < sizeof names / sizeof names[0]; ++k) {
        size_t len = strlen(names[k]);
        if (!strncmp(a, names[k], len) && (a[len] == '\0' || a[len] == '=' || (len == 2 && names[k][1] != '-')))
            return true;
    }
    return false;
}

/* A growable newline-separated list of arguments: the checkpoint's user text. */
typedef struct arglist {
    char *text;
    size_t len;
    bool failed;
} arglist;

static void arglist_add(arglist *l, const char *a)
{
    size_t n = strlen(a);
    if (l->failed)
        return;
    if (strchr(a, '\n')) {
        l->failed = true;
        return;
    }
    char *t = realloc(l->text, l->len + n + 2);
    if (!t) {
        l->failed = true;
        return;
    }
    l->text = t;
    memcpy(t + l->len, a, n);
    l->len += n;
    t[l->len++] = '\n';
    t[l->len] = '\0';
}

/* path made absolute against the current directory; the caller frees. */
static char *absolute_path(const char *path)
{
    if (path[0] == '/')
        return strdup(path);
    char cwd[4096];
    if (!getcwd(cwd, sizeof cwd))
        return NULL;
    size_t n = strlen(cwd) + strlen(path) + 2;
    char *p = malloc(n);
    if (p)
        snprintf(p, n, "%s/%s", cwd, path);
    return p;
}

static int render_run(int argc, char **argv, const spc_checkpoint *resume)
{
    spc_render_options opt;
    spc_render_options_init(&opt);
    opt.resume = resume;
    const char *ckpt_path = NULL;
    arglist recorded = {NULL, 0, false};
    const char *scene_path = NULL, *out_arg = NULL, *stats_path = NULL, *strategy_dir = NULL;
    bool variance = false, quiet = false, lenient = false, denoise = false;
    defines defs;
    if (!defines_init(&defs, argc)) {
        fail("out of memory");
        return EXIT_NOMEM;
    }
    int code = 0;
    for (int i = 0; i < argc && code == 0;) {
        const char *a = argv[i], *v = NULL;
        int i0 = i;
        if (is_help(a)) {
            fputs(usage_render, stdout);
            fputs(usage_render_more, stdout);
            put_specular_nee_help();
            fputs(usage_render_denoise, stdout);
            fputs(usage_render_resume, stdout);
            fputs(usage_exit, stdout);
            defines_release(&defs);
            return 0;
        } else if (opt_value(argc, argv, &i, "--checkpoint-every", NULL, &v)) {
            if (!parse_double(v, &opt.checkpoint_every) || opt.checkpoint_every < 0.0 ||
                opt.checkpoint_every > MAX_SECONDS)
                code = usage_error(usage_render, "--checkpoint-every needs a number of seconds from 0 to %g, not '%s'",
                                   MAX_SECONDS, v ? v : "");
        } else if (opt_value(argc, argv, &i, "--checkpoint", NULL, &v)) {
            if (!v || !*v)
                code = usage_error(usage_render, "--checkpoint needs a file name");
            ckpt_path = v;
        } else if (opt_value(argc, argv, &i, "--output", "-o", &v)) {
            if (!v || !*v)
                code = usage_error(usage_render, "-o needs a file name");
            out_arg = v;
        } else if (opt_value(argc, argv, &i, "--spp", NULL, &v)) {
            if (!parse_int(v, 1, INT_MAX, &opt.spp))
                code = usage_error(usage_render, "--spp needs a positive integer, not '%s'", v ? v : "");
        } else if (opt_value(argc, argv, &i, "--time", NULL, &v)) {
            if (!parse_double(v, &opt.time_limit) || opt.time_limit <= 0.0 || opt.time_limit > MAX_SECONDS)
                code = usage_error(usage_render, "--time needs a positive number of seconds up to %g, not '%s'",
                                   MAX_SECONDS, v ? v : "");
        } else if (opt_value(argc, argv, &i, "--threads", NULL, &v)) {
            if (!parse_int(v, 0, 4096, &opt.threads))
                code = usage_error(usage_render, "--threads needs a count (0: all cores), not '%s'", v ? v : "");
        } else if (opt_value(argc, argv, &i, "--seed", NULL, &v)) {
            if (!parse_u64(v, &opt.seed))
                code = usage_error(usage_render, "--seed needs a non-negative integer, not '%s'", v ? v : "");
        } else if (opt_value(argc, argv, &i, "--res", NULL, &v)) {
            int w = 0, h = 0;
            if (!parse_pair(v, 'x', 1, MAX_FILM_SIDE, &w, &h))
                code = usage_error(usage_render, "--res needs WIDTHxHEIGHT, each 1 to %d, not '%s'", MAX_FILM_SIDE,
                                   v ? v : "");
            opt.width = w;
            opt.height = h;
        } else if (opt_value(argc, argv, &i, "--integrator", NULL, &v)) {
            if (!v || !*v)
                code = usage_error(usage_render, "--integrator needs a name");
            opt.integrator = v;
        } else if (opt_value(argc, argv, &i, "--specular-nee", NULL, &v)) {
            if (!v)
                code = usage_error(usage_render, "--specular-nee needs a name");
            else if (strlen(v) >= SPC_SPECULAR_NEE_MAX)
                code = usage_error(usage_render, "--specular-nee is %zu characters long (at most %d)", strlen(v),
                                   SPC_SPECULAR_NEE_MAX - 1);
            opt.specular_nee = v;
        } else if (opt_value(argc, argv, &i, "--max-depth", NULL, &v)) {
            if (!parse_int(v, -1, INT_MAX, &opt.max_depth))
                code = usage_error(usage_render, "--max-depth needs an integer >= -1, not '%s'", v ? v : "");
        } else if (opt_value(argc, argv, &i, "-D", NULL, &v)) {
            if (!defines_add(&defs, v))
                code = usage_error(usage_render, "-D needs name=value, not '%s'", v ? v : "");
        } else if (opt_value(argc, argv, &i, "--stats", NULL, &v)) {
            if (!v || !*v)
                code = usage_error(usage_render, "--stats needs a file name");
            stats_path = v;
        } else if (opt_value(argc, argv, &i, "--strategy", NULL, &v)) {
            if (!parse_pair(v, ',', 0, 1000000, &opt.strategy_s, &opt.strategy_t))
                code = usage_error(usage_render, "--strategy needs S,T (two non-negative integers), not '%s'",
                                   v ? v : "");
        } else if (!strcmp(a, "--strategy-weighted")) {
            opt.strategy_weighted = true;
            ++i;
        } else if (opt_value(argc, argv, &i, "--strategy-images", NULL, &v)) {
            if (!v || !*v)
                code = usage_error(usage_render, "--strategy-images needs a directory");
            strategy_dir = v;
            opt.strategy_images = true;
        } else if (!strcmp(a, "--mis-balance")) {
            opt.mis_balance = true;
            ++i;
        } else if (opt_value(argc, argv, &i, "--bdpt-pool", NULL, &v)) {
            if (!parse_int(v, -1, 64, &opt.bdpt_pool))
                code = usage_error(usage_render,
                                   "--bdpt-pool needs connections per camera vertex in 1..64, 0 (default) or -1 (off), "
                                   "not '%s'",
                                   v ? v : "");
        } else if (opt_value(argc, argv, &i, "--bdpt-light-paths", NULL, &v)) {
            if (!parse_int(v, 0, 64, &opt.bdpt_light_paths))
                code = usage_error(usage_render,
                                   "--bdpt-light-paths needs light subpaths per sample in 1..64 or 0 "
                                   "(default), not '%s'",
                                   v ? v : "");
        } else if (opt_value(argc, argv, &i, "--bdpt-aim", NULL, &v)) {
            if (!parse_double(v, &opt.bdpt_aim) || !(opt.bdpt_aim < 1.0))
                code = usage_error(usage_render, "--bdpt-aim needs a share below 1, 0 (default) or -1 (off), not '%s'",
                                   v ? v : "");
        } else if (opt_value(argc, argv, &i, "--bdpt-aim-camera", NULL, &v)) {
            if (!parse_double(v, &opt.bdpt_aim_camera) || !(opt.bdpt_aim_camera < 1.0))
                code = usage_error(usage_render,
                                   "--bdpt-aim-camera needs a share below 1, 0 (default) or -1 (off), not '%s'",
                                   v ? v : "");
        } else if (!strcmp(a, "--variance")) {
            variance = true;
            ++i;
        } else if (!strcmp(a, "--aovs")) {
            opt.aovs = true;
            ++i;
        } else if (!strcmp(a, "--denoise")) {
            denoise = opt.aovs = true;
            ++i;
        } else if (opt_value(argc, argv, &i, "--device", NULL, &v)) {
            if (!v || !*v)
                code = usage_error(usage_render, "--device needs cpu, opencl or opencl:N");
            opt.device = v;
        } else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) {
            quiet = true;
            ++i;
        } else if (!strcmp(a, "--lenient")) {
            lenient = true;
            ++i;
        } else if (a[0] == '-' && a[1] != '\0') {
            code = usage_error(usage_render, "unknown option '%s'", a);
        } else {
            if (scene_path)
                code = usage_error(usage_render, "more than one scene given ('%s' and '%s')", scene_path, a);
            scene_path = a;
            ++i;
        }
        if (!option_is_unrecorded(a))
            for (int k = i0; k < i; ++k)
                arglist_add(&recorded, argv[k]);
    }
    if (code == 0 && !scene_path)
        code = usage_error(usage_render, "no scene given");
    if (code == 0 && opt.strategy_weighted && opt.strategy_s < 0)
        code = usage_error(usage_render, "--strategy-weighted needs --strategy S,T");
    if (code == 0 && strategy_dir && opt.strategy_s >= 0)
        code = usage_error(usage_render, "--strategy-images writes every strategy; it does not go with --strategy");
    if (code == 0 && denoise && strategy_dir)
        code = usage_error(usage_render, "--denoise does not go with --strategy-images");
    if (code == 0 && strategy_dir && (ckpt_path || resume))
        code = usage_error(usage_render, "--strategy-images cannot be checkpointed; render without --checkpoint");
    if (code != 0) {
        defines_release(&defs);
        free(recorded.text);
        return code;
    }

    char *out_owned = out_arg ? NULL : default_output(scene_path, ".exr");
    const char *out_path = out_arg ? out_arg : out_owned;
    spc_image_format format = out_path ? spc_image_format_of(out_path) : SPC_FORMAT_UNKNOWN;
    char *png = out_path && format == SPC_FORMAT_EXR ? png_path(out_path) : NULL;
    spc_scene *scene = NULL;
    spc_film *film = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (!out_path || (format == SPC_FORMAT_EXR && !png)) {
        fail("out of memory");
        code = EXIT_NOMEM;
        goto done;
    }
    /* what the path is first (a directory named OUT is a directory, whatever its extension) */
    if (!output_ok(out_path) || (png && !output_ok(png)) || (stats_path && !output_ok(stats_path))) {
        code = EXIT_IO;
        goto done;
    }
    if (format == SPC_FORMAT_UNKNOWN) {
        code = usage_error(usage_render, "%s: unknown image format: name the output .exr, .png, .pfm or .hdr",
                           out_path);
        goto done;
    }
    if (format != SPC_FORMAT_EXR && (variance || opt.aovs)) {
        code = usage_error(usage_render, "%s: --variance and --aovs need an .exr output", out_path);
        goto done;
    }
    if (strategy_dir && mkdir(strategy_dir, 0777) != 0 && errno != EEXIST) {
        fail("%s: cannot create the directory: %s", strategy_dir, strerror(errno));
        code = EXIT_IO;
        goto done;
    }
    if (ckpt_path) {
        if (!output_ok(ckpt_path)) {
            code = EXIT_IO;
            goto done;
        }
        /* what --resume needs to render the same thing again, from any directory */
        char *abs_out = absolute_path(out_path), *abs_scene = absolute_path(scene_path);
        arglist_add(&recorded, "-o");
        arglist_add(&recorded, abs_out ? abs_out : "");
        arglist_add(&recorded, abs_scene ? abs_scene : "");
        bool ok = abs_out && abs_scene && !recorded.failed;
        free(abs_out);
        free(abs_scene);
        if (!ok) {
            fail("%s: cannot record this command line in a checkpoint (an argument holds a newline, or out of "
                 "memory)",
                 ckpt_path);
            code = EXIT_USAGE;
            goto done;
        }
        opt.checkpoint_path = ckpt_path;
        opt.checkpoint_user = recorded.text;
    }

    if (denoise) {
        /* a missing library is reported before the render, not after it */
        spc_status lst = spc_denoise_load(NULL, 0, &err);
        if (lst != SPC_OK) {
            fail_error(&err);
            code = exit_code(lst);
            goto done;
        }
    }
    if (opt.integrator) {
        /* room was reserved: defines_init allots argc + 1 entries and --integrator takes two */
        defs.names[defs.n] = NULL;
        defs.defs[defs.n].name = SPC_DEFINE_INTEGRATOR;
        defs.defs[defs.n].value = opt.integrator;
        defs.n++;
    }
    if (lenient) { /* --lenient is one argument of its own: its entry was reserved too */
        defs.names[defs.n] = NULL;
        defs.defs[defs.n].name = SPC_DEFINE_UNREFERENCED;
        defs.defs[defs.n].value = "warn";
        defs.n++;
    }
    spc_status st = spc_scene_load(scene_path, defs.defs, defs.n, &scene, &err);
    if (st != SPC_OK) {
        fail_error(&err);
        code = exit_code(st);
        goto done;
    }
    spc_scene_summary sum;
    spc_scene_summarize(scene, &sum);

    progress prog;
    memset(&prog, 0, sizeof prog);
    pthread_mutex_init(&prog.mu, NULL);
    if (!quiet && isatty(STDERR_FILENO)) {
        opt.progress = on_progress;
        opt.progress_user = &prog;
    }
    quiet_flag = quiet;
    cancel_flag = 0;
    opt.cancel = (volatile int *)&cancel_flag;
    install_signal_handlers();

    spc_render_stats stats;
    memset(&stats, 0, sizeof stats);
    st = spc_render(scene, &opt, &film, &stats, &err);
    /* from here on a second signal would only interrupt the writes, which are atomic anyway; the
     * default action is the right one */
    restore_signal_handlers();
    if (prog.drawn)
        fputc('\n', stderr);
    pthread_mutex_destroy(&prog.mu);
    bool interrupted = st == SPC_ERR_INTERRUPTED || (st == SPC_OK && cancel_flag);
    bool ckpt_failed = false;
    if (film && (st == SPC_ERR_IO || st == SPC_ERR_LIMIT) && ckpt_path) {
        /* the checkpoint could not be written: keep the image rendered so far, then fail */
        fail_error(&err);
        ckpt_failed = true;
        interrupted = cancel_flag != 0;
    } else if (st != SPC_OK && st != SPC_ERR_INTERRUPTED) {
        fail_error(&err);
        code = exit_code(st);
        goto done;
    }
    if (!film) {
        if (interrupted) {
            fail("interrupted before the first pass finished; nothing written");
            code = EXIT_INTERRUPTED;
        } else {
            fail("the renderer returned no image");
            code = exit_code(SPC_ERR_INTERNAL);
        }
        goto done;
    }
    if (interrupted && (stats.spp <= 0 || spc_film_rgb(film) == NULL)) {
        fail("interrupted before the first pass finished; nothing written");
        code = EXIT_INTERRUPTED;
        goto done;
    }

    /* the final image only: checkpoints hold the film's sums, so a resumed render denoises the
     * same image; if the denoiser fails, the noisy image is written and the exit code says so */
    bool denoise_failed = denoise && !denoise_film(film, opt.threads, quiet);
    st = write_outputs(film, out_path, png, variance);
    if (st != SPC_OK) {
        code = exit_code(st);
        goto done;
    }
    if (strategy_dir && !write_strategy_images(film, strategy_dir, variance)) {
        code = EXIT_IO;
        goto done;
    }
    if (stats_path) {
        stats_info info = {
            .scene = scene_path,
            .output = out_path,
            .integrator = opt.integrator ? opt.integrator : sum.integrator,
            .seed = opt.seed,
            .width = spc_film_width(film),
            .height = spc_film_height(film),
            .interrupted = interrupted,
        };
        char why[SPC_ERROR_MSG_MAX];
        if (!write_stats(stats_path, &stats, &info, why, sizeof why)) {
            fail("%s: cannot write statistics: %s", stats_path, why);
            code = EXIT_IO;
            goto done;
        }
    }
    if (!quiet)
        fprintf(stderr, "%s: %dx%d, %d spp, %.2f s, %.2f Mrays/s, %d threads%s -> %s%s%s\n",
                interrupted ? "interrupted" : "rendered", spc_film_width(film), spc_film_height(film), stats.spp,
                stats.wall_seconds, stats.mrays_per_second, stats.threads,
                stats.invalid_samples ? " (some invalid samples discarded)" : "", out_path, png ? ", " : "",
                png ? png : "");
    code = ckpt_failed ? EXIT_IO : interrupted ? EXIT_INTERRUPTED : denoise_failed ? (int)SPC_ERR_INTERNAL : 0;

done:
    spc_film_destroy(film);
    spc_scene_destroy(scene);
    free(png);
    free(out_owned);
    free(recorded.text);
    defines_release(&defs);
    return code;
}

/* Options a resumed render may set anew; everything else comes from the checkpoint. */
static bool option_allowed_on_resume(const char *a)
{
    static const char *const names[] = {"--output", "-o", "--threads", "--quiet", "-q", "--stats",
                                        "--checkpoint-every", "--checkpoint", "--spp", "--time"};
    for (size_t k = 0; k < sizeof names / sizeof names[0]; ++k) {
        size_t len = strlen(names[k]);
        if (!strncmp(a, names[k], len) && (a[len] == '\0' || a[len] == '=' || (len == 2 && names[k][1] != '-')))
            return true;
    }
    return false;
}

/* `render --resume FILE [options]`: the checkpoint's recorded arguments, then the new ones (the last
 * value of an option wins), checkpointing to FILE unless --checkpoint says otherwise. */
static int cmd_render(int argc, char **argv)
{
    const char *resume_path = NULL;
    int at = -1;
    for (int i = 0; i < argc; ++i) {
        const char *v = NULL;
        int j = i;
        if (opt_value(argc, argv, &j, "--resume", NULL, &v)) {
            if (!v || !*v)
                return usage_error(usage_render, "--resume needs a checkpoint file");
            if (resume_path)
                return usage_error(usage_render, "--resume given twice");
            resume_path = v;
            at = i;
            i = j - 1;
        }
    }
    if (!resume_path)
        return render_run(argc, argv, NULL);

    int skip = argv[at][strlen("--resume")] == '=' ? 1 : 2;
    bool own_ckpt = false;
    for (int i = 0; i < argc; ++i) {
        if (i == at) {
            i += skip - 1;
            continue;
        }
        const char *a = argv[i];
        if (is_help(a)) {
            fputs(usage_render, stdout);
            fputs(usage_render_more, stdout);
            put_specular_nee_help();
            fputs(usage_render_denoise, stdout);
            fputs(usage_render_resume, stdout);
            fputs(usage_exit, stdout);
            return 0;
        }
        if (a[0] != '-' || a[1] == '\0')
            return usage_error(usage_render, "--resume takes the scene from the checkpoint; '%s' is not an option", a);
        if (!option_allowed_on_resume(a))
            return usage_error(usage_render, "'%s' cannot be changed when resuming: the checkpoint fixes it", a);
        if (!strncmp(a, "--checkpoint", 12) && (a[12] == '\0' || a[12] == '='))
            own_ckpt = true;
        /* skip the option's value */
        bool valued = strcmp(a, "--quiet") != 0 && strcmp(a, "-q") != 0 && !strchr(a, '=') &&
                      !(a[1] != '-' && a[2] != '\0');
        if (valued)
            ++i;
    }

    spc_checkpoint *ck = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status lst = spc_checkpoint_load(resume_path, &ck, &err);
    if (lst != SPC_OK) {
        fail_error(&err);
        return exit_code(lst);
    }
    spc_checkpoint_info info;
    spc_checkpoint_get_info(ck, &info);
    size_t ulen = strlen(info.user);
    char *user = malloc(ulen + 1);
    char **args = calloc((size_t)argc + ulen + 4, sizeof *args);
    if (!user || !args) {
        free(user);
        free(args);
        spc_checkpoint_destroy(ck);
        fail("out of memory");
        return EXIT_NOMEM;
    }
    memcpy(user, info.user, ulen + 1);
    int n = 0;
    for (char *p = user, *nl; *p; p = nl + 1) {
        nl = strchr(p, '\n');
        if (!nl)
            break;
        *nl = '\0';
        args[n++] = p;
    }
    if (n == 0) {
        fail("%s: this checkpoint was not written by the specula command (it records no arguments)", resume_path);
        free(user);
        free(args);
        spc_checkpoint_destroy(ck);
        return exit_code(SPC_ERR_VALUE);
    }
    for (int i = 0; i < argc; ++i) {
        if (i == at) {
            i += skip - 1;
            continue;
        }
        args[n++] = argv[i];
    }
    char ckopt[] = "--checkpoint";
    if (!own_ckpt) {
        args[n++] = ckopt;
        args[n++] = (char *)resume_path;
    }
    int code = render_run(n, args, ck);
    free(user);
    free(args);
    spc_checkpoint_destroy(ck);
    return code;
}

/* ---- diff ---- */

/* PNG and JPEG files hold 8-bit sRGB (by their first bytes, as the reader decides). */
static bool is_srgb_file(const char *path)
{
    unsigned char magic[8] = {0};
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return false;
    size_t n = fread(magic, 1, sizeof magic, fp);
    fclose(fp);
    static const unsigned char png[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    static const unsigned char jpg[3] = {0xff, 0xd8, 0xff};
    return (n >= 8 && !memcmp(magic, png, 8)) || (n >= 3 && !memcmp(magic, jpg, 3));
}

static int cmd_diff(int argc, char **argv)
{
    const char *paths[2] = {NULL, NULL};
    int npaths = 0;
    bool json = false;
    double max_relmse = -1.0, min_pass = -1.0;
    for (int i = 0; i < argc; ++i) {
        const char *a = argv[i], *v = NULL;
        int j = i;
        if (opt_value(argc, argv, &j, "--max-relmse", NULL, &v)) {
            if (!parse_double(v, &max_relmse) || max_relmse < 0.0)
                return usage_error(usage_diff, "--max-relmse needs a number >= 0, not '%s'", v ? v : "");
            i = j - 1;
        } else if (opt_value(argc, argv, &j, "--min-pass", NULL, &v)) {
            if (!parse_double(v, &min_pass) || min_pass < 0.0 || min_pass > 1.0)
                return usage_error(usage_diff, "--min-pass needs a fraction from 0 to 1, not '%s'", v ? v : "");
            i = j - 1;
        } else if (is_help(a)) {
            fputs(usage_diff, stdout);
            fputs(usage_exit, stdout);
            return 0;
        } else if (!strcmp(a, "--json")) {
            json = true;
        } else if (a[0] == '-' && a[1] != '\0') {
            return usage_error(usage_diff, "unknown option '%s'", a);
        } else if (npaths < 2) {
            paths[npaths++] = a;
        } else {
            return usage_error(usage_diff, "diff takes two images");
        }
    }
    if (npaths != 2)
        return usage_error(usage_diff, "diff takes two images");

    spc_image_rgb img[2];
    memset(img, 0, sizeof img);
    spc_error err;
    memset(&err, 0, sizeof err);
    int code = 0;
    for (int k = 0; k < 2 && code == 0; ++k) {
        spc_status rst = spc_image_rgb_read(paths[k], &img[k], &err);
        if (rst != SPC_OK) {
            fail_error(&err);
            code = exit_code(rst);
        }
    }
    spc_diff_result r;
    spc_status dst = code == 0 ? spc_image_diff(&img[0], &img[1], &r, &err) : SPC_OK;
    if (dst != SPC_OK) {
        fail("%s vs %s: %s", paths[0], paths[1], err.msg);
        code = exit_code(dst);
    }
    for (int k = 0; k < 2 && code == 0; ++k)
        if (is_srgb_file(paths[k]))
            fprintf(stderr,
                    "specula: note: %s is 8-bit sRGB (a tone-mapped preview): its values were decoded to linear "
                    "for the comparison, and anything above 1 was clipped when it was written\n",
                    paths[k]);
    if (code == 0 && min_pass >= 0.0 && !r.has_ztest) {
        fail("--min-pass needs a variance channel in one of the images (render with --variance)");
        code = exit_code(SPC_ERR_VALUE);
    }
    double ratio[4] = {0, 0, 0, 0};
    if (code == 0) {
        double sa = 0.0, sb = 0.0;
        for (int c = 0; c < 3; ++c) {
            ratio[c] = r.mean_a[c] / r.mean_b[c]; /* inf or NaN (printed as such) for a black reference */
            sa += r.mean_a[c];
            sb += r.mean_b[c];
        }
        ratio[3] = sa / sb;
    }
    if (code == 0 && json) {
        printf("{\n  \"a\": ");
        json_string(stdout, paths[0]);
        printf(",\n  \"b\": ");
        json_string(stdout, paths[1]);
        printf(",\n  \"width\": %d,\n  \"height\": %d", img[0].width, img[0].height);
        const double *means[2] = {r.mean_a, r.mean_b};
        const char *mnames[2] = {"mean_a", "mean_b"};
        for (int k = 0; k < 2; ++k) {
            printf(",\n  \"%s\": [", mnames[k]);
            for (int c = 0; c < 3; ++c) {
                if (c)
                    printf(", ");
                json_number(stdout, means[k][c]);
            }
            printf("]");
        }
        printf(",\n  \"ratio\": [");
        for (int c = 0; c < 3; ++c) {
            if (c)
                printf(", ");
            json_number(stdout, ratio[c]);
        }
        printf("],\n  \"ratio_mean\": ");
        json_number(stdout, ratio[3]);
        printf(",\n  \"srgb\": [%s, %s]", is_srgb_file(paths[0]) ? "true" : "false",
               is_srgb_file(paths[1]) ? "true" : "false");
        printf(",\n  \"mse\": ");
        json_number(stdout, r.mse);
        printf(",\n  \"rel_mse\": ");
        json_number(stdout, r.rel_mse);
        if (r.has_ztest) {
            printf(",\n  \"ztest\": {\"pass_fraction\": ");
            json_number(stdout, r.ztest_pass_fraction);
            printf(", \"pixels\": %d, \"alpha\": 0.01}", r.ztest_pixels);
        } else {
            printf(",\n  \"ztest\": null");
        }
        printf("\n}\n");
    } else if (code == 0) {
        printf("a: %s  %dx%d  mean (%.6g, %.6g, %.6g)\n", paths[0], img[0].width, img[0].height, r.mean_a[0],
               r.mean_a[1], r.mean_a[2]);
        printf("b: %s  %dx%d  mean (%.6g, %.6g, %.6g)\n", paths[1], img[1].width, img[1].height, r.mean_b[0],
               r.mean_b[1], r.mean_b[2]);
        if (isfinite(ratio[3]))
            printf("ratio of means a/b: %.6g (%.6g, %.6g, %.6g)\n", ratio[3], ratio[0], ratio[1], ratio[2]);
        else
            printf("ratio of means a/b: undefined (b is black)\n");
        printf("MSE: %.6g\n", r.mse);
        printf("relMSE: %.6g\n", r.rel_mse);
        if (r.has_ztest)
            printf("z-test: %.4f%% of %d pixels pass (alpha 0.01, Sidak-corrected)\n",
                   100.0 * r.ztest_pass_fraction, r.ztest_pixels);
        else
            printf("z-test: no variance channels\n");
    }
    if (code == 0 && max_relmse >= 0.0 && !(r.rel_mse <= max_relmse)) {
        fail("relMSE %.6g exceeds --max-relmse %g", r.rel_mse, max_relmse);
        code = EXIT_DIFFER;
    }
    if (code == 0 && min_pass >= 0.0 && !(r.ztest_pass_fraction >= min_pass)) {
        fail("%.4f of the pixels pass the z-test, fewer than --min-pass %g", r.ztest_pass_fraction, min_pass);
        code = EXIT_DIFFER;
    }
    spc_image_rgb_release(&img[0]);
    spc_image_rgb_release(&img[1]);
    return code;
}

/* ---- denoise ---- */

static int cmd_denoise(int argc, char **argv)
{
    const char *in = NULL, *out = NULL;
    bool quiet = false;
    spc_denoise_options dopt;
    spc_denoise_options_init(&dopt);
    for (int i = 0; i < argc;) {
        const char *a = argv[i], *v = NULL;
        if (is_help(a)) {
            fputs(usage_denoise, stdout);
            return 0;
        } else if (opt_value(argc, argv, &i, "--output", "-o", &v)) {
            if (!v || !*v)
                return usage_error(usage_denoise, "-o needs a file name");
            out = v;
        } else if (opt_value(argc, argv, &i, "--threads", NULL, &v)) {
            if (!parse_int(v, 0, 4096, &dopt.threads))
                return usage_error(usage_denoise, "--threads needs a count (0: all cores), not '%s'", v ? v : "");
        } else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) {
            quiet = true;
            ++i;
        } else if (a[0] == '-' && a[1] != '\0') {
            return usage_error(usage_denoise, "unknown option '%s'", a);
        } else {
            if (in)
                return usage_error(usage_denoise, "denoise takes one image ('%s' and '%s' given)", in, a);
            in = a;
            ++i;
        }
    }
    if (!in)
        return usage_error(usage_denoise, "no image given");
    if (!out)
        return usage_error(usage_denoise, "no output given (-o OUT.exr)");
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_output_check(out, &err) != SPC_OK) {
        fail_error(&err);
        return exit_code(SPC_ERR_IO);
    }
    progress prog;
    memset(&prog, 0, sizeof prog);
    pthread_mutex_init(&prog.mu, NULL);
    if (!quiet && isatty(STDERR_FILENO)) {
        dopt.progress = on_denoise_progress;
        dopt.progress_user = &prog;
    }
    spc_denoise_stats ds;
    memset(&ds, 0, sizeof ds);
    spc_status st = spc_denoise_exr(in, out, &dopt, &ds, &err);
    if (prog.drawn)
        fputc('\n', stderr);
    pthread_mutex_destroy(&prog.mu);
    if (st != SPC_OK) {
        fail_error(&err);
        return exit_code(st);
    }
    if (!ds.used_aux)
        fprintf(stderr,
                "specula: warning: %s has no albedo.* and normal.* channels (render with --aovs); "
                "denoised the image alone\n",
                in);
    if (ds.nonfinite_pixels)
        fprintf(stderr, "specula: warning: %llu pixels had NaN or infinite values; the denoiser got them as 0\n",
                (unsigned long long)ds.nonfinite_pixels);
    if (!quiet)
        fprintf(stderr, "denoised: Open Image Denoise, %s, %.2f s (%s) -> %s\n",
                ds.used_aux ? "albedo and normal prefiltered" : "image alone", ds.seconds, ds.library, out);
    return 0;
}

/* ---- info ---- */

static int cmd_info(int argc, char **argv)
{
    const char *scene_path = NULL, *info_snee = NULL;
    defines defs;
    if (!defines_init(&defs, argc)) {
        fail("out of memory");
        return EXIT_NOMEM;
    }
    int code = 0;
    for (int i = 0; i < argc && code == 0;) {
        const char *a = argv[i], *v = NULL;
        if (is_help(a)) {
            fputs(usage_info, stdout);
            fputs(usage_exit, stdout);
            defines_release(&defs);
            return 0;
        } else if (!strcmp(a, "--devices")) {
            char *list = spc_devices_describe();
            defines_release(&defs);
            if (!list) {
                fail("out of memory");
                return EXIT_NOMEM;
            }
            fputs(list, stdout);
            free(list);
            return 0;
        } else if (opt_value(argc, argv, &i, "-D", NULL, &v)) {
            if (!defines_add(&defs, v))
                code = usage_error(usage_info, "-D needs name=value, not '%s'", v ? v : "");
        } else if (!strcmp(a, "--lenient")) {
            defs.names[defs.n] = NULL;
            defs.defs[defs.n].name = SPC_DEFINE_UNREFERENCED;
            defs.defs[defs.n].value = "warn";
            defs.n++;
            ++i;
        } else if (opt_value(argc, argv, &i, "--specular-nee", NULL, &v)) {
            if (v && strlen(v) >= SPC_SPECULAR_NEE_MAX)
                code = usage_error(usage_info, "--specular-nee is %zu characters long (at most %d)", strlen(v),
                                   SPC_SPECULAR_NEE_MAX - 1);
            info_snee = v;
        } else if (a[0] == '-' && a[1] != '\0') {
            code = usage_error(usage_info, "unknown option '%s'", a);
        } else {
            if (scene_path)
                code = usage_error(usage_info, "more than one scene given ('%s' and '%s')", scene_path, a);
            scene_path = a;
            ++i;
        }
    }
    if (code == 0 && !scene_path)
        code = usage_error(usage_info, "no scene given");
    if (code != 0) {
        defines_release(&defs);
        return code;
    }

    spc_scene *scene = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = spc_scene_load(scene_path, defs.defs, defs.n, &scene, &err);
    if (st != SPC_OK) {
        fail_error(&err);
        defines_release(&defs);
        return exit_code(st);
    }
    spc_scene_summary s;
    spc_scene_summarize(scene, &s);
    printf("scene: %s\n", scene_path);
    printf("shapes: %d (%d meshes, %d analytic)\n", s.shapes, s.meshes, s.analytic_shapes);
    printf("triangles: %llu\n", (unsigned long long)s.triangles);
    printf("bsdfs: %d\n", s.bsdfs);
    printf("emitters: %d\n", s.emitters);
    printf("textures: %d\n", s.textures);
    printf("bounding box: (%.6g, %.6g, %.6g) to (%.6g, %.6g, %.6g)\n", s.bbox_min[0], s.bbox_min[1], s.bbox_min[2],
           s.bbox_max[0], s.bbox_max[1], s.bbox_max[2]);
    printf("film: %dx%d, %d spp\n", s.width, s.height, s.spp);
    if (s.max_depth < 0)
        printf("integrator: %s (max_depth unbounded)\n", s.integrator);
    else
        printf("integrator: %s (max_depth %d)\n", s.integrator, s.max_depth);
    char *plan = spc_scene_plan(scene, NULL, info_snee);
    if (plan)
        fputs(plan, stdout);
    free(plan);
    char *desc = spc_scene_describe(scene);
    if (desc)
        fputs(desc, stdout);
    free(desc);
    spc_scene_destroy(scene);
    defines_release(&defs);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(usage_main, stderr);
        return EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--version") || !strcmp(cmd, "-V") || !strcmp(cmd, "version")) {
        printf("specula %s\n", SPECULA_VERSION);
        return 0;
    }
    if (is_help(cmd) || !strcmp(cmd, "help")) {
        fputs(usage_main, stdout);
        fputs(usage_exit, stdout);
        return 0;
    }
    if (!strcmp(cmd, "render"))
        return cmd_render(argc - 2, argv + 2);
    if (!strcmp(cmd, "diff"))
        return cmd_diff(argc - 2, argv + 2);
    if (!strcmp(cmd, "info"))
        return cmd_info(argc - 2, argv + 2);
    if (!strcmp(cmd, "denoise"))
        return cmd_denoise(argc - 2, argv + 2);
    if (!strcmp(cmd, "explore"))
        return spc_cli_explore(argc - 2, argv + 2);
    return usage_error(usage_main, "unknown command '%s'", cmd);
}
