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
#include "lanes.h"
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

/* What the comparisons covered: lanes through the vector loop, and those of each kind of
 * reference point that gave a sample. */
typedef struct sphere_counts {
    int vector, kinds[4];
} sphere_counts;

/* A lane's kind of reference point (drawn for every lane), its point (around the sphere by its
 * kind, anywhere for other lights) and random numbers (the special ones on some lanes). */
static int sphere_setup(void *ctx, int i, const spc_emitter *e, spc_rng *rng, spc_vec3 *ref, spc_vec2 *u)
{
    (void)ctx;
    int kind = (int)(spc_rng_next(rng) * 4.0);
    const spc_shape *s = e ? e->shape : NULL;
    if (s && s->type == SPC_SHAPE_SPHERE)
        *ref = ref_for(s, kind, rng);
    else
        *ref = spc_v3(4.0 * spc_rng_next(rng) - 2.0, 4.0 * spc_rng_next(rng) - 2.0, 4.0 * spc_rng_next(rng) - 2.0);
    *u = spc_v2(i % 7 == 2 ? (i % 2 ? 0.0 : 1.0 - DBL_EPSILON / 2) : spc_rng_next(rng), u_for(i, rng));
    return kind;
}

static void sphere_tally(void *ctx, const spc_emitter *e, spc_vec3 ref, int kind, bool ok_many, bool ok_one)
{
    (void)ok_many;
    sphere_counts *c = (sphere_counts *)ctx;
    if (spc_emitter_many_covers_sphere(e) && spc_shape_has_solid_angle_sampling(e->shape, ref)) {
        ++c->vector;
        c->kinds[kind] += ok_one;
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
        sphere_counts c = {0, {0, 0, 0, 0}};
        lanes_direct_hooks hk = {sphere_setup, sphere_tally, &c};
        /* 300 rounds: every record equal to the one-lane call's */
        int failed = lanes_check_direct(sc, 17, 4, 300, &hk);
        CHECK_MSG(failed == 0, "loop %d: %d light samples differ", used, failed);
        CHECK_MSG(c.vector > 3000, "loop %d: only %d samples through the sphere loops", used, c.vector);
        /* every kind of reference point outside gave real samples (inside ones go one lane at a time) */
        CHECK_MSG(c.kinds[0] > 300 && c.kinds[1] > 300 && c.kinds[2] > 300, "loop %d: samples by kind %d %d %d", used,
                  c.kinds[0], c.kinds[1], c.kinds[2]);
        printf("  loop %d: %d lanes through the sphere loops, %d differ\n", used, c.vector, failed);
    }
    spc_emitter_spheres_many_isa(-1);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(sphere_samples_many_match_one_at_a_time);
    return spc_test_finish();
}
