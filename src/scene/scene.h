/*
 * scene/scene.h: the scene: it owns every shape, BSDF, emitter and texture it holds and frees them
 * in one call. Loaders fill it through spc_scene_new_*; spc_scene_finalize then freezes it
 * (sampling tables, light selection, acceleration structure). After that integrators only read it,
 * from any number of threads.
 */
#ifndef SPC_SCENE_SCENE_H
#define SPC_SCENE_SCENE_H

#include <stdint.h>

#include "bsdf/bsdf.h"
#include "core/error.h"
#include "core/math.h"
#include "core/warp.h"
#include "emitter/emitter.h"
#include "medium/medium.h"
#include "scene/shape.h"
#include "scene/texture.h"

struct spc_accel;

typedef enum spc_camera_type {
    SPC_CAMERA_PERSPECTIVE,
    SPC_CAMERA_ORTHOGRAPHIC
} spc_camera_type;

typedef enum spc_fov_axis {
    SPC_FOV_X,
    SPC_FOV_Y,
    SPC_FOV_SMALLER,
    SPC_FOV_LARGER,
    SPC_FOV_DIAGONAL
} spc_fov_axis;

/* The half-extents tan_x, tan_y of a perspective image of width x height pixels on the plane z = 1
 * for a field of view of fov degrees along axis (Mitsuba's fov_axis); false for a fov outside
 * (0, 180) or an empty image. Cameras and projectors share it. */
bool spc_fov_tangents(double fov, spc_fov_axis axis, int width, int height, double *tan_x, double *tan_y);

typedef struct spc_camera {
    spc_camera_type type;
    spc_mat4 to_world; /* camera looks along local +z, local +y is up, local +x is image-left */
    double fov;        /* degrees, along fov_axis */
    spc_fov_axis fov_axis;
    double near_clip, far_clip;
    double aperture_radius; /* thinlens: radius of the lens in local units; 0: a pinhole */
    double focus_distance;  /* thinlens: local depth of the plane in focus */
} spc_camera;

typedef enum spc_rfilter_type {
    SPC_RFILTER_BOX,
    SPC_RFILTER_TENT,
    SPC_RFILTER_GAUSSIAN
} spc_rfilter_type;

/* Steps of the tent and gaussian filters over [0, radius]: Mitsuba 3's MI_FILTER_RESOLUTION
 * (scene/rfilter.h says why the filters are step functions). */
#define SPC_FILTER_RESOLUTION 31
/* Buckets of |u - 1/2| in [0, 1/2] for the guide table of the filter's inverse CDF (scene/rfilter.c) */
#define SPC_FILTER_GUIDE 128

typedef struct spc_film_spec {
    int width, height;                      /* full film */
    int crop_x, crop_y, crop_w, crop_h;     /* rendered window (crop_w = 0: whole film) */
    spc_rfilter_type rfilter;
    double filter_radius;                   /* box 0.5, tent 1, gaussian 4 * stddev */
    double filter_stddev;                   /* gaussian, default 0.5 */
    /* filled by spc_film_filter_prepare (scene/rfilter.h): the normalized density on each step of
     * |x| and the mass of [0, k radius / RES) */
    double filter_step[SPC_FILTER_RESOLUTION];
    double filter_step_cdf[SPC_FILTER_RESOLUTION + 1];
    int filter_guide[SPC_FILTER_GUIDE + 1]; /* the step at each bucket's lower end */
    int filter_guide_scan; /* the most steps the inverse CDF's scan moves past a bucket's guide */
} spc_film_spec;

#define SPC_SPECULAR_NEE_NONE 0

/* One AOV of Mitsuba 3's aov integrator: the channel name and what it holds. */
typedef enum spc_aov_type {
    SPC_AOV_ALBEDO,    /* name.R, .G, .B */
    SPC_AOV_DEPTH,     /* name.T: distance along the camera ray */
    SPC_AOV_POSITION,  /* name.X, .Y, .Z */
    SPC_AOV_SH_NORMAL  /* name.X, .Y, .Z */
} spc_aov_type;
#define SPC_MAX_AOV_OUTPUTS 16
typedef struct spc_aov_output {
    char name[48];
    spc_aov_type type;
} spc_aov_output;

typedef struct spc_integrator_spec {
    char type[64];        /* "path", "ipt", "bdpt" (checked by the renderer) */
    int max_depth;        /* Mitsuba's meaning: 1 = emitters seen directly, 2 = direct light; -1 = no limit */
    int rr_depth;         /* Russian roulette starts at this depth (Mitsuba default 5) */
    bool hide_emitters;
    char specular_nee[SPC_SPECULAR_NEE_MAX]; /* "" or "auto" (chosen from the scene: manifold/snee_plan.h), "none" or "off",
                             * "angular", "newton", "conic", with options (spc_snee_parse) */
    int specular_max_chain; /* longest chain of specular vertices for specular NEE */
    bool mis_balance;       /* bdpt: balance heuristic instead of the power heuristic */
    bool strict_normals;    /* path: no light across surfaces whose shading normal disagrees with
                               the geometric normal (Mitsuba 0.6's strictNormals) */
    int naovs;              /* an aov integrator's outputs, written as EXR channels */
    spc_aov_output aovs[SPC_MAX_AOV_OUTPUTS];
    char aov_image[48];     /* the nested integrator's name: its image also as name.R/G/B */
    char decl_file[512];    /* where the integrator was declared, for error messages */
    int decl_line, decl_col;
} spc_integrator_spec;

