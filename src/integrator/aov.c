/*
 * integrator/aov.c: the auxiliary images a denoiser reads (albedo, shading normal), with Open Image
 * Denoise's definitions (its documentation, "RT" filter, "Albedos" and "Normals"): the features of
 * the first surface with a non-delta lobe seen along the camera ray. A surface whose BSDF has only
 * delta lobes (a mirror, smooth glass, a null interface) is looked through: one of its lobes is
 * sampled, as a path would, and the walk goes on from there, so that over a pixel's samples the
 * albedo of smooth glass is the Fresnel blend of what it reflects and what it transmits. The albedo
 * seen through such surfaces is tinted by their lobes' weights in importance mode (the reflectance
 * or transmittance colour, without the radiance scaling of refraction) and clamped to [0, 1], the
 * range OIDN asks for. A walk that leaves the scene, or finds nothing but delta surfaces after
 * SPC_AOV_MAX_DELTA of them, gives albedo 0 and normal 0 (OIDN's "no surface").
 *
 * The walk draws from its own random stream (keyed by the sampler's pixel, sample index and
 * dimension), so the integrator's sample dimensions, and therefore its image, are the same with
 * and without AOVs. Media are not sampled on the walk.
 */
#include "integrator/aov.h"

/* Delta surfaces followed before giving up: internal reflections in a glass ball rarely pass 8;
 * 16 costs nothing where fewer suffice. */
#define SPC_AOV_MAX_DELTA 16

static double clamp01(double v) { return v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0; }

void spc_aov_from_hit(const spc_render_ctx *ctx, const spc_hit *h0, spc_vec3 wo0, const spc_sampler *smp,
                      spc_sample_out *out)
{
    out->depth = h0->t;
    out->albedo = spc_rgb1(0.0);
    out->normal = spc_v3(0, 0, 0);
    spc_hit h = *h0;
    spc_vec3 wo = wo0;
    spc_rgb tint = spc_rgb1(1.0);
    spc_rng rng;
    bool seeded = false;
    for (int k = 0;; ++k) {
        if (!h.bsdf || !spc_bsdf_is_delta_only(h.bsdf) || !ctx->aovs) {
            spc_rgb a = spc_rgb_mul(tint, spc_bsdf_albedo(h.bsdf, &h));
            out->albedo = (spc_rgb){clamp01(a.r), clamp01(a.g), clamp01(a.b)};
            out->normal = h.sh.n;
            return;
        }
        if (k >= SPC_AOV_MAX_DELTA)
            return;
        if (!seeded) {
            spc_sampler_fork_rng(smp, 0x616f76u /* "aov": a stream of its own */, &rng);
            seeded = true;
        }
        double u_lobe = spc_rng_next(&rng);
        spc_vec2 u_dir = {spc_rng_next(&rng), spc_rng_next(&rng)};
        spc_bsdf_sample bs;
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_IMPORTANCE, wo, u_lobe, u_dir, &bs))
            return;
        tint = spc_rgb_mul(tint, bs.weight);
        if (spc_rgb_is_black(tint))
            return;
        spc_ray ray = spc_hit_spawn(&h, bs.wi);
        if (!spc_scene_intersect(ctx->scene, &ray, &h))
            return;
        wo = spc_neg(ray.d);
    }
}
