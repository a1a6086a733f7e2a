#!/usr/bin/env python3
"""bench/check/light_direct.py: the exact direct light of a random caustic scene's light on its
floor, per pixel in double precision, against Mitsuba 3 and specula rendering the same.

  python3 bench/check/light_direct.py SCENE.xml OUTDIR [--specula build/specula] [--res 32]
                                      [--spp 4096] [--seeds 8]

SCENE.xml: a scene of /work/shared/tools/random_caustic_scene.py with a sphere or a square light.
Writes OUTDIR/NAME_direct.xml: the scene with its casters and sky removed and max_depth 2, so every
pixel is the floor's direct light or black; renders it with Mitsuba 3 (bench/check/mitsuba_ref.py,
--seeds batches of --spp) and with specula (--seeds seeds of --spp, one thread, `--specular-nee
none`), and prints each one's ratio to the exact image over the lit floor pixels (the mean over
batches or seeds with its standard error, the 5th, 50th and 95th percentiles per pixel, and the
lowest and highest pixel).

The exact image: a diffuse floor of albedo rho has radiance rho E / pi under irradiance E. A
uniformly emitting sphere of radius r, radiance L, wholly above the horizon: E = pi L (r / d)^2
cos(theta) (d the distance to its centre, theta that direction's angle to the normal). A polygon of
radiance L emitting to one side: E = L / 2 sum_i angle(v_i, v_i+1) n . unit(v_i x v_i+1) (Lambert's
formula; v_i the vertices less the point) in front of its plane, 0 behind. Each pixel averages that over a 48 x 48 grid (the box filter). The camera
is Mitsuba's perspective look-at camera with the fov along x and a square film.

Why: per-pixel Welch tests of many seeds reach a precision of 1e-4 of a pixel's value, where the
references' own arithmetic shows (Mitsuba's direct light from a sphere light of 0.02 radius at 4
units reads 0.1% over the exact value).
"""
import argparse
import glob
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def vec(s):
    return np.array([float(v) for v in s.split(",")])


def strip(text):
    """The scene without its casters and sky, at max_depth 2."""
    light = re.search(r'  (<shape type="sphere">(?:(?!</shape>).)*<emitter type="area">.*?</shape>|'
                      r'<shape type="rectangle"><transform name="to_world"><scale value="[0-9.]+"/><lookat.*?</shape>)\n',
                      text, re.S)
    if light is None:
        raise SystemExit("no sphere or square light found")
    floor = re.search(r'  <shape type="rectangle">\n.*?</shape>\n', text, re.S).group(0)
    head = text.split("  </sensor>")[0] + "  </sensor>\n"
    head = re.sub(r'(<default name="max_depth" value=")[0-9]+', r"\g<1>2", head)
    return head + floor + "  " + light.group(1) + "\n</scene>\n"


