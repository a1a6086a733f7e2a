/*
 * tests/test_texture.c: constant, bitmap and checkerboard textures. Bilinear and nearest lookups
 * against hand-computed values, the three wrap modes, to_uv, the image orientation (uv (0,0) is
 * the top-left of the file, as in Mitsuba 3), the checkerboard rule, means, and loading: sRGB
 * decoding of 8-bit PNGs written here (and raw), gray expanded, alpha dropped, EXR left linear.
 */
/* ctest-labels: unit */
#include <stdio.h>
#include <unistd.h>

#include <png.h>

#include "harness.h"
#include "png_util.h"
#include "io/image_io.h"
#include "scene/texture.h"

static char tmpdir[256];

/* A bitmap texture over caller-owned data (not released). */
static spc_texture make_bitmap(int w, int h, float *data, spc_wrap_mode wrap, bool nearest)
{
    spc_texture t;
    spc_texture_init_constant(&t, spc_rgb1(0.0));
    t.type = SPC_TEX_BITMAP;
    t.width = w;
    t.height = h;
    t.data = data;
    t.wrap = wrap;
    t.nearest = nearest;
    return t;
}

static void check_rgb(spc_rgb a, spc_rgb b, double tol, const char *what)
{
    bool ok = fabs(a.r - b.r) <= tol && fabs(a.g - b.g) <= tol && fabs(a.b - b.b) <= tol;
    CHECK_MSG(ok, "%s: got (%g, %g, %g), expected (%g, %g, %g)", what, a.r, a.g, a.b, b.r, b.g, b.b);
}

TEST(constant_texture)
{
    spc_texture t;
    spc_texture_init_constant(&t, spc_rgb3(0.1, 0.2, 0.6));
    CHECK(spc_texture_is_constant(&t));
    check_rgb(spc_texture_eval(&t, spc_v2(0.3, -7.0)), spc_rgb3(0.1, 0.2, 0.6), 0.0, "eval");
    CHECK_NEAR(spc_texture_eval1(&t, spc_v2(0.0, 0.0)), 0.3, 1e-15);
    check_rgb(spc_texture_mean(&t), spc_rgb3(0.1, 0.2, 0.6), 0.0, "mean");
    spc_texture_release(&t); /* nothing to free, must not crash */
}

/* 3x2 texture; texel (x, y) = (x, y, 10 + x + 3y) so lookups identify the texels. */
static float grid[3 * 2 * 3];
static void fill_grid(void)
{
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x) {
            float *p = grid + 3 * (y * 3 + x);
            p[0] = (float)x, p[1] = (float)y, p[2] = (float)(10 + x + 3 * y);
        }
}
static spc_rgb texel(int x, int y) { return spc_rgb3(x, y, 10 + x + 3 * y); }

TEST(bitmap_nearest_and_orientation)
{
    fill_grid();
    spc_texture t = make_bitmap(3, 2, grid, SPC_WRAP_REPEAT, true);
    CHECK(!spc_texture_is_constant(&t));
    /* uv (0,0) is the top-left texel: row 0 of the image, no flip */
    check_rgb(spc_texture_eval(&t, spc_v2(0.01, 0.01)), texel(0, 0), 0.0, "top-left");
    check_rgb(spc_texture_eval(&t, spc_v2(0.99, 0.01)), texel(2, 0), 0.0, "top-right");
    check_rgb(spc_texture_eval(&t, spc_v2(0.01, 0.99)), texel(0, 1), 0.0, "bottom-left");
    check_rgb(spc_texture_eval(&t, spc_v2(0.5, 0.75)), texel(1, 1), 0.0, "centre of (1,1)");
    /* texel boundaries: floor(u W) */
    check_rgb(spc_texture_eval(&t, spc_v2(1.0 / 3.0 + 1e-9, 0.2)), texel(1, 0), 0.0, "just right of 1/3");
    check_rgb(spc_texture_eval(&t, spc_v2(1.0 / 3.0 - 1e-9, 0.2)), texel(0, 0), 0.0, "just left of 1/3");
    /* repeat */
    check_rgb(spc_texture_eval(&t, spc_v2(-0.1, 1.2)), texel(2, 0), 0.0, "repeat");
}

