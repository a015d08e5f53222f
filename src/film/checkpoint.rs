//! The film file: a [`Film`] with the header that says which render it belongs to.
//! Checkpoints of interrupted renders and the shards of a split render are both film
//! files; they are written atomically and checked whole on reading.
//!
//! Layout (little-endian): the magic `EMBERCKP`, a `u32` format version, a `u32` length
//! and that many bytes of JSON header (see [`Header`]), then per pixel row by row its
//! [`PixelSums`] ([`PIXEL_BYTES`]: `f64` × 3 radiance sums and × 3 sums of squares,
//! `f32` × 3 albedo, × 3 normal and × 1 depth sums, `u32` finite samples, `u32` samples
//! taken, `u32` flags with bit 0 "converged"), followed, where the header says
//! `"training": true`, by the part of them that path guiding's training added
//! ([`TRAINING_BYTES`]: `f64` × 3 sums and × 3 sums of squares, `u32` finite samples),
//! and last the `u64` XXH3 hash of everything before it, so a damaged or truncated file
//! is refused.
//!
//! Version history: 1 (no accel, no algorithm version, a scene hash over `Debug` text,
//! no sample range, FNV-1a); 2 (radiance sums and counts only); 3 (the render passes,
//! squares for the variance, adaptive sampling's flag, a "complete" claim); 4 (this one:
//! training's share of the sums, which the image weighs apart).
//! Files of other versions are refused.

use std::fs::File;
use std::io::{BufReader, Read};
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde_json::{json, Map, Value};
use xxhash_rust::xxh3::Xxh3;

use super::{Film, Moments, PixelSums};
use crate::io::{self, InputFile, WriteError};

const MAGIC: &[u8; 8] = b"EMBERCKP";
/// The film file format this ember reads and writes.
pub const FORMAT_VERSION: u32 = 4;
/// The bytes of one pixel's record.
pub const PIXEL_BYTES: usize = 6 * 8 + 7 * 4 + 3 * 4;
/// The bytes that follow each pixel's record in a film with training's moments.
pub const TRAINING_BYTES: usize = 6 * 8 + 4;
/// A header this long is surely not ours (it holds a few hundred bytes of settings).
const MAX_HEADER_BYTES: u32 = 1 << 20;

/// What must be equal for two films to hold samples of the same image, as (name, value)
/// pairs in a fixed order: settings, camera, scene fingerprint, accelerator, algorithm.
pub type Identity = Vec<(String, String)>;

/// What a film file says about its film.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Header {
    pub identity: Identity,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of the whole render (`--spp`).
    pub spp: u32,
    /// The sample indices this film holds.
    pub samples: Range<u32>,
    /// `(I, N)` for shard I of N, `None` for a checkpoint of a whole render.
    pub shard: Option<(u32, u32)>,
    /// Fewest samples any pixel has (`samples.len()` when the film is complete without
    /// adaptive sampling).
    pub min_done: u32,
    /// Whether every pixel has all its samples or was stopped by adaptive sampling.
    pub complete: bool,
    /// Whether each pixel's record is followed by its training moments
    /// ([`Film::training`]).
    pub training: bool,
}

impl Header {
    /// The bytes of one pixel in the file.
    fn record_bytes(&self) -> usize {
        PIXEL_BYTES + if self.training { TRAINING_BYTES } else { 0 }
    }

