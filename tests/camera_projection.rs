//! Orthographic cameras and a glTF camera's aspect ratio against geometry: parallel rays
//! that cross the view in scene units, a square of side `s` that fills `s/height` of
//! the image at any depth (scalar and wavefront engines alike), glTF orthographic
//! cameras (`xmag`, `ymag`) chosen by `--camera`, the image size an `aspectRatio`
//! completes, and glTF cameras a scene file places.

mod common;

use std::path::Path;

use common::gltf::GltfBuilder;
use common::{ember_in, emitting_square, Built};
use ember::image::Image;
use ember::integrator::IntegratorKind;
use ember::render::{render, Engine, RenderSettings};
use ember::scene::{CameraSettings, Lens, Projection};
use glam::Vec3;
use serde_json::json;

/// A camera at (0, 0, 5) looking along −z.
fn looking_down_z(projection: Projection) -> CameraSettings {
    CameraSettings {
        eye: Vec3::new(0.0, 0.0, 5.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        projection,
        lens: Lens::PINHOLE,
    }
}

/// Emitted radiance only (one path segment), 4 samples a pixel.
fn shoot(built: &Built, camera: &CameraSettings, size: (u32, u32), engine: Engine) -> Image {
    let settings = RenderSettings {
        width: size.0,
        height: size.1,
        spp: 4,
        max_depth: 1,
        seed: 3,
        integrator: IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine,
    };
    camera.validate().unwrap();
    let camera = camera.camera(size.0, size.1);
    render(&built.scene, &built.accel, &camera, &settings, &|_| {}).0
}

/// The pixels an emitter of radiance 1 lights: how many, and how many rows and
/// columns they span. Every pixel is lit or dark whole (the squares' edges fall on
/// pixel edges), so none lies between.
fn lit(image: &Image) -> (usize, usize, usize) {
    let w = image.width as usize;
    let mut rows = std::collections::BTreeSet::new();
    let mut columns = std::collections::BTreeSet::new();
    let mut count = 0;
    for (i, p) in image.pixels.iter().enumerate() {
        assert!(
            p.x < 1e-6 || (p.x - 1.0).abs() < 1e-6,
            "pixel {i} is {}: partly lit",
            p.x
        );
        if p.x > 0.5 {
            count += 1;
            rows.insert(i / w);
            columns.insert(i % w);
        }
    }
    (count, rows.len(), columns.len())
}

#[test]
fn orthographic_rays_are_parallel_and_cross_the_view_in_scene_units() {
    let settings = CameraSettings {
        eye: Vec3::new(1.0, 2.0, 3.0),
        look_at: Vec3::new(1.0, 2.0, 0.0),
        up: Vec3::Y,
        projection: Projection::Orthographic { height: 4.0 },
        lens: Lens::PINHOLE,
    };
    settings.validate().unwrap();
    // 200 × 100 pixels: the view is 4 units high, so 8 wide.
    let camera = settings.camera(200, 100);
    for (x, y, origin) in [
        (0.0, 0.0, Vec3::new(-3.0, 4.0, 3.0)),
        (200.0, 100.0, Vec3::new(5.0, 0.0, 3.0)),
        (100.0, 50.0, Vec3::new(1.0, 2.0, 3.0)),
        (50.0, 25.0, Vec3::new(-1.0, 3.0, 3.0)),
    ] {
        let ray = camera.ray(x, y);
        assert_eq!(ray.dir, -Vec3::Z, "every ray runs along the view direction");
        assert!(
            (ray.origin - origin).length() < 1e-5,
            "({x}, {y}): {} instead of {origin}",
            ray.origin
        );
    }
}

/// A square of side 1 through an orthographic view 2 units high fills half the image's
/// height and width (32 of 64 pixels) wherever it stands; through a perspective view
/// its image shrinks with distance.
#[test]
fn a_square_fills_side_over_height_of_the_image_at_any_depth() {
    let ortho = looking_down_z(Projection::Orthographic { height: 2.0 });
    for z in [3.0, -4.0] {
        let image = shoot(&emitting_square(z, 1.0), &ortho, (64, 64), Engine::Scalar);
        assert_eq!(lit(&image), (32 * 32, 32, 32), "square at z = {z}");
    }
    // 128 × 64: the view is 4 units wide, the square a quarter of it.
    let image = shoot(
        &emitting_square(0.0, 1.0),
        &ortho,
        (128, 64),
        Engine::Scalar,
    );
    assert_eq!(lit(&image), (32 * 32, 32, 32));
    // Through a perspective camera whose view is 2 units high at z = 0 the nearer
    // square is larger: the view is 2·d·tan(fov/2) = 0.4·d high at distance d, so
    // 1.6 at z = 1, where the square is 40 of 64 pixels.
    let fov = 2.0 * (1.0f32 / 5.0).atan().to_degrees();
    let perspective = looking_down_z(Projection::perspective(fov));
    for (z, side) in [(0.0, 32), (1.0, 40)] {
        let image = shoot(
            &emitting_square(z, 1.0),
            &perspective,
            (64, 64),
            Engine::Scalar,
        );
        assert_eq!(lit(&image), (side * side, side, side), "square at z = {z}");
    }
}

/// The wavefront engine makes the same parallel rays: the same pixels lit.
#[test]
fn the_wavefront_engine_renders_orthographic_views() {
    let ortho = looking_down_z(Projection::Orthographic { height: 2.0 });
    let built = emitting_square(-1.0, 1.0);
    let scalar = shoot(&built, &ortho, (64, 32), Engine::Scalar);
    let wavefront = shoot(&built, &ortho, (64, 32), Engine::Wavefront);
    // 32 rows of 64: the square is half the height and a quarter of the width.
    assert_eq!(lit(&wavefront), (16 * 16, 16, 16));
    assert_eq!(scalar.pixels, wavefront.pixels);
}

#[test]
fn depth_of_field_is_refused_for_an_orthographic_camera() {
    let settings = CameraSettings {
        lens: Lens {
            aperture_radius: 0.1,
            focus_distance: None,
        },
        ..looking_down_z(Projection::Orthographic { height: 2.0 })
    };
    let error = settings.validate().unwrap_err();
    assert!(error.contains("orthographic"), "{error}");
    let dir = tempfile::tempdir().unwrap();
    write_square_obj(dir.path());
    let run = ember_in(
        &[
            "render",
            "square.obj",
            "--ortho-height",
            "2",
            "--aperture",
            "0.1",
        ],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("error: invalid camera: depth of field (--aperture)"),
        "{err}"
    );
    assert!(!dir.path().join("square.png").exists());
    for bad in ["0", "-1", "nan"] {
        let flag = format!("--ortho-height={bad}");
        let run = ember_in(&["render", "square.obj", &flag], dir.path());
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(
            !run.status.success() && err.contains("--ortho-height"),
            "{err}"
        );
    }
}

/// An emissive unit square at z = 0 facing +z, as an OBJ with its MTL.
fn write_square_obj(dir: &Path) {
    let obj = "mtllib square.mtl\nv -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\n\
               usemtl light\nf 1 2 3\nf 1 3 4\n";
    std::fs::write(dir.join("square.obj"), obj).unwrap();
    std::fs::write(dir.join("square.mtl"), "newmtl light\nKd 0 0 0\nKe 1 1 1\n").unwrap();
}

/// Renders `args` (after `render`) in `dir` to `out.exr`, emitted light only, and gives
/// the image and the messages.
fn render_exr(dir: &Path, args: &[&str]) -> (Image, String) {
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--max-depth", "1", "--spp", "2", "-o", "out.exr"]);
    let run = ember_in(&all, dir);
    let err = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(run.status.success(), "{err}");
    (Image::load(&dir.join("out.exr")).unwrap(), err)
}

#[test]
fn ortho_height_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    write_square_obj(dir.path());
    let flags = [
        "square.obj",
        "--eye",
        "0,0,5",
        "--look-at",
        "0,0,0",
        "--ortho-height",
        "2",
        "--width",
        "64",
        "--height",
        "32",
        "-v",
    ];
    let (image, err) = render_exr(dir.path(), &flags);
    assert!(
        err.contains("--eye 0,0,5 --look-at 0,0,0 --ortho-height 2"),
        "{err}"
    );
    assert_eq!((image.width, image.height), (64, 32));
    assert_eq!(lit(&image), (16 * 16, 16, 16));
    // The later of --fov and --ortho-height wins.
    let mut perspective = flags.to_vec();
    perspective.extend_from_slice(&["--fov", "30"]);
    let (_, err) = render_exr(dir.path(), &perspective);
    assert!(err.contains("--look-at 0,0,0 --fov 30"), "{err}");
}

