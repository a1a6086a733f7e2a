/*
 * tests/test_light_skip.c: shadow rays toward a sphere light's own sample leave that sphere
 * untested (spc_scene_occluded_light, Embree's ray masks), and nothing else changes.
 *
 * A ray through a sphere light is blocked by it, except when the ray names that light; every other
 * shape (another sphere light, a plain sphere, triangles) still blocks it, and beyond the 31 mask
 * bits a sphere light is tested again. Shadow rays from points on a floor and from inside a light
 * toward that light's samples give spc_scene_occluded's answer wherever the light itself is not the
 * nearest thing on the ray, and the packet form equals the single rays lane by lane, in packets of
 * 8 and of 16 lanes.
 */
/* ctest-labels: unit */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/accel.h"
#include "core/rng.h"
#include "emitter/emitter.h"
#include "harness.h"
#include "io/mitsuba_xml.h"
#include "packets.h"
#include "scene/hit.h"
#include "scene/scene.h"

/* shape 0: the floor (z = 0, 20 x 20); 1: sphere light A at (0,0,2) r 0.5; 2: sphere light B at
 * (3,0,2) r 0.3; 3: a plain sphere at (-2,0,1) r 0.4; 4: a rectangle light at z = 4 facing down;
 * 5: a plain quad at z = 1 over x in [2, 4], y in [-1, 1] */
static const char *skip_xml =
    "<scene version='3.0.0'>"
    "<shape type='rectangle'><transform name='to_world'><scale value='10'/></transform><bsdf type='diffuse'/></shape>"
    "<shape type='sphere'><point name='center' value='0,0,2'/><float name='radius' value='0.5'/>"
    "<emitter type='area'><rgb name='radiance' value='2,2,2'/></emitter></shape>"
    "<shape type='sphere'><point name='center' value='3,0,2'/><float name='radius' value='0.3'/>"
    "<emitter type='area'><rgb name='radiance' value='1,2,3'/></emitter></shape>"
    "<shape type='sphere'><point name='center' value='-2,0,1'/><float name='radius' value='0.4'/>"
    "<bsdf type='diffuse'/></shape>"
    "<shape type='rectangle'><transform name='to_world'><rotate x='1' angle='180'/><translate value='0,0,4'/>"
    "</transform><emitter type='area'><rgb name='radiance' value='1,1,1'/></emitter></shape>"
    "<shape type='rectangle'><transform name='to_world'><translate value='3,0,1'/></transform>"
    "<bsdf type='diffuse'/></shape>"
    "</scene>";

static spc_scene *load(const char *xml)
{
    spc_scene *sc = NULL;
    spc_error err;
    if (spc_mitsuba_load_string(xml, strlen(xml), "skip.xml", NULL, NULL, 0, &sc, &err) != SPC_OK) {
        printf("  load: %s\n", err.msg);
        return NULL;
    }
    return sc;
}

static spc_ray seg(spc_vec3 a, spc_vec3 b)
{
    spc_vec3 d = spc_sub(b, a);
    double len = spc_length(d);
    spc_ray r = {a, spc_scale(d, 1.0 / len), 0.0, len};
    return r;
}

static const spc_emitter *emitter_of(const spc_scene *sc, int shape)
{
    for (int k = 0; k < sc->nemitters; ++k)
        if (sc->emitters[k]->shape == sc->shapes[shape])
            return sc->emitters[k];
    return NULL;
}

