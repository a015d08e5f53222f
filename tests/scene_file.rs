//! `ember render SCENE.toml`: a scene file gives the image its flags give, byte for
//! byte; the command line overrides the file; paths are relative to the file; every
//! error is one line naming the file, line, column and key, with no output left.

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{ember_in as ember, CORNELL_CAMERA};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

const SMALL: [&str; 6] = ["--width", "48", "--height", "40", "--spp", "4"];

#[test]
fn the_shipped_cornell_scene_file_renders_the_image_of_its_flags() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/cornell-box.toml");
    let obj = repo().join("meshes/CornellBox-Original.obj");
    for accel in ["embree", "bvh"] {
        let mut from_file = vec!["render", scene.to_str().unwrap(), "-o", "file.png"];
        from_file.extend(SMALL);
        from_file.extend(["--accel", accel]);
        ok(&ember(&from_file, dir.path()));
        let mut from_flags = vec!["render", obj.to_str().unwrap(), "-o", "flags.png"];
        from_flags.extend(CORNELL_CAMERA);
        from_flags.extend(SMALL);
        from_flags.extend(["--accel", accel]);
        ok(&ember(&from_flags, dir.path()));
        let a = std::fs::read(dir.path().join("file.png")).unwrap();
        let b = std::fs::read(dir.path().join("flags.png")).unwrap();
        assert!(
            a == b,
            "{accel}: the scene file's image differs from the flags'"
        );
    }
}

/// A scene file in `dir` placing the Cornell box (by an absolute path) with `extra`.
fn write_scene(dir: &Path, extra: &str) -> PathBuf {
    let obj = repo().join("meshes/CornellBox-Original.obj");
    let text = format!("[[obj]]\nfile = {:?}\n{extra}", obj.to_str().unwrap());
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn command_line_flags_override_the_file_and_cameras_are_chosen_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(
        dir.path(),
        "[render]\nspp = 2\nseed = 9\nwidth = 30\nheight = 20\ncamera = \"near\"\n\
         [camera.near]\neye = [0, 1, 3.9]\nlook-at = [0, 1, 0]\n\
         [camera.far]\neye = [0, 1, 8]\nlook-at = [0, 1, 0]\nfov = 30\n",
    );
    let scene = scene.to_str().unwrap();
    let obj = repo().join("meshes/CornellBox-Original.obj");
    let obj = obj.to_str().unwrap();
    let render = |args: &[&str], out: &str| {
        let mut all = vec!["render"];
        all.extend_from_slice(args);
        all.extend(["-o", out]);
        ok(&ember(&all, dir.path()));
        std::fs::read(dir.path().join(out)).unwrap()
    };
    // The same render from the OBJ and flags alone.
    let flags = |seed: &str, camera: &[&str], out: &str| {
        let mut args = vec![
            obj, "--spp", "2", "--seed", seed, "--width", "30", "--height", "20",
        ];
        args.extend_from_slice(camera);
        render(&args, out)
    };
    let near = ["--eye", "0,1,3.9", "--look-at", "0,1,0"];
    // The file's own settings and its default camera.
    assert!(render(&[scene], "a.png") == flags("9", &near, "b.png"));
    // The command line's seed and camera win over the file's.
    let far = ["--eye", "0,1,8", "--look-at", "0,1,0", "--fov", "30"];
    let overridden = render(&[scene, "--seed", "4", "--camera", "far"], "c.png");
    assert!(overridden == flags("4", &far, "d.png"));
    // And a single camera flag overrides that key of the chosen camera only.
    let fov = render(&[scene, "--fov", "30"], "e.png");
    let near_30 = ["--eye", "0,1,3.9", "--look-at", "0,1,0", "--fov", "30"];
    assert!(fov == flags("9", &near_30, "f.png"));
}

#[test]
fn environment_paths_are_relative_to_the_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("scenes");
    std::fs::create_dir(&sub).unwrap();
    let map = repo().join("tests/data/env-convention/mitsuba-rotate-90-side.exr");
    std::fs::copy(&map, sub.join("sky.exr")).unwrap();
    let scene = write_scene(&sub, "[environment]\nenv = \"sky.exr\"\nenv-scale = 0.5\n");
    // Run from the parent folder: `sky.exr` is found beside the scene file.
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", "file.png"];
    args.extend(SMALL);
    ok(&ember(&args, dir.path()));
    let obj = repo().join("meshes/CornellBox-Original.obj");
    let mut args = vec!["render", obj.to_str().unwrap(), "-o", "flags.png"];
    args.extend(["--env", map.to_str().unwrap(), "--env-scale", "0.5"]);
    args.extend(SMALL);
    ok(&ember(&args, dir.path()));
    let a = std::fs::read(dir.path().join("file.png")).unwrap();
    let b = std::fs::read(dir.path().join("flags.png")).unwrap();
    assert!(a == b, "the scene file's sky differs from --env's");
}

