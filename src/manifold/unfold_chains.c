/*
 * manifold/unfold_chains.c: every specular chain through one sphere and one flat mirror
 * (unfold_chains.h): the sphere's planar roots (sphere_roots.h) toward the mirrored light point, or
 * on the mirrored sphere, per plane of the mirror's faces, each polished in the real scene.
 */
#include "manifold/unfold_chains.h"

#include <math.h>

#include "bsdf/bsdf.h"
#include "manifold/flat_chains.h"
#include "manifold/solver.h"
#include "manifold/sphere_chains.h"
#include "manifold/sphere_roots.h"
#include "scene/scene.h"

/* A point counts as outside a sphere of radius R beyond R (1 + this): sphere_chains.c's margin. */
#define SPC_UNFOLD_OUTSIDE_REL 1e-6
/* A root's unfolded segment counts as crossing the mirror's face within this share of the scene's
 * radius of it (crosses_face). The real chain's mirror vertex is that crossing: the planar root is
 * refined to 1e-12 of the arc and the polish moves it by less still, so the margin is some 1e5 times
 * the largest distance between the two, and a root it rejects has no chain. */
#define SPC_UNFOLD_FACE_REL 1e-6

spc_vec3 spc_unfold_mirror_point(spc_vec3 p, spc_vec3 n, double d)
{
    return spc_sub(p, spc_scale(n, 2.0 * (spc_dot(n, p) - d)));
}

static bool outside(spc_vec3 c, double R, spc_vec3 p)
{
    return spc_distance(p, c) > R * (1.0 + SPC_UNFOLD_OUTSIDE_REL);
}

bool spc_unfold_mirror_shape(const spc_shape *s)
{
    double eta = 0.0;
    return s && s->bsdf && spc_flat_chain_shape(s) && spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta == 0.0;
}

/* The sphere's part of a chain, its vertices v[i0 .. i0 + ks - 1]: one of sphere_chains.h's chains
 * of at most two vertices on the sphere s? */
static bool sphere_part(const spc_chain *c, int i0, int ks, bool reflect, const spc_shape **s)
{
    *s = c->v[i0].h.shape;
    if (ks < 1 || ks > 2 || !spc_sphere_chain_shape(*s))
        return false;
    for (int i = i0; i < i0 + ks; ++i)
        if (c->v[i].h.shape != *s)
            return false;
    bool glass = (*s)->bsdf->type == SPC_BSDF_DIELECTRIC;
    if (ks == 1)
        return c->v[i0].event == SPC_CHAIN_REFLECT && (!glass || reflect);
    return glass && c->v[i0].event == SPC_CHAIN_REFRACT && c->v[i0 + 1].event == SPC_CHAIN_REFRACT;
}

bool spc_unfold_chain_covers(const spc_chain *c, bool reflect)
{
    int n = c->n;
    if (n < 2 || n > SPC_UNFOLD_MAX_VERTICES)
        return false;
    const spc_shape *s;
    const spc_chain_vertex *m;
    spc_vec3 cen;
    if (spc_unfold_mirror_shape(c->v[n - 1].h.shape) && c->v[n - 1].event == SPC_CHAIN_REFLECT &&
        sphere_part(c, 0, n - 1, reflect, &s)) {
        cen = s->center; /* x - sphere - mirror - y: x outside the sphere itself */
    } else if (spc_unfold_mirror_shape(c->v[0].h.shape) && c->v[0].event == SPC_CHAIN_REFLECT &&
               sphere_part(c, 1, n - 1, reflect, &s)) {
        m = &c->v[0]; /* x - mirror - sphere - y: x outside the sphere mirrored in the mirror's plane */
        spc_vec3 nm = spc_normalize(m->h.ng);
        cen = spc_unfold_mirror_point(s->center, nm, spc_dot(nm, m->h.p));
    } else {
        return false;
    }
    return outside(cen, s->radius, c->x);
}

/* The sphere's last vertex of the chain whose planar root (in pl) is theta: with m = -1 the
 * reflection point; with m = 0 where the ray refracted in there (eta: inside / outside) leaves.
 * false where that refraction does not exist. */
static bool last_sphere_vertex(const spc_sphere_plane *pl, double theta, int m, double eta, spc_vec3 *out)
{
    double qx = cos(theta), qy = sin(theta);
    if (m == 0) {
        double ux = qx - pl->d, uy = qy, ul = sqrt(ux * ux + uy * uy);
        ux /= ul;
        uy /= ul;
        /* Snell's law at the outward normal (qx, qy), ratio 1 / eta; the chord back to the circle */
        double r = 1.0 / eta, ci = -(ux * qx + uy * qy), s2 = r * r * (1.0 - ci * ci);
        if (!(s2 <= 1.0))
            return false;
        double ct = sqrt(1.0 - s2);
        double tx = r * ux + (r * ci - ct) * qx, ty = r * uy + (r * ci - ct) * qy;
        double len = -2.0 * (tx * qx + ty * qy);
        qx += len * tx;
        qy += len * ty;
    }
    *out = spc_add(pl->c, spc_scale(spc_add(spc_scale(pl->e1, qx), spc_scale(pl->e2, qy)), pl->R));
    return true;
}

