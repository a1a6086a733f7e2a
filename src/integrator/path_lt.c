/*
 * integrator/path_lt.c: light-traced caustics of point and area lights seen directly, through the
 * glass sphere and through a diffuse bounce, for the path tracer (path_lt.h): the light subpath, its
 * joins to the pinhole, and the density ratio that weighs them against specular NEE (and, for area
 * lights, BSDF sampling) at the caustic's receiver (Veach 1997, ch. 9 and
 * 10.2: the power heuristic over two strategies of one path; bdpt's t = 1 join). At its end the
 * light guides: area lights' light through chains longer than any specular NEE makes, joined to
 * the pinhole at the first other surface and weighed against BSDF sampling there alone.
 */
#include "integrator/path_lt.h"

#include <string.h>

#include "integrator/splat.h"
#include "manifold/caustic_guide.h"
#include "manifold/cylinder_chains.h"
#include "manifold/fit_seeds.h"
#include "manifold/flat_chains.h"
#include "manifold/plane_chains.h"
#include "manifold/snee_cost.h"
#include "manifold/specular_nee.h"
#include "manifold/sphere_chains.h"
#include "scene/sdf.h"

/* The share of light subpaths joined to the pinhole through the sphere (p->lt_through, else the
 * default). */
static double through_share(const spc_snee_params *p)
{
    return p->lt_through > 0.0 && p->lt_through <= 1.0 ? p->lt_through : SPC_PATH_LT_THROUGH_SHARE;
}

/* The share of light subpaths joined to the pinhole through the sphere by chains longer than
 * max_chain (p->lt_long, else the default). */
static double long_share(const spc_snee_params *p)
{
    return p->lt_long > 0.0 && p->lt_long <= 1.0 ? p->lt_long : SPC_PATH_LT_LONG_SHARE;
}

/* The longest chain through flat faces from x2 toward the pinhole that a point light's joins take
 * (params.lt_slab_max; 0: none, ltslab off). */
static int slab_max(const spc_snee_params *p)
{
    if (!p->lt_slab)
        return 0;
    return p->lt_slab_max >= 1 && p->lt_slab_max <= SPC_FLAT_MAX_VERTICES ? p->lt_slab_max : 2;
}

/* Is the camera's chain cc from x toward the pinhole one that a point light's joins take through
 * flat faces (with ltslab): one of spc_flat_chains_all's chains (spc_flat_chain_covers with the
 * parameters' reflect) of at most slab_max vertices? Both sides read it, so the joins solve from x
 * exactly the chains the path tracer's side weighs against them. */
static bool slab_camera_chain(const spc_snee_params *p, const spc_chain *cc)
{
    return p->exact && cc->n >= 1 && cc->n <= slab_max(p) && spc_flat_chain_covers(cc, p->reflect) &&
           !spc_sphere_chain_covers(cc, p->reflect);
}

/* The unmapped normal N and the map's normal n (not turned) at h, a hit on a normal-mapped plane
 * (spc_plane_chain_shape), plain or a chain's mapped one: n is read from the map again, from below
 * N, where no turn applies. False where the map cannot be read. */
static bool plane_normals(const spc_hit *h, spc_vec3 *N, spc_vec3 *n)
{
    spc_hit m = *h;
    if (h->normal_mapped) {
        m.sh = spc_frame_from_ns(h->n_unmapped, h->sh.s);
        m.normal_mapped = false;
    }
    *N = m.sh.n;
    if (!spc_bsdf_map_chain_hit(&m, spc_neg(*N)))
        return false;
    *n = m.sh.n;
    return true;
}

/* Does the BSDF at h, a hit on a normal-mapped plane (spc_plane_chain_shape), turn the map's normal
 * for a viewer in the direction w (spc_bsdf_perturbed_face_view: w above the unmapped normal N but
 * below the map's n)? The path tracer's frame at a vertex is the one its camera-side direction
 * sees, a chain's (spc_chain_trace, the plane's enumeration) the one its x-side direction sees and a
 * light subpath's the one its light-side direction sees; the three agree wherever neither of the
 * vertex's two directions turns the normal. True where the map cannot be read
 * (plane_normals). */
static bool plane_turns(const spc_hit *h, spc_vec3 w)
{
    spc_vec3 N, n;
    if (!plane_normals(h, &N, &n))
        return true;
    return spc_dot(w, N) > 0.0 && spc_dot(w, n) < 0.0;
}

/* The adjoint's correction for the map's shading normal at a delta vertex h on a normal-mapped plane
 * that a light subpath (or a join's flux) crosses from the side of w_prev (toward the light) to the
 * side of w_next: |w_prev.n| |w_next.N| / (|w_prev.N| |w_next.n|), n the map's normal, N the plane's
 * (Veach 1997, sec. 5.3, as shading_fix at a diffuse vertex). The refraction law about n maps the
 * rays' measure cos dA dw about n, while the flux and the joins' geometry count it about the plane:
 * without it light tracing's estimate through the water differs from the path tracer's (whose
 * radiance weights need none) by the two vertices' factors, most at the far water seen obliquely.
 * Where neither direction turns the map's normal (plane_turns), both sides' frames are n's. */
static double plane_shading_fix(const spc_hit *h, spc_vec3 w_prev, spc_vec3 w_next)
{
    spc_vec3 N, n;
    if (!plane_normals(h, &N, &n))
        return 0.0;
    return spc_bsdf_shading_adjoint(w_prev, w_next, N, n);
}

/* The radiance transport's n^2 factor at a delta vertex h on a normal-mapped plane, the camera's
 * side toward wo, the light's toward wi: (n_wo / n_wi)^2 for a refraction (radiance grows entering
 * the denser medium), 1 for a reflection; read as the ratio of the two transport modes'
 * throughputs, which differ by that factor alone. 1 where the throughput is zero. */
static double plane_radiance_n2(const spc_hit *h, spc_vec3 wo, spc_vec3 wi)
{
    spc_rgb a = spc_bsdf_specular_throughput(h->bsdf, h, SPC_MODE_RADIANCE, wo, wi);
    spc_rgb b = spc_bsdf_specular_throughput(h->bsdf, h, SPC_MODE_IMPORTANCE, wo, wi);
    double sb = b.r + b.g + b.b;
    return sb > 0.0 ? (a.r + a.g + a.b) / sb : 1.0;
}

/* The joins' value of a light path whose normal-mapped planes' vertices (the subpath's and the
 * join's chain toward the pinhole) carry the radiance transport's n^2 factors with the product n2,
 * (n_camera / n_light)^2 where the path crosses water once: the light subpath carries flux, which a
 * crossing does not scale (the importance transport's weight), and the joins' geometry terms are
 * those of the media the path runs through, so that the radiance factors of a path that crosses
 * into the water and out again (n2 1: the camera above the water) are the ones the chain's
 * geometry term from x2 leaves out, and one unpaired crossing (the camera under the water) is
 * divided out. C unchanged where n2 is 1 (up to rounding). */
static spc_rgb plane_flux_value(spc_rgb C, double n2)
{
    return fabs(n2 - 1.0) > 1e-9 && n2 > 0.0 ? spc_rgb_scale(C, 1.0 / n2) : C;
}

/* Is some vertex of the chain c on a normal-mapped plane one where either of its two directions turns
 * the map's normal (plane_turns)? Light tracing neither makes nor weighs such paths: its subpath's
 * frame there, or the camera's, is not the one the chain's was solved in. */
static bool plane_chain_turned(const spc_chain *c)
{
    for (int i = 0; i < c->n; ++i) {
        const spc_chain_vertex *v = &c->v[i];
        if (spc_plane_chain_shape(v->h.shape) && (plane_turns(&v->h, spc_neg(v->wi)) || plane_turns(&v->h, v->d)))
            return true;
    }
    return false;
}

/* Is the camera's chain cc from x toward the pinhole one that an area light's joins take through a
 * normal-mapped plane (a floor seen through water): one vertex on such a plane, one of
 * spc_plane_chains_all's (with exact enumeration)? */
static bool plane_camera_chain(const spc_snee_params *p, const spc_chain *cc)
{
    return p->exact && cc->n == 1 && spc_plane_chain_covers(cc, p->reflect);
}

/* The share of light subpaths joined to the pinhole through the sphere by the chain cc from x2:
 * through_share for chains within the parameters' max_chain, long_share beyond; 1 for a chain
 * through flat faces (slab_camera_chain) or through a normal-mapped plane (plane_camera_chain). */
static double camera_chain_share(const spc_snee_params *p, const spc_chain *cc)
{
    if (slab_camera_chain(p, cc) || plane_camera_chain(p, cc))
        return 1.0; /* on every subpath (join_slab, join_plane) */
    return cc->n > p->max_chain ? long_share(p) : through_share(p);
}

/* The adjoint BSDF's correction for shading normals (Veach 1997, sec. 5.3), with a normal or bump
 * map's normal where the hit has one (spc_bsdf_adjoint_factor), as bdpt's. */
static double shading_fix(const spc_hit *h, spc_vec3 wo, spc_vec3 wi) { return spc_bsdf_adjoint_factor(h, wo, wi); }

static bool in_window(const spc_render_ctx *ctx, double fx, double fy)
{
    return fx >= ctx->crop_x && fx < ctx->crop_x + ctx->width && fy >= ctx->crop_y && fy < ctx->crop_y + ctx->height;
}

bool spc_path_lt_enabled(const spc_render_ctx *ctx, const spc_snee_params *p)
{
    return p->lt_caustic && ctx->kind == SPC_INTEGRATOR_PATH && ctx->specular_nee != SPC_SNEE_NONE && p->exact &&
           !(p->guide > 0.0) && !ctx->strict_normals && !(p->solver == SPC_SNEE_NEWTON && p->newton.rough) &&
           spc_camera_connectible(ctx->cam) && !(p->receivers > 0 && p->receivers <= 1);
}

int spc_path_lt_budget(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, int segments,
                       int receivers)
{
    /* as spc_path_snee_at_vertex and spc_specular_nee_depth compute it */
    int cap = ctx->specular_max_chain;
    int left = ctx->max_depth >= 0 && ctx->max_depth - segments - 1 < cap ? ctx->max_depth - segments - 1 : cap;
    int b = spc_snee_budget_params(p, x2, left);
    if (b <= 0 || (p->receivers > 0 && receivers >= p->receivers))
        return 0;
    if (b > p->max_chain)
        b = p->max_chain;
    return spc_snee_budget(x2, b, p->any_surface);
}

/* The longest chain through flat faces the path's track follows past the budget with depth_left
 * vertices left (spc_snee_track_long_max; the path runs it with MIS, which area lights' light tracing
 * needs: spc_path_lt_area_enabled). */
static int flat_walk_max(const spc_snee_params *p, int depth_left)
{
    spc_snee_params pm = *p;
    pm.mis = true;
    return spc_snee_track_long_max(&pm, depth_left);
}

