/*
 * tests/test_xml.c: the Mitsuba scene loader (io/mitsuba_xml) and the XML tree (io/xml).
 * Scenes are loaded from strings named "test.xml" whose relative files live in a mkdtemp folder.
 */
/* ctest-labels: unit */
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "harness.h"
#include "io/image_io.h"
#include "io/mitsuba_xml.h"
#include "io/xml.h"

static char tmpdir[256];

static void write_file(const char *rel, const char *text)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, rel);
    FILE *f = fopen(path, "wb");
    if (!f) {
        printf("cannot write %s\n", path);
        return;
    }
    fputs(text, f);
    fclose(f);
}

static spc_status load_defs(const char *xml, const spc_define *defs, int ndefs, spc_scene **s, spc_error *e)
{
    memset(e, 0, sizeof *e);
    return spc_mitsuba_load_string(xml, strlen(xml), "test.xml", tmpdir, defs, ndefs, s, e);
}

static spc_status load(const char *xml, spc_scene **s, spc_error *e) { return load_defs(xml, NULL, 0, s, e); }

/* Loads and expects success; prints the error otherwise. */
static spc_scene *load_ok(const char *xml)
{
    spc_scene *s = NULL;
    spc_error e;
    spc_status st = load(xml, &s, &e);
    if (st != SPC_OK) {
        char buf[1200];
        spc_error_format(&e, buf, sizeof buf);
        printf("  unexpected load failure: %s\n", buf);
    }
    return s;
}

/* Expects failure with this code at line:col and a message containing `needle`. */
static void expect_error(const char *xml, spc_status code, int line, int col, const char *needle)
{
    spc_scene *s = (spc_scene *)1;
    spc_error e;
    spc_status st = load(xml, &s, &e);
    CHECK_MSG(st == code, "status %d, wanted %d (%s)", (int)st, (int)code, e.msg);
    CHECK(s == NULL);
    CHECK_MSG(e.line == line && e.col == col, "at %d:%d, wanted %d:%d (%s)", e.line, e.col, line, col, e.msg);
    CHECK_MSG(strstr(e.msg, needle) != NULL, "message '%s' lacks '%s'", e.msg, needle);
    CHECK(strcmp(e.file, "test.xml") == 0);
    if (st == SPC_OK)
        spc_scene_destroy(s);
}

static spc_rgb const_rgb(const spc_texture *t)
{
    if (!t || t->type != SPC_TEX_CONSTANT)
        return spc_rgb1(-999);
    return t->value;
}

/* stderr capture, for warnings */
static int saved_fd = -1;
static char capture_path[512];

static void capture_begin(void)
{
    fflush(stderr);
    snprintf(capture_path, sizeof capture_path, "%s/stderr.txt", tmpdir);
    saved_fd = dup(2);
    int fd = open(capture_path, O_CREAT | O_TRUNC | O_WRONLY, 0600);
    dup2(fd, 2);
    close(fd);
    spc_warn_set_quiet(0);
}

static char *capture_end(void)
{
    fflush(stderr);
    dup2(saved_fd, 2);
    close(saved_fd);
    spc_warn_set_quiet(1);
    static char buf[8192];
    buf[0] = '\0';
    FILE *f = fopen(capture_path, "rb");
    if (f) {
        size_t n = fread(buf, 1, sizeof buf - 1, f);
        buf[n] = '\0';
        fclose(f);
    }
    return buf;
}

/* ---------------------------------------------------------------------------------------------- */

TEST(xml_tree_positions)
{
    const char *text = "<a x=\"1\">\n  <b y=\"2\"/>\n\t<c>\n    <d/></c>\n</a>\n";
    spc_xml_node *root;
    spc_error e;
    CHECK(spc_xml_parse(text, strlen(text), "f.xml", &root, &e) == SPC_OK);
    if (!root)
        return;
    CHECK(strcmp(root->name, "a") == 0 && root->line == 1 && root->col == 1);
    CHECK(strcmp(spc_xml_get(root, "x"), "1") == 0);
    CHECK(root->nchildren == 2);
    CHECK(root->children[0]->line == 2 && root->children[0]->col == 3);
    CHECK(root->children[1]->line == 3 && root->children[1]->col == 2);
    CHECK(root->children[1]->children[0]->line == 4 && root->children[1]->children[0]->col == 5);
    CHECK(strcmp(root->children[0]->file, "f.xml") == 0);
    spc_xml_free(root);

    const char *bad = "<a>\n  <b>\n</a>\n";
    CHECK(spc_xml_parse(bad, strlen(bad), "f.xml", &root, &e) == SPC_ERR_PARSE);
    CHECK(root == NULL);
    CHECK(e.line == 3 && e.col == 3);
    CHECK(strstr(e.msg, "mismatched tag") != NULL);

    const char *text2 = "<a>\n  hello <b/></a>";
    CHECK(spc_xml_parse(text2, strlen(text2), "f.xml", &root, &e) == SPC_ERR_PARSE);
    CHECK(e.line == 2 && e.col == 3); /* the first non-blank character */
}

TEST(rgb_forms)
{
    spc_scene *s = load_ok("<scene version=\"3.0.0\">\n"
                           "  <bsdf type=\"diffuse\" id=\"a\"><rgb name=\"reflectance\" value=\"0.1, 0.2, 0.3\"/></bsdf>\n"
                           "  <bsdf type=\"diffuse\" id=\"b\"><rgb name=\"reflectance\" value=\"0.1 0.2 0.3\"/></bsdf>\n"
                           "  <bsdf type=\"diffuse\" id=\"c\"><rgb name=\"reflectance\" value=\"0.25\"/></bsdf>\n"
                           "  <bsdf type=\"diffuse\" id=\"d\"><rgb name=\"reflectance\" value=\"#ff0080\"/></bsdf>\n"
                           "  <bsdf type=\"diffuse\" id=\"e\"><float name=\"reflectance\" value=\"0.75\"/></bsdf>\n"
                           "</scene>\n");
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->nbsdfs == 5);
    spc_rgb a = const_rgb(s->bsdfs[0]->reflectance), b = const_rgb(s->bsdfs[1]->reflectance);
    spc_rgb c = const_rgb(s->bsdfs[2]->reflectance), d = const_rgb(s->bsdfs[3]->reflectance);
    spc_rgb f = const_rgb(s->bsdfs[4]->reflectance);
    CHECK_NEAR(a.r, 0.1, 1e-12);
    CHECK_NEAR(a.g, 0.2, 1e-12);
    CHECK_NEAR(a.b, 0.3, 1e-12);
    CHECK(a.r == b.r && a.g == b.g && a.b == b.b);
    CHECK(c.r == 0.25 && c.g == 0.25 && c.b == 0.25);
    /* hex is 8-bit sRGB: ff -> 1, 00 -> 0, 80 -> ((128/255 + 0.055)/1.055)^2.4 */
    CHECK_NEAR(d.r, 1.0, 1e-12);
    CHECK_NEAR(d.g, 0.0, 1e-12);
    CHECK_NEAR(d.b, 0.2158605, 1e-6);
    CHECK(f.r == 0.75 && f.b == 0.75);
    spc_scene_destroy(s);
}

TEST(spectrum_values)
{
    spc_scene *s = load_ok("<scene version=\"3.0.0\">\n"
                           "  <bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"0.5\"/></bsdf>\n"
                           "  <bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"360:0.7, 830:0.7\"/></bsdf>\n"
                           "  <bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"540:0, 550:1, 560:0\"/></bsdf>\n"
                           "  <bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"400:1, 480:1, 500:0\"/></bsdf>\n"
                           "</scene>\n");
    CHECK(s != NULL);
    if (!s)
        return;
    spc_rgb k = const_rgb(s->bsdfs[0]->reflectance);
    CHECK(k.r == 0.5 && k.g == 0.5 && k.b == 0.5);
    /* wavelength lists as Mitsuba 3.9.1's RGB variants read them (spectrum_list_to_srgb with D65),
     * its values to 6 digits */
    spc_rgb flat = const_rgb(s->bsdfs[1]->reflectance);
    CHECK_NEAR(flat.r, 0.69929, 2e-6);
    CHECK_NEAR(flat.g, 0.699211, 2e-6);
    CHECK_NEAR(flat.b, 0.699161, 2e-6);
    spc_rgb green = const_rgb(s->bsdfs[2]->reflectance);
    CHECK(green.r == 0.0 && green.b == 0.0);
    CHECK_NEAR(green.g, 0.140577, 2e-6);
    spc_rgb blue = const_rgb(s->bsdfs[3]->reflectance);
    CHECK(blue.r == 0.0 && blue.g == 0.0);
    CHECK(blue.b > 1.0); /* Mitsuba clamps a reflectance to 1 here; specula does not (see the table) */
    spc_scene_destroy(s);
    /* a conductor's eta and k, read the same way (Mitsuba works in float: agreement to 1e-4) */
    s = load_ok("<scene version=\"3.0.0\"><bsdf type=\"conductor\">"
                "<spectrum name=\"eta\" value=\"300:1.8, 400:1.65, 500:0.9, 600:0.2, 700:0.16, 800:0.18\"/>"
                "<spectrum name=\"k\" value=\"300:1.92, 400:1.95, 500:1.95, 600:2.97, 700:3.8, 800:5.12\"/>"
                "</bsdf></scene>");
    CHECK(s != NULL);
    if (s) {
        CHECK_NEAR(s->bsdfs[0]->cond_eta.r, 0.0452341, 2e-6);
        CHECK_NEAR(s->bsdfs[0]->cond_eta.g, 0.585709, 2e-6);
        CHECK_NEAR(s->bsdfs[0]->cond_eta.b, 1.33692, 2e-5);
        CHECK_NEAR(s->bsdfs[0]->cond_k.r, 3.38869, 1e-4);
        CHECK_NEAR(s->bsdfs[0]->cond_k.g, 2.34904, 1e-4);
        CHECK_NEAR(s->bsdfs[0]->cond_k.b, 1.87516, 3e-4);
        spc_scene_destroy(s);
    }
}

