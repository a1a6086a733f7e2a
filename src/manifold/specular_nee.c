/*
 * manifold/specular_nee.c: specular next-event estimation for any solver (contract and the exact
 * set of paths it covers in specular_nee.h; the solvers and their table: solver.h), the contribution
 * of a solved chain, the unbiased estimate of the reciprocal probability of a solution, and the
 * bookkeeping that keeps the path tracer from counting the same paths again.
 *
 * Contribution: the measurement at x through a chain x -> x_1 .. x_k -> y, integrated over
 * directions at x, is changed to an integral over the light's area with the generalized geometry
 * term of the chain (Jakob and Marschner 2012; Dadfar 2022 sec. 6.6; Hanika et al. 2015), computed
 * from the chain's derivatives (chain.c). Probability: Zeltner et al. 2020, sec. 4.3 (the
 * number of independent solver attempts until the same solution reappears is geometric with mean
 * 1/p; thesis sec. 6.6).
 */
#include "manifold/specular_nee.h"

#include <stdlib.h>
#include <string.h>

#include "core/sampler.h"
#include "manifold/conic.h"
#include "manifold/fit_seeds.h"
#include "manifold/flat_chains.h"
#include "manifold/plane_chains.h"
#include "manifold/receiver.h"
#include "manifold/rough.h"
#include "manifold/snee_cost.h"
#include "manifold/snee_options.h"
#include "manifold/solve_mis.h"
#include "scene/camera.h"
#include "scene/sdf.h"
#include "manifold/cylinder_chains.h"
#include "manifold/sphere_chains.h"
#include "manifold/unfold_chains.h"

/* Distinct solutions the biased estimator keeps per light sample (more are dropped: bias). */
#define SPC_SNEE_BIASED_MAX_SOLUTIONS 8
/* The longest of those chains (vertices): a pass takes one length, uniformly from max_chain + 1 to
 * this; each internal reflection in a glass ball keeps a few percent of the light, and the
 * enumeration's cost grows with the count (1D roots on a ball: 3 us for one, 14 us for four). */
#define SPC_SNEE_LONG_MAX 6
/* The widest guided cone (radians, half-angle): wider, a direction rarely reaches the light, and
 * BSDF sampling does as well. */
#define SPC_SNEE_GUIDE_MAX_ANGLE 0.5
/* The cones' axes: chains solved to this fraction of the light's size. */
#define SPC_SNEE_GUIDE_TOL 0.02
/* Cones per light (chains toward its facing point). */
#define SPC_SNEE_GUIDE_MAX_CONES 4
/* Solutions kept from a solver that enumerates them all (solve_all): one interface rarely has more
 * than a handful between two points. */
#define SPC_SNEE_MAX_ALL 16

/* ---- guided directions (params.guide) ---- */

/* Guided directions run (they need MIS; the rough mode has its own estimator). */
static bool guide_on(const spc_snee_params *p)
{
    return p->guide > 0.0 && p->mis && !(p->solver == SPC_SNEE_NEWTON && p->newton.rough);
}

/* The cones at a receiver toward one light: built from x alone (deterministic), so that the BSDF
 * side and specular NEE's light sample find the same density for a path. */
typedef struct spc_snee_cones {
    const spc_emitter *e; /* the light they aim at; NULL: not built */
    int budget;           /* chains of at most this many vertices (the receiver's budget) */
    double pmf;           /* the light's probability (by power) */
    int n;
    spc_vec3 axis[SPC_SNEE_GUIDE_MAX_CONES];
    double cos_max[SPC_SNEE_GUIDE_MAX_CONES], pdf[SPC_SNEE_GUIDE_MAX_CONES];
} spc_snee_cones;

static bool exact_covers(const spc_snee_query *q, const spc_specular_solver *solver, const spc_chain *c);

/* Whether the light's image through chain c (solved from x toward y, light radius r) is the patch
 * its Jacobian predicts: three probe directions, each aimed by the Jacobian at a point half a
 * radius from y across the final segment, traced through the same surfaces; each must reach the
 * light within a quarter radius of its aim. A smooth interface passes; a normal map's ripples, a
 * silhouette or a fold inside the image fail (the cone would hold a part of a scattered image). */
static bool cone_probes_ok(const spc_scene *sc, const spc_hit *x, const spc_emitter *e, const spc_chain *c,
                           spc_vec3 y, double r, bool any_surface)
{
    spc_vec3 n = spc_neg(c->v[c->n - 1].d);
    spc_vec3 q, dq[2];
    double t;
    if (!spc_chain_plane_hit(c, y, n, &q, dq, &t))
        return false;
    spc_frame pf = spc_frame_from_n(n);
    double m00 = spc_dot(pf.s, dq[0]), m01 = spc_dot(pf.s, dq[1]);
    double m10 = spc_dot(pf.t, dq[0]), m11 = spc_dot(pf.t, dq[1]);
    double det = m00 * m11 - m01 * m10;
    if (!(fabs(det) > 0.0) || !isfinite(det))
        return false;
    spc_chain_sig sig;
    spc_chain_signature(c, &sig);
    spc_chain_opts o = spc_chain_opts_default(c->n);
    o.any_surface = any_surface;
    o.fixed = &sig;
    o.find_end = true;
    /* half a radius out at 0, 120 and 240 degrees: a second-order term along any axis moves one */
    static const double dirs[3][2] = {{0.5, 0.0}, {-0.25, 0.4330127018922193}, {-0.25, -0.4330127018922193}};
    for (int i = 0; i < 3; ++i) {
        /* the aim, relative to where the solved chain meets the plane */
        double u = dirs[i][0] * r, v = dirs[i][1] * r;
        double da = (m11 * u - m01 * v) / det, db = (m00 * v - m10 * u) / det;
        spc_chain pc;
        if (spc_chain_trace(sc, x, &c->frame, c->a + da, c->b + db, &o, &pc) != SPC_CHAIN_END_SURFACE ||
            !pc.has_end_hit || pc.end_hit.emitter != e)
            return false;
        spc_vec3 pq, pdq[2];
        double pt;
        if (!spc_chain_plane_hit(&pc, y, n, &pq, pdq, &pt))
            return false;
        spc_vec3 aim = spc_add(q, spc_add(spc_scale(pf.s, u), spc_scale(pf.t, v)));
        if (spc_distance(pq, aim) > 0.25 * r)
            return false;
    }
    return true;
}

/* The chains from q's x to the point of e facing x (the sphere's nearest point, another shape's
 * area sample at (1/2, 1/2)) that the randomized solver would look for (the straight-line attempt,
 * or solve_all's; not the exact enumerations', whose light samples need no help), each a cone
 * around its first direction as wide as the light's image through it times params.guide, kept
 * where the image is the smooth patch the chain's Jacobian predicts (cone_probes_ok). */
static void cones_build(const spc_snee_query *q0, const spc_emitter *e, int budget, spc_snee_cones *cs)
{
    const spc_snee_params *p = q0->params;
    const spc_scene *sc = q0->scene;
    memset(cs, 0, sizeof *cs);
    cs->e = e;
    cs->budget = budget;
    if (!e || e->type != SPC_EMITTER_AREA || !e->shape || budget < 1)
        return;
    cs->pmf = spc_scene_emitter_pmf(sc, e);
    const spc_shape *s = e->shape;
    spc_vec3 y, ny;
    double r;
    if (s->type == SPC_SHAPE_SPHERE && !s->flip_normals) {
        spc_vec3 v = spc_sub(q0->x->p, s->center);
        double d = spc_length(v);
        if (!(d > s->radius))
            return;
        ny = spc_scale(v, 1.0 / d);
        y = spc_madd(s->center, ny, s->radius);
        r = s->radius;
    } else {
        spc_shape_sample ss;
        spc_shape_sample_area(s, spc_v2(0.5, 0.5), &ss);
        y = ss.p;
        ny = ss.n;
        r = sqrt(s->area / SPC_PI);
    }
    if (!(cs->pmf > 0.0) || !(r > 0.0))
        return;
    /* an axis needs a small fraction of the light's size, not a point on it: the angular attempt
     * stops there, after a few traces instead of a dozen */
    spc_snee_params pc = *p;
    pc.angular.tol_scene = 1.0;
    pc.angular.tol_light = SPC_SNEE_GUIDE_TOL;
    spc_snee_query q;
    spc_snee_query_init(&q, sc, &pc, q0->x, q0->wo, budget);
    q.y = y;
    q.ny = ny;
    q.light_size = sqrt(s->area);
    q.seed = SPC_SNEE_SEED_LIGHT;
    if (spc_snee_exact_covers_all(&q))
        return;
    spc_chain ch[SPC_SNEE_MAX_ALL];
    int nch = 0, it = 0;
    const spc_specular_solver *solver = spc_specular_solver_get(p->solver);
    if (solver && solver->solve_all)
        nch = solver->solve_all(&q, ch, SPC_SNEE_MAX_ALL, &it);
    else if (solver && solver->solve_one && solver->solve_one(&q, NULL, &ch[0], &it) &&
             !exact_covers(&q, solver, &ch[0]))
        nch = 1;
    for (int i = 0; i < nch && cs->n < SPC_SNEE_GUIDE_MAX_CONES; ++i) {
        const spc_chain *c = &ch[i];
        if (c->n < 1 || c->n > budget)
            continue;
        /* solid angle at x per unit area across the final segment at y */
        double g = spc_chain_geometry(c, y, spc_neg(c->v[c->n - 1].d));
        if (!(g > 0.0) || !isfinite(g))
            continue;
        double th = spc_min(p->guide * r * sqrt(g), SPC_SNEE_GUIDE_MAX_ANGLE);
        double cm = cos(th);
        if (!(cm < 1.0) || !cone_probes_ok(sc, q0->x, e, c, y, r, p->any_surface))
            continue;
        cs->axis[cs->n] = c->d0;
        cs->cos_max[cs->n] = cm;
        cs->pdf[cs->n] = spc_warp_uniform_cone_pdf(cm);
        cs->n++;
    }
}

/* The probability of specular NEE's light sample at q's receiver toward e: params.snee_p where
 * guided directions have a cone toward e, else 1. */
static double snee_prob(const spc_snee_query *q, const spc_emitter *e);

/* q's cones toward e (built on first use; NULL without params.guide or from the camera). */
static const spc_snee_cones *cones_for(const spc_snee_query *q, const spc_emitter *e)
{
    spc_snee_cones *cs = q->cones;
    if (!cs || q->cam || !e)
        return NULL;
    if (cs->e != e)
        cones_build(q, e, cs->budget, cs);
    return cs;
}

/* Light points per query (params.light_samples): one with guided directions or the caller's uniforms. */
static int light_count(const spc_snee_params *p)
{
    return p->light_samples > 1 && !guide_on(p) && !p->light_u_on && !p->light_u_smp ? p->light_samples : 1;
}

static double snee_prob(const spc_snee_query *q, const spc_emitter *e)
{
    const spc_snee_cones *cs = cones_for(q, e);
    return cs && cs->n > 0 ? q->params->snee_p : 1.0;
}

/* The guided density (solid angle at x, the light's probability included) of a path that leaves x
 * along d and reaches the cones' light through k chain vertices. */
static double cones_pdf(const spc_snee_cones *cs, spc_vec3 d, int k)
{
    if (!cs || cs->n == 0 || k < 1 || k > cs->budget)
        return 0.0;
    double sum = 0.0;
    for (int i = 0; i < cs->n; ++i)
        if (spc_dot(d, cs->axis[i]) >= cs->cos_max[i])
            sum += cs->pdf[i];
    return cs->pmf * sum / cs->n;
}

/* The power heuristic over the three strategies of a covered path: specular NEE's light sample
 * (psi p_y), BSDF sampling and guided directions (each in the light's area measure). */
static double mis3(double a, double b, double c)
{
    double t = a * a + b * b + c * c;
    return t > 0.0 ? a * a / t : 0.0;
}

/* The largest distance, in units of the light's size (sqrt of its area), between a covered path's
 * light point and its retrace's where another strategy's paths are weighed in (params.alt_ratio):
 * bdpt's light-traced caustics through the glass-ball caustic's sphere retrace to within 1e-3 of
 * it (their directions are recomputed from the vertices' positions, and the focusing chain
 * magnifies that rounding); 1e-2 is far below the distance between two solutions on such a light. */
#define SPC_SNEE_RETRACE_LIGHT_TOL 1e-2

/* The directions the path draws from a surface receiver's BSDF (params.bsdf_n; 0 counts as 1). */
static double bsdf_count(const spc_snee_params *p)
{
    return p && p->bsdf_n > 1.0 ? p->bsdf_n : 1.0;
}

/* The BSDF side's density b of a covered path becomes b times this with params.alt_ratio (or
 * alt_chain_ratio): the power heuristic's sqrt(b^2 + c^2) for the other strategy's density c = ratio
 * b (solver.h). c is the covered chain from x. */
static double alt_factor(const spc_snee_params *p, const spc_hit *x, spc_vec3 wo, const spc_chain *c,
                         const spc_emitter *e, spc_vec3 y, spc_vec3 ny)
{
    if (!p || !(p->alt_ratio || p->alt_chain_ratio) || !x || c->n < 1)
        return 1.0;
    double r = p->alt_chain_ratio ? p->alt_chain_ratio(p->alt_user, x, wo, c, e, y, ny)
                                  : p->alt_ratio(p->alt_user, x, wo, c->d0, c->v[c->n - 1].d, e, y, ny);
    return r > 0.0 && isfinite(r) ? sqrt(1.0 + r * r) : 1.0;
}

/* ---- contribution ---- */

/* The receiver of q: its own, else the pinhole (q->cam) or the surface point q->x seen from q->wo,
 * written to *own. */
static const spc_receiver *query_receiver(const spc_snee_query *q, spc_receiver *own)
{
    if (q->receiver)
        return q->receiver;
    if (q->cam)
        spc_receiver_camera(own, q->cam, q->cam_scale);
    else {
        spc_receiver_surface(own, q->x, q->wo);
        own->guide = q->params ? q->params->cguide_at : NULL;
    }
    return own;
}

static bool exact_shape_covers(const spc_snee_query *q, const spc_chain *c);

/* The probability that BSDF sampling, continuing a path along c's first segment, picks c's events:
 * the product over c's vertices of the lobe choice (spc_bsdf_specular_prob: F for a reflection off
 * glass, 1 - F for a refraction), part of the sampling side's density of a covered path in the MIS
 * weights of both sides. Without it a chain reflected three times inside a glass sphere (F^3 (1 -
 * F)^2, about 0.01) kept the BSDF side's weight near 1 where specular NEE's long pass enumerates it,
 * and BSDF sampling, which reaches such a path rarely and then with the light's full radiance times
 * the floor's albedo, held one seed's error in one pixel on scenes/caustic_glass_sphere.xml
 * (bench/RESULTS.md, "Fold 7"). Only for the chains an exact enumeration finds (exact_shape_covers,
 * a function of q and c alone, so both sides agree): elsewhere specular NEE's density is a stand-in
 * psi and its count of randomized attempts heavy-tailed, and handing it more of those paths made new
 * one-pixel tails on the SDF torus; there the factor is 1 (BSDF sampling keeps its larger share). */
static double chain_events_sample_prob(const spc_snee_query *q, const spc_chain *c)
{
    if (!exact_shape_covers(q, c))
        return 1.0;
    double P = 1.0;
    for (int i = 0; i < c->n && P > 0.0; ++i) {
        const spc_chain_vertex *v = &c->v[i];
        P *= spc_bsdf_specular_prob(v->h.bsdf, &v->h, spc_neg(v->wi), v->d);
    }
    return P;
}

/* The contribution of chain c toward q's light point before MIS (f T Le cos G), and in *b BSDF
 * sampling's density of the same path in the light's area measure (pdf_x G times the events'
 * probability, chain_events_sample_prob; 0 where MIS does not apply: no MIS, not an area light) and
 * in *pc the guided directions' (params.guide; they pick the events by BSDF sampling too). */
static spc_rgb chain_terms(const spc_snee_query *q, const spc_emitter *e, spc_vec2 uv, const spc_chain *c, double *b,
                           double *pc)
{
    const spc_rgb zero = spc_rgb1(0.0);
    *b = *pc = 0.0;
    int k = c->n;
    if (k < 1 || k > q->max_chain)
        return zero;
    if (!q->any_surface)
        for (int i = 0; i < k; ++i)
            if (!spc_chain_caster_allowed(c->v[i].h.shape->caustic_flags, k))
                return zero;
    const spc_chain_vertex *last = &c->v[k - 1];
    spc_vec3 d = last->d;
    /* the last segment must reach y unblocked (earlier segments are first hits by construction);
     * stopped short of y by its error bound: a point sampled on a triangle light may sit ~1e-7
     * relative off the surface the ray tracer intersects, and a tighter margin lets the light
     * shadow itself */
    double y_err = spc_max(q->y_err, 1e-9 * (spc_max_abs(q->y) + q->scene->radius));
    spc_ray sr = spc_hit_spawn_to(&last->h, q->y, y_err);
    if (spc_scene_occluded(q->scene, &sr))
        return zero;

    spc_vec3 ny;
    spc_rgb Le = spc_snee_light_radiance(e, q->y, q->ny, uv, last->h.p, d, &ny);
    if (spc_rgb_is_black(Le))
        return zero;

    spc_receiver own;
    const spc_receiver *r = query_receiver(q, &own);
    spc_rgb f;
    double cosx;
    if (!spc_receiver_eval(r, c->d0, c->v[0].h.p, &f, &cosx))
        return zero;
    /* the media a chain from a medium point crosses (1 elsewhere) */
    spc_rgb T = r->kind == SPC_RECEIVER_MEDIUM ? spc_receiver_transmittance(q->scene, r, c, q->y) : spc_rgb1(1.0);
    if (spc_rgb_is_black(T))
        return zero;
    for (int i = 0; i < k; ++i) {
        const spc_chain_vertex *v = &c->v[i];
        T = spc_rgb_mul(T, spc_bsdf_specular_throughput(v->h.bsdf, &v->h, SPC_MODE_RADIANCE, spc_neg(v->wi), v->d));
        if (spc_rgb_is_black(T))
            return zero;
    }
    double G = spc_chain_geometry(c, q->y, ny);
    if (!(G > 0.0) || !isfinite(G))
        return zero;
    if (q->params && q->params->mis && e->type == SPC_EMITTER_AREA && q->p_y > 0.0) {
        double P_ev = chain_events_sample_prob(q, c);
        *b = spc_receiver_pdf(r, c->d0) * G * P_ev *
             (r->kind == SPC_RECEIVER_SURFACE ? alt_factor(q->params, q->x, q->wo, c, e, q->y, q->ny) *
                                                    bsdf_count(q->params)
                                              : 1.0);
        *pc = cones_pdf(cones_for(q, e), c->d0, k) * G * P_ev;
    }
    /* a point or spot light's chain that another strategy makes too (params.delta_share): its share,
     * given the probability with which this pass enumerates c where that is below 1 (the flat chains
     * past flat_max: flat_psi; the other passes read their psi as 1 there) */
    double share = 1.0;
    if (q->params && q->params->delta_share && (e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_SPOT) &&
        !q->cam && r->kind == SPC_RECEIVER_SURFACE && q->x) {
        double psi = q->params->exact && spc_flat_chain_covers(c, q->params->reflect) && q->psi > 0.0 ? q->psi : 1.0;
        share = q->params->delta_share(q->params->delta_user, q->x, q->wo, c, e, psi);
    }
    return spc_rgb_scale(spc_rgb_mul(spc_rgb_mul(f, T), Le), cosx * G * share);
}

