/*
 * tests/test_mesh_io.c: mesh loaders and mesh operations.
 *
 * OBJ: triangles, quads, convex n-gons, a concave polygon (ear clipping must not produce a
 * triangle outside it), negative indices, v/vt/vn combinations de-indexed into vertices, flipped
 * uvs, missing normals, and errors with file:line:col and the right status. PLY: the same mesh
 * written here as ascii, binary little and big endian (with extra properties and elements to
 * skip) loads identically; errors name lines or elements; vertex and face attributes are named and
 * grouped as Mitsuba 3 does and read back by the mesh_attribute texture. .serialized: files written here with
 * zlib (float and double, versions 3 and 4, several meshes with the end-of-file dictionary),
 * truncated and corrupt ones fail. Mesh operations: transform, degenerate removal, append,
 * validation, polygon triangulation.
 */
/* ctest-labels: unit */
#include <stdint.h>
#include <stdio.h>
#include <unistd.h>

#include <zlib.h>

#include "harness.h"
#include "io/mesh_io.h"
#include "scene/hit.h"
#include "scene/mesh.h"
#include "scene/shape.h"
#include "scene/texture.h"

static char tmpdir[256];

static const char *tmp_path(const char *name)
{
    static char buf[4][512];
    static int k = 0;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (f) {
        fwrite(data, 1, n, f);
        fclose(f);
    }
}

static double tri_area_z(const spc_mesh *m, size_t t)
{
    spc_vec3 a = spc_mesh_p(m, m->idx[3 * t]), b = spc_mesh_p(m, m->idx[3 * t + 1]), c = spc_mesh_p(m, m->idx[3 * t + 2]);
    return 0.5 * spc_cross(spc_sub(b, a), spc_sub(c, a)).z;
}

static double total_area(const spc_mesh *m)
{
    double s = 0.0;
    for (size_t t = 0; t < m->ntris; ++t) {
        spc_vec3 a = spc_mesh_p(m, m->idx[3 * t]), b = spc_mesh_p(m, m->idx[3 * t + 1]),
                 c = spc_mesh_p(m, m->idx[3 * t + 2]);
        s += 0.5 * spc_length(spc_cross(spc_sub(b, a), spc_sub(c, a)));
    }
    return s;
}

/* ---------------- OBJ ---------------- */

TEST(obj_quads_ngons_and_negative_indices)
{
    const char *path = tmp_path("shapes.obj");
    write_text(path, "# a quad, a convex pentagon and a triangle by negative indices\r\n"
                     "o thing\n"
                     "mtllib none.mtl\n"
                     "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                     "g quad\nusemtl red\ns 1\n"
                     "f 1 2 3 4\n"
                     "v 3 0 0\n  v 4 0 0 # trailing comment\nv 4.5 1 0\nv 3.5 2 0\nv 2.5 1 0\n"
                     "f 5 6 7 8 9\n"
                     "v 10 0 0\nv 11 0 0\nv 10 1 0 1.0\n"
                     "f -3 -2 -1\n"
                     "l 1 2\n"
                     "f 1 2 3"); /* no newline at the end */
    spc_mesh m;
    spc_error err = {0};
    spc_status st = spc_obj_load(path, &m, &err);
    CHECK_MSG(st == SPC_OK, "%s", err.msg);
    CHECK(m.ntris == 2 + 3 + 1 + 1);
    CHECK(m.nverts == 4 + 5 + 3);
    CHECK(m.n == NULL && m.uv == NULL);
    /* every triangle faces +z (windings kept) and the areas add up */
    bool all_pos = true;
    for (size_t t = 0; t < m.ntris; ++t)
        all_pos &= tri_area_z(&m, t) > 0.0;
    CHECK(all_pos);
    double shoelace = 0.0;
    double px[5] = {3, 4, 4.5, 3.5, 2.5}, py[5] = {0, 0, 1, 2, 1};
    for (int i = 0; i < 5; ++i)
        shoelace += px[i] * py[(i + 1) % 5] - px[(i + 1) % 5] * py[i];
    CHECK_NEAR(total_area(&m), 1.0 + 0.5 * shoelace + 0.5 + 0.5, 1e-9);
    /* the negative-index triangle uses the last three positions */
    spc_vec3 p = spc_mesh_p(&m, m.idx[3 * 5 + 2]);
    CHECK(p.x == 10.0 && p.y == 1.0);
    spc_mesh_release(&m);
    CHECK(m.p == NULL && m.ntris == 0);
}

TEST(obj_concave_polygon_is_ear_clipped)
{
    /* An L shape listed from a corner that cannot see the whole polygon: a fan from (2,0) would
     * leave the polygon. Area 3. Also in the yz plane, to exercise the dominant-axis projection. */
    const char *path = tmp_path("concave.obj");
    write_text(path, "v 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\n"
                     "f 1 2 3 4 5 6\n"
                     "v 5 2 0\nv 5 2 1\nv 5 1 1\nv 5 1 2\nv 5 0 2\nv 5 0 0\n"
                     "f 7 8 9 10 11 12\n");
    spc_mesh m;
    spc_error err = {0};
    CHECK(spc_obj_load(path, &m, &err) == SPC_OK);
    CHECK(m.ntris == 8);
    bool all_pos = true;
    double a0 = 0.0, a1 = 0.0;
    for (size_t t = 0; t < 4 && t < m.ntris; ++t) {
        all_pos &= tri_area_z(&m, t) > 0.0;
        a0 += tri_area_z(&m, t);
    }
    CHECK(all_pos);
    CHECK_NEAR(a0, 3.0, 1e-12);
    /* second L in the plane x = 5: every triangle's normal points the same way (+x or -x) */
    int plus = 0, minus = 0;
    for (size_t t = 4; t < m.ntris; ++t) {
        spc_vec3 a = spc_mesh_p(&m, m.idx[3 * t]), b = spc_mesh_p(&m, m.idx[3 * t + 1]),
                 c = spc_mesh_p(&m, m.idx[3 * t + 2]);
        double nx = spc_cross(spc_sub(b, a), spc_sub(c, a)).x;
        plus += nx > 0.0;
        minus += nx < 0.0;
        a1 += 0.5 * fabs(nx);
    }
    CHECK(plus == 4 || minus == 4);
    CHECK_NEAR(a1, 3.0, 1e-12);
    spc_mesh_release(&m);
}

