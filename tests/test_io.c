/*
 * tests/test_io.c: image I/O. EXR write/read round trips (extra channels, attributes, HALF and
 * tiled files written here with the core API), atomic replacement (a failed write never
 * touches the old file: missing directory, invalid request, and a write that fails midway under
 * RLIMIT_FSIZE in a child process), PNG, JPEG and BMP reading in all layouts, corrupt and truncated
 * files (errors, never crashes; deterministic byte-flip fuzzing), and the sRGB functions.
 */
/* ctest-labels: unit */
#include <dirent.h>
#include <signal.h>
#include <stdio.h>
#include <stdint.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <jpeglib.h>
#include <openexr.h>
#include <png.h>

#include "harness.h"
#include "png_util.h"
#include "io/image_io.h"

static char tmpdir[256];

static void path_in_tmp(char *buf, size_t size, const char *name) { snprintf(buf, size, "%s/%s", tmpdir, name); }

static long file_size(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (long)sb.st_size : -1;
}

static unsigned char *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)n + 1);
    if (b && fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *size = (size_t)n;
    return b;
}

static void spit(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (f) {
        fwrite(data, 1, size, f);
        fclose(f);
    }
}

/* Counts files in tmpdir whose name contains ".tmp-" (leftover temporaries). */
static int count_temporaries(void)
{
    DIR *d = opendir(tmpdir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        if (strstr(e->d_name, ".tmp-"))
            ++n;
    if (d)
        closedir(d);
    return n;
}

static uint32_t lcg(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return *s >> 8;
}

/* ---------------- EXR ---------------- */

TEST(exr_roundtrip_channels_and_attributes)
{
    enum { W = 7, H = 5, C = 5 };
    const char *names[C] = {"R", "G", "B", "R_var", "albedo.G"};
    float data[W * H * C];
    for (int i = 0; i < W * H * C; ++i)
        data[i] = (float)(i * 0.37 - 3.0) * (i % 3 == 0 ? 1e-3f : 1.0f);
    data[3] = 65504.0f * 4.0f; /* beyond half range: must survive as float */
    char path[512];
    path_in_tmp(path, sizeof path, "rt.exr");
    spc_exr_attr attrs[2] = {{"specula.spp", "64"}, {"comments", "made by test_io"}};
    spc_error err = {0};
    CHECK(spc_exr_write(path, W, H, C, names, data, attrs, 2, &err) == SPC_OK);
    CHECK(count_temporaries() == 0);

    const char *want[4] = {"R_var", "Z", "albedo.G", "R"};
    float *out = NULL;
    bool found[4] = {true, true, true, true};
    int w = 0, h = 0;
    CHECK(spc_exr_read_channels(path, 4, want, &w, &h, &out, found, &err) == SPC_OK);
    CHECK(w == W && h == H);
    CHECK(found[0] && !found[1] && found[2] && found[3]);
    if (out && w == W && h == H) {
        int bad = 0;
        for (int p = 0; p < W * H; ++p) {
            bad += out[4 * p + 0] != data[C * p + 3];
            bad += out[4 * p + 1] != 0.0f;
            bad += out[4 * p + 2] != data[C * p + 4];
            bad += out[4 * p + 3] != data[C * p + 0];
        }
        CHECK_MSG(bad == 0, "%d values differ", bad);
    }
    free(out);

    /* spc_image_read: R, G, B (no A) */
    spc_image img;
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.width == W && img.height == H && img.channels == 3 && !img.srgb);
    if (img.data && img.channels == 3) {
        int bad = 0;
        for (int p = 0; p < W * H; ++p)
            for (int k = 0; k < 3; ++k)
                bad += img.data[3 * p + k] != data[C * p + k];
        CHECK(bad == 0);
    }
    spc_image_release(&img);
    CHECK(img.data == NULL);

    /* attributes, compression and pixel type through the library itself */
    exr_context_t ctx = NULL;
    CHECK(exr_start_read(&ctx, path, NULL) == EXR_ERR_SUCCESS);
    if (ctx) {
        const char *s = NULL;
        int32_t len = 0;
        CHECK(exr_attr_get_string(ctx, 0, "specula.spp", &len, &s) == EXR_ERR_SUCCESS);
        CHECK(s && strcmp(s, "64") == 0);
        CHECK(exr_attr_get_string(ctx, 0, "comments", &len, &s) == EXR_ERR_SUCCESS);
        CHECK(s && strcmp(s, "made by test_io") == 0);
        exr_compression_t comp;
        CHECK(exr_get_compression(ctx, 0, &comp) == EXR_ERR_SUCCESS && comp == EXR_COMPRESSION_ZIP);
        const exr_attr_chlist_t *cl = NULL;
        CHECK(exr_get_channels(ctx, 0, &cl) == EXR_ERR_SUCCESS && cl && cl->num_channels == C);
        for (int c = 0; cl && c < cl->num_channels; ++c)
            CHECK(cl->entries[c].pixel_type == EXR_PIXEL_FLOAT);
        exr_finish(&ctx);
    }
}

