/*
 * tests/test_explore.c: the solver explorer's API handlers (explore/explore.c) without HTTP: the
 * JSON reader on good and bad text; a solve equals the solvers' own results on the same inputs
 * (angular: the same chain bit for bit and the same iteration count as spc_angular_solve without
 * the observer; Newton: spc_newton_solve_one with the straight-line seed; exact: the sphere
 * enumeration), the analytic gradient agrees with the finite difference at every iterate; the
 * loss map's shape; bad requests get 4xx with a message.
 */
/* ctest-labels: unit */
#include <string.h>

#include "core/rng.h"
#include "explore/explore.h"
#include "explore/json.h"
#include "harness.h"
#include "manifold/angular.h"
#include "manifold/specular_nee.h"
#include "manifold/sphere_chains.h"
#include "scene/scene.h"

static spc_scene *load(const char *name)
{
    char path[1024];
    const char *root = getenv("SPC_SOURCE_DIR");
    snprintf(path, sizeof path, "%s/scenes/%s", root ? root : ".", name);
    spc_scene *sc = NULL;
    spc_error err;
    if (spc_scene_load(path, NULL, 0, &sc, &err) != SPC_OK) {
        char buf[2048];
        spc_error_format(&err, buf, (int)sizeof buf);
        printf("  cannot load %s: %s\n", path, buf);
        return NULL;
    }
    return sc;
}

/* Calls the handler and parses its answer (which must be JSON whatever the status). */
static int call(spc_explorer *ex, const char *method, const char *path, const char *body, spc_json_doc *doc)
{
    char *resp = NULL;
    int st = spc_explore_handle(ex, method, path, body, body ? strlen(body) : 0, &resp);
    char msg[256];
    bool ok = resp && spc_json_parse(resp, strlen(resp), doc, msg, sizeof msg);
    if (!ok) {
        printf("  response not JSON (%d): %.200s\n", st, resp ? resp : "(null)");
        st = -1;
    }
    free(resp);
    return st;
}

static const spc_json *path_get(const spc_json_doc *d, const char *a, int k, const char *b)
{
    const spc_json *x = spc_json_get(d, &d->nodes[0], a);
    if (k >= 0)
        x = spc_json_at(d, x, k);
    return b ? spc_json_get(d, x, b) : x;
}

static spc_vec3 jv3(const spc_json_doc *d, const spc_json *a)
{
    return spc_v3(spc_json_at(d, a, 0)->num, spc_json_at(d, a, 1)->num, spc_json_at(d, a, 2)->num);
}

TEST(json_reader)
{
    spc_json_doc d;
    char msg[256];
    const char *good = "{\"a\": [1, -2.5e3, true, null, \"x\\\"\\u0041\"], \"b\": {\"c\": {}}}";
    CHECK(spc_json_parse(good, strlen(good), &d, msg, sizeof msg));
    const spc_json *a = spc_json_get(&d, &d.nodes[0], "a");
    CHECK(a && a->type == SPC_JSON_ARRAY && a->count == 5);
    CHECK(spc_json_at(&d, a, 1)->num == -2500.0);
    CHECK(spc_json_at(&d, a, 2)->type == SPC_JSON_BOOL && spc_json_at(&d, a, 2)->num == 1.0);
    CHECK(spc_json_at(&d, a, 3)->type == SPC_JSON_NULL);
    CHECK(!strcmp(spc_json_at(&d, a, 4)->str, "x\"A"));
    CHECK(spc_json_get(&d, spc_json_get(&d, &d.nodes[0], "b"), "c")->type == SPC_JSON_OBJECT);
    spc_json_doc_release(&d);
    const char *bad[] = {"",      "{",     "{\"a\":}",    "[1,]",
                         "01",    "1e999", "\"abc",       "{\"a\":1} x",
                         "[1 2]", "tru",   "\"\\u00e9\"", "[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]",
                         "-",     "1.",    "{1:2}"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        msg[0] = '\0';
        bool ok = spc_json_parse(bad[i], strlen(bad[i]), &d, msg, sizeof msg);
        CHECK_MSG(!ok && strstr(msg, "malformed JSON at byte"), "'%s' accepted", bad[i]);
        spc_json_doc_release(&d);
    }
}

