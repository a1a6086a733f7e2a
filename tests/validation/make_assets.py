#!/usr/bin/env python3
"""Generate the meshes and textures of the validation scenes (scenes/meshes, scenes/textures).

    python3 tests/validation/make_assets.py [--out scenes]

Everything here is made from formulas (no downloaded data), so the files are ours to commit.
Meshes: an icosphere with vertex normals and uvs (OBJ), a quad with uvs written as one polygon
(OBJ), a torus in ASCII PLY (normals, uvs), a wobbly sphere in binary little-endian PLY
(normals), two shapes in one Mitsuba .serialized file (version 4: a cone and a prism).
Textures: an 8-bit sRGB PNG grid, a JPEG of colored blobs, a float EXR gradient, a raw PNG normal
map of water waves, a PNG height field for bump mapping, a PNG opacity mask, a lat-long EXR sky
with a bright sun, and an emission EXR for textured area lights. Images are written with
Mitsuba's Bitmap (the only image writer at hand), everything else with the standard library.
"""
import argparse
import math
import os
import struct
import sys
import zlib

import numpy as np


# ------------------------------------------------------------------------------------------------
# meshes

def icosphere(level):
    t = (1.0 + 5 ** 0.5) / 2.0
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [np.array(p, dtype=np.float64) / np.linalg.norm(p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    for _ in range(level):
        cache = {}

        def mid(a, b):
            k = (min(a, b), max(a, b))
            if k not in cache:
                p = v[a] + v[b]
                v.append(p / np.linalg.norm(p))
                cache[k] = len(v) - 1
            return cache[k]

        nf = []
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return np.array(v), f


def write_icosphere_obj(path):
    v, f = icosphere(2)
    with open(path, "w") as out:
        out.write("# icosphere (2 subdivisions), unit radius, vertex normals = positions\n")
        for p in v:
            out.write("v %.6f %.6f %.6f\n" % tuple(p))
        for p in v:
            out.write("vn %.6f %.6f %.6f\n" % tuple(p))
        # uv from the position, per vertex (a seam is not needed for a checker of period 1/8)
        for p in v:
            u = 0.5 + math.atan2(p[0], p[2]) / (2 * math.pi)
            w = 0.5 - math.asin(max(-1.0, min(1.0, p[1]))) / math.pi
            out.write("vt %.6f %.6f\n" % (u, w))
        for a, b, c in f:
            out.write("f %d/%d/%d %d/%d/%d %d/%d/%d\n" % (a + 1, a + 1, a + 1, b + 1, b + 1, b + 1, c + 1, c + 1, c + 1))


def write_quad_obj(path):
    with open(path, "w") as out:
        out.write("# a unit quad in z = 0 facing +z, written as one 4-gon with uvs\n")
        out.write("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n")
        out.write("vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n")
        out.write("vn 0 0 1\n")
        out.write("f 1/1/1 2/2/1 3/3/1 4/4/1\n")


def torus(R, r, nu, nv):
    verts, norms, uvs, faces = [], [], [], []
    for i in range(nu + 1):
        u = i / nu
        a = 2 * math.pi * u
        for j in range(nv + 1):
            w = j / nv
            b = 2 * math.pi * w
            c = np.array([math.cos(a), math.sin(a), 0.0])
            n = c * math.cos(b) + np.array([0, 0, 1.0]) * math.sin(b)
            verts.append(c * R + n * r)
            norms.append(n)
            uvs.append((u, w))
    for i in range(nu):
        for j in range(nv):
            a = i * (nv + 1) + j
            b = (i + 1) * (nv + 1) + j
            faces.append((a, b, b + 1))  # Mitsuba 3's PLY loader takes triangles only
            faces.append((a, b + 1, a + 1))
    return verts, norms, uvs, faces


def write_torus_ply_ascii(path):
    v, n, uv, f = torus(0.7, 0.28, 24, 12)
    with open(path, "w") as out:
        out.write("ply\nformat ascii 1.0\ncomment torus R 0.7 r 0.28\n")
        out.write("element vertex %d\n" % len(v))
        for p in ("x", "y", "z", "nx", "ny", "nz", "u", "v"):
            out.write("property float %s\n" % p)
        out.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(f))
        for p, q, t in zip(v, n, uv):
            out.write("%.6f %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n" % (*p, *q, *t))
        for q in f:
            out.write("3 %d %d %d\n" % q)


def write_blob_ply_binary(path):
    v, f = icosphere(3)
    # a smooth radial wobble; normals from the mesh (area-weighted) so they match the surface
    r = 1.0 + 0.12 * np.sin(3 * v[:, 0]) * np.sin(3 * v[:, 1] + 1.0) * np.cos(2 * v[:, 2])
    p = v * r[:, None]
    nrm = np.zeros_like(p)
    for a, b, c in f:
        fn = np.cross(p[b] - p[a], p[c] - p[a])
        nrm[a] += fn
        nrm[b] += fn
        nrm[c] += fn
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    with open(path, "wb") as out:
        hdr = ("ply\nformat binary_little_endian 1.0\ncomment wobbly sphere\nelement vertex %d\n"
               "property float x\nproperty float y\nproperty float z\n"
               "property float nx\nproperty float ny\nproperty float nz\n"
               "element face %d\nproperty list uchar uint vertex_indices\nend_header\n") % (len(p), len(f))
        out.write(hdr.encode("ascii"))
        for q, m in zip(p, nrm):
            out.write(struct.pack("<6f", *q, *m))
        for a, b, c in f:
            out.write(struct.pack("<BIII", 3, a, b, c))


def serialized_record(name, verts, faces, normals=None, uvs=None):
    flags = 0x1000  # single precision
    if normals is not None:
        flags |= 0x0001
    if uvs is not None:
        flags |= 0x0002
    body = struct.pack("<I", flags) + name.encode("utf-8") + b"\0"
    body += struct.pack("<QQ", len(verts), len(faces))
    body += np.asarray(verts, dtype="<f4").tobytes()
    if normals is not None:
        body += np.asarray(normals, dtype="<f4").tobytes()
    if uvs is not None:
        body += np.asarray(uvs, dtype="<f4").tobytes()
    body += np.asarray(faces, dtype="<u4").tobytes()
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(body)


def write_serialized(path):
    # shape 0: a cone (apex up) with flat-shaded sides (no normals: face normals)
    n = 24
    verts = [(0.0, 0.0, 1.0)]
    for i in range(n):
        a = 2 * math.pi * i / n
        verts.append((math.cos(a), math.sin(a), 0.0))
    verts.append((0.0, 0.0, 0.0))
    faces = []
    for i in range(n):
        a, b = 1 + i, 1 + (i + 1) % n
        faces.append((0, a, b))
        faces.append((n + 1, b, a))
    rec0 = serialized_record("cone", verts, faces)
    # shape 1: a triangular prism with per-vertex normals and uvs (smooth sides)
    verts, norms, uvs, faces = [], [], [], []
    for k in range(3):
        a = 2 * math.pi * k / 3 + math.pi / 2
        c = (math.cos(a), math.sin(a))
        for z in (0.0, 1.0):
            verts.append((0.6 * c[0], 0.6 * c[1], z))
            norms.append((c[0], c[1], 0.0))
            uvs.append((k / 3.0, z))
    for k in range(3):
        a0, a1 = 2 * k, 2 * k + 1
        b0, b1 = 2 * ((k + 1) % 3), 2 * ((k + 1) % 3) + 1
        faces.append((a0, b0, b1))
        faces.append((a0, b1, a1))
    rec1 = serialized_record("prism", verts, faces, norms, uvs)
    with open(path, "wb") as out:
        out.write(rec0)
        off1 = out.tell()
        out.write(rec1)
        out.write(struct.pack("<QQI", 0, off1, 2))


# ------------------------------------------------------------------------------------------------
# textures

def write_bitmap(path, img, srgb):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    arr = np.ascontiguousarray(img)
    if path.endswith(".exr"):
        bmp = mi.Bitmap(np.ascontiguousarray(arr.astype(np.float32)), pixel_format=mi.Bitmap.PixelFormat.RGB)
        bmp.write(path)
        return
    bmp = mi.Bitmap(np.ascontiguousarray(np.clip(np.round(arr * 255.0), 0, 255).astype(np.uint8)),
                    pixel_format=mi.Bitmap.PixelFormat.RGB)
    bmp.set_srgb_gamma(srgb)
    if path.endswith(".jpg"):
        bmp.write(path, quality=95)
    else:
        bmp.write(path)


def textures(out):
    ys, xs = np.mgrid[0:32, 0:32] + 0.5
    # grid.png: sRGB, a red/blue gradient with white grid lines every 8 texels and a marker in the
    # top-left corner (so a flipped or mirrored image shows)
    g = np.zeros((32, 32, 3))
    g[..., 0] = xs / 32.0
    g[..., 2] = ys / 32.0
    g[..., 1] = 0.15
    g[(xs.astype(int) % 8 == 0) | (ys.astype(int) % 8 == 0)] = 0.9
    g[1:7, 1:7] = (1.0, 1.0, 0.0)
    write_bitmap(os.path.join(out, "grid.png"), g, True)
    # blobs.jpg: soft colored blobs (JPEG artifacts stay small on smooth content)
    h, w = 32, 48
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    b = np.full((h, w, 3), 0.1)
    for cx, cy, rad, col in ((12, 10, 8, (0.9, 0.3, 0.1)), (34, 20, 10, (0.1, 0.6, 0.9)), (20, 26, 6, (0.3, 0.9, 0.2))):
        wgt = np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * rad * rad))[..., None]
        b += wgt * np.array(col)
    write_bitmap(os.path.join(out, "blobs.jpg"), np.clip(b, 0, 1), True)
    # ramp.exr: linear float values, a diagonal ramp with values above 1 in one corner
    h, w = 16, 16
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    r = np.stack([xx / w * 1.5, yy / h, 0.2 + 0.6 * ((xx + yy) % 4 < 2)], axis=2)
    write_bitmap(os.path.join(out, "ramp.exr"), r, False)
    # waves_normal.png: raw (linear) tangent-space normals of a height field of summed waves
    n = 64
    yy, xx = np.mgrid[0:n, 0:n] / n
    k = 2 * math.pi
    amp = 0.03
    # height h = amp * (sin(2 k x) + sin(k (x + 2 y)) + 0.5 sin(3 k y)), tileable on [0,1]^2
    hx = amp * (2 * k * np.cos(2 * k * xx) + k * np.cos(k * (xx + 2 * yy)))
    hy = amp * (2 * k * np.cos(k * (xx + 2 * yy)) + 1.5 * k * np.cos(3 * k * yy))
    nn = np.stack([-hx, -hy, np.ones_like(hx)], axis=2)
    nn /= np.linalg.norm(nn, axis=2)[..., None]
    write_bitmap(os.path.join(out, "waves_normal.png"), nn * 0.5 + 0.5, False)
    # bumps.png: raw height field of round bumps (0..1)
    n = 32
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    hgt = 0.5 + 0.5 * np.sin(2 * math.pi * xx / 16) * np.sin(2 * math.pi * yy / 16)
    write_bitmap(os.path.join(out, "bumps.png"), np.repeat(hgt[..., None], 3, axis=2), False)
    # mask.png: raw opacity, a disk of 1 with a ring of 0.5 on 0
    n = 32
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    d = np.hypot(xx - 16, yy - 16)
    m = np.where(d < 7, 1.0, np.where(d < 12, 0.5, 0.0))
    m[(xx.astype(int) // 4) % 2 == 0] *= 0.8
    write_bitmap(os.path.join(out, "mask.png"), np.repeat(m[..., None], 3, axis=2), False)
    # sky.exr: lat-long 64x32 sky: blue above, brown ground below the horizon, a small bright
    # warm sun at (u, v) = (0.3, 0.25) and a cool spot at (0.8, 0.4) so orientation errors show
    h, w = 32, 64
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    v = yy / h
    u = xx / w
    sky = np.where((v < 0.5)[..., None], np.stack([0.3 + 0.4 * v, 0.5 + 0.4 * v, np.full_like(v, 1.0)], 2),
                   np.stack([0.25 * np.ones_like(v), 0.18 * np.ones_like(v), 0.1 * np.ones_like(v)], 2))
    sky = sky.copy()
    sun = (np.abs(xx - 0.3 * w) < 1.6) & (np.abs(yy - 0.25 * h) < 1.6)
    sky[sun] = (60.0, 50.0, 35.0)
    spot = (np.abs(xx - 0.8 * w) < 2.5) & (np.abs(yy - 0.4 * h) < 1.5)
    sky[spot] = (2.0, 6.0, 12.0)
    write_bitmap(os.path.join(out, "sky.exr"), sky, False)
    # emit.exr: emission texture for area lights: mostly dark, a few bright cells of different
    # colors (so sampling in proportion to texels matters)
    h, w = 16, 16
    e = np.full((h, w, 3), 0.05)
    e[2:5, 3:6] = (40.0, 20.0, 5.0)
    e[10:12, 11:14] = (5.0, 15.0, 40.0)
    e[12:15, 2:4] = (10.0, 30.0, 10.0)
    write_bitmap(os.path.join(out, "emit.exr"), e, False)
    # emit.png: an 8-bit emission pattern (sRGB decoded), stripes
    h, w = 8, 8
    p = np.zeros((h, w, 3))
    p[:, ::2] = (1.0, 0.8, 0.5)
    p[0:2, :] = (0.2, 0.4, 1.0)
    write_bitmap(os.path.join(out, "emit.png"), p, True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "..", "scenes"))
    a = ap.parse_args()
    md = os.path.join(a.out, "meshes")
    td = os.path.join(a.out, "textures")
    os.makedirs(md, exist_ok=True)
    os.makedirs(td, exist_ok=True)
    write_icosphere_obj(os.path.join(md, "icosphere.obj"))
    write_quad_obj(os.path.join(md, "quad.obj"))
    write_torus_ply_ascii(os.path.join(md, "torus_ascii.ply"))
    write_blob_ply_binary(os.path.join(md, "blob_binary.ply"))
    write_serialized(os.path.join(md, "cone_prism.serialized"))
    textures(td)
    for d in (md, td):
        for f in sorted(os.listdir(d)):
            print("%-40s %7d bytes" % (os.path.join(d, f), os.path.getsize(os.path.join(d, f))))


if __name__ == "__main__":
    sys.exit(main())
