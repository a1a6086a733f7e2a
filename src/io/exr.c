/*
 * io/exr.c: OpenEXR reading and writing through the OpenEXR core C API (openexr.h, 3.1).
 *
 * Writing: one scanline part, FLOAT channels, ZIP compression (16 lines per chunk). The library
 * writes through our own write callback into the descriptor of "<path>.tmp-<pid>" (see
 * spc_atomic_open in image_write.c), which is renamed over path only once exr_finish has written the
 * chunk offset table, so a failure at any step leaves the previous file intact.
 *
 * OpenEXR's encoder (3.1 up to 3.4.7, issue #2306) keeps zlib output whose size EQUALS the raw
 * chunk size, but readers take a chunk of exactly the raw size to be stored uncompressed, so that
 * chunk decodes to garbage. We wrap the pipeline's compress step and store the raw bytes in that
 * case, which is what fixed versions do.
 *
 * Reading: part 0 of a scanline or tiled file (tiles: level 0 only); every requested channel is
 * decoded by the library's default pipeline straight into a float plane (HALF, FLOAT and UINT are
 * converted by the library). Subsampled and deep data are refused with an error, not a crash; a
 * truncated or corrupt file is reported by the library and becomes SPC_ERR_PARSE.
 */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <openexr.h>

#include "io/image_io.h"

/* Pixels we accept in one image (2^28 = 16384^2): beyond this a corrupt header is likelier than a
 * real image, and the float planes would need gigabytes. */
#define SPC_EXR_MAX_PIXELS ((size_t)1 << 28)
/* Decoded bytes of one chunk (16-256 scanlines, or a tile, of every channel): 256 MiB is twenty
 * times a 16384-wide, 16-line chunk of 13 float channels. A corrupt header can claim a chunk of
 * gigabytes (found by fuzzing: 3.2 GB from a 3445-byte file), which OpenEXR would allocate. */
#define SPC_EXR_MAX_CHUNK_BYTES ((uint64_t)1 << 28)

/* The library reports details through a callback; keep the last message of this thread. */
static _Thread_local char last_msg[512];

static void error_cb(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    snprintf(last_msg, sizeof last_msg, "%s (%s)", msg ? msg : "", exr_get_error_code_as_string(code));
}

static spc_status exr_fail(spc_error *err, spc_status code, const char *path, const char *what, exr_result_t rv)
{
    if (last_msg[0])
        return spc_error_set(err, code, path, 0, 0, "%s: %s", what, last_msg);
    return spc_error_set(err, code, path, 0, 0, "%s: %s", what, exr_get_default_error_message(rv));
}

/* ---- writing ---- */

typedef struct write_target {
    int fd;
    int err_no; /* errno of the first failed write */
    exr_result_t (*compress)(exr_encode_pipeline_t *); /* the library's compress step */
} write_target;

/* The library's compress step, then raw bytes when compression saved nothing (see above). */
static exr_result_t compress_fixed(exr_encode_pipeline_t *enc)
{
    const write_target *t = enc->encoding_user_data;
    exr_result_t rv = t->compress(enc);
    if (rv == EXR_ERR_SUCCESS && enc->compressed_bytes == enc->packed_bytes && enc->compressed_buffer &&
        enc->packed_buffer && enc->compressed_buffer != enc->packed_buffer)
        memcpy(enc->compressed_buffer, enc->packed_buffer, enc->packed_bytes);
    return rv;
}

static int64_t write_cb(exr_const_context_t ctxt, void *userdata, const void *buffer, uint64_t sz, uint64_t offset,
                        exr_stream_error_func_ptr_t error_fn)
{
    (void)ctxt;
    (void)error_fn;
    write_target *t = userdata;
    const unsigned char *p = buffer;
    uint64_t left = sz;
    while (left > 0) {
        ssize_t w = pwrite(t->fd, p, (size_t)left, (off_t)offset);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0) {
            if (!t->err_no)
                t->err_no = w < 0 ? errno : EIO;
            return -1;
        }
        p += w;
        offset += (uint64_t)w;
        left -= (uint64_t)w;
    }
    return (int64_t)sz;
}

