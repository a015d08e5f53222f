#!/usr/bin/env python3
"""Writes the glTF scenes ember is compared on against Blender Cycles
(benches/cycles_gltf.py), with Blender's own glTF exporter: real exporter output, as a
Blender user's files are.

    VENV/bin/python scripts/make_gltf_test_scenes.py OUT_DIR

VENV is a Python environment with Blender as a module (`python3 -m venv VENV &&
VENV/bin/pip install bpy numpy`). Writes, each a .glb with its camera:

- cornell-original.glb: meshes/CornellBox-Original.obj with its MTL, imported by
  Blender's OBJ importer (its MTL mapping: Kd as base colour, Ns as roughness, Ke as
  emission) and exported as it stands; the camera of the Cornell references (eye
  0,1,3.9, looking at 0,1,0, 40 degrees vertical).
- spheres.glb: a row of six spheres, metallic 0 and 1 by roughness 0.2, 0.5 and 1.0,
  base colour (0.9, 0.6, 0.3), on a floor of base colour 0.5, roughness 1; for a
  uniform sky (glTF has no sky: the benchmark gives both renderers the same one).
- interior.glb: a closed box room (walls 0.7 grey, floor 0.5 with a red and a green
  wall), a cube and a sphere, lit only by a point light and a spot light
  (KHR_lights_punctual, which the exporter writes from Blender's watts).
- textured.glb: textures as Blender writes them, each image made here (64x64): a floor
  with a checker base colour (sRGB), a sphere whose metallic-roughness texture has
  stripes of metal and of roughness, a cube with a normal map of ridges; lit by a sun
  (KHR_lights_punctual directional) and a uniform sky the benchmark gives (0.2).
- glass.glb: a row of glass spheres (Principled BSDF's Transmission Weight 1, which the
  exporter writes as KHR_materials_transmission, and its IOR as KHR_materials_ior):
  clear at roughness 0, 0.2 and 0.5 (index 1.5), clear water (1.33) at roughness 0, a
  base colour (0.9, 0.6, 0.3) glass at roughness 0.2, and half transmission over that
  base colour at roughness 0.3; in front of a floor and a back wall of base colour
  0.5 with a white stripe on each, so that refraction shows; for a uniform sky.

Each file is rebuilt from scratch on every run. The exporter's order of a sphere's
triangles in its index buffer differs from run to run; the geometry does not.
"""

import math
import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
SIZE = 128  # the render resolution the camera's aspect ratio is taken from


def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x = SIZE
    scene.render.resolution_y = SIZE
    return scene


def add_camera(scene, eye, look_at, vfov_degrees):
    """A perspective camera at `eye` looking at `look_at`, y up (glTF's frame: the
    exporter turns Blender's z-up into glTF's y-up, so positions here are Blender's
    (x, -z, y) of the glTF point)."""
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(vfov_degrees)
    camera = bpy.data.objects.new("camera", data)
    scene.collection.objects.link(camera)
    camera.location = blender(eye)
    direction = camera.location - blender_vector(look_at)
    camera.rotation_euler = direction.to_track_quat("Z", "Y").to_euler()
    scene.camera = camera
    return camera


def blender(p):
    """glTF's (x, y, z), y up, as Blender's z-up coordinates."""
    return (p[0], -p[2], p[1])


def blender_vector(p):
    import mathutils

    return mathutils.Vector(blender(p))


def material(name, base, metallic=0.0, roughness=1.0, transmission=0.0, ior=1.5):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*base, 1.0)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Transmission Weight"].default_value = transmission
    bsdf.inputs["IOR"].default_value = ior
    return m


def add_mesh(scene, name, make, mat, location=(0, 0, 0), smooth=False):
    """A primitive made by `make` (a bpy.ops.mesh operator call), at a glTF location."""
    make()
    obj = bpy.context.active_object
    obj.name = name
    obj.location = blender(location)
    obj.data.materials.append(mat)
    if smooth:
        bpy.ops.object.shade_smooth()
    return obj


def export(path, texcoords=False):
    bpy.ops.export_scene.gltf(
        filepath=path,
        export_format="GLB",
        export_cameras=True,
        export_lights=True,
        export_texcoords=texcoords,
        export_apply=True,
        export_yup=True,
    )
    print(f"wrote {path} ({os.path.getsize(path)} bytes)")


def cornell(out):
    scene = empty_scene()
    obj = os.path.join(REPO, "meshes", "CornellBox-Original.obj")
    bpy.ops.wm.obj_import(filepath=obj, forward_axis="NEGATIVE_Z", up_axis="Y")
    add_camera(scene, (0.0, 1.0, 3.9), (0.0, 1.0, 0.0), 40.0)
    export(os.path.join(out, "cornell-original.glb"))


