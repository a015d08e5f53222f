//! `--env` orients a latitude-longitude map as documented, checked against an
//! independent renderer: Mitsuba 3's `envmap` turned by R degrees about +y is ember's
//! map turned by R − 180 (Mitsuba puts the map's left edge at −z, ember its middle).
//! The references in `tests/data/env-convention/` are Mitsuba's renders of a map in
//! which every direction has its own colour (`make.py` there made them), so a map that
//! is turned, mirrored or flipped cannot match.

use std::path::{Path, PathBuf};
use std::process::Command;

use ember::image::{compare, Image};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/env-convention")
        .join(name)
}

/// relMSE of ember's view of the map along `look_at`, turned by `rotate` degrees,
/// against the Mitsuba render `reference`.
fn error_against(reference: &str, rotate: f32, look_at: &str) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    // A speck far behind the camera: the scene must have a triangle, the view only sky.
    let obj = dir.path().join("speck.obj");
    std::fs::write(
        &obj,
        "v 0 -100 100\nv 0.01 -100 100\nv 0 -99.99 100\nf 1 2 3\n",
    )
    .unwrap();
    let out = dir.path().join("view.exr");
    let status = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(&obj)
        .arg("--env")
        .arg(data("sky.exr"))
        .args(["--env-rotate", &rotate.to_string(), "--eye", "0,0,0"])
        .args([
            "--look-at",
            look_at,
            "--fov",
            "60",
            "--width",
            "48",
            "--height",
            "32",
        ])
        .args(["--spp", "16", "--max-depth", "1", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let image = Image::load(&out).unwrap();
    let reference = Image::load(&data(reference)).expect("the reference ships in tests/data");
    compare(&image, &reference).unwrap().rel_mse
}

#[test]
fn maps_are_oriented_like_the_independent_renderers_turned_half_a_turn() {
    for (view, look_at) in [("front", "0,0,-1"), ("side", "1,0.3,0")] {
        for (mitsuba, rotate) in [("identity", 0.0f32), ("rotate-90", 90.0)] {
            let reference = format!("mitsuba-{mitsuba}-{view}.exr");
            // The two renderers differ only in texel interpolation (bilinear there,
            // nearest here): about 2e-5 on this smooth map.
            let matched = error_against(&reference, rotate - 180.0, look_at);
            assert!(matched < 2e-4, "{reference}: relMSE {matched:.2e}");
            // The test has teeth: the same rotation without the half turn is far off.
            let unmatched = error_against(&reference, rotate, look_at);
            assert!(
                unmatched > 0.1,
                "{reference}: unturned relMSE {unmatched:.2e}"
            );
        }
    }
}
