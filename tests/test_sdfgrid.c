/*
 * tests/test_sdfgrid.c: the sdfgrid shape (scene/sdfgrid.h). Fields that trilinear interpolation
 * reproduces exactly (a plane; the product x y z, trilinear on every voxel) are intersected to
 * double rounding and compared with their closed-form crossings and gradients, under a rotating,
 * non-uniformly scaling to_world and on a grid of unequal sides; a sampled sphere is hit from
 * inside and outside within the interpolation error; the smooth normals equal the exact normal
 * where all voxel gradients agree; bad grids and bad files fail with errors naming them.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include <unistd.h>
#include "io/mitsuba_xml.h"
#include "scene/scene.h"
#include "scene/sdfgrid.h"
#include "scene/shape.h"
#include "specula/specula.h"

static double urand(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) * (1.0 / 9007199254740992.0);
}

static spc_vec3 rand_dir(uint64_t *s)
{
    double z = 2.0 * urand(s) - 1.0, phi = 2.0 * SPC_PI * urand(s), r = sqrt(fmax(0.0, 1.0 - z * z));
    return spc_v3(r * cos(phi), r * sin(phi), z);
}

/* Samples f at the vertices of an nx x ny x nz lattice over [0,1]^3 (x fastest). */
static float *sample(int nx, int ny, int nz, double (*f)(spc_vec3, const double *), const double *par)
{
    float *v = malloc((size_t)nx * ny * nz * sizeof *v);
    for (int z = 0; z < nz; ++z)
        for (int y = 0; y < ny; ++y)
            for (int x = 0; x < nx; ++x)
                v[((size_t)z * ny + y) * nx + x] =
                    (float)f(spc_v3((double)x / (nx - 1), (double)y / (ny - 1), (double)z / (nz - 1)), par);
    return v;
}

/* plane n . q = c (par: nx ny nz c); values representable in float at these sizes */
static double plane_f(spc_vec3 q, const double *p) { return p[0] * q.x + p[1] * q.y + p[2] * q.z - p[3]; }
static double product_f(spc_vec3 q, const double *p) { return q.x * q.y * q.z - p[0]; }
static double sphere_f(spc_vec3 q, const double *p)
{
    return spc_length(spc_sub(q, spc_v3(p[0], p[1], p[2]))) - p[3];
}

static bool in_box(spc_vec3 q, double eps)
{
    return q.x >= -eps && q.x <= 1 + eps && q.y >= -eps && q.y <= 1 + eps && q.z >= -eps && q.z <= 1 + eps;
}

static spc_mat4 test_transform(void)
{
    spc_mat4 S = spc_mat4_scale(spc_v3(2.0, 1.25, 0.8));
    spc_mat4 R = spc_mat4_rotate(spc_normalize(spc_v3(1, 2, 3)), 37.0);
    spc_mat4 T = spc_mat4_translate(spc_v3(0.3, -1.0, 2.0));
    spc_mat4 RS = spc_mat4_mul(&R, &S);
    return spc_mat4_mul(&T, &RS);
}

/* A plane is trilinear: every hit is the exact crossing, every normal the exact normal (smooth
 * normals too, where all voxel gradients are equal), every miss a ray whose crossing is outside
 * the box. */