TEST(obj_deindexing_normals_and_uvs)
{
    /* a unit square made of two faces sharing an edge, with per-face normals and uvs */
    const char *path = tmp_path("attrs.obj");
    write_text(path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                     "vt 0 0\nvt 1 0\nvt 1 1\nvt 0.25 0.75 0.0\n"
                     "vn 0 0 1\nvn 0 0.6 0.8\n"
                     "f 1/1/1 2/2/1 3/3/1\n"
                     "f 1/1/2 3/3/2 4/4/2\n"
                     "f 1/1/1 3/3/1 2/2/1\n"); /* reuses the first face's three vertices */
    spc_mesh m;
    spc_error err = {0};
    CHECK(spc_obj_load(path, &m, &err) == SPC_OK);
    CHECK(m.ntris == 3);
    CHECK(m.nverts == 6); /* (1,1,1) (2,2,1) (3,3,1) (1,1,2) (3,3,2) (4,4,2) */
    CHECK(m.n != NULL && m.uv != NULL);
    if (m.n && m.uv && m.nverts == 6) {
        CHECK(m.idx[6] == m.idx[0] && m.idx[7] == m.idx[2] && m.idx[8] == m.idx[1]);
        uint32_t v4 = m.idx[5]; /* corner 4/4/2 */
        CHECK(m.p[3 * v4] == 0.0f && m.p[3 * v4 + 1] == 1.0f);
        CHECK(m.n[3 * v4 + 1] == 0.6f && m.n[3 * v4 + 2] == 0.8f);
        CHECK(m.uv[2 * v4] == 0.25f && m.uv[2 * v4 + 1] == 0.25f); /* v flipped: 1 - 0.75 */
    }
    spc_mesh_release(&m);
    CHECK(spc_obj_load_ex(path, false, &m, &err) == SPC_OK);
    if (m.uv && m.nverts == 6)
        CHECK(m.uv[2 * m.idx[5] + 1] == 0.75f);
    spc_mesh_release(&m);

    /* v//vn and v/vt forms; missing normals on some corners drop all normals */
    write_text(path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvt 0.5 0.5\n"
                     "f 1//1 2//1 3//1\n"
                     "f 2/1 4/1 3/1\n");
    spc_warn_set_quiet(1);
    CHECK(spc_obj_load(path, &m, &err) == SPC_OK);
    CHECK(m.ntris == 2 && m.nverts == 6);
    CHECK(m.n == NULL);
    CHECK(m.uv != NULL);
    if (m.uv && m.nverts == 6) {
        CHECK(m.uv[2 * m.idx[0]] == 0.0f);  /* corner without uv -> (0,0) */
        CHECK(m.uv[2 * m.idx[3]] == 0.5f);
    }
    spc_mesh_release(&m);

    /* positions only: no normals, no uvs; unreferenced vertices are dropped */
    write_text(path, "v 0 0 0\nv 9 9 9\nv 1 0 0\nv 0 1 0\nf 1 3 4\n");
    CHECK(spc_obj_load(path, &m, &err) == SPC_OK);
    CHECK(m.nverts == 3 && m.ntris == 1 && m.n == NULL && m.uv == NULL);
    spc_mesh_release(&m);
}

static void check_obj_error(const char *text, spc_status code, int line, int col, const char *needle)
{
    const char *path = tmp_path("bad.obj");
    write_text(path, text);
    spc_mesh m;
    spc_error err = {0};
    spc_status st = spc_obj_load(path, &m, &err);
    char buf[1200];
    spc_error_format(&err, buf, sizeof buf);
    CHECK_MSG(st == code, "status %d, expected %d (%s)", (int)st, (int)code, buf);
    CHECK_MSG(err.line == line, "line %d, expected %d (%s)", err.line, line, buf);
    if (col > 0)
        CHECK_MSG(err.col == col, "col %d, expected %d (%s)", err.col, col, buf);
    CHECK_MSG(strstr(buf, "bad.obj:") != NULL, "%s", buf);
    if (needle)
        CHECK_MSG(strstr(buf, needle) != NULL, "'%s' not in '%s'", needle, buf);
    CHECK(m.p == NULL && m.idx == NULL && m.ntris == 0);
}

TEST(obj_errors_name_line_and_column)
{
    check_obj_error("v 0 0 0\nv 1 0 0\nv 1 2 abc\nf 1 2 3\n", SPC_ERR_PARSE, 3, 7, "abc");
    check_obj_error("v 0 0 0\nv 1 0 0\nv 1 2\nf 1 2 3\n", SPC_ERR_PARSE, 3, 0, "missing");
    check_obj_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", SPC_ERR_VALUE, 4, 7, "out of range");
    check_obj_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", SPC_ERR_VALUE, 4, 9, "out of range");
    check_obj_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", SPC_ERR_VALUE, 4, 3, "index 0");
    check_obj_error("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", SPC_ERR_VALUE, 2, 3, "non-finite");
    check_obj_error("v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n", SPC_ERR_VALUE, 2, 3, NULL);
    check_obj_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", SPC_ERR_PARSE, 4, 1, "at least 3");
    check_obj_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/2 2/1 3/1\n", SPC_ERR_VALUE, 5, 5, "texture");
    check_obj_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1x 2 3\n", SPC_ERR_PARSE, 5, 6, "unexpected");
    check_obj_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 inf\nf 1 2 3\n", SPC_ERR_VALUE, 4, 8, NULL);
    check_obj_error("v 0 0 0\n# no faces\n", SPC_ERR_VALUE, 0, 0, "no faces");
    spc_mesh m;
    spc_error err = {0};
    CHECK(spc_obj_load(tmp_path("does_not_exist.obj"), &m, &err) == SPC_ERR_IO);
}