spc_status spc_exr_write(const char *path, int width, int height, int nchannels, const char *const *names,
                         const float *data, const spc_exr_attr *attrs, int nattrs, spc_error *err)
{
    if (width <= 0 || height <= 0 || nchannels <= 0 || !names || !data || nattrs < 0 || (nattrs > 0 && !attrs))
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "invalid EXR write request (%dx%d, %d channels)", width,
                             height, nchannels);
    if ((size_t)width * (size_t)height > SPC_EXR_MAX_PIXELS || (size_t)width * (size_t)nchannels * 4 > INT32_MAX)
        return spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "image too large for EXR output (%dx%d, %d channels)",
                             width, height, nchannels);
    for (int c = 0; c < nchannels; ++c) {
        if (!names[c] || !names[c][0])
            return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "EXR channel %d has no name", c);
        for (int d = 0; d < c; ++d)
            if (strcmp(names[c], names[d]) == 0)
                return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "EXR channel '%s' given twice", names[c]);
    }

    size_t tmpsize = strlen(path) + 64;
    char *tmp = malloc(tmpsize);
    if (!tmp)
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    write_target target = {-1, 0, NULL};
    target.fd = spc_atomic_open(path, tmp, tmpsize, err);
    if (target.fd < 0) {
        free(tmp);
        return err ? err->code : SPC_ERR_IO;
    }

    last_msg[0] = '\0';
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = error_cb;
    init.user_data = &target;
    init.write_fn = write_cb;
    exr_context_t ctx = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool enc_init = false;
    const char *step = "cannot start EXR output";
    int part = 0;
    exr_result_t rv = exr_start_write(&ctx, tmp, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv == EXR_ERR_SUCCESS) {
        step = "cannot define EXR header";
        rv = exr_add_part(ctx, NULL, EXR_STORAGE_SCANLINE, &part);
    }
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctx, part, width, height, EXR_COMPRESSION_ZIP);
    for (int c = 0; c < nchannels && rv == EXR_ERR_SUCCESS; ++c)
        rv = exr_add_channel(ctx, part, names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    for (int a = 0; a < nattrs && rv == EXR_ERR_SUCCESS; ++a) {
        step = "cannot set EXR attribute";
        if (!attrs[a].name || !attrs[a].value)
            rv = EXR_ERR_INVALID_ARGUMENT;
        else
            rv = exr_attr_set_string(ctx, part, attrs[a].name, attrs[a].value);
    }
    if (rv == EXR_ERR_SUCCESS) {
        step = "cannot write EXR header";
        rv = exr_write_header(ctx);
    }
    int32_t lines = 0;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_scanlines_per_chunk(ctx, part, &lines);
    if (rv == EXR_ERR_SUCCESS && lines <= 0)
        rv = EXR_ERR_INVALID_ARGUMENT;

    const int32_t pixel_stride = (int32_t)(nchannels * (int)sizeof(float));
    const int32_t line_stride = width * pixel_stride;
    for (int y = 0; y < height && rv == EXR_ERR_SUCCESS; y += lines) {
        step = "cannot write EXR pixels";
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(ctx, part, y, &cinfo);
        if (rv != EXR_ERR_SUCCESS)
            break;
        rv = enc_init ? exr_encoding_update(ctx, part, &cinfo, &enc) : exr_encoding_initialize(ctx, part, &cinfo, &enc);
        if (rv != EXR_ERR_SUCCESS)
            break;
        for (int k = 0; k < enc.channel_count; ++k) {
            exr_coding_channel_info_t *ch = &enc.channels[k];
            int c = 0;
            while (c < nchannels && strcmp(names[c], ch->channel_name) != 0)
                ++c;
            if (c == nchannels) {
                rv = EXR_ERR_INCORRECT_CHUNK;
                break;
            }
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
            ch->user_pixel_stride = pixel_stride;
            ch->user_line_stride = line_stride;
            ch->encode_from_ptr = (const uint8_t *)(data + ((size_t)y * (size_t)width * (size_t)nchannels + (size_t)c));
        }
        if (rv == EXR_ERR_SUCCESS && !enc_init) {
            enc_init = true;
            rv = exr_encoding_choose_default_routines(ctx, part, &enc);
        }
        if (rv == EXR_ERR_SUCCESS && enc.compress_fn && enc.compress_fn != compress_fixed) {
            target.compress = enc.compress_fn;
            enc.compress_fn = compress_fixed;
        }
        enc.encoding_user_data = &target;
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(ctx, part, &enc);
    }
    if (enc_init)
        exr_encoding_destroy(ctx, &enc);
    if (ctx) {
        exr_result_t frv = exr_finish(&ctx);
        if (rv == EXR_ERR_SUCCESS) {
            step = "cannot finish EXR file";
            rv = frv;
        }
    }
    if (rv != EXR_ERR_SUCCESS || target.err_no) {
        spc_atomic_abort(target.fd, tmp);
        free(tmp);
        if (target.err_no)
            return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "%s: %s", step, strerror(target.err_no));
        return exr_fail(err, SPC_ERR_IO, path, step, rv);
    }
    spc_status st = spc_atomic_commit(target.fd, tmp, path, err);
    free(tmp);
    return st;
}

