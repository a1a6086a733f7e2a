/*
 * tests/test_plugins.c: the loader's plugin table (io/mitsuba_plugin_list.c) is true and
 * docs/PLUGINS.md is that table printed. For every plugin the table marks as read, a small scene
 * using it loads; for every one it marks as not read, loading fails with SPC_ERR_PLUGIN and an
 * error that names the plugin. The committed docs/PLUGINS.md must equal the generated text;
 * SPC_WRITE_PLUGINS=1 build/test_plugins writes it. specula's own properties given as <default>s
 * (the form Mitsuba 3 ignores) are read.
 */
/* ctest-labels: unit */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "io/mitsuba_plugin_list.h"
#include "io/mitsuba_xml.h"
#include "scene/scene.h"
#include "scene/shape.h"
#include "specula/specula.h"

static const char *source_dir(void)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    return d ? d : ".";
}

/* The body of a small scene that uses plugin p (in the scenes/ folder, for its meshes and images). */
static void probe(const mts_plugin *p, char *xml, size_t size)
{
    const char *c = p->category, *n = p->name;
    char inner[600] = "";
    if (strcmp(c, "bsdf") == 0) {
        if (!strcmp(n, "twosided") || !strcmp(n, "mask") || !strcmp(n, "blendbsdf"))
            snprintf(inner, sizeof inner, "<bsdf type=\"diffuse\"/>%s",
                     strcmp(n, "blendbsdf") == 0 ? "<bsdf type=\"conductor\"/>" : "");
        else if (!strcmp(n, "bumpmap"))
            snprintf(inner, sizeof inner,
                     "<texture type=\"bitmap\"><string name=\"filename\" "
                     "value=\"textures/bumps.png\"/></texture><bsdf type=\"diffuse\"/>");
        else if (!strcmp(n, "normalmap"))
            snprintf(inner, sizeof inner,
                     "<texture type=\"bitmap\" name=\"normalmap\"><string name=\"filename\" "
                     "value=\"textures/waves_normal.png\"/></texture><bsdf type=\"diffuse\"/>");
        snprintf(xml, size, "<bsdf type=\"%s\" id=\"b\">%s</bsdf><shape type=\"sphere\"><ref id=\"b\"/></shape>", n,
                 inner);
    } else if (strcmp(c, "emitter") == 0) {
        if (!strcmp(n, "area"))
            snprintf(xml, size, "<shape type=\"sphere\"><emitter type=\"area\"/></shape>");
        else if (!strcmp(n, "envmap"))
            snprintf(xml, size,
                     "<emitter type=\"envmap\"><string name=\"filename\" value=\"textures/sky.exr\"/>"
                     "</emitter>");
        else
            snprintf(xml, size, "<emitter type=\"%s\"/>", n);
    } else if (strcmp(c, "shape") == 0) {
        const char *file = !strcmp(n, "obj")          ? "meshes/quad.obj"
                           : !strcmp(n, "ply")        ? "meshes/torus_ascii.ply"
                           : !strcmp(n, "serialized") ? "meshes/cone_prism.serialized"
                           : strstr(n, "curve")       ? "meshes/curves.txt"
                                                      : NULL;
        if (file)
            snprintf(xml, size, "<shape type=\"%s\"><string name=\"filename\" value=\"%s\"/></shape>", n, file);
        else if (!strcmp(n, "shapegroup") || !strcmp(n, "instance"))
            snprintf(xml, size,
                     "<shape type=\"shapegroup\" id=\"g\"><shape type=\"sphere\"/></shape>"
                     "<shape type=\"instance\"><ref id=\"g\"/></shape>");
        else if (!strcmp(n, "sdf"))
            snprintf(xml, size, "<shape type=\"sdf\"><sdf type=\"sphere\"/></shape>");
        else if (!strcmp(n, "sdfgrid"))
            snprintf(xml, size, "<shape type=\"sdfgrid\"><string name=\"filename\" value=\"sdfgrid/blob.vol\"/></shape>");
        else
            snprintf(xml, size, "<shape type=\"%s\"/>", n);
    } else if (strcmp(c, "texture") == 0) {
        snprintf(xml, size,
                 "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"%s\" name=\"reflectance\">%s"
                 "</texture></bsdf></shape>",
                 n,
                 strcmp(n, "bitmap") == 0           ? "<string name=\"filename\" value=\"textures/grid.png\"/>"
                 : strcmp(n, "mesh_attribute") == 0 ? "<string name=\"name\" value=\"vertex_color\"/>"
                                                    : "");
    } else if (strcmp(c, "sensor") == 0) {
        snprintf(xml, size, "<sensor type=\"%s\">%s</sensor>", n,
                 strcmp(n, "thinlens") == 0 ? "<float name=\"aperture_radius\" value=\"0.1\"/>" : "");
    } else if (strcmp(c, "film") == 0) {
        snprintf(xml, size, "<sensor type=\"perspective\"><film type=\"%s\"/></sensor>", n);
    } else if (strcmp(c, "rfilter") == 0) {
        snprintf(xml, size,
                 "<sensor type=\"perspective\"><film type=\"hdrfilm\"><rfilter type=\"%s\"/></film></sensor>", n);
    } else if (strcmp(c, "sampler") == 0) {
        snprintf(xml, size, "<sensor type=\"perspective\"><sampler type=\"%s\"/></sensor>", n);
    } else if (strcmp(c, "integrator") == 0) {
        if (!strcmp(n, "aov"))
            snprintf(inner, sizeof inner, "<string name=\"aovs\" value=\"d:depth\"/><integrator type=\"path\"/>");
        else if (!strcmp(n, "moment") || !strcmp(n, "stokes"))
            snprintf(inner, sizeof inner, "<integrator type=\"path\"/>");
        snprintf(xml, size, "<integrator type=\"%s\">%s</integrator>", n, inner);
    } else if (strcmp(c, "medium") == 0) {
        snprintf(xml, size,
                 "<medium type=\"%s\" id=\"m\"/><shape type=\"sphere\"><ref name=\"interior\" id=\"m\"/>"
                 "</shape>",
                 n);
    } else if (strcmp(c, "phase") == 0) {
        snprintf(xml, size,
                 "<medium type=\"homogeneous\" id=\"m\"><phase type=\"%s\"/></medium>"
                 "<shape type=\"sphere\"><ref name=\"interior\" id=\"m\"/></shape>",
                 n);
    } else { /* volume */
        snprintf(xml, size,
                 "<medium type=\"heterogeneous\" id=\"m\"><volume type=\"%s\" name=\"sigma_t\">%s</volume></medium>"
                 "<shape type=\"sphere\"><ref name=\"interior\" id=\"m\"/></shape>",
                 n, strcmp(n, "gridvolume") == 0 ? "<string name=\"filename\" value=\"textures/cloud.vol\"/>" : "");
    }
}

