//! The CLI on broken input: one clear error line, a non-zero exit, no panic, and no
//! output file left behind.

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::ember_in as ember;

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// Asserts the run failed the way a user should see it: exit code non-zero, exactly
/// one line on stderr naming the problem, nothing on stdout, no panic text.
fn assert_one_line_error(out: &Output, expect_in_message: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "exit status {:?}, stderr {stderr}",
        out.status
    );
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "want one error line, got: {stderr}");
    assert!(lines[0].starts_with("error:"), "{stderr}");
    assert!(
        lines[0]
            .to_lowercase()
            .contains(&expect_in_message.to_lowercase()),
        "message {:?} should mention {expect_in_message:?}",
        lines[0]
    );
    for bad in ["panicked", "RUST_BACKTRACE", "stack backtrace"] {
        assert!(!stderr.contains(bad), "{stderr}");
    }
    assert!(out.stdout.is_empty());
}

/// Asserts the run failed with clap's own message for a bad flag: exit code 2, the
/// first line `error: ...` naming the flag, then only clap's help lines (a tip, the
/// usage, where to read more), nothing on stdout, no panic text.
fn assert_flag_error(out: &Output, expect_in_message: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert!(lines[0].starts_with("error:"), "{stderr}");
    assert!(lines[0].contains(expect_in_message), "{stderr}");
    for line in &lines[1..] {
        let clap_line = ["  tip:", "Usage:", "For more information", "  ["]
            .iter()
            .any(|start| line.starts_with(start));
        assert!(clap_line, "not one of clap's lines: {line:?} in {stderr}");
    }
    for bad in ["panicked", "RUST_BACKTRACE", "stack backtrace"] {
        assert!(!stderr.contains(bad), "{stderr}");
    }
    assert!(out.stdout.is_empty());
}

/// Writes `files` into a fresh directory and renders `scene.obj` there.
fn render_files(files: &[(&str, &[u8])], extra: &[&str], expect: &str) {
    let dir = tempfile::tempdir().unwrap();
    for (name, content) in files {
        std::fs::write(dir.path().join(name), content).unwrap();
    }
    let mut args = vec![
        "render",
        "scene.obj",
        "-o",
        "out.png",
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
    ];
    args.extend_from_slice(extra);
    let out = ember(&args, dir.path());
    assert_one_line_error(&out, expect);
    assert_no_output(dir.path());
}

fn assert_no_output(dir: &Path) {
    let left: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name.starts_with("out") || name.starts_with(".ember")
        })
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn empty_file() {
    render_files(&[("scene.obj", b"")], &[], "no triangles");
}

#[test]
fn truncated_file() {
    render_files(
        &[("scene.obj", b"v 0 0 0\nv 1 0 0\nv 0 1")],
        &[],
        "scene.obj",
    );
}

#[test]
fn binary_garbage() {
    let garbage: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    render_files(&[("scene.obj", &garbage)], &[], "scene.obj");
}

#[test]
fn index_zero() {
    render_files(
        &[("scene.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")],
        &[],
        "line 4: index 0 is invalid",
    );
}

#[test]
fn index_past_the_end() {
    render_files(
        &[("scene.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")],
        &[],
        "out of range",
    );
}

#[test]
fn relative_index_before_the_start() {
    render_files(
        &[("scene.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n")],
        &[],
        "out of range",
    );
}

#[test]
fn normal_index_out_of_range() {
    render_files(
        &[(
            "scene.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n",
        )],
        &[],
        "out of range",
    );
}

#[test]
fn nan_coordinate() {
    render_files(
        &[("scene.obj", b"v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n")],
        &[],
        "vertex 2 is not finite",
    );
}

#[test]
fn infinite_coordinate() {
    render_files(
        &[("scene.obj", b"v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n")],
        &[],
        "vertex 3 is not finite",
    );
}

#[test]
fn nan_normal() {
    render_files(
        &[(
            "scene.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 NaN 1\nf 1//1 2//1 3//1\n",
        )],
        &[],
        "normal",
    );
}

#[test]
fn only_degenerate_triangles() {
    render_files(
        &[("scene.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")],
        &[],
        "degenerate",
    );
}

/// Absent inputs are warnings by default (`tests/downloaded_scenes.rs`); `--strict`
/// makes them errors.
#[test]
fn missing_mtllib_with_strict() {
    let obj = format!("mtllib missing.mtl\nusemtl red\n{TRIANGLE}");
    render_files(
        &[("scene.obj", obj.as_bytes())],
        &["--strict"],
        "missing.mtl",
    );
}

#[test]
fn malformed_mtl() {
    let obj = format!("mtllib bad.mtl\nusemtl red\n{TRIANGLE}");
    render_files(
        &[
            ("scene.obj", obj.as_bytes()),
            ("bad.mtl", b"newmtl red\nKd 1 zebra 0\n"),
        ],
        &[],
        "bad.mtl:2: material \"red\": Kd: expected a finite number, found \"zebra\"",
    );
}

#[test]
fn missing_texture_with_strict() {
    let obj = format!("mtllib t.mtl\nusemtl wood\n{TRIANGLE}");
    render_files(
        &[
            ("scene.obj", obj.as_bytes()),
            ("t.mtl", b"newmtl wood\nKd 1 1 1\nmap_Kd wood.png\n"),
        ],
        &["--strict"],
        "wood.png",
    );
}

