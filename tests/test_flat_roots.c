/*
 * tests/test_flat_roots.c: the flat enumeration (flat_chains.h) makes every chain that
 * spc_flat_chain_covers accepts, on bench/check/two_slabs_sphere_light.xml.
 *
 * A path that covers accepts is weighted by the MIS against specular NEE's density for it; if the
 * enumeration does not make it, its light is lost (the BSDF side gives it a weight below 1, specular
 * NEE nothing). So from a floor point under both slabs, paths are sampled by the BSDFs alone; each
 * one that reaches the light through 5 vertices that covers accepts (into the lower slab, a total
 * internal reflection off a side face, out, through the upper slab, or the like) is looked up among
 * spc_flat_chain_roots from the floor point to the path's point on the light: one root must have
 * the path's vertices within a small distance and the same events. The same for 3 and 4 vertices.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "chain_mis.h"
#include "core/rng.h"
#include "harness.h"
#include "manifold/chain.h"
#include "manifold/flat_chains.h"
#include "specula/specula.h"

#define SCENE "bench/check/two_slabs_sphere_light.xml"
#define CAMERA spc_v3(-0.4, 2.6, 3.4)
/* Paths with a segment shorter than this are left out: the solver takes a minimum with a segment
 * near 1e-6 of the problem's size (here about 3e-6) for a kink, no chain (flat_chains.c, minimize),
 * and such paths (a vertex on a slab's edge) carry a vanishing share of the light. */
#define SHORTEST 1e-4

/* The scene, its light's radius and radiance set (the XML's defaults light_radius, light_radiance). */
static spc_scene *load(const char *light_radius, const char *light_radiance)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", d ? d : ".", SCENE);
    return chain_mis_load(path, light_radius, light_radiance);
}

/* One BSDF-sampled path from x through delta vertices only: true where it reaches the light, with
 * its vertices in c (hits, arriving directions, events; c->n of them), the light's point in *y and
 * the path's throughput times the light's radiance (luminance) in *value. */
static bool sample_path(const spc_scene *sc, const spc_hit *x, spc_vec3 wo, spc_rng *u, spc_chain *c, spc_vec3 *y,
                        double *value)
{
    c->n = 0;
    spc_bsdf_sample bs;
    if (!spc_bsdf_sample_dir(x->bsdf, x, SPC_MODE_RADIANCE, wo, spc_rng_next(u),
                             spc_v2(spc_rng_next(u), spc_rng_next(u)), &bs))
        return false;
    spc_rgb T = bs.weight;
    spc_ray ray = spc_hit_spawn(x, bs.wi);
    for (;;) {
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h))
            return false;
        if (h.emitter) {
            *y = h.p;
            *value = spc_rgb_lum(spc_rgb_mul(T, spc_emitter_eval_area(h.emitter, &h, spc_neg(ray.d))));
            return c->n > 0;
        }
        if (c->n == SPC_FLAT_MAX_VERTICES || !spc_bsdf_is_delta_only(h.bsdf))
            return false;
        spc_bsdf_sample b2;
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, spc_neg(ray.d), spc_rng_next(u),
                                 spc_v2(spc_rng_next(u), spc_rng_next(u)), &b2))
            return false;
        spc_chain_vertex *v = &c->v[c->n++];
        memset(v, 0, sizeof *v);
        v->h = h;
        v->wi = ray.d;
        v->d = b2.wi;
        v->event = (b2.lobe & SPC_LOBE_DELTA_TRANSMISSION) ? SPC_CHAIN_REFRACT : SPC_CHAIN_REFLECT;
        T = spc_rgb_mul(T, b2.weight);
        ray = spc_hit_spawn(&h, b2.wi);
    }
}

/* Is the path c among the roots of exactly c->n vertices from x to y (each vertex within tol)? */
static bool among_roots(const spc_scene *sc, const spc_chain *c, spc_vec3 x, spc_vec3 y, double tol, int *nroots)
{
    enum { MAX = 64 };
    spc_vec3 pts[MAX * SPC_FLAT_MAX_VERTICES];
    unsigned char ev[MAX * SPC_FLAT_MAX_VERTICES];
    int n = spc_flat_chain_roots(sc, false, true, x, y, c->n, pts, ev, MAX, NULL);
    *nroots = n;
    for (int i = 0; i < n; ++i) {
        bool same = true;
        for (int j = 0; j < c->n && same; ++j)
            same = spc_length(spc_sub(pts[c->n * i + j], c->v[j].h.p)) < tol &&
                   ev[c->n * i + j] == (unsigned char)c->v[j].event;
        if (same)
            return true;
    }
    return false;
}

