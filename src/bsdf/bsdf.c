/*
 * bsdf/bsdf.c: dispatch of the BSDF contract (bsdf.h) to the variants by a switch on the type
 * (one file per variant, see variants.h), lobe flags of every variant, and the specular-interface
 * query used by the specular solvers.
 */
#include "bsdf/variants.h"

void spc_bsdf_prepare(spc_bsdf *b)
{
    if (b && b->type == SPC_BSDF_ROUGHPLASTIC)
        spc_roughplastic_prepare(b);
}

/* Can the texture be nonzero anywhere (a lobe weight that may switch a lobe on)? */
static bool maybe_nonzero(const spc_texture *t)
{
    return t && !(t->type == SPC_TEX_CONSTANT && t->value.r == 0.0 && t->value.g == 0.0 && t->value.b == 0.0);
}

unsigned spc_bsdf_flags(const spc_bsdf *b)
{
    if (!b)
        return 0;
    switch (b->type) {
    case SPC_BSDF_DIFFUSE:
    case SPC_BSDF_ROUGHDIFFUSE:
        return SPC_LOBE_DIFFUSE_REFLECTION;
    case SPC_BSDF_PHONG:
        return SPC_LOBE_DIFFUSE_REFLECTION | SPC_LOBE_GLOSSY_REFLECTION;
    case SPC_BSDF_CONDUCTOR:
        return SPC_LOBE_DELTA_REFLECTION;
    case SPC_BSDF_ROUGHCONDUCTOR:
        return SPC_LOBE_GLOSSY_REFLECTION;
    case SPC_BSDF_DIELECTRIC:
    case SPC_BSDF_THINDIELECTRIC:
        return SPC_LOBE_DELTA_REFLECTION | SPC_LOBE_DELTA_TRANSMISSION;
    case SPC_BSDF_ROUGHDIELECTRIC:
        return SPC_LOBE_GLOSSY_REFLECTION | SPC_LOBE_GLOSSY_TRANSMISSION;
    case SPC_BSDF_PLASTIC:
        return SPC_LOBE_DIFFUSE_REFLECTION | SPC_LOBE_DELTA_REFLECTION;
    case SPC_BSDF_ROUGHPLASTIC:
    case SPC_BSDF_PPLASTIC:
        return SPC_LOBE_DIFFUSE_REFLECTION | SPC_LOBE_GLOSSY_REFLECTION;
    case SPC_BSDF_TWOSIDED:
        return spc_bsdf_flags(b->nested[0]) | spc_bsdf_flags(b->nested[1]);
    case SPC_BSDF_NORMALMAP:
    case SPC_BSDF_BUMPMAP:
        return spc_bsdf_flags(b->nested[0]);
    case SPC_BSDF_NULL:
        return SPC_LOBE_NULL;
    case SPC_BSDF_MASK:
        return spc_bsdf_flags(b->nested[0]) | SPC_LOBE_NULL;
    case SPC_BSDF_BLENDBSDF:
        return spc_bsdf_flags(b->nested[0]) | spc_bsdf_flags(b->nested[1]);
    case SPC_BSDF_PRINCIPLED:
        return SPC_LOBE_DIFFUSE_REFLECTION | SPC_LOBE_GLOSSY_REFLECTION |
               (maybe_nonzero(b->pr.spec_trans) ? SPC_LOBE_GLOSSY_TRANSMISSION : 0u);
    case SPC_BSDF_PRINCIPLEDTHIN:
        return SPC_LOBE_DIFFUSE_REFLECTION | SPC_LOBE_GLOSSY_REFLECTION |
               (maybe_nonzero(b->pr.spec_trans) ? SPC_LOBE_GLOSSY_TRANSMISSION : 0u) |
               (maybe_nonzero(b->pr.diff_trans) ? SPC_LOBE_DIFFUSE_TRANSMISSION : 0u);
    }
    return 0;
}

