#!/usr/bin/env python3
"""bench/check/welch_best.py: per-pixel Welch test of specula renders of independent seeds against the
best reference each pixel has: a high-spp crop where one was rendered, a light tracer on the floor,
the path tracer elsewhere.

  python3 bench/check/welch_best.py IMG_GLOB --path PATH.npy [--floor-ref REF --normal NORMAL.npy]
                                    [--crop CROP.npy@X,Y]... [--window CROP.npy@X,Y]...
                                    [--rel EPS] [--top N] [--map]

IMG_GLOB: a quoted glob of specula EXRs at different --seed values (the default's seeds). PATH.npy:
Mitsuba's path tracer as batches (bench/check/mitsuba_ref.py). REF (with NORMAL.npy, Mitsuba's `normal`
render as the floor mask, as welch_seeds.py --floor): the reference for the pixels whose first hit is the
floor, a Mitsuba ptracer array or a quoted glob of specula EXRs (bdpt seeds). CROP.npy@X,Y: a Mitsuba
array of a window of the film (mitsuba_ref.py --crop X,Y,W,H, e.g. one pixel at millions of spp) whose
top left pixel is (X,Y); its pixels take that reference instead (where a path tracer misses a rare
path, its 8 x 8192 spp batches agree with each other and read low, so only many more samples settle the
pixel). Every mean and standard error comes from the spread over seeds or batches (ddof 1), never from
the images' variance channels.

Per pixel z = (a - b) / sqrt(se_a^2 + se_b^2 + (EPS b)^2) on the channel of largest |z|; a pixel passes if
|z| is under the two-sided Sidak bound at alpha 0.01 over all the pixels of the image. Printed: the pass
rate over the image and per reference, the failures with their reference, for every crop pixel its
z against the crop and against the path tracer's batches (which side the crop settles), and for a
window of more than one pixel the z of its mean (the window's pixels summed per seed and per batch: a
rare path's hits spread over the window's pixels, so its mean settles a small difference that each
pixel's few hits cannot).
"""
import os
import sys
from statistics import NormalDist

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from welch_seeds import load_set  # noqa: E402


def opt(name, default=None):
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default


def mean_se(stack):
    """Per-pixel mean and standard error of the mean over the first axis (ddof 1)."""
    return stack.mean(0), np.sqrt(stack.var(0, ddof=1) / stack.shape[0])


