/*
 * manifold/caustic_guide.c: the caustic photons' pre-pass, their entries, and the guided density
 * at a path vertex (caustic_guide.h).
 *
 * The photons are light paths as a light tracer makes them (emission sampled by spc_emitter_sample_
 * emission, delta lobes sampled in importance mode), kept only from the first delta vertex to the
 * first non-delta hit. Their landing points are binned in a hash grid of cells SPC_CGUIDE_CELL
 * times the scene's radius, per shape and per side of the surface; the busiest cells by power
 * become disks. The mixture at a vertex is a defensive one (Hesterberg 1995; as in path guiding,
 * Mueller et al. 2017, sec. 5, where a BSDF-sampling fraction keeps the estimator's variance bounded
 * wherever the guide is wrong).
 */
#include "manifold/caustic_guide.h"

#include <stdlib.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/rng.h"
#include "core/warp.h"
#include "emitter/emitter.h"
#include "manifold/fit_seeds.h"

/* The grid's cell, in scene radii: the caustic under the demo's glass ball (0.25 x 0.2 on the
 * floor, scene radius 1.7) spans about four cells of 0.14; a cell bounds a disk's radius. */
#define SPC_CGUIDE_CELL (1.0 / 12.0)
/* Cells with less power than this share of the busiest one's are dropped (the mirror ball's
 * reflections spread over every wall, a few photons a cell), and glass casters through which less
 * than this share of the landed photons' power passed get no cone. */
#define SPC_CGUIDE_MIN_SHARE 0.02
/* Cells with fewer photons are dropped: their mean and spread are noise. */
#define SPC_CGUIDE_CELL_PHOTONS 4
/* The smallest disk, in cells (a focus's photons may all fall on one point). */
#define SPC_CGUIDE_MIN_RADIUS 0.125
/* Entries whose weight at a vertex is below this share of the strongest one's are left out there. */
#define SPC_CGUIDE_PRUNE 0.01
/* A disk's radius: the farthest photon of its cell times this margin (the caustic goes on a little
 * past the photons that sampled it), at most the cell's half-diagonal. */
#define SPC_CGUIDE_MARGIN 1.1
#define SPC_CGUIDE_MAX_RADIUS 0.87
/* Delta vertices a photon may pass before it lands. */
#define SPC_CGUIDE_MAX_BOUNCES 8
/* An entry whose plane is closer to x than this many disk radii is not guided toward: x lies in or
 * near the caustic, where specular NEE has it and the disk is seen edge-on. */
#define SPC_CGUIDE_MIN_HEIGHT 0.5
/* The most cone entries (glass casters) a guide keeps, the most powerful first; the disks take
 * the other entries. */
#define SPC_CGUIDE_MAX_CONES 8
/* 1 - cos of the half-angle of the cone from a point at squared distance d2 to a sphere of radius
 * r (d2 > r^2), without cancellation for small cones. */
static double cone_one_minus_cos(double d2, double r)
{
    double s2 = r * r / d2;
    return s2 / (1.0 + sqrt(spc_max(0.0, 1.0 - s2)));
}

typedef struct photon {
    spc_vec3 p, n;
    double power;
    int shape;
    int glass;   /* the last glass caster it passed through (shape index), -1 if none */
    size_t cell; /* its cell's slot in the hash table */
} photon;

typedef struct cell {
    int64_t key[3];
    int shape, side;
    bool used;
    int count;
    double power;
    spc_vec3 sp, sn; /* power-weighted sums of p and n */
    double rmax;     /* the farthest photon's distance from the power-weighted mean */
} cell;

static uint64_t cell_hash(const int64_t k[3], int shape, int side)
{
    uint64_t h = spc_hash64((uint64_t)k[0]);
    h = spc_hash_combine(h, (uint64_t)k[1]);
    h = spc_hash_combine(h, (uint64_t)k[2]);
    return spc_hash_combine(h, (uint64_t)(shape * 2 + side));
}

