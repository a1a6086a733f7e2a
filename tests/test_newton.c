/*
 * tests/test_newton.c: the Newton solver of manifold next-event estimation (src/manifold/newton.c).
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
/* ctest-timeout: 1200 */
#include <string.h>

#include "core/rng.h"
#include "harness.h"
#include "manifold/newton.h"
#include "manifold/specular_nee.h"
#include "scene/camera.h"
#include "render_util.h"
#include "scene/sdf.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

/* ---- scene building ---- */

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

/* A signed distance field shape (scene/sdf.h): a torus (major 1, minor 0.4) or a rounded box
 * (half sizes 0.8, 0.5, 0.3, corner radius 0.15), placed by M. */
static spc_shape *add_sdf(spc_scene *sc, spc_sdf_type type, const spc_mat4 *M, const spc_bsdf *b)
{
    spc_sdf_desc d;
    spc_sdf_desc_init(&d, type);
    if (type == SPC_SDF_TORUS) {
        d.major = 1.0;
        d.minor = 0.4;
    } else {
        d.half_size = spc_v3(0.8, 0.5, 0.3);
        d.radius = 0.15;
    }
    return tu_sdf(sc, &d, M, b);
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

/* ---- Newton converges on known solutions ---- */

static const double scales[3] = {1e-3, 1.0, 1e3};

/* Seeds (straight line to y, or traced toward aim) and solves; returns success. */
static bool newton(spc_scene *sc, spc_vec3 x, spc_vec3 y, spc_vec3 aim, int max_vertices, bool straight,
                   spc_newton_constraint kind, spc_newton_path *p, spc_newton_result *res)
{
    spc_hit hx = tu_free_point(x);
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
        tu_rect(sc, tu_place(spc_v3(5 * s, 5 * s, 1), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), tu_mirror(sc));
        CHECK(tu_finalize(sc));
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
        tu_sphere(sc, ctr, R, tu_mirror(sc));
        CHECK(tu_finalize(sc));
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
        tu_sphere(sc, ctr, s, tu_glass(sc, 1.5));
        CHECK(tu_finalize(sc));
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
                tu_cube(sc, tu_place(spc_v3(10 * s, 10 * s, 0.5 * w), spc_v3(0, 0, 1), 0, spc_v3(0, 0, zc)),
                         tu_glass(sc, eta));
            }
            CHECK(tu_finalize(sc));
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
    spc_hit hx = tu_free_point(x);
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
     * normals (glass), mirror disk then glass sphere, SDFs (glass torus, mirror rounded box at its
     * rounded edge), and six interfaces mixed (a glass slab crossed down and up around a mirror
     * floor, then a mirror sphere: T T R T T R): the target is reached by the chain toward `aim`, the
     * seed is traced toward a point 0.1 away; the solved paths obey the laws to 1e-7 */
    const char *names[8] = {"glass cylinder", "mirror disk",       "glass disk", "glass mesh",
                            "mirror + glass", "glass SDF torus", "mirror SDF box", "six mixed"};
    for (int kind = 0; kind < 2; ++kind)
        for (int c = 0; c < 8; ++c) {
            spc_scene *sc = spc_scene_create();
            spc_vec3 x, aim;
            int nv;
            switch (c) {
            case 0:
                tu_cylinder(sc, spc_v3(0, 0, -2), spc_v3(0.3, 0.2, 2), 0.8, tu_glass(sc, 1.6));
                x = spc_v3(3, 0.5, 0.4), aim = spc_v3(0.1, 0.1, 0), nv = 2;
                break;
            case 1:
                tu_disk(sc, tu_place(spc_v3(1.5, 1.5, 1.5), spc_v3(1, 1, 0), 30, spc_v3(0.1, 0.2, -0.3)), tu_mirror(sc));
                x = spc_v3(0.5, -0.4, 3), aim = spc_v3(0.3, 0.2, -0.3), nv = 1;
                break;
            case 2:
                tu_disk(sc, tu_place(spc_v3(1.5, 1.5, 1.5), spc_v3(1, 1, 0), 30, spc_v3(0.1, 0.2, -0.3)),
                         tu_glass(sc, 1.33));
                x = spc_v3(0.5, -0.4, 3), aim = spc_v3(0.3, 0.2, -0.3), nv = 1;
                break;
            case 3:
                tu_mesh_sphere(sc, spc_v3(0, 0, 0), 1.0, 1.0, 48, 32, tu_glass(sc, 1.5));
                x = spc_v3(2.5, 0.7, -1.1), aim = spc_v3(0.1, 0.1, 0), nv = 2;
                break;
            case 4:
                tu_disk(sc, tu_place(spc_v3(2, 2, 2), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), tu_mirror(sc));
                tu_sphere(sc, spc_v3(1.2, 0, 3.0), 0.7, tu_glass(sc, 1.5));
                x = spc_v3(-1, 0.1, 3), aim = spc_v3(0.15, 0.05, 0), nv = 3;
                break;
            case 5: {
                /* the tube of the torus (around its local y axis), in and out */
                spc_mat4 M = tu_place(spc_v3(1, 1, 1), spc_v3(1, 0.3, 0), 50, spc_v3(0.1, -0.2, 0.3));
                add_sdf(sc, SPC_SDF_TORUS, &M, tu_glass(sc, 1.5));
                x = spc_v3(2.5, 1.5, 2.0), aim = spc_mat4_apply_point(&M, spc_v3(1.0, 0, 0)), nv = 2;
                break;
            }
            case 6: {
                spc_mat4 M = tu_place(spc_v3(1, 1, 1), spc_v3(0, 0, 1), 20, spc_v3(0, 0, 0));
                add_sdf(sc, SPC_SDF_ROUNDBOX, &M, tu_mirror(sc));
                x = spc_v3(0.3, -0.2, 2.5), aim = spc_mat4_apply_point(&M, spc_v3(0.72, 0.0, 0.25)), nv = 1;
                break;
            }
            default:
                tu_cube(sc, tu_place(spc_v3(3, 3, 0.1), spc_v3(0, 0, 1), 0, spc_v3(0, 0, 0.9)), tu_glass(sc, 1.5));
                tu_rect(sc, tu_place(spc_v3(4, 4, 1), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), tu_mirror(sc));
                tu_sphere(sc, spc_v3(2.2, 0, 3.0), 0.7, tu_mirror(sc));
                x = spc_v3(-1.2, 0.05, 2.0), aim = spc_v3(0, 0, 0), nv = 6;
                break;
            }
            CHECK(tu_finalize(sc));
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
            if (ok && c == 7) {
                /* the solved chain keeps the mixed sequence: two reflections (floor, sphere) */
                int nr = 0;
                for (int i = 0; i < p.n; ++i)
                    nr += p.v[i].event == SPC_CHAIN_REFLECT;
                CHECK_MSG(nr == 2 && p.v[2].event == SPC_CHAIN_REFLECT && p.v[5].event == SPC_CHAIN_REFLECT,
                          "six mixed: %d reflections", nr);
            }
            spc_scene_destroy(sc);
        }
}

/* ---- block LU against a dense solve ---- */

