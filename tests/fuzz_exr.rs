//! Fuzzing the EXR reader of `ember denoise` (`LayeredImage::read_exr`, and the header
//! reading `exr_size` that its memory check rests on) on the stable toolchain
//! (proptest). Inputs start from real files written at run time: ember's multi-layer
//! EXR (image, albedo, normal, depth), and the same channels in half and float, with
//! every lossless compression, in scan lines and in tiles; and a file whose header
//! claims 100000x100000 pixels with an offset table to match. They are damaged: header
//! integers (sizes, windows, counts) replaced with hostile values, bytes overwritten,
//! the file cut or extended, parts repeated.
//!
//! What must hold: no input panics or allocates without bound (.ci/fuzz.sh caps the
//! address space, and the memory limit here keeps a claim that passes the check far
//! below it); a refusal is one line naming the file; a file that is read has layers of
//! the size its header gives, and the header reading agrees with it.
//!
//! `EMBER_FUZZ_SECONDS=N` runs for N seconds and prints how many inputs were tried.

mod common;

use std::io::Cursor;
use std::path::PathBuf;
use std::sync::OnceLock;

use ember::image::{Layer, LayeredImage};
use exr::prelude as x;
use exr::prelude::traits::WritableImage;
use proptest::prelude::*;

/// The memory the reader may assume (EMBER_MEMORY_LIMIT): 256 MiB.
const MEMORY_LIMIT: &str = "268435456";

/// The channels of ember's multi-layer EXR as the exr crate writes them, `half` or
/// float, with `compression` and `blocks`.
fn exr_with(half: bool, compression: x::Compression, blocks: x::Blocks) -> Vec<u8> {
    let (w, h) = (7usize, 5usize);
    let names = [
        "R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y",
    ];
    let mut channels = x::SmallVec::<[x::AnyChannel<x::FlatSamples>; 4]>::new();
    for (c, name) in names.iter().enumerate() {
        let values = (0..w * h).map(|p| (p * 7 + c * 3) as f32 / 17.0);
        let samples = if half {
            x::FlatSamples::F16(values.map(x::f16::from_f32).collect())
        } else {
            x::FlatSamples::F32(values.collect())
        };
        channels.push(x::AnyChannel::new(*name, samples));
    }
    let layer = x::Layer::new(
        (w, h),
        x::LayerAttributes::default(),
        x::Encoding {
            compression,
            blocks,
            line_order: x::LineOrder::Increasing,
        },
        x::AnyChannels::sort(channels),
    );
    let mut bytes = Cursor::new(Vec::new());
    x::Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .expect("exr writes");
    bytes.into_inner()
}

/// The files to damage.
fn originals() -> &'static [Vec<u8>] {
    static FILES: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    FILES.get_or_init(|| {
        let mut layered = LayeredImage::new(6, 4);
        let data = |n: usize| (0..24 * n).map(|i| i as f32 / 50.0).collect::<Vec<f32>>();
        layered
            .layers
            .push(Layer::new("", &["R", "G", "B"], data(3)));
        layered
            .layers
            .push(Layer::new("albedo", &["R", "G", "B"], data(3)));
        layered
            .layers
            .push(Layer::new("normal", &["X", "Y", "Z"], data(3)));
        layered.layers.push(Layer::new("depth", &["Z"], data(1)));
        let tiles = x::Blocks::Tiles(x::Vec2(4, 2));
        vec![
            layered.encode_exr().expect("ember's EXR"),
            exr_with(true, x::Compression::Uncompressed, x::Blocks::ScanLines),
            exr_with(false, x::Compression::RLE, x::Blocks::ScanLines),
            exr_with(true, x::Compression::ZIP1, tiles),
            exr_with(false, x::Compression::PIZ, x::Blocks::ScanLines),
            exr_with(true, x::Compression::ZIP16, tiles),
            common::exr::claiming(100_000, 100_000),
            common::exr::claiming(3, 2),
        ]
    })
}

#[derive(Clone, Debug)]
enum Edit {
    /// An i32 at this offset (within the header's first 400 bytes) replaced.
    Int(usize, i32),
    /// A byte replaced.
    Byte(usize, u8),
    /// Cut to this length.
    Cut(usize),
    /// Bytes `from..from + len` repeated at their end.
    Repeat(usize, usize),
    /// Bytes appended.
    Append(Vec<u8>),
}

