#!/usr/bin/env python3
"""ember against Blender Cycles on the same glTF files: each scene rendered by ember and by
Blender's own glTF importer plus Cycles, at the same camera (the file's first), size,
samples and depth, and compared by image mean and relMSE in a Markdown table.

    VENV/bin/python benches/cycles_gltf.py --ember target/release/ember
        [--scenes tests/data/gltf] [--only NAME ...] [--spp 256] [--size 128]
        [--max-depth 8] [--seed 1] [--threads 2] [--keep DIR]

VENV has Blender as a module (`python3 -m venv VENV && VENV/bin/pip install bpy numpy`).
The scenes are those of scripts/make_gltf_test_scenes.py (shipped in tests/data/gltf):

| scene | light |
|---|---|
| cornell-original.glb | its emissive ceiling lamp (KHR_materials_emissive_strength) |
| spheres.glb | a uniform sky of radiance 1 (`--background 1,1,1`; Cycles' world colour 1) |
| interior.glb | a point and a spot light (KHR_lights_punctual), no sky |
| textured.glb | a sun (KHR_lights_punctual) and a uniform sky of radiance 0.2 |
| glass.glb | a uniform sky of radiance 1 |

The Cycles side adapts `gltf_render.py` of the Cycles peer that ember's developers keep
beside the repository (shared/peers/cycles, not part of ember) with the film settings of
that peer's `render.py`: box pixel filter 1 px wide, no clamping, no glossy filter,
caustics on, `max_bounces = max_depth - 2` for every kind (Cycles' 0 bounces is direct
light), no denoising or adaptive sampling. Blender's importer reads glTF lights at
683 lm/W with radius 0, as ember does. A material that is not `doubleSided` has no back
face in glTF, so its emission is made front-only (Blender emits from both faces).

What differs by design, so what the comparison measures: Blender maps metallic-roughness
onto its Principled BSDF, whose GGX layers carry multiple-scattering compensation and whose
dielectric layering is Blender's own (ember follows the glTF specification's Appendix B
BRDF); Cycles' GGX uses height-correlated Smith masking; Cycles samples with Sobol-Burley
patterns and starts Russian roulette after the 2nd bounce. relMSE is
mean((ember - cycles)^2 / (cycles^2 + 0.01)) over pixels and channels (ember compare's
definition), so it holds both renderers' noise as well as their difference.

A measuring tool, not part of ember; it takes no timings.
"""

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)

SCENES = [
    ("cornell-original.glb", 0.0),
    ("spheres.glb", 1.0),
    ("interior.glb", 0.0),
    ("textured.glb", 0.2),
    ("glass.glb", 1.0),
]


