#!/usr/bin/env python3
"""Writes tests/data/gltf/: the glTF files tests/gltf.rs reads, made from the repository's
own meshes (no network, no Blender).

cornell-box.gltf: meshes/CornellBox-Original.obj and its MTL as one glTF, the same
geometry (each `usemtl` run of faces one primitive, polygons fanned into triangles),
each material's Kd as baseColorFactor with metallic 0 and roughness 1, and the light's
Ke as emissiveFactor times KHR_materials_emissive_strength (glTF's factor stops at 1).
The buffer is embedded as a data: URI, so the file stands alone.

Run from the repository's root: python3 scripts/make_gltf_test_data.py
"""

import base64
import json
import struct
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "tests" / "data" / "gltf"


def read_mtl(path):
    materials, name = {}, None
    for line in path.read_text().splitlines():
        words = line.split("#")[0].split()
        if not words:
            continue
        if words[0] == "newmtl":
            name = words[1]
            materials[name] = {"Kd": [0.0] * 3, "Ke": [0.0] * 3}
        elif words[0] in ("Kd", "Ke") and name:
            materials[name][words[0]] = [float(x) for x in words[1:4]]
    return materials


def read_obj(path):
    """Vertices, and the faces of each run of one material, in order."""
    vertices, runs, material = [], [], None
    for line in path.read_text().splitlines():
        words = line.split("#")[0].split()
        if not words:
            continue
        if words[0] == "v":
            vertices.append([float(x) for x in words[1:4]])
        elif words[0] == "usemtl":
            material = words[1]
            runs.append((material, []))
        elif words[0] == "f":
            corners = []
            for w in words[1:]:
                i = int(w.split("/")[0])
                corners.append(i - 1 if i > 0 else len(vertices) + i)
            runs[-1][1].append(corners)
    return vertices, runs


def cornell():
    obj = ROOT / "meshes" / "CornellBox-Original.obj"
    mtl = read_mtl(obj.with_suffix(".mtl"))
    vertices, runs = read_obj(obj)
    names = list(dict.fromkeys(m for m, _ in runs))
    materials = []
    for name in names:
        kd, ke = mtl[name]["Kd"], mtl[name]["Ke"]
        material = {
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": kd + [1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
        }
        strength = max(ke)
        if strength > 0:
            material["emissiveFactor"] = [c / strength for c in ke]
            material["extensions"] = {
                "KHR_materials_emissive_strength": {"emissiveStrength": strength}
            }
        materials.append(material)
    blob = bytearray()
    views, accessors, primitives = [], [], []

    def view(data):
        while len(blob) % 4:
            blob.append(0)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        blob.extend(data)
        return len(views) - 1

    positions = b"".join(struct.pack("<3f", *v) for v in vertices)
    accessors.append(
        {
            "bufferView": view(positions),
            "componentType": 5126,
            "count": len(vertices),
            "type": "VEC3",
            "min": [min(v[k] for v in vertices) for k in range(3)],
            "max": [max(v[k] for v in vertices) for k in range(3)],
        }
    )
    for name, faces in runs:
        indices = []
        for f in faces:
            for k in range(1, len(f) - 1):
                indices += [f[0], f[k], f[k + 1]]
        data = struct.pack(f"<{len(indices)}I", *indices)
        accessors.append(
            {
                "bufferView": view(data),
                "componentType": 5125,
                "count": len(indices),
                "type": "SCALAR",
            }
        )
        primitives.append(
            {
                "attributes": {"POSITION": 0},
                "indices": len(accessors) - 1,
                "material": names.index(name),
            }
        )
    document = {
        "asset": {"version": "2.0", "generator": "scripts/make_gltf_test_data.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "CornellBox-Original", "mesh": 0}],
        "meshes": [{"name": "CornellBox-Original", "primitives": primitives}],
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [
            {
                "byteLength": len(blob),
                "uri": "data:application/octet-stream;base64,"
                + base64.b64encode(bytes(blob)).decode(),
            }
        ],
    }
    (OUT / "cornell-box.gltf").write_text(json.dumps(document, indent=1) + "\n")


if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    cornell()
