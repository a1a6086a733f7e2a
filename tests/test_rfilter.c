/*
 * tests/test_rfilter.c: the camera sample. The pixel filter's sampling against its CDF: the drawn
 * offset is the step a plain search of the cumulative masses finds, and the CDF maps it back to u.
 * The pinhole camera's ray through a film point against the camera's projection and clip planes.
 * The batch forms (filter offsets, camera rays) against the one-sample forms, bit for bit.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "harness.h"
#include "scene/camera.h"
#include "scene/rfilter.h"
#include "scene/scene.h"

/* The definition the sampler must meet: the last step k <= RES - 1 with filter_step_cdf[k] <= t. */
static int step_by_scan(const spc_film_spec *f, double t)
{
    int k = 0;
    for (int j = 1; j < SPC_FILTER_RESOLUTION; ++j)
        if (f->filter_step_cdf[j] <= t)
            k = j;
    return k;
}

static void check_filter(spc_rfilter_type type, double radius, double stddev)
{
    spc_film_spec f;
    memset(&f, 0, sizeof f);
    f.rfilter = type;
    f.filter_radius = radius;
    f.filter_stddev = stddev;
    spc_film_filter_prepare(&f);
    double h = radius / SPC_FILTER_RESOLUTION;
    enum { N = 4000 };
    /* a grid of u, then u exactly on every step's edge and on every guide bucket's edge, and one
     * ulp either side */
    double us[N + 6 * (SPC_FILTER_RESOLUTION + 1) + 6 * (SPC_FILTER_GUIDE + 1)];
    int n = 0;
    for (int i = 0; i < N; ++i)
        us[n++] = (i + 0.5) / N;
    for (int k = 0; k <= SPC_FILTER_RESOLUTION; ++k)
        for (int side = -1; side <= 1; side += 2) {
            double u = 0.5 + side * f.filter_step_cdf[k];
            us[n++] = u;
            us[n++] = nextafter(u, 0.0);
            us[n++] = nextafter(u, 1.0);
        }
    for (int b = 0; b <= SPC_FILTER_GUIDE; ++b)
        for (int side = -1; side <= 1; side += 2) {
            double u = 0.5 + side * (b / (2.0 * SPC_FILTER_GUIDE));
            us[n++] = u;
            us[n++] = nextafter(u, 0.0);
            us[n++] = nextafter(u, 1.0);
        }
    int bad_step = 0, bad_cdf = 0;
    for (int i = 0; i < n; ++i) {
        double u = us[i];
        if (!(u >= 0.0 && u <= 1.0))
            continue;
        double x = spc_film_filter_sample(&f, u, 0.0, -1e9, 1e9);
        double a = fabs(x), t = fabs(u - 0.5);
        int k = step_by_scan(&f, t);
        /* the offset lies in step k (its far end included where t is the whole half mass) */
        if (!(a >= k * h * (1.0 - 1e-12) && a <= (k + 1) * h * (1.0 + 1e-12)) || (u < 0.5 && x > 0.0) ||
            (u > 0.5 && x < 0.0))
            ++bad_step;
        if (fabs(spc_film_filter_cdf(&f, x) - u) > 1e-12 && fabs(a - radius) > 1e-12)
            ++bad_cdf;
    }
    CHECK_MSG(bad_step == 0, "%d of %d offsets outside the step the scan finds", bad_step, n);
    CHECK_MSG(bad_cdf == 0, "%d of %d offsets whose CDF is not u", bad_cdf, n);
}

TEST(gaussian_sample_matches_cdf) { check_filter(SPC_RFILTER_GAUSSIAN, 2.0, 0.5); }
TEST(gaussian_wide_sample_matches_cdf) { check_filter(SPC_RFILTER_GAUSSIAN, 4.0, 1.0); }
TEST(tent_sample_matches_cdf) { check_filter(SPC_RFILTER_TENT, 1.0, 0.5); }
TEST(box_sample_matches_cdf) { check_filter(SPC_RFILTER_BOX, 0.5, 0.5); }

/* A pinhole's ray through film point (fx, fy): unit direction, from the pinhole, projecting back
 * onto (fx, fy), its ends at the local depths near_clip and far_clip, and its direction that of
 * to_world applied to ((1 - 2 fx/W) tan_x, (1 - 2 fy/H) tan_y, 1), under a rotated, translated
 * and non-uniformly scaled to_world. */
