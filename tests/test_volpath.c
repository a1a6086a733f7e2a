/*
 * tests/test_volpath.c: participating media (src/medium/) and the volumetric path tracer
 * (src/integrator/volpath.c).
 *
 * - Phase functions: normalization and mean cosine g by quadrature, sample pdf == eval, and
 *   chi-square of isotropic and Henyey-Greenstein sampling (several g) against their pdfs (Sidak
 *   over the tests of this program).
 * - Free flight: transmittance closed forms; the spectral distance sampler's weights have the
 *   exact expectations sigma_s/sigma_t (1 - exp(-sigma_t t_max)) (interaction) and exp(-sigma_t
 *   t_max) (crossing) per channel, for a throughput that favours one channel, a channel with
 *   sigma_t = 0 and an unbounded segment; the mixture density integrates to 1.
 * - Loader: media nested and referenced, sigma_a/sigma_s, albedo/sigma_t/scale, 0.x names, the
 *   camera's medium, <integrator type="volpath">, and file:line errors for bad values.
 * - Renders against closed forms:
 *   * an absorbing slab between null (index-matched) boundaries seen head-on in front of an
 *     emitter: L = Le exp(-sigma_a d) per channel;
 *   * the same slab bounded by glass (dielectric, eta 1.5): L = Le (1 - F)^2 T / (1 - F^2 T^2),
 *     the interreflections inside included;
 *   * a diffuse plane under an absorbing null slab lit by a uniform environment: NEE's shadow
 *     rays carry the transmittance, BSDF sampling crosses by free flight, and MIS joins them:
 *     L = 2 a Le E_3(tau) with E_3(tau) = int_0^1 mu exp(-tau/mu) dmu;
 *   * radiance conservation: inside a sphere whose inner surface emits Le and reflects nothing,
 *     filled with a medium of albedo 1 (any sigma_t, any phase function), L = Le everywhere (the
 *     equilibrium L = Le solves the transfer equation with this boundary condition);
 *   * the same behind glass: a dielectric sphere filled with an albedo-1 medium under a uniform
 *     environment Le reads Le at every pixel (radiance over n^2 is conserved).
 * - volpath == path on a vacuum scene (box, glass and diffuse spheres), and volpath with == without
 *   an invisible (null) sphere in the light's beam: per-pixel z-tests (Sidak) and image means.
 * - A glass shape filled with a scattering medium, lit through its surface by a small area light:
 *   volpath with and without the specular connection agree per pixel (z-test, Sidak, >= 99% of
 *   pixels) and in the mean, and the connection has the lower variance per sample: a glass slab
 *   with the angular solver, a glass icosphere with the conic solver (when registered). (The
 *   angular solver is not used on the icosphere or an analytic sphere: from deep inside, its
 *   attempts mostly end in total internal reflection and the capped count of attempts is biased
 *   low by 5-8% without the straight-line attempt.)
 * - The connection takes the user's specular NEE options: on a glass sphere, trials=1 changes the
 *   image but not its mean (within 4 standard errors); seed=light, chain=1, nomis and receivers=1
 *   each change the image.
 * - first=P at medium receivers: on a glass sphere in a fog box, first=0.1 changes the image and agrees
 *   with specular NEE off per pixel (z-test, Sidak) and in the mean; so does first=0.1,later=0.1
 *   with tightshare (the roulette's probability from the ball's own sphere and its shadow).
 */
/* ctest-labels: stat */
/* ctest-timeout: 600 */
#include <string.h>

#include "chi2.h"
#include "harness.h"
#include "io/mitsuba_xml.h"
#include "manifold/snee_plan.h"
#include "manifold/specular_nee.h"
#include "medium/medium.h"
#include "render_util.h"

#define NCHI2 6 /* chi-square tests in this program (Sidak) */

/* ---- helpers ---- */

static spc_film *render_nee(const spc_scene *sc, const char *integrator, const char *snee, int spp, uint64_t seed)
{
    return tu_render_nee(sc, integrator, snee, spp, 2, seed, NULL);
}

/* Image mean of each channel within k standard errors of expected[c]; the error is small. */
static void check_mean_rgb(const spc_film *f, const double expected[3], double k, double max_rel_se, const char *what)
{
    for (int c = 0; c < 3; ++c) {
        double m, se;
        tu_image_mean(f, c, &m, &se);
        printf("  %s: channel %d mean %.6f expected %.6f (se %.2g)\n", what, c, m, expected[c], se);
        CHECK_MSG(fabs(m - expected[c]) <= k * se + 1e-6 * expected[c], "%s channel %d: mean %.6f expected %.6f (se %.2g)",
                  what, c, m, expected[c], se);
        CHECK_MSG(se > 0.0 && se < max_rel_se * expected[c], "%s channel %d: standard error %.3g is not small", what, c,
                  se);
    }
}

/* Fraction of pixels passing the Sidak-corrected z-test of a against b (spc_image_diff). */
static double ztest(const spc_film *a, const spc_film *b, const char *what)
{
    spc_image_rgb ia = {a->width, a->height, a->rgb, a->var};
    spc_image_rgb ib = {b->width, b->height, b->rgb, b->var};
    spc_diff_result r;
    spc_error err;
    if (spc_image_diff(&ia, &ib, &r, &err) != SPC_OK || !r.has_ztest)
        return 0.0;
    printf("  %s: z-test pass %.4f, means (%.5f %.5f %.5f) vs (%.5f %.5f %.5f)\n", what, r.ztest_pass_fraction,
           r.mean_a[0], r.mean_a[1], r.mean_a[2], r.mean_b[0], r.mean_b[1], r.mean_b[2]);
    return r.ztest_pass_fraction;
}

static void check_means_agree(const spc_film *a, const spc_film *b, double k, const char *what)
{
    for (int c = 0; c < 3; ++c) {
        double ma, sa, mb, sb;
        tu_image_mean(a, c, &ma, &sa);
        tu_image_mean(b, c, &mb, &sb);
        double se = sqrt(sa * sa + sb * sb);
        CHECK_MSG(fabs(ma - mb) <= k * se, "%s channel %d: means %.6f vs %.6f (se %.2g)", what, c, ma, mb, se);
    }
}

static spc_medium *new_medium(spc_scene *sc, spc_rgb sigma_a, spc_rgb sigma_s, spc_phase_type pt, double g)
{
    spc_medium *m = spc_scene_new_medium(sc);
    if (!m || !spc_medium_init_homogeneous(m, sigma_a, sigma_s))
        return NULL;
    m->phase.type = pt;
    m->phase.g = g;
    return m;
}

static spc_bsdf *new_null(spc_scene *sc)
{
    spc_bsdf *b = spc_scene_new_bsdf(sc);
    b->type = SPC_BSDF_NULL;
    return b;
}

static double rgb_c(spc_rgb v, int c) { return c == 0 ? v.r : (c == 1 ? v.g : v.b); }

