//! Reading image files strictly: a truncated or corrupt file of any format is an error,
//! never an image with a part made up. Every image ember reads (textures, environment
//! maps, `ember compare`) comes through [`decode_file`].
//!
//! The `image` crate refuses truncated PNG, TGA, BMP, EXR and HDR files, but decodes
//! JPEG with zune-jpeg in lenient mode, which fills whatever is missing with grey (as
//! browsers do). JPEG is therefore decoded here with zune-jpeg in strict mode, which
//! reports a stream that ends before its last MCU ("Premature end of buffer") or holds
//! markers where none belong.

use std::path::Path;

use ::image::{DynamicImage, ImageBuffer, ImageFormat};
use zune_core::bytestream::ZCursor;
use zune_core::colorspace::ColorSpace;
use zune_core::options::DecoderOptions;

/// Decodes the image file at `path` (its format guessed from its bytes), refusing
/// damaged files and images whose pixels would not fit in memory. The error is the
/// reason alone: the caller names the file.
pub fn decode_file(path: &Path) -> Result<DynamicImage, String> {
    let reader = ::image::ImageReader::open(path)
        .map_err(one_line)?
        .with_guessed_format()
        .map_err(one_line)?;
    if reader.format() == Some(ImageFormat::Jpeg) {
        let bytes = std::fs::read(path).map_err(one_line)?;
        return decode_jpeg(&bytes);
    }
    reader.decode().map_err(one_line)
}

/// A decoder's message on one line (some span several).
fn one_line(e: impl std::fmt::Display) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// A JPEG stream, decoded strictly to 8-bit grey, grey and alpha, RGB or RGBA (the
/// channels the `image` crate would give it; CMYK and YCCK become RGB).
pub fn decode_jpeg(bytes: &[u8]) -> Result<DynamicImage, String> {
    let options = DecoderOptions::default()
        .set_strict_mode(true)
        .set_max_width(usize::from(u16::MAX))
        .set_max_height(usize::from(u16::MAX));
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    let jpeg = |e| format!("corrupt or truncated JPEG: {}", one_line(e));
    decoder.decode_headers().map_err(jpeg)?;
    let (width, height) = decoder.dimensions().ok_or("JPEG without dimensions")?;
    let colours = match decoder.input_colorspace() {
        Some(c @ (ColorSpace::Luma | ColorSpace::LumaA | ColorSpace::RGBA)) => c,
        _ => ColorSpace::RGB,
    };
    decoder.set_options(decoder.options().jpeg_set_out_colorspace(colours));
    // Dimensions are at most 65535 each: the product cannot overflow a u64.
    let bytes_needed = width as u64 * height as u64 * colours.num_components() as u64;
    crate::limits::check_fits(&format!("a {width}x{height} JPEG"), bytes_needed)?;
    let pixels = decoder.decode().map_err(jpeg)?;
    let (w, h) = (width as u32, height as u32);
    let image = match colours {
        ColorSpace::Luma => ImageBuffer::from_raw(w, h, pixels).map(DynamicImage::ImageLuma8),
        ColorSpace::LumaA => ImageBuffer::from_raw(w, h, pixels).map(DynamicImage::ImageLumaA8),
        ColorSpace::RGBA => ImageBuffer::from_raw(w, h, pixels).map(DynamicImage::ImageRgba8),
        _ => ImageBuffer::from_raw(w, h, pixels).map(DynamicImage::ImageRgb8),
    };
    image.ok_or_else(|| "JPEG decoder returned fewer pixels than its size".into())
}