/* May the segment a -> b of an unfolded chain cross the mirror's plane (nm, dm) inside face f
 * (within tol)? The real chain's mirror vertex is that crossing, so where the segment stays on one
 * side of the plane, or crosses it outside the face, the root has no chain. */
static bool crosses_face(const spc_shape *mirror, int f, spc_vec3 nm, double dm, spc_vec3 a, spc_vec3 b, double tol,
                         spc_vec3 *at)
{
    double sa = spc_dot(nm, a) - dm, sb = spc_dot(nm, b) - dm;
    if ((sa > tol && sb > tol) || (sa < -tol && sb < -tol))
        return false;
    if (!(fabs(sa - sb) > tol))
        return true; /* both ends within tol of the plane: not decided here */
    spc_vec3 p = spc_add(a, spc_scale(spc_sub(b, a), sa / (sa - sb)));
    *at = p;
    return spc_flat_shape_face_holds(mirror, f, p, tol);
}

/* Does the segment a -> b pass deeper than tol into the sphere (c, R)? */
static bool segment_enters(spc_vec3 a, spc_vec3 b, spc_vec3 c, double R, double tol)
{
    spc_vec3 ab = spc_sub(b, a), ac = spc_sub(c, a);
    double l2 = spc_dot(ab, ab);
    double t = l2 > 0.0 ? spc_dot(ac, ab) / l2 : 0.0;
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    return spc_distance(spc_add(a, spc_scale(ab, t)), c) < R - tol;
}

/* The chains of one order through the sphere s and face f of the mirror, on the face's plane (nm,
 * dm): mirror_first puts the mirror's vertex first. Appends to out[*n ..]. With cull, the roots
 * whose unfolded segment misses the face (crosses_face) are not polished, and an order is not
 * solved where its mirror vertex would be seen from the back of a one-sided mirror or no ray
 * through the face reaches the sphere: these have no chain. */