static spc_mat4 camera_to_world(const char *transform_children)
{
    char xml[2048];
    snprintf(xml, sizeof xml,
             "<scene version=\"3.0.0\"><sensor type=\"perspective\"><transform name=\"to_world\">%s</transform>"
             "</sensor></scene>",
             transform_children);
    spc_scene *s = load_ok(xml);
    spc_mat4 m = spc_mat4_identity();
    for (int i = 0; i < 4; ++i)
        m.m[i][i] = -777;
    if (s) {
        m = s->camera.to_world;
        spc_scene_destroy(s);
    }
    return m;
}

static void check_mat(spc_mat4 m, const double want[16])
{
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            CHECK_NEAR(m.m[r][c], want[4 * r + c], 1e-12);
}

TEST(transforms)
{
    /* lookat from (1,2,3) toward -z with up +y: x = up x dir = (-1,0,0), y = (0,1,0), z = (0,0,-1) */
    const double lookat[16] = {-1, 0, 0, 1, 0, 1, 0, 2, 0, 0, -1, 3, 0, 0, 0, 1};
    check_mat(camera_to_world("<lookat origin=\"1, 2, 3\" target=\"1, 2, 2\" up=\"0, 1, 0\"/>"), lookat);
    /* translate then scale: M = S T, so the translation is scaled */
    const double ts[16] = {2, 0, 0, 2, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1};
    check_mat(camera_to_world("<translate x=\"1\"/><scale value=\"2\"/>"), ts);
    const double st[16] = {2, 0, 0, 1, 0, 3, 0, 0, 0, 0, 4, 0, 0, 0, 0, 1};
    check_mat(camera_to_world("<scale x=\"2\" y=\"3\" z=\"4\"/><translate value=\"1, 0, 0\"/>"), st);
    /* rotation about +z by 90 degrees (right-handed): x -> y, y -> -x */
    const double rz[16] = {0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    check_mat(camera_to_world("<rotate z=\"1\" angle=\"90\"/>"), rz);
    /* translate by +x, then rotate: the origin lands on +y */
    const double tr[16] = {0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 1};
    check_mat(camera_to_world("<translate x=\"1\"/><rotate value=\"0 0 1\" angle=\"90\"/>"), tr);
    /* rotate, then translate: the translation is not rotated */
    const double rt[16] = {0, -1, 0, 1, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    check_mat(camera_to_world("<rotate z=\"1\" angle=\"90\"/><translate x=\"1\"/>"), rt);
    /* matrix is row-major; a later matrix multiplies from the left */
    const double mm[16] = {1, 0, 0, 5, 0, 1, 0, 6, 0, 0, 1, 7, 0, 0, 0, 1};
    check_mat(camera_to_world("<matrix value=\"1 0 0 5 0 1 0 6 0 0 1 7 0 0 0 1\"/>"), mm);
    const double ms[16] = {2, 0, 0, 10, 0, 2, 0, 12, 0, 0, 2, 14, 0, 0, 0, 1};
    check_mat(camera_to_world("<matrix value=\"1 0 0 5 0 1 0 6 0 0 1 7 0 0 0 1\"/><scale value=\"2\"/>"), ms);
    /* rotate about +y by 90: x -> -z */
    spc_mat4 ry = camera_to_world("<rotate y=\"1\" angle=\"90\"/>");
    CHECK_NEAR(ry.m[2][0], -1.0, 1e-12);
    CHECK_NEAR(ry.m[0][2], 1.0, 1e-12);
    /* an axis not of unit length is used as written, as Mitsuba 3 does: its matrix for 15 degrees
     * about (0, 1, 1), as Mitsuba 3.9.1 prints it (to_world of a shape), to its 6 digits */
    const double ru[16] = {0.965926, -0.258819, 0.258819,  0, 0.258819, 1, 0.0340742, 0,
                           -0.258819, 0.0340742, 1,        0, 0,        0, 0,         1};
    spc_mat4 m = camera_to_world("<rotate x=\"0.0\" y=\"1.0\" z=\"1.0\" angle=\"15\"/>");
    for (int r = 0; r < 4; ++r)
        for (int q = 0; q < 4; ++q)
            CHECK_NEAR(m.m[r][q], ru[4 * r + q], 1e-6);
}

TEST(defaults_and_defines)
{
    const char *xml = "<scene version=\"3.0.0\">\n"
                      "  <default name=\"spp\" value=\"8\"/>\n"
                      "  <default name=\"res\" value=\"10\"/>\n"
                      "  <default name=\"resx\" value=\"64\"/>\n"
                      "  <default name=\"t\" value=\"diff\"/>\n"
                      "  <sensor type=\"perspective\">\n"
                      "    <sampler type=\"independent\"><integer name=\"sample_count\" value=\"$spp\"/></sampler>\n"
                      "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"$resx\"/>"
                      "<integer name=\"height\" value=\"$res\"/></film>\n"
                      "  </sensor>\n"
                      "  <bsdf type=\"${t}use\"/>\n"
                      "</scene>\n";
    /* "${t}" is not Mitsuba syntax: the '$' is followed by '{', which no parameter matches */
    spc_scene *s;
    spc_error e;
    CHECK(load(xml, &s, &e) == SPC_ERR_VALUE);
    CHECK(e.line == 10 && e.col == 3);

    const char *xml2 = "<scene version=\"3.0.0\">\n"
                       "  <default name=\"spp\" value=\"8\"/>\n"
                       "  <default name=\"res\" value=\"10\"/>\n"
                       "  <default name=\"resx\" value=\"64\"/>\n"
                       "  <default name=\"t\" value=\"diff\"/>\n"
                       "  <sensor type=\"perspective\">\n"
                       "    <sampler type=\"independent\"><integer name=\"sample_count\" value=\"$spp\"/></sampler>\n"
                       "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"$resx\"/>"
                       "<integer name=\"height\" value=\"$res\"/></film>\n"
                       "  </sensor>\n"
                       "  <bsdf type=\"$tuse\"/>\n"
                       "</scene>\n";
    s = load_ok(xml2);
    CHECK(s != NULL);
    if (s) {
        CHECK(s->spp == 8);
        CHECK(s->film.width == 64); /* the longest parameter name matches first */
        CHECK(s->film.height == 10);
        CHECK(s->nbsdfs == 1 && s->bsdfs[0]->type == SPC_BSDF_DIFFUSE);
        spc_scene_destroy(s);
    }
    spc_define defs[2] = {{"spp", "16"}, {"resx", "32"}};
    CHECK(load_defs(xml2, defs, 2, &s, &e) == SPC_OK);
    if (s) {
        CHECK(s->spp == 16);
        CHECK(s->film.width == 32);
        CHECK(s->film.height == 10);
        spc_scene_destroy(s);
    }
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <sensor type=\"perspective\"><float name=\"fov\" value=\"$fov\"/></sensor>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 2, 30, "undefined parameter");
}

TEST(include_and_path)
{
    write_file("part.xml", "<scene version=\"3.0.0\">\n"
                           "  <bsdf type=\"diffuse\" id=\"inc_bsdf\"><rgb name=\"reflectance\" value=\"0.3\"/></bsdf>\n"
                           "  <shape type=\"sphere\"><float name=\"radius\" value=\"$r\"/></shape>\n"
                           "</scene>\n");
    write_file("bsdf_only.xml", "<bsdf type=\"conductor\" id=\"single\"/>\n");
    write_file("loop.xml", "<scene version=\"3.0.0\"><include filename=\"loop.xml\"/></scene>\n");
    /* two bsdfs in one shape is an error; the same scene with one ref must load */
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <default name=\"r\" value=\"2\"/>\n"
                 "  <include filename=\"part.xml\"/>\n"
                 "  <include filename=\"bsdf_only.xml\"/>\n"
                 "  <shape type=\"sphere\"><ref id=\"inc_bsdf\"/><ref id=\"single\"/></shape>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 5, 3, "one bsdf");
    spc_scene *s;
    s = load_ok("<scene version=\"3.0.0\">\n"
                "  <default name=\"r\" value=\"2\"/>\n"
                "  <include filename=\"part.xml\"/>\n"
                "  <include filename=\"bsdf_only.xml\"/>\n"
                "  <shape type=\"disk\"><ref id=\"inc_bsdf\"/></shape>\n"
                "</scene>\n");
    CHECK(s != NULL);
    if (s) {
        CHECK(s->nshapes == 2);
        CHECK(s->shapes[0]->type == SPC_SHAPE_SPHERE);
        CHECK_NEAR(s->shapes[0]->radius, 2.0, 1e-12);
        CHECK(s->shapes[1]->bsdf == s->bsdfs[0]);
        CHECK_NEAR(const_rgb(s->shapes[1]->bsdf->reflectance).g, 0.3, 1e-12);
        CHECK(s->nbsdfs >= 2);
        spc_scene_destroy(s);
    }
    expect_error("<scene version=\"3.0.0\">\n"
                 "    <include filename=\"missing.xml\"/>\n"
                 "</scene>\n",
                 SPC_ERR_IO, 2, 5, "missing.xml");
    spc_error e;
    CHECK(load("<scene version=\"3.0.0\"><include filename=\"loop.xml\"/></scene>", &s, &e) == SPC_ERR_LIMIT);
    CHECK(s == NULL);

    /* <path>: a search directory for relative file names */
    char sub[512];
    snprintf(sub, sizeof sub, "%s/meshes", tmpdir);
    CHECK(mkdir(sub, 0700) == 0 || access(sub, F_OK) == 0);
    write_file("meshes/tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    s = load_ok("<scene version=\"3.0.0\">\n"
                "  <path value=\"meshes\"/>\n"
                "  <shape type=\"obj\"><string name=\"filename\" value=\"tri.obj\"/></shape>\n"
                "</scene>\n");
    CHECK(s != NULL);
    if (s) {
        CHECK(s->nshapes == 1 && s->shapes[0]->type == SPC_SHAPE_MESH && s->shapes[0]->mesh.ntris == 1);
        spc_scene_destroy(s);
    }
    /* an included file's <path> written relative to the including scene (Mitsuba 3's resolver) */
    snprintf(sub, sizeof sub, "%s/parts", tmpdir);
    CHECK(mkdir(sub, 0700) == 0 || access(sub, F_OK) == 0);
    write_file("parts/inc.xml", "<scene version=\"3.0.0\"><path value=\"meshes\"/>"
                                "<shape type=\"obj\"><string name=\"filename\" value=\"tri.obj\"/></shape></scene>\n");
    s = load_ok("<scene version=\"3.0.0\"><include filename=\"parts/inc.xml\"/></scene>\n");
    CHECK(s != NULL && s->nshapes == 1);
    spc_scene_destroy(s);
    expect_error("<scene version=\"3.0.0\"><path value=\"nowhere\"/></scene>\n", SPC_ERR_IO, 1, 24, "nowhere");
}

TEST(forward_reference)
{
    spc_scene *s = load_ok("<scene version=\"3.0.0\">\n"
                           "  <shape type=\"sphere\"><ref id=\"later\"/></shape>\n"
                           "  <shape type=\"sphere\"><ref name=\"bsdf\" id=\"later\"/>"
                           "<point name=\"center\" x=\"3\"/></shape>\n"
                           "  <bsdf type=\"roughconductor\" id=\"later\"><texture type=\"checkerboard\" name=\"alpha\" "
                           "id=\"tex\"/></bsdf>\n"
                           "  <bsdf type=\"diffuse\"><ref name=\"reflectance\" id=\"tex\"/></bsdf>\n"
                           "</scene>\n");
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->nshapes == 2);
    CHECK(s->nbsdfs == 2); /* "later" built once */
    CHECK(s->shapes[0]->bsdf == s->shapes[1]->bsdf);
    CHECK(s->shapes[0]->bsdf->type == SPC_BSDF_ROUGHCONDUCTOR);
    CHECK(s->shapes[0]->bsdf->alpha_u->type == SPC_TEX_CHECKERBOARD);
    CHECK(s->bsdfs[1]->reflectance == s->shapes[0]->bsdf->alpha_u); /* the texture is shared */
    CHECK_NEAR(s->shapes[1]->center.x, 3.0, 1e-12);
    spc_scene_destroy(s);
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"sphere\">\n"
                 "     <ref id=\"nothing\"/></shape>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 6, "nothing");
}

/* Objects declared at the top level with an id and used by reference, as Mitsuba 3's own scenes
 * do: an area emitter referenced from a shape declared before it (cbox-rgb.xml), a sampler, a
 * film and its filter. */
TEST(objects_by_reference)
{
    spc_scene *s = load_ok("<scene version=\"3.0.0\">\n"
                           "  <shape type=\"sphere\"><ref id=\"light\"/></shape>\n"
                           "  <shape type=\"sphere\"><point name=\"center\" x=\"3\"/></shape>\n"
                           "  <emitter type=\"area\" id=\"light\"><rgb name=\"radiance\" value=\"2\"/></emitter>\n"
                           "  <emitter type=\"area\" id=\"unused\"/>\n"
                           "  <sampler type=\"independent\" id=\"smp\"><integer name=\"sample_count\" value=\"9\"/></sampler>\n"
                           "  <rfilter type=\"tent\" id=\"flt\"/>\n"
                           "  <film type=\"hdrfilm\" id=\"flm\"><integer name=\"width\" value=\"20\"/>"
                           "<integer name=\"height\" value=\"10\"/><ref id=\"flt\"/></film>\n"
                           "  <sensor type=\"perspective\"><ref id=\"smp\"/><ref id=\"flm\"/></sensor>\n"
                           "</scene>\n");
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->nemitters == 1);
    CHECK(s->nemitters == 1 && s->emitters[0]->shape == s->shapes[0] && s->shapes[0]->emitter == s->emitters[0]);
    CHECK(s->shapes[1]->emitter == NULL);
    CHECK(s->spp == 9);
    CHECK(s->film.width == 20 && s->film.height == 10);
    CHECK(s->film.rfilter == SPC_RFILTER_TENT);
    spc_scene_destroy(s);
}

