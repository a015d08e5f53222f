#!/usr/bin/env python3
"""How fast ember reads a glTF beside the same mesh as OBJ: each OBJ is converted to a
.glb by Blender's own importer and exporter (positions, normals, texture coordinates;
no images), then ember renders each file at 1 sample of 16x16 pixels, alternating the
formats for --rounds rounds, and its summary line's loading time is read.

    VENV/bin/python benches/gltf_load_speed.py --ember target/release/ember \\
        [--rounds 5] [--instances 100] [--keep DIR] OBJ [OBJ ...]

VENV has Blender as a module (`python3 -m venv VENV && VENV/bin/pip install bpy`). An
OBJ's MTL is used without its texture lines (map_*, bump, norm, disp, refl), so that
neither file loads images and the two carry the same triangles and materials.

Printed per file: triangles, file size, the median loading time of the rounds, MB/s
(file bytes over loading time: text for OBJ, JSON plus buffers for glTF) and million
triangles per second, the measure that compares the formats on the same mesh. Then,
per file, the .glb once more with its nodes placed --instances times side by side (the
same meshes, more nodes): triangles rendered and ember's peak memory against the
.glb's own, which shows what instancing by mesh reuse costs per copy. A measuring
tool, not part of ember; run it on a quiet machine.
"""

import argparse
import json
import struct
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

TEXTURE_LINE = re.compile(r"^\s*(map_|bump|norm|disp|refl)", re.IGNORECASE)
LOADING = re.compile(r"loading ([0-9.]+) s at")
PEAK = re.compile(r"peak memory ([0-9.]+) MiB")
TRIANGLES = re.compile(r"^triangles: (\d+)", re.MULTILINE)
PLACED = re.compile(r"placements put (\d+) triangles in the world")


def untextured_copy(obj, folder):
    """`obj` and its MTL files copied into `folder`, the MTLs without texture lines."""
    source = os.path.dirname(os.path.abspath(obj))
    target = os.path.join(folder, os.path.basename(obj))
    shutil.copy(obj, target)
    for name in os.listdir(source):
        if name.lower().endswith(".mtl"):
            with open(os.path.join(source, name), errors="replace") as f:
                lines = [line for line in f if not TEXTURE_LINE.match(line)]
            with open(os.path.join(folder, name), "w") as f:
                f.writelines(lines)
    return target


def convert(obj, glb):
    """Blender's OBJ import, then its glTF export as a .glb. Run in a process of its own."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.obj_import(filepath=obj, forward_axis="NEGATIVE_Z", up_axis="Y")
    bpy.ops.export_scene.gltf(filepath=glb, export_format="GLB", export_image_format="NONE",
                              export_apply=True, export_yup=True)


def instanced_copy(glb, copies, out):
    """`glb` with every node that holds a mesh placed `copies` times along x, twice the
    largest extent of its positions apart: new nodes, the same meshes and buffers."""
    with open(glb, "rb") as f:
        data = f.read()
    (json_length,) = struct.unpack_from("<I", data, 12)
    doc = json.loads(data[20:20 + json_length])
    rest = data[20 + json_length:]
    extent = max(max(h - l for h, l in zip(a["max"], a["min"]))
                 for a in doc["accessors"] if "max" in a and len(a["max"]) == 3)
    placed = [n for n in doc["nodes"] if "mesh" in n and "matrix" not in n]
    nodes = []
    for k in range(copies):
        for n in placed:
            t = n.get("translation", [0.0, 0.0, 0.0])
            copy = dict(n, translation=[t[0] + 2.0 * extent * k, t[1], t[2]])
            copy.pop("children", None)
            nodes.append(copy)
    doc["nodes"] = nodes
    doc["scenes"] = [{"nodes": list(range(len(nodes)))}]
    doc["scene"] = 0
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
    with open(out, "wb") as f:
        f.write(b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body)


def run_summary(ember, scene, out):
    """ember's stderr for a 1-sample 16x16 render of `scene`."""
    args = [ember, "render", scene, "-o", out, "--spp", "1", "--width", "16", "--height",
            "16", "--threads", "2"]
    run = subprocess.run(args, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"{scene}: ember failed: {run.stderr.strip().splitlines()[-1:]}")
    return run.stderr


def loading_seconds(ember, scene, out):
    return float(LOADING.search(run_summary(ember, scene, out)).group(1))


def peak_mib(ember, scene, out):
    return float(PEAK.search(run_summary(ember, scene, out)).group(1))


def triangles(ember, scene):
    run = subprocess.run([ember, "info", scene], capture_output=True, text=True)
    found = PLACED.search(run.stdout) or TRIANGLES.search(run.stdout)
    return int(found.group(1)) if found else 0


def main():
    if "--convert-one" in sys.argv:
        i = sys.argv.index("--convert-one")
        convert(sys.argv[i + 1], sys.argv[i + 2])
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ember", required=True)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--instances", type=int, default=100)
    ap.add_argument("--keep", help="keep the converted files in this folder")
    ap.add_argument("objs", nargs="+")
    a = ap.parse_args()
    work = a.keep or tempfile.mkdtemp(prefix="gltf-load-")
    pairs = []
    for obj in a.objs:
        stem = os.path.splitext(os.path.basename(obj))[0]
        folder = os.path.join(work, stem)
        os.makedirs(folder, exist_ok=True)
        plain = untextured_copy(obj, folder)
        glb = os.path.join(folder, stem + ".glb")
        if not os.path.exists(glb):
            subprocess.run([sys.executable, os.path.abspath(__file__), "--convert-one", plain,
                            glb], check=True, capture_output=True)
        pairs.append((stem, plain, glb))
    print(f"ember {a.ember}, {a.rounds} rounds alternating, median loading time\n")
    print("| mesh | format | triangles | MB | loading s | MB/s | Mtriangles/s |")
    print("|---|---|---|---|---|---|---|")
    out = os.path.join(work, "out.png")
    for stem, plain, glb in pairs:
        times = {plain: [], glb: []}
        for _ in range(a.rounds):
            for scene in (plain, glb):
                times[scene].append(loading_seconds(a.ember, scene, out))
        for scene, kind in ((plain, "OBJ"), (glb, "GLB")):
            n = triangles(a.ember, scene)
            mb = os.path.getsize(scene) / 1e6
            t = statistics.median(times[scene])
            print(f"| {stem} | {kind} | {n} | {mb:.1f} | {t:.3f} | {mb / t:.0f} | "
                  f"{n / 1e6 / t:.2f} |")
        sys.stdout.flush()
    print(f"\nEach .glb alone and with its nodes placed {a.instances} times:\n")
    print("| mesh | copies | triangles rendered | peak MiB | MiB per copy past the first |")
    print("|---|---|---|---|---|")
    for stem, _, glb in pairs:
        many = glb.replace(".glb", f"-x{a.instances}.glb")
        instanced_copy(glb, a.instances, many)
        one_peak, many_peak = peak_mib(a.ember, glb, out), peak_mib(a.ember, many, out)
        per_copy = (many_peak - one_peak) / max(a.instances - 1, 1)
        print(f"| {stem} | 1 | {triangles(a.ember, glb)} | {one_peak:.1f} | |")
        print(f"| {stem} | {a.instances} | {triangles(a.ember, many)} | {many_peak:.1f} | "
              f"{per_copy:.3f} |")


if __name__ == "__main__":
    main()