/* ---------------- PLY ---------------- */

typedef struct plyw {
    FILE *f;
    int mode; /* 0 ascii, 1 little endian, 2 big endian */
} plyw;

static void put_bytes(plyw *w, const void *v, size_t n)
{
    unsigned char b[8];
    memcpy(b, v, n);
    bool host_le = (union { uint16_t u; unsigned char c[2]; }){.u = 1}.c[0] == 1;
    bool swap = (w->mode == 1) != host_le;
    for (size_t i = 0; i < n; ++i)
        fputc(b[swap ? n - 1 - i : i], w->f);
}

/* type: 'f' float, 'd' double, 'B' uchar, 'H' ushort, 'i' int, 'I' uint */
static void put(plyw *w, char type, double v)
{
    if (w->mode == 0) {
        if (type == 'f' || type == 'd')
            fprintf(w->f, "%.9g ", v);
        else
            fprintf(w->f, "%.0f ", v);
        return;
    }
    switch (type) {
    case 'f': { float x = (float)v; put_bytes(w, &x, 4); break; }
    case 'd': { put_bytes(w, &v, 8); break; }
    case 'B': { uint8_t x = (uint8_t)v; put_bytes(w, &x, 1); break; }
    case 'H': { uint16_t x = (uint16_t)v; put_bytes(w, &x, 2); break; }
    case 'i': { int32_t x = (int32_t)v; put_bytes(w, &x, 4); break; }
    case 'I': { uint32_t x = (uint32_t)v; put_bytes(w, &x, 4); break; }
    default: break;
    }
}

static void endl(plyw *w)
{
    if (w->mode == 0)
        fputc('\n', w->f);
}

static const float ply_pos[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0.5f, 0.25f}};
static const float ply_uv[5][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5f, 0.125f}};

/* The test mesh: 5 vertices (with normals, uvs and extra properties), an "edge" element with a
 * list to skip, a quad and a triangle. variant 1 uses double coordinates, ushort/uint index lists
 * named vertex_index and s/t uvs. */
static void write_ply(const char *path, int mode, int variant)
{
    plyw w = {fopen(path, "wb"), mode};
    if (!w.f)
        return;
    static const char *const fmt[3] = {"ascii", "binary_little_endian", "binary_big_endian"};
    const char *ct = variant ? "double" : "float";
    fprintf(w.f, "ply\nformat %s 1.0\ncomment written by test_mesh_io\n", fmt[mode]);
    fprintf(w.f, "element vertex 5\nproperty %s x\nproperty %s y\nproperty %s z\nproperty uchar red\n", ct, ct, ct);
    fprintf(w.f, "property float nx\nproperty float ny\nproperty float nz\nproperty %s %s\nproperty %s %s\n", ct,
            variant ? "s" : "u", ct, variant ? "t" : "v");
    fprintf(w.f, "property double quality\n");
    fprintf(w.f, "element edge 2\nproperty int vertex1\nproperty list uchar float tags\nproperty int vertex2\n");
    fprintf(w.f, "element face 2\nproperty list %s %s %s\nproperty int flags\n", variant ? "ushort" : "uchar",
            variant ? "uint" : "int", variant ? "vertex_index" : "vertex_indices");
    fprintf(w.f, "end_header\n");
    char c = variant ? 'd' : 'f';
    for (int i = 0; i < 5; ++i) {
        put(&w, c, ply_pos[i][0]), put(&w, c, ply_pos[i][1]), put(&w, c, ply_pos[i][2]);
        put(&w, 'B', 200 + i);
        put(&w, 'f', 0), put(&w, 'f', 0.6), put(&w, 'f', 0.8);
        put(&w, c, ply_uv[i][0]), put(&w, c, ply_uv[i][1]);
        put(&w, 'd', 1e10 * i);
        endl(&w);
    }
    for (int e = 0; e < 2; ++e) {
        put(&w, 'i', e);
        put(&w, 'B', 3 - e);
        for (int k = 0; k < 3 - e; ++k)
            put(&w, 'f', 0.5 * k);
        put(&w, 'i', e + 1);
        endl(&w);
    }
    char lc = variant ? 'H' : 'B', ic = variant ? 'I' : 'i';
    put(&w, lc, 4), put(&w, ic, 0), put(&w, ic, 1), put(&w, ic, 2), put(&w, ic, 3), put(&w, 'i', 7);
    endl(&w);
    put(&w, lc, 3), put(&w, ic, 1), put(&w, ic, 4), put(&w, ic, 2), put(&w, 'i', 8);
    endl(&w);
    fclose(w.f);
}

static bool same_mesh(const spc_mesh *a, const spc_mesh *b)
{
    if (a->nverts != b->nverts || a->ntris != b->ntris || !a->p || !b->p || !a->idx || !b->idx)
        return false;
    if ((a->n == NULL) != (b->n == NULL) || (a->uv == NULL) != (b->uv == NULL))
        return false;
    return memcmp(a->p, b->p, 3 * a->nverts * sizeof(float)) == 0 &&
           memcmp(a->idx, b->idx, 3 * a->ntris * sizeof(uint32_t)) == 0 &&
           (!a->n || memcmp(a->n, b->n, 3 * a->nverts * sizeof(float)) == 0) &&
           (!a->uv || memcmp(a->uv, b->uv, 2 * a->nverts * sizeof(float)) == 0);
}