TEST(only_the_named_sphere_light_is_skipped)
{
    spc_scene *sc = load(skip_xml);
    CHECK(sc != NULL);
    if (!sc)
        return;
    const spc_emitter *A = emitter_of(sc, 1), *B = emitter_of(sc, 2), *Q = emitter_of(sc, 4);
    CHECK(A && B && Q);
    CHECK(spc_scene_light_skip(A) == 1);
    CHECK(spc_scene_light_skip(B) == 2);
    CHECK(spc_scene_light_skip(Q) == -1); /* a rectangle light: every shape tested */
    CHECK(spc_scene_light_skip(NULL) == -1);
    /* straight down through A (z 1.5 to 2.5) to just above the floor */
    spc_ray r = seg(spc_v3(0.1, 0, 3.5), spc_v3(0.1, 0, 0.5));
    CHECK(spc_scene_occluded(sc, &r));
    CHECK(!spc_scene_occluded_light(sc, &r, A)); /* fails where the mask is not honoured */
    CHECK(spc_scene_occluded_light(sc, &r, B));
    CHECK(spc_scene_occluded_light(sc, &r, Q));
    CHECK(spc_scene_occluded_light(sc, &r, NULL));
    /* through B and then the quad: skipping B leaves the quad */
    spc_ray rb = seg(spc_v3(3, 0, 3), spc_v3(3, 0, 0.5));
    CHECK(spc_scene_occluded_light(sc, &rb, B));
    spc_ray rb2 = seg(spc_v3(3, 0, 3), spc_v3(3, 0, 1.5));
    CHECK(spc_scene_occluded(sc, &rb2));
    CHECK(!spc_scene_occluded_light(sc, &rb2, B));
    /* through the plain sphere and through A: still blocked by the plain sphere */
    spc_ray rc = seg(spc_v3(-2, 0, 2), spc_v3(-2, 0, 0.2));
    CHECK(spc_scene_occluded_light(sc, &rc, A));
    /* the packet form, lane by lane */
    const spc_ray *pr[SPC_SCENE_PACKET];
    const spc_emitter *pe[SPC_SCENE_PACKET];
    bool occ[SPC_SCENE_PACKET];
    const spc_ray *rays[4] = {&r, &rb, &rb2, &rc};
    const spc_emitter *ems[4] = {A, B, NULL, Q};
    int n = 0, bad = 0;
    for (int i = 0; i < SPC_SCENE_PACKET; ++i) {
        pr[i] = i % 5 == 4 ? NULL : rays[i % 4];
        pe[i] = ems[(i / 4 + i) % 4];
    }
    packets_occluded_light(sc, pr, pe, occ, false);
    for (int i = 0; i < SPC_SCENE_PACKET; ++i) {
        bool one = pr[i] ? spc_scene_occluded_light(sc, pr[i], pe[i]) : false;
        bad += one != occ[i];
        n += pr[i] != NULL;
    }
    CHECK_MSG(bad == 0, "%d lanes of %d differ from single rays", bad, n);
    spc_scene_destroy(sc);
}

/* Shadow rays as the path tracers make them (spc_hit_spawn_to from a floor hit toward a light's
 * sample), and from points inside A toward A's samples: the answer is spc_scene_occluded's unless
 * the light itself is the nearest hit on the ray (rounding); some rays are blocked by the other
 * shapes. Packets of 16 equal the single rays. */
