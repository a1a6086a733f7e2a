/*
 * io/image_io.h: reading and writing images.
 *
 * - EXR through the OpenEXR core C API (openexr.h); PNG through libpng; JPEG through libjpeg.
 * - Writers are atomic: they write "<path>.tmp-<pid>" and rename it over path only when the whole
 *   file is written and flushed, so a failed run never replaces a good image.
 * - Images in memory are float, interleaved, row-major, row 0 at the TOP.
 */
#ifndef SPC_IO_IMAGE_IO_H
#define SPC_IO_IMAGE_IO_H

#include <stdbool.h>
#include <stddef.h>

#include "core/error.h"
#include "specula/specula.h"

typedef struct spc_image {
    int width, height, channels; /* channels: 1, 3 or 4 after reading */
    float *data;                 /* width * height * channels, owned */
    bool srgb;                   /* values are sRGB-encoded in [0,1] (8/16-bit PNG and JPEG) */
} spc_image;

void spc_image_release(spc_image *img);

/* Reads EXR (R,G,B[,A] or Y), PNG (gray, gray+alpha, RGB, RGBA; 8 or 16 bit), JPEG or BMP
 * (uncompressed, bmp.c), chosen by the file's magic bytes. Errors name the file. */
spc_status spc_image_read(const char *path, spc_image *img, spc_error *err);

/* A named extra attribute for EXR headers (string values). */
typedef struct spc_exr_attr {
    const char *name, *value;
} spc_exr_attr;

/* Writes an EXR with nchannels float (FLOAT, 32-bit) channels named names[i], interleaved data,
 * ZIP compression, plus nattrs string attributes. Channel names are written in the order given
 * (EXR sorts them in the file; readers find them by name). */
spc_status spc_exr_write(const char *path, int width, int height, int nchannels, const char *const *names,
                         const float *data, const spc_exr_attr *attrs, int nattrs, spc_error *err);

/* Reads named channels of an EXR into a planar-by-name interleaved buffer: out receives
 * width*height*nnames floats; a channel that is missing sets *found[i] = false (found may be NULL)
 * and fills zeros. */
spc_status spc_exr_read_channels(const char *path, int nnames, const char *const *names, int *width, int *height,
                                 float **out, bool *found, spc_error *err);

/* Writes an 8-bit sRGB PNG from linear RGB floats (3 channels), clamped to [0,1]. */
spc_status spc_png_write_srgb(const char *path, int width, int height, const float *rgb, spc_error *err);

/* Writes a little-endian Portable Float Map (RGB, linear floats) (pfm.c). */
spc_status spc_pfm_write(const char *path, int width, int height, const float *rgb, spc_error *err);
/* Writes a Radiance RGBE .hdr (flat scanlines) from linear RGB floats (hdr.c). */
spc_status spc_hdr_write(const char *path, int width, int height, const float *rgb, spc_error *err);
/* One pixel in RGBE: shared exponent out[3] = e + 128; black below 1e-32; negatives and NaN as 0. */
void spc_rgbe_encode(const float rgb[3], unsigned char out[4]);

/* sRGB transfer functions. */
double spc_srgb_to_linear(double v);
double spc_linear_to_srgb(double v);

/* ---- Internal to src/io (the readers are image.c's; the atomic writing is image_write.c's, for every writer) ---- */

/* Per-format readers behind spc_image_read (the caller has checked the magic bytes). */
spc_status spc_exr_read_image(const char *path, spc_image *img, spc_error *err);
spc_status spc_png_read_image(const char *path, spc_image *img, spc_error *err);
spc_status spc_jpeg_read_image(const char *path, spc_image *img, spc_error *err);
spc_status spc_bmp_read_image(const char *path, spc_image *img, spc_error *err);

/* Atomic file replacement. spc_atomic_open creates "<path>.tmp-<pid>" (its name is written to tmp,
 * tmpsize >= strlen(path) + 32) and returns its descriptor, or -1 with err set (SPC_ERR_IO).
 * spc_atomic_commit fsyncs, closes and renames tmp over path; on any failure it removes tmp and
 * leaves path untouched. spc_atomic_abort closes and removes tmp. Both always close fd. */
int spc_atomic_open(const char *path, char *tmp, size_t tmpsize, spc_error *err);
/* spc_output_resolve (specula.h) finds the file an atomic write replaces. */
#define SPC_OUTPUT_MAX_LINKS 40 /* links followed before giving up (Linux's own limit) */
spc_status spc_atomic_commit(int fd, const char *tmp, const char *path, spc_error *err);
void spc_atomic_abort(int fd, const char *tmp);
/* write(2) until done (retrying short writes and EINTR); false on failure with errno set. */
bool spc_write_all(int fd, const void *buf, size_t size);

/* Writes a simple raster format atomically: `header`, then `height` rows of rowbytes bytes, row i
 * (in file order) filled by encode(rgb, width, i, row) from the linear RGB floats rgb (width x
 * height, top row first). `format` names the format in messages ("PFM"). Refuses an empty image. */
typedef void (*spc_row_encoder)(const float *rgb, int width, int height, int i, unsigned char *row);
spc_status spc_raster_write(const char *path, const char *format, const char *header, size_t rowbytes, int width,
                            int height, const float *rgb, spc_row_encoder encode, spc_error *err);

#endif