spc_rgb spc_snee_chain_value(const spc_snee_query *q, const spc_emitter *e, spc_vec2 uv, const spc_chain *c)
{
    double b, pc;
    spc_rgb v = chain_terms(q, e, uv, c, &b, &pc);
    if (spc_rgb_is_black(v))
        return v;
    double w = 1.0;
    if (q->params && q->params->mis && e->type == SPC_EMITTER_AREA && q->p_y > 0.0)
        w = mis3(q->p_y * (q->psi > 0.0 ? q->psi : 1.0), b, pc);
    return spc_rgb_scale(v, w);
}

/* spc_snee_chain_value, and in *a specular NEE's density of c (psi p_y) and in *b the sampling
 * side's as chain_terms gives it (both 0 where MIS does not apply). */
static spc_rgb counted_chain_value(const spc_snee_query *q, const spc_emitter *e, spc_vec2 uv, const spc_chain *c,
                                   double *a, double *b)
{
    double pc;
    *a = 0.0;
    spc_rgb v = chain_terms(q, e, uv, c, b, &pc);
    if (spc_rgb_is_black(v))
        return v;
    if (q->params && q->params->mis && e->type == SPC_EMITTER_AREA && q->p_y > 0.0) {
        *a = q->p_y * (q->psi > 0.0 ? q->psi : 1.0);
        v = spc_rgb_scale(v, mis3(*a, *b, pc));
    } else {
        *b = 0.0;
    }
    return v;
}

static int unfold_max(const spc_snee_query *q);

/* Is c a chain on one sphere, one mirror cylinder, through flat faces, through one sphere and one
 * flat mirror (up to unfold_max) or (not from the camera) one normal-mapped plane that params.exact
 * enumerates for q? From the camera a rippled surface's glints are dozens of images of the light (35
 * on the pool's water: the enumeration costs five path samples there), so the randomized attempts
 * keep them. */
static bool exact_shape_covers(const spc_snee_query *q, const spc_chain *c)
{
    const spc_snee_params *p = q->params;
    return p && p->exact &&
           (spc_sphere_chain_covers(c, p->reflect) || spc_cylinder_chain_covers(c) ||
            spc_flat_chain_covers(c, p->reflect) || (c->n <= unfold_max(q) && spc_unfold_chain_covers(c, p->reflect)) ||
            (!q->cam && spc_plane_chain_covers(c, p->reflect)));
}

/* Does specular NEE add the longer chains (params.long_p) at this query? */
/* The longer chains of params.long_p that are not on one sphere: the angular solver's randomized
 * attempts with the chain length fixed (the other solvers keep to their budget). */
static bool random_long(const spc_snee_params *p) { return p->solver == SPC_SNEE_ANGULAR && !p->biased; }

/* The longest chain the long pass looks for: params.long_max, SPC_SNEE_LONG_MAX where unset. */
static int long_top(const spc_snee_params *p)
{
    if (p->long_max <= 0)
        return SPC_SNEE_LONG_MAX;
    return p->long_max < SPC_CHAIN_MAX_VERTICES ? p->long_max : SPC_CHAIN_MAX_VERTICES;
}

static bool long_on(const spc_snee_query *q)
{
    const spc_snee_params *p = q->params;
    return p && (p->exact || random_long(p)) && p->mis && p->long_p > 0.0 && q->long_max > q->max_chain &&
           q->max_chain < long_top(p);
}

/* p as the long pass's randomized attempts have it: a share params.long_events_p of them take a light
 * guide's events (spc_snee_attempt_event_u's ball events: in, reflected at every inner vertex, out).
 * Both sides of the MIS, and the count, read the events' probability from these params. */
static spc_snee_params long_params(const spc_snee_params *p)
{
    spc_snee_params l = *p;
    if (p->long_events_p > 0.0)
        l.ball_events_p = p->long_events_p;
    return l;
}

/* The probability that a call enumerates the longer chains of k vertices (one length per pass, with
 * probability long_p): 0 if it never does. */
static double long_psi(const spc_snee_query *q, int k)
{
    int top = long_top(q->params);
    if (!long_on(q) || k <= q->max_chain || k > q->long_max || k > top)
        return 0.0;
    return q->params->long_p / (double)(top - q->max_chain);
}

/* Is c a chain the long pass leaves to light tracing and BSDF sampling (params.long_flat_lt): every
 * vertex on flat faces, longer than their enumeration, an area light's (light tracing makes such
 * chains from area lights only, integrator/path_lt.h)? */
static bool long_flat_left(const spc_snee_query *q, const spc_chain *c)
{
    const spc_snee_params *p = q->params;
    return p->long_flat_lt && p->lt_caustic && q->light_size > 0.0 && c->n > SPC_FLAT_MAX_VERTICES &&
           spc_flat_chain_faces(c, p->reflect);
}

/* The longest chain through flat faces enumerated at every call: the budget, or where the longer
 * chains run (the path's track then follows covered paths past the budget, to q->long_max) up to
 * SPC_FLAT_EVERY_CALL (flat_chains.h), unless params.flat34_p puts the lengths past the budget up
 * to SPC_FLAT_EVERY_CALL on a share of the calls (flat_psi). */
static int flat_max(const spc_snee_query *q)
{
    int hi = q->max_chain;
    if (long_on(q) && hi < SPC_FLAT_EVERY_CALL && q->params->flat34_p >= 1.0)
        hi = q->long_max < SPC_FLAT_EVERY_CALL ? q->long_max : SPC_FLAT_EVERY_CALL;
    return hi;
}

/* The longest chain through one sphere and one flat mirror (unfold_chains.h) enumerated, at every
 * call: the budget, and where the longer chains run (the path's track then follows covered paths
 * past the budget) up to SPC_UNFOLD_MAX_VERTICES, a glass ball's T T and the mirror's R. Left to
 * the long pass's randomized attempts, that 3-vertex chain's trial counts and 1 / psi made the
 * one-pixel seeds of a glass ball beside a flat mirror (bench/RESULTS.md, part mirrorball34). */
static int unfold_max(const spc_snee_query *q)
{
    if (!q->params || !q->params->unfold)
        return 0;
    int hi = long_on(q) && q->long_max > q->max_chain ? q->long_max : q->max_chain;
    return hi < SPC_UNFOLD_MAX_VERTICES ? hi : SPC_UNFOLD_MAX_VERTICES;
}

/* Is one of q's casters a shape s with is(s)? */
static bool has_caster(const spc_snee_query *q, bool (*is)(const spc_shape *))
{
    const spc_chain_casters *cs = spc_chain_casters_of(q->scene, q->any_surface);
    for (int j = 0; cs && j < cs->n; ++j)
        if (is(q->scene->shapes[cs->idx[j]]))
            return true;
    return false;
}

/* Is one of q's casters a sphere and another a flat mirror (unfold_chains.h)? */
static bool has_unfold_casters(const spc_snee_query *q)
{
    return has_caster(q, spc_sphere_chain_shape) && has_caster(q, spc_unfold_mirror_shape);
}

/* Is one of q's casters a flat-faced shape (flat_chains.h)? */
static bool has_flat_caster(const spc_snee_query *q) { return has_caster(q, spc_flat_chain_shape); }

/* Is one of q's casters a mirror cylinder (cylinder_chains.h)? */
static bool has_cylinder_caster(const spc_snee_query *q) { return has_caster(q, spc_cylinder_chain_shape); }

/* Is one of q's casters a tessellated ball (a sphere fit, fit_seeds.h)? */
static bool has_ball_caster(const spc_snee_query *q)
{
    const spc_chain_casters *cs = spc_chain_casters_of(q->scene, q->any_surface);
    spc_vec3 c;
    double r;
    for (int j = 0; cs && j < cs->n; ++j)
        if (spc_fit_sphere(q->scene->shapes[cs->idx[j]], &c, &r))
            return true;
    return false;
}

/* The probability per call that the chains through flat faces of 5 and 6 vertices (past flat_max,
 * where the longer chains run: long_on) are enumerated: params.flat5_p and flat6_p (and for 3 and 4
 * vertices past the budget params.flat34_p, where it is below 1), each length drawn
 * on its own and its chains counted with 1 / psi; chain_psi gives the BSDF side's density of such a
 * path the same psi. At 0 (the default) specular NEE never makes them and BSDF sampling carries them
 * with weight 1. Five vertices: a total internal reflection off a slab's thin side face on the way
 * through two slabs (a third of the caustic at test_flat_bias's floor point); six: about 1% of the
 * light there. Their enumeration cost 40% and 16% of a sample at the shares 0.25 and 0.025, for
 * 0.7% and 0.1% of the image's light under two slabs (bench/RESULTS.md, "Flat 5" and "The 5- and
 * 6-vertex flat chains left to BSDF sampling"). */
static double flat_psi(const spc_snee_query *q, int k)
{
    if (!long_on(q) || k <= flat_max(q) || k > q->long_max || k > SPC_FLAT_MAX_VERTICES)
        return 0.0;
    if (k <= SPC_FLAT_EVERY_CALL)
        return q->params->flat34_p; /* flat_max below SPC_FLAT_EVERY_CALL: params.flat34_p < 1 */
    return k == 5 ? q->params->flat5_p : k == 6 ? q->params->flat6_p : 0.0;
}

/* The probability per call that the chains of more than the budget's reflections on one mirror
 * cylinder (cylinder_chains.h), up to q->long_max and SPC_SNEE_LONG_MAX, are enumerated, all lengths
 * in one pass, each chain counted with 1 / psi; the BSDF side's density of such a path carries the
 * same psi. On scenes/caustic_mirror_ring.xml BSDF-sampled paths floor -> 3 to 6 wall reflections ->
 * light held every one-pixel tail at 24 seeds with MIS weight 1; enumerating them at every call
 * costs 12x a sample there, at psi 0.01 1.15x; psi 0.01 gave the lowest worst seed of the shares
 * measured, 0.02 and 0.05 cost more for no lower mean (bench/RESULTS.md, "The mirror ring's
 * 3-6-reflection cylinder chains on a share of the calls"). */
#ifndef SPC_CYLINDER_LONG_P
#define SPC_CYLINDER_LONG_P 0.01
#endif
static int cyl_long_max(const spc_snee_query *q)
{
    return q->long_max < SPC_SNEE_LONG_MAX ? q->long_max : SPC_SNEE_LONG_MAX;
}
static double cyl_psi(const spc_snee_query *q, const spc_chain *c)
{
    if (!long_on(q) || c->n <= q->max_chain || c->n > cyl_long_max(q) ||
        (!q->any_surface && !spc_chain_caster_allowed(c->v[0].h.shape->caustic_flags, c->n)))
        return 0.0;
    return SPC_CYLINDER_LONG_P;
}

/* The longest chain on one sphere enumerated past long_top on a share of the calls
 * (params.sphere_long_p): 6 vertices within the caller's depth, 0 where that pass never runs. */
static int sphere_long_max(const spc_snee_query *q)
{
    const spc_snee_params *p = q->params;
    if (!p->exact || !(p->sphere_long_p > 0.0) || !long_on(q))
        return 0;
    int hi = q->long_max < SPC_SNEE_LONG_MAX ? q->long_max : SPC_SNEE_LONG_MAX;
    return hi > long_top(p) ? hi : 0;
}

/* The probability per call that the chains of k vertices on one sphere are enumerated: the long
 * pass's (long_psi) up to long_top, params.sphere_long_p past it up to sphere_long_max. */
static double sphere_psi(const spc_snee_query *q, int k)
{
    if (k <= long_top(q->params))
        return long_psi(q, k);
    return k <= sphere_long_max(q) ? q->params->sphere_long_p : 0.0;
}

/* Is c counted exactly (no <1/p_solve>): enumerated by the solver's solve_all, or on one sphere or
 * mirror cylinder (params.exact)? */
static bool exact_covers(const spc_snee_query *q, const spc_specular_solver *solver, const spc_chain *c)
{
    if (solver->solve_all && solver->covers && solver->covers(c))
        return true;
    return exact_shape_covers(q, c);
}

/* Are the casters cs one sphere (sphere_chains.h, x outside it) and flat mirrors (unfold_chains.h)
 * alone, with q's chains of at most two vertices and the unfolded enumeration on? Then every such
 * chain is on the sphere, on the mirrors, or a sphere's vertex and a mirror's (a glass ball's T T
 * and a mirror take three): all enumerated, provided x lies outside the sphere's image in each
 * mirror plane (unfold_chains.h's condition for the mirror-first order). */
static bool unfold_covers_all(const spc_snee_query *q, const spc_chain_casters *cs)
{
    if (q->max_chain > 2 || unfold_max(q) < q->max_chain)
        return false;
    const spc_shape *ball = NULL;
    for (int j = 0; j < cs->n; ++j) {
        const spc_shape *s = q->scene->shapes[cs->idx[j]];
        if (spc_unfold_mirror_shape(s))
            continue;
        if (ball || !spc_sphere_chain_usable(s, q->x->p))
            return false;
        ball = s;
    }
    for (int j = 0; ball && j < cs->n; ++j) {
        const spc_shape *s = q->scene->shapes[cs->idx[j]];
        spc_vec3 nm[SPC_FLAT_MAX_FACES];
        double dm[SPC_FLAT_MAX_FACES];
        int np = s == ball ? 0 : spc_flat_shape_planes(s, nm, dm, SPC_FLAT_MAX_FACES);
        for (int f = 0; f < np; ++f) {
            spc_vec3 c = spc_unfold_mirror_point(ball->center, nm[f], dm[f]);
            if (!(spc_distance(q->x->p, c) > ball->radius * (1.0 + 1e-6)))
                return false;
        }
    }
    return ball != NULL;
}

bool spc_snee_exact_covers_all(const spc_snee_query *q)
{
    const spc_scene *sc = q->scene;
    if (!q->params || !q->params->exact)
        return false;
    int count = 0;
    bool flat = false; /* the flat-faced shapes' chains are enumerated together, across shapes */
    const spc_chain_casters *cs = spc_chain_casters_of(sc, q->any_surface);
    if (!cs)
        return false;
    for (int j = 0; j < cs->n; ++j) {
        const spc_shape *s = sc->shapes[cs->idx[j]];
        bool used = q->any_surface;
        for (int k = 1; k <= q->max_chain && !used; ++k)
            used = spc_chain_caster_allowed(s->caustic_flags, k);
        if (!used)
            continue;
        if (q->max_chain <= SPC_FLAT_MAX_VERTICES && spc_flat_chain_shape(s)) {
            count += flat ? 0 : 1;
            flat = true;
            continue;
        }
        if (!spc_sphere_chain_usable(s, q->x->p) && !spc_cylinder_chain_shape(s) &&
            (q->cam || !spc_plane_chain_shape(s)))
            return false;
        ++count;
    }
    /* two such shapes: chains through both are the randomized solver's, unless none is short enough */
    return count <= 1 || (!flat && spc_snee_spheres_keep_apart(sc, cs, q->x->p, q->params->reflect, q->max_chain)) ||
           unfold_covers_all(q, cs);
}

/* The biased estimator: the distinct solutions of biased_seeds attempts, each counted once. */
static spc_rgb biased_estimate(const spc_snee_query *q, const spc_specular_solver *solver, const spc_emitter *e,
                               spc_vec2 uv, double p_y, spc_rng *rng, spc_snee_stats *st)
{
    spc_chain found[SPC_SNEE_BIASED_MAX_SOLUTIONS + 1]; /* the last one is scratch */
    int nfound = 0, iterations = 0, seeds = q->params->biased_seeds > 0 ? q->params->biased_seeds : 1;
    spc_rgb sum = spc_rgb1(0.0);
    for (int s = 0; s < seeds; ++s) {
        spc_chain *c = &found[nfound];
        if (!solver->solve_one(q, rng, c, &iterations))
            continue;
        if (exact_covers(q, solver, c))
            continue; /* counted exactly */
        bool seen = false;
        for (int i = 0; i < nfound && !seen; ++i)
            seen = spc_snee_same_solution(&found[i], c, q->scene->radius);
        if (seen)
            continue;
        if (st)
            st->solved++;
        spc_rgb v = spc_snee_chain_value(q, e, uv, c);
        if (!spc_rgb_is_black(v)) {
            sum = spc_rgb_add(sum, v);
            if (st)
                st->contributions++;
        }
        if (nfound < SPC_SNEE_BIASED_MAX_SOLUTIONS)
            ++nfound;
    }
    if (st)
        st->iterations += (uint64_t)iterations;
    return spc_rgb_scale(sum, 1.0 / p_y);
}

/* ---- the light point ---- */

/* A sphere around every caster shape (the union of their bounding boxes); false if none. */
static bool caster_bound(const spc_scene *sc, bool any_surface, spc_vec3 *c, double *r)
{
    const spc_chain_casters *cs = spc_chain_casters_of(sc, any_surface);
    if (!cs || cs->n == 0)
        return false;
    *c = cs->center;
    *r = cs->radius;
    return isfinite(*r);
}