/* A receiver under the glass ball of caustic_glass_sphere.xml, in its caustic. */
#define RX_REQ "\"receiver\":{\"origin\":[0.2,0.05,0.14],\"direction\":[0,-1,0]}"

TEST(scene_json)
{
    spc_scene *sc = load("caustic_glass_sphere.xml");
    CHECK(sc);
    if (!sc)
        return;
    spc_explorer *ex = spc_explore_create(sc);
    spc_json_doc d;
    CHECK(call(ex, "GET", "/api/scene", NULL, &d) == 200);
    const spc_json *shapes = path_get(&d, "shapes", -1, NULL);
    CHECK(shapes && shapes->count == sc->nshapes);
    int spheres = 0, specular = 0;
    for (int i = 0; shapes && i < shapes->count; ++i) {
        const spc_json *s = spc_json_at(&d, shapes, i);
        spheres += !strcmp(spc_json_get(&d, s, "type")->str, "sphere");
        specular += spc_json_get(&d, s, "specular")->num == 1.0;
    }
    CHECK(spheres == 2 && specular == 1);
    CHECK(path_get(&d, "camera", -1, "fov")->num == 35.0);
    spc_json_doc_release(&d);
    spc_explore_destroy(ex);
    spc_scene_destroy(sc);
}

TEST(angular_solve_equals_solver)
{
    spc_scene *sc = load("caustic_glass_sphere.xml");
    if (!sc) {
        CHECK(sc);
        return;
    }
    spc_explorer *ex = spc_explore_create(sc);
    spc_json_doc d;
    CHECK(call(ex, "POST", "/api/solve", "{" RX_REQ ",\"solver\":\"angular\",\"max_chain\":2}", &d) == 200);
    const spc_json *run = path_get(&d, "runs", 0, NULL);
    CHECK(run && spc_json_get(&d, run, "success")->num == 1.0);
    int iters = (int)spc_json_get(&d, run, "iterations")->num;
    const spc_json *its = spc_json_get(&d, run, "iterates");
    CHECK(its && its->count == iters); /* the seed and every trial step */

    /* the same problem by hand: the hit, the light point (light_sample 0), the straight seed */
    spc_ray ray = {spc_v3(0.2, 0.05, 0.14), spc_v3(0, -1, 0), 0.0, INFINITY};
    spc_hit x;
    CHECK(spc_scene_intersect(sc, &ray, &x));
    spc_snee_params p;
    spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 2);
    spc_snee_query q;
    spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 1, 0), 2);
    spc_rng rng;
    spc_rng_seed(&rng, 0, 0x11);
    const spc_emitter *e;
    spc_vec2 uv;
    double p_y;
    bool found = false;
    for (int k = 0; k < 64 && !found; ++k)
        found = spc_snee_sample_light(sc, false, &rng, &q, &e, &uv, &p_y);
    CHECK(found);
    spc_vec3 y = jv3(&d, path_get(&d, "light", -1, "point"));
    CHECK(y.x == q.y.x && y.y == q.y.y && y.z == q.y.z);
    spc_angular_target tg = {q.y, q.ny, sc->radius, q.light_size};
    spc_angular_options ao;
    spc_angular_options_default(&ao);
    spc_chain_opts o = spc_chain_opts_default(2);
    spc_chain c;
    spc_angular_result res;
    bool ok = spc_angular_solve(sc, &x, &tg, spc_normalize(spc_sub(q.y, x.p)), &o, &ao, &c, &res);
    CHECK(ok && res.iterations == iters && c.n == 2);
    const spc_json *sol = spc_json_at(&d, spc_json_get(&d, run, "solutions"), 0);
    const spc_json *pts = spc_json_get(&d, sol, "points");
    CHECK(pts && pts->count == c.n + 2);
    for (int i = 0; pts && i < c.n; ++i) {
        spc_vec3 v = jv3(&d, spc_json_at(&d, pts, i + 1));
        CHECK_MSG(v.x == c.v[i].h.p.x && v.y == c.v[i].h.p.y && v.z == c.v[i].h.p.z, "vertex %d differs", i);
    }
    double G = spc_chain_geometry(&c, q.y, q.ny);
    CHECK(spc_json_get(&d, sol, "G")->num == G && G > 0.0);
    CHECK(spc_json_at(&d, spc_json_get(&d, sol, "contribution"), 0)->num > 0.0);
    /* analytic against finite-difference gradient at every accepted iterate */
    int compared = 0;
    for (int i = 0; its && i < its->count; ++i) {
        const spc_json *it = spc_json_at(&d, its, i);
        const spc_json *g = spc_json_get(&d, it, "grad"), *gf = spc_json_get(&d, it, "grad_fd");
        if (!g)
            continue;
        double g0 = spc_json_at(&d, g, 0)->num, g1 = spc_json_at(&d, g, 1)->num;
        double f0 = spc_json_at(&d, gf, 0)->num, f1 = spc_json_at(&d, gf, 1)->num;
        double L = spc_json_get(&d, it, "loss")->num;
        double gn = sqrt(g0 * g0 + g1 * g1);
        if (L < 1e-16)
            continue; /* at the solution both are rounding noise */
        ++compared;
        CHECK_MSG(hypot(g0 - f0, g1 - f1) <= 1e-4 * gn, "iterate %d: grad (%g, %g) fd (%g, %g)", i, g0, g1, f0, f1);
    }
    CHECK(compared >= 2);
    spc_json_doc_release(&d);
    spc_explore_destroy(ex);
    spc_scene_destroy(sc);
}