/* ---- phase functions ---- */

static double quad_hg(double g, int moment)
{
    /* 2 pi int_{-1}^{1} mu^moment p(mu) dmu by composite Simpson on a fine grid */
    spc_phase p = {SPC_PHASE_HG, g};
    const int n = 200000;
    double s = 0.0;
    for (int i = 0; i <= n; ++i) {
        double mu = -1.0 + 2.0 * i / n;
        spc_vec3 wo = spc_v3(0, 0, -1); /* travel direction +z */
        spc_vec3 wi = spc_v3(spc_safe_sqrt(1.0 - mu * mu), 0.0, mu);
        double f = spc_phase_eval(&p, wo, wi) * (moment ? mu : 1.0);
        s += f * (i == 0 || i == n ? 1.0 : (i % 2 ? 4.0 : 2.0));
    }
    return 2.0 * SPC_PI * s * (2.0 / n) / 3.0;
}

TEST(phase_closed_forms)
{
    spc_phase iso = {SPC_PHASE_ISOTROPIC, 0.0};
    CHECK_NEAR(spc_phase_eval(&iso, spc_v3(0, 0, 1), spc_v3(1, 0, 0)), 1.0 / (4.0 * SPC_PI), 1e-15);
    const double gs[5] = {-0.9, -0.3, 0.0, 0.5, 0.8};
    for (int i = 0; i < 5; ++i) {
        CHECK_NEAR(quad_hg(gs[i], 0), 1.0, 1e-6);
        CHECK_NEAR(quad_hg(gs[i], 1), gs[i], 1e-6);
    }
    /* forward scattering for g > 0: the travel direction is -wo */
    spc_phase hg = {SPC_PHASE_HG, 0.7};
    spc_vec3 wo = spc_normalize(spc_v3(0.3, -0.2, 0.9));
    double fwd = spc_phase_eval(&hg, wo, spc_neg(wo)), back = spc_phase_eval(&hg, wo, wo);
    CHECK_NEAR(fwd, (1 - 0.49) / (4 * SPC_PI * pow(1 - 0.7, 3)), 1e-12);
    CHECK(fwd > 100.0 * back);
    /* reciprocity and sample pdf == eval */
    spc_rng rng;
    spc_rng_seed(&rng, 11, 1);
    for (int k = 0; k < 1000; ++k) {
        spc_vec3 a = spc_warp_uniform_sphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)));
        spc_vec3 b = spc_warp_uniform_sphere(spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)));
        CHECK_NEAR(spc_phase_eval(&hg, a, b), spc_phase_eval(&hg, b, a), 1e-12);
        spc_vec3 wi;
        double pdf;
        CHECK(spc_phase_sample(&hg, a, spc_v2(spc_rng_next(&rng), spc_rng_next(&rng)), &wi, &pdf));
        CHECK_NEAR(spc_length(wi), 1.0, 1e-12);
        CHECK_REL(pdf, spc_phase_pdf(&hg, a, wi), 1e-12, 0.0);
    }
}

typedef struct phase_case {
    spc_phase p;
    spc_vec3 wo;
} phase_case;

static bool phase_chi2_sample(void *user, spc_rng *rng, spc_vec3 *dir)
{
    phase_case *c = user;
    double pdf;
    return spc_phase_sample(&c->p, c->wo, spc_v2(spc_rng_next(rng), spc_rng_next(rng)), dir, &pdf);
}

static double phase_chi2_pdf(void *user, spc_vec3 dir)
{
    phase_case *c = user;
    return spc_phase_pdf(&c->p, c->wo, dir);
}

TEST(phase_chi2)
{
    const struct {
        spc_phase_type t;
        double g;
        const char *name;
    } cases[NCHI2] = {{SPC_PHASE_ISOTROPIC, 0.0, "isotropic"}, {SPC_PHASE_HG, 0.7, "hg g=0.7"},
                      {SPC_PHASE_HG, -0.5, "hg g=-0.5"},         {SPC_PHASE_HG, 0.2, "hg g=0.2"},
                      {SPC_PHASE_HG, 0.9, "hg g=0.9"},           {SPC_PHASE_HG, 5e-5, "hg g=5e-5"}};
    for (int i = 0; i < NCHI2; ++i) {
        phase_case c = {{cases[i].t, cases[i].g}, spc_normalize(spc_v3(0.2, 0.5, -0.8))};
        /* the grid's pole on the travel direction, where HG peaks */
        spc_frame f = spc_frame_from_n(spc_neg(c.wo));
        double p = chi2_direction_test(cases[i].name, phase_chi2_sample, phase_chi2_pdf, &c, &f, 1000000,
                                       (uint64_t)(100 + i), true);
        CHECK_MSG(chi2_accept(p, NCHI2), "%s: p-value %g", cases[i].name, p);
    }
}

/* ---- free flight ---- */

TEST(transmittance_closed_forms)
{
    spc_medium m;
    CHECK(spc_medium_init_homogeneous(&m, spc_rgb3(0.1, 0.0, 2.0), spc_rgb3(0.4, 0.0, 1.0)));
    CHECK(!spc_medium_is_vacuum(&m));
    spc_rgb T = spc_medium_transmittance(&m, 2.0);
    CHECK_NEAR(T.r, exp(-1.0), 1e-15);
    CHECK_NEAR(T.g, 1.0, 0.0);
    CHECK_NEAR(T.b, exp(-6.0), 1e-15);
    T = spc_medium_transmittance(&m, INFINITY);
    CHECK(T.r == 0.0 && T.g == 1.0 && T.b == 0.0);
    CHECK(!spc_medium_init_homogeneous(&m, spc_rgb3(-0.1, 0, 0), spc_rgb1(0.0)));
    CHECK(!spc_medium_init_homogeneous(&m, spc_rgb1(0.0), spc_rgb3(0, NAN, 0)));
    CHECK(spc_medium_init_homogeneous(&m, spc_rgb1(0.0), spc_rgb1(0.0)) && spc_medium_is_vacuum(&m));
}

