//! Render passes against what they must be: the albedo pass of a Cornell box is each
//! wall's `Kd` as the MTL file states it and the normal pass its face normal (turned to
//! the camera), seen directly and through a perfect mirror; the depth pass is the
//! distance to the hit; the variance pass agrees with the variance of the pixel values
//! measured across independent seeds.

mod common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicUsize;

use common::{with_embree, Built};
use ember::accel::{Accel, Ray};
use ember::film::aov::Aov;
use ember::film::Film;
use ember::integrator::IntegratorKind;
use ember::render::{render_progressive, RenderControl, RenderSettings};
use ember::scene::{load_obj, Camera, CameraSettings};
use glam::Vec3;

fn mesh(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("meshes")
        .join(name)
}

/// `Kd` of every material of an MTL file, read from its text.
fn kd_of(mtl: &str) -> HashMap<String, Vec3> {
    let mut kd = HashMap::new();
    let mut name = String::new();
    for line in mtl.lines().map(str::trim) {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("newmtl") => name = words.next().unwrap().to_owned(),
            Some("Kd") => {
                let v: Vec<f32> = words.take(3).map(|w| w.parse().unwrap()).collect();
                kd.insert(name.clone(), Vec3::new(v[0], v[1], v[2]));
            }
            _ => {}
        }
    }
    kd
}

const SIZE: u32 = 48;

fn camera() -> Camera {
    CameraSettings {
        eye: Vec3::new(0.0, 1.0, 3.9),
        look_at: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(40.0),
        lens: Default::default(),
    }
    .camera(SIZE, SIZE)
}

/// A film of samples `samples` of the Cornell box at `max_depth`.
fn film_of(built: &Built, samples: std::ops::Range<u32>, seed: u64, max_depth: u32) -> Film {
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: samples.end,
        max_depth,
        seed,
        integrator: IntegratorKind::Mis,
        light_sampler: Default::default(),
        adaptive: None,
        guiding: None,
        engine: Default::default(),
    };
    let stop = AtomicUsize::new(0);
    let control = RenderControl {
        stop: &stop,
        on_samples: &|_| {},
        first_pass_spp: u32::MAX,
        checkpoint: None,
        deadline: None,
        on_pass: &|_| {},
        on_guide: None,
    };
    let film = Film::new(SIZE, SIZE, samples);
    let camera = camera();
    render_progressive(
        &built.scene,
        &built.accel,
        &camera,
        &settings,
        film,
        &control,
    )
    .0
}

/// What a ray sees first: (material name, unit face normal, distance), following
/// perfect mirrors (materials named in `mirrors`) as a mirror does.
fn seen(built: &Built, mut ray: Ray, mirrors: &[&str]) -> Option<(String, Vec3, f32)> {
    let mut first_t = None;
    for _ in 0..4 {
        let hit = built.accel.intersect(&ray)?;
        first_t.get_or_insert(hit.t);
        let [a, b, c] = built.scene.mesh.vertices(hit.prim);
        let n = (b - a).cross(c - a).normalize();
        let material = built.scene.mesh.material[hit.prim as usize] as usize;
        let name = built.scene.materials[material].name.clone();
        if !mirrors.contains(&name.as_str()) {
            let towards_camera = if n.dot(ray.dir) > 0.0 { -n } else { n };
            return Some((name, towards_camera, first_t.unwrap()));
        }
        let p = ray.origin + hit.t * ray.dir;
        let dir = ray.dir - 2.0 * ray.dir.dot(n) * n;
        ray = Ray::new(p + 1e-4 * dir, dir);
    }
    None
}

/// Pixels whose whole footprint sees one surface (a 3×3 grid over the pixel, its edges
/// included, agrees on the material and the plane), with what they see from the centre.
fn uniform_pixels(built: &Built, mirrors: &[&str]) -> Vec<(usize, String, Vec3, f32)> {
    let camera = camera();
    let mut out = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            let at =
                |dx: f32, dy: f32| seen(built, camera.ray(x as f32 + dx, y as f32 + dy), mirrors);
            let grid = [0.0, 0.5, 1.0];
            let corners: Vec<(f32, f32)> =
                grid.iter().flat_map(|&a| grid.map(|b| (a, b))).collect();
            let Some(centre) = at(0.5, 0.5) else { continue };
            let same = corners.iter().all(|&(dx, dy)| {
                at(dx, dy).is_some_and(|(m, n, _)| m == centre.0 && n.dot(centre.1) > 0.99999)
            });
            if same {
                out.push(((y * SIZE + x) as usize, centre.0, centre.1, centre.2));
            }
        }
    }
    out
}

