#!/usr/bin/env python3
"""Writes a large OBJ for measuring loading (issue 12): a gently curved square grid
of N x N quads, two triangles each, positions only, `f a b c` faces.

Usage: benches/grid_obj.py OUT.obj [QUADS_PER_SIDE]   (default 1000: 2M triangles, ~75 MB)
"""
import math
import sys


def main():
    out = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
    with open(out, "w") as f:
        f.write(f"# {n}x{n} grid, {2 * n * n} triangles\n")
        for j in range(n + 1):
            y = j / n
            f.write("".join(
                f"v {i / n:.6f} {0.05 * math.sin(6.0 * i / n) * math.cos(5.0 * y):.6f} {y:.6f}\n"
                for i in range(n + 1)))
        row = n + 1
        for j in range(n):
            lines = []
            for i in range(n):
                a = j * row + i + 1
                b, c, d = a + 1, a + row, a + row + 1
                lines.append(f"f {a} {c} {d}\nf {a} {d} {b}\n")
            f.write("".join(lines))


if __name__ == "__main__":
    main()
