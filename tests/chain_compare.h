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
#include "manifold/angular.h"
#include "manifold/specular_nee.h"

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

/* The point of shape `floor_shape` straight below (px, 0.05, pz). */
static inline bool chain_floor_point(const spc_scene *sc, int floor_shape, double px, double pz, spc_hit *x)
{
    spc_ray ray = {spc_v3(px, 0.05, pz), spc_v3(0, -1, 0), 0, INFINITY};
    return spc_scene_intersect(sc, &ray, x) && x->shape_index == floor_shape;
}

#endif