/* Traces one photon; writes its landing to *out (false if it does not land after a delta vertex). */
static bool trace_photon(const spc_scene *sc, spc_rng *rng, photon *out)
{
    double pmf;
    const spc_emitter *e = spc_scene_sample_emitter(sc, spc_rng_next(rng), &pmf);
    spc_vec2 u_pos = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    spc_vec2 u_dir = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    spc_emitter_emission em;
    if (!e || !(pmf > 0.0) || !spc_emitter_sample_emission(e, u_pos, u_dir, &em))
        return false;
    spc_rgb beta = spc_rgb_scale(em.weight, 1.0 / pmf);
    spc_hit o;
    memset(&o, 0, sizeof o);
    o.p = em.p;
    o.ng = em.delta_pos || em.is_infinite ? em.d : em.n;
    o.err = em.err;
    spc_ray ray = spc_hit_spawn(&o, em.d);
    int deltas = 0;
    out->glass = -1;
    for (int bounce = 0; bounce <= SPC_CGUIDE_MAX_BOUNCES; ++bounce) {
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h))
            return false;
        spc_vec3 wo = spc_neg(ray.d);
        if (!spc_bsdf_is_delta_only(h.bsdf)) {
            if (deltas == 0)
                return false;
            out->p = h.p;
            out->n = spc_dot(h.ng, wo) >= 0.0 ? h.ng : spc_neg(h.ng);
            out->power = spc_rgb_lum(beta);
            out->shape = h.shape_index;
            return out->power > 0.0 && isfinite(out->power);
        }
        spc_bsdf_sample bs;
        double u_lobe = spc_rng_next(rng);
        spc_vec2 u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_IMPORTANCE, wo, u_lobe, u, &bs))
            return false;
        beta = spc_rgb_mul(beta, bs.weight);
        if (spc_rgb_is_black(beta))
            return false;
        if (!(bs.lobe & SPC_LOBE_NULL))
            ++deltas;
        if (bs.lobe & SPC_LOBE_DELTA_TRANSMISSION) {
            double eta = 0.0;
            if (spc_bsdf_is_specular_interface(h.bsdf, &eta) && eta > 0.0)
                out->glass = h.shape_index;
        }
        ray = spc_hit_spawn(&h, bs.wi);
    }
    return false;
}

static int cmp_power_desc(const void *a, const void *b)
{
    const cell *x = a, *y = b;
    if (x->power != y->power)
        return x->power < y->power ? 1 : -1;
    /* a total order, so that qsort's result does not depend on its algorithm */
    for (int i = 0; i < 3; ++i)
        if (x->key[i] != y->key[i])
            return x->key[i] < y->key[i] ? -1 : 1;
    if (x->shape != y->shape)
        return x->shape < y->shape ? -1 : 1;
    return x->side < y->side ? -1 : x->side > y->side;
}

bool spc_cguide_cone_sphere(const spc_scene *sc, const spc_shape *s, spc_vec3 *c, double *r)
{
    /* a box's corners reach up to sqrt(3) times a ball's radius: a wider cone than the ball's own */
    if (s->type == SPC_SHAPE_SPHERE) {
        *c = s->center;
        *r = s->radius;
    } else if (!spc_fit_sphere(s, c, r)) {
        *c = spc_scale(spc_add(s->bbox_min, s->bbox_max), 0.5);
        *r = 0.5 * spc_length(spc_sub(s->bbox_max, s->bbox_min));
    }
    return *r > 0.0 && isfinite(*r) && *r < SPC_CGUIDE_MAX_CONE * sc->radius;
}

