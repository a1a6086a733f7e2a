/*
 * integrator/path_graze.c: grazing directions along a mirror cylinder's wall (path_graze.h): the
 * cylinders and their elevation bands, the draw at a receiver near the wall and its density, the
 * ray followed through the wall's reflections, and BSDF sampling's side of the MIS weight.
 */
#include "integrator/path_graze.h"

#include <math.h>

#include "bsdf/bsdf.h"
#include "emitter/emitter.h"
#include "manifold/cylinder_chains.h"
#include "scene/scene.h"

/* Wall points per turn at which the elevation band is measured; the band is widened by one step's
 * turn of the tangent so that the points between them are inside it too. */
#define SPC_GRAZE_BAND_STEPS 256
/* The largest grazing angle ever drawn (radians): past it a chain of SPC_GRAZE_MIN_REFLECTIONS
 * climbs any wall of length below 2.9 radii at elevations over 10 degrees. */
#define SPC_GRAZE_ALPHA_CAP 0.2

/* The elevation band [lo, hi] under which the wall points of c whose tangent points within alpha
 * (plus the light's angular radius) of an area light see that light's bounding sphere, over every
 * area light of sc. False where no wall point qualifies or a light's sphere reaches into the wall's
 * own region (its axial projection within the section). */
static bool elevation_band(const spc_scene *sc, const spc_graze_cylinder *c, spc_vec3 e1, spc_vec3 e2, double alpha,
                           double *lo, double *hi)
{
    const double pi = 3.14159265358979323846;
    const double step = 2.0 * pi / SPC_GRAZE_BAND_STEPS;
    bool any = false;
    *lo = INFINITY;
    *hi = -INFINITY;
    for (int k = 0; k < sc->nemitters; ++k) {
        const spc_emitter *e = sc->emitters[k];
        if (e->type != SPC_EMITTER_AREA || e->shape_index < 0 || e->shape_index >= sc->nshapes)
            continue;
        const spc_shape *ls = sc->shapes[e->shape_index];
        spc_vec3 lc = spc_scale(spc_add(ls->bbox_min, ls->bbox_max), 0.5);
        double lr = 0.5 * spc_length(spc_sub(ls->bbox_max, ls->bbox_min));
        for (int j = 0; j < SPC_GRAZE_BAND_STEPS; ++j) {
            double psi = (j + 0.5) * step;
            spc_vec3 n = spc_add(spc_scale(e1, cos(psi)), spc_scale(e2, sin(psi)));
            spc_vec3 w0 = spc_add(c->o, spc_scale(n, c->radius));
            spc_vec3 v0 = spc_sub(lc, w0);
            spc_vec3 vh = spc_sub(v0, spc_scale(c->a, spc_dot(v0, c->a)));
            double dh = spc_length(vh);
            if (!(dh > lr))
                return false;
            /* the angle between the horizontal direction to the light and the wall's tangent */
            double gamma = asin(spc_min(1.0, fabs(spc_dot(vh, n)) / dh));
            if (gamma > alpha + asin(lr / dh) + step)
                continue;
            for (int end = 0; end < 2; ++end) {
                spc_vec3 v = end ? spc_sub(v0, spc_scale(c->a, c->len)) : v0;
                double va = spc_dot(v, c->a), dist = spc_length(v);
                double el = atan2(va, dh), half = asin(spc_min(1.0, lr / dist));
                *lo = spc_min(*lo, el - half - step);
                *hi = spc_max(*hi, el + half + step);
                any = true;
            }
        }
    }
    return any;
}

bool spc_path_graze_init(spc_path_graze *g, const spc_scene *sc)
{
    g->n = 0;
    for (int i = 0; i < sc->nshapes && g->n < SPC_GRAZE_MAX_CYLINDERS; ++i) {
        const spc_shape *s = sc->shapes[i];
        if (!spc_cylinder_chain_shape(s))
            continue;
        spc_graze_cylinder *c = &g->c[g->n];
        c->shape = s;
        c->o = spc_mat4_apply_point(&s->to_world, spc_v3(0, 0, 0));
        spc_vec3 A = spc_mat4_apply_vector(&s->to_world, spc_v3(0, 0, 1));
        spc_vec3 e1 = spc_mat4_apply_vector(&s->to_world, spc_v3(1, 0, 0));
        spc_vec3 e2 = spc_mat4_apply_vector(&s->to_world, spc_v3(0, 1, 0));
        c->len = spc_length(A);
        c->radius = spc_length(e1);
        double tol = 1e-9 * c->radius;
        /* a circular section normal to the axis only */
        if (!(c->len > 0.0 && c->radius > 0.0) || fabs(spc_length(e2) - c->radius) > tol ||
            fabs(spc_dot(e1, e2)) > tol * c->radius || fabs(spc_dot(e1, A)) > tol * c->len ||
            fabs(spc_dot(e2, A)) > tol * c->len)
            continue;
        c->a = spc_scale(A, 1.0 / c->len);
        e1 = spc_scale(e1, 1.0 / c->radius);
        e2 = spc_scale(e2, 1.0 / c->radius);
        double lo, hi;
        if (!elevation_band(sc, c, e1, e2, SPC_GRAZE_ALPHA_CAP, &lo, &hi) || !(lo > 0.0 || hi < 0.0))
            continue;
        /* a chain of SPC_GRAZE_MIN_REFLECTIONS has that many less one whole chords between its first
         * and last wall points, each climbing 2 R sin(alpha) tan|theta|, all within the wall's
         * length: the grazing angles it can have */
        double t = spc_min(fabs(tan(lo)), fabs(tan(hi)));
        double sa = c->len / (2.0 * (SPC_GRAZE_MIN_REFLECTIONS - 1) * c->radius * t);
        c->alpha_max = spc_min(SPC_GRAZE_ALPHA_CAP, asin(spc_min(1.0, sa)));
        if (!elevation_band(sc, c, e1, e2, c->alpha_max, &lo, &hi) || !(lo > 0.0 || hi < 0.0))
            continue;
        c->theta_lo = spc_max(lo, -0.5 * 3.14159265358979323846 + 1e-6);
        c->theta_hi = spc_min(hi, 0.5 * 3.14159265358979323846 - 1e-6);
        c->eps_max = c->radius * (1.0 - cos(c->alpha_max));
        g->n++;
    }
    return g->n > 0;
}

