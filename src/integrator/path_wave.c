/*
 * integrator/path_wave.c: path.c's plain path tracer (path with specular NEE off, ipt) run over many
 * camera samples at once, their rays traced in packets (path_wave.h).
 *
 * A wave holds up to WAVE_MAX lanes (a tile's camera samples), each one path. One step of the wave
 * traces every live lane's ray, in packets of the scene's width (spc_scene_intersect_packet); each
 * lane then takes what path.c does at the hit up to its light sample (emission, depth, strict normals,
 * next-event estimation's light point); the shadow rays go out in packets whose rays share an
 * octant, by Embree's coherent traversal (spc_scene_occluded_light_packet_coherent); the lanes'
 * BSDFs are sampled together (the diffuse ones' warps in one call, the others in
 * spc_bsdf_sample_dir_many, where rough metals share their visible-normal searches); each lane adds
 * its light sample's contribution, takes its BSDF sample and plays Russian roulette. A lane whose
 * path ends stores the estimate and takes the next camera sample while there is one; the live lanes
 * are then packed to the front, so the steps of the wave's last long paths cost what those paths
 * need. Where max_depth ends every path before Russian roulette starts (wave_lockstep) the wave
 * takes W samples at once and the next W when all of them have ended.
 *
 * Every lane draws its sampler dimensions in path.c's order (the live lanes' pairs of a stage at
 * once, spc_sampler_draw_many: the same values) and computes path.c's expressions in path.c's
 * order, so each estimate is bit for bit spc_path_sample's (test_path_wave checks it on whole
 * images); which lanes share a packet changes no answer. The light sample's MIS weight is computed
 * after the shadow ray, as path.c does, so occluded samples do not pay for the BSDF's pdf.
 */
#include "integrator/path_wave.h"

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "bsdf/diffuse_view.h"
#include "integrator/aov.h"

static atomic_uint_least64_t wave_samples;

uint64_t spc_path_wave_samples(void) { return atomic_load(&wave_samples); }

typedef struct lane {
    int path; /* the sample this lane runs (index into the caller's arrays); -1 when idle */
    spc_ray ray;
    spc_rgb L, beta;
    bool specular; /* the last scattering was a delta lobe (or it is the camera) */
    double prev_pdf, eta_scale;
    spc_vec3 prev_p;
    int segments; /* the path's segments once ray is traced */
    bool camera_ok; /* ray is the camera ray, already traced (the wave's cam[]): whether it hit something */
    /* the fields from here on are a step's own (the light sample at the current vertex, waiting for
     * its shadow ray, and the vertex's BSDF view), dead between steps: a lane moved to another
     * place between steps takes the fields above (lane_move) */
    bool shadow;
    spc_ray sr;
    spc_rgb f, Le;
    spc_vec3 wo, wi;
    double cosi, lp;
    double bsdf_pdf; /* the BSDF's density of wi (not for a diffuse view, whose pdf is cheap) */
    bool is_delta;
    /* the vertex's BSDF as a diffuse lobe (bsdf/diffuse_view.h), where it is one */
    bool diffuse;
    spc_diffuse_view dv;
} lane;

/* Lane `from`'s path into lane `to`, between two steps (the fields a step rewrites are left). */
static void lane_move(lane *to, const lane *from) { memcpy(to, from, offsetof(lane, shadow)); }

static bool depth_allows(int max_depth, int segments) { return max_depth < 0 || segments <= max_depth; }

bool spc_path_wave_applies(const spc_render_ctx *ctx)
{
    if (!(ctx->kind == SPC_INTEGRATOR_IPT || (ctx->kind == SPC_INTEGRATOR_PATH && ctx->specular_nee == SPC_SNEE_NONE)))
        return false;
    /* Embree's curve intersectors for packets round differently from the single-ray ones (the
     * curves scene's image changed), so scenes with curves keep path.c */
    for (int i = 0; i < ctx->scene->nshapes; ++i)
        if (ctx->scene->shapes[i]->type == SPC_SHAPE_CURVE)
            return false;
    return true;
}

