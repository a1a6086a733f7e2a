/*
 * tests/test_exact_chains.c: every specular chain through one sphere (manifold/sphere_chains.c) and
 * every chain of reflections on one mirror cylinder (manifold/cylinder_chains.c).
 *
 * - The planar roots against an independent formulation (angles: Snell's law on the incidence
 *   angle, chords that turn by pi + 2 beta about the centre) scanned on a 20001-point grid, over
 *   random configurations, for the outside reflection and for 0 to 5 internal reflections,
 *   glass (eta 1.5, 1.33) and a bubble (eta 0.75, total internal reflection on entry): every root
 *   the dense scan finds is among spc_sphere_chain_roots', and every one of those is a root; and
 *   1500 configurations of the outside reflection and the refraction through with y mostly behind
 *   the sphere, where the refraction's caustic puts pairs of roots close together (its folds).
 * - From inside the sphere (spc_sphere_inside_roots), the way out after 0 to 2 internal reflections
 *   against a formulation by angles scanned over 20001 first directions: every isolated root found,
 *   those by the edge of total internal reflection included, and every returned one a root.
 * - The outside reflection, which is solved in closed form (a quartic), against the dense scan over
 *   4000 configurations: far, near the sphere, grazing, and y behind the sphere.
 * - In a scene: the chains spc_sphere_chains_all enumerates from floor points to light points
 *   through a glass ball (chains of up to 3 vertices, reflections included) and a mirror ball, each
 *   checked to end on its light point, contain every distinct chain that 3000 randomized angular
 *   attempts find.
 * - The cylinder's projected roots against an independent formulation (the ellipse as a quadric
 *   p^T Q p = 1: normals Q p, chords from the quadratic) scanned on a 20001-point grid, for random
 *   ellipses, x inside and outside, 1 to 3 reflections.
 * - In a scene: a round mirror ring and a tilted elliptic mirror cylinder (two-sided conductors) on
 *   a floor, floor points inside and outside, chains of up to 3 reflections: every distinct chain
 *   that randomized angular attempts find is enumerated, and every enumerated chain ends on y.
 * - Normal-mapped planes (manifold/plane_chains.c): the normal the enumeration models is the chain
 *   vertex's (spc_bsdf_map_chain_hit) on rippled water and a rippled mirror, and maps it does not
 *   model are refused; its roots against a dense Newton search on Snell's law (or the mirror law)
 *   with the modelled normal, the normal the BSDF turns toward a grazing viewer included; and in
 *   scenes, every chain randomized attempts find is enumerated.
 * - roots1d itself on a cubic: a root is kept where the target is ahead of it and dropped where it
 *   is behind, and no point is evaluated twice.
 */
/* ctest-labels: unit */
#include <math.h>
#include <string.h>

#include "core/rng.h"
#include "chain_compare.h"
#include "harness.h"
#include "manifold/angular.h"
#include "manifold/specular_nee.h"
#include "manifold/cylinder_chains.h"
#include "manifold/plane_chains.h"
#include "manifold/roots1d.h"
#include "manifold/sphere_chains.h"
#include "manifold/sphere_roots.h"
#include "render_util.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

/* ---- the planar problem, by angles ---- */

static double wrap(double a)
{
    while (a > SPC_PI)
        a -= 2 * SPC_PI;
    while (a <= -SPC_PI)
        a += 2 * SPC_PI;
    return a;
}

/* f = v x (y - Q) for the entry point at angle th, as spc_sphere_chain_roots defines it, computed
 * from angles; false where a refraction does not exist. */
static bool f_angles(double d, double y1, double y2, int m, double eta, double th, double *f, double *ahead)
{
    double phi_u = atan2(sin(th), cos(th) - d); /* direction x -> P */
    double phi_v, qa;                           /* final direction, angle of the last vertex */
    if (m < 0) {
        phi_v = 2.0 * th - phi_u + SPC_PI; /* mirror about the normal line at angle th */
        qa = th;
    } else {
        double alpha = wrap(phi_u - (th + SPC_PI)); /* against the inward normal */
        double sb = sin(alpha) / eta;
        if (fabs(sb) >= 1.0)
            return false;
        double beta = asin(sb);
        /* each chord turns the vertex by pi + 2 beta about the centre; the direction keeps the angle
         * beta to the inward normal at its start, so it leaves vertex j at th_j + pi + beta */
        qa = th + (m + 1) * (SPC_PI + 2.0 * beta);
        double dir_in = th + m * (SPC_PI + 2.0 * beta) + SPC_PI + beta; /* the last chord's direction */
        double gamma = wrap(dir_in - qa);                               /* against the outward normal */
        double so = eta * sin(gamma);
        if (fabs(so) >= 1.0)
            return false;
        phi_v = qa + asin(so);
    }
    double qx = cos(qa), qy = sin(qa), vx = cos(phi_v), vy = sin(phi_v);
    double rx = y1 - qx, ry = y2 - qy;
    *f = vx * ry - vy * rx;
    *ahead = vx * rx + vy * ry;
    return true;
}

/* Random configurations against the dense scan: m from -1 to 5 (low: -1 and 0 only, the orders
 * with the coarser grid, y mostly behind the sphere where the refraction's caustic and its folds
 * lie, within a few radii). */
static void planar_dense(int trials, bool low, bool near, int *pdense)
{
    const double etas[3] = {1.5, 1.33, 0.75};
    int dense_roots = 0, found = 0, missed = 0, extra = 0, configs = 0;
    for (int trial = 0; trial < trials; ++trial) {
        int m = low ? (int)(rnd() * 2) - 1 : (int)(rnd() * 7) - 1; /* up to five internal reflections */
        double eta = etas[(int)(rnd() * 3)];
        double d = 1.05 + 5.0 * rnd() * rnd();
        double r = 1.05 + 6.0 * rnd(), a = 2 * SPC_PI * rnd();
        if (low && rnd() < 0.7) {
            r = 1.02 + 3.0 * rnd();
            a = SPC_PI + 1.2 * (2.0 * rnd() - 1.0);
        }
        if (near) {
            /* x a floor point within 0.3 radii of the contact of a ball (radius 0.5, resting on
             * the floor y = 0) and y a point of a small light above and beside it, as in
             * bench/check/ball_small_light.xml */
            double u = 0.15 * (2.0 * rnd() - 1.0), v = 0.15 * (2.0 * rnd() - 1.0);
            double z0 = 2.0 * rnd() - 1.0, ph = 2.0 * SPC_PI * rnd(), rs = sqrt(1.0 - z0 * z0);
            spc_vec3 xf = spc_v3(u, 0.0, v), c = spc_v3(0.0, 0.5, 0.0);
            spc_vec3 yl = spc_v3(0.3 + 0.05 * rs * cos(ph), 2.0 + 0.05 * rs * sin(ph), -0.4 + 0.05 * z0);
            spc_sphere_plane pl;
            if (!spc_sphere_plane_of(xf, c, 0.5, yl, &pl))
                continue;
            d = pl.d;
            r = sqrt(pl.y1 * pl.y1 + pl.y2 * pl.y2);
            a = atan2(pl.y2, pl.y1);
            m = (int)(rnd() * 2) - 1;
            eta = 1.5;
        }
        double y1 = r * cos(a), y2 = fabs(r * sin(a));
        double theta[16];
        int n = spc_sphere_chain_roots(d, y1, y2, m, eta, theta, 16);
        ++configs;
        /* every root returned is a root, and y is ahead */
        for (int i = 0; i < n; ++i) {
            double f, ahead;
            bool ok = f_angles(d, y1, y2, m, eta, theta[i], &f, &ahead);
            CHECK_MSG(ok && fabs(f) < 1e-9 * (1.0 + r) && ahead > 0.0, "m %d eta %g: root %g has f %g ahead %g", m, eta,
                      theta[i], f, ahead);
            if (!(ok && fabs(f) < 1e-9 * (1.0 + r) && ahead > 0.0))
                ++extra;
        }
        /* the dense scan */
        const int N = 20000;
        double tmax = acos(1.0 / d) * (1.0 - 1e-9);
        double fp = 0, ap = 0, tp = 0;
        bool okp = false;
        for (int j = 0; j <= N; ++j) {
            double t = -tmax + 2.0 * tmax * j / N, f, ahead;
            bool ok = f_angles(d, y1, y2, m, eta, t, &f, &ahead);
            if (ok && okp && (f > 0.0) != (fp > 0.0) && ahead > 0.0 && ap > 0.0) {
                double root = tp + (t - tp) * fp / (fp - f);
                ++dense_roots;
                bool hit = false;
                for (int i = 0; i < n; ++i)
                    hit = hit || fabs(theta[i] - root) < 4.0 * tmax / N;
                if (hit) {
                    ++found;
                } else {
                    ++missed;
                    printf("    missed: d %g y (%g, %g) m %d eta %g root %g (arc +-%g)\n", d, y1, y2, m, eta, root,
                           tmax);
                }
            }
            okp = ok;
            fp = f;
            ap = ahead;
            tp = t;
        }
    }
    printf("    %d configurations%s: dense scan %d roots, found %d, missed %d; %d returned roots false\n", configs,
           low ? " (m -1 and 0)" : "", dense_roots, found, missed, extra);
    CHECK(missed == 0 && extra == 0);
    *pdense = dense_roots;
}