TEST(every_plugin_is_as_listed)
{
    int n;
    const mts_plugin *p = mts_plugin_list(&n);
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/scenes", source_dir());
    for (int i = 0; i < n; ++i) {
        char body[1500], xml[2000];
        probe(&p[i], body, sizeof body);
        snprintf(xml, sizeof xml, "<scene version=\"3.0.0\">%s</scene>", body);
        spc_scene *s = NULL;
        spc_error err;
        memset(&err, 0, sizeof err);
        spc_status st = spc_mitsuba_load_string(xml, strlen(xml), "probe.xml", dir, NULL, 0, &s, &err);
        if (p[i].status == MTS_PLUGIN_NO) {
            CHECK_MSG(st == SPC_ERR_PLUGIN, "%s '%s' is listed as not read but loads (status %d: %s)", p[i].category,
                      p[i].name, (int)st, err.msg);
            /* volumes are refused where a medium would take them, without their name */
            if (strcmp(p[i].category, "volume") != 0)
                CHECK_MSG(strstr(err.msg, p[i].name) != NULL, "%s '%s': the error does not name it: %s", p[i].category,
                          p[i].name, err.msg);
        } else {
            CHECK_MSG(st == SPC_OK, "%s '%s' is listed as read but does not load: %s", p[i].category, p[i].name,
                      err.msg);
        }
        spc_scene_destroy(s);
    }
}

