//! The model files ember reads, told apart by their extension, and the one function
//! that loads any of them: wherever an OBJ is accepted (the scene `ember render` and
//! `ember info` are given, a scene file's `[[mesh]]` entries), so is every format here.

use std::path::Path;

use super::{load_gltf, load_obj_with, FileCamera, LoadOptions, LoadReport, Scene, SceneError};

/// What ember reads, for messages.
pub const MODEL_FORMATS: &str = "OBJ (.obj) and glTF 2.0 (.gltf, .glb)";

/// A model file's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelFormat {
    Obj,
    Gltf,
}

impl ModelFormat {
    /// The format of `path` by its extension (any case); `None` for one ember does
    /// not read.
    pub fn of(path: &Path) -> Option<ModelFormat> {
        let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(ModelFormat::Obj),
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

/// Loads the model at `path` by its format; a file of no known extension is read as
/// OBJ (the command line refuses those first).
pub fn load_model(path: &Path, options: &LoadOptions) -> Result<LoadedModel, SceneError> {
    match ModelFormat::of(path) {
        Some(ModelFormat::Gltf) => load_gltf(path, options),
        Some(ModelFormat::Obj) | None => {
            load_obj_with(path, options).map(|(scene, report)| LoadedModel {
                scene,
                report,
                cameras: Vec::new(),
                contents: Vec::new(),
            })
        }
    }
}
