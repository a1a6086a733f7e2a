/*
 * tests/render_util.h: helpers for tests that build scenes in code and render them.
 */
#ifndef SPC_TESTS_RENDER_UTIL_H
#define SPC_TESTS_RENDER_UTIL_H

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "integrator/integrator.h"
#include "render/film.h"
#include "scene/scene.h"
#include "scene/sdf.h"
#include "scene/shape.h"
#include "specula/specula.h"

/* The scene file at `rel` (an absolute path, or one relative to the source tree: $SPC_SOURCE_DIR, else
 * the working directory)
 * with $res defined as res where res > 0; NULL on failure (printed with its file and line). */
static inline spc_scene *tu_load(const char *rel, int res)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    char path[1024], r[16];
    if (rel[0] == '/')
        snprintf(path, sizeof path, "%s", rel);
    else
        snprintf(path, sizeof path, "%s/%s", d ? d : ".", rel);
    snprintf(r, sizeof r, "%d", res);
    spc_define defs[1] = {{"res", r}};
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_scene_load(path, defs, res > 0 ? 1 : 0, &sc, &err) != SPC_OK) {
        char msg[1200];
        spc_error_format(&err, msg, sizeof msg);
        printf("  %s\n", msg);
        return NULL;
    }
    return sc;
}

static inline spc_bsdf *tu_diffuse(spc_scene *sc, double albedo)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_DIFFUSE;
    b->reflectance = spc_scene_constant(sc, spc_rgb1(albedo));
    return b;
}

static inline spc_emitter *tu_area(spc_scene *sc, spc_shape *sh, int shape_index, double radiance)
{
    spc_emitter *e = spc_scene_new_emitter(sc);
    e->type = SPC_EMITTER_AREA;
    e->radiance = spc_scene_constant(sc, spc_rgb1(radiance));
    e->shape_index = shape_index;
    sh->emitter = e;
    return e;
}

static inline void tu_camera(spc_scene *sc, spc_vec3 origin, spc_vec3 target, spc_vec3 up, double fov, int w, int h)
{
    spc_mat4_lookat(origin, target, up, &sc->camera.to_world);
    sc->camera.fov = fov;
    sc->camera.fov_axis = SPC_FOV_X;
    sc->film.width = w;
    sc->film.height = h;
    sc->film.rfilter = SPC_RFILTER_BOX;
    sc->film.filter_radius = 0.5;
}

/* A smooth dielectric of relative index eta, white reflectance and transmittance. */
static inline spc_bsdf *tu_glass(spc_scene *sc, double eta)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_DIELECTRIC;
    b->eta = eta;
    b->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    b->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    return b;
}