TEST(newton_and_exact_equal_solvers)
{
    spc_scene *sc = load("caustic_glass_sphere.xml");
    if (!sc) {
        CHECK(sc);
        return;
    }
    spc_explorer *ex = spc_explore_create(sc);
    spc_json_doc d;
    CHECK(call(ex, "POST", "/api/solve", "{" RX_REQ ",\"solver\":\"all\"}", &d) == 200);
    const spc_json *runs = path_get(&d, "runs", -1, NULL);
    CHECK(runs && runs->count == 4);
    spc_ray ray = {spc_v3(0.2, 0.05, 0.14), spc_v3(0, -1, 0), 0.0, INFINITY};
    spc_hit x;
    CHECK(spc_scene_intersect(sc, &ray, &x));
    spc_snee_params p;
    spc_snee_params_default(&p, SPC_SNEE_NEWTON, 2);
    spc_snee_query q;
    spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 1, 0), 2);
    spc_rng rng;
    spc_rng_seed(&rng, 0, 0x11);
    const spc_emitter *e;
    spc_vec2 uv;
    double p_y;
    bool found = false;
    for (int k = 0; k < 64 && !found; ++k)
        found = spc_snee_sample_light(sc, false, &rng, &q, &e, &uv, &p_y);
    CHECK(found);
    q.seed = SPC_SNEE_SEED_LIGHT;
    spc_chain c;
    int it = 0;
    bool ok = spc_newton_solve_one(&q, NULL, &c, &it);
    const spc_json *nr = spc_json_at(&d, runs, 1);
    CHECK(!strcmp(spc_json_get(&d, nr, "solver")->str, "newton"));
    CHECK(ok && spc_json_get(&d, nr, "success")->num == 1.0 && (int)spc_json_get(&d, nr, "iterations")->num == it);
    /* Newton's iterates: the seed path, then projected steps, the constraints falling to ~0 */
    const spc_json *nits = spc_json_get(&d, nr, "iterates");
    CHECK(nits && nits->count >= 2);
    double E0 = spc_json_get(&d, spc_json_at(&d, nits, 0), "constraints")->num, Elast = E0;
    for (int i = 0; nits && i < nits->count; ++i) {
        const spc_json *ni = spc_json_at(&d, nits, i);
        if (spc_json_get(&d, ni, "accepted")->num == 1.0)
            Elast = spc_json_get(&d, ni, "constraints")->num;
    }
    CHECK_MSG(Elast < 1e-8 * E0, "constraints %g -> %g", E0, Elast);
    const spc_json *pts = spc_json_get(&d, spc_json_at(&d, spc_json_get(&d, nr, "solutions"), 0), "points");
    for (int i = 0; ok && pts && i < c.n; ++i) {
        spc_vec3 v = jv3(&d, spc_json_at(&d, pts, i + 1));
        CHECK_MSG(v.x == c.v[i].h.p.x && v.y == c.v[i].h.p.y && v.z == c.v[i].h.p.z, "newton vertex %d", i);
    }
    /* exact: the sphere enumeration's chains, as many and the same */
    spc_snee_params pa;
    spc_snee_params_default(&pa, SPC_SNEE_ANGULAR, 2);
    q.params = &pa;
    spc_chain all[16];
    int n = spc_sphere_chains_all(&q, all, 16, &it);
    const spc_json *er = spc_json_at(&d, runs, 3);
    CHECK(!strcmp(spc_json_get(&d, er, "solver")->str, "exact"));
    const spc_json *sols = spc_json_get(&d, er, "solutions");
    CHECK_MSG(n >= 1 && sols && sols->count == n, "exact: %d chains, %d in the answer", n, sols ? sols->count : -1);
    for (int k = 0; sols && k < n && k < sols->count; ++k) {
        const spc_json *pk = spc_json_get(&d, spc_json_at(&d, sols, k), "points");
        spc_vec3 v = jv3(&d, spc_json_at(&d, pk, 1));
        CHECK(v.x == all[k].v[0].h.p.x && v.y == all[k].v[0].h.p.y && v.z == all[k].v[0].h.p.z);
    }
    spc_json_doc_release(&d);
    spc_explore_destroy(ex);
    spc_scene_destroy(sc);
}

