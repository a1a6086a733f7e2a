#!/usr/bin/env python3
"""bench/check/region_sums.py: one region's sum (RGB, over pixels) in several images, each with its
standard error, to compare renderers and estimators on a part of the image.

  python3 bench/check/region_sums.py --mask NORMAL.npy --rows Y0,Y1 --cols X0,X1 IMAGE[:ROW0]...

IMAGE is a Mitsuba batch array (bench/check/mitsuba_ref.py: batches x height x width x 3; the
standard error from the batches' sums) or a specula render written with --variance (the standard
error from its variance channels; pixels are independent, but the R, G and B of a pixel come from
the same paths, so the bound for correlation 1, (sd_R + sd_G + sd_B)^2 per pixel, is used: the sum
of the three variances understates the sum's variance by up to a factor 3). ROW0: the image is a film crop whose
first row is ROW0 of the full 32x32 frame (both kinds). The region is rows Y0..Y1-1, columns
X0..X1-1 of the full frame; with --mask (Mitsuba's aov integrator, mitsuba_ref.py --integrator
normal) only the pixels whose first hit is the floor (shading normal (0, 1, 0)) count: the pixels
Mitsuba's and specula's light tracers (ptracer) render, so that a light tracer's sum is a
reference for a path tracer's there.
"""
import argparse

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("images", nargs="+")
    ap.add_argument("--mask", help="NORMAL.npy: count only the pixels that see the floor first")
    ap.add_argument("--rows", default="0,32")
    ap.add_argument("--cols", default="0,32")
    ap.add_argument("--size", type=int, default=32, help="the full frame's width and height")
    a = ap.parse_args()
    n = a.size
    y0, y1 = (int(v) for v in a.rows.split(","))
    x0, x1 = (int(v) for v in a.cols.split(","))
    sel = np.zeros((n, n), bool)
    sel[y0:y1, x0:x1] = True
    if a.mask:
        sel &= np.load(a.mask)[0][..., 1] > 0.999
    print("pixels: %d" % sel.sum())
    for spec in a.images:
        path, _, row0 = spec.partition(":")
        row0 = int(row0 or 0)
        if path.endswith(".npy"):
            ref = np.load(path).astype(np.float64)
            full = np.zeros((ref.shape[0], n, n, 3))
            full[:, row0:row0 + ref.shape[1], :ref.shape[2]] = ref
            sums = full[:, sel].reshape(ref.shape[0], -1).sum(1)
            print("%-60s %10.4f +- %.4f  (%d batches)" % (spec, sums.mean(), sums.std(ddof=1) / np.sqrt(len(sums)),
                                                         len(sums)))
        else:
            ch = dict(mi.Bitmap(path).split())
            img = np.array(ch["<root>"], dtype=np.float64)[..., :3]
            var = np.array(ch["variance"], dtype=np.float64)[..., :3]
            fi, fv = np.zeros((n, n, 3)), np.zeros((n, n, 3))
            fi[row0:row0 + img.shape[0], :img.shape[1]] = img
            fv[row0:row0 + img.shape[0], :img.shape[1]] = var
            print("%-60s %10.4f +- %.4f" % (spec, fi[sel].sum(), np.sqrt((np.sqrt(fv[sel]).sum(-1) ** 2).sum())))


if __name__ == "__main__":
    main()
