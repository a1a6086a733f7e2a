/*
 * tests/packets.h: the scene's packet calls (scene.h: packets of spc_scene_packet_width lanes, 8 or
 * 16) over SPC_SCENE_PACKET lanes, as consecutive packets of the scene's width, so that a test's
 * packets of SPC_SCENE_PACKET lanes run at either width; and the width of the scenes built next
 * (SPECULA_PACKET_WIDTH, read when a scene's accel is built).
 */
#ifndef SPC_TESTS_PACKETS_H
#define SPC_TESTS_PACKETS_H

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>

#include "scene/scene.h"

/* The packet width of the scenes built from now on: 8 or 16, or 0 for the host's native one. */
static inline void packets_set_width(int w)
{
    if (w == 0) {
        unsetenv("SPECULA_PACKET_WIDTH");
        return;
    }
    char v[16];
    snprintf(v, sizeof v, "%d", w);
    setenv("SPECULA_PACKET_WIDTH", v, 1);
}

/* spc_scene_intersect_packet (coherent: spc_scene_intersect_packet_coherent) over SPC_SCENE_PACKET lanes. */
static inline void packets_intersect(const spc_scene *sc, const spc_ray *const r[SPC_SCENE_PACKET],
                                     spc_hit h[SPC_SCENE_PACKET], bool hit[SPC_SCENE_PACKET], bool coherent)
{
    const int w = spc_scene_packet_width(sc);
    for (int i = 0; i < SPC_SCENE_PACKET; i += w)
        (coherent ? spc_scene_intersect_packet_coherent : spc_scene_intersect_packet)(sc, r + i, h + i, hit + i);
}

/* spc_scene_trace_packet_coherent over SPC_SCENE_PACKET lanes. */
static inline void packets_trace_coherent(const spc_scene *sc, const spc_ray *const r[SPC_SCENE_PACKET],
                                          spc_scene_answer a[SPC_SCENE_PACKET])
{
    const int w = spc_scene_packet_width(sc);
    for (int i = 0; i < SPC_SCENE_PACKET; i += w)
        spc_scene_trace_packet_coherent(sc, r + i, a + i);
}

/* spc_scene_occluded_light_packet (coherent: its octant form) over SPC_SCENE_PACKET lanes. */
static inline void packets_occluded_light(const spc_scene *sc, const spc_ray *const r[SPC_SCENE_PACKET],
                                          const spc_emitter *const e[SPC_SCENE_PACKET], bool occluded[SPC_SCENE_PACKET],
                                          bool coherent)
{
    const int w = spc_scene_packet_width(sc);
    for (int i = 0; i < SPC_SCENE_PACKET; i += w)
        (coherent ? spc_scene_occluded_light_packet_coherent : spc_scene_occluded_light_packet)(sc, r + i, e + i,
                                                                                                occluded + i);
}

#endif