TEST(shadow_rays_toward_samples_agree)
{
    spc_scene *sc = load(skip_xml);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_rng rng;
    spc_rng_seed(&rng, 5, 9);
    int nrays = 0, nblocked = 0, ndiff = 0, nbad = 0, npacket_bad = 0;
    enum { W = SPC_SCENE_PACKET };
    spc_ray pr_store[W];
    const spc_ray *pr[W];
    const spc_emitter *pe[W];
    bool single[W], occ[W];
    int lanes = 0;
    for (int k = 0; k < 20000; ++k) {
        const spc_emitter *e = sc->emitters[spc_rng_next(&rng) < 0.5 ? 0 : 1];
        if (e->shape->type != SPC_SHAPE_SPHERE)
            e = emitter_of(sc, 1);
        spc_ray sr;
        spc_emitter_direct ds;
        spc_vec2 u = spc_v2(spc_rng_next(&rng), spc_rng_next(&rng));
        if (k % 4 == 3 && e == emitter_of(sc, 1)) {
            /* from inside A (area sampling), a plain segment stopping short of the sample */
            spc_vec3 c = e->shape->center;
            spc_vec3 ref = spc_add(c, spc_v3(0.8 * spc_rng_next(&rng) - 0.4, 0.4 * spc_rng_next(&rng) - 0.2,
                                             0.4 * spc_rng_next(&rng) - 0.2));
            if (!spc_emitter_sample_direct(e, ref, u, &ds))
                continue;
            sr = seg(ref, ds.p);
            sr.tmax *= 1.0 - 1e-7;
        } else {
            spc_vec3 o = spc_v3(12.0 * spc_rng_next(&rng) - 6.0, 8.0 * spc_rng_next(&rng) - 4.0, 5.0);
            spc_ray down = {o, spc_v3(0, 0, -1), 0.0, SPC_INF};
            spc_hit h;
            if (!spc_scene_intersect(sc, &down, &h) || h.shape != sc->shapes[0])
                continue;
            if (!spc_emitter_sample_direct(e, h.p, u, &ds))
                continue;
            sr = spc_hit_spawn_to(&h, ds.p, ds.err);
        }
        ++nrays;
        bool plain = spc_scene_occluded(sc, &sr), light = spc_scene_occluded_light(sc, &sr, e);
        nblocked += light;
        if (plain != light) {
            ++ndiff;
            spc_hit h2;
            bool own = !light && spc_scene_intersect(sc, &sr, &h2) && h2.shape == e->shape;
            nbad += !own;
        }
        pr_store[lanes] = sr;
        pe[lanes] = e;
        single[lanes] = light;
        if (++lanes == W) {
            for (int i = 0; i < W; ++i)
                pr[i] = &pr_store[i];
            packets_occluded_light(sc, pr, pe, occ, false);
            for (int i = 0; i < W; ++i)
                npacket_bad += occ[i] != single[i];
            lanes = 0;
        }
    }
    CHECK_MSG(nrays > 10000, "only %d shadow rays", nrays);
    CHECK_MSG(nblocked > 200, "only %d blocked by the other shapes", nblocked);
    CHECK_MSG(nbad == 0, "%d of %d answers differ without the light being the ray's nearest hit (%d differ)",
              nbad, nrays, ndiff);
    CHECK_MSG(npacket_bad == 0, "%d packet lanes differ from single rays", npacket_bad);
    printf("  %d shadow rays, %d blocked, %d answers changed by the skip\n", nrays, nblocked, ndiff);
    spc_scene_destroy(sc);
}

/* Beyond SPC_ACCEL_SKIP_MAX sphere lights there are no mask bits left: the later ones are tested. */
TEST(sphere_lights_beyond_the_mask_bits_are_tested)
{
    enum { N = SPC_ACCEL_SKIP_MAX + 3 };
    size_t cap = 256 * N + 64;
    char *xml = malloc(cap);
    CHECK(xml != NULL);
    if (!xml)
        return;
    size_t len = (size_t)snprintf(xml, cap, "<scene version='3.0.0'>");
    for (int i = 0; i < N; ++i)
        len += (size_t)snprintf(xml + len, cap - len,
                                "<shape type='sphere'><point name='center' value='%d,0,0'/><float name='radius' "
                                "value='0.3'/><emitter type='area'><rgb name='radiance' value='1,1,1'/></emitter></shape>",
                                i);
    snprintf(xml + len, cap - len, "</scene>");
    spc_scene *sc = load(xml);
    free(xml);
    CHECK(sc != NULL);
    if (!sc)
        return;
    int skipped = 0, tested = 0;
    for (int i = 0; i < N; ++i) {
        const spc_emitter *e = emitter_of(sc, i);
        CHECK(e && spc_scene_light_skip(e) == i);
        spc_ray r = seg(spc_v3(i, 0, 2), spc_v3(i, 0, -2));
        CHECK(spc_scene_occluded(sc, &r));
        if (spc_scene_occluded_light(sc, &r, e))
            ++tested;
        else
            ++skipped;
    }
    CHECK_MSG(skipped == SPC_ACCEL_SKIP_MAX && tested == N - SPC_ACCEL_SKIP_MAX, "skipped %d, tested %d", skipped,
              tested);
    spc_scene_destroy(sc);
}