/* Gaussian elimination with partial pivoting on the dense m x m system (m <= 16). */
static bool dense_solve(int m, double M[16][16], double r[16], double out[16])
{
    for (int c = 0; c < m; ++c) {
        int piv = c;
        for (int i = c + 1; i < m; ++i)
            if (fabs(M[i][c]) > fabs(M[piv][c]))
                piv = i;
        if (M[piv][c] == 0.0)
            return false;
        for (int j = 0; j < m; ++j) {
            double t = M[c][j];
            M[c][j] = M[piv][j];
            M[piv][j] = t;
        }
        double t = r[c];
        r[c] = r[piv];
        r[piv] = t;
        for (int i = c + 1; i < m; ++i) {
            double f = M[i][c] / M[c][c];
            for (int j = c; j < m; ++j)
                M[i][j] -= f * M[c][j];
            r[i] -= f * r[c];
        }
    }
    for (int i = m - 1; i >= 0; --i) {
        double acc = r[i];
        for (int j = i + 1; j < m; ++j)
            acc -= M[i][j] * out[j];
        out[i] = acc / M[i][i];
    }
    return true;
}

TEST(block_lu_equals_dense)
{
    /* [0]: diagonally dominant systems, [1]: random ones (no pivoting between blocks loses digits
     * when an eliminated pivot block is nearly singular; dense elimination pivots) */
    int tested[2] = {0, 0};
    double worst[2] = {0.0, 0.0};
    for (int trial = 0; trial < 2000; ++trial) {
        int n = 1 + trial % SPC_CHAIN_MAX_VERTICES, kind = trial % 2;
        double A[SPC_CHAIN_MAX_VERTICES][2][2], B[SPC_CHAIN_MAX_VERTICES][2][2], C[SPC_CHAIN_MAX_VERTICES][2][2];
        double R[SPC_CHAIN_MAX_VERTICES][2], X[SPC_CHAIN_MAX_VERTICES][2];
        double M[16][16], r[16], xd[16];
        memset(M, 0, sizeof M);
        /* rows scaled over two orders of magnitude, as the constraint blocks of vertices at
         * different distances are */
        for (int i = 0; i < n; ++i)
            for (int a = 0; a < 2; ++a) {
                double sc = pow(10.0, 2 * rnd() - 1);
                for (int b = 0; b < 2; ++b) {
                    A[i][a][b] = i > 0 ? sc * (2 * rnd() - 1) : 0.0;
                    B[i][a][b] = sc * (2 * rnd() - 1) + (a == b && kind == 0 ? 4.0 * sc : 0.0);
                    C[i][a][b] = i < n - 1 ? sc * (2 * rnd() - 1) : 0.0;
                    if (i > 0)
                        M[2 * i + a][2 * (i - 1) + b] = A[i][a][b];
                    M[2 * i + a][2 * i + b] = B[i][a][b];
                    if (i < n - 1)
                        M[2 * i + a][2 * (i + 1) + b] = C[i][a][b];
                }
                R[i][a] = r[2 * i + a] = 2 * rnd() - 1;
            }
        bool ok = spc_newton_block_solve(n, (const double(*)[2][2])A, (const double(*)[2][2])B,
                                         (const double(*)[2][2])C, (const double(*)[2])R, X);
        if (!dense_solve(2 * n, M, r, xd))
            continue;
        double xmax = 0.0, err = 0.0;
        for (int i = 0; i < 2 * n; ++i) {
            xmax = spc_max(xmax, fabs(xd[i]));
            err = spc_max(err, fabs(xd[i] - X[i / 2][i % 2]));
        }
        if (kind == 1 && xmax > 1e3)
            continue; /* ill-conditioned */
        CHECK_MSG(ok, "block solve failed on a system the dense solve handles (kind %d, n %d)", kind, n);
        if (!ok)
            continue;
        ++tested[kind];
        worst[kind] = spc_max(worst[kind], err / spc_max(xmax, 1e-300));
    }
    printf("    1..%d blocks: %d diagonally dominant systems, worst relative difference %.2e; %d random, %.2e\n",
           SPC_CHAIN_MAX_VERTICES, tested[0], worst[0], tested[1], worst[1]);
    CHECK(tested[0] == 1000 && tested[1] > 700);
    CHECK_MSG(worst[0] < 1e-13, "dominant: worst %g", worst[0]);
    CHECK_MSG(worst[1] < 1e-7, "random: worst %g", worst[1]);
}

/* ---- constraint Jacobian and generalized geometry term ---- */

typedef struct chain_case {
    const char *name;
    spc_scene *sc;
    spc_vec3 x, aim;
    double spread;
    int nv;
    unsigned char events[4];
    bool forced;
    bool mesh; /* float vertices: looser tolerances */
} chain_case;