TEST(bitmap_bilinear_values)
{
    fill_grid();
    spc_texture t = make_bitmap(3, 2, grid, SPC_WRAP_CLAMP, false);
    /* texel centres give the texels exactly */
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x)
            check_rgb(spc_texture_eval(&t, spc_v2((x + 0.5) / 3.0, (y + 0.5) / 2.0)), texel(x, y), 1e-12, "centre");
    /* halfway between (0,0) and (1,0) */
    check_rgb(spc_texture_eval(&t, spc_v2(1.0 / 3.0, 0.25)), spc_rgb3(0.5, 0.0, 10.5), 1e-12, "midpoint x");
    /* a general point: s = u W - 0.5 = 0.7, r = v H - 0.5 = 0.4 */
    spc_vec2 uv = spc_v2(1.2 / 3.0, 0.9 / 2.0);
    spc_rgb expect = spc_rgb3(0.7, 0.4, 10.0 + 0.7 + 3.0 * 0.4); /* the grid is affine in (x, y) */
    check_rgb(spc_texture_eval(&t, uv), expect, 1e-12, "interior");
    CHECK_NEAR(spc_texture_eval1(&t, uv), (expect.r + expect.g + expect.b) / 3.0, 1e-12);
    /* a non-affine texture: 2x2 with one bright texel; bilinear weight at (s, r) = (0.25, 0.75) */
    float four[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 4, 4, 4}; /* texel (1,1) = 4 */
    spc_texture q = make_bitmap(2, 2, four, SPC_WRAP_CLAMP, false);
    check_rgb(spc_texture_eval(&q, spc_v2(0.75 / 2.0, 1.25 / 2.0)), spc_rgb1(4 * 0.25 * 0.75), 1e-12, "weights");
}

TEST(bitmap_wrap_modes)
{
    fill_grid();
    /* centres of the virtual texels x = -1, x = 3 and x = -2 in row 0 (bilinear at a centre = that
     * texel after wrapping) */
    spc_vec2 xm1 = spc_v2(-0.5 / 3.0, 0.25), x3 = spc_v2(3.5 / 3.0, 0.25), xm2 = spc_v2(-1.5 / 3.0, 0.25);
    spc_texture r = make_bitmap(3, 2, grid, SPC_WRAP_REPEAT, false);
    check_rgb(spc_texture_eval(&r, xm1), texel(2, 0), 1e-12, "repeat -1");
    check_rgb(spc_texture_eval(&r, x3), texel(0, 0), 1e-12, "repeat 3");
    check_rgb(spc_texture_eval(&r, xm2), texel(1, 0), 1e-12, "repeat -2");
    spc_texture m = make_bitmap(3, 2, grid, SPC_WRAP_MIRROR, false);
    check_rgb(spc_texture_eval(&m, xm1), texel(0, 0), 1e-12, "mirror -1");
    check_rgb(spc_texture_eval(&m, x3), texel(2, 0), 1e-12, "mirror 3");
    check_rgb(spc_texture_eval(&m, xm2), texel(1, 0), 1e-12, "mirror -2");
    check_rgb(spc_texture_eval(&m, spc_v2(6.5 / 3.0, 0.25)), texel(0, 0), 1e-12, "mirror 6 (period 2N)");
    spc_texture c = make_bitmap(3, 2, grid, SPC_WRAP_CLAMP, false);
    check_rgb(spc_texture_eval(&c, xm2), texel(0, 0), 1e-12, "clamp -2");
    check_rgb(spc_texture_eval(&c, spc_v2(40.0, 40.0)), texel(2, 1), 1e-12, "clamp far");
    /* repeat blends across the seam: u = 0 is halfway between texels 2 and 0 */
    check_rgb(spc_texture_eval(&r, spc_v2(0.0, 0.25)), spc_rgb3(1.0, 0.0, 11.0), 1e-12, "repeat seam");
    check_rgb(spc_texture_eval(&c, spc_v2(0.0, 0.25)), texel(0, 0), 1e-12, "clamp edge");
    /* huge and NaN coordinates do not crash */
    spc_rgb big = spc_texture_eval(&r, spc_v2(1e30, -1e30));
    CHECK(spc_rgb_finite(big));
    spc_rgb nan = spc_texture_eval(&m, spc_v2(NAN, 0.5));
    CHECK(spc_rgb_finite(nan));
}

