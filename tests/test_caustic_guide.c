/*
 * tests/test_caustic_guide.c: caustic guiding at receivers (manifold/caustic_guide.h).
 *
 * The guided density against its sampling: over uniform directions, 4 pi p_guide averages to 1 (a
 * density), and the guided samples' g / p_guide averages to the uniform estimate of the integral of
 * a test function g over the disks' directions (the density is the one the samples follow, where
 * disks overlap, where one is tilted and where a cone overlaps a disk). The defensive mixture as the path tracer runs it: the
 * record's pdf is a p_guide + (1 - a) p_bsdf and its weight f cos / pdf, and the mean weight is the
 * diffuse albedo (unbiased). Where the guide stays off (a disk seen from below its plane, a BSDF
 * that transmits; a cone from within its sphere or behind the surface). The pre-pass on the demo:
 * its busiest entry is the glass ball's caustic on the floor, its one cone is the glass ball's own
 * sphere (whose directions from the ceiling all enter the ball), and two builds are identical.
 */
/* ctest-labels: unit */
#include <string.h>

#include "core/rng.h"
#include "harness.h"
#include "manifold/caustic_guide.h"
#include "render_util.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

static spc_vec3 random_dir(void)
{
    double z = 1.0 - 2.0 * rnd(), r = sqrt(fmax(0.0, 1.0 - z * z)), phi = 2.0 * SPC_PI * rnd();
    return spc_v3(r * cos(phi), r * sin(phi), z);
}

/* Three disks below a ceiling point: two overlapping in the plane z = 0, one tilted; and a cone
 * toward a sphere that overlaps the first disk's directions. */
static void three_disks(spc_cguide *g)
{
    memset(g, 0, sizeof *g);
    g->n = 4;
    g->cones = 1;
    g->a = 0.3;
    g->e[0] = (spc_cguide_entry){spc_v3(0, 0, 0), spc_v3(0, 0, 1), 0.6, 2.0, false};
    g->e[1] = (spc_cguide_entry){spc_v3(0.3, 0, 0), spc_v3(0, 0, 1), 0.4, 1.0, false};
    g->e[2] = (spc_cguide_entry){spc_v3(-1.0, 0.2, 0.4), spc_normalize(spc_v3(1, 0, 1)), 0.3, 1.5, false};
    g->e[3] = (spc_cguide_entry){spc_v3(0.5, -0.3, 0.5), spc_v3(0, 0, 0), 0.35, 1.2, true};
}

/* A ceiling hit at p facing down (normal -z), of BSDF b, seen from below. */
static spc_hit ceiling_hit(const spc_bsdf *b, spc_vec3 p)
{
    spc_hit h;
    memset(&h, 0, sizeof h);
    h.p = p;
    h.ng = spc_v3(0, 0, -1);
    h.sh = spc_frame_from_n(h.ng);
    h.bsdf = b;
    h.shape_index = -1;
    return h;
}

static double g_test(spc_vec3 w) { return (1.0 + w.x) * (1.0 + w.x) + 0.5 * w.y; }