/* ---- reading ---- */

/* Decodes the requested channels of part 0 into float planes (width*height each). planes[i] is
 * allocated for every name found; found[i] says which. */
static spc_status read_planes(const char *path, int nnames, const char *const *names, int *width, int *height,
                              float **planes, bool *found, spc_error *err)
{
    for (int i = 0; i < nnames; ++i) {
        planes[i] = NULL;
        found[i] = false;
    }
    FILE *probe = fopen(path, "rb");
    if (!probe)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open EXR: %s", strerror(errno));
    fclose(probe);

    last_msg[0] = '\0';
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = error_cb;
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_start_read(&ctx, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        if (ctx)
            exr_finish(&ctx);
        return exr_fail(err, SPC_ERR_PARSE, path, "not a readable OpenEXR file", rv);
    }

    spc_status st = SPC_OK;
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chlist = NULL;
    size_t w = 0, h = 0;
    if ((rv = exr_get_storage(ctx, 0, &storage)) != EXR_ERR_SUCCESS ||
        (rv = exr_get_data_window(ctx, 0, &dw)) != EXR_ERR_SUCCESS ||
        (rv = exr_get_channels(ctx, 0, &chlist)) != EXR_ERR_SUCCESS || !chlist) {
        st = exr_fail(err, SPC_ERR_PARSE, path, "bad EXR header", rv);
        goto done;
    }
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "deep EXR images are not supported");
        goto done;
    }
    if ((int64_t)dw.max.x < (int64_t)dw.min.x || (int64_t)dw.max.y < (int64_t)dw.min.y) {
        st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "empty EXR data window");
        goto done;
    }
    w = (size_t)((int64_t)dw.max.x - (int64_t)dw.min.x + 1);
    h = (size_t)((int64_t)dw.max.y - (int64_t)dw.min.y + 1);
    if (w > SPC_EXR_MAX_PIXELS || h > SPC_EXR_MAX_PIXELS || w * h > SPC_EXR_MAX_PIXELS) {
        st = spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "EXR image too large (%zux%zu)", w, h);
        goto done;
    }
    for (int i = 0; i < nnames; ++i) {
        for (int c = 0; c < chlist->num_channels; ++c) {
            const exr_attr_chlist_entry_t *e = &chlist->entries[c];
            if (!e->name.str || strcmp(e->name.str, names[i]) != 0)
                continue;
            if (e->x_sampling != 1 || e->y_sampling != 1) {
                st = spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "subsampled EXR channel '%s' is not supported",
                                   names[i]);
                goto done;
            }
            found[i] = true;
        }
    }
    /* the planes are allocated once the first chunk's table entry has been read: a corrupt header
     * claiming a huge image in a tiny file is refused before gigabytes are reserved */
    bool planes_ready = false;

    /* Chunks: scanline blocks, or level-0 tiles. (x0, y0) is the chunk's first pixel relative to
     * the data window. */
    int32_t lines = 0, tw = 0, th = 0, ntx = 1, nty = 0;
    if (storage == EXR_STORAGE_SCANLINE) {
        rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
        if (rv == EXR_ERR_SUCCESS && lines <= 0)
            rv = EXR_ERR_INVALID_ATTR;
        if (rv == EXR_ERR_SUCCESS)
            nty = (int32_t)((h + (size_t)lines - 1) / (size_t)lines);
    } else {
        rv = exr_get_tile_sizes(ctx, 0, 0, 0, &tw, &th);
        if (rv == EXR_ERR_SUCCESS && (tw <= 0 || th <= 0))
            rv = EXR_ERR_INVALID_ATTR;
        if (rv == EXR_ERR_SUCCESS) {
            ntx = (int32_t)((w + (size_t)tw - 1) / (size_t)tw);
            nty = (int32_t)((h + (size_t)th - 1) / (size_t)th);
        }
    }
    if (rv != EXR_ERR_SUCCESS) {
        st = exr_fail(err, SPC_ERR_PARSE, path, "bad EXR chunk layout", rv);
        goto done;
    }

    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    bool dec_init = false;
    for (int32_t ty = 0; ty < nty && rv == EXR_ERR_SUCCESS; ++ty) {
        for (int32_t tx = 0; tx < ntx && rv == EXR_ERR_SUCCESS; ++tx) {
            exr_chunk_info_t cinfo;
            size_t x0, y0;
            if (storage == EXR_STORAGE_SCANLINE) {
                x0 = 0;
                y0 = (size_t)ty * (size_t)lines;
                rv = exr_read_scanline_chunk_info(ctx, 0, (int)(dw.min.y + (int64_t)y0), &cinfo);
            } else {
                x0 = (size_t)tx * (size_t)tw;
                y0 = (size_t)ty * (size_t)th;
                rv = exr_read_tile_chunk_info(ctx, 0, tx, ty, 0, 0, &cinfo);
            }
            if (rv != EXR_ERR_SUCCESS)
                break;
            if (cinfo.unpacked_size > SPC_EXR_MAX_CHUNK_BYTES) {
                /* the library would allocate it whole before looking at the data */
                st = spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "EXR chunk of %llu bytes is too large",
                                   (unsigned long long)cinfo.unpacked_size);
                rv = EXR_ERR_CORRUPT_CHUNK;
                break;
            }
            for (int i = 0; i < nnames && !planes_ready; ++i) {
                if (found[i] && !(planes[i] = calloc(w * h, sizeof(float)))) {
                    st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for a %zux%zu image", w, h);
                    rv = EXR_ERR_OUT_OF_MEMORY;
                    break;
                }
            }
            if (rv != EXR_ERR_SUCCESS)
                break;
            planes_ready = true;
            rv = dec_init ? exr_decoding_update(ctx, 0, &cinfo, &dec) : exr_decoding_initialize(ctx, 0, &cinfo, &dec);
            if (rv != EXR_ERR_SUCCESS)
                break;
            for (int k = 0; k < dec.channel_count; ++k) {
                exr_coding_channel_info_t *ch = &dec.channels[k];
                ch->decode_to_ptr = NULL;
                for (int i = 0; i < nnames; ++i) {
                    if (!found[i] || strcmp(names[i], ch->channel_name) != 0)
                        continue;
                    /* The library writes ch->height lines of ch->width pixels: they must fit. */
                    if (ch->width < 0 || ch->height < 0 || x0 + (size_t)ch->width > w ||
                        y0 + (size_t)ch->height > h) {
                        rv = EXR_ERR_CORRUPT_CHUNK;
                        break;
                    }
                    ch->user_data_type = EXR_PIXEL_FLOAT;
                    ch->user_bytes_per_element = (int16_t)sizeof(float);
                    ch->user_pixel_stride = (int32_t)sizeof(float);
                    ch->user_line_stride = (int32_t)(w * sizeof(float));
                    ch->decode_to_ptr = (uint8_t *)(planes[i] + y0 * w + x0);
                }
            }
            if (rv == EXR_ERR_SUCCESS && !dec_init) {
                dec_init = true;
                rv = exr_decoding_choose_default_routines(ctx, 0, &dec);
            }
            if (rv == EXR_ERR_SUCCESS)
                rv = exr_decoding_run(ctx, 0, &dec);
        }
    }
    if (dec_init)
        exr_decoding_destroy(ctx, &dec);
    if (rv != EXR_ERR_SUCCESS && st == SPC_OK)
        st = exr_fail(err, SPC_ERR_PARSE, path, "corrupt or truncated EXR pixel data", rv);

