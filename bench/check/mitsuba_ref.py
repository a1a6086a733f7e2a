#!/usr/bin/env python3
"""bench/check/mitsuba_ref.py: a Mitsuba 3 reference as batches, for per-pixel Welch tests
(bench/check/cmp_ref.py).

  python3 bench/check/mitsuba_ref.py SCENE.xml OUT.npy [--batches 32] [--spp 8192] [--res 32]
                                     [--max-depth 4] [--integrator path|volpath|ptracer]
                                     [-D name=value]...

Renders --batches independent images of --spp samples each with the llvm_ad_rgb variant (scalar_rgb
if LLVM is missing) and saves them as one array, batches x height x width x 3; the per-pixel
variance of the mean comes from the batches.

Which integrator: the one named here replaces the scene's, so a scene with media needs `volpath`.
`path` (the scene's own kind) finds a small light's reflection in a glass ball only when a BSDF
sample from the floor lands on the light's tiny image in the ball (about once in 1e5 samples for
random caustic scene 2); at 524k spp most floor pixels still have none, so its
per-pixel mean is low there with a batch variance that does not show it, and any estimator that
gets that reflection right fails a per-pixel test against it (bench/RESULTS.md, "Reflections off
glass: no bias"). `ptracer` (light tracing, every path connected to the camera at its last
diffuse vertex) reaches that reflection from the light and is the reference for pixels that see a
diffuse surface directly; it renders nothing seen through glass or in a mirror, so compare only
those pixels (cmp_ref.py --floor).

`normal` (Mitsuba's aov integrator, nn:sh_normal) renders the shading normal of the first surface
the camera ray hits, delta surfaces included, as the mask for that comparison: specula's normal AOV
looks through glass and mirrors (OIDN's convention), so it would keep pixels that see the floor
through a glass ball or in a mirror, which ptracer cannot render.
"""
import argparse
import os
import re
import sys
import time

import numpy as np

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--batches", type=int, default=32)
    ap.add_argument("--spp", type=int, default=8192)
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--max-depth", type=int, default=4)
    ap.add_argument("--integrator", default="path", choices=["path", "volpath", "ptracer", "normal"])
    ap.add_argument("-D", action="append", default=[], help="name=value: a <default> of the scene")
    ap.add_argument("--threads", type=int, default=0, help="Dr.Jit's worker threads (0: all cores)")
    ap.add_argument("--crop", default="", help="X,Y,W,H: render only this window of the --res film "
                    "(hdrfilm's crop), e.g. a few failing pixels at millions of spp; the array is "
                    "batches x H x W x 3")
    ap.add_argument("--first-batch", type=int, default=0,
                    help="number of the first batch: its seed, so that runs with disjoint batch "
                    "ranges are independent and can be concatenated")
    ap.add_argument("--seed0", type=int, default=-1,
                    help="batch b's seed is SEED0 + b (default: 7919 (FIRST_BATCH + b + 1))")
    a = ap.parse_args()
    if a.threads > 0:
        dr.set_thread_count(a.threads)
    try:
        mi.set_variant("llvm_ad_rgb")
    except Exception:
        mi.set_variant("scalar_rgb")
    params = dict(kv.split("=", 1) for kv in a.D)
    params.update(res=a.res, spp=a.spp, max_depth=a.max_depth)
    # Mitsuba refuses parameters the scene does not use (a scene with a fixed max_depth, say) and
    # properties only specula reads (specular NEE settings): those are dropped, and an edited file
    # is loaded with its folder on the file resolver (for relative paths).
    text = open(a.scene).read()
    params = {k: v for k, v in params.items() if re.search(r"\$" + k + r"\b", text)}
    if a.crop:
        cx, cy, cw, ch = (int(v) for v in a.crop.split(","))
        text = re.sub(r'(<film type="hdrfilm">)', r'\1<integer name="crop_offset_x" value="%d"/>'
                      r'<integer name="crop_offset_y" value="%d"/><integer name="crop_width" value="%d"/>'
                      r'<integer name="crop_height" value="%d"/>' % (cx, cy, cw, ch), text, count=1)
    edited = re.sub(r'<(string|integer|boolean|float)\s+name="(specular_nee|specular_max_chain|mis_balance|'
                    r'caustic_caster|caustic_receiver|caustic_caster_single|caustic_caster_multi)"[^>]*/>',
                    "", text)
    if a.crop or edited != text:
        mi.file_resolver().prepend(os.path.dirname(os.path.abspath(a.scene)))
        scene = mi.load_string(edited, **params)
    else:
        scene = mi.load_file(a.scene, **params)
    if a.integrator == "normal":
        integrator = mi.load_dict({"type": "aov", "aovs": "nn:sh_normal"})
    else:
        integrator = mi.load_dict({"type": a.integrator, "max_depth": a.max_depth})
    imgs = []
    t0 = time.time()
    for b in range(a.batches):
        img = mi.render(scene, integrator=integrator, seed=(a.seed0 + b if a.seed0 >= 0 else
                                                            7919 * (a.first_batch + b + 1)), spp=a.spp)
        imgs.append(np.array(img)[:, :, :3])
        print("batch %d/%d, %.0f s" % (b + 1, a.batches, time.time() - t0), file=sys.stderr, flush=True)
    np.save(a.out, np.stack(imgs))


if __name__ == "__main__":
    main()
