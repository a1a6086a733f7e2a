#!/usr/bin/env python3
"""Equal-CPU-time error of the opencl device (PoCL) against the CPU device.

Renders a reference with the CPU device's bdpt, then, for each integrator and device, several
seeds at spp chosen so that both devices get about the same CPU time (user + system of the whole
process, PoCL's threads included), and reports per device: spp, mean CPU seconds, mean relMSE
over the seeds (mean over pixels and channels of (a - ref)^2 / (ref^2 + 0.01)), the worst seed's
relMSE and the worst pixel's share of the error summed over seeds.

Usage: python3 bench/bench_opencl_error.py [SCENE] [RES] [SPP_CPU] [SEEDS] [REF_SPP]
(defaults scenes/caustic_sdf_torus.xml 64 64 4 4096). Needs build/specula with OpenCL and
Mitsuba 3's Python package (to read the EXRs).
"""
import os, subprocess, sys, tempfile, resource
import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
scene = sys.argv[1] if len(sys.argv) > 1 else "scenes/caustic_sdf_torus.xml"
res = int(sys.argv[2]) if len(sys.argv) > 2 else 64
spp_cpu = int(sys.argv[3]) if len(sys.argv) > 3 else 64
seeds = int(sys.argv[4]) if len(sys.argv) > 4 else 4
ref_spp = int(sys.argv[5]) if len(sys.argv) > 5 else 4096
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
exe = os.path.join(root, "build", "specula")
tmp = tempfile.mkdtemp()


def render(device, integ, spp, seed, out):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([exe, "render", os.path.join(root, scene), "--device", device, "--integrator", integ,
                    "--max-depth", "8", "--res", f"{res}x{res}", "--spp", str(spp), "--seed", str(seed),
                    "--quiet", "-o", out], check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def load(path):
    return np.array(dict(mi.Bitmap(path).split())["<root>"])[..., :3].astype(np.float64)


ref_path = os.path.join(tmp, "ref.exr")
t = render("cpu", "bdpt", ref_spp, 1000, ref_path)
ref = load(ref_path)
print(f"{scene} {res}x{res}; reference: cpu bdpt {ref_spp} spp ({t:.1f} CPU s)")
print(f"{'integ':6} {'device':7} {'spp':>5} {'CPU s':>7} {'relMSE':>10} {'worst seed':>11} {'worst px share':>15}")
for integ in ("path", "bdpt"):
    # the opencl spp for equal CPU time, from one calibration render each
    tc = render("cpu", integ, spp_cpu, 99, os.path.join(tmp, "c.exr"))
    to = render("opencl", integ, spp_cpu, 99, os.path.join(tmp, "c.exr"))
    for device, spp in (("cpu", spp_cpu), ("opencl", max(1, round(spp_cpu * tc / to)))):
        errs, times, per_px = [], [], np.zeros(ref.shape[:2])
        for seed in range(seeds):
            out = os.path.join(tmp, f"{device}_{integ}_{seed}.exr")
            times.append(render(device, integ, spp, seed + 1, out))
            e = (load(out) - ref) ** 2 / (ref ** 2 + 0.01)
            errs.append(e.mean())
            per_px += e.mean(axis=2)
        share = per_px.max() / per_px.sum()
        print(f"{integ:6} {device:7} {spp:5d} {np.mean(times):7.2f} {np.mean(errs):10.5f} {max(errs):11.5f} "
              f"{share:15.4f}")
