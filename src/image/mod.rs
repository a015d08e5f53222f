//! Images: a buffer of linear `f32` RGB pixels and its codecs. PNG is written as 8-bit
//! sRGB through a tone map ([`Tonemap`]), EXR and HDR as linear radiance; any format the `image` crate reads (textures,
//! references) is decoded to linear RGB. Files appear whole or not at all ([`crate::io`]).

mod compare;
mod decode;
pub mod layers;
mod tonemap;

pub use compare::{
    compare, compare_crop, compare_pixels, downsampled, Crop, CropError, ImageError, SizeMismatch,
};
pub use decode::{decode_file, decode_jpeg, ImageFile};
pub use layers::{ExrSize, Layer, LayerError, LayeredImage};
pub use tonemap::{ToneCurve, Tonemap};

use std::path::{Path, PathBuf};

use crate::io::{self, WriteError};

use ::image::{DynamicImage, ImageFormat, Rgb32FImage, RgbImage};
use glam::Vec3;

/// Linear RGB radiance per pixel, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

/// An output file format, chosen by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    Png,
    Exr,
    Hdr,
}

#[derive(Debug, thiserror::Error)]
pub enum ImageFileError {
    #[error("unsupported output format {0:?}: use .png, .exr or .hdr")]
    UnknownFormat(PathBuf),
    #[error(transparent)]
    Write(#[from] WriteError),
    #[error("cannot read image {path}: {reason}")]
    Read { path: PathBuf, reason: String },
}

impl OutputFormat {
    pub fn from_path(path: &Path) -> Result<Self, ImageFileError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(OutputFormat::Png),
            Some("exr") => Ok(OutputFormat::Exr),
            Some("hdr") => Ok(OutputFormat::Hdr),
            _ => Err(ImageFileError::UnknownFormat(path.to_owned())),
        }
    }
}

