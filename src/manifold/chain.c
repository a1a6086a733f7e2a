/*
 * manifold/chain.c: tracing a specular chain from a point along a parameterized direction, with
 * the analytic derivatives of every vertex with respect to the two direction parameters.
 *
 * Implements Dadfar 2022 (shared/papers/000): the forward path x_i = x_{i-1} + v_{i-1} t_{i-1}
 * (sec. 5.1, eq. 16), reflection and refraction (eq. 4, 8, written as eq. 26-29), and their
 * derivatives (sec. 6.1: eq. 24 for positions, eq. 25 for reflection, eq. 30-33 for refraction,
 * eq. 34-37 for hit distances by implicit differentiation of the surface constraint; sec. 6.2:
 * normal derivatives, eq. 40 for spheres and eq. 43-46 for interpolated triangle normals, here
 * taken from the hit's surface derivatives so every shape kind is handled by one code path).
 * Sec. 6.4's polar angles are replaced by gnomonic coordinates on the tangent plane of a base
 * direction (no pole; see chain.h). The generalized geometry term (Jakob and Marschner 2012) is
 * computed from the Jacobian of the final segment's hit on the light's tangent plane.
 */
#include "manifold/chain.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* |ng . d| below this is a grazing hit: the hit-distance derivative (eq. 37) divides by it. */
#define SPC_CHAIN_GRAZING 1e-9
/* Gram determinant of (dpdu, dpdv) below this fraction of |dpdu|^2 |dpdv|^2 means the surface
 * parameterization is degenerate (e.g. exactly at a sphere's pole, probability zero): the
 * normal's derivative cannot be recovered from the hit's derivatives there. */
#define SPC_CHAIN_GRAM_EPS 1e-20

spc_chain_opts spc_chain_opts_default(int max_vertices)
{
    spc_chain_opts o;
    memset(&o, 0, sizeof o);
    o.max_vertices = max_vertices;
    return o;
}

bool spc_chain_caster_allowed(unsigned flags, int k) { return spc_scene_caster_allowed(flags, k); }

const spc_chain_casters *spc_chain_casters_of(const spc_scene *sc, bool any_surface)
{
    return &sc->casters[any_surface ? 1 : 0];
}

bool spc_chain_shape_is_caster(const spc_shape *s, bool any_surface, int *event)
{
    double eta;
    if (!spc_scene_shape_is_caster(s, any_surface, &eta))
        return false;
    if (event)
        *event = eta > 0.0 ? SPC_CHAIN_REFRACT : SPC_CHAIN_REFLECT;
    return true;
}

bool spc_chain_surface(const spc_hit *h, bool any_surface, int *event)
{
    /* the hit's BSDF is the shape's (no per-hit BSDF exists yet); ask the hit's in case */
    if (!h->shape || h->bsdf != h->shape->bsdf)
        return false;
    return spc_chain_shape_is_caster(h->shape, any_surface, event);
}

int spc_chain_pick_event(int event, double u, double reflect_p, double *prob)
{
    if (event != SPC_CHAIN_REFRACT) {
        if (prob)
            *prob = 1.0;
        return event;
    }
    bool r = u < reflect_p;
    if (prob)
        *prob = r ? reflect_p : 1.0 - reflect_p;
    return r ? SPC_CHAIN_REFLECT : SPC_CHAIN_REFRACT;
}

double spc_chain_events_prob(const spc_scene *sc, const spc_chain_sig *sig, bool any_surface, double reflect_p)
{
    double P = 1.0;
    for (int i = 0; i < sig->n; ++i) {
        int ev = SPC_CHAIN_REFLECT;
        if (sig->shape[i] < 0 || sig->shape[i] >= sc->nshapes ||
            !spc_chain_shape_is_caster(sc->shapes[sig->shape[i]], any_surface, &ev))
            return 0.0;
        if (ev == SPC_CHAIN_REFRACT)
            P *= sig->event[i] == SPC_CHAIN_REFLECT ? reflect_p : 1.0 - reflect_p;
    }
    return P;
}