static void lane_start(lane *ln, int path, const spc_ray *ray0, spc_sample_out *out)
{
    ln->path = path;
    ln->ray = *ray0;
    ln->L = spc_rgb1(0.0);
    ln->beta = spc_rgb1(1.0);
    ln->specular = true;
    ln->prev_pdf = 1.0;
    ln->eta_scale = 1.0;
    ln->prev_p = ray0->o;
    ln->segments = 1;
    ln->shadow = false;
    out->albedo = spc_rgb1(0.0);
    out->normal = spc_v3(0, 0, 0);
    out->depth = 0.0;
}

/* The camera rays of a tile's neighbouring pixels run nearly parallel, so each group of
 * SPC_SCENE_PACKET consecutive samples' camera rays is traced ahead as one coherent packet, the same
 * hits: bench_embree_replay measured Embree's coherent traversal at 25 ns per camera ray of the
 * cornell box, against 63 ns in incoherent packets of their own and 100 ns for the rays mixed in the
 * wave's packets. A lane that takes a sample fills its hit record from the group's answer in place
 * (a record is 300-odd bytes: filling the group's records and copying one into the lane cost 1.6 to
 * 2.1% of the cornell box) and leaves its first packet. */
typedef struct camera_hits {
    int group; /* samples [group W, group W + W) are traced, W the scene's packet width; -1: none yet */
    spc_scene_answer a[SPC_SCENE_PACKET];
} camera_hits;

/* lane_start for sample `path` of rays[0..n), with its camera hit filled in *h (the lane's record); the caller
 * marks the lane as holding its camera hit (the wave's cam[]). */
static void lane_take(const spc_render_ctx *ctx, lane *ln, spc_hit *h, int path, int n, const spc_ray *rays,
                      spc_sample_out *out, camera_hits *ch)
{
    const int W = spc_scene_packet_width(ctx->scene);
    int g = path / W, k = path % W;
    if (ch->group != g) {
        const spc_ray *r[SPC_SCENE_PACKET];
        for (int j = 0; j < W; ++j)
            r[j] = g * W + j < n ? &rays[g * W + j] : NULL;
        spc_scene_trace_packet_coherent(ctx->scene, r, ch->a);
        ch->group = g;
    }
    lane_start(ln, path, &rays[path], out);
    ln->camera_ok = spc_scene_fill_answer(ctx->scene, &rays[path], &ch->a[k], h);
}

/* path.c's loop body from the intersection to next-event estimation: emission, the depth, strict
 * normals. false: the path has ended. */
static bool lane_surface(const spc_render_ctx *ctx, lane *ln, bool hit, const spc_hit *h, spc_sampler *smp,
                         spc_sample_out *out)
{
    const spc_scene *sc = ctx->scene;
    const bool nee = ctx->kind == SPC_INTEGRATOR_PATH;
    const int segments = ln->segments;
    const spc_ray *ray = &ln->ray;
    ln->shadow = false;
    if (!hit) {
        if (sc->env && !(segments == 1 && ctx->hide_emitters)) {
            spc_rgb Le = spc_emitter_eval_infinite(sc->env, ray->d);
            double w = 1.0;
            if (nee && !ln->specular) {
                double lp = spc_scene_emitter_pmf(sc, sc->env) * spc_emitter_pdf_infinite(sc->env, ray->d);
                w = spc_mis_power(ln->prev_pdf, lp);
            }
            ln->L = spc_rgb_add(ln->L, spc_rgb_scale(spc_rgb_mul(ln->beta, Le), w));
        }
        return false;
    }
    spc_vec3 wo = spc_neg(ray->d);
    ln->wo = wo;
    if (segments == 1 && out->aovs)
        spc_aov_from_hit(ctx, h, wo, smp, out);
    if (h->emitter && !(segments == 1 && ctx->hide_emitters)) {
        spc_rgb Le = spc_emitter_eval_area(h->emitter, h, wo);
        if (!spc_rgb_is_black(Le)) {
            double w = 1.0;
            if (nee && !ln->specular) {
                double lp =
                    spc_scene_emitter_pmf(sc, h->emitter) * spc_emitter_pdf_direct(h->emitter, ln->prev_p, h->p, h->ng);
                w = spc_mis_power(ln->prev_pdf, lp);
            }
            ln->L = spc_rgb_add(ln->L, spc_rgb_scale(spc_rgb_mul(ln->beta, Le), w));
        }
    }
    if (!depth_allows(ctx->max_depth, segments + 1))
        return false;
    if (ctx->strict_normals && spc_dot(wo, h->ng) * spc_dot(wo, h->sh.n) < 0.0)
        return false;
    const spc_shape *s = h->shape;
    if (s->diffuse_const) {
        int side = spc_diffuse_view_side(h, wo);
        spc_diffuse_view_make(h, s->diffuse_sign[side], s->diffuse_albedo[side], &ln->dv);
        ln->diffuse = true;
    } else {
        ln->diffuse = spc_diffuse_view_of(h->bsdf, h, wo, &ln->dv);
    }
    return true;
}

