/*
 * render/film_denoise.c: spc_film_denoise (specula.h), a resolved film denoised in place. The film's
 * albedo and normal AOVs, when it has them, are the auxiliary images; the denoising itself is
 * spc_denoise_rgb (denoise/denoise.c), which sits below the render layer and knows no film. The
 * noisy image is kept (f->noisy) for the EXR's noisy.* channels.
 */
#include <stdlib.h>

#include "render/film.h"
#include "specula/specula.h"

spc_status spc_film_denoise(struct spc_film *f, const spc_denoise_options *o, spc_denoise_stats *stats, spc_error *err)
{
    if (!f || !f->rgb)
        return spc_error_set(err, SPC_ERR_INTERNAL, NULL, 0, 0, "denoise: the film has not been resolved");
    if (f->noisy)
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "denoise: the film is denoised already");
    size_t npix = (size_t)f->width * (size_t)f->height;
    float *out = malloc(3 * npix * sizeof(float));
    float *albedo = NULL, *normal = NULL;
    bool aux = f->has_aovs && f->aov;
    if (aux) {
        albedo = malloc(3 * npix * sizeof(float));
        normal = malloc(3 * npix * sizeof(float));
    }
    spc_status st = SPC_OK;
    if (!out || (aux && (!albedo || !normal))) {
        st =
            spc_error_set(err, SPC_ERR_NOMEM, NULL, 0, 0, "out of memory denoising a %dx%d image", f->width, f->height);
    } else {
        for (size_t i = 0; aux && i < npix; ++i)
            for (int c = 0; c < 3; ++c) {
                albedo[3 * i + (size_t)c] = f->aov[SPC_FILM_AOVS * i + (size_t)c];
                normal[3 * i + (size_t)c] = f->aov[SPC_FILM_AOVS * i + 3 + (size_t)c];
            }
        st = spc_denoise_rgb(f->width, f->height, f->rgb, albedo, normal, out, o, stats, err);
    }
    free(albedo);
    free(normal);
    if (st != SPC_OK) {
        free(out);
        return st;
    }
    f->noisy = f->rgb;
    f->rgb = out;
    return SPC_OK;
}
