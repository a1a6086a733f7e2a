/*
 * tests/test_snee_lights.c: specular NEE's chains toward the kinds of area light
 * (manifold/specular_nee.c, the last segment of a chain).
 *
 * - A small rectangle light (two triangles) a few units from the origin, a glass ball between it
 *   and the floor: the default's image of the ball's shadow and caustic against specular NEE off.
 *   A point sampled on a triangle lies off the plane the ray tracer intersects by up to its error
 *   bound; a chain's last segment that stopped short of it by less shadowed the light by itself,
 *   and about one chain in seven was lost (the image 14% low, z about -8, 94% of the pixels
 *   passing; random caustic scene 16 was 16% low on the floor in the ball's shadow). The light's size, radiance and the camera
 *   are those of that case, where the loss showed; a light three times larger lost nothing.
 * - The light sample's uniforms from the path tracer's stream (spc_snee_params.light_u_smp): the
 *   light and point spc_snee_sample_light draws from a copy of the stream are those of the
 *   uniforms drawn at once in the path tracer's order (light_u_on), on two lights and many
 *   streams, and differ from those of the pairs taken the other way round.
 * - A share of a sphere light's points drawn in the cone from the receiver (params.light_x): the
 *   mixture's density integrates to the light's area, and the samples land on the side the
 *   receiver sees.
 * - The long pass's own light point under that share (spc_snee_sample_long_light): drawn from the
 *   cap alone at its density, as without the share, on newton_slabs' light (the whole sphere) and
 *   caustic_slabs' (a cap: the light outside the casters' sphere).
 */
/* ctest-labels: stat */
/* ctest-timeout: 300 */
#include <math.h>
#include <string.h>

#include "core/sampler.h"
#include "harness.h"
#include "manifold/fit_seeds.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "render_util.h"

/* A floor (z = 0, half-size 4), a glass sphere of radius 0.257 resting on it, and a square light of
 * half-size ls and radiance L at (2.91, 0.822, 3.039) facing the origin; an 8x8 camera looking
 * straight down at the ball's shadow from 1.2 above. (Random caustic scene 16's small ball and light,
 * its y-up coordinates turned to z-up.) NULL if the scene cannot be made. */
static spc_scene *shadow_scene(double ls, double L)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *fl = spc_scene_new_shape(sc);
    spc_mat4 F = spc_mat4_scale(spc_v3(4, 4, 1));
    spc_shape_init_rectangle(fl, &F, NULL, 0, 0, &err);
    fl->bsdf = tu_diffuse(sc, 0.5);
    tu_sphere(sc, spc_v3(-0.516, 0.656, 0.257), 0.257, tu_glass(sc, 1.5));
    spc_shape *light = spc_scene_new_shape(sc);
    spc_mat4 look, S = spc_mat4_scale(spc_v3(ls, ls, 1));
    spc_mat4_lookat(spc_v3(2.91, 0.822, 3.039), spc_v3(0, 0, 0), spc_v3(0, -0.01, 1), &look);
    spc_mat4 M = spc_mat4_mul(&look, &S);
    spc_shape_init_rectangle(light, &M, NULL, 0, 0, &err);
    light->bsdf = tu_diffuse(sc, 0.0);
    tu_area(sc, light, 2, L);
    tu_camera(sc, spc_v3(-1.0, 0.64, 1.2), spc_v3(-1.0, 0.64, 0.0), spc_v3(1, 0, 0), 30, 8, 8);
    sc->integrator.max_depth = 4;
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

TEST(triangle_light_chains_not_self_shadowed)
{
    spc_scene *sc = shadow_scene(0.4, 75.0);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_film *ref = tu_render_nee(sc, "path", "none", 65536, 2, 51, NULL);
    spc_film *img = tu_render_nee(sc, "path", NULL, 2048, 2, 52, NULL);
    CHECK(ref && img);
    if (ref && img) {
        spc_diff_result d;
        memset(&d, 0, sizeof d);
        CHECK(tu_image_agrees(img, ref, 0.95, "default vs none", &d));
        double ma, sa, mb, sb;
        tu_image_mean(img, 1, &ma, &sa);
        tu_image_mean(ref, 1, &mb, &sb);
        printf("    z-test pass %.4f of %d pixels; green means %.5f +- %.5f vs %.5f +- %.5f (ratio %.4f)\n",
               d.ztest_pass_fraction, d.ztest_pixels, ma, sa, mb, sb, ma / mb);
    }
    spc_film_destroy(img);
    spc_film_destroy(ref);
    spc_scene_destroy(sc);
}

