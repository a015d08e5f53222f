#!/usr/bin/env python3
"""Light sampling compared in one sitting (issue 20): relMSE at equal spp and efficiency
(1 / (relMSE x seconds)) of two or more variants of `ember render` on one scene, run
alternately round by round so that drift in the machine's load hits all alike.

A variant is NAME=BINARY[:EXTRA ARGS], e.g. `alias=target/release/ember:--light-sampler alias`
or `main=/tmp/main/ember`. Seconds are the render's own (ember's summary line); relMSE is
`ember compare IMAGE REFERENCE`; with --cpu, seconds are the process's CPU time instead
(steadier on a busy machine; use it with --threads 1). Every round uses another seed. Prints one line per run,
then the means and the ratios against the first variant.

Usage:
  benches/light_sampling.py --reference REF.exr --variant NAME=BIN[:ARGS] --variant ...
                            [--rounds 3] [--cpu] [--crop X,Y,W,H ...] -- SCENE.obj [render flags...]
Example (the many-light room; the reference is ember's own at 4096 spp):
  benches/light_sampling.py --reference ref.exr \\
      --variant alias=target/release/ember:"--light-sampler alias" \\
      --variant bvh=target/release/ember:"--light-sampler bvh" \\
      -- meshes/many-light-room.obj --eye 1.2,1.6,7.2 --look-at 10,1.0,2 \\
         --width 160 --height 90 --spp 64
"""
import argparse
import os
import re
import resource
import shlex
import subprocess
import sys
import tempfile


def render(binary, args, out, seed, cpu):
    cmd = [binary, "render", *args, "--seed", str(seed), "-o", out]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(cmd, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    found = re.search(r" in ([0-9.]+) s:", done.stderr)
    if done.returncode != 0 or not found:
        sys.exit(f"error: {shlex.join(cmd)}: {done.stderr.strip()}")
    if cpu:
        # The process's CPU time (loading included), less sensitive than wall time to
        # other work on a shared machine.
        return (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return float(found.group(1))


def relmse(binary, image, reference, crop=None):
    crop_args = ["--crop", crop] if crop else []
    out = subprocess.run([binary, "compare", image, reference, *crop_args], capture_output=True, text=True)
    found = re.search(r"relMSE ([0-9.eE+-]+)", out.stdout)
    if not found:
        sys.exit(f"error: ember compare {image}: {out.stderr.strip() or out.stdout.strip()}")
    return float(found.group(1))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--reference", required=True)
    parser.add_argument("--variant", action="append", required=True)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--crop", action="append", default=[], metavar="X,Y,W,H",
        help="also report relMSE inside this rectangle (ember compare --crop); repeatable",
    )
    parser.add_argument(
        "--cpu", action="store_true", help="seconds of CPU time of the whole process, not the render's wall time"
    )
    parser.add_argument("render", nargs=argparse.REMAINDER)
    opts = parser.parse_args()
    render_args = [a for a in opts.render if a != "--"]
    variants = []
    for v in opts.variant:
        name, rest = v.split("=", 1)
        binary, _, extra = rest.partition(":")
        variants.append((name, binary, shlex.split(extra)))
    print(f"load average before: {os.getloadavg()}")
    results = {name: [] for name, _, _ in variants}
    crop_results = {name: [] for name, _, _ in variants}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(opts.rounds):
            for name, binary, extra in variants:
                out = os.path.join(tmp, f"{name}-{r}.exr")
                seconds = render(binary, render_args + extra, out, 1000 + r, opts.cpu)
                error = relmse(variants[0][1], out, opts.reference)
                results[name].append((seconds, error))
                crops = [relmse(variants[0][1], out, opts.reference, c) for c in opts.crop]
                crop_results[name].append(crops)
                shown = "".join(f", crop {c} relMSE {e:.4e}" for c, e in zip(opts.crop, crops))
                print(f"round {r} {name}: {seconds:.2f} s, relMSE {error:.4e}{shown}", flush=True)
    print(f"load average after: {os.getloadavg()}")
    base_s = sum(s for s, _ in results[variants[0][0]]) / opts.rounds
    base_e = sum(e for _, e in results[variants[0][0]]) / opts.rounds
    print("| variant | seconds | relMSE | relMSE ratio | efficiency ratio |")
    print("|---|---|---|---|---|")
    for name, _, _ in variants:
        s = sum(x for x, _ in results[name]) / opts.rounds
        e = sum(x for _, x in results[name]) / opts.rounds
        print(
            f"| {name} | {s:.2f} | {e:.4e} | {base_e / e:.2f}x lower | "
            f"{(base_e * base_s) / (e * s):.2f}x |"
        )
    for k, crop in enumerate(opts.crop):
        mean = lambda name: sum(c[k] for c in crop_results[name]) / opts.rounds
        base = mean(variants[0][0])
        print(f"crop {crop}: " + ", ".join(
            f"{name} relMSE {mean(name):.4e} ({base / mean(name):.2f}x lower)" for name, _, _ in variants))


if __name__ == "__main__":
    main()
