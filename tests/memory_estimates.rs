//! Every memory estimate ember checks before it allocates, pinned against the peak it
//! estimates (issue 48). Each case runs in a child process (this test program run
//! again for that case alone) with `EMBER_MEMORY_LIMIT` set: the child starts the
//! kernel's peak (`VmHWM`) again from its resident memory just before the work
//! (`ember::limits::reset_peak_resident`), does it, and reports how far the peak grew.
//!
//! For each reader and input, with a limit the estimate fits in, the work succeeds and
//! its peak stays within the estimate, and the estimate is not far above the peak (so
//! that it refuses nothing that would fit); with the limit below the estimate, the work
//! is refused before it allocates, its peak far under the limit. The CLI's own
//! estimates (`ember denoise`'s, `ember bench`'s) are pinned the same way against the
//! peak the run reports (its summary line, its JSON), less that of a tiny run.
//!
//! A program of its own (`harness = false`): the child runs one case, which a test
//! function of the standard harness could not do alone.

#[allow(dead_code)]
#[path = "common/ply.rs"]
mod ply;
#[allow(dead_code, unused_imports)]
#[path = "../src/cli/bench/procedural.rs"]
mod procedural;

use std::path::{Path, PathBuf};
use std::process::Command;

use ember::image::{Image, ImageFile, Layer, LayeredImage};
use ember::scene::{load_obj, SceneFile};

const CASE: &str = "EMBER_MEMORY_CASE";
const INPUT: &str = "EMBER_MEMORY_INPUT";
const LIMIT: &str = "EMBER_MEMORY_LIMIT";

/// How far an estimate may lie above the peak it estimates.
const MOST_OVER: f64 = 4.0;

fn main() {
    match std::env::var(CASE) {
        Ok(case) => child(&case, Path::new(&std::env::var(INPUT).unwrap())),
        Err(_) => parent(),
    }
}

// ---------------------------------------------------------------------------------
// The child: one case's work, measured.

/// Runs `case` on `input`, then prints `ok GROWN` or `refused GROWN MESSAGE`: how many
/// bytes the peak resident memory grew above the resident memory before the work.
fn child(case: &str, input: &Path) {
    // Whatever the work needs that is not its own (threads, Embree's device) first.
    let device = ember::embree::Device::new("threads=1").unwrap();
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .unwrap();
    // What placing takes apart from the placements: the OBJ, and the list of them
    // (a scene file's parse, which would leave its freed memory for the work to
    // reuse unseen, is the case "scene-read").
    let placing = case.strip_prefix("place-").map(|n| {
        let (tri, _) = load_obj(input).unwrap();
        (tri, translations(n.parse().unwrap()))
    });
    let before = ember::limits::resident_bytes().unwrap();
    assert!(ember::limits::reset_peak_resident(), "cannot reset VmHWM");
    let result = match placing {
        Some((tri, instances)) => place(&tri, instances, &device),
        None => work(case, input),
    };
    let grown = ember::limits::peak_resident_bytes()
        .unwrap()
        .saturating_sub(before);
    match result {
        Ok(()) => println!("ok {grown}"),
        Err(e) => println!("refused {grown} {}", e.replace('\n', " ")),
    }
}

/// `n` placements of mesh 0 on a grid, as `placements` writes them.
fn translations(n: usize) -> Vec<ember::geometry::Instance> {
    (0..n)
        .map(|i| ember::geometry::Instance {
            mesh: 0,
            transform: glam::Affine3A::from_translation(glam::Vec3::new(
                (i % 100) as f32,
                (i / 100 % 100) as f32,
                (i / 10000) as f32,
            )),
        })
        .collect()
}

/// Places `obj` by `instances`, as a scene file's loading does, and renders the scene
/// on both backends.
fn place(
    obj: &ember::scene::Scene,
    instances: Vec<ember::geometry::Instance>,
    device: &ember::embree::Device,
) -> Result<(), String> {
    let text = |e: &dyn std::fmt::Display| e.to_string();
    let scene = ember::scene::place(&[obj], instances).map_err(|e| text(&e))?;
    let instancing = scene.instancing.as_ref().unwrap();
    let mesh = &scene.mesh;
    let bvh = ember::accel::instanced_bvh(mesh, instancing).map_err(|e| text(&e))?;
    render(&scene, &bvh);
    drop(bvh);
    let quality = ember::embree::BuildQuality::High;
    let embree = ember::accel::instanced_embree(device, mesh, instancing, quality, None)
        .map_err(|e| text(&e))?;
    render(&scene, &embree);
    Ok(())
}

