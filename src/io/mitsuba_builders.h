/*
 * io/mitsuba_builders.h: the builders of the Mitsuba loader: from an object element's properties
 * (mitsuba_props.h) to the scene's BSDFs, textures, shapes, emitters and media. The registry
 * (mitsuba_plugin_list.c) names the builder of each plugin; the category functions below look the
 * type up in the registry the walk handed in (L->plugins) and are what a builder calls for a
 * nested object.
 *
 *   mitsuba_plugins.c    shapes, BSDFs, textures, emitters
 *   mitsuba_principled.c principled, principledthin
 *   mitsuba_curves.c     linearcurve, bsplinecurve
 *   mitsuba_sdfgrid.c    sdfgrid
 *   mitsuba_media.c      participating media and phase functions
 *   mitsuba_volumes.c    volumes (gridvolume, constvolume)
 *   mitsuba_integrators.c  integrators
 */
#ifndef SPC_IO_MITSUBA_BUILDERS_H
#define SPC_IO_MITSUBA_BUILDERS_H

#include "io/mitsuba_props.h"

/* ---- mitsuba_plugins.c ---- */
const spc_bsdf *mts_build_bsdf(mts_loader *L, spc_xml_node *node);
const spc_texture *mts_build_texture(mts_loader *L, spc_xml_node *node);
/* A texture-valued property: rgb / spectrum / float constants, a nested texture or a ref. */
const spc_texture *mts_get_texture(mts_loader *L, mts_props *P, const char *name, spc_rgb def);
/* Builds a shape (or, for instance, copies of a shapegroup's shapes) with `prefix` applied
 * before its own to_world (identity at the top level). */
spc_status mts_build_shape(mts_loader *L, spc_xml_node *node, const spc_mat4 *prefix, bool in_group);
/* mitsuba_sdfgrid.c: the grid of an sdfgrid shape, or NULL after mts_fail */
struct spc_sdfgrid *mts_load_sdfgrid(mts_loader *L, mts_props *P, const spc_xml_node *node, const spc_mat4 *to_world);
spc_status mts_build_emitter(mts_loader *L, spc_xml_node *node, spc_shape *shape, int shape_index);
void mts_mesh_cache_release(mts_loader *L);

/* ---- mitsuba_curves.c ---- */
struct spc_curve;
/* Is type one of Mitsuba 3's curve shapes (linearcurve, bsplinecurve)? */
bool mts_is_curve_type(const char *type);
/* Reads a curve shape's file with its positions in world space (M); NULL after mts_fail. The caller
 * owns the result (spc_shape_init_curve takes it). */
struct spc_curve *mts_load_curve(mts_loader *L, spc_xml_node *node, mts_props *P, const char *type,
                                 const spc_mat4 *M);

/* ---- mitsuba_media.c ---- */
/* Builds a <medium> into the scene (once per id); returns its index in scene->media, or -1 after
 * mts_fail. */
int mts_build_medium(mts_loader *L, spc_xml_node *node);
/* Reads a <phase> element; false after mts_fail. */
bool mts_build_phase(mts_loader *L, spc_xml_node *node, spc_phase *out);
/* mitsuba_volumes.c: the volume-valued property `name` (a nested gridvolume or constvolume, or a
 * plain value read as a constvolume over the unit cube; def when absent) into *out; false on error.
 * mts_is_grid_volume: is the property a volume other than a constvolume (without reading it)? */
bool mts_get_volume(mts_loader *L, mts_props *P, const char *name, spc_rgb def, spc_volume *out);
bool mts_is_grid_volume(mts_props *P, const char *name);
/* The interior and exterior media nested in or referenced by a shape's properties (-1: none);
 * false after mts_fail (a medium without name="interior" / "exterior", or two of one). */
bool mts_shape_media(mts_loader *L, mts_props *P, int *interior, int *exterior);

/* mitsuba_integrators.c: an <integrator> (depth: how deep it is nested in aov, moment or stokes)
 * into L->scene->integrator; L's error set on failure. */
void mts_build_integrator(mts_loader *L, spc_xml_node *node, int depth);

/* The builders the table names (mitsuba_plugins.c, mitsuba_principled.c, mitsuba_media.c,
 * mitsuba_volumes.c, mitsuba_integrators.c). */
void mts_bsdf_diffuse(const mts_build *a);
void mts_bsdf_roughdiffuse(const mts_build *a);
void mts_bsdf_phong(const mts_build *a);
void mts_bsdf_conductor(const mts_build *a);
void mts_bsdf_roughconductor(const mts_build *a);
void mts_bsdf_dielectric(const mts_build *a);
void mts_bsdf_thindielectric(const mts_build *a);
void mts_bsdf_roughdielectric(const mts_build *a);
void mts_bsdf_plastic(const mts_build *a);
void mts_bsdf_roughplastic(const mts_build *a);
void mts_bsdf_pplastic(const mts_build *a);
void mts_bsdf_principled(const mts_build *a);
void mts_bsdf_principledthin(const mts_build *a);
void mts_bsdf_twosided(const mts_build *a);
void mts_bsdf_normalmap(const mts_build *a);
void mts_bsdf_bumpmap(const mts_build *a);
void mts_bsdf_null(const mts_build *a);
void mts_bsdf_polarizer(const mts_build *a);
void mts_bsdf_mask(const mts_build *a);
void mts_bsdf_blendbsdf(const mts_build *a);

void mts_shape_sphere(const mts_build *a);
void mts_shape_disk(const mts_build *a);
void mts_shape_rectangle(const mts_build *a);
void mts_shape_cube(const mts_build *a);
void mts_shape_cylinder(const mts_build *a);
void mts_shape_obj(const mts_build *a);
void mts_shape_ply(const mts_build *a);
void mts_shape_serialized(const mts_build *a);
void mts_shape_sdf(const mts_build *a);
void mts_shape_curve(const mts_build *a); /* linearcurve, bsplinecurve */
void mts_shape_sdfgrid(const mts_build *a);
void mts_shape_shapegroup(const mts_build *a);
void mts_shape_instance(const mts_build *a);

void mts_texture_bitmap(const mts_build *a);
void mts_texture_checkerboard(const mts_build *a);
void mts_texture_rawconstant(const mts_build *a);
void mts_texture_mesh_attribute(const mts_build *a);

void mts_medium_homogeneous(const mts_build *a);
void mts_medium_heterogeneous(const mts_build *a);
void mts_phase_isotropic(const mts_build *a);
void mts_phase_hg(const mts_build *a);
void mts_volume_constvolume(const mts_build *a);
void mts_volume_gridvolume(const mts_build *a);

void mts_integrator_path(const mts_build *a);    /* path, prb */
void mts_integrator_volpath(const mts_build *a); /* volpath, volpathmis */
void mts_integrator_direct(const mts_build *a);
void mts_integrator_ptracer(const mts_build *a);
void mts_integrator_bdpt(const mts_build *a);
void mts_integrator_ipt(const mts_build *a);
void mts_integrator_nested(const mts_build *a); /* aov, moment, stokes */

void mts_emitter_area(const mts_build *a);
void mts_emitter_point(const mts_build *a);
void mts_emitter_spot(const mts_build *a);
void mts_emitter_directional(const mts_build *a);
void mts_emitter_constant(const mts_build *a);
void mts_emitter_envmap(const mts_build *a);
void mts_emitter_projector(const mts_build *a);

#endif