/* float -> half for normal numbers and zero (enough for the exact values used here). */
static uint16_t to_half(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    uint32_t sign = (u >> 16) & 0x8000u;
    int e = (int)((u >> 23) & 0xff) - 127 + 15;
    uint32_t m = (u >> 13) & 0x3ffu;
    if ((u & 0x7fffffffu) == 0)
        return (uint16_t)sign;
    return (uint16_t)(sign | (uint32_t)e << 10 | m);
}

/* The library's compress step with the fix for OpenEXR issue #2306 (see src/io/exr.c). */
static exr_result_t (*lib_compress)(exr_encode_pipeline_t *);
static exr_result_t compress_fixed(exr_encode_pipeline_t *e)
{
    exr_result_t rv = lib_compress(e);
    if (rv == EXR_ERR_SUCCESS && e->compressed_bytes == e->packed_bytes && e->compressed_buffer != e->packed_buffer)
        memcpy(e->compressed_buffer, e->packed_buffer, e->packed_bytes);
    return rv;
}

/* Writes an EXR with the core API: HALF channels, scanline or tiled (4x4 tiles), data window
 * starting at (x0, y0). data is interleaved float, converted to half here. */
static bool write_half_exr(const char *path, bool tiled, int x0, int y0, int w, int h, int nc, const char **names,
                           const float *data)
{
    uint16_t *hd = malloc(sizeof *hd * (size_t)(w * h * nc));
    for (int i = 0; i < w * h * nc; ++i)
        hd[i] = to_half(data[i]);
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int part = 0;
    bool ok = exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init) == EXR_ERR_SUCCESS;
    ok = ok && exr_add_part(ctx, "p", tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part) == EXR_ERR_SUCCESS;
    exr_attr_box2i_t dw;
    dw.min.x = x0, dw.min.y = y0, dw.max.x = x0 + w - 1, dw.max.y = y0 + h - 1;
    exr_attr_v2f_t swc;
    swc.x = 0.0f, swc.y = 0.0f;
    ok = ok && exr_initialize_required_attr(ctx, part, &dw, &dw, 1.0f, &swc, 1.0f, EXR_LINEORDER_INCREASING_Y,
                                            EXR_COMPRESSION_ZIPS) == EXR_ERR_SUCCESS;
    for (int c = 0; ok && c < nc; ++c)
        ok = exr_add_channel(ctx, part, names[c], EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1) ==
             EXR_ERR_SUCCESS;
    if (tiled)
        ok = ok && exr_set_tile_descriptor(ctx, part, 4, 4, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN) == EXR_ERR_SUCCESS;
    ok = ok && exr_write_header(ctx) == EXR_ERR_SUCCESS;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool first = true;
    int32_t lines = 1;
    if (ok && !tiled)
        ok = exr_get_scanlines_per_chunk(ctx, part, &lines) == EXR_ERR_SUCCESS;
    int ntx = tiled ? (w + 3) / 4 : 1, nty = tiled ? (h + 3) / 4 : (h + lines - 1) / lines;
    for (int ty = 0; ok && ty < nty; ++ty)
        for (int tx = 0; ok && tx < ntx; ++tx) {
            exr_chunk_info_t ci;
            int px = tiled ? 4 * tx : 0, py = tiled ? 4 * ty : ty * lines;
            if (tiled)
                ok = exr_write_tile_chunk_info(ctx, part, tx, ty, 0, 0, &ci) == EXR_ERR_SUCCESS;
            else
                ok = exr_write_scanline_chunk_info(ctx, part, y0 + py, &ci) == EXR_ERR_SUCCESS;
            ok = ok && (first ? exr_encoding_initialize(ctx, part, &ci, &enc)
                              : exr_encoding_update(ctx, part, &ci, &enc)) == EXR_ERR_SUCCESS;
            for (int k = 0; ok && k < enc.channel_count; ++k) {
                int c = 0;
                while (c < nc && strcmp(names[c], enc.channels[k].channel_name) != 0)
                    ++c;
                enc.channels[k].user_data_type = EXR_PIXEL_HALF;
                enc.channels[k].user_bytes_per_element = 2;
                enc.channels[k].user_pixel_stride = 2 * nc;
                enc.channels[k].user_line_stride = 2 * nc * w;
                enc.channels[k].encode_from_ptr = (const uint8_t *)(hd + ((size_t)py * w + px) * nc + c);
            }
            if (ok && first)
                ok = exr_encoding_choose_default_routines(ctx, part, &enc) == EXR_ERR_SUCCESS;
            if (ok && enc.compress_fn && enc.compress_fn != compress_fixed) {
                lib_compress = enc.compress_fn;
                enc.compress_fn = compress_fixed;
            }
            first = false;
            ok = ok && exr_encoding_run(ctx, part, &enc) == EXR_ERR_SUCCESS;
        }
    if (!first)
        exr_encoding_destroy(ctx, &enc);
    if (ctx)
        ok = exr_finish(&ctx) == EXR_ERR_SUCCESS && ok;
    free(hd);
    return ok;
}

/* OpenEXR's encoder bug #2306: a chunk whose zlib output is exactly as long as its raw bytes used
 * to be written compressed but read as raw. Tiny images with a varying amount of redundancy hit
 * that size; every one must read back exactly. */
