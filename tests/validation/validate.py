#!/usr/bin/env python3
"""Render every validation scene with Mitsuba 3 and with specula and z-test the images.

    python3 tests/validation/validate.py [SCENE.xml ...] [--out DIR] [--res 64] [--spp 1024]
                                         [--passes 32] [--force] [--markdown FILE] [--json FILE]

Default scenes: scenes/*.xml and ../shared/scenes/*/scene.xml. For each scene:
  1. a Mitsuba 3 reference (tests/validation/mitsuba_ref.py, scalar_rgb): the mean of `passes`
     independent renders and the variance of that mean from their spread; cached in --out and
     reused unless --force;
  2. a specula render at the same spp with --variance (the variance of the mean from its passes);
  3. `specula diff --json`: per pixel and channel z = (a - b) / sqrt(var_a + var_b), a pixel fails
     when its smallest p-value (Sidak over its channels) is below alpha = 0.01 Sidak-corrected over
     the pixels. Mitsuba's own bar (src/render/tests/test_renders.py) is 99.75% of pixels passing.
Both renderers get `-D integrator=path` (volpath for scenes whose default is volpath) and the
small resolution (`res`, or `resx`/`resy` when the scene declares those defaults). Mitsuba gets
the file with specula-only properties removed (mitsuba_ref.py). Scenes listed in SPP_FACTOR get
more samples (caustics need them for the variance estimate to be meaningful). The table gives
resolution, spp of each, pass rate, both means and relMSE.

The per-pixel test has little power against a small bias spread over the whole image (a 2%
difference in one material passed 96% of the pixels), so each row also gets z_mean: per channel,
the difference of the image means over its standard error, sqrt(sum of both per-pixel variances)
/ pixels (pixels are independent in both renderers). A channel beyond the Sidak-corrected bound
for alpha = 0.01 over the three channels (|z| > 2.94) marks the row. Scenes that declare resx and
resy keep their aspect ratio, the smaller side `res` pixels.
"""
import argparse
import glob
import hashlib
import json
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
PASS_BAR = 0.9975

# Scenes Mitsuba 3 cannot render, and why (reported instead of an error).
NOT_IN_MITSUBA = {
    "roughdiffuse": "Mitsuba 3.9 has no roughdiffuse plugin (Mitsuba 0.6 had one)",
    "caustic_sdf_torus": "the sdf shape is specula's own; Mitsuba 3 has no such plugin",
}

# Scenes whose estimators are noisy enough that 1024 spp leaves a poor variance estimate.
SPP_FACTOR = {
    "caustic_glass_sphere": 4,
    "caustic_mirror_ring": 4,
    "caustic_pool": 4,
    "veach-mis": 2,
    # volpath through a glass boundary without NEE into the medium: light is found by phase
    # sampling only, so both images are noisy
    "medium_glass": 16,
}

# |z| bound for the image means: alpha 0.01, Sidak over 3 channels (two-sided normal quantile)
Z_MEAN_BOUND = 2.94


def scene_name(path):
    base = os.path.basename(path)
    if base == "scene.xml":
        return os.path.basename(os.path.dirname(path))
    return os.path.splitext(base)[0]


def resolution_defines(path, res):
    text = open(path, encoding="utf-8").read()
    values = dict(re.findall(r'<default\s+name="([a-zA-Z_]+)"\s+value="([^"]*)"', text))
    names = set(values)
    d = []
    if "res" in names:
        d.append("res=%d" % res)
    if "resx" in names and "resy" in names:
        # keep the aspect ratio, the smaller side res pixels
        wx, wy = float(values["resx"]), float(values["resy"])
        d.append("resx=%d" % round(res * max(1.0, wx / wy)))
        d.append("resy=%d" % round(res * max(1.0, wy / wx)))
    elif "resx" in names or "resy" in names:
        d += ["%s=%d" % (k, res) for k in ("resx", "resy") if k in names]
    if "integrator" in names:
        # the path tracer, or volpath for scenes made for it (participating media)
        volpath = re.search(r'<default\s+name="integrator"\s+value="volpath"', text)
        d.append("integrator=volpath" if volpath else "integrator=path")
    return d


def image_mean_z(a_path, b_path):
    """Per channel: (mean_a - mean_b) / standard error of the difference of the image means."""
    import numpy as np
    import mitsuba as mi

    if not mi.variant():
        mi.set_variant("scalar_rgb")

    def load(p):
        bmp = mi.Bitmap(p)
        names = [f.name for f in bmp.struct_()]
        x = np.array(bmp, dtype=np.float64)
        m = x[..., [names.index(c) for c in ("R", "G", "B")]]
        v = x[..., [names.index("variance." + c) for c in ("R", "G", "B")]]
        return m, v

    ma, va = load(a_path)
    mb, vb = load(b_path)
    n = ma.shape[0] * ma.shape[1]
    se = np.sqrt((va + vb).sum(axis=(0, 1))) / n
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (ma.mean(axis=(0, 1)) - mb.mean(axis=(0, 1))) / se
    return [float(v) if np.isfinite(v) else 0.0 for v in z]


