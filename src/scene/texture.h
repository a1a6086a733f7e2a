/*
 * scene/texture.h: textures evaluated at a surface uv. A constant value is also a texture, so
 * every reflectance, roughness or radiance parameter of a plugin is a `const spc_texture *`.
 *
 * XML (Mitsuba): <texture type="bitmap"> filename, filter_type ("bilinear"|"nearest"),
 * wrap_mode ("repeat"|"mirror"|"clamp"), raw (bool: no sRGB decoding of 8-bit images), to_uv;
 * <texture type="checkerboard"> color0 (0.4), color1 (0.2), to_uv;
 * <texture type="mesh_attribute"> name ("vertex_*" or "face_*", required), scale (1).
 */
#ifndef SPC_SCENE_TEXTURE_H
#define SPC_SCENE_TEXTURE_H

#include <stdint.h>

#include "core/error.h"
#include "core/math.h"

typedef enum spc_texture_type {
    SPC_TEX_CONSTANT,
    SPC_TEX_BITMAP,
    SPC_TEX_CHECKERBOARD,
    SPC_TEX_MESH_ATTRIBUTE /* a mesh's vertex or face attribute: needs the hit (mesh_attribute.c) */
} spc_texture_type;

typedef enum spc_wrap_mode {
    SPC_WRAP_REPEAT,
    SPC_WRAP_MIRROR,
    SPC_WRAP_CLAMP
} spc_wrap_mode;

typedef struct spc_texture {
    spc_texture_type type;
    spc_rgb value; /* constant */
    /* bitmap: linear RGB, row-major, row 0 at the top of the image. As in Mitsuba 3 (drjit's
     * Texture), uv (0,0) is the top-left corner of the image file: texel (x, y) covers
     * u in [x/width, (x+1)/width], v in [y/height, (y+1)/height] with y counted from the top; the
     * OBJ loader flips v (Mitsuba's flip_tex_coords, default true), so OBJ files still see v = 0 at
     * the bottom of the image. */
    int width, height;
    float *data; /* 3 * width * height, owned */
    bool nearest;
    spc_wrap_mode wrap;
    /* checkerboard */
    spc_rgb color0, color1;
    /* mesh_attribute: the attribute's name ("vertex_*" or "face_*") and a factor */
    char attribute[64];
    double attr_scale;
    /* to_uv: uv' = M (u, v, 1), rows 0 and 1 of a 3x3 affine map */
    double to_uv[2][3];
} spc_texture;

struct spc_hit;

/* A constant texture (the caller owns it: static or inside a scene). */
void spc_texture_init_constant(spc_texture *t, spc_rgb value);
/* The texture at uv. A constant's value is read inline (lights and BSDFs of constant parameters
 * call this per lane and per vertex); every other type goes to spc_texture_eval_general, whose
 * constant case returns the same value. */
spc_rgb spc_texture_eval_general(const spc_texture *t, spc_vec2 uv);
static inline spc_rgb spc_texture_eval(const spc_texture *t, spc_vec2 uv)
{
    return t->type == SPC_TEX_CONSTANT ? t->value : spc_texture_eval_general(t, uv);
}
/* The texture at a surface hit: what BSDFs call. Mesh attributes are read from the hit's mesh,
 * every other texture is spc_texture_eval at the hit's uv; a constant inline, as above. */
spc_rgb spc_texture_eval_hit_general(const spc_texture *t, const struct spc_hit *h);
static inline spc_rgb spc_texture_eval_hit(const spc_texture *t, const struct spc_hit *h)
{
    return t->type == SPC_TEX_CONSTANT ? t->value : spc_texture_eval_hit_general(t, h);
}
double spc_texture_eval1_hit(const spc_texture *t, const struct spc_hit *h);
/* A mesh_attribute texture reading the attribute named name times scale (the caller owns it).
 * false when the name does not start with "vertex_" or "face_" or is too long. */
bool spc_texture_init_mesh_attribute(spc_texture *t, const char *name, double scale);
/* Mesh attributes at a hit (mesh_attribute.c): vertex attributes interpolated with the hit's
 * barycentrics, face attributes constant over each triangle; one channel is spread to all three,
 * a fourth is dropped. Black where the hit's shape is not a mesh or has no attribute of that
 * name. */
spc_rgb spc_mesh_attribute_eval(const spc_texture *t, const struct spc_hit *h);
/* Mean of the channels at uv (roughness, opacity, weights): Mitsuba 3's eval_1, whose
 * checkerboard has its two colors swapped (texture.c). */
double spc_texture_eval1(const spc_texture *t, spc_vec2 uv);
/* Gradient of spc_texture_eval1 with respect to the surface uv (before to_uv), as Mitsuba 3's
 * eval_1_grad: for bilinear bitmaps the exact gradient of the interpolant in the cell holding uv,
 * (d/ds, d/dt) times the resolution, then through the transpose of to_uv's linear part; zero for
 * nearest bitmaps, constants and checkerboards (piecewise constant). */
spc_vec2 spc_texture_eval1_grad(const spc_texture *t, spc_vec2 uv);
/* spc_texture_eval and, in grad[0], grad[1], its derivatives with respect to the surface u and v
 * (before to_uv), per channel, as spc_texture_eval1_grad: exact for the bilinear interpolant in
 * the cell holding uv, zero for piecewise constant textures. Normal maps on specular chain
 * vertices need it (bsdf/normalmap.c). */
spc_rgb spc_texture_eval_grad(const spc_texture *t, spc_vec2 uv, spc_rgb grad[2]);
/* Bitmap texel (x, y) (y from the top row), with the texture's wrap mode applied to out-of-range
 * indices. Black for other texture types. */
spc_rgb spc_texture_texel(const spc_texture *t, int64_t x, int64_t y);
/* Mean value over [0,1]^2 (for light power and albedo estimates); 1/2 times the scale for a
 * mesh attribute (its values are not known without the mesh). */
spc_rgb spc_texture_mean(const spc_texture *t);
static inline bool spc_texture_is_constant(const spc_texture *t) { return t->type == SPC_TEX_CONSTANT; }
/* A checkerboard texture with identity to_uv (the caller owns it). */
void spc_texture_init_checkerboard(spc_texture *t, spc_rgb color0, spc_rgb color1);
/* Loads an image (EXR, PNG, JPEG, BMP) into a bitmap texture: linear RGB (8/16-bit images are
 * sRGB-decoded unless raw; gray is expanded to RGB; alpha is dropped), bilinear, repeat, identity
 * to_uv; the caller may change nearest/wrap/to_uv afterwards. On failure *t is a black constant
 * texture and err names the file. Free with spc_texture_release. */
spc_status spc_texture_load_bitmap(spc_texture *t, const char *path, bool raw, spc_error *err);
void spc_texture_release(spc_texture *t);

#endif