bool spc_bsdf_reads_derivatives(const spc_bsdf *b)
{
    if (!b)
        return false;
    switch (b->type) {
    case SPC_BSDF_NORMALMAP: /* the texture frame's rotation (spc_shape_texture_frame), dndu, dndv */
    case SPC_BSDF_BUMPMAP:   /* dpdu, dpdv */
        return true;
    case SPC_BSDF_TWOSIDED:
    case SPC_BSDF_BLENDBSDF:
    case SPC_BSDF_MASK:
        return spc_bsdf_reads_derivatives(b->nested[0]) || spc_bsdf_reads_derivatives(b->nested[1]);
    case SPC_BSDF_DIFFUSE:
    case SPC_BSDF_ROUGHDIFFUSE:
    case SPC_BSDF_PHONG:
    case SPC_BSDF_CONDUCTOR:
    case SPC_BSDF_ROUGHCONDUCTOR:
    case SPC_BSDF_DIELECTRIC:
    case SPC_BSDF_THINDIELECTRIC:
    case SPC_BSDF_ROUGHDIELECTRIC:
    case SPC_BSDF_PLASTIC:
    case SPC_BSDF_ROUGHPLASTIC:
    case SPC_BSDF_PPLASTIC:
    case SPC_BSDF_NULL:
    case SPC_BSDF_PRINCIPLED:
    case SPC_BSDF_PRINCIPLEDTHIN:
        return false;
    }
    return true;
}

static bool texture_reads_uv(const spc_texture *t) { return t && t->type != SPC_TEX_CONSTANT; }

bool spc_bsdf_reads_uv(const spc_bsdf *b)
{
    if (!b)
        return false;
    if (b->type == SPC_BSDF_NORMALMAP || b->type == SPC_BSDF_BUMPMAP)
        return true; /* their maps, and the texture frame from the surface coordinates */
    const spc_principled_params *pr = &b->pr;
    const spc_texture *tex[] = {b->reflectance,  b->specular_reflectance, b->specular_transmittance, b->alpha_u,
                                b->alpha_v,      b->weight,               b->opacity,                pr->base_color,
                                pr->roughness,   pr->anisotropic,         pr->metallic,              pr->spec_trans,
                                pr->spec_tint,   pr->sheen,               pr->sheen_tint,            pr->flatness,
                                pr->clearcoat,   pr->clearcoat_gloss,     pr->diff_trans,            pr->eta_thin};
    for (size_t i = 0; i < sizeof tex / sizeof tex[0]; ++i)
        if (texture_reads_uv(tex[i]))
            return true;
    return spc_bsdf_reads_uv(b->nested[0]) || spc_bsdf_reads_uv(b->nested[1]);
}

spc_rgb spc_bsdf_eval(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    if (!b)
        return spc_rgb1(0.0);
    switch (b->type) {
    case SPC_BSDF_DIFFUSE: return spc_diffuse_eval(b, h, mode, wo, wi);
    case SPC_BSDF_ROUGHDIFFUSE: return spc_roughdiffuse_eval(b, h, mode, wo, wi);
    case SPC_BSDF_PHONG: return spc_phong_eval(b, h, mode, wo, wi);
    case SPC_BSDF_CONDUCTOR: return spc_conductor_eval(b, h, mode, wo, wi);
    case SPC_BSDF_ROUGHCONDUCTOR: return spc_roughconductor_eval(b, h, mode, wo, wi);
    case SPC_BSDF_DIELECTRIC: return spc_dielectric_eval(b, h, mode, wo, wi);
    case SPC_BSDF_THINDIELECTRIC: return spc_thindielectric_eval(b, h, mode, wo, wi);
    case SPC_BSDF_ROUGHDIELECTRIC: return spc_roughdielectric_eval(b, h, mode, wo, wi);
    case SPC_BSDF_PLASTIC: return spc_plastic_eval(b, h, mode, wo, wi);
    case SPC_BSDF_ROUGHPLASTIC: return spc_roughplastic_eval(b, h, mode, wo, wi);
    case SPC_BSDF_PPLASTIC: return spc_pplastic_eval(b, h, mode, wo, wi);
    case SPC_BSDF_TWOSIDED: return spc_twosided_eval(b, h, mode, wo, wi);
    case SPC_BSDF_NORMALMAP: return spc_normalmap_eval(b, h, mode, wo, wi);
    case SPC_BSDF_BUMPMAP: return spc_bumpmap_eval(b, h, mode, wo, wi);
    case SPC_BSDF_NULL: return spc_null_eval(b, h, mode, wo, wi);
    case SPC_BSDF_MASK: return spc_mask_eval(b, h, mode, wo, wi);
    case SPC_BSDF_BLENDBSDF: return spc_blendbsdf_eval(b, h, mode, wo, wi);
    case SPC_BSDF_PRINCIPLED: return spc_principled_eval(b, h, mode, wo, wi);
    case SPC_BSDF_PRINCIPLEDTHIN: return spc_principledthin_eval(b, h, mode, wo, wi);
    }
    return spc_rgb1(0.0);
}

