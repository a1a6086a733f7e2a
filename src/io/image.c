/*
 * io/image.c: image reading by file content (not by extension). The per-format readers and
 * writers live in exr.c, png.c, jpeg.c and bmp.c; what the writers share (sRGB, atomic
 * replacement) is in image_write.c, below them.
 *
 * spc_image_read looks at the first bytes of the file: "v/1\x01" is OpenEXR, "\x89PNG\r\n\x1a\n"
 * is PNG, "\xff\xd8\xff" is JPEG and "BM" is BMP.
 */
#include "io/image_io.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void spc_image_release(spc_image *img)
{
    if (!img)
        return;
    free(img->data);
    memset(img, 0, sizeof *img);
}

spc_status spc_image_read(const char *path, spc_image *img, spc_error *err)
{
    memset(img, 0, sizeof *img);
    FILE *f = fopen(path, "rb");
    if (!f)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open image: %s", strerror(errno));
    unsigned char magic[8] = {0};
    size_t n = fread(magic, 1, sizeof magic, f);
    fclose(f);

    static const unsigned char exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};
    static const unsigned char png_magic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    static const unsigned char jpg_magic[3] = {0xff, 0xd8, 0xff};
    if (n >= 4 && memcmp(magic, exr_magic, 4) == 0)
        return spc_exr_read_image(path, img, err);
    if (n >= 8 && memcmp(magic, png_magic, 8) == 0)
        return spc_png_read_image(path, img, err);
    if (n >= 3 && memcmp(magic, jpg_magic, 3) == 0)
        return spc_jpeg_read_image(path, img, err);
    if (n >= 2 && magic[0] == 'B' && magic[1] == 'M')
        return spc_bmp_read_image(path, img, err);
    return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "unknown image format (expected OpenEXR, PNG, JPEG or BMP)");
}
