#!/usr/bin/env python3
"""Render time of one big triangle mesh: specula against Mitsuba 3 at equal spp.

    python3 bench/bench_mesh_render.py [--tris 1000000] [--res 256] [--spp 16] [--dir /tmp/mesh_render]
                                       [bench_vs_mitsuba.py options, e.g. --specula build/specula --repeats 2]

Writes bench_mesh_scale.py's bumpy height field (binary PLY, float positions, face normals) under its
rectangle light, with the film size as a `res` default (max_depth 3, the path tracer), then times
both renderers on it with bench_vs_mitsuba.py (CPU seconds of the render, specula's including the
load and the BVH build).
"""
import argparse
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import bench_mesh_scale  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tris", type=int, default=1000000)
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--dir", default="/tmp/mesh_render")
    a, rest = ap.parse_known_args()
    os.makedirs(a.dir, exist_ok=True)
    k = max(1, int(round((a.tris / 2) ** 0.5)))
    ply = os.path.join(a.dir, "grid_%d.ply" % k)
    if not os.path.exists(ply):
        bench_mesh_scale.write_grid_ply(ply, k)
    xml = bench_mesh_scale.SCENE.format(ply=ply)
    xml = xml.replace('<scene version="3.0.0">', '<scene version="3.0.0">\n  <default name="res" value="%d"/>\n'
                      '  <default name="integrator" value="path"/>' % a.res)
    xml = xml.replace('<integrator type="path">', '<integrator type="$integrator">')
    xml = xml.replace('name="width" value="32"', 'name="width" value="$res"')
    xml = xml.replace('name="height" value="32"', 'name="height" value="$res"')
    path = os.path.join(a.dir, "mesh_%d.xml" % (2 * k * k))
    with open(path, "w") as f:
        f.write(xml)
    sys.exit(subprocess.call([sys.executable, os.path.join(HERE, "bench_vs_mitsuba.py"), path, "--spp", str(a.spp)]
                             + rest))


if __name__ == "__main__":
    main()
