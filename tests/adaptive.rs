//! Adaptive sampling: deterministic (any thread count, interrupted and resumed), it puts
//! the samples where the error is, converges to the independent reference, and at equal
//! total samples beats uniform sampling on GlossyMix.

mod common;

use std::path::{Path, PathBuf};

use common::{with_embree, Built};
use ember::film::Film;
use ember::image::{compare, Image};
use ember::integrator::IntegratorKind;
use ember::render::{Adaptive, RenderSettings};
use ember::scene::{load_obj, Camera, CameraSettings};
use glam::Vec3;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// The references' camera (tests/data/references/cornell-box/README.md).
fn camera(size: u32) -> Camera {
    CameraSettings {
        eye: Vec3::new(0.0, 1.0, 3.9),
        look_at: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(40.0),
        lens: Default::default(),
    }
    .camera(size, size)
}

fn settings(size: u32, spp: u32, adaptive: Option<Adaptive>) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 8,
        seed: 5,
        integrator: IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive,
        guiding: None,
        engine: Default::default(),
    }
}

/// Renders `film` on with `threads` workers, stopping after about `stop_after` samples.
fn run(
    built: &Built,
    s: &RenderSettings,
    film: Film,
    threads: usize,
    stop_after: Option<u64>,
) -> Film {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let camera = camera(s.width);
    pool.install(|| {
        common::render_stopping(&built.scene, &built.accel, &camera, s, film, 1, stop_after)
    })
}

fn cornell(name: &str) -> Built {
    with_embree(load_obj(&repo(&format!("meshes/{name}"))).unwrap().0)
}

#[test]
fn adaptive_renders_are_the_same_at_any_thread_count_and_after_any_interruption() {
    let built = cornell("CornellBox-Original.obj");
    let adaptive = Adaptive {
        threshold: 0.25,
        min_spp: 4,
    };
    let s = settings(40, 64, Some(adaptive));
    let fresh = || Film::new(s.width, s.height, 0..s.spp);
    let whole = run(&built, &s, fresh(), 2, None);
    assert_eq!(
        run(&built, &s, fresh(), 1, None),
        whole,
        "1 thread against 2"
    );

    // The samples went where the error is: some pixels stopped early, some went on.
    let done: Vec<u32> = whole.pixels.iter().map(|p| p.done).collect();
    let stopped = whole.pixels.iter().filter(|p| p.converged).count();
    assert!(
        stopped > 100 && stopped < done.len(),
        "{stopped} of {} stopped",
        done.len()
    );
    assert!(done.iter().all(|&d| d >= adaptive.min_spp));
    assert!(whole.pixels.iter().all(|p| p.converged || p.done == s.spp));
    assert!(whole.is_complete());

    // Interrupted anywhere (inside passes, tiles and pixels) and resumed, on one
    // thread or two: the same film, bit for bit.
    for (stops, threads) in [(vec![700u64, 5000, 20_000], 2), (vec![1, 3_333], 1)] {
        let mut film = fresh();
        for stop_after in stops {
            film = run(&built, &s, film, threads, Some(stop_after));
        }
        assert_eq!(run(&built, &s, film, threads, None), whole);
    }
}

/// The 512² reference averaged over `factor × factor` blocks: with a box pixel filter,
/// exactly the reference of the smaller image.
fn reference_at(path: &str, size: u32) -> Image {
    let full = Image::load(&repo(path)).unwrap();
    let factor = full.width / size;
    let mut out = Image::new(size, size);
    for y in 0..size {
        for x in 0..size {
            let mut sum = Vec3::ZERO;
            for dy in 0..factor {
                for dx in 0..factor {
                    sum += full.pixels[((y * factor + dy) * full.width + x * factor + dx) as usize];
                }
            }
            out.pixels[(y * size + x) as usize] = sum / (factor * factor) as f32;
        }
    }
    out
}