/// A glTF of an emissive unit square at z = 0 facing +z, and two cameras at
/// (0, 0, 5) looking along −z: "persp" (vertical view 2 units high at the square,
/// `aspectRatio` 1.5) and "flat" (orthographic, `xmag` 2, `ymag` 1).
fn cameras_gltf() -> GltfBuilder {
    let mut gltf = GltfBuilder::default();
    let m = gltf.material(json!({"emissiveFactor": [1.0, 1.0, 1.0],
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0}}));
    let p = [
        [-0.5, -0.5, 0.0],
        [0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
        [-0.5, 0.5, 0.0],
    ];
    let mesh = gltf.mesh(&p, None, &[0, 1, 2, 0, 2, 3], Some(m));
    gltf.node(json!({"mesh": mesh}), true);
    let yfov = 2.0 * (1.0f32 / 5.0).atan();
    gltf.json["cameras"] = json!([
        {"name": "persp", "type": "perspective",
         "perspective": {"yfov": yfov, "znear": 0.1, "aspectRatio": 1.5}},
        {"name": "flat", "type": "orthographic",
         "orthographic": {"xmag": 2.0, "ymag": 1.0, "znear": 0.0, "zfar": 100.0}},
    ]);
    for camera in [0, 1] {
        gltf.node(
            json!({"camera": camera, "translation": [0.0, 0.0, 5.0]}),
            true,
        );
    }
    gltf
}