TEST(dialect_06_equals_3)
{
    const char *v06 = "<scene version=\"0.6.0\">\n"
                      "  <integrator type=\"path\"><integer name=\"maxDepth\" value=\"7\"/>"
                      "<integer name=\"rrDepth\" value=\"3\"/><boolean name=\"hideEmitters\" value=\"true\"/></integrator>\n"
                      "  <sensor type=\"perspective\"><float name=\"fov\" value=\"30\"/>"
                      "<string name=\"fovAxis\" value=\"y\"/><float name=\"nearClip\" value=\"0.5\"/>\n"
                      "    <transform name=\"toWorld\"><lookAt origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/></transform>\n"
                      "    <sampler type=\"ldsampler\"><integer name=\"sampleCount\" value=\"32\"/></sampler>\n"
                      "    <film type=\"ldrfilm\"><integer name=\"width\" value=\"100\"/><integer name=\"height\" value=\"50\"/>"
                      "<integer name=\"cropOffsetX\" value=\"10\"/><rfilter type=\"box\"/></film>\n"
                      "  </sensor>\n"
                      "  <shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/>\n"
                      "    <bsdf type=\"dielectric\"><float name=\"intIOR\" value=\"1.7\"/>"
                      "<string name=\"extIOR\" value=\"water\"/></bsdf></shape>\n"
                      "  <shape type=\"cube\"><transform name=\"toWorld\"><scale value=\"2\"/></transform>\n"
                      "    <bsdf type=\"roughconductor\"><float name=\"alphaU\" value=\"0.2\"/>"
                      "<float name=\"alphaV\" value=\"0.3\"/><string name=\"material\" value=\"Au\"/></bsdf></shape>\n"
                      "  <shape type=\"rectangle\"><bsdf type=\"plastic\"><rgb name=\"diffuseReflectance\" value=\"0.1\"/>"
                      "<float name=\"intIOR\" value=\"1.6\"/></bsdf></shape>\n"
                      "  <shape type=\"disk\"><bsdf type=\"diffuse\"><rgb name=\"diffuseReflectance\" value=\"0.4\"/>"
                      "</bsdf></shape>\n"
                      "</scene>\n";
    const char *v3 = "<scene version=\"3.0.0\">\n"
                     "  <integrator type=\"path\"><integer name=\"max_depth\" value=\"7\"/>"
                     "<integer name=\"rr_depth\" value=\"3\"/><boolean name=\"hide_emitters\" value=\"true\"/></integrator>\n"
                     "  <sensor type=\"perspective\"><float name=\"fov\" value=\"30\"/>"
                     "<string name=\"fov_axis\" value=\"y\"/><float name=\"near_clip\" value=\"0.5\"/>\n"
                     "    <transform name=\"to_world\"><lookat origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/></transform>\n"
                     "    <sampler type=\"ldsampler\"><integer name=\"sample_count\" value=\"32\"/></sampler>\n"
                     "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"100\"/><integer name=\"height\" value=\"50\"/>"
                     "<integer name=\"crop_offset_x\" value=\"10\"/><rfilter type=\"box\"/></film>\n"
                     "  </sensor>\n"
                     "  <shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/>\n"
                     "    <bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.7\"/>"
                     "<string name=\"ext_ior\" value=\"water\"/></bsdf></shape>\n"
                     "  <shape type=\"cube\"><transform name=\"to_world\"><scale value=\"2\"/></transform>\n"
                     "    <bsdf type=\"roughconductor\"><float name=\"alpha_u\" value=\"0.2\"/>"
                     "<float name=\"alpha_v\" value=\"0.3\"/><string name=\"material\" value=\"Au\"/></bsdf></shape>\n"
                     "  <shape type=\"rectangle\"><bsdf type=\"plastic\"><rgb name=\"diffuse_reflectance\" value=\"0.1\"/>"
                     "<float name=\"int_ior\" value=\"1.6\"/></bsdf></shape>\n"
                     "  <shape type=\"disk\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.4\"/>"
                     "</bsdf></shape>\n"
                     "</scene>\n";
    capture_begin();
    spc_scene *a = load_ok(v06), *b = load_ok(v3);
    const char *warnings = capture_end();
    CHECK_MSG(warnings[0] == '\0', "unexpected warnings: %s", warnings);
    CHECK(a && b);
    if (!a || !b) {
        spc_scene_destroy(a);
        spc_scene_destroy(b);
        return;
    }
    CHECK(strcmp(a->integrator.type, "path") == 0 && a->integrator.max_depth == 7 && b->integrator.max_depth == 7);
    CHECK(a->integrator.rr_depth == 3 && b->integrator.rr_depth == 3);
    CHECK(a->integrator.hide_emitters && b->integrator.hide_emitters);
    CHECK(a->camera.fov == 30 && a->camera.fov_axis == SPC_FOV_Y && b->camera.fov_axis == SPC_FOV_Y);
    CHECK(a->camera.near_clip == 0.5 && b->camera.near_clip == 0.5);
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            CHECK(a->camera.to_world.m[r][c] == b->camera.to_world.m[r][c]);
    CHECK_NEAR(a->camera.to_world.m[2][3], 5.0, 1e-12);
    CHECK(a->spp == 32 && b->spp == 32);
    CHECK(a->film.width == 100 && a->film.height == 50 && a->film.crop_x == 10 && a->film.crop_w == 90);
    CHECK(b->film.crop_x == 10 && b->film.crop_w == 90 && b->film.rfilter == SPC_RFILTER_BOX);
    CHECK(a->film.rfilter == SPC_RFILTER_BOX && a->film.filter_radius == 0.5);
    CHECK(a->nshapes == 4 && b->nshapes == 4);
    for (int i = 0; i < 4 && a->nshapes == 4 && b->nshapes == 4; ++i) {
        const spc_bsdf *x = a->shapes[i]->bsdf, *y = b->shapes[i]->bsdf;
        CHECK(x->type == y->type);
        CHECK(x->eta == y->eta);
        CHECK(x->cond_eta.r == y->cond_eta.r && x->cond_k.b == y->cond_k.b);
        if (x->reflectance && y->reflectance)
            CHECK(const_rgb(x->reflectance).r == const_rgb(y->reflectance).r);
        if (x->alpha_u && y->alpha_u) {
            CHECK(const_rgb(x->alpha_u).r == const_rgb(y->alpha_u).r);
            CHECK(const_rgb(x->alpha_v).r == const_rgb(y->alpha_v).r);
        }
    }
    CHECK_NEAR(a->shapes[0]->bsdf->eta, 1.7 / 1.333, 1e-12);
    CHECK_NEAR(const_rgb(a->shapes[1]->bsdf->alpha_v).r, 0.3, 1e-12);
    CHECK_NEAR(const_rgb(a->shapes[2]->bsdf->reflectance).r, 0.1, 1e-12);
    CHECK_NEAR(const_rgb(a->shapes[3]->bsdf->reflectance).r, 0.4, 1e-12);
    spc_scene_destroy(a);
    spc_scene_destroy(b);
}

