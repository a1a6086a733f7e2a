/*
 * tests/test_diff.c: image comparison (spc_image_diff) on synthetic images with known answers,
 * and the image readers and film writers it relies on (EXR with variance and AOV channels, PNG).
 */
/* ctest-labels: unit */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "harness.h"
#include "io/image_io.h"
#include "render/film.h"
#include "specula/specula.h"

#define SPC_TEST_PI 3.14159265358979323846

/* splitmix64 and Box-Muller: deterministic noise, so the statistical checks cannot flake */
static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static double uniform01(void)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return ((double)(z >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}
static double gaussian(void)
{
    double u1 = uniform01(), u2 = uniform01();
    return sqrt(-2.0 * log(u1)) * cos(2.0 * SPC_TEST_PI * u2);
}
static spc_image_rgb make_image(int w, int h, bool with_var)
{
    spc_image_rgb img = {w, h, calloc(3 * (size_t)w * (size_t)h, sizeof(float)), NULL};
    if (with_var)
        img.variance = calloc(3 * (size_t)w * (size_t)h, sizeof(float));
    return img;
}

static char tmpdir[64];

static const char *tmp_path(const char *name)
{
    static char buf[4][256];
    static int k = 0;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

TEST(identical_images)
{
    spc_image_rgb a = make_image(8, 4, true);
    for (int i = 0; i < 8 * 4 * 3; ++i) {
        a.rgb[i] = (float)(0.1 * (i % 7));
        a.variance[i] = 0.01f;
    }
    spc_diff_result r;
    spc_error err;
    CHECK(spc_image_diff(&a, &a, &r, &err) == SPC_OK);
    CHECK(r.mse == 0.0);
    CHECK(r.rel_mse == 0.0);
    CHECK(r.has_ztest);
    CHECK(r.ztest_pixels == 32);
    CHECK(r.ztest_pass_fraction == 1.0);
    for (int k = 0; k < 3; ++k)
        CHECK_NEAR(r.mean_a[k], r.mean_b[k], 0.0);
    spc_image_rgb_release(&a);
}

TEST(hand_computed_errors)
{
    /* pixel 0: a = 1, b = 0 -> (1)^2 / 0.01 = 100 per channel; pixel 1: a = 0, b = 1 -> 1/1.01 */
    spc_image_rgb a = make_image(2, 1, false), b = make_image(2, 1, false);
    for (int k = 0; k < 3; ++k) {
        a.rgb[k] = 1.0f;
        b.rgb[3 + k] = 1.0f;
    }
    spc_diff_result r;
    spc_error err;
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK_NEAR(r.mse, 1.0, 1e-12);
    CHECK_NEAR(r.rel_mse, (300.0 + 3.0 / 1.01) / 6.0, 1e-9);
    CHECK(!r.has_ztest);
    for (int k = 0; k < 3; ++k) {
        CHECK_NEAR(r.mean_a[k], 0.5, 1e-12);
        CHECK_NEAR(r.mean_b[k], 0.5, 1e-12);
    }
    /* per-channel means are kept apart */
    a.rgb[1] = 3.0f;
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK_NEAR(r.mean_a[0], 0.5, 1e-12);
    CHECK_NEAR(r.mean_a[1], 1.5, 1e-12);
    spc_image_rgb_release(&a);
    spc_image_rgb_release(&b);
}

TEST(size_mismatch)
{
    spc_image_rgb a = make_image(4, 4, false), b = make_image(4, 5, false);
    spc_diff_result r;
    spc_error err;
    memset(&err, 0, sizeof err);
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_ERR_VALUE);
    CHECK(err.code == SPC_ERR_VALUE);
    CHECK(strstr(err.msg, "4x4") != NULL);
    spc_image_rgb_release(&a);
    spc_image_rgb_release(&b);
}

/* a = b + noise drawn with exactly the variance a reports: nearly every pixel passes */
TEST(consistent_noise_passes)
{
    int w = 64, h = 64;
    double sigma = 0.05;
    spc_image_rgb a = make_image(w, h, true), b = make_image(w, h, false);
    for (int i = 0; i < w * h * 3; ++i) {
        b.rgb[i] = (float)(0.2 + 0.6 * uniform01());
        a.rgb[i] = (float)(b.rgb[i] + sigma * gaussian());
        a.variance[i] = (float)(sigma * sigma);
    }
    spc_diff_result r;
    spc_error err;
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK(r.has_ztest);
    CHECK(r.ztest_pixels == w * h);
    CHECK_MSG(r.ztest_pass_fraction >= 0.999, "pass fraction %g", r.ztest_pass_fraction);
    CHECK_NEAR(r.mse, sigma * sigma, 0.1 * sigma * sigma);

    /* the same noise, 10 sigma off: essentially nothing passes (both variances count, so
     * z = 10 / sqrt 2 ~ 7, still far beyond the corrected threshold of ~4.9) */
    for (int i = 0; i < w * h * 3; ++i)
        a.rgb[i] = (float)(b.rgb[i] + 10.0 * sigma);
    b.variance = calloc(3 * (size_t)w * (size_t)h, sizeof(float));
    for (int i = 0; i < w * h * 3; ++i)
        b.variance[i] = (float)(sigma * sigma);
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK_MSG(r.ztest_pass_fraction < 0.01, "pass fraction %g", r.ztest_pass_fraction);
    spc_image_rgb_release(&a);
    spc_image_rgb_release(&b);
}

/* One pixel: alpha_sidak = 0.01, and the per-channel Sidak combination over 3 channels makes the
 * threshold |z| = Phi^-1(1 - (1 - 0.99^(1/3)) / 2) = 2.935 on one channel. */
TEST(single_pixel_threshold)
{
    spc_image_rgb a = make_image(1, 1, true), b = make_image(1, 1, false);
    for (int k = 0; k < 3; ++k)
        a.variance[k] = 1.0f;
    spc_diff_result r;
    spc_error err;
    a.rgb[1] = 2.8f;
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK(r.ztest_pass_fraction == 1.0);
    a.rgb[1] = 3.1f;
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK(r.ztest_pass_fraction == 0.0);
    /* with only one channel carrying variance the correction is for k = 1: threshold 2.576 */
    a.variance[0] = a.variance[2] = 0.0f;
    a.rgb[1] = 2.7f;
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK(r.ztest_pass_fraction == 0.0);
    a.rgb[1] = 2.5f;
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK(r.ztest_pass_fraction == 1.0);
    spc_image_rgb_release(&a);
    spc_image_rgb_release(&b);
}

/* Zero total variance: exact comparison with a relative tolerance of 1e-5. */
TEST(zero_variance_pixels)
{
    spc_image_rgb a = make_image(2, 1, true), b = make_image(2, 1, false);
    for (int k = 0; k < 3; ++k) {
        a.rgb[k] = b.rgb[k] = 0.25f;
        a.rgb[3 + k] = b.rgb[3 + k] = 0.75f;
    }
    spc_diff_result r;
    spc_error err;
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK(r.has_ztest);
    CHECK(r.ztest_pass_fraction == 1.0);
    a.rgb[4] = 0.7501f; /* 1e-4 off: beyond 1e-5 relative */
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK_NEAR(r.ztest_pass_fraction, 0.5, 1e-12);
    a.rgb[4] = NAN; /* a NaN never passes */
    a.rgb[0] = 0.25f;
    CHECK(spc_image_diff(&a, &b, &r, &err) == SPC_OK);
    CHECK_NEAR(r.ztest_pass_fraction, 0.5, 1e-12);
    spc_image_rgb_release(&a);
    spc_image_rgb_release(&b);
}

TEST(exr_read_with_and_without_variance)
{
    int w = 3, h = 2;
    const char *names6[6] = {"R", "G", "B", "variance.R", "variance.G", "variance.B"};
    float data[3 * 2 * 6];
    for (int i = 0; i < w * h * 6; ++i)
        data[i] = (float)i * 0.125f;
    spc_error err;
    memset(&err, 0, sizeof err);
    const char *p6 = tmp_path("var.exr");
    CHECK(spc_exr_write(p6, w, h, 6, names6, data, NULL, 0, &err) == SPC_OK);
    spc_image_rgb img;
    CHECK(spc_image_rgb_read(p6, &img, &err) == SPC_OK);
    CHECK(img.width == w && img.height == h);
    CHECK(img.variance != NULL);
    if (img.rgb && img.variance)
        for (int i = 0; i < w * h; ++i)
            for (int k = 0; k < 3; ++k) {
                CHECK(img.rgb[3 * i + k] == data[6 * i + k]);
                CHECK(img.variance[3 * i + k] == data[6 * i + 3 + k]);
            }
    spc_image_rgb_release(&img);
    CHECK(img.rgb == NULL && img.variance == NULL);

    const char *p3 = tmp_path("novar.exr");
    CHECK(spc_exr_write(p3, w, h, 3, names6, data, NULL, 0, &err) == SPC_OK);
    CHECK(spc_image_rgb_read(p3, &img, &err) == SPC_OK);
    CHECK(img.variance == NULL);
    CHECK(img.rgb && img.rgb[3] == data[3]);
    spc_image_rgb_release(&img);
    remove(p6);
    remove(p3);

    memset(&err, 0, sizeof err);
    CHECK(spc_image_rgb_read(tmp_path("missing.exr"), &img, &err) == SPC_ERR_IO);
    CHECK(strstr(err.file, "missing.exr") != NULL);
}

TEST(png_read_is_linear)
{
    float rgb[4 * 3] = {0.0f, 0.5f, 1.0f, 0.2f, 0.2f, 0.2f, 0.9f, 0.05f, 0.7f, 2.0f, -1.0f, 0.5f};
    spc_error err;
    const char *p = tmp_path("img.png");
    CHECK(spc_png_write_srgb(p, 2, 2, rgb, &err) == SPC_OK);
    spc_image_rgb img;
    CHECK(spc_image_rgb_read(p, &img, &err) == SPC_OK);
    CHECK(img.width == 2 && img.height == 2 && img.variance == NULL);
    if (img.rgb)
        for (int i = 0; i < 12; ++i) {
            double want = rgb[i] < 0.0f ? 0.0 : (rgb[i] > 1.0f ? 1.0 : rgb[i]);
            CHECK_NEAR(img.rgb[i], want, 0.005); /* 8-bit sRGB quantization */
        }
    spc_image_rgb_release(&img);
    remove(p);
}

/* A film with two passes (values 1 and 3 in every pixel's R): mean 2, variance of the mean 1. */
TEST(film_exr_channels_and_attributes)
{
    struct spc_film *f = spc_film_create(4, 2, 0, 0, 4, 2, true);
    CHECK(f != NULL);
    if (!f)
        return;
    for (int pass = 0; pass < 2; ++pass) {
        for (int i = 0; i < 8; ++i) {
            f->pass[3 * i + 0] = pass == 0 ? 1.0 : 3.0;
            f->pass[3 * i + 1] = 0.5;
            f->pass[3 * i + 2] = (double)i;
            for (int k = 0; k < 7; ++k)
                f->aov_sum[SPC_FILM_AOVS * i + k] += 0.1 * (k + 1);
        }
        spc_film_commit_pass(f);
    }
    CHECK(spc_film_resolve(f));
    spc_error err;
    memset(&err, 0, sizeof err);
    const char *p = tmp_path("film.exr");
    CHECK(spc_film_write_exr(f, p, true, &err) == SPC_OK);
    const char *names[] = {"R", "G", "B", "variance.R", "variance.G", "albedo.R", "normal.Y", "depth.Z", "nope"};
    bool found[9];
    int w = 0, h = 0;
    float *data = NULL;
    CHECK(spc_exr_read_channels(p, 9, names, &w, &h, &data, found, &err) == SPC_OK);
    CHECK(w == 4 && h == 2);
    for (int k = 0; k < 8; ++k)
        CHECK_MSG(found[k], "channel %s", names[k]);
    CHECK(!found[8]);
    if (data) {
        CHECK_NEAR(data[0], 2.0, 1e-6);    /* R */
        CHECK_NEAR(data[1], 0.5, 1e-6);    /* G */
        CHECK_NEAR(data[3], 1.0, 1e-6);    /* variance.R */
        CHECK_NEAR(data[4], 0.0, 1e-6);    /* variance.G */
        CHECK_NEAR(data[5], 0.1, 1e-6);    /* albedo.R: (0.1 + 0.1) / 2 passes */
        CHECK_NEAR(data[6], 0.5, 1e-6);    /* normal.Y, the 5th AOV */
        CHECK_NEAR(data[7], 0.7, 1e-6);    /* depth.Z */
        CHECK_NEAR(data[9 * 5 + 2], 5.0, 1e-6); /* B of pixel 5 */
    }
    free(data);

    /* without variance: no variance channels, but the AOVs are still there */
    CHECK(spc_film_write_exr(f, p, false, &err) == SPC_OK);
    data = NULL;
    CHECK(spc_exr_read_channels(p, 9, names, &w, &h, &data, found, &err) == SPC_OK);
    CHECK(found[0] && !found[3] && found[7]);
    free(data);

    const char *png = tmp_path("film.png");
    CHECK(spc_film_write_png(f, png, &err) == SPC_OK);
    CHECK(access(png, F_OK) == 0);
    remove(p);
    remove(png);
    spc_film_destroy(f);
}

int main(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/spc_test_diff_XXXXXX");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    RUN(identical_images);
    RUN(hand_computed_errors);
    RUN(size_mismatch);
    RUN(consistent_noise_passes);
    RUN(single_pixel_threshold);
    RUN(zero_variance_pixels);
    RUN(exr_read_with_and_without_variance);
    RUN(png_read_is_linear);
    RUN(film_exr_channels_and_attributes);
    rmdir(tmpdir);
    return spc_test_finish();
}
