//! Fuzzing scene files on the stable toolchain (proptest): text made of scene-file
//! pieces (tables, every key of `[render]`, `[environment]` and `[camera.NAME]`, the
//! entries' transforms with values at the edge of `f32`, `[[light]]` tables of every
//! type and key, values of every TOML type, broken syntax, stray bytes).
//!
//! What must hold: the reader and the loader never panic, and every error is one line
//! `FILE:LINE:COLUMN: KEY: ...` inside the file; a scene that loads is placed within
//! what rays can carry, and renders on both backends (Embree must not abort on a ray
//! an instance takes past its limit). One input in eight also goes through `ember
//! render` (the settings are checked there, as its flags): it renders, or fails with
//! one `error:` line and exit status 1, and leaves no image.
//!
//! `EMBER_FUZZ_SECONDS=N` runs for N seconds and prints how many inputs were tried;
//! `EMBER_FUZZ_BIN=PATH` runs that `ember` instead of this build's (a copy, so that a
//! long run goes on while the tree is rebuilt).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use ember::scene::SceneFile;
use proptest::prelude::*;

fn cornell() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj");
    format!("{:?}", path.to_str().unwrap())
}

fn number() -> impl Strategy<Value = String> + Clone {
    prop_oneof![
        Just("0".to_string()),
        Just("-1.5".to_string()),
        Just("1e30".to_string()),
        Just("1e-19".to_string()),
        Just("1e-12".to_string()),
        Just("1e17".to_string()),
        Just("3.4e38".to_string()),
        Just("-0.0".to_string()),
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("4".to_string()),
        Just("100000".to_string()),
        (-5.0f32..5.0).prop_map(|v| format!("{v:?}")),
    ]
}

/// A value of any TOML type, as a setting's key may be (wrongly) given.
fn value() -> impl Strategy<Value = String> + Clone {
    let vec3 = (number(), number(), number()).prop_map(|(a, b, c)| format!("[{a}, {b}, {c}]"));
    prop_oneof![
        Just("true".to_string()),
        Just("false".to_string()),
        number(),
        vec3,
        Just("[1, 2]".to_string()),
        Just("[]".to_string()),
        Just("\"mis\"".to_string()),
        Just("\"albedo\"".to_string()),
        Just("[\"albedo\", \"normal\", \"albedo\"]".to_string()),
        Just("\"a\"".to_string()),
        Just("\"none.exr\"".to_string()),
        Just("{ a = 1 }".to_string()),
        Just("1979-05-27".to_string()),
    ]
}

/// Keys of every table, a few that belong elsewhere or nowhere.
const KEYS: [&str; 35] = [
    "spp",
    "width",
    "height",
    "integrator",
    "denoise",
    "guiding",
    "guiding-iterations",
    "noise-threshold",
    "min-spp",
    "time-limit",
    "aov",
    "max-depth",
    "seed",
    "threads",
    "light-sampler",
    "accel",
    "tonemap",
    "exposure",
    "camera",
    "guide-image",
    "guide-pixel",
    "guide-sky",
    "checkpoint-every",
    "output",
    "shard",
    "background",
    "env",
    "env-scale",
    "env-rotate",
    "eye",
    "look-at",
    "up",
    "fov",
    "ortho-height",
    "zoom",
];

/// The keys of `[[light]]` tables, and its types (with one it lacks).
const LIGHT_KEYS: [&str; 15] = [
    "intensity",
    "power",
    "candela",
    "irradiance",
    "lux",
    "radiance",
    "inner-angle",
    "outer-angle",
    "angular-diameter",
    "radius",
    "size",
    "direction",
    "color",
    "type",
    "name",
];
const LIGHT_TYPES: [&str; 7] = [
    "point",
    "spot",
    "directional",
    "quad",
    "disk",
    "sphere",
    "lamp",
];

/// A `[[light]]` table's pieces: its header, a type, and its keys with values of any
/// kind.
fn light_piece() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("[[light]]\n".to_string()),
        prop::sample::select(&LIGHT_TYPES[..]).prop_map(|t| format!("[[light]]\ntype = \"{t}\"\n")),
        (prop::sample::select(&LIGHT_KEYS[..]), number()).prop_map(|(k, v)| format!("{k} = {v}\n")),
        (prop::sample::select(&LIGHT_KEYS[..]), value()).prop_map(|(k, v)| format!("{k} = {v}\n")),
    ]
}