TEST(bitmap_to_uv_and_mean)
{
    fill_grid();
    spc_texture t = make_bitmap(3, 2, grid, SPC_WRAP_REPEAT, true);
    /* uv' = (2u + 0.1, v): u = 0.55 -> 1.2 -> repeats to 0.2 */
    t.to_uv[0][0] = 2.0;
    t.to_uv[0][2] = 0.1;
    check_rgb(spc_texture_eval(&t, spc_v2(0.55, 0.1)), texel(0, 0), 0.0, "scaled");
    check_rgb(spc_texture_eval(&t, spc_v2(0.75, 0.1)), texel(1, 0), 0.0, "scaled 2");
    spc_rgb mean = spc_texture_mean(&t);
    check_rgb(mean, spc_rgb3(1.0, 0.5, 10.0 + 1.0 + 1.5), 1e-12, "mean");
}

/* spc_texture_eval_grad: the value equals spc_texture_eval, the gradient the central difference of
 * the bilinear interpolant inside a cell (through a rotating, scaling to_uv and the repeat wrap),
 * its channel mean spc_texture_eval1_grad; piecewise constant textures have none. */
TEST(bitmap_gradient)
{
    float data[5 * 4 * 3];
    for (int i = 0; i < 5 * 4 * 3; ++i)
        data[i] = (float)(0.5 + 0.45 * sin(1.7 * i + 0.3 * (i % 3)));
    spc_texture t = make_bitmap(5, 4, data, SPC_WRAP_REPEAT, false);
    t.to_uv[0][0] = 1.3;
    t.to_uv[0][1] = -0.4;
    t.to_uv[1][0] = 0.7;
    t.to_uv[1][1] = 2.1;
    t.to_uv[0][2] = 0.05;
    uint64_t st = 7;
    double worst = 0.0;
    int n = 0;
    for (int it = 0; it < 500; ++it) {
        st = st * 6364136223846793005ULL + 1442695040888963407ULL;
        spc_vec2 uv = spc_v2((double)(st >> 40) / (1 << 24) * 3 - 1, (double)((st >> 16) & 0xffffff) / (1 << 24) * 3 - 1);
        spc_rgb g[2];
        spc_rgb v = spc_texture_eval_grad(&t, uv, g);
        check_rgb(v, spc_texture_eval(&t, uv), 0.0, "value");
        spc_vec2 g1 = spc_texture_eval1_grad(&t, uv);
        CHECK_NEAR(spc_rgb_avg(g[0]), g1.x, 1e-12);
        CHECK_NEAR(spc_rgb_avg(g[1]), g1.y, 1e-12);
        const double h = 1e-7;
        for (int j = 0; j < 2; ++j) {
            spc_vec2 d = j == 0 ? spc_v2(h, 0) : spc_v2(0, h);
            spc_rgb p = spc_texture_eval(&t, spc_v2(uv.x + d.x, uv.y + d.y));
            spc_rgb m = spc_texture_eval(&t, spc_v2(uv.x - d.x, uv.y - d.y));
            spc_rgb fd = spc_rgb_scale(spc_rgb_sub(p, m), 0.5 / h);
            double e = spc_max(fabs(fd.r - g[j].r), spc_max(fabs(fd.g - g[j].g), fabs(fd.b - g[j].b)));
            /* a cell border between the samples is a kink: the one-sided differences differ */
            double kink = spc_rgb_avg(spc_rgb_sub(spc_rgb_sub(p, v), spc_rgb_sub(v, m))) / h;
            if (fabs(kink) < 1e-3) {
                worst = spc_max(worst, e);
                ++n;
            }
        }
    }
    printf("    %d smooth samples, worst |grad - fd| %.2e\n", n, worst);
    CHECK(n > 900);
    CHECK(worst < 1e-5);
    t.nearest = true;
    spc_rgb g[2];
    spc_texture_eval_grad(&t, spc_v2(0.3, 0.3), g);
    CHECK(spc_rgb_is_black(g[0]) && spc_rgb_is_black(g[1]));
}