TEST(named_ior_and_conductors)
{
    spc_scene *s = load_ok("<scene version=\"3.0.0\">\n"
                           "  <bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"diamond\"/>"
                           "<string name=\"ext_ior\" value=\"vacuum\"/></bsdf>\n"
                           "  <bsdf type=\"dielectric\"/>\n"
                           "  <bsdf type=\"conductor\"/>\n"
                           "  <bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/></bsdf>\n"
                           "  <bsdf type=\"roughconductor\"><rgb name=\"eta\" value=\"0.2, 0.9, 1.1\"/>"
                           "<rgb name=\"k\" value=\"3.9, 2.4, 2.1\"/></bsdf>\n"
                           "  <bsdf type=\"conductor\"><string name=\"material\" value=\"Cu_palik\"/></bsdf>\n"
                           "</scene>\n");
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK_NEAR(s->bsdfs[0]->eta, 2.419, 1e-12);
    CHECK_NEAR(s->bsdfs[1]->eta, 1.5046 / 1.000277, 1e-12);
    CHECK(s->bsdfs[2]->cond_k.r < 0.0); /* material none: a perfect mirror */
    /* Mitsuba 3.9's RGB values for Au and Cu (mitsuba_tables.c) */
    CHECK_NEAR(s->bsdfs[3]->cond_eta.r, 0.1430360, 1e-6);
    CHECK_NEAR(s->bsdfs[3]->cond_k.b, 1.6033592, 1e-6);
    CHECK_NEAR(const_rgb(s->bsdfs[3]->specular_reflectance).g, 1.0, 0);
    CHECK_NEAR(s->bsdfs[4]->cond_eta.g, 0.9, 1e-12);
    CHECK_NEAR(s->bsdfs[4]->cond_k.r, 3.9, 1e-12);
    CHECK(s->bsdfs[4]->distribution == SPC_MICROFACET_BECKMANN && s->bsdfs[4]->sample_visible);
    CHECK_NEAR(const_rgb(s->bsdfs[4]->alpha_u).r, 0.1, 1e-12);
    CHECK_NEAR(s->bsdfs[5]->cond_eta.g, 0.9237495, 1e-6);
    spc_scene_destroy(s);
    /* a 0.6 conductor defaults to copper */
    s = load_ok("<scene version=\"0.6.0\"><bsdf type=\"conductor\"/></scene>");
    CHECK(s != NULL);
    if (s) {
        CHECK_NEAR(s->bsdfs[0]->cond_k.r, 3.9132621, 1e-6);
        spc_scene_destroy(s);
    }
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"dielectric\">\n"
                 "    <string name=\"int_ior\" value=\"unobtainium\"/></bsdf>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 5, "unobtainium");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"conductor\"><string name=\"material\" value=\"Xx\"/></bsdf>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 2, 26, "'Xx'");
}

TEST(shapes_and_emitters)
{
    spc_scene *s = load_ok(
        "<scene version=\"3.0.0\">\n"
        "  <shape type=\"sphere\"><point name=\"center\" value=\"1, 0, 0\"/><float name=\"radius\" value=\"0.5\"/>\n"
        "    <transform name=\"to_world\"><scale value=\"2\"/><translate z=\"1\"/></transform>\n"
        "    <boolean name=\"caustic_caster\" value=\"true\"/><boolean name=\"caustic_receiver\" value=\"false\"/>\n"
        "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 2, 3\"/></emitter></shape>\n"
        "  <shape type=\"cylinder\"><float name=\"radius\" value=\"0.25\"/><point name=\"p1\" x=\"0\" y=\"0\" z=\"2\"/>"
        "<boolean name=\"flip_normals\" value=\"true\"/></shape>\n"
        "  <shape type=\"shapegroup\" id=\"g\">\n"
        "    <shape type=\"sphere\"><float name=\"radius\" value=\"0.1\"/></shape>\n"
        "    <shape type=\"rectangle\"/>\n"
        "  </shape>\n"
        "  <shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><translate x=\"5\"/></transform></shape>\n"
        "  <shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><translate x=\"-5\"/></transform></shape>\n"
        "  <emitter type=\"point\"><point name=\"position\" value=\"0, 4, 0\"/><rgb name=\"intensity\" value=\"10\"/></emitter>\n"
        "  <emitter type=\"spot\"><float name=\"cutoff_angle\" value=\"40\"/>"
        "<transform name=\"to_world\"><translate y=\"2\"/></transform></emitter>\n"
        "  <emitter type=\"directional\"><vector name=\"direction\" value=\"0, -2, 0\"/></emitter>\n"
        "  <emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.5\"/></emitter>\n"
        "</scene>\n");
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->nshapes == 6);
    CHECK(s->nemitters == 5);
    const spc_shape *sp = s->shapes[0];
    CHECK(sp->type == SPC_SHAPE_SPHERE);
    CHECK_NEAR(sp->radius, 1.0, 1e-12);      /* 0.5 scaled by 2 */
    CHECK_NEAR(sp->center.x, 2.0, 1e-12);    /* (1,0,0) scaled by 2 */
    CHECK_NEAR(sp->center.z, 1.0, 1e-12);    /* then translated */
    CHECK(sp->caustic_flags == (SPC_CAUSTIC_FLAGS_EXPLICIT | SPC_CAUSTIC_CASTER));
    CHECK(sp->emitter == s->emitters[0]);
    CHECK(s->emitters[0]->type == SPC_EMITTER_AREA && s->emitters[0]->shape == sp && s->emitters[0]->shape_index == 0);
    CHECK_NEAR(const_rgb(s->emitters[0]->radiance).b, 3.0, 0);
    CHECK(sp->bsdf && sp->bsdf->type == SPC_BSDF_DIFFUSE);
    CHECK_NEAR(const_rgb(sp->bsdf->reflectance).r, 0.0, 0); /* an emitter without a bsdf: black, as Mitsuba 3 */
    CHECK_NEAR(const_rgb(s->shapes[1]->bsdf->reflectance).r, 0.5, 0); /* others: diffuse 0.5 */
    CHECK(s->shapes[1]->type == SPC_SHAPE_CYLINDER && s->shapes[1]->flip_normals);
    CHECK(!(s->shapes[1]->caustic_flags & SPC_CAUSTIC_FLAGS_EXPLICIT));
    CHECK(s->shapes[2]->type == SPC_SHAPE_SPHERE && s->shapes[4]->type == SPC_SHAPE_SPHERE);
    CHECK_NEAR(s->shapes[2]->center.x, 5.0, 1e-12);
    CHECK_NEAR(s->shapes[4]->center.x, -5.0, 1e-12);
    CHECK(s->shapes[3]->type == SPC_SHAPE_MESH && s->shapes[3]->mesh.ntris == 2);
    CHECK(s->emitters[1]->type == SPC_EMITTER_POINT);
    CHECK_NEAR(s->emitters[1]->position.y, 4.0, 0);
    CHECK_NEAR(s->emitters[1]->intensity.g, 10.0, 0);
    CHECK(s->emitters[2]->type == SPC_EMITTER_SPOT);
    CHECK_NEAR(s->emitters[2]->beam_width, 30.0, 1e-12);
    CHECK_NEAR(s->emitters[2]->position.y, 2.0, 1e-12);
    CHECK(s->emitters[3]->type == SPC_EMITTER_DIRECTIONAL);
    CHECK_NEAR(s->emitters[3]->direction.y, -1.0, 1e-12);
    CHECK(s->emitters[4]->type == SPC_EMITTER_CONSTANT);
    spc_scene_destroy(s);
}

