#!/usr/bin/env python3
"""bench/bench_default.py: the default specular NEE (snee_plan.h) against `--specular-nee none`
at equal CPU time, on every caustic scene in scenes/.

For each scene: a reference rendered by the default (specula render, no flag) at `--ref` CPU
seconds; then, for each of `--seeds` seeds, the default and none, each with the sample count that a
short calibration render says fits `--budget` CPU seconds (user + system of the child, from
os.wait4, minus the same command at 1 spp on one pixel: loading and the acceleration structure).
relMSE = mean over pixels of (img - ref)^2 / (ref^2 + 0.01) (as `specula diff`), scaled to the
budget (relMSE x cpu / budget, exact for an unbiased estimator). Reports per setting the mean over
seeds, the worst seed, and the share of the worst pixel in the error of the mean image's error sum,
and the ratio none / default of the means. The reference's own error is in both columns alike.

usage (from the source root):
  python3 bench/bench_default.py [--specula build/specula] [--out /tmp/bench_default] [--res 24]
                                 [--budget 1.0] [--ref 12] [--seeds 3] [--setting S] [SCENE.xml ...]
(--setting S: S instead of the default in the first column, against the same reference)
"""
import argparse
import glob
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))


def read_exr(path):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(path)).astype(np.float64)[..., :3]


def run(args):
    pid = os.fork()
    if pid == 0:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        try:
            os.execv(args[0], args)
        finally:
            os._exit(127)
    _, status, ru = os.wait4(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError("failed: " + " ".join(args))
    return ru.ru_utime + ru.ru_stime


def render(a, scene, out, setting, spp, seed, res):
    cmd = [a.specula, "render", scene, "-o", out, "--spp", str(spp), "--seed", str(seed), "--threads", "1",
           "--res", "%dx%d" % (res, res), "--quiet"]
    if setting is not None:
        cmd += ["--specular-nee", setting]
    return run(cmd)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--out", default="/tmp/bench_default")
    ap.add_argument("--res", type=int, default=24)
    ap.add_argument("--budget", type=float, default=1.0)
    ap.add_argument("--ref", type=float, default=12.0)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--setting", default=None, help="render this setting in the default's column (no flag if absent)")
    a = ap.parse_args()
    scenes = a.scenes or sorted(glob.glob(os.path.join(ROOT, "scenes", "caustic_*.xml")) +
                                [os.path.join(ROOT, "scenes", "demo.xml")])
    os.makedirs(a.out, exist_ok=True)
    print("| scene | default | relMSE default: mean (worst seed) | relMSE none: mean (worst seed) | none / default | worst pixel's share (default, none) |")
    print("|---|---|---|---|---|---|")
    for scene in scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        plan = subprocess.run([a.specula, "info", scene], capture_output=True, text=True).stdout
        line = next((l for l in plan.splitlines() if l.startswith("specular NEE:")), "?")
        setting = line.split(":", 1)[1].split(";")[0].strip() if ":" in line else "?"
        base = run([a.specula, "render", scene, "-o", os.path.join(a.out, "x.exr"), "--spp", "1", "--res", "1x1",
                    "--threads", "1", "--quiet"])
        if a.setting:
            setting = a.setting
        cal = {}
        for s in (a.setting, "none"):
            c = render(a, scene, os.path.join(a.out, "cal.exr"), s, 4, 99, a.res) - base
            cal[s] = max(c, 1e-3) / 4.0
        ref_path = os.path.join(a.out, name + "_ref.exr")
        if not os.path.exists(ref_path):
            render(a, scene, ref_path, None, max(16, int(a.ref / cal[a.setting])), 12345, a.res)
        ref = read_exr(ref_path)
        res = {}
        for s in (a.setting, "none"):
            errs, shares = [], []
            spp = max(1, int(a.budget / cal[s]))
            for k in range(a.seeds):
                p = os.path.join(a.out, "%s_%s_%d.exr" % (name, (s or "default").replace(":", "_"), k))
                cpu = render(a, scene, p, s, spp, 1 + k, a.res) - base
                img = read_exr(p)
                e = ((img - ref) ** 2 / (ref ** 2 + 0.01)).mean(-1)
                errs.append(e.mean() * max(cpu, 1e-3) / a.budget)
                shares.append(e.max() / max(e.sum(), 1e-300))
            res[s] = (np.mean(errs), max(errs), max(shares), spp)
        d, n = res[a.setting], res["none"]
        print("| %s | %s | %.3g (%.3g), %d spp | %.3g (%.3g), %d spp | %.1f | %.2f, %.2f |" % (
            name, setting, d[0], d[1], d[3], n[0], n[1], n[3], n[0] / d[0], d[2], n[2]))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
