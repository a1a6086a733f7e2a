/*
 * bench/bench_denoise.c: how much Open Image Denoise lowers the error, and what it does to a
 * caustic (bench/RESULTS.md, "Denoising").
 *
 * usage: bench_denoise [RES [SEEDS [REF_SPP [PNG_DIR [ONLY]]]]]   (from the repository root; ONLY:
 * run only the scenes whose label contains it, e.g. "angular"; PNG_DIR "-" writes none)
 *
 * For the Cornell box (tests/data/cornell-box.xml, path) and the glass-ball caustic
 * (scenes/caustic_glass_sphere.xml, path with angular specular NEE, and plain path), RES x RES
 * (128), at 4, 16 and 64 spp over SEEDS seeds (8): the relMSE of the noisy and of the denoised
 * image against a REF_SPP (4096) render of another seed, its own noise subtracted
 * (tests/denoise_util.h). Printed per scene and spp: the means over seeds, the ratio of the means,
 * the smallest and largest per-seed ratio, the worst seed's denoised relMSE and the largest share
 * of one pixel in a seed's error; CPU seconds of rendering and of denoising (getrusage: the
 * denoiser's threads included).
 *
 * The caustic's sharpness (does the denoiser blur it?): at the reference's brightest pixel in the
 * image's lower half (the focus of the ball's caustic), the energy within a radius of res / 32
 * pixels, and the part of it in the central 3x3 pixels, of the noisy and denoised images against
 * the reference's, as means over the seeds ("energy" and "core" columns; core < 1 where the
 * denoiser spreads the focus out).
 *
 * Per-seed relMSE values go to stderr.
 *
 * With PNG_DIR: crops of the caustic (seed 0, path + angular) at 4, 16 and 64 spp, noisy |
 * denoised | reference side by side, magnified 3x, exposed at 1/4 so the focus is not clipped:
 * PNG_DIR/denoise_caustic_<spp>spp.png; and the whole Cornell box at 16 spp:
 * PNG_DIR/denoise_cornell_16spp.png.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "denoise_util.h"
#include "io/image_io.h"
#include "render/film.h"

#define BENCH_MAX_SEEDS 32
#define CROP_ZOOM 3
#define CROP_GAP 2 /* black pixels between the panels */

static double cpu_seconds(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec + (double)ru.ru_stime.tv_sec +
           1e-6 * (double)ru.ru_stime.tv_usec;
}

/* Panels (images res x res) cropped to [x0, x0 + cw) x [y0, y0 + ch), magnified, side by side. */
static void write_strip(const char *path, const float *const *panels, int npanels, int res, int x0, int y0, int cw,
                        int ch, float exposure)
{
    int pw = cw * CROP_ZOOM, W = npanels * pw + (npanels - 1) * CROP_GAP, H = ch * CROP_ZOOM;
    float *img = calloc(3 * (size_t)W * (size_t)H, sizeof(float));
    if (!img)
        return;
    for (int k = 0; k < npanels; ++k)
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < pw; ++x) {
                int sx = x0 + x / CROP_ZOOM, sy = y0 + y / CROP_ZOOM;
                for (int c = 0; c < 3; ++c)
                    img[3 * ((size_t)y * W + (size_t)(k * (pw + CROP_GAP) + x)) + (size_t)c] =
                        exposure * panels[k][3 * ((size_t)sy * res + (size_t)sx) + (size_t)c];
            }
    spc_error err;
    if (spc_png_write_srgb(path, W, H, img, &err) != SPC_OK)
        fprintf(stderr, "%s: %s\n", path, err.msg);
    else
        printf("wrote %s\n", path);
    free(img);
}

/* Sum of R + G + B over the pixels within `radius` (a square) of (cx, cy). */
static double window_sum(const float *rgb, int res, int cx, int cy, int radius)
{
    double s = 0.0;
    for (int y = cy - radius; y <= cy + radius; ++y)
        for (int x = cx - radius; x <= cx + radius; ++x)
            if (x >= 0 && y >= 0 && x < res && y < res)
                for (int c = 0; c < 3; ++c)
                    s += rgb[3 * ((size_t)y * res + (size_t)x) + (size_t)c];
    return s;
}

typedef struct bench_scene {
    const char *label, *path, *snee;
    bool crops; /* write the caustic crops */
} bench_scene;

