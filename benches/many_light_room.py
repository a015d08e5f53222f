#!/usr/bin/env python3
"""Writes meshes/many-light-room.obj and .mtl (issue 20): a shared interior lit by many
small emitters of mixed power and a few strong ones, to measure light sampling that
scales (the light BVH against the alias table).

A hall 20 x 3 x 8 (x, y, z; y up) split into four bays by partition walls with
doorways, with desks in the bays. About a thousand small emitting squares (10 cm) of
eight powers over two decades sit on the ceiling (facing down), on the long walls and
the partitions (facing into the bays) and on the desks (facing up); three large
ceiling panels are the strong lights. Deterministic (fixed seed): running it again
writes the same files.

Usage: benches/many_light_room.py [OUT_DIR]   (default: meshes/)
Render, e.g.: ember render meshes/many-light-room.obj --eye 1.2,1.6,7.2 --look-at 10,1.0,2
"""
import os
import random
import sys

W, H, D = 20.0, 3.0, 8.0
PARTITIONS = [5.0, 10.0, 15.0]  # x of the partition walls; doorway at z in [5.5, 7]
DOOR = (5.5, 7.0)
SMALL = 0.1
OFFSET = 0.005
POWERS = [0.5 * (60 ** (i / 7)) for i in range(8)]  # Ke from 0.5 to 30


class Obj:
    def __init__(self):
        self.vertices, self.faces = [], []  # faces: (material, [indices])

    def quad(self, material, a, b, c, d):
        """A quad a-b-c-d, counter-clockwise seen from the side it emits to."""
        base = len(self.vertices) + 1
        self.vertices += [a, b, c, d]
        self.faces.append((material, [base, base + 1, base + 2, base + 3]))

    def square(self, material, center, u, v, size):
        """A square of side `size` around `center`, spanned by unit u, v (normal u x v)."""
        h = size / 2
        p = lambda s, t: tuple(center[i] + s * u[i] + t * v[i] for i in range(3))
        self.quad(material, p(-h, -h), p(h, -h), p(h, h), p(-h, h))

    def box(self, material, lo, hi):
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        q = self.quad
        q(material, (x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0))  # top
        q(material, (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1))  # +z
        q(material, (x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0))  # -z
        q(material, (x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1))  # +x
        q(material, (x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0))  # -x


