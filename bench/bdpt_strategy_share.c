/*
 * bench/bdpt_strategy_share.c: how much of an image each bdpt strategy carries in a window, from
 * the films of `specula render --strategy-images DIR` ("which strategies carry the
 * caustic").
 *
 * usage: bdpt_strategy_share IMAGE.exr DIR [X Y [RADIUS]]
 *
 * The window is (2 RADIUS + 1)^2 pixels (RADIUS 3) centred on pixel (X, Y), by default on the
 * brightest pixel of IMAGE (sum of R, G, B). For every strategy of lengths 1..8 whose weighted film
 * DIR/sS_tT_weighted.exr exists it prints the window's sum of R + G + B and its share of IMAGE's;
 * the last line is the sum over strategies, which equals IMAGE's up to float rounding.
 */
#include <stdio.h>
#include <stdlib.h>

#include "specula/specula.h"

#define SHARE_MAX_LENGTH 8 /* SPC_STRATEGY_IMAGES_MAX_DEPTH */

static double window_sum(const spc_image_rgb *im, int cx, int cy, int r)
{
    double sum = 0.0;
    for (int y = cy - r; y <= cy + r; ++y)
        for (int x = cx - r; x <= cx + r; ++x)
            if (x >= 0 && y >= 0 && x < im->width && y < im->height)
                for (int c = 0; c < 3; ++c)
                    sum += im->rgb[3 * ((size_t)y * im->width + x) + c];
    return sum;
}

int main(int argc, char **argv)
{
    if (argc != 3 && argc != 5 && argc != 6) {
        fprintf(stderr, "usage: %s IMAGE.exr DIR [X Y [RADIUS]]\n", argv[0]);
        return 2;
    }
    spc_image_rgb full;
    spc_error err;
    if (spc_image_rgb_read(argv[1], &full, &err) != SPC_OK) {
        fprintf(stderr, "%s: %s\n", argv[1], err.msg);
        return 3;
    }
    int cx = 0, cy = 0, r = argc == 6 ? atoi(argv[5]) : 3;
    if (argc >= 5) {
        cx = atoi(argv[3]);
        cy = atoi(argv[4]);
    } else {
        double best = -1.0;
        for (int y = 0; y < full.height; ++y)
            for (int x = 0; x < full.width; ++x) {
                const float *p = full.rgb + 3 * ((size_t)y * full.width + x);
                if (p[0] + p[1] + p[2] > best) {
                    best = p[0] + p[1] + p[2];
                    cx = x;
                    cy = y;
                }
            }
    }
    double total = window_sum(&full, cx, cy, r), sum = 0.0;
    printf("window: %dx%d pixels centred on (%d, %d); image: %.6g (sum of R + G + B)\n", 2 * r + 1, 2 * r + 1, cx,
           cy, total);
    printf("| strategy (s, t) | length | window sum | share of the image |\n|---|---|---|---|\n");
    for (int k = 1; k <= SHARE_MAX_LENGTH; ++k)
        for (int s = 0; s <= k; ++s) {
            char path[4096];
            snprintf(path, sizeof path, "%s/s%d_t%d_weighted.exr", argv[2], s, k + 1 - s);
            spc_image_rgb im;
            if (spc_image_rgb_read(path, &im, &err) != SPC_OK)
                continue;
            if (im.width == full.width && im.height == full.height) {
                double v = window_sum(&im, cx, cy, r);
                sum += v;
                double share = total > 0.0 ? 100.0 * v / total : 0.0;
                printf("| (%d, %d) | %d | %.6g | %.4f%% |\n", s, k + 1 - s, k, v, share);
            }
            spc_image_rgb_release(&im);
        }
    printf("| all | | %.6g | %.4f%% |\n", sum, total > 0.0 ? 100.0 * sum / total : 0.0);
    spc_image_rgb_release(&full);
    return 0;
}
