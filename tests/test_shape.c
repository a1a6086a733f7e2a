/*
 * tests/test_shape.c: exact intersections, surface derivatives against finite differences, and
 * area / solid-angle sampling of shapes.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "harness.h"
#include "scene/scene.h"
#include "scene/shape.h"
#include "specula/specula.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

TEST(sphere_intersection_precise)
{
    spc_shape s;
    memset(&s, 0, sizeof s);
    spc_error err;
    CHECK(spc_shape_init_sphere(&s, spc_v3(1, 2, 3), 0.5, NULL, NULL, 0, 0, &err));
    CHECK(spc_shape_prepare(&s) == SPC_OK);
    CHECK_NEAR(s.area, SPC_PI, 1e-12);
    for (int i = 0; i < 1000; ++i) {
        double dist = pow(10.0, 6.0 * rnd()); /* from 1 to 1e6 away */
        spc_vec3 dir = spc_warp_uniform_sphere(spc_v2(rnd(), rnd()));
        spc_vec3 target = spc_madd(s.center, spc_warp_uniform_sphere(spc_v2(rnd(), rnd())), 0.3);
        spc_ray r;
        r.o = spc_madd(target, dir, dist);
        r.d = spc_normalize(spc_sub(target, r.o));
        r.tmin = 0;
        r.tmax = INFINITY;
        double t, u, v;
        CHECK(spc_shape_intersect_analytic(&s, &r, &t, &u, &v));
        spc_hit h;
        spc_shape_fill_hit(&s, 0, u, v, &r, t, &h);
        CHECK_NEAR(spc_distance(h.p, s.center), 0.5, 1e-12);
        CHECK_NEAR(spc_distance(spc_madd(r.o, r.d, t), h.p), 0.0, 1e-9 * dist);
        CHECK(spc_dot(h.ng, r.d) < 0.0);
        /* a ray spawned outward from the hit does not hit the sphere again */
        spc_ray out = spc_hit_spawn(&h, spc_reflect(spc_neg(r.d), h.ng));
        CHECK(!spc_shape_intersect_analytic(&s, &out, &t, &u, &v));
        /* a ray spawned inward hits the far side, not the same point */
        spc_ray in = spc_hit_spawn(&h, r.d);
        CHECK(spc_shape_intersect_analytic(&s, &in, &t, &u, &v));
        CHECK(t > 1e-6);
    }
    spc_shape_release(&s);
}

/* Finite differences of position and unit normal with respect to the surface parameters. */
static void check_derivs_mesh(void)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    float p[9] = {0, 0, 0, 1, 0.1f, 0, 0.2f, 1, 0.3f};
    float n[9] = {0.1f, 0, 1, -0.3f, 0.2f, 1, 0.2f, -0.4f, 0.8f};
    uint32_t idx[3] = {0, 1, 2};
    m.nverts = 3;
    m.ntris = 1;
    m.p = malloc(sizeof p);
    m.n = malloc(sizeof n);
    m.idx = malloc(sizeof idx);
    memcpy(m.p, p, sizeof p);
    memcpy(m.n, n, sizeof n);
    memcpy(m.idx, idx, sizeof idx);
    spc_shape s;
    memset(&s, 0, sizeof s);
    spc_error err;
    CHECK(spc_shape_init_mesh(&s, &m, NULL, NULL, 0, 0, &err));
    CHECK(spc_shape_prepare(&s) == SPC_OK);
    spc_ray r = {spc_v3(0, 0, 1), spc_v3(0, 0, -1), 0, INFINITY};
    const double e = 1e-6;
    for (int i = 0; i < 50; ++i) {
        double b1 = 0.1 + 0.4 * rnd(), b2 = 0.1 + 0.4 * rnd();
        spc_hit h, hu, hv, hu2, hv2;
        spc_shape_fill_hit(&s, 0, b1, b2, &r, 1, &h);
        spc_shape_fill_hit(&s, 0, b1 + e, b2, &r, 1, &hu);
        spc_shape_fill_hit(&s, 0, b1 - e, b2, &r, 1, &hu2);
        spc_shape_fill_hit(&s, 0, b1, b2 + e, &r, 1, &hv);
        spc_shape_fill_hit(&s, 0, b1, b2 - e, &r, 1, &hv2);
        spc_vec3 fdu = spc_scale(spc_sub(hu.sh.n, hu2.sh.n), 0.5 / e);
        spc_vec3 fdv = spc_scale(spc_sub(hv.sh.n, hv2.sh.n), 0.5 / e);
        CHECK_NEAR(spc_distance(fdu, h.dndu), 0.0, 1e-7 * (1 + spc_length(fdu)));
        CHECK_NEAR(spc_distance(fdv, h.dndv), 0.0, 1e-7 * (1 + spc_length(fdv)));
        spc_vec3 fpu = spc_scale(spc_sub(hu.p, hu2.p), 0.5 / e);
        CHECK_NEAR(spc_distance(fpu, h.dpdu), 0.0, 1e-7);
        CHECK_NEAR(spc_length(h.sh.n), 1.0, 1e-12);
        CHECK(spc_dot(h.ng, h.sh.n) > 0.0);
    }
    spc_shape_release(&s);
}

static void sphere_point_hit(const spc_shape *s, double u, double v, spc_hit *h)
{
    double phi = 2 * SPC_PI * u, th = SPC_PI * v;
    spc_vec3 l = spc_v3(sin(th) * cos(phi), sin(th) * sin(phi), cos(th));
    spc_vec3 n = spc_mat4_apply_vector(&s->to_world, l);
    spc_vec3 p = spc_madd(s->center, n, s->radius);
    spc_ray r;
    r.o = spc_madd(p, n, 3.0);
    r.d = spc_neg(n);
    r.tmin = 0;
    r.tmax = INFINITY;
    spc_shape_fill_hit(s, 0, 0, 0, &r, 3.0, h);
}

