#!/usr/bin/env python3
"""Load time and memory of one big triangle mesh: specula against Mitsuba 3, 10 thousand to 10 million
triangles.

    python3 bench/bench_mesh_scale.py [--specula build/specula] [--variant llvm_ad_rgb]
                                      [--tris 10000,100000,1000000,10000000] [--dir /tmp/mesh_scale]
                                      [--render RES:SPP] [--base OTHER_SPECULA]

Each mesh is a bumpy height field (a k x k grid of quads, two triangles each, positions as float,
no normals or uvs) in a binary PLY, under a rectangle light, seen by a 32x32 camera. For each size
both renderers run in a fresh process that loads the scene (reading the PLY, building the BVH) and
renders 1 spp at 32x32 (so the time is the load's); /usr/bin/time gives the process's wall and CPU
seconds and its peak resident memory. A process with the smallest mesh (2 triangles) is the
baseline whose memory is subtracted: the "extra" columns are what the mesh costs. Mitsuba runs as
`python3 -c` (mi.load_file + mi.render); since its process also imports Python modules and compiles
kernels, the load itself is measured inside it too (CPU seconds and resident memory added across
mi.load_file). One thread each (specula --threads 1,
dr.set_thread_count(1)): the BVH builds' own threading would otherwise make the numbers depend on
what else runs on the machine.

--render RES:SPP adds the render at equal spp (RES x RES, max_depth 3, one thread each, CPU
seconds): for specula a second process at that size, less the CPU seconds of its 1-spp 32x32
process (so the load is not counted twice), for Mitsuba a second process that loads, renders once
at 1 spp (the kernels' compilation) and times a second mi.render at SPP. --base OTHER_SPECULA runs
a second specula binary the same way in the same loop (load, memory and render), so a change is
measured before and after in one run; the processes alternate per size.
"""
import argparse
import os
import subprocess
import sys

import numpy as np

LLVM_DEFAULT = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))

# The height field under a small square light that faces it (turned down: a rectangle faces +z), so
# that both renderers shade the mesh and trace shadow rays, not only extension rays.
SCENE = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="3"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0, -2.2, 1.6" target="0, 0, 0" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sample_count" value="1"/></sampler>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
  </sensor>
  <shape type="ply"><string name="filename" value="{ply}"/><boolean name="face_normals" value="true"/>
    <bsdf type="diffuse"/></shape>
  <shape type="rectangle">
    <transform name="to_world"><scale value="0.3"/><rotate x="1" angle="180"/><translate value="0, 0, 2"/></transform>
    <emitter type="area"><rgb name="radiance" value="20"/></emitter>
  </shape>
