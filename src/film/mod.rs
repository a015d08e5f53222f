//! The film: where a render's samples are added. Per pixel it holds sums over the finite
//! sample estimates ([`PixelSums`]: the radiance in `f64`, added in sample order, its
//! square, and the render passes), how many of them were finite, and how many samples
//! were taken, for one range of sample indices that is the same for every pixel
//! (`0..spp` for a whole render, a shard's share otherwise).
//!
//! Sample `i` of a pixel always uses the random stream `(seed, pixel, i)` and is added
//! after samples `first..i`, so however a render is split into passes, interrupted and
//! resumed, the sums are bit for bit the same. Films of adjacent sample ranges merge
//! (shards); a film resolves to an [`Image`] and to its passes ([`aov`]); [`checkpoint`]
//! stores one in a file.

pub mod aov;
pub mod checkpoint;
pub mod merge;
pub mod output;
pub mod weights;

use std::ops::Range;

use glam::{DVec3, Vec3};

use crate::image::Image;

/// What one camera sample adds to its pixel: the radiance estimate and the render
/// passes' values (see [`crate::integrator::PathTracer::sample`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    pub radiance: Vec3,
    /// Albedo at the first vertex whose BSDF is not a delta (seen through mirrors and
    /// glass), or the sky's radiance clamped to `[0, 1]` where the path escapes first.
    pub albedo: Vec3,
    /// Shading normal there, turned towards the incoming ray; zero where none is hit.
    pub normal: Vec3,
    /// Distance along the camera ray to its first hit; zero for a miss.
    pub depth: f32,
}

/// The sums a film holds for one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSums {
    /// Sum of the finite radiance estimates.
    pub radiance: DVec3,
    /// Sum of their squares, per channel: with `radiance` and `kept`, the variance.
    pub radiance_sq: DVec3,
    /// Sums of the passes over the same (finite) samples, in `f32`: they guide a
    /// denoiser and are shown, so `f32` rounding is far below what matters.
    pub albedo: Vec3,
    pub normal: Vec3,
    pub depth: f32,
    /// Samples whose estimate was finite (the divisor of every mean).
    pub kept: u32,
    /// Samples taken.
    pub done: u32,
    /// Adaptive sampling stopped this pixel before the film's range was done.
    pub converged: bool,
}

/// Sums of a set of finite radiance estimates: the first two moments and the count.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    pub sum: DVec3,
    pub sum_sq: DVec3,
    pub kept: u32,
}

impl Moments {
    /// Adds one finite estimate.
    #[inline]
    pub fn add(&mut self, l: DVec3) {
        self.sum += l;
        self.sum_sq += l * l;
        self.kept += 1;
    }

    /// Adds the moments of other samples.
    pub fn merge(&mut self, other: &Moments) {
        self.sum += other.sum;
        self.sum_sq += other.sum_sq;
        self.kept += other.kept;
    }

    /// The samples' mean (black without any).
    pub fn mean(&self) -> DVec3 {
        match self.kept {
            0 => DVec3::ZERO,
            n => self.sum / f64::from(n),
        }
    }

    /// The samples' unbiased variance per channel; `None` with fewer than two.
    pub fn sample_variance(&self) -> Option<DVec3> {
        if self.kept < 2 {
            return None;
        }
        let n = f64::from(self.kept);
        // Rounding can make E[x²] − E[x]² a hair negative for constant samples (and
        // for the difference of two sets' sums, see `PixelSums::moments_without`).
        Some(((self.sum_sq - self.sum * (self.sum / n)) / (n - 1.0)).max(DVec3::ZERO))
    }
}

impl PixelSums {
    /// Adds one sample; a non-finite radiance estimate is counted as taken but left
    /// out of every sum. Returns whether it was kept.
    #[inline]
    pub fn add(&mut self, s: &Sample) -> bool {
        self.done += 1;
        if !s.radiance.is_finite() {
            return false;
        }
        let l = s.radiance.as_dvec3();
        self.radiance += l;
        self.radiance_sq += l * l;
        self.albedo += s.albedo;
        self.normal += s.normal;
        self.depth += s.depth;
        self.kept += 1;
        true
    }

    /// Adds one of guiding's training samples: as [`add`](Self::add), and to the
    /// pixel's `training` moments too.
    #[inline]
    pub fn add_training(&mut self, s: &Sample, training: &mut Moments) -> bool {
        let kept = self.add(s);
        if kept {
            training.add(s.radiance.as_dvec3());
        }
        kept
    }

    /// The moments of all kept samples.
    pub fn moments(&self) -> Moments {
        Moments {
            sum: self.radiance,
            sum_sq: self.radiance_sq,
            kept: self.kept,
        }
    }

