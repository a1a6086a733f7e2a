"""Where the opencl device's image differs from the CPU device's: image means over NS seeds of the
full bdpt image under several OpenCL build options, of path, and of every single bdpt strategy
(s, t) up to s + t = 6, unweighted (`--strategy s,t` on the CPU, -DONLY_S/-DONLY_T on the device).
Run on the GPU machine from the repository root after unpacking .devkit/lib.tar.xz (see
bench/gpu/check.sh): LP is the library path (.devkit/lib, then the driver's folder), OCL_ICD_VENDORS
a folder naming the driver's libnvidia-opencl.so.1."""
import json, os, subprocess, sys, time, numpy as np
K = os.path.join(os.getcwd(), ".devkit"); L = K + "/lib"; LP = os.environ.get("LP", L)
OUT = os.environ.get("OUT", "/tmp/devout"); os.makedirs(OUT, exist_ok=True)
RES = int(os.environ.get("RES", "96")); SPP = int(os.environ.get("SPP", "64")); NS = int(os.environ.get("NS", "3"))
T0 = time.time(); BUDGET = float(os.environ.get("BUDGET", "330"))
def pfm_mean(p):
    with open(p, "rb") as f:
        f.readline(); w, h = map(int, f.readline().split()); f.readline()
        a = np.frombuffer(f.read(), dtype="<f4")
    return a.reshape(h, w, 3).astype(np.float64).mean()
def render(scene, dev, seed, extra, cl_opts=None, integ="bdpt"):
    env = dict(os.environ)
    if cl_opts is not None: env["SPC_CL_DEBUG"] = cl_opts
    cmd = [L + "/ld-linux-x86-64.so.2", "--library-path", LP, K + "/specula", "render", "scenes/%s.xml" % scene,
           "--device", dev, "--integrator", integ, "--max-depth", "8", "--res", "%dx%d" % (RES, RES),
           "--spp", str(SPP), "--seed", str(seed), "--quiet", "-o", OUT + "/x.pfm", "--stats", OUT + "/st.json"] + extra
    if dev == "cpu": cmd += ["--threads", "16"]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if r.returncode: print("FAIL", " ".join(cmd[4:]), r.stderr[-300:]); return None, 0
    st = json.load(open(OUT + "/st.json"))
    return pfm_mean(OUT + "/x.pfm"), st.get("invalid_samples", 0)
def row(label, scene, dev, extra=[], cl=None, integ="bdpt"):
    ms, inv = [], 0
    for s in range(NS):
        m, i = render(scene, dev, 11 + s, extra, cl, integ)
        if m is None: return None
        ms.append(m); inv += i
    ms = np.array(ms); mu = ms.mean(); se = ms.std(ddof=1) / np.sqrt(len(ms)) if len(ms) > 1 else 0
    print("%-44s %-7s mean %.5f +- %.5f  invalid %d   [%.0fs]" % (label, dev, mu, se, inv, time.time() - T0), flush=True)
    return mu, se
sc = "sdf_shapes_csg"
print("== full bdpt image, build options ==")
row("csg bdpt", sc, "cpu")
for o in ["", "-cl-opt-disable", "-cl-fp32-correctly-rounded-divide-sqrt", "-cl-denorms-are-zero"]:
    row("csg bdpt opts '%s'" % o, sc, "opencl", cl=o)
row("csg path", sc, "cpu", ["--specular-nee", "none"], integ="path")
row("csg path", sc, "opencl", integ="path")
print("== single strategies, unweighted (cpu --strategy s,t vs opencl -DONLY_S -DONLY_T) ==")
for k in range(2, 7):
    for s in range(0, k):
        t = k - s
        if (s, t) == (1, 1) or t < 1: continue
        if time.time() - T0 > BUDGET: print("budget reached"); sys.exit(0)
        a = row("csg s=%d t=%d" % (s, t), sc, "cpu", ["--strategy", "%d,%d" % (s, t)])
        b = row("csg s=%d t=%d" % (s, t), sc, "opencl", cl="-DONLY_S=%d -DONLY_T=%d" % (s, t))
        if a and b: print("   ratio opencl/cpu %.4f  z %.2f" % (b[0] / a[0] if a[0] else 0, (b[0] - a[0]) / np.hypot(a[1], b[1]) if a[1] + b[1] > 0 else 0))
