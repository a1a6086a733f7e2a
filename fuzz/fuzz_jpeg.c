/*
 * fuzz/fuzz_jpeg.c: libFuzzer harness for the JPEG reader (the target is spc_fuzz_jpeg in
 * fuzz/fuzz_targets.h), seeded with JPEG files only. Built with -DSPC_FUZZ=ON (clang); run by
 * fuzz/run.sh.
 */
#include "fuzz_targets.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) { return spc_fuzz_jpeg(data, size); }