#[test]
fn a_gltf_orthographic_camera_is_read_and_picked() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cams.gltf"), cameras_gltf().to_gltf()).unwrap();
    let info = ember_in(&["info", "cams.gltf"], dir.path());
    let out = String::from_utf8_lossy(&info.stdout);
    assert!(info.status.success(), "{out}");
    assert!(
        out.contains("1 \"flat\": --eye 0,0,5 --look-at 0,0,4 --ortho-height 2, aspect ratio 2"),
        "{out}"
    );
    for pick in ["flat", "1"] {
        // xmag/ymag = 2: the width follows the height given.
        let (image, err) = render_exr(
            dir.path(),
            &["cams.gltf", "--camera", pick, "--height", "32"],
        );
        assert!(
            err.contains(
                "camera (the file's camera \"flat\"): --eye 0,0,5 --look-at 0,0,4 --ortho-height 2"
            ),
            "{err}"
        );
        assert_eq!((image.width, image.height), (64, 32));
        // The view is 4 × 2 units: the unit square is 16 × 16 pixels.
        assert_eq!(lit(&image), (16 * 16, 16, 16));
    }
    // Flags override it: a perspective view from the same place.
    let (_, err) = render_exr(
        dir.path(),
        &["cams.gltf", "--camera", "flat", "--fov", "20"],
    );
    assert!(err.contains("--look-at 0,0,4 --fov 20"), "{err}");
}

/// `aspectRatio` completes the size the command line leaves out; both sides given keep
/// the vertical field of view (the square stays half the image's height), with a note.
#[test]
fn a_cameras_aspect_ratio_completes_the_image_size() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cams.gltf"), cameras_gltf().to_gltf()).unwrap();
    let size = |args: &[&str]| {
        let mut all = vec!["cams.gltf"];
        all.extend_from_slice(args);
        let (image, err) = render_exr(dir.path(), &all);
        (image, err)
    };
    let (image, err) = size(&["--height", "40"]);
    assert_eq!((image.width, image.height), (60, 40));
    assert!(!err.contains("note: the image's aspect ratio"), "{err}");
    // The view is 3 × 2 units at the square: 20 × 20 pixels, square as it is.
    assert_eq!(lit(&image), (20 * 20, 20, 20));
    let (image, _) = size(&["--width", "90"]);
    assert_eq!((image.width, image.height), (90, 60));
    let (image, _) = size(&[]);
    assert_eq!((image.width, image.height), (768, 512));
    let (image, err) = size(&["--width", "40", "--height", "40"]);
    assert_eq!((image.width, image.height), (40, 40));
    let notes: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("note: the image's aspect ratio"))
        .collect();
    assert_eq!(notes.len(), 1, "{err}");
    assert!(notes[0].contains("keeps its vertical view"), "{err}");
    // The vertical view kept: the square is still half the height, 20 of 40 rows.
    assert_eq!(lit(&image), (20 * 20, 20, 20));
    // A size the ratio cannot make is one error line.
    let run = ember_in(
        &[
            "render",
            "cams.gltf",
            "--camera",
            "flat",
            "--height",
            "10000",
        ],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("give --width and --height"), "{err}");
}

