#!/usr/bin/env python3
"""relMSE of saved bench_default.py images against another reference: relmse_vs_ref.py REF.exr GLOB...

REF.exr has a variance channel (specula render --variance), e.g. a bdpt render. For each GLOB (one
column of a bench_default.py --out folder, e.g. "DIR/scene_none_*.exr"): the mean over seeds of
bench_default's per-seed relMSE (((img - ref)^2 - ref_var) / (ref^2 + 0.01), averaged over pixels
and channels), without its CPU-time factor (each column's spp is the budget over its calibrated cost
per sample, so a seed's CPU time is about the budget), the worst seed, and the worst pixel's share
of the worst seed's error."""
import glob
import os
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
b = mi.Bitmap(sys.argv[1])
ch = dict(b.split())
R = np.array(ch["<root>"]).astype(float)[..., :3]
V = np.array(ch["variance"]).astype(float)[..., :3]
for pat in sys.argv[2:]:
    errs, shares = [], []
    for p in sorted(glob.glob(pat)):
        img = np.array(mi.Bitmap(p)).astype(float)[..., :3]
        e = (((img - R) ** 2 - V) / (R ** 2 + 0.01)).mean(-1)
        errs.append(e.mean())
        shares.append(e.max() / max(e.sum(), 1e-300))
    if not errs:
        print("%s: no images" % pat)
        continue
    errs = np.array(errs)
    k = int(errs.argmax())
    print("%s: n %d, mean %.4g, worst seed %.4g, its worst pixel's share %.2f" % (
        os.path.basename(pat), len(errs), errs.mean(), errs[k], shares[k]))
