/*
 * manifold/fit_seeds.c: seeds from the sphere fitted to a tessellated ball (fit_seeds.h): the fit,
 * kept in the shape, and the fitted sphere's exact solutions (sphere_roots.h) as
 * seed directions. A glass SDF that is one torus gets seeds the same way from spheres of its tube's
 * radius centred on its core circle near the query (spc_fit_torus).
 */
#include "manifold/fit_seeds.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/warp.h"
#include "manifold/receiver.h"
#include "manifold/solver.h"
#include "scene/sdf.h"
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
    bool torus; /* an SDF of one torus primitive (spc_fit_torus) */
    spc_vec3 axis;
    double major, minor;
    double edge; /* a fitted mesh's longest edge over its radius (spc_fit_edge_angle) */
} fit_cache;

static void fit_destroy(void *p) { free(p); }

/* A specular SDF whose field is one torus primitive: its centre, axis, major and minor radii in world
 * units (the node frame has the torus around local y at the origin; M maps world to node). */
static void torus_build(const spc_shape *s, fit_cache *fc)
{
    double eta = 0.0;
    spc_sdf_flat f;
    int depth = 0;
    if (!s->sdf || !s->bsdf || !spc_bsdf_is_specular_interface(s->bsdf, &eta) ||
        spc_sdf_flatten(s->sdf, &f, 1, &depth) != 1 || f.type != SPC_SDF_TORUS || !(f.s > 0.0))
        return;
    double(*M)[4] = f.M;
    double det = M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) - M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                 M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]);
    if (!(fabs(det) > 0.0))
        return;
    double inv[3][3]; /* the inverse of M's linear part (adjugate over the determinant) */
    inv[0][0] = (M[1][1] * M[2][2] - M[1][2] * M[2][1]) / det;
    inv[0][1] = (M[0][2] * M[2][1] - M[0][1] * M[2][2]) / det;
    inv[0][2] = (M[0][1] * M[1][2] - M[0][2] * M[1][1]) / det;
    inv[1][0] = (M[1][2] * M[2][0] - M[1][0] * M[2][2]) / det;
    inv[1][1] = (M[0][0] * M[2][2] - M[0][2] * M[2][0]) / det;
    inv[1][2] = (M[0][2] * M[1][0] - M[0][0] * M[1][2]) / det;
    inv[2][0] = (M[1][0] * M[2][1] - M[1][1] * M[2][0]) / det;
    inv[2][1] = (M[0][1] * M[2][0] - M[0][0] * M[2][1]) / det;
    inv[2][2] = (M[0][0] * M[1][1] - M[0][1] * M[1][0]) / det;
    /* the node origin in world: M o + t = 0; the axis: the image of local y */
    spc_vec3 o = spc_v3(-(inv[0][0] * M[0][3] + inv[0][1] * M[1][3] + inv[0][2] * M[2][3]),
                        -(inv[1][0] * M[0][3] + inv[1][1] * M[1][3] + inv[1][2] * M[2][3]),
                        -(inv[2][0] * M[0][3] + inv[2][1] * M[1][3] + inv[2][2] * M[2][3]));
    spc_vec3 a = spc_v3(inv[0][1], inv[1][1], inv[2][1]);
    double la = spc_length(a);
    if (!(la > 0.0) || !(f.param[0] > f.param[1]) || !(f.param[1] > 0.0))
        return;
    fc->torus = true;
    fc->center = o;
    fc->axis = spc_scale(a, 1.0 / la);
    fc->major = f.s * f.param[0];
    fc->minor = f.s * f.param[1];
}

static void fit_build(const spc_shape *s, fit_cache *fc)
{
    double eta = 0.0;
    const spc_mesh *m = &s->mesh;
    if (s->type == SPC_SHAPE_SDF) {
        torus_build(s, fc);
        return;
    }
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
    double e2 = 0.0;
    for (size_t t = 0; t < m->ntris; ++t)
        for (int k = 0; k < 3; ++k) {
            const float *a = m->p + 3 * (size_t)m->idx[3 * t + k], *b = m->p + 3 * (size_t)m->idx[3 * t + (k + 1) % 3];
            double dx = (double)a[0] - b[0], dy = (double)a[1] - b[1], dz = (double)a[2] - b[2];
            e2 = fmax(e2, dx * dx + dy * dy + dz * dz);
        }
    fc->ok = true;
    fc->center = c;
    fc->radius = R;
    fc->edge = sqrt(e2) / R;
}