TEST(planar_roots_against_dense_scan)
{
    spc_rng_seed(&rng, 5, 1);
    int dense = 0;
    planar_dense(400, false, false, &dense);
    CHECK(dense > 200);
    /* the outside reflection and the refraction through, on the coarser grid, near the folds */
    planar_dense(1500, true, false, &dense);
    CHECK(dense > 500);
}

/* x within 0.05 radii of the sphere (a floor point by the contact of a glass ball resting on the
 * floor, under a light): the arc x sees is narrow and the refraction's fold lies near its grazing
 * end, where a grid of 16 samples missed pairs of roots and the default lost a fifth of a pixel's
 * caustic at the fold beside the contact (bench/check/ball_small_light.xml). */
TEST(planar_roots_near_the_sphere)
{
    spc_rng_seed(&rng, 7, 1);
    int dense = 0;
    planar_dense(1500, true, true, &dense);
    CHECK(dense > 500);
}

/* The planar problem from inside the circle (spc_sphere_inside_roots), by angles and parametrized by
 * the first direction phi from x = (d, 0): the ray's distance from the centre gives the incidence
 * angle alpha (sin alpha = d |sin phi|) at every vertex, each chord turns the vertex by pi - 2 alpha
 * about the centre in the sense of the ray's angular momentum, and the way out leaves at the angle
 * beta (sin beta = eta sin alpha) to the outward normal, turned the same way. f = v x (y - Q); *th0
 * the first vertex's angle; false where the way out is totally reflected. */
static bool f_inside(double d, double y1, double y2, int m, double eta, double phi, double *f, double *ahead,
                     double *th0)
{
    double L = d * sin(phi), sa = fabs(L);
    if (sa >= 1.0 || L == 0.0)
        return false;
    double t = -d * cos(phi) + sqrt(1.0 - sa * sa);
    *th0 = atan2(t * sin(phi), d + t * cos(phi));
    double sg = L > 0.0 ? 1.0 : -1.0, alpha = asin(sa);
    double qa = *th0 + sg * m * (SPC_PI - 2.0 * alpha);
    double sb = eta * sa;
    if (sb >= 1.0)
        return false;
    double va = qa + sg * asin(sb);
    double rx = y1 - cos(qa), ry = y2 - sin(qa), vx = cos(va), vy = sin(va);
    *f = vx * ry - vy * rx;
    *ahead = vx * rx + vy * ry;
    return true;
}

/* From points inside the sphere (a medium point in a glass ball), the way out after 0 to 2 internal
 * reflections, over random configurations (x from the centre to 0.98 radii, y from 1.05 to 6 radii,
 * glass and water): every root the dense scan over the first direction finds with no other root
 * within two of the solver's grid cells is among the returned ones (their first directions within
 * 0.01 radians: the roots seed attempts in a cone of 5 degrees), among them roots whose way out is
 * within 11 degrees of grazing (the light seen at the ball's rim from inside, by the edge of total
 * internal reflection), and every returned root has a sign change of f within 0.01 of its
 * direction. Fails if the chords, the way out or the edge's bracket are got wrong. */
TEST(inside_roots_against_dense_scan)
{
    spc_rng_seed(&rng, 11, 3);
    const double etas[2] = {1.5, 1.33}, tol = 0.01, iso = 4.0 * SPC_PI / 32.0;
    int configs = 0, dense = 0, isolated = 0, found = 0, missed = 0, returned = 0, false_roots = 0, grazing = 0;
    for (int trial = 0; trial < 600; ++trial) {
        int m = (int)(rnd() * 3);
        double eta = etas[(int)(rnd() * 2)];
        double d = 0.98 * rnd(), r = 1.05 + 5.0 * rnd() * rnd(), a = 2.0 * SPC_PI * rnd();
        double y1 = r * cos(a), y2 = r * sin(a);
        double theta[SPC_SPHERE_MAX_ROOTS];
        int n = spc_sphere_inside_roots(d, y1, y2, m, eta, theta, SPC_SPHERE_MAX_ROOTS);
        ++configs;
        returned += n;
        double phis[SPC_SPHERE_MAX_ROOTS]; /* the returned roots' first directions */
        for (int k = 0; k < n; ++k)
            phis[k] = atan2(sin(theta[k]), cos(theta[k]) - d);
        /* the dense scan's roots, as first directions, and the sine of their way out */
        double roots[64], sout[64];
        int nr = 0;
        const int N = 20000;
        double fp = 0.0, ap = 0.0, pp = 0.0;
        bool okp = false;
        for (int j = 0; j <= N; ++j) {
            double phi = -SPC_PI + 2.0 * SPC_PI * (j + 0.5) / (N + 1), f = 0.0, ahead = 0.0, th;
            bool ok = f_inside(d, y1, y2, m, eta, phi, &f, &ahead, &th);
            if (ok && okp && (f > 0.0) != (fp > 0.0) && ahead > 0.0 && ap > 0.0 && nr < 64) {
                sout[nr] = eta * d * fabs(sin(phi));
                roots[nr++] = pp + (phi - pp) * fp / (fp - f);
            }
            okp = ok;
            fp = f;
            ap = ahead;
            pp = phi;
        }
        dense += nr;
        for (int i = 0; i < nr; ++i) {
            bool alone = true;
            for (int j = 0; j < nr; ++j)
                alone = alone && (j == i || fabs(wrap(roots[j] - roots[i])) > iso);
            if (!alone)
                continue;
            ++isolated;
            bool hit = false;
            for (int k = 0; k < n; ++k)
                hit = hit || fabs(wrap(phis[k] - roots[i])) < tol;
            if (hit) {
                ++found;
                grazing += sout[i] > 0.98;
            } else {
                ++missed;
                printf("    missed: d %g y (%g, %g) m %d eta %g root %g\n", d, y1, y2, m, eta, roots[i]);
            }
        }
        /* each returned root: f changes sign within tol of its direction, or the way out ends there */
        for (int k = 0; k < n; ++k) {
            bool sign_change = false, edge = false;
            double fl = 0.0;
            bool okl = false;
            for (int j = -20; j <= 20; ++j) {
                double f = 0.0, ahead = 0.0, t0;
                bool ok = f_inside(d, y1, y2, m, eta, phis[k] + tol * j / 20.0, &f, &ahead, &t0) && ahead > 0.0;
                edge = edge || (okl != ok && j > -20);
                sign_change = sign_change || (ok && okl && (f > 0.0) != (fl > 0.0));
                okl = ok;
                fl = f;
            }
            if (!sign_change && !edge) {
                ++false_roots;
                printf("    not a root: d %g y (%g, %g) m %d eta %g theta %g\n", d, y1, y2, m, eta, theta[k]);
            }
        }
    }
    printf("    %d configurations: dense scan %d roots (%d isolated), found %d (%d within 11 degrees of grazing), "
           "missed %d; %d returned, %d not roots\n",
           configs, dense, isolated, found, grazing, missed, returned, false_roots);
    CHECK(isolated > 600 && missed == 0 && false_roots == 0);
    CHECK(grazing >= 5);
}