/// Renders the scene file `text` in a fresh folder and checks the failure: one line,
/// `error: scene.toml:LINE:COLUMN: KEY: ...`, a non-zero exit, no image left.
fn assert_file_error(text: &str, at: (usize, usize), key: &str, words: &str) {
    assert_file_error_with(text, &[], at, key, words)
}

/// [`assert_file_error`] with `extra` flags on the command line.
fn assert_file_error_with(
    text: &str,
    extra: &[&str],
    (line, column): (usize, usize),
    key: &str,
    words: &str,
) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), text).unwrap();
    // A map for the command line's --env (`env.exr`), made beside the file.
    let map = ember::image::Image {
        width: 4,
        height: 2,
        pixels: vec![glam::Vec3::ONE; 8],
    };
    map.save(&dir.path().join("env.exr")).unwrap();
    let mut args = vec!["render", "scene.toml", "-o", "out.png"];
    args.extend(SMALL);
    args.extend(extra);
    let out = ember(&args, dir.path());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{text}: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{text}: want one line, got {stderr}");
    let want = format!("error: scene.toml:{line}:{column}: {key}: ");
    assert!(
        lines[0].starts_with(&want),
        "{text}: {:?} should start {want:?}",
        lines[0]
    );
    assert!(
        lines[0].contains(words),
        "{text}: {:?} should say {words:?}",
        lines[0]
    );
    assert!(!stderr.contains("panicked"));
    assert!(!dir.path().join("out.png").exists());
}

#[test]
fn every_scene_file_error_is_one_line_with_file_line_column_and_key() {
    let obj = repo().join("meshes/CornellBox-Original.obj");
    let obj = format!("file = {:?}\n", obj.to_str().unwrap());
    let cases: Vec<(String, (usize, usize), &str, &str)> = vec![
        // An unknown key of an [[obj]].
        (format!("[[obj]]\n{obj}colour = 1\n"), (3, 1), "colour", "unknown field"),
        // A wrong type (the array's length).
        (format!("[[obj]]\n{obj}translate = [1, 2]\n"), (3, 13), "translate", "length 3"),
        // A missing OBJ, relative to the file.
        ("[[obj]]\nfile = \"nowhere.obj\"\n".into(), (2, 8), "obj.file", "nowhere.obj"),
        // A flag's own check on a setting's value.
        (format!("[render]\nspp = 0\n[[obj]]\n{obj}"), (2, 1), "render.spp", "--spp"),
        (format!("[render]\nspp = \"many\"\n[[obj]]\n{obj}"), (2, 1), "render.spp", "many"),
        (format!("[render]\nwidht = 3\n[[obj]]\n{obj}"), (2, 1), "render.widht", "unknown setting"),
        (format!("[render]\noutput = \"x.png\"\n[[obj]]\n{obj}"), (2, 1), "render.output", "command line"),
        (format!("[camera.a]\neye = [0, 1]\n[[obj]]\n{obj}"), (2, 1), "camera.a.eye", "a list of 3 numbers, not a list of 2"),
        (format!("[camera.a]\nzoom = 2\n[[obj]]\n{obj}"), (2, 1), "camera.a.zoom", "unknown key"),
        (format!("[environment]\nenv = \"none.exr\"\n[[obj]]\n{obj}"), (2, 1), "environment.env", "none.exr"),
        // Transforms.
        (format!("[[obj]]\n{obj}scale = [1, 0, 1]\n"), (3, 9), "obj.scale", "non-zero"),
        (
            format!("[[obj]]\n{obj}translate = [1, 0, 0]\nmatrix = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n"),
            (4, 10),
            "obj.matrix",
            "not both",
        ),
        (
            format!("[[obj]]\n{obj}matrix = [[1,0,0,0],[0,1,0,0],[0,0,0,0],[0,0,0,1]]\n"),
            (3, 10),
            "obj.matrix",
            "singular",
        ),
        // Instances.
        (format!("[[obj]]\n{obj}[[instance]]\nobj = \"chair\"\n"), (4, 7), "instance.obj", "chair"),
        // Syntax.
        (format!("[[obj]\n{obj}"), (1, 7), "(syntax)", "expected"),
    ];
    for (text, at, key, words) in cases {
        assert_file_error(&text, at, key, words);
    }
}

