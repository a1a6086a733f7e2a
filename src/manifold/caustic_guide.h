/*
 * manifold/caustic_guide.h: sampling directions toward the caustics that light a receiver.
 *
 * Specular NEE gives a caustic's radiance exactly where the camera path's vertex lies in it, but a
 * path that sees the caustic only through a diffuse bounce (the ceiling lit by the bright spot under
 * a glass ball) reaches that spot by BSDF sampling alone, rarely and with a large weight. The guide
 * makes that bounce less rare:
 *
 *   - a pre-pass (spc_cguide_build) traces light paths from the lights through at least one delta
 *     vertex to their first non-delta hit, and records where they land with their power (caustic
 *     photons); photons are binned in a grid on the landing surfaces and each busy cell becomes an
 *     entry: a disk at the photons' mean position, in the plane of their mean normal (toward the
 *     side the light came from), reaching the farthest of them (within the cell), with their
 *     power;
 *   - each glass caster (a refracting specular interface) that photons passed before they landed
 *     becomes a cone entry too: its sphere (spc_cguide_cone_sphere), with the power of those
 *     photons (the last glass caster each passed; at least 2% of the landed photons' power).
 *     A disk is aimed at in a straight line, so it cannot reach a caustic that a vertex sees only
 *     through the glass (the ceiling lit by the bright spot where a glass ball touches the floor,
 *     seen through the ball); the cone draws directions uniformly in the solid angle of the
 *     caster's sphere, and refraction takes a share of them to that caustic;
 *   - at a path vertex x (spc_cguide_vertex_init) each entry gets a selection weight: its power times
 *     the cosines at both ends over the squared distance (what the entry's radiance would give x,
 *     up to the albedo), zero for an entry x sees edge-on or from behind, or that lies behind x's
 *     surface when the BSDF only reflects (a cone: its power times the cosine at x over the squared
 *     distance, zero from within its sphere or where its centre lies behind x's surface);
 *   - the continuation direction is drawn from the defensive mixture
 *         p(w) = a p_guide(w) + (1 - a) p_bsdf(w),
 *     where p_guide picks an entry by its weight, a point uniformly on its disk and the direction
 *     toward it (a cone: a direction uniformly in the cone). p_guide is evaluable for any
 *     direction: the sum over entries of the selection probability times the disk's area density
 *     at the ray's crossing of the disk's plane, times t^2 / |cos| (a cone: 1 / its solid angle
 *     within it). The disks are a proposal only (no occlusion test; a direction toward an occluded
 *     disk is wasted, not wrong), so the estimator is unbiased for any cloud, and a = 0 (no entry
 *     seen from x) leaves the BSDF's sampling alone.
 * The path integrator uses the mixture's density wherever it used the BSDF's for that bounce: the
 * throughput, MIS against light NEE, and MIS of specular NEE against BSDF sampling (receiver.h: a
 * surface receiver's density is the mixture's when it carries a guide vertex).
 *
 * Determinism: the pre-pass uses one fixed stream per photon and runs on one thread; the entries do
 * not depend on thread count or timing.
 */
#ifndef SPC_MANIFOLD_CAUSTIC_GUIDE_H
#define SPC_MANIFOLD_CAUSTIC_GUIDE_H

#include <stdbool.h>
#include <stdint.h>

#include "scene/scene.h"

/* Light paths the render's pre-pass traces: one per film pixel, from SPC_CGUIDE_MIN_PHOTONS to
 * SPC_CGUIDE_MAX_PHOTONS, so that the pre-pass stays a few percent of a render of a few samples per
 * pixel or more: on the demo a light path costs about a tenth of a camera sample with specular NEE
 * (callgrind: 65536 of them, 5.5% of a 32x32 render at 16 spp), and some 4% of them reach the glass
 * or mirror ball. Not from the sample count: a render cancelled or resumed after some passes must
 * equal a render of that many passes (render/checkpoint.h), so the guide may not depend on how many
 * were asked for. */
#define SPC_CGUIDE_MIN_PHOTONS 8192
#define SPC_CGUIDE_MAX_PHOTONS 65536
static inline long spc_cguide_photons(double pixels)
{
    double n = pixels;
    return n < SPC_CGUIDE_MIN_PHOTONS   ? SPC_CGUIDE_MIN_PHOTONS
           : n > SPC_CGUIDE_MAX_PHOTONS ? SPC_CGUIDE_MAX_PHOTONS
                                        : (long)n;
}

/* The pre-pass's stream: fixed, so that every seed and thread count gets the same guide. */
#define SPC_CGUIDE_STREAM 0x63617573746963ULL