/* Monte Carlo expectation of the distance sampler's weights against the closed forms. */
static void free_flight_case(spc_rgb sa, spc_rgb ss, double t_max, spc_rgb beta, uint64_t seed)
{
    spc_medium m;
    CHECK(spc_medium_init_homogeneous(&m, sa, ss));
    const int n = 400000;
    double sum_s[3] = {0}, sq_s[3] = {0}, sum_p[3] = {0}, sq_p[3] = {0};
    spc_rng rng;
    spc_rng_seed(&rng, seed, 3);
    int fails = 0;
    for (int i = 0; i < n; ++i) {
        spc_medium_event ev;
        if (!spc_medium_sample_distance(&m, t_max, beta, spc_rng_next(&rng), spc_rng_next(&rng), &ev)) {
            ++fails;
            continue;
        }
        CHECK_REL(ev.pdf, spc_medium_pdf_distance(&m, beta, ev.t, t_max, ev.scattered), 1e-12, 0.0);
        for (int c = 0; c < 3; ++c) {
            double w = rgb_c(ev.weight, c);
            if (ev.scattered) {
                sum_s[c] += w;
                sq_s[c] += w * w;
            } else {
                sum_p[c] += w;
                sq_p[c] += w * w;
            }
        }
    }
    CHECK(fails == 0);
    for (int c = 0; c < 3; ++c) {
        double st = rgb_c(sa, c) + rgb_c(ss, c);
        double Tmax = st > 0.0 ? exp(-st * t_max) : 1.0;
        double want_s = st > 0.0 ? rgb_c(ss, c) / st * (1.0 - Tmax) : 0.0;
        double want_p = Tmax;
        double ms = sum_s[c] / n, mp = sum_p[c] / n;
        double ses = sqrt(fmax(sq_s[c] / n - ms * ms, 0.0) / n), sep = sqrt(fmax(sq_p[c] / n - mp * mp, 0.0) / n);
        CHECK_MSG(fabs(ms - want_s) <= 4.5 * ses + 1e-12, "channel %d interaction: %.6f vs %.6f (se %.2g)", c, ms, want_s,
                  ses);
        CHECK_MSG(fabs(mp - want_p) <= 4.5 * sep + 1e-12, "channel %d crossing: %.6f vs %.6f (se %.2g)", c, mp, want_p,
                  sep);
    }
    /* the mixture density of an interaction integrates with P(crossing) to 1 */
    if (isfinite(t_max)) {
        const int k = 20000;
        double s = 0.0;
        for (int i = 0; i <= k; ++i) {
            double t = t_max * i / k * (1.0 - 1e-12);
            s += spc_medium_pdf_distance(&m, beta, t, t_max, true) * (i == 0 || i == k ? 1.0 : (i % 2 ? 4.0 : 2.0));
        }
        s *= t_max / k / 3.0;
        CHECK_NEAR(s + spc_medium_pdf_distance(&m, beta, t_max, t_max, false), 1.0, 1e-7);
    }
}

TEST(free_flight_expectations)
{
    /* a throughput that favours red, distinct sigma_t per channel */
    free_flight_case(spc_rgb3(0.1, 0.5, 0.3), spc_rgb3(0.4, 0.5, 2.7), 1.3, spc_rgb3(1.0, 0.4, 0.1), 21);
    /* a channel with sigma_t = 0: it always crosses */
    free_flight_case(spc_rgb3(0.0, 0.2, 1.0), spc_rgb3(0.0, 0.8, 1.0), 0.7, spc_rgb1(1.0), 22);
    /* an unbounded segment: every channel with sigma_t > 0 interacts */
    free_flight_case(spc_rgb3(0.2, 0.2, 0.2), spc_rgb3(0.3, 1.0, 3.0), INFINITY, spc_rgb3(0.2, 1.0, 0.5), 23);
    /* black throughput: channels uniform, still unbiased */
    free_flight_case(spc_rgb3(0.5, 0.1, 0.0), spc_rgb3(0.5, 0.4, 4.0), 0.5, spc_rgb1(0.0), 24);
}

/* ---- loader ---- */

static spc_status load_xml(const char *xml, spc_scene **s, spc_error *e)
{
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/scenes", spc_test_source_dir());
    return spc_mitsuba_load_string(xml, strlen(xml), "test.xml", dir, NULL, 0, s, e);
}

static void expect_error(const char *xml, spc_status code, int line, const char *needle)
{
    spc_scene *s = NULL;
    spc_error e;
    memset(&e, 0, sizeof e);
    spc_status st = load_xml(xml, &s, &e);
    CHECK_MSG(st == code, "status %d, expected %d (%s)", (int)st, (int)code, e.msg);
    CHECK_MSG(e.line == line, "line %d, expected %d (%s)", e.line, line, e.msg);
    CHECK_MSG(strstr(e.msg, needle) != NULL, "message '%s' lacks '%s'", e.msg, needle);
    CHECK(s == NULL);
    spc_scene_destroy(s);
}