TEST(density_matches_sampling)
{
    spc_scene *sc = spc_scene_create();
    spc_cguide g;
    three_disks(&g);
    spc_hit h = ceiling_hit(tu_diffuse(sc, 0.5), spc_v3(0.2, 0.1, 1.5));
    spc_cguide_vertex v;
    spc_cguide_vertex_init(&v, &g, &h, spc_v3(0, 0, -1));
    CHECK_MSG(v.a == g.a && v.n == 4, "a %g, %d entries", v.a, v.n);
    /* 4 pi p_guide over uniform directions: 1; and the integral of g over the disks' directions */
    const int N = 400000;
    double s = 0.0, s2 = 0.0, gi = 0.0, gi2 = 0.0;
    for (int i = 0; i < N; ++i) {
        spc_vec3 w = random_dir();
        double p = 4.0 * SPC_PI * spc_cguide_pdf(&v, w);
        s += p;
        s2 += p * p;
        double q = p > 0.0 ? 4.0 * SPC_PI * g_test(w) : 0.0;
        gi += q;
        gi2 += q * q;
    }
    double mean = s / N, se = sqrt((s2 / N - mean * mean) / N);
    CHECK_MSG(fabs(mean - 1.0) < 4.0 * se && se < 0.02, "integral of p_guide %.4f (se %.4f)", mean, se);
    double gu = gi / N, gu_se = sqrt((gi2 / N - gu * gu) / N);
    /* the guided samples */
    double t = 0.0, t2 = 0.0;
    int bad = 0;
    for (int i = 0; i < N; ++i) {
        spc_vec3 w;
        if (!spc_cguide_sample(&v, rnd(), spc_v2(rnd(), rnd()), &w)) {
            ++bad;
            continue;
        }
        double p = spc_cguide_pdf(&v, w);
        if (!(p > 0.0)) {
            ++bad;
            continue;
        }
        double q = g_test(w) / p;
        t += q;
        t2 += q * q;
    }
    double gs = t / N, gs_se = sqrt((t2 / N - gs * gs) / N);
    CHECK_MSG(bad == 0, "%d samples without density", bad);
    CHECK_MSG(fabs(gs - gu) < 4.0 * sqrt(gs_se * gs_se + gu_se * gu_se),
              "integral of g: guided %.4f (se %.4f), "
              "uniform %.4f (se %.4f)",
              gs, gs_se, gu, gu_se);
    printf("    integral of p_guide %.4f (se %.4f); of g: guided %.4f, uniform %.4f\n", mean, se, gs, gu);
    spc_scene_destroy(sc);
}

TEST(mixture_is_unbiased)
{
    spc_scene *sc = spc_scene_create();
    spc_cguide g;
    three_disks(&g);
    const double albedo = 0.5;
    spc_hit h = ceiling_hit(tu_diffuse(sc, albedo), spc_v3(0.2, 0.1, 1.5));
    spc_vec3 wo = spc_normalize(spc_v3(0.3, -0.2, -1.0));
    spc_cguide_vertex v;
    spc_cguide_vertex_init(&v, &g, &h, wo);
    CHECK(v.a > 0.0);
    const int N = 400000;
    double s = 0.0, s2 = 0.0, worst = 0.0;
    int guided = 0;
    for (int i = 0; i < N; ++i) {
        double u = rnd();
        spc_bsdf_sample bs;
        if (!spc_cguide_sample_mix(&v, &h, wo, u, spc_v2(rnd(), rnd()), &bs))
            continue;
        guided += u < v.a;
        /* the record against the mixture's parts */
        double pb = spc_bsdf_pdf(h.bsdf, &h, SPC_MODE_RADIANCE, wo, bs.wi);
        double pm = v.a * spc_cguide_pdf(&v, bs.wi) + (1.0 - v.a) * pb;
        double f = spc_bsdf_eval(h.bsdf, &h, SPC_MODE_RADIANCE, wo, bs.wi).r * spc_absdot(bs.wi, h.sh.n);
        worst = fmax(worst, fabs(bs.pdf - pm) / pm + fabs(bs.weight.r - f / pm) / (f / pm));
        CHECK_NEAR(spc_cguide_mix_pdf(&v, pb, bs.wi), pm, 1e-12 * pm);
        s += bs.weight.r;
        s2 += bs.weight.r * bs.weight.r;
    }
    double mean = s / N, se = sqrt((s2 / N - mean * mean) / N);
    CHECK_MSG(worst < 1e-9, "record vs mixture: relative difference %.3g", worst);
    CHECK_MSG(fabs(mean - albedo) < 4.0 * se, "mean weight %.5f (se %.5f), albedo %.2f", mean, se, albedo);
    CHECK(fabs((double)guided / N - v.a) < 0.01);
    printf("    mean weight %.5f (se %.5f) for albedo %.2f; guided share %.3f\n", mean, se, albedo, (double)guided / N);
    /* without a guide: the BSDF's own sample */
    spc_bsdf_sample a, b;
    CHECK(spc_cguide_sample_mix(NULL, &h, wo, 0.3, spc_v2(0.4, 0.6), &a) &&
          spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, wo, 0.3, spc_v2(0.4, 0.6), &b) && a.pdf == b.pdf &&
          a.wi.x == b.wi.x && a.weight.r == b.weight.r);
    spc_scene_destroy(sc);
}

