/*
 * io/mitsuba_sdfgrid.c: reads a Mitsuba 3 <shape type="sdfgrid"> into a grid (scene/sdfgrid.h).
 *
 * XML (Mitsuba 3's parameters; defaults in parentheses):
 *   filename   a one-channel .vol grid (io/vol.h); its values sit on the vertices of [0,1]^3 and
 *              the file's own bounding box is ignored, as in Mitsuba
 *   normals    ("smooth") shading normals: "smooth" or "analytic"
 *   to_world   (identity) the map of [0,1]^3 to the world (read by the caller)
 * The "grid" tensor property exists only in Mitsuba's Python and C++ APIs, not in XML.
 */
#include <stdlib.h>
#include <string.h>

#include "io/mitsuba_builders.h"
#include "io/vol.h"
#include "scene/sdfgrid.h"

spc_sdfgrid *mts_load_sdfgrid(mts_loader *L, mts_props *P, const spc_xml_node *node, const spc_mat4 *to_world)
{
    const char *fname = mts_get_string(L, P, "filename", NULL);
    const char *normals = mts_get_string(L, P, "normals", "smooth");
    if (L->status != SPC_OK)
        return NULL;
    bool smooth = strcmp(normals, "smooth") == 0;
    if (!smooth && strcmp(normals, "analytic") != 0) {
        mts_fail(L, mts_where(P, "normals"), SPC_ERR_VALUE, "sdfgrid normals '%s': expected smooth or analytic",
                 normals);
        return NULL;
    }
    if (!fname) {
        mts_fail(L, node, SPC_ERR_VALUE, "sdfgrid shape needs a filename (a .vol grid)");
        return NULL;
    }
    char path[4096];
    const spc_xml_node *at = mts_where(P, "filename");
    if (!mts_resolve(L, at, fname, path, sizeof path)) {
        mts_fail(L, at, SPC_ERR_IO, "sdfgrid file '%s' %s", fname, mts_resolve_failure(L, at, fname));
        return NULL;
    }
    spc_volume v;
    memset(&v, 0, sizeof v);
    spc_error sub;
    memset(&sub, 0, sizeof sub);
    spc_status st = spc_vol_read(path, &v, NULL, &sub);
    if (st != SPC_OK) {
        mts_fail(L, at, st, "sdfgrid file '%s': %s", fname, sub.msg);
        return NULL;
    }
    spc_sdfgrid *g = NULL;
    if (v.channels != 1)
        mts_fail(L, at, SPC_ERR_VALUE, "sdfgrid file '%s' has %d channels, expected 1", fname, v.channels);
    else if (!(g = spc_sdfgrid_create(v.data, v.res[0], v.res[1], v.res[2], to_world, smooth, path, 0, 0, &sub)))
        mts_fail(L, at, sub.code ? sub.code : SPC_ERR_VALUE, "sdfgrid file '%s': %s", fname, sub.msg);
    free(v.data);
    return g;
}
