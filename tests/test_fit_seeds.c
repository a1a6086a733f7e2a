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
 * - The solutions counted per chain length (spc_fit_root_count, which the ball pass of specular NEE
 *   asks before it looks for chains of a length): none of 3 vertices and three of 5 from a floor
 *   point to the light.
 * - A trial count's reuse of a seed's outcome (solver.h, seed_decides): the angular and conic
 *   solvers, with the events fixed, draw only the seed and answer as a function of it.
 * - From a medium point inside the tessellated ball of scenes/medium_glass.xml: the chains that
 *   leave near the rim are found with p >= 0.01 with the fitted sphere's way out from inside (below
 *   0.004 without), and the trial counts stay unbiased.
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
#include "manifold/receiver.h"
#include "medium/medium.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "render_util.h"
#include "specula/specula.h"

#define SCENE "bench/check/glass_ball_mesh.xml"

/* Specular NEE from floor point x to the light point at light_u (0.5, u1, u2) (*e: the emitter drawn),
 * with pf's fitted seeds against pu's cone seeds: chain_seeds_compare adds both to *res, the fitted
 * roots are left in *fit. False where no light point is drawn. */
static bool compare_fit_at(spc_scene *sc, spc_snee_params *pf, const spc_snee_params *pu, const spc_hit *x,
                           double u1, double u2, spc_rng *rng, const spc_emitter **e, int attempts, int counts,
                           double count_pmin, int point, chain_seeds_cmp *res, spc_fit_roots *fit)
{
    spc_snee_query qf, qu;
    spc_snee_query_init(&qf, sc, pf, x, spc_v3(0, 1, 0), 2);
    spc_vec2 uv;
    double p_y;
    pf->light_u_on = true;
    pf->light_u[0] = 0.5;
    pf->light_u[1] = u1;
    pf->light_u[2] = u2;
    bool lit = spc_snee_sample_light(sc, false, rng, &qf, e, &uv, &p_y);
    pf->light_u_on = false;
    if (!lit)
        return false;
    fit->nshapes = 0;
    qf.fit = fit;
    qu = qf;
    qu.params = pu;
    qu.fit = NULL;
    chain_seeds_compare(&qf, &qu, *e, uv, sc->radius, rng, attempts, counts, count_pmin, point, res);
    return true;
}

TEST(fit_of_a_tessellated_ball_only)
{
    spc_scene *sc = tu_load(SCENE, 0);
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
    sc = tu_load(path, 0);
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
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params pf, pu;
    CHECK(spc_snee_parse("angular:noreflect", 2, &pf));
    CHECK(spc_snee_parse("angular:noreflect,nofitseeds", 2, &pu));
    CHECK(pf.fit_seeds && !pu.fit_seeds);
    const int attempts = spc_test_quick() ? 1000 : 4000, counts = spc_test_quick() ? 100 : 300;
    chain_seeds_cmp r;
    chain_seeds_cmp_init(&r);
    spc_rng rng;
    spc_rng_seed(&rng, 7, 12);
    for (int i = 0; i < 9; ++i) {
        spc_hit x;
        if (!chain_floor_point(sc, 1, -0.25 + 0.08 * (i % 3), 0.12 + 0.08 * (i / 3), &x))
            continue;
        const spc_emitter *e;
        spc_fit_roots fit;
        compare_fit_at(sc, &pf, &pu, &x, 0.3 + 0.05 * i, 0.6, &rng, &e, attempts, counts, 0.0, i, &r, &fit);
    }
    printf("    smallest p of a valuable chain: fit %.4f, cone seeds %.4f; second moment: fit %.4g, cone %.4g\n",
           r.pmin_a, r.pmin_b, r.m2_a, r.m2_b);
    CHECK_MSG(r.checked >= 6, "%d chains checked", r.checked);
    CHECK_MSG(r.pmin_a >= 0.1, "a valuable chain found with p %g", r.pmin_a);
    CHECK_MSG(r.m2_a < 0.5 * r.m2_b, "second moment: fit %g, cone seeds %g", r.m2_a, r.m2_b);
    spc_scene_destroy(sc);
}