    /// The film's name for messages: `shard 2/8`, or `a whole render`.
    pub fn label(&self) -> String {
        match self.shard {
            Some((i, n)) => format!("shard {i}/{n}"),
            None => "a whole render".into(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("cannot read {path}: {reason}")]
    Read { path: PathBuf, reason: String },
    #[error("{path} is not a valid ember checkpoint or shard: {reason}")]
    Invalid { path: PathBuf, reason: String },
    #[error(
        "{path} has film file format version {found}, but this ember reads only version \
         {FORMAT_VERSION}: render it again"
    )]
    Version { path: PathBuf, found: u32 },
    #[error("{path} was made with {key} {theirs}, but this render has {key} {ours}")]
    Mismatch {
        path: PathBuf,
        key: String,
        theirs: String,
        ours: String,
    },
    #[error("{path} holds samples {theirs:?} of each pixel, but this render needs {ours:?}")]
    Range {
        path: PathBuf,
        theirs: Range<u32>,
        ours: Range<u32>,
    },
    #[error("{path} already has {done} samples per pixel, more than --spp {spp}")]
    PastTarget { path: PathBuf, done: u32, spp: u32 },
    #[error("{path}: {reason}")]
    TooLarge { path: PathBuf, reason: String },
    #[error(transparent)]
    Write(#[from] WriteError),
}

fn header_json(header: &Header) -> String {
    let identity: Map<String, Value> = header
        .identity
        .iter()
        .map(|(k, v)| (k.clone(), Value::String(v.clone())))
        .collect();
    json!({
        "identity": identity,
        "width": header.width,
        "height": header.height,
        "spp": header.spp,
        "samples": [header.samples.start, header.samples.end],
        "shard": header.shard.map(|(i, n)| [i, n]),
        "min_done": header.min_done,
        "complete": header.complete,
        "training": header.training,
    })
    .to_string()
}

/// Encodes a film file. The header's size, range, `min_done`, `complete` and `training`
/// are taken from `film`.
pub fn encode(header: &Header, film: &Film) -> Vec<u8> {
    let header = Header {
        width: film.width,
        height: film.height,
        samples: film.samples.clone(),
        min_done: film.min_done(),
        complete: film.is_complete(),
        training: !film.training.is_empty(),
        ..header.clone()
    };
    let json = header_json(&header);
    let mut out = Vec::with_capacity(24 + json.len() + film.pixels.len() * header.record_bytes());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(json.as_bytes());
    for (i, p) in film.pixels.iter().enumerate() {
        encode_pixel(p, &mut out);
        if let Some(t) = film.training.get(i) {
            encode_training(t, &mut out);
        }
    }
    let hash = xxhash_rust::xxh3::xxh3_64(&out);
    out.extend_from_slice(&hash.to_le_bytes());
    out
}

fn encode_pixel(p: &PixelSums, out: &mut Vec<u8>) {
    for c in p
        .radiance
        .to_array()
        .into_iter()
        .chain(p.radiance_sq.to_array())
    {
        out.extend_from_slice(&c.to_le_bytes());
    }
    let floats = p.albedo.to_array().into_iter().chain(p.normal.to_array());
    for c in floats.chain([p.depth]) {
        out.extend_from_slice(&c.to_le_bytes());
    }
    for w in [p.kept, p.done, u32::from(p.converged)] {
        out.extend_from_slice(&w.to_le_bytes());
    }
}

fn encode_training(t: &Moments, out: &mut Vec<u8>) {
    for c in t.sum.to_array().into_iter().chain(t.sum_sq.to_array()) {
        out.extend_from_slice(&c.to_le_bytes());
    }
    out.extend_from_slice(&t.kept.to_le_bytes());
}

/// Training's moments of the pixel `p`, or `None` where they cannot be its: non-finite
/// or negative sums, more samples than the pixel kept.
fn decode_training(bytes: &[u8], p: &PixelSums) -> Option<Moments> {
    let f64_at = |k: usize| f64::from_le_bytes(bytes[8 * k..8 * k + 8].try_into().expect("8"));
    let t = Moments {
        sum: DVec3::new(f64_at(0), f64_at(1), f64_at(2)),
        sum_sq: DVec3::new(f64_at(3), f64_at(4), f64_at(5)),
        kept: u32::from_le_bytes(bytes[48..52].try_into().expect("4")),
    };
    let finite = t.sum.is_finite() && t.sum_sq.is_finite();
    (finite && t.sum_sq.min_element() >= 0.0 && t.kept <= p.kept).then_some(t)
}

/// One pixel's record, or `None` where its values cannot be a film's: non-finite or
/// negative sums, more kept than taken samples, unknown flags.
fn decode_pixel(px: &[u8]) -> Option<PixelSums> {
    let f64_at = |k: usize| f64::from_le_bytes(px[8 * k..8 * k + 8].try_into().expect("8"));
    let f32_at = |k: usize| f32::from_le_bytes(px[48 + 4 * k..52 + 4 * k].try_into().expect("4"));
    let u32_at = |k: usize| u32::from_le_bytes(px[76 + 4 * k..80 + 4 * k].try_into().expect("4"));
    let p = PixelSums {
        radiance: DVec3::new(f64_at(0), f64_at(1), f64_at(2)),
        radiance_sq: DVec3::new(f64_at(3), f64_at(4), f64_at(5)),
        albedo: glam::Vec3::new(f32_at(0), f32_at(1), f32_at(2)),
        normal: glam::Vec3::new(f32_at(3), f32_at(4), f32_at(5)),
        depth: f32_at(6),
        kept: u32_at(0),
        done: u32_at(1),
        converged: u32_at(2) == 1,
    };
    let finite = p.radiance.is_finite()
        && p.radiance_sq.is_finite()
        && p.albedo.is_finite()
        && p.normal.is_finite()
        && p.depth.is_finite();
    (finite && p.radiance_sq.min_element() >= 0.0 && p.kept <= p.done && u32_at(2) <= 1)
        .then_some(p)
}

/// Writes a film file atomically: the file is the old one or the whole new one.
pub fn save(path: &Path, header: &Header, film: &Film) -> Result<(), CheckpointError> {
    Ok(io::write_atomically(path, &encode(header, film))?)
}

/// A film file opened for reading: the one reader of shards and checkpoints (`ember
/// merge` and `--resume` alike), which trusts nothing in the file. Its header is read
/// and checked whole ([`check_header`]) before anything is allocated from it; the pixels
/// follow one by one ([`FilmReader::read_pixels`]), hashed as they go, so that a large
/// file is never held in memory whole.
pub struct FilmReader {
    pub path: PathBuf,
    pub header: Header,
    reader: BufReader<File>,
    hasher: Xxh3,
}

impl FilmReader {
    pub fn open(path: &Path) -> Result<FilmReader, CheckpointError> {
        let input = InputFile::open(path).map_err(|e| CheckpointError::Read {
            path: path.to_owned(),
            reason: e.reason,
        })?;
        let file_len = input.len();
        let file = input.into_file();
        let mut reader = FilmReader {
            path: path.to_owned(),
            header: Header::default(), // read next
            reader: BufReader::with_capacity(1 << 16, file),
            hasher: Xxh3::new(),
        };
        let json_len = reader.read_preamble()?;
        let mut json = vec![0; json_len as usize];
        reader.read_hashed(&mut json)?;
        reader.header = parse_header(&json).map_err(|reason| reader.invalid(&reason))?;
        check_header(&reader.header, json_len, file_len).map_err(|r| reader.invalid(&r))?;
        let (w, h) = (reader.header.width, reader.header.height);
        crate::limits::check_fits(
            &format!("the {w}x{h} film it holds"),
            crate::render::render_memory_bytes(w, h),
        )
        .map_err(|reason| CheckpointError::TooLarge {
            path: path.to_owned(),
            reason,
        })?;
        Ok(reader)
    }

