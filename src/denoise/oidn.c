/*
 * denoise/oidn.c: finds and loads Intel Open Image Denoise at run time and runs its RT filter
 * (oidn.h says where it looks). The library is loaded once per process and never unloaded (its
 * thread pool does not survive dlclose).
 *
 * A run, as OIDN's documentation recommends for final frames: with auxiliary images, each of
 * albedo and normal is denoised in place by an RT filter of its own, then the beauty filter gets
 * them with cleanAux set; "hdr" is set (the film is linear radiance); quality is OIDN's default
 * (high). The CPU device is asked for explicitly, so the result does not depend on a GPU being
 * present.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <glob.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "denoise/oidn.h"

/* OIDN's C API, the part used here (include/OpenImageDenoise/oidn.h of OIDN 2.x). */
typedef struct oidn_device_impl *oidn_device;
typedef struct oidn_filter_impl *oidn_filter;
typedef bool (*oidn_progress_fn)(void *user, double n);
#define OIDN_DEVICE_TYPE_CPU 1
#define OIDN_FORMAT_FLOAT3 3
#define OIDN_ERROR_NONE 0

typedef struct oidn_api {
    oidn_device (*new_device)(int type);
    void (*set_device_int)(oidn_device d, const char *name, int value);
    void (*commit_device)(oidn_device d);
    int (*get_device_error)(oidn_device d, const char **message);
    void (*release_device)(oidn_device d);
    oidn_filter (*new_filter)(oidn_device d, const char *type);
    void (*set_shared_filter_image)(oidn_filter f, const char *name, void *ptr, int format, size_t w, size_t h,
                                    size_t byte_offset, size_t pixel_stride, size_t row_stride);
    void (*set_filter_bool)(oidn_filter f, const char *name, bool value);
    void (*set_filter_progress)(oidn_filter f, oidn_progress_fn fn, void *user);
    void (*commit_filter)(oidn_filter f);
    void (*execute_filter)(oidn_filter f);
    void (*release_filter)(oidn_filter f);
} oidn_api;

/* The symbols, in the order of oidn_api's members. */
static const char *const oidn_symbols[] = {
    "oidnNewDevice",
    "oidnSetDeviceInt",
    "oidnCommitDevice",
    "oidnGetDeviceError",
    "oidnReleaseDevice",
    "oidnNewFilter",
    "oidnSetSharedFilterImage",
    "oidnSetFilterBool",
    "oidnSetFilterProgressMonitorFunction",
    "oidnCommitFilter",
    "oidnExecuteFilter",
    "oidnReleaseFilter",
};
#define OIDN_NSYMBOLS (sizeof oidn_symbols / sizeof oidn_symbols[0])
_Static_assert(sizeof(oidn_api) == OIDN_NSYMBOLS * sizeof(void (*)(void)), "one symbol per member");

static pthread_mutex_t load_mu = PTHREAD_MUTEX_INITIALIZER;
static bool loaded;
static oidn_api api;
static char loaded_path[1024];

#define TRIED_MAX 2048 /* the list of places tried, for the error message */

static void tried_add(char *tried, const char *what)
{
    size_t n = strlen(tried);
    if (n + strlen(what) + 3 < TRIED_MAX)
        snprintf(tried + n, TRIED_MAX - n, "%s%s", n ? ", " : "", what);
}

/* dlopen path and resolve every symbol; on failure *why says what went wrong. */
static bool try_open(const char *path, char *tried, char *why, size_t whysize)
{
    tried_add(tried, path);
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        const char *e = dlerror();
        snprintf(why, whysize, "%s", e ? e : "dlopen failed");
        return false;
    }
    oidn_api a;
    void **slots = (void **)&a;
    for (size_t i = 0; i < OIDN_NSYMBOLS; ++i) {
        slots[i] = dlsym(lib, oidn_symbols[i]);
        if (!slots[i]) {
            snprintf(why, whysize, "%s has no %s (not Open Image Denoise 2.x?)", path, oidn_symbols[i]);
            dlclose(lib);
            return false;
        }
    }
    api = a;
    snprintf(loaded_path, sizeof loaded_path, "%s", path);
    /* dlopen by bare name: report the file the loader found */
    Dl_info info;
    if (strchr(path, '/') == NULL && dladdr(slots[0], &info) && info.dli_fname)
        snprintf(loaded_path, sizeof loaded_path, "%s", info.dli_fname);
    return true;
}

