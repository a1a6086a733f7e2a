#!/usr/bin/env python3
"""bench/check/hand_caustic_scenes.py: six caustic scenes written by hand, of the kinds that
random_caustic_scene.py (/work/shared/tools) makes rarely, for the default against Mitsuba 3 on
scenes nobody tuned it for (bench/RESULTS.md, "Fresh caustic scenes at main 2fa744f").

  python3 bench/check/hand_caustic_scenes.py OUTDIR

writes OUTDIR/hb_ball_small.xml (a glass ball under a small sphere light, no sky), hb_slabs3.xml
(three separated tilted glass slabs), hb_triball_square.xml (a glass ball of smooth-shaded
triangles under a square light, with its OBJ), hb_gold_ring.xml (a short gold mirror ring: a
reflected caustic), hb_spot_ball_slab.xml (a spot light through a glass ball and a slab: a delta
light, which Mitsuba's path tracer cannot render through glass; compare with its ptracer) and
hb_flatmirror_ball.xml (a glass ball before an upright flat mirror). Only plugins both Mitsuba 3 and
specula read. Uses random_caustic_scene.py's sphere mesh writer.
"""
import os, sys
sys.path.insert(0, os.environ.get("SPC_TOOLS", "/work/shared/tools"))
from random_caustic_scene import uv_sphere_obj

out = sys.argv[1]
HEAD = '''<scene version="3.0.0">
  <!-- %s -->
  <default name="spp" value="64"/>
  <default name="res" value="64"/>
  <default name="max_depth" value="%d"/>
  <integrator type="path"><integer name="max_depth" value="$max_depth"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="%g"/>
    <transform name="to_world"><lookat origin="%s" target="%s" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
    <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/><rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.55, 0.55, 0.52"/></bsdf>
  </shape>
'''
GL = '<bsdf type="dielectric"><float name="int_ior" value="%.2f"/><float name="ext_ior" value="1.0"/></bsdf>'

def cube(sx, sy, sz, rx, ry, tx, ty, tz, ior):
    return ('  <shape type="cube"><transform name="to_world"><scale x="%g" y="%g" z="%g"/><rotate x="1" angle="%g"/>'
            '<rotate y="1" angle="%g"/><translate x="%g" y="%g" z="%g"/></transform>%s</shape>\n'
            % (sx, sy, sz, rx, ry, tx, ty, tz, GL % ior))

def sphere_light(x, y, z, r, rad):
    return ('  <shape type="sphere"><point name="center" x="%g" y="%g" z="%g"/><float name="radius" value="%g"/>'
            '<emitter type="area"><rgb name="radiance" value="%g, %g, %g"/></emitter></shape>\n'
            % (x, y, z, r, rad, rad * 0.95, rad * 0.88))

scenes = {}
# 1. a glass ball under a small sphere light, no sky
scenes["hb_ball_small"] = (HEAD % ("a glass ball IOR 1.45 r 0.38 under a sphere light r 0.025, no sky", 8, 36,
                                   "-2.4, 2.9, -2.6", "0, 0.25, 0")
    + '  <shape type="sphere"><point name="center" x="-0.1" y="0.38" z="0.2"/><float name="radius" value="0.38"/>%s</shape>\n' % (GL % 1.45)
    + sphere_light(1.1, 2.6, -0.7, 0.025, 9000) + '</scene>\n')
# 2. three separated glass slabs at different heights and tilts, sphere light, no sky
scenes["hb_slabs3"] = (HEAD % ("three separated tilted glass slabs, sphere light r 0.06, no sky", 12, 40,
                               "2.8, 3.2, -2.2", "0, 0.3, 0")
    + cube(0.35, 0.05, 0.30, 12, 20, -0.6, 0.9, 0.2, 1.5)
    + cube(0.30, 0.06, 0.25, -9, 65, 0.5, 1.1, -0.3, 1.6)
    + cube(0.28, 0.04, 0.32, 5, -30, 0.2, 0.6, 0.7, 1.45)
    + sphere_light(0.1, 3.0, -0.2, 0.06, 3000) + '</scene>\n')
