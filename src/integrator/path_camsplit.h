/*
 * integrator/path_camsplit.h: the camera-side split of the light seen through glass, for the path
 * tracer (the user's "camsplit[=K]", spc_snee_params.cam_split).
 *
 * The paths camera -> k >= 1 delta scatterings -> emitter (a light seen through a glass torus after
 * a reflection inside it, T R T, or through both sides of its tube, T T T T) are made by the camera
 * ray alone where no other strategy makes them (specular NEE from the pinhole takes chains of 1-2
 * vertices, light tracing joins the pinhole through spheres and flat faces): a thin, bright image
 * of a small light that a pixel's rays cross rarely, each hit worth hundreds. At equal CPU the
 * default takes 15-100x fewer camera samples than plain path tracing, so this class has that many
 * times plain path tracing's variance per CPU second (bench/RESULTS.md, "The SDF torus's tails
 * over 48 fresh seeds").
 *
 * Call this class C: the emission (and the environment) a camera path reaches at its second or a
 * later vertex while every vertex before was a surface whose BSDF is delta only. A sample's C part
 * is F(u), a function of the camera sample u (its film position, lens point and the lobe choices
 * along the way), and F(u) is 0 unless A(u): the camera ray's first hit is a delta-only surface.
 *
 * Where the camera ray's first hit is such a surface (A(u0)), up to SPC_PATH_CAMSPLIT_TRIALS K more
 * film positions are drawn in the same pixel from the film's filter (as the driver draws the camera
 * sample's) on a stream forked from the sample's sampler; those whose ray meets a delta-only
 * surface first are kept, up to K of them (M in all), and each follows its delta scatterings by
 * BSDF sampling, counting only class C's terms with the weights the camera path gives them
 * (spc_path_snee_emitter_weight on its own state, spc_path_snee_begin_view). The sample's C part is
 * then (F(u0) + sum of the kept rays' F) / (1 + M). Unbiased: the kept rays are draws of u given
 * A(u) (rejection), independent of one another and of u0, and given M = m (the number kept depends
 * only on which trials were accepted) still so; u0 given A(u0) is another such draw, so the mean of
 * the 1 + m has the conditional expectation E[F | A], and over u0 E[F 1_A] = E[F]. Every other
 * part of the sample is unchanged, and no dimension of the sampler is used, so with the option off
 * (or where the first hit is not delta-only glass) the image is bit for bit the same.
 *
 * With params.cam_split_recv (the user's "camrecv") the extra rays also take class D: the emission
 * (and the environment) a camera path reaches past its first vertex x whose BSDF is not delta only,
 * after at least one delta-only vertex past x while every vertex but x was delta only, on paths of
 * at least params.cam_split_recv_min delta vertices in all (camera ->
 * T T -> floor -> T R R R T -> light: a light guide seen from a floor seen through the glass; camera
 * -> T R...R T -> floor -> T T -> light: the floor's caustic reached through a light guide from the
 * camera). Such a path is BSDF sampling's at x, rare and worth hundreds where x is a bright
 * caustic's receiver behind the glass; no other strategy joins it (light tracing joins the pinhole
 * only where the camera sees x directly). Each kept ray samples x's BSDF once on its stream and
 * follows the delta scatterings after it, with x's specular NEE state as the camera path has it
 * (spc_path_snee_receiver_view) and so the same weights; the sample's class D part is the mean of
 * the 1 + M as for class C, by the same argument (class D is 0 without A as well). The direct
 * light at x, its queries and the emission x's sample reaches at once stay the camera path's.
 */
#ifndef SPC_INTEGRATOR_PATH_CAMSPLIT_H
#define SPC_INTEGRATOR_PATH_CAMSPLIT_H

#include "integrator/context.h"

/* Film positions tried per extra ray wanted: where the glass covers a sliver of the pixel most
 * trials miss it, and each costs one camera ray; the cap bounds that cost. */
#define SPC_PATH_CAMSPLIT_TRIALS 3
/* The stream key of the extra rays (spc_sampler_fork_rng). */
#define SPC_PATH_CAMSPLIT_STREAM 0x63616d73706c6974ULL

/* Does the split run in this render (params.cam_split, the path integrator with specular NEE, no
 * receiver guide)? */
bool spc_path_camsplit_enabled(const spc_render_ctx *ctx);

/* Do the extra rays also take class D (params.cam_split_recv, with the split on)? With light-traced
 * caustics (params.lt_caustic) the rays keep the camera path's record of its scatterings, which
 * their weights at the first receiver read (spc_path_snee_begin_view). */
bool spc_path_camsplit_recv(const spc_render_ctx *ctx);

/* A: is the camera ray's first hit h a surface that only reflects and refracts (delta-only BSDF)? */
bool spc_path_camsplit_first(const spc_hit *h);

/* The extra rays of the camera sample of pixel (tls->px, tls->py) whose sampler is smp (forked,
 * not moved): returns M, the rays kept, and adds to *sum the sum of their class C terms (and class
 * D's with spc_path_camsplit_recv). */
int spc_path_camsplit_rays(const spc_render_ctx *ctx, const spc_tls *tls, const spc_sampler *smp, spc_rgb *sum);

#endif