TEST(guide_off_where_it_cannot_help)
{
    spc_scene *sc = spc_scene_create();
    spc_cguide g;
    three_disks(&g);
    g.n = 2; /* the plane z = 0 only */
    spc_cguide_vertex v;
    /* below the disks' plane (their unlit side) */
    spc_hit h = ceiling_hit(tu_diffuse(sc, 0.5), spc_v3(0.1, 0.0, -1.0));
    spc_cguide_vertex_init(&v, &g, &h, spc_v3(0, 0, -1));
    CHECK(v.a == 0.0 && spc_cguide_pdf(&v, spc_v3(0, 0, 1)) == 0.0);
    /* facing away: a floor point above the disks, seen from above, whose BSDF reflects upward */
    h = ceiling_hit(tu_diffuse(sc, 0.5), spc_v3(0.1, 0.0, 1.0));
    h.ng = h.sh.n = spc_v3(0, 0, 1);
    h.sh = spc_frame_from_n(h.ng);
    spc_cguide_vertex_init(&v, &g, &h, spc_v3(0, 0, 1));
    CHECK(v.a == 0.0);
    /* glass transmits: no guide */
    h = ceiling_hit(tu_glass(sc, 1.5), spc_v3(0.1, 0.0, 1.0));
    spc_cguide_vertex_init(&v, &g, &h, spc_v3(0, 0, -1));
    CHECK(v.a == 0.0);
    /* no guide at all */
    h = ceiling_hit(tu_diffuse(sc, 0.5), spc_v3(0.1, 0.0, 1.0));
    spc_cguide_vertex_init(&v, NULL, &h, spc_v3(0, 0, -1));
    CHECK(v.a == 0.0 && spc_cguide_mix_pdf(&v, 0.25, spc_v3(0, 0, -1)) == 0.25);
    /* a cone: not from within its sphere, nor where its centre lies behind the surface */
    three_disks(&g);
    g.e[0] = g.e[3];
    g.n = 1;
    h = ceiling_hit(tu_diffuse(sc, 0.5), spc_v3(0.6, -0.3, 0.6));
    spc_cguide_vertex_init(&v, &g, &h, spc_v3(0, 0, -1));
    CHECK(v.a == 0.0);
    h = ceiling_hit(tu_diffuse(sc, 0.5), spc_v3(0.5, -0.3, 1.5));
    h.ng = spc_v3(0, 0, 1);
    h.sh = spc_frame_from_n(h.ng);
    spc_cguide_vertex_init(&v, &g, &h, spc_v3(0, 0, 1));
    CHECK(v.a == 0.0);
    h = ceiling_hit(tu_diffuse(sc, 0.5), spc_v3(0.5, -0.3, 1.5));
    spc_cguide_vertex_init(&v, &g, &h, spc_v3(0, 0, -1));
    CHECK(v.a > 0.0 && spc_cguide_pdf(&v, spc_v3(0, 0, -1)) > 0.0 && spc_cguide_pdf(&v, spc_v3(0, 0, 1)) == 0.0);
    spc_scene_destroy(sc);
}

