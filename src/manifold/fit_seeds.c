/*
 * manifold/fit_seeds.c: seeds from the sphere fitted to a tessellated ball (fit_seeds.h): the fit,
 * kept in the shape, and the fitted sphere's exact solutions (sphere_roots.h) as
 * seed directions.
 */
#include "manifold/fit_seeds.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "manifold/solver.h"
#include "manifold/sphere_roots.h"

/* A ball's tessellation: every vertex within this fraction of the radius from the fitted sphere,
 * and each side of the bounding box within it of the diameter (a hemisphere, a cube, a torus or an
 * elongated pebble fail). A UV sphere of 16 x 32 faces has its vertices on the sphere and its faces
 * within 2% of it. */
#define SPC_FIT_TOL 0.05
/* Fewer vertices than this is a polyhedron, not a ball. */
#define SPC_FIT_MIN_VERTS 24

typedef struct fit_cache {
    void (*destroy)(void *); /* first member: spc_shape_release calls it */
    bool ok;
    spc_vec3 center;
    double radius;
} fit_cache;

static void fit_destroy(void *p) { free(p); }

static void fit_build(const spc_shape *s, fit_cache *fc)
{
    double eta = 0.0;
    const spc_mesh *m = &s->mesh;
    if (s->type != SPC_SHAPE_MESH || !s->bsdf || !spc_bsdf_is_specular_interface(s->bsdf, &eta) ||
        m->nverts < SPC_FIT_MIN_VERTS)
        return;
    spc_vec3 c = spc_scale(spc_add(s->bbox_min, s->bbox_max), 0.5);
    double sum = 0.0;
    for (size_t i = 0; i < m->nverts; ++i)
        sum += spc_distance(spc_v3(m->p[3 * i], m->p[3 * i + 1], m->p[3 * i + 2]), c);
    double R = sum / (double)m->nverts;
    if (!(R > 0.0) || !isfinite(R))
        return;
    spc_vec3 ext = spc_sub(s->bbox_max, s->bbox_min);
    if (fabs(ext.x - 2.0 * R) > SPC_FIT_TOL * 2.0 * R || fabs(ext.y - 2.0 * R) > SPC_FIT_TOL * 2.0 * R ||
        fabs(ext.z - 2.0 * R) > SPC_FIT_TOL * 2.0 * R)
        return;
    for (size_t i = 0; i < m->nverts; ++i)
        if (fabs(spc_distance(spc_v3(m->p[3 * i], m->p[3 * i + 1], m->p[3 * i + 2]), c) - R) > SPC_FIT_TOL * R)
            return;
    fc->ok = true;
    fc->center = c;
    fc->radius = R;
}

bool spc_fit_sphere(const spc_shape *s, spc_vec3 *center, double *radius)
{
    if (s->type != SPC_SHAPE_MESH)
        return false;
    void **slot = (void **)&((spc_shape *)s)->fit_cache;
    fit_cache *cur = __atomic_load_n(slot, __ATOMIC_ACQUIRE);
    if (!cur) {
        fit_cache *fc = calloc(1, sizeof *fc);
        if (!fc)
            return false;
        fc->destroy = fit_destroy;
        fit_build(s, fc);
        void *expected = NULL;
        if (__atomic_compare_exchange_n(slot, &expected, (void *)fc, false, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE))
            cur = fc;
        else {
            fit_destroy(fc); /* another thread won */
            cur = expected;
        }
    }
    if (!cur->ok)
        return false;
    *center = cur->center;
    *radius = cur->radius;
    return true;
}

/* The first directions of the fitted sphere's chains (center c, radius R) from q's x to its y, of
 * the query's lengths and the events its params allow (a conductor: one reflection; a dielectric:
 * in and out, with reflect also one reflection and internal ones): at most max, written to dir. */
