/*
 * tests/test_heterogeneous.c: heterogeneous media and volume-valued properties (src/medium/
 * gridvolume.c, heterogeneous.c, medium.c; io/vol.c; the loader's io/mitsuba_volumes.c).
 *
 * - .vol files: a written grid reads back (values, size, channels, bounding box); truncated,
 *   foreign and 2-channel files are refused with their path in the message.
 * - Lookups: trilinear values at texel centres are the texels, halfway between two the mean;
 *   clamp, repeat and mirror wrapping; nearest filtering; to_world.
 * - Optical depth: the exact piecewise integration against a fine midpoint quadrature of
 *   spc_medium_coefficients along random rays through a rotated, stretched 3-channel grid (and a
 *   nearest one, and a constvolume bounded by its unit cube).
 * - Free flight: the sample's pdf is spc_medium_pdf_ray's; with all the throughput in one channel
 *   the distances follow that channel's optical depth (1 - exp(-tau(t)) is uniform: chi-square);
 *   with a white throughput every channel's estimate is unbiased: the mean weight of interactions
 *   in each of four intervals matches the quadrature of sigma_s T over it, and passing the segment
 *   matches T(t_max).
 * - Radiance conservation (a white furnace for media): inside a sphere whose inner surface emits
 *   Le and reflects nothing, filled with a heterogeneous medium of albedo 1 (a spectral grid,
 *   partly vacuum), volpath's image mean is Le.
 * - Against Mitsuba 3: scenes/medium_grid.xml (a grid cloud with an albedo grid, a homogeneous
 *   sphere with a volume albedo) by the per-pixel z-test (99.75% of the pixels, as
 *   test_mitsuba_refs) and the image mean (|z| < 3.3 per channel) against the committed
 *   reference (tests/validation/make_test_refs.py medium_grid); the cloud 10% denser fails the
 *   mean test (the test's power; skipped in the sanitizers' quick mode, SPC_TEST_QUICK).
 * - Loader errors name the file and line.
 */
/* ctest-labels: stat scene */
/* ctest-timeout: 600 */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "chi2.h"
#include "harness.h"
#include "io/mitsuba_xml.h"
#include "io/vol.h"
#include "medium/medium.h"
#include "render/film.h"
#include "render_util.h"
#include "scene/scene.h"
#include "specula/specula.h"

static const char *source_dir(void)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    return d ? d : ".";
}

static double ch(spc_rgb c, int i) { return i == 0 ? c.r : (i == 1 ? c.g : c.b); }

/* Writes a .vol file; returns false on I/O failure. `magic` overrides the first 4 bytes. */
static bool write_vol(const char *path, const char *magic, int xr, int yr, int zr, int chn, const float *data,
                      size_t nvalues, const float bbox[6])
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return false;
    unsigned char h[48];
    memcpy(h, magic, 4);
    int32_t ints[5] = {1, xr, yr, zr, chn};
    memcpy(h + 4, ints, sizeof ints); /* the test machines are little endian, as the format */
    memcpy(h + 24, bbox, 6 * sizeof(float));
    bool ok = fwrite(h, 1, 48, f) == 48 && fwrite(data, sizeof(float), nvalues, f) == nvalues;
    return fclose(f) == 0 && ok;
}