TEST(checkerboard_pattern)
{
    spc_texture t;
    spc_rgb c0 = spc_rgb3(0.9, 0.1, 0.1), c1 = spc_rgb3(0.1, 0.1, 0.9);
    spc_texture_init_checkerboard(&t, c0, c1);
    CHECK(!spc_texture_is_constant(&t));
    /* Mitsuba 3: color0 where (frac(u) > .5) == (frac(v) > .5) */
    check_rgb(spc_texture_eval(&t, spc_v2(0.25, 0.25)), c0, 0.0, "(.25,.25)");
    check_rgb(spc_texture_eval(&t, spc_v2(0.75, 0.25)), c1, 0.0, "(.75,.25)");
    check_rgb(spc_texture_eval(&t, spc_v2(0.25, 0.75)), c1, 0.0, "(.25,.75)");
    check_rgb(spc_texture_eval(&t, spc_v2(0.75, 0.75)), c0, 0.0, "(.75,.75)");
    check_rgb(spc_texture_eval(&t, spc_v2(1.25, 3.25)), c0, 0.0, "periodic");
    check_rgb(spc_texture_eval(&t, spc_v2(-0.25, 0.25)), c1, 0.0, "negative u: frac = .75");
    check_rgb(spc_texture_eval(&t, spc_v2(0.5, 0.25)), c0, 0.0, "u = .5 is not > .5");
    /* to_uv: scale 4 gives 4x4 cells per unit square */
    t.to_uv[0][0] = t.to_uv[1][1] = 4.0;
    check_rgb(spc_texture_eval(&t, spc_v2(0.2, 0.05)), c1, 0.0, "scaled");
    /* a float read swaps the colors, as Mitsuba 3.9's eval_1 */
    CHECK_NEAR(spc_texture_eval1(&t, spc_v2(0.05, 0.05)), spc_rgb_avg(c1), 1e-15);
    CHECK_NEAR(spc_texture_eval1(&t, spc_v2(0.2, 0.05)), spc_rgb_avg(c0), 1e-15);
    check_rgb(spc_texture_mean(&t), spc_rgb3(0.5, 0.1, 0.5), 1e-15, "mean");
    /* the mean is the area average: count over a fine grid */
    double s = 0.0;
    int n = 200;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            s += spc_texture_eval(&t, spc_v2((i + 0.5) / n, (j + 0.5) / n)).r;
    CHECK_NEAR(s / (n * n), 0.5, 1e-12);
}

