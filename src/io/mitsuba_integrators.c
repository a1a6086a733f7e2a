/*
 * io/mitsuba_integrators.c: the integrator builders (mitsuba_builders.h). Mitsuba's integrators map
 * to specula's: path and prb to path, volpath and volpathmis to volpath, direct to path with
 * max_depth 2, ptracer to ptracer; bdpt and ipt are specula's own. aov, moment and stokes wrap a
 * nested integrator, whose image is the render (aov: its AOVs too). Properties (defaults as in
 * Mitsuba 3): max_depth -1, rr_depth 5, hide_emitters false, and specula's own specular_nee (""
 * or auto: chosen from the scene, manifold/snee_plan.h; none or off; angular | newton | conic,
 * optionally with options as "newton:biased=8,rough": the grammar of manifold/snee_options.h,
 * checked here), specular_max_chain, mis_balance (bdpt: the balance heuristic), strict_normals.
 * The define "@integrator" replaces the type of the file's integrator (the nested one of a
 * wrapper), keeping its properties, so that a scene made for another renderer's integrator loads.
 */
#include <stdio.h>
#include <string.h>

#include "io/mitsuba_builders.h"
#include "manifold/snee_options.h"

/* Nested integrators followed (aov in aov ...): far beyond any real scene; bounds a fuzzed one. */
#define MTS_INTEGRATOR_MAX_NESTING 8

/* The aov integrator's "aovs": comma-separated name:type pairs (Mitsuba 3's aov.cpp), of the types
 * specula keeps per pixel. */
static void parse_aovs(mts_loader *L, mts_props *P, const spc_xml_node *node)
{
    static const struct {
        const char *name;
        spc_aov_type type;
    } types[] = {{"albedo", SPC_AOV_ALBEDO},
                 {"depth", SPC_AOV_DEPTH},
                 {"position", SPC_AOV_POSITION},
                 {"sh_normal", SPC_AOV_SH_NORMAL}};
    spc_integrator_spec *it = &L->scene->integrator;
    const char *list = mts_get_string(L, P, "aovs", "");
    const spc_xml_node *at = mts_where(P, "aovs");
    if (!at)
        at = node;
    it->naovs = 0;
    for (const char *p = list; L->status == SPC_OK && *p;) {
        while (*p == ' ' || *p == ',')
            ++p;
        if (!*p)
            break;
        const char *end = p;
        while (*end && *end != ',')
            ++end;
        const char *colon = memchr(p, ':', (size_t)(end - p));
        size_t nlen = colon ? (size_t)(colon - p) : 0;
        while (nlen > 0 && p[nlen - 1] == ' ')
            --nlen;
        const char *t = colon ? colon + 1 : end;
        while (t < end && *t == ' ')
            ++t;
        size_t tlen = (size_t)(end - t);
        while (tlen > 0 && t[tlen - 1] == ' ')
            --tlen;
        if (!colon || nlen == 0 || tlen == 0 || nlen >= sizeof it->aovs[0].name) {
            mts_fail(L, at, SPC_ERR_VALUE, "aovs: expected name:type pairs separated by commas, got \"%.*s\"",
                     (int)(end - p), p);
            break;
        }
        int found = -1;
        for (size_t i = 0; i < sizeof types / sizeof types[0]; ++i)
            if (strlen(types[i].name) == tlen && strncmp(types[i].name, t, tlen) == 0)
                found = (int)i;
        if (found < 0) {
            mts_fail(L, at, SPC_ERR_PLUGIN, "aov type '%.*s' is not supported (albedo, depth, position, sh_normal)",
                     (int)tlen, t);
            break;
        }
        if (it->naovs == SPC_MAX_AOV_OUTPUTS) {
            mts_fail(L, at, SPC_ERR_LIMIT, "more than %d aovs", SPC_MAX_AOV_OUTPUTS);
            break;
        }
        spc_aov_output *o = &it->aovs[it->naovs++];
        snprintf(o->name, sizeof o->name, "%.*s", (int)nlen, p);
        o->type = types[found].type;
        p = end;
    }
}

