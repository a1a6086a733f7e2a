/*
 * fuzz/fuzz_png.c: libFuzzer harness for the image readers (PNG, and JPEG and BMP by magic bytes) (the target is spc_fuzz_png in
 * fuzz/fuzz_targets.h). Built with -DSPC_FUZZ=ON (clang); run by fuzz/run.sh.
 */
#include "fuzz_targets.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) { return spc_fuzz_png(data, size); }