spc_cguide *spc_cguide_build(const spc_scene *sc, long photons, uint64_t seed, double a)
{
    if (!sc || photons <= 0 || !(a > 0.0 && a < 1.0) || sc->nemitters == 0)
        return NULL;
    photon *ph = malloc((size_t)photons * sizeof *ph);
    if (!ph)
        return NULL;
    long landed = 0;
    for (long i = 0; i < photons; ++i) {
        spc_rng rng;
        spc_rng_seed(&rng, seed, (uint64_t)i);
        if (trace_photon(sc, &rng, &ph[landed]))
            ++landed;
    }
    if (landed == 0) {
        free(ph);
        return NULL;
    }
    size_t cap = 16;
    while (cap < (size_t)landed * 2)
        cap *= 2;
    cell *cells = calloc(cap, sizeof *cells);
    spc_cguide *g = calloc(1, sizeof *g);
    if (!cells || !g) {
        free(ph);
        free(cells);
        free(g);
        return NULL;
    }
    const double h = SPC_CGUIDE_CELL * sc->radius;
    double total = 0.0;
    for (long i = 0; i < landed; ++i) {
        const photon *q = &ph[i];
        double w = q->power / (double)photons;
        total += w;
        int64_t k[3] = {(int64_t)floor(q->p.x / h), (int64_t)floor(q->p.y / h), (int64_t)floor(q->p.z / h)};
        /* the side: the normal's largest component's sign, so a thin wall's two faces stay apart */
        double ax = fabs(q->n.x), ay = fabs(q->n.y), az = fabs(q->n.z);
        double big = ax >= ay && ax >= az ? q->n.x : ay >= az ? q->n.y : q->n.z;
        int side = big >= 0.0;
        size_t j = (size_t)cell_hash(k, q->shape, side) & (cap - 1);
        while (cells[j].used && !(cells[j].key[0] == k[0] && cells[j].key[1] == k[1] && cells[j].key[2] == k[2] &&
                                  cells[j].shape == q->shape && cells[j].side == side))
            j = (j + 1) & (cap - 1);
        cell *c = &cells[j];
        if (!c->used) {
            c->used = true;
            memcpy(c->key, k, sizeof k);
            c->shape = q->shape;
            c->side = side;
        }
        c->count++;
        c->power += w;
        c->sp = spc_madd(c->sp, q->p, w);
        c->sn = spc_madd(c->sn, q->n, w);
        ph[i].cell = j;
    }
    /* each disk reaches the farthest photon of its cell, so that the disks cover every point the
     * photons landed on: a caustic point no disk covers has the mixture's BSDF share 1 - a of its
     * density alone, and its weight grows by 1 / (1 - a) */
    for (long i = 0; i < landed; ++i) {
        cell *c = &cells[ph[i].cell];
        double d = spc_distance(ph[i].p, spc_scale(c->sp, 1.0 / c->power));
        c->rmax = spc_max(c->rmax, d);
    }
    /* the cones: the power of the photons that passed each glass caster */
    double *through = calloc((size_t)sc->nshapes, sizeof *through);
    if (!through) {
        free(ph);
        free(cells);
        free(g);
        return NULL;
    }
    for (long i = 0; i < landed; ++i)
        if (ph[i].glass >= 0 && ph[i].glass < sc->nshapes)
            through[ph[i].glass] += ph[i].power / (double)photons;
    free(ph);
    spc_cguide_entry cones[SPC_CGUIDE_MAX_CONES];
    int ncones = 0;
    while (ncones < SPC_CGUIDE_MAX_CONES) {
        int best = -1;
        for (int i = 0; i < sc->nshapes; ++i)
            if (through[i] > 0.0 && (best < 0 || through[i] > through[best]))
                best = i;
        if (best < 0 || !(through[best] >= SPC_CGUIDE_MIN_SHARE * total))
            break;
        spc_cguide_entry *en = &cones[ncones];
        en->n = spc_v3(0, 0, 0);
        en->power = through[best];
        en->cone = true;
        if (spc_cguide_cone_sphere(sc, sc->shapes[best], &en->c, &en->r))
            ++ncones;
        through[best] = 0.0;
    }
    free(through);
    /* the kept cells, busiest first */
    size_t nkeep = 0;
    for (size_t j = 0; j < cap; ++j)
        if (cells[j].used && cells[j].count >= SPC_CGUIDE_CELL_PHOTONS)
            cells[nkeep++] = cells[j];
    qsort(cells, nkeep, sizeof *cells, cmp_power_desc);
    for (size_t j = 0; j < nkeep && g->n < SPC_CGUIDE_MAX_ENTRIES - ncones; ++j) {
        const cell *c = &cells[j];
        if (c->power < SPC_CGUIDE_MIN_SHARE * cells[0].power)
            break;
        spc_vec3 m = spc_scale(c->sp, 1.0 / c->power);
        double r = c->rmax * SPC_CGUIDE_MARGIN;
        double nl = spc_length(c->sn);
        if (!(nl > 0.0) || !isfinite(r))
            continue;
        spc_cguide_entry *en = &g->e[g->n++];
        en->c = m;
        en->n = spc_scale(c->sn, 1.0 / nl);
        en->r = spc_clamp(r, SPC_CGUIDE_MIN_RADIUS * h, SPC_CGUIDE_MAX_RADIUS * h);
        en->power = c->power;
        en->cone = false;
    }
    free(cells);
    /* the cones after the disks */
    for (int j = 0; j < ncones; ++j)
        g->e[g->n++] = cones[j];
    g->cones = ncones;
    if (g->n == 0) {
        free(g);
        return NULL;
    }
    g->a = a;
    g->photons = photons;
    g->landed = landed;
    g->power = total;
    return g;
}