/* Two sphere lights and nothing else: A at (0,0,2) r 0.5 and B at (3,0,2) r 0.3, or the same far
 * from the origin and small (centers near (1e4, -2e4, 3e3), radii 1e-3 and 2e-3). */
static const char *two_lights_xml =
    "<scene version='3.0.0'>"
    "<shape type='sphere'><point name='center' value='0,0,2'/><float name='radius' value='0.5'/>"
    "<emitter type='area'><rgb name='radiance' value='1,1,1'/></emitter></shape>"
    "<shape type='sphere'><point name='center' value='3,0,2'/><float name='radius' value='0.3'/>"
    "<emitter type='area'><rgb name='radiance' value='1,1,1'/></emitter></shape>"
    "</scene>";
static const char *far_lights_xml =
    "<scene version='3.0.0'>"
    "<shape type='sphere'><point name='center' value='10000.3,-20000.1,3000.7'/><float name='radius' value='0.001'/>"
    "<emitter type='area'><rgb name='radiance' value='1,1,1'/></emitter></shape>"
    "<shape type='sphere'><point name='center' value='10000.31,-20000.1,3000.7'/><float name='radius' value='0.002'/>"
    "<emitter type='area'><rgb name='radiance' value='1,1,1'/></emitter></shape>"
    "</scene>";

/* A packet's lanes whose lines pass clearly outside a sphere light are not handed to its exact
 * test (the packets' cull on the float rays): a packet of 16 shadow rays of which one passes
 * through A runs exactly one analytic test (Embree's packet traversal alone hands every active
 * lane to the callback of a sphere that any lane's ray meets: 16 here). */
TEST(packets_skip_the_exact_test_for_lines_far_from_spheres)
{
    spc_scene *sc = load(two_lights_xml);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_ray rs[SPC_SCENE_PACKET];
    const spc_ray *pr[SPC_SCENE_PACKET];
    const spc_emitter *pe[SPC_SCENE_PACKET];
    bool occ[SPC_SCENE_PACKET];
    for (int i = 0; i < SPC_SCENE_PACKET; ++i) {
        /* lane 0 straight up through A; the others straight up at x = -1.5 - i/10 */
        double x = i == 0 ? 0.1 : -1.5 - 0.1 * i;
        rs[i] = seg(spc_v3(x, 0.05 * i, 0), spc_v3(x, 0.05 * i, 4));
        pr[i] = &rs[i];
        pe[i] = NULL;
    }
    uint64_t before = spc_accel_analytic_tests();
    packets_occluded_light(sc, pr, pe, occ, false);
    uint64_t tests = spc_accel_analytic_tests() - before;
    CHECK(occ[0]);
    int nocc = 0;
    for (int i = 1; i < SPC_SCENE_PACKET; ++i)
        nocc += occ[i];
    CHECK_MSG(nocc == 0, "%d lanes blocked that pass beside the lights", nocc);
    CHECK_MSG(tests == 1, "%llu exact tests for one lane that meets a light", (unsigned long long)tests);
    spc_scene_destroy(sc);
}

/* The cull never changes an answer: rays whose lines pass at r (1 + eps) from a light's center,
 * eps from -1e-3 to 1e-3 down to 1e-15 and 0, near the origin and far from it, give in packets
 * the single rays' answers (which no cull touches) lane by lane, and the lanes whose lines pass
 * within 1e-5 r of the silhouette still meet the exact test. */
