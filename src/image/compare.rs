//! How far an image is from a reference: MSE, relative MSE and PSNR over all pixels
//! and channels of linear RGB (the metrics of `shared/references/cornell-box/README.md`).

use super::Image;

/// Error of a test image against a reference of the same size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// `mean((a − b)²)`.
    pub mse: f64,
    /// `mean((a − b)² / (b² + 0.01))`: noise relative to brightness, so dark and bright
    /// regions weigh alike.
    pub rel_mse: f64,
    /// `10 · log10(1 / MSE)`, peak 1.0 on linear values (infinite for equal images).
    pub psnr: f64,
}

/// The two images differ in size, so they cannot be compared pixel by pixel.
#[derive(Debug, thiserror::Error)]
#[error("images differ in size: {a_width}x{a_height} against reference {b_width}x{b_height}")]
pub struct SizeMismatch {
    pub a_width: u32,
    pub a_height: u32,
    pub b_width: u32,
    pub b_height: u32,
}

/// Compares `image` against `reference`.
pub fn compare(image: &Image, reference: &Image) -> Result<ImageError, SizeMismatch> {
    if (image.width, image.height) != (reference.width, reference.height)
        || image.pixels.len() != reference.pixels.len()
    {
        return Err(SizeMismatch {
            a_width: image.width,
            a_height: image.height,
            b_width: reference.width,
            b_height: reference.height,
        });
    }
    Ok(compare_pixels(
        image
            .pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(a, b)| (*a, *b)),
    ))
}

/// The metrics over any set of (test, reference) pixel pairs, e.g. a subset of an image.
pub fn compare_pixels(pairs: impl Iterator<Item = (glam::Vec3, glam::Vec3)>) -> ImageError {
    let (mut se, mut rel, mut n) = (0.0f64, 0.0f64, 0u64);
    for (a, b) in pairs {
        for (a, b) in a.to_array().into_iter().zip(b.to_array()) {
            let (a, b) = (f64::from(a), f64::from(b));
            let d2 = (a - b) * (a - b);
            se += d2;
            rel += d2 / (b * b + 0.01);
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    let mse = se / n;
    ImageError {
        mse,
        rel_mse: rel / n,
        psnr: 10.0 * (1.0 / mse).log10(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn metrics_of_a_known_difference() {
        let mut a = Image::new(2, 1);
        let mut b = Image::new(2, 1);
        b.pixels = vec![Vec3::splat(0.1), Vec3::splat(0.3)];
        a.pixels = vec![Vec3::splat(0.2), Vec3::splat(0.3)];
        let e = compare(&a, &b).unwrap();
        // One of two pixels off by 0.1 in every channel.
        assert!((e.mse - 0.005).abs() < 1e-9);
        assert!((e.rel_mse - 0.5 * 0.01 / (0.01 + 0.01)).abs() < 1e-6);
        assert!((e.psnr - 10.0 * (200.0f64).log10()).abs() < 1e-6);
        assert!(compare(&Image::new(2, 2), &b).is_err());
    }
}
