//! An ember built without Open Image Denoise (`cargo test --no-default-features`): it
//! still renders (the other tests), and denoising fails in one line that says how to
//! get OIDN. With the `denoise` feature, tests/denoise.rs tests denoising instead.
#![cfg(not(feature = "denoise"))]

use ember::denoise::{available, denoise, DenoiseError};
use ember::image::Image;
use glam::Vec3;

#[test]
fn the_library_says_how_to_get_oidn() {
    let image = Image {
        width: 2,
        height: 2,
        pixels: vec![Vec3::ONE; 4],
    };
    let err = denoise(&image, None).unwrap_err();
    assert!(matches!(err, DenoiseError::NotBuilt), "{err}");
    assert!(err.to_string().contains("scripts/setup.sh"), "{err}");
    assert!(matches!(available(), Err(DenoiseError::NotBuilt)));
}

#[test]
fn ember_denoise_and_info_say_it_is_not_built_in() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.exr");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_ember"))
        .args([
            "denoise".as_ref(),
            dir.path().join("in.exr").as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("built without Open Image Denoise") && stderr.contains("scripts/setup.sh"),
        "{stderr}"
    );
    assert!(!out.exists());
    let info = std::process::Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("info")
        .output()
        .unwrap();
    assert!(info.status.success());
    assert!(String::from_utf8_lossy(&info.stdout)
        .contains("denoiser: none: this ember was built without Open Image Denoise"));
}
