//! A glTF's images as ember's textures: each image's bytes (a file beside the glTF, a
//! `data:` URI, or a buffer view of a GLB), decoded once, and from it every texture the
//! materials ask of it: the base colour (sRGB), the metallic-roughness texture
//! (linear; its G and B channels read by the material), the normal map (with its scale), the
//! emission, and the alpha channel as a cut-out. An image file that is absent is a
//! warning (an error with `--strict`), as OBJ textures are.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use glam::Vec3;
use image::{DynamicImage, ImageFormat};

use super::source::{data_uri_mime, read_uri, uri_path, Source};
use crate::image::ImageFile;
use crate::scene::asset_paths;
use crate::scene::texture_files::decode_image;
use crate::scene::warnings::Warnings;
use crate::scene::{AlphaMap, SceneError, Texels, Texture, TextureKind};

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
    /// Per (image, purpose): its texture (or alpha map, for `Alpha`) index; `None`
    /// where the image is absent, or an alpha channel is opaque everywhere.
    pub ids: BTreeMap<(usize, Purpose), Option<u32>>,
}

/// Decodes every image requested, once each, and makes the textures asked of it.
/// `requests` maps each (image, purpose) to the material that asks first (for
/// messages) and what it uses where the image is absent.
pub fn make_textures(
    source: &Source,
    requests: &BTreeMap<(usize, Purpose), (String, String)>,
    warnings: &mut Warnings,
) -> Result<Made, SceneError> {
    let mut made = Made::default();
    let mut images = requests.keys().map(|&(image, _)| image).collect::<Vec<_>>();
    images.dedup();
    for index in images {
        let purposes: Vec<Purpose> = requests
            .keys()
            .filter(|(i, _)| *i == index)
            .map(|&(_, p)| p)
            .collect();
        let (material, instead) = &requests[&(index, purposes[0])];
        let image = match load_image(source, index, material, instead, warnings)? {
            Some(image) => image,
            None => {
                for p in purposes {
                    made.ids.insert((index, p), None);
                }
                continue;
            }
        };
        for purpose in purposes {
            let id = match purpose {
                Purpose::Alpha { factor, cutoff } => {
                    alpha_map(&image, f32::from_bits(factor), cutoff.map(f32::from_bits)).map(
                        |map| {
                            made.alpha_maps.push(Arc::new(map));
                            made.alpha_maps.len() as u32 - 1
                        },
                    )
                }
                purpose => {
                    made.textures.push(Arc::new(texture(&image, purpose)));
                    Some(made.textures.len() as u32 - 1)
                }
            };
            made.ids.insert((index, purpose), id);
        }
    }
    Ok(made)
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
    };
    (!map.is_opaque()).then_some(map)
}
