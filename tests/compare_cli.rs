//! `ember compare A B`: the metrics it prints and its one-line errors.

use std::path::Path;
use std::process::Command;

use ember::image::Image;
use glam::Vec3;

fn ember(args: &[&Path]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("compare")
        .args(args)
        .output()
        .expect("ember runs")
}

#[test]
fn prints_mse_relmse_and_psnr_of_two_exr_files() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    let mut image = Image::new(4, 2);
    let mut reference = Image::new(4, 2);
    reference.pixels.fill(Vec3::splat(0.1));
    image.pixels.fill(Vec3::splat(0.1));
    image.pixels[0] = Vec3::splat(0.5);
    image.save(&a).unwrap();
    reference.save(&b).unwrap();
    let out = ember(&[&a, &b]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    // One pixel of 8 off by 0.4: MSE 0.16/8 = 0.02, relMSE 0.02/0.02 = 1, PSNR 10·log10(50).
    assert!(text.contains("MSE 2.000000e-2"), "{text}");
    assert!(text.contains("relMSE 1.000000e0"), "{text}");
    assert!(text.contains("PSNR 16.99 dB"), "{text}");
}

#[test]
fn different_sizes_are_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.hdr"));
    Image::new(4, 2).save(&a).unwrap();
    Image::new(2, 4).save(&b).unwrap();
    let out = ember(&[&a, &b]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("differ in size") && err.contains("4x2"),
        "{err}"
    );
    let missing = ember(&[&dir.path().join("nope.exr"), &b]);
    assert!(!missing.status.success());
    assert_eq!(String::from_utf8_lossy(&missing.stderr).lines().count(), 1);
}

/// `--downsample N` judges an image N times the reference's size by its N×N block
/// means: a 4x2 image whose 2x2 blocks average to the 2x1 reference compares as equal;
/// a factor that does not divide the size is a one-line error.
#[test]
fn downsample_compares_block_means() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    let mut image = Image::new(4, 2);
    for (i, p) in image.pixels.iter_mut().enumerate() {
        // Blocks {0, 1, 4, 5} and {2, 3, 6, 7}: means 0.25 and 0.45.
        *p = Vec3::splat(0.1 * i as f32);
    }
    let mut reference = Image::new(2, 1);
    reference.pixels = vec![Vec3::splat(0.25), Vec3::splat(0.45)];
    image.save(&a).unwrap();
    reference.save(&b).unwrap();
    let run = |factor: &str| {
        Command::new(env!("CARGO_BIN_EXE_ember"))
            .arg("compare")
            .args([&a, &b])
            .args(["--downsample", factor])
            .output()
            .expect("ember runs")
    };
    let out = run("2");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    // Equal up to the rounding of the f32 inputs.
    let rel: f64 = text
        .split("relMSE ")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(rel < 1e-12, "{text}");
    let bad = run("3");
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("--downsample 3"), "{err}");
}

/// `ember render` with the reference's camera flags writes a linear EXR that lines up
/// with Mitsuba's reference: same framing, row order and scale (a wrong camera, row
/// order or a gamma would leave a relMSE far above the noise of 2 spp).
#[test]
fn render_reproduces_the_reference_camera() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // Shipped with the repository, so this test runs in every clone.
    let reference = root.join("tests/data/references/cornell-box/cornell_ref_8192spp.exr");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cornell.exr");
    let status = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(root.join("meshes/CornellBox-Original.obj"))
        .args(["--eye", "0,1,3.9", "--look-at", "0,1,0", "--fov", "40"])
        .args([
            "--width",
            "512",
            "--height",
            "512",
            "--max-depth",
            "8",
            "--spp",
            "2",
        ])
        .args(["--integrator", "mis", "-o"])
        .arg(&out)
        .output()
        .expect("ember runs");
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let image = Image::load(&out).unwrap();
    let reference = Image::load(&reference).unwrap();
    let error = ember::image::compare(&image, &reference).unwrap();
    // MIS scores relMSE ≈ 0.18 / spp here; a misaligned image scores above 1.
    assert!(error.rel_mse < 0.2, "relMSE {} at 2 spp", error.rel_mse);
    let (mean, expected) = (image.mean(), reference.mean());
    assert!(
        ((mean - expected) / expected).abs().max_element() < 0.03,
        "mean {mean} vs reference {expected}"
    );
}