#[test]
fn adaptive_sampling_converges_to_the_reference_and_beats_uniform_sampling_at_equal_samples() {
    let size = 128;
    let built = cornell("CornellBox-GlossyMix.obj");
    let reference = reference_at(
        "tests/data/references/cornell-glossy/CornellBox-GlossyMix_ref_4096spp.exr",
        size,
    );
    let adaptive = Adaptive {
        threshold: 0.15,
        min_spp: Adaptive::default_min_spp(1024),
    };
    let s = settings(size, 1024, Some(adaptive));
    let film = run(&built, &s, Film::new(size, size, 0..s.spp), 2, None);
    let mean_spp = film.total_done() as f64 / f64::from(size * size);
    let uniform_spp = mean_spp.ceil() as u32;
    let u = settings(size, uniform_spp, None);
    let uniform = run(&built, &u, Film::new(size, size, 0..u.spp), 2, None);
    let (a, b) = (film.resolve(), uniform.resolve());
    let (ea, eb) = (
        compare(&a, &reference).unwrap(),
        compare(&b, &reference).unwrap(),
    );
    eprintln!(
        "GlossyMix {size}²: adaptive (T {}, mean {mean_spp:.1} spp) relMSE {:.3e}, uniform {uniform_spp} spp {:.3e}",
        adaptive.threshold, ea.rel_mse, eb.rel_mse
    );
    assert!(
        ea.rel_mse < eb.rel_mse,
        "adaptive {:.3e} against uniform {:.3e}",
        ea.rel_mse,
        eb.rel_mse
    );
    // Converges to the same image: the means agree to within the noise.
    let (ma, mr) = (a.mean(), reference.mean());
    eprintln!("means: adaptive {ma}, uniform {}, reference {mr}", b.mean());
    assert!(
        ((ma - mr) / mr).abs().max_element() < 0.01,
        "mean {ma} against {mr}"
    );
}

/// Adaptive shards: each shard of N adapts on its own samples to the threshold T·√N
/// (its share of the samples), so that their merge reaches about T; every shard is
/// complete when its pixels have all their samples or converged, and they merge.
#[test]
fn adaptive_shards_merge_into_one_image_with_the_samples_of_both() {
    let ember = env!("CARGO_BIN_EXE_ember");
    let dir = tempfile::tempdir().unwrap();
    let scene = repo("meshes/CornellBox-Original.obj");
    let common = [
        "--width",
        "32",
        "--height",
        "32",
        "--spp",
        "128",
        "--noise-threshold",
        "0.1",
    ];
    let mut shards = Vec::new();
    for i in 0..2 {
        let shard = dir.path().join(format!("{i}.shard"));
        let out = std::process::Command::new(ember)
            .arg("render")
            .arg(&scene)
            .args(common)
            .args(["--shard", &format!("{i}/2"), "-o"])
            .arg(&shard)
            .output()
            .unwrap();
        let log = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success() && log.contains("converged"), "{log}");
        shards.push(shard);
    }
    let merged = dir.path().join("m.exr");
    let out = std::process::Command::new(ember)
        .arg("merge")
        .args(&shards)
        .args(["--aov", "spp", "-o"])
        .arg(&merged)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let layers = ember::image::layers::LayeredImage::read_exr(&merged).unwrap();
    let spp = &layers.layer("spp").unwrap().data;
    // Each shard took at least --min-spp (32) of its 64 samples in every pixel.
    assert!(spp.iter().all(|&n| (64.0..=128.0).contains(&n)), "{spp:?}");
    assert!(spp.iter().any(|&n| n < 128.0), "some pixels converged");
}

/// `--time-limit` ends a render that would take far longer, writes its image (not a
/// partial one) and says what it reached.
#[test]
fn a_time_limit_ends_the_render_and_reports_what_it_reached() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.exr");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(repo("meshes/CornellBox-Original.obj"))
        .args([
            "--width",
            "32",
            "--height",
            "32",
            "--spp",
            "1000000",
            "--time-limit",
            "0.5",
        ])
        .args(["--noise-threshold", "0.0001", "--aov", "spp", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{log}");
    let summary = log
        .lines()
        .find(|l| l.starts_with("wrote"))
        .expect("a summary line");
    assert!(
        summary.contains("(min/mean/max)") && summary.contains("converged"),
        "{summary}"
    );
    let layers = ember::image::layers::LayeredImage::read_exr(&out).unwrap();
    let spp = &layers.layer("spp").unwrap().data;
    let (lo, hi) = spp
        .iter()
        .fold((f32::MAX, 0.0f32), |(a, b), &n| (a.min(n), b.max(n)));
    // Far short of --spp; and passes sized to the limit leave pixels close in samples.
    assert!(hi < 1_000_000.0 && lo >= 1.0, "{lo}..{hi}");
    assert!(!dir.path().join("t.partial.exr").exists());
}
