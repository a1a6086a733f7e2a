/*
 * io/pfm.c: writes Portable Float Maps (PFM), the plain linear-float format pbrt and HDR tools read.
 *
 * Layout: the text header "PF\n<width> <height>\n-1.0\n" (a negative scale means little-endian
 * floats), then width x height RGB triples of 32-bit floats, rows from the BOTTOM of the image up.
 * Written atomically like every image (image.c).
 */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/image_io.h"

spc_status spc_pfm_write(const char *path, int width, int height, const float *rgb, spc_error *err)
{
    if (width <= 0 || height <= 0 || !rgb)
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "invalid PFM write request (%dx%d)", width, height);
    size_t tmpsize = strlen(path) + 64, rowbytes = (size_t)width * 3 * 4;
    char *tmp = malloc(tmpsize);
    unsigned char *row = malloc(rowbytes);
    if (!tmp || !row) {
        free(tmp);
        free(row);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    }
    int fd = spc_atomic_open(path, tmp, tmpsize, err);
    if (fd < 0) {
        free(tmp);
        free(row);
        return SPC_ERR_IO;
    }
    char header[64];
    int hl = snprintf(header, sizeof header, "PF\n%d %d\n-1.0\n", width, height);
    bool ok = spc_write_all(fd, header, (size_t)hl);
    for (int y = height - 1; ok && y >= 0; --y) {
        const float *src = rgb + (size_t)y * (size_t)width * 3;
        for (size_t i = 0; i < (size_t)width * 3; ++i) {
            uint32_t u;
            memcpy(&u, &src[i], 4);
            for (int b = 0; b < 4; ++b)
                row[4 * i + (size_t)b] = (unsigned char)(u >> (8 * b));
        }
        ok = spc_write_all(fd, row, rowbytes);
    }
    spc_status st;
    if (ok) {
        st = spc_atomic_commit(fd, tmp, path, err);
    } else {
        int e = errno;
        spc_atomic_abort(fd, tmp);
        st = spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot write PFM: %s", strerror(e));
    }
    free(tmp);
    free(row);
    return st;
}