TEST(surface_derivatives)
{
    check_derivs_mesh();
    spc_shape s;
    memset(&s, 0, sizeof s);
    spc_error err;
    spc_mat4 R = spc_mat4_rotate(spc_v3(1, 1, 0), 30);
    CHECK(spc_shape_init_sphere(&s, spc_v3(0.5, 0, 0), 2.0, &R, NULL, 0, 0, &err));
    const double e = 1e-6;
    for (int i = 0; i < 50; ++i) {
        double u = 0.05 + 0.9 * rnd(), v = 0.1 + 0.8 * rnd();
        spc_hit h, a, b, c, d;
        sphere_point_hit(&s, u, v, &h);
        CHECK_NEAR(h.uv.x, u, 1e-9);
        CHECK_NEAR(h.uv.y, v, 1e-9);
        sphere_point_hit(&s, u + e, v, &a);
        sphere_point_hit(&s, u - e, v, &b);
        sphere_point_hit(&s, u, v + e, &c);
        sphere_point_hit(&s, u, v - e, &d);
        CHECK_NEAR(spc_distance(spc_scale(spc_sub(a.p, b.p), 0.5 / e), h.dpdu), 0.0, 1e-6);
        CHECK_NEAR(spc_distance(spc_scale(spc_sub(c.p, d.p), 0.5 / e), h.dpdv), 0.0, 1e-6);
        CHECK_NEAR(spc_distance(spc_scale(spc_sub(a.ng, b.ng), 0.5 / e), h.dndu), 0.0, 1e-6);
        CHECK_NEAR(spc_distance(spc_scale(spc_sub(c.ng, d.ng), 0.5 / e), h.dndv), 0.0, 1e-6);
    }
    spc_shape_release(&s);
}

TEST(analytic_disk_and_cylinder)
{
    spc_shape d;
    memset(&d, 0, sizeof d);
    spc_error err;
    spc_mat4 T = spc_mat4_translate(spc_v3(0, 0, 2));
    spc_mat4 S = spc_mat4_scale(spc_v3(3, 3, 3));
    spc_mat4 M = spc_mat4_mul(&T, &S);
    CHECK(spc_shape_init_disk(&d, &M, NULL, 0, 0, &err));
    CHECK(spc_shape_prepare(&d) == SPC_OK);
    CHECK_NEAR(d.area, 9 * SPC_PI, 1e-9);
    spc_ray r = {spc_v3(1, 1, 5), spc_v3(0, 0, -1), 0, INFINITY};
    double t, u, v;
    CHECK(spc_shape_intersect_analytic(&d, &r, &t, &u, &v));
    CHECK_NEAR(t, 3.0, 1e-12);
    r.o = spc_v3(2.5, 2.5, 5); /* outside the radius */
    CHECK(!spc_shape_intersect_analytic(&d, &r, &t, &u, &v));

    spc_shape c;
    memset(&c, 0, sizeof c);
    CHECK(spc_shape_init_cylinder(&c, spc_v3(0, 0, 0), spc_v3(0, 0, 2), 0.5, NULL, NULL, 0, 0, &err));
    CHECK(spc_shape_prepare(&c) == SPC_OK);
    CHECK_NEAR(c.area, 2 * SPC_PI * 0.5 * 2, 1e-9);
    spc_ray rc = {spc_v3(3, 0, 1), spc_v3(-1, 0, 0), 0, INFINITY};
    CHECK(spc_shape_intersect_analytic(&c, &rc, &t, &u, &v));
    CHECK_NEAR(t, 2.5, 1e-12);
    spc_hit h;
    spc_shape_fill_hit(&c, 0, u, v, &rc, t, &h);
    CHECK_NEAR(h.ng.x, 1.0, 1e-12);
    CHECK_NEAR(h.p.z, 1.0, 1e-12);
    /* open: a ray along the axis misses */
    spc_ray ra = {spc_v3(0, 0, 5), spc_v3(0, 0, -1), 0, INFINITY};
    CHECK(!spc_shape_intersect_analytic(&c, &ra, &t, &u, &v));
    spc_shape_release(&d);
    spc_shape_release(&c);
}

/* The solid angle of a sphere, estimated by area sampling converted to solid angle, and the
 * density of cone sampling, both give 2 pi (1 - cos_max). */
TEST(sphere_sampling_solid_angle)
{
    spc_shape s;
    memset(&s, 0, sizeof s);
    spc_error err;
    CHECK(spc_shape_init_sphere(&s, spc_v3(0, 0, 0), 1.0, NULL, NULL, 0, 0, &err));
    CHECK(spc_shape_prepare(&s) == SPC_OK);
    spc_vec3 ref = spc_v3(0, 3, 0);
    double cos_max = sqrt(1 - 1.0 / 9.0);
    double exact = 2 * SPC_PI * (1 - cos_max);
    double acc = 0.0;
    const int N = 200000;
    for (int i = 0; i < N; ++i) {
        spc_shape_sample ss;
        spc_shape_sample_area(&s, spc_v2(rnd(), rnd()), &ss);
        spc_vec3 d = spc_sub(ss.p, ref);
        double dist2 = spc_length2(d);
        double c = -spc_dot(ss.n, d) / sqrt(dist2);
        if (c > 0) /* visible side */
            acc += c / dist2 / ss.pdf;
    }
    CHECK_NEAR(acc / N, exact, 0.01 * exact);
    spc_shape_sample ss;
    CHECK(spc_shape_sample_solid_angle(&s, ref, spc_v2(0.3, 0.7), true, &ss));
    CHECK_NEAR(1.0 / ss.pdf, exact, 1e-12);
    CHECK_NEAR(spc_length(ss.p), 1.0, 1e-12);
    CHECK(spc_dot(ss.n, spc_sub(ref, ss.p)) > 0.0);
    CHECK(!spc_shape_sample_solid_angle(&s, spc_v3(0, 0.5, 0), spc_v2(0.3, 0.7), true, &ss));
    /* without uv: every other field bit for bit the same */
    for (int i = 0; i < 1000; ++i) {
        spc_vec2 u = spc_v2(rnd(), rnd());
        spc_shape_sample a, b;
        CHECK(spc_shape_sample_solid_angle(&s, ref, u, true, &a));
        CHECK(spc_shape_sample_solid_angle(&s, ref, u, false, &b));
        CHECK(memcmp(&a.p, &b.p, sizeof a.p) == 0 && memcmp(&a.n, &b.n, sizeof a.n) == 0);
        CHECK(a.pdf == b.pdf && a.err == b.err && a.prim == b.prim);
        CHECK(b.uv.x == 0.0 && b.uv.y == 0.0);
        CHECK(a.uv.x >= 0.0 && a.uv.x <= 1.0 && a.uv.y >= 0.0 && a.uv.y <= 1.0);
    }
    spc_shape_release(&s);
}

