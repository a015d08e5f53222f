//! Scenes as they arrive from the web (docs/input-rules.md): an absent material
//! library, texture or material is one warning and the render goes on, as the
//! constant colour or the default material would render; paths written on another
//! machine resolve; vertex colours give the colour they say; `--strict` refuses each
//! of these; a file that is there but damaged is refused either way. Every scene is
//! made here, and every run is judged by its exit, its messages and its image.
//!
//! The scene: a 2×2 quad filling a 16×16 view, lit by a white sky, rendered with
//! material sampling only to depth 2. A Lambertian quad of albedo `c` under a sky of
//! radiance 1 sends exactly `c` to the eye, and cosine sampling estimates it with no
//! variance, so every pixel is `c`.

mod common;

use std::path::Path;
use std::process::Output;

use common::ember_in as ember;
use ember::image::Image;
use ember::scene::{load_obj, load_obj_with, LoadOptions};
use glam::Vec3;

const QUAD: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
const FACE: &str = "f 1/1 2/2 3/3 4/4\n";

/// The quad OBJ naming `mtllib` and `usemtl` (each left out when empty).
fn quad_obj(mtllib: &str, usemtl: &str) -> String {
    let mut obj = String::new();
    if !mtllib.is_empty() {
        obj += &format!("mtllib {mtllib}\n");
    }
    obj += QUAD;
    if !usemtl.is_empty() {
        obj += &format!("usemtl {usemtl}\n");
    }
    obj + FACE
}

/// A folder with `files` written into it (subfolders made as needed).
fn folder(files: &[(&str, &[u8])]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        let path = dir.path().join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }
    dir
}

/// A PNG of one sRGB colour.
fn png(rgb: [u8; 3]) -> Vec<u8> {
    let image = image::RgbImage::from_pixel(2, 2, image::Rgb(rgb));
    let mut bytes = Vec::new();
    image::DynamicImage::from(image)
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .unwrap();
    bytes
}

/// What a render said and drew.
struct Run {
    out: Output,
    stderr: String,
    image: Option<Image>,
}

impl Run {
    fn warnings(&self) -> Vec<&str> {
        self.stderr
            .lines()
            .filter(|l| l.starts_with("warning:"))
            .collect()
    }

    /// Succeeded with exactly one warning, holding every one of `words`, counted in the
    /// summary; returns the image.
    fn one_warning(&self, words: &[&str]) -> &Image {
        assert!(self.out.status.success(), "{}", self.stderr);
        let warnings = self.warnings();
        assert_eq!(warnings.len(), 1, "{}", self.stderr);
        for word in words {
            assert!(
                warnings[0].contains(word),
                "{word:?} not in {}",
                warnings[0]
            );
        }
        assert!(self.stderr.contains(", 1 warning\n"), "{}", self.stderr);
        self.image.as_ref().unwrap()
    }

    /// Succeeded with no warning; returns the image.
    fn clean(&self) -> &Image {
        assert!(self.out.status.success(), "{}", self.stderr);
        assert!(self.warnings().is_empty(), "{}", self.stderr);
        self.image.as_ref().unwrap()
    }

    /// Failed with one `error:` line holding every one of `words`, and no image.
    fn refused(&self, words: &[&str]) {
        assert!(!self.out.status.success(), "{}", self.stderr);
        let lines: Vec<&str> = self.stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{}", self.stderr);
        assert!(lines[0].starts_with("error:"), "{}", self.stderr);
        for word in words {
            assert!(lines[0].contains(word), "{word:?} not in {}", lines[0]);
        }
        assert!(self.image.is_none());
    }
}

/// Renders `scene` in `dir` (see the module documentation) with `extra` flags.
fn render(dir: &Path, scene: &str, extra: &[&str]) -> Run {
    let mut args = vec![
        "render",
        scene,
        "-o",
        "out.exr",
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "4",
        "--max-depth",
        "2",
        "--integrator",
        "bsdf",
        "--background",
        "1,1,1",
        "--eye",
        "0,0,3",
        "--look-at",
        "0,0,0",
        "--fov",
        "30",
    ];
    args.extend_from_slice(extra);
    let out = ember(&args, dir);
    let output = dir.join("out.exr");
    let image = output.is_file().then(|| {
        let image = Image::load(&output).unwrap();
        std::fs::remove_file(&output).unwrap();
        image
    });
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    Run { out, stderr, image }
}

