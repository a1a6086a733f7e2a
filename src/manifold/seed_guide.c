/*
 * manifold/seed_guide.c: the light paths' pre-pass, its grid, and the guided seed directions
 * (seed_guide.h). The idea is Fan et al. 2023 ("Manifold Path Guiding", sec. 4: seed chains drawn
 * from a distribution learned from found chains, mixed with the uniform seeds); here the chains come
 * from one deterministic pre-pass of light paths rather than from the render's own solutions, so the
 * seed distribution is frozen before the first camera sample.
 */
#include "manifold/seed_guide.h"

#include <stdlib.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/warp.h"
#include "emitter/emitter.h"
#include "manifold/chain.h"

/* The grid's cell, in scene radii. A seed draws from the 2 x 2 x 2 cells nearest to x, so the light
 * paths it uses landed within about two cells of x. Measured on the triangle glass ball (scene radius
 * 4.3, ball radius 0.5): cells of 1/32 of the scene's radius gave 4.5x none at equal time, cells of
 * 1/24 of the casters' radius (6x finer) 0.5x: most receivers then had no record near them and kept
 * the uniform seeds (bench/RESULTS.md, "Guided seeds"). */
#define SPC_SGUIDE_CELL (1.0 / 32.0)
/* The seed cone's half-angle: this many cells seen from the record's vertex at x's distance (the
 * vertex of the chain through x itself lies within about that of a light path that landed a cell
 * away), at most SPC_SGUIDE_MAX_SIN as a sine. */
#define SPC_SGUIDE_JITTER 0.5
#define SPC_SGUIDE_MAX_SIN 0.25
/* Delta vertices a light path may pass before it lands. */
#define SPC_SGUIDE_MAX_BOUNCES 8

#define NK SPC_CHAIN_MAX_VERTICES

typedef struct cell {
    int64_t key[3];
    bool used;
    uint32_t start[NK + 1]; /* records of k vertices: [start[k - 1], start[k]) */
} cell;

typedef struct record {
    int64_t key[3];
    int k;
    spc_vec3 v; /* the last caster vertex before the landing point */
} record;

struct spc_sguide {
    double h; /* cell size */
    size_t cap;
    cell *cells;
    spc_vec3 *v; /* vertices, grouped by cell and k */
    long n;
};

static double cellsize(const spc_scene *sc) { return SPC_SGUIDE_CELL * sc->radius; }

static uint64_t key_hash(const int64_t k[3])
{
    uint64_t h = spc_hash64((uint64_t)k[0]);
    h = spc_hash_combine(h, (uint64_t)k[1]);
    return spc_hash_combine(h, (uint64_t)k[2]);
}

static const cell *find(const spc_sguide *g, const int64_t k[3])
{
    size_t j = (size_t)key_hash(k) & (g->cap - 1);
    while (g->cells[j].used) {
        const cell *c = &g->cells[j];
        if (c->key[0] == k[0] && c->key[1] == k[1] && c->key[2] == k[2])
            return c;
        j = (j + 1) & (g->cap - 1);
    }
    return NULL;
}

static cell *find_or_add(spc_sguide *g, const int64_t k[3])
{
    size_t j = (size_t)key_hash(k) & (g->cap - 1);
    while (g->cells[j].used) {
        cell *c = &g->cells[j];
        if (c->key[0] == k[0] && c->key[1] == k[1] && c->key[2] == k[2])
            return c;
        j = (j + 1) & (g->cap - 1);
    }
    cell *c = &g->cells[j];
    c->used = true;
    memcpy(c->key, k, sizeof c->key);
    return c;
}

