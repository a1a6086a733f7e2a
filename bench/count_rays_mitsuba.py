#!/usr/bin/env python3
"""Rays per camera sample of Mitsuba 3's `path` integrator rule, counted, against specula's counters.

    python3 bench/count_rays_mitsuba.py [--specula build/specula] [--spp 16] [--scale S] [scene.xml ...]

Mitsuba has no ray counter, so this script runs the rule of its path integrator (src/integrators/
path.cpp, read for this count) as a loop over arrays of the LLVM variant, with Mitsuba's own scene
queries: one extension ray per live path per bounce; at a vertex that may continue (depth + 1 <
max_depth, a valid hit) with a smooth BSDF, one emitter sample whose shadow ray is traced when its
pdf is not zero (Scene::sample_emitter_direction); BSDF sampling; after the bounce depth += 1 and,
from depth >= rr_depth (5), Russian roulette with q = min(max(throughput) * eta^2, 0.95); a path
ends when its throughput is zero. The random numbers are a PCG32 stream per sample, not Mitsuba's
sampler: the counts are expectations, so any independent numbers give them.

specula's counts come from its --stats JSON (rays_traced, shadow_rays) on the same XML, resolution
and spp. Prints both per camera sample, then the distribution of path lengths under Mitsuba's rule
(the share of samples by their number of extension rays).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))
LLVM_DEFAULT = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
DEFAULT_SCENES = (("cornell-box", 0.25), ("veach-mis", 0.25))


def defaults_of(path):
    text = open(path, encoding="utf-8").read()
    return dict(re.findall(r'<default\s+name="([a-zA-Z_]+)"\s+value="([^"]*)"', text))


def mitsuba_counts(mi, dr, path, defs, spp, max_depth, rr_depth=5):
    scene = mi.load_file(path, **defs)
    sensor = scene.sensors()[0]
    w, h = sensor.film().crop_size()
    n = w * h * spp
    idx = dr.arange(mi.UInt32, n)
    rng = mi.PCG32(size=n, initstate=mi.UInt64(idx))
    pix = idx // spp
    pos = mi.Vector2f(mi.Float(pix % w), mi.Float(pix // w))
    pos += mi.Vector2f(rng.next_float32(), rng.next_float32())
    ray, _ = sensor.sample_ray(0.0, rng.next_float32(), pos / mi.Vector2f(w, h),
                               mi.Point2f(rng.next_float32(), rng.next_float32()))
    ray = mi.Ray3f(ray)
    active = mi.Bool(True)
    depth = mi.UInt32(0)
    throughput = mi.Spectrum(1.0)
    eta = mi.Float(1.0)
    ext = mi.UInt32(0)
    shadow = mi.UInt32(0)
    ctx = mi.BSDFContext()
    for _ in range(10000):
        ext += dr.select(active, 1, 0)
        si = scene.ray_intersect(ray, active)
        active_next = active & (depth + 1 < (max_depth if max_depth >= 0 else 2**31)) & si.is_valid()
        if not dr.any(active_next):
            break
        bsdf = si.bsdf(ray)
        active_em = active_next & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
        ds, _ = scene.sample_emitter_direction(si, mi.Point2f(rng.next_float32(), rng.next_float32()), False,
                                               active_em)
        shadow += dr.select(active_em & (ds.pdf != 0.0), 1, 0)
        bs, weight = bsdf.sample(ctx, si, rng.next_float32(), mi.Point2f(rng.next_float32(), rng.next_float32()),
                                 active_next)
        throughput = dr.select(active_next, throughput * weight, throughput)
        eta = dr.select(active_next, eta * bs.eta, eta)
        ray = mi.Ray3f(dr.select(active_next, si.spawn_ray(si.to_world(bs.wo)), ray))
        depth = dr.select(active_next, depth + 1, depth)
        tmax = dr.max(throughput)
        q = dr.minimum(tmax * eta * eta, 0.95)
        rr_active = depth >= rr_depth
        rr_continue = rng.next_float32() < q
        throughput = dr.select(active_next & rr_active, throughput / q, throughput)
        active = active_next & (~rr_active | rr_continue) & (tmax != 0.0)
        dr.eval(ray, active, depth, throughput, eta, ext, shadow, rng)
    import numpy as np
    hist = np.bincount(np.array(ext, dtype=np.int64)) / n
    return dr.sum(ext)[0] / n, dr.sum(shadow)[0] / n, (w, h), hist


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--specula", default=os.path.join(ROOT, "build", "specula"))
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--scale", type=float, default=None)
    a = ap.parse_args()
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM_DEFAULT)
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    scenes = [(p, a.scale or 1.0) for p in a.scenes] or [
        (os.path.join("/work/shared/scenes", s, "scene.xml"), a.scale or f) for s, f in DEFAULT_SCENES]
    print("| scene | resolution | spp | max_depth | specula extension / sample | Mitsuba extension / sample "
          "| specula shadow / sample | Mitsuba shadow / sample |")
    print("|---|---|---|---|---|---|---|---|")
    hists = []
    for path, scale in scenes:
        d = defaults_of(path)
        defs = {"integrator": "path"}
        if "resx" in d:
            defs["resx"] = str(int(int(d["resx"]) * scale))
            defs["resy"] = str(int(int(d["resy"]) * scale))
        max_depth = int(d.get("max_depth", -1))
        me, ms, (w, h), hist = mitsuba_counts(mi, dr, path, defs, a.spp, max_depth)
        hists.append((path, hist))
        with tempfile.TemporaryDirectory() as tmp:
            st = os.path.join(tmp, "stats.json")
            dflags = sum((["-D", "%s=%s" % kv] for kv in defs.items()), [])
            subprocess.run([a.specula, "render", path, "-o", os.path.join(tmp, "out.exr"), "--spp", str(a.spp),
                            "--quiet", "--stats", st] + dflags, check=True)
            j = json.load(open(st))
        n = j["width"] * j["height"] * j["spp"]
        se = (j["rays_traced"] - j["shadow_rays"]) / n
        ss = j["shadow_rays"] / n
        name = os.path.basename(os.path.dirname(path)) if path.endswith("scene.xml") else os.path.basename(path)
        print("| %s | %dx%d | %d | %d | %.4f | %.4f | %.4f | %.4f |" % (name, w, h, a.spp, max_depth, se, me, ss, ms),
              flush=True)
    # the path lengths under Mitsuba's rule: the share of samples with k rays traced for extension (the
    # camera ray included), k = 1, 2, ...; the tail beyond 12 summed
    print("\nMitsuba's rule, share of samples by extension rays (camera ray included):")
    for path, hist in hists:
        name = os.path.basename(os.path.dirname(path)) if path.endswith("scene.xml") else os.path.basename(path)
        cells = ["%d: %.4f" % (k, hist[k]) for k in range(1, min(len(hist), 13))]
        if len(hist) > 13:
            cells.append(">12: %.5f (longest %d)" % (hist[13:].sum(), len(hist) - 1))
        print("%s  %s" % (name, ", ".join(cells)))


if __name__ == "__main__":
    sys.exit(main())
