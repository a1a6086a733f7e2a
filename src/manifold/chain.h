/*
 * manifold/chain.h: differentiable specular chains (the forward path of the angular
 * parameterization, Dadfar 2022, sec. 5, and its derivatives, sec. 6.1-6.4).
 *
 * A chain starts at a point x (usually a diffuse surface point) and leaves it along a direction
 * given by two parameters (a, b) on the tangent plane of a base direction w (gnomonic
 * coordinates):
 *
 *     d0(a, b) = normalize(w + a s + b t),     (s, t, w) an orthonormal frame,
 *
 * which has no pole anywhere in the hemisphere around w (the polar angles of the thesis, eq.
 * 47-53, have one at theta = 0). At (0, 0) the parameters are orthonormal coordinates of the unit
 * sphere; in general the solid angle element is dw = cos^3 da db with cos = 1/sqrt(1+a^2+b^2).
 *
 * The ray is traced through the scene; every surface hit whose BSDF is a smooth specular
 * interface (spc_bsdf_is_specular_interface) and that may cast caustics (shape->caustic_flags,
 * see spc_chain_caster_allowed) becomes a chain vertex where the ray reflects (conductors) or
 * refracts (dielectrics; total internal reflection is reported, not turned into a reflection).
 * The first other surface ends the chain. Alongside, the derivatives with respect to (a, b) of
 * every vertex position, hit distance, shading normal and outgoing direction are carried
 * analytically:
 *   - hit distance and position by implicit differentiation of the surface constraint (thesis eq.
 *     34-37): the position moves in the tangent plane of the surface, ng . dp = 0;
 *   - the shading normal through the surface parameters: dp = dpdu du + dpdv dv is solved for
 *     (du, dv) (least squares on the 2x2 Gram matrix), then dn = dndu du + dndv dv with the
 *     hit's dndu/dndv (sphere curvature, triangle barycentrics with renormalized interpolated
 *     normals, thesis eq. 40, 43-46; any shape that fills spc_hit's derivatives works, SDFs
 *     included);
 *   - reflection and refraction by the chain rule (thesis eq. 25, 26-33).
 * A normal-mapped interface (bsdf normalmap over a conductor or dielectric) is a chain vertex with
 * the mapped normal and its derivatives through the texture (spc_bsdf_map_chain_hit, applied by
 * spc_chain_intersect as the arriving ray sees it); bilinear maps make such chains smooth inside
 * texels and continuous across them.
 * Triangle hits are re-intersected in double precision (Embree reports float barycentrics), so a
 * chain is a smooth function of (a, b) to double precision away from silhouettes and edges of
 * mesh-less shapes.
 *
 * Units: positions and distances in scene units; parameters (a, b) are dimensionless.
 * Hot path: no allocation; failure is reported through spc_chain.end.
 */
#ifndef SPC_MANIFOLD_CHAIN_H
#define SPC_MANIFOLD_CHAIN_H

#include "scene/scene.h"

/* Longest chain the fixed-size records hold (chains of up to 4 are asked for; room to spare). */
#define SPC_CHAIN_MAX_VERTICES 8

typedef enum spc_chain_event {
    SPC_CHAIN_REFLECT = 0,
    SPC_CHAIN_REFRACT = 1
} spc_chain_event;

/* How a trace ended. Only ESCAPED and SURFACE describe a usable chain. */
typedef enum spc_chain_end {
    SPC_CHAIN_END_ESCAPED,   /* the final segment leaves the scene */
    SPC_CHAIN_END_SURFACE,   /* the final segment hits a surface that is not a chain vertex (end_hit) */
    SPC_CHAIN_END_LIMIT,     /* the final segment hits another chain surface: the chain is too long */
    SPC_CHAIN_END_TIR,       /* total internal reflection where a refraction was asked (at fail_vertex) */
    SPC_CHAIN_END_MISMATCH,  /* a fixed signature was not followed (other surface, a miss, or an event
                                the BSDF cannot do) */
    SPC_CHAIN_END_DEGENERATE /* grazing hit or a degenerate surface parameterization */
} spc_chain_end;

