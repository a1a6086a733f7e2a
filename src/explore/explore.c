/*
 * explore/explore.c: the solver explorer's API handlers (explore.h): the scene as JSON, solves that
 * record every iterate, and the angular loss over the direction parameters around a seed.
 *
 * A solve runs the same code the renderer runs, through the solvers' own headers: the angular
 * solver (angular.h) with its observer hook recording each traced chain, Newton's method on the
 * vertices (newton.h: seed path, solve, the chain it polishes to), the conic solver's and the exact
 * enumerations' solve_all. For each accepted angular iterate the loss |r|^2 of Dadfar 2022 (sec.
 * 5.1) and its gradient 2 J^T r in the chain's direction parameters (sec. 6.1) are reported next to
 * a central finite difference of the loss with the chain's signature held (sec. 7 draws the two
 * side by side). Each solution carries specular NEE's value of the chain (spc_snee_chain_value:
 * the path's throughput from x to the light, without 1/p(y) and the trial count) and its
 * generalized geometry term (spc_chain_geometry).
 */
#include "explore/explore.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bsdf/bsdf.h"
#include "emitter/emitter.h"
#include "explore/json.h"
#include "manifold/angular.h"
#include "manifold/chain.h"
#include "manifold/conic.h"
#include "manifold/cylinder_chains.h"
#include "manifold/newton.h"
#include "manifold/plane_chains.h"
#include "manifold/specular_nee.h"
#include "manifold/sphere_chains.h"
#include "scene/scene.h"
#include "scene/sdf.h"

/* Finite-difference step in the gnomonic direction parameters: central differences of a loss
 * smooth to double precision lose about sqrt(eps) / h relative; 1e-6 keeps both that and the
 * truncation error h^2 near 1e-8 of the gradient. */
#define FD_STEP_DEFAULT 1e-6
/* Solutions kept per solver (specular_nee.c keeps as many). */
#define MAX_SOLUTIONS 16
/* Specular surfaces a pick ray passes straight through on its way to the receiver. */
#define PICK_MAX_SPECULAR 16
/* Draws of specular NEE's light sample before the explorer gives up on finding a light point a
 * chain can reach (the sky of the caustic scenes takes a few percent of the draws). */
#define LIGHT_TRIES 64
/* Default limit of a request's solver time (seconds). */
#define TIME_LIMIT_DEFAULT 2.0

struct spc_explorer {
    const spc_scene *sc;
};

spc_explorer *spc_explore_create(const spc_scene *s)
{
    spc_explorer *ex = calloc(1, sizeof *ex);
    if (ex)
        ex->sc = s;
    return ex;
}

void spc_explore_destroy(spc_explorer *ex) { free(ex); }

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- request reading ---- */

typedef struct req {
    const spc_json_doc *d;
    const spc_json *root;
    char msg[256];
    bool bad;
} req;

static bool bad(req *r, const char *fmt, const char *what)
{
    if (!r->bad)
        snprintf(r->msg, sizeof r->msg, fmt, what);
    r->bad = true;
    return false;
}

/* A number in [lo, hi] at obj.key; absent: *v keeps its default (false if required). */
static bool get_num(req *r, const spc_json *obj, const char *key, double lo, double hi, bool required, double *v)
{
    const spc_json *j = spc_json_get(r->d, obj, key);
    if (!j)
        return required ? bad(r, "missing '%s'", key) : true;
    if (j->type != SPC_JSON_NUMBER)
        return bad(r, "'%s' must be a number", key);
    if (!(j->num >= lo && j->num <= hi)) {
        char m[200];
        snprintf(m, sizeof m, "'%s' out of range [%g, %g]", key, lo, hi);
        return bad(r, "%s", m);
    }
    *v = j->num;
    return true;
}

static bool get_int(req *r, const spc_json *obj, const char *key, int lo, int hi, int *v)
{
    double x = *v;
    if (!get_num(r, obj, key, lo, hi, false, &x))
        return false;
    if (x != floor(x))
        return bad(r, "'%s' must be an integer", key);
    *v = (int)x;
    return true;
}

/* Three numbers of magnitude <= lim; unit: normalized, and refused if zero. */
static bool get_vec3(req *r, const spc_json *obj, const char *key, double lim, bool unit, bool required, spc_vec3 *v)
{
    const spc_json *j = spc_json_get(r->d, obj, key);
    if (!j)
        return required ? bad(r, "missing '%s'", key) : true;
    if (j->type != SPC_JSON_ARRAY || j->count != 3)
        return bad(r, "'%s' must be an array of 3 numbers", key);
    double c[3];
    for (int i = 0; i < 3; ++i) {
        const spc_json *e = spc_json_at(r->d, j, i);
        if (e->type != SPC_JSON_NUMBER)
            return bad(r, "'%s' must be an array of 3 numbers", key);
        if (!(fabs(e->num) <= lim))
            return bad(r, "'%s' out of range", key);
        c[i] = e->num;
    }
    *v = spc_v3(c[0], c[1], c[2]);
    if (unit) {
        double l = spc_length(*v);
        if (!(l > 1e-12))
            return bad(r, "'%s' must not be zero", key);
        *v = spc_scale(*v, 1.0 / l);
    }
    return true;
}

static const char *get_str(req *r, const spc_json *obj, const char *key, const char *def)
{
    const spc_json *j = spc_json_get(r->d, obj, key);
    if (!j)
        return def;
    if (j->type != SPC_JSON_STRING) {
        bad(r, "'%s' must be a string", key);
        return NULL;
    }
    return j->str;
}

static bool get_bool(req *r, const spc_json *obj, const char *key, bool *v)
{
    const spc_json *j = spc_json_get(r->d, obj, key);
    if (!j)
        return true;
    if (j->type != SPC_JSON_BOOL)
        return bad(r, "'%s' must be true or false", key);
    *v = j->num != 0.0;
    return true;
}

/* ---- writing helpers ---- */

static void jvec3(spc_jbuf *b, spc_vec3 v)
{
    double c[3] = {v.x, v.y, v.z};
    spc_jbuf_vec(b, c, 3);
}

static int finish(spc_jbuf *b, int status, char **response)
{
    if (b->failed) {
        free(b->s);
        *response = NULL;
        return 500;
    }
    *response = b->s;
    return status;
}