/// Every pixel is `colour`, to within `tolerance` relative.
fn assert_uniform(image: &Image, colour: Vec3, tolerance: f32) {
    for p in &image.pixels {
        let error = ((*p - colour).abs() / colour.max(Vec3::splat(1e-3))).max_element();
        assert!(error <= tolerance, "pixel {p} vs {colour}");
    }
}

fn same_image(a: &Image, b: &Image) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    assert!(a.pixels == b.pixels, "the images differ");
}

const RED: &str = "newmtl red paint\nKd 0.7 0.2 0.1\n";

#[test]
fn a_missing_texture_renders_as_its_constant_colour_with_one_warning() {
    let obj = quad_obj("scene.mtl", "red paint");
    let with_map = format!("{RED}map_Kd wood grain.png\n");
    let dir = folder(&[
        ("scene.obj", obj.as_bytes()),
        ("scene.mtl", with_map.as_bytes()),
        ("twin.obj", quad_obj("twin.mtl", "red paint").as_bytes()),
        ("twin.mtl", RED.as_bytes()),
    ]);
    let missing = render(dir.path(), "scene.obj", &[]);
    let image = missing.one_warning(&[
        "wood grain.png",
        "map_Kd",
        "\"red paint\"",
        "not found",
        "Kd 0.7 0.2 0.1 instead",
    ]);
    assert_uniform(image, Vec3::new(0.7, 0.2, 0.1), 1e-5);
    same_image(image, render(dir.path(), "twin.obj", &[]).clean());
    // Every other slot too: each absent file is one warning, and the quad is unchanged.
    for slot in [
        "map_Ks", "map_Ke", "map_Ns", "map_Pr", "map_Pm", "map_d", "bump", "norm",
    ] {
        let mtl = format!("{RED}{slot} gone.png\n");
        std::fs::write(dir.path().join("scene.mtl"), mtl).unwrap();
        let run = render(dir.path(), "scene.obj", &[]);
        same_image(run.one_warning(&["gone.png", slot, "\"red paint\""]), image);
        render(dir.path(), "scene.obj", &["--strict"]).refused(&["gone.png", slot]);
    }
}

#[test]
fn a_missing_material_library_or_material_is_one_warning() {
    let dir = folder(&[
        ("gone-mtl.obj", quad_obj("gone.mtl", "red paint").as_bytes()),
        ("undefined.obj", quad_obj("scene.mtl", "no such").as_bytes()),
        ("scene.mtl", RED.as_bytes()),
        ("plain.obj", quad_obj("", "").as_bytes()),
    ]);
    // The default material: grey 0.5 where no material applies.
    let plain = render(dir.path(), "plain.obj", &[]);
    let grey = plain.clean();
    assert_uniform(grey, Vec3::splat(0.5), 1e-5);
    let undefined = render(dir.path(), "undefined.obj", &[]);
    let image = undefined.one_warning(&["undefined.obj:10", "usemtl \"no such\"", "default"]);
    same_image(image, grey);
    // The absent library is the warning; the material it would have defined is then
    // undefined too.
    let gone = render(dir.path(), "gone-mtl.obj", &[]);
    assert!(gone.out.status.success(), "{}", gone.stderr);
    let warnings = gone.warnings();
    assert_eq!(warnings.len(), 2, "{}", gone.stderr);
    assert!(warnings[0].contains("gone.mtl") && warnings[0].contains("file not found"));
    assert!(warnings[1].contains("\"red paint\""), "{}", warnings[1]);
    assert!(gone.stderr.contains(", 2 warnings\n"), "{}", gone.stderr);
    same_image(gone.image.as_ref().unwrap(), grey);

    render(dir.path(), "undefined.obj", &["--strict"]).refused(&["undefined.obj:10", "no such"]);
    render(dir.path(), "gone-mtl.obj", &["--strict"]).refused(&["gone.mtl", "not found"]);
}