/* From inside the sphere, the pairs of roots at the refraction's fold, where the two ways out to y lie
 * within one or two cells of the solver's grid and f has one sign at the cells' ends: first the
 * medium point traced in scenes/medium_glass.xml (d 0.796, its pair at first directions of about 126
 * and 134 degrees inside one 11-degree cell, of which the grid's sign changes alone found none), then
 * over random configurations every root of the way out without internal reflection (the seeds from
 * inside, fit_seeds.c, take no other) that has a neighbour in the dense scan within two cells (so the
 * isolated test above does not check it) but none within 2 degrees is among the returned ones. Fails
 * without the extremum search between cells or between the edge of total reflection and the first
 * sample past it (inside_pair in sphere_roots.c: 12 of 58 such roots missed without the second). */
TEST(inside_roots_pairs_at_the_fold)
{
    {
        double theta[SPC_SPHERE_MAX_ROOTS];
        const double d = 0.796138, y1 = -1.995768, y2 = 1.715315;
        int n = spc_sphere_inside_roots(d, y1, y2, 0, 1.5, theta, SPC_SPHERE_MAX_ROOTS);
        int near126 = 0, near134 = 0;
        for (int k = 0; k < n; ++k) {
            double phi = atan2(sin(theta[k]), cos(theta[k]) - d) * 180.0 / SPC_PI;
            near126 += fabs(phi - 126.1) < 1.0;
            near134 += fabs(phi - 134.3) < 1.0;
        }
        printf("    traced point: %d roots, %d near 126.1 and %d near 134.3 degrees\n", n, near126, near134);
        CHECK(near126 == 1 && near134 == 1);
    }
    spc_rng_seed(&rng, 23, 5);
    const double etas[2] = {1.5, 1.33}, tol = 0.01, iso = 4.0 * SPC_PI / 32.0, apart = 2.0 * SPC_PI / 180.0;
    const int configs = spc_test_quick() ? 2000 : 6000;
    int paired = 0, found = 0, missed = 0;
    for (int trial = 0; trial < configs; ++trial) {
        const int m = 0; /* the way out without internal reflection: the fitted seeds from inside use it alone */
        double eta = etas[(int)(rnd() * 2)];
        double d = 0.98 * rnd(), r = 1.05 + 5.0 * rnd() * rnd(), a = 2.0 * SPC_PI * rnd();
        double y1 = r * cos(a), y2 = r * sin(a);
        double theta[SPC_SPHERE_MAX_ROOTS];
        int n = spc_sphere_inside_roots(d, y1, y2, m, eta, theta, SPC_SPHERE_MAX_ROOTS);
        double phis[SPC_SPHERE_MAX_ROOTS];
        for (int k = 0; k < n; ++k)
            phis[k] = atan2(sin(theta[k]), cos(theta[k]) - d);
        double roots[64];
        int nr = 0;
        const int N = 6000; /* 0.06 degrees: pairs 2 degrees apart are resolved */
        double fp = 0.0, ap = 0.0, pp = 0.0;
        bool okp = false;
        for (int j = 0; j <= N; ++j) {
            double phi = -SPC_PI + 2.0 * SPC_PI * (j + 0.5) / (N + 1), f = 0.0, ahead = 0.0, th;
            bool ok = f_inside(d, y1, y2, m, eta, phi, &f, &ahead, &th);
            if (ok && okp && (f > 0.0) != (fp > 0.0) && ahead > 0.0 && ap > 0.0 && nr < 64)
                roots[nr++] = pp + (phi - pp) * fp / (fp - f);
            okp = ok;
            fp = f;
            ap = ahead;
            pp = phi;
        }
        for (int i = 0; i < nr; ++i) {
            bool neighbour = false, crowded = false;
            for (int j = 0; j < nr; ++j) {
                double dist = fabs(wrap(roots[j] - roots[i]));
                neighbour = neighbour || (j != i && dist <= iso);
                crowded = crowded || (j != i && dist < apart);
            }
            if (!neighbour || crowded)
                continue;
            ++paired;
            bool hit = false;
            for (int k = 0; k < n; ++k)
                hit = hit || fabs(wrap(phis[k] - roots[i])) < tol;
            if (hit) {
                ++found;
            } else {
                ++missed;
                if (missed <= 5)
                    printf("    missed: d %g y (%g, %g) m %d eta %g root %g\n", d, y1, y2, m, eta, roots[i]);
            }
        }
    }
    printf("    %d configurations: %d roots with a neighbour within two cells, found %d, missed %d\n", configs, paired,
           found, missed);
    CHECK(paired > configs / 75 && missed == 0);
}

/* roots1d (roots1d.h) on f(t) = t^3 + t / 2 - k, ahead(t) = t - a: the root is kept where the target
 * is ahead at it and dropped where it is behind, to the tolerance; and no t is evaluated twice (a
 * root's ahead test reads the value the refinement kept at its bracket's end). */
typedef struct cubic_ctx {
    double k, a;
    double seen[512];
    int n, twice;
} cubic_ctx;

static bool cubic_fn(const void *ctx, double t, double *f, double *ahead, double *ang)
{
    cubic_ctx *c = (cubic_ctx *)ctx;
    for (int i = 0; i < c->n; ++i)
        c->twice += c->seen[i] == t;
    if (c->n < 512)
        c->seen[c->n++] = t;
    *f = t * t * t + 0.5 * t - c->k;
    *ahead = t - c->a;
    if (ang)
        ang[0] = 0.0;
    return true;
}

TEST(roots1d_ahead_read_at_the_root)
{
    enum { G = 8 };
    int kept = 0, dropped = 0;
    for (int i = 0; i < 40; ++i) {
        cubic_ctx c = {.k = -0.7 + 1.4 * (i + 0.37) / 40.0, .a = (i % 2) ? -2.0 : 2.0};
        double t[G + 1], f[G + 1], ah[G + 1], ang[G + 1][SPC_ROOTS1D_MAX_ANGLES] = {{0}};
        bool ok[G + 1];
        for (int j = 0; j <= G; ++j) {
            t[j] = -1.0 + 2.0 * j / G;
            f[j] = t[j] * t[j] * t[j] + 0.5 * t[j] - c.k;
            ah[j] = t[j] - c.a;
            ok[j] = true;
        }
        double roots[4];
        int n = spc_roots1d(cubic_fn, NULL, &c, t, f, ah, &ang[0][0], 1, ok, G, NULL, 1e-12, roots, 4);
        CHECK(c.twice == 0);
        if (c.a < 0.0) {
            CHECK(n == 1);
            if (n == 1)
                CHECK(fabs(roots[0] * roots[0] * roots[0] + 0.5 * roots[0] - c.k) < 1e-11);
            kept += n;
        } else {
            CHECK(n == 0);
            dropped += n == 0;
        }
    }
    printf("  %d roots kept, %d dropped (target behind)\n", kept, dropped);
}

/* Every signature solved in one call (spc_sphere_chain_roots_all, whose signatures share the grid
 * and the subdivision's midpoints) returns the same roots, bit for bit, as each signature solved
 * alone (spc_sphere_chain_roots, which the dense scans above check); so does a set of signatures
 * with gaps (spc_sphere_chain_roots_some), and it leaves the others without roots. Configurations
 * come in pairs with the same d and another y (the same grid and midpoint angles, other values: what
 * one query left behind must not serve the next), far and near the sphere (the finer grid), each
 * index. */
