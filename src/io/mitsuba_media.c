/*
 * io/mitsuba_media.c: the Mitsuba loader's participating media: <medium> and <phase> elements,
 * nested in a shape (name="interior" / "exterior"), in the sensor (the camera's medium), at the top
 * level with an id, or referenced by <ref>. Values are checked here and reported with file:line.
 *
 * <medium type="homogeneous"> (medium/homogeneous.c):
 *   sigma_a, sigma_s   spectrum/rgb/float   a missing one is 0 (0.x files: sigmaA, sigmaS)
 *   sigma_t, albedo    spectrum/rgb/float   1, 0.75 (Mitsuba 3); sigma_s = albedo sigma_t
 *   scale              float                1 (0.x: also densityMultiplier)
 *   sample_emitters    boolean              true
 *   <phase>            nested or ref        isotropic
 *   albedo may be a volume (gridvolume: sigma_s varies, sigma_t does not); sigma_t a constvolume.
 * <medium type="heterogeneous"> (medium/heterogeneous.c): sigma_t (volume or value, 1), albedo
 *   (volume or value, 0.75), scale (1), sample_emitters (true), has_spectral_extinction (ignored),
 *   <phase>. Volumes: io/mitsuba_volumes.c.
 * Giving both pairs (sigma_a/sigma_s and sigma_t/albedo) is an error, as are negative or non-finite
 * coefficients, albedo outside [0, 1], named materials ("material"), a grid as a homogeneous
 * medium's sigma_t and volumes as sigma_a or sigma_s.
 * <phase type="isotropic"/>; <phase type="hg">: g (0.8), -1 < g < 1.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/mitsuba_builders.h"

static bool check_rgb(mts_loader *L, mts_props *P, const char *name, spc_rgb v, double hi)
{
    double c[3] = {v.r, v.g, v.b};
    for (int i = 0; i < 3; ++i)
        if (!(c[i] >= 0.0 && c[i] <= hi && isfinite(c[i]))) {
            if (hi < INFINITY)
                mts_fail(L, mts_where(P, name), SPC_ERR_VALUE, "medium %s (%g, %g, %g) must lie in [0, %g]", name, v.r,
                         v.g, v.b, hi);
            else
                mts_fail(L, mts_where(P, name), SPC_ERR_VALUE,
                         "medium %s (%g, %g, %g) must be finite and not negative", name, v.r, v.g, v.b);
            return false;
        }
    return true;
}

/* Is the property `name` a nested volume? */
static bool volume_named(mts_props *P, const char *name)
{
    for (int i = 0; i < P->n; ++i) {
        const mts_prop *p = &P->p[i];
        if (p->name && strcmp(p->name, name) == 0)
            return p->kind == MTS_OBJECT && strcmp(p->obj->name, "volume") == 0;
    }
    return false;
}

/* A volume's values are finite and not negative (and at most 1 for an albedo). */
static bool check_volume(mts_loader *L, mts_props *P, const char *name, const spc_volume *v, bool albedo)
{
    if (!v->grid)
        return check_rgb(L, P, name, v->value, albedo ? 1.0 : INFINITY);
    size_t n = (size_t)v->res[0] * (size_t)v->res[1] * (size_t)v->res[2] * (size_t)v->channels;
    for (size_t i = 0; i < n; ++i)
        if (!(v->data[i] >= 0.0f) || (albedo && v->data[i] > 1.0f)) {
            mts_fail(L, mts_where(P, name), SPC_ERR_VALUE, "medium %s: grid value %zu is %g (must lie in [0, %s])",
                     name, i, (double)v->data[i], albedo ? "1" : "inf");
            return false;
        }
    return true;
}

/* ---- the phase function and medium builders: one per row of the plugin table ---- */

void mts_phase_isotropic(const mts_build *a) { ((spc_phase *)a->object)->type = SPC_PHASE_ISOTROPIC; }

void mts_phase_hg(const mts_build *a)
{
    spc_phase *out = a->object;
    double g = mts_get_float(a->L, a->P, "g", 0.8);
    if (a->L->status == SPC_OK && !(g > -1.0 && g < 1.0))
        mts_fail(a->L, mts_where(a->P, "g"), SPC_ERR_VALUE, "hg phase function g = %g must lie in (-1, 1)", g);
    out->type = SPC_PHASE_HG;
    out->g = g;
}

bool mts_build_phase(mts_loader *L, spc_xml_node *node, spc_phase *out)
{
    out->type = SPC_PHASE_ISOTROPIC;
    out->g = 0.0;
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return false;
    const char *type = mts_type(node);
    const mts_plugin *row = mts_plugin_find(L, "phase", type);
    if (row && row->build) {
        mts_build a = {.L = L, .node = node, .type = type, .P = &P, .object = out};
        row->build(&a);
    } else {
        mts_fail_plugin(L, node, "phase", type);
    }
    mts_props_end(&P);
    return L->status == SPC_OK;
}

