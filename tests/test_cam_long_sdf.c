/*
 * tests/test_cam_long_sdf.c: specular NEE from the pinhole through a glass SDF's longer chains
 * (spc_snee_params.cam_long, the user's "camlong"), on scenes/caustic_sdf_torus.xml (a glass torus
 * as a signed distance field over a floor under a small sphere light).
 *
 * - The query from the camera finds chains of 3 and 4 vertices on the torus (in, reflected inside
 *   the tube, out) with camlong, and more solutions than without it.
 * - The camera rays through those chains' film positions, followed by BSDF sampling through the
 *   torus to the light, are the paths the query covers: with camlong the track from the camera
 *   follows them and their MIS weight (spc_snee_camera_bsdf_weight, sampled with the chain's real
 *   solve probability) lies in [0, 1] and is small on average (the query takes most of the class);
 *   without it every such path keeps weight 1 (no other strategy makes it).
 * - Renders with camlong agree with --specular-nee none (per-pixel z-test, image mean) under a
 *   larger light, and with the plan's setting without camlong (camlong on every query, and on a
 *   quarter of them).
 */
/* ctest-labels: stat */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bsdf/bsdf.h"
#include "core/rng.h"
#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "render_util.h"
#include "scene/camera.h"

#define TORUS "scenes/caustic_sdf_torus.xml"
/* the torus's plan (specula info) without its camlong */
#define TORUS_PLAN "angular:camera,first=0.1,later=0.1,ltguide,nolong,camsplit=4,camrecv,ltcaus"

/* Queries from the pinhole with the setting, the same random numbers for every setting: the
 * solutions found (spc_snee_stats.solved), and up to max_out splats with a value in out. */
static int camera_queries(const spc_scene *sc, const spc_camera_state *cam, const char *setting, int n,
                          spc_snee_splat *out, int max_out, int *nout, uint64_t *solved)
{
    spc_snee_params p;
    if (!spc_snee_parse(setting, 2, &p))
        return 0;
    p.mis = true; /* as the path tracer runs it */
    spc_snee_stats st;
    memset(&st, 0, sizeof st);
    spc_rng rng;
    spc_rng_seed(&rng, 0x63616d6c6f6e67ULL, 3);
    *nout = 0;
    for (int i = 0; i < n; ++i) {
        spc_snee_splat sp[SPC_SNEE_CAMERA_SPLATS];
        int m = spc_snee_camera(sc, &p, cam, 1.0, 2, SPC_CHAIN_MAX_VERTICES, &rng, &st, sp, SPC_SNEE_CAMERA_SPLATS);
        for (int j = 0; j < m && *nout < max_out; ++j)
            if (sp[j].value.r > 0.0)
                out[(*nout)++] = sp[j];
    }
    *solved = st.solved;
    return 1;
}

/* The path from the pinhole through film position (fx, fy) followed by BSDF sampling (lobe choices
 * from rng) through delta scatterings: true if it reaches the light after k of them (*k), with the
 * track from the camera as the path tracer keeps it (t), the camera ray's direction *d0 and the
 * light's hit *lh. */
static bool trace_to_light(const spc_scene *sc, const spc_camera_state *cam, const spc_snee_params *p, double fx,
                           double fy, spc_rng *rng, spc_snee_track *t, int *k, spc_vec3 *d0, spc_hit *lh)
{
    spc_ray ray = spc_camera_ray(cam, fx, fy);
    *d0 = ray.d;
    spc_snee_track_begin(t, p, 2, SPC_CHAIN_MAX_VERTICES);
    t->long_max = spc_snee_camera_long_max(p, SPC_CHAIN_MAX_VERTICES, t->long_max);
    *k = 0;
    for (int seg = 0; seg < 12; ++seg) {
        spc_hit h;
        if (!spc_scene_intersect(sc, &ray, &h))
            return false;
        if (h.emitter) {
            *lh = h;
            return true;
        }
        if (!h.bsdf || !spc_bsdf_is_delta_only(h.bsdf))
            return false;
        spc_vec3 wo = spc_neg(ray.d);
        spc_vec2 u;
        u.x = spc_rng_next(rng);
        u.y = spc_rng_next(rng);
        spc_bsdf_sample bs;
        if (!spc_bsdf_sample_dir(h.bsdf, &h, SPC_MODE_RADIANCE, wo, spc_rng_next(rng), u, &bs))
            return false;
        spc_snee_track_scatter(t, &h, bs.lobe, 2, p->any_surface, p->reflect);
        ++*k;
        ray = spc_hit_spawn(&h, bs.wi);
    }
    return false;
}

