/*
 * manifold/plane_chains.c: every one-vertex chain through a normal-mapped plane (plane_chains.h).
 *
 * Coordinates: the plane's frame (S, T, N) as spc_bsdf_map_chain_hit builds it (S the texture
 * tangent made orthogonal to N, T = N x S), origin o on the plane; a point of the plane has local
 * coordinates (P_S, P_T, 0), affine in the texel coordinates (s, t) = (u' W - 1/2, v' H - 1/2)
 * of the bilinear lookup (u', v' = to_uv(uv)). Cell (i, j) is [i, i+1] x [j, j+1] in (s, t), where
 * the interpolant blends texels (i, j), (i+1, j), (i, j+1), (i+1, j+1) with weights from the
 * fractional parts (a, b) (scene/texture.c, bilinear).
 *
 * Culling: over a rectangle of (s, t), each component of w = d / |d|, d = X - P (X = x or y, P
 * on the rectangle), has its exact range: d_S / |d| grows with d_S and, for d_S of one sign,
 * shrinks in magnitude as d_T^2 grows, so its extremes sit at d_S's ends with d_T^2 at its least
 * or most; d_N / |d| (d_N fixed) is extreme at |d|'s ends. h's components are then bounded by the
 * sums, and the node is culled where h_k = sigma_k h_N cannot hold for any values in those ranges
 * and any slope sigma_k = m_k / m_N of the map there (every blend of texels with m_N > 0 has its
 * slopes between theirs: a mediant), compared by interval products, which need no sign of h_N;
 * where some texel has m_N <= 0, by the intervals of F itself. The turned pass also culls where
 * no normal of the node can face away from x.
 */
#include "manifold/plane_chains.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "bsdf/bsdf.h"
#include "manifold/solver.h"
#include "scene/scene.h"
#include "scene/shape.h"
#include "scene/texture.h"

static inline double dmin2(double a, double b) { return a < b ? a : b; }
static inline double dmax2(double a, double b) { return a > b ? a : b; }

/* Two lanes of doubles (x's and y's terms side by side in may_hold): GCC/Clang vector extensions,
 * SSE2's square root where there is one. Every operation is IEEE's, lane by lane, so the culling
 * is the scalar computation's, bit for bit. */
typedef double v2d __attribute__((vector_size(16)));
typedef long long v2m __attribute__((vector_size(16)));

static inline v2d v2_sel(v2m m, v2d a, v2d b) { return (v2d)(((v2m)a & m) | ((v2m)b & ~m)); }
static inline v2d v2_min(v2d a, v2d b) { return v2_sel((v2m)(a < b), a, b); }
static inline v2d v2_max(v2d a, v2d b) { return v2_sel((v2m)(a > b), a, b); }
static inline v2d v2_sqrt(v2d a)
{
#if defined(__SSE2__)
    return (v2d)_mm_sqrt_pd((__m128d)a);
#else
    return (v2d){sqrt(a[0]), sqrt(a[1])};
#endif
}

/* Two pairs of lanes as one vector of four, so that the AVX2 build of may_hold takes two pairs'
 * quotients in one instruction (the base ISA's build splits it in two; the same IEEE operations). */
typedef double v4d __attribute__((vector_size(32)));

#define V4_CAT(a, b) ((v4d){(a)[0], (a)[1], (b)[0], (b)[1]})
#define V4_LO(a) ((v2d){(a)[0], (a)[1]})
#define V4_HI(a) ((v2d){(a)[2], (a)[3]})
#define V4_SQRT(a) V4_CAT(v2_sqrt(V4_LO(a)), v2_sqrt(V4_HI(a)))

/* The culling test's helpers, inlined into each build of it (may_hold_base, may_hold_avx2): the AVX2
 * build then calls no SSE code while the upper halves of its vector registers are in use (SSE code
 * run then is slow: calls left in cost the pool's render most of the AVX2 build's gain). */
#define SPC_PLANE_INLINE static inline __attribute__((always_inline))

/* Levels of pieces of a surviving cell (1: the cell, 2: its quarters, 3: sixteenths); Newton's
 * method starts from each surviving piece of the last level. Over 240 configurations of the dense
 * test (test_exact_chains.c, grazing mirrors included) quarters missed 2 of 786 roots, sixteenths
 * none. */
#define SPC_PLANE_SPLIT 3
/* Roots kept per query and plane. */
#define SPC_PLANE_MAX_ROOTS 256
#define SPC_PLANE_NEWTON_ITERATIONS 30
/* Pyramid levels at most (cells up to 2^24 per side). */
#define SPC_PLANE_LEVELS 26
/* Cells at most (2048 x 2048: the pyramid above them takes about 60 MB; a larger map on one plane
 * is not enumerated, its chains are left to the randomized solver). */
#define SPC_PLANE_MAX_CELLS (1 << 22)

typedef struct bnd {
    double lo[3], hi[3];   /* m's components (S, T, N) */
    double slo[2], shi[2]; /* m_S / m_N and m_T / m_N, when slopes */
    bool slopes;           /* every texel has m_N > 0 */
} bnd;

/* A node's bounds as stored (levels above the cells; the cells' own come from their four texels
 * when needed): floats rounded outward. */
typedef struct bndf {
    float lo[3], hi[3], slo[2], shi[2];
    unsigned char slopes;
} bndf;

typedef struct plane_map {
    void (*destroy)(void *); /* first member: spc_shape_release calls it */
    bool ok;
    const spc_texture *tex;
    double eta;            /* the dielectric's int_ior / ext_ior; 0 for a conductor */
    spc_vec3 o, S, T, N;
    double p0[2], ps[2], pt[2]; /* local (P_S, P_T) = p0 + s ps + t pt */
    double smin, smax, tmin, tmax;
    int i0, j0, nlev;
    int nu[SPC_PLANE_LEVELS], nv[SPC_PLANE_LEVELS];
    bndf *lev[SPC_PLANE_LEVELS]; /* lev[0] unused (NULL) */
} plane_map;

static void map_destroy(void *p)
{
    plane_map *m = p;
    for (int l = 0; l < m->nlev; ++l)
        free(m->lev[l]);
    free(m);
}

static void texel_m(const spc_texture *t, int64_t i, int64_t j, double m[3])
{
    spc_rgb c = spc_texture_texel(t, i, j);
    m[0] = 2.0 * c.r - 1.0;
    m[1] = 2.0 * c.g - 1.0;
    m[2] = 2.0 * c.b - 1.0;
}