/* The shapes that may be vertices of a specular chain (spc_scene_shape_is_caster) for one
 * any_surface setting: their indices in ascending order and the sphere around their bounding boxes
 * (radius 0 if none); per caster (bound_c[k], bound_r[k] for idx[k]) a sphere that holds it, as tight
 * as is cheap: a sphere shape's own, for a mesh its box's centre and the farthest vertex from it,
 * else the sphere around its bounding box. Built by spc_scene_finalize. */
typedef struct spc_scene_casters {
    int n;
    int *idx;
    spc_vec3 center;
    double radius;
    spc_vec3 *bound_c;
    double *bound_r;
} spc_scene_casters;

typedef struct spc_scene {
    spc_shape **shapes;
    int nshapes, cap_shapes;
    spc_bsdf **bsdfs;
    int nbsdfs, cap_bsdfs;
    spc_emitter **emitters;
    int nemitters, cap_emitters;
    spc_texture **textures;
    int ntextures, cap_textures;
    spc_medium **media; /* participating media (medium/medium.h); shapes refer to them by index */
    int nmedia, cap_media;
    int camera_medium;  /* the medium the camera sits in: index into media, -1 for vacuum */

    spc_camera camera;
    spc_film_spec film;
    spc_integrator_spec integrator;
    int spp;
    uint64_t seed;

    /* set by spc_scene_finalize */
    const spc_emitter *env;       /* the infinite emitter, or NULL */
    spc_distrib1d light_distrib;  /* over emitters, in proportion to power */
    double *light_pmf;            /* per emitter (same order as emitters) */
    spc_vec3 bbox_min, bbox_max;  /* of the shapes */
    spc_vec3 center;
    double radius;                /* bounding sphere radius (>= a small positive value) */
    struct spc_accel *accel;
    bool finalized;
    /* some mesh keeps no per-triangle frame (more than SPC_MESH_FRAME_MAX_TRIS triangles): its hits
     * miss the cache, so packets prefetch their records before filling them */
    bool prefetch_hits;
    int packet_width;             /* the accel's (spc_scene_packet_width), kept here for the packet loops */
    spc_scene_casters casters[2]; /* the specular chains' casters: [0] by caustic flags, [1] any_surface */

    char path[512]; /* the file it was loaded from, if any */
    /* FNV-1a of the bytes of every file the scene file references (includes, meshes, textures,
     * envmaps, spectra), in the order the loader resolved them; SPC_FNV_OFFSET if none */
    uint64_t files_hash;
    /* of the scene file's bytes, the -D defines and files_hash (spc_scene_load), 0 if unknown */
    uint64_t content_hash;
    /* Embree's watertight triangle test (RTC_SCENE_FLAG_ROBUST): true by default; the scene
     * property embree_use_robust_intersections, which Mitsuba 3 reads with the default false.
     * Without it a ray through a mesh's shared edge can pass between its two triangles and
     * plain path tracing of the cornell box takes about 9% less CPU time (bench/RESULTS.md). */
    bool accel_robust;
    /* Embree's compact BVH from this many triangles in all; 0: SPC_ACCEL_COMPACT_TRIS (accel.h) */
    size_t accel_compact_tris;
} spc_scene;

/* Returns NULL on allocation failure. */
spc_scene *spc_scene_create(void);
/* Frees everything the scene owns; NULL does nothing. */
void spc_scene_destroy(spc_scene *s);

/* New zeroed objects registered in the scene (which frees them). NULL on allocation failure. */
spc_shape *spc_scene_new_shape(spc_scene *s);
spc_bsdf *spc_scene_new_bsdf(spc_scene *s);
spc_emitter *spc_scene_new_emitter(spc_scene *s);
spc_texture *spc_scene_new_texture(spc_scene *s);
/* A medium; its index field is its position in s->media. */
spc_medium *spc_scene_new_medium(spc_scene *s);
/* A constant texture owned by the scene. */
const spc_texture *spc_scene_constant(spc_scene *s, spc_rgb value);

/* Fills defaults for camera, film, integrator, spp: Mitsuba's (fov 45 along x, 768x576,
 * box filter... as documented in the loader). */
void spc_scene_set_defaults(spc_scene *s);

/* Validates, builds sampling tables and the acceleration structure. */
spc_status spc_scene_finalize(spc_scene *s, spc_error *err);

/* Do the caustic flags allow a shape in chains of k specular vertices? SPC_CAUSTIC_CASTER allows
 * every length; CASTER_SINGLE / CASTER_MULTI, when either is set, restrict it to one vertex / more. */
bool spc_scene_caster_allowed(unsigned caustic_flags, int k);
/* Is s a possible chain vertex: a specular interface BSDF that chains can follow on its shape, no
 * emitter, a caster for some chain length (unless any_surface)? *eta (may be NULL) receives the
 * BSDF's relative index (spc_bsdf_is_specular_interface: 0 for a mirror). */