    fn invalid(&self, reason: &str) -> CheckpointError {
        CheckpointError::Invalid {
            path: self.path.clone(),
            reason: reason.to_owned(),
        }
    }

    fn read_hashed(&mut self, buf: &mut [u8]) -> Result<(), CheckpointError> {
        self.reader
            .read_exact(buf)
            .map_err(|_| self.invalid("too short (truncated)"))?;
        self.hasher.update(buf);
        Ok(())
    }

    /// Reads magic and version; returns the header's length.
    fn read_preamble(&mut self) -> Result<u32, CheckpointError> {
        let mut preamble = [0u8; 16];
        self.read_hashed(&mut preamble)?;
        if &preamble[..8] != MAGIC {
            return Err(self.invalid("wrong magic bytes"));
        }
        let word = |at: usize| u32::from_le_bytes(preamble[at..at + 4].try_into().expect("4"));
        if word(8) != FORMAT_VERSION {
            return Err(CheckpointError::Version {
                path: self.path.clone(),
                found: word(8),
            });
        }
        match word(12) {
            len if len <= MAX_HEADER_BYTES => Ok(len),
            len => Err(self.invalid(&format!("a header of {len} bytes"))),
        }
    }

    /// Calls `add(i, pixel, training)` for every pixel in order (`training` its
    /// training moments where the film has them), then checks the hash and the
    /// header's claims against the pixels: on an error, what `add` received must be
    /// thrown away.
    pub fn read_pixels(
        mut self,
        mut add: impl FnMut(usize, &PixelSums, Option<&Moments>),
    ) -> Result<(), CheckpointError> {
        let pixels = self.header.width as usize * self.header.height as usize;
        let range_len = self.header.samples.len() as u32;
        let record = self.header.record_bytes();
        let mut chunk = vec![0u8; record * 4096];
        let mut tally = PixelTally::new();
        let mut i = 0;
        while i < pixels {
            let n = (pixels - i).min(4096);
            let bytes = &mut chunk[..n * record];
            self.reader
                .read_exact(bytes)
                .map_err(|_| self.invalid("too short (truncated)"))?;
            self.hasher.update(bytes);
            for px in bytes.chunks_exact(record) {
                let (sums, training) = px.split_at(PIXEL_BYTES);
                let decoded = decode_pixel(sums)
                    .filter(|p| p.done <= range_len)
                    .and_then(|p| match self.header.training {
                        true => Some((p, Some(decode_training(training, &p)?))),
                        false => Some((p, None)),
                    });
                match decoded {
                    Some((p, t)) => {
                        tally.add(i, &p, &self.header);
                        add(i, &p, t.as_ref())
                    }
                    _ => return Err(self.invalid(&format!("inconsistent data at pixel {i}"))),
                }
                i += 1;
            }
        }
        let mut stored = [0u8; 8];
        self.reader
            .read_exact(&mut stored)
            .map_err(|_| self.invalid("too short (truncated)"))?;
        if self.hasher.digest() != u64::from_le_bytes(stored) {
            return Err(self.invalid("checksum mismatch (damaged)"));
        }
        match tally.disagreement(&self.header) {
            Some(reason) => Err(self.invalid(&reason)),
            None => Ok(()),
        }
    }

