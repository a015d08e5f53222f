//! The mesh formats ember reads, told apart by their extension: a format is one arm of
//! [`mesh_reader`]'s match, and every place that takes a mesh (`ember render` and
//! `ember info`, scene files' `[[obj]]` entries, `ember bench`) reads through it.

use std::path::Path;

use super::{load_obj_with, load_ply_with, LoadOptions, LoadReport, Scene, SceneError};

/// The mesh formats, for messages (a list that "and ember scene files" can end).
pub const MESH_FORMATS: &str = "OBJ (.obj), PLY (.ply)";

/// A mesh reader: the file's scene, and what the load found.
pub type MeshReader = fn(&Path, &LoadOptions) -> Result<(Scene, LoadReport), SceneError>;

/// The reader of the mesh file `path`, by its extension in any case; `None` where
/// ember reads no mesh of that kind.
pub fn mesh_reader(path: &Path) -> Option<MeshReader> {
    let extension = path.extension()?.to_str()?.to_ascii_lowercase();
    Some(match extension.as_str() {
        "obj" => load_obj_with,
        "ply" => load_ply_with,
        _ => return None,
    })
}

/// Loads the mesh file `path` with the reader of its format.
pub fn load_mesh(path: &Path, options: &LoadOptions) -> Result<(Scene, LoadReport), SceneError> {
    let Some(read) = mesh_reader(path) else {
        let what = match path.extension() {
            Some(e) => format!(".{} files", e.to_string_lossy()),
            None => "files without an extension".to_owned(),
        };
        return Err(SceneError::Format {
            path: path.to_owned(),
            what,
        });
    };
    read(path, options)
}
