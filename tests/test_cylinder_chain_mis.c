/*
 * tests/test_cylinder_chain_mis.c: the MIS weights of the paths that reach the light through three
 * to six reflections on one mirror cylinder (specular_nee.c, cyl_psi), on
 * scenes/caustic_mirror_ring.xml.
 *
 * Specular NEE's budget there is 2 vertices; where its longer chains run (long_p, the default) it
 * enumerates the cylinder's chains of 3 to 6 reflections on a share of the calls too (psi
 * SPC_CYLINDER_LONG_P), so the BSDF side weights those paths by the power heuristic against specular
 * NEE's density times that share.
 * - At the floor point of that scene's tail (pixel (25, 16) of 32x32, seed 7, whose one sample
 *   floor -> three reflections -> light held 96% of the seed's error), the BSDF-sampled paths
 *   through 3 to 6 cylinder vertices have a mean weight below 0.05 and none above 0.5 (the small
 *   light's density dwarfs the BSDF's even at the share; weight 1, every one, when no pass covers
 *   them).
 * - With a larger light (radius 0.4, the same power), at floor points inside the ring, specular NEE
 *   plus the BSDF-sampled paths it covers (weighted by spc_snee_mis_bsdf_weight) agree with BSDF
 *   sampling alone (every weight 1): |z| < 4 at every point.
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "chain_mis.h"
#include "core/rng.h"
#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "specula/specula.h"

#define SCENE "scenes/caustic_mirror_ring.xml"
#define CAMERA spc_v3(0.3, 3.2, 1.9)
#define FLOOR 1

TEST(three_reflection_weight)
{
    spc_scene *sc = chain_mis_load(SCENE, NULL, NULL);
    if (!sc)
        return;
    spc_snee_params p;
    chain_mis_default_params(&p);
    spc_hit x;
    CHECK(chain_mis_floor_point(sc, FLOOR, 0.787, -0.057, &x));
    spc_vec3 wo = spc_normalize(spc_sub(CAMERA, x.p));
    spc_rng u;
    spc_rng_seed(&u, 5, 1);
    int n3 = 0, nl = 0;
    double w3 = 0.0, wl = 0.0, wmax = 0.0;
    for (int i = 0; i < 400000 && n3 < 100; ++i) {
        int k;
        double w;
        chain_mis_bsdf_path(sc, &p, &x, wo, false, &u, &k, &w);
        if (k >= 3 && k <= 6) {
            n3 += k == 3;
            w3 += k == 3 ? w : 0.0;
            ++nl;
            wl += w;
            wmax = w > wmax ? w : wmax;
        }
    }
    printf("    %d paths through 3 cylinder vertices: mean weight %.2g; %d through 3-6: mean %.2g, largest %.2g\n", n3,
           n3 ? w3 / n3 : 0.0, nl, nl ? wl / nl : 0.0, wmax);
    CHECK(n3 >= 10);
    CHECK_MSG(n3 > 0 && w3 / n3 < 0.05, "mean weight at 3 vertices %.4f", n3 ? w3 / n3 : 0.0);
    CHECK_MSG(nl > 0 && wl / nl < 0.05, "mean weight at 3-6 vertices %.4f", nl ? wl / nl : 0.0);
    CHECK_MSG(wmax < 0.5, "largest weight %.4f", wmax);
    spc_scene_destroy(sc);
}

TEST(weighted_sum_agrees_with_bsdf_sampling)
{
    /* a light of radius 0.4 (the same power), which BSDF sampling alone finds through the ring
     * often enough for a z-test; points near the wall the light comes through (3-reflection paths),
     * across the ring, at its centre */
    static const double pts[3][2] = {{0.787, -0.057}, {-0.5, 0.3}, {0.0, 0.0}};
    chain_mis_check_agrees(SCENE, "0.4", "25, 23.75, 21.25", FLOOR, pts, 3, CAMERA, 20000);
}

int main(void)
{
    RUN(three_reflection_weight);
    RUN(weighted_sum_agrees_with_bsdf_sampling);
    return spc_test_finish();
}