/* A light point for the chains' last segment from the sphere (cb, cr) around the casters. On a
 * sphere light (normals outward) only the cap whose tangent planes have part of that sphere in
 * front can emit toward a caster: its points are drawn uniformly, density 1 / (cap area), so the
 * attempts and their variance are not spent on the far side (over half of the light from a
 * distant caster). Other shapes: uniform by area. False if no point of the light can face the
 * casters. */
static bool sample_light_facing(const spc_shape *s, spc_vec3 cb, double cr, spc_vec2 u, spc_shape_sample *out)
{
    if (s->type != SPC_SHAPE_SPHERE || s->flip_normals) {
        spc_shape_sample_area(s, u, out);
        return true;
    }
    /* n . (z - y) > 0 for some z of the bound, y = c + R n: n . axis > (R - cr) / D */
    spc_vec3 axis = spc_sub(cb, s->center);
    double D = spc_length(axis), R = s->radius;
    double cmin = D > 0.0 ? (R - cr) / D : -1.0;
    if (cmin >= 1.0)
        return false;
    if (!(cmin > -1.0)) {
        spc_shape_sample_area(s, u, out);
        return true;
    }
    spc_frame fr = spc_frame_from_n(spc_scale(axis, 1.0 / D));
    double z = 1.0 - u.x * (1.0 - cmin), sr = sqrt(spc_max(0.0, 1.0 - z * z)), phi = 2.0 * SPC_PI * u.y;
    spc_vec3 d = spc_frame_to_world(&fr, spc_v3(sr * cos(phi), sr * sin(phi), z));
    /* the point, normal, uv and error bound exactly as spc_shape_sample_area has them */
    out->p = spc_madd(s->center, d, R);
    out->n = d;
    out->uv = spc_sphere_uv(s, d);
    out->pdf = 1.0 / (2.0 * SPC_PI * R * R * (1.0 - cmin));
    out->err = 1e-9 * (spc_max_abs(s->center) + R);
    out->prim = 0;
    return true;
}

/* params.light_x: the share of the light points drawn in the cone toward the sphere light s from the
 * surface receiver at xp (0 where it does not apply: no share, another shape, xp inside). */
static double light_x_share(const spc_snee_params *p, const spc_shape *s, spc_vec3 xp)
{
    if (!p || !(p->light_x > 0.0) || !s || s->type != SPC_SHAPE_SPHERE || s->flip_normals)
        return 0.0;
    return spc_shape_has_solid_angle_sampling(s, xp) ? spc_min(p->light_x, 1.0) : 0.0;
}

/* The receiver point whose cone params.light_x draws from: a surface receiver's (not the pinhole's,
 * not a medium point's); NULL otherwise. */
static const spc_hit *light_x_receiver(const spc_snee_query *q)
{
    if (!q->x || q->cam || (q->receiver && q->receiver->kind != SPC_RECEIVER_SURFACE))
        return NULL;
    return q->x;
}

/* The area density at y (normal ny) on the sphere light s of spc_snee_sample_light's mixture at the
 * receiver point xp with the share a of it in the cone from xp (light_x_share > 0), the light's pmf
 * left out: the cone's solid angle density turned to area at y where xp sees y's side, plus the
 * share 1 - a of the cap facing the casters' sphere (cb, cr) (sample_light_facing). */
static double light_x_pdf(const spc_shape *s, spc_vec3 cb, double cr, double a, spc_vec3 xp, spc_vec3 y, spc_vec3 ny)
{
    double pc = 0.0;
    spc_vec3 v = spc_sub(xp, y);
    double d2 = spc_length2(v), cy = spc_dot(ny, v);
    if (cy > 0.0 && d2 > 0.0)
        pc = spc_shape_pdf_solid_angle(s, xp, y) * cy / (d2 * sqrt(d2));
    double pf;
    spc_vec3 axis = spc_sub(cb, s->center);
    double D = spc_length(axis), R = s->radius;
    double cmin = D > 0.0 ? (R - cr) / D : -1.0;
    if (cmin >= 1.0)
        pf = 0.0;
    else if (!(cmin > -1.0))
        pf = 1.0 / s->area;
    else
        pf = spc_dot(spc_normalize(spc_sub(y, s->center)), axis) / D < cmin
                 ? 0.0
                 : 1.0 / (2.0 * SPC_PI * R * R * (1.0 - cmin));
    return a * pc + (1.0 - a) * pf;
}

bool spc_snee_sample_light(const spc_scene *sc, bool any_surface, spc_rng *rng, spc_snee_query *q,
                           const spc_emitter **e_out, spc_vec2 *uv, double *p_y)
{
    /* the caller's stratified uniforms where it has drawn them (spc_snee_params.light_u) */
    const spc_snee_params *sp = q->params;
    bool given = sp && (sp->light_u_on || sp->light_u_smp);
    double lu[3] = {0.0, 0.0, 0.0};
    if (given && sp->light_u_on) {
        lu[0] = sp->light_u[0];
        lu[1] = sp->light_u[1];
        lu[2] = sp->light_u[2];
    } else if (given) {
        /* the caller's stream at the light sample's pairs, in its order: the point's pair first */
        spc_sampler s = *sp->light_u_smp;
        spc_vec2 u_pos = spc_sampler_2d(&s);
        lu[0] = spc_sampler_1d(&s);
        lu[1] = u_pos.x;
        lu[2] = u_pos.y;
    }
    double pmf;
    const spc_emitter *e = spc_scene_sample_emitter(sc, given ? lu[0] : spc_rng_next(rng), &pmf);
    if (!e)
        return false;
    *e_out = e;
    *uv = spc_v2(0, 0);
    switch (e->type) {
    case SPC_EMITTER_AREA: {
        /* the last chain vertex lies on a caster, inside the casters' bounding sphere, and the
         * light emits only on the side of its normal: y must face that sphere */
        spc_vec3 cb;
        double cr;
        if (!caster_bound(sc, any_surface, &cb, &cr))
            return false;
        spc_shape_sample ss;
        spc_vec2 u = given ? spc_v2(lu[1], lu[2]) : spc_v2(spc_rng_next(rng), spc_rng_next(rng));
        /* params.light_x: a share of the points in the cone from the receiver, u.x split between
         * the two ways */
        const spc_hit *xr = light_x_receiver(q);
        double a = xr ? light_x_share(sp, e->shape, xr->p) : 0.0;
        if (a > 0.0 && u.x < a) {
            if (!spc_shape_sample_solid_angle(e->shape, xr->p, spc_v2(u.x / a, u.y), true, &ss) || !(ss.pdf > 0.0))
                return false;
        } else if (!sample_light_facing(e->shape, cb, cr, a > 0.0 ? spc_v2((u.x - a) / (1.0 - a), u.y) : u, &ss))
            return false;
        if (spc_dot(ss.n, spc_sub(cb, ss.p)) + cr <= 0.0)
            return false; /* exact: every chain would arrive from behind the light */
        q->y = ss.p;
        q->ny = ss.n;
        q->light_size = sqrt(e->shape->area);
        q->y_err = ss.err;
        *uv = ss.uv;
        *p_y = pmf * (a > 0.0 ? light_x_pdf(e->shape, cb, cr, a, xr->p, ss.p, ss.n) : ss.pdf);
        break;
    }
    case SPC_EMITTER_POINT:
    case SPC_EMITTER_SPOT:
        q->y = e->position;
        q->ny = spc_v3(0, 0, 0);
        q->light_size = 0.0;
        q->y_err = 0.0;
        *p_y = pmf;
        break;
    case SPC_EMITTER_DIRECTIONAL:
    case SPC_EMITTER_CONSTANT:
    case SPC_EMITTER_ENVMAP:
    case SPC_EMITTER_PROJECTOR:
        return false;
    default:
        return false;
    }
    return *p_y > 0.0;
}

bool spc_snee_sample_long_light(const spc_snee_query *q, const spc_emitter *e, spc_rng *rng, spc_snee_query *lq,
                                struct spc_fit_roots *fit, spc_vec2 *uv, double *p_y)
{
    /* under params.light_x the mixture draws the points of chains that leave a slab through a side
     * face (they reach the light from outside the receiver's cone) at only 1 - A of the cap's
     * density, and the long pass's randomized chains, counted with 1 / psi, are the heaviest of
     * those: its own point from the cap alone keeps them at the density they had without the cone */
    const spc_hit *xr = light_x_receiver(q);
    double a = xr && e->type == SPC_EMITTER_AREA ? light_x_share(q->params, e->shape, xr->p) : 0.0;
    if (!(a > 0.0))
        return true;
    spc_vec3 cb;
    double cr;
    if (!caster_bound(q->scene, q->params->any_surface, &cb, &cr))
        return false;
    double mix = light_x_pdf(e->shape, cb, cr, a, xr->p, q->y, q->ny);
    spc_vec2 u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    spc_shape_sample ss;
    if (!(mix > 0.0) || !sample_light_facing(e->shape, cb, cr, u, &ss) || spc_dot(ss.n, spc_sub(cb, ss.p)) + cr <= 0.0)
        return false;
    lq->y = ss.p;
    lq->ny = ss.n;
    lq->y_err = ss.err;
    fit->nshapes = 0;
    lq->fit = fit;
    *uv = ss.uv;
    *p_y = *p_y / mix * ss.pdf;
    lq->p_y = *p_y;
    return *p_y > 0.0;
}

double spc_snee_light_pdf(const spc_scene *sc, bool any_surface, const spc_emitter *e, spc_vec3 y, spc_vec3 ny)
{
    if (!e || e->type != SPC_EMITTER_AREA || !e->shape)
        return 0.0;
    double pmf = spc_scene_emitter_pmf(sc, e);
    spc_vec3 cb;
    double cr;
    if (!(pmf > 0.0) || !caster_bound(sc, any_surface, &cb, &cr))
        return 0.0;
    if (spc_dot(ny, spc_sub(cb, y)) + cr <= 0.0)
        return 0.0; /* spc_snee_sample_light's exact test */
    const spc_shape *s = e->shape;
    if (s->type != SPC_SHAPE_SPHERE || s->flip_normals)
        return pmf / s->area;
    /* sample_light_facing's cap */
    spc_vec3 axis = spc_sub(cb, s->center);
    double D = spc_length(axis), R = s->radius;
    double cmin = D > 0.0 ? (R - cr) / D : -1.0;
    if (cmin >= 1.0)
        return 0.0;
    if (!(cmin > -1.0))
        return pmf / s->area;
    spc_vec3 n = spc_normalize(spc_sub(y, s->center));
    if (spc_dot(n, axis) / D < cmin)
        return 0.0;
    return pmf / (2.0 * SPC_PI * R * R * (1.0 - cmin));
}

double spc_snee_light_pdf_at(const spc_scene *sc, const spc_snee_params *p, const spc_emitter *e, spc_vec3 y,
                             spc_vec3 ny, spc_vec3 xp)
{
    double ax = e ? light_x_share(p, e->shape, xp) : 0.0;
    if (!(ax > 0.0))
        return spc_snee_light_pdf(sc, p->any_surface, e, y, ny);
    /* the mixture's density, where y faces the casters' sphere (spc_snee_sample_light's exact test) */
    spc_vec3 cb;
    double cr;
    double pmf = spc_scene_emitter_pmf(sc, e);
    if (!(pmf > 0.0) || !caster_bound(sc, p->any_surface, &cb, &cr) || spc_dot(ny, spc_sub(cb, y)) + cr <= 0.0)
        return 0.0;
    return pmf * light_x_pdf(e->shape, cb, cr, ax, xp, y, ny);
}

/* The straight-line attempt of params.straight_first (deterministic: seeded toward y, the BSDFs'
 * events): false if it does not apply to q or finds nothing. */
static bool straight_solve(const spc_snee_query *q, const spc_specular_solver *solver, spc_chain *out, int *iterations)
{
    const spc_snee_params *p = q->params;
    bool random_seed = p->seed == SPC_SNEE_SEED_SHAPE || p->seed == SPC_SNEE_SEED_CONE;
    if (!p->straight_first || !random_seed || p->biased || !solver || !solver->solve_one || solver->solve_all ||
        !spc_snee_straight_hits_glass(q))
        return false;
    spc_snee_query ql = *q;
    ql.seed = SPC_SNEE_SEED_LIGHT;
    ql.want = NULL;
    /* a chain on one sphere is counted with the other sphere chains (params.exact) */
    return solver->solve_one(&ql, NULL, out, iterations) && !exact_covers(q, solver, out);
}

/* psi (spc_snee_params.mis) of a chain a randomized attempt finds. */
static double random_psi(const spc_snee_params *p)
{
    return p->biased || !(p->mis_solve > 0.0 && p->mis_solve < 1.0) ? 1.0 : p->mis_solve;
}

/* psi of the chain c found by a randomized attempt: random_psi, and with params.mis_events times the
 * probability of c's events where the attempts pick them (params.reflect; spc_chain_events_prob). The
 * estimate divides the trial count by that probability; with the stand-in following it, a light
 * sample's weighted value is bounded by about random_psi n f / (2 p_b) (n the trial count) whatever
 * the events, where with random_psi alone the bound grows by 1 / P(events) (two reflections off glass:
 * 25x). Both sides of the MIS compute it from the chain's signature. */
static double attempt_psi(const spc_snee_query *q, const spc_chain *c)
{
    const spc_snee_params *p = q->params;
    double psi = random_psi(p);
    if (p->mis_events && p->reflect && !p->biased && psi < 1.0) {
        spc_chain_sig sig;
        spc_chain_signature(c, &sig);
        psi *= spc_snee_attempt_events_prob(q, &sig);
    }
    return psi;
}

/* Is s a signed distance field without creases (spc_sdf_has_creases: smooth primitives joined only
 * by smooth unions; not a box, nor a CSG operation's seams)? */
static bool smooth_sdf(const spc_shape *s)
{
    return s && s->type == SPC_SHAPE_SDF && s->sdf && !spc_sdf_has_creases(s->sdf);
}

/* psi of a longer chain c (past the budget) that the long pass's randomized attempt finds, less the
 * pass's own probability long_psi: attempt_psi, but 1 where every vertex of c lies on an SDF without
 * creases (smooth_sdf). The long pass looks for chains of k vertices with probability long_psi
 * (0.025 for k = 4 past a budget of 2), so with the stand-in's further 0.1 a path reflected twice
 * inside the glass tube of scenes/caustic_sdf_torus.xml kept weight 0.59 on the BSDF side, which
 * reaches it rarely and with the value f / b (about 370: at 55 spp a pixel 40 times its mean, that
 * scene's worst seed). Across a crease the attempts find a chain rarely (a cube less a sphere in
 * scenes/sdf_shapes_csg.xml: a trial count of 1609), and there the stand-in's small share for
 * specular NEE is what bounds its value, so such chains keep it. A function of the chain, so both
 * sides of the MIS decide alike (bench/RESULTS.md, "Torus 2"). */
static double long_attempt_psi(const spc_snee_query *q, const spc_chain *c)
{
    for (int i = 0; i < c->n; ++i)
        if (!smooth_sdf(c->v[i].h.shape))
            return attempt_psi(q, c);
    return 1.0;
}

/* The stand-in psi with which give_up_cap weighs a longer chain c (past the budget) of the long pass:
 * where that pass's attempts take a light guide's events (params.long_events_p) and every vertex of
 * c lies on an SDF without creases, 1 (long_attempt_psi's: such a chain is given up at its own count
 * C = P(events) (a^2 + b^2) / (a b), as a chain within the budget is), else 0 (never given up:
 * counted on by roulette). With those events, inside the SDF torus a 4-vertex chain (in, two
 * reflections, out) with a about 6 b, found once in about 600 attempts, was counted 620 times: a
 * sample of 3,300 in a pixel of 0.1, one seed's whole error, where its C is 5.5 (bench/RESULTS.md,
 * part torus25). Where b is far below a, C passes the cap and the count goes on by roulette. Only
 * for a chain with the light guide's events (their probability at least long_events_p): with other
 * events P(events) is small (0.13 for in, reflected, out at reflect_p 0.2 without long_events_p),
 * so C falls below the cap even where b is a thousandth of a, and the BSDF-sampled paths through
 * the tube got their weight back: without the default's long pass they held whole seeds' errors
 * (test_sdf_chain_mis; bench/RESULTS.md, part torus25). */
static double long_give_up_psi(const spc_snee_query *q, const spc_chain *c)
{
    const spc_snee_params *p = q->params;
    if (!(p->long_events_p > 0.0))
        return 0.0;
    for (int i = 0; i < c->n; ++i)
        if (!smooth_sdf(c->v[i].h.shape))
            return 0.0;
    spc_chain_sig sig;
    spc_chain_signature(c, &sig);
    return spc_snee_attempt_events_prob(q, &sig) >= p->long_events_p ? 1.0 : 0.0;
}

/* psi of the straight-line solution: 1 (it is found whenever it exists), but with guided
 * directions random_psi like any other, so that the BSDF side and a guided direction need not
 * repeat the straight-line attempt for every path that reaches the light (one solve each, more
 * than the direction itself costs); the guided directions carry the smooth images that attempt
 * finds. */
static double straight_psi(const spc_snee_params *p)
{
    return guide_on(p) ? random_psi(p) : 1.0;
}

/* The randomized attempts' chains weighed by the balance heuristic with their real solve probability
 * (params.solve_mis, solve_mis.h) rather than the stand-in psi: with MIS, unbiased attempts and no
 * guided directions (whose third strategy keeps the stand-in). */
static bool solve_mis_on(const spc_snee_params *p) { return p->mis && p->solve_mis && !p->biased && !guide_on(p); }

/* Is every vertex of c on a tessellated ball (a sphere fit, fit_seeds.h)? The real solve probability
 * weighs those chains and, within the budget, the smooth SDFs' (solve_mis_within), not the others:
 * on a water mesh (scenes/newton_pool.xml, p moderate everywhere) it was 2.3x worse at equal time
 * than the stand-in, which hands BSDF sampling more of the paths and so avoids the trial count's own
 * variance, which the balance heuristic does not see. A function of the chain, so both sides of the
 * MIS decide alike. */
