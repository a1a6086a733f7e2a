/*
 * render/driver.h: the render loop (driver.c) below the public spc_render (render/api.c): a render
 * of a scene whose specular NEE plan is settled.
 *
 * spc_render makes the plan (spc_driver_plan), lets the pilot render check an automatic one
 * (render/snee_pilot.h, whose small renders come here with explicit settings), then renders through
 * spc_driver_render. The calls run one way: api.c -> snee_pilot.c -> driver.c, and api.c ->
 * driver.c; the driver knows nothing of the pilot but the note it left in the plan.
 */
#ifndef SPC_RENDER_DRIVER_H
#define SPC_RENDER_DRIVER_H

#include "manifold/snee_plan.h"
#include "specula/specula.h"

/* The specular NEE plan of a render of sc with options o, before any pilot: o's setting, else the
 * scene's, else (or for "auto") the one chosen from the scene for o's integrator (else the scene's);
 * off where the setting is automatic and the device is OpenCL, which has no specular NEE. Never
 * fails: a bad setting or integrator name is refused by spc_driver_render. */
void spc_driver_plan(const spc_scene *sc, const spc_render_options *o, spc_snee_plan *plan);

/* spc_render (specula.h) with the plan `plan` (spc_driver_plan's, or the pilot's change of it): its
 * setting runs, and its pilot_note goes to the statistics; o->specular_nee only decides whether an
 * error in the setting names --specular-nee or the scene's property. */
spc_status spc_driver_render(const spc_scene *sc, const spc_render_options *o, const spc_snee_plan *plan,
                             spc_film **out, spc_render_stats *stats, spc_error *err);

#endif
