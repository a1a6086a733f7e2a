/*
 * tests/test_core.c: transforms, the sampler's stratification and determinism, warping densities,
 * discrete distributions.
 */
/* ctest-labels: unit */
#include <string.h>
#include <unistd.h>

#include "core/math.h"
#include "core/rng.h"
#include "core/sampler.h"
#include "core/warp.h"

#include "harness.h"

TEST(mat4_inverse_and_lookat)
{
    spc_mat4 R = spc_mat4_rotate(spc_v3(1, 2, 3), 37.0);
    spc_mat4 T = spc_mat4_translate(spc_v3(1, -2, 5));
    spc_mat4 S = spc_mat4_scale(spc_v3(2, 3, 0.5));
    spc_mat4 M = spc_mat4_mul(&T, &R);
    M = spc_mat4_mul(&M, &S);
    spc_mat4 Mi;
    CHECK(spc_mat4_inverse(&M, &Mi));
    spc_mat4 I = spc_mat4_mul(&M, &Mi);
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            CHECK_NEAR(I.m[i][j], i == j ? 1.0 : 0.0, 1e-12);
    /* rotation by 90 degrees about z maps x to y (right-handed) */
    spc_mat4 Rz = spc_mat4_rotate(spc_v3(0, 0, 1), 90.0);
    spc_vec3 y = spc_mat4_apply_vector(&Rz, spc_v3(1, 0, 0));
    CHECK_NEAR(y.x, 0.0, 1e-12);
    CHECK_NEAR(y.y, 1.0, 1e-12);
    /* lookat: +z toward the target, +x = up x dir (image left) */
    spc_mat4 L;
    CHECK(spc_mat4_lookat(spc_v3(0, 0, 5), spc_v3(0, 0, 0), spc_v3(0, 1, 0), &L));
    spc_vec3 dz = spc_mat4_apply_vector(&L, spc_v3(0, 0, 1));
    spc_vec3 dx = spc_mat4_apply_vector(&L, spc_v3(1, 0, 0));
    CHECK_NEAR(dz.z, -1.0, 1e-12);
    CHECK_NEAR(dx.x, -1.0, 1e-12);
    spc_mat4 Z;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            Z.m[i][j] = 0.0;
    CHECK(!spc_mat4_inverse(&Z, &Mi));
    /* normals by the inverse transpose stay perpendicular to transformed tangents */
    spc_vec3 t = spc_v3(1, 1, 0), n = spc_v3(1, -1, 0.3);
    t = spc_sub(t, spc_scale(n, spc_dot(t, n) / spc_dot(n, n)));
    spc_mat4_inverse(&M, &Mi);
    CHECK_NEAR(spc_dot(spc_mat4_apply_vector(&M, t), spc_mat4_apply_normal(&Mi, n)), 0.0, 1e-12);
}

TEST(frames_orthonormal)
{
    spc_rng r;
    spc_rng_seed(&r, 1, 2);
    for (int i = 0; i < 1000; ++i) {
        spc_vec3 n = spc_warp_uniform_sphere(spc_v2(spc_rng_next(&r), spc_rng_next(&r)));
        spc_frame f = spc_frame_from_n(n);
        CHECK_NEAR(spc_dot(f.s, f.t), 0.0, 1e-12);
        CHECK_NEAR(spc_dot(f.s, f.n), 0.0, 1e-12);
        CHECK_NEAR(spc_length(f.s), 1.0, 1e-12);
        CHECK_NEAR(spc_length(f.t), 1.0, 1e-12);
        CHECK(spc_dot(spc_cross(f.s, f.t), f.n) > 0.999999);
    }
}

/* Each 2D dimension of a pixel's stream is stratified: for N = 4^k samples, every cell of an
 * (2^k x 2^k) grid holds exactly one point (a (0,2)-sequence property), in every dimension. */
