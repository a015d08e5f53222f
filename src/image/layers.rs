//! Multi-layer OpenEXR files: the render and its passes (albedo, normal, depth, …) in one
//! file, as 32-bit float channels of a single part.
//!
//! Channels are named by OpenEXR's layer convention, "channel C of layer L is called
//! L.C", which Blender, tev, OpenImageIO and Nuke all show as layers: the main image is
//! the layer with the empty name, stored as plain `R`, `G`, `B` so that any viewer shows
//! it; a pass is e.g. `albedo.R`, `normal.X`, `depth.Z`. The names ember writes are in
//! [`names`].

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Cursor, Seek, SeekFrom};
use std::path::Path;

use exr::prelude as x;
use exr::prelude::traits::{ReadChannels, ReadLayers, WritableImage};
use glam::Vec3;

use super::{Image, ImageFileError};
use crate::io::{self, InputFile, WriteError};

/// The layer and channel names ember writes (docs/guide.md, "Passes, denoising, …").
pub mod names {
    /// The main image: the final (denoised, if asked) radiance, as plain `R,G,B`.
    pub const MAIN: &str = "";
    /// Colour layers' channels.
    pub const RGB: [&str; 3] = ["R", "G", "B"];
    /// Direction layers' channels (Blender's `Normal.X/Y/Z`).
    pub const XYZ: [&str; 3] = ["X", "Y", "Z"];
    /// Reflectance at the first non-delta hit, `R,G,B`.
    pub const ALBEDO: &str = "albedo";
    /// Shading normal at the first non-delta hit, world space, `X,Y,Z`.
    pub const NORMAL: &str = "normal";
    /// Distance along the camera ray to the first hit, `Z` (OpenEXR's depth channel).
    pub const DEPTH: &str = "depth";
    /// Variance of the pixel's mean radiance, `R,G,B`.
    pub const VARIANCE: &str = "variance";
    /// Samples taken in the pixel, `Y` (one value, as a grey image).
    pub const SPP: &str = "spp";
    /// The image before denoising, kept beside the denoised one, `R,G,B`.
    pub const NOISY: &str = "noisy";
}

/// One layer: named channels, interleaved per pixel, rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// Empty for the main image; may hold dots for nested layers (`a.b`).
    pub name: String,
    pub channels: Vec<String>,
    /// `channels.len()` values per pixel, pixel after pixel, row 0 at the top.
    pub data: Vec<f32>,
}

/// An EXR file's size as its headers give it (its first part's), before any pixel is
/// read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExrSize {
    pub width: u32,
    pub height: u32,
    /// Channels in all parts.
    pub channels: u64,
    /// Bytes of memory [`LayeredImage::read_exr`] holds at its peak: every channel's
    /// samples as stored (2 or 4 bytes), as `f32`, and interleaved into its layer, and
    /// the offset table.
    pub read_bytes: u64,
}

/// Layers of one size, written as one multi-layer EXR.
#[derive(Clone, Debug, PartialEq)]
pub struct LayeredImage {
    pub width: u32,
    pub height: u32,
    pub layers: Vec<Layer>,
}

/// What is wrong with the layers of a file or of an image about to be written.
#[derive(Debug, thiserror::Error)]
pub enum LayerError {
    #[error("no layer {layer:?} (with channels {wanted})")]
    Missing { layer: String, wanted: String },
    #[error("layer {layer:?} has channels {found:?}, expected {wanted:?}")]
    Channels {
        layer: String,
        found: Vec<String>,
        wanted: Vec<String>,
    },
    #[error("layer {layer:?} holds {found} values, expected {expected} ({channels} channels of {width}x{height})")]
    Size {
        layer: String,
        found: usize,
        expected: usize,
        channels: usize,
        width: u32,
        height: u32,
    },
    #[error("channel {0:?} appears twice")]
    Duplicate(String),
    #[error("channel name {0:?} is empty or holds a dot")]
    BadChannelName(String),
}

impl Layer {
    /// A layer of `channels` over `data` (interleaved per pixel).
    pub fn new(name: &str, channels: &[&str], data: Vec<f32>) -> Layer {
        Layer {
            name: name.to_owned(),
            channels: channels.iter().map(|c| c.to_string()).collect(),
            data,
        }
    }

    /// Three channels (`names::RGB`, `names::XYZ`, …) from an image's pixels.
    pub fn from_image(name: &str, channels: [&str; 3], image: &Image) -> Layer {
        let data = image.pixels.iter().flat_map(|p| p.to_array()).collect();
        Layer::new(name, &channels, data)
    }

    /// The main image's layer (plain `R,G,B`), the one [`LayeredImage::main_image`]
    /// reads back.
    pub fn main(image: &Image) -> Layer {
        Layer::from_image(names::MAIN, names::RGB, image)
    }