double spc_bsdf_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi)
{
    if (!b)
        return 0.0;
    switch (b->type) {
    case SPC_BSDF_DIFFUSE: return spc_diffuse_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_ROUGHDIFFUSE: return spc_roughdiffuse_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_PHONG: return spc_phong_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_CONDUCTOR: return spc_conductor_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_ROUGHCONDUCTOR: return spc_roughconductor_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_DIELECTRIC: return spc_dielectric_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_THINDIELECTRIC: return spc_thindielectric_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_ROUGHDIELECTRIC: return spc_roughdielectric_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_PLASTIC: return spc_plastic_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_ROUGHPLASTIC: return spc_roughplastic_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_PPLASTIC: return spc_pplastic_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_TWOSIDED: return spc_twosided_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_NORMALMAP: return spc_normalmap_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_BUMPMAP: return spc_bumpmap_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_NULL: return spc_null_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_MASK: return spc_mask_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_BLENDBSDF: return spc_blendbsdf_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_PRINCIPLED: return spc_principled_pdf(b, h, mode, wo, wi);
    case SPC_BSDF_PRINCIPLEDTHIN: return spc_principledthin_pdf(b, h, mode, wo, wi);
    }
    return 0.0;
}

spc_rgb spc_bsdf_eval_pdf(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, spc_vec3 wi,
                          double *pdf)
{
    if (b && b->type == SPC_BSDF_ROUGHCONDUCTOR)
        return spc_roughconductor_eval_pdf(b, h, mode, wo, wi, pdf);
    if (b && b->type == SPC_BSDF_TWOSIDED)
        return spc_twosided_eval_pdf(b, h, mode, wo, wi, pdf);
    *pdf = spc_bsdf_pdf(b, h, mode, wo, wi);
    return spc_bsdf_eval(b, h, mode, wo, wi);
}

/* The one guard for every variant, one sample at a time or many: a sample is either usable or
 * reported as none. */
static bool sample_usable(const spc_bsdf_sample *s)
{
    return s->pdf > 0.0 && spc_rgb_finite(s->weight) && spc_v3_finite(s->wi);
}

bool spc_bsdf_sample_dir(const spc_bsdf *b, const spc_hit *h, spc_transport mode, spc_vec3 wo, double u_lobe,
                         spc_vec2 u, spc_bsdf_sample *out)
{
    if (!b)
        return false;
    bool ok = false;
    switch (b->type) {
    case SPC_BSDF_DIFFUSE: ok = spc_diffuse_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_ROUGHDIFFUSE: ok = spc_roughdiffuse_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_PHONG: ok = spc_phong_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_CONDUCTOR: ok = spc_conductor_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_ROUGHCONDUCTOR: ok = spc_roughconductor_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_DIELECTRIC: ok = spc_dielectric_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_THINDIELECTRIC: ok = spc_thindielectric_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_ROUGHDIELECTRIC: ok = spc_roughdielectric_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_PLASTIC: ok = spc_plastic_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_ROUGHPLASTIC: ok = spc_roughplastic_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_PPLASTIC: ok = spc_pplastic_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_TWOSIDED: ok = spc_twosided_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_NORMALMAP: ok = spc_normalmap_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_BUMPMAP: ok = spc_bumpmap_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_NULL: ok = spc_null_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_MASK: ok = spc_mask_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_BLENDBSDF: ok = spc_blendbsdf_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_PRINCIPLED: ok = spc_principled_sample(b, h, mode, wo, u_lobe, u, out); break;
    case SPC_BSDF_PRINCIPLEDTHIN: ok = spc_principledthin_sample(b, h, mode, wo, u_lobe, u, out); break;
    }
    return ok && sample_usable(out);
}