/* What every integrator reads: ours is specula's integrator, max_depth 2 fixes the depth (direct). */
static void read_common(const mts_build *a, const char *ours, int max_depth)
{
    mts_loader *L = a->L;
    mts_props *P = a->P;
    spc_xml_node *node = a->node;
    spc_integrator_spec *it = &L->scene->integrator;
    snprintf(it->type, sizeof it->type, "%s", ours);
    it->max_depth = max_depth == 2 ? 2 : mts_get_int(L, P, "max_depth", -1);
    it->rr_depth = mts_get_int(L, P, "rr_depth", 5);
    it->hide_emitters = mts_get_bool(L, P, "hide_emitters", false);
    /* specula's own (bdpt); read for every type so that --integrator path on a bdpt scene is quiet */
    it->mis_balance = mts_get_bool(L, P, "mis_balance", false);
    it->strict_normals = mts_get_bool(L, P, "strict_normals", false);
    if (it->strict_normals && strcmp(ours, "path") != 0)
        mts_warn(mts_where(P, "strict_normals"), "strict_normals is honoured by the path integrator only");
    if (mts_has(P, "specular_nee")) {
        const char *nee = mts_get_string(L, P, "specular_nee", "");
        char why[SPC_SNEE_WHY_MAX];
        if (strlen(nee) >= sizeof it->specular_nee)
            mts_fail(L, mts_where(P, "specular_nee"), SPC_ERR_VALUE, "specular_nee is longer than %d characters",
                     (int)sizeof it->specular_nee - 1);
        else if (spc_snee_setting_check(nee, why, sizeof why) != SPC_SNEE_PARSE_OK)
            mts_fail(L, mts_where(P, "specular_nee"), SPC_ERR_VALUE, "specular_nee '%s': %s", nee, why);
        snprintf(it->specular_nee, sizeof it->specular_nee, "%s", nee);
    }
    if (mts_has(P, "specular_max_chain"))
        it->specular_max_chain = mts_get_int(L, P, "specular_max_chain", it->specular_max_chain);
    if (L->status == SPC_OK && it->max_depth < -1)
        mts_fail(L, mts_where(P, "max_depth"), SPC_ERR_VALUE, "max_depth %d must be -1 (no limit) or >= 0",
                 it->max_depth);
    if (L->status == SPC_OK && it->rr_depth < 1)
        mts_fail(L, mts_where(P, "rr_depth"), SPC_ERR_VALUE, "rr_depth %d must be at least 1", it->rr_depth);
    snprintf(it->decl_file, sizeof it->decl_file, "%s", node->file ? node->file : "");
    it->decl_line = node->line;
    it->decl_col = node->col;
}

/* ---- the integrator builders: one per integrator row of the plugin table ---- */

void mts_integrator_path(const mts_build *a) { read_common(a, "path", -1); }
void mts_integrator_volpath(const mts_build *a) { read_common(a, "volpath", -1); }
void mts_integrator_bdpt(const mts_build *a) { read_common(a, "bdpt", -1); }
void mts_integrator_ipt(const mts_build *a) { read_common(a, "ipt", -1); }

void mts_integrator_ptracer(const mts_build *a)
{
    mts_ignore(a->P, "samples_per_pass"); /* how Mitsuba splits its work; the image is the same */
    read_common(a, "ptracer", -1);
}

void mts_integrator_direct(const mts_build *a)
{
    mts_ignore(a->P, "emitter_samples");
    mts_ignore(a->P, "bsdf_samples");
    mts_ignore(a->P, "shading_samples");
    read_common(a, "path", 2);
}

/* aov, moment, stokes: the nested integrator (a->nested: how deep this one is nested) */
void mts_integrator_nested(const mts_build *a)
{
    spc_integrator_spec *it = &a->L->scene->integrator;
    if (strcmp(a->type, "aov") == 0)
        parse_aovs(a->L, a->P, a->node);
    spc_xml_node *inner = mts_object(a->P, "integrator", 0, NULL);
    if (inner && strcmp(a->type, "aov") == 0 && spc_xml_get(inner, "name"))
        snprintf(it->aov_image, sizeof it->aov_image, "%s", spc_xml_get(inner, "name"));
    if (inner && a->nested < MTS_INTEGRATOR_MAX_NESTING) {
        mts_build_integrator(a->L, inner, a->nested + 1);
    } else {
        mts_warn(a->node, "integrator '%s' without a nested integrator: using path", a->type);
        snprintf(it->type, sizeof it->type, "path");
    }
}

void mts_build_integrator(mts_loader *L, spc_xml_node *node, int depth)
{
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return;
    const char *type = mts_type(node);
    const mts_plugin *row = mts_plugin_find(L, "integrator", type);
    mts_build_fn build = row ? row->build : NULL;
    /* the define replaces the type of the integrator that renders: a wrapper's nested one */
    if (build != mts_integrator_nested && L->integrator_override) {
        type = L->integrator_override;
        row = mts_plugin_find(L, "integrator", type);
        build = row && row->build != mts_integrator_nested ? row->build : NULL;
    }
    if (build) {
        mts_build a = {.L = L, .node = node, .type = type, .P = &P, .nested = depth};
        build(&a);
    } else if (row) {
        mts_fail_plugin(L, node, "integrator", type);
    } else {
        mts_fail(L, node, SPC_ERR_PLUGIN,
                 "unknown integrator '%s'; choose one of specula's with --integrator path or -D integrator=path", type);
    }
    mts_props_end(&P);
}
