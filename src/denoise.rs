//! Denoising a rendered image with Intel Open Image Denoise (OIDN), through the `oidn`
//! crate's safe API, on OIDN's CPU device.
//!
//! The colour goes through OIDN's `RT` filter (the one trained on Monte Carlo renders) as
//! HDR radiance. Given albedo and normal passes (the first non-delta hit's), those guide
//! it, and are first denoised themselves, each by an `RT` filter of its own, so that the
//! main filter may take them as noise-free (`cleanAux`): OIDN's recipe for final frames.
//! The crate's safe API sets a filter's colour input always, so a pass is prefiltered
//! as an LDR colour image (albedo as it is, normals mapped from [-1, 1] to [0, 1] and
//! back) rather than through OIDN's auxiliary-only mode.
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

/// Denoises `color` (linear HDR radiance), guided by `(albedo, normal)` when given.
/// Input with a NaN or infinity anywhere is refused: OIDN would spread it.
pub fn denoise(color: &Image, aux: Option<(&Image, &Image)>) -> Result<Image, DenoiseError> {
    if color.width == 0 || color.height == 0 {
        return Err(DenoiseError::Empty(color.width, color.height));
    }
    check_finite("colour", color)?;
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
            let albedo = prefilter(&device, albedo, |c| c.clamp(Vec3::ZERO, Vec3::ONE), |c| c)?;
            let normal = prefilter(
                &device,
                normal,
                |n| (n * 0.5 + 0.5).clamp(Vec3::ZERO, Vec3::ONE),
                |c| c * 2.0 - 1.0,
            )?;
            filter
                .albedo_normal_buffer(
                    device.create_buffer(&albedo)?,
                    device.create_buffer(&normal)?,
                )?
                .clean_aux(true);
        }
        let mut pixels = flatten(color, |c| c);
        filter.filter_in_place(&mut pixels)?;
        Ok(Image {
            width: color.width,
            height: color.height,
            pixels: pixels.chunks_exact(3).map(Vec3::from_slice).collect(),
        })
    }

    /// A pass denoised by an `RT` filter of its own, as an LDR image: `to_unit` maps
    /// it into [0, 1], `from_unit` back.
    fn prefilter(
        device: &oidn::Device,
        pass: &Image,
        to_unit: impl Fn(Vec3) -> Vec3,
        from_unit: impl Fn(Vec3) -> Vec3,
    ) -> Result<Vec<f32>, DenoiseError> {
        let mut filter = oidn::RayTracing::try_new(device)?;
        filter
            .hdr(false)
            .image_dimensions(pass.width as usize, pass.height as usize);
        let mut data = flatten(pass, to_unit);
        filter.filter_in_place(&mut data)?;
        for c in data.chunks_exact_mut(3) {
            c.copy_from_slice(&from_unit(Vec3::from_slice(c)).to_array());
        }
        Ok(data)
    }

    /// Pixels as OIDN's interleaved `FLOAT3`, each through `map`.
    fn flatten(image: &Image, map: impl Fn(Vec3) -> Vec3) -> Vec<f32> {
        image
            .pixels
            .iter()
            .flat_map(|&p| map(p).to_array())
            .collect()
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
