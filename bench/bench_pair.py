#!/usr/bin/env python3
"""bench/bench_pair.py: two specular NEE settings against each other at equal CPU time.

For each scene: a reference (REF.exr given as SCENE=REF, or rendered with setting A at `--ref` CPU
seconds), then for each seed the two settings rendered one after the other (so both see the same
machine load), each with the sample count that a calibration render says fits `--budget` CPU
seconds (user + system of the child, minus a 1-spp 1x1 render: loading). relMSE as
bench/bench_default.py (mean over pixels of (img - ref)^2 / (ref^2 + 0.01), scaled by cpu / budget).
Prints per setting the mean over seeds, the worst seed and the worst pixel's largest share of a
seed's error, and B / A of the means.

usage (from the source root):
  python3 bench/bench_pair.py A B SCENE.xml[=REF.exr] ... [--seeds 8] [--budget 1] [--res 24]
                              [--ref 40] [--out /tmp/bench_pair]
e.g. python3 bench/bench_pair.py angular:noreflect angular scenes/caustic_glass_sphere.xml
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_default import ROOT, read_exr, render, run  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--out", default="/tmp/bench_pair")
    ap.add_argument("--res", type=int, default=24)
    ap.add_argument("--budget", type=float, default=1.0)
    ap.add_argument("--ref", type=float, default=40.0)
    ap.add_argument("--seeds", type=int, default=8)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    print("| scene | %s: mean (worst seed), spp, worst pixel's share | %s: mean (worst seed), spp, worst pixel's "
          "share | %s / %s |" % (a.a, a.b, a.a, a.b))
    print("|---|---|---|---|")
    for arg in a.scenes:
        scene, _, ref_path = arg.partition("=")
        name = os.path.splitext(os.path.basename(scene))[0]
        base = run([a.specula, "render", scene, "-o", os.path.join(a.out, "x.exr"), "--spp", "1", "--res", "1x1",
                    "--threads", "1", "--quiet"])
        cal = {}
        for s in (a.a, a.b):
            c = render(a, scene, os.path.join(a.out, "cal.exr"), s, 8, 99, a.res) - base
            cal[s] = max(c, 1e-3) / 8.0
        if not ref_path:
            ref_path = os.path.join(a.out, name + "_ref.exr")
            if not os.path.exists(ref_path):
                render(a, scene, ref_path, a.a, max(16, int(a.ref / cal[a.a])), 12345, a.res)
        ref = read_exr(ref_path)
        errs = {a.a: [], a.b: []}
        shares = {a.a: [], a.b: []}
        spp = {s: max(1, int(a.budget / cal[s])) for s in (a.a, a.b)}
        for k in range(a.seeds):
            for s in (a.a, a.b):
                p = os.path.join(a.out, "%s_%s_%d.exr" % (name, s.replace(":", "_").replace(",", "_"), k))
                cpu = render(a, scene, p, s, spp[s], 1 + k, a.res) - base
                e = ((read_exr(p) - ref) ** 2 / (ref ** 2 + 0.01)).mean(-1)
                errs[s].append(e.mean() * max(cpu, 1e-3) / a.budget)
                shares[s].append(e.max() / max(e.sum(), 1e-300))
        ma, mb = np.mean(errs[a.a]), np.mean(errs[a.b])
        print("| %s | %.3g (%.3g), %d spp, %.2f | %.3g (%.3g), %d spp, %.2f | %.2f |" % (
            name, ma, max(errs[a.a]), spp[a.a], max(shares[a.a]), mb, max(errs[a.b]), spp[a.b], max(shares[a.b]),
            ma / mb))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