bool spc_path_graze_enabled(const spc_render_ctx *ctx, bool lg_enabled)
{
    return ctx->graze && ctx->kind == SPC_INTEGRATOR_PATH && ctx->specular_nee != SPC_SNEE_NONE && !lg_enabled;
}

/* The receiver's frame toward cylinder c: the unit radial direction u (toward the wall), the
 * tangent t = a x u and the largest turn beta_max; false where x is not inside c within eps_max of
 * its wall, between its ends. */
typedef struct graze_frame {
    spc_vec3 u, t;
    double beta_max;
} graze_frame;

static bool frame_at(const spc_graze_cylinder *c, spc_vec3 x, graze_frame *f)
{
    spc_vec3 rel = spc_sub(x, c->o);
    double h = spc_dot(rel, c->a);
    if (h < -1e-4 * c->len || h > c->len)
        return false;
    spc_vec3 r = spc_sub(rel, spc_scale(c->a, h));
    double rr = spc_length(r);
    double eps = c->radius - rr;
    if (!(eps > 0.0 && eps < c->eps_max) || !(rr > 0.0))
        return false;
    /* the ray's distance to the axis, rr cos(beta), is kept; its grazing angle at the wall is
     * acos(rr cos(beta) / R), below alpha_max for |beta| below beta_max */
    double cb = cos(c->alpha_max) * c->radius / rr;
    if (!(cb < 1.0))
        return false;
    f->beta_max = acos(cb);
    f->u = spc_scale(r, 1.0 / rr);
    f->t = spc_cross(c->a, f->u);
    return f->beta_max > 0.0;
}

/* The receiver x's cylinder (the first whose frame holds it), or -1. */
static int cylinder_at(const spc_path_graze *g, spc_vec3 x, graze_frame *f)
{
    for (int i = 0; i < g->n; ++i)
        if (frame_at(&g->c[i], x, f))
            return i;
    return -1;
}

static double band_pdf(const spc_graze_cylinder *c, const graze_frame *f, double theta)
{
    return 1.0 / (4.0 * f->beta_max * (c->theta_hi - c->theta_lo) * cos(theta));
}

/* p_g of direction d at a receiver in frame f of cylinder c. */
static double graze_pdf(const spc_graze_cylinder *c, const graze_frame *f, spc_vec3 d)
{
    double sa = spc_dot(d, c->a);
    double theta = asin(spc_clamp(sa, -1.0, 1.0));
    if (!(theta >= c->theta_lo && theta <= c->theta_hi))
        return 0.0;
    spc_vec3 hd = spc_sub(d, spc_scale(c->a, sa));
    double ct = spc_dot(hd, f->t), cu = spc_dot(hd, f->u);
    double beta = atan2(cu, fabs(ct));
    if (!(fabs(beta) <= f->beta_max))
        return 0.0;
    return band_pdf(c, f, theta);
}

double spc_path_graze_pdf(const spc_path_graze *g, const spc_hit *x, spc_vec3 d)
{
    graze_frame f;
    int ci = cylinder_at(g, x->p, &f);
    return ci < 0 ? 0.0 : graze_pdf(&g->c[ci], &f, d);
}

/* The draw at x in frame f of cylinder c: a side, a turn, an elevation. */
static spc_vec3 graze_draw(const spc_graze_cylinder *c, const graze_frame *f, spc_rng *rng, double *pdf)
{
    double side = spc_rng_next(rng) < 0.5 ? 1.0 : -1.0;
    double beta = (2.0 * spc_rng_next(rng) - 1.0) * f->beta_max;
    double theta = c->theta_lo + spc_rng_next(rng) * (c->theta_hi - c->theta_lo);
    spc_vec3 hd = spc_add(spc_scale(f->t, side * cos(beta)), spc_scale(f->u, sin(beta)));
    *pdf = band_pdf(c, f, theta);
    return spc_add(spc_scale(hd, cos(theta)), spc_scale(c->a, sin(theta)));
}

