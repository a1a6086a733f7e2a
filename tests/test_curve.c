/*
 * tests/test_curve.c: the curve shapes (scene/curve.h). Hits through Embree's round curves against
 * closed forms: a two-point linear curve of constant radius is a capsule (a cylinder between two
 * spheres), a B-spline over four evenly spaced collinear points a cylinder; their normals and uv as
 * Mitsuba 3 defines them; back faces culled (a ray from inside a tube leaves it without a hit). The
 * curve file's errors name the file and the line, through the parser and the Mitsuba loader.
 */
/* ctest-labels: unit */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/rng.h"
#include "harness.h"
#include "io/mitsuba_xml.h"
#include "scene/curve.h"
#include "scene/scene.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

/* A scene of one curve read from text; NULL (and a printed message) on failure. */
static spc_scene *curve_scene(const char *text, spc_curve_basis basis)
{
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_curve *c = calloc(1, sizeof *c);
    if (!c || spc_curve_parse(text, strlen(text), "test.txt", basis, NULL, c, &err) != SPC_OK) {
        printf("  parse: %s\n", err.msg);
        free(c);
        return NULL;
    }
    spc_scene *sc = spc_scene_create();
    spc_shape *sh = sc ? spc_scene_new_shape(sc) : NULL;
    if (!sh || !spc_shape_init_curve(sh, c, NULL, 0, 0, &err)) {
        spc_scene_destroy(sc);
        return NULL;
    }
    spc_bsdf *d = spc_scene_new_bsdf(sc);
    d->type = SPC_BSDF_DIFFUSE;
    d->reflectance = spc_scene_constant(sc, spc_rgb1(0.5));
    sh->bsdf = d;
    spc_scene_set_defaults(sc);
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* Entry distance of ray (o, d), |d| = 1, into the sphere (c, r): +inf for a miss. */
static double sphere_entry(spc_vec3 o, spc_vec3 d, spc_vec3 c, double r)
{
    spc_vec3 oc = spc_sub(o, c);
    double b = spc_dot(oc, d), q = spc_dot(oc, oc) - r * r, disc = b * b - q;
    if (disc < 0.0)
        return INFINITY;
    double t = -b - sqrt(disc);
    return t > 0.0 ? t : INFINITY;
}

/* Entry distance into the capsule of radius r around the segment z in [-1, 1] on the z axis, and
 * its outward normal there. */
static double capsule_entry(spc_vec3 o, spc_vec3 d, double r, spc_vec3 *n)
{
    double best = INFINITY;
    double a = d.x * d.x + d.y * d.y, b = o.x * d.x + o.y * d.y, q = o.x * o.x + o.y * o.y - r * r;
    if (a > 0.0 && b * b - a * q >= 0.0) {
        double t = (-b - sqrt(b * b - a * q)) / a;
        double z = o.z + t * d.z;
        if (t > 0.0 && fabs(z) <= 1.0) {
            best = t;
            spc_vec3 p = spc_madd(o, d, t);
            *n = spc_normalize(spc_v3(p.x, p.y, 0.0));
        }
    }
    for (int k = -1; k <= 1; k += 2) {
        spc_vec3 c = spc_v3(0, 0, k);
        double t = sphere_entry(o, d, c, r);
        if (t < best) {
            best = t;
            *n = spc_normalize(spc_sub(spc_madd(o, d, t), c));
        }
    }
    return best;
}

/* Rays from all around at points near the capsule: the same hits as the closed form (Embree finds
 * them in float: 1e-4 at unit scale), the same normals; the uv of Mitsuba's linearcurve. */
TEST(linear_curve_is_a_capsule)
{
    const double R = 0.4;
    spc_scene *sc = curve_scene("0 0 -1 0.4\n0 0 1 0.4\n", SPC_CURVE_LINEAR);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int hits = 0, misses = 0, bad = 0;
    for (int i = 0; i < 4000; ++i) {
        spc_vec3 target = spc_v3(1.2 * (2 * rnd() - 1), 1.2 * (2 * rnd() - 1), 3.0 * (2 * rnd() - 1));
        spc_vec3 dir = spc_warp_uniform_sphere(spc_v2(rnd(), rnd()));
        spc_ray r = {spc_madd(target, dir, -6.0), dir, 0.0, INFINITY};
        spc_vec3 n_exact = spc_v3(0, 0, 0);
        double t_exact = capsule_entry(r.o, r.d, R, &n_exact);
        /* leave out grazing rays: within 1e-3 of the silhouette either way */
        double t_in = capsule_entry(r.o, r.d, R - 1e-3, &(spc_vec3){0, 0, 0});
        double t_out = capsule_entry(r.o, r.d, R + 1e-3, &(spc_vec3){0, 0, 0});
        if (isfinite(t_out) && !isfinite(t_in))
            continue;
        spc_hit h;
        bool hit = spc_scene_intersect(sc, &r, &h);
        if (!isfinite(t_exact)) {
            ++misses;
            bad += hit;
            continue;
        }
        ++hits;
        if (!hit || fabs(h.t - t_exact) > 1e-4 || spc_dot(h.ng, n_exact) < 1.0 - 1e-5 || !(h.err > 0.0)) {
            if (bad++ < 5)
                printf("  ray %d: hit %d t %.6f exact %.6f n.n %.8f\n", i, hit, hit ? h.t : 0.0, t_exact,
                       hit ? spc_dot(h.ng, n_exact) : 0.0);
            continue;
        }
        /* uv: v along the segment (one segment: (z + 1) / 2 on the tube), u the angle from Mitsuba's
         * frame around +z (v_rot = +y, v_rad = v_rot x axis = +x): atan2(n.y, n.x) / (2 pi) */
        if (fabs(h.p.z) < 0.99) {
            double phi = atan2(h.ng.y, h.ng.x);
            if (phi < 0.0)
                phi += 2.0 * SPC_PI;
            CHECK_NEAR(h.uv.y, (h.p.z + 1.0) / 2.0, 1e-4);
            CHECK_NEAR(h.uv.x, phi / (2.0 * SPC_PI), 1e-4 + (phi < 1e-3 || phi > 2 * SPC_PI - 1e-3));
        }
        CHECK_NEAR(spc_length(h.sh.n), 1.0, 1e-12);
        CHECK_NEAR(spc_dot(h.sh.n, h.sh.s), 0.0, 1e-12);
    }
    printf("  %d hits, %d misses checked\n", hits, misses);
    CHECK(hits > 500 && misses > 500);
    CHECK_MSG(bad == 0, "%d rays disagree with the capsule", bad);
    spc_scene_destroy(sc);
}

/* A B-spline over (0,0,-3), (0,0,-1), (0,0,1), (0,0,3) of constant radius is the cylinder z in
 * [-1, 1]: hits on its side at the cylinder's distance, normals radial, uv.x = (z + 1) / 2 (Mitsuba's
 * rescaled global parameter), uv.y the angle. */
TEST(bspline_curve_is_a_cylinder)
{
    const double R = 0.3;
    spc_scene *sc = curve_scene("0 0 -3 0.3\n0 0 -1 0.3\n0 0 1 0.3\n0 0 3 0.3\n", SPC_CURVE_BSPLINE);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int n = 0, bad = 0;
    for (int i = 0; i < 2000; ++i) {
        double phi = 2.0 * SPC_PI * rnd(), z = 1.8 * rnd() - 0.9, rho = (0.98 * rnd()) * R;
        spc_vec3 target = spc_v3(rho * cos(phi), rho * sin(phi), z);
        double a = 2.0 * SPC_PI * rnd();
        spc_vec3 dir = spc_normalize(spc_v3(cos(a), sin(a), 0.3 * (2 * rnd() - 1)));
        spc_ray r = {spc_madd(target, dir, -5.0), dir, 0.0, INFINITY};
        double A = dir.x * dir.x + dir.y * dir.y, B = r.o.x * dir.x + r.o.y * dir.y;
        double Q = r.o.x * r.o.x + r.o.y * r.o.y - R * R;
        double t_exact = (-B - sqrt(B * B - A * Q)) / A;
        spc_vec3 p = spc_madd(r.o, dir, t_exact);
        if (fabs(p.z) > 0.95)
            continue;
        ++n;
        spc_hit h;
        bool hit = spc_scene_intersect(sc, &r, &h);
        spc_vec3 n_exact = spc_normalize(spc_v3(p.x, p.y, 0.0));
        double ang = atan2(n_exact.y, n_exact.x);
        if (ang < 0.0)
            ang += 2.0 * SPC_PI;
        bool seam = ang < 1e-3 || ang > 2.0 * SPC_PI - 1e-3;
        if (!hit || fabs(h.t - t_exact) > 1e-4 || spc_dot(h.ng, n_exact) < 1.0 - 1e-5 ||
            fabs(h.uv.x - (p.z + 1.0) / 2.0) > 1e-4 || (!seam && fabs(h.uv.y - ang / (2.0 * SPC_PI)) > 1e-4)) {
            if (bad++ < 5)
                printf("  ray %d: hit %d t %.6f exact %.6f uv (%.5f %.5f) expected (%.5f %.5f)\n", i, hit,
                       hit ? h.t : 0.0, t_exact, hit ? h.uv.x : 0.0, hit ? h.uv.y : 0.0, (p.z + 1.0) / 2.0,
                       ang / (2.0 * SPC_PI));
        }
    }
    CHECK(n > 1000);
    CHECK_MSG(bad == 0, "%d of %d rays disagree with the cylinder", bad, n);
    spc_scene_destroy(sc);
}

/* Back faces are culled, as in Mitsuba 3: rays from the axis outward, and shadow rays from there,
 * find nothing; the same rays from outside inward hit. */
TEST(back_faces_are_culled)
{
    spc_scene *sc = curve_scene("0 0 -1 0.5\n0 0 1 0.5\n", SPC_CURVE_LINEAR);
    CHECK(sc != NULL);
    if (!sc)
        return;
    for (int i = 0; i < 200; ++i) {
        spc_vec3 dir = spc_warp_uniform_sphere(spc_v2(rnd(), rnd()));
        spc_ray r = {spc_v3(0, 0, 0.5 * (2 * rnd() - 1)), dir, 0.0, INFINITY};
        spc_hit h;
        CHECK(!spc_scene_intersect(sc, &r, &h));
        CHECK(!spc_scene_occluded(sc, &r));
        spc_ray in = {spc_madd(r.o, dir, 3.0), spc_neg(dir), 0.0, INFINITY};
        CHECK(spc_scene_intersect(sc, &in, &h));
        CHECK(spc_scene_occluded(sc, &in));
    }
    spc_scene_destroy(sc);
}

/* Several curves in one file: segments per curve (n - 1 linear, n - 3 B-spline), their first
 * points, the radius kept under to_world while positions scale. */
TEST(file_layout_and_transform)
{
    const char *text = "0 0 0 0.1\n1 0 0 0.2\n2 0 0 0.3\n\n\n  0 1 0 0.1\r\n0 2 0 0.1\n0 3 0 0.1\n0 4 0 0.1\n";
    spc_curve c;
    spc_error err;
    spc_mat4 M = spc_mat4_identity();
    M.m[0][0] = M.m[1][1] = M.m[2][2] = 2.0;
    M.m[0][3] = 1.0;
    CHECK(spc_curve_parse(text, strlen(text), "t.txt", SPC_CURVE_LINEAR, &M, &c, &err) == SPC_OK);
    CHECK(c.ncp == 7 && c.nseg == 5);
    uint32_t lin[5] = {0, 1, 3, 4, 5};
    for (int i = 0; i < 5 && c.nseg == 5; ++i)
        CHECK(c.seg[i] == lin[i]);
    CHECK_NEAR(c.cp[4 * 1 + 0], 3.0, 0.0); /* x = 2 * 1 + 1 */
    CHECK_NEAR(c.cp[4 * 1 + 3], 0.2, 1e-7); /* radius not scaled */
    spc_curve_release(&c);
    /* the first curve has 3 points: too few for a B-spline */
    CHECK(spc_curve_parse(text, strlen(text), "t.txt", SPC_CURVE_BSPLINE, NULL, &c, &err) == SPC_ERR_PARSE);
    CHECK(err.line == 1 && strstr(err.msg, "at least 4") && strcmp(err.file, "t.txt") == 0);
    const char *four = "0 0 0 1\n1 0 0 1\n2 0 0 1\n3 0 0 1\n4 0 0 1\n";
    CHECK(spc_curve_parse(four, strlen(four), "t.txt", SPC_CURVE_BSPLINE, NULL, &c, &err) == SPC_OK);
    CHECK(c.nseg == 2 && c.seg[0] == 0 && c.seg[1] == 1);
    spc_curve_release(&c);
}

/* Bad files: the error names the file and the line, with the right code. */
TEST(bad_files_name_file_and_line)
{
    static const struct {
        const char *text;
        spc_status code;
        int line;
    } cases[] = {
        {"0 0 0 1\n0 0 x 1\n", SPC_ERR_PARSE, 2},         /* not a number */
        {"0 0 0 1\n0 0 1\n", SPC_ERR_PARSE, 2},           /* three numbers */
        {"0 0 0 1\n0 0 1 1 5\n", SPC_ERR_PARSE, 2},       /* five */
        {"0 0 0 1\n0 0 1 1\n\n0 nan 1 1\n0 0 2 1\n", SPC_ERR_VALUE, 4}, /* NaN position */
        {"0 0 0 1\n0 0 1 inf\n", SPC_ERR_VALUE, 2},       /* infinite radius */
        {"0 0 0 1\n0 0 1 -0.5\n", SPC_ERR_VALUE, 2},      /* negative radius */
        {"0 0 0 1\n0 0 1 1\n\n5 5 5 1\n", SPC_ERR_PARSE, 4}, /* a curve of one point */
        {"\n\n  \n", SPC_ERR_PARSE, 4},                   /* no points */
        {"", SPC_ERR_PARSE, 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_curve c;
        spc_error err;
        memset(&err, 0, sizeof err);
        spc_status st = spc_curve_parse(cases[i].text, strlen(cases[i].text), "bad.txt", SPC_CURVE_LINEAR, NULL, &c,
                                        &err);
        CHECK_MSG(st == cases[i].code && err.line == cases[i].line && strcmp(err.file, "bad.txt") == 0,
                  "case %zu: status %d line %d file '%s': %s", i, (int)st, err.line, err.file, err.msg);
        CHECK(c.cp == NULL && c.seg == NULL && c.nseg == 0);
    }
    spc_curve c;
    spc_error err;
    CHECK(spc_curve_read("/nonexistent/curves.txt", SPC_CURVE_LINEAR, NULL, &c, &err) == SPC_ERR_IO);
    CHECK(strcmp(err.file, "/nonexistent/curves.txt") == 0);
}

/* Through the Mitsuba loader: a missing file and a bad line fail the load with a message naming
 * the curve file and its line; a curve with an emitter is refused; a good one loads. */
TEST(loader_errors)
{
    char dir[] = "/tmp/spc_curve_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[256];
    snprintf(path, sizeof path, "%s/bad.txt", dir);
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (!f)
        return;
    fputs("0 0 0 0.1\n1 0 0 0.1\n\n1 1 1 nan\n2 2 2 0.1\n", f);
    fclose(f);
    snprintf(path, sizeof path, "%s/good.txt", dir);
    f = fopen(path, "w");
    fputs("0 0 0 0.1\n1 0 0 0.1\n", f);
    fclose(f);
    static const struct {
        const char *xml, *needle;
    } cases[] = {
        {"<scene version='3.0.0'><shape type='linearcurve'><string name='filename' value='none.txt'/></shape></scene>",
         "none.txt"},
        {"<scene version='3.0.0'><shape type='bsplinecurve'><string name='filename' value='bad.txt'/></shape></scene>",
         "bad.txt:1: a B-spline curve needs at least 4"},
        {"<scene version='3.0.0'><shape type='linearcurve'><string name='filename' value='bad.txt'/></shape></scene>",
         "bad.txt:4"},
        {"<scene version='3.0.0'><shape type='linearcurve'/></scene>", "filename"},
        {"<scene version='3.0.0'><shape type='linearcurve'><string name='filename' value='good.txt'/>"
         "<emitter type='area'/></shape></scene>",
         "emitter"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_scene *s = NULL;
        spc_error err;
        memset(&err, 0, sizeof err);
        spc_status st = spc_mitsuba_load_string(cases[i].xml, strlen(cases[i].xml), "c.xml", dir, NULL, 0, &s, &err);
        char msg[1200];
        spc_error_format(&err, msg, sizeof msg);
        CHECK_MSG(st != SPC_OK && s == NULL && strstr(msg, cases[i].needle) && strstr(msg, "c.xml:1"),
                  "case %zu: status %d: %s", i, (int)st, msg);
        spc_scene_destroy(s);
    }
    const char *good =
        "<scene version='3.0.0'><shape type='linearcurve'><string name='filename' value='good.txt'/></shape></scene>";
    spc_scene *s = NULL;
    spc_error err;
    CHECK(spc_mitsuba_load_string(good, strlen(good), "c.xml", dir, NULL, 0, &s, &err) == SPC_OK);
    spc_scene_destroy(s);
    snprintf(path, sizeof path, "%s/bad.txt", dir);
    remove(path);
    snprintf(path, sizeof path, "%s/good.txt", dir);
    remove(path);
    rmdir(dir);
}

int main(void)
{
    spc_rng_seed(&rng, 7, 0);
    RUN(linear_curve_is_a_capsule);
    RUN(bspline_curve_is_a_cylinder);
    RUN(back_faces_are_culled);
    RUN(file_layout_and_transform);
    RUN(bad_files_name_file_and_line);
    RUN(loader_errors);
    return spc_test_finish();
}