spc_vec3 spc_chain_direction(const spc_frame *f, double a, double b, spc_vec3 dd[2])
{
    spc_vec3 w = spc_add(f->n, spc_add(spc_scale(f->s, a), spc_scale(f->t, b)));
    double inv = 1.0 / spc_length(w);
    spc_vec3 d = spc_scale(w, inv);
    /* d(w/|w|) = (I - d d^T) dw / |w| */
    dd[0] = spc_scale(spc_sub(f->s, spc_scale(d, spc_dot(d, f->s))), inv);
    dd[1] = spc_scale(spc_sub(f->t, spc_scale(d, spc_dot(d, f->t))), inv);
    return d;
}

/* Exact ray-triangle intersection in double (Moller-Trumbore on the stored float vertices) for
 * the triangle Embree reported, so that chains of meshes are smooth to double precision. */
static bool refine_triangle(const spc_shape *s, int prim, const spc_ray *r, double *t, double *b1, double *b2)
{
    const spc_mesh *m = &s->mesh;
    spc_vec3 p0 = spc_mesh_p(m, m->idx[3 * prim]);
    spc_vec3 e1 = spc_sub(spc_mesh_p(m, m->idx[3 * prim + 1]), p0);
    spc_vec3 e2 = spc_sub(spc_mesh_p(m, m->idx[3 * prim + 2]), p0);
    spc_vec3 pv = spc_cross(r->d, e2);
    double det = spc_dot(e1, pv);
    if (det == 0.0)
        return false;
    double inv = 1.0 / det;
    spc_vec3 tv = spc_sub(r->o, p0);
    spc_vec3 qv = spc_cross(tv, e1);
    *b1 = spc_dot(tv, pv) * inv;
    *b2 = spc_dot(r->d, qv) * inv;
    *t = spc_dot(e2, qv) * inv;
    return isfinite(*t);
}

/* spc_scene_intersect's record, on a triangle at refine_triangle's coordinates where they are
 * valid: the record is filled once, from the refined coordinates or else from Embree's; with slim,
 * a mesh hit without what only shading reads (spc_shape_fill_hit_chain), except on a normal-mapped
 * surface, whose mapping reads the whole record. */
static bool intersect(const spc_scene *sc, const spc_ray *r, bool slim, spc_hit *h)
{
    spc_scene_answer a;
    spc_scene_trace(sc, r, &a);
    if (a.shape < 0)
        return false;
    const spc_shape *s = sc->shapes[a.shape];
    if (s->type == SPC_SHAPE_MESH) {
        double t, b1, b2;
        if (refine_triangle(s, a.prim, r, &t, &b1, &b2) && t > 0.0) {
            a.u = b1;
            a.v = b2;
            a.t = t;
        }
    }
    h->shape_index = a.shape;
    if (slim && !(s->bsdf && s->bsdf->type == SPC_BSDF_NORMALMAP))
        spc_shape_fill_hit_chain(s, a.prim, a.u, a.v, r, a.t, h);
    else
        spc_shape_fill_hit(s, a.prim, a.u, a.v, r, a.t, h);
    /* a normal-mapped chain surface: the mapped frame as the ray arriving sees it */
    if (h->bsdf && h->bsdf->type == SPC_BSDF_NORMALMAP && spc_chain_shape_is_caster(s, true, NULL))
        spc_bsdf_map_chain_hit(h, spc_neg(r->d));
    return true;
}

bool spc_chain_hit_ready(const spc_hit *h)
{
    return !h->bsdf || h->bsdf->type != SPC_BSDF_NORMALMAP || !h->bsdf->normalmap || h->normal_mapped;
}

bool spc_chain_intersect(const spc_scene *sc, const spc_ray *r, spc_hit *h) { return intersect(sc, r, false, h); }

/* A normal-mapped hit is always whole (intersect), and filling it again would undo its mapping. */
static void complete_hit(spc_hit *h)
{
    if (!(h->bsdf && h->bsdf->type == SPC_BSDF_NORMALMAP))
        spc_shape_hit_complete(h);
}

void spc_chain_complete(spc_chain *c)
{
    for (int i = 0; i < c->n; ++i)
        complete_hit(&c->v[i].h);
    if (c->has_end_hit)
        complete_hit(&c->end_hit);
}

