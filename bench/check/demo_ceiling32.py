#!/usr/bin/env python3
"""32x32: none (65536 spp) against the default (8192 spp) and Mitsuba's ptracer (8 x 8192 light
paths per pixel) on the demo: per-pixel Welch, the ceiling's sum, and the pixel (14, 5).
  python3 bench/check/demo_ceiling32.py [DIR]
DIR (default /tmp/welch15/) holds q_none_1.exr, q_default_1.exr (render --variance),
p32_*.npy (mitsuba_ref.py --integrator ptracer batches) and n32.npy (--integrator normal), 32x32.
"""
import glob
from statistics import NormalDist
import numpy as np
import mitsuba as mi
mi.set_variant("scalar_rgb")
import sys
D = (sys.argv[1].rstrip("/") + "/") if len(sys.argv) > 1 and not sys.argv[1].startswith("--") else "/tmp/welch15/"
def load_exr(p):
    ch = dict(mi.Bitmap(p).split())
    return (np.array(ch["<root>"], dtype=np.float64)[..., :3].mean(-1),
            np.array(ch["variance"], dtype=np.float64)[..., :3].mean(-1))
E = {}
for n in ["none", "default"]:
    f = D + "q_%s_1.exr" % n
    if glob.glob(f):
        m, v = load_exr(f); E[n] = (m, v)
fs = sorted(glob.glob(D + "p32_*.npy"))
if fs:
    b = np.concatenate([np.load(f) for f in fs]).astype(np.float64).mean(-1)
    E["mts_ptracer"] = (b.mean(0), b.var(0, ddof=1) / b.shape[0]); print("mts batches", b.shape[0])
nrm = np.load(D + "n32.npy")[0]
ceil = (nrm[..., 1] < -0.999) & (E["none"][0] < 3)
diff = (np.abs(nrm).max(-1) > 0.999) & (E["none"][0] < 3)
print("ceiling px", ceil.sum(), "diffuse px", diff.sum())
names = list(E)
for i in range(len(names)):
    for j in range(i + 1, len(names)):
        (a, va), (b_, vb) = E[names[i]], E[names[j]]
        msk = diff if "mts" in names[i] + names[j] else np.ones(a.shape, bool)
        z = (a - b_) / np.sqrt(va + vb + (1e-4 * 0.5 * (abs(a) + abs(b_))) ** 2 + 1e-30)
        zz = z[msk]; thr = NormalDist().inv_cdf(1 - (1 - 0.99 ** (1.0 / zz.size)) / 2)
        s = "%s vs %s, %d px: pass %.4f (|z|<%.2f), |z|>3.5 %.3f, mean z %+.2f" % (names[i], names[j], zz.size, (abs(zz) < thr).mean(), thr, (abs(zz) > 3.5).mean(), zz.mean())
        zc = z[ceil]
        d = a[ceil].sum() - b_[ceil].sum(); se = np.sqrt(va[ceil].sum() + vb[ceil].sum())
        s += "; ceiling: pass %.3f, mean z %+.2f, sum %+.2f%% (z %+.1f)" % ((abs(zc) < thr).mean(), zc.mean(), 100 * (a[ceil].sum() / b_[ceil].sum() - 1), d / se)
        print(s)
for n, (m, v) in E.items():
    print("%-12s ceiling mean %.5f +- %.5f;  (14,5) %.5f +- %.5f; (17,5) %.5f +- %.5f" % (n, m[ceil].mean(), np.sqrt(v[ceil].sum()) / ceil.sum(), m[5, 14], v[5, 14] ** .5, m[5, 17], v[5, 17] ** .5))
print("ceiling rows 2-6, cols 10-21, each estimator:")
for n, (m, v) in E.items():
    print(n); [print("  ", " ".join("%.3f" % m[y, x] for x in range(10, 22))) for y in range(2, 7)]