TEST(sampler_stratified_and_deterministic)
{
    const int N = 256, G = 16;
    for (int dim = 0; dim < 6; ++dim) {
        int counts[16 * 16] = {0};
        for (int i = 0; i < N; ++i) {
            spc_sampler s;
            spc_sampler_start(&s, 7, 11, (uint32_t)i, 42);
            spc_vec2 u = spc_v2(0, 0);
            for (int d = 0; d <= dim; ++d)
                u = spc_sampler_2d(&s);
            CHECK(u.x >= 0.0 && u.x < 1.0 && u.y >= 0.0 && u.y < 1.0);
            counts[(int)(u.y * G) * G + (int)(u.x * G)]++;
        }
        int bad = 0;
        for (int c = 0; c < G * G; ++c)
            bad += counts[c] != 1;
        CHECK_MSG(bad == 0, "dimension %d: %d cells without exactly one point", dim, bad);
    }
    spc_sampler a, b, c;
    spc_sampler_start(&a, 3, 4, 5, 6);
    spc_sampler_start(&b, 3, 4, 5, 6);
    spc_sampler_start(&c, 3, 4, 5, 7);
    double va = spc_sampler_1d(&a), vb = spc_sampler_1d(&b), vc = spc_sampler_1d(&c);
    CHECK(va == vb);
    CHECK(va != vc);
    /* different pixels are decorrelated: the mean of the products is near 1/4 */
    double acc = 0.0;
    for (int i = 0; i < 4096; ++i) {
        spc_sampler p, q;
        spc_sampler_start(&p, (uint32_t)i, 0, 0, 1);
        spc_sampler_start(&q, (uint32_t)i + 1, 0, 0, 1);
        acc += spc_sampler_1d(&p) * spc_sampler_1d(&q);
    }
    CHECK_NEAR(acc / 4096.0, 0.25, 0.02);
}

/* Each aligned block of 2^10 consecutive samples of a pixel's stream is a (0,10,2)-net in every
 * dimension pair: every elementary interval of area 2^-10 (2^a by 2^(10-a) cells, a = 0..10) holds
 * exactly one point. This needs the second coordinate to be the Sobol (Pascal matrix) dimension of
 * the first's index: a different generator matrix breaks it in some of the 11 grids. */
TEST(sampler_blocks_are_02_nets)
{
    enum { M = 10, N = 1 << M };
    static unsigned char counts[N];
    int bad = 0;
    for (int block = 0; block < 2; ++block)
        for (int dim = 0; dim < 4; ++dim) {
            spc_vec2 u[N];
            for (int i = 0; i < N; ++i) {
                spc_sampler s;
                spc_sampler_start(&s, 5, 9 + (uint32_t)block, (uint32_t)(block * N + i), 77);
                for (int d = 0; d <= dim; ++d)
                    u[i] = spc_sampler_2d(&s);
            }
            for (int a = 0; a <= M; ++a) {
                memset(counts, 0, sizeof counts);
                for (int i = 0; i < N; ++i) {
                    int cx = (int)(u[i].x * (double)(1 << a)), cy = (int)(u[i].y * (double)(1 << (M - a)));
                    counts[(cy << a) + cx]++;
                }
                for (int c = 0; c < N; ++c)
                    bad += counts[c] != 1;
            }
        }
    CHECK_MSG(bad == 0, "%d elementary intervals without exactly one point", bad);
}

/* Many streams at once (spc_sampler_2d_many, spc_sampler_draw_many with every mask of the pairs
 * that need their y) give the one-pair calls' values bit for bit and move each stream as they do;
 * a pair without its y gets 0 there; lanes without a stream are left alone. Sizes cross the batch's
 * internal flush (128 pairs). */
