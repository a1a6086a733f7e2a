/*
 * tests/test_path_lt_view.c: the area light seen from the camera through flat glass, by light
 * tracing (integrator/path_lt_view.h, specular NEE's "ltview"), on bench/check/slab_light_view.xml
 * (a small square light seen by the camera through a glass slab: T T and, after a partial
 * reflection off the slab's far face inside it, T R T).
 *
 * - The enumeration's partial reflections: from the light point to the pinhole it finds chains with
 *   a reflection off glass inside them, which spc_flat_chains_all (total reflections only) does not.
 * - Every join is a path the camera ray makes: the ray from the pinhole through the chain's last
 *   vertex, traced with the chain's events, reaches the light at the join's light point (within
 *   1e-6 of the scene), and the camera ray's weight there (spc_path_lt_view_camera_weight, from its
 *   own retrace, with specular NEE from the pinhole's weight of that camera path, which is 1 on
 *   every join) and the join's sum to one within 1e-6 (2e-14 measured). The joins are the T R T
 *   chains (the T T and R ones specular NEE from the pinhole weighs: not shared here), and light
 *   tracing takes the larger share of them (r > 1).
 * - Where specular NEE from the pinhole weighs the path (a weight below 1), the camera ray's weight is
 *   left as it is.
 * - A render with ltview agrees with one with --specular-nee none (z-test, image mean); with ltview
 *   on every sample (ltview=1) beside the camera query and ltcaus too.
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "harness.h"
#include "integrator/path_lt_view.h"
#include "manifold/flat_chains.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "render_util.h"

#define SCENE "bench/check/slab_light_view.xml"
/* the plan's setting for the scene (specula info; its flat5=1 left out, a later flat5 overrides it) */
#define PLAN "angular:camera=0.025,first=0.1,later=0.1,long=0.3,ltcaus,flat34=0.3,flat5=0.3,longmax=8"

static spc_scene *view_load(spc_camera_state *cam, spc_snee_params *p, const char *setting)
{
    spc_scene *sc = tu_load(SCENE, 16);
    CHECK(sc != NULL);
    if (!sc)
        return NULL;
    CHECK(spc_camera_prepare(cam, &sc->camera, sc->film.width, sc->film.height));
    CHECK(spc_snee_parse(setting, 2, p));
    return sc;
}

static spc_render_ctx view_ctx(spc_scene *sc, spc_camera_state *cam, const spc_snee_params *p)
{
    spc_render_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = sc;
    ctx.cam = cam;
    ctx.kind = SPC_INTEGRATOR_PATH;
    ctx.max_depth = sc->integrator.max_depth;
    ctx.rr_depth = 5;
    ctx.specular_nee = SPC_SNEE_ANGULAR;
    ctx.specular_max_chain = 2;
    ctx.snee = *p;
    ctx.width = sc->film.width;
    ctx.height = sc->film.height;
    return ctx;
}

typedef struct view_tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    int joins, by_len[SPC_PATH_LT_VIEW_MAX_CHAIN + 1], reflect, above, below, unreached, query_shared;
    double worst_gap, worst_light;
} view_tally;

static void check_view_join(void *user, const spc_path_lt_view_join *j)
{
    view_tally *t = user;
    const spc_scene *sc = t->ctx->scene;
    const spc_chain *cc = j->cc;
    int k = cc->n;
    ++t->joins;
    ++t->by_len[k];
    unsigned char ev[SPC_PATH_LT_VIEW_MAX_CHAIN];
    bool refl = false;
    for (int i = 0; i < k; ++i) {
        ev[i] = cc->v[k - 1 - i].event; /* the camera's order */
        refl = refl || ev[i] == SPC_CHAIN_REFLECT;
    }
    t->reflect += refl;
    if (j->r > 1.0)
        ++t->above;
    else
        ++t->below;
    /* the camera ray through the chain's last vertex, followed with the chain's events */
    spc_vec3 o = t->ctx->cam->origin;
    spc_vec3 d = spc_normalize(spc_sub(cc->v[k - 1].h.p, o));
    spc_frame f = spc_frame_from_n(d);
    spc_hit start;
    memset(&start, 0, sizeof start);
    start.p = o;
    start.ng = d;
    start.err = 1e-9;
    spc_chain_opts opt = spc_chain_opts_default(k);
    opt.events = ev;
    opt.any_surface = t->p->any_surface;
    spc_chain cam;
    spc_chain_trace(sc, &start, &f, 0.0, 0.0, &opt, &cam);
    if (cam.n != k || !cam.has_end_hit || cam.end_hit.emitter != j->e) {
        ++t->unreached;
        return;
    }
    double dl = spc_distance(cam.end_hit.p, j->y) / sc->radius;
    if (dl > t->worst_light)
        t->worst_light = dl;
    /* specular NEE from the pinhole leaves the path to the camera ray: its weight there is 1 */
    spc_snee_params pp = *t->p;
    pp.mis = true;
    double cam_scale =
        (double)t->ctx->cam->width * (double)t->ctx->cam->height / ((double)t->ctx->width * (double)t->ctx->height);
    double w_query = spc_snee_camera_bsdf_weight(sc, &pp, t->ctx->cam, cam_scale, d, t->ctx->specular_max_chain, k, ev,
                                                 &cam.end_hit);
    if (!(w_query == 1.0))
        ++t->query_shared;
    double w_cam = spc_path_lt_view_camera_weight(t->ctx, t->p, &cam.end_hit, cam.v[k - 1].d, k, ev, w_query);
    double gap = fabs(w_cam + j->w - 1.0);
    if (gap > t->worst_gap)
        t->worst_gap = gap;
    /* where another strategy's weight is below 1, the camera ray's stays that */
    CHECK(spc_path_lt_view_camera_weight(t->ctx, t->p, &cam.end_hit, cam.v[k - 1].d, k, ev, 0.5) == 0.5);
}