TEST(picked_light)
{
    spc_scene *sc = load("caustic_glass_sphere.xml");
    if (!sc) {
        CHECK(sc);
        return;
    }
    spc_explorer *ex = spc_explore_create(sc);
    spc_json_doc d;
    /* a ray up into the sphere light (centre (-0.9, 2.4, -0.6), radius 0.12): y its lowest point */
    CHECK(call(ex, "POST", "/api/solve",
               "{" RX_REQ ",\"light\":{\"origin\":[-0.9,1.5,-0.6],\"direction\":[0,1,0]},\"solver\":\"exact\"}",
               &d) == 200);
    spc_vec3 y = jv3(&d, path_get(&d, "light", -1, "point"));
    spc_vec3 ny = jv3(&d, path_get(&d, "light", -1, "normal"));
    CHECK(fabs(y.x + 0.9) < 1e-9 && fabs(y.y - 2.28) < 1e-9 && fabs(y.z + 0.6) < 1e-9);
    CHECK(fabs(ny.y + 1.0) < 1e-9);
    const spc_json *sols = spc_json_get(&d, path_get(&d, "runs", 0, NULL), "solutions");
    CHECK(sols && sols->count >= 1);
    for (int k = 0; sols && k < sols->count; ++k) {
        const spc_json *pts = spc_json_get(&d, spc_json_at(&d, sols, k), "points");
        spc_vec3 e = jv3(&d, spc_json_at(&d, pts, pts->count - 1));
        CHECK(e.x == y.x && e.y == y.y && e.z == y.z); /* every chain ends at the picked point */
    }
    spc_json_doc_release(&d);
    /* a ray that meets the floor first is refused */
    CHECK(call(ex, "POST", "/api/solve", "{" RX_REQ ",\"light\":{\"origin\":[0,1,0],\"direction\":[0,-1,0]}}", &d) ==
          422);
    CHECK(strstr(spc_json_get(&d, &d.nodes[0], "error")->str, "area light"));
    spc_json_doc_release(&d);
    spc_explore_destroy(ex);
    spc_scene_destroy(sc);
}

