/*
 * io/jpeg.c: JPEG reading with libjpeg (libjpeg-turbo's libjpeg 6.2 API).
 *
 * libjpeg's default error handler calls exit(); ours formats the message and longjmps back to
 * the reader, which frees everything and returns SPC_ERR_PARSE. libjpeg treats a premature end of
 * data (or of a data segment) only as a warning (it pads the image with gray); we treat those
 * warnings as errors, so a truncated texture is reported instead of rendered. Other warnings are
 * passed to spc_warn.
 *
 * Output: gray -> 1 channel, everything else -> 3 channels (YCbCr converted by libjpeg; CMYK and
 * YCCK converted here, inverted as Adobe writes them when the Adobe marker says so). Values are
 * the encoded ones in [0,1] (img->srgb = true).
 */
#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jpeglib.h>
#include <jerror.h>

#include "io/image_io.h"

/* Largest image read, in pixels (2^28 = 16384^2). */
#define SPC_JPEG_MAX_PIXELS ((size_t)1 << 28)

/* Can a file of `bytes` hold the entropy-coded data of the header's image? A Huffman-coded file
 * (baseline or progressive) spends at least one bit per MCU (the first component's DC code), so a
 * header that announces millions of pixels in a few hundred bytes is refused before libjpeg or we
 * allocate for them (fuzzing: a 213-byte file announced 4146 x 55808, 2.8 GB of floats).
 * Arithmetic coding can go below a bit per MCU: not checked there. */
static bool data_can_fit(const struct jpeg_decompress_struct *cinfo, long bytes)
{
    if (cinfo->arith_code || bytes < 0)
        return true;
    size_t mw = 8 * (size_t)(cinfo->max_h_samp_factor > 0 ? cinfo->max_h_samp_factor : 1);
    size_t mh = 8 * (size_t)(cinfo->max_v_samp_factor > 0 ? cinfo->max_v_samp_factor : 1);
    size_t mcus = (((size_t)cinfo->image_width + mw - 1) / mw) * (((size_t)cinfo->image_height + mh - 1) / mh);
    return mcus / 8 <= (size_t)bytes;
}

typedef struct jpeg_ctx {
    struct jpeg_error_mgr mgr; /* first member: libjpeg passes &mgr as cinfo->err */
    jmp_buf jmp;
    char msg[JMSG_LENGTH_MAX];
    const char *path;
} jpeg_ctx;

static void on_error_exit(j_common_ptr cinfo)
{
    jpeg_ctx *c = (jpeg_ctx *)cinfo->err;
    c->mgr.format_message(cinfo, c->msg);
    longjmp(c->jmp, 1);
}

static void on_emit_message(j_common_ptr cinfo, int level)
{
    jpeg_ctx *c = (jpeg_ctx *)cinfo->err;
    if (level >= 0)
        return; /* trace messages */
    c->mgr.num_warnings++;
    c->mgr.format_message(cinfo, c->msg);
    /* data ended early, or a marker cut the entropy-coded data short: libjpeg would pad the rest of
     * the image with gray, which for a corrupt header can mean decoding millions of made-up pixels
     * (fuzzing: an 845-byte file decoded as 224x65486 took seconds) */
    if (c->mgr.msg_code == JWRN_JPEG_EOF || c->mgr.msg_code == JWRN_HIT_MARKER)
        longjmp(c->jmp, 1);
    spc_warn(c->path, 0, 0, "JPEG: %s", c->msg);
}

static void on_output_message(j_common_ptr cinfo) { (void)cinfo; }

