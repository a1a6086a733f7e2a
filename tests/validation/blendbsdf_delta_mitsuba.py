#!/usr/bin/env python3
"""Mitsuba 3's blendbsdf with a smooth (delta) component: is its sample() unbiased?

    python3 tests/validation/blendbsdf_delta_mitsuba.py [--n 20000]

At one surface point and one incident direction, the mean of sample()'s weight estimates the
directional albedo. For a blend with weight w of BSDFs with albedos a0 and a1 it must be
(1 - w) a0 + w a1, whatever the components. Printed: each component's estimate, the blend's, the
expected mixture, and one delta sample of the blend (its pdf and weight): a blend that mixes the
smooth component's density into the delta sample's (pdf (1 - w) pdf0(wo) + w instead of w) lowers
the delta lobe's weight, and the blend's albedo falls below the mixture.
"""
import argparse

import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=20000)
    ap.add_argument("--weight", type=float, default=0.5)
    a = ap.parse_args()
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    print("Mitsuba", mi.__version__)
    diffuse = {"type": "diffuse"}
    gold = {"type": "conductor", "material": "Au"}
    si = mi.SurfaceInteraction3f()
    si.n = [0, 0, 1]
    si.sh_frame = mi.Frame3f([0, 0, 1])
    si.wi = mi.Vector3f(0.6, 0, 0.8)
    ctx = mi.BSDFContext()
    rng = np.random.default_rng(1)

    def albedo(d):
        b = mi.load_dict(d)
        tot = np.zeros(3)
        for _ in range(a.n):
            _, w = b.sample(ctx, si, rng.random(), [rng.random(), rng.random()])
            tot += np.array(w)
        return tot / a.n

    a0, a1 = albedo(diffuse), albedo(gold)
    blend = {"type": "blendbsdf", "weight": a.weight, "a": diffuse, "b": gold}
    ab = albedo(blend)
    expect = (1 - a.weight) * a0 + a.weight * a1
    print("diffuse alone    ", a0)
    print("conductor alone  ", a1)
    print("blend            ", ab)
    print("(1-w) a0 + w a1  ", expect, " blend / expected", ab / expect)
    bs, w = mi.load_dict(blend).sample(ctx, si, 0.5 * a.weight, [0.3, 0.6])
    print("a delta sample of the blend: pdf %.4f (w = %.4f), weight %s (the conductor's alone: %s)"
          % (bs.pdf, a.weight, w, mi.load_dict(gold).sample(ctx, si, 0.5, [0.3, 0.6])[1]))


if __name__ == "__main__":
    main()