static int error_response(int status, const char *msg, char **response)
{
    spc_jbuf b = {0};
    spc_jbuf_raw(&b, "{\"error\":");
    spc_jbuf_str(&b, msg);
    spc_jbuf_raw(&b, "}");
    return finish(&b, status, response);
}

/* ---- GET /api/scene ---- */

/* Surface nets on a grid over the field's box: one vertex per cell the surface crosses (the mean of
 * its edges' crossings), a quad per crossed grid edge. For display only. */
static void write_sdf(spc_jbuf *b, const spc_shape *s)
{
    const int N = SPC_EXPLORE_SDF_GRID;
    spc_vec3 lo = s->bbox_min, hi = s->bbox_max, ext = spc_sub(hi, lo);
    lo = spc_sub(lo, spc_scale(ext, 0.02));
    ext = spc_scale(ext, 1.04);
    int M = N + 1;
    double *f = malloc((size_t)M * M * M * sizeof *f);
    int *vid = malloc((size_t)N * N * N * sizeof *vid);
    if (!f || !vid) {
        free(f);
        free(vid);
        b->failed = true;
        return;
    }
#define GP(i, j, k) spc_v3(lo.x + ext.x * (i) / N, lo.y + ext.y * (j) / N, lo.z + ext.z * (k) / N)
#define F(i, j, k) f[((size_t)(k)*M + (j)) * M + (i)]
    for (int k = 0; k < M; ++k)
        for (int j = 0; j < M; ++j)
            for (int i = 0; i < M; ++i)
                F(i, j, k) = spc_sdf_eval(s->sdf, GP(i, j, k));
    spc_jbuf_raw(b, ",\"positions\":[");
    int nv = 0;
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i) {
                spc_vec3 sum = spc_v3(0, 0, 0);
                int cnt = 0;
                for (int e = 0; e < 12; ++e) {
                    /* the cube's 12 edges: axis e / 4, the other two corners' bits e % 4 */
                    int ax = e / 4, u = e & 1, v = (e >> 1) & 1;
                    int c0[3], c1[3];
                    c0[ax] = 0;
                    c1[ax] = 1;
                    c0[(ax + 1) % 3] = c1[(ax + 1) % 3] = u;
                    c0[(ax + 2) % 3] = c1[(ax + 2) % 3] = v;
                    double f0 = F(i + c0[0], j + c0[1], k + c0[2]), f1 = F(i + c1[0], j + c1[1], k + c1[2]);
                    if ((f0 < 0) == (f1 < 0))
                        continue;
                    double t = f0 / (f0 - f1);
                    spc_vec3 p0 = GP(i + c0[0], j + c0[1], k + c0[2]), p1 = GP(i + c1[0], j + c1[1], k + c1[2]);
                    sum = spc_add(sum, spc_add(p0, spc_scale(spc_sub(p1, p0), t)));
                    ++cnt;
                }
                vid[((size_t)k * N + j) * N + i] = cnt ? nv : -1;
                if (cnt) {
                    spc_vec3 p = spc_scale(sum, 1.0 / cnt);
                    spc_jbuf_printf(b, "%s%.6g,%.6g,%.6g", nv ? "," : "", p.x, p.y, p.z);
                    ++nv;
                }
            }
    spc_jbuf_raw(b, "],\"indices\":[");
    bool first = true;
#define V(i, j, k) vid[((size_t)(k)*N + (j)) * N + (i)]
    for (int k = 1; k < N; ++k)
        for (int j = 1; j < N; ++j)
            for (int i = 1; i < N; ++i)
                for (int ax = 0; ax < 3; ++ax) {
                    /* the grid edge from corner (i, j, k) along ax, shared by four cells */
                    int c[3] = {i, j, k};
                    int c1[3] = {i, j, k};
                    c1[ax] += 1;
                    if (c1[ax] > N)
                        continue;
                    double f0 = F(c[0], c[1], c[2]), f1 = F(c1[0], c1[1], c1[2]);
                    if ((f0 < 0) == (f1 < 0) || c[ax] >= N)
                        continue;
                    int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3, q[4];
                    for (int m = 0; m < 4; ++m) {
                        int cc[3] = {c[0], c[1], c[2]};
                        cc[a1] -= (m == 1 || m == 2);
                        cc[a2] -= (m >= 2);
                        q[m] = V(cc[0], cc[1], cc[2]);
                    }
                    if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[3] < 0)
                        continue;
                    if (f0 < 0)
                        spc_jbuf_printf(b, "%s%d,%d,%d,%d,%d,%d", first ? "" : ",", q[0], q[1], q[2], q[0], q[2], q[3]);
                    else
                        spc_jbuf_printf(b, "%s%d,%d,%d,%d,%d,%d", first ? "" : ",", q[0], q[2], q[1], q[0], q[3], q[2]);
                    first = false;
                }
    spc_jbuf_raw(b, "]");
#undef V
#undef F
#undef GP
    free(f);
    free(vid);
}

static void write_mat4(spc_jbuf *b, const spc_mat4 *m)
{
    spc_jbuf_raw(b, "[");
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            spc_jbuf_printf(b, "%s%.9g", i + j ? "," : "", m->m[i][j]);
    spc_jbuf_raw(b, "]");
}

static const char *shape_type_name(spc_shape_type t)
{
    switch (t) {
    case SPC_SHAPE_MESH:
        return "mesh";
    case SPC_SHAPE_SPHERE:
        return "sphere";
    case SPC_SHAPE_DISK:
        return "disk";
    case SPC_SHAPE_CYLINDER:
        return "cylinder";
    case SPC_SHAPE_SDF:
        return "sdf";
    case SPC_SHAPE_CURVE:
        return "curve";
    case SPC_SHAPE_SDFGRID:
        return "sdfgrid";
    }
    return "unknown";
}

