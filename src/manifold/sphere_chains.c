/*
 * manifold/sphere_chains.c: every specular chain through one sphere (sphere_chains.h), from the
 * planar problem's roots (sphere_roots.h) polished in 3D from the point the chain's first ray leaves
 * from, in one trace as a rule.
 */
#include "manifold/sphere_chains.h"

#include <math.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "manifold/solver.h"
#include "manifold/sphere_roots.h"
#include "scene/scene.h"

_Static_assert(SPC_SPHERE_MAX_M == SPC_CHAIN_MAX_VERTICES - 2, "a sphere chain has m + 2 vertices");

/* x (and y) count as outside a sphere of radius R beyond R (1 + this). */
#define SPC_SPHERE_OUTSIDE_REL 1e-6

bool spc_sphere_chain_shape(const spc_shape *s)
{
    if (!s || s->type != SPC_SHAPE_SPHERE || s->flip_normals || s->emitter || !s->bsdf || !(s->radius > 0.0))
        return false;
    const spc_bsdf *b = s->bsdf;
    if (b->type == SPC_BSDF_TWOSIDED)
        return b->nested[0] && b->nested[0]->type == SPC_BSDF_CONDUCTOR &&
               (!b->nested[1] || b->nested[1]->type == SPC_BSDF_CONDUCTOR);
    return b->type == SPC_BSDF_CONDUCTOR || b->type == SPC_BSDF_DIELECTRIC;
}

static bool outside(const spc_shape *s, spc_vec3 p)
{
    return spc_distance(p, s->center) > s->radius * (1.0 + SPC_SPHERE_OUTSIDE_REL);
}

static bool is_dielectric(const spc_shape *s) { return s->bsdf->type == SPC_BSDF_DIELECTRIC; }

bool spc_sphere_chain_covers(const spc_chain *c, bool reflect)
{
    int n = c->n;
    if (n < 1)
        return false;
    const spc_shape *s = c->v[0].h.shape;
    if (!spc_sphere_chain_shape(s) || !outside(s, c->x))
        return false;
    for (int i = 0; i < n; ++i)
        if (c->v[i].h.shape != s)
            return false;
    if (!is_dielectric(s))
        return n == 1 && c->v[0].event == SPC_CHAIN_REFLECT;
    if (n == 1)
        return reflect && c->v[0].event == SPC_CHAIN_REFLECT;
    if (n > 2 && !reflect)
        return false;
    for (int i = 0; i < n; ++i) {
        int want = (i == 0 || i == n - 1) ? SPC_CHAIN_REFRACT : SPC_CHAIN_REFLECT;
        if (c->v[i].event != want)
            return false;
    }
    return true;
}

bool spc_sphere_chain_usable(const spc_shape *s, spc_vec3 x) { return spc_sphere_chain_shape(s) && outside(s, x); }

/* ---- in the scene ---- */

int spc_sphere_chains_all(const spc_snee_query *q, spc_chain *out, int max_out, int *iterations)
{
    const spc_scene *sc = q->scene;
    const spc_snee_params *p = q->params;
    bool reflect = p && p->reflect;
    spc_vec3 x = q->x->p;
    int n = 0;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, q->any_surface);
    for (int j = 0; cs && j < cs->n && n < max_out; ++j) {
        const spc_shape *s = sc->shapes[cs->idx[j]];
        int event;
        if (!spc_sphere_chain_shape(s) || !spc_chain_shape_is_caster(s, q->any_surface, &event) || !outside(s, x) ||
            !outside(s, q->y))
            continue;
        double R = s->radius;
        /* the problem from the point the chain's first ray leaves from (x offset off its surface, as
         * spc_chain_trace spawns it), so that the polish's first trace already meets its tolerance */
        spc_vec3 xo = spc_hit_offset(q->x, spc_sub(s->center, x));
        spc_sphere_plane pl;
        if (!spc_sphere_plane_of(xo, s->center, R, q->y, &pl))
            continue;
        double eta = 0.0;
        spc_bsdf_is_specular_interface(s->bsdf, &eta);
        /* m = -1: one reflection; m >= 0: in, m internal reflections, out */
        int m_lo = event == SPC_CHAIN_REFLECT ? -1 : (reflect ? -1 : 0);
        int m_hi = event == SPC_CHAIN_REFLECT ? -1 : (reflect ? SPC_SPHERE_MAX_M : 0);
        if (m_hi > q->max_chain - 2)
            m_hi = q->max_chain - 2; /* k = m + 2 vertices (m = -1: one) */
        if (q->min_chain > 1 && m_lo < q->min_chain - 2)
            m_lo = q->min_chain - 2;
        if (m_hi < m_lo)
            continue;
        double roots[SPC_SPHERE_SIGNATURES][SPC_SPHERE_MAX_ROOTS];
        int nroots[SPC_SPHERE_SIGNATURES];
        spc_sphere_chain_roots_all(pl.d, pl.y1, pl.y2, eta, m_lo, m_hi, roots, nroots);
        for (int m = m_lo; m <= m_hi && n < max_out; ++m) {
            int k = m < 0 ? 1 : m + 2;
            if (k > q->max_chain || (!q->any_surface && !spc_chain_caster_allowed(s->caustic_flags, k)))
                continue;
            const double *theta = roots[m + 1];
            int nr = nroots[m + 1];
            unsigned char ev[SPC_CHAIN_MAX_VERTICES];
            for (int v = 0; v < k; ++v)
                ev[v] = (m >= 0 && (v == 0 || v == k - 1)) ? SPC_CHAIN_REFRACT : SPC_CHAIN_REFLECT;
            for (int r = 0; r < nr && n < max_out; ++r) {
                spc_vec3 dir = spc_normalize(spc_sub(spc_sphere_plane_point(&pl, theta[r]), xo));
                if (spc_snee_exact_polish(q, s, k, ev, dir, out, n, iterations))
                    ++n;
            }
        }
    }
    return n;
}
