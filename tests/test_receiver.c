/*
 * tests/test_receiver.c: the receivers a specular chain starts at (manifold/receiver.h).
 *
 * For each kind, the scattering factor and the density spc_receiver_eval / spc_receiver_pdf give
 * against the direct computation: a diffuse surface's albedo / pi and cos / pi in closed form and a
 * rough conductor's spc_bsdf_eval / spc_bsdf_pdf; the isotropic phase function's 1 / (4 pi) and a
 * Henyey-Greenstein lobe's closed form; the pinhole's importance and direction density
 * 1 / (A cos^3) (A the image plane's area at unit distance) times the samples-per-pass scale, zero
 * behind the camera and off the chain's first direction. The transmittance of a chain from a medium
 * point through a medium boundary against exp(-sigma_t d) per segment, and 1 for a surface
 * receiver.
 */
/* ctest-labels: unit */
#include <string.h>

#include "core/rng.h"
#include "harness.h"
#include "manifold/receiver.h"
#include "render_util.h"

static spc_rng rng;
static double rnd(void) { return spc_rng_next(&rng); }

static spc_vec3 random_dir(void)
{
    double z = 1.0 - 2.0 * rnd(), r = sqrt(fmax(0.0, 1.0 - z * z)), phi = 2.0 * SPC_PI * rnd();
    return spc_v3(r * cos(phi), r * sin(phi), z);
}

/* A floor hit at the origin, normal +z, of BSDF b. */
static spc_hit floor_hit(const spc_bsdf *b)
{
    spc_hit h;
    memset(&h, 0, sizeof h);
    h.p = spc_v3(0, 0, 0);
    h.ng = spc_v3(0, 0, 1);
    h.sh = spc_frame_from_n(h.ng);
    h.bsdf = b;
    h.shape_index = -1;
    return h;
}

TEST(surface_matches_bsdf)
{
    spc_scene *sc = spc_scene_create();
    const double albedo = 0.7;
    spc_bsdf *diff = tu_diffuse(sc, albedo);
    spc_bsdf *rough = spc_scene_new_bsdf(sc);
    rough->type = SPC_BSDF_ROUGHCONDUCTOR;
    rough->distribution = SPC_MICROFACET_GGX;
    rough->alpha_u = rough->alpha_v = spc_scene_constant(sc, spc_rgb1(0.3));
    rough->sample_visible = true;
    rough->specular_reflectance = spc_scene_constant(sc, spc_rgb1(1.0));
    rough->cond_eta = spc_rgb3(0.143, 0.374, 1.442);
    rough->cond_k = spc_rgb3(3.983, 2.385, 1.603);
    spc_hit hd = floor_hit(diff), hr = floor_hit(rough);
    int checked = 0;
    for (int i = 0; i < 200; ++i) {
        spc_vec3 wo = random_dir(), d0 = random_dir();
        if (wo.z < 0.05)
            wo.z = -wo.z + 0.1, wo = spc_normalize(wo);
        spc_receiver r;
        spc_rgb f;
        double cosf;
        /* diffuse: albedo / pi and |cos|, density cos / pi on the side of wo, zero on the other */
        spc_receiver_surface(&r, &hd, wo);
        CHECK(r.kind == SPC_RECEIVER_SURFACE && spc_receiver_origin(&r) == &hd);
        bool ok = spc_receiver_eval(&r, d0, spc_add(hd.p, d0), &f, &cosf);
        double pdf = spc_receiver_pdf(&r, d0);
        if (d0.z > 1e-6) {
            CHECK(ok);
            CHECK_REL(f.r, albedo / SPC_PI, 1e-12, 0.0);
            CHECK_REL(cosf, d0.z, 1e-12, 0.0);
            CHECK_REL(pdf, d0.z / SPC_PI, 1e-9, 0.0);
            ++checked;
        } else if (d0.z < -1e-6) {
            CHECK(!ok);
            CHECK(pdf == 0.0);
        }
        /* a rough conductor: the BSDF's own eval and pdf */
        spc_receiver_surface(&r, &hr, wo);
        ok = spc_receiver_eval(&r, d0, spc_add(hr.p, d0), &f, &cosf);
        spc_rgb fb = spc_bsdf_eval(rough, &hr, SPC_MODE_RADIANCE, wo, d0);
        CHECK(ok == !spc_rgb_is_black(fb));
        if (ok) {
            CHECK(f.r == fb.r && f.g == fb.g && f.b == fb.b);
            CHECK(cosf == fabs(d0.z));
        }
        CHECK(spc_receiver_pdf(&r, d0) == spc_bsdf_pdf(rough, &hr, SPC_MODE_RADIANCE, wo, d0));
    }
    CHECK(checked > 50);
    spc_scene_destroy(sc);
}

