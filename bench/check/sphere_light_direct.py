#!/usr/bin/env python3
"""bench/check/sphere_light_direct.py: the exact direct light of a sphere light on the diffuse floor
of a random caustic scene (/work/shared/tools/random_caustic_scene.py), per pixel, in double
precision, against renders of the direct light alone (max_depth 2) by Mitsuba 3 and by specula.

  python3 bench/check/sphere_light_direct.py SCENE.xml RES [--mitsuba M.npy] [--specula 'GLOB']

A uniformly emitting sphere of radius r and radiance L wholly above a point's horizon gives it the
irradiance E = pi L (r / d)^2 cos(theta) (d the distance to the centre, theta its angle to the normal),
so a diffuse floor of albedo rho has radiance rho L (r / d)^2 cos(theta) there; each pixel's value is
that averaged over a 48 x 48 grid in the pixel (the box filter). Pixels where any grid point sees
something other than the floor, or where a caster sphere comes within its radius + 0.05 of the segment
from a grid point to the light, are left out. Only scenes whose casters are spheres (glass or mirror)
and whose light is one sphere: anything else could shadow the floor unseen here.

M.npy: mitsuba_ref.py SCENE M.npy --max-depth 2 (its batches); GLOB: specula EXRs rendered with
-D max_depth=2 at several seeds. Prints each renderer's mean ratio to the exact value over the pixels
kept (with the spread over its batches or seeds) and the 5th and 95th percentiles per pixel.
"""
import glob
import re
import sys

import numpy as np


def vec(s):
    return np.array([float(v) for v in s.split(",")])


def exact(xml, res, grid=48):
    t = open(xml).read()
    if re.search(r'<shape type="(obj|cube|cylinder|ply|serialized|disk)"', t):
        raise SystemExit("%s: a caster that is not a sphere; this check handles sphere casters only" % xml)
    fov = float(re.search(r'name="fov" value="([0-9.]+)"', t).group(1))
    look = re.search(r'lookat origin="([^"]+)" target="([^"]+)" up="([^"]+)"', t)
    o, tg, up = vec(look.group(1)), vec(look.group(2)), vec(look.group(3))
    rho = vec(re.search(r'name="reflectance" value="([^"]+)"', t).group(1))
    light = re.search(r'<shape type="sphere"><point name="center" x="([-0-9.]+)" y="([-0-9.]+)" z="([-0-9.]+)"/>'
                      r'<float name="radius" value="([0-9.]+)"/><emitter type="area"><rgb name="radiance" '
                      r'value="([^"]+)"', t)
    if light is None:
        raise SystemExit("%s: no sphere light" % xml)
    lc = np.array([float(light.group(i)) for i in (1, 2, 3)])
    lr, L = float(light.group(4)), vec(light.group(5))
    casters = [(np.array([float(x), float(y), float(z)]), float(r)) for x, y, z, r in re.findall(
        r'<shape type="sphere"><point name="center" x="([-0-9.]+)" y="([-0-9.]+)" z="([-0-9.]+)"/>'
        r'<float name="radius" value="([0-9.]+)"/><bsdf', t)]
    # Mitsuba's look-at frame and perspective camera: x to the left, fov along x, a square film
    d = (tg - o) / np.linalg.norm(tg - o)
    left = np.cross(up, d)
    left /= np.linalg.norm(left)
    nup = np.cross(d, left)
    tn = np.tan(np.radians(fov) / 2)
    g = (np.arange(grid) + 0.5) / grid
    out = np.full((res, res, 3), np.nan)
    for py in range(res):
        for px in range(res):
            u, v = (px + g[None, :]) / res, (py + g[:, None]) / res
            dirs = -(2 * u - 1)[..., None] * tn * left - (2 * v - 1)[..., None] * tn * nup + d
            dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
            t_hit = -o[1] / dirs[..., 1]
            if np.any(t_hit <= 0):
                continue
            p = o + t_hit[..., None] * dirs
            if np.any(np.abs(p[..., 0]) > 4) or np.any(np.abs(p[..., 2]) > 4):
                continue
            w = lc - p
            dist = np.linalg.norm(w, axis=-1)
            wn = w / dist[..., None]
            blocked = False
            for c, r in casters:
                oc = o - c
                b = (dirs * oc).sum(-1)
                s = np.clip(((c - p) * wn).sum(-1), 0, dist)
                near = np.linalg.norm(p + s[..., None] * wn - c, axis=-1)
                if np.any(b * b - (oc @ oc - r * r) > 0) or np.any(near < r + 0.05):
                    blocked = True
                    break
            if not blocked:
                out[py, px] = rho * L * ((lr / dist) ** 2 * wn[..., 1]).mean()
    return out


def main():
    xml, res = sys.argv[1], int(sys.argv[2])
    ex = exact(xml, res)
    keep = np.isfinite(ex[..., 0])
    print("%s: %d pixels see the floor lit by the whole light" % (xml, keep.sum()))
    sets = []
    if "--mitsuba" in sys.argv:
        sets.append(("Mitsuba 3", np.load(sys.argv[sys.argv.index("--mitsuba") + 1]).astype(np.float64)))
    if "--specula" in sys.argv:
        import mitsuba as mi
        mi.set_variant("scalar_rgb")
        files = sorted(glob.glob(sys.argv[sys.argv.index("--specula") + 1]))
        sets.append(("specula", np.stack([np.array(dict(mi.Bitmap(f).split())["<root>"], dtype=np.float64)[..., :3]
                                          for f in files])))
    for name, x in sets:
        per = np.array([(xi[keep] / ex[keep]).mean() for xi in x])
        pix = x.mean(0)[keep] / ex[keep]
        print("  %-9s / exact: %.5f +- %.5f over %d batches or seeds; per pixel 5%% %.5f, median %.5f, 95%% %.5f" % (
            name, per.mean(), per.std(ddof=1) / np.sqrt(len(per)), len(per), np.percentile(pix, 5),
            np.median(pix), np.percentile(pix, 95)))


if __name__ == "__main__":
    main()