/* A sphere with BSDF b (NULL: none). */
static inline spc_shape *tu_sphere(spc_scene *sc, spc_vec3 c, double r, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_sphere(s, c, r, NULL, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

/* The unit disk, rectangle or cube's placement: scale, then a rotation by deg degrees about axis,
 * then a translation to pos. */
static inline spc_mat4 tu_place(spc_vec3 scale, spc_vec3 axis, double deg, spc_vec3 pos)
{
    spc_mat4 S = spc_mat4_scale(scale), R = spc_mat4_rotate(axis, deg), T = spc_mat4_translate(pos);
    spc_mat4 RS = spc_mat4_mul(&R, &S);
    return spc_mat4_mul(&T, &RS);
}

static inline spc_shape *tu_disk(spc_scene *sc, spc_mat4 M, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_disk(s, &M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

static inline spc_shape *tu_rect(spc_scene *sc, spc_mat4 M, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_rectangle(s, &M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

static inline spc_shape *tu_cube(spc_scene *sc, spc_mat4 M, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_cube(s, &M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

static inline spc_shape *tu_cylinder(spc_scene *sc, spc_vec3 p0, spc_vec3 p1, double r, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_cylinder(s, p0, p1, r, NULL, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

/* A UV sphere tessellated into nu x nv quads with vertex normals (smooth shading), squashed along z
 * by zscale (1: a sphere; otherwise an ellipsoid whose normals are the ellipsoid's, not radial). */
static inline spc_shape *tu_mesh_sphere(spc_scene *sc, spc_vec3 c, double r, double zscale, int nu, int nv,
                                        const spc_bsdf *b)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = (size_t)(nu * (nv + 1));
    m.ntris = (size_t)(2 * nu * nv);
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.n = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    for (int j = 0; j <= nv; ++j)
        for (int i = 0; i < nu; ++i) {
            double th = SPC_PI * j / nv, ph = 2 * SPC_PI * i / nu;
            spc_vec3 l = spc_v3(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
            spc_vec3 n = zscale == 1.0 ? l : spc_normalize(spc_v3(l.x, l.y, l.z / zscale));
            size_t k = (size_t)(j * nu + i);
            m.p[3 * k] = (float)(c.x + r * l.x);
            m.p[3 * k + 1] = (float)(c.y + r * l.y);
            m.p[3 * k + 2] = (float)(c.z + r * zscale * l.z);
            m.n[3 * k] = (float)n.x;
            m.n[3 * k + 1] = (float)n.y;
            m.n[3 * k + 2] = (float)n.z;
        }
    size_t t = 0;
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            uint32_t a = (uint32_t)(j * nu + i), bb = (uint32_t)(j * nu + (i + 1) % nu);
            uint32_t cc = (uint32_t)((j + 1) * nu + i), dd = (uint32_t)((j + 1) * nu + (i + 1) % nu);
            /* outward winding: (a, c, b) and (b, c, d) for theta growing downward */
            uint32_t tri[6] = {a, cc, bb, bb, cc, dd};
            memcpy(m.idx + 3 * t, tri, sizeof tri);
            t += 2;
        }
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    if (!spc_shape_init_mesh(s, &m, NULL, NULL, 0, 0, &err))
        printf("  mesh: %s\n", err.msg);
    s->bsdf = b;
    return s;
}

/* Finalizes sc; false (and the reason printed) on failure. */
static inline bool tu_finalize(spc_scene *sc)
{
    spc_error err;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        return false;
    }
    return true;
}

/* A free start point at p (no surface, no ray offset): normal +z. */
static inline spc_hit tu_free_point(spc_vec3 p)
{
    spc_hit h;
    memset(&h, 0, sizeof h);
    h.p = p;
    h.ng = spc_v3(0, 0, 1);
    h.sh = spc_frame_from_n(h.ng);
    return h;
}

/* A signed distance field shape of one primitive d (scene/sdf.h) placed by M, with BSDF b; NULL
 * (and the reason printed) if d or M is refused. */
static inline spc_shape *tu_sdf(spc_scene *sc, const spc_sdf_desc *d, const spc_mat4 *M, const spc_bsdf *b)
{
    spc_sdf *f = spc_sdf_create();
    spc_error err;
    int root = spc_sdf_add(f, d, NULL, 0, 0, &err);
    spc_shape *s = spc_scene_new_shape(sc);
    if (root < 0 || !spc_shape_init_sdf(s, f, root, M, NULL, 0, 0, &err)) {
        printf("  sdf: %s\n", err.msg);
        return NULL;
    }
    s->bsdf = b;
    return s;
}

/* A perfect mirror (a conductor with k = -1: reflectance 1 at every angle). */
static inline spc_bsdf *tu_mirror(spc_scene *sc)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_CONDUCTOR;
    b->cond_k = spc_rgb1(-1.0);
    b->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    return b;
}

/* A normalmap BSDF over `nested` with an n x n tangent-space map (bilinear, repeat, to_uv scaled by
 * rep) of smooth tilts up to about `tilt` radians, a sum of sines with phases drawn from seed. */
static inline spc_bsdf *tu_normal_mapped(spc_scene *sc, const spc_bsdf *nested, int n, double tilt, double rep,
                                         uint64_t seed)
{
    spc_texture *t = spc_scene_new_texture(sc);
    spc_texture_init_constant(t, spc_rgb1(0.0));
    t->type = SPC_TEX_BITMAP;
    t->width = t->height = n;
    t->data = malloc(3 * (size_t)(n * n) * sizeof(float));
    t->nearest = false;
    t->wrap = SPC_WRAP_REPEAT;
    double ph[4];
    for (int k = 0; k < 4; ++k) {
        seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
        ph[k] = 2 * SPC_PI * (double)(seed >> 11) / 9007199254740992.0;
    }
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            double u = 2 * SPC_PI * x / n, v = 2 * SPC_PI * y / n;
            double ax = tilt * sin(u + ph[0]) * cos(2 * v + ph[1]), ay = tilt * cos(2 * u + ph[2]) * sin(v + ph[3]);
            spc_vec3 nl = spc_normalize(spc_v3(tan(ax), tan(ay), 1.0));
            float *p = t->data + 3 * (y * n + x);
            p[0] = (float)(0.5 * nl.x + 0.5);
            p[1] = (float)(0.5 * nl.y + 0.5);
            p[2] = (float)(0.5 * nl.z + 0.5);
        }
    t->to_uv[0][0] = t->to_uv[1][1] = rep;
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_NORMALMAP;
    b->normalmap = t;
    b->nested[0] = nested;
    return b;
}

/* The options of tu_render_stats's renders (the others at their defaults), for a caller that sets
 * more of them before tu_render_options. */
static inline void tu_options(spc_render_options *o, const char *integrator, const char *snee, int spp, int threads,
                              uint64_t seed)
{
    spc_render_options_init(o);
    o->spp = spp;
    o->threads = threads;
    o->seed = seed;
    o->integrator = integrator;
    o->specular_nee = snee;
}

/* Renders with options o and returns the film (caller destroys); NULL on failure (message printed).
 * *st (if not NULL) gets the render's statistics, *status (if not NULL) its status. */
static inline spc_film *tu_render_options(const spc_scene *sc, const spc_render_options *o, spc_render_stats *st,
                                          spc_status *status)
{
    spc_film *f = NULL;
    spc_error err;
    spc_render_stats own;
    if (!st)
        st = &own;
    memset(st, 0, sizeof *st);
    spc_status s = spc_render(sc, o, &f, st, &err);
    if (status)
        *status = s;
    if (s != SPC_OK) {
        char buf[1200];
        spc_error_format(&err, buf, sizeof buf);
        printf("  render failed: %s\n", buf);
        spc_film_destroy(f);
        return NULL;
    }
    return f;
}

/* Renders with specular NEE `snee` (NULL: the scene's) and returns the film (caller destroys); NULL on
 * failure (message printed). *st (if not NULL) gets the render's statistics. */
static inline spc_film *tu_render_stats(const spc_scene *sc, const char *integrator, const char *snee, int spp,
                                        int threads, uint64_t seed, spc_render_stats *st)
{
    spc_render_options o;
    tu_options(&o, integrator, snee, spp, threads, seed);
    return tu_render_options(sc, &o, st, NULL);
}

/* tu_render_stats, with only the wall time (*wall_seconds, if not NULL). */
static inline spc_film *tu_render_nee(const spc_scene *sc, const char *integrator, const char *snee, int spp,
                                      int threads, uint64_t seed, double *wall_seconds)
{
    spc_render_stats st;
    spc_film *f = tu_render_stats(sc, integrator, snee, spp, threads, seed, &st);
    if (f && wall_seconds)
        *wall_seconds = st.wall_seconds;
    return f;
}

/* Renders and returns the film (caller destroys); NULL on failure (message printed). Specular NEE
 * as the scene says, and off where it says nothing: these tests check the integrators themselves,
 * not the default chosen from the scene (tests of that pass NULL to tu_render_nee). */
static inline spc_film *tu_render(const spc_scene *sc, const char *integrator, int spp, int threads, uint64_t seed)
{
    return tu_render_nee(sc, integrator, sc->integrator.specular_nee[0] ? NULL : "none", spp, threads, seed, NULL);
}

/* Mean over pixels and channel c (0..2), and the standard error of that mean. */
static inline void tu_image_mean(const spc_film *f, int c, double *mean, double *stderr_)
{
    size_t n = (size_t)f->width * f->height;
    double s = 0.0, v = 0.0;
    for (size_t i = 0; i < n; ++i) {
        s += f->rgb[3 * i + c];
        v += f->var[3 * i + c];
    }
    *mean = s / (double)n;
    *stderr_ = sqrt(v) / (double)n;
}

/* The summed per-pixel variance (of the pixel means) over every pixel and channel: how noisy a
 * render is as a whole; 0 for NULL. */
static inline double tu_var_sum(const spc_film *f)
{
    double v = 0.0;
    for (size_t i = 0; f && i < (size_t)3 * f->width * f->height; ++i)
        v += f->var[i];
    return v;
}

/* The image tests' agreement of img with the reference ref: the per-pixel z-test (Sidak, alpha
 * 0.01) passes on at least min_pass of the pixels, and every channel's image mean lies within 3
 * standard errors. Prints each failure after `label`; *d (may be NULL) receives the comparison. */
static inline bool tu_image_agrees(const spc_film *img, const spc_film *ref, double min_pass, const char *label,
                                   spc_diff_result *d)
{
    spc_image_rgb a = {img->width, img->height, img->rgb, img->var};
    spc_image_rgb b = {ref->width, ref->height, ref->rgb, ref->var};
    spc_diff_result r;
    spc_error err;
    if (spc_image_diff(&a, &b, &r, &err) != SPC_OK) {
        printf("  %s: images cannot be compared: %s\n", label, err.msg);
        return false;
    }
    if (d)
        *d = r;
    bool ok = true;
    if (!r.has_ztest || r.ztest_pass_fraction < min_pass) {
        printf("  %s: z-test pass fraction %.4f\n", label, r.ztest_pass_fraction);
        ok = false;
    }
    for (int c = 0; c < 3; ++c) {
        double ma, sa, mb, sb;
        tu_image_mean(img, c, &ma, &sa);
        tu_image_mean(ref, c, &mb, &sb);
        double se = sqrt(sa * sa + sb * sb);
        if (!(fabs(ma - mb) <= 3 * se)) {
            printf("  %s channel %d: mean %.5f vs %.5f (se %.2g)\n", label, c, ma, mb, se);
            ok = false;
        }
    }
    return ok;
}

/* Renders sc by `path` under the specular NEE settings a_set (spp_a samples per pixel, seed) and
 * b_set (spp_b, seed + 1) at 2 threads and compares the two: true where the per-pixel z-test passes
 * on at least 99% of the pixels and the image means differ by less than 4 standard errors (both
 * printed under label). */
static inline bool tu_settings_agree(const spc_scene *sc, const char *a_set, int spp_a, const char *b_set, int spp_b,
                                     uint64_t seed, const char *label)
{
    spc_film *a = tu_render_nee(sc, "path", a_set, spp_a, 2, seed, NULL);
    spc_film *b = tu_render_nee(sc, "path", b_set, spp_b, 2, seed + 1, NULL);
    bool ok = a && b;
    if (ok) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        ok = tu_image_agrees(a, b, 0.99, label, &d);
        double ma, sa, mb, sb;
        tu_image_mean(a, 0, &ma, &sa);
        tu_image_mean(b, 0, &mb, &sb);
        double z = (ma - mb) / sqrt(sa * sa + sb * sb);
        printf("    %s: z-test pass %.4f of %d pixels; means %.5f +- %.5f vs %.5f +- %.5f (z %.2f)\n", label,
               d.ztest_pass_fraction, d.ztest_pixels, ma, sa, mb, sb, z);
        ok = ok && fabs(z) < 4.0;
    } else {
        printf("  %s: a render failed\n", label);
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    return ok;
}

#endif
