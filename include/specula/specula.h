/*
 * specula.h: the public C API of specula: load a scene, render it, write images.
 *
 * The `specula` command uses nothing but this header. Every function that can fail returns a
 * spc_status and fills a caller-owned spc_error with "file:line:col: message". The library never
 * exits the process and never writes a partial image over an existing file.
 */
#ifndef SPECULA_SPECULA_H
#define SPECULA_SPECULA_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SPECULA_VERSION "0.1.0"

typedef enum spc_status {
    SPC_OK = 0,          /* success */
    SPC_ERR_IO = 1,      /* a file could not be opened, read or written */
    SPC_ERR_PARSE = 2,   /* malformed input: XML syntax, OBJ/PLY/EXR/PNG content */
    SPC_ERR_PLUGIN = 3,  /* an unknown plugin type or an integrator specula does not have */
    SPC_ERR_VALUE = 4,   /* a well-formed but invalid value: negative radius, NaN vertex, bad index */
    SPC_ERR_NOMEM = 5,   /* an allocation failed */
    SPC_ERR_LIMIT = 6,   /* a size beyond what specula accepts (film, sample count) */
    SPC_ERR_ACCEL = 7,   /* Embree refused the device or the scene */
    SPC_ERR_INTERNAL = 8, /* a broken invariant: a bug in specula */
    SPC_ERR_INTERRUPTED = 9 /* the render was cancelled (SIGINT/SIGTERM); the partial result is valid */
} spc_status;

#define SPC_ERROR_MSG_MAX 1024

/* Details of the last failure: "file:line:col: message". line/col are 0 when unknown. */
typedef struct spc_error {
    spc_status code;
    char file[512];
    int line, col;
    char msg[SPC_ERROR_MSG_MAX];
} spc_error;

/* Writes "file:line:col: message" (parts omitted when unknown) into buf. */
void spc_error_format(const spc_error *err, char *buf, int size);
const char *spc_status_name(spc_status code);

typedef struct spc_define {
    const char *name, *value; /* -D name=value: overrides <default name=...> */
} spc_define;
/* A define of this name replaces the type of the scene's <integrator> (keeping its properties), so
 * `--integrator path` works on files that name an integrator specula does not have. */
#define SPC_DEFINE_INTEGRATOR "@integrator"

typedef struct spc_scene spc_scene;
typedef struct spc_film spc_film;

/* ---- scenes ---- */
/* Loads a Mitsuba XML scene; *out is NULL on failure. Free with spc_scene_destroy. */
spc_status spc_scene_load(const char *path, const spc_define *defs, int ndefs, spc_scene **out, spc_error *err);
void spc_scene_destroy(spc_scene *s);

typedef struct spc_scene_summary {
    int shapes, meshes, analytic_shapes, bsdfs, emitters, textures;
    uint64_t triangles;
    double bbox_min[3], bbox_max[3];
    int width, height, spp, max_depth;
    char integrator[64];
} spc_scene_summary;
void spc_scene_summarize(const spc_scene *s, spc_scene_summary *out);
/* One line per shape / BSDF / emitter, for `specula info`; the caller frees the string. */
char *spc_scene_describe(const spc_scene *s);
/* What specular NEE will do when s is rendered with this integrator (NULL: the scene's) and setting
 * (NULL: the scene's; "" or "auto": chosen from the scene; "none": off; else as given): a line with
 * the setting (or why it is off), then one per caster with the method that finds its chains and the
 * chain lengths. The caller frees the string; NULL if out of memory. */
char *spc_scene_plan(const spc_scene *s, const char *integrator, const char *specular_nee);

/* ---- rendering ---- */
typedef void (*spc_progress_fn)(void *user, double fraction, int spp_done, int spp_total, double elapsed_s);

typedef struct spc_render_options {
    int spp;                 /* 0: the scene's sample count */
    double time_limit;       /* seconds; > 0: render as many whole passes as fit (spp is then a cap if > 0) */
    int threads;             /* 0: all cores */
    uint64_t seed;
    int width, height;       /* 0: the scene's film size */
    const char *integrator;  /* NULL: the scene's ("path", "ipt", "bdpt") */
    const char *specular_nee;/* NULL: the scene's; "" or "auto": chosen from the scene (spc_scene_plan),
                              * "none": off, or a setting: "angular", "newton:biased=8", ... */
    int max_depth;           /* 0: the scene's; -1: unbounded */
    bool aovs;               /* albedo, shading normal, depth */
    spc_progress_fn progress;
    void *progress_user;
    volatile int *cancel;    /* polled between passes; nonzero stops the render cleanly */
    int strategy_s, strategy_t; /* bdpt debug: >= 0 renders only the (s, t) strategy, unweighted */
    bool strategy_weighted;  /* with strategy_s/t: apply the MIS weight */
    bool mis_balance;        /* bdpt: balance heuristic instead of the power heuristic (beta = 2); also on
                              * when the scene's integrator says <boolean name="mis_balance" value="true"/> */
    /* Checkpoints (see spc_checkpoint below). With checkpoint_path the film's state is written there
     * atomically at pass boundaries, at least checkpoint_every seconds apart (<= 0: after every batch
     * of passes, which are then kept short), and once more when the render ends or is cancelled.
     * checkpoint_user is stored verbatim (the CLI keeps its arguments there). */
    const char *checkpoint_path;
    double checkpoint_every;     /* seconds; spc_render_options_init sets 60 */
    const char *checkpoint_user;
    /* Non-NULL: continue that render from its pass count, to the spp target of these options. The
     * scene (file bytes and defines) and the resolved settings must equal the checkpoint's, or the
     * render is refused with SPC_ERR_VALUE saying what differs. The result is bit-identical to an
     * uninterrupted render of the same spp and seed. */
    const struct spc_checkpoint *resume;
    /* bdpt debug: in the same render, also accumulate each strategy (s, t), t >= 1, of every length
     * s + t - 1 = 1 .. max_depth into films of its own, MIS-weighted and unweighted (light tracing,
     * t = 1, splats as in the image). The weighted films sum to the image; each film equals the
     * render of that one strategy (strategy_s/t, strategy_weighted) with the same seed, bit for bit.
     * Needs bdpt and 1 <= max_depth <= SPC_STRATEGY_IMAGES_MAX_DEPTH; not with strategy_s/t nor
     * with checkpoints. Memory: about 100 bytes per pixel per film. Read them with
     * spc_film_strategy. */
    bool strategy_images;
} spc_render_options;

