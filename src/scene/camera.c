/*
 * scene/camera.c: camera ray generation and projection.
 *
 * Perspective (Mitsuba 3): fov along fov_axis; a film point (fx, fy) maps to the local direction
 * ((1 - 2 fx/W) tan_x, (1 - 2 fy/H) tan_y, 1). Orthographic: local x in [-1, 1] across the width
 * and y in [-H/W, H/W], scaled by to_world.
 *
 * Importance (BDPT, light tracing): a film point uniform over the image plane z = 1 (area
 * A = 4 tan_x tan_y) gives the ray direction w = M v / |M v|, v = (x, y, 1), M the linear part of
 * to_world; its solid-angle density is |M v|^3 / (|det M| A) (= 1 / (A cos^3 theta) for a rigid
 * M; Veach 1997, sec. 10.8; pbrt-v4's PerspectiveCamera::PDF_We without the lens). See camera.h
 * for the normalization against the pixel filter.
 *
 * Thin lens (Mitsuba 3's thinlens): the ray from a point on the lens disk (radius aperture_radius,
 * at the pinhole, in the plane z = 0) toward the point where the pinhole ray meets the plane in
 * focus z = focus_distance; so that plane is sharp and the rest is blurred.
 */
#include "scene/camera.h"
#include "core/warp.h"

bool spc_camera_prepare(spc_camera_state *cs, const spc_camera *c, int width, int height)
{
    cs->type = c->type;
    cs->to_world = c->to_world;
    if (!spc_mat4_inverse(&c->to_world, &cs->to_local) || width <= 0 || height <= 0)
        return false;
    cs->width = width;
    cs->height = height;
    cs->origin = spc_mat4_apply_point(&c->to_world, spc_v3(0, 0, 0));
    cs->forward = spc_normalize(spc_mat4_apply_vector(&c->to_world, spc_v3(0, 0, 1)));
    cs->near_clip = c->near_clip;
    cs->far_clip = c->far_clip;
    cs->pixel_scale = spc_length(spc_mat4_apply_vector(&c->to_world, spc_v3(0, 0, 1)));
    double aspect = (double)width / (double)height;
    if (c->type == SPC_CAMERA_ORTHOGRAPHIC) {
        cs->tan_x = 1.0;
        cs->tan_y = 1.0 / aspect;
    } else {
        if (!spc_fov_tangents(c->fov, c->fov_axis, width, height, &cs->tan_x, &cs->tan_y))
            return false;
    }
    cs->image_area = 4.0 * cs->tan_x * cs->tan_y;
    /* M ((1 - 2 fx/W) tan_x, (1 - 2 fy/H) tan_y, 1) = M (tan_x, tan_y, 1) + fx M (-2 tan_x/W, 0, 0)
     * + fy M (0, -2 tan_y/H, 0) */
    cs->ray_d0 = spc_mat4_apply_vector(&cs->to_world, spc_v3(cs->tan_x, cs->tan_y, 1.0));
    cs->ray_dfx = spc_mat4_apply_vector(&cs->to_world, spc_v3(-2.0 * cs->tan_x / width, 0.0, 0.0));
    cs->ray_dfy = spc_mat4_apply_vector(&cs->to_world, spc_v3(0.0, -2.0 * cs->tan_y / height, 0.0));
    cs->aperture_radius = c->type == SPC_CAMERA_PERSPECTIVE ? c->aperture_radius : 0.0;
    cs->focus_distance = c->focus_distance;
    if (cs->aperture_radius > 0.0 && !(cs->focus_distance > 0.0))
        return false;
    return true;
}

spc_ray spc_camera_ray_lens(const spc_camera_state *cs, double fx, double fy, spc_vec2 u_lens)
{
    if (!spc_camera_has_lens(cs))
        return spc_camera_ray(cs, fx, fy);
    double x = (1.0 - 2.0 * fx / cs->width) * cs->tan_x;
    double y = (1.0 - 2.0 * fy / cs->height) * cs->tan_y;
    spc_vec2 a = spc_warp_disk_concentric(u_lens);
    spc_vec3 lens = spc_v3(cs->aperture_radius * a.x, cs->aperture_radius * a.y, 0.0);
    /* the pinhole ray's point on the plane in focus, seen from the lens point */
    spc_vec3 v = spc_sub(spc_v3(x * cs->focus_distance, y * cs->focus_distance, cs->focus_distance), lens);
    spc_vec3 dw = spc_mat4_apply_vector(&cs->to_world, v);
    double len = spc_length(dw);
    spc_ray r;
    r.o = spc_mat4_apply_point(&cs->to_world, lens);
    r.d = spc_scale(dw, 1.0 / len);
    /* local depth z is reached at t = z |dw| / v.z */
    r.tmin = cs->near_clip * len / v.z;
    r.tmax = cs->far_clip * len / v.z;
    return r;
}

