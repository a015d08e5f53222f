//! The glTF metallic-roughness BSDF against mathematics: its draws follow its `pdf`
//! (chi-square), `pdf` integrates to 1 less the void draws, `sample` returns exactly
//! `eval` and `pdf`, it is reciprocal; white furnaces keep 0.9 to 1 of the light (a
//! white metal exactly 1, which Kulla–Conty's compensation promises), a smooth metal is
//! a mirror of Schlick's Fresnel from `F0` = base colour, a black dielectric reflects
//! the 4% of index 1.5; and in a scene, under a white sky, a plane of the material
//! returns its albedo, and a glTF texture feeds roughness from green and metallic from
//! blue.

mod common;

use std::sync::Arc;

use common::bsdf::{
    albedo, assert_every_lobe_draws_by_its_pdf, assert_pdf_integrates_to_the_kept_draws,
    assert_reciprocal, assert_sample_agrees_with_eval_and_pdf, direction, tilted_normal,
};
use common::stats::{bin_integrals, SampleSums};
use common::{build, quad, with_embree};
use ember::accel::{Accel, Ray};
use ember::bsdf::{fresnel_dielectric, Bsdf, MetallicRoughness};
use ember::integrator::{IntegratorKind, PathTracer, RayCount};
use ember::sampling::Rng;
use ember::scene::{Channel, Environment, Material, Scene, Texture, TriangleMesh};
use glam::{DVec3, Vec2, Vec3};

/// Polar angles of `wo`, in degrees, grazing included.
const THETAS: [f32; 4] = [5.0, 40.0, 70.0, 87.0];

/// Materials across metallic, roughness and colour, and one with
/// `KHR_materials_ior` and `KHR_materials_specular`.
fn materials() -> Vec<(&'static str, MetallicRoughness)> {
    let m = MetallicRoughness::new;
    vec![
        ("plastic α 0.25", m(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.25)),
        ("gold α 0.09", m(Vec3::new(1.0, 0.77, 0.34), 1.0, 0.09)),
        ("half metal α 0.6", m(Vec3::splat(0.9), 0.5, 0.6)),
        ("black dielectric α 0.1", m(Vec3::ZERO, 0.0, 0.1)),
        ("rough metal α 1", m(Vec3::new(0.9, 0.6, 0.3), 1.0, 1.0)),
        ("rough plastic α 1", m(Vec3::new(0.3, 0.6, 0.9), 0.0, 1.0)),
        (
            "specular extension α 0.16",
            MetallicRoughness {
                ior: 1.8,
                specular: 0.5,
                specular_colour: Vec3::new(1.0, 0.4, 0.4),
                ..m(Vec3::splat(0.5), 0.2, 0.16)
            },
        ),
    ]
}

fn lobes(n: Vec3) -> Vec<(&'static str, Bsdf)> {
    materials()
        .into_iter()
        .map(|(name, m)| (name, Bsdf::metallic_roughness(&m, n, n)))
        .collect()
}

#[test]
fn sampled_directions_follow_the_pdf() {
    let n = tilted_normal();
    let lobes: Vec<(String, Bsdf)> = lobes(n)
        .into_iter()
        .map(|(name, b)| (name.to_string(), b))
        .collect();
    assert!(lobes.iter().all(|(_, bsdf)| !bsdf.is_delta()));
    assert_every_lobe_draws_by_its_pdf(&lobes, n, &THETAS, 500);
}

#[test]
fn pdf_integrates_to_one_less_the_failed_draws() {
    let n = tilted_normal();
    for (name, bsdf) in lobes(n) {
        for theta in THETAS {
            let wo = direction(n, theta, 2.0);
            assert_pdf_integrates_to_the_kept_draws(&format!("{name}, θo {theta}°"), &bsdf, wo);
        }
    }
}

#[test]
fn sample_agrees_exactly_with_eval_and_pdf() {
    let n = tilted_normal();
    let mut rng = Rng::seeded(31);
    for (name, bsdf) in lobes(n) {
        for theta in THETAS {
            let wo = direction(n, theta, 1.0);
            assert_sample_agrees_with_eval_and_pdf(name, &bsdf, wo, &mut rng);
        }
    }
}

/// The Fresnel terms take `wo·h = wi·h` and the compensation lobe is symmetric in
/// `μo` and `μi`, so the whole BSDF is reciprocal.
#[test]
fn reflection_is_reciprocal() {
    let n = tilted_normal();
    let mut rng = Rng::seeded(32);
    for (name, bsdf) in lobes(n) {
        assert_reciprocal(name, &bsdf, n, &mut rng);
    }
}