static bool is_dir(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

static bool file_exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISREG(st.st_mode);
}

/* The library inside a site-packages folder's pyoidn package, if there. */
static bool try_site(const char *site, char *tried, char *why, size_t whysize)
{
    char p[1024];
    snprintf(p, sizeof p, "%s/pyoidn/oidn/lib/" SPC_OIDN_SONAME, site);
    if (!file_exists(p)) {
        tried_add(tried, p);
        return false;
    }
    return try_open(p, tried, why, whysize);
}

/* The folder of the pyoidn package that `python3` imports, or "" (stderr discarded). */
static void python_package_dir(char *out, size_t size)
{
    out[0] = '\0';
    FILE *fp = popen("python3 -c \"import importlib.util as u, os; s = u.find_spec('pyoidn'); "
                     "print(os.path.dirname(s.origin) if s and s.origin else '')\" 2>/dev/null",
                     "r");
    if (!fp)
        return;
    if (!fgets(out, (int)size, fp))
        out[0] = '\0';
    pclose(fp);
    out[strcspn(out, "\r\n")] = '\0';
}

static bool try_glob(const char *pattern, char *tried, char *why, size_t whysize)
{
    glob_t g;
    bool ok = false;
    if (glob(pattern, 0, NULL, &g) == 0)
        for (size_t i = 0; i < g.gl_pathc && !ok; ++i)
            ok = try_site(g.gl_pathv[i], tried, why, whysize);
    else
        tried_add(tried, pattern);
    globfree(&g);
    return ok;
}

static spc_status load_library(spc_error *err)
{
    char tried[TRIED_MAX] = "", why[1024] = "";
    const char *env = getenv(SPC_OIDN_ENV);
    if (env && *env) {
        char p[1024];
        if (is_dir(env))
            snprintf(p, sizeof p, "%s/" SPC_OIDN_SONAME, env);
        else
            snprintf(p, sizeof p, "%s", env);
        if (try_open(p, tried, why, sizeof why))
            return SPC_OK;
        return spc_error_set(err, SPC_ERR_IO, p, 0, 0,
                             "cannot load Open Image Denoise from " SPC_OIDN_ENV " (%s); " SPC_OIDN_INSTALL_HINT, why);
    }
    if (try_open(SPC_OIDN_SONAME, tried, why, sizeof why))
        return SPC_OK;
#ifdef SPC_OIDN_CONFIGURED_DIR
    if (SPC_OIDN_CONFIGURED_DIR[0] && try_site(SPC_OIDN_CONFIGURED_DIR, tried, why, sizeof why))
        return SPC_OK;
#endif
    char pkg[1024];
    python_package_dir(pkg, sizeof pkg);
    if (pkg[0]) {
        char p[1200];
        snprintf(p, sizeof p, "%s/oidn/lib/" SPC_OIDN_SONAME, pkg);
        if (try_open(p, tried, why, sizeof why))
            return SPC_OK;
    } else {
        tried_add(tried, "python3's pyoidn package (none)");
    }
    const char *venv = getenv("VIRTUAL_ENV"), *home = getenv("HOME");
    char pat[1024];
    if (venv && *venv) {
        snprintf(pat, sizeof pat, "%s/lib/python3*/site-packages", venv);
        if (try_glob(pat, tried, why, sizeof why))
            return SPC_OK;
    }
    if (home && *home) {
        snprintf(pat, sizeof pat, "%s/.local/lib/python3*/site-packages", home);
        if (try_glob(pat, tried, why, sizeof why))
            return SPC_OK;
    }
    if (try_glob("/usr/local/lib/python3*/dist-packages", tried, why, sizeof why) ||
        try_glob("/usr/local/lib/python3*/site-packages", tried, why, sizeof why) ||
        try_glob("/usr/lib/python3/dist-packages", tried, why, sizeof why))
        return SPC_OK;
    return spc_error_set(err, SPC_ERR_IO, NULL, 0, 0,
                         "Open Image Denoise (" SPC_OIDN_SONAME ") not found; %s (tried: %s)", SPC_OIDN_INSTALL_HINT,
                         tried);
}

spc_status spc_oidn_load(char *library, size_t size, spc_error *err)
{
    pthread_mutex_lock(&load_mu);
    spc_status st = SPC_OK;
    if (!loaded) {
        st = load_library(err);
        loaded = st == SPC_OK;
    }
    if (st == SPC_OK && library && size > 0)
        snprintf(library, size, "%s", loaded_path);
    pthread_mutex_unlock(&load_mu);
    return st;
}