def cycles_render(scene, out_npy, spp, size, max_depth, seed, threads, background):
    """Renders `scene` with Blender's glTF importer and Cycles (CPU) into `out_npy`
    (float32 H x W x 3, row 0 at the top). Run in a process of its own."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=scene)
    sc = bpy.context.scene
    cameras = [o for o in sc.objects if o.type == "CAMERA"]
    if not cameras:
        sys.exit(f"{scene}: no camera in the file")
    sc.camera = cameras[0]
    one_sided_emission(bpy)
    c = sc.cycles
    sc.render.engine = "CYCLES"
    c.device = "CPU"
    sc.render.threads_mode = "FIXED"
    sc.render.threads = threads
    c.samples = spp
    c.seed = seed
    c.use_animated_seed = False
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.use_guiding = False
    bounces = max(max_depth - 2, 0)
    for name in ("max_bounces", "diffuse_bounces", "glossy_bounces",
                 "transmission_bounces", "transparent_max_bounces"):
        setattr(c, name, bounces)
    c.volume_bounces = 0
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.use_fast_gi = False
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    sc.render.resolution_x = sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.render.film_transparent = False
    sc.render.dither_intensity = 0.0
    world = bpy.data.worlds.new("world")
    sc.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs[0].default_value = (background, background, background, 1.0)
    bg.inputs[1].default_value = 1.0
    sc.view_settings.view_transform = "Standard"
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    with tempfile.TemporaryDirectory() as tmp:
        sc.render.filepath = os.path.join(tmp, "cycles.exr")
        bpy.ops.render.render(write_still=True)
        np.save(out_npy, read_exr(sc.render.filepath, bpy))
    np.save(out_npy.replace(".npy", "-objects.npy"), object_masks(bpy, sc, size))
    for o in sc.objects:
        if o.type == "LIGHT":
            print(f"light {o.name}: {o.data.type} {o.data.energy:.4g} W", file=sys.stderr)


def object_masks(bpy, sc, size):
    """Which object each pixel's centre sees, as a size x size array of strings ("" for
    none), row 0 at the top: a ray from the camera through the pixel centre, cast by
    Blender into the scene it renders. Only pixels whose 3x3 neighbourhood sees the same
    object count in a region's mean (`region_means`), so edges, where the two renderers'
    pixel filters differ, are left out."""
    cam = sc.camera
    depsgraph = bpy.context.evaluated_depsgraph_get()
    # view_frame: top-right, bottom-right, bottom-left, top-left in camera space.
    tr, br, bl, tl = (cam.matrix_world @ v for v in cam.data.view_frame(scene=sc))
    origin = cam.matrix_world.translation
    names = np.full((size, size), "", dtype=object)
    for row in range(size):
        v = (row + 0.5) / size
        left, right = tl.lerp(bl, v), tr.lerp(br, v)
        for col in range(size):
            target = left.lerp(right, (col + 0.5) / size)
            hit, _, _, _, obj, _ = sc.ray_cast(depsgraph, origin, (target - origin).normalized())
            names[row, col] = obj.name if hit else ""
    return names.astype(str)


def region_means(image, names, prefix):
    """Each object whose name starts with `prefix`: the mean of `image` over the pixels
    inside its silhouette (3x3 neighbourhood all on it)."""
    same = np.ones(names.shape, dtype=bool)
    padded = np.pad(names, 1, mode="edge")
    h, w = names.shape
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            same &= padded[dy:dy + h, dx:dx + w] == names
    means = {}
    for name in sorted(set(names.ravel())):
        inside = same & (names == name)
        if name.startswith(prefix) and inside.any():
            means[name] = image[inside].mean()
    return means


def one_sided_emission(bpy):
    """Emission of materials that are not doubleSided (the importer marks them
    use_backface_culling) made front-only: strength * (1 - Backfacing)."""
    for m in bpy.data.materials:
        p = m.node_tree.nodes.get("Principled BSDF") if m.use_nodes else None
        if p is None or not m.use_backface_culling:
            continue
        strength = p.inputs["Emission Strength"]
        colour = p.inputs["Emission Color"].default_value[:3]
        if strength.is_linked or strength.default_value == 0 or max(colour) == 0:
            continue
        nt = m.node_tree
        geometry = nt.nodes.new("ShaderNodeNewGeometry")
        front = nt.nodes.new("ShaderNodeMath")
        front.operation = "SUBTRACT"
        front.inputs[0].default_value = 1.0
        scaled = nt.nodes.new("ShaderNodeMath")
        scaled.operation = "MULTIPLY"
        scaled.inputs[1].default_value = strength.default_value
        nt.links.new(geometry.outputs["Backfacing"], front.inputs[1])
        nt.links.new(front.outputs[0], scaled.inputs[0])
        nt.links.new(scaled.outputs[0], strength)


def read_exr(path, bpy=None):
    """An EXR's RGB as float64 H x W x 3, row 0 at the top, read by Blender."""
    if bpy is None:
        import bpy
    image = bpy.data.images.load(path)
    w, h = image.size
    pixels = np.array(image.pixels[:], dtype=np.float64).reshape(h, w, image.channels)
    bpy.data.images.remove(image)
    return pixels[::-1, :, :3]