/* The bounds of the blends of four vectors. */
/* An empty bound, then one normal m added (pos: m_N > 0, its slopes r = m_S / m_N, m_T / m_N). */
static void bnd_reset(bnd *b)
{
    b->slopes = true;
    for (int k = 0; k < 3; ++k) {
        b->lo[k] = INFINITY;
        b->hi[k] = -INFINITY;
    }
    b->slo[0] = b->slo[1] = INFINITY;
    b->shi[0] = b->shi[1] = -INFINITY;
}

static void bnd_add(bnd *b, const double m[3], bool pos, const double r[2])
{
    for (int k = 0; k < 3; ++k) {
        b->lo[k] = dmin2(b->lo[k], m[k]);
        b->hi[k] = dmax2(b->hi[k], m[k]);
    }
    if (!pos) {
        b->slopes = false;
        return;
    }
    for (int k = 0; k < 2; ++k) {
        b->slo[k] = dmin2(b->slo[k], r[k]);
        b->shi[k] = dmax2(b->shi[k], r[k]);
    }
}

static void bnd_of(double m[4][3], bnd *b)
{
    bnd_reset(b);
    for (int c = 0; c < 4; ++c) {
        bool pos = m[c][2] > 0.0;
        double r[2] = {0.0, 0.0};
        if (pos) {
            r[0] = m[c][0] / m[c][2];
            r[1] = m[c][1] / m[c][2];
        }
        bnd_add(b, m[c], pos, r);
    }
}

static float round_down(double x)
{
    float f = (float)x;
    return (double)f > x ? nextafterf(f, -INFINITY) : f;
}

static float round_up(double x)
{
    float f = (float)x;
    return (double)f < x ? nextafterf(f, INFINITY) : f;
}

static void bnd_store(const bnd *b, bndf *o)
{
    for (int k = 0; k < 3; ++k) {
        o->lo[k] = round_down(b->lo[k]);
        o->hi[k] = round_up(b->hi[k]);
    }
    for (int k = 0; k < 2; ++k) {
        o->slo[k] = round_down(b->slo[k]);
        o->shi[k] = round_up(b->shi[k]);
    }
    o->slopes = b->slopes;
}

static void bnd_load(const bndf *o, bnd *b)
{
    for (int k = 0; k < 3; ++k) {
        b->lo[k] = o->lo[k];
        b->hi[k] = o->hi[k];
    }
    for (int k = 0; k < 2; ++k) {
        b->slo[k] = o->slo[k];
        b->shi[k] = o->shi[k];
    }
    b->slopes = o->slopes;
}

static void bnd_merge(bnd *a, const bnd *b)
{
    for (int k = 0; k < 3; ++k) {
        a->lo[k] = dmin2(a->lo[k], b->lo[k]);
        a->hi[k] = dmax2(a->hi[k], b->hi[k]);
    }
    a->slopes = a->slopes && b->slopes;
    for (int k = 0; k < 2; ++k) {
        a->slo[k] = dmin2(a->slo[k], b->slo[k]);
        a->shi[k] = dmax2(a->shi[k], b->shi[k]);
    }
}

/* Is the BSDF a normal map these chains model: a bilinear bitmap whose to_uv maps u and v
 * separately, over a smooth dielectric or conductor? *eta: the dielectric's, 0 for a conductor. */
static bool bsdf_ok(const spc_bsdf *b, double *eta)
{
    if (!b || b->type != SPC_BSDF_NORMALMAP || !b->normalmap || !b->nested[0])
        return false;
    const spc_texture *t = b->normalmap;
    if (t->type != SPC_TEX_BITMAP || t->nearest || !t->data || t->width <= 0 || t->height <= 0)
        return false;
    if (t->to_uv[0][1] != 0.0 || t->to_uv[1][0] != 0.0 || t->to_uv[0][0] == 0.0 || t->to_uv[1][1] == 0.0 ||
        !isfinite(t->to_uv[0][0] + t->to_uv[1][1] + t->to_uv[0][2] + t->to_uv[1][2]))
        return false;
    const spc_bsdf *n = b->nested[0];
    if (n->type == SPC_BSDF_DIELECTRIC) {
        *eta = n->eta;
        return n->eta > 0.0 && isfinite(n->eta);
    }
    *eta = 0.0;
    return n->type == SPC_BSDF_CONDUCTOR;
}

static spc_vec3 vert(const spc_mesh *m, size_t i)
{
    return spc_v3(m->p[3 * i], m->p[3 * i + 1], m->p[3 * i + 2]);
}

/* The bounds of node (i, j) of level l: a cell's from its four texels (left in mc), above from the
 * pyramid. */
static void node_bnd(const plane_map *pm, int l, int i, int j, bnd *b, double mc[4][3])
{
    if (l > 0) {
        bnd_load(&pm->lev[l][(size_t)j * pm->nu[l] + i], b);
        return;
    }
    int64_t ci = (int64_t)pm->i0 + i, cj = (int64_t)pm->j0 + j;
    texel_m(pm->tex, ci, cj, mc[0]);
    texel_m(pm->tex, ci + 1, cj, mc[1]);
    texel_m(pm->tex, ci, cj + 1, mc[2]);
    texel_m(pm->tex, ci + 1, cj + 1, mc[3]);
    bnd_of(mc, b);
}

