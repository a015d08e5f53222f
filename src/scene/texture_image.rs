//! Texture images as materials read them: colour maps (`map_Kd`, `map_Ks`, `map_Ke`)
//! and data maps (`bump`, `norm`, `map_Pr`, `map_Pm`, `map_Ns`), looked up by their
//! [`Sampler`]: repeating, clamped or mirrored, bilinear or nearest.
//!
//! Texels keep the precision of their file. 8-bit images stay 8-bit (3 bytes per RGB
//! texel, 1 per single-channel one, instead of 12 as `f32` RGB): colour maps are
//! decoded from sRGB through a 256-entry table at lookup, data maps are read as
//! `value / 255` (linear: a normal or a roughness is not a colour). Only
//! floating-point images (EXR, HDR) and 16-bit ones keep `f32` texels, already linear.
//! Filtering happens after decoding, so a colour map filters linear radiometric values.

use std::sync::LazyLock;

use glam::{Vec2, Vec3};
use image::{ColorType, DynamicImage};

use super::texture_sampler::{Filter, Footprint, Sampler};
use crate::image::srgb_to_linear;

/// How a texture's stored values become the numbers a material reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TextureKind {
    /// RGB colour: 8- and 16-bit values are sRGB-encoded (`map_Kd`, `map_Ks`, `map_Ke`).
    Colour,
    /// RGB data, linear (`norm`).
    Vector,
    /// One linear channel: the image's luminance (`bump`, `map_Pr`, `map_Pm`, `map_Ns`).
    Scalar,
}

/// The texels of a [`Texture`], row 0 at the top as in the image file.
#[derive(Clone, Debug, PartialEq)]
pub enum Texels {
    /// 8-bit sRGB-encoded colour, 3 bytes per texel (the decoder's buffer, kept as is).
    Srgb8(Vec<u8>),
    /// 8-bit linear RGB data, 3 bytes per texel.
    Rgb8(Vec<u8>),
    /// 8-bit single channel (linear).
    Gray8(Vec<u8>),
    /// Linear RGB.
    RgbF32(Vec<Vec3>),
    /// Linear single channel.
    GrayF32(Vec<f32>),
}

/// A texture image and its lookup.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub texels: Texels,
    /// How lookups wrap and filter (MTL's maps repeat, bilinearly; a glTF texture's
    /// sampler says).
    pub sampler: Sampler,
}

/// sRGB 8-bit code → linear value, for every code.
static SRGB8_TO_LINEAR: LazyLock<[f32; 256]> =
    LazyLock::new(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)));

/// Texel `i` of 8-bit sRGB colour, decoded through `table`.
#[inline(always)]
fn srgb8(table: &[f32; 256], t: &[u8], i: usize) -> Vec3 {
    let [r, g, b] = [t[3 * i], t[3 * i + 1], t[3 * i + 2]];
    Vec3::new(table[r as usize], table[g as usize], table[b as usize])
}

/// Texel `i` of 8-bit linear RGB data.
#[inline(always)]
fn rgb8(t: &[u8], i: usize) -> Vec3 {
    let [r, g, b] = [t[3 * i], t[3 * i + 1], t[3 * i + 2]];
    Vec3::new(r.into(), g.into(), b.into()) / 255.0
}

/// Texel `i` of an 8-bit single channel, in x, y and z.
#[inline(always)]
fn gray8(t: &[u8], i: usize) -> Vec3 {
    Vec3::splat(f32::from(t[i]) / 255.0)
}

/// The bilinear weighted sum of the four texels of `f`, read by `texel(index)`.
#[inline(always)]
fn bilinear(f: &Footprint, texel: impl Fn(usize) -> Vec3) -> Vec3 {
    let (fx, fy) = (f.fx, f.fy);
    let weight = [
        (1.0 - fx) * (1.0 - fy),
        fx * (1.0 - fy),
        (1.0 - fx) * fy,
        fx * fy,
    ];
    let mut sum = Vec3::ZERO;
    for (w, &i) in weight.iter().zip(&f.index) {
        sum += *w * texel(i);
    }
    sum
}

impl Texture {
    /// An RGB texture of linear colour, `width × height` texels (row 0 at the top).
    pub fn from_linear(width: u32, height: u32, texels: Vec<Vec3>) -> Texture {
        assert_eq!(texels.len(), width as usize * height as usize);
        Texture {
            width,
            height,
            texels: Texels::RgbF32(texels),
            sampler: Sampler::default(),
        }
    }

    /// Keeps a decoded image as `kind` asks, in the fewest bytes that lose nothing.
    pub fn from_image(image: DynamicImage, kind: TextureKind) -> Texture {
        let (width, height) = (image.width(), image.height());
        let eight_bit = matches!(
            image.color(),
            ColorType::L8 | ColorType::La8 | ColorType::Rgb8 | ColorType::Rgba8
        );
        let floating = matches!(image.color(), ColorType::Rgb32F | ColorType::Rgba32F);
        let rgb8 = |image: DynamicImage| image.into_rgb8().into_raw();
        let texels = match kind {
            TextureKind::Scalar if eight_bit => Texels::Gray8(image.into_luma8().into_raw()),
            TextureKind::Scalar => Texels::GrayF32(image.to_luma32f().into_raw()),
            TextureKind::Colour if eight_bit => Texels::Srgb8(rgb8(image)),
            TextureKind::Vector if eight_bit => Texels::Rgb8(rgb8(image)),
            TextureKind::Colour | TextureKind::Vector => {
                // Floating-point files hold linear values; 16-bit colour is sRGB.
                let decode = kind == TextureKind::Colour && !floating;
                let rgb = image.into_rgb32f();
                let value = |c: f32| if decode { srgb_to_linear(c) } else { c };
                Texels::RgbF32(
                    rgb.pixels()
                        .map(|p| Vec3::new(value(p[0]), value(p[1]), value(p[2])))
                        .collect(),
                )
            }
        };
        Texture {
            width,
            height,
            texels,
            sampler: Sampler::default(),
        }
    }