/* The combinatorial part of a chain: which shapes, in which order, with which events. Mesh
 * triangles may change along a solve; the shape may not. */
typedef struct spc_chain_sig {
    int n;
    int shape[SPC_CHAIN_MAX_VERTICES]; /* index in scene->shapes */
    unsigned char event[SPC_CHAIN_MAX_VERTICES];
} spc_chain_sig;

typedef struct spc_chain_vertex {
    spc_hit h;          /* the surface hit (position, frames, surface derivatives, BSDF, shape) */
    double t;           /* distance along wi from the ray origin (the previous vertex or x, offset
                           along its ng by its error bound as spc_hit_spawn does) */
    double dt[2];       /* dt / d(a, b) */
    spc_vec3 dp[2];     /* d h.p / d(a, b) */
    spc_vec3 dn[2];     /* d h.sh.n / d(a, b) */
    spc_vec3 wi;        /* unit travel direction arriving here */
    spc_vec3 d;         /* unit travel direction leaving here */
    spc_vec3 dd[2];     /* dd / d(a, b) */
    int event;          /* spc_chain_event */
    double eta_ti;      /* n(leaving side) / n(arriving side); 1 for a reflection */
} spc_chain_vertex;

typedef struct spc_chain {
    spc_vec3 x;          /* start point (not offset) */
    spc_frame frame;     /* d0(a, b) = normalize(frame.n + a frame.s + b frame.t) */
    double a, b;
    spc_vec3 d0, dd0[2]; /* initial direction and its derivatives */
    int n;               /* chain vertices */
    spc_chain_vertex v[SPC_CHAIN_MAX_VERTICES];
    spc_chain_end end;
    int fail_vertex;     /* index of the vertex where TIR / mismatch / degeneracy happened */
    bool has_end_hit;
    spc_hit end_hit;     /* SURFACE and LIMIT: what the final segment hits first */
} spc_chain;

typedef struct spc_chain_opts {
    int max_vertices;            /* 1 .. SPC_CHAIN_MAX_VERTICES */
    const spc_chain_sig *fixed;  /* follow exactly this signature (solver steps), or NULL */
    const unsigned char *events; /* without fixed: forced event per vertex, or NULL: the BSDF's
                                    (conductor: reflect, dielectric: refract) */
    /* without fixed and events: one uniform number per vertex that picks the event at a dielectric
     * vertex by spc_chain_pick_event (reflection with probability reflect_p), or NULL: the BSDF's
     * events. Conductors reflect either way. */
    const double *event_u;
    double reflect_p;
    bool any_surface;            /* every specular interface is a chain surface, whatever its
                                    caustic flags (tests, benchmarks) */
    bool find_end;               /* with fixed: also intersect the final segment (end, end_hit) */
    /* without fixed: end after the last vertex without intersecting the final segment (end
     * SURFACE, no end hit), for a caller that takes the chain whatever that segment meets (the
     * polish of an exact root, whose final segment's visibility is tested later) */
    bool skip_end;
    /* a solver's step: the vertices' hits on meshes without uv and the shading tangents
     * (spc_shape_fill_hit_chain), which tracing, the derivatives and the residuals do not read;
     * spc_chain_complete fills them in the chain the solver keeps */
    bool slim;
} spc_chain_opts;

/* Default options: up to max_vertices vertices, BSDF events, caustic flags respected. */
spc_chain_opts spc_chain_opts_default(int max_vertices);

/* May a shape with these caustic flags be a vertex of a chain of k vertices? Specular shapes are
 * casters by default (SPC_CAUSTIC_CASTER); CASTER_SINGLE / CASTER_MULTI, when either is set,
 * restrict the shape to chains of one vertex / of more than one. */
bool spc_chain_caster_allowed(unsigned caustic_flags, int k);
/* Is the shape a possible chain vertex (specular interface BSDF, no emitter, caster for some chain
 * length unless any_surface)? *event (may be NULL) receives the BSDF's event. */
bool spc_chain_shape_is_caster(const spc_shape *s, bool any_surface, int *event);
/* The scene's casters (spc_chain_shape_is_caster) for one any_surface setting: their shape indices
 * in ascending order and the sphere around their bounding boxes (r 0 if none); built by
 * spc_scene_finalize (a scene's shapes, BSDFs and caustic flags must not change after it). */
