//! How far an image is from a reference: MSE, relative MSE and PSNR over all pixels
//! and channels of linear RGB (the metrics of the Cornell references' README).

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

/// `image` averaged over blocks of `factor × factor` pixels: a render at `factor` times
/// a reference's width and height, brought to the reference's size, is a render at that
/// size with `factor²` times the samples (the blocks are the reference's pixels), so a
/// large render can be judged against a smaller reference. `None` when the size is not
/// a multiple of `factor` (or `factor` is 0).
pub fn downsampled(image: &Image, factor: u32) -> Option<Image> {
    if factor == 0 || !image.width.is_multiple_of(factor) || !image.height.is_multiple_of(factor) {
        return None;
    }
    let (width, height) = (image.width / factor, image.height / factor);
    let mut out = Image::new(width, height);
    let weight = 1.0 / f64::from(factor * factor);
    for (i, pixel) in out.pixels.iter_mut().enumerate() {
        let (x, y) = (i as u32 % width, i as u32 / width);
        let mut sum = glam::DVec3::ZERO;
        for row in y * factor..(y + 1) * factor {
            let start = (row * image.width + x * factor) as usize;
            for p in &image.pixels[start..start + factor as usize] {
                sum += p.as_dvec3();
            }
        }
        *pixel = (sum * weight).as_vec3();
    }
    Some(out)
}

/// A rectangle of pixels: its top-left corner (column `x`, row `y`, row 0 at the top)
/// and size, as `ember compare --crop x,y,w,h` reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crop {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

impl std::str::FromStr for Crop {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let numbers: Vec<u32> = s
            .split(',')
            .map(|n| n.trim().parse::<u32>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("{s:?} is not x,y,w,h (four whole numbers)"))?;
        let [x, y, width, height] = numbers[..] else {
            return Err(format!("{s:?} is not x,y,w,h (four whole numbers)"));
        };
        if width == 0 || height == 0 {
            return Err(format!("{s:?} is an empty rectangle"));
        }
        Ok(Crop {
            x,
            y,
            width,
            height,
        })
    }
}

/// The crop does not lie inside the images.
#[derive(Debug, thiserror::Error)]
pub enum CropError {
    #[error(transparent)]
    Size(#[from] SizeMismatch),
    #[error("crop {}x{} at ({}, {}) reaches outside the {width}x{height} image", .crop.width, .crop.height, .crop.x, .crop.y)]
    Outside { crop: Crop, width: u32, height: u32 },
}

/// Compares the pixels of `image` inside `crop` against those of `reference`.
pub fn compare_crop(image: &Image, reference: &Image, crop: Crop) -> Result<ImageError, CropError> {
    compare(image, reference)?;
    let (width, height) = (image.width, image.height);
    let inside = u64::from(crop.x) + u64::from(crop.width) <= u64::from(width)
        && u64::from(crop.y) + u64::from(crop.height) <= u64::from(height);
    if !inside {
        return Err(CropError::Outside {
            crop,
            width,
            height,
        });
    }
    let pixel = |row: u32, column: u32| (row * width + column) as usize;
    Ok(compare_pixels((crop.y..crop.y + crop.height).flat_map(
        |row| {
            (crop.x..crop.x + crop.width).map(move |column| {
                (
                    image.pixels[pixel(row, column)],
                    reference.pixels[pixel(row, column)],
                )
            })
        },
    )))
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
    /// Blocks average exactly (a 4×2 image of known values to 2×1), and sizes that are
    /// not multiples are refused.
    #[test]
    fn downsampling_averages_blocks() {
        let mut image = Image::new(4, 2);
        for (i, p) in image.pixels.iter_mut().enumerate() {
            *p = Vec3::splat(i as f32);
        }
        let small = downsampled(&image, 2).expect("4x2 by 2");
        assert_eq!((small.width, small.height), (2, 1));
        // Pixels 0, 1, 4, 5 and 2, 3, 6, 7.
        assert_eq!(small.pixels, vec![Vec3::splat(2.5), Vec3::splat(4.5)]);
        assert_eq!(
            downsampled(&image, 1).expect("same size").pixels,
            image.pixels
        );
        assert!(downsampled(&image, 3).is_none());
        assert!(downsampled(&image, 0).is_none());
    }

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

    #[test]
    fn a_crop_counts_only_its_pixels() {
        // 3x2 images differing only in the pixel at column 2, row 1.
        let reference = Image {
            width: 3,
            height: 2,
            pixels: vec![Vec3::splat(0.5); 6],
        };
        let mut image = reference.clone();
        image.pixels[3 + 2] = Vec3::splat(0.7);
        let crop = |s: &str| s.parse::<Crop>().unwrap();
        let error = |c: &str| compare_crop(&image, &reference, crop(c)).unwrap();
        // The whole image as a crop is the whole comparison.
        assert_eq!(error("0,0,3,2"), compare(&image, &reference).unwrap());
        // Only the differing pixel: MSE 0.2² in every channel.
        assert!((error("2,1,1,1").mse - 0.04).abs() < 1e-6);
        // The two pixels of the right column: half that.
        assert!((error("2,0,1,2").mse - 0.02).abs() < 1e-6);
        assert_eq!(error("0,0,2,2").mse, 0.0);
        assert!(compare_crop(&image, &reference, crop("2,1,2,1")).is_err());
        assert!(compare_crop(&image, &reference, crop("0,2,1,1")).is_err());
        for bad in ["1,2,3", "1,2,3,4,5", "a,b,c,d", "0,0,0,1", "-1,0,1,1"] {
            assert!(bad.parse::<Crop>().is_err(), "{bad}");
        }
    }
}