TEST(exr_zip_chunks_that_do_not_shrink_roundtrip)
{
    char path[512];
    path_in_tmp(path, sizeof path, "zip_edge.exr");
    const char *names[1] = {"Y"};
    uint32_t s = 99;
    int bad_images = 0;
    for (int round = 0; round < 1500; ++round) {
        int w = 4 + (int)(lcg(&s) % 24);
        int distinct = 1 + (int)(lcg(&s) % 12);
        float v[32];
        for (int i = 0; i < w; ++i)
            v[i] = (float)(lcg(&s) % (uint32_t)distinct) * 0.37f + (float)(lcg(&s) % 3 == 0) * (float)lcg(&s);
        spc_error err = {0};
        if (spc_exr_write(path, w, 1, 1, names, v, NULL, 0, &err) != SPC_OK) {
            ++bad_images;
            continue;
        }
        float *out = NULL;
        int ow = 0, oh = 0;
        if (spc_exr_read_channels(path, 1, names, &ow, &oh, &out, NULL, &err) != SPC_OK || ow != w || oh != 1 ||
            memcmp(out, v, sizeof(float) * (size_t)w) != 0)
            ++bad_images;
        free(out);
    }
    CHECK_MSG(bad_images == 0, "%d of 1500 images did not round-trip", bad_images);
}

TEST(exr_reads_half_tiled_and_offset_windows)
{
    enum { W = 10, H = 7 };
    float data[W * H * 4];
    for (int p = 0; p < W * H; ++p)
        for (int k = 0; k < 4; ++k)
            data[4 * p + k] = (float)((p * 4 + k) % 29) * 0.125f + (k == 3 ? 0.5f : 0.0f);
    const char *names[4] = {"R", "G", "B", "A"};
    for (int variant = 0; variant < 2; ++variant) {
        bool tiled = variant == 1;
        char path[512];
        path_in_tmp(path, sizeof path, tiled ? "half_tiled.exr" : "half_scan.exr");
        CHECK(write_half_exr(path, tiled, 3, -2, W, H, 4, names, data));
        spc_image img;
        spc_error err = {0};
        spc_status st = spc_image_read(path, &img, &err);
        CHECK_MSG(st == SPC_OK, "%s", err.msg);
        CHECK(img.width == W && img.height == H && img.channels == 4);
        if (st == SPC_OK && img.channels == 4 && img.width == W && img.height == H) {
            int bad = 0;
            for (int i = 0; i < W * H * 4; ++i)
                bad += img.data[i] != data[i];
            CHECK_MSG(bad == 0, "%s: %d values differ", path, bad);
        }
        spc_image_release(&img);
    }
    /* a lone luminance channel reads as one channel */
    const char *y[1] = {"Y"};
    float yd[W * H];
    for (int i = 0; i < W * H; ++i)
        yd[i] = (float)i * 0.25f;
    char path[512];
    path_in_tmp(path, sizeof path, "gray.exr");
    CHECK(write_half_exr(path, false, 0, 0, W, H, 1, y, yd));
    spc_image img;
    spc_error err = {0};
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.channels == 1 && img.width == W);
    if (img.data && img.channels == 1)
        CHECK(img.data[17] == 17 * 0.25f);
    spc_image_release(&img);
}

TEST(exr_write_to_missing_directory_fails_cleanly)
{
    char path[512];
    snprintf(path, sizeof path, "%s/no/such/dir/out.exr", tmpdir);
    const char *names[1] = {"Y"};
    float v[4] = {1, 2, 3, 4};
    spc_error err = {0};
    CHECK(spc_exr_write(path, 2, 2, 1, names, v, NULL, 0, &err) == SPC_ERR_IO);
    CHECK(strstr(err.file, "out.exr") != NULL);
    CHECK(file_size(path) < 0);
    float rgb[12] = {0};
    CHECK(spc_png_write_srgb(path, 2, 2, rgb, &err) == SPC_ERR_IO);
}

