/*
 * io/mitsuba_principled.c: the parameters of Mitsuba 3's principled and principledthin BSDFs
 * (src/bsdf/principled.c and principledthin.c list them with their defaults), read as Mitsuba
 * reads them: every weight a float or a texture; principled's IOR from `eta` or from `specular`
 * (eta = 2 / (1 - sqrt(0.08 specular)) - 1, Burley 2015's mapping), never both; with spec_trans
 * given, eta 1 and specular 0 (no interface to refract at) are moved to 1.001 and 0.001.
 */
#include <string.h>

#include "io/mitsuba_builders.h"

/* Mitsuba's get_flag: the parameter is given and is not the float 0. */
static bool given(mts_props *P, const char *name)
{
    for (int i = 0; i < P->n; ++i) {
        const mts_prop *p = &P->p[i];
        if (p->name && strcmp(p->name, name) == 0)
            return !((p->kind == MTS_FLOAT || p->kind == MTS_INT) && p->f == 0.0);
    }
    return false;
}

/* A float texture parameter: negative weights are refused where Mitsuba's range is [0, 1]. */
static const spc_texture *weight(mts_loader *L, mts_props *P, const char *name, double def)
{
    const spc_texture *t = mts_get_texture(L, P, name, spc_rgb1(def));
    if (t && L->status == SPC_OK && spc_texture_is_constant(t) &&
        !(t->value.r >= 0.0 && t->value.g >= 0.0 && t->value.b >= 0.0))
        mts_fail(L, mts_where(P, name), SPC_ERR_VALUE, "%s must not be negative", name);
    return t;
}

/* Both BSDFs' parameters into b (b->type set). */
static void read_params(mts_loader *L, mts_props *P, spc_bsdf *b, const spc_xml_node *node)
{
    bool thin = b->type == SPC_BSDF_PRINCIPLEDTHIN;
    spc_principled_params *pr = &b->pr;
    pr->base_color = mts_get_texture(L, P, "base_color", spc_rgb1(0.5));
    pr->roughness = weight(L, P, "roughness", 0.5);
    pr->anisotropic = weight(L, P, "anisotropic", 0.0);
    pr->spec_trans = weight(L, P, "spec_trans", 0.0);
    pr->spec_tint = weight(L, P, "spec_tint", 0.0);
    pr->sheen = weight(L, P, "sheen", 0.0);
    pr->sheen_tint = weight(L, P, "sheen_tint", 0.0);
    pr->flatness = weight(L, P, "flatness", 0.0);
    bool has_spec_trans = given(P, "spec_trans");
    if (thin) {
        pr->diff_trans = weight(L, P, "diff_trans", 0.0);
        pr->eta_thin = mts_get_texture(L, P, "eta", spc_rgb1(1.5));
        pr->rate_spec = mts_get_float(L, P, "specular_reflectance_sampling_rate", 1.0);
        pr->rate_spec_trans = mts_get_float(L, P, "specular_transmittance_sampling_rate", 1.0);
        pr->rate_diffuse = mts_get_float(L, P, "diffuse_reflectance_sampling_rate", 1.0);
        pr->rate_diff_trans = mts_get_float(L, P, "diffuse_transmittance_sampling_rate", 1.0);
        if (L->status == SPC_OK && pr->eta_thin && spc_texture_is_constant(pr->eta_thin) &&
            !(pr->eta_thin->value.r > 0.0))
            mts_fail(L, mts_where(P, "eta"), SPC_ERR_VALUE, "principledthin: eta must be positive");
    } else {
        pr->metallic = weight(L, P, "metallic", 0.0);
        pr->clearcoat = weight(L, P, "clearcoat", 0.0);
        pr->clearcoat_gloss = weight(L, P, "clearcoat_gloss", 0.0);
        pr->rate_spec = mts_get_float(L, P, "main_specular_sampling_rate", 1.0);
        pr->rate_clearcoat = mts_get_float(L, P, "clearcoat_sampling_rate", 1.0);
        pr->rate_diffuse = mts_get_float(L, P, "diffuse_reflectance_sampling_rate", 1.0);
        if (mts_has(P, "eta") && mts_has(P, "specular")) {
            mts_fail(L, mts_where(P, "specular"), SPC_ERR_VALUE, "principled: give either eta or specular, not both");
        } else if (mts_has(P, "eta")) {
            b->eta = mts_get_float(L, P, "eta", 1.5);
            if (has_spec_trans && b->eta == 1.0)
                b->eta = 1.001;
            if (L->status == SPC_OK && !(b->eta > 0.0))
                mts_fail(L, mts_where(P, "eta"), SPC_ERR_VALUE, "principled: eta %g must be positive", b->eta);
        } else {
            double specular = mts_get_float(L, P, "specular", 0.5);
            if (has_spec_trans && specular == 0.0)
                specular = 1e-3;
            if (L->status == SPC_OK && !(specular >= 0.0 && specular < 12.5))
                mts_fail(L, mts_where(P, "specular"), SPC_ERR_VALUE,
                         "principled: specular %g outside [0, 12.5) (it maps to an IOR)", specular);
            else
                b->eta = 2.0 / (1.0 - sqrt(0.08 * specular)) - 1.0;
        }
    }
    double rates[5] = {pr->rate_spec, pr->rate_spec_trans, pr->rate_clearcoat, pr->rate_diffuse, pr->rate_diff_trans};
    for (int k = 0; k < 5; ++k)
        if (L->status == SPC_OK && !(rates[k] >= 0.0))
            mts_fail(L, node, SPC_ERR_VALUE, "%s: sampling rates must not be negative", mts_type(node));
}

/* ---- the builders the plugin registry names ---- */

void mts_bsdf_principled(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_PRINCIPLED;
    read_params(a->L, a->P, b, a->node);
}

void mts_bsdf_principledthin(const mts_build *a)
{
    spc_bsdf *b = a->object;
    b->type = SPC_BSDF_PRINCIPLEDTHIN;
    read_params(a->L, a->P, b, a->node);
}
