/*
 * io/pfm.c: writes Portable Float Maps (PFM), the plain linear-float format pbrt and HDR tools read.
 *
 * Layout: the text header "PF\n<width> <height>\n-1.0\n" (a negative scale means little-endian
 * floats), then width x height RGB triples of 32-bit floats, rows from the BOTTOM of the image up.
 * Written atomically like every image (image_write.c).
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/image_io.h"

/* File row i is image row height - 1 - i, as little-endian floats. */
static void encode_row(const float *rgb, int width, int height, int i, unsigned char *row)
{
    const float *src = rgb + (size_t)(height - 1 - i) * (size_t)width * 3;
    for (size_t k = 0; k < (size_t)width * 3; ++k) {
        uint32_t u;
        memcpy(&u, &src[k], 4);
        for (int b = 0; b < 4; ++b)
            row[4 * k + (size_t)b] = (unsigned char)(u >> (8 * b));
    }
}

spc_status spc_pfm_write(const char *path, int width, int height, const float *rgb, spc_error *err)
{
    char header[64];
    snprintf(header, sizeof header, "PF\n%d %d\n-1.0\n", width, height);
    return spc_raster_write(path, "PFM", header, (size_t)width * 3 * 4, width, height, rgb, encode_row, err);
}
