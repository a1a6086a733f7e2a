#!/usr/bin/env python3
"""bench/check/welch_seeds.py: per-pixel Welch test of specula renders of independent seeds against a
reference of independent batches or seeds, both variances from the spread over seeds.

  python3 bench/check/welch_seeds.py REF IMG_GLOB [--rel EPS] [--floor NORMAL.npy] [--map] [--top N]

REF: a Mitsuba batch array (bench/check/mitsuba_ref.py, batches x h x w x 3) or a quoted glob of
specula EXRs (independent seeds, e.g. bdpt). IMG_GLOB: a quoted glob of specula EXRs rendered with
--variance at different --seed values. Per pixel and channel z = (a - b) / sqrt(se_a^2 + se_b^2 +
(EPS b)^2), se from the seeds' (batches') spread (ddof 1) over their count; a pixel passes if every
channel's |z| is under the two-sided bound at alpha 0.01, Sidak-corrected over the pixels tested.
Printed beside it: the same test with the images' own variance channels for se_a, the 4x4 block sums'
test, the mean z, the image mean ratio a / b with its standard error from the seeds' and batches'
image means, and the quadrants' ratios (over the pixels tested).

--rel EPS (default 1e-4): a relative tolerance. With many seeds the per-pixel error of both images
  falls to 1e-4 of the value and below, where Mitsuba's own float32 arithmetic shows (its direct light
  from a small sphere light reads 0.1-0.2% over the exact value: bench/check/sphere_light_direct.py),
  so a test at that precision fails on every pixel the light reaches; --rel 0.002 asks for agreement
  to 0.2% on top of the noise.
--floor NORMAL.npy: test only the pixels whose first hit is the floor y = 0 at every sample
  (mitsuba_ref.py --integrator normal), e.g. against Mitsuba's ptracer, which renders nothing seen
  through glass or in a mirror.
--not-floor: with --floor, test the other pixels instead (those that see glass, a mirror, the light
  or the sky first): with the floor tested against Mitsuba's ptracer and the rest against its path
  tracer, every pixel is tested once against a reference that can render it.
--map: the pixels as a grid: '+' / '-' fail high / low, ''' / ',' |z| over 2.5, ' ' not tested.
--top N: the N pixels of largest |z| with both values, their standard errors, the seeds' values and
  the largest reference batch over the batches' median (a spike: the reference's rare path).
"""
import glob
import sys
from statistics import NormalDist

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")


def load_exr(path):
    ch = dict(mi.Bitmap(path).split())
    img = np.array(ch["<root>"], dtype=np.float64)[..., :3]
    var = np.array(ch["variance"], dtype=np.float64)[..., :3] if "variance" in ch else np.full_like(img, np.nan)
    return img, var


def load_set(spec):
    if spec.endswith(".npy"):
        return np.load(spec).astype(np.float64), None
    files = sorted(glob.glob(spec))
    if len(files) < 2:
        raise SystemExit("%s: fewer than 2 files" % spec)
    pairs = [load_exr(f) for f in files]
    return np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])


def arg(name, default):
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default


def ratio_se(xa, xb):
    """a / b of two sets of per-seed means, with its standard error."""
    r = xa.mean() / xb.mean()
    return r, r * np.sqrt(xa.var(ddof=1) / len(xa) / xa.mean() ** 2 + xb.var(ddof=1) / len(xb) / xb.mean() ** 2)