/* A Mitsuba 3 plugin specula does not read is named as such, not as a typo. */
TEST(unread_plugins_are_named)
{
    const char *xml = "<scene version=\"3.0.0\"><bsdf type=\"hair\"/></scene>";
    spc_scene *s = NULL;
    spc_error err;
    CHECK(spc_mitsuba_load_string(xml, strlen(xml), "t.xml", ".", NULL, 0, &s, &err) == SPC_ERR_PLUGIN);
    CHECK_MSG(strstr(err.msg, "bsdf 'hair' (a Mitsuba 3 plugin) is not supported") != NULL, "%s", err.msg);
    xml = "<scene version=\"3.0.0\"><bsdf type=\"hare\"/></scene>";
    CHECK(spc_mitsuba_load_string(xml, strlen(xml), "t.xml", ".", NULL, 0, &s, &err) == SPC_ERR_PLUGIN);
    CHECK_MSG(strstr(err.msg, "unknown bsdf type 'hare'") != NULL, "%s", err.msg);
}

/* The table is the one list of names: every bsdf, shape, emitter, texture, medium, phase, volume and
 * integrator row the loader reads names its
 * builder, and an unknown type's error lists every name of its category the table marks read
 * (and none it marks not read). */
TEST(unknown_type_lists_the_table)
{
    int n;
    const mts_plugin *p = mts_plugin_list(&n);
    for (int i = 0; i < n; ++i) {
        bool registry = !strcmp(p[i].category, "bsdf") || !strcmp(p[i].category, "shape") ||
                        !strcmp(p[i].category, "emitter") || !strcmp(p[i].category, "texture") ||
                        !strcmp(p[i].category, "medium") || !strcmp(p[i].category, "phase") ||
                        !strcmp(p[i].category, "volume") || !strcmp(p[i].category, "integrator");
        if (registry)
            CHECK_MSG((p[i].build != NULL) == (p[i].status != MTS_PLUGIN_NO), "%s '%s': builder %s, status %d",
                      p[i].category, p[i].name, p[i].build ? "set" : "missing", (int)p[i].status);
        else
            CHECK_MSG(p[i].build == NULL, "%s '%s' names a builder the loader never calls", p[i].category, p[i].name);
    }
    static const char *const xml[][2] = {
        {"bsdf", "<bsdf type=\"zzz\"/>"},
        {"shape", "<shape type=\"zzz\"/>"},
        {"emitter", "<emitter type=\"zzz\"/>"},
        {"texture", "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"zzz\" name=\"reflectance\"/>"
                    "</bsdf></shape>"},
        {"sensor", "<sensor type=\"zzz\"/>"},
        {"sampler", "<sensor type=\"perspective\"><sampler type=\"zzz\"/></sensor>"},
        {"film", "<sensor type=\"perspective\"><film type=\"zzz\"/></sensor>"},
        {"rfilter", "<sensor type=\"perspective\"><film type=\"hdrfilm\"><rfilter type=\"zzz\"/></film></sensor>"},
        {"medium", "<shape type=\"sphere\"><medium type=\"zzz\" name=\"interior\"/></shape>"},
        {"phase", "<shape type=\"sphere\"><medium type=\"homogeneous\" name=\"interior\"><phase type=\"zzz\"/>"
                  "</medium></shape>"},
        {"volume", "<shape type=\"sphere\"><medium type=\"heterogeneous\" name=\"interior\">"
                   "<volume type=\"zzz\" name=\"sigma_t\"/></medium></shape>"},
    };
    for (size_t k = 0; k < sizeof xml / sizeof xml[0]; ++k) {
        char doc[600];
        snprintf(doc, sizeof doc, "<scene version=\"3.0.0\">%s</scene>", xml[k][1]);
        spc_scene *s = NULL;
        spc_error err;
        memset(&err, 0, sizeof err);
        CHECK(spc_mitsuba_load_string(doc, strlen(doc), "t.xml", ".", NULL, 0, &s, &err) == SPC_ERR_PLUGIN);
        spc_scene_destroy(s);
        const char *list = strchr(err.msg, '(');
        CHECK_MSG(strstr(err.msg, "unknown") && strstr(err.msg, "'zzz'") && list, "%s", err.msg);
        if (!list)
            continue;
        for (int i = 0; i < n; ++i) {
            if (strcmp(p[i].category, xml[k][0]) != 0)
                continue;
            bool listed = false; /* as a whole name: after "(" or " ", before "," or ")" */
            for (const char *q = list; (q = strstr(q, p[i].name)) != NULL; ++q)
                if ((q[-1] == '(' || q[-1] == ' ') &&
                    (q[strlen(p[i].name)] == ',' || q[strlen(p[i].name)] == ')'))
                    listed = true;
            CHECK_MSG(listed == (p[i].status != MTS_PLUGIN_NO), "%s '%s' %s the list: %s", xml[k][0], p[i].name,
                      listed ? "is in" : "is missing from", err.msg);
        }
    }
}