TEST(partial_reflections_enumerated)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = view_load(&cam, &p, PLAN ",ltview=1");
    if (!sc)
        return;
    /* from the light's centre to the pinhole: the chains with a reflection inside the glass are
     * the partial enumeration's only */
    const spc_emitter *e = NULL;
    for (int i = 0; i < sc->nemitters && !e; ++i)
        if (sc->emitters[i]->type == SPC_EMITTER_AREA)
            e = sc->emitters[i];
    CHECK(e != NULL);
    if (!e) {
        spc_scene_destroy(sc);
        return;
    }
    int partial_only = 0, total_all = 0, partial_all = 0;
    spc_rng rng;
    spc_rng_seed(&rng, 5, 7);
    for (int s = 0; s < 400; ++s) {
        spc_hit yh;
        memset(&yh, 0, sizeof yh);
        spc_vec2 u = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
        spc_shape_sample ss;
        spc_shape_sample_area(e->shape, u, &ss);
        yh.p = ss.p;
        yh.ng = ss.n;
        yh.err = 1e-7;
        spc_snee_query q;
        spc_snee_query_init(&q, sc, &p, &yh, ss.n, SPC_PATH_LT_VIEW_MAX_CHAIN);
        q.y = cam.origin;
        q.light_size = 0.0;
        spc_chain a[16], b[16];
        int na = spc_flat_chains_all(&q, a, 16, NULL), nb = spc_flat_chains_all_partial(&q, false, b, 16, NULL);
        total_all += na;
        partial_all += nb;
        for (int i = 0; i < nb; ++i)
            if (!spc_flat_chain_covers(&b[i], true)) {
                ++partial_only;
                CHECK(spc_flat_chain_faces(&b[i], true));
            }
    }
    printf("  400 light points: %d chains of the enumeration, %d with partial reflections allowed, %d of them with "
           "a partial reflection\n",
           total_all, partial_all, partial_only);
    CHECK(partial_only > 0 && partial_all > total_all);
    spc_scene_destroy(sc);
}

TEST(weights_sum_to_one)
{
    spc_camera_state cam;
    spc_snee_params p;
    spc_scene *sc = view_load(&cam, &p, PLAN ",ltview=1");
    if (!sc)
        return;
    spc_render_ctx ctx = view_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_view_enabled(&ctx, &p));
    view_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    spc_rng rng;
    spc_rng_seed(&rng, 19, 3);
    int draws = spc_test_quick() ? 20000 : 100000;
    for (int i = 0; i < draws; ++i)
        spc_path_lt_view_joins(&ctx, &p, &rng, check_view_join, &t);
    printf("  %d draws: %d joins (1 vertex %d, 2 %d, 3 %d), %d with a reflection, r > 1 on %d, r < 1 on %d; "
           "camera ray not reaching the light point %d, largest light-point distance %.3g of the scene, largest gap "
           "of the two weights' sum from 1 %.3g\n",
           draws, t.joins, t.by_len[1], t.by_len[2], t.by_len[3], t.reflect, t.above, t.below, t.unreached,
           t.worst_light, t.worst_gap);
    CHECK(t.joins > 100 && t.reflect > 10 && t.by_len[3] > 10);
    CHECK(t.above > 0);
    CHECK(t.unreached == 0);
    CHECK_MSG(t.query_shared == 0, "%d joins of paths specular NEE from the pinhole weighs", t.query_shared);
    CHECK(t.worst_light < 1e-6);
    CHECK_MSG(t.worst_gap < 1e-6, "the weights sum to 1 +- %.3g", t.worst_gap);
    spc_scene_destroy(sc);
}

/* path with `with` (seed) against none (seed + 1, spp_none): the images agree by the per-pixel
 * z-test on 0.99 of the pixels and their means within 4 standard errors. */
static void agrees_with_none(const char *with, int spp, int spp_none, uint64_t seed, const char *label)
{
    spc_scene *sc = tu_load(SCENE, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(tu_settings_agree(sc, with, spp, "none", spp_none, seed, label));
    spc_scene_destroy(sc);
}

TEST(render_agrees_with_none)
{
    /* none at 8192 spp in both modes: fewer leave its T R T pixels to a few hits, and its variance
     * there below the truth (4 of 256 pixels failed at 2048) */
    int q = spc_test_quick() ? 2 : 1;
    agrees_with_none(PLAN ",ltview", 512 / q, 8192, 31, "ltview vs none");
    /* on every sample, beside the camera query and light tracing of caustics alone (a setting of at most 95
     * characters: the plan's longer ones are cut there) */
    agrees_with_none("angular:camera=0.025,ltcaus,ltview=1", 512 / q, 8192, 33, "ltview=1 vs none");
}

int main(void)
{
    RUN(partial_reflections_enumerated);
    RUN(weights_sum_to_one);
    RUN(render_agrees_with_none);
    return spc_test_finish();
}
