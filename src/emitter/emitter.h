/*
 * emitter/emitter.h: light sources. Tagged union, dispatched in emitter.c, one file per variant.
 *
 * Conventions:
 * - sample_direct() samples a point on the light as seen from a reference point ref and reports
 *   its density in SOLID ANGLE at ref (spheres by the subtended cone, other shapes by area
 *   converted with dist^2 / |cos|). Delta lights (point, spot, directional) report pdf = 1 and
 *   is_delta; their L already includes the 1/dist^2 falloff, so every strategy adds
 *   f * L * |cos_ref| / pdf.
 * - L is radiance leaving the light toward ref. Area emitters are one-sided: zero on the side
 *   opposite to the shape's normal.
 * - Infinite lights (constant, envmap) have dist = +inf and are evaluated by direction.
 * - power() estimates emitted flux (for picking lights in proportion to power).
 *
 * XML: point (intensity, position | to_world), area (radiance: rgb or texture), constant
 * (radiance), envmap (filename, scale, to_world), spot (intensity, cutoff_angle 20,
 * beam_width cutoff*3/4, to_world), directional (irradiance, direction | to_world), projector
 * (irradiance, scale, fov | focal_length, to_world: projector.c).
 */
#ifndef SPC_EMITTER_EMITTER_H
#define SPC_EMITTER_EMITTER_H

#include "core/math.h"
#include "core/warp.h"
#include "scene/hit.h"
#include "scene/texture.h"

struct spc_shape;

typedef enum spc_emitter_type {
    SPC_EMITTER_POINT,
    SPC_EMITTER_SPOT,
    SPC_EMITTER_DIRECTIONAL,
    SPC_EMITTER_AREA,
    SPC_EMITTER_CONSTANT,
    SPC_EMITTER_ENVMAP,
    SPC_EMITTER_PROJECTOR
} spc_emitter_type;

typedef struct spc_emitter {
    spc_emitter_type type;
    spc_rgb intensity;                 /* point, spot (W/sr) */
    spc_vec3 position;                 /* point, spot */
    spc_mat4 to_world, to_local;       /* spot (looks along +z), envmap */
    double cutoff_angle, beam_width;   /* spot, degrees */
    spc_vec3 direction;                /* directional: direction light travels */
    spc_rgb irradiance;                /* directional */
    const spc_texture *radiance;       /* area, constant, envmap (bitmap lat-long) */
    const spc_texture *texture;        /* spot: an image over the beam (NULL: none); projector: its
                                          irradiance image */
    double scale;                      /* envmap, projector, default 1 */
    double tan_x, tan_y;               /* projector: half-extents of its image on the plane z = 1 */
    const struct spc_shape *shape;     /* area */
    int shape_index;                   /* area */
    /* set by spc_emitter_prepare: */
    spc_distrib2d tex_distrib;         /* envmap, projector */
    bool has_tex_distrib;
    /* area lights with a bitmap radiance on a small mesh: texel-proportional sampling (area.c) */
    spc_distrib1d cell_distrib;        /* over the sub-triangles of every triangle */
    size_t *cell_offset;               /* per triangle: index of its first cell (ntris + 1 entries) */
    int *cell_k;                       /* per triangle: subdivisions per edge (k^2 cells) */
    bool has_cell_distrib;
    spc_vec3 scene_center;             /* infinite and directional lights */
    double scene_radius;
    double power;
    int index; /* position in scene->emitters */
} spc_emitter;

typedef struct spc_emitter_direct {
    spc_vec3 p, n;   /* point on the light and its normal (n unused for delta/infinite) */
    spc_vec3 wi;     /* unit direction from ref toward the light */
    double dist;     /* distance to p, +inf for infinite lights */
    spc_rgb L;       /* radiance toward ref (delta lights: intensity / dist^2, or irradiance) */
    double pdf;      /* solid angle at ref; 1 for delta lights */
    double err;      /* error bound of p along the ray from ref (spc_hit_spawn_to's q_err): p's position
                        bound, over the cosine at p for points sampled by area (SPC_AREA_GRAZING_COS) */
    bool is_delta, is_infinite;
} spc_emitter_direct;

/* A shadow ray toward a point p sampled on a light's surface meets that surface, as the accelerator
 * rounds it (single precision), within about err / cos of p along the ray, cos the angle at p; where
 * the ray grazes the light that is past spc_hit_spawn_to's margin of 2 err, and the light shadows its
 * own sample: the floor beside the plane of a square light lost 12-35% of its direct light. So the
 * err of an area-sampled point is reported along the ray, err / max(cos, SPC_AREA_GRAZING_COS); below
 * this cosine a sample's contribution (proportional to it) is under 1e-3 of a head-on one's, and the
 * margin stays under 1000 err. */