    /// The whole film, checked.
    pub fn read_film(self) -> Result<Film, CheckpointError> {
        let h = &self.header;
        let mut film = Film::new(h.width, h.height, h.samples.clone());
        self.read_pixels(|i, p, t| {
            film.pixels[i] = *p;
            if let Some(t) = t {
                film.training_mut()[i] = *t;
            }
        })?;
        Ok(film)
    }
}

fn parse_header(json: &[u8]) -> Result<Header, String> {
    let v: Value = serde_json::from_slice(json).map_err(|e| format!("header: {e}"))?;
    let uint = |key: &str| -> Result<u32, String> {
        v.get(key)
            .and_then(Value::as_u64)
            .and_then(|n| u32::try_from(n).ok())
            .ok_or_else(|| format!("header lacks {key}"))
    };
    let pair = |key: &str| -> Result<Option<(u32, u32)>, String> {
        match v.get(key) {
            None | Some(Value::Null) => Ok(None),
            Some(Value::Array(a)) if a.len() == 2 => {
                let n = |x: &Value| x.as_u64().and_then(|n| u32::try_from(n).ok());
                match (n(&a[0]), n(&a[1])) {
                    (Some(a), Some(b)) => Ok(Some((a, b))),
                    _ => Err(format!("bad {key}")),
                }
            }
            Some(_) => Err(format!("bad {key}")),
        }
    };
    let identity = v
        .get("identity")
        .and_then(Value::as_object)
        .ok_or("header lacks identity")?
        .iter()
        .map(|(k, v)| Ok((k.clone(), v.as_str().ok_or("bad identity")?.to_owned())))
        .collect::<Result<Identity, String>>()?;
    let (start, end) = pair("samples")?.ok_or("header lacks samples")?;
    let header = Header {
        identity,
        width: uint("width")?,
        height: uint("height")?,
        spp: uint("spp")?,
        samples: start..end,
        shard: pair("shard")?,
        min_done: uint("min_done")?,
        complete: v
            .get("complete")
            .and_then(Value::as_bool)
            .ok_or("header lacks complete")?,
        training: v
            .get("training")
            .and_then(Value::as_bool)
            .ok_or("header lacks training")?,
    };
    Ok(header)
}

/// The length of a film file of `pixels` records of `record_bytes` whose JSON header is
/// `json_len` bytes: preamble, header, pixel records, hash. `None` past `u64` (no such
/// file exists).
fn file_len_for(json_len: u32, pixels: u64, record_bytes: usize) -> Option<u64> {
    pixels
        .checked_mul(record_bytes as u64)?
        .checked_add(16 + u64::from(json_len) + 8)
}

/// Checks what a header claims before anything is read or allocated from it: its size
/// against the identity it carries and ember's limits, its sample range against its
/// spp and shard number, its sample counts against its range, and the file's length
/// against the size (with checked arithmetic). What the pixels must then agree with
/// is checked as they are read ([`FilmReader::read_pixels`]).
fn check_header(h: &Header, json_len: u32, file_len: u64) -> Result<(), String> {
    use crate::limits::{MAX_IMAGE_SIDE, MAX_SHARDS, MAX_SPP};
    for (key, value) in [("width", h.width), ("height", h.height)] {
        if !(1..=MAX_IMAGE_SIDE).contains(&value) {
            return Err(format!("its {key} {value} is outside 1..={MAX_IMAGE_SIDE}"));
        }
        let carried = h.identity.iter().find(|(k, _)| k == key);
        let carried = carried.map_or("none", |(_, v)| v.as_str());
        if carried != value.to_string() {
            return Err(format!(
                "its {key} {value} disagrees with the {key} {carried} of the render it names"
            ));
        }
    }
    if !(1..=MAX_SPP).contains(&h.spp) {
        return Err(format!("its spp {} is outside 1..={MAX_SPP}", h.spp));
    }
    let expected = match h.shard {
        Some((i, n)) if i >= n || n > MAX_SHARDS => {
            return Err(format!(
                "shard {i}/{n} is not one of 0/N .. N-1/N, N ≤ {MAX_SHARDS}"
            ))
        }
        Some(shard) => super::shard_samples(h.spp, shard),
        None => 0..h.spp,
    };
    if h.samples != expected {
        return Err(format!(
            "as {} of {} spp it would hold samples {expected:?}, but it claims samples {:?}",
            h.label(),
            h.spp,
            h.samples
        ));
    }
    let len = h.samples.len() as u32;
    if h.min_done > len || (h.min_done == len && !h.complete) {
        return Err(format!(
            "it claims {} samples in every pixel of its {len}, and to be {}",
            h.min_done,
            if h.complete { "complete" } else { "incomplete" }
        ));
    }
    let pixels = u64::from(h.width) * u64::from(h.height);
    match file_len_for(json_len, pixels, h.record_bytes()) {
        Some(expected) if expected == file_len => Ok(()),
        expected => Err(format!(
            "{file_len} bytes where its {}x{} header promises {} (truncated or damaged)",
            h.width,
            h.height,
            expected.map_or("more than 2^64".into(), |n| n.to_string())
        )),
    }
}

/// What the pixels of a film file hold, against which its header's claims are
/// checked once they are all read.
struct PixelTally {
    /// The fewest samples any pixel has.
    fewest: u32,
    /// The first pixel with fewer samples than the header claims for all: (index, done).
    short: Option<(usize, u32)>,
    /// The first pixel neither finished nor stopped by adaptive sampling.
    unfinished: Option<(usize, u32)>,
}

impl PixelTally {
    fn new() -> Self {
        PixelTally {
            fewest: u32::MAX,
            short: None,
            unfinished: None,
        }
    }

