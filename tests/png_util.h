/*
 * tests/png_util.h: writing PNG test inputs with libpng (the reference encoder), so that the
 * loader's PNG reader is checked against files it did not write. Static, one copy per test program,
 * like the harness's helpers.
 */
#ifndef SPC_TESTS_PNG_UTIL_H
#define SPC_TESTS_PNG_UTIL_H

#include <png.h>
#include <stdbool.h>
#include <stdio.h>

/* Writes a PNG with libpng: color type, bit depth, optional palette / tRNS. */
static inline bool write_png_raw(const char *path, int w, int h, int color, int depth, const unsigned char *rows,
                          size_t rowbytes, const png_color *pal, int npal, const png_byte *trns, int ntrns)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return false;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        fclose(f);
        return false;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, depth, color, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (pal)
        png_set_PLTE(png, info, pal, npal);
    if (trns)
        png_set_tRNS(png, info, trns, ntrns, NULL);
    png_write_info(png, info);
    for (int y = 0; y < h; ++y)
        png_write_row(png, (png_const_bytep)(rows + (size_t)y * rowbytes));
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    fclose(f);
    return true;
}

/* An 8-bit PNG of comps channels per pixel (color: a PNG_COLOR_TYPE_*), rows packed. */
static inline bool write_png8(const char *path, int w, int h, int color, const unsigned char *pix, int comps)
{
    return write_png_raw(path, w, h, color, 8, pix, (size_t)w * (size_t)comps, NULL, 0, NULL, 0);
}

#endif
