#!/usr/bin/env python3
"""bench/bench_fixed_pair.py: variants of one renderer at a fixed sample count, paired seed by seed.

    python3 bench/bench_fixed_pair.py SCENE.xml SPP SEEDS LABEL=BIN[|ENV[|ARGS]] ...
        [--integrator bdpt] [--res 32] [--first-seed 1] [--out DIR]

Each seed renders every variant in turn (one thread, `-D res=RES`), so that all of them see the same
machine load; BIN is a specula binary, ENV space-separated NAME=VALUE pairs for its environment,
ARGS extra arguments (e.g. "base=/tmp/base/specula" "q01=build/specula||--specular-nee
angular:camera=0.01"). Per variant: the mean CPU seconds of a render (user + system of the child),
the scatter over the seeds (mean over pixels and channels of the variance over seeds / (ref^2 +
0.01), ref = the mean of all variants' images: relMSE less the bias they share), the image mean, and
the first variant's scatter x CPU over this one's (above 1: this one is better at equal CPU time).
A variance measure at equal samples: the tails of a heavy-tailed scene need more seeds than its
mean, and an equal-CPU run with a reference (bench_bdpt_seeds.py) for the claim.
"""
import argparse
import os
import subprocess
import sys

import numpy as np


def read_rgb(path):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("spp", type=int)
    ap.add_argument("seeds", type=int)
    ap.add_argument("variants", nargs="+")
    ap.add_argument("--integrator", default="bdpt")
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--out", default="/tmp/specula_fixed_pair")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    variants = []
    for v in a.variants:
        label, rest = v.split("=", 1)
        binary, env, args = (rest.split("|") + ["", ""])[:3]
        variants.append((label, binary, env.split(), args.split()))
    imgs = {v[0]: [] for v in variants}
    cpu = {v[0]: [] for v in variants}
    for seed in range(a.first_seed, a.first_seed + a.seeds):
        for label, binary, env, args in variants:
            out = os.path.join(a.out, f"{label}_{seed}.exr")
            cmd = [binary, "render", a.scene, "--integrator", a.integrator, "--spp", str(a.spp), "--seed", str(seed),
                   "--threads", "1", "--quiet", "-o", out, "-D", f"res={a.res}"] + args
            e = dict(os.environ)
            e.update(kv.split("=", 1) for kv in env)
            p = subprocess.Popen(cmd, env=e)
            _, status, ru = os.wait4(p.pid, 0)
            if status != 0:
                sys.exit(f"render failed: {' '.join(cmd)}")
            cpu[label].append(ru.ru_utime + ru.ru_stime)
            imgs[label].append(read_rgb(out))
    ref = np.mean([np.mean(imgs[v[0]], axis=0) for v in variants], axis=0)
    first = None
    print(f"{os.path.basename(a.scene)}: {a.integrator}, {a.spp} spp, seeds {a.first_seed}..{a.first_seed + a.seeds - 1}, "
          f"{a.res}x{a.res}, one thread, load average {open('/proc/loadavg').read().split()[:3]}")
    print("| variant | CPU s | scatter | image mean | first / this (x CPU) |")
    print("|---|---|---|---|---|")
    for label, *_ in variants:
        x = np.array(imgs[label])
        scatter = (x.var(axis=0, ddof=1) / (ref ** 2 + 0.01)).mean()
        c = float(np.mean(cpu[label]))
        if first is None:
            first = scatter * c
        print(f"| {label} | {c:.3f} | {scatter:.5g} | {x.mean():.5f} | {first / (scatter * c):.3f} |")


if __name__ == "__main__":
    sys.exit(main())