TEST(vol_files)
{
    char path[] = "/tmp/spc_test_volXXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd < 0)
        return;
    close(fd);
    float data[2 * 3 * 4 * 3], bbox[6] = {-1, -2, -3, 1, 2, 3};
    for (int i = 0; i < 72; ++i)
        data[i] = 0.25f * (float)i;
    CHECK(write_vol(path, "VOL\3", 2, 3, 4, 3, data, 72, bbox));
    spc_volume v;
    memset(&v, 0, sizeof v);
    double bb[6];
    spc_error err;
    CHECK(spc_vol_read(path, &v, bb, &err) == SPC_OK);
    CHECK(v.res[0] == 2 && v.res[1] == 3 && v.res[2] == 4 && v.channels == 3 && v.data);
    if (v.data) {
        CHECK(v.data[0] == 0.0f && v.data[71] == 17.75f);
        CHECK(bb[0] == -1.0 && bb[5] == 3.0);
        spc_mat4 id = spc_mat4_identity();
        CHECK(spc_volume_finish_grid(&v, &id));
        CHECK_NEAR(v.max.r, 17.25, 0.0);
        CHECK_NEAR(v.max.b, 17.75, 0.0);
        free(v.data);
    }
    /* truncated data, a foreign file, two channels */
    CHECK(write_vol(path, "VOL\3", 2, 3, 4, 3, data, 50, bbox));
    CHECK(spc_vol_read(path, &v, NULL, &err) == SPC_ERR_PARSE);
    CHECK_MSG(strstr(err.file, "spc_test_vol") && strstr(err.msg, "truncated"), "%s: %s", err.file, err.msg);
    CHECK(write_vol(path, "VOX\3", 2, 3, 4, 3, data, 72, bbox));
    CHECK(spc_vol_read(path, &v, NULL, &err) == SPC_ERR_PARSE);
    CHECK(write_vol(path, "VOL\3", 2, 3, 2, 2, data, 24, bbox));
    CHECK(spc_vol_read(path, &v, NULL, &err) == SPC_ERR_VALUE);
    CHECK(write_vol(path, "VOL\3", 0, 3, 2, 1, data, 24, bbox));
    CHECK(spc_vol_read(path, &v, NULL, &err) == SPC_ERR_VALUE);
    unlink(path);
    CHECK(spc_vol_read(path, &v, NULL, &err) == SPC_ERR_IO);
}

/* ------------------------------------------------------------------------------------------ */

/* A grid volume over `data` (copied), channels 1 or 3. */
static spc_volume make_grid(int xr, int yr, int zr, int chn, const double *vals, bool nearest, spc_volume_wrap w,
                            const spc_mat4 *to_world)
{
    spc_volume v;
    memset(&v, 0, sizeof v);
    v.res[0] = xr;
    v.res[1] = yr;
    v.res[2] = zr;
    v.channels = chn;
    size_t n = (size_t)xr * yr * zr * chn;
    v.data = malloc(n * sizeof(float));
    for (size_t i = 0; v.data && i < n; ++i)
        v.data[i] = (float)vals[i];
    v.nearest = nearest;
    v.wrap = w;
    spc_volume_finish_grid(&v, to_world);
    return v;
}

TEST(lookups)
{
    /* 3 x 2 x 1, one channel: x fastest */
    double vals[6] = {1, 2, 4, 10, 20, 40};
    spc_mat4 id = spc_mat4_identity();
    spc_volume v = make_grid(3, 2, 1, 1, vals, false, SPC_VOLUME_CLAMP, &id);
    /* texel (i, j) is centred at ((i + .5) / 3, (j + .5) / 2) */
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(0.5 / 3, 0.25, 0.5)).g, 1.0, 1e-12);
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(2.5 / 3, 0.75, 0.5)).g, 40.0, 1e-12);
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(1.0 / 3, 0.25, 0.5)).g, 1.5, 1e-12); /* halfway in x */
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(0.5 / 3, 0.5, 0.5)).g, 5.5, 1e-12);  /* halfway in y */
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(-3.0, 0.1, 7.0)).g, 1.0, 1e-12);     /* clamped */
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(1.0 / 3, 0.5, 0.5)).g, 8.25, 1e-12); /* centre of four */
    v.wrap = SPC_VOLUME_REPEAT;
    /* u = 0 lies halfway between texel 2 (wrapped from -1) and texel 0 */
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(0.0, 0.25, 0.5)).g, 2.5, 1e-12);
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(1.0 + 0.5 / 3, 0.25, 0.5)).g, 1.0, 1e-12);
    v.wrap = SPC_VOLUME_MIRROR;
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(0.0, 0.25, 0.5)).g, 1.0, 1e-12); /* the edge texel repeats */
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(-0.5 / 3, 0.25, 0.5)).g, 1.0, 1e-12);
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(-1.5 / 3, 0.25, 0.5)).g, 2.0, 1e-12);
    v.wrap = SPC_VOLUME_CLAMP;
    v.nearest = true;
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(0.34, 0.6, 0.5)).g, 20.0, 1e-12);
    free(v.data);
    /* to_world: the unit cube scaled by 2 and moved by (1, 0, 0); bounds follow */
    spc_mat4 s = spc_mat4_scale(spc_v3(2, 2, 2)), t = spc_mat4_translate(spc_v3(1, 0, 0));
    spc_mat4 m = spc_mat4_mul(&t, &s);
    v = make_grid(3, 2, 1, 1, vals, false, SPC_VOLUME_CLAMP, &m);
    CHECK_NEAR(spc_volume_eval(&v, spc_v3(1.0 + 2.0 * 2.5 / 3, 1.5, 1.0)).g, 40.0, 1e-12);
    CHECK(v.lo.x == 1.0 && v.hi.x == 3.0 && v.hi.y == 2.0);
    free(v.data);
}

