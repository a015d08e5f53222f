//! `ember render --accel embree|bvh`: with the same seed both backends give the same
//! image, up to floating-point ties (a path that meets an edge or a tie may take another
//! triangle and diverge from there).

use std::path::Path;
use std::process::Command;

use ember::accel::{Bvh, EmbreeAccel};
use ember::embree::{BuildQuality, Device};
use ember::image::Image;
use ember::integrator::IntegratorKind;
use ember::render::{render, RenderSettings};
use ember::scene::{load_obj, CameraSettings};

fn cornell() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/CornellBox-Original.obj")
}

#[test]
fn same_seed_same_image_with_either_backend() {
    let (scene, _) = load_obj(&cornell()).unwrap();
    let (lo, hi) = scene.bounds();
    let camera = CameraSettings::framing(lo, hi, 40.0).camera(48, 48);
    let settings = RenderSettings {
        width: 48,
        height: 48,
        spp: 8,
        max_depth: 6,
        seed: 7,
        integrator: IntegratorKind::Bsdf,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    let device = Device::new("").unwrap();
    let (m, t) = (&scene.mesh.positions, &scene.mesh.triangles);
    let embree = EmbreeAccel::build(&device, m, t, BuildQuality::High).unwrap();
    let bvh = Bvh::build(m, t).unwrap();
    let (a, sa) = render(&scene, &embree, &camera, &settings, &|_| {});
    let (b, sb) = render(&scene, &bvh, &camera, &settings, &|_| {});
    // Nearly every pixel is bit-identical; the rest differ by a few paths at most.
    let same = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| p == q)
        .count();
    assert!(
        same * 100 >= a.pixels.len() * 95,
        "{same} of {} pixels equal",
        a.pixels.len()
    );
    let mean =
        |f: &Image| f.pixels.iter().map(|p| p.element_sum()).sum::<f32>() / f.pixels.len() as f32;
    assert!(
        (mean(&a) - mean(&b)).abs() <= 0.01 * mean(&a),
        "{} vs {}",
        mean(&a),
        mean(&b)
    );
    let rays = sa.rays.abs_diff(sb.rays);
    assert!(
        rays * 100 <= sa.rays,
        "ray counts {} vs {}",
        sa.rays,
        sb.rays
    );
}

#[test]
fn cli_renders_with_the_native_bvh() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bvh.png");
    let status = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(cornell())
        .args([
            "--accel", "bvh", "--width", "16", "--height", "16", "--spp", "2", "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    assert!(String::from_utf8_lossy(&status.stderr).contains(" bvh "));
    assert_eq!(Image::load(&out).unwrap().width, 16);
}