int spc_path_lt_flat_budget(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, int segments,
                            int receivers)
{
    int b = spc_path_lt_budget(ctx, p, x2, segments, receivers);
    if (b <= 0)
        return 0;
    /* the path's track past the budget, as spc_path_snee_at_vertex starts it at x2 */
    int left = ctx->max_depth >= 0 && ctx->max_depth - segments - 1 < SPC_CHAIN_MAX_VERTICES
                   ? ctx->max_depth - segments - 1
                   : SPC_CHAIN_MAX_VERTICES;
    int l = flat_walk_max(p, left);
    return l > b ? l : b;
}

/* Is s a mirror ball (a sphere with a smooth conductor)? */
static bool mirror_ball(const spc_shape *s)
{
    return s && s->type == SPC_SHAPE_SPHERE && s->bsdf && s->bsdf->type == SPC_BSDF_CONDUCTOR;
}

/* Is s a glass caster (a shape with a smooth dielectric)? */
static bool glass_shape(const spc_shape *s) { return s && s->bsdf && s->bsdf->type == SPC_BSDF_DIELECTRIC; }

/* Is the chain c (from x2 toward an area light) the light off a mirror ball through glass: its last
 * vertex (the light's side) a reflection off a mirror ball, every other vertex (at least two) on one
 * glass shape (a glass ball, a cube), no reflection inside the glass unless params.reflect?
 * Specular NEE finds such chains by its longer chains' randomized attempts alone (more vertices
 * than the budget), counted by trials with a stand-in psi, and where the mirror's image of the
 * light is focused by the glass onto a wall both their counts and BSDF sampling's values are large
 * and rare (bench/RESULTS.md, "The real solve probability for the light off a mirror through
 * glass"); light tracing's density is high exactly there. Its weights, as the tessellated ball's,
 * come from spc_snee_receiver_weights on every side and need no exact count. */
static bool mirror_glass_chain(const spc_snee_params *p, const spc_chain *c)
{
    int k = c->n;
    if (k < 3 || !mirror_ball(c->v[k - 1].h.shape) || c->v[k - 1].event != SPC_CHAIN_REFLECT)
        return false;
    const spc_shape *g = c->v[0].h.shape;
    if (!glass_shape(g))
        return false;
    for (int i = 0; i < k - 1; ++i)
        if (c->v[i].h.shape != g || (!p->reflect && c->v[i].event == SPC_CHAIN_REFLECT))
            return false;
    return true;
}

int spc_path_lt_area_chain_max(const spc_snee_params *p, const spc_chain *c, int kmax, int kflat)
{
    return ((p->exact && spc_flat_chain_faces(c, p->reflect)) || mirror_glass_chain(p, c)) && kflat > kmax ? kflat
                                                                                                           : kmax;
}

/* The cone from the point y toward the casters' bounding sphere: its axis and cosine (cos_max -1:
 * the whole sphere of directions, y inside the bound). False without casters. */
static bool caster_cone(const spc_scene *sc, bool any_surface, spc_vec3 y, spc_vec3 *axis, double *cos_max)
{
    const spc_chain_casters *cs = spc_chain_casters_of(sc, any_surface);
    if (!cs || cs->n == 0 || !(cs->radius > 0.0))
        return false;
    spc_vec3 a = spc_sub(cs->center, y);
    double D = spc_length(a);
    if (!(D > cs->radius)) {
        *axis = spc_v3(0, 0, 1);
        *cos_max = -1.0;
        return true;
    }
    *axis = spc_scale(a, 1.0 / D);
    double s = cs->radius / D;
    *cos_max = sqrt(spc_max(0.0, 1.0 - s * s));
    return true;
}

/* The emission's direction density of w (unit, from the light at y). */
static double cone_pdf(const spc_scene *sc, bool any_surface, spc_vec3 y, spc_vec3 w)
{
    spc_vec3 axis;
    double cm;
    if (!caster_cone(sc, any_surface, y, &axis, &cm))
        return 0.0;
    if (cm > -1.0 && spc_dot(w, axis) < cm)
        return 0.0;
    return 1.0 / (2.0 * SPC_PI * (1.0 - cm));
}

/* The most mirror balls an area light's subpaths aim at. */
#define MIRROR_AIMS 8

/* The mirror balls among the casters that an area light's subpaths aim a share of their directions
 * at (SPC_PATH_LT_MIRROR_SHARE): where a glass caster is there too and the subpath follows chains
 * past the budget (the longer chains' pass on: mirror_glass_chain's joins). At most max to out; 0
 * elsewhere, where the directions are the casters' cone alone. */
static int mirror_aims(const spc_scene *sc, const spc_snee_params *p, const spc_shape **out, int max)
{
    const spc_chain_casters *cs = spc_chain_casters_of(sc, p->any_surface);
    if (!cs || flat_walk_max(p, SPC_CHAIN_MAX_VERTICES) <= p->max_chain)
        return 0;
    int n = 0;
    bool glass = false;
    for (int i = 0; i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        glass = glass || glass_shape(s);
        if (mirror_ball(s) && n < max)
            out[n++] = s;
    }
    return glass ? n : 0;
}

/* The direction at (u1, u2) uniform over the cone of directions around axis with cosine at least cm
 * (density 1 / (2 pi (1 - cm))). */
static spc_vec3 cone_direction(spc_vec3 axis, double cm, double u1, double u2)
{
    double ct = 1.0 - u1 * (1.0 - cm), st = sqrt(spc_max(0.0, 1.0 - ct * ct)), phi = 2.0 * SPC_PI * u2;
    spc_frame fa = spc_frame_from_n(axis);
    return spc_normalize(
        spc_add(spc_add(spc_scale(fa.s, st * cos(phi)), spc_scale(fa.t, st * sin(phi))), spc_scale(fa.n, ct)));
}

/* The cosine of the cone from y around the sphere (c, r), its axis in *axis; false with y inside. */
static bool sphere_cone(spc_vec3 y, spc_vec3 c, double r, spc_vec3 *axis, double *cos_max)
{
    spc_vec3 a = spc_sub(c, y);
    double D = spc_length(a);
    if (!(D > r))
        return false;
    *axis = spc_scale(a, 1.0 / D);
    *cos_max = sqrt(spc_max(0.0, 1.0 - (r / D) * (r / D)));
    return true;
}

/* The direction density of an area light's subpath at y toward w (area_start's): the cone toward
 * the casters, mixed with the cones toward the mirror balls (mirror_aims) on a share
 * SPC_PATH_LT_MIRROR_SHARE. */
static double area_dir_pdf(const spc_scene *sc, const spc_snee_params *p, spc_vec3 y, spc_vec3 w)
{
    double pdf = cone_pdf(sc, p->any_surface, y, w);
    const spc_shape *balls[MIRROR_AIMS];
    int nb = mirror_aims(sc, p, balls, MIRROR_AIMS);
    if (nb == 0)
        return pdf;
    double pb = 0.0;
    for (int i = 0; i < nb; ++i) {
        spc_vec3 axis;
        double cm;
        if (sphere_cone(y, balls[i]->center, balls[i]->radius, &axis, &cm) && spc_dot(w, axis) >= cm)
            pb += 1.0 / (2.0 * SPC_PI * (1.0 - cm));
    }
    return (1.0 - SPC_PATH_LT_MIRROR_SHARE) * pdf + SPC_PATH_LT_MIRROR_SHARE * pb / nb;
}

/* Is every vertex of the chain c on one tessellated glass ball (a triangle mesh with a fitted
 * sphere, fit_seeds.h, dielectric), with c's start x outside it and no reflection unless
 * params.reflect? Specular NEE finds such chains by its randomized attempts and the fitted sphere's
 * seeds, not by an exact enumeration. */
static bool mesh_ball_chain(const spc_snee_params *p, const spc_chain *c)
{
    if (c->n < 1)
        return false;
    const spc_shape *s = c->v[0].h.shape;
    spc_vec3 fc;
    double fr;
    if (!s || s->type != SPC_SHAPE_MESH || !s->bsdf || s->bsdf->type != SPC_BSDF_DIELECTRIC ||
        !spc_fit_sphere(s, &fc, &fr) || !(spc_distance(c->x, fc) > fr))
        return false;
    for (int i = 0; i < c->n; ++i)
        if (c->v[i].h.shape != s || (!p->reflect && c->v[i].event == SPC_CHAIN_REFLECT))
            return false;
    return true;
}

/* Is the chain c (from x2 toward a point light) one whose paths light tracing makes: one glass
 * sphere's or through flat faces only (glass slabs; both with exact enumeration), or a tessellated
 * glass ball's (mesh_ball_chain)? For the flat faces specular NEE's density carries the probability
 * of its enumeration's pass (point_psi). For the ball, specular NEE's estimate of each chain's value
 * is unbiased but not an enumeration (the fitted sphere's seeds, randomized attempts counted by
 * their trials): the weights need only be the same function of the path on both sides, so both
 * sides take the ratio below with specular NEE's density that of an exact count (the query's
 * roulette alone). */
static bool point_chain_covers(const spc_snee_params *p, const spc_chain *c)
{
    if (!p->exact || c->n < 1)
        return false;
    return spc_sphere_chain_covers(c, p->reflect) || spc_flat_chain_covers(c, p->reflect) || mesh_ball_chain(p, c);
}

/* The depth left after `segments` path segments for the longer chains (specular NEE's long_max at
 * a receiver there, as spc_path_snee_at_vertex passes it). */
static int long_left(const spc_render_ctx *ctx, int segments)
{
    return ctx->max_depth >= 0 && ctx->max_depth - segments - 1 < SPC_CHAIN_MAX_VERTICES ? ctx->max_depth - segments - 1
                                                                                         : SPC_CHAIN_MAX_VERTICES;
}

int spc_path_lt_point_flat_budget(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, int segments,
                                  int receivers)
{
    int b = spc_path_lt_budget(ctx, p, x2, segments, receivers);
    if (b <= 0 || !p->exact)
        return b > 0 ? b : 0;
    int l = long_left(ctx, segments);
    if (l > SPC_FLAT_MAX_VERTICES)
        l = SPC_FLAT_MAX_VERTICES;
    return l > b ? l : b;
}

/* The probability with which specular NEE's query at x2 (reached as spc_path_lt_budget's x2)
 * enumerates the point light's chain c through flat faces (spc_snee_flat_psi with its budget and
 * depth left there): the factor of specular NEE's density that light tracing's ratio of such a path
 * (spc_path_lt_ratio_via, spc_path_lt_ratio_first) leaves out; 0 where it never does (the path is
 * light tracing's alone); 1 for any other chain. */
static double point_psi(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, int segments,
                        int receivers, const spc_chain *c)
{
    if (!p->exact || !spc_flat_chain_covers(c, p->reflect))
        return 1.0;
    return spc_snee_flat_psi(p, spc_path_lt_budget(ctx, p, x2, segments, receivers), long_left(ctx, segments), c->n);
}

/* Is e a light at a point whose caustics light tracing makes (a point light, or a spot light: the
 * same subpaths, their throughput its intensity toward the subpath's direction)? */