TEST(pinhole_ray_through_film_point)
{
    spc_camera c;
    memset(&c, 0, sizeof c);
    c.type = SPC_CAMERA_PERSPECTIVE;
    spc_mat4 look, S = spc_mat4_scale(spc_v3(1.5, 0.7, 2.0));
    CHECK(spc_mat4_lookat(spc_v3(1, 2, 3), spc_v3(-0.5, 0.3, 0.2), spc_v3(0.1, 1, 0), &look));
    c.to_world = spc_mat4_mul(&look, &S);
    c.fov = 38.0;
    c.fov_axis = SPC_FOV_X;
    c.near_clip = 0.01;
    c.far_clip = 500.0;
    spc_camera_state cs;
    const int W = 96, H = 54;
    CHECK(spc_camera_prepare(&cs, &c, W, H));
    double worst_proj = 0.0, worst_clip = 0.0, worst_dir = 0.0;
    for (int i = 0; i < 4000; ++i) {
        double fx = W * ((i % 61) + 0.37) / 61.0, fy = H * ((i / 61) + 0.61) / 66.0;
        spc_ray r = spc_camera_ray(&cs, fx, fy);
        CHECK_NEAR(spc_length(r.d), 1.0, 1e-14);
        CHECK(r.o.x == cs.origin.x && r.o.y == cs.origin.y && r.o.z == cs.origin.z);
        double px, py;
        CHECK(spc_camera_project(&cs, spc_madd(r.o, r.d, 3.0), &px, &py));
        worst_proj = fmax(worst_proj, fmax(fabs(px - fx), fabs(py - fy)));
        spc_vec3 a = spc_mat4_apply_point(&cs.to_local, spc_madd(r.o, r.d, r.tmin));
        spc_vec3 b = spc_mat4_apply_point(&cs.to_local, spc_madd(r.o, r.d, r.tmax));
        worst_clip = fmax(worst_clip, fmax(fabs(a.z - c.near_clip) / c.near_clip, fabs(b.z - c.far_clip) / c.far_clip));
        spc_vec3 v = spc_v3((1.0 - 2.0 * fx / W) * cs.tan_x, (1.0 - 2.0 * fy / H) * cs.tan_y, 1.0);
        spc_vec3 d = spc_normalize(spc_mat4_apply_vector(&cs.to_world, v));
        worst_dir = fmax(worst_dir, spc_length(spc_sub(d, r.d)));
    }
    CHECK_MSG(worst_proj < 1e-9, "projection off by %g pixels", worst_proj);
    CHECK_MSG(worst_clip < 1e-12, "clip depths off by %g relative", worst_clip);
    CHECK_MSG(worst_dir < 1e-14, "direction off by %g", worst_dir);
}

/* spc_film_filter_sample_many gives spc_film_filter_sample's offsets bit for bit: tent, gaussians
 * (one whose scan is too long for the vector loop) and box; u on a grid, on every step's and guide
 * bucket's edge and one ulp either side; pixel centres inside a window, near its edges and away
 * from them; counts that are not a multiple of a vector. Run under every ISA by
 * camera_rays_many_match_one_at_a_time. */