/* The plane's frame, affine maps and pyramid; m->ok false where s is not such a plane. */
static void map_build(const spc_shape *s, plane_map *pm)
{
    pm->ok = false;
    if (s->type != SPC_SHAPE_MESH || s->emitter || !bsdf_ok(s->bsdf, &pm->eta))
        return;
    const spc_mesh *m = &s->mesh;
    if (!m->uv || m->ntris < 1 || m->nverts < 3)
        return;
    pm->tex = s->bsdf->normalmap;
    /* uv -> position, fitted on the first triangle: p = P0 + u Pu + v Pv */
    uint32_t i0 = m->idx[0], i1 = m->idx[1], i2 = m->idx[2];
    spc_vec3 a = vert(m, i0), e1 = spc_sub(vert(m, i1), a), e2 = spc_sub(vert(m, i2), a);
    double tduv[4];
    spc_mesh_tri_duv(m, 0, tduv);
    spc_vec3 Pu, Pv;
    if (!spc_uv_tangents(e1, e2, tduv, 1e-12, &Pu, &Pv))
        return;
    spc_vec3 P0 = spc_sub(a, spc_add(spc_scale(Pu, m->uv[2 * i0]), spc_scale(Pv, m->uv[2 * i0 + 1])));
    spc_vec3 ng = spc_cross(Pu, Pv);
    double lng = spc_length(ng);
    double size = spc_length(spc_sub(s->bbox_max, s->bbox_min));
    if (!(lng > 0.0) || !(size > 0.0))
        return;
    ng = spc_scale(ng, 1.0 / lng);
    /* every vertex on that map (float positions: a relative 1e-5), every normal along ng */
    double tol = 1e-5 * size;
    for (size_t i = 0; i < m->nverts; ++i) {
        spc_vec3 q = spc_add(P0, spc_add(spc_scale(Pu, m->uv[2 * i]), spc_scale(Pv, m->uv[2 * i + 1])));
        if (!(spc_distance(q, vert(m, i)) <= tol))
            return;
        if (m->n && !s->face_normals) {
            spc_vec3 n = spc_v3(m->n[3 * i], m->n[3 * i + 1], m->n[3 * i + 2]);
            double ln = spc_length(n);
            if (!(ln > 0.0) || !(fabs(spc_dot(n, ng)) >= ln * (1.0 - 1e-6)))
                return;
        }
    }
    /* the frame spc_bsdf_map_chain_hit builds, from a hit on the first triangle */
    spc_vec3 c = spc_add(a, spc_scale(spc_add(e1, e2), 1.0 / 3.0));
    spc_ray r;
    r.o = spc_add(c, spc_scale(ng, size));
    r.d = spc_neg(ng);
    r.tmin = 0.0;
    r.tmax = 2.0 * size;
    spc_hit h;
    memset(&h, 0, sizeof h);
    spc_shape_fill_hit(s, 0, 1.0 / 3.0, 1.0 / 3.0, &r, size, &h);
    spc_vec2 duv[2];
    spc_vec3 T, dT[2];
    if (!spc_shape_texture_frame(&h, duv, &T, dT))
        return;
    spc_vec3 N = h.sh.n;
    if (!(fabs(spc_dot(N, ng)) > 1.0 - 1e-6))
        return;
    spc_vec3 su = spc_sub(T, spc_scale(N, spc_dot(N, T)));
    double ls = spc_length(su);
    if (!(ls > 1e-12 * spc_length(T)))
        return;
    pm->N = N;
    pm->S = spc_scale(su, 1.0 / ls);
    pm->T = spc_cross(N, pm->S);
    pm->o = P0;
    /* (s, t) -> uv -> local coordinates */
    const spc_texture *t = pm->tex;
    double W = t->width, H = t->height;
    double Au = t->to_uv[0][0], Bu = t->to_uv[0][2], Av = t->to_uv[1][1], Bv = t->to_uv[1][2];
    double cus = 1.0 / (W * Au), cu0 = (0.5 / W - Bu) / Au; /* u = cu0 + s cus */
    double cvt = 1.0 / (H * Av), cv0 = (0.5 / H - Bv) / Av;
    spc_vec3 Q0 = spc_add(spc_scale(Pu, cu0), spc_scale(Pv, cv0)); /* relative to o = P0 */
    spc_vec3 Qs = spc_scale(Pu, cus), Qt = spc_scale(Pv, cvt);
    spc_vec3 E[2] = {pm->S, pm->T};
    for (int k = 0; k < 2; ++k) {
        pm->p0[k] = spc_dot(Q0, E[k]);
        pm->ps[k] = spc_dot(Qs, E[k]);
        pm->pt[k] = spc_dot(Qt, E[k]);
    }
    pm->smin = pm->tmin = INFINITY;
    pm->smax = pm->tmax = -INFINITY;
    for (size_t i = 0; i < m->nverts; ++i) {
        double sv = (Au * m->uv[2 * i] + Bu) * W - 0.5, tv = (Av * m->uv[2 * i + 1] + Bv) * H - 0.5;
        pm->smin = dmin2(pm->smin, sv);
        pm->smax = dmax2(pm->smax, sv);
        pm->tmin = dmin2(pm->tmin, tv);
        pm->tmax = dmax2(pm->tmax, tv);
    }
    if (!(pm->smax - pm->smin < 1e7 && pm->tmax - pm->tmin < 1e7))
        return;
    pm->i0 = (int)floor(pm->smin);
    pm->j0 = (int)floor(pm->tmin);
    int nu = (int)floor(pm->smax) - pm->i0 + 1, nv = (int)floor(pm->tmax) - pm->j0 + 1;
    if ((double)nu * nv > SPC_PLANE_MAX_CELLS)
        return;
    /* the pyramid: level 0 the cells (not stored), each level above 2 x 2 of the one below */
    pm->nu[0] = nu;
    pm->nv[0] = nv;
    pm->lev[0] = NULL;
    pm->nlev = 1;
    while (!(nu == 1 && nv == 1) && pm->nlev < SPC_PLANE_LEVELS) {
        int l = pm->nlev, bu = nu, bv = nv;
        nu = (nu + 1) / 2;
        nv = (nv + 1) / 2;
        pm->nu[l] = nu;
        pm->nv[l] = nv;
        pm->lev[l] = malloc(sizeof(bndf) * (size_t)nu * (size_t)nv);
        if (!pm->lev[l])
            return;
        pm->nlev++;
        for (int j = 0; j < nv; ++j)
            for (int i = 0; i < nu; ++i) {
                bnd b, c;
                double mc[4][3];
                node_bnd(pm, l - 1, 2 * i, 2 * j, &b, mc); /* 2i < bu, 2j < bv */
                for (int dj = 0; dj < 2; ++dj)
                    for (int di = 0; di < 2; ++di) {
                        int ci = 2 * i + di, cj = 2 * j + dj;
                        if ((di == 0 && dj == 0) || ci >= bu || cj >= bv)
                            continue;
                        node_bnd(pm, l - 1, ci, cj, &c, mc);
                        bnd_merge(&b, &c);
                    }
                bnd_store(&b, &pm->lev[l][(size_t)j * nu + i]);
            }
    }
    pm->ok = pm->nu[pm->nlev - 1] == 1 && pm->nv[pm->nlev - 1] == 1;
}

/* The shape's map, built on first use and published atomically (as conic_solver.c's cache). */
static const plane_map *map_get(const spc_shape *s)
{
    if (!s || s->type != SPC_SHAPE_MESH || !s->bsdf || s->bsdf->type != SPC_BSDF_NORMALMAP)
        return NULL;
    void **slot = (void **)&((spc_shape *)s)->plane_cache;
    plane_map *cur = __atomic_load_n(slot, __ATOMIC_ACQUIRE);
    if (!cur) {
        plane_map *pm = calloc(1, sizeof *pm);
        if (!pm)
            return NULL;
        pm->destroy = map_destroy;
        map_build(s, pm);
        void *expected = NULL;
        if (__atomic_compare_exchange_n(slot, &expected, (void *)pm, false, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE)) {
            cur = pm;
        } else {
            map_destroy(pm); /* another thread won */
            cur = expected;
        }
    }
    return cur->ok ? cur : NULL;
}

