//! The scene formats `ember render` and `ember info` read, told apart by extension, so
//! that a file in another format is refused by name with the list of what ember reads
//! (rather than read as an OBJ with no faces).

use std::path::Path;

use anyhow::{bail, Result};
use ember::scene::{ModelFormat, MODEL_FORMATS};

/// A scene's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    /// A model file ember reads ([`ModelFormat`]): OBJ, glTF, PLY.
    Model,
    /// An ember scene file: OBJs placed, cameras, environment, settings.
    SceneFile,
}

impl SceneFormat {
    /// The format of `path` by its extension (any case), or one line naming what
    /// ember reads.
    pub fn of(path: &Path) -> Result<SceneFormat> {
        if ModelFormat::of(path).is_some() {
            return Ok(SceneFormat::Model);
        }
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        if ModelFormat::of(path).is_some() {
            return Ok(SceneFormat::Model);
        }
        match ext.as_deref() {
            Some("toml") => Ok(SceneFormat::SceneFile),
            Some(ext) => bail!(
                "{}: ember reads {MODEL_FORMATS} and ember scene files (.toml), not {}",
                path.display(),
                known_format(ext).map_or_else(|| format!(".{ext} files"), str::to_owned)
            ),
            None => bail!(
                "{}: ember reads {MODEL_FORMATS} and ember scene files (.toml), told apart by the extension; this file has none",
                path.display()
            ),
        }
    }
}

/// The name of a format users try, for the message.
fn known_format(ext: &str) -> Option<&'static str> {
    Some(match ext {
        "stl" => "STL",
        "fbx" => "FBX",
        "dae" => "COLLADA",
        "usd" | "usda" | "usdc" | "usdz" => "USD",
        "abc" => "Alembic",
        "blend" => "Blender files",
        "3ds" => "3DS",
        "pbrt" => "pbrt scenes",
        "xml" => "XML (Mitsuba) scenes",
        "png" | "jpg" | "jpeg" | "exr" | "hdr" | "tga" | "bmp" => "images",
        "mtl" => "material libraries alone (give the OBJ that names it)",
        _ => return None,
    })
}
