/*
 * tests/test_path_wave.c: the packet path tracer (integrator/path_wave.c) gives path.c's image bit
 * for bit.
 *
 * Each scene is rendered twice through the public API, once with the driver's default (the packet
 * path tracer wherever it applies) and once with SPECULA_PATH_WAVE=0 (path.c's one path at a time),
 * and the EXRs (RGB, variance, AOVs) are compared byte for byte. The scenes cover what the packets
 * must get right: triangles and Embree's curves, analytic shapes as user geometry in double
 * (spheres, disks, cylinders, SDFs), smooth and rough glass and metals, an environment map, point,
 * spot and area lights, a thin lens, Russian roulette past max_depth, and the ipt mode. The
 * packet path tracer's sample count proves it ran (and that the other render did not use it); a
 * scene with Embree's curves, whose packet hits differ from single rays', must not take it. Embree
 * is also forced to AVX2 and SSE4.2, where its 16-wide packets take a fallback path (which aborted
 * on inactive lanes before they were marked by their ray data), and the packets to 8 and 16 lanes. The wave's light samples, computed
 * for many lanes at once, and its diffuse lobe without bsdf.c's dispatch are compared with the
 * one-lane ones field by field (the light samples under every instruction set).
 */
/* ctest-labels: scene */
/* ctest-timeout: 300 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bsdf/diffuse_view.h"
#include "core/rng.h"
#include "emitter/emitter.h"
#include "file_util.h"
#include "harness.h"
#include "integrator/path_wave.h"
#include "io/mitsuba_xml.h"
#include "lanes.h"
#include "scene/scene.h"
#include "scene/shape.h"
#include "specula/specula.h"

#define RES "24"
#define SPP 4

static char tmpdir[64];
static char scenes_dir[2048];

/* Renders sc with the integrator and max_depth given, the packet path tracer on or off; writes an
 * EXR with variance and AOVs to out. The samples the packet path tracer took go to *wave. */
static bool render_to(spc_scene *sc, const char *integrator, int max_depth, bool packets, const char *out,
                      uint64_t *wave)
{
    setenv("SPECULA_PATH_WAVE", packets ? "1" : "0", 1);
    spc_render_options o;
    spc_render_options_init(&o);
    o.integrator = integrator;
    o.specular_nee = "none";
    o.spp = SPP;
    o.seed = 7;
    o.threads = 2;
    o.aovs = true;
    o.max_depth = max_depth;
    spc_film *film = NULL;
    spc_error err;
    uint64_t w0 = spc_path_wave_samples();
    spc_status st = spc_render(sc, &o, &film, NULL, &err);
    *wave = spc_path_wave_samples() - w0;
    bool ok = st == SPC_OK && film && spc_film_write_exr(film, out, true, &err) == SPC_OK;
    if (!ok)
        printf("  %s: %s\n", out, err.msg);
    spc_film_destroy(film);
    unsetenv("SPECULA_PATH_WAVE");
    return ok;
}

/* One scene file of scenes/ with one integrator: the two renders agree byte for byte; the packet
 * path tracer ran in the first (unless `packets` is false: a scene it must not take). */
static void check_scene_packets(const char *file, const char *integrator, int max_depth, bool packets)
{
    char path[2300];
    /* a file of scenes/, or an absolute path */
    snprintf(path, sizeof path, "%s%s%s", file[0] == '/' ? "" : scenes_dir, file[0] == '/' ? "" : "/", file);
    spc_define defs[1] = {{"res", RES}};
    spc_scene *sc = NULL;
    spc_error err;
    /* scenes without a "res" default are loaded as they are */
    if (spc_scene_load(path, defs, 1, &sc, &err) != SPC_OK && spc_scene_load(path, NULL, 0, &sc, &err) != SPC_OK) {
        CHECK_MSG(false, "%s: %s", file, err.msg);
        return;
    }
    char a[128], b[128];
    snprintf(a, sizeof a, "%s/packets.exr", tmpdir);
    snprintf(b, sizeof b, "%s/single.exr", tmpdir);
    uint64_t wa = 0, wb = 0;
    bool ok = render_to(sc, integrator, max_depth, true, a, &wa) && render_to(sc, integrator, max_depth, false, b, &wb);
    CHECK_MSG(ok, "%s (%s): render failed", file, integrator);
    CHECK_MSG((wa > 0) == packets && wb == 0, "%s (%s): packet samples %llu and %llu", file, integrator,
              (unsigned long long)wa, (unsigned long long)wb);
    CHECK_MSG(ok && same_file(a, b), "%s (%s, max_depth %d): the packet path tracer's image differs from path.c's",
              file, integrator, max_depth);
    spc_scene_destroy(sc);
}