fn piece() -> impl Strategy<Value = String> {
    let obj = cornell();
    let vec3 = (number(), number(), number()).prop_map(|(a, b, c)| format!("[{a}, {b}, {c}]"));
    let row = (number(), number(), number(), number())
        .prop_map(|(a, b, c, d)| format!("[{a}, {b}, {c}, {d}]"));
    let matrix = prop::collection::vec(row, 0..6).prop_map(|rows| rows.join(", "));
    prop_oneof![
        Just("[[obj]]\n".to_string()),
        Just("[[instance]]\nobj = \"box\"\n".to_string()),
        Just("[[instance]]\n".to_string()),
        Just("[render]\n".to_string()),
        Just("[environment]\n".to_string()),
        Just("[camera.a]\n".to_string()),
        Just("[camera.b]\n".to_string()),
        Just(format!("file = {obj}\n")),
        Just("file = \"missing.obj\"\n".to_string()),
        Just("name = \"box\"\n".to_string()),
        Just("obj = \"box\"\n".to_string()),
        vec3.clone().prop_map(|v| format!("translate = {v}\n")),
        vec3.clone().prop_map(|v| format!("scale = {v}\n")),
        number().prop_map(|v| format!("scale = {v}\n")),
        (vec3, number()).prop_map(|(a, d)| format!("rotate = {{ axis = {a}, degrees = {d} }}\n")),
        matrix.prop_map(|m| format!("matrix = [{m}]\n")),
        (prop::sample::select(&KEYS[..]), value()).prop_map(|(k, v)| format!("{k} = {v}\n")),
        Just("translate = \"far\"\n".to_string()),
        light_piece(),
        Just("[[obj\n".to_string()),
        Just("= 3\n".to_string()),
        Just("é = \"ü\"\n".to_string()),
        "[ -~]{0,12}\n",
    ]
}

#[derive(Debug)]
struct Input {
    text: String,
    /// Also run `ember render` on it.
    cli: bool,
}

fn input() -> impl Strategy<Value = Input> {
    (any::<bool>(), prop::collection::vec(piece(), 0..14), 0u8..8).prop_map(
        |(start_valid, pieces, cli)| {
            // Half the files start as a valid scene, so that the loader, the transforms
            // and the settings are reached too, not only the reader's errors.
            let start = if start_valid {
                format!("[[obj]]\nfile = {}\nname = \"box\"\n", cornell())
            } else {
                String::new()
            };
            Input {
                text: start + &pieces.concat(),
                cli: cli == 0,
            }
        },
    )
}

fn check_error(e: &ember::scene::SceneFileError, text: &str) -> Result<(), TestCaseError> {
    let line = e.to_string();
    let lines = text.lines().count().max(1);
    prop_assert!(!line.contains('\n'), "{line:?}");
    prop_assert!(line.starts_with("fuzz.toml:"), "{line:?}");
    prop_assert!(
        e.line >= 1 && e.line <= lines + 1 && e.column >= 1,
        "{line:?} in\n{text}"
    );
    Ok(())
}

/// `ember render` of the file in a fresh folder: an image, or one error line, exit
/// status 1 and no image.
fn check_cli(text: &str) -> Result<(), TestCaseError> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("fuzz.toml"), text).unwrap();
    let ember =
        std::env::var_os("EMBER_FUZZ_BIN").unwrap_or_else(|| env!("CARGO_BIN_EXE_ember").into());
    let out = Command::new(ember)
        .args([
            "render",
            "fuzz.toml",
            "-o",
            "out.png",
            "--width",
            "4",
            "--height",
            "4",
        ])
        .args(["--spp", "1", "--max-depth", "2", "--threads", "1"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let made: Vec<PathBuf> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap() != "fuzz.toml")
        .collect();
    if out.status.success() {
        prop_assert!(dir.path().join("out.png").is_file(), "{stderr}\n{text}");
        return Ok(());
    }
    prop_assert_eq!(out.status.code(), Some(1), "{}\n{}", stderr, text);
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    prop_assert_eq!(lines.len(), 1, "one error line: {}\n{}", stderr, text);
    prop_assert!(lines[0].starts_with("error: "), "{}\n{}", stderr, text);
    prop_assert!(made.is_empty(), "left {:?}: {}\n{}", made, stderr, text);
    Ok(())
}

fn check(input: &Input) -> Result<bool, TestCaseError> {
    let text = &input.text;
    if input.cli {
        check_cli(text)?;
    }
    let file = match SceneFile::parse(Path::new("fuzz.toml"), text.clone()) {
        Ok(file) => file,
        Err(e) => return check_error(&e, text).map(|()| false),
    };
    let (scene, _) = match file.load_scene(&Default::default()) {
        Ok(loaded) => loaded,
        Err(e) => return check_error(&e, text).map(|()| false),
    };
    let (lo, hi) = scene.bounds();
    prop_assert!(lo.is_finite() && hi.is_finite(), "{}", text);
    common::fuzz::render_both(&scene)?;
    Ok(true)
}

#[test]
fn fuzz_scene_file() {
    common::fuzz::run("fuzz_scene_file", "loaded and rendered", input(), check);
}
