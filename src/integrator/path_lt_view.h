/*
 * integrator/path_lt_view.h: an area light seen from the camera through flat glass, by light
 * tracing, for the path tracer.
 *
 * The paths camera - k delta scatterings on flat-faced casters - a point y on an area light (the
 * light's image through a glass slab, or in it after a reflection inside the glass: T R T) are made
 * by the camera ray alone where specular NEE from the pinhole does not make them (its flat
 * enumeration takes total reflections only, and it runs only with params.camera): a thin image of
 * a small light that a pixel's rays hit rarely, each hit worth hundreds. Here, on a share S of the
 * camera samples (params.lt_view_share), a point y is drawn on an area light as specular NEE draws
 * it (spc_snee_sample_light, density p_y in area measure), every chain from y to the pinhole
 * through flat faces of 1 to SPC_PATH_LT_VIEW_MAX_CHAIN vertices is solved exactly
 * (spc_flat_chains_all_partial: one chain per face sequence, partial reflections too), and each is
 * splatted where the camera sees its last vertex. Its density in area measure at y is S p_y; the
 * camera ray's is the camera's density of y through the chain (We / N |cos| G times the lobe
 * choices along it); both sides weigh the path by the power heuristic with the ratio r of the two
 * (spc_path_lt_view_ratio), a function of the chain alone, so the weights sum to one.
 *
 * Which paths: the chain's vertices all on flat-faced casters (spc_flat_chain_faces with any
 * reflection), at most SPC_PATH_LT_VIEW_MAX_CHAIN of them and within max_depth, with params.camera
 * two or more of them with a reflection off glass among them (the rest are its enumeration's: not
 * solved here, which keeps the joins' cost down), and specular NEE from the pinhole leaves the path
 * to the camera ray (its weight there is 1: no camera query, or one that never makes the chain).
 * Where specular NEE from the pinhole shares the path, neither side weighs it here.
 *
 * Cost: the face sequences with reflections inside the glass are many (a cube: about 75 of 3
 * vertices from one light point); a draw costs 1.1-3x a camera sample on slab scenes, so the plan
 * does not run it (bench/RESULTS.md, part pinhole29).
 */
#ifndef SPC_INTEGRATOR_PATH_LT_VIEW_H
#define SPC_INTEGRATOR_PATH_LT_VIEW_H

#include "integrator/context.h"
#include "manifold/chain.h"

/* The longest chain from the light to the pinhole this strategy solves: three vertices are the
 * light's image reflected once inside a slab (in, a partial reflection off the far face, out);
 * the face sequences grow as the faces to the power of the length (four vertices cost 1.7-3.7x a
 * camera sample on slab scenes that had no such chain, three 1.1-3x). */
#define SPC_PATH_LT_VIEW_MAX_CHAIN 3

/* The share of camera samples that trace a light point (the user's "ltview" without a value). */
#define SPC_PATH_LT_VIEW_SHARE 0.25

/* Does the strategy run in this render (params.lt_view, the path integrator with specular NEE and
 * its MIS, a connectible camera, no strict normals or receiver guide)? */
bool spc_path_lt_view_enabled(const spc_render_ctx *ctx, const spc_snee_params *p);

/* The ratio r of the strategy's density of the path y - chain cc - pinhole to the camera ray's, in
 * area measure at y (the area light e's point y, normal ny; cc from y toward the pinhole, retraced
 * or solved). 0 where the strategy does not make the path (not its chains, a light point it never
 * draws, the camera does not see cc's last vertex). Does not check specular NEE from the pinhole
 * (the callers do). */
double spc_path_lt_view_ratio(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_emitter *e, spc_vec3 y,
                              spc_vec3 ny, const spc_chain *cc);

/* The camera ray's power-heuristic weight 1 / (1 + r^2) of the path that hit the area light at
 * hit (h->emitter set) after k delta scatterings with these events from the camera (in the
 * camera's order), leaving its last vertex along dlast (toward the light). 1 where the strategy
 * does not make the path. w_base: the path's weight without this strategy (specular NEE from the
 * pinhole's); the strategy shares the path only where it is 1. */
double spc_path_lt_view_camera_weight(const spc_render_ctx *ctx, const spc_snee_params *p, const spc_hit *h,
                                      spc_vec3 dlast, int k, const unsigned char *events, double w_base);

/* One join of the strategy: film position (fx, fy), contribution C (to be weighted by w), the
 * ratio r and weight w, the chain from the light point y (normal ny) on e to the pinhole. */
typedef struct spc_path_lt_view_join {
    double fx, fy;
    spc_rgb C;
    double r, w;
    const spc_chain *cc;
    const spc_emitter *e;
    spc_vec3 y, ny;
} spc_path_lt_view_join;

/* One camera sample's draw (rng: a stream of it): each join with positive weight and an unblocked
 * view of the pinhole handed to sink (records live for the call). */
void spc_path_lt_view_joins(const spc_render_ctx *ctx, const spc_snee_params *p, spc_rng *rng,
                            void (*sink)(void *user, const spc_path_lt_view_join *j), void *user);

/* The same, splatted (spc_splat_add) with their weights. */
void spc_path_lt_view_trace(const spc_render_ctx *ctx, const spc_snee_params *p, spc_tls *tls, spc_rng *rng);

#endif