#define SPC_AREA_GRAZING_COS 1e-3

typedef struct spc_emitter_emission {
    spc_vec3 p, n, d; /* origin, surface normal (or d for point lights), direction */
    spc_rgb weight;   /* Le * |cos| / (pdf_pos * pdf_dir) */
    double pdf_pos;   /* area density (1 for delta positions) */
    double pdf_dir;   /* solid angle density (1 for delta directions) */
    double err;
    bool delta_pos, delta_dir, is_infinite;
} spc_emitter_emission;

/* Scene bounds are needed by infinite and directional lights. false: zero power or no memory. */
bool spc_emitter_prepare(spc_emitter *e, spc_vec3 scene_center, double scene_radius);
void spc_emitter_release(spc_emitter *e);
bool spc_emitter_is_delta(const spc_emitter *e);
bool spc_emitter_is_infinite(const spc_emitter *e);

bool spc_emitter_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_vec2 u, spc_emitter_direct *out);
/* Light samples of n reference points at once (area_many.c): ok[i] and out[i] bit for bit as
 * ok[i] = spc_emitter_sample_direct(e[i], ref[i], u[i], &out[i]) gives them (e[i] NULL: ok[i] false,
 * out[i] untouched). Lights that spc_emitter_many_covers share vector instructions across lanes;
 * others are sampled one lane at a time. */
/* The most lanes a call takes: a path tracer wave's (integrator/path_wave.c), all at once, which
 * measured 2.8% less CPU time on the cornell box than calls of 16 lanes. */
#define SPC_EMITTER_MANY_MAX 256
void spc_emitter_sample_direct_many(int n, const spc_emitter *const e[], const spc_vec3 ref[], const spc_vec2 u[],
                                    spc_emitter_direct out[], bool ok[]);
/* Is e an area light on a triangle mesh without vertex normals, sampled uniformly by area, with a
 * constant radiance (the lights spc_emitter_sample_direct_many samples in vector form)? */
bool spc_emitter_many_covers(const spc_emitter *e);
/* Is e an area light on a sphere with a constant radiance (sampled in vector form by
 * spc_emitter_sample_direct_many wherever the reference point is outside the sphere)? */
bool spc_emitter_many_covers_sphere(const spc_emitter *e);
/* The lanes lane[0..n) (n <= SPC_EMITTER_MANY_MAX) of spc_emitter_sample_direct_many's arrays whose
 * emitters pass spc_emitter_many_covers_sphere (sphere_many.c): the same out and ok. */
void spc_emitter_sample_spheres_many(int n, const int *lane, const spc_emitter *const e[], const spc_vec3 ref[],
                                     const spc_vec2 u[], spc_emitter_direct out[], bool ok[]);
/* Which of sphere_many.c's loops runs (tests): 2 AVX-512, 1 AVX2, 0 plain, capped at what the CPU
 * has; -1 the best it has (the default). Returns the one that will run. Not thread-safe. */
int spc_emitter_spheres_many_isa(int isa);
/* Solid-angle density at ref of sample_direct producing point p (normal n) on an area light. */
double spc_emitter_pdf_direct(const spc_emitter *e, spc_vec3 ref, spc_vec3 p, spc_vec3 n);
/* Radiance leaving an area light at hit h in direction w (unit, away from the surface). */
spc_rgb spc_emitter_eval_area(const spc_emitter *e, const spc_hit *h, spc_vec3 w);
/* Radiance arriving along a ray that escaped the scene, travelling in direction d. */
spc_rgb spc_emitter_eval_infinite(const spc_emitter *e, spc_vec3 d);
/* Solid-angle density with which sample_direct of an infinite light produces wi = d, where d is
 * the direction of a ray escaping the scene (it points toward the light). */
double spc_emitter_pdf_infinite(const spc_emitter *e, spc_vec3 d);

/* Radiant intensity (W/sr) of a light at a point (point, spot) toward the unit world direction d,
 * with a spot's falloff and image; black for every other light. */
spc_rgb spc_emitter_eval_intensity(const spc_emitter *e, spc_vec3 d);

/* Emission sampling (BDPT, light tracing). */
bool spc_emitter_sample_emission(const spc_emitter *e, spc_vec2 u_pos, spc_vec2 u_dir, spc_emitter_emission *out);
/* Densities of sample_emission for the given origin, normal and direction. */
void spc_emitter_pdf_emission(const spc_emitter *e, spc_vec3 p, spc_vec3 n, spc_vec3 d, double *pdf_pos,
                              double *pdf_dir);

#endif