static spc_scene *case_scene(int c, chain_case *cc)
{
    spc_scene *sc = spc_scene_create();
    memset(cc, 0, sizeof *cc);
    cc->sc = sc;
    switch (c) {
    case 0:
        tu_sphere(sc, spc_v3(0.2, -0.1, 0.3), 1.0, tu_mirror(sc));
        *cc = (chain_case){"mirror sphere", sc, {3, 1, 2}, {0.2, -0.1, 0.3}, 0.2, 1, {0}, false, false};
        break;
    case 1:
        tu_sphere(sc, spc_v3(0, 0, 0), 1.0, tu_glass(sc, 1.5));
        *cc = (chain_case){"glass sphere", sc, {2.5, 0.7, -1.1}, {0, 0, 0}, 0.25, 2, {1, 1}, true, false};
        break;
    case 2:
        tu_sphere(sc, spc_v3(0, 0, 0), 1.0, tu_glass(sc, 1.5));
        *cc = (chain_case){"glass sphere TIR", sc, {2.5, 0.7, -1.1}, {0, 0, 0}, 0.25, 4, {1, 0, 0, 1}, true, false};
        break;
    case 3:
        tu_cylinder(sc, spc_v3(0, 0, -2), spc_v3(0.3, 0.2, 2), 0.8, tu_glass(sc, 1.6));
        *cc = (chain_case){"glass cylinder", sc, {3, 0.5, 0.4}, {0.15, 0.1, 0}, 0.12, 3, {1, 0, 1}, true, false};
        break;
    case 4:
        tu_disk(sc, tu_place(spc_v3(1.5, 1.5, 1.5), spc_v3(1, 1, 0), 30, spc_v3(0.1, 0.2, -0.3)), tu_glass(sc, 1.33));
        *cc = (chain_case){"glass disk", sc, {0.5, -0.4, 3}, {0.1, 0.2, -0.3}, 0.2, 1, {0}, false, false};
        break;
    case 5:
        tu_mesh_sphere(sc, spc_v3(0, 0, 0), 1.0, 1.0, 24, 16, tu_glass(sc, 1.5));
        *cc = (chain_case){"glass mesh", sc, {2.5, 0.7, -1.1}, {0, 0, 0}, 0.2, 2, {1, 1}, true, true};
        break;
    case 7: {
        spc_mat4 M = tu_place(spc_v3(1, 1, 1), spc_v3(1, 0.3, 0), 50, spc_v3(0.1, -0.2, 0.3));
        add_sdf(sc, SPC_SDF_TORUS, &M, tu_glass(sc, 1.5));
        spc_vec3 aim = spc_mat4_apply_point(&M, spc_v3(1.0, 0, 0));
        *cc = (chain_case){"glass SDF torus", sc, {2.5, 1.5, 2.0}, aim, 0.04, 2, {1, 1}, true, false};
        break;
    }
    default:
        tu_cube(sc, tu_place(spc_v3(3, 3, 0.2), spc_v3(0, 0, 1), 0, spc_v3(0, 0, 0)), tu_glass(sc, 1.6));
        tu_cube(sc, tu_place(spc_v3(3, 3, 0.2), spc_v3(0, 0, 1), 0, spc_v3(0, 0, -0.7)), tu_glass(sc, 1.6));
        *cc = (chain_case){"two slabs", sc, {0.2, 0.1, 1.5}, {0, 0, -1}, 0.3, 4, {1, 1, 1, 1}, true, true};
        break;
    }
    if (!tu_finalize(sc)) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* A random admissible chain of the case: traced from x at random parameters, with y on the
 * continuation of its final segment and a random light normal facing it. */
static bool random_chain(const chain_case *cc, spc_chain *c, spc_vec3 *y, spc_vec3 *ny)
{
    spc_hit x = tu_free_point(cc->x);
    spc_frame fr = spc_frame_from_n(spc_normalize(spc_sub(cc->aim, cc->x)));
    spc_chain_opts o = spc_chain_opts_default(cc->nv);
    o.any_surface = true;
    if (cc->forced)
        o.events = cc->events;
    for (int it = 0; it < 100; ++it) {
        double a = cc->spread * (2 * rnd() - 1), b = cc->spread * (2 * rnd() - 1);
        spc_chain_trace(cc->sc, &x, &fr, a, b, &o, c);
        if (c->n != cc->nv || !(c->end == SPC_CHAIN_END_ESCAPED || c->end == SPC_CHAIN_END_SURFACE))
            continue;
        const spc_chain_vertex *l = &c->v[c->n - 1];
        *y = spc_madd(l->h.p, l->d, 0.5 + 2 * rnd());
        spc_vec3 r = spc_normalize(spc_v3(2 * rnd() - 1, 2 * rnd() - 1, 2 * rnd() - 1));
        *ny = spc_normalize(spc_sub(r, spc_scale(l->d, 1.5))); /* facing the segment */
        return true;
    }
    return false;
}

/* Moves vertex i of p by h along its tangent basis vector j, back onto its surface by a ray along
 * -ng. False if the ray misses or lands on another triangle. */
static bool perturb(const spc_scene *sc, spc_newton_path *p, int i, spc_vec3 e, double h)
{
    spc_hit *hv = &p->v[i].h;
    double up = 1e-3 * sc->radius;
    spc_ray r = {spc_madd(spc_madd(hv->p, e, h), hv->ng, up), spc_neg(hv->ng), 0.0, 2 * up};
    spc_hit nh;
    if (!spc_chain_intersect(sc, &r, &nh) || nh.shape_index != hv->shape_index || nh.prim != hv->prim)
        return false;
    *hv = nh;
    return true;
}

#define NCASES 8

TEST(constraint_jacobian_finite_differences)
{
    for (int c = 0; c < NCASES; ++c) {
        chain_case cc;
        spc_scene *sc = case_scene(c, &cc);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        for (int variant = 0; variant < 3; ++variant) {
            /* half vector, angle difference, and half vector with rough offset normals */
            spc_newton_constraint kind = variant == 1 ? SPC_NEWTON_ANGLE_DIFF : SPC_NEWTON_HALF_VECTOR;
            double worst = 0.0;
            int checked = 0;
            for (int t = 0; t < 30; ++t) {
                static spc_chain ch;
                spc_vec3 y, ny;
                if (!random_chain(&cc, &ch, &y, &ny))
                    continue;
                spc_newton_path p;
                spc_newton_path_from_chain(&ch, &p);
                if (variant == 2) {
                    p.ref = spc_normalize(spc_v3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5));
                    for (int i = 0; i < p.n; ++i) {
                        p.v[i].rough = true;
                        p.v[i].m = spc_normalize(spc_v3(0.2 * (rnd() - 0.5), 0.2 * (rnd() - 0.5), 1));
                    }
                }
                double cv[SPC_CHAIN_MAX_VERTICES][2], A[SPC_CHAIN_MAX_VERTICES][2][2], B[SPC_CHAIN_MAX_VERTICES][2][2],
                    C[SPC_CHAIN_MAX_VERTICES][2][2], c1[SPC_CHAIN_MAX_VERTICES][2], c2[SPC_CHAIN_MAX_VERTICES][2];
                double Ad[SPC_CHAIN_MAX_VERTICES][2][2], Bd[SPC_CHAIN_MAX_VERTICES][2][2], Cd[SPC_CHAIN_MAX_VERTICES][2][2];
                spc_vec3 basis[SPC_CHAIN_MAX_VERTICES][2], bd[SPC_CHAIN_MAX_VERTICES][2];
                if (!spc_newton_constraints(cc.x, &p, y, ny, kind, cv, A, B, C, basis))
                    continue;
                const double h = 1e-6 * sc->radius;
                bool ok = true;
                double fd[SPC_CHAIN_MAX_VERTICES][SPC_CHAIN_MAX_VERTICES][2][2]; /* d c_i / d alpha_j */
                for (int j = 0; j < p.n && ok; ++j)
                    for (int b = 0; b < 2 && ok; ++b) {
                        spc_newton_path pp = p, pm = p;
                        ok = perturb(sc, &pp, j, basis[j][b], h) && perturb(sc, &pm, j, basis[j][b], -h) &&
                             spc_newton_constraints(cc.x, &pp, y, ny, kind, c1, Ad, Bd, Cd, bd) &&
                             spc_newton_constraints(cc.x, &pm, y, ny, kind, c2, Ad, Bd, Cd, bd);
                        for (int i = 0; i < p.n && ok; ++i)
                            for (int a = 0; a < 2; ++a)
                                fd[i][j][a][b] = (c1[i][a] - c2[i][a]) / (2 * h);
                    }
                if (!ok)
                    continue;
                /* y moves in its plane: no projection needed */
                spc_frame fy = spc_frame_from_n(ny);
                double fdy[2][2];
                for (int b = 0; b < 2; ++b) {
                    spc_vec3 e = b ? fy.t : fy.s;
                    spc_newton_constraints(cc.x, &p, spc_madd(y, e, h), ny, kind, c1, Ad, Bd, Cd, bd);
                    spc_newton_constraints(cc.x, &p, spc_madd(y, e, -h), ny, kind, c2, Ad, Bd, Cd, bd);
                    for (int a = 0; a < 2; ++a)
                        fdy[a][b] = (c1[p.n - 1][a] - c2[p.n - 1][a]) / (2 * h);
                }
                double jmax = 0.0, err = 0.0;
                for (int i = 0; i < p.n; ++i)
                    for (int j = 0; j < p.n; ++j)
                        for (int a = 0; a < 2; ++a)
                            for (int b = 0; b < 2; ++b) {
                                double an = j == i - 1 ? A[i][a][b] : j == i ? B[i][a][b] : j == i + 1 ? C[i][a][b] : 0.0;
                                jmax = spc_max(jmax, fabs(an));
                                err = spc_max(err, fabs(an - fd[i][j][a][b]));
                            }
                for (int a = 0; a < 2; ++a)
                    for (int b = 0; b < 2; ++b)
                        err = spc_max(err, fabs(C[p.n - 1][a][b] - fdy[a][b]));
                worst = spc_max(worst, err / jmax);
                ++checked;
            }
            double tol = cc.mesh ? 1e-4 : 1e-6;
            printf("    %-16s %s%s: %d chains, worst relative error %.2e\n", cc.name, kind_name(kind),
                   variant == 2 ? " (rough)" : "", checked, worst);
            CHECK_MSG(checked >= 10, "%s: only %d chains", cc.name, checked);
            CHECK_MSG(worst < tol, "%s %s: worst %g", cc.name, kind_name(kind), worst);
        }
        spc_scene_destroy(sc);
    }
}

