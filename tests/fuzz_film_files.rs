//! Fuzzing the reader of film files (shards and checkpoints) on the stable toolchain
//! (proptest). Inputs start from real files ember encoded (a complete shard, an
//! incomplete checkpoint) and are damaged: header fields replaced with hostile values
//! (huge, zero, negative, fractional, wrong types, missing, disagreeing with the
//! identity), pixel bytes overwritten, the file cut or extended. The checksum is
//! recomputed over the damaged bytes most of the time, so that the reader is tested
//! past it; the layout used for that is the one the format documents (preamble, JSON
//! header, pixel records, XXH3).
//!
//! What must hold: no input panics or allocates without bound (.ci/fuzz.sh caps the
//! address space); a refusal is one line naming the file; a file that is read is
//! consistent: its film has the header's size and range, no pixel has more samples
//! than the range or more finite ones than samples, the fewest samples in a pixel and
//! "complete" are what the header claims, and `ember merge`'s reader and `--resume`'s
//! agree.
//!
//! `EMBER_FUZZ_SECONDS=N` runs for N seconds and prints how many inputs were tried.

mod common;

use std::path::PathBuf;
use std::sync::OnceLock;

use ember::film::checkpoint::{self, FilmReader, Header};
use ember::film::{merge, shard_samples, Film, Moments};
use glam::DVec3;
use proptest::prelude::*;
use serde_json::{json, Value};

/// The identity of the films: what a render writes, for a 6x4 image.
fn identity() -> checkpoint::Identity {
    [
        ("width", "6"),
        ("height", "4"),
        ("max-depth", "5"),
        ("seed", "3"),
        ("accel", "embree"),
        ("scene", "00000000deadbeef"),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v.to_owned()))
    .collect()
}

/// A film of 6x4 pixels over `samples` with `done(i)` samples in pixel i, which
/// adaptive sampling stopped where `converged(i)`.
fn film(
    samples: std::ops::Range<u32>,
    done: impl Fn(usize) -> u32,
    converged: impl Fn(usize) -> bool,
) -> Film {
    let mut film = Film::new(6, 4, samples);
    for (i, p) in film.pixels.iter_mut().enumerate() {
        p.done = done(i);
        p.kept = done(i).saturating_sub(u32::from(i % 5 == 0));
        p.radiance = DVec3::new(i as f64, 0.5, f64::from(done(i)) * 0.25);
        p.radiance_sq = p.radiance * p.radiance;
        p.albedo = glam::Vec3::splat(0.5);
        p.normal = glam::Vec3::Z * p.kept as f32;
        p.depth = 2.0 * p.kept as f32;
        p.converged = converged(i);
    }
    // Guiding's training took the first half of the kept samples.
    let training: Vec<_> = film
        .pixels
        .iter()
        .map(|p| Moments {
            sum: p.radiance * 0.4,
            sum_sq: p.radiance_sq * 0.3,
            kept: p.kept / 2,
        })
        .collect();
    film.training = training;
    film
}

/// Real film files to damage: shard 1/3 of a 7 spp render (complete), the checkpoint
/// of a whole 7 spp render interrupted with 2 to 4 samples per pixel, and one that
/// adaptive sampling completed (some pixels stopped at 3 samples).
fn originals() -> &'static [Vec<u8>; 3] {
    static FILES: OnceLock<[Vec<u8>; 3]> = OnceLock::new();
    FILES.get_or_init(|| {
        let range = shard_samples(7, (1, 3));
        let shard = Header {
            identity: identity(),
            spp: 7,
            shard: Some((1, 3)),
            ..Header::default()
        };
        let n = range.len() as u32;
        let whole = Header {
            shard: None,
            ..shard.clone()
        };
        let stopped = |i: usize| i % 4 == 1;
        [
            checkpoint::encode(&shard, &film(range, |_| n, |_| false)),
            checkpoint::encode(&whole, &film(0..7, |i| 2 + (i % 3) as u32, |_| false)),
            checkpoint::encode(
                &whole,
                &film(0..7, |i| if stopped(i) { 3 } else { 7 }, stopped),
            ),
        ]
    })
}

/// The parts of a film file, as the format documents them.
#[derive(Clone, Debug)]
struct Parts {
    preamble: Vec<u8>,
    header: Value,
    records: Vec<u8>,
}

fn split(bytes: &[u8]) -> Parts {
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    Parts {
        preamble: bytes[..12].to_vec(),
        header: serde_json::from_slice(&bytes[16..16 + len]).unwrap(),
        records: bytes[16 + len..bytes.len() - 8].to_vec(),
    }
}