TEST(sphere_signatures_together_same_as_alone)
{
    spc_rng_seed(&rng, 11, 1);
    const double etas[3] = {1.5, 1.33, 0.75};
    int configs = 0, roots = 0, differ = 0, some_roots = 0;
    for (int trial = 0; trial < 1200; ++trial) {
        double eta = etas[trial % 3];
        double d = trial % 2 ? 1.005 + 0.25 * rnd() : 1.05 + 5.0 * rnd() * rnd();
        for (int k = 0; k < 2; ++k) {
            double r = 1.02 + 6.0 * rnd(), a = 2 * SPC_PI * rnd();
            double y1 = r * cos(a), y2 = fabs(r * sin(a));
            int mlo = (int)(rnd() * 3) - 1, mhi = SPC_SPHERE_MAX_M - (int)(rnd() * 3);
            double all[SPC_SPHERE_SIGNATURES][SPC_SPHERE_MAX_ROOTS];
            int n[SPC_SPHERE_SIGNATURES];
            spc_sphere_chain_roots_all(d, y1, y2, eta, mlo, mhi, all, n);
            ++configs;
            for (int m = mlo; m <= mhi; ++m) {
                double alone[SPC_SPHERE_MAX_ROOTS];
                int na = spc_sphere_chain_roots(d, y1, y2, m, eta, alone, SPC_SPHERE_MAX_ROOTS);
                roots += na;
                if (na != n[m + 1] || memcmp(alone, all[m + 1], (size_t)na * sizeof *alone) != 0) {
                    ++differ;
                    printf("    differ: d %g y (%g, %g) eta %g m %d: %d roots together, %d alone\n", d, y1, y2, eta, m,
                           n[m + 1], na);
                }
            }
            /* a set of signatures with gaps (spc_sphere_chain_roots_some) */
            bool want[SPC_SPHERE_SIGNATURES];
            for (int m = -1; m <= SPC_SPHERE_MAX_M; ++m)
                want[m + 1] = rnd() < 0.4;
            spc_sphere_chain_roots_some(d, y1, y2, eta, want, all, n);
            for (int m = -1; m <= SPC_SPHERE_MAX_M; ++m) {
                double alone[SPC_SPHERE_MAX_ROOTS];
                int na = want[m + 1] ? spc_sphere_chain_roots(d, y1, y2, m, eta, alone, SPC_SPHERE_MAX_ROOTS) : 0;
                some_roots += na;
                if (na != n[m + 1] || memcmp(alone, all[m + 1], (size_t)na * sizeof *alone) != 0) {
                    ++differ;
                    printf("    differ: d %g y (%g, %g) eta %g m %d (wanted %d): %d roots in the set, %d alone\n", d,
                           y1, y2, eta, m, want[m + 1], n[m + 1], na);
                }
            }
        }
    }
    printf("    %d roots of sets with gaps\n", some_roots);
    CHECK(some_roots > 500);
    printf("    %d configurations, %d roots alone; %d signatures differ\n", configs, roots, differ);
    CHECK(roots > 1000);
    CHECK(differ == 0);
}

/* The outside reflection (solved as a quartic) against a dense scan of f_angles over 4000 random
 * configurations of four kinds: x and y far (up to 1000 radii), x near the sphere (within 1e-4 to
 * 0.1 radii), y near the grazing ray from x (the root at the arc's end), and y behind the sphere
 * seen from x. Every root the scan brackets is returned, at the scan's root refined by bisection
 * to within 1e-9, and every returned root is a root with y ahead. */
TEST(reflection_roots_against_dense_scan)
{
    spc_rng_seed(&rng, 13, 1);
    int dense_roots = 0, found = 0, missed = 0, extra = 0, most = 0;
    double worst = 0.0;
    for (int trial = 0; trial < 4000; ++trial) {
        int kind = trial % 4;
        double d, y1, y2;
        if (kind == 0) { /* far */
            d = 1.0 + exp(log(1000.0) * rnd());
            double r = 1.0 + exp(log(1000.0) * rnd()), a = SPC_PI * rnd();
            y1 = r * cos(a);
            y2 = r * sin(a);
        } else if (kind == 1) { /* x near the sphere */
            d = 1.0 + exp(log(1e-4) + (log(0.1) - log(1e-4)) * rnd());
            double r = 1.0 + 5.0 * rnd() * rnd(), a = SPC_PI * rnd();
            y1 = r * cos(a);
            y2 = r * sin(a);
        } else if (kind == 2) { /* y beside the grazing ray from x past its tangent point */
            d = 1.001 + 10.0 * rnd() * rnd();
            double tm = acos(1.0 / d), px = cos(tm), py = sin(tm);
            double ux = px - d, uy = py, ul = sqrt(ux * ux + uy * uy), s = 0.01 + 5.0 * rnd();
            double e = exp(log(1e-7) + (log(0.1) - log(1e-7)) * rnd()) * (rnd() < 0.8 ? 1.0 : -1.0);
            y1 = px + s * ux / ul + e * px;
            y2 = py + s * uy / ul + e * py;
            if (y1 * y1 + y2 * y2 <= 1.0 + 1e-9)
                continue;
        } else { /* y behind the sphere */
            d = 1.01 + 10.0 * rnd() * rnd();
            double r = 1.0 + exp(log(1e-3) + (log(3.0) - log(1e-3)) * rnd()), a = SPC_PI - 1.4 * rnd();
            y1 = r * cos(a);
            y2 = r * sin(a);
        }
        double r = sqrt(y1 * y1 + y2 * y2);
        double theta[16];
        int n = spc_sphere_chain_roots(d, y1, y2, -1, 1.5, theta, 16);
        most = n > most ? n : most;
        for (int i = 0; i < n; ++i) {
            double f, ahead;
            bool ok = f_angles(d, y1, y2, -1, 1.5, theta[i], &f, &ahead);
            if (!(ok && fabs(f) < 1e-9 * (1.0 + r) && ahead > 0.0)) {
                ++extra;
                printf("    false: d %g y (%g, %g) root %g f %g ahead %g\n", d, y1, y2, theta[i], f, ahead);
            }
        }
        const int N = 3000;
        double tmax = acos(1.0 / d) * (1.0 - 1e-9);
        double fp = 0, ap = 0, tp = 0;
        for (int j = 0; j <= N; ++j) {
            double t = -tmax + 2.0 * tmax * j / N, f, ahead;
            f_angles(d, y1, y2, -1, 1.5, t, &f, &ahead);
            if (j > 0 && (f > 0.0) != (fp > 0.0) && ahead > 0.0 && ap > 0.0) {
                double lo = tp, hi = t, flo = fp;
                for (int it = 0; it < 60; ++it) {
                    double mid = 0.5 * (lo + hi), fm, am;
                    f_angles(d, y1, y2, -1, 1.5, mid, &fm, &am);
                    if ((fm > 0.0) == (flo > 0.0)) {
                        lo = mid;
                        flo = fm;
                    } else {
                        hi = mid;
                    }
                }
                double root = 0.5 * (lo + hi), best = 1e300;
                ++dense_roots;
                for (int i = 0; i < n; ++i)
                    best = fmin(best, fabs(theta[i] - root));
                if (best < 1e-9) {
                    ++found;
                    worst = fmax(worst, best);
                } else {
                    ++missed;
                    printf("    missed: d %g y (%g, %g) root %g (arc +-%g), nearest returned %g away\n", d, y1, y2,
                           root, tmax, best);
                }
            }
            fp = f;
            ap = ahead;
            tp = t;
        }
    }
    printf("    dense scan %d roots, found %d (at most %.2g apart), missed %d; %d returned roots false; at most %d "
           "per configuration\n",
           dense_roots, found, worst, missed, extra, most);
    CHECK(missed == 0 && extra == 0);
    CHECK(dense_roots > 1800);
}

/* ---- in a scene ---- */

/* An 8 x 8 diffuse floor (z = 0); the caller adds the caster and then the light (shape index 2). */
static spc_scene *floor_scene(void)
{
    spc_scene *sc = spc_scene_create();
    spc_shape *floor = spc_scene_new_shape(sc);
    spc_error err;
    spc_mat4 M = spc_mat4_scale(spc_v3(4, 4, 1));
    spc_shape_init_rectangle(floor, &M, NULL, 0, 0, &err);
    floor->bsdf = tu_diffuse(sc, 0.8);
    return sc;
}

