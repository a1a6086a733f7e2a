#!/usr/bin/env python3
"""Wall time of specula against Mitsuba 3 at equal samples per pixel, 2 threads each.

    python3 bench/bench_vs_mitsuba.py [--specula build/specula] [--spp 64] [--scale 0.5]
                                      [--variant llvm_ad_rgb] [--repeats 3] [SCENE.xml ...]

Default scenes: ../shared/scenes/cornell-box and veach-mis, rendered at `scale` times their own
resolution with the path tracer (-D integrator=path) and the scenes' max_depth. Both renderers get
2 threads: specula --threads 2; Mitsuba through drjit's thread pool (dr.set_thread_count(2)).
The variant defaults to llvm_ad_rgb and falls back to scalar_rgb when it cannot render here. The
times are of the render alone (scene loading excluded): specula's --stats wall_seconds, and for
Mitsuba the mi.render() call after one untimed warm-up render (which, for the llvm variants,
compiles the kernel; its time is reported separately). The renders alternate (specula, Mitsuba,
specula, ...) `repeats` times and the table gives the medians and their ratio, so that load from
other processes hits both alike; the 1-minute load average is printed before and after.

CPU seconds (user + system, all threads) are measured next to wall time, because on a shared
machine wall time depends on what else runs: for specula getrusage(RUSAGE_CHILDREN) around the
child process (so it includes parsing the scene and building the BVH, a small share here: an upper
bound for the render alone), for Mitsuba getrusage(RUSAGE_SELF) around mi.render() in this process.
Both ratios specula / Mitsuba are reported, of the medians over the repeats.
"""
import argparse
import glob
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))


def defaults_of(path):
    text = open(path, encoding="utf-8").read()
    return dict(re.findall(r'<default\s+name="([a-zA-Z_]+)"\s+value="([^"]*)"', text))


def cpu_seconds(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--scale", type=float, default=0.5)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    scenes = a.scenes or sorted(glob.glob(os.path.join(ROOT, "..", "shared", "scenes", "*", "scene.xml")))

    # A variant that loads can still abort inside its JIT (llvm_ad_rgb does here, "LLVM ERROR:
    # Cannot select ... fminimum" with the system's LLVM): try a tiny render in a child process.
    probe = ("import mitsuba as mi; mi.set_variant('%s'); "
             "mi.render(mi.load_dict(mi.cornell_box()), spp=1)" % a.variant)
    if subprocess.run([sys.executable, "-c", probe], capture_output=True).returncode != 0:
        print("variant %s does not render here: using scalar_rgb" % a.variant)
        a.variant = "scalar_rgb"

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    dr.set_thread_count(2)
    print("load average before: %.2f" % os.getloadavg()[0])
    rows = []
    for path in scenes:
        name = os.path.basename(os.path.dirname(path)) if path.endswith("scene.xml") else os.path.basename(path)
        d = defaults_of(path)
        defs = {"integrator": "path"}
        if "resx" in d:
            defs["resx"] = str(int(int(d["resx"]) * a.scale))
            defs["resy"] = str(int(int(d["resy"]) * a.scale))
        elif "res" in d:
            defs["res"] = str(int(int(d["res"]) * a.scale))
        dflags = sum((["-D", "%s=%s" % kv] for kv in defs.items()), [])
        scene = mi.load_file(path, **defs)
        t0 = time.time()
        mi.render(scene, spp=a.spp, seed=0)
        warm = time.time() - t0
        ts, tm, cs, cm = [], [], [], []
        with tempfile.TemporaryDirectory() as tmp:
            for r in range(a.repeats):
                stats = os.path.join(tmp, "stats.json")
                c0 = cpu_seconds(resource.RUSAGE_CHILDREN)
                subprocess.run([a.specula, "render", path, "-o", os.path.join(tmp, "out.exr"), "--spp", str(a.spp),
                                "--threads", "2", "--quiet", "--stats", stats, "--seed", str(r)] + dflags, check=True)
                cs.append(cpu_seconds(resource.RUSAGE_CHILDREN) - c0)
                ts.append(json.load(open(stats))["wall_seconds"])
                c0 = cpu_seconds(resource.RUSAGE_SELF)
                t0 = time.time()
                img = mi.render(scene, spp=a.spp, seed=r + 1)
                dr.eval(img)
                dr.sync_thread()
                tm.append(time.time() - t0)
                cm.append(cpu_seconds(resource.RUSAGE_SELF) - c0)
        res = "%sx%s" % (defs.get("resx", defs.get("res")), defs.get("resy", defs.get("res")))
        row = {"scene": name, "res": res, "spp": a.spp, "specula_s": statistics.median(ts),
               "mitsuba_s": statistics.median(tm), "mitsuba_first_s": warm, "variant": a.variant,
               "specula_cpu": statistics.median(cs), "mitsuba_cpu": statistics.median(cm)}
        row["ratio"] = row["specula_s"] / row["mitsuba_s"]
        row["cpu_ratio"] = row["specula_cpu"] / row["mitsuba_cpu"]
        rows.append(row)
        print("%-12s %-9s spp %d  wall: specula %.2f s  Mitsuba (%s) %.2f s (first render %.2f s)  ratio %.2f;"
              "  CPU: specula %.2f s  Mitsuba %.2f s  ratio %.2f" % (name, res, a.spp, row["specula_s"], a.variant,
                                                                     row["mitsuba_s"], warm, row["ratio"], row["specula_cpu"],
                                                                     row["mitsuba_cpu"], row["cpu_ratio"]), flush=True)
        print("  wall specula %s  Mitsuba %s" % (["%.2f" % t for t in ts], ["%.2f" % t for t in tm]))
        print("  CPU  specula %s  Mitsuba %s" % (["%.2f" % t for t in cs], ["%.2f" % t for t in cm]), flush=True)
    print("load average after: %.2f" % os.getloadavg()[0])
    print()
    print("| scene | resolution | spp | wall specula (s) | wall Mitsuba %s (s) | wall specula / Mitsuba "
          "| CPU specula (s) | CPU Mitsuba (s) | CPU specula / Mitsuba | Mitsuba first render (s) |" % a.variant)
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %s | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |" % (
            r["scene"], r["res"], r["spp"], r["specula_s"], r["mitsuba_s"], r["ratio"], r["specula_cpu"],
            r["mitsuba_cpu"], r["cpu_ratio"], r["mitsuba_first_s"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