/* The fitted sphere's solutions that the seeds (and the ball pass's choice of lengths) use, from the
 * floor point (-0.23, 0, 0.72) under the triangle glass ball to the centre of its light: none of 3
 * vertices (one internal reflection sends the light back up), three of 5 (three reflections; each
 * converges on the mesh to a chain of its own), and none for a cube. The roots of 1-2 vertices
 * computed along with a longer length's are kept and give the directions computed alone. */
TEST(fit_root_count_by_length)
{
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params p;
    CHECK(spc_snee_parse("angular", 2, &p));
    spc_hit x;
    CHECK(chain_floor_point(sc, 1, -0.23, 0.72, &x));
    const spc_shape *ball = NULL, *floor = sc->shapes[1];
    for (int i = 0; i < sc->nshapes && !ball; ++i) {
        spc_vec3 c;
        double r;
        if (spc_fit_sphere(sc->shapes[i], &c, &r))
            ball = sc->shapes[i];
    }
    CHECK(ball != NULL);
    int n[7] = {0};
    for (int k = 3; k <= 6 && ball; ++k) {
        spc_snee_query q;
        spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 1, 0), k);
        q.min_chain = k;
        q.y = spc_v3(0.4, 2.2, -0.6);
        spc_fit_roots fit;
        fit.nshapes = 0;
        q.fit = &fit;
        n[k] = spc_fit_root_count(&q, ball);
        CHECK(spc_fit_root_count(&q, ball) == n[k] && fit.nshapes == 1); /* kept, not recomputed */
        CHECK(spc_fit_root_count(&q, floor) == 0);
        /* the roots of the query's own lengths (1-2 vertices) computed along with the long ones'
         * (spc_fit_root_count_with): its entry takes them, and its directions are those computed
         * alone, bit for bit */
        spc_snee_query q2;
        spc_snee_query_init(&q2, sc, &p, &x, spc_v3(0, 1, 0), 2);
        q2.y = q.y;
        q2.fit = &fit;
        spc_fit_roots fit_alone;
        fit_alone.nshapes = 0;
        spc_snee_query q2a = q2;
        q2a.fit = &fit_alone;
        fit.nshapes = 0;
        CHECK(spc_fit_root_count_with(&q, ball, q2.min_chain, q2.max_chain) == n[k]);
        CHECK(fit.nshapes == 1 && (fit.e[0].have & 3u) == 3u); /* m = -1 and 0 kept */
        spc_vec3 d2[SPC_FIT_MAX_DIRS], d2a[SPC_FIT_MAX_DIRS];
        int m2[SPC_FIT_MAX_DIRS], m2a[SPC_FIT_MAX_DIRS];
        int n2 = spc_fit_roots_of(&q2, ball, d2, m2, SPC_FIT_MAX_DIRS);
        int n2a = spc_fit_roots_of(&q2a, ball, d2a, m2a, SPC_FIT_MAX_DIRS);
        CHECK(n2 > 0 && n2 == n2a && fit.nshapes == 2);
        CHECK(memcmp(d2, d2a, (size_t)n2 * sizeof *d2) == 0 && memcmp(m2, m2a, (size_t)n2 * sizeof *m2) == 0);
    }
    printf("    roots by length: 3: %d, 4: %d, 5: %d, 6: %d\n", n[3], n[4], n[5], n[6]);
    CHECK(n[3] == 0 && n[5] == 3);
    spc_scene_destroy(sc);
}

/* The glass SDF torus of scenes/caustic_sdf_torus.xml (R 0.8, r 0.28, its axis y turned 25 degrees
 * about x, centre (0, 0.64, 0)): its fit (spc_fit_torus) and its tube spheres' seeds. At floor points
 * around the ring toward the light's centre (2 vertices, no reflections), the seeds' mixture finds
 * every chain worth over 1% of the point's best with p >= 0.03 and lowers the chains' summed second
 * moment below 0.7 of the cone seeds'; the trial counts stay an unbiased 1 / p of the mixture's p;
 * chains of 4 vertices get no tube seed. It fails without the torus's seeds (the two settings then
 * draw alike) and where the tube seeds go to the long pass's chains. */