/// `mtllib a.mtl b.mtl` names two libraries, as the OBJ specification allows, while a
/// library whose own name holds a space is still found by its whole name.
#[test]
fn one_mtllib_statement_names_several_libraries_or_one_with_spaces() {
    let green = "newmtl green\nKd 0.1 0.6 0.2\n";
    let two = quad_obj("other.mtl scene.mtl", "red paint");
    let green_from_two = quad_obj("scene.mtl other.mtl", "green");
    let spaced = quad_obj("my paints.mtl", "red paint");
    let dir = folder(&[
        ("two.obj", two.as_bytes()),
        ("green.obj", green_from_two.as_bytes()),
        ("spaced.obj", spaced.as_bytes()),
        ("scene.mtl", RED.as_bytes()),
        ("other.mtl", green.as_bytes()),
        ("my paints.mtl", RED.as_bytes()),
    ]);
    let red = Vec3::new(0.7, 0.2, 0.1);
    assert_uniform(render(dir.path(), "two.obj", &[]).clean(), red, 1e-5);
    let image = render(dir.path(), "green.obj", &[]);
    assert_uniform(image.clean(), Vec3::new(0.1, 0.6, 0.2), 1e-5);
    let strict = render(dir.path(), "spaced.obj", &["--strict"]);
    assert_uniform(strict.clean(), red, 1e-5);
    // A missing one of the two is one warning naming it alone.
    std::fs::remove_file(dir.path().join("other.mtl")).unwrap();
    let run = render(dir.path(), "two.obj", &[]);
    assert_uniform(run.one_warning(&["other.mtl", "not found"]), red, 1e-5);
    assert!(!run.stderr.contains("scene.mtl"), "{}", run.stderr);
}

/// A scene whose texture folder was never shipped warns once per material and slot;
/// past twenty lines the rest are counted (all printed with `-v`), and the summary
/// counts them all.
#[test]
fn past_twenty_warnings_the_rest_are_counted() {
    let mut obj = format!("mtllib many.mtl\n{QUAD}");
    let mut mtl = String::new();
    for m in 0..25 {
        obj += &format!("usemtl m{m}\n{FACE}");
        mtl += &format!("newmtl m{m}\nKd 0.5 0.5 0.5\nmap_Kd textures/m{m}.png\n");
    }
    let dir = folder(&[("many.obj", obj.as_bytes()), ("many.mtl", mtl.as_bytes())]);
    let run = render(dir.path(), "many.obj", &[]);
    assert!(run.out.status.success(), "{}", run.stderr);
    let warnings = run.warnings();
    assert_eq!(warnings.len(), 21, "{}", run.stderr);
    assert!(warnings[19].contains("m19.png"), "{}", warnings[19]);
    assert!(warnings[20].contains("5 more warnings"), "{}", warnings[20]);
    assert!(run.stderr.contains(", 25 warnings\n"), "{}", run.stderr);
    let verbose = render(dir.path(), "many.obj", &["-v"]);
    assert_eq!(verbose.warnings().len(), 25, "{}", verbose.stderr);
}

#[test]
fn paths_from_other_machines_resolve_by_their_file_name() {
    let red = png([200, 40, 20]);
    let twin_mtl = "newmtl m\nKd 1 1 1\nmap_Kd wood.png\n";
    let dir = folder(&[
        ("scene.obj", quad_obj("scene.mtl", "m").as_bytes()),
        ("twin.obj", quad_obj("twin.mtl", "m").as_bytes()),
        ("twin.mtl", twin_mtl.as_bytes()),
        ("wood.png", &red),
        ("sub/scene.obj", quad_obj("scene.mtl", "m").as_bytes()),
        ("sub/textures/Wood.PNG", &red),
    ]);
    let twin = render(dir.path(), "twin.obj", &[]);
    let expected = twin.clean();
    let cases = [
        (
            "C:\\Users\\x\\wood.png",
            "scene.obj",
            "by its file name alone",
        ),
        (
            "/home/author/scenes/wood.png",
            "scene.obj",
            "by its file name alone",
        ),
        (
            "..\\maps\\wood.png",
            "sub/scene.obj",
            "ignoring upper and lower case",
        ),
    ];
    for (written, scene, how) in cases {
        let mtl = format!("newmtl m\nKd 1 1 1\nmap_Kd {written}\n");
        let at = Path::new(scene).with_file_name("scene.mtl");
        std::fs::write(dir.path().join(at), mtl).unwrap();
        let run = render(dir.path(), scene, &[]);
        same_image(
            run.one_warning(&[written, "map_Kd", "\"m\"", how]),
            expected,
        );
        // --strict takes only what is written (and backslashes as separators).
        render(dir.path(), scene, &["--strict"]).refused(&[written, "--strict"]);
    }
    // Backslashes as separators: a warning saying so, and --strict renders it too.
    std::fs::write(
        dir.path().join("sub/scene.mtl"),
        "newmtl m\nKd 1 1 1\nmap_Kd textures\\Wood.PNG\n",
    )
    .unwrap();
    let run = render(dir.path(), "sub/scene.obj", &["--strict"]);
    same_image(run.one_warning(&["backslashes"]), expected);
    // A material library written with a Windows path resolves the same way.
    std::fs::write(
        dir.path().join("elsewhere.obj"),
        quad_obj("D:\\exports\\twin.mtl", "m"),
    )
    .unwrap();
    let run = render(dir.path(), "elsewhere.obj", &[]);
    same_image(run.one_warning(&["twin.mtl", "file name alone"]), expected);
}