/* ------------------------------------------------------------------------------------------ */

/* A heterogeneous medium over a 5 x 4 x 3 3-channel grid, stretched and rotated. */
static void make_medium(spc_medium *m, bool nearest, uint64_t seed)
{
    spc_rng rng;
    spc_rng_seed(&rng, seed, 1);
    double vals[5 * 4 * 3 * 3];
    for (int i = 0; i < 5 * 4 * 3 * 3; ++i)
        vals[i] = spc_rng_next(&rng) < 0.2 ? 0.0 : 3.0 * spc_rng_next(&rng);
    spc_mat4 s = spc_mat4_scale(spc_v3(1.5, 1.0, 0.8)), r = spc_mat4_rotate(spc_v3(0.3, 1, 0.2), 35);
    spc_mat4 t = spc_mat4_translate(spc_v3(-0.6, -0.4, -0.5));
    spc_mat4 rs = spc_mat4_mul(&r, &s), m4 = spc_mat4_mul(&t, &rs);
    spc_volume v = make_grid(5, 4, 3, 3, vals, nearest, SPC_VOLUME_CLAMP, &m4);
    memset(m, 0, sizeof *m);
    spc_medium_init_heterogeneous(m, &v, 1.3, spc_rgb3(0.9, 0.6, 0.3));
}

/* Optical depth by the midpoint rule with n steps over the part of [0, t] inside the volume's
 * bounds (where sigma_t is continuous for trilinear grids and constants). */
static spc_rgb quad_depth(const spc_medium *m, spc_vec3 o, spc_vec3 d, double t, int n)
{
    spc_rgb tau = spc_rgb1(0.0);
    double lo[3] = {m->sigma_t_vol.lo.x, m->sigma_t_vol.lo.y, m->sigma_t_vol.lo.z};
    double hi[3] = {m->sigma_t_vol.hi.x, m->sigma_t_vol.hi.y, m->sigma_t_vol.hi.z};
    double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z}, a = 0.0, b = t;
    for (int k = 0; k < 3; ++k) {
        double t0 = (lo[k] - oo[k]) / dd[k], t1 = (hi[k] - oo[k]) / dd[k];
        a = fmax(a, fmin(t0, t1));
        b = fmin(b, fmax(t0, t1));
    }
    if (!(b > a))
        return tau;
    double h = (b - a) / n;
    for (int i = 0; i < n; ++i) {
        spc_rgb st, ss;
        spc_medium_coefficients(m, spc_madd(o, d, a + (i + 0.5) * h), &st, &ss);
        tau = spc_rgb_add(tau, spc_rgb_scale(st, h));
    }
    return tau;
}

static spc_vec3 random_dir(spc_rng *rng)
{
    return spc_warp_uniform_sphere(spc_v2(spc_rng_next(rng), spc_rng_next(rng)));
}

