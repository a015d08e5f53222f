//! The four integrators against mathematics and against an independent renderer:
//! a furnace with a known answer, convergence towards Mitsuba's Cornell box reference
//! at least at the rate 1/spp (an unbiased estimator's), and the gain of light sampling on a
//! scene with a small light.

mod common;

use std::path::{Path, PathBuf};

use common::{build, diffuse, inward_cube, with_embree, Built};
use ember::accel::{Accel, Ray};
use ember::film::{compare_pixels, Film, ImageError};
use ember::integrator::{IntegratorKind, PathTracer, RayCount};
use ember::render::pixel_sample;
use ember::sampling::{uniform_sphere, Rng};
use ember::scene::{load_obj, Camera, CameraSettings, Material, Model};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

const ALL: [IntegratorKind; 4] = [
    IntegratorKind::Bsdf,
    IntegratorKind::Light,
    IntegratorKind::Mixture,
    IntegratorKind::Mis,
];

/// Mean radiance and its standard error over `n` random rays from `origin`.
fn mean_radiance<A: Accel>(tracer: &PathTracer<'_, A>, origin: Vec3, n: u64) -> (DVec3, DVec3) {
    let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
    let mut count = RayCount::default();
    for i in 0..n {
        let mut rng = Rng::for_sample(99, 0, i);
        let dir = uniform_sphere(rng.f32(), rng.f32());
        let l = tracer
            .radiance(Ray::new(origin, dir), &mut rng, &mut count)
            .as_dvec3();
        sum += l;
        sum2 += l * l;
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean * mean).max(DVec3::ZERO);
    (mean, (var / n as f64).powf(0.5))
}

/// Inside a closed room where every surface has albedo `a` and emits `Le`, the
/// radiance along any ray is `Le · Σ_{k<N} a^k` for paths of at most N segments.
#[test]
fn furnace_every_integrator_finds_the_geometric_series() {
    let albedo = 0.6f32;
    let le = Vec3::new(1.0, 0.5, 0.25);
    // 2 cells per edge: 48 emissive triangles; 6 per edge: 432 ("many lights").
    for cells in [2, 6] {
        let built = build(
            &inward_cube(cells, 0),
            vec![diffuse(Vec3::splat(albedo), le)],
        );
        for kind in ALL {
            for max_depth in [1, 2, 5, 40] {
                let truth: f64 = (0..max_depth)
                    .map(|k| f64::from(albedo).powi(k as i32))
                    .sum();
                let truth = le.as_dvec3() * truth;
                let tracer = PathTracer::new(&built.scene, &built.accel, max_depth, kind);
                let (mean, sigma) = mean_radiance(&tracer, Vec3::new(0.1, -0.3, 0.2), 20_000);
                for c in 0..3 {
                    let tolerance = 4.0 * sigma[c] + 1e-4 * truth[c];
                    assert!(
                        (mean[c] - truth[c]).abs() <= tolerance,
                        "{kind:?}, {cells}² cells, depth {max_depth}: channel {c} = {} ± {}, expected {}",
                        mean[c],
                        sigma[c],
                        truth[c]
                    );
                }
            }
        }
    }
}

/// The furnace again with every other triangle a perfect mirror of reflectance `a`
/// (emitting `Le` too): specular bounces keep their delta sampling in every
/// integrator, and the emission seen after them counts in full.
#[test]
fn furnace_with_mirrors() {
    let albedo = 0.5f32;
    let le = Vec3::new(0.3, 1.0, 2.0);
    let mirror = Material {
        specular: Vec3::splat(albedo),
        emission: le,
        model: Model::Conductor { alpha: 0.0 },
        ..Material::default()
    };
    let tris: Vec<_> = inward_cube(3, 0)
        .into_iter()
        .enumerate()
        .map(|(i, (t, _))| (t, (i % 2) as u32))
        .collect();
    let built = build(&tris, vec![diffuse(Vec3::splat(albedo), le), mirror]);
    for kind in ALL {
        let max_depth = 6;
        let truth: f64 = (0..max_depth).map(|k| f64::from(albedo).powi(k)).sum();
        let truth = le.as_dvec3() * truth;
        let tracer = PathTracer::new(&built.scene, &built.accel, max_depth as u32, kind);
        let (mean, sigma) = mean_radiance(&tracer, Vec3::new(-0.2, 0.1, 0.3), 20_000);
        for c in 0..3 {
            assert!(
                (mean[c] - truth[c]).abs() <= 4.0 * sigma[c] + 1e-4 * truth[c],
                "{kind:?}: channel {c} = {} ± {}, expected {}",
                mean[c],
                sigma[c],
                truth[c]
            );
        }
    }
}

