/*
 * medium/heterogeneous.c: Mitsuba 3's heterogeneous medium: sigma_t(x) = scale sigma_t_vol(x)
 * inside the world bounds of its sigma_t volume (vacuum outside, as Mitsuba's intersect_aabb),
 * sigma_s(x) = sigma_t(x) albedo(x), albedo a constant or a volume (gridvolume.c).
 *
 * Optical depth is integrated exactly (medium.h): along the ray the volume is a cubic polynomial
 * on each piece between planes of texel centres (spc_volume_pieces), and Simpson's rule
 * (b - a) / 6 (f(a) + 4 f(m) + f(b)) is exact for cubics; nearest grids and constants are constant
 * on their pieces. Transmittance is then exp(-tau), with no noise. Free flight inverts tau for the
 * chosen channel (regular tracking; Sutton et al. 1999, "Monte Carlo methods for volumetric light
 * transport", and the survey of Novak et al. 2018, sec. 4.1): tau_c(t) = -ln(1 - u) is solved on
 * the piece where tau_c crosses it by Newton's method, safeguarded by bisection, on the exact
 * partial integral (tau_c is increasing: sigma_t >= 0). Mitsuba draws the same distribution by
 * delta tracking against its majorant; the densities are identical, only the noise differs.
 *
 * Mitsuba XML <medium type="heterogeneous">:
 *   sigma_t   volume (gridvolume, constvolume) or float/rgb (a constvolume over the unit cube)   1
 *   albedo    volume or float/rgb                                                             0.75
 *   scale     float                                                                            1
 *   sample_emitters boolean true; has_spectral_extinction (accepted; RGB is always spectral here)
 *   <phase>   nested or referenced, isotropic by default
 */
#include <math.h>

#include "medium/variants.h"
#include "medium/volume_pieces.h"

/* Newton steps for a free-flight distance within one piece (each halves the bracket at worst). */
#define FREE_FLIGHT_MAX_ITER 60

static double ch(spc_rgb c, int i) { return i == 0 ? c.r : (i == 1 ? c.g : c.b); }

static spc_rgb sigma_t_at(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t)
{
    return spc_rgb_scale(spc_volume_eval(&m->sigma_t_vol, spc_madd(o, d, t)), m->scale);
}

/* The parameter range [*ta, *tb] of the ray inside the volume's bounds and [0, t_max]. */
static bool clip(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t_max, double *ta, double *tb)
{
    const spc_volume *v = &m->sigma_t_vol;
    double lo[3] = {v->lo.x, v->lo.y, v->lo.z}, hi[3] = {v->hi.x, v->hi.y, v->hi.z};
    double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
    double a = 0.0, b = t_max;
    for (int k = 0; k < 3; ++k) {
        if (dd[k] == 0.0) {
            if (oo[k] < lo[k] || oo[k] > hi[k])
                return false;
            continue;
        }
        double t0 = (lo[k] - oo[k]) / dd[k], t1 = (hi[k] - oo[k]) / dd[k];
        if (t0 > t1) {
            double s = t0;
            t0 = t1;
            t1 = s;
        }
        a = fmax(a, t0);
        b = fmin(b, t1);
    }
    *ta = a;
    *tb = b;
    return b > a;
}

static bool piecewise_constant(const spc_medium *m) { return !m->sigma_t_vol.grid || m->sigma_t_vol.nearest; }

/* Optical depth over [a, b], inside one piece. */
static spc_rgb depth(const spc_medium *m, spc_vec3 o, spc_vec3 d, double a, double b)
{
    if (piecewise_constant(m))
        return spc_rgb_scale(sigma_t_at(m, o, d, 0.5 * (a + b)), b - a);
    spc_rgb s = spc_rgb_add(spc_rgb_add(sigma_t_at(m, o, d, a), spc_rgb_scale(sigma_t_at(m, o, d, 0.5 * (a + b)), 4.0)),
                            sigma_t_at(m, o, d, b));
    return spc_rgb_scale(s, (b - a) / 6.0);
}

static spc_rgb exp_neg(spc_rgb tau) { return spc_rgb3(exp(-tau.r), exp(-tau.g), exp(-tau.b)); }

/* Optical depth from the ray's start to t (t may be +inf). */
static spc_rgb depth_to(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t)
{
    spc_rgb tau = spc_rgb1(0.0);
    double ta, tb, a, b;
    if (!clip(m, o, d, t, &ta, &tb))
        return tau;
    spc_volume_pieces it;
    spc_volume_pieces_begin(&it, &m->sigma_t_vol, o, d, ta, tb);
    while (spc_volume_pieces_next(&it, &a, &b))
        tau = spc_rgb_add(tau, depth(m, o, d, a, b));
    return tau;
}