TEST(exr_failed_write_keeps_old_file)
{
    char path[512];
    path_in_tmp(path, sizeof path, "keep.exr");
    const char *names[3] = {"R", "G", "B"};
    float small[2 * 2 * 3] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    spc_error err = {0};
    CHECK(spc_exr_write(path, 2, 2, 3, names, small, NULL, 0, &err) == SPC_OK);
    size_t n0 = 0;
    unsigned char *before = slurp(path, &n0);
    CHECK(before != NULL);

    /* Invalid requests fail before anything is written. */
    const char *dup[3] = {"R", "G", "R"};
    CHECK(spc_exr_write(path, 2, 2, 3, dup, small, NULL, 0, &err) == SPC_ERR_VALUE);
    spc_exr_attr bad_attr = {"channels", "not a channel list"};
    CHECK(spc_exr_write(path, 2, 2, 3, names, small, &bad_attr, 1, &err) != SPC_OK);
    CHECK(count_temporaries() == 0);

    /* A write that fails midway: the child may not write more than 4 KiB per file, and the
     * noisy 128x128 image needs far more. The child reports the status it got. */
    enum { W = 128, H = 128 };
    pid_t pid = fork();
    if (pid == 0) {
        signal(SIGXFSZ, SIG_IGN);
        struct rlimit rl = {4096, 4096};
        setrlimit(RLIMIT_FSIZE, &rl);
        float *big = malloc(sizeof(float) * W * H * 3);
        uint32_t s = 12345;
        for (int i = 0; big && i < W * H * 3; ++i)
            big[i] = (float)lcg(&s) / 16777216.0f;
        spc_error e = {0};
        spc_status st = spc_exr_write(path, W, H, 3, names, big, NULL, 0, &e);
        char png_path[600];
        snprintf(png_path, sizeof png_path, "%s.png", path);
        spc_status st2 = spc_png_write_srgb(png_path, W, H, big, &e);
        _exit(st == SPC_ERR_IO && st2 == SPC_ERR_IO ? 0 : 1);
    }
    int status = 0;
    CHECK(pid > 0 && waitpid(pid, &status, 0) == pid);
    CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 0, "child status %d", status);
    size_t n1 = 0;
    unsigned char *after = slurp(path, &n1);
    CHECK(after && n1 == n0 && memcmp(before, after, n0) == 0);
    CHECK(count_temporaries() == 0);
    char png_path[600];
    snprintf(png_path, sizeof png_path, "%s.png", path);
    CHECK(file_size(png_path) < 0);
    free(before);
    free(after);

    /* and the old file still reads */
    spc_image img;
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.width == 2 && img.data && img.data[11] == 12.0f);
    spc_image_release(&img);
}

/* ---------------- PNG ---------------- */

TEST(png_roundtrip_srgb)
{
    enum { W = 16, H = 16 };
    float rgb[W * H * 3];
    for (int i = 0; i < W * H * 3; ++i)
        rgb[i] = (float)spc_srgb_to_linear((i % 256) / 255.0);
    rgb[0] = -1.0f;        /* clamped to 0 */
    rgb[1] = 7.0f;         /* clamped to 1 */
    rgb[2] = NAN;          /* written as 0 */
    char path[512];
    path_in_tmp(path, sizeof path, "rt.png");
    spc_error err = {0};
    CHECK(spc_png_write_srgb(path, W, H, rgb, &err) == SPC_OK);
    CHECK(count_temporaries() == 0);
    spc_image img;
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.width == W && img.height == H && img.channels == 3 && img.srgb);
    if (img.data && img.channels == 3) {
        int bad = 0;
        for (int i = 3; i < W * H * 3; ++i)
            bad += fabs(img.data[i] - (i % 256) / 255.0) > 1e-6;
        CHECK_MSG(bad == 0, "%d values differ", bad);
        CHECK(img.data[0] == 0.0f && img.data[1] == 1.0f && img.data[2] == 0.0f);
    }
    spc_image_release(&img);
}

TEST(png_reads_every_layout)
{
    char path[512];
    spc_error err = {0};
    spc_image img;
    /* 16-bit gray (big endian samples) */
    unsigned char g16[2 * 2 * 2] = {0x00, 0x00, 0xff, 0xff, 0x80, 0x00, 0x12, 0x34};
    path_in_tmp(path, sizeof path, "g16.png");
    CHECK(write_png_raw(path, 2, 2, PNG_COLOR_TYPE_GRAY, 16, g16, 4, NULL, 0, NULL, 0));
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.channels == 1 && img.width == 2 && img.height == 2);
    if (img.data && img.channels == 1) {
        CHECK(img.data[0] == 0.0f && img.data[1] == 1.0f);
        CHECK_NEAR(img.data[2], 0x8000 / 65535.0, 1e-7);
        CHECK_NEAR(img.data[3], 0x1234 / 65535.0, 1e-7);
    }
    spc_image_release(&img);

    /* palette with transparency -> RGBA; 4-bit indices */
    png_color pal[3] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}};
    png_byte trns[3] = {255, 128, 0};
    unsigned char p4[1] = {0x12}; /* pixels 1, 2 */
    unsigned char p4rows[2] = {0x12, 0x00};
    (void)p4;
    path_in_tmp(path, sizeof path, "pal.png");
    CHECK(write_png_raw(path, 2, 2, PNG_COLOR_TYPE_PALETTE, 4, p4rows, 1, pal, 3, trns, 3));
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.channels == 4);
    if (img.data && img.channels == 4) {
        /* pixel 0 = index 1 (green, alpha 128), pixel 1 = index 2 (blue, alpha 0), row 1 = index 0 */
        CHECK(img.data[0] == 0.0f && img.data[1] == 1.0f && img.data[2] == 0.0f);
        CHECK_NEAR(img.data[3], 128 / 255.0, 1e-7);
        CHECK(img.data[6] == 1.0f && img.data[7] == 0.0f);
        CHECK(img.data[8] == 1.0f && img.data[11] == 1.0f);
    }
    spc_image_release(&img);

    /* gray + alpha -> RGBA */
    unsigned char ga[2 * 2] = {10, 20, 30, 40};
    path_in_tmp(path, sizeof path, "ga.png");
    CHECK(write_png_raw(path, 2, 1, PNG_COLOR_TYPE_GRAY_ALPHA, 8, ga, 4, NULL, 0, NULL, 0));
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.channels == 4 && img.width == 2 && img.height == 1);
    if (img.data && img.channels == 4) {
        CHECK_NEAR(img.data[4], 30 / 255.0, 1e-7);
        CHECK_NEAR(img.data[5], 30 / 255.0, 1e-7);
        CHECK_NEAR(img.data[7], 40 / 255.0, 1e-7);
    }
    spc_image_release(&img);

    /* 1-bit gray */
    unsigned char g1[2] = {0x80, 0x40};
    path_in_tmp(path, sizeof path, "g1.png");
    CHECK(write_png_raw(path, 2, 2, PNG_COLOR_TYPE_GRAY, 1, g1, 1, NULL, 0, NULL, 0));
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.channels == 1);
    if (img.data && img.channels == 1)
        CHECK(img.data[0] == 1.0f && img.data[1] == 0.0f && img.data[2] == 0.0f && img.data[3] == 1.0f);
    spc_image_release(&img);

    /* 16-bit RGBA */
    unsigned char rgba16[8] = {0xff, 0xff, 0x00, 0x00, 0x80, 0x00, 0x00, 0x01};
    path_in_tmp(path, sizeof path, "rgba16.png");
    CHECK(write_png_raw(path, 1, 1, PNG_COLOR_TYPE_RGBA, 16, rgba16, 8, NULL, 0, NULL, 0));
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.channels == 4);
    if (img.data && img.channels == 4) {
        CHECK(img.data[0] == 1.0f && img.data[1] == 0.0f);
        CHECK_NEAR(img.data[3], 1 / 65535.0, 1e-9);
    }
    spc_image_release(&img);
}