TEST(ply_ascii_and_binary_agree)
{
    spc_mesh ref = {0};
    for (int variant = 0; variant < 2; ++variant)
        for (int mode = 0; mode < 3; ++mode) {
            char name[64];
            snprintf(name, sizeof name, "m%d_%d.ply", variant, mode);
            const char *path = tmp_path(name);
            write_ply(path, mode, variant);
            spc_mesh m;
            spc_error err = {0};
            spc_status st = spc_ply_load(path, &m, &err);
            CHECK_MSG(st == SPC_OK, "%s: %s", name, err.msg);
            if (st != SPC_OK)
                continue;
            CHECK(m.nverts == 5 && m.ntris == 3 && m.n && m.uv);
            if (variant == 0 && mode == 0) {
                ref = m;
                int bad = 0;
                for (int i = 0; i < 5 && m.nverts == 5; ++i)
                    for (int k = 0; k < 3; ++k)
                        bad += m.p[3 * i + k] != ply_pos[i][k];
                CHECK(bad == 0);
                CHECK(m.uv[2 * 4] == 0.5f && m.uv[2 * 4 + 1] == 0.125f);
                CHECK(m.n[1] == 0.6f && m.n[2] == 0.8f);
                uint32_t expect[9] = {0, 1, 2, 0, 2, 3, 1, 4, 2};
                CHECK(m.ntris == 3 && memcmp(m.idx, expect, sizeof expect) == 0);
                continue;
            }
            CHECK_MSG(same_mesh(&ref, &m), "%s differs from the ascii file", name);
            spc_mesh_release(&m);
        }
    spc_mesh_release(&ref);
}

static void check_ply_error(const char *path, spc_status code, int line, const char *needle)
{
    spc_mesh m;
    spc_error err = {0};
    spc_status st = spc_ply_load(path, &m, &err);
    char buf[1200];
    spc_error_format(&err, buf, sizeof buf);
    CHECK_MSG(st == code, "status %d, expected %d (%s)", (int)st, (int)code, buf);
    if (line >= 0)
        CHECK_MSG(err.line == line, "line %d, expected %d (%s)", err.line, line, buf);
    if (needle)
        CHECK_MSG(strstr(buf, needle) != NULL, "'%s' not in '%s'", needle, buf);
    CHECK(m.p == NULL && m.ntris == 0);
}

TEST(ply_errors)
{
    const char *path = tmp_path("bad.ply");
    const char *hdr = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    char text[1024];
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0.5x\n3 0 1 2\n", hdr);
    write_text(path, text);
    check_ply_error(path, SPC_ERR_PARSE, 12, "0.5x");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", hdr);
    write_text(path, text);
    check_ply_error(path, SPC_ERR_VALUE, 13, "out of range");
    snprintf(text, sizeof text, "%s0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n", hdr);
    write_text(path, text);
    check_ply_error(path, SPC_ERR_VALUE, 12, "non-finite");
    write_text(path, "ply\nformat ascii 1.0\nelement vertex 3\nproperty flot x\nend_header\n");
    check_ply_error(path, SPC_ERR_PARSE, 4, "flot");
    write_text(path, "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n");
    check_ply_error(path, SPC_ERR_PARSE, -1, "end_header");
    write_text(path, "not a ply\n");
    check_ply_error(path, SPC_ERR_PARSE, 1, NULL);
    /* a count far beyond the file's size fails before allocating */
    write_text(path, "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                     "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                     "end_header\n");
    check_ply_error(path, SPC_ERR_PARSE, 3, "too short");

    /* truncated binary files name the element */
    write_ply(path, 1, 0);
    FILE *f = fopen(path, "rb");
    unsigned char buf[4096];
    size_t n = f ? fread(buf, 1, sizeof buf, f) : 0;
    if (f)
        fclose(f);
    write_bytes(path, buf, n - 6);
    check_ply_error(path, SPC_ERR_PARSE, 0, "face 1");
    /* index out of range in a binary file: the last index of face 1 (then its int flags) */
    buf[n - 8] = 9;
    write_bytes(path, buf, n);
    check_ply_error(path, SPC_ERR_VALUE, 0, "face 1: vertex index 9");
}

/* ---------------- .serialized ---------------- */

typedef struct bytes {
    unsigned char *b;
    size_t n, cap;
} bytes;

static void add(bytes *s, const void *v, size_t n)
{
    if (s->n + n > s->cap) {
        s->cap = 2 * (s->n + n) + 256;
        s->b = realloc(s->b, s->cap);
    }
    memcpy(s->b + s->n, v, n);
    s->n += n;
}
static void add_u16(bytes *s, uint16_t v) { add(s, &v, 2); } /* the test host is little endian */
static void add_u32(bytes *s, uint32_t v) { add(s, &v, 4); }
static void add_u64(bytes *s, uint64_t v) { add(s, &v, 8); }
static void add_real(bytes *s, bool dbl, double v)
{
    if (dbl) {
        add(s, &v, 8);
    } else {
        float f = (float)v;
        add(s, &f, 4);
    }
}