TEST(torus_tube_seeds)
{
    spc_scene *sc = tu_load("scenes/caustic_sdf_torus.xml", 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const spc_shape *torus = NULL;
    spc_vec3 c, a;
    double R = 0.0, r = 0.0;
    for (int i = 0; i < sc->nshapes && !torus; ++i)
        if (spc_fit_torus(sc->shapes[i], &c, &a, &R, &r))
            torus = sc->shapes[i];
    CHECK(torus != NULL);
    if (!torus) {
        spc_scene_destroy(sc);
        return;
    }
    printf("    torus: centre (%.3f, %.3f, %.3f), axis (%.3f, %.3f, %.3f), R %.3f, r %.3f\n", c.x, c.y, c.z, a.x, a.y,
           a.z, R, r);
    CHECK(spc_distance(c, spc_v3(0, 0.64, 0)) < 1e-6 && fabs(R - 0.8) < 1e-6 && fabs(r - 0.28) < 1e-6);
    CHECK(fabs(a.x) < 1e-6 && fabs(a.y - cos(25 * M_PI / 180)) < 1e-6 && fabs(fabs(a.z) - sin(25 * M_PI / 180)) < 1e-6);
    spc_vec3 sc0;
    double sr;
    CHECK(!spc_fit_sphere(torus, &sc0, &sr)); /* not a ball: no ball pass, no chains counted exactly */
    spc_snee_params pf, pu;
    CHECK(spc_snee_parse("angular:noreflect", 2, &pf));
    CHECK(spc_snee_parse("angular:noreflect,nofitseeds", 2, &pu));
    const int attempts = spc_test_quick() ? 1000 : 3000, counts = spc_test_quick() ? 100 : 200;
    chain_seeds_cmp res;
    chain_seeds_cmp_init(&res);
    spc_rng rng;
    spc_rng_seed(&rng, 11, 5);
    const spc_emitter *e = sc->nemitters > 0 ? sc->emitters[0] : NULL;
    for (int i = 0; i < 8 && e; ++i) {
        double phi = 2.0 * M_PI * (i + 0.25) / 8.0;
        spc_hit x;
        if (!chain_floor_point(sc, 0, 0.75 * cos(phi), 0.75 * sin(phi), &x))
            continue;
        spc_fit_roots fit;
        compare_fit_at(sc, &pf, &pu, &x, 0.3 + 0.05 * i, 0.6, &rng, &e, attempts, counts, 0.0, i, &res, &fit);
    }
    /* the long pass's chains (past two vertices) keep the cone's seeds: the tube sphere's solutions
     * with internal reflections lie far from the torus's, and those chains' counts grew */
    spc_hit x;
    bool xf = e && chain_floor_point(sc, 0, 0.75 * cos(M_PI / 16), 0.75 * sin(M_PI / 16), &x);
    CHECK(xf);
    spc_snee_params pr; /* with reflections: the tube sphere has 4-vertex solutions */
    CHECK(spc_snee_parse("angular", 2, &pr));
    if (xf) {
        int got[2] = {0, 0};
        for (int k = 0; k < 2; ++k) {
            spc_snee_query q;
            spc_snee_query_init(&q, sc, &pr, &x, spc_v3(0, 1, 0), k ? 4 : 2);
            q.min_chain = k ? 4 : 1;
            q.y = spc_v3(0.4, 2.92, -0.3);
            spc_fit_roots fit;
            fit.nshapes = 0;
            q.fit = &fit;
            for (int t = 0; t < 200; ++t) {
                spc_vec3 d;
                got[k] += spc_fit_seed(&q, torus, &rng, &d);
            }
        }
        printf("    tube seeds in 200 draws: 2 vertices %d, 4 vertices %d\n", got[0], got[1]);
        CHECK(got[0] > 50 && got[1] == 0);
    }
    printf("    smallest p of a valuable chain: tube seeds %.4f, cone seeds %.4f; second moment: %.4g, %.4g\n",
           res.pmin_a, res.pmin_b, res.m2_a, res.m2_b);
    CHECK_MSG(res.checked >= 6, "%d chains checked", res.checked);
    CHECK_MSG(res.pmin_a >= 0.03, "a valuable chain found with p %g", res.pmin_a);
    CHECK_MSG(res.m2_a < 0.7 * res.m2_b, "second moment: tube seeds %g, cone seeds %g", res.m2_a, res.m2_b);
    spc_scene_destroy(sc);
}

/* Below the torus's low rim of scenes/caustic_sdf_torus.xml (the floor point of that scene's worst
 * seed) toward the bottom of the light, two valuable 2-vertex chains lie near a fold, a few
 * hundredths of a radian apart; one seed direction of the tube spheres reaches the second. The
 * light's end lies 7 tube radii from the core circle, so its sphere gives no seeds: 3 directions,
 * not 5, and that chain's p about 0.12 (0.07 with the light's sphere's seeds), its trial count still
 * an unbiased 1 / p. Fails with the far end's sphere kept (p below 0.095, 5 directions). */
TEST(torus_fold_pair_far_end)
{
    spc_scene *sc = tu_load("scenes/caustic_sdf_torus.xml", 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params pf, pu;
    CHECK(spc_snee_parse("angular:camera,first=0.1,later=0.1", 2, &pf));
    CHECK(spc_snee_parse("angular:camera,first=0.1,later=0.1,nofitseeds", 2, &pu));
    const int attempts = spc_test_quick() ? 1500 : 3000, counts = spc_test_quick() ? 50 : 100;
    chain_seeds_cmp res;
    chain_seeds_cmp_init(&res);
    spc_rng rng;
    spc_rng_seed(&rng, 11, 5);
    const spc_emitter *e = sc->nemitters > 0 ? sc->emitters[0] : NULL;
    spc_hit x;
    bool xf = e && chain_floor_point(sc, 0, -0.121, 0.877, &x);
    CHECK(xf);
    int ndirs = -1;
    for (int i = 0; i < 2 && xf; ++i) {
        spc_fit_roots fit; /* toward the light's lowest points */
        bool lit = compare_fit_at(sc, &pf, &pu, &x, 0.05 * i, 0.5, &rng, &e, attempts, counts, 0.01, i, &res, &fit);
        CHECK(lit);
        if (!lit)
            continue;
        ndirs = fit.nshapes > 0 ? fit.e[0].n : 0;
    }
    printf("    tube seed directions %d; smallest p of a valuable chain: tube seeds %.4f, cone seeds %.4f\n", ndirs,
           res.pmin_a, res.pmin_b);
    CHECK_MSG(ndirs == 3, "%d tube seed directions", ndirs);
    CHECK_MSG(res.checked >= 4, "%d chains checked", res.checked);
    CHECK_MSG(res.pmin_a >= 0.095, "a valuable chain found with p %g", res.pmin_a);
    spc_scene_destroy(sc);
}

/* The solvers marked seed_decides (solver.h) draw nothing from the random stream but the seed
 * direction where the query fixes the events, and answer as a function of that direction: a trial
 * count (specular_nee.c) then keeps the outcome of each fitted seed instead of solving it again.
 * From the floor point of fit_root_count_by_length toward its light point, for 2- and 5-vertex
 * chains with the ball pass's fitted share 0.9: a found chain's trials, each solved as a trial does
 * it and again from the seed drawn alone (then given as q.seed_dir), give the same iteration count
 * and chain, and the trial leaves the random stream where the seed's draw alone leaves it. It fails
 * where such a solver draws more than its seed. */
TEST(seed_decides_a_trial)
{
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params p;
    CHECK(spc_snee_parse("angular", 2, &p));
    p.fit_share = 0.9;
    spc_hit x;
    CHECK(chain_floor_point(sc, 1, -0.23, 0.72, &x));
    const spc_shape *ball = NULL;
    for (int i = 0; i < sc->nshapes && !ball; ++i) {
        spc_vec3 c;
        double r;
        if (spc_fit_sphere(sc->shapes[i], &c, &r))
            ball = sc->shapes[i];
    }
    CHECK(ball != NULL);
    const char *names[2] = {"angular", "conic"};
    int trials = 0, fitted = 0, found = 0, differ = 0, chains = 0;
    for (int si = 0; si < 2 && ball; ++si) {
        int id = 0;
        CHECK(spc_specular_solver_parse(names[si], &id));
        const spc_specular_solver *solver = spc_specular_solver_get(id);
        CHECK(solver && solver->solve_one && solver->seed_decides);
        if (!solver || !solver->solve_one)
            continue;
        for (int k = 2; k <= 5; k += 3) {
            spc_snee_query q;
            spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 1, 0), k);
            q.min_chain = k;
            q.y = spc_v3(0.4, 2.2, -0.6);
            spc_fit_roots fit;
            fit.nshapes = 0;
            q.fit = &fit;
            spc_vec3 fd[SPC_FIT_MAX_DIRS];
            int fm[SPC_FIT_MAX_DIRS];
            int nf = spc_fit_roots_of(&q, ball, fd, fm, SPC_FIT_MAX_DIRS);
            spc_rng rng;
            spc_rng_seed(&rng, 9, (uint64_t)(2 * k + si));
            static spc_chain sol, c1, c2;
            for (int a = 0; a < 40; ++a) {
                int it = 0;
                if (!solver->solve_one(&q, &rng, &sol, &it) || sol.n != k)
                    continue;
                ++chains;
                spc_chain_sig want;
                spc_chain_signature(&sol, &want);
                spc_snee_query tq = q;
                tq.want = &want;
                tq.events = want.event;
                for (int t = 0; t < 25; ++t) {
                    spc_rng r1 = rng, r2 = rng;
                    int it1 = 0, it2 = 0;
                    bool ok1 = solver->solve_one(&tq, &r1, &c1, &it1), ok2 = false;
                    spc_vec3 dir;
                    if (spc_snee_seed_direction(&tq, &r2, &dir)) {
                        spc_snee_query sq = tq;
                        sq.seed_dir = &dir;
                        spc_rng r3 = r2; /* what the solve from the given seed draws is not kept */
                        ok2 = solver->solve_one(&sq, &r3, &c2, &it2);
                        for (int i = 0; i < nf; ++i)
                            fitted += memcmp(&fd[i], &dir, sizeof dir) == 0;
                    }
                    bool same = ok1 == ok2 && it1 == it2 && memcmp(&r1, &r2, sizeof r1) == 0;
                    if (same && ok1) {
                        same = c1.n == c2.n;
                        for (int i = 0; same && i < c1.n; ++i)
                            same = memcmp(&c1.v[i].h.p, &c2.v[i].h.p, sizeof c1.v[i].h.p) == 0;
                        found += spc_snee_same_solution(&sol, &c1, sc->radius);
                    }
                    differ += !same;
                    ++trials;
                    rng = r1;
                }
            }
        }
    }
    printf("    %d chains, %d trials (%d from a fitted seed, %d found the chain): %d differ\n", chains, trials,
           fitted, found, differ);
    CHECK(chains >= 8 && fitted > trials / 2 && found > trials / 4);
    CHECK(differ == 0);
    spc_scene_destroy(sc);
}