TEST(filter_samples_many_match_one_at_a_time)
{
    const double params[4][3] = {{SPC_RFILTER_TENT, 1.0, 0.5}, {SPC_RFILTER_GAUSSIAN, 2.0, 0.5},
                                 {SPC_RFILTER_GAUSSIAN, 4.0, 1.0}, {SPC_RFILTER_BOX, 0.5, 0.5}};
    int bad = 0, total = 0;
    for (int p = 0; p < 4; ++p) {
        spc_film_spec f;
        memset(&f, 0, sizeof f);
        f.rfilter = (spc_rfilter_type)params[p][0];
        f.filter_radius = params[p][1];
        f.filter_stddev = params[p][2];
        spc_film_filter_prepare(&f);
        enum { G = 1001, M = G + 6 * (SPC_FILTER_RESOLUTION + 1) + 6 * (SPC_FILTER_GUIDE + 1) + 2 };
        static double u[M], c[M], x[M];
        int n = 0;
        for (int i = 0; i < G; ++i)
            u[n++] = (i + 0.5) / G;
        for (int k = 0; k <= SPC_FILTER_RESOLUTION; ++k)
            for (int side = -1; side <= 1; side += 2) {
                double e = 0.5 + side * f.filter_step_cdf[k];
                u[n++] = e;
                u[n++] = nextafter(e, 0.0);
                u[n++] = nextafter(e, 1.0);
            }
        for (int b = 0; b <= SPC_FILTER_GUIDE; ++b)
            for (int side = -1; side <= 1; side += 2) {
                double e = 0.5 + side * (b / (2.0 * SPC_FILTER_GUIDE));
                u[n++] = e;
                u[n++] = nextafter(e, 0.0);
                u[n++] = nextafter(e, 1.0);
            }
        u[n++] = 0.0;
        u[n++] = 1.0;
        for (int i = 0; i < n; ++i)
            u[i] = u[i] < 0.0 ? 0.0 : u[i] > 1.0 ? 1.0 : u[i];
        /* the window [3, 15): pixel centres 3.5 .. 14.5, the outer ones' supports crossing its edges */
        for (int i = 0; i < n; ++i)
            c[i] = 3.5 + (i * 7) % 12;
        for (int m = n; m > 0; m = m > 40 ? m / 3 : m - 13) {
            spc_film_filter_sample_many(&f, m, u, c, 3.0, 15.0, x);
            for (int i = 0; i < m; ++i) {
                double one = spc_film_filter_sample(&f, u[i], c[i], 3.0, 15.0);
                bad += memcmp(&one, &x[i], sizeof one) != 0;
                ++total;
            }
        }
    }
    CHECK_MSG(bad == 0, "%d of %d offsets differ", bad, total);
}

/* spc_camera_ray_many gives spc_camera_ray's rays bit for bit (perspective and orthographic, counts
 * that cross its batch of 64, film points inside and outside the film); with every ISA it is built
 * for, each in a child process of this program (SPECULA_VECTOR_ISA caps the one a process picks). */
TEST(camera_rays_many_match_one_at_a_time)
{
    int bad = 0;
    for (int type = 0; type < 2; ++type) {
        spc_camera c;
        memset(&c, 0, sizeof c);
        c.type = type ? SPC_CAMERA_ORTHOGRAPHIC : SPC_CAMERA_PERSPECTIVE;
        spc_mat4 look, S = spc_mat4_scale(spc_v3(1.5, 0.7, 2.0));
        CHECK(spc_mat4_lookat(spc_v3(1, 2, 3), spc_v3(-0.5, 0.3, 0.2), spc_v3(0.1, 1, 0), &look));
        c.to_world = spc_mat4_mul(&look, &S);
        c.fov = 38.0;
        c.fov_axis = SPC_FOV_X;
        c.near_clip = 0.01;
        c.far_clip = 500.0;
        spc_camera_state cs;
        const int W = 96, H = 54;
        CHECK(spc_camera_prepare(&cs, &c, W, H));
        enum { N = 300 };
        double fx[N], fy[N];
        spc_ray r[N];
        for (int i = 0; i < N; ++i) {
            fx[i] = W * ((i % 17) - 2.3) / 13.0;
            fy[i] = H * ((i / 17) + 0.61) / 16.0;
        }
        for (int n = 0; n <= N; n += n < 70 ? 1 : 77) {
            spc_camera_ray_many(&cs, n, fx, fy, r);
            for (int i = 0; i < n; ++i) {
                spc_ray one = spc_camera_ray(&cs, fx[i], fy[i]);
                bad += memcmp(&one.o, &r[i].o, sizeof one.o) || memcmp(&one.d, &r[i].d, sizeof one.d) ||
                       memcmp(&one.tmin, &r[i].tmin, sizeof one.tmin) || memcmp(&one.tmax, &r[i].tmax, sizeof one.tmax);
            }
        }
    }
    CHECK_MSG(bad == 0, "%d rays differ", bad);
    if (getenv("SPECULA_VECTOR_ISA"))
        return;
    const char *const isas[] = {"base", "avx2"};
    spc_t_under_isas("camera_rays_many_match_one_at_a_time,filter_samples_many_match_one_at_a_time", isas, 2);
}

int main(void)
{
    RUN(gaussian_sample_matches_cdf);
    RUN(gaussian_wide_sample_matches_cdf);
    RUN(tent_sample_matches_cdf);
    RUN(box_sample_matches_cdf);
    RUN(pinhole_ray_through_film_point);
    RUN(filter_samples_many_match_one_at_a_time);
    RUN(camera_rays_many_match_one_at_a_time);
    return spc_test_finish();
}