TEST(geometry_term_matches_chain)
{
    for (int c = 0; c < NCASES; ++c) {
        chain_case cc;
        spc_scene *sc = case_scene(c, &cc);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        double worst[2] = {0, 0};
        int checked = 0;
        for (int t = 0; t < 60; ++t) {
            static spc_chain ch;
            spc_vec3 y, ny;
            if (!random_chain(&cc, &ch, &y, &ny))
                continue;
            spc_newton_path p;
            spc_newton_path_from_chain(&ch, &p);
            double Gc = spc_chain_geometry(&ch, y, ny);
            if (!(Gc > 0.0))
                continue;
            for (int kind = 0; kind < 2; ++kind) {
                double Gn = spc_newton_geometry(cc.x, &p, y, ny, kind);
                worst[kind] = spc_max(worst[kind], fabs(Gn - Gc) / Gc);
            }
            ++checked;
        }
        /* the chain's rays leave each vertex from an offset origin (1e-9 relative for analytic
         * shapes, ~1e-6 for float meshes), so its polyline satisfies the constraints only to about
         * that size: |c| ~ 4e-7 on the meshes here, which the focusing of the chain amplifies 10 to
         * 100 times in G */
        double tol = cc.mesh ? 1e-3 : 1e-6;
        printf("    %-16s %d vertices: %d chains, worst relative difference %.2e (half vector), %.2e (angle diff)\n",
               cc.name, cc.nv, checked, worst[0], worst[1]);
        CHECK_MSG(checked >= 30, "%s: only %d chains", cc.name, checked);
        CHECK_MSG(worst[0] < tol && worst[1] < tol, "%s: %g %g", cc.name, worst[0], worst[1]);
        spc_scene_destroy(sc);
    }
}

/* The generalized geometry term against finite differences of re-solved paths: y moves by +-h
 * along the two axes of its plane, Newton re-solves from the solution, and the direction w from x
 * to the first vertex sweeps the solid angle |dw/ds x dw/dt| per unit area of y. Cases whose
 * normals are smooth (analytic shapes, the SDF, flat slabs; a tessellated sphere's interpolated
 * normals bend at triangle edges, which a difference may straddle). */
TEST(geometry_term_finite_differences)
{
    spc_rng_seed(&rng, 2012, 6); /* its own stream: the same chains when run alone */
    for (int c = 0; c < NCASES; ++c) {
        chain_case cc;
        spc_scene *sc = case_scene(c, &cc);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        if (c == 5) {
            spc_scene_destroy(sc);
            continue;
        }
        spc_hit hx = tu_free_point(cc.x);
        for (int kind = 0; kind < 2; ++kind) {
            spc_newton_options o;
            spc_newton_options_default(&o);
            o.constraint = (spc_newton_constraint)kind;
            o.tol_scene = 1e-14; /* the differences divide the solve's error by h */
            const double h = 1e-6 * sc->radius;
            double worst = 0.0;
            int checked = 0;
            for (int t = 0; t < 20; ++t) {
                static spc_chain ch;
                spc_vec3 y, ny;
                if (!random_chain(&cc, &ch, &y, &ny))
                    continue;
                spc_newton_path p;
                spc_newton_result res;
                spc_newton_path_from_chain(&ch, &p);
                if (!spc_newton_solve(sc, &hx, y, &p, &o, &res))
                    continue;
                double G = spc_newton_geometry(cc.x, &p, y, ny, o.constraint);
                spc_frame fy = spc_frame_from_n(ny);
                bool ok = G > 0.0;
                double Gh[2] = {0, 0}; /* central differences at h and h / 2 */
                for (int level = 0; level < 2 && ok; ++level) {
                    double hl = level ? 0.5 * h : h;
                    spc_vec3 dw[2];
                    for (int b = 0; b < 2 && ok; ++b) {
                        spc_vec3 w[2];
                        for (int sgn = 0; sgn < 2 && ok; ++sgn) {
                            spc_newton_path q = p;
                            spc_vec3 yq = spc_madd(y, b ? fy.t : fy.s, sgn ? -hl : hl);
                            ok = spc_newton_solve(sc, &hx, yq, &q, &o, &res) && q.n == p.n;
                            for (int i = 0; i < q.n && ok; ++i)
                                ok = q.v[i].h.shape_index == p.v[i].h.shape_index && q.v[i].event == p.v[i].event;
                            w[sgn] = spc_normalize(spc_sub(q.v[0].h.p, cc.x));
                        }
                        dw[b] = spc_scale(spc_sub(w[0], w[1]), 1.0 / (2 * hl));
                    }
                    Gh[level] = spc_length(spc_cross(dw[0], dw[1]));
                }
                if (!ok)
                    continue;
                /* Richardson: the O(h^2) truncation error, large near the ball's caustic where G
                 * is large (3e-4 there at h = 1e-6, 7e-2 at h = 1e-4), cancels */
                double Gfd = Gh[1] + (Gh[1] - Gh[0]) / 3.0;
                worst = spc_max(worst, fabs(G - Gfd) / Gfd);
                ++checked;
            }
            printf("    %-16s %s: %d chains, worst relative difference %.2e\n", cc.name, kind_name(kind), checked,
                   worst);
            CHECK_MSG(checked >= 10, "%s: only %d chains", cc.name, checked);
            CHECK_MSG(worst < 1e-5, "%s %s: worst %g", cc.name, kind_name(kind), worst);
        }
        spc_scene_destroy(sc);
    }
}

/* The specular_nee setting's options (spc_snee_parse): what --specular-nee and the XML integrator's
 * specular_nee accept. */
