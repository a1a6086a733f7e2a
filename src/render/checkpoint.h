/*
 * render/checkpoint.h: the on-disk state of an unfinished render, so that a render killed at any
 * moment can be continued to an image bit-identical to an uninterrupted one.
 *
 * What makes that possible is the driver's contract: the value of pass p at pixel (x, y) depends
 * only on (x, y, p, seed, scene, settings), and passes are added to the film's double sums one at a
 * time in pass order. A checkpoint holds those sums exactly (the bits of every double) after a
 * whole number of passes, so continuing from pass index spp_done performs the very same sequence of
 * floating-point additions.
 *
 * File layout (little-endian; doubles as their IEEE-754 bits), version SPC_CKPT_FORMAT:
 *
 *   offset  size
 *   0       8     magic "SPCCKPT\0"
 *   8       4     format (u32)
 *   12      16    specula version that wrote it, NUL-padded
 *   28      8     scene hash (u64; spc_scene.content_hash: the bytes of the scene file and of every
 *                 file it references, and its defines)
 *   36      8     settings hash (u64; FNV-1a of the settings text below)
 *   44      4     spp_done (i32): passes in the sums
 *   48      4     spp_target (i32): passes the render was asked for
 *   52      8     invalid samples discarded so far (u64)
 *   60      4 x 6 full width, full height, crop x, crop y, width, height (i32)
 *   84      4     has AOVs (i32, 0 or 1)
 *   88      4 x 3 byte lengths of: settings text, scene path, user text (u32)
 *   100           settings text, scene path, user text (no terminating NULs)
 *   then          sum[3 n], sumsq[3 n], and with AOVs aov_sum[7 n] (f64; n = width * height)
 *   last    4     CRC-32 (zlib's) of every byte before it
 *
 * Writes are atomic (temporary file, fsync, rename: io/image_io.h), so a kill leaves either the old
 * or the new checkpoint; the CRC catches a file damaged any other way.
 */
#ifndef SPC_RENDER_CHECKPOINT_H
#define SPC_RENDER_CHECKPOINT_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "core/hash.h"
#include "render/film.h"

#define SPC_CKPT_FORMAT 1u
#define SPC_CKPT_HEADER_BYTES 100
#define SPC_CKPT_MAX_TEXT (1u << 20) /* settings, path and user text: far beyond any real one */

struct spc_checkpoint {
    char path[1024];       /* the file it was read from, for messages */
    char version[17];
    uint64_t scene_hash, settings_hash;
    int spp_done, spp_target;
    uint64_t invalid_samples;
    int full_width, full_height, crop_x, crop_y, width, height;
    bool has_aovs;
    char *settings, *scene_path, *user; /* NUL-terminated, owned */
    double *sum, *sumsq, *aov_sum;      /* owned; aov_sum NULL without AOVs */
};

/* What the driver records besides the film itself. */
typedef struct spc_ckpt_meta {
    uint64_t scene_hash;
    const char *settings; /* from spc_ckpt_settings_text */
    int spp_target;
    const char *scene_path;
    const char *user; /* may be NULL */
} spc_ckpt_meta;

/* Hash of a scene file's bytes, each define's name and value, and files_hash (spc_scene.files_hash:
 * the bytes of every file the scene references); 0 if the scene file cannot be read. */
uint64_t spc_ckpt_scene_hash(const char *path, const spc_define *defs, int ndefs, uint64_t files_hash);

/* The resolved settings that decide every pass's values, as "key=value;..." text (their hash is the
 * settings hash): integrator, depths, strategies, specular NEE, seed, film, crop and filter, AOVs.
 * Whoever adds a setting that changes pixel values adds it here. */
struct spc_render_ctx;
void spc_ckpt_settings_text(const struct spc_render_ctx *ctx, const char *specular_nee, uint64_t seed, bool aovs,
                            char *buf, size_t size);

/* Writes the film's sums (after f->spp whole passes) and meta to path, atomically. */
spc_status spc_ckpt_write(const char *path, const struct spc_film *f, const spc_ckpt_meta *meta, spc_error *err);

/* Checks that checkpoint c can continue a render of this scene with these settings and film, and
 * copies its sums, pass count and invalid-sample count into f (a fresh film). SPC_ERR_VALUE with a
 * message saying what differs otherwise; f is then untouched. */
spc_status spc_ckpt_restore(const struct spc_checkpoint *c, uint64_t scene_hash, const char *settings,
                            struct spc_film *f, spc_error *err);

#endif