static int handle_scene(const spc_explorer *ex, char **response)
{
    const spc_scene *sc = ex->sc;
    spc_jbuf b = {0};
    spc_jbuf_raw(&b, "{\"bbox\":[");
    jvec3(&b, sc->bbox_min);
    spc_jbuf_raw(&b, ",");
    jvec3(&b, sc->bbox_max);
    spc_jbuf_raw(&b, "],\"radius\":");
    spc_jbuf_num(&b, sc->radius);
    spc_jbuf_raw(&b, ",\"camera\":{\"origin\":");
    const spc_mat4 *cm = &sc->camera.to_world;
    jvec3(&b, spc_mat4_apply_point(cm, spc_v3(0, 0, 0)));
    spc_jbuf_raw(&b, ",\"forward\":");
    jvec3(&b, spc_normalize(spc_mat4_apply_vector(cm, spc_v3(0, 0, 1))));
    spc_jbuf_raw(&b, ",\"up\":");
    jvec3(&b, spc_normalize(spc_mat4_apply_vector(cm, spc_v3(0, 1, 0))));
    spc_jbuf_printf(&b, ",\"fov\":%.9g,\"fov_axis\":\"%s\",\"width\":%d,\"height\":%d}", sc->camera.fov,
                    sc->camera.fov_axis == SPC_FOV_Y ? "y" : "x", sc->film.width, sc->film.height);
    spc_jbuf_raw(&b, ",\"shapes\":[");
    for (int i = 0; i < sc->nshapes; ++i) {
        const spc_shape *s = sc->shapes[i];
        double eta = 0.0;
        bool spec = s->bsdf && spc_bsdf_is_specular_interface(s->bsdf, &eta);
        spc_jbuf_printf(&b, "%s{\"index\":%d,\"type\":\"%s\",\"id\":", i ? "," : "", i, shape_type_name(s->type));
        spc_jbuf_str(&b, s->id);
        spc_jbuf_printf(&b, ",\"specular\":%s,\"eta\":", spec ? "true" : "false");
        spc_jbuf_num(&b, eta);
        /* a display colour: the BSDF's albedo at the middle of the texture space */
        spc_hit h;
        memset(&h, 0, sizeof h);
        h.uv.x = h.uv.y = 0.5;
        h.ng = spc_v3(0, 0, 1);
        h.sh = spc_frame_from_n(h.ng);
        h.shape = s;
        h.shape_index = i;
        h.bsdf = s->bsdf;
        spc_rgb al = s->bsdf ? spc_bsdf_albedo(s->bsdf, &h) : spc_rgb1(0.0);
        double alv[3] = {al.r, al.g, al.b};
        spc_jbuf_raw(&b, ",\"albedo\":");
        spc_jbuf_vec(&b, alv, 3);
        spc_jbuf_printf(&b, ",\"caster\":%s,\"receiver\":%s,\"emitter\":%s",
                        spc_chain_shape_is_caster(s, false, NULL) ? "true" : "false",
                        (s->caustic_flags & SPC_CAUSTIC_RECEIVER) && !spec ? "true" : "false",
                        s->emitter ? "true" : "false");
        switch (s->type) {
        case SPC_SHAPE_MESH: {
            spc_jbuf_raw(&b, ",\"positions\":[");
            for (size_t v = 0; v < s->mesh.nverts; ++v)
                spc_jbuf_printf(&b, "%s%.7g,%.7g,%.7g", v ? "," : "", s->mesh.p[3 * v], s->mesh.p[3 * v + 1],
                                s->mesh.p[3 * v + 2]);
            spc_jbuf_raw(&b, "],\"indices\":[");
            for (size_t t = 0; t < 3 * s->mesh.ntris; ++t)
                spc_jbuf_printf(&b, "%s%u", t ? "," : "", (unsigned)s->mesh.idx[t]);
            spc_jbuf_raw(&b, "]");
            break;
        }
        case SPC_SHAPE_SPHERE:
            spc_jbuf_raw(&b, ",\"center\":");
            jvec3(&b, s->center);
            spc_jbuf_raw(&b, ",\"radius\":");
            spc_jbuf_num(&b, s->radius);
            break;
        case SPC_SHAPE_DISK:
        case SPC_SHAPE_CYLINDER:
            spc_jbuf_raw(&b, ",\"to_world\":");
            write_mat4(&b, &s->to_world);
            spc_jbuf_raw(&b, ",\"radius\":");
            spc_jbuf_num(&b, s->type == SPC_SHAPE_DISK ? 1.0 : s->radius);
            spc_jbuf_raw(&b, ",\"length\":");
            spc_jbuf_num(&b, s->length);
            break;
        case SPC_SHAPE_SDF:
            write_sdf(&b, s);
            break;
        case SPC_SHAPE_CURVE: /* not drawn by the explorer */
        case SPC_SHAPE_SDFGRID: /* bounds only */
            break;
        }
        spc_jbuf_raw(&b, "}");
    }
    spc_jbuf_raw(&b, "],\"lights\":[");
    for (int i = 0; i < sc->nemitters; ++i) {
        const spc_emitter *e = sc->emitters[i];
        const char *type = "other";
        switch (e->type) {
        case SPC_EMITTER_POINT:
            type = "point";
            break;
        case SPC_EMITTER_SPOT:
            type = "spot";
            break;
        case SPC_EMITTER_DIRECTIONAL:
            type = "directional";
            break;
        case SPC_EMITTER_AREA:
            type = "area";
            break;
        case SPC_EMITTER_CONSTANT:
            type = "constant";
            break;
        case SPC_EMITTER_ENVMAP:
            type = "envmap";
            break;
        case SPC_EMITTER_PROJECTOR:
            type = "projector";
            break;
        }
        spc_jbuf_printf(&b, "%s{\"index\":%d,\"type\":\"%s\"", i ? "," : "", i, type);
        if (e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_SPOT) {
            spc_jbuf_raw(&b, ",\"position\":");
            jvec3(&b, e->position);
        }
        if (e->type == SPC_EMITTER_AREA)
            spc_jbuf_printf(&b, ",\"shape\":%d", e->shape_index);
        spc_jbuf_raw(&b, "}");
    }
    spc_jbuf_raw(&b, "]}");
    return finish(&b, 200, response);
}

/* ---- the connection problem of a request ---- */

typedef struct problem {
    spc_hit x;
    spc_vec3 wo;
    spc_snee_params params;
    spc_snee_query q;
    const spc_emitter *e;
    spc_vec2 uv;
    double p_y;
    int max_chain;
    spc_angular_target tg;
} problem;