typedef spc_scene_casters spc_chain_casters;
const spc_chain_casters *spc_chain_casters_of(const spc_scene *sc, bool any_surface);
/* Is the surface of h a possible chain vertex (specular interface, no emitter, caster for some
 * chain length unless any_surface)? *event receives the BSDF's event. */
bool spc_chain_surface(const spc_hit *h, bool any_surface, int *event);

/* The event at a chain vertex whose BSDF's event is `event`, when dielectric vertices may also
 * reflect (spc_chain_opts.event_u): a conductor (event REFLECT) reflects; a dielectric (REFRACT)
 * reflects when u < reflect_p and refracts otherwise. The probability does not depend on the
 * geometry, so that the probability of a chain's events is known exactly (spc_chain_events_prob)
 * and the Bernoulli trials of specular NEE need only estimate that of its directions. *prob (may be
 * NULL) receives the probability of the event returned. */
int spc_chain_pick_event(int event, double u, double reflect_p, double *prob);
/* The probability that spc_chain_pick_event gives the events of signature sig (1 without any
 * dielectric vertex). */
double spc_chain_events_prob(const spc_scene *sc, const spc_chain_sig *sig, bool any_surface, double reflect_p);

/* The scene's first hit along r, a triangle hit re-intersected in double precision (as the chain
 * tracer does, so that other solvers project onto the same surfaces), a normal-mapped chain
 * surface mapped as seen from -r.d; false for a miss. */
bool spc_chain_intersect(const spc_scene *sc, const spc_ray *r, spc_hit *h);
/* False for a normal-mapped hit whose map could not be applied (spc_bsdf_map_chain_hit failed):
 * it must not become a chain vertex. */
bool spc_chain_hit_ready(const spc_hit *h);

/* d0 and its derivatives for the frame and parameters. */
spc_vec3 spc_chain_direction(const spc_frame *f, double a, double b, spc_vec3 dd[2]);

/* Traces the chain from the surface point x (x->err and x->ng offset the first ray; a free point
 * may pass err = 0) and returns out->end. */
spc_chain_end spc_chain_trace(const spc_scene *sc, const spc_hit *x, const spc_frame *frame, double a, double b,
                              const spc_chain_opts *opts, spc_chain *out);

/* Fills what opts.slim left out of the chain's hits: afterwards each is spc_chain_intersect's
 * record, byte for byte. */
void spc_chain_complete(spc_chain *c);

/* Re-expresses the chain in the frame centred on its current direction d0 (a = b = 0) by the
 * chain rule, without tracing again. False if the old parameterization is singular there. */
bool spc_chain_recenter(spc_chain *c);

void spc_chain_signature(const spc_chain *c, spc_chain_sig *sig);
bool spc_chain_sig_equal(const spc_chain_sig *a, const spc_chain_sig *b);

/* Start point and travel direction of the final segment, with derivatives. */
void spc_chain_final_segment(const spc_chain *c, spc_vec3 *o, spc_vec3 do_[2], spc_vec3 *d, spc_vec3 dd[2]);

/* Where the final segment meets the plane through y with normal ny, and its derivatives with
 * respect to (a, b). False if the segment is parallel to the plane or meets it behind. */
bool spc_chain_plane_hit(const spc_chain *c, spc_vec3 y, spc_vec3 ny, spc_vec3 *q, spc_vec3 dq[2], double *t);

/* dw / (da db) of the parameterization at (c->a, c->b): cos^3 of the angle to frame.n. */
double spc_chain_solid_angle_density(const spc_chain *c);

/* Generalized geometry term |dw(x) / dA(y)| of the chain toward a point y on a surface of unit
 * normal ny (thesis sec. 6.6 with Jakob and Marschner 2012): the solid angle at x per unit area at
 * y through the whole chain. For a point light pass ny = -d of the final segment. 0 if degenerate. */
double spc_chain_geometry(const spc_chain *c, spc_vec3 y, spc_vec3 ny);

#endif
