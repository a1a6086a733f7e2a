/*
 * manifold/receiver.c: the three kinds of receiver a specular chain starts at (receiver.h): the
 * start point chains are traced from, the scattering factor toward the chain's first direction and
 * its density for MIS, and the transmittance of the media a chain from a medium point crosses.
 */
#include "manifold/receiver.h"

#include <string.h>

#include "manifold/caustic_guide.h"

/* A bare start point: no shape, BSDF or offset; the frame around n orients the chain's tangent
 * plane only. */
static void bare_point(spc_hit *x, spc_vec3 p, spc_vec3 n)
{
    memset(x, 0, sizeof *x);
    x->p = p;
    x->ng = n;
    x->sh = spc_frame_from_n(n);
    x->err = 0.0;
    x->t = 0.0;
    x->shape_index = -1;
}

void spc_receiver_surface(spc_receiver *r, const spc_hit *h, spc_vec3 wo)
{
    memset(r, 0, sizeof *r);
    r->kind = SPC_RECEIVER_SURFACE;
    r->hit = h;
    r->wo = wo;
    r->medium = -1;
}

void spc_receiver_medium(spc_receiver *r, spc_vec3 p, spc_vec3 wo, const spc_phase *phase, int medium)
{
    memset(r, 0, sizeof *r);
    r->kind = SPC_RECEIVER_MEDIUM;
    bare_point(&r->point, p, spc_neg(wo));
    r->wo = wo;
    r->phase = phase;
    r->medium = medium;
}

void spc_receiver_camera(spc_receiver *r, const spc_camera_state *cam, double cam_scale)
{
    memset(r, 0, sizeof *r);
    r->kind = SPC_RECEIVER_CAMERA;
    bare_point(&r->point, cam->origin, cam->forward);
    r->wo = cam->forward;
    r->cam = cam;
    r->cam_scale = cam_scale;
    r->medium = -1;
}

bool spc_receiver_eval(const spc_receiver *r, spc_vec3 d0, spc_vec3 p1, spc_rgb *f, double *cosf)
{
    switch (r->kind) {
    case SPC_RECEIVER_SURFACE: {
        const spc_hit *x = r->hit;
        *f = spc_bsdf_eval(x->bsdf, x, SPC_MODE_RADIANCE, r->wo, d0);
        *cosf = spc_absdot(d0, x->sh.n);
        break;
    }
    case SPC_RECEIVER_MEDIUM:
        *f = spc_rgb1(spc_phase_eval(r->phase, r->wo, d0));
        *cosf = 1.0;
        break;
    case SPC_RECEIVER_CAMERA: {
        /* the importance toward p1 (a point the camera's rays reach, past the near plane), over the
         * camera samples per pass: the caller splats it on p1's film position */
        spc_camera_direct cd;
        if (!spc_camera_sample_direct(r->cam, p1, &cd) || spc_dot(cd.wi, d0) > -1.0 + 1e-9)
            return false;
        *f = spc_rgb1(cd.We * r->cam_scale / ((double)r->cam->width * (double)r->cam->height));
        *cosf = 1.0;
        break;
    }
    default: return false;
    }
    return !spc_rgb_is_black(*f) && *cosf > 0.0;
}

double spc_receiver_pdf(const spc_receiver *r, spc_vec3 d0)
{
    switch (r->kind) {
    case SPC_RECEIVER_SURFACE:
        return spc_cguide_mix_pdf(r->guide, spc_bsdf_pdf(r->hit->bsdf, r->hit, SPC_MODE_RADIANCE, r->wo, d0), d0);
    case SPC_RECEIVER_MEDIUM: return spc_phase_pdf(r->phase, r->wo, d0);
    case SPC_RECEIVER_CAMERA: return spc_camera_pdf_dir(r->cam, d0) * r->cam_scale;
    default: return 0.0;
    }
}

int spc_receiver_medium_after(const spc_hit *h, spc_vec3 d, int cur)
{
    const spc_shape *s = h->shape;
    if (!s || (s->interior_medium < 0 && s->exterior_medium < 0))
        return cur;
    return spc_dot(d, h->ng) < 0.0 ? s->interior_medium : s->exterior_medium;
}

/* The transmittance of medium med (-1: vacuum) from a to b. */
static spc_rgb segment_tr(const spc_scene *sc, int med, spc_vec3 a, spc_vec3 b)
{
    double d = spc_distance(a, b);
    if (med < 0 || !(d > 0.0))
        return spc_rgb1(1.0);
    return spc_medium_transmittance_ray(sc->media[med], a, spc_scale(spc_sub(b, a), 1.0 / d), d);
}

spc_rgb spc_receiver_transmittance(const spc_scene *sc, const spc_receiver *r, const spc_chain *c, spc_vec3 y)
{
    spc_rgb T = spc_rgb1(1.0);
    if (r->kind != SPC_RECEIVER_MEDIUM)
        return T;
    int med = r->medium;
    spc_vec3 a = r->point.p;
    for (int i = 0; i < c->n; ++i) {
        const spc_chain_vertex *v = &c->v[i];
        T = spc_rgb_mul(T, segment_tr(sc, med, a, v->h.p));
        med = spc_receiver_medium_after(&v->h, v->d, med);
        a = v->h.p;
    }
    return spc_rgb_mul(T, segment_tr(sc, med, a, y));
}
