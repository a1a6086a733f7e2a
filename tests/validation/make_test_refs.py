#!/usr/bin/env python3
"""Render the Mitsuba 3 references that tests/test_mitsuba_refs.c checks specula against.

    python3 tests/validation/make_test_refs.py [--spp 4096] [--passes 32] [NAME ...]

Writes tests/data/mitsuba_refs/NAME.exr (R, G, B and variance.R/G/B: the mean of `passes`
independent Mitsuba 3 scalar_rgb renders and the variance of that mean) for the scenes listed in
REFS, at the resolution given there, with -D integrator=path unless the entry names another. The references are rendered once
and committed, so CI needs no Mitsuba. Keep the list in step with the table in the test.
"""
import argparse
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
OUT = os.path.join(ROOT, "tests", "data", "mitsuba_refs")

# name: (scene file under scenes/, defines). Resolution 32 unless said.
REFS = {
    "shapes": ("shapes.xml", ["res=32"]),
    "textures": ("textures.xml", ["res=32"]),
    "conductors": ("conductors.xml", ["res=32"]),
    "envmap": ("envmap.xml", ["res=32"]),
    "normal_bump": ("normal_bump.xml", ["res=32"]),
    "area_textured": ("area_textured.xml", ["res=32"]),
    "lights": ("lights.xml", ["res=32"]),
    "v06_box": ("v06_box.xml", ["res=32"]),
    "mask_null": ("mask_null.xml", ["res=32"]),
    "dielectrics": ("dielectrics.xml", ["res=32"]),
    "principled": ("principled.xml", ["res=32"]),
    "medium_thin": ("medium_thin.xml", ["res=32", "integrator=volpath"]),
    "medium_grid": ("medium_grid.xml", ["res=32", "integrator=volpath"]),
    "spot_texture": ("spot_texture.xml", ["res=32"]),
    "thinlens": ("thinlens.xml", ["res=32"]),
    "mesh_attribute": ("mesh_attribute.xml", ["res=32"]),
    "projector": ("projector.xml", ["res=32"]),
    "curves": ("curves.xml", ["res=32"]),
    "sdfgrid": ("sdfgrid.xml", ["res=32"]),
    "sdfgrid_normals": ("sdfgrid_normals.xml", ["res=32"]),
}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("names", nargs="*")
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--passes", type=int, default=32)
    a = ap.parse_args()
    os.makedirs(OUT, exist_ok=True)
    for name in a.names or sorted(REFS):
        scene, defs = REFS[name]
        cmd = [sys.executable, os.path.join(HERE, "mitsuba_ref.py"), os.path.join(ROOT, "scenes", scene),
               os.path.join(OUT, name + ".exr"), "--spp", str(a.spp), "--passes", str(a.passes)]
        if not any(d.startswith("integrator=") for d in defs):
            cmd += ["-D", "integrator=path"]
        for d in defs:
            cmd += ["-D", d]
        print(" ".join(cmd), flush=True)
        subprocess.run(cmd, check=True)
    total = sum(os.path.getsize(os.path.join(OUT, f)) for f in os.listdir(OUT))
    print("tests/data/mitsuba_refs: %d bytes" % total)


if __name__ == "__main__":
    sys.exit(main())
