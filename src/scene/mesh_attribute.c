/*
 * scene/mesh_attribute.c: the mesh_attribute texture (Mitsuba 3's src/textures/mesh_attribute.cpp
 * with Mesh::eval_attribute): a value stored per vertex or per face of the mesh that was hit.
 *
 * A vertex attribute is interpolated with the hit's barycentrics over the triangle's three
 * vertices, (1 - b1 - b2) a0 + b1 a1 + b2 a2; a face attribute is the triangle's value (a PLY
 * polygon's value on each of its triangles). A one-channel attribute is the same in R, G and B;
 * three channels are an RGB colour (a fourth, alpha, is dropped). The result is multiplied by the
 * texture's scale. The attribute is found by name on the hit's mesh, so one texture serves every
 * mesh that has the attribute; elsewhere (another mesh, an analytic shape) it is black.
 *
 * XML: <texture type="mesh_attribute"> name (string, required: "vertex_<x>" or "face_<x>"),
 * scale (float, 1).
 */
#include <string.h>

#include "scene/hit.h"
#include "scene/shape.h"
#include "scene/texture.h"

static spc_rgb attr_rgb(const spc_mesh_attr *a, const float *v)
{
    if (a->dim < 3)
        return spc_rgb1(v[0]);
    return spc_rgb3(v[0], v[1], v[2]);
}

spc_rgb spc_mesh_attribute_eval(const spc_texture *t, const spc_hit *h)
{
    const spc_shape *s = h->shape;
    if (!s || s->type != SPC_SHAPE_MESH || h->prim < 0 || (size_t)h->prim >= s->mesh.ntris)
        return spc_rgb1(0.0);
    const spc_mesh_attr *a = spc_mesh_find_attr(&s->mesh, t->attribute);
    if (!a)
        return spc_rgb1(0.0);
    size_t tri = (size_t)h->prim, d = (size_t)a->dim;
    spc_rgb v;
    if (a->face) {
        v = attr_rgb(a, a->data + d * tri);
    } else {
        const uint32_t *id = s->mesh.idx + 3 * tri;
        double b0 = 1.0 - h->b1 - h->b2;
        v = spc_rgb_add(spc_rgb_scale(attr_rgb(a, a->data + d * id[0]), b0),
                        spc_rgb_add(spc_rgb_scale(attr_rgb(a, a->data + d * id[1]), h->b1),
                                    spc_rgb_scale(attr_rgb(a, a->data + d * id[2]), h->b2)));
    }
    return spc_rgb_scale(v, t->attr_scale);
}
