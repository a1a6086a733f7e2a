#!/usr/bin/env python3
"""Load every scene of the Mitsuba 3 scene collection (mitsuba-renderer/mitsuba-data) in Mitsuba 3
and in specula, render both small and compare.

    python3 tests/validation/mitsuba_data.py DATA_DIR [--work DIR] [--res 32] [--spp 256]
            [--passes 8] [--timeout 300] [--only SUBSTRING] [--json FILE] [--markdown FILE]

DATA_DIR is a checkout of mitsuba-data (its docs/scenes, tests/scenes and scenes folders are
searched). A scene file is an .xml whose root is <scene> and that does not live in a folder of
pieces (include, fragments, common, meshes); 0.x files are skipped (Mitsuba 3 does not load them).

The collection's films are large, and some are declared in included files, so the script first
writes a small copy of the collection into --work: every .xml with each <film>'s width and height
rewritten to RES pixels on the longer side (its aspect ratio kept; crop windows dropped) and a
<default name="res"> set to RES; every other file linked. Both renderers then read the same files.

For each scene:
  1. Mitsuba 3 (scalar_rgb) loads it (with -D spp when the scene needs a value) and renders
     `passes` independent images of spp/passes samples: the mean and the variance of the mean
     (R, G, B and variance.R/G/B) go to an EXR, as tests/validation/mitsuba_ref.py writes them;
  2. specula renders it at the same spp with --variance;
  3. `specula diff --json`: image means, the per-pixel z-test (alpha 0.01, Sidak over the pixels;
     Mitsuba's bar is 99.75% of pixels) and z_mean, the difference of the image means over its
     standard error (|z_mean| > 2.94: alpha 0.01 over three channels).
The table lists for each scene: loads in Mitsuba, loads in specula (or the first line of the
error), the mean of each renderer (average of the channels), their ratio, the z-test pass rate
and the largest |z_mean|. A scene "agrees" when the means are within 5%.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
PIECE_DIRS = {"include", "includes", "fragments", "common", "meshes", "textures", "refs"}
Z_MEAN_BOUND = 2.94

# Known differences that are Mitsuba's and not specula's (shown in the table's note column).
NOTES = {
    "scenes/hello.xml": "Mitsuba's direct integrator counts each of emitter_samples delta-light "
                        "samples with weight 1 (4x here); specula weighs them 1/emitter_samples",
    "docs/scenes/integrator_direct_lum.xml": "Mitsuba's direct with bsdf_samples 0 misses light reflected by "
                                             "smooth surfaces; specula's direct estimator includes it",
    "docs/scenes/bsdf_blendbsdf.xml": "open: a blend of rough plastic and smooth gold by a texture; each part "
                                      "alone agrees",
}


def find_scenes(data):
    out = []
    for top in ("docs/scenes", "tests/scenes", "scenes"):
        base = os.path.join(data, top)
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames[:] = sorted(d for d in dirnames if d not in PIECE_DIRS)
            for f in sorted(filenames):
                if not f.endswith(".xml"):
                    continue
                p = os.path.join(dirpath, f)
                try:
                    head = open(p, encoding="utf-8", errors="replace").read(4000)
                except OSError:
                    continue
                m = re.search(r"<scene\s+version\s*=\s*['\"](\d+)", head)
                if not m:
                    continue
                if m.group(1) == "0":
                    continue
                out.append(os.path.relpath(p, data))
    return out


FILM_RE = re.compile(r"(<film\b[^>]*>)(.*?)(</film>)", re.S)


def shrink_film(body, res):
    def get(name, default):
        m = re.search(r"<integer\s+name\s*=\s*['\"]%s['\"]\s+value\s*=\s*['\"](\d+)['\"]" % name, body)
        return int(m.group(1)) if m else default

    w, h = get("width", 768), get("height", 576)
    if w >= h:
        nw, nh = res, max(1, round(res * h / w))
    else:
        nw, nh = max(1, round(res * w / h)), res
    body = re.sub(r"<integer\s+name\s*=\s*['\"]crop_[a-z_]+['\"][^>]*/>", "", body)
    for name, v in (("width", nw), ("height", nh)):
        pat = r"(<integer\s+name\s*=\s*['\"]%s['\"]\s+value\s*=\s*['\"])[^'\"]*(['\"])" % name
        if re.search(pat, body):
            body = re.sub(pat, r"\g<1>%d\g<2>" % v, body)
        else:
            body = '<integer name="%s" value="%d"/>' % (name, v) + body
    return body


def shrink_xml(text, res):
    text = FILM_RE.sub(lambda m: m.group(1) + shrink_film(m.group(2), res) + m.group(3), text)
    # a film written as <film .../> with no children: give it the size
    text = re.sub(r"<film\b([^>]*)/>",
                  lambda m: '<film%s><integer name="width" value="%d"/><integer name="height" value="%d"/></film>'
                  % (m.group(1), res, max(1, round(res * 576 / 768))), text)
    text = re.sub(r"(<default\s+name\s*=\s*['\"]res['\"]\s+value\s*=\s*['\"])\d+", r"\g<1>%d" % res, text)
    return text


def make_small_copy(data, work, res):
    dst_root = os.path.join(work, "data")
    for dirpath, dirnames, filenames in os.walk(data):
        dirnames[:] = [d for d in dirnames if d != ".git"]
        rel = os.path.relpath(dirpath, data)
        os.makedirs(os.path.join(dst_root, rel), exist_ok=True)
        for f in filenames:
            src = os.path.join(dirpath, f)
            dst = os.path.join(dst_root, rel, f)
            if os.path.lexists(dst):
                os.remove(dst)
            if f.endswith(".xml"):
                text = open(src, encoding="utf-8", errors="replace").read()
                with open(dst, "w", encoding="utf-8") as fh:
                    fh.write(shrink_xml(text, res))
            else:
                os.symlink(os.path.abspath(src), dst)
    return dst_root


MITSUBA_JOB = r'''
import sys, numpy as np
import mitsuba as mi
mi.set_variant("scalar_rgb")
scene_path, out, spp, passes = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
err = None
for defs in ({}, {"spp": str(spp)}, {"res": sys.argv[5], "spp": str(spp)}, {"res": sys.argv[5]}):
    try:
        scene = mi.load_file(scene_path, **defs)
        break
    except Exception as e:
        err = err or e  # the error without parameters is the telling one
else:
    print("LOADFAIL " + " ".join(str(err).split())[:300])
    sys.exit(3)
print("DEFS " + " ".join("%s=%s" % kv for kv in defs.items()))
per = max(1, spp // passes)
imgs = []
for i in range(passes):
    img = np.array(mi.render(scene, seed=1000 + i, spp=per), dtype=np.float64)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.shape[2] == 1:
        img = np.repeat(img, 3, axis=2)
    imgs.append(img[:, :, :3])
st = np.stack(imgs)
mean = st.mean(axis=0)
var = st.var(axis=0, ddof=1) / passes
bmp = mi.Bitmap(np.concatenate([mean, var], axis=2).astype(np.float32),
                channel_names=["R", "G", "B", "variance.R", "variance.G", "variance.B"])
bmp.write(out)
print("OK")
'''


def run(cmd, timeout, env=None):
    t0 = time.time()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
        return p.returncode, p.stdout, p.stderr, time.time() - t0
    except subprocess.TimeoutExpired:
        return 124, "", "timed out after %d s" % timeout, time.time() - t0


def first_error(text):
    for line in text.splitlines():
        if "error" in line.lower() and "warning" not in line.lower():
            return line.strip()[:200]
    lines = [l for l in text.splitlines() if l.strip()]
    return lines[-1].strip()[:200] if lines else ""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("--work", default="/tmp/specula_mitsuba_data")
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--passes", type=int, default=8)
    ap.add_argument("--timeout", type=int, default=300)
    ap.add_argument("--only", default="")
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--json", default="")
    ap.add_argument("--markdown", default="")
    ap.add_argument("--resume", action="store_true", help="keep the rows already in --json")
    ap.add_argument("--mitsuba-from", default="",
                    help="an earlier run's --json whose --work holds its Mitsuba images (NAME_mitsuba.exr, same "
                         "--res/--spp/--passes, copied into this --work): Mitsuba is not run again; specula takes "
                         "the first of the Mitsuba job's define sets that it loads with")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    small = make_small_copy(os.path.abspath(a.data), a.work, a.res)
    scenes = [s for s in find_scenes(a.data) if a.only in s]
    rows = []
    cached = {}
    if a.mitsuba_from:
        cached = {r["scene"]: r for r in json.load(open(a.mitsuba_from))["rows"]}
    done = {}
    if a.resume and a.json and os.path.exists(a.json):
        done = {r["scene"]: r for r in json.load(open(a.json))["rows"]}
    for rel in scenes:
        if rel in done:
            rows.append(done[rel])
            continue
        path = os.path.join(small, rel)
        tag = re.sub(r"[^A-Za-z0-9]+", "_", rel)
        ref = os.path.join(a.work, tag + "_mitsuba.exr")
        img = os.path.join(a.work, tag + "_specula.exr")
        r = {"scene": rel, "note": NOTES.get(rel, "")}
        defs = []
        c = cached.get(rel)
        if c is not None and (not c.get("mitsuba_loads") or os.path.exists(ref)):
            for k in ("mitsuba_s", "mitsuba_loads", "mitsuba_error"):
                if k in c:
                    r[k] = c[k]
            r["mitsuba_cached"] = True
            if c.get("mitsuba_loads"):
                # the Mitsuba job's define sets, in its order: the first specula loads with
                for dset in ([], ["spp=%d" % a.spp], ["res=%d" % a.res, "spp=%d" % a.spp], ["res=%d" % a.res]):
                    cmd = [a.specula, "info", path]
                    for d in dset:
                        cmd += ["-D", d]
                    if run(cmd, a.timeout)[0] == 0:
                        defs = dset
                        break
        else:
            rc, out, err, dt = run([sys.executable, "-c", MITSUBA_JOB, path, ref, str(a.spp), str(a.passes),
                                    str(a.res)], a.timeout)
            r["mitsuba_s"] = round(dt, 1)
            r["mitsuba_loads"] = rc == 0 and "OK" in out
            for line in out.splitlines():
                if line.startswith("LOADFAIL"):
                    r["mitsuba_error"] = line[9:]
                if line.startswith("DEFS"):
                    defs = line[5:].split()
            if rc != 0 and "mitsuba_error" not in r:
                r["mitsuba_error"] = first_error(err) or "exit %d" % rc
                # loaded but failed to render: still counts as not rendered by Mitsuba
        cmd = [a.specula, "render", path, "-o", img, "--spp", str(a.spp), "--variance", "--quiet", "--seed", "1"]
        for d in defs:
            if not d.startswith("spp="):
                cmd += ["-D", d]
        if any(d.startswith("spp=") for d in defs):
            cmd += ["-D", "spp=%d" % a.spp]
        rc, out, err, dt = run(cmd, a.timeout)
        r["specula_s"] = round(dt, 1)
        r["specula_loads"] = rc == 0
        if rc != 0:
            r["specula_error"] = first_error(err) or "exit %d" % rc
        if r["mitsuba_loads"] and r["specula_loads"]:
            rc, out, err, _ = run([a.specula, "diff", img, ref, "--json"], 120)
            try:
                d = json.loads(out)
                ma, mb = d["mean_a"], d["mean_b"]
                r["specula_mean"] = sum(ma) / 3
                r["mitsuba_mean"] = sum(mb) / 3
                r["ratio"] = r["specula_mean"] / r["mitsuba_mean"] if r["mitsuba_mean"] > 0 else None
                if "ztest" in d:
                    r["ztest_pass"] = d["ztest"]["pass_fraction"]
                r["z_mean"] = image_mean_z(img, ref)
            except (ValueError, KeyError) as e:
                r["diff_error"] = "%s %s" % (e, err.strip()[:200])
        rows.append(r)
        print(format_row(r), flush=True)
        if a.json:  # as it goes, for --resume
            with open(a.json, "w") as fh:
                json.dump({"res": a.res, "spp": a.spp, "passes": a.passes, "rows": rows}, fh, indent=1)
    summary = summarize(rows)
    print(summary)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump({"res": a.res, "spp": a.spp, "passes": a.passes, "rows": rows}, fh, indent=1)
    if a.markdown:
        with open(a.markdown, "w") as fh:
            fh.write(markdown(rows, a, summary))


def image_mean_z(a_path, b_path):
    """Largest |(mean_a - mean_b) / standard error| over the channels (pixels independent)."""
    try:
        import mitsuba as mi
        import numpy as np
        mi.set_variant("scalar_rgb")
    except ImportError:
        return None
    ims = []
    for p in (a_path, b_path):
        arr = np.array(mi.Bitmap(p), dtype=np.float64)
        ims.append(arr)
    a, b = ims
    n = a.shape[0] * a.shape[1]
    z = 0.0
    for c in range(3):
        se = (a[:, :, 3 + c].sum() + b[:, :, 3 + c].sum()) ** 0.5 / n
        d = a[:, :, c].mean() - b[:, :, c].mean()
        if se > 0:
            z = max(z, abs(d) / se)
        elif abs(d) > 1e-12:
            z = float("inf")
    return z


def agrees(r):
    ratio = r.get("ratio")
    return ratio is not None and abs(ratio - 1.0) <= 0.05


def format_row(r):
    m = "yes" if r["mitsuba_loads"] else "no"
    s = "yes" if r["specula_loads"] else "no: " + r.get("specula_error", "")
    if "ratio" in r and r["ratio"] is not None:
        zt = "%.2f%%" % (100 * r["ztest_pass"]) if "ztest_pass" in r else "-"
        zm = "%.1f" % r["z_mean"] if r.get("z_mean") is not None else "-"
        return "%-62s M %-3s S %-3s  %.4g / %.4g = %.3f  z %s  zmean %s  (%.0f s, %.0f s)" % (
            r["scene"], m, "yes", r["specula_mean"], r["mitsuba_mean"], r["ratio"], zt, zm, r["mitsuba_s"],
            r["specula_s"])
    return "%-62s M %-3s S %s" % (r["scene"], m + ("" if r["mitsuba_loads"] else " (" + r.get("mitsuba_error", "")[:80] + ")"), s)


def summarize(rows):
    mi_ok = [r for r in rows if r["mitsuba_loads"]]
    both = [r for r in mi_ok if r["specula_loads"]]
    agree = [r for r in both if agrees(r)]
    return ("%d scene files; Mitsuba 3 renders %d; specula renders %d of those (%.0f%%); %d of those agree "
            "within 5%% in image mean (%.0f%%)" % (len(rows), len(mi_ok), len(both),
                                                  100.0 * len(both) / max(1, len(mi_ok)), len(agree),
                                                  100.0 * len(agree) / max(1, len(both))))


def markdown(rows, a, summary):
    out = ["%s (%dpx on the longer side, %d spp, Mitsuba 3 scalar_rgb in %d passes).\n" % (
        summary, a.res, a.spp, a.passes), "",
        "| scene | Mitsuba | specula | mean specula / Mitsuba | ratio | z-test | max \\|z_mean\\| | note |",
        "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        m = "yes" if r["mitsuba_loads"] else "no (%s)" % r.get("mitsuba_error", "")[:90].replace("|", "/")
        s = "yes" if r["specula_loads"] else "no (%s)" % r.get("specula_error", "")[:110].replace("|", "/")
        means = ratio = zt = zm = ""
        if r.get("ratio") is not None:
            means = "%.4g / %.4g" % (r["specula_mean"], r["mitsuba_mean"])
            ratio = "%.3f" % r["ratio"]
            zt = "%.2f%%" % (100 * r["ztest_pass"]) if "ztest_pass" in r else ""
            zm = "%.1f" % r["z_mean"] if r.get("z_mean") is not None else ""
        out.append("| %s | %s | %s | %s | %s | %s | %s | %s |" % (r["scene"], m, s, means, ratio, zt, zm, r["note"]))
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    sys.exit(main())
