//! The wavefront engine (`--engine wavefront`): it converges to the independent
//! reference at the scalar loop's error per sample, each (pixel, sample) keeps its own
//! stream whatever the threads and passes, the packet queries answer as single rays
//! do, and what it does not render yet is refused in one line.

mod common;

use std::path::Path;

use ember::accel::{Accel, Bvh, EmbreeAccel, Hits16, Ray, Rays16, PACKET};
use ember::embree::{BuildQuality, Device};
use ember::film::Film;
use ember::image::{compare, Image};
use ember::integrator::IntegratorKind;
use ember::render::{render, Engine, RenderSettings};
use ember::scene::{load_obj, Camera, CameraSettings, Light, PointLight, Scene};
use ember::wavefront::LaneScene;
use glam::Vec3;

fn repo(path: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn cornell() -> Scene {
    load_obj(&repo("meshes/CornellBox-Original.obj"))
        .expect("bundled Cornell box loads")
        .0
}

/// The camera of `tests/data/references/cornell-box` (its README).
fn reference_camera(width: u32, height: u32) -> Camera {
    CameraSettings {
        eye: Vec3::new(0.0, 1.0, 3.9),
        look_at: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(40.0),
        lens: Default::default(),
    }
    .camera(width, height)
}

fn settings(size: u32, spp: u32, max_depth: u32, engine: Engine) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth,
        seed: 5,
        integrator: IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine,
    }
}

fn embree(scene: &Scene) -> EmbreeAccel {
    let device = Device::new("").unwrap();
    let (p, t) = (&scene.mesh.positions, &scene.mesh.triangles);
    EmbreeAccel::build(&device, p, t, BuildQuality::High).unwrap()
}

fn render_with<A: Accel>(scene: &Scene, accel: &A, s: &RenderSettings, threads: usize) -> Image {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let camera = reference_camera(s.width, s.height);
    pool.install(|| render(scene, accel, &camera, s, &|_| {})).0
}

