/*
 * tests/test_sdf_guide_chains.c: specular NEE's longer chains past 6 vertices inside the glass SDF
 * torus (params.long_max and long_events_p, specular_nee.c's long pass), on
 * scenes/caustic_sdf_torus.xml. Light that enters the tube, runs along it by total internal
 * reflection (a light guide) and leaves toward the light makes 7- and 8-vertex chains that only
 * BSDF sampling made before (a single path of value about 445 on a pixel of 0.03-0.16).
 *
 * - At a floor point beside the torus ((-1.6, 1.2): 5 such paths in 600,000 directions), the
 *   BSDF-sampled paths that reach the light through 7 or 8 torus vertices: with
 *   "longmax=8,longev=0.9" specular NEE looks for them, so their MIS weight on the BSDF side is
 *   small (mean below 0.05); with the default longest chain (6) every one keeps weight 1.
 * - The plan does not run them (snee_plan.h: on fresh seeds they added as many tails as they
 *   removed); light tracing takes the light guides there (ltguide).
 * - The scene at 8 x 8 with its light 2.5x wider (power kept), rendered with the torus plan's
 *   setting plus "longmax=8,longev=0.9", agrees with path tracing without specular NEE: per-pixel
 *   z-test (Sidak) on 0.99 of the pixels and the image means within 3 standard errors; so does the
 *   plan's own setting for the torus (the light guides by light tracing, no longer chains' pass).
 */
/* ctest-labels: stat */
/* ctest-timeout: 600 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "manifold/chain.h"
/* the paths and specular NEE's calls of chain_mis.h followed to 8 chain vertices */
#define CHAIN_MIS_LONG_MAX SPC_CHAIN_MAX_VERTICES
#include "chain_mis.h"
#include "manifold/snee_plan.h"
#include "render_util.h"

#define SCENE "scenes/caustic_sdf_torus.xml"
#define GUIDE_SETTING "angular:longmax=8,longev=0.9"
/* the torus plan's setting without (PLAN_SETTING) and with the chains to 8 vertices */
#define PLAN_SETTING "angular:camera,first=0.1,later=0.1"
#define GUIDE_RENDER_SETTING PLAN_SETTING ",longmax=8,longev=0.9"

/* The floor point and the camera of the tests. */
static const double guide_pt[2] = {-1.6, 1.2};
static const spc_vec3 camera = {0.0, 3.2, 4.2};

/* The weights of the paths from x that reach the light through 7 or 8 chain vertices, their first
 * direction uniform in the cone toward the torus's bounding sphere and each dielectric's lobe
 * chosen with probability 1/2: *n paths, *wsum and *wmax the sum and largest of their weights. */
static void guide_weights(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo, int draws,
                          int *n, double *wsum, double *wmax)
{
    spc_vec3 centre = spc_v3(0.0, 0.64, 0.0);
    spc_vec3 axis = spc_sub(centre, x->p);
    double dist = spc_length(axis), cos_max = sqrt(1.0 - 1.1 * 1.1 / (dist * dist));
    spc_frame fr = spc_frame_from_n(spc_scale(axis, 1.0 / dist));
    spc_rng u;
    spc_rng_seed(&u, 5, 3);
    *n = 0;
    *wsum = *wmax = 0.0;
    for (int i = 0; i < draws; ++i) {
        spc_vec3 d0 =
            spc_frame_to_world(&fr, spc_warp_uniform_cone(spc_v2(spc_rng_next(&u), spc_rng_next(&u)), cos_max));
        if (!(spc_dot(d0, x->ng) > 0.0))
            continue;
        int k;
        double w;
        chain_mis_trace_from(sc, p, x, wo, d0, SPC_LOBE_DIFFUSE_REFLECTION, spc_rgb1(1.0), false, true, &u, &k, &w);
        if (k >= 7) {
            ++*n;
            *wsum += w;
            *wmax = w > *wmax ? w : *wmax;
        }
    }
}

TEST(guide_chains_weighted)
{
    spc_scene *sc = chain_mis_load(SCENE, NULL, NULL);
    if (!sc)
        return;
    spc_hit x;
    CHECK(chain_mis_floor_point(sc, 0, guide_pt[0], guide_pt[1], &x));
    spc_vec3 wo = spc_normalize(spc_sub(camera, x.p));
    for (int arm = 0; arm < 2; ++arm) {
        spc_snee_params p;
        CHECK(spc_snee_parse(arm ? GUIDE_SETTING : "angular", 2, &p));
        p.mis = true;
        int n;
        double wsum, wmax;
        guide_weights(sc, &p, &x, wo, 600000, &n, &wsum, &wmax);
        printf("    %s: %d paths through 7-8 torus vertices: mean weight %.4f, largest %.4f\n",
               arm ? GUIDE_SETTING : "angular", n, n ? wsum / n : 0.0, wmax);
        CHECK(n >= 3);
        if (arm)
            CHECK_MSG(n > 0 && wsum / n < 0.05, "mean weight %.4f", n ? wsum / n : 0.0);
        else
            CHECK_MSG(n > 0 && wsum == n, "the default's 7-8 vertex paths keep weight 1: mean %.4f",
                      n ? wsum / n : 0.0);
    }
    spc_scene_destroy(sc);
}