/* specula's own properties in the form Mitsuba 3 ignores (a <default> inside the plugin) are read
 * as the properties; other defaults there are only defaults; a bad value names its line. */
TEST(own_properties_as_defaults)
{
    const char *xml =
        "<scene version=\"3.0.0\">\n"
        "<integrator type=\"path\"><default name=\"specular_nee\" value=\"none\"/>\n"
        "<default name=\"specular_max_chain\" value=\"3\"/><default name=\"other\" value=\"1\"/></integrator>\n"
        "<shape type=\"sphere\"><default name=\"caustic_caster\" value=\"true\"/>\n"
        "<default name=\"caustic_receiver\" value=\"false\"/></shape>\n"
        "<shape type=\"sphere\"><float name=\"radius\" value=\"$other\"/></shape></scene>";
    spc_scene *s = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_status st = spc_mitsuba_load_string(xml, strlen(xml), "t.xml", ".", NULL, 0, &s, &err);
    CHECK_MSG(st == SPC_OK, "%s", err.msg);
    if (st == SPC_OK) {
        CHECK(strcmp(s->integrator.specular_nee, "none") == 0);
        CHECK(s->integrator.specular_max_chain == 3);
        CHECK(s->nshapes == 2);
        CHECK((s->shapes[0]->caustic_flags & SPC_CAUSTIC_CASTER) &&
              !(s->shapes[0]->caustic_flags & SPC_CAUSTIC_RECEIVER));
        CHECK(s->shapes[0]->caustic_flags & SPC_CAUSTIC_FLAGS_EXPLICIT);
        CHECK(!(s->shapes[1]->caustic_flags & SPC_CAUSTIC_FLAGS_EXPLICIT));
    }
    spc_scene_destroy(s);
    s = NULL;
    xml = "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<default name=\"caustic_caster\" value=\"maybe\"/>"
          "</shape></scene>";
    CHECK(spc_mitsuba_load_string(xml, strlen(xml), "t.xml", ".", NULL, 0, &s, &err) == SPC_ERR_VALUE);
    CHECK_MSG(err.line == 3 && strstr(err.msg, "maybe") != NULL, "%d: %s", err.line, err.msg);
    spc_scene_destroy(s);
}

TEST(plugins_md_is_generated)
{
    char *text = NULL;
    size_t len = 0;
    FILE *m = open_memstream(&text, &len);
    CHECK(m != NULL);
    if (!m)
        return;
    CHECK(mts_plugins_markdown(m) == 0);
    fclose(m);
    char path[1024];
    snprintf(path, sizeof path, "%s/docs/PLUGINS.md", source_dir());
    if (getenv("SPC_WRITE_PLUGINS")) {
        FILE *f = fopen(path, "w");
        CHECK(f != NULL);
        if (f) {
            fwrite(text, 1, len, f);
            fclose(f);
        }
    }
    FILE *f = fopen(path, "rb");
    CHECK_MSG(f != NULL, "%s is missing: run SPC_WRITE_PLUGINS=1 build/test_plugins", path);
    if (f) {
        char *have = malloc(len + 2);
        size_t got = have ? fread(have, 1, len + 1, f) : 0;
        fclose(f);
        CHECK_MSG(have && got == len && memcmp(have, text, len) == 0,
                  "%s differs from the plugin table: run SPC_WRITE_PLUGINS=1 build/test_plugins", path);
        free(have);
    }
    free(text);
}

int main(void)
{
    spc_warn_set_quiet(1);
    RUN(every_plugin_is_as_listed);
    RUN(unread_plugins_are_named);
    RUN(unknown_type_lists_the_table);
    RUN(own_properties_as_defaults);
    RUN(plugins_md_is_generated);
    return spc_test_finish();
}
