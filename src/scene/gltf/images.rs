//! A glTF's textures as ember's: each image's bytes (a file beside the glTF, a
//! `data:` URI, or a buffer view of a GLB), decoded once, and from it every texture the
//! materials ask of it, each looked up by its glTF texture's sampler (wrap modes and
//! filter): the base colour (sRGB), the metallic-roughness texture
//! (linear; its G and B channels read by the material), the normal map (with its scale), the
//! emission, and the alpha channel as a cut-out. An image file that is absent is a
//! warning (an error with `--strict`), as OBJ textures are.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use glam::Vec3;
use gltf::texture::{MagFilter, MinFilter, WrappingMode};
use image::{DynamicImage, ImageFormat};

use super::source::{data_uri_mime, read_uri, uri_path, Source};
use crate::image::ImageFile;
use crate::scene::asset_paths;
use crate::scene::texture_files::decode_image;
use crate::scene::warnings::Warnings;
use crate::scene::{AlphaMap, Filter, Sampler, SceneError, Texels, Texture, TextureKind, Wrap};

/// What a material makes of an image. Factors are kept as bits so that requests can
/// be told apart and ordered.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Purpose {
    /// The base colour (its factor multiplies it in the material).
    BaseColour,
    /// Roughness in the green channel, metallic in the blue: linear data.
    MetallicRoughness,
    /// A tangent-space normal map whose X and Y are scaled.
    Normal(u32),
    Emission,
    /// The alpha channel times a factor, cut at a threshold (`MASK`) or kept
    /// (`BLEND`, `None`).
    Alpha {
        factor: u32,
        cutoff: Option<u32>,
    },
}

/// The textures and alpha maps made, and which request each answers.
#[derive(Default)]
pub struct Made {
    pub textures: Vec<Arc<Texture>>,
    pub alpha_maps: Vec<Arc<AlphaMap>>,
    /// Per (glTF texture, purpose): its texture (or alpha map, for `Alpha`) index;
    /// `None` where the image is absent, or an alpha channel is opaque everywhere.
    pub ids: BTreeMap<(usize, Purpose), Option<u32>>,
}

/// Decodes every image the requested textures show, once each, and makes what each
/// request asks of it with its texture's sampler. `requests` maps each (glTF texture,
/// purpose) to the material that asks first (for messages) and what it uses where the
/// image is absent. Textures of one image and one sampler share what is made.
pub fn make_textures(
    source: &Source,
    requests: &BTreeMap<(usize, Purpose), (String, String)>,
    warnings: &mut Warnings,
) -> Result<Made, SceneError> {
    let mut made = Made::default();
    let textures: Vec<gltf::Texture<'_>> = source.document.textures().collect();
    let mut by_image: BTreeMap<usize, Vec<(usize, Purpose)>> = BTreeMap::new();
    for &(texture, purpose) in requests.keys() {
        let image = textures[texture].source().index();
        by_image.entry(image).or_default().push((texture, purpose));
    }
    for (index, wanted) in by_image {
        let (material, instead) = &requests[&wanted[0]];
        let Some(image) = load_image(source, index, material, instead, warnings)? else {
            for key in wanted {
                made.ids.insert(key, None);
            }
            continue;
        };
        let mut shared: BTreeMap<(Purpose, Sampler), Option<u32>> = BTreeMap::new();
        for (texture, purpose) in wanted {
            let sampler = sampler(&textures[texture].sampler());
            let id = match shared.get(&(purpose, sampler)) {
                Some(&id) => id,
                None => made.make(&image, purpose, sampler),
            };
            shared.insert((purpose, sampler), id);
            made.ids.insert((texture, purpose), id);
        }
    }
    Ok(made)
}

impl Made {
    /// The texture (or alpha map) `purpose` makes of `image`, looked up by `sampler`.
    fn make(&mut self, image: &DynamicImage, purpose: Purpose, sampler: Sampler) -> Option<u32> {
        match purpose {
            Purpose::Alpha { factor, cutoff } => {
                let cutoff = cutoff.map(f32::from_bits);
                let map = alpha_map(image, f32::from_bits(factor), cutoff)?;
                self.alpha_maps.push(Arc::new(AlphaMap { sampler, ..map }));
                Some(self.alpha_maps.len() as u32 - 1)
            }
            purpose => {
                let texture = texture(image, purpose);
                self.textures.push(Arc::new(Texture { sampler, ..texture }));
                Some(self.textures.len() as u32 - 1)
            }
        }
    }
}

/// A glTF sampler as ember's: its wrap modes, and its filter by [`filter`].
pub fn sampler(sampler: &gltf::texture::Sampler<'_>) -> Sampler {
    let wrap = |mode: WrappingMode| match mode {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::ClampToEdge => Wrap::Clamp,
        WrappingMode::MirroredRepeat => Wrap::Mirror,
    };
    Sampler {
        wrap_s: wrap(sampler.wrap_s()),
        wrap_t: wrap(sampler.wrap_t()),
        filter: filter(sampler).0,
    }
}