TEST(plane_exact_under_transform)
{
    /* coefficients that are sums of powers of two, so the float grid holds the plane exactly */
    const double par[4] = {0.375, 0.5, -0.75, 0.0625};
    int nx = 9, ny = 5, nz = 7;
    float *v = sample(nx, ny, nz, plane_f, par);
    spc_mat4 M = test_transform(), Mi;
    spc_mat4_inverse(&M, &Mi);
    spc_error err;
    spc_sdfgrid *g = spc_sdfgrid_create(v, nx, ny, nz, &M, true, "t", 0, 0, &err);
    CHECK(g != NULL);
    free(v);
    if (!g)
        return;
    spc_vec3 nl = spc_v3(par[0], par[1], par[2]);
    spc_vec3 nw = spc_normalize(spc_mat4_apply_normal(&Mi, nl));
    uint64_t s = 7;
    int hits = 0, misses = 0, bad_t = 0, bad_n = 0, bad_miss = 0;
    for (int i = 0; i < 4000; ++i) {
        /* an origin around the box, a direction toward a random point of it */
        spc_vec3 ql = spc_v3(3 * urand(&s) - 1, 3 * urand(&s) - 1, 3 * urand(&s) - 1);
        spc_vec3 target = spc_v3(urand(&s), urand(&s), urand(&s));
        spc_ray r;
        r.o = spc_mat4_apply_point(&M, ql);
        r.d = spc_normalize(spc_sub(spc_mat4_apply_point(&M, target), r.o));
        r.tmin = 0.0;
        r.tmax = INFINITY;
        /* exact: f along the ray is linear in t */
        spc_vec3 ol = spc_mat4_apply_point(&Mi, r.o), dl = spc_mat4_apply_vector(&Mi, r.d);
        double f0 = plane_f(ol, par), f1 = spc_dot(nl, dl);
        double ts = -f0 / f1;
        bool expect = ts > 0.0 && in_box(spc_madd(ol, dl, ts), -1e-9);
        bool borderline = ts > 0.0 && in_box(spc_madd(ol, dl, ts), 1e-9) && !expect;
        double t;
        bool hit = spc_sdfgrid_intersect(g, &r, &t);
        if (borderline)
            continue;
        if (expect && hit) {
            ++hits;
            if (!(fabs(t - ts) <= 1e-10 * (1.0 + ts)))
                ++bad_t;
            spc_hit h;
            memset(&h, 0, sizeof h);
            spc_sdfgrid_fill_hit(g, spc_madd(r.o, r.d, t), false, &h);
            /* smooth normals blend the voxels around the nearest vertex; at a vertex of the upper
             * faces that includes voxels past the grid, whose clamped gradient lacks that axis
             * (Mitsuba's definition, kept): exact only away from them */
            spc_vec3 q = spc_mat4_apply_point(&Mi, h.p);
            bool upper = lround(q.x * (nx - 1)) > nx - 2 || lround(q.y * (ny - 1)) > ny - 2 ||
                         lround(q.z * (nz - 1)) > nz - 2;
            if (!(spc_length(spc_sub(h.ng, nw)) < 1e-9) || (!upper && !(spc_length(spc_sub(h.sh.n, nw)) < 1e-9)))
                ++bad_n;
        } else if (!expect && !hit)
            ++misses;
        else
            ++bad_miss;
    }
    CHECK_MSG(hits > 500 && misses > 500, "%d hits, %d misses", hits, misses);
    CHECK_MSG(bad_t == 0 && bad_n == 0 && bad_miss == 0, "%d wrong t, %d wrong normals, %d wrong hit/miss", bad_t,
              bad_n, bad_miss);
    spc_sdfgrid_destroy(g);
}

/* The first crossing of x y z = c along a ray, by dense stepping on the exact field and bisection. */
static bool product_reference(spc_vec3 o, spc_vec3 d, double c, double *t_out)
{
    double t0 = 0.0, t1 = INFINITY;
    double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
    for (int a = 0; a < 3; ++a) {
        if (dd[a] == 0.0)
            continue;
        double ta = -oo[a] / dd[a], tb = (1.0 - oo[a]) / dd[a];
        t0 = fmax(t0, fmin(ta, tb));
        t1 = fmin(t1, fmax(ta, tb));
    }
    if (!(t0 < t1))
        return false;
    const double par[1] = {c};
    int n = 20000;
    double h = (t1 - t0) / n, prev = product_f(spc_madd(o, d, t0), par);
    for (int i = 1; i <= n; ++i) {
        double t = t0 + i * h, f = product_f(spc_madd(o, d, t), par);
        if ((f <= 0.0) != (prev <= 0.0)) {
            double lo = t - h, hi = t;
            for (int k = 0; k < 200; ++k) {
                double mid = 0.5 * (lo + hi);
                if ((product_f(spc_madd(o, d, mid), par) <= 0.0) == (prev <= 0.0))
                    lo = mid;
                else
                    hi = mid;
            }
            *t_out = 0.5 * (lo + hi);
            return true;
        }
        prev = f;
    }
    return false;
}

