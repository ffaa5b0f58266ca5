#!/usr/bin/env python3
"""Writes the bundled radiosity scenes (assets/scenes/*.obj + .mtl): the Cornell box, a room like
Fig. 2 and an office like Fig. 5 of Liu and Wu's paper. Run from the repository root:

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


def box(w, name, material, lo, hi, bottom=False):
    """An axis-aligned box as outward-facing quads (y up); its bottom only if asked."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    centre = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
    faces = {
        "top": [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],
        "bottom": [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],
        "front": [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)],
        "back": [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
        "left": [(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)],
        "right": [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],
    }
    for side, c in faces.items():
        if side == "bottom" and not bottom:
            continue
        w.polygon(f"{name}_{side}", material, away(c, centre))


def shell(w, size, wall="wall", floor="floor", ceiling="ceiling", window=None):
    """A room's floor, ceiling and four walls, facing in. `window` ((y0, y1), (z0, z1)) cuts an
    opening in the west wall (x = 0), which is then four rectangles round it, and fills it with an
    emitting pane in the wall's plane: a pane in front of a whole wall would leave the wall behind
    it unlit, and the vertices round the pane's outline dark."""
    x, y, z = size
    centre = (x / 2, y / 2, z / 2)
    w.polygon("floor", floor, facing([(0, 0, 0), (x, 0, 0), (x, 0, z), (0, 0, z)], centre))
    w.polygon("ceiling", ceiling, facing([(0, y, 0), (x, y, 0), (x, y, z), (0, y, z)], centre))
    w.polygon("wall_south", wall, facing([(0, 0, 0), (x, 0, 0), (x, y, 0), (0, y, 0)], centre))
    w.polygon("wall_north", wall, facing([(0, 0, z), (x, 0, z), (x, y, z), (0, y, z)], centre))

    def west(name, material, y0, y1, z0, z1):
        w.polygon(name, material, facing([(0, y0, z0), (0, y1, z0), (0, y1, z1), (0, y0, z1)], centre))

    if window is None:
        west("wall_west", wall, 0, y, 0, z)
    else:
        (y0, y1), (z0, z1) = window
        west("wall_west_below", wall, 0, y0, 0, z)
        west("wall_west_above", wall, y1, y, 0, z)
        west("wall_west_left", wall, y0, y1, 0, z0)
        west("wall_west_right", wall, y0, y1, z1, z)
        west("window", "window", y0, y1, z0, z1)
    w.polygon("wall_east", wall, facing([(x, 0, 0), (x, y, 0), (x, y, z), (x, 0, z)], centre))


def table(w, name, x, z, width, depth, height, material):
    box(w, f"{name}_top", material, (x, height - 0.04, z), (x + width, height, z + depth), bottom=True)
    for i, (lx, lz) in enumerate([(x + 0.05, z + 0.05), (x + width - 0.1, z + 0.05),
                                   (x + 0.05, z + depth - 0.1), (x + width - 0.1, z + depth - 0.1)]):
        box(w, f"{name}_leg{i}", material, (lx, 0, lz), (lx + 0.05, height - 0.04, lz + 0.05))


def chair(w, name, x, z, material, back_at_high_z=True):
    box(w, f"{name}_seat", material, (x, 0.42, z), (x + 0.45, 0.46, z + 0.45), bottom=True)
    for i, (lx, lz) in enumerate([(x, z), (x + 0.4, z), (x, z + 0.4), (x + 0.4, z + 0.4)]):
        box(w, f"{name}_leg{i}", material, (lx, 0, lz), (lx + 0.05, 0.42, lz + 0.05))
    bz = z + 0.4 if back_at_high_z else z
    box(w, f"{name}_back", material, (x, 0.46, bz), (x + 0.45, 0.95, bz + 0.05), bottom=True)


