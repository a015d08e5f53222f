//! What a new user meets: help and clap's own messages, inputs in formats ember does not
//! read, the automatic camera printed as flags (which reproduce the render exactly) and
//! its note when it sees only the outside of a closed room, `ember info SCENE`, `-q`,
//! and `--json` on success and on failure.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn ember(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ember"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn mesh(name: &str) -> String {
    let path: PathBuf = [env!("CARGO_MANIFEST_DIR"), "meshes", name]
        .iter()
        .collect();
    path.display().to_string()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A tiny render's flags.
const SMALL: [&str; 6] = ["--width", "40", "--height", "32", "--spp", "2"];

#[test]
fn bare_ember_prints_help_and_clap_keeps_its_suggestions() {
    let dir = tempfile::tempdir().unwrap();
    let out = ember(&[], dir.path());
    assert_eq!(out.status.code(), Some(2));
    let help = stderr(&out);
    for text in ["Usage: ember", "render", "merge", "info", "-q, --quiet"] {
        assert!(help.contains(text), "{help}");
    }
    let out = ember(&["render", "x.obj", "--spps", "4"], dir.path());
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.starts_with("error: unexpected argument '--spps'"),
        "{err}"
    );
    assert!(err.contains("a similar argument exists: '--spp'"), "{err}");
    assert!(err.contains("Usage: ember render"), "{err}");
    let out = ember(&["render", "x.obj", "--integrator", "path"], dir.path());
    let err = stderr(&out);
    assert!(
        err.contains("[possible values: bsdf, light, mixture, mis]"),
        "{err}"
    );
    // -h is the summary, --help the whole text.
    let short = stdout(&ember(&["render", "-h"], dir.path()));
    let long = stdout(&ember(&["render", "--help"], dir.path()));
    assert!(short.contains("Camera:") && short.contains("Long renders and shards:"));
    assert!(
        long.len() > short.len() + 1000,
        "{} vs {}",
        long.len(),
        short.len()
    );
}

#[test]
fn other_formats_are_named_with_what_ember_reads() {
    let dir = tempfile::tempdir().unwrap();
    for (name, what) in [
        ("model.stl", "not STL"),
        ("photo.png", "not images"),
        ("model.xyz", "not .xyz files"),
        ("model", "this file has none"),
    ] {
        std::fs::write(dir.path().join(name), "ply\nformat ascii 1.0\n").unwrap();
        for command in ["render", "info"] {
            let out = ember(&[command, name], dir.path());
            let err = stderr(&out);
            assert!(!out.status.success());
            assert_eq!(err.lines().count(), 1, "{err}");
            assert!(
                err.starts_with(&format!(
                    "error: {name}: ember reads OBJ (.obj), glTF 2.0 (.gltf, .glb), PLY (.ply)"
                )),
                "{err}"
            );
            assert!(err.contains(what), "{err}");
        }
    }
    // A missing file says why once.
    let out = ember(&["render", "missing.obj"], dir.path());
    let err = stderr(&out);
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
}

/// The `camera (...): FLAGS` line of a render's stderr, split into arguments.
fn camera_flags(err: &str) -> Vec<String> {
    let line = err
        .lines()
        .find(|l| l.starts_with("camera ("))
        .unwrap_or_else(|| panic!("no camera line in {err}"));
    let flags = line.split_once("): ").unwrap().1;
    flags.split_whitespace().map(String::from).collect()
}

#[test]
fn the_automatic_camera_printed_as_flags_gives_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = mesh("CornellBox-Sphere.obj");
    let out = ember(
        &[&["render", &scene, "-o", "auto.exr"][..], &SMALL].concat(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("camera (automatic, framing the scene's bounds from +z): --eye "));
    // The box is open towards the camera and lit: no note.
    assert!(!err.contains("note:"), "{err}");
    let flags = camera_flags(&err);
    let mut args: Vec<&str> = vec!["render", &scene, "-o", "given.exr"];
    args.extend(SMALL);
    args.extend(flags.iter().map(String::as_str));
    let out = ember(&args, dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        !stderr(&out).contains("camera ("),
        "a given camera is not printed"
    );
    let read = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
    assert_eq!(read("auto.exr"), read("given.exr"));
}