/* Reads receiver, light_sample and max_chain and sets up the query. 4xx status on failure. */
static int read_problem(const spc_scene *sc, req *r, int solver, problem *pb)
{
    memset(pb, 0, sizeof *pb);
    const spc_json *rx = spc_json_get(r->d, r->root, "receiver");
    if (!rx || rx->type != SPC_JSON_OBJECT)
        return bad(r, "missing '%s' (an object with origin and direction)", "receiver"), 400;
    double lim = 1e3 * sc->radius + spc_length(sc->center);
    spc_vec3 o, d;
    if (!get_vec3(r, rx, "origin", lim, false, true, &o) || !get_vec3(r, rx, "direction", 1e9, true, true, &d))
        return 400;
    int max_chain = 2, light_sample = 0;
    if (!get_int(r, r->root, "max_chain", 1, 4, &max_chain) ||
        !get_int(r, r->root, "light_sample", 0, 1000000, &light_sample))
        return 400;
    /* the first surface along the pick ray that is not a specular interface: a receiver seen
     * through glass or in a mirror's plane is picked where the straight ray meets it */
    spc_ray ray = {o, d, 0.0, INFINITY};
    bool hit = false;
    for (int k = 0; k < PICK_MAX_SPECULAR; ++k) {
        double eta;
        if (!(hit = spc_scene_intersect(sc, &ray, &pb->x)) || !spc_bsdf_is_specular_interface(pb->x.bsdf, &eta))
            break;
        ray = spc_hit_spawn(&pb->x, d);
        hit = false;
    }
    if (!hit)
        return bad(r, "%s", "the receiver ray misses the scene"), 422;
    pb->wo = spc_neg(d);
    pb->max_chain = max_chain;
    spc_snee_params_default(&pb->params, solver, max_chain);
    if (pb->x.emitter || spc_snee_budget(&pb->x, max_chain, false) < 1)
        return bad(r, "%s", "the picked point is not a receiver (a specular, emitting or non-receiving surface)"), 422;
    spc_snee_query_init(&pb->q, sc, &pb->params, &pb->x, pb->wo, max_chain);
    spc_rng rng;
    spc_rng_seed(&rng, (uint64_t)light_sample, 0x11);
    const spc_json *lj = spc_json_get(r->d, r->root, "light");
    if (lj) {
        /* a picked light point: where the ray meets an area light */
        spc_vec3 lo, ld;
        if (lj->type != SPC_JSON_OBJECT)
            return bad(r, "'%s' must be an object with origin and direction", "light"), 400;
        if (!get_vec3(r, lj, "origin", lim, false, true, &lo) || !get_vec3(r, lj, "direction", 1e9, true, true, &ld))
            return 400;
        spc_ray lr = {lo, ld, 0.0, INFINITY};
        spc_hit lh;
        if (!spc_scene_intersect(sc, &lr, &lh) || !lh.emitter || lh.emitter->type != SPC_EMITTER_AREA)
            return bad(r, "%s", "the light ray does not meet an area light first"), 422;
        pb->e = lh.emitter;
        pb->uv = lh.uv;
        pb->q.y = lh.p;
        pb->q.ny = lh.ng;
        pb->q.light_size = sqrt(lh.shape->area);
        pb->p_y = spc_snee_light_pdf(sc, false, pb->e, pb->q.y, pb->q.ny);
    } else {
        /* light_sample k: the first point the stream k draws on a light a chain can reach (an
         * environment light's draws give none) */
        bool found = false;
        for (int k = 0; k < LIGHT_TRIES && !found; ++k)
            found = spc_snee_sample_light(sc, false, &rng, &pb->q, &pb->e, &pb->uv, &pb->p_y);
        if (!found)
            return bad(r, "%s", "no light point a chain can reach (no caster, or only environment lights)"), 422;
    }
    pb->tg.y = pb->q.y;
    pb->tg.ny = pb->q.ny;
    pb->tg.scale = sc->radius;
    pb->tg.light_size = pb->q.light_size;
    return 0;
}

/* The seed direction of an angular or Newton solve: "straight" (toward y), "cone" (specular NEE's
 * seed distribution, draw seed_index), or "seed_direction": [x, y, z]. */
static bool read_seed(req *r, problem *pb, spc_vec3 *dir, bool *straight)
{
    const char *mode = get_str(r, r->root, "seed", "straight");
    if (!mode)
        return false;
    *straight = false;
    if (spc_json_get(r->d, r->root, "seed_direction"))
        return get_vec3(r, r->root, "seed_direction", 1e9, true, true, dir);
    if (!strcmp(mode, "straight")) {
        *straight = true;
        *dir = spc_normalize(spc_sub(pb->q.y, pb->x.p));
        return true;
    }
    if (!strcmp(mode, "cone")) {
        int k = 0;
        if (!get_int(r, r->root, "seed_index", 0, 1000000, &k))
            return false;
        spc_rng rng;
        spc_rng_seed(&rng, (uint64_t)k, 0x5eed);
        pb->q.seed = SPC_SNEE_SEED_CONE;
        if (!spc_snee_seed_direction(&pb->q, &rng, dir))
            return bad(r, "%s", "no seed direction: the scene has no caster");
        return true;
    }
    return bad(r, "unknown seed '%s' (straight, cone)", mode);
}

static void write_points(spc_jbuf *b, spc_vec3 x, const spc_chain *c, spc_vec3 end)
{
    spc_jbuf_raw(b, "[");
    jvec3(b, x);
    for (int i = 0; i < c->n; ++i) {
        spc_jbuf_raw(b, ",");
        jvec3(b, c->v[i].h.p);
    }
    spc_jbuf_raw(b, ",");
    jvec3(b, end);
    spc_jbuf_raw(b, "]");
}

static bool chain_usable(const spc_chain *c)
{
    return c->n >= 1 && (c->end == SPC_CHAIN_END_ESCAPED || c->end == SPC_CHAIN_END_SURFACE);
}

/* Where to draw the end of the final segment: the closest point to y on its line ahead, or a
 * scene radius out when the chain ended early. */
static spc_vec3 chain_end_point(const spc_chain *c, spc_vec3 y, double radius)
{
    if (c->n < 1)
        return spc_madd(c->x, c->d0, radius);
    const spc_chain_vertex *v = &c->v[c->n - 1];
    if (c->end == SPC_CHAIN_END_TIR || c->end == SPC_CHAIN_END_MISMATCH || c->end == SPC_CHAIN_END_DEGENERATE)
        return v->h.p;
    double t = spc_dot(spc_sub(y, v->h.p), v->d);
    if (!(t > 0.0))
        t = 0.1 * radius;
    return spc_madd(v->h.p, v->d, t);
}

static const char *end_name(spc_chain_end e)
{
    switch (e) {
    case SPC_CHAIN_END_ESCAPED:
        return "escaped";
    case SPC_CHAIN_END_SURFACE:
        return "surface";
    case SPC_CHAIN_END_LIMIT:
        return "too long";
    case SPC_CHAIN_END_TIR:
        return "total internal reflection";
    case SPC_CHAIN_END_MISMATCH:
        return "left the signature";
    case SPC_CHAIN_END_DEGENERATE:
        return "degenerate";
    }
    return "?";
}

