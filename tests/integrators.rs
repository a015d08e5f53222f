//! The four integrators against mathematics and against an independent renderer:
//! a furnace with a known answer, convergence towards Mitsuba's Cornell box reference
//! at least at the rate 1/spp (an unbiased estimator's), and the gain of light sampling on a
//! scene with a small light.

mod common;

use std::path::{Path, PathBuf};

use common::stats::{furnace_radiance, SampleSums};
use common::{build, diffuse, inward_cube, with_embree, Built};
use ember::accel::{Accel, Ray};
use ember::guiding::{Guiding, SdTree};
use ember::image::{compare_pixels, Image, ImageError};
use ember::integrator::{IntegratorKind, PathTracer, RayCount};
use ember::light::LightSamplerKind;
use ember::render::{pixel_sample, train_guide, RenderSettings};
use ember::sampling::{uniform_sphere, Rng};
use ember::scene::{
    load_obj, Camera, CameraSettings, Environment, Material, Model, MtlValues, Scene,
};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::sync::atomic::AtomicUsize;
use std::sync::Arc;

const ALL: [IntegratorKind; 4] = [
    IntegratorKind::Bsdf,
    IntegratorKind::Light,
    IntegratorKind::Mixture,
    IntegratorKind::Mis,
];

/// The sums of the radiance along `n` random rays from `origin`.
fn radiance_sums<A: Accel>(tracer: &PathTracer<'_, A>, origin: Vec3, n: u64) -> SampleSums {
    let mut sums = SampleSums::default();
    let mut count = RayCount::default();
    for i in 0..n {
        let mut rng = Rng::for_sample(99, 0, i);
        let dir = uniform_sphere(rng.f32(), rng.f32());
        sums.add(tracer.radiance(Ray::new(origin, dir), &mut rng, &mut count));
    }
    sums
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
                let tracer = PathTracer::new(&built.scene, &built.accel, max_depth, kind);
                let sums = radiance_sums(&tracer, Vec3::new(0.1, -0.3, 0.2), 20_000);
                let label = format!("{kind:?}, {cells}² cells, depth {max_depth}");
                sums.assert_mean(&label, furnace_radiance(le, albedo, max_depth));
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
        let tracer = PathTracer::new(&built.scene, &built.accel, max_depth, kind);
        let sums = radiance_sums(&tracer, Vec3::new(-0.2, 0.1, 0.3), 20_000);
        sums.assert_mean(
            &format!("{kind:?}"),
            furnace_radiance(le, albedo, max_depth),
        );
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
        let (mean, _) = radiance_sums(&tracer, Vec3::ZERO, 1000).mean_and_error();
        assert_eq!(mean, DVec3::ZERO, "{kind:?}");
    }
}

/// A file shipped with the repository (meshes and `tests/data`).
fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// A 40° pinhole camera at `eye` looking at `look_at`, y up.
fn camera(eye: Vec3, look_at: Vec3, size: u32) -> Camera {
    CameraSettings {
        eye,
        look_at,
        up: Vec3::Y,
        projection: ember::scene::Projection::perspective(40.0),
        lens: Default::default(),
    }
    .camera(size, size)
}

/// The reference camera of `tests/data/references/cornell-box/README.md` (also
/// GlossyMix's).
fn reference_camera(size: u32) -> Camera {
    camera(Vec3::new(0.0, 1.0, 3.9), Vec3::new(0.0, 1.0, 0.0), size)
}

/// The camera of the Sphere reference (`tests/data/references/cornell-glossy`).
fn sphere_camera(size: u32) -> Camera {
    camera(Vec3::new(0.0, 0.8, 3.2), Vec3::new(0.0, 0.8, 0.0), size)
}

fn load(path: &Path) -> Built {
    with_embree(load_obj(path).expect("scene loads").0)
}

/// Renders every `stride`-th pixel of a `size²` image (each pixel exactly as a full
/// render would: box filter, `spp` samples) and returns (index, colour) pairs.
#[allow(clippy::too_many_arguments)]
fn render_pixels(
    loaded: &Built,
    camera: &Camera,
    kind: IntegratorKind,
    max_depth: u32,
    size: u32,
    stride: u32,
    spp: u32,
    seed: u64,
) -> Vec<(usize, Vec3)> {
    let tracer = PathTracer::new(&loaded.scene, &loaded.accel, max_depth, kind);
    render_pixels_with(&tracer, camera, size, stride, spp, seed)
}