def run(cmd, log):
    t0 = time.time()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    dt = time.time() - t0
    with open(log, "a") as f:
        f.write("$ " + " ".join(cmd) + "\n" + p.stdout + "\n")
    if p.returncode != 0:
        raise RuntimeError("command failed (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stdout[-2000:]))
    return p.stdout, dt


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--out", default="/tmp/specula-validation")
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--passes", type=int, default=32)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--force", action="store_true", help="re-render cached Mitsuba references")
    ap.add_argument("--markdown")
    ap.add_argument("--json")
    ap.add_argument("-D", action="append", default=[], help="extra define for both renderers")
    a = ap.parse_args()
    scenes = a.scenes or (sorted(glob.glob(os.path.join(ROOT, "scenes", "*.xml"))) +
                          sorted(glob.glob(os.path.join(ROOT, "..", "shared", "scenes", "*", "scene.xml"))))
    os.makedirs(a.out, exist_ok=True)
    log = os.path.join(a.out, "validate.log")
    rows = []
    for path in scenes:
        name = scene_name(path)
        spp = a.spp * SPP_FACTOR.get(name, 1)
        defs = resolution_defines(path, a.res) + a.D
        dflags = sum((["-D", d] for d in defs), [])
        # the cached reference is named by what it depends on: the file, the defines, spp, passes
        key = hashlib.sha1(("%s|%s|%d|%d" % (open(path, "rb").read(), defs, spp, a.passes)).encode()).hexdigest()[:10]
        ref = os.path.join(a.out, "%s_%s_mitsuba.exr" % (name, key))
        img = os.path.join(a.out, name + "_specula.exr")
        row = {"scene": name, "res": a.res, "spp_mitsuba": spp, "spp_specula": spp, "passes": a.passes}
        try:
            if a.force or not os.path.exists(ref):
                _, row["time_mitsuba"] = run([sys.executable, os.path.join(HERE, "mitsuba_ref.py"), path, ref, "--spp",
                                              str(spp), "--passes", str(a.passes)] + dflags, log)
            _, row["time_specula"] = run([a.specula, "render", path, "-o", img, "--spp", str(spp), "--variance",
                                          "--quiet", "--threads", str(a.threads)] + dflags, log)
            out, _ = run([a.specula, "diff", img, ref, "--json"], log)
            d = json.loads(out)
            row["width"], row["height"] = d["width"], d["height"]
            row["pass"] = d["ztest"]["pass_fraction"]
            row["mean_specula"] = d["mean_a"]
            row["mean_mitsuba"] = d["mean_b"]
            row["rel_mse"] = d["rel_mse"]
            row["z_mean"] = image_mean_z(img, ref)
        except (RuntimeError, KeyError, ValueError) as e:
            lines = [l for l in str(e).splitlines() if l.strip()]
            row["error"] = NOT_IN_MITSUBA.get(name, lines[0] + (" ... " + lines[-1] if len(lines) > 1 else ""))
        rows.append(row)
        print(format_row(row), flush=True)
    table = markdown(rows)
    print()
    print(table)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(table + "\n")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0 if all(agrees(r) or r["scene"] in NOT_IN_MITSUBA for r in rows) else 1


def agrees(r):
    return "pass" in r and r["pass"] >= PASS_BAR and max(abs(z) for z in r["z_mean"]) <= Z_MEAN_BOUND


def fmt3(v):
    return "(%.4g, %.4g, %.4g)" % tuple(v)


def format_row(r):
    if "error" in r:
        return "%-24s ERROR %s" % (r["scene"], r["error"])
    return "%-24s %3dx%-3d spp %5d  pass %7.3f%%  specula %s  mitsuba %s  relMSE %.3g  z_mean %s%s" % (
        r["scene"], r["width"], r["height"], r["spp_specula"], 100 * r["pass"], fmt3(r["mean_specula"]),
        fmt3(r["mean_mitsuba"]), r["rel_mse"], fmtz(r["z_mean"]), "" if agrees(r) else "  BELOW")


def fmtz(z):
    return "(%.2f, %.2f, %.2f)" % tuple(z)


def markdown(rows):
    lines = ["| scene | res | spp (Mitsuba / specula) | pixels passing | mean specula | mean Mitsuba | relMSE "
             "| z of the image means |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "error" in r:
            lines.append("| %s | | | not compared: %s | | | | |" % (r["scene"], r["error"]))
            continue
        mark = "" if r["pass"] >= PASS_BAR else " **below**"
        zmark = "" if max(abs(z) for z in r["z_mean"]) <= Z_MEAN_BOUND else " **differ**"
        lines.append("| %s | %dx%d | %d (%d passes) / %d | %.2f%%%s | %s | %s | %.3g | %s%s |" % (
            r["scene"], r["width"], r["height"], r["spp_mitsuba"], r["passes"], r["spp_specula"], 100 * r["pass"], mark,
            fmt3(r["mean_specula"]), fmt3(r["mean_mitsuba"]), r["rel_mse"], fmtz(r["z_mean"]), zmark))
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
