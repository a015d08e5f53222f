//! Denoising a rendered image with Intel Open Image Denoise (OIDN), through the `oidn`
//! crate's safe API, on OIDN's CPU device.
//!
//! The colour goes through OIDN's `RT` filter (the one trained on Monte Carlo renders) as
//! HDR radiance, guided, when given, by the albedo and normal passes of the first
//! non-delta hit, which keep edges and texture sharp. The passes are given as they are,
//! in OIDN's mode for auxiliary images that may hold some noise (a pixel's samples
//! average them, but behind glass, or where surfaces meet inside a pixel, they vary).
//!
//! Not done: OIDN's final-frame recipe, denoising each pass first (a filter with only
//! `albedo` or `normal` set) and then declaring them clean (`cleanAux`). The `oidn`
//! crate 2.5.1's safe API cannot express it: a filter's colour input is always set, and
//! its `clean_aux(true)` sets a parameter named `clean_aux`, which OIDN ignores ("unknown
//! filter parameter" with OIDN_VERBOSE=2; the parameter is `cleanAux`). Measured through
//! OIDN's C API, the recipe did not pay on the Cornell boxes
//! (benches/results/2026-12-01-denoising.md).
//!
//! Without the `denoise` feature ember has no OIDN, and every call here says how to get
//! it.

use crate::image::Image;

/// Why an image could not be denoised.
#[derive(Debug, thiserror::Error)]
pub enum DenoiseError {
    #[error(
        "this ember was built without Open Image Denoise: run scripts/setup.sh and rebuild \
         (cargo build --release)"
    )]
    NotBuilt,
    #[error("the {pass} image has a non-finite value {value} at pixel ({x}, {y}): OIDN needs finite input")]
    NonFinite {
        pass: &'static str,
        x: u32,
        y: u32,
        value: f32,
    },
    #[error("the {pass} image is {found_w}x{found_h}, the colour image {width}x{height}")]
    SizeMismatch {
        pass: &'static str,
        found_w: u32,
        found_h: u32,
        width: u32,
        height: u32,
    },
    #[error("the image is empty ({0}x{1})")]
    Empty(u32, u32),
    /// The machine (or EMBER_MEMORY_LIMIT) has less memory than denoising needs.
    #[error("{0}")]
    Memory(String),
    /// OIDN's own error: its kind and message.
    #[error("Open Image Denoise failed ({kind}): {message}")]
    Oidn { kind: &'static str, message: String },
}

/// The OIDN in this build: the library linked and the device it denoises on.
#[derive(Clone, Debug)]
pub struct DenoiserInfo {
    /// The library's version, from the file linked (`libOpenImageDenoise.so.2.5.1`).
    pub version: String,
    /// The library file the build linked.
    pub library: &'static str,
    pub device: &'static str,
}

/// Bytes of memory denoising a `width × height` image takes: OIDN's scratch memory
/// (measured with OIDN_VERBOSE=2: 1.21 GB at 1920×1080, 582 bytes a pixel; above about
/// 2.6 GB OIDN splits the image into tiles, as at 3840×2160) and the colour, the guides
/// and the output, each as ember's image and as OIDN's buffer.
pub fn memory_bytes(width: u32, height: u32) -> u64 {
    const SCRATCH_PER_PIXEL: u64 = 600;
    const SCRATCH_MAX: u64 = 2800 << 20;
    const IMAGES_PER_PIXEL: u64 = 4 * 2 * 12;
    let pixels = u64::from(width) * u64::from(height);
    (pixels * SCRATCH_PER_PIXEL).min(SCRATCH_MAX) + pixels * IMAGES_PER_PIXEL
}

