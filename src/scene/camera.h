/*
 * scene/camera.h: pinhole perspective and orthographic cameras (Mitsuba conventions: the camera
 * looks along local +z, local +y is up and local +x points to the image's LEFT; pixel (0, 0) is
 * the top-left corner of the full film; film coordinates are continuous pixels).
 */
#ifndef SPC_SCENE_CAMERA_H
#define SPC_SCENE_CAMERA_H

#include "core/math.h"
#include "scene/scene.h"

typedef struct spc_camera_state {
    spc_camera_type type;
    spc_mat4 to_world, to_local;
    spc_vec3 origin;      /* perspective: the pinhole */
    spc_vec3 forward;     /* world +z of the camera, unit */
    double tan_x, tan_y;  /* half extents of the image plane at local z = 1 (ortho: at any z) */
    int width, height;    /* full film */
    double near_clip, far_clip;
    double image_area;    /* area of the image plane at z = 1 (perspective) in world units */
    double pixel_scale;   /* world length of the camera's unit local x (to normalize scaled to_world) */
    double aperture_radius, focus_distance; /* thin lens (perspective); radius 0: the pinhole */
    /* perspective: the world direction through film point (fx, fy), unnormalized, is
     * ray_d0 + fx ray_dfx + fy ray_dfy (to_world applied to the local direction, precomputed) */
    spc_vec3 ray_d0, ray_dfx, ray_dfy;
} spc_camera_state;

bool spc_camera_prepare(spc_camera_state *cs, const spc_camera *c, int width, int height);
/* Ray through continuous film position (fx, fy) in pixels of the full film. */
spc_ray spc_camera_ray(const spc_camera_state *cs, double fx, double fy);
/* out[i] = spc_camera_ray(cs, fx[i], fy[i]) for i < n, bit for bit, many at once (scene/camera_many.c:
 * vector instructions where the CPU has AVX2 or AVX-512) */
void spc_camera_ray_many(const spc_camera_state *cs, int n, const double *fx, const double *fy, spc_ray *out);
/* True for a thin-lens camera (aperture_radius > 0): its rays need a lens sample. */
static inline bool spc_camera_has_lens(const spc_camera_state *cs) { return cs->aperture_radius > 0.0; }
/* A thin lens's ray through (fx, fy) from the lens point u_lens (uniform in [0,1)^2, mapped
 * concentrically onto the lens disk), as Mitsuba 3's thinlens: aimed at the point the pinhole ray
 * meets on the plane z = focus_distance. The pinhole's ray when the camera has no lens. */
spc_ray spc_camera_ray_lens(const spc_camera_state *cs, double fx, double fy, spc_vec2 u_lens);
/* Projects a world point onto the film: false if behind the camera or outside the film.
 * *fx, *fy receive the continuous film position. */
bool spc_camera_project(const spc_camera_state *cs, spc_vec3 p, double *fx, double *fy);

/*
 * Camera importance, for strategies that connect to the camera (BDPT's t = 1, light tracing).
 * Only the perspective pinhole can be connected to: an orthographic camera has a delta direction
 * per film point, so no light-path vertex can reach it (spc_camera_connectible is false, the
 * functions below return 0 / false and BDPT skips those strategies).
 *
 * Normalization. The driver estimates pixel j as I_j = integral over the film of f_j(x) L(x) dx,
 * x in pixels of the FULL film and f_j the pixel filter normalized to integrate to 1 (box filter
 * of radius 0.5: f_j = 1 on the pixel). Changing variables to the direction w of the camera ray
 * gives I_j = integral f_j(x(w)) We(w) L(w) dw with the importance per unit solid angle
 * We(w) = W H pdf_dir(w), where pdf_dir is the density of w when the film point is uniform over
 * the whole film (1 / (A cos^3) for an image plane of area A at unit distance). A light-tracing
 * estimate of I_j therefore multiplies by We and lets spc_splat_add apply f_j; the integrator
 * divides by the number of light paths traced per pass.
 */
/* True if light paths can be connected to the camera (perspective pinhole). A thin lens is not
 * connectible: bdpt's t = 1, ipt's camera hits and specular NEE from the camera then have no
 * strategy there, as with an orthographic camera, and the other strategies' weights sum to one
 * without them (unbiased; the lens's light-traced caustics come from the camera side only). */
bool spc_camera_connectible(const spc_camera_state *cs);
/* Solid-angle density of the world direction d (unit) of a camera ray when the film position is
 * uniform over the whole film. The same expression is returned past the film's edges (callers
 * decide what lies on the film); 0 behind the camera and for orthographic and thin-lens cameras. */
double spc_camera_pdf_dir(const spc_camera_state *cs, spc_vec3 d);

typedef struct spc_camera_direct {
    spc_vec3 p;       /* the pinhole */
    spc_vec3 wi;      /* unit direction from ref toward the pinhole */
    double dist;      /* distance from ref to the pinhole */
    spc_vec3 p_near;  /* where the camera ray through ref starts (on the near clip plane): visibility
                         must be tested from ref up to this point only */
    double fx, fy;    /* film position (continuous pixels of the full film) */
    double We;        /* importance per unit solid angle at the pinhole: W H pdf_dir(-wi) */
    double pdf;       /* density of choosing the camera point: 1 (the pinhole is a delta position) */
} spc_camera_direct;

/* Connects a world point to the camera: false if ref projects outside the film, lies outside the
 * clip range, or the camera is not connectible. (Callers rendering a crop window check that
 * (fx, fy) lies in it: the driver takes no camera sample outside the rendered window.) */
bool spc_camera_sample_direct(const spc_camera_state *cs, spc_vec3 ref, spc_camera_direct *out);

#endif
