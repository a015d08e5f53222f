//! The model files ember reads, told apart by their extension, and the one function
//! that loads any of them: wherever an OBJ is accepted (the scene `ember render` and
//! `ember info` are given, a scene file's `[[obj]]` entries, `ember bench`'s meshes),
//! so is every format here. A format is one variant and one arm of each match.

use std::path::Path;

use super::{load_obj_with, load_ply_with, LoadOptions, LoadReport, Scene, SceneError};

/// What ember reads, for messages (a list that "and ember scene files" can end).
pub const MODEL_FORMATS: &str = "OBJ (.obj), PLY (.ply)";

/// A model file's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelFormat {
    Obj,
    Ply,
}

impl ModelFormat {
    /// The format of `path` by its extension (any case); `None` for one ember does
    /// not read.
    pub fn of(path: &Path) -> Option<ModelFormat> {
        let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(ModelFormat::Obj),
            "ply" => Some(ModelFormat::Ply),
            _ => None,
        }
    }
}

/// A loaded model: the scene, and what is worth telling.
pub struct LoadedModel {
    pub scene: Scene,
    pub report: LoadReport,
}

/// Loads the model at `path` by its format; a file of another extension is refused in
/// one line that names what ember reads.
pub fn load_model(path: &Path, options: &LoadOptions) -> Result<LoadedModel, SceneError> {
    let (scene, report) = match ModelFormat::of(path) {
        Some(ModelFormat::Obj) => load_obj_with(path, options)?,
        Some(ModelFormat::Ply) => load_ply_with(path, options)?,
        None => {
            let what = match path.extension() {
                Some(e) => format!(".{} files", e.to_string_lossy()),
                None => "files without an extension".to_owned(),
            };
            return Err(SceneError::Format {
                path: path.to_owned(),
                what,
            });
        }
    };
    Ok(LoadedModel { scene, report })
}
