//! The model files ember reads, told apart by their extension, and the one function
//! that loads any of them: wherever an OBJ is accepted (the scene `ember render` and
//! `ember info` are given, a scene file's `[[mesh]]` and `[[obj]]` entries, `ember
//! bench`'s meshes), so is every format here. A format is one variant and one arm of
//! each match.

use std::path::Path;

use super::{
    load_gltf, load_obj_with, load_ply_with, FileCamera, LoadOptions, LoadReport, Scene, SceneError,
};

/// What ember reads, for messages (a list that "and ember scene files" can end).
pub const MODEL_FORMATS: &str = "OBJ (.obj), glTF 2.0 (.gltf, .glb), PLY (.ply)";

/// A model file's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelFormat {
    Obj,
    Ply,
    Gltf,
}

impl ModelFormat {
    /// The format of `path` by its extension (any case); `None` for one ember does
    /// not read.
    pub fn of(path: &Path) -> Option<ModelFormat> {
        let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(ModelFormat::Obj),
            "ply" => Some(ModelFormat::Ply),
            "gltf" | "glb" => Some(ModelFormat::Gltf),
            _ => None,
        }
    }
}

/// A loaded model: the scene, what is worth telling, the cameras it places (glTF), and
/// `ember info`'s lines about what else it holds.
pub struct LoadedModel {
    pub scene: Scene,
    pub report: LoadReport,
    pub cameras: Vec<FileCamera>,
    pub contents: Vec<String>,
}

/// Loads the model at `path` by its format; a file of another extension is refused in
/// one line that names what ember reads.
pub fn load_model(path: &Path, options: &LoadOptions) -> Result<LoadedModel, SceneError> {
    let plain = |(scene, report)| LoadedModel {
        scene,
        report,
        cameras: Vec::new(),
        contents: Vec::new(),
    };
    match ModelFormat::of(path) {
        Some(ModelFormat::Gltf) => load_gltf(path, options),
        Some(ModelFormat::Obj) => load_obj_with(path, options).map(plain),
        Some(ModelFormat::Ply) => load_ply_with(path, options).map(plain),
        None => {
            let what = match path.extension() {
                Some(e) => format!(".{} files", e.to_string_lossy()),
                None => "files without an extension".to_owned(),
            };
            Err(SceneError::Format {
                path: path.to_owned(),
                what,
            })
        }
    }
}
