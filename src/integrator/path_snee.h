/*
 * integrator/path_snee.h: specular NEE inside the path tracer, as a few hooks over one state.
 *
 * spc_path_sample (path.c) calls these at the points of its loop; with specular NEE off (or in the
 * ipt mode) every hook does nothing and returns the neutral value. What they keep:
 *   - the parameters as the path tracer runs them (the user's, with MIS against BSDF sampling unless
 *     "nomis" or the rough-vertex mode);
 *   - the exclusion track (spc_snee_track): since the last receiver, is the path still one that
 *     specular NEE covers, so that its emitter hit is weighted against specular NEE's light sample
 *     (or dropped) instead of counted twice;
 *   - the receiver the track started at (x, wo, the sampled direction), for that MIS weight;
 *   - the receivers passed (spc_snee_params.receivers, later_p), and whether the track started at
 *     the camera's pinhole (spc_snee_params.camera).
 * The contract of the covered paths and the weights is specular_nee.h's.
 */
#ifndef SPC_INTEGRATOR_PATH_SNEE_H
#define SPC_INTEGRATOR_PATH_SNEE_H

#include "integrator/context.h"
#include "integrator/path_lt.h"
#include "integrator/path_lt_view.h"
#include "manifold/caustic_guide.h"

typedef struct spc_path_snee {
    bool on;                 /* specular NEE runs in this path */
    spc_snee_track track;    /* the exclusion track */
    spc_vec3 mis_wo, mis_d0; /* the receiver the track started at (mis_x below): its wo and sampled
                                direction */
    bool cam_track;          /* the track started at the pinhole (until the first non-delta scattering) */
    double cam_scale;        /* the full film's pixels over the camera samples per pass */
    spc_vec3 cam_d0;         /* the camera ray's direction */
    int receivers;           /* non-delta vertices so far */
    int budget, long_budget; /* at the current vertex: the chain budget specular NEE used (0: none)
                                and the longer chains' bound */
    /* the next receiver's query was counted by splitting (path.c): its state is set up as usual,
     * its value not added */
    bool skip_query;
    /* the light-traced caustics (path_lt.h, params.lt_caustic): the path's first receiver x1, the
     * camera ray's hit, with its sampled direction (lt_x1, lt_w1 below), and the non-delta vertices
     * after it (lt_mid below), while at most SPC_PATH_LT_MID_MAX delta scatterings (lt_m) follow
     * each */
    const spc_render_ctx *ctx;
    int scatterings;
    bool lt_enabled, lt_on;
    int lt_m, lt_kmax, lt_kflat, lt_nmid; /* lt_kflat: spc_path_lt_point_flat_budget's */
    spc_vec3 lt_w1;
    unsigned char cam_events[SPC_CHAIN_MAX_VERTICES]; /* the delta scatterings before the first receiver */
    /* the camera's side of the receiver where params.alt_chain_ratio was set (area lights' light
     * tracing), kept for the BSDF side's weight of the paths that leave it (the state above moves
     * on with the path): x1 (alt_x1 below) and w1 (alt_x1_set: the second receiver), the delta
     * scatterings before it (the first receiver), the chain budget there and light tracing's for
     * flat chains */
    spc_vec3 alt_w1;
    bool alt_x1_set;
    int alt_scatterings, alt_kmax, alt_kflat;
    /* the light-guide caustics (path_lt.h, params.lt_guide): the camera ray's hit lg_x (below; left
     * toward the camera along lg_wo, along lg_d0 by a non-delta sample), the delta scatterings at
     * chain surfaces since (lg_k) and the last direction (lg_dlast); lg_on while the path is one the
     * strategy may make; lg_point_min: spc_path_lt_guide_point_min_chain's */
    bool lg_enabled, lg_on;
    int lg_k, lg_min, lg_point_min;
    spc_vec3 lg_wo, lg_d0, lg_dlast;
    /* the light seen through flat glass (path_lt_view.h, params.lt_view): lv_on while every
     * scattering since the camera was a delta one on a flat-faced shape, at most
     * SPC_PATH_LT_VIEW_MAX_CHAIN of them: their events (lv_ev, the camera's order) and the last
     * direction (lv_dlast) */
    bool lv_enabled, lv_on;
    int lv_k;
    unsigned char lv_ev[SPC_PATH_LT_VIEW_MAX_CHAIN];
    spc_vec3 lv_dlast;
    /* From here on spc_path_snee_begin clears nothing (most of the struct's size, cleared once per
     * camera sample at a measurable cost): each field is written before it is read, under the flag
     * or count above that says it holds a value (on, lt_on, lt_nmid, alt_x1_set, lg_on; gv by
     * spc_path_snee_guide_at at every vertex; mis_x where the track starts with params.mis, the only
     * case its weight reads it, and mis_gv with it, its flag mis_gv.a cleared). */
    spc_snee_params p;        /* the user's parameters, mis and query_p as this path runs them */
    /* the stream at the current vertex's light sample (skip_light_u), where p.light_u_smp points;
     * a copy of the state points at the original's until spc_path_snee_at_vertex runs on it */
    spc_sampler light_smp;
    spc_cguide_vertex gv;     /* the caustic guide at the current vertex (gv.a 0: none) */
    spc_cguide_vertex mis_gv; /* and at mis_x, the receiver the track started at */
    spc_hit mis_x;
    spc_hit lt_x1;
    spc_path_lt_vertex lt_mid[SPC_PATH_LT_MID_VERTICES > 0 ? SPC_PATH_LT_MID_VERTICES : 1];
    spc_hit alt_x1;
    spc_hit lg_x;
} spc_path_snee;