TEST(sensor_and_integrators)
{
    spc_scene *s = load_ok("<scene version=\"3.0.0\"><integrator type=\"direct\"/><sensor type=\"perspective\">"
                           "<film type=\"hdrfilm\"><rfilter type=\"tent\"/></film></sensor></scene>");
    CHECK(s != NULL);
    if (s) {
        CHECK(strcmp(s->integrator.type, "path") == 0 && s->integrator.max_depth == 2);
        CHECK(s->integrator.decl_line == 1 && s->integrator.decl_col == 24);
        /* no fov: focal length 50mm on 36x24mm, along the diagonal */
        CHECK(s->camera.fov_axis == SPC_FOV_DIAGONAL);
        CHECK_NEAR(s->camera.fov, 2.0 * atan(sqrt(36.0 * 36.0 + 24.0 * 24.0) / 100.0) * 180.0 / SPC_PI, 1e-9);
        CHECK(s->film.width == 768 && s->film.height == 576);
        CHECK(s->film.rfilter == SPC_RFILTER_TENT && s->film.filter_radius == 1.0);
        CHECK(s->spp == 4);
        spc_scene_destroy(s);
    }
    s = load_ok("<scene version=\"3.0.0\"><integrator type=\"aov\"><string name=\"aovs\" value=\"d:depth\"/>"
                "<integrator type=\"bdpt\"><integer name=\"max_depth\" value=\"9\"/></integrator></integrator>"
                "<sensor type=\"orthographic\"><film type=\"hdrfilm\"/></sensor></scene>");
    CHECK(s != NULL);
    if (s) {
        CHECK(strcmp(s->integrator.type, "bdpt") == 0 && s->integrator.max_depth == 9);
        CHECK(s->camera.type == SPC_CAMERA_ORTHOGRAPHIC);
        CHECK(s->film.rfilter == SPC_RFILTER_GAUSSIAN && s->film.filter_radius == 2.0);
        spc_scene_destroy(s);
    }
    s = load_ok("<scene version=\"3.0.0\"><integrator type=\"path\"><string name=\"specular_nee\" value=\"conic\"/>"
                "</integrator><sensor type=\"perspective\"><string name=\"focal_length\" value=\"35mm\"/>"
                "<sampler type=\"stratified\"><integer name=\"sample_count\" value=\"9\"/>"
                "<integer name=\"seed\" value=\"3\"/></sampler></sensor></scene>");
    CHECK(s != NULL);
    if (s) {
        CHECK(strcmp(s->integrator.specular_nee, "conic") == 0);
        CHECK(s->spp == 9 && s->seed == 3);
        CHECK_NEAR(s->camera.fov, 2.0 * atan(sqrt(36.0 * 36.0 + 24.0 * 24.0) / 70.0) * 180.0 / SPC_PI, 1e-9);
        spc_scene_destroy(s);
    }
    /* aov: the types specula keeps; another is refused by name */
    expect_error("<scene version=\"3.0.0\"><integrator type=\"aov\"><string name=\"aovs\" value=\"a:depth,b:uv\"/>"
                 "<integrator type=\"path\"/></integrator></scene>",
                 SPC_ERR_PLUGIN, 1, 47, "aov type 'uv'");
    /* thinlens: a lens (its focus_distance defaults to far_clip), aperture_radius required */
    s = load_ok("<scene version=\"3.0.0\"><sensor type=\"thinlens\"><float name=\"aperture_radius\" value=\"0.1\"/>"
                "<float name=\"far_clip\" value=\"50\"/></sensor></scene>");
    CHECK(s && s->camera.type == SPC_CAMERA_PERSPECTIVE);
    CHECK(s && s->camera.aperture_radius == 0.1 && s->camera.focus_distance == 50.0);
    spc_scene_destroy(s);
    expect_error("<scene version=\"3.0.0\"><sensor type=\"thinlens\"/></scene>", SPC_ERR_VALUE, 1, 24,
                 "aperture_radius");
    expect_error("<scene version=\"3.0.0\"><sensor type=\"thinlens\"><float name=\"aperture_radius\" value=\"0.1\"/>"
                 "<float name=\"focus_distance\" value=\"-1\"/></sensor></scene>",
                 SPC_ERR_VALUE, 1, 91, "focus_distance");
}

TEST(error_locations)
{
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"plastik\"/>\n"
                 "</scene>\n",
                 SPC_ERR_PLUGIN, 2, 3, "unknown bsdf type 'plastik'");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"sphere\">\n"
                 "      <bsdf type=\"diffuse\"/><emitter type=\"laser\"/></shape>\n"
                 "</scene>\n",
                 SPC_ERR_PLUGIN, 3, 29, "unknown emitter type 'laser'");
    expect_error("<scene version=\"3.0.0\">\n"
                 "\t<shape type=\"teapot\"/>\n"
                 "</scene>\n",
                 SPC_ERR_PLUGIN, 2, 2, "'teapot'");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <integrator type=\"path_sms_ss\">\n"
                 "    <integer name=\"max_depth\" value=\"5\"/>\n"
                 "  </integrator>\n"
                 "</scene>\n",
                 SPC_ERR_PLUGIN, 2, 3,
                 "unknown integrator 'path_sms_ss'; choose one of specula's with --integrator path or -D "
                 "integrator=path");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"diffuse\">\n"
                 "</scene>\n",
                 SPC_ERR_PARSE, 3, 3, "mismatched tag");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"obj\">\n"
                 "    <string name=\"filename\" value=\"no/such/mesh.obj\"/>\n"
                 "  </shape>\n"
                 "</scene>\n",
                 SPC_ERR_IO, 3, 5, "no/such/mesh.obj");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"sphere\">\n"
                 "    <float name=\"radius\" value=\"-1\"/>\n"
                 "  </shape>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 5, "sphere radius -1 must be positive");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"sphere\">\n"
                 "      <float name=\"radius\" value=\"1.0x\"/>\n"
                 "  </shape>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 7, "could not parse float value \"1.0x\"");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1, 0.2\"/></bsdf>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 2, 24, "one or three values");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <sensor type=\"perspective\"><integer name=\"fov\" value=\"abc\"/></sensor>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 2, 30, "abc");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"sphere\"><transform name=\"to_world\"><scale x=\"1\" y=\"2\"/></transform></shape>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 2, 24, "uniformly");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <emitter type=\"area\"/>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 2, 3, "nested inside a <shape>");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"diffuse\" id=\"x\"/>\n"
                 "  <bsdf type=\"diffuse\" id=\"x\"/>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 3, "duplicate id 'x'");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"diffuse\"><float name=\"reflectance\" value=\"1\"/>"
                 "<float name=\"reflectance\" value=\"2\"/></bsdf>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 2, 61, "given twice");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"twosided\" id=\"a\"><ref id=\"b\"/></bsdf>\n"
                 "  <bsdf type=\"twosided\" id=\"b\"><ref id=\"a\"/></bsdf>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 2, 3, "cycle");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <medium type=\"homogenous\"/>\n"
                 "</scene>\n",
                 SPC_ERR_PLUGIN, 2, 3, "homogenous");
    /* references, includes and attributes that are missing, and a degenerate transform */
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"sphere\">\n"
                 "    <ref id=\"nothere\"/>\n"
                 "  </shape>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 5, "unknown id 'nothere'");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <include filename=\"no_such_part.xml\"/>\n"
                 "</scene>\n",
                 SPC_ERR_IO, 2, 3, "no_such_part.xml");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"diffuse\">\n"
                 "    <rgb name=\"reflectance\"/>\n"
                 "  </bsdf>\n"
                 "</scene>\n",
                 SPC_ERR_PARSE, 3, 5, "needs a 'value' attribute");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"sphere\">\n"
                 "    <transform name=\"to_world\">\n"
                 "      <rotate angle=\"30\"/>\n"
                 "    </transform>\n"
                 "  </shape>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 4, 7, "non-zero axis");
}

