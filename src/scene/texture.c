/*
 * scene/texture.c: constant, bitmap and checkerboard textures, following Mitsuba 3.
 *
 * Bitmap (Mitsuba 3 src/textures/bitmap.cpp, which samples a drjit Texture): uv is first mapped
 * by to_uv; uv (0,0) is the top-left corner of the image as stored in the file (no flip; OBJ
 * files get v flipped by their loader instead). Texel (x, y), y counted from the top row, is
 * centred at ((x + 0.5)/W, (y + 0.5)/H).
 *   nearest:  texel (floor(u W), floor(v H)), wrapped.
 *   bilinear: s = u W - 0.5, t = v H - 0.5; the four texels around (floor s, floor t), each index
 *             wrapped, weighted by the fractional parts.
 *   wrap:     repeat: i mod N; clamp: min(max(i, 0), N-1); mirror: i mod 2N, reflected into
 *             [0, N) so that the edge texel repeats (..., 1, 0, 0, 1, ..., N-1, N-1, N-2, ...).
 * Checkerboard (Mitsuba 3 src/textures/checkerboard.cpp, eval): with (u, v) = to_uv(uv),
 * color0 where (u - floor u > 0.5) == (v - floor v > 0.5), color1 elsewhere; the mean is the
 * average of the two colors. Mitsuba 3's eval_1, which every float parameter reads (roughness,
 * weights, opacity, heights, the principled BSDF's parameters), uses the opposite test (color0
 * where the two differ; checked on Mitsuba 3.9.1): spc_texture_eval1 does the same, so that a
 * float checkerboard renders as in Mitsuba (its mitsuba-data principled scenes fail the per-pixel
 * z-test otherwise). The two patterns are shifted by one cell; their means are equal.
 */
#include "scene/texture.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "io/image_io.h"
#include "scene/hit.h"

static void set_identity_uv(spc_texture *t)
{
    memset(t->to_uv, 0, sizeof t->to_uv);
    t->to_uv[0][0] = 1.0;
    t->to_uv[1][1] = 1.0;
}

void spc_texture_init_constant(spc_texture *t, spc_rgb value)
{
    memset(t, 0, sizeof *t);
    t->type = SPC_TEX_CONSTANT;
    t->value = value;
    t->wrap = SPC_WRAP_REPEAT;
    set_identity_uv(t);
}

void spc_texture_init_checkerboard(spc_texture *t, spc_rgb color0, spc_rgb color1)
{
    memset(t, 0, sizeof *t);
    t->type = SPC_TEX_CHECKERBOARD;
    t->color0 = color0;
    t->color1 = color1;
    t->wrap = SPC_WRAP_REPEAT;
    set_identity_uv(t);
}

static spc_vec2 map_uv(const spc_texture *t, spc_vec2 uv)
{
    const double(*m)[3] = t->to_uv;
    return spc_v2(m[0][0] * uv.x + m[0][1] * uv.y + m[0][2], m[1][0] * uv.x + m[1][1] * uv.y + m[1][2]);
}

/* Integer texel coordinate of a continuous one; NaN -> 0, far values are clamped (any integer
 * beyond +-2^40 wraps like a nearer one for the sizes we accept, up to float precision). */
static int64_t to_index(double x)
{
    if (!(x == x))
        return 0;
    x = spc_clamp(x, -1099511627776.0, 1099511627776.0);
    return (int64_t)floor(x);
}

static int64_t wrap_index(int64_t i, int64_t n, spc_wrap_mode mode)
{
    switch (mode) {
    case SPC_WRAP_CLAMP:
        return i < 0 ? 0 : (i >= n ? n - 1 : i);
    case SPC_WRAP_MIRROR: {
        int64_t m = i % (2 * n);
        if (m < 0)
            m += 2 * n;
        return m < n ? m : 2 * n - 1 - m;
    }
    case SPC_WRAP_REPEAT:
        break;
    }
    int64_t m = i % n;
    return m < 0 ? m + n : m;
}

static spc_rgb texel(const spc_texture *t, int64_t x, int64_t y)
{
    x = wrap_index(x, t->width, t->wrap);
    y = wrap_index(y, t->height, t->wrap);
    const float *p = t->data + 3 * ((size_t)y * (size_t)t->width + (size_t)x);
    return spc_rgb3(p[0], p[1], p[2]);
}

/* The bilinear interpolant at the mapped uv p (a bitmap with data, not nearest): its value and, if
 * d is not NULL, its partials per unit of the mapped u and v in the cell holding p. */
