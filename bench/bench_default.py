#!/usr/bin/env python3
"""bench/bench_default.py: the default specular NEE (snee_plan.h) against `--specular-nee none`
at equal CPU time, on every caustic scene in scenes/.

For each scene: a reference rendered by the default (specula render, no flag; or --ref-setting) at
`--ref` CPU seconds, with its per-pixel variance; then, for each of `--seeds` seeds, the default and
none (and each --extra setting), each with the sample count that fits `--budget` CPU seconds (user + system of the child, from
os.wait4, minus the same command at 1 spp on one pixel with specular NEE off: loading and the
acceleration structure). The calibration renders each setting at n and 2n spp: their difference
gives the CPU per sample, the rest the fixed cost of a render (the plan's pilot), which is charged
once to the budget, not to the samples. relMSE = mean over pixels of
((img - ref)^2 - var_ref) / (ref^2 + 0.01) (as `specula diff`, less the reference's own expected
share, var_ref its variance of the mean: without it the reference's error sits in every column and
caps the ratios), scaled to the budget (relMSE x cpu / budget, exact for an unbiased estimator).
Reports per setting the mean over seeds, the worst seed, and the largest share of one pixel in a
seed's error sum, and the ratio none / setting of the means.

usage (from the source root):
  python3 bench/bench_default.py [--specula build/specula] [--out /tmp/bench_default] [--res 24]
                                 [--budget 1.0] [--ref 12] [--seeds 3] [--seed0 1] [--per-seed]
                                 [--setting S] [--extra S ...]
                                 [--ref-setting S] [--recalibrate] [SCENE.xml ...]
(--setting S: S instead of the default in the first column, against the same reference; --extra S:
one more column; --ref-setting S: the reference rendered with S instead of the default; --recalibrate:
each setting timed once more at the sample count the first calibration gave, for settings whose cost
per sample depends on the render's size, as auto:pilot's pilot render; --seed0 B (or --seed-base B):
the render seeds are B .. B + seeds - 1, default 1; --per-seed: each seed's line). Per setting, one line on stderr names the worst seed, its relMSE,
its worst pixel (x, y) and that pixel's share of the seed's error sum.
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


def render(a, scene, out, setting, spp, seed, res, variance=False):
    cmd = [a.specula, "render", scene, "-o", out, "--spp", str(spp), "--seed", str(seed), "--threads", "1",
           "--res", "%dx%d" % (res, res), "--quiet"]
    if setting is not None:
        cmd += ["--specular-nee", setting]
    if variance:
        cmd += ["--variance"]
    return run(cmd)


def calibrate(a, scene, s, base):
    """(CPU per sample, fixed CPU per render beyond the load) of setting s: a render at 4 spp, then
    renders at n and 2n spp, n doubled from 4 until their difference (n samples) takes a fifth of the
    budget or more; the CPU per sample from the 4-spp and the last render's difference, the fixed
    cost what the 4-spp render took beyond its 4 samples."""
    cal = os.path.join(a.out, "cal.exr")
    n = 4
    t0 = t1 = render(a, scene, cal, s, n, 99, a.res) - base
    while True:
        t2 = render(a, scene, cal, s, 2 * n, 99, a.res) - base
        if t2 - t1 >= 0.2 * a.budget or n >= 1 << 20:
            break
        n, t1 = 2 * n, t2
    per = max(t2 - t0, 1e-4) / (2 * n - 4)
    return per, max(t0 - 4 * per, 0.0)


def budget_spp(budget, per, fixed):
    """Samples that fill the budget after the fixed cost (at least 1)."""
    return max(1, int((budget - fixed) / per))


def read_exr_var(path):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    b = mi.Bitmap(path)
    ch = dict(b.split())
    img = np.array(ch["<root>"]).astype(np.float64)[..., :3]
    return img, np.array(ch["variance"]).astype(np.float64)[..., :3]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--out", default="/tmp/bench_default")
    ap.add_argument("--res", type=int, default=24)
    ap.add_argument("--budget", type=float, default=1.0)
    ap.add_argument("--ref", type=float, default=12.0)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--seed0", "--seed-base", dest="seed0", type=int, default=1, help="the first seed of the renders (seeds seed0 .. seed0 + seeds - 1)")
    ap.add_argument("--per-seed", action="store_true",
                    help="print each seed's relMSE, its worst pixel (x, y) and that pixel's share")
    ap.add_argument("--setting", default=None, help="render this setting in the default's column (no flag if absent)")
    ap.add_argument("--extra", action="append", default=[], help="one more column with this setting")
    ap.add_argument("--ref-setting", default=None, help="the reference's setting (default: no flag)")
    ap.add_argument("--recalibrate", action="store_true",
                    help="time each setting once more at the budget's sample count (for auto:pilot)")
    a = ap.parse_args()
    scenes = a.scenes or sorted(glob.glob(os.path.join(ROOT, "scenes", "caustic_*.xml")) +
                                [os.path.join(ROOT, "scenes", "demo.xml")])
    os.makedirs(a.out, exist_ok=True)
    cols = [a.setting, "none"] + a.extra
    head = "| scene | default | relMSE default: mean (worst seed), spp | relMSE none: mean (worst seed), spp | none / default |"
    for x in a.extra:
        head += " relMSE %s: mean (worst seed), spp | none / it |" % x
    head += " worst pixel's share (%s) |" % ", ".join(c or "default" for c in cols)
    print(head)
    print("|---" * (head.count("|") - 1) + "|")
    for scene in scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        plan = subprocess.run([a.specula, "info", scene], capture_output=True, text=True).stdout
        line = next((l for l in plan.splitlines() if l.startswith("specular NEE:")), "?")
        setting = line.split(":", 1)[1].split(";")[0].strip() if ":" in line else "?"
        # loading and the acceleration structure; with specular NEE off, so that a pilot render
        # (auto:pilot) is counted in the renders' time, not subtracted with the load
        base = run([a.specula, "render", scene, "-o", os.path.join(a.out, "x.exr"), "--spp", "1", "--res", "1x1",
                    "--threads", "1", "--quiet", "--specular-nee", "none"])
        if a.setting:
            setting = a.setting
        # per setting: its CPU per sample and its fixed cost per render beyond the load (the plan's
        # pilot at load, a pilot render), from two renders' difference: the fixed cost is spent once
        # per render, so charging it to a few samples would make a setting with a pilot look 10-100x
        # dearer per sample than it is and starve its column at equal time
        cal, fixed = {}, {}
        for s in cols + [a.ref_setting]:
            if s in cal:
                continue
            cal[s], fixed[s] = calibrate(a, scene, s, base)
            if a.recalibrate and s != a.ref_setting:
                # once more at the budget's sample count: a setting whose cost per sample depends on
                # the render's size (a pilot render, auto:pilot) is timed as it will run
                spp = budget_spp(a.budget, cal[s], fixed[s])
                c = render(a, scene, os.path.join(a.out, "cal.exr"), s, spp, 99, a.res) - base
                cal[s] = max(c - fixed[s], 1e-3) / spp
        ref_path = os.path.join(a.out, "%s_ref_%s.exr" % (name, (a.ref_setting or "default").replace(":", "_")))
        if not os.path.exists(ref_path):
            render(a, scene, ref_path, a.ref_setting, max(16, budget_spp(a.ref, cal[a.ref_setting],
                                                                         fixed[a.ref_setting])), 12345, a.res,
                   variance=True)
        ref, ref_var = read_exr_var(ref_path)
        res = {}
        for s in cols:
            errs, shares, worst = [], [], []
            spp = budget_spp(a.budget, cal[s], fixed[s])
            for k in range(a.seeds):
                p = os.path.join(a.out, "%s_%s_%d.exr" % (name, (s or "default").replace(":", "_"), k))
                cpu = render(a, scene, p, s, spp, a.seed0 + k, a.res) - base
                img = read_exr(p)
                e = (((img - ref) ** 2 - ref_var) / (ref ** 2 + 0.01)).mean(-1)
                errs.append(e.mean() * max(cpu, 1e-3) / a.budget)
                shares.append(e.max() / max(e.sum(), 1e-300))
                y, x = np.unravel_index(np.argmax(e), e.shape)
                worst.append((a.seed0 + k, int(x), int(y), shares[-1]))
                if a.per_seed:
                    print("#  %s %s seed %d: relMSE %.4g, worst pixel (x %d, y %d) share %.2f, cpu %.3f s" % (
                        name, s or "default", a.seed0 + k, errs[-1], x, y, shares[-1], cpu))
            res[s] = (np.mean(errs), max(errs), max(shares), spp)
            k = int(np.argmax(errs))
            print("%s %s: worst seed %d relMSE %.4g, pixel (%d, %d) share %.2f; median %.4g" % (
                name, s or "default", worst[k][0], errs[k], worst[k][1], worst[k][2], worst[k][3],
                np.median(errs)), file=sys.stderr)
            np.savetxt(os.path.join(a.out, "%s_%s_errs.txt" % (name, (s or "default").replace(":", "_"))),
                       np.array([[w[0], errs[i], w[1], w[2], w[3]] for i, w in enumerate(worst)]),
                       fmt="%.6g", header="seed relMSE worst_x worst_y worst_share")
        d, n = res[a.setting], res["none"]
        row = "| %s | %s | %.3g (%.3g), %d spp | %.3g (%.3g), %d spp | %.1f |" % (
            name, setting, d[0], d[1], d[3], n[0], n[1], n[3], n[0] / d[0])
        for x in a.extra:
            r = res[x]
            row += " %.3g (%.3g), %d spp | %.1f |" % (r[0], r[1], r[3], n[0] / r[0])
        row += " %s |" % ", ".join("%.2f" % res[c][2] for c in cols)
        print(row)
        sys.stdout.flush()


if __name__ == "__main__":
    main()