/* The most entries a guide keeps (the busiest cells): every vertex weighs each of them, and each
 * density evaluation tests the ray against each disk. */
#define SPC_CGUIDE_MAX_ENTRIES 32

typedef struct spc_cguide_entry {
    spc_vec3 c, n; /* disk centre and unit normal (toward the side the light arrived from); a cone's
                      sphere centre (n unused) */
    double r;      /* disk radius; a cone's sphere radius */
    double power;  /* the photons' power (luminance, W) */
    bool cone;     /* a cone toward a glass caster's sphere, not a disk */
} spc_cguide_entry;

typedef struct spc_cguide {
    int n; /* entries */
    spc_cguide_entry e[SPC_CGUIDE_MAX_ENTRIES];
    double a;     /* the mixture's guide probability at a vertex that sees an entry */
    long photons; /* light paths traced */
    long landed;  /* of them, landed after a delta vertex */
    double power; /* the power the landed photons carry */
    int cones;    /* of the entries, cones toward glass casters (the last ones) */
} spc_cguide;

/* The sphere a cone entry aims at for glass caster s of scene sc: s's own sphere (an analytic
 * sphere, or the one fitted to a triangle ball), else the one around its bounding box. False where
 * that sphere reaches further than SPC_CGUIDE_MAX_CONE of the scene's radius (a water surface over
 * a pool): a cone there fills most of a vertex's sky and guides nowhere. */
#define SPC_CGUIDE_MAX_CONE 0.5
bool spc_cguide_cone_sphere(const spc_scene *sc, const spc_shape *s, spc_vec3 *c, double *r);

/* Traces `photons` light paths (stream `seed`), and builds the guide with mixture probability a
 * (0 < a < 1). Returns NULL where no photon lands after a delta vertex (no caster lit) or memory
 * runs out: the caller then samples by the BSDF alone. Free with spc_cguide_destroy. */
spc_cguide *spc_cguide_build(const spc_scene *sc, long photons, uint64_t seed, double a);
void spc_cguide_destroy(spc_cguide *g);

/* The guide at one path vertex: the entries' selection weights from x. */
typedef struct spc_cguide_vertex {
    const spc_cguide *g;
    spc_vec3 x;
    double a;    /* the mixture probability at x (0: BSDF sampling alone) */
    double wsum; /* sum of w */
    int n;       /* the entries x weighs (w > 0): their indices in g->e and their weights */
    unsigned char idx[SPC_CGUIDE_MAX_ENTRIES];
    double w[SPC_CGUIDE_MAX_ENTRIES];
} spc_cguide_vertex;

/* The guide at the surface hit h (wo toward the previous vertex). g may be NULL (then a = 0). The
 * guide runs only at BSDFs with a smooth lobe and no transmission lobe. */
void spc_cguide_vertex_init(spc_cguide_vertex *v, const spc_cguide *g, const spc_hit *h, spc_vec3 wo);

/* Draws a direction from p_guide (u1 picks the entry, u2 the point on its disk): false where v->a
 * is 0 or the point is x itself. */
bool spc_cguide_sample(const spc_cguide_vertex *v, double u1, spc_vec2 u2, spc_vec3 *wi);

/* p_guide(wi) (solid angle at x; 0 where v->a is 0). */
double spc_cguide_pdf(const spc_cguide_vertex *v, spc_vec3 wi);

/* Samples the continuation at the surface hit h (wo toward the previous vertex) from the mixture
 * at v (radiance mode), as spc_bsdf_sample_dir does from the BSDF alone (which it is where v is
 * NULL or v->a is 0): u_lobe < a picks the guide (u_lobe / a its entry, u_dir the disk point),
 * else the BSDF with (u_lobe - a) / (1 - a). The record's pdf is the mixture's density of wi (for a
 * delta lobe the BSDF's probability times 1 - a) and weight = f |cos| / pdf. A guided direction is
 * reported as the BSDF's diffuse (else glossy) reflection lobe. False: no sample. */
bool spc_cguide_sample_mix(const spc_cguide_vertex *v, const spc_hit *h, spc_vec3 wo, double u_lobe, spc_vec2 u_dir,
                           struct spc_bsdf_sample *bs);

/* The mixture's density of wi, given the BSDF's density pdf_bsdf of it: a p_guide + (1 - a) pdf_bsdf;
 * pdf_bsdf itself where v is NULL or a is 0. */
static inline double spc_cguide_mix_pdf(const spc_cguide_vertex *v, double pdf_bsdf, spc_vec3 wi)
{
    if (!v || !(v->a > 0.0))
        return pdf_bsdf;
    return v->a * spc_cguide_pdf(v, wi) + (1.0 - v->a) * pdf_bsdf;
}

#endif