static bool solve_mis_chain(const spc_snee_params *p, const spc_chain *c)
{
    if (!solve_mis_on(p) || c->n < 1)
        return false;
    for (int i = 0; i < c->n; ++i) {
        spc_vec3 fc;
        double fr;
        if (!c->v[i].h.shape || !spc_fit_sphere(c->v[i].h.shape, &fc, &fr))
            return false;
    }
    return true;
}

/* Does every vertex of c lie on an SDF without creases (smooth_sdf)? */
static bool smooth_sdf_chain(const spc_chain *c)
{
    if (c->n < 1)
        return false;
    for (int i = 0; i < c->n; ++i)
        if (!smooth_sdf(c->v[i].h.shape))
            return false;
    return true;
}

/* Is c, a randomized attempt's chain within the budget, weighed by the balance heuristic with its real
 * solve probability: solve_mis_chain's, or one on SDFs without creases? With the stand-in psi, the
 * glass SDF torus's (scenes/caustic_sdf_torus.xml) glints seen from the camera (one reflection, found
 * about once in 800 attempts) were counted 4,000 times: one splat of 1,100 on a pixel of 0.7, a
 * seed's whole error; the real probability bounds such a sample by the camera ray's value f / b
 * (bench/RESULTS.md, "The SDF torus's tails traced on fresh seeds"). A function of the chain, so both
 * sides of the MIS decide alike. */
static bool solve_mis_within(const spc_snee_params *p, const spc_chain *c)
{
    return solve_mis_chain(p, c) || (solve_mis_on(p) && smooth_sdf_chain(c));
}

/* The longer chains on a tessellated ball (solve_mis_chain: every vertex on a sphere fit) have a
 * pass of their own at every call where the longer chains run (long_on): one randomized attempt at a
 * length drawn uniformly past the budget, its events the ball's (in, reflected, out) with probability
 * SPC_BALL_EVENTS_P, else picked with SPC_BALL_REFLECT_P, its seeds from the fitted sphere's
 * solutions of that length at SPC_BALL_FIT_SHARE. The general long pass (probability long_p) keeps
 * the other chains only. With long_p's 1 / 40 per length and 0.2 per reflection, a 5-vertex chain
 * under the triangle glass ball (bench/check/glass_ball_mesh.xml) had specular NEE's density 1 / 7 of
 * BSDF sampling's even where every attempt finds it, so one BSDF-sampled path held a seed's whole
 * error (bench/RESULTS.md, "The triangle glass ball's 5-vertex tail"). */
#define SPC_BALL_LONG_P 1.0
#define SPC_BALL_REFLECT_P 0.5
/* The ball pass's attempts take the events of a chain through one ball (in, reflected at every inner
 * vertex, out: spc_snee_attempt_event_u) with this probability, the others pick each event at
 * SPC_BALL_REFLECT_P: the only events a chain of 2 or more vertices on one convex ball can have get
 * 0.9 instead of 0.5^k (0.03 at 5 vertices), and chains through two balls keep a share. With it and
 * SPC_BALL_FIT_SHARE, the 5-vertex paths from the floor point under that tail reach the light with a
 * mean BSDF-side weight of 0.005 instead of 0.15 (test_solve_mis; bench/RESULTS.md, "The triangle
 * glass ball's 5-vertex chain"). */
#define SPC_BALL_EVENTS_P 0.9
/* The ball pass's share of seeds from the fitted sphere's solutions (fit_seeds.h): its chains have
 * one length, so the fitted sphere's solutions of that length are the chains it looks for (at that
 * floor point three of them, each found by its own seed in 3-5 iterations; p per chain 0.17-0.23
 * at the default share 0.5, 0.25-0.35 at 0.9). */
#define SPC_BALL_FIT_SHARE 0.9

/* The ball pass's event probability: SPC_BALL_REFLECT_P, or params.reflect_p where that is higher. */
static double ball_reflect_p(const spc_snee_params *p)
{
    return p->reflect_p > SPC_BALL_REFLECT_P ? p->reflect_p : SPC_BALL_REFLECT_P;
}

/* p with the ball pass's events and seeds. */
static spc_snee_params ball_params(const spc_snee_params *p)
{
    spc_snee_params b = *p;
    b.reflect_p = ball_reflect_p(p);
    b.ball_events_p = SPC_BALL_EVENTS_P;
    b.fit_share = SPC_BALL_FIT_SHARE;
    return b;
}

/* Does the sphere fitted to one of lq's casters have a chain of lq's length (min_chain = max_chain)
 * from x to lq's light point (spc_fit_root_count: the roots its seeds draw from, kept in lq->fit)?
 * The roots of q's own lengths (lq is q's copy) come along on the same grid, for fit_first. */
static bool ball_has_roots(const spc_snee_query *lq, const spc_snee_query *q)
{
    const spc_chain_casters *cs = spc_chain_casters_of(lq->scene, lq->any_surface);
    for (int j = 0; cs && j < cs->n; ++j)
        if (spc_fit_root_count_with(lq, lq->scene->shapes[cs->idx[j]], q->min_chain, q->max_chain) > 0)
            return true;
    return false;
}

/* The probability that a call's ball pass looks for chains of k vertices: 0 if it never does, nor
 * where no fitted sphere has a chain of k vertices toward q's light point (ball_has_roots: a chain
 * the mesh has there is left to BSDF sampling; the attempt, which would have no fitted seed, is not
 * made). A function of the query, so both sides of the MIS compute it alike. */
static double ball_long_psi(const spc_snee_query *q, int k)
{
    if (!long_on(q) || !solve_mis_on(q->params) || k <= q->max_chain || k > q->long_max || k > SPC_SNEE_LONG_MAX)
        return 0.0;
    spc_snee_params bp = ball_params(q->params);
    spc_snee_query lq = *q;
    lq.params = &bp;
    lq.min_chain = lq.max_chain = k;
    if (!ball_has_roots(&lq, q))
        return 0.0;
    return SPC_BALL_LONG_P / (double)(SPC_SNEE_LONG_MAX - q->max_chain);
}

/* Does one of q's casters lie on a glass SDF without creases (smooth_sdf)? */
static bool has_smooth_sdf_caster(const spc_snee_query *q) { return has_caster(q, smooth_sdf); }

/* The camera's longer chains on a glass SDF (params.cam_long): from the pinhole only, where the
 * real solve probability weighs the randomized attempts' chains, up to SPC_SNEE_CAM_LONG_MAX
 * vertices: the class is in, one reflection inside the tube, out (the camera rays through those
 * chains' film positions on scenes/caustic_sdf_torus.xml met the light after 3 vertices, none after
 * 4: test_cam_long_sdf), and a longer length costs its attempts for fewer such chains. */
#define SPC_SNEE_CAM_LONG_MAX 4

static bool cam_long_params(const spc_snee_params *p)
{
    return p && p->cam_long && p->cam_long_p > 0.0 && p->camera && solve_mis_on(p) && random_long(p);
}

static bool cam_long_on(const spc_snee_query *q)
{
    return q->cam && cam_long_params(q->params) && q->max_chain < SPC_SNEE_CAM_LONG_MAX && q->long_max > q->max_chain &&
           has_smooth_sdf_caster(q);
}

/* The probability that a camera query's SDF pass looks for chains of k vertices: on a share
 * cam_long_p of the queries one length, uniform in max_chain + 1 .. SPC_SNEE_CAM_LONG_MAX (a length
 * past the caller's depth is drawn but not looked for), so that the value does not depend on the
 * depth, which the BSDF side does not know. A function of the query, so both sides of the MIS
 * compute it alike. */
static double cam_long_psi(const spc_snee_query *q, int k)
{
    if (!cam_long_on(q) || k <= q->max_chain || k > SPC_SNEE_CAM_LONG_MAX || k > q->long_max)
        return 0.0;
    return q->params->cam_long_p / (double)(SPC_SNEE_CAM_LONG_MAX - q->max_chain);
}

/* Is c, a chain past the budget, one that the real solve probability weighs: the ball pass's
 * (solve_mis_chain) or, from the camera, one on glass SDFs without creases (params.cam_long)? */
static bool long_solve_mis_chain(const spc_snee_query *q, const spc_chain *c)
{
    return solve_mis_chain(q->params, c) || (q->cam && cam_long_params(q->params) && smooth_sdf_chain(c));
}

/* The grazing seeds of a tessellated ball: where the light point y lies just behind the fitted
 * sphere's rim as seen from x, a ray that meets a facet at a grazing angle below the facet's tilt
 * against its interpolated normals is reflected under the facet plane, meets the next facet and is
 * reflected again: a (reflect, reflect) chain around the rim that the sphere itself (convex, no two
 * reflections in a row) and so its fitted seeds do not have. The randomized attempts found one with
 * p about 1e-3, so a BSDF-sampled path through it kept MIS weight 0.64 and held 0.95 of a seed's
 * error under the triangle glass ball (bench/RESULTS.md, "grazing double reflections"). Such a chain
 * exists only in a narrow window of grazing angles, too narrow for a few fixed seeds to land in: the
 * rays in the plane of x, the centre and y, on y's side, passing the centre at fr (1 - delta), are
 * traced through (reflect, reflect) on a grid of SPC_GRAZE_GRID + 1 values of delta up to
 * SPC_GRAZE_DELTA e^2, e the mesh's edge angle (spc_fit_edge_angle; a facet tilts by about e / 2
 * against its normals, and a ray at grazing angle g passes the centre at delta about g^2 / 2), and
 * where the in-plane angle between the leaving ray and y changes sign between neighbours the
 * interpolated direction is a seed, and so is the point past a run's end nearer zero where the chain
 * stops existing between two grid points (a root there is common: the window is 2-3 grid points
 * wide). Under the triangle glass ball (e = 0.18) its seeds' chains had delta 0.0005-0.0045; under
 * random scene 338's coarser ball (e = 0.28) the BSDF-sampled ones holding its worst seeds
 * 0.008-0.0085. Only where y lies less than SPC_GRAZE_GAP e behind the rim (the angle from x): of the
 * glass ball's chains that fixed seeds found where the gap was below 0.6 rad, 99.5% lay below 0.15,
 * at 29% of those queries. */
#define SPC_GRAZE_GRID 32
#define SPC_GRAZE_DELTA 0.15
#define SPC_GRAZE_GAP 0.8
#define SPC_GRAZE_MAX_SEEDS 4
/* For chains of 3 or more reflections (graze_long) the grid is this many times finer: their windows
 * are narrower, and on the 32-point grid the 3-reflection chain of a traced tail path (floor point
 * (0.24, 0, 0.58) under the triangle glass ball) fell between grid points. */
#define SPC_GRAZE_LONG_FINE 4

/* The unit direction whose sine against the centre's direction oh is sn, toward nh (unit, normal
 * to oh). */
static spc_vec3 graze_dir(spc_vec3 oh, spc_vec3 nh, double sn)
{
    return spc_add(spc_scale(oh, sqrt(1.0 - sn * sn)), spc_scale(nh, sn));
}

/* The grazing seed directions from q's x around the sphere (fc, fr) fitted to a mesh of edge angle e
 * toward q's y (above), for chains of k reflections (events ev): the number written to dir (at most
 * SPC_GRAZE_MAX_SEEDS), 0 where y is not just behind the rim. A chain of k reflections turns the ray
 * about k - 1 times as far around the rim as two do, so the gap allowed grows as k - 1. */
static int graze_seeds(const spc_snee_query *q, spc_vec3 fc, double fr, double e, const unsigned char *ev, int k,
                       spc_vec3 *dir)
{
    spc_vec3 oc = spc_sub(fc, q->x->p);
    double D = spc_length(oc);
    spc_vec3 d = spc_sub(q->y, q->x->p);
    double L = spc_length(d);
    if (!(D > fr) || !(L > D))
        return 0;
    spc_vec3 oh = spc_scale(oc, 1.0 / D);
    d = spc_scale(d, 1.0 / L);
    double cy = spc_dot(d, oh);
    spc_vec3 nh = spc_sub(d, spc_scale(oh, cy));
    double nl = spc_length(nh);
    if (!(nl > 0.0))
        return 0;
    /* the rim's angle from the centre's direction, less y's: y behind the rim by this much */
    double gap = asin(fr / D) - acos(spc_clamp(cy, -1.0, 1.0));
    double delta_max = SPC_GRAZE_DELTA * e * e;
    if (!(gap > 0.0 && gap < SPC_GRAZE_GAP * e * (k - 1)) || !(delta_max > 0.0 && delta_max < 1.0))
        return 0;
    nh = spc_scale(nh, 1.0 / nl);
    spc_chain_opts o = spc_chain_opts_default(k);
    o.any_surface = q->any_surface;
    o.events = ev;
    o.slim = true;
    const int grid = k > 2 ? SPC_GRAZE_LONG_FINE * SPC_GRAZE_GRID : SPC_GRAZE_GRID;
    double step = fr * delta_max / grid / D; /* in sn */
    /* the current run of grid points with a (reflect, reflect) chain: its first two and last two
     * points (sn, f), its length, whether f changed sign in it */
    double rs[4] = {0, 0, 0, 0}, rf[4] = {0, 0, 0, 0};
    int len = 0, n = 0;
    bool crossed = false;
    for (int g = 0; g <= grid + 1 && n < SPC_GRAZE_MAX_SEEDS; ++g) {
        double sn = fr * (1.0 - delta_max * g / grid) / D;
        bool valid = false;
        double f = 0.0;
        if (g <= grid) {
            spc_frame fw = spc_frame_from_n(graze_dir(oh, nh, sn));
            spc_chain ch;
            spc_chain_end end = spc_chain_trace(q->scene, q->x, &fw, 0.0, 0.0, &o, &ch);
            if ((end == SPC_CHAIN_END_SURFACE || end == SPC_CHAIN_END_ESCAPED) && ch.n == k) {
                /* the leaving ray's in-plane angle less that of the direction to y */
                spc_vec3 out = ch.v[k - 1].d, to_y = spc_sub(q->y, ch.v[k - 1].h.p);
                f = atan2(spc_dot(out, nh), spc_dot(out, oh)) - atan2(spc_dot(to_y, nh), spc_dot(to_y, oh));
                valid = isfinite(f);
            }
        }
        if (valid) {
            if (len > 0 && (f > 0.0) != (rf[3] > 0.0)) { /* a root between two neighbours */
                dir[n++] = graze_dir(oh, nh, rs[3] + (sn - rs[3]) * rf[3] / (rf[3] - f));
                crossed = true;
            }
            if (len < 2) {
                rs[len] = sn;
                rf[len] = f;
            }
            rs[2] = rs[3];
            rf[2] = rf[3];
            rs[3] = sn;
            rf[3] = f;
            ++len;
            continue;
        }
        /* the run ends: without a root inside it, the root may lie just past its end nearer zero,
         * where the chain stops existing between two grid points; extrapolated from that end */
        if (len == 1 && !crossed) {
            dir[n++] = graze_dir(oh, nh, rs[0]);
        } else if (len >= 2 && !crossed) {
            bool last = fabs(rf[3]) < fabs(rf[0]);
            double se = last ? rs[3] : rs[0], fe = last ? rf[3] : rf[0];
            double sb = last ? rs[2] : rs[1], fb = last ? rf[2] : rf[1];
            double s_root = se - fe * (se - sb) / (fe - fb);
            if (fe != fb && fabs(s_root - se) <= step && s_root > 0.0 && s_root < 1.0)
                dir[n++] = graze_dir(oh, nh, s_root);
        }
        len = 0;
        crossed = false;
    }
    return n;
}

/* Appends c to fit_first's n chains in out unless it is not the ball's (solve_mis_chain), an exact
 * enumeration's, the straight-line solution (*straight, or NULL) or one of them; the new count. */
static int fit_keep(const spc_snee_query *q, const spc_specular_solver *solver, const spc_chain *straight,
                    const spc_chain *c, spc_chain *out, int n)
{
    if (!solve_mis_chain(q->params, c) || exact_covers(q, solver, c))
        return n;
    if (straight && spc_snee_same_solution(straight, c, q->scene->radius))
        return n;
    for (int i = 0; i < n; ++i)
        if (spc_snee_same_solution(&out[i], c, q->scene->radius))
            return n;
    out[n] = *c;
    return n + 1;
}

/* The chains on tessellated balls found from each of the fitted sphere's solutions (fit_seeds.h) as
 * the seed, with that solution's events (in, m internal reflections, out; or one reflection): a
 * deterministic function of q, like the straight-line solution, so they are counted with psi 1 and
 * the randomized attempts skip them. Near the caustic's fold a floor point under the triangle glass
 * ball has three such 2-vertex chains; a randomized attempt found each with p about 0.19 (at most
 * 1 / 3 with every seed fitted), so a BSDF-sampled path through one kept weight 0.75 and held a
 * seed's error (bench/RESULTS.md, "fitted roots counted exactly"). Then, within 2 vertices, the
 * (reflect, reflect) chains from the grazing seeds (graze_seeds). Only where solve_mis_chain holds
 * (the ball's chains), within q's lengths, without the straight-line solution (*straight, or NULL)
 * and the exact enumerations' chains; duplicates once. Writes at most max to out. */