/// [`render_pixels`] with a tracer of the caller's (a guided one).
fn render_pixels_with<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    size: u32,
    stride: u32,
    spp: u32,
    seed: u64,
) -> Vec<(usize, Vec3)> {
    (0..size)
        .step_by(stride as usize)
        .collect::<Vec<_>>()
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..size).step_by(stride as usize).map(move |x| {
                let pixel = u64::from(y * size + x);
                let mut count = RayCount::default();
                let mut sum = DVec3::ZERO;
                for s in 0..spp {
                    let l =
                        pixel_sample(tracer, camera, seed, (x, y), pixel, s, &mut count).radiance;
                    if l.is_finite() {
                        sum += l.as_dvec3();
                    }
                }
                (pixel as usize, (sum / f64::from(spp)).as_vec3())
            })
        })
        .collect()
}

fn error_against(pixels: &[(usize, Vec3)], reference: &Image) -> ImageError {
    compare_pixels(pixels.iter().map(|&(i, c)| (c, reference.pixels[i])))
}

/// One scene and its independent reference.
struct ReferenceScene {
    obj: &'static str,
    reference: &'static str,
    camera: fn(u32) -> Camera,
    max_depth: u32,
}

const ORIGINAL: ReferenceScene = ReferenceScene {
    obj: "meshes/CornellBox-Original.obj",
    reference: "tests/data/references/cornell-box/cornell_ref_8192spp.exr",
    camera: reference_camera,
    max_depth: 8,
};

const ORIGINAL_DIRECT: ReferenceScene = ReferenceScene {
    reference: "tests/data/references/cornell-box/cornell_direct_ref_8192spp.exr",
    max_depth: 2,
    ..ORIGINAL
};

const GLOSSY_MIX: ReferenceScene = ReferenceScene {
    obj: "meshes/CornellBox-GlossyMix.obj",
    reference: "tests/data/references/cornell-glossy/CornellBox-GlossyMix_ref_4096spp.exr",
    camera: reference_camera,
    max_depth: 8,
};

const SPHERE: ReferenceScene = ReferenceScene {
    obj: "meshes/CornellBox-Sphere.obj",
    reference: "tests/data/references/cornell-glossy/CornellBox-Sphere_ref_2048spp.exr",
    camera: sphere_camera,
    max_depth: 8,
};

/// relMSE of every integrator against the independent reference at `low` and `high`
/// spp (every 4th pixel in x and y, sampled as `ember render` samples them); `guided`:
/// each with a guide of its own, trained at 128² over 5 iterations (31 spp).
fn errors_against(
    scene: &ReferenceScene,
    low: u32,
    high: u32,
    guided: bool,
) -> Vec<(IntegratorKind, f64, f64)> {
    let reference = Image::load(&repo(scene.reference)).expect("reference ships in tests/data");
    assert_eq!((reference.width, reference.height), (512, 512));
    let loaded = load(&repo(scene.obj));
    let camera = (scene.camera)(512);
    ALL.iter()
        .map(|&kind| {
            let tracer = PathTracer::new(&loaded.scene, &loaded.accel, scene.max_depth, kind);
            let tree = guided.then(|| trained_guide(&tracer, scene, kind));
            let tracer = tracer.with_guide(tree.as_ref());
            let error = |spp, seed| {
                let pixels = render_pixels_with(&tracer, &camera, 512, 4, spp, seed);
                error_against(&pixels, &reference).rel_mse
            };
            let (l, h) = (error(low, 1), error(high, 2));
            eprintln!(
                "{}{} {kind:?}: relMSE {l:.3e} at {low} spp, {h:.3e} at {high} spp (ratio {:.2})",
                scene.obj,
                if guided { " guided" } else { "" },
                l / h
            );
            (kind, l, h)
        })
        .collect()
}

