//! Adaptive sampling: after each pass, a pixel goes on only while its estimated
//! relative error ([`PixelSums::relative_error`], the error `ember compare`'s relMSE
//! weighs) is above the threshold.
//!
//! A pixel's own estimate is unreliable while it has few samples: a pixel whose few
//! paths all missed a small light looks noiseless. So a pixel is stopped only when
//! it has `min_spp` samples and every pixel of its 5×5 neighbourhood (in the whole
//! image, across tiles) is below the threshold too: the neighbours rarely all miss
//! the same light by the same luck. The decision depends only on the film after a
//! pass, so it is the same at any thread count and after a resume.
//!
//! Stopping on a pixel's own samples is not quite unbiased: a pixel stops a little
//! more often when its samples happen to be low; the bias is small and falls with T
//! and with `min_spp` (benches/results/2026-12-01-time-to-a-clean-image.md).

use crate::film::PixelSums;

/// How far (in pixels, each way) a pixel's neighbourhood reaches.
const NEIGHBOURHOOD_RADIUS: usize = 2;

/// `--noise-threshold` and `--min-spp`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// Largest relative error (standard error over `sqrt(mean² + 0.01)`, the RMS of
    /// the channels) at which a pixel stops.
    pub threshold: f32,
    /// Samples of the film's range a pixel takes before it may stop.
    pub min_spp: u32,
}

impl Adaptive {
    /// The default `--min-spp`: enough samples for a variance estimate to mean
    /// something, and never more than the render takes.
    pub fn default_min_spp(spp: u32) -> u32 {
        32.min(spp)
    }

    /// The threshold for one of `n` shards of a render that should reach `threshold`
    /// once merged: each shard holds about 1/n of the samples, so its error may be √n
    /// times as large (the merged variance is the n shards' mean variance over n).
    pub fn for_shard_of(self, n: u32) -> Adaptive {
        Adaptive {
            threshold: self.threshold * (n as f32).sqrt(),
            ..self
        }
    }
}

/// Which pixels of a `width × height` image (row by row) lie in a calm neighbourhood:
/// `error` (each pixel's [`PixelSums::relative_error`], 0 for a pixel already
/// stopped) is at most `threshold` everywhere in their 5×5 window.
pub fn calm(error: &[f64], width: u32, height: u32, threshold: f32) -> Vec<bool> {
    let (w, h) = (width as usize, height as usize);
    let r = NEIGHBOURHOOD_RADIUS;
    // The largest error in each row's windows, then over the window's rows.
    let mut across = vec![0.0f64; w * h];
    for y in 0..h {
        for x in 0..w {
            let row = &error[y * w + x.saturating_sub(r)..y * w + (x + r + 1).min(w)];
            across[y * w + x] = row.iter().copied().fold(0.0, f64::max);
        }
    }
    let threshold = f64::from(threshold);
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let worst = (y.saturating_sub(r)..(y + r + 1).min(h))
                .map(|yy| across[yy * w + x])
                .fold(0.0, f64::max);
            worst <= threshold
        })
        .collect()
}

impl Adaptive {
    /// Whether a pixel may stop, given whether its neighbourhood is calm.
    pub fn may_stop(&self, p: &PixelSums, calm: bool) -> bool {
        p.converged || (calm && p.done >= self.min_spp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// A pixel of `n` samples: half of value `a`, half `b` (its variance known).
    fn pixel(n: u32, a: f64, b: f64) -> PixelSums {
        let (h, k) = (f64::from(n / 2), f64::from(n - n / 2));
        PixelSums {
            radiance: DVec3::splat(h * a + k * b),
            radiance_sq: DVec3::splat(h * a * a + k * b * b),
            kept: n,
            done: n,
            ..PixelSums::default()
        }
    }

    #[test]
    fn relative_error_of_a_known_pixel() {
        // 16 samples of 0 and 2: mean 1, sample variance 16/15, over 16: 1/15.
        let p = pixel(16, 0.0, 2.0);
        let expected = (1.0f64 / 15.0 / 1.01).sqrt();
        assert!((p.relative_error() - expected).abs() < 1e-12);
        assert!(pixel(1, 1.0, 1.0).relative_error().is_infinite());
    }

    #[test]
    fn a_noisy_neighbour_keeps_a_pixel_going() {
        let adaptive = Adaptive {
            threshold: 0.05,
            min_spp: 8,
        };
        let (w, h) = (9, 7);
        let mut pixels = vec![pixel(64, 1.0, 1.0); w * h];
        pixels[2 * w + 3] = pixel(64, 0.0, 2.0); // error ≈ 0.124
        let error: Vec<f64> = pixels.iter().map(PixelSums::relative_error).collect();
        let stop = calm(&error, w as u32, h as u32, adaptive.threshold);
        for y in 0..h {
            for x in 0..w {
                let near = (x as i32 - 3).abs() <= 2 && (y as i32 - 2).abs() <= 2;
                assert_eq!(stop[y * w + x], !near, "pixel ({x}, {y})");
            }
        }
        // Below min_spp nothing stops, however calm; a stopped pixel stays stopped.
        assert!(!adaptive.may_stop(&pixel(4, 1.0, 1.0), true));
        assert!(adaptive.may_stop(&pixel(8, 1.0, 1.0), true));
        assert!(!adaptive.may_stop(&pixel(64, 1.0, 1.0), false));
        let stopped = PixelSums {
            converged: true,
            ..pixel(2, 1.0, 1.0)
        };
        assert!(adaptive.may_stop(&stopped, false));
    }
}
