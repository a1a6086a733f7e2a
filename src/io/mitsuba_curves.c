/*
 * io/mitsuba_curves.c: the <shape type="linearcurve"> and <shape type="bsplinecurve"> plugins of
 * Mitsuba 3: a file of control points "x y z radius" (scene/curve.h), positions transformed by
 * to_world, radii not. Curves are not area emitters in Mitsuba 3 (no sampling), so an emitter
 * nested in one is refused.
 *
 * XML parameters:
 *   filename  string, required: the control-point file
 *   to_world  transform (identity)
 */
#include <stdlib.h>
#include <string.h>

#include "io/mitsuba_builders.h"
#include "scene/curve.h"

bool mts_is_curve_type(const char *type)
{
    return strcmp(type, "linearcurve") == 0 || strcmp(type, "bsplinecurve") == 0;
}

spc_curve *mts_load_curve(mts_loader *L, spc_xml_node *node, mts_props *P, const char *type, const spc_mat4 *M)
{
    const char *fname = mts_get_string(L, P, "filename", NULL);
    char path[4096];
    if (L->status != SPC_OK)
        return NULL;
    if (!fname) {
        mts_fail(L, node, SPC_ERR_VALUE, "%s shape needs a filename", type);
        return NULL;
    }
    if (mts_count_objects(P, "emitter") > 0) {
        mts_fail(L, node, SPC_ERR_VALUE, "a %s cannot be an area emitter (Mitsuba 3 cannot sample it either)", type);
        return NULL;
    }
    if (!mts_resolve(L, mts_where(P, "filename"), fname, path, sizeof path)) {
        mts_fail(L, mts_where(P, "filename"), SPC_ERR_IO, "curve file '%s' %s", fname,
                 mts_resolve_failure(L, mts_where(P, "filename"), fname));
        return NULL;
    }
    spc_curve *c = calloc(1, sizeof *c);
    if (!c) {
        mts_fail(L, node, SPC_ERR_NOMEM, "out of memory");
        return NULL;
    }
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    spc_status st = spc_curve_read(path, strcmp(type, "linearcurve") == 0 ? SPC_CURVE_LINEAR : SPC_CURVE_BSPLINE, M,
                                   c, &sub);
    if (st != SPC_OK) {
        char msg[SPC_ERROR_MSG_MAX];
        spc_error_format(&sub, msg, sizeof msg);
        mts_fail(L, mts_where(P, "filename"), st, "cannot load %s: %s", type, msg);
        free(c);
        return NULL;
    }
    return c;
}