done:
    exr_finish(&ctx);
    if (st != SPC_OK) {
        for (int i = 0; i < nnames; ++i) {
            free(planes[i]);
            planes[i] = NULL;
        }
        return st;
    }
    *width = (int)w;
    *height = (int)h;
    return SPC_OK;
}

/* Names of the channels in part 0 (for picking R,G,B,A / Y / a lone channel). */
static spc_status list_channels(const char *path, char names[][64], int max, int *count, spc_error *err)
{
    FILE *probe = fopen(path, "rb");
    if (!probe)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open EXR: %s", strerror(errno));
    fclose(probe);
    last_msg[0] = '\0';
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = error_cb;
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_start_read(&ctx, path, &init);
    const exr_attr_chlist_t *chlist = NULL;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_channels(ctx, 0, &chlist);
    if (rv != EXR_ERR_SUCCESS || !chlist) {
        if (ctx)
            exr_finish(&ctx);
        return exr_fail(err, SPC_ERR_PARSE, path, "not a readable OpenEXR file", rv);
    }
    *count = 0;
    for (int c = 0; c < chlist->num_channels && *count < max; ++c)
        if (chlist->entries[c].name.str)
            snprintf(names[(*count)++], 64, "%s", chlist->entries[c].name.str);
    exr_finish(&ctx);
    return SPC_OK;
}

