/*
 * fuzz/fuzz_curve.c: libFuzzer harness for the curve shapes' control-point files (the target is
 * spc_fuzz_curve in fuzz/fuzz_targets.h). Built with -DSPC_FUZZ=ON (clang); run by fuzz/run.sh.
 */
#include "fuzz_targets.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) { return spc_fuzz_curve(data, size); }
