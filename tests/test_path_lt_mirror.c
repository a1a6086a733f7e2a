/*
 * tests/test_path_lt_mirror.c: the light-traced caustics of area lights off a mirror ball through
 * glass (integrator/path_lt.h, specular NEE's "ltcaus"): the light reflected by the mirror ball,
 * refracted through a glass ball (scenes/demo.xml) or a glass cube (scenes/caustic_glass_cube.xml),
 * onto a diffuse receiver x2, joined to the pinhole.
 *
 * - Such joins occur (chains of at least three vertices: the glass's, then the mirror ball's
 *   reflection), and on each light tracing's weight is the share the path tracer's side leaves to it
 *   at x2: the BSDF side's weights there (spc_snee_receiver_weights with the camera side's ratio)
 *   give light tracing's part equal to the join's weight, and BSDF sampling's own part and light
 *   tracing's are non-negative and sum to at most one (the rest is specular NEE's, whose longer
 *   chains' randomized attempts count these chains by trials). Light tracing takes the larger share
 *   on some joins.
 * - A render of the demo with ltcaus agrees with one without (the same estimator's two splits) by
 *   the per-pixel z-test and the image mean.
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

#define DEMO "scenes/demo.xml"
/* the demo's plan (specula info) without its caustic guide at receivers, which turns area lights'
 * light tracing off */
#define DEMO_PLAN "angular:camera=0.022,first=0.1,later=0.1,long=0.2"
#define CUBE "scenes/caustic_glass_cube.xml"
/* the cube's plan (specula info), light tracing included */
#define CUBE_PLAN                                                                                                      \
    "angular:camera=0.03,first=0.1,later=0.1,long=0.3,flat5=1,first=1,ltcaus,flat34=0.3,flat5=0.3,longmax=8"

typedef struct mirror_tally {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    int joins, mirror, kinds[3], by_length[SPC_CHAIN_MAX_VERTICES + 1];
    int above, below;
    double worst_gap, worst_sum;
} mirror_tally;

/* Is the join's light chain one off the mirror ball through glass (its last vertex a reflection off
 * a conductor sphere, the others on one dielectric shape)? */
static bool mirror_join(const spc_path_lt_join *j)
{
    int k = j->c->n;
    if (k < 3)
        return false;
    const spc_shape *m = j->c->v[k - 1].h.shape, *g = j->c->v[0].h.shape;
    if (!m || m->type != SPC_SHAPE_SPHERE || !m->bsdf || m->bsdf->type != SPC_BSDF_CONDUCTOR || !g || !g->bsdf ||
        g->bsdf->type != SPC_BSDF_DIELECTRIC)
        return false;
    for (int i = 0; i < k - 1; ++i)
        if (j->c->v[i].h.shape != g)
            return false;
    return true;
}

static void check_mirror_join(void *user, const spc_path_lt_join *j)
{
    mirror_tally *t = user;
    const spc_scene *sc = t->ctx->scene;
    ++t->joins;
    if (!mirror_join(j))
        return;
    ++t->mirror;
    ++t->kinds[j->x1 ? 2 : j->cc ? 1 : 0];
    if (j->c->n <= SPC_CHAIN_MAX_VERTICES)
        ++t->by_length[j->c->n];
    CHECK_MSG(j->e->type == SPC_EMITTER_AREA && j->w > 0.0 && j->w <= 1.0, "a join of weight %.17g", j->w);
    int segments = j->x1 ? 2 : j->cc ? j->cc->n + 1 : 1;
    int kmax = spc_path_lt_budget(t->ctx, t->p, j->x2, segments, j->x1 ? 1 : 0);
    int kflat = spc_path_lt_flat_budget(t->ctx, t->p, j->x2, segments, j->x1 ? 1 : 0);
    CHECK(j->c->n > kmax && j->c->n <= spc_path_lt_area_chain_max(t->p, j->c, kmax, kflat));
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

/* n light subpaths on the scene under the setting (every camera sample's), tallied; at least
 * min_joins of them off the mirror ball through glass. */
static void mirror_joins(const char *scene, const char *setting, uint64_t seed, int n, int min_joins)
{
    spc_scene *sc = tu_load(scene, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_camera_state cam;
    spc_snee_params p;
    CHECK(spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height));
    CHECK(spc_snee_parse(setting, 2, &p));
    p.lt_share = 1.0;
    spc_render_ctx ctx = lt_ctx(sc, &cam, &p);
    CHECK(spc_path_lt_enabled(&ctx, &p) && spc_path_lt_area_enabled(&p));
    mirror_tally t;
    memset(&t, 0, sizeof t);
    t.ctx = &ctx;
    t.p = &p;
    spc_rng rng;
    spc_rng_seed(&rng, seed, 7);
    for (int i = 0; i < n; ++i)
        spc_path_lt_joins(&ctx, &p, &rng, check_mirror_join, &t);
    printf("  %s: %d joins of %d subpaths, %d off the mirror ball through glass (directly %d, through the ball %d, "
           "through a diffuse bounce %d; chains of 3, 4, 5 vertices %d %d %d), light tracing's weight above 1/2 on "
           "%d, below on %d; largest gap of its weight from the path side's %.3g, largest sum of BSDF sampling's "
           "and light tracing's %.6f\n",
           scene, t.joins, n, t.mirror, t.kinds[0], t.kinds[1], t.kinds[2], t.by_length[3], t.by_length[4],
           t.by_length[5], t.above, t.below, t.worst_gap, t.worst_sum);
    CHECK_MSG(t.mirror >= min_joins, "joins off the mirror ball through glass: %d of %d subpaths", t.mirror, n);
    CHECK_MSG(t.worst_gap < 1e-9, "light tracing's weight against the path side's: gap %.3g", t.worst_gap);
    CHECK(t.worst_sum <= 1.0 + 1e-9);
    CHECK(t.above > 0);
    spc_scene_destroy(sc);
}

TEST(demo_joins_weigh_as_the_path_side)
{
    /* 0.8% of the subpaths join off the mirror ball through the glass ball */
    int n = spc_test_quick() ? 10000 : 40000;
    mirror_joins(DEMO, DEMO_PLAN ",ltcaus", 91, n, n / 400);
}

/* The cube's: 1.5e-4 of the subpaths (the cone toward the casters is mostly the cube's) */
TEST(cube_joins_weigh_as_the_path_side) { mirror_joins(CUBE, CUBE_PLAN, 93, 40000, 2); }

TEST(demo_render_agrees_without_it)
{
    int q = spc_test_quick() ? 2 : 1;
    spc_scene *sc = tu_load(DEMO, 16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(tu_settings_agree(sc, DEMO_PLAN ",ltcaus", 1024 / q, DEMO_PLAN, 1024 / q, 95, "demo: ltcaus vs without"));
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(demo_joins_weigh_as_the_path_side);
    RUN(cube_joins_weigh_as_the_path_side);
    RUN(demo_render_agrees_without_it);
    return spc_test_finish();
}
