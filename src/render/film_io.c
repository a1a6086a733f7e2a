/*
 * render/film_io.c: writes a resolved film as an EXR (mean, optionally the variance of the mean,
 * and the AOVs) and as an 8-bit sRGB PNG preview. Both go through io/image_io's atomic writers
 * (temporary file, then rename), so a failure never leaves a half-written image behind.
 *
 * EXR channel names: R, G, B; variance.R, variance.G, variance.B; albedo.R, albedo.G, albedo.B,
 * normal.X, normal.Y, normal.Z, depth.Z. String attributes: "spp", "renderer",
 * "integrator" and "specular_nee" (the setting that ran; empty for a film not rendered), and
 * "denoiser" for a denoised film. A denoised film (spc_film_denoise) writes the denoised image as
 * R, G, B, the image before as noisy.R, noisy.G, noisy.B, and its variance as
 * noisy.variance.R/G/B (the denoised image has none).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "io/image_io.h"
#include "render/film.h"
#include "specula/specula.h"

/* rgb + noisy rgb + variance rgb + the AOVs: --aovs' 7, or an aov integrator's outputs (3 each)
 * and its nested integrator's image again */
#define FILM_IO_MAX_CHANNELS (12 + 3 * SPC_MAX_AOV_OUTPUTS)

static spc_status check_resolved(const struct spc_film *f, const char *path, spc_error *err)
{
    if (!f || !path)
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "no film or no output path");
    if (!f->rgb || f->width <= 0 || f->height <= 0)
        return spc_error_set(err, SPC_ERR_INTERNAL, path, 0, 0, "the film has not been resolved");
    return SPC_OK;
}

spc_status spc_film_write_exr(const struct spc_film *f, const char *path, bool variance, spc_error *err)
{
    spc_status st = check_resolved(f, path, err);
    if (st != SPC_OK)
        return st;
    if (variance && !f->var)
        return spc_error_set(err, SPC_ERR_INTERNAL, path, 0, 0, "the film has no resolved variance");
    bool aovs = f->has_aovs && f->aov;

    const char *names[FILM_IO_MAX_CHANNELS];
    char named[FILM_IO_MAX_CHANNELS][64];
    int src[FILM_IO_MAX_CHANNELS]; /* per AOV channel: its index in the film's AOVs, or -1 - k for rgb k */
    int naov = 0;
    int nch = 0;
    names[nch++] = "R";
    names[nch++] = "G";
    names[nch++] = "B";
    if (f->noisy) {
        names[nch++] = "noisy.R";
        names[nch++] = "noisy.G";
        names[nch++] = "noisy.B";
    }
    if (variance) {
        names[nch++] = f->noisy ? "noisy.variance.R" : "variance.R";
        names[nch++] = f->noisy ? "noisy.variance.G" : "variance.G";
        names[nch++] = f->noisy ? "noisy.variance.B" : "variance.B";
    }
    if (aovs && f->naov_out > 0) {
        /* as Mitsuba 3's aov integrator: the nested integrator's image, then each AOV */
        static const char *rgb_s[3] = {"R", "G", "B"}, *xyz_s[3] = {"X", "Y", "Z"};
        if (f->aov_image[0])
            for (int k = 0; k < 3; ++k) {
                snprintf(named[naov], sizeof named[naov], "%s.%s", f->aov_image, rgb_s[k]);
                src[naov++] = -1 - k;
            }
        for (int a = 0; a < f->naov_out; ++a) {
            const spc_aov_output *o = &f->aov_out[a];
            int first = 0, n = 3;
            const char **suffix = xyz_s;
            switch (o->type) {
            case SPC_AOV_ALBEDO: first = 0; suffix = rgb_s; break;
            case SPC_AOV_SH_NORMAL: first = 3; break;
            case SPC_AOV_DEPTH: first = 6; n = 1; break;
            case SPC_AOV_POSITION: first = 7; break;
            }
            for (int k = 0; k < n; ++k) {
                snprintf(named[naov], sizeof named[naov], "%s.%s", o->name, n == 1 ? "T" : suffix[k]);
                src[naov++] = first + k;
            }
        }
        for (int k = 0; k < naov; ++k)
            names[nch++] = named[k];
    } else if (aovs) {
        names[nch++] = "albedo.R";
        names[nch++] = "albedo.G";
        names[nch++] = "albedo.B";
        names[nch++] = "normal.X";
        names[nch++] = "normal.Y";
        names[nch++] = "normal.Z";
        names[nch++] = "depth.Z";
    }

    size_t npix = (size_t)f->width * (size_t)f->height;
    float *data = malloc(npix * (size_t)nch * sizeof(float));
    if (!data)
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory writing a %dx%d image", f->width,
                             f->height);
    for (size_t i = 0; i < npix; ++i) {
        float *px = data + i * (size_t)nch;
        int c = 0;
        for (int k = 0; k < 3; ++k)
            px[c++] = f->rgb[3 * i + (size_t)k];
        if (f->noisy)
            for (int k = 0; k < 3; ++k)
                px[c++] = f->noisy[3 * i + (size_t)k];
        if (variance)
            for (int k = 0; k < 3; ++k)
                px[c++] = f->var[3 * i + (size_t)k];
        if (aovs && f->naov_out > 0)
            for (int k = 0; k < naov; ++k)
                px[c++] = src[k] < 0 ? f->rgb[3 * i + (size_t)(-1 - src[k])]
                                     : f->aov[SPC_FILM_AOVS * i + (size_t)src[k]];
        else if (aovs)
            for (int k = 0; k < 7; ++k)
                px[c++] = f->aov[SPC_FILM_AOVS * i + (size_t)k];
    }

    char spp[32];
    snprintf(spp, sizeof spp, "%d", f->spp);
    const spc_exr_attr attrs[] = {
        {"spp", spp},
        {"renderer", "specula " SPECULA_VERSION},
        {"integrator", f->integrator},
        {"specular_nee", f->specular_nee},
        {"denoiser", "Intel Open Image Denoise 2 (RT filter, hdr; noisy image in noisy.*)"}, /* last: only when denoised */
    };
    int nattrs = (int)(sizeof attrs / sizeof attrs[0]) - (f->noisy ? 0 : 1);
    st = spc_exr_write(path, f->width, f->height, nch, names, data, attrs, nattrs, err);
    free(data);
    return st;
}