    /// Bytes the texels take.
    pub fn texel_bytes(&self) -> usize {
        match &self.texels {
            Texels::Srgb8(t) | Texels::Rgb8(t) | Texels::Gray8(t) => t.len(),
            Texels::RgbF32(t) => 12 * t.len(),
            Texels::GrayF32(t) => 4 * t.len(),
        }
    }

    /// The value of texel `i` (row-major); single channels are repeated in x, y and z.
    #[inline]
    pub fn texel(&self, i: usize) -> Vec3 {
        match &self.texels {
            Texels::Srgb8(t) => srgb8(&SRGB8_TO_LINEAR, t, i),
            Texels::Rgb8(t) => rgb8(t, i),
            Texels::Gray8(t) => gray8(t, i),
            Texels::RgbF32(t) => t[i],
            Texels::GrayF32(t) => Vec3::splat(t[i]),
        }
    }

    /// The value at `uv`, wrapped and filtered as the sampler says; `(0, 0)` is the
    /// bottom-left of the image (OBJ convention). 0 where `uv` is not finite.
    #[inline]
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        // One dispatch on the storage per lookup rather than per texel (`texel`): the
        // match and the table's lazy initialisation check leave the four fetches
        // (staircase, 1 thread: 3-4% faster).
        match &self.texels {
            Texels::Srgb8(t) => {
                let table = &*SRGB8_TO_LINEAR;
                self.lookup(uv, |i| srgb8(table, t, i))
            }
            Texels::Rgb8(t) => self.lookup(uv, |i| rgb8(t, i)),
            Texels::Gray8(t) => self.lookup(uv, |i| gray8(t, i)),
            Texels::RgbF32(t) => self.lookup(uv, |i| t[i]),
            Texels::GrayF32(t) => self.lookup(uv, |i| Vec3::splat(t[i])),
        }
    }

    /// The sampler's lookup at `uv` of the texels `texel(index)` reads.
    #[inline(always)]
    fn lookup(&self, uv: Vec2, texel: impl Fn(usize) -> Vec3) -> Vec3 {
        let (w, h, s) = (self.width, self.height, self.sampler);
        match s.filter {
            Filter::Bilinear => s.footprint(uv, w, h).map(|f| bilinear(&f, texel)),
            Filter::Nearest => s.nearest(uv, w, h).map(texel),
        }
        .unwrap_or(Vec3::ZERO)
    }

    /// The value of a single-channel texture at `uv` (the first channel of others).
    #[inline]
    pub fn sample_scalar(&self, uv: Vec2) -> f32 {
        self.sample(uv).x
    }

    /// The mean over all texels.
    pub fn mean(&self) -> Vec3 {
        let n = self.width as usize * self.height as usize;
        let sum: glam::DVec3 = (0..n).map(|i| self.texel(i).as_dvec3()).sum();
        (sum / n.max(1) as f64).as_vec3()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{GrayImage, Luma, Rgb, RgbImage};

    #[test]
    fn eight_bit_colour_is_decoded_from_srgb_and_data_is_not() {
        let rgb = DynamicImage::ImageRgb8(RgbImage::from_pixel(1, 1, Rgb([0, 128, 255])));
        let colour = Texture::from_image(rgb.clone(), TextureKind::Colour);
        assert_eq!(colour.texel_bytes(), 3);
        let c = colour.sample(Vec2::splat(0.5));
        // The sRGB curve, from its definition.
        let expected = ((128.0f32 / 255.0 + 0.055) / 1.055).powf(2.4);
        assert_eq!(c.x, 0.0);
        assert!(
            (c.y - expected).abs() < 1e-6 && (c.z - 1.0).abs() < 1e-6,
            "{c}"
        );
        let data = Texture::from_image(rgb, TextureKind::Vector);
        assert!((data.sample(Vec2::splat(0.5)).y - 128.0 / 255.0).abs() < 1e-6);
        let grey = DynamicImage::ImageLuma8(GrayImage::from_pixel(1, 1, Luma([51])));
        let scalar = Texture::from_image(grey, TextureKind::Scalar);
        assert_eq!(scalar.texel_bytes(), 1);
        assert!((scalar.sample_scalar(Vec2::splat(0.3)) - 0.2).abs() < 1e-6);
    }

    #[test]
    fn floating_point_images_stay_linear() {
        let mut img = image::Rgb32FImage::new(1, 1);
        img.put_pixel(0, 0, Rgb([0.5, 2.0, 0.25]));
        let t = Texture::from_image(DynamicImage::ImageRgb32F(img), TextureKind::Colour);
        assert_eq!(t.sample(Vec2::splat(0.5)), Vec3::new(0.5, 2.0, 0.25));
    }

    #[test]
    fn bilinear_between_texel_centres_with_wrapping() {
        let t = Texture {
            width: 2,
            height: 1,
            texels: Texels::Gray8(vec![0, 255]),
            sampler: Sampler::default(),
        };
        assert_eq!(t.sample_scalar(Vec2::new(0.25, 0.5)), 0.0);
        assert_eq!(t.sample_scalar(Vec2::new(0.75, 0.5)), 1.0);
        assert!((t.sample_scalar(Vec2::new(0.5, 0.5)) - 0.5).abs() < 1e-6);
        // Across the seam: halfway between the last and the first texel.
        assert!((t.sample_scalar(Vec2::new(1.0, 0.5)) - 0.5).abs() < 1e-6);
        assert_eq!(t.sample_scalar(Vec2::new(-1.25, 7.5)), 1.0);
    }
}