/* Begin a camera path (ray0, the camera ray; smp its sampler, not moved): the state, and with
 * params.camera specular NEE from the pinhole, its splats added to the tile (spc_splat_add). */
void spc_path_snee_begin(spc_path_snee *s, const spc_render_ctx *ctx, spc_tls *tls, const spc_ray *ray0,
                         const spc_sampler *smp);

/* Begin the state of a camera ray that only follows delta scatterings and counts the emission it
 * reaches (path_camsplit.h): the same exclusion track from the pinhole and the same records of the
 * light seen through flat glass and of the scatterings before the first receiver (light-traced
 * caustics' weights) as spc_path_snee_begin sets up, so that spc_path_snee_emitter_weight and the
 * weights at the first receiver give such a path the weight the camera path would give it; no
 * camera query, no light subpath, no sampler dimension. After each delta scattering at h the caller
 * calls spc_path_snee_delta_vertex, then spc_path_snee_scattered. */
void spc_path_snee_begin_view(spc_path_snee *s, const spc_render_ctx *ctx, const spc_ray *ray0);

/* At a vertex with a delta-only BSDF reached after `segments` segments: the chain budget state
 * spc_path_snee_at_vertex leaves there (no query, no sampler dimension). */
void spc_path_snee_delta_vertex(spc_path_snee *s, const spc_render_ctx *ctx, int segments);

/* At the first vertex h of such a camera ray whose BSDF is not delta only, reached after `segments`
 * segments: the state spc_path_snee_at_vertex leaves there (chain budgets, the query's probability)
 * without its query or a sampler dimension, so that the emission reached by a sample of h's BSDF
 * gets the weight the camera path gives it. Not with light-traced caustics (params.lt_caustic),
 * whose shares read the camera path's record of its scatterings. The caller then calls
 * spc_path_snee_scattered. */
void spc_path_snee_receiver_view(spc_path_snee *s, const spc_render_ctx *ctx, const spc_hit *h, int segments);

/* The weight of the emission at the surface hit h (h->emitter set, its emission not black) reached
 * by BSDF sampling, against specular NEE: 1 where specular NEE does not cover the path; else the
 * MIS weight against its light sample (spc_snee_mis_bsdf_weight, spc_snee_camera_bsdf_weight), 0
 * where the path is dropped. */
double spc_path_snee_emitter_weight(const spc_path_snee *s, const spc_render_ctx *ctx, const spc_hit *h);

/* Does ordinary NEE at h (toward e, direction wi) close a path specular NEE already counted (rough
 * chain vertices only)? */
