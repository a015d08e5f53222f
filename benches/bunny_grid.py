#!/usr/bin/env python3
"""Writes a scene file placing the Stanford bunny on an N x N grid (issue 23: the
instancing memory target, 1000 bunnies = 69M placed triangles), each copy turned about
y by its own angle, under a uniform sky, with a camera that sees the whole grid.

Usage: benches/bunny_grid.py OUT.toml [COUNT] [BUNNY.obj]
  COUNT defaults to 1000 (a 32 x 32 grid, filled row by row);
  BUNNY.obj defaults to shared/meshes/bunny/stanford-bunny.obj beside the repository.
The OBJ path is written relative to OUT.toml's folder.
"""
import math
import os
import sys


def main():
    out = os.path.abspath(sys.argv[1])
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    bunny = sys.argv[3] if len(sys.argv) > 3 else os.path.join(
        repo, "..", "shared", "meshes", "bunny", "stanford-bunny.obj")
    side = math.ceil(math.sqrt(count))
    spacing = 0.25  # the bunny is about 0.16 wide
    extent = side * spacing
    lines = [
        f"# {count} instances of the Stanford bunny on a {side} x {side} grid "
        f"(benches/bunny_grid.py)",
        "[render]",
        "width = 320",
        "height = 180",
        "spp = 4",
        "",
        "[camera.grid]",
        f"eye = [{extent / 2:.4f}, {extent * 0.6:.4f}, {extent * 1.3:.4f}]",
        f"look-at = [{extent / 2:.4f}, 0, {extent / 2:.4f}]",
        "fov = 45",
        "",
        "[environment]",
        "background = [1, 1, 1]",
        "",
        "[[obj]]",
        f'file = "{os.path.relpath(os.path.abspath(bunny), os.path.dirname(out))}"',
        'name = "bunny"',
        "translate = [0, 0, 0]",
    ]
    for i in range(1, count):
        x, z = (i % side) * spacing, (i // side) * spacing
        degrees = (i * 137.508) % 360  # golden-angle turns: no two alike
        lines += [
            "",
            "[[instance]]",
            'obj = "bunny"',
            f"translate = [{x:.4f}, 0, {z:.4f}]",
            f"rotate = {{ axis = [0, 1, 0], degrees = {degrees:.3f} }}",
        ]
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