# 3. a glass ball of smooth-shaded triangles under a square light, no sky
uv_sphere_obj(os.path.join(out, "hb_triball_square_ball.obj"), 0.42, 28, 14)
scenes["hb_triball_square"] = (HEAD % ("a glass ball of 756 smooth-shaded triangles, IOR 1.5, under a square light, no sky", 8, 36,
                                       "2.9, 2.6, 2.0", "0, 0.25, 0")
    + '  <shape type="obj"><string name="filename" value="hb_triball_square_ball.obj"/><transform name="to_world"><translate x="0.1" y="0.42" z="-0.1"/></transform>%s</shape>\n' % (GL % 1.5)
    + '  <shape type="rectangle"><transform name="to_world"><scale value="0.08"/><lookat origin="-1.2, 2.7, 0.9" target="0, 0, 0" up="0, 1, 0.01"/></transform><emitter type="area"><rgb name="radiance" value="1800, 1710, 1580"/></emitter></shape>\n'
    + '</scene>\n')
# 4. a mirror object with a reflected caustic: a short gold mirror ring, the light low beside it
scenes["hb_gold_ring"] = (HEAD % ("a short open gold mirror cylinder r 0.55 h 0.3, sphere light r 0.04 low beside it, dim sky: the cardioid inside", 8, 34,
                                  "0.3, 3.4, -2.6", "0, 0, 0.1")
    + '  <emitter type="constant"><rgb name="radiance" value="0.02, 0.02, 0.025"/></emitter>\n'
    + '  <shape type="cylinder"><point name="p0" x="0" y="0" z="0"/><point name="p1" x="0" y="0.3" z="0"/><float name="radius" value="0.55"/><bsdf type="twosided"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></bsdf></shape>\n'
    + sphere_light(-1.4, 1.1, -0.9, 0.04, 6000) + '</scene>\n')
# 5. a delta light: a spot light aimed at a glass ball beside a tilted slab, no sky
scenes["hb_spot_ball_slab"] = (HEAD % ("a spot light aimed at a glass ball IOR 1.6 beside a tilted glass slab, no sky", 10, 40,
                                       "-2.6, 3.0, 2.4", "0, 0.3, 0")
    + '  <shape type="sphere"><point name="center" x="0.3" y="0.35" z="0.1"/><float name="radius" value="0.35"/>%s</shape>\n' % (GL % 1.6)
    + cube(0.3, 0.04, 0.25, 15, 30, -0.45, 0.75, -0.3, 1.5)
    + '  <emitter type="spot"><transform name="to_world"><lookat origin="1.2, 2.9, -1.4" target="0.0, 0.4, 0.0" up="0, 1, 0"/></transform><float name="cutoff_angle" value="25"/><float name="beam_width" value="18"/><rgb name="intensity" value="40, 38, 35"/></emitter>\n'
    + '</scene>\n')
for k, v in scenes.items():
    open(os.path.join(out, k + ".xml"), "w").write(v)
# 6. a glass ball in front of an upright flat mirror (the unfolded enumeration's class), light in front
s6 = (HEAD % ("a glass ball IOR 1.6 r 0.35 before an upright flat twosided mirror tilted 25 degrees, sphere light r 0.05 in front, no sky", 8, 42,
              "-2.2, 2.6, -3.2", "0, 0.35, 0.2")
      + '  <shape type="rectangle"><transform name="to_world"><scale x="0.8" y="0.55"/><rotate y="1" angle="-25"/><translate x="0.1" y="0.56" z="1.1"/></transform><bsdf type="twosided"><bsdf type="conductor"/></bsdf></shape>\n'
      + '  <shape type="sphere"><point name="center" x="-0.15" y="0.35" z="0.45"/><float name="radius" value="0.35"/>%s</shape>\n' % (GL % 1.6)
      + sphere_light(-0.5, 2.2, -1.0, 0.05, 2500) + '</scene>\n')
open(os.path.join(out, "hb_flatmirror_ball.xml"), "w").write(s6)
