/*
 * bench/newton_scenes.c: the caustic scenes rendered by path tracing with specular
 * NEE (newton, unbiased unless the setting says otherwise) against the implicit path tracer `ipt`,
 * at sizes larger than CI's (tests/test_newton.c renders small scenes built in code).
 *
 *   build/newton_scenes REF_SPP SNEE_SPP RES [SETTING [SCENE.xml ...]]
 *
 * SETTING is a specular_nee value (default "newton"; e.g. "newton:biased=8"); the scenes default to
 * the six caustic scenes (scenes/caustic_{glass_sphere,mirror_ring,sdf_torus,pool}.xml,
 * scenes/newton_{pool,slabs}.xml: run from the source tree's root). For each scene: the fraction of
 * pixels that pass the per-pixel z-test (alpha 0.01, Sidak-corrected for the pixel count, with the
 * variance of both means: spc_image_diff), the image means' ratio, and the CPU seconds of each
 * render (process CPU time: the machine is shared). For a scene with a dielectric sphere lit by a
 * sphere light (caustic_glass_sphere.xml), also the caustic region's energy ratio newton / ipt with
 * its standard error: the floor points within 0.8 sphere radii of where the line from the light
 * through the sphere's centre meets the floor, seen directly or through delta refractions (Cycles'
 * MNEE loses about half of that energy against its own path tracer; specula must not).
 * SPC_NEWTON_SCENES_OUT=dir writes dir/<scene>_{ipt,snee}.exr. Results go to bench/RESULTS.md by hand.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "bsdf/bsdf.h"
#include "core/error.h"
#include "scene/camera.h"
#include "scene/scene.h"
#include "specula/specula.h"

static spc_film *render(const spc_scene *sc, const char *integrator, const char *snee, int spp, uint64_t seed,
                        double *cpu)
{
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = spp;
    /* 2 by default (the machine's cores); SPC_NEWTON_SCENES_THREADS=1 leaves one core to others */
    o.threads = getenv("SPC_NEWTON_SCENES_THREADS") ? atoi(getenv("SPC_NEWTON_SCENES_THREADS")) : 2;
    o.seed = seed;
    o.integrator = integrator;
    o.specular_nee = snee;
    spc_film *f = NULL;
    spc_error err;
    spc_render_stats st;
    double t0 = bench_process_seconds();
    if (spc_render(sc, &o, &f, &st, &err) != SPC_OK) {
        fprintf(stderr, "render failed: %s\n", err.msg);
        spc_film_destroy(f);
        return NULL;
    }
    *cpu = bench_process_seconds() - t0;
    return f;
}

/* The caustic centre of a dielectric sphere under a sphere light: the first non-delta surface the
 * line from the light's centre through the sphere's centre reaches. False without such a pair. */
static bool caustic_centre(const spc_scene *sc, spc_vec3 *c, double *r)
{
    const spc_shape *ball = NULL, *light = NULL;
    for (int i = 0; i < sc->nshapes; ++i) {
        const spc_shape *s = sc->shapes[i];
        double eta;
        if (s->type != SPC_SHAPE_SPHERE)
            continue;
        if (s->emitter)
            light = s;
        else if (s->bsdf && spc_bsdf_is_specular_interface(s->bsdf, &eta) && eta > 0.0)
            ball = s;
    }
    if (!ball || !light)
        return false;
    spc_ray ray = {ball->center, spc_normalize(spc_sub(ball->center, light->center)), 0.0, SPC_INF};
    spc_hit h;
    for (int b = 0; b < 8 && spc_scene_intersect(sc, &ray, &h); ++b) {
        if (h.shape != ball) {
            *c = h.p;
            *r = 0.8 * ball->radius;
            return true;
        }
        ray = spc_hit_spawn(&h, ray.d);
    }
    return false;
}

/* Pixels whose camera ray through the pixel centre reaches a non-delta surface within r of c,
 * directly or through delta refractions. */
static int region_mask(const spc_scene *sc, int w, int hgt, spc_vec3 c, double r, unsigned char *mask)
{
    spc_camera_state cam;
    int n = 0;
    if (!spc_camera_prepare(&cam, &sc->camera, w, hgt))
        return 0;
    for (int j = 0; j < hgt; ++j)
        for (int i = 0; i < w; ++i) {
            spc_hit hit;
            mask[j * w + i] = 0;
            spc_ray ray = spc_camera_ray(&cam, i + 0.5, j + 0.5);
            for (int b = 0; b < 8 && spc_scene_intersect(sc, &ray, &hit); ++b) {
                double eta;
                if (!hit.bsdf || !spc_bsdf_is_specular_interface(hit.bsdf, &eta) || !(eta > 0.0)) {
                    if (spc_distance(hit.p, c) < r) {
                        mask[j * w + i] = 1;
                        ++n;
                    }
                    break;
                }
                double cos_t, eta_ti, ci = spc_dot(spc_neg(ray.d), hit.sh.n);
                spc_fresnel_dielectric(ci, eta, &cos_t, &eta_ti);
                if (cos_t == 0.0)
                    break;
                ray = spc_hit_spawn(&hit, spc_refract(spc_neg(ray.d), hit.sh.n, cos_t, eta_ti));
            }
        }
    return n;
}