    /// The channel's full name in the file: `layer.channel`, or `channel` for the main
    /// image.
    fn full_name(&self, channel: &str) -> String {
        if self.name.is_empty() {
            channel.to_owned()
        } else {
            format!("{}.{channel}", self.name)
        }
    }
}

impl LayeredImage {
    pub fn new(width: u32, height: u32) -> Self {
        LayeredImage {
            width,
            height,
            layers: Vec::new(),
        }
    }

    /// The layer called `name`, if there is one.
    pub fn layer(&self, name: &str) -> Option<&Layer> {
        self.layers.iter().find(|l| l.name == name)
    }

    /// Adds a layer, or replaces the one of the same name.
    pub fn set(&mut self, layer: Layer) {
        match self.layers.iter_mut().find(|l| l.name == layer.name) {
            Some(old) => *old = layer,
            None => self.layers.push(layer),
        }
    }

    /// The three-channel layer `name` whose channels are `channels`, as an [`Image`].
    pub fn image(&self, name: &str, channels: [&str; 3]) -> Result<Image, LayerError> {
        let layer = self.layer(name).ok_or_else(|| LayerError::Missing {
            layer: name.to_owned(),
            wanted: channels.join(","),
        })?;
        if layer.channels != channels {
            return Err(LayerError::Channels {
                layer: name.to_owned(),
                found: layer.channels.clone(),
                wanted: channels.iter().map(|c| c.to_string()).collect(),
            });
        }
        self.check_size(layer)?;
        Ok(Image {
            width: self.width,
            height: self.height,
            pixels: layer
                .data
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect(),
        })
    }

    /// The main image (`R,G,B` without a layer name).
    pub fn main_image(&self) -> Result<Image, LayerError> {
        self.image(names::MAIN, names::RGB)
    }

    fn check_size(&self, layer: &Layer) -> Result<(), LayerError> {
        let channels = layer.channels.len();
        let expected = channels * self.width as usize * self.height as usize;
        if layer.data.len() == expected {
            Ok(())
        } else {
            Err(LayerError::Size {
                layer: layer.name.clone(),
                found: layer.data.len(),
                expected,
                channels,
                width: self.width,
                height: self.height,
            })
        }
    }

    /// Every layer the right size, channel names without dots, no name twice.
    fn validate(&self) -> Result<(), LayerError> {
        let mut seen = std::collections::HashSet::new();
        for layer in &self.layers {
            self.check_size(layer)?;
            for c in &layer.channels {
                if c.is_empty() || c.contains('.') {
                    return Err(LayerError::BadChannelName(c.clone()));
                }
                let full = layer.full_name(c);
                if !seen.insert(full.clone()) {
                    return Err(LayerError::Duplicate(full));
                }
            }
        }
        Ok(())
    }

    /// The image as an EXR file in memory: one part, 32-bit float channels, ZIP
    /// compression (lossless), blocks in increasing order. exrs compresses blocks in
    /// parallel and, with the default unspecified order, writes them as they finish, so
    /// the same image could give different bytes from run to run.
    pub fn encode_exr(&self) -> Result<Vec<u8>, String> {
        self.validate().map_err(|e| e.to_string())?;
        let pixels = self.width as usize * self.height as usize;
        let mut channels = x::SmallVec::<[x::AnyChannel<x::FlatSamples>; 4]>::new();
        for layer in &self.layers {
            let n = layer.channels.len();
            for (i, c) in layer.channels.iter().enumerate() {
                let samples = (0..pixels).map(|p| layer.data[p * n + i]).collect();
                channels.push(x::AnyChannel::new(
                    layer.full_name(c).as_str(),
                    x::FlatSamples::F32(samples),
                ));
            }
        }
        let part = x::Layer::new(
            (self.width as usize, self.height as usize),
            x::LayerAttributes::default(),
            x::Encoding {
                compression: x::Compression::ZIP16,
                line_order: x::LineOrder::Increasing,
                ..x::Encoding::default()
            },
            x::AnyChannels::sort(channels),
        );
        let mut bytes = Cursor::new(Vec::new());
        x::Image::from_layer(part)
            .write()
            .to_buffered(&mut bytes)
            .map_err(|e| e.to_string())?;
        Ok(bytes.into_inner())
    }

    /// Writes the image to `path` as a multi-layer EXR, atomically.
    pub fn write_exr(&self, path: &Path) -> Result<(), ImageFileError> {
        let bytes = self.encode_exr().map_err(|reason| WriteError {
            path: path.to_owned(),
            reason,
        })?;
        Ok(io::write_atomically(path, &bytes)?)
    }

    /// The size of the EXR file at `path` and what reading it takes, from its
    /// headers alone.
    pub fn exr_size(path: &Path) -> Result<ExrSize, ImageFileError> {
        let (headers, _) = read_exr_meta(path)?;
        let first = headers.first().ok_or_else(|| ImageFileError::Read {
            path: path.to_owned(),
            reason: "it holds no image part".into(),
        })?;
        let side = |s: usize| u32::try_from(s).unwrap_or(u32::MAX);
        Ok(ExrSize {
            width: side(first.layer_size.0),
            height: side(first.layer_size.1),
            channels: headers.iter().map(|h| h.channels.list.len() as u64).sum(),
            read_bytes: exr_headers_memory(&headers),
        })
    }