static void write_solution(spc_jbuf *b, const problem *pb, const spc_chain *c)
{
    spc_rgb v = spc_snee_chain_value(&pb->q, pb->e, pb->uv, c);
    spc_vec3 ny = pb->q.ny;
    if (spc_length2(ny) == 0.0)
        ny = spc_neg(c->v[c->n - 1].d);
    double G = spc_chain_geometry(c, pb->q.y, ny);
    spc_jbuf_raw(b, "{\"points\":");
    write_points(b, pb->x.p, c, pb->q.y);
    spc_jbuf_raw(b, ",\"signature\":[");
    for (int i = 0; i < c->n; ++i)
        spc_jbuf_printf(b, "%s[%d,\"%s\"]", i ? "," : "", c->v[i].h.shape_index,
                        c->v[i].event == SPC_CHAIN_REFLECT ? "R" : "T");
    spc_jbuf_raw(b, "],\"d0\":");
    jvec3(b, c->d0);
    spc_jbuf_raw(b, ",\"contribution\":");
    double rgb[3] = {v.r, v.g, v.b};
    spc_jbuf_vec(b, rgb, 3);
    spc_jbuf_raw(b, ",\"G\":");
    spc_jbuf_num(b, G);
    spc_jbuf_raw(b, ",\"value\":");
    double val = (v.r + v.g + v.b) / 3.0;
    spc_jbuf_num(b, val / pb->p_y);
    spc_jbuf_raw(b, "}");
}

/* ---- the angular solver, recorded ---- */

typedef struct recorder {
    spc_chain *c;
    bool *accepted;
    int n, cap;
} recorder;

static void record(void *user, const spc_chain *c, bool accepted)
{
    recorder *rc = user;
    if (rc->n < rc->cap) {
        rc->c[rc->n] = *c;
        rc->accepted[rc->n] = accepted;
        rc->n++;
    }
}

/* Loss |r|^2 of the chain re-traced at (a, b) in c's frame with c's signature; NaN if it breaks. */
static double loss_at(const spc_scene *sc, const problem *pb, const spc_chain *c, const spc_chain_opts *fo,
                      spc_angular_loss loss, double a, double b)
{
    spc_chain t;
    spc_chain_trace(sc, &pb->x, &c->frame, a, b, fo, &t);
    if (!chain_usable(&t) || t.n != c->n)
        return NAN;
    spc_vec3 r, J[2];
    spc_angular_residual(&t, &pb->tg, loss, &r, J);
    return spc_length2(r);
}

static void write_iterate(spc_jbuf *b, const spc_scene *sc, const problem *pb, const spc_chain *c, bool accepted,
                          spc_angular_loss loss, double h)
{
    spc_jbuf_raw(b, "{\"points\":");
    write_points(b, pb->x.p, c, chain_end_point(c, pb->q.y, sc->radius));
    spc_jbuf_printf(b, ",\"accepted\":%s,\"end\":\"%s\",\"d0\":", accepted ? "true" : "false", end_name(c->end));
    jvec3(b, c->d0);
    if (chain_usable(c)) {
        spc_vec3 r, J[2];
        spc_angular_residual(c, &pb->tg, loss, &r, J);
        double L = spc_length2(r);
        spc_jbuf_raw(b, ",\"loss\":");
        spc_jbuf_num(b, L);
        if (accepted) {
            double g[2] = {2.0 * spc_dot(J[0], r), 2.0 * spc_dot(J[1], r)};
            spc_chain_sig sig;
            spc_chain_signature(c, &sig);
            spc_chain_opts fo = spc_chain_opts_default(pb->max_chain);
            fo.fixed = &sig;
            double gf[2];
            gf[0] = (loss_at(sc, pb, c, &fo, loss, c->a + h, c->b) - loss_at(sc, pb, c, &fo, loss, c->a - h, c->b)) /
                    (2.0 * h);
            gf[1] = (loss_at(sc, pb, c, &fo, loss, c->a, c->b + h) - loss_at(sc, pb, c, &fo, loss, c->a, c->b - h)) /
                    (2.0 * h);
            spc_jbuf_raw(b, ",\"grad\":");
            spc_jbuf_vec(b, g, 2);
            spc_jbuf_raw(b, ",\"grad_fd\":");
            spc_jbuf_vec(b, gf, 2);
            /* the same as directions at x: the change of d0 along -gradient */
            spc_jbuf_raw(b, ",\"grad3\":");
            jvec3(b, spc_add(spc_scale(c->dd0[0], g[0]), spc_scale(c->dd0[1], g[1])));
            spc_jbuf_raw(b, ",\"grad_fd3\":");
            jvec3(b, spc_add(spc_scale(c->dd0[0], gf[0]), spc_scale(c->dd0[1], gf[1])));
        }
    }
    spc_jbuf_raw(b, "}");
}

static const char *angular_stop_name(spc_angular_stop s)
{
    switch (s) {
    case SPC_ANGULAR_STOP_CONVERGED:
        return "converged";
    case SPC_ANGULAR_STOP_SEED:
        return "the seed chain is unusable";
    case SPC_ANGULAR_STOP_MAX_ITER:
        return "iteration limit";
    case SPC_ANGULAR_STOP_STALL:
        return "stalled (the loss barely decreases)";
    case SPC_ANGULAR_STOP_MIN_BETA:
        return "no step lowers the loss (local minimum)";
    case SPC_ANGULAR_STOP_SINGULAR:
        return "singular step";
    }
    return "?";
}

typedef struct solve_opts {
    spc_angular_options ao;
    double h;
    spc_vec3 seed;
    bool straight;
} solve_opts;

