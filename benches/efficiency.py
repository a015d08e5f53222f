#!/usr/bin/env python3
"""Efficiency of ember against Mitsuba 3 on the Cornell boxes, in one sitting (issue 12).

Efficiency is 1 / (relMSE x seconds): relMSE against the shipped references
(tests/data/references), seconds of rendering as each renderer reports them (ember's
summary line, Mitsuba's `render_s`); the whole process's CPU
time, loading and Mitsuba's JIT included, is printed beside them. The
renderers run alternately, scene by scene, so that drift in the machine's load hits
both alike. Nothing else should run meanwhile: the script prints the load average
before and after, and a busy machine makes the table worthless.

Usage:
  benches/efficiency.py --mitsuba-dir DIR [--ember target/release/ember] [--spp 256]
                        [--scenes original,glossy] [--samplers independent,multijitter,ldsampler]
                        [--engines scalar,wavefront] [--threads N] [--rounds R]

`--engines` renders with each ember engine (`--engine`); `--threads` gives both renderers
that many threads (default: all); `--rounds` repeats the whole alternation and reports
each renderer's mean. Beside the render seconds the table gives the CPU seconds of the
whole process (user + system, from the kernel's accounting of the child), which a
loaded machine disturbs far less than wall time.

DIR holds Mitsuba's `render.py` (the peer scripts that made the references; they need
`pip install mitsuba numpy` and, for the LLVM variant, Debian's libllvm19). Images go
to a temporary directory; the table is printed as Markdown.
"""
import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFS = os.path.join(ROOT, "tests", "data", "references")

# The settings every reference was made with: camera, image, depth, box filter.
CAMERA = {"eye": (0, 1, 3.9), "target": (0, 1, 0), "up": (0, 1, 0), "fov": 40}
SIZE, DEPTH = 512, 8

SCENES = {
    "original": ("meshes/CornellBox-Original.obj", "cornell-box/cornell_ref_8192spp.exr", []),
    "glossy": (
        "meshes/CornellBox-GlossyMix.obj",
        "cornell-glossy/CornellBox-GlossyMix_ref_4096spp.exr",
        ["--materials", "mtl"],
    ),
}


def child_cpu_seconds():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def timed(cmd, json_out=None):
    """Runs `cmd`, failing loudly; returns (render seconds, whole-process CPU seconds)."""
    before = child_cpu_seconds()
    done = subprocess.run(cmd, capture_output=True, text=True)
    cpu = child_cpu_seconds() - before
    if done.returncode != 0:
        sys.exit(f"error: {' '.join(cmd)} failed:\n{done.stderr.strip()}")
    if json_out:
        with open(json_out) as f:
            return json.load(f)["render_s"], cpu
    found = re.search(r" in ([0-9.]+) s:", done.stdout + done.stderr)
    if not found:
        sys.exit(f"error: no render time in ember's summary:\n{done.stderr.strip()}")
    return float(found.group(1)), cpu


def rel_mse(ember, image, reference, peer_compare):
    """relMSE of `image` (ember's EXR, or Mitsuba's .npy through the peer's compare.py)."""
    if image.endswith(".npy"):
        cmd = [sys.executable, peer_compare, image, reference]
    else:
        cmd = [ember, "compare", image, reference]
    out = subprocess.run(cmd, capture_output=True, text=True)
    found = re.search(r"relMSE\s*:?\s*([0-9.eE+-]+)", out.stdout)
    if out.returncode != 0 or not found:
        sys.exit(f"error: comparing {image}: {out.stderr.strip() or out.stdout.strip()}")
    return float(found.group(1))


def ember_cmd(ember, scene, spp, out, engine, threads):
    c = CAMERA
    more = ["--threads", str(threads)] if threads else []
    return [ember, "render", scene, "--engine", engine, *more, "--spp", str(spp), "--seed", "1",
            "--max-depth", str(DEPTH), "--width", str(SIZE), "--height", str(SIZE),
            "--fov", str(c["fov"]), "--eye", ",".join(map(str, c["eye"])),
            "--look-at", ",".join(map(str, c["target"])), "--up", ",".join(map(str, c["up"])),
            "-o", out]