/* The solid-angle sample of a sphere is the cone warp's direction: for each u, the direction from
 * the reference point to the sampled point has the cone warp's cos theta (1 - u.x (1 - cos_max))
 * and azimuth 2 pi u.y + pi in spc_frame_from_n of the axis, and the point is the ray's nearest
 * intersection with the sphere, from far (a tiny cone) to just outside the surface. */
TEST(sphere_solid_angle_sample_is_the_cone_warp)
{
    spc_shape s;
    memset(&s, 0, sizeof s);
    spc_error err;
    spc_vec3 c = spc_v3(0.5, -1.0, 2.0);
    CHECK(spc_shape_init_sphere(&s, c, 0.75, NULL, NULL, 0, 0, &err));
    CHECK(spc_shape_prepare(&s) == SPC_OK);
    const double dists[] = {0.7501, 0.8, 1.5, 4.0, 30.0, 1000.0};
    for (int k = 0; k < 6; ++k) {
        spc_vec3 ref = spc_madd(c, spc_normalize(spc_v3(0.3, -0.8, 0.5)), dists[k]);
        spc_vec3 axis = spc_normalize(spc_sub(c, ref));
        spc_frame fr = spc_frame_from_n(axis);
        double cos_max = sqrt(1.0 - 0.75 * 0.75 / spc_length2(spc_sub(c, ref)));
        double worst_cos = 0.0, worst_phi = 0.0, worst_t = 0.0;
        for (int i = 0; i < 2000; ++i) {
            spc_vec2 u = spc_v2(rnd(), rnd());
            spc_shape_sample ss;
            CHECK(spc_shape_sample_solid_angle(&s, ref, u, false, &ss));
            spc_vec3 d = spc_sub(ss.p, ref);
            double t = spc_length(d);
            spc_vec3 w = spc_scale(d, 1.0 / t);
            spc_vec3 l = spc_frame_to_local(&fr, w);
            worst_cos = fmax(worst_cos, fabs(l.z - (1.0 - u.x * (1.0 - cos_max))) / (1.0 - cos_max));
            double phi = atan2(l.y, l.x), want = 2.0 * SPC_PI * u.y - SPC_PI;
            double dphi = fabs(remainder(phi - want, 2.0 * SPC_PI));
            if (1.0 - l.z * l.z > 1e-6)
                worst_phi = fmax(worst_phi, dphi);
            /* the nearest root along w, relative to the distance */
            spc_vec3 f = spc_sub(ref, c);
            double b = spc_dot(f, w), disc = 0.75 * 0.75 - spc_length2(spc_sub(f, spc_scale(w, b)));
            double tn = -b - sqrt(fmax(disc, 0.0));
            worst_t = fmax(worst_t, fabs(t - tn) / dists[k]);
            CHECK_NEAR(spc_length(spc_sub(ss.p, c)), 0.75, 1e-12);
            CHECK(spc_dot(ss.n, spc_sub(ref, ss.p)) >= -1e-9);
        }
        CHECK_MSG(worst_cos < 1e-6, "distance %g: cos theta off by %g of the cone", dists[k], worst_cos);
        CHECK_MSG(worst_phi < 1e-6, "distance %g: azimuth off by %g", dists[k], worst_phi);
        CHECK_MSG(worst_t < 1e-6, "distance %g: not the nearest point (%g)", dists[k], worst_t);
    }
    spc_shape_release(&s);
}

/* Hits on a mesh with its kept per-triangle frames (spc_shape.tri_frame) equal, bit for bit, the
 * hits computed from the vertices alone: with and without uvs, vertex normals, flip_normals, a
 * degenerate uv map. */
static bool same_hit(const spc_hit *a, const spc_hit *b)
{
    return memcmp(&a->p, &b->p, sizeof a->p) == 0 && memcmp(&a->ng, &b->ng, sizeof a->ng) == 0 &&
           memcmp(&a->sh, &b->sh, sizeof a->sh) == 0 && memcmp(&a->uv, &b->uv, sizeof a->uv) == 0 &&
           memcmp(&a->dpdu, &b->dpdu, sizeof a->dpdu) == 0 && memcmp(&a->dpdv, &b->dpdv, sizeof a->dpdv) == 0 &&
           memcmp(&a->dndu, &b->dndu, sizeof a->dndu) == 0 && memcmp(&a->dndv, &b->dndv, sizeof a->dndv) == 0 &&
           a->err == b->err;
}

/* The two-triangle quad (bent out of its plane) of the mesh frame tests, with vertex normals where
 * `normals` and the uvs UV[0..8) where UV is not NULL; its arrays are malloc'ed, for
 * spc_shape_init_mesh to take. */
