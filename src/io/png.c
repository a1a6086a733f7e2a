/*
 * io/png.c: PNG reading and 8-bit sRGB PNG writing with libpng.
 *
 * libpng reports errors by calling an error function that must not return; ours records the
 * message and longjmps back to the setjmp in the caller, so a corrupt or truncated file becomes
 * SPC_ERR_PARSE instead of a crash or an exit. Variables changed between setjmp and a longjmp are
 * volatile (C11 7.13.2.1).
 *
 * Reading expands palettes, low-bit gray and tRNS transparency; 16-bit samples are kept at full
 * precision. Output channels: gray -> 1, RGB -> 3, gray+alpha and RGBA -> 4 (gray+alpha is
 * expanded to RGBA so that callers only see 1, 3 or 4). Values are the encoded ones in [0,1]
 * (img->srgb = true): decoding to linear is the caller's choice (textures may be raw).
 *
 * Writing encodes linear RGB with the sRGB curve, clamps to [0,1] (NaN -> 0), rounds to 8 bits,
 * and writes atomically (temporary file, fsync, rename).
 */
#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <png.h>

#include "io/image_io.h"

/* Largest image read, in pixels (2^28 = 16384^2): beyond this a corrupt header is likelier. */
#define SPC_PNG_MAX_PIXELS ((size_t)1 << 28)
#define SPC_PNG_MAX_CHUNK ((png_alloc_size_t)1 << 24) /* bytes of one chunk libpng may hold in memory */
/* Deflate compresses at most 1032:1 (a run of one byte), so a file of n bytes holds at most about
 * 1032 n bytes of image data: a header that announces more is refused before the image is
 * allocated (the JPEG fuzzer's lesson: a few hundred bytes announcing gigabytes). */
#define SPC_PNG_MAX_INFLATE 1100

typedef struct png_ctx {
    jmp_buf jmp;
    char msg[256];
    int fd;        /* writing */
    int write_errno;
} png_ctx;

static void on_error(png_structp png, png_const_charp msg)
{
    png_ctx *c = png_get_error_ptr(png);
    snprintf(c->msg, sizeof c->msg, "%s", msg ? msg : "libpng error");
    longjmp(c->jmp, 1);
}

static void on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg; /* warnings (bad ancillary chunks, ...) do not stop reading */
}

/* ---- writing ---- */

static void on_write(png_structp png, png_bytep data, size_t len)
{
    png_ctx *c = png_get_io_ptr(png);
    if (!spc_write_all(c->fd, data, len)) {
        c->write_errno = errno;
        png_error(png, "write failed");
    }
}

static void on_flush(png_structp png) { (void)png; }

static unsigned char encode8(float v)
{
    if (!(v > 0.0f)) /* also NaN */
        return 0;
    double s = spc_linear_to_srgb(v);
    if (s >= 1.0)
        return 255;
    return (unsigned char)(s * 255.0 + 0.5);
}

spc_status spc_png_write_srgb(const char *path, int width, int height, const float *rgb, spc_error *err)
{
    if (width <= 0 || height <= 0 || !rgb)
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "invalid PNG write request (%dx%d)", width, height);
    if ((size_t)width * (size_t)height > SPC_PNG_MAX_PIXELS)
        return spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "image too large for PNG output (%dx%d)", width, height);
    size_t tmpsize = strlen(path) + 64;
    char *tmp = malloc(tmpsize);
    unsigned char *row = malloc((size_t)width * 3);
    png_ctx *c = calloc(1, sizeof *c);
    if (!tmp || !row || !c) {
        free(tmp);
        free(row);
        free(c);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    }
    c->fd = spc_atomic_open(path, tmp, tmpsize, err);
    if (c->fd < 0) {
        free(tmp);
        free(row);
        free(c);
        return err ? err->code : SPC_ERR_IO;
    }
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, c, on_error, on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    spc_status st = SPC_OK;
    if (!png || !info) {
        st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "cannot create PNG writer");
    } else if (setjmp(c->jmp)) {
        if (c->write_errno)
            st = spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot write PNG: %s", strerror(c->write_errno));
        else
            st = spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot write PNG: %s", c->msg);
    } else {
        png_set_write_fn(png, c, on_write, on_flush);
        png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                     PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
        png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
        png_write_info(png, info);
        for (int y = 0; y < height; ++y) {
            const float *src = rgb + (size_t)y * (size_t)width * 3;
            for (size_t i = 0; i < (size_t)width * 3; ++i)
                row[i] = encode8(src[i]);
            png_write_row(png, row);
        }
        png_write_end(png, info);
    }
    if (png)
        png_destroy_write_struct(&png, info ? &info : NULL);
    if (st == SPC_OK)
        st = spc_atomic_commit(c->fd, tmp, path, err);
    else
        spc_atomic_abort(c->fd, tmp);
    free(tmp);
    free(row);
    free(c);
    return st;
}

/* ---- reading ---- */

