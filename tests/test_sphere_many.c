/*
 * tests/test_sphere_many.c: sphere lights sampled for many reference points at once
 * (emitter/sphere_many.c, through spc_emitter_sample_direct_many) give spc_emitter_sample_direct's
 * records bit for bit, in each of the three loops (plain, AVX2, AVX-512, as far as the CPU has them).
 *
 * Spheres: a plain one, one with flipped normals, one placed by a to_world transform (scaled and
 * moved), a large one, a textured one (not covered: one lane at a time) and a rectangle light mixed
 * in (the triangle loops). Reference points: random ones around the spheres, points just outside the
 * surface (cos_max near 0, the tangent clamp of cos_alpha), far away (a tiny cone), and inside
 * (area sampling, one lane at a time). The random numbers include u.y on the quarter turns and half
 * way between them (the sine and cosine's quadrant switch) and u.x at 0 and next to 1.
 */
/* ctest-labels: unit */
#include <float.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "core/rng.h"
#include "emitter/emitter.h"
#include "harness.h"
#include "io/mitsuba_xml.h"
#include "scene/scene.h"
#include "scene/shape.h"

static const char *spheres_xml =
    "<scene version='3.0.0'>"
    "<shape type='sphere'><point name='center' value='1,0,1'/><float name='radius' value='0.25'/>"
    "<emitter type='area'><rgb name='radiance' value='2,3,4'/></emitter></shape>"
    "<shape type='sphere'><point name='center' value='-1,0.5,0'/><float name='radius' value='0.4'/>"
    "<boolean name='flip_normals' value='true'/><emitter type='area'><rgb name='radiance' value='1,1,1'/>"
    "</emitter></shape>"
    "<shape type='sphere'><transform name='to_world'><scale value='0.3'/><translate value='0.2,-1.1,0.4'/>"
    "</transform><emitter type='area'><rgb name='radiance' value='5,1,1'/></emitter></shape>"
    "<shape type='sphere'><point name='center' value='0,40,0'/><float name='radius' value='35'/>"
    "<emitter type='area'><rgb name='radiance' value='0.1,0.2,0.3'/></emitter></shape>"
    "<shape type='sphere'><point name='center' value='0,0,-1.5'/><float name='radius' value='0.3'/>"
    "<emitter type='area'><texture type='checkerboard' name='radiance'/></emitter></shape>"
    "<shape type='rectangle'><transform name='to_world'><translate value='0.2,1.5,-0.3'/></transform>"
    "<emitter type='area'><rgb name='radiance' value='3,2,1'/></emitter></shape>"
    "</scene>";

static bool same_direct(bool ok_a, const spc_emitter_direct *a, bool ok_b, const spc_emitter_direct *b)
{
    if (ok_a != ok_b)
        return false;
    if (!ok_a)
        return true;
    return memcmp(&a->p, &b->p, sizeof a->p) == 0 && memcmp(&a->n, &b->n, sizeof a->n) == 0 &&
           memcmp(&a->wi, &b->wi, sizeof a->wi) == 0 && memcmp(&a->dist, &b->dist, sizeof a->dist) == 0 &&
           memcmp(&a->L, &b->L, sizeof a->L) == 0 && memcmp(&a->pdf, &b->pdf, sizeof a->pdf) == 0 &&
           memcmp(&a->err, &b->err, sizeof a->err) == 0 && a->is_delta == b->is_delta &&
           a->is_infinite == b->is_infinite;
}

/* A reference point for sphere s: kind 0 random around it, 1 just outside its surface, 2 far, 3 inside. */
static spc_vec3 ref_for(const spc_shape *s, int kind, spc_rng *rng)
{
    spc_vec3 d = spc_warp_uniform_sphere(spc_v2(spc_rng_next(rng), spc_rng_next(rng)));
    double R = s->radius;
    switch (kind) {
    case 1:
        return spc_madd(s->center, d, R * (1.0 + 1e-7 * (1.0 + spc_rng_next(rng))));
    case 2:
        return spc_madd(s->center, d, R * 1e5 * (1.0 + spc_rng_next(rng)));
    case 3:
        return spc_madd(s->center, d, R * 0.9 * spc_rng_next(rng));
    default:
        return spc_madd(s->center, d, R * (1.0 + 10.0 * spc_rng_next(rng)));
    }
}

