/*
 * bsdf/microfacet.c: GGX and Beckmann microfacet distributions with anisotropic roughness.
 *
 * - D(m): Walter et al. 2007, eqs. 25 (Beckmann) and 33 (GGX), written with the anisotropic
 *   slope scaling (x^2/alpha_u^2 + y^2/alpha_v^2) of Heitz 2014, eqs. 72 and 80.
 * - Lambda(w): Heitz 2014, eqs. 72 (Beckmann: (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt(pi))) and
 *   86 (GGX: (-1 + sqrt(1 + 1/a^2))/2), with 1/a = alpha(phi) tan(theta). Beckmann uses the exact
 *   expression (Mitsuba uses a rational fit within 0.35 %), so sampling and pdf agree exactly.
 * - Visible normals, GGX: Heitz 2018, "Sampling the GGX Distribution of Visible Normals"
 *   (stretch, sample the projected hemisphere, unstretch).
 * - Visible normals, Beckmann: Heitz and d'Eon 2014, "Importance Sampling Microfacet-Based BSDFs
 *   using the Distribution of Visible Normals", sec. 4: stretch the direction to alpha = 1, sample
 *   the visible slope distribution for that incidence, rotate, unstretch. The x-slope marginal
 *   p(x) ~ (1 - x tan t) exp(-x^2), x < cot t, has the CDF
 *   F(x) = sqrt(pi)/2 erfc(-x) + tan(t)/2 exp(-x^2), which we invert to double precision by
 *   Halley's method safeguarded with bisection, started from a tabulated guess; the y-slope is
 *   Gaussian: erfinv(2u - 1).
 * - sample_visible false: slopes drawn from the (stretched) isotropic slope distribution, giving
 *   the density D(m) m.z.
 */
#include "bsdf/microfacet.h"

#include <pthread.h>

#include "core/warp.h"

/* Slopes beyond this are irrelevant for the Beckmann slope CDF: exp(-10^2) is below double
 * precision relative to the distribution's mass. */
#define BECKMANN_SLOPE_LIMIT 10.0
/* Iterations of the Beckmann slope inversion: from the table's guess about 1.9 on average, up to
 * 19 in the tails' end cells (20000 draws); the bound only guards against pathological inputs. */
#define BECKMANN_MAX_ITERATIONS 60
/* Where a = cot(theta) / alpha(phi) >= 6, Beckmann's Lambda is below 2e-19 (asymptotically
 * exp(-a^2) / (4 a^3 sqrt(pi)): 1.5e-19 at a = 6), far below half an ulp of 1
 * (1.1e-16), so G1 = 1 / (1 + Lambda) is exactly 1 in double. Lambda then returns 0 without its exp
 * and erfc; test_microfacet_fast checks G1's bits against the full formula on both sides of the
 * limit. Rough metals mostly see such directions (alpha 0.1: every theta below 59 degrees). */
#define BECKMANN_LAMBDA_A2T2_NEGLIGIBLE (1.0 / 36.0)

spc_microfacet spc_microfacet_make(spc_microfacet_type type, double alpha_u, double alpha_v, bool sample_visible)
{
    spc_microfacet md;
    md.type = type;
    md.alpha_u = isfinite(alpha_u) ? spc_max(alpha_u, SPC_MICROFACET_MIN_ALPHA) : SPC_MICROFACET_MIN_ALPHA;
    md.alpha_v = isfinite(alpha_v) ? spc_max(alpha_v, SPC_MICROFACET_MIN_ALPHA) : SPC_MICROFACET_MIN_ALPHA;
    md.sample_visible = sample_visible;
    return md;
}

spc_microfacet spc_microfacet_from_bsdf(const spc_bsdf *b, const spc_hit *h)
{
    double au = b->alpha_u ? spc_texture_eval1_hit(b->alpha_u, h) : 0.1;
    double av = b->alpha_v ? spc_texture_eval1_hit(b->alpha_v, h) : au;
    return spc_microfacet_make(b->distribution, au, av, b->sample_visible);
}