static bool point_like(const spc_emitter *e)
{
    return e->type == SPC_EMITTER_POINT || e->type == SPC_EMITTER_SPOT;
}

/* Light tracing's density of the chain c from x toward the point or spot light e, in area measure
 * at x: the emission's direction density (the cone toward the casters, whatever a spot's beam),
 * the chain's lobe choices and |dw0/dA(x)| = cos(x) G. */
static double light_density(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, const spc_chain *c,
                            const spc_emitter *e)
{
    int k = c->n;
    if (!e || !point_like(e) || k < 1 || !point_chain_covers(p, c))
        return 0.0;
    spc_vec3 d_last = c->v[k - 1].d;
    double G = spc_chain_geometry(c, e->position, spc_neg(d_last));
    double P = 1.0;
    for (int i = 0; i < k; ++i) {
        const spc_chain_vertex *v = &c->v[i];
        P *= spc_bsdf_specular_prob(v->h.bsdf, &v->h, spc_neg(v->wi), v->d);
    }
    return cone_pdf(sc, p->any_surface, e->position, spc_neg(d_last)) * P * spc_absdot(c->d0, x->ng) * G;
}

/* The probability of specular NEE's query at x: the roulette of the path's first receiver
 * (first_p) or of a later one (later_p). */
static double query_prob(const spc_scene *sc, const spc_snee_params *p, spc_vec3 x, bool first)
{
    spc_snee_params pq = *p;
    pq.query_p = first ? spc_snee_first_prob(sc, p, x) : spc_snee_later_prob(sc, p, x);
    return spc_snee_query_prob(&pq);
}

static double ratio_of(double num, double den)
{
    if (!(num > 0.0) || !(den > 0.0))
        return 0.0;
    double r = num / den;
    return isfinite(r) ? r : 0.0;
}

double spc_path_lt_ratio(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x1, spc_vec3 w1,
                         const spc_hit *x2, spc_vec3 w2, const spc_chain *c, const spc_emitter *e)
{
    return spc_path_lt_ratio_via(ctx, p, x1, w1, NULL, 0, x2, w2, c, e);
}

double spc_path_lt_ratio_via(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x1, spc_vec3 w1,
                             const spc_path_lt_vertex *mid, int nmid, const spc_hit *x2, spc_vec3 w2,
                             const spc_chain *c, const spc_emitter *e)
{
    const spc_scene *sc = ctx->scene;
    /* the camera's density of x1 per camera sample (bdpt's t = 1: We / N, to area) */
    spc_camera_direct cd;
    if (!spc_camera_sample_direct(ctx->cam, x1->p, &cd) || !in_window(ctx, cd.fx, cd.fy))
        return 0.0;
    double p_cam = cd.We / ((double)ctx->width * (double)ctx->height) * spc_absdot(cd.wi, x1->ng) / (cd.dist * cd.dist);
    double p1 = spc_bsdf_pdf(x1->bsdf, x1, SPC_MODE_RADIANCE, cd.wi, w1);
    double cos1 = spc_absdot(w1, x1->ng);
    double p2 = spc_bsdf_pdf(x2->bsdf, x2, SPC_MODE_IMPORTANCE, c->d0, w2);
    double cos2 = spc_absdot(w2, x2->ng);
    double q = query_prob(sc, p, x2->p, false);
    double num = light_density(sc, p, x2, c, e) * p2 * cos1, den = q * cos2 * p1 * p_cam;
    for (int i = 0; i < nmid; ++i) {
        const spc_path_lt_vertex *v = &mid[i];
        num *= spc_bsdf_pdf(v->h.bsdf, &v->h, SPC_MODE_IMPORTANCE, v->b, v->a) * spc_absdot(v->b, v->h.ng);
        den *= spc_bsdf_pdf(v->h.bsdf, &v->h, SPC_MODE_RADIANCE, v->a, v->b) * spc_absdot(v->a, v->h.ng);
    }
    return ratio_of(num, den);
}

/* The most chains of the tessellated glass balls from x2 toward the pinhole a join looks for (the
 * fitted sphere's solutions per ball). */
#define MESH_CAMERA_CHAINS SPC_FIT_MAX_DIRS

/* The chains of the tessellated glass balls (mesh_ball_chain) from x toward the pinhole, of at most
 * max_chain vertices: for each ball, specular NEE's solver seeded along each of the fitted
 * sphere's solutions toward the pinhole with that solution's events (as specular NEE seeds its
 * fitted roots toward a light), the distinct chains it converges to. A deterministic function of x
 * (no random draw: the seed and the events fixed), computed alike by light tracing's joins and by
 * the path tracer's side, so that a path through the ball toward the pinhole is light tracing's
 * to share exactly where its chain is one of these (mesh_camera_chain_found). At most max to out. */
static int mesh_camera_chains(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x, int max_chain,
                              spc_chain *out, int max)
{
    const spc_scene *sc = ctx->scene;
    const spc_chain_casters *cs = spc_chain_casters_of(sc, p->any_surface);
    const spc_specular_solver *solver = spc_specular_solver_get(p->solver);
    if (!cs || !solver || !solver->solve_one || max_chain < 1)
        return 0;
    int n = 0;
    for (int j = 0; j < cs->n && n < max; ++j) {
        const spc_shape *s = sc->shapes[cs->idx[j]];
        spc_vec3 fc;
        double fr;
        if (s->type != SPC_SHAPE_MESH || !s->bsdf || s->bsdf->type != SPC_BSDF_DIELECTRIC ||
            !spc_fit_sphere(s, &fc, &fr) || !(spc_distance(x->p, fc) > fr))
            continue;
        spc_snee_query q;
        spc_snee_query_init(&q, sc, p, x, x->ng, max_chain);
        q.y = ctx->cam->origin;
        q.ny = spc_v3(0, 0, 0);
        q.light_size = 0.0;
        spc_vec3 dir[SPC_FIT_MAX_DIRS];
        int m[SPC_FIT_MAX_DIRS];
        int nr = spc_fit_roots_of(&q, s, dir, m, SPC_FIT_MAX_DIRS);
        for (int r = 0; r < nr && n < max; ++r) {
            unsigned char ev[SPC_CHAIN_MAX_VERTICES];
            int k = spc_fit_root_events(m[r], ev);
            if (k > max_chain || k > SPC_CHAIN_MAX_VERTICES)
                continue;
            if (!p->reflect && (m[r] != 0))
                continue;
            spc_snee_query tq = q;
            tq.seed_dir = &dir[r];
            tq.events = p->reflect ? ev : NULL;
            spc_rng rng; /* unused by a fixed seed with fixed events; seeded for determinism */
            spc_rng_seed(&rng, 1, 2);
            spc_chain c;
            int it = 0;
            if (!solver->solve_one(&tq, &rng, &c, &it) || c.n < 1 || c.n > max_chain || !mesh_ball_chain(p, &c))
                continue;
            bool dup = false;
            for (int i = 0; i < n && !dup; ++i)
                dup = spc_snee_same_solution(&out[i], &c, sc->radius);
            if (!dup)
                out[n++] = c;
        }
    }
    return n;
}

/* Is the camera's chain cc from x (a tessellated ball's) one of mesh_camera_chains's there? */
static bool mesh_camera_chain_found(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x,
                                    const spc_chain *cc)
{
    spc_chain all[MESH_CAMERA_CHAINS];
    int n = mesh_camera_chains(ctx, p, x, p->max_chain, all, MESH_CAMERA_CHAINS);
    for (int i = 0; i < n; ++i)
        if (all[i].n == cc->n && spc_snee_same_solution(&all[i], cc, ctx->scene->radius))
            return true;
    return false;
}

/* The camera's density of the point x per camera sample, in area measure at x, where the camera
 * sees x directly (cc NULL) or through the chain cc from x (one glass sphere, at most max_chain
 * vertices: the chains spc_sphere_chains_all enumerates toward the pinhole); *cd the join to the
 * pinhole. 0 where the camera does not see x so. */
static double camera_density(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x, const spc_chain *cc,
                             spc_camera_direct *cd)
{
    double N = (double)ctx->width * (double)ctx->height;
    if (!cc) {
        if (!spc_camera_sample_direct(ctx->cam, x->p, cd) || !in_window(ctx, cd->fx, cd->fy))
            return 0.0;
        return cd->We / N * spc_absdot(cd->wi, x->ng) / (cd->dist * cd->dist);
    }
    int j = cc->n;
    if (j < 1 || j > spc_path_lt_camera_max_chain(p))
        return 0.0;
    if (!spc_sphere_chain_covers(cc, p->reflect) && !(j <= p->max_chain && mesh_ball_chain(p, cc)) &&
        !slab_camera_chain(p, cc) && !plane_camera_chain(p, cc))
        return 0.0;
    const spc_chain_vertex *last = &cc->v[j - 1];
    if (!spc_camera_sample_direct(ctx->cam, last->h.p, cd) || !in_window(ctx, cd->fx, cd->fy))
        return 0.0;
    /* through a normal-mapped plane: not where the camera's ray (toward the pinhole from the
     * vertex) or x's side turns the map's normal (plane_turns): the camera's frame there is not the
     * chain's, and the retraced chain of such a camera path leaves the vertex elsewhere */
    if (plane_camera_chain(p, cc) && (plane_turns(&last->h, spc_normalize(spc_sub(ctx->cam->origin, last->h.p))) ||
                                      plane_turns(&last->h, spc_neg(last->wi))))
        return 0.0;
    double G = spc_chain_geometry(cc, ctx->cam->origin, spc_neg(last->d));
    double P = 1.0;
    for (int i = 0; i < j; ++i) {
        const spc_chain_vertex *v = &cc->v[i];
        P *= spc_bsdf_specular_prob(v->h.bsdf, &v->h, spc_neg(v->wi), v->d);
    }
    return cd->We / N * spc_absdot(cc->d0, x->ng) * G * P;
}

/* spc_path_lt_ratio_first where the camera's chain cc, if a tessellated ball's, is known to be one
 * of mesh_camera_chains's at x (light tracing's joins, which take their cc from there). */
static double ratio_first(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x, const spc_chain *cc,
                          const spc_chain *c, const spc_emitter *e)
{
    spc_camera_direct cd;
    double pc = camera_density(ctx, p, x, cc, &cd);
    /* light tracing joins x to the pinhole through the sphere on a share of its subpaths only */
    double share = cc ? camera_chain_share(p, cc) : 1.0;
    return ratio_of(share * light_density(ctx->scene, p, x, c, e), query_prob(ctx->scene, p, x->p, true) * pc);
}

double spc_path_lt_ratio_first(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x,
                               const spc_chain *cc, const spc_chain *c, const spc_emitter *e)
{
    /* through a tessellated ball, light tracing joins x to the pinhole by the chains it finds
     * there only (mesh_camera_chains): the path tracer's side keeps the rest */
    if (cc && !spc_sphere_chain_covers(cc, p->reflect) && !slab_camera_chain(p, cc) &&
        !(cc->n <= p->max_chain && mesh_ball_chain(p, cc) && mesh_camera_chain_found(ctx, p, x, cc)))
        return 0.0;
    return ratio_first(ctx, p, x, cc, c, e);
}