/* ---------------- JPEG ---------------- */

static bool write_jpeg(const char *path, int w, int h, int comps, const unsigned char *pix)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return false;
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr jerr;
    c.err = jpeg_std_error(&jerr);
    jpeg_create_compress(&c);
    jpeg_stdio_dest(&c, f);
    c.image_width = (JDIMENSION)w;
    c.image_height = (JDIMENSION)h;
    c.input_components = comps;
    c.in_color_space = comps == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, 98, TRUE);
    jpeg_start_compress(&c, TRUE);
    while (c.next_scanline < c.image_height) {
        JSAMPROW row = (JSAMPROW)(pix + (size_t)c.next_scanline * (size_t)(w * comps));
        jpeg_write_scanlines(&c, &row, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    fclose(f);
    return true;
}

TEST(jpeg_reads_rgb_and_gray)
{
    enum { W = 24, H = 16 };
    unsigned char pix[W * H * 3];
    for (int i = 0; i < W * H; ++i) {
        pix[3 * i] = 200;
        pix[3 * i + 1] = 100;
        pix[3 * i + 2] = 30;
    }
    char path[512];
    path_in_tmp(path, sizeof path, "c.jpg");
    CHECK(write_jpeg(path, W, H, 3, pix));
    spc_image img;
    spc_error err = {0};
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.width == W && img.height == H && img.channels == 3 && img.srgb);
    if (img.data && img.channels == 3) {
        CHECK_NEAR(img.data[3 * 37 + 0], 200 / 255.0, 3 / 255.0);
        CHECK_NEAR(img.data[3 * 37 + 1], 100 / 255.0, 3 / 255.0);
        CHECK_NEAR(img.data[3 * 37 + 2], 30 / 255.0, 3 / 255.0);
    }
    spc_image_release(&img);

    unsigned char gray[W * H];
    for (int i = 0; i < W * H; ++i)
        gray[i] = (unsigned char)(i % W < W / 2 ? 40 : 220);
    path_in_tmp(path, sizeof path, "g.jpg");
    CHECK(write_jpeg(path, W, H, 1, gray));
    CHECK(spc_image_read(path, &img, &err) == SPC_OK);
    CHECK(img.channels == 1 && img.width == W);
    if (img.data && img.channels == 1) {
        CHECK_NEAR(img.data[W * 8 + 2], 40 / 255.0, 4 / 255.0);
        CHECK_NEAR(img.data[W * 8 + W - 3], 220 / 255.0, 4 / 255.0);
    }
    spc_image_release(&img);
}

/* ---------------- corrupt files ---------------- */

/* Truncations of a valid file must all fail with SPC_ERR_PARSE. */
static void check_truncations(const char *src, const char *name, int steps)
{
    size_t n = 0;
    unsigned char *b = slurp(src, &n);
    CHECK(b != NULL && n > 16);
    if (!b)
        return;
    char path[512];
    path_in_tmp(path, sizeof path, name);
    int fails = 0;
    for (int k = 1; k <= steps; ++k) {
        size_t len = n * (size_t)k / (size_t)(steps + 1);
        if (len < 8)
            continue;
        spit(path, b, len);
        spc_image img;
        spc_error err = {0};
        spc_status st = spc_image_read(path, &img, &err);
        if (st != SPC_ERR_PARSE) {
            ++fails;
            printf("  %s truncated to %zu of %zu bytes: status %d\n", name, len, n, (int)st);
        }
        if (st == SPC_OK)
            spc_image_release(&img);
    }
    CHECK(fails == 0);
    free(b);
}