#[test]
fn a_texture_that_is_there_but_damaged_is_refused() {
    let mtl = "newmtl m\nKd 1 1 1\nmap_Kd wood.png\n";
    let dir = folder(&[
        ("scene.obj", quad_obj("scene.mtl", "m").as_bytes()),
        ("scene.mtl", mtl.as_bytes()),
        ("wood.png", &png([1, 2, 3])[..40]),
    ]);
    render(dir.path(), "scene.obj", &[]).refused(&["wood.png", "map_Kd", "\"m\""]);
    // Found by a later rule, it is still damage, not absence.
    std::fs::rename(dir.path().join("wood.png"), dir.path().join("WOOD.png")).unwrap();
    render(dir.path(), "scene.obj", &[]).refused(&["WOOD.png", "map_Kd"]);
}

#[test]
fn strict_in_a_scene_file_refuses_what_would_be_a_warning() {
    let dir = folder(&[
        ("scene.obj", quad_obj("gone.mtl", "").as_bytes()),
        ("lenient.toml", b"[[obj]]\nfile = \"scene.obj\"\n"),
        (
            "strict.toml",
            b"[render]\nstrict = true\n\n[[obj]]\nfile = \"scene.obj\"\n",
        ),
    ]);
    let run = render(dir.path(), "lenient.toml", &[]);
    assert_uniform(run.one_warning(&["gone.mtl"]), Vec3::splat(0.5), 1e-5);
    render(dir.path(), "strict.toml", &[]).refused(&["strict.toml", "gone.mtl"]);
}

/// `v x y z r g b` multiplies the diffuse colour: in [0, 1] or 0-255 as written, on a
/// material's `Kd` or on the default material (white when vertices carry colours).
#[test]
fn vertex_colours_give_the_colour_they_say() {
    let colour = Vec3::new(0.8, 0.4, 0.2);
    // The quad with every vertex coloured `rgb`, of material `material` (none if empty).
    let coloured = |rgb: &str, material: &str| {
        let mut obj = String::new();
        if !material.is_empty() {
            obj += &format!("mtllib scene.mtl\nusemtl {material}\n");
        }
        for (x, y) in [(-1, -1), (1, -1), (1, 1), (-1, 1)] {
            obj += &format!("v {x} {y} 0 {rgb}\n");
        }
        obj + "f 1 2 3 4\n"
    };
    let dir = folder(&[
        ("unit.obj", coloured("0.8 0.4 0.2", "white").as_bytes()),
        ("bytes.obj", coloured("204 102 51", "white").as_bytes()),
        ("bare.obj", coloured("204 102 51", "").as_bytes()),
        ("halved.obj", coloured("0.8 0.4 0.2", "half").as_bytes()),
        ("twin.obj", quad_obj("scene.mtl", "twin").as_bytes()),
        (
            "scene.mtl",
            b"newmtl white\nKd 1 1 1\nnewmtl half\nKd 0.5 0.5 0.5\nnewmtl twin\nKd 0.8 0.4 0.2\n",
        ),
    ]);
    let twin = render(dir.path(), "twin.obj", &[]);
    let expected = twin.clean();
    assert_uniform(expected, colour, 1e-5);
    for (scene, range, factor) in [
        ("unit.obj", "[0, 1]", 1.0),
        ("bytes.obj", "0-255", 1.0),
        ("bare.obj", "0-255", 1.0),
        ("halved.obj", "[0, 1]", 0.5),
    ] {
        let run = render(dir.path(), scene, &[]);
        let image = run.clean();
        assert!(
            run.stderr.contains(&format!("vertex colours ({range})")),
            "{}",
            run.stderr
        );
        // Interpolating three equal colours rounds differently from the constant.
        assert_uniform(image, colour * factor, 1e-5);
        if factor == 1.0 {
            let close = image
                .pixels
                .iter()
                .zip(&expected.pixels)
                .all(|(a, b)| (*a - *b).abs().max_element() <= 1e-5);
            assert!(close, "{scene} differs from its constant-Kd twin");
        }
        let info = ember(&["info", scene], dir.path());
        let said = String::from_utf8_lossy(&info.stdout);
        assert!(info.status.success(), "{said}");
        assert!(
            said.contains(&format!("vertex colours: written in {range}")),
            "{said}"
        );
    }
    // Placed from a scene file beside an OBJ without colours and a second copy (both
    // far out of view), the colours go with their mesh.
    let placed = "[[obj]]\nfile = \"bytes.obj\"\nname = \"q\"\n\n\
                  [[obj]]\nfile = \"twin.obj\"\ntranslate = [-100, 0, 0]\n\n\
                  [[instance]]\nobj = \"q\"\ntranslate = [100, 0, 0]\n";
    std::fs::write(dir.path().join("placed.toml"), placed).unwrap();
    let run = render(dir.path(), "placed.toml", &[]);
    assert!(run.stderr.contains("placed 3 times"), "{}", run.stderr);
    assert_uniform(run.clean(), colour, 1e-5);
}