def exact(text, res, grid=48):
    fov = float(re.search(r'name="fov" value="([0-9.]+)"', text).group(1))
    look = re.search(r'<sensor.*?lookat origin="([^"]+)" target="([^"]+)" up="([^"]+)"', text, re.S)
    o, tg, up = vec(look.group(1)), vec(look.group(2)), vec(look.group(3))
    rho = vec(re.search(r'name="reflectance" value="([^"]+)"', text).group(1))
    sph = re.search(r'<shape type="sphere"><point name="center" x="([-0-9.]+)" y="([-0-9.]+)" z="([-0-9.]+)"/>'
                    r'<float name="radius" value="([0-9.]+)"/><emitter type="area"><rgb name="radiance" value="([^"]+)"',
                    text)
    if sph:
        lc = np.array([float(sph.group(i)) for i in (1, 2, 3)])
        lr, L = float(sph.group(4)), vec(sph.group(5))

        def irradiance(p):
            w = lc - p
            d = np.linalg.norm(w, axis=-1)
            return np.pi * (lr / d) ** 2 * w[..., 1] / d
    else:
        sq = re.search(r'<scale value="([0-9.]+)"/><lookat origin="([^"]+)" target="([^"]+)" up="([^"]+)"/></transform>'
                       r'<emitter type="area"><rgb name="radiance" value="([^"]+)"', text)
        s, lo, lt, lu, L = float(sq.group(1)), vec(sq.group(2)), vec(sq.group(3)), vec(sq.group(4)), vec(sq.group(5))
        dz = (lt - lo) / np.linalg.norm(lt - lo)
        dx = np.cross(lu, dz)
        dx /= np.linalg.norm(dx)
        dy = np.cross(dz, dx)
        verts = [lo + s * (a * dx + b * dy) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]

        def irradiance(p):
            E = 0.0
            for i in range(4):
                v0, v1 = verts[i] - p, verts[(i + 1) % 4] - p
                c = np.cross(v0, v1)
                cosang = (v0 * v1).sum(-1) / (np.linalg.norm(v0, axis=-1) * np.linalg.norm(v1, axis=-1))
                E = E + np.arccos(np.clip(cosang, -1, 1)) * c[..., 1] / np.linalg.norm(c, axis=-1)
            # one-sided: no light behind the rectangle's plane
            return np.where(((p - lo) * dz).sum(-1) > 0, np.abs(E) / 2, 0.0)
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
            t_hit = -o[1] / dirs[..., 1]
            if np.any(t_hit <= 0):
                continue
            p = o + t_hit[..., None] * dirs
            if np.any(np.abs(p[..., 0]) > 4) or np.any(np.abs(p[..., 2]) > 4):
                continue
            out[py, px] = rho * L * irradiance(p).mean() / np.pi
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("outdir")
    ap.add_argument("--specula", default=os.path.join(HERE, "..", "..", "build", "specula"))
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--seeds", type=int, default=8)
    a = ap.parse_args()
    os.makedirs(a.outdir, exist_ok=True)
    name = os.path.splitext(os.path.basename(a.scene))[0]
    text = strip(open(a.scene).read())
    xml = os.path.join(a.outdir, name + "_direct.xml")
    open(xml, "w").write(text)
    ex = exact(text, a.res)
    keep = np.isfinite(ex[..., 0]) & (ex.min(-1) > 0)
    mnpy = os.path.join(a.outdir, name + "_direct_mitsuba.npy")
    if not os.path.exists(mnpy):
        subprocess.run([sys.executable, os.path.join(HERE, "mitsuba_ref.py"), xml, mnpy, "--batches", str(a.seeds),
                        "--spp", str(a.spp), "--res", str(a.res), "--max-depth", "2", "--threads", "1"],
                       check=True, stderr=subprocess.DEVNULL)
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    imgs = []
    for k in range(a.seeds):
        out = os.path.join(a.outdir, "%s_direct_specula_%d.exr" % (name, k))
        if not os.path.exists(out):
            subprocess.run([a.specula, "render", xml, "--res", "%dx%d" % (a.res, a.res), "--spp", str(a.spp),
                            "--seed", str(k + 1), "--threads", "1", "--quiet", "--specular-nee", "none", "-o", out],
                           check=True)
        imgs.append(np.array(dict(mi.Bitmap(out).split())["<root>"], dtype=np.float64)[..., :3])
    print("%s: %d lit floor pixels" % (name, keep.sum()))
    for who, x in (("Mitsuba 3", np.load(mnpy).astype(np.float64)), ("specula", np.stack(imgs))):
        per = np.array([(xi[keep] / ex[keep]).mean() for xi in x])
        pix = (x.mean(0)[keep] / ex[keep]).mean(-1)
        ys, xs = np.nonzero(keep)
        lo, hi = int(np.argmin(pix)), int(np.argmax(pix))
        print("  %-9s / exact: %.5f +- %.5f; per pixel 5%% %.5f, median %.5f, 95%% %.5f; lowest %.4f at (%d, %d), "
              "highest %.4f at (%d, %d)" % (who, per.mean(), per.std(ddof=1) / np.sqrt(len(per)), np.percentile(pix, 5),
                                            np.median(pix), np.percentile(pix, 95), pix[lo], xs[lo], ys[lo], pix[hi],
                                            xs[hi], ys[hi]))


if __name__ == "__main__":
    main()