fn check_albedo_and_normal(
    built: &Built,
    kd: &HashMap<String, Vec3>,
    mirrors: &[&str],
    film: &Film,
) {
    let albedo = film.aov(Aov::Albedo);
    let normal = film.aov(Aov::Normal);
    let pixels = uniform_pixels(built, mirrors);
    assert!(
        pixels.len() > (SIZE * SIZE / 2) as usize,
        "{} pixels",
        pixels.len()
    );
    let mut seen_materials = std::collections::HashSet::new();
    for (i, material, n, _) in &pixels {
        let a = Vec3::from_slice(&albedo[3 * i..3 * i + 3]);
        let m = Vec3::from_slice(&normal[3 * i..3 * i + 3]);
        let expected = kd[material];
        assert!(
            (a - expected).abs().max_element() < 1e-6,
            "pixel {i} ({material}): albedo {a} against Kd {expected}"
        );
        assert!(
            (m - *n).length() < 1e-5,
            "pixel {i} ({material}): normal {m} against {n}"
        );
        seen_materials.insert(material.clone());
    }
    assert!(seen_materials.len() >= 5, "{seen_materials:?}");
}

#[test]
fn albedo_and_normal_passes_are_each_walls_kd_and_face_normal() {
    let path = mesh("CornellBox-Original.obj");
    let kd = kd_of(&std::fs::read_to_string(path.with_extension("mtl")).unwrap());
    let built = with_embree(load_obj(&path).unwrap().0);
    let film = film_of(&built, 0..8, 1, 4);
    check_albedo_and_normal(&built, &kd, &[], &film);

    // The depth pass is the distance along the camera ray, within the pixel's spread.
    let depth = film.aov(Aov::Depth);
    for (i, _, _, t) in uniform_pixels(&built, &[]) {
        assert!(
            (depth[i] - t).abs() < 0.02 * t,
            "pixel {i}: depth {} against {t}",
            depth[i]
        );
    }
}

#[test]
fn through_a_perfect_mirror_the_passes_are_those_of_the_surface_seen_in_it() {
    // McGuire's mirror box, with its tall box made a perfect mirror: Ns 10⁷ gives
    // α = 4.5e-4, below ember's delta threshold (its own Ns 1000 is a glossy metal).
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("CornellBox-Mirror.obj");
    std::fs::copy(mesh("CornellBox-Mirror.obj"), &obj).unwrap();
    let mtl = std::fs::read_to_string(mesh("CornellBox-Mirror.mtl")).unwrap();
    let mtl = mtl
        .replace("Kd 0.01 0.01 0.01", "Kd 0 0 0")
        .replace("Ns 1000", "Ns 10000000");
    std::fs::write(obj.with_extension("mtl"), &mtl).unwrap();
    let kd = kd_of(&mtl);
    let built = with_embree(load_obj(&obj).unwrap().0);
    let film = film_of(&built, 0..4, 2, 5);
    let through_mirror = uniform_pixels(&built, &["tallBox"])
        .into_iter()
        .zip(uniform_pixels(&built, &[]))
        .filter(|((_, seen, _, _), (_, direct, _, _))| direct == "tallBox" && seen != "tallBox")
        .count();
    assert!(
        through_mirror > 20,
        "{through_mirror} pixels see a wall in the mirror"
    );
    check_albedo_and_normal(&built, &kd, &["tallBox"], &film);
}

#[test]
fn variance_pass_agrees_with_the_variance_across_seeds() {
    let built = with_embree(load_obj(&mesh("CornellBox-Original.obj")).unwrap().0);
    // Samples past the 2^16 a pixel stratifies (see `sampling::rng`), which are
    // independent: the pass estimates the variance of a mean of independent samples.
    // Within the stratified ones it is larger than the true variance (on this box about
    // 6×), so adaptive sampling errs on the side of more samples there.
    let (seeds, first) = (48, 1 << 16);
    let films: Vec<Film> = (0..seeds)
        .map(|s| film_of(&built, first..first + 8, 100 + s, 3))
        .collect();
    let variances: Vec<Vec<f32>> = films.iter().map(|f| f.aov(Aov::Variance)).collect();
    let pixels = (SIZE * SIZE) as usize;
    let (mut measured, mut predicted) = (0.0f64, 0.0f64);
    for i in 0..pixels {
        for c in 0..3 {
            let values: Vec<f64> = films.iter().map(|f| f.pixels[i].mean()[c]).collect();
            let mean = values.iter().sum::<f64>() / seeds as f64;
            let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (seeds - 1) as f64;
            measured += var;
            predicted += variances
                .iter()
                .map(|v| f64::from(v[3 * i + c]))
                .sum::<f64>()
                / seeds as f64;
        }
    }
    // Over 48 seeds the measured variance has a relative spread of about √(2/47) ≈ 0.2 per
    // pixel; summed over 6912 pixel channels (correlated and heavy-tailed) it is within a
    // few percent, the predicted one tighter still.
    let ratio = predicted / measured;
    assert!(
        (0.9..1.1).contains(&ratio),
        "variance pass / measured variance = {ratio:.3}"
    );
}
