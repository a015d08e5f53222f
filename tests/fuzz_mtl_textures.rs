//! Fuzzing the texture statements of MTL files (`map_Kd [-options args]... file`, and
//! every other map) through ember's scene loading from disk, on the stable toolchain
//! (proptest). Statements are made from the MTL options with hostile arguments (NaN,
//! infinities, huge numbers, words, missing ones), unknown options, and files that are
//! good images of several kinds, damaged images (truncated JPEG and PNG, an EXR with an
//! infinite texel), no image at all, a directory, or missing.
//!
//! What must hold: no input panics; a refusal is one line; a statement made only of
//! known options with finite arguments and a good file loads; a scene that loads
//! has finite texels and bump multipliers, texture indices in range, and renders
//! with no sample NaN or infinite.
//!
//! `EMBER_FUZZ_SECONDS=N` runs for N seconds and prints how many inputs were tried
//! (`.ci/fuzz.sh` does). Failures found become cases in `regressions` below.

mod common;

use std::path::PathBuf;
use std::sync::OnceLock;

use ember::image::Image;
use ember::scene::{load_obj, Scene, Texels};
use glam::Vec3;
use proptest::prelude::*;

/// The texture files, made once in a temporary directory (kept for the whole run).
struct Files {
    dir: tempfile::TempDir,
}

/// Images every map reads (an absolute path and names with a space or a backslash too).
const GOOD: [&str; 8] = [
    "rgb.png",
    "grey-alpha.png",
    "rgba.png",
    "deep.png",
    "float.exr",
    "photo.jpg",
    "sub dir/b.png",
    "sub dir\\b.png",
];
/// Files no map may accept.
const BAD: [&str; 7] = [
    "cut.jpg",
    "cut.png",
    "inf.exr",
    "empty.png",
    "text.png",
    "folder.png",
    "missing.png",
];

fn files() -> &'static Files {
    static FILES: OnceLock<Files> = OnceLock::new();
    FILES.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let gradient = |w: u32, h: u32, f: &dyn Fn(u32, u32) -> [u8; 4]| {
            image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(f(x, y)))
        };
        let rgba = gradient(5, 3, &|x, y| {
            [(x * 50) as u8, (y * 80) as u8, 90, (x * 60) as u8]
        });
        image::DynamicImage::from(rgba.clone())
            .to_rgb8()
            .save(d.join("rgb.png"))
            .unwrap();
        image::DynamicImage::from(rgba.clone())
            .to_luma_alpha8()
            .save(d.join("grey-alpha.png"))
            .unwrap();
        rgba.save(d.join("rgba.png")).unwrap();
        image::DynamicImage::from(rgba.clone())
            .to_rgb16()
            .save(d.join("deep.png"))
            .unwrap();
        std::fs::create_dir(d.join("sub dir")).unwrap();
        std::fs::copy(d.join("rgb.png"), d.join("sub dir/b.png")).unwrap();
        let texels: Vec<Vec3> = (0..12).map(|i| Vec3::splat(i as f32 / 4.0)).collect();
        let float = Image {
            width: 4,
            height: 3,
            pixels: texels.clone(),
        };
        float.save(&d.join("float.exr")).unwrap();
        let mut inf = float.clone();
        inf.pixels[7].y = f32::INFINITY;
        inf.save(&d.join("inf.exr")).unwrap();
        let photo = gradient(40, 24, &|x, y| [(x * 6) as u8, (y * 10) as u8, 128, 255]);
        image::DynamicImage::from(photo)
            .to_rgb8()
            .save(d.join("photo.jpg"))
            .unwrap();
        for (whole, cut) in [("photo.jpg", "cut.jpg"), ("rgb.png", "cut.png")] {
            let bytes = std::fs::read(d.join(whole)).unwrap();
            std::fs::write(d.join(cut), &bytes[..bytes.len() / 2]).unwrap();
        }
        std::fs::write(d.join("empty.png"), b"").unwrap();
        std::fs::write(d.join("text.png"), b"not an image\n").unwrap();
        std::fs::create_dir(d.join("folder.png")).unwrap();
        std::fs::write(
            d.join("scene.obj"),
            "mtllib scene.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\n\
             vt 1 1\nvt 0 1\nvn 0 0 1\nusemtl a\nf 1/1/1 2/2/1 3/3/1\nusemtl b\n\
             f 1/1/1 3/3/1 4/4/1\n",
        )
        .unwrap();
        Files { dir }
    })
}

