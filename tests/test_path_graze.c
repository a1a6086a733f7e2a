/*
 * tests/test_path_graze.c: the grazing directions along a mirror cylinder's wall (path_graze.h) on
 * scenes/caustic_mirror_ring.xml.
 * - The ring's cylinder is served, with an elevation band above the floor; a scene without a mirror
 *   cylinder has none.
 * - p_g is a density: its integral over the sphere is 1 (Monte Carlo over uniform directions), and
 *   every drawn direction has the density the draw reports.
 * - At floor points at the wall's foot where the light comes through 9 and more reflections (the
 *   whispering gallery), with a light of radius 0.4 (the same power) so that BSDF sampling alone
 *   finds those paths often enough: BSDF sampling weighted by spc_path_graze_bsdf_weight plus the
 *   strategy's term agree with BSDF sampling alone (every weight 1), |z| < 4, and with less
 *   variance.
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/rng.h"
#include "core/warp.h"
#include "emitter/emitter.h"
#include "harness.h"
#include "integrator/path_graze.h"
#include "scene/scene.h"
#include "specula/specula.h"

#define SCENE "scenes/caustic_mirror_ring.xml"
#define CAMERA spc_v3(0.3, 3.2, 1.9)
#define FLOOR 1

static spc_scene *load(const char *path, const char *radius, const char *radiance)
{
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    spc_define defs[2] = {{"light_radius", radius}, {"light_radiance", radiance}};
    CHECK_MSG(spc_scene_load(path, defs, radius ? 2 : 0, &sc, &err) == SPC_OK, "%s: %s", path, err.msg);
    return sc;
}

/* The floor point at distance eps inside the ring's wall (radius 0.8) at azimuth phi (degrees, from
 * +x toward +z). */
static bool foot_point(const spc_scene *sc, double phi, double eps, spc_hit *x)
{
    double r = 0.8 - eps, a = phi * 3.14159265358979323846 / 180.0;
    spc_ray ray = {spc_v3(r * cos(a), 0.01, r * sin(a)), spc_v3(0, -1, 0), 0, INFINITY};
    return spc_scene_intersect(sc, &ray, x) && x->shape_index == FLOOR;
}

TEST(ring_cylinder_served)
{
    spc_scene *sc = load(SCENE, NULL, NULL);
    if (!sc)
        return;
    spc_path_graze g;
    CHECK(spc_path_graze_init(&g, sc));
    CHECK(g.n == 1);
    const spc_graze_cylinder *c = &g.c[0];
    printf("    band %.4f..%.4f rad, alpha_max %.4f, eps_max %.5f\n", c->theta_lo, c->theta_hi, c->alpha_max,
           c->eps_max);
    CHECK_MSG(c->theta_lo > 0.0 && c->theta_hi > c->theta_lo && c->theta_hi < 1.2, "band %g..%g", c->theta_lo,
              c->theta_hi);
    CHECK(c->alpha_max > 0.0 && c->alpha_max <= 0.2 && c->eps_max > 0.0 && c->eps_max < 0.02);
    CHECK(fabs(c->radius - 0.8) < 1e-9 && fabs(c->len - 0.45) < 1e-9);
    spc_scene_destroy(sc);
    sc = load("scenes/caustic_glass_sphere.xml", NULL, NULL);
    if (!sc)
        return;
    CHECK(!spc_path_graze_init(&g, sc));
    spc_scene_destroy(sc);
}

TEST(pdf_is_a_density)
{
    spc_scene *sc = load(SCENE, NULL, NULL);
    if (!sc)
        return;
    spc_path_graze g;
    CHECK(spc_path_graze_init(&g, sc));
    spc_hit x;
    CHECK(foot_point(sc, 326.0, 0.0005, &x));
    spc_rng u;
    spc_rng_seed(&u, 7, 1);
    /* every draw has the density it reports */
    int bad = 0;
    for (int i = 0; i < 10000; ++i) {
        spc_vec3 d;
        double pdf;
        CHECK(spc_path_graze_sample(&g, &x, &u, &d, &pdf));
        double q = spc_path_graze_pdf(&g, &x, d);
        bad += !(fabs(q - pdf) <= 1e-6 * pdf && fabs(spc_length(d) - 1.0) < 1e-9);
    }
    CHECK_MSG(bad == 0, "%d draws whose density differs", bad);
    /* its integral over the sphere */
    int n = spc_test_quick() ? 1000000 : 4000000;
    double s = 0.0, s2 = 0.0;
    for (int i = 0; i < n; ++i) {
        spc_vec3 d = spc_warp_uniform_sphere(spc_v2(spc_rng_next(&u), spc_rng_next(&u)));
        double v = 4.0 * 3.14159265358979323846 * spc_path_graze_pdf(&g, &x, d);
        s += v;
        s2 += v * v;
    }
    double m = s / n, se = sqrt((s2 / n - m * m) / n);
    printf("    integral of p_g over the sphere: %.4f +- %.4f\n", m, se);
    CHECK_MSG(fabs(m - 1.0) < 4.0 * se && se < 0.03, "integral %.4f +- %.4f", m, se);
    /* a receiver away from the wall has none */
    spc_hit y;
    CHECK(foot_point(sc, 326.0, 0.05, &y));
    spc_vec3 d;
    double pdf;
    CHECK(!spc_path_graze_sample(&g, &y, &u, &d, &pdf));
    spc_scene_destroy(sc);
}