/* The shortest segment between c's vertices (and from x to its first). */
static double shortest_segment(const spc_chain *c, spc_vec3 x)
{
    double m = spc_length(spc_sub(c->v[0].h.p, x));
    for (int j = 1; j < c->n; ++j)
        m = fmin(m, spc_length(spc_sub(c->v[j].h.p, c->v[j - 1].h.p)));
    return m;
}

/* From the floor point (px, pz), BSDF paths until `want` of them reach the light through k >= 3
 * vertices that covers accepts: the value of those the roots miss over the value of all, per k. */
static void missed_share(const spc_scene *sc, double px, double pz, int want, double *missed, double *all, int *found,
                         int *lost, int *edge)
{
    spc_ray down = {spc_v3(px, 0.01, pz), spc_v3(0, -1, 0), 0, INFINITY};
    spc_hit x;
    CHECK(spc_scene_intersect(sc, &down, &x) && x.shape_index == 0);
    spc_vec3 wo = spc_normalize(spc_sub(CAMERA, x.p));
    spc_rng u;
    spc_rng_seed(&u, 21, 1);
    for (int k = 0; k <= SPC_FLAT_MAX_VERTICES; ++k) {
        missed[k] = all[k] = 0.0;
        found[k] = lost[k] = 0;
    }
    int n = 0;
    *edge = 0;
    for (long i = 0; i < 20000000 && n < want; ++i) {
        spc_chain c;
        spc_vec3 y;
        double v;
        if (!sample_path(sc, &x, wo, &u, &c, &y, &v) || c.n < 3 || !(v > 0.0) || !spc_flat_chain_covers(&c, true))
            continue;
        ++n;
        if (shortest_segment(&c, x.p) < SHORTEST) {
            ++*edge;
            continue;
        }
        int nroots;
        bool in = among_roots(sc, &c, x.p, y, 1e-5, &nroots);
        all[c.n] += v;
        if (in) {
            ++found[c.n];
        } else {
            ++lost[c.n];
            missed[c.n] += v;
            if (lost[c.n] <= 3) {
                printf("    missed, %d vertices (%d roots there):", c.n, nroots);
                for (int j = 0; j < c.n; ++j)
                    printf(" %s(%.4f %.4f %.4f)", c.v[j].event == SPC_CHAIN_REFLECT ? "R" : "T", c.v[j].h.p.x,
                           c.v[j].h.p.y, c.v[j].h.p.z);
                printf(" -> y (%.4f %.4f %.4f), shortest segment %.3g\n", y.x, y.y, y.z, shortest_segment(&c, x.p));
            }
        }
    }
}

TEST(every_covered_chain_is_a_root)
{
    /* a larger light (same power) so that BSDF sampling reaches it often */
    spc_scene *sc = load("0.3", "17.8, 17, 16");
    if (!sc)
        return;
    /* floor points under both slabs: test_flat_bias.c's (a third of its light through five
     * vertices) and three more */
    static const double pts[][2] = {{-0.064, 0.142}, {0.15, -0.05}, {-0.15, 0.05}, {0.2, 0.25}};
    const int npaths = getenv("NPATHS") ? atoi(getenv("NPATHS")) : 1000;
    for (int i = 0; i < 4; ++i) {
        double missed[SPC_FLAT_MAX_VERTICES + 1], all[SPC_FLAT_MAX_VERTICES + 1];
        int found[SPC_FLAT_MAX_VERTICES + 1], lost[SPC_FLAT_MAX_VERTICES + 1];
        int edge;
        missed_share(sc, pts[i][0], pts[i][1], npaths, missed, all, found, lost, &edge);
        printf("    (%.3f, %.3f): %d paths with a segment under %g left out\n", pts[i][0], pts[i][1], edge, SHORTEST);
        for (int k = 3; k <= SPC_FLAT_MAX_VERTICES; ++k) {
            if (!found[k] && !lost[k])
                continue;
            printf("    (%.3f, %.3f), %d vertices: %d paths found among the roots, %d not (%.1f%% of their value)\n",
                   pts[i][0], pts[i][1], k, found[k], lost[k], all[k] > 0.0 ? 100.0 * missed[k] / all[k] : 0.0);
            CHECK_MSG(lost[k] == 0, "%d of %d covered %d-vertex paths are no root", lost[k], found[k] + lost[k], k);
        }
    }
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(every_covered_chain_is_a_root);
    return spc_test_finish();
}