TEST(sampler_many_matches_one_at_a_time)
{
    int bad = 0, checked = 0;
    for (int n = 1; n <= 53; n += 13)
        for (int npairs = 1; npairs <= 5; ++npairs) /* the path wave draws 5 */
            for (unsigned mask = 0; mask <= 1u << npairs; ++mask) {
                /* mask 1 << npairs: spc_sampler_2d_many */
                bool all = mask == 1u << npairs;
                spc_sampler a[53], b[53];
                spc_sampler *pa[53];
                spc_vec2 u[265];
                for (int i = 0; i < n; ++i) {
                    spc_sampler_start(&a[i], (uint32_t)i, 5, (uint32_t)(i * 7 + n), 11);
                    for (int k = 0; k < i % 4; ++k) /* streams at different dimensions */
                        spc_sampler_1d(&a[i]);
                    b[i] = a[i];
                    pa[i] = i % 5 == 3 ? NULL : &a[i];
                }
                for (int round = 0; round < 3; ++round) {
                    if (all)
                        spc_sampler_2d_many(pa, n, npairs, u);
                    else
                        spc_sampler_draw_many(pa, n, npairs, mask, u);
                    for (int i = 0; i < n; ++i) {
                        if (!pa[i]) {
                            bad += a[i].dim != b[i].dim;
                            continue;
                        }
                        for (int k = 0; k < npairs; ++k) {
                            spc_vec2 v = spc_sampler_2d(&b[i]);
                            double y = all || (mask >> k & 1u) ? v.y : 0.0;
                            bad += v.x != u[i * npairs + k].x || y != u[i * npairs + k].y;
                            ++checked;
                        }
                        bad += a[i].dim != b[i].dim;
                    }
                }
            }
    CHECK_MSG(bad == 0, "%d of %d pairs or stream positions differ", bad, checked);
    CHECK(checked > 2000);
}

/* spc_sampler_draw_many_used: the pairs a stream reads (its use bits, different per stream) are the
 * one-pair calls' values bit for bit, the pairs it does not read are left as they were, and every
 * stream moves past all its pairs, so the next draw is the same as after spc_sampler_draw_many.
 * Sizes cross the batch's internal flush (128 pairs) and the grouping's chunk (256 streams); use NULL
 * reads every pair; up to 7 pairs, so up to 128 masks, each stream's group split off the list of
 * those left. Every other call is spc_sampler_draw_many_used_by_pair's (pair k of stream i in
 * u[k ldu + i]), the same values in the other layout. */
TEST(sampler_many_used_matches_one_at_a_time)
{
    int bad = 0, checked = 0, skipped = 0;
    const double mark = -7.0;
    enum { NMAX = 271 }; /* odd: round 2 also reads use NULL */
    for (int n = 1; n <= NMAX; n = n < 79 ? n + 13 : NMAX + (n == NMAX)) /* 1, 14, ..., 79, then 271 */
        for (int npairs = 1; npairs <= 7; ++npairs)
            for (unsigned ymask = 0; ymask < 1u << npairs; ymask += 1u + (unsigned)npairs * (unsigned)npairs / 4u) {
                spc_sampler a[NMAX], b[NMAX];
                spc_sampler *pa[NMAX];
                unsigned use[NMAX];
                spc_vec2 u[(NMAX + 2) * 7];
                for (int i = 0; i < n; ++i) {
                    spc_sampler_start(&a[i], (uint32_t)i, 9, (uint32_t)(i * 3 + n), 4);
                    for (int k = 0; k < i % 3; ++k) /* streams at different dimensions */
                        spc_sampler_1d(&a[i]);
                    b[i] = a[i];
                    pa[i] = i % 7 == 5 ? NULL : &a[i];
                }
                for (int round = 0; round < 3; ++round) {
                    for (int i = 0; i < n; ++i) /* every mask, the empty one and the full one included */
                        use[i] = (unsigned)(i * 11 + round * 5 + npairs) % (1u << npairs);
                    const bool by_pair = (round + npairs) % 2 == 1;
                    const int ldu = n + 2;
                    for (int j = 0; j < ldu * npairs; ++j)
                        u[j] = spc_v2(mark, mark);
                    if (by_pair)
                        spc_sampler_draw_many_used_by_pair(pa, round == 2 && n % 2 ? NULL : use, n, npairs, ymask, u,
                                                           ldu);
                    else
                        spc_sampler_draw_many_used(pa, round == 2 && n % 2 ? NULL : use, n, npairs, ymask, u);
                    for (int i = 0; i < n; ++i) {
                        if (!pa[i]) {
                            bad += a[i].dim != b[i].dim;
                            continue;
                        }
                        for (int k = 0; k < npairs; ++k) {
                            spc_vec2 v = spc_sampler_2d(&b[i]), w = by_pair ? u[k * ldu + i] : u[i * npairs + k];
                            if (round == 2 && n % 2 ? false : !(use[i] >> k & 1u)) {
                                bad += w.x != mark || w.y != mark;
                                ++skipped;
                                continue;
                            }
                            bad += v.x != w.x || (ymask >> k & 1u ? v.y : 0.0) != w.y;
                            ++checked;
                        }
                        bad += a[i].dim != b[i].dim;
                    }
                }
            }
    CHECK_MSG(bad == 0, "%d pairs or stream positions differ (%d checked, %d skipped)", bad, checked, skipped);
    CHECK(checked > 2000 && skipped > 1000);
}

