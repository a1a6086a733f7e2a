#!/usr/bin/env python3
"""bench/check/cmp_ref.py: per-pixel Welch tests of specula renders against a batch reference.

  python3 bench/check/cmp_ref.py REF.npy IMG.exr... [--floor AOV.exr[:nx,ny,nz]] [--spikes]
                                 [--blocks N]

REF.npy: batches x height x width x 3 (bench/check/mitsuba_ref.py); IMG.exr: specula render
--variance. Per pixel z = (img - ref) / sqrt(var_img + var_ref + (1e-4 ref)^2) on each channel (the
floor: Mitsuba's float sums differ by 1e-5 on constant pixels); a pixel passes if every channel's
|z| is under the two-sided threshold at alpha 0.01, Sidak-corrected for the pixels tested. Prints
the fraction passing, the mean z over pixels and channels, the worst |z| and the ratio of the
sums over the pixels tested.

--floor AOV.exr|NORMAL.npy: test only pixels whose every camera sample hit first a surface with this
  normal (default 0,1,0), e.g. against a ptracer reference, which renders nothing seen through glass.
  NORMAL.npy: mitsuba_ref.py --integrator normal (the first surface hit, mirrors and glass
  included). AOV.exr: specula's normal AOV (render --aovs), which looks through delta surfaces, so
  it also keeps pixels that see the floor through glass or in a mirror.
--spikes: the pixels tested grouped by the number of reference batches with a spike (a batch above
  the batches' median by 8 robust standard deviations): where a rare path (a small light's image in
  a glass ball) carries part of a pixel, a reference that rarely samples it is low on the pixels
  without a spike and high on the others, while a biased image is off in every group.
--blocks N: the same test on sums over N x N pixel blocks too (a bias stays, a rare path's
  misses average out).
"""
import argparse
from statistics import NormalDist

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")


def load_exr(path):
    ch = dict(mi.Bitmap(path).split())
    img = np.array(ch["<root>"], dtype=np.float64)[..., :3]
    if "variance" not in ch:
        raise SystemExit("%s: no variance channels (render with --variance)" % path)
    return img, np.array(ch["variance"], dtype=np.float64)[..., :3]


def welch(a, va, m, vm, mask):
    z = (a - m) / np.sqrt(va + vm + (1e-4 * m) ** 2 + 1e-30)
    zm = np.abs(z).max(-1)[mask]
    n = max(zm.size, 1)
    thr = NormalDist().inv_cdf(1 - (1 - (1 - 0.01) ** (1.0 / n)) / 2)
    return z, zm, thr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ref")
    ap.add_argument("images", nargs="+")
    ap.add_argument("--floor", default=None)
    ap.add_argument("--spikes", action="store_true")
    ap.add_argument("--blocks", type=int, default=0)
    a = ap.parse_args()
    ref = np.load(a.ref).astype(np.float64)
    nb = ref.shape[0]
    m = ref.mean(0)
    vm = ref.var(0, ddof=1) / nb
    mask = np.ones(m.shape[:2], bool)
    if a.floor:
        path, _, normal = a.floor.partition(":")
        want = np.array([float(v) for v in normal.split(",")]) if normal else np.array([0.0, 1.0, 0.0])
        if path.endswith(".npy"):
            nrm = np.load(path).astype(np.float64).mean(0)
        else:
            nrm = np.array(dict(mi.Bitmap(path).split())["normal"], dtype=np.float64)
        mask = np.all(np.abs(nrm - want) < 1e-6, axis=-1)
    for path in a.images:
        img, vi = load_exr(path)
        z, zm, thr = welch(img, vi, m, vm, mask)
        print("%s: %d pixels, pass %.4f (|z| < %.2f), mean z %+.3f, worst |z| %.1f, sum ratio %.5f" % (
            path, zm.size, (zm < thr).mean(), thr, z[mask].mean(), zm.max(), img[mask].sum() / m[mask].sum()))
        if a.spikes:
            lum = ref.mean(-1)
            med = np.median(lum, 0)
            mad = 1.4826 * np.median(np.abs(lum - med), 0)
            spikes = ((lum - med) > 8 * mad).sum(0)
            for lo, hi in ((0, 0), (1, 1), (2, 3), (4, nb)):
                sel = mask & (spikes >= lo) & (spikes <= hi)
                if sel.any():
                    zz = np.abs(z).max(-1)[sel]
                    print("  reference batches with a spike %d-%d: %4d pixels, pass %.4f, mean z %+.3f, "
                          "sum ratio %.5f" % (lo, hi, sel.sum(), (zz < thr).mean(), z[sel].mean(),
                                              img[sel].sum() / m[sel].sum()))
        if a.blocks > 1:
            n = a.blocks
            h, w = (m.shape[0] // n) * n, (m.shape[1] // n) * n

            def blk(x):
                x = x[..., :h, :w, :] * mask[:h, :w, None]
                return x.reshape(x.shape[:-3] + (h // n, n, w // n, n, 3)).sum((-2, -4))

            rb = blk(ref)
            bm, bv = rb.mean(0), rb.var(0, ddof=1) / nb
            bmask = blk(np.ones_like(m))[..., 0] > 0
            z, zm, thr = welch(blk(img), blk(vi), bm, bv, bmask)
            print("  %dx%d blocks: %d, pass %.4f (|z| < %.2f), mean z %+.3f, worst |z| %.1f" % (
                n, n, zm.size, (zm < thr).mean(), thr, z[bmask].mean(), zm.max()))


if __name__ == "__main__":
    main()