/* A floor, a glass ball and two square lights of different power (light_u[0] picks one). */
static spc_scene *two_light_scene(void)
{
    spc_scene *sc = spc_scene_create();
    spc_error err;
    spc_shape *fl = spc_scene_new_shape(sc);
    spc_mat4 F = spc_mat4_scale(spc_v3(4, 4, 1));
    spc_shape_init_rectangle(fl, &F, NULL, 0, 0, &err);
    fl->bsdf = tu_diffuse(sc, 0.5);
    tu_sphere(sc, spc_v3(0, 0, 0.5), 0.5, tu_glass(sc, 1.5));
    for (int i = 0; i < 2; ++i) {
        spc_shape *light = spc_scene_new_shape(sc);
        spc_mat4 look, S = spc_mat4_scale(spc_v3(0.3 + 0.2 * i, 0.3, 1));
        spc_mat4_lookat(spc_v3(i ? -2.0 : 2.0, 0.5, 3.0), spc_v3(0, 0, 0), spc_v3(0, -0.01, 1), &look);
        spc_mat4 M = spc_mat4_mul(&look, &S);
        spc_shape_init_rectangle(light, &M, NULL, 0, 0, &err);
        light->bsdf = tu_diffuse(sc, 0.0);
        tu_area(sc, light, 2 + i, i ? 30.0 : 10.0);
    }
    tu_camera(sc, spc_v3(0, -3, 2), spc_v3(0, 0, 0.3), spc_v3(0, 0, 1), 40, 8, 8);
    if (spc_scene_finalize(sc, &err) != SPC_OK) {
        printf("  finalize: %s\n", err.msg);
        spc_scene_destroy(sc);
        return NULL;
    }
    return sc;
}

/* The light sample of spc_snee_sample_light with parameters p at the floor point x. */
static bool light_sample(const spc_scene *sc, const spc_snee_params *p, const spc_hit *x, const spc_emitter **e,
                         spc_snee_query *q, double *p_y)
{
    spc_snee_query_init(q, sc, p, x, spc_v3(0, 0, 1), 2);
    spc_rng rng;
    spc_rng_seed(&rng, 1, 2);
    spc_vec2 uv;
    return spc_snee_sample_light(sc, p->any_surface, &rng, q, e, &uv, p_y);
}

TEST(light_uniforms_from_the_stream)
{
    spc_scene *sc = two_light_scene();
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_snee_params p;
    CHECK(spc_snee_parse("angular", 2, &p));
    spc_hit x;
    memset(&x, 0, sizeof x);
    x.p = spc_v3(0.7, 0.3, 0.0);
    x.ng = x.sh.n = spc_v3(0, 0, 1);
    int same = 0, swapped_differ = 0, lights[2] = {0, 0}, n = 256;
    for (int i = 0; i < n; ++i) {
        spc_sampler s;
        spc_sampler_start(&s, (uint32_t)(i % 16), (uint32_t)(i / 16), (uint32_t)i, 77);
        spc_sampler_skip(&s, (uint32_t)(i % 5));
        /* the path tracer's order: the point's pair, then the light's choice */
        spc_sampler a = s;
        spc_vec2 u_pos = spc_sampler_2d(&a);
        spc_snee_params pe = p, pl = p, pw = p;
        pe.light_u_on = true;
        pe.light_u[0] = spc_sampler_1d(&a);
        pe.light_u[1] = u_pos.x;
        pe.light_u[2] = u_pos.y;
        pl.light_u_smp = &s;
        /* the two pairs the other way round */
        spc_sampler b = s;
        pw.light_u_on = true;
        pw.light_u[0] = spc_sampler_1d(&b);
        spc_vec2 u_w = spc_sampler_2d(&b);
        pw.light_u[1] = u_w.x;
        pw.light_u[2] = u_w.y;
        const spc_emitter *ee = NULL, *el = NULL, *ew = NULL;
        spc_snee_query qe, ql, qw;
        double ye = 0.0, yl = 0.0, yw = 0.0;
        bool oe = light_sample(sc, &pe, &x, &ee, &qe, &ye), ol = light_sample(sc, &pl, &x, &el, &ql, &yl),
             ow = light_sample(sc, &pw, &x, &ew, &qw, &yw);
        if (oe == ol && ee == el && (!oe || (qe.y.x == ql.y.x && qe.y.y == ql.y.y && qe.y.z == ql.y.z && ye == yl)))
            ++same;
        if (oe && (ow != oe || ew != ee || qw.y.x != qe.y.x || qw.y.y != qe.y.y))
            ++swapped_differ;
        if (oe && ee)
            ++lights[ee == sc->emitters[0] ? 0 : 1];
    }
    printf("    %d of %d light samples the same; %d differ with the pairs swapped; lights picked %d, %d\n", same, n,
           swapped_differ, lights[0], lights[1]);
    CHECK(same == n);
    CHECK(swapped_differ > n / 2);
    CHECK(lights[0] > 0 && lights[1] > 0);
    spc_scene_destroy(sc);
}