/* Whether the vertex at h takes next-event estimation's light sample (path.c's test). */
static bool lane_takes_light(const spc_render_ctx *ctx, const lane *ln, const spc_hit *h)
{
    return ctx->kind == SPC_INTEGRATOR_PATH && (ln->diffuse || spc_bsdf_has_smooth(h->bsdf));
}

/* Next-event estimation's second half, with the light's sample ds (ok: spc_emitter_sample_direct's
 * result with path.c's u_lpos): the shadow ray (ln->shadow, ln->sr) and what its contribution needs. */
static void lane_light(const spc_render_ctx *ctx, lane *ln, const spc_hit *h, double pmf, bool ok,
                       const spc_emitter_direct *ds)
{
    const spc_bsdf *b = h->bsdf;
    const spc_vec3 wo = ln->wo;
    if (ok) {
        /* the BSDF's value and density in one call where they share terms (bsdf.h); a diffuse view's
         * value comes with |dot(wi, sh.n)| where it is not zero (and where it is, cosi is not read) */
        double cosi = 0.0;
        spc_rgb f = ln->diffuse ? spc_diffuse_view_eval_cos(&ln->dv, h, wo, ds->wi, &cosi)
                                : spc_bsdf_eval_pdf(b, h, SPC_MODE_RADIANCE, wo, ds->wi, &ln->bsdf_pdf);
        if (!ln->diffuse)
            cosi = spc_absdot(ds->wi, h->sh.n);
        if (ctx->strict_normals && !(spc_dot(ds->wi, h->ng) * spc_dot(ds->wi, h->sh.n) > 0.0))
            cosi = 0.0;
        if (!spc_rgb_is_black(f) && cosi > 0.0) {
            ln->shadow = true;
            ln->sr = ds->is_infinite ? spc_hit_spawn(h, ds->wi) : spc_hit_spawn_to(h, ds->p, ds->err);
            ln->f = f;
            ln->Le = ds->L;
            ln->wi = ds->wi;
            ln->cosi = cosi;
            ln->lp = pmf * ds->pdf;
            ln->is_delta = ds->is_delta;
        }
    }
}

/* path.c's loop body after the shadow ray (occluded: its answer): the light sample's contribution,
 * BSDF sampling with path.c's dimensions u_lobe, u_dir, u_rr, Russian roulette. At a diffuse vertex
 * *wl is u_dir's cosine-weighted direction (spc_warp_cosine_hemisphere); at any other vertex *pre is
 * spc_bsdf_sample_dir's sample with u_lobe and u_dir and pre_ok its result. false: the path has
 * ended. */