/* spc_warp_cosine_hemisphere_many gives the one-at-a-time warp's directions bit for bit: random
 * points, the center (the disk's origin), both diagonals (|a| = |b|, where the octant flips), the
 * square's edges and corners, and counts that cross the batch (64). */
TEST(cosine_hemisphere_many_matches_one_at_a_time)
{
    enum { N = 1000 };
    spc_vec2 u[N];
    spc_vec3 w[N];
    spc_rng rng;
    spc_rng_seed(&rng, 3, 9);
    for (int i = 0; i < N; ++i) {
        double x = spc_rng_next(&rng), y = spc_rng_next(&rng);
        switch (i % 8) {
        case 0: y = x; break;       /* a = b */
        case 1: y = 1.0 - x; break; /* a = -b */
        case 2: x = i % 16 < 8 ? 0.0 : 0x1.fffffffffffffp-1; break;
        case 3: x = 0.5; break;
        default: break;
        }
        u[i] = spc_v2(x, y);
    }
    u[7] = spc_v2(0.5, 0.5);
    u[15] = spc_v2(0.0, 0.0);
    u[23] = spc_v2(0.0, 0x1.fffffffffffffp-1);
    int bad = 0;
    for (int n = 0; n <= N; n += n < 70 ? 1 : 331) {
        spc_warp_cosine_hemisphere_many(n, u, w);
        for (int i = 0; i < n; ++i) {
            spc_vec3 v = spc_warp_cosine_hemisphere(u[i]);
            bad += memcmp(&v, &w[i], sizeof v) != 0;
        }
    }
    CHECK_MSG(bad == 0, "%d directions differ", bad);
}

/* A row's streams started at once equal spc_sampler_start's, field for field, for rows that are no
 * multiple of the pass (64) and pixel coordinates near 2^32. */
TEST(sampler_start_row_matches_start)
{
    spc_rng r;
    spc_rng_seed(&r, 8, 1);
    int bad = 0, checked = 0;
    spc_sampler a[150], b;
    for (int round = 0; round < 40; ++round) {
        int n = 1 + (int)(spc_rng_next(&r) * 150);
        uint32_t px0 = round % 5 == 4 ? 0xffffff80u : (uint32_t)(spc_rng_next(&r) * 4096);
        uint32_t py = (uint32_t)(spc_rng_next(&r) * 4096), index = (uint32_t)(spc_rng_next(&r) * 1e9);
        uint64_t seed = (uint64_t)(spc_rng_next(&r) * 1e18);
        spc_sampler_start_row(a, n, px0, py, index, seed);
        for (int i = 0; i < n; ++i) {
            spc_sampler_start(&b, px0 + (uint32_t)i, py, index, seed);
            bad += a[i].pixel_seed != b.pixel_seed || a[i].index != b.index || a[i].index_rev != b.index_rev ||
                   a[i].dim != b.dim;
            ++checked;
        }
    }
    CHECK_MSG(bad == 0, "%d of %d streams differ", bad, checked);
}

