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
 *   Halley's method safeguarded with bisection, started from a tabulated guess (the search is
 *   microfacet_many.c's, for one sample or many at once); the y-slope is Gaussian, erfinv(2u - 1),
 *   the root of the same search at normal incidence.
 * - sample_visible false: slopes drawn from the (stretched) isotropic slope distribution, giving
 *   the density D(m) m.z.
 */
#include "bsdf/microfacet.h"

#include <pthread.h>

#include "core/warp.h"

/* Slopes beyond this are irrelevant for the Beckmann slope CDF: exp(-10^2) is below double
 * precision relative to the distribution's mass. */
#define BECKMANN_SLOPE_LIMIT 10.0
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

/* The visible x-slope for alpha = 1 and incidence angle theta (tan_t, cot_t), searched from the
 * guess x (microfacet_many.c). */
static double invert_beckmann_slope_cdf(double u, double tan_t, double cot_t, double x)
{
    spc_beckmann_slope_x_many(1, &u, &tan_t, &cot_t, &x);
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

/* The table built, once: the callers of the guesses below call it once per sample or per batch, so
 * that the guesses themselves make no call */
static void beckmann_table_ready(void) { pthread_once(&beckmann_table_once, beckmann_table_build); }

/* u's cell in the table: whether it is one of the interior cells (*table), its index and fraction */
static bool beckmann_table_cell(double u, int *j, double *fu)
{
    double su = u * BECKMANN_TABLE_U;
    *j = (int)su;
    *fu = su - *j;
    return *j >= 1 && *j < BECKMANN_TABLE_U - 1;
}

/* The guess for the x-slope's search: the table's, except in its two end cells of u, where x runs
 * off into the tails (*table false there: the Gaussian's erfinv(2u - 1)). The table must be built
 * (beckmann_table_ready). */
static double beckmann_slope_guess(double u, double tan_t, bool *table)
{
    int j;
    double fu;
    *table = beckmann_table_cell(u, &j, &fu);
    if (!*table)
        return spc_erfinv(2.0 * u - 1.0);
    double sg = tan_t / (1.0 + tan_t) * BECKMANN_TABLE_G;
    int i = sg < BECKMANN_TABLE_G - 1 ? (int)sg : BECKMANN_TABLE_G - 1;
    double fg = sg - i;
    const float *r0 = beckmann_table[i], *r1 = beckmann_table[i + 1];
    double x0 = r0[j] + fu * (r0[j + 1] - r0[j]), x1 = r1[j] + fu * (r1[j + 1] - r1[j]);
    return x0 + fg * (x1 - x0);
}

/* beckmann_slope_guess at normal incidence (tan_t = 0), the y-slope's: row 0 alone. The same value:
 * there g = 0, so i = 0 and fg = 0, and x0 + 0 * (x1 - x0) is x0 (x1 - x0 is finite, and x0 is not
 * -0: the row increases, so r0[j] + fu * (r0[j + 1] - r0[j]) adds a product of sign +). */
static double beckmann_slope_guess_normal(double u, bool *table)
{
    int j;
    double fu;
    *table = beckmann_table_cell(u, &j, &fu);
    if (!*table)
        return spc_erfinv(2.0 * u - 1.0);
    const float *r0 = beckmann_table[0];
    return r0[j] + fu * (r0[j + 1] - r0[j]);
}

/* Beckmann visible normal (Heitz and d'Eon 2014, sec. 4 and appendix A) in two halves around the
 * slopes' searches, so that many samples can share one search (spc_microfacet_sample_many): the
 * stretched direction and the searches' inputs; then the slopes rotated and unstretched. The y-slope
 * is an independent Gaussian with variance 1/2, erfinv(2 u.y - 1): the root of the same search with
 * tan_t = 0 (sqrt(pi)/2 erfc(-y) = u.y sqrt(pi)), started from the table's guess at normal incidence;
 * in the table's two end cells of u.y, and for both slopes at normal incidence, erfinv itself (u
 * clamped away from 0 and 1 so that it stays finite). */
typedef struct beckmann_visible {
    spc_vec3 ws;
    double sin_t;
    bool normal;            /* normal incidence: both slopes Gaussian, x and y below; no search */
    bool x_table, y_search; /* x's search starts from the table's guess (else erfinv's); y has one */
    double tan_t, cot_t;    /* the x-slope's search */
    double x, y;            /* the searches' guesses, or the slopes where there is no search */
} beckmann_visible;

static void beckmann_visible_begin(double au, double av, spc_vec3 w, spc_vec2 u, beckmann_visible *b)
{
    b->ws = spc_normalize(spc_v3(au * w.x, av * w.y, w.z));
    b->sin_t = sqrt(b->ws.x * b->ws.x + b->ws.y * b->ws.y);
    b->normal = b->sin_t < 1e-12;
    b->x_table = b->y_search = false;
    if (!b->normal)
        b->y = beckmann_slope_guess_normal(u.y, &b->y_search);
    if (!b->y_search)
        b->y = spc_erfinv(2.0 * spc_clamp(u.y, 1e-12, 1.0 - 1e-12) - 1.0);
    if (b->normal) {
        b->x = spc_erfinv(2.0 * spc_clamp(u.x, 1e-12, 1.0 - 1e-12) - 1.0);
    } else {
        b->tan_t = b->sin_t / b->ws.z;
        b->cot_t = b->ws.z / b->sin_t;
        b->x = beckmann_slope_guess(u.x, b->tan_t, &b->x_table);
    }
}

/* m from the slopes x and y (the searches' answers, or b->x and b->y where there is none) */
static spc_vec3 beckmann_visible_end(double au, double av, const beckmann_visible *b, double x, double y)
{
    double sx = x, sy = y;
    if (!b->normal) {
        double c = b->ws.x / b->sin_t, s = b->ws.y / b->sin_t;
        sx = c * x - s * y;
        sy = s * x + c * y;
    }
    return spc_normalize(spc_v3(-sx * au, -sy * av, 1.0));
}

static spc_vec3 sample_visible_beckmann(double au, double av, spc_vec3 w, spc_vec2 u)
{
    beckmann_visible b;
    beckmann_table_ready();
    beckmann_visible_begin(au, av, w, u, &b);
    double x = b.normal ? b.x : invert_beckmann_slope_cdf(u.x, b.tan_t, b.cot_t, b.x);
    double y = b.y_search ? invert_beckmann_slope_cdf(u.y, 0.0, SPC_INF, b.y) : b.y;
    return beckmann_visible_end(au, av, &b, x, y);
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

/* spc_microfacet_sample_many's lanes per pass */
#define MICROFACET_MANY_BATCH 16

void spc_microfacet_sample_many(int n, const spc_microfacet *md, const spc_vec3 *w, const spc_vec2 *u, spc_vec3 *m,
                                double *pdf)
{
    enum { B = MICROFACET_MANY_BATCH };
    beckmann_visible b[B];
    int lane[B];
    /* the searches of a pass: x-slopes in [0, nx), y-slopes in [B, B + ny) */
    double su[2 * B], tan_t[2 * B], cot_t[2 * B], s[2 * B];
    int xk[B], yk[B];
    beckmann_table_ready();
    for (int i0 = 0; i0 < n; i0 += B) {
        int nb = 0, nx = 0, ny = 0;
        for (int i = i0; i < n && i < i0 + B; ++i) {
            if (!(md[i].sample_visible && md[i].type == SPC_MICROFACET_BECKMANN && w[i].z > 0.0)) {
                m[i] = spc_microfacet_sample(&md[i], w[i], u[i], &pdf[i]);
                continue;
            }
            beckmann_visible *bi = &b[nb];
            beckmann_visible_begin(md[i].alpha_u, md[i].alpha_v, w[i], u[i], bi);
            /* the searches from the table's guesses share the pass; an x-slope's from the tails' end
             * cells (a few in a thousand, and the slowest) goes alone, with the same answer */
            xk[nb] = yk[nb] = -1;
            if (!bi->normal && !bi->x_table)
                bi->x = invert_beckmann_slope_cdf(u[i].x, bi->tan_t, bi->cot_t, bi->x);
            else if (!bi->normal) {
                su[nx] = u[i].x;
                tan_t[nx] = bi->tan_t;
                cot_t[nx] = bi->cot_t;
                s[nx] = bi->x;
                xk[nb] = nx++;
            }
            if (bi->y_search) {
                su[B + ny] = u[i].y;
                tan_t[B + ny] = 0.0;
                cot_t[B + ny] = SPC_INF;
                s[B + ny] = bi->y;
                yk[nb] = B + ny++;
            }
            lane[nb++] = i;
        }
        /* one call for both kinds: move the y-slopes next to the x-slopes */
        for (int k = 0; k < ny; ++k) {
            su[nx + k] = su[B + k];
            tan_t[nx + k] = tan_t[B + k];
            cot_t[nx + k] = cot_t[B + k];
            s[nx + k] = s[B + k];
        }
        spc_beckmann_slope_x_many(nx + ny, su, tan_t, cot_t, s);
        for (int k = 0; k < nb; ++k) {
            int i = lane[k];
            double x = xk[k] >= 0 ? s[xk[k]] : b[k].x, y = yk[k] >= 0 ? s[nx + yk[k] - B] : b[k].y;
            m[i] = beckmann_visible_end(md[i].alpha_u, md[i].alpha_v, &b[k], x, y);
            pdf[i] = spc_microfacet_pdf(&md[i], w[i], m[i]);
        }
    }
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