TEST(loader_media)
{
    const char *xml = "<scene version=\"3.0.0\">\n"
                      "  <integrator type=\"volpath\"/>\n"
                      "  <sensor type=\"perspective\"><ref id=\"fog\"/></sensor>\n"
                      "  <medium type=\"homogeneous\" id=\"fog\">\n"
                      "    <rgb name=\"albedo\" value=\"0.5, 1, 0\"/>\n"
                      "    <rgb name=\"sigma_t\" value=\"1, 2, 4\"/>\n"
                      "    <float name=\"scale\" value=\"0.5\"/>\n"
                      "    <phase type=\"hg\"><float name=\"g\" value=\"0.7\"/></phase>\n"
                      "  </medium>\n"
                      "  <shape type=\"sphere\">\n"
                      "    <bsdf type=\"dielectric\"/>\n"
                      "    <medium type=\"homogeneous\" name=\"interior\">\n"
                      "      <rgb name=\"sigma_a\" value=\"0.1, 0.2, 0.3\"/>\n"
                      "      <float name=\"sigma_s\" value=\"2\"/>\n"
                      "      <boolean name=\"sample_emitters\" value=\"false\"/>\n"
                      "    </medium>\n"
                      "    <ref name=\"exterior\" id=\"fog\"/>\n"
                      "  </shape>\n"
                      "  <shape type=\"sphere\"><point name=\"center\" x=\"3\" y=\"0\" z=\"0\"/>"
                      "<ref name=\"interior\" id=\"fog\"/></shape>\n"
                      "</scene>\n";
    spc_scene *s = NULL;
    spc_error e;
    spc_status st = load_xml(xml, &s, &e);
    CHECK_MSG(st == SPC_OK, "%s", e.msg);
    if (!s)
        return;
    CHECK(strcmp(s->integrator.type, "volpath") == 0);
    CHECK(s->nmedia == 2);
    CHECK(s->camera_medium >= 0 && s->camera_medium < s->nmedia);
    CHECK(s->nshapes == 2);
    if (s->nmedia == 2 && s->nshapes == 2 && s->camera_medium >= 0) {
        const spc_medium *fog = s->media[s->camera_medium];
        CHECK(strcmp(fog->id, "fog") == 0);
        CHECK_NEAR(fog->sigma_t.r, 0.5, 1e-12);
        CHECK_NEAR(fog->sigma_t.g, 1.0, 1e-12);
        CHECK_NEAR(fog->sigma_t.b, 2.0, 1e-12);
        CHECK_NEAR(fog->sigma_s.r, 0.25, 1e-12);
        CHECK_NEAR(fog->sigma_s.g, 1.0, 1e-12);
        CHECK_NEAR(fog->sigma_s.b, 0.0, 1e-12);
        CHECK(fog->phase.type == SPC_PHASE_HG && fabs(fog->phase.g - 0.7) < 1e-12);
        CHECK(fog->sample_emitters);
        const spc_shape *a = s->shapes[0], *b = s->shapes[1];
        CHECK(a->exterior_medium == s->camera_medium && b->interior_medium == s->camera_medium);
        CHECK(b->exterior_medium == -1);
        CHECK(a->interior_medium >= 0 && a->interior_medium != s->camera_medium);
        if (a->interior_medium >= 0) {
            const spc_medium *in = s->media[a->interior_medium];
            CHECK_NEAR(in->sigma_a.b, 0.3, 1e-12);
            CHECK_NEAR(in->sigma_s.g, 2.0, 1e-12);
            CHECK_NEAR(in->sigma_t.r, 2.1, 1e-12);
            CHECK(in->phase.type == SPC_PHASE_ISOTROPIC);
            CHECK(!in->sample_emitters);
        }
    }
    spc_scene_destroy(s);

    /* Mitsuba 0.x names (sigmaA, sigmaS) and a camera without a medium */
    s = NULL;
    st = load_xml("<scene version=\"0.6.0\">\n"
                  "  <shape type=\"sphere\"><medium type=\"homogeneous\" name=\"interior\">"
                  "<spectrum name=\"sigmaA\" value=\"0.5\"/><spectrum name=\"sigmaS\" value=\"1.5\"/>"
                  "<phase type=\"isotropic\"/></medium></shape>\n"
                  "</scene>\n",
                  &s, &e);
    CHECK_MSG(st == SPC_OK, "%s", e.msg);
    if (s) {
        CHECK(s->nmedia == 1 && s->camera_medium == -1);
        if (s->nmedia == 1)
            CHECK_NEAR(s->media[0]->sigma_t.g, 2.0, 1e-9);
    }
    spc_scene_destroy(s);

    const char *head = "<scene version=\"3.0.0\">\n";
    char buf[2048];
    snprintf(buf, sizeof buf,
             "%s  <medium type=\"homogeneous\">\n    <float name=\"sigma_a\" value=\"-1\"/>\n  </medium>\n</scene>\n",
             head);
    expect_error(buf, SPC_ERR_VALUE, 3, "sigma_a");
    snprintf(buf, sizeof buf, "%s  <medium type=\"homogeneous\">\n    <float name=\"albedo\" value=\"1.5\"/>\n  </medium>\n</scene>\n",
             head);
    expect_error(buf, SPC_ERR_VALUE, 3, "albedo");
    snprintf(buf, sizeof buf,
             "%s  <medium type=\"homogeneous\">\n    <float name=\"sigma_s\" value=\"1\"/>\n"
             "    <float name=\"sigma_t\" value=\"1\"/>\n  </medium>\n</scene>\n",
             head);
    expect_error(buf, SPC_ERR_VALUE, 4, "not both");
    snprintf(buf, sizeof buf,
             "%s  <medium type=\"homogeneous\">\n    <phase type=\"hg\">\n      <float name=\"g\" value=\"1\"/>\n"
             "    </phase>\n  </medium>\n</scene>\n",
             head);
    expect_error(buf, SPC_ERR_VALUE, 4, "(-1, 1)");
    snprintf(buf, sizeof buf, "%s  <medium type=\"homogeneous\">\n    <phase type=\"rayleigh\"/>\n  </medium>\n</scene>\n",
             head);
    expect_error(buf, SPC_ERR_PLUGIN, 3, "rayleigh");
    snprintf(buf, sizeof buf,
             "%s  <medium type=\"heterogeneous\">\n    <volume type=\"gridvolume\" name=\"sigma_t\"/>\n"
             "  </medium>\n</scene>\n",
             head);
    expect_error(buf, SPC_ERR_VALUE, 3, "gridvolume needs a filename");
    snprintf(buf, sizeof buf, "%s  <shape type=\"sphere\">\n    <medium type=\"homogeneous\"/>\n  </shape>\n</scene>\n",
             head);
    expect_error(buf, SPC_ERR_VALUE, 3, "interior");
    snprintf(buf, sizeof buf,
             "%s  <shape type=\"sphere\">\n    <medium type=\"homogeneous\" name=\"interior\"/>\n"
             "    <medium type=\"homogeneous\" name=\"interior\"/>\n  </shape>\n</scene>\n",
             head);
    expect_error(buf, SPC_ERR_VALUE, 4, "one interior");
    snprintf(buf, sizeof buf, "%s  <medium type=\"homogeneous\">\n    <float name=\"scale\" value=\"-2\"/>\n  </medium>\n</scene>\n",
             head);
    expect_error(buf, SPC_ERR_VALUE, 3, "scale");
}

/* ---- renders against closed forms ---- */

/* Orthographic camera at height z0 looking down -z at a 1 x 1 window. */
static void ortho_down(spc_scene *sc, double z0)
{
    sc->camera.type = SPC_CAMERA_ORTHOGRAPHIC;
    spc_mat4 V;
    spc_mat4_lookat(spc_v3(0, 0, z0), spc_v3(0, 0, z0 - 1), spc_v3(0, 1, 0), &V);
    spc_mat4 S = spc_mat4_scale(spc_v3(0.5, 0.5, 1));
    sc->camera.to_world = spc_mat4_mul(&V, &S);
    sc->film.width = sc->film.height = 8;
    sc->film.rfilter = SPC_RFILTER_BOX;
    sc->film.filter_radius = 0.5;
}

/* A box [-w, w]^2 x [z0, z1] of null BSDF holding medium m as its interior. */
static void null_slab(spc_scene *sc, const spc_medium *m, double w, double z0, double z1)
{
    spc_shape *slab = spc_scene_new_shape(sc);
    spc_mat4 S = spc_mat4_scale(spc_v3(w, w, 0.5 * (z1 - z0)));
    spc_mat4 T = spc_mat4_translate(spc_v3(0, 0, 0.5 * (z0 + z1)));
    spc_mat4 M = spc_mat4_mul(&T, &S);
    spc_error err;
    spc_shape_init_cube(slab, &M, NULL, 0, 0, &err);
    slab->bsdf = new_null(sc);
    slab->interior_medium = m->index;
}