TEST(optical_depth_is_exact)
{
    spc_rng rng;
    spc_rng_seed(&rng, 7, 7);
    for (int variant = 0; variant < 3; ++variant) {
        spc_medium m;
        if (variant < 2) {
            make_medium(&m, variant == 1, 11);
        } else {
            spc_volume c;
            spc_mat4 id = spc_mat4_identity();
            spc_volume_init_constant(&c, spc_rgb3(0.5, 1.0, 2.0), &id);
            memset(&m, 0, sizeof m);
            spc_medium_init_heterogeneous(&m, &c, 1.0, spc_rgb1(0.5));
        }
        double worst = 0.0;
        int nonzero = 0;
        int rays = spc_test_quick() ? 12 : 40;
        for (int i = 0; i < rays; ++i) {
            spc_vec3 o =
                spc_v3(2.0 * spc_rng_next(&rng) - 1.0, 2.0 * spc_rng_next(&rng) - 1.0, 2.0 * spc_rng_next(&rng) - 1.0);
            spc_vec3 d = random_dir(&rng);
            double t = 3.0 * spc_rng_next(&rng);
            spc_rgb T = spc_medium_transmittance_ray(&m, o, d, t);
            spc_rgb q = quad_depth(&m, o, d, t, spc_test_quick() ? 50000 : 200000);
            for (int c = 0; c < 3; ++c) {
                double tau = -log(ch(T, c));
                worst = fmax(worst, fabs(tau - ch(q, c)) / fmax(1e-3, ch(q, c)));
                nonzero += ch(q, c) > 1e-3;
            }
        }
        printf("  %s: worst relative error of the optical depth %.2g (%d nonzero)\n",
               variant == 0 ? "trilinear grid" : (variant == 1 ? "nearest grid" : "constvolume"), worst, nonzero);
        /* the midpoint rule's own error near the nearest grid's jumps is h * jump */
        CHECK_MSG(worst < (variant == 1 ? 1e-4 : 1e-7), "optical depth off by %g", worst);
        CHECK(nonzero >= (spc_test_quick() ? 5 : 20));
        spc_medium_release(&m);
    }
}

/* ------------------------------------------------------------------------------------------ */