/* A property no plugin reads is an error naming file:line and the closest name the plugin read
 * (Mitsuba 3's "unreferenced property"); the define @unreferenced=warn makes it a warning. */
/* -D must name a <default> of the scene (or a $name it uses); the error lists the defaults. */
TEST(define_must_name_a_default)
{
    const char *xml = "<scene version=\"3.0.0\">\n"
                      "  <default name=\"spp\" value=\"4\"/>\n"
                      "  <default name=\"res\" value=\"8\"/>\n"
                      "  <sensor type=\"perspective\"><sampler type=\"independent\">"
                      "<integer name=\"sample_count\" value=\"$spp\"/></sampler>"
                      "<film type=\"hdrfilm\"><integer name=\"width\" value=\"$res\"/>"
                      "<integer name=\"height\" value=\"$res\"/></film></sensor>\n"
                      "</scene>\n";
    spc_define nosuch = {"nosuch", "3"};
    spc_scene *s = (spc_scene *)1;
    spc_error e;
    CHECK(load_defs(xml, &nosuch, 1, &s, &e) == SPC_ERR_VALUE && s == NULL);
    CHECK_MSG(strstr(e.msg, "-D nosuch=3") && strstr(e.msg, "its defaults are: spp, res"), "%s", e.msg);
    CHECK(strcmp(e.file, "test.xml") == 0);
    spc_define ok = {"spp", "2"};
    CHECK(load_defs(xml, &ok, 1, &s, &e) == SPC_OK && s && s->spp == 2);
    spc_scene_destroy(s);
    /* a $name without a <default>, given by -D, is used: accepted */
    const char *nodefault = "<scene version=\"3.0.0\"><sensor type=\"perspective\"><sampler type=\"independent\">"
                            "<integer name=\"sample_count\" value=\"$n\"/></sampler></sensor></scene>\n";
    spc_define n = {"n", "3"};
    CHECK(load_defs(nodefault, &n, 1, &s, &e) == SPC_OK && s && s->spp == 3);
    spc_scene_destroy(s);
    /* and a scene without defaults says so */
    s = (spc_scene *)1;
    CHECK(load_defs("<scene version=\"3.0.0\"/>\n", &nosuch, 1, &s, &e) == SPC_ERR_VALUE && s == NULL);
    CHECK_MSG(strstr(e.msg, "it declares no defaults"), "%s", e.msg);
    /* a define too large for an integer property: out of range, said so */
    spc_define huge = {"res", "99999999999"};
    CHECK(load_defs(xml, &huge, 1, &s, &e) == SPC_ERR_LIMIT && s == NULL);
    CHECK_MSG(strstr(e.msg, "property 'width': 99999999999 is out of range"), "%s", e.msg);
    spc_define frac = {"res", "2.5"};
    CHECK(load_defs(xml, &frac, 1, &s, &e) != SPC_OK && s == NULL);
    CHECK_MSG(strstr(e.msg, "must be an integer") || strstr(e.msg, "could not parse integer"), "%s", e.msg);
}

/* Messages that say what is wrong: a kind mismatch with the right article; a sphere scaled by 0;
 * a directory given as a mesh file; focus_distance on a perspective sensor is no warning. */
TEST(messages_say_what_is_wrong)
{
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"sphere\">\n"
                 "    <string name=\"radius\" value=\"big\"/>\n"
                 "  </shape>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 5, "property 'radius' must be a float, not a string");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <sensor type=\"perspective\"><film type=\"hdrfilm\">\n"
                 "    <string name=\"width\" value=\"wide\"/>\n"
                 "  </film></sensor>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 5, "property 'width' must be an integer, not a string");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"sphere\">\n"
                 "    <transform name=\"to_world\">\n"
                 "      <scale value=\"0\"/>\n"
                 "    </transform>\n"
                 "  </shape>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 5, "scale of 0");
    char dir[600];
    snprintf(dir, sizeof dir, "%s/meshdir.obj", tmpdir);
    CHECK(mkdir(dir, 0755) == 0 || errno == EEXIST);
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"obj\">\n"
                 "    <string name=\"filename\" value=\"meshdir.obj\"/>\n"
                 "  </shape>\n"
                 "</scene>\n",
                 SPC_ERR_IO, 3, 5, "mesh file 'meshdir.obj' is a directory, not a file");
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <shape type=\"obj\">\n"
                 "    <string name=\"filename\" value=\"nowhere.obj\"/>\n"
                 "  </shape>\n"
                 "</scene>\n",
                 SPC_ERR_IO, 3, 5, "mesh file 'nowhere.obj' not found");
    capture_begin();
    spc_scene *s = load_ok("<scene version=\"3.0.0\">\n"
                           "  <sensor type=\"perspective\">\n"
                           "    <float name=\"focus_distance\" value=\"3\"/>\n"
                           "  </sensor>\n"
                           "</scene>\n");
    const char *w = capture_end();
    CHECK(s != NULL);
    spc_scene_destroy(s);
    CHECK_MSG(w[0] == '\0', "a warning for focus_distance on a perspective sensor: %s", w);
}

TEST(unreferenced_property_is_an_error)
{
    write_file("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    const char *typo = "<scene version=\"3.0.0\">\n"
                       "  <shape type=\"sphere\">\n"
                       "    <float name=\"radiu\" value=\"2\"/>\n"
                       "  </shape>\n"
                       "</scene>\n";
    expect_error(typo, SPC_ERR_VALUE, 3, 5, "unreferenced property 'radiu' of <shape type=\"sphere\">");
    expect_error(typo, SPC_ERR_VALUE, 3, 5, "did you mean 'radius'?");
    /* nothing close: no suggestion */
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"diffuse\">\n"
                 "    <float name=\"wavelength_band\" value=\"1\"/>\n"
                 "  </bsdf>\n"
                 "</scene>\n",
                 SPC_ERR_VALUE, 3, 5, "unreferenced property 'wavelength_band' of <bsdf type=\"diffuse\">; ");

    spc_define lenient = {SPC_DEFINE_UNREFERENCED, "warn"};
    spc_scene *s = NULL;
    spc_error e;
    capture_begin();
    spc_status st = load_defs(typo, &lenient, 1, &s, &e);
    const char *w = capture_end();
    CHECK_MSG(st == SPC_OK && s != NULL, "%s", e.msg);
    CHECK_MSG(strstr(w, "test.xml:3:5: warning: unreferenced property 'radiu'") != NULL, "got: %s", w);
    CHECK_MSG(strstr(w, "did you mean 'radius'?") != NULL, "got: %s", w);
    spc_scene_destroy(s);
    spc_define bad = {SPC_DEFINE_UNREFERENCED, "maybe"};
    s = (spc_scene *)1;
    CHECK(load_defs(typo, &bad, 1, &s, &e) == SPC_ERR_VALUE && s == NULL);
    CHECK(strstr(e.msg, "warn or error") != NULL);

    /* properties other renderers' plugins use and specula keeps are not warned about */
    capture_begin();
    s = load_ok("<scene version=\"3.0.0\">\n"
                "  <shape type=\"obj\"><string name=\"filename\" value=\"tri.obj\"/>"
                "<boolean name=\"face_normals\" value=\"true\"/>"
                "<boolean name=\"caustic_caster_single\" value=\"true\"/>"
                "<boolean name=\"caustic_caster_multi\" value=\"false\"/></shape>\n"
                "  <sensor type=\"perspective\"><film type=\"hdrfilm\">"
                "<string name=\"pixel_format\" value=\"rgb\"/></film></sensor>\n"
                "</scene>\n");
    w = capture_end();
    CHECK_MSG(w[0] == '\0', "unexpected warnings: %s", w);
    CHECK(s != NULL);
    if (s) {
        CHECK(s->shapes[0]->face_normals);
        CHECK(s->shapes[0]->caustic_flags == (SPC_CAUSTIC_FLAGS_EXPLICIT | SPC_CAUSTIC_CASTER_SINGLE));
        spc_scene_destroy(s);
    }
}

