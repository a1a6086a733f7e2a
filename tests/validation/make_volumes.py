#!/usr/bin/env python3
"""Generate the volume grids of the validation scenes (scenes/textures/*.vol), from formulas.

    python3 tests/validation/make_volumes.py [--out scenes/textures]

cloud.vol: 12 x 10 x 8 cells, 1 channel: a lumpy blob of density (0 at the edges, up to about
3), a dense knot in one corner, so that trilinear interpolation and the grid's anisotropic cells
matter. tint.vol: 5 x 6 x 4 cells, 3 channels in [0.2, 1]: an albedo that varies along each
axis. Both in Mitsuba's .vol format (version 3, float32, little endian).
"""
import argparse
import os
import struct
import sys

import numpy as np


def write_vol(path, data):
    """data[z, y, x] or data[z, y, x, c]"""
    zres, yres, xres = data.shape[:3]
    ch = 1 if data.ndim == 3 else data.shape[3]
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]))
        f.write(struct.pack("<iiiii", 1, xres, yres, zres, ch))
        f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(np.ascontiguousarray(data, dtype="<f4").tobytes())


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.normpath(os.path.join(here, "..", "..", "scenes", "textures")))
    a = ap.parse_args()
    z, y, x = np.meshgrid((np.arange(8) + 0.5) / 8, (np.arange(10) + 0.5) / 10, (np.arange(12) + 0.5) / 12,
                          indexing="ij")
    r2 = ((x - 0.5) / 0.45) ** 2 + ((y - 0.5) / 0.45) ** 2 + ((z - 0.5) / 0.45) ** 2
    cloud = np.clip(1.0 - r2, 0, None) * (2.0 + np.sin(9 * x) * np.cos(7 * y + 2 * z))
    cloud[(x > 0.7) & (y > 0.6) & (z < 0.4)] += 2.5
    write_vol(os.path.join(a.out, "cloud.vol"), cloud)
    z, y, x = np.meshgrid((np.arange(4) + 0.5) / 4, (np.arange(6) + 0.5) / 6, (np.arange(5) + 0.5) / 5,
                          indexing="ij")
    tint = np.stack([0.6 + 0.4 * np.cos(5 * x), 0.6 + 0.4 * np.sin(4 * y + 1), 0.2 + 0.8 * z], axis=-1)
    write_vol(os.path.join(a.out, "tint.vol"), np.clip(tint, 0.2, 1.0))
    print("wrote cloud.vol, tint.vol to", a.out)


if __name__ == "__main__":
    sys.exit(main())