static spc_mesh quad_mesh(bool normals, const float *UV)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = 4;
    m.ntris = 2;
    m.p = malloc(12 * sizeof(float));
    m.idx = malloc(6 * sizeof(uint32_t));
    float P[12] = {0, 0, 0, 1, 0, 0.1f, 1, 1, 0, 0, 1, 0.3f};
    uint32_t I[6] = {0, 1, 2, 0, 2, 3};
    memcpy(m.p, P, sizeof P);
    memcpy(m.idx, I, sizeof I);
    if (normals) {
        float N[12] = {0, 0, 1, 0.1f, 0, 1, 0, 0.2f, 1, -0.1f, 0, 1};
        m.n = malloc(sizeof N);
        memcpy(m.n, N, sizeof N);
    }
    if (UV) {
        m.uv = malloc(8 * sizeof(float));
        memcpy(m.uv, UV, 8 * sizeof(float));
    }
    return m;
}

TEST(mesh_kept_frames_match)
{
    int checked = 0;
    for (int kind = 0; kind < 4; ++kind)
        for (int flip = 0; flip < 2; ++flip) {
            spc_shape s;
            memset(&s, 0, sizeof s);
            spc_error err;
            spc_mat4 T = {{{1, 0.2, 0, 0.5}, {0, 1.3, 0.1, -2}, {0.3, 0, 0.7, 1}, {0, 0, 0, 1}}}; /* sheared */
            if (kind == 0) {
                CHECK(spc_shape_init_cube(&s, &T, NULL, 0, 0, &err)); /* uvs */
            } else {
                /* two triangles; kind 1: no uvs, 2: vertex normals, 3: a uv map of zero area */
                static const float UV[8] = {0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f};
                spc_mesh m = quad_mesh(kind == 2, kind == 3 ? UV : NULL);
                CHECK(spc_shape_init_mesh(&s, &m, &T, NULL, 0, 0, &err));
            }
            s.flip_normals = flip != 0;
            CHECK(spc_shape_prepare(&s) == SPC_OK);
            CHECK(s.tri_frame != NULL);
            double *kept = s.tri_frame;
            for (int i = 0; i < 200; ++i) {
                int prim = (int)(rnd() * (double)s.mesh.ntris);
                double b1 = rnd(), b2 = rnd() * (1.0 - b1);
                spc_hit a, b;
                memset(&a, 0, sizeof a);
                memset(&b, 0, sizeof b);
                s.tri_frame = kept;
                spc_shape_fill_hit(&s, prim, b1, b2, NULL, 1.0, &a);
                s.tri_frame = NULL;
                spc_shape_fill_hit(&s, prim, b1, b2, NULL, 1.0, &b);
                CHECK(same_hit(&a, &b));
                ++checked;
            }
            /* flip_normals changed after the frames were kept: still the same hits */
            s.flip_normals = !s.flip_normals;
            for (int i = 0; i < 50; ++i) {
                int prim = (int)(rnd() * (double)s.mesh.ntris);
                double b1 = rnd(), b2 = rnd() * (1.0 - b1);
                spc_hit a, b;
                memset(&a, 0, sizeof a);
                memset(&b, 0, sizeof b);
                s.tri_frame = kept;
                spc_shape_fill_hit(&s, prim, b1, b2, NULL, 1.0, &a);
                s.tri_frame = NULL;
                spc_shape_fill_hit(&s, prim, b1, b2, NULL, 1.0, &b);
                CHECK(same_hit(&a, &b));
                ++checked;
            }
            s.tri_frame = kept;
            spc_shape_release(&s);
        }
    CHECK(checked == 8 * 250);
}

/* Every field of two records, each with memcmp (not the padding between them). */
static bool same_record(const spc_hit *a, const spc_hit *b)
{
#define SAME(f) (memcmp(&a->f, &b->f, sizeof a->f) == 0)
    return SAME(t) && SAME(p) && SAME(ng) && SAME(sh) && SAME(uv) && SAME(dpdu) && SAME(dpdv) && SAME(dndu) &&
           SAME(dndv) && SAME(b1) && SAME(b2) && SAME(err) && SAME(n_unmapped) && SAME(normal_mapped) &&
           SAME(prim) && SAME(shape_index) && SAME(shape) && SAME(bsdf) && SAME(emitter);
#undef SAME
}

/* The mesh of the hit-record tests below, prepared: kind 0 a cube (uvs); 1 a quad without uvs; 2
 * with vertex normals; 3 vertex normals and uvs; 4 vertex normals under face_normals; under an affine
 * transform, its normals flipped or not, its frames kept or dropped. */
static void lazy_test_mesh(spc_shape *s, int kind, bool flip, bool keep)
{
    memset(s, 0, sizeof *s);
    spc_error err;
    spc_mat4 T = {{{1, 0.2, 0, 0.5}, {0, 1.3, 0.1, -2}, {0.3, 0, 0.7, 1}, {0, 0, 0, 1}}};
    if (kind == 0) {
        CHECK(spc_shape_init_cube(s, &T, NULL, 0, 0, &err));
    } else {
        static const float UV[8] = {0, 0, 1, 0.1f, 0.9f, 1, 0.2f, 0.8f};
        spc_mesh m = quad_mesh(kind >= 2, kind == 3 ? UV : NULL);
        CHECK(spc_shape_init_mesh(s, &m, &T, NULL, 0, 0, &err));
        s->face_normals = kind == 4;
    }
    s->flip_normals = flip;
    CHECK(spc_shape_prepare(s) == SPC_OK);
    if (!keep)
        spc_shape_drop_frames(s);
}

/* A shading record (spc_shape_fill_hit_shading) on a mesh with lazy_derivs leaves the derivatives
 * out and has every other field of spc_shape_fill_hit's record; spc_shape_hit_derivatives then
 * completes it to that record, field for field. The lazy record starts from a byte pattern, so a
 * field that neither call fills differs. Meshes with and without uvs, vertex normals (also under
 * face_normals), flip_normals, kept frames or not; without lazy_derivs the shading record is whole.
 * Where the mesh's materials also read no uv (uv_unread) the shading record's uv is zero until
 * spc_shape_hit_derivatives. */