/* params.light_x on scenes/newton_slabs.xml's sphere light (radius 0.3, inside the slabs' bounding
 * sphere: every point of it faces the casters) from a floor point under the slabs: the mean of
 * 1 / p_y over the light samples is the light's area 4 pi R^2 for the shares 0, 0.5 and 0.9 (every
 * point drawn with the mixture's density, none left out), and the share of samples on the side the
 * receiver sees (where the chains through the slabs end) rises from under a half to near 0.95. */
TEST(light_cone_from_the_receiver)
{
    spc_scene *sc = tu_load("scenes/newton_slabs.xml", 8);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const spc_emitter *light = sc->emitters[0];
    CHECK(light->type == SPC_EMITTER_AREA && light->shape->type == SPC_SHAPE_SPHERE);
    const double R = light->shape->radius, area = 4.0 * SPC_PI * R * R;
    spc_hit x;
    memset(&x, 0, sizeof x);
    x.p = spc_v3(0.1, 0.0, 0.2);
    x.ng = x.sh.n = spc_v3(0, 1, 0);
    const double shares[3] = {0.0, 0.5, 0.9};
    double seen[3];
    for (int k = 0; k < 3; ++k) {
        spc_snee_params p;
        CHECK(spc_snee_parse("angular", 4, &p));
        p.light_x = shares[k];
        spc_rng rng;
        spc_rng_seed(&rng, 5, (uint64_t)k);
        const int n = 200000;
        double s1 = 0.0, s2 = 0.0;
        int front = 0;
        for (int i = 0; i < n; ++i) {
            spc_snee_query q;
            spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 1, 0), 4);
            const spc_emitter *e = NULL;
            spc_vec2 uv;
            double p_y = 0.0;
            if (!spc_snee_sample_light(sc, p.any_surface, &rng, &q, &e, &uv, &p_y) || !(p_y > 0.0))
                continue;
            s1 += 1.0 / p_y;
            s2 += 1.0 / (p_y * p_y);
            front += spc_dot(q.ny, spc_sub(x.p, q.y)) > 0.0;
        }
        double m = s1 / n, se = sqrt(fmax(0.0, s2 / n - m * m) / n);
        seen[k] = (double)front / n;
        printf("    lightx=%g: mean 1/p_y %.5f +- %.5f (area %.5f), samples x sees %.3f\n", shares[k], m, se, area,
               seen[k]);
        CHECK_MSG(fabs(m - area) < 4.0 * se + 1e-9 * area, "lightx=%g: %.5f vs %.5f", shares[k], m, area);
    }
    CHECK(seen[0] < 0.5 && seen[1] > seen[0] + 0.2 && seen[2] > 0.9);
    spc_scene_destroy(sc);
}

