/*
 * io/hdr.c: writes Radiance RGBE (.hdr) images (Ward, "Real Pixels", Graphics Gems II, 1991).
 *
 * Each pixel is three 8-bit mantissas sharing one 8-bit exponent: for m = max(r, g, b) with
 * m = f 2^e, f in [0.5, 1), the bytes are (r, g, b) 256 / 2^e and e + 128; m < 1e-32 is (0,0,0,0).
 * Scanlines are written flat (not run-length encoded), which every reader accepts, top row first
 * ("-Y height +X width"). Negative and NaN values become 0. Written atomically (image_write.c).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/image_io.h"

#define RGBE_MIN 1e-32 /* below this the pixel is stored as black (Ward's threshold) */

void spc_rgbe_encode(const float rgb[3], unsigned char out[4])
{
    double c[3];
    for (int k = 0; k < 3; ++k)
        c[k] = rgb[k] > 0.0f && isfinite(rgb[k]) ? rgb[k] : 0.0;
    double m = fmax(c[0], fmax(c[1], c[2]));
    if (m < RGBE_MIN) {
        memset(out, 0, 4);
        return;
    }
    int e;
    double f = frexp(m, &e); /* m = f 2^e, f in [0.5, 1) */
    if (e > 127) {           /* beyond RGBE's range: the largest value it holds */
        out[0] = out[1] = out[2] = 255;
        out[3] = 255;
        return;
    }
    double scale = f * 256.0 / m;
    for (int k = 0; k < 3; ++k) {
        double v = c[k] * scale;
        out[k] = (unsigned char)(v >= 255.0 ? 255 : v);
    }
    out[3] = (unsigned char)(e + 128);
}

/* File row i is image row i, one RGBE quadruple per pixel. */
static void encode_row(const float *rgb, int width, int height, int i, unsigned char *row)
{
    (void)height;
    const float *src = rgb + (size_t)i * (size_t)width * 3;
    for (int x = 0; x < width; ++x)
        spc_rgbe_encode(src + 3 * (size_t)x, row + 4 * (size_t)x);
}

spc_status spc_hdr_write(const char *path, int width, int height, const float *rgb, spc_error *err)
{
    char header[128];
    snprintf(header, sizeof header, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n", height, width);
    return spc_raster_write(path, "HDR", header, (size_t)width * 4, width, height, rgb, encode_row, err);
}