static void order_chains(const spc_snee_query *q, const spc_shape *s, const spc_shape *mirror, int f, spc_vec3 nm,
                         double dm, bool mirror_first, int kmin, int kmax, spc_chain *out, int *n, int max_out,
                         int *iterations, bool cull, spc_unfold_tally *tally)
{
    spc_vec3 x = q->x->p;
    double R = s->radius;
    /* the sphere in the unfolded frame: itself where its vertices come first, else its image */
    spc_vec3 c = mirror_first ? spc_unfold_mirror_point(s->center, nm, dm) : s->center;
    spc_vec3 y1 = spc_unfold_mirror_point(q->y, nm, dm);
    if (!outside(c, R, x) || !outside(c, R, y1))
        return;
    /* a one-sided mirror reflects on its exterior side only: the side of the point next to its
     * vertex, x (mirror first) or y (sphere first) */
    double tol = SPC_UNFOLD_FACE_REL * q->scene->radius;
    if (cull && spc_flat_shape_front_only(mirror) && spc_dot(nm, mirror_first ? x : q->y) - dm < -tol) {
        if (tally)
            tally->orders_culled++;
        return;
    }
    /* a reflection keeps the path on one side of the plane: the sphere's vertex next to the mirror's
     * lies on the side of y (sphere first) or of x (mirror first), so a sphere wholly across the
     * plane from that point has no chain of this order */
    double sr = spc_dot(nm, mirror_first ? x : q->y) - dm, sc = spc_dot(nm, s->center) - dm;
    if (sr == 0.0 || (sr * sc < 0.0 && fabs(sc) >= R))
        return;
    spc_vec3 xo = spc_hit_offset(q->x, spc_sub(c, x));
    /* the unfolded segment through the mirror's face, seen from its end off the sphere (x, or the
     * mirrored light point), must go on to meet the sphere (or its image): where no ray from there
     * through the face does, no root has a chain. A crossing within tol of the face moves a point
     * at distance L beyond it by at most tol L / h off the face's pyramid, h the apex's height over
     * the plane. */
    if (cull) {
        spc_vec3 a = mirror_first ? xo : y1;
        double h = fabs(spc_dot(nm, a) - dm);
        if (h > tol && !spc_flat_shape_face_cone_meets(mirror, f, a, c, R, tol * (spc_distance(a, c) + R) / h)) {
            if (tally)
                tally->orders_culled++;
            return;
        }
    }
    spc_sphere_plane pl;
    if (!spc_sphere_plane_of(xo, c, R, y1, &pl))
        return;
    double eta = 0.0;
    spc_bsdf_is_specular_interface(s->bsdf, &eta);
    bool glass = s->bsdf->type == SPC_BSDF_DIELECTRIC;
    bool reflect = q->params && q->params->reflect;
    /* m = -1: one reflection off the sphere; m = 0: in and out (a glass ball) */
    int m_lo = glass && !reflect ? 0 : -1;
    int m_hi = glass ? 0 : -1;
    if (m_lo < kmin - 3)
        m_lo = kmin - 3;
    if (m_hi > kmax - 3)
        m_hi = kmax - 3;
    if (m_hi < m_lo)
        return;
    double roots[SPC_SPHERE_SIGNATURES][SPC_SPHERE_MAX_ROOTS];
    int nroots[SPC_SPHERE_SIGNATURES];
    spc_sphere_chain_roots_all(pl.d, pl.y1, pl.y2, eta, m_lo, m_hi, roots, nroots);
    for (int mm = m_lo; mm <= m_hi && *n < max_out; ++mm) {
        int ks = mm < 0 ? 1 : 2, k = ks + 1;
        if (!q->any_surface &&
            (!spc_chain_caster_allowed(s->caustic_flags, k) || !spc_chain_caster_allowed(mirror->caustic_flags, k)))
            continue;
        const spc_shape *shapes[SPC_UNFOLD_MAX_VERTICES];
        unsigned char ev[SPC_UNFOLD_MAX_VERTICES];
        int i0 = mirror_first ? 1 : 0;
        for (int v = 0; v < ks; ++v) {
            shapes[i0 + v] = s;
            ev[i0 + v] = ks == 2 ? SPC_CHAIN_REFRACT : SPC_CHAIN_REFLECT;
        }
        int im = mirror_first ? 0 : ks;
        shapes[im] = mirror;
        ev[im] = SPC_CHAIN_REFLECT;
        for (int r = 0; r < nroots[mm + 1] && *n < max_out; ++r) {
            spc_vec3 p = spc_sphere_plane_point(&pl, roots[mm + 1][r]);
            if (tally)
                tally->roots++;
            if (cull) {
                /* the unfolded segment through the mirror's plane: x to the image's entry point, or
                 * the sphere's last vertex to the mirrored light point */
                spc_vec3 a = xo, b = p;
                bool have = true;
                if (!mirror_first) {
                    have = last_sphere_vertex(&pl, roots[mm + 1][r], mm, eta, &a);
                    b = y1;
                }
                spc_vec3 at = {NAN, NAN, NAN};
                /* mirror first: the real sphere across x's way to the mirror blocks it (the trace
                 * meets the sphere first) */
                if (have && (!crosses_face(mirror, f, nm, dm, a, b, tol, &at) ||
                             (mirror_first && !isnan(at.x) && segment_enters(xo, at, s->center, R, tol)))) {
                    if (tally)
                        tally->roots_culled++;
                    continue;
                }
            }
            spc_vec3 dir = spc_normalize(spc_sub(p, xo));
            if (spc_snee_exact_polish_shapes(q, shapes, k, ev, dir, out, *n, iterations)) {
                ++*n;
                if (tally)
                    tally->chains++;
            }
        }
    }
}

int spc_unfold_chains_all(const spc_snee_query *q, spc_chain *out, int max_out, int *iterations)
{
    return spc_unfold_chains_cull(q, out, max_out, iterations, true, NULL);
}

int spc_unfold_chains_cull(const spc_snee_query *q, spc_chain *out, int max_out, int *iterations, bool cull,
                           spc_unfold_tally *tally)
{
    const spc_scene *sc = q->scene;
    int kmin = q->min_chain > 2 ? q->min_chain : 2;
    int kmax = q->max_chain < SPC_UNFOLD_MAX_VERTICES ? q->max_chain : SPC_UNFOLD_MAX_VERTICES;
    int n = 0;
    if (kmax < kmin)
        return 0;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, q->any_surface);
    for (int j = 0; cs && j < cs->n; ++j) {
        const spc_shape *s = sc->shapes[cs->idx[j]];
        if (!spc_sphere_chain_shape(s) || !spc_chain_shape_is_caster(s, q->any_surface, NULL))
            continue;
        for (int i = 0; i < cs->n; ++i) {
            const spc_shape *mirror = sc->shapes[cs->idx[i]];
            if (!spc_unfold_mirror_shape(mirror))
                continue;
            spc_vec3 nm[SPC_FLAT_MAX_FACES];
            double dm[SPC_FLAT_MAX_FACES];
            int np = spc_flat_shape_planes(mirror, nm, dm, SPC_FLAT_MAX_FACES);
            for (int f = 0; f < np; ++f) {
                order_chains(q, s, mirror, f, nm[f], dm[f], false, kmin, kmax, out, &n, max_out, iterations, cull,
                             tally);
                order_chains(q, s, mirror, f, nm[f], dm[f], true, kmin, kmax, out, &n, max_out, iterations, cull,
                             tally);
            }
        }
    }
    return n;
}