double spc_microfacet_d(const spc_microfacet *md, spc_vec3 m)
{
    if (m.z <= 0.0)
        return 0.0;
    double au = md->alpha_u, av = md->alpha_v;
    double sx = m.x / au, sy = m.y / av; /* slope terms times cos */
    double z2 = m.z * m.z;
    switch (md->type) {
    case SPC_MICROFACET_BECKMANN: {
        double e = (sx * sx + sy * sy) / z2;
        return exp(-e) / (SPC_PI * au * av * z2 * z2);
    }
    case SPC_MICROFACET_GGX: {
        double k = sx * sx + sy * sy + z2;
        return 1.0 / (SPC_PI * au * av * k * k);
    }
    }
    return 0.0;
}

double spc_microfacet_lambda(const spc_microfacet *md, spc_vec3 w)
{
    double z2 = w.z * w.z;
    if (z2 <= 0.0)
        return SPC_INF;
    /* alpha(phi)^2 tan^2(theta) */
    double a2t2 = (w.x * w.x * md->alpha_u * md->alpha_u + w.y * w.y * md->alpha_v * md->alpha_v) / z2;
    if (a2t2 <= 0.0)
        return 0.0;
    switch (md->type) {
    case SPC_MICROFACET_BECKMANN: {
        if (a2t2 <= BECKMANN_LAMBDA_A2T2_NEGLIGIBLE)
            return 0.0;
        double a = 1.0 / sqrt(a2t2);
        /* (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt(pi)), with erfc to keep precision for large a */
        return 0.5 * (exp(-a * a) / (a * sqrt(SPC_PI)) - erfc(a));
    }
    case SPC_MICROFACET_GGX:
        /* (sqrt(1 + x) - 1)/2 written as x / (2 (sqrt(1 + x) + 1)) to avoid cancellation */
        return a2t2 / (2.0 * (sqrt(1.0 + a2t2) + 1.0));
    }
    return 0.0;
}

double spc_microfacet_g1(const spc_microfacet *md, spc_vec3 w, spc_vec3 m)
{
    if (spc_dot(w, m) * w.z <= 0.0)
        return 0.0;
    return 1.0 / (1.0 + spc_microfacet_lambda(md, w));
}

double spc_microfacet_g(const spc_microfacet *md, spc_vec3 wo, spc_vec3 wi, spc_vec3 m)
{
    return spc_microfacet_g1(md, wo, m) * spc_microfacet_g1(md, wi, m);
}

/* GGX visible normal in the hemisphere configuration (Heitz 2018, listing 1). */
static spc_vec3 sample_visible_ggx(double au, double av, spc_vec3 w, spc_vec2 u)
{
    spc_vec3 vh = spc_normalize(spc_v3(au * w.x, av * w.y, w.z));
    double len2 = vh.x * vh.x + vh.y * vh.y;
    spc_vec3 t1 = len2 > 0.0 ? spc_scale(spc_v3(-vh.y, vh.x, 0.0), 1.0 / sqrt(len2)) : spc_v3(1.0, 0.0, 0.0);
    spc_vec3 t2 = spc_cross(vh, t1);
    double r = sqrt(u.x), sp, cp;
    spc_sincos_2pi(u.y, &sp, &cp);
    double p1 = r * cp, p2 = r * sp;
    double s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(spc_max(0.0, 1.0 - p1 * p1)) + s * p2;
    spc_vec3 nh = spc_add(spc_add(spc_scale(t1, p1), spc_scale(t2, p2)),
                          spc_scale(vh, spc_safe_sqrt(1.0 - p1 * p1 - p2 * p2)));
    return spc_normalize(spc_v3(au * nh.x, av * nh.y, spc_max(0.0, nh.z)));
}

/* Unnormalized CDF of the Beckmann visible x-slope for alpha = 1 and tan(theta) = tan_t. */
static double beckmann_slope_cdf(double x, double tan_t)
{
    return 0.5 * sqrt(SPC_PI) * erfc(-x) + 0.5 * tan_t * exp(-x * x);
}

/* The visible x-slope for alpha = 1 and incidence angle theta (tan_t, cot_t): the root of
 * F(x) = F(lo) + u (F(hi) - F(lo)) from the guess x, by Halley's method safeguarded with
 * bisection. One erfc and one exp give F and, with the density F' = (1 - x tan_t) exp(-x^2), its
 * first three derivatives. A Halley step ends the search when its error estimate K |step|^3,
 * K = |F'''/(6 F') - F''^2/(4 F'^2)|, is below 1e-15 (1 + |x|); so does a Newton step below
 * 1e-14 (1 + |x|) (the test that also ends the search near cot_t, where F' vanishes and Halley's
 * estimate does not hold). */