TEST(free_flight)
{
    spc_medium m;
    make_medium(&m, false, 12);
    spc_vec3 o = spc_v3(-1.4, -0.3, 0.1), d = spc_normalize(spc_v3(1.0, 0.25, -0.1));
    double t_max = 2.4;
    spc_rgb Tmax = spc_medium_transmittance_ray(&m, o, d, t_max);
    printf("  T(t_max) = (%.4f %.4f %.4f)\n", Tmax.r, Tmax.g, Tmax.b);
    CHECK(Tmax.r > 0.01 && Tmax.r < 0.9 && Tmax.b > 0.01 && Tmax.b < 0.9);
    /* (a) one channel: 1 - exp(-tau_r(t)) is uniform on [0, 1 - T_r(t_max)) */
    enum { NB = 20, N = 200000 };
    double hist[NB] = {0}, passed = 0.0, worst_pdf = 0.0;
    spc_rng rng;
    spc_rng_seed(&rng, 5, 5);
    for (int i = 0; i < N; ++i) {
        spc_medium_event ev;
        if (!spc_medium_sample_ray(&m, o, d, t_max, spc_rgb3(1, 0, 0), spc_rng_next(&rng), spc_rng_next(&rng), &ev))
            continue;
        double p = spc_medium_pdf_ray(&m, o, d, spc_rgb3(1, 0, 0), ev.t, t_max, ev.scattered);
        worst_pdf = fmax(worst_pdf, fabs(p - ev.pdf) / ev.pdf);
        if (!ev.scattered) {
            passed += 1.0;
            continue;
        }
        double u = 1.0 - spc_medium_transmittance_ray(&m, o, d, ev.t).r;
        int b = (int)(u / (1.0 - Tmax.r) * NB);
        hist[b < 0 ? 0 : (b >= NB ? NB - 1 : b)] += 1.0;
    }
    double expect = N * (1.0 - Tmax.r) / NB, chi2 = 0.0;
    for (int b = 0; b < NB; ++b)
        chi2 += (hist[b] - expect) * (hist[b] - expect) / expect;
    double pass_expect = N * Tmax.r;
    chi2 += (passed - pass_expect) * (passed - pass_expect) / pass_expect;
    double p = chi2_gamma_q(0.5 * NB, 0.5 * chi2);
    printf("  one channel: chi2 %.1f (dof %d) p %.3f; pdf vs pdf_ray %.2g\n", chi2, NB, p, worst_pdf);
    CHECK_MSG(chi2_accept(p, 1), "free-flight distances do not follow the optical depth: p = %g", p);
    CHECK(worst_pdf < 1e-9);
    /* (b) white throughput: each channel's estimate is unbiased */
    double edges[5] = {0.0, 0.5, 1.0, 1.6, t_max};
    double sum[5][3] = {{0}}, sum2[5][3] = {{0}};
    const int M = 200000;
    for (int i = 0; i < M; ++i) {
        spc_medium_event ev;
        if (!spc_medium_sample_ray(&m, o, d, t_max, spc_rgb1(1.0), spc_rng_next(&rng), spc_rng_next(&rng), &ev))
            continue;
        int k = 4;
        if (ev.scattered)
            for (k = 0; k < 3 && ev.t >= edges[k + 1]; ++k)
                ;
        for (int c = 0; c < 3; ++c) {
            double w = ch(ev.weight, c);
            sum[k][c] += w;
            sum2[k][c] += w * w;
        }
    }
    double worst_z = 0.0;
    for (int k = 0; k < 5; ++k) {
        for (int c = 0; c < 3; ++c) {
            double want;
            if (k == 4) {
                want = ch(Tmax, c);
            } else {
                /* the quadrature of sigma_s(t) T(t) over the interval */
                want = 0.0;
                int n = 4000;
                double h = (edges[k + 1] - edges[k]) / n;
                for (int j = 0; j < n; ++j) {
                    double t = edges[k] + (j + 0.5) * h;
                    spc_rgb st, ss;
                    spc_medium_coefficients(&m, spc_madd(o, d, t), &st, &ss);
                    want += ch(ss, c) * ch(spc_medium_transmittance_ray(&m, o, d, t), c) * h;
                }
            }
            double mean = sum[k][c] / M, se = sqrt(fmax(0.0, sum2[k][c] / M - mean * mean) / M);
            double z = fabs(mean - want) / fmax(se, 1e-12);
            worst_z = fmax(worst_z, z);
            CHECK_MSG(z < 4.5, "interval %d channel %d: mean weight %.5f, expected %.5f (se %.2g)", k, c, mean, want,
                      se);
        }
    }
    printf("  white throughput: worst |z| %.2f over 5 intervals x 3 channels\n", worst_z);
    spc_medium_release(&m);
}

/* ------------------------------------------------------------------------------------------ */

TEST(radiance_conservation)
{
    const double Le = 1.5;
    spc_scene *sc = spc_scene_create();
    spc_medium *m = spc_scene_new_medium(sc);
    CHECK(m != NULL);
    if (!m) {
        spc_scene_destroy(sc);
        return;
    }
    spc_medium tmp;
    make_medium(&tmp, false, 13);
    int index = m->index;
    *m = tmp; /* the scene's medium now owns the grid */
    m->index = index;
    m->albedo = spc_rgb1(1.0);
    m->phase.type = SPC_PHASE_HG;
    m->phase.g = 0.4;
    spc_shape *sh = spc_scene_new_shape(sc);
    spc_error err;
    spc_shape_init_sphere(sh, spc_v3(0.1, -0.2, 0.3), 1.2, NULL, NULL, 0, 0, &err);
    sh->flip_normals = true;
    sh->bsdf = tu_diffuse(sc, 0.0);
    sh->interior_medium = sh->exterior_medium = m->index;
    tu_area(sc, sh, 0, Le);
    sc->camera_medium = m->index;
    tu_camera(sc, spc_v3(0.3, -0.1, 0.0), spc_v3(0.0, 0.3, 1.0), spc_v3(0, 1, 0), 90, 8, 8);
    sc->camera.near_clip = 1e-4;
    CHECK(spc_scene_finalize(sc, &err) == SPC_OK);
    spc_film *f = tu_render_nee(sc, "volpath", "none", 256, 2, 17, NULL);
    CHECK(f != NULL);
    for (int c = 0; f && c < 3; ++c) {
        double mean, se;
        tu_image_mean(f, c, &mean, &se);
        printf("  conservation: channel %d mean %.5f (se %.2g), Le %.2f\n", c, mean, se, Le);
        CHECK_MSG(fabs(mean - Le) <= 3.5 * se + 1e-9 && se < 0.02 * Le, "channel %d: %.5f +- %.2g, expected %.2f", c,
                  mean, se, Le);
    }
    spc_film_destroy(f);
    spc_scene_destroy(sc);
}