static double u_for(int i, spc_rng *rng)
{
    static const double special[] = {0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0 - DBL_EPSILON / 2};
    if (i % 5 == 3)
        return special[(int)(spc_rng_next(rng) * 9.0)];
    return spc_rng_next(rng);
}

/* 300 rounds of 37 lanes (two full batches and a partial one): every record equal to the one-lane
 * call's; vector counts the lanes that went through the vector loop, kinds[k] those of each kind. */
static void compare(const spc_scene *sc, int *vector, int *failed, int kinds[4])
{
    enum { N = 37 };
    spc_rng rng;
    spc_rng_seed(&rng, 17, 4);
    for (int round = 0; round < 300; ++round) {
        const spc_emitter *e[N];
        spc_vec3 ref[N];
        spc_vec2 u[N];
        spc_emitter_direct many[N], one;
        bool ok[N];
        int kind[N];
        for (int i = 0; i < N; ++i) {
            int k = (int)(spc_rng_next(&rng) * (sc->nemitters + 1));
            e[i] = k < sc->nemitters ? sc->emitters[k] : NULL;
            kind[i] = (int)(spc_rng_next(&rng) * 4.0);
            const spc_shape *s = e[i] ? e[i]->shape : NULL;
            if (s && s->type == SPC_SHAPE_SPHERE)
                ref[i] = ref_for(s, kind[i], &rng);
            else
                ref[i] = spc_v3(4.0 * spc_rng_next(&rng) - 2.0, 4.0 * spc_rng_next(&rng) - 2.0,
                                4.0 * spc_rng_next(&rng) - 2.0);
            u[i] = spc_v2(i % 7 == 2 ? (i % 2 ? 0.0 : 1.0 - DBL_EPSILON / 2) : spc_rng_next(&rng), u_for(i, &rng));
            ok[i] = !(i % 2); /* must be overwritten */
        }
        spc_emitter_sample_direct_many(N, e, ref, u, many, ok);
        for (int i = 0; i < N; ++i) {
            if (!e[i]) {
                *failed += ok[i];
                continue;
            }
            bool ok1 = spc_emitter_sample_direct(e[i], ref[i], u[i], &one);
            bool vec = spc_emitter_many_covers_sphere(e[i]) && spc_shape_has_solid_angle_sampling(e[i]->shape, ref[i]);
            if (vec) {
                ++*vector;
                kinds[kind[i]] += ok1;
            }
            if (!same_direct(ok[i], &many[i], ok1, &one)) {
                if (*failed < 3)
                    printf("  lane %d (emitter %d, kind %d): many %d, one %d\n", i, e[i]->index, kind[i], ok[i], ok1);
                ++*failed;
            }
        }
    }
}

TEST(sphere_samples_many_match_one_at_a_time)
{
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_mitsuba_load_string(spheres_xml, strlen(spheres_xml), "spheres.xml", NULL, NULL, 0, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    CHECK(sc->nemitters == 6);
    int ncover = 0;
    for (int k = 0; k < sc->nemitters; ++k)
        ncover += spc_emitter_many_covers_sphere(sc->emitters[k]);
    CHECK_MSG(ncover == 4, "%d lights covered by the sphere loops, expected the four constant spheres", ncover);
    for (int isa = 2; isa >= 0; --isa) {
        int used = spc_emitter_spheres_many_isa(isa);
        int vector = 0, failed = 0, kinds[4] = {0, 0, 0, 0};
        compare(sc, &vector, &failed, kinds);
        CHECK_MSG(failed == 0, "loop %d: %d light samples differ", used, failed);
        CHECK_MSG(vector > 3000, "loop %d: only %d samples through the sphere loops", used, vector);
        /* every kind of reference point outside gave real samples (inside ones go one lane at a time) */
        CHECK_MSG(kinds[0] > 300 && kinds[1] > 300 && kinds[2] > 300, "loop %d: samples by kind %d %d %d", used,
                  kinds[0], kinds[1], kinds[2]);
        printf("  loop %d: %d lanes through the sphere loops, %d differ\n", used, vector, failed);
    }
    spc_emitter_spheres_many_isa(-1);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(sphere_samples_many_match_one_at_a_time);
    return spc_test_finish();
}