TEST(bsdf_variants)
{
    spc_scene *s = load_ok(
        "<scene version=\"3.0.0\">\n"
        "  <bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf>\n"
        "  <bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.25\"/><bsdf type=\"diffuse\"/>"
        "<bsdf type=\"conductor\"/></bsdf>\n"
        "  <bsdf type=\"mask\"><bsdf type=\"null\"/></bsdf>\n"
        "  <bsdf type=\"roughplastic\"><string name=\"distribution\" value=\"ggx\"/>"
        "<boolean name=\"nonlinear\" value=\"true\"/></bsdf>\n"
        "  <bsdf type=\"phong\"/>\n"
        "  <bsdf type=\"roughdiffuse\"/>\n"
        "  <bsdf type=\"thindielectric\"><float name=\"int_ior\" value=\"1.25\"/><float name=\"ext_ior\" value=\"1\"/></bsdf>\n"
        "  <bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.3\"/></bsdf>\n"
        "  <bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\">"
        "<rgb name=\"color0\" value=\"1\"/><transform name=\"to_uv\"><scale x=\"4\" y=\"2\"/></transform></texture></bsdf>\n"
        "</scene>\n");
    CHECK(s != NULL);
    if (!s)
        return;
    const spc_bsdf *two = NULL, *blend = NULL, *mask = NULL, *rp = NULL, *ph = NULL, *rd = NULL, *th = NULL,
                   *rdi = NULL, *chk = NULL;
    for (int i = 0; i < s->nbsdfs; ++i) {
        const spc_bsdf *b = s->bsdfs[i];
        if (b->type == SPC_BSDF_TWOSIDED)
            two = b;
        else if (b->type == SPC_BSDF_BLENDBSDF)
            blend = b;
        else if (b->type == SPC_BSDF_MASK)
            mask = b;
        else if (b->type == SPC_BSDF_ROUGHPLASTIC)
            rp = b;
        else if (b->type == SPC_BSDF_PHONG)
            ph = b;
        else if (b->type == SPC_BSDF_ROUGHDIFFUSE)
            rd = b;
        else if (b->type == SPC_BSDF_THINDIELECTRIC)
            th = b;
        else if (b->type == SPC_BSDF_ROUGHDIELECTRIC)
            rdi = b;
        else if (b->type == SPC_BSDF_DIFFUSE && b->reflectance->type == SPC_TEX_CHECKERBOARD)
            chk = b;
    }
    CHECK(two && two->nested[0] && two->nested[0]->type == SPC_BSDF_DIFFUSE && two->nested[1] == two->nested[0]);
    CHECK(blend && const_rgb(blend->weight).r == 0.25 && blend->nested[1]->type == SPC_BSDF_CONDUCTOR);
    CHECK(mask && const_rgb(mask->opacity).r == 0.5 && mask->nested[0]->type == SPC_BSDF_NULL);
    CHECK(rp && rp->distribution == SPC_MICROFACET_GGX && rp->nonlinear && const_rgb(rp->alpha_u).r == 0.1);
    CHECK(rp && fabs(rp->eta - 1.49 / 1.000277) < 1e-12);
    CHECK(ph && ph->exponent == 30.0 && const_rgb(ph->specular_reflectance).r == 0.2 &&
          const_rgb(ph->reflectance).r == 0.5);
    CHECK(rd && const_rgb(rd->alpha_u).r == 0.2);
    CHECK(th && th->eta == 1.25);
    CHECK(rdi && const_rgb(rdi->alpha_v).r == 0.3);
    CHECK(chk && chk->reflectance->color0.r == 1.0 && chk->reflectance->color1.r == 0.2);
    CHECK(chk && chk->reflectance->to_uv[0][0] == 4.0 && chk->reflectance->to_uv[1][1] == 2.0);
    spc_scene_destroy(s);
    expect_error("<scene version=\"3.0.0\">\n"
                 "  <bsdf type=\"diffuse\">\n"
                 "    <texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"nope.png\"/>"
                 "</texture></bsdf>\n"
                 "</scene>\n",
                 SPC_ERR_IO, 3, 47, "nope.png");
}


TEST(bitmaps_and_envmap)
{
    char path[600];
    snprintf(path, sizeof path, "%s/tex.exr", tmpdir);
    const char *names[3] = {"R", "G", "B"};
    const float px[6] = {1, 2, 3, 4, 5, 6};
    spc_error e;
    CHECK(spc_exr_write(path, 2, 1, 3, names, px, NULL, 0, &e) == SPC_OK);
    snprintf(path, sizeof path, "%s/nm.png", tmpdir);
    const float half[3] = {0.5f, 0.5f, 1.0f};
    CHECK(spc_png_write_srgb(path, 1, 1, half, &e) == SPC_OK);
    spc_scene *s = load_ok(
        "<scene version=\"3.0.0\">\n"
        "  <texture type=\"bitmap\" id=\"t\"><string name=\"filename\" value=\"tex.exr\"/>"
        "<string name=\"filter_type\" value=\"nearest\"/><string name=\"wrap_mode\" value=\"clamp\"/>"
        "<transform name=\"to_uv\"><scale x=\"2\"/><translate y=\"0.5\"/></transform></texture>\n"
        "  <bsdf type=\"diffuse\"><ref name=\"reflectance\" id=\"t\"/></bsdf>\n"
        "  <bsdf type=\"normalmap\"><texture type=\"bitmap\" name=\"normalmap\"><string name=\"filename\" "
        "value=\"nm.png\"/><boolean name=\"raw\" value=\"true\"/></texture><bsdf type=\"diffuse\"/></bsdf>\n"
        "  <bsdf type=\"bumpmap\"><ref id=\"t\"/><float name=\"scale\" value=\"0.5\"/><bsdf type=\"diffuse\"/></bsdf>\n"
        "  <emitter type=\"envmap\"><string name=\"filename\" value=\"tex.exr\"/><float name=\"scale\" value=\"3\"/>"
        "</emitter>\n"
        "</scene>\n");
    CHECK(s != NULL);
    if (!s)
        return;
    const spc_texture *t = s->bsdfs[0]->reflectance;
    CHECK(t->type == SPC_TEX_BITMAP && t->width == 2 && t->height == 1);
    CHECK(t->data && t->data[3] == 4.0f && t->data[5] == 6.0f); /* EXR is linear: no decoding */
    CHECK(t->nearest && t->wrap == SPC_WRAP_CLAMP);
    CHECK(t->to_uv[0][0] == 2.0 && t->to_uv[1][1] == 1.0 && t->to_uv[1][2] == 0.5 && t->to_uv[0][2] == 0.0);
    const spc_bsdf *nm = s->bsdfs[1];
    CHECK(nm->type == SPC_BSDF_NORMALMAP && nm->normalmap && nm->nested[0]);
    /* raw: the stored 8-bit value (0.5 encoded as sRGB is 187.5/255) is not decoded back to 0.5 */
    CHECK(nm->normalmap && nm->normalmap->data && fabs(nm->normalmap->data[0] - 187.5 / 255.0) < 0.6 / 255.0);
    const spc_bsdf *bm = s->bsdfs[3];
    CHECK(bm->type == SPC_BSDF_BUMPMAP && bm->bump == t && bm->bump_scale == 0.5);
    CHECK(s->nemitters == 1 && s->emitters[0]->type == SPC_EMITTER_ENVMAP);
    CHECK(s->emitters[0]->scale == 3.0 && s->emitters[0]->radiance->type == SPC_TEX_BITMAP);
    spc_scene_destroy(s);
}

/* The scene's own property embree_use_robust_intersections (Mitsuba 3's name): read into
 * spc_scene.accel_robust, true when absent; a value that is not a boolean is an error. */
TEST(scene_robust_property)
{
    static const char *fmt = "<scene version=\"3.0.0\">\n%s  <shape type=\"sphere\"/>\n</scene>\n";
    static const char *props[3] = {"", "  <boolean name=\"embree_use_robust_intersections\" value=\"false\"/>\n",
                                   "  <boolean name=\"embree_use_robust_intersections\" value=\"TRUE\"/>\n"};
    const bool want[3] = {true, false, true};
    char xml[512];
    for (int i = 0; i < 3; ++i) {
        snprintf(xml, sizeof xml, fmt, props[i]);
        spc_scene *s = load_ok(xml);
        CHECK(s != NULL);
        if (s)
            CHECK(s->accel_robust == want[i]);
        spc_scene_destroy(s);
    }
    snprintf(xml, sizeof xml, fmt, "  <boolean name=\"embree_use_robust_intersections\" value=\"maybe\"/>\n");
    expect_error(xml, SPC_ERR_VALUE, 2, 3, "could not parse boolean");
    snprintf(xml, sizeof xml, fmt, "  <boolean name=\"embree_robust\" value=\"true\"/>\n");
    expect_error(xml, SPC_ERR_PARSE, 2, 3, "top level");
}