#[test]
fn texture_that_is_not_an_image() {
    let obj = format!("mtllib t.mtl\nusemtl wood\n{TRIANGLE}");
    render_files(
        &[
            ("scene.obj", obj.as_bytes()),
            ("t.mtl", b"newmtl wood\nKd 1 1 1\nmap_Kd wood.png\n"),
            ("wood.png", b"this is not a png"),
        ],
        &[],
        "wood.png",
    );
}

#[test]
fn missing_normal_map_with_strict() {
    let obj = format!("mtllib t.mtl\nusemtl wood\n{TRIANGLE}");
    render_files(
        &[
            ("scene.obj", obj.as_bytes()),
            (
                "t.mtl",
                b"newmtl wood\nKd 1 1 1\nnorm -bm 1 wood normals.png\n",
            ),
        ],
        &["--strict"],
        "wood normals.png",
    );
}

#[test]
fn unknown_texture_option() {
    let obj = format!("mtllib t.mtl\nusemtl wood\n{TRIANGLE}");
    render_files(
        &[
            ("scene.obj", obj.as_bytes()),
            ("t.mtl", b"newmtl wood\nKd 1 1 1\nbump -bogus 2 h.png\n"),
        ],
        &[],
        "-bogus",
    );
}

#[test]
fn metallic_out_of_range() {
    let obj = format!("mtllib t.mtl\nusemtl wood\n{TRIANGLE}");
    render_files(
        &[
            ("scene.obj", obj.as_bytes()),
            ("t.mtl", b"newmtl wood\nKd 1 1 1\nPm 1.5\n"),
        ],
        &[],
        "Pm",
    );
}

#[test]
fn missing_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = ember(&["render", "nowhere.obj", "-o", "out.png"], dir.path());
    assert_one_line_error(&out, "nowhere.obj");
    assert_no_output(dir.path());
}

#[test]
fn directory_as_scene() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("scene.obj")).unwrap();
    let out = ember(&["render", "scene.obj", "-o", "out.png"], dir.path());
    assert_one_line_error(&out, "directory");
    assert_no_output(dir.path());
}

#[test]
fn unwritable_output_path() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.obj"), TRIANGLE).unwrap();
    let out = ember(
        &[
            "render",
            "scene.obj",
            "-o",
            "no/such/dir/out.png",
            "--spp",
            "1",
        ],
        dir.path(),
    );
    assert_one_line_error(&out, "cannot write");
    // A directory where the file should go.
    std::fs::create_dir(dir.path().join("out.png")).unwrap();
    let out = ember(
        &["render", "scene.obj", "-o", "out.png", "--spp", "1"],
        dir.path(),
    );
    assert_one_line_error(&out, "directory");
}

#[test]
fn unknown_output_format() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.obj"), TRIANGLE).unwrap();
    let out = ember(
        &["render", "scene.obj", "-o", "out.jpg", "--spp", "1"],
        dir.path(),
    );
    assert_one_line_error(&out, "unsupported output format");
    assert_no_output(dir.path());
}

#[test]
fn nonsense_flag_values() {
    for (flag, value, expect) in [
        ("--spp", "0", "--spp"),
        ("--spp=-3", "", "--spp"),
        ("--width", "abc", "--width"),
        ("--height", "0", "--height"),
        ("--width", "100000", "--width"),
        ("--fov", "180", "--fov"),
        ("--fov", "0", "--fov"),
        ("--fov", "nan", "--fov"),
        ("--max-depth", "0", "--max-depth"),
        ("--threads", "0", "--threads"),
        ("--eye", "1,2", "--eye"),
        ("--eye", "1,2,nan", "--eye"),
        ("--seed", "x", "--seed"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("scene.obj"), TRIANGLE).unwrap();
        let args: Vec<&str> = ["render", "scene.obj", "-o", "out.png", flag, value]
            .into_iter()
            .filter(|a| !a.is_empty())
            .collect();
        assert_flag_error(&ember(&args, dir.path()), expect);
        assert_no_output(dir.path());
    }
}

#[test]
fn camera_that_cannot_see() {
    // Eye and target coincide, or up is parallel to the view direction.
    render_files(
        &[("scene.obj", TRIANGLE.as_bytes())],
        &["--eye", "0,0,1", "--look-at", "0,0,1"],
        "camera",
    );
    render_files(
        &[("scene.obj", TRIANGLE.as_bytes())],
        &["--eye", "0,2,0", "--look-at", "0,0,0"],
        "camera",
    );
}

#[test]
fn a_good_scene_renders_and_leaves_only_its_image() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.obj"), TRIANGLE).unwrap();
    let out = ember(
        &[
            "render",
            "scene.obj",
            "-o",
            "out.exr",
            "--width",
            "16",
            "--height",
            "8",
            "--spp",
            "2",
        ],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let mut names = names;
    names.sort();
    assert_eq!(names, ["out.exr", "scene.obj"]);
    let image = ember::image::Image::load(&dir.path().join("out.exr")).unwrap();
    assert_eq!((image.width, image.height), (16, 8));
    // The scene has no emitter, so a white sky lights it: rays that miss read 1.
    assert!(image.pixels.contains(&glam::Vec3::ONE));
    assert!(String::from_utf8_lossy(&out.stderr).contains("white sky"));
}
