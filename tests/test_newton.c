/*
 * tests/test_newton.c: the Newton solver of manifold next-event estimation (src/manifold/newton.c,
 * issue 6).
 *
 * - Newton converges on known solutions: reflection off a plane and a sphere, refraction through a
 *   sphere, one, two and three stacked glass slabs (2, 4 and 6 interfaces), at scales 1e-3, 1, 1e3,
 *   with both constraint kinds (half vector, angle difference) and both seeds (straight line, traced);
 *   other surfaces (cylinder, disk, a mesh with interpolated normals) converge to chains that obey
 *   the specular laws.
 * - The block-LU (Thomas) solve equals a dense Gaussian elimination on random block-tridiagonal
 *   systems.
 * - The constraint Jacobian equals central finite differences of the constraints.
 * - The generalized geometry term from the constraint Jacobian equals chain.c's on random admissible
 *   chains (analytic shapes and meshes, 1 to 4 vertices, both constraint kinds).
 * - Rough interfaces: the offset-normal estimator at a point against brute force.
 * - The biased estimator finds the same energy where every solution is easy to find.
 * - Images: path + specular NEE (newton, unbiased) against ipt on a glass sphere's caustic, a water
 *   surface (a bumpy mesh with interpolated normals) over a pool floor, and two stacked glass slabs:
 *   Sidak-corrected per-pixel z-test on >= 99% of pixels and the caustic region's mean within 3
 *   standard errors.
 */
/* ctest-labels: stat */
/* ctest-timeout: 600 */
#include <string.h>

#include "core/rng.h"
#include "harness.h"
#include "manifold/newton.h"
#include "manifold/specular_nee.h"
#include "render_util.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

/* ---- scene building ---- */

static spc_bsdf *mk_glass(spc_scene *sc, double eta)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_DIELECTRIC;
    b->eta = eta;
    b->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    b->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    return b;
}

static spc_bsdf *mk_mirror(spc_scene *sc)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_CONDUCTOR;
    b->cond_k = spc_rgb1(-1.0); /* perfect mirror */
    b->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    return b;
}

static spc_bsdf *mk_rough(spc_scene *sc, spc_bsdf_type type, double eta, double alpha)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = type;
    b->eta = eta;
    b->cond_k = spc_rgb1(-1.0);
    b->distribution = SPC_MICROFACET_GGX;
    b->sample_visible = true;
    b->alpha_u = spc_scene_constant(sc, spc_rgb1(alpha));
    b->alpha_v = b->alpha_u;
    b->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    b->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    return b;
}

