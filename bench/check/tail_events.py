#!/usr/bin/env python3
"""bench/check/tail_events.py: how often each renderer draws a rare bright sample in a crop, and
whether the two crops agree, from batches of renders at the same spp.

  python3 bench/check/tail_events.py MITSUBA.npy 'SPECULA_DIR/b*.exr' --spp 4096 [--min 300]

MITSUBA.npy: batches x height x width x 3 (bench/check/mitsuba_ref.py on a crop_scene.py scene);
the specula batches: one EXR per seed of the same crop (`specula render CROP.xml --spp N --seed S`).
An event is a batch pixel whose R exceeds the pixel's median over the batches by more than
--min / spp (one sample worth --min or more) and whose G excess is below 0.8 of its R excess (a
sample tinted by the scene's metal; set --tint 0 for any colour). Prints, per renderer, the crop
mean with its standard error over batches, the events per million samples and their size (one
sample's value: the excess times spp), then the two crops' mean ratio and per-pixel Welch z-tests
(significance 0.01 corrected for the pixel count).
"""
import argparse
import glob
from statistics import NormalDist

import numpy as np


def load_exrs(pattern):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    fs = sorted(glob.glob(pattern))
    return np.stack([np.array(mi.Bitmap(f))[..., :3].astype(np.float64) for f in fs])


def events(B, thr, tint):
    ex = B - np.median(B, axis=0)
    m = ex[..., 0] > thr
    if tint > 0:
        m &= ex[..., 1] < tint * ex[..., 0]
    return m, ex


def summary(name, B, spp, vmin, tint):
    n, h, w, _ = B.shape
    cm = B.mean(axis=(1, 2, 3))
    m, ex = events(B, vmin / spp, tint)
    e = ex[m] * spp
    print("%s: %d batches x %d spp; crop mean %.6f +- %.6f; events %d = %.2f per 1e6 samples; size mean %.1f, "
          "median %.1f; G/R %.3f B/R %.3f" % (
              name, n, spp, cm.mean(), cm.std(ddof=1) / np.sqrt(n), len(e), len(e) / (n * spp * h * w) * 1e6,
              e[:, 0].mean() if len(e) else 0, np.median(e[:, 0]) if len(e) else 0,
              (e[:, 1] / e[:, 0]).mean() if len(e) else 0, (e[:, 2] / e[:, 0]).mean() if len(e) else 0))


def compare(A, B, names):
    a, b = A.mean(0).mean(-1), B.mean(0).mean(-1)
    va = A.mean(-1).var(0, ddof=1) / A.shape[0]
    vb = B.mean(-1).var(0, ddof=1) / B.shape[0]
    z = (a - b) / np.sqrt(va + vb + 1e-30)
    zc = NormalDist().inv_cdf(1 - (1 - 0.99 ** (1.0 / z.size)) / 2)
    ca, cb = A.mean(axis=(1, 2, 3)), B.mean(axis=(1, 2, 3))
    se = np.sqrt(ca.var(ddof=1) / len(ca) + cb.var(ddof=1) / len(cb))
    print("%s / %s: crop mean ratio %.5f (difference %+.6f +- %.6f, z %.2f); per-pixel |z| >= %.2f: %d of %d; "
          "max |z| %.2f" % (names[0], names[1], ca.mean() / cb.mean(), ca.mean() - cb.mean(), se,
                            (ca.mean() - cb.mean()) / se, zc, (abs(z) >= zc).sum(), z.size, abs(z).max()))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mitsuba")
    ap.add_argument("specula", help="a glob of the specula batches' EXRs (quoted)")
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("--min", type=float, default=300.0, help="an event's least value of one sample")
    ap.add_argument("--tint", type=float, default=0.8, help="an event's G excess below this share of its R excess")
    a = ap.parse_args()
    M = np.load(a.mitsuba).astype(np.float64)
    S = load_exrs(a.specula)
    summary("Mitsuba", M, a.spp, a.min, a.tint)
    summary("specula", S, a.spp, a.min, a.tint)
    compare(S, M, ("specula", "Mitsuba"))


if __name__ == "__main__":
    main()