def spheres(out):
    scene = empty_scene()
    floor = material("floor", (0.5, 0.5, 0.5))
    add_mesh(
        scene, "floor", lambda: bpy.ops.mesh.primitive_plane_add(size=40.0), floor
    )
    for row, metallic in enumerate((0.0, 1.0)):
        for column, roughness in enumerate((0.2, 0.5, 1.0)):
            name = f"metallic{metallic:g}-roughness{roughness:g}"
            m = material(name, (0.9, 0.6, 0.3), metallic, roughness)
            x = (column - 1) * 1.1
            z = (row - 0.5) * 1.1
            make = lambda: bpy.ops.mesh.primitive_uv_sphere_add(
                segments=32, ring_count=16, radius=0.5
            )
            add_mesh(scene, name, make, m, (x, 0.5, z), smooth=True)
    add_camera(scene, (0.0, 3.0, 4.0), (0.0, 0.3, 0.0), 40.0)
    export(os.path.join(out, "spheres.glb"))


def interior(out):
    scene = empty_scene()
    grey = material("walls", (0.7, 0.7, 0.7))
    red = material("red", (0.7, 0.1, 0.1))
    green = material("green", (0.1, 0.6, 0.1))
    # The room: a cube seen from inside (normals flipped), 4 wide, 3 high, 4 deep.
    room = add_mesh(
        scene, "room", lambda: bpy.ops.mesh.primitive_cube_add(size=1.0), grey, (0, 1.5, 0)
    )
    room.scale = (4.0, 4.0, 3.0)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.flip_normals()
    bpy.ops.object.mode_set(mode="OBJECT")
    room.data.materials.append(red)
    room.data.materials.append(green)
    # Blender's cube: faces 0 (-x) and 2 (+x) as the coloured walls.
    room.data.polygons[0].material_index = 1
    room.data.polygons[2].material_index = 2
    add_mesh(
        scene,
        "block",
        lambda: bpy.ops.mesh.primitive_cube_add(size=0.8),
        material("block", (0.8, 0.8, 0.6)),
        (-0.7, 0.4, -0.6),
    )
    add_mesh(
        scene,
        "ball",
        lambda: bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.45),
        material("ball", (0.3, 0.4, 0.8), 0.0, 0.5),
        (0.8, 0.45, 0.2),
        smooth=True,
    )
    point = bpy.data.lights.new("point", "POINT")
    point.energy = 40.0  # W, which the exporter writes as 40 * 683 / (4 pi) cd
    point.shadow_soft_size = 0.0
    lamp = bpy.data.objects.new("point", point)
    lamp.location = blender((0.5, 2.6, 0.8))
    scene.collection.objects.link(lamp)
    spot = bpy.data.lights.new("spot", "SPOT")
    spot.energy = 80.0
    spot.shadow_soft_size = 0.0
    spot.spot_size = math.radians(50.0)
    spot.spot_blend = 0.3
    beam = bpy.data.objects.new("spot", spot)
    beam.location = blender((-1.2, 2.8, 1.2))
    direction = beam.location - blender_vector((-0.7, 0.0, -0.6))
    beam.rotation_euler = direction.to_track_quat("Z", "Y").to_euler()
    scene.collection.objects.link(beam)
    add_camera(scene, (0.0, 1.5, 1.9), (0.0, 1.0, -2.0), 60.0)
    export(os.path.join(out, "interior.glb"))


def image(name, pixel, colour_data):
    """A 64x64 image of `pixel(x, y)` -> (r, g, b) in [0, 1], packed into the .blend so
    that the exporter embeds it as PNG; `colour_data` images are sRGB, others raw data."""
    size = 64
    img = bpy.data.images.new(name, size, size, alpha=False)
    img.colorspace_settings.name = "sRGB" if colour_data else "Non-Color"
    values = []
    for y in range(size):
        for x in range(size):
            values += [*pixel(x, y), 1.0]
    img.pixels = values
    img.file_format = "PNG"
    img.pack()
    return img


def textured_material(name, base=None, metallic_roughness=None, normal=None):
    """A Principled BSDF fed by image textures wired as Blender's exporter recognises:
    an image into Base Color; one image's green into Roughness and blue into Metallic
    (through Separate Color); an image through a Normal Map node."""
    m = material(name, (0.8, 0.8, 0.8))
    nodes, links = m.node_tree.nodes, m.node_tree.links
    bsdf = nodes["Principled BSDF"]

    def texture(img):
        node = nodes.new("ShaderNodeTexImage")
        node.image = img
        node.interpolation = "Linear"
        return node

    if base is not None:
        links.new(texture(base).outputs["Color"], bsdf.inputs["Base Color"])
    if metallic_roughness is not None:
        split = nodes.new("ShaderNodeSeparateColor")
        links.new(texture(metallic_roughness).outputs["Color"], split.inputs["Color"])
        links.new(split.outputs["Green"], bsdf.inputs["Roughness"])
        links.new(split.outputs["Blue"], bsdf.inputs["Metallic"])
    if normal is not None:
        mapping = nodes.new("ShaderNodeNormalMap")
        links.new(texture(normal).outputs["Color"], mapping.inputs["Color"])
        links.new(mapping.outputs["Normal"], bsdf.inputs["Normal"])
    return m


