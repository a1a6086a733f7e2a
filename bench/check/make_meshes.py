#!/usr/bin/env python3
"""bench/check/make_meshes.py: the meshes of the check scenes, written beside this script.

  python3 bench/check/make_meshes.py

- glass_ball_mesh.obj: a UV sphere of radius 0.5 (48 x 24 quads as triangles) with unit vertex
  normals, centred at the origin (glass_ball_mesh.xml moves it).
- mirror_bowl.obj: the inside of a spherical cap (radius 1, opening half-angle 50 degrees, 48 x 12
  quads) with vertex normals pointing into the bowl (toward its centre of curvature), so that it
  focuses like a concave mirror (mirror_bowl.xml).
Deterministic: the same files every run."""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def write(name, verts, normals, faces):
    with open(os.path.join(HERE, name), "w") as f:
        f.write("# %s: written by bench/check/make_meshes.py\n" % name)
        for v in verts:
            f.write("v %.9f %.9f %.9f\n" % v)
        for n in normals:
            f.write("vn %.9f %.9f %.9f\n" % n)
        for a, b, c in faces:
            f.write("f %d//%d %d//%d %d//%d\n" % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1))


def grid(nu, nv, point, normal):
    """(nu+1) x (nv+1) vertices over u in [0, 1] (around, seam duplicated), v in [0, 1]."""
    verts, normals, faces = [], [], []
    for j in range(nv + 1):
        for i in range(nu + 1):
            u, v = i / nu, j / nv
            verts.append(point(u, v))
            normals.append(normal(u, v))
    for j in range(nv):
        for i in range(nu):
            a = j * (nu + 1) + i
            b, c, d = a + 1, a + nu + 1, a + nu + 2
            faces.append((a, b, d))
            faces.append((a, d, c))
    return verts, normals, faces


def area(v, t):
    a, b, c = (v[k] for k in t)
    e1 = [b[i] - a[i] for i in range(3)]
    e2 = [c[i] - a[i] for i in range(3)]
    x = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
    return 0.5 * math.sqrt(sum(q * q for q in x))


def sphere_dir(u, theta):
    phi = 2 * math.pi * u
    return (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))


def main():
    r = 0.5
    v, n, f = grid(48, 24, lambda u, w: tuple(r * c for c in sphere_dir(u, math.pi * w)),
                   lambda u, w: sphere_dir(u, math.pi * w))
    f = [t for t in f if area(v, t) > 1e-12]  # the poles' degenerate triangles dropped
    write("glass_ball_mesh.obj", v, n, f)
    half = math.radians(50)
    # the cap below its centre of curvature (0, 0, 0): points at -y, opening upward
    v, n, f = grid(48, 12, lambda u, w: tuple(-c if k == 1 else c for k, c in enumerate(sphere_dir(u, half * w))),
                   lambda u, w: tuple(c if k == 1 else -c for k, c in enumerate(sphere_dir(u, half * w))))
    f = [t for t in f if area(v, t) > 1e-12]
    write("mirror_bowl.obj", v, n, f)


if __name__ == "__main__":
    main()
