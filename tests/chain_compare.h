/*
 * tests/chain_compare.h: an exact enumeration's chains against randomized solver attempts.
 *
 * The enumerations (spheres, cylinders, normal-mapped planes, flat faces) are tested for
 * completeness the same way: from one receiver point to one light point, the angular solver is
 * run many times, and every distinct chain it finds that the enumeration is meant to cover must
 * be among the enumerated ones.
 */
#ifndef SPC_TESTS_CHAIN_COMPARE_H
#define SPC_TESTS_CHAIN_COMPARE_H

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include "core/rng.h"
#include "harness.h"
#include "manifold/angular.h"
#include "manifold/specular_nee.h"

/* The start the enumeration tests share: the receiver x where a ray straight down from `above` meets
 * the floor (shape 0) first, the query q from it (normal +z, chains of up to max_chain vertices) and
 * a light point drawn from r into q (its emitter and uv in *e and *uv where they are asked for).
 * False where the ray misses the floor or no light point is drawn. q keeps a pointer to x. */
static inline bool chain_compare_floor_query(const spc_scene *sc, const spc_snee_params *p, spc_vec3 above,
                                             int max_chain, spc_rng *r, spc_hit *x, spc_snee_query *q,
                                             const spc_emitter **e, spc_vec2 *uv)
{
    spc_ray ray = {above, spc_v3(0, 0, -1), 0, INFINITY};
    if (!spc_scene_intersect(sc, &ray, x) || x->shape_index != 0)
        return false;
    spc_snee_query_init(q, sc, p, x, spc_v3(0, 0, 1), max_chain);
    const spc_emitter *e_own;
    spc_vec2 uv_own;
    double p_y;
    return spc_snee_sample_light(sc, true, r, q, e ? e : &e_own, uv ? uv : &uv_own, &p_y);
}

/* Whether a randomized chain counts: one the enumeration covers and that reaches the light. */
typedef bool (*chain_compare_keep)(const spc_snee_query *q, const spc_chain *c, void *ctx);

/* `attempts` randomized angular attempts from q, their events drawn from r. Each distinct chain
 * (the first 32) that `keep` accepts adds one to *distinct, and one to *missing when none of
 * all[0..n) is the same solution; a missing chain is printed with `label`. */
static inline void chain_compare_random(const spc_snee_query *q, spc_rng *r, int attempts, const spc_chain *all, int n,
                                        double radius, chain_compare_keep keep, void *ctx, const char *label,
                                        int *distinct, int *missing)
{
    spc_chain seen[32];
    int nseen = 0;
    for (int a = 0; a < attempts; ++a) {
        spc_chain c;
        int it = 0;
        if (!spc_angular_solve_one(q, r, &c, &it) || !keep(q, &c, ctx))
            continue;
        bool dup = false;
        for (int j = 0; j < nseen && !dup; ++j)
            dup = spc_snee_same_solution(&seen[j], &c, radius);
        if (dup || nseen == 32)
            continue;
        seen[nseen++] = c;
        ++*distinct;
        bool in = false;
        for (int i = 0; i < n && !in; ++i)
            in = spc_snee_same_solution(&all[i], &c, radius);
        if (!in) {
            ++*missing;
            printf("    %s, x (%g %g %g), y (%g %g %g): a randomized chain of %d vertices (first at %g %g %g) not "
                   "enumerated\n",
                   label, q->x->p.x, q->x->p.y, q->x->p.z, q->y.x, q->y.y, q->y.z, c.n, c.v[0].h.p.x, c.v[0].h.p.y,
                   c.v[0].h.p.z);
        }
    }
}

/* Distinct chains and how often attempts found each (the first CHAIN_TALLY_MAX), two chains being
 * the same solution when spc_snee_same_solution says so at the given size. */
#define CHAIN_TALLY_MAX 16

typedef struct chain_tally {
    spc_chain c[CHAIN_TALLY_MAX];
    int hits[CHAIN_TALLY_MAX];
    int n;
} chain_tally;

static inline void chain_tally_add(chain_tally *t, const spc_chain *c, double size)
{
    for (int i = 0; i < t->n; ++i)
        if (spc_snee_same_solution(&t->c[i], c, size)) {
            t->hits[i]++;
            return;
        }
    if (t->n < CHAIN_TALLY_MAX) {
        t->c[t->n] = *c;
        t->hits[t->n++] = 1;
    }
}

static inline int chain_tally_hits(const chain_tally *t, const spc_chain *c, double size)
{
    for (int i = 0; i < t->n; ++i)
        if (spc_snee_same_solution(&t->c[i], c, size))
            return t->hits[i];
    return 0;
}

/* Two seed strategies for the randomized solver at one receiver point, a (tested) against b (the
 * reference), summed over the points a test visits. */
