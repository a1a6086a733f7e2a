/*
 * tests/test_fit_seeds.c: seeds from the sphere fitted to a tessellated ball (manifold/fit_seeds.h).
 *
 * - The fit: the triangle glass ball of bench/check/glass_ball_mesh.xml (radius 0.5 at (0, 0.5, 0))
 *   has one, within 1%; its floor (a rectangle), a glass cube and an analytic sphere have none.
 * - At floor points in the ball's caustic, the chains that 4000 attempts find (angular:noreflect,
 *   2 vertices): with the fit's seeds every chain worth over 1% of the point's largest is found with
 *   probability >= 0.1 (the fold's rare sheet has 0.02-0.05 with the cone's seeds alone, whose
 *   trial count is the heavy tail), and the second moment of the chains' summed estimate v^2 (2 - p) / p falls below half
 *   the cone seeds'. It fails if the fit or its seeds are undone.
 * - The trial count stays unbiased for the mixture: for those chains the mean of 300 Bernoulli trial
 *   counts (spc_snee_count_same) times the measured p is 1 within 4 standard errors; it fails if the
 *   trials drew their seeds from another distribution than the first attempt.
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "core/rng.h"
#include "chain_compare.h"
#include "harness.h"
#include "manifold/angular.h"
#include "manifold/fit_seeds.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "specula/specula.h"

#define SCENE "bench/check/glass_ball_mesh.xml"

static spc_scene *load(const char *path)
{
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_scene_load(path, NULL, 0, &sc, &err) != SPC_OK) {
        printf("    %s: %s\n", path, err.msg);
        return NULL;
    }
    return sc;
}

TEST(fit_of_a_tessellated_ball_only)
{
    spc_scene *sc = load(SCENE);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int fits = 0, meshes = 0;
    for (int i = 0; i < sc->nshapes; ++i) {
        const spc_shape *s = sc->shapes[i];
        spc_vec3 c;
        double r;
        meshes += s->type == SPC_SHAPE_MESH;
        if (!spc_fit_sphere(s, &c, &r))
            continue;
        ++fits;
        printf("    shape %d: centre (%.4f, %.4f, %.4f), radius %.4f\n", i, c.x, c.y, c.z, r);
        CHECK(spc_distance(c, spc_v3(0, 0.5, 0)) < 0.005 && fabs(r - 0.5) < 0.005);
        CHECK(spc_bsdf_is_specular_interface(s->bsdf, &(double){0}));
    }
    CHECK_MSG(fits == 1 && meshes >= 3, "%d fits among %d meshes", fits, meshes);
    spc_scene_destroy(sc);
    /* a glass cube and an analytic glass sphere: no fit */
    const char *xml = "<scene version=\"3.0.0\">\n"
                      "<shape type=\"cube\"><bsdf type=\"dielectric\"/></shape>\n"
                      "<shape type=\"sphere\"><point name=\"center\" x=\"3\" y=\"0\" z=\"0\"/>"
                      "<bsdf type=\"dielectric\"/></shape>\n"
                      "<shape type=\"rectangle\"><transform name=\"to_world\"><translate y=\"-2\"/></transform>"
                      "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>\n"
                      "</scene>\n";
    char path[256];
    snprintf(path, sizeof path, "/tmp/spc_fit_seeds_%ld.xml", (long)getpid());
    FILE *fp = fopen(path, "w");
    CHECK(fp != NULL);
    if (!fp)
        return;
    fputs(xml, fp);
    fclose(fp);
    sc = load(path);
    remove(path);
    CHECK(sc != NULL);
    for (int i = 0; sc && i < sc->nshapes; ++i) {
        spc_vec3 c;
        double r;
        CHECK_MSG(!spc_fit_sphere(sc->shapes[i], &c, &r), "shape %d has a fit", i);
    }
    spc_scene_destroy(sc);
}


