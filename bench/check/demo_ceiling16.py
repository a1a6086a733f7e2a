#!/usr/bin/env python3
"""Compare default / none / bdpt / ptracer (specula, seeds as batches) and Mitsuba ptracer / path
(batches) on scenes/demo.xml at 16x16: per-pixel Welch over the combined means, and region sums
(ceiling, floor, walls: Mitsuba's normal AOV of the first hit) with standard errors.
  python3 bench/check/demo_ceiling16.py [DIR] [--map]
DIR (default /tmp/welch15/) holds r_{default,none,bdpt,ptracer}_SEED.exr (specula render --variance,
one per seed: bench/check/demo_ceiling_one.sh), m_{ptracer,path}_*.npy (bench/check/mitsuba_ref.py
batches) and m_normal.npy (mitsuba_ref.py --integrator normal), all 16x16.
"""
import glob, sys
from statistics import NormalDist
import numpy as np
import mitsuba as mi
mi.set_variant("scalar_rgb")
import sys
D = (sys.argv[1].rstrip("/") + "/") if len(sys.argv) > 1 and not sys.argv[1].startswith("--") else "/tmp/welch15/"

def load_exr(p):
    ch = dict(mi.Bitmap(p).split())
    return (np.array(ch["<root>"], dtype=np.float64)[..., :3].mean(-1),
            np.array(ch["variance"], dtype=np.float64)[..., :3].mean(-1))

ests = {}
for n in ["default", "none", "bdpt", "ptracer"]:
    fs = sorted(glob.glob(D + "r_%s_*.exr" % n))
    if not fs:
        continue
    ims = [load_exr(f) for f in fs]
    a = np.stack([i[0] for i in ims]); v = np.stack([i[1] for i in ims])
    k = len(fs)
    # mean over seeds; variance of the mean from the renders' own variance channels (vch) and,
    # independently, from the spread of the seeds (vsp; few seeds: rough)
    ests[n] = dict(k=k, batches=a, m=a.mean(0), v=v.sum(0) / k ** 2,
                   vsp=a.var(0, ddof=1) / k if k > 1 else None)
for n in ["ptracer", "path"]:
    fs = sorted(glob.glob(D + "m_%s_*.npy" % n))
    if not fs:
        continue
    b = np.concatenate([np.load(f) for f in fs]).astype(np.float64).mean(-1)
    k = b.shape[0]
    ests["mts_" + n] = dict(k=k, batches=b, m=b.mean(0), v=b.var(0, ddof=1) / k, vsp=b.var(0, ddof=1) / k)

nrm = np.load(D + "m_normal.npy")[0] if glob.glob(D + "m_normal.npy") else None
ref = ests.get("default")
regions = {}
if nrm is not None:
    ny = nrm[..., 1]; nx = nrm[..., 0]; nz = nrm[..., 2]
    bright = ests["default"]["m"] > 3
    regions["ceiling"] = (ny < -0.999) & ~bright
    regions["floor"] = ny > 0.999
    regions["back"] = nz > 0.999
    regions["red"] = nx > 0.999
    regions["green"] = nx < -0.999
    regions["diffuse(all)"] = regions["ceiling"] | regions["floor"] | regions["back"] | regions["red"] | regions["green"]
    regions["spheres"] = ~regions["diffuse(all)"] & ~bright

print("estimators:", {n: e["k"] for n, e in ests.items()})
print("\nregion means (pixel mean over the region) +- SE from variance channels [SE from seed spread]:")
for r, msk in regions.items():
    line = "%-13s %3d px:" % (r, msk.sum())
    for n, e in ests.items():
        mu = e["m"][msk].mean(); se = np.sqrt(e["v"][msk].sum()) / msk.sum()
        sp = e["batches"][:, msk].mean(1); ses = sp.std(ddof=1) / np.sqrt(len(sp)) if len(sp) > 1 else 0
        line += "  %s %.5f+-%.5f[%.5f]" % (n, mu, se, ses)
    print(line)

print("\nper-pixel Welch (combined means), Sidak alpha 0.01; region z of the sum:")
names = list(ests)
for i in range(len(names)):
    for j in range(i + 1, len(names)):
        A, B = ests[names[i]], ests[names[j]]
        msk = np.ones(A["m"].shape, bool)
        if "ptracer" in names[i] or "ptracer" in names[j]:
            msk = regions["diffuse(all)"] if regions else msk
        z = (A["m"] - B["m"]) / np.sqrt(A["v"] + B["v"] + (1e-4 * 0.5 * (abs(A["m"]) + abs(B["m"]))) ** 2 + 1e-30)
        zz = z[msk]; n = zz.size
        thr = NormalDist().inv_cdf(1 - (1 - (1 - 0.01) ** (1.0 / n)) / 2)
        s = "%-12s vs %-12s %3d px: pass %.4f (|z|<%.2f), |z|>3.5 %.3f, mean z %+.2f, worst |z| %.1f" % (
            names[i], names[j], n, (abs(zz) < thr).mean(), thr, (abs(zz) > 3.5).mean(), zz.mean(), abs(zz).max())
        for r in ["ceiling", "floor", "back"]:
            if r in regions:
                m = regions[r] & msk
                d = A["m"][m].sum() - B["m"][m].sum(); se = np.sqrt(A["v"][m].sum() + B["v"][m].sum())
                s += "; %s %+.2f%% z %+.1f" % (r, 100 * (A["m"][m].sum() / B["m"][m].sum() - 1), d / se)
        print(s)
if "--map" in sys.argv and regions:
    print("\nregions map (c ceiling, f floor, b back, r red, g green, s spheres, L light):")
    h, w = regions["ceiling"].shape
    for y in range(h):
        print("".join("L" if ests["default"]["m"][y, x] > 3 else next((k[0] for k in ["ceiling", "floor", "back", "red", "green", "spheres"] if regions[k][y, x]), "?") for x in range(w)))