static int fit_dirs(const spc_snee_query *q, const spc_shape *s, spc_vec3 c, double R, spc_vec3 *dir,
                    signed char *ms, int max)
{
    spc_vec3 x = q->x->p;
    spc_sphere_plane pl;
    if (!spc_sphere_plane_of(x, c, R, q->y, &pl))
        return 0;
    double eta = 0.0;
    spc_bsdf_is_specular_interface(s->bsdf, &eta);
    bool conductor = !(eta > 0.0), reflect = q->params && q->params->reflect;
    /* m = -1: one reflection; m >= 0: in, m internal reflections, out (m + 2 vertices) */
    int m_lo = conductor || reflect ? -1 : 0;
    int m_hi = conductor ? -1 : (reflect ? SPC_CHAIN_MAX_VERTICES - 2 : 0);
    if (m_hi > q->max_chain - 2)
        m_hi = q->max_chain - 2;
    if (q->min_chain > 1 && m_lo < q->min_chain - 2)
        m_lo = q->min_chain - 2;
    int n = 0;
    for (int m = m_lo; m <= m_hi && n < max; ++m) {
        double theta[SPC_FIT_MAX_DIRS];
        int nr = spc_sphere_chain_roots(pl.d, pl.y1, pl.y2, m, eta, theta, max - n);
        for (int r = 0; r < nr; ++r) {
            ms[n] = (signed char)m;
            dir[n++] = spc_normalize(spc_sub(spc_sphere_plane_point(&pl, theta[r]), x));
        }
    }
    return n;
}

/* The fitted sphere's solution directions for q and caster s (center c, radius R) and their events
 * (*ms): q->fit's entry for s and q's chain lengths, filled on first use, or where q->fit has no
 * room, computed into `all` and `all_m`. */
static const spc_vec3 *fit_entry(const spc_snee_query *q, const spc_shape *s, spc_vec3 c, double R,
                                 spc_vec3 all[SPC_FIT_MAX_DIRS], signed char all_m[SPC_FIT_MAX_DIRS], int *n,
                                 const signed char **ms)
{
    spc_fit_roots *fr = q->fit;
    int j = 0;
    while (fr && j < fr->nshapes &&
           (fr->e[j].s != s || fr->e[j].min_chain != q->min_chain || fr->e[j].max_chain != q->max_chain))
        ++j;
    if (fr && j == fr->nshapes && j < SPC_FIT_MAX_SHAPES) {
        fr->e[j].s = s;
        fr->e[j].min_chain = q->min_chain;
        fr->e[j].max_chain = q->max_chain;
        fr->e[j].n = fit_dirs(q, s, c, R, fr->e[j].dir, fr->e[j].m, SPC_FIT_MAX_DIRS);
        fr->nshapes++;
    }
    if (fr && j < fr->nshapes) {
        *n = fr->e[j].n;
        *ms = fr->e[j].m;
        return fr->e[j].dir;
    }
    *n = fit_dirs(q, s, c, R, all, all_m, SPC_FIT_MAX_DIRS);
    *ms = all_m;
    return all;
}

int spc_fit_root_count(const spc_snee_query *q, const spc_shape *s)
{
    spc_vec3 c, all[SPC_FIT_MAX_DIRS];
    signed char all_m[SPC_FIT_MAX_DIRS];
    const signed char *ms;
    double R;
    int n = 0;
    if (!spc_fit_sphere(s, &c, &R))
        return 0;
    fit_entry(q, s, c, R, all, all_m, &n, &ms);
    return n;
}

int spc_fit_roots_of(const spc_snee_query *q, const spc_shape *s, spc_vec3 *dir, int *m, int max)
{
    spc_vec3 c, all[SPC_FIT_MAX_DIRS];
    signed char all_m[SPC_FIT_MAX_DIRS];
    const signed char *ms;
    double R;
    int n = 0;
    if (!spc_fit_sphere(s, &c, &R))
        return 0;
    const spc_vec3 *d = fit_entry(q, s, c, R, all, all_m, &n, &ms);
    if (n > max)
        n = max;
    for (int i = 0; i < n; ++i) {
        dir[i] = d[i];
        m[i] = ms[i];
    }
    return n;
}

bool spc_fit_seed(const spc_snee_query *q, const spc_shape *s, spc_rng *rng, spc_vec3 *dir)
{
    spc_vec3 c;
    double R;
    if (!spc_fit_sphere(s, &c, &R))
        return false;
    double share = q->params && q->params->fit_share > 0.0 ? q->params->fit_share : SPC_FIT_SEED_SHARE;
    if (!(spc_rng_next(rng) < share))
        return false;
    double u = spc_rng_next(rng);
    spc_vec3 all[SPC_FIT_MAX_DIRS];
    signed char all_m[SPC_FIT_MAX_DIRS];
    const signed char *ms;
    int n = 0;
    const spc_vec3 *d = fit_entry(q, s, c, R, all, all_m, &n, &ms);
    if (n < 1)
        return false;
    int i = (int)(u * n);
    *dir = d[i < n ? i : n - 1];
    return true;
}