/// White furnace: with base colour 1, the dielectric and the metal keep between 0.9
/// and 1 of the light at every roughness and angle; the white metal's Fresnel is 1,
/// so single scattering plus the compensation is exactly 1.
#[test]
fn white_furnace_keeps_between_nine_tenths_and_all() {
    let n = tilted_normal();
    for roughness in [0.1f32, 0.3, 0.5, 0.7, 1.0] {
        for metallic in [0.0f32, 1.0] {
            let m = MetallicRoughness::new(Vec3::ONE, metallic, roughness * roughness);
            let bsdf = Bsdf::metallic_roughness(&m, n, n);
            for theta in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
                let wo = direction(n, theta, 0.4);
                let (mean, sigma) = albedo(&bsdf, wo, 100_000, 12);
                let label = format!("metallic {metallic}, roughness {roughness}, θo {theta}°");
                eprintln!("{label}: albedo {} ± {sigma}", mean.x);
                let bound = 5.0 * sigma + 3e-3;
                assert!(
                    mean.max_element() <= 1.0 + bound,
                    "{label}: {mean} ± {sigma}"
                );
                assert!(
                    mean.min_element() >= 0.9 - bound,
                    "{label}: {mean} ± {sigma}"
                );
                if metallic == 1.0 {
                    assert!(
                        (mean - Vec3::ONE).abs().max_element() <= bound,
                        "{label}: {mean}"
                    );
                }
            }
        }
    }
}

/// Nothing reflects more than it receives, whatever the colour and parameters.
#[test]
fn no_material_reflects_more_than_it_receives() {
    let n = tilted_normal();
    for (name, bsdf) in lobes(n) {
        for theta in [0.0f32, 45.0, 75.0, 89.0] {
            let (mean, sigma) = albedo(&bsdf, direction(n, theta, 0.1), 50_000, 13);
            assert!(
                mean.max_element() <= 1.0 + 5.0 * sigma + 3e-3,
                "{name}, θo {theta}°: {mean} ± {sigma}"
            );
        }
    }
}

/// Schlick's Fresnel from `f0` at cosine `cos`, from its definition.
fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    f0 + (Vec3::ONE - f0) * (1.0 - cos).powi(5)
}

/// A smooth metal is a perfect mirror reflecting Schlick's Fresnel of `F0` = base
/// colour: exactly `F0` head-on; a nearly smooth one reflects about as much.
#[test]
fn smooth_metal_is_a_mirror_of_its_base_colour() {
    let n = tilted_normal();
    let f0 = Vec3::new(0.9, 0.5, 0.1);
    let mirror = Bsdf::metallic_roughness(&MetallicRoughness::new(f0, 1.0, 0.0), n, n);
    assert!(mirror.is_delta());
    for theta in [0.0f32, 60.0, 85.0] {
        let wo = direction(n, theta, 0.3);
        let s = mirror
            .sample(wo, Vec2::new(0.4, 0.6))
            .expect("a mirror reflects");
        assert!(s.delta);
        assert!((s.wi - (2.0 * wo.dot(n) * n - wo)).length() < 1e-5);
        let want = schlick(f0, theta.to_radians().cos());
        assert!(
            (s.weight() - want).abs().max_element() < 1e-5,
            "{theta}°: {}",
            s.weight()
        );
    }
    let wo = direction(n, 0.0, 0.0);
    assert_eq!(mirror.sample(wo, Vec2::new(0.4, 0.6)).unwrap().weight(), f0);
    let nearly = Bsdf::metallic_roughness(&MetallicRoughness::new(f0, 1.0, 0.002), n, n);
    assert!(!nearly.is_delta());
    let (mean, sigma) = albedo(&nearly, wo, 50_000, 14);
    assert!(
        (mean - f0).abs().max_element() < 5.0 * sigma + 5e-3,
        "{mean}"
    );
}

/// A black smooth dielectric reflects only its specular layer: the Fresnel of index
/// 1.5 head-on (4%), Schlick's curve from there at other angles.
#[test]
fn black_dielectric_reflects_the_fresnel_of_index_one_and_a_half() {
    let n = tilted_normal();
    let black = Bsdf::metallic_roughness(&MetallicRoughness::new(Vec3::ZERO, 0.0, 0.01), n, n);
    for theta in [0.0f32, 45.0, 70.0] {
        let cos = theta.to_radians().cos();
        let (mean, sigma) = albedo(&black, direction(n, theta, 0.8), 100_000, 15);
        let want = schlick(Vec3::splat(0.04), cos);
        eprintln!("θo {theta}°: {mean} ± {sigma}, Schlick {}", want.x);
        assert!(
            (mean - want).abs().max_element() < 5.0 * sigma + 2e-3,
            "{theta}°: {mean}"
        );
        if theta == 0.0 {
            assert!((mean.x - fresnel_dielectric(1.0, 1.5)).abs() < 5.0 * sigma + 2e-3);
        }
    }
}

/// `∫ eval(wo, wi) dωi` by quadrature over the sphere (per channel): the albedo the
/// integrator must find, independently of the sampler.
fn albedo_by_quadrature(bsdf: &Bsdf, n: Vec3, wo: Vec3) -> DVec3 {
    let channel = |c: usize| -> f64 {
        let value = |wi: Vec3| bsdf.eval(wo, wi)[c];
        bin_integrals(&value, n, 64, 64, 8).iter().sum()
    };
    DVec3::new(channel(0), channel(1), channel(2))
}

