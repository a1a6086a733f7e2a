/*
 * io/bmp.c: Windows BMP reading (no library): what Mitsuba's bitmap texture reads from .bmp files.
 *
 * Layout: a 14-byte file header ("BM", file size, pixel data offset), then a DIB header whose
 * first field is its size: 12 (OS/2 BITMAPCOREHEADER: 16-bit width and height, 3-byte palette
 * entries) or 40 and up (BITMAPINFOHEADER and its V2-V5 extensions: 32-bit signed width and
 * height, compression, palette size, colour masks at byte 40 of the header when it is 52 bytes or
 * longer, or just after a 40-byte header for BI_BITFIELDS).
 * Read: 1, 4 and 8 bits per pixel through the palette; 16 bits (5-5-5 unless masks say otherwise);
 * 24 bits (B, G, R); 32 bits (B, G, R, unused, or masks). Compression BI_RGB, or BI_BITFIELDS /
 * BI_ALPHABITFIELDS for 16 and 32 bits; RLE, JPEG and PNG payloads are refused with an error
 * naming them. Rows are padded to 4 bytes and stored bottom-up unless the height is negative.
 *
 * Output: 3 channels (alpha dropped, as the texture loader drops it), values the encoded ones in
 * [0, 1] (img->srgb = true; 8-bit BMP files are sRGB by convention).
 *
 * Robustness: the whole file is read (at most SPC_BMP_MAX_BYTES); every offset, the palette, every
 * row and every palette index are checked against what the file holds before use, so a corrupt
 * header cannot read outside the buffer or allocate more than its pixels need.
 */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/image_io.h"

#define SPC_BMP_MAX_BYTES ((size_t)1 << 30)  /* largest file read */
#define SPC_BMP_MAX_PIXELS ((size_t)1 << 28) /* 16384^2, as the other readers */

enum { BI_RGB = 0, BI_RLE8 = 1, BI_RLE4 = 2, BI_BITFIELDS = 3, BI_JPEG = 4, BI_PNG = 5, BI_ALPHABITFIELDS = 6 };

static uint32_t u16le(const unsigned char *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static uint32_t u32le(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* A colour mask as shift and maximum; false if not one run of 1 to 16 bits. */
typedef struct channel_mask {
    uint32_t mask;
    int shift;
    double max;
} channel_mask;

static bool mask_init(channel_mask *c, uint32_t mask)
{
    c->mask = mask;
    c->shift = 0;
    if (!mask)
        return false;
    while (!((mask >> c->shift) & 1u))
        ++c->shift;
    uint32_t v = mask >> c->shift;
    if (v & (v + 1u)) /* not a contiguous run of ones */
        return false;
    int bits = 0;
    while (v) {
        ++bits;
        v >>= 1;
    }
    if (bits > 16)
        return false;
    c->max = (double)((1u << bits) - 1u);
    return true;
}

static float mask_value(const channel_mask *c, uint32_t px) { return (float)(((px & c->mask) >> c->shift) / c->max); }

static spc_status read_file(const char *path, unsigned char **out, size_t *size, spc_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open image: %s", strerror(errno));
    size_t cap = 1 << 16, n = 0;
    unsigned char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break;
        if (cap >= SPC_BMP_MAX_BYTES) {
            free(buf);
            fclose(f);
            return spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "BMP file larger than %zu bytes", SPC_BMP_MAX_BYTES);
        }
        cap *= 2;
        unsigned char *q = realloc(buf, cap);
        if (!q)
            free(buf);
        buf = q;
    }
    bool bad = ferror(f) != 0;
    fclose(f);
    if (!buf)
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading the file");
    if (bad) {
        free(buf);
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "read error");
    }
    *out = buf;
    *size = n;
    return SPC_OK;
}

