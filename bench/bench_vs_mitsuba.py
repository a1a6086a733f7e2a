#!/usr/bin/env python3
"""Time of specula against Mitsuba 3 at equal samples per pixel, same threads each.

    python3 bench/bench_vs_mitsuba.py [--specula build/specula] [--spp 64] [--scale S] [--threads 2]
                                      [--variant llvm_ad_rgb] [--scalar] [--repeats 3] [--base OTHER_SPECULA]
                                      [SCENE.xml[:SCALE] ...]

Default scenes: ../shared/scenes/cornell-box at 0.25 of its resolution (256x256) and veach-mis at
its own (1280x720), rendered with the path tracer (-D integrator=path) and the scenes' max_depth;
--scale S sets every scene's scale, SCENE.xml:S one scene's. Both renderers get the same thread
count: specula --threads N; Mitsuba through drjit's thread pool (dr.set_thread_count(N)).
The variant defaults to llvm_ad_rgb, with DRJIT_LIBLLVM_PATH set to Debian 12's libLLVM 19 unless
the environment sets it (Debian's LLVM 14 is too old for drjit, 15 and 16 fail to compile its
kernels on AVX-512 hosts); it falls back to scalar_rgb when it cannot render here. --scalar also
times scalar_rgb in the same run (a third column). The times are of the render alone (scene
loading excluded): specula's --stats wall_seconds, and for Mitsuba the mi.render() call after one
untimed warm-up render (which, for the llvm variants, compiles the kernel; its time is reported
separately). The renders alternate (specula, Mitsuba, specula, ...) `repeats` times and the table
gives the medians and their ratio, so that load from other processes hits both alike; the 1-minute
load average is printed before and after. --base OTHER_SPECULA renders a second specula binary in
the same loop (the two take turns going first), so that a change is measured before and after
against the same Mitsuba renders.

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


LLVM_DEFAULT = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
# The sizes: the cornell box at a quarter of its 1024x1024, veach-mis at its 1280x720.
DEFAULT_SCENES = (("cornell-box", 0.25), ("veach-mis", 1.0))


def mitsuba_time(mi, dr, scene, spp, seed):
    """Wall and CPU seconds of one mi.render() in this process."""
    c0 = cpu_seconds(resource.RUSAGE_SELF)
    t0 = time.time()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.time() - t0, cpu_seconds(resource.RUSAGE_SELF) - c0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--scale", type=float, default=None)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--scalar", action="store_true", help="also time scalar_rgb in the same run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--base", default=None, help="a second specula binary timed in the same loop (before/after)")
    a = ap.parse_args()
    scenes = []
    for arg in a.scenes:
        path, _, sc = arg.rpartition(":") if re.search(r":[0-9.]+$", arg) else (arg, "", "")
        scenes.append((path, float(sc) if sc else (a.scale or 1.0)))
    if not scenes:
        shared = os.path.join(ROOT, "..", "shared", "scenes")
        if not os.path.isdir(shared):
            shared = "/work/shared/scenes"
        scenes = [(os.path.join(shared, n, "scene.xml"), a.scale or sc) for n, sc in DEFAULT_SCENES]
    if "llvm" in a.variant and "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LLVM_DEFAULT):
        os.environ["DRJIT_LIBLLVM_PATH"] = LLVM_DEFAULT

    # A variant that loads can still abort inside its JIT (llvm_ad_rgb does with Debian's LLVM 15
    # and 16: "LLVM ERROR: Cannot select ... fminimum"): try a tiny render in a child process.
    probe = ("import mitsuba as mi; mi.set_variant('%s'); "
             "mi.render(mi.load_dict(mi.cornell_box()), spp=1)" % a.variant)
    if subprocess.run([sys.executable, "-c", probe], capture_output=True).returncode != 0:
        print("variant %s does not render here: using scalar_rgb" % a.variant)
        a.variant = "scalar_rgb"
    scalar = a.scalar and a.variant != "scalar_rgb"

    import drjit as dr
    import mitsuba as mi

    dr.set_thread_count(a.threads)
    print("load average before: %.2f" % os.getloadavg()[0])
    rows = []
    for path, scale in scenes:
        name = os.path.basename(os.path.dirname(path)) if path.endswith("scene.xml") else os.path.basename(path)
        d = defaults_of(path)
        defs = {"integrator": "path"}
        if "resx" in d:
            defs["resx"] = str(int(int(d["resx"]) * scale))
            defs["resy"] = str(int(int(d["resy"]) * scale))
        elif "res" in d:
            defs["res"] = str(int(int(d["res"]) * scale))
        dflags = sum((["-D", "%s=%s" % kv] for kv in defs.items()), [])
        mi.set_variant(a.variant)
        scene = mi.load_file(path, **defs)
        t0 = time.time()
        mi.render(scene, spp=a.spp, seed=0)
        warm = time.time() - t0
        scene_scalar = None
        if scalar:
            mi.set_variant("scalar_rgb")
            scene_scalar = mi.load_file(path, **defs)
        ts, tm, cs, cm, tss, css, tb, cb = [], [], [], [], [], [], [], []
        with tempfile.TemporaryDirectory() as tmp:
            for r in range(a.repeats):
                stats = os.path.join(tmp, "stats.json")
                # with --base, the two specula binaries take turns going first
                order = [(a.specula, ts, cs)] if not a.base else \
                    [(a.specula, ts, cs), (a.base, tb, cb)][::1 if r % 2 == 0 else -1]
                for binary, tl, cl in order:
                    c0 = cpu_seconds(resource.RUSAGE_CHILDREN)
                    subprocess.run([binary, "render", path, "-o", os.path.join(tmp, "out.exr"), "--spp", str(a.spp),
                                    "--threads", str(a.threads), "--quiet", "--stats", stats, "--seed", str(r)] + dflags,
                                   check=True)
                    cl.append(cpu_seconds(resource.RUSAGE_CHILDREN) - c0)
                    tl.append(json.load(open(stats))["wall_seconds"])
                mi.set_variant(a.variant)
                w, c = mitsuba_time(mi, dr, scene, a.spp, r + 1)
                tm.append(w)
                cm.append(c)
                if scalar:
                    mi.set_variant("scalar_rgb")
                    w, c = mitsuba_time(mi, dr, scene_scalar, a.spp, r + 1)
                    tss.append(w)
                    css.append(c)
        res = "%sx%s" % (defs.get("resx", defs.get("res")), defs.get("resy", defs.get("res")))
        row = {"scene": name, "res": res, "spp": a.spp, "specula_s": statistics.median(ts),
               "mitsuba_s": statistics.median(tm), "mitsuba_first_s": warm, "variant": a.variant,
               "specula_cpu": statistics.median(cs), "mitsuba_cpu": statistics.median(cm)}
        row["ratio"] = row["specula_s"] / row["mitsuba_s"]
        row["cpu_ratio"] = row["specula_cpu"] / row["mitsuba_cpu"]
        if scalar:
            row["scalar_s"] = statistics.median(tss)
            row["scalar_cpu"] = statistics.median(css)
        if a.base:
            row["base_cpu"] = statistics.median(cb)
        rows.append(row)
        print("%-12s %-9s spp %d  wall: specula %.2f s  Mitsuba (%s) %.2f s (first render %.2f s)  ratio %.2f;"
              "  CPU: specula %.2f s  Mitsuba %.2f s  ratio %.2f" % (name, res, a.spp, row["specula_s"], a.variant,
                                                                     row["mitsuba_s"], warm, row["ratio"], row["specula_cpu"],
                                                                     row["mitsuba_cpu"], row["cpu_ratio"]), flush=True)
        print("  wall specula %s  Mitsuba %s" % (["%.2f" % t for t in ts], ["%.2f" % t for t in tm]))
        print("  CPU  specula %s  Mitsuba %s" % (["%.2f" % t for t in cs], ["%.2f" % t for t in cm]), flush=True)
        if scalar:
            print("  scalar_rgb wall %s  CPU %s" % (["%.2f" % t for t in tss], ["%.2f" % t for t in css]), flush=True)
        if a.base:
            print("  base specula wall %s  CPU %s" % (["%.2f" % t for t in tb], ["%.2f" % t for t in cb]), flush=True)
    print("load average after: %.2f" % os.getloadavg()[0])
    print()
    print("%d thread(s) each, medians of %d" % (a.threads, a.repeats))
    head = ("| scene | resolution | spp | wall specula (s) | wall Mitsuba %s (s) | wall specula / Mitsuba "
            "| CPU specula (s) | CPU Mitsuba (s) | CPU specula / Mitsuba |" % a.variant)
    sep = "|---|---|---|---|---|---|---|---|---|"
    if scalar:
        head += " wall scalar_rgb (s) | CPU scalar_rgb (s) | CPU specula / scalar_rgb |"
        sep += "---|---|---|"
    if a.base:
        head += " CPU base specula (s) | CPU base / Mitsuba |"
        sep += "---|---|"
    print(head + " Mitsuba first render (s) |")
    print(sep + "---|")
    for r in rows:
        line = "| %s | %s | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |" % (
            r["scene"], r["res"], r["spp"], r["specula_s"], r["mitsuba_s"], r["ratio"], r["specula_cpu"],
            r["mitsuba_cpu"], r["cpu_ratio"])
        if scalar:
            line += " %.2f | %.2f | %.2f |" % (r["scalar_s"], r["scalar_cpu"], r["specula_cpu"] / r["scalar_cpu"])
        if a.base:
            line += " %.2f | %.2f |" % (r["base_cpu"], r["base_cpu"] / r["mitsuba_cpu"])
        print(line + " %.2f |" % r["mitsuba_first_s"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
