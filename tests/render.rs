//! Whole renders of the bundled Cornell box: reproducibility and energy.

use std::path::Path;

use ember::accel::EmbreeAccel;
use ember::embree::{BuildQuality, Device};
use ember::image::Image;
use ember::integrator::IntegratorKind;
use ember::render::{render, RenderSettings};
use ember::scene::{load_obj, Camera, CameraSettings, Scene};
use glam::{Vec2, Vec3};

fn cornell() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj");
    load_obj(&path).expect("bundled Cornell box loads").0
}

/// The camera of `tests/data/references/cornell-box` (its README).
fn reference_camera() -> CameraSettings {
    CameraSettings {
        eye: Vec3::new(0.0, 1.0, 3.9),
        look_at: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(40.0),
        lens: Default::default(),
    }
}

fn render_on(threads: usize, scene: &Scene, settings: RenderSettings) -> Image {
    let device = Device::new("").unwrap();
    let accel = EmbreeAccel::build(
        &device,
        &scene.mesh.positions,
        &scene.mesh.triangles,
        BuildQuality::High,
    )
    .unwrap();
    let camera: Camera = reference_camera().camera(settings.width, settings.height);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| render(scene, &accel, &camera, &settings, &|_| {}))
        .0
}

fn settings(size: u32, spp: u32, max_depth: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth,
        seed: 3,
        integrator: IntegratorKind::Bsdf,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    }
}

#[test]
fn same_seed_same_image_with_one_or_two_threads() {
    let scene = cornell();
    let s = RenderSettings {
        width: 70,
        height: 45,
        ..settings(0, 4, 8)
    };
    let one = render_on(1, &scene, s);
    let two = render_on(2, &scene, s);
    let bits = |f: &Image| {
        f.pixels
            .iter()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&one), bits(&two));
    // And another seed gives another image.
    let other = render_on(2, &scene, RenderSettings { seed: 4, ..s });
    assert_ne!(bits(&one), bits(&other));
}

/// Area of a polygon in the plane (shoelace formula).
fn polygon_area(points: &[Vec2]) -> f32 {
    let n = points.len();
    0.5 * (0..n)
        .map(|i| points[i].perp_dot(points[(i + 1) % n]))
        .sum::<f32>()
        .abs()
}

#[test]
fn emitters_seen_directly_cover_their_projected_area() {
    // With one path segment the image shows only emission: its mean is Ke times the
    // fraction of the image the light's projection covers, computed here by projecting
    // the light's triangles through the pinhole.
    let scene = cornell();
    let size = 128;
    let film = render_on(2, &scene, settings(size, 32, 1));
    let cam = reference_camera();
    let forward = (cam.look_at - cam.eye).normalize();
    let right = forward.cross(cam.up).normalize();
    let up = right.cross(forward);
    let vfov = cam.projection.vfov_degrees().expect("a perspective camera");
    let tan_half = (vfov.to_radians() / 2.0).tan();
    let project = |p: Vec3| {
        let d = p - cam.eye;
        let z = d.dot(forward);
        let (sx, sy) = (d.dot(right) / (z * tan_half), d.dot(up) / (z * tan_half));
        Vec2::new(
            (sx + 1.0) / 2.0 * size as f32,
            (1.0 - sy) / 2.0 * size as f32,
        )
    };
    let covered: f32 = scene
        .emitters
        .iter()
        .map(|&t| polygon_area(&scene.mesh.vertices(t).map(project)))
        .sum();
    let fraction = covered / (size * size) as f32;
    assert!(
        fraction > 0.005 && fraction < 0.1,
        "light covers {fraction}"
    );
    let expected = Vec3::new(17.0, 12.0, 4.0) * fraction;
    let mean = film.mean();
    let rel = ((mean - expected) / expected).abs().max_element();
    assert!(
        rel < 0.02,
        "mean {mean} vs projected-area estimate {expected}"
    );
}

#[test]
fn cornell_box_energy_is_in_the_expected_range() {
    let scene = cornell();
    let size = 128;
    let direct = render_on(2, &scene, settings(size, 256, 2));
    let full = render_on(2, &scene, settings(size, 256, 8));
    for film in [&direct, &full] {
        assert!(film
            .pixels
            .iter()
            .all(|p| p.is_finite() && p.min_element() >= 0.0));
    }
    let (d, f) = (direct.mean(), full.mean());
    // More segments can only add light, and with albedos below 1 the added light is
    // a fraction of what is already there: less than 1/(1 − 0.78) − 1 times the
    // direct image (0.78 being the largest albedo in the scene, per channel bound).
    assert!(f.cmpgt(d).all(), "full {f} not above direct {d}");
    assert!(
        f.cmplt(d / (1.0 - 0.78)).all(),
        "full {f} too bright for direct {d}"
    );
    // The independent renderer's means (tests/data/references/cornell-box/README.md),
    // within 4%: about 4 standard errors of this estimate.
    let reference_direct = Vec3::new(0.13861, 0.09437, 0.02939);
    let reference_full = Vec3::new(0.18547, 0.12040, 0.03437);
    for (got, want) in [(d, reference_direct), (f, reference_full)] {
        let rel = ((got - want) / want).abs().max_element();
        assert!(rel < 0.04, "mean {got} vs reference {want}");
    }
}
