/*
 * tools/specula.c: the `specula` command: render a Mitsuba scene, compare two images, describe a
 * scene. It uses nothing but the public header specula/specula.h, which proves the API suffices.
 *
 * Exit codes: 0 success, 2 usage, 3 bad input (scene or image), 4 render failure, 5 write failure,
 * 130 interrupted (after writing the image rendered so far). Errors are one line on stderr,
 * "specula: file:line:col: message". Images are written atomically by the library, and never
 * when loading or rendering failed, so an existing image is never replaced by a broken one.
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

#include "specula/specula.h"

enum {
    EXIT_USAGE = 2,       /* bad command line */
    EXIT_INPUT = 3,       /* the scene or an image could not be loaded */
    EXIT_RENDER = 4,      /* the renderer failed */
    EXIT_WRITE = 5,       /* an output could not be written */
    EXIT_INTERRUPTED = 130 /* SIGINT/SIGTERM: 128 + SIGINT, as shells report it */
};

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
    "\n"
    "  specula --version            print the version\n"
    "  specula <command> --help     options of a command\n";

static const char *const usage_render =
    "usage: specula render SCENE.xml [options]\n"
    "\n"
    "  -o, --output OUT.exr   output image (default: the scene's name with .exr, in the current\n"
    "                         directory); a PNG preview is written beside it (OUT.png)\n"
    "  --spp N                samples per pixel (default: the scene's)\n"
    "  --time SECONDS         render whole passes until the time is up (--spp then caps)\n"
    "  --threads N            worker threads (default: all cores)\n"
    "  --seed S               random seed (default 0)\n"
    "  --res WxH              film size (default: the scene's)\n"
    "  --integrator NAME      path, ipt, bdpt or volpath (default: the scene's)\n"
    "  --specular-nee NAME[:OPTS]  none, angular, newton or conic (default: the scene's); OPTS,\n"
    "                         comma-separated: unbiased (default: one solution, 1/p by Bernoulli\n"
    "                         trials) or biased[=M] (M seeds, distinct solutions summed; M 8),\n"
    "                         trials=N (cap; 256 angular, 64 others), seed=cone|shape|light|bsdf\n"
    "                         (default cone); newton: constraint=angle|half, rough (rough\n"
    "                         interfaces as chain vertices); nomis (covered BSDF paths dropped);\n"
    "                         reflect[=P] (chains also reflect off glass, with probability P at a\n"
    "                         dielectric vertex; 0.2; angular's and conic's default), noreflect;\n"
    "                         mispsi=Q (MIS: randomized attempts' chains weighted as if found\n"
    "                         with probability Q; 0.1); receivers=N (only at the first N\n"
    "                         diffuse or glossy vertices of a path); camera[=Q] (also from\n"
    "                         the pinhole, Q of the samples: lights seen through glass);\n"
    "                         chain=N (longest chain; default the scene's, 2); noexact (no\n"
    "                         exact chains on a sphere, mirror cylinder, normal-mapped plane);\n"
    "                         long=P, nolong (longer chains, P per call; 0.1);\n"
    "                         guide[=M] (guided directions in cones M x the light's image; 1),\n"
    "                         sneep=Q (then the light sample only with probability Q);\n"
    "                         e.g. --specular-nee newton:biased=8\n"
    "  --max-depth N          longest path, Mitsuba's meaning; -1 for no limit\n"
    "  -D name=value          override a <default name=... value=...> of the scene (repeatable)\n"
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
    "  --quiet                no progress bar or summary\n"
    "  --checkpoint FILE      save the render state to FILE (atomically) every --checkpoint-every\n"
    "                         seconds, and when the render ends or is interrupted\n"
    "  --checkpoint-every S   seconds between checkpoints (default 60; 0: after every pass)\n"
    "\n"
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

static const char *const usage_diff =
    "usage: specula diff A.exr B.exr [--json]\n"
    "\n"
    "Compares image A against the reference B: per-channel means, MSE, relMSE\n"
    "(mean of (a-b)^2 / (b^2 + 0.01)) and, when either image has variance channels, the fraction\n"
    "of pixels passing a z-test at alpha 0.01 (Sidak-corrected for the pixel count).\n"
    "  --json                 print the result as JSON\n";

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
    "usage: specula info SCENE.xml [-D name=value]...\n"
    "\n"
    "Prints the scene's shapes, triangles, BSDFs, emitters, bounding box, film and integrator,\n"
    "then one line per shape, BSDF and emitter.\n";

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
    if (!s || !*s)
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
    if (!s || !*s || *s == '-')
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

/* OUT.exr -> OUT.png; any other name gets ".png" appended. The caller frees. */
static char *png_path(const char *out)
{
    size_t len = strlen(out);
    if (len > 4 && !strcasecmp(out + len - 4, ".exr"))
        len -= 4;
    char *p = malloc(len + 5);
    if (!p)
        return NULL;
    memcpy(p, out, len);
    strcpy(p + len, ".png");
    return p;
}