/* spc_snee_sample_long_light with params.light_x = 0.5 from a floor point: over many queries the
 * mean of 1 / p_y of the long pass's own point equals that of the query's point drawn without the
 * share (both the area of the cap facing the casters: the whole light on scenes/newton_slabs.xml, a
 * cap on scenes/caustic_slabs.xml), and the share of its points the receiver sees is the cap's, not
 * the mixture's; without the share nothing is drawn and the query's point is kept. */
static void long_light_from_the_cap(const char *path, spc_vec3 xp)
{
    spc_scene *sc = tu_load(path, 8);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_hit x;
    memset(&x, 0, sizeof x);
    x.p = xp;
    x.ng = x.sh.n = spc_v3(0, 1, 0);
    const int n = 200000;
    double m[2], se[2], seen[2];
    for (int k = 0; k < 2; ++k) { /* k 0: the query's point without the share; 1: the long pass's with it */
        spc_snee_params p;
        CHECK(spc_snee_parse("angular", 4, &p));
        p.light_x = k ? 0.5 : 0.0;
        spc_rng rng;
        spc_rng_seed(&rng, 7, (uint64_t)k);
        double s1 = 0.0, s2 = 0.0;
        /* the denominator: every query without the share (its failed draws count 0), the queries
         * whose own point was drawn with it (the long pass runs only after one) */
        int front = 0, drawn = 0, kept = 0, queries = 0;
        for (int i = 0; i < n; ++i) {
            spc_snee_query q;
            spc_snee_query_init(&q, sc, &p, &x, spc_v3(0, 1, 0), 4);
            const spc_emitter *e = NULL;
            spc_vec2 uv;
            double p_y = 0.0;
            bool lit = spc_snee_sample_light(sc, p.any_surface, &rng, &q, &e, &uv, &p_y) && p_y > 0.0;
            queries += k == 0 || lit;
            if (!lit)
                continue;
            spc_snee_query lq = q;
            spc_fit_roots fit;
            spc_vec2 luv = uv;
            double lp = p_y;
            bool ok = spc_snee_sample_long_light(&q, e, &rng, &lq, &fit, &luv, &lp);
            if (k == 0) {
                kept += ok && lp == p_y && spc_distance(lq.y, q.y) == 0.0;
                lq = q;
            } else {
                if (!ok || !(lp > 0.0))
                    continue;
                drawn += spc_distance(lq.y, q.y) > 0.0;
                CHECK(lq.p_y == lp);
            }
            double py = k ? lp : p_y;
            s1 += 1.0 / py;
            s2 += 1.0 / (py * py);
            front += spc_dot(lq.ny, spc_sub(x.p, lq.y)) > 0.0;
        }
        m[k] = s1 / queries;
        se[k] = sqrt(fmax(0.0, s2 / queries - m[k] * m[k]) / queries);
        seen[k] = (double)front / queries;
        if (k == 0)
            CHECK_MSG(kept > n / 2, "%s: the query's point kept %d times", path, kept);
        else
            CHECK_MSG(drawn > n / 2, "%s: the long pass's own point drawn %d times", path, drawn);
    }
    printf("    %s: mean 1/p_y %.5f +- %.5f (the query's, no share) vs %.5f +- %.5f (the long pass's, share "
           "0.5); share seen %.3f vs %.3f\n",
           path, m[0], se[0], m[1], se[1], seen[0], seen[1]);
    CHECK_MSG(fabs(m[0] - m[1]) < 4.0 * sqrt(se[0] * se[0] + se[1] * se[1]) + 1e-9 * m[0], "%s: %.5f vs %.5f", path,
              m[0], m[1]);
    CHECK_MSG(fabs(seen[0] - seen[1]) < 0.01, "%s: seen %.3f vs %.3f", path, seen[0], seen[1]);
    spc_scene_destroy(sc);
}

TEST(long_pass_light_from_the_cap)
{
    long_light_from_the_cap("scenes/newton_slabs.xml", spc_v3(0.1, 0.0, 0.2));
    long_light_from_the_cap("scenes/caustic_slabs.xml", spc_v3(0.1, 0.0, 0.2));
}

int main(void)
{
    RUN(triangle_light_chains_not_self_shadowed);
    RUN(light_uniforms_from_the_stream);
    RUN(light_cone_from_the_receiver);
    RUN(long_pass_light_from_the_cap);
    return spc_test_finish();
}
