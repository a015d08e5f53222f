//! Reading image files strictly: a truncated or corrupt file of any format is an error,
//! never an image with a part made up. Every image ember reads (textures, environment
//! maps, `ember compare`) comes through [`decode_file`].
//!
//! The `image` crate refuses truncated PNG, TGA, BMP, EXR and HDR files, but decodes
//! JPEG with zune-jpeg in lenient mode, which fills whatever is missing with grey (as
//! browsers do). JPEG is therefore decoded here with zune-jpeg in strict mode, which
//! reports a stream that ends before its last MCU ("Premature end of buffer") or holds
//! markers where none belong.

use std::io::Read;
use std::path::Path;

use ::image::{DynamicImage, ImageBuffer, ImageDecoder, ImageFormat, ImageReader, Limits};
use zune_core::bytestream::ZCursor;
use zune_core::colorspace::ColorSpace;
use zune_core::options::DecoderOptions;

use crate::io::InputFile;
use crate::limits::{available_memory, check_fits, human_bytes};

/// Decodes the image file at `path` (its format guessed from its bytes), refusing
/// damaged files and images whose decoding would not fit in memory. The error is the
/// reason alone: the caller names the file.
pub fn decode_file(path: &Path) -> Result<DynamicImage, String> {
    ImageFile::open(path)?.decode_within("image", 0)
}

/// What a decoder holds whatever the image's size: inflate windows, row buffers.
const DECODER_BYTES: u64 = 4 << 20;

/// An image file whose header has been read: its size is known, nothing is decoded.
pub struct ImageFile {
    pub width: u32,
    pub height: u32,
    /// Bytes of the decoder's output (the `DynamicImage`).
    decoded_bytes: u64,
    /// Bytes the decoder holds besides its output: a JPEG's whole file, an EXR's
    /// channels before they are interleaved.
    working_bytes: u64,
    source: Source,
}

enum Source {
    /// A JPEG's bytes, decoded strictly by zune-jpeg ([`decode_jpeg`]).
    Jpeg(Vec<u8>),
    Other(Box<dyn ImageDecoder>),
}

impl ImageFile {
    /// Opens the image file at `path` and reads its header.
    pub fn open(path: &Path) -> Result<ImageFile, String> {
        let input = InputFile::open(path).map_err(|e| e.reason)?;
        let file_bytes = input.len();
        // The extension first (TGA has no signature), then the bytes where they tell.
        let format = ImageFormat::from_path(path).ok();
        Self::from_reader(input.into_reader(), file_bytes, format)
    }

    /// An image held in memory (a glTF's embedded image), its format told by `format`
    /// (a MIME type's) or else guessed from its bytes.
    pub fn from_bytes(bytes: Vec<u8>, format: Option<ImageFormat>) -> Result<ImageFile, String> {
        let len = bytes.len() as u64;
        Self::from_reader(std::io::Cursor::new(bytes), len, format)
    }

