#!/usr/bin/env python3
"""Per-pixel and per-block Welch tests of specula EXRs (with variance channels) against a reference
of independent batches (a .npy of shape batches x H x W x 3, e.g. Mitsuba 3 renders of seeds 0..B-1),
or against another specula EXR with variance: cmp_blocks.py REF.npy|REF.exr IMG.exr [IMG.exr ...]

For blocks of 1x1, 4x4, 8x8 pixels and the whole image: the fraction of blocks passing (alpha 0.01,
Sidak-corrected for the block count), the mean z and the largest |z| (luminance). Why blocks: where
an estimator finds a small light's image rarely (a path tracer, and bdpt's light paths, finding a
light's reflection in a glass ball), its per-pixel variance does not show the mass it missed, so
the per-pixel test fails a right image wherever the reference's pixels got no such path; summed over
blocks the reference's rare paths average out, and a bias, which is smooth, remains.
"""
import sys
from statistics import NormalDist

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")


def load_exr(path):
    ch = dict(mi.Bitmap(path).split())
    img = np.array(ch["<root>"]).astype(np.float64)[..., :3].mean(-1)
    return img, np.array(ch["variance"]).astype(np.float64)[..., :3].mean(-1)


def main():
    if sys.argv[1].endswith(".npy"):
        ref = np.load(sys.argv[1]).astype(np.float64).mean(-1)
        m, vm = ref.mean(0), ref.var(0, ddof=1) / ref.shape[0]
    else:
        m, vm = load_exr(sys.argv[1])
    for path in sys.argv[2:]:
        a, va = load_exr(path)
        h, w = a.shape
        out = []
        for bs in (1, 4, 8, 0):
            by, bx = (h, w) if bs == 0 else (bs, bs)
            f = lambda x: x[: h // by * by, : w // bx * bx].reshape(h // by, by, w // bx, bx).sum((1, 3))
            z = (f(a) - f(m)) / np.sqrt(f(va) + f(vm) + 1e-30)
            thr = NormalDist().inv_cdf(1 - (1 - (1 - 0.01) ** (1.0 / z.size)) / 2)
            out.append("%s: pass %.3f, mean z %+.2f, max |z| %.1f" % (
                "image" if bs == 0 else "%dx%d" % (bs, bs), (np.abs(z) < thr).mean(), z.mean(), np.abs(z).max()))
        print("%s (mean / reference's %.5f): %s" % (path, a.mean() / m.mean(), "; ".join(out)))


if __name__ == "__main__":
    main()
