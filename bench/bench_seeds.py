#!/usr/bin/env python3
"""bench/bench_seeds.py: one setting's equal-CPU-time error over many seeds against a fixed reference.

bench_default.py renders its own reference per output folder and a few seeds; where an estimator has
a heavy tail (one sample in a few million holding a seed's whole error), a comparison of two builds
or settings needs the same reference and more seeds, and the sample count decides which rare samples
a seed contains (renders are deterministic per seed and sample index). This script renders seeds
seed0+1..seed0+N (`--seed0`, default 0: fresh seeds past a run's), `--jobs` at once, one thread
each, each at the sample count that a 4-spp calibration says fits `--budget` CPU seconds (user +
system of the child, less the load time), and prints per seed relMSE = mean over pixels of ((img -
ref)^2 - var_ref) / (ref^2 + 0.01) scaled by cpu / budget (as bench_default.py), with the mean,
median, worst seed and the worst pixel's share.

usage (from the source root):
  python3 bench/bench_seeds.py SCENE.xml REF.exr [--setting S] [--seeds 24] [--seed0 0] [--jobs 4]
                               [--res 32] [--budget 1.5] [--spp N] [--specula build/specula] [--out DIR]
REF.exr: a render with --variance at the same size (e.g. bench_default.py's reference, or
`specula render SCENE --spp 4096 --variance`). --setting: a --specular-nee value (default: no
flag, the plan's). --spp: this sample count instead of the calibration's (same samples for two
builds).
"""
import argparse
import os
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))
sys.path.insert(0, HERE)
from bench_default import run  # noqa: E402  (a child's CPU seconds, output discarded)


def read(path, var=False):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    ch = dict(mi.Bitmap(path).split())
    img = np.array(ch["<root>"]).astype(np.float64)[..., :3]
    if var:
        return img, np.array(ch["variance"]).astype(np.float64)[..., :3]
    return img


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("ref")
    ap.add_argument("--setting", default=None)
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--seed0", type=int, default=0, help="render seeds seed0+1 .. seed0+seeds (fresh seeds)")
    ap.add_argument("--jobs", type=int, default=4)
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--budget", type=float, default=1.5)
    ap.add_argument("--spp", type=int, default=0)
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--out", default="/tmp/bench_seeds")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    flag = ["--specular-nee", a.setting] if a.setting else []
    size = ["--threads", "1", "--res", "%dx%d" % (a.res, a.res), "--quiet"]
    base = run([a.specula, "render", a.scene, "-o", os.path.join(a.out, "x.exr"), "--spp", "1", "--res", "1x1",
                "--threads", "1", "--quiet", "--specular-nee", "none"])
    spp = a.spp
    if spp <= 0:
        c = run([a.specula, "render", a.scene, "-o", os.path.join(a.out, "cal.exr"), "--spp", "4", "--seed", "99"] +
                size + flag) - base
        spp = max(1, int(a.budget / (max(c, 1e-3) / 4.0)))
    ref, ref_var = read(a.ref, True)

    def one(k):
        p = os.path.join(a.out, "seed%d.exr" % (a.seed0 + k + 1))
        cpu = run([a.specula, "render", a.scene, "-o", p, "--spp", str(spp), "--seed", str(a.seed0 + k + 1)] + size +
                  flag) - base
        e = (((read(p) - ref) ** 2 - ref_var) / (ref ** 2 + 0.01)).mean(-1)
        y, x = np.unravel_index(np.argmax(e), e.shape)
        return e.mean() * max(cpu, 1e-3) / a.budget, e.max() / max(e.sum(), 1e-300), (y, x), cpu

    with ThreadPoolExecutor(a.jobs) as ex:
        r = list(ex.map(one, range(a.seeds)))
    errs = np.array([x[0] for x in r])
    w = int(errs.argmax())
    print("%s %s: %d spp, mean %.4g, median %.4g, worst %.4g (seed %d, pixel (%d, %d) %.2f of it), CPU %.2f s" % (
        os.path.basename(a.scene), a.setting or "default", spp, errs.mean(), np.median(errs), errs[w], a.seed0 + w + 1,
        r[w][2][0], r[w][2][1], r[w][1], np.mean([x[3] for x in r])))
    print("per seed: " + " ".join("%.3g" % e for e in errs))


if __name__ == "__main__":
    main()
