/*
 * integrator/bdpt_pool.c: the light-vertex pool's selection model and the pass's pool sorted by
 * cell (bdpt_pool.h states the estimator; bdpt.c traces the pool and the pilot and makes the
 * connections). Popov et al. 2015, secs. 4-5: the selection distribution per camera cell from the
 * estimated contributions of the cells' light vertices, visibility included (the pilot's shadow
 * rays); bdpt's own connections stay the defensive technique (bdpt_pool.h).
 */
#include <stdlib.h>
#include <string.h>

#include "integrator/bdpt_pool.h"

bool spc_bdpt_pool_model_init(spc_bdpt_pool_model *m, spc_vec3 lo, spc_vec3 hi, int connections)
{
    memset(m, 0, sizeof *m);
    m->connections = connections;
    m->first = SPC_BDPT_POOL_FIRST_FACTOR * connections;
    m->later = (connections + 2) / 3;
    double ext[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
    double longest = spc_max(ext[0], spc_max(ext[1], ext[2]));
    if (!(longest > 0.0) || !isfinite(longest))
        longest = 1.0;
    double cell = longest / SPC_BDPT_POOL_GRID;
    m->inv_cell = 1.0 / cell;
    m->lo = lo;
    m->ncells = 1;
    for (int a = 0; a < 3; ++a) {
        int g = (int)ceil(ext[a] / cell - 1e-9);
        m->g[a] = g < 1 ? 1 : g > SPC_BDPT_POOL_GRID ? SPC_BDPT_POOL_GRID : g;
        m->ncells *= m->g[a];
    }
    size_t n = (size_t)m->ncells;
    m->nu = calloc(n, sizeof *m->nu);
    m->score = calloc(n * n, sizeof *m->score);
    m->pi = calloc(n * n, sizeof *m->pi);
    m->cdf = calloc(n * n, sizeof *m->cdf);
    return m->nu && m->score && m->pi && m->cdf;
}

void spc_bdpt_pool_model_release(spc_bdpt_pool_model *m)
{
    free(m->nu);
    free(m->score);
    free(m->pi);
    free(m->cdf);
    memset(m, 0, sizeof *m);
}

int spc_bdpt_pool_cell(const spc_bdpt_pool_model *m, spc_vec3 p)
{
    double q[3] = {p.x - m->lo.x, p.y - m->lo.y, p.z - m->lo.z};
    int i[3];
    for (int a = 0; a < 3; ++a) {
        double f = q[a] * m->inv_cell;
        int v = f >= 0.0 ? (int)f : 0; /* also NaN -> 0 */
        i[a] = v < m->g[a] ? v : m->g[a] - 1;
    }
    return (i[2] * m->g[1] + i[1]) * m->g[0] + i[0];
}

/* Row pi (n entries summing to 1 or 0) into its running sums; from its last nonzero entry on they
 * are 1, so that every u1 < 1 finds a cell that pi can pick despite rounding. */
static void cdf_build(const double *pi, int n, double *cdf)
{
    double sum = 0.0;
    int last = -1;
    for (int k = 0; k < n; ++k) {
        sum += pi[k];
        cdf[k] = sum;
        if (pi[k] > 0.0)
            last = k;
    }
    for (int k = last < 0 ? n : last; k < n; ++k)
        cdf[k] = 1.0;
}

bool spc_bdpt_pool_model_finish(spc_bdpt_pool_model *m, double light_paths)
{
    const int n = m->ncells;
    double nu_sum = 0.0;
    for (int k = 0; k < n; ++k) {
        m->nu[k] = light_paths > 0.0 ? m->nu[k] / light_paths : 0.0;
        nu_sum += m->nu[k];
    }
    for (int c = 0; c < n; ++c) {
        const double *sc = m->score + (size_t)c * n;
        double *pi = m->pi + (size_t)c * n;
        double s = 0.0;
        for (int k = 0; k < n; ++k)
            s += m->nu[k] > 0.0 ? sc[k] : 0.0;
        for (int k = 0; k < n; ++k) {
            if (!(m->nu[k] > 0.0) || !(nu_sum > 0.0))
                pi[k] = 0.0;
            else /* a row the pilot never scored picks uniformly among the pool's vertices */
                pi[k] = s > 0.0 ? sc[k] / s : m->nu[k] / nu_sum;
        }
        cdf_build(pi, n, m->cdf + (size_t)c * n);
    }
    return true;
}

void spc_bdpt_pool_clear(spc_bdpt_pool *p, const spc_bdpt_pool_model *m, double light_paths)
{
    p->m = m;
    p->light_paths = light_paths;
    p->n = 0;
}

bool spc_bdpt_pool_add(spc_bdpt_pool *p, const void *sub, int s, int cell)
{
    if (p->n == p->cap) {
        size_t cap = p->cap ? 2 * p->cap : 4096;
        spc_bdpt_pool_ref *r = realloc(p->refs, cap * sizeof *r);
        if (!r)
            return false;
        p->refs = r;
        p->cap = cap;
    }
    p->refs[p->n++] = (spc_bdpt_pool_ref){sub, s, cell};
    return true;
}

bool spc_bdpt_pool_finish(spc_bdpt_pool *p)
{
    const int n = p->m->ncells;
    if (!p->start) {
        p->start = malloc((size_t)(n + 1) * sizeof *p->start);
        if (!p->start)
            return false;
    }
    spc_bdpt_pool_ref *tmp = realloc(p->tmp, (p->cap ? p->cap : 1) * sizeof *tmp);
    if (!tmp)
        return false;
    p->tmp = tmp;
    /* counting sort, stable: the order within a cell is the order of addition */
    memset(p->start, 0, (size_t)(n + 1) * sizeof *p->start);
    for (size_t i = 0; i < p->n; ++i)
        p->start[p->refs[i].cell + 1]++;
    for (int k = 0; k < n; ++k)
        p->start[k + 1] += p->start[k];
    int *fill = p->start; /* advanced while placing, then restored */
    for (size_t i = 0; i < p->n; ++i)
        tmp[fill[p->refs[i].cell]++] = p->refs[i];
    for (int k = n; k > 0; --k)
        p->start[k] = p->start[k - 1];
    p->start[0] = 0;
    p->tmp = p->refs;
    p->refs = tmp;
    return true;
}

void spc_bdpt_pool_release(spc_bdpt_pool *p)
{
    free(p->refs);
    free(p->tmp);
    free(p->start);
    memset(p, 0, sizeof *p);
}

bool spc_bdpt_pool_pick(const spc_bdpt_pool *p, int c, double u1, double u2, const spc_bdpt_pool_ref **ref, double *q)
{
    const spc_bdpt_pool_model *m = p->m;
    const int n = m->ncells;
    const size_t row = (size_t)c * n;
    const double *cdf = m->cdf + row;
    int lo = 0, hi = n - 1; /* the first k with u1 < cdf[k] (hi: a row of zeros, whose pi is 0) */
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (u1 < cdf[mid])
            hi = mid;
        else
            lo = mid + 1;
    }
    const int k = lo;
    double pk = m->pi[row + k];
    int cnt = p->start[k + 1] - p->start[k];
    if (!(pk > 0.0) || cnt <= 0)
        return false;
    int j = (int)(u2 * cnt);
    if (j >= cnt)
        j = cnt - 1;
    *ref = &p->refs[p->start[k] + j];
    *q = pk / cnt;
    return true;
}
