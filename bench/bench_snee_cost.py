#!/usr/bin/env python3
"""bench/bench_snee_cost.py: several specular NEE settings against each other and `none` at equal
CPU time on one scene (the per-sample cost of specular NEE, bench/RESULTS.md).

Like bench_default.py: a reference rendered by the first setting at `--ref` CPU seconds; per setting
a 4-spp calibration render (CPU seconds per sample, user + system of the child from os.wait4, minus
the same command at 1 spp on one pixel), then `--seeds` renders with the sample count that fits
`--budget` CPU seconds. relMSE = mean over pixels of (img - ref)^2 / (ref^2 + 0.01), scaled by the
render's measured CPU time over the budget. Per setting: CPU-s per sample, relMSE mean over seeds,
worst seed, worst pixel's largest share of a seed's error, and the ratio none / setting.

usage (from the source root):
  python3 bench/bench_snee_cost.py SCENE.xml [--res 32] [--budget 2] [--ref 40] [--seeds 3]
                                   [--out DIR] SETTING [SETTING ...]
"""
import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_default import read_exr, run  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("settings", nargs="+")
    ap.add_argument("--specula", default=os.path.join(HERE, "..", "build", "specula"))
    ap.add_argument("--out", default="/tmp/bench_snee_cost")
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--budget", type=float, default=2.0)
    ap.add_argument("--ref", type=float, default=40.0)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--seed0", type=int, default=1)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    name = os.path.splitext(os.path.basename(a.scene))[0]

    def render(out, setting, spp, seed):
        return run([a.specula, "render", a.scene, "-o", out, "--spp", str(spp), "--seed", str(seed), "--threads",
                    "1", "--res", "%dx%d" % (a.res, a.res), "--quiet", "--specular-nee", setting])

    base = run([a.specula, "render", a.scene, "-o", os.path.join(a.out, "x.exr"), "--spp", "1", "--res", "1x1",
                "--threads", "1", "--quiet"])
    settings = a.settings + (["none"] if "none" not in a.settings else [])
    cal = {s: max(render(os.path.join(a.out, "cal.exr"), s, 4, 99) - base, 1e-3) / 4.0 for s in settings}
    ref_path = os.path.join(a.out, "%s_%d_ref.exr" % (name, a.res))
    if not os.path.exists(ref_path):
        render(ref_path, settings[0], max(16, int(a.ref / cal[settings[0]])), 12345)
    ref = read_exr(ref_path)
    res = {}
    for s in settings:
        errs, shares = [], []
        spp = max(1, int(a.budget / cal[s]))
        for k in range(a.seeds):
            p = os.path.join(a.out, "%s_%s_%d.exr" % (name, s.replace(":", "_").replace(",", "_"), k))
            cpu = render(p, s, spp, a.seed0 + k) - base
            e = ((read_exr(p) - ref) ** 2 / (ref ** 2 + 0.01)).mean(-1)
            errs.append(e.mean() * max(cpu, 1e-3) / a.budget)
            shares.append(e.max() / max(e.sum(), 1e-300))
        res[s] = (np.mean(errs), max(errs), max(shares), spp, cal[s])
    print("%s, %dx%d, %g CPU-s per render, %d seeds, reference %s" % (name, a.res, a.res, a.budget, a.seeds, settings[0]))
    print("| setting | CPU-s per sample (x none) | spp | relMSE mean (worst seed) | worst pixel's share | none / this |")
    print("|---|---|---|---|---|---|")
    n = res["none"][0]
    for s in settings:
        m, w, sh, spp, c = res[s]
        print("| %s | %.3g ms (%.1fx) | %d | %.3g (%.3g) | %.2f | %.2f |" % (s, 1e3 * c, c / cal["none"], spp, m, w, sh,
                                                                          n / m))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