/// A guide for `tracer` (of integrator `kind`) on `scene`, trained at 128² over 5
/// iterations (31 spp); some of its regions guide.
fn trained_guide<A: Accel>(
    tracer: &PathTracer<'_, A>,
    scene: &ReferenceScene,
    kind: IntegratorKind,
) -> SdTree {
    let guiding = Guiding { iterations: 5 };
    let training = RenderSettings {
        width: 128,
        height: 128,
        spp: 1,
        max_depth: scene.max_depth,
        seed: 9,
        integrator: kind,
        adaptive: None,
        light_sampler: Default::default(),
        guiding: Some(guiding),
        engine: Default::default(),
    };
    let camera = (scene.camera)(128);
    let stop = AtomicUsize::new(0);
    let (tree, stats) =
        train_guide(tracer, &camera, &training, guiding, &stop).expect("not stopped");
    eprintln!(
        "{} {kind:?}: {} of {} regions guided",
        scene.obj, stats.guided_leaves, stats.leaves
    );
    assert!(
        stats.guided_leaves > 0,
        "{kind:?} on {}: {stats:?}",
        scene.obj
    );
    tree
}

/// relMSE against the independent reference must fall at least like 1/spp for every
/// integrator (`low` → `high` spp): its variance does, and a bias would not. Returns
/// each integrator's relMSE at `high` spp.
fn converges_to(scene: &ReferenceScene, low: u32, high: u32) -> Vec<(IntegratorKind, f64)> {
    converges_with(errors_against(scene, low, high, false), scene, low, high)
}

/// [`converges_to`]'s test on the `errors` of every integrator at `low` and `high` spp.
fn converges_with(
    errors: Vec<(IntegratorKind, f64, f64)>,
    scene: &ReferenceScene,
    low: u32,
    high: u32,
) -> Vec<(IntegratorKind, f64)> {
    errors
        .into_iter()
        .map(|(kind, at_low, at_high)| {
            let ratio = at_low / at_high;
            // Independent samples give `high / low` (heavy-tailed noise, BSDF sampling
            // of a small light, scatters it down to 2.5 for 4×). The pixel's first
            // dimensions are stratified (Owen-scrambled Sobol), which falls faster:
            // about 4^1.5 = 8 where the integrand has edges (shadows), at most 4^3 = 64
            // for smooth ones. Slower than 1/spp would be a bias that stops the error
            // falling.
            assert!(
                (2.5..64.0).contains(&ratio),
                "{kind:?} on {}: relMSE ratio {low}→{high} spp is {ratio:.2}",
                scene.obj
            );
            (kind, at_high)
        })
        .collect()
}

/// `mis`'s relMSE from [`converges_to`]'s results is within 1.5× of what the
/// independent renderer gets at `spp` (its noise constant over spp, plus the
/// reference's own noise, both from the reference's README).
fn mis_within_the_peer(
    errors: &[(IntegratorKind, f64)],
    spp: u32,
    peer_constant: f64,
    reference_noise: f64,
) -> f64 {
    let mis = error_of(errors, IntegratorKind::Mis);
    let peer = peer_constant / f64::from(spp) + reference_noise;
    assert!(
        mis < 1.5 * peer,
        "mis relMSE {mis:.3e} at {spp} spp, peer {peer:.3e}"
    );
    mis
}

fn error_of(errors: &[(IntegratorKind, f64)], kind: IntegratorKind) -> f64 {
    errors
        .iter()
        .find(|e| e.0 == kind)
        .expect("every integrator ran")
        .1
}

#[test]
fn all_integrators_converge_to_the_global_illumination_reference() {
    converges_to(&ORIGINAL, 8, 32);
}

#[test]
fn all_integrators_converge_to_the_direct_lighting_reference() {
    converges_to(&ORIGINAL_DIRECT, 8, 32);
}