/* Solves dp = dpdu du + dpdv dv (least squares) and returns dn = dndu du + dndv dv. */
static bool normal_derivative(const spc_hit *h, spc_vec3 dp, spc_vec3 *dn)
{
    double g11 = spc_dot(h->dpdu, h->dpdu), g12 = spc_dot(h->dpdu, h->dpdv), g22 = spc_dot(h->dpdv, h->dpdv);
    double det = g11 * g22 - g12 * g12;
    if (!(det > SPC_CHAIN_GRAM_EPS * g11 * g22))
        return false;
    double r1 = spc_dot(h->dpdu, dp), r2 = spc_dot(h->dpdv, dp);
    double du = (g22 * r1 - g12 * r2) / det, dv = (g11 * r2 - g12 * r1) / det;
    *dn = spc_add(spc_scale(h->dndu, du), spc_scale(h->dndv, dv));
    return true;
}

/* Reflection (eq. 4) and its derivative (eq. 25). */
static void reflect(spc_chain_vertex *v, spc_vec3 d, const spc_vec3 dd[2])
{
    spc_vec3 n = v->h.sh.n;
    double c = spc_dot(d, n);
    v->d = spc_sub(d, spc_scale(n, 2.0 * c));
    for (int j = 0; j < 2; ++j) {
        double dc = spc_dot(dd[j], n) + spc_dot(d, v->dn[j]);
        v->dd[j] = spc_sub(dd[j], spc_add(spc_scale(n, 2.0 * dc), spc_scale(v->dn[j], 2.0 * c)));
    }
    v->eta_ti = 1.0;
}

/* Refraction (eq. 26-29) and its derivative (eq. 30-33). eta = n_inside / n_outside with the
 * inside opposite to the shading normal, as the dielectric BSDF has it. False under total
 * internal reflection. */
static bool refract(spc_chain_vertex *v, double eta, spc_vec3 d, const spc_vec3 dd[2])
{
    spc_vec3 n = v->h.sh.n, dn[2] = {v->dn[0], v->dn[1]};
    double r; /* n_incident / n_transmitted */
    if (spc_dot(d, n) < 0.0) {
        r = 1.0 / eta;
    } else {
        r = eta;
        n = spc_neg(n);
        dn[0] = spc_neg(dn[0]);
        dn[1] = spc_neg(dn[1]);
    }
    /* n now faces the incident side: c = -d . n > 0 */
    double c = -spc_dot(d, n);
    double k = 1.0 - r * r * (1.0 - c * c);
    if (!(k > 0.0))
        return false;
    double sk = sqrt(k);
    double m = r * c - sk;
    v->d = spc_add(spc_scale(d, r), spc_scale(n, m));
    for (int j = 0; j < 2; ++j) {
        double dc = -(spc_dot(dd[j], n) + spc_dot(d, dn[j]));
        double dk = 2.0 * r * r * c * dc;
        double dsk = dk / (2.0 * sk);
        v->dd[j] = spc_add(spc_add(spc_scale(dd[j], r), spc_scale(n, r * dc - dsk)), spc_scale(dn[j], m));
    }
    v->eta_ti = 1.0 / r;
    return true;
}

