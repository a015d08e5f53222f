//! `--exposure` and `--tonemap` shape 8-bit outputs only: EXR stays linear radiance,
//! and the default (clip, 0 EV) is the plain sRGB encoding images always had.

use std::path::Path;
use std::process::Command;

fn render(out: &Path, extra: &[&str]) {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj");
    let status = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(scene)
        .args(["--width", "16", "--height", "16", "--spp", "2", "-o"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
}

#[test]
fn tone_mapping_changes_png_and_never_exr() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name);
    render(&p("plain.exr"), &[]);
    render(&p("aces.exr"), &["--tonemap", "aces", "--exposure", "2"]);
    let read = |name: &str| std::fs::read(p(name)).unwrap();
    assert_eq!(read("plain.exr"), read("aces.exr"), "EXR must stay linear");
    render(&p("plain.png"), &[]);
    render(&p("clip.png"), &["--tonemap", "clip", "--exposure", "0"]);
    assert_eq!(
        read("plain.png"),
        read("clip.png"),
        "the default is clip at 0 EV"
    );
    for curve in ["aces", "agx"] {
        render(&p("curve.png"), &["--tonemap", curve]);
        assert_ne!(read("plain.png"), read("curve.png"), "{curve} changes PNG");
    }
    // Brighter by a stop: no pixel gets darker, some get brighter.
    render(&p("up.png"), &["--exposure", "1"]);
    let (a, b) = (read("plain.png"), read("up.png"));
    let decode = |bytes: &[u8]| image::load_from_memory(bytes).unwrap().to_rgb8().into_raw();
    let (a, b) = (decode(&a), decode(&b));
    assert!(a.iter().zip(&b).all(|(x, y)| y >= x));
    assert!(a.iter().zip(&b).any(|(x, y)| y > x));
}
