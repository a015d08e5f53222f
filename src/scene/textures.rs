//! Finding and decoding the image files an MTL names, each once: colour textures
//! (`map_Kd`, decoded from sRGB to linear RGB) and opacity maps (`map_d`, and the alpha
//! channel of `map_Kd`, kept as linear 8-bit planes).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use image::DynamicImage;

use super::{AlphaMap, SceneError, Texture};

/// The textures and alpha maps of a scene as its materials name them.
pub(super) struct TextureLoader {
    /// Where relative names are looked up: beside the OBJ, then beside each MTL.
    /// Empty for scenes in memory, where every texture is "not found".
    dirs: Vec<PathBuf>,
    pub textures: Vec<Texture>,
    pub alpha_maps: Vec<Arc<AlphaMap>>,
    texture_ids: HashMap<PathBuf, (u32, Option<u32>)>,
    /// Keyed by file and by whether it is a `map_d` (which falls back to luminance).
    alpha_ids: HashMap<(PathBuf, bool), u32>,
}

impl TextureLoader {
    pub fn new(dirs: Vec<PathBuf>) -> Self {
        TextureLoader {
            dirs,
            textures: Vec::new(),
            alpha_maps: Vec::new(),
            texture_ids: HashMap::new(),
            alpha_ids: HashMap::new(),
        }
    }

    /// A `map_Kd`: the index of its colour texture, and of its alpha channel as an
    /// alpha map when it has a non-opaque one.
    pub fn diffuse(
        &mut self,
        name: &str,
        material: &str,
    ) -> Result<(u32, Option<u32>), SceneError> {
        let file = self.find(name, "map_Kd", material)?;
        if let Some(&ids) = self.texture_ids.get(&file) {
            return Ok(ids);
        }
        let image = decode(&file, 24).map_err(|reason| error(&file, "map_Kd", material, reason))?;
        let alpha = AlphaMap::from_alpha_channel(&image).map(|map| {
            self.alpha_maps.push(Arc::new(map));
            let id = self.alpha_maps.len() as u32 - 1;
            self.alpha_ids.insert((file.clone(), false), id);
            id
        });
        let linear = crate::image::Image::from_image(image);
        self.textures.push(Texture {
            width: linear.width,
            height: linear.height,
            texels: linear.pixels,
        });
        let ids = (self.textures.len() as u32 - 1, alpha);
        self.texture_ids.insert(file, ids);
        Ok(ids)
    }

    /// A `map_d`: the index of its alpha map (alpha channel, else luminance).
    pub fn opacity(&mut self, name: &str, material: &str) -> Result<u32, SceneError> {
        let file = self.find(name, "map_d", material)?;
        let key = (file, true);
        if let Some(&id) = self.alpha_ids.get(&key) {
            return Ok(id);
        }
        let image = decode(&key.0, 4).map_err(|reason| error(&key.0, "map_d", material, reason))?;
        self.alpha_maps
            .push(Arc::new(AlphaMap::from_opacity_image(&image)));
        let id = self.alpha_maps.len() as u32 - 1;
        self.alpha_ids.insert(key, id);
        Ok(id)
    }

    fn find(&self, name: &str, slot: &'static str, material: &str) -> Result<PathBuf, SceneError> {
        find_texture(name, &self.dirs).ok_or_else(|| {
            let dir = self.dirs.first().map_or(Path::new(""), PathBuf::as_path);
            error(&dir.join(name), slot, material, "file not found".into())
        })
    }
}

fn error(path: &Path, slot: &'static str, material: &str, reason: String) -> SceneError {
    SceneError::Texture {
        path: path.to_owned(),
        slot,
        material: material.to_owned(),
        reason,
    }
}

/// Finds a texture file next to the OBJ or one of its MTL files. Options before the
/// file name (`-s 1 1 1 wood.png`) are skipped by trying the last word too.
fn find_texture(name: &str, dirs: &[PathBuf]) -> Option<PathBuf> {
    let name = name.trim();
    let last_word = name.split_whitespace().last().unwrap_or(name);
    let normalized = |n: &str| n.replace('\\', "/");
    [name, last_word]
        .iter()
        .flat_map(|n| dirs.iter().map(move |d| d.join(normalized(n))))
        .find(|p| p.is_file())
}

/// Decodes an image file, refusing one whose copies (`bytes_per_texel` of them beside
/// the decoded image) would not fit in memory.
fn decode(path: &Path, bytes_per_texel: u64) -> Result<DynamicImage, String> {
    let image = image::ImageReader::open(path)
        .map_err(|e| e.to_string())?
        .with_guessed_format()
        .map_err(|e| e.to_string())?
        .decode()
        .map_err(|e| e.to_string())?;
    // The decoder caps its own allocation (the image crate's default limit, 512 MiB);
    // the copies made from it take up to `bytes_per_texel` per texel on top.
    let texels = u64::from(image.width()) * u64::from(image.height());
    crate::limits::check_fits(
        &format!("a {}x{} texture", image.width(), image.height()),
        texels * bytes_per_texel,
    )?;
    if texels == 0 {
        return Err("image is empty".into());
    }
    Ok(image)
}
