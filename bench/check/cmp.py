#!/usr/bin/env python3
"""Per-pixel Welch comparison of two EXRs with variance channels: cmp.py A.exr B.exr [--map].

The variances get a floor of (1e-4 x the pixel's mean)^2: pixels that both renderers see as a
constant (the sky, a light seen directly) have zero variance in each but differ in the last float
digits of their sums, which would otherwise fail with an infinite z."""
import sys
import numpy as np
import mitsuba as mi
mi.set_variant('scalar_rgb')

def load(p):
    b = mi.Bitmap(p)
    a = np.array(b, copy=False).astype(np.float64)
    return a[..., 0:3].mean(-1), a[..., 3:6].mean(-1)

a, va = load(sys.argv[1])
b, vb = load(sys.argv[2])
z = (a - b) / np.sqrt(va + vb + (1e-4 * 0.5 * (abs(a) + abs(b))) ** 2 + 1e-30)
n = a.size
from math import erf, sqrt
alpha = 1 - (1 - 0.01) ** (1.0 / n)
from statistics import NormalDist
zc = NormalDist().inv_cdf(1 - alpha / 2)
print("means %.5f %.5f (%+.2f%%); pass %.4f (|z|<%.2f); frac|z|>3.5 %.4f; mean z %.3f" % (
    a.mean(), b.mean(), 100 * (a.mean() / b.mean() - 1), (abs(z) < zc).mean(), zc, (abs(z) > 3.5).mean(), z.mean()))
if '--map' in sys.argv:
    h, w = z.shape
    for y in range(h):
        print(''.join('+' if v > 3.5 else '-' if v < -3.5 else '.' for v in z[y]))
if '--top' in sys.argv:
    d = a - b
    idx = np.argsort(-abs(d).ravel())[:8]
    for i in idx:
        y, x = divmod(i, a.shape[1])
        print("  (%d,%d) a %.4f +- %.4f  b %.4f +- %.4f  z %.1f" % (x, y, a[y, x], va[y, x] ** .5, b[y, x], vb[y, x] ** .5, z[y, x]))
if '--topz' in sys.argv:
    idx = np.argsort(-abs(z).ravel())[:12]
    for i in idx:
        y, x = divmod(i, a.shape[1])
        print("  (%d,%d) a %.4f +- %.4f  b %.4f +- %.4f  z %.1f" % (x, y, a[y, x], va[y, x] ** .5, b[y, x], vb[y, x] ** .5, z[y, x]))