/* The chains that specular NEE counts exactly from the fitted sphere's solutions (as its fit_first
 * solves them: each solution's first direction as the seed, with that solution's events), without
 * duplicates; at most max written to out. */
static int fit_chains_of(const spc_snee_query *q, const spc_shape *ball, const spc_specular_solver *solver,
                         spc_chain *out, int max)
{
    spc_vec3 dir[SPC_FIT_MAX_DIRS];
    int m[SPC_FIT_MAX_DIRS];
    int nr = spc_fit_roots_of(q, ball, dir, m, SPC_FIT_MAX_DIRS), n = 0;
    for (int r = 0; r < nr && n < max; ++r) {
        unsigned char ev[SPC_CHAIN_MAX_VERTICES];
        int k = m[r] < 0 ? 1 : m[r] + 2;
        if (k > q->max_chain)
            continue;
        for (int i = 0; i < SPC_CHAIN_MAX_VERTICES; ++i)
            ev[i] = i >= 1 && i <= m[r] ? SPC_CHAIN_REFLECT : SPC_CHAIN_REFRACT;
        if (m[r] < 0)
            ev[0] = SPC_CHAIN_REFLECT;
        spc_snee_query tq = *q;
        tq.seed_dir = &dir[r];
        tq.want = NULL;
        tq.events = ev;
        spc_rng rng;
        spc_rng_seed(&rng, 1, 2);
        spc_chain c;
        int it = 0;
        if (!solver->solve_one(&tq, &rng, &c, &it) || c.n < 1 || c.n > q->max_chain)
            continue;
        bool dup = false;
        for (int i = 0; i < n; ++i)
            dup = dup || spc_snee_same_solution(&out[i], &c, q->scene->radius);
        if (!dup)
            out[n++] = c;
    }
    return n;
}

