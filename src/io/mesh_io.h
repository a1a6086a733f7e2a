/*
 * io/mesh_io.h: triangle mesh loaders. Each returns the mesh in OBJECT space; quads and n-gons are
 * triangulated (fan for convex polygons; ear clipping for concave ones), and every value is
 * validated (finite numbers, indices in range) with errors that name "file:line" (OBJ, ASCII
 * PLY) or "file: element i" (binary formats). On failure *out is left empty.
 */
#ifndef SPC_IO_MESH_IO_H
#define SPC_IO_MESH_IO_H

#include "core/error.h"
#include "scene/mesh.h"

/* OBJ: v, vn, vt, f (v, v/vt, v//vn, v/vt/vn; negative indices count back from the last
 * definition); o, g, s, usemtl, mtllib, l, p and unknown statements are ignored. Texture
 * coordinates are flipped, v' = 1 - v, as Mitsuba's flip_tex_coords (default true) does;
 * spc_obj_load_ex lets the caller choose. A file without faces is an error (SPC_ERR_VALUE). */
spc_status spc_obj_load(const char *path, spc_mesh *out, spc_error *err);
spc_status spc_obj_load_ex(const char *path, bool flip_tex_coords, spc_mesh *out, spc_error *err);
/* PLY: ascii, binary_little_endian and binary_big_endian; vertex x y z, optional nx ny nz,
 * u v (or s t, texture_u texture_v); face vertex_indices (or vertex_index) lists. */
spc_status spc_ply_load(const char *path, spc_mesh *out, spc_error *err);
/* Mitsuba's .serialized format (zlib-compressed, versions 3 and 4); shape_index selects the mesh
 * in a multi-mesh file. */
spc_status spc_serialized_load(const char *path, int shape_index, spc_mesh *out, spc_error *err);

#endif
