#!/usr/bin/env python3
"""bench/sdf_caustic_scene.py: fresh glass SDF caustic scenes made from scenes/caustic_sdf_torus.xml.

  python3 bench/sdf_caustic_scene.py OUTDIR SEED [SEED ...]

writes OUTDIR/sdf_SEED.xml: the torus's major and tube radii, its tilt, the glass's index (bk7, 1.33
or 1.7) and the sphere light's place and radius (power kept) drawn from the seed; seeds with
SEED % 3 == 2 get a glass capsule or rounded box instead of the torus (a smooth curved SDF that is not
a torus). Same seed, same scene (Python's random).
"""
import math
import os
import random
import re
import sys

src = open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "caustic_sdf_torus.xml")).read()
outdir = sys.argv[1]
for s in map(int, sys.argv[2:]):
    r = random.Random(s)
    R = r.uniform(0.5, 1.0); rr = r.uniform(0.15, 0.35) * R / 0.8
    tilt = r.uniform(0, 40)
    lr = r.uniform(0.05, 0.1)
    lx, ly, lz = r.uniform(-1, 1), r.uniform(2.2, 3.5), r.uniform(-1, 0.5)
    ior = r.choice(["bk7", "1.33", "1.7"])
    if s % 3 == 2:
        if r.random() < 0.5:
            h = r.uniform(0.3, 0.6); rad = r.uniform(0.2, 0.35)
            sdf = '<sdf type="capsule"><point name="p0" x="%.3f" y="0" z="0"/><point name="p1" x="%.3f" y="0" z="0"/><float name="radius" value="%.3f"/></sdf>' % (-h, h, rad)
            low = rad
        else:
            a, b, c, rad = r.uniform(0.3, 0.6), r.uniform(0.2, 0.4), r.uniform(0.3, 0.6), r.uniform(0.12, 0.2)
            sdf = '<sdf type="roundbox"><vector name="size" x="%.3f" y="%.3f" z="%.3f"/><float name="radius" value="%.3f"/></sdf>' % (a, b, c, rad)
            low = 0.7
        ty = low + 0.3
    else:
        sdf = '<sdf type="torus"><float name="major_radius" value="%.3f"/><float name="minor_radius" value="%.3f"/></sdf>' % (R, rr)
        ty = R * math.sin(math.radians(tilt)) + rr + 0.02
    out = re.sub(r'<sdf type="torus">.*?</sdf>', sdf, src, flags=re.S)
    out = out.replace('<rotate x="1" angle="25"/>', '<rotate x="1" angle="%.1f"/>' % tilt)
    out = out.replace('<translate y="0.64"/>', '<translate y="%.3f"/>' % ty)
    out = out.replace('value="bk7"', 'value="%s"' % ior) if ior == "bk7" else out.replace('<string name="int_ior" value="bk7"/>', '<float name="int_ior" value="%s"/>' % ior)
    out = out.replace('x="0.4" y="3.0" z="-0.3"', 'x="%.3f" y="%.3f" z="%.3f"' % (lx, ly, lz))
    out = out.replace('<default name="light_radius" value="0.08"/>', '<default name="light_radius" value="%.3f"/>' % lr)
    sc = (0.08 / lr) ** 2
    out = out.replace('<default name="light_radiance" value="400, 380, 340"/>', '<default name="light_radiance" value="%.1f, %.1f, %.1f"/>' % (400*sc, 380*sc, 340*sc))
    open(os.path.join(outdir, 'sdf_%d.xml' % s), 'w').write(out)