bool spc_plane_chain_shape(const spc_shape *s) { return map_get(s) != NULL; }

static spc_vec3 to_local(const plane_map *pm, spc_vec3 p)
{
    spc_vec3 d = spc_sub(p, pm->o);
    return spc_v3(spc_dot(d, pm->S), spc_dot(d, pm->T), spc_dot(d, pm->N));
}

static spc_vec3 to_world(const plane_map *pm, double ls, double lt)
{
    return spc_add(pm->o, spc_add(spc_scale(pm->S, ls), spc_scale(pm->T, lt)));
}

/* The texel coordinates (s, t) of the plane point with local coordinates (ls, lt). */
static bool local_to_st(const plane_map *pm, double ls, double lt, double *s, double *t)
{
    double det = pm->ps[0] * pm->pt[1] - pm->ps[1] * pm->pt[0];
    if (!(det != 0.0))
        return false;
    double rx = ls - pm->p0[0], ry = lt - pm->p0[1];
    *s = (rx * pm->pt[1] - ry * pm->pt[0]) / det;
    *t = (pm->ps[0] * ry - pm->ps[1] * rx) / det;
    return true;
}

/* The blend at (s, t) of the cell holding it, as the texture's bilinear lookup. */
static void model_m(const plane_map *pm, double s, double t, double m[3])
{
    double fs = floor(s), ft = floor(t);
    int64_t ci = (int64_t)fs, cj = (int64_t)ft;
    double a = s - fs, b = t - ft;
    double c[4][3];
    texel_m(pm->tex, ci, cj, c[0]);
    texel_m(pm->tex, ci + 1, cj, c[1]);
    texel_m(pm->tex, ci, cj + 1, c[2]);
    texel_m(pm->tex, ci + 1, cj + 1, c[3]);
    for (int k = 0; k < 3; ++k)
        m[k] = (1 - a) * (1 - b) * c[0][k] + a * (1 - b) * c[1][k] + (1 - a) * b * c[2][k] + a * b * c[3][k];
}

bool spc_plane_chain_model_normal(const spc_shape *s, spc_vec3 p, double m[3], spc_vec3 frame[3])
{
    const plane_map *pm = map_get(s);
    double st, tt;
    if (!pm)
        return false;
    spc_vec3 l = to_local(pm, p);
    if (!local_to_st(pm, l.x, l.y, &st, &tt))
        return false;
    model_m(pm, st, tt, m);
    if (frame) {
        frame[0] = pm->S;
        frame[1] = pm->T;
        frame[2] = pm->N;
    }
    return true;
}

/* ---- one query ---- */

struct problem;
typedef bool (*may_hold_fn)(const struct problem *pb, double s0, double s1, double t0, double t1, const struct bnd *b);

typedef struct problem {
    may_hold_fn may_hold; /* may_hold_base or may_hold_avx2 */
    const plane_map *pm;
    /* the pass for the normals the BSDF turns toward x (spc_bsdf_perturbed_face_view: where x is
     * on N's side but behind the mapped normal, the normal's tangential part changes sign) */
    bool turned;
    double X[2][3]; /* x and y, local */
    double eta[2];  /* the index on x's side and on y's (1, 1 for a reflection) */
    v2d XS, XT, XN, XN2, ETA; /* the same in may_hold's lanes (x, y), XN2 = XN^2 */
    double roots[SPC_PLANE_MAX_ROOTS][2];
    bool root_turned[SPC_PLANE_MAX_ROOTS];
    int nroots;
} problem;

/* The turned field's bounds and corner vectors: the tangential parts negated. */
static void bnd_turn(bnd *b)
{
    for (int k = 0; k < 2; ++k) {
        double lo = b->lo[k];
        b->lo[k] = -b->hi[k];
        b->hi[k] = -lo;
        double sl = b->slo[k];
        b->slo[k] = -b->shi[k];
        b->shi[k] = -sl;
    }
}

/* The cell's corner vectors c from its texels' mc, turned in the turned pass. */
static void corners(const problem *pb, double mc[4][3], double c[4][3])
{
    memcpy(c, mc, sizeof(double[4][3]));
    if (pb->turned)
        for (int q = 0; q < 4; ++q) {
            c[q][0] = -c[q][0];
            c[q][1] = -c[q][1];
        }
}

/* The local box of the plane points of the (s, t) box. */
SPC_PLANE_INLINE void p_box(const plane_map *pm, double s0, double s1, double t0, double t1, double pl[2], double ph[2])
{
    for (int k = 0; k < 2; ++k) {
        double c = pm->p0[k] + 0.5 * (s0 + s1) * pm->ps[k] + 0.5 * (t0 + t1) * pm->pt[k];
        double r = 0.5 * (s1 - s0) * fabs(pm->ps[k]) + 0.5 * (t1 - t0) * fabs(pm->pt[k]);
        pl[k] = c - r;
        ph[k] = c + r;
    }
}

SPC_PLANE_INLINE void imul(double a0, double a1, double b0, double b1, double *lo, double *hi)
{
    double p0 = a0 * b0, p1 = a0 * b1, p2 = a1 * b0, p3 = a1 * b1;
    *lo = dmin2(dmin2(p0, p1), dmin2(p2, p3));
    *hi = dmax2(dmax2(p0, p1), dmax2(p2, p3));
}

/* Margin of the culling tests (slopes and F are O(1) quantities). */
#define SPC_PLANE_CULL_EPS 1e-9

/* Can h_k = sigma h_N (sigma in [slo, shi], the node's slopes), or h_k m_N = h_N m_k (m in the
 * node's component box), hold for some values in the ranges of h_k and h_N? */
SPC_PLANE_INLINE bool component_may_hold(double hkl, double hkh, double hnl, double hnh, const bnd *b, int k)
{
    double lo, hi;
    if (b->slopes) {
        imul(b->slo[k], b->shi[k], hnl, hnh, &lo, &hi);
        return !(hkh < lo - SPC_PLANE_CULL_EPS || hkl > hi + SPC_PLANE_CULL_EPS);
    }
    double al, ah, bl, bh;
    imul(hkl, hkh, b->lo[2], b->hi[2], &al, &ah);
    imul(hnl, hnh, b->lo[k], b->hi[k], &bl, &bh);
    return !(al - bh > SPC_PLANE_CULL_EPS || ah - bl < -SPC_PLANE_CULL_EPS);
}