    /// Reads every channel of an EXR file (all parts of the same size; half, float and
    /// integer samples as `f32`), after checking from its headers that reading it fits
    /// in memory. Layers come back sorted by name, the main image first; a layer's
    /// channels in the order R, G, B, A, then the rest alphabetically (so `X,Y,Z` as
    /// written).
    pub fn read_exr(path: &Path) -> Result<LayeredImage, ImageFileError> {
        let fail = |reason: String| ImageFileError::Read {
            path: path.to_owned(),
            reason,
        };
        let (headers, reader) = read_exr_meta(path)?;
        let (w, h) = headers.first().map_or((0, 0), |h| h.layer_size.into());
        crate::limits::check_fits(&format!("a {w}x{h} EXR"), exr_headers_memory(&headers))
            .map_err(fail)?;
        let image = x::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_buffered(reader)
            .map_err(|e| fail(format!("not a readable OpenEXR file: {e}")))?;
        let size = image
            .layer_data
            .first()
            .ok_or_else(|| fail("it holds no image part".into()))?
            .size;
        let (width, height) = (size.0 as u32, size.1 as u32);
        // Full layer name -> (channel name -> samples).
        let mut grouped: BTreeMap<String, Vec<(String, Vec<f32>)>> = BTreeMap::new();
        for part in &image.layer_data {
            if part.size != size {
                return Err(fail(format!(
                    "its parts differ in size ({}x{} and {}x{}): ember reads one size only",
                    size.0, size.1, part.size.0, part.size.1
                )));
            }
            let part_name = part.attributes.layer_name.as_ref().map(|n| n.to_string());
            for channel in &part.channel_data.list {
                let full = channel.name.to_string();
                let (prefix, c) = full.rsplit_once('.').unwrap_or(("", &full));
                let layer = [part_name.as_deref().unwrap_or(""), prefix]
                    .into_iter()
                    .filter(|s| !s.is_empty())
                    .collect::<Vec<_>>()
                    .join(".");
                let samples = channel.sample_data.values_as_f32().collect();
                grouped
                    .entry(layer)
                    .or_default()
                    .push((c.to_owned(), samples));
            }
        }
        let pixels = width as usize * height as usize;
        let layers = grouped
            .into_iter()
            .map(|(name, mut channels)| {
                channels.sort_by(|a, b| channel_order(&a.0).cmp(&channel_order(&b.0)));
                let mut data = vec![0.0; pixels * channels.len()];
                for (i, (_, samples)) in channels.iter().enumerate() {
                    for (p, &v) in samples.iter().enumerate() {
                        data[p * channels.len() + i] = v;
                    }
                }
                Layer {
                    name,
                    channels: channels.into_iter().map(|(c, _)| c).collect(),
                    data,
                }
            })
            .collect();
        Ok(LayeredImage {
            width,
            height,
            layers,
        })
    }
}

/// The headers of the EXR file at `path`, read before any pixel, and the file rewound
/// for the reader.
fn read_exr_meta(path: &Path) -> Result<(exr::meta::Headers, BufReader<File>), ImageFileError> {
    let fail = |reason: String| ImageFileError::Read {
        path: path.to_owned(),
        reason,
    };
    let mut reader = InputFile::open(path)
        .map_err(|e| fail(e.reason))?
        .into_reader();
    let meta = exr::meta::MetaData::read_from_buffered(&mut reader, false)
        .map_err(|e| fail(format!("not a readable OpenEXR file: {e}")))?;
    reader
        .seek(SeekFrom::Start(0))
        .map_err(|e| fail(e.to_string()))?;
    Ok((meta.headers, reader))
}

/// Bytes reading the parts `headers` describe holds at its peak (see
/// [`LayeredImage::exr_memory_bytes`]).
fn exr_headers_memory(headers: &[exr::meta::header::Header]) -> u64 {
    headers
        .iter()
        .map(|header| {
            let pixels = (header.layer_size.0 as u64).saturating_mul(header.layer_size.1 as u64);
            let per_pixel: u64 = header
                .channels
                .list
                .iter()
                .map(|c| c.sample_type.bytes_per_sample() as u64 + 4 + 4)
                .sum::<u64>()
                + 8;
            pixels.saturating_mul(per_pixel)
        })
        .fold(0, u64::saturating_add)
}

/// Sort key of a channel within its layer: colour channels in their usual order, then
/// the rest by name.
fn channel_order(name: &str) -> (usize, &str) {
    let rank = ["R", "G", "B", "A"]
        .iter()
        .position(|&c| c == name)
        .unwrap_or(4);
    (rank, name)
}