static int fit_first(const spc_snee_query *q, const spc_specular_solver *solver, const spc_chain *straight,
                     spc_chain *out, int max, int *iterations)
{
    const spc_snee_params *p = q->params;
    if (!solve_mis_on(p) || !p->fit_seeds || !solver || !solver->solve_one || solver->solve_all || p->biased ||
        !has_ball_caster(q))
        return 0;
    const spc_chain_casters *cs = spc_chain_casters_of(q->scene, q->any_surface);
    int n = 0;
    for (int j = 0; cs && j < cs->n; ++j) {
        spc_vec3 dir[SPC_FIT_MAX_DIRS];
        int m[SPC_FIT_MAX_DIRS];
        int nr = spc_fit_roots_of(q, q->scene->shapes[cs->idx[j]], dir, m, SPC_FIT_MAX_DIRS);
        for (int r = 0; r < nr && n < max; ++r) {
            unsigned char ev[SPC_CHAIN_MAX_VERTICES];
            if (spc_fit_root_events(m[r], ev) > SPC_CHAIN_MAX_VERTICES)
                continue;
            spc_snee_query tq = *q;
            tq.seed_dir = &dir[r];
            tq.want = NULL;
            tq.events = p->reflect ? ev : NULL;
            spc_rng rng; /* unused by a fixed seed with fixed events; seeded for determinism */
            spc_rng_seed(&rng, 1, 2);
            spc_chain c;
            if (solver->solve_one(&tq, &rng, &c, iterations) && c.n <= q->max_chain && c.n >= 1)
                n = fit_keep(q, solver, straight, &c, out, n);
        }
        unsigned char ev[SPC_CHAIN_MAX_VERTICES];
        for (int i = 0; i < SPC_CHAIN_MAX_VERTICES; ++i)
            ev[i] = SPC_CHAIN_REFRACT;
        ev[0] = ev[1] = SPC_CHAIN_REFLECT;
        spc_vec3 fc, gdir[SPC_GRAZE_MAX_SEEDS];
        double fr;
        const spc_shape *s = q->scene->shapes[cs->idx[j]];
        int ng = q->max_chain >= 2 && p->reflect && spc_fit_sphere(s, &fc, &fr)
                     ? graze_seeds(q, fc, fr, spc_fit_edge_angle(s), ev, 2, gdir)
                     : 0;
        for (int g = 0; g < ng && n < max; ++g) {
            spc_snee_query tq = *q;
            tq.seed_dir = &gdir[g];
            tq.want = NULL;
            tq.events = ev;
            spc_rng rng; /* unused, as above */
            spc_rng_seed(&rng, 1, 2);
            spc_chain c;
            if (solver->solve_one(&tq, &rng, &c, iterations) && c.n == 2)
                n = fit_keep(q, solver, straight, &c, out, n);
        }
    }
    return n;
}

/* Is c one of fit_first's chains for q? */
static bool fit_first_has(const spc_snee_query *q, const spc_specular_solver *solver, const spc_chain *straight,
                          const spc_chain *c)
{
    spc_chain all[SPC_FIT_MAX_DIRS];
    int it = 0;
    int n = fit_first(q, solver, straight, all, SPC_FIT_MAX_DIRS, &it);
    for (int i = 0; i < n; ++i)
        if (spc_snee_same_solution(&all[i], c, q->scene->radius))
            return true;
    return false;
}

/* The longest chain of reflections around a tessellated ball's rim counted exactly (graze_long):
 * BSDF-sampled paths through 3 and 4 such reflections held the worst seeds under the triangle glass
 * ball (bench/RESULTS.md, "the rim's reflection chains"). */
#define SPC_GRAZE_LONG_MAX 4
/* The share of the calls (where the longer chains run) that look for them, each found chain counted
 * 1 / share times. Looking at every call cost 2.0x a default sample under the triangle glass ball
 * (paired CPU; 1.3x on a grid 4x coarser, which missed the 3-reflection chain of a traced tail path),
 * while BSDF sampling's density of these chains is a tiny fraction of specular NEE's light sample:
 * at share 0.05 the paths of test_solve_mis's ball_rim_reflections_weight keep a mean BSDF-side
 * weight of 0.017 (3 reflections; one path in 60 that the seeds miss, at weight 1) and 0.000 (4),
 * as at share 1. */
#define SPC_GRAZE_LONG_P 0.05

/* Are the rim's chains of k reflections past the budget counted exactly for q (graze_long)? A
 * function of q's parameters and casters; the callers check that the longer chains run (long_on,
 * k within q's long_max). */
static bool graze_long_on(const spc_snee_query *q, int k)
{
    const spc_snee_params *p = q->params;
    return k >= 3 && k <= SPC_GRAZE_LONG_MAX && k <= SPC_CHAIN_MAX_VERTICES && solve_mis_on(p) && p->fit_seeds &&
           p->reflect && random_long(p) && has_ball_caster(q);
}

/* The chains of k reflections (k >= 3, past the budget) around the rim of a tessellated ball from
 * q's x toward q's light point, from the grazing seeds of that length (graze_seeds): a ray under a
 * facet's tilt against its interpolated normals is reflected into the next facet, and at a still
 * more grazing angle into the one after it. The sphere fitted to the ball has no such chain, so the
 * ball pass (which needs the fitted sphere's solutions of that length: ball_long_psi) never looks
 * for them, and BSDF sampling alone made them at MIS weight 1. A deterministic function of q like
 * fit_first's chains, counted with psi SPC_GRAZE_LONG_P (the share of the calls where the longer
 * chains run that look for them). Writes at most
 * max distinct chains to out. */
static int graze_long(const spc_snee_query *q, const spc_specular_solver *solver, int k, spc_chain *out, int max,
                      int *iterations)
{
    if (!graze_long_on(q, k) || !solver || !solver->solve_one || solver->solve_all)
        return 0;
    const spc_chain_casters *cs = spc_chain_casters_of(q->scene, q->any_surface);
    unsigned char ev[SPC_CHAIN_MAX_VERTICES];
    for (int i = 0; i < SPC_CHAIN_MAX_VERTICES; ++i)
        ev[i] = SPC_CHAIN_REFLECT;
    int n = 0;
    for (int j = 0; cs && j < cs->n && n < max; ++j) {
        const spc_shape *s = q->scene->shapes[cs->idx[j]];
        spc_vec3 fc, gdir[SPC_GRAZE_MAX_SEEDS];
        double fr;
        if (!spc_fit_sphere(s, &fc, &fr))
            continue;
        int ng = graze_seeds(q, fc, fr, spc_fit_edge_angle(s), ev, k, gdir);
        for (int g = 0; g < ng && n < max; ++g) {
            spc_snee_query tq = *q;
            tq.min_chain = tq.max_chain = k;
            tq.seed_dir = &gdir[g];
            tq.want = NULL;
            tq.events = ev;
            spc_rng rng; /* unused by a fixed seed with fixed events; seeded for determinism */
            spc_rng_seed(&rng, 1, 2);
            spc_chain c;
            if (!solver->solve_one(&tq, &rng, &c, iterations) || c.n != k || !solve_mis_chain(q->params, &c))
                continue;
            bool dup = false;
            for (int i = 0; i < n && !dup; ++i)
                dup = spc_snee_same_solution(&out[i], &c, q->scene->radius);
            if (!dup)
                out[n++] = c;
        }
    }
    return n;
}

/* Is c one of graze_long's chains for q (of c's length)? */
static bool graze_long_has(const spc_snee_query *q, const spc_specular_solver *solver, const spc_chain *c)
{
    if (!graze_long_on(q, c->n))
        return false;
    for (int i = 0; i < c->n; ++i)
        if (c->v[i].event != SPC_CHAIN_REFLECT)
            return false;
    spc_chain all[SPC_GRAZE_MAX_SEEDS];
    int it = 0;
    int n = graze_long(q, solver, c->n, all, SPC_GRAZE_MAX_SEEDS, &it);
    for (int i = 0; i < n; ++i)
        if (spc_snee_same_solution(&all[i], c, q->scene->radius))
            return true;
    return false;
}

/* psi of the chain c toward q's light point: 1 for a chain found exactly (solve_all's, or the
 * straight-line solution: straight_psi), else random_psi; past the budget long_psi for a longer chain on one
 * sphere (params.long_p), else 0 (specular NEE never makes it). *rand_s: for a chain that a
 * randomized attempt finds (solve_mis_chain), the probability of the query's pass that looks for it
 * (ball_long_psi, the ball pass's, past the budget, else 1); 0 for every other chain. *counted: c is
 * a randomized attempt's chain that specular NEE counts with inv_p_solve (neither solve_mis_chain's
 * nor an exact one). *long_pass: c is the long pass's (params.long_p: on one sphere, or a randomized
 * attempt's), which draws its own light point under params.light_x (spc_snee_sample_long_light). */
static double chain_psi(const spc_snee_query *q, const spc_chain *c, double *rand_s, bool *counted, bool *long_pass)
{
    const spc_snee_params *p = q->params;
    *rand_s = 0.0;
    *counted = false;
    *long_pass = false;
    if (c->n > q->max_chain) { /* longer than the budget: one of params.long_p's, or none */
        if (p->exact && spc_flat_chain_covers(c, p->reflect))
            return c->n <= flat_max(q) ? 1.0 : flat_psi(q, c->n); /* through flat faces */
        if (p->exact && c->n <= unfold_max(q) && spc_unfold_chain_covers(c, p->reflect))
            return 1.0; /* through a sphere and a flat mirror, at every call */
        if (p->exact && spc_sphere_chain_covers(c, p->reflect)) {
            /* enumerated on the sphere: by the long pass toward its own light point, or past its
             * top on a share of the calls toward the query's */
            *long_pass = c->n <= long_top(p);
            return sphere_psi(q, c->n);
        }
        if (p->exact && spc_cylinder_chain_covers(c))
            return cyl_psi(q, c); /* enumerated on the cylinder on a share of the calls */
        if (!random_long(p))
            return 0.0;
        spc_snee_query lq = *q;
        lq.min_chain = lq.max_chain = c->n;
        if (p->exact && spc_snee_exact_covers_all(&lq))
            return 0.0; /* the long pass makes no randomized attempt there (estimate), and c is not exact */
        if (long_solve_mis_chain(q, c)) { /* the ball pass's, or the rim's counted exactly (graze_long) */
            bool on_ball = solve_mis_chain(p, c);
            if (on_ball && long_on(q) && c->n <= q->long_max &&
                graze_long_has(q, spc_specular_solver_get(p->solver), c))
                return SPC_GRAZE_LONG_P;
            *rand_s = on_ball ? ball_long_psi(q, c->n) : cam_long_psi(q, c->n);
            return *rand_s * long_attempt_psi(q, c);
        }
        if (long_flat_left(q, c))
            return 0.0;
        *counted = true;
        *long_pass = true;
        spc_snee_params lp = long_params(p); /* the events as the long pass's attempts pick them */
        lq.params = &lp;
        return long_psi(q, c->n) * long_attempt_psi(&lq, c); /* a randomized attempt's */
    }
    if (p->exact && !exact_shape_covers(q, c) && spc_snee_exact_covers_all(q))
        return 0.0; /* the exact enumerations alone run there, and c is not theirs */
    const spc_specular_solver *solver = spc_specular_solver_get(p->solver);
    if (!solver || (random_psi(p) == 1.0 && !solve_mis_within(p, c)))
        return 1.0;
    if (exact_covers(q, solver, c))
        return 1.0;
    if (guide_on(p))
        return random_psi(p); /* straight_psi: no attempt to repeat */
    spc_chain straight;
    int it = 0;
    bool have_straight = straight_solve(q, solver, &straight, &it);
    if (have_straight && spc_snee_same_solution(&straight, c, q->scene->radius))
        return 1.0;
    if (solve_mis_within(p, c)) {
        if (fit_first_has(q, solver, have_straight ? &straight : NULL, c))
            return 1.0;
        *rand_s = 1.0;
    } else {
        *counted = true;
    }
    return attempt_psi(q, c);
}

/* Seed directions whose trial outcome a count keeps (solve_trial): the fitted sphere's solutions,
 * which the ball pass's trials draw nine times in ten, are at most SPC_FIT_MAX_DIRS per caster; a
 * cone seed is never drawn twice and only takes a slot. */
#define SPC_TRIAL_MEMO 16

/* One Bernoulli trial of a chain's count (solve_mis.h): an attempt of the query (its want and
 * events set to the chain's) that finds the same chain. Where the solver's answer is a function of
 * the seed direction (seed_decides, the events fixed), the outcome of a direction drawn before is
 * reused: the same outcome, iteration count and random stream as solving again, for one solve per
 * fitted seed instead of one per trial. */
typedef struct solve_trial {
    const spc_snee_query *q;
    const spc_specular_solver *solver;
    const spc_chain *target;
    spc_rng *rng;
    int iterations;
    spc_chain scratch;
    int nmemo;
    spc_vec3 memo_dir[SPC_TRIAL_MEMO];
    bool memo_same[SPC_TRIAL_MEMO];
    int memo_iterations[SPC_TRIAL_MEMO];
} solve_trial;

/* Does t reuse the outcome of a seed direction drawn before (the solver's answer a function of it)? */
static bool trial_memo_on(const solve_trial *t)
{
    const spc_snee_query *q = t->q;
    return t->solver->seed_decides && (q->events || !q->params->reflect || q->seed == SPC_SNEE_SEED_LIGHT);
}

static bool solve_trial_same(void *user)
{
    solve_trial *t = user;
    const spc_snee_query *q = t->q;
    if (!trial_memo_on(t))
        return t->solver->solve_one(q, t->rng, &t->scratch, &t->iterations) &&
               spc_snee_same_solution(t->target, &t->scratch, q->scene->radius);
    /* the seed as solve_one draws it, then solve_one from that seed (it draws nothing more) */
    spc_vec3 dir;
    if (!spc_snee_seed_direction(q, t->rng, &dir))
        return false;
    for (int i = 0; i < t->nmemo; ++i)
        if (memcmp(&t->memo_dir[i], &dir, sizeof dir) == 0) {
            t->iterations += t->memo_iterations[i];
            return t->memo_same[i];
        }
    spc_snee_query sq = *q;
    sq.seed_dir = &dir;
    int it = 0;
    bool same = t->solver->solve_one(&sq, t->rng, &t->scratch, &it) &&
                spc_snee_same_solution(t->target, &t->scratch, q->scene->radius);
    t->iterations += it;
    if (t->nmemo < SPC_TRIAL_MEMO) {
        t->memo_dir[t->nmemo] = dir;
        t->memo_same[t->nmemo] = same;
        t->memo_iterations[t->nmemo++] = it;
    }
    return same;
}

/* tq: q counting trials of chain c (its signature in *want, with reflect its events), and the
 * probability of those events (what the count is divided by); 0 if they cannot happen. */
static double trial_query(const spc_snee_query *q, const spc_chain *c, spc_chain_sig *want, spc_snee_query *tq)
{
    const spc_snee_params *p = q->params;
    spc_chain_signature(c, want);
    *tq = *q;
    tq->want = want;
    if (!p->reflect)
        return 1.0;
    tq->events = want->event;
    return spc_snee_attempt_events_prob(q, want);
}

static int trial_cap(const spc_snee_params *p) { return p->max_trials > 0 ? p->max_trials : SPC_SNEE_MAX_TRIALS; }

/* Does the chain pass through more than one shape (a path that no exact enumeration covers, from one
 * caster to another)? */
static bool chain_crosses_shapes(const spc_chain *c)
{
    for (int i = 1; i < c->n; ++i)
        if (c->v[i].h.shape_index != c->v[0].h.shape_index)
            return true;
    return false;
}

/* The largest count at which specular NEE keeps a randomized attempt's chain on one shape at a surface
 * receiver, in units of the count at which its weighted sample equals the sampling side's unweighted
 * one (give_up_cap). 1: specular NEE's sample never exceeds f / b, the most a sampled path adds. On
 * scenes/caustic_sdf_torus.xml a 2-refraction chain with a ~ 1.9 b, found about once in 59 attempts,
 * was counted 92 times (59 attempts over its events' probability 0.64) at weight 0.78: 3.9 f / b, one
 * pixel's 99% of a seed's error (bench/RESULTS.md, part trace19). */
#define SPC_SNEE_GIVE_UP_SCALE 1.0

/* The count at which specular NEE gives up a randomized attempt's chain (inv_p_solve), leaving that
 * path to the sampling side, rather than go on by Russian roulette past the cap; 0 where it never
 * does. With MIS (the
 * sampling side's density b of the chain positive), a stand-in psi below 1,
 * attempts seeded at random and no guided directions (whose third strategy would need the share
 * too). A count cut there carries no tail: at most cap / a. With N the count (geometric, success
 * probability p per attempt) and C the cap, specular NEE then takes p E[N 1{N <= C}] = 1 - g(p) of
 * its MIS share, g(p) = (1 - p)^C (1 + C p), which is exactly the probability of at most one success
 * in C + 1 attempts; the sampling side adds the share times a 0/1 estimate of g(p) from C + 1 attempts
 * of its own (cap_share_left), stopped at the second success. Only where a <= C b (a, b: specular NEE's
 * and the sampling side's densities of the path): the share the sampling side gains then adds at
 * most F / b <= C F / a to one of its samples, no more than specular NEE's count cut at C carries;
 * where b is far smaller the count goes on by roulette. At medium receivers, and at surfaces for
 * chains that cross from one shape to another, which no exact enumeration covers: where it was
 * measured to pay. On the demo a chain through the glass ball and off the mirror sphere counted 454
 * times held a seed's error; given up, the mean relMSE over 32 seeds fell 3x (bench/RESULTS.md, part
 * sphere12). Weighed instead by the real solve probability (solve_mis.h), as the tessellated balls'
 * chains are, the long pass's chains off a mirror ball and through glass lost: BSDF sampling's mean
 * weight on them rose 1.2-21x (the attempts find them with p A of the order of b), and on two fresh
 * scenes of a mirror ball beside a glass ball the mean relMSE at equal CPU rose 3.1x on one and the
 * median 5.8x on the other (bench/RESULTS.md, "The real solve probability for the light off a mirror
 * through glass"). Chains on one shape at the cap
 * went on by roulette: under the SDF torus the give-up at the cap handed long BSDF-sampled paths
 * through it weight 1 (test_sdf_chain_mis) and its 8 seeds read 1.4x the mean relMSE. So a chain on
 * one shape within the budget (psi, its stand-in, positive; 0 for the long pass's) is given up at a
 * count of its own, where the sampling side's share is worth
 * having: at the count C at which specular NEE's weighted sample, C / P(events) psi f w_a / a (w_a =
 * a^2 / (a^2 + b^2), the power heuristic), equals f / b, the largest the sampling side adds with the
 * share, times SPC_SNEE_GIVE_UP_SCALE, where C is below the cap (a and b within a factor of a few
 * of each other; a = b: C = 2 P(events) / psi); at the cap where C is not and b >= a (specular NEE's
 * sample at the cap is then below f / b too). Where b is far below a, the sampling side's paths are
 * rare and large, and the count goes on by roulette. A chain from a medium point deep in a
 * glass ball has p ~ 1e-4 (its attempts end in total internal reflection): counted past the cap its
 * 1/p ~ 1e4 made one pixel hold 99% of a seed's error on scenes/medium_glass.xml (bench/RESULTS.md,
 * part medtail10). The same function of the query on both sides. */