/* x y z is trilinear on every voxel, so the grid's surface is exactly x y z = c: its crossings
 * (roots of a true cubic along each ray) and its gradient (y z, x z, x y) are known. */
TEST(cubic_surface_exact)
{
    const double c = 0.0625;
    const double par[1] = {c};
    int n = 5; /* vertices at multiples of 1/4: x y z - c is exact in float */
    float *v = sample(n, n, n, product_f, par);
    spc_error err;
    spc_sdfgrid *g = spc_sdfgrid_create(v, n, n, n, NULL, false, "t", 0, 0, &err);
    free(v);
    CHECK(g != NULL);
    if (!g)
        return;
    uint64_t s = 11;
    int hits = 0, bad = 0, bad_n = 0, agree_miss = 0;
    for (int i = 0; i < 1500; ++i) {
        spc_ray r;
        r.o = spc_v3(3 * urand(&s) - 1, 3 * urand(&s) - 1, 3 * urand(&s) - 1);
        spc_vec3 target = spc_v3(0.2 + 0.8 * urand(&s), 0.2 + 0.8 * urand(&s), 0.2 + 0.8 * urand(&s));
        r.d = spc_normalize(spc_sub(target, r.o));
        r.tmin = 0.0;
        r.tmax = INFINITY;
        double tr, t;
        bool ref = product_reference(r.o, r.d, c, &tr);
        bool hit = spc_sdfgrid_intersect(g, &r, &t);
        if (ref && hit) {
            ++hits;
            if (!(fabs(t - tr) < 1e-9))
                ++bad;
            spc_vec3 p = spc_madd(r.o, r.d, t);
            spc_vec3 ne = spc_normalize(spc_v3(p.y * p.z, p.x * p.z, p.x * p.y));
            spc_hit h;
            memset(&h, 0, sizeof h);
            spc_sdfgrid_fill_hit(g, p, false, &h);
            if (!(spc_length(spc_sub(h.ng, ne)) < 1e-8))
                ++bad_n;
        } else if (!ref && !hit)
            ++agree_miss;
        else
            ++bad;
    }
    CHECK_MSG(hits > 300 && agree_miss > 100, "%d hits, %d misses", hits, agree_miss);
    CHECK_MSG(bad == 0 && bad_n == 0, "%d wrong crossings, %d wrong normals of %d hits", bad, bad_n, hits);
    spc_sdfgrid_destroy(g);
}

/* A sampled sphere: hits from outside and from inside (the exit) within the interpolation error
 * of a distance field on a 1/32 lattice; misses past the radius; tmin and tmax respected. */
TEST(sphere_inside_outside)
{
    const double par[4] = {0.5, 0.5, 0.5, 0.3};
    int n = 33;
    float *v = sample(n, n, n, sphere_f, par);
    spc_error err;
    spc_sdfgrid *g = spc_sdfgrid_create(v, n, n, n, NULL, true, "t", 0, 0, &err);
    free(v);
    CHECK(g != NULL);
    if (!g)
        return;
    CHECK(spc_sdfgrid_occupied(g) > 0 && spc_sdfgrid_occupied(g) < (size_t)32 * 32 * 32 / 4);
    /* the area estimate: within 3% of 4 pi r^2 */
    CHECK_REL(spc_sdfgrid_area(g), 4.0 * SPC_PI * 0.09, 0.03, 0.0);
    spc_vec3 c = spc_v3(0.5, 0.5, 0.5);
    uint64_t s = 5;
    const double tol = 2e-3; /* |trilinear - distance| on this lattice, ~ h^2 / (2 r) */
    int bad = 0;
    for (int i = 0; i < 500; ++i) {
        spc_vec3 d = rand_dir(&s);
        double t;
        spc_ray r = {c, d, 0.0, INFINITY};
        /* from the centre: the exit at the radius; the normal points along d */
        if (!spc_sdfgrid_intersect(g, &r, &t) || fabs(t - 0.3) > tol) {
            ++bad;
            continue;
        }
        spc_hit h;
        memset(&h, 0, sizeof h);
        spc_sdfgrid_fill_hit(g, spc_madd(r.o, r.d, t), false, &h);
        if (!(spc_dot(h.ng, d) > 0.99 && spc_dot(h.sh.n, d) > 0.99))
            ++bad;
        /* from outside toward the centre: the entry, then (tmin past it) the exit */
        spc_ray ro = {spc_madd(c, d, 0.45), spc_neg(d), 0.0, INFINITY};
        if (!spc_sdfgrid_intersect(g, &ro, &t) || fabs(t - 0.15) > tol)
            ++bad;
        ro.tmin = 0.2;
        if (!spc_sdfgrid_intersect(g, &ro, &t) || fabs(t - 0.75) > tol)
            ++bad;
        /* tmax before the surface: no hit */
        ro.tmin = 0.0;
        ro.tmax = 0.14;
        if (spc_sdfgrid_intersect(g, &ro, &t))
            ++bad;
        /* a line passing 0.35 from the centre misses */
        spc_frame fr = spc_frame_from_n(d);
        spc_ray rm = {spc_madd(spc_madd(c, fr.s, 0.35), d, -2.0), d, 0.0, INFINITY};
        if (spc_sdfgrid_intersect(g, &rm, &t))
            ++bad;
    }
    CHECK_MSG(bad == 0, "%d of 500 directions wrong", bad);
    spc_sdfgrid_destroy(g);
}