/* The range of u / |d| with u in [u0, u1] (one tangential component of d = X - P) and the other's
 * square between o_min2 and o_max2, per lane: u / |d| grows with u, and for u of one sign shrinks in
 * magnitude as the other components grow. */
SPC_PLANE_INLINE void unit_range(v2d u0, v2d u1, v2d omin2, v2d omax2, v2d z2, v2d *lo, v2d *hi)
{
    const v2d zero = {0.0, 0.0}, one = {1.0, 1.0};
    v2d rh = v2_sel(u1 >= zero, omin2, omax2), rl = v2_sel(u0 >= zero, omax2, omin2);
    v4d d2 = V4_CAT(u1 * u1 + rh + z2, u0 * u0 + rl + z2), d = V4_SQRT(d2);
    v2d dh = V4_LO(d), dl = V4_HI(d);
    v2m hok = (v2m)(dh > zero), lok = (v2m)(dl > zero);
    v2d dhs = v2_sel(hok, dh, one), dls = v2_sel(lok, dl, one);
    v4d q = V4_CAT(u1, u0) / V4_CAT(dhs, dls);
    *hi = v2_sel(hok, V4_LO(q), one);
    *lo = v2_sel(lok, V4_HI(q), -one);
}

/* Can the (s, t) box, whose normals lie within b, hold a root? Each component of h = sum_e eta_e
 * w_e is bounded by the sum of the exact ranges of w_e's component (w_e = d_e / |d_e|, d_e = X_e - P
 * for P on the box; x and y in the two lanes); the normal component first, then S (most boxes fail
 * there), then T. */
SPC_PLANE_INLINE bool may_hold_body(const problem *pb, double s0, double s1, double t0, double t1, const bnd *b)
{
    const v2d zero = {0.0, 0.0};
    double pl[2], ph[2];
    p_box(pb->pm, s0, s1, t0, t1, pl, ph);
    /* d's tangential ranges [ds0, ds1] x [dt0, dt1] and their squares' */
    v2d ds0 = pb->XS - (v2d){ph[0], ph[0]}, ds1 = pb->XS - (v2d){pl[0], pl[0]};
    v2d dt0 = pb->XT - (v2d){ph[1], ph[1]}, dt1 = pb->XT - (v2d){pl[1], pl[1]};
    v2d a0 = ds0 * ds0, a1 = ds1 * ds1, c0 = dt0 * dt0, c1 = dt1 * dt1;
    v2d smin2 = v2_sel((v2m)(ds0 <= zero) & (v2m)(ds1 >= zero), zero, v2_min(a0, a1)), smax2 = v2_max(a0, a1);
    v2d tmin2 = v2_sel((v2m)(dt0 <= zero) & (v2m)(dt1 >= zero), zero, v2_min(c0, c1)), tmax2 = v2_max(c0, c1);
    /* d_N / |d|, d_N = z fixed: extreme at |d|'s least and most */
    v2d rmin2 = smin2 + tmin2 + pb->XN2, rmax2 = smax2 + tmax2 + pb->XN2;
    v4d r2 = V4_CAT(rmin2, rmax2), nn = V4_CAT(pb->XN, pb->XN) / V4_SQRT(r2);
    v2d na = V4_LO(nn), nc = V4_HI(nn);
    v2d nlo = pb->ETA * v2_min(na, nc), nhi = pb->ETA * v2_max(na, nc);
    double nl = nlo[0] + nlo[1], nh = nhi[0] + nhi[1];
    v2d wl[2], wh[2];
    for (int k = 0; k < 2; ++k) {
        if (k == 0)
            unit_range(ds0, ds1, tmin2, tmax2, pb->XN2, &wl[0], &wh[0]);
        else
            unit_range(dt0, dt1, smin2, smax2, pb->XN2, &wl[1], &wh[1]);
        v2d kl = pb->ETA * wl[k], kh = pb->ETA * wh[k];
        if (!component_may_hold(kl[0] + kl[1], kh[0] + kh[1], nl, nh, b, k))
            return false;
    }
    if (pb->turned && b->slopes) {
        /* a turn needs w_x . m < 0 for the map's own normal m (slopes -sigma of the turned field's):
         * the least of w_N + w_S m_S / m_N + w_T m_T / m_N over the box must be negative (lane x) */
        double least = nc[0];
        for (int k = 0; k < 2; ++k) {
            double lo, hi;
            imul(wl[k][0], wh[k][0], -b->shi[k], -b->slo[k], &lo, &hi);
            least += lo;
        }
        if (least > SPC_PLANE_CULL_EPS)
            return false;
    }
    return true;
}

/* may_hold compiled for the base ISA and, on x86-64 with GCC or Clang, for AVX2 (its paired
 * quotients one 4-lane division: 0.95x the pool's CPU), picked by the CPU at each query (a flag the
 * runtime reads once). AVX2 without FMA: no product is fused, so both compute the same IEEE
 * operations and cull the same nodes. The AVX2 one clears the upper halves of the vector registers
 * before it returns, since its callers are SSE code. */
static bool may_hold_base(const problem *pb, double s0, double s1, double t0, double t1, const bnd *b)
{
    return may_hold_body(pb, s0, s1, t0, t1, b);
}

#if defined(__x86_64__) && defined(__GNUC__) && defined(__ELF__)
#include <immintrin.h>
__attribute__((target("avx2"))) static bool may_hold_avx2(const problem *pb, double s0, double s1, double t0, double t1,
                                                          const bnd *b)
{
    bool r = may_hold_body(pb, s0, s1, t0, t1, b);
    _mm256_zeroupper();
    return r;
}

static may_hold_fn may_hold_pick(void)
{
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") ? may_hold_avx2 : may_hold_base;
}
#else
static may_hold_fn may_hold_pick(void) { return may_hold_base; }
#endif