/// A hostile JSON value for a header field.
fn hostile_value() -> impl Strategy<Value = Value> {
    prop_oneof![
        4 => prop::sample::select(vec![
            0u64, 1, 2, 3, 4, 6, 7, 8, 24, 255, 16384, 16385, 65535, 65536, 1 << 31,
            u64::from(u32::MAX), 1 << 32, u64::MAX,
        ])
        .prop_map(|n| json!(n)),
        1 => any::<u32>().prop_map(|n| json!(n)),
        1 => prop::sample::select(vec![
            json!(-1), json!(0.5), json!(1e300), json!("6"), json!(null), json!(true),
            json!([]), json!([1]), json!([0, 7]), json!([2, 1]), json!([0, 0]), json!([7, 7]),
            json!([0, 4294967295u64]), json!([1, 3]), json!([3, 3]), json!([0, 1]),
            json!({}), json!(""),
        ]),
        1 => (0u32..9, 0u32..9).prop_map(|(a, b)| json!([a, b])),
    ]
}

const FIELDS: [&str; 8] = [
    "width", "height", "spp", "samples", "shard", "min_done", "complete", "identity",
];

/// One damage to a file.
#[derive(Clone, Debug)]
enum Edit {
    /// Replaces (or with `None` removes) a header field.
    Field(&'static str, Option<Value>),
    /// Sets the identity's entry `key` to `value`, or removes it.
    Identity(&'static str, Option<String>),
    /// Overwrites a byte of the pixel records.
    Byte(prop::sample::Index, u8),
    /// Cuts the records to a fraction of their length, or appends bytes.
    Resize(prop::sample::Index, i8),
    /// Overwrites a byte of the preamble (magic, version).
    Preamble(u8, u8),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        6 => (prop::sample::select(FIELDS.to_vec()), prop::option::weighted(0.9, hostile_value()))
            .prop_map(|(f, v)| Edit::Field(f, v)),
        2 => (
            prop::sample::select(vec!["width", "height", "seed", "scene"]),
            prop::option::weighted(0.8, "[0-9]{0,6}|x|-1|4294967296"),
        )
            .prop_map(|(k, v)| Edit::Identity(k, v)),
        4 => (any::<prop::sample::Index>(), any::<u8>()).prop_map(|(i, b)| Edit::Byte(i, b)),
        1 => (any::<prop::sample::Index>(), any::<i8>()).prop_map(|(i, n)| Edit::Resize(i, n)),
        1 => (0u8..12, any::<u8>()).prop_map(|(i, b)| Edit::Preamble(i, b)),
    ]
}

#[derive(Clone, Debug)]
struct Input {
    original: usize,
    edits: Vec<Edit>,
    /// Whether the checksum is computed over the damaged bytes (else the original's).
    rehash: bool,
}

fn input() -> impl Strategy<Value = Input> {
    (
        0..3usize,
        prop::collection::vec(edit(), 0..5),
        prop::bool::weighted(0.9),
    )
        .prop_map(|(original, edits, rehash)| Input {
            original,
            edits,
            rehash,
        })
}

impl Input {
    fn bytes(&self) -> Vec<u8> {
        let original = &originals()[self.original];
        let mut parts = split(original);
        for edit in &self.edits {
            apply(&mut parts, edit);
        }
        let json = parts.header.to_string();
        let mut bytes = parts.preamble;
        bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
        bytes.extend_from_slice(json.as_bytes());
        bytes.extend_from_slice(&parts.records);
        let hash = match self.rehash {
            true => xxhash_rust::xxh3::xxh3_64(&bytes),
            false => u64::from_le_bytes(original[original.len() - 8..].try_into().unwrap()),
        };
        bytes.extend_from_slice(&hash.to_le_bytes());
        bytes
    }
}

fn apply(parts: &mut Parts, edit: &Edit) {
    let header = parts.header.as_object_mut().unwrap();
    match edit {
        Edit::Field(key, Some(v)) => {
            header.insert((*key).to_owned(), v.clone());
        }
        Edit::Field(key, None) => {
            header.remove(*key);
        }
        Edit::Identity(key, value) => {
            if let Some(Value::Object(identity)) = header.get_mut("identity") {
                match value {
                    Some(v) => identity.insert((*key).to_owned(), json!(v)),
                    None => identity.remove(*key),
                };
            }
        }
        Edit::Byte(at, byte) if !parts.records.is_empty() => {
            let i = at.index(parts.records.len());
            parts.records[i] = *byte;
        }
        Edit::Byte(..) => {}
        Edit::Resize(at, n) if *n < 0 => {
            let keep = at.index(parts.records.len() + 1);
            parts.records.truncate(keep);
        }
        Edit::Resize(_, n) => parts
            .records
            .resize(parts.records.len() + *n as usize, 0x5a),
        Edit::Preamble(i, byte) => parts.preamble[*i as usize] = *byte,
    }
}

/// The file an input is written to: one per test thread (the fuzz test and the
/// regressions run at once), in one temporary directory.
fn path() -> PathBuf {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    let dir = DIR.get_or_init(|| tempfile::tempdir().unwrap());
    let thread = format!("{:?}", std::thread::current().id());
    let digits: String = thread.chars().filter(char::is_ascii_digit).collect();
    dir.path().join(format!("film-{digits}.shard"))
}

/// Whether the input was read as a film (true) or refused with an error.
fn check(input: &Input) -> Result<bool, TestCaseError> {
    let path = &path();
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    std::fs::write(path, input.bytes()).unwrap();
    let one_line = |e: &dyn std::fmt::Display| -> Result<(), TestCaseError> {
        let message = e.to_string();
        prop_assert!(!message.contains('\n'), "not one line: {}", message);
        prop_assert!(
            message.contains(&name),
            "does not name the file: {}",
            message
        );
        Ok(())
    };
    let reader = match FilmReader::open(path) {
        Ok(reader) => reader,
        Err(e) => return one_line(&e).map(|_| false),
    };
    let header = reader.header.clone();
    let read = reader.read_film();
    let merged = merge::merge(std::slice::from_ref(path), true);
    match (&read, &merged) {
        (Ok(film), Ok((merged, _))) => {
            check_film(film, &header)?;
            // The merge of one file is that film over 0..spp.
            prop_assert_eq!(&merged.pixels, &film.pixels);
        }
        (Err(e), Err(_)) => one_line(e)?,
        // A merge may refuse what reads as a film on its own (it holds samples that
        // are not all of 0..spp only with --allow-partial, which is given here).
        (Ok(_), Err(e)) => prop_assert!(false, "read, but merge refused: {}", e),
        (Err(e), Ok(_)) => prop_assert!(false, "merged, but read refused: {}", e),
    }
    Ok(read.is_ok())
}

fn check_film(film: &Film, header: &Header) -> Result<(), TestCaseError> {
    prop_assert_eq!((film.width, film.height), (header.width, header.height));
    prop_assert_eq!(&film.samples, &header.samples);
    let pixels = film.width as usize * film.height as usize;
    prop_assert!(film.pixels.len() == pixels);
    let range = film.samples.len() as u32;
    for p in &film.pixels {
        prop_assert!(p.kept <= p.done && p.done <= range);
        prop_assert!(p.radiance.is_finite() && p.albedo.is_finite() && p.depth.is_finite());
    }
    prop_assert_eq!(film.training.is_empty(), !header.training);
    for (t, p) in film.training.iter().zip(&film.pixels) {
        prop_assert!(t.kept <= p.kept && t.sum.is_finite() && t.sum_sq.min_element() >= 0.0);
    }
    prop_assert_eq!(film.min_done(), header.min_done);
    prop_assert_eq!(film.is_complete(), header.complete);
    let identity: Vec<_> = header
        .identity
        .iter()
        .filter(|(k, _)| k == "width")
        .collect();
    prop_assert_eq!(identity[0].1.clone(), film.width.to_string());
    prop_assert!(header.spp >= 1 && header.samples.end <= header.spp);
    Ok(())
}

#[test]
fn fuzz_film_files() {
    common::fuzz::run("fuzz_film_files", "read as films", input(), check);
}

/// Inputs the fuzzer (or review) found problems with, kept so they never come back.
mod regressions {
    use super::*;