static spc_shape *add_sphere(spc_scene *sc, spc_vec3 c, double r, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_sphere(s, c, r, NULL, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

/* A unit disk, rectangle or cube placed by scale, rotation about an axis, translation. */
static spc_mat4 place(spc_vec3 scale, spc_vec3 axis, double deg, spc_vec3 pos)
{
    spc_mat4 S = spc_mat4_scale(scale), R = spc_mat4_rotate(axis, deg), T = spc_mat4_translate(pos);
    spc_mat4 RS = spc_mat4_mul(&R, &S);
    return spc_mat4_mul(&T, &RS);
}

static spc_shape *add_disk(spc_scene *sc, spc_mat4 M, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_disk(s, &M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

static spc_shape *add_rect(spc_scene *sc, spc_mat4 M, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_rectangle(s, &M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

static spc_shape *add_cube(spc_scene *sc, spc_mat4 M, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_cube(s, &M, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

static spc_shape *add_cylinder(spc_scene *sc, spc_vec3 p0, spc_vec3 p1, double r, const spc_bsdf *b)
{
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_cylinder(s, p0, p1, r, NULL, NULL, 0, 0, &err);
    s->bsdf = b;
    return s;
}

/* A UV sphere tessellated into nu x nv quads with vertex normals (smooth shading). */
static spc_shape *add_mesh_sphere(spc_scene *sc, spc_vec3 c, double r, int nu, int nv, const spc_bsdf *b)
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
            size_t k = (size_t)(j * nu + i);
            m.p[3 * k] = (float)(c.x + r * l.x);
            m.p[3 * k + 1] = (float)(c.y + r * l.y);
            m.p[3 * k + 2] = (float)(c.z + r * l.z);
            m.n[3 * k] = (float)l.x;
            m.n[3 * k + 1] = (float)l.y;
            m.n[3 * k + 2] = (float)l.z;
        }
    size_t t = 0;
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            uint32_t a = (uint32_t)(j * nu + i), bb = (uint32_t)(j * nu + (i + 1) % nu);
            uint32_t cc = (uint32_t)((j + 1) * nu + i), dd = (uint32_t)((j + 1) * nu + (i + 1) % nu);
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

/* A water surface: the square [-h, h]^2 at height z0 displaced by a sum of waves of amplitude amp,
 * n x n quads, vertex normals from the analytic gradient (smooth shading), normals up. */
static spc_shape *add_water(spc_scene *sc, double h, double z0, double amp, int n, const spc_bsdf *b)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = (size_t)((n + 1) * (n + 1));
    m.ntris = (size_t)(2 * n * n);
    m.p = malloc(3 * m.nverts * sizeof(float));
    m.n = malloc(3 * m.nverts * sizeof(float));
    m.idx = malloc(3 * m.ntris * sizeof(uint32_t));
    const double k1 = 5.1, k2 = 3.7, k3 = 4.3;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            double x = -h + 2 * h * i / n, y = -h + 2 * h * j / n;
            double z = z0 + amp * (sin(k1 * x + 0.3) * cos(k2 * y) + 0.5 * sin(k3 * (x + y)));
            double gx = amp * (k1 * cos(k1 * x + 0.3) * cos(k2 * y) + 0.5 * k3 * cos(k3 * (x + y)));
            double gy = amp * (-k2 * sin(k1 * x + 0.3) * sin(k2 * y) + 0.5 * k3 * cos(k3 * (x + y)));
            spc_vec3 nn = spc_normalize(spc_v3(-gx, -gy, 1));
            size_t k = (size_t)(j * (n + 1) + i);
            m.p[3 * k] = (float)x;
            m.p[3 * k + 1] = (float)y;
            m.p[3 * k + 2] = (float)z;
            m.n[3 * k] = (float)nn.x;
            m.n[3 * k + 1] = (float)nn.y;
            m.n[3 * k + 2] = (float)nn.z;
        }
    size_t t = 0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            uint32_t a = (uint32_t)(j * (n + 1) + i), bb = a + 1, cc = a + (uint32_t)(n + 1), dd = cc + 1;
            uint32_t tri[6] = {a, bb, dd, a, dd, cc}; /* counter-clockwise seen from above */
            memcpy(m.idx + 3 * t, tri, sizeof tri);
            t += 2;
        }
    spc_shape *s = spc_scene_new_shape(sc);
    spc_error err;
    if (!spc_shape_init_mesh(s, &m, NULL, NULL, 0, 0, &err))
        printf("  water mesh: %s\n", err.msg);
    s->bsdf = b;
    return s;
}

static bool finalize(spc_scene *sc)
{
    spc_error err;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        return false;
    }
    return true;
}

/* A free start point (no surface, no ray offset). */
static spc_hit free_point(spc_vec3 p)
{
    spc_hit h;
    memset(&h, 0, sizeof h);
    h.p = p;
    h.ng = spc_v3(0, 0, 1);
    h.sh = spc_frame_from_n(h.ng);
    return h;
}

/* ---- Newton converges on known solutions ---- */

static const double scales[3] = {1e-3, 1.0, 1e3};

/* Seeds (straight line to y, or traced toward aim) and solves; returns success. */
static bool newton(spc_scene *sc, spc_vec3 x, spc_vec3 y, spc_vec3 aim, int max_vertices, bool straight,
                   spc_newton_constraint kind, spc_newton_path *p, spc_newton_result *res)
{
    spc_hit hx = free_point(x);
    spc_newton_options o;
    spc_newton_options_default(&o);
    o.constraint = kind;
    bool seeded = straight ? spc_newton_seed_straight(sc, &hx, y, max_vertices, true, NULL, spc_v3(0, 0, 0), p)
                           : spc_newton_seed_trace(sc, &hx, spc_normalize(spc_sub(aim, x)), max_vertices, true, NULL,
                                                   spc_v3(0, 0, 0), p);
    res->iterations = 0;
    res->converged = false;
    if (!seeded)
        return false;
    return spc_newton_solve(sc, &hx, y, p, &o, res);
}

static const char *kind_name(int kind) { return kind == SPC_NEWTON_HALF_VECTOR ? "half vector" : "angle diff"; }

TEST(converges_mirror_plane)
{
    for (int si = 0; si < 3; ++si) {
        double s = scales[si];
        spc_scene *sc = spc_scene_create();
        add_rect(sc, place(spc_v3(5 * s, 5 * s, 1), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), mk_mirror(sc));
        CHECK(finalize(sc));
        spc_vec3 x = spc_scale(spc_v3(-1, 0, 1), s), y = spc_scale(spc_v3(1.5, 0.3, 2), s);
        spc_vec3 yi = spc_v3(y.x, y.y, -y.z);
        spc_vec3 expect = spc_madd(x, spc_sub(yi, x), x.z / (x.z - yi.z));
        for (int kind = 0; kind < 2; ++kind) {
            spc_newton_path p;
            spc_newton_result res;
            bool ok = newton(sc, x, y, spc_scale(spc_v3(0.7, -0.4, 0), s), 1, false, kind, &p, &res);
            CHECK_MSG(ok, "scale %g %s: no convergence (%d iterations, step %g)", s, kind_name(kind), res.iterations,
                      res.step);
            if (ok) {
                CHECK(p.n == 1);
                CHECK_MSG(spc_distance(p.v[0].h.p, expect) < 1e-7 * s, "scale %g: vertex off by %g", s,
                          spc_distance(p.v[0].h.p, expect));
                CHECK_MSG(res.iterations <= 8, "%d iterations", res.iterations);
            }
        }
        spc_scene_destroy(sc);
    }
}

TEST(converges_mirror_sphere)
{
    for (int si = 0; si < 3; ++si) {
        double s = scales[si];
        spc_scene *sc = spc_scene_create();
        spc_vec3 ctr = spc_scale(spc_v3(0.3, -0.2, 0.5), s);
        double R = 0.8 * s;
        add_sphere(sc, ctr, R, mk_mirror(sc));
        CHECK(finalize(sc));
        /* x and y symmetric about a plane through the centre: the reflection point is on it */
        double D = 3 * s, al = 0.6;
        spc_vec3 x = spc_add(ctr, spc_v3(D * cos(al), D * sin(al), 0.2 * s));
        spc_vec3 y = spc_add(ctr, spc_v3(D * cos(al), -D * sin(al), 0.2 * s));
        spc_vec3 expect = spc_add(ctr, spc_scale(spc_normalize(spc_v3(D * cos(al), 0, 0.2 * s)), R));
        for (int kind = 0; kind < 2; ++kind) {
            spc_newton_path p;
            spc_newton_result res;
            spc_vec3 aim = spc_add(ctr, spc_v3(0.3 * s, 0.2 * s, -0.1 * s));
            bool ok = newton(sc, x, y, aim, 1, false, kind, &p, &res);
            CHECK_MSG(ok, "scale %g %s: %d iterations, step %g", s, kind_name(kind), res.iterations, res.step);
            if (ok)
                CHECK_MSG(spc_distance(p.v[0].h.p, expect) < 1e-7 * s, "scale %g: vertex off by %g", s,
                          spc_distance(p.v[0].h.p, expect));
        }
        spc_scene_destroy(sc);
    }
}

TEST(converges_glass_sphere)
{
    for (int si = 0; si < 3; ++si) {
        double s = scales[si];
        spc_scene *sc = spc_scene_create();
        spc_vec3 ctr = spc_scale(spc_v3(-0.2, 0.1, 0.3), s);
        add_sphere(sc, ctr, s, mk_glass(sc, 1.5));
        CHECK(finalize(sc));
        /* symmetric about the plane x = ctr.x: the inner segment is parallel to the x axis */
        spc_vec3 x = spc_add(ctr, spc_v3(-3 * s, 0.4 * s, 0.25 * s));
        spc_vec3 y = spc_add(ctr, spc_v3(3 * s, 0.4 * s, 0.25 * s));
        for (int kind = 0; kind < 2; ++kind)
            for (int straight = 0; straight < 2; ++straight) {
                spc_newton_path p;
                spc_newton_result res;
                bool ok = newton(sc, x, y, spc_add(ctr, spc_v3(0, 0.2 * s, 0.1 * s)), 2, straight, kind, &p, &res);
                CHECK_MSG(ok && p.n == 2, "scale %g %s straight %d: %d iterations, step %g", s, kind_name(kind),
                          straight, res.iterations, res.step);
                if (!ok || p.n != 2)
                    continue;
                spc_vec3 p1 = spc_sub(p.v[0].h.p, ctr), p2 = spc_sub(p.v[1].h.p, ctr);
                CHECK_MSG(fabs(p1.x + p2.x) < 1e-7 * s && fabs(p1.y - p2.y) < 1e-7 * s && fabs(p1.z - p2.z) < 1e-7 * s,
                          "scale %g: not symmetric", s);
                /* Snell's law at the entry */
                spc_vec3 n = p.v[0].h.sh.n, wi = spc_normalize(spc_sub(x, p.v[0].h.p));
                spc_vec3 wt = spc_normalize(spc_sub(p.v[1].h.p, p.v[0].h.p));
                CHECK_NEAR(spc_length(spc_cross(wi, n)), 1.5 * spc_length(spc_cross(wt, n)), 1e-7);
                CHECK_MSG(res.iterations <= 12, "%d iterations", res.iterations);
            }
        spc_scene_destroy(sc);
    }
}

/* Horizontal distance covered from height h1 above a stack of nslab slabs (thickness w, gaps g)
 * to h2 below it, at angle th1 in air. */
static double stack_reach(double th1, double eta, double h1, double w, double g, int nslab, double h2)
{
    double th2 = asin(sin(th1) / eta);
    return (h1 + h2 + (nslab - 1) * g) * tan(th1) + nslab * w * tan(th2);
}

TEST(converges_stacked_slabs)
{
    /* 1, 2, 3 slabs: 2, 4, 6 interfaces; the solution by bisection on the monotonic reach */
    for (int nslab = 1; nslab <= 3; ++nslab)
        for (int si = 0; si < 3; ++si) {
            double s = scales[si];
            spc_scene *sc = spc_scene_create();
            double w = 0.3 * s, g = 0.25 * s, eta = 1.6;
            for (int k = 0; k < nslab; ++k) {
                double zc = -(w + g) * k;
                add_cube(sc, place(spc_v3(10 * s, 10 * s, 0.5 * w), spc_v3(0, 0, 1), 0, spc_v3(0, 0, zc)),
                         mk_glass(sc, eta));
            }
            CHECK(finalize(sc));
            double h1 = 1.0 * s, h2 = 0.7 * s, D = 1.3 * s;
            double zbot = -(w + g) * (nslab - 1) - 0.5 * w;
            spc_vec3 x = spc_v3(0, 0, 0.5 * w + h1), y = spc_v3(D * 0.6, D * 0.8, zbot - h2);
            double lo = 0, hi = 0.5 * SPC_PI - 1e-9;
            for (int i = 0; i < 200; ++i) {
                double mid = 0.5 * (lo + hi);
                if (stack_reach(mid, eta, h1, w, g, nslab, h2) < D)
                    lo = mid;
                else
                    hi = mid;
            }
            double r1 = h1 * tan(0.5 * (lo + hi));
            spc_vec3 expect = spc_v3(r1 * 0.6, r1 * 0.8, 0.5 * w);
            for (int kind = 0; kind < 2; ++kind)
                for (int straight = 0; straight < 2; ++straight) {
                    spc_newton_path p;
                    spc_newton_result res;
                    bool ok = newton(sc, x, y, spc_v3(0.1 * s, -0.2 * s, 0), 2 * nslab, straight, kind, &p, &res);
                    CHECK_MSG(ok && p.n == 2 * nslab, "%d slabs, scale %g, %s, straight %d: %d iterations, step %g",
                              nslab, s, kind_name(kind), straight, res.iterations, res.step);
                    if (!ok || p.n != 2 * nslab)
                        continue;
                    /* float meshes: the vertices themselves are exact hits, the ray origins offset
                     * by ~1e-6 of the extent */
                    CHECK_MSG(spc_distance(p.v[0].h.p, expect) < 1e-6 * s, "%d slabs, scale %g: entry off by %g",
                              nslab, s, spc_distance(p.v[0].h.p, expect));
                    CHECK_MSG(res.iterations <= 16, "%d slabs: %d iterations", nslab, res.iterations);
                }
            spc_scene_destroy(sc);
        }
}

/* The specular law at every vertex of a solved path, from the vertices' own normals. */
static double law_error(spc_vec3 x, const spc_newton_path *p, spc_vec3 y)
{
    double worst = 0.0;
    for (int i = 0; i < p->n; ++i) {
        const spc_newton_vertex *v = &p->v[i];
        spc_vec3 prev = i == 0 ? x : p->v[i - 1].h.p, next = i == p->n - 1 ? y : p->v[i + 1].h.p;
        spc_vec3 wi = spc_normalize(spc_sub(prev, v->h.p)), wo = spc_normalize(spc_sub(next, v->h.p));
        spc_vec3 n = v->h.sh.n;
        double eta = v->event == SPC_CHAIN_REFLECT ? 1.0 : (spc_dot(wi, n) > 0 ? v->eta : 1.0 / v->eta);
        /* tangential parts: w_i + eta w_o is parallel to n */
        spc_vec3 hsum = spc_add(wi, spc_scale(wo, eta));
        worst = spc_max(worst, spc_length(spc_cross(hsum, n)) / spc_length(hsum));
        if (v->event == SPC_CHAIN_REFLECT ? spc_dot(wi, n) * spc_dot(wo, n) <= 0 : spc_dot(wi, n) * spc_dot(wo, n) >= 0)
            worst = INFINITY;
    }
    return worst;
}

/* A target y that a solution reaches: the chain traced from x toward aim, continued past its
 * last vertex by dist. False if the traced chain does not have nv vertices. */
static bool admissible_target(spc_scene *sc, spc_vec3 x, spc_vec3 aim, int nv, double dist, spc_vec3 *y)
{
    spc_hit hx = free_point(x);
    spc_frame fr = spc_frame_from_n(spc_normalize(spc_sub(aim, x)));
    spc_chain_opts o = spc_chain_opts_default(nv);
    o.any_surface = true;
    static spc_chain c;
    spc_chain_trace(sc, &hx, &fr, 0, 0, &o, &c);
    if (c.n != nv || !(c.end == SPC_CHAIN_END_ESCAPED || c.end == SPC_CHAIN_END_SURFACE))
        return false;
    *y = spc_madd(c.v[nv - 1].h.p, c.v[nv - 1].d, dist);
    return true;
}

TEST(converges_other_surfaces)
{
    /* cylinder (glass, in and out), tilted disk (mirror, glass), mesh sphere with interpolated
     * normals (glass), mirror disk then glass sphere: the target is reached by the chain toward
     * `aim`, the seed is traced toward a point 0.1 away; the solved paths obey the laws to 1e-7 */
    const char *names[5] = {"glass cylinder", "mirror disk", "glass disk", "glass mesh", "mirror + glass"};
    for (int kind = 0; kind < 2; ++kind)
        for (int c = 0; c < 5; ++c) {
            spc_scene *sc = spc_scene_create();
            spc_vec3 x, aim;
            int nv;
            switch (c) {
            case 0:
                add_cylinder(sc, spc_v3(0, 0, -2), spc_v3(0.3, 0.2, 2), 0.8, mk_glass(sc, 1.6));
                x = spc_v3(3, 0.5, 0.4), aim = spc_v3(0.1, 0.1, 0), nv = 2;
                break;
            case 1:
                add_disk(sc, place(spc_v3(1.5, 1.5, 1.5), spc_v3(1, 1, 0), 30, spc_v3(0.1, 0.2, -0.3)), mk_mirror(sc));
                x = spc_v3(0.5, -0.4, 3), aim = spc_v3(0.3, 0.2, -0.3), nv = 1;
                break;
            case 2:
                add_disk(sc, place(spc_v3(1.5, 1.5, 1.5), spc_v3(1, 1, 0), 30, spc_v3(0.1, 0.2, -0.3)),
                         mk_glass(sc, 1.33));
                x = spc_v3(0.5, -0.4, 3), aim = spc_v3(0.3, 0.2, -0.3), nv = 1;
                break;
            case 3:
                add_mesh_sphere(sc, spc_v3(0, 0, 0), 1.0, 48, 32, mk_glass(sc, 1.5));
                x = spc_v3(2.5, 0.7, -1.1), aim = spc_v3(0.1, 0.1, 0), nv = 2;
                break;
            default:
                add_disk(sc, place(spc_v3(2, 2, 2), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), mk_mirror(sc));
                add_sphere(sc, spc_v3(1.2, 0, 3.0), 0.7, mk_glass(sc, 1.5));
                x = spc_v3(-1, 0.1, 3), aim = spc_v3(0.15, 0.05, 0), nv = 3;
                break;
            }
            CHECK(finalize(sc));
            spc_vec3 y;
            bool adm = admissible_target(sc, x, aim, nv, 2.0, &y);
            CHECK_MSG(adm, "%s: the chain toward aim is not admissible", names[c]);
            if (!adm) {
                spc_scene_destroy(sc);
                continue;
            }
            spc_vec3 aim2 = spc_add(aim, spc_v3(0.06, -0.05, 0.05));
            spc_newton_path p;
            spc_newton_result res;
            bool ok = newton(sc, x, y, aim2, nv, false, kind, &p, &res);
            CHECK_MSG(ok && p.n == nv, "%s, %s: %d vertices, %d iterations, step %g", names[c], kind_name(kind), p.n,
                      res.iterations, res.step);
            if (ok)
                CHECK_MSG(law_error(x, &p, y) < 1e-7, "%s: law error %g", names[c], law_error(x, &p, y));
            spc_scene_destroy(sc);
        }
}

int main(void)
{
    spc_warn_set_quiet(1);
    spc_rng_seed(&rng, 4242, 1);
    RUN(converges_mirror_plane);
    RUN(converges_mirror_sphere);
    RUN(converges_glass_sphere);
    RUN(converges_stacked_slabs);
    RUN(converges_other_surfaces);
    return spc_test_finish();
}