/* The sphere light (shape index 2) and the scene finalized; NULL (destroyed) on failure. */
static spc_scene *add_light_finish(spc_scene *sc, spc_vec3 c, double r)
{
    spc_shape *light = tu_sphere(sc, c, r, tu_diffuse(sc, 0.0));
    tu_area(sc, light, 2, 5.0);
    spc_error err;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

static spc_scene *ball_scene(bool mirror)
{
    spc_scene *sc = floor_scene();
    tu_sphere(sc, spc_v3(0, 0, 0.6), 0.5, mirror ? tu_mirror(sc) : tu_glass(sc, 1.5));
    /* low to the side: the light's internal reflections (its rainbow) reach the floor */
    return add_light_finish(sc, spc_v3(-1.6, 0.3, 1.0), 0.3);
}

/* Distance from y to the chain's final half-line. */
static double miss(const spc_chain *c, spc_vec3 y)
{
    const spc_chain_vertex *v = &c->v[c->n - 1];
    spc_vec3 r = spc_sub(y, v->h.p);
    double t = spc_dot(r, v->d);
    return t < 0.0 ? spc_length(r) : spc_length(spc_sub(r, spc_scale(v->d, t)));
}

/* Does the chain contribute (its final segment reaches y unblocked, as spc_snee_chain_value
 * requires; the solvers leave that check to it)? */
static bool reaches(const spc_snee_query *q, const spc_emitter *e, spc_vec2 uv, const spc_chain *c)
{
    return spc_snee_chain_value(q, e, uv, c).r > 0.0;
}

/* What one comparison of an enumeration with randomized attempts counted. */
typedef struct tally {
    int points, enumerated, reaching, multi, random_distinct, random_missing, by_len[4];
} tally;

/* At the floor point below `above` and one light point drawn from it (rng stream `stream`): the
 * chains the enumeration finds (the cylinder's, or the sphere's) each end on y, are covered, and are
 * distinct; and every distinct contributing chain of the kind that 3000 randomized angular attempts
 * find is among them. */
enum { KIND_SPHERE, KIND_CYLINDER, KIND_PLANE };

static int enumerate(int kind, const spc_snee_query *q, spc_chain *all, int max)
{
    if (kind == KIND_CYLINDER)
        return spc_cylinder_chains_all(q, all, max, NULL);
    if (kind == KIND_PLANE)
        return spc_plane_chains_all(q, true, all, max, NULL);
    return spc_sphere_chains_all(q, all, max, NULL);
}

static bool covers(int kind, const spc_chain *c)
{
    if (kind == KIND_CYLINDER)
        return spc_cylinder_chain_covers(c);
    if (kind == KIND_PLANE)
        return spc_plane_chain_covers(c, true);
    return spc_sphere_chain_covers(c, true);
}

/* A randomized chain counts where the enumeration covers it and it reaches the light point (a
 * chain whose last segment is blocked, by the wall below its rim or the light's far side, is not one). */
typedef struct keep_ctx {
    int kind;
    const spc_emitter *e;
    spc_vec2 uv;
} keep_ctx;

static bool keep_exact(const spc_snee_query *q, const spc_chain *c, void *ctx)
{
    const keep_ctx *k = ctx;
    return covers(k->kind, c) && reaches(q, k->e, k->uv, c);
}

static void compare_at(spc_scene *sc, const spc_snee_params *p, spc_vec3 above, uint64_t stream, int kind,
                       const char *label, tally *t)
{
    spc_hit x;
    spc_snee_query q;
    const spc_emitter *e;
    spc_vec2 uv;
    spc_rng r;
    spc_rng_seed(&r, 3, stream);
    if (!chain_compare_floor_query(sc, p, above, 3, &r, &x, &q, &e, &uv))
        return;
    ++t->points;
    CHECK(spc_snee_exact_covers_all(&q));
    spc_chain all[32];
    int n = enumerate(kind, &q, all, 32);
    t->enumerated += n;
    int reach0 = t->reaching;
    for (int i = 0; i < n; ++i) {
        ++t->by_len[all[i].n < 4 ? all[i].n : 3];
        CHECK_MSG(miss(&all[i], q.y) < 1e-6, "chain %d of %d vertices misses y by %g", i, all[i].n, miss(&all[i], q.y));
        CHECK(covers(kind, &all[i]));
        t->reaching += reaches(&q, e, uv, &all[i]) ? 1 : 0;
        for (int j = 0; j < i; ++j)
            CHECK(!spc_snee_same_solution(&all[i], &all[j], sc->radius));
    }
    t->multi += t->reaching - reach0 >= 2 ? 1 : 0;
    /* randomized attempts (their events drawn as specular NEE draws them); a chain whose last
     * segment is blocked (by the wall below its rim, the light's far side) is not one */
    keep_ctx kc = {kind, e, uv};
    chain_compare_random(&q, &r, 3000, all, n, sc->radius, keep_exact, &kc, label, &t->random_distinct,
                         &t->random_missing);
}

static void print_tally(const char *label, const tally *t)
{
    printf("    %s: %d points, %d chains enumerated (1/2/3+ vertices: %d/%d/%d; %d reach y), %d distinct randomized, "
           "%d of them not enumerated; %d points see several images\n",
           label, t->points, t->enumerated, t->by_len[1], t->by_len[2], t->by_len[3], t->reaching, t->random_distinct,
           t->random_missing, t->multi);
}

TEST(sphere_chains_contain_randomized_solutions)
{
    spc_rng_seed(&rng, 11, 2);
    for (int mirror = 0; mirror < 2; ++mirror) {
        spc_scene *sc = ball_scene(mirror);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_snee_params p;
        spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 3);
        p.any_surface = true;
        const char *label = mirror ? "mirror ball" : "glass ball";
        tally t;
        memset(&t, 0, sizeof t);
        for (int pt = 0; pt < 40; ++pt)
            compare_at(sc, &p, spc_v3(-3.0 + 6.0 * rnd(), -1.5 + 3.0 * rnd(), 0.05), (uint64_t)pt, KIND_SPHERE, label, &t);
        print_tally(label, &t);
        CHECK(t.points >= 16 && t.random_distinct >= 10);
        CHECK(t.random_missing == 0);
        if (mirror)
            CHECK(t.by_len[2] == 0 && t.by_len[3] == 0 && t.by_len[1] > 0);
        else
            CHECK(t.by_len[1] > 0 && t.by_len[2] > 0 && t.by_len[3] > 0);
        spc_scene_destroy(sc);
    }
}

/* ---- the cylinder's projected problem, as a quadric ---- */

/* f for k reflections with the first vertex at p1 = u cos(phi) + v sin(phi), the ellipse written as
 * p^T Q p = 1 (Q = M^-T M^-1): normal Q p, the next vertex the other root of the line's quadratic. */
static bool f_quadric(const double u[2], const double v[2], const double x[2], const double y[2], int k, double phi,
                      double *f, double *ahead)
{
    double det = u[0] * v[1] - u[1] * v[0];
    double mi[2][2] = {{v[1] / det, -v[0] / det}, {-u[1] / det, u[0] / det}};
    double Q[2][2];
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j)
            Q[i][j] = mi[0][i] * mi[0][j] + mi[1][i] * mi[1][j];
    double p[2] = {u[0] * cos(phi) + v[0] * sin(phi), u[1] * cos(phi) + v[1] * sin(phi)};
    double d[2] = {p[0] - x[0], p[1] - x[1]};
    double l = hypot(d[0], d[1]);
    d[0] /= l;
    d[1] /= l;
    for (int j = 0; j < k; ++j) {
        double n[2] = {Q[0][0] * p[0] + Q[0][1] * p[1], Q[1][0] * p[0] + Q[1][1] * p[1]};
        double nl = hypot(n[0], n[1]);
        n[0] /= nl;
        n[1] /= nl;
        double dn = d[0] * n[0] + d[1] * n[1];
        d[0] -= 2 * dn * n[0];
        d[1] -= 2 * dn * n[1];
        if (j == k - 1)
            break;
        /* (p + t d)^T Q (p + t d) = 1 with p^T Q p = 1: t = -2 d^T Q p / d^T Q d */
        double dQp = d[0] * (Q[0][0] * p[0] + Q[0][1] * p[1]) + d[1] * (Q[1][0] * p[0] + Q[1][1] * p[1]);
        double dQd = d[0] * (Q[0][0] * d[0] + Q[0][1] * d[1]) + d[1] * (Q[1][0] * d[0] + Q[1][1] * d[1]);
        double t = -2 * dQp / dQd;
        if (!(t > 1e-9))
            return false;
        p[0] += t * d[0];
        p[1] += t * d[1];
    }
    double r[2] = {y[0] - p[0], y[1] - p[1]};
    *f = d[0] * r[1] - d[1] * r[0];
    *ahead = d[0] * r[0] + d[1] * r[1];
    return true;
}