static void run_angular(spc_jbuf *b, const spc_scene *sc, problem *pb, const solve_opts *so)
{
    recorder rc = {0};
    rc.cap = SPC_EXPLORE_MAX_TRACE + 1;
    rc.c = malloc((size_t)rc.cap * sizeof *rc.c);
    rc.accepted = malloc((size_t)rc.cap * sizeof *rc.accepted);
    if (!rc.c || !rc.accepted) {
        free(rc.c);
        free(rc.accepted);
        b->failed = true;
        return;
    }
    spc_angular_options ao = so->ao;
    ao.trace = record;
    ao.trace_user = &rc;
    spc_chain_opts o = spc_chain_opts_default(pb->max_chain);
    spc_chain out;
    spc_angular_result res;
    double t0 = now_s();
    bool ok = spc_angular_solve(sc, &pb->x, &pb->tg, so->seed, &o, &ao, &out, &res);
    double dt = now_s() - t0;
    spc_jbuf_printf(b, "{\"solver\":\"angular\",\"success\":%s,\"iterations\":%d,\"stop\":\"%s\",\"time_ms\":",
                    ok ? "true" : "false", res.iterations, angular_stop_name(res.stop));
    spc_jbuf_num(b, 1e3 * dt);
    spc_jbuf_raw(b, ",\"residual\":");
    spc_jbuf_num(b, res.residual);
    spc_jbuf_raw(b, ",\"seed_direction\":");
    jvec3(b, so->seed);
    spc_jbuf_raw(b, ",\"iterates\":[");
    for (int i = 0; i < rc.n; ++i) {
        if (i)
            spc_jbuf_raw(b, ",");
        write_iterate(b, sc, pb, &rc.c[i], rc.accepted[i], ao.loss, so->h);
    }
    spc_jbuf_raw(b, "],\"solutions\":[");
    if (ok)
        write_solution(b, pb, &out);
    spc_jbuf_raw(b, "]}");
    free(rc.c);
    free(rc.accepted);
}

/* ---- Newton's method on the vertices ---- */

static const char *newton_stop_name(spc_newton_stop s)
{
    switch (s) {
    case SPC_NEWTON_CONVERGED:
        return "converged";
    case SPC_NEWTON_STOP_SEED:
        return "the constraints are undefined at the seed";
    case SPC_NEWTON_STOP_SINGULAR:
        return "singular Jacobian";
    case SPC_NEWTON_STOP_ITERATIONS:
        return "iteration limit";
    case SPC_NEWTON_STOP_PROGRESS:
        return "no step lowers the constraints";
    case SPC_NEWTON_STOP_SIDES:
        return "a vertex on the wrong side";
    }
    return "?";
}

static void write_path(spc_jbuf *b, spc_vec3 x, const spc_newton_path *p, spc_vec3 y, double E, bool accepted)
{
    spc_jbuf_raw(b, "{\"points\":[");
    jvec3(b, x);
    for (int i = 0; i < p->n; ++i) {
        spc_jbuf_raw(b, ",");
        jvec3(b, p->v[i].h.p);
    }
    spc_jbuf_raw(b, ",");
    jvec3(b, y);
    spc_jbuf_printf(b, "],\"accepted\":%s,\"constraints\":", accepted ? "true" : "false");
    spc_jbuf_num(b, E);
    spc_jbuf_raw(b, "}");
}

typedef struct newton_recorder {
    spc_newton_path *p;
    double *E;
    bool *accepted;
    int n, cap;
} newton_recorder;

static void record_newton(void *user, const spc_newton_path *p, double E, bool accepted)
{
    newton_recorder *rc = user;
    if (rc->n < rc->cap) {
        rc->p[rc->n] = *p;
        rc->E[rc->n] = E;
        rc->accepted[rc->n] = accepted;
        rc->n++;
    }
}

static void run_newton(spc_jbuf *b, const spc_scene *sc, problem *pb, const solve_opts *so)
{
    newton_recorder rc = {0};
    rc.cap = SPC_EXPLORE_MAX_TRACE + 1;
    rc.p = malloc((size_t)rc.cap * sizeof *rc.p);
    rc.E = malloc((size_t)rc.cap * sizeof *rc.E);
    rc.accepted = malloc((size_t)rc.cap * sizeof *rc.accepted);
    if (!rc.p || !rc.E || !rc.accepted) {
        free(rc.p);
        free(rc.E);
        free(rc.accepted);
        b->failed = true;
        return;
    }
    spc_newton_options no = pb->params.newton;
    if (no.max_iterations > SPC_EXPLORE_MAX_TRACE)
        no.max_iterations = SPC_EXPLORE_MAX_TRACE;
    no.trace = record_newton;
    no.trace_user = &rc;
    spc_newton_path p;
    const spc_vec3 noref = spc_v3(0, 0, 0);
    double t0 = now_s();
    bool seeded = so->straight ? spc_newton_seed_straight(sc, &pb->x, pb->q.y, pb->max_chain, false, NULL, noref, &p)
                               : spc_newton_seed_trace(sc, &pb->x, so->seed, pb->max_chain, false, NULL, noref, &p);
    spc_newton_result res = {0};
    bool ok = false;
    spc_chain out;
    int it = 0;
    if (seeded) {
        ok = spc_newton_solve(sc, &pb->x, pb->q.y, &p, &no, &res);
        if (ok)
            ok = spc_newton_to_chain(sc, &pb->x, &p, &pb->tg, &pb->params.angular, pb->params.newton.polish_iterations,
                                     false, &out, &it);
    }
    double dt = now_s() - t0;
    spc_jbuf_printf(b, "{\"solver\":\"newton\",\"success\":%s,\"iterations\":%d,\"stop\":\"%s\",\"time_ms\":",
                    ok ? "true" : "false", res.iterations + it,
                    !seeded                  ? "no seed path"
                    : (res.converged && !ok) ? "the polished chain did not converge"
                                             : newton_stop_name(res.stop));
    spc_jbuf_num(b, 1e3 * dt);
    spc_jbuf_raw(b, ",\"iterates\":[");
    for (int i = 0; i < rc.n; ++i) {
        if (i)
            spc_jbuf_raw(b, ",");
        write_path(b, pb->x.p, &rc.p[i], pb->q.y, rc.E[i], rc.accepted[i]);
    }
    spc_jbuf_raw(b, "],\"solutions\":[");
    if (ok)
        write_solution(b, pb, &out);
    spc_jbuf_raw(b, "]}");
    free(rc.p);
    free(rc.E);
    free(rc.accepted);
}

/* ---- every solution: the conic solver and the exact enumerations ---- */

