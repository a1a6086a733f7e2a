/*
 * denoise/denoise.c: the public denoising calls (specula.h) on an image in memory and on an EXR
 * file (a resolved film is denoised by render/film_denoise.c through spc_denoise_rgb). Each
 * prepares the inputs OIDN is given (denoise/oidn.c runs it):
 *
 * - No NaN or infinite value reaches OIDN: such a value is given as 0 and its pixel counted
 *   (spc_denoise_stats.nonfinite_pixels), since a single one spreads over the filter's whole
 *   receptive field.
 * - The albedo is clamped to [0, 1] and the normal to [-1, 1], the ranges OIDN requires.
 * - Without AOVs the image is denoised alone (stats->used_aux false; the CLI warns).
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "denoise/oidn.h"
#include "io/image_io.h"
#include "specula/specula.h"

void spc_denoise_options_init(spc_denoise_options *o)
{
    memset(o, 0, sizeof *o);
    o->prefilter = true;
}

spc_status spc_denoise_load(char *library, size_t size, spc_error *err) { return spc_oidn_load(library, size, err); }

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static float finite_clamped(float v, float lo, float hi, bool *bad)
{
    if (!isfinite(v)) {
        *bad = true;
        return 0.0f;
    }
    return v < lo ? lo : (v > hi ? hi : v);
}

spc_status spc_denoise_rgb(int width, int height, const float *rgb, const float *albedo, const float *normal,
                           float *out, const spc_denoise_options *o, spc_denoise_stats *stats, spc_error *err)
{
    spc_denoise_options defaults;
    if (!o) {
        spc_denoise_options_init(&defaults);
        o = &defaults;
    }
    spc_denoise_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    double t0 = now_seconds();
    if (width <= 0 || height <= 0 || !rgb || !out)
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "denoise: no image");
    if ((!albedo) != (!normal))
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "denoise: albedo and normal go together");
    if ((size_t)width * (size_t)height > ((size_t)1 << 30))
        return spc_error_set(err, SPC_ERR_LIMIT, NULL, 0, 0, "denoise: %dx%d is too large", width, height);
    const bool aux = albedo != NULL;
    size_t n = 3 * (size_t)width * (size_t)height;
    float *color = malloc(n * sizeof(float));
    float *a = aux ? malloc(n * sizeof(float)) : NULL, *nn = aux ? malloc(n * sizeof(float)) : NULL;
    if (!color || (aux && (!a || !nn))) {
        free(color);
        free(a);
        free(nn);
        return spc_error_set(err, SPC_ERR_NOMEM, NULL, 0, 0, "out of memory denoising a %dx%d image", width, height);
    }
    for (size_t p = 0; p < n / 3; ++p) {
        bool bad = false;
        for (int c = 0; c < 3; ++c) {
            size_t i = 3 * p + (size_t)c;
            color[i] = finite_clamped(rgb[i], -FLT_MAX, FLT_MAX, &bad);
            if (aux) {
                a[i] = finite_clamped(albedo[i], 0.0f, 1.0f, &bad);
                nn[i] = finite_clamped(normal[i], -1.0f, 1.0f, &bad);
            }
        }
        stats->nonfinite_pixels += bad;
    }
    spc_status st = spc_oidn_denoise(width, height, color, a, nn, out, o->prefilter, o->threads, o->progress,
                                     o->progress_user, stats->library, sizeof stats->library, err);
    stats->used_aux = aux;
    stats->seconds = now_seconds() - t0;
    free(color);
    free(a);
    free(nn);
    return st;
}

/* The channels `specula denoise` reads, in this order (slots below). */
static const char *const exr_in_names[] = {
    "R",          "G",          "B",          "noisy.R",          "noisy.G",          "noisy.B",
    "variance.R", "variance.G", "variance.B", "noisy.variance.R", "noisy.variance.G", "noisy.variance.B",
    "albedo.R",   "albedo.G",   "albedo.B",   "normal.X",         "normal.Y",         "normal.Z",
    "depth.Z",
};
enum {
    IN_RGB = 0,
    IN_NOISY = 3,
    IN_VAR = 6,
    IN_NOISY_VAR = 9,
    IN_ALBEDO = 12,
    IN_NORMAL = 15,
    IN_DEPTH = 18,
    IN_COUNT = 19
};
_Static_assert(sizeof exr_in_names / sizeof exr_in_names[0] == IN_COUNT, "one name per slot");