TEST(parse_specular_nee_options)
{
    spc_snee_params p;
    CHECK(spc_snee_parse("newton", 2, &p) && p.solver == SPC_SNEE_NEWTON && !p.biased && !p.newton.rough &&
          p.seed == SPC_SNEE_SEED_CONE && p.max_chain == 2);
    CHECK(spc_snee_parse("angular:seed=shape", 2, &p) && p.seed == SPC_SNEE_SEED_SHAPE);
    CHECK(spc_snee_parse("angular:seed=cone", 2, &p) && p.seed == SPC_SNEE_SEED_CONE);
    CHECK(spc_snee_parse("newton:biased", 3, &p) && p.biased && p.biased_seeds > 0 && p.max_chain == 3);
    CHECK(spc_snee_parse("newton:biased=5,seed=light,constraint=half,trials=7,rough", 2, &p) && p.biased &&
          p.biased_seeds == 5 && p.seed == SPC_SNEE_SEED_LIGHT && p.newton.constraint == SPC_NEWTON_HALF_VECTOR &&
          p.max_trials == 7 && p.newton.rough);
    CHECK(spc_snee_parse("angular:biased=2,unbiased,seed=bsdf", 2, &p) && p.solver == SPC_SNEE_ANGULAR && !p.biased &&
          p.seed == SPC_SNEE_SEED_BSDF);
    CHECK(spc_snee_parse("", 2, &p) && p.solver == SPC_SNEE_NONE);
    CHECK(spc_snee_parse("angular", 2, &p) && p.reflect && p.mis_solve == 0.1 && !p.camera && p.receivers == 0);
    CHECK(spc_snee_parse("conic", 2, &p) && p.reflect);
    CHECK(spc_snee_parse("newton", 2, &p) && !p.reflect && p.mis_solve == 0.1);
    CHECK(spc_snee_parse("angular:noreflect", 2, &p) && !p.reflect);
    CHECK(spc_snee_parse("newton:rough", 2, &p) && p.newton.rough && !p.reflect);
    CHECK(spc_snee_parse("angular:reflect", 2, &p) && p.reflect && p.reflect_p > 0.0 && p.reflect_p < 1.0);
    CHECK(spc_snee_parse("newton:reflect=0.05,mispsi=0.25", 2, &p) && p.reflect && p.reflect_p == 0.05 &&
          p.mis_solve == 0.25);
    CHECK(spc_snee_parse("conic:reflect=0.5,mispsi=1", 2, &p) && p.reflect && p.reflect_p == 0.5 && p.mis_solve == 1.0);
    CHECK(spc_snee_parse("angular", 2, &p) && p.receivers == 0);
    CHECK(spc_snee_parse("angular:receivers=1", 2, &p) && p.receivers == 1);
    CHECK(spc_snee_parse("angular", 2, &p) && !p.camera);
    CHECK(spc_snee_parse("newton:camera,reflect", 2, &p) && p.camera && p.reflect && p.camera_p == 1.0);
    CHECK(spc_snee_parse("angular:camera=0.25", 2, &p) && p.camera && p.camera_p == 0.25);
    CHECK(spc_snee_parse("angular", 2, &p) && p.exact && p.max_chain == 2);
    CHECK(spc_snee_parse("newton:noexact", 2, &p) && !p.exact);
    CHECK(spc_snee_parse("conic:noexact,exact,chain=4", 2, &p) && p.exact && p.max_chain == 4);
    CHECK(spc_snee_parse("newton:rough", 2, &p) && !p.exact);
    CHECK(spc_snee_parse("angular", 2, &p) && p.long_p > 0.0 && p.long_p < 1.0);
    CHECK(spc_snee_parse("newton:long=0.5", 2, &p) && p.long_p == 0.5);
    CHECK(spc_snee_parse("conic:long=1,nolong", 2, &p) && p.long_p == 0.0);
    CHECK(spc_snee_parse("angular", 2, &p) && p.guide == 0.0 && p.snee_p == 1.0);
    CHECK(spc_snee_parse("angular:guide", 2, &p) && p.guide == 1.0 && p.snee_p == 1.0);
    CHECK(spc_snee_parse("newton:guide=1.5,sneep=0.1", 2, &p) && p.guide == 1.5 && p.snee_p == 0.1);
    CHECK(spc_snee_parse("conic:guide=3,noguide", 2, &p) && p.guide == 0.0);
    /* mistakes are refused, not ignored */
    const char *bad[] = {"newtn", "newton:", "newton:biased=0", "newton:biased=x", "newton:seed=sun",
                         "newton:fast", "angular:rough", "angular:constraint=half", "none:biased",
                         "newton:trials=", "newton:biased=8,,rough", "angular:reflect=1", "angular:reflect=0",
                         "angular:reflect=x",
                         "angular:reflect=", "angular:mispsi=0", "angular:mispsi=1.5", "angular:mispsi",
                         "newton:rough,reflect", "angular:receivers=0", "angular:receivers",
                         "angular:chain=0", "angular:chain=9", "angular:chain", "angular:spheres",
                         "angular:long=0", "angular:long=1.5", "angular:long", "angular:long=x", "angular:guide=0",
                         "angular:guide=101", "angular:guide=x", "angular:sneep=0", "angular:sneep=1.5",
                         "angular:sneep", "angular:camera=0", "angular:camera=1.5", "angular:camera=x",
                         "angular:camera="};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i)
        CHECK_MSG(!spc_snee_parse(bad[i], 2, &p), "'%s' accepted", bad[i]);
}

/* ---- specular NEE at a point against brute force ---- */

/* A diffuse floor (z = 0, albedo 0.8), a disk light of radius rl at lp facing down (radiance 5),
 * and casters: 0 a vertical mirror, 1 a glass slab, 2 a glass ball, 3 a rough vertical mirror,
 * 4 a rough glass ball, 5 a rough glass slab. */
static spc_scene *point_scene(int kind, double rl, spc_vec3 lp)
{
    spc_scene *sc = spc_scene_create();
    tu_rect(sc, tu_place(spc_v3(4, 4, 1), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), tu_diffuse(sc, 0.8));
    spc_shape *light = tu_disk(sc, tu_place(spc_v3(rl, rl, rl), spc_v3(1, 0, 0), 180, lp), tu_diffuse(sc, 0.0));
    tu_area(sc, light, 1, 5.0);
    spc_mat4 slab = tu_place(spc_v3(2.5, 2.5, 0.25), spc_v3(0, 0, 1), 0, spc_v3(0, 0, 1.0));
    spc_mat4 wall = tu_place(spc_v3(3, 3, 1), spc_v3(0, 1, 0), 90, spc_v3(0, 0, 1.5));
    switch (kind) {
    case 0: tu_rect(sc, wall, tu_mirror(sc)); break;
    case 1: tu_cube(sc, slab, tu_glass(sc, 1.5)); break;
    case 2: tu_sphere(sc, spc_v3(0.1, 0.0, 0.8), 0.6, tu_glass(sc, 1.5)); break;
    case 3: tu_rect(sc, wall, mk_rough(sc, SPC_BSDF_ROUGHCONDUCTOR, 0, 0.2)); break;
    case 4: tu_sphere(sc, spc_v3(0.1, 0.0, 0.8), 0.6, mk_rough(sc, SPC_BSDF_ROUGHDIELECTRIC, 1.5, 0.08)); break;
    default: tu_cube(sc, slab, mk_rough(sc, SPC_BSDF_ROUGHDIELECTRIC, 1.5, 0.15)); break;
    }
    if (!tu_finalize(sc)) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* Brute force over the same paths: cosine-sampled directions from x, then at every caster the
 * BSDF sampled, kept only when it samples the chain's event (conductors reflect, dielectrics
 * transmit, delta or glossy), ending on the light after 1..max_chain casters. */
static void brute_force(const spc_scene *sc, const spc_hit *x, int max_chain, int n, double *mean, double *se)
{
    double s1 = 0, s2 = 0;
    for (int i = 0; i < n; ++i) {
        spc_vec3 l = spc_warp_cosine_hemisphere(spc_v2(rnd(), rnd()));
        spc_vec3 d = spc_frame_to_world(&x->sh, l);
        spc_ray r = spc_hit_spawn(x, d);
        /* f cos / pdf of the receiver (its albedo for a diffuse one) */
        double w = spc_bsdf_eval(x->bsdf, x, SPC_MODE_RADIANCE, x->sh.n, d).r * SPC_PI, v = 0;
        for (int k = 0; k <= max_chain; ++k) {
            spc_hit h;
            if (!spc_scene_intersect(sc, &r, &h))
                break;
            if (h.emitter) {
                if (k >= 1)
                    v = w * spc_emitter_eval_area(h.emitter, &h, spc_neg(r.d)).r;
                break;
            }
            const spc_bsdf *b = h.bsdf;
            bool refl = b->type == SPC_BSDF_CONDUCTOR || b->type == SPC_BSDF_ROUGHCONDUCTOR;
            bool refr = b->type == SPC_BSDF_DIELECTRIC || b->type == SPC_BSDF_ROUGHDIELECTRIC;
            if (!refl && !refr)
                break;
            spc_bsdf_sample bs;
            if (!spc_bsdf_sample_dir(b, &h, SPC_MODE_RADIANCE, spc_neg(r.d), rnd(), spc_v2(rnd(), rnd()), &bs))
                break;
            unsigned want = refl ? SPC_LOBE_DELTA_REFLECTION | SPC_LOBE_GLOSSY_REFLECTION
                                 : SPC_LOBE_DELTA_TRANSMISSION | SPC_LOBE_GLOSSY_TRANSMISSION;
            if (!(bs.lobe & want))
                break;
            w *= bs.weight.r;
            r = spc_hit_spawn(&h, bs.wi);
        }
        s1 += v;
        s2 += v * v;
    }
    *mean = s1 / n;
    *se = sqrt(spc_max(s2 / n - *mean * *mean, 0.0) / n);
}