/* Traces one light path toward the casters; false if it does not land after a caster vertex. */
static bool trace(const spc_scene *sc, const spc_chain_casters *cs, bool any_surface, spc_rng *rng, record *out)
{
    double pmf;
    const spc_emitter *e = spc_scene_sample_emitter(sc, spc_rng_next(rng), &pmf);
    spc_vec2 u_pos = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    spc_vec2 u_dir = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    int pick = (int)(spc_rng_next(rng) * cs->n);
    spc_vec2 u_cone = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    spc_emitter_emission em;
    if (!e || !(pmf > 0.0) || !spc_emitter_sample_emission(e, u_pos, u_dir, &em) || em.is_infinite)
        return false;
    /* the direction: uniform in the cone toward the chosen caster's bounding sphere (a proposal for
     * where chains are, not an estimate: any density of light paths keeps the seeds valid) */
    const spc_shape *s = sc->shapes[cs->idx[pick < cs->n ? pick : cs->n - 1]];
    spc_vec3 c = spc_scale(spc_add(s->bbox_min, s->bbox_max), 0.5), dc = spc_sub(c, em.p);
    double r = 0.5 * spc_distance(s->bbox_min, s->bbox_max), l = spc_length(dc);
    spc_vec3 d = em.d;
    if (l > r * 1.000001) {
        double sin_max = r / l, cos_max = sqrt(spc_max(0.0, 1.0 - sin_max * sin_max));
        spc_frame f = spc_frame_from_n(spc_scale(dc, 1.0 / l));
        d = spc_frame_to_world(&f, spc_warp_uniform_cone(u_cone, cos_max));
    }
    if (!em.delta_pos && spc_dot(d, em.n) <= 0.0)
        return false; /* behind a one-sided area light */
    spc_hit o;
    memset(&o, 0, sizeof o);
    o.p = em.p;
    o.ng = em.delta_pos ? d : em.n;
    o.err = em.err;
    spc_ray ray = spc_hit_spawn(&o, d);
    int k = 0;
    for (int bounce = 0; bounce <= SPC_SGUIDE_MAX_BOUNCES; ++bounce) {
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h))
            return false;
        spc_vec3 wo = spc_neg(ray.d);
        if (!h.bsdf || !spc_bsdf_is_delta_only(h.bsdf)) {
            if (k == 0 || k > NK)
                return false;
            out->k = k;
            out->key[0] = (int64_t)floor(h.p.x / cellsize(sc));
            out->key[1] = (int64_t)floor(h.p.y / cellsize(sc));
            out->key[2] = (int64_t)floor(h.p.z / cellsize(sc));
            return true;
        }
        spc_bsdf_sample bs;
        double u_lobe = spc_rng_next(rng);
        spc_vec2 u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_IMPORTANCE, wo, u_lobe, u, &bs))
            return false;
        if (!(bs.lobe & SPC_LOBE_NULL)) {
            int event;
            if (!spc_chain_surface(&h, any_surface, &event))
                return false; /* a delta surface no chain passes */
            ++k;
            out->v = h.p;
        }
        ray = spc_hit_spawn(&h, bs.wi);
    }
    return false;
}

