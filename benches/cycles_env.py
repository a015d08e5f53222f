"""Cycles (the peer script of ../shared/peers/cycles) under an environment map.

The peer's render.py renders ember's OBJ+MTL scenes in Blender Cycles under ember's MTL
mapping, with a black world. This wrapper adds the one thing the sky-lit room needs:
an equirectangular map around the scene, read as ember reads it
(src/scene/environment.rs: y up, the map's middle column along -z, --env-rotate turning
it about +y, nearest texel), so that Cycles renders the room as ember does once its
textures are taken out of the MTL (render.py maps none).

    CYCLES_PEER=DIR python cycles_env.py [--env MAP.exr --env-rotate DEG]
        [--cycles-setting NAME=VALUE ...] RENDER_PY_ARGS...

DIR holds render.py (default ../shared/peers/cycles); run it with the Python of that
peer's venv (`pip install bpy numpy`). The rotation's sign was checked against ember
on the sky alone (a 64x32 view along four directions: mean absolute difference 1-2% of
the mean at 16 spp, the images' own noise). Cycles importance-samples the world from a
2048-wide map of it. `--cycles-setting` sets any `scene.cycles` property after the
peer's own settings (e.g. `guiding_distribution_type=DIRECTIONAL_QUADTREE`, Open PGL's
SD-tree). A measuring tool, not part of ember.
"""

import math
import os
import sys

sys.path.insert(0, os.environ.get("CYCLES_PEER", "../shared/peers/cycles"))
import render  # noqa: E402  (the peer script, found through CYCLES_PEER)


def take_option(argv, name, default):
    """Removes `name VALUE` from argv and returns VALUE (or default)."""
    if name not in argv:
        return default
    i = argv.index(name)
    value = argv[i + 1]
    del argv[i : i + 2]
    return value


def take_settings(argv):
    """Removes every `--cycles-setting NAME=VALUE` from argv; returns (NAME, VALUE)
    pairs, VALUE read as a bool, int or float where it is one."""
    settings = []
    while "--cycles-setting" in argv:
        name, _, text = take_option(argv, "--cycles-setting", "").partition("=")
        value = {"True": True, "False": False}.get(text, text)
        for kind in (int, float):
            if isinstance(value, str):
                try:
                    value = kind(value)
                except ValueError:
                    pass
        settings.append((name, value))
    return settings


def add_environment(bpy, scene, path, rotate_degrees):
    """Lights the world with the map at `path`. ember looks a unit direction d up at
    u = 1/2 + atan2(x', -z') / 2pi, v = acos(d.y) / pi (row 0 up), with
    x' = c d.x - s d.z and z' = s d.x + c d.z for the map turned by the angle whose
    sine and cosine are s and c; Blender's equirectangular lookup of the vector
    (z', x', d.y) gives the same texel."""
    nodes, links = scene.world.node_tree.nodes, scene.world.node_tree.links
    background = nodes.get("Background")
    direction = nodes.new("ShaderNodeSeparateXYZ")
    links.new(nodes.new("ShaderNodeTexCoord").outputs["Generated"], direction.inputs[0])
    angle = -math.radians(rotate_degrees)  # Blender's frame turns the other way
    s, c = math.sin(angle), math.cos(angle)

    def combination(along_x, along_z):
        terms = []
        for axis, factor in (("X", along_x), ("Z", along_z)):
            term = nodes.new("ShaderNodeMath")
            term.operation = "MULTIPLY"
            links.new(direction.outputs[axis], term.inputs[0])
            term.inputs[1].default_value = factor
            terms.append(term)
        total = nodes.new("ShaderNodeMath")
        total.operation = "ADD"
        links.new(terms[0].outputs[0], total.inputs[0])
        links.new(terms[1].outputs[0], total.inputs[1])
        return total.outputs[0]

    lookup = nodes.new("ShaderNodeCombineXYZ")
    links.new(combination(s, c), lookup.inputs["X"])
    links.new(combination(c, -s), lookup.inputs["Y"])
    links.new(direction.outputs["Y"], lookup.inputs["Z"])
    texture = nodes.new("ShaderNodeTexEnvironment")
    texture.image = bpy.data.images.load(path)
    texture.interpolation = "Closest"
    links.new(lookup.outputs[0], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], background.inputs["Color"])
    background.inputs["Strength"].default_value = 1.0
    scene.world.cycles.sampling_method = "MANUAL"
    scene.world.cycles.sample_map_resolution = 2048


def main():
    argv = sys.argv[1:]
    env = take_option(argv, "--env", None)
    rotate = float(take_option(argv, "--env-rotate", "0"))
    settings = take_settings(argv)
    if settings:
        peer_settings = render.configure_render

        def configure_with_settings(bpy, st, scene, args):
            peer_settings(bpy, st, scene, args)
            for name, value in settings:
                st.set("scene.cycles", scene.cycles, name, value)

        render.configure_render = configure_with_settings
    if env is not None:
        plain_world = render.setup_world

        def world_with_environment(bpy, st, scene, background):
            plain_world(bpy, st, scene, background)
            add_environment(bpy, scene, env, rotate)

        render.setup_world = world_with_environment
    return render.main(argv)


if __name__ == "__main__":
    sys.exit(main())
