#!/usr/bin/env python3
"""Writes the sdfgrid test grids of scenes/sdfgrid.xml (Mitsuba .vol, one float32 channel).

Values sit on the vertices of [0,1]^3 (vertex i at i / (n - 1)), x fastest, as Mitsuba 3's
sdfgrid reads them; the file's bounding box is unused by sdfgrid (written as the unit box).
  torus.vol   24^3: a torus around local z, major radius 0.3, minor 0.12, centred in the box
  blob.vol    12^3: the union of two spheres (radii 0.3 and 0.22), coarse on purpose: its
              trilinear facets and the smooth normals' blend are visible
  ball.vol    7^3: a sphere of radius 0.4, coarser still (scenes/sdfgrid_normals.xml)
"""
import os
import struct

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def write_vol(path, f):
    nz, ny, nx = f.shape
    with open(path, "wb") as out:
        out.write(b"VOL" + bytes([3]))
        out.write(struct.pack("<i3ii6f", 1, nx, ny, nz, 1, 0, 0, 0, 1, 1, 1))
        out.write(np.ascontiguousarray(f, dtype="<f4").tobytes())


def lattice(n):
    t = np.linspace(0.0, 1.0, n)
    z, y, x = np.meshgrid(t, t, t, indexing="ij")
    return x, y, z


def main():
    x, y, z = lattice(24)
    q = np.hypot(x - 0.5, y - 0.5) - 0.3
    write_vol(os.path.join(HERE, "torus.vol"), np.hypot(q, z - 0.5) - 0.12)
    x, y, z = lattice(12)
    a = np.sqrt((x - 0.4) ** 2 + (y - 0.45) ** 2 + (z - 0.5) ** 2) - 0.3
    b = np.sqrt((x - 0.68) ** 2 + (y - 0.6) ** 2 + (z - 0.45) ** 2) - 0.22
    write_vol(os.path.join(HERE, "blob.vol"), np.minimum(a, b))
    x, y, z = lattice(7)
    write_vol(os.path.join(HERE, "ball.vol"), np.sqrt((x - 0.5) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2) - 0.4)


if __name__ == "__main__":
    main()
