/*
 * io/mitsuba_volumes.c: volume-valued medium properties (medium/gridvolume.c lists the XML of
 * gridvolume and constvolume). A property given as a plain value (float, rgb, spectrum) is, as in
 * Mitsuba 3, a constvolume over the unit cube.
 */
#include <stdlib.h>
#include <string.h>

#include "io/mitsuba_builders.h"
#include "io/vol.h"

/* ---- the volume builders: one per volume row of the plugin table ---- */

void mts_volume_constvolume(const mts_build *a)
{
    spc_rgb value = mts_get_rgb(a->L, a->P, "value", spc_rgb1(1.0));
    if (a->L->status == SPC_OK && !spc_volume_init_constant(a->object, value, a->transform))
        mts_fail(a->L, mts_where(a->P, "to_world"), SPC_ERR_VALUE, "constvolume: to_world is singular");
}

void mts_volume_gridvolume(const mts_build *a)
{
    mts_loader *L = a->L;
    mts_props *P = a->P;
    spc_xml_node *node = a->node;
    spc_volume *out = a->object;
    spc_mat4 to_world = *a->transform;
    const char *fname = mts_get_string(L, P, "filename", NULL);
    const char *filter = mts_get_string(L, P, "filter_type", "trilinear");
    const char *wrap = mts_get_string(L, P, "wrap_mode", "clamp");
    bool grid_bbox = mts_get_bool(L, P, "use_grid_bbox", false);
    mts_ignore(P, "raw");   /* RGB: no spectral conversion either way */
    mts_ignore(P, "accel"); /* CUDA hardware interpolation */
    if (L->status == SPC_OK && strcmp(filter, "trilinear") != 0 && strcmp(filter, "nearest") != 0)
        mts_fail(L, mts_where(P, "filter_type"), SPC_ERR_VALUE, "unknown filter_type '%s' (trilinear, nearest)",
                 filter);
    spc_volume_wrap wm = SPC_VOLUME_CLAMP;
    if (strcmp(wrap, "repeat") == 0)
        wm = SPC_VOLUME_REPEAT;
    else if (strcmp(wrap, "mirror") == 0)
        wm = SPC_VOLUME_MIRROR;
    else if (L->status == SPC_OK && strcmp(wrap, "clamp") != 0)
        mts_fail(L, mts_where(P, "wrap_mode"), SPC_ERR_VALUE, "unknown wrap_mode '%s' (clamp, repeat, mirror)",
                 wrap);
    char path[4096];
    if (L->status == SPC_OK && !fname)
        mts_fail(L, node, SPC_ERR_VALUE, "gridvolume needs a filename");
    else if (L->status == SPC_OK && !mts_resolve(L, mts_where(P, "filename"), fname, path, sizeof path))
        mts_fail(L, mts_where(P, "filename"), SPC_ERR_IO, "volume file '%s' %s", fname,
                 mts_resolve_failure(L, mts_where(P, "filename"), fname));
    if (L->status == SPC_OK) {
        spc_error sub;
        memset(&sub, 0, sizeof sub);
        double bbox[6];
        if (spc_vol_read(path, out, bbox, &sub) != SPC_OK) {
            char msg[SPC_ERROR_MSG_MAX];
            spc_error_format(&sub, msg, sizeof msg);
            mts_fail(L, mts_where(P, "filename"), sub.code ? sub.code : SPC_ERR_IO, "cannot load volume '%s': %s",
                     fname, msg);
        } else {
            out->nearest = strcmp(filter, "nearest") == 0;
            out->wrap = wm;
            if (grid_bbox) {
                /* the unit cube maps to the file's bounding box first */
                spc_mat4 t = spc_mat4_translate(spc_v3(bbox[0], bbox[1], bbox[2]));
                spc_mat4 s = spc_mat4_scale(spc_v3(bbox[3] - bbox[0], bbox[4] - bbox[1], bbox[5] - bbox[2]));
                spc_mat4 ts = spc_mat4_mul(&t, &s);
                to_world = spc_mat4_mul(&to_world, &ts);
            }
            if (!spc_volume_finish_grid(out, &to_world))
                mts_fail(L, node, SPC_ERR_VALUE, "gridvolume: to_world (with the grid's bounding box) is singular");
        }
    }
}

/* A <volume> element into *out (false: failed, L's error set). */
static bool build_volume(mts_loader *L, spc_xml_node *node, spc_volume *out)
{
    memset(out, 0, sizeof *out);
    mts_props P;
    if (mts_props_collect(L, node, &P))
        return false;
    const char *type = mts_type(node);
    spc_mat4 to_world = mts_get_transform(L, &P, "to_world");
    const mts_plugin *row = mts_plugin_find(L, "volume", type);
    if (row && row->build) {
        mts_build a = {.L = L, .node = node, .type = type, .P = &P, .object = out, .transform = &to_world};
        row->build(&a);
    } else {
        mts_fail_plugin(L, node, "volume", type);
    }
    mts_props_end(&P);
    if (L->status != SPC_OK) {
        free(out->data);
        out->data = NULL;
        return false;
    }
    return true;
}

bool mts_get_volume(mts_loader *L, mts_props *P, const char *name, spc_rgb def, spc_volume *out)
{
    mts_prop *p = mts_find(P, name);
    if (p && p->kind == MTS_OBJECT && strcmp(p->obj->name, "volume") == 0)
        return build_volume(L, p->obj, out);
    spc_rgb v = mts_get_rgb(L, P, name, def);
    if (L->status != SPC_OK)
        return false;
    spc_mat4 id = spc_mat4_identity();
    return spc_volume_init_constant(out, v, &id);
}

bool mts_is_grid_volume(mts_props *P, const char *name)
{
    for (int i = 0; i < P->n; ++i) {
        const mts_prop *p = &P->p[i];
        if (p->name && strcmp(p->name, name) == 0)
            return p->kind == MTS_OBJECT && strcmp(p->obj->name, "volume") == 0 &&
                   strcmp(mts_type(p->obj), "constvolume") != 0;
    }
    return false;
}