TEST(lossmap_shape)
{
    spc_scene *sc = load("caustic_glass_sphere.xml");
    if (!sc) {
        CHECK(sc);
        return;
    }
    spc_explorer *ex = spc_explore_create(sc);
    spc_json_doc d;
    CHECK(call(ex, "POST", "/api/lossmap", "{" RX_REQ ",\"size\":9,\"extent\":0.05}", &d) == 200);
    const spc_json *loss = path_get(&d, "loss", -1, NULL);
    CHECK(loss && loss->count == 81);
    /* the centre cell (a = b = 0) is the seed: its loss is the solve's first iterate's */
    const spc_json *c = spc_json_at(&d, loss, 40);
    CHECK(c && c->type == SPC_JSON_NUMBER);
    double centre = c ? c->num : -1.0;
    spc_json_doc_release(&d);
    CHECK(call(ex, "POST", "/api/solve", "{" RX_REQ ",\"solver\":\"angular\"}", &d) == 200);
    const spc_json *it0 = spc_json_at(&d, spc_json_get(&d, path_get(&d, "runs", 0, NULL), "iterates"), 0);
    double L0 = it0 ? spc_json_get(&d, it0, "loss")->num : -1.0;
    CHECK_MSG(fabs(centre - L0) <= 1e-5 * L0 && L0 > 0.0, "centre %g, seed %g", centre, L0);
    spc_json_doc_release(&d);
    /* basins: the centre cell (the seed) reaches the solution the solve reaches */
    CHECK(call(ex, "POST", "/api/lossmap", "{" RX_REQ ",\"size\":9,\"extent\":0.4,\"basins\":true}", &d) == 200);
    const spc_json *basin = path_get(&d, "basin", -1, NULL), *bsol = path_get(&d, "solutions", -1, NULL);
    CHECK(basin && basin->count == 81 && bsol && bsol->count >= 1);
    int bc = basin ? (int)spc_json_at(&d, basin, 40)->num : -1;
    CHECK(bc >= 0 && bsol && bc < bsol->count);
    spc_vec3 bd = bc >= 0 && bsol ? jv3(&d, spc_json_at(&d, bsol, bc)) : spc_v3(0, 0, 0);
    spc_json_doc_release(&d);
    CHECK(call(ex, "POST", "/api/solve", "{" RX_REQ ",\"solver\":\"angular\"}", &d) == 200);
    spc_vec3 sd = jv3(
        &d, spc_json_get(&d, spc_json_at(&d, spc_json_get(&d, path_get(&d, "runs", 0, NULL), "solutions"), 0), "d0"));
    CHECK_MSG(spc_length(spc_sub(bd, sd)) < 1e-9, "basin's solution (%g %g %g), solve's (%g %g %g)", bd.x, bd.y, bd.z,
              sd.x, sd.y, sd.z);
    spc_json_doc_release(&d);
    /* the time limit: a 128^2 map (16k traces, tens of ms) cut after 1 ms returns the rows done */
    CHECK(call(ex, "POST", "/api/lossmap", "{" RX_REQ ",\"size\":128,\"extent\":0.5,\"time_limit\":0.001}", &d) == 200);
    int rows = (int)path_get(&d, "rows", -1, NULL)->num;
    CHECK(path_get(&d, "timed_out", -1, NULL)->num == 1.0 && rows >= 1 && rows < 128);
    CHECK(path_get(&d, "loss", -1, NULL)->count == 128 * rows);
    spc_json_doc_release(&d);
    spc_explore_destroy(ex);
    spc_scene_destroy(sc);
}

