#!/usr/bin/env python3
"""Mitsuba 3's cost per ray on the rays specula traced: bench_embree_replay.c's files through Mitsuba's scene.

    python3 bench/embree_replay_mitsuba.py SCENE.xml RAYS [--variant llvm_ad_rgb] [--threads 1] [-D name=value ...]

RAYS.isect and RAYS.occl are the rays of a specula render (bench/patches/dump_rays.patch; 8 floats a
ray: origin, direction, tnear, tfar). They are traced with Mitsuba's own queries on the same XML:
intersection rays by scene.ray_intersect_preliminary (Embree's hit and nothing of the surface
interaction), shadow rays by scene.ray_test, as the LLVM variant's kernels call Embree (packets of
the kernel's width, 16 on AVX-512). Mitsuba 3's rays have no tnear (its Embree rays start at 0): a
ray with tnear > 0 (specula's camera rays start at the near clip) starts at that point instead. The time is the process's CPU
time around the evaluation, on the given number of drjit threads, the best of three rounds after a
warm-up that compiles the kernels.
"""
import argparse
import os
import resource
import sys

import numpy as np

LLVM_DEFAULT = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("rays")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("-D", action="append", default=[])
    a = ap.parse_args()
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM_DEFAULT)
    import drjit as dr
    import mitsuba as mi
    mi.set_variant(a.variant)
    dr.set_thread_count(a.threads)
    defs = dict(d.split("=", 1) for d in a.D)
    scene = mi.load_file(a.scene, **defs)
    print("| kind | rays | Mitsuba %s ns/ray | hits |" % a.variant)
    print("|---|---|---|---|")
    for kind in ("isect", "occl"):
        q = np.fromfile(a.rays + "." + kind, dtype=np.float32).reshape(-1, 8)
        # a ray that starts at tnear > 0 (the camera's near clip) starts at its point there instead
        t0 = q[:, 6:7]
        o = q[:, 0:3] + t0 * q[:, 3:6]
        o = mi.Point3f(o[:, 0], o[:, 1], o[:, 2])
        d = mi.Vector3f(q[:, 3], q[:, 4], q[:, 5])
        maxt = mi.Float(np.minimum(q[:, 7] - q[:, 6], np.float32(3.0e38)))
        best, hits = 1e30, 0
        for rnd in range(4):
            ray = mi.Ray3f(o, d, maxt, 0.0, mi.Color0f() if hasattr(mi, "Color0f") else [])
            dr.eval(ray)
            c0 = cpu()
            if kind == "isect":
                pi = scene.ray_intersect_preliminary(ray)
                hit = pi.is_valid()
            else:
                hit = scene.ray_test(ray)
            dr.eval(hit)
            n = int(dr.count(hit)[0]) if hasattr(dr.count(hit), '__getitem__') else int(dr.count(hit))
            dt = cpu() - c0
            if rnd > 0:
                best = min(best, dt)
            hits = n
        print("| %s | %d | %.1f | %d |" % (kind, q.shape[0], 1e9 * best / q.shape[0], hits), flush=True)


if __name__ == "__main__":
    sys.exit(main())
