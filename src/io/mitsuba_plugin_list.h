/*
 * io/mitsuba_plugin_list.h: the plugin registry: every plugin of Mitsuba 3 by category, whether the
 * loader reads it, and the builder it calls (mitsuba_plugin_list.c). The walk hands it to the
 * loader (L->plugins); docs/PLUGINS.md is it printed.
 */
#ifndef SPC_IO_MITSUBA_PLUGIN_LIST_H
#define SPC_IO_MITSUBA_PLUGIN_LIST_H

#include <stdio.h>

#include "io/mitsuba_props.h"

/* The whole table (*n rows, grouped by category). */
const mts_plugin *mts_plugin_list(int *n);
/* Writes docs/PLUGINS.md's text; 0, or -1 on a write error. */
int mts_plugins_markdown(FILE *out);

#endif
