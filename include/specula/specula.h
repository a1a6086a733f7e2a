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
/* A define of this name with the value "warn" makes a property that no plugin reads a warning
 * instead of an error (scenes written for other renderers); "error" is the default. */
#define SPC_DEFINE_UNREFERENCED "@unreferenced"

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
 * chain lengths, and what the pilot render that checks an automatic plan measured (a render at the
 * scene's own size and sample count would make the same; render/snee_pilot.h). The caller frees the
 * string; NULL if out of memory. */
char *spc_scene_plan(const spc_scene *s, const char *integrator, const char *specular_nee);
/* The options a specular NEE setting takes ("angular:trials=64,seed=light"), one paragraph each
 * with its values and default, lines indented by `indent` and at most `width` columns: the help of
 * --specular-nee and of the integrator property specular_nee. The caller frees the string; NULL if
 * out of memory. */
char *spc_specular_nee_help(int indent, int width);

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
    /* Where to render: NULL or "cpu" (specula's threads), "opencl" or "opencl:N" (device N of
     * spc_devices_describe). The opencl device renders only scenes it supports and refuses others
     * with SPC_ERR_PLUGIN naming what it lacks; the film, passes and seeds work as on the CPU, the
     * image is deterministic for a given device (not equal to the CPU's bit for bit). */
    const char *device;
    /* bdpt: each camera vertex also joins bdpt_pool light vertices picked by importance from a pool
     * of the pass's light subpaths (integrator/bdpt_pool.h); -1: off; 0: by default, 3 where fewer
     * than a quarter of the camera's first hits see a light sample (indirectly lit scenes) and the
     * rendered window has at most 65536 pixels, else off. Memory: each pass keeps its light
     * subpaths, about 2.7 KB a pixel on an indoor scene. Not with strategy_s/t, strategy_images or
     * the opencl device (by default off there). */
    int bdpt_pool;
    /* bdpt: light subpaths traced per camera sample, 1..64: the first serves every strategy, the
     * others light tracing (t = 1) only, which MIS then counts that many times; 0: by default (1).
     * Not on the opencl device. */
    int bdpt_light_paths;
    /* bdpt: the share of area lights' emission drawn toward the glass and mirror casters' spheres
     * (integrator/bdpt.h), below 1, times the share of a pilot's aimed rays that reach a caster;
     * 0: by default (0.25); negative: off (the lights' own emission). Not on the opencl device. */
    double bdpt_aim;
    /* bdpt: the share of the camera's first bounce drawn toward the same casters' spheres, below 1,
     * times the share of the casters' light that reached them after a diffuse bounce (a pilot);
     * 0: by default (0.2); negative: off. Only where the emission is aimed (bdpt_aim). */
    double bdpt_aim_camera;
} spc_render_options;

#define SPC_STRATEGY_IMAGES_MAX_DEPTH 8
#define SPC_STRATEGY_IMAGES_MAX 44 /* strategies of lengths 1 .. 8: 8 (8 + 3) / 2 */

void spc_render_options_init(spc_render_options *o);

/* The longest specular NEE setting, with its terminating zero: a longer one given to spc_render (its
 * options' specular_nee, or a scene's specular_nee property) is refused, never cut. */
#define SPC_SPECULAR_NEE_MAX 256
/* The pilot render's note (what it measured and chose), with its terminating zero. */
#define SPC_SPECULAR_NEE_NOTE_MAX 704

typedef struct spc_render_stats {
    int spp;
    double wall_seconds;
    uint64_t rays_traced;
    uint64_t shadow_rays_traced; /* of rays_traced, the shadow rays (0 on the OpenCL device) */
    double mrays_per_second;
    int threads;
    uint64_t samples;
    uint64_t invalid_samples; /* NaN or infinite estimates, discarded and counted */
    char specular_nee[SPC_SPECULAR_NEE_MAX]; /* the specular NEE setting that ran ("none" when off; see spc_scene_plan) */
    char specular_nee_pilot[SPC_SPECULAR_NEE_NOTE_MAX]; /* what the pilot render measured and chose, or "" where none ran */
    int caustic_guide_entries;    /* caustic guiding at receivers: the guide's entries (0: it did not run) */
    int caustic_guide_cones;      /* of them, cones toward glass casters */
    double caustic_guide_seconds; /* and its photon pre-pass's wall time (inside wall_seconds) */
    double bdpt_aim;              /* bdpt: the share of area lights' emission aimed at casters (0: none) */
    double bdpt_aim_camera;       /* bdpt: the share of the camera's first bounce aimed at them (0: none) */
} spc_render_stats;

spc_status spc_render(const spc_scene *s, const spc_render_options *o, spc_film **out, spc_render_stats *stats,
                      spc_error *err);

/* The render devices found (cpu, then every OpenCL device as "opencl:N ..."), one line each; the
 * caller frees the string (NULL when out of memory). */
char *spc_devices_describe(void);

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

/* ---- denoising: Intel Open Image Denoise 2.x, loaded at run time (src/denoise/oidn.h says where
 * it is looked for: $SPECULA_OIDN_LIBRARY, the system's library path, the PyPI package pyoidn) ---- */
typedef void (*spc_denoise_progress_fn)(void *user, double fraction);
typedef struct spc_denoise_options {
    int threads;      /* 0: OIDN's choice (all cores) */
    bool prefilter;   /* denoise albedo and normal first and give them to the image's filter as clean
                       * (OIDN's cleanAux), as OIDN recommends for final frames; init: true */
    spc_denoise_progress_fn progress; /* may be NULL; fraction of the whole run, from OIDN's threads */
    void *progress_user;
} spc_denoise_options;
void spc_denoise_options_init(spc_denoise_options *o);
/* Finds and loads the library now (once per process): SPC_OK with its path in library (size
 * bytes, may be NULL), or SPC_ERR_IO saying where it looked and how to install it. The CLI asks
 * before a render with --denoise, so a missing library costs no render. */