/* F and its Jacobian at (a, b) of the cell at (ci, cj) with corner vectors c. */
static void eval_F(const problem *pb, double ci, double cj, double c[4][3], double a, double b, double F[2],
                   double J[2][2])
{
    const plane_map *pm = pb->pm;
    double s = ci + a, t = cj + b;
    double P[2] = {pm->p0[0] + s * pm->ps[0] + t * pm->pt[0], pm->p0[1] + s * pm->ps[1] + t * pm->pt[1]};
    double dP[2][3] = {{pm->ps[0], pm->ps[1], 0.0}, {pm->pt[0], pm->pt[1], 0.0}}; /* d/da, d/db */
    double h[3] = {0, 0, 0}, dh[2][3] = {{0, 0, 0}, {0, 0, 0}};
    for (int e = 0; e < 2; ++e) {
        double d[3] = {pb->X[e][0] - P[0], pb->X[e][1] - P[1], pb->X[e][2]};
        double r = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        double w[3] = {d[0] / r, d[1] / r, d[2] / r};
        for (int k = 0; k < 3; ++k)
            h[k] += pb->eta[e] * w[k];
        for (int j = 0; j < 2; ++j) {
            /* dw = -(dP - w (w . dP)) / r */
            double wd = w[0] * dP[j][0] + w[1] * dP[j][1];
            for (int k = 0; k < 3; ++k)
                dh[j][k] -= pb->eta[e] * (dP[j][k] - w[k] * wd) / r;
        }
    }
    double m[3], dm[2][3];
    for (int k = 0; k < 3; ++k) {
        m[k] = (1 - a) * (1 - b) * c[0][k] + a * (1 - b) * c[1][k] + (1 - a) * b * c[2][k] + a * b * c[3][k];
        dm[0][k] = (1 - b) * (c[1][k] - c[0][k]) + b * (c[3][k] - c[2][k]);
        dm[1][k] = (1 - a) * (c[2][k] - c[0][k]) + a * (c[3][k] - c[1][k]);
    }
    for (int k = 0; k < 2; ++k) {
        F[k] = h[k] * m[2] - h[2] * m[k];
        for (int j = 0; j < 2; ++j)
            J[k][j] = dh[j][k] * m[2] + h[k] * dm[j][2] - dh[j][2] * m[k] - h[2] * dm[j][k];
    }
}

static bool have_root(const problem *pb, double s, double t, double tol)
{
    for (int i = 0; i < pb->nroots; ++i)
        if (fabs(pb->roots[i][0] - s) <= tol && fabs(pb->roots[i][1] - t) <= tol)
            return true;
    return false;
}

/* Does the BSDF turn the map's normal at (s, t) toward x (spc_bsdf_perturbed_face_view: x on N's
 * side, behind the mapped normal)? */
static bool is_turned(const problem *pb, double s, double t)
{
    const plane_map *pm = pb->pm;
    if (!(pb->X[0][2] > 0.0))
        return false;
    double m[3];
    model_m(pm, s, t, m);
    double wo[3] = {pb->X[0][0] - (pm->p0[0] + s * pm->ps[0] + t * pm->pt[0]),
                    pb->X[0][1] - (pm->p0[1] + s * pm->ps[1] + t * pm->pt[1]), pb->X[0][2]};
    return wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2] < 0.0;
}

/* Newton's method on the cell's F from (a, b); the root is kept if it lies in the cell's part
 * [a0, a1] x [b0, b1] and is new. */
static void newton_cell(problem *pb, double ci, double cj, double c[4][3], double a, double b, double a0,
                        double a1, double b0, double b1)
{
    double F[2], J[2][2];
    eval_F(pb, ci, cj, c, a, b, F, J);
    double f = F[0] * F[0] + F[1] * F[1];
    for (int it = 0; it < SPC_PLANE_NEWTON_ITERATIONS; ++it) {
        double det = J[0][0] * J[1][1] - J[0][1] * J[1][0];
        if (!(fabs(det) > 0.0) || !isfinite(det))
            return;
        double da = -(J[1][1] * F[0] - J[0][1] * F[1]) / det;
        double db = -(J[0][0] * F[1] - J[1][0] * F[0]) / det;
        double len = sqrt(da * da + db * db);
        if (!isfinite(len))
            return;
        if (len > 0.5) { /* stay near the cell */
            da *= 0.5 / len;
            db *= 0.5 / len;
            len = 0.5;
        }
        /* backtracking on |F|^2 (near a grazing reflection F turns fast, and full steps cycle) */
        double lam = 1.0, na = a, nb = b, nF[2], nJ[2][2], nf = f;
        bool moved = false;
        for (int ls = 0; ls < 16; ++ls) {
            na = a + lam * da;
            nb = b + lam * db;
            eval_F(pb, ci, cj, c, na, nb, nF, nJ);
            nf = nF[0] * nF[0] + nF[1] * nF[1];
            if (nf < f || lam * len < 1e-12) {
                moved = true;
                break;
            }
            lam *= 0.5;
        }
        if (!moved)
            return;
        a = na;
        b = nb;
        f = nf;
        F[0] = nF[0];
        F[1] = nF[1];
        memcpy(J, nJ, sizeof J);
        if (a < -1.0 || a > 2.0 || b < -1.0 || b > 2.0)
            return;
        if (lam * len < 1e-12) {
            const double eps = 1e-9;
            if (a < a0 - eps || a > a1 + eps || b < b0 - eps || b > b1 + eps)
                return;
            double s = ci + a, t = cj + b;
            if (is_turned(pb, s, t) != pb->turned)
                return; /* the other pass's normal there */
            if (pb->nroots < SPC_PLANE_MAX_ROOTS && !have_root(pb, s, t, 1e-7)) {
                pb->roots[pb->nroots][0] = s;
                pb->roots[pb->nroots][1] = t;
                pb->root_turned[pb->nroots] = pb->turned;
                pb->nroots++;
            }
            return;
        }
    }
}

static void blend(double c[4][3], double a, double b, double out[3])
{
    for (int k = 0; k < 3; ++k)
        out[k] = (1 - a) * (1 - b) * c[0][k] + a * (1 - b) * c[1][k] + (1 - a) * b * c[2][k] + a * b * c[3][k];
}

/* Pieces per side of a cell at the last level, and the grid of their corners. */
#define SPC_PLANE_PIECES (1 << (SPC_PLANE_SPLIT - 1))
#define SPC_PLANE_GRID (SPC_PLANE_PIECES + 1)

/* A cell's corner vectors blended at the pieces' corners, each when a piece first needs it (a piece's
 * bounds are its four corners'): the coordinates in the cell, the blended m, and its slopes where
 * m_N > 0. */
typedef struct cell_grid {
    double (*c)[3]; /* the cell's corner vectors */
    bool done[SPC_PLANE_GRID][SPC_PLANE_GRID];
    double a[SPC_PLANE_GRID], b[SPC_PLANE_GRID];
    double m[SPC_PLANE_GRID][SPC_PLANE_GRID][3];
    double r[SPC_PLANE_GRID][SPC_PLANE_GRID][2];
    bool pos[SPC_PLANE_GRID][SPC_PLANE_GRID];
} cell_grid;

