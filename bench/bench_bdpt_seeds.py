#!/usr/bin/env python3
"""path against bdpt at equal CPU time over several seeds, with each seed's worst pixel.

    python3 bench/bench_bdpt_seeds.py [--specula build/specula] [--cpu 4] [--seeds 8] [--res 32]
                                      [--first-seed 1] [--threads 1] [--jobs 1] [--refs DIR] [--out DIR]
                                      [--arm INTEGRATOR[=SNEE] ...] [--mitsuba-spp 32768]
                                      [--mitsuba-variant V] [SCENE ...]

SCENE is one of the names below (default: all). An arm is an integrator and its specular NEE
setting: `--arm path=none` renders path with `--specular-nee none` (plain path tracing), `--arm
path` or `--arm path=plan` passes no `--specular-nee` (the scene's plan decides, as a user's
render without flags), `--arm bdpt=angular:camera` passes that setting to bdpt (bdpt runs specular
NEE as one of its strategies, so its setting matters too). The default arms are path=none,
path=plan and bdpt=plan. Without --arm, the older flags build them: --integrators (path,bdpt)
with --snee SPEC for every integrator, --path-snee / --bdpt-snee for one. Each arm's exact setting is
printed in the header and in its table row.

For each scene a Mitsuba 3 reference (path tracer, llvm_ad_rgb, `--mitsuba-spp` samples in 32
passes, tests/validation/mitsuba_ref.py) is rendered once into --refs (kept: delete it to render
again); `--mitsuba-variant scalar_rgb` where drjit's LLVM backend does not load (it needs the
libLLVM named in DRJIT_LIBLLVM_PATH below). Each arm's CPU seconds per sample (and per render:
bdpt's pool pilot) are measured by two short calibration renders, and every seed then renders the
samples per pixel that take --cpu CPU seconds (user + system of the child, os.wait4), so the arms
get equal CPU time however the machine's cores are shared; the table gives the CPU seconds actually
used and compares arms by relMSE x CPU seconds. Renders use --threads threads (1: the project's
rule for CPU figures); --jobs runs that many seeds at once.

The arms run alternately, so that a drift of the machine's load over the minutes of a run falls on
every arm alike: the calibration renders go arm by arm (every arm's short render, then every arm's
long one), and each seed renders all arms one after the other, in the order given on the first seed,
reversed on the second, and so on (with --jobs N, N seeds do so at once).

--ref-pool CPU pools the Mitsuba reference with a specula path and a specula bdpt render of CPU
seconds each (seeds 9001 and 9002, not the bench's, each integrator's plan, two threads; cached in
--refs) for the relMSE figures: the three images are averaged with one weight per image, inversely
proportional to its image-wide relative variance (var / (ref^2 + 0.01), mean over pixels), so the
weights do not follow any pixel's own noise and the pooled mean stays unbiased; its variance of
the mean is the weighted sum of the three. A reference whose own error is a fraction of the
renders' keeps it from moving the arms' ratios. The z-test is always against the Mitsuba reference
alone (an independent renderer, so a bias shared by specula's integrators still shows). Mitsuba
3.9's LLVM variant splats with the exact tent (and gaussian), its scalar variant and specula with
the 31-step table (scene/rfilter.h): at a sharp edge the two differ by several percent (the cornell
box's light, measured in part bdpt30), so a scene with such a filter wants `--mitsuba-variant
scalar_rgb` for its z-test (its cached reference deleted first).

--bdpt-pool M renders bdpt with connections to M light vertices from the pass's pool
(integrator/bdpt_pool.h). Each seed's line names its worst pixel (x, y).

Per render: relMSE = mean over pixels and channels of ((a - b)^2 - var(b)) / (b^2 + 0.01) (as
`specula diff`, less the reference's own variance of the mean), and the worst pixel's share of
that sum. Per scene and arm: mean and worst relMSE over the seeds with the worst seed's worst-pixel
share, the largest worst-pixel share over the seeds, the lowest z-test pass fraction, CPU
microseconds per sample, and each arm's relMSE x CPU over the (first) bdpt arm's.
"""
import argparse
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))
SHARED = os.path.normpath(os.path.join(ROOT, "..", "..", "shared", "scenes"))