/* The shape's cache, built on first use (thread-safe); NULL where out of memory. */
static const fit_cache *cache_of(const spc_shape *s)
{
    void **slot = (void **)&((spc_shape *)s)->fit_cache;
    fit_cache *cur = __atomic_load_n(slot, __ATOMIC_ACQUIRE);
    if (!cur) {
        fit_cache *fc = calloc(1, sizeof *fc);
        if (!fc)
            return NULL;
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
    return cur;
}

bool spc_fit_sphere(const spc_shape *s, spc_vec3 *center, double *radius)
{
    if (s->type != SPC_SHAPE_MESH)
        return false;
    const fit_cache *cur = cache_of(s);
    if (!cur || !cur->ok)
        return false;
    *center = cur->center;
    *radius = cur->radius;
    return true;
}

/* The signatures m (-1: one reflection; m >= 0: in, m internal reflections, out: m + 2 vertices) of
 * chains of min_chain..max_chain vertices (min_chain 0: 1) on a sphere of a conductor or a dielectric,
 * with params.reflect or not: [*lo, *hi], false where empty. */
static bool m_range(int min_chain, int max_chain, bool conductor, bool reflect, int *lo, int *hi)
{
    int m_lo = conductor || reflect ? -1 : 0;
    int m_hi = conductor ? -1 : (reflect ? SPC_CHAIN_MAX_VERTICES - 2 : 0);
    if (m_hi > max_chain - 2)
        m_hi = max_chain - 2;
    if (min_chain > 1 && m_lo < min_chain - 2)
        m_lo = min_chain - 2;
    if (m_hi > SPC_SPHERE_MAX_M)
        m_hi = SPC_SPHERE_MAX_M;
    *lo = m_lo;
    *hi = m_hi;
    return m_lo <= m_hi;
}

/* Where the planar roots go: an entry of q->fit (its signatures' roots kept for later entries of the
 * same shape), or none (computed for the call alone). */
typedef struct root_store {
    unsigned *have;
    int *nr;
    double (*theta)[SPC_SPHERE_MAX_ROOTS];
    const spc_fit_roots *fr; /* the earlier entries, whose roots are taken */
    int before;              /* how many */
    const spc_shape *s;
    int also_min, also_max; /* chain lengths whose roots come along (0, 0: none) */
} root_store;

/* The first directions of the fitted sphere's chains from q's x inside it (a medium point within a
 * glass ball) to its y outside: the way out with no internal reflection (a chain of one vertex), at
 * most max, written to dir (ms gets 0). Not the ways out after internal reflections: with them a render
 * of scenes/medium_glass.xml took 1.4x the CPU of one without these seeds, against 1.1x for the way
 * out alone, and the mean relMSE at equal CPU over 24 seeds was 0.033 against 0.023. */
static int inside_dirs(const spc_snee_query *q, const spc_shape *s, spc_vec3 c, double R, spc_vec3 *dir,
                       signed char *ms, int max)
{
    spc_sphere_plane pl;
    double eta = 0.0;
    spc_bsdf_is_specular_interface(s->bsdf, &eta);
    if (!(eta > 0.0) || q->min_chain > 1 || !spc_sphere_plane_inside(q->x->p, c, R, q->y, &pl))
        return 0;
    double theta[SPC_SPHERE_MAX_ROOTS];
    int nr = spc_sphere_inside_roots(pl.d, pl.y1, pl.y2, 0, eta, theta, SPC_SPHERE_MAX_ROOTS);
    int n = 0;
    for (int r = 0; r < nr && n < max; ++r) {
        ms[n] = 0;
        dir[n++] = spc_normalize(spc_sub(spc_sphere_plane_point(&pl, theta[r]), q->x->p));
    }
    return n;
}

/* Is q's x a medium point inside the sphere (c, R)? The fitted roots' events (spc_fit_root_events)
 * are those of chains from outside; from inside the seeds alone (spc_fit_seed) take the fit. */
static bool x_inside(const spc_snee_query *q, spc_vec3 c, double R)
{
    return q->receiver && q->receiver->kind == SPC_RECEIVER_MEDIUM && spc_distance(q->x->p, c) < R;
}

/* The first directions of the fitted sphere's chains (center c, radius R) from q's x to its y, of
 * the query's lengths and the events its params allow (a conductor: one reflection; a dielectric:
 * in and out, with reflect also one reflection and internal ones): at most max, written to dir.
 * With st, the planar roots are taken from st's earlier entries where they hold them, else computed
 * (with those of st's also lengths, on one grid) and kept in st. */
static int fit_dirs(const spc_snee_query *q, const spc_shape *s, spc_vec3 c, double R, root_store *st, spc_vec3 *dir,
                    signed char *ms, int max)
{
    spc_vec3 x = q->x->p;
    if (x_inside(q, c, R)) /* a torus's tube spheres from inside: not measured, none as before */
        return s->type == SPC_SHAPE_MESH ? inside_dirs(q, s, c, R, dir, ms, max) : 0;
    spc_sphere_plane pl;
    if (!spc_sphere_plane_of(x, c, R, q->y, &pl))
        return 0;
    double eta = 0.0;
    spc_bsdf_is_specular_interface(s->bsdf, &eta);
    bool conductor = !(eta > 0.0), reflect = q->params && q->params->reflect;
    int m_lo, m_hi;
    if (!m_range(q->min_chain, q->max_chain, conductor, reflect, &m_lo, &m_hi))
        return 0;
    double own_theta[SPC_SPHERE_SIGNATURES][SPC_SPHERE_MAX_ROOTS];
    int own_nr[SPC_SPHERE_SIGNATURES];
    double(*theta)[SPC_SPHERE_MAX_ROOTS] = own_theta;
    int *nr = own_nr;
    if (!st) {
        /* every length in one pass over the arc (the way in and the chords shared), in order of m */
        spc_sphere_chain_roots_all(pl.d, pl.y1, pl.y2, eta, m_lo, m_hi, theta, nr);
    } else {
        /* the signatures an earlier entry of s computed, then the rest (and the also lengths') */
        *st->have = 0;
        for (int j = 0; j < st->before; ++j) {
            if (st->fr->e[j].s != s)
                continue;
            for (int m = -1; m <= SPC_SPHERE_MAX_M; ++m) {
                unsigned bit = 1u << (m + 1);
                if ((st->fr->e[j].have & bit) && !(*st->have & bit)) {
                    st->nr[m + 1] = st->fr->e[j].nr[m + 1];
                    memcpy(st->theta[m + 1], st->fr->e[j].theta[m + 1], sizeof st->theta[m + 1]);
                    *st->have |= bit;
                }
            }
        }
        bool want[SPC_SPHERE_SIGNATURES] = {false}, any = false;
        for (int m = m_lo; m <= m_hi; ++m)
            any |= want[m + 1] = !(*st->have & (1u << (m + 1)));
        int a_lo, a_hi;
        if (any && m_range(st->also_min, st->also_max, conductor, reflect, &a_lo, &a_hi))
            for (int m = a_lo; m <= a_hi; ++m)
                want[m + 1] |= !(*st->have & (1u << (m + 1)));
        if (any) {
            spc_sphere_chain_roots_some(pl.d, pl.y1, pl.y2, eta, want, own_theta, own_nr);
            for (int m = -1; m <= SPC_SPHERE_MAX_M; ++m)
                if (want[m + 1]) {
                    st->nr[m + 1] = own_nr[m + 1];
                    memcpy(st->theta[m + 1], own_theta[m + 1], sizeof st->theta[m + 1]);
                    *st->have |= 1u << (m + 1);
                }
        }
        theta = st->theta;
        nr = st->nr;
    }
    int n = 0;
    for (int m = m_lo; m <= m_hi; ++m)
        for (int r = 0; r < nr[m + 1] && n < max; ++r) {
            ms[n] = (signed char)m;
            dir[n++] = spc_normalize(spc_sub(spc_sphere_plane_point(&pl, theta[m + 1][r]), x));
        }
    return n;
}

double spc_fit_edge_angle(const spc_shape *s)
{
    if (s->type != SPC_SHAPE_MESH)
        return 0.0;
    const fit_cache *cur = cache_of(s);
    return cur && cur->ok ? cur->edge : 0.0;
}

bool spc_fit_torus(const spc_shape *s, spc_vec3 *center, spc_vec3 *axis, double *major, double *minor)
{
    if (s->type != SPC_SHAPE_SDF)
        return false;
    const fit_cache *cur = cache_of(s);
    if (!cur || !cur->torus)
        return false;
    *center = cur->center;
    *axis = cur->axis;
    *major = cur->major;
    *minor = cur->minor;
    return true;
}

/* The point of a torus's core circle (centre o, unit axis a, radius R) nearest to p, false on the
 * axis. */
static bool core_point(spc_vec3 o, spc_vec3 a, double R, spc_vec3 p, spc_vec3 *c)
{
    spc_vec3 v = spc_sub(p, o);
    v = spc_sub(v, spc_scale(a, spc_dot(v, a)));
    double l = spc_length(v);
    if (!(l > 1e-9 * R))
        return false;
    *c = spc_add(o, spc_scale(v, R / l));
    return true;
}

/* The first directions of the chains of spheres of the tube's radius r centred on the core circle
 * where the chains from q's x to its y cross the tube: at the core point nearest to the point of the
 * segment x y closest to the circle (SPC_TUBE_SEGMENT_STEPS samples), and at those nearest to x and
 * to y where that end lies within SPC_TUBE_NEAR r of the circle; a centre within r of an earlier one
 * is left out. Across its tube a torus is that sphere (along the tube it curves with R + r or R - r
 * instead), so the sphere's exact solutions lie near the torus's. */
#define SPC_TUBE_SEGMENT_STEPS 16
/* How near the core circle (in tube radii) an end of the query must lie for the tube sphere nearest
 * it to seed. A far end's sphere lies across the ring from the chains: on
 * scenes/caustic_sdf_torus.xml the light's (7 r away) gave 2 of a floor point's 5 seeds, to chains
 * the segment's sphere finds too, and one of a pair of valuable chains near a fold, which one seed
 * of the 5 reaches, got p 0.07 (a trial count of 42: that scene's worst seed); without that sphere
 * p 0.12, and test_fit_seeds' 8 ring points' summed second moment fell from 79 to 45
 * (bench/RESULTS.md, "The SDF torus's tails traced"). 2: an end on or just off the tube keeps its
 * sphere. */
#define SPC_TUBE_NEAR 2.0
/* The longest chains seeded from the tube spheres (spc_fit_seed). */
#define SPC_TUBE_MAX_CHAIN 2
static int tube_dirs(const spc_snee_query *q, const spc_shape *s, const fit_cache *fc, spc_vec3 *dir, signed char *ms,
                     int max)
{
    spc_vec3 x = q->x->p, y = q->y, cand[3];
    int nc = 0;
    spc_vec3 best = x;
    double dbest = INFINITY;
    for (int i = 0; i < SPC_TUBE_SEGMENT_STEPS; ++i) {
        spc_vec3 p = spc_add(x, spc_scale(spc_sub(y, x), (i + 0.5) / SPC_TUBE_SEGMENT_STEPS)), c;
        if (!core_point(fc->center, fc->axis, fc->major, p, &c))
            continue;
        double d = spc_distance(p, c);
        if (d < dbest) {
            dbest = d;
            best = p;
        }
    }
    spc_vec3 from[3] = {best, x, y};
    for (int i = 0; i < 3; ++i) {
        spc_vec3 c;
        if (!core_point(fc->center, fc->axis, fc->major, from[i], &c))
            continue;
        if (i > 0 && spc_distance(from[i], c) > SPC_TUBE_NEAR * fc->minor)
            continue; /* an end far from the tube: its sphere lies away from the chains */
        bool near = false;
        for (int j = 0; j < nc && !near; ++j)
            near = spc_distance(cand[j], c) < fc->minor;
        if (!near)
            cand[nc++] = c;
    }
    int n = 0;
    for (int i = 0; i < nc && n < max; ++i)
        n += fit_dirs(q, s, cand[i], fc->minor, NULL, dir + n, ms + n, max - n);
    return n;
}

/* The fitted sphere's solution directions for q and caster s (center c, radius R; or a torus's tube
 * spheres where tube is its cache) and their events (*ms): q->fit's entry for s and q's chain
 * lengths, filled on first use (a ball's with the roots of chains of also_min..also_max vertices
 * computed along: root_store), or where q->fit has no room, computed into `all` and `all_m`. */
static const spc_vec3 *fit_entry(const spc_snee_query *q, const spc_shape *s, spc_vec3 c, double R,
                                 const fit_cache *tube, int also_min, int also_max, spc_vec3 all[SPC_FIT_MAX_DIRS],
                                 signed char all_m[SPC_FIT_MAX_DIRS], int *n, const signed char **ms)
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
        fr->e[j].have = 0;
        root_store st = {&fr->e[j].have, fr->e[j].nr, fr->e[j].theta, fr, j, s, also_min, also_max};
        fr->e[j].n = tube ? tube_dirs(q, s, tube, fr->e[j].dir, fr->e[j].m, SPC_FIT_MAX_DIRS)
                          : fit_dirs(q, s, c, R, &st, fr->e[j].dir, fr->e[j].m, SPC_FIT_MAX_DIRS);
        fr->nshapes++;
    }
    if (fr && j < fr->nshapes) {
        *n = fr->e[j].n;
        *ms = fr->e[j].m;
        return fr->e[j].dir;
    }
    *n = tube ? tube_dirs(q, s, tube, all, all_m, SPC_FIT_MAX_DIRS)
              : fit_dirs(q, s, c, R, NULL, all, all_m, SPC_FIT_MAX_DIRS);
    *ms = all_m;
    return all;
}