static void check_scene(const char *file, const char *integrator, int max_depth)
{
    check_scene_packets(file, integrator, max_depth, true);
}

TEST(path_matches_path_c)
{
    const char *files[] = {"demo.xml",           "shapes.xml",    "dielectrics.xml", "conductors.xml",
                           "envmap.xml",         "lights.xml",    "textures.xml",    "thinlens.xml",
                           "sdf_shapes_csg.xml", "mask_null.xml", "normal_bump.xml", "spot_texture.xml"};
    const int nfiles = (int)(sizeof files / sizeof files[0]);
    for (int i = 0; i < nfiles; i += spc_test_stride(nfiles))
        check_scene(files[i], "path", 0);
    /* Embree's curves: path.c's single rays (their packet hits differ) */
    check_scene_packets("curves.xml", "path", 0, false);
}

/* path.c's options that end paths or hide light: strict normals (shapes.xml's meshes with vertex
 * normals, where shading and geometric normals disagree: the option changes its image) and hidden
 * emitters, in a copy of shapes.xml with its mesh and texture paths made absolute. */
TEST(strict_normals_and_hidden_emitters_match_path_c)
{
    char src[2300], dst[128];
    snprintf(src, sizeof src, "%s/shapes.xml", scenes_dir);
    snprintf(dst, sizeof dst, "%s/strict.xml", tmpdir);
    long n = 0;
    char *text = (char *)slurp(src, &n);
    FILE *fp = text ? fopen(dst, "w") : NULL;
    CHECK(fp != NULL);
    if (!fp) {
        free(text);
        return;
    }
    static const char integ[] = "<integrator type=\"$integrator\">";
    static const char *const dirs[] = {"value=\"meshes/", "value=\"textures/"};
    int edits = 0;
    for (long i = 0; i < n; ++i) {
        if (strncmp(text + i, integ, sizeof integ - 1) == 0) {
            fprintf(fp, "%s<boolean name=\"strict_normals\" value=\"true\"/>"
                        "<boolean name=\"hide_emitters\" value=\"true\"/>",
                    integ);
            i += (long)sizeof integ - 2;
            ++edits;
            continue;
        }
        bool done = false;
        for (int d = 0; d < 2 && !done; ++d)
            if (strncmp(text + i, dirs[d], strlen(dirs[d])) == 0) {
                fprintf(fp, "value=\"%s/%s", scenes_dir, dirs[d] + 7);
                i += (long)strlen(dirs[d]) - 1;
                done = true;
            }
        if (!done)
            fputc(text[i], fp);
    }
    fclose(fp);
    free(text);
    CHECK(edits == 1);
    check_scene(dst, "path", 0);
}

/* Embree's packets on other instruction sets: a CPU without native 16-wide packets (AVX2, SSE4.2)
 * runs them through another code path (which tells inactive lanes by their ray data). */
TEST(other_isas_match_path_c)
{
    const char *isas[] = {"isa=avx2", "isa=sse4.2"};
    for (int k = 0; k < 2; ++k) {
        setenv("SPECULA_EMBREE_CONFIG", isas[k], 1);
        check_scene("demo.xml", "path", 0);
        check_scene("shapes.xml", "path", 0);
        unsetenv("SPECULA_EMBREE_CONFIG");
    }
}

/* The packets at both widths (SPECULA_PACKET_WIDTH), whichever is native here: 8-wide packets on an
 * AVX-512 host and 16-wide ones on an AVX2 host are not native and take Embree's other code paths. */
TEST(both_packet_widths_match_path_c)
{
    const char *widths[] = {"8", "16"};
    for (int k = 0; k < 2; ++k) {
        setenv("SPECULA_PACKET_WIDTH", widths[k], 1);
        check_scene("demo.xml", "path", 0);
        check_scene("shapes.xml", "path", 0);
        unsetenv("SPECULA_PACKET_WIDTH");
    }
}

