"""Where the opencl device's image differs from the CPU device's: image means over NS seeds of the
full bdpt image under several OpenCL build options, of path, and of single bdpt strategies (s, t),
unweighted (`--strategy s,t` on the CPU, -DONLY_S/-DONLY_T on the device). The CPU renders run
`--specular-nee none` (the device's estimator). Run on the GPU machine from the repository root
after unpacking .devkit/lib.tar.xz (see bench/gpu/check.sh): LP is the library path (.devkit/lib,
then the driver's folder), OCL_ICD_VENDORS a folder naming the driver's libnvidia-opencl.so.1.
Knobs (environment): RES, SPP, NS (seeds), SCENES (space-separated scene names), OPTIONS
('|'-separated kernel build options for full-image rows; "none" for no such rows), PATHROW (0 skips
path), STRATS (space-separated s,t, or none; default every strategy up to s + t = 6), BUDGET (seconds)."""
import json, os, subprocess, sys, time, numpy as np
K = os.path.join(os.getcwd(), ".devkit"); L = K + "/lib"; LP = os.environ.get("LP", L)
OUT = os.environ.get("OUT", "/tmp/devout"); os.makedirs(OUT, exist_ok=True)
RES = int(os.environ.get("RES", "96")); SPP = int(os.environ.get("SPP", "64")); NS = int(os.environ.get("NS", "3"))
T0 = time.time(); BUDGET = float(os.environ.get("BUDGET", "330"))
SCENES = os.environ.get("SCENES", "sdf_shapes_csg").split()
OPTIONS = os.environ.get("OPTIONS", "|-cl-opt-disable|-cl-fp32-correctly-rounded-divide-sqrt|-cl-denorms-are-zero")
PATHROW = os.environ.get("PATHROW", "1") == "1"
STRATS = os.environ.get("STRATS")
if STRATS == "none":
    STRATS = []
elif STRATS:
    STRATS = [tuple(map(int, x.split(","))) for x in STRATS.split()]
else:
    STRATS = [(s, k - s) for k in range(2, 7) for s in range(0, k) if (s, k - s) != (1, 1)]
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
    if dev == "cpu": cmd += ["--threads", "16", "--specular-nee", "none"]
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
def ratio(a, b):
    if a and b: print("   ratio opencl/cpu %.4f  z %.2f" % (b[0] / a[0] if a[0] else 0, (b[0] - a[0]) / np.hypot(a[1], b[1]) if a[1] + b[1] > 0 else 0), flush=True)
for sc in SCENES:
    short = sc.replace("sdf_shapes_", "").replace("caustic_sdf_", "")
    if OPTIONS != "none":
        print("== %s: full bdpt image, build options ==" % sc)
        a = row("%s bdpt" % short, sc, "cpu")
        for o in OPTIONS.split("|"):
            ratio(a, row("%s bdpt opts '%s'" % (short, o), sc, "opencl", cl=o))
    if PATHROW:
        ratio(row("%s path" % short, sc, "cpu", integ="path"), row("%s path" % short, sc, "opencl", integ="path"))
    print("== %s: single strategies, unweighted (cpu --strategy s,t vs opencl -DONLY_S -DONLY_T) ==" % sc)
    for s, t in STRATS:
        if time.time() - T0 > BUDGET: print("budget reached"); sys.exit(0)
        a = row("%s s=%d t=%d" % (short, s, t), sc, "cpu", ["--strategy", "%d,%d" % (s, t)])
        b = row("%s s=%d t=%d" % (short, s, t), sc, "opencl", cl="-DONLY_S=%d -DONLY_T=%d" % (s, t))
        ratio(a, b)