/* ---- area lights ---- */

/* Is every vertex of the chain c on one glass SDF without creases (a dielectric SDF shape), with no
 * reflection unless params.reflect? Specular NEE finds such chains by randomized attempts weighed with
 * their sampled solve probability (solve_mis.h), not by an enumeration; light tracing's ratio for an
 * area light is against BSDF sampling alone, so, as for the tessellated ball, its three weights come
 * from spc_snee_receiver_weights on every side and need no exact count. */
static bool sdf_glass_chain(const spc_snee_params *p, const spc_chain *c)
{
    if (c->n < 1)
        return false;
    const spc_shape *s = c->v[0].h.shape;
    if (!s || s->type != SPC_SHAPE_SDF || !s->sdf || spc_sdf_has_creases(s->sdf) || !s->bsdf ||
        s->bsdf->type != SPC_BSDF_DIELECTRIC)
        return false;
    for (int i = 0; i < c->n; ++i)
        if (c->v[i].h.shape != s || (!p->reflect && c->v[i].event == SPC_CHAIN_REFLECT))
            return false;
    return true;
}

/* Is the chain c (from x2 toward an area light) one whose paths light tracing makes: one glass
 * sphere's (spc_sphere_chain_covers, with exact enumeration), through flat faces only (the slabs'
 * chains, spc_flat_chain_faces, with exact enumeration; reflections on a mirror cylinder,
 * spc_cylinder_chain_covers, with exact enumeration; up to spc_path_lt_flat_budget's length:
 * also those the enumeration leaves to BSDF sampling, longer than it goes or with a partial
 * reflection inside the glass, whose weights are then BSDF sampling's and light tracing's alone),
 * or every vertex on one tessellated glass ball (a triangle mesh with a fitted sphere, fit_seeds.h)
 * with x2 outside it, or on one glass SDF without creases (sdf_glass_chain)? The area light's ratio
 * is light tracing's density over BSDF sampling's at x2 (spc_path_lt_area_ratio), in which specular
 * NEE's density does not appear, so the ball's chains and the SDF's need no exact count, and the
 * flat chains past the budget none at every call: the three weights come from
 * spc_snee_receiver_weights on both sides, with specular NEE's own psi. */
static bool area_chain_covers(const spc_snee_params *p, const spc_chain *c)
{
    if (c->n < 1)
        return false;
    if (spc_sphere_chain_covers(c, p->reflect) || spc_flat_chain_faces(c, p->reflect) || spc_cylinder_chain_covers(c) ||
        spc_plane_chain_covers(c, p->reflect))
        return p->exact && !plane_chain_turned(c);
    return mesh_ball_chain(p, c) || sdf_glass_chain(p, c) || mirror_glass_chain(p, c);
}

/* The share of camera samples that trace an area light's subpath (p->lt_share, else the default). */
static double area_share(const spc_snee_params *p)
{
    return p->lt_share > 0.0 && p->lt_share <= 1.0 ? p->lt_share : SPC_PATH_LT_AREA_SHARE;
}

/* The path tracer's density of the continuation wi at its vertex h (wo toward the camera's side),
 * given the BSDF's density pdf_bsdf of it: with the caustic guide at receivers the path draws it
 * from the guided mixture (caustic_guide.h; spc_path_snee_guide_at), whose density is a function of
 * h, wo and wi alone, so both sides of a join's ratio read the same; else the BSDF's. gv receives
 * the guide at h (a = 0 where none). */
static double path_dir_pdf(const spc_snee_params *p, const spc_hit *h, spc_vec3 wo, spc_vec3 wi, double pdf_bsdf,
                           spc_cguide_vertex *gv)
{
    gv->a = 0.0;
    if (!p->cguide || !(p->recv_guide > 0.0))
        return pdf_bsdf;
    spc_cguide_vertex_init(gv, p->cguide, h, wo);
    return spc_cguide_mix_pdf(gv, pdf_bsdf, wi);
}

double spc_path_lt_area_ratio(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x1, spc_vec3 w1,
                              const spc_hit *x2, spc_vec3 wo2, const spc_chain *cc, const spc_chain *c,
                              const spc_emitter *e, spc_vec3 y, spc_vec3 ny)
{
    const spc_scene *sc = ctx->scene;
    int k = c->n;
    if (!e || e->type != SPC_EMITTER_AREA || k < 1 || !area_chain_covers(p, c))
        return 0.0;
    /* the joins through a tessellated ball are point lights' only; through the sphere (with its
     * longer chains, join_first) and through flat faces (ltslab, within max_chain) both kinds' */
    if (cc && !(spc_sphere_chain_covers(cc, p->reflect)
                    ? cc->n <= spc_path_lt_camera_max_chain(p)
                    : cc->n <= p->max_chain && (slab_camera_chain(p, cc) || plane_camera_chain(p, cc))))
        return 0.0;
    spc_vec3 d_last = c->v[k - 1].d;
    /* light tracing's y, its direction toward the chain and |dw0/dA(x2)| without the chain's G,
     * against BSDF sampling at x2 toward d0 and the light's cosine (G's part only area measure has) */
    double num = area_share(p) * spc_snee_light_pdf(sc, p->any_surface, e, y, ny) *
                 area_dir_pdf(sc, p, y, spc_neg(d_last)) * spc_absdot(c->d0, x2->ng);
    spc_cguide_vertex gv;
    double den = path_dir_pdf(p, x2, wo2, c->d0, spc_bsdf_pdf(x2->bsdf, x2, SPC_MODE_RADIANCE, wo2, c->d0), &gv) *
                 spc_absdot(ny, d_last);
    if (x1) {
        /* the camera's side x1 - x2 against light tracing's x2 - x1, as spc_path_lt_ratio */
        spc_camera_direct cd;
        if (!spc_camera_sample_direct(ctx->cam, x1->p, &cd) || !in_window(ctx, cd.fx, cd.fy))
            return 0.0;
        double p_cam =
            cd.We / ((double)ctx->width * (double)ctx->height) * spc_absdot(cd.wi, x1->ng) / (cd.dist * cd.dist);
        num *= spc_bsdf_pdf(x2->bsdf, x2, SPC_MODE_IMPORTANCE, c->d0, wo2) * spc_absdot(w1, x1->ng);
        den *= spc_absdot(wo2, x2->ng) *
               path_dir_pdf(p, x1, cd.wi, w1, spc_bsdf_pdf(x1->bsdf, x1, SPC_MODE_RADIANCE, cd.wi, w1), &gv) * p_cam;
    } else {
        spc_camera_direct cd;
        num *= cc ? camera_chain_share(p, cc) : 1.0;
        den *= camera_density(ctx, p, x2, cc, &cd);
    }
    return ratio_of(num, den);
}

/* The camera's side of a join as params.alt_chain_ratio reads it (spc_path_lt_area_ratio's x1, w1,
 * cc), with the chain budget at x2. */
typedef struct area_side {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    const spc_hit *x1;
    spc_vec3 w1;
    const spc_chain *cc;
    int kmax, kflat;
} area_side;

static double area_side_ratio(const void *user, const spc_hit *x, spc_vec3 wo, const spc_chain *c, const spc_emitter *e,
                              spc_vec3 y, spc_vec3 ny)
{
    const area_side *a = user;
    if (c->n > spc_path_lt_area_chain_max(a->p, c, a->kmax, a->kflat))
        return 0.0;
    return spc_path_lt_area_ratio(a->ctx, a->p, a->x1, a->w1, x, wo, a->cc, c, e, y, ny);
}

/* Light tracing's weight of the join whose x2 (seen from wo2 on the camera's side) reached the area
 * light's point y (normal ny) through k chain vertices with these events (from x2) along d0: the
 * share the path tracer's BSDF-side weight at x2 (spc_snee_receiver_weights, with specular NEE's
 * query probability there) leaves to it. side: the camera's side. */
static double area_weight(const spc_render_ctx *ctx, const spc_snee_params *p, const area_side *side, bool first,
                          const spc_hit *x2, spc_vec3 wo2, spc_vec3 d0, int k, const unsigned char *events,
                          const spc_emitter *e, spc_vec3 y, spc_vec3 ny)
{
    spc_snee_params pq = *p;
    pq.mis = true;
    pq.query_p = first ? spc_snee_first_prob(ctx->scene, p, x2->p) : spc_snee_later_prob(ctx->scene, p, x2->p);
    pq.alt_ratio = NULL;
    pq.alt_chain_ratio = area_side_ratio;
    pq.alt_user = side;
    pq.delta_share = NULL;
    pq.light_u_on = false;
    /* the path's density at x2: the guided mixture's where the guide runs there (as
     * spc_path_snee_guide_at sets it for the path tracer's query and its BSDF hit) */
    spc_cguide_vertex gv;
    gv.a = 0.0;
    if (p->cguide && p->recv_guide > 0.0)
        spc_cguide_vertex_init(&gv, p->cguide, x2, wo2);
    pq.cguide_at = gv.a > 0.0 ? &gv : NULL;
    spc_receiver r;
    spc_receiver_surface(&r, x2, wo2);
    r.guide = pq.cguide_at;
    spc_hit lh;
    memset(&lh, 0, sizeof lh);
    lh.p = y;
    lh.ng = ny;
    lh.emitter = e;
    lh.shape = e->shape;
    double w_alt;
    spc_snee_receiver_weights(ctx->scene, &pq, &r, d0, side->kmax, k, events, &lh, &w_alt);
    return w_alt;
}

/* The chain from x2 with the light subpath's k events at the direction (a, b) of the frame f, in the
 * form specular NEE finds it (spc_chain from x2); false where it does not come out as k vertices. */
static bool trace_events(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x2, const spc_frame *f,
                         double a, double b, int k, const unsigned char *events, spc_chain *c)
{
    spc_chain_opts o = spc_chain_opts_default(k);
    o.events = events;
    o.any_surface = p->any_surface;
    spc_chain_end end = spc_chain_trace(sc, x2, f, a, b, &o, c);
    if (c->n != k || !(end == SPC_CHAIN_END_ESCAPED || end == SPC_CHAIN_END_SURFACE || end == SPC_CHAIN_END_LIMIT))
        return false;
    if (!p->any_surface)
        for (int i = 0; i < k; ++i)
            if (!spc_chain_caster_allowed(c->v[i].h.shape->caustic_flags, k))
                return false;
    return true;
}

/* The largest move of the retrace's direction (a, b) in its Newton steps: the rounding of x2 moves
 * the chain through y by about 1e-5 (6e-4 measured near the caustic's fold); beyond the fold, where
 * no chain from x2 reaches y, the steps would run off toward another chain. */
#define RETRACE_MAX_MOVE 1e-3