    fn add(&mut self, i: usize, p: &PixelSums, header: &Header) {
        self.fewest = self.fewest.min(p.done);
        if p.done < header.min_done && self.short.is_none() {
            self.short = Some((i, p.done));
        }
        if !p.converged && p.done < header.samples.len() as u32 && self.unfinished.is_none() {
            self.unfinished = Some((i, p.done));
        }
    }

    /// Why the header's claims ("every pixel has at least `min_done` samples", and
    /// "complete") disagree with the pixels, if they do.
    fn disagreement(&self, h: &Header) -> Option<String> {
        let at = |i: usize| (i as u32 % h.width, i as u32 / h.width);
        let len = h.samples.len();
        if let (true, Some((i, done))) = (h.complete, self.unfinished) {
            let (x, y) = at(i);
            return Some(format!(
                "it claims to be complete, but pixel ({x}, {y}) has {done} of its {len} samples \
                 and was not stopped by adaptive sampling"
            ));
        }
        if let Some((i, done)) = self.short {
            let (x, y) = at(i);
            return Some(format!(
                "it claims {} samples in every pixel, but pixel ({x}, {y}) has {done}",
                h.min_done
            ));
        }
        if self.fewest != h.min_done {
            return Some(format!(
                "it claims {} samples in every pixel, but every pixel has {} or more",
                h.min_done, self.fewest
            ));
        }
        (!h.complete && self.unfinished.is_none())
            .then(|| "it claims to be incomplete, but every pixel is finished".into())
    }
}

/// The first setting in which `theirs` differs from `ours`, as (key, theirs, ours);
/// a key only one side has (such as `light-sampler`, named only when not the
/// default) is a difference, its missing value written `(none)`.
pub fn first_difference(theirs: &Identity, ours: &Identity) -> Option<(String, String, String)> {
    let value_in = |identity: &Identity, key: &str| {
        identity
            .iter()
            .find(|(k, _)| k == key)
            .map_or("(none)", |(_, v)| v.as_str())
            .to_owned()
    };
    let ours_first = ours.iter().find_map(|(key, value)| {
        let other = value_in(theirs, key);
        (other != *value).then(|| (key.clone(), other, value.clone()))
    });
    ours_first.or_else(|| {
        theirs
            .iter()
            .find(|(key, _)| !ours.iter().any(|(k, _)| k == key))
            .map(|(key, value)| (key.clone(), value.clone(), "(none)".to_owned()))
    })
}

/// Reads a film file to continue the render `identity` describes over the sample
/// indices `samples`: same identity, same first sample, and no more samples than wanted.
pub fn load(
    path: &Path,
    identity: &Identity,
    samples: Range<u32>,
) -> Result<Film, CheckpointError> {
    let reader = FilmReader::open(path)?;
    if let Some((key, theirs, ours)) = first_difference(&reader.header.identity, identity) {
        return Err(CheckpointError::Mismatch {
            path: path.to_owned(),
            key,
            theirs,
            ours,
        });
    }
    let mut film = reader.read_film()?;
    if film.samples.start != samples.start {
        return Err(CheckpointError::Range {
            path: path.to_owned(),
            theirs: film.samples,
            ours: samples,
        });
    }
    let most = film.pixels.iter().map(|p| p.done).max().unwrap_or(0);
    if most > samples.len() as u32 {
        return Err(CheckpointError::PastTarget {
            path: path.to_owned(),
            done: samples.start + most,
            spp: samples.end,
        });
    }
    film.samples = samples;
    Ok(film)
}
