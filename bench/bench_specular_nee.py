#!/usr/bin/env python3
"""bench/bench_specular_nee.py: specular next-event estimation at equal CPU time.

For each caustic scene (and, where the scene's light is large, a smaller light of the same power),
`specula render` with `--specular-nee none` (plain path tracing), `angular`, `newton` and, on the
scenes with one specular interface, `conic`; each image's relMSE against a converged reference
(`specula diff --json`), scaled to equal CPU time. For context, `bdpt` (no specular NEE) too.

Equal CPU time. The machine is shared, so wall time says little: each render's CPU time (user +
system of the child process, from os.wait4) is measured, minus the CPU time of the same command at
1x1 pixel and 1 spp (loading, acceleration structures). For an unbiased estimator relMSE x CPU-s is
constant, so relMSE at T CPU-s = relMSE x cpu / T. Each estimator's spp is chosen from a short
calibration render so that every render gets about the same CPU budget (the scaling is then small,
and a heavy-tailed estimator such as path tracing on a caustic is measured over as many samples as
it would get at equal time, not fewer).

The reference. Rendered once per scene variant (cached in --out; kept between runs) by `path` with
the scene's most efficient specular NEE solver (a long render; unbiased up to the solvers' capped
Bernoulli-trial counts), and
checked against an independent estimator (bdpt, or ipt) by the per-pixel z-test of `specula diff`.
The reference's own relMSE is estimated from its variance channels, E[(ref - mu)^2 / (ref^2 +
0.01)], and reported: the measured relMSE of an estimator is its true relMSE plus about this much.

usage (from the source root):
  bench/bench_specular_nee.py refs [--specula BUILD/specula] [--out DIR] [--only NAME,...]
  bench/bench_specular_nee.py run  [--specula BUILD/specula] [--out DIR] [--budget CPU_S] [--only ...]
Prints a Markdown table per run; JSON of every render next to the images in --out.
"""
import argparse
import json
import os
import struct
import subprocess
import sys
import time
import zlib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))

# Smaller lights keep the light's power: radiance scaled by (r / r_small)^2.
def small_light(r, r_small, rgb):
    s = (r / r_small) ** 2
    return {"light_radius": str(r_small), "light_radiance": ", ".join("%.6g" % (c * s) for c in rgb)}


