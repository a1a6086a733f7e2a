/*
 * tests/test_sdf_chain_mis.c: the MIS weight of the longer chains through a signed distance field
 * (specular_nee.c, long_attempt_psi), on the glass SDF torus (scenes/caustic_sdf_torus.xml).
 *
 * - At the floor point of that scene's worst seed (a pixel at the image's lower-left corner), the
 *   paths that leave it toward the torus and reach the light through 3 or more torus vertices (a
 *   ray reflected inside the tube) keep a small MIS weight on the BSDF side: mean below 0.004 and
 *   none above 0.02 (0.0002 and 0.0009 measured; with the stand-in psi's 0.1 on the long pass,
 *   0.020 and 0.084, and the render's firefly was such a path at weight 0.59 holding its value
 *   f / b, about 370).
 * - At floor points under and beside the torus, specular NEE plus the BSDF-sampled paths it covers
 *   (chains up to 6 vertices, weighted by spc_snee_mis_bsdf_weight) agree with BSDF sampling alone
 *   (every path weight 1, no specular NEE): |z| < 4 at every point; the same with nine in ten of
 *   the randomized attempts seeded from the tube spheres (fitshare=0.9).
 * - The light's glints seen from the camera (one reflection off the torus; query from the camera):
 *   the camera rays that reach the light through them are weighed with the randomized attempts'
 *   real solve probability (solve_mis), not the stand-in psi: the weight, a sampled 1 - r^N, lies
 *   in [0, 1] and differs from the stand-in's power heuristic on most such rays (with the stand-in,
 *   specular NEE's trial count put one splat of 1,100 on a pixel of 0.7: bench/RESULTS.md, "The
 *   SDF torus's tails traced on fresh seeds").
 */
/* ctest-labels: stat */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/rng.h"
#include "core/warp.h"
#include "chain_mis.h"
#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "scene/camera.h"
#include "specula/specula.h"

#define SCENE "scenes/caustic_sdf_torus.xml"

TEST(long_chain_weight)
{
    spc_scene *sc = chain_mis_load(SCENE, NULL, NULL);
    if (!sc)
        return;
    spc_snee_params p;
    chain_mis_default_params(&p);
    /* the floor point seen in pixel (30, 3) of 32x32, and the direction to the camera */
    spc_hit x;
    CHECK(chain_mis_floor_point(sc, 0, -1.104, 1.734, &x));
    spc_vec3 wo = spc_normalize(spc_sub(spc_v3(0.0, 3.2, 4.2), x.p));
    /* directions toward the torus's bounding sphere (centre (0, 0.64, 0), radius 1.08): the weight is a
     * function of the path, whatever drew its first direction */
    int n;
    double wsum, wmax;
    chain_mis_long_weights(sc, &p, &x, wo, spc_v3(0.0, 0.64, 0.0), 1.1, 100000, INT_MAX, false, &n, &wsum, &wmax);
    printf("    %d paths through 3+ torus vertices: mean weight %.4f, largest %.4f\n", n, n ? wsum / n : 0.0, wmax);
    CHECK(n >= 5);
    CHECK_MSG(n > 0 && wsum / n < 0.004, "mean weight %.4f", n ? wsum / n : 0.0);
    CHECK_MSG(wmax < 0.02, "largest weight %.4f", wmax);
    spc_scene_destroy(sc);
}

TEST(weighted_sum_agrees_with_bsdf_sampling)
{
    static const double pts[4][2] = {{-1.104, 1.734}, {-0.45, 0.0}, {0.0, -0.45}, {0.9, 0.0}};
    chain_mis_check_agrees(SCENE, NULL, NULL, 0, pts, 4, spc_v3(0.0, 3.2, 4.2), 30000);
}