</scene>
"""


def write_grid_ply(path, k):
    """A k x k grid of quads over [-1, 1]^2 with a bumpy height: 2 k^2 triangles."""
    n = k + 1
    x, y = np.meshgrid(np.linspace(-1, 1, n, dtype=np.float64), np.linspace(-1, 1, n, dtype=np.float64))
    z = 0.05 * np.sin(7 * x) * np.cos(5 * y)
    verts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1).astype("<f4")
    i = np.arange(k, dtype=np.int64)
    a = (i[None, :] + n * i[:, None]).ravel()
    quads = np.stack([a, a + 1, a + n + 1, a + n], axis=1)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=0).astype("<i4")
    faces = np.empty(len(tris), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"] = 3
    faces["i"] = tris
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                 "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n"
                 % (len(verts), len(tris))).encode())
        f.write(verts.tobytes())
        f.write(faces.tobytes())
    return len(tris)


def timed(cmd, env=None):
    """(wall s, CPU s, peak RSS MiB, stdout) of one process, from /usr/bin/time."""
    r = subprocess.run(["/usr/bin/time", "-f", "TIME %e %U %S %M"] + cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise RuntimeError("%s failed: %s" % (cmd[0], r.stderr[-2000:]))
    line = [l for l in r.stderr.splitlines() if l.startswith("TIME ")][-1].split()
    return float(line[1]), float(line[2]) + float(line[3]), float(line[4]) / 1024.0, r.stdout


def mitsuba_load(out):
    """(load CPU s, resident MiB added by the load) printed by the Mitsuba child."""
    f = [l for l in out.splitlines() if l.startswith("MI ")][-1].split()
    return float(f[1]), float(f[2])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--tris", default="10000,100000,1000000,10000000")
    ap.add_argument("--dir", default="/tmp/mesh_scale")
    ap.add_argument("--render", default=None, help="RES:SPP, the render at equal spp")
    ap.add_argument("--base", default=None, help="a second specula binary timed in the same loop")
    a = ap.parse_args()
    res, spp = (int(x) for x in a.render.split(":")) if a.render else (0, 0)
    os.makedirs(a.dir, exist_ok=True)
    env = dict(os.environ)
    if "llvm" in a.variant and "DRJIT_LIBLLVM_PATH" not in env and os.path.exists(LLVM_DEFAULT):
        env["DRJIT_LIBLLVM_PATH"] = LLVM_DEFAULT
    # Mitsuba in its own process: the load's CPU seconds and resident memory measured around
    # mi.load_file (the process's import and JIT compilation are not the mesh's), then one render
    mitsuba = ("import os, resource, sys, drjit as dr, mitsuba as mi\n"
               "def rss(): return int(open('/proc/self/statm').read().split()[1]) * os.sysconf('SC_PAGE_SIZE') / 2**20\n"
               "def cpu(): r = resource.getrusage(resource.RUSAGE_SELF); return r.ru_utime + r.ru_stime\n"
               "mi.set_variant('%s'); dr.set_thread_count(1)\n"
               "r0, c0 = rss(), cpu(); scene = mi.load_file(sys.argv[1]); r1, c1 = rss(), cpu()\n"
               "img = mi.render(scene, spp=1); dr.eval(img)\n"
               "print('MI %%.3f %%.1f' %% (c1 - c0, r1 - r0))\n"
               "if len(sys.argv) > 2:\n"
               "    c2 = cpu(); img = mi.render(scene, spp=int(sys.argv[2])); dr.eval(img); dr.sync_thread()\n"
               "    print('MR %%.3f' %% (cpu() - c2))\n" % a.variant)
    binaries = [("specula", a.specula)] + ([("base", a.base)] if a.base else [])
    sizes = [1] + [int(t) for t in a.tris.split(",")]
    rows = []
    base = None
    for target in sizes:
        k = max(1, int(round((target / 2) ** 0.5)))
        ply = os.path.join(a.dir, "grid_%d.ply" % k)
        xml = os.path.join(a.dir, "grid_%d.xml" % k)
        ntris = 2 * k * k
        if not os.path.exists(ply):
            write_grid_ply(ply, k)
        with open(xml, "w") as f:
            f.write(SCENE.format(ply=ply))
        sp = {}
        for name, binary in binaries:
            sp[name] = timed([binary, "render", xml, "--spp", "1", "--threads", "1", "--quiet", "-o",
                              os.path.join(a.dir, "out.exr")])
        m = timed([sys.executable, "-c", mitsuba, xml], env=env)
        ml = mitsuba_load(m[3])
        s = sp["specula"]
        if base is None:
            base = (s, m, {n: v[2] for n, v in sp.items()})
            print("baseline (2 triangles): specula %.2f CPU-s %.0f MiB; Mitsuba process %.2f CPU-s %.0f MiB, load %.2f CPU-s"
                  % (s[1], s[2], m[1], m[2], ml[0]), flush=True)
            continue
        rend = {}
        if res:
            rxml = os.path.join(a.dir, "grid_%d_%d.xml" % (k, res))
            with open(rxml, "w") as f:
                f.write(SCENE.format(ply=ply).replace('value="32"', 'value="%d"' % res))
            for name, binary in binaries:
                r = timed([binary, "render", rxml, "--spp", str(spp), "--threads", "1", "--quiet", "-o",
                           os.path.join(a.dir, "out_%s.exr" % name)])
                rend[name] = r[1] - sp[name][1]
            mr = timed([sys.executable, "-c", mitsuba, rxml, str(spp)], env=env)
            rend["mitsuba"] = float([l for l in mr[3].splitlines() if l.startswith("MR ")][-1].split()[1])
        rows.append((ntris, os.path.getsize(ply) / 2**20, sp, m, ml, rend))
        print("%9d tris: specula wall %.2f s CPU %.2f s RSS %.0f MiB | Mitsuba process wall %.2f s CPU %.2f s RSS %.0f MiB,"
              " load_file CPU %.2f s +%.0f MiB" % (ntris, s[0], s[1], s[2], m[0], m[1], m[2], ml[0], ml[1]), flush=True)
        for name in sp:
            if name != "specula":
                print("           %s: CPU %.2f s RSS %.0f MiB" % (name, sp[name][1], sp[name][2]), flush=True)
        if rend:
            print("           render %dx%d %d spp, CPU s: %s" % (res, res, spp, ", ".join(
                "%s %.2f" % kv for kv in rend.items())), flush=True)
    print()
    print("One thread each. specula: the whole process (load + 32x32 at 1 spp), extra = its peak RSS minus the"
          " 2-triangle scene's (%.0f MiB). Mitsuba %s: CPU seconds and resident memory added across mi.load_file"
          " in the process, and its process peak minus the 2-triangle one's (%.0f MiB)." % (base[0][2], a.variant,
                                                                                          base[1][2]))
    print()
    print("| triangles | PLY (MiB) | specula CPU (s) | specula extra peak RSS (MiB) | bytes/tri | Mitsuba load CPU (s) "
          "| Mitsuba load RSS (MiB) | bytes/tri | Mitsuba extra peak RSS (MiB) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for ntris, mb, sp, m, ml, rend in rows:
        s = sp["specula"]
        ds, dm = s[2] - base[0][2], m[2] - base[1][2]
        print("| %d | %.1f | %.2f | %.0f | %.0f | %.2f | %.0f | %.0f | %.0f |" % (
            ntris, mb, s[1], ds, ds * 2**20 / ntris, ml[0], ml[1], ml[1] * 2**20 / ntris, dm))
    if a.base:
        print()
        print("| triangles | base CPU (s) | this CPU (s) | base extra peak RSS (MiB) | this extra peak RSS (MiB) |")
        print("|---|---|---|---|---|")
        for ntris, mb, sp, m, ml, rend in rows:
            print("| %d | %.2f | %.2f | %.0f | %.0f |" % (ntris, sp["base"][1], sp["specula"][1],
                                                     sp["base"][2] - base[2]["base"], sp["specula"][2] - base[2]["specula"]))
    if res:
        print()
        cols = [n for n, _ in binaries]
        print("Render %dx%d at %d spp, one thread, CPU s (specula: its process less its 1-spp 32x32 one; Mitsuba: "
              "mi.render after a warm-up)" % (res, res, spp))
        print("| triangles | " + " | ".join("%s (s)" % c for c in cols) + " | Mitsuba (s) | "
              + " | ".join("%s / Mitsuba" % c for c in cols) + " |")
        print("|---" * (2 + 2 * len(cols)) + "|")
        for ntris, mb, sp, m, ml, rend in rows:
            print("| %d | " % ntris + " | ".join("%.2f" % rend[c] for c in cols) + " | %.2f | " % rend["mitsuba"]
                  + " | ".join("%.2f" % (rend[c] / rend["mitsuba"]) for c in cols) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
