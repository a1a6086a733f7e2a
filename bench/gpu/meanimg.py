"""Mean images over NS seeds for several renders of one scene, to see where two devices differ:
writes OUT/<label>.npz (mean, se: the standard error over seeds, means: each seed's image mean) and prints each
image mean +- its standard error. Run like probe.py (LP, OCL_ICD_VENDORS; RES, SPP, NS, SCENE).
Each config is label:device:integrator[:extra options separated by commas]."""
import os, subprocess, sys, numpy as np
K = os.path.join(os.getcwd(), ".devkit"); L = K + "/lib"; LP = os.environ.get("LP", L)
OUT = os.environ.get("OUT", "/tmp/devout"); os.makedirs(OUT, exist_ok=True)
W = os.environ.get("WORK", "/tmp/meanimg"); os.makedirs(W, exist_ok=True)
RES = int(os.environ.get("RES", "96")); SPP = int(os.environ.get("SPP", "1024")); NS = int(os.environ.get("NS", "8"))
SCENE = os.environ.get("SCENE", "caustic_sdf_torus")
def pfm(p):
    with open(p, "rb") as f:
        f.readline(); w, h = map(int, f.readline().split()); f.readline()
        return np.frombuffer(f.read(), dtype="<f4").reshape(h, w, 3).astype(np.float64)
for cfg in sys.argv[1:]:
    label, dev, integ, *extra = cfg.split(":")
    extra = extra[0].split(",") if extra else []
    ims = []
    for s in range(NS):
        cmd = [L + "/ld-linux-x86-64.so.2", "--library-path", LP, K + "/specula", "render", "scenes/%s.xml" % SCENE,
               "--device", dev, "--integrator", integ, "--max-depth", "8", "--res", "%dx%d" % (RES, RES), "--spp", str(SPP),
               "--seed", str(11 + s), "--quiet", "-o", W + "/x.pfm"] + extra
        if dev == "cpu": cmd += ["--threads", "16", "--specular-nee", "none"]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode: print("FAIL", cfg, r.stderr[-300:]); break
        ims.append(pfm(W + "/x.pfm"))
    if len(ims) < 2: continue
    a = np.array(ims); m = a.mean(0); se = a.std(0, ddof=1) / np.sqrt(len(a))
    means = a.mean((1, 2, 3))
    print("%-16s mean %.5f +- %.5f" % (label, means.mean(), means.std(ddof=1) / np.sqrt(len(means))), flush=True)
    np.savez(OUT + "/%s.npz" % label, mean=m, se=se, means=means)