/* The light chain from x2 to the point light at y with the events the light subpath took: the
 * retrace along d0, then Newton steps on its direction until its last segment passes through y.
 * x2 is the subpath's hit, rounded off the segment it arrived on, so the plain retrace misses y by
 * that rounding, magnified by the chain (near grazing reflections, 1-3% in the density); specular
 * NEE weighs the path with the chain it solves from x2 through y, and the weights sum to one only
 * where both sides evaluate the same chain. False where the retrace fails; *exact: whether the
 * chain passes through y (within 1e-9 of |y - x2|; not where x2 lies past the caustic's fold,
 * where no chain reaches y and specular NEE has none to find). */
static bool retrace_chain(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x2, spc_vec3 d0, int k,
                          const unsigned char *events, spc_vec3 y, spc_chain *c, bool *exact)
{
    spc_frame f = spc_frame_from_n(d0);
    *exact = false;
    if (!trace_events(sc, p, x2, &f, 0.0, 0.0, k, events, c))
        return false;
    double tol = 1e-9 * spc_length(spc_sub(y, x2->p));
    double err = SPC_INF;
    for (int it = 0; it < 8; ++it) {
        spc_vec3 q, dq[2];
        spc_vec3 ny = spc_neg(c->v[k - 1].d);
        if (!spc_chain_plane_hit(c, y, ny, &q, dq, NULL))
            break;
        spc_vec3 e = spc_sub(q, y);
        double el = spc_length(e);
        if (!(el < err))
            break;
        err = el;
        if (!(el > tol))
            break;
        /* dq[0] da + dq[1] db = -e in the least-squares sense (the plane's two dimensions) */
        double m00 = spc_dot(dq[0], dq[0]), m01 = spc_dot(dq[0], dq[1]), m11 = spc_dot(dq[1], dq[1]);
        double r0 = -spc_dot(dq[0], e), r1 = -spc_dot(dq[1], e);
        double det = m00 * m11 - m01 * m01;
        if (!(fabs(det) > 0.0) || !isfinite(det))
            break;
        double a = c->a + (m11 * r0 - m01 * r1) / det, b = c->b + (m00 * r1 - m01 * r0) / det;
        if (!(a * a + b * b < RETRACE_MAX_MOVE * RETRACE_MAX_MOVE))
            break;
        spc_chain next;
        if (!trace_events(sc, p, x2, &f, a, b, k, events, &next))
            break;
        *c = next;
    }
    *exact = err <= tol;
    return true;
}

/* How much the chain c from x2 focuses the point light's flux at y onto x2: G times the squared
 * length of the chain's path (about 1 for a plane mirror, large near the caustic's fold). */
static double chain_focus(const spc_chain *c, const spc_hit *x2, spc_vec3 y)
{
    double L = 0.0;
    spc_vec3 prev = x2->p;
    for (int i = 0; i < c->n; ++i) {
        L += spc_length(spc_sub(c->v[i].h.p, prev));
        prev = c->v[i].h.p;
    }
    L += spc_length(spc_sub(y, prev));
    return spc_chain_geometry(c, y, spc_neg(c->v[c->n - 1].d)) * L * L;
}

/* Where the chain's focus (chain_focus) passes this, light tracing asks whether specular NEE at x2
 * finds its chain: on point_light_ball the enumeration missed chains of focus 95 and more only (12
 * seeds of 20000 subpaths), and 14% of the subpaths focus past 30. */
#define LT_CHECK_FOCUS 30.0

/* Does specular NEE at x2 find the chain c to the point light at y: is c one of the sphere's
 * chains it enumerates there (the same length, the first direction within 1e-6 in 1 - cos)? The
 * enumeration's root isolation can miss the two chains that meet near the caustic's fold. */
static bool nee_finds(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x2, const spc_chain *c,
                      spc_vec3 y)
{
    spc_snee_query q;
    spc_snee_query_init(&q, sc, p, x2, c->d0, p->max_chain);
    q.y = y;
    q.ny = spc_v3(0, 0, 0);
    q.light_size = 0.0;
    spc_chain all[SPC_PATH_LT_CAMERA_CHAINS];
    int n = spc_sphere_chains_all(&q, all, SPC_PATH_LT_CAMERA_CHAINS, NULL);
    for (int i = 0; i < n; ++i)
        if (all[i].n == c->n && spc_dot(all[i].d0, c->d0) > 1.0 - 1e-6)
            return true;
    return false;
}

/* The light subpath's end as its joins read it: the light e and its point y (normal ny; a point
 * light's position), the chain c from x2 to y, and x2's arrival direction d0 (toward the chain).
 * Point lights: lt_only where specular NEE cannot make the path. Area lights: the chain's events
 * from x2, for the BSDF side's weight at x2 (spc_path_lt_area_ratio, area_weight). */
typedef struct lt_end {
    const spc_emitter *e;
    spc_vec3 y, ny, d0;
    const spc_chain *c;
    bool area, lt_only;
    int k;
    unsigned char ev[SPC_CHAIN_MAX_VERTICES];
    double n2; /* the subpath's radiance n^2 factors up to x2 (plane_radiance_n2) */
} lt_end;

/* The chain budgets at x2 reached after `segments` segments with `receivers` receivers before it
 * (*kmax: specular NEE's, *kflat: light tracing's for flat chains, an area light's
 * spc_path_lt_flat_budget or a point light's spc_path_lt_point_flat_budget), whether the light
 * subpath's chain fits them, and in *psi (point lights) specular NEE's probability of enumerating
 * that chain there (point_psi; 1 for area lights). */
static bool chain_fits(const spc_render_ctx *ctx, const spc_snee_params *p, const lt_end *L, const spc_hit *x2,
                       int segments, int receivers, int *kmax, int *kflat, double *psi)
{
    *kmax = spc_path_lt_budget(ctx, p, x2, segments, receivers);
    *kflat = L->area ? spc_path_lt_flat_budget(ctx, p, x2, segments, receivers)
                     : spc_path_lt_point_flat_budget(ctx, p, x2, segments, receivers);
    *psi = L->area ? 1.0 : point_psi(ctx, p, x2, segments, receivers, L->c);
    return L->c->n <= spc_path_lt_area_chain_max(p, L->c, *kmax, *kflat);
}

/* The ratio *r and light tracing's weight of the join x1 (NULL: x2 is the first receiver, seen
 * through cc or directly) - the nmid middle vertices mid (point lights only) - x2 (seen from wo2) -
 * the light subpath L; kmax the chain budget at x2, kflat the flat chains' (spc_path_lt_flat_budget),
 * psi (point lights) specular NEE's probability of enumerating the chain there (chain_fits). 0
 * where light tracing does not make the path. */
static double join_weight(const spc_render_ctx *ctx, const spc_snee_params *p, const lt_end *L, const spc_hit *x1,
                          spc_vec3 w1, const spc_path_lt_vertex *mid, int nmid, const spc_hit *x2, spc_vec3 wo2,
                          const spc_chain *cc, int kmax, int kflat, double psi, double *r)
{
    if (!L->area) {
        *r = x1 ? spc_path_lt_ratio_via(ctx, p, x1, w1, mid, nmid, x2, wo2, L->c, L->e)
                : ratio_first(ctx, p, x2, cc, L->c, L->e);
        if (*r > 0.0 && (L->lt_only || !(psi > 0.0)))
            *r = INFINITY;
        else if (*r > 0.0)
            *r /= psi;
        return *r > 0.0 ? spc_path_lt_weight(*r) : 0.0;
    }
    *r = spc_path_lt_area_ratio(ctx, p, x1, w1, x2, wo2, cc, L->c, L->e, L->y, L->ny);
    if (!(*r > 0.0))
        return 0.0;
    area_side side = {ctx, p, x1, w1, cc, kmax, kflat};
    return area_weight(ctx, p, &side, x1 == NULL, x2, wo2, L->d0, L->k, L->ev, L->e, L->y, L->ny);
}

/* The join of the light subpath at x2 (as join_first's) to the pinhole through the chain cc from
 * x2 toward it (the sphere's, a tessellated ball's or through flat faces), counted over the share of
 * subpaths that looks for it (camera_chain_share), where it fits x2's budgets and the camera sees
 * its last vertex unblocked. */
static void join_chain(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, spc_rgb beta,
                       const lt_end *L, const spc_chain *cc, void (*sink)(void *user, const spc_path_lt_join *j),
                       void *user)
{
    double N = (double)ctx->width * (double)ctx->height;
    spc_vec3 d0 = L->d0;
    spc_camera_direct cd;
    int kmax_cc, kflat_cc;
    double psi_cc;
    if (!chain_fits(ctx, p, L, x2, cc->n + 1, 0, &kmax_cc, &kflat_cc, &psi_cc))
        return;
    double pc = camera_density(ctx, p, x2, cc, &cd);
    if (!(pc > 0.0))
        return;
    const spc_chain_vertex *last = &cc->v[cc->n - 1];
    spc_rgb T = spc_rgb1(1.0);
    double n2 = L->n2;
    for (int v = 0; v < cc->n; ++v) {
        T = spc_rgb_mul(T, spc_bsdf_specular_throughput(cc->v[v].h.bsdf, &cc->v[v].h, SPC_MODE_RADIANCE, cc->v[v].d,
                                                        spc_neg(cc->v[v].wi)));
        if (spc_plane_chain_shape(cc->v[v].h.shape)) {
            T = spc_rgb_scale(T, plane_shading_fix(&cc->v[v].h, spc_neg(cc->v[v].wi), cc->v[v].d));
            n2 *= plane_radiance_n2(&cc->v[v].h, cc->v[v].d, spc_neg(cc->v[v].wi));
        }
    }
    spc_rgb f = spc_bsdf_eval(x2->bsdf, x2, SPC_MODE_IMPORTANCE, d0, cc->d0);
    double G = spc_chain_geometry(cc, ctx->cam->origin, spc_neg(last->d));
    double g = shading_fix(x2, d0, cc->d0) * spc_absdot(cc->d0, x2->sh.n) * G;
    spc_rgb C = plane_flux_value(
        spc_rgb_scale(spc_rgb_mul(spc_rgb_mul(beta, f), T), g * cd.We / N / camera_chain_share(p, cc)), n2);
    if (spc_rgb_is_black(C) || !isfinite(g))
        return;
    spc_ray sr = spc_hit_spawn_to(&last->h, cd.p_near, 0.0);
    double r = 0.0;
    double w = join_weight(ctx, p, L, NULL, spc_v3(0, 0, 0), NULL, 0, x2, cc->d0, cc, kmax_cc, kflat_cc, psi_cc, &r);
    if (w > 0.0 && !spc_scene_occluded(ctx->scene, &sr)) {
        spc_path_lt_join j = {NULL, x2, spc_v3(0, 0, 0), cc->d0, L->c, L->e, cd.fx, cd.fy, C, r, cc, NULL, 0,
                              L->y, L->ny, w};
        sink(user, &j);
    }
}

/* The joins of the light subpath at x2 (as join_first's) to the pinhole through the sphere, by
 * its chains of min_chain to max_chain vertices from x2 toward the pinhole, each counted over the
 * share of subpaths that looks for it (camera_chain_share). */