void spc_bsdf_sample_dir_many(int n, const spc_bsdf *const b[], const spc_hit *const h[], spc_transport mode,
                              const spc_vec3 wo[], const double u_lobe[], const spc_vec2 u[], spc_bsdf_sample out[],
                              bool ok[])
{
    enum { BATCH = 16 };
    spc_hit flip[BATCH];
    const spc_bsdf *rb[BATCH];
    const spc_hit *rh[BATCH];
    spc_vec3 rwo[BATCH];
    spc_vec2 ru[BATCH];
    spc_bsdf_sample rout[BATCH];
    bool rok[BATCH];
    int lane[BATCH];
    for (int i0 = 0; i0 < n; i0 += BATCH) {
        int k = 0;
        for (int i = i0; i < n && i < i0 + BATCH; ++i) {
            /* a rough metal, or twosided's rough-metal side that wo sees (with twosided's flipped
             * hit): to the batch; every other BSDF one at a time */
            const spc_bsdf *nb = b[i];
            const spc_hit *hs = h[i];
            if (!nb) {
                ok[i] = false;
                continue;
            }
            if (nb->type == SPC_BSDF_TWOSIDED)
                nb = spc_twosided_side(nb, h[i], wo[i], &flip[i - i0], &hs);
            if (!(nb && nb->type == SPC_BSDF_ROUGHCONDUCTOR)) {
                ok[i] = spc_bsdf_sample_dir(b[i], h[i], mode, wo[i], u_lobe[i], u[i], &out[i]);
                continue;
            }
            rb[k] = nb;
            rh[k] = hs;
            rwo[k] = wo[i];
            ru[k] = u[i];
            lane[k++] = i;
        }
        spc_roughconductor_sample_many(k, rb, rh, rwo, ru, rout, rok);
        for (int j = 0; j < k; ++j) {
            int i = lane[j];
            out[i] = rout[j];
            ok[i] = rok[j] && sample_usable(&out[i]);
        }
    }
}

spc_rgb spc_bsdf_albedo(const spc_bsdf *b, const spc_hit *h)
{
    if (!b)
        return spc_rgb1(0.0);
    switch (b->type) {
    case SPC_BSDF_DIFFUSE: return spc_diffuse_albedo(b, h);
    case SPC_BSDF_ROUGHDIFFUSE: return spc_roughdiffuse_albedo(b, h);
    case SPC_BSDF_PHONG: return spc_phong_albedo(b, h);
    case SPC_BSDF_CONDUCTOR: return spc_conductor_albedo(b, h);
    case SPC_BSDF_ROUGHCONDUCTOR: return spc_roughconductor_albedo(b, h);
    case SPC_BSDF_DIELECTRIC: return spc_dielectric_albedo(b, h);
    case SPC_BSDF_THINDIELECTRIC: return spc_thindielectric_albedo(b, h);
    case SPC_BSDF_ROUGHDIELECTRIC: return spc_roughdielectric_albedo(b, h);
    case SPC_BSDF_PLASTIC: return spc_plastic_albedo(b, h);
    case SPC_BSDF_ROUGHPLASTIC: return spc_roughplastic_albedo(b, h);
    case SPC_BSDF_PPLASTIC: return spc_pplastic_albedo(b, h);
    case SPC_BSDF_TWOSIDED: return spc_twosided_albedo(b, h);
    case SPC_BSDF_NORMALMAP: return spc_normalmap_albedo(b, h);
    case SPC_BSDF_BUMPMAP: return spc_bumpmap_albedo(b, h);
    case SPC_BSDF_NULL: return spc_null_albedo(b, h);
    case SPC_BSDF_MASK: return spc_mask_albedo(b, h);
    case SPC_BSDF_BLENDBSDF: return spc_blendbsdf_albedo(b, h);
    case SPC_BSDF_PRINCIPLED: return spc_principled_albedo(b, h);
    case SPC_BSDF_PRINCIPLEDTHIN: return spc_principledthin_albedo(b, h);
    }
    return spc_rgb1(0.0);
}