bool spc_path_graze_sample(const spc_path_graze *g, const spc_hit *x, spc_rng *rng, spc_vec3 *d, double *pdf)
{
    graze_frame f;
    int ci = cylinder_at(g, x->p, &f);
    if (ci < 0)
        return false;
    *d = graze_draw(&g->c[ci], &f, rng, pdf);
    return true;
}

spc_rgb spc_path_graze_estimate(const spc_render_ctx *ctx, const spc_hit *h, spc_vec3 wo, int segments, spc_rng *rng)
{
    const spc_path_graze *g = ctx->graze;
    const spc_rgb zero = spc_rgb1(0.0);
    graze_frame f;
    int ci = cylinder_at(g, h->p, &f);
    if (ci < 0)
        return zero;
    /* the reflections the depth left allows: the light is met at segment segments + k + 1 */
    int kmax = SPC_GRAZE_MAX_REFLECTIONS;
    if (ctx->max_depth >= 0 && ctx->max_depth - segments - 1 < kmax)
        kmax = ctx->max_depth - segments - 1;
    if (kmax < SPC_GRAZE_MIN_REFLECTIONS)
        return zero;
    const spc_graze_cylinder *c = &g->c[ci];
    double pg;
    spc_vec3 d = graze_draw(c, &f, rng, &pg);
    if (ctx->strict_normals && !(spc_dot(d, h->ng) * spc_dot(d, h->sh.n) > 0.0))
        return zero;
    double pb;
    spc_rgb fr = spc_bsdf_eval_pdf(h->bsdf, h, SPC_MODE_RADIANCE, wo, d, &pb);
    double cosi = spc_absdot(d, h->sh.n);
    if (spc_rgb_is_black(fr) || !(cosi > 0.0))
        return zero;
    spc_rgb T = spc_rgb_scale(fr, cosi / pg);
    spc_ray ray = spc_hit_spawn(h, d);
    for (int k = 0;; ++k) {
        spc_hit w;
        if (!spc_scene_intersect(ctx->scene, &ray, &w))
            return zero;
        spc_vec3 wi = spc_neg(ray.d);
        if (w.emitter) {
            if (k < SPC_GRAZE_MIN_REFLECTIONS || k > kmax || w.emitter->type != SPC_EMITTER_AREA)
                return zero;
            spc_rgb Le = spc_emitter_eval_area(w.emitter, &w, wi);
            return spc_rgb_scale(spc_rgb_mul(T, Le), spc_mis_power(pg, pb));
        }
        if (w.shape != c->shape || k >= kmax)
            return zero;
        if (ctx->strict_normals && spc_dot(wi, w.ng) * spc_dot(wi, w.sh.n) < 0.0)
            return zero;
        spc_bsdf_sample bs;
        if (!spc_bsdf_sample_dir(w.bsdf, &w, SPC_MODE_RADIANCE, wi, 0.5, spc_v2(0.5, 0.5), &bs) ||
            bs.lobe != SPC_LOBE_DELTA_REFLECTION)
            return zero;
        if (ctx->strict_normals && !(spc_dot(bs.wi, w.ng) * spc_dot(bs.wi, w.sh.n) > 0.0))
            return zero;
        T = spc_rgb_mul(T, bs.weight);
        if (spc_rgb_is_black(T))
            return zero;
        ray = spc_hit_spawn(&w, bs.wi);
    }
}

void spc_path_graze_scattered(const spc_render_ctx *ctx, spc_graze_track *t, const spc_hit *h, spc_vec3 wo,
                              spc_vec3 wi, unsigned lobe, bool guided)
{
    if (lobe & SPC_LOBE_DELTA) {
        if (!t->live)
            return;
        if (h->shape != ctx->graze->c[t->cyl].shape || lobe != SPC_LOBE_DELTA_REFLECTION ||
            ++t->k > SPC_GRAZE_MAX_REFLECTIONS)
            t->live = false;
        return;
    }
    t->live = false;
    if (guided)
        return;
    graze_frame f;
    int ci = cylinder_at(ctx->graze, h->p, &f);
    if (ci < 0)
        return;
    double pg = graze_pdf(&ctx->graze->c[ci], &f, wi);
    if (!(pg > 0.0))
        return;
    t->live = true;
    t->cyl = ci;
    t->k = 0;
    t->pg = pg;
    t->pb = spc_bsdf_pdf(h->bsdf, h, SPC_MODE_RADIANCE, wo, wi);
}

double spc_path_graze_bsdf_weight(const spc_render_ctx *ctx, const spc_graze_track *t, const spc_hit *h)
{
    (void)ctx;
    if (!t->live || t->k < SPC_GRAZE_MIN_REFLECTIONS || t->k > SPC_GRAZE_MAX_REFLECTIONS || !h->emitter ||
        h->emitter->type != SPC_EMITTER_AREA)
        return 1.0;
    return spc_mis_power(t->pb, t->pg);
}
