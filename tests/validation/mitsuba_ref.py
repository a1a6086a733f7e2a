#!/usr/bin/env python3
"""Render a reference mean and per-pixel variance of the mean with Mitsuba 3.

    python3 tests/validation/mitsuba_ref.py SCENE.xml OUT.exr --spp 1024 --passes 16 [-D name=value]...

The image is the mean of `passes` independent renders (different seeds) of spp/passes samples
each; the variance of the mean is estimated from the spread of the passes, so `specula diff` can run
per-pixel z-tests against it. Channels: R, G, B, variance.R, variance.G, variance.B.
"""
import argparse
import os
import re
import sys

import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--passes", type=int, default=16)
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("-D", action="append", default=[])
    ap.add_argument("--res", help="WxH: the film's width and height instead of the scene's")
    a = ap.parse_args()
    import mitsuba as mi

    mi.set_variant(a.variant)
    defs = {}
    for d in a.D:
        k, v = d.split("=", 1)
        defs[k] = v
    text = open(a.scene, encoding="utf-8").read()
    # Mitsuba 3 upgrades 0.x property names but not the <lookAt> tag; and it refuses properties
    # only specula reads (specular NEE settings, mis_balance, caustic flags). Such files are edited in memory
    # and loaded with the scene's folder on the file resolver (for relative paths).
    edited = text.replace("<lookAt", "<lookat")
    if a.res:
        w, h = a.res.lower().split("x")
        edited = re.sub(r'(<integer\s+name="width"\s+value=")[^"]*(")', r"\g<1>%s\g<2>" % w, edited)
        edited = re.sub(r'(<integer\s+name="height"\s+value=")[^"]*(")', r"\g<1>%s\g<2>" % h, edited)
    edited = re.sub(r'<(string|integer|boolean)\s+name="(specular_nee|specular_max_chain|mis_balance|caustic_caster|'
                    r'caustic_receiver|caustic_caster_single|caustic_caster_multi)"[^>]*/>', "", edited)
    if edited != text:
        mi.file_resolver().prepend(os.path.dirname(os.path.abspath(a.scene)))
        scene = mi.load_string(edited, **defs)
    else:
        scene = mi.load_file(a.scene, **defs)
    per = max(1, a.spp // a.passes)
    imgs = []
    for i in range(a.passes):
        img = np.array(mi.render(scene, seed=1000 + i, spp=per), dtype=np.float64)[:, :, :3]
        imgs.append(img)
    stack = np.stack(imgs)
    mean = stack.mean(axis=0)
    var = stack.var(axis=0, ddof=1) / a.passes if a.passes > 1 else np.zeros_like(mean)
    out = np.concatenate([mean, var], axis=2).astype(np.float32)
    bmp = mi.Bitmap(out, channel_names=["R", "G", "B", "variance.R", "variance.G", "variance.B"])
    bmp.write(a.out)
    print(f"{a.out}: {a.passes} passes x {per} spp, mean {mean.mean(axis=(0, 1))}")


if __name__ == "__main__":
    sys.exit(main())