TEST(fit_seeds_find_every_chain_and_count_unbiased)
{
    spc_scene *sc = load(SCENE);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params pf, pu;
    CHECK(spc_snee_parse("angular:noreflect", 2, &pf));
    CHECK(spc_snee_parse("angular:noreflect,nofitseeds", 2, &pu));
    CHECK(pf.fit_seeds && !pu.fit_seeds);
    const int attempts = spc_test_quick() ? 1000 : 4000, counts = spc_test_quick() ? 100 : 300;
    double m2_fit = 0.0, m2_uni = 0.0, pmin_fit = 1.0, pmin_uni = 1.0;
    int checked = 0;
    spc_rng rng;
    spc_rng_seed(&rng, 7, 12);
    for (int i = 0; i < 9; ++i) {
        spc_hit x;
        if (!chain_floor_point(sc, 1, -0.25 + 0.08 * (i % 3), 0.12 + 0.08 * (i / 3), &x))
            continue;
        spc_snee_query qf, qu;
        spc_snee_query_init(&qf, sc, &pf, &x, spc_v3(0, 1, 0), 2);
        const spc_emitter *e;
        spc_vec2 uv;
        double p_y;
        pf.light_u_on = true;
        pf.light_u[0] = 0.5;
        pf.light_u[1] = 0.3 + 0.05 * i;
        pf.light_u[2] = 0.6;
        if (!spc_snee_sample_light(sc, false, &rng, &qf, &e, &uv, &p_y))
            continue;
        pf.light_u_on = false;
        spc_fit_roots fit;
        fit.nshapes = 0;
        qf.fit = &fit;
        qu = qf;
        qu.params = &pu;
        qu.fit = NULL;
        chain_tally tf = {0}, tu = {0};
        for (int a = 0; a < attempts; ++a) {
            spc_chain c;
            int it = 0;
            if (spc_angular_solve_one(&qf, &rng, &c, &it))
                chain_tally_add(&tf, &c, sc->radius);
            if (spc_angular_solve_one(&qu, &rng, &c, &it))
                chain_tally_add(&tu, &c, sc->radius);
        }
        chain_tally all = tf;
        for (int s = 0; s < tu.n; ++s)
            if (!chain_tally_hits(&all, &tu.c[s], sc->radius) && all.n < CHAIN_TALLY_MAX)
                all.c[all.n++] = tu.c[s];
        double vmax = 0.0;
        for (int s = 0; s < all.n; ++s)
            vmax = fmax(vmax, spc_rgb_lum(spc_snee_chain_value(&qf, e, uv, &all.c[s])));
        for (int s = 0; s < all.n; ++s) {
            double v = spc_rgb_lum(spc_snee_chain_value(&qf, e, uv, &all.c[s]));
            if (!(v > 0.0))
                continue; /* no value (the last segment blocked, the light's back) */
            double pfs = (double)chain_tally_hits(&tf, &all.c[s], sc->radius) / attempts;
            double pus = (double)chain_tally_hits(&tu, &all.c[s], sc->radius) / attempts;
            pfs = pfs > 0.0 ? pfs : 1.0 / attempts;
            pus = pus > 0.0 ? pus : 1.0 / attempts;
            m2_fit += v * v * (2.0 - pfs) / pfs;
            m2_uni += v * v * (2.0 - pus) / pus;
            if (v > 0.01 * vmax) { /* a chain that matters at x */
                pmin_fit = pfs < pmin_fit ? pfs : pmin_fit;
                pmin_uni = pus < pmin_uni ? pus : pmin_uni;
            }
            spc_chain_sig want;
            spc_chain_signature(&all.c[s], &want);
            spc_snee_query tq = qf;
            tq.want = &want;
            double sn = 0.0, sn2 = 0.0;
            for (int k = 0; k < counts; ++k) {
                bool capped;
                int it = 0;
                int n = spc_snee_count_same(&tq, spc_specular_solver_get(SPC_SNEE_ANGULAR), NULL, &rng, &all.c[s],
                                            100000, &capped, &it);
                sn += n;
                sn2 += (double)n * n;
            }
            double mean = sn / counts, var = (sn2 / counts - mean * mean) / counts;
            double rel = sqrt(var / (mean * mean) + (1.0 - pfs) / (pfs * attempts));
            double z = (mean * pfs - 1.0) / rel;
            printf("    x %d chain %d (value %.3g): p with the fit %.4f, cone seeds %.4f; mean count %.2f, "
                   "p x count %.3f (z %+.2f)\n",
                   i, s, v, pfs, pus, mean, mean * pfs, z);
            CHECK_MSG(fabs(z) < 4.0, "x %d chain %d: p %g, mean count %g, z %g", i, s, pfs, mean, z);
            ++checked;
        }
    }
    printf("    smallest p of a valuable chain: fit %.4f, cone seeds %.4f; second moment: fit %.4g, cone %.4g\n",
           pmin_fit, pmin_uni, m2_fit, m2_uni);
    CHECK_MSG(checked >= 6, "%d chains checked", checked);
    CHECK_MSG(pmin_fit >= 0.1, "a valuable chain found with p %g", pmin_fit);
    CHECK_MSG(m2_fit < 0.5 * m2_uni, "second moment: fit %g, cone seeds %g", m2_fit, m2_uni);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(fit_of_a_tessellated_ball_only);
    RUN(fit_seeds_find_every_chain_and_count_unbiased);
    return spc_test_finish();
}