/* The same under the other instruction sets the batches are compiled for (SPECULA_VECTOR_ISA caps
 * the one the process picks, so each runs in a child process of this program). */
TEST(vector_batches_every_isa)
{
    const char *const isas[] = {"base", "avx2", "avx512", "avx512gfni"};
    spc_t_under_isas("sampler_many_matches_one_at_a_time,sampler_many_used_matches_one_at_a_time,"
                     "sampler_start_row_matches_start,cosine_hemisphere_many_matches_one_at_a_time", isas, 4);
}

/* Monte Carlo integral of f / pdf over the warped samples equals the integral of f. */
TEST(warps_match_their_pdfs)
{
    spc_rng r;
    spc_rng_seed(&r, 3, 4);
    const int N = 200000;
    double cos_acc = 0.0, cone_acc = 0.0, sph = 0.0, tri = 0.0;
    double cos_max = 0.8;
    for (int i = 0; i < N; ++i) {
        spc_vec2 u = spc_v2(spc_rng_next(&r), spc_rng_next(&r));
        spc_vec3 w = spc_warp_cosine_hemisphere(u);
        CHECK_NEAR(spc_length(w), 1.0, 1e-12);
        cos_acc += 1.0 / spc_warp_cosine_hemisphere_pdf(w); /* integral of 1 over the hemisphere */
        spc_vec3 c = spc_warp_uniform_cone(u, cos_max);
        CHECK(c.z >= cos_max - 1e-12);
        cone_acc += c.z / spc_warp_uniform_cone_pdf(cos_max);
        spc_vec3 s = spc_warp_uniform_sphere(u);
        sph += s.z * s.z * 4.0 * SPC_PI;
        spc_vec2 b = spc_warp_uniform_triangle(u);
        CHECK(b.x >= 0 && b.y >= 0 && b.x + b.y <= 1.0 + 1e-12);
        tri += b.x; /* mean barycentric is 1/3 */
    }
    CHECK_NEAR(cos_acc / N, 2.0 * SPC_PI, 0.05);
    CHECK_NEAR(cone_acc / N, SPC_PI * (1.0 - cos_max * cos_max), 0.01);
    CHECK_NEAR(sph / N, 4.0 * SPC_PI / 3.0, 0.03);
    CHECK_NEAR(tri / N, 1.0 / 3.0, 0.003);
}

/* The warps' sin and cos without libm: spc_sincos_2pi within 2 half-ulps of 1 of the exact sin and cos
 * of 2 pi u over [0, 1] and beyond it, exact at the quarter turns; spc_sincos_quarter within 2 ulps relative on
 * [-pi/4, pi/4]; and the concentric disk map equal to its form with libm's cos and sin. */