static bool lane_scatter(const spc_render_ctx *ctx, lane *ln, bool occluded, const spc_hit *h, const spc_vec3 *wl,
                         const spc_bsdf_sample *pre, bool pre_ok, double u_rr)
{
    const spc_vec3 wo = ln->wo;
    if (ln->shadow && !occluded) {
        double w = 1.0;
        if (!ln->is_delta) {
            /* a diffuse view's pdf is spc_diffuse_view_pdf's cos_i / pi: its value was not zero
             * (dot(wo, n) > 0 and cos_i = dot(wi, n) > 0), and cos_i is cosi, |dot(wi, sh.n)|, bit
             * for bit (n is sh.n times +1 or -1, negation is exact) */
            double pdf = ln->diffuse ? ln->cosi * SPC_INV_PI : ln->bsdf_pdf;
            w = spc_mis_power(ln->lp, pdf);
        }
        spc_rgb c = spc_rgb_mul(spc_rgb_mul(ln->beta, ln->f), ln->Le);
        ln->L = spc_rgb_add(ln->L, spc_rgb_scale(c, ln->cosi * w / ln->lp));
    }

    spc_bsdf_sample dbs;
    bool sampled = ln->diffuse ? spc_diffuse_view_sample_warped(&ln->dv, h, wo, *wl, &dbs) : pre_ok;
    if (!sampled)
        return false;
    const spc_bsdf_sample *bsp = ln->diffuse ? &dbs : pre;
    if (ctx->strict_normals && !(spc_dot(bsp->wi, h->ng) * spc_dot(bsp->wi, h->sh.n) > 0.0))
        return false;
    ln->beta = spc_rgb_mul(ln->beta, bsp->weight);
    if (spc_rgb_is_black(ln->beta))
        return false;
    ln->specular = (bsp->lobe & SPC_LOBE_DELTA) != 0;
    ln->prev_pdf = bsp->pdf;
    ln->prev_p = h->p;
    if (bsp->lobe & (SPC_LOBE_DELTA_TRANSMISSION | SPC_LOBE_GLOSSY_TRANSMISSION | SPC_LOBE_DIFFUSE_TRANSMISSION))
        ln->eta_scale *= bsp->eta * bsp->eta;
    ln->ray = spc_hit_spawn(h, bsp->wi);

    if (ln->segments >= ctx->rr_depth) {
        double q = spc_min(0.95, spc_rgb_max(ln->beta) * ln->eta_scale);
        if (!(u_rr < q))
            return false;
        ln->beta = spc_rgb_scale(ln->beta, 1.0 / q);
    }
    ++ln->segments;
    return true;
}

/* Whether the wave runs its lanes in lockstep. When max_depth ends every path by rr_depth, the paths
 * are short and of nearly equal length, and a path's last segment (the one max_depth stops at) only
 * looks for emission: refilled lanes mix such segments into the steps of the others, so each step's
 * light sampling, sampler draws and BSDF sampling run for fewer lanes. In lockstep those segments
 * share their steps, which then skip everything after the intersection. Paired CPU time, one thread
 * (bench/RESULTS.md, "part 9: one pixel's samples in the wave's lanes"): veach-mis (max_depth 3)
 * -10%, the cornell box at max_depth 3 -12% and at 5 -3%; with Russian roulette's long tails (the
 * cornell box's max_depth 30) lockstep left packets nearly empty and cost +3%. */
static bool wave_lockstep(const spc_render_ctx *ctx) { return ctx->max_depth > 0 && ctx->max_depth <= ctx->rr_depth; }

/* Lanes in a wave: a tile's camera samples (the driver's 16 x 16 pixels, one pass) at once. Against
 * a wave of 16 lanes (one packet), paired CPU time, one thread (bench/RESULTS.md, part perf23):
 * veach-mis -11%, the cornell box -14%. The vector stages (the sampler's draws, light samples, the
 * rough metals' searches) run over more lanes a call, and a step's shadow rays, grouped by octant,
 * fill packets of one octant, which Embree's coherent traversal takes at a lower cost per ray than
 * mixed packets (a replay of the cornell box's shadow rays: 41 -> 28 ns a ray with 256 lanes, 31
 * with 128, 37 with 64). Extension rays stay in Embree's incoherent traversal: its coherent one
 * breaks ties between coincident surfaces (scenes/mask_null.xml) in another order than single rays,
 * so the images would no longer be path.c's. The per-lane arrays take about 1.1 KB a lane, 290 KB
 * of the thread's stack. Fewer lanes, for records that fit a smaller cache, cost more than they
 * save: on an AVX2 host with 32 KiB of L1 data cache and 512 KiB of L2 a core, 128 and 64 lanes
 * took the cornell box's instructions +2.2% and +4.9% (each step's fixed work over fewer lanes,
 * emptier octant packets) and left its modelled L1 misses where they were (the records, 95 and
 * 48 KB, still pass through the L1 at every stage); paired CPU time, one thread, 128 / 64 / 32
 * lanes: the cornell box +2.6% / +11% / +14% (an A/A copy +1.4%), veach-mis +12% with 32 lanes
 * (128 and 64 within an A/A copy's +8%; bench/RESULTS.md, "the wave's width"). The width changes
 * no image: each lane's estimate is path.c's. */
