/*
 * render/diff.c: reading RGB images (with the variance of the mean when an EXR has it) and comparing
 * an image against a reference, for `specula diff` and the end-to-end scene tests.
 *
 * Error measures: per-channel means, MSE and relMSE = mean((a-b)^2 / (b^2 + 0.01)) over every pixel
 * and channel (the 0.01 keeps dark reference pixels from dominating, as in the rendering papers'
 * "relative MSE").
 *
 * Statistical test (when a or b carries variance channels), after Mitsuba 3's test_renders.py: for
 * every pixel and channel z = (a - b) / sqrt(var_a + var_b), two-sided p = erfc(|z| / sqrt 2).
 * The three channels of a pixel are combined by the smallest p with a Sidak correction,
 * p_pixel = 1 - (1 - p_min)^k over its k channels with nonzero variance: the probability that the
 * largest |z| of k independent standard normals is at least the observed one. We chose this over
 * a chi-square with 3 degrees of freedom because it does not dilute one badly wrong channel among
 * two good ones, and it needs no incomplete gamma function. A pixel passes when
 * p_pixel >= alpha_sidak = 1 - (1 - 0.01)^(1/npixels), so a correct image passes every pixel with
 * probability 0.99 as a whole. A channel whose combined variance is zero cannot be tested
 * statistically; it passes iff |a - b| <= 1e-5 (|b| + 1e-3) (a pixel of zero total variance thus
 * passes iff all three channels match to that tolerance). A channel within that tolerance passes
 * whatever its variance (float rounding is not evidence).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>

#include "io/image_io.h"
#include "specula/specula.h"

#define DIFF_REL_EPS 0.01          /* relMSE denominator offset, as the papers define it */
#define DIFF_ALPHA 0.01            /* family-wise significance level of the z-test */
#define DIFF_EXACT_REL 1e-5        /* zero-variance pixels: relative tolerance (float images of two
                                      * renderers differ by ~1e-6 where nothing is random: Mitsuba
                                      * decodes sRGB texels in float) ... */
#define DIFF_EXACT_ABS 1e-3        /* ... with this floor on |b| */

static const unsigned char exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};

/* 1: EXR, 0: something else, -1: cannot read (err set). */
static int file_is_exr(const char *path, spc_error *err)
{
    FILE *fp = fopen(path, "rb");
    if (!fp) {
        spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open: %s", strerror(errno));
        return -1;
    }
    unsigned char m[4] = {0};
    size_t n = fread(m, 1, 4, fp);
    fclose(fp);
    return n == 4 && memcmp(m, exr_magic, 4) == 0;
}

void spc_image_rgb_release(spc_image_rgb *img)
{
    if (!img)
        return;
    free(img->rgb);
    free(img->variance);
    img->rgb = NULL;
    img->variance = NULL;
    img->width = img->height = 0;
}

/* Any image spc_image_read understands, turned into linear RGB. */
static spc_status read_generic(const char *path, spc_image_rgb *out, spc_error *err)
{
    spc_image im = {0};
    spc_status st = spc_image_read(path, &im, err);
    if (st != SPC_OK)
        return st;
    if (im.width <= 0 || im.height <= 0 || im.channels < 1 || im.channels > 4) {
        spc_image_release(&im);
        return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "unsupported image layout");
    }
    size_t npix = (size_t)im.width * (size_t)im.height;
    float *rgb = malloc(3 * npix * sizeof(float));
    if (!rgb) {
        spc_image_release(&im);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading the image");
    }
    int ch = im.channels;
    for (size_t i = 0; i < npix; ++i) {
        const float *px = im.data + i * (size_t)ch;
        for (int k = 0; k < 3; ++k) {
            /* gray (+alpha) replicates its one value; RGBA drops alpha */
            double v = ch >= 3 ? px[k] : px[0];
            rgb[3 * i + (size_t)k] = (float)(im.srgb ? spc_srgb_to_linear(v) : v);
        }
    }
    out->width = im.width;
    out->height = im.height;
    out->rgb = rgb;
    out->variance = NULL;
    spc_image_release(&im);
    return SPC_OK;
}