TEST(ipt_and_roulette_match_path_c)
{
    check_scene("demo.xml", "ipt", 0);
    check_scene("dielectrics.xml", "ipt", 0);
    /* unbounded depth: Russian roulette ends every path */
    check_scene("demo.xml", "path", -1);
    check_scene("envmap.xml", "path", 3);
    /* max_depth up to rr_depth: the wave's lanes run in lockstep (path_wave.c) */
    check_scene("demo.xml", "path", 2);
    check_scene("demo.xml", "path", 5);
    check_scene("dielectrics.xml", "ipt", 4);
}

/* The wave's light samples (spc_emitter_sample_direct_many: mesh lights in vector form, others one
 * lane at a time) equal spc_emitter_sample_direct's in every field and in their result, for
 * reference points all around the lights (behind them, on their plane, far away): two rectangles
 * (each sampled as one parallelogram; the second flipped: batches of lanes on both lights and on
 * one), a flipped cube (the normal flipped), and the first rectangle through the triangle pick with
 * its kept normals and without them (computed from the edges), which the vector form covers; a
 * sphere and a rectangle with a checkerboard radiance, which it does not. */
static const char *many_xml =
    "<scene version='3.0.0'>"
    "<shape type='rectangle'><transform name='to_world'><scale value='0.7,0.4,1'/><rotate x='1' angle='30'/>"
    "<translate value='0.2,1.5,-0.3'/></transform><emitter type='area'><rgb name='radiance' value='3,2,1'/>"
    "</emitter></shape>"
    "<shape type='cube'><boolean name='flip_normals' value='true'/><transform name='to_world'>"
    "<scale value='0.3'/><translate value='-1,0.5,0.5'/></transform><emitter type='area'>"
    "<rgb name='radiance' value='1,1,2'/></emitter></shape>"
    "<shape type='sphere'><point name='center' value='1,0,1'/><float name='radius' value='0.25'/>"
    "<emitter type='area'><rgb name='radiance' value='2,2,2'/></emitter></shape>"
    "<shape type='rectangle'><transform name='to_world'><rotate y='1' angle='70'/><translate value='1.5,0.3,0'/>"
    "</transform><emitter type='area'><texture type='checkerboard' name='radiance'/></emitter></shape>"
    "<shape type='rectangle'><boolean name='flip_normals' value='true'/><transform name='to_world'>"
    "<scale value='0.5,0.9,1'/><rotate z='1' angle='20'/><rotate x='1' angle='-40'/><translate value='-0.6,-0.4,0.8'/>"
    "</transform><emitter type='area'><rgb name='radiance' value='1,3,2'/></emitter></shape>"
    "</scene>";

/* A lane's reference point: anywhere around the lights, or (every ninth lane on a mesh light) a point
 * on the light itself (its plane: no sample). */
static int many_setup(void *ctx, int i, const spc_emitter *e, spc_rng *rng, spc_vec3 *ref, spc_vec2 *u)
{
    (void)ctx;
    *ref = spc_v3(4.0 * spc_rng_next(rng) - 2.0, 4.0 * spc_rng_next(rng) - 1.0, 4.0 * spc_rng_next(rng) - 2.0);
    if (i % 9 == 4 && e && e->shape->type == SPC_SHAPE_MESH) {
        spc_shape_sample ss;
        spc_shape_sample_area(e->shape, spc_v2(0.3, 0.6), &ss);
        *ref = ss.p;
    }
    *u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    return 0;
}

/* Counts the samples that went through the vector form. */
static void many_tally(void *ctx, const spc_emitter *e, spc_vec3 ref, int tag, bool ok_many, bool ok_one)
{
    (void)ref, (void)tag, (void)ok_one;
    *(int *)ctx += spc_emitter_many_covers(e) && ok_many;
}

static void check_many(const spc_scene *sc, int *covered, int *failed)
{
    lanes_direct_hooks hk = {many_setup, many_tally, covered};
    *failed += lanes_check_direct(sc, 11, 3, 200, &hk);
}