bool spc_bsdf_has_null(const spc_bsdf *b)
{
    if (!b)
        return false;
    if (b->type == SPC_BSDF_THINDIELECTRIC || b->type == SPC_BSDF_NULL || b->type == SPC_BSDF_MASK)
        return true;
    if (b->type == SPC_BSDF_TWOSIDED)
        return spc_bsdf_has_null(b->nested[0]) || spc_bsdf_has_null(b->nested[1]);
    return false;
}

spc_rgb spc_bsdf_null_transmission(const spc_bsdf *b, const spc_hit *h, spc_vec3 wo)
{
    if (!b)
        return spc_rgb1(0.0);
    switch (b->type) {
    case SPC_BSDF_NULL: return spc_null_null_transmission(b, h);
    case SPC_BSDF_MASK: return spc_mask_null_transmission(b, h);
    case SPC_BSDF_THINDIELECTRIC: return spc_thindielectric_null_transmission(b, h, wo);
    case SPC_BSDF_TWOSIDED: {
        /* the side wo is on picks the nested BSDF, as twosided's sampling does */
        const spc_bsdf *side = spc_dot(wo, h->sh.n) >= 0.0 || !b->nested[1] ? b->nested[0] : b->nested[1];
        return spc_bsdf_null_transmission(side, h, wo);
    }
    case SPC_BSDF_DIFFUSE:
    case SPC_BSDF_ROUGHDIFFUSE:
    case SPC_BSDF_PHONG:
    case SPC_BSDF_CONDUCTOR:
    case SPC_BSDF_ROUGHCONDUCTOR:
    case SPC_BSDF_DIELECTRIC:
    case SPC_BSDF_ROUGHDIELECTRIC:
    case SPC_BSDF_PLASTIC:
    case SPC_BSDF_ROUGHPLASTIC:
    case SPC_BSDF_PPLASTIC:
    case SPC_BSDF_NORMALMAP:
    case SPC_BSDF_BUMPMAP:
    case SPC_BSDF_BLENDBSDF:
    case SPC_BSDF_PRINCIPLED:
    case SPC_BSDF_PRINCIPLEDTHIN: return spc_rgb1(0.0);
    }
    return spc_rgb1(0.0);
}

bool spc_bsdf_sample_is_null(const spc_bsdf *b, const spc_bsdf_sample *bs)
{
    if (bs->lobe == SPC_LOBE_NULL)
        return true;
    /* a thin sheet's straight transmission (reported as a delta transmission with eta 1) */
    return bs->lobe == SPC_LOBE_DELTA_TRANSMISSION && spc_bsdf_has_null(b) && bs->eta == 1.0 &&
           (b->type == SPC_BSDF_THINDIELECTRIC ||
            (b->type == SPC_BSDF_TWOSIDED && b->nested[0]->type == SPC_BSDF_THINDIELECTRIC &&
             (!b->nested[1] || b->nested[1]->type == SPC_BSDF_THINDIELECTRIC)));
}

bool spc_bsdf_is_specular_interface(const spc_bsdf *b, double *eta)
{
    if (eta)
        *eta = 0.0;
    if (!b)
        return false;
    switch (b->type) {
    case SPC_BSDF_CONDUCTOR:
        return true;
    case SPC_BSDF_DIELECTRIC:
        if (eta)
            *eta = b->eta;
        return true;
    case SPC_BSDF_TWOSIDED:
        /* a two-sided mirror is still a mirror on both sides; only when both sides agree (and not
         * over a normal map: the chains map only a normalmap at the top) */
        if (b->nested[0] && b->nested[0]->type == SPC_BSDF_NORMALMAP)
            return false;
        if (b->nested[1] && b->nested[1] != b->nested[0]) {
            double e0, e1;
            bool s0 = spc_bsdf_is_specular_interface(b->nested[0], &e0);
            bool s1 = spc_bsdf_is_specular_interface(b->nested[1], &e1);
            if (!(s0 && s1 && e0 == e1))
                return false;
        }
        return spc_bsdf_is_specular_interface(b->nested[0], eta);
    case SPC_BSDF_NORMALMAP:
        /* the chain maps the normal at each vertex (spc_bsdf_map_chain_hit) */
        return spc_bsdf_is_specular_interface(b->nested[0], eta);
    case SPC_BSDF_DIFFUSE:
    case SPC_BSDF_ROUGHDIFFUSE:
    case SPC_BSDF_PHONG:
    case SPC_BSDF_ROUGHCONDUCTOR:
    case SPC_BSDF_THINDIELECTRIC: /* no bending: the solvers treat it as a null-like sheet */
    case SPC_BSDF_ROUGHDIELECTRIC:
    case SPC_BSDF_PLASTIC:        /* has a diffuse lobe besides its coating */
    case SPC_BSDF_ROUGHPLASTIC:
    case SPC_BSDF_PPLASTIC:
    case SPC_BSDF_BUMPMAP:
    case SPC_BSDF_NULL:
    case SPC_BSDF_MASK:
    case SPC_BSDF_BLENDBSDF:
    case SPC_BSDF_PRINCIPLED:
    case SPC_BSDF_PRINCIPLEDTHIN:
        return false;
    }
    return false;
}