/* The midpoints of [v[lo], v[hi]] as the recursive halving makes them. */
static void grid_mid(double *v, int lo, int hi)
{
    if (hi - lo < 2)
        return;
    int mid = (lo + hi) / 2;
    v[mid] = 0.5 * (v[lo] + v[hi]);
    grid_mid(v, lo, mid);
    grid_mid(v, mid, hi);
}

/* Grid corner (u, v): the blend and its slopes. */
static void grid_point(cell_grid *g, int u, int v)
{
    double *m = g->m[u][v];
    blend(g->c, g->a[u], g->b[v], m);
    g->pos[u][v] = m[2] > 0.0;
    if (g->pos[u][v]) {
        g->r[u][v][0] = m[0] / m[2];
        g->r[u][v][1] = m[1] / m[2];
    }
    g->done[u][v] = true;
}

/* The bounds of the piece with grid corners (i0, j0) .. (i1, j1). */
static void piece_bnd(cell_grid *g, int i0, int i1, int j0, int j1, bnd *b)
{
    const int ii[4] = {i0, i1, i0, i1}, jj[4] = {j0, j0, j1, j1};
    bnd_reset(b);
    for (int c = 0; c < 4; ++c) {
        if (!g->done[ii[c]][jj[c]])
            grid_point(g, ii[c], jj[c]);
        bnd_add(b, g->m[ii[c]][jj[c]], g->pos[ii[c]][jj[c]], g->r[ii[c]][jj[c]]);
    }
}

/* The piece with grid corners (i0, j0) .. (i1, j1) of the cell at (ci, cj): culled, split, or
 * Newton's start. The whole cell (depth 1) passed as the pyramid's node already. */
static void solve_piece(problem *pb, double ci, double cj, double c[4][3], cell_grid *g, int i0, int i1, int j0, int j1,
                        int depth)
{
    if (depth > 1) {
        bnd b;
        piece_bnd(g, i0, i1, j0, j1, &b);
        if (!pb->may_hold(pb, ci + g->a[i0], ci + g->a[i1], cj + g->b[j0], cj + g->b[j1], &b))
            return;
    }
    if (depth < SPC_PLANE_SPLIT) {
        int im = (i0 + i1) / 2, jm = (j0 + j1) / 2;
        solve_piece(pb, ci, cj, c, g, i0, im, j0, jm, depth + 1);
        solve_piece(pb, ci, cj, c, g, im, i1, j0, jm, depth + 1);
        solve_piece(pb, ci, cj, c, g, i0, im, jm, j1, depth + 1);
        solve_piece(pb, ci, cj, c, g, im, i1, jm, j1, depth + 1);
        return;
    }
    double a0 = g->a[i0], a1 = g->a[i1], b0 = g->b[j0], b1 = g->b[j1];
    /* a piece that holds a root found already starts no other search */
    for (int i = 0; i < pb->nroots; ++i) {
        double ra = pb->roots[i][0] - ci, rb = pb->roots[i][1] - cj;
        if (ra >= a0 && ra <= a1 && rb >= b0 && rb <= b1)
            return;
    }
    const int n = SPC_PLANE_GRID - 1;
    newton_cell(pb, ci, cj, c, 0.5 * (a0 + a1), 0.5 * (b0 + b1), g->a[0], g->a[n], g->b[0], g->b[n]);
}

static void solve_cell(problem *pb, int i, int j, double mc[4][3])
{
    const plane_map *pm = pb->pm;
    int64_t ci = pm->i0 + i, cj = pm->j0 + j;
    double c[4][3];
    corners(pb, mc, c);
    double a0 = dmax2(0.0, pm->smin - (double)ci), a1 = dmin2(1.0, pm->smax - (double)ci);
    double b0 = dmax2(0.0, pm->tmin - (double)cj), b1 = dmin2(1.0, pm->tmax - (double)cj);
    if (!(a1 > a0 && b1 > b0))
        return;
    const int n = SPC_PLANE_GRID - 1;
    cell_grid g;
    g.c = c;
    memset(g.done, 0, sizeof g.done);
    g.a[0] = a0;
    g.a[n] = a1;
    g.b[0] = b0;
    g.b[n] = b1;
    grid_mid(g.a, 0, n);
    grid_mid(g.b, 0, n);
    solve_piece(pb, (double)ci, (double)cj, c, &g, 0, n, 0, n, 1);
}

static void descend(problem *pb, int l, int i, int j)
{
    const plane_map *pm = pb->pm;
    if (i >= pm->nu[l] || j >= pm->nv[l])
        return;
    double w = (double)((int64_t)1 << l);
    double s0 = dmax2(pm->smin, pm->i0 + i * w), s1 = dmin2(pm->smax, pm->i0 + (i + 1) * w);
    double t0 = dmax2(pm->tmin, pm->j0 + j * w), t1 = dmin2(pm->tmax, pm->j0 + (j + 1) * w);
    if (!(s1 > s0 && t1 > t0))
        return;
    bnd b;
    double mc[4][3];
    node_bnd(pm, l, i, j, &b, mc);
    if (pb->turned)
        bnd_turn(&b);
    if (!pb->may_hold(pb, s0, s1, t0, t1, &b))
        return;
    if (l == 0) {
        solve_cell(pb, i, j, mc);
        return;
    }
    for (int dj = 0; dj < 2; ++dj)
        for (int di = 0; di < 2; ++di)
            descend(pb, l - 1, 2 * i + di, 2 * j + dj);
}

/* The roots for x and y (local z of both nonzero); false if the event is not the shape's. */
static bool problem_init(problem *pb, const plane_map *pm, spc_vec3 x, spc_vec3 y, bool *refract)
{
    pb->pm = pm;
    pb->may_hold = may_hold_pick();
    pb->nroots = 0;
    spc_vec3 xl = to_local(pm, x), yl = to_local(pm, y);
    if (!(xl.z != 0.0 && yl.z != 0.0))
        return false;
    pb->X[0][0] = xl.x;
    pb->X[0][1] = xl.y;
    pb->X[0][2] = xl.z;
    pb->X[1][0] = yl.x;
    pb->X[1][1] = yl.y;
    pb->X[1][2] = yl.z;
    *refract = (xl.z > 0.0) != (yl.z > 0.0);
    pb->eta[0] = pb->eta[1] = 1.0;
    if (*refract) {
        if (!(pm->eta > 0.0))
            return false;
        /* N points outside (ext_ior, relative 1), the other side holds int_ior (relative eta) */
        pb->eta[0] = xl.z > 0.0 ? 1.0 : pm->eta;
        pb->eta[1] = yl.z > 0.0 ? 1.0 : pm->eta;
    }
    pb->XS = (v2d){xl.x, yl.x};
    pb->XT = (v2d){xl.y, yl.y};
    pb->XN = (v2d){xl.z, yl.z};
    pb->XN2 = pb->XN * pb->XN;
    pb->ETA = (v2d){pb->eta[0], pb->eta[1]};
    return true;
}

