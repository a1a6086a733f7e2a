#!/usr/bin/env python3
"""bench/check/cmp_mix.py: per-pixel Welch tests between any two estimates of one image, each made
of several independent parts, with a reference mixed by pixel class.

  python3 bench/check/cmp_mix.py --mask NORMAL.npy --src NAME=FILE[,FILE...] ... \
      [--mix NAME=FLOORSRC/RESTSRC] [--floor-only NAME...] [--blocks N] --cmp A:B ...

--src NAME=FILES: one estimate. FILE.npy: batches x height x width x 3 (bench/check/mitsuba_ref.py),
  several files concatenated along the batches; the mean's variance is the batches' variance / their
  count. FILE.exr: a specula render with --variance; several files (the same spp, different seeds)
  are averaged, their variances summed / count^2.
--mask NORMAL.npy: Mitsuba's first-hit shading normal (mitsuba_ref.py --integrator normal, delta
  surfaces included); the floor class is the pixels whose every sample hit the normal (0, 1, 0) first.
--mix NAME=F/R: a new estimate taking source F on the floor pixels and R on the others. The class is
  fixed by the geometry before any comparison: light tracing (ptracer) samples the paths that end on
  the floor by way of the light's image in the glass, which path tracing finds about once in 1e5
  samples, and renders nothing seen through glass; path tracing covers the rest.
--floor-only NAME: a source valid only on the floor pixels (ptracer): its comparisons skip the rest.
--cmp A:B: for the pixels of each class (all, floor, rest), the fraction passing the per-pixel Welch
  test on every channel at alpha 0.01 Sidak-corrected over that class's pixels, the mean z (A - B),
  the worst |z|, the ratio of A's sum to B's with its z; with --blocks N the same on N x N block sums.
"""
import argparse
from statistics import NormalDist

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")


def load(files):
    files = files.split(",")
    if files[0].endswith(".npy"):
        ref = np.concatenate([np.load(f).astype(np.float64) for f in files])
        return ref.mean(0), ref.var(0, ddof=1) / ref.shape[0], "%d batches" % ref.shape[0]
    imgs, vars_ = [], []
    for f in files:
        ch = dict(mi.Bitmap(f).split())
        imgs.append(np.array(ch["<root>"], dtype=np.float64)[..., :3])
        vars_.append(np.array(ch["variance"], dtype=np.float64)[..., :3])
    k = len(files)
    return sum(imgs) / k, sum(vars_) / k ** 2, "%d renders" % k


def welch(a, va, b, vb, sel):
    z = (a - b) / np.sqrt(va + vb + (1e-4 * b) ** 2 + 1e-30)
    zm = np.abs(z).max(-1)[sel]
    n = max(zm.size, 1)
    thr = NormalDist().inv_cdf(1 - (1 - (1 - 0.01) ** (1.0 / n)) / 2)
    sa, sb = a[sel].sum(), b[sel].sum()
    zs = (sa - sb) / np.sqrt(va[sel].sum() + vb[sel].sum() + 1e-30)
    return zm.size, (zm < thr).mean(), thr, z[sel].mean(), zm.max(), sa / max(sb, 1e-30), zs


def blocks(x, n):
    h, w = (x.shape[0] // n) * n, (x.shape[1] // n) * n
    return x[:h, :w].reshape(h // n, n, w // n, n, 3).sum((1, 3))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mask", required=True)
    ap.add_argument("--src", action="append", default=[])
    ap.add_argument("--mix", action="append", default=[])
    ap.add_argument("--floor-only", nargs="*", default=[])
    ap.add_argument("--blocks", type=int, default=0)
    ap.add_argument("--cmp", action="append", default=[])
    a = ap.parse_args()
    nrm = np.load(a.mask).astype(np.float64).mean(0)
    floor = np.all(np.abs(nrm - np.array([0.0, 1.0, 0.0])) < 1e-6, axis=-1)
    src = {}
    for s in a.src:
        name, files = s.split("=", 1)
        src[name] = load(files)
        print("%s: %s" % (name, src[name][2]))
    for s in a.mix:
        name, fr = s.split("=", 1)
        f, r = (src[x] for x in fr.split("/"))
        fl = floor[..., None]
        src[name] = (np.where(fl, f[0], r[0]), np.where(fl, f[1], r[1]), fr)
    print("floor pixels %d, rest %d" % (floor.sum(), (~floor).sum()))
    print("| A vs B | pixels | n | pass | mean z | worst abs z | sum ratio A/B (z) |")
    print("|---|---|---|---|---|---|---|")
    for c in a.cmp:
        na, nb = c.split(":")
        (ma, va, _), (mb, vb, _) = src[na], src[nb]
        only_floor = na in a.floor_only or nb in a.floor_only
        classes = [("floor", floor)] if only_floor else [("all", np.ones_like(floor)), ("floor", floor),
                                                         ("rest", ~floor)]
        for cname, sel in classes:
            n, p, thr, mz, wz, ratio, zs = welch(ma, va, mb, vb, sel)
            print("| %s vs %s | %s | %d | %.4f | %+.3f | %.1f | %.5f (%+.1f) |" % (
                na, nb, cname, n, p, mz, wz, ratio, zs))
            if a.blocks > 1:
                k = a.blocks
                selb = blocks(np.broadcast_to(sel[..., None], ma.shape).astype(np.float64), k)[..., 0] > 0
                m3 = sel[..., None]
                n, p, thr, mz, wz, ratio, zs = welch(blocks(ma * m3, k), blocks(va * m3, k), blocks(mb * m3, k),
                                                     blocks(vb * m3, k), selb)
                print("| %s vs %s | %s, %dx%d blocks | %d | %.4f | %+.3f | %.1f | |" % (
                    na, nb, cname, k, k, n, p, mz, wz))


if __name__ == "__main__":
    main()