/// Issue 48, class 3: every table is strict whether this run uses it or not (an
/// `[environment]` the command line's `--env` replaces, a camera not rendered); a
/// value must be of its flag's type (`spp = false` is no longer dropped); and the
/// errors that come from several settings together (a companion missing, a
/// conflict), a negative background and an unknown `[render] camera` are located too.
#[test]
fn settings_are_strict_in_every_table_and_located() {
    let obj = repo().join("meshes/CornellBox-Original.obj");
    let obj = format!("[[obj]]\nfile = {:?}\n", obj.to_str().unwrap());
    let env = ["--env", "env.exr"];
    // (file, command-line flags, line and column, key, words of the error)
    type Case<'a> = (String, &'a [&'a str], (usize, usize), &'a str, &'a str);
    let cases: Vec<Case> = vec![
        // Unknown keys where this run would not look.
        (
            format!("[environment]\nbackgrond = [1, 1, 1]\n{obj}"),
            &env,
            (2, 1),
            "environment.backgrond",
            "unknown key",
        ),
        (
            format!("[render]\ncamera = \"a\"\n[camera.a]\nfov = 30\n[camera.b]\nzoom = 2\n{obj}"),
            &[],
            (6, 1),
            "camera.b.zoom",
            "unknown key",
        ),
        (
            format!("[camera.b]\nfov = \"wide\"\n{obj}"),
            &["--camera", "b"],
            (2, 1),
            "camera.b.fov",
            "a number",
        ),
        // Values of the wrong type, `false` on a key that is not a switch among them.
        (
            format!("[render]\nspp = false\n{obj}"),
            &[],
            (2, 1),
            "render.spp",
            "takes a number, not false",
        ),
        (
            format!("[render]\nseed = true\n{obj}"),
            &[],
            (2, 1),
            "render.seed",
            "not true",
        ),
        (
            format!("[render]\ndenoise = 1\n{obj}"),
            &[],
            (2, 1),
            "render.denoise",
            "true or false",
        ),
        (
            format!("[render]\nintegrator = 3\n{obj}"),
            &[],
            (2, 1),
            "render.integrator",
            "a string",
        ),
        (
            format!("[render]\naov = [\"albedo\", 3]\n{obj}"),
            &[],
            (2, 1),
            "render.aov",
            "a name",
        ),
        (
            format!("[environment]\nbackground = \"1,1,1\"\n{obj}"),
            &[],
            (2, 1),
            "environment.background",
            "a list of 3 numbers",
        ),
        // Settings that need a companion, or conflict.
        (
            format!("[environment]\nenv-scale = 2\n{obj}"),
            &[],
            (2, 1),
            "environment.env-scale",
            "needs `env`",
        ),
        (
            format!("[render]\nmin-spp = 4\n{obj}"),
            &[],
            (2, 1),
            "render.min-spp",
            "needs `noise-threshold`",
        ),
        (
            format!("[render]\nguiding-iterations = 2\n{obj}"),
            &[],
            (2, 1),
            "render.guiding-iterations",
            "needs `guiding`",
        ),
        (
            format!("[environment]\nbackground = [1, 1, 1]\nenv = \"env.exr\"\n{obj}"),
            &[],
            (3, 1),
            "environment.env",
            "cannot be given with `background`",
        ),
        // A negative sky, an unknown camera, cameras to choose from.
        (
            format!("[environment]\nbackground = [1, -1, 1]\n{obj}"),
            &[],
            (2, 1),
            "environment.background",
            "negative",
        ),
        (
            format!("[render]\ncamera = \"top\"\n{obj}"),
            &[],
            (2, 1),
            "render.camera",
            "names the camera \"top\", but has no such camera",
        ),
        (
            format!("[camera.a]\nfov = 30\n[camera.b]\nfov = 40\n{obj}"),
            &[],
            (1, 1),
            "render.camera",
            "choose one",
        ),
    ];
    for (text, extra, at, key, words) in cases {
        assert_file_error_with(&text, extra, at, key, words);
    }
    // What the command line gives a companion or a choice for renders.
    let dir = tempfile::tempdir().unwrap();
    let map = ember::image::Image {
        width: 4,
        height: 2,
        pixels: vec![glam::Vec3::ONE; 8],
    };
    map.save(&dir.path().join("env.exr")).unwrap();
    for (text, extra) in [
        (format!("[environment]\nenv-scale = 2\n{obj}"), &env[..]),
        (
            format!("[render]\nmin-spp = 4\n{obj}"),
            &["--noise-threshold", "0.5"][..],
        ),
        (format!("[render]\nguiding = false\n{obj}"), &[][..]),
    ] {
        std::fs::write(dir.path().join("scene.toml"), &text).unwrap();
        let mut args = vec!["render", "scene.toml", "-o", "out.png"];
        args.extend(SMALL);
        args.extend(extra);
        ok(&ember(&args, dir.path()));
    }
}

#[test]
fn a_cameras_lens_keys_are_the_lens_flags() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(
        dir.path(),
        "[camera.dof]\neye = [0, 1, 3.9]\nlook-at = [0, 1, 0]\naperture = 0.1\nfocus-distance = 3\n",
    );
    let obj = repo().join("meshes/CornellBox-Original.obj");
    let mut file = vec!["render", scene.to_str().unwrap(), "-o", "file.png"];
    file.extend(SMALL);
    ok(&ember(&file, dir.path()));
    let mut flags = vec!["render", obj.to_str().unwrap(), "-o", "flags.png"];
    flags.extend(["--eye", "0,1,3.9", "--look-at", "0,1,0"]);
    flags.extend(["--aperture", "0.1", "--focus-distance", "3"]);
    flags.extend(SMALL);
    ok(&ember(&flags, dir.path()));
    let mut pinhole = vec!["render", obj.to_str().unwrap(), "-o", "pinhole.png"];
    pinhole.extend(["--eye", "0,1,3.9", "--look-at", "0,1,0"]);
    pinhole.extend(SMALL);
    ok(&ember(&pinhole, dir.path()));
    let read = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
    assert!(read("file.png") == read("flags.png"));
    assert!(read("file.png") != read("pinhole.png"));
}