def main():
    rel = float(arg("--rel", 1e-4))
    ref, _ = load_set(sys.argv[1])
    img, imgv = load_set(sys.argv[2])
    nr, ni = ref.shape[0], img.shape[0]
    h, w = img.shape[1:3]
    mask = np.ones((h, w), bool)
    if "--floor" in sys.argv:
        nrm = np.load(arg("--floor", "")).astype(np.float64).mean(0)
        mask = (np.abs(nrm[..., 1] - 1) < 1e-4) & (np.abs(nrm[..., 0]) < 1e-4) & (np.abs(nrm[..., 2]) < 1e-4)
        if "--not-floor" in sys.argv:
            mask = ~mask
    n = int(mask.sum())
    a, b = img.mean(0), ref.mean(0)
    sb2 = ref.var(0, ddof=1) / nr
    thr = NormalDist().inv_cdf(1 - (1 - (1 - 0.01) ** (1.0 / n)) / 2)

    def worst_z(sa2):
        z = (a - b) / np.sqrt(sa2 + sb2 + (rel * b) ** 2 + 1e-30)
        return z, np.take_along_axis(z, np.abs(z).argmax(-1)[..., None], -1)[..., 0]

    z, zi = worst_z(img.var(0, ddof=1) / ni)
    _, ziv = worst_z(imgv.mean(0) / ni if imgv is not None else img.var(0, ddof=1) / ni)
    fail = (np.abs(zi) >= thr) & mask
    failv = (np.abs(ziv) >= thr) & mask
    r, se = ratio_se(img[:, mask].reshape(ni, -1).mean(1), ref[:, mask].reshape(nr, -1).mean(1))
    bs = 4
    A = img.reshape(ni, h // bs, bs, w // bs, bs, 3).sum((2, 4))
    B = ref.reshape(nr, h // bs, bs, w // bs, bs, 3).sum((2, 4))
    zb = np.abs((A.mean(0) - B.mean(0)) / np.sqrt(A.var(0, ddof=1) / ni + B.var(0, ddof=1) / nr +
                                                  (rel * B.mean(0)) ** 2 + 1e-30)).max(-1)
    thrb = NormalDist().inv_cdf(1 - (1 - (1 - 0.01) ** (1.0 / zb.size)) / 2)
    print("pixels %d: pass %.4f (%d fail: %d high, %d low); with the variance channels %.4f; 4x4 blocks %.4f; "
          "mean z %+.2f; image mean ratio %.5f +- %.5f (z %+.1f); |z| bound %.2f, rel %g" % (
              n, 1 - fail.sum() / n, fail.sum(), (fail & (zi > 0)).sum(), (fail & (zi < 0)).sum(),
              1 - failv.sum() / n, (zb < thrb).mean(), z[mask].mean(), r, se, (r - 1) / se, thr, rel))
    quads = (("top left", slice(0, h // 2), slice(0, w // 2)), ("top right", slice(0, h // 2), slice(w // 2, w)),
             ("bottom left", slice(h // 2, h), slice(0, w // 2)), ("bottom right", slice(h // 2, h), slice(w // 2, w)))
    print("  " + "; ".join("%s %.4f +- %.4f" % ((q,) + ratio_se(img[:, ys, xs][:, mask[ys, xs]].reshape(ni, -1).mean(1),
                                                                 ref[:, ys, xs][:, mask[ys, xs]].reshape(nr, -1).mean(1)))
                           for q, ys, xs in quads if mask[ys, xs].sum() > 0))
    if "--map" in sys.argv:
        for y in range(h):
            print("  " + "".join(" " if not mask[y, x] else ("+" if zi[y, x] > 0 else "-") if fail[y, x] else
                                 "'" if zi[y, x] > 2.5 else "," if zi[y, x] < -2.5 else "." for x in range(w)))
    if "--top" in sys.argv:
        lum_a, lum_b = a.mean(-1), b.mean(-1)
        zt = np.where(mask, np.abs(zi), -1)
        for i in np.argsort(-zt.ravel())[:int(arg("--top", 8))]:
            y, x = divmod(int(i), w)
            rb = ref[:, y, x].mean(-1)
            print("  (%d,%d) z %+.1f  img %.5g +- %.2g  ref %.5g +- %.2g  seeds [%s]  ref's largest batch / median %.1f" % (
                x, y, zi[y, x], lum_a[y, x], np.sqrt(img[:, y, x].mean(-1).var(ddof=1) / ni), lum_b[y, x],
                np.sqrt(rb.var(ddof=1) / nr), " ".join("%.3g" % v for v in img[:, y, x].mean(-1)),
                rb.max() / max(np.median(rb), 1e-12)))


if __name__ == "__main__":
    main()