# ":camera": specular NEE from the camera too (glints, the light seen through glass or in a mirror);
# ":camera=0.25" in a quarter of the camera samples (the pool's glints: a dozen randomized attempts
# per query for 1% of the variance).
# ":noexact": the glass ball's, the mirror ring's and the normal-mapped water's chains left to the
# randomized solver instead of enumerated exactly (spc_snee_params.exact, the default). ":nolong": without the glass ball's longer
# chains (internal reflections; spc_snee_params.long_p).
# ":guide,sneep=0.1": guided directions (spc_snee_params.guide) with the light sample one time in
# ten where a cone exists (snee_p); for the scenes whose light has one smooth image through the
# chain (the mesh pool, the slabs).
# conic runs where its chains exist (one vertex on a triangle mesh with interpolated normals): on the
# analytic mirror cylinder it would hand every chain to angular, and on caustic_pool's normal-mapped
# water (a chain vertex of angular and newton since the normal map is differentiated) too.
# name, scene, defines, solvers, reference solver, checks, description. A check is an integrator
# (bdpt, ipt) or a specular NEE solver of `path` other than the reference's; "+" joins several.
# Where the camera sees a diffuse surface through a specular one (the pools' floors through the
# water, the floor's caustic in the mirror ring's wall), the light comes by specular-diffuse-specular
# paths, which bdpt samples only by hitting the light: its variance estimate there is too low for
# the z-test, so those scenes are also checked against another solver.
VARIANTS = [
    ("glass_sphere", "caustic_glass_sphere", {},
     ["none", "angular", "angular:nolong", "angular:noexact", "angular:camera", "newton"],
     "angular:camera", "bdpt",
     "glass sphere on a floor, sphere light r 0.12 (2 refractions)"),
    ("glass_sphere_small", "caustic_glass_sphere", small_light(0.12, 0.04, (220, 200, 170)),
     ["none", "angular", "angular:nolong", "angular:camera"], "angular:camera", "bdpt",
     "the same, light r 0.04 (same power)"),
    ("mirror_ring", "caustic_mirror_ring", {}, ["none", "angular", "angular:noexact", "angular:camera", "newton"],
     "angular",
     "bdpt+newton",
     "mirror cylinder (analytic), sphere light r 0.1 (1 reflection)"),
    ("sdf_torus", "caustic_sdf_torus", {}, ["none", "angular", "angular:camera", "newton"], "angular:camera",
     "bdpt+none+angular",
     "glass SDF torus, sphere light r 0.08 (2 refractions)"),
    ("pool_normalmap", "caustic_pool", {}, ["none", "angular", "angular:camera", "angular:camera=0.25", "newton"],
     "angular:camera",
     "bdpt+none+angular",
     "water plane with a normal map over a tiled pool, sphere light r 0.15"),
    ("newton_pool", "newton_pool", {}, ["none", "angular", "angular:guide,sneep=0.1", "newton", "conic"],
     "angular:guide,sneep=0.1", "bdpt+conic+newton",
     "mesh water (interpolated normals), sphere light r 0.25 (1 refraction)"),
    ("newton_pool_small", "newton_pool", small_light(0.25, 0.08, (40, 38, 34)),
     ["none", "angular", "angular:guide,sneep=0.1", "newton", "conic"], "conic", "bdpt+newton",
     "the same, light r 0.08 (same power)"),
    ("slabs", "newton_slabs", {}, ["none", "angular", "angular:guide,sneep=0.1", "newton"], "angular", "bdpt",
     "two glass slabs, sphere light r 0.3 (4 refractions)"),
    ("slabs_small", "newton_slabs", small_light(0.3, 0.1, (30, 28, 24)),
     ["none", "angular", "angular:guide,sneep=0.1", "newton"],
     "angular", "bdpt", "the same, light r 0.1 (same power)"),
]


def read_exr(path):
    """Channels of a scanline EXR (FLOAT or HALF; NO or ZIP/ZIPS compression) as name -> HxW array."""
    with open(path, "rb") as f:
        buf = f.read()
    if struct.unpack_from("<I", buf, 0)[0] != 20000630:
        raise ValueError(path + ": not an EXR file")
    pos = 8
    attrs = {}
    while buf[pos] != 0:
        end = buf.index(b"\0", pos)
        name = buf[pos:end].decode()
        pos = end + 1
        end = buf.index(b"\0", pos)
        typ = buf[pos:end].decode()
        pos = end + 1
        size = struct.unpack_from("<i", buf, pos)[0]
        pos += 4
        attrs[name] = (typ, buf[pos:pos + size])
        pos += size
    pos += 1
    chans = []
    raw = attrs["channels"][1]
    p = 0
    while raw[p] != 0:
        end = raw.index(b"\0", p)
        cname = raw[p:end].decode()
        ptype = struct.unpack_from("<i", raw, end + 1)[0]
        chans.append((cname, ptype))
        p = end + 1 + 16
    comp = attrs["compression"][1][0]
    xmin, ymin, xmax, ymax = struct.unpack("<iiii", attrs["dataWindow"][1])
    w, h = xmax - xmin + 1, ymax - ymin + 1
    lines = {0: 1, 1: 1, 2: 1, 3: 16}[comp]
    nchunks = (h + lines - 1) // lines
    offsets = struct.unpack_from("<%dQ" % nchunks, buf, pos)
    dtypes = {1: np.float16, 2: np.float32}
    out = {c: np.zeros((h, w), np.float64) for c, _ in chans}
    for off in offsets:
        y, size = struct.unpack_from("<ii", buf, off)
        data = buf[off + 8:off + 8 + size]
        y -= ymin
        n = min(lines, h - y)
        expect = sum(n * w * np.dtype(dtypes[t]).itemsize for _, t in chans)
        if comp in (2, 3) and size < expect:
            d = np.frombuffer(zlib.decompress(data), np.uint8).astype(np.int32)
            d = np.cumsum(np.concatenate(([d[0]], d[1:] - 128))) & 0xFF  # undo the predictor
            d = d.astype(np.uint8)
            half = (len(d) + 1) // 2
            t = np.empty(len(d), np.uint8)
            t[0::2] = d[:half]
            t[1::2] = d[half:]
            data = t.tobytes()
        p = 0
        for yy in range(n):
            for c, t in chans:
                dt = np.dtype(dtypes[t])
                out[c][y + yy] = np.frombuffer(data, dt, w, p)
                p += w * dt.itemsize
    return out