static double invert_beckmann_slope_cdf(double u, double tan_t, double cot_t, double x)
{
    double lo = -BECKMANN_SLOPE_LIMIT, hi = spc_min(cot_t, BECKMANN_SLOPE_LIMIT);
    double f_lo = beckmann_slope_cdf(lo, tan_t);
    double f_hi = hi >= SPC_BECKMANN_SLOPE_CDF_FLAT && tan_t <= 1.0 / SPC_BECKMANN_SLOPE_CDF_FLAT
                      ? sqrt(SPC_PI)
                      : beckmann_slope_cdf(hi, tan_t);
    double target = f_lo + u * (f_hi - f_lo);
    x = spc_clamp(x, lo, hi);
    if (!(x > lo && x < hi))
        x = 0.5 * (lo + hi);
    for (int it = 0; it < BECKMANN_MAX_ITERATIONS; ++it) {
        /* the CDF and its derivatives share exp(-x^2): beckmann_slope_cdf written out */
        double e = exp(-x * x);
        double F = (0.5 * sqrt(SPC_PI) * erfc(-x) + 0.5 * tan_t * e) - target;
        if (F == 0.0)
            return x;
        if (F > 0.0)
            hi = x;
        else
            lo = x;
        double a = 1.0 - x * tan_t;
        double d1 = a * e; /* F' */
        if (!(d1 > 0.0)) {
            x = 0.5 * (lo + hi);
            continue;
        }
        double d2 = (-tan_t - 2.0 * x * a) * e; /* F'' */
        double newton = F / d1;
        double den = 1.0 - 0.5 * newton * d2 / d1;
        bool halley = den > 0.5; /* else the Newton step */
        double next = x - (halley ? newton / den : newton);
        double scale = 1.0 + fabs(x);
        if (fabs(newton) <= 1e-14 * scale)
            return next;
        if (next > lo && next < hi) {
            double d3 = (-2.0 + 6.0 * x * tan_t + 4.0 * x * x - 4.0 * x * x * x * tan_t) * e; /* F''' */
            double r = d2 / d1, step = fabs(next - x);
            double K = fabs(d3 / (6.0 * d1) - 0.25 * r * r);
            if (halley && (1.0 + K) * step * step * step <= 1e-15 * scale)
                return next;
        } else {
            next = 0.5 * (lo + hi);
        }
        if (hi - lo <= 1e-15 * scale)
            return next;
        x = next;
    }
    return x;
}

/* The table of guesses for invert_beckmann_slope_cdf: x at g = i / BECKMANN_TABLE_G, where
 * g = tan_t / (1 + tan_t) (0 at normal incidence, 1 at grazing), and u = j / BECKMANN_TABLE_U,
 * interpolated bilinearly. From it Halley's method needs about 1.9 evaluations of the CDF on
 * average (a replica in Python over 20000 draws at 0.05 to 1.55 rad; from the Gaussian guess
 * erfinv(2u - 1) Newton's method needed 4.7 to 7.8, and erfinv costs one or two more). The two end
 * cells of u, where x runs off into the tails, keep the Gaussian guess. 65 x 257 floats (67 KiB),
 * built on first use. The guess changes where the search starts, not what it converges to. */
#define BECKMANN_TABLE_G 64
#define BECKMANN_TABLE_U 256
static float beckmann_table[BECKMANN_TABLE_G + 1][BECKMANN_TABLE_U + 1];
static pthread_once_t beckmann_table_once = PTHREAD_ONCE_INIT;

static void beckmann_table_build(void)
{
    for (int i = 0; i <= BECKMANN_TABLE_G; ++i) {
        /* the grazing row just below g = 1: tan_t = 2^30 */
        double g = i < BECKMANN_TABLE_G ? (double)i / BECKMANN_TABLE_G : 1.0 - 0x1p-30;
        double tan_t = g / (1.0 - g), cot_t = g > 0.0 ? (1.0 - g) / g : SPC_INF;
        double x = -BECKMANN_SLOPE_LIMIT;
        beckmann_table[i][0] = (float)x;
        for (int j = 1; j <= BECKMANN_TABLE_U; ++j) {
            double u = (double)j / BECKMANN_TABLE_U;
            x = invert_beckmann_slope_cdf(u, tan_t, cot_t, j == 1 ? spc_erfinv(2.0 * u - 1.0) : x);
            beckmann_table[i][j] = (float)x;
        }
    }
}

