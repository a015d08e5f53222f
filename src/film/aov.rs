//! Render passes (arbitrary output variables): what a film knows of each pixel beside
//! its radiance, resolved to per-pixel values for an EXR layer or the denoiser.

use super::weights::SplitWeights;
use super::{Film, Moments, PixelSums};
use crate::image::layers::names;

/// A render pass `--aov` can ask for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Aov {
    /// Mean albedo at the first non-delta vertex (RGB).
    Albedo,
    /// Mean shading normal there, in world space (XYZ; shorter than 1 where a pixel
    /// straddles surfaces, zero where nothing is hit).
    Normal,
    /// Mean distance along the camera ray to the first hit (0 for misses).
    Depth,
    /// Estimated variance of the pixel's radiance (RGB): of the mean, not of one
    /// sample, so it falls as 1/spp; infinite below two samples.
    Variance,
    /// Samples taken in the pixel.
    Spp,
}

impl Aov {
    pub const ALL: [Aov; 5] = [
        Aov::Albedo,
        Aov::Normal,
        Aov::Depth,
        Aov::Variance,
        Aov::Spp,
    ];

    /// The name on the command line and of the EXR layer ([`names`]).
    pub fn name(self) -> &'static str {
        match self {
            Aov::Albedo => names::ALBEDO,
            Aov::Normal => names::NORMAL,
            Aov::Depth => names::DEPTH,
            Aov::Variance => names::VARIANCE,
            Aov::Spp => names::SPP,
        }
    }

    pub fn from_name(name: &str) -> Option<Aov> {
        Aov::ALL.into_iter().find(|a| a.name() == name)
    }

    /// The pass's channel names, as EXR viewers expect them for such data.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            Aov::Albedo | Aov::Variance => &names::RGB,
            Aov::Normal => &names::XYZ,
            Aov::Depth => &["Z"],
            Aov::Spp => &["Y"],
        }
    }

    /// The pass's value at one pixel, one number per channel, into `out`.
    fn values(self, p: &PixelSums, (weights, t): (&SplitWeights, &Moments), out: &mut Vec<f32>) {
        let mean = |sum: glam::Vec3| match p.kept {
            0 => glam::Vec3::ZERO,
            n => sum / n as f32,
        };
        match self {
            Aov::Albedo => out.extend(mean(p.albedo).to_array()),
            Aov::Normal => out.extend(mean(p.normal).to_array()),
            Aov::Depth => out.push(match p.kept {
                0 => 0.0,
                n => p.depth / n as f32,
            }),
            Aov::Variance => out.extend(weights.variance_of_mean(p, t).as_vec3().to_array()),
            Aov::Spp => out.push(p.done as f32),
        }
    }
}

impl Film {
    /// A pass over the whole image, row by row, channels interleaved per pixel.
    pub fn aov(&self, aov: Aov) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.pixels.len() * aov.channels().len());
        let weights = match aov {
            Aov::Variance => SplitWeights::of(self),
            _ => SplitWeights::EQUAL,
        };
        for (i, p) in self.pixels.iter().enumerate() {
            aov.values(p, (&weights, &self.training_of(i)), &mut out);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Sample;
    use glam::Vec3;

    #[test]
    fn passes_are_means_over_the_kept_samples() {
        let mut film = Film::new(1, 1, 0..4);
        let p = &mut film.pixels[0];
        for (l, d) in [(1.0, 2.0), (3.0, 4.0), (f32::NAN, 100.0)] {
            p.add(&Sample {
                radiance: Vec3::splat(l),
                albedo: Vec3::new(0.5, 0.25, 1.0),
                normal: Vec3::Y,
                depth: d,
            });
        }
        assert_eq!((p.kept, p.done), (2, 3));
        assert_eq!(film.aov(Aov::Albedo), vec![0.5, 0.25, 1.0]);
        assert_eq!(film.aov(Aov::Normal), vec![0.0, 1.0, 0.0]);
        assert_eq!(film.aov(Aov::Depth), vec![3.0]);
        assert_eq!(film.aov(Aov::Spp), vec![3.0]);
        // Samples 1 and 3: sample variance 2, variance of the mean 1.
        assert_eq!(film.aov(Aov::Variance), vec![1.0; 3]);
    }

    #[test]
    fn names_round_trip() {
        for aov in Aov::ALL {
            assert_eq!(Aov::from_name(aov.name()), Some(aov));
        }
        assert_eq!(Aov::from_name("beauty"), None);
    }
}