int main(int argc, char **argv)
{
    int res = argc > 1 ? atoi(argv[1]) : 128;
    int seeds = argc > 2 ? atoi(argv[2]) : 8;
    int ref_spp = argc > 3 ? atoi(argv[3]) : 4096;
    const char *png_dir = argc > 4 && strcmp(argv[4], "-") != 0 ? argv[4] : NULL;
    const char *only = argc > 5 ? argv[5] : NULL;
    if (res < 16 || seeds < 1 || seeds > BENCH_MAX_SEEDS || ref_spp < 16) {
        fprintf(stderr, "usage: %s [RES [SEEDS [REF_SPP [PNG_DIR [ONLY]]]]]\n", argv[0]);
        return 2;
    }
    const bench_scene scenes[] = {
        {"cornell box, path", "tests/data/cornell-box.xml", NULL, false},
        {"caustic, path + angular", "scenes/caustic_glass_sphere.xml", "angular", true},
        {"caustic, path", "scenes/caustic_glass_sphere.xml", "", false},
    };
    const int spps[] = {4, 16, 64};
    size_t npix = (size_t)res * (size_t)res;
    printf("%dx%d, %d seeds, references %d spp of seed 1000 (the caustic's: path + angular)\n", res, res, seeds,
           ref_spp);
    printf("| scene | spp | relMSE noisy | relMSE denoised | ratio of means | per-seed ratio min..max | worst seed "
           "(denoised) | worst pixel share, noisy / denoised | CPU s render / denoise | caustic energy, noisy / "
           "denoised | caustic core, noisy / denoised |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
    spc_film *ref = NULL;
    const char *ref_path = NULL;
    for (size_t s = 0; s < sizeof scenes / sizeof scenes[0]; ++s) {
        const bench_scene *bs = &scenes[s];
        if (only && !strstr(bs->label, only))
            continue;
        if (!ref || strcmp(ref_path, bs->path) != 0) {
            spc_film_destroy(ref);
            ref = du_render(bs->path, res, ref_spp, 1000, bs->snee, false);
            ref_path = bs->path;
            if (!ref)
                return 1;
        }
        /* the caustic's focus: the reference's brightest pixel in the lower half */
        int fx = 0, fy = res / 2;
        double best = -1.0;
        for (int y = res / 2; y < res; ++y)
            for (int x = 0; x < res; ++x) {
                const float *p = ref->rgb + 3 * ((size_t)y * res + (size_t)x);
                if (p[0] + p[1] + p[2] > best) {
                    best = p[0] + p[1] + p[2];
                    fx = x;
                    fy = y;
                }
            }
        const int radius = res / 32;
        double ref_energy = window_sum(ref->rgb, res, fx, fy, radius), ref_core = window_sum(ref->rgb, res, fx, fy, 1);
        for (size_t k = 0; k < sizeof spps / sizeof spps[0]; ++k) {
            double noisy[BENCH_MAX_SEEDS], den[BENCH_MAX_SEEDS], share_n = 0.0, share_d = 0.0;
            double cpu_render = 0.0, cpu_denoise = 0.0, energy[2] = {0, 0}, core[2] = {0, 0};
            for (int seed = 0; seed < seeds; ++seed) {
                double t0 = cpu_seconds();
                spc_film *f = du_render(bs->path, res, spps[k], (uint64_t)seed, bs->snee, true);
                double t1 = cpu_seconds();
                if (!f)
                    return 1;
                double sh;
                noisy[seed] = du_relmse(f->rgb, ref->rgb, ref->var, npix, &sh);
                double e = window_sum(f->rgb, res, fx, fy, radius);
                energy[0] += e / ref_energy / seeds;
                core[0] += window_sum(f->rgb, res, fx, fy, 1) / e / (ref_core / ref_energy) / seeds;
                share_n = sh > share_n ? sh : share_n;
                spc_error err;
                if (spc_film_denoise(f, NULL, NULL, &err) != SPC_OK) {
                    fprintf(stderr, "denoise: %s\n", err.msg);
                    return 1;
                }
                double t2 = cpu_seconds();
                den[seed] = du_relmse(f->rgb, ref->rgb, ref->var, npix, &sh);
                e = window_sum(f->rgb, res, fx, fy, radius);
                energy[1] += e / ref_energy / seeds;
                core[1] += window_sum(f->rgb, res, fx, fy, 1) / e / (ref_core / ref_energy) / seeds;
                fprintf(stderr, "%s, %d spp, seed %d: relMSE noisy %.5f denoised %.5f ratio %.2f\n", bs->label, spps[k],
                        seed, noisy[seed], den[seed], noisy[seed] / den[seed]);
                share_d = sh > share_d ? sh : share_d;
                cpu_render += t1 - t0;
                cpu_denoise += t2 - t1;
                if (png_dir && seed == 0 && (bs->crops || (s == 0 && spps[k] == 16))) {
                    char path[1024];
                    const float *panels[3] = {f->noisy, f->rgb, ref->rgb};
                    if (bs->crops) {
                        /* the caustic below the ball and the ball itself (at 128: pixels 40..88, 52..100) */
                        snprintf(path, sizeof path, "%s/denoise_caustic_%dspp.png", png_dir, spps[k]);
                        write_strip(path, panels, 3, res, res * 5 / 16, res * 13 / 32, res * 3 / 8, res * 3 / 8, 0.25f);
                    } else {
                        snprintf(path, sizeof path, "%s/denoise_cornell_%dspp.png", png_dir, spps[k]);
                        write_strip(path, panels, 3, res, 0, 0, res, res, 1.0f);
                    }
                }
                spc_film_destroy(f);
            }
            double mn = 0.0, md = 0.0, rmin = 1e300, rmax = 0.0, worst = 0.0;
            int worst_seed = 0;
            for (int seed = 0; seed < seeds; ++seed) {
                mn += noisy[seed] / seeds;
                md += den[seed] / seeds;
                double r = noisy[seed] / den[seed];
                rmin = r < rmin ? r : rmin;
                rmax = r > rmax ? r : rmax;
                if (den[seed] > worst) {
                    worst = den[seed];
                    worst_seed = seed;
                }
            }
            printf("| %s | %d | %.5f | %.5f | %.1fx | %.1f..%.1f | %.5f (seed %d) | %.1f%% / %.1f%% | %.1f / %.1f | ",
                   bs->label, spps[k], mn, md, mn / md, rmin, rmax, worst, worst_seed, 100.0 * share_n, 100.0 * share_d,
                   cpu_render, cpu_denoise);
            if (strstr(bs->label, "caustic"))
                printf("%.3f / %.3f | %.3f / %.3f |\n", energy[0], energy[1], core[0], core[1]);
            else
                printf("- | - |\n");
            fflush(stdout);
        }
    }
    spc_film_destroy(ref);
    return 0;
}