TEST(medium_matches_phase)
{
    spc_phase iso = {SPC_PHASE_ISOTROPIC, 0.0}, hg = {SPC_PHASE_HG, 0.6};
    spc_vec3 p = spc_v3(0.5, -1.0, 2.0);
    for (int i = 0; i < 200; ++i) {
        spc_vec3 wo = random_dir(), d0 = random_dir();
        spc_receiver r;
        spc_rgb f;
        double cosf;
        spc_receiver_medium(&r, p, wo, &iso, 3);
        const spc_hit *o = spc_receiver_origin(&r);
        CHECK(r.kind == SPC_RECEIVER_MEDIUM && r.medium == 3);
        CHECK(o->p.x == p.x && o->p.y == p.y && o->p.z == p.z && o->err == 0.0 && !o->bsdf && !o->shape);
        CHECK(spc_receiver_eval(&r, d0, spc_add(p, d0), &f, &cosf));
        CHECK_REL(f.r, 1.0 / (4.0 * SPC_PI), 1e-12, 0.0);
        CHECK(f.g == f.r && f.b == f.r && cosf == 1.0);
        CHECK_REL(spc_receiver_pdf(&r, d0), 1.0 / (4.0 * SPC_PI), 1e-12, 0.0);
        /* Henyey-Greenstein: wo points back along the incoming ray, so the scattering angle's cosine
         * is -wo . d0, and g > 0 scatters forward */
        spc_receiver_medium(&r, p, wo, &hg, 0);
        CHECK(spc_receiver_eval(&r, d0, spc_add(p, d0), &f, &cosf));
        double g = hg.g, c = -spc_dot(wo, d0);
        double want = (1.0 - g * g) / (4.0 * SPC_PI * pow(1.0 + g * g - 2.0 * g * c, 1.5));
        CHECK_REL(f.r, want, 1e-9, 0.0);
        CHECK(cosf == 1.0);
        CHECK_REL(spc_receiver_pdf(&r, d0), want, 1e-9, 0.0);
    }
}

TEST(camera_matches_importance)
{
    spc_scene *sc = spc_scene_create();
    const int W = 32, H = 24;
    tu_camera(sc, spc_v3(0, 0, 5), spc_v3(0, 0, 0), spc_v3(0, 1, 0), 45.0, W, H);
    spc_camera_state cs;
    CHECK(spc_camera_prepare(&cs, &sc->camera, W, H));
    /* image plane at unit distance: fov 45 along x, aspect H / W */
    double tx = tan(0.5 * 45.0 * SPC_PI / 180.0), A = (2.0 * tx) * (2.0 * tx * H / W);
    const double cam_scale = 4.0;
    spc_receiver r;
    spc_receiver_camera(&r, &cs, cam_scale);
    const spc_hit *o = spc_receiver_origin(&r);
    CHECK(r.kind == SPC_RECEIVER_CAMERA && o->p.z == 5.0 && !o->bsdf);
    int on_film = 0;
    for (int i = 0; i < 400; ++i) {
        /* a point in front of the camera, inside the field of view or not */
        spc_vec3 p1 = spc_v3(6.0 * rnd() - 3.0, 6.0 * rnd() - 3.0, 2.0 * rnd() - 1.0);
        spc_vec3 d0 = spc_normalize(spc_sub(p1, cs.origin));
        double cos_t = -d0.z; /* the camera looks down -z */
        bool inside = fabs(d0.x / cos_t) < tx * 0.999 && fabs(d0.y / cos_t) < tx * H / W * 0.999;
        bool outside = fabs(d0.x / cos_t) > tx * 1.001 || fabs(d0.y / cos_t) > tx * H / W * 1.001;
        spc_rgb f;
        double cosf;
        bool ok = spc_receiver_eval(&r, d0, p1, &f, &cosf);
        double want = cam_scale / (A * cos_t * cos_t * cos_t);
        CHECK_REL(spc_receiver_pdf(&r, d0), want, 1e-9, 0.0);
        if (inside) {
            CHECK(ok);
            /* We cam_scale / (W H) = pdf_dir cam_scale */
            CHECK_REL(f.r, want, 1e-9, 0.0);
            CHECK(cosf == 1.0);
            ++on_film;
            /* the factor is zero where d0 does not lead to p1 */
            spc_vec3 off = spc_normalize(spc_add(d0, spc_v3(0.05, 0.0, 0.0)));
            CHECK(!spc_receiver_eval(&r, off, p1, &f, &cosf));
        } else if (outside) {
            CHECK(!ok);
        }
    }
    CHECK(on_film > 50);
    /* behind the camera: nothing */
    spc_rgb f;
    double cosf;
    CHECK(!spc_receiver_eval(&r, spc_v3(0, 0, 1), spc_v3(0, 0, 7), &f, &cosf));
    CHECK(spc_receiver_pdf(&r, spc_v3(0, 0, 1)) == 0.0);
    spc_scene_destroy(sc);
}

