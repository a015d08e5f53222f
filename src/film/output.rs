//! How a film becomes an output file: its image, denoised if asked, with the render
//! passes as layers of an EXR. `ember render` and `ember merge` both write through here.

use std::path::Path;

use super::aov::Aov;
use super::Film;
use crate::denoise::{self, DenoiseError};
use crate::image::layers::{names, Layer, LayeredImage};
use crate::image::{Image, ImageFileError, OutputFormat, Tonemap};

/// What goes into the output file beside the image.
pub struct FilmOutput<'a> {
    /// Passes written as layers (EXR only; the caller refuses them for other formats),
    /// each once however often it is named.
    pub aovs: &'a [Aov],
    /// Denoise the image with the albedo and normal passes as guides.
    pub denoise: bool,
    /// The tone map of 8-bit outputs.
    pub tonemap: &'a Tonemap,
}

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error(transparent)]
    File(#[from] ImageFileError),
    #[error(transparent)]
    Denoise(#[from] DenoiseError),
    #[error(
        "{count} of the {pixels} pixels have no sample (the first is ({x}, {y})): an image \
         would show them black although nothing was measured there; no image written"
    )]
    Unsampled {
        count: usize,
        pixels: usize,
        x: u32,
        y: u32,
    },
}

impl FilmOutput<'_> {
    /// Writes `film` to `path` (atomically, as every output).
    /// Refuses a film with a pixel no sample reached.
    pub fn write(&self, film: &Film, path: &Path) -> Result<(), OutputError> {
        let unsampled = film.pixels.iter().filter(|p| p.done == 0).count();
        if let Some(first) = film.pixels.iter().position(|p| p.done == 0) {
            return Err(OutputError::Unsampled {
                count: unsampled,
                pixels: film.pixels.len(),
                x: first as u32 % film.width,
                y: first as u32 / film.width,
            });
        }
        let noisy = film.resolve();
        let image = if self.denoise {
            let albedo = pass_image(film, Aov::Albedo);
            let normal = pass_image(film, Aov::Normal);
            Some(denoise::denoise(&noisy, Some((&albedo, &normal)))?)
        } else {
            None
        };
        let main = image.as_ref().unwrap_or(&noisy);
        if OutputFormat::from_path(path)? != OutputFormat::Exr
            || (self.aovs.is_empty() && image.is_none())
        {
            return Ok(main.save_with(path, self.tonemap)?);
        }
        let mut layered = LayeredImage::new(film.width, film.height);
        layered.layers.push(Layer::main(main));
        if image.is_some() {
            layered
                .layers
                .push(Layer::from_image(names::NOISY, names::RGB, &noisy));
        }
        // A pass named twice (`--aov albedo,normal,albedo`) is one layer.
        for (i, &aov) in self.aovs.iter().enumerate() {
            if self.aovs[..i].contains(&aov) {
                continue;
            }
            layered
                .layers
                .push(Layer::new(aov.name(), aov.channels(), film.aov(aov)));
        }
        Ok(layered.write_exr(path)?)
    }
}

/// A three-channel pass as an image (albedo, normal) for the denoiser.
fn pass_image(film: &Film, aov: Aov) -> Image {
    let data = film.aov(aov);
    let mut image = Image::new(film.width, film.height);
    for (p, v) in image.pixels.iter_mut().zip(data.chunks_exact(3)) {
        *p = glam::Vec3::from_slice(v);
    }
    image
}