# name: (scene file, -D definitions given the resolution)
SCENES = {
    "indirect_lamp_glass": ("scenes/indirect_lamp_glass.xml", lambda r: [f"res={r}"]),
    "indirect_door": ("scenes/indirect_door.xml", lambda r: [f"res={r}"]),
    "caustic_sphere": ("scenes/caustic_sphere.xml", lambda r: [f"res={r}"]),
    "cornell_box": ("cornell-box/scene.xml", lambda r: [f"resx={r}", f"resy={r}"]),
}


def scene_path(rel):
    p = os.path.join(ROOT, rel)
    return p if os.path.exists(p) else os.path.join(SHARED, rel)


def read_exr(path):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(path), dtype=np.float64)


def read_rgb(path):
    return read_exr(path)[:, :, :3]


def read_mean_var(path):
    """(mean RGB, variance-of-the-mean RGB) of an EXR written with variance channels (Mitsuba's
    reference or specula's --variance), found by channel name."""
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    b = mi.Bitmap(path)
    names = [f.name for f in b.struct_()]
    px = np.array(b, dtype=np.float64)
    idx = lambda keys: [names.index(k) for k in keys]
    return px[:, :, idx(["R", "G", "B"])], px[:, :, idx(["variance.R", "variance.G", "variance.B"])]


def pool_reference(parts):
    """One weight per image, inversely proportional to its image-wide relative variance (a constant
    per image, not per pixel, so the pooled mean is unbiased); returns the pooled mean, its variance
    of the mean and the weights."""
    base = parts[0][0]
    rel = np.array([(v / (base ** 2 + 0.01)).mean() for _, v in parts])
    w = (1.0 / rel) / (1.0 / rel).sum()
    mean = sum(wi * m for wi, (m, _) in zip(w, parts))
    var = sum(wi * wi * v for wi, (_, v) in zip(w, parts))
    return mean, var, w


class Arm:
    """One integrator with one specular NEE setting: snee '' passes no --specular-nee (the plan)."""

    def __init__(self, spec):
        it, _, sn = spec.partition("=")
        if it not in ("path", "bdpt"):
            raise SystemExit(f"unknown integrator in arm '{spec}'")
        self.integrator, self.snee = it, "" if sn in ("", "plan") else sn

    def label(self):
        return f"{self.integrator}[{self.snee or 'plan'}]"

    def flags(self):
        return ["--specular-nee", self.snee] if self.snee else []

    def setting(self):
        return f"--specular-nee {self.snee}" if self.snee else "no --specular-nee (the plan)"


def arms_of(a):
    if a.arm:
        return [Arm(x) for x in a.arm]
    arms = []
    for it in a.integrators.split(","):
        own = a.bdpt_snee if it == "bdpt" else a.path_snee
        arms.append(Arm(f"{it}={own or a.snee}"))
    return arms


def render(a, scene, defs, arm, spp, seed, out, threads=None):
    """Renders and returns the child's CPU seconds (user + system)."""
    cmd = [a.specula, "render", scene, "--integrator", arm.integrator, "--spp", str(spp), "--seed", str(seed),
           "--threads", str(threads or a.threads), "--quiet", "--variance", "-o", out, "-D", "integrator=path"]
    cmd += arm.flags()
    if arm.integrator == "bdpt" and a.bdpt_pool:
        cmd += ["--bdpt-pool", str(a.bdpt_pool)]
    for d in defs:
        cmd += ["-D", d]
    p = subprocess.Popen(cmd)
    _, status, ru = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        raise subprocess.CalledProcessError(p.returncode, cmd)
    return ru.ru_utime + ru.ru_stime


def ztest_pass(a, img, ref_path):
    """`specula diff`'s per-pixel z-test (Sidak-corrected) of img against the reference."""
    import json

    r = subprocess.run([a.specula, "diff", img, ref_path, "--json"], check=True, capture_output=True, text=True)
    return json.loads(r.stdout).get("ztest", {}).get("pass_fraction", float("nan"))