void spc_cguide_destroy(spc_cguide *g) { free(g); }

void spc_cguide_vertex_init(spc_cguide_vertex *v, const spc_cguide *g, const spc_hit *h, spc_vec3 wo)
{
    v->g = g;
    v->x = h->p;
    v->a = 0.0;
    v->wsum = 0.0;
    v->n = 0;
    if (!g || !h->bsdf)
        return;
    unsigned fl = spc_bsdf_flags(h->bsdf);
    if (!(fl & SPC_LOBE_SMOOTH) || (fl & SPC_LOBE_TRANSMISSION))
        return;
    /* the side the BSDF reflects to: wo's, across the geometric normal */
    double side = spc_dot(wo, h->ng) >= 0.0 ? 1.0 : -1.0;
    double wmax = 0.0;
    for (int j = 0; j < g->n; ++j) {
        const spc_cguide_entry *e = &g->e[j];
        spc_vec3 d = spc_sub(e->c, h->p);
        if (e->cone) {
            double d2 = spc_length2(d);
            if (!(d2 > e->r * e->r) || !(side * spc_dot(d, h->ng) > 0.0))
                continue;
            /* power cos_x / d^2 */
            double w = e->power * spc_absdot(d, h->sh.n) / (d2 * sqrt(d2));
            if (!(w > 0.0) || !isfinite(w))
                continue;
            v->idx[v->n] = (unsigned char)j;
            v->w[v->n++] = w;
            wmax = spc_max(wmax, w);
            continue;
        }
        double height = -spc_dot(d, e->n); /* x's height over the disk's plane, on its lit side */
        if (!(height > SPC_CGUIDE_MIN_HEIGHT * e->r) || !(side * spc_dot(d, h->ng) > 0.0))
            continue;
        double d2 = spc_length2(d);
        /* power cos_x cos_y / max(d^2, r^2), cos_x cos_y = (d.n_x)(height) / d^2 */
        double w = e->power * spc_absdot(d, h->sh.n) * height / (d2 * spc_max(d2, e->r * e->r));
        if (!(w > 0.0) || !isfinite(w))
            continue;
        v->idx[v->n] = (unsigned char)j;
        v->w[v->n++] = w;
        wmax = spc_max(wmax, w);
    }
    /* entries far below the strongest are dropped: they cost a test per density evaluation and
     * would draw few directions */
    int k = 0;
    for (int i = 0; i < v->n; ++i)
        if (v->w[i] >= SPC_CGUIDE_PRUNE * wmax) {
            v->idx[k] = v->idx[i];
            v->w[k++] = v->w[i];
            v->wsum += v->w[i];
        }
    v->n = k;
    if (v->n > 0 && v->wsum > 0.0 && isfinite(v->wsum))
        v->a = g->a;
    else {
        v->n = 0;
        v->wsum = 0.0;
    }
}

bool spc_cguide_sample(const spc_cguide_vertex *v, double u1, spc_vec2 u2, spc_vec3 *wi)
{
    if (!(v->a > 0.0) || v->n == 0)
        return false;
    double t = u1 * v->wsum;
    int i = 0;
    while (i < v->n - 1 && t >= v->w[i]) {
        t -= v->w[i];
        ++i;
    }
    const spc_cguide_entry *e = &v->g->e[v->idx[i]];
    if (e->cone) {
        spc_vec3 d = spc_sub(e->c, v->x);
        double d2 = spc_length2(d);
        if (!(d2 > e->r * e->r))
            return false;
        double omc = u2.x * cone_one_minus_cos(d2, e->r);
        double cost = 1.0 - omc, sint = sqrt(spc_max(0.0, omc * (2.0 - omc)));
        double phi = 2.0 * SPC_PI * u2.y;
        spc_frame fr = spc_frame_from_n(spc_scale(d, 1.0 / sqrt(d2)));
        *wi =
            spc_add(spc_add(spc_scale(fr.s, sint * cos(phi)), spc_scale(fr.t, sint * sin(phi))), spc_scale(fr.n, cost));
        return true;
    }
    spc_vec2 dk = spc_warp_disk_concentric(u2);
    spc_frame fr = spc_frame_from_n(e->n);
    spc_vec3 y = spc_add(e->c, spc_add(spc_scale(fr.s, dk.x * e->r), spc_scale(fr.t, dk.y * e->r)));
    spc_vec3 d = spc_sub(y, v->x);
    double l = spc_length(d);
    if (!(l > 0.0))
        return false;
    *wi = spc_scale(d, 1.0 / l);
    return true;
}