static void write_exr(const spc_film *f, const char *scene, const char *what)
{
    const char *dir = getenv("SPC_NEWTON_SCENES_OUT");
    if (!dir || !f)
        return;
    char base[256], path[1024];
    const char *slash = strrchr(scene, '/');
    snprintf(base, sizeof base, "%s", slash ? slash + 1 : scene);
    char *dot = strrchr(base, '.');
    if (dot)
        *dot = '\0';
    snprintf(path, sizeof path, "%s/%s_%s.exr", dir, base, what);
    spc_error err;
    if (spc_film_write_exr(f, path, true, &err) != SPC_OK)
        fprintf(stderr, "%s: %s\n", path, err.msg);
}

int main(int argc, char **argv)
{
    if (argc < 4) {
        fprintf(stderr, "usage: %s REF_SPP SNEE_SPP RES [SETTING [SCENE.xml ...]]\n", argv[0]);
        return 2;
    }
    int ref_spp = atoi(argv[1]), snee_spp = atoi(argv[2]), res = atoi(argv[3]);
    const char *setting = argc > 4 ? argv[4] : "newton";
    static const char *defaults[] = {"caustic_glass_sphere", "caustic_mirror_ring", "caustic_sdf_torus",
                                     "caustic_pool",         "newton_pool",         "newton_slabs"};
    int nscenes = argc > 5 ? argc - 5 : (int)(sizeof defaults / sizeof defaults[0]);
    spc_warn_set_quiet(1);
    printf("| scene | res | ipt spp | %s spp | z-test pass | image mean ratio | caustic region ratio (se) | "
           "CPU s ipt | CPU s snee |\n|---|---|---|---|---|---|---|---|---|\n",
           setting);
    for (int si = 0; si < nscenes; ++si) {
        char path[1024];
        if (argc > 5)
            snprintf(path, sizeof path, "%s", argv[5 + si]);
        else
            snprintf(path, sizeof path, "scenes/%s.xml", defaults[si]);
        char rs[32];
        snprintf(rs, sizeof rs, "%d", res);
        spc_define defs[1] = {{"res", rs}};
        spc_scene *sc = NULL;
        spc_error err;
        if (spc_scene_load(path, defs, 1, &sc, &err) != SPC_OK) {
            fprintf(stderr, "%s: %s\n", path, err.msg);
            continue;
        }
        double cpu_ref = 0, cpu_snee = 0;
        spc_film *ref = render(sc, "ipt", "", ref_spp, 101, &cpu_ref);
        spc_film *img = render(sc, "path", setting, snee_spp, 202, &cpu_snee);
        if (!ref || !img) {
            spc_film_destroy(ref);
            spc_film_destroy(img);
            spc_scene_destroy(sc);
            continue;
        }
        write_exr(ref, path, "ipt");
        write_exr(img, path, "snee");
        int w = spc_film_width(img), h = spc_film_height(img);
        spc_image_rgb a = {w, h, (float *)spc_film_rgb(img), (float *)spc_film_variance(img)};
        spc_image_rgb b = {w, h, (float *)spc_film_rgb(ref), (float *)spc_film_variance(ref)};
        spc_diff_result d;
        if (spc_image_diff(&a, &b, &d, &err) != SPC_OK) {
            fprintf(stderr, "diff: %s\n", err.msg);
            d.has_ztest = false;
        }
        double ma = (d.mean_a[0] + d.mean_a[1] + d.mean_a[2]) / 3, mb = (d.mean_b[0] + d.mean_b[1] + d.mean_b[2]) / 3;
        char region[96] = "-";
        spc_vec3 c;
        double r;
        if (caustic_centre(sc, &c, &r)) {
            unsigned char *mask = malloc((size_t)w * (size_t)h);
            int n = region_mask(sc, w, h, c, r, mask);
            double sa = 0, va = 0, sb = 0, vb = 0;
            for (int k = 0; k < w * h; ++k)
                if (mask[k])
                    for (int ch = 0; ch < 3; ++ch) {
                        sa += a.rgb[3 * k + ch];
                        va += a.variance[3 * k + ch];
                        sb += b.rgb[3 * k + ch];
                        vb += b.variance[3 * k + ch];
                    }
            /* ratio of sums; its standard error by the delta method (independent renders) */
            if (n > 0 && sb > 0.0) {
                double q = sa / sb, se = q * sqrt(va / (sa * sa) + vb / (sb * sb));
                snprintf(region, sizeof region, "%.4f (%.4f), %d px", q, se, n);
            }
            free(mask);
        }
        const char *slash = strrchr(path, '/');
        printf("| %s | %d | %d | %d | %.4f of %d | %.4f | %s | %.1f | %.1f |\n", slash ? slash + 1 : path, res, ref_spp,
               snee_spp, d.has_ztest ? d.ztest_pass_fraction : -1.0, d.ztest_pixels, mb > 0 ? ma / mb : 0.0, region,
               cpu_ref, cpu_snee);
        fflush(stdout);
        spc_film_destroy(ref);
        spc_film_destroy(img);
        spc_scene_destroy(sc);
    }
    return 0;
}