TEST(light_samples_many_match_one_at_a_time)
{
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_mitsuba_load_string(many_xml, strlen(many_xml), "many.xml", NULL, NULL, 0, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    CHECK(sc->nemitters == 5);
    int ncover = 0;
    for (int k = 0; k < sc->nemitters; ++k)
        ncover += spc_emitter_many_covers(sc->emitters[k]);
    CHECK_MSG(ncover == 3, "%d lights covered by the vector form, expected the rectangles and the cube", ncover);
    CHECK(sc->emitters[4]->shape->has_para);
    int covered = 0, failed = 0;
    check_many(sc, &covered, &failed);
    CHECK_MSG(failed == 0, "%d light samples differ", failed);
    CHECK_MSG(covered > 500, "only %d samples through the vector form", covered);
    /* the rectangle through the triangle pick, with its kept normals and without them (its normal
     * from the edges) */
    spc_shape *rect = (spc_shape *)sc->emitters[0]->shape;
    CHECK(rect->type == SPC_SHAPE_MESH && rect->tri_frame != NULL && rect->has_para);
    rect->has_para = false;
    covered = failed = 0;
    check_many(sc, &covered, &failed);
    CHECK_MSG(failed == 0, "%d light samples differ through the triangle pick", failed);
    CHECK(covered > 500);
    double *kept = rect->tri_frame;
    rect->tri_frame = NULL;
    covered = failed = 0;
    check_many(sc, &covered, &failed);
    CHECK_MSG(failed == 0, "%d light samples differ without the kept normals", failed);
    CHECK(covered > 500);
    rect->tri_frame = kept;
    rect->has_para = true;
    spc_scene_destroy(sc);
}

/* The wave's diffuse view (bsdf/diffuse_view.h) gives spc_bsdf_eval's, spc_bsdf_pdf's and
 * spc_bsdf_sample_dir's values bit for bit: diffuse with a constant, a default and a checkerboard
 * reflectance; twosided diffuse (the back side through a flipped frame), twosided with two
 * diffuse sides, and twosided with a conductor behind (a view on the front only); directions on
 * both sides and on the horizon. A conductor has no view. */
static const char *view_xml =
    "<scene version='3.0.0'>"
    "<shape type='rectangle'><bsdf type='diffuse'><rgb name='reflectance' value='0.2,0.5,0.7'/></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='diffuse'/></shape>"
    "<shape type='rectangle'><bsdf type='diffuse'><texture type='checkerboard' name='reflectance'/></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='twosided'><bsdf type='diffuse'><rgb name='reflectance' value='0.3'/>"
    "</bsdf></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='twosided'><bsdf type='diffuse'><rgb name='reflectance' value='0.3'/>"
    "</bsdf><bsdf type='diffuse'><rgb name='reflectance' value='0.6,0.1,0.1'/></bsdf></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='twosided'><bsdf type='diffuse'/><bsdf type='conductor'/></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='conductor'/></shape>"
    "</scene>";

/* Views seen, how many of them on a back side, and how many were also made from the shape's
 * constant sides (spc_shape.diffuse_const). */
typedef struct view_counts {
    const spc_scene *sc;
    int views, back, consts;
} view_counts;

/* One round of diffuse_view_matches_bsdf: the view's eval, pdf and sample against the BSDF's. */
static bool view_round(void *ctx, int round, const spc_bsdf *b, spc_hit *h, spc_vec3 wo, spc_rng *rng, bool loud)
{
    view_counts *c = (view_counts *)ctx;
    spc_vec3 wi = spc_warp_uniform_sphere(spc_v2(spc_rng_next(rng), spc_rng_next(rng)));
    if (round % 50 == 7)
        wo = h->sh.s; /* on the horizon */
    if (round % 50 == 9)
        wi = h->sh.t;
    spc_vec2 u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    spc_diffuse_view v;
    const spc_shape *shape = c->sc->shapes[round % c->sc->nshapes];
    if (!spc_diffuse_view_of(b, h, wo, &v)) {
        /* no view: neither diffuse nor a twosided side that is */
        bool plain = b->type == SPC_BSDF_DIFFUSE;
        bool twosided_diffuse =
            b->type == SPC_BSDF_TWOSIDED && spc_dot(wo, h->sh.n) >= 0.0 && b->nested[0]->type == SPC_BSDF_DIFFUSE;
        return !(plain || twosided_diffuse) && !shape->diffuse_const;
    }
    ++c->views;
    c->back += v.sign < 0.0;
    if (shape->diffuse_const) {
        /* the path wave's view of a constant-reflectance shape: the same bytes */
        int side = spc_diffuse_view_side(h, wo);
        spc_diffuse_view k;
        spc_diffuse_view_make(h, shape->diffuse_sign[side], shape->diffuse_albedo[side], &k);
        ++c->consts;
        if (memcmp(&k, &v, sizeof k) != 0) {
            if (loud)
                printf("  round %d: the constant sides' view differs (side %d)\n", round, side);
            return false;
        }
    }
    spc_rgb f1 = spc_diffuse_view_eval(&v, h, wo, wi), f0 = spc_bsdf_eval(b, h, SPC_MODE_RADIANCE, wo, wi);
    double p1 = spc_diffuse_view_pdf(&v, h, wo, wi), p0 = spc_bsdf_pdf(b, h, SPC_MODE_RADIANCE, wo, wi);
    spc_bsdf_sample s1, s0;
    memset(&s1, 0, sizeof s1);
    memset(&s0, 0, sizeof s0);
    bool ok1 = spc_diffuse_view_sample(&v, h, wo, u, &s1);
    bool ok0 = spc_bsdf_sample_dir(b, h, SPC_MODE_RADIANCE, wo, 0.5, u, &s0);
    bool same = memcmp(&f1, &f0, sizeof f1) == 0 && memcmp(&p1, &p0, sizeof p1) == 0 && ok1 == ok0 &&
                (!ok0 || (memcmp(&s1.wi, &s0.wi, sizeof s1.wi) == 0 &&
                          memcmp(&s1.weight, &s0.weight, sizeof s1.weight) == 0 &&
                          memcmp(&s1.pdf, &s0.pdf, sizeof s1.pdf) == 0 && s1.lobe == s0.lobe && s1.eta == s0.eta));
    if (!same && loud)
        printf("  round %d (sign %g): eval %g/%g pdf %g/%g sample %d/%d\n", round, v.sign, f1.r, f0.r, p1, p0, ok1,
               ok0);
    return same;
}

/* The same under every instruction set the light samples' loops are compiled for (SPECULA_VECTOR_ISA
 * caps the one a process picks, so each runs in a child process of this program). */
TEST(light_samples_many_every_isa)
{
    const char *const isas[] = {"base", "avx2", "avx512"};
    spc_t_under_isas("light_samples_many_match_one_at_a_time", isas, 3);
}

TEST(diffuse_view_matches_bsdf)
{
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_mitsuba_load_string(view_xml, strlen(view_xml), "view.xml", NULL, NULL, 0, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    CHECK(sc->nshapes == 7);
    /* constant on both sides: the constant and default diffuse, the two twosided diffuse ones */
    const bool consts[7] = {true, true, false, true, true, false, false};
    for (int i = 0; i < 7 && i < sc->nshapes; ++i)
        CHECK_MSG(sc->shapes[i]->diffuse_const == consts[i], "shape %d: diffuse_const %d", i,
                  sc->shapes[i]->diffuse_const);
    view_counts c = {sc, 0, 0, 0};
    int failed = lanes_check_bsdfs(sc, 5, 1, 4000, view_round, &c);
    CHECK_MSG(failed == 0, "%d of %d diffuse views differ from the BSDF", failed, c.views);
    CHECK_MSG(c.views > 2000 && c.back > 500 && c.consts > 1500, "%d views, %d of them on a back side, %d constant",
              c.views, c.back, c.consts);
    spc_scene_destroy(sc);
}

/* A mesh too big for kept per-triangle frames (more than SPC_MESH_FRAME_MAX_TRIS triangles), with
 * vertex normals and uvs: its packets prefetch the hits' index triples and vertices before filling
 * them, and the image stays path.c's. The mesh is a bumpy height field written as a binary PLY. */
TEST(big_mesh_prefetch_matches_path_c)
{
    enum { K = 200 }; /* K x K vertices, 2 (K - 1)^2 = 79,202 triangles */
    char ply[128], xml[128];
    snprintf(ply, sizeof ply, "%s/grid.ply", tmpdir);
    snprintf(xml, sizeof xml, "%s/grid.xml", tmpdir);
    FILE *fp = fopen(ply, "wb");
    CHECK(fp != NULL);
    if (!fp)
        return;
    fprintf(fp, "ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                "property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\n"
                "property float v\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n",
            K * K, (K - 1) * (K - 1));
    for (int j = 0; j < K; ++j)
        for (int i = 0; i < K; ++i) {
            float x = -1.0f + 2.0f * (float)i / (K - 1), z = -1.0f + 2.0f * (float)j / (K - 1);
            float y = 0.05f * (float)(((i * 7 + j * 13) % 11) - 5) / 5.0f;
            float nl = 1.0f / sqrtf(1.0f + 0.01f * (float)((i + j) % 5));
            float v[8] = {x, y, z, 0.1f * (float)((i % 3) - 1) * nl, nl, 0.1f * (float)((j % 3) - 1) * nl,
                          (float)i / (K - 1), (float)j / (K - 1)};
            fwrite(v, sizeof v, 1, fp);
        }
    for (int j = 0; j + 1 < K; ++j)
        for (int i = 0; i + 1 < K; ++i) {
            unsigned char four = 4;
            int32_t q[4] = {j * K + i, (j + 1) * K + i, (j + 1) * K + i + 1, j * K + i + 1};
            fwrite(&four, 1, 1, fp);
            fwrite(q, sizeof q, 1, fp);
        }
    fclose(fp);
    fp = fopen(xml, "w");
    CHECK(fp != NULL);
    if (!fp)
        return;
    fprintf(fp, "<scene version=\"3.0.0\"><default name=\"res\" value=\"24\"/>"
                "<integrator type=\"path\"><integer name=\"max_depth\" value=\"4\"/></integrator>"
                "<sensor type=\"perspective\"><float name=\"fov\" value=\"50\"/>"
                "<transform name=\"to_world\"><lookat origin=\"0, 1.6, 2.2\" target=\"0, 0, 0\" up=\"0, 1, 0\"/>"
                "</transform><film type=\"hdrfilm\"><integer name=\"width\" value=\"$res\"/>"
                "<integer name=\"height\" value=\"$res\"/></film></sensor>"
                "<shape type=\"ply\"><string name=\"filename\" value=\"%s\"/>"
                "<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\"/></bsdf></shape>"
                "<shape type=\"rectangle\"><transform name=\"to_world\"><rotate x=\"1\" angle=\"90\"/>"
                "<translate y=\"1.5\"/></transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"4\"/>"
                "</emitter></shape></scene>",
            ply);
    fclose(fp);
    spc_scene *sc = NULL;
    spc_error err;
    CHECK_MSG(spc_scene_load(xml, NULL, 0, &sc, &err) == SPC_OK, "%s", err.msg);
    if (!sc)
        return;
    CHECK(sc->prefetch_hits);
    CHECK(sc->nshapes >= 1 && sc->shapes[0]->type == SPC_SHAPE_MESH && !sc->shapes[0]->tri_frame &&
          sc->shapes[0]->mesh.ntris == 2 * (K - 1) * (K - 1) && sc->shapes[0]->mesh.n && sc->shapes[0]->mesh.uv);
    spc_scene_destroy(sc);
    check_scene(xml, "path", 0);
}

int main(void)
{
    char cwd[1024];
    if (!getcwd(cwd, sizeof cwd))
        return 1;
    const char *src = spc_test_source_dir();
    snprintf(scenes_dir, sizeof scenes_dir, "%s%s%s/scenes", src[0] == '/' ? "" : cwd, src[0] == '/' ? "" : "/", src);
    snprintf(tmpdir, sizeof tmpdir, "/tmp/spc_path_wave_XXXXXX");
    if (!mkdtemp(tmpdir))
        return 1;
    RUN(light_samples_many_match_one_at_a_time);
    RUN(light_samples_many_every_isa);
    RUN(diffuse_view_matches_bsdf);
    RUN(path_matches_path_c);
    RUN(ipt_and_roulette_match_path_c);
    RUN(other_isas_match_path_c);
    RUN(both_packet_widths_match_path_c);
    RUN(strict_normals_and_hidden_emitters_match_path_c);
    RUN(big_mesh_prefetch_matches_path_c);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", tmpdir);
    if (system(cmd) != 0)
        printf("could not remove %s\n", tmpdir);
    return spc_test_finish();
}