fn edit() -> impl Strategy<Value = Edit> {
    let hostile = prop_oneof![
        Just(0i32),
        Just(-1),
        Just(1),
        Just(i32::MAX),
        Just(i32::MIN),
        Just(65535),
        Just(100_000),
        Just(1 << 20),
        any::<i32>(),
    ];
    prop_oneof![
        3 => (0usize..400, hostile).prop_map(|(at, v)| Edit::Int(at, v)),
        3 => (any::<usize>(), any::<u8>()).prop_map(|(at, v)| Edit::Byte(at, v)),
        1 => any::<usize>().prop_map(Edit::Cut),
        1 => (any::<usize>(), 1usize..64).prop_map(|(at, n)| Edit::Repeat(at, n)),
        1 => prop::collection::vec(any::<u8>(), 1..32).prop_map(Edit::Append),
    ]
}

#[derive(Debug)]
struct Input {
    original: usize,
    edits: Vec<Edit>,
}

fn input() -> impl Strategy<Value = Input> {
    (0..originals().len(), prop::collection::vec(edit(), 0..5))
        .prop_map(|(original, edits)| Input { original, edits })
}

impl Input {
    fn bytes(&self) -> Vec<u8> {
        let mut b = originals()[self.original].clone();
        for edit in &self.edits {
            let len = b.len().max(1);
            match *edit {
                Edit::Int(at, v) if at + 4 <= b.len() => {
                    b[at..at + 4].copy_from_slice(&v.to_le_bytes())
                }
                Edit::Int(..) => {}
                Edit::Byte(at, v) => {
                    if let Some(byte) = b.get_mut(at % len) {
                        *byte = v;
                    }
                }
                Edit::Cut(at) => b.truncate(at % len),
                Edit::Repeat(at, n) => {
                    let start = at % len;
                    let end = (start + n).min(b.len());
                    let copy = b[start..end].to_vec();
                    b.splice(end..end, copy);
                }
                Edit::Append(ref extra) => b.extend_from_slice(extra),
            }
        }
        b
    }
}

fn path() -> PathBuf {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    let dir = DIR.get_or_init(|| tempfile::tempdir().unwrap());
    let thread = format!("{:?}", std::thread::current().id());
    let name: String = thread.chars().filter(char::is_ascii_alphanumeric).collect();
    dir.path().join(format!("fuzz-{name}.exr"))
}

fn check(input: &Input) -> Result<bool, TestCaseError> {
    let path = path();
    std::fs::write(&path, input.bytes()).unwrap();
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    let one_line = |e: &dyn std::fmt::Display| -> Result<(), TestCaseError> {
        let line = e.to_string();
        prop_assert!(!line.contains('\n'), "{line:?}");
        prop_assert!(line.contains(&name), "{line:?} should name the file");
        Ok(())
    };
    let size = LayeredImage::exr_size(&path);
    match LayeredImage::read_exr(&path) {
        Err(e) => one_line(&e).map(|()| false),
        Ok(image) => {
            let size = size.map_err(|e| TestCaseError::fail(format!("read, but: {e}")))?;
            prop_assert_eq!((image.width, image.height), (size.width, size.height));
            let pixels = image.width as usize * image.height as usize;
            let mut floats = 0u64;
            for layer in &image.layers {
                prop_assert_eq!(layer.data.len(), pixels * layer.channels.len());
                floats += layer.data.len() as u64;
            }
            prop_assert!(4 * floats <= size.read_bytes, "{} floats, {size:?}", floats);
            Ok(true)
        }
    }
}

#[test]
fn fuzz_exr() {
    // Set before any reading, in this target's only test.
    std::env::set_var("EMBER_MEMORY_LIMIT", MEMORY_LIMIT);
    for (i, bytes) in originals().iter().enumerate() {
        let path = path();
        std::fs::write(&path, bytes).unwrap();
        let read = LayeredImage::read_exr(&path);
        // The whole files read, but for the one claiming 100000x100000, which is
        // refused for its memory before any pixel is read.
        match i {
            6 => assert!(
                read.as_ref()
                    .is_err_and(|e| e.to_string().contains("memory")),
                "{read:?}"
            ),
            _ => assert!(read.is_ok(), "original {i}: {read:?}"),
        }
    }
    common::fuzz::run("fuzz_exr", "read", input(), check);
}