static bool floor_hit(const spc_scene *sc, spc_vec3 above, spc_hit *h)
{
    spc_ray r = {above, spc_v3(0, 0, -1), 0, INFINITY};
    return spc_scene_intersect(sc, &r, h) && h->shape_index == 0;
}

typedef struct point_run {
    int seed;
    bool biased, rough;
    spc_newton_constraint kind;
    int biased_seeds; /* 0: the default */
} point_run;

static void point_estimate(const spc_scene *sc, const spc_hit *x, int max_chain, const point_run *pr, int N,
                           double *mean, double *se, spc_snee_stats *st)
{
    spc_snee_params p;
    spc_snee_params_default(&p, SPC_SNEE_NEWTON, max_chain);
    p.seed = (spc_snee_seed)pr->seed;
    p.biased = pr->biased;
    p.newton.rough = pr->rough;
    p.newton.constraint = pr->kind;
    p.exact = false;   /* newton's own attempts on the glass ball (its enumeration: test_manifold.c) */
    if (pr->biased_seeds > 0)
        p.biased_seeds = pr->biased_seeds;
    memset(st, 0, sizeof *st);
    spc_rng r;
    spc_rng_seed(&r, 99 + (uint64_t)pr->seed, (uint64_t)N);
    double s1 = 0, s2 = 0;
    for (int i = 0; i < N; ++i) {
        double v = spc_specular_nee(sc, &p, x, spc_v3(0, 0, 1), max_chain, &r, st).r;
        s1 += v;
        s2 += v * v;
    }
    *mean = s1 / N;
    *se = sqrt(spc_max(s2 / N - *mean * *mean, 0.0) / N);
}

TEST(snee_point_estimates)
{
    const char *names[3] = {"mirror", "glass slab", "glass ball"};
    const spc_vec3 xs[3] = {{1, 0.3, 0}, {0.2, -0.1, 0}, {0.15, 0.05, 0}};
    const spc_vec3 lps[3] = {{2, 0, 2}, {0.5, 0.2, 2.5}, {0.0, 0.1, 3.0}};
    const double rls[3] = {0.2, 0.4, 0.5};
    for (int kind = 0; kind < 3; ++kind) {
        spc_scene *sc = point_scene(kind, rls[kind], lps[kind]);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_hit x;
        CHECK(floor_hit(sc, spc_add(xs[kind], spc_v3(0, 0, 0.05)), &x));
        double ref, ref_se;
        brute_force(sc, &x, 2, kind == 0 ? 200000 : 400000, &ref, &ref_se);
        /* unbiased with every seed (the straight line only where it meets the caster: the slab),
         * both constraint kinds; biased where every solution is easy to find */
        const point_run runs[] = {{SPC_SNEE_SEED_SHAPE, false, false, SPC_NEWTON_HALF_VECTOR, 0},
                                  {SPC_SNEE_SEED_SHAPE, false, false, SPC_NEWTON_ANGLE_DIFF, 0},
                                  {SPC_SNEE_SEED_BSDF, false, false, SPC_NEWTON_HALF_VECTOR, 0},
                                  {SPC_SNEE_SEED_LIGHT, false, false, SPC_NEWTON_HALF_VECTOR, 0},
                                  {SPC_SNEE_SEED_SHAPE, true, false, SPC_NEWTON_ANGLE_DIFF, 0},
                                  {SPC_SNEE_SEED_CONE, false, false, SPC_NEWTON_ANGLE_DIFF, 0}};
        double unbiased_se = 0.0;
        for (int ri = 0; ri < 6; ++ri) {
            const point_run *pr = &runs[ri];
            if (pr->seed == SPC_SNEE_SEED_LIGHT && kind != 1)
                continue;
            if (pr->biased && kind == 2)
                continue; /* the ball's second solution is rare from shape seeds: biased loses it (below) */
            double m, se;
            spc_snee_stats st;
            point_estimate(sc, &x, 2, pr, kind == 0 ? 5000 : 20000, &m, &se, &st);
            if (ri == 1)
                unbiased_se = se;
            if (pr->biased && kind == 1)
                /* one solution, found by most seeds but not all (1.2 trials per solution): the biased
                 * sum has no trial count's spread */
                CHECK_MSG(se < 0.5 * unbiased_se, "slab: biased se %.3g not below unbiased %.3g", se, unbiased_se);
            double tol = 4.0 * sqrt(se * se + ref_se * ref_se) + 1e-4 * ref;
            printf("    %-10s seed %d %s%s: snee %.5f +- %.5f, brute force %.5f +- %.5f; solved %.2f, "
                   "trials/solution %.2f, capped %llu\n",
                   names[kind], pr->seed, kind_name(pr->kind), pr->biased ? " biased" : "", m, se, ref, ref_se,
                   (double)st.solved / (double)st.calls,
                   st.contributions ? (double)st.trials / (double)st.contributions : 0.0,
                   (unsigned long long)st.capped);
            CHECK_MSG(fabs(m - ref) <= tol, "%s, seed %d: %.6f vs %.6f", names[kind], pr->seed, m, ref);
            CHECK(ref > 0.0 && st.contributions > 0);
        }
        if (kind == 2) {
            /* the biased estimator where one of the ball's two solutions is rarely found from shape
             * seeds: with one seed per light sample it loses that solution's energy most of the
             * time; more seeds recover it (the bias shrinks, never changes sign), while the
             * unbiased estimator above matched */
            double m[2], se[2];
            const int seeds[2] = {1, 32}, N[2] = {4000, 2000};
            for (int j = 0; j < 2; ++j) {
                point_run pr = {SPC_SNEE_SEED_SHAPE, true, false, SPC_NEWTON_ANGLE_DIFF, seeds[j]};
                spc_snee_stats st;
                point_estimate(sc, &x, 2, &pr, N[j], &m[j], &se[j], &st);
                printf("    %-10s biased, %2d seeds: snee %.5f +- %.5f (brute force %.5f +- %.5f)\n", names[kind],
                       seeds[j], m[j], se[j], ref, ref_se);
            }
            double tol1 = 4.0 * sqrt(se[0] * se[0] + ref_se * ref_se);
            CHECK_MSG(m[0] < ref - tol1, "biased, 1 seed: %.5f not below %.5f", m[0], ref);
            CHECK_MSG(m[1] > m[0] + 4.0 * sqrt(se[0] * se[0] + se[1] * se[1]), "biased: 32 seeds %.5f, 1 seed %.5f",
                      m[1], m[0]);
            CHECK_MSG(m[1] < ref + 4.0 * sqrt(se[1] * se[1] + ref_se * ref_se), "biased, 32 seeds: %.5f above %.5f",
                      m[1], ref);
        }
        spc_scene_destroy(sc);
    }
}