TEST(mesh_lazy_derivatives_match)
{
    int checked = 0, skipped = 0, uv_zero = 0;
    for (int kind = 0; kind < 5; ++kind)
        for (int flip = 0; flip < 2; ++flip)
            for (int keep = 0; keep < 2; ++keep)
                for (int lazy = 0; lazy < 2; ++lazy) {
                    spc_shape s;
                    lazy_test_mesh(&s, kind, flip != 0, keep != 0);
                    s.lazy_derivs = lazy != 0;
                    /* half the lazy meshes' materials read no uv: their shading records leave uv
                     * at zero, and spc_shape_hit_derivatives fills it */
                    s.uv_unread = lazy && keep;
                    for (int i = 0; i < 100; ++i) {
                        int prim = (int)(rnd() * (double)s.mesh.ntris);
                        double b1 = rnd(), b2 = rnd() * (1.0 - b1);
                        spc_hit e, l;
                        memset(&e, 0, sizeof e);
                        memset(&l, 0xA5, sizeof l);
                        spc_shape_fill_hit(&s, prim, b1, b2, NULL, 1.5, &e);
                        e.shape_index = 7;
                        spc_shape_fill_hit_shading(&s, prim, b1, b2, NULL, 1.5, &l);
                        l.shape_index = 7;
                        if (lazy) {
                            /* the derivatives were left out (still the pattern) */
                            unsigned char pat[sizeof l.dndu];
                            memset(pat, 0xA5, sizeof pat);
                            skipped += memcmp(&l.dpdu, pat, sizeof pat) == 0 && memcmp(&l.dndv, pat, sizeof pat) == 0;
                            CHECK(!same_record(&e, &l));
                            if (s.uv_unread) {
                                CHECK(l.uv.x == 0.0 && l.uv.y == 0.0);
                                uv_zero += e.uv.x != 0.0 || e.uv.y != 0.0;
                            }
                        }
                        spc_shape_hit_derivatives(&l);
                        CHECK(same_record(&e, &l));
                        ++checked;
                    }
                    spc_shape_release(&s);
                }
    CHECK(checked == 5 * 2 * 2 * 2 * 100);
    CHECK(skipped == checked / 2);
    CHECK_MSG(uv_zero > checked / 8, "%d records with uv left out", uv_zero);
}

/* A chain record (spc_shape_fill_hit_chain, what a specular solver's steps read) has every field of
 * spc_shape_fill_hit's record but uv and the tangents sh.s, sh.t, which are zero; spc_shape_hit_complete
 * then makes it that record, field for field. The chain record starts from a byte pattern, so a field
 * that neither call fills differs. Meshes with and without uvs, vertex normals (also under
 * face_normals), flip_normals, kept frames or not. */
TEST(mesh_chain_hits_complete)
{
    int checked = 0;
    for (int kind = 0; kind < 5; ++kind)
        for (int flip = 0; flip < 2; ++flip)
            for (int keep = 0; keep < 2; ++keep) {
                spc_shape s;
                lazy_test_mesh(&s, kind, flip != 0, keep != 0);
                for (int i = 0; i < 100; ++i) {
                    int prim = (int)(rnd() * (double)s.mesh.ntris);
                    double b1 = rnd(), b2 = rnd() * (1.0 - b1);
                    spc_hit e, c;
                    memset(&e, 0, sizeof e);
                    memset(&c, 0xA5, sizeof c);
                    spc_shape_fill_hit(&s, prim, b1, b2, NULL, 1.5, &e);
                    e.shape_index = 7;
                    spc_shape_fill_hit_chain(&s, prim, b1, b2, NULL, 1.5, &c);
                    c.shape_index = 7;
#define SAME(f) (memcmp(&e.f, &c.f, sizeof e.f) == 0)
                    CHECK(SAME(t) && SAME(p) && SAME(ng) && SAME(sh.n) && SAME(dpdu) && SAME(dpdv) && SAME(dndu) &&
                          SAME(dndv) && SAME(b1) && SAME(b2) && SAME(err) && SAME(n_unmapped) &&
                          SAME(normal_mapped) && SAME(prim) && SAME(shape) && SAME(bsdf) && SAME(emitter));
#undef SAME
                    CHECK(c.uv.x == 0.0 && c.uv.y == 0.0 && spc_length2(c.sh.s) == 0.0 && spc_length2(c.sh.t) == 0.0);
                    CHECK(!same_record(&e, &c));
                    spc_shape_hit_complete(&c);
                    CHECK(same_record(&e, &c));
                    ++checked;
                }
                spc_shape_release(&s);
            }
    CHECK(checked == 5 * 2 * 2 * 100);
}

/* The shading record of a mesh whose kept frames hold every field shading reads (spc_shape_fill_hit_shading's
 * straight-line fill: frames kept, no vertex normals in use, the frames kept under the shape's
 * flip_normals, the triangle's tangent not zero) is, field for field, the record the same call makes
 * from the vertices with the frames dropped, and spc_shape_hit_derivatives completes it to
 * spc_shape_fill_hit's. Both records start from a byte pattern. Meshes as lazy_test_mesh's and a quad
 * with one triangle's kept tangent zero (that fill's fallback), flip_normals, flip_normals changed
 * after the frames were kept, uv read or not. */
