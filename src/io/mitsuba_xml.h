/*
 * io/mitsuba_xml.h: loads a Mitsuba scene file (versions 0.5/0.6, 2.x and 3.x dialects) into a
 * spc_scene. The scene is finalized (accel built) on success.
 *
 * Errors are "file:line:col: message" in err with a status code; nothing is half-loaded: on
 * failure *out is NULL and everything allocated is freed.
 */
#ifndef SPC_IO_MITSUBA_XML_H
#define SPC_IO_MITSUBA_XML_H

#include "core/error.h"
#include "scene/scene.h"

/* spc_define (-D name=value) is declared in specula/specula.h. A define with the reserved name
 * below (not a valid $parameter name) replaces the type of the file's <integrator>, keeping its
 * properties: the command line's --integrator passes it so that a scene written for an integrator
 * specula does not have (path_guiding_integrator, ...) still loads. */
#define SPC_MITSUBA_INTEGRATOR_DEFINE SPC_DEFINE_INTEGRATOR

spc_status spc_mitsuba_load(const char *path, const spc_define *defs, int ndefs, spc_scene **out, spc_error *err);
/* The same from a string in memory; base_dir resolves relative file names (NULL: cwd). */
spc_status spc_mitsuba_load_string(const char *xml, size_t len, const char *name, const char *base_dir,
                                   const spc_define *defs, int ndefs, spc_scene **out, spc_error *err);

#endif