spc_status spc_png_read_image(const char *path, spc_image *img, spc_error *err)
{
    memset(img, 0, sizeof *img);
    FILE *f = fopen(path, "rb");
    if (!f)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open PNG: %s", strerror(errno));
    png_ctx *c = calloc(1, sizeof *c);
    if (!c) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    }
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, c, on_error, on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    unsigned char *volatile pixels = NULL;
    png_bytep *volatile rows = NULL;
    float *volatile out = NULL;
    spc_status st = SPC_OK;
    if (!png || !info) {
        st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "cannot create PNG reader");
        goto done;
    }
    if (setjmp(c->jmp)) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "corrupt or truncated PNG: %s", c->msg);
        goto done;
    }
    long bytes = -1;
    if (fseek(f, 0, SEEK_END) == 0) {
        bytes = ftell(f);
        rewind(f);
    }
    png_init_io(png, f);
    png_set_user_limits(png, 1u << 20, 1u << 20);
    /* Ancillary chunks we do not use are skipped unread: libpng would otherwise allocate whatever
     * length a corrupt one claims (found by fuzzing: a 322-byte file whose tEXt chunk claimed
     * 755 MB took seconds and 743 MB to reject). tRNS is kept; colour is taken as sRGB anyway. */
    static const png_byte ignored[] = "tEXt\0zTXt\0iTXt\0iCCP\0sPLT\0eXIf\0tIME\0pCAL\0sCAL\0hIST\0sBIT\0"
                                      "pHYs\0oFFs\0bKGD\0cHRM\0gAMA\0sRGB";
    png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_NEVER, NULL, 0);
    png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_NEVER, ignored, (int)(sizeof ignored / 5));
    png_set_chunk_malloc_max(png, SPC_PNG_MAX_CHUNK);
    png_read_info(png, info);
    png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    if ((size_t)w * (size_t)h > SPC_PNG_MAX_PIXELS) {
        st = spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "PNG image too large (%ux%u)", (unsigned)w, (unsigned)h);
        goto done;
    }
    /* the image's bytes before any transform (at least one byte per row and pass besides) */
    size_t raw = png_get_rowbytes(png, info) * (size_t)h;
    if (bytes >= 0 && raw / SPC_PNG_MAX_INFLATE > (size_t)bytes) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0,
                           "corrupt or truncated PNG: %ux%u pixels in a file of %ld bytes", (unsigned)w,
                           (unsigned)h, bytes);
        goto done;
    }
    int color = png_get_color_type(png, info);
    if (color == PNG_COLOR_TYPE_PALETTE)
        png_set_palette_to_rgb(png);
    if (color == PNG_COLOR_TYPE_GRAY && png_get_bit_depth(png, info) < 8)
        png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS))
        png_set_tRNS_to_alpha(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);

    int channels = png_get_channels(png, info);
    int depth = png_get_bit_depth(png, info);
    size_t rowbytes = png_get_rowbytes(png, info);
    if (channels < 1 || channels > 4 || (depth != 8 && depth != 16) ||
        rowbytes != (size_t)w * (size_t)channels * (size_t)(depth / 8)) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "unsupported PNG layout (%d channels, %d bits)", channels,
                           depth);
        goto done;
    }
    pixels = malloc(rowbytes * h);
    rows = malloc(sizeof(png_bytep) * h);
    int outc = channels == 2 ? 4 : channels;
    out = malloc((size_t)w * (size_t)h * (size_t)outc * sizeof(float));
    if (!pixels || !rows || !out) {
        st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for a %ux%u image", (unsigned)w, (unsigned)h);
        goto done;
    }
    for (png_uint_32 y = 0; y < h; ++y)
        rows[y] = pixels + (size_t)y * rowbytes;
    png_read_image(png, rows);
    png_read_end(png, NULL);

    const double scale = depth == 16 ? 1.0 / 65535.0 : 1.0 / 255.0;
    size_t np = (size_t)w * (size_t)h;
    for (size_t p = 0; p < np; ++p) {
        float v[4];
        for (int k = 0; k < channels; ++k) {
            const unsigned char *s = pixels + (p * (size_t)channels + (size_t)k) * (size_t)(depth / 8);
            unsigned q = depth == 16 ? ((unsigned)s[0] << 8 | s[1]) : s[0];
            v[k] = (float)(q * scale);
        }
        float *d = out + p * (size_t)outc;
        if (channels == 2) {
            d[0] = d[1] = d[2] = v[0];
            d[3] = v[1];
        } else {
            for (int k = 0; k < channels; ++k)
                d[k] = v[k];
        }
    }
    img->width = (int)w;
    img->height = (int)h;
    img->channels = outc;
    img->data = out;
    img->srgb = true;
    out = NULL;

done:
    if (png)
        png_destroy_read_struct(&png, info ? &info : NULL, NULL);
    fclose(f);
    free(pixels);
    free(rows);
    free(out);
    free(c);
    return st;
}
