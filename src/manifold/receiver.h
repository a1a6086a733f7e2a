/*
 * manifold/receiver.h: where a specular chain starts, and what it scatters there.
 *
 * Specular NEE connects a receiver x through a chain of specular vertices to a light point y
 * (specular_nee.h). A receiver is one of three kinds, each with its own scattering factor toward
 * the chain's first direction d0 (unit, away from x) and the density in which the receiver's own
 * sampling picks d0 (solid angle at x; the other strategy of the MIS weight):
 *
 *   kind     factor f(d0) (times cos)                    density of d0
 *   surface  BSDF(wo, d0), radiance mode; |d0 . n_s|     the BSDF's sampling pdf (mixed with the
 *                                                        caustic guide's where r->guide is set)
 *   medium   phase(wo, d0); 1                            the phase function's (exact sampling)
 *   camera   We(p1) cam_scale / (W H); 1                 W H / N pdf_dir(d0), N the camera samples
 *                                                        per pass: pdf_dir(d0) cam_scale
 *
 * wo points toward the previous path vertex (a surface or medium receiver); p1 is the chain's
 * first vertex (the camera's importance is that of the film point p1 projects to). The factor and
 * the cosine are kept apart so that callers multiply them in the order they always have.
 *
 * Chains are traced from the receiver's start point (spc_receiver_origin): the surface hit itself,
 * or a bare point (the pinhole, a medium point) with no shape, no BSDF and no offset, whose frame
 * only orients the chain tracer's tangent plane.
 *
 * Media: a medium receiver (volpath) has the transmittance of each of the chain's segments in the
 * medium it crosses (the receiver's medium, then across every vertex that is a medium transition
 * the medium of the side the segment goes to, Mitsuba's rule) as a factor of the chain's value
 * (spc_receiver_transmittance); surface and camera receivers of the path tracer ignore media.
 */
#ifndef SPC_MANIFOLD_RECEIVER_H
#define SPC_MANIFOLD_RECEIVER_H

#include <stdbool.h>

#include "manifold/chain.h"
#include "scene/camera.h"

typedef enum spc_receiver_kind {
    SPC_RECEIVER_SURFACE, /* a surface point with a non-delta BSDF lobe */
    SPC_RECEIVER_MEDIUM,  /* a scattering point inside a participating medium */
    SPC_RECEIVER_CAMERA   /* the pinhole of a perspective camera */
} spc_receiver_kind;

typedef struct spc_receiver {
    spc_receiver_kind kind;
    const spc_hit *hit; /* surface: the hit (borrowed) */
    spc_hit point;      /* medium, camera: the bare start point (see above) */
    spc_vec3 wo;        /* surface, medium: toward the previous vertex; camera: the forward axis */
    const spc_phase *phase;             /* medium: its phase function (borrowed) */
    int medium;                         /* medium: its index in scene->media */
    const spc_camera_state *cam;        /* camera (borrowed) */
    double cam_scale;                   /* camera: the full film's pixels over the samples per pass */
    /* surface: the caustic guide at the hit (caustic_guide.h), or NULL; with one, the receiver's
     * own density is the guided mixture's (a p_guide + (1 - a) p_bsdf) */
    const struct spc_cguide_vertex *guide;
} spc_receiver;

/* A surface receiver at h (borrowed: it must outlive r), wo toward the previous vertex. */
void spc_receiver_surface(spc_receiver *r, const spc_hit *h, spc_vec3 wo);
/* A medium receiver at p inside medium `medium` (index in scene->media) of phase function phase. */
void spc_receiver_medium(spc_receiver *r, spc_vec3 p, spc_vec3 wo, const spc_phase *phase, int medium);
/* The camera's pinhole (a perspective camera; cam_scale as spc_snee_camera). */
void spc_receiver_camera(spc_receiver *r, const spc_camera_state *cam, double cam_scale);

/* The point chains are traced from (the surface hit, or the bare point). */
static inline const spc_hit *spc_receiver_origin(const spc_receiver *r)
{
    return r->kind == SPC_RECEIVER_SURFACE ? r->hit : &r->point;
}

/* The scattering factor toward d0 with the chain's first vertex at p1 (table above): *f and *cosf;
 * false (nothing to add) where either vanishes, or from the camera where p1 is off the film, before
 * the near plane, or not along d0. */
bool spc_receiver_eval(const spc_receiver *r, spc_vec3 d0, spc_vec3 p1, spc_rgb *f, double *cosf);
/* The density of d0 in the receiver's own sampling (table above); 0 where it never picks d0. */
double spc_receiver_pdf(const spc_receiver *r, spc_vec3 d0);

/* The transmittance of the media along chain c from a medium receiver to the light point y (table
 * above): 1 for other receivers and in vacuum. */
spc_rgb spc_receiver_transmittance(const spc_scene *sc, const spc_receiver *r, const spc_chain *c, spc_vec3 y);

/* The medium (index, -1 vacuum) of a ray leaving the surface of h along d, coming from `cur`:
 * interior opposite to the geometric normal, exterior on its side; unchanged at a surface that is
 * no medium transition. */
int spc_receiver_medium_after(const spc_hit *h, spc_vec3 d, int cur);

#endif