spc_status spc_denoise_load(char *library, size_t size, spc_error *err);
typedef struct spc_denoise_stats {
    bool used_aux;             /* albedo and normal guided the filter (false: the image alone) */
    uint64_t nonfinite_pixels; /* pixels with a NaN or infinite value in the image or its AOVs: the
                                * value is given to OIDN as 0 and the pixel counted */
    double seconds;            /* wall time of the denoising, loading the library included */
    char library[1024];        /* the OIDN library used */
} spc_denoise_stats;
/* Denoises a linear HDR image (3 floats per pixel, row 0 at the top) into out (3 floats per pixel;
 * may be rgb). albedo and normal (3 floats per pixel, OIDN's definitions: integrator/aov.c) are both
 * given or both NULL; albedo is clamped to [0, 1] and normal to [-1, 1] for OIDN. Errors: SPC_ERR_IO
 * when the library is missing (the message says how to install it), SPC_ERR_NOMEM,
 * SPC_ERR_INTERNAL when OIDN fails. */
spc_status spc_denoise_rgb(int width, int height, const float *rgb, const float *albedo, const float *normal,
                           float *out, const spc_denoise_options *o, spc_denoise_stats *stats, spc_error *err);
/* Denoises a resolved film, with its AOVs when it has them (stats->used_aux says). Afterwards
 * spc_film_rgb is the denoised image, spc_film_noisy_rgb the image before, and the writers write
 * the denoised image: the EXR as R, G, B, with the noisy image as noisy.R/G/B (and its variance, if
 * written, as noisy.variance.R/G/B, never as variance.*: it is not the denoised image's). */
spc_status spc_film_denoise(spc_film *f, const spc_denoise_options *o, spc_denoise_stats *stats, spc_error *err);
/* The image before spc_film_denoise (owned by the film), or NULL for a film not denoised. */
const float *spc_film_noisy_rgb(const spc_film *f);
/* `specula denoise`: reads an EXR written by specula (R, G, B, and albedo.*, normal.* when rendered
 * with AOVs; an image already denoised is denoised again from its noisy.* channels), denoises it
 * and writes out atomically as spc_film_write_exr does for a denoised film: R, G, B denoised,
 * noisy.R/G/B, noisy.variance.* if the input had variance, and the AOV channels it had. */
spc_status spc_denoise_exr(const char *in, const char *out, const spc_denoise_options *o, spc_denoise_stats *stats,
                           spc_error *err);

/* Output formats, chosen by the path's extension (case-insensitive) as in pbrt-v4 and Mitsuba. */
typedef enum spc_image_format {
    SPC_FORMAT_UNKNOWN = 0, /* any other extension, or none */
    SPC_FORMAT_EXR,         /* .exr: linear float, every channel */
    SPC_FORMAT_PNG,         /* .png: 8-bit sRGB, clamped to [0, 1] */
    SPC_FORMAT_PFM,         /* .pfm: linear float RGB, little-endian */
    SPC_FORMAT_HDR          /* .hdr: Radiance RGBE */
} spc_image_format;
spc_image_format spc_image_format_of(const char *path);
/* Writes the film in the format its extension names (SPC_ERR_VALUE for an unknown one, or for
 * variance or AOVs in anything but EXR); atomic, like every writer. */
spc_status spc_film_write(const spc_film *f, const char *path, bool variance, spc_error *err);
/* Checks, before rendering, that path can be written as an output: after following symbolic links
 * it names a regular file or nothing yet, in an existing writable folder. SPC_ERR_IO otherwise,
 * saying what it is (directory, device, FIFO, socket). Every writer applies the same check: no
 * output ever replaces anything but a regular file. */
spc_status spc_output_check(const char *path, spc_error *err);
/* The file a write of path replaces: path with its symbolic links followed (relative targets from
 * the link's folder), into out (size bytes); the same checks and errors as spc_output_check. */
spc_status spc_output_resolve(const char *path, char *out, size_t size, spc_error *err);

/* ---- images (for `specula diff`) ---- */
typedef struct spc_image_rgb {
    int width, height;
    float *rgb;      /* 3 per pixel */
    float *variance; /* 3 per pixel (variance of the mean), or NULL when the file has none */
} spc_image_rgb;
/* Reads EXR (R,G,B and variance.R/G/B when present), PNG or JPEG; 8-bit sRGB files (PNG, JPEG) are
 * decoded to linear values. */
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

/* ---- the solver explorer (`specula explore`) ---- */
typedef struct spc_explorer spc_explorer;
/* Largest request body the explorer accepts (bytes); the server refuses longer ones (413). */
#define SPC_EXPLORE_MAX_BODY 8192
/* An explorer over a loaded scene (which must outlive it). NULL on allocation failure. */
spc_explorer *spc_explore_create(const spc_scene *s);
void spc_explore_destroy(spc_explorer *ex);
/* Answers one API request (GET /api/scene, POST /api/solve, POST /api/lossmap; README, "The solver
 * explorer"): returns the HTTP status and sets *response to a JSON text the caller frees (an
 * object with "error" for every status >= 400; NULL only if memory ran out, status 500). Safe to
 * call from several threads at once. */
int spc_explore_handle(spc_explorer *ex, const char *method, const char *path, const char *body, size_t len,
                       char **response);

#ifdef __cplusplus
}
#endif
#endif