/// One texture statement and whether it must load.
#[derive(Clone, Debug)]
struct Statement {
    text: String,
    must_load: bool,
}

const SLOTS: [&str; 11] = [
    "map_Kd", "map_Ks", "map_Ke", "map_Ns", "map_Pr", "map_Pm", "map_d", "bump", "map_Bump",
    "norm", "map_bump",
];

/// The options of the MTL specification and how many numbers each takes when valid.
const OPTIONS: [(&str, u32, u32); 13] = [
    ("-blendu", 1, 1),
    ("-blendv", 1, 1),
    ("-bm", 1, 1),
    ("-boost", 1, 1),
    ("-cc", 1, 1),
    ("-clamp", 1, 1),
    ("-imfchan", 1, 1),
    ("-mm", 2, 2),
    ("-texres", 1, 1),
    ("-type", 1, 1),
    ("-o", 1, 3),
    ("-s", 1, 3),
    ("-t", 1, 3),
];

/// A finite number as an MTL file writes it.
fn finite() -> impl Strategy<Value = String> {
    prop_oneof![
        (-10.0f32..10.0).prop_map(|v| v.to_string()),
        Just("0".to_owned()),
        Just("1".to_owned()),
        (-1e6f32..1e6).prop_map(|v| format!("{v:e}")),
    ]
}

/// An argument no number should be trusted to be.
fn hostile() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<f32>().prop_map(|v| v.to_string()),
        prop::sample::select(vec![
            "nan", "NaN", "inf", "-inf", "1e39", "-1e39", "3e38", "1e-45", "", "x", "on", "-",
            "--bm", "-bm", "1e", "0x10",
        ])
        .prop_map(str::to_owned),
    ]
}

/// `-option args...`: valid (a known option and its count of finite numbers), or not.
fn option() -> impl Strategy<Value = (String, bool)> {
    let valid = (0..OPTIONS.len(), 0u32..3)
        .prop_flat_map(|(k, extra)| {
            let (name, lo, hi) = OPTIONS[k];
            let count = (lo + extra).min(hi) as usize;
            // `-clamp` takes a word, on or off; every other option numbers.
            let arg = match name {
                "-clamp" => prop::sample::select(vec!["on".to_owned(), "off".to_owned()]).boxed(),
                _ => finite().boxed(),
            };
            prop::collection::vec(arg, count).prop_map(move |args| (name, args))
        })
        .prop_map(|(name, args)| (format!("{name} {}", args.join(" ")), true));
    let hostile = (
        prop_oneof![
            prop::sample::select(OPTIONS.iter().map(|o| o.0).collect::<Vec<_>>()),
            prop::sample::select(vec!["-bogus", "-", "-O", "-BM", "bm"]),
        ],
        prop::collection::vec(prop_oneof![finite(), hostile()], 0..5),
    )
        .prop_map(|(name, args)| (format!("{name} {}", args.join(" ")), false));
    prop_oneof![3 => valid, 2 => hostile]
}

fn statement() -> impl Strategy<Value = Statement> {
    let good = prop_oneof![
        prop::sample::select(GOOD.to_vec()).prop_map(str::to_owned),
        Just("absolute".to_owned()),
    ];
    let file = prop_oneof![
        3 => good.prop_map(|f| (f, true)),
        1 => prop::sample::select(BAD.to_vec()).prop_map(|f| (f.to_owned(), false)),
        1 => "[ -~]{0,12}".prop_map(|f| (f, false)),
    ];
    (
        prop::sample::select(SLOTS.to_vec()),
        prop::collection::vec(option(), 0..4),
        file,
    )
        .prop_map(|(slot, options, (file, good_file))| {
            let file = match file.as_str() {
                "absolute" => files().dir.path().join("rgb.png").display().to_string(),
                _ => file,
            };
            let must_load = good_file && options.iter().all(|(_, valid)| *valid);
            let options: Vec<String> = options.into_iter().map(|(o, _)| o).collect();
            Statement {
                text: format!("{slot} {} {file}", options.join(" ")),
                must_load,
            }
        })
}

/// An MTL file: the materials `a` and `b` of the scene's two triangles, each with
/// colours and texture statements.
#[derive(Clone, Debug)]
struct Input {
    materials: [Vec<Statement>; 2],
}