TEST(medium_chain_transmittance)
{
    spc_scene *sc = spc_scene_create();
    spc_medium *inside = spc_scene_new_medium(sc), *outside = spc_scene_new_medium(sc);
    CHECK(spc_medium_init_homogeneous(inside, spc_rgb1(0.3), spc_rgb1(0.2)));  /* sigma_t 0.5 */
    CHECK(spc_medium_init_homogeneous(outside, spc_rgb1(0.1), spc_rgb1(0.1))); /* sigma_t 0.2 */
    spc_shape *s = tu_sphere(sc, spc_v3(0, 0, 0), 1.0, tu_glass(sc, 1.5));
    s->interior_medium = inside->index;
    s->exterior_medium = outside->index;
    /* a chain of one vertex: from (0, 0, -0.5) inside up to the sphere's top, out to y = (0, 0, 3) */
    spc_chain c;
    memset(&c, 0, sizeof c);
    c.n = 1;
    c.v[0].h.p = spc_v3(0, 0, 1);
    c.v[0].h.ng = spc_v3(0, 0, 1);
    c.v[0].h.shape = s;
    c.v[0].wi = c.v[0].d = spc_v3(0, 0, 1);
    spc_vec3 y = spc_v3(0, 0, 3);
    spc_phase iso = {SPC_PHASE_ISOTROPIC, 0.0};
    spc_receiver r;
    spc_receiver_medium(&r, spc_v3(0, 0, -0.5), spc_v3(0, 0, -1), &iso, inside->index);
    spc_rgb T = spc_receiver_transmittance(sc, &r, &c, y);
    CHECK_REL(T.r, exp(-0.5 * 1.5 - 0.2 * 2.0), 1e-12, 0.0);
    CHECK(T.g == T.r && T.b == T.r);
    /* the same chain reflected back inside: no medium change, the inside's sigma_t on both */
    c.v[0].d = spc_v3(0, 0, -1);
    T = spc_receiver_transmittance(sc, &r, &c, spc_v3(0, 0, -0.2));
    CHECK_REL(T.r, exp(-0.5 * (1.5 + 1.2)), 1e-12, 0.0);
    /* a surface receiver ignores media */
    spc_hit h = floor_hit(tu_diffuse(sc, 0.5));
    spc_receiver_surface(&r, &h, spc_v3(0, 0, 1));
    T = spc_receiver_transmittance(sc, &r, &c, y);
    CHECK(T.r == 1.0 && T.g == 1.0 && T.b == 1.0);
    spc_scene_destroy(sc);
}

int main(void)
{
    spc_rng_seed(&rng, 19, 0);
    RUN(surface_matches_bsdf);
    RUN(medium_matches_phase);
    RUN(camera_matches_importance);
    RUN(medium_chain_transmittance);
    return spc_test_finish();
}