#define SPC_STRATEGY_IMAGES_MAX_DEPTH 8
#define SPC_STRATEGY_IMAGES_MAX 44 /* strategies of lengths 1 .. 8: 8 (8 + 3) / 2 */

void spc_render_options_init(spc_render_options *o);

typedef struct spc_render_stats {
    int spp;
    double wall_seconds;
    uint64_t rays_traced;
    double mrays_per_second;
    int threads;
    uint64_t samples;
    uint64_t invalid_samples; /* NaN or infinite estimates, discarded and counted */
    char specular_nee[96];    /* the specular NEE setting that ran ("none" when off; see spc_scene_plan) */
} spc_render_stats;

spc_status spc_render(const spc_scene *s, const spc_render_options *o, spc_film **out, spc_render_stats *stats,
                      spc_error *err);

/* ---- checkpoints ---- */
/* The saved state of an unfinished render: film sums after a whole number of passes, the resolved
 * settings, a hash of the scene, the version that wrote it. */
typedef struct spc_checkpoint spc_checkpoint;
/* Reads and verifies a checkpoint; *out is NULL on failure: SPC_ERR_IO (unreadable), SPC_ERR_PARSE
 * (torn, damaged or not a checkpoint: a checksum covers the whole file), SPC_ERR_VALUE (written by
 * another specula version). Free with spc_checkpoint_destroy. */
spc_status spc_checkpoint_load(const char *path, spc_checkpoint **out, spc_error *err);
void spc_checkpoint_destroy(spc_checkpoint *c);
typedef struct spc_checkpoint_info {
    int spp_done, spp_target;
    int width, height;                 /* rendered window */
    const char *scene_path, *settings; /* settings: "key=value;..." */
    const char *user;                  /* the options' checkpoint_user ("" if none) */
    const char *version;               /* of the specula that wrote it */
} spc_checkpoint_info; /* strings owned by the checkpoint */
void spc_checkpoint_get_info(const spc_checkpoint *c, spc_checkpoint_info *out);

/* ---- films ---- */
void spc_film_destroy(spc_film *f);
int spc_film_width(const spc_film *f);
int spc_film_height(const spc_film *f);
/* Mean RGB (3 floats per pixel, row 0 at the top); owned by the film. */
const float *spc_film_rgb(const spc_film *f);
/* Variance of the pixel mean (3 floats per pixel); owned by the film. */
const float *spc_film_variance(const spc_film *f);
/* Strategy films of a render with strategy_images (0 and NULL otherwise, or for i out of range):
 * film i holds strategy (*s, *t), *weighted or not; owned by f (valid until f is destroyed), and
 * written like any film (spc_film_write_exr, spc_film_write_png). */
int spc_film_strategy_count(const spc_film *f);
const spc_film *spc_film_strategy(const spc_film *f, int i, int *s, int *t, bool *weighted);
/* EXR with R,G,B; with `variance` also variance.R/G/B; with AOVs albedo.*, normal.*, depth.Z when
 * rendered. Written atomically (temporary file, then rename). */
spc_status spc_film_write_exr(const spc_film *f, const char *path, bool variance, spc_error *err);
/* 8-bit sRGB preview, clamped; atomic. */
spc_status spc_film_write_png(const spc_film *f, const char *path, spc_error *err);

/* ---- images (for `specula diff`) ---- */
typedef struct spc_image_rgb {
    int width, height;
    float *rgb;      /* 3 per pixel */
    float *variance; /* 3 per pixel (variance of the mean), or NULL when the file has none */
} spc_image_rgb;
spc_status spc_image_rgb_read(const char *path, spc_image_rgb *out, spc_error *err);
void spc_image_rgb_release(spc_image_rgb *img);

typedef struct spc_diff_result {
    double mean_a[3], mean_b[3];
    double mse, rel_mse; /* relMSE = mean((a-b)^2 / (b^2 + 0.01)) over pixels and channels */
    bool has_ztest;
    double ztest_pass_fraction; /* pixels passing a z-test at alpha 0.01, Sidak-corrected */
    int ztest_pixels;
} spc_diff_result;
/* Compares a against reference b; the z-test uses the variance channels of both when present. */
spc_status spc_image_diff(const spc_image_rgb *a, const spc_image_rgb *b, spc_diff_result *out, spc_error *err);

#ifdef __cplusplus
}
#endif
#endif