const char *spc_bsdf_type_name(spc_bsdf_type t)
{
    switch (t) {
    case SPC_BSDF_DIFFUSE: return "diffuse";
    case SPC_BSDF_ROUGHDIFFUSE: return "roughdiffuse";
    case SPC_BSDF_PHONG: return "phong";
    case SPC_BSDF_CONDUCTOR: return "conductor";
    case SPC_BSDF_ROUGHCONDUCTOR: return "roughconductor";
    case SPC_BSDF_DIELECTRIC: return "dielectric";
    case SPC_BSDF_THINDIELECTRIC: return "thindielectric";
    case SPC_BSDF_ROUGHDIELECTRIC: return "roughdielectric";
    case SPC_BSDF_PLASTIC: return "plastic";
    case SPC_BSDF_ROUGHPLASTIC: return "roughplastic";
    case SPC_BSDF_PPLASTIC: return "pplastic";
    case SPC_BSDF_TWOSIDED: return "twosided";
    case SPC_BSDF_NORMALMAP: return "normalmap";
    case SPC_BSDF_BUMPMAP: return "bumpmap";
    case SPC_BSDF_NULL: return "null";
    case SPC_BSDF_MASK: return "mask";
    case SPC_BSDF_BLENDBSDF: return "blendbsdf";
    case SPC_BSDF_PRINCIPLED: return "principled";
    case SPC_BSDF_PRINCIPLEDTHIN: return "principledthin";
    }
    return "?";
}

double spc_bsdf_adjoint_factor(const spc_hit *h, spc_vec3 wo, spc_vec3 wi)
{
    const spc_bsdf *b = h->bsdf;
    spc_hit flip;
    const spc_hit *hs = h;
    if (b && b->type == SPC_BSDF_TWOSIDED) /* the side the importance call takes, by wo */
        b = spc_twosided_side(b, h, wo, &flip, &hs);
    /* a chain's hit already mapped (spc_bsdf_map_chain_hit) carries the map's normal in sh */
    if (!b || h->normal_mapped || (b->type != SPC_BSDF_NORMALMAP && b->type != SPC_BSDF_BUMPMAP))
        return spc_bsdf_shading_adjoint(wo, wi, h->ng, h->sh.n);
    spc_hit po, pc;
    if (b->type == SPC_BSDF_NORMALMAP)
        spc_normalmap_hit_frame(b, hs, &po);
    else
        spc_bumpmap_hit_frame(b, hs, &po);
    pc = po;
    spc_bsdf_perturbed_face_view(hs, &po, wo); /* the frame the importance call used */
    spc_bsdf_perturbed_face_view(hs, &pc, wi); /* the frame the camera's radiance call uses */
    double den = spc_absdot(wo, h->ng) * spc_absdot(wi, po.sh.n) * spc_bsdf_bump_shadowing(hs, &po, wi);
    if (!(den > 0.0))
        return 0.0;
    return spc_absdot(wo, pc.sh.n) * spc_absdot(wi, h->ng) * spc_bsdf_bump_shadowing(hs, &pc, wo) / den;
}