static spc_rgb bilinear(const spc_texture *t, spc_vec2 p, spc_rgb d[2])
{
    double s = p.x * t->width - 0.5, r = p.y * t->height - 0.5;
    int64_t x0 = to_index(s), y0 = to_index(r);
    double fx = s - (double)x0, fy = r - (double)y0;
    if (!(fx >= 0.0 && fx <= 1.0))
        fx = 0.0;
    if (!(fy >= 0.0 && fy <= 1.0))
        fy = 0.0;
    spc_rgb c00 = texel(t, x0, y0), c10 = texel(t, x0 + 1, y0);
    spc_rgb c01 = texel(t, x0, y0 + 1), c11 = texel(t, x0 + 1, y0 + 1);
    spc_rgb c0 = spc_rgb_add(spc_rgb_scale(c00, 1.0 - fx), spc_rgb_scale(c10, fx));
    spc_rgb c1 = spc_rgb_add(spc_rgb_scale(c01, 1.0 - fx), spc_rgb_scale(c11, fx));
    if (d) {
        d[0] = spc_rgb_scale(spc_rgb_add(spc_rgb_scale(spc_rgb_sub(c10, c00), 1.0 - fy),
                                         spc_rgb_scale(spc_rgb_sub(c11, c01), fy)),
                             (double)t->width);
        d[1] = spc_rgb_scale(spc_rgb_sub(c1, c0), (double)t->height);
    }
    return spc_rgb_add(spc_rgb_scale(c0, 1.0 - fy), spc_rgb_scale(c1, fy));
}

static bool has_bilinear(const spc_texture *t)
{
    return t->type == SPC_TEX_BITMAP && !t->nearest && t->data && t->width > 0 && t->height > 0;
}

static spc_rgb eval_bitmap(const spc_texture *t, spc_vec2 uv)
{
    if (!t->data || t->width <= 0 || t->height <= 0)
        return spc_rgb1(0.0);
    if (t->nearest)
        return texel(t, to_index(uv.x * t->width), to_index(uv.y * t->height));
    return bilinear(t, uv, NULL);
}

spc_rgb spc_texture_eval_general(const spc_texture *t, spc_vec2 uv)
{
    switch (t->type) {
    case SPC_TEX_CONSTANT:
        return t->value;
    case SPC_TEX_BITMAP:
        return eval_bitmap(t, map_uv(t, uv));
    case SPC_TEX_CHECKERBOARD: {
        spc_vec2 p = map_uv(t, uv);
        bool hu = p.x - floor(p.x) > 0.5, hv = p.y - floor(p.y) > 0.5;
        return hu == hv ? t->color0 : t->color1;
    }
    case SPC_TEX_MESH_ATTRIBUTE: /* needs a hit: spc_texture_eval_hit */
        return spc_rgb1(0.0);
    }
    return spc_rgb1(0.0);
}

double spc_texture_eval1(const spc_texture *t, spc_vec2 uv)
{
    if (t->type == SPC_TEX_CHECKERBOARD) {
        spc_vec2 p = map_uv(t, uv);
        bool hu = p.x - floor(p.x) > 0.5, hv = p.y - floor(p.y) > 0.5;
        return spc_rgb_avg(hu != hv ? t->color0 : t->color1);
    }
    return spc_rgb_avg(spc_texture_eval(t, uv));
}

spc_rgb spc_texture_eval_hit_general(const spc_texture *t, const spc_hit *h)
{
    if (t->type == SPC_TEX_MESH_ATTRIBUTE)
        return spc_mesh_attribute_eval(t, h);
    return spc_texture_eval(t, h->uv);
}

double spc_texture_eval1_hit(const spc_texture *t, const spc_hit *h)
{
    if (t->type == SPC_TEX_MESH_ATTRIBUTE)
        return spc_rgb_avg(spc_mesh_attribute_eval(t, h));
    return spc_texture_eval1(t, h->uv); /* the checkerboard's float read, as Mitsuba 3's eval_1 */
}

bool spc_texture_init_mesh_attribute(spc_texture *t, const char *name, double scale)
{
    memset(t, 0, sizeof *t);
    t->type = SPC_TEX_MESH_ATTRIBUTE;
    t->attr_scale = scale;
    t->wrap = SPC_WRAP_REPEAT;
    set_identity_uv(t);
    size_t n = strlen(name);
    if (n >= sizeof t->attribute || (strncmp(name, "vertex_", 7) != 0 && strncmp(name, "face_", 5) != 0))
        return false;
    memcpy(t->attribute, name, n + 1);
    return true;
}

spc_rgb spc_texture_texel(const spc_texture *t, int64_t x, int64_t y)
{
    if (t->type != SPC_TEX_BITMAP || !t->data || t->width <= 0 || t->height <= 0)
        return spc_rgb1(0.0);
    return texel(t, x, y);
}