spc_status spc_image_rgb_read(const char *path, spc_image_rgb *out, spc_error *err)
{
    memset(out, 0, sizeof *out);
    if (!path)
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "no image path given");
    int is_exr = file_is_exr(path, err);
    if (is_exr < 0)
        return err ? err->code : SPC_ERR_IO;
    if (!is_exr)
        return read_generic(path, out, err);

    static const char *const names[6] = {"R", "G", "B", "variance.R", "variance.G", "variance.B"};
    bool found[6] = {false};
    int w = 0, h = 0;
    float *data = NULL;
    spc_status st = spc_exr_read_channels(path, 6, names, &w, &h, &data, found, err);
    if (st != SPC_OK)
        return st;
    if (!(found[0] && found[1] && found[2])) {
        /* no R, G, B: a luminance-only (Y) or otherwise named EXR; let the general reader decide */
        free(data);
        return read_generic(path, out, err);
    }
    bool has_var = found[3] && found[4] && found[5];
    size_t npix = (size_t)w * (size_t)h;
    float *rgb = malloc(3 * npix * sizeof(float));
    float *var = has_var ? malloc(3 * npix * sizeof(float)) : NULL;
    if (!rgb || (has_var && !var)) {
        free(rgb);
        free(var);
        free(data);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading the image");
    }
    for (size_t i = 0; i < npix; ++i)
        for (size_t k = 0; k < 3; ++k) {
            rgb[3 * i + k] = data[6 * i + k];
            if (has_var)
                var[3 * i + k] = data[6 * i + 3 + k];
        }
    free(data);
    out->width = w;
    out->height = h;
    out->rgb = rgb;
    out->variance = var;
    return SPC_OK;
}

/* Two-sided normal tail probability of |z|. */
static double normal_two_sided_p(double z) { return erfc(fabs(z) / sqrt(2.0)); }

spc_status spc_image_diff(const spc_image_rgb *a, const spc_image_rgb *b, spc_diff_result *out, spc_error *err)
{
    memset(out, 0, sizeof *out);
    if (!a || !b || !a->rgb || !b->rgb || a->width <= 0 || a->height <= 0)
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "diff: empty image");
    if (a->width != b->width || a->height != b->height)
        return spc_error_set(err, SPC_ERR_VALUE, NULL, 0, 0, "diff: image sizes differ (%dx%d vs %dx%d)", a->width,
                             a->height, b->width, b->height);
    size_t npix = (size_t)a->width * (size_t)a->height;

    double sum_a[3] = {0, 0, 0}, sum_b[3] = {0, 0, 0}, se = 0.0, rse = 0.0;
    for (size_t i = 0; i < npix; ++i)
        for (size_t k = 0; k < 3; ++k) {
            double va = a->rgb[3 * i + k], vb = b->rgb[3 * i + k];
            double d = va - vb;
            sum_a[k] += va;
            sum_b[k] += vb;
            se += d * d;
            rse += d * d / (vb * vb + DIFF_REL_EPS);
        }
    for (int k = 0; k < 3; ++k) {
        out->mean_a[k] = sum_a[k] / (double)npix;
        out->mean_b[k] = sum_b[k] / (double)npix;
    }
    out->mse = se / (3.0 * (double)npix);
    out->rel_mse = rse / (3.0 * (double)npix);

    if (!a->variance && !b->variance)
        return SPC_OK;
    out->has_ztest = true;
    /* Sidak-corrected per-pixel level; log1p/expm1 keep it accurate for millions of pixels */
    double alpha = -expm1(log1p(-DIFF_ALPHA) / (double)npix);
    size_t passed = 0;
    for (size_t i = 0; i < npix; ++i) {
        bool exact_ok = true;
        int k_tested = 0;
        double p_min = 1.0;
        for (size_t k = 0; k < 3; ++k) {
            double va = a->rgb[3 * i + k], vb = b->rgb[3 * i + k];
            double var = (a->variance ? (double)a->variance[3 * i + k] : 0.0) +
                         (b->variance ? (double)b->variance[3 * i + k] : 0.0);
            double d = va - vb;
            /* a difference within float precision is no evidence, whatever the variance: images
             * of a constant background differ in the last bits, and a sum of squares then leaves
             * a variance of ~1e-19 that would make it "significant" */
            if (fabs(d) <= DIFF_EXACT_REL * (fabs(vb) + DIFF_EXACT_ABS)) {
                k_tested += var > 0.0; /* p = 1, still one of the channels the Sidak step counts */
                continue;
            }
            if (var > 0.0) {
                double p = normal_two_sided_p(d / sqrt(var));
                if (!(p >= 0.0)) /* NaN value or variance: no evidence of agreement */
                    p = 0.0;
                p_min = p < p_min ? p : p_min;
                k_tested++;
            } else {
                exact_ok = false; /* also catches NaN values and negative or NaN variances */
            }
        }
        double p_pixel = k_tested > 0 ? -expm1((double)k_tested * log1p(-p_min)) : 1.0;
        if (exact_ok && p_pixel >= alpha)
            passed++;
    }
    out->ztest_pixels = npix > (size_t)0x7fffffff ? 0x7fffffff : (int)npix;
    out->ztest_pass_fraction = (double)passed / (double)npix;
    return SPC_OK;
}
