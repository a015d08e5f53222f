//! Finding and decoding the image files an MTL names, each once: colour maps
//! (`map_Kd`, `map_Ks`, `map_Ke`, decoded as sRGB), data maps (`bump`, `norm`,
//! `map_Pr`, `map_Pm`, `map_Ns`, linear) and opacity maps (`map_d`, and the alpha
//! channel of `map_Kd`, kept as linear 8-bit planes).
//!
//! A statement's value is `[-option args]... file name`: the options of the MTL
//! specification are skipped with their arguments (`-bm` is kept, for bump maps, and
//! `-clamp on` makes the texture clamp to its edges instead of repeating), and the
//! rest of the line is the file name (spaces included), found by the rules of
//! [`super::asset_paths`]. A file that is absent is a warning and the map is left out
//! (an error with `--strict`); a file that is there but does not decode is an error.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use image::DynamicImage;

use super::asset_paths;
use super::warnings::Warnings;
use super::{AlphaMap, Sampler, SceneError, Texture, TextureKind};

/// The material a texture statement belongs to, where its file names are looked up,
/// and what replaces a map whose file is absent.
pub(super) struct Referrer<'a> {
    pub material: &'a str,
    /// The folder of the MTL that names it first, then the OBJ's; empty for scenes in
    /// memory, where every texture is absent.
    pub folders: &'a [&'a Path],
    /// For a warning: what the material uses where the map is absent.
    pub instead: String,
}

/// A decoded texture statement: the texture's index and that of its alpha channel as
/// an alpha map (a `map_Kd`'s, when not opaque), and the statement's `-bm` multiplier.
type Loaded = ((u32, Option<u32>), f32);

/// What a texture is decoded from and looked up by: its file, how it is decoded,
/// whether it is a `map_Kd` (whose alpha channel is an alpha map, kept beside it) and
/// its sampler.
type TextureKey = (PathBuf, TextureKind, bool, Sampler);

/// The textures and alpha maps of a scene as its materials name them.
#[derive(Default)]
pub(super) struct TextureLoader {
    pub textures: Vec<Arc<Texture>>,
    pub alpha_maps: Vec<Arc<AlphaMap>>,
    texture_ids: HashMap<TextureKey, (u32, Option<u32>)>,
    /// Keyed by file, by whether it is a `map_d` (which falls back to luminance) and
    /// by its sampler.
    alpha_ids: HashMap<(PathBuf, bool, Sampler), u32>,
}

impl TextureLoader {
    /// A `map_Kd`: the index of its colour texture, and of its alpha channel as an
    /// alpha map when it has a non-opaque one; `None` when its file is absent.
    pub fn diffuse(
        &mut self,
        statement: &str,
        referrer: &Referrer<'_>,
        warnings: &mut Warnings,
    ) -> Result<Option<(u32, Option<u32>)>, SceneError> {
        let loaded = self.load(statement, "map_Kd", referrer, TextureKind::Colour, warnings)?;
        Ok(loaded.map(|(ids, _)| ids))
    }

    /// Any other texture map: its index, and the `-bm` multiplier of its statement
    /// (1 when absent); `None` when its file is absent.
    pub fn texture(
        &mut self,
        statement: &str,
        slot: &'static str,
        referrer: &Referrer<'_>,
        kind: TextureKind,
        warnings: &mut Warnings,
    ) -> Result<Option<(u32, f32)>, SceneError> {
        let loaded = self.load(statement, slot, referrer, kind, warnings)?;
        Ok(loaded.map(|((id, _), bump_scale)| (id, bump_scale)))
    }

    /// Decodes the file of a texture statement once per kind (a `map_Kd` also gets its
    /// alpha channel as an alpha map).
    fn load(
        &mut self,
        statement: &str,
        slot: &'static str,
        referrer: &Referrer<'_>,
        kind: TextureKind,
        warnings: &mut Warnings,
    ) -> Result<Option<Loaded>, SceneError> {
        let Some((file, options)) = find(statement, slot, referrer, warnings)? else {
            return Ok(None);
        };
        let material = referrer.material;
        let sampler = options.sampler();
        let key = (file, kind, slot == "map_Kd", sampler);
        if let Some(&ids) = self.texture_ids.get(&key) {
            return Ok(Some((ids, options.bump_scale)));
        }
        let bytes_per_texel = if kind == TextureKind::Scalar { 4 } else { 12 };
        let image = decode(&key.0, bytes_per_texel)
            .map_err(|reason| error(&key.0, slot, material, reason))?;
        let alpha = key
            .2
            .then(|| AlphaMap::from_alpha_channel(&image))
            .flatten()
            .map(|map| {
                self.alpha_maps.push(Arc::new(AlphaMap { sampler, ..map }));
                let id = self.alpha_maps.len() as u32 - 1;
                self.alpha_ids.insert((key.0.clone(), false, sampler), id);
                id
            });
        let texture = Texture::from_image(image, kind);
        self.textures.push(Arc::new(Texture { sampler, ..texture }));
        let ids = (self.textures.len() as u32 - 1, alpha);
        self.texture_ids.insert(key, ids);
        Ok(Some((ids, options.bump_scale)))
    }