def rel_mse_noise(ref_exr):
    """The expected relMSE of the reference against its own mean, from its variance channels."""
    im = read_exr(ref_exr)
    acc = 0.0
    for c in "RGB":
        acc += np.mean(im["variance." + c] / (im[c] ** 2 + 0.01))
    return acc / 3.0


def run_cpu(cmd):
    """Runs cmd; returns (CPU seconds of the child, wall seconds). Raises on failure."""
    t0 = time.time()
    proc = subprocess.Popen(cmd, cwd=ROOT)
    _, status, ru = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError("failed (%d): %s" % (proc.returncode, " ".join(cmd)))
    return ru.ru_utime + ru.ru_stime, time.time() - t0


def render_cmd(a, scene, defines, integrator, solver, spp, seed, out, res=None, variance=False):
    res = res or "%dx%d" % (a.res, a.res)
    cmd = [a.specula, "render", os.path.join("scenes", scene + ".xml"), "--integrator", integrator,
           "--spp", str(spp), "--seed", str(seed), "--threads", str(a.threads), "--res", res,
           "--quiet", "-o", out]
    if integrator == "path":
        cmd += ["--specular-nee", solver]
    for k, v in defines.items():
        cmd += ["-D", "%s=%s" % (k, v)]
    if variance:
        cmd.append("--variance")
    return cmd


def diff(a, img, ref):
    r = subprocess.run([a.specula, "diff", img, ref, "--json"], cwd=ROOT, check=True,
                       capture_output=True, text=True)
    return json.loads(r.stdout)


def overhead(a, scene, defines, integrator, solver):
    """CPU seconds of the command at 1x1 pixel and 1 spp (loading, acceleration structures)."""
    out = os.path.join(a.out, "overhead.exr")
    cpu, _ = run_cpu(render_cmd(a, scene, defines, integrator, solver, 1, 99, out, res="1x1"))
    return cpu


def timed_render(a, scene, defines, integrator, solver, cpu_budget, seed, out, variance=False):
    """Calibrates spp to cpu_budget (CPU seconds of rendering), renders; returns a dict."""
    base = overhead(a, scene, defines, integrator, solver)
    probe = os.path.join(a.out, "probe.exr")
    pspp = a.probe_spp
    cpu, _ = run_cpu(render_cmd(a, scene, defines, integrator, solver, pspp, seed + 1000, probe))
    per_spp = max(cpu - base, 1e-3) / pspp
    spp = int(min(max(round(cpu_budget / per_spp), 4), a.max_spp))
    stats = out[:-4] + ".json"
    cmd = render_cmd(a, scene, defines, integrator, solver, spp, seed, out, variance=variance)
    cmd += ["--stats", stats]
    cpu, wall = run_cpu(cmd)
    return {"spp": spp, "cpu": cpu - base, "cpu_total": cpu, "overhead": base, "wall": wall,
            "cmd": " ".join(cmd)}


