//! The image being rendered (linear `f32` RGB) and writing it out: PNG as 8-bit sRGB,
//! EXR and HDR as linear radiance. Files appear whole or not at all.

mod compare;

pub use compare::{compare, compare_pixels, ImageError, SizeMismatch};

use std::io::Write;
use std::path::{Path, PathBuf};

use glam::Vec3;
use image::{ImageFormat, Rgb32FImage, RgbImage};

/// Linear RGB radiance per pixel, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
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
pub enum FilmError {
    #[error("unsupported output format {0:?}: use .png, .exr or .hdr")]
    UnknownFormat(PathBuf),
    #[error("cannot write {path}: {reason}")]
    Write { path: PathBuf, reason: String },
    #[error("cannot read image {path}: {reason}")]
    Read { path: PathBuf, reason: String },
}

impl OutputFormat {
    pub fn from_path(path: &Path) -> Result<Self, FilmError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(OutputFormat::Png),
            Some("exr") => Ok(OutputFormat::Exr),
            Some("hdr") => Ok(OutputFormat::Hdr),
            _ => Err(FilmError::UnknownFormat(path.to_owned())),
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

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Film {
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
        Rgb32FImage::from_raw(self.width, self.height, data).expect("film size matches its pixels")
    }

    fn to_srgb8(&self) -> RgbImage {
        let data = self
            .pixels
            .iter()
            .flat_map(|p| p.to_array())
            .map(|c| (linear_to_srgb(c) * 255.0 + 0.5) as u8)
            .collect();
        RgbImage::from_raw(self.width, self.height, data).expect("film size matches its pixels")
    }

    /// Encodes the image in `format` into memory.
    pub fn encode(&self, format: OutputFormat) -> Result<Vec<u8>, image::ImageError> {
        let mut bytes = std::io::Cursor::new(Vec::new());
        match format {
            OutputFormat::Png => self.to_srgb8().write_to(&mut bytes, ImageFormat::Png)?,
            OutputFormat::Exr => self
                .to_rgb32f()
                .write_to(&mut bytes, ImageFormat::OpenExr)?,
            OutputFormat::Hdr => self.to_rgb32f().write_to(&mut bytes, ImageFormat::Hdr)?,
        }
        Ok(bytes.into_inner())
    }

    /// Writes the image to `path` in the format its extension names, atomically.
    pub fn save(&self, path: &Path) -> Result<(), FilmError> {
        let format = OutputFormat::from_path(path)?;
        let bytes = self.encode(format).map_err(|e| FilmError::Write {
            path: path.to_owned(),
            reason: e.to_string(),
        })?;
        write_atomically(path, &bytes)
    }

    /// Reads a PNG (taken as sRGB), EXR or HDR (linear) image into linear RGB.
    pub fn load(path: &Path) -> Result<Film, FilmError> {
        let fail = |reason: String| FilmError::Read {
            path: path.to_owned(),
            reason,
        };
        let image = image::ImageReader::open(path)
            .map_err(|e| fail(e.to_string()))?
            .with_guessed_format()
            .map_err(|e| fail(e.to_string()))?
            .decode()
            .map_err(|e| fail(e.to_string()))?;
        Ok(Film::from_image(image))
    }

    /// A decoded image in linear RGB: floating-point images (EXR, HDR) as they are,
    /// 8- and 16-bit ones (PNG, JPEG, …) decoded from sRGB.
    pub fn from_image(image: image::DynamicImage) -> Film {
        let linear = matches!(
            image.color(),
            image::ColorType::Rgb32F | image::ColorType::Rgba32F
        );
        let rgb = image.to_rgb32f();
        let decode = |c: f32| if linear { c } else { srgb_to_linear(c) };
        Film {
            width: rgb.width(),
            height: rgb.height(),
            pixels: rgb
                .pixels()
                .map(|p| Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])))
                .collect(),
        }
    }
}

/// Checks before any work is done that `path` can be written: its format is known and
/// its directory accepts a new file. Nothing is left behind.
pub fn check_writable(path: &Path) -> Result<(), FilmError> {
    OutputFormat::from_path(path)?;
    let fail = |reason: String| FilmError::Write {
        path: path.to_owned(),
        reason,
    };
    if path.is_dir() {
        return Err(fail("it is a directory".into()));
    }
    let dir = parent_dir(path);
    tempfile::Builder::new()
        .prefix(".ember-check")
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| fail(io_reason(&e)))
}

/// An I/O error's message without the temporary file's name that tempfile appends.
fn io_reason(e: &std::io::Error) -> String {
    match e.raw_os_error() {
        Some(code) => std::io::Error::from_raw_os_error(code).to_string(),
        None => e.to_string(),
    }
}

fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `bytes` to a temporary file beside `path`, flushes it to disk and renames it
/// over `path`: readers see the old file or the whole new one, never a part.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), FilmError> {
    let fail = |reason: String| FilmError::Write {
        path: path.to_owned(),
        reason,
    };
    let mut file = tempfile::Builder::new()
        .prefix(".ember-")
        .suffix(".tmp")
        .tempfile_in(parent_dir(path))
        .map_err(|e| fail(io_reason(&e)))?;
    file.write_all(bytes).map_err(|e| fail(e.to_string()))?;
    // tempfile creates files readable by their owner only; an image or checkpoint is an
    // ordinary file, so keep the mode of the file being replaced, or rw-r--r--.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).map_or(0o644, |m| m.permissions().mode() & 0o7777);
        file.as_file()
            .set_permissions(std::fs::Permissions::from_mode(mode))
            .map_err(|e| fail(e.to_string()))?;
    }
    file.as_file().sync_all().map_err(|e| fail(e.to_string()))?;
    file.persist(path).map_err(|e| fail(e.error.to_string()))?;
    Ok(())
}
