#!/usr/bin/env python3
"""Tabulate Mitsuba 3's principled and principledthin BSDFs for tests/test_principled.c.

    python3 tests/validation/make_principled_values.py

Writes tests/data/principled_mitsuba.txt: for each configuration a line
    config K THIN base_r base_g base_b roughness anisotropic metallic spec_trans spec_tint sheen
           sheen_tint flatness clearcoat clearcoat_gloss eta diff_trans
and then lines
    K MODE wi_x wi_y wi_z wo_x wo_y wo_z f_r f_g f_b pdf
with Mitsuba's (scalar_rgb) eval, which includes the cosine of wo, and pdf, for local directions
(Mitsuba's wi toward the viewer, wo toward the light; MODE 0 radiance, 1 importance). A third of
the pairs are near-specular reflections, so the glossy lobes are exercised where they are large.
Configurations with eta given use `eta`; principled ones without use the same value through
`specular` (eta = 2 / (1 - sqrt(0.08 specular)) - 1), which the loader test covers separately.
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.normpath(os.path.join(HERE, "..", "data", "principled_mitsuba.txt"))
KEYS = ["roughness", "anisotropic", "metallic", "spec_trans", "spec_tint", "sheen", "sheen_tint", "flatness",
        "clearcoat", "clearcoat_gloss", "eta", "diff_trans"]
DEFAULTS = {"roughness": 0.5, "eta": 1.5}

CONFIGS = [
    (False, [0.2, 0.8, 0.1], dict(roughness=0.15, anisotropic=0.8, metallic=0.7, clearcoat=0.9, sheen=0.2,
                                  eta=1.7)),
    (False, [0.7, 0.3, 0.5], dict(roughness=0.4, spec_trans=0.6, metallic=0.1, spec_tint=0.5, sheen=0.5,
                                  sheen_tint=0.7, flatness=0.4, clearcoat=0.3, clearcoat_gloss=0.6, eta=1.33)),
    (False, [0.5, 0.5, 0.5], dict(roughness=0.7, spec_trans=1.0, eta=1.5)),
    (False, [0.9, 0.6, 0.3], dict(roughness=0.05, metallic=1.0, anisotropic=0.3, eta=1.45)),
    (True, [0.7, 0.1, 0.1], dict(anisotropic=0.05, spec_trans=0.2, diff_trans=1.4, sheen=0.8, eta=1.33)),
    (True, [0.3, 0.6, 0.2], dict(roughness=0.3, anisotropic=0.5, spec_trans=0.7, diff_trans=0.4, sheen=0.1,
                                 spec_tint=0.6, sheen_tint=0.3, flatness=0.5, eta=1.6)),
]
PAIRS = 24


def main():
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    rng = np.random.default_rng(7)

    def unit():
        v = rng.normal(size=3)
        return v / np.linalg.norm(v)

    lines = []
    for k, (thin, base, prm) in enumerate(CONFIGS):
        d = {"type": "principledthin" if thin else "principled", "base_color": {"type": "rgb", "value": base}}
        d.update(prm)
        b = mi.load_dict(d)
        vals = [prm.get(key, DEFAULTS.get(key, 0.0)) for key in KEYS]
        lines.append("config %d %d %s %s" % (k, int(thin), " ".join("%.9g" % c for c in base),
                                              " ".join("%.9g" % v for v in vals)))
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
        si.n = mi.Normal3f(0, 0, 1)
        si.uv = mi.Point2f(0.3, 0.4)
        ctx = mi.BSDFContext()
        for mode in (0, 1):
            ctx.mode = mi.TransportMode.Radiance if mode == 0 else mi.TransportMode.Importance
            for n in range(PAIRS):
                wi, wo = unit(), unit()
                if n < PAIRS // 2:
                    wi[2] = abs(wi[2])  # most from the front
                if n < PAIRS // 3:
                    h = unit()
                    h[2] = abs(h[2]) + 1.0
                    h /= np.linalg.norm(h)
                    wo = 2.0 * np.dot(wi, h) * h - wi
                si.wi = mi.Vector3f(*wi)
                f = b.eval(ctx, si, mi.Vector3f(*wo))
                p = b.pdf(ctx, si, mi.Vector3f(*wo))
                lines.append("%d %d %s %s %.9g %.9g %.9g %.9g" % (k, mode, " ".join("%.17g" % c for c in wi),
                                                               " ".join("%.17g" % c for c in wo), f[0], f[1], f[2],
                                                               p))
    with open(OUT, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    print("%s: %d lines" % (OUT, len(lines)))


if __name__ == "__main__":
    sys.exit(main())