static void join_through(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, spc_rgb beta,
                         const lt_end *L, int min_chain, int max_chain,
                         void (*sink)(void *user, const spc_path_lt_join *j), void *user)
{
    spc_snee_query q;
    spc_snee_query_init(&q, ctx->scene, p, x2, L->d0, max_chain);
    q.min_chain = min_chain;
    q.y = ctx->cam->origin;
    q.ny = spc_v3(0, 0, 0);
    q.light_size = 0.0;
    spc_chain all[SPC_PATH_LT_CAMERA_CHAINS + MESH_CAMERA_CHAINS];
    int n = spc_sphere_chains_all(&q, all, SPC_PATH_LT_CAMERA_CHAINS, NULL);
    /* and a point light's paths through the tessellated balls' chains of at most max_chain */
    if (!L->area && min_chain <= p->max_chain)
        n += mesh_camera_chains(ctx, p, x2, p->max_chain < max_chain ? p->max_chain : max_chain, all + n,
                                MESH_CAMERA_CHAINS);
    for (int i = 0; i < n; ++i)
        if (all[i].n >= min_chain && all[i].n <= max_chain)
            join_chain(ctx, p, x2, beta, L, &all[i], sink, user);
}

/* The most chains through flat faces from x2 toward the pinhole one join enumerates: a cube's
 * sequences of one and two faces give a few (in and out, a reflection off a face). */
#define SLAB_CAMERA_CHAINS 32

/* The joins at x2 to the pinhole through flat faces (ltslab): every chain of spc_flat_chains_all
 * from x2 toward the pinhole of 1 to slab_max vertices (a floor point seen through a glass slab),
 * on every subpath. The path tracer's side weighs the camera ray that meets x2 through such a chain
 * against these (a point light's: spc_path_lt_ratio_first; an area light's: spc_path_lt_area_ratio
 * with that chain, the camera's density through it from camera_density). */
static void join_slab(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, spc_rgb beta,
                      const lt_end *L, void (*sink)(void *user, const spc_path_lt_join *j), void *user)
{
    int kmax = slab_max(p);
    if (kmax < 1 || !p->exact)
        return;
    spc_snee_query q;
    spc_snee_query_init(&q, ctx->scene, p, x2, L->d0, kmax);
    q.min_chain = 1;
    q.y = ctx->cam->origin;
    q.ny = spc_v3(0, 0, 0);
    q.light_size = 0.0;
    spc_chain all[SLAB_CAMERA_CHAINS];
    int n = spc_flat_chains_all(&q, all, SLAB_CAMERA_CHAINS, NULL);
    for (int i = 0; i < n; ++i)
        if (slab_camera_chain(p, &all[i]))
            join_chain(ctx, p, x2, beta, L, &all[i], sink, user);
}

/* The light subpath's end and the sink of its joins, for spc_plane_chains_each's callback. */
typedef struct plane_join {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    const spc_hit *x2;
    spc_rgb beta;
    const lt_end *L;
    void (*sink)(void *user, const spc_path_lt_join *j);
    void *user;
} plane_join;

static void plane_join_one(void *user, const spc_chain *cc)
{
    const plane_join *pj = user;
    if (plane_camera_chain(pj->p, cc))
        join_chain(pj->ctx, pj->p, pj->x2, pj->beta, pj->L, cc, pj->sink, pj->user);
}

/* An area light's joins at x2 to the pinhole through a normal-mapped plane: every one-vertex chain
 * of spc_plane_chains_each from x2 toward the pinhole (the floor seen through water, often at
 * several points of the ripples), on every subpath. The path tracer's side weighs the camera ray
 * that meets x2 through such a chain against these (spc_path_lt_area_ratio with that chain; the
 * camera's density through it from camera_density). */
static void join_plane(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, spc_rgb beta,
                       const lt_end *L, void (*sink)(void *user, const spc_path_lt_join *j), void *user)
{
    if (!L->area || !p->exact || p->max_chain < 1)
        return;
    spc_snee_query q;
    spc_snee_query_init(&q, ctx->scene, p, x2, L->d0, 1);
    q.min_chain = 1;
    q.y = ctx->cam->origin;
    q.ny = spc_v3(0, 0, 0);
    q.light_size = 0.0;
    plane_join pj = {ctx, p, x2, beta, L, sink, user};
    int it = 0;
    spc_plane_chains_each(&q, p->reflect, plane_join_one, &pj, &it);
}

/* Is some caster a glass sphere (a sphere whose chains spc_sphere_chains_all enumerates, with a
 * refracting interface: the only sphere with chains longer than two vertices, in, reflections
 * inside, out)? */
static bool glass_sphere_caster(const spc_scene *sc, bool any_surface)
{
    const spc_chain_casters *cs = spc_chain_casters_of(sc, any_surface);
    for (int i = 0; cs && i < cs->n; ++i) {
        const spc_shape *s = sc->shapes[cs->idx[i]];
        double eta = 0.0;
        if (spc_sphere_chain_shape(s) && spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0)
            return true;
    }
    return false;
}

/* The joins of the light subpath at x2 (arrived from d0 with throughput beta through the chain of
 * L) to the pinhole where x2 is the path's first receiver: directly, and through each chain of the
 * glass sphere toward the pinhole. */
static void join_first(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x2, spc_rgb beta,
                       const lt_end *L, spc_rng *rng, void (*sink)(void *user, const spc_path_lt_join *j), void *user)
{
    const spc_scene *sc = ctx->scene;
    double N = (double)ctx->width * (double)ctx->height;
    spc_vec3 d0 = L->d0;
    const spc_chain *c = L->c;
    spc_camera_direct cd;
    int kmax, kflat;
    double psi;
    if (chain_fits(ctx, p, L, x2, 1, 0, &kmax, &kflat, &psi) && camera_density(ctx, p, x2, NULL, &cd) > 0.0) {
        spc_rgb f = spc_bsdf_eval(x2->bsdf, x2, SPC_MODE_IMPORTANCE, d0, cd.wi);
        double g = shading_fix(x2, d0, cd.wi) * spc_absdot(cd.wi, x2->sh.n) / (cd.dist * cd.dist);
        spc_rgb C = plane_flux_value(spc_rgb_scale(spc_rgb_mul(beta, f), g * cd.We / N), L->n2);
        spc_ray sr = spc_hit_spawn_to(x2, cd.p_near, 0.0);
        double r = 0.0;
        double w = spc_rgb_is_black(C)
                       ? 0.0
                       : join_weight(ctx, p, L, NULL, spc_v3(0, 0, 0), NULL, 0, x2, cd.wi, NULL, kmax, kflat, psi, &r);
        if (w > 0.0 && !spc_scene_occluded(sc, &sr)) {
            spc_path_lt_join j = {NULL, x2, spc_v3(0, 0, 0), cd.wi, c, L->e, cd.fx, cd.fy, C, r, NULL, NULL, 0,
                                  L->y, L->ny, w};
            sink(user, &j);
        }
    }
    /* through the sphere: its chains from x2 to the pinhole, on a share of the subpaths (their
     * contributions over the share; the share is in the density spc_path_lt_ratio_first weighs);
     * the chains longer than the parameters' max_chain on a share of their own */
    double share = through_share(p);
    if (share > 0.0 && (share >= 1.0 || spc_rng_next(rng) < share))
        join_through(ctx, p, x2, beta, L, 1, p->max_chain, sink, user);
    /* through flat faces (glass slabs), with ltslab */
    join_slab(ctx, p, x2, beta, L, sink, user);
    /* an area light's through a normal-mapped plane (water), where its own chain ran through one */
    join_plane(ctx, p, x2, beta, L, sink, user);
    /* through the sphere's longer chains (in, reflections inside, out), on a share of their own;
     * an area light's only where a glass sphere has such chains (elsewhere its stream is not drawn) */
    double ls = long_share(p);
    if (spc_path_lt_camera_max_chain(p) > p->max_chain && (!L->area || glass_sphere_caster(sc, p->any_surface)) &&
        (ls >= 1.0 || spc_rng_next(rng) < ls))
        join_through(ctx, p, x2, beta, L, p->max_chain + 1, spc_path_lt_camera_max_chain(p), sink, user);
}

bool spc_path_lt_area_enabled(const spc_snee_params *p) { return !p->no_mis; }

/* A light subpath's start on the area light e (picked with the uniform ue): the point y (normal
 * ny) as specular NEE samples it (spc_snee_sample_light), a direction uniform in the cone toward
 * the casters' bounding sphere; *beta the emitted radiance times the cosine at y over both
 * densities. False where no light leaves toward the casters. */
static bool area_start(const spc_scene *sc, const spc_snee_params *p, const spc_emitter *e, double ue, spc_rng *rng,
                       spc_ray *ray, spc_vec3 *y, spc_vec3 *ny, spc_rgb *beta)
{
    spc_snee_params lp = *p;
    lp.light_u_on = true;
    lp.light_u[0] = ue;
    lp.light_u[1] = spc_rng_next(rng);
    lp.light_u[2] = spc_rng_next(rng);
    spc_snee_query q;
    memset(&q, 0, sizeof q);
    q.params = &lp;
    const spc_emitter *es;
    spc_vec2 uv;
    double p_y;
    if (!spc_snee_sample_light(sc, p->any_surface, rng, &q, &es, &uv, &p_y) || es != e || !(p_y > 0.0))
        return false;
    spc_vec3 axis;
    double cm;
    if (!caster_cone(sc, p->any_surface, q.y, &axis, &cm))
        return false;
    /* a share of the directions toward one mirror ball (where mirror_aims has any), the rest toward
     * the casters; the density is the mixture's (area_dir_pdf) */
    const spc_shape *balls[MIRROR_AIMS];
    int nb = mirror_aims(sc, p, balls, MIRROR_AIMS);
    if (nb > 0 && spc_rng_next(rng) < SPC_PATH_LT_MIRROR_SHARE) {
        int i = (int)(spc_rng_next(rng) * nb);
        if (i >= nb)
            i = nb - 1;
        if (!sphere_cone(q.y, balls[i]->center, balls[i]->radius, &axis, &cm))
            return false;
    }
    double u1 = spc_rng_next(rng), u2 = spc_rng_next(rng);
    spc_vec3 w0 = cone_direction(axis, cm, u1, u2);
    double cy = spc_dot(w0, q.ny);
    if (!(cy > 0.0))
        return false;
    spc_vec3 nyo;
    spc_rgb Le = spc_snee_light_radiance(e, q.y, q.ny, uv, spc_add(q.y, w0), spc_neg(w0), &nyo);
    if (spc_rgb_is_black(Le))
        return false;
    double pdir = nb > 0 ? area_dir_pdf(sc, p, q.y, w0) : 1.0 / (2.0 * SPC_PI * (1.0 - cm));
    if (!(pdir > 0.0))
        return false;
    *beta = spc_rgb_scale(Le, cy / (p_y * pdir));
    *y = q.y;
    *ny = q.ny;
    spc_hit h;
    memset(&h, 0, sizeof h);
    h.p = q.y;
    h.ng = q.ny;
    h.err = spc_max(q.y_err, 1e-9 * (spc_max_abs(q.y) + sc->radius));
    *ray = spc_hit_spawn(&h, w0);
    return true;
}