MATERIALS = """newmtl wall
Kd 0.72 0.70 0.66

newmtl ceiling
Kd 0.80 0.80 0.78

newmtl floor
Kd 0.45 0.32 0.20

newmtl wood
Kd 0.55 0.36 0.20

newmtl fabric
Kd 0.25 0.30 0.55

newmtl shelf
Kd 0.60 0.52 0.40

newmtl partition
Kd 0.40 0.50 0.45

newmtl lamp
Kd 0.80 0.80 0.80
Ke 40 38 34

newmtl window
Kd 0.80 0.80 0.80
Ke 14 16 20
"""


def save_furnished(w, out, name):
    """Writes NAME.obj and NAME.mtl (the materials the room and the office share)."""
    w.save(os.path.join(out, f"{name}.obj"))
    with open(os.path.join(out, f"{name}.mtl"), "w") as f:
        f.write("# Materials of the room and office scenes: Kd reflectance, Ke emitted exitance.\n" + MATERIALS)


def room(out):
    """A room like Liu and Wu's Fig. 2: a table, two chairs, a shelf, a ceiling light and a
    window light, in metres."""
    w = Writer(
        [
            "A room like Fig. 2 of Liu and Wu's radiosity simplification paper: a table, two chairs,",
            "a shelf, a ceiling light and a window; metres, y up. Written by scripts/make_scenes.py.",
        ],
        "room.mtl",
    )
    size = (5.0, 3.0, 4.0)
    shell(w, size, window=((1.0, 2.2), (1.2, 2.8)))
    table(w, "table", 1.8, 1.5, 1.4, 0.9, 0.75, "wood")
    chair(w, "chair1", 2.0, 2.45, "fabric")
    chair(w, "chair2", 2.5, 0.95, "fabric", back_at_high_z=False)
    box(w, "shelf", "shelf", (4.55, 0, 0.6), (5.0 - 0.001, 1.8, 2.0))
    for i, h in enumerate([0.45, 0.9, 1.35]):
        box(w, f"shelf_board{i}", "shelf", (4.2, h, 0.6), (4.55, h + 0.03, 2.0), bottom=True)
    lamp = [(2.2, 2.995, 1.7), (2.8, 2.995, 1.7), (2.8, 2.995, 2.3), (2.2, 2.995, 2.3)]
    w.polygon("ceiling_light", "lamp", facing(lamp, (2.5, 0.0, 2.0)))
    save_furnished(w, out, "room")


def office(out):
    """An office like the paper's Fig. 5: desks in rows, partitions between them and several
    ceiling lights, in metres."""
    w = Writer(
        [
            "An office like Fig. 5 of Liu and Wu's radiosity simplification paper: desks, partitions",
            "and six ceiling lights; metres, y up. Written by scripts/make_scenes.py.",
        ],
        "office.mtl",
    )
    size = (10.0, 3.0, 8.0)
    shell(w, size)
    for row in range(2):
        for col in range(3):
            x, z = 1.2 + col * 3.0, 1.5 + row * 3.5
            table(w, f"desk{row}{col}", x, z, 1.6, 0.8, 0.74, "wood")
            chair(w, f"chair{row}{col}", x + 0.55, z + 0.95, "fabric")
            box(w, f"partition{row}{col}", "partition", (x - 0.1, 0, z - 0.12), (x + 1.7, 1.4, z - 0.06))
    for i in range(3):
        for j in range(2):
            cx, cz = 2.0 + i * 3.0, 2.2 + j * 3.6
            lamp = [(cx - 0.6, 2.995, cz - 0.3), (cx + 0.6, 2.995, cz - 0.3),
                    (cx + 0.6, 2.995, cz + 0.3), (cx - 0.6, 2.995, cz + 0.3)]
            w.polygon(f"light{i}{j}", "lamp", facing(lamp, (cx, 0.0, cz)))
    save_furnished(w, out, "office")


if __name__ == "__main__":
    out = os.path.join("assets", "scenes")
    os.makedirs(out, exist_ok=True)
    cornell(out)
    room(out)
    office(out)