/* ------------------------------------------------------------------------------------------ */

/* Renders scenes/medium_grid.xml with cloud_scale `scale` at 32 pixels and compares it with the
 * Mitsuba reference: the pixel pass fraction and the largest |z| of the channels' image means. */
static bool against_mitsuba(const char *scale, double *pass, double *zmax)
{
    char scene[1024], ref[1024], msg[1200];
    snprintf(scene, sizeof scene, "%s/scenes/medium_grid.xml", source_dir());
    snprintf(ref, sizeof ref, "%s/tests/data/mitsuba_refs/medium_grid.exr", source_dir());
    spc_define defs[3] = {{"res", "32"}, {"integrator", "volpath"}, {"cloud_scale", scale}};
    spc_scene *s = NULL;
    spc_error err;
    if (spc_scene_load(scene, defs, 3, &s, &err) != SPC_OK) {
        spc_error_format(&err, msg, sizeof msg);
        printf("  %s\n", msg);
        return false;
    }
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 512;
    o.seed = 3;
    o.specular_nee = "none";
    spc_film *f = NULL;
    spc_render_stats st;
    spc_status rs = spc_render(s, &o, &f, &st, &err);
    spc_scene_destroy(s);
    spc_image_rgb r;
    if (rs != SPC_OK || spc_image_rgb_read(ref, &r, &err) != SPC_OK || !r.variance) {
        spc_film_destroy(f);
        return false;
    }
    spc_image_rgb a = {spc_film_width(f), spc_film_height(f), (float *)spc_film_rgb(f), (float *)spc_film_variance(f)};
    spc_diff_result dr;
    bool ok = spc_image_diff(&a, &r, &dr, &err) == SPC_OK && dr.has_ztest;
    *pass = ok ? dr.ztest_pass_fraction : 0.0;
    *zmax = 0.0;
    size_t n = (size_t)a.width * (size_t)a.height;
    for (int c = 0; ok && c < 3; ++c) {
        double da = 0.0, va = 0.0;
        for (size_t i = 0; i < n; ++i) {
            da += a.rgb[3 * i + c] - r.rgb[3 * i + c];
            va += a.variance[3 * i + c] + r.variance[3 * i + c];
        }
        *zmax = fmax(*zmax, fabs(da) / sqrt(va));
    }
    printf("  cloud_scale %s: pass %.2f%%, image mean |z| <= %.2f, specula (%.4f %.4f %.4f) mitsuba (%.4f %.4f %.4f)\n",
           scale, 100.0 * *pass, *zmax, dr.mean_a[0], dr.mean_a[1], dr.mean_a[2], dr.mean_b[0], dr.mean_b[1],
           dr.mean_b[2]);
    spc_image_rgb_release(&r);
    spc_film_destroy(f);
    return ok;
}

TEST(matches_mitsuba)
{
    double pass, z;
    CHECK(against_mitsuba("3", &pass, &z));
    CHECK_MSG(pass >= 0.9975, "%.4f of the pixels pass", pass);
    CHECK_MSG(z < 3.3, "image mean off by %.2f standard errors", z);
    /* power: a cloud 10% denser is caught by the image means (not repeated under the sanitizers'
     * quick mode, where one render is already slow) */
    if (spc_test_quick())
        return;
    CHECK(against_mitsuba("3.3", &pass, &z));
    CHECK_MSG(z > 5.0, "a 10%% denser cloud is only %.2f standard errors off", z);
}

