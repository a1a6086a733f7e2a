/*
 * tests/test_path_lt_sdf.c: the light-traced caustics of area lights through a glass SDF
 * (integrator/path_lt.h, specular NEE's "ltcaus"), on scenes/caustic_sdf_torus.xml (a glass torus as
 * a signed distance field over a floor under a small sphere light).
 *
 * - The light subpaths refracted through the torus reach the floor and join the pinhole there
 *   (directly, and from the floor point a diffuse bounce reaches); every join's chain lies on the
 *   torus, and its weight is the share the path tracer's side leaves to light tracing at x2: the
 *   BSDF side's weights there (spc_snee_receiver_weights with the camera side's ratio) give light
 *   tracing's part equal to the join's weight, and BSDF sampling's own part and light tracing's
 *   are non-negative and sum to at most one (the rest is specular NEE's, whose randomized attempts
 *   are weighed with their sampled solve probability, solve_mis.h: the three sum to one in
 *   expectation). Light tracing takes the larger share on some joins (near the caustic's fold).
 * - Renders with ltcaus agree with --specular-nee none (per-pixel z-test, image mean) under a larger
 *   light, with the camera-side split and its receiver sample (camrecv=1, every class D path), whose
 *   rays keep the camera path's record of its scatterings with ltcaus on.
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "harness.h"
#include "integrator/path_lt.h"
#include "manifold/snee_cost.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "path_lt_util.h"
#include "render_util.h"

#define TORUS "scenes/caustic_sdf_torus.xml"
/* the torus's plan (specula info) without its ltcaus */
#define TORUS_PLAN "angular:camera,first=0.1,later=0.1,ltguide,nolong"

typedef struct sdf_tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    int joins, kinds[2], off_torus, by_length[SPC_CHAIN_MAX_VERTICES + 1];
    int above, below;
    double worst_gap, worst_sum;
} sdf_tally;

static void check_sdf_join(void *user, const spc_path_lt_join *j)
{
    sdf_tally *t = user;
    const spc_scene *sc = t->ctx->scene;
    ++t->joins;
    ++t->kinds[j->x1 ? 1 : 0];
    CHECK_MSG(j->e->type == SPC_EMITTER_AREA && j->w > 0.0 && !j->cc, "a join of weight %.17g", j->w);
    for (int i = 0; i < j->c->n; ++i)
        t->off_torus += !j->c->v[i].h.shape || j->c->v[i].h.shape->type != SPC_SHAPE_SDF;
    if (j->c->n <= SPC_CHAIN_MAX_VERTICES)
        ++t->by_length[j->c->n];
    int segments = j->x1 ? 2 : 1;
    int kmax = spc_path_lt_budget(t->ctx, t->p, j->x2, segments, j->x1 ? 1 : 0);
    int kflat = spc_path_lt_flat_budget(t->ctx, t->p, j->x2, segments, j->x1 ? 1 : 0);
    CHECK(j->c->n <= spc_path_lt_area_chain_max(t->p, j->c, kmax, kflat));
    area_cam side = {t->ctx, t->p, j, kmax, kflat};
    spc_snee_params pp = *t->p;
    pp.mis = true;
    pp.query_p = j->x1 ? spc_snee_later_prob(sc, t->p, j->x2->p) : spc_snee_first_prob(sc, t->p, j->x2->p);
    pp.alt_chain_ratio = area_cam_ratio;
    pp.alt_user = &side;
    double w_alt;
    double w_own = join_receiver_weights(sc, &pp, j, kmax, &w_alt);
    double gap = fabs(w_alt - j->w);
    if (gap > t->worst_gap)
        t->worst_gap = gap;
    CHECK_MSG(w_own >= 0.0 && w_alt >= 0.0, "weights %.17g %.17g", w_own, w_alt);
    if (w_own + w_alt > t->worst_sum)
        t->worst_sum = w_own + w_alt;
    t->above += j->w > 0.5;
    t->below += j->w < 0.5;
}

TEST(joins_on_the_torus_weigh_as_the_path_side)
{
    spc_scene *sc = tu_load(TORUS, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_camera_state cam;
    spc_snee_params p;
    CHECK(spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height));
    CHECK(spc_snee_parse(TORUS_PLAN ",ltcaus", 2, &p));
    p.lt_share = 1.0;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_enabled(&ctx, &p) && spc_path_lt_area_enabled(&p));
    sdf_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    spc_rng rng;
    spc_rng_seed(&rng, 71, 7);
    int n = spc_test_quick() ? 4000 : 10000;
    for (int i = 0; i < n; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_sdf_join, &t);
    printf("  %s: %d joins of %d subpaths (directly %d, through a diffuse bounce %d; chains of 1, 2, 3, 4 "
           "vertices %d %d %d %d), light tracing's weight above 1/2 on %d, below on %d; largest gap of its weight "
           "from the path side's %.3g, largest sum of BSDF sampling's and light tracing's %.6f\n",
           TORUS, t.joins, n, t.kinds[0], t.kinds[1], t.by_length[1], t.by_length[2], t.by_length[3], t.by_length[4],
           t.above, t.below, t.worst_gap, t.worst_sum);
    /* about 7% of the subpaths join, 6% of those through a diffuse bounce: the bounds scale with n */
    CHECK(t.joins > n / 100 && t.kinds[0] > n / 200 && t.kinds[1] > n / 1000);
    CHECK(t.by_length[2] > n / 200);
    CHECK(t.off_torus == 0);
    CHECK_MSG(t.worst_gap < 1e-9, "light tracing's weight against the path side's: gap %.3g", t.worst_gap);
    CHECK(t.worst_sum <= 1.0 + 1e-9);
    CHECK(t.above > 0 && t.below > 0);
    spc_scene_destroy(sc);
}

/* The torus under a sphere light of radius 0.3 (power kept), at res x res: none converges at a
 * test's spp there. */
static spc_scene *torus_large_light(int res)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    char path[1024], r[16];
    snprintf(path, sizeof path, "%s/%s", d ? d : ".", TORUS);
    snprintf(r, sizeof r, "%d", res);
    spc_define defs[3] = {{"res", r}, {"light_radius", "0.3"}, {"light_radiance", "28.44, 27.02, 24.18"}};
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_scene_load(path, defs, 3, &sc, &err) != SPC_OK)
        return NULL;
    return sc;
}

static void agrees_with_none(const char *setting, int spp, uint64_t seed, const char *label)
{
    int q = spc_test_quick() ? 2 : 1;
    spc_scene *sc = torus_large_light(16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(tu_settings_agree(sc, setting, spp / q, "none", 4096 / q, seed, label));
    spc_scene_destroy(sc);
}

TEST(render_agrees_with_none)
{
    agrees_with_none(TORUS_PLAN ",camsplit=4,camrecv=1,ltcaus", 256, 81, "torus, large light, ltcaus and camrecv=1");
}

int main(void)
{
    RUN(joins_on_the_torus_weigh_as_the_path_side);
    RUN(render_agrees_with_none);
    return spc_test_finish();
}
