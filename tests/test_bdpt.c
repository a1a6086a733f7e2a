/*
 * tests/test_bdpt.c: bidirectional path tracing (src/integrator/bdpt.c) and camera importance.
 *
 * - Closed forms of test_render.c rendered by bdpt: white furnace sphere and cube (three scales),
 *   point light in a diffuse sphere, glass slab behind an orthographic camera (no t = 1).
 * - Per-pixel z-tests (Sidak over pixels, alpha 0.01, spc_image_diff; at least 99% of pixels
 *   pass) and image means within 4 standard errors, bdpt against path: a box with an area light,
 *   a glass and a mirror sphere; a caustic (glass sphere on a floor, small sphere light); a point
 *   light in a diffuse box; a constant environment and an environment map over a glass sphere;
 *   directional and spot lights; coarse smooth-shaded meshes (diffuse and glass), where the
 *   shading-normal correction of light subpaths matters; a normal-mapped floor and wall, where it
 *   must use the map's normal (also for ptracer); and bdpt's balance heuristic against its
 *   power heuristic.
 * - Strategies (debug mode): the weighted single-strategy images sum to the full image (same
 *   seed); each unweighted strategy (s, t) of length k = s + t - 1 in a scene without corners
 *   (every strategy samples every path there, with finite variance) agrees with the length-k
 *   image; light tracing (t = 1) agrees with NEE (s = 1) for box, tent and Gaussian pixel filters
 *   and a crop window, which checks the normalization of the camera importance. All strategies in
 *   one render (strategy_images) equal the single-strategy renders bit for bit and sum to the image.
 * - Bit-identical images, splats included, for 1 and 2 threads.
 */
/* ctest-labels: stat */
/* ctest-timeout: 600 */
#include "harness.h"
#include "integrator/bdpt.h"
#include "render_util.h"
#include "scene/mesh.h"

/* ---- helpers ---- */

static spc_film *render_opts(const spc_scene *sc, const char *integrator, int spp, int threads, uint64_t seed,
                             int max_depth, int s, int t, bool weighted, bool balance)
{
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp;
    o.threads = threads;
    o.seed = seed;
    o.integrator = integrator;
    o.max_depth = max_depth;
    o.strategy_s = s;
    o.strategy_t = t;
    o.strategy_weighted = weighted;
    o.mis_balance = balance;
    spc_film *f = NULL;
    spc_error err;
    spc_render_stats st;
    if (spc_render(sc, &o, &f, &st, &err) != SPC_OK) {
        char buf[1200];
        spc_error_format(&err, buf, sizeof buf);
        printf("  render failed: %s\n", buf);
        spc_film_destroy(f);
        return NULL;
    }
    return f;
}

/* |mean - expected| within k standard errors (as test_render.c). */
static void check_mean(const spc_film *f, double expected, double k)
{
    for (int c = 0; c < 3; ++c) {
        double m, se;
        tu_image_mean(f, c, &m, &se);
        CHECK_MSG(fabs(m - expected) <= k * se + 1e-6 * expected, "channel %d: mean %.6f expected %.6f (se %.2g)", c, m,
                  expected, se);
        CHECK_MSG(se > 0.0 && se < 0.02 * expected, "channel %d: standard error %.3g is not small", c, se);
    }
}

/* Fraction of pixels passing the Sidak-corrected z-test of a against b (both with variance);
 * prints the worst pixels when below `need`. */
static double ztest(const spc_film *a, const spc_film *b, double need, const char *what)
{
    spc_image_rgb ia = {a->width, a->height, a->rgb, a->var};
    spc_image_rgb ib = {b->width, b->height, b->rgb, b->var};
    spc_diff_result r;
    spc_error err;
    if (spc_image_diff(&ia, &ib, &r, &err) != SPC_OK || !r.has_ztest)
        return 0.0;
    printf("  %s: z-test pass %.4f, means (%.5f %.5f %.5f) vs (%.5f %.5f %.5f)\n", what, r.ztest_pass_fraction,
           r.mean_a[0], r.mean_a[1], r.mean_a[2], r.mean_b[0], r.mean_b[1], r.mean_b[2]);
    if (r.ztest_pass_fraction < need) {
        int shown = 0;
        for (int i = 0; i < a->width * a->height && shown < 8; ++i)
            for (int c = 0; c < 3; ++c) {
                double v = (double)a->var[3 * i + c] + b->var[3 * i + c];
                double z = v > 0.0 ? (a->rgb[3 * i + c] - b->rgb[3 * i + c]) / sqrt(v) : 0.0;
                if (fabs(z) > 4.0) {
                    printf("    pixel (%d, %d) channel %d: %.5g vs %.5g, z = %.2f\n", i % a->width, i / a->width, c,
                           a->rgb[3 * i + c], b->rgb[3 * i + c], z);
                    ++shown;
                    break;
                }
            }
    }
    return r.ztest_pass_fraction;
}

/* The image means of a and b agree within k combined standard errors, per channel. */
static void check_means_agree(const spc_film *a, const spc_film *b, double k)
{
    for (int c = 0; c < 3; ++c) {
        double ma, sa, mb, sb;
        tu_image_mean(a, c, &ma, &sa);
        tu_image_mean(b, c, &mb, &sb);
        double se = sqrt(sa * sa + sb * sb);
        CHECK_MSG(fabs(ma - mb) <= k * se + 1e-7, "channel %d: image means %.6f and %.6f differ by %.2f standard errors",
                  c, ma, mb, se > 0.0 ? fabs(ma - mb) / se : INFINITY);
    }
}

/* As ztest, but only over pixels whose reference value b is at least `floor` times b's image
 * mean in every channel (Sidak over the pixels tested). Where a strategy has to find a small
 * light by chance (the penumbra of the lit side of an object), a few thousand samples may find
 * it zero times: a zero mean with a zero variance estimate says nothing, so those pixels are
 * left to the image-mean check. */
static double ztest_lit(const spc_film *a, const spc_film *b, double floor, const char *what)
{
    double mean[3] = {0, 0, 0};
    size_t npix = (size_t)b->width * b->height;
    for (size_t i = 0; i < npix; ++i)
        for (int c = 0; c < 3; ++c)
            mean[c] += b->rgb[3 * i + c] / (double)npix;
    size_t tested = 0, passed = 0;
    for (int pass = 0; pass < 2; ++pass) {
        double alpha = pass ? -expm1(log1p(-0.01) / (double)(tested ? tested : 1)) : 0.0;
        for (size_t i = 0; i < npix; ++i) {
            bool lit = true;
            for (int c = 0; c < 3; ++c)
                lit = lit && b->rgb[3 * i + c] >= floor * mean[c];
            if (!lit)
                continue;
            if (!pass) {
                ++tested;
                continue;
            }
            double p_min = 1.0;
            for (int c = 0; c < 3; ++c) {
                double v = (double)a->var[3 * i + c] + b->var[3 * i + c];
                double z = v > 0.0 ? (a->rgb[3 * i + c] - b->rgb[3 * i + c]) / sqrt(v) : 0.0;
                double p = erfc(fabs(z) / sqrt(2.0));
                p_min = p < p_min ? p : p_min;
            }
            if (-expm1(3.0 * log1p(-p_min)) >= alpha)
                ++passed;
        }
    }
    double frac = tested ? (double)passed / (double)tested : 0.0;
    printf("  %s: z-test pass %.4f of %zu pixels with b >= %.2f x mean\n", what, frac, tested, floor);
    return tested >= npix / 2 ? frac : 0.0;
}

static spc_bsdf *twosided_diffuse(spc_scene *sc, double r, double g, double b)
{
    spc_bsdf *d = spc_scene_new_bsdf(sc);
    d->type = SPC_BSDF_DIFFUSE;
    d->reflectance = spc_scene_constant(sc, spc_rgb3(r, g, b));
    spc_bsdf *t = spc_scene_new_bsdf(sc);
    t->type = SPC_BSDF_TWOSIDED;
    t->nested[0] = d;
    return t;
}

static spc_bsdf *glass(spc_scene *sc, double eta)
{
    spc_bsdf *g = spc_scene_new_bsdf(sc);
    g->type = SPC_BSDF_DIELECTRIC;
    g->eta = eta;
    g->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    g->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    return g;
}

static spc_bsdf *mirror(spc_scene *sc)
{
    spc_bsdf *m = spc_scene_new_bsdf(sc);
    m->type = SPC_BSDF_CONDUCTOR;
    m->cond_eta = spc_rgb1(0.0);
    m->cond_k = spc_rgb1(-1.0); /* perfect mirror */
    m->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    return m;
}

/* A rectangle ([-1,1]^2 in xy, normal +z) scaled by (sx, sy), rotated about x by rx degrees (then
 * about y by ry), translated to c. */
static spc_shape *rect(spc_scene *sc, double sx, double sy, double rx, double ry, spc_vec3 c, const spc_bsdf *b)
{
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_mat4 S = spc_mat4_scale(spc_v3(sx, sy, 1.0));
    spc_mat4 Rx = spc_mat4_rotate(spc_v3(1, 0, 0), rx);
    spc_mat4 Ry = spc_mat4_rotate(spc_v3(0, 1, 0), ry);
    spc_mat4 T = spc_mat4_translate(c);
    spc_mat4 M = spc_mat4_mul(&Rx, &S);
    M = spc_mat4_mul(&Ry, &M);
    M = spc_mat4_mul(&T, &M);
    spc_error err;
    spc_shape_init_rectangle(sh, &M, NULL, 0, 0, &err);
    sh->bsdf = b;
    return sh;
}

static spc_shape *sphere(spc_scene *sc, spc_vec3 c, double r, const spc_bsdf *b)
{
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_sphere(sh, c, r, NULL, NULL, 0, 0, &err);
    sh->bsdf = b;
    return sh;
}

