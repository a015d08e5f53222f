//! Opacity maps: one 8-bit plane per texture (0 transparent, 255 opaque), a twelfth of
//! an RGB [`super::Texture`]'s memory, looked up like one (by its [`Sampler`]). They come
//! from the alpha channel of a `map_Kd` or `map_d` image, or from the luminance of a
//! `map_d` image without one. Opacity is data, not colour: nothing is sRGB-decoded.

use glam::Vec2;
use image::DynamicImage;

use super::texture_sampler::{Filter, Sampler};

#[derive(Clone, Debug, PartialEq)]
pub struct AlphaMap {
    pub width: u32,
    pub height: u32,
    /// Row 0 at the top, as in the image file.
    pub texels: Vec<u8>,
    /// The sampler of the texture it comes from.
    pub sampler: Sampler,
}

impl AlphaMap {
    /// The alpha channel of `image`, or `None` when it has none or it is opaque
    /// everywhere (so that an RGBA `map_Kd` with a solid alpha costs nothing).
    pub fn from_alpha_channel(image: &DynamicImage) -> Option<AlphaMap> {
        if !image.color().has_alpha() {
            return None;
        }
        let rgba = image.to_rgba8();
        let texels: Vec<u8> = rgba.pixels().map(|p| p[3]).collect();
        texels.iter().any(|&a| a < u8::MAX).then_some(AlphaMap {
            width: rgba.width(),
            height: rgba.height(),
            texels,
            sampler: Sampler::default(),
        })
    }

    /// A `map_d` image: its alpha channel where it has one, else its luminance (the
    /// stored values, linear; Rec. 709 weights).
    pub fn from_opacity_image(image: &DynamicImage) -> AlphaMap {
        if image.color().has_alpha() {
            let rgba = image.to_rgba8();
            return AlphaMap {
                width: rgba.width(),
                height: rgba.height(),
                texels: rgba.pixels().map(|p| p[3]).collect(),
                sampler: Sampler::default(),
            };
        }
        let luma = image.to_luma8();
        AlphaMap {
            width: luma.width(),
            height: luma.height(),
            texels: luma.into_raw(),
            sampler: Sampler::default(),
        }
    }

    /// Whether every texel is fully opaque.
    pub fn is_opaque(&self) -> bool {
        self.texels.iter().all(|&a| a == u8::MAX)
    }

    /// The opacity in `[0, 1]` at `uv`; `(0, 0)` is the bottom-left of the image (OBJ
    /// convention), as for colour textures. 1 where `uv` is not finite.
    #[inline]
    pub fn sample(&self, uv: Vec2) -> f32 {
        let (w, h, s) = (self.width, self.height, self.sampler);
        let texel = |i: usize| f32::from(self.texels[i]);
        let value = match s.filter {
            Filter::Bilinear => s.footprint(uv, w, h).map(|f| {
                let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
                let [tl, tr, bl, br] = f.index.map(texel);
                lerp(lerp(tl, tr, f.fx), lerp(bl, br, f.fx), f.fy)
            }),
            Filter::Nearest => s.nearest(uv, w, h).map(texel),
        };
        value.map_or(1.0, |v| v * (1.0 / 255.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{GrayImage, Luma, Rgba, RgbaImage};

    #[test]
    fn alpha_channel_or_luminance() {
        let mut rgba = RgbaImage::from_pixel(2, 1, Rgba([10, 20, 30, 255]));
        let opaque = DynamicImage::ImageRgba8(rgba.clone());
        assert!(AlphaMap::from_alpha_channel(&opaque).is_none());
        rgba.put_pixel(1, 0, Rgba([10, 20, 30, 0]));
        let cut = DynamicImage::ImageRgba8(rgba);
        assert_eq!(AlphaMap::from_alpha_channel(&cut).unwrap().texels, [255, 0]);
        assert_eq!(AlphaMap::from_opacity_image(&cut).texels, [255, 0]);
        // No alpha channel: the grey values themselves, not sRGB-decoded.
        let grey = DynamicImage::ImageLuma8(GrayImage::from_pixel(1, 1, Luma([128])));
        assert_eq!(AlphaMap::from_opacity_image(&grey).texels, [128]);
        assert!(AlphaMap::from_alpha_channel(&grey).is_none());
    }

    #[test]
    fn samples_texel_centres_and_wraps() {
        let map = AlphaMap {
            width: 2,
            height: 1,
            texels: vec![0, 255],
            sampler: Sampler::default(),
        };
        assert_eq!(map.sample(Vec2::new(0.25, 0.5)), 0.0);
        assert_eq!(map.sample(Vec2::new(0.75, 0.5)), 1.0);
        assert!((map.sample(Vec2::new(0.5, 0.5)) - 0.5).abs() < 1e-6);
        assert_eq!(map.sample(Vec2::new(1.75, -3.5)), 1.0);
    }
}