/* Random byte flips: reading must return (OK or an error), never crash or hang. */
static void fuzz(const char *src, const char *name, int rounds, uint32_t seed)
{
    size_t n = 0;
    unsigned char *b = slurp(src, &n);
    CHECK(b != NULL);
    if (!b)
        return;
    unsigned char *m = malloc(n);
    char path[512];
    path_in_tmp(path, sizeof path, name);
    int errors = 0;
    for (int r = 0; r < rounds; ++r) {
        memcpy(m, b, n);
        int flips = 1 + (int)(lcg(&seed) % 4);
        for (int k = 0; k < flips; ++k) {
            size_t at = 8 + lcg(&seed) % (n - 8); /* keep the magic so the format reader runs */
            m[at] = (unsigned char)lcg(&seed);
        }
        spit(path, m, n);
        spc_image img;
        spc_error err = {0};
        spc_status st = spc_image_read(path, &img, &err);
        if (st == SPC_OK) {
            CHECK(img.data != NULL && img.width > 0 && img.height > 0);
            spc_image_release(&img);
        } else {
            ++errors;
            CHECK(err.msg[0] != '\0');
        }
    }
    printf("  %s: %d of %d corrupted files rejected\n", name, errors, rounds);
    free(b);
    free(m);
}

TEST(corrupt_files_are_errors_not_crashes)
{
    char png_path[512], exr_path[512], jpg_path[512];
    path_in_tmp(png_path, sizeof png_path, "src.png");
    path_in_tmp(exr_path, sizeof exr_path, "src.exr");
    path_in_tmp(jpg_path, sizeof jpg_path, "src.jpg");
    enum { W = 32, H = 24 };
    float rgb[W * H * 3];
    unsigned char pix[W * H * 3];
    uint32_t s = 7;
    for (int i = 0; i < W * H * 3; ++i) {
        rgb[i] = (float)(lcg(&s) % 1000) / 1000.0f;
        pix[i] = (unsigned char)(lcg(&s) & 0xff);
    }
    spc_error err = {0};
    const char *names[3] = {"B", "G", "R"};
    CHECK(spc_png_write_srgb(png_path, W, H, rgb, &err) == SPC_OK);
    CHECK(spc_exr_write(exr_path, W, H, 3, names, rgb, NULL, 0, &err) == SPC_OK);
    CHECK(write_jpeg(jpg_path, W, H, 3, pix));

    check_truncations(png_path, "trunc.png", 12);
    check_truncations(exr_path, "trunc.exr", 12);
    check_truncations(jpg_path, "trunc.jpg", 12);

    /* a corrupted PNG data byte is caught by the CRC */
    size_t n = 0;
    unsigned char *b = slurp(png_path, &n);
    if (b) {
        b[n / 2] ^= 0x55;
        char path[512];
        path_in_tmp(path, sizeof path, "crc.png");
        spit(path, b, n);
        spc_image img;
        CHECK(spc_image_read(path, &img, &err) == SPC_ERR_PARSE);
        CHECK(strstr(err.file, "crc.png") != NULL);
        free(b);
    }

    /* not an image, and no file */
    char path[512];
    path_in_tmp(path, sizeof path, "text.png");
    spit(path, "hello, world\n", 13);
    spc_image img;
    CHECK(spc_image_read(path, &img, &err) == SPC_ERR_PARSE);
    path_in_tmp(path, sizeof path, "missing.exr");
    CHECK(spc_image_read(path, &img, &err) == SPC_ERR_IO);
    float *out = NULL;
    int w, h;
    const char *r[1] = {"R"};
    CHECK(spc_exr_read_channels(path, 1, r, &w, &h, &out, NULL, &err) == SPC_ERR_IO && out == NULL);
    CHECK(spc_exr_read_channels(png_path, 1, r, &w, &h, &out, NULL, &err) == SPC_ERR_PARSE && out == NULL);

    fuzz(png_path, "fuzz.png", 150, 1);
    fuzz(exr_path, "fuzz.exr", 150, 2);
    fuzz(jpg_path, "fuzz.jpg", 150, 3);
}

/* ---------------- BMP ---------------- */

/* The test image: 5 x 3 (rows padded), colour index (3x + 5y) mod ncol into bmp_pal. */
static const unsigned char bmp_pal[16][3] = {
    {10, 255, 0},   {50, 225, 17},  {90, 195, 34},  {130, 165, 51}, {170, 135, 68}, {210, 105, 85},
    {250, 75, 102}, {5, 45, 119},   {45, 15, 136},  {85, 240, 153}, {125, 210, 170}, {165, 180, 187},
    {205, 150, 204}, {245, 120, 221}, {0, 90, 238},  {40, 60, 255}};
enum { BMP_W = 5, BMP_H = 3 };
static int bmp_idx(int x, int y, int ncol) { return (3 * x + 5 * y) % ncol; }

static void put_u16(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
}
static void put_u32(unsigned char *p, uint32_t v)
{
    put_u16(p, v & 0xffff);
    put_u16(p + 2, v >> 16);
}

