/*
 * medium/medium.c: the medium contract's functions along a ray (medium.h), dispatched to the
 * variants by type (homogeneous.c: closed forms by distance; heterogeneous.c: exact optical depth
 * through volumes), the coefficients at a point, and the release of volume grids.
 */
#include <stdlib.h>

#include "medium/variants.h"

void spc_medium_release(spc_medium *m)
{
    if (!m)
        return;
    free(m->sigma_t_vol.data);
    free(m->albedo_vol.data);
    m->sigma_t_vol.data = m->albedo_vol.data = NULL;
}

void spc_medium_init_heterogeneous(spc_medium *m, const spc_volume *sigma_t_vol, double scale, spc_rgb albedo)
{
    m->type = SPC_MEDIUM_HETEROGENEOUS;
    m->sigma_t_vol = *sigma_t_vol;
    m->scale = scale;
    m->albedo = albedo;
    m->has_albedo_vol = false;
    /* the bounds of the coefficients, for descriptions */
    m->sigma_t = spc_rgb_scale(sigma_t_vol->max, scale);
    m->sigma_s = spc_rgb_mul(m->sigma_t, albedo);
    m->sigma_a = spc_rgb_sub(m->sigma_t, m->sigma_s);
    m->phase.type = SPC_PHASE_ISOTROPIC;
    m->phase.g = 0.0;
    m->sample_emitters = true;
}

void spc_medium_coefficients(const spc_medium *m, spc_vec3 x, spc_rgb *sigma_t, spc_rgb *sigma_s)
{
    switch (m->type) {
    case SPC_MEDIUM_HOMOGENEOUS:
        *sigma_t = m->sigma_t;
        *sigma_s = m->has_albedo_vol ? spc_rgb_mul(m->sigma_t, spc_volume_eval(&m->albedo_vol, x)) : m->sigma_s;
        return;
    case SPC_MEDIUM_HETEROGENEOUS: {
        bool inside = x.x >= m->sigma_t_vol.lo.x && x.x <= m->sigma_t_vol.hi.x && x.y >= m->sigma_t_vol.lo.y &&
                      x.y <= m->sigma_t_vol.hi.y && x.z >= m->sigma_t_vol.lo.z && x.z <= m->sigma_t_vol.hi.z;
        *sigma_t = inside ? spc_rgb_scale(spc_volume_eval(&m->sigma_t_vol, x), m->scale) : spc_rgb1(0.0);
        *sigma_s = spc_rgb_mul(*sigma_t, m->has_albedo_vol ? spc_volume_eval(&m->albedo_vol, x) : m->albedo);
        return;
    }
    }
    *sigma_t = *sigma_s = spc_rgb1(0.0);
}

spc_rgb spc_medium_transmittance_ray(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t)
{
    switch (m->type) {
    case SPC_MEDIUM_HOMOGENEOUS:
        return spc_medium_transmittance(m, t);
    case SPC_MEDIUM_HETEROGENEOUS:
        return spc_heterogeneous_transmittance(m, o, d, t);
    }
    return spc_rgb1(1.0);
}

bool spc_medium_sample_ray(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t_max, spc_rgb beta, double u_channel,
                           double u_dist, spc_medium_event *out)
{
    switch (m->type) {
    case SPC_MEDIUM_HOMOGENEOUS: {
        if (!spc_medium_sample_distance(m, t_max, beta, u_channel, u_dist, out))
            return false;
        if (out->scattered && m->has_albedo_vol) {
            /* the scattering coefficient where the interaction is */
            spc_rgb st, ss;
            spc_medium_coefficients(m, spc_madd(o, d, out->t), &st, &ss);
            out->weight = spc_rgb_scale(spc_rgb_mul(ss, spc_medium_transmittance(m, out->t)), 1.0 / out->pdf);
            out->albedo = spc_rgb_div(ss, st);
        }
        return true;
    }
    case SPC_MEDIUM_HETEROGENEOUS:
        return spc_heterogeneous_sample(m, o, d, t_max, beta, u_channel, u_dist, out);
    }
    return false;
}

double spc_medium_pdf_ray(const spc_medium *m, spc_vec3 o, spc_vec3 d, spc_rgb beta, double t, double t_max,
                          bool scattered)
{
    switch (m->type) {
    case SPC_MEDIUM_HOMOGENEOUS:
        return spc_medium_pdf_distance(m, beta, t, t_max, scattered);
    case SPC_MEDIUM_HETEROGENEOUS:
        return spc_heterogeneous_pdf(m, o, d, beta, t, t_max, scattered);
    }
    return 0.0;
}