/* The floor points under the triangle glass ball where a camera sample's rare large contributions
 * land (bench/RESULTS.md, "the fold tail traced": a diffuse floor point seen by the camera reaches
 * them through the ball; specular NEE there adds two chains of nearly equal value): on the caustic's
 * fold, where two 2-vertex chains to the light merge. Toward a 32 x 32 grid of points on the light,
 * every chain that 400 randomized attempts find is one the fitted sphere's solutions give (counted
 * exactly, no trial count), and at some light points the pair lies within 10% in value, each over
 * 50: the fold's two near-merged roots are both found. It fails if a fitted solution stops
 * converging to one of the two (a missed root there is a bias, and its trial count a tail). */
TEST(ball_fold_pair_counted_exactly)
{
    spc_scene *sc = tu_load(SCENE, 0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params p;
    CHECK(spc_snee_parse("angular", 2, &p));
    const spc_specular_solver *solver = spc_specular_solver_get(p.solver);
    const spc_shape *ball = NULL;
    for (int i = 0; i < sc->nshapes && !ball; ++i) {
        spc_vec3 c;
        double r;
        if (spc_fit_sphere(sc->shapes[i], &c, &r))
            ball = sc->shapes[i];
    }
    CHECK(ball != NULL && solver && solver->solve_one);
    const double pts[2][2] = {{-0.0219, -0.0392}, {-0.1805, 0.2983}};
    const int attempts = spc_test_quick() ? 200 : 400, grid = 32;
    spc_rng rng;
    spc_rng_seed(&rng, 13, 3);
    int lit = 0, chains = 0, missed = 0, pairs = 0;
    for (int k = 0; k < 2 && ball && solver && solver->solve_one; ++k) {
        spc_hit x; /* the floor just below the ball's lowest facets */
        spc_ray ray = {spc_v3(pts[k][0], 5e-4, pts[k][1]), spc_v3(0, -1, 0), 0, INFINITY};
        bool on_floor = spc_scene_intersect(sc, &ray, &x) && x.shape_index == 1;
        CHECK(on_floor);
        for (int l = 0; on_floor && l < grid * grid; ++l) {
            spc_snee_query q;
            spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 1, 0), 2);
            p.light_u_on = true;
            p.light_u[0] = 0.5;
            p.light_u[1] = (l % grid + 0.5) / grid;
            p.light_u[2] = (l / grid + 0.5) / grid;
            const spc_emitter *e;
            spc_vec2 uv;
            double p_y;
            bool ok = spc_snee_sample_light(sc, false, &rng, &q, &e, &uv, &p_y);
            p.light_u_on = false;
            if (!ok)
                continue;
            spc_fit_roots fit;
            fit.nshapes = 0;
            q.fit = &fit;
            spc_chain fc[SPC_FIT_MAX_DIRS];
            int nf = fit_chains_of(&q, ball, solver, fc, SPC_FIT_MAX_DIRS);
            chain_tally t;
            t.n = 0;
            for (int a = 0; a < attempts; ++a) {
                spc_chain c;
                int it = 0;
                if (solver->solve_one(&q, &rng, &c, &it) && c.n <= 2)
                    chain_tally_add(&t, &c, sc->radius);
            }
            lit += t.n > 0;
            double v[CHAIN_TALLY_MAX];
            for (int i = 0; i < t.n; ++i) {
                bool in = false;
                for (int j = 0; j < nf; ++j)
                    in = in || spc_snee_same_solution(&fc[j], &t.c[i], sc->radius);
                q.psi = 1.0;
                v[i] = spc_rgb_avg(spc_snee_chain_value(&q, e, uv, &t.c[i])) / p_y;
                ++chains;
                if (!in) {
                    ++missed;
                    printf("    (%.4f, %.4f), light point %d: a chain of %d vertices, value %.1f, not the fit's\n",
                           pts[k][0], pts[k][1], l, t.c[i].n, v[i]);
                }
            }
            pairs += t.n == 2 && v[0] > 50.0 && v[1] > 50.0 && fabs(v[0] - v[1]) < 0.1 * fmax(v[0], v[1]);
        }
    }
    printf("    %d lit light points, %d chains, %d not the fit's, %d near-merged pairs\n", lit, chains, missed, pairs);
    CHECK_MSG(lit >= 10 && chains >= 20, "%d lit light points, %d chains", lit, chains);
    CHECK_MSG(missed == 0, "%d chains not the fit's", missed);
    CHECK_MSG(pairs >= 1, "%d near-merged pairs", pairs);
    spc_scene_destroy(sc);
}