static void run_all(spc_jbuf *b, const spc_scene *sc, problem *pb, bool conic)
{
    spc_chain *out = malloc(MAX_SOLUTIONS * sizeof *out);
    if (!out) {
        b->failed = true;
        return;
    }
    int it = 0, n = 0;
    double t0 = now_s();
    if (conic) {
        n = spc_conic_solve_all(&pb->q, out, MAX_SOLUTIONS, &it);
    } else {
        n = spc_sphere_chains_all(&pb->q, out, MAX_SOLUTIONS, &it);
        n += spc_cylinder_chains_all(&pb->q, out + n, MAX_SOLUTIONS - n, &it);
        n += spc_plane_chains_all(&pb->q, pb->params.reflect, out + n, MAX_SOLUTIONS - n, &it);
    }
    double dt = now_s() - t0;
    spc_jbuf_printf(b, "{\"solver\":\"%s\",\"success\":%s,\"iterations\":%d,\"stop\":\"%d solution%s\",\"time_ms\":",
                    conic ? "conic" : "exact", n > 0 ? "true" : "false", it, n, n == 1 ? "" : "s");
    spc_jbuf_num(b, 1e3 * dt);
    spc_jbuf_raw(b, ",\"iterates\":[],\"solutions\":[");
    for (int i = 0; i < n; ++i) {
        if (i)
            spc_jbuf_raw(b, ",");
        write_solution(b, pb, &out[i]);
    }
    spc_jbuf_raw(b, "]}");
    free(out);
}

static const char *const solver_names[] = {"angular", "newton", "conic", "exact"};
#define NSOLVER_NAMES 4

/* Options shared by the solve and the loss map. */
static bool read_angular(req *r, solve_opts *so)
{
    spc_angular_options_default(&so->ao);
    const char *method = get_str(r, r->root, "method", "gauss_newton");
    const char *loss = get_str(r, r->root, "loss", "plane");
    if (!method || !loss)
        return false;
    if (!strcmp(method, "gauss_newton"))
        so->ao.method = SPC_ANGULAR_GAUSS_NEWTON;
    else if (!strcmp(method, "gradient"))
        so->ao.method = SPC_ANGULAR_GRADIENT;
    else if (!strcmp(method, "levenberg_marquardt"))
        so->ao.method = SPC_ANGULAR_LEVENBERG_MARQUARDT;
    else
        return bad(r, "unknown method '%s' (gauss_newton, gradient, levenberg_marquardt)", method);
    if (!strcmp(loss, "plane"))
        so->ao.loss = SPC_ANGULAR_LOSS_PLANE;
    else if (!strcmp(loss, "segment"))
        so->ao.loss = SPC_ANGULAR_LOSS_SEGMENT;
    else
        return bad(r, "unknown loss '%s' (plane, segment)", loss);
    so->h = FD_STEP_DEFAULT;
    return get_int(r, r->root, "max_iterations", 1, SPC_EXPLORE_MAX_TRACE, &so->ao.max_iterations) &&
           get_num(r, r->root, "fd_step", 1e-9, 1e-2, false, &so->h);
}

static int handle_solve(const spc_explorer *ex, req *r, char **response)
{
    const spc_scene *sc = ex->sc;
    const char *solver = get_str(r, r->root, "solver", "angular");
    if (!solver)
        return 400;
    bool want[NSOLVER_NAMES] = {false};
    bool all = !strcmp(solver, "all");
    int nwant = 0;
    for (int i = 0; i < NSOLVER_NAMES; ++i)
        if (all || !strcmp(solver, solver_names[i]))
            want[i] = true, ++nwant;
    if (!nwant)
        return bad(r, "unknown solver '%s' (angular, newton, conic, exact, all)", solver), 400;
    double limit = TIME_LIMIT_DEFAULT;
    solve_opts so;
    if (!get_num(r, r->root, "time_limit", 0.001, SPC_EXPLORE_MAX_TIME, false, &limit) || !read_angular(r, &so))
        return 400;
    problem pb;
    int st = read_problem(sc, r, want[1] && !want[0] ? SPC_SNEE_NEWTON : SPC_SNEE_ANGULAR, &pb);
    if (st)
        return st;
    pb.params.angular.trace = NULL;
    if (!read_seed(r, &pb, &so.seed, &so.straight))
        return r->bad ? 400 : 422;
    spc_jbuf b = {0};
    spc_jbuf_raw(&b, "{\"receiver\":{\"point\":");
    jvec3(&b, pb.x.p);
    spc_jbuf_raw(&b, ",\"normal\":");
    jvec3(&b, pb.x.sh.n);
    spc_jbuf_printf(&b, ",\"shape\":%d},\"light\":{\"point\":", pb.x.shape_index);
    jvec3(&b, pb.q.y);
    spc_jbuf_raw(&b, ",\"normal\":");
    jvec3(&b, pb.q.ny);
    spc_jbuf_printf(&b, ",\"emitter\":%d,\"size\":", pb.e ? pb.e->index : -1);
    spc_jbuf_num(&b, pb.q.light_size);
    spc_jbuf_raw(&b, ",\"pdf\":");
    spc_jbuf_num(&b, pb.p_y);
    spc_jbuf_raw(&b, "},\"runs\":[");
    double t0 = now_s();
    bool first = true, timed_out = false;
    for (int i = 0; i < NSOLVER_NAMES; ++i) {
        if (!want[i])
            continue;
        if (now_s() - t0 > limit) {
            timed_out = true;
            break;
        }
        if (!first)
            spc_jbuf_raw(&b, ",");
        first = false;
        if (i == 0)
            run_angular(&b, sc, &pb, &so);
        else if (i == 1)
            run_newton(&b, sc, &pb, &so);
        else
            run_all(&b, sc, &pb, i == 2);
    }
    spc_jbuf_printf(&b, "],\"timed_out\":%s}", timed_out ? "true" : "false");
    return finish(&b, 200, response);
}

/* ---- POST /api/lossmap ---- */