TEST(absorbing_slab_head_on)
{
    const double Le = 2.0, d = 0.8;
    spc_scene *sc = spc_scene_create();
    spc_medium *m = new_medium(sc, spc_rgb3(0.3, 1.0, 2.5), spc_rgb1(0.0), SPC_PHASE_ISOTROPIC, 0.0);
    CHECK(m != NULL);
    if (!m) {
        spc_scene_destroy(sc);
        return;
    }
    null_slab(sc, m, 10.0, -0.4, -0.4 + d);
    spc_shape *light = spc_scene_new_shape(sc);
    spc_mat4 S = spc_mat4_scale(spc_v3(30, 30, 1));
    spc_mat4 T = spc_mat4_translate(spc_v3(0, 0, -3));
    spc_mat4 M = spc_mat4_mul(&T, &S);
    spc_error err;
    spc_shape_init_rectangle(light, &M, NULL, 0, 0, &err);
    light->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, light, 1, Le);
    ortho_down(sc, 5.0);
    CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
    spc_film *f = render_nee(sc, "volpath", NULL, 1024, 1);
    CHECK(f != NULL);
    if (f) {
        double want[3] = {Le * exp(-0.3 * d), Le * exp(-1.0 * d), Le * exp(-2.5 * d)};
        check_mean_rgb(f, want, 3.5, 0.02, "slab");
    }
    spc_film_destroy(f);
    /* path ignores media: it sees Le through the null boundaries */
    f = render_nee(sc, "path", NULL, 16, 1);
    CHECK(f != NULL);
    if (f)
        for (int c = 0; c < 3; ++c) {
            double mean, se;
            tu_image_mean(f, c, &mean, &se);
            CHECK_NEAR(mean, Le, 1e-6 * Le);
        }
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* The absorbing slab again, bounded by glass (dielectric, eta 1.5) instead of null faces: seen
 * head-on the light crosses both interfaces with transmittance 1 - F each (radiance scaled by
 * 1 / eta^2 going in and eta^2 coming out) and is reflected back and forth inside, so
 * L = Le (1 - F)^2 T / (1 - F^2 T^2) with F = ((eta - 1) / (eta + 1))^2 and T = exp(-sigma_a d) per
 * channel: the medium's transmittance, the dielectric's weights and the medium tracking across a
 * refractive boundary on paths that reach an area light only by BSDF sampling. */
TEST(absorbing_glass_slab_head_on)
{
    const double Le = 2.0, d = 0.8, eta = 1.5;
    const spc_rgb sigma_a = spc_rgb3(0.3, 1.0, 2.5);
    spc_scene *sc = spc_scene_create();
    spc_medium *m = new_medium(sc, sigma_a, spc_rgb1(0.0), SPC_PHASE_ISOTROPIC, 0.0);
    CHECK(m != NULL);
    if (!m) {
        spc_scene_destroy(sc);
        return;
    }
    null_slab(sc, m, 10.0, -0.4, -0.4 + d);
    spc_bsdf *g = spc_scene_new_bsdf(sc);
    g->type = SPC_BSDF_DIELECTRIC;
    g->eta = eta;
    g->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    g->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    sc->shapes[sc->nshapes - 1]->bsdf = g; /* the slab null_slab just added */
    spc_shape *light = spc_scene_new_shape(sc);
    spc_mat4 S = spc_mat4_scale(spc_v3(30, 30, 1));
    spc_mat4 T = spc_mat4_translate(spc_v3(0, 0, -3));
    spc_mat4 M = spc_mat4_mul(&T, &S);
    spc_error err;
    spc_shape_init_rectangle(light, &M, NULL, 0, 0, &err);
    light->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, light, 1, Le);
    ortho_down(sc, 5.0);
    CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
    spc_film *f = render_nee(sc, "volpath", "none", 16384, 7);
    CHECK(f != NULL);
    if (f) {
        const double F = ((eta - 1.0) / (eta + 1.0)) * ((eta - 1.0) / (eta + 1.0));
        double want[3];
        for (int c = 0; c < 3; ++c) {
            double Tc = exp(-rgb_c(sigma_a, c) * d);
            want[c] = Le * (1.0 - F) * (1.0 - F) * Tc / (1.0 - F * F * Tc * Tc);
        }
        check_mean_rgb(f, want, 3.5, 0.02, "glass slab");
    }
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* E_3(tau) = int_0^1 mu exp(-tau / mu) dmu (Simpson; the integrand is smooth and 0 at mu = 0). */
static double expint3(double tau)
{
    const int n = 100000;
    double s = 0.0;
    for (int i = 1; i <= n; ++i) {
        double mu = (double)i / n;
        s += mu * exp(-tau / mu) * (i == n ? 1.0 : (i % 2 ? 4.0 : 2.0));
    }
    return s / n / 3.0;
}