/* A quad (4 vertices, 2 triangles) shifted by `shift`; appends header + zlib stream to out. */
static void add_serialized_mesh(bytes *out, int version, uint32_t flags, double shift, bool corrupt_index)
{
    bytes raw = {0};
    bool dbl = (flags & 0x2000) != 0;
    add_u32(&raw, flags);
    if (version == 4)
        add(&raw, "quad", 5);
    add_u64(&raw, 4);
    add_u64(&raw, 2);
    double pos[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    for (int i = 0; i < 4; ++i)
        for (int k = 0; k < 3; ++k)
            add_real(&raw, dbl, pos[i][k] + (k == 2 ? shift : 0.0));
    if (flags & 0x1)
        for (int i = 0; i < 4; ++i)
            add_real(&raw, dbl, 0), add_real(&raw, dbl, 0), add_real(&raw, dbl, 1);
    if (flags & 0x2)
        for (int i = 0; i < 4; ++i)
            add_real(&raw, dbl, pos[i][0] * 0.5), add_real(&raw, dbl, pos[i][1] * 0.25);
    if (flags & 0x8)
        for (int i = 0; i < 12; ++i)
            add_real(&raw, dbl, 0.3);
    uint32_t idx[6] = {0, 1, 2, 0, 2, corrupt_index ? 4u : 3u};
    add(&raw, idx, sizeof idx);
    uLongf clen = compressBound(raw.n);
    unsigned char *c = malloc(clen);
    compress2(c, &clen, raw.b, raw.n, 6);
    add_u16(out, 0x041C);
    add_u16(out, (uint16_t)version);
    add(out, c, clen);
    free(c);
    free(raw.b);
}

static void check_quad(const spc_mesh *m, double shift, bool normals, bool uvs)
{
    CHECK(m->nverts == 4 && m->ntris == 2);
    CHECK((m->n != NULL) == normals && (m->uv != NULL) == uvs);
    if (m->nverts != 4 || m->ntris != 2)
        return;
    CHECK(m->p[3 * 2] == 1.0f && m->p[3 * 2 + 1] == 1.0f && m->p[3 * 2 + 2] == (float)shift);
    uint32_t expect[6] = {0, 1, 2, 0, 2, 3};
    CHECK(memcmp(m->idx, expect, sizeof expect) == 0);
    if (m->n)
        CHECK(m->n[3 * 3 + 2] == 1.0f);
    if (m->uv)
        CHECK(m->uv[2 * 2] == 0.5f && m->uv[2 * 2 + 1] == 0.25f);
}

TEST(serialized_single_meshes)
{
    const char *path = tmp_path("one.serialized");
    spc_mesh m;
    spc_error err = {0};
    struct {
        int version;
        uint32_t flags;
        bool n, uv;
    } cases[] = {{4, 0x1000 | 0x1 | 0x2, true, true}, {4, 0x2000 | 0x2, false, true}, {3, 0x2000 | 0x1, true, false},
                 {3, 0x1000, false, false},           {4, 0x1000 | 0x1 | 0x10, false, false},
                 {4, 0x2000 | 0x1 | 0x2 | 0x8, true, true}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        bytes b = {0};
        add_serialized_mesh(&b, cases[c].version, cases[c].flags, 0.5, false);
        write_bytes(path, b.b, b.n);
        spc_status st = spc_serialized_load(path, 0, &m, &err);
        CHECK_MSG(st == SPC_OK, "case %zu: %s", c, err.msg);
        if (st == SPC_OK)
            check_quad(&m, 0.5, cases[c].n, cases[c].uv);
        spc_mesh_release(&m);
        free(b.b);
    }
}

TEST(serialized_multi_mesh_dictionary)
{
    const char *path = tmp_path("multi.serialized");
    spc_mesh m;
    spc_error err = {0};
    for (int version = 3; version <= 4; ++version) {
        bytes b = {0};
        uint64_t off[3];
        for (int i = 0; i < 3; ++i) {
            off[i] = b.n;
            add_serialized_mesh(&b, version, 0x1000 | (i == 1 ? 0x2 : 0), i * 10.0, false);
        }
        for (int i = 0; i < 3; ++i) {
            if (version == 4)
                add_u64(&b, off[i]);
            else
                add_u32(&b, (uint32_t)off[i]);
        }
        add_u32(&b, 3);
        write_bytes(path, b.b, b.n);
        for (int i = 0; i < 3; ++i) {
            spc_status st = spc_serialized_load(path, i, &m, &err);
            CHECK_MSG(st == SPC_OK, "v%d mesh %d: %s", version, i, err.msg);
            if (st == SPC_OK)
                check_quad(&m, i * 10.0, false, i == 1);
            spc_mesh_release(&m);
        }
        CHECK(spc_serialized_load(path, 3, &m, &err) == SPC_ERR_VALUE);
        CHECK(strstr(err.msg, "out of range") != NULL);
        CHECK(spc_serialized_load(path, -1, &m, &err) == SPC_ERR_VALUE);
        free(b.b);
    }
}

TEST(serialized_corrupt_files)
{
    const char *path = tmp_path("bad.serialized");
    spc_mesh m;
    spc_error err = {0};
    bytes b = {0};
    add_serialized_mesh(&b, 4, 0x1000 | 0x1 | 0x2, 0.0, false);
    /* every truncation fails */
    int fails = 0;
    for (size_t len = 0; len < b.n; len += 3) {
        write_bytes(path, b.b, len);
        spc_status st = spc_serialized_load(path, 0, &m, &err);
        if (st != SPC_ERR_PARSE) {
            ++fails;
            printf("  truncated to %zu of %zu: status %d\n", len, b.n, (int)st);
        }
        if (st == SPC_OK)
            spc_mesh_release(&m);
    }
    CHECK(fails == 0);
    /* wrong magic, wrong version */
    b.b[0] ^= 0xff;
    write_bytes(path, b.b, b.n);
    CHECK(spc_serialized_load(path, 0, &m, &err) == SPC_ERR_PARSE);
    CHECK(strstr(err.msg, "format") != NULL);
    b.b[0] ^= 0xff;
    b.b[2] = 5;
    write_bytes(path, b.b, b.n);
    CHECK(spc_serialized_load(path, 0, &m, &err) == SPC_ERR_PARSE);
    CHECK(strstr(err.msg, "version") != NULL);
    b.b[2] = 4;
    /* a flipped byte inside the stream: zlib's checksum or the format catches it */
    b.b[b.n / 2] ^= 0x10;
    write_bytes(path, b.b, b.n);
    spc_status st = spc_serialized_load(path, 0, &m, &err);
    CHECK(st != SPC_OK);
    if (st == SPC_OK)
        spc_mesh_release(&m);
    free(b.b);
    /* an index out of range */
    bytes c = {0};
    add_serialized_mesh(&c, 4, 0x1000, 0.0, true);
    write_bytes(path, c.b, c.n);
    CHECK(spc_serialized_load(path, 0, &m, &err) == SPC_ERR_VALUE);
    CHECK(strstr(err.msg, "triangle 1") != NULL);
    /* shape 1 of a file without a dictionary */
    CHECK(spc_serialized_load(path, 1, &m, &err) != SPC_OK);
    free(c.b);
    CHECK(spc_serialized_load(tmp_path("none.serialized"), 0, &m, &err) == SPC_ERR_IO);
}

/* ---------------- mutation fuzzing ---------------- */

static uint32_t lcg(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return *s >> 8;
}

typedef spc_status (*loader)(const char *path, spc_mesh *out, spc_error *err);
static spc_status load_serialized0(const char *path, spc_mesh *out, spc_error *err)
{
    return spc_serialized_load(path, 0, out, err);
}

/* Byte flips, insertions of digits/signs/separators and truncations of a valid file: the loader
 * returns OK (with a valid mesh) or an error with a message, never crashes. */
static void fuzz_loader(loader load, const unsigned char *src, size_t n, const char *name, int rounds, uint32_t seed)
{
    unsigned char *m = malloc(n + 16);
    const char *path = tmp_path(name);
    int rejected = 0;
    for (int r = 0; r < rounds; ++r) {
        size_t len = n;
        memcpy(m, src, n);
        int edits = 1 + (int)(lcg(&seed) % 3);
        for (int k = 0; k < edits; ++k) {
            size_t at = lcg(&seed) % len;
            static const char pool[] = "0123456789-+.eE/ \n#nanif";
            switch (lcg(&seed) % 3) {
            case 0: m[at] = (unsigned char)lcg(&seed); break;
            case 1: m[at] = (unsigned char)pool[lcg(&seed) % (sizeof pool - 1)]; break;
            default: len = at + 1; break;
            }
        }
        write_bytes(path, m, len);
        spc_mesh mesh;
        spc_error err = {0};
        spc_status st = load(path, &mesh, &err);
        if (st == SPC_OK) {
            CHECK(spc_mesh_validate(&mesh, path, &err) == SPC_OK);
            spc_mesh_release(&mesh);
        } else {
            ++rejected;
            CHECK(err.msg[0] != '\0');
            CHECK(mesh.p == NULL && mesh.idx == NULL);
        }
    }
    printf("  %s: %d of %d mutated files rejected\n", name, rejected, rounds);
    free(m);
}

TEST(loaders_survive_mutations)
{
    const char *obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 1\nvn 0 0 1\n"
                      "f 1/1/1 2/2/1 3/2/1 4/1/1\nf -4//1 -2//1 -1//1\nf 1 2 3\n";
    fuzz_loader(spc_obj_load, (const unsigned char *)obj, strlen(obj), "fuzz.obj", 400, 11);
    for (int mode = 0; mode < 3; ++mode) {
        const char *path = tmp_path("fuzz_src.ply");
        write_ply(path, mode, mode == 2);
        FILE *f = fopen(path, "rb");
        unsigned char buf[4096];
        size_t n = f ? fread(buf, 1, sizeof buf, f) : 0;
        if (f)
            fclose(f);
        fuzz_loader(spc_ply_load, buf, n, "fuzz.ply", 300, 20u + (uint32_t)mode);
    }
    bytes b = {0};
    add_serialized_mesh(&b, 4, 0x1000 | 0x1 | 0x2, 0.0, false);
    fuzz_loader(load_serialized0, b.b, b.n, "fuzz.serialized", 300, 31);
    free(b.b);
}

/* ---------------- mesh operations ---------------- */

static spc_mesh make_mesh(size_t nv, const float *p, const float *n, const float *uv, size_t nt, const uint32_t *idx)
{
    spc_mesh m = {0};
    m.nverts = nv;
    m.ntris = nt;
    m.p = malloc(3 * nv * sizeof(float));
    memcpy(m.p, p, 3 * nv * sizeof(float));
    if (n) {
        m.n = malloc(3 * nv * sizeof(float));
        memcpy(m.n, n, 3 * nv * sizeof(float));
    }
    if (uv) {
        m.uv = malloc(2 * nv * sizeof(float));
        memcpy(m.uv, uv, 2 * nv * sizeof(float));
    }
    m.idx = malloc(3 * nt * sizeof(uint32_t));
    memcpy(m.idx, idx, 3 * nt * sizeof(uint32_t));
    return m;
}

TEST(mesh_transform_normals_by_inverse_transpose)
{
    float p[9] = {1, 1, 0, 0, 0, 0, 0, 0, 1};
    float s = (float)(1.0 / sqrt(2.0));
    float n[9] = {s, s, 0, s, s, 0, 0, 0, 1};
    uint32_t idx[3] = {0, 1, 2};
    spc_mesh m = make_mesh(3, p, n, NULL, 1, idx);
    spc_mat4 sc = spc_mat4_scale(spc_v3(2, 1, 1)), tr = spc_mat4_translate(spc_v3(1, 2, 3));
    spc_mat4 M = spc_mat4_mul(&tr, &sc);
    CHECK(spc_mesh_transform(&m, &M));
    CHECK_NEAR(m.p[0], 3.0, 1e-6);
    CHECK_NEAR(m.p[1], 3.0, 1e-6);
    CHECK_NEAR(m.p[2], 3.0, 1e-6);
    /* (1,1,0) under the inverse transpose of diag(2,1,1): (0.5, 1, 0), normalized */
    CHECK_NEAR(m.n[0], 0.5 / sqrt(1.25), 1e-6);
    CHECK_NEAR(m.n[1], 1.0 / sqrt(1.25), 1e-6);
    CHECK_NEAR(m.n[2], 0.0, 1e-7);
    CHECK_NEAR(m.n[8], 1.0, 1e-7);
    /* singular: refused, mesh untouched */
    float before[9];
    memcpy(before, m.p, sizeof before);
    spc_mat4 flat = spc_mat4_scale(spc_v3(1, 0, 1));
    CHECK(!spc_mesh_transform(&m, &flat));
    CHECK(memcmp(before, m.p, sizeof before) == 0);
    /* a mirror keeps the vertex order */
    spc_mat4 mirror = spc_mat4_scale(spc_v3(-1, 1, 1));
    CHECK(spc_mesh_transform(&m, &mirror));
    CHECK(m.idx[0] == 0 && m.idx[1] == 1 && m.idx[2] == 2);
    CHECK_NEAR(m.p[0], -3.0, 1e-6);
    CHECK_NEAR(m.n[0], -0.5 / sqrt(1.25), 1e-6);
    spc_mesh_release(&m);
}

TEST(mesh_drop_degenerate_append_validate)
{
    float p[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0, 5, 5, 5};
    uint32_t idx[15] = {0, 1, 2, /* good */ 0, 0, 1, /* repeated */ 0, 1, 3, /* collinear */
                        1, 2, 4, /* good */ 2, 2, 2};
    spc_mesh m = make_mesh(5, p, NULL, NULL, 5, idx);
    CHECK(spc_mesh_drop_degenerate(&m) == 3);
    CHECK(m.ntris == 2);
    CHECK(m.idx[0] == 0 && m.idx[2] == 2 && m.idx[3] == 1 && m.idx[5] == 4);
    spc_error err = {0};
    CHECK(spc_mesh_validate(&m, "m", &err) == SPC_OK);

    /* append: dst has normals, src has uvs -> normals dropped, uvs zero-filled for dst */
    float n3[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    float uv3[6] = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f};
    uint32_t one[3] = {0, 1, 2};
    spc_mesh a = make_mesh(3, p, n3, NULL, 1, one);
    spc_mesh b = make_mesh(3, p + 3, NULL, uv3, 1, one);
    CHECK(spc_mesh_append(&a, &b));
    CHECK(a.nverts == 6 && a.ntris == 2 && a.n == NULL && a.uv != NULL);
    CHECK(a.idx[3] == 3 && a.idx[4] == 4 && a.idx[5] == 5);
    if (a.uv)
        CHECK(a.uv[0] == 0.0f && a.uv[6] == 0.1f && a.uv[11] == 0.6f);
    CHECK(a.p[9] == 1.0f);
    CHECK(spc_mesh_validate(&a, "a", &err) == SPC_OK);
    /* appending to an empty mesh copies the layout */
    spc_mesh e = {0};
    CHECK(spc_mesh_append(&e, &b));
    CHECK(e.nverts == 3 && e.uv != NULL && e.n == NULL && e.idx[2] == 2);

    /* validation names the first bad value */
    a.p[4] = NAN;
    CHECK(spc_mesh_validate(&a, "a.obj", &err) == SPC_ERR_VALUE);
    CHECK(strstr(err.msg, "vertex 1") != NULL && strcmp(err.file, "a.obj") == 0);
    a.p[4] = 0.0f;
    a.idx[4] = 6;
    CHECK(spc_mesh_validate(&a, "a.obj", &err) == SPC_ERR_VALUE);
    CHECK(strstr(err.msg, "triangle 1") != NULL);
    spc_mesh_release(&a);
    spc_mesh_release(&b);
    spc_mesh_release(&e);
    spc_mesh_release(&m);
    spc_mesh_release(NULL);
}

TEST(polygon_triangulation)
{
    /* a star (concave, 10 vertices): ear clipping covers exactly its area with positive
     * triangles */
    float p[30];
    uint32_t ids[10];
    for (int i = 0; i < 10; ++i) {
        double a = 2.0 * SPC_PI * i / 10.0, r = (i % 2) ? 0.4 : 1.0;
        p[3 * i] = (float)(r * cos(a)), p[3 * i + 1] = (float)(r * sin(a)), p[3 * i + 2] = 0.0f;
        ids[i] = (uint32_t)i;
    }
    double area = 0.0;
    for (int i = 0; i < 10; ++i) {
        int j = (i + 1) % 10;
        area += 0.5 * ((double)p[3 * i] * p[3 * j + 1] - (double)p[3 * j] * p[3 * i + 1]);
    }
    uint32_t tris[24];
    for (int rot = 0; rot < 10; ++rot) {
        uint32_t r[10];
        for (int i = 0; i < 10; ++i)
            r[i] = ids[(i + rot) % 10];
        size_t k = spc_polygon_triangulate(p, r, 10, tris);
        CHECK(k == 8);
        double sum = 0.0;
        bool pos = true;
        for (size_t t = 0; t < k; ++t) {
            const float *a = p + 3 * tris[3 * t], *b = p + 3 * tris[3 * t + 1], *c = p + 3 * tris[3 * t + 2];
            double z = 0.5 * (((double)b[0] - a[0]) * ((double)c[1] - a[1]) - ((double)b[1] - a[1]) * ((double)c[0] - a[0]));
            pos &= z > 0.0;
            sum += fabs(z);
        }
        CHECK(pos);
        CHECK_NEAR(sum, area, 1e-6);
    }
    CHECK(spc_polygon_triangulate(p, ids, 2, tris) == 0);
}

/* Mesh attributes as Mitsuba 3's PLY loader names them, kept in step with the triangles, and read
 * back by the mesh_attribute texture at a hit. */
TEST(ply_attributes)
{
    const char *path = tmp_path("attrs.ply");
    write_text(path, "ply\nformat ascii 1.0\n"
                     "element vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
                     "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty float glow_x\n"
                     "property float foo\nproperty float bar_q\nproperty float pos_x\nproperty float pos_y\n"
                     "element face 3\nproperty list uchar int vertex_indices\nproperty float weight_0\n"
                     "property float tint_r\nproperty float tint_g\nproperty float tint_b\nend_header\n"
                     "0 0 0   255 0 51   0.5  9 9 9 9\n"
                     "1 0 0   0 255 0    1.5  9 9 9 9\n"
                     "1 1 0   0 0 255    2.5  9 9 9 9\n"
                     "0 1 0   255 255 255 3.5 9 9 9 9\n"
                     "2 0.5 0 0 0 0      4.5  9 9 9 9\n"
                     "4 0 1 2 3  0.25  0.1 0.2 0.3\n"
                     "3 1 4 2    0.75  0.4 0.5 0.6\n"
                     "3 0 0 0    0.5   0 0 0\n");
    spc_mesh m;
    spc_error err = {0};
    spc_status st = spc_ply_load(path, &m, &err);
    CHECK_MSG(st == SPC_OK, "%s", err.msg);
    if (st != SPC_OK)
        return;
    CHECK(m.nattrs == 4);
    const spc_mesh_attr *col = spc_mesh_find_attr(&m, "vertex_color");
    const spc_mesh_attr *glow = spc_mesh_find_attr(&m, "vertex_glow");
    const spc_mesh_attr *w = spc_mesh_find_attr(&m, "face_weight");
    const spc_mesh_attr *tint = spc_mesh_find_attr(&m, "face_tint_color");
    CHECK(!spc_mesh_find_attr(&m, "vertex_foo") && !spc_mesh_find_attr(&m, "vertex_bar") &&
          !spc_mesh_find_attr(&m, "vertex_pos"));
    CHECK(col && col->dim == 3 && !col->face && glow && glow->dim == 1 && !glow->face);
    CHECK(w && w->dim == 1 && w->face && tint && tint->dim == 3 && tint->face);
    if (!col || !glow || !w || !tint || m.ntris != 4) {
        CHECK_MSG(m.ntris == 4, "%zu triangles", m.ntris);
        spc_mesh_release(&m);
        return;
    }
    /* integer colours: normalized and sRGB-decoded (51/255 = 0.2 -> 0.0331) */
    CHECK(col->data[0] == 1.0f && col->data[1] == 0.0f);
    CHECK_NEAR(col->data[2], 0.033105, 1e-5);
    CHECK(glow->data[3] == 3.5f);
    /* the quad's value on both of its triangles, then the triangle's, then the third face's */
    CHECK(w->data[0] == 0.25f && w->data[1] == 0.25f && w->data[2] == 0.75f && w->data[3] == 0.5f);
    CHECK(tint->data[3] == 0.1f && tint->data[6] == 0.4f && tint->data[8] == 0.6f);
    /* dropping the degenerate third face keeps face attributes with their triangles */
    CHECK(spc_mesh_drop_degenerate(&m) == 1 && m.ntris == 3 && w->data[2] == 0.75f);

    spc_shape s;
    memset(&s, 0, sizeof s);
    s.type = SPC_SHAPE_MESH;
    s.mesh = m;
    spc_texture tv, tf, tbad;
    CHECK(spc_texture_init_mesh_attribute(&tv, "vertex_glow", 2.0));
    CHECK(spc_texture_init_mesh_attribute(&tf, "face_tint_color", 1.0));
    CHECK(!spc_texture_init_mesh_attribute(&tbad, "glow", 1.0));
    spc_hit h;
    memset(&h, 0, sizeof h);
    h.shape = &s;
    h.prim = 2; /* vertices 1, 4, 2: glow 1.5, 4.5, 2.5 */
    h.b1 = 0.25;
    h.b2 = 0.5;
    CHECK_NEAR(spc_texture_eval_hit(&tv, &h).g, 2.0 * (0.25 * 1.5 + 0.25 * 4.5 + 0.5 * 2.5), 1e-6);
    spc_rgb c = spc_texture_eval_hit(&tf, &h);
    CHECK_NEAR(c.r, 0.4, 1e-6);
    CHECK_NEAR(c.b, 0.6, 1e-6);
    h.prim = 1;
    CHECK_NEAR(spc_texture_eval_hit(&tf, &h).g, 0.2, 1e-6);
    CHECK_NEAR(spc_texture_eval1_hit(&tf, &h), 0.2, 1e-6); /* the mean of the channels */
    /* a copy has the same attributes */
    spc_mesh copy = {0};
    copy.nverts = m.nverts;
    copy.ntris = m.ntris;
    CHECK(spc_mesh_copy_attrs(&copy, &m) && copy.nattrs == 4 && spc_mesh_find_attr(&copy, "face_weight")->data[2] == 0.75f);
    spc_mesh_release(&copy);
    spc_mesh_release(&s.mesh);
}

int main(void)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/specula_test_mesh_io_XXXXXX");
    if (!mkdtemp(tmpdir)) {
        printf("cannot create a temporary directory\n");
        return 1;
    }
    RUN(obj_quads_ngons_and_negative_indices);
    RUN(obj_concave_polygon_is_ear_clipped);
    RUN(obj_deindexing_normals_and_uvs);
    RUN(obj_errors_name_line_and_column);
    RUN(ply_ascii_and_binary_agree);
    RUN(ply_errors);
    RUN(ply_attributes);
    RUN(serialized_single_meshes);
    RUN(serialized_multi_mesh_dictionary);
    RUN(serialized_corrupt_files);
    RUN(loaders_survive_mutations);
    RUN(mesh_transform_normals_by_inverse_transpose);
    RUN(mesh_drop_degenerate_append_validate);
    RUN(polygon_triangulation);
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (system(cmd) != 0)
        printf("could not remove %s\n", tmpdir);
    return spc_test_finish();
}
