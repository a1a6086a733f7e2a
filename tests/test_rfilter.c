/*
 * tests/test_rfilter.c: the pixel filter's sampling against its CDF: the drawn offset is the step
 * a plain search of the cumulative masses finds, and the CDF maps it back to u.
 */
/* ctest-labels: unit */
#include <math.h>
#include <string.h>

#include "harness.h"
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
    /* a grid of u, then u exactly on every step's edge and one ulp either side */
    double us[N + 6 * (SPC_FILTER_RESOLUTION + 1)];
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

int main(void)
{
    RUN(gaussian_sample_matches_cdf);
    RUN(gaussian_wide_sample_matches_cdf);
    RUN(tent_sample_matches_cdf);
    RUN(box_sample_matches_cdf);
    return spc_test_finish();
}