    /// The moments of the samples that are not in `training` (the final guide's).
    pub fn moments_without(&self, training: &Moments) -> Moments {
        Moments {
            sum: self.radiance - training.sum,
            sum_sq: self.radiance_sq - training.sum_sq,
            kept: self.kept - training.kept,
        }
    }

    /// Adds the sums of the same pixel over a later sample range (another shard).
    pub fn merge(&mut self, other: &PixelSums) {
        self.radiance += other.radiance;
        self.radiance_sq += other.radiance_sq;
        self.albedo += other.albedo;
        self.normal += other.normal;
        self.depth += other.depth;
        self.kept += other.kept;
        self.done += other.done;
        // A merged pixel stopped early where any part of it did: it has fewer samples
        // than the whole range for that reason, not by a missing part.
        self.converged |= other.converged;
    }

    /// The mean radiance of the kept samples (black without any), each weighing the
    /// same (the image weighs training's apart: [`Film::resolve`]).
    pub fn mean(&self) -> DVec3 {
        self.moments().mean()
    }

    /// The estimated variance of [`mean`](Self::mean) per channel: the samples'
    /// unbiased variance over their count. Infinite with fewer than two samples,
    /// since nothing is known of it then.
    pub fn variance_of_mean(&self) -> DVec3 {
        match self.moments().sample_variance() {
            Some(var) => var / f64::from(self.kept),
            None => DVec3::INFINITY,
        }
    }

    /// The pixel's estimated relative error as `ember compare` weighs it: the square
    /// root of the expected `(mean − truth)² / (truth² + 0.01)`, averaged over the
    /// channels, with the mean standing in for the truth.
    pub fn relative_error(&self) -> f64 {
        let mean = self.mean();
        let rel = self.variance_of_mean() / (mean * mean + DVec3::splat(0.01));
        (rel.element_sum() / 3.0).sqrt()
    }
}

/// Per-pixel sample sums over the sample indices `samples`.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// The sample indices this film accumulates; pixel `i` holds samples
    /// `samples.start .. samples.start + pixels[i].done`.
    pub samples: Range<u32>,
    pub pixels: Vec<PixelSums>,
    /// The part of each pixel's sums that path guiding's training samples added, kept
    /// apart so that the image can weigh them against the final guide's by their
    /// variances ([`weights`]): empty until a training sample is added (without
    /// guiding, or in a shard past training's samples), then one per pixel.
    pub training: Vec<Moments>,
}

/// A rectangle of a [`Film`] (x0, y0, width, height), copied out so that one worker at
/// a time can add samples to it; written back with [`Film::write_tile`].
#[derive(Clone, Debug)]
pub struct FilmTile {
    pub rect: (u32, u32, u32, u32),
    pub pixels: Vec<PixelSums>,
    /// Training's moments of its pixels, as [`Film::training`]: empty or one a pixel.
    pub training: Vec<Moments>,
}

impl FilmTile {
    /// Pixel `i` and its training moments, which are made when first asked for.
    pub fn training_pixel(&mut self, i: usize) -> (&mut PixelSums, &mut Moments) {
        let training = made_training(&mut self.training, self.pixels.len());
        (&mut self.pixels[i], &mut training[i])
    }
}

/// `training`, made (zero, one per pixel) if it is still empty.
fn made_training(training: &mut Vec<Moments>, pixels: usize) -> &mut [Moments] {
    if training.is_empty() {
        *training = vec![Moments::default(); pixels];
    }
    training
}

