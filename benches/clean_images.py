#!/usr/bin/env python3
"""Time to a clean image (issue 19): how long ember takes to reach a target relMSE
against a reference, with uniform sampling, adaptive sampling, and adaptive sampling
plus Open Image Denoise, and (optionally) Blender Cycles with its own adaptive sampling
and OIDN, in one sitting.

Each method runs a sweep of ever more work (uniform: spp doubling; adaptive: the noise
threshold falling by sqrt(2); with the denoiser: spp doubling; Cycles: spp doubling
with `--adaptive 0.01` and `--denoise`) until its relMSE is at or below the target.
The time at the target is interpolated log-log between the last two runs (a first run
already below it counts its own time). ember's times are whole-process wall seconds
(loading and denoising included); Cycles' are its own `render_s` (its process adds
2-3 s of Blender start-up, printed beside). Nothing else
should run meanwhile: the load average is printed before and after.

Usage:
  benches/clean_images.py [--ember target/release/ember] [--scenes original,glossy]
                          [--target-original 1e-3] [--target-glossy 1e-2]
                          [--cycles-dir DIR --cycles-python PY]

`--cycles-dir` holds the peer's render.py (shared/peers/cycles; `pip install bpy numpy`).
The Cornell references are the shipped ones (tests/data/references, 512², depth 8).
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFS = os.path.join(ROOT, "tests", "data", "references")
CAMERA = ["--eye", "0,1,3.9", "--look-at", "0,1,0", "--fov", "40"]
SIZE, DEPTH = 512, 8
SCENES = {
    "original": ("meshes/CornellBox-Original.obj", "cornell-box/cornell_ref_8192spp.exr"),
    "glossy": ("meshes/CornellBox-GlossyMix.obj", "cornell-glossy/CornellBox-GlossyMix_ref_4096spp.exr"),
}
# The grey-white room of shared/meshes (lit by its sky through the windows), at the
# reference's size; the reference is an ember render given by --room-reference (not
# shipped), e.g. 160x90 at 8192 spp.
ROOM_FLAGS = ["--env-rotate", "-90", "--fov", "58.7155", "--eye", "5.10518,0.731065,-2.31789",
              "--look-at", "4.143388,0.805472,-2.054414", "--up", "0.071763,0.997228,-0.019659"]


def run(cmd):
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(f"error: {' '.join(cmd)} failed:\n{done.stderr.strip()}")
    return wall, done


def rel_mse(ember, image, reference):
    _, done = run([ember, "compare", image, reference])
    return float(re.search(r"relMSE ([0-9.e+-]+)", done.stdout).group(1))


def ember_point(args, scene, out, extra):
    if scene == "room":
        obj = os.path.join(args.room_dir, "living-room.obj")
        env = os.path.join(args.room_dir, "textures", "Sky 19.exr")
        w, h = args.room_size.split("x")
        view = ["--width", w, "--height", h, "--env", env, *ROOM_FLAGS]
    else:
        obj = os.path.join(ROOT, SCENES[scene][0])
        view = ["--width", str(SIZE), "--height", str(SIZE), *CAMERA]
    cmd = [args.ember, "render", obj, "--max-depth", str(DEPTH), "--seed", "1", *view,
           "-o", out, *extra]
    wall, done = run(cmd)
    summary = [l for l in done.stderr.splitlines() if l.startswith("wrote")][-1]
    return wall, summary


def cycles_point(args, scene, out, spp):
    obj = os.path.join(ROOT, SCENES[scene][0])
    cmd = [args.cycles_python, os.path.join(args.cycles_dir, "render.py"), obj,
           "--origin", "0", "1", "3.9", "--target", "0", "1", "0", "--up", "0", "1", "0",
           "--fov", "40", "--width", str(SIZE), "--height", str(SIZE), "--spp", str(spp),
           "--max-depth", str(DEPTH), "--seed", "1", "--threads", "2", "--out", out,
           "--adaptive", "0.01", "--denoise", "--quiet"]
    wall, done = run(cmd)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    # Cycles' own render time: the whole process adds 2-3 s of Blender start-up.
    return report["render_s"], f"wall {wall:.2f} s"


def sweep(name, points, target, measure):
    """Runs `measure(p)` for p in points until relMSE <= target; returns the rows and
    the interpolated time at the target (None if never reached)."""
    rows = []
    for p in points:
        wall, err, note = measure(p)
        rows.append((p, wall, err, note))
        print(f"  {name} {p}: {wall:.2f} s, relMSE {err:.3e}  [{note}]", flush=True)
        if err <= target:
            break
    if rows[-1][2] > target:
        return rows, None
    if len(rows) == 1:
        return rows, rows[0][1]
    (_, t0, e0, _), (_, t1, e1, _) = rows[-2], rows[-1]
    if e0 <= e1:
        return rows, t1
    slope = (math.log(t1) - math.log(t0)) / (math.log(e1) - math.log(e0))
    return rows, math.exp(math.log(t0) + slope * (math.log(target) - math.log(e0)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ember", default=os.path.join(ROOT, "target", "release", "ember"))
    ap.add_argument("--scenes", default="original,glossy")
    ap.add_argument("--target-original", type=float, default=1e-3)
    ap.add_argument("--target-glossy", type=float, default=1e-2)
    ap.add_argument("--target-room", type=float, default=1e-2)
    ap.add_argument("--room-dir", help="shared/meshes/grey-white-room")
    ap.add_argument("--room-reference", help="a converged ember render of the room")
    ap.add_argument("--room-size", default="160x90")
    ap.add_argument("--cycles-dir")
    ap.add_argument("--cycles-python", default=sys.executable)
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()}")
    table = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in args.scenes.split(","):
            target = getattr(args, f"target_{scene}")
            reference = args.room_reference if scene == "room" else os.path.join(REFS, SCENES[scene][1])
            print(f"{scene}: target relMSE {target:g}")

            def ember_measure(extra):
                def measure(p):
                    out = os.path.join(tmp, "e.exr")
                    wall, note = ember_point(args, scene, out, extra(p))
                    return wall, rel_mse(args.ember, out, reference), note
                return measure

            thresholds = [0.4 / math.sqrt(2) ** k for k in range(16)]
            doubling = [2 ** k for k in range(0, 14)]
            # Adaptive with a denoiser: the budget --spp doubles, each pixel takes a
            # quarter of it first, and stops below T = 0.1 (a relMSE of about 1e-2
            # before denoising).
            budget = lambda spp: ["--spp", str(4 * spp), "--min-spp", str(spp), "--noise-threshold", "0.1"]
            methods = [
                ("uniform", doubling[2:], ember_measure(lambda spp: ["--spp", str(spp)])),
                ("adaptive (--min-spp 32)", thresholds,
                 ember_measure(lambda t: ["--spp", "8192", "--noise-threshold", f"{t:.4g}"])),
                ("uniform+denoise", doubling,
                 ember_measure(lambda spp: ["--spp", str(spp), "--denoise"])),
                ("adaptive+denoise", doubling, ember_measure(lambda spp: budget(spp) + ["--denoise"])),
            ]
            if args.cycles_dir and scene != "room":  # Cycles' peer maps no textures
                def cycles_measure(spp):
                    out = os.path.join(tmp, "c.exr")
                    wall, note = cycles_point(args, scene, out, spp)
                    return wall, rel_mse(args.ember, out, reference), note[:120]
                methods.append(("cycles adaptive+OIDN", [2 ** k for k in range(0, 12)], cycles_measure))
            for name, points, measure in methods:
                _, at = sweep(name, points, target, measure)
                table.append((scene, name, target, at))
    print(f"load average after: {os.getloadavg()}")
    print("\n| scene | method | target relMSE | seconds to reach it | vs uniform |")
    print("|---|---|---|---|---|")
    for scene, name, target, at in table:
        uniform = next(a for s, n, _, a in table if s == scene and n == "uniform")
        ratio = f"{uniform / at:.1f}x" if at and uniform else "-"
        shown = f"{at:.2f}" if at else "not reached"
        print(f"| {scene} | {name} | {target:g} | {shown} | {ratio} |")


if __name__ == "__main__":
    main()