def errors(img, ref, ref_var):
    """relMSE against the truth: the reference's own variance of the mean is subtracted from each
    squared difference (E[(a - b)^2] = E[(a - truth)^2] + Var(b) for independent a and b), so a
    noisy reference does not inflate the error of a good image."""
    e = (((img - ref) ** 2 - ref_var) / (ref ** 2 + 0.01)).sum(axis=2)
    total = e.sum()
    worst = np.clip(e, 0.0, None).max()
    y, x = np.unravel_index(np.argmax(e), e.shape)
    return total / e.size / 3.0, (worst / total if total > 0 else 1.0), (int(x), int(y))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--cpu", type=float, default=4.0)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--refs", default="/tmp/specula_bdpt_refs")
    ap.add_argument("--out", default="/tmp/specula_bdpt_seeds")
    ap.add_argument("--mitsuba-spp", type=int, default=32768)
    ap.add_argument("--mitsuba-variant", default="llvm_ad_rgb")
    ap.add_argument("--arm", action="append", default=[])
    ap.add_argument("--snee", default="")
    ap.add_argument("--path-snee", default="")
    ap.add_argument("--bdpt-snee", default="")
    ap.add_argument("--integrators", default="")
    ap.add_argument("--bdpt-pool", type=int, default=0)
    ap.add_argument("--ref-pool", type=float, default=0.0)
    a = ap.parse_args()
    if not a.arm and not a.integrators:
        a.arm = ["path=none", "path=plan", "bdpt=plan"]
    arms = arms_of(a)
    os.makedirs(a.refs, exist_ok=True)
    os.makedirs(a.out, exist_ok=True)
    print(f"{a.res}x{a.res}, {a.cpu} CPU s per render, {a.threads} thread(s), seeds {a.first_seed}.."
          f"{a.first_seed + a.seeds - 1}, load average "
          f"{open('/proc/loadavg').read().split()[:3]}")
    for arm in arms:
        print(f"arm {arm.label()}: --integrator {arm.integrator}, {arm.setting()}"
              + (f", --bdpt-pool {a.bdpt_pool}" if arm.integrator == "bdpt" and a.bdpt_pool else ""))
    print("| scene | arm | spp | CPU s (mean) | CPU us / sample | relMSE mean | relMSE worst (seed): its worst pixel's "
          "share | worst pixel's share, largest over seeds | z-test pass, lowest over seeds | relMSE x CPU / bdpt's |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in a.scenes or list(SCENES):
        rel, defs_of = SCENES[name]
        scene, defs = scene_path(rel), defs_of(a.res)
        ref_path = os.path.join(a.refs, f"{name}_{a.res}.exr")
        if not os.path.exists(ref_path):
            env = dict(os.environ, DRJIT_LIBLLVM_PATH="/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
            subprocess.run([sys.executable, os.path.join(ROOT, "tests/validation/mitsuba_ref.py"), scene, ref_path,
                            "--spp", str(a.mitsuba_spp), "--passes", "32", "--variant", a.mitsuba_variant,
                            "-D", "integrator=path"] + [x for d in defs for x in ("-D", d)], check=True, env=env)
        ref, ref_var = read_mean_var(ref_path)
        mref, mref_var = ref, ref_var
        print(f"  {name}: Mitsuba reference's own relMSE (its variance of the mean) "
              f"{(ref_var / (ref ** 2 + 0.01)).mean():.3g}", file=sys.stderr)

        def calibrate(arms_, budget, threads=None):
            # two calibration renders per arm, so that a fixed cost per render (bdpt's pool pilot) is
            # not spread over the samples: CPU(spp) = fixed + spp * per_sample; every arm's short
            # render, then every arm's long one
            cal = 64
            out = os.path.join(a.out, "cal.exr")
            c1 = [render(a, scene, defs, arm, cal, 100, out, threads) for arm in arms_]
            c2 = [render(a, scene, defs, arm, 2 * cal, 100, out, threads) for arm in arms_]
            spps = []
            for x1, x2 in zip(c1, c2):
                per = max((x2 - x1) / cal, 0.5 * x2 / (2 * cal), 1e-6)
                fixed = min(max(x1 - cal * per, 0.0), 0.5 * budget)
                spps.append(max(1, int(round((budget - fixed) / per))))
            return spps

        if a.ref_pool > 0:
            parts = [(ref, ref_var)]
            for k, it in enumerate(("path", "bdpt")):
                pooled = os.path.join(a.refs, f"{name}_{a.res}_{it}_{a.ref_pool:g}cpu.exr")
                if not os.path.exists(pooled):
                    spp = calibrate([Arm(it)], a.ref_pool, 2)[0]
                    cpu = render(a, scene, defs, Arm(it), spp, 9001 + k, pooled, 2)
                    print(f"  {name}: reference part {it}, {spp} spp, CPU {cpu:.1f} s", file=sys.stderr)
                parts.append(read_mean_var(pooled))
            for (m, v), label in zip(parts, ("mitsuba", "path", "bdpt")):
                print(f"  {name}: reference part {label}: own relMSE {(v / (ref ** 2 + 0.01)).mean():.3g}",
                      file=sys.stderr)
            ref, ref_var, w = pool_reference(parts)
            print(f"  {name}: pooled reference (weights {', '.join(f'{x:.3f}' for x in w)}): own relMSE "
                  f"{(ref_var / (ref ** 2 + 0.01)).mean():.3g}", file=sys.stderr)
        spps = calibrate(arms, a.cpu)

        def one_arm(arm, spp, seed):
            pool = f"_pool{a.bdpt_pool}" if arm.integrator == "bdpt" and a.bdpt_pool else ""
            tag = (arm.snee or "plan").replace(":", "_").replace(",", "_").replace("=", "_")
            out = os.path.join(a.out, f"{name}_{arm.integrator}_{tag}{pool}_{seed}.exr")
            cpu = render(a, scene, defs, arm, spp, seed, out)
            img = read_rgb(out)
            rm, share, wxy = errors(img, ref, ref_var)
            zp = ztest_pass(a, out, ref_path)
            rm_m = errors(img, mref, mref_var)[0]
            print(f"  {name} {arm.label()} seed {seed}: spp {spp}, CPU {cpu:.2f} s, relMSE {rm:.4g}, worst pixel "
                  f"{100 * share:.1f}% at {wxy}, z-test against Mitsuba {100 * zp:.2f}%"
                  + (f", relMSE against Mitsuba alone {rm_m:.4g}" if a.ref_pool > 0 else ""), file=sys.stderr,
                  flush=True)
            return (rm, share, cpu, seed, zp, rm_m)

        def one(seed):
            # every arm on this seed, one after the other; the order turns with the seed
            order = list(range(len(arms)))
            if (seed - a.first_seed) % 2:
                order.reverse()
            rows = [None] * len(arms)
            for i in order:
                rows[i] = one_arm(arms[i], spps[i], seed)
            return rows

        with ThreadPoolExecutor(max_workers=max(1, a.jobs)) as ex:
            per_seed = list(ex.map(one, range(a.first_seed, a.first_seed + a.seeds)))
        results = []
        for i, arm in enumerate(arms):
            rows = [r[i] for r in per_seed]
            results.append((arm, spps[i], rows))
            if a.ref_pool > 0:
                print(f"  {name} {arm.label()}: mean relMSE against Mitsuba alone "
                      f"{np.mean([r[5] for r in rows]):.4g}", file=sys.stderr)
        base = next((r for r in results if r[0].integrator == "bdpt"), None)

        def cost(r):  # mean relMSE x mean CPU seconds: the error at one CPU second
            return np.mean([x[0] for x in r[2]]) * np.mean([x[2] for x in r[2]])

        for arm, spp, rows in results:
            rm = np.array([r[0] for r in rows])
            worst = max(rows)
            cpu = np.mean([r[2] for r in rows])
            ratio = f"{cost((arm, spp, rows)) / cost(base):.2f}" if base else ""
            print(f"| {name} | {arm.label()} | {spp} | {cpu:.2f} | {1e6 * cpu / (spp * a.res * a.res):.2f} | "
                  f"{rm.mean():.4g} | {worst[0]:.4g} (s{worst[3]}): {100 * worst[1]:.1f}% | "
                  f"{100 * max(r[1] for r in rows):.1f}% | {100 * min(r[4] for r in rows):.2f}% | {ratio} |",
                  flush=True)


if __name__ == "__main__":
    sys.exit(main())