/* Smooth normals (Hansson-Soderlund et al.): on a sphere they blend the voxel gradients, close to
 * the exact normal and closer than the analytic (one-voxel) gradient on average. */
TEST(smooth_normals_closer_on_sphere)
{
    const double par[4] = {0.5, 0.5, 0.5, 0.35};
    int n = 9; /* coarse, so that the facets show */
    float *v = sample(n, n, n, sphere_f, par);
    spc_error err;
    spc_sdfgrid *gs = spc_sdfgrid_create(v, n, n, n, NULL, true, "t", 0, 0, &err);
    spc_sdfgrid *ga = spc_sdfgrid_create(v, n, n, n, NULL, false, "t", 0, 0, &err);
    free(v);
    CHECK(gs && ga);
    if (!gs || !ga) {
        spc_sdfgrid_destroy(gs);
        spc_sdfgrid_destroy(ga);
        return;
    }
    uint64_t s = 3;
    double es = 0.0, ea = 0.0;
    int m = 0;
    for (int i = 0; i < 400; ++i) {
        spc_vec3 d = rand_dir(&s);
        spc_ray r = {spc_v3(0.5, 0.5, 0.5), d, 0.0, INFINITY};
        double t;
        if (!spc_sdfgrid_intersect(gs, &r, &t))
            continue;
        spc_vec3 p = spc_madd(r.o, d, t), ne = spc_normalize(spc_sub(p, r.o));
        spc_hit hs, ha;
        memset(&hs, 0, sizeof hs);
        memset(&ha, 0, sizeof ha);
        spc_sdfgrid_fill_hit(gs, p, false, &hs);
        spc_sdfgrid_fill_hit(ga, p, true, &ha);
        es += acos(spc_clamp(spc_dot(hs.sh.n, ne), -1.0, 1.0));
        ea += acos(spc_clamp(spc_dot(spc_neg(ha.sh.n), ne), -1.0, 1.0)); /* flip_normals negates */
        CHECK(spc_length(spc_sub(hs.ng, spc_neg(ha.ng))) < 1e-12); /* the same geometric normal */
        ++m;
    }
    CHECK(m > 350);
    es /= m;
    ea /= m;
    CHECK_MSG(es < 0.05 && es < 0.8 * ea, "mean angle to the exact normal: smooth %.4f, analytic %.4f", es, ea);
    spc_sdfgrid_destroy(gs);
    spc_sdfgrid_destroy(ga);
}