TEST(more_syntax)
{
    write_file("refl.spd", "# wavelength value\n360 0.25\n830 0.25\n");
    write_file("bad_part.xml", "<scene version=\"3.0.0\">\n\n   <bsdf type=\"velvet\"/>\n</scene>\n");
    spc_scene *s = load_ok(
        "<scene version=\"0.6.0\">\n"
        "  <bsdf type=\"diffuse\"><spectrum name=\"reflectance\" filename=\"refl.spd\"/></bsdf>\n"
        "  <bsdf type=\"diffuse\"><srgb name=\"reflectance\" value=\"0.5\"/></bsdf>\n"
        "  <bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\">"
        "<float name=\"uoffset\" value=\"0.5\"/><float name=\"uscale\" value=\"4\"/></texture></bsdf>\n"
        "  <bsdf type=\"null\" id=\"n\"/>\n"
        "  <alias id=\"n\" as=\"m\"/>\n"
        "  <shape type=\"disk\"><ref id=\"m\"/></shape>\n"
        "  <sensor type=\"perspective\"><transform name=\"toWorld\"><lookAt origin=\"0,0,0\" target=\"0,0,1\"/>"
        "</transform></sensor>\n"
        "</scene>\n");
    CHECK(s != NULL);
    if (s) {
        /* a flat 0.25 from a file, as Mitsuba 3 reads it (0.25 x 0.998872: D65 white, not 1) */
        CHECK_NEAR(const_rgb(s->bsdfs[0]->reflectance).g, 0.25 * 0.998872, 1e-6);
        CHECK_NEAR(const_rgb(s->bsdfs[1]->reflectance).r, 0.2140411, 1e-6); /* sRGB 0.5 decoded */
        const spc_texture *c = s->bsdfs[2]->reflectance;
        /* as Mitsuba 3's upgrade: translate by the offset, then scale: u' = 4 (u + 0.5) */
        CHECK(c->type == SPC_TEX_CHECKERBOARD && c->to_uv[0][0] == 4.0 && c->to_uv[0][2] == 2.0);
        CHECK(s->shapes[0]->bsdf == s->bsdfs[3]);
        /* lookat without up: some up perpendicular to the view direction */
        spc_vec3 z = spc_v3(s->camera.to_world.m[0][2], s->camera.to_world.m[1][2], s->camera.to_world.m[2][2]);
        spc_vec3 y = spc_v3(s->camera.to_world.m[0][1], s->camera.to_world.m[1][1], s->camera.to_world.m[2][1]);
        CHECK_NEAR(z.z, 1.0, 1e-12);
        CHECK_NEAR(spc_dot(y, z), 0.0, 1e-12);
        CHECK_NEAR(spc_length(y), 1.0, 1e-12);
        spc_scene_destroy(s);
    }
    /* an error inside an included file names that file and its position */
    spc_error e;
    CHECK(load("<scene version=\"3.0.0\"><include filename=\"bad_part.xml\"/></scene>", &s, &e) == SPC_ERR_PLUGIN);
    CHECK(strstr(e.file, "bad_part.xml") != NULL);
    CHECK(e.line == 3 && e.col == 4);
    CHECK(strstr(e.msg, "velvet") != NULL);
}

/* Every prefix (in steps) and a few hundred random byte mutations of a scene that uses most of
 * the syntax must either load or fail with a message: never crash, never leave a half scene. */
TEST(fuzz_truncations_and_mutations)
{
    const char *base =
        "<scene version=\"3.0.0\">\n"
        "  <default name=\"spp\" value=\"4\"/>\n"
        "  <integrator type=\"path\"><integer name=\"max_depth\" value=\"5\"/></integrator>\n"
        "  <sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>\n"
        "    <transform name=\"to_world\"><lookat origin=\"0,1,5\" target=\"0,0,0\" up=\"0,1,0\"/></transform>\n"
        "    <sampler type=\"independent\"><integer name=\"sample_count\" value=\"$spp\"/></sampler>\n"
        "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"32\"/><rfilter type=\"gaussian\"/></film>\n"
        "  </sensor>\n"
        "  <bsdf type=\"twosided\" id=\"w\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5, 0.4, 0.3\"/>"
        "</bsdf></bsdf>\n"
        "  <shape type=\"rectangle\"><ref id=\"w\"/><transform name=\"to_world\"><scale value=\"3\"/>"
        "<rotate x=\"1\" angle=\"-90\"/></transform></shape>\n"
        "  <shape type=\"sphere\"><point name=\"center\" value=\"0, 1, 0\"/><float name=\"radius\" value=\"0.5\"/>"
        "<bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"water\"/></bsdf></shape>\n"
        "  <shape type=\"disk\"><emitter type=\"area\"><spectrum name=\"radiance\" value=\"400:1, 700:2\"/></emitter>"
        "<transform name=\"to_world\"><translate y=\"3\"/></transform></shape>\n"
        "  <emitter type=\"constant\"><rgb name=\"radiance\" value=\"#101010\"/></emitter>\n"
        "</scene>\n";
    size_t n = strlen(base);
    char *buf = malloc(n + 1);
    uint64_t state = 12345;
    int loaded = 0, failed = 0;
    for (int trial = 0; trial < 400; ++trial) {
        size_t len = n;
        memcpy(buf, base, n + 1);
        if (trial < 100) {
            len = (size_t)trial * n / 100; /* prefixes */
            buf[len] = '\0';
        } else {
            int k = 1 + trial % 3;
            for (int j = 0; j < k; ++j) {
                state = state * 6364136223846793005ull + 1442695040888963407ull;
                size_t pos = (size_t)(state >> 33) % n;
                static const char alphabet[] = "<>/\"=$#:, .-0123456789abcxyz\n";
                buf[pos] = alphabet[(state >> 20) % (sizeof alphabet - 1)];
            }
        }
        spc_scene *s = (spc_scene *)1;
        spc_error e;
        memset(&e, 0, sizeof e);
        spc_status st = spc_mitsuba_load_string(buf, len, "fuzz.xml", tmpdir, NULL, 0, &s, &e);
        if (st == SPC_OK) {
            CHECK(s != NULL);
            ++loaded;
            spc_scene_destroy(s);
        } else {
            CHECK(s == NULL);
            CHECK(e.code == st && e.msg[0] != '\0');
            ++failed;
        }
    }
    CHECK(loaded > 0 && failed > 100);
    free(buf);
}

/* The shared scenes' folder (../shared/scenes), given on the command line: CMake registers the
 * run that reads them (test_xml_shared) only where it finds them, and that run fails without them. */
static const char *shared_dir = NULL;

static void shared_scene(const char *name, int nshapes, int nemitters)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s/scene.xml", shared_dir, name);
    CHECK_MSG(access(path, R_OK) == 0, "%s not found", path);
    if (access(path, R_OK) != 0)
        return;
    spc_scene *s = (spc_scene *)1;
    spc_error e;
    CHECK(spc_mitsuba_load(path, NULL, 0, &s, &e) == SPC_ERR_PLUGIN);
    CHECK(s == NULL);
    CHECK(strstr(e.msg, "unknown integrator 'path_guiding_integrator'") != NULL);
    CHECK(e.line > 0 && e.col > 0);
    spc_define d = {"integrator", "path"};
    spc_status st = spc_mitsuba_load(path, &d, 1, &s, &e);
    CHECK_MSG(st == SPC_OK, "%s", e.msg);
    if (st != SPC_OK)
        return;
    CHECK(s->nshapes == nshapes);
    CHECK(s->nemitters == nemitters);
    CHECK(strcmp(s->integrator.type, "path") == 0);
    CHECK(s->spp == 64);
    spc_scene_destroy(s);
    /* what --integrator passes: the file's integrator type is replaced, its max_depth kept */
    spc_define o = {SPC_MITSUBA_INTEGRATOR_DEFINE, "bdpt"};
    st = spc_mitsuba_load(path, &o, 1, &s, &e);
    CHECK_MSG(st == SPC_OK, "%s", e.msg);
    if (st != SPC_OK)
        return;
    CHECK(strcmp(s->integrator.type, "bdpt") == 0);
    CHECK(s->integrator.max_depth > 0);
    spc_scene_destroy(s);
}

TEST(shared_scenes)
{
    shared_scene("cornell-box", 8, 1);
    shared_scene("veach-mis", 9, 3);
}

int main(int argc, char **argv)
{
    snprintf(tmpdir, sizeof tmpdir, "/tmp/specula_xml_XXXXXX");
    if (!mkdtemp(tmpdir)) {
        printf("mkdtemp failed\n");
        return 1;
    }
    spc_warn_set_quiet(1);
    if (argc == 3 && !strcmp(argv[1], "--shared-scenes")) { /* only the shared scenes */
        shared_dir = argv[2];
        RUN(shared_scenes);
        rmdir(tmpdir);
        return spc_test_finish();
    }
    RUN(xml_tree_positions);
    RUN(rgb_forms);
    RUN(spectrum_values);
    RUN(transforms);
    RUN(defaults_and_defines);
    RUN(include_and_path);
    RUN(forward_reference);
    RUN(objects_by_reference);
    RUN(dialect_06_equals_3);
    RUN(named_ior_and_conductors);
    RUN(shapes_and_emitters);
    RUN(sensor_and_integrators);
    RUN(error_locations);
    RUN(unreferenced_property_is_an_error);
    RUN(define_must_name_a_default);
    RUN(messages_say_what_is_wrong);
    RUN(bsdf_variants);
    RUN(bitmaps_and_envmap);
    RUN(more_syntax);
    RUN(scene_robust_property);
    RUN(fuzz_truncations_and_mutations);
    char cmd[512];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (system(cmd) != 0)
        printf("could not remove %s\n", tmpdir);
    return spc_test_finish();
}