/* Writes the test image as a BMP: bpp 1/4/8 (palette of ncol), 16 (565 masks), 24, 32 (masks
 * if given, else BI_RGB); hsize 12, 40 or 124; top_down stores rows top first. Returns the size. */
static size_t make_bmp(unsigned char *b, int bpp, int hsize, bool top_down, const uint32_t *masks, int ncol,
                       uint32_t compression)
{
    memset(b, 0, 4096);
    bool core = hsize == 12;
    size_t at = 14 + (size_t)hsize;
    bool after_masks = masks && hsize == 40;
    size_t mask_at = hsize == 40 ? at : 14 + 40;
    if (after_masks)
        at += 12;
    if (masks)
        for (int k = 0; k < 3; ++k)
            put_u32(b + mask_at + 4 * (size_t)k, masks[k]);
    if (bpp <= 8)
        for (int i = 0; i < ncol; ++i) {
            unsigned char *e = b + at + (size_t)(core ? 3 : 4) * (size_t)i;
            e[0] = bmp_pal[i][2];
            e[1] = bmp_pal[i][1];
            e[2] = bmp_pal[i][0];
        }
    if (bpp <= 8)
        at += (size_t)(core ? 3 : 4) * (size_t)ncol;
    size_t row = ((BMP_W * (size_t)bpp + 31) / 32) * 4;
    for (int y = 0; y < BMP_H; ++y) {
        unsigned char *r = b + at + row * (size_t)(top_down ? y : BMP_H - 1 - y);
        for (int x = 0; x < BMP_W; ++x) {
            int i = bmp_idx(x, y, bpp <= 8 ? ncol : 16);
            const unsigned char *c = bmp_pal[i];
            if (bpp <= 8) {
                size_t bit = (size_t)x * (size_t)bpp;
                r[bit / 8] |= (unsigned char)(i << (8 - bpp - bit % 8));
            } else if (bpp == 16) {
                put_u16(r + 2 * x, (uint32_t)(c[0] >> 3) << 11 | (uint32_t)(c[1] >> 2) << 5 | (uint32_t)(c[2] >> 3));
            } else if (bpp == 24) {
                r[3 * x] = c[2];
                r[3 * x + 1] = c[1];
                r[3 * x + 2] = c[0];
            } else if (masks) { /* R in the low byte, then G, B */
                put_u32(r + 4 * x, (uint32_t)c[0] | (uint32_t)c[1] << 8 | (uint32_t)c[2] << 16);
            } else {
                put_u32(r + 4 * x, (uint32_t)c[2] | (uint32_t)c[1] << 8 | (uint32_t)c[0] << 16);
            }
        }
    }
    size_t size = at + row * BMP_H;
    b[0] = 'B';
    b[1] = 'M';
    put_u32(b + 2, (uint32_t)size);
    put_u32(b + 10, (uint32_t)at);
    put_u32(b + 14, (uint32_t)hsize);
    if (core) {
        put_u16(b + 18, BMP_W);
        put_u16(b + 20, BMP_H);
        put_u16(b + 22, 1);
        put_u16(b + 24, (uint32_t)bpp);
    } else {
        put_u32(b + 18, BMP_W);
        put_u32(b + 22, top_down ? (uint32_t)-BMP_H : BMP_H);
        put_u16(b + 26, 1);
        put_u16(b + 28, (uint32_t)bpp);
        put_u32(b + 30, compression);
        put_u32(b + 46, bpp <= 8 ? (uint32_t)ncol : 0);
    }
    return size;
}