def main():
    rel = float(opt("--rel", 1e-4))
    img, _ = load_set(sys.argv[1])
    h, w = img.shape[1:3]
    a, sa = mean_se(img)
    path, _ = load_set(opt("--path"))
    b, sb = mean_se(path)
    src = np.full((h, w), "path", dtype=object)
    bp, sbp = b.copy(), sb.copy()
    if "--floor-ref" in sys.argv:
        fl, _ = load_set(opt("--floor-ref"))
        fm, fs = mean_se(fl)
        nrm = np.load(opt("--normal")).astype(np.float64).mean(0)
        floor = (np.abs(nrm[..., 1] - 1) < 1e-4) & (np.abs(nrm[..., 0]) < 1e-4) & (np.abs(nrm[..., 2]) < 1e-4)
        b[floor], sb[floor] = fm[floor], fs[floor]
        src[floor] = "floor"
    crops, windows = [], []
    for i, arg in enumerate(sys.argv):
        if arg == "--window":
            f, xy = sys.argv[i + 1].rsplit("@", 1)
            x0, y0 = (int(v) for v in xy.split(","))
            windows.append((x0, y0, np.load(f).astype(np.float64)))
        if arg == "--crop":
            f, xy = sys.argv[i + 1].rsplit("@", 1)
            x0, y0 = (int(v) for v in xy.split(","))
            c = np.load(f).astype(np.float64)
            cm, cs = mean_se(c)
            for dy in range(c.shape[1]):
                for dx in range(c.shape[2]):
                    y, x = y0 + dy, x0 + dx
                    b[y, x], sb[y, x] = cm[dy, dx], cs[dy, dx]
                    src[y, x] = "crop"
                    crops.append((x, y, c.shape[0], c[:, dy, dx].mean(-1)))
            if c.shape[1] * c.shape[2] > 1:
                windows.append((x0, y0, c))

    def worst(m, s):
        z = (a - m) / np.sqrt(sa ** 2 + s ** 2 + (rel * m) ** 2 + 1e-30)
        return np.take_along_axis(z, np.abs(z).argmax(-1)[..., None], -1)[..., 0]

    z = worst(b, sb)
    zpath = worst(bp, sbp)
    n = h * w
    thr = NormalDist().inv_cdf(1 - (1 - (1 - 0.01) ** (1.0 / n)) / 2)
    fail = np.abs(z) >= thr
    print("pixels %d: pass %.4f (%d fail: %d high, %d low); |z| bound %.2f, rel %g; seeds %d, path batches %d" % (
        n, 1 - fail.sum() / n, fail.sum(), (fail & (z > 0)).sum(), (fail & (z < 0)).sum(), thr, rel,
        img.shape[0], path.shape[0]))
    for s in ("floor", "path", "crop"):
        m = src == s
        if m.any():
            print("  against %s: %d pixels, pass %.4f (%d high, %d low)" % (
                s, m.sum(), 1 - (fail & m).sum() / m.sum(), (fail & m & (z > 0)).sum(), (fail & m & (z < 0)).sum()))
    lum_a = a.mean(-1)
    for x, y, nb, vals in crops:
        print("  crop (%d,%d): default %.5g +- %.2g; crop %.5g +- %.2g (%d batches %s); path %.5g +- %.2g; "
              "z vs crop %+.1f, vs path %+.1f" % (
                  x, y, lum_a[y, x], np.sqrt(img[:, y, x].mean(-1).var(ddof=1) / img.shape[0]), vals.mean(),
                  vals.std(ddof=1) / np.sqrt(nb), nb, " ".join("%.4g" % v for v in vals), bp[y, x].mean(),
                  np.sqrt(path[:, y, x].mean(-1).var(ddof=1) / path.shape[0]), z[y, x], zpath[y, x]))
    for x0, y0, c in windows:
        ys, xs = slice(y0, y0 + c.shape[1]), slice(x0, x0 + c.shape[2])
        ra, rp = (v[:, ys, xs].mean((1, 2, 3)) for v in (img, path))
        rc = c.mean((1, 2, 3))
        d, sd = ra.mean() - rc.mean(), np.sqrt(ra.var(ddof=1) / len(ra) + rc.var(ddof=1) / len(rc))
        dp, sdp = ra.mean() - rp.mean(), np.sqrt(ra.var(ddof=1) / len(ra) + rp.var(ddof=1) / len(rp))
        print("  window (%d,%d) %dx%d, its mean: default %.5g, crop %.5g (z %+.1f), path %.5g (z %+.1f)" % (
            x0, y0, c.shape[2], c.shape[1], ra.mean(), rc.mean(), d / sd, rp.mean(), dp / sdp))
    if "--map" in sys.argv:
        for y in range(h):
            print("  " + "".join(("+" if z[y, x] > 0 else "-") if fail[y, x] else
                                 {"floor": ".", "path": ":", "crop": "c"}[src[y, x]] for x in range(w)))
    order = np.argsort(-np.abs(z).ravel())
    for i in order[:int(opt("--top", 0))]:
        y, x = divmod(int(i), w)
        print("  (%d,%d) %s z %+.1f  default %.5g +- %.2g  ref %.5g +- %.2g  (path z %+.1f)" % (
            x, y, src[y, x], z[y, x], lum_a[y, x], sa[y, x].mean(), b[y, x].mean(), sb[y, x].mean(), zpath[y, x]))


if __name__ == "__main__":
    main()