enum { WAVE_MAX = 256 };

/* Packets of at most this many rays are traced as single rays (the same hits and answers, scene.h).
 * They are the remainders of the octant groups and the steps of a wave's last long paths: on the
 * cornell box (32 spp) 18% of the shadow-ray packets and 6% of the extension packets carry one or
 * two rays (2% and 0.5% of the rays). A packet call with one or two live rays costs more than as many
 * single-ray calls; paired CPU time, one thread, 2 against 0 (bench/RESULTS.md, part perf25a): the
 * cornell box -1.1% (faster in 22 of 32 rounds), veach-mis (few such packets) flat; 1 and 4 gained
 * less. */
enum { SINGLE_RAYS_MAX = 2 };
_Static_assert(WAVE_MAX <= SPC_EMITTER_MANY_MAX, "a wave's light samples in one call");
_Static_assert(WAVE_MAX % SPC_SCENE_PACKET == 0, "a wave's lanes in whole packets of 8 or 16");

/* The vertex's five sampler pairs that a lane reads (bits of spc_sampler_draw_many_used's use):
 * u_light, u_lpos and u_dir always; u_lobe only at a vertex that is not a diffuse view (a diffuse
 * lane's direction is u_dir's warp), u_rr only once Russian roulette plays (segments >= rr_depth). */
enum { USE_ALWAYS = 1u << 0 | 1u << 1 | 1u << 3, USE_LOBE = 1u << 2, USE_RR = 1u << 4 };

/* The octant of d (its three sign bits). */
static int octant(spc_vec3 d) { return (d.x < 0.0) | (d.y < 0.0) << 1 | (d.z < 0.0) << 2; }

/* The lanes [0, w) grouped by key[i], their rays' octants (8: the lane has no ray), in packets of
 * up to P lanes (at most SPC_SCENE_PACKET) of one octant: pk[k] the lane of packet slot k (-1: an idle slot); pk
 * holds OCTANT_PACKET_SLOTS entries. Returns the packets. The lanes without a ray go to a ninth
 * group after the packets, so that placing the lanes takes no branch on whether a lane has a ray
 * (lanes with and without a shadow ray alternate without a pattern). The keys are taken where the
 * rays are made, while the lanes' records are in cache.
 *
 * The lanes are counted and placed in OCTANT_WAYS interleaved sets (lane i in set i % OCTANT_WAYS),
 * each with its own counts and next slots, an octant's slots holding its lanes of set 0, then of
 * set 1, and so on. With one set (++count[key[i]], pk[start[key[i]]++] = i) each lane's load waited
 * for the lane before's store wherever both had one key, as neighbouring lanes mostly do (their
 * shadow rays aim at one light; the lanes without a ray share key 8): perf put 4.4% of the wave's
 * own time on the placing loop's two instructions (cornell box). Which lanes of an octant share a
 * packet changes no answer (trace_shadows). */
enum { OCTANT_PACKET_SLOTS = WAVE_MAX + 8 * SPC_SCENE_PACKET + WAVE_MAX, OCTANT_WAYS = 4 };
_Static_assert(WAVE_MAX % OCTANT_WAYS == 0, "a wave's lanes in whole sets");
static inline __attribute__((always_inline)) int octant_packets(int w, const unsigned char *key, const int P, int *pk)
{
    int count[OCTANT_WAYS][9] = {{0}};
    int i = 0;
    for (; i + OCTANT_WAYS <= w; i += OCTANT_WAYS)
        for (int s = 0; s < OCTANT_WAYS; ++s)
            ++count[s][key[i + s]];
    for (; i < w; ++i)
        ++count[i % OCTANT_WAYS][key[i]];
    int start[OCTANT_WAYS][9], np = 0;
    for (int k = 0; k < 9; ++k) {
        int at = np * P;
        for (int s = 0; s < OCTANT_WAYS; ++s) {
            start[s][k] = at;
            at += count[s][k];
        }
        if (k == 8)
            break;
        np += (at - np * P + P - 1) / P;
        /* the idle slots of the octant's last packet */
        for (int j = at; j < np * P; ++j)
            pk[j] = -1;
    }
    for (i = 0; i + OCTANT_WAYS <= w; i += OCTANT_WAYS)
        for (int s = 0; s < OCTANT_WAYS; ++s)
            pk[start[s][key[i + s]]++] = i + s;
    for (; i < w; ++i)
        pk[start[i % OCTANT_WAYS][key[i]]++] = i;
    return np;
}