static double sample_beckmann_slope_x(double u, double tan_t, double cot_t)
{
    double su = u * BECKMANN_TABLE_U;
    int j = (int)su;
    double guess;
    if (!(j >= 1 && j < BECKMANN_TABLE_U - 1)) {
        guess = spc_erfinv(2.0 * u - 1.0);
    } else {
        pthread_once(&beckmann_table_once, beckmann_table_build);
        double sg = tan_t / (1.0 + tan_t) * BECKMANN_TABLE_G;
        int i = sg < BECKMANN_TABLE_G - 1 ? (int)sg : BECKMANN_TABLE_G - 1;
        double fg = sg - i, fu = su - j;
        const float *r0 = beckmann_table[i], *r1 = beckmann_table[i + 1];
        double x0 = r0[j] + fu * (r0[j + 1] - r0[j]), x1 = r1[j] + fu * (r1[j + 1] - r1[j]);
        guess = x0 + fg * (x1 - x0);
    }
    return invert_beckmann_slope_cdf(u, tan_t, cot_t, guess);
}

/* Beckmann visible normal (Heitz and d'Eon 2014, sec. 4 and appendix A). */
static spc_vec3 sample_visible_beckmann(double au, double av, spc_vec3 w, spc_vec2 u)
{
    spc_vec3 ws = spc_normalize(spc_v3(au * w.x, av * w.y, w.z));
    double sin_t = sqrt(ws.x * ws.x + ws.y * ws.y);
    double sx, sy;
    /* the y-slope is an independent Gaussian with variance 1/2; clamp u away from 0 and 1 so that
     * erfinv stays finite */
    double uy = spc_clamp(u.y, 1e-12, 1.0 - 1e-12);
    sy = spc_erfinv(2.0 * uy - 1.0);
    if (sin_t < 1e-12) {
        sx = spc_erfinv(2.0 * spc_clamp(u.x, 1e-12, 1.0 - 1e-12) - 1.0);
    } else {
        double tan_t = sin_t / ws.z, cot_t = ws.z / sin_t;
        double x = sample_beckmann_slope_x(u.x, tan_t, cot_t);
        double c = ws.x / sin_t, s = ws.y / sin_t;
        sx = c * x - s * sy;
        sy = s * x + c * sy;
    }
    return spc_normalize(spc_v3(-sx * au, -sy * av, 1.0));
}

spc_vec3 spc_microfacet_sample(const spc_microfacet *md, spc_vec3 w, spc_vec2 u, double *pdf)
{
    double au = md->alpha_u, av = md->alpha_v;
    spc_vec3 m;
    if (md->sample_visible) {
        if (w.z <= 0.0) {
            *pdf = 0.0;
            return spc_v3(0.0, 0.0, 1.0);
        }
        m = md->type == SPC_MICROFACET_GGX ? sample_visible_ggx(au, av, w, u) : sample_visible_beckmann(au, av, w, u);
    } else {
        double r2 = md->type == SPC_MICROFACET_GGX ? u.x / (1.0 - u.x) : -log(1.0 - u.x);
        double r = spc_safe_sqrt(r2), sp, cp;
        spc_sincos_2pi(u.y, &sp, &cp);
        m = spc_normalize(spc_v3(-au * r * cp, -av * r * sp, 1.0));
    }
    *pdf = spc_microfacet_pdf(md, w, m);
    return m;
}

double spc_microfacet_pdf(const spc_microfacet *md, spc_vec3 w, spc_vec3 m)
{
    double d = spc_microfacet_d(md, m);
    if (d == 0.0)
        return 0.0;
    if (!md->sample_visible)
        return d * m.z;
    if (w.z < 0.0)
        w = spc_neg(w);
    if (w.z == 0.0)
        return 0.0;
    return spc_microfacet_pdf_given(md, w, m, d, spc_microfacet_g1(md, w, m));
}

double spc_microfacet_pdf_given(const spc_microfacet *md, spc_vec3 w, spc_vec3 m, double d, double g1w)
{
    if (!md->sample_visible)
        return d * m.z;
    return g1w * spc_max(0.0, spc_dot(w, m)) * d / w.z;
}