/// The radiance along `ray` by the MIS path tracer, with its standard error.
fn radiance<A: Accel>(tracer: &PathTracer<'_, A>, ray: Ray, seed: u64) -> (DVec3, DVec3) {
    let mut count = RayCount::default();
    let mut sums = SampleSums::default();
    for i in 0..40_000 {
        let mut rng = Rng::for_sample(seed, 0, i);
        sums.add(tracer.radiance(ray, &mut rng, &mut count));
    }
    sums.mean_and_error()
}

/// A plane of the material under a white sky sees only the sky, so it returns its
/// directional albedo towards the viewer: a rough dielectric its albedo by quadrature,
/// a smooth metal the sky times Schlick's Fresnel of its base colour.
#[test]
fn a_plane_under_a_white_sky_returns_its_albedo() {
    let base = Vec3::new(0.8, 0.5, 0.2);
    let materials = [
        Material::metallic_roughness("rough plastic", base, 0.0, 1.0),
        Material::metallic_roughness("chrome", base, 1.0, 0.0),
    ];
    for (index, material) in materials.iter().enumerate() {
        let (a, b) = (Vec3::new(-50.0, 0.0, -50.0), Vec3::new(50.0, 0.0, -50.0));
        let (c, d) = (Vec3::new(50.0, 0.0, 50.0), Vec3::new(-50.0, 0.0, 50.0));
        let mut built = build(&quad(a, d, c, b, 0), vec![material.clone()]);
        built.scene.sky = Some(Arc::new(Environment::constant(Vec3::ONE)));
        let tracer = PathTracer::new(&built.scene, &built.accel, 16, IntegratorKind::Mis);
        for theta in [0.0f32, 50.0, 75.0] {
            let wo = direction(Vec3::Y, theta, 0.5);
            let ray = Ray::new(2.0 * wo, -wo);
            let (mean, error) = radiance(&tracer, ray, index as u64);
            let bsdf = Bsdf::metallic_roughness(
                &MetallicRoughness::new(base, material.metallic, material.alpha()),
                Vec3::Y,
                Vec3::Y,
            );
            let want = if bsdf.is_delta() {
                schlick(base, theta.to_radians().cos()).as_dvec3()
            } else {
                albedo_by_quadrature(&bsdf, Vec3::Y, wo)
            };
            eprintln!(
                "{}, θ {theta}°: {mean} ± {error}, want {want}",
                material.name
            );
            assert!(
                ((mean - want).abs() - 5.0 * error).max_element() <= 2e-3,
                "{}, θ {theta}°: {mean} ± {error}, want {want}",
                material.name
            );
        }
    }
}

/// glTF's textures: the base colour texture multiplies `baseColorFactor`, and one
/// metallic-roughness texture gives roughness from green and metallic from blue, each
/// times its factor (α = (roughness factor × green)²).
#[test]
fn a_gltf_texture_feeds_roughness_from_green_and_metallic_from_blue() {
    let triangle = [
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
    ];
    let mesh = TriangleMesh {
        positions: triangle.to_vec(),
        normals: Vec::new(),
        uvs: vec![Vec2::ZERO, Vec2::new(0.5, 1.0), Vec2::X],
        triangles: vec![[0, 1, 2]],
        material: vec![0],
        colours: Vec::new(),
    };
    let colour = Texture::from_linear(1, 1, vec![Vec3::new(0.5, 0.25, 1.0)]);
    let metallic_roughness = Texture::from_linear(1, 1, vec![Vec3::new(0.9, 0.6, 0.3)]);
    let mut material = Material::metallic_roughness("textured", Vec3::new(0.8, 1.0, 0.5), 0.5, 0.5);
    material.diffuse_texture = Some(0);
    material.maps.roughness = Some(1);
    material.maps.roughness_channel = Channel::Green;
    material.maps.metallic = Some(1);
    material.maps.metallic_channel = Channel::Blue;
    let scene = Scene::new(
        mesh,
        vec![material],
        vec![Arc::new(colour), Arc::new(metallic_roughness)],
    );
    let built = with_embree(scene);
    let hit = built
        .accel
        .intersect(&Ray::new(Vec3::new(0.0, 1.0, -0.2), -Vec3::Y))
        .expect("the ray hits the triangle");
    let p = built.scene.params(&built.scene.surface(&hit));
    assert!(
        (p.albedo - Vec3::new(0.4, 0.25, 0.5)).abs().max_element() < 1e-6,
        "{}",
        p.albedo
    );
    assert!(
        (p.metallic - 0.5 * 0.3).abs() < 1e-6,
        "metallic {}",
        p.metallic
    );
    assert!(
        (p.alpha - (0.5f32 * 0.6).powi(2)).abs() < 1e-6,
        "alpha {}",
        p.alpha
    );
}