/* True if the directory that will hold path exists and is writable (checked before rendering so a
 * long render is not wasted on a typo). */
static bool output_dir_ok(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return access(".", W_OK) == 0;
    size_t len = slash == path ? 1 : (size_t)(slash - path);
    char *dir = malloc(len + 1);
    if (!dir)
        return false;
    memcpy(dir, path, len);
    dir[len] = '\0';
    bool ok = access(dir, W_OK) == 0;
    free(dir);
    return ok;
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

static bool write_stats(const char *path, const spc_render_stats *st, const stats_info *in, char *why, size_t whylen)
{
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
    fprintf(fp, ",\n  \"mrays_per_second\": ");
    json_number(fp, st->mrays_per_second);
    fprintf(fp, ",\n  \"threads\": %d", st->threads);
    fprintf(fp, ",\n  \"samples\": %llu", (unsigned long long)st->samples);
    fprintf(fp, ",\n  \"invalid_samples\": %llu", (unsigned long long)st->invalid_samples);
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
    bool variance = false, quiet = false, denoise = false;
    defines defs;
    if (!defines_init(&defs, argc)) {
        fail("out of memory");
        return EXIT_RENDER;
    }
    int code = 0;
    for (int i = 0; i < argc && code == 0;) {
        const char *a = argv[i], *v = NULL;
        int i0 = i;
        if (is_help(a)) {
            fputs(usage_render, stdout);
            fputs(usage_render_denoise, stdout);
            defines_release(&defs);
            return 0;
        } else if (opt_value(argc, argv, &i, "--checkpoint-every", NULL, &v)) {
            if (!parse_double(v, &opt.checkpoint_every) || opt.checkpoint_every < 0.0)
                code = usage_error(usage_render, "--checkpoint-every needs a number of seconds >= 0, not '%s'",
                                   v ? v : "");
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
            if (!parse_double(v, &opt.time_limit) || opt.time_limit <= 0.0)
                code = usage_error(usage_render, "--time needs a positive number of seconds, not '%s'", v ? v : "");
        } else if (opt_value(argc, argv, &i, "--threads", NULL, &v)) {
            if (!parse_int(v, 0, 4096, &opt.threads))
                code = usage_error(usage_render, "--threads needs a count (0: all cores), not '%s'", v ? v : "");
        } else if (opt_value(argc, argv, &i, "--seed", NULL, &v)) {
            if (!parse_u64(v, &opt.seed))
                code = usage_error(usage_render, "--seed needs a non-negative integer, not '%s'", v ? v : "");
        } else if (opt_value(argc, argv, &i, "--res", NULL, &v)) {
            int w = 0, h = 0, n = 0;
            if (!v || sscanf(v, "%dx%d%n", &w, &h, &n) != 2 || v[n] != '\0' || w <= 0 || h <= 0)
                code = usage_error(usage_render, "--res needs WIDTHxHEIGHT, not '%s'", v ? v : "");
            opt.width = w;
            opt.height = h;
        } else if (opt_value(argc, argv, &i, "--integrator", NULL, &v)) {
            if (!v || !*v)
                code = usage_error(usage_render, "--integrator needs a name");
            opt.integrator = v;
        } else if (opt_value(argc, argv, &i, "--specular-nee", NULL, &v)) {
            if (!v)
                code = usage_error(usage_render, "--specular-nee needs a name");
            else if (!strcmp(v, "none") || !strcmp(v, "off"))
                v = "";
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
            int n = 0;
            if (!v || sscanf(v, "%d,%d%n", &opt.strategy_s, &opt.strategy_t, &n) != 2 || v[n] != '\0' ||
                opt.strategy_s < 0 || opt.strategy_t < 0)
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
        } else if (!strcmp(a, "--variance")) {
            variance = true;
            ++i;
        } else if (!strcmp(a, "--aovs")) {
            opt.aovs = true;
            ++i;
        } else if (!strcmp(a, "--denoise")) {
            denoise = opt.aovs = true;
            ++i;
        } else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) {
            quiet = true;
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
    char *png = out_path ? png_path(out_path) : NULL;
    spc_scene *scene = NULL;
    spc_film *film = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (!out_path || !png) {
        fail("out of memory");
        code = EXIT_RENDER;
        goto done;
    }
    if (!output_dir_ok(out_path)) {
        fail("%s: cannot write there: %s", out_path, strerror(errno));
        code = EXIT_WRITE;
        goto done;
    }
    if (strategy_dir && mkdir(strategy_dir, 0777) != 0 && errno != EEXIST) {
        fail("%s: cannot create the directory: %s", strategy_dir, strerror(errno));
        code = EXIT_WRITE;
        goto done;
    }
    if (ckpt_path) {
        if (!output_dir_ok(ckpt_path)) {
            fail("%s: cannot write there: %s", ckpt_path, strerror(errno));
            code = EXIT_WRITE;
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
        if (spc_denoise_load(NULL, 0, &err) != SPC_OK) {
            fail_error(&err);
            code = EXIT_RENDER;
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
    spc_status st = spc_scene_load(scene_path, defs.defs, defs.n, &scene, &err);
    if (st != SPC_OK) {
        fail_error(&err);
        code = EXIT_INPUT;
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
        code = resume && st == SPC_ERR_VALUE ? EXIT_INPUT : EXIT_RENDER;
        goto done;
    }
    if (!film) {
        if (interrupted) {
            fail("interrupted before the first pass finished; nothing written");
            code = EXIT_INTERRUPTED;
        } else {
            fail("the renderer returned no image");
            code = EXIT_RENDER;
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
    st = spc_film_write_exr(film, out_path, variance, &err);
    if (st == SPC_OK)
        st = spc_film_write_png(film, png, &err);
    if (st != SPC_OK) {
        fail_error(&err);
        code = EXIT_WRITE;
        goto done;
    }
    if (strategy_dir && !write_strategy_images(film, strategy_dir, variance)) {
        code = EXIT_WRITE;
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
        char why[256];
        if (!write_stats(stats_path, &stats, &info, why, sizeof why)) {
            fail("%s: cannot write statistics: %s", stats_path, why);
            code = EXIT_WRITE;
            goto done;
        }
    }
    if (!quiet)
        fprintf(stderr, "%s: %dx%d, %d spp, %.2f s, %.2f Mrays/s, %d threads%s -> %s, %s\n",
                interrupted ? "interrupted" : "rendered", spc_film_width(film), spc_film_height(film), stats.spp,
                stats.wall_seconds, stats.mrays_per_second, stats.threads,
                stats.invalid_samples ? " (some invalid samples discarded)" : "", out_path, png);
    code = ckpt_failed ? EXIT_WRITE : interrupted ? EXIT_INTERRUPTED : denoise_failed ? EXIT_RENDER : 0;

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
            fputs(usage_render_denoise, stdout);
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
    if (spc_checkpoint_load(resume_path, &ck, &err) != SPC_OK) {
        fail_error(&err);
        return EXIT_INPUT;
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
        return EXIT_RENDER;
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
        return EXIT_INPUT;
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

static int cmd_diff(int argc, char **argv)
{
    const char *paths[2] = {NULL, NULL};
    int npaths = 0;
    bool json = false;
    for (int i = 0; i < argc; ++i) {
        const char *a = argv[i];
        if (is_help(a)) {
            fputs(usage_diff, stdout);
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
    for (int k = 0; k < 2 && code == 0; ++k)
        if (spc_image_rgb_read(paths[k], &img[k], &err) != SPC_OK) {
            fail_error(&err);
            code = EXIT_INPUT;
        }
    spc_diff_result r;
    if (code == 0 && spc_image_diff(&img[0], &img[1], &r, &err) != SPC_OK) {
        fail("%s vs %s: %s", paths[0], paths[1], err.msg);
        code = EXIT_INPUT;
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
        printf("MSE: %.6g\n", r.mse);
        printf("relMSE: %.6g\n", r.rel_mse);
        if (r.has_ztest)
            printf("z-test: %.4f%% of %d pixels pass (alpha 0.01, Sidak-corrected)\n",
                   100.0 * r.ztest_pass_fraction, r.ztest_pixels);
        else
            printf("z-test: no variance channels\n");
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
    if (!output_dir_ok(out)) {
        fail("%s: cannot write there: %s", out, strerror(errno));
        return EXIT_WRITE;
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
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = spc_denoise_exr(in, out, &dopt, &ds, &err);
    if (prog.drawn)
        fputc('\n', stderr);
    pthread_mutex_destroy(&prog.mu);
    if (st != SPC_OK) {
        fail_error(&err);
        return st == SPC_ERR_PARSE || (st == SPC_ERR_IO && !strcmp(err.file, in)) ? EXIT_INPUT
               : st == SPC_ERR_IO && !strcmp(err.file, out)                       ? EXIT_WRITE
                                                                                  : EXIT_RENDER;
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
    const char *scene_path = NULL;
    defines defs;
    if (!defines_init(&defs, argc)) {
        fail("out of memory");
        return EXIT_INPUT;
    }
    int code = 0;
    for (int i = 0; i < argc && code == 0;) {
        const char *a = argv[i], *v = NULL;
        if (is_help(a)) {
            fputs(usage_info, stdout);
            defines_release(&defs);
            return 0;
        } else if (opt_value(argc, argv, &i, "-D", NULL, &v)) {
            if (!defines_add(&defs, v))
                code = usage_error(usage_info, "-D needs name=value, not '%s'", v ? v : "");
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
    if (spc_scene_load(scene_path, defs.defs, defs.n, &scene, &err) != SPC_OK) {
        fail_error(&err);
        defines_release(&defs);
        return EXIT_INPUT;
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
    return usage_error(usage_main, "unknown command '%s'", cmd);
}