def ember_render(ember, scene, out_exr, a, background):
    """ember's render of `scene` with its default engine; None and the error line when
    ember cannot render it."""
    b = f"{background:g}"
    args = [ember, "render", scene, "-o", out_exr, "--width", str(a.size),
            "--height", str(a.size), "--spp", str(a.spp), "--max-depth", str(a.max_depth),
            "--seed", str(a.seed), "--threads", str(a.threads), "--background", f"{b},{b},{b}"]
    run = subprocess.run(args, capture_output=True, text=True)
    if run.returncode != 0:
        lines = run.stderr.strip().splitlines()
        return None, lines[-1] if lines else f"exit {run.returncode}"
    return read_exr(out_exr), None


def main():
    if "--cycles-one" in sys.argv:
        i = sys.argv.index("--cycles-one")
        scene, out, spp, size, depth, seed, threads, background = sys.argv[i + 1:i + 9]
        cycles_render(scene, out, int(spp), int(size), int(depth), int(seed), int(threads),
                      float(background))
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ember", required=True, help="the ember binary to compare")
    ap.add_argument("--scenes", default=os.path.join(REPO, "tests", "data", "gltf"))
    ap.add_argument("--only", nargs="*", help="scene file names to run (default: all)")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--keep", help="keep the images (EXR, npy) in this folder")
    a = ap.parse_args()
    out = a.keep or tempfile.mkdtemp(prefix="cycles-gltf-")
    os.makedirs(out, exist_ok=True)
    print(f"{a.size}x{a.size}, {a.spp} spp, max depth {a.max_depth}, seed {a.seed}; "
          f"ember {a.ember}\n")
    print("| scene | Cycles mean | ember mean | ember / Cycles | relMSE |")
    print("|---|---|---|---|---|")
    regions = []
    for name, background in SCENES:
        if a.only and name not in a.only:
            continue
        scene = os.path.join(a.scenes, name)
        stem = os.path.splitext(name)[0]
        cycles_npy = os.path.join(out, f"{stem}-cycles.npy")
        worker = [sys.executable, os.path.abspath(__file__), "--cycles-one", scene, cycles_npy,
                  str(a.spp), str(a.size), str(a.max_depth), str(a.seed), str(a.threads),
                  str(background)]
        subprocess.run(worker, check=True, capture_output=True)
        cycles = np.load(cycles_npy)
        ember, error = ember_render(a.ember, scene, os.path.join(out, f"{stem}-ember.exr"),
                                    a, background)
        if ember is None:
            error = error.replace("|", "\\|")
            print(f"| {stem} | {cycles.mean():.5f} | not rendered: {error} | | |")
            continue
        rel = ((ember - cycles) ** 2 / (cycles ** 2 + 0.01)).mean()
        ratio = ember.mean() / cycles.mean()
        print(f"| {stem} | {cycles.mean():.5f} | {ember.mean():.5f} | {ratio:.4f} | {rel:.3e} |")
        regions.append((stem, np.load(cycles_npy.replace(".npy", "-objects.npy")),
                        cycles, ember))
        sys.stdout.flush()
    print_regions(regions)


def print_regions(regions):
    """Each object's mean in each scene (the spheres named `metallicM-roughnessR`...)."""
    rows = []
    for stem, names, cycles, ember in regions:
        c, e = region_means(cycles, names, ""), region_means(ember, names, "")
        rows += [(stem, name, c[name], e[name]) for name in c if name]
    if not rows:
        return
    print("\nEach object's mean over its silhouette (pixels whose 3x3 neighbourhood is on it):\n")
    print("| scene | object | Cycles mean | ember mean | ember / Cycles |")
    print("|---|---|---|---|---|")
    for stem, name, c, e in rows:
        print(f"| {stem} | {name} | {c:.5f} | {e:.5f} | {e / c:.4f} |")


if __name__ == "__main__":
    main()