TEST(bmp_reads_every_layout)
{
    static const uint32_t rgbx[3] = {0x000000ffu, 0x0000ff00u, 0x00ff0000u};
    static const uint32_t m565[3] = {0xf800u, 0x07e0u, 0x001fu};
    static const struct {
        const char *name;
        int bpp, hsize;
        bool top_down;
        const uint32_t *masks;
        int ncol;
    } v[] = {{"24-bit", 24, 40, false, NULL, 0},         {"32-bit V5 top-down", 32, 124, true, NULL, 0},
             {"32-bit masks", 32, 40, false, rgbx, 0},   {"32-bit V5 masks", 32, 124, false, rgbx, 0},
             {"16-bit 565", 16, 40, true, m565, 0},      {"8-bit palette", 8, 40, false, NULL, 16},
             {"4-bit palette", 4, 40, false, NULL, 11},  {"1-bit OS/2", 1, 12, false, NULL, 2}};
    unsigned char b[4096];
    char path[512];
    path_in_tmp(path, sizeof path, "t.bmp");
    for (size_t k = 0; k < sizeof v / sizeof v[0]; ++k) {
        size_t n = make_bmp(b, v[k].bpp, v[k].hsize, v[k].top_down, v[k].masks, v[k].ncol,
                            v[k].masks ? 3u : 0u);
        spit(path, b, n);
        spc_image img;
        spc_error err = {0};
        spc_status st = spc_image_read(path, &img, &err);
        CHECK_MSG(st == SPC_OK, "%s: %s", v[k].name, err.msg);
        if (st != SPC_OK)
            continue;
        CHECK(img.width == BMP_W && img.height == BMP_H && img.channels == 3 && img.srgb);
        int bad = 0;
        for (int y = 0; y < BMP_H; ++y)
            for (int x = 0; x < BMP_W; ++x) {
                const unsigned char *c = bmp_pal[bmp_idx(x, y, v[k].bpp <= 8 ? v[k].ncol : 16)];
                for (int ch = 0; ch < 3; ++ch) {
                    double want = c[ch] / 255.0;
                    if (v[k].bpp == 16) {
                        int bits = ch == 1 ? 6 : 5;
                        want = (double)(c[ch] >> (8 - bits)) / ((1 << bits) - 1);
                    }
                    bad += fabs(img.data[3 * (y * BMP_W + x) + ch] - want) > 1e-6;
                }
            }
        CHECK_MSG(bad == 0, "%s: %d values differ", v[k].name, bad);
        spc_image_release(&img);
    }

    /* refused with errors that say why */
    spc_image img;
    spc_error err = {0};
    size_t n = make_bmp(b, 8, 40, false, NULL, 16, 1); /* RLE8 */
    spit(path, b, n);
    CHECK(spc_image_read(path, &img, &err) == SPC_ERR_VALUE && strstr(err.msg, "RLE") && strstr(err.file, "t.bmp"));
    n = make_bmp(b, 8, 40, false, NULL, 16, 0);
    put_u32(b + 46, 4); /* 4 palette entries, pixels use up to 15 */
    spit(path, b, n);
    CHECK(spc_image_read(path, &img, &err) == SPC_ERR_PARSE && strstr(err.msg, "palette"));
    n = make_bmp(b, 24, 40, false, NULL, 0, 0);
    put_u32(b + 18, 40000); /* wider than the file holds */
    spit(path, b, n);
    CHECK(spc_image_read(path, &img, &err) == SPC_ERR_PARSE && strstr(err.msg, "past the end"));
    n = make_bmp(b, 32, 40, false, rgbx, 0, 3);
    put_u32(b + 14 + 40, 0x0f0f0000u); /* not one run of bits */
    spit(path, b, n);
    CHECK(spc_image_read(path, &img, &err) == SPC_ERR_PARSE && strstr(err.msg, "mask"));

    /* truncations are parse errors; byte flips never crash */
    n = make_bmp(b, 24, 40, false, NULL, 0, 0);
    spit(path, b, n);
    check_truncations(path, "trunc.bmp", 12);
    fuzz(path, "fuzz.bmp", 300, 4);
    n = make_bmp(b, 4, 40, true, NULL, 11, 0);
    spit(path, b, n);
    fuzz(path, "fuzz4.bmp", 300, 5);
}

/* ---------------- sRGB ---------------- */

TEST(srgb_functions_are_inverses)
{
    double worst = 0.0;
    for (int i = 0; i <= 1000; ++i) {
        double v = i / 1000.0;
        worst = fmax(worst, fabs(spc_linear_to_srgb(spc_srgb_to_linear(v)) - v));
        worst = fmax(worst, fabs(spc_srgb_to_linear(spc_linear_to_srgb(v)) - v));
    }
    CHECK(worst < 1e-12);
    CHECK_NEAR(spc_srgb_to_linear(0.5), 0.214041140482232, 1e-12);
    CHECK_NEAR(spc_linear_to_srgb(0.5), 0.735356983052449, 1e-12);
    CHECK(spc_srgb_to_linear(0.0) == 0.0 && fabs(spc_srgb_to_linear(1.0) - 1.0) < 1e-15);
    /* continuous at the joint of the two pieces */
    CHECK_NEAR(spc_srgb_to_linear(0.04045 - 1e-12), spc_srgb_to_linear(0.04045 + 1e-12), 1e-8); /* the standard curve jumps by 2e-9 here */
    CHECK_NEAR(spc_linear_to_srgb(0.0031308 - 1e-12), spc_linear_to_srgb(0.0031308 + 1e-12), 1e-7);
    /* monotonic */
    bool mono = true;
    for (int i = 0; i < 1000; ++i)
        mono &= spc_srgb_to_linear((i + 1) / 1000.0) > spc_srgb_to_linear(i / 1000.0);
    CHECK(mono);
}

int main(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/specula_test_io_XXXXXX");
    if (!mkdtemp(tmpdir)) {
        printf("cannot create a temporary directory\n");
        return 1;
    }
    spc_warn_set_quiet(1);
    RUN(exr_roundtrip_channels_and_attributes);
    RUN(exr_zip_chunks_that_do_not_shrink_roundtrip);
    RUN(exr_reads_half_tiled_and_offset_windows);
    RUN(exr_write_to_missing_directory_fails_cleanly);
    RUN(exr_failed_write_keeps_old_file);
    RUN(png_roundtrip_srgb);
    RUN(png_reads_every_layout);
    RUN(jpeg_reads_rgb_and_gray);
    RUN(corrupt_files_are_errors_not_crashes);
    RUN(bmp_reads_every_layout);
    RUN(srgb_functions_are_inverses);
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (system(cmd) != 0)
        printf("could not remove %s\n", tmpdir);
    return spc_test_finish();
}