/// `meshes/CornellBox-Original.obj` with its light cut into `cuts × cuts` quads of
/// the same plane, winding and material (the same emitting area, so the same image),
/// written beside a copy of its MTL in a directory of its own; returns the OBJ's path.
fn original_with_subdivided_light(cuts: usize) -> PathBuf {
    let source = std::fs::read_to_string(repo("meshes/CornellBox-Original.obj")).unwrap();
    let (shell, light) = source
        .split_once("## Object light")
        .expect("the light comes last");
    let corners: Vec<Vec3> = light
        .lines()
        .filter_map(|l| l.strip_prefix("v"))
        .map(|l| {
            let v: Vec<f32> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            Vec3::new(v[0], v[1], v[2])
        })
        .collect();
    let [v1, v2, _, v4] = corners[..] else {
        panic!("the light is one quad: {corners:?}");
    };
    let point = |a: usize, b: usize| {
        let (a, b) = (a as f32 / cuts as f32, b as f32 / cuts as f32);
        v1 + a * (v2 - v1) + b * (v4 - v1)
    };
    let mut obj = format!("{shell}g light\nusemtl light\n");
    for i in 0..cuts {
        for j in 0..cuts {
            // Corners in the order of the original quad's (v1, v2, v3, v4).
            for (a, b) in [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)] {
                let p = point(a, b);
                obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
            }
            obj += "f -4 -3 -2 -1\n";
        }
    }
    let dir = std::env::temp_dir().join(format!("ember-subdivided-light-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(
        repo("meshes/CornellBox-Original.mtl"),
        dir.join("CornellBox-Original.mtl"),
    )
    .unwrap();
    let path = dir.join("CornellBox-Original.obj");
    std::fs::write(&path, obj).unwrap();
    path
}

/// The Cornell box with its light cut into 16 × 16 quads: 512 emitters, so that the
/// default light sampler is the light BVH (five levels of four-wide nodes), with its
/// solid-angle rule. Every integrator, each of which weighs samples by the BVH's
/// probabilities (the MIS weights and the mixture at emitters hit by BSDF rays, next-
/// event estimation where they are drawn), still converges to the independent
/// reference of the undivided box at the rate 1/spp: the tree's choices and the
/// densities it reports agree.
#[test]
fn all_integrators_converge_with_the_light_bvh_to_the_reference() {
    let path = original_with_subdivided_light(16);
    let loaded = load(&path);
    let tracer = PathTracer::new(&loaded.scene, &loaded.accel, 8, IntegratorKind::Mis);
    assert_eq!(tracer.lights.len(), 512);
    assert_eq!(tracer.lights.kind(), Some(LightSamplerKind::Bvh));
    assert!(tracer.lights.build_cost().1 > 1, "a tree of one node");
    let leaked: &'static str = Box::leak(path.to_string_lossy().into_owned().into_boxed_str());
    let scene = ReferenceScene {
        obj: leaked,
        ..ORIGINAL
    };
    let errors = converges_to(&scene, 8, 32);
    std::fs::remove_dir_all(path.parent().unwrap()).unwrap();
    // As good as the alias table on the undivided light, within the noise of two runs.
    let mis = error_of(&errors, IntegratorKind::Mis);
    let undivided = error_of(&converges_to(&ORIGINAL, 8, 32), IntegratorKind::Mis);
    assert!(
        mis < 1.25 * undivided,
        "mis {mis:.3e}, undivided {undivided:.3e}"
    );
}

/// Glossy floor, rough metal box and rough coated box: every integrator converges to
/// the independent renderer's image at the rate 1/spp, and `mis` is within the noise
/// the independent renderer itself has (relMSE ≈ 1.37/spp with independent samples,
/// plus the reference's own 3.3e-4). The book's mixture, one sample per vertex and no
/// shadow rays, stays within 4.5× of `mis` (4.1× here: Russian roulette from vertex 6
/// lowered `mis`'s error by a quarter and left the mixture's, which its void light
/// draws dominate, where it was).
#[test]
fn all_integrators_converge_to_the_glossy_reference() {
    let errors = converges_to(&GLOSSY_MIX, 16, 64);
    let mis = mis_within_the_peer(&errors, 64, 1.37, 3.3e-4);
    let mixture = error_of(&errors, IntegratorKind::Mixture);
    assert!(
        mixture < 4.5 * mis,
        "mixture {mixture:.3e} against mis {mis:.3e}"
    );
}

/// A GGX mirror sphere and a glass sphere (delta refraction with 1/η² scaling), with
/// interpolated normals: every integrator converges to the independent reference
/// (whose renderer has relMSE ≈ 2.75/spp there, its reference 1.3e-3).
#[test]
fn all_integrators_converge_to_the_sphere_reference() {
    let errors = converges_to(&SPHERE, 16, 64);
    mis_within_the_peer(&errors, 64, 2.75, 1.3e-3);
}