static int give_up_cap(const spc_snee_query *q, const spc_chain *c, double a, double b, double psi)
{
    const spc_snee_params *p = q->params;
    spc_receiver own;
    int cap = trial_cap(p);
    if (!(p->mis && !p->biased && !guide_on(p) && random_psi(p) < 1.0 && q->seed != SPC_SNEE_SEED_LIGHT && b > 0.0 &&
          a > 0.0))
        return 0;
    spc_receiver_kind kind = query_receiver(q, &own)->kind;
    if (kind == SPC_RECEIVER_MEDIUM || (kind == SPC_RECEIVER_SURFACE && chain_crosses_shapes(c)))
        return a <= cap * b ? cap : 0;
    if (kind != SPC_RECEIVER_SURFACE || !(psi > 0.0))
        return 0;
    double p_ev = 1.0;
    if (p->reflect) {
        spc_chain_sig sig;
        spc_chain_signature(c, &sig);
        p_ev = spc_snee_attempt_events_prob(q, &sig);
    }
    double C = SPC_SNEE_GIVE_UP_SCALE * p_ev * (a * a + b * b) / (psi * a * b);
    return C < cap ? (int)ceil(C) : b >= a ? cap : 0;
}

/* The count of t's trials until its chain is found again, 0 where the first cap attempts all fail
 * (give_up_cap). *attempts gets the attempts run. */
static double count_within_cap(solve_trial *t, int cap, int *attempts)
{
    for (int n = 1; n <= cap; ++n)
        if (solve_trial_same(t)) {
            *attempts = n;
            return n;
        }
    *attempts = cap;
    return 0.0;
}

/* The sampling side's estimate of g(p) (give_up_cap): 1 if at most one of cap + 1 trials of t finds
 * its chain, else 0; stops at the second success. */
static double cap_share_left(solve_trial *t, int cap)
{
    int found = 0;
    for (int n = 0; n <= cap; ++n)
        if (solve_trial_same(t) && ++found == 2)
            return 0.0;
    return 1.0;
}

/* A generator for the BSDF side's trials (the weight functions get none): seeded by a hash of the
 * path's coordinates (the receiver, the first direction, the light point), continuous random
 * variables of the sample, so the stream is a fresh one per sample and the render deterministic. */
static void path_rng(spc_rng *rng, spc_vec3 a, spc_vec3 b, spc_vec3 c)
{
    const double v[9] = {a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z};
    uint64_t h = 0x736e65656d6973ULL;
    for (int i = 0; i < 9; ++i) {
        uint64_t bits;
        memcpy(&bits, &v[i], sizeof bits);
        h = spc_hash_combine(h, bits);
    }
    spc_rng_seed(rng, h, spc_hash64(h));
}

/* The three strategies' densities (the light's area measure) of a covered path that left the
 * receiver r along d0 and reached the area light at the hit `light` through k chain vertices with
 * these events: *a specular NEE's light sample (psi p_y), *b the sampling side's (the receiver's
 * own density, spc_receiver_pdf, times the chain's geometry term and its events' probability),
 * *c guided directions' (params.guide; cones at x toward the light, cs if given, else built here).
 * The chain is retraced for its geometry term. False if the retrace does not reproduce the path.
 * *alt_f (if not NULL): the factor alt_factor put into *b (1 without another strategy).
 * p->mis is set and e is an area light. */
static bool covered_terms(const spc_scene *sc, const spc_snee_params *p, const spc_receiver *r, spc_vec3 d0,
                          int max_chain, int k, const unsigned char *events, const spc_hit *light,
                          const spc_snee_cones *cs, double *a, double *b, double *c, double *w_solve, double *alt_f)
{
    const spc_emitter *e = light->emitter;
    const spc_hit *x = spc_receiver_origin(r);
    const spc_camera_state *cam = r->kind == SPC_RECEIVER_CAMERA ? r->cam : NULL;
    *a = *b = *c = 0.0;
    if (w_solve)
        *w_solve = -1.0;
    if (alt_f)
        *alt_f = 1.0;
    double p_y = r->kind == SPC_RECEIVER_SURFACE ? spc_snee_light_pdf_at(sc, p, e, light->p, light->ng, x->p)
                                                 : spc_snee_light_pdf(sc, p->any_surface, e, light->p, light->ng);
    /* the long pass's own light point's density under params.light_x (spc_snee_sample_long_light):
     * the cap's */
    bool own_y = r->kind == SPC_RECEIVER_SURFACE && light_x_share(p, e->shape, x->p) > 0.0;
    double p_long = own_y ? spc_snee_light_pdf(sc, p->any_surface, e, light->p, light->ng) : p_y;
    bool guided = guide_on(p) && r->kind == SPC_RECEIVER_SURFACE;
    if (!(p_y > 0.0) && !(p_long > 0.0) && !guided) {
        *b = 1.0; /* specular NEE never draws this light point: BSDF sampling's alone */
        return true;
    }
    spc_frame fr = spc_frame_from_n(d0);
    spc_chain_opts o = spc_chain_opts_default(k);
    o.any_surface = p->any_surface;
    o.events = events;
    spc_chain ch;
    /* the retrace's light point must be the path's: within rounding for a path sampled from x (the
     * retrace repeats its arithmetic); a path traced from the light side (bdpt's light tracing,
     * params.alt_ratio) lands up to about 1e-3 of the light's size away after a focusing chain,
     * its directions recomputed from the vertices' positions */
    double tol = 1e-6 * (sc->radius + spc_max_abs(light->p));
    if ((p->alt_ratio || p->alt_chain_ratio) && e->shape)
        tol = spc_max(tol, SPC_SNEE_RETRACE_LIGHT_TOL * sqrt(e->shape->area));
    if (spc_chain_trace(sc, x, &fr, 0.0, 0.0, &o, &ch) != SPC_CHAIN_END_SURFACE || ch.n != k || !ch.has_end_hit ||
        ch.end_hit.emitter != e || spc_distance(ch.end_hit.p, light->p) > tol)
        return false;
    double G = spc_chain_geometry(&ch, light->p, light->ng);
    if (!(G > 0.0) || !isfinite(G))
        return false;
    /* a surface's density at the sampled direction, the others' at the retraced one */
    double pdf = spc_receiver_pdf(r, r->kind == SPC_RECEIVER_SURFACE ? d0 : ch.d0) *
                 (r->kind == SPC_RECEIVER_SURFACE ? bsdf_count(p) : 1.0);
    spc_snee_query q;
    spc_snee_query_init(&q, sc, p, x, r->wo, max_chain);
    q.receiver = r;
    q.cam = cam; /* chain_events_sample_prob reads it as the query from the camera does */
    double P_ev = chain_events_sample_prob(&q, &ch);
    double f_alt = r->kind == SPC_RECEIVER_SURFACE ? alt_factor(p, x, r->wo, &ch, e, light->p, light->ng) : 1.0;
    if (alt_f)
        *alt_f = f_alt;
    *b = pdf * G * P_ev * f_alt;
    spc_snee_cones own;
    if (guided) {
        if (!cs || cs->e != e || cs->budget != max_chain) {
            cones_build(&q, e, max_chain, &own);
            cs = &own;
        }
        *c = cones_pdf(cs, ch.d0, k) * G * P_ev;
    }
    if (p_y > 0.0 || p_long > 0.0) {
        /* psi as specular NEE has it for this chain toward this light point */
        q.y = light->p;
        q.ny = light->ng;
        q.light_size = sqrt(e->shape->area);
        q.p_y = p_y;
        q.cam_scale = r->cam_scale;
        q.long_max = SPC_CHAIN_MAX_VERTICES; /* the track went no further than the caller's depth */
        spc_fit_roots fit; /* the fitted sphere's solutions toward this light point (fit_seeds.h) */
        fit.nshapes = 0;
        q.fit = &fit;
        double ps = cam ? p->camera_p : guided && cs && cs->n > 0 ? p->snee_p : spc_snee_query_prob(p) * light_count(p);
        double rs;
        bool counted, long_pass;
        double psi = chain_psi(&q, &ch, &rs, &counted, &long_pass);
        if (long_pass) /* the long pass's chain: drawn toward its own light point */
            p_y = q.p_y = p_long;
        *a = psi * p_y * ps;
        const spc_specular_solver *solver = spc_specular_solver_get(p->solver);
        /* the cap as specular NEE's query has it: its stand-in for a chain within the budget, the
         * long pass's (long_give_up_psi, with its length and events) for a longer one */
        spc_snee_params lp = long_params(p);
        spc_snee_query gq = q;
        if (ch.n > max_chain) {
            gq.min_chain = gq.max_chain = ch.n;
            gq.params = &lp;
        }
        int cap = counted ? give_up_cap(&gq, &ch, *a, *b, ch.n > max_chain ? long_give_up_psi(&gq, &ch) : psi) : 0;
        if (cap > 0 && w_solve && solver && solver->solve_one) {
            /* specular NEE gives the chain up where its count reaches the cap: its MIS share times the
             * probability of that, sampled by attempts toward this light point like its own */
            spc_snee_query lq = q;
            if (ch.n > max_chain) { /* the long pass's chain */
                lq.params = &lp;
                lq.min_chain = lq.max_chain = ch.n;
            }
            spc_chain_sig want;
            spc_snee_query tq;
            double p_ev = trial_query(&lq, &ch, &want, &tq);
            double w_nee = mis3(*a, *b, *c);
            double left = 1.0; /* events the attempts never pick: specular NEE never counts it */
            if (p_ev > 0.0) {
                spc_rng rng;
                path_rng(&rng, x->p, d0, light->p);
                solve_trial t = {.q = &tq, .solver = solver, .target = &ch, .rng = &rng};
                left = cap_share_left(&t, cap);
            }
            *w_solve = mis3(*b, *a, *c) + w_nee * left;
        }
        if (rs > 0.0 && w_solve && solver && solver->solve_one) {
            /* a randomized attempt's chain: the weight sampled with the real solve probability, by
             * the attempts specular NEE would make toward this light point (its long pass's length) */
            spc_snee_query lq = q;
            spc_snee_params bp = ball_params(p);
            if (ch.n > max_chain) { /* the ball pass's chain */
                lq.min_chain = lq.max_chain = ch.n;
                lq.params = &bp;
            }
            spc_chain_sig want;
            spc_snee_query tq;
            double p_ev = trial_query(&lq, &ch, &want, &tq);
            spc_rng rng;
            path_rng(&rng, x->p, d0, light->p);
            solve_trial t = {.q = &tq, .solver = solver, .target = &ch, .rng = &rng};
            *w_solve = spc_solve_mis_sampled(p_y * ps * rs * p_ev, *b, solve_trial_same, &t, &rng, trial_cap(p), NULL);
        }
    }
    return true;
}

/* The weight of a covered path sampled by the receiver r itself, as covered_terms; with another
 * strategy (params.alt_ratio, alt_chain_ratio) that weight is the two strategies' share together,
 * split by their densities: *w_alt (if not NULL) gets the other strategy's part, and the receiver's
 * own part is returned where w_alt is not NULL. */
static double covered_weight(const spc_scene *sc, const spc_snee_params *p, const spc_receiver *r, spc_vec3 d0,
                             int max_chain, int k, const unsigned char *events, const spc_hit *light, double *w_alt)
{
    double a, b, c, ws, f;
    if (w_alt)
        *w_alt = 0.0;
    if (!covered_terms(sc, p, r, d0, max_chain, k, events, light, NULL, &a, &b, &c, &ws, &f))
        return 0.0;
    double w = ws >= 0.0 ? ws : mis3(b, a, c);
    if (!w_alt)
        return w;
    /* b = b_own f with f^2 = 1 + ratio^2: the receiver's own share 1 / f^2 of w, the other's the rest */
    double own = w / (f * f);
    *w_alt = w - own;
    return own;
}

double spc_snee_receiver_weight(const spc_scene *sc, const spc_snee_params *p, const spc_receiver *r, spc_vec3 d0,
                                int max_chain, int k, const unsigned char *events, const spc_hit *light)
{
    const spc_emitter *e = light->emitter;
    if (!p->mis || !e || k < 1 || k > SPC_CHAIN_MAX_VERTICES)
        return 0.0;
    return covered_weight(sc, p, r, d0, max_chain, k, events, light, NULL);
}

double spc_snee_receiver_weights(const spc_scene *sc, const spc_snee_params *p, const spc_receiver *r, spc_vec3 d0,
                                 int max_chain, int k, const unsigned char *events, const spc_hit *light, double *w_alt)
{
    const spc_emitter *e = light->emitter;
    *w_alt = 0.0;
    if (!p->mis || !e || k < 1 || k > SPC_CHAIN_MAX_VERTICES)
        return 0.0;
    return covered_weight(sc, p, r, d0, max_chain, k, events, light, w_alt);
}

double spc_snee_mis_bsdf_weight(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                                spc_vec3 d0, int max_chain, int k, const unsigned char *events, const spc_hit *light)
{
    spc_receiver r;
    spc_receiver_surface(&r, x, wo);
    r.guide = p->cguide_at;
    return spc_snee_receiver_weight(sc, p, &r, d0, max_chain, k, events, light);
}

int spc_snee_budget(const spc_hit *x, int max_chain, bool any_surface)
{
    if (max_chain < 1 || !x->bsdf || !spc_bsdf_has_smooth(x->bsdf))
        return 0;
    if (!any_surface && !(x->shape && (x->shape->caustic_flags & SPC_CAUSTIC_RECEIVER)))
        return 0;
    return max_chain < SPC_CHAIN_MAX_VERTICES ? max_chain : SPC_CHAIN_MAX_VERTICES;
}

/* Where an estimate's contributions go: summed (a surface point), or one per chain (the camera:
 * each chain lands on its own pixel). */
typedef struct snee_sink {
    spc_rgb total;
    spc_snee_splat *splats;
    int nsplats, max_splats;
} snee_sink;

static void emit(const spc_snee_query *q, snee_sink *sk, const spc_chain *c, spc_rgb v)
{
    if (!sk->splats) {
        sk->total = spc_rgb_add(sk->total, v);
        return;
    }
    spc_camera_direct cd;
    if (sk->nsplats < sk->max_splats && spc_camera_sample_direct(q->cam, c->v[0].h.p, &cd)) {
        spc_snee_splat *o = &sk->splats[sk->nsplats++];
        o->fx = cd.fx;
        o->fy = cd.fy;
        o->value = v;
    }
}

/* Chains found exactly (every one of their kind), each added with 1 / p_y. */
static void emit_exact(const spc_snee_query *q, const spc_emitter *e, spc_vec2 uv, double p_y, const spc_chain *all,
                       int nall, int iterations, spc_snee_stats *st, snee_sink *sk)
{
    if (st) {
        st->iterations += (uint64_t)iterations;
        st->solved += nall > 0 ? 1u : 0u;
    }
    for (int i = 0; i < nall; ++i) {
        spc_rgb v = spc_snee_chain_value(q, e, uv, &all[i]);
        if (spc_rgb_is_black(v))
            continue;
        emit(q, sk, &all[i], spc_rgb_scale(v, 1.0 / p_y));
        if (st)
            st->contributions++;
    }
}

typedef struct plane_emit {
    const spc_snee_query *q;
    const spc_emitter *e;
    spc_vec2 uv;
    double p_y;
    spc_snee_stats *st;
    snee_sink *sk;
} plane_emit;

static void plane_emit_one(void *user, const spc_chain *c)
{
    plane_emit *pe = user;
    spc_rgb v = spc_snee_chain_value(pe->q, pe->e, pe->uv, c);
    if (spc_rgb_is_black(v))
        return;
    emit(pe->q, pe->sk, c, spc_rgb_scale(v, 1.0 / pe->p_y));
    if (pe->st)
        pe->st->contributions++;
}

/* Every chain through one normal-mapped plane (plane_chains.h), each added with 1 / p_y as it is
 * found. */
static void emit_plane_chains(const spc_snee_query *q, const spc_emitter *e, spc_vec2 uv, double p_y,
                              spc_snee_stats *st, snee_sink *sk)
{
    plane_emit pe = {q, e, uv, p_y, st, sk};
    int it = 0;
    int n = spc_plane_chains_each(q, q->params->reflect, plane_emit_one, &pe, &it);
    if (st) {
        st->iterations += (uint64_t)it;
        st->solved += n > 0 ? 1u : 0u;
    }
}

/* <1/p_solve> of the solution sol of a randomized attempt for q: attempts until the same solution
 * is found again (with reflect, following its events, whose probability is known); with give_up
 * positive (give_up_cap) 0 where the count reaches give_up, else past the cap by Russian roulette. */
static double inv_p_solve(const spc_snee_query *q, const spc_specular_solver *solver, const spc_chain *sol,
                          int give_up, spc_rng *rng, spc_snee_stats *st)
{
    const spc_snee_params *p = q->params;
    if (q->seed == SPC_SNEE_SEED_LIGHT)
        return 1.0; /* deterministic */
    spc_chain_sig want;
    spc_chain_signature(sol, &want);
    spc_snee_query tq = *q;
    tq.want = &want;
    double p_events = 1.0;
    if (p->reflect) {
        tq.events = want.event;
        p_events = spc_snee_attempt_events_prob(q, &want);
    }
    bool capped;
    int iterations = 0, n = 0;
    double N;
    if (give_up > 0) {
        solve_trial t = {.q = &tq, .solver = solver, .target = sol, .rng = rng};
        N = count_within_cap(&t, give_up, &n);
        capped = N == 0.0;
        iterations = t.iterations;
    } else {
        N = spc_snee_count_same(&tq, solver, NULL, rng, sol, trial_cap(p), &n, &capped, &iterations);
    }
    if (st) {
        st->trials += (uint64_t)n;
        st->iterations += (uint64_t)iterations;
        st->trial_iterations += (uint64_t)iterations;
        st->capped += capped ? 1u : 0u;
    }
    return p_events > 0.0 ? N / p_events : 0.0;
}

/* One randomized attempt of q (solver->solve_one, its iterations added to *iterations). Where the
 * solver's answer is a function of its seed direction and events (seed_decides), the direction is
 * drawn here, as solve_one draws it first, and handed to it: the same random stream and answer, and
 * *seeded tells the direction (a count of the chain found starts from it: attempt_memo). */
