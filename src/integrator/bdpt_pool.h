/*
 * integrator/bdpt_pool.h: bdpt's pool of light vertices (bdpt_pool.c): the selection model that
 * says, for a camera vertex in a spatial cell, from which cells of light vertices to pick
 * (learned once per render by bdpt.c's pilot), and the pass's pool of light vertices sorted by
 * cell, from which camera vertices draw their connections.
 *
 * The estimator (Popov et al. 2015, "Probabilistic connections for bidirectional path tracing",
 * secs. 4-5; Davidovic et al. 2014, "Light vertex cache"). Each pass traces N light subpaths (one
 * per pixel of the rendered window: the subpaths plain bdpt's camera samples would trace) and
 * keeps their connectible vertices. Each camera vertex in cell c keeps bdpt's connections to its
 * own pixel's light subpath and makes M_t more (M at the second camera vertex, more at the first,
 * fewer later: spc_bdpt_pool_connections); each picks a light cell k with probability pi_c(k)
 * (the model, fixed for the render), then one of the n_k(P) vertices of this pass's pool P in cell
 * k uniformly, and contributes C w / (N M q) with q = pi_c(k) / n_k(P) the pick's actual
 * probability: given the pool, the expectation is the sum over the pool's vertices of C w / N, so
 * the estimate is unbiased whatever the model. A camera vertex's M_t picks draw their cells by
 * inverting pi_c's running sum at M_t evenly spaced points shifted by one uniform (bdpt.c's
 * connect_pool): each pick alone has the probabilities above, so the estimate stays unbiased, and
 * together they take the cells in proportion to pi_c rather than at random. In the MIS weights a
 * connection is two techniques: the own subpath (one sample of the path) and the pool, counted as
 * c = min(a, N) samples with a = M pi_c(k) / nu_k (nu_k the expected number of connectible
 * vertices per light subpath in cell k, the pilot's; N the pass's light subpaths). Each vertex of cell k is taken a / N times on
 * average, and the pass holds N light subpaths: where a exceeds N (a rarely visited cell with a
 * large pi_c(k): the door's ceiling corner, a = 36,000 at N = 1,024) the picks take the same few
 * vertices many times over and add no sample of the light's side beyond the N subpaths. Counted as
 * a, such joins got the weight of a technique that had found the path 36,000 times where the pass
 * holds one light subpath there or none, and a pass whose subpath bounced in that corner gave one
 * pixel 1,200x its value (bench/RESULTS.md, "bdpt's pool counts its picks as at most N samples").
 * The count a N / (a + N) (the two stages' variances added) also tames that pass but lowers the
 * count in common cells too: 1.7% more error on the door's other seeds. The counts are functions
 * of the path's two joined vertices only, so the weights of every path still sum to one (they use
 * the model's expectation, never this pool's counts, which depend on the light subpath being
 * weighted). Since the own subpath's connection covers every path, pi may be zero where the pilot
 * found nothing: the pool then simply does not help there.
 */
#ifndef SPC_INTEGRATOR_BDPT_POOL_H
#define SPC_INTEGRATOR_BDPT_POOL_H

#include <stddef.h>
#include <stdint.h>

#include "core/math.h"

/* Cells along the scene box's longest side (the others in proportion, at least 1). 8 puts the
 * door's partition (x = 0, box 6 wide) on a cell border and keeps the model's table at most
 * 512 x 512; on the door (32x32, 128 spp, M = 2) 6 and 8 did equally, 12 and 16 worse (the
 * pilot's samples spread over more pairs of cells). */
#define SPC_BDPT_POOL_GRID 8

/* Connections per camera vertex by its depth: the first (the camera ray's hit, t = 2) makes this
 * many times M, the second M, the later ones M / 3 (rounded up). The first vertex's connections
 * carry the pixel's whole light, a later vertex's only what its throughput lets through, and a
 * pick costs little next to the rest of a camera sample. On the door (32x32, 128 spp, seeds 1-2,
 * one thread; relative variance of the mean x CPU s, pilot included; first / second / later):
 * 3 / 3 / 3 0.00457; 15 / 3 / 3 0.00296-0.00308; 24 / 6 / 2 0.00267; 24 / 4 / 2 0.00252;
 * 32 / 8 / 2 0.00249; 32 / 4 / 1 0.00246; 48 / 6 / 1 0.00246; 32 / 4 / 0 0.00241; more at the
 * later vertices loses (2 / 4 / 4: 0.00549). */
#define SPC_BDPT_POOL_FIRST_FACTOR 10