typedef struct chain_seeds_cmp {
    double m2_a, m2_b;     /* second moment of the estimate, summed over chains of value v: v^2 (2 - p) / p */
    double pmin_a, pmin_b; /* the smallest p of a chain worth more than 1% of the point's best */
    int checked;           /* chains whose trial count was checked */
} chain_seeds_cmp;

static inline void chain_seeds_cmp_init(chain_seeds_cmp *r)
{
    r->m2_a = r->m2_b = 0.0;
    r->pmin_a = r->pmin_b = 1.0;
    r->checked = 0;
}

/* `attempts` solves of qa and of qb (same receiver and light point y on emitter e at uv) find the
 * chains and each one's probability p per attempt under either strategy; the second moments and
 * smallest p are added to *r. Each chain with p_a >= count_pmin is then counted with
 * spc_snee_count_same `counts` times under qa: the mean trial count times p_a must be 1 (an unbiased
 * 1/p), within 4 standard errors of both estimates. `radius`: the size that tells chains apart. */
static inline void chain_seeds_compare(const spc_snee_query *qa, const spc_snee_query *qb, const spc_emitter *e,
                                       spc_vec2 uv, double radius, spc_rng *rng, int attempts, int counts,
                                       double count_pmin, int point, chain_seeds_cmp *r)
{
    chain_tally ta = {0}, tb = {0};
    for (int a = 0; a < attempts; ++a) {
        spc_chain c;
        int it = 0;
        if (spc_angular_solve_one(qa, rng, &c, &it))
            chain_tally_add(&ta, &c, radius);
        if (spc_angular_solve_one(qb, rng, &c, &it))
            chain_tally_add(&tb, &c, radius);
    }
    chain_tally all = ta;
    for (int s = 0; s < tb.n; ++s)
        if (!chain_tally_hits(&all, &tb.c[s], radius) && all.n < CHAIN_TALLY_MAX)
            all.c[all.n++] = tb.c[s];
    double vmax = 0.0;
    for (int s = 0; s < all.n; ++s)
        vmax = fmax(vmax, spc_rgb_lum(spc_snee_chain_value(qa, e, uv, &all.c[s])));
    for (int s = 0; s < all.n; ++s) {
        double v = spc_rgb_lum(spc_snee_chain_value(qa, e, uv, &all.c[s]));
        if (!(v > 0.0))
            continue; /* no value (the last segment blocked, the light's back) */
        double pa = (double)chain_tally_hits(&ta, &all.c[s], radius) / attempts;
        double pb = (double)chain_tally_hits(&tb, &all.c[s], radius) / attempts;
        pa = pa > 0.0 ? pa : 1.0 / attempts;
        pb = pb > 0.0 ? pb : 1.0 / attempts;
        r->m2_a += v * v * (2.0 - pa) / pa;
        r->m2_b += v * v * (2.0 - pb) / pb;
        if (v > 0.01 * vmax) {
            r->pmin_a = pa < r->pmin_a ? pa : r->pmin_a;
            r->pmin_b = pb < r->pmin_b ? pb : r->pmin_b;
        }
        if (pa < count_pmin)
            continue;
        spc_chain_sig want;
        spc_chain_signature(&all.c[s], &want);
        spc_snee_query tq = *qa;
        tq.want = &want;
        double sn = 0.0, sn2 = 0.0;
        for (int k = 0; k < counts; ++k) {
            bool capped;
            int it = 0, att = 0;
            double n = spc_snee_count_same(&tq, spc_specular_solver_get(SPC_SNEE_ANGULAR), NULL, rng, &all.c[s],
                                           100000, &att, &capped, &it);
            sn += n;
            sn2 += n * n;
        }
        double mean = sn / counts, var = (sn2 / counts - mean * mean) / counts;
        /* the product's relative error: the count's mean and the frequency's */
        double rel = sqrt(var / (mean * mean) + (1.0 - pa) / (pa * attempts));
        double z = (mean * pa - 1.0) / rel;
        printf("    x %d chain %d (%d vertices, value %.3g): p %.4f, reference seeds %.4f; mean count %.2f, "
               "p x count %.3f (z %+.2f)\n",
               point, s, all.c[s].n, v, pa, pb, mean, mean * pa, z);
        CHECK_MSG(fabs(z) < 4.0, "x %d chain %d: p %g, mean count %g, z %g", point, s, pa, mean, z);
        ++r->checked;
    }
}

/* The point of shape `floor_shape` straight below (px, 0.05, pz). */
static inline bool chain_floor_point(const spc_scene *sc, int floor_shape, double px, double pz, spc_hit *x)
{
    spc_ray ray = {spc_v3(px, 0.05, pz), spc_v3(0, -1, 0), 0, INFINITY};
    return spc_scene_intersect(sc, &ray, x) && x->shape_index == floor_shape;
}

#endif