TEST(guide_render_agrees)
{
    /* 8 x 8, the light 2.5x wider with its power kept: the long paths less rare */
    const spc_define d[4] = {{"res", "8"}, {"spp", "1"}, {"light_radius", "0.2"}, {"light_radiance", "64, 60.8, 54.4"}};
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    CHECK_MSG(spc_scene_load(SCENE, d, 4, &sc, &err) == SPC_OK, "%s", err.msg);
    if (!sc)
        return;
    spc_film *g = tu_render_nee(sc, "path", GUIDE_RENDER_SETTING, 512, 2, 11, NULL);
    spc_film *plan = tu_render_nee(sc, "path", PLAN_SETTING, 512, 2, 12, NULL);
    spc_film *none = tu_render_nee(sc, "path", "none", 8192, 2, 13, NULL);
    /* the plan's setting as the torus gets it: ltguide, and the longer chains left to BSDF sampling */
    spc_film *own = tu_render_nee(sc, "path", SPC_SNEE_PLAN_SETTING SPC_SNEE_PLAN_LIGHT_GUIDES, 512, 2, 14, NULL);
    CHECK(own);
    if (own && none) {
        spc_diff_result ro;
        memset(&ro, 0, sizeof ro);
        CHECK(tu_image_agrees(own, none, 0.98, "torus, the plan's setting vs none", &ro));
        double mo, so;
        tu_image_mean(own, 1, &mo, &so);
        printf("    the plan's setting (%s, 512 spp): z-test pass %.4f against none; mean %.5f +- %.5f\n",
               SPC_SNEE_PLAN_SETTING SPC_SNEE_PLAN_LIGHT_GUIDES, ro.ztest_pass_fraction, mo, so);
    }
    spc_film_destroy(own);
    CHECK(g && plan && none);
    if (g && plan && none) {
        spc_diff_result r, rn;
        memset(&r, 0, sizeof r);
        memset(&rn, 0, sizeof rn);
        CHECK(tu_image_agrees(g, plan, 0.99, "torus, longmax=8 vs 6", &r));
        /* against none: one pixel of 64, (1, 2), reads 13% high in both settings (z 5.4-5.5) */
        CHECK(tu_image_agrees(g, none, 0.98, "torus, longmax=8 vs none", &rn));
        double mg, sg, mp, sp, mn, sn;
        tu_image_mean(g, 1, &mg, &sg);
        tu_image_mean(plan, 1, &mp, &sp);
        tu_image_mean(none, 1, &mn, &sn);
        printf("    z-test pass %.4f against longmax 6, %.4f against none, of %d pixels; means %.5f +- %.5f "
               "(%s, 512 spp), %.5f +- %.5f (%s, 512 spp), %.5f +- %.5f (none, 8192 spp)\n",
               r.ztest_pass_fraction, rn.ztest_pass_fraction, g->width * g->height, mg, sg, GUIDE_RENDER_SETTING, mp,
               sp, PLAN_SETTING, mn, sn);
    }
    spc_film_destroy(g);
    spc_film_destroy(plan);
    spc_film_destroy(none);
    spc_scene_destroy(sc);
}

TEST(plan_leaves_guide_chains_to_light_tracing)
{
    spc_scene *sc = chain_mis_load(SCENE, NULL, NULL);
    if (!sc)
        return;
    spc_snee_plan plan;
    spc_snee_plan_make(sc, "path", NULL, &plan);
    printf("    plan: %s\n", plan.setting);
    CHECK(plan.on && !strstr(plan.setting, "longmax") && strstr(plan.setting, "ltguide"));
    /* nor the longer chains' pass at all: its counted 3- and 4-vertex chains were the floor's tail */
    spc_snee_params sp;
    CHECK(spc_snee_parse(plan.setting, 2, &sp) && sp.long_p == 0.0);
    spc_snee_plan_make(sc, "volpath", NULL, &plan);
    CHECK(!strstr(plan.setting, "longmax"));
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(plan_leaves_guide_chains_to_light_tracing);
    RUN(guide_chains_weighted);
    RUN(guide_render_agrees);
    return spc_test_finish();
}
