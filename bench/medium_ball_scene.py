#!/usr/bin/env python3
"""bench/medium_ball_scene.py: fresh scenes of scenes/medium_glass.xml's kind (volpath: a scattering
medium inside a tessellated glass ball, lit through the glass by a small area light), drawn from a
seed, for equal-CPU runs of the default against none (bench_default.py).

  python3 bench/medium_ball_scene.py OUTDIR SEED [SEED ...]

Each seed writes OUTDIR/medium_ball_SEED.xml: the ball is scenes/meshes/icosphere.obj (320 faces)
or bench/check/glass_ball_mesh.obj (a UV sphere of 2208 faces), scaled to radius 0.6-1.0, glass of
index 1.33-1.6; the homogeneous medium inside has sigma_t 0.6-2.4 per unit length (each channel
drawn), albedo 0.7-0.95 per channel, Henyey-Greenstein g 0-0.7; a square light of half-size
0.12-0.25 at distance 2.2-3.2 from the ball, 20-70 degrees from the vertical, radiance scaled so
that its power is the medium_glass light's; half of the seeds add a grey diffuse floor under the
ball. The mesh paths are absolute (the scene may be written anywhere). The draws are printed.
"""
import math
import os
import random
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))
MESHES = [(os.path.join(ROOT, "scenes", "meshes", "icosphere.obj"), 1.0),
          (os.path.join(ROOT, "bench", "check", "glass_ball_mesh.obj"), 0.5)]


def scene(seed):
    r = random.Random(seed)
    mesh, r0 = MESHES[r.randrange(2)]
    R = r.uniform(0.6, 1.0)
    ior = r.uniform(1.33, 1.6)
    st = [r.uniform(0.6, 2.4) for _ in range(3)]
    smax = max(st)
    alb = [r.uniform(0.7, 0.95) for _ in range(3)]
    g = r.uniform(0.0, 0.7)
    half = r.uniform(0.12, 0.25)
    dist = r.uniform(2.2, 3.2)
    tilt = math.radians(r.uniform(20, 70))
    az = r.uniform(0, 2 * math.pi)
    lx, ly, lz = dist * math.sin(tilt) * math.cos(az), dist * math.cos(tilt), dist * math.sin(tilt) * math.sin(az)
    radiance = 250.0 * (0.2 / half) ** 2
    floor = r.random() < 0.5
    # the light faces the ball: the rectangle's normal (+z) turned to point from the light to the centre
    dx, dy, dz = -lx / dist, -ly / dist, -lz / dist
    # a lookat for the light: origin at the light, target the ball's centre
    info = "mesh %s R %.3f ior %.3f sigma_t (%.2f %.2f %.2f) albedo (%.2f %.2f %.2f) g %.2f light half %.3f at (%.2f %.2f %.2f) floor %d" % (
        os.path.basename(mesh), R, ior, *st, *alb, g, half, lx, ly, lz, floor)
    s = """<?xml version="1.0"?>
<!-- bench/medium_ball_scene.py seed %d: %s -->
<scene version="3.0.0">
    <default name="spp" value="64"/>
    <default name="res" value="256"/>
    <default name="integrator" value="volpath"/>
    <default name="max_depth" value="-1"/>
    <integrator type="$integrator">
        <integer name="max_depth" value="$max_depth"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="35"/>
        <transform name="to_world">
            <lookat origin="0, %.4f, %.4f" target="0, 0.05, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="$res"/>
            <integer name="height" value="$res"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <medium type="homogeneous" id="inside">
        <rgb name="albedo" value="%.4f, %.4f, %.4f"/>
        <rgb name="sigma_t" value="%.6f, %.6f, %.6f"/>
        <float name="scale" value="%.6f"/>
        <phase type="hg">
            <float name="g" value="%.4f"/>
        </phase>
    </medium>
    <shape type="obj" id="glass">
        <string name="filename" value="%s"/>
        <transform name="to_world"><scale value="%.6f"/></transform>
        <bsdf type="dielectric">
            <float name="int_ior" value="%.4f"/>
            <float name="ext_ior" value="1.0"/>
        </bsdf>
        <ref name="interior" id="inside"/>
    </shape>
    <shape type="rectangle" id="light">
        <transform name="to_world"><scale value="%.4f"/><lookat origin="%.4f, %.4f, %.4f" target="0, 0, 0" up="0, 0, 1"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="%.4f"/></emitter>
    </shape>
""" % (seed, info, 1.4 * R / 1.0 + 0.2, 4.6 * R, *alb, st[0] / smax, st[1] / smax, st[2] / smax, smax, g, mesh,
       R / r0, ior, half, lx, ly, lz, radiance)
    if floor:
        s += """    <shape type="rectangle" id="floor">
        <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><translate y="%.4f"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </shape>
""" % (-R - 0.001)
    s += "</scene>\n"
    return s, info


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    for a in sys.argv[2:]:
        seed = int(a)
        s, info = scene(seed)
        path = os.path.join(out, "medium_ball_%d.xml" % seed)
        with open(path, "w") as f:
            f.write(s)
        print(path, info)


if __name__ == "__main__":
    main()