/// A colour that varies across the quad is interpolated: each pixel column of a quad
/// red on its left edge and blue on its right is their mixture there. The same from
/// either OBJ reader (a line statement sends the file to tobj), and with colours on
/// some vertices only (the others white).
#[test]
fn vertex_colours_are_interpolated_across_triangles() {
    let obj = "v -1 -1 0 1 0 0\nv 1 -1 0 0 0 1\nv 1 1 0 0 0 1\nv -1 1 0 1 0 0\nf 1 2 3 4\n";
    let dir = folder(&[
        ("scene.obj", obj.as_bytes()),
        ("tobj.obj", format!("{obj}l 1 2\n").as_bytes()),
        (
            "mixed.obj",
            format!("{obj}v 5 5 5\nv 6 5 5\nv 5 6 5\nf 5 6 7\n").as_bytes(),
        ),
    ]);
    let run = render(dir.path(), "scene.obj", &[]);
    let image = run.clean();
    same_image(render(dir.path(), "tobj.obj", &[]).clean(), image);
    let (mixed, _) = load_obj(&dir.path().join("mixed.obj")).unwrap();
    let colours = &mixed.mesh.colours;
    assert_eq!(colours.len(), 7, "{colours:?}");
    assert_eq!(colours[0], Vec3::X);
    assert_eq!(colours[1], Vec3::Z);
    assert!(colours[4..].iter().all(|&c| c == Vec3::ONE), "{colours:?}");
    // Pixel column x spans u from −0.8 to 0.8 (the view's half-width at the quad).
    let half = 3.0 * 15f32.to_radians().tan();
    for (i, p) in image.pixels.iter().enumerate() {
        let x = ((i % 16) as f32 + 0.5) / 16.0 * 2.0 - 1.0;
        let blue = 0.5 * (1.0 + x * half);
        let expected = Vec3::new(1.0 - blue, 0.0, blue);
        // Each pixel averages its 4 samples over its width of 0.1 in x.
        assert!(
            (*p - expected).abs().max_element() < 0.06,
            "pixel {i}: {p} vs {expected}"
        );
    }
}

/// A 3ds Max export (doubled spaces and tabs after keys, CRLF, trailing spaces, `Tf`,
/// `Ka`, `illum`, `map_Ka`, a name with spaces) reads as the same materials as a clean
/// file, and renders the same image with no warning.
#[test]
fn a_3ds_max_mtl_reads_as_a_clean_one() {
    let max = "# 3ds Max Wavefront OBJ Exporter v0.97b - (c)2007 guruware\r\n\
               # File Created: 04.07.2013 22:57:34\r\n\r\n\
               newmtl  red paint \r\n\tNs 10.0000\r\n\tNi 1.5000\r\n\td 1.0000\r\n\
               \tTr 0.0000\r\n\tTf 1.0000 1.0000 1.0000 \r\n\tillum 2\r\n\
               \tKa 0.5880 0.5880 0.5880\r\n\tKd  0.7000\t0.2000 0.1000 \r\n\
               \tKs 0.0000 0.0000 0.0000\r\n\tKe 0.0000 0.0000 0.0000\r\n\
               \tmap_Ka  wood grain.png \r\n\tmap_Kd  wood grain.png \r\n";
    let clean = "newmtl red paint\nNs 10\nNi 1.5\nd 1\nillum 2\nKd 0.7 0.2 0.1\nKs 0 0 0\n\
                 Ke 0 0 0\nmap_Kd wood grain.png\n";
    let obj = |mtl: &str| quad_obj(mtl, "red paint").replace("usemtl red", "usemtl\t red");
    let wood = png([90, 160, 30]);
    let dir = folder(&[
        ("max.obj", obj("max.mtl").as_bytes()),
        ("max.mtl", max.as_bytes()),
        ("clean.obj", obj("clean.mtl").as_bytes()),
        ("clean.mtl", clean.as_bytes()),
        ("wood grain.png", &wood),
    ]);
    let (from_max, report) = load_obj(&dir.path().join("max.obj")).unwrap();
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let (from_clean, _) = load_obj(&dir.path().join("clean.obj")).unwrap();
    assert_eq!(from_max.materials, from_clean.materials);
    assert_eq!(from_max.materials[0].name, "red paint");
    assert!(from_max.materials[0].diffuse_texture.is_some());
    assert_eq!(from_max.mesh.material, from_clean.mesh.material);
    let image = render(dir.path(), "max.obj", &["--strict"]);
    same_image(image.clean(), render(dir.path(), "clean.obj", &[]).clean());
}