/* The lanes' rays r[0, nl) (NULL: none) traced in packets of P consecutive lanes (the scene's width,
 * a constant in each inlined copy), their hits in h and hit; a packet of at most SINGLE_RAYS_MAX rays
 * as single rays. By Embree's incoherent traversal: its coherent one breaks ties between coincident
 * surfaces in another order than single rays. */
static inline __attribute__((always_inline)) void trace_lanes(const spc_scene *sc, int nl, const spc_ray *const *r,
                                                              spc_hit *h, bool *hit, const int P)
{
    for (int i0 = 0; i0 < nl; i0 += P) {
        const spc_ray *pr[SPC_SCENE_PACKET];
        int active = 0;
        for (int j = 0; j < P; ++j) {
            pr[j] = i0 + j < nl ? r[i0 + j] : NULL;
            active += pr[j] != NULL;
        }
        if (active > SINGLE_RAYS_MAX) {
            spc_scene_intersect_packet(sc, pr, h + i0, hit + i0);
            continue;
        }
        /* (a packet of camera samples has its hits already: active is 0) */
        for (int j = 0; j < P && i0 + j < nl; ++j) {
            hit[i0 + j] = false;
            if (pr[j]) {
                spc_scene_answer a;
                spc_scene_trace(sc, pr[j], &a);
                hit[i0 + j] = spc_scene_fill_answer(sc, pr[j], &a, &h[i0 + j]);
            }
        }
    }
}

/* The shadow rays r[0, nl) (NULL: none; le the emitters that sampled their ends) in packets of P
 * lanes of one octant each (okey, octant_packets; pk its slots), by Embree's coherent traversal (the
 * same answers: whether anything lies between two points has no ties to break): occluded[i] for
 * every lane with a ray. */
static inline __attribute__((always_inline)) void trace_shadows(const spc_scene *sc, int nl, const unsigned char *okey,
                                                                const spc_ray *const *r, const spc_emitter *const *le,
                                                                int *pk, bool *occluded, const int P)
{
    const int np = octant_packets(nl, okey, P, pk);
    for (int p = 0; p < np; ++p) {
        const spc_ray *pr[SPC_SCENE_PACKET];
        const spc_emitter *pe[SPC_SCENE_PACKET];
        bool po[SPC_SCENE_PACKET];
        int active = 0;
        for (int j = 0; j < P; ++j) {
            int i = pk[p * P + j];
            pr[j] = i >= 0 ? r[i] : NULL;
            pe[j] = i >= 0 ? le[i] : NULL;
            active += i >= 0;
        }
        if (active > SINGLE_RAYS_MAX)
            spc_scene_occluded_light_packet_coherent(sc, pr, pe, po);
        else
            for (int j = 0; j < P; ++j)
                po[j] = pr[j] && spc_scene_occluded_light(sc, pr[j], pe[j]);
        for (int j = 0; j < P; ++j)
            if (pk[p * P + j] >= 0)
                occluded[pk[p * P + j]] = po[j];
    }
}

