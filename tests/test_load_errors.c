/*
 * tests/test_load_errors.c: malformed or missing files referenced by a Mitsuba scene are reported
 * at the XML element that names them (file:line:col) with the file's own position where it has
 * one: a missing or corrupt bitmap texture, a missing envmap, PLY files with a truncated vertex
 * or an index out of range, a serialized shape_index beyond the file's meshes, a non-mesh given
 * as an OBJ. (test_xml checks the scene syntax itself; test_mesh_io fuzzes the mesh readers.)
 */
/* ctest-labels: unit */
#include "harness.h"

#include <unistd.h>

#include "io/mitsuba_xml.h"
#include "scene/scene.h"

static char dir[256];

static void put_file(const char *name, const char *text)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* Loads "<scene version=3.0.0>\n  BODY\n</scene>" from the temporary folder and checks the error. */
static void expect(const char *body, spc_status code, int line, int col, const char *needle)
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
    CHECK_MSG(err.line == line && err.col == col, "at %d:%d, expected %d:%d (%s)", err.line, err.col, line, col, msg);
    CHECK_MSG(strstr(msg, needle) != NULL, "message '%s' lacks '%s'", msg, needle);
    CHECK_MSG(strstr(msg, "bad.xml") == msg, "message '%s' does not start with the scene file", msg);
    spc_scene_destroy(s);
}

static const char *ply_head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                              "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

TEST(textures_and_envmaps)
{
    expect("<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
           "<string name=\"filename\" value=\"missing.png\"/></texture></bsdf>",
           SPC_ERR_IO, 2, 66, "texture file 'missing.png' not found");
    put_file("fake.png", "not an image at all");
    expect("<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
           "<string name=\"filename\" value=\"fake.png\"/></texture></bsdf>",
           SPC_ERR_PARSE, 2, 24, "unknown image format");
    put_file("cut.png", "\x89PNG\r\n\x1a\n\0\0\0\rIHDR\0\0");
    expect("<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
           "<string name=\"filename\" value=\"cut.png\"/></texture></bsdf>",
           SPC_ERR_PARSE, 2, 24, "cut.png");
    expect("<emitter type=\"envmap\"><string name=\"filename\" value=\"nosky.exr\"/></emitter>", SPC_ERR_IO, 2, 26,
           "envmap file 'nosky.exr' not found");
}

TEST(meshes)
{
    char ply[1024];
    snprintf(ply, sizeof ply, "%s0 0 0\n1 0 0\n0 1\n3 0 1 2\n", ply_head); /* a vertex lacks z */
    put_file("short.ply", ply);
    expect("<shape type=\"ply\"><string name=\"filename\" value=\"short.ply\"/></shape>", SPC_ERR_VALUE, 2, 21,
           "short.ply:13");
    snprintf(ply, sizeof ply, "%s0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", ply_head);
    put_file("index.ply", ply);
    expect("<shape type=\"ply\"><string name=\"filename\" value=\"index.ply\"/></shape>", SPC_ERR_VALUE, 2, 21,
           "vertex index 7 out of range");
    put_file("noply.ply", "solid stl\n");
    expect("<shape type=\"ply\"><string name=\"filename\" value=\"noply.ply\"/></shape>", SPC_ERR_PARSE, 2, 21,
           "noply.ply");
    put_file("text.obj", "this is not a mesh\n");
    expect("<shape type=\"obj\"><string name=\"filename\" value=\"text.obj\"/></shape>", SPC_ERR_VALUE, 2, 21,
           "no faces");
    char ser[1024];
    snprintf(ser, sizeof ser,
             "<shape type=\"serialized\"><string name=\"filename\" value=\"%s/scenes/meshes/cone_prism.serialized\"/>"
             "<integer name=\"shape_index\" value=\"5\"/></shape>",
             getenv("SPC_SOURCE_DIR") ? getenv("SPC_SOURCE_DIR") : "..");
    expect(ser, SPC_ERR_VALUE, 2, 28, "shape_index 5 out of range (the file has 2 meshes)");
}

int main(void)
{
    snprintf(dir, sizeof dir, "/tmp/specula_load_errors_%ld", (long)getpid());
    char cmd[512];
    snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
    if (system(cmd) != 0)
        return 1;
    RUN(textures_and_envmaps);
    RUN(meshes);
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        printf("could not remove %s\n", dir);
    return spc_test_finish();
}
