//! How a pixel's training samples are weighed against the rest (Müller, "Practical
//! Path Guiding in Production", 2019: each iteration's image weighed by the inverse of
//! its variance).
//!
//! A guided render's first `2^N − 1` samples per pixel are training's, drawn with guides
//! learnt from one, two, four, … samples per pixel (the first unguided), and the rest
//! with the final guide. Each sample is an unbiased estimate of the pixel, but not an
//! equally good one: a training sample carries several times the variance of a
//! final-guide one on glossy scenes (benches/results/2026-12-03-guiding-sittings-1-to-9.md).
//! Two independent unbiased means, `m_t` of `n_t` training samples and `m_f` of `n_f`
//! final ones, combine with the least variance as
//!
//! ```text
//! m = (a·m_t + b·m_f) / (a + b),   a = n_t / v_t,   b = n_f / v_f,
//! ```
//!
//! `v_t` and `v_f` the variances of one sample of each kind. A pixel has too few
//! training samples to know its own, so they are the image's: each kind's per-sample
//! variance relative to the square of the pixel's final-guide mean plus 0.01 (the
//! error `ember compare` and adaptive sampling measure), averaged over the channels and
//! over the pixels with at least two samples of both kinds. The scale is the final
//! samples' mean, not all samples' (Cornell GlossyMix: training's variance 3.2–3.5× the
//! final guide's by it, 1.7× by the mean of all), because a rare large training
//! sample raises the mean of all and so hides its own share of the variance. The
//! counts `n_t`, `n_f` stay each pixel's own, so pixels stopped early by adaptive
//! sampling or a time limit are weighed by what they have.
//!
//! The weights depend on the samples only through these two averages over the whole
//! image, so the image is biased by far less than its noise, and consistent: as the
//! final guide's samples grow, `b` outweighs `a`. Where nothing is known of a variance
//! (no training samples, fewer than two of a kind in every pixel, a variance of 0) every
//! sample weighs the same, as before: a render without guiding is unchanged bit for bit.

use glam::DVec3;

use super::{Film, Moments, PixelSums};

/// The inverse per-sample variances of training's samples and of the rest, or `None`
/// for the plain mean.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitWeights(Option<(f64, f64)>);

impl SplitWeights {
    /// Every sample weighs the same.
    pub const EQUAL: SplitWeights = SplitWeights(None);

    /// The weights of `film`'s samples (see the module's documentation).
    pub fn of(film: &Film) -> SplitWeights {
        let (mut training, mut rest, mut pixels) = (0.0, 0.0, 0u64);
        for (p, kept_apart) in film.pixels.iter().zip(&film.training) {
            let last = p.moments_without(kept_apart);
            let Some((t, f)) = kept_apart.sample_variance().zip(last.sample_variance()) else {
                continue;
            };
            let m = last.mean();
            let scale = m * m + DVec3::splat(0.01);
            training += (t / scale).element_sum() / 3.0;
            rest += (f / scale).element_sum() / 3.0;
            pixels += 1;
        }
        let known = |v: f64| v.is_finite() && v > 0.0;
        if pixels == 0 || !known(training) || !known(rest) {
            return SplitWeights::EQUAL;
        }
        let n = pixels as f64;
        SplitWeights(Some((n / training, n / rest)))
    }

    /// Made from the two per-sample variances directly.
    #[cfg(test)]
    fn from_variances(training: f64, rest: f64) -> SplitWeights {
        SplitWeights(Some((1.0 / training, 1.0 / rest)))
    }

    /// The weight of the training mean in pixel `p`'s estimate, with both kinds'
    /// moments (training's are `t`); `None` where the pixel has one kind only, or the
    /// weights are equal.
    fn split(&self, p: &PixelSums, t: &Moments) -> Option<(f64, Moments, Moments)> {
        let (inv_training, inv_rest) = self.0?;
        let (t, f) = (*t, p.moments_without(t));
        if t.kept == 0 || f.kept == 0 {
            return None;
        }
        let a = f64::from(t.kept) * inv_training;
        let b = f64::from(f.kept) * inv_rest;
        Some((a / (a + b), t, f))
    }

    /// The estimate of pixel `p`, whose training samples' moments are `t`: its two
    /// means weighed.
    pub fn mean(&self, p: &PixelSums, t: &Moments) -> DVec3 {
        match self.split(p, t) {
            Some((w, t, f)) => t.mean() * w + f.mean() * (1.0 - w),
            None => p.mean(),
        }
    }