/// Denoises `color` (linear HDR radiance), guided by `(albedo, normal)` when given.
/// Input with a NaN or infinity anywhere is refused: OIDN would spread it.
pub fn denoise(color: &Image, aux: Option<(&Image, &Image)>) -> Result<Image, DenoiseError> {
    if color.width == 0 || color.height == 0 {
        return Err(DenoiseError::Empty(color.width, color.height));
    }
    check_finite("colour", color)?;
    let (w, h) = (color.width, color.height);
    crate::limits::check_fits(&format!("denoising a {w}x{h} image"), memory_bytes(w, h))
        .map_err(DenoiseError::Memory)?;
    if let Some((albedo, normal)) = aux {
        for (pass, image) in [("albedo", albedo), ("normal", normal)] {
            if (image.width, image.height) != (color.width, color.height) {
                return Err(DenoiseError::SizeMismatch {
                    pass,
                    found_w: image.width,
                    found_h: image.height,
                    width: color.width,
                    height: color.height,
                });
            }
            check_finite(pass, image)?;
        }
    }
    oidn_filter::denoise(color, aux)
}

/// Whether this build can denoise: OIDN is built in and its CPU device starts. Lets a
/// render that will denoise fail before it starts rather than after.
pub fn available() -> Result<DenoiserInfo, DenoiseError> {
    oidn_filter::info()
}

fn check_finite(pass: &'static str, image: &Image) -> Result<(), DenoiseError> {
    let bad = image.pixels.iter().enumerate().find_map(|(i, p)| {
        p.to_array()
            .into_iter()
            .find(|v| !v.is_finite())
            .map(|v| (i, v))
    });
    match bad {
        None => Ok(()),
        Some((i, value)) => Err(DenoiseError::NonFinite {
            pass,
            x: i as u32 % image.width,
            y: i as u32 / image.width,
            value,
        }),
    }
}

#[cfg(feature = "denoise")]
mod oidn_filter {
    use super::{DenoiseError, DenoiserInfo};
    use crate::image::Image;
    use glam::Vec3;

    impl From<oidn::Error> for DenoiseError {
        fn from(e: oidn::Error) -> Self {
            DenoiseError::Oidn {
                kind: e.kind().as_str(),
                message: e.message().to_owned(),
            }
        }
    }

    const LIBRARY: &str = env!("EMBER_OIDN_LIBRARY");

    pub fn info() -> Result<DenoiserInfo, DenoiseError> {
        oidn::Device::cpu()?;
        let version = LIBRARY
            .rsplit_once(".so.")
            .map_or("(unknown version)", |(_, v)| v)
            .to_owned();
        Ok(DenoiserInfo {
            version,
            library: LIBRARY,
            device: "CPU",
        })
    }

    pub fn denoise(color: &Image, aux: Option<(&Image, &Image)>) -> Result<Image, DenoiseError> {
        let device = oidn::Device::cpu()?;
        let (w, h) = (color.width as usize, color.height as usize);
        let mut filter = oidn::RayTracing::try_new(&device)?;
        filter.hdr(true).image_dimensions(w, h);
        if let Some((albedo, normal)) = aux {
            filter.albedo_normal_buffer(
                device.create_buffer(&flatten(albedo))?,
                device.create_buffer(&flatten(normal))?,
            )?;
        }
        let mut pixels = flatten(color);
        filter.filter_in_place(&mut pixels)?;
        Ok(Image {
            width: color.width,
            height: color.height,
            pixels: pixels.chunks_exact(3).map(Vec3::from_slice).collect(),
        })
    }

    /// Pixels as OIDN's interleaved `FLOAT3`.
    fn flatten(image: &Image) -> Vec<f32> {
        image.pixels.iter().flat_map(|p| p.to_array()).collect()
    }
}

#[cfg(not(feature = "denoise"))]
mod oidn_filter {
    use super::{DenoiseError, DenoiserInfo};
    use crate::image::Image;

    pub fn info() -> Result<DenoiserInfo, DenoiseError> {
        Err(DenoiseError::NotBuilt)
    }

    pub fn denoise(_: &Image, _: Option<(&Image, &Image)>) -> Result<Image, DenoiseError> {
        Err(DenoiseError::NotBuilt)
    }
}