#[test]
fn a_closed_room_seen_from_outside_gets_one_note() {
    let dir = tempfile::tempdir().unwrap();
    let room = mesh("many-light-room.obj");
    let out = ember(
        &[&["render", &room, "-o", "room.png"][..], &SMALL].concat(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    let notes: Vec<&str> = err.lines().filter(|l| l.starts_with("note:")).collect();
    assert_eq!(notes.len(), 1, "{err}");
    assert!(
        notes[0].contains("sees only the outside of a closed model"),
        "{err}"
    );
    assert!(
        notes[0].contains("(0,0,0) to (20,3,8)"),
        "the bounds: {err}"
    );
    // The note is right: the image is black.
    let image = ember::image::Image::load(&dir.path().join("room.png")).unwrap();
    assert_eq!(image.mean(), glam::Vec3::ZERO);
    // From inside, the room is lit and there is no note.
    let inside = ["--eye", "10,1.5,4", "--look-at", "0,1.5,4"];
    let out = ember(
        &[&["render", &room, "-o", "in.png"][..], &SMALL, &inside].concat(),
        dir.path(),
    );
    assert!(!stderr(&out).contains("note:"), "{}", stderr(&out));
}

#[test]
fn info_shows_what_render_reads() {
    let dir = tempfile::tempdir().unwrap();
    let out = ember(&["info", &mesh("CornellBox-Original.obj")], dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    for line in [
        "triangles: 36 (",
        "materials: 9",
        "emitters: 2 emissive triangles in 1 material",
        "sky: none",
        "textures: none",
        "bounds: (-1.02, 0, -1.04) to (1, 1.99, 0.99)",
        "camera (automatic, framing the bounds from +z): --eye ",
        "vertex colours: none",
    ] {
        assert!(text.contains(line), "no {line:?} in {text}");
    }
    // The light's power: π · area · luminance of Ke, its area from the mesh.
    let (scene, _) = ember::scene::load_obj(Path::new(&mesh("CornellBox-Original.obj"))).unwrap();
    let area: f64 = scene
        .emitters
        .iter()
        .map(|&t| {
            let [a, b, c] = scene.mesh.vertices(t);
            0.5 * f64::from((b - a).cross(c - a).length())
        })
        .sum();
    let luminance = 0.2126 * 17.0 + 0.7152 * 12.0 + 0.0722 * 4.0;
    let power = std::f64::consts::PI * area * luminance;
    assert!(
        text.contains(&format!("area {area:.4}, power {power:.4}")),
        "{text}"
    );

    // A scene file: its camera, its placements; an unlit OBJ: the white sky.
    let gallery: PathBuf = [env!("CARGO_MANIFEST_DIR"), "scenes", "cornell-gallery.toml"]
        .iter()
        .collect();
    let out = ember(&["info", gallery.to_str().unwrap()], dir.path());
    let text = stdout(&out);
    assert!(
        text.contains("camera (the scene file's): --eye 0,2.15,9 --look-at 0,2.15,0"),
        "{text}"
    );
    assert!(text.contains("6 placements put"), "{text}");
    std::fs::write(
        dir.path().join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let text = stdout(&ember(&["info", "tri.obj"], dir.path()));
    assert!(
        text.contains("sky: uniform white (the scene has no emitter"),
        "{text}"
    );
}

#[test]
fn quiet_keeps_warnings_and_errors_only() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.obj"),
        "mtllib absent.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let out = ember(
        &[&["-q", "render", "s.obj", "-o", "s.png"][..], &SMALL].concat(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.lines().all(|l| l.starts_with("warning:")), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    // -q after the command, too.
    let out = ember(
        &[&["render", "s.obj", "-o", "s.png", "-q"][..], &SMALL].concat(),
        dir.path(),
    );
    assert_eq!(stderr(&out).lines().count(), 1, "{}", stderr(&out));
}

#[test]
fn json_is_one_object_on_success_and_nothing_on_failure() {
    let dir = tempfile::tempdir().unwrap();
    let scene = mesh("CornellBox-Original.obj");
    let out = ember(
        &[&["render", &scene, "-o", "a.exr", "--json"][..], &SMALL].concat(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert_eq!(doc["width"], 40);
    assert_eq!(doc["height"], 32);
    assert_eq!(doc["spp_min"], 2);
    assert_eq!(doc["finished"], true);
    assert_eq!(doc["triangles"], 36);
    assert!(doc["mrays_per_second"].as_f64().unwrap() > 0.0);
    assert!(doc["camera"]["flags"]
        .as_str()
        .unwrap()
        .starts_with("--eye "));
    assert_eq!(doc["camera"]["automatic"], true);
    // The human summary is still on stderr.
    assert!(stderr(&out).contains("wrote a.exr"));

    // compare and merge speak JSON too.
    let out = ember(&["compare", "a.exr", "a.exr", "--json"], dir.path());
    let doc: Value = serde_json::from_slice(&out.stdout).expect("compare's JSON");
    assert_eq!(doc["mse"], 0.0);
    assert_eq!(doc["psnr"], Value::Null);
    for i in 0..2 {
        let shard = format!("{i}/2");
        let part = format!("p{i}.ember");
        let args = [
            &["render", &scene, "--shard", &shard, "-o", &part][..],
            &SMALL,
        ]
        .concat();
        assert!(ember(&args, dir.path()).status.success());
    }
    let out = ember(
        &["merge", "p0.ember", "p1.ember", "-o", "m.exr", "--json"],
        dir.path(),
    );
    let doc: Value = serde_json::from_slice(&out.stdout).expect("merge's JSON");
    assert_eq!(doc["spp"], 2);
    assert_eq!(doc["shards"].as_array().unwrap().len(), 2);

    // A failing run: its error on stderr in one line, nothing on stdout.
    std::fs::write(dir.path().join("bad.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
    for args in [
        &["render", "bad.obj", "--json", "-o", "b.png"][..],
        &["compare", "a.exr", "missing.exr", "--json"][..],
        &["merge", "p0.ember", "-o", "m2.exr", "--json"][..],
    ] {
        let out = ember(args, dir.path());
        assert!(!out.status.success());
        assert!(out.stdout.is_empty(), "{:?}: {}", args, stdout(&out));
        assert_eq!(stderr(&out).lines().count(), 1, "{}", stderr(&out));
    }
}
