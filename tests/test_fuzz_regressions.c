/*
 * tests/test_fuzz_regressions.c: replays, through the same entry points as the libFuzzer harnesses
 * (fuzz/fuzz_targets.h), every input that once crashed, hung or tripped a sanitizer in a loader
 * (tests/data/fuzz_regressions/<target>/, named after what they found), plus the seed corpora
 * (fuzz/corpus/<target>/). Each must load or fail cleanly; under SPC_SANITIZE=ON (CI's build-asan)
 * any memory error or leak fails the test. The targets also abort on a loader that "succeeds" with
 * a non-finite vertex, an out-of-range index or an empty image.
 */
/* ctest-labels: unit */
/* ctest-timeout: 300 */
#include "../fuzz/fuzz_targets.h" /* first: it defines _GNU_SOURCE */

#include <dirent.h>
#include <sys/resource.h>

#include "harness.h"

typedef int (*target_fn)(const uint8_t *, size_t);

/* Feeds every file of dir to fn; returns how many. */
static int replay_dir(const char *dir, target_fn fn)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.')
            continue;
        char path[2048];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        FILE *fp = fopen(path, "rb");
        if (!fp)
            continue;
        fseek(fp, 0, SEEK_END);
        long size = ftell(fp);
        fseek(fp, 0, SEEK_SET);
        uint8_t *buf = malloc(size > 0 ? (size_t)size : 1);
        bool ok = buf && (size <= 0 || fread(buf, 1, (size_t)size, fp) == (size_t)size);
        fclose(fp);
        CHECK_MSG(ok, "cannot read %s", path);
        if (ok) {
            printf("  %s\n", path);
            fflush(stdout);
            fn(buf, size > 0 ? (size_t)size : 0);
            ++n;
        }
        free(buf);
    }
    closedir(d);
    return n;
}

static int replay(const char *name, target_fn fn)
{
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/tests/data/fuzz_regressions/%s", spc_test_source_dir(), name);
    int n = replay_dir(dir, fn);
    snprintf(dir, sizeof dir, "%s/fuzz/corpus/%s", spc_test_source_dir(), name);
    int seeds = replay_dir(dir, fn);
    CHECK_MSG(seeds > 0, "no seed corpus in %s", dir);
    return n + seeds;
}

TEST(xml) { replay("xml", spc_fuzz_xml); }
TEST(obj) { replay("obj", spc_fuzz_obj); }
TEST(ply) { replay("ply", spc_fuzz_ply); }
TEST(serialized) { replay("serialized", spc_fuzz_serialized); }
/* exr/chunk_claims_3GB.exr: a 3445-byte file whose chunk claims 3.2 GB, which OpenEXR would allocate
 * (chunks beyond 256 MiB are refused); exr/huge_window_*: tiny files whose data window claims up to
 * 2^28 pixels (planes are allocated only once the first chunk's table entry is read). */
TEST(exr)
{
    replay("exr", spc_fuzz_exr);
    char path[1024];
    snprintf(path, sizeof path, "%s/tests/data/fuzz_regressions/exr/chunk_claims_3GB.exr", spc_test_source_dir());
    const char *names[] = {"R", "G", "B", "variance.R", "depth.Z"};
    int w = 0, h = 0;
    float *px = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    CHECK(spc_exr_read_channels(path, 5, names, &w, &h, &px, NULL, &err) == SPC_ERR_LIMIT && !px);
    CHECK_MSG(strstr(err.msg, "too large") != NULL, "%s", err.msg);
    free(px);
}
/* Peak resident memory of this process so far, in MB. */
static long peak_rss_mb(void)
{
    struct rusage ru;
    return getrusage(RUSAGE_SELF, &ru) == 0 ? ru.ru_maxrss / 1024 : -1;
}

TEST(png)
{
    replay("png", spc_fuzz_png);
    /* png/text_chunk_claims_755MB.png: a corrupt ancillary chunk claiming 755 MB in a 322-byte file,
     * which libpng allocates before noticing the file ended: such chunks are skipped.
     * png/jpeg_marker_cuts_data_224x65486.jpg: a 14.6-megapixel image whose data is cut short, which
     * libjpeg pads with gray (176 MB of floats) and only warns about: that warning is an error.
     * png/jpeg_header_claims_4146x55808.jpg: a 213-byte file whose header announces 231 megapixels
     * (2.8 GB of floats, allocated before reading any data); a Huffman-coded file needs a bit per
     * MCU, so such a header is refused before anything is allocated.
     * png/png_header_claims_16000x16000.png: the same for PNG (made by hand, 74 bytes announcing 1 GB
     * of pixels): deflate inflates at most 1032:1. */
    char path[1024];
    snprintf(path, sizeof path, "%s/tests/data/fuzz_regressions/png/jpeg_header_claims_4146x55808.jpg",
             spc_test_source_dir());
    spc_image img;
    spc_error err;
    memset(&err, 0, sizeof err);
    CHECK(spc_image_read(path, &img, &err) == SPC_ERR_PARSE);
    CHECK_MSG(strstr(err.msg, "truncated") != NULL && strstr(err.msg, "213 bytes") != NULL, "%s", err.msg);
    snprintf(path, sizeof path, "%s/tests/data/fuzz_regressions/png/png_header_claims_16000x16000.png",
             spc_test_source_dir());
    memset(&err, 0, sizeof err);
    CHECK(spc_image_read(path, &img, &err) == SPC_ERR_PARSE);
    CHECK_MSG(strstr(err.msg, "truncated") != NULL && strstr(err.msg, "74 bytes") != NULL, "%s", err.msg);
    long mb = peak_rss_mb();
    CHECK_MSG(mb >= 0 && mb < 150, "peak RSS %ld MB", mb); /* ~10 MB, ~50 MB under ASan */
}
TEST(checkpoint) { replay("checkpoint", spc_fuzz_checkpoint); }
TEST(vol) { replay("vol", spc_fuzz_vol); }

/* The empty input and a few trivially hostile ones reach every target: the test fails by crashing
 * (and, under the CI's ASan build, by any memory error or leak); there is no value to compare. */
TEST(tiny_inputs)
{
    const target_fn all[] = {spc_fuzz_xml, spc_fuzz_obj, spc_fuzz_ply, spc_fuzz_serialized,
                             spc_fuzz_exr, spc_fuzz_png, spc_fuzz_checkpoint, spc_fuzz_vol,
                             spc_fuzz_curve};
    const char *inputs[] = {"", "\0", "<", "ply\n", "v/1\x01", "\x89PNG\r\n\x1a\n", "SPCCKPT", "f 1 2 3\n"};
    for (size_t t = 0; t < sizeof all / sizeof all[0]; ++t)
        for (size_t i = 0; i < sizeof inputs / sizeof inputs[0]; ++i)
            all[t]((const uint8_t *)inputs[i], i == 1 ? 1 : strlen(inputs[i]));
}

int main(void)
{
    RUN(xml);
    RUN(obj);
    RUN(ply);
    RUN(serialized);
    RUN(exr);
    RUN(png);
    RUN(checkpoint);
    RUN(vol);
    RUN(tiny_inputs);
    return spc_test_finish();
}