spc_status spc_jpeg_read_image(const char *path, spc_image *img, spc_error *err)
{
    memset(img, 0, sizeof *img);
    FILE *f = fopen(path, "rb");
    if (!f)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open JPEG: %s", strerror(errno));
    struct jpeg_decompress_struct *cinfo = calloc(1, sizeof *cinfo);
    jpeg_ctx *c = calloc(1, sizeof *c);
    if (!cinfo || !c) {
        free(cinfo);
        free(c);
        fclose(f);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    }
    cinfo->err = jpeg_std_error(&c->mgr);
    c->mgr.error_exit = on_error_exit;
    c->mgr.emit_message = on_emit_message;
    c->mgr.output_message = on_output_message;
    c->path = path;

    unsigned char *volatile row = NULL;
    float *volatile out = NULL;
    spc_status st = SPC_OK;
    if (setjmp(c->jmp)) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "corrupt or truncated JPEG: %s", c->msg);
        goto done;
    }
    long bytes = -1;
    if (fseek(f, 0, SEEK_END) == 0) {
        bytes = ftell(f);
        rewind(f);
    }
    jpeg_create_decompress(cinfo);
    jpeg_stdio_src(cinfo, f);
    jpeg_read_header(cinfo, TRUE);
    if ((size_t)cinfo->image_width * (size_t)cinfo->image_height > SPC_JPEG_MAX_PIXELS) {
        st = spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "JPEG image size %ux%u not supported",
                           (unsigned)cinfo->image_width, (unsigned)cinfo->image_height);
        goto done;
    }
    if (!data_can_fit(cinfo, bytes)) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0,
                           "corrupt or truncated JPEG: %ux%u pixels in a file of %ld bytes",
                           (unsigned)cinfo->image_width, (unsigned)cinfo->image_height, bytes);
        goto done;
    }
    bool cmyk = cinfo->jpeg_color_space == JCS_CMYK || cinfo->jpeg_color_space == JCS_YCCK;
    if (cinfo->jpeg_color_space == JCS_GRAYSCALE)
        cinfo->out_color_space = JCS_GRAYSCALE;
    else if (cmyk)
        cinfo->out_color_space = JCS_CMYK;
    else
        cinfo->out_color_space = JCS_RGB;
    jpeg_start_decompress(cinfo);

    size_t w = cinfo->output_width, h = cinfo->output_height;
    int comps = cinfo->output_components;
    if (w == 0 || h == 0 || w * h > SPC_JPEG_MAX_PIXELS) {
        st = spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "JPEG image size %zux%zu not supported", w, h);
        goto done;
    }
    if (comps != (cmyk ? 4 : cinfo->out_color_space == JCS_GRAYSCALE ? 1 : 3)) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "unexpected JPEG component count %d", comps);
        goto done;
    }
    int outc = comps == 1 ? 1 : 3;
    row = malloc(w * (size_t)comps);
    out = malloc(w * h * (size_t)outc * sizeof(float));
    if (!row || !out) {
        st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for a %zux%zu image", w, h);
        goto done;
    }
    bool inverted = cinfo->saw_Adobe_marker;
    while (cinfo->output_scanline < cinfo->output_height) {
        size_t y = cinfo->output_scanline;
        JSAMPROW rp = row;
        if (jpeg_read_scanlines(cinfo, &rp, 1) != 1) {
            st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "corrupt or truncated JPEG: no data for row %zu", y);
            goto done;
        }
        float *d = out + y * w * (size_t)outc;
        for (size_t x = 0; x < w; ++x) {
            const unsigned char *s = row + x * (size_t)comps;
            if (comps == 1) {
                d[x] = s[0] / 255.0f;
            } else if (comps == 3) {
                for (int k = 0; k < 3; ++k)
                    d[3 * x + (size_t)k] = s[k] / 255.0f;
            } else {
                double k = inverted ? s[3] / 255.0 : 1.0 - s[3] / 255.0;
                for (int q = 0; q < 3; ++q) {
                    double v = inverted ? s[q] / 255.0 : 1.0 - s[q] / 255.0;
                    d[3 * x + (size_t)q] = (float)(v * k);
                }
            }
        }
    }
    jpeg_finish_decompress(cinfo);
    img->width = (int)w;
    img->height = (int)h;
    img->channels = outc;
    img->data = out;
    img->srgb = true;
    out = NULL;

done:
    jpeg_destroy_decompress(cinfo);
    fclose(f);
    free(row);
    free(out);
    free(cinfo);
    free(c);
    return st;
}