TEST(demo_prepass)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/scenes/demo.xml", spc_test_source_dir());
    spc_scene *sc = NULL;
    spc_error err;
    CHECK_MSG(spc_scene_load(path, NULL, 0, &sc, &err) == SPC_OK, "%s", err.msg);
    if (!sc)
        return;
    spc_cguide *g = spc_cguide_build(sc, 1 << 15, SPC_CGUIDE_STREAM, 0.25);
    spc_cguide *g2 = spc_cguide_build(sc, 1 << 15, SPC_CGUIDE_STREAM, 0.25);
    CHECK(g && g2);
    if (g && g2) {
        CHECK(g->n > 0 && g->n <= SPC_CGUIDE_MAX_ENTRIES && g->landed > 0 && g->landed < g->photons);
        CHECK(g->n == g2->n && g->cones == g2->cones && !memcmp(g->e, g2->e, sizeof g->e));
        /* one cone, last: the glass ball (not the mirror ball), its own sphere */
        CHECK_MSG(g->cones == 1 && g->n >= 2, "%d cones", g->cones);
        const spc_cguide_entry *cone = &g->e[g->n - 1];
        CHECK(cone->cone && !g->e[0].cone);
        CHECK_MSG(spc_distance(cone->c, spc_v3(-0.42, 0.36, -0.1)) < 1e-9 && fabs(cone->r - 0.36) < 1e-9,
                  "cone at (%g, %g, %g), r %g", cone->c.x, cone->c.y, cone->c.z, cone->r);
        /* from the ceiling above the ball, every direction the cone draws enters the ball */
        spc_hit hc = ceiling_hit(tu_diffuse(sc, 0.7), spc_v3(-0.6, 2.0, 0.2));
        hc.ng = spc_v3(0, -1, 0);
        hc.sh = spc_frame_from_n(hc.ng);
        spc_cguide_vertex v;
        spc_cguide_vertex_init(&v, g, &hc, spc_v3(0, -1, 0));
        int in_cone = -1;
        for (int i = 0; i < v.n; ++i)
            if (v.idx[i] == g->n - 1)
                in_cone = i;
        CHECK_MSG(v.a > 0.0 && in_cone >= 0, "the ceiling's guide: a %g, %d entries, cone %d", v.a, v.n, in_cone);
        int missed = 0, drawn = 0;
        for (int i = 0; i < 2000 && in_cone >= 0; ++i) {
            spc_vec3 w;
            /* u1 inside the cone's share of the selection */
            double lo = 0.0;
            for (int k = 0; k < in_cone; ++k)
                lo += v.w[k];
            double u1 = (lo + v.w[in_cone] * rnd()) / v.wsum;
            if (!spc_cguide_sample(&v, u1, spc_v2(rnd(), rnd()), &w))
                continue;
            ++drawn;
            spc_vec3 oc = spc_sub(hc.p, cone->c);
            double b = spc_dot(oc, w), c = spc_length2(oc) - cone->r * cone->r;
            missed += !(b < 0.0 && b * b - c > 0.0);
        }
        CHECK_MSG(drawn > 1900 && missed == 0, "%d of %d cone directions miss the ball", missed, drawn);
        /* the glass ball (centre x -0.42) focuses the ceiling light on the floor below it */
        const spc_cguide_entry *e = &g->e[0];
        CHECK_MSG(fabs(e->c.y) < 1e-6 && e->n.y > 0.99 && e->c.x < -0.3 && e->c.x > -0.7 && e->r > 0.0,
                  "busiest entry at (%g, %g, %g), normal (%g, %g, %g)", e->c.x, e->c.y, e->c.z, e->n.x, e->n.y, e->n.z);
        for (int j = 1; j < g->n - g->cones; ++j)
            CHECK(g->e[j].power <= g->e[j - 1].power);
        printf("    %d entries from %ld of %ld photons; busiest at (%.3f, %.3f, %.3f), r %.3f\n", g->n, g->landed,
               g->photons, e->c.x, e->c.y, e->c.z, e->r);
    }
    spc_cguide_destroy(g);
    spc_cguide_destroy(g2);
    spc_cguide_destroy(NULL);
    spc_scene_destroy(sc);
}

int main(void)
{
    spc_rng_seed(&rng, 20, 0);
    RUN(density_matches_sampling);
    RUN(mixture_is_unbiased);
    RUN(guide_off_where_it_cannot_help);
    RUN(demo_prepass);
    return spc_test_finish();
}