TEST(load_png_srgb_decoding)
{
    char path[512];
    snprintf(path, sizeof path, "%s/tex.png", tmpdir);
    /* 2x2 RGB: top row (128, 0, 255) (255, 64, 10); bottom row gray levels */
    unsigned char pix[12] = {128, 0, 255, 255, 64, 10, 30, 30, 30, 200, 200, 200};
    CHECK(write_png8(path, 2, 2, PNG_COLOR_TYPE_RGB, pix, 3));
    spc_texture t;
    spc_error err = {0};
    CHECK(spc_texture_load_bitmap(&t, path, false, &err) == SPC_OK);
    CHECK(t.type == SPC_TEX_BITMAP && t.width == 2 && t.height == 2 && t.data != NULL);
    CHECK(t.wrap == SPC_WRAP_REPEAT && !t.nearest && t.to_uv[0][0] == 1.0 && t.to_uv[1][1] == 1.0);
    if (t.data) {
        CHECK_NEAR(t.data[0], spc_srgb_to_linear(128 / 255.0), 1e-7);
        CHECK_NEAR(t.data[0], 0.2158605, 1e-6);
        CHECK(t.data[1] == 0.0f);
        CHECK_NEAR(t.data[2], 1.0, 1e-7);
        CHECK_NEAR(t.data[4], spc_srgb_to_linear(64 / 255.0), 1e-7);
        /* top-left of the file is uv (0,0) */
        t.nearest = true;
        check_rgb(spc_texture_eval(&t, spc_v2(0.25, 0.25)),
                  spc_rgb3(spc_srgb_to_linear(128 / 255.0), 0.0, 1.0), 1e-7, "uv (0,0) is the top-left pixel");
        check_rgb(spc_texture_eval(&t, spc_v2(0.25, 0.75)), spc_rgb1(spc_srgb_to_linear(30 / 255.0)), 1e-7,
                  "bottom row");
    }
    spc_texture_release(&t);
    CHECK(t.data == NULL);

    CHECK(spc_texture_load_bitmap(&t, path, true, &err) == SPC_OK);
    if (t.data)
        CHECK_NEAR(t.data[0], 128 / 255.0, 1e-7);
    spc_texture_release(&t);

    /* gray -> RGB, gray+alpha -> RGB (alpha dropped) */
    unsigned char ga[4] = {100, 7, 250, 9};
    CHECK(write_png8(path, 2, 1, PNG_COLOR_TYPE_GRAY_ALPHA, ga, 2));
    CHECK(spc_texture_load_bitmap(&t, path, false, &err) == SPC_OK);
    CHECK(t.width == 2 && t.height == 1);
    if (t.data) {
        double g = spc_srgb_to_linear(100 / 255.0);
        CHECK_NEAR(t.data[0], g, 1e-7);
        CHECK_NEAR(t.data[1], g, 1e-7);
        CHECK_NEAR(t.data[2], g, 1e-7);
        CHECK_NEAR(t.data[3], spc_srgb_to_linear(250 / 255.0), 1e-7);
    }
    check_rgb(spc_texture_mean(&t), spc_rgb1(0.5 * (spc_srgb_to_linear(100 / 255.0) + spc_srgb_to_linear(250 / 255.0))),
              1e-7, "mean of a loaded texture");
    spc_texture_release(&t);
}

TEST(load_exr_stays_linear_and_errors)
{
    char path[512];
    snprintf(path, sizeof path, "%s/tex.exr", tmpdir);
    const char *names[4] = {"R", "G", "B", "A"};
    float px[8] = {0.5f, 2.0f, 0.25f, 0.1f, 0.0f, 0.75f, 9.0f, 1.0f};
    spc_error err = {0};
    CHECK(spc_exr_write(path, 2, 1, 4, names, px, NULL, 0, &err) == SPC_OK);
    spc_texture t;
    CHECK(spc_texture_load_bitmap(&t, path, false, &err) == SPC_OK);
    if (t.data) {
        CHECK(t.data[0] == 0.5f && t.data[1] == 2.0f && t.data[2] == 0.25f);
        CHECK(t.data[3] == 0.0f && t.data[4] == 0.75f && t.data[5] == 9.0f);
    }
    spc_texture_release(&t);

    snprintf(path, sizeof path, "%s/none.png", tmpdir);
    CHECK(spc_texture_load_bitmap(&t, path, false, &err) == SPC_ERR_IO);
    CHECK(t.type == SPC_TEX_CONSTANT && t.data == NULL);
    check_rgb(spc_texture_eval(&t, spc_v2(0.5, 0.5)), spc_rgb1(0.0), 0.0, "failed load is black");
}

int main(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/specula_test_texture_XXXXXX");
    if (!mkdtemp(tmpdir)) {
        printf("cannot create a temporary directory\n");
        return 1;
    }
    RUN(constant_texture);
    RUN(bitmap_nearest_and_orientation);
    RUN(bitmap_bilinear_values);
    RUN(bitmap_wrap_modes);
    RUN(bitmap_to_uv_and_mean);
    RUN(bitmap_gradient);
    RUN(checkerboard_pattern);
    RUN(load_png_srgb_decoding);
    RUN(load_exr_stays_linear_and_errors);
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (system(cmd) != 0)
        printf("could not remove %s\n", tmpdir);
    return spc_test_finish();
}