    /// A `map_d`: the index of its alpha map (alpha channel, else luminance); `None`
    /// when its file is absent.
    pub fn opacity(
        &mut self,
        statement: &str,
        referrer: &Referrer<'_>,
        warnings: &mut Warnings,
    ) -> Result<Option<u32>, SceneError> {
        let Some((file, options)) = find(statement, "map_d", referrer, warnings)? else {
            return Ok(None);
        };
        let sampler = options.sampler();
        let key = (file, true, sampler);
        if let Some(&id) = self.alpha_ids.get(&key) {
            return Ok(Some(id));
        }
        let image = decode(&key.0, 4)
            .map_err(|reason| error(&key.0, "map_d", referrer.material, reason))?;
        let map = AlphaMap::from_opacity_image(&image);
        self.alpha_maps.push(Arc::new(AlphaMap { sampler, ..map }));
        let id = self.alpha_maps.len() as u32 - 1;
        self.alpha_ids.insert(key, id);
        Ok(Some(id))
    }
}

/// The file a texture statement names and the statement's options; `None` (with a
/// warning) when the file is absent.
fn find(
    statement: &str,
    slot: &'static str,
    referrer: &Referrer<'_>,
    warnings: &mut Warnings,
) -> Result<Option<(PathBuf, TextureOptions)>, SceneError> {
    let material = referrer.material;
    let options = parse_statement(statement)
        .map_err(|reason| error(Path::new(statement.trim()), slot, material, reason))?;
    let found = asset_paths::find(&options.file, referrer.folders);
    let written = referrer
        .folders
        .first()
        .map_or(PathBuf::from(&options.file), |dir| dir.join(&options.file));
    let missing = |reason| error(&written, slot, material, reason);
    let file = warnings.located(found, missing, &referrer.instead)?;
    Ok(file.map(|file| (file, options)))
}

fn error(path: &Path, slot: &'static str, material: &str, reason: String) -> SceneError {
    SceneError::Texture {
        path: path.to_owned(),
        slot,
        material: material.to_owned(),
        reason,
    }
}

/// What a texture statement says besides which file.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct TextureOptions {
    pub file: String,
    /// `-bm`: the bump multiplier.
    pub bump_scale: f32,
    /// `-clamp on`: the texture clamps to its edge texels instead of repeating.
    pub clamp: bool,
}

impl TextureOptions {
    /// How the texture is looked up: repeating, or clamped with `-clamp on`;
    /// bilinear either way.
    pub fn sampler(&self) -> Sampler {
        match self.clamp {
            true => Sampler::CLAMP,
            false => Sampler::default(),
        }
    }
}

/// The options of the MTL specification and how many arguments each takes (`-o`,
/// `-s` and `-t` take one to three numbers).
const OPTION_ARGUMENTS: [(&str, usize); 13] = [
    ("-blendu", 1),
    ("-blendv", 1),
    ("-bm", 1),
    ("-boost", 1),
    ("-cc", 1),
    ("-clamp", 1),
    ("-imfchan", 1),
    ("-mm", 2),
    ("-texres", 1),
    ("-type", 1),
    ("-o", 3),
    ("-s", 3),
    ("-t", 3),
];