TEST(cylinder_roots_against_dense_scan)
{
    spc_rng_seed(&rng, 7, 3);
    int dense_roots = 0, found = 0, missed = 0, extra = 0;
    for (int trial = 0; trial < 800; ++trial) {
        int k = 1 + (int)(rnd() * 3);
        /* an ellipse: axes of length 0.5 .. 2 at a random angle, possibly clockwise */
        double ra = 0.5 + 1.5 * rnd(), rb = 0.5 + 1.5 * rnd(), ang = 2 * SPC_PI * rnd();
        double sg = rnd() < 0.5 ? -1.0 : 1.0;
        double u[2] = {ra * cos(ang), ra * sin(ang)}, v[2] = {-sg * rb * sin(ang), sg * rb * cos(ang)};
        /* x inside (half the time) or outside; y anywhere around */
        double xr = rnd() < 0.5 ? 0.9 * rnd() : 1.2 + 2.0 * rnd(), xa = 2 * SPC_PI * rnd();
        double yr = 0.2 + 4.0 * rnd(), ya = 2 * SPC_PI * rnd();
        double x[2] = {u[0] * xr * cos(xa) + v[0] * xr * sin(xa), u[1] * xr * cos(xa) + v[1] * xr * sin(xa)};
        double y[2] = {u[0] * yr * cos(ya) + v[0] * yr * sin(ya), u[1] * yr * cos(ya) + v[1] * yr * sin(ya)};
        double phi[16], len[48], total[16];
        int n = spc_cylinder_chain_roots(u, v, x, y, k, phi, len, total, 16);
        for (int i = 0; i < n; ++i) {
            double f, ahead;
            bool ok = f_quadric(u, v, x, y, k, phi[i], &f, &ahead);
            bool good = ok && fabs(f) < 1e-8 * (1.0 + yr) && ahead > 0.0;
            CHECK_MSG(good, "k %d: root %g has f %g ahead %g", k, phi[i], f, ahead);
            extra += !good;
        }
        const int N = 20000;
        double fp = 0, ap = 0, tp = 0;
        bool okp = false;
        for (int j = 0; j <= N; ++j) {
            double t = 2 * SPC_PI * j / N, f, ahead;
            bool ok = f_quadric(u, v, x, y, k, t, &f, &ahead);
            if (ok && okp && (f > 0.0) != (fp > 0.0) && ahead > 0.0 && ap > 0.0) {
                double root = tp + (t - tp) * fp / (fp - f);
                ++dense_roots;
                bool hit = false;
                for (int i = 0; i < n; ++i) {
                    double dd = fabs(phi[i] - root);
                    hit = hit || dd < 4.0 * SPC_PI / N || fabs(dd - 2 * SPC_PI) < 4.0 * SPC_PI / N;
                }
                if (hit) {
                    ++found;
                } else {
                    ++missed;
                    printf("    missed: k %d u (%.17g, %.17g) v (%.17g, %.17g) x (%.17g, %.17g) y (%.17g, %.17g) root "
                           "%g\n",
                           k, u[0], u[1], v[0], v[1], x[0], x[1], y[0], y[1], root);
                }
            }
            okp = ok;
            fp = f;
            ap = ahead;
            tp = t;
        }
    }
    printf("    800 configurations: dense scan %d roots, found %d, missed %d; %d returned roots false\n", dense_roots,
           found, missed, extra);
    CHECK(dense_roots > 150);
    CHECK(missed == 0 && extra == 0);
}

/* A floor, a two-sided mirror cylinder (round: the ring of scenes/caustic_mirror_ring.xml; or
 * elliptic and tilted), a sphere light outside it. */
static spc_scene *cylinder_scene(bool elliptic)
{
    spc_scene *sc = floor_scene();
    spc_shape *cyl = spc_scene_new_shape(sc);
    spc_bsdf *mirror = spc_scene_new_bsdf(sc);
    mirror->type = SPC_BSDF_TWOSIDED;
    mirror->nested[0] = tu_mirror(sc);
    mirror->nested[1] = NULL;
    spc_error err;
    if (elliptic) {
        spc_mat4 S = spc_mat4_scale(spc_v3(1.4, 0.8, 1.0)), R = spc_mat4_rotate(spc_v3(1, 0.3, 0), 12.0);
        spc_mat4 RS = spc_mat4_mul(&R, &S);
        spc_shape_init_cylinder(cyl, spc_v3(0, 0, -0.05), spc_v3(0, 0, 0.5), 0.7, &RS, NULL, 0, 0, &err);
    } else {
        spc_shape_init_cylinder(cyl, spc_v3(0, 0, 0), spc_v3(0, 0, 0.9), 0.8, NULL, NULL, 0, 0, &err);
    }
    cyl->bsdf = mirror;
    return add_light_finish(sc, spc_v3(-2.2, 0.3, 1.3), 0.15);
}

TEST(cylinder_chains_contain_randomized_solutions)
{
    spc_rng_seed(&rng, 13, 4);
    for (int elliptic = 0; elliptic < 2; ++elliptic) {
        spc_scene *sc = cylinder_scene(elliptic);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_snee_params p;
        spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 3);
        p.any_surface = true;
        const char *label = elliptic ? "elliptic cylinder" : "round cylinder";
        tally t;
        memset(&t, 0, sizeof t);
        for (int pt = 0; pt < 40; ++pt) {
            /* half inside the cylinder's footprint, half around it */
            double r = pt % 2 ? 0.6 * sqrt(rnd()) : 0.9 + 1.5 * rnd(), a = 2 * SPC_PI * rnd();
            compare_at(sc, &p, spc_v3(r * cos(a), r * sin(a), 0.02), 100 + (uint64_t)pt, KIND_CYLINDER, label, &t);
        }
        print_tally(label, &t);
        CHECK(t.points >= 30 && t.random_distinct >= 10);
        CHECK(t.random_missing == 0);
        CHECK(t.by_len[1] > 0 && t.by_len[2] > 0);
        spc_scene_destroy(sc);
    }
}

/* ---- normal-mapped planes ---- */

/* A floor and a normal-mapped plane: water (glass 1.33 under the map) above the floor, its to_uv
 * flipped and offset and the rectangle turned; or a rippled mirror standing beside the floor (a
 * conductor under the map). A sphere light above the water, or in front of the mirror. */
static spc_scene *plane_scene(bool mirror)
{
    spc_scene *sc = floor_scene();
    spc_shape *w = spc_scene_new_shape(sc);
    spc_error err;
    spc_bsdf *b = tu_normal_mapped(sc, mirror ? tu_mirror(sc) : tu_glass(sc, 1.33), 16, mirror ? 0.3 : 0.5, 3.0, 5);
    spc_texture *t = (spc_texture *)b->normalmap;
    if (mirror) {
        /* the plane x = 2.2 facing -x, 1.5 high */
        spc_mat4 S = spc_mat4_scale(spc_v3(3.0, 1.5, 1.0)), R = spc_mat4_rotate(spc_v3(0, 1, 0), -90.0);
        spc_mat4 T = spc_mat4_translate(spc_v3(2.2, 0.0, 1.0));
        spc_mat4 RS = spc_mat4_mul(&R, &S), M = spc_mat4_mul(&T, &RS);
        spc_shape_init_rectangle(w, &M, NULL, 0, 0, &err);
    } else {
        t->to_uv[0][0] = -7.0;
        t->to_uv[0][2] = 0.3;
        t->to_uv[1][1] = 5.0;
        t->to_uv[1][2] = 0.1;
        spc_mat4 S = spc_mat4_scale(spc_v3(2.5, 2.0, 1.0)), R = spc_mat4_rotate(spc_v3(0, 0, 1), 25.0);
        spc_mat4 T = spc_mat4_translate(spc_v3(0.0, 0.0, 1.0));
        spc_mat4 RS = spc_mat4_mul(&R, &S), M = spc_mat4_mul(&T, &RS);
        spc_shape_init_rectangle(w, &M, NULL, 0, 0, &err);
    }
    w->bsdf = b;
    return add_light_finish(sc, mirror ? spc_v3(-0.8, 0.3, 1.3) : spc_v3(0.4, 0.3, 2.2), 0.15);
}

/* The normal the enumeration models (the texels' bilinear blend in the plane's frame) is the one a
 * chain vertex gets from spc_bsdf_map_chain_hit, at random points of the plane. */