typedef struct spc_bdpt_pool_model {
    int connections; /* M: connections from the second camera vertex */
    int first;       /* from the first camera vertex: SPC_BDPT_POOL_FIRST_FACTOR x M */
    int later;       /* from the later ones: M / 3 rounded up */
    spc_vec3 lo;     /* the grid's corner */
    double inv_cell; /* 1 / the cells' edge */
    int g[3], ncells;
    double *nu;    /* ncells: connectible light vertices per light subpath in the cell */
    double *score; /* ncells x ncells: the pilot's summed contributions, camera cell major */
    double *pi;    /* ncells x ncells: pi_c(k), rows sum to 1 (or 0 with no light vertices) */
    double *cdf;   /* ncells x ncells: each row's running sum of pi (its last nonzero entry and those
                    * after it set to 1); a row that sums to 0 stays 0 */
    double paths;  /* N, the light subpaths of a pass's pool (the rendered window's pixels): the
                    * most a count may be (spc_bdpt_pool_count); 0: no bound */
} spc_bdpt_pool_model;

/* Sets up the grid over [lo, hi] with the tables zeroed and paths 0; false if out of memory (then
 * release it). */
bool spc_bdpt_pool_model_init(spc_bdpt_pool_model *m, spc_vec3 lo, spc_vec3 hi, int connections);
void spc_bdpt_pool_model_release(spc_bdpt_pool_model *m);
/* The cell of point p (points outside the grid go to its nearest cell). */
int spc_bdpt_pool_cell(const spc_bdpt_pool_model *m, spc_vec3 p);
/* After the pilot has added to nu (vertex counts) and score: nu divided by the pilot's light
 * subpaths, pi and its running sums built; false if out of memory. */
bool spc_bdpt_pool_model_finish(spc_bdpt_pool_model *m, double light_paths);
/* Connections from the camera subpath's t-th vertex (t = 2: the camera ray's hit). */
static inline int spc_bdpt_pool_connections(const spc_bdpt_pool_model *m, int t)
{
    return t == 2 ? m->first : t == 3 ? m->connections : m->later;
}
/* The MIS count of the connection joining a light vertex in cell k to a camera vertex in cell c,
 * the camera subpath's t-th vertex: min(a, N) with a = M_t pi_c(k) / nu_k and N = m->paths (a
 * alone where paths is 0; 0 where nu_k is 0: such vertices are never picked). */
static inline double spc_bdpt_pool_count(const spc_bdpt_pool_model *m, int c, int k, int t)
{
    double nu = m->nu[k];
    if (!(nu > 0.0))
        return 0.0;
    double a = spc_bdpt_pool_connections(m, t) * m->pi[(size_t)c * m->ncells + k] / nu;
    return m->paths > 0.0 && a > m->paths ? m->paths : a;
}

/* One vertex of the pool: its light subpath's first vertex (bdpt.c's vertex array) and the
 * number s of light vertices up to it (the vertex is sub[s - 1]). */
typedef struct spc_bdpt_pool_ref {
    const void *sub;
    int s;
    int cell;
} spc_bdpt_pool_ref;

/* A pass's pool: vertices added in a fixed order, then sorted by cell (stable). */
typedef struct spc_bdpt_pool {
    const spc_bdpt_pool_model *m;
    double light_paths;      /* N */
    spc_bdpt_pool_ref *refs; /* by cell after spc_bdpt_pool_finish */
    spc_bdpt_pool_ref *tmp;
    size_t n, cap;
    int *start; /* ncells + 1 */
} spc_bdpt_pool;

/* Empties the pool for a new pass (keeps its memory). */
void spc_bdpt_pool_clear(spc_bdpt_pool *p, const spc_bdpt_pool_model *m, double light_paths);
/* Adds a vertex; false if out of memory. */
bool spc_bdpt_pool_add(spc_bdpt_pool *p, const void *sub, int s, int cell);
/* Sorts the vertices by cell; false if out of memory. */
bool spc_bdpt_pool_finish(spc_bdpt_pool *p);
void spc_bdpt_pool_release(spc_bdpt_pool *p);
/* Picks a light vertex for a camera vertex in cell c from uniforms u1 (the cell: the first k whose
 * running sum of pi_c exceeds u1, so that picks with evenly spread u1 take the cells in proportion)
 * and u2 (the vertex in it); false if the picked cell is empty in this pool (the pick contributes
 * nothing). *q: the pick's probability pi_c(k) / n_k. */
bool spc_bdpt_pool_pick(const spc_bdpt_pool *p, int c, double u1, double u2, const spc_bdpt_pool_ref **ref, double *q);

#endif