TEST(rough_point_estimates)
{
    const char *names[3] = {"rough mirror", "rough glass ball", "rough glass slab"};
    const spc_vec3 xs[3] = {{1, 0.3, 0}, {0.25, 0.05, 0}, {0.2, -0.1, 0}};
    const spc_vec3 lps[3] = {{2, 0, 2}, {0.0, 0.1, 3.0}, {0.5, 0.2, 2.5}};
    const double rls[3] = {0.2, 0.5, 0.4};
    for (int kind = 0; kind < 3; ++kind) {
        spc_scene *sc = point_scene(3 + kind, rls[kind], lps[kind]);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_hit x;
        CHECK(floor_hit(sc, spc_add(xs[kind], spc_v3(0, 0, 0.05)), &x));
        double ref, ref_se;
        brute_force(sc, &x, 2, 400000, &ref, &ref_se);
        /* rough off: no chain through rough surfaces */
        point_run off = {SPC_SNEE_SEED_SHAPE, false, false, SPC_NEWTON_HALF_VECTOR, 0};
        double m, se;
        spc_snee_stats st;
        point_estimate(sc, &x, 2, &off, 2000, &m, &se, &st);
        CHECK(m == 0.0);
        for (int k = 0; k < 2; ++k) {
            point_run pr = {SPC_SNEE_SEED_SHAPE, false, true, (spc_newton_constraint)k, 0};
            point_estimate(sc, &x, 2, &pr, 12000, &m, &se, &st);
            double tol = 4.0 * sqrt(se * se + ref_se * ref_se) + 1e-4 * ref;
            printf("    %-16s %s: snee %.5f +- %.5f, brute force %.5f +- %.5f; solved %.2f, trials/solution %.2f, "
                   "capped %llu\n",
                   names[kind], kind_name(k), m, se, ref, ref_se, (double)st.solved / (double)st.calls,
                   st.contributions ? (double)st.trials / (double)st.contributions : 0.0,
                   (unsigned long long)st.capped);
            CHECK_MSG(fabs(m - ref) <= tol, "%s %s: %.6f vs %.6f", names[kind], kind_name(k), m, ref);
            CHECK(ref > 0.0 && st.contributions > 0);
        }
        spc_scene_destroy(sc);
    }
}

/* An optional argument runs only the tests whose name contains it. */
#define RUNF(name)                                                                                                    \
    do {                                                                                                              \
        if (!filter || strstr(#name, filter))                                                                         \
            RUN(name);                                                                                                 \
    } while (0)

/* ---- images: path + specular NEE (newton) against ipt ---- */

/* 0: a glass sphere's caustic; 1: a water surface (bumpy mesh, interpolated normals) over a pool
 * floor; 2: two stacked glass slabs; 3: a rough glass sphere's caustic. Small films: the reference
 * is an ipt render. */
static spc_scene *image_scene(int which, spc_vec3 *region_c, double *region_r)
{
    spc_scene *sc = spc_scene_create();
    switch (which) {
    case 0: {
        /* the floor inside the ball's focal length (0.75 from its centre), so the caustic is a
         * bright converging spot without a focus on the floor (where G has an integrable
         * singularity and every estimator an infinite variance); seen through the ball from above */
        tu_rect(sc, tu_place(spc_v3(3, 3, 1), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), tu_diffuse(sc, 0.7));
        tu_sphere(sc, spc_v3(0, 0, 0.55), 0.5, tu_glass(sc, 1.5));
        spc_shape *light = tu_sphere(sc, spc_v3(0.35, 0.25, 2.2), 0.35, tu_diffuse(sc, 0.0));
        tu_area(sc, light, 2, 2.0);
        tu_camera(sc, spc_v3(0.1, -1.2, 2.6), spc_v3(0, 0, 0.2), spc_v3(0, 0, 1), 26, 24, 24);
        sc->integrator.specular_max_chain = 2;
        /* where the line from the light through the ball's centre meets the floor, and the caustic
         * around it */
        *region_c = spc_v3(-0.117, -0.083, 0);
        *region_r = 0.3;
        break;
    }
    case 1:
    case 4:
    case 5: {
        /* a pool: bumpy mesh water with interpolated normals (1), or a flat water surface under a
         * normal map (4, 5: a 16 x 16 bilinear map of tilts up to ~0.15 rad, repeated twice; every
         * chain vertex's normal comes from the map) */
        tu_rect(sc, tu_place(spc_v3(1, 1, 1), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), tu_diffuse(sc, 0.7));
        if (which == 1)
            add_water(sc, 1.3, 0.4, 0.02, 48, tu_glass(sc, 1.33));
        else
            tu_rect(sc, tu_place(spc_v3(1.3, 1.3, 1), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0.4)),
                     tu_normal_mapped(sc, tu_glass(sc, 1.33), 16, 0.15, 2.0, 3));
        spc_shape *light = tu_sphere(sc, spc_v3(0.2, 0.1, 2.0), 0.2, tu_diffuse(sc, 0.0));
        tu_area(sc, light, 2, 10.0);
        tu_camera(sc, spc_v3(0, -1.6, 2.4), spc_v3(0, 0, 0), spc_v3(0, 0, 1), 45, 24, 24);
        sc->integrator.specular_max_chain = 1;
        *region_c = spc_v3(0, 0, 0);
        *region_r = 0.8;
        break;
    }
    case 3: {
        /* scene 0 with a rough glass ball (GGX, alpha 0.03), rendered with rough chain vertices. At
         * alpha 0.1 the offset-normal estimator is heavy-tailed (rare light samples whose offset
         * chain lies near a caustic of its own): 3% of the pixels failed at 256 spp, with the means
         * of blocks over the ball and the caustic within 1.3 standard errors of ipt's */
        tu_rect(sc, tu_place(spc_v3(3, 3, 1), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), tu_diffuse(sc, 0.7));
        tu_sphere(sc, spc_v3(0, 0, 0.55), 0.5, mk_rough(sc, SPC_BSDF_ROUGHDIELECTRIC, 1.5, 0.03));
        spc_shape *light = tu_sphere(sc, spc_v3(0.35, 0.25, 2.2), 0.35, tu_diffuse(sc, 0.0));
        tu_area(sc, light, 2, 2.0);
        tu_camera(sc, spc_v3(0.1, -1.2, 2.6), spc_v3(0, 0, 0.2), spc_v3(0, 0, 1), 26, 24, 24);
        sc->integrator.specular_max_chain = 2;
        *region_c = spc_v3(-0.117, -0.083, 0);
        *region_r = 0.3;
        break;
    }
    default: {
        /* slabs wider than the floor: every floor point sees the light through four interfaces
         * only (top and bottom faces); the camera looks at the floor from under the slabs */
        tu_rect(sc, tu_place(spc_v3(1.2, 1.2, 1), spc_v3(1, 0, 0), 0, spc_v3(0, 0, 0)), tu_diffuse(sc, 0.7));
        tu_cube(sc, tu_place(spc_v3(2.5, 2.5, 0.08), spc_v3(0, 0, 1), 0, spc_v3(0, 0, 0.9)), tu_glass(sc, 1.5));
        tu_cube(sc, tu_place(spc_v3(2.5, 2.5, 0.08), spc_v3(0, 0, 1), 0, spc_v3(0, 0, 0.55)), tu_glass(sc, 1.5));
        spc_shape *light = tu_sphere(sc, spc_v3(0.3, 0.2, 2.2), 0.3, tu_diffuse(sc, 0.0));
        tu_area(sc, light, 3, 4.0);
        tu_camera(sc, spc_v3(0.1, -1.1, 0.4), spc_v3(0.1, 0.3, 0), spc_v3(0, 0, 1), 50, 24, 24);
        sc->integrator.specular_max_chain = 4;
        /* the bright disk: the light's image through the slabs */
        *region_c = spc_v3(0.25, 0.17, 0);
        *region_r = 0.5;
        break;
    }
    }
    if (!tu_finalize(sc)) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

static spc_film *render_with(const spc_scene *sc, const char *integrator, const char *snee, int spp, uint64_t seed)
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
        printf("  render failed: %s\n", err.msg);
        spc_film_destroy(f);
        return NULL;
    }
    return f;
}

