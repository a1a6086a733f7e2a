#!/usr/bin/env python3
"""Writes scenes/meshes/conic_bunny.obj: a closed, irregular, non-convex "bunny-like" glass mesh
for the conic solver's validation scene (scenes/conic_bunny.xml).

    python3 tests/validation/make_conic_bunny.py [--level 4] [--out scenes/meshes/conic_bunny.obj]

An icosphere (level subdivisions: 20 * 4^level triangles, shared vertices, so the surface is
watertight) displaced radially, r(d) = body(d) * (1 + head + ears - dents + ripple): an
ellipsoidal body, a head lump, two ear lumps, two dents on the flanks and a low-frequency ripple,
so no symmetry plane and concave regions where one interface has several specular solutions.
Vertex normals are the area-weighted means of the adjacent face normals (smooth shading, what an
exported scan would carry). The mesh is placed with its lowest point 0.002 above y = 0 (the
floor of the scene). Deterministic: no random numbers.
"""
import argparse
import math
import os


def icosphere(level):
    t = (1.0 + 5 ** 0.5) / 2.0
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
             (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [normalize(v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
             (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(level):
        mid = {}

        def midpoint(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                va, vb = verts[a], verts[b]
                verts.append(normalize(((va[0] + vb[0]) / 2, (va[1] + vb[1]) / 2, (va[2] + vb[2]) / 2)))
                mid[key] = len(verts) - 1
            return mid[key]

        nf = []
        for a, b, c in faces:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = nf
    return verts, faces


def normalize(v):
    l = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    return (v[0] / l, v[1] / l, v[2] / l)


def lump(d, axis, width):
    """exp(-angle^2 / width^2) around the unit direction axis."""
    c = max(-1.0, min(1.0, d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]))
    a = math.acos(c)
    return math.exp(-(a / width) ** 2)


def radius(d):
    # ellipsoidal body, longer along x, flatter along y
    body = 1.0 / math.sqrt((d[0] / 0.50) ** 2 + (d[1] / 0.36) ** 2 + (d[2] / 0.40) ** 2)
    head = 0.45 * lump(d, normalize((0.75, 0.6, 0.1)), 0.45)
    ears = 0.55 * lump(d, normalize((0.35, 1.0, 0.25)), 0.16) + 0.45 * lump(d, normalize((0.45, 1.0, -0.2)), 0.14)
    dents = 0.18 * lump(d, normalize((-0.2, 0.15, 1.0)), 0.35) + 0.12 * lump(d, normalize((-0.6, 0.3, -0.8)), 0.3)
    ripple = 0.04 * math.sin(5.0 * d[0] + 1.3) * math.cos(4.0 * d[2] - 0.4) + 0.03 * math.sin(6.0 * d[1] + 2.0 * d[2])
    return body * (1.0 + head + ears - dents + ripple)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--level", type=int, default=4)
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--out", default=os.path.join(here, "..", "..", "scenes", "meshes", "conic_bunny.obj"))
    a = ap.parse_args()
    dirs, faces = icosphere(a.level)
    pos = [tuple(r * c for c in d) for d, r in ((d, radius(d)) for d in dirs)]
    ymin = min(p[1] for p in pos)
    pos = [(p[0], p[1] - ymin + 0.002, p[2]) for p in pos]
    nrm = [[0.0, 0.0, 0.0] for _ in pos]
    for f in faces:
        p0, p1, p2 = (pos[i] for i in f)
        e1 = [p1[k] - p0[k] for k in range(3)]
        e2 = [p2[k] - p0[k] for k in range(3)]
        n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
        for i in f:  # area weighted: the cross product is twice the area
            for k in range(3):
                nrm[i][k] += n[k]
    with open(a.out, "w", encoding="utf-8") as out:
        out.write("# conic_bunny: tests/validation/make_conic_bunny.py --level %d (%d triangles)\n" % (a.level, len(faces)))
        for p in pos:
            out.write("v %.6f %.6f %.6f\n" % p)
        for n in nrm:
            n = normalize(n)
            out.write("vn %.6f %.6f %.6f\n" % n)
        for f in faces:
            # icosphere faces wind counter-clockwise seen from outside: outward geometric normals
            out.write("f %d//%d %d//%d %d//%d\n" % (f[0] + 1, f[0] + 1, f[1] + 1, f[1] + 1, f[2] + 1, f[2] + 1))
    print("wrote %s: %d vertices, %d triangles" % (a.out, len(pos), len(faces)))


if __name__ == "__main__":
    main()
