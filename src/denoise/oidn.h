/*
 * denoise/oidn.h: Intel Open Image Denoise (OIDN 2.x), loaded at run time with dlopen, so that
 * specula builds and runs without it and needs it only when asked to denoise.
 *
 * Where the library is looked for, in this order:
 *   1. $SPECULA_OIDN_LIBRARY: the library file, or a folder holding libOpenImageDenoise.so.2.
 *      When set, nothing else is tried (a test can make the library "missing").
 *   2. The system's library path (dlopen of "libOpenImageDenoise.so.2": LD_LIBRARY_PATH, ldconfig).
 *   3. The PyPI package `pyoidn`, which ships the official build with its CPU device in
 *      <site-packages>/pyoidn/oidn/lib: the site-packages folder python3 had when specula was
 *      configured (SPC_OIDN_CONFIGURED_DIR), then the one `python3` reports now, then the usual
 *      site-packages folders (/usr/local/lib/python3.* /dist-packages and site-packages,
 *      ~/.local/lib/python3.* /site-packages, $VIRTUAL_ENV).
 * The error when all fail says where it looked and how to install it (`pip install pyoidn`).
 *
 * Only the few C API functions below are declared (OIDN's include/OpenImageDenoise/oidn.h, whose
 * handles are opaque pointers and whose enums are ints); they are resolved with dlsym.
 */
#ifndef SPC_DENOISE_OIDN_H
#define SPC_DENOISE_OIDN_H

#include <stdbool.h>
#include <stddef.h>

#include "core/error.h"

#define SPC_OIDN_ENV "SPECULA_OIDN_LIBRARY"
#define SPC_OIDN_SONAME "libOpenImageDenoise.so.2"
#define SPC_OIDN_INSTALL_HINT                                                                                          \
    "install it with `pip install pyoidn` (ships libOpenImageDenoise.so.2), or set " SPC_OIDN_ENV                      \
    " to the library's path"

typedef void (*spc_oidn_progress_fn)(void *user, double fraction);

/* Loads the library if not yet loaded (thread-safe); library receives its path. SPC_ERR_IO when
 * it is nowhere to be found, with the places tried and SPC_OIDN_INSTALL_HINT in the message. */
spc_status spc_oidn_load(char *library, size_t size, spc_error *err);

/* One denoising run of the RT filter, HDR. color, out: w x h x 3 floats (out may be color).
 * albedo, normal: both NULL or both w x h x 3 floats; with prefilter they are denoised first, in
 * place, and then given to the beauty filter as clean (OIDN's cleanAux), as its documentation
 * recommends for final frames. threads: 0 lets OIDN choose. progress (may be NULL) gets the
 * fraction done over the whole run. library receives the path of the library used (size bytes).
 * Errors: SPC_ERR_IO when the library cannot be found or loaded (the message names the places
 * tried and how to install it), SPC_ERR_INTERNAL with OIDN's message when it fails. */
spc_status spc_oidn_denoise(int w, int h, const float *color, float *albedo, float *normal, float *out, bool prefilter,
                            int threads, spc_oidn_progress_fn progress, void *progress_user, char *library, size_t size,
                            spc_error *err);

#endif
