#!/usr/bin/env python3
"""bench/check/welch_detail.py: what lies behind a per-pixel Welch rate (bench/check/cmp_ref.py).

  python3 bench/check/welch_detail.py REF.npy IMG.exr [--list N]

REF.npy: batches x height x width x 3 (bench/check/mitsuba_ref.py); IMG.exr: specula render
--variance. Prints the image-sum ratio IMG / REF with its standard error (pixels of IMG independent;
the R, G and B of one pixel come from the same paths and are correlated, which the variance
channels do not record, so IMG's part is the bound for correlation 1, (sd_R + sd_G + sd_B)^2 per
pixel: summing the three variances instead understates it by up to sqrt(3); REF's from its batches'
sums) and its z, the sums of the four quadrants the same way, and the N
failing pixels of largest |z| (every channel, alpha 0.01 Sidak, as in cmp_ref.py)
with both values, their standard errors and the number of reference batches with a spike (a batch
above the batches' median by 8 robust standard deviations): failures only where no batch has a
spike and reading high is what a reference that misses a rare path gives; a bias fails anywhere.
"""
import argparse
from statistics import NormalDist

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ref")
    ap.add_argument("img")
    ap.add_argument("--list", type=int, default=12)
    a = ap.parse_args()
    ref = np.load(a.ref).astype(np.float64)
    nb = ref.shape[0]
    m, vm = ref.mean(0), ref.var(0, ddof=1) / nb
    ch = dict(mi.Bitmap(a.img).split())
    img = np.array(ch["<root>"], dtype=np.float64)[..., :3]
    vi = np.array(ch["variance"], dtype=np.float64)[..., :3]
    h, w = m.shape[:2]

    def ratio(sel):
        si, sr = img[sel].sum(), m[sel].sum()
        vsi = (np.sqrt(vi[sel]).sum(-1) ** 2).sum()  # channels correlated: the bound (see above)
        bs = ref[:, sel].reshape(nb, -1).sum(1)
        vsr = bs.var(ddof=1) / nb
        r = si / sr
        return r, r * np.sqrt(vsi / si ** 2 + vsr / sr ** 2), (si - sr) / np.sqrt(vsi + vsr)

    full = np.ones((h, w), bool)
    print("image sum ratio %.5f +- %.5f (z %+.2f)" % ratio(full))
    for name, ys, xs in (("top-left", slice(0, h // 2), slice(0, w // 2)),
                         ("top-right", slice(0, h // 2), slice(w // 2, w)),
                         ("bottom-left", slice(h // 2, h), slice(0, w // 2)),
                         ("bottom-right", slice(h // 2, h), slice(w // 2, w))):
        sel = np.zeros((h, w), bool)
        sel[ys, xs] = True
        print("  %-12s %.5f +- %.5f (z %+.2f)" % ((name,) + ratio(sel)))
    z = (img - m) / np.sqrt(vi + vm + (1e-4 * m) ** 2 + 1e-30)
    zm = np.abs(z).max(-1)
    thr = NormalDist().inv_cdf(1 - (1 - (1 - 0.01) ** (1.0 / zm.size)) / 2)
    lum = ref.mean(-1)
    med = np.median(lum, 0)
    mad = 1.4826 * np.median(np.abs(lum - med), 0)
    spikes = ((lum - med) > 8 * mad).sum(0)
    fail = np.argwhere(zm >= thr)
    hi = sum(1 for y, x in fail if img[y, x].mean() > m[y, x].mean())
    print("failing pixels %d (%d read high), %d of them with no spiked reference batch" % (
        len(fail), hi, sum(1 for y, x in fail if spikes[y, x] == 0)))
    order = sorted(fail.tolist(), key=lambda p: -zm[p[0], p[1]])[:a.list]
    for y, x in order:
        print("  (x %2d, y %2d) specula %.5g +- %.2g  Mitsuba %.5g +- %.2g  z %+.1f  spiked batches %d" % (
            x, y, img[y, x].mean(), np.sqrt(vi[y, x].mean()), m[y, x].mean(), np.sqrt(vm[y, x].mean()),
            z[y, x][np.argmax(np.abs(z[y, x]))], spikes[y, x]))


if __name__ == "__main__":
    main()
