#!/usr/bin/env python3
"""bench/check/crop_scene.py: a copy of a Mitsuba XML scene rendering only a crop of its film, for
per-pixel comparisons of specula and Mitsuba at many samples in a few pixels.

  python3 bench/check/crop_scene.py SCENE.xml OUT.xml --res 160x90 --crop X Y W H [--box]
                                    [--integrator path]

The film's width and height become --res (the scene's $resx/$resy or $res defaults are rewritten, or the
literal values), crop_offset_x/y and crop_width/height are added, --box replaces the reconstruction
filter by a box (one pixel per sample in both renderers: the same estimator of the same pixel), and
the `integrator` default becomes --integrator. Relative paths in the scene are not rewritten: write
OUT next to SCENE, or into a folder of its own for scenes without external files (veach-mis).
"""
import argparse
import re
import sys

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("out")
ap.add_argument("--res", required=True)
ap.add_argument("--crop", type=int, nargs=4, required=True, metavar=("X", "Y", "W", "H"))
ap.add_argument("--box", action="store_true")
ap.add_argument("--integrator", default="path")
a = ap.parse_args()
w, h = (int(v) for v in a.res.split("x"))
s = open(a.scene).read()
s = re.sub(r'(<default name="resx" value=")[^"]*', r"\g<1>%d" % w, s)
s = re.sub(r'(<default name="resy" value=")[^"]*', r"\g<1>%d" % h, s)
# one $res for both sides (the random caustic scenes): only a square --res can keep it
if re.search(r'<default name="res" value=', s):
    if w != h:
        sys.exit("crop_scene.py: the scene has one $res for width and height; give a square --res")
    s = re.sub(r'(<default name="res" value=")[^"]*', r"\g<1>%d" % w, s)
s = re.sub(r'(<default name="integrator" value=")[^"]*', r"\g<1>" + a.integrator, s)
s = re.sub(r'(<integer name="width" value=")(\d+)', r"\g<1>%d" % w, s)
s = re.sub(r'(<integer name="height" value=")(\d+)', r"\g<1>%d" % h, s)
x, y, cw, ch = a.crop
s = re.sub(r'(<integer name="height" value="[^"]*"\s*/>)',
           r'\1\n\t\t\t<integer name="crop_offset_x" value="%d" />\n\t\t\t<integer name="crop_offset_y" value="%d" />'
           r'\n\t\t\t<integer name="crop_width" value="%d" />\n\t\t\t<integer name="crop_height" value="%d" />'
           % (x, y, cw, ch), s, count=1)
if a.box:
    s = re.sub(r'<rfilter type="[^"]*"\s*/>', '<rfilter type="box" />', s)
open(a.out, "w").write(s)