/* With a larger share of the randomized attempts seeded from the torus's tube spheres (fitshare: the
 * attempts' seed mixture changes, and with it the solve probability the BSDF side's weight takes),
 * specular NEE plus the weighted BSDF-sampled paths still agree with BSDF sampling alone at the
 * same floor points: the option moves the weights, not their sum. The option parses in (0, 1]. */
TEST(fit_share_weights_sum)
{
    spc_snee_params p;
    CHECK(spc_snee_parse("angular:fitshare=0.9", 2, &p));
    CHECK(p.fit_share == 0.9);
    CHECK(!spc_snee_parse("angular:fitshare=0", 2, &p));
    CHECK(!spc_snee_parse("angular:fitshare=1.5", 2, &p));
    spc_scene *sc = chain_mis_load(SCENE, NULL, NULL);
    if (!sc)
        return;
    CHECK(spc_snee_parse("angular:fitshare=0.9", 2, &p));
    p.mis = true;
    static const double pts[4][2] = {{-1.104, 1.734}, {-0.45, 0.0}, {0.0, -0.45}, {0.9, 0.0}};
    double zmax = chain_mis_zmax(sc, &p, 0, pts, 4, spc_v3(0.0, 3.2, 4.2), 30000);
    CHECK_MSG(zmax < 4.0, "|z| %.2f", zmax);
    spc_scene_destroy(sc);
}

TEST(camera_glint_weight_sampled)
{
    /* the light 3.75x wider (power kept): its glints cover more of the image */
    spc_scene *sc = chain_mis_load(SCENE, "0.3", "28.4, 27.0, 24.2");
    if (!sc)
        return;
    spc_camera_state cs;
    CHECK(spc_camera_prepare(&cs, &sc->camera, 32, 32));
    spc_snee_params p, ps;
    CHECK(spc_snee_parse("angular:camera", 2, &p));
    CHECK(spc_snee_parse("angular:camera,nosolvemis", 2, &ps));
    p.mis = ps.mis = true;
    spc_rng u;
    spc_rng_seed(&u, 7, 1);
    int n = 0, differ = 0;
    double wmin = 1.0, wmax = 0.0;
    for (int i = 0; i < 400000 && n < 40; ++i) {
        spc_ray r = spc_camera_ray(&cs, 32.0 * spc_rng_next(&u), 32.0 * spc_rng_next(&u));
        spc_hit h, l;
        if (!spc_scene_intersect(sc, &r, &h) || h.shape_index != 1)
            continue;
        /* the mirror direction at the torus, as the glass's reflection lobe has it */
        spc_vec3 wo = spc_neg(r.d);
        spc_vec3 wi = spc_sub(spc_scale(h.sh.n, 2.0 * spc_dot(wo, h.sh.n)), wo);
        spc_ray r2 = spc_hit_spawn(&h, wi);
        if (!spc_scene_intersect(sc, &r2, &l) || !l.emitter)
            continue;
        unsigned char ev[1] = {SPC_CHAIN_REFLECT};
        double w = spc_snee_camera_bsdf_weight(sc, &p, &cs, 1.0, r.d, 2, 1, ev, &l);
        double w_standin = spc_snee_camera_bsdf_weight(sc, &ps, &cs, 1.0, r.d, 2, 1, ev, &l);
        ++n;
        differ += fabs(w - w_standin) > 1e-6;
        wmin = w < wmin ? w : wmin;
        wmax = w > wmax ? w : wmax;
    }
    printf("    %d camera rays to the light by one reflection: weight in [%.3g, %.3g], %d differ from the "
           "stand-in's\n",
           n, wmin, wmax, differ);
    CHECK(n >= 20);
    CHECK(wmin >= 0.0 && wmax <= 1.0);
    CHECK_MSG(differ * 2 > n, "%d of %d weights differ from the stand-in's", differ, n);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(long_chain_weight);
    RUN(weighted_sum_agrees_with_bsdf_sampling);
    RUN(fit_share_weights_sum);
    RUN(camera_glint_weight_sampled);
    return spc_test_finish();
}
