#!/usr/bin/env python3
"""CAD-like test meshes: smooth, gently curved surfaces tessellated the way CAD kernels do it, with
long sliver triangles (aspect ratios in the hundreds), the kind on which quadric simplification is
known to be weak.

    python3 scripts/make_cad.py OUT_DIR

writes
- cylinder.obj: an open tube (radius 1, length 3; two holes, one part) of 2,000 segments around and
  4 rows along: 16,000 slivers about 0.75 long and 0.003 wide.
- blade.obj: a twisted, cambered blade (a closed ruled sweep of an airfoil-like section along its
  span, 60° of twist), 1,600 stations around the section and 5 along the span, capped at both
  ends by fans: about 16,000 triangles, nearly all slivers.

Both are deterministic (no randomness), made by the project, and free of third-party licences.
"""

import math
import os
import sys


def write_obj(path, vertices, faces, comment):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(f"# {comment}\n")
        for v in vertices:
            f.write("v %.9g %.9g %.9g\n" % v)
        for t in faces:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
    os.replace(tmp, path)


def tube_faces(rows, around):
    """Two triangles per quad between consecutive rings of `around` vertices, counter-clockwise
    seen from outside."""
    faces = []
    for j in range(rows):
        for i in range(around):
            a = j * around + i
            b = j * around + (i + 1) % around
            faces.append((a, b, b + around))
            faces.append((a, b + around, a + around))
    return faces


def cylinder(segments=2000, rows=4, radius=1.0, length=3.0):
    vertices = []
    for j in range(rows + 1):
        z = length * j / rows
        for i in range(segments):
            a = 2.0 * math.pi * i / segments
            vertices.append((radius * math.cos(a), radius * math.sin(a), z))
    return vertices, tube_faces(rows, segments)


def blade(around=1600, stations=5, span=4.0, chord=1.0, twist_deg=60.0):
    """An airfoil-like closed section (a thin cambered ellipse), swept along z with twist."""

    def section(u, s):
        # u in [0, 1): around the section; s in [0, 1]: along the span.
        a = 2.0 * math.pi * u
        x = 0.5 * chord * math.cos(a)
        thickness = 0.06 * chord * (1.0 - 0.5 * s)
        camber = 0.08 * chord * (1.0 - (2.0 * x / chord) ** 2)
        y = thickness * math.sin(a) + camber
        t = math.radians(twist_deg) * s
        c, n = math.cos(t), math.sin(t)
        return (c * x - n * y, n * x + c * y, span * s)

    vertices = []
    for j in range(stations + 1):
        s = j / stations
        for i in range(around):
            vertices.append(section(i / around, s))
    faces = tube_faces(stations, around)
    # Caps: a fan from each end's centre.
    for j, flip in ((0, True), (stations, False)):
        centre = len(vertices)
        ring = range(j * around, (j + 1) * around)
        xs = [vertices[v] for v in ring]
        vertices.append(
            (sum(p[0] for p in xs) / around, sum(p[1] for p in xs) / around, xs[0][2])
        )
        for i in range(around):
            a = j * around + i
            b = j * around + (i + 1) % around
            faces.append((centre, b, a) if flip else (centre, a, b))
    return vertices, faces


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    v, f = cylinder()
    write_obj(os.path.join(out, "cylinder.obj"), v, f, "vunify scripts/make_cad.py: sliver cylinder")
    v, f = blade()
    write_obj(os.path.join(out, "blade.obj"), v, f, "vunify scripts/make_cad.py: twisted blade")
    print(f"wrote cylinder.obj and blade.obj to {out}")


if __name__ == "__main__":
    main()