TEST(plane_model_normal_matches_chain_vertex)
{
    spc_rng_seed(&rng, 17, 1);
    for (int mirror = 0; mirror < 2; ++mirror) {
        spc_scene *sc = plane_scene(mirror);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        const spc_shape *w = sc->shapes[1];
        CHECK(spc_plane_chain_shape(w));
        CHECK(!spc_plane_chain_shape(sc->shapes[0]) && !spc_plane_chain_shape(sc->shapes[2]));
        if (!mirror) {
            /* maps the enumeration does not model are left to the randomized solver: a to_uv that
             * turns u into v, nearest texels, a curved shape */
            const char *what[3] = {"turned to_uv", "nearest", "sphere"};
            for (int k = 0; k < 3; ++k) {
                spc_scene *o = floor_scene();
                spc_error err;
                spc_mat4 M = spc_mat4_translate(spc_v3(0, 0, 1));
                spc_bsdf *b = tu_normal_mapped(o, tu_glass(o, 1.33), 8, 0.3, 2.0, 9);
                spc_texture *t = (spc_texture *)b->normalmap;
                spc_shape *sh;
                if (k == 2) {
                    sh = tu_sphere(o, spc_v3(0, 0, 2), 0.5, b);
                } else {
                    sh = spc_scene_new_shape(o);
                    spc_shape_init_rectangle(sh, &M, NULL, 0, 0, &err);
                    sh->bsdf = b;
                    if (k == 0)
                        t->to_uv[0][1] = 0.5;
                    else
                        t->nearest = true;
                }
                CHECK(spc_scene_finalize(o, &err) == SPC_OK);
                CHECK_MSG(!spc_plane_chain_shape(sh), "%s taken as a plane", what[k]);
                spc_scene_destroy(o);
            }
        }
        double worst = 0.0;
        int n = 0;
        for (int i = 0; i < 2000; ++i) {
            /* a ray onto the plane from its front side */
            spc_vec3 o = mirror ? spc_v3(1.0, -1.3 + 2.6 * rnd(), 0.1 + 1.8 * rnd())
                                : spc_v3(-1.5 + 3.0 * rnd(), -1.5 + 3.0 * rnd(), 1.5);
            spc_vec3 d = mirror ? spc_v3(1, 0, 0) : spc_v3(0, 0, -1);
            spc_ray r = {o, d, 0.0, INFINITY};
            spc_hit h;
            if (!spc_scene_intersect(sc, &r, &h) || h.shape != w)
                continue;
            spc_vec3 fr[3];
            double m[3];
            CHECK(spc_plane_chain_model_normal(w, h.p, m, fr));
            spc_vec3 mw = spc_normalize(spc_add(spc_add(spc_scale(fr[0], m[0]), spc_scale(fr[1], m[1])),
                                                spc_scale(fr[2], m[2])));
            CHECK(spc_bsdf_map_chain_hit(&h, spc_neg(d)) && h.normal_mapped);
            worst = spc_max(worst, spc_length(spc_sub(mw, h.sh.n)));
            ++n;
        }
        printf("    %s: %d points, largest difference %.2e\n", mirror ? "mirror" : "water", n, worst);
        CHECK(n > 1000);
        CHECK(worst < 1e-6); /* the shape's float uv */
        spc_scene_destroy(sc);
    }
}

TEST(plane_chains_contain_randomized_solutions)
{
    spc_rng_seed(&rng, 19, 3);
    for (int mirror = 0; mirror < 2; ++mirror) {
        spc_scene *sc = plane_scene(mirror);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        spc_snee_params p;
        spc_snee_params_default(&p, SPC_SNEE_ANGULAR, 3);
        p.any_surface = true;
        const char *label = mirror ? "rippled mirror" : "rippled water";
        tally t;
        memset(&t, 0, sizeof t);
        for (int pt = 0; pt < 40; ++pt)
            compare_at(sc, &p, spc_v3(-2.0 + 3.8 * rnd(), -1.5 + 3.0 * rnd(), 0.05), 200 + (uint64_t)pt, KIND_PLANE,
                       label, &t);
        print_tally(label, &t);
        CHECK(t.points >= 30 && t.random_distinct >= 20);
        CHECK(t.random_missing == 0);
        CHECK(t.multi >= 3); /* several images of the light */
        CHECK(t.by_len[2] == 0 && t.by_len[3] == 0);
        spc_scene_destroy(sc);
    }
}

/* The plane's roots (spc_plane_chain_roots, before any polish) against an independent search: on a
 * square of water or mirror under a 16 x 16 map repeated 2 x 2, Snell's law (or the mirror law) applied to the
 * modelled normal from x to each point, the residual the tangential part of the refracted direction
 * minus the direction to y, and Newton's method with finite differences from 8 x 8 starts in every
 * texel cell. Every root of the dense search is among the enumeration's; the enumeration's extra roots
 * are those of the half-vector condition that no refraction realizes. */
static bool snell_residual(const spc_shape *w, spc_vec3 x, spc_vec3 y, bool refract, double eta, spc_vec3 p,
                           double r[3], spc_vec3 fr[3], int turned)
{
    double m[3];
    if (!spc_plane_chain_model_normal(w, p, m, fr))
        return false;
    if (turned) { /* the normal the BSDF turns toward x: its tangential part negated */
        m[0] = -m[0];
        m[1] = -m[1];
    }
    spc_vec3 n = spc_normalize(spc_add(spc_add(spc_scale(fr[0], m[0]), spc_scale(fr[1], m[1])), spc_scale(fr[2], m[2])));
    spc_vec3 i = spc_normalize(spc_sub(p, x)), o;
    if (refract) {
        /* eta: int / ext; x below the plane (inside) */
        double e = spc_dot(spc_sub(x, p), fr[2]) < 0.0 ? eta : 1.0 / eta;
        double c = -spc_dot(i, n);
        if (c < 0.0) {
            n = spc_neg(n);
            c = -c;
        }
        double k = 1.0 - e * e * (1.0 - c * c);
        if (k < 0.0)
            return false;
        o = spc_add(spc_scale(i, e), spc_scale(n, e * c - sqrt(k)));
    } else {
        o = spc_sub(i, spc_scale(n, 2.0 * spc_dot(i, n)));
    }
    spc_vec3 g = spc_sub(o, spc_normalize(spc_sub(y, p)));
    r[0] = spc_dot(g, fr[0]);
    r[1] = spc_dot(g, fr[1]);
    /* the tangential parts also agree where o is y's direction mirrored in the plane (no root):
     * r[2] holds the normal part, checked at convergence */
    r[2] = spc_dot(g, fr[2]);
    return true;
}