static spc_scene *finalize(spc_scene *sc)
{
    spc_error err;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* The demo's Cornell box (scenes/demo.xml) built in code: white floor, ceiling and back wall, red
 * left and green right walls, an area light under the ceiling (light_scale times the demo's size),
 * optionally the glass and mirror spheres, or a point light instead of the area light. */
enum { BOX_PLAIN = 0, BOX_SPHERES = 1, BOX_POINT = 2 };
static spc_scene *cornell_box_fov(int variant, int res, double light_scale, double fov)
{
    spc_scene *sc = spc_scene_create();
    spc_bsdf *white = twosided_diffuse(sc, 0.725, 0.71, 0.68);
    spc_bsdf *red = twosided_diffuse(sc, 0.63, 0.065, 0.05);
    spc_bsdf *green = twosided_diffuse(sc, 0.14, 0.45, 0.091);
    rect(sc, 1, 1, -90, 0, spc_v3(0, 0, 0), white);
    rect(sc, 1, 1, 90, 0, spc_v3(0, 2, 0), white);
    rect(sc, 1, 1, 0, 0, spc_v3(0, 1, -1), white);
    rect(sc, 1, 1, 0, 90, spc_v3(-1, 1, 0), red);
    rect(sc, 1, 1, 0, -90, spc_v3(1, 1, 0), green);
    if (variant == BOX_POINT) {
        spc_emitter *e = spc_scene_new_emitter(sc);
        e->type = SPC_EMITTER_POINT;
        e->intensity = spc_rgb3(3.0, 2.5, 1.5);
        e->position = spc_v3(0.2, 1.6, 0.1);
        sphere(sc, spc_v3(-0.3, 0.4, -0.2), 0.4, twosided_diffuse(sc, 0.5, 0.6, 0.7));
    } else {
        spc_shape *l = rect(sc, 0.25 * light_scale, 0.2 * light_scale, 90, 0, spc_v3(0, 1.98, 0), tu_diffuse(sc, 0.0));
        spc_emitter *e = tu_area(sc, l, sc->nshapes - 1, 1.0);
        e->radiance = spc_scene_constant(sc, spc_rgb_scale(spc_rgb3(17, 12, 4), 1.0 / (light_scale * light_scale)));
    }
    if (variant == BOX_SPHERES) {
        sphere(sc, spc_v3(-0.42, 0.36, -0.1), 0.36, glass(sc, 1.5));
        sphere(sc, spc_v3(0.45, 0.33, -0.45), 0.33, mirror(sc));
    }
    tu_camera(sc, spc_v3(0, 1, 3.9), spc_v3(0, 1, 0), spc_v3(0, 1, 0), fov, res, res);
    return finalize(sc);
}

static spc_scene *cornell_box(int variant, int res, double light_scale)
{
    return cornell_box_fov(variant, res, light_scale, 40.0);
}

/* A caustic: a glass sphere on a diffuse floor in front of a wall, lit by a small sphere light. */
static spc_scene *caustic_scene(int res)
{
    spc_scene *sc = spc_scene_create();
    spc_bsdf *white = twosided_diffuse(sc, 0.7, 0.7, 0.7);
    rect(sc, 3, 3, -90, 0, spc_v3(0, 0, 0), white);
    rect(sc, 3, 2, 0, 0, spc_v3(0, 2, -1.5), white);
    sphere(sc, spc_v3(0, 0.5, 0), 0.5, glass(sc, 1.5));
    spc_shape *l = sphere(sc, spc_v3(0.9, 2.2, 0.6), 0.2, tu_diffuse(sc, 0.0));
    spc_emitter *e = tu_area(sc, l, sc->nshapes - 1, 1.0);
    e->radiance = spc_scene_constant(sc, spc_rgb3(30, 27, 22));
    tu_camera(sc, spc_v3(0, 2.2, 3.2), spc_v3(-0.2, 0.3, 0), spc_v3(0, 1, 0), 45, res, res);
    return finalize(sc);
}

/* A coarse triangulated sphere (nu x nv quads) with smooth vertex normals: its shading normals
 * differ from the geometric ones by up to ~20 degrees, which exercises the adjoint correction. */
static spc_shape *mesh_sphere(spc_scene *sc, spc_vec3 c, double r, int nu, int nv, const spc_bsdf *b)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = (size_t)(nu + 1) * (size_t)(nv + 1);
    m.ntris = 2 * (size_t)nu * (size_t)nv;
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.n = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    if (!m.p || !m.n || !m.idx) {
        spc_mesh_release(&m);
        return NULL;
    }
    for (int j = 0; j <= nv; ++j)
        for (int i = 0; i <= nu; ++i) {
            double th = SPC_PI * j / nv, ph = 2.0 * SPC_PI * i / nu;
            spc_vec3 d = spc_v3(sin(th) * cos(ph), cos(th), sin(th) * sin(ph));
            size_t k = (size_t)j * (nu + 1) + i;
            m.p[3 * k] = (float)(c.x + r * d.x);
            m.p[3 * k + 1] = (float)(c.y + r * d.y);
            m.p[3 * k + 2] = (float)(c.z + r * d.z);
            m.n[3 * k] = (float)d.x;
            m.n[3 * k + 1] = (float)d.y;
            m.n[3 * k + 2] = (float)d.z;
        }
    size_t t = 0;
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            uint32_t a = (uint32_t)(j * (nu + 1) + i), bq = a + 1, cq = a + (uint32_t)(nu + 1), dq = cq + 1;
            uint32_t tri[6] = {a, bq, cq, bq, dq, cq};
            for (int q = 0; q < 6; ++q)
                m.idx[3 * t + q] = tri[q];
            t += 2;
        }
    spc_mesh_drop_degenerate(&m);
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    if (!spc_shape_init_mesh(sh, &m, NULL, NULL, 0, 0, &err)) {
        spc_mesh_release(&m);
        return NULL;
    }
    sh->bsdf = b;
    return sh;
}

/* The Cornell box with coarse smooth-shaded mesh spheres (one diffuse, one glass). */
static spc_scene *box_smooth_meshes(int res)
{
    spc_scene *sc = spc_scene_create();
    spc_bsdf *white = twosided_diffuse(sc, 0.725, 0.71, 0.68);
    rect(sc, 1, 1, -90, 0, spc_v3(0, 0, 0), white);
    rect(sc, 1, 1, 90, 0, spc_v3(0, 2, 0), white);
    rect(sc, 1, 1, 0, 0, spc_v3(0, 1, -1), white);
    rect(sc, 1, 1, 0, 90, spc_v3(-1, 1, 0), twosided_diffuse(sc, 0.63, 0.065, 0.05));
    rect(sc, 1, 1, 0, -90, spc_v3(1, 1, 0), twosided_diffuse(sc, 0.14, 0.45, 0.091));
    spc_shape *l = rect(sc, 0.5, 0.4, 90, 0, spc_v3(0, 1.98, 0), tu_diffuse(sc, 0.0));
    spc_emitter *e = tu_area(sc, l, sc->nshapes - 1, 1.0);
    e->radiance = spc_scene_constant(sc, spc_rgb3(17, 12, 4));
    spc_shape *a = mesh_sphere(sc, spc_v3(-0.42, 0.4, -0.1), 0.38, 6, 4, glass(sc, 1.5));
    spc_shape *b = mesh_sphere(sc, spc_v3(0.45, 0.5, -0.4), 0.45, 5, 4, twosided_diffuse(sc, 0.8, 0.8, 0.8));
    if (!a || !b) {
        spc_scene_destroy(sc);
        return NULL;
    }
    tu_camera(sc, spc_v3(0, 1, 3.9), spc_v3(0, 1, 0), spc_v3(0, 1, 0), 40, res, res);
    return finalize(sc);
}

/* Inside a closed diffuse sphere, lit by a small sphere light, with a diffuse ball: no corners
 * (the geometry term between two points of the wall is 1 / (4 R^2)) and no background, so every
 * unweighted strategy has finite variance and every pixel sees all path lengths. */
static spc_scene *inside_sphere_scene(int res)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *wall = sphere(sc, spc_v3(0, 0, 0), 2.0, tu_diffuse(sc, 0.6));
    wall->bsdf = twosided_diffuse(sc, 0.6, 0.5, 0.4);
    wall->flip_normals = true;
    sphere(sc, spc_v3(-0.5, -0.6, 0.3), 0.5, twosided_diffuse(sc, 0.3, 0.7, 0.8));
    spc_shape *l = sphere(sc, spc_v3(0.6, 0.8, -0.5), 0.35, tu_diffuse(sc, 0.0));
    tu_area(sc, l, sc->nshapes - 1, 3.0);
    tu_camera(sc, spc_v3(0, 0, 1.5), spc_v3(0, 0, -1), spc_v3(0, 1, 0), 70, res, res);
    return finalize(sc);
}

/* A floor with a diffuse and a glass sphere under a uniform sky (constant environment). */
static spc_scene *sky_scene(int res, bool image)
{
    spc_scene *sc = spc_scene_create();
    rect(sc, 2.5, 2.5, -90, 0, spc_v3(0, 0, 0), twosided_diffuse(sc, 0.7, 0.6, 0.5));
    sphere(sc, spc_v3(-0.6, 0.45, 0.0), 0.45, twosided_diffuse(sc, 0.3, 0.7, 0.8));
    sphere(sc, spc_v3(0.6, 0.45, 0.2), 0.45, glass(sc, 1.5));
    spc_emitter *e = spc_scene_new_emitter(sc);
    e->type = SPC_EMITTER_CONSTANT;
    e->radiance = spc_scene_constant(sc, spc_rgb3(0.8, 0.9, 1.0));
    if (image) {
        /* a lat-long map: a sky gradient and a bright "sun" texel block (importance sampled) */
        spc_texture *t = spc_scene_new_texture(sc);
        t->type = SPC_TEX_BITMAP;
        t->width = 32;
        t->height = 16;
        t->data = calloc(3 * 32 * 16, sizeof(float));
        for (int y = 0; y < 16 && t->data; ++y)
            for (int x = 0; x < 32; ++x) {
                float *p = t->data + 3 * (y * 32 + x);
                double g = y < 8 ? 0.3 + 0.05 * y : 0.1;
                bool sun = x >= 20 && x < 22 && y >= 3 && y < 5;
                p[0] = (float)(sun ? 40.0 : 0.8 * g);
                p[1] = (float)(sun ? 36.0 : 0.9 * g);
                p[2] = (float)(sun ? 30.0 : 1.0 * g);
            }
        e->type = SPC_EMITTER_ENVMAP;
        e->radiance = t;
    }
    e->scale = 1.0;
    e->to_world = spc_mat4_identity();
    tu_camera(sc, spc_v3(0, 1.4, 3.2), spc_v3(0, 0.4, 0), spc_v3(0, 1, 0), 50, res, res);
    return finalize(sc);
}

/* A diffuse floor, wall and sphere lit by a directional light and a spot light (both delta). */
static spc_scene *delta_lights_scene(int res)
{
    spc_scene *sc = spc_scene_create();
    rect(sc, 2.5, 2.5, -90, 0, spc_v3(0, 0, 0), twosided_diffuse(sc, 0.7, 0.6, 0.5));
    rect(sc, 2.5, 1.5, 0, 0, spc_v3(0, 1.5, -1.2), twosided_diffuse(sc, 0.6, 0.6, 0.6));
    sphere(sc, spc_v3(0.0, 0.5, 0.0), 0.5, twosided_diffuse(sc, 0.3, 0.7, 0.8));
    spc_emitter *d = spc_scene_new_emitter(sc);
    d->type = SPC_EMITTER_DIRECTIONAL;
    d->direction = spc_normalize(spc_v3(0.4, -1.0, -0.3));
    d->irradiance = spc_rgb3(1.0, 0.9, 0.7);
    spc_emitter *sp = spc_scene_new_emitter(sc);
    sp->type = SPC_EMITTER_SPOT;
    sp->intensity = spc_rgb3(4, 4, 5);
    sp->cutoff_angle = 30.0;
    sp->beam_width = 20.0;
    spc_mat4_lookat(spc_v3(-1.2, 2.0, 1.0), spc_v3(0, 0.3, 0), spc_v3(0, 1, 0), &sp->to_world);
    tu_camera(sc, spc_v3(0, 1.4, 3.2), spc_v3(0, 0.5, 0), spc_v3(0, 1, 0), 50, res, res);
    return finalize(sc);
}