def build(rng):
    o = Obj()
    # The shell, seen from inside.
    o.quad("floor", (0, 0, 0), (0, 0, D), (W, 0, D), (W, 0, 0))
    o.quad("ceiling", (0, H, 0), (W, H, 0), (W, H, D), (0, H, D))
    o.quad("wall", (0, 0, 0), (W, 0, 0), (W, H, 0), (0, H, 0))
    o.quad("wall", (W, 0, D), (0, 0, D), (0, H, D), (W, H, D))
    o.quad("wall", (0, 0, D), (0, 0, 0), (0, H, 0), (0, H, D))
    o.quad("accent", (W, 0, 0), (W, 0, D), (W, H, D), (W, H, 0))
    # Partitions with a doorway, 10 cm thick.
    for x in PARTITIONS:
        o.box("wall", (x - 0.05, 0, 0), (x + 0.05, H, DOOR[0]))
        o.box("wall", (x - 0.05, 0, DOOR[1]), (x + 0.05, H, D))
        o.box("wall", (x - 0.05, 2.2, DOOR[0]), (x + 0.05, H, DOOR[1]))
    # Two desks per bay.
    desks = []
    for bay in range(4):
        for z in (1.5, 4.0):
            x = bay * 5 + 1.5 + rng.uniform(0, 1.5)
            lo, hi = (x, 0, z), (x + 1.2, 0.75, z + 0.7)
            o.box("desk", lo, hi)
            desks.append((lo, hi))

    def small(center, u, v):
        o.square(f"light{rng.randrange(len(POWERS))}", center, u, v, SMALL)

    count = 0
    # Ceiling: a jittered grid facing down (u x v = -y; it was +y before, so that the
    # ceiling lamps and panels shone into the 5 mm gap above them).
    for i in range(50):
        for k in range(8):
            x, z = (i + rng.uniform(0.2, 0.8)) * W / 50, (k + rng.uniform(0.2, 0.8)) * D / 8
            if any(abs(x - p) < 0.15 for p in PARTITIONS):
                continue
            small((x, H - OFFSET, z), (1, 0, 0), (0, 0, 1))
            count += 1
    # Long walls: rows of lamps facing into the hall.
    for i in range(100):
        x = (i + rng.uniform(0.2, 0.8)) * W / 100
        if any(abs(x - p) < 0.15 for p in PARTITIONS):
            continue
        for y in (0.9, 2.1):
            small((x, y + rng.uniform(-0.2, 0.2), OFFSET), (1, 0, 0), (0, 1, 0))
            small((x, y + rng.uniform(-0.2, 0.2), D - OFFSET), (-1, 0, 0), (0, 1, 0))
            count += 2
    # Partitions, both faces.
    for x in PARTITIONS:
        for j in range(25):
            z = (j + rng.uniform(0.2, 0.8)) * DOOR[0] / 25
            y = rng.uniform(0.4, 2.6)
            small((x - 0.05 - OFFSET, y, z), (0, 0, 1), (0, 1, 0))
            small((x + 0.05 + OFFSET, y, z), (0, 0, -1), (0, 1, 0))
            count += 2
    # Desk lamps facing up.
    for lo, hi in desks:
        for _ in range(8):
            x, z = rng.uniform(lo[0] + 0.1, hi[0] - 0.1), rng.uniform(lo[2] + 0.1, hi[2] - 0.1)
            small((x, hi[1] + OFFSET, z), (1, 0, 0), (0, 0, -1))
            count += 1
    # The strong lights: large ceiling panels in three of the bays.
    for x in (2.5, 12.5, 17.5):
        o.square("panel", (x, H - OFFSET, 4.0), (1, 0, 0), (0, 0, 1), 0.8)
    return o, count


MTL = """# Materials of many-light-room.obj (benches/many_light_room.py).
newmtl floor
Kd 0.55 0.5 0.45
newmtl ceiling
Kd 0.8 0.8 0.8
newmtl wall
Kd 0.7 0.7 0.68
newmtl accent
Kd 0.25 0.35 0.6
newmtl desk
Kd 0.45 0.3 0.2
Ks 0.2 0.2 0.2
Ns 200
newmtl panel
Kd 0 0 0
Ke 12 11 9
"""


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "meshes"
    )
    o, count = build(random.Random(20))
    colours = [(1.0, 0.85, 0.6), (0.7, 0.8, 1.0)]
    mtl = MTL + "".join(
        f"newmtl light{i}\nKd 0 0 0\nKe "
        + " ".join(f"{p * c:.4g}" for c in colours[i % 2])
        + "\n"
        for i, p in enumerate(POWERS)
    )
    with open(os.path.join(out, "many-light-room.mtl"), "w") as f:
        f.write(mtl)
    with open(os.path.join(out, "many-light-room.obj"), "w") as f:
        f.write(
            f"# many-light-room: {count} small emitters of mixed power and 3 ceiling panels in a\n"
            "# hall of four bays. Written by benches/many_light_room.py; public domain.\n"
            "mtllib many-light-room.mtl\n"
        )
        for v in o.vertices:
            f.write("v " + " ".join(f"{c:.4f}" for c in v) + "\n")
        material = None
        for m, idx in o.faces:
            if m != material:
                f.write(f"usemtl {m}\n")
                material = m
            f.write("f " + " ".join(map(str, idx)) + "\n")
    print(f"{count} small emitters, {len(o.faces)} faces, {len(o.vertices)} vertices")


if __name__ == "__main__":
    main()