static bool attempt(const spc_snee_query *q, const spc_specular_solver *solver, spc_rng *rng, spc_chain *out,
                    int *iterations, spc_vec3 *seed, bool *seeded)
{
    *seeded = false;
    if (!solver->seed_decides || q->seed_dir)
        return solver->solve_one(q, rng, out, iterations);
    if (!spc_snee_seed_direction(q, rng, seed))
        return false; /* solve_one stops there too, its iterations untouched */
    spc_snee_query aq = *q;
    aq.seed_dir = seed;
    *seeded = true;
    return solver->solve_one(&aq, rng, out, iterations);
}

/* The attempt that found t's chain from the seed direction seed in `iterations` iterations
 * (attempt), kept as t's first memo: a trial drawing that direction finds the chain again, with as
 * many iterations (seed_decides), without solving. */
static void attempt_memo(solve_trial *t, const spc_vec3 *seed, int iterations)
{
    if (!seed || !trial_memo_on(t) || t->nmemo >= SPC_TRIAL_MEMO)
        return;
    t->memo_dir[t->nmemo] = *seed;
    t->memo_same[t->nmemo] = true;
    t->memo_iterations[t->nmemo++] = iterations;
}

/* The chain sol of a randomized attempt toward q's light point (its density p_y, the query's and the
 * long pass's probabilities included), weighed by the balance heuristic with its real solve
 * probability: its value times spc_solve_mis_light's estimate of 1 / (p A + b) from its trials. seed
 * (or NULL): the direction the attempt that found sol started from (attempt), in seed_it iterations. */
static void emit_solve_mis(const spc_snee_query *q, const spc_specular_solver *solver, const spc_emitter *e,
                           spc_vec2 uv, double p_y, const spc_chain *sol, const spc_vec3 *seed, int seed_it,
                           spc_rng *rng, spc_snee_stats *st, snee_sink *sk)
{
    double b, pc;
    spc_rgb v = chain_terms(q, e, uv, sol, &b, &pc);
    if (spc_rgb_is_black(v))
        return;
    spc_chain_sig want;
    spc_snee_query tq;
    double p_ev = trial_query(q, sol, &want, &tq);
    if (!(p_ev > 0.0))
        return;
    solve_trial t = {.q = &tq, .solver = solver, .target = sol, .rng = rng};
    attempt_memo(&t, seed, seed_it);
    int n = 0;
    bool capped = false;
    double z = spc_solve_mis_light(p_y * p_ev, b, solve_trial_same, &t, rng, trial_cap(q->params), &n, &capped);
    if (st) {
        st->trials += (uint64_t)n;
        st->iterations += (uint64_t)t.iterations;
        st->trial_iterations += (uint64_t)t.iterations;
        st->capped += capped ? 1u : 0u;
        st->contributions++;
    }
    emit(q, sk, sol, spc_rgb_scale(v, z));
}

/* params.long_p's pass for the angular solver: one randomized attempt for a chain of exactly
 * lq->max_chain vertices (not on one sphere when params.exact enumerates those), counted with its
 * <1/p_solve> over p_y (the light point's density times psi). */
static void random_long_estimate(const spc_snee_query *lq, const spc_specular_solver *solver, const spc_emitter *e,
                                 spc_vec2 uv, double p_y, bool ball, spc_rng *rng, spc_snee_stats *st, snee_sink *sk)
{
    spc_chain sol;
    spc_vec3 seed;
    bool seeded;
    int it = 0;
    spc_snee_query aq = *lq;
    aq.keep_n = lq->max_chain; /* a chain of another length is dropped below */
    bool ok = attempt(&aq, solver, rng, &sol, &it, &seed, &seeded);
    if (st)
        st->iterations += (uint64_t)it;
    if (!ok || sol.n != lq->max_chain || exact_covers(lq, solver, &sol) || (!ball && long_flat_left(lq, &sol)))
        return;
    if (long_solve_mis_chain(lq, &sol) != ball)
        return; /* the other pass's chain */
    if (ball && graze_long_has(lq, solver, &sol))
        return; /* counted exactly (graze_long) */
    if (ball) {
        if (st)
            st->solved++;
        emit_solve_mis(lq, solver, e, uv, p_y, &sol, seeded ? &seed : NULL, it, rng, st, sk);
        return;
    }
    spc_snee_query vq = *lq;
    vq.psi = lq->psi * long_attempt_psi(lq, &sol);
    double a, b;
    spc_rgb v = counted_chain_value(&vq, e, uv, &sol, &a, &b);
    if (spc_rgb_is_black(v))
        return;
    double inv_p = inv_p_solve(lq, solver, &sol, give_up_cap(lq, &sol, a, b, long_give_up_psi(lq, &sol)), rng, st);
    if (st) {
        st->solved++;
        st->contributions++;
    }
    emit(lq, sk, &sol, spc_rgb_scale(v, inv_p / p_y));
}

/* The estimate for the query's light point (drawn: e, uv, p_y), unbiased unless params.biased. */
static void estimate(spc_snee_query *q, const spc_specular_solver *solver, const spc_emitter *e, spc_vec2 uv,
                     double p_y, spc_rng *rng, spc_snee_stats *st, snee_sink *sk)
{
    const spc_snee_params *p = q->params;
    const spc_scene *sc = q->scene;
    /* every chain on one sphere or one mirror cylinder, exactly (params.exact) */
    if (p->exact) {
        spc_chain all[SPC_SNEE_MAX_ALL];
        int it = 0;
        int nall = spc_sphere_chains_all(q, all, SPC_SNEE_MAX_ALL, &it);
        nall += spc_cylinder_chains_all(q, all + nall, SPC_SNEE_MAX_ALL - nall, &it);
        spc_snee_query fq = *q; /* the flat chains may run past the budget */
        fq.max_chain = flat_max(q);
        /* the longer chains through flat faces, each length on its own share of the calls
         * (flat_psi), drawn first so that one walk of the faces finds them with the shorter ones
         * (spc_flat_chains_all_later); emitted after those, as their own walks were */
        bool flat = fq.max_chain < SPC_FLAT_MAX_VERTICES && has_flat_caster(q);
        unsigned longer = 0;
        double psi_k[SPC_FLAT_MAX_VERTICES + 1] = {0.0};
        for (int k = fq.max_chain + 1; flat && k <= SPC_FLAT_MAX_VERTICES; ++k) {
            psi_k[k] = flat_psi(q, k);
            if (psi_k[k] > 0.0 && (psi_k[k] >= 1.0 || spc_rng_next(rng) < psi_k[k]))
                longer |= 1u << k;
        }
        spc_flat_later later;
        nall += spc_flat_chains_all_later(&fq, longer, &later, all + nall, SPC_SNEE_MAX_ALL - nall, &it);
        emit_exact(&fq, e, uv, p_y, all, nall, it, st, sk);
        if (!q->cam)
            emit_plane_chains(q, e, uv, p_y, st, sk);
        /* through one sphere and one flat mirror, up to unfold_max */
        if (unfold_max(q) >= 2 && has_unfold_casters(q)) {
            spc_snee_query uq = *q;
            uq.max_chain = unfold_max(q);
            it = 0;
            nall = spc_unfold_chains_all(&uq, all, SPC_SNEE_MAX_ALL, &it);
            emit_exact(&uq, e, uv, p_y, all, nall, it, st, sk);
        }
        for (int k = fq.max_chain + 1; k <= SPC_FLAT_MAX_VERTICES; ++k) {
            if (!(longer >> k & 1u))
                continue;
            spc_snee_query lq = *q;
            lq.min_chain = lq.max_chain = k;
            lq.psi = psi_k[k];
            it = 0;
            nall = spc_flat_chains_later(&lq, &later, k, all, SPC_SNEE_MAX_ALL, &it);
            emit_exact(&lq, e, uv, p_y * psi_k[k], all, nall, it, st, sk);
        }
    }
    /* on a share of the calls the longer chains on a mirror cylinder, every length at once (cyl_psi) */
    if (p->exact && long_on(q) && cyl_long_max(q) > q->max_chain && has_cylinder_caster(q) &&
        spc_rng_next(rng) < SPC_CYLINDER_LONG_P) {
        spc_chain all[SPC_SNEE_MAX_ALL];
        spc_snee_query lq = *q;
        lq.min_chain = q->max_chain + 1;
        lq.max_chain = cyl_long_max(q);
        lq.psi = SPC_CYLINDER_LONG_P;
        int it = 0;
        int nall = spc_cylinder_chains_all(&lq, all, SPC_SNEE_MAX_ALL, &it);
        emit_exact(&lq, e, uv, p_y * SPC_CYLINDER_LONG_P, all, nall, it, st, sk);
    }
    /* with probability long_p the longer chains of one length too, each counted with 1 / psi: on a
     * sphere all of them (on the mirror ring the cylinder's longer chains cost a quarter of the
     * samples and gained nothing: bench/RESULTS.md, "how far specular NEE can go"), elsewhere one
     * randomized attempt's */
    double u = long_on(q) ? spc_rng_next(rng) : 1.0;
    /* on a share of the calls the chains on one sphere past the long pass's top, every length at
     * once (sphere_psi): where u > 1 - sphere_long_p, the top of the same draw, so that the stream
     * of every other pass stays as it is without the option */
    if (1.0 - u < p->sphere_long_p && sphere_long_max(q) > 0 && has_caster(q, spc_sphere_chain_shape)) {
        spc_chain all[SPC_SNEE_MAX_ALL];
        spc_snee_query lq = *q;
        lq.min_chain = long_top(p) + 1;
        lq.max_chain = sphere_long_max(q);
        lq.psi = p->sphere_long_p;
        int it = 0;
        int nall = spc_sphere_chains_all(&lq, all, SPC_SNEE_MAX_ALL, &it);
        emit_exact(&lq, e, uv, p_y * p->sphere_long_p, all, nall, it, st, sk);
    }
    if (u < p->long_p) {
        int k = q->max_chain + 1 + (int)(u / p->long_p * (long_top(p) - q->max_chain));
        double psi = long_psi(q, k);
        spc_snee_query lq = *q;
        spc_fit_roots lfit;
        spc_vec2 luv = uv;
        double lp_y = p_y; /* the pass's light point: the query's, or its own (spc_snee_sample_long_light) */
        if (psi > 0.0 && spc_snee_sample_long_light(q, e, rng, &lq, &lfit, &luv, &lp_y)) {
            lq.min_chain = lq.max_chain = k;
            lq.psi = psi;
            if (p->exact) {
                spc_chain all[SPC_SNEE_MAX_ALL];
                int it = 0;
                int nall = spc_sphere_chains_all(&lq, all, SPC_SNEE_MAX_ALL, &it);
                emit_exact(&lq, e, luv, lp_y * psi, all, nall, it, st, sk);
            }
            if (random_long(p) && solver->solve_one && !(p->exact && spc_snee_exact_covers_all(&lq))) {
                spc_snee_params lp = long_params(p);
                lq.params = &lp;
                lq.psi = psi; /* MIS: times attempt_psi, as any randomized attempt's chain */
                random_long_estimate(&lq, solver, e, luv, lp_y * psi, false, rng, st, sk);
            }
        }
    }
    /* the ball pass: the longer chains on a tessellated ball (ball_long_psi) */
    double ub = long_on(q) && solve_mis_on(p) && random_long(p) && solver->solve_one && has_ball_caster(q)
                    ? spc_rng_next(rng)
                    : 1.0;
    if (ub < SPC_BALL_LONG_P) {
        int k = q->max_chain + 1 + (int)(ub / SPC_BALL_LONG_P * (SPC_SNEE_LONG_MAX - q->max_chain));
        double psi = ball_long_psi(q, k);
        if (psi > 0.0) {
            spc_snee_params bp = ball_params(p);
            spc_snee_query lq = *q;
            lq.params = &bp;
            lq.min_chain = lq.max_chain = k;
            lq.psi = psi;
            if (!(p->exact && spc_snee_exact_covers_all(&lq)))
                random_long_estimate(&lq, solver, e, uv, p_y * psi, true, rng, st, sk);
        }
    }
    /* from the camera, the longer chains on a glass SDF (cam_long_psi), weighed as the ball pass's */
    double uc = cam_long_on(q) && solver->solve_one ? spc_rng_next(rng) : 1.0;
    if (uc < p->cam_long_p) {
        int k = q->max_chain + 1 + (int)(uc / p->cam_long_p * (SPC_SNEE_CAM_LONG_MAX - q->max_chain));
        if (k > SPC_SNEE_CAM_LONG_MAX)
            k = SPC_SNEE_CAM_LONG_MAX;
        double psi = cam_long_psi(q, k);
        if (psi > 0.0) {
            spc_snee_params bp = ball_params(p);
            spc_snee_query lq = *q;
            lq.params = &bp;
            lq.min_chain = lq.max_chain = k;
            lq.psi = psi;
            random_long_estimate(&lq, solver, e, uv, p_y * psi, true, rng, st, sk);
        }
    }
    /* the rim's chains of reflections past the budget, counted exactly on a share of the calls
     * (graze_long, SPC_GRAZE_LONG_P) */
    bool graze = long_on(q) && q->long_max > q->max_chain && q->max_chain < SPC_GRAZE_LONG_MAX &&
                 graze_long_on(q, q->max_chain + 1 > 3 ? q->max_chain + 1 : 3) && spc_rng_next(rng) < SPC_GRAZE_LONG_P;
    for (int k = q->max_chain + 1; graze && k <= q->long_max && k <= SPC_GRAZE_LONG_MAX; ++k) {
        spc_snee_query lq = *q;
        lq.min_chain = lq.max_chain = k;
        if (!graze_long_on(&lq, k) || (p->exact && spc_snee_exact_covers_all(&lq)))
            continue;
        spc_chain gl[SPC_GRAZE_MAX_SEEDS];
        int it = 0;
        int ngl = graze_long(&lq, solver, k, gl, SPC_GRAZE_MAX_SEEDS, &it);
        if (st)
            st->iterations += (uint64_t)it;
        for (int i = 0; i < ngl; ++i) {
            lq.psi = SPC_GRAZE_LONG_P;
            spc_rgb vg = spc_snee_chain_value(&lq, e, uv, &gl[i]);
            lq.psi = 0.0;
            if (!spc_rgb_is_black(vg)) {
                emit(&lq, sk, &gl[i], spc_rgb_scale(vg, 1.0 / (p_y * SPC_GRAZE_LONG_P)));
                if (st)
                    st->contributions++;
            }
        }
    }
    if (p->exact && spc_snee_exact_covers_all(q))
        return;
    /* a solver that enumerates every solution: the exact sum, no probability to estimate */
    if (solver->solve_all) {
        spc_chain all[SPC_SNEE_MAX_ALL];
        int it = 0;
        int nall = solver->solve_all(q, all, SPC_SNEE_MAX_ALL, &it);
        emit_exact(q, e, uv, p_y, all, nall, it, st, sk);
        if (!solver->solve_one || !solver->covers || (solver->covers_all && solver->covers_all(q)))
            return;
    }

    if (p->biased && !q->cam) {
        sk->total = spc_rgb_add(sk->total, biased_estimate(q, solver, e, uv, p_y, rng, st));
        return;
    }

    /* the straight-line solution, counted exactly (spc_snee_params.straight_first) */
    spc_chain straight;
    int it = 0;
    bool have_straight = straight_solve(q, solver, &straight, &it);
    if (st)
        st->iterations += (uint64_t)it;
    if (have_straight) {
        q->psi = straight_psi(p);
        spc_rgb vs = spc_snee_chain_value(q, e, uv, &straight);
        q->psi = 0.0;
        if (st)
            st->straight++;
        if (!spc_rgb_is_black(vs)) {
            emit(q, sk, &straight, spc_rgb_scale(vs, 1.0 / p_y));
            if (st)
                st->contributions++;
        }
    }

    /* the fitted sphere's solutions' chains, counted exactly (fit_first) */
    spc_chain ff[SPC_FIT_MAX_DIRS];
    it = 0;
    int nff = fit_first(q, solver, have_straight ? &straight : NULL, ff, SPC_FIT_MAX_DIRS, &it);
    if (st)
        st->iterations += (uint64_t)it;
    for (int i = 0; i < nff; ++i) {
        q->psi = 1.0;
        spc_rgb vf = spc_snee_chain_value(q, e, uv, &ff[i]);
        q->psi = 0.0;
        if (!spc_rgb_is_black(vf)) {
            emit(q, sk, &ff[i], spc_rgb_scale(vf, 1.0 / p_y));
            if (st)
                st->contributions++;
        }
    }

    spc_chain sol;
    spc_vec3 seed;
    bool seeded;
    int iterations = 0;
    bool ok = attempt(q, solver, rng, &sol, &iterations, &seed, &seeded);
    if (st)
        st->iterations += (uint64_t)iterations;
    if (!ok)
        return;
    if (exact_covers(q, solver, &sol))
        return; /* already counted exactly */
    if (have_straight && spc_snee_same_solution(&straight, &sol, sc->radius))
        return; /* counted exactly above */
    for (int i = 0; i < nff; ++i)
        if (spc_snee_same_solution(&ff[i], &sol, sc->radius))
            return; /* counted exactly above */
    if (st)
        st->solved++;
    if (solve_mis_within(p, &sol)) {
        emit_solve_mis(q, solver, e, uv, p_y, &sol, seeded ? &seed : NULL, iterations, rng, st, sk);
        return;
    }
    double psi = attempt_psi(q, &sol); /* neither the straight-line solution nor one of solve_all's */
    q->psi = psi;
    double a, b;
    spc_rgb v = counted_chain_value(q, e, uv, &sol, &a, &b);
    q->psi = 0.0;
    if (spc_rgb_is_black(v))
        return;

    if (st)
        st->contributions++;
    emit(q, sk, &sol, spc_rgb_scale(v, inv_p_solve(q, solver, &sol, give_up_cap(q, &sol, a, b, psi), rng, st) / p_y));
}

/* One guided direction (params.guide): a light by power, a direction in one of its cones at x,
 * traced through the chain's surfaces by their BSDFs (the events they sample, as a path would);
 * counted where it reaches that light through a chain the path integrator's track would cover,
 * weighed against specular NEE's light sample and BSDF sampling. */