bool spc_scene_shape_is_caster(const spc_shape *s, bool any_surface, double *eta);

bool spc_scene_intersect(const spc_scene *s, const spc_ray *r, spc_hit *h);
bool spc_scene_occluded(const spc_scene *s, const spc_ray *r);
/* The same for a packet of spc_scene_packet_width(s) rays traced together (lane i where r[i] is not
 * NULL; the arrays' first width entries are read and written, SPC_SCENE_PACKET is the widest):
 * hit[i] and h[i] are spc_scene_intersect's for r[i] (hit[i] false for an inactive lane), except
 * that h[i] is a shading record (spc_shape_fill_hit_shading: on a mesh whose BSDF reads no
 * derivatives, spc_shape_hit_derivatives fills them on demand); occluded[i] spc_scene_occluded's. */
#define SPC_SCENE_PACKET 16
/* The packets' width, 8 or 16 (spc_accel_packet_width). */
int spc_scene_packet_width(const spc_scene *s);
void spc_scene_intersect_packet(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET], spc_hit h[SPC_SCENE_PACKET],
                                bool hit[SPC_SCENE_PACKET]);
/* spc_scene_intersect_packet for rays that run nearly parallel from nearby origins (a camera's rays
 * through neighbouring pixels): the same hits, by Embree's coherent traversal
 * (spc_accel_intersect_packet_coherent). */
void spc_scene_intersect_packet_coherent(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                                         spc_hit h[SPC_SCENE_PACKET], bool hit[SPC_SCENE_PACKET]);
/* A packet's answer for one ray before its hit record is filled: the shape index (-1: no hit), the
 * primitive and the surface coordinates and distance that spc_shape_fill_hit takes. A caller that
 * traces ahead keeps these (40 bytes a lane) and fills each record where it is used. */
typedef struct spc_scene_answer {
    int shape, prim;
    double u, v, t;
} spc_scene_answer;
/* spc_scene_intersect's traversal for one ray, the answer left unfilled (a->shape -1 for a miss):
 * for a caller that refines the hit before filling its record (the chains' triangle hits), so that
 * the record is filled once. */
void spc_scene_trace(const spc_scene *s, const spc_ray *r, spc_scene_answer *a);
/* spc_scene_intersect_packet_coherent's traversal, the answers left unfilled (a[i].shape -1 for a
 * miss or an inactive lane). */
void spc_scene_trace_packet_coherent(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                                     spc_scene_answer a[SPC_SCENE_PACKET]);
/* The hit record of answer a for ray r (the ray it was traced for), the packet calls' shading record
 * (spc_scene_intersect's, the derivatives left out where spc_shape_fill_hit_shading leaves them out);
 * false (h untouched) for a miss. */
bool spc_scene_fill_answer(const spc_scene *s, const spc_ray *r, const spc_scene_answer *a, spc_hit *h);
void spc_scene_occluded_packet(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                               bool occluded[SPC_SCENE_PACKET]);
/* Next-event estimation's shadow ray r from a point toward the point that emitter e (NULL: none)
 * sampled for it: spc_scene_occluded's answer, except that e's own shape is not tested where its
 * sample cannot lie behind the shape (spc_scene_light_skip), so a light does not block its own
 * sample through rounding, and its test (an analytic sphere's) is not paid for. */
bool spc_scene_occluded_light(const spc_scene *s, const spc_ray *r, const spc_emitter *e);
/* The shape index that a shadow ray toward a sample of e need not test, or -1: a sphere light
 * without a texture's cell distribution, whose samples are on the cap that the reference point
 * sees (solid angle sampling from outside) or anywhere from inside (area sampling), so the
 * segment to the sample does not cross the sphere. */
static inline int spc_scene_light_skip(const spc_emitter *e)
{
    if (!e || e->type != SPC_EMITTER_AREA || !e->shape || e->has_cell_distrib)
        return -1;
    return e->shape->type == SPC_SHAPE_SPHERE ? e->shape_index : -1;
}
/* spc_scene_occluded_light per lane: e[i] the emitter that sampled lane i's point (NULL: none). */
void spc_scene_occluded_light_packet(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                                     const spc_emitter *const e[SPC_SCENE_PACKET], bool occluded[SPC_SCENE_PACKET]);
/* spc_scene_occluded_light_packet for rays whose directions share their signs (one octant), by
 * Embree's coherent traversal: the same answers. */
void spc_scene_occluded_light_packet_coherent(const spc_scene *s, const spc_ray *const r[SPC_SCENE_PACKET],
                                              const spc_emitter *const e[SPC_SCENE_PACKET],
                                              bool occluded[SPC_SCENE_PACKET]);

/* Picks an emitter in proportion to power; *pmf receives its probability. NULL if none. */
const spc_emitter *spc_scene_sample_emitter(const spc_scene *s, double u, double *pmf);
double spc_scene_emitter_pmf(const spc_scene *s, const spc_emitter *e);

/* Rays traced by the calling thread since it started (intersect + occluded). */
uint64_t spc_scene_rays_traced(void);

#endif