impl Film {
    /// An empty film for the sample indices `samples` of a `width × height` image.
    pub fn new(width: u32, height: u32, samples: Range<u32>) -> Self {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            samples,
            pixels: vec![PixelSums::default(); n],
            training: Vec::new(),
        }
    }

    /// Pixel `i`'s training moments (zero where the film has none).
    pub fn training_of(&self, i: usize) -> Moments {
        self.training.get(i).copied().unwrap_or_default()
    }

    /// Training's moments, made (zero) when first asked for.
    pub fn training_mut(&mut self) -> &mut [Moments] {
        made_training(&mut self.training, self.pixels.len())
    }

    /// Fewest samples any pixel has.
    pub fn min_done(&self) -> u32 {
        self.pixels.iter().map(|p| p.done).min().unwrap_or(0)
    }

    /// Samples taken over the whole image.
    pub fn total_done(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.done)).sum()
    }

    /// Whether every pixel has every sample of the film's range, or was stopped by
    /// adaptive sampling.
    pub fn is_complete(&self) -> bool {
        let len = self.samples.len() as u32;
        self.pixels.iter().all(|p| p.converged || p.done >= len)
    }

    /// The image so far: each pixel the mean of its finite samples (black without
    /// any), guiding's training samples and the rest weighed by their variances
    /// ([`weights::SplitWeights`]; the plain mean without guiding).
    pub fn resolve(&self) -> Image {
        let weights = weights::SplitWeights::of(self);
        let mut image = Image::new(self.width, self.height);
        for (i, (out, p)) in image.pixels.iter_mut().zip(&self.pixels).enumerate() {
            *out = weights.mean(p, &self.training_of(i)).as_vec3();
        }
        image
    }

    /// Adds the film of the sample range that follows this one (a later shard), so that
    /// the range grows to `self.samples.start .. other.samples.end`. Sums are added per
    /// pixel, earlier range first; see [`merge`] for how that compares with one process.
    pub fn merge(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height, self.samples.end),
            (other.width, other.height, other.samples.start),
            "films of one image and adjacent sample ranges"
        );
        for (a, b) in self.pixels.iter_mut().zip(&other.pixels) {
            a.merge(b);
        }
        if !other.training.is_empty() {
            for (a, b) in self.training_mut().iter_mut().zip(&other.training) {
                a.merge(b);
            }
        }
        self.samples.end = other.samples.end;
    }

    /// The film cut into `tile_size`-square tiles (smaller at the right and bottom
    /// edges), row by row.
    pub fn tiles(&self, tile_size: u32) -> Vec<FilmTile> {
        tile_rects(self.width, self.height, tile_size)
            .into_iter()
            .map(|rect| FilmTile {
                rect,
                pixels: self
                    .rows(rect)
                    .flat_map(|row| self.pixels[row].iter().copied())
                    .collect(),
                training: match self.training.is_empty() {
                    true => Vec::new(),
                    false => self
                        .rows(rect)
                        .flat_map(|row| self.training[row].iter().copied())
                        .collect(),
                },
            })
            .collect()
    }

    /// Puts a tile's pixels back in their place.
    pub fn write_tile(&mut self, tile: &FilmTile) {
        let w = tile.rect.2 as usize;
        for (r, row) in self.rows(tile.rect).enumerate() {
            self.pixels[row].copy_from_slice(&tile.pixels[r * w..(r + 1) * w]);
        }
        if !tile.training.is_empty() {
            self.training_mut();
            for (r, row) in self.rows(tile.rect).enumerate() {
                self.training[row].copy_from_slice(&tile.training[r * w..(r + 1) * w]);
            }
        }
    }

    /// The index ranges of the rows of a rectangle in the pixel arrays.
    fn rows(&self, (x0, y0, w, h): (u32, u32, u32, u32)) -> impl Iterator<Item = Range<usize>> {
        let width = self.width as usize;
        (y0 as usize..(y0 + h) as usize)
            .map(move |y| y * width + x0 as usize..y * width + (x0 + w) as usize)
    }
}

/// The sample indices of shard `i` of `n` of a render of `spp` samples per pixel:
/// `floor(i·spp/n) .. floor((i+1)·spp/n)`. The shards of one `n` are disjoint, cover
/// `0..spp` in order, and differ in size by at most one sample.
pub fn shard_samples(spp: u32, (i, n): (u32, u32)) -> Range<u32> {
    let at = |k: u32| (u64::from(k) * u64::from(spp) / u64::from(n)) as u32;
    at(i)..at(i + 1)
}

/// The tiles of a `width × height` image as (x0, y0, w, h), row by row.
pub fn tile_rects(width: u32, height: u32, tile_size: u32) -> Vec<(u32, u32, u32, u32)> {
    let mut tiles = Vec::new();
    for y0 in (0..height).step_by(tile_size as usize) {
        for x0 in (0..width).step_by(tile_size as usize) {
            tiles.push((
                x0,
                y0,
                tile_size.min(width - x0),
                tile_size.min(height - y0),
            ));
        }
    }
    tiles
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_tile_the_samples_in_order() {
        for spp in [0, 1, 2, 7, 10, 64, 1_000_000] {
            for n in [1, 2, 3, 4, 7, 10, 16, 100] {
                let ranges: Vec<_> = (0..n).map(|i| shard_samples(spp, (i, n))).collect();
                assert_eq!(ranges[0].start, 0);
                assert_eq!(ranges[n as usize - 1].end, spp);
                assert!(ranges.windows(2).all(|w| w[0].end == w[1].start));
                let (lo, hi) = (spp / n, spp.div_ceil(n));
                assert!(ranges.iter().all(|r| (lo..=hi).contains(&(r.len() as u32))));
            }
        }
    }

    #[test]
    fn tiles_written_back_rebuild_the_film() {
        let mut film = Film::new(37, 21, 0..4);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            p.radiance = DVec3::splat(i as f64);
            p.done = i as u32 % 5;
        }
        let tiles = film.tiles(16);
        assert_eq!(tiles.len(), 3 * 2);
        let mut rebuilt = Film::new(37, 21, 0..4);
        for tile in &tiles {
            rebuilt.write_tile(tile);
        }
        assert_eq!(rebuilt, film);
    }
}