TEST(bad_requests)
{
    spc_scene *sc = load("caustic_glass_sphere.xml");
    if (!sc) {
        CHECK(sc);
        return;
    }
    spc_explorer *ex = spc_explore_create(sc);
    struct {
        const char *method, *path, *body;
        int status;
        const char *msg;
    } cases[] = {
        {"GET", "/api/nothing", NULL, 404, "no such API path"},
        {"GET", "/../etc/passwd", NULL, 404, "no such API path"},
        {"GET", "/api/solve", NULL, 405, "POST"},
        {"POST", "/api/scene", "{}", 405, "GET"},
        {"POST", "/api/solve", "{", 400, "malformed JSON"},
        {"POST", "/api/solve", "[1]", 400, "JSON object"},
        {"POST", "/api/solve", "{}", 400, "receiver"},
        {"POST", "/api/solve", "{" RX_REQ ",\"solver\":\"magic\"}", 400, "unknown solver"},
        {"POST", "/api/solve", "{" RX_REQ ",\"max_chain\":99}", 400, "out of range"},
        {"POST", "/api/solve", "{" RX_REQ ",\"max_chain\":1.5}", 400, "integer"},
        {"POST", "/api/solve", "{" RX_REQ ",\"max_iterations\":100000}", 400, "out of range"},
        {"POST", "/api/solve", "{" RX_REQ ",\"time_limit\":1e9}", 400, "out of range"},
        {"POST", "/api/solve", "{\"receiver\":{\"origin\":[1e300,0,0],\"direction\":[0,-1,0]}}", 400, "out of range"},
        {"POST", "/api/solve", "{\"receiver\":{\"origin\":[0,1,0],\"direction\":[0,0,0]}}", 400, "zero"},
        {"POST", "/api/solve", "{\"receiver\":{\"origin\":[0,1,0],\"direction\":[1,2]}}", 400, "3 numbers"},
        {"POST", "/api/solve", "{\"receiver\":{\"origin\":[0,10,0],\"direction\":[0,1,0]}}", 422, "misses"},
        {"POST", "/api/solve", "{\"receiver\":{\"origin\":[-0.9,3,-0.6],\"direction\":[0,-1,0]}}", 422,
         "not a receiver"},
        {"POST", "/api/solve", "{" RX_REQ ",\"seed\":\"psychic\"}", 400, "unknown seed"},
        {"POST", "/api/lossmap", "{" RX_REQ ",\"size\":100000}", 400, "out of range"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        spc_json_doc d;
        int st = call(ex, cases[i].method, cases[i].path, cases[i].body, &d);
        const spc_json *err = st > 0 ? spc_json_get(&d, &d.nodes[0], "error") : NULL;
        CHECK_MSG(st == cases[i].status && err && strstr(err->str, cases[i].msg), "case %d: %d '%s'", (int)i, st,
                  err ? err->str : "");
        if (st > 0)
            spc_json_doc_release(&d);
    }
    /* a body over the limit */
    size_t n = SPC_EXPLORE_MAX_BODY + 10;
    char *big = malloc(n + 1);
    memset(big, ' ', n);
    big[0] = '{';
    big[n - 1] = '}';
    big[n] = '\0';
    char *resp = NULL;
    CHECK(spc_explore_handle(ex, "POST", "/api/solve", big, n, &resp) == 413 && resp && strstr(resp, "too large"));
    free(resp);
    free(big);
    spc_explore_destroy(ex);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(json_reader);
    RUN(scene_json);
    RUN(angular_solve_equals_solver);
    RUN(newton_and_exact_equal_solvers);
    RUN(picked_light);
    RUN(lossmap_shape);
    RUN(bad_requests);
    return spc_test_finish();
}