/* A diffuse floor and back wall under a normal map of strong tilts (up to about 0.6 rad), lit by a
 * spot light and a small area light, seen obliquely: a light subpath's shading-normal correction
 * there needs the map's normal, not the surface's (spc_bsdf_adjoint_factor). With the surface's,
 * light tracing's share of the floor (s >= 2, t = 1) was off by the two normals' cosines. */
static spc_scene *normal_mapped_scene(int res)
{
    spc_scene *sc = spc_scene_create();
    rect(sc, 2.5, 2.5, -90, 0, spc_v3(0, 0, 0), tu_normal_mapped(sc, tu_diffuse(sc, 0.7), 32, 0.15, 3.0, 7));
    rect(sc, 2.5, 1.5, 0, 0, spc_v3(0, 1.5, -1.2), tu_normal_mapped(sc, tu_diffuse(sc, 0.6), 32, 0.3, 2.0, 8));
    spc_shape *l = rect(sc, 0.2, 0.2, 90, 0, spc_v3(0.6, 1.6, 0.2), tu_diffuse(sc, 0.0));
    tu_area(sc, l, sc->nshapes - 1, 12.0);
    spc_emitter *sp = spc_scene_new_emitter(sc);
    sp->type = SPC_EMITTER_SPOT;
    sp->intensity = spc_rgb3(4, 4, 5);
    sp->cutoff_angle = 40.0;
    sp->beam_width = 30.0;
    spc_mat4_lookat(spc_v3(-1.5, 1.2, 0.8), spc_v3(0, 0, -0.3), spc_v3(0, 1, 0), &sp->to_world);
    tu_camera(sc, spc_v3(0, 0.8, 3.0), spc_v3(0, 0.3, -0.3), spc_v3(0, 1, 0), 45, res, res);
    return finalize(sc);
}

/* ---- closed forms ---- */

TEST(white_furnace_sphere)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *sh = sphere(sc, spc_v3(0.3, -0.2, 0.1), 1.0, tu_diffuse(sc, 0.5));
    sh->flip_normals = true;
    tu_area(sc, sh, 0, 1.0);
    tu_camera(sc, spc_v3(0.3, -0.2, 0.1), spc_v3(0.3, -0.2, 1.1), spc_v3(0, 1, 0), 90, 8, 8);
    sc->camera.near_clip = 1e-4;
    sc = finalize(sc);
    CHECK(sc != NULL);
    spc_film *f = sc ? tu_render(sc, "bdpt", 256, 2, 1) : NULL;
    CHECK(f != NULL);
    if (f)
        check_mean(f, 2.0, 3.5);
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

TEST(white_furnace_cube_scales)
{
    double scales[3] = {1e-3, 1.0, 1e3};
    for (int i = 0; i < 3; ++i) {
        double s = scales[i];
        spc_scene *sc = spc_scene_create();
        spc_shape *sh = spc_scene_new_shape(sc);
        spc_error err;
        spc_mat4 M = spc_mat4_scale(spc_v3(s, 0.7 * s, 1.3 * s));
        spc_mat4 T = spc_mat4_translate(spc_v3(2 * s, 0, -s));
        M = spc_mat4_mul(&T, &M);
        spc_shape_init_cube(sh, &M, NULL, 0, 0, &err);
        sh->flip_normals = true;
        sh->bsdf = tu_diffuse(sc, 0.6);
        tu_area(sc, sh, 0, 0.5);
        tu_camera(sc, spc_v3(2.2 * s, 0.1 * s, -s), spc_v3(1.5 * s, -0.3 * s, -0.2 * s), spc_v3(0, 1, 0), 100, 8, 8);
        sc->camera.near_clip = 1e-4 * s;
        sc = finalize(sc);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_film *f = tu_render(sc, "bdpt", 128, 2, 3);
        CHECK(f != NULL);
        if (f)
            check_mean(f, 0.5 / (1.0 - 0.6), 3.5);
        spc_film_destroy(f);
        spc_scene_destroy(sc);
    }
}

