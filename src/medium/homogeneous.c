/*
 * medium/homogeneous.c: a homogeneous medium (constant coefficients inside the shapes that name it):
 * closed-form transmittance T(d) = exp(-sigma_t d), and spectral free-flight sampling by one
 * channel chosen in proportion to the path throughput, weighted by the mixture ("average") density
 * of all channels so that every RGB channel is estimated without bias (the one-sample balance
 * heuristic over channels; Veach 1997, sec. 9.2.4; Miller, Georgiev and Jarosz 2019, "A null-
 * scattering path integral formulation of light transport", sec. 5 on spectral MIS; pbrt-v4 sec.
 * 14.1.3). Formulas in medium.h.
 *
 * Mitsuba XML <medium type="homogeneous"> (read by io/mitsuba_plugins.c):
 *   sigma_a, sigma_s   spectrum/rgb/float       (Mitsuba 0.x names sigmaA, sigmaS; a missing one is 0)
 *   sigma_t, albedo    spectrum/rgb/float       1, 0.75 (Mitsuba 3: sigma_s = albedo sigma_t)
 *   scale              float                    1 (multiplies every coefficient)
 *   sample_emitters    boolean                  true
 *   <phase>            nested or referenced     isotropic
 */
#include "medium/variants.h"

static double channel(spc_rgb c, int i) { return i == 0 ? c.r : (i == 1 ? c.g : c.b); }

static double tr1(double sigma, double d)
{
    /* sigma = 0 over an infinite distance is 1, not exp(NaN) */
    return sigma > 0.0 ? exp(-sigma * d) : 1.0;
}

bool spc_medium_init_homogeneous(spc_medium *m, spc_rgb sigma_a, spc_rgb sigma_s)
{
    for (int i = 0; i < 3; ++i) {
        double a = channel(sigma_a, i), s = channel(sigma_s, i);
        if (!(a >= 0.0) || !(s >= 0.0) || !isfinite(a) || !isfinite(s))
            return false;
    }
    m->type = SPC_MEDIUM_HOMOGENEOUS;
    m->sigma_a = sigma_a;
    m->sigma_s = sigma_s;
    m->sigma_t = spc_rgb_add(sigma_a, sigma_s);
    m->phase.type = SPC_PHASE_ISOTROPIC;
    m->phase.g = 0.0;
    m->sample_emitters = true;
    m->has_albedo_vol = false;
    m->albedo = spc_rgb1(0.0);
    m->scale = 1.0;
    return true;
}

bool spc_medium_is_vacuum(const spc_medium *m)
{
    switch (m->type) {
    case SPC_MEDIUM_HOMOGENEOUS: return spc_rgb_is_black(m->sigma_t);
    case SPC_MEDIUM_HETEROGENEOUS: return !(m->scale > 0.0) || spc_rgb_max(m->sigma_t_vol.max) <= 0.0;
    }
    return true;
}

spc_rgb spc_medium_transmittance(const spc_medium *m, double d)
{
    switch (m->type) {
    case SPC_MEDIUM_HOMOGENEOUS:
        return spc_rgb3(tr1(m->sigma_t.r, d), tr1(m->sigma_t.g, d), tr1(m->sigma_t.b, d));
    case SPC_MEDIUM_HETEROGENEOUS: break; /* depends on the ray: spc_medium_transmittance_ray */
    }
    return spc_rgb1(1.0);
}

/* sum_c q_c sigma_t[c] T_c(t) (interaction) or sum_c q_c T_c(t_max) (passing) */
static double mixture(const spc_medium *m, const double q[3], double t, bool scattered)
{
    double pdf = 0.0;
    for (int i = 0; i < 3; ++i) {
        double s = channel(m->sigma_t, i);
        if (q[i] > 0.0)
            pdf += q[i] * (scattered ? s : 1.0) * tr1(s, t);
    }
    return pdf;
}

double spc_medium_pdf_distance(const spc_medium *m, spc_rgb beta, double t, double t_max, bool scattered)
{
    double q[3];
    spc_medium_channel_pmf(beta, q);
    if (scattered && !(t < t_max))
        return 0.0;
    return mixture(m, q, scattered ? t : t_max, scattered);
}

bool spc_medium_sample_distance(const spc_medium *m, double t_max, spc_rgb beta, double u_channel, double u_dist,
                                spc_medium_event *out)
{
    double q[3];
    spc_medium_channel_pmf(beta, q);
    /* the channel: the first whose cumulative probability exceeds u (zero-probability channels
     * are never chosen, even when u sits on a boundary) */
    int c = spc_medium_pick_channel(q, u_channel);
    if (c < 0)
        return false;
    double s = channel(m->sigma_t, c);
    double t = s > 0.0 ? -log1p(-u_dist) / s : INFINITY;
    if (t < t_max) {
        double pdf = mixture(m, q, t, true);
        if (!(pdf > 0.0))
            return false;
        out->scattered = true;
        out->t = t;
        out->pdf = pdf;
        out->weight = spc_rgb_scale(spc_rgb_mul(m->sigma_s, spc_medium_transmittance(m, t)), 1.0 / pdf);
        out->albedo = spc_rgb_div(m->sigma_s, m->sigma_t);
        return true;
    }
    double P = mixture(m, q, t_max, false);
    if (!(P > 0.0))
        return false;
    out->scattered = false;
    out->t = t_max;
    out->pdf = P;
    out->weight = spc_rgb_scale(spc_medium_transmittance(m, t_max), 1.0 / P);
    out->albedo = spc_rgb1(0.0);
    return true;
}