def textured(out):
    scene = empty_scene()
    checker = image(
        "checker",
        lambda x, y: (0.8, 0.7, 0.2) if (x // 8 + y // 8) % 2 else (0.1, 0.2, 0.5),
        True,
    )
    # Stripes across u: metal in every other 16-texel band, roughness 0.2 or 0.7 in
    # bands of 8 (glTF: roughness in green, metal in blue).
    stripes = image(
        "metal-rough",
        lambda x, y: (0.0, 0.2 if (x // 8) % 2 else 0.7, 1.0 if (x // 16) % 2 else 0.0),
        False,
    )

    def ridge(x, y):
        # Tangent-space normals tilting back and forth along u: ridges.
        tilt = 0.5 * math.sin(2.0 * math.pi * x / 16.0)
        n = (tilt, 0.0, 1.0)
        length = math.sqrt(n[0] ** 2 + n[2] ** 2)
        return (0.5 + 0.5 * n[0] / length, 0.5, 0.5 + 0.5 * n[2] / length)

    ridges = image("ridges", ridge, False)
    add_mesh(
        scene,
        "floor",
        lambda: bpy.ops.mesh.primitive_plane_add(size=6.0),
        textured_material("checker-floor", base=checker),
    )
    add_mesh(
        scene,
        "striped-sphere",
        lambda: bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.6),
        textured_material("striped", metallic_roughness=stripes),
        (0.7, 0.6, 0.0),
        smooth=True,
    )
    add_mesh(
        scene,
        "ridged-cube",
        lambda: bpy.ops.mesh.primitive_cube_add(size=1.0),
        textured_material("ridged", normal=ridges),
        (-0.8, 0.5, 0.2),
    )
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 2.0  # W/m², which the exporter writes as 2 * 683 lux
    sun.angle = 0.0
    light = bpy.data.objects.new("sun", sun)
    light.rotation_euler = blender_vector((0.4, 1.0, 0.6)).to_track_quat("Z", "Y").to_euler()
    scene.collection.objects.link(light)
    add_camera(scene, (0.0, 2.2, 3.4), (0.0, 0.4, 0.0), 45.0)
    export(os.path.join(out, "textured.glb"), texcoords=True)


def glass(out):
    scene = empty_scene()
    grey = material("floor", (0.5, 0.5, 0.5))
    white = material("stripe", (0.95, 0.95, 0.95))
    add_mesh(scene, "floor", lambda: bpy.ops.mesh.primitive_plane_add(size=40.0), grey)
    wall = add_mesh(
        scene, "wall", lambda: bpy.ops.mesh.primitive_plane_add(size=40.0), grey, (0, 0, -1.5)
    )
    wall.rotation_euler = (math.radians(90.0), 0.0, 0.0)
    # White stripes on the floor (across the row) and the wall (along it), just above
    # them, for the balls to refract.
    stripe = add_mesh(
        scene, "floor-stripe", lambda: bpy.ops.mesh.primitive_plane_add(size=1.0), white,
        (0, 0.002, -0.9),
    )
    stripe.scale = (8.0, 0.25, 1.0)
    stripe = add_mesh(
        scene, "wall-stripe", lambda: bpy.ops.mesh.primitive_plane_add(size=1.0), white,
        (0, 1.0, -1.498),
    )
    stripe.rotation_euler = (math.radians(90.0), 0.0, 0.0)
    stripe.scale = (8.0, 0.3, 1.0)
    balls = [
        ("clear-r0", (1, 1, 1), 0.0, 1.0, 1.5),
        ("clear-r0.2", (1, 1, 1), 0.2, 1.0, 1.5),
        ("clear-r0.5", (1, 1, 1), 0.5, 1.0, 1.5),
        ("water-r0", (1, 1, 1), 0.0, 1.0, 1.33),
        ("amber-r0.2", (0.9, 0.6, 0.3), 0.2, 1.0, 1.5),
        ("half-r0.3", (0.9, 0.6, 0.3), 0.3, 0.5, 1.5),
    ]
    for i, (name, base, roughness, transmission, ior) in enumerate(balls):
        m = material(name, base, 0.0, roughness, transmission, ior)
        x = (i % 3 - 1) * 1.1
        z = (i // 3 - 0.5) * 1.1
        make = lambda: bpy.ops.mesh.primitive_uv_sphere_add(
            segments=32, ring_count=16, radius=0.5
        )
        add_mesh(scene, name, make, m, (x, 0.5, z), smooth=True)
    add_camera(scene, (0.0, 2.2, 4.2), (0.0, 0.4, 0.0), 40.0)
    export(os.path.join(out, "glass.glb"))


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    cornell(out)
    spheres(out)
    interior(out)
    textured(out)
    glass(out)


if __name__ == "__main__":
    main()