spc_status spc_film_write_png(const struct spc_film *f, const char *path, spc_error *err)
{
    spc_status st = check_resolved(f, path, err);
    if (st != SPC_OK)
        return st;
    return spc_png_write_srgb(path, f->width, f->height, f->rgb, err);
}

spc_image_format spc_image_format_of(const char *path)
{
    static const struct {
        const char *ext;
        spc_image_format format;
    } formats[] = {
        {".exr", SPC_FORMAT_EXR},
        {".png", SPC_FORMAT_PNG},
        {".pfm", SPC_FORMAT_PFM},
        {".hdr", SPC_FORMAT_HDR},
    };
    const char *slash = path ? strrchr(path, '/') : NULL;
    const char *dot = path ? strrchr(slash ? slash : path, '.') : NULL;
    if (!dot)
        return SPC_FORMAT_UNKNOWN;
    for (size_t i = 0; i < sizeof formats / sizeof formats[0]; ++i)
        if (strcasecmp(dot, formats[i].ext) == 0)
            return formats[i].format;
    return SPC_FORMAT_UNKNOWN;
}

spc_status spc_film_write(const struct spc_film *f, const char *path, bool variance, spc_error *err)
{
    spc_image_format format = spc_image_format_of(path);
    if (format != SPC_FORMAT_EXR && (variance || (f && f->has_aovs)))
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0,
                             "the variance and AOV channels can only be written to an .exr file");
    spc_status st = check_resolved(f, path, err);
    if (st != SPC_OK)
        return st;
    switch (format) {
    case SPC_FORMAT_EXR: return spc_film_write_exr(f, path, variance, err);
    case SPC_FORMAT_PNG: return spc_png_write_srgb(path, f->width, f->height, f->rgb, err);
    case SPC_FORMAT_PFM: return spc_pfm_write(path, f->width, f->height, f->rgb, err);
    case SPC_FORMAT_HDR: return spc_hdr_write(path, f->width, f->height, f->rgb, err);
    case SPC_FORMAT_UNKNOWN: break;
    }
    return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "unknown image format: name it .exr, .png, .pfm or .hdr");
}