TEST(diffuse_plane_under_absorbing_slab)
{
    const double a = 0.5, Le = 1.0;
    const spc_rgb sigma = spc_rgb3(0.2, 0.8, 2.0); /* slab thickness 1: tau = sigma */
    spc_scene *sc = spc_scene_create();
    spc_medium *m = new_medium(sc, sigma, spc_rgb1(0.0), SPC_PHASE_ISOTROPIC, 0.0);
    CHECK(m != NULL);
    if (!m) {
        spc_scene_destroy(sc);
        return;
    }
    const double W = 1000.0; /* rays below mu = 1e-3 miss the slab: their share ~1e-6 is negligible */
    null_slab(sc, m, W, 1.0, 2.0);
    spc_shape *plane = spc_scene_new_shape(sc);
    spc_mat4 S = spc_mat4_scale(spc_v3(W, W, 1));
    spc_error err;
    spc_shape_init_rectangle(plane, &S, NULL, 0, 0, &err);
    plane->bsdf = tu_diffuse(sc, a);
    spc_emitter *env = spc_scene_new_emitter(sc);
    env->type = SPC_EMITTER_CONSTANT;
    env->radiance = spc_scene_constant(sc, spc_rgb1(Le));
    ortho_down(sc, 0.5);
    CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
    spc_film *f = render_nee(sc, "volpath", NULL, 2048, 2);
    CHECK(f != NULL);
    if (f) {
        double want[3];
        for (int c = 0; c < 3; ++c)
            want[c] = 2.0 * a * Le * expint3(rgb_c(sigma, c));
        check_mean_rgb(f, want, 3.5, 0.02, "plane under slab");
    }
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* Inside a black sphere emitting Le inward, filled with an albedo-1 medium: L = Le. */
static void conservation_case(spc_rgb sigma_s, spc_phase_type pt, double g, uint64_t seed)
{
    const double Le = 1.5;
    spc_scene *sc = spc_scene_create();
    spc_medium *m = new_medium(sc, spc_rgb1(0.0), sigma_s, pt, g);
    CHECK(m != NULL);
    if (!m) {
        spc_scene_destroy(sc);
        return;
    }
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_sphere(sh, spc_v3(0.1, -0.2, 0.3), 1.0, NULL, NULL, 0, 0, &err);
    sh->flip_normals = true;
    sh->bsdf = tu_diffuse(sc, 0.0);
    sh->interior_medium = sh->exterior_medium = m->index; /* rays never leave: both sides */
    tu_area(sc, sh, 0, Le);
    sc->camera_medium = m->index;
    tu_camera(sc, spc_v3(0.3, -0.1, 0.0), spc_v3(0.0, 0.3, 1.0), spc_v3(0, 1, 0), 90, 8, 8);
    sc->camera.near_clip = 1e-4;
    CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
    spc_film *f = render_nee(sc, "volpath", NULL, 512, seed);
    CHECK(f != NULL);
    if (f) {
        double want[3] = {Le, Le, Le};
        check_mean_rgb(f, want, 3.5, 0.02, "conservation");
    }
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* The furnace behind glass: a dielectric sphere (eta 1.5) filled with an albedo-1 medium under a
 * uniform environment Le, seen from outside. Radiance over n^2 is conserved by refraction, by
 * reflection and by lossless scattering, so the equilibrium is Le outside and eta^2 Le inside, and
 * every pixel (rays that miss the sphere too) reads Le: each path's value is Le times the 1 / eta^2
 * of every entry and the eta^2 of every exit, in expectation over free flight, the spectral
 * channel choice and the roulette (which here meets the eta^2 scale of paths inside). */
static void glass_furnace_case(spc_rgb sigma_s, spc_phase_type pt, double g, uint64_t seed)
{
    const double Le = 1.5;
    spc_scene *sc = spc_scene_create();
    spc_medium *m = new_medium(sc, spc_rgb1(0.0), sigma_s, pt, g);
    CHECK(m != NULL);
    if (!m) {
        spc_scene_destroy(sc);
        return;
    }
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_sphere(sh, spc_v3(0.0, 0.0, 0.0), 1.0, NULL, NULL, 0, 0, &err);
    spc_bsdf *glass = spc_scene_new_bsdf(sc);
    glass->type = SPC_BSDF_DIELECTRIC;
    glass->eta = 1.5;
    glass->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    glass->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    sh->bsdf = glass;
    sh->interior_medium = m->index;
    spc_emitter *env = spc_scene_new_emitter(sc);
    env->type = SPC_EMITTER_CONSTANT;
    env->radiance = spc_scene_constant(sc, spc_rgb1(Le));
    tu_camera(sc, spc_v3(0.0, 0.5, 3.5), spc_v3(0.0, 0.0, 0.0), spc_v3(0, 1, 0), 30, 8, 8);
    CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
    spc_film *f = render_nee(sc, "volpath", "none", 2048, seed);
    CHECK(f != NULL);
    if (f) {
        double want[3] = {Le, Le, Le};
        check_mean_rgb(f, want, 3.5, 0.02, "glass furnace");
    }
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

TEST(glass_furnace)
{
    glass_furnace_case(spc_rgb3(0.5, 1.5, 4.0), SPC_PHASE_HG, 0.6, 8);
    glass_furnace_case(spc_rgb3(2.0, 0.3, 1.0), SPC_PHASE_ISOTROPIC, 0.0, 9);
}

TEST(radiance_conservation_furnace)
{
    conservation_case(spc_rgb3(0.5, 1.5, 4.0), SPC_PHASE_HG, 0.6, 3);
    conservation_case(spc_rgb3(2.0, 0.3, 1.0), SPC_PHASE_ISOTROPIC, 0.0, 4);
    conservation_case(spc_rgb3(1.0, 1.0, 1.0), SPC_PHASE_HG, -0.4, 5);
}

/* ---- volpath == path in vacuum ---- */

static spc_scene *vacuum_box(bool ghost_sphere)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *room = spc_scene_new_shape(sc);
    spc_shape_init_cube(room, NULL, NULL, 0, 0, &err);
    room->flip_normals = true;
    room->bsdf = tu_diffuse(sc, 0.6);
    spc_shape *light = spc_scene_new_shape(sc);
    spc_mat4 S = spc_mat4_scale(spc_v3(0.3, 0.3, 1));
    spc_mat4 R = spc_mat4_rotate(spc_v3(1, 0, 0), 90.0);
    spc_mat4 T = spc_mat4_translate(spc_v3(0, 0.98, 0));
    spc_mat4 RS = spc_mat4_mul(&R, &S);
    spc_mat4 M = spc_mat4_mul(&T, &RS);
    spc_shape_init_rectangle(light, &M, NULL, 0, 0, &err);
    light->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, light, 1, 8.0);
    spc_shape *glass = spc_scene_new_shape(sc);
    spc_shape_init_sphere(glass, spc_v3(-0.4, -0.6, 0.2), 0.35, NULL, NULL, 0, 0, &err);
    spc_bsdf *g = spc_scene_new_bsdf(sc);
    g->type = SPC_BSDF_DIELECTRIC;
    g->eta = 1.5;
    g->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    g->specular_transmittance = spc_scene_constant(sc, spc_rgb1(1.0));
    glass->bsdf = g;
    spc_shape *ball = spc_scene_new_shape(sc);
    spc_shape_init_sphere(ball, spc_v3(0.45, -0.65, -0.2), 0.3, NULL, NULL, 0, 0, &err);
    ball->bsdf = tu_diffuse(sc, 0.8);
    if (ghost_sphere) {
        /* an invisible sphere in the light's beam: volpath's paths and shadow rays cross it */
        spc_shape *ghost = spc_scene_new_shape(sc);
        spc_shape_init_sphere(ghost, spc_v3(0.1, 0.4, 0.1), 0.4, NULL, NULL, 0, 0, &err);
        ghost->bsdf = new_null(sc);
    }
    tu_camera(sc, spc_v3(0, 0, -0.95), spc_v3(0, -0.1, 0), spc_v3(0, 1, 0), 70, 16, 16);
    sc->camera.near_clip = 1e-3;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

TEST(volpath_equals_path_in_vacuum)
{
    spc_scene *sc = vacuum_box(false);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *a = render_nee(sc, "volpath", NULL, 512, 10);
    spc_film *b = render_nee(sc, "path", NULL, 512, 11);
    CHECK(a && b);
    if (a && b) {
        CHECK(ztest(a, b, "volpath vs path (vacuum)") >= 0.99);
        check_means_agree(a, b, 3.5, "volpath vs path (vacuum)");
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_scene_destroy(sc);
}

/* A null surface is invisible: the same image with and without it (it is crossed by paths, whose
 * emitter hits behind it keep the MIS weight of the vertex before it, and by shadow rays). (path
 * cannot serve as the reference here: for it a null surface blocks NEE, so light behind it is
 * found only by BSDF sampling, and its variance estimate at this sample count is unreliable.) */
TEST(null_surface_is_invisible)
{
    spc_scene *with = vacuum_box(true), *without = vacuum_box(false);
    CHECK(with && without);
    spc_film *a = with ? render_nee(with, "volpath", NULL, 512, 12) : NULL;
    spc_film *b = without ? render_nee(without, "volpath", NULL, 512, 13) : NULL;
    CHECK(a && b);
    if (a && b) {
        CHECK(ztest(a, b, "volpath with vs without a null sphere") >= 0.99);
        check_means_agree(a, b, 3.5, "volpath with vs without a null sphere");
    }
    spc_film_destroy(a);
    spc_film_destroy(b);
    spc_scene_destroy(with);
    spc_scene_destroy(without);
}

/* ---- glass filled with a scattering medium: the specular connection ---- */

/* A dielectric shape (given by `shape`, the inside of a <shape> element) filled with a scattering
 * medium, lit through its surface by an area light above it; no other surface. */
static const char *glass_medium_fmt =
    "<scene version=\"3.0.0\">\n"
    "  <integrator type=\"volpath\"/>\n"
    "  <sensor type=\"perspective\">\n"
    "    <float name=\"fov\" value=\"38\"/>\n"
    "    <transform name=\"to_world\"><lookat origin=\"0, 1.2, 4\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>\n"
    "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"12\"/><integer name=\"height\" value=\"12\"/>"
    "<rfilter type=\"box\"/></film>\n"
    "  </sensor>\n"
    "  <medium type=\"homogeneous\" id=\"smoke\">\n"
    "    <rgb name=\"albedo\" value=\"0.95, 0.9, 0.8\"/>\n"
    "    <rgb name=\"sigma_t\" value=\"1.0, 1.5, 2.0\"/>\n"
    "    <phase type=\"hg\"><float name=\"g\" value=\"0.4\"/></phase>\n"
    "  </medium>\n"
    "  <shape %s\n"
    "    <bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.5\"/><float name=\"ext_ior\" value=\"1\"/></bsdf>\n"
    "    <ref name=\"interior\" id=\"smoke\"/>\n"
    "  </shape>\n"
    "  <shape type=\"rectangle\">\n"
    "    <transform name=\"to_world\"><scale value=\"0.6\"/><rotate x=\"1\" angle=\"90\"/>"
    "<translate x=\"0.5\" y=\"2.5\" z=\"0.3\"/></transform>\n"
    "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"10\"/></emitter>\n"
    "  </shape>\n"
    "</scene>\n";

/* volpath with the connection by `solver` against volpath without it (phase sampling only). */
static void connection_case(const char *shape, const char *solver, int spp_ref, int spp, const char *what)
{
    char xml[4096];
    snprintf(xml, sizeof xml, glass_medium_fmt, shape);
    spc_scene *sc = NULL;
    spc_error e;
    spc_status st = load_xml(xml, &sc, &e);
    CHECK_MSG(st == SPC_OK, "%s", e.msg);
    if (!sc)
        return;
    CHECK(sc->nmedia == 1 && sc->shapes[0]->interior_medium == 0);
    spc_film *ref = render_nee(sc, "volpath", "none", spp_ref, 31);
    spc_film *con = render_nee(sc, "volpath", solver, spp, 32);
    CHECK(ref && con);
    if (ref && con) {
        CHECK_MSG(ztest(con, ref, what) >= 0.99, "%s", what);
        check_means_agree(con, ref, 3.5, what);
        double vc = 0.0, vr = 0.0;
        for (int i = 0; i < 3 * con->width * con->height; ++i) {
            vc += con->var[i] * spp;
            vr += ref->var[i] * spp_ref;
        }
        printf("  %s: variance per sample, summed over pixels: %.4g with the connection, %.4g without\n", what, vc, vr);
        /* the connection carries the light phase sampling finds only by chance: lower variance */
        CHECK_MSG(vc < vr, "%s: variance per sample %.4g is not below %.4g", what, vc, vr);
    }
    spc_film_destroy(ref);
    spc_film_destroy(con);
    spc_scene_destroy(sc);
}

/* A glass slab (a rotated box: flat faces, where the angular solver converges reliably). */
TEST(glass_slab_connection_angular)
{
    connection_case("type=\"cube\">\n    <transform name=\"to_world\"><scale x=\"1\" y=\"0.4\" z=\"0.8\"/>"
                    "<rotate y=\"1\" angle=\"20\"/></transform>",
                    "angular", 2048, 256, "glass slab: angular connection vs phase sampling");
}

/* A glass icosphere (interpolated normals) by the conic solver, which enumerates every solution. */
TEST(glass_icosphere_connection_conic)
{
    int conic;
    bool registered = spc_specular_solver_parse("conic", &conic) && spc_specular_solver_get(conic);
    CHECK_MSG(registered, "the conic solver is not registered");
    if (!registered)
        return;
    connection_case("type=\"obj\">\n    <string name=\"filename\" value=\"meshes/icosphere.obj\"/>", "conic", 2048, 256,
                    "glass icosphere: conic connection vs phase sampling");
}

/* The plan's volpath setting for a tessellated ball, phase seeds included (snee_plan.h), on the glass
 * icosphere: the randomized attempts seeded half from the phase function, half from the cone, with
 * the stand-in psi; it agrees with phase sampling alone per pixel and in the image mean. */
TEST(glass_icosphere_plan_phase_seeds)
{
    connection_case("type=\"obj\">\n    <string name=\"filename\" value=\"meshes/icosphere.obj\"/>",
                    SPC_SNEE_PLAN_SETTING_BALLS_VOLPATH SPC_SNEE_PLAN_VOLPATH_PHASE_SEEDS, 2048, 256,
                    "glass icosphere: the plan's connection with phase seeds vs phase sampling");
}

/* Does a render differ from b anywhere, bit for bit? */
static bool films_differ(const spc_film *a, const spc_film *b)
{
    return a->width != b->width || a->height != b->height ||
           memcmp(a->rgb, b->rgb, sizeof a->rgb[0] * 3 * (size_t)a->width * (size_t)a->height) != 0;
}

/* volpath's connection takes the user's options: trials=1 cuts every Bernoulli-trial count at 1
 * attempt, a count that reaches it giving its chain up to phase sampling where specular NEE's density
 * is at most its cap times phase sampling's (cap_gives_up), else going on by roulette, so the image
 * changes but its mean does not; seed=light changes
 * the attempts, chain=1 drops the chains that reflect inside the ball before they leave it, nomis
 * drops the phase-sampled paths specular NEE covers instead of weighting them, receivers=1 leaves
 * the second and later medium vertices to phase sampling; the same setting twice gives the same
 * image. */
TEST(volpath_honours_specular_nee_options)
{
    char xml[4096];
    snprintf(xml, sizeof xml, glass_medium_fmt,
             "type=\"sphere\">\n    <float name=\"radius\" value=\"0.8\"/>");
    spc_scene *sc = NULL;
    spc_error e;
    CHECK_MSG(load_xml(xml, &sc, &e) == SPC_OK, "%s", e.msg);
    if (!sc)
        return;
    const int spp = 2048;
    spc_film *a = render_nee(sc, "volpath", "angular", spp, 41);
    spc_film *a2 = render_nee(sc, "volpath", "angular", spp, 41);
    spc_film *capped = render_nee(sc, "volpath", "angular:trials=1", spp, 41);
    spc_film *light = render_nee(sc, "volpath", "angular:seed=light", spp, 41);
    const char *others[3] = {"angular:chain=1", "angular:nomis", "angular:receivers=1"};
    for (int i = 0; i < 3 && a; ++i) {
        spc_film *o = render_nee(sc, "volpath", others[i], spp / 8, 41);
        spc_film *a8 = render_nee(sc, "volpath", "angular", spp / 8, 41);
        CHECK(o && a8);
        if (o && a8)
            CHECK_MSG(films_differ(a8, o), "%s is ignored", others[i]);
        spc_film_destroy(o);
        spc_film_destroy(a8);
    }
    CHECK(a && a2 && capped && light);
    if (a && a2 && capped && light) {
        CHECK(!films_differ(a, a2));
        CHECK_MSG(films_differ(a, capped), "trials=1 is ignored");
        CHECK_MSG(films_differ(a, light), "seed=light is ignored");
        for (int c = 0; c < 3; ++c) {
            double ma, sa, mc, scp;
            tu_image_mean(a, c, &ma, &sa);
            tu_image_mean(capped, c, &mc, &scp);
            printf("  channel %d: mean %.5f (se %.2g), with trials=1 %.5f (se %.2g)\n", c, ma, sa, mc, scp);
            CHECK_MSG(fabs(ma - mc) < 4.0 * sqrt(sa * sa + scp * scp), "trials=1 moves the mean of channel %d", c);
        }
    }
    spc_film_destroy(a);
    spc_film_destroy(a2);
    spc_film_destroy(capped);
    spc_film_destroy(light);
    spc_scene_destroy(sc);
}

/* A glass sphere in a fog that fills a box of null faces around it, lit from above by a small area
 * light: the fog's points outside the sphere are medium receivers from which the sphere fills a small
 * share of the directions. */
static const char *fog_ball_xml =
    "<scene version=\"3.0.0\">\n"
    "  <integrator type=\"volpath\"/>\n"
    "  <sensor type=\"perspective\">\n"
    "    <float name=\"fov\" value=\"40\"/>\n"
    "    <transform name=\"to_world\"><lookat origin=\"0, 0.5, 4\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>\n"
    "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"12\"/><integer name=\"height\" value=\"12\"/>"
    "<rfilter type=\"box\"/></film>\n"
    "  </sensor>\n"
    "  <medium type=\"homogeneous\" id=\"fog\">\n"
    "    <rgb name=\"albedo\" value=\"0.9, 0.9, 0.85\"/>\n"
    "    <rgb name=\"sigma_t\" value=\"0.4, 0.5, 0.6\"/>\n"
    "    <phase type=\"hg\"><float name=\"g\" value=\"0.3\"/></phase>\n"
    "  </medium>\n"
    "  <shape type=\"cube\">\n"
    "    <transform name=\"to_world\"><scale x=\"1.2\" y=\"1.2\" z=\"1.2\"/></transform>\n"
    "    <bsdf type=\"null\"/>\n"
    "    <ref name=\"interior\" id=\"fog\"/>\n"
    "  </shape>\n"
    "  <shape type=\"sphere\">\n"
    "    <float name=\"radius\" value=\"0.3\"/><point name=\"center\" x=\"0\" y=\"0.4\" z=\"0\"/>\n"
    "    <bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1.5\"/><float name=\"ext_ior\" value=\"1\"/></bsdf>\n"
    "    <ref name=\"exterior\" id=\"fog\"/>\n"
    "  </shape>\n"
    "  <shape type=\"rectangle\">\n"
    "    <transform name=\"to_world\"><scale value=\"0.15\"/><rotate x=\"1\" angle=\"90\"/>"
    "<translate y=\"1.1\"/></transform>\n"
    "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"60\"/></emitter>\n"
    "  </shape>\n"
    "</scene>\n";

/* first=P at medium receivers: at a path's first medium vertex the query is made with the probability
 * spc_snee_first_prob gives there (P where the sphere looks small, 1 within its bounds), counted
 * 1/P times, and the phase-sampled paths it covers weighed with the same probability. On the fog
 * ball, first=0.1 changes the image (the option is read at the first medium vertex, where it used to
 * be path's only), and the image agrees with phase sampling alone (specular NEE off) per pixel
 * (z-test, Sidak) and in the mean: the roulette keeps the estimate unbiased. */
TEST(volpath_first_receiver_roulette)
{
    spc_scene *sc = NULL;
    spc_error e;
    CHECK_MSG(load_xml(fog_ball_xml, &sc, &e) == SPC_OK, "%s", e.msg);
    if (!sc)
        return;
    const int spp = 2048;
    spc_film *all = render_nee(sc, "volpath", "angular", spp / 8, 51);
    spc_film *some4 = render_nee(sc, "volpath", "angular:first=0.1", spp / 8, 51);
    spc_film *some = render_nee(sc, "volpath", "angular:first=0.1", spp, 52);
    spc_film *none = render_nee(sc, "volpath", "none", 2 * spp, 53);
    spc_film *tight4 = render_nee(sc, "volpath", "angular:first=0.1,later=0.1,tightshare", spp / 8, 51);
    spc_film *loose4 = render_nee(sc, "volpath", "angular:first=0.1,later=0.1", spp / 8, 51);
    spc_film *tight = render_nee(sc, "volpath", "angular:first=0.1,later=0.1,tightshare", spp, 54);
    CHECK(all && some4 && some && none && tight4 && loose4 && tight);
    if (all && some4 && some && none && tight4 && loose4 && tight) {
        CHECK_MSG(films_differ(all, some4), "first=0.1 is ignored at medium receivers");
        CHECK_MSG(ztest(some, none, "fog ball: first=0.1 vs specular NEE off") >= 0.99, "first=0.1 vs none");
        check_means_agree(some, none, 3.5, "fog ball: first=0.1 vs specular NEE off");
        CHECK_MSG(films_differ(tight4, loose4), "tightshare is ignored at medium receivers");
        CHECK_MSG(ztest(tight, none, "fog ball: tightshare vs specular NEE off") >= 0.99, "tightshare vs none");
        check_means_agree(tight, none, 3.5, "fog ball: tightshare vs specular NEE off");
    }
    spc_film_destroy(tight4);
    spc_film_destroy(loose4);
    spc_film_destroy(tight);
    spc_film_destroy(all);
    spc_film_destroy(some4);
    spc_film_destroy(some);
    spc_film_destroy(none);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(phase_closed_forms);
    RUN(phase_chi2);
    RUN(transmittance_closed_forms);
    RUN(free_flight_expectations);
    RUN(loader_media);
    RUN(absorbing_slab_head_on);
    RUN(absorbing_glass_slab_head_on);
    RUN(diffuse_plane_under_absorbing_slab);
    RUN(radiance_conservation_furnace);
    RUN(glass_furnace);
    RUN(volpath_equals_path_in_vacuum);
    RUN(null_surface_is_invisible);
    RUN(glass_slab_connection_angular);
    RUN(glass_icosphere_connection_conic);
    RUN(glass_icosphere_plan_phase_seeds);
    RUN(volpath_honours_specular_nee_options);
    RUN(volpath_first_receiver_roulette);
    return spc_test_finish();
}
