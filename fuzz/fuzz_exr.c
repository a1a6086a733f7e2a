/*
 * fuzz/fuzz_exr.c: libFuzzer harness for the EXR reader: spc_image_read, spc_exr_read_channels and
 * spc_image_rgb_read (the target is spc_fuzz_exr in fuzz/fuzz_targets.h). Built with
 * -DSPC_FUZZ=ON (clang); run by fuzz/run.sh.
 */
#include "fuzz_targets.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) { return spc_fuzz_exr(data, size); }