spc_rgb spc_heterogeneous_transmittance(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t)
{
    return exp_neg(depth_to(m, o, d, t));
}

/* The s in [0, b - a] where channel c's optical depth from a reaches rem (< its depth over the
 * piece). */
static double solve_in_piece(const spc_medium *m, spc_vec3 o, spc_vec3 d, int c, double a, double b, double rem)
{
    double h = b - a;
    if (piecewise_constant(m)) {
        double s = ch(sigma_t_at(m, o, d, 0.5 * (a + b)), c);
        return s > 0.0 ? spc_clamp(rem / s, 0.0, h) : h;
    }
    double lo = 0.0, hi = h, s = 0.5 * h;
    for (int i = 0; i < FREE_FLIGHT_MAX_ITER; ++i) {
        double F = ch(depth(m, o, d, a, a + s), c) - rem;
        if (F > 0.0)
            hi = s;
        else
            lo = s;
        double f = ch(sigma_t_at(m, o, d, a + s), c);
        double sn = f > 0.0 ? s - F / f : 0.5 * (lo + hi);
        if (!(sn > lo && sn < hi))
            sn = 0.5 * (lo + hi);
        if (fabs(sn - s) <= 1e-14 * (h + fabs(a)) || hi - lo <= 1e-15 * (h + fabs(a))) {
            s = sn;
            break;
        }
        s = sn;
    }
    return s;
}

static double mixture(const double q[3], spc_rgb sigma, spc_rgb T, bool scattered)
{
    double p = 0.0;
    for (int i = 0; i < 3; ++i)
        if (q[i] > 0.0)
            p += q[i] * (scattered ? ch(sigma, i) : 1.0) * ch(T, i);
    return p;
}

static spc_rgb albedo_at(const spc_medium *m, spc_vec3 x)
{
    return m->has_albedo_vol ? spc_volume_eval(&m->albedo_vol, x) : m->albedo;
}

bool spc_heterogeneous_sample(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t_max, spc_rgb beta, double u_channel,
                              double u_dist, spc_medium_event *out)
{
    double q[3];
    spc_medium_channel_pmf(beta, q);
    int c = spc_medium_pick_channel(q, u_channel);
    if (c < 0)
        return false;
    double target = -log1p(-u_dist), ta, tb, a, b, t = INFINITY;
    spc_rgb tau = spc_rgb1(0.0);
    if (clip(m, o, d, t_max, &ta, &tb)) {
        spc_volume_pieces it;
        spc_volume_pieces_begin(&it, &m->sigma_t_vol, o, d, ta, tb);
        while (spc_volume_pieces_next(&it, &a, &b)) {
            spc_rgb dt = depth(m, o, d, a, b);
            if (ch(tau, c) + ch(dt, c) > target) {
                double s = solve_in_piece(m, o, d, c, a, b, target - ch(tau, c));
                t = a + s;
                tau = spc_rgb_add(tau, depth(m, o, d, a, t));
                break;
            }
            tau = spc_rgb_add(tau, dt);
        }
    }
    spc_rgb T = exp_neg(tau);
    if (t < t_max) {
        spc_vec3 x = spc_madd(o, d, t);
        spc_rgb st = spc_rgb_scale(spc_volume_eval(&m->sigma_t_vol, x), m->scale);
        spc_rgb al = albedo_at(m, x);
        double pdf = mixture(q, st, T, true);
        if (!(pdf > 0.0))
            return false;
        out->scattered = true;
        out->t = t;
        out->pdf = pdf;
        out->albedo = al;
        out->weight = spc_rgb_scale(spc_rgb_mul(spc_rgb_mul(st, al), T), 1.0 / pdf);
        return true;
    }
    double P = mixture(q, spc_rgb1(0.0), T, false);
    if (!(P > 0.0))
        return false;
    out->scattered = false;
    out->t = t_max;
    out->pdf = P;
    out->albedo = spc_rgb1(0.0);
    out->weight = spc_rgb_scale(T, 1.0 / P);
    return true;
}

double spc_heterogeneous_pdf(const spc_medium *m, spc_vec3 o, spc_vec3 d, spc_rgb beta, double t, double t_max,
                             bool scattered)
{
    double q[3];
    spc_medium_channel_pmf(beta, q);
    if (scattered && !(t < t_max))
        return 0.0;
    double at = scattered ? t : t_max;
    spc_rgb T = exp_neg(depth_to(m, o, d, at));
    spc_rgb sigma = spc_rgb1(0.0);
    if (scattered) {
        double ta, tb;
        /* sigma_t is zero outside the bounds */
        if (clip(m, o, d, INFINITY, &ta, &tb) && t >= ta && t <= tb)
            sigma = sigma_t_at(m, o, d, t);
    }
    return mixture(q, sigma, T, scattered);
}