static spc_status decode(const char *path, const unsigned char *b, size_t size, spc_image *img, spc_error *err)
{
#define FAIL(...) return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "BMP: " __VA_ARGS__)
    if (size < 14 + 12 || b[0] != 'B' || b[1] != 'M')
        FAIL("not a BMP file (too short or no 'BM' signature)");
    size_t data_off = u32le(b + 10);
    size_t hsize = u32le(b + 14);
    bool core = hsize == 12;
    if (!core && hsize < 40)
        FAIL("unknown header size %zu", hsize);
    if (hsize > size - 14)
        FAIL("header of %zu bytes runs past the end of the file", hsize);
    const unsigned char *h = b + 14;
    int64_t width, height;
    uint32_t planes, bpp, compression = BI_RGB, ncolors = 0;
    if (core) {
        width = u16le(h + 4);
        height = u16le(h + 6);
        planes = u16le(h + 8);
        bpp = u16le(h + 10);
    } else {
        width = (int32_t)u32le(h + 4);
        height = (int32_t)u32le(h + 8);
        planes = u16le(h + 12);
        bpp = u16le(h + 14);
        compression = u32le(h + 16);
        ncolors = u32le(h + 32);
    }
    bool top_down = height < 0;
    if (top_down)
        height = -height;
    if (planes != 1)
        FAIL("%u colour planes (1 expected)", planes);
    if (width <= 0 || height <= 0)
        FAIL("empty or negative-width image (%lld x %lld)", (long long)width, (long long)height);
    if ((size_t)width * (size_t)height > SPC_BMP_MAX_PIXELS)
        return spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "BMP: image of %lld x %lld pixels is too large",
                             (long long)width, (long long)height);
    if (compression == BI_RLE8 || compression == BI_RLE4)
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "BMP: RLE-compressed files are not supported");
    if (compression == BI_JPEG || compression == BI_PNG)
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "BMP: embedded %s data is not supported",
                             compression == BI_JPEG ? "JPEG" : "PNG");
    bool bitfields = compression == BI_BITFIELDS || compression == BI_ALPHABITFIELDS;
    if (compression != BI_RGB && !bitfields)
        FAIL("unknown compression %u", compression);
    if (bpp != 1 && bpp != 4 && bpp != 8 && bpp != 16 && bpp != 24 && bpp != 32)
        FAIL("%u bits per pixel (1, 4, 8, 16, 24 or 32 expected)", bpp);
    if (bitfields && bpp != 16 && bpp != 32)
        FAIL("colour masks with %u bits per pixel (16 or 32 expected)", bpp);

    /* colour masks: 16-bit default 5-5-5, 32-bit default 8-8-8 */
    channel_mask cm[3];
    uint32_t masks[3] = {bpp == 16 ? 0x7c00u : 0xff0000u, bpp == 16 ? 0x03e0u : 0x00ff00u,
                         bpp == 16 ? 0x001fu : 0x0000ffu};
    size_t after_header = 14 + hsize;
    if (bitfields) {
        size_t at = 14 + 40;
        if (hsize == 40) { /* the masks follow the header */
            after_header += compression == BI_ALPHABITFIELDS ? 16 : 12;
            if (after_header > size)
                FAIL("colour masks run past the end of the file");
        } else if (hsize < 52) {
            FAIL("header of %zu bytes too short for colour masks", hsize);
        }
        for (int k = 0; k < 3; ++k)
            masks[k] = u32le(b + at + 4 * (size_t)k);
    }
    for (int k = 0; k < 3; ++k)
        if (!mask_init(&cm[k], masks[k]))
            FAIL("colour mask 0x%08x is not one run of 1 to 16 bits", masks[k]);

    /* palette */
    float pal[256][3];
    uint32_t npal = 0;
    if (bpp <= 8) {
        uint32_t maxpal = 1u << bpp;
        npal = ncolors ? ncolors : maxpal;
        if (npal > maxpal)
            FAIL("%u palette entries for %u bits per pixel", npal, bpp);
        size_t esize = core ? 3 : 4;
        if (after_header > size || (size - after_header) / esize < npal)
            FAIL("palette of %u entries runs past the end of the file", npal);
        for (uint32_t i = 0; i < npal; ++i) {
            const unsigned char *e = b + after_header + esize * i;
            pal[i][0] = e[2] / 255.0f;
            pal[i][1] = e[1] / 255.0f;
            pal[i][2] = e[0] / 255.0f;
        }
    }

    size_t w = (size_t)width, hgt = (size_t)height;
    size_t row_bytes = ((w * bpp + 31) / 32) * 4;
    if (data_off > size || (size - data_off) / row_bytes < hgt) {
        /* the last row may lack its padding in files cut exactly at the pixels */
        size_t need = row_bytes * (hgt - 1) + (w * bpp + 7) / 8;
        if (data_off > size || size - data_off < need)
            FAIL("pixel data (%zu rows of %zu bytes at offset %zu) runs past the end of the file (%zu bytes)", hgt,
                 row_bytes, data_off, size);
    }
    float *out = malloc(3 * w * hgt * sizeof(float));
    if (!out)
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for %zu x %zu pixels", w, hgt);
    for (size_t y = 0; y < hgt; ++y) {
        const unsigned char *row = b + data_off + row_bytes * (top_down ? y : hgt - 1 - y);
        float *o = out + 3 * w * y;
        for (size_t x = 0; x < w; ++x, o += 3) {
            if (bpp <= 8) {
                size_t bit = x * bpp;
                uint32_t idx = (row[bit / 8] >> (8 - bpp - bit % 8)) & ((1u << bpp) - 1u);
                if (idx >= npal) {
                    free(out);
                    FAIL("pixel (%zu, %zu) uses palette entry %u of %u", x, y, idx, npal);
                }
                memcpy(o, pal[idx], 3 * sizeof(float));
            } else if (bpp == 24) {
                const unsigned char *p = row + 3 * x;
                o[0] = p[2] / 255.0f;
                o[1] = p[1] / 255.0f;
                o[2] = p[0] / 255.0f;
            } else {
                uint32_t px = bpp == 16 ? u16le(row + 2 * x) : u32le(row + 4 * x);
                for (int k = 0; k < 3; ++k)
                    o[k] = mask_value(&cm[k], px);
            }
        }
    }
    img->width = (int)w;
    img->height = (int)hgt;
    img->channels = 3;
    img->data = out;
    img->srgb = true;
    return SPC_OK;
#undef FAIL
}

spc_status spc_bmp_read_image(const char *path, spc_image *img, spc_error *err)
{
    memset(img, 0, sizeof *img);
    unsigned char *buf = NULL;
    size_t size = 0;
    spc_status st = read_file(path, &buf, &size, err);
    if (st != SPC_OK)
        return st;
    st = decode(path, buf, size, img, err);
    free(buf);
    return st;
}