/* Progress over the whole run: filter k of n reports its own fraction. */
typedef struct progress_span {
    spc_oidn_progress_fn fn;
    void *user;
    int k, n;
} progress_span;

static bool on_oidn_progress(void *user, double n)
{
    progress_span *s = user;
    if (s->fn)
        s->fn(s->user, ((double)s->k + (n < 0.0 ? 0.0 : n > 1.0 ? 1.0 : n)) / (double)s->n);
    return true; /* never cancel */
}

static spc_status device_error(oidn_device d, const char *what, spc_error *err)
{
    const char *msg = NULL;
    int code = api.get_device_error(d, &msg);
    if (code == OIDN_ERROR_NONE)
        return SPC_OK;
    return spc_error_set(err, SPC_ERR_INTERNAL, loaded_path, 0, 0, "Open Image Denoise failed %s (error %d): %s", what,
                         code, msg ? msg : "no message");
}

/* Runs one RT filter: input images named names[i] (NULL-terminated), output into out. */
static spc_status run_filter(oidn_device d, int w, int h, const char *const *names, float *const *images, float *out,
                             bool hdr, bool clean_aux, progress_span *span, const char *what, spc_error *err)
{
    oidn_filter f = api.new_filter(d, "RT");
    spc_status st = device_error(d, what, err);
    if (st != SPC_OK || !f) {
        if (f)
            api.release_filter(f);
        return st != SPC_OK ? st : spc_error_set(err, SPC_ERR_INTERNAL, loaded_path, 0, 0, "no RT filter");
    }
    for (int i = 0; names[i]; ++i)
        api.set_shared_filter_image(f, names[i], images[i], OIDN_FORMAT_FLOAT3, (size_t)w, (size_t)h, 0, 0, 0);
    api.set_shared_filter_image(f, "output", out, OIDN_FORMAT_FLOAT3, (size_t)w, (size_t)h, 0, 0, 0);
    if (hdr)
        api.set_filter_bool(f, "hdr", true);
    if (clean_aux)
        api.set_filter_bool(f, "cleanAux", true);
    api.set_filter_progress(f, on_oidn_progress, span);
    api.commit_filter(f);
    st = device_error(d, what, err);
    if (st == SPC_OK) {
        api.execute_filter(f);
        st = device_error(d, what, err);
    }
    api.release_filter(f);
    return st;
}

spc_status spc_oidn_denoise(int w, int h, const float *color, float *albedo, float *normal, float *out, bool prefilter,
                            int threads, spc_oidn_progress_fn progress, void *progress_user, char *library, size_t size,
                            spc_error *err)
{
    if (w <= 0 || h <= 0 || !color || !out || (!albedo) != (!normal))
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "denoise: bad image arguments");
    spc_status st = spc_oidn_load(library, size, err);
    if (st != SPC_OK)
        return st;
    oidn_device d = api.new_device(OIDN_DEVICE_TYPE_CPU);
    if (!d)
        return spc_error_set(err, SPC_ERR_INTERNAL, loaded_path, 0, 0,
                             "Open Image Denoise has no CPU device (its libOpenImageDenoise_device_cpu is missing "
                             "beside the library?)");
    if (threads > 0)
        api.set_device_int(d, "numThreads", threads);
    api.commit_device(d);
    st = device_error(d, "to start its CPU device", err);
    const bool aux = albedo != NULL, pre = aux && prefilter;
    progress_span span = {progress, progress_user, 0, pre ? 3 : 1};
    if (st == SPC_OK && pre) {
        const char *an[] = {"albedo", NULL}, *nn[] = {"normal", NULL};
        float *ai[] = {albedo}, *ni[] = {normal};
        st = run_filter(d, w, h, an, ai, albedo, false, false, &span, "on the albedo", err);
        span.k = 1;
        if (st == SPC_OK)
            st = run_filter(d, w, h, nn, ni, normal, false, false, &span, "on the normals", err);
        span.k = 2;
    }
    if (st == SPC_OK) {
        const char *names[] = {"color", aux ? "albedo" : NULL, "normal", NULL};
        float *images[] = {(float *)color, albedo, normal};
        st = run_filter(d, w, h, names, images, out, true, pre, &span, "on the image", err);
    }
    api.release_device(d);
    return st;
}