/* Partials per unit of the mapped uv -> per unit of the surface uv: the transpose of to_uv's
 * linear part. */
static void unmap_grad(const spc_texture *t, spc_rgb d[2], spc_rgb out[2])
{
    const double(*m)[3] = t->to_uv;
    out[0] = spc_rgb_add(spc_rgb_scale(d[0], m[0][0]), spc_rgb_scale(d[1], m[1][0]));
    out[1] = spc_rgb_add(spc_rgb_scale(d[0], m[0][1]), spc_rgb_scale(d[1], m[1][1]));
}

spc_vec2 spc_texture_eval1_grad(const spc_texture *t, spc_vec2 uv)
{
    spc_rgb g[2];
    spc_texture_eval_grad(t, uv, g);
    return spc_v2(spc_rgb_avg(g[0]), spc_rgb_avg(g[1]));
}

spc_rgb spc_texture_eval_grad(const spc_texture *t, spc_vec2 uv, spc_rgb grad[2])
{
    grad[0] = grad[1] = spc_rgb1(0.0);
    if (!has_bilinear(t))
        return spc_texture_eval(t, uv);
    spc_rgb d[2];
    spc_rgb v = bilinear(t, map_uv(t, uv), d);
    unmap_grad(t, d, grad);
    return v;
}

spc_rgb spc_texture_mean(const spc_texture *t)
{
    switch (t->type) {
    case SPC_TEX_CONSTANT:
        return t->value;
    case SPC_TEX_CHECKERBOARD:
        return spc_rgb_scale(spc_rgb_add(t->color0, t->color1), 0.5);
    case SPC_TEX_MESH_ATTRIBUTE:
        return spc_rgb1(0.5 * t->attr_scale);
    case SPC_TEX_BITMAP: {
        if (!t->data || t->width <= 0 || t->height <= 0)
            return spc_rgb1(0.0);
        /* Row sums first: keeps the double sums well conditioned for large images. */
        double sum[3] = {0.0, 0.0, 0.0};
        for (int y = 0; y < t->height; ++y) {
            double row[3] = {0.0, 0.0, 0.0};
            const float *p = t->data + 3 * (size_t)y * (size_t)t->width;
            for (int x = 0; x < t->width; ++x)
                for (int k = 0; k < 3; ++k)
                    row[k] += p[3 * x + k];
            for (int k = 0; k < 3; ++k)
                sum[k] += row[k];
        }
        double inv = 1.0 / ((double)t->width * (double)t->height);
        return spc_rgb3(sum[0] * inv, sum[1] * inv, sum[2] * inv);
    }
    }
    return spc_rgb1(0.0);
}

void spc_texture_release(spc_texture *t)
{
    if (!t)
        return;
    free(t->data);
    t->data = NULL;
    t->width = t->height = 0;
}

spc_status spc_texture_load_bitmap(spc_texture *t, const char *path, bool raw, spc_error *err)
{
    spc_texture_init_constant(t, spc_rgb1(0.0));
    spc_image img;
    spc_status st = spc_image_read(path, &img, err);
    if (st != SPC_OK)
        return st;
    if (img.channels != 1 && img.channels != 3 && img.channels != 4) {
        int c = img.channels;
        spc_image_release(&img);
        return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "unsupported channel count %d", c);
    }
    size_t np = (size_t)img.width * (size_t)img.height;
    float *rgb = malloc(np * 3 * sizeof(float));
    if (!rgb) {
        spc_image_release(&img);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for a %dx%d texture", img.width,
                             img.height);
    }
    /* sRGB decoding: 8-bit values (k/255) through a table, anything else through the curve. */
    bool decode = img.srgb && !raw;
    float lut[256];
    if (decode)
        for (int k = 0; k < 256; ++k)
            lut[k] = (float)spc_srgb_to_linear(k / 255.0);
    for (size_t p = 0; p < np; ++p) {
        const float *s = img.data + p * (size_t)img.channels;
        for (int k = 0; k < 3; ++k) {
            float v = s[img.channels == 1 ? 0 : k];
            if (decode) {
                float q = v * 255.0f;
                int qi = (int)lrintf(q);
                if (qi >= 0 && qi <= 255 && fabsf(q - (float)qi) < 1e-3f)
                    v = lut[qi];
                else
                    v = (float)spc_srgb_to_linear(v);
            }
            rgb[3 * p + (size_t)k] = v;
        }
    }
    t->type = SPC_TEX_BITMAP;
    t->width = img.width;
    t->height = img.height;
    t->data = rgb;
    t->nearest = false;
    t->wrap = SPC_WRAP_REPEAT;
    spc_image_release(&img);
    return SPC_OK;
}