fn input() -> impl Strategy<Value = Input> {
    let material = || prop::collection::vec(statement(), 0..5);
    (material(), material()).prop_map(|(a, b)| Input { materials: [a, b] })
}

impl Input {
    fn mtl(&self) -> String {
        let mut text = String::new();
        for (name, statements) in ["a", "b"].iter().zip(&self.materials) {
            text.push_str(&format!(
                "newmtl {name}\nKd 0.5 0.6 0.7\nKs 0.2 0.2 0.2\nNs 20\n"
            ));
            for s in statements {
                text.push_str(&s.text);
                text.push('\n');
            }
        }
        text
    }

    fn must_load(&self) -> bool {
        self.materials.iter().flatten().all(|s| s.must_load)
    }
}

/// A scene of its own for each thread: the fuzz target and the regression cases run
/// at once, and one writing the shared `scene.mtl` while the other loads it made the
/// other load a material it never wrote.
fn scene_for_this_thread(mtl: &str) -> PathBuf {
    let dir = files().dir.path();
    let id = format!("{:?}", std::thread::current().id())
        .replace(|c: char| !c.is_ascii_alphanumeric(), "");
    let obj = std::fs::read_to_string(dir.join("scene.obj")).unwrap();
    let own = dir.join(format!("scene-{id}.obj"));
    std::fs::write(
        &own,
        obj.replace("mtllib scene.mtl", &format!("mtllib scene-{id}.mtl")),
    )
    .unwrap();
    std::fs::write(dir.join(format!("scene-{id}.mtl")), mtl).unwrap();
    own
}

/// Whether the input loaded (true) or was refused with an error.
fn check(input: &Input) -> Result<bool, TestCaseError> {
    let mtl = input.mtl();
    match load_obj(&scene_for_this_thread(&mtl)) {
        Err(e) => {
            let message = e.to_string();
            prop_assert!(!message.contains('\n'), "not one line: {message}");
            prop_assert!(!input.must_load(), "refused a valid MTL: {message}\n{mtl}");
            Ok(false)
        }
        Ok((scene, _)) => {
            check_scene(&scene)?;
            let dropped = common::fuzz::render_tiny(&scene)?;
            prop_assert_eq!(dropped, 0, "NaN or infinite samples\n{}", mtl);
            Ok(true)
        }
    }
}

fn check_scene(scene: &Scene) -> Result<(), TestCaseError> {
    let textures = scene.textures.len();
    for m in &scene.materials {
        let maps = &m.maps;
        let ids = [
            m.diffuse_texture,
            maps.specular,
            maps.shininess,
            maps.emission,
            maps.roughness,
            maps.metallic,
            maps.bump,
            maps.normal,
        ];
        prop_assert!(ids.into_iter().flatten().all(|t| (t as usize) < textures));
        prop_assert!(maps.bump_scale.is_finite());
        if let Some(a) = m.opacity_map {
            prop_assert!((a as usize) < scene.alpha_maps.len());
        }
    }
    for t in &scene.textures {
        let finite = match &t.texels {
            Texels::RgbF32(v) => v.iter().all(|x| x.is_finite()),
            Texels::GrayF32(v) => v.iter().all(|x| x.is_finite()),
            _ => true,
        };
        prop_assert!(finite);
    }
    Ok(())
}

#[test]
fn fuzz_mtl_texture_statements() {
    common::fuzz::run(
        "fuzz_mtl_texture_statements",
        "loaded and rendered",
        input(),
        check,
    );
}

/// Inputs the fuzzer (or review) found problems with, kept so they never come back.
mod regressions {
    use super::*;

    fn statement(text: &str, must_load: bool) -> Statement {
        Statement {
            text: text.to_owned(),
            must_load,
        }
    }

    fn loads_or_errs(statements: &[Statement]) {
        let input = Input {
            materials: [statements.to_vec(), Vec::new()],
        };
        check(&input).unwrap();
    }

    #[test]
    fn damaged_files_are_refused_and_good_ones_load() {
        loads_or_errs(&[statement("map_Kd -o 1 2 3 -bm 2 photo.jpg", true)]);
        loads_or_errs(&[statement("map_Kd cut.jpg", false)]);
        loads_or_errs(&[statement("map_Ke inf.exr", false)]);
        loads_or_errs(&[statement("bump -bm nan rgb.png", false)]);
        loads_or_errs(&[statement("norm -s 1 sub dir\\b.png", true)]);
    }
}