/// 3ds Max names its materials `Material #25`: a `#` in a `usemtl` name is part of
/// it, as it is in `newmtl`, so each face gets its own material, without a warning.
#[test]
fn a_hash_in_a_material_name_is_part_of_it() {
    let obj = format!(
        "mtllib max.mtl\n{QUAD}usemtl Material #25\nf 1 2 3\nusemtl Material #26\nf 1 3 4\n"
    );
    let mtl = "newmtl Material #25\nKd 1 0 0\nnewmtl Material #26\nKd 0 1 0\n";
    let dir = folder(&[("max.obj", obj.as_bytes()), ("max.mtl", mtl.as_bytes())]);
    let (scene, report) = load_obj(&dir.path().join("max.obj")).unwrap();
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let diffuse = |t: usize| scene.materials[scene.mesh.material[t] as usize].diffuse;
    assert_eq!(diffuse(0), Vec3::X);
    assert_eq!(diffuse(1), Vec3::Y);
}

#[test]
fn mtl_syntax_errors_name_the_file_line_and_what_was_expected() {
    let dir = folder(&[("scene.obj", quad_obj("bad.mtl", "m").as_bytes())]);
    for (mtl, words) in [
        (
            "newmtl m\r\n\tKd 0.5 0.5 0.5\r\n\tNs ten\r\n",
            &[
                "bad.mtl:3:",
                "material \"m\"",
                "Ns",
                "expected a finite number",
                "\"ten\"",
            ][..],
        ),
        (
            "newmtl m\nKs 0.1 0.1\n",
            &["bad.mtl:2:", "Ks", "expected three numbers", "\"0.1 0.1\""][..],
        ),
        (
            "newmtl m\n\n\nmap_Kd -bogus 3 x.png\n",
            &["bad.mtl:4:", "map_Kd", "unknown texture option \"-bogus\""][..],
        ),
        (
            "\nnewmtl\t\n",
            &["bad.mtl:2:", "newmtl: expected a material name"][..],
        ),
    ] {
        std::fs::write(dir.path().join("bad.mtl"), mtl).unwrap();
        render(dir.path(), "scene.obj", &[]).refused(words);
    }
    // An unknown key is one warning naming its line, not an error.
    std::fs::write(
        dir.path().join("bad.mtl"),
        "newmtl m\nKd 0.5 0.5 0.5\nvendor_gloss 3\nvendor_gloss 4\n",
    )
    .unwrap();
    let run = render(dir.path(), "scene.obj", &[]);
    assert_uniform(
        run.one_warning(&["bad.mtl:3", "unknown key `vendor_gloss`"]),
        Vec3::splat(0.5),
        1e-5,
    );
}

/// The library API takes the same rules: warnings in the report, errors with `strict`.
#[test]
fn the_library_loads_with_warnings_or_strictly() {
    let dir = folder(&[
        ("scene.obj", quad_obj("scene.mtl", "m").as_bytes()),
        ("scene.mtl", b"newmtl m\nKd 1 1 1\nmap_Kd C:\\x\\gone.png\n"),
    ]);
    let path = dir.path().join("scene.obj");
    let (scene, report) = load_obj(&path).unwrap();
    assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
    assert!(scene.materials[0].diffuse_texture.is_none());
    assert_eq!(scene.materials[0].diffuse, Vec3::ONE);
    let strict = LoadOptions { strict: true };
    let error = load_obj_with(&path, &strict).unwrap_err().to_string();
    assert!(
        error.contains("gone.png") && error.contains("map_Kd"),
        "{error}"
    );
}
