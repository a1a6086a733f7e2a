/*
 * render/camera.h: pinhole perspective and orthographic cameras (Mitsuba conventions: the camera
 * looks along local +z, local +y is up and local +x points to the image's LEFT; pixel (0, 0) is
 * the top-left corner of the full film; film coordinates are continuous pixels).
 */
#ifndef SPC_RENDER_CAMERA_H
#define SPC_RENDER_CAMERA_H

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
} spc_camera_state;

bool spc_camera_prepare(spc_camera_state *cs, const spc_camera *c, int width, int height);
/* Ray through continuous film position (fx, fy) in pixels of the full film. */
spc_ray spc_camera_ray(const spc_camera_state *cs, double fx, double fy);
/* Projects a world point onto the film: false if behind the camera or outside the film.
 * *fx, *fy receive the continuous film position. */
bool spc_camera_project(const spc_camera_state *cs, spc_vec3 p, double *fx, double *fy);

#endif