static void guided(spc_snee_query *q, spc_rng *rng, spc_snee_stats *st, snee_sink *sk)
{
    const spc_snee_params *p = q->params;
    const spc_scene *sc = q->scene;
    const spc_hit *x = q->x;
    double pmf;
    const spc_emitter *e = spc_scene_sample_emitter(sc, spc_rng_next(rng), &pmf);
    double u0 = spc_rng_next(rng);
    spc_vec2 u = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
    if (!e || e->type != SPC_EMITTER_AREA)
        return;
    const spc_snee_cones *cs = cones_for(q, e);
    if (!cs || cs->n == 0)
        return;
    int i = (int)(u0 * cs->n);
    i = i < cs->n ? i : cs->n - 1;
    spc_frame fr = spc_frame_from_n(cs->axis[i]);
    spc_vec3 d0 = spc_frame_to_world(&fr, spc_warp_uniform_cone(u, cs->cos_max[i]));
    double pdf = cones_pdf(cs, d0, 1);
    spc_rgb f = spc_bsdf_eval(x->bsdf, x, SPC_MODE_RADIANCE, q->wo, d0);
    double cosx = spc_absdot(d0, x->sh.n);
    if (!(pdf > 0.0) || spc_rgb_is_black(f) || !(cosx > 0.0))
        return;
    if (st)
        st->guided++;
    spc_rgb T = spc_rgb_scale(f, cosx / pdf);
    /* the track as the path integrator starts it at a receiver (a non-delta lobe) */
    spc_snee_track t;
    memset(&t, 0, sizeof t);
    spc_snee_track_scatter(&t, x, SPC_LOBE_DIFFUSE_REFLECTION, q->max_chain, p->any_surface, p->reflect);
    spc_ray ray = spc_hit_spawn(x, d0);
    for (;;) {
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h))
            return;
        if (h.emitter) {
            if (h.emitter != e || t.k > q->max_chain || !spc_snee_track_covers(&t, sc, e))
                return;
            spc_rgb Le = spc_emitter_eval_area(e, &h, spc_neg(ray.d));
            double a, b, c;
            spc_receiver own;
            if (spc_rgb_is_black(Le) || !covered_terms(sc, p, query_receiver(q, &own), d0, q->max_chain, t.k, t.events,
                                                       &h, cs, &a, &b, &c, NULL, NULL))
                return;
            double w = mis3(c, a, b);
            if (!(w > 0.0))
                return;
            if (st)
                st->guided_hits++;
            sk->total = spc_rgb_add(sk->total, spc_rgb_scale(spc_rgb_mul(T, Le), w));
            return;
        }
        if (t.k >= q->max_chain)
            return;
        spc_bsdf_sample bs;
        double ul = spc_rng_next(rng);
        spc_vec2 ud = spc_v2(spc_rng_next(rng), spc_rng_next(rng));
        if (!h.bsdf || !spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, spc_neg(ray.d), ul, ud, &bs) ||
            !(bs.lobe & SPC_LOBE_DELTA))
            return;
        spc_snee_track_scatter(&t, &h, bs.lobe, 0, p->any_surface, p->reflect);
        if (!t.live)
            return;
        T = spc_rgb_mul(T, bs.weight);
        if (spc_rgb_is_black(T))
            return;
        ray = spc_hit_spawn(&h, bs.wi);
    }
}

spc_rgb spc_specular_nee(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                         int max_chain, spc_rng *rng, spc_snee_stats *st)
{
    return spc_specular_nee_depth(sc, p, x, wo, max_chain, SPC_CHAIN_MAX_VERTICES, rng, st);
}

static spc_rgb receiver_nee(const spc_scene *sc, const spc_snee_params *p, const spc_specular_solver *solver,
                            const spc_receiver *r, int max_chain, int long_max, spc_rng *rng, spc_snee_stats *st);

/* params.query_p: is the query made (with that probability; receiver_nee counts it 1 / query_p
 * times)? The first draw of the query's stream, played before the receiver is built: most
 * vertices of a path make no query. */
static bool query_made(const spc_snee_params *p, spc_rng *rng)
{
    double pq = spc_snee_query_prob(p);
    return !(pq < 1.0) || spc_rng_next(rng) < pq;
}

spc_rgb spc_specular_nee_depth(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                               int max_chain, int long_max, spc_rng *rng, spc_snee_stats *st)
{
    const spc_rgb zero = spc_rgb1(0.0);
    const spc_specular_solver *solver = spc_specular_solver_get(p->solver);
    if (max_chain > p->max_chain)
        max_chain = p->max_chain;
    max_chain = spc_snee_budget(x, max_chain, p->any_surface);
    if (!solver || (!solver->solve_one && !solver->solve_all) || max_chain < 1)
        return zero;
    if (p->solver == SPC_SNEE_NEWTON && p->newton.rough)
        return spc_rough_nee(sc, p, x, wo, spc_snee_budget_params(p, x, max_chain), rng, st);
    if (!query_made(p, rng))
        return zero;
    spc_receiver r;
    spc_receiver_surface(&r, x, wo);
    r.guide = p->cguide_at;
    return receiver_nee(sc, p, solver, &r, max_chain, long_max, rng, st);
}

spc_rgb spc_specular_nee_at(const spc_scene *sc, const spc_snee_params *p, const spc_receiver *r, int max_chain,
                            int long_max, spc_rng *rng, spc_snee_stats *st)
{
    if (r->kind == SPC_RECEIVER_SURFACE)
        return spc_specular_nee_depth(sc, p, r->hit, r->wo, max_chain, long_max, rng, st);
    const spc_specular_solver *solver = spc_specular_solver_get(p->solver);
    if (max_chain > p->max_chain)
        max_chain = p->max_chain;
    if (max_chain > SPC_CHAIN_MAX_VERTICES)
        max_chain = SPC_CHAIN_MAX_VERTICES;
    if (r->kind != SPC_RECEIVER_MEDIUM || !solver || (!solver->solve_one && !solver->solve_all) || max_chain < 1 ||
        (p->solver == SPC_SNEE_NEWTON && p->newton.rough) || !query_made(p, rng))
        return spc_rgb1(0.0);
    return receiver_nee(sc, p, solver, r, max_chain, long_max, rng, st);
}

static spc_rgb receiver_nee(const spc_scene *sc, const spc_snee_params *p, const spc_specular_solver *solver,
                            const spc_receiver *r, int max_chain, int long_max, spc_rng *rng, spc_snee_stats *st)
{
    const spc_rgb zero = spc_rgb1(0.0);
    /* params.query_p: the query made with that probability (query_made, played by the caller),
     * counted 1 / query_p times (p_y below) */
    double pq = spc_snee_query_prob(p);

    spc_snee_query q;
    spc_snee_query_init(&q, sc, p, spc_receiver_origin(r), r->wo, max_chain);
    q.receiver = r;
    q.long_max = long_max < SPC_CHAIN_MAX_VERTICES ? long_max : SPC_CHAIN_MAX_VERTICES;
    spc_fit_roots fit;
    fit.nshapes = 0;
    q.fit = &fit;
    const spc_emitter *e;
    spc_vec2 uv;
    double p_y;
    /* params.guide: at surface receivers (the cones' directions are traced as BSDF samples) */
    bool guide = guide_on(p) && r->kind == SPC_RECEIVER_SURFACE;
    /* params.light_samples: n light points, each a query of its own counted 1 / n times */
    int n = light_count(p);
    if (n > 1) {
        snee_sink sk;
        memset(&sk, 0, sizeof sk);
        const spc_snee_query q0 = q;
        for (int i = 0; i < n; ++i) {
            q = q0;
            fit.nshapes = 0;
            if (!spc_snee_sample_light(sc, p->any_surface, rng, &q, &e, &uv, &p_y))
                continue;
            p_y *= pq * n;
            q.p_y = p_y;
            if (st)
                st->calls++;
            estimate(&q, solver, e, uv, p_y, rng, st, &sk);
        }
        return sk.total;
    }
    bool lit = spc_snee_sample_light(sc, p->any_surface, rng, &q, &e, &uv, &p_y);
    if (!lit && !guide)
        return zero;
    /* the cones at x, built on first use (a light sample that fails still leaves the guided
     * direction its turn: its density does not depend on specular NEE's) */
    spc_snee_cones cones;
    if (guide) {
        memset(&cones, 0, sizeof cones);
        cones.budget = max_chain;
        q.cones = &cones;
    }
    snee_sink sk;
    memset(&sk, 0, sizeof sk);
    /* params.snee_p: the light sample made with that probability, counted 1 / snee_p times */
    double ps = lit && guide ? snee_prob(&q, e) : 1.0;
    if (ps < 1.0) {
        lit = spc_rng_next(rng) < ps;
        p_y *= ps;
    }
    p_y *= pq;
    if (lit) {
        q.p_y = p_y;
        if (st)
            st->calls++;
        estimate(&q, solver, e, uv, p_y, rng, st, &sk);
    }
    if (guide)
        guided(&q, rng, st, &sk);
    return sk.total;
}

/* ---- from the camera ---- */

int spc_snee_camera(const spc_scene *sc, const spc_snee_params *p, const spc_camera_state *cam, double cam_scale,
                    int max_chain, int long_max, spc_rng *rng, spc_snee_stats *st, spc_snee_splat *out, int max_out)
{
    const spc_specular_solver *solver = spc_specular_solver_get(p->solver);
    if (max_chain > p->max_chain)
        max_chain = p->max_chain;
    if (!solver || (!solver->solve_one && !solver->solve_all) || max_chain < 1 || !spc_camera_connectible(cam) ||
        (p->solver == SPC_SNEE_NEWTON && p->newton.rough))
        return 0;
    /* params.camera_p: the query made with that probability, counted 1 / camera_p times (decided
     * before the query is set up: most calls make none) */
    if (p->camera_p < 1.0 && !(spc_rng_next(rng) < p->camera_p))
        return 0;
    spc_receiver r;
    spc_receiver_camera(&r, cam, cam_scale);
    spc_snee_query q;
    spc_snee_query_init(&q, sc, p, spc_receiver_origin(&r), r.wo, max_chain);
    q.receiver = &r;
    q.cam = cam;
    q.cam_scale = cam_scale;
    q.long_max = long_max < SPC_CHAIN_MAX_VERTICES ? long_max : SPC_CHAIN_MAX_VERTICES;
    spc_fit_roots fit;
    fit.nshapes = 0;
    q.fit = &fit;
    const spc_emitter *e;
    spc_vec2 uv;
    double p_y;
    if (!spc_snee_sample_light(sc, p->any_surface, rng, &q, &e, &uv, &p_y))
        return 0;
    p_y *= p->camera_p;
    q.p_y = p_y;
    if (st)
        st->calls++;
    snee_sink sk;
    memset(&sk, 0, sizeof sk);
    sk.splats = out;
    sk.max_splats = max_out;
    estimate(&q, solver, e, uv, p_y, rng, st, &sk);
    return sk.nsplats;
}

double spc_snee_camera_bsdf_weight(const spc_scene *sc, const spc_snee_params *p, const spc_camera_state *cam,
                                   double cam_scale, spc_vec3 d0, int max_chain, int k, const unsigned char *events,
                                   const spc_hit *light)
{
    const spc_emitter *e = light->emitter;
    if (!p->camera || !spc_camera_connectible(cam))
        return 1.0;
    if (!p->mis || !e || k < 1 || k > SPC_CHAIN_MAX_VERTICES)
        return 0.0; /* covered and not weighted: specular NEE's alone */
    spc_receiver r;
    spc_receiver_camera(&r, cam, cam_scale);
    return covered_weight(sc, p, &r, d0, max_chain, k, events, light, NULL);
}

/* ---- exclusion of the covered paths from BSDF sampling ---- */

void spc_snee_track_scatter(spc_snee_track *t, const spc_hit *h, unsigned lobe, int snee_budget, bool any_surface,
                            bool reflect)
{
    if (!(lobe & SPC_LOBE_DELTA)) {
        /* a non-delta scattering: a new receiver, tracked if specular NEE ran there */
        t->live = snee_budget > 0;
        t->k = 0;
        t->max_chain = snee_budget;
        t->long_max = 0;
        t->single_ok = t->multi_ok = true;
        t->any_surface = any_surface;
        t->reflect = reflect;
        return;
    }
    if (!t->live)
        return;
    int event;
    if (!spc_chain_surface(h, t->any_surface, &event)) {
        t->live = false;
        return;
    }
    /* the BSDF's event, or with reflect either delta lobe of a dielectric */
    if (event == SPC_CHAIN_REFRACT && t->reflect && lobe == SPC_LOBE_DELTA_REFLECTION)
        event = SPC_CHAIN_REFLECT;
    unsigned want = event == SPC_CHAIN_REFLECT ? SPC_LOBE_DELTA_REFLECTION : SPC_LOBE_DELTA_TRANSMISSION;
    if (lobe != want || t->k >= (t->long_max > t->max_chain ? t->long_max : t->max_chain)) {
        t->live = false;
        return;
    }
    t->events[t->k++] = (unsigned char)event;
    if (!t->any_surface) {
        t->single_ok = t->single_ok && spc_chain_caster_allowed(h->shape->caustic_flags, 1);
        t->multi_ok = t->multi_ok && spc_chain_caster_allowed(h->shape->caustic_flags, 2);
    }
}

void spc_snee_track_begin(spc_snee_track *t, const spc_snee_params *p, int budget, int long_max)
{
    t->live = budget > 0;
    t->k = 0;
    t->max_chain = budget;
    t->single_ok = t->multi_ok = true;
    t->any_surface = p->any_surface;
    t->reflect = p->reflect;
    t->long_max = budget > 0 ? spc_snee_track_long_max(p, long_max) : 0;
}

bool spc_snee_track_covers(const spc_snee_track *t, const spc_scene *sc, const spc_emitter *e)
{
    if (!t->live || t->k < 1 || t->k > (t->long_max > t->max_chain ? t->long_max : t->max_chain) || !e ||
        e->type != SPC_EMITTER_AREA)
        return false;
    if (!(t->k == 1 ? t->single_ok : t->multi_ok))
        return false;
    return spc_scene_emitter_pmf(sc, e) > 0.0;
}

/* ---- the same with rough vertices ---- */

static bool rough_mode(const spc_snee_params *p) { return p->solver == SPC_SNEE_NEWTON && p->newton.rough; }

int spc_snee_budget_params(const spc_snee_params *p, const spc_hit *x, int max_chain)
{
    int b = spc_snee_budget(x, max_chain, p->any_surface);
    if (b > 0 && rough_mode(p) && spc_newton_rough_surface(x, p->any_surface, NULL))
        return 0;
    return b;
}

/* The chain-vertex bookkeeping of one more vertex on h (allowed flags, budget). */
static void track_vertex(spc_snee_track *t, const spc_hit *h)
{
    if (++t->k > t->max_chain) {
        t->live = false;
        return;
    }
    if (!t->any_surface) {
        t->single_ok = t->single_ok && spc_chain_caster_allowed(h->shape->caustic_flags, 1);
        t->multi_ok = t->multi_ok && spc_chain_caster_allowed(h->shape->caustic_flags, 2);
    }
}

void spc_snee_track_scatter_params(spc_snee_track *t, const spc_snee_params *p, const spc_hit *h, unsigned lobe,
                                   int snee_budget, int long_max)
{
    int event;
    if (rough_mode(p) && spc_newton_rough_surface(h, p->any_surface, &event)) {
        unsigned want = event == SPC_CHAIN_REFLECT ? SPC_LOBE_GLOSSY_REFLECTION : SPC_LOBE_GLOSSY_TRANSMISSION;
        if (t->live && lobe == want)
            track_vertex(t, h);
        else
            t->live = false; /* any other lobe: not a chain vertex, and never a receiver */
        return;
    }
    spc_snee_track_scatter(t, h, lobe, snee_budget, p->any_surface, p->reflect && !rough_mode(p));
    if (!(lobe & SPC_LOBE_DELTA) && snee_budget > 0)
        t->long_max = spc_snee_track_long_max(p, long_max);
}

double spc_snee_flat_psi(const spc_snee_params *p, int max_chain, int long_max, int k)
{
    /* a query as receiver_nee builds it, for flat_max and flat_psi, which read no more of it */
    spc_snee_query q;
    memset(&q, 0, sizeof q);
    q.params = p;
    q.max_chain = max_chain;
    q.long_max = long_max < SPC_CHAIN_MAX_VERTICES ? long_max : SPC_CHAIN_MAX_VERTICES;
    if (!p->exact || k < 1 || k > SPC_FLAT_MAX_VERTICES)
        return 0.0;
    return k <= flat_max(&q) ? 1.0 : flat_psi(&q, k);
}

int spc_snee_track_long_max(const spc_snee_params *p, int long_max)
{
    /* as long_on has it at a query */
    if (!((p->exact || random_long(p)) && p->mis && p->long_p > 0.0))
        return 0;
    int top = long_top(p);
    if (p->exact && p->sphere_long_p > 0.0 && top < SPC_SNEE_LONG_MAX)
        top = SPC_SNEE_LONG_MAX; /* the chains on one sphere past it (sphere_psi) */
    return long_max < top ? long_max : top;
}

int spc_snee_camera_long_max(const spc_snee_params *p, int long_max, int track_long_max)
{
    if (!cam_long_params(p))
        return track_long_max;
    int k = long_max < SPC_SNEE_CAM_LONG_MAX ? long_max : SPC_SNEE_CAM_LONG_MAX;
    return k > track_long_max ? k : track_long_max;
}

bool spc_snee_track_covers_light(const spc_snee_track *t, const spc_snee_params *p, const spc_scene *sc,
                                 const spc_hit *h, spc_vec3 wo, spc_vec3 wi, const spc_emitter *e)
{
    int event;
    if (!rough_mode(p) || !t->live || !e || !spc_newton_rough_surface(h, p->any_surface, &event))
        return false;
    if (e->type != SPC_EMITTER_AREA && e->type != SPC_EMITTER_POINT && e->type != SPC_EMITTER_SPOT)
        return false;
    /* sides by the shading normal, as the solver's constraints have them */
    double s = spc_dot(wo, h->sh.n) * spc_dot(wi, h->sh.n);
    if (event == SPC_CHAIN_REFLECT ? !(s > 0.0) : !(s < 0.0))
        return false;
    spc_snee_track u = *t;
    track_vertex(&u, h);
    if (!u.live || !(u.k == 1 ? u.single_ok : u.multi_ok))
        return false;
    return spc_scene_emitter_pmf(sc, e) > 0.0;
}