spc_ray spc_camera_ray(const spc_camera_state *cs, double fx, double fy)
{
    spc_ray r;
    if (cs->type == SPC_CAMERA_ORTHOGRAPHIC) {
        double x = (1.0 - 2.0 * fx / cs->width) * cs->tan_x;
        double y = (1.0 - 2.0 * fy / cs->height) * cs->tan_y;
        r.o = spc_mat4_apply_point(&cs->to_world, spc_v3(x, y, 0.0));
        r.d = cs->forward;
        r.tmin = cs->near_clip * cs->pixel_scale;
        r.tmax = cs->far_clip * cs->pixel_scale;
        return r;
    }
    spc_vec3 dw = spc_madd(spc_madd(cs->ray_d0, cs->ray_dfx, fx), cs->ray_dfy, fy);
    double len = spc_length(dw);
    r.o = cs->origin;
    r.d = spc_scale(dw, 1.0 / len);
    /* clip planes are depths along the camera's z axis: local depth z is at distance z |dw| */
    r.tmin = cs->near_clip * len;
    r.tmax = cs->far_clip * len;
    return r;
}

bool spc_camera_project(const spc_camera_state *cs, spc_vec3 p, double *fx, double *fy)
{
    spc_vec3 l = spc_mat4_apply_point(&cs->to_local, p);
    double x, y;
    if (cs->type == SPC_CAMERA_ORTHOGRAPHIC) {
        if (l.z <= 0.0)
            return false;
        x = l.x;
        y = l.y;
    } else {
        if (!(l.z > 0.0))
            return false;
        x = l.x / l.z;
        y = l.y / l.z;
    }
    *fx = (1.0 - x / cs->tan_x) * 0.5 * cs->width;
    *fy = (1.0 - y / cs->tan_y) * 0.5 * cs->height;
    return *fx >= 0.0 && *fx < cs->width && *fy >= 0.0 && *fy < cs->height;
}

bool spc_camera_connectible(const spc_camera_state *cs)
{
    return cs->type == SPC_CAMERA_PERSPECTIVE && !spc_camera_has_lens(cs);
}

/* Density of the direction through the image-plane point (x, y, 1), local coordinates. */
static double pdf_dir_local(const spc_camera_state *cs, double x, double y)
{
    spc_vec3 mv = spc_mat4_apply_vector(&cs->to_world, spc_v3(x, y, 1.0));
    double det = fabs(spc_mat4_det3(&cs->to_world));
    if (!(det > 0.0))
        return 0.0;
    double len = spc_length(mv);
    return len * len * len / (det * cs->image_area);
}

double spc_camera_pdf_dir(const spc_camera_state *cs, spc_vec3 d)
{
    if (!spc_camera_connectible(cs))
        return 0.0;
    spc_vec3 l = spc_mat4_apply_vector(&cs->to_local, d);
    if (!(l.z > 0.0))
        return 0.0;
    return pdf_dir_local(cs, l.x / l.z, l.y / l.z);
}

bool spc_camera_sample_direct(const spc_camera_state *cs, spc_vec3 ref, spc_camera_direct *out)
{
    if (!spc_camera_connectible(cs))
        return false;
    spc_vec3 l = spc_mat4_apply_point(&cs->to_local, ref);
    /* camera rays start at local depth near_clip and end at far_clip */
    if (!(l.z > cs->near_clip && l.z < cs->far_clip))
        return false;
    double x = l.x / l.z, y = l.y / l.z;
    double fx = (1.0 - x / cs->tan_x) * 0.5 * cs->width;
    double fy = (1.0 - y / cs->tan_y) * 0.5 * cs->height;
    if (!(fx >= 0.0 && fx < cs->width && fy >= 0.0 && fy < cs->height))
        return false;
    double pdf = pdf_dir_local(cs, x, y);
    spc_vec3 d = spc_sub(cs->origin, ref);
    double dist = spc_length(d);
    if (!(pdf > 0.0) || !(dist > 0.0))
        return false;
    out->p = cs->origin;
    out->wi = spc_scale(d, 1.0 / dist);
    out->dist = dist;
    /* the camera ray through ref reaches local depth near_clip at a fraction near/z of the way */
    out->p_near = spc_madd(cs->origin, spc_sub(ref, cs->origin), cs->near_clip / l.z);
    out->fx = fx;
    out->fy = fy;
    out->We = (double)cs->width * (double)cs->height * pdf;
    out->pdf = 1.0;
    return true;
}
