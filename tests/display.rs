//! `ember render --display HOST:PORT` against a listener that speaks tev's protocol (as
//! tev's `Ipc.h` defines it): the viewer is told of the image once and then receives its
//! tiles; the last image it holds is the image written; the image written is the same
//! as without a viewer; a viewer that is absent or goes away costs one warning.

use std::io::Read;
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::thread;

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj")
}

/// A small render of the Cornell box to `out`, with `extra` flags.
fn render(out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(cornell())
        .args([
            "--width", "150", "--height", "140", "--spp", "8", "--seed", "3",
        ])
        .arg("-o")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

/// What the viewer was sent.
#[derive(Debug, Default)]
struct Received {
    name: String,
    size: (usize, usize),
    creates: usize,
    updates: usize,
    /// The image as the updates left it, RGB interleaved.
    pixels: Vec<f32>,
}

/// Reads a NUL-terminated string at `*at`.
fn string(b: &[u8], at: &mut usize) -> String {
    let end = b[*at..]
        .iter()
        .position(|&c| c == 0)
        .expect("NUL-terminated")
        + *at;
    let s = String::from_utf8(b[*at..end].to_vec()).unwrap();
    *at = end + 1;
    s
}

fn i32_at(b: &[u8], at: &mut usize) -> i32 {
    let v = i32::from_le_bytes(b[*at..*at + 4].try_into().unwrap());
    *at += 4;
    v
}

fn i64_at(b: &[u8], at: &mut usize) -> i64 {
    let v = i64::from_le_bytes(b[*at..*at + 8].try_into().unwrap());
    *at += 8;
    v
}

/// Decodes every packet of one connection until it closes.
fn decode(mut stream: TcpStream) -> Received {
    let mut got = Received::default();
    loop {
        let mut len = [0u8; 4];
        if stream.read_exact(&mut len).is_err() {
            return got;
        }
        let len = u32::from_le_bytes(len) as usize;
        let mut b = vec![0u8; len - 4];
        stream.read_exact(&mut b).expect("a whole packet");
        let mut at = 2;
        match b[0] {
            4 => {
                got.creates += 1;
                got.name = string(&b, &mut at);
                let (w, h) = (i32_at(&b, &mut at) as usize, i32_at(&b, &mut at) as usize);
                let channels = i32_at(&b, &mut at);
                let names: Vec<String> = (0..channels).map(|_| string(&b, &mut at)).collect();
                assert_eq!(names, ["R", "G", "B"]);
                got.size = (w, h);
                got.pixels = vec![f32::NAN; w * h * 3];
            }
            6 => {
                got.updates += 1;
                assert_eq!(string(&b, &mut at), got.name);
                let channels = i32_at(&b, &mut at) as usize;
                let names: Vec<String> = (0..channels).map(|_| string(&b, &mut at)).collect();
                assert_eq!(names, ["R", "G", "B"]);
                let [x, y, w, h] = [0; 4].map(|_| i32_at(&b, &mut at) as usize);
                let offsets: Vec<i64> = (0..channels).map(|_| i64_at(&b, &mut at)).collect();
                let strides: Vec<i64> = (0..channels).map(|_| i64_at(&b, &mut at)).collect();
                assert_eq!(b.len() - at, w * h * channels * 4, "the tile's values");
                assert!(x + w <= got.size.0 && y + h <= got.size.1);
                let value = |i: usize| {
                    f32::from_le_bytes(b[at + 4 * i..at + 4 * i + 4].try_into().unwrap())
                };
                for c in 0..channels {
                    for ty in 0..h {
                        for tx in 0..w {
                            let i = offsets[c] as usize + (ty * w + tx) * strides[c] as usize;
                            got.pixels[((y + ty) * got.size.0 + x + tx) * 3 + c] = value(i);
                        }
                    }
                }
            }
            other => panic!("unexpected packet type {other}"),
        }
    }
}

/// A listener on a free local port, decoding its first connection on a thread.
fn viewer() -> (String, thread::JoinHandle<Received>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let handle = thread::spawn(move || decode(listener.accept().unwrap().0));
    (address, handle)
}

fn warnings(out: &Output) -> Vec<String> {
    String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .map(String::from)
        .collect()
}

/// The render succeeded with exactly one warning, which says each of `words`.
fn assert_one_warning(out: &Output, words: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let warnings = warnings(out);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    for word in words {
        assert!(warnings[0].contains(word), "{warnings:?}");
    }
}

#[test]
fn the_viewer_ends_with_the_image_written_and_the_image_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let (address, viewer) = viewer();
    let shown = dir.path().join("shown.exr");
    let out = render(&shown, &["--display", &address]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(warnings(&out).is_empty(), "{:?}", warnings(&out));
    let got = viewer.join().unwrap();
    assert_eq!(got.creates, 1);
    assert_eq!(got.name, "shown.exr");
    assert_eq!(got.size, (150, 140));
    // Tiles of 128: 2 across, 2 down, for at least the final image.
    assert!(got.updates >= 4, "{} updates", got.updates);

    let plain = dir.path().join("plain.exr");
    let out = render(&plain, &[]);
    assert!(out.status.success());
    let written = std::fs::read(&shown).unwrap();
    assert_eq!(
        written,
        std::fs::read(&plain).unwrap(),
        "--display changed the image"
    );

    let image = ember::image::Image::load(&shown).unwrap();
    let expected: Vec<f32> = image.pixels.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    assert_eq!(got.pixels.len(), expected.len());
    let differ = got
        .pixels
        .iter()
        .zip(&expected)
        .filter(|(a, b)| a.to_bits() != b.to_bits());
    assert_eq!(
        differ.count(),
        0,
        "the viewer's last image is not the one written"
    );
}

#[test]
fn an_absent_viewer_costs_one_warning() {
    // A port nothing listens on: bound, then released.
    let address = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .to_string();
    let dir = tempfile::tempdir().unwrap();
    let out = render(&dir.path().join("x.png"), &["--display", &address]);
    assert_one_warning(&out, &["tev viewer", &address]);
    assert!(dir.path().join("x.png").is_file());
}

#[test]
fn a_viewer_that_goes_away_costs_one_warning() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    // Reads the first packet, then closes the connection and stops listening.
    let viewer = thread::spawn(move || {
        let (mut stream, _) = listener.accept().unwrap();
        let mut len = [0u8; 4];
        stream.read_exact(&mut len).unwrap();
        let mut rest = vec![0u8; u32::from_le_bytes(len) as usize - 4];
        stream.read_exact(&mut rest).unwrap();
        assert_eq!(rest[0], 4, "CreateImage first");
    });
    let dir = tempfile::tempdir().unwrap();
    // Long enough that updates follow the viewer's going.
    let out = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(cornell())
        .args(["--width", "400", "--height", "400", "--spp", "64"])
        .args(["--display", &address, "-o"])
        .arg(dir.path().join("x.png"))
        .output()
        .unwrap();
    viewer.join().unwrap();
    assert_one_warning(&out, &["went away"]);
}

#[test]
fn a_malformed_address_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = render(&dir.path().join("x.png"), &["--display", "localhost"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("error: invalid value 'localhost' for '--display"),
        "{err}"
    );
    assert!(err.contains("HOST:PORT"), "{err}");
    assert!(!dir.path().join("x.png").exists());
}