spc_status spc_exr_read_image(const char *path, spc_image *img, spc_error *err)
{
    memset(img, 0, sizeof *img);
    char chans[64][64];
    int nchans = 0;
    spc_status st = list_channels(path, chans, 64, &nchans, err);
    if (st != SPC_OK)
        return st;
    bool has[5] = {false};
    static const char *const rgbay[5] = {"R", "G", "B", "A", "Y"};
    for (int c = 0; c < nchans; ++c)
        for (int k = 0; k < 5; ++k)
            if (strcmp(chans[c], rgbay[k]) == 0)
                has[k] = true;

    const char *want[4];
    int n;
    if (has[0] && has[1] && has[2]) {
        want[0] = "R", want[1] = "G", want[2] = "B", want[3] = "A";
        n = has[3] ? 4 : 3;
    } else if (has[4]) {
        want[0] = "Y";
        n = 1;
    } else if (nchans == 1) {
        want[0] = chans[0];
        n = 1;
    } else {
        return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "EXR has no R,G,B or Y channels");
    }

    float *planes[4] = {NULL};
    bool found[4] = {false};
    int w = 0, h = 0;
    st = read_planes(path, n, want, &w, &h, planes, found, err);
    if (st != SPC_OK)
        return st;
    size_t np = (size_t)w * (size_t)h;
    img->data = malloc(np * (size_t)n * sizeof(float));
    if (!img->data) {
        for (int i = 0; i < n; ++i)
            free(planes[i]);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for a %dx%d image", w, h);
    }
    for (size_t p = 0; p < np; ++p)
        for (int i = 0; i < n; ++i)
            img->data[p * (size_t)n + (size_t)i] = planes[i] ? planes[i][p] : 0.0f;
    for (int i = 0; i < n; ++i)
        free(planes[i]);
    img->width = w;
    img->height = h;
    img->channels = n;
    img->srgb = false;
    return SPC_OK;
}

spc_status spc_exr_read_channels(const char *path, int nnames, const char *const *names, int *width, int *height,
                                 float **out, bool *found, spc_error *err)
{
    *out = NULL;
    if (nnames <= 0 || !names)
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "no EXR channels requested");
    float **planes = calloc((size_t)nnames, sizeof *planes);
    bool *have = calloc((size_t)nnames, sizeof *have);
    if (!planes || !have) {
        free(planes);
        free(have);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    }
    int w = 0, h = 0;
    spc_status st = read_planes(path, nnames, names, &w, &h, planes, have, err);
    if (st == SPC_OK) {
        size_t np = (size_t)w * (size_t)h;
        float *buf = malloc(np * (size_t)nnames * sizeof(float));
        if (!buf) {
            st = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for a %dx%d image", w, h);
        } else {
            for (size_t p = 0; p < np; ++p)
                for (int i = 0; i < nnames; ++i)
                    buf[p * (size_t)nnames + (size_t)i] = planes[i] ? planes[i][p] : 0.0f;
            *out = buf;
            *width = w;
            *height = h;
            if (found)
                for (int i = 0; i < nnames; ++i)
                    found[i] = have[i];
        }
    }
    for (int i = 0; i < nnames; ++i)
        free(planes[i]);
    free(planes);
    free(have);
    return st;
}