static void find_roots(problem *pb)
{
    const plane_map *pm = pb->pm;
    pb->turned = false;
    descend(pb, pm->nlev - 1, 0, 0);
    /* the turned normals: only for x on N's side */
    if (pb->X[0][2] > 0.0) {
        pb->turned = true;
        descend(pb, pm->nlev - 1, 0, 0);
        pb->turned = false;
    }
}

static int roots_with(const spc_shape *s, spc_vec3 x, spc_vec3 y, bool refract, spc_vec3 *out, int max, bool base)
{
    const plane_map *pm = map_get(s);
    problem pb;
    bool rf;
    if (!pm || !problem_init(&pb, pm, x, y, &rf) || rf != refract)
        return 0;
    if (base)
        pb.may_hold = may_hold_base;
    find_roots(&pb);
    int n = 0;
    for (int i = 0; i < pb.nroots && n < max; ++i) {
        double ls = pm->p0[0] + pb.roots[i][0] * pm->ps[0] + pb.roots[i][1] * pm->pt[0];
        double lt = pm->p0[1] + pb.roots[i][0] * pm->ps[1] + pb.roots[i][1] * pm->pt[1];
        out[n++] = to_world(pm, ls, lt);
    }
    return n;
}

int spc_plane_chain_roots(const spc_shape *s, spc_vec3 x, spc_vec3 y, bool refract, spc_vec3 *out, int max)
{
    return roots_with(s, x, y, refract, out, max, false);
}

int spc_plane_chain_roots_base_isa(const spc_shape *s, spc_vec3 x, spc_vec3 y, bool refract, spc_vec3 *out, int max,
                                   bool *other)
{
    *other = may_hold_pick() != may_hold_base;
    return roots_with(s, x, y, refract, out, max, true);
}

bool spc_plane_chain_covers(const spc_chain *c, bool reflect)
{
    if (c->n != 1)
        return false;
    const spc_hit *h = &c->v[0].h;
    const plane_map *pm = map_get(h->shape);
    if (!pm)
        return false;
    if (c->v[0].event == SPC_CHAIN_REFRACT ? !(pm->eta > 0.0) : (pm->eta > 0.0 && !reflect))
        return false;
    return true; /* turned normals included (find_roots' second pass) */
}

/* Does the direction from the root r (world point P) toward y lie on the same side of the mapped
 * normal as of the plane's (else spc_bsdf_perturbed_scale zeroes the chain's value)? */
static bool lit_side(const plane_map *pm, const problem *pb, int r, spc_vec3 P, spc_vec3 y)
{
    double m[3];
    model_m(pm, pb->roots[r][0], pb->roots[r][1], m);
    if (pb->root_turned[r]) {
        m[0] = -m[0];
        m[1] = -m[1];
    }
    spc_vec3 mw = spc_add(spc_add(spc_scale(pm->S, m[0]), spc_scale(pm->T, m[1])), spc_scale(pm->N, m[2]));
    spc_vec3 wi = spc_normalize(spc_sub(y, P));
    double c0 = spc_dot(wi, pm->N), c1 = spc_dot(wi, mw) / spc_length(mw);
    return !(fabs(c0) > 1e-9 && fabs(c1) > 1e-9 && c0 * c1 < 0.0);
}

int spc_plane_chains_each(const spc_snee_query *q, bool reflect, void (*fn)(void *user, const spc_chain *c),
                          void *user, int *iterations)
{
    const spc_scene *sc = q->scene;
    int n = 0;
    if (q->max_chain < 1 || q->min_chain > 1)
        return 0;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, q->any_surface);
    for (int j = 0; cs && j < cs->n; ++j) {
        const spc_shape *s = sc->shapes[cs->idx[j]];
        if (!q->any_surface && !spc_chain_caster_allowed(s->caustic_flags, 1))
            continue;
        const plane_map *pm = map_get(s);
        if (!pm)
            continue;
        problem pb;
        bool refract;
        if (!problem_init(&pb, pm, q->x->p, q->y, &refract) || (!refract && pm->eta > 0.0 && !reflect))
            continue;
        find_roots(&pb);
        unsigned char ev = refract ? SPC_CHAIN_REFRACT : SPC_CHAIN_REFLECT;
        for (int r = 0; r < pb.nroots; ++r) {
            double ls = pm->p0[0] + pb.roots[r][0] * pm->ps[0] + pb.roots[r][1] * pm->pt[0];
            double lt = pm->p0[1] + pb.roots[r][0] * pm->ps[1] + pb.roots[r][1] * pm->pt[1];
            spc_vec3 P = to_world(pm, ls, lt);
            if (!lit_side(pm, &pb, r, P, q->y))
                continue;
            /* an area light's back (spc_area_eval: one-sided), also where y is on a sphere light's far side */
            spc_vec3 yp = spc_sub(P, q->y);
            if (spc_dot(q->ny, yp) < -1e-9 * spc_length(yp))
                continue;
            spc_vec3 xo = spc_hit_offset(q->x, spc_sub(P, q->x->p));
            spc_vec3 dir = spc_normalize(spc_sub(P, xo));
            spc_chain c;
            /* each root gives its own chain: the polish must stay at it (the roots are distinct) */
            if (!spc_snee_exact_polish(q, s, 1, &ev, dir, &c, 0, iterations) ||
                spc_distance(c.v[0].h.p, P) > SPC_SNEE_SAME_REL * sc->radius || !spc_plane_chain_covers(&c, reflect))
                continue;
            fn(user, &c);
            ++n;
        }
    }
    return n;
}

typedef struct collect {
    spc_chain *out;
    int n, max;
} collect;

static void collect_one(void *user, const spc_chain *c)
{
    collect *k = user;
    if (k->n < k->max)
        k->out[k->n++] = *c;
}

int spc_plane_chains_all(const spc_snee_query *q, bool reflect, spc_chain *out, int max_out, int *iterations)
{
    collect k = {out, 0, max_out};
    spc_plane_chains_each(q, reflect, collect_one, &k, iterations);
    return k.n;
}
