#!/usr/bin/env python3
"""bench/bench_seeds.py: one setting's error per seed at equal CPU time against a fixed reference, and
where each seed's error lies (its worst pixel and that pixel's share), for finding one-pixel tails.

Complements bench_default.py (which renders its own reference with the default and compares the
default with none): here the reference is given (e.g. `--specular-nee none` at many samples, rendered
with --variance, so that no tail of the estimator under test sits in it), the seeds a range, the
sample count fixed or calibrated once to --budget CPU seconds (user + system of one-thread
children), and environment variables pass through to specula. relMSE per seed as bench_default.py:
mean over pixels of ((img - ref)^2 - var_ref) / (ref^2 + 0.01), times cpu / budget.

usage (from the source root):
  python3 bench/bench_seeds.py --ref REF.exr [--scene scenes/caustic_sdf_torus.xml] [--setting S]
         [--label L] [--seeds 1-8] [--spp N | --budget 1.5] [--res 32] [--specula build/specula] [--out DIR]
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_default as bd  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--specula", default=os.path.join(bd.ROOT, "build", "specula"))
    ap.add_argument("--scene", default=os.path.join(bd.ROOT, "scenes", "caustic_sdf_torus.xml"))
    ap.add_argument("--ref", required=True, help="reference EXR with a variance channel (--variance)")
    ap.add_argument("--setting", default=None, help="--specular-nee S (no flag if absent)")
    ap.add_argument("--label", default="x")
    ap.add_argument("--seeds", default="1-8", help="first-last")
    ap.add_argument("--budget", type=float, default=1.5)
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--spp", type=int, default=0, help="fixed sample count (0: calibrated to the budget)")
    ap.add_argument("--out", default="/tmp/bench_seeds")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    lo, hi = map(int, a.seeds.split("-"))
    base = bd.run([a.specula, "render", a.scene, "-o", os.path.join(a.out, "x_%s.exr" % a.label), "--spp", "1",
                   "--res", "1x1", "--threads", "1", "--quiet", "--specular-nee", "none"])
    if a.spp <= 0:
        c = bd.render(a, a.scene, os.path.join(a.out, "cal_%s.exr" % a.label), a.setting, 8, 99, a.res) - base
        a.spp = max(1, int(a.budget / (max(c, 1e-3) / 8)))
    ref, ref_var = bd.read_exr_var(a.ref)
    errs, shares = [], []
    for s in range(lo, hi + 1):
        p = os.path.join(a.out, "%s_%d.exr" % (a.label, s))
        cpu = bd.render(a, a.scene, p, a.setting, a.spp, s, a.res) - base
        e = (((bd.read_exr(p) - ref) ** 2 - ref_var) / (ref ** 2 + 0.01)).mean(-1)
        errs.append(e.mean() * max(cpu, 1e-3) / a.budget)
        shares.append(e.max() / max(e.sum(), 1e-300))
        print("  seed %d: relMSE %.4g cpu %.2f share %.2f at row %d col %d" % ((s, errs[-1], cpu, shares[-1]) +
              np.unravel_index(np.argmax(e), e.shape)), flush=True)
    w = int(np.argmax(errs))
    print("%s: %d spp, relMSE mean %.4g, worst %.4g (seed %d, worst pixel's share %.2f)" % (
        a.label, a.spp, np.mean(errs), errs[w], lo + w, shares[w]))


if __name__ == "__main__":
    main()