/// The sRGB transfer curve, from linear `[0, 1]` to encoded `[0, 1]`.
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`linear_to_srgb`]: from encoded `[0, 1]` to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Image {
    pub fn new(width: u32, height: u32) -> Self {
        Image {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    /// Mean of all pixels.
    pub fn mean(&self) -> Vec3 {
        let sum = self
            .pixels
            .iter()
            .fold(glam::DVec3::ZERO, |acc, p| acc + p.as_dvec3());
        (sum / self.pixels.len().max(1) as f64).as_vec3()
    }

    fn to_rgb32f(&self) -> Rgb32FImage {
        let data = self.pixels.iter().flat_map(|p| p.to_array()).collect();
        Rgb32FImage::from_raw(self.width, self.height, data).expect("image size matches its pixels")
    }

    fn to_srgb8(&self, tonemap: &Tonemap) -> RgbImage {
        let data = self.pixels.iter().flat_map(|&p| tonemap.to_u8(p)).collect();
        RgbImage::from_raw(self.width, self.height, data).expect("image size matches its pixels")
    }

    /// Encodes the image in `format` into memory (8-bit formats through the default
    /// tone map: sRGB, clipped).
    pub fn encode(&self, format: OutputFormat) -> Result<Vec<u8>, String> {
        self.encode_with(format, &Tonemap::default())
    }

    /// Encodes the image in `format`, 8-bit formats through `tonemap` (EXR and HDR
    /// stay linear). EXR goes through the layer writer, as one main layer, because
    /// it writes its blocks in a fixed order: the same image, the same bytes.
    pub fn encode_with(&self, format: OutputFormat, tonemap: &Tonemap) -> Result<Vec<u8>, String> {
        let mut bytes = std::io::Cursor::new(Vec::new());
        let written = match format {
            OutputFormat::Png => self
                .to_srgb8(tonemap)
                .write_to(&mut bytes, ImageFormat::Png),
            OutputFormat::Exr => {
                let mut layered = LayeredImage::new(self.width, self.height);
                layered.layers.push(Layer::main(self));
                return layered.encode_exr();
            }
            OutputFormat::Hdr => self.to_rgb32f().write_to(&mut bytes, ImageFormat::Hdr),
        };
        written.map_err(|e| e.to_string())?;
        Ok(bytes.into_inner())
    }

    /// Writes the image to `path` in the format its extension names, atomically.
    pub fn save(&self, path: &Path) -> Result<(), ImageFileError> {
        self.save_with(path, &Tonemap::default())
    }

    /// [`save`](Self::save), 8-bit formats through `tonemap`.
    pub fn save_with(&self, path: &Path, tonemap: &Tonemap) -> Result<(), ImageFileError> {
        let format = OutputFormat::from_path(path)?;
        let bytes = self
            .encode_with(format, tonemap)
            .map_err(|reason| WriteError {
                path: path.to_owned(),
                reason,
            })?;
        Ok(io::write_atomically(path, &bytes)?)
    }

    /// Reads an image (8- and 16-bit formats taken as sRGB, EXR and HDR as linear) into
    /// linear RGB, strictly ([`decode_file`]).
    pub fn load(path: &Path) -> Result<Image, ImageFileError> {
        let fail = |reason| ImageFileError::Read {
            path: path.to_owned(),
            reason,
        };
        let file = ImageFile::open(path).map_err(fail)?;
        let image = file
            .decode_within("image", Image::LOAD_BYTES_PER_PIXEL)
            .map_err(fail)?;
        Ok(Image::from_image(image))
    }

    /// Bytes per pixel [`Image::load`] makes beside the decoded image: an RGB `f32`
    /// copy of it, then the pixels.
    pub const LOAD_BYTES_PER_PIXEL: u64 = 24;

    /// Loads two images that are used together (`ember compare`'s image and reference),
    /// after checking from their headers that both fit in memory at once, beside a
    /// downsampled copy of the first: nothing is decoded when they do not.
    pub fn load_pair(a: &Path, b: &Path) -> Result<(Image, Image), ImageFileError> {
        let open = |path: &Path| {
            ImageFile::open(path).map_err(|reason| ImageFileError::Read {
                path: path.to_owned(),
                reason,
            })
        };
        let (file_a, file_b) = (open(a)?, open(b)?);
        let needed = pair_memory_bytes(&file_a, &file_b);
        let what = format!(
            "comparing a {}x{} image with a {}x{} reference",
            file_a.width, file_a.height, file_b.width, file_b.height
        );
        crate::limits::check_fits(&what, needed).map_err(|reason| ImageFileError::Read {
            path: a.to_owned(),
            reason,
        })?;
        let decode = |file: ImageFile, path: &Path| {
            file.decode()
                .map(Image::from_image)
                .map_err(|reason| ImageFileError::Read {
                    path: path.to_owned(),
                    reason,
                })
        };
        // Each is held while the other is decoded (the check above counted both).
        let image = decode(file_a, a)?;
        Ok((image, decode(file_b, b)?))
    }
}

/// Bytes of memory [`Image::load_pair`] holds at its peak: both decodings with their
/// conversions, and a downsampled copy of the first image (at most its own size).
pub fn pair_memory_bytes(a: &ImageFile, b: &ImageFile) -> u64 {
    let pixels_a = u64::from(a.width) * u64::from(a.height);
    a.memory_bytes(Image::LOAD_BYTES_PER_PIXEL)
        .saturating_add(b.memory_bytes(Image::LOAD_BYTES_PER_PIXEL))
        .saturating_add(pixels_a.saturating_mul(12))
}

impl Image {
    /// A decoded image in linear RGB: floating-point images (EXR, HDR) as they are,
    /// 8- and 16-bit ones (PNG, JPEG, …) decoded from sRGB.
    pub fn from_image(image: DynamicImage) -> Image {
        let linear = matches!(
            image.color(),
            ::image::ColorType::Rgb32F | ::image::ColorType::Rgba32F
        );
        let rgb = image.to_rgb32f();
        let decode = |c: f32| if linear { c } else { srgb_to_linear(c) };
        Image {
            width: rgb.width(),
            height: rgb.height(),
            pixels: rgb
                .pixels()
                .map(|p| Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])))
                .collect(),
        }
    }
}

/// Checks before any work is done that `path` names a known image format and can be
/// written. Nothing is left behind.
pub fn check_output(path: &Path) -> Result<(), ImageFileError> {
    OutputFormat::from_path(path)?;
    Ok(io::check_writable(path)?)
}