int spc_fit_root_count_with(const spc_snee_query *q, const spc_shape *s, int min_chain, int max_chain)
{
    spc_vec3 c, all[SPC_FIT_MAX_DIRS];
    signed char all_m[SPC_FIT_MAX_DIRS];
    const signed char *ms;
    double R;
    int n = 0;
    if (!spc_fit_sphere(s, &c, &R) || x_inside(q, c, R))
        return 0;
    fit_entry(q, s, c, R, NULL, min_chain, max_chain, all, all_m, &n, &ms);
    return n;
}

int spc_fit_root_count(const spc_snee_query *q, const spc_shape *s)
{
    return spc_fit_root_count_with(q, s, 0, 0);
}

int spc_fit_roots_of(const spc_snee_query *q, const spc_shape *s, spc_vec3 *dir, int *m, int max)
{
    spc_vec3 c, all[SPC_FIT_MAX_DIRS];
    signed char all_m[SPC_FIT_MAX_DIRS];
    const signed char *ms;
    double R;
    int n = 0;
    if (!spc_fit_sphere(s, &c, &R) || x_inside(q, c, R))
        return 0;
    const spc_vec3 *d = fit_entry(q, s, c, R, NULL, 0, 0, all, all_m, &n, &ms);
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
    spc_vec3 c = spc_v3(0, 0, 0);
    double R = 0.0;
    const fit_cache *tube = NULL;
    if (s->type == SPC_SHAPE_SDF) {
        /* chains of one or two vertices only: a longer chain reflects inside the tube and runs along
         * it, where the sphere's solutions lie far from the torus's, and the long pass's chains then
         * lost half their seeds' probability (their trial counts were that scene's worst seeds) */
        if (q->max_chain > SPC_TUBE_MAX_CHAIN)
            return false;
        tube = cache_of(s);
        if (!tube || !tube->torus)
            return false;
    } else if (!spc_fit_sphere(s, &c, &R))
        return false;
    double share = q->params && q->params->fit_share > 0.0 ? q->params->fit_share : SPC_FIT_SEED_SHARE;
    if (!(spc_rng_next(rng) < share))
        return false;
    double u = spc_rng_next(rng);
    spc_vec3 all[SPC_FIT_MAX_DIRS];
    signed char all_m[SPC_FIT_MAX_DIRS];
    const signed char *ms;
    int n = 0;
    const spc_vec3 *d = fit_entry(q, s, c, R, tube, 0, 0, all, all_m, &n, &ms);
    if (n < 1)
        return false;
    int i = (int)(u * n);
    *dir = d[i < n ? i : n - 1];
    if (!tube && x_inside(q, c, R)) {
        /* from inside, uniform in a cone around the fitted solution: near the rim the mesh's chain
         * lies a degree or more from the sphere's, outside the basin of the exact direction */
        spc_frame f = spc_frame_from_n(*dir);
        spc_vec2 uj = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
        *dir = spc_frame_to_world(&f, spc_warp_uniform_cone(uj, SPC_FIT_INSIDE_COS));
    }
    return true;
}

int spc_fit_root_events(int m, unsigned char ev[SPC_CHAIN_MAX_VERTICES])
{
    int k = m < 0 ? 1 : m + 2;
    if (k > SPC_CHAIN_MAX_VERTICES)
        return k;
    for (int i = 0; i < SPC_CHAIN_MAX_VERTICES; ++i)
        ev[i] = SPC_CHAIN_REFRACT;
    for (int i = 1; i <= m; ++i)
        ev[i] = SPC_CHAIN_REFLECT;
    if (m < 0)
        ev[0] = SPC_CHAIN_REFLECT;
    return k;
}