double spc_cguide_pdf(const spc_cguide_vertex *v, spc_vec3 wi)
{
    if (!(v->a > 0.0))
        return 0.0;
    double pdf = 0.0;
    for (int i = 0; i < v->n; ++i) {
        const spc_cguide_entry *e = &v->g->e[v->idx[i]];
        if (e->cone) {
            spc_vec3 d = spc_sub(e->c, v->x);
            double d2 = spc_length2(d);
            if (!(d2 > e->r * e->r))
                continue;
            double omc = cone_one_minus_cos(d2, e->r);
            if (spc_dot(wi, d) >= (1.0 - omc) * sqrt(d2))
                pdf += v->w[i] / (2.0 * SPC_PI * omc);
            continue;
        }
        double cosd = spc_dot(wi, e->n);
        if (!(cosd < 0.0))
            continue; /* x is on the lit side: only directions against the normal reach the disk */
        double t = spc_dot(spc_sub(e->c, v->x), e->n) / cosd;
        if (!(t > 0.0))
            continue;
        spc_vec3 y = spc_madd(v->x, wi, t);
        if (spc_length2(spc_sub(y, e->c)) >= e->r * e->r)
            continue;
        pdf += v->w[i] * t * t / (-cosd * SPC_PI * e->r * e->r);
    }
    return pdf / v->wsum;
}

bool spc_cguide_sample_mix(const spc_cguide_vertex *v, const spc_hit *h, spc_vec3 wo, double u_lobe, spc_vec2 u_dir,
                           spc_bsdf_sample *bs)
{
    const spc_bsdf *b = h->bsdf;
    if (!v || !(v->a > 0.0))
        return spc_bsdf_sample_dir(b, h, SPC_MODE_RADIANCE, wo, u_lobe, u_dir, bs);
    const double a = v->a;
    if (u_lobe < a) {
        spc_vec3 wi;
        if (!spc_cguide_sample(v, u_lobe / a, u_dir, &wi))
            return false;
        spc_rgb f = spc_bsdf_eval(b, h, SPC_MODE_RADIANCE, wo, wi);
        double cosi = spc_absdot(wi, h->sh.n);
        double pdf = a * spc_cguide_pdf(v, wi) + (1.0 - a) * spc_bsdf_pdf(b, h, SPC_MODE_RADIANCE, wo, wi);
        if (spc_rgb_is_black(f) || !(cosi > 0.0) || !(pdf > 0.0) || !isfinite(pdf))
            return false;
        bs->wi = wi;
        bs->weight = spc_rgb_scale(f, cosi / pdf);
        bs->pdf = pdf;
        bs->lobe = (spc_bsdf_flags(b) & SPC_LOBE_DIFFUSE_REFLECTION) ? SPC_LOBE_DIFFUSE_REFLECTION
                                                                     : SPC_LOBE_GLOSSY_REFLECTION;
        bs->eta = 1.0;
        return true;
    }
    double u = (u_lobe - a) / (1.0 - a);
    if (u >= 1.0)
        u = nextafter(1.0, 0.0);
    if (!spc_bsdf_sample_dir(b, h, SPC_MODE_RADIANCE, wo, u, u_dir, bs))
        return false;
    if (bs->lobe & SPC_LOBE_DELTA) {
        bs->weight = spc_rgb_scale(bs->weight, 1.0 / (1.0 - a));
        bs->pdf *= 1.0 - a;
        return true;
    }
    double pdf = a * spc_cguide_pdf(v, bs->wi) + (1.0 - a) * bs->pdf;
    if (!(pdf > 0.0))
        return false;
    bs->weight = spc_rgb_scale(bs->weight, bs->pdf / pdf);
    bs->pdf = pdf;
    return true;
}