TEST(sincos_without_libm)
{
    spc_rng r;
    spc_rng_seed(&r, 5, 6);
    double worst = 0.0, worst_rel = 0.0, worst_disk = 0.0;
    for (int i = 0; i < 200000; ++i) {
        double u = spc_rng_next(&r);
        if (i % 3 == 1)
            u = 6.0 * u - 3.0;
        double s, c;
        spc_sincos_2pi(u, &s, &c);
        /* in long double: libm's double 2 pi u is itself rounded by up to 1.8e-15 at |u| = 3 */
        long double a = 2.0L * 3.141592653589793238462643383279503L * (long double)u;
        worst = fmax(worst, fmax(fabs((double)(s - sinl(a))), fabs((double)(c - cosl(a)))));
        double x = (spc_rng_next(&r) - 0.5) * (SPC_PI / 2.0);
        spc_sincos_quarter(x, &s, &c);
        if (x != 0.0)
            worst_rel = fmax(worst_rel, fabs(s - sin(x)) / fabs(sin(x)));
        worst_rel = fmax(worst_rel, fabs(c - cos(x)) / cos(x));
        spc_vec2 v = spc_v2(spc_rng_next(&r), spc_rng_next(&r));
        spc_vec2 d = spc_warp_disk_concentric(v);
        double p = 2.0 * v.x - 1.0, q = 2.0 * v.y - 1.0, rr, phi;
        if (fabs(p) > fabs(q)) {
            rr = p;
            phi = (SPC_PI / 4.0) * (q / p);
        } else {
            rr = q;
            phi = SPC_PI / 2.0 - (SPC_PI / 4.0) * (p / q);
        }
        worst_disk = fmax(worst_disk, fmax(fabs(d.x - rr * cos(phi)), fabs(d.y - rr * sin(phi))));
    }
    CHECK_MSG(worst <= 2.0 * 0x1p-53, "sincos_2pi off by %g", worst);
    CHECK_MSG(worst_rel <= 2.0 * 0x1p-52, "sincos_quarter off by %g relative", worst_rel);
    CHECK_MSG(worst_disk <= 1e-15, "concentric disk off by %g", worst_disk);
    const double quarter[][3] = {{0.0, 0.0, 1.0}, {0.25, 1.0, 0.0}, {0.5, 0.0, -1.0},
                                 {0.75, -1.0, 0.0}, {1.0, 0.0, 1.0}, {-0.25, -1.0, 0.0}};
    for (int k = 0; k < 6; ++k) {
        double s, c;
        spc_sincos_2pi(quarter[k][0], &s, &c);
        CHECK(s == quarter[k][1] && c == quarter[k][2]);
    }
}

TEST(tent_and_gaussian_inversions)
{
    /* tent: the CDF at x is 1/2 (1+x)^2 on [-1, 0] */
    CHECK_NEAR(spc_warp_tent(0.5 * 0.25), -0.5, 1e-12);
    CHECK_NEAR(spc_warp_tent(0.5), 0.0, 1e-12);
    CHECK_NEAR(spc_warp_tent(1.0 - 0.5 * 0.25), 0.5, 1e-12);
    for (double x = -0.99; x < 1.0; x += 0.11)
        CHECK_NEAR(erf(spc_erfinv(x)), x, 1e-12);
    /* truncated gaussian: median 0, quartiles at the normal quantile scaled by truncation */
    CHECK_NEAR(spc_warp_gaussian_truncated(0.5, 0.5, 2.0), 0.0, 1e-12);
    double q = spc_warp_gaussian_truncated(0.75, 0.5, 2.0);
    double s = 0.5 * sqrt(2.0);
    CHECK_NEAR(erf(q / s), 0.5 * erf(2.0 / s), 1e-10);
}

/* The index and remapped u of spc_distrib1d_sample by a plain linear search: the largest i with
 * cdf[i] <= u, then off empty bins (forward, else back), u rescaled within the bin. */
static size_t distrib_linear(const spc_distrib1d *d, double u, double *u_remap)
{
    size_t lo = 0;
    for (size_t i = 1; i < d->n; ++i)
        if (d->cdf[i] <= u)
            lo = i;
    while (lo + 1 < d->n && d->pmf[lo] == 0.0)
        ++lo;
    while (lo > 0 && d->pmf[lo] == 0.0)
        --lo;
    double r = d->pmf[lo] > 0.0 ? (u - d->cdf[lo]) / d->pmf[lo] : 0.0;
    *u_remap = spc_clamp(r, 0.0, 0x1.fffffffffffffp-1);
    return lo;
}

/* spc_distrib1d_sample equals the linear search, index and remapped u bit for bit, on weights with
 * and without empty bins (which it steps over only where there are any), at the bins' edges and
 * at random u. */
