//! Multi-layer EXR (src/image/layers.rs): what is written comes back bit for bit, the
//! channels carry OpenEXR's `layer.channel` names, and a plain EXR reader sees the main
//! image.

use ember::image::layers::names;
use ember::image::{Image, Layer, LayerError, LayeredImage};
use glam::Vec3;

const W: u32 = 7;
const H: u32 = 5;

/// Values no rounding would keep: negatives, subnormals, huge, tiny, and a different
/// value in every channel of every pixel.
fn awkward(n: usize, salt: u32) -> Vec<f32> {
    (0..n as u32)
        .map(|i| {
            let h = (i.wrapping_mul(2_654_435_761) ^ salt).rotate_left(7);
            match i % 5 {
                0 => f32::from_bits(h & 0x007f_ffff), // subnormal
                1 => -(h as f32) * 1e-9,
                2 => 3.0e38 * ((h % 1000) as f32 / 1000.0),
                _ => f32::from_bits((h & 0x3fff_ffff) | 0x0080_0000),
            }
        })
        .collect()
}

fn sample_image() -> LayeredImage {
    let px = (W * H) as usize;
    let mut image = LayeredImage::new(W, H);
    image.set(Layer::new(names::MAIN, &names::RGB, awkward(3 * px, 1)));
    image.set(Layer::new(names::ALBEDO, &names::RGB, awkward(3 * px, 2)));
    image.set(Layer::new(names::DEPTH, &["Z"], awkward(px, 3)));
    image.set(Layer::new(names::NORMAL, &names::XYZ, awkward(3 * px, 4)));
    image.set(Layer::new(names::SPP, &["Y"], awkward(px, 5)));
    image.set(Layer::new(names::VARIANCE, &names::RGB, awkward(3 * px, 6)));
    image
}

fn bits(data: &[f32]) -> Vec<u32> {
    data.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn write_then_read_gives_the_same_channels_and_bits() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("passes.exr");
    let written = sample_image();
    written.write_exr(&path).unwrap();
    let read = LayeredImage::read_exr(&path).unwrap();
    assert_eq!((read.width, read.height), (W, H));
    // Sorted by name with the main image first: the order sample_image() uses.
    let names: Vec<&str> = read.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["", "albedo", "depth", "normal", "spp", "variance"]);
    for (w, r) in written.layers.iter().zip(&read.layers) {
        assert_eq!(w.channels, r.channels, "layer {:?}", w.name);
        assert_eq!(bits(&w.data), bits(&r.data), "layer {:?}", w.name);
    }
}

#[test]
fn channels_carry_openexr_layer_names() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("passes.exr");
    sample_image().write_exr(&path).unwrap();
    let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
    assert_eq!(meta.headers.len(), 1, "one part");
    let mut found: Vec<String> = meta.headers[0]
        .channels
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    found.sort();
    let mut expected = vec![
        "R",
        "G",
        "B",
        "albedo.R",
        "albedo.G",
        "albedo.B",
        "depth.Z",
        "normal.X",
        "normal.Y",
        "normal.Z",
        "spp.Y",
        "variance.R",
        "variance.G",
        "variance.B",
    ];
    expected.sort();
    assert_eq!(found, expected);
    for c in &meta.headers[0].channels.list {
        assert_eq!(
            c.sample_type,
            exr::meta::attribute::SampleType::F32,
            "{}",
            c.name
        );
    }
}

#[test]
fn a_single_layer_reader_sees_the_main_image() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("passes.exr");
    let main = Image {
        width: W,
        height: H,
        pixels: (0..W * H)
            .map(|i| Vec3::new(i as f32, 0.5 * i as f32, 1.0 / (1 + i) as f32))
            .collect(),
    };
    let mut layered = sample_image();
    layered.set(Layer::from_image(names::MAIN, names::RGB, &main));
    layered.write_exr(&path).unwrap();
    // The image crate's EXR decoder knows nothing of layers and reads R, G, B.
    assert_eq!(Image::load(&path).unwrap(), main);
    assert_eq!(
        LayeredImage::read_exr(&path).unwrap().main_image().unwrap(),
        main
    );
}

#[test]
fn asking_for_a_missing_or_mismatched_layer_is_an_error() {
    let image = sample_image();
    let missing = image.image(names::NOISY, names::RGB).unwrap_err();
    assert!(matches!(missing, LayerError::Missing { .. }), "{missing}");
    assert!(missing.to_string().contains("\"noisy\""), "{missing}");
    let wrong = image.image(names::NORMAL, names::RGB).unwrap_err();
    assert!(matches!(wrong, LayerError::Channels { .. }), "{wrong}");
}

#[test]
fn a_malformed_image_is_refused_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.exr");
    let mut short = LayeredImage::new(W, H);
    short.set(Layer::new(names::MAIN, &names::RGB, vec![0.0; 5]));
    let dotted = {
        let mut i = LayeredImage::new(1, 1);
        i.set(Layer::new("a", &["x.R"], vec![0.0]));
        i
    };
    for (image, says) in [(short, "values"), (dotted, "dot")] {
        let err = image.write_exr(&path).unwrap_err().to_string();
        assert!(err.contains(says) && err.contains("bad.exr"), "{err}");
        assert!(!path.exists());
    }
}

/// The same image gives the same bytes: exrs compresses blocks on several threads and,
/// unless told the order, writes each as it finishes. An image of many 64×64 tiles
/// whose blocks take different times to compress (noise beside flat areas) is written
/// repeatedly, as a plain EXR and with layers, and every encoding must be the first.
#[test]
fn the_same_image_always_encodes_to_the_same_bytes() {
    let (w, h) = (640u32, 384u32);
    let px = (w * h) as usize;
    let mut noise = awkward(3 * px, 9);
    // Flat bands compress almost at once; noisy ones do not.
    for (i, v) in noise.iter_mut().enumerate() {
        if (i / 3 / w as usize / 64).is_multiple_of(2) {
            *v = 0.25;
        }
    }
    let image = Image {
        width: w,
        height: h,
        pixels: noise.chunks_exact(3).map(Vec3::from_slice).collect(),
    };
    let mut layered = LayeredImage::new(w, h);
    layered.set(Layer::from_image(names::MAIN, names::RGB, &image));
    layered.set(Layer::new(names::DEPTH, &["Z"], awkward(px, 10)));
    let plain = image.encode(ember::image::OutputFormat::Exr).unwrap();
    let first = layered.encode_exr().unwrap();
    for _ in 0..12 {
        assert!(image.encode(ember::image::OutputFormat::Exr).unwrap() == plain);
        assert!(layered.encode_exr().unwrap() == first);
    }
    // What was written is what the image holds.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plain.exr");
    std::fs::write(&path, &plain).unwrap();
    assert_eq!(Image::load(&path).unwrap(), image);
}
