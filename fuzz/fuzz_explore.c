/*
 * fuzz/fuzz_explore.c: libFuzzer harness for the solver explorer's request handling
 * (spc_explore_handle, src/explore/): the first byte picks the path (solve, lossmap, scene, or a
 * bad one) and the method, the rest is the request body, against a small caustic scene (a glass
 * ball and a mirror disk over a floor, a sphere light) built once from the string below. Every
 * answer must be JSON text with a status in 200..599; a crash, leak, sanitizer report or an answer
 * that breaks that is the finding. Built with -DSPC_FUZZ=ON (clang); run by fuzz/run.sh.
 */
#include "fuzz_targets.h"

#include "explore/json.h"

static const char scene_xml[] =
    "<scene version='3.0.0'>"
    "<sensor type='perspective'><float name='fov' value='40'/>"
    "<transform name='to_world'><lookat origin='0,2,3' target='0,0.3,0' up='0,1,0'/></transform>"
    "<film type='hdrfilm'><integer name='width' value='8'/><integer name='height' value='8'/></film></sensor>"
    "<shape type='sphere'><point name='center' x='-0.8' y='2' z='-0.5'/><float name='radius' value='0.1'/>"
    "<emitter type='area'><rgb name='radiance' value='50,50,50'/></emitter></shape>"
    "<shape type='rectangle'><transform name='to_world'><scale value='2'/><rotate x='1' angle='-90'/></transform>"
    "<bsdf type='diffuse'/></shape>"
    "<shape type='sphere'><point name='center' x='0' y='0.4' z='0'/><float name='radius' value='0.4'/>"
    "<bsdf type='dielectric'/></shape>"
    "<shape type='disk'><transform name='to_world'><scale value='0.3'/><rotate y='1' angle='60'/>"
    "<translate x='0.9' y='0.4'/></transform><bsdf type='conductor'/></shape>"
    "</scene>";

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static spc_scene *sc = NULL;
    static spc_explorer *ex = NULL;
    if (!ex) {
        spc_warn_set_quiet(1);
        spc_error err;
        if (spc_mitsuba_load_string(scene_xml, sizeof scene_xml - 1, "fuzz_explore.xml", spc_fuzz_empty_dir(), NULL, 0,
                                    &sc, &err) != SPC_OK ||
            !(ex = spc_explore_create(sc)))
            abort(); /* the harness's own scene must load */
    }
    if (size < 1)
        return 0;
    static const char *const paths[] = {"/api/solve", "/api/lossmap", "/api/scene", "/api/../x"};
    const char *path = paths[data[0] & 3];
    const char *method = (data[0] & 4) ? "GET" : "POST";
    if (data[0] & 8)
        path = paths[0]; /* most inputs exercise the solve */
    char *resp = NULL;
    int st = spc_explore_handle(ex, method, path, (const char *)data + 1, size - 1, &resp);
    if (st < 200 || st > 599 || (st != 500 && !resp))
        abort();
    if (resp) {
        spc_json_doc d;
        char msg[128];
        if (!spc_json_parse(resp, strlen(resp), &d, msg, sizeof msg))
            abort(); /* an answer that is not JSON */
        spc_json_doc_release(&d);
    }
    free(resp);
    return 0;
}