/// The work of `case`.
fn work(case: &str, input: &Path) -> Result<(), String> {
    let text = |e: &dyn std::fmt::Display| e.to_string();
    match case {
        "scene-read" => SceneFile::read(input).map(drop).map_err(|e| text(&e)),
        "scene-load" => SceneFile::read(input)
            .and_then(|file| file.load_scene(&Default::default()))
            .map(drop)
            .map_err(|e| text(&e)),
        "obj-load" => load_obj(input).map(drop).map_err(|e| text(&e)),
        "ply-load" => ember::scene::load_ply(input)
            .map(drop)
            .map_err(|e| text(&e)),
        "exr-read" => LayeredImage::read_exr(input)
            .map(drop)
            .map_err(|e| text(&e)),
        "image-load" => Image::load(input).map(drop).map_err(|e| text(&e)),
        "compare" => Image::load_pair(input, input)
            .map(drop)
            .map_err(|e| text(&e)),
        other => panic!("unknown case {other}"),
    }
}

/// 16x16 pixels at 1 sample through the framing camera.
fn render<A: ember::accel::Accel>(scene: &ember::scene::Scene, accel: &A) {
    let (lo, hi) = scene.bounds();
    let camera = ember::scene::CameraSettings::framing(lo, hi, 40.0).camera(16, 16);
    let settings = ember::render::RenderSettings {
        width: 16,
        height: 16,
        spp: 1,
        max_depth: 2,
        seed: 1,
        integrator: ember::integrator::IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    ember::render::render(scene, accel, &camera, &settings, &|_| {});
}

// ---------------------------------------------------------------------------------
// The parent: inputs made at run time, each case run with the estimate's limit and
// below it.

/// What a child reported.
#[derive(Debug)]
struct Run {
    ok: bool,
    grown: u64,
    message: String,
}

fn run_child(case: &str, input: &Path, limit: u64) -> Run {
    let out = Command::new(std::env::current_exe().unwrap())
        .env(CASE, case)
        .env(INPUT, input)
        .env(LIMIT, limit.to_string())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{case}: {stdout} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut words = stdout.trim().splitn(3, ' ');
    let ok = words.next() == Some("ok");
    let grown = words.next().unwrap().parse().unwrap();
    Run {
        ok,
        grown,
        message: words.next().unwrap_or("").to_owned(),
    }
}

/// `case` on `input` under a limit of `estimate`: done, its peak within the estimate
/// and the estimate within [`MOST_OVER`] times it. Under half the estimate: refused
/// naming memory, its peak under that limit.
fn pin(case: &str, input: &Path, estimate: u64) {
    pin_peak(case, input, estimate);
    let limit = estimate / 2;
    let refused = run_child(case, input, limit);
    assert!(!refused.ok, "{case} done under half its estimate");
    assert!(refused.message.contains("memory"), "{}", refused.message);
    assert!(
        refused.grown < limit,
        "{case}: refused, but only after the peak grew {} (limit {limit})",
        refused.grown
    );
}

/// The first half of [`pin`]: done within the estimate, which is not far above.
fn pin_peak(case: &str, input: &Path, estimate: u64) {
    let fits = run_child(case, input, estimate);
    println!(
        "{case} {}: estimate {estimate}, peak grew {} ({:.2}x)",
        input.file_name().unwrap().to_string_lossy(),
        fits.grown,
        estimate as f64 / fits.grown.max(1) as f64
    );
    assert!(
        fits.ok,
        "{case} refused within its estimate: {}",
        fits.message
    );
    assert!(
        fits.grown <= estimate,
        "{case}: the peak grew {} past the estimate {estimate}",
        fits.grown
    );
    assert!(
        estimate as f64 <= MOST_OVER * fits.grown as f64,
        "{case}: the estimate {estimate} is over {MOST_OVER}x the peak {}",
        fits.grown
    );
}

fn parent() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_files(d);
    material_libraries(d);
    ply_files(d);
    exr_files(d);
    images(d);
    #[cfg(feature = "denoise")]
    denoise(d);
    #[cfg(not(feature = "denoise"))]
    println!("denoise: this build cannot denoise (feature `denoise` off): not pinned");
    bench(d);
    println!("memory estimates: all pinned");
}

