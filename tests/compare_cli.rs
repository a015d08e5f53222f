//! `ember compare A B`: the metrics it prints and its one-line errors.

use std::path::Path;
use std::process::Command;

use ember::film::Film;
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
    let mut image = Film::new(4, 2);
    let mut reference = Film::new(4, 2);
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
    Film::new(4, 2).save(&a).unwrap();
    Film::new(2, 4).save(&b).unwrap();
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