spc_chain_end spc_chain_trace(const spc_scene *sc, const spc_hit *x, const spc_frame *frame, double a, double b,
                              const spc_chain_opts *opts, spc_chain *c)
{
    c->x = x->p;
    c->frame = *frame;
    c->a = a;
    c->b = b;
    c->n = 0;
    c->fail_vertex = -1;
    c->has_end_hit = false;
    c->d0 = spc_chain_direction(frame, a, b, c->dd0);

    const spc_chain_sig *fixed = opts->fixed;
    int limit = fixed ? fixed->n : opts->max_vertices;
    if (limit > SPC_CHAIN_MAX_VERTICES)
        limit = SPC_CHAIN_MAX_VERTICES;

    /* the ray origin (offset from the previous surface along its ng) and its derivative; the
     * offset's own derivative, err times the derivative of ng, is below double rounding for the
     * double-precision analytic shapes and zero for flat triangles */
    spc_vec3 dprev[2] = {spc_v3(0, 0, 0), spc_v3(0, 0, 0)};
    spc_vec3 d = c->d0, dd[2] = {c->dd0[0], c->dd0[1]};
    spc_ray ray = spc_hit_spawn(x, d);
    for (int i = 0;; ++i) {
        if (i == limit && (fixed ? !opts->find_end : opts->skip_end))
            return c->end = SPC_CHAIN_END_SURFACE;
        /* the hit goes straight into its vertex (the end hit past the last one is copied out) */
        spc_hit hl, *hp = i < SPC_CHAIN_MAX_VERTICES ? &c->v[i].h : &hl;
        if (!intersect(sc, &ray, opts->slim, hp)) {
            c->fail_vertex = i;
            return c->end = (fixed && i < limit) ? SPC_CHAIN_END_MISMATCH : SPC_CHAIN_END_ESCAPED;
        }
        const spc_hit *h = hp;
        int event = SPC_CHAIN_REFLECT;
        bool chain_surface = spc_chain_surface(h, opts->any_surface, &event);
        if (i == limit || !chain_surface) {
            if (fixed && i < limit) {
                c->fail_vertex = i;
                return c->end = SPC_CHAIN_END_MISMATCH;
            }
            c->has_end_hit = true;
            c->end_hit = *h;
            return c->end = chain_surface ? SPC_CHAIN_END_LIMIT : SPC_CHAIN_END_SURFACE;
        }
        if (fixed) {
            if (h->shape_index != fixed->shape[i]) {
                c->fail_vertex = i;
                return c->end = SPC_CHAIN_END_MISMATCH;
            }
            event = fixed->event[i];
        } else if (opts->events) {
            event = opts->events[i];
        } else if (opts->event_u && chain_surface) {
            event = spc_chain_pick_event(event, opts->event_u[i], opts->reflect_p, NULL);
        }

        spc_chain_vertex *v = &c->v[i];
        c->fail_vertex = i;
        if (!spc_chain_hit_ready(h))
            return c->end = SPC_CHAIN_END_DEGENERATE;
        v->wi = d;
        v->event = event;
        /* hit distance and position (eq. 16, 24), distance derivative from ng . dp = 0 (eq. 37) */
        double t = spc_dot(spc_sub(h->p, ray.o), d);
        double den = spc_dot(h->ng, d);
        if (!(fabs(den) > SPC_CHAIN_GRAZING))
            return c->end = SPC_CHAIN_END_DEGENERATE;
        v->t = t;
        for (int j = 0; j < 2; ++j) {
            spc_vec3 q = spc_madd(dprev[j], dd[j], t);
            v->dt[j] = -spc_dot(h->ng, q) / den;
            v->dp[j] = spc_madd(q, d, v->dt[j]);
            if (!normal_derivative(h, v->dp[j], &v->dn[j]))
                return c->end = SPC_CHAIN_END_DEGENERATE;
        }
        if (event == SPC_CHAIN_REFLECT) {
            reflect(v, d, dd);
        } else {
            double eta;
            spc_bsdf_is_specular_interface(h->bsdf, &eta);
            if (!(eta > 0.0))
                return c->end = SPC_CHAIN_END_MISMATCH;
            if (!refract(v, eta, d, dd))
                return c->end = SPC_CHAIN_END_TIR;
        }
        c->n = i + 1;
        c->fail_vertex = -1;
        dprev[0] = v->dp[0];
        dprev[1] = v->dp[1];
        d = v->d;
        dd[0] = v->dd[0];
        dd[1] = v->dd[1];
        ray = spc_hit_spawn(&v->h, d);
    }
}

/* Derivatives with respect to the old parameters -> with respect to the new ones (v[0], v[1]; C is
 * 2x2; pointer parameters: GCC's -Wstringop-overflow misread the array ones under ASan). */
static void reparam(spc_vec3 *v, double (*C)[2])
{
    spc_vec3 a = v[0], b = v[1];
    v[0] = spc_add(spc_scale(a, C[0][0]), spc_scale(b, C[1][0]));
    v[1] = spc_add(spc_scale(a, C[0][1]), spc_scale(b, C[1][1]));
}