static int handle_lossmap(const spc_explorer *ex, req *r, char **response)
{
    const spc_scene *sc = ex->sc;
    solve_opts so;
    int n = 64;
    double extent = 0.3, limit = TIME_LIMIT_DEFAULT;
    bool basins = false;
    if (!read_angular(r, &so) || !get_int(r, r->root, "size", 4, SPC_EXPLORE_MAX_MAP, &n) ||
        !get_bool(r, r->root, "basins", &basins) || !get_num(r, r->root, "extent", 1e-6, 2.0, false, &extent) ||
        !get_num(r, r->root, "time_limit", 0.001, SPC_EXPLORE_MAX_TIME, false, &limit))
        return 400;
    problem pb;
    int st = read_problem(sc, r, SPC_SNEE_ANGULAR, &pb);
    if (st)
        return st;
    if (!read_seed(r, &pb, &so.seed, &so.straight))
        return r->bad ? 400 : 422;
    spc_frame fr = spc_frame_from_n(so.seed);
    spc_chain_opts o = spc_chain_opts_default(pb.max_chain);
    /* c: the cell's chain; with basins, sol[0..nsol) the distinct solutions found and sol[nsol]
     * the scratch of each cell's solve */
    spc_chain *c = malloc((MAX_SOLUTIONS + 2) * sizeof *c), *sol = c + 1;
    int nsol = 0;
    spc_jbuf b = {0};
    if (!c)
        return error_response(500, "out of memory", response);
    spc_jbuf_printf(&b, "{\"size\":%d,\"extent\":", n);
    spc_jbuf_num(&b, extent);
    spc_jbuf_raw(&b, ",\"frame\":{\"s\":");
    jvec3(&b, fr.s);
    spc_jbuf_raw(&b, ",\"t\":");
    jvec3(&b, fr.t);
    spc_jbuf_raw(&b, ",\"n\":");
    jvec3(&b, fr.n);
    spc_jbuf_raw(&b, "},\"loss\":[");
    /* cells row by row, b (t) from -extent to extent, a (s) within a row; the signature of each
     * cell's chain as a small id, so the page can show where the chain's surfaces change */
    spc_chain_sig sigs[32];
    int nsig = 0;
    int *sig_id = malloc(2 * (size_t)n * n * sizeof *sig_id), *basin = sig_id + (size_t)n * n;
    if (!sig_id) {
        free(c);
        return error_response(500, "out of memory", response);
    }
    double t0 = now_s();
    bool timed_out = false;
    int done = 0;
    for (int j = 0; j < n && !timed_out; ++j) {
        for (int i = 0; i < n; ++i) {
            double a = extent * (2.0 * (i + 0.5) / n - 1.0), bb = extent * (2.0 * (j + 0.5) / n - 1.0);
            spc_chain_trace(sc, &pb.x, &fr, a, bb, &o, c);
            double L = NAN;
            int id = -1;
            if (chain_usable(c)) {
                spc_vec3 rr, J[2];
                spc_angular_residual(c, &pb.tg, so.ao.loss, &rr, J);
                L = spc_length2(rr);
                spc_chain_sig sg;
                spc_chain_signature(c, &sg);
                for (int k = 0; k < nsig && id < 0; ++k)
                    if (spc_chain_sig_equal(&sigs[k], &sg))
                        id = k;
                if (id < 0 && nsig < 32) {
                    sigs[nsig] = sg;
                    id = nsig++;
                }
            }
            sig_id[j * n + i] = id;
            if (basins) {
                /* the basin of attraction: which solution the solver reaches from this direction */
                spc_vec3 dd[2];
                spc_vec3 dir = spc_chain_direction(&fr, a, bb, dd);
                spc_angular_result res;
                int bid = -1;
                if (spc_angular_solve(sc, &pb.x, &pb.tg, dir, &o, &so.ao, &sol[nsol], &res)) {
                    for (int k = 0; k < nsol && bid < 0; ++k)
                        if (spc_snee_same_solution(&sol[k], &sol[nsol], sc->radius))
                            bid = k;
                    if (bid < 0 && nsol < MAX_SOLUTIONS)
                        bid = nsol++;
                }
                basin[j * n + i] = bid;
            }
            if (done++)
                spc_jbuf_raw(&b, ",");
            if (isfinite(L))
                spc_jbuf_printf(&b, "%.6g", L);
            else
                spc_jbuf_raw(&b, "null");
        }
        timed_out = now_s() - t0 > limit;
    }
    spc_jbuf_raw(&b, "],\"signature\":[");
    for (int k = 0; k < done; ++k)
        spc_jbuf_printf(&b, "%s%d", k ? "," : "", sig_id[k]);
    spc_jbuf_raw(&b, "]");
    if (basins) {
        spc_jbuf_raw(&b, ",\"basin\":[");
        for (int k = 0; k < done; ++k)
            spc_jbuf_printf(&b, "%s%d", k ? "," : "", basin[k]);
        spc_jbuf_raw(&b, "],\"solutions\":[");
        for (int k = 0; k < nsol; ++k) {
            if (k)
                spc_jbuf_raw(&b, ",");
            jvec3(&b, sol[k].d0);
        }
        spc_jbuf_raw(&b, "]");
    }
    spc_jbuf_printf(&b, ",\"rows\":%d,\"timed_out\":%s}", done / n, timed_out ? "true" : "false");
    free(sig_id);
    free(c);
    return finish(&b, 200, response);
}

/* ---- dispatch ---- */

int spc_explore_handle(spc_explorer *ex, const char *method, const char *path, const char *body, size_t len,
                       char **response)
{
    *response = NULL;
    if (!ex || !method || !path)
        return error_response(500, "no explorer", response);
    bool get = !strcmp(method, "GET"), post = !strcmp(method, "POST");
    if (!strcmp(path, "/api/scene")) {
        if (!get)
            return error_response(405, "use GET for /api/scene", response);
        return handle_scene(ex, response);
    }
    bool solve = !strcmp(path, "/api/solve"), lossmap = !strcmp(path, "/api/lossmap");
    if (!solve && !lossmap)
        return error_response(404, "no such API path (/api/scene, /api/solve, /api/lossmap)", response);
    if (!post)
        return error_response(405, "use POST with a JSON body", response);
    if (len > SPC_EXPLORE_MAX_BODY)
        return error_response(413, "request body too large", response);
    spc_json_doc doc;
    req r;
    memset(&r, 0, sizeof r);
    if (!spc_json_parse(body ? body : "", body ? len : 0, &doc, r.msg, sizeof r.msg)) {
        spc_json_doc_release(&doc);
        return error_response(400, r.msg[0] ? r.msg : "malformed JSON", response);
    }
    r.d = &doc;
    r.root = &doc.nodes[0];
    int status;
    if (r.root->type != SPC_JSON_OBJECT) {
        status = 400;
        bad(&r, "%s", "the body must be a JSON object");
    } else {
        status = solve ? handle_solve(ex, &r, response) : handle_lossmap(ex, &r, response);
    }
    spc_json_doc_release(&doc);
    if (status >= 400 && !*response)
        return error_response(status, r.msg[0] ? r.msg : "bad request", response);
    return status;
}