#[test]
fn bad_gltf_camera_numbers_are_one_error_line() {
    let dir = tempfile::tempdir().unwrap();
    for (camera, says) in [
        (
            json!({"type": "orthographic", "orthographic": {"xmag": 0.0, "ymag": 1.0, "znear": 0.0, "zfar": 1.0}}),
            "xmag 0",
        ),
        (
            json!({"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": -2.0, "znear": 0.0, "zfar": 1.0}}),
            "ymag -2",
        ),
        (
            json!({"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1, "aspectRatio": 0.0}}),
            "aspectRatio 0",
        ),
    ] {
        let mut gltf = cameras_gltf();
        gltf.json["cameras"][0] = camera;
        std::fs::write(dir.path().join("bad.gltf"), gltf.to_gltf()).unwrap();
        let run = ember_in(&["render", "bad.gltf"], dir.path());
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success());
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.starts_with("error: ") && err.contains(says), "{err}");
    }
}

/// A scene file's glTF cameras: placed by their entry's transform (an orthographic
/// view's height scaled with it), the first the default without camera tables, picked
/// by `--camera` or by a table's `camera`, whose other keys override it.
#[test]
fn scene_files_use_the_cameras_of_their_gltf_files() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cams.gltf"), cameras_gltf().to_gltf()).unwrap();
    let scene = |extra: &str| {
        let text = format!(
            "[[mesh]]\nfile = \"cams.gltf\"\nname = \"set\"\ntranslate = [10, 0, 0]\n\
             scale = 2\n{extra}"
        );
        std::fs::write(dir.path().join("scene.toml"), text).unwrap();
    };
    scene("");
    let info = ember_in(&["info", "scene.toml"], dir.path());
    let out = String::from_utf8_lossy(&info.stdout);
    assert!(info.status.success(), "{out}");
    assert!(
        out.contains("camera (the file's camera \"persp\"): --eye 10,0,10 --look-at 10,0,8"),
        "{out}"
    );
    assert!(out.contains("0 \"persp\" of [[mesh]] \"set\""), "{out}");
    assert!(
        out.contains(
            "1 \"flat\" of [[mesh]] \"set\": --eye 10,0,10 --look-at 10,0,8 --ortho-height 4"
        ),
        "{out}"
    );
    // Scaled twice over, the square is seen through the scaled view as the glTF's own
    // camera sees it: 16 × 16 pixels of 64 × 32.
    let (image, err) = render_exr(
        dir.path(),
        &["scene.toml", "--camera", "flat", "--height", "32"],
    );
    assert!(err.contains("--ortho-height 4"), "{err}");
    assert_eq!((image.width, image.height), (64, 32));
    assert_eq!(lit(&image), (16 * 16, 16, 16));
    // A table names the camera and overrides a key of it.
    scene("[camera.top]\ncamera = \"persp\"\nfov = 30\n");
    let info = ember_in(&["info", "scene.toml"], dir.path());
    let out = String::from_utf8_lossy(&info.stdout);
    assert!(
        out.contains(
            "camera (the file's camera \"persp\"): --eye 10,0,10 --look-at 10,0,8 --fov 30"
        ),
        "{out}"
    );
    // --camera names a table, or else a glTF camera; an unknown one lists both.
    let run = ember_in(&["info", "scene.toml"], dir.path());
    assert!(run.status.success());
    let run = ember_in(&["render", "scene.toml", "--camera", "nope"], dir.path());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("error: --camera \"nope\": scene.toml has no such camera")
            && err.contains("[camera.top], \"persp\" of [[mesh]] \"set\", \"flat\""),
        "{err}"
    );
    // A table's unknown camera is refused at its line.
    scene("[camera.top]\ncamera = \"nope\"\n");
    let run = ember_in(&["render", "scene.toml"], dir.path());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with(
            "error: scene.toml:7:1: camera.top.camera: the scene names the camera \"nope\", \
             but has no such camera"
        ),
        "{err}"
    );
    scene("[camera.top]\ncamera = [1]\n");
    let run = ember_in(&["render", "scene.toml"], dir.path());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && err.starts_with("error: scene.toml:7:1: camera.top.camera:"),
        "{err}"
    );
}