/* homogeneous and heterogeneous (hetero): one reading of the coefficients, checked alike */
static void medium(const mts_build *a, bool hetero)
{
    mts_loader *L = a->L;
    mts_props *P = a->P;
    spc_xml_node *node = a->node;
    bool pair_as = mts_has(P, "sigma_a") || mts_has(P, "sigma_s");
    bool pair_ta = mts_has(P, "sigma_t") || mts_has(P, "albedo");
    if (!hetero && mts_is_grid_volume(P, "sigma_t")) {
        mts_fail(L, mts_where(P, "sigma_t"), SPC_ERR_VALUE,
                 "a homogeneous medium's sigma_t is one value; a grid of them makes a heterogeneous medium");
    } else if (volume_named(P, "sigma_a") || volume_named(P, "sigma_s")) {
        mts_fail(L, mts_where(P, volume_named(P, "sigma_a") ? "sigma_a" : "sigma_s"), SPC_ERR_VALUE,
                 "sigma_a and sigma_s are constants; give a volume as sigma_t or albedo");
    } else if (hetero && pair_as) {
        mts_fail(L, mts_where(P, mts_has(P, "sigma_a") ? "sigma_a" : "sigma_s"), SPC_ERR_VALUE,
                 "a heterogeneous medium takes sigma_t and albedo");
    } else if (mts_has(P, "material")) {
        mts_fail(L, mts_where(P, "material"), SPC_ERR_PLUGIN,
                 "named medium materials are not supported; give sigma_a and sigma_s, or sigma_t and albedo");
    } else if (pair_as && pair_ta) {
        mts_fail(L, mts_where(P, mts_has(P, "sigma_t") ? "sigma_t" : "albedo"), SPC_ERR_VALUE,
                 "a medium takes sigma_a and sigma_s, or sigma_t and albedo, not both");
    } else if (mts_count_objects(P, "phase") > 1) {
        mts_fail(L, node, SPC_ERR_VALUE, "a medium takes one phase function, got %d", mts_count_objects(P, "phase"));
    }
    spc_rgb sa = spc_rgb1(0.0), ss = spc_rgb1(0.0);
    spc_volume vol_t, vol_a; /* heterogeneous sigma_t; a volume albedo (either type) */
    memset(&vol_t, 0, sizeof vol_t);
    memset(&vol_a, 0, sizeof vol_a);
    bool have_a = false;
    double scale = 1.0;
    bool emitters = true;
    spc_phase phase = {SPC_PHASE_ISOTROPIC, 0.0};
    if (L->status == SPC_OK) {
        const char *scale_name = mts_has(P, "density_multiplier") ? "density_multiplier" : "scale";
        scale = mts_get_float(L, P, scale_name, 1.0);
        if (L->status == SPC_OK && !(scale >= 0.0 && scale < INFINITY))
            mts_fail(L, mts_where(P, scale_name), SPC_ERR_VALUE, "medium %s %g must be finite and not negative",
                     scale_name, scale);
        mts_ignore(P, "has_spectral_extinction"); /* RGB channels are always sampled as spectra */
        if (hetero) {
            if (mts_get_volume(L, P, "sigma_t", spc_rgb1(1.0), &vol_t))
                check_volume(L, P, "sigma_t", &vol_t, false);
            if (L->status == SPC_OK && mts_get_volume(L, P, "albedo", spc_rgb1(0.75), &vol_a) &&
                check_volume(L, P, "albedo", &vol_a, true))
                have_a = true;
        } else if (pair_as) {
            sa = mts_get_rgb(L, P, "sigma_a", spc_rgb1(0.0));
            ss = mts_get_rgb(L, P, "sigma_s", spc_rgb1(0.0));
            if (L->status == SPC_OK && check_rgb(L, P, "sigma_a", sa, INFINITY))
                check_rgb(L, P, "sigma_s", ss, INFINITY);
        } else {
            spc_rgb st = spc_rgb1(1.0), al = spc_rgb1(0.75);
            if (mts_has(P, "sigma_t") && mts_get_volume(L, P, "sigma_t", st, &vol_t))
                st = vol_t.value; /* a constvolume: its value everywhere */
            memset(&vol_t, 0, sizeof vol_t);
            if (mts_is_grid_volume(P, "albedo")) {
                if (mts_get_volume(L, P, "albedo", al, &vol_a) && check_volume(L, P, "albedo", &vol_a, true)) {
                    have_a = true;
                    al = vol_a.max; /* for the description; sampling reads the volume */
                }
            } else if (mts_has(P, "albedo") && mts_get_volume(L, P, "albedo", al, &vol_a)) {
                al = vol_a.value;
            }
            if (L->status == SPC_OK && check_rgb(L, P, "sigma_t", st, INFINITY) &&
                (have_a || check_rgb(L, P, "albedo", al, 1.0))) {
                ss = spc_rgb_mul(al, st);
                sa = spc_rgb_sub(st, ss);
            }
        }
        emitters = mts_get_bool(L, P, "sample_emitters", true);
        spc_xml_node *pn = mts_object(P, "phase", 0, NULL);
        if (pn && L->status == SPC_OK)
            mts_build_phase(L, pn, &phase);
    }
    if (L->status == SPC_OK) {
        spc_medium *m = spc_scene_new_medium(L->scene);
        if (!m) {
            mts_fail(L, node, SPC_ERR_NOMEM, "out of memory");
        } else if (hetero) {
            spc_medium_init_heterogeneous(m, &vol_t, scale, have_a && !vol_a.grid ? vol_a.value : spc_rgb1(0.75));
            vol_t.data = NULL; /* the medium owns it */
            if (have_a && vol_a.grid) {
                m->albedo_vol = vol_a;
                m->has_albedo_vol = true;
                vol_a.data = NULL;
            }
        } else if (!spc_medium_init_homogeneous(m, spc_rgb_scale(sa, scale), spc_rgb_scale(ss, scale))) {
            mts_fail(L, node, SPC_ERR_VALUE, "medium coefficients overflow (scale %g)", scale);
        } else if (have_a) {
            m->albedo_vol = vol_a;
            m->has_albedo_vol = true;
            vol_a.data = NULL;
        }
        if (m && L->status == SPC_OK) {
            m->phase = phase;
            m->sample_emitters = emitters;
            *(spc_medium **)a->object = m;
        }
    }
    free(vol_t.data);
    free(vol_a.data);
}