/* Pixels whose camera ray (through the pixel centre) first meets the floor (shape 0) within r of c. */
static int region_mask(const spc_scene *sc, spc_vec3 c, double r, unsigned char *mask)
{
    spc_camera_state cam;
    int w = sc->film.width, h = sc->film.height, n = 0;
    if (!spc_camera_prepare(&cam, &sc->camera, w, h))
        return 0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            spc_hit hit;
            mask[j * w + i] = 0;
            spc_ray ray = spc_camera_ray(&cam, i + 0.5, j + 0.5);
            /* follow delta refractions down to the floor (the pool's and the slabs' floor) */
            for (int b = 0; b < 8 && spc_scene_intersect(sc, &ray, &hit); ++b) {
                if (hit.shape_index == 0) {
                    if (spc_distance(hit.p, c) < r) {
                        mask[j * w + i] = 1;
                        ++n;
                    }
                    break;
                }
                double eta;
                if (hit.bsdf && hit.bsdf->type == SPC_BSDF_ROUGHDIELECTRIC)
                    eta = hit.bsdf->eta; /* the rough ball: along its macro surface's refraction */
                else if (!spc_bsdf_is_specular_interface(hit.bsdf, &eta) || !(eta > 0.0))
                    break;
                double cos_t, eta_ti;
                double ci = spc_dot(spc_neg(ray.d), hit.sh.n);
                spc_fresnel_dielectric(ci, eta, &cos_t, &eta_ti);
                if (cos_t == 0.0)
                    break;
                ray = spc_hit_spawn(&hit, spc_refract(spc_neg(ray.d), hit.sh.n, cos_t, eta_ti));
            }
        }
    return n;
}

TEST(images_path_newton_vs_ipt)
{
    const char *names[6] = {"glass sphere caustic", "pool", "two slabs", "rough sphere caustic",
                            "normal-mapped pool", "normal-mapped pool"};
    const int ref_spp[6] = {8192, 8192, 8192, 8192, 8192, 8192}, snee_spp[6] = {256, 256, 256, 512, 256, 256};
    /* the rough ball at 512 spp: its rough-vertex estimator is heavy-tailed (one sample at seed 12 put
     * the caustic region 3 standard errors high at 256 spp; seeds 13-15 read -0.7 to +0.9).
     * The rough ball through rough chain vertices: the path tracer then drops the glossy paths and
     * light samples those chains cover (an error there shows as a doubled or missing caustic); the
     * normal-mapped pool with its chains enumerated (plane_chains.h: exact, the default, whichever the
     * solver) and with angular's randomized attempts */
    const char *snee[6] = {"newton", "newton", "newton", "newton:rough", "newton", "angular:noexact"};
    for (int which = 0; which < 6; which += spc_test_stride(6)) {
        /* SPC_NEWTON_ONLY=i renders only scene i, SPC_NEWTON_SNEE=setting overrides its specular
         * NEE setting (for looking at one) */
        if (getenv("SPC_NEWTON_ONLY") && atoi(getenv("SPC_NEWTON_ONLY")) != which)
            continue;
        spc_vec3 rc;
        double rr;
        spc_scene *sc = image_scene(which, &rc, &rr);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_film *ref = render_with(sc, "ipt", "none", ref_spp[which], 11);
        const char *setting = getenv("SPC_NEWTON_SNEE") ? getenv("SPC_NEWTON_SNEE") : snee[which];
        spc_film *img = render_with(sc, "path", setting, snee_spp[which], 12);
        CHECK(ref && img);
        if (ref && img && getenv("SPC_NEWTON_IMAGES")) {
            /* for looking at the scenes: SPC_NEWTON_IMAGES=dir writes dir/newton_<i>_{path,ipt}.png */
            char path[1024];
            spc_error err;
            snprintf(path, sizeof path, "%s/newton_%d_path.png", getenv("SPC_NEWTON_IMAGES"), which);
            spc_film_write_png(img, path, &err);
            snprintf(path, sizeof path, "%s/newton_%d_ipt.png", getenv("SPC_NEWTON_IMAGES"), which);
            spc_film_write_png(ref, path, &err);
            snprintf(path, sizeof path, "%s/newton_%d_path.exr", getenv("SPC_NEWTON_IMAGES"), which);
            spc_film_write_exr(img, path, true, &err);
            snprintf(path, sizeof path, "%s/newton_%d_ipt.exr", getenv("SPC_NEWTON_IMAGES"), which);
            spc_film_write_exr(ref, path, true, &err);
        }
        if (ref && img) {
            spc_image_rgb a = {img->width, img->height, img->rgb, img->var};
            spc_image_rgb b = {ref->width, ref->height, ref->rgb, ref->var};
            spc_diff_result d;
            spc_error err;
            CHECK(spc_image_diff(&a, &b, &d, &err) == SPC_OK);
            CHECK_MSG(d.has_ztest && d.ztest_pass_fraction >= 0.99, "%s: z-test pass fraction %.4f", names[which],
                      d.ztest_pass_fraction);
            /* the caustic region's mean energy */
            int w = img->width, h = img->height;
            unsigned char *mask = malloc((size_t)(w * h));
            int nreg = region_mask(sc, rc, rr, mask);
            double sa = 0, va = 0, sb = 0, vb = 0;
            for (int k = 0; k < w * h; ++k)
                if (mask[k])
                    for (int c = 0; c < 3; ++c) {
                        sa += img->rgb[3 * k + c];
                        va += img->var[3 * k + c];
                        sb += ref->rgb[3 * k + c];
                        vb += ref->var[3 * k + c];
                    }
            double m = 3.0 * nreg;
            double ma = sa / m, mb = sb / m, se = sqrt(va + vb) / m;
            printf("    %-20s z-test pass %.4f of %d pixels; caustic region (%d pixels) %.5f vs ipt %.5f (se %.5f, "
                   "%.2f se)\n",
                   names[which], d.ztest_pass_fraction, d.ztest_pixels, nreg, ma, mb, se, fabs(ma - mb) / se);
            CHECK_MSG(nreg >= 20, "%s: region of %d pixels", names[which], nreg);
            CHECK_MSG(fabs(ma - mb) <= 3.0 * se, "%s: caustic region %.5f vs %.5f (se %.2g)", names[which], ma, mb, se);
            free(mask);
        }
        spc_film_destroy(ref);
        spc_film_destroy(img);
        spc_scene_destroy(sc);
    }
}

int main(int argc, char **argv)
{
    const char *filter = argc > 1 ? argv[1] : NULL;
    spc_warn_set_quiet(1);
    spc_rng_seed(&rng, 4242, 1);
    RUNF(converges_mirror_plane);
    RUNF(converges_mirror_sphere);
    RUNF(converges_glass_sphere);
    RUNF(converges_stacked_slabs);
    RUNF(converges_other_surfaces);
    RUNF(block_lu_equals_dense);
    RUNF(constraint_jacobian_finite_differences);
    RUNF(geometry_term_matches_chain);
    RUNF(geometry_term_finite_differences);
    RUNF(parse_specular_nee_options);
    RUNF(snee_point_estimates);
    RUNF(rough_point_estimates);
    RUNF(images_path_newton_vs_ipt);
    return spc_test_finish();
}
