#!/usr/bin/env python3
"""bench/bdpt_split.py: where bdpt's variance is, per strategy (s, t), over seeds.

    python3 bench/bdpt_split.py [--specula build/specula] [--spp 512] [--seeds 8] [--res 32]
                                [--max-depth 8] [--rows Y0:Y1] [--out DIR] SCENE.xml [-- ARGS...]

Renders SCENE with bdpt and `--strategy-images` (one thread, seeds 1..N, `-D res=RES`), and prints the
image's variance over the seeds as relMSE's measure (mean over pixels and channels of var /
(ref^2 + 0.01), ref = the mean image), then every weighted strategy film's own variance in the
same measure with its share of the image's, the part of it in the rows Y0:Y1 (default: the lower
half of the film), and the film's share of the image's mean. "snee" is the image minus the sum of
the strategy films: specular NEE's own contributions, which no strategy film holds. The films'
variances do not add up to the image's (they covary). CPU is user + system of the renders (the
strategy films cost a little extra). ARGS go to every render (e.g. --specular-nee angular:camera=0.01).
"""
import argparse
import glob
import os
import subprocess
import sys

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def read_rgb(path):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


def main():
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1:]
        argv = argv[:argv.index("--")]
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--spp", type=int, default=512)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--rows", default="")
    ap.add_argument("--out", default="/tmp/specula_bdpt_split")
    ap.add_argument("--top", type=int, default=14)
    a = ap.parse_args(argv)
    y0, y1 = (int(v) for v in a.rows.split(":")) if a.rows else (a.res // 2, a.res)
    imgs, films, cpu = [], {}, 0.0
    for seed in range(1, a.seeds + 1):
        d = os.path.join(a.out, f"seed{seed}")
        os.makedirs(d, exist_ok=True)
        for f in glob.glob(os.path.join(d, "*.exr")):
            os.remove(f)
        cmd = [a.specula, "render", a.scene, "--integrator", "bdpt", "--spp", str(a.spp), "--seed", str(seed),
               "--threads", "1", "--quiet", "-o", os.path.join(d, "image.exr"), "-D", f"res={a.res}",
               "--max-depth", str(a.max_depth), "--strategy-images", d] + extra
        p = subprocess.Popen(cmd)
        _, status, ru = os.wait4(p.pid, 0)
        if status != 0:
            sys.exit(f"render failed: {' '.join(cmd)}")
        cpu += ru.ru_utime + ru.ru_stime
        imgs.append(read_rgb(os.path.join(d, "image.exr")))
        for f in glob.glob(os.path.join(d, "s*_t*_weighted.exr")):
            films.setdefault(os.path.basename(f)[:-len("_weighted.exr")], []).append(read_rgb(f))
    imgs = np.array(imgs)
    ref = imgs.mean(axis=0)
    den = ref ** 2 + 0.01
    total = (imgs.var(axis=0, ddof=1) / den).mean()
    print(f"{os.path.basename(a.scene)}: {a.seeds} seeds x {a.spp} spp, CPU {cpu / a.seeds:.3f} s a seed, "
          f"image variance {total:.4g} (rows {y0}:{y1}: {100 * (imgs.var(axis=0, ddof=1) / den)[y0:y1].sum() / (total * den.size):.1f}%)")
    rows, acc = [], 0.0
    for name, v in films.items():
        v = np.array(v)
        acc = acc + v
        var = v.var(axis=0, ddof=1) / den
        rows.append((var.mean(), name, var[y0:y1].sum() / den.size, v.mean() / ref.mean()))
    rest = imgs - acc
    var = rest.var(axis=0, ddof=1) / den
    rows.append((var.mean(), "snee", var[y0:y1].sum() / den.size, rest.mean() / ref.mean()))
    print(f"| strategy | variance | share | in rows {y0}:{y1} | share of the mean |")
    print("|---|---|---|---|---|")
    for v, name, part, mean in sorted(rows, reverse=True)[:a.top]:
        print(f"| {name} | {v:.3g} | {100 * v / total:.1f}% | {100 * part / total:.1f}% | {100 * mean:.1f}% |")


if __name__ == "__main__":
    sys.exit(main())