/// An instanced scene says in its loading line how many placements it has and how many
/// triangles they put in the world: the OBJ's own count times the placements.
#[test]
fn the_loading_line_counts_the_placements() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(
        dir.path(),
        "name = \"box\"\n[[instance]]\nobj = \"box\"\ntranslate = [3, 0, 0]\n\
         [[instance]]\nobj = \"box\"\nscale = -1\n",
    );
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", "out.png"];
    args.extend(SMALL);
    let out = ember(&args, dir.path());
    ok(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let line = stderr
        .lines()
        .find(|l| l.starts_with("loaded "))
        .expect("a loading line");
    let count = |after: &str| -> u64 {
        let rest = &line[line.find(after).unwrap_or_else(|| panic!("{line}")) + after.len()..];
        rest.split(|c: char| !c.is_ascii_digit())
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let triangles = count(": ");
    assert_eq!(count(", placed "), 3, "{line}");
    assert_eq!(count(" times ("), 3 * triangles, "{line}");
}

/// Copies the folder `from` into `to`, recursively.
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}

/// Every scene file in `scenes/` renders from the repository alone: copied with
/// `meshes/` into an empty folder (so nothing beside the repository, such as a
/// `../shared`, can be reached), each renders at a small size to an image that is not
/// black, and at least one of them places OBJs by `[[instance]]`.
#[test]
fn every_shipped_scene_renders_from_the_repository_alone() {
    let dir = tempfile::tempdir().unwrap();
    copy_tree(&repo().join("scenes"), &dir.path().join("scenes"));
    copy_tree(&repo().join("meshes"), &dir.path().join("meshes"));
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(dir.path().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 2, "scenes/ holds {scenes:?}");
    let mut instanced = 0;
    for scene in &scenes {
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", "out.exr"];
        args.extend(["--width", "32", "--height", "24", "--spp", "8"]);
        let out = ember(&args, dir.path());
        ok(&out);
        let image = ember::image::Image::load(&dir.path().join("out.exr")).unwrap();
        let lit = image
            .pixels
            .iter()
            .filter(|p| p.max_element() > 0.0)
            .count();
        // Mostly lit: the scenes fill their frames, with gaps between placed models.
        assert!(
            4 * lit >= image.pixels.len() && image.mean().max_element() > 0.01,
            "{}: {lit} of {} pixels lit, mean {}",
            scene.display(),
            image.pixels.len(),
            image.mean()
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        if stderr
            .lines()
            .any(|l| l.starts_with("loaded ") && l.contains(", placed "))
        {
            instanced += 1;
        }
    }
    assert!(
        instanced >= 1,
        "no scene in scenes/ places OBJs by instances"
    );
}