void mts_medium_homogeneous(const mts_build *a) { medium(a, false); }
void mts_medium_heterogeneous(const mts_build *a) { medium(a, true); }


int mts_build_medium(mts_loader *L, spc_xml_node *node)
{
    /* a medium with an id is built once, whatever refers to it */
    mts_id *entry = mts_id_of(L, node);
    if (entry) {
        if (entry->state == 2)
            return ((const spc_medium *)entry->obj)->index;
        if (entry->state == 1) {
            mts_fail(L, node, SPC_ERR_VALUE, "reference cycle through id '%s'", entry->id);
            return -1;
        }
        entry->state = 1;
    }
    int index = -1;
    mts_props P;
    if (mts_props_collect(L, node, &P)) {
        if (entry)
            entry->state = 0;
        return -1;
    }
    const char *type = mts_type(node);
    const mts_plugin *row = mts_plugin_find(L, "medium", type);
    spc_medium *m = NULL;
    if (row && row->build) {
        mts_build a = {.L = L, .node = node, .type = type, .P = &P, .object = &m};
        row->build(&a);
    } else {
        mts_fail_plugin(L, node, "medium", type);
    }
    if (m && L->status == SPC_OK) {
        const char *id = spc_xml_get(node, "id");
        if (id)
            snprintf(m->id, sizeof m->id, "%s", id);
        index = m->index;
        if (entry) {
            entry->obj = m;
            entry->state = 2;
        }
    }
    if (entry && entry->state != 2)
        entry->state = 0;
    mts_props_end(&P);
    return L->status == SPC_OK ? index : -1;
}

bool mts_shape_media(mts_loader *L, mts_props *P, int *interior, int *exterior)
{
    *interior = *exterior = -1;
    for (int i = 0; i < P->n && L->status == SPC_OK; ++i) {
        mts_prop *p = &P->p[i];
        if (p->kind != MTS_OBJECT || strcmp(p->obj->name, "medium") != 0)
            continue;
        p->used = true;
        int *slot = NULL;
        if (p->name && strcmp(p->name, "interior") == 0)
            slot = interior;
        else if (p->name && strcmp(p->name, "exterior") == 0)
            slot = exterior;
        if (!slot) {
            mts_fail(L, p->node, SPC_ERR_VALUE, "a shape's medium needs name=\"interior\" or name=\"exterior\"%s%s%s",
                     p->name ? ", not \"" : "", p->name ? p->name : "", p->name ? "\"" : "");
            break;
        }
        if (*slot >= 0) {
            mts_fail(L, p->node, SPC_ERR_VALUE, "a shape takes one %s medium", p->name);
            break;
        }
        *slot = mts_build_medium(L, p->obj);
    }
    return L->status == SPC_OK;
}
