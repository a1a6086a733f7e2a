#!/usr/bin/env python3
"""bench/check/pixel_footprint.py: how much of one pixel's per-sample variance is its footprint's,
which no estimator that starts its paths at the camera can remove.

  python3 bench/check/pixel_footprint.py SCENE.xml X Y [--res 32] [--sub 16] [--spp 256]
                                         [--setting S] [--seed 5] [--specula build/specula]

A camera sample draws its film position uniformly in the pixel (box filter), so the pixel's variance
per sample is the mean over its area of the variance of a sample at a fixed position (the estimator's
own: light sampling, specular NEE, BSDF sampling) plus the variance of the radiance over the area
(the footprint's: a caustic's focus or a light's image smaller than the pixel). The second part is
the same for path tracing with or without specular NEE; only strategies that reach the film from the
light side (light tracing, bdpt) change it. The script renders pixel (X, Y) of the film at --res as
--sub x --sub subpixels (the film at res * sub, cropped as bench/check/crop_scene.py does; the copy
of the scene is written next to SCENE so that its relative paths hold, the image into a temporary
folder) with --variance, and prints the pixel's mean, the subpixels' coefficient of variation (the
footprint's relative standard deviation per sample), the mean relative standard deviation per sample
within a subpixel (the estimator's at that scale, itself partly the subpixel's footprint: raise --sub
until the share settles), and the footprint's share of the pixel's per-sample variance. The
subpixels' spread is counted less the variance of their means, so that a few samples per subpixel do
not read as footprint.
"""
import argparse
import os
import re
import shutil
import subprocess
import tempfile

import numpy as np


def read(path):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    ch = dict(mi.Bitmap(path).split())
    return (np.array(ch["<root>"]).astype(np.float64)[..., :3].mean(-1),
            np.array(ch["variance"]).astype(np.float64)[..., :3].mean(-1))


def crop_xml(scene, out, res, x, y, w, h):
    s = open(scene).read()
    s = re.sub(r'(<integer name="width" value=")[^"]*', r"\g<1>%d" % res, s)
    s = re.sub(r'(<integer name="height" value=")[^"]*', r"\g<1>%d" % res, s)
    s = re.sub(r'(<integer name="height" value="[^"]*"\s*/>)',
               r'\1<integer name="crop_offset_x" value="%d"/><integer name="crop_offset_y" value="%d"/>'
               r'<integer name="crop_width" value="%d"/><integer name="crop_height" value="%d"/>' % (x, y, w, h),
               s, count=1)
    s = re.sub(r'<rfilter type="[^"]*"\s*/>', '<rfilter type="box"/>', s)
    open(out, "w").write(s)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("x", type=int)
    ap.add_argument("y", type=int)
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--sub", type=int, default=16)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--setting", default=None, help="a --specular-nee value (default: the plan's)")
    ap.add_argument("--seed", type=int, default=5)
    ap.add_argument("--specula", default=os.path.join(os.path.dirname(__file__), "..", "..", "build", "specula"))
    a = ap.parse_args()
    base = os.path.splitext(a.scene)[0]
    tmp = tempfile.mkdtemp(prefix="footprint_")
    xml, exr = base + "_footprint.xml", os.path.join(tmp, "footprint.exr")
    crop_xml(a.scene, xml, a.res * a.sub, a.x * a.sub, a.y * a.sub, a.sub, a.sub)
    cmd = [a.specula, "render", xml, "-o", exr, "--spp", str(a.spp), "--seed", str(a.seed), "--threads", "1",
           "--variance", "--quiet"]
    if a.setting:
        cmd += ["--specular-nee", a.setting]
    try:
        subprocess.run(cmd, check=True)
        img, var = read(exr)
    finally:
        os.remove(xml)
        shutil.rmtree(tmp)
    m = img.mean()
    # the radiance's variance over the pixel's area: the subpixel means' spread less their own noise
    foot = max(img.var() - var.mean(), 0.0)
    own = (var * a.spp).mean()       # a sample's variance at a fixed subpixel, averaged over them
    rel_own = np.mean(np.sqrt(var * a.spp) / np.maximum(img, 1e-12))
    print("pixel (%d, %d) at %dx%d: mean %.4g over %dx%d subpixels at %d spp" % (a.x, a.y, a.res, a.res, m, a.sub,
                                                                              a.sub, a.spp))
    print("footprint: relative sd per sample %.3g (subpixels' CV; max subpixel %.3g)" % (np.sqrt(foot) / m,
                                                                                         img.max()))
    print("within subpixels: mean relative sd per sample %.3g" % rel_own)
    print("per-sample relative sd of the pixel %.3g, the footprint's share of its variance %.2f" % (
        np.sqrt(foot + own) / m, foot / (foot + own)))


if __name__ == "__main__":
    main()