TEST(camera_query_weighs_tube_chains)
{
    spc_scene *sc = tu_load(TORUS, 32);
    CHECK(sc != NULL);
    if (!sc)
        return;
    spc_camera_state cam;
    CHECK(spc_camera_prepare(&cam, &sc->camera, sc->film.width, sc->film.height));
    int n = spc_test_quick() ? 3000 : 6000;
    enum { MAX_SPLATS = 4096 };
    static spc_snee_splat sp[MAX_SPLATS], sp0[MAX_SPLATS];
    int ns = 0, ns0 = 0;
    uint64_t solved = 0, solved0 = 0;
    CHECK(camera_queries(sc, &cam, TORUS_PLAN ",camlong", n, sp, MAX_SPLATS, &ns, &solved));
    CHECK(camera_queries(sc, &cam, TORUS_PLAN, n, sp0, MAX_SPLATS, &ns0, &solved0));
    printf("    %d queries: %d splats, %llu solutions with camlong; %d, %llu without\n", n, ns,
           (unsigned long long)solved, ns0, (unsigned long long)solved0);
    CHECK(solved > solved0 && ns > ns0);

    /* the camera rays through the splats' film positions, followed through the torus by BSDF
     * sampling (several lobe choices each) */
    spc_snee_params p, p0;
    CHECK(spc_snee_parse(TORUS_PLAN ",camlong", 2, &p) && spc_snee_parse(TORUS_PLAN, 2, &p0));
    p.camera_p = p0.camera_p = 1.0;
    p.mis = p0.mis = true;
    spc_rng rng;
    spc_rng_seed(&rng, 0x7475626550ULL, 5);
    int paths[SPC_CHAIN_MAX_VERTICES + 1] = {0}, covered0 = 0, outside = 0;
    double wsum = 0.0, wmax = 0.0;
    int nw = 0;
    for (int i = 0; i < ns; ++i) {
        for (int rep = 0; rep < 16; ++rep) {
            spc_snee_track t, t0;
            int k, k0;
            spc_vec3 d0, d00;
            spc_hit lh, lh0;
            spc_rng r0 = rng;
            bool hit = trace_to_light(sc, &cam, &p, sp[i].fx, sp[i].fy, &rng, &t, &k, &d0, &lh);
            bool hit0 = trace_to_light(sc, &cam, &p0, sp[i].fx, sp[i].fy, &r0, &t0, &k0, &d00, &lh0);
            if (!hit || k < 3 || k > 4)
                continue;
            ++paths[k];
            CHECK(hit0 && k0 == k);
            /* without camlong the track does not cover it: the camera ray's alone */
            if (spc_snee_track_covers(&t0, sc, lh0.emitter))
                ++covered0;
            if (!spc_snee_track_covers(&t, sc, lh.emitter))
                continue;
            double w = spc_snee_camera_bsdf_weight(sc, &p, &cam, 1.0, d0, t.max_chain, t.k, t.events, &lh);
            if (!(w >= 0.0 && w <= 1.0))
                ++outside;
            wsum += w;
            wmax = spc_max(wmax, w);
            ++nw;
        }
    }
    printf("    camera paths through the splats' film positions reaching the light: %d of 3 vertices, %d of 4; "
           "%d weighed, mean weight %.4f (largest %.4f), %d covered without camlong\n",
           paths[3], paths[4], nw, nw ? wsum / nw : 0.0, wmax, covered0);
    CHECK(paths[3] > 0);
    CHECK(nw == paths[3] + paths[4]);
    CHECK(outside == 0);
    CHECK(nw > 0 && wsum / nw < 0.5);
    CHECK(covered0 == 0);
    spc_scene_destroy(sc);
}

/* The torus under a sphere light of radius 0.3 (power kept), at res x res. */
static spc_scene *torus_large_light(int res)
{
    const char *d = getenv("SPC_SOURCE_DIR");
    char path[1024], r[16];
    snprintf(path, sizeof path, "%s/%s", d ? d : ".", TORUS);
    snprintf(r, sizeof r, "%d", res);
    spc_define defs[3] = {{"res", r}, {"light_radius", "0.3"}, {"light_radiance", "28.44, 27.02, 24.18"}};
    spc_scene *sc = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_scene_load(path, defs, 3, &sc, &err) != SPC_OK)
        return NULL;
    return sc;
}

static void agrees(const char *setting, const char *other, int spp, int spp_other, uint64_t seed, const char *label)
{
    int q = spc_test_quick() ? 2 : 1;
    spc_scene *sc = torus_large_light(16);
    CHECK(sc != NULL);
    if (!sc)
        return;
    CHECK(tu_settings_agree(sc, setting, spp / q, other, spp_other / q, seed, label));
    spc_scene_destroy(sc);
}

TEST(render_agrees_with_none)
{
    agrees(TORUS_PLAN ",camlong", "none", 256, 4096, 91, "torus, large light, camlong against none");
}

TEST(render_agrees_without_camlong)
{
    agrees(TORUS_PLAN ",camlong", TORUS_PLAN, 256, 512, 93, "torus, large light, camlong against the plan");
    /* on a share of the queries: the pass's density carries the share on both sides */
    agrees(TORUS_PLAN ",camlong=0.25", TORUS_PLAN, 256, 512, 95, "torus, large light, camlong=0.25 against the plan");
}

int main(void)
{
    RUN(camera_query_weighs_tube_chains);
    RUN(render_agrees_with_none);
    RUN(render_agrees_without_camlong);
    return spc_test_finish();
}