TEST(mesh_kept_shading_fill_match)
{
    int checked = 0, zero_tangents = 0;
    for (int kind = 0; kind < 6; ++kind)
        for (int flip = 0; flip < 2; ++flip)
            for (int turned = 0; turned < 2; ++turned)
                for (int uv_unread = 0; uv_unread < 2; ++uv_unread) {
                    spc_shape s;
                    if (kind < 5) {
                        lazy_test_mesh(&s, kind, flip != 0, true);
                    } else {
                        spc_error err;
                        spc_mat4 T = {{{1, 0.2, 0, 0.5}, {0, 1.3, 0.1, -2}, {0.3, 0, 0.7, 1}, {0, 0, 0, 1}}};
                        memset(&s, 0, sizeof s);
                        spc_mesh m = quad_mesh(false, NULL);
                        CHECK(spc_shape_init_mesh(&s, &m, &T, NULL, 0, 0, &err));
                        s.flip_normals = flip != 0;
                        CHECK(spc_shape_prepare(&s) == SPC_OK);
                        /* the second triangle's kept tangent zero, as where its frame fell back to
                         * spc_frame_from_n (the loader drops the degenerate triangles that would) */
                        CHECK(s.tri_frame != NULL && s.mesh.ntris == 2);
                        if (s.tri_frame)
                            s.tri_frame[SPC_TRI_FRAME_STRIDE + 3] = s.tri_frame[SPC_TRI_FRAME_STRIDE + 4] =
                                s.tri_frame[SPC_TRI_FRAME_STRIDE + 5] = 0.0;
                    }
                    CHECK(s.tri_frame != NULL);
                    double *kept = s.tri_frame;
                    for (size_t t = 0; t < s.mesh.ntris; ++t) {
                        const double *c = kept + SPC_TRI_FRAME_STRIDE * t;
                        zero_tangents += c[3] == 0.0 && c[4] == 0.0 && c[5] == 0.0;
                    }
                    if (turned)
                        s.flip_normals = !s.flip_normals;
                    s.lazy_derivs = true;
                    s.uv_unread = uv_unread != 0;
                    for (int i = 0; i < 50; ++i) {
                        int prim = (int)(rnd() * (double)s.mesh.ntris);
                        double b1 = rnd(), b2 = rnd() * (1.0 - b1);
                        spc_hit e, a, b;
                        memset(&e, 0, sizeof e);
                        memset(&a, 0xA5, sizeof a);
                        memset(&b, 0xA5, sizeof b);
                        s.tri_frame = kept;
                        spc_shape_fill_hit_shading(&s, prim, b1, b2, NULL, 1.5, &a);
                        spc_shape_fill_hit(&s, prim, b1, b2, NULL, 1.5, &e);
                        s.tri_frame = NULL;
                        spc_shape_fill_hit_shading(&s, prim, b1, b2, NULL, 1.5, &b);
                        s.tri_frame = kept;
                        a.shape_index = b.shape_index = e.shape_index = 7;
                        CHECK(same_record(&a, &b));
                        spc_shape_hit_derivatives(&a);
                        CHECK(same_record(&e, &a));
                        ++checked;
                    }
                    spc_shape_release(&s);
                }
    CHECK(checked == 6 * 2 * 2 * 2 * 50);
    CHECK_MSG(zero_tangents > 0, "no kept tangent of zero: the fill's fallback untested");
}

TEST(mesh_area_sampling_uniform)
{
    spc_shape s;
    memset(&s, 0, sizeof s);
    spc_error err;
    spc_mat4 S = spc_mat4_scale(spc_v3(2, 1, 1));
    CHECK(spc_shape_init_rectangle(&s, &S, NULL, 0, 0, &err));
    CHECK(spc_shape_prepare(&s) == SPC_OK);
    CHECK_NEAR(s.area, 8.0, 1e-12);
    /* placed meshes carry the float of padding Embree's in-place reads need */
    CHECK(s.mesh.p_padded && s.mesh.p[3 * s.mesh.nverts] == 0.0f);
    double mx = 0, mxx = 0;
    const int N = 100000;
    for (int i = 0; i < N; ++i) {
        spc_shape_sample ss;
        spc_shape_sample_area(&s, spc_v2(rnd(), rnd()), &ss);
        CHECK_NEAR(ss.pdf, 1.0 / 8.0, 1e-12);
        mx += ss.p.x;
        mxx += ss.p.x * ss.p.x;
    }
    CHECK_NEAR(mx / N, 0.0, 0.02);
    CHECK_NEAR(mxx / N, 4.0 / 3.0, 0.02); /* uniform on [-2, 2] */
    /* invalid inputs */
    spc_shape bad;
    memset(&bad, 0, sizeof bad);
    CHECK(!spc_shape_init_sphere(&bad, spc_v3(0, 0, 0), -1.0, NULL, "x.xml", 3, 4, &err));
    CHECK(err.code == SPC_ERR_VALUE && err.line == 3);
    spc_mat4 Z = spc_mat4_scale(spc_v3(0, 1, 1));
    CHECK(!spc_shape_init_disk(&bad, &Z, "x.xml", 5, 6, &err));
    spc_shape_release(&s);
}

/* A sphere's uv only where its materials read them: spc_scene_finalize marks the spheres whose BSDF
 * and emitter read no uv (a constant reflectance, a dielectric, a constant area light) and not
 * those with a checkerboard (also nested in twosided); on a marked sphere the hit's and the area
 * sample's uv are zero and every other field is bit for bit the unmarked sphere's. */
