/*
 * accel/accel.h: the acceleration structure (Embree 3). Triangles go to Embree's triangle
 * geometry; analytic shapes are Embree user geometry intersected in double precision from the
 * caller's double ray (passed through an extended intersect context). No Embree type leaves
 * src/accel/.
 */
#ifndef SPC_ACCEL_ACCEL_H
#define SPC_ACCEL_ACCEL_H

#include <stdint.h>

#include "core/error.h"
#include "core/math.h"

struct spc_scene;
typedef struct spc_accel spc_accel;

/* Builds over scene->shapes (which must stay alive and unchanged). NULL with err on failure. */
spc_accel *spc_accel_create(const struct spc_scene *scene, spc_error *err);
void spc_accel_destroy(spc_accel *a);

/* Scenes of at least this many triangles in all get Embree's compact BVH unless the scene sets its
 * own limit (spc_scene.accel_compact_tris): a BVH4 whose leaves index the shared vertex buffer
 * (triangle4i) instead of a BVH8 whose leaves hold copies of the vertices (triangle4v). The hits
 * are the same either way. Compact builds in about half the time and memory but traces a ray in
 * about 1.5x the time (a 999,698-triangle height field: 0.19 against 0.38 CPU-s to build, 34 MiB
 * less peak memory, 480 against 314 ns a ray), so it pays only where a render traces fewer rays
 * than about its triangles; a 10-million-triangle mesh loads in about half the memory with it
 * (1230 -> 656 MiB peak). bench/RESULTS.md has the measurements. */
#define SPC_ACCEL_COMPACT_TRIS (1u << 22)
/* Was the BVH built compact? */
bool spc_accel_compact(const spc_accel *a);

/* Nearest hit in (tmin, tmax): shape index, primitive, surface coordinates and distance. */
bool spc_accel_intersect(const spc_accel *a, const spc_ray *r, int *shape, int *prim, double *u, double *v,
                         double *t);
/* Any hit in (tmin, tmax). */
bool spc_accel_occluded(const spc_accel *a, const spc_ray *r);
/* The same, where the caller knows that the shape with index skip cannot meet the ray in
 * (tmin, tmax) in exact arithmetic (a shadow ray toward a point that the shape's own light sampled
 * on the part of it that the origin sees): that shape may be left untested, so the answer differs
 * from spc_accel_occluded's only where rounding made the shape block the ray. Shapes left
 * untested: up to SPC_ACCEL_SKIP_MAX analytic spheres with an emitter (Embree's ray masks, one bit
 * each, given at build in shape order); any other skip (or -1) tests every shape. */
#define SPC_ACCEL_SKIP_MAX 31
bool spc_accel_occluded_skip(const spc_accel *a, const spc_ray *r, int skip);
/* Does the accel leave any shape untested for a skip (has it an emitting sphere)? */
bool spc_accel_skips_any(const spc_accel *a);
/* Packets of spc_accel_packet_width(a) rays traced together (Embree's rtcIntersect8/16,
 * rtcOccluded8/16): lane i of [0, width) traces r[i] where r[i] is not NULL; the functions read and
 * write the arrays' first width entries only. The results are spc_accel_intersect's and
 * spc_accel_occluded's per lane (shape[i] = -1 and prim[i], u[i], v[i], t[i] 0 for a miss or an
 * inactive lane; occluded[i] false for an inactive lane), whatever the width. SPC_ACCEL_PACKET is
 * the widest packet. */
#define SPC_ACCEL_PACKET 16
/* The packets' width, 8 or 16: Embree's native width on the host (16 with AVX-512, 8 with AVX2;
 * 16 where neither is native), or SPECULA_PACKET_WIDTH's (8 or 16) where that is set. */
int spc_accel_packet_width(const spc_accel *a);
void spc_accel_intersect_packet(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                                int shape[SPC_ACCEL_PACKET], int prim[SPC_ACCEL_PACKET], double u[SPC_ACCEL_PACKET],
                                double v[SPC_ACCEL_PACKET], double t[SPC_ACCEL_PACKET]);
/* spc_accel_intersect_packet for rays that run nearly parallel from nearby origins (a camera's
 * rays through neighbouring pixels): Embree's coherent packet traversal, the same hits. Slower than
 * spc_accel_intersect_packet for rays that scatter (2x on a path tracer's bounces). */
void spc_accel_intersect_packet_coherent(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                                         int shape[SPC_ACCEL_PACKET], int prim[SPC_ACCEL_PACKET],
                                         double u[SPC_ACCEL_PACKET], double v[SPC_ACCEL_PACKET],
                                         double t[SPC_ACCEL_PACKET]);
void spc_accel_occluded_packet(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                               bool occluded[SPC_ACCEL_PACKET]);
/* spc_accel_occluded_skip per lane (skip[i] for lane i); skip NULL: spc_accel_occluded_packet. */
void spc_accel_occluded_packet_skip(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                                    const int skip[SPC_ACCEL_PACKET], bool occluded[SPC_ACCEL_PACKET]);
/* spc_accel_occluded_packet_skip for rays whose directions share their signs (one octant): Embree's
 * coherent traversal in scenes of fewer than SPC_ACCEL_INCOHERENT_SHADOW_TRIS triangles, its
 * incoherent one in bigger ones (spc_accel_shadows_coherent); the same answers either way. The
 * coherent traversal pays on the cornell box's shadow packets (36 triangles), but on height fields
 * of 10 thousand to a million triangles, whose BVH's deep levels the packet's rays part in, it costs
 * 7 to 11% of plain path tracing's CPU time (bench/RESULTS.md). */
#define SPC_ACCEL_INCOHERENT_SHADOW_TRIS (1u << 13)
bool spc_accel_shadows_coherent(const spc_accel *a);
void spc_accel_occluded_packet_skip_coherent(const spc_accel *a, const spc_ray *const r[SPC_ACCEL_PACKET],
                                             const int skip[SPC_ACCEL_PACKET], bool occluded[SPC_ACCEL_PACKET]);
/* Benchmark support: traces n rays with bare rtcIntersect1 calls (no hit records, no double
 * precision user geometry bookkeeping beyond what Embree calls) and returns how many hit. Not
 * counted in spc_accel_rays_traced. */
uint64_t spc_accel_raw_loop(const spc_accel *a, const spc_ray *rays, size_t n);
/* Rays traced by the calling thread so far. */
uint64_t spc_accel_rays_traced(void);
/* Of those, the shadow rays (spc_accel_occluded and the lanes of spc_accel_occluded_packet). */
uint64_t spc_accel_shadow_rays_traced(void);
/* Lanes that the calling thread's traces have handed to an analytic shape's exact test (Embree's
 * user geometry callbacks) so far: a measure of the work the packets' culls save. */
uint64_t spc_accel_analytic_tests(void);

#endif