/// Splits `[-option args]... file name` (see the module documentation). An unknown
/// option, a missing argument or no file name is an error.
pub(super) fn parse_statement(statement: &str) -> Result<TextureOptions, String> {
    let mut rest = statement.trim();
    let mut bump_scale = 1.0;
    let mut clamp = false;
    while rest.starts_with('-') {
        let (option, after) = split_word(rest);
        let count = OPTION_ARGUMENTS
            .iter()
            .find(|(name, _)| *name == option)
            .map(|&(_, n)| n)
            .ok_or_else(|| format!("unknown texture option {option:?}"))?;
        // `-o`, `-s` and `-t` take up to three numbers; the others exactly `count` words.
        let variadic = matches!(option, "-o" | "-s" | "-t");
        rest = after;
        for k in 0..count {
            let (word, after) = split_word(rest);
            let is_number = word.parse::<f32>().is_ok();
            if variadic && k > 0 && !is_number {
                break;
            }
            if word.is_empty() || (variadic && !is_number) {
                return Err(format!("texture option {option} is missing its arguments"));
            }
            if option == "-bm" {
                bump_scale = word
                    .parse::<f32>()
                    .ok()
                    .filter(|b| b.is_finite())
                    .ok_or_else(|| format!("-bm {word:?} is not a number"))?;
            }
            if option == "-clamp" {
                clamp = match word.to_ascii_lowercase().as_str() {
                    "on" => true,
                    "off" => false,
                    _ => return Err(format!("-clamp takes on or off, not {word:?}")),
                };
            }
            rest = after;
        }
    }
    if rest.is_empty() {
        return Err("no file name after the options".into());
    }
    Ok(TextureOptions {
        file: rest.to_owned(),
        bump_scale,
        clamp,
    })
}

/// The first whitespace-separated word of `text` and what follows it, trimmed.
fn split_word(text: &str) -> (&str, &str) {
    let text = text.trim_start();
    match text.find(char::is_whitespace) {
        Some(end) => (&text[..end], text[end..].trim_start()),
        None => (text, ""),
    }
}

/// Decodes an image file, refusing one whose decoding and copies (`bytes_per_texel` of
/// them beside the decoded image) would not fit in memory.
fn decode(path: &Path, bytes_per_texel: u64) -> Result<DynamicImage, String> {
    decode_image(crate::image::ImageFile::open(path)?, bytes_per_texel)
}

/// Decodes an opened image as [`decode`] does a file.
pub(super) fn decode_image(
    file: crate::image::ImageFile,
    bytes_per_texel: u64,
) -> Result<DynamicImage, String> {
    let image = file.decode_within("texture", bytes_per_texel)?;
    if let Some((x, y, value)) = non_finite_texel(&image) {
        return Err(format!(
            "texel ({x}, {y}) holds {value}: every value must be finite"
        ));
    }
    Ok(image)
}

/// The first texel (x, y) of a floating-point image with a NaN or infinite channel, and
/// that value: it would make every sample that reads it non-finite. (8- and 16-bit
/// images hold only finite values.)
fn non_finite_texel(image: &DynamicImage) -> Option<(u32, u32, f32)> {
    let (values, channels): (&[f32], usize) = match image {
        DynamicImage::ImageRgb32F(b) => (b.as_raw(), 3),
        DynamicImage::ImageRgba32F(b) => (b.as_raw(), 4),
        _ => return None,
    };
    let i = values.iter().position(|v| !v.is_finite())?;
    let texel = (i / channels) as u32;
    Some((texel % image.width(), texel / image.width(), values[i]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_are_skipped_with_their_arguments() {
        let parsed =
            parse_statement("-bm 0.5 -s 1 2 -o 0.1 0.2 0.3 -clamp on my wood.png").unwrap();
        assert_eq!(parsed.file, "my wood.png");
        assert_eq!(parsed.bump_scale, 0.5);
        assert!(parsed.clamp);
        assert_eq!(parsed.sampler(), Sampler::CLAMP);
        let repeating = parse_statement("-clamp off wood.png").unwrap();
        assert_eq!(repeating.sampler(), Sampler::default());
        assert!(parse_statement("-clamp maybe wood.png")
            .unwrap_err()
            .contains("-clamp"));
        assert_eq!(parse_statement("  a b\\c.jpg ").unwrap().file, "a b\\c.jpg");
        assert_eq!(parse_statement("-s 2 x.png").unwrap().file, "x.png");
        assert_eq!(parse_statement("-mm 0 1 x.png").unwrap().file, "x.png");
        assert!(parse_statement("-wat 1 x.png")
            .unwrap_err()
            .contains("-wat"));
        assert!(parse_statement("-bm").is_err());
        assert!(parse_statement("-bm x y.png").is_err());
        assert!(parse_statement("-clamp on").is_err());
    }
}
