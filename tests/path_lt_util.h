/*
 * tests/path_lt_util.h: what the tests of the light-traced caustics (integrator/path_lt.h) share: a
 * path render context as the joins' callers see it, and the camera's side of an area light's join
 * (the ratio the path tracer's specular NEE reads at x2) for checking a join's weight against the
 * path side's (test_path_lt.c, test_path_lt_sdf.c).
 */
#ifndef SPC_TESTS_PATH_LT_UTIL_H
#define SPC_TESTS_PATH_LT_UTIL_H

#include <string.h>

#include "integrator/path_lt.h"
#include "manifold/receiver.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "render_util.h"

/* A path render context on sc with specular NEE's setting p, as the joins' callers see it. */
static spc_render_ctx lt_ctx(spc_scene *sc, spc_camera_state *cam, const spc_snee_params *p)
{
    spc_render_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = sc;
    ctx.cam = cam;
    ctx.kind = SPC_INTEGRATOR_PATH;
    ctx.max_depth = -1;
    ctx.rr_depth = 5;
    ctx.specular_nee = SPC_SNEE_ANGULAR;
    ctx.specular_max_chain = 2;
    ctx.snee = *p;
    ctx.width = sc->film.width;
    ctx.height = sc->film.height;
    return ctx;
}

/* The camera's side of an area light's join as the path tracer's specular NEE at x2 reads it
 * (params.alt_chain_ratio): its x1, w1 and camera chain cc, the chain budget at x2. */
typedef struct area_cam {
    const spc_render_ctx *ctx;
    const spc_snee_params *p;
    const spc_path_lt_join *j;
    int kmax, kflat;
} area_cam;

static double area_cam_ratio(const void *user, const spc_hit *x, spc_vec3 wo, const spc_chain *c, const spc_emitter *e,
                             spc_vec3 y, spc_vec3 ny)
{
    const area_cam *a = user;
    if (c->n > spc_path_lt_area_chain_max(a->p, c, a->kmax, a->kflat))
        return 0.0;
    return spc_path_lt_area_ratio(a->ctx, a->p, a->j->x1, a->j->w1, x, wo, a->j->cc, c, e, y, ny);
}

/* The weights spc_snee_receiver_weights gives a join's path at its receiver x2 (the chain j->c to the
 * light point j->y) under pp with the chain budget kmax: specular NEE's own (returned) and the other
 * strategies' (*w_alt). */
static double join_receiver_weights(const spc_scene *sc, const spc_snee_params *pp, const spc_path_lt_join *j, int kmax,
                                    double *w_alt)
{
    spc_receiver r;
    spc_receiver_surface(&r, j->x2, j->w2);
    r.guide = pp->cguide_at; /* the path's guided mixture at x2, if any */
    unsigned char ev[SPC_CHAIN_MAX_VERTICES];
    for (int i = 0; i < j->c->n && i < SPC_CHAIN_MAX_VERTICES; ++i)
        ev[i] = j->c->v[i].event;
    spc_hit lh;
    memset(&lh, 0, sizeof lh);
    lh.p = j->y;
    lh.ng = j->ny;
    lh.emitter = j->e;
    lh.shape = j->e->shape;
    return spc_snee_receiver_weights(sc, pp, &r, j->c->d0, kmax, j->c->n, ev, &lh, w_alt);
}

#endif