def ref_paths(a, name):
    d = a.ref_dir or a.out
    return os.path.join(d, name + "_ref.exr"), os.path.join(d, name + "_ref.meta.json")


def cmd_refs(a, variants):
    os.makedirs(a.out, exist_ok=True)
    for name, scene, defs, _, solver, checks, _ in variants:
        ref, meta = ref_paths(a, name)
        if os.path.exists(meta) and not a.force:
            with open(meta) as f:
                m = json.load(f)
            print("%s: reference cached (%s)" % (name, meta), flush=True)
        else:
            r = timed_render(a, scene, defs, "path", solver, a.ref_budget, 1, ref, variance=True)
            m = {"name": name, "ref": r, "ref_solver": solver, "ref_rel_mse_noise": rel_mse_noise(ref),
                 "checks": [], "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                 "loadavg": open("/proc/loadavg").read().split()[:3]}
            print("%s: reference path %s, %d spp, %.0f CPU-s, own relMSE %.3g" % (
                name, solver, r["spp"], r["cpu"], m["ref_rel_mse_noise"]), flush=True)
        for i, chk in enumerate(checks.split("+")):
            if any(c["check"] == chk for c in m["checks"]):
                continue
            integ, s = (chk, "none") if chk in ("bdpt", "ipt") else ("path", chk)
            out = os.path.join(a.out, "%s_check_%s.exr" % (name, chk))
            c = timed_render(a, scene, defs, integ, s, a.check_budget, 2 + i, out, variance=True)
            d = diff(a, out, ref)
            c.update({"check": chk, "diff": d, "own_rel_mse": rel_mse_noise(out)})
            m["checks"].append(c)
            print("  check %s: %d spp, %.0f CPU-s, relMSE vs reference %.4g (own %.3g), z-test %s" % (
                chk, c["spp"], c["cpu"], d["rel_mse"], c["own_rel_mse"], json.dumps(d.get("ztest"))),
                flush=True)
        with open(meta, "w") as f:
            json.dump(m, f, indent=1)


def fmt(x):
    return "%.3g" % x


def cmd_run(a, variants):
    os.makedirs(a.out, exist_ok=True)
    load0 = open("/proc/loadavg").read().split()[:3]
    t0 = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    rows, summary = [], []
    results = {}
    prev = None
    if a.reuse:
        with open(a.reuse) as f:
            prev = json.load(f)
    for name, scene, defs, solvers, _, _, desc in variants:
        ref, meta = ref_paths(a, name)
        with open(meta) as f:
            m = json.load(f)
        res = {}
        for s in solvers + (["bdpt"] if a.bdpt else []):
            img = os.path.join(a.out, "%s_%s_run.exr" % (name, s))
            integ, sol = ("bdpt", "none") if s == "bdpt" else ("path", s)
            if prev:  # the images and CPU times of an earlier run, against these references
                r = prev[name]["solvers"][s]
            else:
                r = timed_render(a, scene, defs, integ, sol, a.budget, 3 + a.seed, img)
            r["rel_mse"] = diff(a, img, ref)["rel_mse"]
            r["at_T"] = r["rel_mse"] * r["cpu"] / a.budget
            res[s] = r
            print("  %s %s: %d spp, %.1f CPU-s, relMSE %.4g" % (name, s, r["spp"], r["cpu"], r["rel_mse"]),
                  file=sys.stderr, flush=True)
        results[name] = {"solvers": res, "ref": m}
        for s in res:
            r = res[s]
            ratio = res["none"]["at_T"] / r["at_T"]
            rows.append("| %s | %s | %d | %.1f | %s | %s | %s |" % (
                name, s, r["spp"], r["cpu"], fmt(r["rel_mse"]), fmt(r["at_T"]),
                "" if s == "none" else "%.2f" % ratio))
        best = min(res, key=lambda s: res[s]["at_T"])
        checks = "; ".join("%s %d spp: %.3g / %s" % (
            c["check"], c["spp"], c["diff"]["rel_mse"],
            "%.4f" % c["diff"]["ztest"]["pass_fraction"] if c["diff"].get("ztest") else "-")
            for c in m["checks"])
        summary.append("| %s | %s | %s %d spp, %.0f CPU-s | %s (%.1f%% of the lowest measured) | %s |" % (
            name, desc, m["ref_solver"], m["ref"]["spp"], m["ref"]["cpu"], fmt(m["ref_rel_mse_noise"]),
            100.0 * m["ref_rel_mse_noise"] / res[best]["rel_mse"], checks))
    load1 = open("/proc/loadavg").read().split()[:3]
    with open(os.path.join(a.out, "run%d%s.json" % (a.seed, "_rescored" if prev else "")), "w") as f:
        json.dump(results, f, indent=1)
    print("date %s to %s, %d cores, load average %s at the start, %s at the end; budget %.0f CPU-s "
          "per render, %d threads, %dx%d px" % (t0, time.strftime("%H:%M UTC", time.gmtime()),
                                               os.cpu_count(), " ".join(load0), " ".join(load1),
                                               a.budget, a.threads, a.res, a.res))
    print()
    print("| variant | specular NEE | spp | CPU s | relMSE | relMSE at %.0f CPU-s | path / this at equal CPU time |"
          % a.budget)
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(r)
    print()
    print("| variant | scene | reference (path +) | reference's own relMSE | checks: relMSE vs reference / z-test pass fraction |")
    print("|---|---|---|---|---|")
    for r in summary:
        print(r)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mode", choices=["refs", "run"])
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--out", default="/tmp/specula_bench_snee")
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--budget", type=float, default=10.0, help="CPU seconds per measured render")
    ap.add_argument("--ref-budget", type=float, default=150.0, help="CPU seconds per reference")
    ap.add_argument("--check-budget", type=float, default=60.0, help="CPU seconds per check render")
    ap.add_argument("--probe-spp", type=int, default=4)
    ap.add_argument("--max-spp", type=int, default=1 << 16)
    ap.add_argument("--no-bdpt", dest="bdpt", action="store_false",
                    help="skip the bdpt row (context: the other way to sample caustics)")
    ap.add_argument("--seed", type=int, default=0, help="added to the measured renders' seeds")
    ap.add_argument("--ref-dir", default="", help="references from this directory (default --out)")
    ap.add_argument("--reuse", default="", help="run: re-score the images of the run whose JSON this is "
                    "(in --out) against the references instead of rendering")
    ap.add_argument("--only", default="", help="comma-separated variant names")
    ap.add_argument("--ref-solver", default="", help="refs: render the references with this specular NEE "
                    "setting instead of the variants' (e.g. 'angular:camera')")
    ap.add_argument("--solvers", default="", help="run: these specular NEE settings instead of the variants' "
                    "(';'-separated, e.g. 'none;angular:reflect,mispsi=0.1'; 'none' is always measured)")
    ap.add_argument("--force", action="store_true", help="re-render cached references")
    a = ap.parse_args()
    a.specula = os.path.abspath(a.specula)
    a.out = os.path.abspath(a.out)
    a.ref_dir = os.path.abspath(a.ref_dir) if a.ref_dir else ""
    only = set(filter(None, a.only.split(",")))
    variants = [v for v in VARIANTS if not only or v[0] in only]
    if a.ref_solver:
        variants = [v[:4] + (a.ref_solver,) + tuple(v[5:]) for v in variants]
    if a.solvers:
        sol = ["none"] + [x for x in a.solvers.split(";") if x and x != "none"]
        variants = [(v[0], v[1], v[2], sol) + tuple(v[4:]) for v in variants]
    if a.mode == "refs":
        cmd_refs(a, variants)
    else:
        cmd_run(a, variants)


if __name__ == "__main__":
    main()
