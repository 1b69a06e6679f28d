#!/usr/bin/env python3
"""Writes the closed OBJ meshes of scenes/flotsam.json (scenes/meshes/).

Each mesh is centred on its centroid (Wake and Bullet take the mesh origin as the centre
of mass). Run from the repository root: python3 scripts/make_flotsam_meshes.py
"""
import math
import os
import random

OUT = os.path.join("scenes", "meshes")


def write(name, verts, faces, comment):
    cx = sum(v[0] for v in verts) / len(verts)
    cy = sum(v[1] for v in verts) / len(verts)
    cz = sum(v[2] for v in verts) / len(verts)
    with open(os.path.join(OUT, name + ".obj"), "w") as f:
        f.write("# %s (scripts/make_flotsam_meshes.py)\n" % comment)
        for v in verts:
            f.write("v %.5f %.5f %.5f\n" % (v[0] - cx, v[1] - cy, v[2] - cz))
        for t in faces:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))


def ring_strips(rings, n, downwards):
    """Triangles joining rings 0..rings of n vertices each (ring k at k * n), facing out;
    `downwards`: the rings are stacked from the top down."""
    faces = []
    for k in range(rings):
        for i in range(n):
            a, b = k * n + i, k * n + (i + 1) % n
            c, d = b + n, a + n
            faces += [(a, b, c), (a, c, d)] if downwards else [(a, c, b), (a, d, c)]
    return faces


def torus(R, r, nu, nv):
    verts, faces = [], []
    for i in range(nu):
        u = 2 * math.pi * i / nu
        for j in range(nv):
            v = 2 * math.pi * j / nv
            verts.append(((R + r * math.cos(v)) * math.cos(u), r * math.sin(v),
                          (R + r * math.cos(v)) * math.sin(u)))
    for i in range(nu):
        for j in range(nv):
            a = i * nv + j
            b = ((i + 1) % nu) * nv + j
            c = ((i + 1) % nu) * nv + (j + 1) % nv
            d = i * nv + (j + 1) % nv
            faces += [(a, d, c), (a, c, b)]
    return verts, faces


def barrel(radius, half_height, bulge, n, rings):
    verts, faces = [], []
    for k in range(rings + 1):
        y = -half_height + 2 * half_height * k / rings
        rr = radius * (1 + bulge * (1 - (y / half_height) ** 2))
        for i in range(n):
            a = 2 * math.pi * i / n
            verts.append((rr * math.cos(a), y, rr * math.sin(a)))
    bottom, top = len(verts), len(verts) + 1
    verts += [(0, -half_height, 0), (0, half_height, 0)]
    faces += ring_strips(rings, n, downwards=False)
    for i in range(n):
        faces.append((bottom, i, (i + 1) % n))
        faces.append((top, rings * n + (i + 1) % n, rings * n + i))
    return verts, faces


def icosphere(subdivisions):
    t = (1 + math.sqrt(5)) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
             (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [tuple(c / math.sqrt(1 + t * t) for c in v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        cache, new = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = [(verts[a][k] + verts[b][k]) / 2 for k in range(3)]
                n = math.sqrt(sum(c * c for c in m))
                verts.append(tuple(c / n for c in m))
                cache[key] = len(verts) - 1
            return cache[key]

        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return verts, faces


def rock(size, seed):
    random.seed(seed)
    verts, faces = icosphere(2)
    out = []
    for v in verts:
        s = size * random.uniform(0.85, 1.1)
        out.append((1.3 * s * v[0], 0.8 * s * v[1], s * v[2]))
    return out, faces


def boat(length, beam, depth, n):
    """A closed hull: elliptic deck outline, sides tapering to a keel line."""
    verts, faces = [], []
    rings = 4
    for k in range(rings + 1):
        s = 1 - k / rings  # 1 at the deck, 0 at the keel
        y = -depth * (1 - s)
        for i in range(n):
            a = 2 * math.pi * i / n
            x = 0.5 * length * math.cos(a) * (0.6 + 0.4 * s)
            z = 0.5 * beam * math.sin(a) * s ** 0.7
            verts.append((x, y, z))
    deck = len(verts)
    verts.append((0, 0, 0))
    faces += ring_strips(rings, n, downwards=True)
    for i in range(n):
        faces.append((deck, (i + 1) % n, i))
    # The keel ring has zero width: close it with a fan of its own.
    keel = len(verts)
    verts.append((0, -depth, 0))
    for i in range(n):
        faces.append((keel, rings * n + i, rings * n + (i + 1) % n))
    return verts, faces


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    write("ring_buoy", *torus(0.05, 0.018, 32, 16), "ring buoy: torus R 5 cm, r 1.8 cm")
    write("barrel", *barrel(0.035, 0.05, 0.12, 24, 6), "barrel: radius 3.5 cm, height 10 cm")
    write("rock", *rock(0.04, 3), "pumice rock: lumpy ellipsoid about 10 x 6 x 8 cm")
    write("boat", *boat(0.16, 0.07, 0.04, 24), "toy boat: 16 cm long, 7 cm beam")