/* The weight a light subpath that arrived at h along d carries past the delta sample bs there: the
 * sample's own (importance transport), except on a normal-mapped plane, where it is the delta
 * lobe's throughput as the path tracer's radiance transport has it for the reversed pair (the
 * camera's side toward bs.wi, the light's behind), times the map's shading factor
 * (plane_shading_fix), over the lobe's probability. The map's shading normal makes the adjoint
 * BSDF differ from the importance-mode sample's weight (the cosine factors, the shadowing term),
 * and the joins must carry the value that specular NEE and BSDF sampling give the same path. The
 * radiance throughput's eta^2 is the one the join's geometry term from x2 leaves out (a chain's
 * term through one refraction is the one from x2's medium) where the join crosses the water back;
 * *n2 collects it (plane_radiance_n2), and the joins that do not cross back divide it out
 * (plane_flux_value). */
static spc_rgb delta_weight(const spc_hit *h, spc_vec3 d, const spc_bsdf_sample *bs, double *n2)
{
    if (!spc_plane_chain_shape(h->shape))
        return bs->weight;
    if (!(bs->pdf > 0.0))
        return spc_rgb1(0.0);
    *n2 *= plane_radiance_n2(h, bs->wi, spc_neg(d));
    spc_rgb T = spc_bsdf_specular_throughput(h->bsdf, h, SPC_MODE_RADIANCE, bs->wi, spc_neg(d));
    T = spc_rgb_scale(T, plane_shading_fix(h, spc_neg(d), bs->wi));
    return spc_rgb_scale(T, 1.0 / bs->pdf);
}

/* Follows ray through the delta scatterings at chain surfaces, at most kmax of them (up to kflat
 * while every one is on a flat-faced caster, spc_flat_chain_shape; up to kmix while the first is on
 * a mirror ball and the others on one glass shape, mirror_glass_chain's), multiplying beta by each sampled
 * weight (the importance transport of a light subpath). x: the first other surface;
 * events[i] and verts[i] (each unless NULL): the i-th scattering's event and surface. The number of scatterings, or -1 where the
 * walk ends before such a surface (the ray escapes, kmax is passed, a sample is not a delta lobe, the
 * throughput is black). ray ends as the last segment's. */
static int delta_walk(const spc_scene *sc, const spc_snee_params *p, spc_rng *rng, int kmax, int kflat, int kmix,
                      spc_ray *ray, spc_rgb *beta, double *n2, unsigned char *events, spc_hit *verts, spc_hit *x)
{
    bool flat = kflat > kmax, mix = kmix > kmax;
    const spc_shape *glass = NULL; /* the glass after the mirror ball */
    for (int k = 0;; ++k) {
        spc_hit h;
        if (!spc_scene_intersect(sc, ray, &h))
            return -1;
        int ev;
        if (!spc_chain_surface(&h, p->any_surface, &ev) || !spc_bsdf_is_delta_only(h.bsdf)) {
            *x = h;
            return k;
        }
        flat = flat && spc_flat_chain_shape(h.shape);
        if (k == 0)
            mix = mix && mirror_ball(h.shape);
        else if (k == 1)
            mix = mix && glass_shape(glass = h.shape);
        else
            mix = mix && h.shape == glass;
        if (k >= (flat ? kflat : mix ? kmix : kmax))
            return -1;
        spc_bsdf_sample bs;
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_IMPORTANCE, spc_neg(ray->d), spc_rng_next(rng),
                                 spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &bs) ||
            !(bs.lobe & SPC_LOBE_DELTA))
            return -1;
        /* on a normal-mapped plane, not where either direction turns the map's normal: the
         * importance sample's frame is then not the one the path tracer's side has there */
        if (spc_plane_chain_shape(h.shape) && (plane_turns(&h, spc_neg(ray->d)) || plane_turns(&h, bs.wi)))
            return -1;
        *beta = spc_rgb_mul(*beta, delta_weight(&h, ray->d, &bs, n2));
        if (spc_rgb_is_black(*beta))
            return -1;
        if (events)
            events[k] = bs.lobe == SPC_LOBE_DELTA_REFLECTION ? SPC_CHAIN_REFLECT : SPC_CHAIN_REFRACT;
        if (verts)
            verts[k] = h;
        *ray = spc_hit_spawn(&h, bs.wi);
    }
}

/* The start of a point or spot light e's subpath (picked with probability pmf): a direction uniform
 * in the cone toward the casters; a spot's beam (its falloff, zero past cutoff_angle) is in the
 * throughput, so the density is the same as a point light's. false where the casters are out of
 * reach or the throughput is black. */
static bool point_start(const spc_scene *sc, const spc_snee_params *p, const spc_emitter *e, double pmf, spc_rng *rng,
                        spc_ray *ray, spc_rgb *beta)
{
    spc_vec3 y = e->position, axis;
    double cm;
    if (!caster_cone(sc, p->any_surface, y, &axis, &cm))
        return false;
    double u1 = spc_rng_next(rng), u2 = spc_rng_next(rng);
    spc_vec3 w0 = cone_direction(axis, cm, u1, u2);
    double pdir = 1.0 / (2.0 * SPC_PI * (1.0 - cm));
    *beta = spc_rgb_scale(spc_emitter_eval_intensity(e, w0), 1.0 / (pmf * pdir));
    *ray = (spc_ray){.o = y, .d = w0, .tmin = 0.0, .tmax = SPC_INF};
    return !spc_rgb_is_black(*beta);
}

void spc_path_lt_joins(const spc_render_ctx *ctx, const spc_snee_params *p, spc_rng *rng,
                       void (*sink)(void *user, const spc_path_lt_join *j), void *user)
{
    const spc_scene *sc = ctx->scene;
    double pmf, ue = spc_rng_next(rng);
    const spc_emitter *e = spc_scene_sample_emitter(sc, ue, &pmf);
    if (!e || !(pmf > 0.0))
        return;
    lt_end L;
    memset(&L, 0, sizeof L);
    L.e = e;
    spc_rgb beta;
    spc_ray ray;
    if (point_like(e)) {
        if (!point_start(sc, p, e, pmf, rng, &ray, &beta))
            return;
        L.y = e->position;
    } else if (e->type == SPC_EMITTER_AREA && e->shape && spc_path_lt_area_enabled(p)) {
        /* on a share of the samples, counted over it (the share is in the density
         * spc_path_lt_area_ratio weighs); the emitter's uniform again: spc_snee_sample_light picks
         * the same light with it */
        double share = area_share(p);
        if ((share < 1.0 && !(spc_rng_next(rng) < share)) || !area_start(sc, p, e, ue, rng, &ray, &L.y, &L.ny, &beta))
            return;
        if (share < 1.0)
            beta = spc_rgb_scale(beta, 1.0 / share);
        L.area = true;
    } else {
        return;
    }

    /* the chain: delta scatterings at chain surfaces, up to the longest budget (an area light's
     * through flat faces: up to the longest its track may follow, spc_path_lt_flat_budget) */
    int kmax = p->max_chain < SPC_CHAIN_MAX_VERTICES ? p->max_chain : SPC_CHAIN_MAX_VERTICES;
    int kflat = kmax;
    if (L.area) {
        int l = flat_walk_max(p, SPC_CHAIN_MAX_VERTICES);
        kflat = l > kmax ? l : kmax;
    } else if (p->exact && SPC_FLAT_MAX_VERTICES > kmax) {
        kflat = SPC_FLAT_MAX_VERTICES; /* a point light's: spc_path_lt_point_flat_budget */
    }
    unsigned char events[SPC_CHAIN_MAX_VERTICES];
    spc_hit x2;
    /* an area light's off a mirror ball through glass: up to the same (mirror_glass_chain) */
    L.n2 = 1.0;
    int k = delta_walk(sc, p, rng, kmax, kflat, L.area ? kflat : kmax, &ray, &beta, &L.n2, events, NULL, &x2);
    if (k < 1 || !spc_bsdf_has_smooth(x2.bsdf))
        return;
    spc_vec3 d0 = spc_neg(ray.d);
    L.d0 = d0;
    spc_chain c;
    if (!L.area) {
        /* the events from x2 (the subpath took them from the light: the reverse order, which the
         * sphere's and the ball's chains, in, reflected inside, out, do not tell from it) */
        unsigned char ev[SPC_CHAIN_MAX_VERTICES];
        for (int i = 0; i < k; ++i)
            ev[i] = events[k - 1 - i];
        bool exact;
        if (!retrace_chain(sc, p, &x2, d0, k, ev, L.y, &c, &exact) || !point_chain_covers(p, &c))
            return;
        if (spc_sphere_chain_covers(&c, p->reflect)) {
            /* a path specular NEE cannot make is light tracing's alone: r infinite, its weight 1.
             * Its enumeration at x2 is asked where it may miss the chain: near the caustic's fold,
             * where the chain focuses the light (and where no chain passes through y) */
            L.lt_only = (!exact || chain_focus(&c, &x2, L.y) > LT_CHECK_FOCUS) && !nee_finds(sc, p, &x2, &c, L.y);
        } else if (spc_flat_chain_covers(&c, p->reflect)) {
            /* through flat faces: one chain per face sequence passes through y (no fold), and
             * specular NEE's flat enumeration solves it from x2 on the calls it runs that length
             * (point_psi); weighed with the chain solved through y, as specular NEE's is */
            if (exact)
                L.d0 = c.d0;
        } else {
            /* the tessellated ball: where the retrace reaches the light, specular NEE's attempts
             * find that chain with some probability and count it without bias (point_chain_covers);
             * where it does not, no chain from x2 passes through the light with these events and the
             * path is light tracing's alone. Otherwise the chain through y, as specular NEE solves it */
            L.lt_only = !exact;
            if (exact)
                L.d0 = c.d0;
        }
    } else {
        /* the events from x2, and the chain from x2 solved through y, as specular NEE's at x2 is: the
         * BSDF side's weight (area_weight) retraces it along its first direction, and the weights
         * of the path on the three sides sum to one only where they evaluate the same chain (the
         * subpath's own misses y by the rounding of x2, magnified by the chain) */
        L.k = k;
        for (int i = 0; i < k; ++i)
            L.ev[i] = events[k - 1 - i];
        bool exact;
        if (!retrace_chain(sc, p, &x2, d0, k, L.ev, L.y, &c, &exact) || !area_chain_covers(p, &c))
            return;
        if (exact)
            L.d0 = c.d0;
    }
    L.c = &c;

    /* x2 as the path's first receiver: seen by the camera directly, or through the glass sphere */
    join_first(ctx, p, &x2, beta, &L, rng, sink, user);

    /* x2's scattering toward the camera's side: a non-delta sample */
    spc_bsdf_sample bs;
    if (!spc_bsdf_sample_dir(x2.bsdf, &x2, SPC_MODE_IMPORTANCE, d0, spc_rng_next(rng),
                             spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &bs) ||
        (bs.lobe & SPC_LOBE_DELTA))
        return;
    spc_vec3 w2 = bs.wi;
    beta = spc_rgb_scale(spc_rgb_mul(beta, bs.weight), shading_fix(&x2, d0, w2));
    ray = spc_hit_spawn(&x2, w2);

    /* then m delta scatterings to x1, joined to the pinhole at each vertex with a smooth lobe; a
     * non-delta scattering there makes that vertex a middle one (up to SPC_PATH_LT_MID_VERTICES)
     * and starts the count of delta scatterings again */
    spc_path_lt_vertex mid[SPC_PATH_LT_MID_VERTICES > 0 ? SPC_PATH_LT_MID_VERTICES : 1];
    int nmid = 0, segs = 0; /* segs: segments from x2 to h */
    double n2 = L.n2;       /* and the radiance n^2 factors of the delta scatterings past x2 */
    for (int m = 0; m <= SPC_PATH_LT_MID_MAX && !spc_rgb_is_black(beta); ++m) {
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h))
            return;
        ++segs;
        spc_vec3 wo = spc_neg(ray.d);
        int kmax2, kflat2;
        double psi2;
        if (spc_bsdf_has_smooth(h.bsdf) && chain_fits(ctx, p, &L, &x2, segs + 1, 1 + nmid, &kmax2, &kflat2, &psi2)) {
            spc_camera_direct cd;
            if (spc_camera_sample_direct(ctx->cam, h.p, &cd) && in_window(ctx, cd.fx, cd.fy)) {
                spc_rgb f = spc_bsdf_eval(h.bsdf, &h, SPC_MODE_IMPORTANCE, wo, cd.wi);
                double g = shading_fix(&h, wo, cd.wi) * spc_absdot(cd.wi, h.sh.n) / (cd.dist * cd.dist);
                spc_rgb C = plane_flux_value(
                    spc_rgb_scale(spc_rgb_mul(beta, f), g * cd.We / ((double)ctx->width * (double)ctx->height)), n2);
                if (!spc_rgb_is_black(C)) {
                    double r = 0.0;
                    double w = join_weight(ctx, p, &L, &h, wo, mid, nmid, &x2, w2, NULL, kmax2, kflat2, psi2, &r);
                    spc_ray sr = spc_hit_spawn_to(&h, cd.p_near, 0.0);
                    if (w > 0.0 && !spc_scene_occluded(sc, &sr)) {
                        spc_path_lt_join j = {&h, &x2, wo, w2, &c, L.e, cd.fx, cd.fy, C, r, NULL, mid, nmid,
                                              L.y, L.ny, w};
                        sink(user, &j);
                    }
                }
            }
        }
        spc_bsdf_sample bm;
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_IMPORTANCE, wo, spc_rng_next(rng),
                                 spc_v2(spc_rng_next(rng), spc_rng_next(rng)), &bm))
            return;
        if (!(bm.lobe & SPC_LOBE_DELTA)) {
            /* an area light's subpath has no middle vertex (the path tracer's side weighs its
             * paths against light tracing at the second receiver only) */
            if (L.area || nmid >= SPC_PATH_LT_MID_VERTICES)
                return;
            mid[nmid++] = (spc_path_lt_vertex){h, bm.wi, wo};
            beta = spc_rgb_scale(spc_rgb_mul(beta, bm.weight), shading_fix(&h, wo, bm.wi));
            ray = spc_hit_spawn(&h, bm.wi);
            m = -1;
            continue;
        }
        beta = spc_rgb_mul(beta, delta_weight(&h, ray.d, &bm, &n2));
        ray = spc_hit_spawn(&h, bm.wi);
    }
}

