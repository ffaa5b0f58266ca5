#!/usr/bin/env python3
"""Writes the bundled radiosity scenes (assets/scenes/*.obj + .mtl). Run from the repository root:

    python3 scripts/make_scenes.py

The Cornell box's geometry is the Cornell University Program of Computer Graphics' "Cornell Box
Data" (in millimetres); its RGB reflectances and light are the approximation in Benedikt Bitterli's
"Rendering Resources" (2016) cornell-box scene.
"""
import math
import os


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def newell(c):
    n = (0.0, 0.0, 0.0)
    for i in range(len(c)):
        n = tuple(x + y for x, y in zip(n, cross(c[i], c[(i + 1) % len(c)])))
    return n


def centroid(c):
    return tuple(sum(p[k] for p in c) / len(c) for k in range(3))


def facing(c, point):
    """The polygon wound so that its normal points towards `point`."""
    return c if dot(newell(c), sub(point, centroid(c))) > 0 else c[::-1]


def away(c, point):
    return c if dot(newell(c), sub(centroid(c), point)) > 0 else c[::-1]


class Writer:
    def __init__(self, header, mtl):
        self.lines = [f"# {h}" for h in header] + [f"mtllib {mtl}"]
        self.next = 1

    def polygon(self, name, material, corners):
        self.lines += [f"o {name}", f"usemtl {material}"]
        self.lines += ["v %g %g %g" % p for p in corners]
        self.lines.append("f " + " ".join(str(self.next + k) for k in range(len(corners))))
        self.next += len(corners)

    def save(self, path):
        with open(path, "w") as f:
            f.write("\n".join(self.lines) + "\n")


def cornell(out):
    w = Writer(
        [
            "The Cornell box: geometry from the Cornell University Program of Computer Graphics,",
            '"Cornell Box Data" (www.graphics.cornell.edu/online/box/data.html), in millimetres.',
            'RGB reflectances and light: the approximation in Benedikt Bitterli\'s "Rendering Resources"',
            "(2016) cornell-box scene; its light radiance (17, 12, 4) is given here as radiant exitance,",
            "pi times it. Changes: the light is lowered 0.5 mm so that it does not overlap the ceiling,",
            "and faces are wound to face into the room (walls) and out of the blocks.",
            "Written by scripts/make_scenes.py.",
        ],
        "cornell.mtl",
    )
    room = (278.0, 274.0, 280.0)
    walls = [
        ("floor", "white", [(552.8, 0, 0), (0, 0, 0), (0, 0, 559.2), (549.6, 0, 559.2)]),
        ("ceiling", "white", [(556.0, 548.8, 0), (556.0, 548.8, 559.2), (0, 548.8, 559.2), (0, 548.8, 0)]),
        ("back_wall", "white", [(549.6, 0, 559.2), (0, 0, 559.2), (0, 548.8, 559.2), (556.0, 548.8, 559.2)]),
        ("right_wall", "green", [(0, 0, 559.2), (0, 0, 0), (0, 548.8, 0), (0, 548.8, 559.2)]),
        ("left_wall", "red", [(552.8, 0, 0), (549.6, 0, 559.2), (556.0, 548.8, 559.2), (556.0, 548.8, 0)]),
    ]
    for name, material, c in walls:
        w.polygon(name, material, facing(c, room))
    light = [(343.0, 548.3, 227.0), (343.0, 548.3, 332.0), (213.0, 548.3, 332.0), (213.0, 548.3, 227.0)]
    w.polygon("light", "light", facing(light, (278.0, 0.0, 280.0)))
    short = [
        [(130.0, 165.0, 65.0), (82.0, 165.0, 225.0), (240.0, 165.0, 272.0), (290.0, 165.0, 114.0)],
        [(290.0, 0, 114.0), (290.0, 165.0, 114.0), (240.0, 165.0, 272.0), (240.0, 0, 272.0)],
        [(130.0, 0, 65.0), (130.0, 165.0, 65.0), (290.0, 165.0, 114.0), (290.0, 0, 114.0)],
        [(82.0, 0, 225.0), (82.0, 165.0, 225.0), (130.0, 165.0, 65.0), (130.0, 0, 65.0)],
        [(240.0, 0, 272.0), (240.0, 165.0, 272.0), (82.0, 165.0, 225.0), (82.0, 0, 225.0)],
    ]
    tall = [
        [(423.0, 330.0, 247.0), (265.0, 330.0, 296.0), (314.0, 330.0, 456.0), (472.0, 330.0, 406.0)],
        [(423.0, 0, 247.0), (423.0, 330.0, 247.0), (472.0, 330.0, 406.0), (472.0, 0, 406.0)],
        [(472.0, 0, 406.0), (472.0, 330.0, 406.0), (314.0, 330.0, 456.0), (314.0, 0, 456.0)],
        [(314.0, 0, 456.0), (314.0, 330.0, 456.0), (265.0, 330.0, 296.0), (265.0, 0, 296.0)],
        [(265.0, 0, 296.0), (265.0, 330.0, 296.0), (423.0, 330.0, 247.0), (423.0, 0, 247.0)],
    ]
    for i, c in enumerate(short):
        w.polygon(f"short_block_{i}", "white", away(c, (186.0, 82.5, 168.5)))
    for i, c in enumerate(tall):
        w.polygon(f"tall_block_{i}", "white", away(c, (368.5, 165.0, 351.25)))
    w.save(os.path.join(out, "cornell.obj"))
    pi = math.pi
    with open(os.path.join(out, "cornell.mtl"), "w") as f:
        f.write(
            "# Reflectances (Kd) and emitted radiant exitance (Ke) of the Cornell box, after Bitterli (2016).\n"
            "newmtl white\nKd 0.725 0.71 0.68\n\n"
            "newmtl red\nKd 0.63 0.065 0.05\n\n"
            "newmtl green\nKd 0.14 0.45 0.091\n\n"
            f"newmtl light\nKd 0.78 0.78 0.78\nKe {17 * pi:.4f} {12 * pi:.4f} {4 * pi:.4f}\n"
        )


if __name__ == "__main__":
    out = os.path.join("assets", "scenes")
    os.makedirs(out, exist_ok=True)
    cornell(out)