void spc_path_wave_sample(const spc_render_ctx *ctx, spc_tls *tls, int n, const spc_ray *rays, spc_sampler *smp,
                          spc_sample_out *out)
{
    (void)tls; /* plain path tracing splats nothing */
    atomic_fetch_add(&wave_samples, (uint64_t)n);
    enum { W = WAVE_MAX };
    const int P = spc_scene_packet_width(ctx->scene); /* the packets' lanes: WAVE_MAX is a multiple */
    lane ln[WAVE_MAX];
    spc_hit h[WAVE_MAX];
    bool hit[WAVE_MAX], alive[WAVE_MAX], occluded[WAVE_MAX];
    const spc_ray *r[WAVE_MAX];
    spc_sampler *ls[WAVE_MAX];
    spc_vec2 u[5 * WAVE_MAX]; /* the lanes' pairs by pair number: lane i's k-th in u[k W + i] */
    const spc_emitter *le[WAVE_MAX];
    double pmf[WAVE_MAX];
    spc_vec3 ref[WAVE_MAX];
    spc_emitter_direct ds[WAVE_MAX];
    bool ds_ok[WAVE_MAX];
    spc_vec2 u_dir[WAVE_MAX];
    spc_vec3 wl[WAVE_MAX], wl_d[WAVE_MAX];
    int dlane[WAVE_MAX];
    const spc_bsdf *sb[WAVE_MAX];
    const spc_hit *sh[WAVE_MAX];
    spc_vec3 swo[WAVE_MAX];
    double su_lobe[WAVE_MAX];
    spc_vec2 su_dir[WAVE_MAX];
    spc_bsdf_sample bs[WAVE_MAX];
    bool bs_ok[WAVE_MAX];
    int sidx[WAVE_MAX];
    int pk[OCTANT_PACKET_SLOTS];
    /* what the stages' loops over the lanes test, kept apart from the lanes' records: a record
     * (ln[i], h[i]) is 700-odd bytes, a wave's records 190 KB, so a loop that reads one field of
     * every record misses the L1 cache at every lane (cachegrind's cache simulation of the cornell
     * box: the wave's own loops held three quarters of the render's L1 read misses) */
    bool cam[WAVE_MAX];   /* lane i's ray is its camera ray, traced: its hit waits in h[i] */
    bool nee[WAVE_MAX];   /* the live lane's vertex takes a light sample (lane_takes_light) */
    bool ended[WAVE_MAX]; /* the lane's path ended in this step and it took no next sample */
    unsigned char okey[WAVE_MAX]; /* the shadow rays' octants (8: none) */
    unsigned use[WAVE_MAX];       /* the pairs of u a lane reads at its vertex (USE_*) */
    int next = 0, live = 0;
    int nl = 0; /* the lanes in use, [0, nl): live lanes are kept packed at the front */
    const bool lockstep = wave_lockstep(ctx);
    camera_hits ch;
    ch.group = -1;
    while (live > 0 || next < n) {
        if (live == 0) /* the first samples, or in lockstep the next W */
            for (nl = 0; nl < W && next < n; ++nl) {
                lane_take(ctx, &ln[nl], &h[nl], next, n, rays, &out[next], &ch);
                cam[nl] = true;
                ++next;
                ++live;
            }
        /* (every lane in [0, nl) is live here: the ended ones were packed away) */
        for (int i = 0; i < nl; ++i)
            r[i] = cam[i] ? NULL : &ln[i].ray;
        /* the lanes' rays in packets of consecutive lanes (the live lanes are packed; a lane whose
         * camera hit waits has none); the packets' loops in a copy per width, whose loops over the
         * lanes of a packet unroll */
        if (P == 8)
            trace_lanes(ctx->scene, nl, r, h, hit, 8);
        else
            trace_lanes(ctx->scene, nl, r, h, hit, 16);
        for (int i = 0; i < nl; ++i) {
            if (cam[i]) {
                hit[i] = ln[i].camera_ok;
                cam[i] = false;
            }
            alive[i] = lane_surface(ctx, &ln[i], hit[i], &h[i], &smp[ln[i].path], &out[ln[i].path]);
            ls[i] = alive[i] ? &smp[ln[i].path] : NULL;
            nee[i] = alive[i] && lane_takes_light(ctx, &ln[i], &h[i]);
            if (nee[i])
                ref[i] = h[i].p;
            /* (a lane that ended has no vertex: its diffuse flag was never set) */
            use[i] = !alive[i] ? USE_ALWAYS
                               : USE_ALWAYS | (ln[i].diffuse ? 0u : USE_LOBE) |
                                     (ln[i].segments >= ctx->rr_depth ? USE_RR : 0u);
        }
        /* the vertex's dimensions of every live lane at once, in path.c's order: next-event
         * estimation's (u_light, u_lpos), then BSDF sampling's (u_lobe, u_dir, u_rr); u_light, u_lobe
         * and u_rr are 1D (path.c's spc_sampler_1d: their pairs' y are not computed), and a lane's
         * u_lobe and u_rr are computed only where it reads them (use[i]). Nothing between the two
         * stages draws from the lanes' streams. */
        spc_sampler_draw_many_used_by_pair(ls, use, nl, 5, 0xAu, u, W);
        /* the lights chosen, then every lane's light sample in one call (lanes of mesh lights share
         * vector instructions, emitter/area_many.c) */
        for (int i = 0; i < nl; ++i)
            le[i] = nee[i] ? spc_scene_sample_emitter(ctx->scene, u[i].x, &pmf[i]) : NULL;
        spc_emitter_sample_direct_many(nl, le, ref, u + W, ds, ds_ok);
        /* each live lane's light sample, and (while its record is in cache) its entry in the BSDF
         * samples' lists below: the diffuse lanes' directions, warped together (core/warp_many.c);
         * the other live lanes' BSDF samples in one call (rough metals share their visible-normal
         * searches, bsdf.h), lane i's in bs[sidx[i]] */
        int nd = 0, ns = 0;
        for (int i = 0; i < nl; ++i) {
            r[i] = NULL;
            occluded[i] = false;
            okey[i] = 8;
            if (!alive[i])
                continue;
            lane_light(ctx, &ln[i], &h[i], pmf[i], le[i] && ds_ok[i], &ds[i]);
            if (ln[i].shadow) {
                r[i] = &ln[i].sr;
                okey[i] = (unsigned char)octant(ln[i].sr.d);
            }
            if (ln[i].diffuse) {
                dlane[nd] = i;
                u_dir[nd++] = u[3 * W + i];
                continue;
            }
            sidx[i] = ns;
            sb[ns] = h[i].bsdf;
            sh[ns] = &h[i];
            swo[ns] = ln[i].wo;
            su_lobe[ns] = u[2 * W + i].x;
            su_dir[ns++] = u[3 * W + i];
        }
        /* the shadow rays in packets of one octant each */
        if (P == 8)
            trace_shadows(ctx->scene, nl, okey, r, le, pk, occluded, 8);
        else
            trace_shadows(ctx->scene, nl, okey, r, le, pk, occluded, 16);
        spc_warp_cosine_hemisphere_many(nd, u_dir, wl_d);
        for (int j = 0; j < nd; ++j)
            wl[dlane[j]] = wl_d[j];
        spc_bsdf_sample_dir_many(ns, sb, sh, SPC_MODE_RADIANCE, swo, su_lobe, su_dir, bs, bs_ok);
        for (int i = 0; i < nl; ++i) {
            ended[i] = false;
            const bool diffuse = alive[i] && ln[i].diffuse;
            if (alive[i] && lane_scatter(ctx, &ln[i], occluded[i], &h[i], &wl[i], diffuse ? NULL : &bs[sidx[i]],
                                         !diffuse && bs_ok[sidx[i]], use[i] & USE_RR ? u[4 * W + i].x : 0.0))
                continue;
            /* the path has ended: its estimate, and the lane takes the next sample */
            out[ln[i].path].L = ln[i].L;
            ln[i].path = -1;
            --live;
            if (!lockstep && next < n) {
                lane_take(ctx, &ln[i], &h[i], next, n, rays, &out[next], &ch);
                cam[i] = true;
                ++next;
                ++live;
            } else {
                ended[i] = true;
            }
        }
        /* the live lanes packed to the front, so that the steps of a wave's last paths do not walk
         * its ended lanes: each ended lane's place taken by the last lane (a lane's state is ln[i],
         * and h[i] where its camera hit waits) */
        for (int i = 0; i < nl;) {
            if (!ended[i]) {
                ++i;
                continue;
            }
            if (i != --nl) {
                lane_move(&ln[i], &ln[nl]);
                ended[i] = ended[nl];
                cam[i] = cam[nl];
                if (cam[i])
                    h[i] = h[nl];
            }
        }
    }
}