/* ------------------------------------------------------------------------------------------ */

static spc_status load(const char *medium_xml, spc_error *err)
{
    char xml[4096];
    snprintf(xml, sizeof xml,
             "<scene version=\"3.0.0\">\n"
             "%s\n"
             "<shape type=\"sphere\"><ref name=\"interior\" id=\"m\"/></shape>\n"
             "</scene>\n",
             medium_xml);
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/scenes", source_dir());
    spc_scene *s = NULL;
    spc_status st = spc_mitsuba_load_string(xml, strlen(xml), "m.xml", dir, NULL, 0, &s, err);
    spc_scene_destroy(s);
    return st;
}

TEST(loader)
{
    spc_error err;
    char msg[1200];
    CHECK(load("<medium type=\"heterogeneous\" id=\"m\">\n<volume type=\"gridvolume\" name=\"sigma_t\">"
               "<string name=\"filename\" value=\"textures/cloud.vol\"/></volume>\n"
               "<volume type=\"gridvolume\" name=\"albedo\"><string name=\"filename\" value=\"textures/tint.vol\"/>"
               "</volume></medium>",
               &err) == SPC_OK);
    CHECK(load("<medium type=\"heterogeneous\" id=\"m\"><float name=\"sigma_t\" value=\"2\"/></medium>", &err) ==
          SPC_OK);
    CHECK(load("<medium type=\"heterogeneous\" id=\"m\">\n<volume type=\"gridvolume\" name=\"sigma_t\">\n"
               "<string name=\"filename\" value=\"textures/none.vol\"/></volume></medium>",
               &err) == SPC_ERR_IO);
    spc_error_format(&err, msg, sizeof msg);
    CHECK_MSG(strstr(msg, "m.xml:4:") && strstr(msg, "none.vol"), "%s", msg);
    CHECK(load("<medium type=\"homogeneous\" id=\"m\">\n<volume type=\"gridvolume\" name=\"sigma_t\">"
               "<string name=\"filename\" value=\"textures/cloud.vol\"/></volume></medium>",
               &err) == SPC_ERR_VALUE);
    spc_error_format(&err, msg, sizeof msg);
    CHECK_MSG(strstr(msg, "m.xml:3:") && strstr(msg, "heterogeneous"), "%s", msg);
    CHECK(load("<medium type=\"heterogeneous\" id=\"m\">\n<volume type=\"gridvolume\" name=\"albedo\">"
               "<string name=\"filename\" value=\"textures/cloud.vol\"/></volume></medium>",
               &err) == SPC_ERR_VALUE); /* cloud.vol's values exceed 1: not an albedo */
    spc_error_format(&err, msg, sizeof msg);
    CHECK_MSG(strstr(msg, "albedo") && strstr(msg, "[0, 1]"), "%s", msg);
    CHECK(load("<medium type=\"heterogeneous\" id=\"m\">\n<volume type=\"gridvolume\" name=\"sigma_t\">"
               "<string name=\"filename\" value=\"textures/cloud.vol\"/>\n"
               "<string name=\"wrap_mode\" value=\"tile\"/></volume></medium>",
               &err) == SPC_ERR_VALUE);
    spc_error_format(&err, msg, sizeof msg);
    CHECK_MSG(strstr(msg, "m.xml:4:") && strstr(msg, "wrap_mode 'tile'"), "%s", msg);
}

int main(void)
{
    (void)chi2_direction_test; /* chi2.h's direction sampler test has no use here */
    RUN(vol_files);
    RUN(lookups);
    RUN(optical_depth_is_exact);
    RUN(free_flight);
    RUN(radiance_conservation);
    RUN(matches_mitsuba);
    RUN(loader);
    return spc_test_finish();
}