TEST(bad_grids)
{
    float v[27];
    for (int i = 0; i < 27; ++i)
        v[i] = (float)(i - 13);
    spc_error err;
    memset(&err, 0, sizeof err);
    CHECK(spc_sdfgrid_create(v, 1, 3, 9, NULL, true, "g.vol", 0, 0, &err) == NULL);
    CHECK(err.code == SPC_ERR_VALUE && strstr(err.msg, "at least 2") && strcmp(err.file, "g.vol") == 0);
    v[5] = NAN;
    CHECK(spc_sdfgrid_create(v, 3, 3, 3, NULL, true, "g.vol", 0, 0, &err) == NULL);
    CHECK(err.code == SPC_ERR_VALUE && strstr(err.msg, "not finite") && strstr(err.msg, "x 2, y 1, z 0"));
    v[5] = 0.0f;
    spc_mat4 M = spc_mat4_scale(spc_v3(1, 0, 1));
    CHECK(spc_sdfgrid_create(v, 3, 3, 3, &M, true, "g.vol", 0, 0, &err) == NULL);
    CHECK(err.code == SPC_ERR_VALUE && strstr(err.msg, "singular"));
    /* a grid without surface is valid and never hit */
    for (int i = 0; i < 27; ++i)
        v[i] = 1.0f;
    spc_sdfgrid *g = spc_sdfgrid_create(v, 3, 3, 3, NULL, true, "g.vol", 0, 0, &err);
    CHECK(g && spc_sdfgrid_occupied(g) == 0);
    spc_ray r = {spc_v3(0.5, 0.5, -1), spc_v3(0, 0, 1), 0.0, INFINITY};
    double t;
    CHECK(g && !spc_sdfgrid_intersect(g, &r, &t));
    spc_sdfgrid_destroy(g);
    spc_sdfgrid_destroy(NULL);
}

/* ---- the loader ---- */

static char dir[256];

static void write_vol(const char *name, int nx, int ny, int nz, int channels, const float *data, size_t nvalues)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f)
        return;
    int32_t head[5] = {1, nx, ny, nz, channels};
    float box[6] = {0, 0, 0, 1, 1, 1};
    fwrite("VOL\3", 1, 4, f);
    fwrite(head, 4, 5, f);
    fwrite(box, 4, 6, f);
    fwrite(data, 4, nvalues, f);
    fclose(f);
}

static void expect(const char *body, spc_status code, const char *needle)
{
    char xml[2048];
    snprintf(xml, sizeof xml, "<scene version=\"3.0.0\">\n  %s\n</scene>\n", body);
    spc_scene *s = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = spc_mitsuba_load_string(xml, strlen(xml), "bad.xml", dir, NULL, 0, &s, &err);
    char msg[1200];
    spc_error_format(&err, msg, sizeof msg);
    CHECK_MSG(st == code, "status %d, expected %d (%s)", (int)st, (int)code, msg);
    CHECK_MSG(strstr(msg, needle) != NULL, "message '%s' lacks '%s'", msg, needle);
    if (code != SPC_OK)
        CHECK_MSG(strstr(msg, "bad.xml:2:") == msg, "message '%s' does not start with the scene file and line", msg);
    spc_scene_destroy(s);
}

TEST(loader)
{
    snprintf(dir, sizeof dir, "/tmp/spc_test_sdfgrid_%d", (int)getpid());
    char cmd[300];
    snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
    if (system(cmd) != 0) {
        CHECK_MSG(0, "cannot make %s", dir);
        return;
    }
    float v[64];
    for (int i = 0; i < 64; ++i)
        v[i] = (float)((i % 4) - 1.5);
    write_vol("ok.vol", 4, 4, 4, 1, v, 64);
    expect("<shape type=\"sdfgrid\"><string name=\"filename\" value=\"ok.vol\"/></shape>", SPC_OK, "");
    expect("<shape type=\"sdfgrid\"><string name=\"filename\" value=\"ok.vol\"/>"
           "<string name=\"normals\" value=\"analytic\"/></shape>",
           SPC_OK, "");
    expect("<shape type=\"sdfgrid\"><string name=\"filename\" value=\"nothere.vol\"/></shape>", SPC_ERR_IO,
           "nothere.vol");
    expect("<shape type=\"sdfgrid\"/>", SPC_ERR_VALUE, "needs a filename");
    expect("<shape type=\"sdfgrid\"><string name=\"filename\" value=\"ok.vol\"/>"
           "<string name=\"normals\" value=\"bumpy\"/></shape>",
           SPC_ERR_VALUE, "normals 'bumpy'");
    expect("<shape type=\"sdfgrid\"><string name=\"filename\" value=\"ok.vol\"/><emitter type=\"area\"/></shape>",
           SPC_ERR_VALUE, "cannot be an area emitter");
    write_vol("cut.vol", 4, 4, 4, 1, v, 40);
    expect("<shape type=\"sdfgrid\"><string name=\"filename\" value=\"cut.vol\"/></shape>", SPC_ERR_PARSE, "cut.vol");
    v[9] = NAN;
    write_vol("nan.vol", 4, 4, 4, 1, v, 64);
    expect("<shape type=\"sdfgrid\"><string name=\"filename\" value=\"nan.vol\"/></shape>", SPC_ERR_PARSE, "nan.vol");
    v[9] = 0.0f;
    write_vol("flat.vol", 1, 8, 8, 1, v, 64);
    expect("<shape type=\"sdfgrid\"><string name=\"filename\" value=\"flat.vol\"/></shape>", SPC_ERR_VALUE,
           "at least 2");
    write_vol("rgb.vol", 2, 2, 4, 3, v, 48);
    expect("<shape type=\"sdfgrid\"><string name=\"filename\" value=\"rgb.vol\"/></shape>", SPC_ERR_VALUE,
           "3 channels, expected 1");
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        printf("  could not remove %s\n", dir);
}