/// Without emitters every integrator returns black (and light sampling copes with
/// having nothing to sample).
#[test]
fn no_lights_no_light() {
    let built = build(
        &inward_cube(1, 0),
        vec![diffuse(Vec3::splat(0.8), Vec3::ZERO)],
    );
    for kind in ALL {
        let tracer = PathTracer::new(&built.scene, &built.accel, 8, kind);
        let (mean, _) = mean_radiance(&tracer, Vec3::ZERO, 1000);
        assert_eq!(mean, DVec3::ZERO, "{kind:?}");
    }
}

fn shared(path: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("shared")
        .join(path);
    p.exists().then_some(p)
}

/// The reference camera of `shared/references/cornell-box/README.md`.
fn reference_camera(size: u32) -> Camera {
    CameraSettings {
        eye: Vec3::new(0.0, 1.0, 3.9),
        look_at: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        vfov_degrees: 40.0,
    }
    .camera(size, size)
}

fn load(path: &Path) -> Built {
    with_embree(load_obj(path).expect("scene loads").0)
}

/// Renders every `stride`-th pixel of a `size²` image (each pixel exactly as a full
/// render would: box filter, `spp` samples) and returns (index, colour) pairs.
fn render_pixels(
    loaded: &Built,
    kind: IntegratorKind,
    max_depth: u32,
    size: u32,
    stride: u32,
    spp: u32,
    seed: u64,
) -> Vec<(usize, Vec3)> {
    let camera = reference_camera(size);
    let tracer = PathTracer::new(&loaded.scene, &loaded.accel, max_depth, kind);
    (0..size)
        .step_by(stride as usize)
        .collect::<Vec<_>>()
        .into_par_iter()
        .flat_map_iter(|y| {
            let tracer = &tracer;
            (0..size).step_by(stride as usize).map(move |x| {
                let pixel = u64::from(y * size + x);
                let mut count = RayCount::default();
                let mut sum = Vec3::ZERO;
                for s in 0..spp {
                    let l = pixel_sample(tracer, &camera, seed, (x, y), pixel, s, &mut count);
                    if l.is_finite() {
                        sum += l;
                    }
                }
                (pixel as usize, sum / spp as f32)
            })
        })
        .collect()
}

fn error_against(pixels: &[(usize, Vec3)], reference: &Film) -> ImageError {
    compare_pixels(pixels.iter().map(|&(i, c)| (c, reference.pixels[i])))
}

/// relMSE against Mitsuba's reference must fall at least like 1/spp for every
/// integrator: its variance does, and a bias would not. Every 4th pixel in x and y,
/// 8 and 32 spp, sampled as `ember render` samples them.
fn converges_to(reference_file: &str, max_depth: u32) {
    let (Some(obj), Some(reference)) = (
        shared("meshes/cornell-box/CornellBox-Original.obj"),
        shared(&format!("references/cornell-box/{reference_file}")),
    ) else {
        eprintln!("skipped: ../shared meshes or references are not there");
        return;
    };
    let reference = Film::load(&reference).expect("reference loads");
    assert_eq!((reference.width, reference.height), (512, 512));
    let loaded = load(&obj);
    for kind in ALL {
        let low = error_against(
            &render_pixels(&loaded, kind, max_depth, 512, 4, 8, 1),
            &reference,
        );
        let high = error_against(
            &render_pixels(&loaded, kind, max_depth, 512, 4, 32, 2),
            &reference,
        );
        let ratio = low.rel_mse / high.rel_mse;
        eprintln!(
            "{reference_file} {kind:?}: relMSE {:.3e} at 8 spp, {:.3e} at 32 spp (ratio {ratio:.2})",
            low.rel_mse, high.rel_mse
        );
        // Independent samples give 4 (heavy-tailed noise, BSDF sampling of a small
        // light, scatters it down to 2.5). The pixel's first dimensions are stratified
        // (Owen-scrambled Sobol), which falls faster: about 4^1.5 = 8 where the
        // integrand has edges (shadows), at most 4^3 = 64 for smooth ones. Slower than
        // 1/spp would be a bias that stops the error falling.
        assert!(
            (2.5..64.0).contains(&ratio),
            "{kind:?} at depth {max_depth}: relMSE ratio 8→32 spp is {ratio:.2}, expected 4 to 8"
        );
    }
}