TEST(sphere_uv_only_where_read)
{
    static const char *xml =
        "<scene version=\"3.0.0\">\n"
        "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0\" z=\"0\"/>"
        "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5\"/></bsdf></shape>\n"
        "<shape type=\"sphere\"><point name=\"center\" x=\"3\" y=\"0\" z=\"0\"/>"
        "<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\"/></bsdf></shape>\n"
        "<shape type=\"sphere\"><point name=\"center\" x=\"6\" y=\"0\" z=\"0\"/>"
        "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>\n"
        "<shape type=\"sphere\"><point name=\"center\" x=\"9\" y=\"0\" z=\"0\"/><bsdf type=\"dielectric\"/></shape>\n"
        "<shape type=\"sphere\"><point name=\"center\" x=\"12\" y=\"0\" z=\"0\"/><bsdf type=\"twosided\">"
        "<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\"/></bsdf></bsdf></shape>\n"
        "</scene>\n";
    const char *dir = getenv("TMPDIR");
    char path[512];
    snprintf(path, sizeof path, "%s/spc_test_sphere_uv_%d.xml", dir ? dir : "/tmp", (int)(rnd() * 1e9));
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (!f)
        return;
    fputs(xml, f);
    fclose(f);
    spc_scene *sc = NULL;
    spc_error err;
    CHECK_MSG(spc_scene_load(path, NULL, 0, &sc, &err) == SPC_OK, "%s", err.msg);
    remove(path);
    if (!sc)
        return;
    CHECK(sc->nshapes == 5);
    const bool unread[5] = {true, false, true, true, false};
    for (int i = 0; i < 5 && i < sc->nshapes; ++i)
        CHECK_MSG(sc->shapes[i]->uv_unread == unread[i], "sphere %d: uv_unread %d", i, sc->shapes[i]->uv_unread);
    spc_shape read = *sc->shapes[0];
    read.uv_unread = false;
    const spc_shape *marked = sc->shapes[0];
    int differ = 0, zero = 0, nonzero = 0;
    for (int i = 0; i < 200; ++i) {
        spc_vec3 n = spc_warp_uniform_sphere(spc_v2(rnd(), rnd()));
        spc_ray r = {spc_madd(marked->center, n, 3.0), spc_neg(n), 0.0, INFINITY};
        spc_hit a, b;
        memset(&a, 0, sizeof a);
        memset(&b, 0, sizeof b);
        spc_shape_fill_hit(marked, 0, 0, 0, &r, 2.0, &a);
        spc_shape_fill_hit(&read, 0, 0, 0, &r, 2.0, &b);
        zero += a.uv.x == 0.0 && a.uv.y == 0.0 && a.b1 == 0.0 && a.b2 == 0.0;
        nonzero += b.uv.y > 0.0 && b.b1 == b.uv.x && b.b2 == b.uv.y;
        b.uv = a.uv;
        b.b1 = a.b1;
        b.b2 = a.b2;
        b.shape = a.shape; /* the copy's address */
        differ += memcmp(&a, &b, sizeof a) != 0;
        spc_shape_sample sa, sb;
        spc_vec2 u = spc_v2(rnd(), rnd());
        spc_shape_sample_area(marked, u, &sa);
        spc_shape_sample_area(&read, u, &sb);
        zero += sa.uv.x == 0.0 && sa.uv.y == 0.0;
        nonzero += sb.uv.y > 0.0;
        differ += !(sa.p.x == sb.p.x && sa.p.y == sb.p.y && sa.p.z == sb.p.z && sa.pdf == sb.pdf);
    }
    CHECK_MSG(zero == 400 && nonzero == 400 && differ == 0, "uv zero %d, filled %d; %d differ", zero, nonzero, differ);
    spc_scene_destroy(sc);
}

/* A sheared parallelogram of two triangles, the second wound against the first and both listed
 * from another corner (so that the sampler's corner roles are not the index order), with uvs that
 * are each corner's parallelogram coordinates, for spc_shape_init_mesh to take. `bend` lifts one
 * corner out of the plane by that much (relative to the corners' size). */