fn bits(image: &Image) -> Vec<u32> {
    image
        .pixels
        .iter()
        .flat_map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

/// Against Mitsuba's converged images (full light transport, and direct light alone):
/// the error falls as 1/spp, and at 16 spp it is the scalar loop's within 10% (the same
/// estimator, the same stratification of the camera and first vertex).
#[test]
fn converges_to_the_reference_at_the_scalar_error_per_sample() {
    let scene = cornell();
    let accel = embree(&scene);
    for (reference, depth) in [
        (
            "tests/data/references/cornell-box/cornell_ref_8192spp.exr",
            8,
        ),
        (
            "tests/data/references/cornell-box/cornell_direct_ref_8192spp.exr",
            2,
        ),
    ] {
        let reference = Image::load(&repo(reference)).expect("reference ships in tests/data");
        let error = |spp, engine| {
            let image = render_with(&scene, &accel, &settings(512, spp, depth, engine), 2);
            compare(&image, &reference).unwrap().rel_mse
        };
        let (low, high) = (error(2, Engine::Wavefront), error(16, Engine::Wavefront));
        let scalar = error(16, Engine::Scalar);
        eprintln!("depth {depth}: wavefront {low:.3e} at 2 spp, {high:.3e} at 16; scalar {scalar:.3e} at 16");
        assert!(
            low / high > 6.0,
            "error must fall as 1/spp: {low:e} -> {high:e}"
        );
        assert!(
            high < 1.1 * scalar,
            "wavefront {high:e} vs scalar {scalar:e}"
        );
    }
}

/// Each (pixel, sample) has its own stream: one thread or two, one pass or passes of
/// doubling sample counts (how `ember render` renders), the film is the same, bit for
/// bit; another seed gives another image.
#[test]
fn the_same_image_whatever_the_threads_and_passes() {
    let scene = cornell();
    let accel = embree(&scene);
    let s = RenderSettings {
        height: 45,
        ..settings(70, 13, 8, Engine::Wavefront)
    };
    let one = render_with(&scene, &accel, &s, 1);
    let two = render_with(&scene, &accel, &s, 2);
    assert_eq!(bits(&one), bits(&two));
    let camera = reference_camera(s.width, s.height);
    let passes = common::render_stopping(
        &scene,
        &accel,
        &camera,
        &s,
        Film::new(s.width, s.height, 0..s.spp),
        1,
        None,
    );
    assert_eq!(bits(&one), bits(&passes.resolve()));
    let other = render_with(&scene, &accel, &RenderSettings { seed: 6, ..s }, 2);
    assert_ne!(bits(&one), bits(&other));
}

/// The native BVH answers the packets ray by ray: the two backends give the same
/// image up to rounding (their triangle tests round the hit distance differently, and a
/// path that meets an edge or a tie may go another way), far closer than two seeds.
#[test]
fn both_backends_give_the_same_image() {
    let scene = cornell();
    let s = settings(64, 8, 8, Engine::Wavefront);
    let bvh = Bvh::build(&scene.mesh.positions, &scene.mesh.triangles).unwrap();
    let accel = embree(&scene);
    let a = render_with(&scene, &accel, &s, 2);
    let b = render_with(&scene, &bvh, &s, 2);
    let other_seed = render_with(&scene, &accel, &RenderSettings { seed: 6, ..s }, 2);
    let backends = compare(&a, &b).unwrap().rel_mse;
    let seeds = compare(&a, &other_seed).unwrap().rel_mse;
    assert!(
        backends * 10.0 < seeds,
        "backends {backends:e}, seeds {seeds:e}"
    );
    let mean = |f: &Image| f.pixels.iter().map(|p| p.element_sum()).sum::<f32>();
    assert!((mean(&a) - mean(&b)).abs() <= 0.01 * mean(&a));
}

/// `rtcIntersect16` and `rtcOccluded16` through the wrapper answer every active lane as
/// the single-ray queries do, leave inactive lanes missed and unblocked, and treat a
/// lane with a NaN or huge ray as inactive (as the single queries refuse those rays).
#[test]
fn packets_answer_as_single_rays() {
    let scene = cornell();
    let accel = embree(&scene);
    let mut rng = ember::sampling::Rng::seeded(9);
    for round in 0..200 {
        let mut rays = Rays16::default();
        let active: [bool; PACKET] = std::array::from_fn(|l| (l + round) % 5 != 0);
        for l in 0..PACKET {
            let origin = Vec3::new(
                rng.f32() * 2.0 - 1.0,
                rng.f32() * 2.0,
                rng.f32() * 2.0 - 1.0,
            );
            let dir = ember::sampling::uniform_sphere(rng.f32(), rng.f32());
            let tmax = if l % 2 == 0 {
                f32::INFINITY
            } else {
                rng.f32() * 3.0
            };
            let mut ray = Ray::segment(origin, dir, tmax);
            if l == 7 && round % 3 == 0 {
                ray.dir = Vec3::new(f32::NAN, 0.0, 1.0);
            }
            if l == 9 && round % 3 == 0 {
                ray.origin = Vec3::splat(1e30);
            }
            rays.set(l, &ray);
        }
        let mut hits = Hits16::default();
        accel.intersect16(&active, &rays, &mut hits, round % 2 == 0);
        let blocked = accel.occluded16(&active, &rays);
        for l in 0..PACKET {
            // The same distance; a tie between coincident triangles may name either.
            let single = active[l].then(|| accel.intersect(&rays.ray(l))).flatten();
            let t = |h: Option<ember::accel::Hit>| h.map(|h| h.t.to_bits());
            assert_eq!(t(hits.hit(l)), t(single), "round {round}, lane {l}");
            let occluded = active[l] && accel.occluded(&rays.ray(l));
            assert_eq!(blocked[l], occluded, "round {round}, lane {l}");
        }
    }
}

/// What the engine does not render yet is named, not rendered wrongly: the glossy box
/// (GGX lobes), placed lights, two-sided emitters and the CLI flags it cannot honour are
/// refused in one line each.
#[test]
fn what_it_does_not_render_yet_is_refused_in_one_line() {
    let glossy = load_obj(&repo("meshes/CornellBox-GlossyMix.obj"))
        .unwrap()
        .0;
    let reason = LaneScene::new(&glossy).unwrap_err();
    assert!(reason.contains("Lambert"), "{reason}");
    assert!(LaneScene::new(&cornell()).is_ok());
    let mut lit = cornell();
    lit.lights.push(Light::Point(PointLight {
        position: Vec3::new(0.0, 1.5, 0.0),
        intensity: Vec3::ONE,
        spot: None,
    }));
    let reason = LaneScene::new(&lit).unwrap_err();
    assert!(reason.contains("lights"), "{reason}");
    let mut two_sided = cornell();
    for m in &mut two_sided.materials {
        m.two_sided_emission = m.is_emissive();
    }
    let reason = LaneScene::new(&two_sided).unwrap_err();
    assert!(reason.contains("two-sided emitters"), "{reason}");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.exr");
    let out = out.to_str().unwrap();
    let glossy_path = repo("meshes/CornellBox-GlossyMix.obj");
    let original = repo("meshes/CornellBox-Original.obj");
    for (scene, extra) in [
        (glossy_path.to_str().unwrap(), &[][..]),
        (original.to_str().unwrap(), &["--integrator", "bsdf"][..]),
        (original.to_str().unwrap(), &["--guiding"][..]),
        (original.to_str().unwrap(), &["--aov", "albedo"][..]),
        (original.to_str().unwrap(), &["--aperture", "0.1"][..]),
    ] {
        let mut args = vec![
            "render",
            scene,
            "--engine",
            "wavefront",
            "--spp",
            "1",
            "-o",
            out,
        ];
        args.extend_from_slice(extra);
        let run = common::ember_in(&args, dir.path());
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{extra:?} rendered");
        let lines: Vec<_> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "{stderr}");
        assert!(
            lines[0].starts_with("error:") && lines[0].contains("wavefront"),
            "{stderr}"
        );
        assert!(!Path::new(out).exists());
    }
}