def mitsuba_cmd(render_py, scene, extra, sampler, spp, out, threads):
    c = CAMERA
    return [sys.executable, render_py, scene, *extra, "--threads", str(threads),
            "--origin", *map(str, c["eye"]), "--target", *map(str, c["target"]),
            "--up", *map(str, c["up"]), "--fov", str(c["fov"]),
            "--width", str(SIZE), "--height", str(SIZE), "--max-depth", str(DEPTH),
            "--variant", "llvm_ad_rgb", "--rfilter", "box", "--sampler", sampler,
            "--spp", str(spp), "--seed", "7", "--npy", out, "--json", out + ".json"]


def main():
    args = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args.add_argument("--mitsuba-dir", required=True)
    args.add_argument("--ember", default=os.path.join(ROOT, "target", "release", "ember"))
    args.add_argument("--spp", type=int, default=256)
    args.add_argument("--scenes", default="original,glossy")
    args.add_argument("--samplers", default="independent,multijitter,ldsampler")
    args.add_argument("--engines", default="scalar")
    args.add_argument("--threads", type=int, default=0)
    args.add_argument("--rounds", type=int, default=1)
    a = args.parse_args()
    render_py = os.path.join(a.mitsuba_dir, "render.py")
    if not os.path.isfile(render_py):
        sys.exit(f"error: no render.py in {a.mitsuba_dir}")
    print(f"load average before: {os.getloadavg()[0]:.2f}", file=sys.stderr)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.scenes.split(","):
            obj, ref, extra = SCENES[name]
            obj, ref = os.path.join(ROOT, obj), os.path.join(REFS, ref)
            runs = []
            for engine in a.engines.split(","):
                out = f"{tmp}/ember-{engine}.exr"
                cmd = ember_cmd(a.ember, obj, a.spp, out, engine, a.threads)
                runs.append((f"ember {engine}", cmd, out, None))
            for s in a.samplers.split(","):
                # .npy: Mitsuba 3.9's EXR writer hangs with --threads 1.
                out = f"{tmp}/mitsuba-{s}.npy"
                cmd = mitsuba_cmd(render_py, obj, extra, s, a.spp, out, a.threads)
                runs.append((f"Mitsuba {s}", cmd, out, out + ".json"))
            # Every renderer once per round, in turn, and ember's first again at the end,
            # so that drift in the load hits all alike; each row is the mean of its runs.
            results = {}
            for label, cmd, out, json_out in runs * a.rounds + runs[:1]:
                render, cpu = timed(cmd, json_out)
                err = rel_mse(a.ember, out, ref, os.path.join(a.mitsuba_dir, "compare.py"))
                results.setdefault(label, []).append((render, cpu, err))
            best_peer = 0.0
            for label, measured in results.items():
                render = sum(m[0] for m in measured) / len(measured)
                cpu = sum(m[1] for m in measured) / len(measured)
                err = measured[-1][2]
                eff = 1.0 / (err * render)
                if not label.startswith("ember"):
                    best_peer = max(best_peer, eff)
                rows.append([name, label, render, cpu, err, eff])
            for row in rows:
                if row[0] == name and row[1].startswith("ember"):
                    row.append(row[5] / best_peer)
    print(f"load average after: {os.getloadavg()[0]:.2f}", file=sys.stderr)
    print(f"spp {a.spp}, threads {a.threads or 'all'}, rounds {a.rounds}")
    print("| scene | renderer | render s | process CPU s | relMSE | efficiency | vs best peer |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        ratio = f"{row[6]:.2f}x" if len(row) > 6 else ""
        print(f"| {row[0]} | {row[1]} | {row[2]:.2f} | {row[3]:.2f} | {row[4]:.3e} "
              f"| {row[5]:.1f} | {ratio} |")


if __name__ == "__main__":
    main()
