/*
 * manifold/snee_cost.c: exact early-outs for specular NEE (snee_cost.h). Each test proves that
 * some work cannot produce a chain (or a nonzero contribution), so skipping it leaves the estimate
 * unchanged. Also the query's Russian-roulette probability at a path's receivers, from the share of
 * the receiver's directions that the casters fill.
 */
#include "manifold/snee_cost.h"

#include <math.h>

#include "bsdf/bsdf.h"
#include "emitter/emitter.h"
#include "manifold/sphere_chains.h"
#include "scene/scene.h"


/* Spheres closer than this (relative to the sum of their radii) count as overlapping. */
#define SPC_SNEE_APART_REL 1e-6

/* The fewest vertices of one visit of a chain to the sphere s (spc_sphere_chain_shape). */
static int visit_vertices(const spc_shape *s, bool reflect)
{
    return s->bsdf->type == SPC_BSDF_DIELECTRIC && !reflect ? 2 : 1;
}

bool spc_snee_spheres_keep_apart(const spc_scene *sc, const spc_chain_casters *cs, spc_vec3 x, bool reflect,
                                 int max_chain)
{
    if (!cs)
        return false;
    int least = 1 << 20, next = 1 << 20; /* the two shortest visits */
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        if (!spc_sphere_chain_usable(s, x))
            return false;
        for (int j = 0; j < i; ++j) {
            const spc_shape *t = sc->shapes[cs->idx[j]];
            if (!(spc_distance(s->center, t->center) > (s->radius + t->radius) * (1.0 + SPC_SNEE_APART_REL)))
                return false;
        }
        int v = visit_vertices(s, reflect);
        if (v < least) {
            next = least;
            least = v;
        } else if (v < next) {
            next = v;
        }
    }
    return cs->n < 2 || least + next > max_chain;
}

double spc_snee_query_prob(const spc_snee_params *p)
{
    return p->guide > 0.0 || !(p->query_p > 0.0 && p->query_p < 1.0) ? 1.0 : p->query_p;
}

double spc_snee_caster_share(const spc_scene *sc, const spc_chain_casters *cs, spc_vec3 x)
{
    if (!cs)
        return 0.0;
    double share = 0.0;
    for (int i = 0; i < cs->n && share < 1.0; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        spc_vec3 c = spc_scale(spc_add(s->bbox_min, s->bbox_max), 0.5);
        double R = 0.5 * spc_length(spc_sub(s->bbox_max, s->bbox_min));
        double d = spc_length(spc_sub(c, x));
        share += d > R ? 0.5 * (1.0 - sqrt(1.0 - (R / d) * (R / d))) : 1.0;
    }
    return share < 1.0 ? share : 1.0;
}

/* Does x lie in the shadow of the caster's tight sphere (c, R) from a light at l: behind the sphere
 * as seen from l, within R of the line from l through c? There a glass ball focuses the light's
 * caustic (its focus lies 1.5 to 2 radii from the centre, beyond the sphere itself). */
static bool in_shadow(spc_vec3 c, double R, spc_vec3 l, spc_vec3 x)
{
    spc_vec3 a = spc_sub(c, l);
    double la = spc_length(a);
    if (!(la > R))
        return false;
    a = spc_scale(a, 1.0 / la);
    spc_vec3 v = spc_sub(x, c);
    double t = spc_dot(v, a);
    return t > 0.0 && spc_length2(spc_sub(v, spc_scale(a, t))) < R * R;
}

/* spc_snee_caster_share with each caster's tight sphere (spc_scene_casters.bound_c, bound_r), and 1
 * in the shadow of one from a light specular NEE samples (in_shadow; an area light by its box's
 * centre). */
static double tight_caster_share(const spc_scene *sc, const spc_chain_casters *cs, spc_vec3 x)
{
    if (!cs || !cs->bound_c)
        return 0.0;
    double share = 0.0;
    for (int i = 0; i < cs->n && share < 1.0; ++i) {
        spc_vec3 c = cs->bound_c[i];
        double R = cs->bound_r[i], d = spc_length(spc_sub(c, x));
        share += d > R ? 0.5 * (1.0 - sqrt(1.0 - (R / d) * (R / d))) : 1.0;
        for (int k = 0; k < sc->nemitters && share < 1.0; ++k) {
            const spc_emitter *e = sc->emitters[k];
            spc_vec3 l;
            if (e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_SPOT)
                l = e->position;
            else if (e->type == SPC_EMITTER_AREA && e->shape_index >= 0 && e->shape_index < sc->nshapes)
                l = spc_scale(spc_add(sc->shapes[e->shape_index]->bbox_min, sc->shapes[e->shape_index]->bbox_max), 0.5);
            else
                continue;
            if (in_shadow(c, R, l, x))
                share = 1.0;
        }
    }
    return share < 1.0 ? share : 1.0;
}

/* The probability of a query at x with floor q (later_p or first_p): the share of x's directions
 * the casters fill over SPC_SNEE_QUERY_FULL_SHARE, at least q and at most 1. */
static double share_prob(const spc_scene *sc, const spc_snee_params *p, spc_vec3 x, double q)
{
    if (!(q > 0.0 && q < 1.0))
        return 1.0;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, p->any_surface);
    double r = (p->tight_share ? tight_caster_share(sc, cs, x) : spc_snee_caster_share(sc, cs, x)) /
               SPC_SNEE_QUERY_FULL_SHARE;
    double top = p->near_p > 0.0 && p->near_p < 1.0 ? fmax(p->near_p, q) : 1.0; /* params.near_p */
    return r >= top ? top : r > q ? r : q;
}

double spc_snee_later_prob(const spc_scene *sc, const spc_snee_params *p, spc_vec3 x)
{
    return share_prob(sc, p, x, p->later_p);
}

double spc_snee_first_prob(const spc_scene *sc, const spc_snee_params *p, spc_vec3 x)
{
    return share_prob(sc, p, x, p->first_p);
}