/// A sampler's filter, and whether its `magFilter` and `minFilter` disagree. A lookup
/// is a point, with no footprint to tell magnification from minification, so one
/// filter serves both: nearest when both are nearest (mipmaps aside), or the one given
/// is, as Blender's importer reads them; bilinear otherwise.
pub fn filter(sampler: &gltf::texture::Sampler<'_>) -> (Filter, bool) {
    let mag = sampler.mag_filter().map(|m| m == MagFilter::Nearest);
    let min = sampler.min_filter().map(|m| {
        matches!(
            m,
            MinFilter::Nearest | MinFilter::NearestMipmapNearest | MinFilter::NearestMipmapLinear
        )
    });
    let nearest = match (mag, min) {
        (Some(mag), Some(min)) => mag && min,
        (one, other) => one.or(other).unwrap_or(false),
    };
    let filter = match nearest {
        true => Filter::Nearest,
        false => Filter::Bilinear,
    };
    (filter, mag.zip(min).is_some_and(|(a, b)| a != b))
}

/// The MIME types glTF images come in, as formats.
fn format_of(mime: Option<&str>) -> Option<ImageFormat> {
    match mime? {
        "image/png" => Some(ImageFormat::Png),
        "image/jpeg" => Some(ImageFormat::Jpeg),
        _ => None,
    }
}

/// Image `index` decoded, or `None` (warned) when its file is absent.
fn load_image(
    source: &Source,
    index: usize,
    material: &str,
    instead: &str,
    warnings: &mut Warnings,
) -> Result<Option<DynamicImage>, SceneError> {
    let image = source
        .document
        .images()
        .nth(index)
        .expect("a validated document's image index");
    let error = |path: &Path, reason: String| SceneError::Texture {
        path: path.to_owned(),
        slot: "glTF image",
        material: material.to_owned(),
        reason,
    };
    let here = Path::new("(embedded)");
    let file = match image.source() {
        gltf::image::Source::View { view, mime_type } => {
            let buffer = &source.buffers[view.buffer().index()];
            let end = view.offset().checked_add(view.length());
            let bytes = end
                .and_then(|end| buffer.get(view.offset()..end))
                .ok_or_else(|| {
                    error(
                        here,
                        format!("image {index}'s buffer view reaches past its buffer"),
                    )
                })?;
            ImageFile::from_bytes(bytes.to_vec(), format_of(Some(mime_type)))
        }
        gltf::image::Source::Uri { uri, mime_type } if uri.starts_with("data:") => {
            let mime = mime_type.or(data_uri_mime(uri));
            let bytes = read_uri(uri, &source.folder, 0)
                .map_err(|reason| error(here, format!("image {index}: {reason}")))?;
            ImageFile::from_bytes(bytes, format_of(mime))
        }
        gltf::image::Source::Uri { uri, .. } => {
            let written = uri_path(uri, &source.folder)
                .map_err(|reason| error(here, format!("image {index}: {reason}")))?;
            let relative = written.strip_prefix(&source.folder).unwrap_or(&written);
            let found = asset_paths::find(&relative.to_string_lossy(), &[&source.folder]);
            let missing = |reason| error(&written, reason);
            let Some(path) = warnings.located(found, missing, instead)? else {
                return Ok(None);
            };
            return ImageFile::open(&path)
                .and_then(|file| decode_image(file, 12))
                .map(Some)
                .map_err(|reason| error(&path, reason));
        }
    };
    // Twelve bytes per texel at most for the copy a texture keeps (a scaled normal map).
    file.and_then(|file| decode_image(file, 12))
        .map(Some)
        .map_err(|reason| error(here, format!("image {index}: {reason}")))
}

/// The texture `purpose` makes of `image`.
fn texture(image: &DynamicImage, purpose: Purpose) -> Texture {
    let (width, height) = (image.width(), image.height());
    let texels = match purpose {
        Purpose::BaseColour | Purpose::Emission => {
            return Texture::from_image(image.clone(), TextureKind::Colour)
        }
        Purpose::MetallicRoughness => {
            return Texture::from_image(image.clone(), TextureKind::Vector)
        }
        Purpose::Normal(bits) => {
            let scale = f32::from_bits(bits);
            let data = Texture::from_image(image.clone(), TextureKind::Vector);
            if scale == 1.0 {
                return data;
            }
            // glTF's scaledNormal: X and Y of the decoded vector times the scale.
            let n = width as usize * height as usize;
            let scaled = (0..n).map(|i| {
                let v = data.texel(i) * 2.0 - Vec3::ONE;
                (Vec3::new(v.x * scale, v.y * scale, v.z) + Vec3::ONE) * 0.5
            });
            Texels::RgbF32(scaled.collect())
        }
        Purpose::Alpha { .. } => unreachable!("alpha is an alpha map"),
    };
    Texture {
        width,
        height,
        texels,
        sampler: Sampler::default(),
    }
}

/// The alpha channel times `factor` as an alpha map, cut at `cutoff` (`MASK`: 0 below,
/// 1 at or above); `None` when it is opaque everywhere.
fn alpha_map(image: &DynamicImage, factor: f32, cutoff: Option<f32>) -> Option<AlphaMap> {
    let rgba = image.to_rgba8();
    let texels: Vec<u8> = rgba
        .pixels()
        .map(|p| {
            let a = f32::from(p[3]) / 255.0 * factor;
            match cutoff {
                Some(c) if a >= c => 255,
                Some(_) => 0,
                None => (a.clamp(0.0, 1.0) * 255.0).round() as u8,
            }
        })
        .collect();
    let map = AlphaMap {
        width: rgba.width(),
        height: rgba.height(),
        texels,
        sampler: Sampler::default(),
    };
    (!map.is_opaque()).then_some(map)
}