/// A scene file of one triangle's OBJ placed `n` times.
fn placements(dir: &Path, n: usize) -> PathBuf {
    std::fs::write(dir.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let mut text = String::from("[[obj]]\nfile = \"tri.obj\"\nname = \"t\"\n");
    for i in 0..n {
        text += &format!(
            "[[instance]]\nobj = \"t\"\ntranslate = [{}, {}, {}]\n",
            i % 100,
            i / 100 % 100,
            i / 10000
        );
    }
    let path = dir.join(format!("placed-{n}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

fn scene_files(d: &Path) {
    // Entries, many keys in one table, inline tables: what the estimate counts.
    let keys: String = (0..100_000).map(|i| format!("k{i} = 1\n")).collect();
    let inline = vec!["{ a = 1 }"; 100_000].join(", ");
    let obj = "[[obj]]\nfile = \"tri.obj\"\n";
    std::fs::write(d.join("keys.toml"), format!("[render]\n{keys}{obj}")).unwrap();
    std::fs::write(
        d.join("inline.toml"),
        format!("[render]\nx = [{inline}]\n{obj}"),
    )
    .unwrap();
    for path in [
        placements(d, 100_000),
        d.join("keys.toml"),
        d.join("inline.toml"),
    ] {
        let bytes = std::fs::read(&path).unwrap();
        pin(
            "scene-read",
            &path,
            ember::scene::parse_memory_bytes(&bytes),
        );
    }
    // Placing and rendering on both backends: the estimate of a scene file's loading.
    let n = 50_000;
    let (tri, _) = load_obj(&d.join("tri.obj")).unwrap();
    let estimate = ember::scene::placement_memory_bytes(&[&tri], std::iter::repeat_n(0, n));
    pin_peak(&format!("place-{n}"), &d.join("tri.obj"), estimate);
    // The same with an OBJ of 100 emissive triangles, each placement with its
    // world-space copies of them.
    let lamps = lamps(d);
    let (lamp, _) = load_obj(&lamps).unwrap();
    let n = 5000;
    let estimate = ember::scene::placement_memory_bytes(&[&lamp], std::iter::repeat_n(0, n));
    pin_peak(&format!("place-{n}"), &lamps, estimate);
    // A scene file's loading checks that estimate, and refuses what does not fit
    // before it places anything: under a limit its parse fits in.
    let mut text = String::from("[[obj]]\nfile = \"lamps.obj\"\nname = \"l\"\n");
    for i in 0..n - 1 {
        text += &format!("[[instance]]\nobj = \"l\"\ntranslate = [{i}, 0, 0]\n");
    }
    let path = d.join("lamps.toml");
    std::fs::write(&path, &text).unwrap();
    let file = SceneFile::read(&path).unwrap();
    assert_eq!(file.load_memory_bytes(&[&lamp]), estimate);
    let limit =
        ember::scene::parse_memory_bytes(text.as_bytes()) + lamp.mesh.triangles.len() as u64 * 4096;
    assert!(limit < estimate);
    let refused = run_child("scene-load", &path, limit);
    assert!(
        !refused.ok && refused.message.contains("5000 placements"),
        "{refused:?}"
    );
}

/// An OBJ of 100 emissive triangles.
fn lamps(dir: &Path) -> PathBuf {
    std::fs::write(dir.join("lamps.mtl"), "newmtl lamp\nKd 0 0 0\nKe 1 1 1\n").unwrap();
    let mut obj = String::from("mtllib lamps.mtl\nusemtl lamp\n");
    for t in 0..100 {
        obj += &format!("v {t} 0 0\nv {t}.5 0 0\nv {t} 1 0\nf -3 -2 -1\n");
    }
    let path = dir.join("lamps.obj");
    std::fs::write(&path, obj).unwrap();
    path
}

/// OBJs of one triangle whose MTL holds 200 000 materials, or 200 000 statements of
/// distinct unknown keys (each kept for its warning): the estimate of the library's
/// text and materials, and of the OBJ's text.
fn material_libraries(d: &Path) {
    let materials: String = (0..200_000).map(|i| format!("newmtl m{i}\n")).collect();
    let unknown: String = "newmtl m\n".to_owned()
        + &(0..200_000)
            .map(|i| format!("k{i} v\n"))
            .collect::<String>();
    for (name, mtl, count) in [("materials", materials, 200_000), ("unknown", unknown, 1)] {
        let obj = format!("mtllib {name}.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m0\nf 1 2 3\n");
        std::fs::write(d.join(format!("{name}.mtl")), &mtl).unwrap();
        let path = d.join(format!("{name}.obj"));
        std::fs::write(&path, &obj).unwrap();
        let estimate = mtl.len() as u64 * ember::scene::MEMORY_PER_MTL_BYTE
            + count * ember::scene::MEMORY_PER_MATERIAL
            + obj.len() as u64 * ember::scene::MEMORY_PER_OBJ_BYTE;
        pin("obj-load", &path, estimate);
    }
}

/// PLY meshes of 200 000 vertices: with every attribute and a triangle each, in binary
/// and in ASCII; positions alone; and one polygon of them all, whose triangles the
/// header does not count (its list grows as it is fanned).
fn ply_files(d: &Path) {
    use ember::scene::{MEMORY_PER_PLY_TRIANGLE, MEMORY_PER_PLY_VERTEX};
    use ply::{Encoding, PlyMesh};
    let n = 200_000usize;
    let positions: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let a = i as f32 * 1e-3;
            [a.cos() * (1.0 + a), a.sin(), (i % 7) as f32]
        })
        .collect();
    let triangles: Vec<Vec<i64>> = (0..n as i64)
        .map(|i| vec![i, (i + 1) % n as i64, (i + 2) % n as i64])
        .collect();
    let full = PlyMesh::new(&positions, &triangles)
        .with("float", "nx", |_| 0.0)
        .with("float", "ny", |_| 1.0)
        .with("float", "nz", |_| 0.0)
        .with("float", "u", |i| i as f64 / n as f64)
        .with("float", "v", |_| 0.5)
        .with("uchar", "red", |i| (i % 256) as f64)
        .with("uchar", "green", |_| 7.0)
        .with("uchar", "blue", |_| 9.0);
    let bare = PlyMesh::new(&positions, &triangles);
    let mut fan = PlyMesh::new(&positions, &[(0..n as i64).collect()]);
    fan.list_types = ("uint".into(), "int".into());
    let estimate = |triangles: usize| {
        n as u64 * MEMORY_PER_PLY_VERTEX + triangles as u64 * MEMORY_PER_PLY_TRIANGLE
    };
    for (name, mesh, encoding, triangles) in [
        ("full.ply", &full, Encoding::LittleEndian, n),
        ("full-ascii.ply", &full, Encoding::Ascii, n),
        ("bare.ply", &bare, Encoding::BigEndian, n),
        ("fan.ply", &fan, Encoding::LittleEndian, n - 1),
    ] {
        let path = d.join(name);
        std::fs::write(&path, mesh.bytes(encoding)).unwrap();
        pin("ply-load", &path, estimate(triangles));
    }
}

/// A `w`x`h` EXR of ember's layers (image, albedo, normal, depth) in float.
fn layered_exr(path: &Path, w: u32, h: u32) {
    let mut image = LayeredImage::new(w, h);
    let pixels = (w * h) as usize;
    let data = |n: usize| (0..pixels * n).map(|i| (i % 977) as f32 / 977.0).collect();
    image.layers.push(Layer::new("", &["R", "G", "B"], data(3)));
    image
        .layers
        .push(Layer::new("albedo", &["R", "G", "B"], data(3)));
    image
        .layers
        .push(Layer::new("normal", &["X", "Y", "Z"], data(3)));
    image.layers.push(Layer::new("depth", &["Z"], data(1)));
    image.write_exr(path).unwrap();
}

fn exr_files(d: &Path) {
    let path = d.join("layers.exr");
    layered_exr(&path, 1024, 768);
    let estimate = LayeredImage::exr_size(&path).unwrap().read_bytes;
    pin("exr-read", &path, estimate);
}

/// A 1024x768 picture in every format ember reads as an image.
fn images(d: &Path) {
    let (w, h) = (1024u32, 768u32);
    let pixels: Vec<glam::Vec3> = (0..w * h)
        .map(|i| glam::Vec3::new((i % w) as f32 / w as f32, (i / w) as f32 / h as f32, 0.5))
        .collect();
    let image = Image {
        width: w,
        height: h,
        pixels,
    };
    for ext in ["exr", "hdr", "png", "jpg"] {
        let path = d.join(format!("picture.{ext}"));
        match ext {
            "jpg" => {
                let bytes = image.encode(ember::image::OutputFormat::Png).unwrap();
                let png = ::image::load_from_memory(&bytes).unwrap();
                png.save_with_format(&path, ::image::ImageFormat::Jpeg)
                    .unwrap();
            }
            _ => image.save(&path).unwrap(),
        }
        let file = ImageFile::open(&path).unwrap();
        pin(
            "image-load",
            &path,
            file.memory_bytes(Image::LOAD_BYTES_PER_PIXEL),
        );
        let pair = ember::image::pair_memory_bytes(&file, &ImageFile::open(&path).unwrap());
        pin("compare", &path, pair);
    }
}

// ---------------------------------------------------------------------------------
// The CLI's own estimates, against the peak its run reports.

const EMBER: &str = env!("CARGO_BIN_EXE_ember");

/// `ember ARGS` in `dir` with `EMBER_MEMORY_LIMIT` set to `limit`: exit status and
/// stderr.
fn ember(dir: &Path, args: &[&str], limit: u64) -> (bool, String, String) {
    let out = Command::new(EMBER)
        .args(args)
        .current_dir(dir)
        .env(LIMIT, limit.to_string())
        .output()
        .unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.success(), text(&out.stdout), text(&out.stderr))
}

/// Bytes from `human_bytes`'s "12.3 MiB" following `after` in `text`.
fn bytes_after(text: &str, after: &str) -> u64 {
    let rest = &text[text
        .find(after)
        .unwrap_or_else(|| panic!("{after:?} in {text}"))
        + after.len()..];
    let mut words = rest.split_whitespace();
    let value: f64 = words.next().unwrap().parse().unwrap();
    let unit = match words.next().unwrap().trim_end_matches([',', ')']) {
        "B" => 1.0,
        "KiB" => 1024.0,
        "MiB" => 1048576.0,
        "GiB" => 1073741824.0,
        other => panic!("unit {other}"),
    };
    (value * unit) as u64
}

/// `ember denoise` of a 1024x768 EXR (with albedo and normal) into an EXR: the peak its
/// summary reports less that of denoising an 8x8 one, against the estimate its
/// refusal names (to 0.05 MiB).
#[cfg(feature = "denoise")]
fn denoise(d: &Path) {
    layered_exr(&d.join("big.exr"), 1024, 768);
    layered_exr(&d.join("tiny.exr"), 8, 8);
    let peak = |input: &str| {
        let (ok, _, err) = ember(d, &["denoise", input, "-o", "denoised.exr"], u64::MAX / 2);
        assert!(ok, "{err}");
        bytes_after(&err, "peak memory ")
    };
    let grown = peak("big.exr") - peak("tiny.exr");
    let (ok, _, err) = ember(d, &["denoise", "big.exr", "-o", "denoised.exr"], 1);
    assert!(!ok && err.lines().count() == 1, "{err}");
    let estimate = bytes_after(&err, "needs ");
    println!(
        "denoise 1024x768: estimate {estimate}, peak grew {grown} ({:.2}x)",
        estimate as f64 / grown as f64
    );
    assert!(grown <= estimate, "{grown} > {estimate}");
    assert!(estimate as f64 <= MOST_OVER * grown as f64);
}

/// `ember bench` of a procedural sphere of 300 000 triangles with 20 000 rays per set:
/// the peak its JSON reports less that of a sphere of 1000 triangles with 1000 rays,
/// against `bench_memory_bytes`; and a mesh that does not fit is refused before it is
/// made.
fn bench(d: &Path) {
    let peak = |mesh: &str, rays: &str| {
        let args = [
            "bench",
            "--procedural",
            mesh,
            "--rays",
            rays,
            "--min-time",
            "0",
        ];
        let (ok, out, err) = ember(
            d,
            &[&args[..], &["--threads", "1", "--json"]].concat(),
            u64::MAX / 2,
        );
        assert!(ok, "{err}");
        let json: serde_json::Value = serde_json::from_str(&out).unwrap();
        json["peak_resident_bytes"].as_u64().unwrap()
    };
    let grown = peak("sphere:300k", "20000") - peak("sphere:1k", "1000");
    let sphere: procedural::Procedural = "sphere:300k".parse().unwrap();
    let estimate = procedural::bench_memory_bytes(sphere.most_triangles(), 20_000);
    println!(
        "bench sphere:300k: estimate {estimate}, peak grew {grown} ({:.2}x)",
        estimate as f64 / grown as f64
    );
    assert!(grown <= estimate, "{grown} > {estimate}");
    assert!(estimate as f64 <= MOST_OVER * grown as f64);
    let (ok, _, err) = ember(d, &["bench", "--procedural", "soup:100m"], estimate);
    assert!(
        !ok && err.lines().count() == 1 && err.contains("soup:100000000"),
        "{err}"
    );
}