static spc_mesh para_mesh(double bend)
{
    spc_mesh m;
    memset(&m, 0, sizeof m);
    m.nverts = 4;
    m.ntris = 2;
    m.p = malloc(12 * sizeof(float));
    m.idx = malloc(6 * sizeof(uint32_t));
    m.uv = malloc(8 * sizeof(float));
    /* corners c0, c0 + a, c0 + a + b, c0 + b with a = (2, 0.5, 0), b = (0.5, 1, 0.25) */
    float P[12] = {1, 1, 1, 3, 1.5f, 1, 3.5f, 2.5f, 1.25f, 1.5f, 2, 1.25f};
    P[11] += (float)(bend * 4.0);
    uint32_t I[6] = {1, 2, 0, 3, 2, 0};
    float UV[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    memcpy(m.p, P, sizeof P);
    memcpy(m.idx, I, sizeof I);
    memcpy(m.uv, UV, sizeof UV);
    return m;
}

/* Pearson's statistic of counts against equal expectations, as standard deviations of the
 * chi-square distribution (nbins - 1 degrees of freedom) above its mean. */
static double chi2_uniform_sd(const int *count, int nbins, int n)
{
    double expect = (double)n / nbins, x2 = 0.0;
    for (int i = 0; i < nbins; ++i)
        x2 += (count[i] - expect) * (count[i] - expect) / expect;
    return (x2 - (nbins - 1)) / sqrt(2.0 * (nbins - 1));
}

/* A mesh of two triangles that form a parallelogram is sampled as one (spc_shape.has_para): the
 * points are uniform over the two halves (a chi-square on the triangle each lands in, which has
 * half the area) and over a 6 x 6 grid of the parallelogram (its own coordinates, the uvs, which
 * come from the triangle the sample names); each point lies in the triangle it names, with that
 * triangle's normal (flipped with flip_normals) and the density 1 / area. A corner off the plane by
 * more than SPC_PARA_TOL, vertex normals, a bent quad and more triangles keep the triangle pick;
 * rectangles qualify, the cornell box's light among them. */
TEST(mesh_parallelogram_sampling)
{
    spc_error err;
    spc_mat4 I = spc_mat4_identity();
    for (int flip = 0; flip < 2; ++flip) {
        spc_shape s;
        memset(&s, 0, sizeof s);
        spc_mesh m = para_mesh(0.0);
        CHECK(spc_shape_init_mesh(&s, &m, &I, NULL, 0, 0, &err));
        s.flip_normals = flip != 0;
        CHECK(spc_shape_prepare(&s) == SPC_OK);
        CHECK(s.has_para);
        spc_vec3 v[4];
        for (int k = 0; k < 4; ++k)
            v[k] = spc_mesh_p(&s.mesh, (uint32_t)k);
        spc_vec3 ea = spc_sub(v[1], v[0]), eb = spc_sub(v[3], v[0]);
        enum { G = 6, N = 144000 };
        int half[2] = {0, 0}, grid[G * G], bad = 0;
        memset(grid, 0, sizeof grid);
        for (int i = 0; i < N; ++i) {
            spc_shape_sample ss;
            spc_shape_sample_area(&s, spc_v2(rnd(), rnd()), &ss);
            bad += !(ss.prim == 0 || ss.prim == 1) || ss.pdf != 1.0 / s.area;
            if (!(ss.prim == 0 || ss.prim == 1))
                continue;
            ++half[ss.prim];
            /* the point at its uv (the parallelogram's coordinates) */
            spc_vec3 q = spc_add(spc_add(v[0], spc_scale(ea, ss.uv.x)), spc_scale(eb, ss.uv.y));
            bad += !(spc_length(spc_sub(q, ss.p)) < 1e-12 * 4.0);
            /* in its triangle, with that triangle's normal */
            const uint32_t *t = s.mesh.idx + 3 * ss.prim;
            spc_vec3 t0 = spc_mesh_p(&s.mesh, t[0]), e1 = spc_sub(spc_mesh_p(&s.mesh, t[1]), t0),
                     e2 = spc_sub(spc_mesh_p(&s.mesh, t[2]), t0), nc = spc_cross(e1, e2), d = spc_sub(ss.p, t0);
            double n2 = spc_dot(nc, nc);
            double b1 = spc_dot(spc_cross(d, e2), nc) / n2, b2 = spc_dot(spc_cross(e1, d), nc) / n2;
            bad += !(b1 > -1e-12 && b2 > -1e-12 && b1 + b2 < 1.0 + 1e-12);
            spc_vec3 ng = spc_normalize(nc);
            if (flip)
                ng = spc_neg(ng);
            bad += !(spc_length(spc_sub(ng, ss.n)) < 1e-12) || !(ss.err > 0.0);
            int gx = (int)(ss.uv.x * G), gy = (int)(ss.uv.y * G);
            if (gx >= 0 && gx < G && gy >= 0 && gy < G)
                ++grid[gx + G * gy];
            else
                ++bad;
        }
        CHECK_MSG(bad == 0, "%d samples off their triangle, uv, normal or density", bad);
        /* below 5 standard deviations (p 0.005 at one degree of freedom, 5e-5 at 35; the stream is fixed) */
        double zh = chi2_uniform_sd(half, 2, half[0] + half[1]), zg = chi2_uniform_sd(grid, G * G, N);
        CHECK_MSG(zh < 5.0 && zg < 5.0, "halves %d/%d (%.2f sd), grid %.2f sd", half[0], half[1], zh, zg);
        spc_shape_release(&s);
    }
    /* what keeps the triangle pick */
    for (int kind = 0; kind < 4; ++kind) {
        spc_shape s;
        memset(&s, 0, sizeof s);
        spc_mesh m = kind == 0 ? para_mesh(4.0 * SPC_PARA_TOL) : kind == 1 ? quad_mesh(false, NULL)
                                                                           : quad_mesh(true, NULL);
        if (kind == 2) {
            /* the flat parallelogram with vertex normals */
            spc_mesh_release(&m);
            m = para_mesh(0.0);
            m.n = malloc(12 * sizeof(float));
            for (int k = 0; k < 12; ++k)
                m.n[k] = k % 3 == 2 ? 1.0f : 0.0f;
        }
        if (kind == 3)
            CHECK(spc_shape_init_cube(&s, &I, NULL, 0, 0, &err));
        else
            CHECK(spc_shape_init_mesh(&s, &m, &I, NULL, 0, 0, &err));
        CHECK(spc_shape_prepare(&s) == SPC_OK);
        CHECK_MSG(!s.has_para, "kind %d sampled as a parallelogram", kind);
        if (kind == 3)
            spc_mesh_release(&m);
        spc_shape_release(&s);
    }
    /* rectangles: a rotated, scaled one and the cornell box's light (its to_world) */
    spc_mat4 R = spc_mat4_rotate(spc_v3(0.3, 1, 0.2), 37.0), S = spc_mat4_scale(spc_v3(3.1, 0.7, 1));
    spc_mat4 RS = spc_mat4_mul(&R, &S);
    spc_mat4 C = {{{0.235, -1.66103e-008, -7.80685e-009, -0.005},
                   {-2.05444e-008, 3.90343e-009, -0.0893, 1.98},
                   {2.05444e-008, 0.19, 8.30516e-009, -0.03},
                   {0, 0, 0, 1}}};
    for (int k = 0; k < 2; ++k) {
        spc_shape s;
        memset(&s, 0, sizeof s);
        CHECK(spc_shape_init_rectangle(&s, k ? &C : &RS, NULL, 0, 0, &err));
        CHECK(spc_shape_prepare(&s) == SPC_OK);
        CHECK_MSG(s.has_para, "rectangle %d not sampled as a parallelogram", k);
        spc_shape_release(&s);
    }
}

int main(void)
{
    spc_rng_seed(&rng, 12, 34);
    RUN(sphere_intersection_precise);
    RUN(surface_derivatives);
    RUN(analytic_disk_and_cylinder);
    RUN(sphere_sampling_solid_angle);
    RUN(sphere_solid_angle_sample_is_the_cone_warp);
    RUN(mesh_area_sampling_uniform);
    RUN(mesh_parallelogram_sampling);
    RUN(mesh_kept_frames_match);
    RUN(mesh_lazy_derivatives_match);
    RUN(mesh_chain_hits_complete);
    RUN(mesh_kept_shading_fill_match);
    RUN(sphere_uv_only_where_read);
    return spc_test_finish();
}
