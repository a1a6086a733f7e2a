#!/usr/bin/env python3
"""bench/error_map.py: where a bench_default.py run's error is, pixel by pixel and seed by seed.

Reads a bench_default.py output folder (DIR/SCENE_ref_*.exr with its variance, DIR/SCENE_SETTING_K.exr
for the seeds K) and sums bench_default's relMSE terms ((img - ref)^2 - var_ref) / (ref^2 + 0.01) per
pixel over the seeds. Prints the share of the sum in each pixel class (from the normal AOV of a
`specula render SCENE --aovs` image given with --aov: "curved" for pixels whose normal is no axis, else
the axis and its sign; with --floor-split the floor (normal +y) also by the reference: above 0.5, below
0.06, between), the ten largest pixels with their reference values, and per seed its unscaled relMSE
and its worst pixel's share; then the mean, median and worst of the seeds' relMSE and the mean without
the worst seed, for every setting in the folder.

usage: python3 bench/error_map.py DIR SCENE [--setting default] [--aov AOV.exr] [--floor-split]
                                  [--exclude K,K]
"""
import argparse
import glob
import os

import numpy as np


def channels(path):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    return {k: np.array(v).astype(np.float64) for k, v in mi.Bitmap(path).split()}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("scene")
    ap.add_argument("--setting", default="default", help="the file name's setting part (':' as '_')")
    ap.add_argument("--aov", help="an EXR with a normal channel (specula render --aovs), same size")
    ap.add_argument("--floor-split", action="store_true")
    ap.add_argument("--exclude", default="", help="seed file indices to leave out, comma-separated")
    a = ap.parse_args()
    r = channels(glob.glob(os.path.join(a.dir, "%s_ref_*.exr" % a.scene))[0])
    ref, var = r["<root>"][..., :3], r["variance"][..., :3]
    R = ref.mean(-1)
    classes = {"all": np.ones(R.shape, bool)}
    if a.aov:
        n = channels(a.aov)["normal"][..., :3]
        ax = np.argmax(np.abs(n), -1)
        sign = np.take_along_axis(n, ax[..., None], -1)[..., 0] > 0
        axial = np.abs(n).max(-1) > 0.999
        classes = {"curved": ~axial}
        for i, name in enumerate("xyz"):
            for s, sn in ((True, "+"), (False, "-")):
                m = axial & (ax == i) & (sign == s)
                if m.any():
                    classes[name + sn] = m
        if a.floor_split and "y+" in classes:
            fl = classes.pop("y+")
            classes["y+ ref > 0.5"] = fl & (R > 0.5)
            classes["y+ ref < 0.06"] = fl & (R < 0.06)
            classes["y+ between"] = fl & (R >= 0.06) & (R <= 0.5)
    skip = set(x for x in a.exclude.split(",") if x)
    paths = [p for p in sorted(glob.glob(os.path.join(a.dir, "%s_%s_[0-9]*.exr" % (a.scene, a.setting))))
             if os.path.splitext(p)[0].rsplit("_", 1)[1] not in skip]
    E = np.zeros(R.shape)
    per = []
    for p in paths:
        img = channels(p)["<root>"][..., :3]
        e = (((img - ref) ** 2 - var) / (ref ** 2 + 0.01)).mean(-1)
        E += e
        per.append((int(os.path.splitext(p)[0].rsplit("_", 1)[1]), e.mean(), e.max() / e.sum(),
                    np.unravel_index(e.argmax(), e.shape)))
    tot = E.sum()
    print("%s %s: %d seeds, error sum %.4g" % (a.scene, a.setting, len(paths), tot))
    for k, m in classes.items():
        print("  %-16s %4d px  share %.3f" % (k, m.sum(), E[m].sum() / tot))
    top = np.argsort(E.ravel())[::-1][:10]
    print("  ten largest pixels: %.3f of the sum" % (E.ravel()[top].sum() / tot))
    for i in top:
        y, x = np.unravel_index(i, E.shape)
        print("    (x %d, y %d) share %.3f, reference %.4g" % (x, y, E[y, x] / tot, R[y, x]))
    for k, m, sh, (y, x) in sorted(per):
        print("  seed file %d (seed %d): relMSE %.3g, worst pixel (x %d, y %d) %.2f of it" % (k, k + 1, m, x, y, sh))
    es = np.array([m for _, m, _, _ in per])
    print("  unscaled relMSE: mean %.3g, median %.3g, worst %.3g, mean without the worst %.3g" % (
        es.mean(), np.median(es), es.max(), np.sort(es)[:-1].mean() if len(es) > 1 else es.mean()))


if __name__ == "__main__":
    main()