/// With path guiding, every integrator's relMSE against the independent reference
/// falls at least like 1/spp (as [`converges_to`] asks of them unguided): the
/// mixtures with the guide, and in `mis` the MIS weights with their density, add no
/// bias. Guided `mis` at 64 spp is within the noise the independent renderer has, as
/// unguided `mis` is.
#[test]
fn guided_integrators_converge_to_the_glossy_reference() {
    let errors = converges_with(
        errors_against(&GLOSSY_MIX, 16, 64, true),
        &GLOSSY_MIX,
        16,
        64,
    );
    mis_within_the_peer(&errors, 64, 1.37, 3.3e-4);
}

#[test]
fn guided_integrators_converge_to_the_global_illumination_reference() {
    converges_with(errors_against(&ORIGINAL, 8, 32, true), &ORIGINAL, 8, 32);
}

#[test]
fn guided_integrators_converge_to_the_sphere_reference() {
    let errors = converges_with(errors_against(&SPHERE, 16, 64, true), &SPHERE, 16, 64);
    mis_within_the_peer(&errors, 64, 2.75, 1.3e-3);
}

/// On a Cornell box whose light is 1% of the ceiling, sampling the light must beat
/// sampling the material by a wide margin at equal spp (measured against a 2048-spp
/// `mis` render of ember's own, 32×32 pixels).
#[test]
fn light_sampling_wins_on_a_small_light() {
    let obj = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/small-light.obj");
    let loaded = load(&obj);
    let size = 32;
    let camera = reference_camera(size);
    let reference_pixels =
        render_pixels(&loaded, &camera, IntegratorKind::Mis, 8, size, 1, 2048, 7);
    let mut reference = Image::new(size, size);
    for (i, c) in reference_pixels {
        reference.pixels[i] = c;
    }
    let error = |kind| {
        error_against(
            &render_pixels(&loaded, &camera, kind, 8, size, 1, 32, 3),
            &reference,
        )
        .rel_mse
    };
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
    built.scene.sky = Some(Arc::new(Environment::constant(sky)));
    for kind in ALL {
        let tracer = PathTracer::new(&built.scene, &built.accel, 8, kind);
        let mut count = RayCount::default();
        let mut sums = SampleSums::default();
        let n = 20_000;
        for i in 0..n {
            let mut rng = Rng::for_sample(5, 1, i);
            // Looking down at the triangle's centre region, from above and below
            // (diffuse surfaces are two-sided).
            let from = if i % 2 == 0 { 1.0 } else { -1.0 };
            let origin = Vec3::new(0.0, from, 0.0);
            let target = Vec3::new(0.2 * rng.f32() - 0.1, 0.0, 0.2 * rng.f32() - 0.1);
            let ray = Ray::new(origin, (target - origin).normalize());
            sums.add(tracer.radiance(ray, &mut rng, &mut count));
        }
        let (mean, err) = sums.mean_and_error();
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

/// A convex object of any MTL material under a white sky never comes out brighter
/// than the sky: a cube of each material (outward faces), seen along a few fixed
/// rays, each estimated by every integrator. Lambert with `Kd = 1` and a perfect
/// mirror with `Ks = 1` return exactly the sky.
#[test]
fn convex_objects_under_a_white_sky_are_never_brighter_than_it() {
    let white = Some(Vec3::ONE);
    let mtl = |kd, ks, ns, illum| MtlValues {
        kd,
        ks,
        ns,
        illum,
        ..MtlValues::default()
    };
    let cases = [
        ("lambert Kd 1", mtl(white, None, None, None), true),
        ("mirror Ks 1", mtl(None, white, Some(1e9), Some(3)), true),
        ("conductor Ks 1", mtl(None, white, Some(20.0), None), false),
        (
            "coated Kd 1 Ks 1",
            mtl(white, white, Some(50.0), None),
            false,
        ),
        (
            "coated Kd 1 Ks 0.5",
            mtl(white, Some(Vec3::splat(0.5)), Some(5.0), None),
            false,
        ),
        (
            "coated rough",
            mtl(white, Some(Vec3::splat(0.2)), Some(0.0), None),
            false,
        ),
        ("glass", mtl(None, None, None, Some(7)), false),
    ];
    // Rays from outside aimed at the cube: head-on, oblique, grazing an edge.
    let rays = [
        (Vec3::new(0.1, 0.2, 4.0), Vec3::new(0.1, 0.2, 0.0)),
        (Vec3::new(3.0, 2.0, 3.0), Vec3::new(0.2, -0.1, 0.3)),
        (Vec3::new(-4.0, 0.3, 0.5), Vec3::new(0.0, 0.95, 0.9)),
    ];
    for (name, values, exact) in cases {
        let material = Material::from_mtl(name, &values, None);
        let cube: Vec<_> = inward_cube(2, 0)
            .into_iter()
            .map(|([a, b, c], m)| ([a, c, b], m))
            .collect();
        let mut built = build(&cube, vec![material]);
        built.scene.sky = Some(Arc::new(Environment::constant(Vec3::ONE)));
        for kind in ALL {
            let tracer = PathTracer::new(&built.scene, &built.accel, 64, kind);
            for (i, &(from, to)) in rays.iter().enumerate() {
                let ray = Ray::new(from, (to - from).normalize());
                let mut count = RayCount::default();
                let n = 20_000u64;
                let mut sums = SampleSums::default();
                for s in 0..n {
                    let mut rng = Rng::for_sample(11, i as u64, s);
                    sums.add(tracer.radiance(ray, &mut rng, &mut count));
                }
                let (mean, sigma) = sums.mean_and_error();
                let bound = 4.0 * sigma.max_element() + 1e-5;
                assert!(
                    mean.max_element() <= 1.0 + bound,
                    "{name}, {kind:?}, ray {i}: {mean} ± {sigma} is brighter than the sky"
                );
                if exact {
                    assert!(
                        (mean - DVec3::ONE).abs().max_element() <= bound,
                        "{name}, {kind:?}, ray {i}: {mean} ± {sigma}, expected exactly 1"
                    );
                }
            }
        }
    }
}

/// The Sphere scene (glass, a GGX sphere, interpolated normals) scaled by 1e-3 and by
/// 1e3, and moved 1e4 away from the origin, gives the same image as the original
/// within noise: ray offsets follow each hit's rounding error, not a fixed epsilon.
#[test]
fn scaled_and_translated_scenes_render_the_same() {
    let size = 64;
    let original = load_obj(&repo(SPHERE.obj)).expect("scene loads").0;
    let render = |scene: Scene, eye: Vec3, look_at: Vec3, seed: u64| {
        let built = with_embree(scene);
        let pixels = render_pixels(
            &built,
            &camera(eye, look_at, size),
            IntegratorKind::Mis,
            8,
            size,
            1,
            64,
            seed,
        );
        let mut film = Image::new(size, size);
        for (i, c) in pixels {
            film.pixels[i] = c;
        }
        film
    };
    let (eye, look_at) = (Vec3::new(0.0, 0.8, 3.2), Vec3::new(0.0, 0.8, 0.0));
    let base = render(original.clone(), eye, look_at, 1);
    // Two independent renders of the same scene differ by this much: the noise.
    let noise = compare_pixels(
        render(original.clone(), eye, look_at, 2)
            .pixels
            .iter()
            .zip(&base.pixels)
            .map(|(&a, &b)| (a, b)),
    )
    .rel_mse;
    for (scale, shift) in [(1e-3f32, 0.0f32), (1e3, 0.0), (1.0, 1e4)] {
        let mut scene = original.clone();
        let map = |p: Vec3| p * scale + Vec3::splat(shift);
        for p in &mut scene.mesh.positions {
            *p = map(*p);
        }
        let moved = render(scene, map(eye), map(look_at), 1);
        let error = compare_pixels(moved.pixels.iter().zip(&base.pixels).map(|(&a, &b)| (a, b)));
        eprintln!(
            "scale {scale}, shift {shift}: relMSE {:.3e} against the original (noise {noise:.3e})",
            error.rel_mse
        );
        assert!(
            error.rel_mse < noise,
            "scale {scale}, shift {shift}: relMSE {:.3e} against the original, noise {noise:.3e}",
            error.rel_mse
        );
    }
}