#[test]
fn all_integrators_converge_to_the_global_illumination_reference() {
    converges_to("cornell_ref_8192spp.exr", 8);
}

#[test]
fn all_integrators_converge_to_the_direct_lighting_reference() {
    converges_to("cornell_direct_ref_8192spp.exr", 2);
}

/// On a Cornell box whose light is 1% of the ceiling, sampling the light must beat
/// sampling the material by a wide margin at equal spp (measured against a 2048-spp
/// `mis` render of ember's own, 32×32 pixels).
#[test]
fn light_sampling_wins_on_a_small_light() {
    let obj = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/small-light.obj");
    let loaded = load(&obj);
    let size = 32;
    let reference_pixels = render_pixels(&loaded, IntegratorKind::Mis, 8, size, 1, 2048, 7);
    let mut reference = Film::new(size, size);
    for (i, c) in reference_pixels {
        reference.pixels[i] = c;
    }
    let error =
        |kind| error_against(&render_pixels(&loaded, kind, 8, size, 1, 32, 3), &reference).rel_mse;
    let bsdf = error(IntegratorKind::Bsdf);
    let mixture = error(IntegratorKind::Mixture);
    let mis = error(IntegratorKind::Mis);
    eprintln!(
        "small light, 32 spp: relMSE bsdf {bsdf:.3e}, mixture {mixture:.3e} ({:.1}x lower), mis {mis:.3e} ({:.1}x lower)",
        bsdf / mixture,
        bsdf / mis
    );
    assert!(bsdf > 5.0 * mixture, "mixture {mixture} vs bsdf {bsdf}");
    assert!(bsdf > 5.0 * mis, "mis {mis} vs bsdf {bsdf}");
    assert!(mixture > mis, "MIS should beat the one-sample mixture here");
}

/// A diffuse triangle under a uniform sky of radiance `S` (nothing else in the scene):
/// every point of it sees the sky over its whole hemisphere, so it reflects exactly
/// `albedo · S` towards any viewer, and rays that miss it see `S`.
#[test]
fn uniform_sky_over_a_diffuse_triangle() {
    let albedo = Vec3::new(0.8, 0.5, 0.2);
    let sky = Vec3::new(1.0, 2.0, 0.5);
    let mut built = build(
        &[(
            [
                Vec3::new(-1.0, 0.0, -1.0),
                Vec3::new(1.0, 0.0, -1.0),
                Vec3::new(0.0, 0.0, 1.0),
            ],
            0,
        )],
        vec![diffuse(albedo, Vec3::ZERO)],
    );
    built.scene.background = sky;
    for kind in ALL {
        let tracer = PathTracer::new(&built.scene, &built.accel, 8, kind);
        let mut count = RayCount::default();
        let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
        let n = 20_000;
        for i in 0..n {
            let mut rng = Rng::for_sample(5, 1, i);
            // Looking down at the triangle's centre region, from above and below
            // (diffuse surfaces are two-sided).
            let from = if i % 2 == 0 { 1.0 } else { -1.0 };
            let origin = Vec3::new(0.0, from, 0.0);
            let target = Vec3::new(0.2 * rng.f32() - 0.1, 0.0, 0.2 * rng.f32() - 0.1);
            let ray = Ray::new(origin, (target - origin).normalize());
            let l = tracer.radiance(ray, &mut rng, &mut count).as_dvec3();
            sum += l;
            sum2 += l * l;
        }
        let mean = sum / n as f64;
        let err = ((sum2 / n as f64 - mean * mean).max(DVec3::ZERO) / n as f64).powf(0.5);
        let want = (albedo * sky).as_dvec3();
        assert!(
            ((mean - want).abs() - 4.0 * err - DVec3::splat(1e-6)).max_element() <= 0.0,
            "{kind:?}: {mean} vs {want} ± {err}"
        );
        // A ray that misses everything sees the sky itself.
        let up = Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::Y);
        let l = tracer.radiance(up, &mut Rng::seeded(1), &mut count);
        assert_eq!(l, sky);
    }
}