/* A glass sdfgrid is never a specular chain vertex (its normal has no derivatives): a glass
 * sphere beside it is; the default render (specular NEE on) runs and gives a finite image. */
TEST(not_a_chain_vertex)
{
    snprintf(dir, sizeof dir, "%s/scenes", spc_test_source_dir());
    const char *xml =
        "<scene version=\"3.0.0\">"
        "<sensor type=\"perspective\"><transform name=\"to_world\"><lookat origin=\"0,0,4\" target=\"0,0,0\" "
        "up=\"0,1,0\"/></transform><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/>"
        "<integer name=\"height\" value=\"8\"/></film></sensor>"
        "<shape type=\"sdfgrid\"><string name=\"filename\" value=\"sdfgrid/ball.vol\"/>"
        "<bsdf type=\"dielectric\"/><transform name=\"to_world\"><translate x=\"-1.2\" y=\"-0.5\" "
        "z=\"-0.5\"/></transform></shape>"
        "<shape type=\"sphere\"><float name=\"radius\" value=\"0.4\"/><point name=\"center\" x=\"0.7\" "
        "y=\"0\" z=\"0\"/><bsdf type=\"dielectric\"/></shape>"
        "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"3\"/><translate z=\"-1\"/>"
        "</transform></shape>"
        "<shape type=\"sphere\"><float name=\"radius\" value=\"0.2\"/><point name=\"center\" x=\"0\" "
        "y=\"2\" z=\"1\"/><emitter type=\"area\"><rgb name=\"radiance\" value=\"20\"/></emitter></shape>"
        "</scene>";
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = spc_mitsuba_load_string(xml, strlen(xml), "chain.xml", dir, NULL, 0, &sc, &err);
    CHECK_MSG(st == SPC_OK, "%s", err.msg);
    if (st != SPC_OK)
        return;
    CHECK(sc->nshapes == 4 && sc->shapes[0]->type == SPC_SHAPE_SDFGRID);
    CHECK(!spc_scene_shape_is_caster(sc->shapes[0], true, NULL));
    CHECK(spc_scene_shape_is_caster(sc->shapes[1], true, NULL));
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 16;
    o.seed = 1;
    spc_film *f = NULL;
    spc_render_stats rs;
    st = spc_render(sc, &o, &f, &rs, &err);
    CHECK_MSG(st == SPC_OK, "%s", err.msg);
    if (f) {
        const float *rgb = spc_film_rgb(f);
        double sum = 0.0;
        bool finite = true;
        for (int i = 0; i < 3 * 64; ++i) {
            finite &= isfinite(rgb[i]) != 0;
            sum += rgb[i];
        }
        CHECK(finite && sum > 0.0);
    }
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(plane_exact_under_transform);
    RUN(cubic_surface_exact);
    RUN(sphere_inside_outside);
    RUN(smooth_normals_closer_on_sphere);
    RUN(bad_grids);
    RUN(loader);
    RUN(not_a_chain_vertex);
    return spc_test_finish();
}
