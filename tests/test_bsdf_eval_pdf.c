/*
 * tests/test_bsdf_eval_pdf.c: spc_bsdf_eval_pdf gives spc_bsdf_eval's value and spc_bsdf_pdf's
 * density bit for bit (memcmp), for the variants that share terms between the two (roughconductor
 * with Beckmann and GGX, visible-normal sampling on and off, anisotropic, with a textured alpha and a
 * perfect mirror's Fresnel; twosided around them, front and back, with one and two nested BSDFs) and
 * for others that take the two calls (diffuse, roughplastic, roughdielectric, plastic). Directions
 * are random on the whole sphere, including both hemispheres, the horizon and wi = wo.
 */
/* ctest-labels: unit */
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/rng.h"
#include "core/warp.h"
#include "harness.h"
#include "io/mitsuba_xml.h"
#include "lanes.h"
#include "scene/scene.h"
#include "scene/shape.h"

static const char *bsdfs_xml =
    "<scene version='3.0.0'>"
    "<shape type='rectangle'><bsdf type='roughconductor'><float name='alpha' value='0.05'/>"
    "<string name='distribution' value='beckmann'/></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='roughconductor'><float name='alpha' value='0.3'/>"
    "<string name='distribution' value='ggx'/><rgb name='eta' value='0.2,0.9,1.1'/>"
    "<rgb name='k' value='3.9,2.4,2.1'/><rgb name='specular_reflectance' value='0.3,0.5,0.7'/></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='roughconductor'><float name='alpha_u' value='0.05'/>"
    "<float name='alpha_v' value='0.4'/><boolean name='sample_visible' value='false'/></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='roughconductor'><string name='material' value='none'/>"
    "<texture type='checkerboard' name='alpha'><float name='color0' value='0.02'/>"
    "<float name='color1' value='0.5'/></texture></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='twosided'><bsdf type='roughconductor'><float name='alpha' value='0.1'/>"
    "</bsdf></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='twosided'><bsdf type='roughconductor'><float name='alpha' value='0.1'/>"
    "</bsdf><bsdf type='roughconductor'><float name='alpha' value='0.25'/><string name='distribution' value='ggx'/>"
    "</bsdf></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='twosided'><bsdf type='diffuse'/></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='roughplastic'><float name='alpha' value='0.2'/></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='roughdielectric'><float name='alpha' value='0.2'/></bsdf></shape>"
    "<shape type='rectangle'><bsdf type='plastic'/></shape>"
    "</scene>";

/* Nonzero values and densities compared, and rounds with wo on the back side. */
typedef struct eval_pdf_counts {
    int nonzero_f, nonzero_pdf, back;
} eval_pdf_counts;

/* One round: wi near the mirror direction (where a glossy lobe is large) or anywhere, sometimes wo
 * on the horizon or wi = wo; spc_bsdf_eval_pdf against the two calls. */
static bool eval_pdf_round(void *ctx, int round, const spc_bsdf *b, spc_hit *h, spc_vec3 wo, spc_rng *rng, bool loud)
{
    eval_pdf_counts *c = (eval_pdf_counts *)ctx;
    spc_vec3 wi;
    if (round % 3 == 0) {
        spc_vec3 r = spc_reflect(wo, h->ng);
        spc_vec3 j = spc_warp_uniform_sphere(spc_v2(spc_rng_next(rng), spc_rng_next(rng)));
        wi = spc_normalize(spc_madd(r, j, 0.1 * spc_rng_next(rng)));
    } else {
        wi = spc_warp_uniform_sphere(spc_v2(spc_rng_next(rng), spc_rng_next(rng)));
    }
    if (round % 97 == 5)
        wo = h->sh.s; /* on the horizon */
    if (round % 89 == 7)
        wi = wo;
    c->back += spc_dot(wo, h->ng) < 0.0;
    double pdf1 = -1.0;
    spc_rgb f1 = spc_bsdf_eval_pdf(b, h, SPC_MODE_RADIANCE, wo, wi, &pdf1);
    spc_rgb f0 = spc_bsdf_eval(b, h, SPC_MODE_RADIANCE, wo, wi);
    double pdf0 = spc_bsdf_pdf(b, h, SPC_MODE_RADIANCE, wo, wi);
    c->nonzero_f += !spc_rgb_is_black(f0);
    c->nonzero_pdf += pdf0 > 0.0;
    bool same = memcmp(&f0, &f1, sizeof f0) == 0 && memcmp(&pdf0, &pdf1, sizeof pdf0) == 0;
    if (!same && loud)
        printf("  round %d: f %.17g %.17g %.17g / %.17g %.17g %.17g, pdf %.17g / %.17g\n", round, f0.r, f0.g, f0.b,
               f1.r, f1.g, f1.b, pdf0, pdf1);
    return same;
}

TEST(eval_pdf_matches_eval_and_pdf)
{
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_mitsuba_load_string(bsdfs_xml, strlen(bsdfs_xml), "bsdfs.xml", NULL, NULL, 0, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    CHECK(sc->nshapes == 10);
    eval_pdf_counts c = {0, 0, 0};
    int failed = lanes_check_bsdfs(sc, 23, 2, 20000, eval_pdf_round, &c);
    CHECK_MSG(failed == 0, "%d evaluations differ", failed);
    /* the comparisons covered real lobe values and densities, on both sides */
    CHECK_MSG(c.nonzero_f > 5000 && c.nonzero_pdf > 5000 && c.back > 5000, "f %d, pdf %d nonzero, %d back sides",
              c.nonzero_f, c.nonzero_pdf, c.back);
    spc_scene_destroy(sc);
}

int main(void)
{
    RUN(eval_pdf_matches_eval_and_pdf);
    return spc_test_finish();
}