bool spc_chain_recenter(spc_chain *c)
{
    spc_frame nf = spc_frame_from_n(c->d0);
    /* [s', t'] = [dd/da, dd/db] C: project on s', t' and invert the 2x2 matrix */
    double P00 = spc_dot(c->dd0[0], nf.s), P01 = spc_dot(c->dd0[1], nf.s);
    double P10 = spc_dot(c->dd0[0], nf.t), P11 = spc_dot(c->dd0[1], nf.t);
    double det = P00 * P11 - P01 * P10;
    if (!(fabs(det) > 0.0) || !isfinite(det))
        return false;
    double C[2][2] = {{P11 / det, -P01 / det}, {-P10 / det, P00 / det}};
    reparam(c->dd0, C);
    for (int i = 0; i < c->n; ++i) {
        spc_chain_vertex *v = &c->v[i];
        reparam(v->dp, C);
        reparam(v->dn, C);
        reparam(v->dd, C);
        double t0 = v->dt[0], t1 = v->dt[1];
        v->dt[0] = t0 * C[0][0] + t1 * C[1][0];
        v->dt[1] = t0 * C[0][1] + t1 * C[1][1];
    }
    c->frame = nf;
    c->a = c->b = 0.0;
    return true;
}

void spc_chain_signature(const spc_chain *c, spc_chain_sig *sig)
{
    memset(sig, 0, sizeof *sig);
    sig->n = c->n;
    for (int i = 0; i < c->n; ++i) {
        sig->shape[i] = c->v[i].h.shape_index;
        sig->event[i] = (unsigned char)c->v[i].event;
    }
}

bool spc_chain_sig_equal(const spc_chain_sig *a, const spc_chain_sig *b)
{
    if (a->n != b->n)
        return false;
    for (int i = 0; i < a->n; ++i)
        if (a->shape[i] != b->shape[i] || a->event[i] != b->event[i])
            return false;
    return true;
}

void spc_chain_final_segment(const spc_chain *c, spc_vec3 *o, spc_vec3 do_[2], spc_vec3 *d, spc_vec3 dd[2])
{
    if (c->n == 0) {
        *o = c->x;
        do_[0] = do_[1] = spc_v3(0, 0, 0);
        *d = c->d0;
        dd[0] = c->dd0[0];
        dd[1] = c->dd0[1];
        return;
    }
    const spc_chain_vertex *v = &c->v[c->n - 1];
    *o = v->h.p;
    do_[0] = v->dp[0];
    do_[1] = v->dp[1];
    *d = v->d;
    dd[0] = v->dd[0];
    dd[1] = v->dd[1];
}

bool spc_chain_plane_hit(const spc_chain *c, spc_vec3 y, spc_vec3 ny, spc_vec3 *q, spc_vec3 dq[2], double *t_out)
{
    spc_vec3 o, d, dO[2], dd[2];
    spc_chain_final_segment(c, &o, dO, &d, dd);
    double den = spc_dot(d, ny);
    if (!(fabs(den) > SPC_CHAIN_GRAZING))
        return false;
    double t = spc_dot(spc_sub(y, o), ny) / den;
    if (!(t > 0.0))
        return false;
    *q = spc_madd(o, d, t);
    for (int j = 0; j < 2; ++j) {
        spc_vec3 w = spc_madd(dO[j], dd[j], t);
        double dt = -spc_dot(w, ny) / den;
        dq[j] = spc_madd(w, d, dt);
    }
    if (t_out)
        *t_out = t;
    return true;
}

double spc_chain_solid_angle_density(const spc_chain *c)
{
    double cs = 1.0 / sqrt(1.0 + c->a * c->a + c->b * c->b);
    return cs * cs * cs;
}

double spc_chain_geometry(const spc_chain *c, spc_vec3 y, spc_vec3 ny)
{
    spc_vec3 q, dq[2];
    if (!spc_chain_plane_hit(c, y, ny, &q, dq, NULL))
        return 0.0;
    double area = spc_length(spc_cross(dq[0], dq[1])); /* dA(y) / (da db) */
    if (!(area > 0.0) || !isfinite(area))
        return 0.0;
    return spc_chain_solid_angle_density(c) / area;
}