/* From a medium point inside a tessellated glass ball filled with a medium (scenes/medium_glass.xml,
 * the point where a path that left the ball near its rim and hit the light held a seed's error),
 * toward 3 x 3 points of the light around the one that path hit: the volpath plan's attempts with the
 * fitted sphere's way out from inside (spc_sphere_inside_roots, seeds in a cone of 5 degrees around
 * it) against the same attempts without fitted seeds. With them every chain that leaves the ball
 * near its rim (the way out within 25 degrees of grazing) is found with p >= 0.01; without them some
 * such chain has p below 0.004 (the cone and phase seeds find it a few times in a thousand: its
 * count and the phase-sampled paths of weight 1 left beside it were the scene's tail); every
 * chain's trial count is an unbiased 1 / p of the mixture. Fails if the inside roots or their seeds
 * are undone. */
TEST(medium_point_inside_ball_rim_chains)
{
    spc_scene *sc = tu_load("scenes/medium_glass.xml", 0);
    CHECK(sc != NULL && sc->nmedia == 1 && sc->nemitters == 1);
    if (!sc || sc->nmedia != 1 || sc->nemitters != 1)
        return;
    spc_snee_params pf, pu;
    CHECK(spc_snee_parse("angular:camera,first=0.1,later=0.1,nosolvemis,phaseseeds=0.8", 2, &pf));
    CHECK(spc_snee_parse("angular:camera,first=0.1,later=0.1,nosolvemis,phaseseeds=0.8,nofitseeds", 2, &pu));
    const int attempts = spc_test_quick() ? 1500 : 3000, counts = spc_test_quick() ? 40 : 80;
    spc_rng rng;
    spc_rng_seed(&rng, 13, 7);
    spc_receiver r;
    spc_receiver_medium(&r, spc_v3(0.2402338, -0.4709180, -0.4421671), spc_v3(0.1041613, 0.1466586, 0.9836878),
                        &sc->media[0]->phase, 0);
    const spc_emitter *e = sc->emitters[0];
    double pmin_fit = 1.0, pmin_cone = 1.0;
    int rim = 0, checked = 0;
    for (int i = 0; i < 9; ++i) {
        spc_snee_query qf;
        spc_snee_query_init(&qf, sc, &pf, spc_receiver_origin(&r), r.wo, 2);
        qf.receiver = &r;
        spc_vec2 uv;
        double p_y;
        pf.light_u_on = true;
        pf.light_u[0] = 0.5;
        pf.light_u[1] = 0.42 + 0.04 * (i % 3);
        pf.light_u[2] = 0.42 + 0.04 * (i / 3);
        const spc_emitter *ei;
        bool lit = spc_snee_sample_light(sc, false, &rng, &qf, &ei, &uv, &p_y);
        pf.light_u_on = false;
        CHECK(lit && ei == e);
        if (!lit)
            continue;
        spc_fit_roots fit;
        fit.nshapes = 0;
        qf.fit = &fit;
        spc_snee_query qu = qf;
        qu.params = &pu;
        qu.fit = NULL;
        /* the rim chains' p with either seeds, then the counts under the fitted seeds */
        chain_tally ta = {0}, tb = {0};
        for (int a = 0; a < attempts; ++a) {
            spc_chain c;
            int it = 0;
            if (spc_angular_solve_one(&qf, &rng, &c, &it))
                chain_tally_add(&ta, &c, sc->radius);
            if (spc_angular_solve_one(&qu, &rng, &c, &it))
                chain_tally_add(&tb, &c, sc->radius);
        }
        chain_tally all = ta;
        for (int k = 0; k < tb.n; ++k)
            if (!chain_tally_hits(&all, &tb.c[k], sc->radius) && all.n < CHAIN_TALLY_MAX)
                all.c[all.n++] = tb.c[k];
        bool has_rim = false;
        for (int k = 0; k < all.n; ++k) {
            const spc_chain *c = &all.c[k];
            spc_vec3 last = c->v[c->n - 1].h.p;
            double cos_out = spc_dot(spc_normalize(spc_sub(qf.y, last)), c->v[c->n - 1].h.sh.n);
            if (c->n != 1 || !(fabs(cos_out) < 0.42)) /* 25 degrees from grazing */
                continue;
            double pa = (double)chain_tally_hits(&ta, c, sc->radius) / attempts;
            double pb = (double)chain_tally_hits(&tb, c, sc->radius) / attempts;
            printf("    light point %d: rim chain, cos out %.3f, p %.4f with the fitted seeds, %.4f without\n", i,
                   fabs(cos_out), pa, pb);
            ++rim;
            has_rim = true;
            pmin_fit = fmin(pmin_fit, pa);
            pmin_cone = fmin(pmin_cone, pb);
        }
        if (has_rim) { /* the trial counts stay unbiased under the fitted seeds (every chain) */
            chain_seeds_cmp res;
            chain_seeds_cmp_init(&res);
            chain_seeds_compare(&qf, &qu, e, uv, sc->radius, &rng, attempts, counts, 0.02, i, &res);
            checked += res.checked;
        }
    }
    printf("    %d rim chains: smallest p %.4f with the fitted seeds, %.4f without; %d counts checked\n", rim,
           pmin_fit, pmin_cone, checked);
    CHECK(rim >= 3);
    CHECK_MSG(pmin_fit >= 0.01, "a rim chain found with p %g", pmin_fit);
    CHECK_MSG(pmin_cone < 0.004, "without the fitted seeds the rarest rim chain had p %g", pmin_cone);
    CHECK(checked >= 3);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(fit_of_a_tessellated_ball_only);
    RUN(fit_seeds_find_every_chain_and_count_unbiased);
    RUN(fit_root_count_by_length);
    RUN(seed_decides_a_trial);
    RUN(torus_tube_seeds);
    RUN(torus_fold_pair_far_end);
    RUN(ball_fold_pair_counted_exactly);
    RUN(medium_point_inside_ball_rim_chains);
    return spc_test_finish();
}