bool spc_path_snee_light_covered(const spc_path_snee *s, const spc_scene *sc, const spc_hit *h, spc_vec3 wo,
                                 spc_vec3 wi, const spc_emitter *e);

/* Specular NEE at the path vertex h (wo toward the previous vertex; segments: the path's segments
 * so far), to be multiplied by the path throughput: chains within the depth left and the budget.
 * With specular NEE on, the light sample's uniforms come from smp's next two dimension pairs
 * (used up at every vertex, so that they stay aligned across a pixel's samples and stratified, and
 * computed only where the query samples a light); the rest of the estimate draws from a fork of it. With s->skip_query set (then cleared; the query was
 * counted by splitting, path.c): every state the later MIS weights read set up alike, the query
 * itself not made (black). */
spc_rgb spc_path_snee_at_vertex(spc_path_snee *s, const spc_render_ctx *ctx, const spc_hit *h, spc_vec3 wo,
                                int segments, spc_sampler *smp);

/* Does the path tracer split specular NEE at the reflection off the smooth dielectric h (path.c,
 * split_snee)? Where specular NEE runs, unless "nosplit", at triangle meshes only (tessellated
 * balls, slabs, panes): a tessellated ball seen from the camera reflects its own caustic on the
 * floor beside it, which no other strategy takes there (light tracing joins the pinhole through
 * analytic spheres only). At an analytic sphere those paths are light tracing's too (ltcaus), and
 * on a smooth SDF (caustic_sdf_torus) the split's queries cost 5-10% more CPU per sample for no
 * gain at equal CPU (bench/RESULTS.md, part tails30). */
bool spc_path_snee_splits(const spc_path_snee *s, const spc_hit *h);

/* On flat-faced glass (spc_flat_chain_shape: a cube, a slab, a pane), the reflection's probability
 * from which that split runs on every sample (params.split_f 0). The split removes the lobe
 * choice's variance, F (1 - F) Q^2 for a query value Q at the reflected receiver, at the cost of
 * one query per sample; taken by roulette with probability p and counted 1/p, it leaves
 * F^2 Q^2 (1/p - 1), and at p = min(1, F / S) that is F (S - F) Q^2, never more than the lobe
 * choice's (p >= F), for a query on a share F / S of the samples. The split's worth per query
 * grows with F: on the glass cube the reflections at F below 0.1 (its faces seen head-on) held 20%
 * of the variance it removes for 88% of its queries' CPU, those at F 0.25-1 (grazing, and inside
 * the glass) 80% for 8% (bench/RESULTS.md, "The split by roulette on flat glass"). On a
 * tessellated ball the split runs on every sample: its own caustic's fold, reflected at F
 * 0.04-0.1, gives query values that the roulette's S Q turned into one-pixel seeds (3 of 16 seeds
 * on a random scene). */
#define SPC_PATH_SPLIT_F 0.25
/* The sampler fork's stream of the split's roulette (spc_sampler_fork_rng). */
#define SPC_PATH_SPLIT_STREAM 0x73706c6974ULL

/* The probability that the split runs at the vertex h where the sampled path takes the reflection
 * with probability pr (its Fresnel term): on flat-faced glass min(1, pr / S), S the "splitf" option
 * or SPC_PATH_SPLIT_F; elsewhere 1. */
double spc_path_snee_split_prob(const spc_path_snee *s, const spc_hit *h, double pr);

/* The caustic guide (caustic_guide.h) at the path vertex h (wo toward the previous vertex), to
 * sample its continuation with spc_cguide_sample_mix and weigh it with spc_cguide_mix_pdf; specular
 * NEE at h (spc_path_snee_at_vertex) and the MIS weight of the paths it covers from h use the same
 * mixture. NULL where the guide does not run there (BSDF sampling alone). */
const spc_cguide_vertex *spc_path_snee_guide_at(spc_path_snee *s, const spc_hit *h, spc_vec3 wo);

/* After BSDF sampling at h (wo toward the previous vertex) chose direction wi in lobe `lobe`. */
void spc_path_snee_scattered(spc_path_snee *s, const spc_hit *h, spc_vec3 wo, spc_vec3 wi, unsigned lobe);

#endif