TEST(packets_cull_agrees_at_the_silhouette)
{
    const char *xmls[2] = {two_lights_xml, far_lights_xml};
    static const double eps[] = {0.0, 1e-15, 1e-12, 1e-9, 1e-7, 1e-5, 1e-3, 1e-1, 1.0};
    const int neps = (int)(sizeof eps / sizeof eps[0]);
    for (int x = 0; x < 2; ++x) {
        spc_scene *sc = load(xmls[x]);
        CHECK(sc != NULL);
        if (!sc)
            return;
        spc_rng rng;
        spc_rng_seed(&rng, 11, (uint64_t)x);
        int nbad = 0, nhit = 0, nmiss = 0, lanes = 0, nnear = 0;
        uint64_t near_tests = 0;
        spc_ray rs[SPC_SCENE_PACKET];
        const spc_ray *pr[SPC_SCENE_PACKET];
        const spc_emitter *pe[SPC_SCENE_PACKET];
        bool occ[SPC_SCENE_PACKET], single[SPC_SCENE_PACKET];
        bool near[SPC_SCENE_PACKET];
        for (int k = 0; k < 4000; ++k) {
            const spc_shape *s = sc->shapes[k % 2];
            double R = s->radius;
            /* a unit direction d and a unit normal n to it: the line through c + R (1 + e) n along d */
            spc_vec3 d = spc_normalize(spc_v3(spc_rng_next(&rng) - 0.5, spc_rng_next(&rng) - 0.5, spc_rng_next(&rng) - 0.5));
            spc_vec3 n = spc_normalize(spc_cross(d, spc_v3(spc_rng_next(&rng) - 0.5, spc_rng_next(&rng) - 0.5, 1.0)));
            double e = eps[(k / 2) % neps] * (k % 4 < 2 ? 1.0 : -1.0);
            double back = R * (2.0 + 50.0 * spc_rng_next(&rng));
            spc_vec3 p = spc_add(s->center, spc_scale(n, R * (1.0 + e)));
            int i = lanes++;
            rs[i] = (spc_ray){spc_sub(p, spc_scale(d, back)), d, 0.0, 2.0 * back};
            pr[i] = &rs[i];
            pe[i] = NULL;
            near[i] = fabs(e) <= 1e-5;
            single[i] = spc_scene_occluded(sc, &rs[i]);
            nhit += single[i];
            nmiss += !single[i];
            if (lanes < SPC_SCENE_PACKET)
                continue;
            packets_occluded_light(sc, pr, pe, occ, false);
            for (int j = 0; j < SPC_SCENE_PACKET; ++j)
                nbad += occ[j] != single[j];
            /* the near lanes alone: each meets its sphere's exact test */
            int m = 0;
            for (int j = 0; j < SPC_SCENE_PACKET; ++j) {
                pr[j] = near[j] ? &rs[j] : NULL;
                m += near[j];
            }
            uint64_t before = spc_accel_analytic_tests();
            packets_occluded_light(sc, pr, pe, occ, false);
            near_tests += spc_accel_analytic_tests() - before;
            nnear += m;
            lanes = 0;
        }
        CHECK_MSG(nbad == 0, "scene %d: %d packet lanes differ from single rays", x, nbad);
        CHECK_MSG(nhit > 500 && nmiss > 500, "scene %d: %d hits, %d misses", x, nhit, nmiss);
        CHECK_MSG(near_tests >= (uint64_t)nnear, "scene %d: %llu exact tests for %d lanes at the silhouette", x,
                  (unsigned long long)near_tests, nnear);
        printf("  scene %d: %d hits, %d misses, %d silhouette lanes, %llu exact tests for them\n", x, nhit, nmiss,
               nnear, (unsigned long long)near_tests);
        spc_scene_destroy(sc);
    }
}

int main(void)
{
    for (int w = 8; w <= 16; w += 8) {
        packets_set_width(w);
        printf("packets of %d lanes\n", w);
        RUN(only_the_named_sphere_light_is_skipped);
        RUN(shadow_rays_toward_samples_agree);
        RUN(sphere_lights_beyond_the_mask_bits_are_tested);
        RUN(packets_skip_the_exact_test_for_lines_far_from_spheres);
        RUN(packets_cull_agrees_at_the_silhouette);
    }
    packets_set_width(0);
    return spc_test_finish();
}