    /// The estimated variance of [`mean`](Self::mean) per channel: each kind's sample
    /// variance over its count, times its weight squared. A kind with a single sample
    /// in this pixel takes the sample variance of all the pixel's samples.
    pub fn variance_of_mean(&self, p: &PixelSums, t: &Moments) -> DVec3 {
        let Some((w, t, f)) = self.split(p, t) else {
            return p.variance_of_mean();
        };
        let Some(pooled) = p.moments().sample_variance() else {
            return DVec3::INFINITY;
        };
        let of = |m: Moments| m.sample_variance().unwrap_or(pooled) / f64::from(m.kept);
        of(t) * (w * w) + of(f) * ((1.0 - w) * (1.0 - w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Sample;
    use glam::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg32;

    /// A film of `pixels` pixels, each with truth `μ = 1 + i mod 7`, `n_t` training
    /// samples and `n_f` final ones, each the truth times `1 + σ·z` for `z` uniform of
    /// variance 1: relative variances `σ_t²` and `σ_f²`.
    fn film(pixels: u32, (n_t, sigma_t): (u32, f32), (n_f, sigma_f): (u32, f32)) -> Film {
        let mut film = Film::new(pixels, 1, 0..n_t + n_f);
        let mut rng = Pcg32::seed_from_u64(7);
        film.training = vec![Moments::default(); pixels as usize];
        for (i, (p, t)) in film.pixels.iter_mut().zip(&mut film.training).enumerate() {
            let truth = 1.0 + (i % 7) as f32;
            let mut draw = |sigma: f32| Sample {
                radiance: Vec3::splat(
                    truth * (1.0 + sigma * 12f32.sqrt() * (rng.random::<f32>() - 0.5)),
                ),
                ..Sample::default()
            };
            for _ in 0..n_t {
                p.add_training(&draw(sigma_t), t);
            }
            for _ in 0..n_f {
                p.add(&draw(sigma_f));
            }
        }
        film
    }

    /// Mean over the pixels of (estimate − truth)² / truth², and of the estimated
    /// variance of the estimate over truth².
    fn errors(film: &Film, weights: &SplitWeights) -> (f64, f64) {
        let (mut err, mut est) = (0.0, 0.0);
        for (i, (p, t)) in film.pixels.iter().zip(&film.training).enumerate() {
            let truth = 1.0 + (i % 7) as f64;
            err += ((weights.mean(p, t).x - truth) / truth).powi(2);
            est += weights.variance_of_mean(p, t).x / (truth * truth);
        }
        let n = film.pixels.len() as f64;
        (err / n, est / n)
    }

    #[test]
    fn a_film_without_training_is_its_plain_mean() {
        let mut film = film(500, (0, 0.0), (9, 0.5));
        assert_eq!(SplitWeights::of(&film), SplitWeights::EQUAL);
        film.training.clear();
        assert_eq!(SplitWeights::of(&film), SplitWeights::EQUAL);
        let image = film.resolve();
        for (out, p) in image.pixels.iter().zip(&film.pixels) {
            assert_eq!(*out, p.mean().as_vec3());
        }
    }

    #[test]
    fn each_kinds_variance_is_estimated() {
        let film = film(20_000, (7, 3.0), (24, 0.5));
        let SplitWeights(Some((inv_t, inv_f))) = SplitWeights::of(&film) else {
            panic!("weights expected");
        };
        // 1/σ²: 1/9 and 4, to within the noise of the estimates.
        assert!((inv_t * 9.0 - 1.0).abs() < 0.1, "1/v_t {inv_t}");
        assert!((inv_f / 4.0 - 1.0).abs() < 0.1, "1/v_f {inv_f}");
    }

    #[test]
    fn weighed_means_have_the_least_variance() {
        let film = film(20_000, (7, 3.0), (24, 0.5));
        // The minimum variance of two unbiased means weighed by their inverse
        // variances, 1/(7/9 + 24/0.25), against every sample weighing the same,
        // (7·9 + 24·0.25)/31².
        let least = 1.0 / (7.0 / 9.0 + 24.0 / 0.25);
        let equal = (7.0 * 9.0 + 24.0 * 0.25) / (31.0 * 31.0);
        let within_10_percent = |what: &str, found: f64, expected: f64| {
            let off = found / expected - 1.0;
            assert!(off.abs() < 0.1, "{what}: {found} against {expected}");
        };
        let (weighed, estimated) = errors(&film, &SplitWeights::of(&film));
        within_10_percent("weighed", weighed, least);
        within_10_percent("weighed, estimated", estimated, least);
        let (plain, estimated) = errors(&film, &SplitWeights::EQUAL);
        within_10_percent("equal", plain, equal);
        within_10_percent("equal, estimated", estimated, equal);
        // And the image is the weighed one.
        let image = film.resolve();
        let weights = SplitWeights::of(&film);
        for ((out, p), t) in image.pixels.iter().zip(&film.pixels).zip(&film.training) {
            assert_eq!(*out, weights.mean(p, t).as_vec3());
        }
    }

    #[test]
    fn a_pixel_with_one_kind_takes_its_plain_mean() {
        let mut film = film(2000, (3, 1.0), (5, 1.0));
        let weights = SplitWeights::from_variances(1.0, 0.01);
        let (mut only_training, mut t) = (PixelSums::default(), Moments::default());
        for l in [1.0, 2.0, 4.0] {
            let sample = Sample {
                radiance: Vec3::splat(l),
                ..Sample::default()
            };
            only_training.add_training(&sample, &mut t);
        }
        assert_eq!(weights.mean(&only_training, &t), only_training.mean());
        (film.pixels[0], film.training[0]) = (only_training, t);
        assert_eq!(film.resolve().pixels[0], Vec3::splat(7.0 / 3.0));
    }
}