    fn from_reader<R: std::io::BufRead + std::io::Seek + 'static>(
        source: R,
        file_bytes: u64,
        format: Option<ImageFormat>,
    ) -> Result<ImageFile, String> {
        let mut reader = ImageReader::new(source);
        if let Some(format) = format {
            reader.set_format(format);
        }
        let mut reader = reader.with_guessed_format().map_err(one_line)?;
        if reader.format() == Some(ImageFormat::Jpeg) {
            check_fits(
                &format!("a JPEG file of {}", human_bytes(file_bytes)),
                file_bytes,
            )?;
            let mut bytes = Vec::with_capacity(file_bytes as usize);
            reader
                .into_inner()
                .take(file_bytes)
                .read_to_end(&mut bytes)
                .map_err(one_line)?;
            let (width, height, colours) = jpeg_header(&bytes)?;
            let decoded_bytes =
                u64::from(width) * u64::from(height) * colours.num_components() as u64;
            // The file, and zune-jpeg's planes of components while it converts them.
            return Ok(ImageFile {
                width,
                height,
                decoded_bytes,
                working_bytes: file_bytes + decoded_bytes,
                source: Source::Jpeg(bytes),
            });
        }
        // The one memory limit bounds what the decoder allocates inside too (the
        // `image` crate's own default, 512 MiB, would refuse large maps that fit).
        let mut limits = Limits::no_limits();
        limits.max_alloc = available_memory();
        reader.limits(limits);
        let decoder = reader.into_decoder().map_err(one_line)?;
        let (width, height) = decoder.dimensions();
        let decoded_bytes = decoder.total_bytes();
        // The decoders hold about their output again while they work: the EXR
        // decoder every channel as its own f32 array before interleaving them, the
        // HDR decoder its RGBE texels, the PNG decoder its rows and inflate buffers
        // (measured by `tests/memory_estimates.rs`).
        let working_bytes = decoded_bytes;
        Ok(ImageFile {
            width,
            height,
            decoded_bytes,
            working_bytes,
            source: Source::Other(Box::new(decoder)),
        })
    }

    /// Bytes of memory decoding holds at its peak, with `extra_per_pixel` bytes per
    /// pixel that the caller makes from the image while it is held.
    pub fn memory_bytes(&self, extra_per_pixel: u64) -> u64 {
        let pixels = u64::from(self.width) * u64::from(self.height);
        DECODER_BYTES
            .saturating_add(self.decoded_bytes)
            .saturating_add(self.working_bytes)
            .saturating_add(pixels.saturating_mul(extra_per_pixel))
    }

    /// Decodes the image, after checking that it and `extra_per_pixel` bytes per pixel
    /// fit in the memory available; `what` the image is names it in the refusal.
    pub fn decode_within(self, what: &str, extra_per_pixel: u64) -> Result<DynamicImage, String> {
        check_fits(
            &format!("a {}x{} {what}", self.width, self.height),
            self.memory_bytes(extra_per_pixel),
        )?;
        self.decode()
    }

    /// Decodes the image (the caller has checked the memory).
    pub fn decode(self) -> Result<DynamicImage, String> {
        if self.width == 0 || self.height == 0 {
            return Err("image is empty".into());
        }
        match self.source {
            Source::Jpeg(bytes) => decode_jpeg(&bytes),
            Source::Other(decoder) => DynamicImage::from_decoder(decoder).map_err(one_line),
        }
    }
}

/// A decoder's message on one line (some span several).
fn one_line(e: impl std::fmt::Display) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// A JPEG's width, height and the colours it decodes to, from its header.
fn jpeg_header(bytes: &[u8]) -> Result<(u32, u32, ColorSpace), String> {
    let (_, width, height, colours) = jpeg_decoder(bytes)?;
    Ok((width as u32, height as u32, colours))
}

/// A JPEG decoder with its header read, the image's width and height, and the colours
/// it decodes to.
type JpegHeader<'b> = (
    zune_jpeg::JpegDecoder<ZCursor<&'b [u8]>>,
    usize,
    usize,
    ColorSpace,
);

/// A strict zune-jpeg decoder over `bytes` with its header read and its output colours
/// chosen, and the image's width, height and those colours.
fn jpeg_decoder(bytes: &[u8]) -> Result<JpegHeader<'_>, String> {
    let options = DecoderOptions::default()
        .set_strict_mode(true)
        .set_max_width(usize::from(u16::MAX))
        .set_max_height(usize::from(u16::MAX));
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    decoder
        .decode_headers()
        .map_err(|e| format!("corrupt or truncated JPEG: {}", one_line(e)))?;
    let (width, height) = decoder.dimensions().ok_or("JPEG without dimensions")?;
    let colours = match decoder.input_colorspace() {
        Some(c @ (ColorSpace::Luma | ColorSpace::LumaA | ColorSpace::RGBA)) => c,
        _ => ColorSpace::RGB,
    };
    decoder.set_options(decoder.options().jpeg_set_out_colorspace(colours));
    Ok((decoder, width, height, colours))
}

/// A JPEG stream, decoded strictly to 8-bit grey, grey and alpha, RGB or RGBA (the
/// channels the `image` crate would give it; CMYK and YCCK become RGB).
pub fn decode_jpeg(bytes: &[u8]) -> Result<DynamicImage, String> {
    let (mut decoder, width, height, colours) = jpeg_decoder(bytes)?;
    let jpeg = |e| format!("corrupt or truncated JPEG: {}", one_line(e));
    // Dimensions are at most 65535 each: the product cannot overflow a u64.
    let bytes_needed = width as u64 * height as u64 * colours.num_components() as u64;
    check_fits(&format!("a {width}x{height} JPEG"), bytes_needed)?;
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