/* L = (a / pi) (I / r^2) / (1 - a) on every wall point of the sphere. */
TEST(point_light_in_sphere)
{
    spc_scene *sc = spc_scene_create();
    double r = 2.0, a = 0.5, I = 3.0;
    spc_shape *sh = sphere(sc, spc_v3(0, 0, 0), r, tu_diffuse(sc, a));
    sh->flip_normals = true;
    spc_emitter *e = spc_scene_new_emitter(sc);
    e->type = SPC_EMITTER_POINT;
    e->intensity = spc_rgb1(I);
    e->position = spc_v3(0, 0, 0);
    tu_camera(sc, spc_v3(0, 0, 0.5), spc_v3(0, 1, 0.5), spc_v3(0, 0, 1), 90, 8, 8);
    sc = finalize(sc);
    CHECK(sc != NULL);
    spc_film *f = sc ? tu_render(sc, "bdpt", 256, 2, 4) : NULL;
    CHECK(f != NULL);
    if (f)
        check_mean(f, (a / SPC_PI) * (I / (r * r)) / (1.0 - a), 3.5);
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* A glass slab seen at normal incidence by an orthographic camera in front of a uniform emitter:
 * L = Le (1 - R) / (1 + R). The orthographic camera cannot be joined to: no t = 1 strategy. */
TEST(glass_slab_orthographic)
{
    double eta = 1.5, Le = 2.0;
    double R = spc_sqr((eta - 1) / (eta + 1));
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *slab = spc_scene_new_shape(sc);
    spc_mat4 M = spc_mat4_scale(spc_v3(10, 10, 0.2));
    spc_shape_init_cube(slab, &M, NULL, 0, 0, &err);
    slab->bsdf = glass(sc, eta);
    spc_shape *light = rect(sc, 30, 30, 0, 0, spc_v3(0, 0, -3), tu_diffuse(sc, 0.0));
    tu_area(sc, light, 1, Le);
    sc->camera.type = SPC_CAMERA_ORTHOGRAPHIC;
    spc_mat4 V;
    spc_mat4_lookat(spc_v3(0, 0, 5), spc_v3(0, 0, 0), spc_v3(0, 1, 0), &V);
    spc_mat4 Sc = spc_mat4_scale(spc_v3(0.5, 0.5, 1));
    sc->camera.to_world = spc_mat4_mul(&V, &Sc);
    sc->film.width = sc->film.height = 8;
    sc->film.rfilter = SPC_RFILTER_BOX;
    sc->film.filter_radius = 0.5;
    sc = finalize(sc);
    CHECK(sc != NULL);
    spc_film *f = sc ? tu_render(sc, "bdpt", 512, 2, 5) : NULL;
    CHECK(f != NULL);
    if (f)
        check_mean(f, Le * (1 - R) / (1 + R), 3.5);
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* ---- bdpt against path ---- */

/* A bdpt film b against a path-traced film p of the same scene: both rendered, 99% of the pixels
 * passing the z-test, and the image means agreeing; both films are destroyed. */
static void check_against_path(spc_film *b, spc_film *p, const char *what)
{
    CHECK(b && p);
    if (b && p) {
        CHECK(ztest(b, p, 0.99, what) >= 0.99);
        check_means_agree(b, p, 4.0);
    }
    spc_film_destroy(b);
    spc_film_destroy(p);
}

static void compare_to_path(spc_scene *sc, int spp_bdpt, int spp_path, int max_depth, const char *what)
{
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *b = render_opts(sc, "bdpt", spp_bdpt, 2, 11, max_depth, -1, -1, false, false);
    spc_film *p = render_opts(sc, "path", spp_path, 2, 12, max_depth, -1, -1, false, false);
    check_against_path(b, p, what);
    spc_scene_destroy(sc);
}

TEST(box_glass_mirror_against_path)
{
    /* the light is twice the demo's size so that path finds the caustics of the glass sphere
     * often enough for its variance estimate to be trustworthy */
    compare_to_path(cornell_box(BOX_SPHERES, 24, 2.0), 256, 2048, -1, "box with glass and mirror spheres");
}

TEST(caustic_against_path)
{
    compare_to_path(caustic_scene(24), 256, 4096, -1, "caustic");
}

TEST(point_light_against_path)
{
    compare_to_path(cornell_box(BOX_POINT, 24, 1.0), 128, 1024, -1, "point light box");
}

TEST(shading_normals_against_path)
{
    compare_to_path(box_smooth_meshes(24), 256, 2048, -1, "smooth-shaded mesh spheres");
}

TEST(environment_against_path)
{
    compare_to_path(sky_scene(24, false), 128, 1024, -1, "constant environment, glass sphere");
    compare_to_path(sky_scene(24, true), 128, 1024, -1, "environment map, glass sphere");
}

TEST(directional_and_spot_against_path)
{
    compare_to_path(delta_lights_scene(24), 128, 1024, -1, "directional and spot lights");
}

TEST(normal_maps_against_path)
{
    compare_to_path(normal_mapped_scene(24), 256, 1024, -1, "normal-mapped floor and wall");
}

/* K light subpaths per camera sample, the extra ones for light tracing only: MIS counts t = 1 K
 * times (its camera density divided by K in every weight), so every path's weights still sum to
 * one and the image agrees with path's. A count that differs between the weights of t = 1 and of
 * the other strategies biases the image (made by hand: t = 1's own weight counting K and the
 * others' 1, the box's image mean 35 standard errors below path's). */
static void light_paths_against_path(spc_scene *sc, int k, int spp_bdpt, int spp_path, const char *what)
{
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp_bdpt;
    o.threads = 2;
    o.seed = 13;
    o.integrator = "bdpt";
    o.max_depth = -1;
    o.bdpt_light_paths = k;
    spc_film *b = NULL;
    spc_error err;
    spc_render_stats st;
    CHECK(spc_render(sc, &o, &b, &st, &err) == SPC_OK);
    spc_film *p = render_opts(sc, "path", spp_path, 2, 14, -1, -1, -1, false, false);
    check_against_path(b, p, what);
    spc_scene_destroy(sc);
}

/* The weighted light-tracing films' share of the image at K light subpaths per camera sample:
 * with t = 1 counted K times MIS hands it more of the paths it samples well (the caustic seen
 * directly). A count of one for every strategy stays unbiased (the weights still sum to one, the
 * test above cannot see it) but leaves the share where it is at K = 1 (made by hand: 0.028 at
 * K = 4 against 0.029 at 1; counted right 0.21). Also: at K the weighted films still sum to the
 * image. */
static double light_tracing_share(const spc_scene *sc, int k, int res, double *sum_err)
{
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 64;
    o.threads = 2;
    o.seed = 17;
    o.integrator = "bdpt";
    o.max_depth = 6;
    o.strategy_images = true;
    o.bdpt_light_paths = k;
    spc_film *full = NULL;
    spc_error err;
    if (spc_render(sc, &o, &full, NULL, &err) != SPC_OK || !full)
        return -1.0;
    size_t np = (size_t)res * res * 3;
    double *sum = calloc(np, sizeof(double));
    double t1 = 0.0, img = 0.0, diff = 0.0;
    for (int i = 0; sum && i < spc_film_strategy_count(full); ++i) {
        int s = -1, t = -1;
        bool w = false;
        const spc_film *f = spc_film_strategy(full, i, &s, &t, &w);
        if (!f || !w)
            continue;
        for (size_t j = 0; j < np; ++j) {
            sum[j] += f->rgb[j];
            if (t == 1)
                t1 += f->rgb[j];
        }
    }
    for (size_t j = 0; sum && j < np; ++j) {
        img += full->rgb[j];
        diff = fmax(diff, fabs(sum[j] - full->rgb[j]) / (fabs(full->rgb[j]) + 1e-3));
    }
    *sum_err = sum ? diff : INFINITY;
    free(sum);
    spc_film_destroy(full);
    return img > 0.0 ? t1 / img : -1.0;
}

TEST(light_paths_raise_light_tracing_share)
{
    spc_scene *sc = caustic_scene(16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    double e1, e4;
    double s1 = light_tracing_share(sc, 1, 16, &e1), s4 = light_tracing_share(sc, 4, 16, &e4);
    printf("  caustic, light tracing's share of the image: %.4f with 1 light subpath, %.4f with 4 (films sum to the "
           "image within %.2g, %.2g)\n",
           s1, s4, e1, e4);
    CHECK(s1 > 0.0 && s4 > 0.0);
    CHECK_MSG(s4 > 2.0 * s1, "share %.4f at 4 subpaths, %.4f at 1", s4, s1);
    CHECK(e1 < 1e-4 && e4 < 1e-4);
    spc_scene_destroy(sc);
}

TEST(light_paths_per_sample_against_path)
{
    light_paths_against_path(caustic_scene(24), 4, 128, 4096, "caustic, 4 light subpaths per sample");
    light_paths_against_path(cornell_box(BOX_SPHERES, 24, 2.0), 3, 128, 2048,
                             "box with glass and mirror spheres, 3 light subpaths per sample");
}

/* Both heuristics weight every path to a total of one: the images agree. */
TEST(balance_heuristic_against_power)
{
    spc_scene *sc = cornell_box(BOX_SPHERES, 16, 2.0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *a = render_opts(sc, "bdpt", 256, 2, 21, -1, -1, -1, false, true);
    spc_film *b = render_opts(sc, "bdpt", 256, 2, 22, -1, -1, -1, false, false);
    CHECK(a && b);
    if (a && b) {
        CHECK(ztest(a, b, 0.99, "balance vs power") >= 0.99);
        check_means_agree(a, b, 4.0);
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_scene_destroy(sc);
}

/* ---- ptracer: light tracing alone ---- */

/* ptracer against path on scenes without smooth surfaces seen by the camera (which light tracing
 * cannot reach): the plain box (an area light seen directly: (1, 1)), the point-light box, the
 * directional and spot lights, and path's depth limits and hide_emitters. */
static void ptracer_vs_path(spc_scene *sc, int spp_pt, int spp_path, int max_depth, bool hide, const char *what)
{
    CHECK(sc != NULL);
    if (!sc)
        return;
    sc->integrator.hide_emitters = hide;
    spc_film *a = render_opts(sc, "ptracer", spp_pt, 2, 31, max_depth, -1, -1, false, false);
    spc_film *p = render_opts(sc, "path", spp_path, 2, 32, max_depth, -1, -1, false, false);
    CHECK(a && p);
    if (a && p) {
        CHECK(ztest(a, p, 0.99, what) >= 0.99);
        check_means_agree(a, p, 4.0);
    }
    spc_film_destroy(a);
    spc_film_destroy(p);
    spc_scene_destroy(sc);
}

TEST(ptracer_against_path)
{
    ptracer_vs_path(cornell_box(BOX_PLAIN, 16, 2.0), 512, 512, -1, false, "ptracer: box");
    ptracer_vs_path(cornell_box(BOX_PLAIN, 16, 2.0), 256, 256, 1, false, "ptracer: box, max_depth 1");
    ptracer_vs_path(cornell_box(BOX_PLAIN, 16, 2.0), 256, 256, 3, true, "ptracer: box, max_depth 3, emitters hidden");
    ptracer_vs_path(cornell_box(BOX_POINT, 16, 1.0), 256, 512, -1, false, "ptracer: point light box");
    ptracer_vs_path(delta_lights_scene(16), 256, 512, -1, false, "ptracer: directional and spot lights");
    ptracer_vs_path(normal_mapped_scene(16), 256, 512, -1, false, "ptracer: normal-mapped floor and wall");
}

/* A light at infinity seen directly (max_depth 1: only emitters), which ptracer splats from
 * directions sampled toward it from the pinhole: a constant sky and an environment map. */
TEST(ptracer_sees_the_sky)
{
    ptracer_vs_path(sky_scene(16, false), 256, 256, 1, false, "ptracer: constant sky seen directly");
    ptracer_vs_path(sky_scene(16, true), 2048, 256, 1, false, "ptracer: environment map seen directly");
}

/* ---- strategies ---- */

/* With the same seed every strategy sees the same subpaths, so the weighted single-strategy
 * images of all (s, t) with s + t - 1 <= max_depth add up to the full image. */
TEST(weighted_strategies_sum_to_full_image)
{
    spc_scene *sc = cornell_box(BOX_SPHERES, 16, 1.0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const int max_depth = 4, spp = 16;
    spc_film *full = render_opts(sc, "bdpt", spp, 2, 31, max_depth, -1, -1, false, false);
    CHECK(full != NULL);
    size_t n = (size_t)16 * 16 * 3;
    double *sum = calloc(n, sizeof(double));
    int nonzero = 0;
    for (int k = 1; k <= max_depth; ++k)
        for (int s = 0; s <= k + 1; ++s) {
            int t = k + 1 - s;
            if (t < 1)
                continue;
            spc_film *f = render_opts(sc, "bdpt", spp, 2, 31, max_depth, s, t, true, false);
            CHECK(f != NULL);
            if (!f)
                continue;
            double m = 0.0;
            for (size_t i = 0; i < n; ++i) {
                sum[i] += f->rgb[i];
                m += f->rgb[i];
            }
            nonzero += m > 0.0;
            spc_film_destroy(f);
        }
    CHECK_MSG(nonzero == 14, "%d of the 14 strategies (s, t) with t >= 1 contributed", nonzero);
    if (full) {
        double worst = 0.0;
        for (size_t i = 0; i < n; ++i) {
            double d = fabs(sum[i] - full->rgb[i]) / (fabs(full->rgb[i]) + 1e-6);
            worst = d > worst ? d : worst;
        }
        CHECK_MSG(worst < 1e-4, "largest relative difference %.3g", worst);
    }
    free(sum);
    spc_film_destroy(full);
    spc_scene_destroy(sc);
}

/* Two films hold the same bits (mean and variance). */
static bool same_film(const spc_film *a, const spc_film *b)
{
    size_t n = 3 * (size_t)a->width * (size_t)a->height * sizeof(float);
    return a->width == b->width && a->height == b->height && memcmp(a->rgb, b->rgb, n) == 0 &&
           memcmp(a->var, b->var, n) == 0;
}

/* strategy_images: one render fills a weighted and an unweighted film for every strategy of every
 * length up to max_depth. Each equals the single-strategy render of the same seed bit for bit (so
 * each unweighted one is that strategy's own estimator, checked against the length images above),
 * the weighted ones sum to the image, and the image itself is the one rendered without them. */
TEST(strategy_images_in_one_render)
{
    spc_scene *sc = cornell_box(BOX_SPHERES, 16, 1.0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const int max_depth = 4, spp = 16;
    const uint64_t seed = 37;
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp;
    o.threads = 2;
    o.seed = seed;
    o.integrator = "bdpt";
    o.max_depth = max_depth;
    o.strategy_images = true;
    spc_film *full = NULL;
    spc_error err;
    CHECK(spc_render(sc, &o, &full, NULL, &err) == SPC_OK && full);
    spc_film *plain = render_opts(sc, "bdpt", spp, 1, seed, max_depth, -1, -1, false, false);
    CHECK(plain && full && same_film(full, plain));
    int expected = 0;
    for (int k = 1; k <= max_depth; ++k)
        expected += 2 * (k + 1); /* s = 0 .. k, weighted and not */
    int n = spc_film_strategy_count(full);
    CHECK_MSG(n == expected, "%d strategy films, expected %d", n, expected);
    size_t np = (size_t)16 * 16 * 3;
    double *sum = calloc(np, sizeof(double));
    int seen[SPC_STRATEGY_IMAGES_MAX_DEPTH + 2][SPC_STRATEGY_IMAGES_MAX_DEPTH + 2][2];
    memset(seen, 0, sizeof seen);
    int lit_t1 = 0, lit_st = 0, identical = 0;
    for (int i = 0; full && i < n; ++i) {
        int s = -1, t = -1;
        bool w = false;
        const spc_film *f = spc_film_strategy(full, i, &s, &t, &w);
        CHECK(f != NULL && s >= 0 && t >= 1 && s + t - 1 <= max_depth);
        if (!f || s < 0 || t < 1 || s + t - 1 > max_depth)
            continue;
        seen[s][t][w]++;
        double m = 0.0;
        for (size_t j = 0; j < np; ++j) {
            if (w)
                sum[j] += f->rgb[j];
            m += f->rgb[j];
        }
        if (w && m > 0.0) {
            lit_t1 += t == 1;
            lit_st += s >= 2 && t >= 2;
        }
        spc_film *one = render_opts(sc, "bdpt", spp, 2, seed, max_depth, s, t, w, false);
        CHECK(one != NULL);
        if (one) {
            bool same = same_film(f, one);
            identical += same;
            CHECK_MSG(same, "strategy (%d, %d) %s differs from its single-strategy render", s, t,
                      w ? "weighted" : "unweighted");
        }
        spc_film_destroy(one);
    }
    printf("  %d of %d strategy films equal their single-strategy renders\n", identical, n);
    for (int k = 1; k <= max_depth; ++k)
        for (int s = 0; s <= k; ++s)
            CHECK_MSG(seen[s][k + 1 - s][0] == 1 && seen[s][k + 1 - s][1] == 1, "strategy (%d, %d) not there once", s,
                      k + 1 - s);
    /* light tracing splats and general connections both reached their films */
    CHECK(lit_t1 > 0 && lit_st > 0);
    if (full) {
        double worst = 0.0;
        for (size_t j = 0; j < np; ++j) {
            double d = fabs(sum[j] - full->rgb[j]) / (fabs(full->rgb[j]) + 1e-6);
            worst = d > worst ? d : worst;
        }
        CHECK_MSG(worst < 1e-4, "weighted strategy films: largest relative difference from the image %.3g", worst);
    }
    free(sum);
    spc_film_destroy(plain);
    spc_film_destroy(full);

    /* refused: another integrator, no depth limit, with a single strategy, with a checkpoint */
    spc_film *f = NULL;
    o.integrator = "path";
    CHECK(spc_render(sc, &o, &f, NULL, &err) == SPC_ERR_VALUE && !f);
    o.integrator = "bdpt";
    o.max_depth = -1;
    CHECK(spc_render(sc, &o, &f, NULL, &err) == SPC_ERR_VALUE && !f);
    o.max_depth = max_depth;
    o.strategy_s = 1;
    o.strategy_t = 2;
    CHECK(spc_render(sc, &o, &f, NULL, &err) == SPC_ERR_VALUE && !f);
    o.strategy_s = o.strategy_t = -1;
    o.checkpoint_path = "/nonexistent/never-written.ckpt";
    CHECK(spc_render(sc, &o, &f, NULL, &err) == SPC_ERR_VALUE && !f);
    CHECK(strstr(err.msg, "checkpoint") != NULL);
    spc_scene_destroy(sc);
}

/* In a diffuse scene lit by an area light every strategy (s, t) with t >= 1 samples every path
 * of length k = s + t - 1, so each unweighted strategy alone estimates the length-k image, which
 * is the sum of the weighted strategies of that length (here rendered with other seeds). The
 * scene has no corners, where joining two surface vertices (s, t >= 2) has infinite variance,
 * and no background, where sparse contributions make per-pixel variance estimates unreliable. */
TEST(unweighted_strategies_estimate_length_images)
{
    spc_scene *sc = inside_sphere_scene(16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    for (int k = 2; k <= 3; ++k) {
        /* the length-k image: the weighted strategies of length k, each rendered with its own
         * seed so that the variances of their means add */
        size_t n = (size_t)16 * 16 * 3;
        spc_film *ref = NULL;
        for (int s = 0; s <= k + 1; ++s) {
            int t = k + 1 - s;
            if (t < 1)
                continue;
            spc_film *f = render_opts(sc, "bdpt", 1024, 2, 40 + 10 * k + s, k, s, t, true, false);
            CHECK(f != NULL);
            if (!f)
                continue;
            if (!ref) {
                ref = f;
                continue;
            }
            for (size_t i = 0; i < n; ++i) {
                ref->rgb[i] += f->rgb[i];
                ref->var[i] += f->var[i];
            }
            spc_film_destroy(f);
        }
        CHECK(ref != NULL);
        for (int s = 0; s <= k + 1 && ref; ++s) {
            int t = k + 1 - s;
            if (t < 1)
                continue;
            int spp = (s == 0 || t == 1) ? 2048 : 512;
            spc_film *f = render_opts(sc, "bdpt", spp, 2, 90 + 10 * k + s, k, s, t, false, false);
            CHECK(f != NULL);
            if (!f)
                continue;
            char what[80];
            snprintf(what, sizeof what, "unweighted (s=%d, t=%d) vs length-%d image", s, t, k);
            CHECK_MSG(ztest_lit(f, ref, 0.05, what) >= 0.99, "%s", what);
            check_means_agree(f, ref, 4.0);
            spc_film_destroy(f);
        }
        spc_film_destroy(ref);
    }
    spc_scene_destroy(sc);
}

/* Light tracing (2, 1) against next-event estimation (1, 2) for direct light, unweighted, for
 * every pixel filter and with a crop window: the camera importance and its normalization by the
 * filter and the number of light paths per pass. */
TEST(light_tracing_matches_nee_for_every_filter)
{
    struct {
        spc_rfilter_type type;
        double radius, stddev;
        bool crop;
        const char *name;
    } cases[4] = {{SPC_RFILTER_BOX, 0.5, 0.0, false, "box"},
                  {SPC_RFILTER_TENT, 1.0, 0.0, false, "tent"},
                  {SPC_RFILTER_GAUSSIAN, 2.0, 0.5, false, "gaussian"},
                  {SPC_RFILTER_TENT, 1.0, 0.0, true, "tent, crop window"}};
    for (int c = 0; c < 4; ++c) {
        /* a narrower view, all inside the box: no pixel straddles the box's edge */
        spc_scene *sc = cornell_box_fov(BOX_PLAIN, 16, 1.5, 28.0);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        sc->film.rfilter = cases[c].type;
        sc->film.filter_radius = cases[c].radius;
        sc->film.filter_stddev = cases[c].stddev;
        if (cases[c].crop) {
            sc->film.width = sc->film.height = 24;
            sc->film.crop_x = 5;
            sc->film.crop_y = 3;
            sc->film.crop_w = 16;
            sc->film.crop_h = 12;
        }
        spc_film *lt = render_opts(sc, "bdpt", 512, 2, 60 + c, 2, 2, 1, false, false);
        spc_film *ne = render_opts(sc, "bdpt", 256, 2, 70 + c, 2, 1, 2, false, false);
        CHECK(lt && ne);
        if (lt && ne) {
            CHECK_MSG(ztest(lt, ne, 0.99, cases[c].name) >= 0.99, "%s", cases[c].name);
            check_means_agree(lt, ne, 4.0);
            double m_lt, m_ne, se;
            tu_image_mean(lt, 1, &m_lt, &se);
            tu_image_mean(ne, 1, &m_ne, &se);
            CHECK(m_lt > 0.0 && m_ne > 0.0);
        }
        spc_film_destroy(lt);
        spc_film_destroy(ne);
        spc_scene_destroy(sc);
    }
}

/* ---- determinism ---- */

/* ---- specular NEE inside bdpt ---- */

static spc_film *render_snee(const spc_scene *sc, const char *integrator, const char *snee, int spp, uint64_t seed)
{
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp;
    o.threads = 2;
    o.seed = seed;
    o.integrator = integrator;
    o.specular_nee = snee;
    spc_film *f = NULL;
    spc_error err;
    spc_render_stats st;
    if (spc_render(sc, &o, &f, &st, &err) != SPC_OK) {
        spc_film_destroy(f);
        return NULL;
    }
    return f;
}

/* The largest per-pixel relative variance of the mean, var / (mean^2 + 0.01) over channels, and
 * its share of the sum over pixels: where a render's heavy tail sits. */
static double worst_rel_var(const spc_film *f, double *share)
{
    double worst = 0.0, sum = 0.0;
    for (int i = 0; i < f->width * f->height; ++i) {
        double r = 0.0;
        for (int c = 0; c < 3; ++c)
            r += f->var[3 * i + c] / ((double)f->rgb[3 * i + c] * f->rgb[3 * i + c] + 0.01);
        sum += r;
        worst = r > worst ? r : worst;
    }
    *share = sum > 0.0 ? worst / sum : 0.0;
    return worst;
}

/* The glass ball's outliers: the paths that show the light and its caustic through the ball
 * (camera - glass - light, camera - glass - glass - floor - glass - glass - light) have one BDPT
 * strategy, s = 0, which finds the small light by chance; without specular NEE three pixels at
 * the ball's centre and its reflection of the light held 70% of bdpt's variance. Specular NEE
 * from the camera and from the camera vertices seen through glass with no two adjacent non-delta
 * vertices before them (snee_receiver in bdpt.c; the floor seen through the ball, and the floor
 * seen from there through the ball again) adds a strategy for them, weighed against s = 0 by the
 * path integrator's split. The image must not change (z-test and means against bdpt without it
 * and against path, with and without the pinhole's chains), and the heavy pixels must go: the
 * worst pixel's variance falls to less than half and holds less than a quarter of the image's. */
TEST(specular_nee_tames_s0_only_paths)
{
    spc_scene *sc = tu_load("scenes/caustic_sphere.xml", 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *plain = render_snee(sc, "bdpt", "none", 1024, 51);
    spc_film *with = render_snee(sc, "bdpt", "angular:camera", 1024, 52);
    spc_film *path = render_snee(sc, "path", "", 4096, 53);
    spc_film *receivers = render_snee(sc, "bdpt", "angular", 1024, 54);
    CHECK(plain && with && path && receivers);
    if (receivers && plain && path) {
        CHECK(ztest(receivers, plain, 0.99, "bdpt with specular NEE at its receivers vs without") >= 0.99);
        check_means_agree(receivers, plain, 4.0);
        CHECK(ztest(receivers, path, 0.99, "bdpt with specular NEE at its receivers vs path") >= 0.99);
        check_means_agree(receivers, path, 4.0);
    }
    spc_film_destroy(receivers);
    if (plain && with && path) {
        CHECK(ztest(with, plain, 0.99, "bdpt with specular NEE vs without") >= 0.99);
        check_means_agree(with, plain, 4.0);
        CHECK(ztest(with, path, 0.99, "bdpt with specular NEE vs path") >= 0.99);
        check_means_agree(with, path, 4.0);
        double sp, sw;
        double wp = worst_rel_var(plain, &sp), ww = worst_rel_var(with, &sw);
        printf("  worst pixel's relative variance: %.3g (%.0f%% of the image's) without specular NEE, %.3g (%.0f%%) "
               "with\n", wp, 100.0 * sp, ww, 100.0 * sw);
        CHECK_MSG(ww < 0.5 * wp, "specular NEE left the worst pixel's variance at %.3g (without: %.3g)", ww, wp);
        CHECK_MSG(sw < 0.25, "the worst pixel holds %.0f%% of the variance", 100.0 * sw);
    }
    spc_film_destroy(plain);
    spc_film_destroy(with);
    spc_film_destroy(path);
    spc_scene_destroy(sc);
}

/* The setting that covers the light seen in and through the ball at equal time (the pinhole's
 * chains on one camera sample in ten) and the corner receivers (corner_receiver in bdpt.c: specular
 * NEE where a camera vertex's non-delta predecessor is very close, in the room's corners, its
 * sample and the two BDPT strategies of the same paths splitting them by the path integrator's
 * weights): the image must not change against plain bdpt and path, and no pixel may hold a quarter
 * of the variance. */
TEST(specular_nee_camera_share_and_corners)
{
    spc_scene *sc = tu_load("scenes/caustic_sphere.xml", 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *plain = render_snee(sc, "bdpt", "none", 2048, 61);
    spc_film *with = render_snee(sc, "bdpt", "angular:camera=0.1", 1024, 62);
    spc_film *path = render_snee(sc, "path", "", 2048, 63);
    CHECK(plain && with && path);
    if (plain && with && path) {
        CHECK(ztest(with, plain, 0.99, "bdpt angular:camera=0.1 vs plain bdpt") >= 0.99);
        check_means_agree(with, plain, 4.0);
        CHECK(ztest(with, path, 0.99, "bdpt angular:camera=0.1 vs path") >= 0.99);
        check_means_agree(with, path, 4.0);
        double sw, wv = worst_rel_var(with, &sw);
        printf("  worst pixel's relative variance %.3g, %.0f%% of the image's\n", wv, 100.0 * sw);
        CHECK_MSG(sw < 0.25, "the worst pixel holds %.0f%% of the variance", 100.0 * sw);
    }
    spc_film_destroy(plain);
    spc_film_destroy(with);
    spc_film_destroy(path);
    spc_scene_destroy(sc);
}

/* The corner path of the glass-ball caustic (32x32, pixel (18, 14): camera - glass - glass - floor
 * - wall - glass - light, floor and wall 0.014 apart): s = 0 and the connection across the corner
 * were its only strategies, and s = 0 found it about once in 260,000 samples at 300 times the
 * pixel's value. With corner receivers (corner_receiver in bdpt.c) specular NEE takes it: over four
 * seeds of 65,536 samples the pixel's relative standard error stays below 0.004 (measured 0.0020 to
 * 0.0025; without corner receivers seed 2 caught the path and read 0.0083). */
TEST(corner_receivers_take_the_corner_path)
{
    spc_scene *sc = tu_load("scenes/caustic_sphere.xml", 32);
    CHECK(sc != NULL);
    if (!sc)
        return;
    sc->film.crop_x = 18;
    sc->film.crop_y = 14;
    sc->film.crop_w = sc->film.crop_h = 1;
    double worst = 0.0;
    for (uint64_t seed = 1; seed <= 4; ++seed) {
        spc_film *f = render_snee(sc, "bdpt", "angular:camera=0.1", 65536, seed);
        CHECK(f != NULL);
        if (!f)
            continue;
        double m = 0.0, v = 0.0;
        for (int c = 0; c < 3; ++c) {
            m += f->rgb[c] / 3.0;
            v += f->var[c] / 3.0;
        }
        double rel = m > 0.0 ? sqrt(v) / m : INFINITY;
        printf("  seed %d: pixel (18, 14) %.4f, relative standard error %.4f\n", (int)seed, m, rel);
        worst = rel > worst ? rel : worst;
        spc_film_destroy(f);
    }
    CHECK_MSG(worst < 0.004, "the corner pixel's relative standard error reached %.4f", worst);
    spc_scene_destroy(sc);
}

/* Specular NEE at the surfaces the camera sees directly ("direct"; direct_receiver in bdpt.c): the
 * caustic seen directly (camera - floor - glass - glass - light) gets a third strategy besides
 * s = 0 and light tracing, weighed against both (light tracing's density through the
 * params.alt_ratio of specular_nee.h). Light tracing's samples of those paths find their weight by
 * retracing the chain from the floor, whose light point lands up to 1e-3 of the light's size away
 * after the focusing ball: with the retrace held to rounding (the tolerance of paths sampled from the
 * floor), most light-traced caustic samples lost their weight and the caustic's pixels read 25-45%
 * low (32x32: z -11 to -16, image mean 2.4% low). The image must equal plain bdpt's (z-test and
 * image means) with the query at every floor point and at one in four. */
TEST(direct_receivers_weigh_light_tracing)
{
    spc_scene *sc = tu_load("scenes/caustic_sphere.xml", 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *plain = render_snee(sc, "bdpt", "angular:camera=0.1", 4096, 71);
    spc_film *all = render_snee(sc, "bdpt", "angular:camera=0.1,direct", 1024, 72);
    spc_film *share = render_snee(sc, "bdpt", "angular:camera=0.1,direct=0.25", 2048, 73);
    spc_film *same_seed = render_snee(sc, "bdpt", "angular:camera=0.1", 1024, 72);
    CHECK(plain && all && share && same_seed);
    if (plain && all && share && same_seed) {
        CHECK(ztest(all, plain, 0.99, "bdpt direct vs plain bdpt") >= 0.99);
        check_means_agree(all, plain, 4.0);
        CHECK(ztest(share, plain, 0.99, "bdpt direct=0.25 vs plain bdpt") >= 0.99);
        check_means_agree(share, plain, 4.0);
        CHECK_MSG(!same_film(all, same_seed), "direct rendered the plain image: the query did not run");
    }
    spc_film_destroy(plain);
    spc_film_destroy(all);
    spc_film_destroy(share);
    spc_film_destroy(same_seed);
    spc_scene_destroy(sc);
}

/* The mean and the variance of the mean of a film's pixels, summed over pixels, averaged over
 * channels. */
static void pixels_of(const spc_film *f, double *m, double *v)
{
    *m = *v = 0.0;
    for (int i = 0; i < 3 * f->width * f->height; ++i) {
        *m += f->rgb[i] / 3.0;
        *v += f->var[i] / 3.0;
    }
}

/* Receivers seen by a reflection off a glass ball (reflected_receiver in bdpt.c): pixels (15..17,
 * 17) of the glass-ball caustic at 32x32 see, in the ball's rim, the floor next to the ball where its
 * caustic lies, and specular NEE's light point there made most of their variance. With reflected=4
 * (the default) each query there draws four light points, counted a quarter each and weighed so in
 * the MIS against s = 0: over four seeds the three pixels' variance at equal samples must fall
 * below 0.75 of reflected=1's (measured 0.53, per seed 0.41-0.65; a seed's variance estimate
 * scatters by about 18%, so equal variances would read 1 +- 0.13), the sums of their means agreeing
 * within 4 standard errors. */
TEST(reflected_receivers_take_more_light_points)
{
    spc_scene *sc = tu_load("scenes/caustic_sphere.xml", 32);
    CHECK(sc != NULL);
    if (!sc)
        return;
    sc->film.crop_x = 15;
    sc->film.crop_y = 17;
    sc->film.crop_w = 3;
    sc->film.crop_h = 1;
    double m[2] = {0.0, 0.0}, v[2] = {0.0, 0.0};
    const char *setting[2] = {"angular:camera=0.03,reflected=1", "angular:camera=0.03"};
    for (uint64_t seed = 1; seed <= 4; ++seed) {
        for (int i = 0; i < 2; ++i) {
            spc_film *f = render_snee(sc, "bdpt", setting[i], 16384, 80 + seed);
            CHECK(f != NULL);
            if (!f)
                continue;
            double fm, fv;
            pixels_of(f, &fm, &fv);
            m[i] += fm / 4.0;
            v[i] += fv / 16.0;
            spc_film_destroy(f);
        }
    }
    double z = (m[1] - m[0]) / sqrt(v[0] + v[1]);
    printf("  pixels (15..17, 17): reflected=1 %.4f (variance of the mean %.3g), reflected=4 %.4f (%.3g): "
           "variance ratio %.2f, z %.2f\n", m[0], v[0], m[1], v[1], v[1] / v[0], z);
    CHECK_MSG(v[1] < 0.75 * v[0], "reflected=4 left the pixels' variance at %.2f of reflected=1's", v[1] / v[0]);
    CHECK_MSG(fabs(z) < 4.0, "the two means differ by %.2f standard errors", z);
    spc_scene_destroy(sc);
}

/* The outlier of the glass-ball caustic at 32x32, seed 6: one s = 0 sample of camera - ball - ball -
 * floor - ball - ball - ball - floor - ball - ball - light in pixel (18, 9), after 1,666 samples 0.514
 * where the reference is 0.425 (29% of that seed's error in the bench). Specular NEE at the second
 * floor vertex (a later receiver, receiver_params) with four light points leaves s = 0 a small
 * weight there: 0.429. The same pixel, the same samples (the camera subpath's streams are the
 * pixel's, whatever the window). */
TEST(later_receivers_tame_the_caustic_outlier)
{
    spc_scene *sc = tu_load("scenes/caustic_sphere.xml", 32);
    CHECK(sc != NULL);
    if (!sc)
        return;
    sc->film.crop_x = 18;
    sc->film.crop_y = 9;
    sc->film.crop_w = 1;
    sc->film.crop_h = 1;
    spc_film *f = render_opts(sc, "bdpt", 1666, 1, 6, -1, -1, -1, false, false);
    CHECK(f != NULL);
    if (f) {
        double m = 0.0;
        for (int c = 0; c < 3; ++c)
            m += f->rgb[c] / 3.0;
        printf("  pixel (18, 9), seed 6, 1666 spp: %.4f (reference 0.425)\n", m);
        CHECK_MSG(m > 0.38 && m < 0.47, "pixel (18, 9) at %.4f", m);
    }
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* ---- emission aimed at the casters (bdpt.h, spc_bdpt_aim) ---- */

/* A bdpt render of sc with the aim's shares `aim` and `aim_camera` (0: the default, -1: off), and its
 * stats. */
static spc_film *render_aim2(const spc_scene *sc, double aim, double aim_camera, int spp, uint64_t seed,
                             bool strategies, spc_render_stats *st)
{
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp;
    o.threads = 2;
    o.seed = seed;
    o.integrator = "bdpt";
    o.max_depth = strategies ? 6 : -1;
    o.strategy_images = strategies;
    o.bdpt_aim = aim;
    o.bdpt_aim_camera = aim_camera;
    spc_film *f = NULL;
    spc_error err;
    if (spc_render(sc, &o, &f, st, &err) != SPC_OK) {
        char buf[1200];
        spc_error_format(&err, buf, sizeof buf);
        printf("  render failed: %s\n", buf);
        spc_film_destroy(f);
        return NULL;
    }
    return f;
}

/* render_aim2 with the camera's share by default. */
static spc_film *render_aim(const spc_scene *sc, double aim, int spp, uint64_t seed, bool strategies,
                            spc_render_stats *st)
{
    return render_aim2(sc, aim, 0.0, spp, seed, strategies, st);
}

/* The unweighted film of strategy (s, t): the sums over pixels and channels of its values and of its
 * variances of the mean. */
static bool strategy_film_sums(const spc_film *full, int s_want, int t_want, double *sum, double *var)
{
    size_t np = (size_t)full->width * full->height * 3;
    for (int i = 0; i < spc_film_strategy_count(full); ++i) {
        int s = -1, t = -1;
        bool w = true;
        const spc_film *f = spc_film_strategy(full, i, &s, &t, &w);
        if (!f || w || t != t_want || s != s_want)
            continue;
        *sum = *var = 0.0;
        for (size_t j = 0; j < np; ++j) {
            *sum += f->rgb[j];
            *var += f->var[j];
        }
        return true;
    }
    return false;
}

/* The unweighted light-tracing film of light - glass - glass - diffuse vertex - camera (s = 4,
 * t = 1): the sums over pixels and channels of its values and of its variances of the mean. */
static bool caustic_light_tracing(const spc_film *full, double *sum, double *var)
{
    size_t np = (size_t)full->width * full->height * 3;
    for (int i = 0; i < spc_film_strategy_count(full); ++i) {
        int s = -1, t = -1;
        bool w = true;
        const spc_film *f = spc_film_strategy(full, i, &s, &t, &w);
        if (!f || w || t != 1 || s != 4)
            continue;
        *sum = *var = 0.0;
        for (size_t j = 0; j < np; ++j) {
            *sum += f->rgb[j];
            *var += f->var[j];
        }
        return true;
    }
    return false;
}

/* With the aim about a quarter of the light subpaths pass through the glass ball instead of 2%, so
 * light tracing's own estimate of the caustic (s = 4, t = 1, unweighted) has several times less
 * variance at the same samples (3.2x here), and the same mean. With the walks left without the aim
 * (made by hand: the stats still report it) the variances are equal, 0.001162 both. The stats
 * report the pilot's share (0 when off). */
TEST(aim_raises_light_tracing_through_glass)
{
    /* the caustic scene without its wall: the floor's light of s = 4, t = 1 comes through the ball */
    spc_scene *sc = spc_scene_create();
    rect(sc, 3, 3, -90, 0, spc_v3(0, 0, 0), twosided_diffuse(sc, 0.7, 0.7, 0.7));
    sphere(sc, spc_v3(0, 0.5, 0), 0.5, glass(sc, 1.5));
    spc_shape *l = sphere(sc, spc_v3(0.9, 2.2, 0.6), 0.2, tu_diffuse(sc, 0.0));
    spc_emitter *e = tu_area(sc, l, sc->nshapes - 1, 1.0);
    e->radiance = spc_scene_constant(sc, spc_rgb3(30, 27, 22));
    tu_camera(sc, spc_v3(0, 2.2, 3.2), spc_v3(-0.2, 0.3, 0), spc_v3(0, 1, 0), 45, 16, 16);
    sc = finalize(sc);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_render_stats st_on, st_off;
    memset(&st_on, 0, sizeof st_on);
    memset(&st_off, 0, sizeof st_off);
    spc_film *on = render_aim(sc, 0.0, 64, 31, true, &st_on);
    spc_film *off = render_aim(sc, -1.0, 64, 31, true, &st_off);
    CHECK(on && off);
    double sum_on = 0.0, var_on = 0.0, sum_off = 0.0, var_off = 0.0;
    if (on && off && caustic_light_tracing(on, &sum_on, &var_on) && caustic_light_tracing(off, &sum_off, &var_off)) {
        printf("  caustic, light tracing through the glass (s = 4, t = 1): sum %.4g, variance %.4g with the aim "
               "(share %.3f); sum %.4g, variance %.4g without\n",
               sum_on, var_on, st_on.bdpt_aim, sum_off, var_off);
        CHECK(st_on.bdpt_aim > 0.15 && st_on.bdpt_aim <= 0.25);
        CHECK(st_off.bdpt_aim == 0.0);
        CHECK(sum_on > 0.0 && sum_off > 0.0 && var_on > 0.0);
        double se = sqrt(var_on + var_off);
        CHECK_MSG(fabs(sum_on - sum_off) < 4.0 * se, "sums %.4g and %.4g differ by %.1f standard errors", sum_on,
                  sum_off, fabs(sum_on - sum_off) / se);
        CHECK_MSG(var_off > 2.0 * var_on, "variance %.4g with the aim, %.4g without", var_on, var_off);
    } else {
        CHECK_MSG(false, "no s = 4, t = 1 strategy film");
    }
    spc_film_destroy(on);
    spc_film_destroy(off);
    spc_scene_destroy(sc);
}

/* The mixture's density in the light subpath's weight and in every MIS weight: with most of the
 * emission aimed (0.9) the images still agree with path's, on the caustic (one glass cone) and on the
 * box with a glass and a mirror sphere (two cones; the light under the ceiling sees both). A weight
 * divided by the cosine density instead of the mixture's (made by hand) puts the image means 84
 * (caustic) and 141 (box) standard errors above path's. */
TEST(aimed_emission_against_path)
{
    spc_scene *scs[2] = {caustic_scene(24), cornell_box(BOX_SPHERES, 24, 2.0)};
    const char *what[2] = {"caustic, aim 0.9", "box with glass and mirror spheres, aim 0.9"};
    const int spp_path[2] = {4096, 2048};
    for (int k = 0; k < 2; ++k) {
        CHECK(scs[k] != NULL);
        if (!scs[k])
            continue;
        spc_render_stats st;
        memset(&st, 0, sizeof st);
        spc_film *b = render_aim(scs[k], 0.9, 256, 41, false, &st);
        printf("  %s: aimed share %.3f\n", what[k], st.bdpt_aim);
        CHECK(st.bdpt_aim > 0.5);
        spc_film *p = render_opts(scs[k], "path", spp_path[k], 2, 42, -1, -1, -1, false, false);
        check_against_path(b, p, what[k]);
        spc_scene_destroy(scs[k]);
    }
}

/* The pilot finds no caster where an opaque plate hides the ball from the light: no aim. */
TEST(aim_off_where_casters_hidden)
{
    spc_scene *sc = spc_scene_create();
    spc_bsdf *white = twosided_diffuse(sc, 0.7, 0.7, 0.7);
    rect(sc, 3, 3, -90, 0, spc_v3(0, 0, 0), white);
    sphere(sc, spc_v3(0, 0.5, 0), 0.5, glass(sc, 1.5));
    rect(sc, 1.5, 1.5, 90, 0, spc_v3(0, 1.5, 0), white); /* a plate between light and ball */
    spc_shape *l = sphere(sc, spc_v3(0, 2.2, 0), 0.2, tu_diffuse(sc, 0.0));
    spc_emitter *e = tu_area(sc, l, sc->nshapes - 1, 1.0);
    e->radiance = spc_scene_constant(sc, spc_rgb3(30, 27, 22));
    tu_camera(sc, spc_v3(0, 2.2, 3.2), spc_v3(0, 0.3, 0), spc_v3(0, 1, 0), 45, 8, 8);
    sc = finalize(sc);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_render_stats st;
    memset(&st, 0, sizeof st);
    spc_film *f = render_aim(sc, 0.0, 1, 51, false, &st);
    CHECK(f != NULL);
    CHECK_MSG(st.bdpt_aim == 0.0, "aimed share %.3f behind the plate", st.bdpt_aim);
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* The glass-ball caustic of scenes/caustic_sphere.xml: a small light half a unit from the wall, whose
 * bright spot the ball focuses onto the floor. */
static spc_scene *hot_spot_scene(int res)
{
    spc_scene *sc = spc_scene_create();
    spc_bsdf *white = twosided_diffuse(sc, 0.7, 0.7, 0.7);
    rect(sc, 3, 3, -90, 0, spc_v3(0, 0, 0), white);
    rect(sc, 3, 2, 0, 0, spc_v3(0, 2, -1.5), white);
    sphere(sc, spc_v3(0, 0.5, 0), 0.5, glass(sc, 1.5));
    spc_shape *l = sphere(sc, spc_v3(-0.6, 2.0, -1.0), 0.1, tu_diffuse(sc, 0.0));
    spc_emitter *e = tu_area(sc, l, sc->nshapes - 1, 1.0);
    e->radiance = spc_scene_constant(sc, spc_rgb3(300, 270, 220));
    tu_camera(sc, spc_v3(0, 2.4, 3.6), spc_v3(0.1, 0.3, 0.2), spc_v3(0, 1, 0), 40, res, res);
    return finalize(sc);
}

/* hot_spot_scene with a mirror ball beside the glass one: two cones from the floor. */
static spc_scene *hot_spot_scene_two_balls(int res)
{
    spc_scene *sc = spc_scene_create();
    spc_bsdf *white = twosided_diffuse(sc, 0.7, 0.7, 0.7);
    rect(sc, 3, 3, -90, 0, spc_v3(0, 0, 0), white);
    rect(sc, 3, 2, 0, 0, spc_v3(0, 2, -1.5), white);
    sphere(sc, spc_v3(0, 0.5, 0), 0.5, glass(sc, 1.5));
    sphere(sc, spc_v3(0.9, 0.3, 0.3), 0.3, mirror(sc));
    spc_shape *l = sphere(sc, spc_v3(-0.6, 2.0, -1.0), 0.1, tu_diffuse(sc, 0.0));
    spc_emitter *e = tu_area(sc, l, sc->nshapes - 1, 1.0);
    e->radiance = spc_scene_constant(sc, spc_rgb3(300, 270, 220));
    tu_camera(sc, spc_v3(0, 2.4, 3.6), spc_v3(0.1, 0.3, 0.2), spc_v3(0, 1, 0), 40, res, res);
    return finalize(sc);
}

/* The camera's first bounce aimed at the ball (bdpt.h, spc_bdpt_aim.cam): camera - floor - glass -
 * glass - wall with a light point joined to the wall (s = 1, t = 5: the wall's bright spot seen
 * through the ball from the floor) is sampled many times as often, so that strategy's own estimate
 * (unweighted; it also holds the paths that bounce off the wall and the floor, which the aim samples
 * less often) has less variance at the same samples (1.63-1.68x at 0.9, seeds 61-63), and the same
 * mean. The pilot halves 0.9 here (half of the ball's light comes off the wall and the floor); none
 * when off. */
TEST(camera_aim_raises_camera_paths_through_glass)
{
    spc_scene *sc = hot_spot_scene(16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_render_stats st_on, st_off;
    memset(&st_on, 0, sizeof st_on);
    memset(&st_off, 0, sizeof st_off);
    spc_film *on = render_aim2(sc, 0.0, 0.9, 256, 61, true, &st_on);
    spc_film *off = render_aim2(sc, 0.0, -1.0, 256, 61, true, &st_off);
    CHECK(on && off);
    double sum_on = 0.0, var_on = 0.0, sum_off = 0.0, var_off = 0.0;
    if (on && off && strategy_film_sums(on, 1, 5, &sum_on, &var_on) && strategy_film_sums(off, 1, 5, &sum_off, &var_off)) {
        printf("  camera - floor - glass - glass - wall, light point (s = 1, t = 5): sum %.4g, variance %.4g with "
               "the camera's aim (share %.3f); sum %.4g, variance %.4g without\n",
               sum_on, var_on, st_on.bdpt_aim_camera, sum_off, var_off);
        CHECK(st_on.bdpt_aim_camera > 0.3 && st_on.bdpt_aim_camera < 0.6);
        CHECK(st_off.bdpt_aim_camera == 0.0 && st_off.bdpt_aim > 0.0);
        CHECK(sum_on > 0.0 && sum_off > 0.0 && var_on > 0.0);
        double se = sqrt(var_on + var_off);
        CHECK_MSG(fabs(sum_on - sum_off) < 4.0 * se, "sums %.4g and %.4g differ by %.1f standard errors", sum_on,
                  sum_off, fabs(sum_on - sum_off) / se);
        CHECK_MSG(var_off > 1.4 * var_on, "variance %.4g with the camera's aim, %.4g without", var_on, var_off);
    } else {
        CHECK_MSG(false, "no s = 1, t = 5 strategy film");
    }
    spc_film_destroy(on);
    spc_film_destroy(off);
    spc_scene_destroy(sc);
}

/* The camera's mixture density in the walk's weight and in every MIS weight: with most of the first
 * bounce aimed (0.9) the images still agree with path's, on the caustic with its bright spot and on
 * the same with a mirror ball beside the glass one (two cones). With the BSDF's density in the
 * weights of t = 1 and t = 2 instead of the mixture's (made by hand) the image means differ from
 * path's by 5.4 (one cone) and 6.2 (two cones) standard errors in every channel. */
TEST(camera_aim_against_path)
{
    spc_scene *scs[2] = {hot_spot_scene(16), hot_spot_scene_two_balls(16)};
    const char *what[2] = {"caustic with its bright spot, camera aim 0.9",
                           "the same with a mirror ball beside the glass one, camera aim 0.9"};
    const int spp_path[2] = {4096, 2048};
    for (int k = 0; k < 2; ++k) {
        CHECK(scs[k] != NULL);
        if (!scs[k])
            continue;
        spc_render_stats st;
        memset(&st, 0, sizeof st);
        spc_film *b = render_aim2(scs[k], 0.0, 0.9, 256, 71, false, &st);
        printf("  %s: camera's aimed share %.3f\n", what[k], st.bdpt_aim_camera);
        CHECK(st.bdpt_aim_camera > 0.1);
        spc_film *p = render_opts(scs[k], "path", spp_path[k], 2, 72, -1, -1, -1, false, false);
        check_against_path(b, p, what[k]);
        spc_scene_destroy(scs[k]);
    }
}

/* The camera's aim only where the casters show the surfaces the camera sees something brighter
 * than the rest of what they see (camera_aim_gain): on the hot-spot caustic, not on the box with a
 * glass and a mirror sphere under a ceiling light (its walls seen through the balls are lit as the
 * walls seen directly), nor on a glass ball on a floor under a sky; the light's aim stays on in
 * all three. Asked for 0.9 in each. A crop window gets the whole film's verdict. */
TEST(camera_aim_gate)
{
    spc_scene *scs[3] = {hot_spot_scene(16), cornell_box(BOX_SPHERES, 16, 2.0), NULL};
    spc_scene *sky = spc_scene_create();
    rect(sky, 3, 3, -90, 0, spc_v3(0, 0, 0), twosided_diffuse(sky, 0.7, 0.7, 0.7));
    sphere(sky, spc_v3(0, 0.5, 0), 0.5, glass(sky, 1.5));
    spc_shape *l = sphere(sky, spc_v3(-0.6, 2.0, -1.0), 0.1, tu_diffuse(sky, 0.0));
    spc_emitter *e = tu_area(sky, l, sky->nshapes - 1, 1.0);
    e->radiance = spc_scene_constant(sky, spc_rgb3(300, 270, 220));
    spc_emitter *env = spc_scene_new_emitter(sky);
    env->type = SPC_EMITTER_CONSTANT;
    env->radiance = spc_scene_constant(sky, spc_rgb3(0.8, 0.9, 1.0));
    tu_camera(sky, spc_v3(0, 2.4, 3.6), spc_v3(0.1, 0.3, 0.2), spc_v3(0, 1, 0), 40, 16, 16);
    scs[2] = finalize(sky);
    const char *what[3] = {"hot-spot caustic", "box with glass and mirror spheres", "glass ball under a sky"};
    for (int k = 0; k < 3; ++k) {
        CHECK(scs[k] != NULL);
        if (!scs[k])
            continue;
        spc_render_stats st;
        memset(&st, 0, sizeof st);
        spc_film *f = render_aim2(scs[k], 0.0, 0.9, 1, 81, false, &st);
        CHECK(f != NULL);
        printf("  %s: light's aimed share %.3f, camera's %.3f\n", what[k], st.bdpt_aim, st.bdpt_aim_camera);
        CHECK(st.bdpt_aim > 0.0);
        if (k == 0)
            CHECK_MSG(st.bdpt_aim_camera > 0.3, "%s: camera's aimed share %.3f", what[k], st.bdpt_aim_camera);
        else
            CHECK_MSG(st.bdpt_aim_camera == 0.0, "%s: camera's aimed share %.3f", what[k], st.bdpt_aim_camera);
        spc_film_destroy(f);
        if (k == 0) {
            /* a crop of pixels that see only the ball: the pilot reads the whole film, same aim */
            double full = st.bdpt_aim_camera;
            spc_scene *crop = scs[k];
            crop->film.crop_x = 7;
            crop->film.crop_y = 5;
            crop->film.crop_w = 2;
            crop->film.crop_h = 2;
            memset(&st, 0, sizeof st);
            f = render_aim2(crop, 0.0, 0.9, 1, 81, false, &st);
            CHECK(f != NULL);
            CHECK_MSG(st.bdpt_aim_camera == full, "crop: camera's aimed share %.3f, whole film %.3f",
                      st.bdpt_aim_camera, full);
            spc_film_destroy(f);
        }
        spc_scene_destroy(scs[k]);
    }
}

TEST(same_image_for_any_thread_count)
{
    spc_scene *sc = cornell_box(BOX_SPHERES, 20, 1.0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *a = render_opts(sc, "bdpt", 8, 1, 7, -1, -1, -1, false, false);
    spc_film *b = render_opts(sc, "bdpt", 8, 2, 7, -1, -1, -1, false, false);
    spc_film *c = render_opts(sc, "bdpt", 8, 2, 8, -1, -1, -1, false, false);
    CHECK(a && b && c);
    if (a && b && c) {
        size_t n = 3 * (size_t)a->width * a->height;
        CHECK(memcmp(a->rgb, b->rgb, n * sizeof(float)) == 0);
        CHECK(memcmp(a->var, b->var, n * sizeof(float)) == 0);
        CHECK(memcmp(a->rgb, c->rgb, n * sizeof(float)) != 0); /* the seed matters */
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_film_destroy(c);
    spc_scene_destroy(sc);
}

/* The film's AOVs (albedo, normal, depth) are filled only when asked for, and asking moves no
 * image bit: bdpt's AOV walk through delta surfaces draws from a stream of its own. */
TEST(aovs_only_when_asked_and_image_unchanged)
{
    spc_scene *sc = cornell_box(BOX_SPHERES, 16, 1.0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *f[2] = {NULL, NULL};
    for (int k = 0; k < 2; ++k) {
        spc_render_options o;
        spc_render_options_init(&o);
        o.spp = 4;
        o.threads = 1;
        o.seed = 5;
        o.integrator = "bdpt";
        o.aovs = k == 1;
        spc_error err;
        spc_render_stats st;
        if (spc_render(sc, &o, &f[k], &st, &err) != SPC_OK) {
            spc_film_destroy(f[k]);
            f[k] = NULL;
        }
    }
    CHECK(f[0] && f[1]);
    if (f[0] && f[1]) {
        size_t n = 3 * (size_t)f[0]->width * f[0]->height;
        CHECK(memcmp(f[0]->rgb, f[1]->rgb, n * sizeof(float)) == 0);
        CHECK(memcmp(f[0]->var, f[1]->var, n * sizeof(float)) == 0);
        CHECK(!f[0]->has_aovs && f[1]->has_aovs && f[1]->aov);
        /* the box's walls are diffuse: every pixel sees an albedo and a depth */
        double albedo = 0.0, depth = 0.0;
        for (size_t i = 0; f[1]->aov && i < (size_t)f[1]->width * f[1]->height; ++i) {
            albedo += f[1]->aov[i * SPC_FILM_AOVS];
            depth += f[1]->aov[i * SPC_FILM_AOVS + 6];
        }
        CHECK_MSG(albedo > 0.0 && depth > 0.0, "albedo sum %g, depth sum %g", albedo, depth);
    }
    spc_film_destroy(f[0]);
    spc_film_destroy(f[1]);
    spc_scene_destroy(sc);
}

TEST(integrator_name)
{
    spc_integrator_kind k;
    CHECK(spc_integrator_kind_from_name("bdpt", &k) && k == SPC_INTEGRATOR_BDPT);
    CHECK(!strcmp(spc_integrator_kind_name(SPC_INTEGRATOR_BDPT), "bdpt"));
    /* every kind has one name, and the name parses back to it */
    const spc_integrator_kind all[] = {SPC_INTEGRATOR_PATH, SPC_INTEGRATOR_IPT, SPC_INTEGRATOR_BDPT,
                                       SPC_INTEGRATOR_VOLPATH, SPC_INTEGRATOR_PTRACER};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; ++i)
        CHECK(spc_integrator_kind_from_name(spc_integrator_kind_name(all[i]), &k) && k == all[i]);
    CHECK(!spc_integrator_kind_from_name("pathh", &k));
    char names[128];
    spc_integrator_kind_names(names, sizeof names);
    CHECK_MSG(!strcmp(names, "path, ipt, bdpt, volpath, ptracer"), "%s", names);
}

int main(void)
{
    spc_warn_set_quiet(1);
    RUN(integrator_name);
    RUN(white_furnace_sphere);
    RUN(white_furnace_cube_scales);
    RUN(point_light_in_sphere);
    RUN(glass_slab_orthographic);
    RUN(same_image_for_any_thread_count);
    RUN(aovs_only_when_asked_and_image_unchanged);
    RUN(weighted_strategies_sum_to_full_image);
    RUN(strategy_images_in_one_render);
    RUN(light_tracing_matches_nee_for_every_filter);
    RUN(unweighted_strategies_estimate_length_images);
    RUN(balance_heuristic_against_power);
    RUN(point_light_against_path);
    RUN(environment_against_path);
    RUN(shading_normals_against_path);
    RUN(directional_and_spot_against_path);
    RUN(normal_maps_against_path);
    RUN(box_glass_mirror_against_path);
    RUN(caustic_against_path);
    RUN(light_paths_per_sample_against_path);
    RUN(light_paths_raise_light_tracing_share);
    RUN(ptracer_against_path);
    RUN(ptracer_sees_the_sky);
    RUN(specular_nee_tames_s0_only_paths);
    RUN(specular_nee_camera_share_and_corners);
    RUN(corner_receivers_take_the_corner_path);
    RUN(direct_receivers_weigh_light_tracing);
    RUN(reflected_receivers_take_more_light_points);
    RUN(later_receivers_tame_the_caustic_outlier);
    RUN(aim_raises_light_tracing_through_glass);
    RUN(aimed_emission_against_path);
    RUN(aim_off_where_casters_hidden);
    RUN(camera_aim_raises_camera_paths_through_glass);
    RUN(camera_aim_against_path);
    RUN(camera_aim_gate);
    printf("bdpt subpaths truncated at the vertex limit: %llu\n", (unsigned long long)spc_bdpt_truncated_paths());
    return spc_test_finish();
}