/* From x, a path drawn by the floor's BSDF and followed through reflections on the wall to the
 * light: its luminance (BSDF weight times the reflections' times Le) where it reaches the light
 * after SPC_GRAZE_MIN_REFLECTIONS or more reflections, else 0; weighted by the BSDF side's MIS
 * weight unless plain. */
static double bsdf_path(const spc_render_ctx *ctx, const spc_hit *x, spc_vec3 wo, bool plain, spc_rng *u)
{
    spc_bsdf_sample bs;
    if (!spc_bsdf_sample_dir(x->bsdf, x, SPC_MODE_RADIANCE, wo, spc_rng_next(u),
                             spc_v2(spc_rng_next(u), spc_rng_next(u)), &bs))
        return 0.0;
    spc_graze_track t = {.live = false};
    spc_path_graze_scattered(ctx, &t, x, wo, bs.wi, bs.lobe, false);
    spc_rgb T = bs.weight;
    spc_ray ray = spc_hit_spawn(x, bs.wi);
    for (int k = 0; k <= SPC_GRAZE_MAX_REFLECTIONS + 1; ++k) {
        spc_hit h;
        if (!spc_scene_intersect(ctx->scene, &ray, &h))
            return 0.0;
        spc_vec3 wi = spc_neg(ray.d);
        if (h.emitter) {
            if (k < SPC_GRAZE_MIN_REFLECTIONS)
                return 0.0;
            double w = plain ? 1.0 : spc_path_graze_bsdf_weight(ctx, &t, &h);
            return spc_rgb_lum(spc_rgb_mul(T, spc_emitter_eval_area(h.emitter, &h, wi))) * w;
        }
        if (!spc_bsdf_is_delta_only(h.bsdf) ||
            !spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, wi, 0.5, spc_v2(0.5, 0.5), &bs))
            return 0.0;
        spc_path_graze_scattered(ctx, &t, &h, wi, bs.wi, bs.lobe, false);
        T = spc_rgb_mul(T, bs.weight);
        ray = spc_hit_spawn(&h, bs.wi);
    }
    return 0.0;
}

TEST(weighted_sum_agrees_with_bsdf_sampling)
{
    spc_scene *sc = load(SCENE, "0.4", "25, 23.75, 21.25");
    if (!sc)
        return;
    spc_path_graze g;
    CHECK(spc_path_graze_init(&g, sc));
    spc_render_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = sc;
    ctx.kind = SPC_INTEGRATOR_PATH;
    ctx.max_depth = -1;
    ctx.specular_nee = 1;
    ctx.graze = &g;
    /* the foot of the wall where the light comes round it clockwise and counter-clockwise */
    static const double pts[3][2] = {{326.0, 0.0003}, {34.0, 0.0003}, {326.0, 0.0015}};
    int n = spc_test_quick() ? 100000 : 400000;
    for (int i = 0; i < 3; ++i) {
        spc_hit x;
        CHECK(foot_point(sc, pts[i][0], pts[i][1], &x));
        spc_vec3 wo = spc_normalize(spc_sub(CAMERA, x.p));
        spc_rng ua, ub, ug;
        spc_rng_seed(&ua, 100 + i, 1);
        spc_rng_seed(&ub, 200 + i, 2);
        spc_rng_seed(&ug, 300 + i, 3);
        double sa = 0, sa2 = 0, sb = 0, sb2 = 0, sg = 0;
        int hits = 0;
        for (int j = 0; j < n; ++j) {
            double a = bsdf_path(&ctx, &x, wo, true, &ua);
            double gterm = spc_rgb_lum(spc_path_graze_estimate(&ctx, &x, wo, 1, &ug));
            double b = bsdf_path(&ctx, &x, wo, false, &ub) + gterm;
            hits += a > 0.0;
            sa += a;
            sa2 += a * a;
            sb += b;
            sb2 += b * b;
            sg += gterm;
        }
        double ma = sa / n, mb = sb / n;
        double va = (sa2 / n - ma * ma) / n, vb = (sb2 / n - mb * mb) / n;
        double z = (mb - ma) / sqrt(va + vb + 1e-300);
        printf("    (%.0f deg, eps %.4f): BSDF alone %.5f +- %.5f (%d hits), weighted + grazing %.5f +- %.5f "
               "(grazing %.0f%%), z %+.2f\n",
               pts[i][0], pts[i][1], ma, sqrt(va), hits, mb, sqrt(vb), mb > 0 ? 100.0 * sg / n / mb : 0.0, z);
        CHECK_MSG(hits >= 20, "BSDF sampling found %d paths", hits);
        CHECK_MSG(fabs(z) < 4.0, "z %.2f", z);
        CHECK_MSG(vb < 0.5 * va, "variance %.3g against BSDF sampling's %.3g", vb, va);
    }
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(ring_cylinder_served);
    RUN(pdf_is_a_density);
    RUN(weighted_sum_agrees_with_bsdf_sampling);
    return spc_test_finish();
}