typedef struct splat_sink {
    const spc_render_ctx *ctx;
    spc_tls *tls;
} splat_sink;

static void splat_join(void *user, const spc_path_lt_join *j)
{
    const splat_sink *s = user;
    spc_splat_add(s->ctx, s->tls, j->fx, j->fy, spc_rgb_scale(j->C, j->w));
}

void spc_path_lt_trace(const spc_render_ctx *ctx, const spc_snee_params *p, spc_tls *tls, spc_rng *rng)
{
    splat_sink s = {ctx, tls};
    spc_path_lt_joins(ctx, p, rng, splat_join, &s);
}

/* ---- long chains: the light guides ---- */

/* The share of camera samples that trace a light-guide subpath, counted 1/S times (params.lt_guide_share;
 * outside (0, 1]: every sample). */
static double guide_share(const spc_snee_params *p)
{
    return p->lt_guide_share > 0.0 && p->lt_guide_share <= 1.0 ? p->lt_guide_share : 1.0;
}

bool spc_path_lt_guide_enabled(const spc_render_ctx *ctx, const spc_snee_params *p)
{
    return p->lt_guide && ctx->kind == SPC_INTEGRATOR_PATH && ctx->specular_nee != SPC_SNEE_NONE &&
           !(p->recv_guide > 0.0) && !ctx->strict_normals && !(p->solver == SPC_SNEE_NEWTON && p->newton.rough) &&
           spc_camera_connectible(ctx->cam);
}

int spc_path_lt_guide_min_chain(const spc_render_ctx *ctx, const spc_snee_params *p)
{
    int b = p->max_chain > ctx->specular_max_chain ? p->max_chain : ctx->specular_max_chain;
    int l = spc_snee_track_long_max(p, SPC_CHAIN_MAX_VERTICES);
    return (l > b ? l : b) + 1;
}

int spc_path_lt_guide_point_min_chain(const spc_render_ctx *ctx, const spc_snee_params *p)
{
    int b = p->max_chain > ctx->specular_max_chain ? p->max_chain : ctx->specular_max_chain;
    return (b > SPC_FLAT_MAX_VERTICES ? b : SPC_FLAT_MAX_VERTICES) + 1;
}

double spc_path_lt_guide_ratio(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *x, spc_vec3 wo,
                               spc_vec3 d0, spc_vec3 d_last, const spc_emitter *e, spc_vec3 y, spc_vec3 ny)
{
    const spc_scene *sc = ctx->scene;
    if (!e || e->type != SPC_EMITTER_AREA || !e->shape)
        return 0.0;
    spc_camera_direct cd;
    double num = guide_share(p) * spc_snee_light_pdf(sc, p->any_surface, e, y, ny) *
                 area_dir_pdf(sc, p, y, spc_neg(d_last)) * spc_absdot(d0, x->ng);
    double den = spc_bsdf_pdf(x->bsdf, x, SPC_MODE_RADIANCE, wo, d0) * spc_absdot(ny, d_last) *
                 camera_density(ctx, p, x, NULL, &cd);
    return ratio_of(num, den);
}

void spc_path_lt_guide_joins(const spc_render_ctx *ctx, const spc_snee_params *p, spc_rng *rng,
                             void (*sink)(void *user, const spc_path_lt_guide_join *j), void *user)
{
    const spc_scene *sc = ctx->scene;
    double share = guide_share(p);
    if (share < 1.0 && !(spc_rng_next(rng) < share))
        return;
    double pmf, ue = spc_rng_next(rng);
    const spc_emitter *e = spc_scene_sample_emitter(sc, ue, &pmf);
    if (!e || !(pmf > 0.0))
        return;
    bool delta = point_like(e);
    if (!delta && (e->type != SPC_EMITTER_AREA || !e->shape))
        return;
    spc_ray ray;
    spc_vec3 y = e->position, ny = spc_v3(0.0, 0.0, 0.0);
    spc_rgb beta;
    if (delta ? !point_start(sc, p, e, pmf, rng, &ray, &beta) : !area_start(sc, p, e, ue, rng, &ray, &y, &ny, &beta))
        return;
    beta = spc_rgb_scale(beta, 1.0 / share);
    spc_vec3 d_last = spc_neg(ray.d);

    /* the delta scatterings at chain surfaces, to the first other surface x */
    spc_hit x, v[SPC_PATH_LT_GUIDE_MAX];
    double n2 = 1.0;
    int k = delta_walk(sc, p, rng, SPC_PATH_LT_GUIDE_MAX, SPC_PATH_LT_GUIDE_MAX, SPC_PATH_LT_GUIDE_MAX, &ray, &beta,
                       &n2, NULL, v, &x);
    /* a light guide's chain (longer than any specular NEE covers), within max_depth's k + 2 segments */
    if (k < (delta ? spc_path_lt_guide_point_min_chain(ctx, p) : spc_path_lt_guide_min_chain(ctx, p)) ||
        (ctx->max_depth >= 0 && k + 2 > ctx->max_depth) ||
        !spc_bsdf_has_smooth(x.bsdf))
        return;
    /* a point or spot light's chain through a normal-mapped plane is not the guides' (the walk
     * refuses some of them: plane_turns), so specular NEE keeps all of them (path_snee.c) */
    for (int i = 0; delta && i < k; ++i)
        if (spc_plane_chain_shape(v[i].shape))
            return;
    spc_vec3 d0 = spc_neg(ray.d);
    spc_camera_direct cd;
    if (!(camera_density(ctx, p, &x, NULL, &cd) > 0.0))
        return;
    spc_rgb f = spc_bsdf_eval(x.bsdf, &x, SPC_MODE_IMPORTANCE, d0, cd.wi);
    double g = shading_fix(&x, d0, cd.wi) * spc_absdot(cd.wi, x.sh.n) / (cd.dist * cd.dist);
    spc_rgb C = plane_flux_value(
        spc_rgb_scale(spc_rgb_mul(beta, f), g * cd.We / ((double)ctx->width * (double)ctx->height)), n2);
    if (spc_rgb_is_black(C) || !isfinite(g))
        return;
    /* a point or spot light's: no other strategy makes the path (BSDF sampling never meets the
     * light, light tracing's caustics' chains are shorter, specular NEE's within its budget are
     * shorter and its long pass's longer ones at x are weighed 0: spc_path_lt_guide_point_min_chain),
     * r infinite */
    double r = delta ? INFINITY : spc_path_lt_guide_ratio(ctx, p, &x, cd.wi, d0, d_last, e, y, ny);
    if (!(r > 0.0))
        return;
    spc_ray sr = spc_hit_spawn_to(&x, cd.p_near, 0.0);
    if (spc_scene_occluded(sc, &sr))
        return;
    spc_path_lt_guide_join j = {&x, cd.wi, d0, d_last, v, k, e, y, ny, cd.fx, cd.fy, C, r, spc_path_lt_weight(r)};
    sink(user, &j);
}

static void splat_guide_join(void *user, const spc_path_lt_guide_join *j)
{
    const splat_sink *s = user;
    spc_splat_add(s->ctx, s->tls, j->fx, j->fy, spc_rgb_scale(j->C, j->w));
}

void spc_path_lt_guide_trace(const spc_render_ctx *ctx, const spc_snee_params *p, spc_tls *tls, spc_rng *rng)
{
    splat_sink s = {ctx, tls};
    spc_path_lt_guide_joins(ctx, p, rng, splat_guide_join, &s);
}
