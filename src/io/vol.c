/*
 * io/vol.c: Mitsuba's binary volume grid format (Mitsuba 0.6's and 3's gridvolume), little
 * endian:
 *   bytes 0-2   "VOL"               byte 3      version, 3
 *   int32       encoding, 1 (float32)
 *   int32 x3    cells along x, y, z
 *   int32       channels (1, 3; Mitsuba also has 6, which no medium property reads)
 *   float32 x6  bounding box xmin, ymin, zmin, xmax, ymax, zmax
 *   float32     data[((z * yres + y) * xres + x) * channels + c]
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/vol.h"

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static float lef(const unsigned char *p)
{
    uint32_t u = le32(p);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

spc_status spc_vol_read(const char *path, spc_volume *v, double bbox[6], spc_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open volume grid");
    unsigned char h[48];
    if (fread(h, 1, sizeof h, f) != sizeof h) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "truncated volume grid header (48 bytes)");
    }
    if (memcmp(h, "VOL", 3) != 0 || h[3] != 3) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "not a version 3 .vol volume grid");
    }
    int32_t enc = (int32_t)le32(h + 4), res[3] = {(int32_t)le32(h + 8), (int32_t)le32(h + 12), (int32_t)le32(h + 16)};
    int32_t ch = (int32_t)le32(h + 20);
    if (enc != 1) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "volume grid encoding %d (only 1, float32, is read)",
                             (int)enc);
    }
    if (ch != 1 && ch != 3) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "volume grid with %d channels (1 or 3 are read)", (int)ch);
    }
    if (res[0] <= 0 || res[1] <= 0 || res[2] <= 0) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "volume grid size %d x %d x %d", (int)res[0], (int)res[1],
                             (int)res[2]);
    }
    /* the count in double first: three sizes up to 2^31 overflow 64 bits */
    double nd = (double)res[0] * (double)res[1] * (double)res[2] * (double)ch;
    if (nd > (double)SPC_VOL_MAX_VALUES) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "volume grid of %.0f values (at most %llu)", nd,
                             (unsigned long long)SPC_VOL_MAX_VALUES);
    }
    unsigned long long n =
        (unsigned long long)res[0] * (unsigned long long)res[1] * (unsigned long long)res[2] * (unsigned long long)ch;
    /* the file must hold the values before anything is allocated for them */
    long here = ftell(f);
    if (here < 0 || fseek(f, 0, SEEK_END) != 0) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot seek in volume grid");
    }
    long end = ftell(f);
    if (end < 0 || fseek(f, here, SEEK_SET) != 0 || (unsigned long long)(end - here) < n * 4ull) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "truncated volume grid: %lld bytes for %llu values",
                             (long long)(end - here), n);
    }
    float *data = malloc((size_t)n * sizeof(float));
    unsigned char *raw = malloc((size_t)n * 4);
    if (!data || !raw) {
        free(data);
        free(raw);
        fclose(f);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for a %llu-value volume grid", n);
    }
    size_t got = fread(raw, 4, (size_t)n, f);
    fclose(f);
    if (got != (size_t)n) {
        free(data);
        free(raw);
        return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "truncated volume grid: %zu of %llu values", got, n);
    }
    for (size_t i = 0; i < (size_t)n; ++i) {
        data[i] = lef(raw + 4 * i);
        if (!isfinite(data[i])) {
            free(data);
            free(raw);
            return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "volume grid value %zu is not finite", i);
        }
    }
    free(raw);
    for (int k = 0; k < 3; ++k)
        v->res[k] = res[k];
    v->channels = ch;
    v->data = data;
    if (bbox)
        for (int k = 0; k < 6; ++k)
            bbox[k] = lef(h + 24 + 4 * k);
    return SPC_OK;
}
