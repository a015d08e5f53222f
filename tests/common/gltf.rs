//! glTF files made in code for the tests: a builder of buffers, accessors, meshes,
//! nodes and the rest as JSON (serde_json values), written as `.gltf` with its buffer
//! in a `data:` URI or as `.glb`.

use base64::Engine;
use serde_json::{json, Value};

use super::ember_in;

/// A glTF document under construction, with one buffer.
#[derive(Clone)]
pub struct GltfBuilder {
    pub json: Value,
    pub bin: Vec<u8>,
}

impl Default for GltfBuilder {
    fn default() -> Self {
        GltfBuilder {
            json: json!({
                "asset": {"version": "2.0"},
                "scene": 0,
                "scenes": [{"nodes": []}],
                "nodes": [],
                "meshes": [],
                "materials": [],
                "accessors": [],
                "bufferViews": [],
            }),
            bin: Vec::new(),
        }
    }
}

impl GltfBuilder {
    fn push(&mut self, key: &str, value: Value) -> usize {
        let list = self.json[key].as_array_mut().expect("a list");
        list.push(value);
        list.len() - 1
    }

    /// Appends bytes as a buffer view (4-byte aligned) and gives its index.
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.push(
            "bufferViews",
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}),
        )
    }

    /// An accessor of f32 vectors (`VEC2`, `VEC3`) with min and max for positions.
    pub fn floats(&mut self, values: &[Vec<f32>], kind: &str) -> usize {
        let bytes: Vec<u8> = values
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let view = self.view(&bytes);
        let n = values[0].len();
        let min: Vec<f32> = (0..n)
            .map(|k| values.iter().map(|v| v[k]).fold(f32::INFINITY, f32::min))
            .collect();
        let max: Vec<f32> = (0..n)
            .map(|k| {
                values
                    .iter()
                    .map(|v| v[k])
                    .fold(f32::NEG_INFINITY, f32::max)
            })
            .collect();
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": 5126, "count": values.len(),
                   "type": kind, "min": min, "max": max}),
        )
    }

    /// An accessor of u32 indices.
    pub fn indices(&mut self, indices: &[u32]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": 5125, "count": indices.len(),
                   "type": "SCALAR"}),
        )
    }

    pub fn material(&mut self, material: Value) -> usize {
        self.push("materials", material)
    }

    /// A mesh of one indexed triangle primitive.
    pub fn mesh(
        &mut self,
        positions: &[[f32; 3]],
        uvs: Option<&[[f32; 2]]>,
        indices: &[u32],
        material: Option<usize>,
    ) -> usize {
        let p = self.floats(
            &positions.iter().map(|p| p.to_vec()).collect::<Vec<_>>(),
            "VEC3",
        );
        let mut attributes = json!({"POSITION": p});
        if let Some(uvs) = uvs {
            let t = self.floats(&uvs.iter().map(|t| t.to_vec()).collect::<Vec<_>>(), "VEC2");
            attributes["TEXCOORD_0"] = json!(t);
        }
        let i = self.indices(indices);
        let mut primitive = json!({"attributes": attributes, "indices": i});
        if let Some(m) = material {
            primitive["material"] = json!(m);
        }
        self.push("meshes", json!({"primitives": [primitive]}))
    }

    /// A node (a root of the scene when `root`) and its index.
    pub fn node(&mut self, node: Value, root: bool) -> usize {
        let n = self.push("nodes", node);
        if root {
            self.json["scenes"][0]["nodes"]
                .as_array_mut()
                .unwrap()
                .push(json!(n));
        }
        n
    }

    /// Declares an extension used (and required, with `required`).
    pub fn uses(&mut self, name: &str, required: bool) {
        let mut add = |key: &str| {
            let list = self
                .json
                .as_object_mut()
                .unwrap()
                .entry(key)
                .or_insert(json!([]));
            list.as_array_mut().unwrap().push(json!(name));
        };
        add("extensionsUsed");
        if required {
            add("extensionsRequired");
        }
    }

    /// Adds `KHR_lights_punctual` light `light` and gives its index.
    pub fn light(&mut self, light: Value) -> usize {
        if self.json.get("extensions").is_none() {
            self.uses("KHR_lights_punctual", false);
            self.json["extensions"] = json!({"KHR_lights_punctual": {"lights": []}});
        }
        let list = self.json["extensions"]["KHR_lights_punctual"]["lights"]
            .as_array_mut()
            .unwrap();
        list.push(light);
        list.len() - 1
    }

    /// The JSON with the buffer as a `data:` URI.
    pub fn to_gltf(&self) -> String {
        let mut json = self.json.clone();
        let data = base64::engine::general_purpose::STANDARD.encode(&self.bin);
        json["buffers"] = json!([{
            "byteLength": self.bin.len(),
            "uri": format!("data:application/octet-stream;base64,{data}"),
        }]);
        json.to_string()
    }

    /// The file as a GLB: the JSON chunk, then the binary chunk.
    pub fn to_glb(&self) -> Vec<u8> {
        let mut json = self.json.clone();
        json["buffers"] = json!([{"byteLength": self.bin.len()}]);
        let mut text = json.to_string().into_bytes();
        while !text.len().is_multiple_of(4) {
            text.push(b' ');
        }
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + text.len() + 8 + bin.len();
        let mut glb = Vec::with_capacity(total);
        glb.extend_from_slice(b"glTF");
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&(total as u32).to_le_bytes());
        glb.extend_from_slice(&(text.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"JSON");
        glb.extend_from_slice(&text);
        glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"BIN\0");
        glb.extend_from_slice(&bin);
        glb
    }
}

/// A square of side `2·half` in the plane y = `y`, facing +y, with texture coordinates
/// (0,0) at (−x, −z) to (1,1) at (+x, +z), as two triangles.
pub fn floor_quad(half: f32, y: f32) -> ([[f32; 3]; 4], [[f32; 2]; 4], [u32; 6]) {
    (
        [
            [-half, y, -half],
            [half, y, -half],
            [half, y, half],
            [-half, y, half],
        ],
        [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
        // Counter-clockwise seen from +y.
        [0, 2, 1, 0, 3, 2],
    )
}

/// An RGB image as a PNG in a `data:` URI, for a glTF's `images`.
pub fn png_data_uri(image: image::RgbImage) -> String {
    let mut png = Vec::new();
    image::DynamicImage::ImageRgb8(image)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let data = base64::engine::general_purpose::STANDARD.encode(&png);
    format!("data:image/png;base64,{data}")
}

/// Runs `ember render` and `ember info` on `bytes` as `name`: each must fail with one
/// `error:` line naming the file and containing `says`.
pub fn refused(name: &str, bytes: &[u8], says: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(name), bytes).unwrap();
    for command in [
        &[
            "render", name, "--spp", "1", "--width", "4", "--height", "4",
        ][..],
        &["info", name],
    ] {
        let out = ember_in(command, dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{name}: {err}");
        assert_eq!(err.lines().count(), 1, "{name}: {err}");
        assert!(err.starts_with(&format!("error: {name}")), "{name}: {err}");
        assert!(err.contains(says), "{name}: expected {says:?} in {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}