    #[test]
    fn the_originals_read_and_a_huge_header_is_refused() {
        for original in 0..3 {
            let input = Input {
                original,
                edits: Vec::new(),
                rehash: true,
            };
            check(&input).unwrap();
            std::fs::write(path(), input.bytes()).unwrap();
            assert!(FilmReader::open(&path()).unwrap().read_film().is_ok());
        }
        let huge = Input {
            original: 0,
            edits: vec![
                Edit::Field("width", Some(json!(u32::MAX))),
                Edit::Field("height", Some(json!(u32::MAX))),
                Edit::Identity("width", Some(u32::MAX.to_string())),
                Edit::Identity("height", Some(u32::MAX.to_string())),
            ],
            rehash: true,
        };
        check(&huge).unwrap();
        std::fs::write(path(), huge.bytes()).unwrap();
        assert!(FilmReader::open(&path()).is_err());
    }

    /// A film reads back as it was written, training's share of the sums with it; a
    /// pixel claiming more training samples than kept ones is refused.
    #[test]
    fn films_read_back_whole_and_training_cannot_exceed_the_kept_samples() {
        let header = Header {
            identity: identity(),
            spp: 7,
            ..Header::default()
        };
        let written = film(0..7, |i| 2 + (i % 3) as u32, |_| false);
        std::fs::write(path(), checkpoint::encode(&header, &written)).unwrap();
        let read = FilmReader::open(&path()).unwrap().read_film().unwrap();
        assert_eq!(read, written);
        let mut bad = written;
        bad.training[5].kept = bad.pixels[5].kept + 1;
        std::fs::write(path(), checkpoint::encode(&header, &bad)).unwrap();
        let error = FilmReader::open(&path()).unwrap().read_film().unwrap_err();
        assert!(
            error.to_string().contains("inconsistent data at pixel 5"),
            "{error}"
        );
    }
}