TEST(plane_roots_against_dense_newton)
{
    spc_rng_seed(&rng, 23, 5);
    int dense = 0, found = 0, extra = 0, enumerated = 0, multi = 0, n_turned = 0;
    for (int cfg = 0; cfg < 24; ++cfg) {
        bool mirror = cfg % 3 == 2;
        spc_scene *sc = floor_scene();
        spc_shape *w = spc_scene_new_shape(sc);
        spc_error err;
        spc_mat4 M = spc_mat4_translate(spc_v3(0, 0, 1));
        spc_shape_init_rectangle(w, &M, NULL, 0, 0, &err);
        w->bsdf = tu_normal_mapped(sc, mirror ? tu_mirror(sc) : tu_glass(sc, 1.33), 16, 0.5, 2.0, 100 + (uint64_t)cfg);
        sc = add_light_finish(sc, spc_v3(0, 0, 3), 0.1);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        w = sc->shapes[1];
        spc_vec3 x = spc_v3(-0.6 + 1.2 * rnd(), -0.6 + 1.2 * rnd(), mirror ? 1.3 + rnd() : -0.5 + rnd() * 1.3);
        spc_vec3 y = spc_v3(-1.0 + 2.0 * rnd(), -1.0 + 2.0 * rnd(), 1.5 + 2.0 * rnd());
        if (mirror && cfg % 2) { /* grazing: x and y low over the mirror, on either side of it */
            x = spc_v3(-1.3 - 0.5 * rnd(), -0.5 + rnd(), 1.03 + 0.1 * rnd());
            y = spc_v3(1.3 + 0.5 * rnd(), -0.5 + rnd(), 1.05 + 0.2 * rnd());
        }
        spc_vec3 roots[256];
        int n = spc_plane_chain_roots(w, x, y, !mirror, roots, 256);
        enumerated += n;
        spc_vec3 fr[3];
        double r[3];
        int here = 0;
        /* the dense search, in the plane's (S, T) coordinates over [-1, 1]^2 */
        spc_vec3 seen[256];
        int nseen = 0;
        const int G = 16 * 8;
        for (int turned = 0; turned < 2; ++turned)
        for (int a = 0; a < G; ++a)
            for (int b = 0; b < G; ++b) {
                spc_vec3 p = spc_v3(-1.0 + 2.0 * (a + 0.5) / G, -1.0 + 2.0 * (b + 0.5) / G, 1.0);
                bool conv = false;
                for (int it = 0; it < 40 && !conv; ++it) {
                    if (!snell_residual(w, x, y, !mirror, 1.33, p, r, fr, turned))
                        break;
                    double h = 1e-7, J[2][2];
                    for (int j = 0; j < 2; ++j) {
                        double rp[3], rm[3];
                        spc_vec3 fr2[3];
                        if (!snell_residual(w, x, y, !mirror, 1.33, spc_add(p, spc_scale(fr[j], h)), rp, fr2, turned) ||
                            !snell_residual(w, x, y, !mirror, 1.33, spc_sub(p, spc_scale(fr[j], h)), rm, fr2, turned))
                            break;
                        J[0][j] = (rp[0] - rm[0]) / (2 * h);
                        J[1][j] = (rp[1] - rm[1]) / (2 * h);
                    }
                    double det = J[0][0] * J[1][1] - J[0][1] * J[1][0];
                    if (!(fabs(det) > 1e-14))
                        break;
                    double da = -(J[1][1] * r[0] - J[0][1] * r[1]) / det, db = -(J[0][0] * r[1] - J[1][0] * r[0]) / det;
                    double len = sqrt(da * da + db * db);
                    if (len > 0.02) {
                        da *= 0.02 / len;
                        db *= 0.02 / len;
                    }
                    p = spc_add(p, spc_add(spc_scale(fr[0], da), spc_scale(fr[1], db)));
                    if (fabs(p.x) > 1.0 || fabs(p.y) > 1.0)
                        break;
                    conv = len < 1e-11 && snell_residual(w, x, y, !mirror, 1.33, p, r, fr, turned) &&
                           fabs(r[0]) + fabs(r[1]) < 1e-9 && fabs(r[2]) < 1e-6;
                }
                if (!conv)
                    continue;
                /* the BSDF's normal there: turned where x is on N's side behind the map's own normal */
                double mm[3];
                spc_plane_chain_model_normal(w, p, mm, fr);
                spc_vec3 wo = spc_sub(x, p);
                double won = spc_dot(wo, fr[0]) * mm[0] + spc_dot(wo, fr[1]) * mm[1] + spc_dot(wo, fr[2]) * mm[2];
                if ((spc_dot(wo, fr[2]) > 0.0 && won < 0.0) != (turned != 0))
                    continue; /* not the normal the BSDF has at p */
                bool dup = false;
                for (int k = 0; k < nseen && !dup; ++k)
                    dup = spc_distance(seen[k], p) < 1e-6;
                if (dup || nseen == 256)
                    continue;
                seen[nseen++] = p;
                ++dense;
                n_turned += turned;
                ++here;
                bool in = false;
                for (int k = 0; k < n && !in; ++k)
                    in = spc_distance(roots[k], p) < 1e-6;
                found += in ? 1 : 0;
                if (!in)
                    printf("    config %d (%s): root (%.6f %.6f)%s not enumerated\n", cfg, mirror ? "mirror" : "water", p.x,
                           p.y, turned ? " (turned normal)" : "");
            }
        multi += here >= 2 ? 1 : 0;
        /* every enumerated root that Snell's law realizes is one of the dense ones */
        for (int k = 0; k < n; ++k) {
            double r2[3];
            bool ok0 = snell_residual(w, x, y, !mirror, 1.33, roots[k], r, fr, 0) && fabs(r[0]) + fabs(r[1]) <= 1e-7 &&
                       fabs(r[2]) < 1e-6;
            bool ok1 = snell_residual(w, x, y, !mirror, 1.33, roots[k], r2, fr, 1) &&
                       fabs(r2[0]) + fabs(r2[1]) <= 1e-7 && fabs(r2[2]) < 1e-6;
            if (!ok0 && !ok1) {
                ++extra;
                continue;
            }
            bool in = false;
            for (int j = 0; j < nseen && !in; ++j)
                in = spc_distance(roots[k], seen[j]) < 1e-6;
            CHECK_MSG(in, "config %d: an enumerated root the dense search did not find", cfg);
        }
        spc_scene_destroy(sc);
    }
    printf("    24 configurations: dense search %d roots (%d configurations with several; %d with the turned normal), "
           "enumerated %d of them; %d enumerated in all, %d of them no refraction realizes\n",
           dense, multi, n_turned, found, enumerated, extra);
    CHECK(dense >= 40 && multi >= 4 && n_turned >= 5);
    CHECK(found == dense);
}

/* The culling test's two builds (the base ISA's and AVX2's, where the CPU has it) give the same roots,
 * bit for bit: on the square of water or mirror of plane_roots_against_dense_newton, 400 pairs x, y,
 * refractions from either side, reflections from above and grazing ones. On a CPU without AVX2 both
 * calls take the base build and the test says so. */
TEST(plane_roots_same_on_every_isa)
{
    spc_rng_seed(&rng, 29, 7);
    int configs = 0, roots = 0, differ = 0;
    bool other = false;
    for (int cfg = 0; cfg < 4; ++cfg) {
        bool mirror = cfg % 2 == 1;
        spc_scene *sc = floor_scene();
        spc_shape *w = spc_scene_new_shape(sc);
        spc_error err;
        spc_mat4 M = spc_mat4_translate(spc_v3(0, 0, 1));
        spc_shape_init_rectangle(w, &M, NULL, 0, 0, &err);
        w->bsdf = tu_normal_mapped(sc, mirror ? tu_mirror(sc) : tu_glass(sc, 1.33), 16, 0.5, 2.0, 300 + (uint64_t)cfg);
        sc = add_light_finish(sc, spc_v3(0, 0, 3), 0.1);
        CHECK(sc != NULL);
        if (!sc)
            continue;
        w = sc->shapes[1];
        for (int q = 0; q < 100; ++q) {
            spc_vec3 x =
                spc_v3(-1.2 + 2.4 * rnd(), -1.2 + 2.4 * rnd(), mirror ? 1.05 + 2.0 * rnd() : -0.5 + rnd() * 1.3);
            spc_vec3 y = spc_v3(-1.5 + 3.0 * rnd(), -1.5 + 3.0 * rnd(), 1.2 + 2.0 * rnd());
            if (mirror && q % 4 == 0) { /* grazing */
                x = spc_v3(-1.3 - 0.5 * rnd(), -0.5 + rnd(), 1.03 + 0.1 * rnd());
                y = spc_v3(1.3 + 0.5 * rnd(), -0.5 + rnd(), 1.05 + 0.2 * rnd());
            }
            if (!mirror && x.z > 1.0 && q % 2) /* refraction from above: y under the water */
                y.z = 0.2 + 0.6 * rnd();
            spc_vec3 a[256], b[256];
            int na = spc_plane_chain_roots(w, x, y, !mirror, a, 256);
            int nb = spc_plane_chain_roots_base_isa(w, x, y, !mirror, b, 256, &other);
            ++configs;
            roots += na;
            if (na != nb || memcmp(a, b, sizeof a[0] * (size_t)na) != 0) {
                ++differ;
                printf("    configuration %d, pair %d: %d roots against the base build's %d\n", cfg, q, na, nb);
            }
        }
        spc_scene_destroy(sc);
    }
    printf("    %d pairs, %d roots; the CPU's build %s; %d pairs differ\n", configs, roots,
           other ? "is AVX2's" : "is the base ISA's (no AVX2 here: nothing compared)", differ);
    CHECK(roots >= 100);
    CHECK(differ == 0);
}

int main(void)
{
    RUN(planar_roots_against_dense_scan);
    RUN(planar_roots_near_the_sphere);
    RUN(inside_roots_against_dense_scan);
    RUN(inside_roots_pairs_at_the_fold);
    RUN(reflection_roots_against_dense_scan);
    RUN(sphere_signatures_together_same_as_alone);
    RUN(roots1d_ahead_read_at_the_root);
    RUN(sphere_chains_contain_randomized_solutions);
    RUN(cylinder_roots_against_dense_scan);
    RUN(cylinder_chains_contain_randomized_solutions);
    RUN(plane_model_normal_matches_chain_vertex);
    RUN(plane_chains_contain_randomized_solutions);
    RUN(plane_roots_against_dense_newton);
    RUN(plane_roots_same_on_every_isa);
    return spc_test_finish();
}