TEST(distrib_search_matches_linear)
{
    spc_rng r;
    spc_rng_seed(&r, 4, 2);
    int differ = 0, with_empty = 0, samples = 0;
    for (int round = 0; round < 400; ++round) {
        /* both searches: counting up to SPC_DISTRIB1D_COUNT_MAX entries, bisection beyond */
        size_t n = 1 + (size_t)(spc_rng_next(&r) * (round % 4 == 3 ? 40 : 12));
        double w[40];
        for (size_t i = 0; i < n; ++i)
            w[i] = round % 2 && spc_rng_next(&r) < 0.3 ? 0.0 : spc_rng_next(&r) + (round % 3 == 0 ? 0.0 : 0.01);
        spc_distrib1d d;
        if (!spc_distrib1d_init(&d, w, n))
            continue;
        with_empty += d.has_empty;
        for (int k = 0; k < 200; ++k) {
            double u = k < (int)n ? d.cdf[k] : k < 2 * (int)n ? nextafter(d.cdf[k - n], 0.0) : spc_rng_next(&r);
            double ua, ub;
            size_t a = spc_distrib1d_sample(&d, u, &ua), b = distrib_linear(&d, u, &ub);
            differ += a != b || memcmp(&ua, &ub, sizeof ua) != 0;
            ++samples;
        }
        spc_distrib1d_release(&d);
    }
    printf("  %d samples (%d distributions with empty bins): %d differ\n", samples, with_empty, differ);
    CHECK(with_empty > 50 && samples > 60000);
    CHECK(differ == 0);
}

TEST(distributions)
{
    double w[5] = {1, 0, 3, 0, 4};
    spc_distrib1d d;
    CHECK(spc_distrib1d_init(&d, w, 5));
    CHECK_NEAR(d.sum, 8.0, 1e-15);
    int counts[5] = {0};
    for (int i = 0; i < 8000; ++i) {
        double ur;
        size_t k = spc_distrib1d_sample(&d, (i + 0.5) / 8000.0, &ur);
        CHECK(ur >= 0.0 && ur < 1.0);
        counts[k]++;
    }
    CHECK(counts[0] == 1000 && counts[1] == 0 && counts[2] == 3000 && counts[3] == 0 && counts[4] == 4000);
    spc_distrib1d_release(&d);
    double z[2] = {0, 0};
    CHECK(!spc_distrib1d_init(&d, z, 2));
    double nanw[2] = {1, NAN};
    CHECK(!spc_distrib1d_init(&d, nanw, 2));

    double img[6] = {1, 2, 0, 0, 3, 4}; /* 3 x 2 */
    spc_distrib2d d2;
    CHECK(spc_distrib2d_init(&d2, img, 3, 2));
    spc_rng r;
    spc_rng_seed(&r, 9, 9);
    double acc = 0.0;
    for (int i = 0; i < 20000; ++i) {
        double pdf;
        spc_vec2 p = spc_distrib2d_sample(&d2, spc_v2(spc_rng_next(&r), spc_rng_next(&r)), &pdf);
        CHECK_NEAR(pdf, spc_distrib2d_pdf(&d2, p), 1e-9);
        acc += 1.0 / pdf; /* integral of 1 over the support */
    }
    /* support: 4 non-zero cells of area 1/6 */
    CHECK_NEAR(acc / 20000.0, 4.0 / 6.0, 0.02);
    spc_distrib2d_release(&d2);
}

int main(void)
{
    RUN(mat4_inverse_and_lookat);
    RUN(frames_orthonormal);
    RUN(sampler_stratified_and_deterministic);
    RUN(sampler_blocks_are_02_nets);
    RUN(sampler_many_matches_one_at_a_time);
    RUN(sampler_many_used_matches_one_at_a_time);
    RUN(cosine_hemisphere_many_matches_one_at_a_time);
    RUN(vector_batches_every_isa);
    RUN(warps_match_their_pdfs);
    RUN(sincos_without_libm);
    RUN(tent_and_gaussian_inversions);
    RUN(distributions);
    RUN(distrib_search_matches_linear);
    RUN(sampler_start_row_matches_start);
    return spc_test_finish();
}