spc_sguide *spc_sguide_build(const spc_scene *sc, long photons, uint64_t seed, bool any_surface)
{
    const spc_chain_casters *cs = sc ? spc_chain_casters_of(sc, any_surface) : NULL;
    if (!cs || cs->n == 0 || photons <= 0 || sc->nemitters == 0)
        return NULL;
    record *rec = malloc((size_t)photons * sizeof *rec);
    if (!rec)
        return NULL;
    long n = 0;
    for (long i = 0; i < photons; ++i) {
        spc_rng rng;
        spc_rng_seed(&rng, seed, (uint64_t)i);
        if (trace(sc, cs, any_surface, &rng, &rec[n]))
            ++n;
    }
    spc_sguide *g = calloc(1, sizeof *g);
    if (n == 0 || !g) {
        free(rec);
        free(g);
        return NULL;
    }
    g->h = cellsize(sc);
    g->cap = 16;
    while (g->cap < (size_t)n * 2)
        g->cap *= 2;
    g->cells = calloc(g->cap, sizeof *g->cells);
    g->v = malloc((size_t)n * sizeof *g->v);
    if (!g->cells || !g->v) {
        free(rec);
        spc_sguide_destroy(g);
        return NULL;
    }
    g->n = n;
    /* counts per cell and k in start[k] (shifted by one), then the offsets by a running sum over the
     * table's slots and each cell's k, then the records in place */
    for (long i = 0; i < n; ++i)
        find_or_add(g, rec[i].key)->start[rec[i].k]++;
    uint32_t at = 0;
    for (size_t j = 0; j < g->cap; ++j) {
        cell *c = &g->cells[j];
        if (!c->used)
            continue;
        c->start[0] = at;
        for (int k = 1; k <= NK; ++k) {
            uint32_t count = c->start[k];
            c->start[k] = at; /* the fill cursor of k: after the fill, the end of k's records */
            at += count;
        }
    }
    for (long i = 0; i < n; ++i) {
        cell *c = find_or_add(g, rec[i].key);
        g->v[c->start[rec[i].k]++] = rec[i].v;
    }
    /* start[k] is now the end of k's records: it is the start of k + 1's (k < NK) */
    free(rec);
    return g;
}

void spc_sguide_destroy(spc_sguide *g)
{
    if (!g)
        return;
    free(g->cells);
    free(g->v);
    free(g);
}

long spc_sguide_records(const spc_sguide *g) { return g ? g->n : 0; }

/* The 8 cells nearest to x and, for each, the records with k in [kmin, kmax]: [lo[i], hi[i]). */
static long gather(const spc_sguide *g, spc_vec3 x, int kmin, int kmax, uint32_t lo[8], uint32_t hi[8])
{
    if (kmin < 1)
        kmin = 1;
    if (kmax > NK)
        kmax = NK;
    long total = 0;
    int64_t b[3] = {(int64_t)floor(x.x / g->h - 0.5), (int64_t)floor(x.y / g->h - 0.5), (int64_t)floor(x.z / g->h - 0.5)};
    for (int i = 0; i < 8; ++i) {
        int64_t k[3] = {b[0] + (i & 1), b[1] + ((i >> 1) & 1), b[2] + ((i >> 2) & 1)};
        const cell *c = kmin <= kmax ? find(g, k) : NULL;
        lo[i] = hi[i] = 0;
        if (!c)
            continue;
        lo[i] = c->start[kmin - 1];
        hi[i] = c->start[kmax];
        total += (long)(hi[i] - lo[i]);
    }
    return total;
}

long spc_sguide_count(const spc_sguide *g, spc_vec3 x, int kmin, int kmax)
{
    uint32_t lo[8], hi[8];
    return g ? gather(g, x, kmin, kmax, lo, hi) : 0;
}

bool spc_sguide_seed(const spc_sguide *g, spc_vec3 x, int kmin, int kmax, double u, spc_vec2 u2, spc_vec3 *dir)
{
    uint32_t lo[8], hi[8];
    long total = g ? gather(g, x, kmin, kmax, lo, hi) : 0;
    if (total == 0)
        return false;
    long j = (long)(u * (double)total);
    if (j >= total)
        j = total - 1;
    spc_vec3 v = x;
    for (int i = 0; i < 8; ++i) {
        long m = (long)(hi[i] - lo[i]);
        if (j < m) {
            v = g->v[lo[i] + (uint32_t)j];
            break;
        }
        j -= m;
    }
    spc_vec3 d = spc_sub(v, x);
    double l = spc_length(d);
    if (!(l > 0.0))
        return false; /* x on a caster vertex: the caller seeds uniformly */
    double s = spc_min(SPC_SGUIDE_MAX_SIN, SPC_SGUIDE_JITTER * g->h / l);
    spc_frame f = spc_frame_from_n(spc_scale(d, 1.0 / l));
    *dir = spc_frame_to_world(&f, spc_warp_uniform_cone(u2, sqrt(1.0 - s * s)));
    return true;
}
