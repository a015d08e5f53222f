//! Fuzzing the glTF reader on the stable toolchain (proptest): small valid files made
//! at run time (a textured floor under a point and a spot light, a camera, a mesh two
//! nodes share, a strip, a sparse accessor, a MASK material, a rough glass with a
//! transmission texture), mutated at the JSON
//! level (values replaced by numbers at the edge of `f32` and `u32`, wrong types,
//! indices out of range, keys removed, nodes made their own ancestors, URIs broken) and
//! as bytes of the GLB (bytes and length fields overwritten, the file cut short).
//!
//! What must hold: loading never panics; an error is one line naming the file; a
//! scene that loads renders finite pixels, instanced scenes on both backends.
//!
//! `EMBER_FUZZ_SECONDS=N` runs for N seconds and prints how many inputs were tried.

mod common;

use std::sync::OnceLock;

use common::gltf::{floor_quad, GltfBuilder};
use ember::scene::{load_gltf, Channel, LoadOptions, Model};
use proptest::prelude::*;
use serde_json::{json, Value};

/// The valid file every input starts from.
fn base() -> &'static GltfBuilder {
    static BASE: OnceLock<GltfBuilder> = OnceLock::new();
    BASE.get_or_init(|| {
        let mut gltf = GltfBuilder::default();
        let mut png = Vec::new();
        let image = image::RgbaImage::from_fn(2, 2, |x, y| image::Rgba([200, 100, 50, 120 * (x + y) as u8]));
        image::DynamicImage::ImageRgba8(image)
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        use base64::Engine;
        let data = base64::engine::general_purpose::STANDARD.encode(&png);
        gltf.json["images"] = json!([{"uri": format!("data:image/png;base64,{data}")}]);
        gltf.json["samplers"] = json!([{"wrapS": 33071}]);
        gltf.json["textures"] = json!([{"source": 0, "sampler": 0}]);
        gltf.uses("KHR_texture_transform", false);
        let textured = gltf.material(json!({"alphaMode": "MASK", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0], "rotation": 0.3}}},
            "metallicRoughnessTexture": {"index": 0}},
            "normalTexture": {"index": 0, "scale": 0.5},
            "emissiveTexture": {"index": 0}, "emissiveFactor": [0.1, 0.1, 0.1]}));
        let (p, uv, i) = floor_quad(2.0, 0.0);
        let floor = gltf.mesh(&p, Some(&uv), &i, Some(textured));
        gltf.node(json!({"mesh": floor}), true);
        for name in ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_specular"] {
            gltf.uses(name, false);
        }
        let plain = gltf.material(json!({"pbrMetallicRoughness": {"metallicFactor": 0.5},
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.7, "transmissionTexture": {"index": 0}},
                "KHR_materials_ior": {"ior": 1.4},
                "KHR_materials_specular": {"specularFactor": 0.8, "specularColorFactor": [1.0, 0.9, 0.8]}}}));
        let box_mesh = gltf.mesh(
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            None,
            &[0, 1, 2, 0, 2, 3],
            Some(plain),
        );
        let parent = gltf.node(json!({"translation": [0.0, 0.5, 0.0], "children": []}), true);
        let a = gltf.node(json!({"mesh": box_mesh, "translation": [-1.0, 0.0, 0.0]}), false);
        let b = gltf.node(json!({"mesh": box_mesh, "scale": [1.0, 2.0, -1.0]}), false);
        gltf.json["nodes"][parent]["children"] = json!([a, b]);
        // A strip read through a sparse accessor.
        let strip = gltf.floats(
            &[[-1.0, 0.1, -1.0], [-1.0, 0.1, 1.0], [0.0, 0.1, -1.0], [0.0, 0.1, 1.0]].map(|v: [f32; 3]| v.to_vec()),
            "VEC3",
        );
        let sparse_indices = gltf.view(&[3u8, 0, 0, 0]);
        let sparse_values = gltf.view(&[0.5f32, 0.2, 1.0].map(f32::to_le_bytes).concat());
        gltf.json["accessors"][strip]["sparse"] = json!({"count": 1,
            "indices": {"bufferView": sparse_indices, "componentType": 5125},
            "values": {"bufferView": sparse_values}});
        gltf.json["meshes"].as_array_mut().unwrap().push(json!({"primitives": [
            {"attributes": {"POSITION": strip}, "mode": 5}]}));
        gltf.node(json!({"mesh": 2}), true);
        let point = gltf.light(json!({"type": "point", "intensity": 50.0, "range": 4.0}));
        let spot = gltf.light(json!({"type": "spot", "intensity": 80.0, "color": [1.0, 0.5, 0.5],
            "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}}));
        gltf.node(json!({"translation": [0.0, 2.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": point}}}), true);
        gltf.node(json!({"rotation": [-std::f32::consts::FRAC_1_SQRT_2, 0.0, 0.0, std::f32::consts::FRAC_1_SQRT_2], "translation": [1.0, 3.0, 0.0],
            "extensions": {"KHR_lights_punctual": {"light": spot}}}), true);
        gltf.json["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]);
        gltf.node(json!({"camera": 0, "translation": [0.0, 1.0, 4.0]}), true);
        gltf
    })
}

/// Values that test a reader: the edges of `f32` and `u32`, wrong types.
fn hostile_value() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(json!(-1)),
        Just(json!(0)),
        Just(json!(1)),
        Just(json!(3)),
        Just(json!(255)),
        Just(json!(65536)),
        Just(json!(4294967295u64)),
        Just(json!(1_000_000_000u64)),
        Just(json!(1e39)),
        Just(json!(-1e39)),
        Just(json!(3.4e38)),
        Just(json!(1e-45)),
        Just(json!(0.5)),
        Just(json!("")),
        Just(json!("data:;base64,@@")),
        Just(json!("../../../etc/passwd")),
        Just(json!(null)),
        Just(json!([])),
        Just(json!([0, 0, 0, 0])),
        Just(json!({})),
        Just(json!(true)),
        (0u32..40).prop_map(|n| json!(n)),
    ]
}

/// One change to the JSON: a value replaced (at a path picked by two numbers), a key
/// removed, or a node made the child of another.
#[derive(Clone, Debug)]
enum Change {
    Replace { pick: Vec<usize>, value: Value },
    Remove { pick: Vec<usize> },
    Child { parent: usize, child: usize },
}

fn change() -> impl Strategy<Value = Change> {
    let pick = prop::collection::vec(0usize..64, 1..5);
    prop_oneof![
        4 => (pick.clone(), hostile_value()).prop_map(|(pick, value)| Change::Replace { pick, value }),
        1 => pick.prop_map(|pick| Change::Remove { pick }),
        1 => (0usize..8, 0usize..8).prop_map(|(parent, child)| Change::Child { parent, child }),
    ]
}

/// The value at the path `pick` chooses (each number picks a key or item modulo the
/// count), and its parent.
fn walk<'v>(json: &'v mut Value, pick: &[usize]) -> Option<(&'v mut Value, String)> {
    let (&first, rest) = pick.split_first()?;
    let key = match json {
        Value::Object(map) if !map.is_empty() => map.keys().nth(first % map.len())?.clone(),
        Value::Array(list) if !list.is_empty() => (first % list.len()).to_string(),
        _ => return None,
    };
    let child_is_leaf = |v: &Value| {
        !matches!(v, Value::Object(m) if !m.is_empty())
            && !matches!(v, Value::Array(l) if !l.is_empty())
    };
    let child = match json {
        Value::Object(map) => map.get(&key)?,
        Value::Array(list) => list.get(key.parse::<usize>().ok()?)?,
        _ => return None,
    };
    if rest.is_empty() || child_is_leaf(child) {
        return Some((json, key));
    }
    let child = match json {
        Value::Object(map) => map.get_mut(&key)?,
        Value::Array(list) => list.get_mut(key.parse::<usize>().ok()?)?,
        _ => return None,
    };
    walk(child, rest)
}

fn apply(gltf: &mut GltfBuilder, change: &Change) {
    match change {
        Change::Replace { pick, value } => {
            if let Some((parent, key)) = walk(&mut gltf.json, pick) {
                match parent {
                    Value::Object(map) => drop(map.insert(key, value.clone())),
                    Value::Array(list) => list[key.parse::<usize>().unwrap()] = value.clone(),
                    _ => {}
                }
            }
        }
        Change::Remove { pick } => {
            if let Some((Value::Object(map), key)) = walk(&mut gltf.json, pick) {
                map.remove(&key);
            }
        }
        Change::Child { parent, child } => {
            let Some(nodes) = gltf.json["nodes"].as_array_mut().filter(|n| !n.is_empty()) else {
                return;
            };
            let n = nodes.len();
            let Some(node) = nodes[parent % n].as_object_mut() else {
                return;
            };
            if let Some(list) = node.entry("children").or_insert(json!([])).as_array_mut() {
                list.push(json!(child % n));
            }
        }
    }
}

/// An input: JSON changes, then, as a GLB, byte changes (position, value) and a cut.
#[derive(Clone, Debug)]
struct Input {
    changes: Vec<Change>,
    glb: bool,
    bytes: Vec<(usize, u8)>,
    words: Vec<(usize, u32)>,
    cut: Option<usize>,
}

fn input() -> impl Strategy<Value = Input> {
    (
        prop::collection::vec(change(), 0..4),
        any::<bool>(),
        prop::collection::vec((any::<usize>(), any::<u8>()), 0..3),
        prop::collection::vec(
            (
                0usize..6,
                prop_oneof![
                    Just(0u32),
                    Just(1),
                    Just(u32::MAX),
                    Just(1 << 30),
                    any::<u32>()
                ],
            ),
            0..2,
        ),
        prop::option::weighted(0.1, any::<usize>()),
    )
        .prop_map(|(changes, glb, bytes, words, cut)| Input {
            changes,
            glb,
            bytes,
            words,
            cut,
        })
}

/// The file's bytes.
fn file_of(input: &Input) -> (Vec<u8>, &'static str) {
    let mut gltf = base().clone();
    for change in &input.changes {
        apply(&mut gltf, change);
    }
    if !input.glb {
        return (gltf.to_gltf().into_bytes(), "fuzz.gltf");
    }
    let mut bytes = gltf.to_glb();
    // The header's and the chunk headers' u32 fields: 4, 8, 12, 16, and the bin chunk's.
    let json_length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let fields = [4, 8, 12, 16, 20 + json_length, 24 + json_length];
    for &(k, word) in &input.words {
        let at = fields[k];
        if at + 4 <= bytes.len() {
            bytes[at..at + 4].copy_from_slice(&word.to_le_bytes());
        }
    }
    let n = bytes.len();
    for &(at, value) in &input.bytes {
        bytes[at % n] = value;
    }
    if let Some(cut) = input.cut {
        bytes.truncate(cut % n);
    }
    (bytes, "fuzz.glb")
}

fn check(input: &Input) -> Result<bool, TestCaseError> {
    let dir = tempfile::tempdir().unwrap();
    let (bytes, name) = file_of(input);
    let path = dir.path().join(name);
    std::fs::write(&path, &bytes).unwrap();
    match load_gltf(&path, &LoadOptions::default()) {
        Ok(loaded) => {
            common::fuzz::render_both(&loaded.scene)?;
            Ok(true)
        }
        Err(e) => {
            let line = e.to_string();
            prop_assert!(!line.contains('\n'), "{line:?}");
            prop_assert!(
                line.contains(name) || line.starts_with("texture") || line.starts_with("material"),
                "{line:?}"
            );
            Ok(false)
        }
    }
}

#[test]
fn fuzz_gltf() {
    common::fuzz::run("fuzz_gltf", "loaded and rendered", input(), check);
}

/// The file every input starts from loads as it is, as .gltf and as .glb, and renders.
#[test]
fn the_unchanged_file_loads_and_renders() {
    for glb in [false, true] {
        let input = Input {
            changes: Vec::new(),
            glb,
            bytes: Vec::new(),
            words: Vec::new(),
            cut: None,
        };
        let (bytes, name) = file_of(&input);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let loaded = load_gltf(&path, &LoadOptions::default()).expect("the base file loads");
        assert!(
            loaded.scene.instancing.is_some(),
            "the shared mesh is instanced"
        );
        assert_eq!(loaded.scene.lights.len(), 2);
        assert_eq!(loaded.cameras.len(), 1);
        assert!(
            loaded.scene.opacity().is_some(),
            "the MASK material cuts out"
        );
        // One metallic-roughness texture: roughness from green, metallic from blue.
        let floor = &loaded.scene.materials[0];
        assert!(matches!(floor.model, Model::MetallicRoughness { .. }));
        assert!(floor.maps.roughness.is_some() && floor.maps.roughness == floor.maps.metallic);
        assert_eq!(floor.maps.roughness_channel, Channel::Green);
        assert_eq!(floor.maps.metallic_channel, Channel::Blue);
        let glass = &loaded.scene.materials[1];
        assert!(
            matches!(glass.model, Model::MetallicRoughness { transmission, .. } if transmission == 0.7)
        );
        assert!(glass.maps.transmission.is_some());
        common::fuzz::render_both(&loaded.scene).unwrap();
    }
}