static bool have3(const bool *found, int slot) { return found[slot] && found[slot + 1] && found[slot + 2]; }

spc_status spc_denoise_exr(const char *in, const char *out, const spc_denoise_options *o, spc_denoise_stats *stats,
                           spc_error *err)
{
    if (!in || !out)
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "denoise: no input or output path");
    int w = 0, h = 0;
    float *px = NULL;
    bool found[IN_COUNT];
    spc_status st = spc_exr_read_channels(in, IN_COUNT, exr_in_names, &w, &h, &px, found, err);
    if (st != SPC_OK)
        return st;
    /* an image denoised before is denoised again from its noisy channels */
    int src = have3(found, IN_NOISY) ? IN_NOISY : IN_RGB;
    int var = have3(found, IN_NOISY_VAR) ? IN_NOISY_VAR : have3(found, IN_VAR) ? IN_VAR : -1;
    bool aux = have3(found, IN_ALBEDO) && have3(found, IN_NORMAL), depth = found[IN_DEPTH];
    if (!have3(found, src)) {
        free(px);
        return spc_error_set(err, SPC_ERR_PARSE, in, 0, 0, "no R, G, B channels to denoise");
    }
    size_t npix = (size_t)w * (size_t)h;
    float *color = malloc(3 * npix * sizeof(float)), *den = malloc(3 * npix * sizeof(float));
    float *albedo = aux ? malloc(3 * npix * sizeof(float)) : NULL,
          *normal = aux ? malloc(3 * npix * sizeof(float)) : NULL;
    int nch = 6 + (var >= 0 ? 3 : 0) + (aux ? 6 : 0) + (depth ? 1 : 0);
    float *data = malloc(npix * (size_t)nch * sizeof(float));
    if (!color || !den || !data || (aux && (!albedo || !normal))) {
        st = spc_error_set(err, SPC_ERR_NOMEM, in, 0, 0, "out of memory denoising a %dx%d image", w, h);
        goto done;
    }
    for (size_t p = 0; p < npix; ++p)
        for (int c = 0; c < 3; ++c) {
            const float *q = px + p * IN_COUNT;
            color[3 * p + (size_t)c] = q[src + c];
            if (aux) {
                albedo[3 * p + (size_t)c] = q[IN_ALBEDO + c];
                normal[3 * p + (size_t)c] = q[IN_NORMAL + c];
            }
        }
    st = spc_denoise_rgb(w, h, color, albedo, normal, den, o, stats, err);
    if (st != SPC_OK)
        goto done;
    const char *names[16];
    int k = 0;
    for (int c = 0; c < 3; ++c)
        names[k++] = exr_in_names[IN_RGB + c];
    for (int c = 0; c < 3; ++c)
        names[k++] = exr_in_names[IN_NOISY + c];
    if (var >= 0)
        for (int c = 0; c < 3; ++c)
            names[k++] = exr_in_names[IN_NOISY_VAR + c];
    if (aux)
        for (int c = 0; c < 6; ++c)
            names[k++] = exr_in_names[IN_ALBEDO + c];
    if (depth)
        names[k++] = exr_in_names[IN_DEPTH];
    for (size_t p = 0; p < npix; ++p) {
        const float *q = px + p * IN_COUNT;
        float *d = data + p * (size_t)nch;
        int j = 0;
        for (int c = 0; c < 3; ++c)
            d[j++] = den[3 * p + (size_t)c];
        for (int c = 0; c < 3; ++c)
            d[j++] = q[src + c];
        if (var >= 0)
            for (int c = 0; c < 3; ++c)
                d[j++] = q[var + c];
        if (aux)
            for (int c = 0; c < 6; ++c)
                d[j++] = q[IN_ALBEDO + c];
        if (depth)
            d[j++] = q[IN_DEPTH];
    }
    const spc_exr_attr attrs[] = {
        {"renderer", "specula " SPECULA_VERSION},
        {"denoiser", "Intel Open Image Denoise 2 (RT filter, hdr; noisy image in noisy.*)"},
    };
    st = spc_exr_write(out, w, h, nch, names, data, attrs, 2, err);
done:
    free(px);
    free(color);
    free(den);
    free(albedo);
    free(normal);
    free(data);
    return st;
}
