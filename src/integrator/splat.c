/*
 * integrator/splat.c: splats, spread over the pixels within the pixel filter's radius by the
 * normalized filter (renormalized near the rendered window's edges), into the tile's scratch.
 */
#include "integrator/splat.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "scene/rfilter.h"

#define SPC_SPLAT_MAX_COORD 1e9 /* film coordinates beyond this lie on no film (sides <= 65536) */

static void push_splat(spc_tls *tls, int film, int x, int y, spc_rgb v)
{
    if (tls->nsplats == tls->cap) {
        size_t ncap = tls->cap ? 2 * tls->cap : 256;
        spc_splat *ns = realloc(tls->splats, ncap * sizeof *ns);
        if (!ns) {
            tls->oom = true;
            if (film == 0)
                tls->invalid++;
            return;
        }
        tls->splats = ns;
        tls->cap = ncap;
    }
    spc_splat *s = &tls->splats[tls->nsplats++];
    s->x = x;
    s->y = y;
    s->r = (float)v.r;
    s->g = (float)v.g;
    s->b = (float)v.b;
    s->film = film;
}

void spc_splat_add(const spc_render_ctx *ctx, spc_tls *tls, double fx, double fy, spc_rgb v)
{
    spc_splat_add_to(ctx, tls, 0, fx, fy, v);
}

void spc_splat_add_to(const spc_render_ctx *ctx, spc_tls *tls, int film, double fx, double fy, spc_rgb v)
{
    /* splats are stored as float: a value beyond float range is as invalid as a NaN (the driver
     * applies the same rule to camera samples) */
    if (!(fabs(v.r) <= FLT_MAX && fabs(v.g) <= FLT_MAX && fabs(v.b) <= FLT_MAX)) {
        if (film == 0)
            tls->invalid++;
        return;
    }
    if (!(fabs(fx) < SPC_SPLAT_MAX_COORD && fabs(fy) < SPC_SPLAT_MAX_COORD))
        return; /* NaN or far off the film: no pixel; and the int conversions below stay defined */
    double r = ctx->film->filter_radius;
    /* pixels whose centers lie within the filter radius, in the rendered window */
    int x0 = (int)floor(fx - r - 0.5) + 1, x1 = (int)floor(fx + r - 0.5);
    int y0 = (int)floor(fy - r - 0.5) + 1, y1 = (int)floor(fy + r - 0.5);
    if (ctx->film->rfilter == SPC_RFILTER_BOX) {
        /* a box of radius 0.5 covers exactly the pixel containing the point */
        if (r <= 0.5) {
            x0 = x1 = (int)floor(fx);
            y0 = y1 = (int)floor(fy);
        }
    }
    for (int y = y0; y <= y1; ++y) {
        int wy = y - ctx->crop_y;
        if (wy < 0 || wy >= ctx->height)
            continue;
        bool unit_box = ctx->film->rfilter == SPC_RFILTER_BOX && r <= 0.5;
        double fyw = unit_box ? 1.0 : spc_film_filter_eval(ctx->film, y + 0.5 - fy);
        for (int x = x0; x <= x1; ++x) {
            int wx = x - ctx->crop_x;
            if (wx < 0 || wx >= ctx->width)
                continue;
            double fxw = unit_box ? 1.0 : spc_film_filter_eval(ctx->film, x + 0.5 - fx);
            double w = fxw * fyw;
            /* near the window's edges the filter is renormalized over the part inside (film.h) */
            if (w > 0.0 && r > 0.5)
                w /= spc_film_filter_mass(ctx->film, x + 0.5, ctx->crop_x, ctx->crop_x + ctx->width) *
                     spc_film_filter_mass(ctx->film, y + 0.5, ctx->crop_y, ctx->crop_y + ctx->height);
            if (w > 0.0)
                push_splat(tls, film, wx, wy, spc_rgb_scale(v, w));
        }
    }
}
