//! glTF's transmission (`KHR_materials_transmission` with `KHR_materials_ior` and
//! `KHR_materials_specular`) against mathematics: the rough glass's draws follow its
//! `pdf` over the whole sphere, reflection and refraction, from both sides (chi-square);
//! `pdf` integrates to the draws that yield a direction; `sample` returns exactly `eval`
//! and `pdf` and the index it crossed; `f(wo, wi) E(wo)/η_o² = f(wi, wo) E(wi)/η_i²`
//! (reciprocal up to the energy compensation's scale `1/E`); a clear glass in a white
//! furnace keeps all the light, at any roughness, from either side; smooth, it is
//! ember's smooth glass, and nearly smooth it splits light by Fresnel's equations. In
//! scenes: a clear glass ball under a white sky looks white, rough too, and hostile
//! values are one error line.

mod common;

use std::f64::consts::PI;
use std::sync::Arc;

use common::bsdf::{
    assert_draws_follow_pdf_about, assert_pdf_integrates_to_the_kept_draws,
    assert_sample_agrees_with_eval_and_pdf, direction, draw, tilted_normal,
};
use common::gltf::{floor_quad, png_data_uri, refused, GltfBuilder};
use common::stats::SampleSums;
use common::{build, quad, with_embree, Built};
use ember::accel::{Accel, Ray};
use ember::bsdf::{fresnel_dielectric, glass_albedo, Bsdf, MetallicRoughness};
use ember::image::srgb_to_linear;
use ember::integrator::{IntegratorKind, PathTracer, RayCount};
use ember::light::LightSamplerKind;
use ember::sampling::{uniform_sphere, Rng};
use ember::scene::{load_gltf, Environment, LoadOptions, Material, Model};
use glam::{DVec3, Vec2, Vec3};
use serde_json::json;

/// Polar angles of `wo`, in degrees, grazing included.
const THETAS: [f32; 4] = [5.0, 40.0, 70.0, 87.0];

/// A glass of base colour `base`, roughness `roughness` and index `ior`, all transmission.
fn glass(base: Vec3, roughness: f32, ior: f32) -> MetallicRoughness {
    MetallicRoughness {
        ior,
        transmission: 1.0,
        ..MetallicRoughness::new(base, 0.0, roughness * roughness)
    }
}

/// Glasses across roughness, index and colour, and materials that mix the glass with
/// the diffuse base, the metal and `KHR_materials_specular`.
fn materials() -> Vec<(&'static str, MetallicRoughness)> {
    vec![
        ("clear glass r 0.3 ior 1.5", glass(Vec3::ONE, 0.3, 1.5)),
        ("clear glass r 0.6 ior 1.33", glass(Vec3::ONE, 0.6, 1.33)),
        ("clear glass r 1 ior 2.4", glass(Vec3::ONE, 1.0, 2.4)),
        (
            "tinted glass r 0.5",
            glass(Vec3::new(0.9, 0.5, 0.2), 0.5, 1.5),
        ),
        (
            "half transmission r 0.4",
            MetallicRoughness {
                transmission: 0.5,
                ..glass(Vec3::new(0.3, 0.6, 0.9), 0.4, 1.5)
            },
        ),
        (
            "glass and metal r 0.5",
            MetallicRoughness {
                metallic: 0.3,
                ..glass(Vec3::new(0.8, 0.7, 0.5), 0.5, 1.7)
            },
        ),
        (
            "specular extension glass r 0.4",
            MetallicRoughness {
                specular: 0.6,
                specular_colour: Vec3::new(1.0, 0.5, 2.0),
                ..glass(Vec3::splat(0.8), 0.4, 1.6)
            },
        ),
    ]
}

fn lobes(n: Vec3) -> Vec<(String, Bsdf)> {
    materials()
        .into_iter()
        .map(|(name, m)| (name.to_string(), Bsdf::metallic_roughness(&m, n, n)))
        .collect()
}

#[test]
fn sampled_directions_follow_the_pdf_over_the_sphere() {
    let n = tilted_normal();
    let lobes = lobes(n);
    assert!(lobes
        .iter()
        .all(|(_, bsdf)| !bsdf.is_delta() && bsdf.transmits()));
    // Bins about a direction across the normal (see `assert_draws_follow_pdf_about`).
    let axis = n.any_orthonormal_vector();
    let mut seed = 900;
    for (name, bsdf) in &lobes {
        for theta in THETAS {
            for side in [1.0f32, -1.0] {
                let wo = side * direction(n, theta, 0.7);
                let label = format!("{name}, θo = {theta}°, side {side}");
                assert_draws_follow_pdf_about(&label, bsdf, axis, wo, seed);
                seed += 2;
            }
        }
    }
}

#[test]
fn pdf_integrates_to_the_draws_that_yield_a_direction() {
    let n = tilted_normal();
    for (name, bsdf) in lobes(n) {
        for theta in THETAS {
            for side in [1.0f32, -1.0] {
                let wo = side * direction(n, theta, 2.0);
                let label = format!("{name}, θo {theta}°, side {side}");
                let failed = assert_pdf_integrates_to_the_kept_draws(&label, &bsdf, wo);
                eprintln!("{label}: {failed:.4} of the draws void");
            }
        }
    }
}

/// The index of the side of `w`: 1 in front of the normal, `ior` behind it.
fn index_of_side(w: Vec3, n: Vec3, ior: f32) -> f32 {
    if w.dot(n) > 0.0 {
        1.0
    } else {
        ior
    }
}

/// `sample` returns what `eval` and `pdf` say of its direction, and the relative index
/// it crossed: `η_i/η_o` across the surface, 1 on the same side.
#[test]
fn sample_agrees_exactly_with_eval_pdf_and_the_index_crossed() {
    let n = tilted_normal();
    let mut rng = Rng::seeded(41);
    for ((name, bsdf), (_, m)) in lobes(n).into_iter().zip(materials()) {
        let mut crossed = 0;
        for theta in THETAS {
            for side in [1.0f32, -1.0] {
                let wo = side * direction(n, theta, 1.0);
                assert_sample_agrees_with_eval_and_pdf(&name, &bsdf, wo, &mut rng);
                let mut kept = 0;
                for _ in 0..2000 {
                    let Some(s) = draw(&bsdf, wo, &mut rng) else {
                        continue;
                    };
                    kept += 1;
                    let want = index_of_side(s.wi, n, m.ior) / index_of_side(wo, n, m.ior);
                    assert!(
                        (s.eta - want).abs() < 1e-6,
                        "{name}: η {} for {want}",
                        s.eta
                    );
                    assert_eq!(s.eta, bsdf.eta(wo, s.wi), "{name}");
                    crossed += usize::from(s.wi.dot(n) * wo.dot(n) < 0.0);
                }
                // Rough glass seen from inside sends up to half its draws into its own
                // surface.
                assert!(kept > 500, "{name}, θo {theta}°, side {side}: {kept} kept");
            }
        }
        assert!(crossed > 1000, "{name}: {crossed} refracted");
    }
}

/// The clear glass's single-scattering albedo for light arriving along `w` (see
/// [`glass_albedo`]): the energy compensation divides the glass's lobe by it.
fn single_scattering_albedo(w: Vec3, n: Vec3, m: &MetallicRoughness) -> f32 {
    let eta = if w.dot(n) > 0.0 { m.ior } else { 1.0 / m.ior };
    glass_albedo(w.dot(n).abs(), m.alpha, eta)
}

/// Generalised reciprocity in the radiance convention, up to the energy compensation
/// (Turquin's and Cycles' scale `1/E(wo)`, which is not reciprocal):
/// `f(wo, wi) E(wo)/η_o² = f(wi, wo) E(wi)/η_i²`, `η` the index on each direction's side,
/// over random pairs on the whole sphere; at least a thousand of them refracted and
/// non-zero. Where the glass is mixed with the base or the metal, whose lobes are not
/// scaled, refracted pairs only (only the glass refracts).
#[test]
fn the_btdf_is_reciprocal_up_to_the_squared_indices_and_compensation() {
    let n = tilted_normal();
    let mut rng = Rng::seeded(42);
    for ((name, bsdf), (_, m)) in lobes(n).into_iter().zip(materials()) {
        let (mut crossed, mut worst) = (0, 0.0f32);
        let pure = m.transmission >= 1.0 && m.metallic <= 0.0;
        for _ in 0..20_000 {
            let a = uniform_sphere(rng.f32(), rng.f32());
            let b = uniform_sphere(rng.f32(), rng.f32());
            let (ca, cb) = (a.dot(n).abs(), b.dot(n).abs());
            if ca < 1e-3 || cb < 1e-3 || !(pure || a.dot(n) * b.dot(n) < 0.0) {
                continue;
            }
            let (ia, ib) = (index_of_side(a, n, m.ior), index_of_side(b, n, m.ior));
            let (ea, eb) = (
                single_scattering_albedo(a, n, &m),
                single_scattering_albedo(b, n, &m),
            );
            let f_ab = bsdf.eval(a, b) * ea / cb / (ia * ia);
            let f_ba = bsdf.eval(b, a) * eb / ca / (ib * ib);
            let scale = f_ab.max_element().max(f_ba.max_element());
            // f32 rounding: `1 − F` cancels where a facet is seen at a grazing angle.
            let error = (f_ab - f_ba).abs().max_element();
            assert!(
                error <= 5e-4 * scale + 1e-7,
                "{name}: f({a}, {b})/η² = {f_ab} but f({b}, {a})/η² = {f_ba}"
            );
            if scale > 1e-5 {
                worst = worst.max(error / scale);
            }
            crossed += usize::from(scale > 0.0 && a.dot(n) * b.dot(n) < 0.0);
        }
        eprintln!("{name}: {crossed} refracted pairs, largest relative difference {worst:e}");
        assert!(crossed > 1000, "{name}: only {crossed} refracted pairs");
    }
}

/// White furnace: a clear glass (base colour white) reflects and transmits together
/// all the light it receives, within 2%, at every roughness and index, from either side
/// at any angle up to 80° (single scattering alone keeps as little as 30% at roughness
/// 1), and at a grazing 89° still no more than it receives.
#[test]
fn a_clear_glass_in_a_white_furnace_keeps_all_the_light() {
    let n = tilted_normal();
    for roughness in [0.1f32, 0.3, 0.5, 0.7, 1.0] {
        for ior in [1.33f32, 1.5, 2.0] {
            let bsdf = Bsdf::metallic_roughness(&glass(Vec3::ONE, roughness, ior), n, n);
            for theta in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
                for side in [1.0f32, -1.0] {
                    let wo = side * direction(n, theta, 0.4);
                    let (mean, sigma) = energy_albedo(&bsdf, wo, 200_000);
                    let label =
                        format!("roughness {roughness}, ior {ior}, θo {theta}°, side {side}");
                    eprintln!("{label}: R+T {mean} ± {sigma}");
                    assert!(
                        mean <= 1.0 + 5.0 * sigma + 2e-3,
                        "{label}: {mean} ± {sigma}"
                    );
                    if theta <= 80.0 {
                        assert!(mean >= 0.98 - 5.0 * sigma, "{label}: {mean} ± {sigma}");
                    }
                }
            }
        }
    }
}

/// No glass, tinted, mixed with the base or the metal, or with `KHR_materials_specular`,
/// returns more of any channel than it receives, from either side.
#[test]
fn no_glass_returns_more_than_it_receives() {
    let n = tilted_normal();
    for (name, bsdf) in lobes(n) {
        for theta in [0.0f32, 45.0, 75.0, 89.0] {
            for side in [1.0f32, -1.0] {
                let wo = side * direction(n, theta, 0.1);
                let mut rng = Rng::seeded(47);
                let count = 100_000;
                let (mut sum, mut sum2) = (DVec3::ZERO, 0.0f64);
                for _ in 0..count {
                    if let Some(s) = draw(&bsdf, wo, &mut rng) {
                        let w = (s.weight() * s.eta * s.eta).as_dvec3();
                        sum += w;
                        sum2 += w.max_element().powi(2);
                    }
                }
                let mean = sum / count as f64;
                let sigma = ((sum2 / count as f64 - mean.max_element().powi(2)).max(0.0)
                    / count as f64)
                    .sqrt();
                assert!(
                    mean.max_element() <= 1.0 + 5.0 * sigma + 2e-3,
                    "{name}, θo {theta}°, side {side}: {mean} ± {sigma}"
                );
            }
        }
    }
}

/// The directional albedo `∫ f cos dωi` of `wo` with the refracted light's `1/η²` taken
/// out (energy is conserved, not radiance), in the red channel, and its standard error.
fn energy_albedo(bsdf: &Bsdf, wo: Vec3, count: usize) -> (f32, f32) {
    let mut rng = Rng::seeded(43);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..count {
        if let Some(s) = draw(bsdf, wo, &mut rng) {
            let w = f64::from(s.weight().x * s.eta * s.eta);
            sum += w;
            sum2 += w * w;
        }
    }
    let mean = sum / count as f64;
    let var = (sum2 / count as f64 - mean * mean).max(0.0);
    (mean as f32, (var / count as f64).sqrt() as f32)
}

/// Walter, Marschner, Li and Torrance's rough glass (2007), written out here in f64
/// from the paper: GGX, separable Smith masking, exact Fresnel; `f(wo, wi) |cos θi|` in
/// the radiance convention for an interface of index `ior` behind the normal `n`.
fn walter(n: Vec3, wo: Vec3, wi: Vec3, alpha: f64, ior: f64) -> f64 {
    let (n, o, i) = (n.as_dvec3(), wo.as_dvec3(), wi.as_dvec3());
    let cos_o = o.dot(n);
    // Light arrives on the side of wo; its index is 1 in front of n, ior behind.
    let eta = if cos_o > 0.0 { ior } else { 1.0 / ior };
    let n = if cos_o > 0.0 { n } else { -n };
    let (cos_o, cos_i) = (cos_o.abs(), i.dot(n));
    let tan2 = |c: f64| (1.0 - c * c) / (c * c);
    let g1 = |c: f64| 2.0 / (1.0 + (1.0 + alpha * alpha * tan2(c)).sqrt());
    let d = |cos_h: f64| {
        let c2 = cos_h * cos_h;
        alpha * alpha / (PI * (c2 * (alpha * alpha - 1.0) + 1.0).powi(2))
    };
    let fresnel = |c: f64| {
        let s2 = (1.0 - c * c) / (eta * eta);
        if s2 >= 1.0 {
            return 1.0;
        }
        let t = (1.0 - s2).sqrt();
        let rs = (c - eta * t) / (c + eta * t);
        let rp = (eta * c - t) / (eta * c + t);
        0.5 * (rs * rs + rp * rp)
    };
    let masking = g1(cos_o) * g1(cos_i.abs());
    if cos_i > 0.0 {
        let h = (o + i).normalize();
        return fresnel(o.dot(h)) * d(h.dot(n)) * masking / (4.0 * cos_o);
    }
    let mut h = (o + eta * i).normalize();
    if h.dot(n) < 0.0 {
        h = -h;
    }
    let (oh, ih) = (o.dot(h), i.dot(h));
    if oh <= 0.0 || ih >= 0.0 {
        return 0.0;
    }
    let denominator = oh + eta * ih;
    (1.0 - fresnel(oh)) * d(h.dot(n)) * masking * oh * -ih / (cos_o * denominator * denominator)
}

/// A clear glass's `eval` is Walter et al.'s BSDF divided by the single-scattering albedo
/// of `wo` (the energy compensation): over random pairs on the sphere, reflected and
/// refracted, from both sides, for several roughnesses and indices.
#[test]
fn a_clear_glass_evaluates_walters_formulas() {
    let n = tilted_normal();
    let mut rng = Rng::seeded(46);
    for (roughness, ior) in [(0.3f32, 1.5f32), (0.6, 1.33), (1.0, 2.4), (0.15, 1.7)] {
        let alpha = roughness * roughness;
        let m = glass(Vec3::ONE, roughness, ior);
        let bsdf = Bsdf::metallic_roughness(&m, n, n);
        let (mut reflected, mut refracted) = (0, 0);
        for _ in 0..50_000 {
            let wo = uniform_sphere(rng.f32(), rng.f32());
            let wi = uniform_sphere(rng.f32(), rng.f32());
            if wo.dot(n).abs() < 1e-2 || wi.dot(n).abs() < 1e-2 {
                continue;
            }
            let want = walter(n, wo, wi, f64::from(alpha), f64::from(ior));
            // The compensation taken out again, so that f32's rounding is compared at
            // the scale it was made at.
            let single = f64::from(single_scattering_albedo(wo, n, &m));
            let got = f64::from(bsdf.eval(wo, wi).x) * single;
            assert!(
                (got - want).abs() <= 1e-3 * want + 1e-6,
                "roughness {roughness}, ior {ior}: eval({wo}, {wi}) × E = {got}, Walter {want}"
            );
            if want > 1e-3 {
                let crossed = wo.dot(n) * wi.dot(n) < 0.0;
                refracted += usize::from(crossed);
                reflected += usize::from(!crossed);
            }
        }
        assert!(
            reflected > 200 && refracted > 200,
            "{reflected} {refracted}"
        );
    }
}

/// A smooth clear glass is ember's smooth glass, draw for draw.
#[test]
fn a_smooth_clear_glass_is_the_smooth_dielectric() {
    let n = tilted_normal();
    let smooth = Bsdf::metallic_roughness(&glass(Vec3::ONE, 0.0, 1.5), n, n);
    let reference = Bsdf::dielectric(1.5, n, n);
    assert!(smooth.is_delta() && smooth.transmits());
    let mut rng = Rng::seeded(44);
    for theta in [0.0f32, 30.0, 60.0, 85.0] {
        for side in [1.0f32, -1.0] {
            let wo = side * direction(n, theta, 0.9);
            for _ in 0..200 {
                let u = Vec2::new(rng.f32(), rng.f32());
                assert_eq!(smooth.sample(wo, u), reference.sample(wo, u));
            }
        }
    }
}

/// Nearly smooth (α = 0.002, still GGX), a clear glass reflects Fresnel's share of the
/// light and transmits the rest: `R = F(θo)`, and `T·η² = 1 − F(θo)` (the radiance
/// carried is `(1 − F)/η²`).
#[test]
fn a_nearly_smooth_glass_splits_light_by_fresnel() {
    let n = tilted_normal();
    let ior = 1.5;
    let bsdf = Bsdf::metallic_roughness(&glass(Vec3::ONE, 0.002f32.sqrt(), ior), n, n);
    assert!(!bsdf.is_delta());
    for theta in [0.0f32, 45.0, 75.0] {
        for side in [1.0f32, -1.0] {
            let wo = side * direction(n, theta, 0.2);
            let eta = if side > 0.0 { ior } else { 1.0 / ior };
            let f = fresnel_dielectric(theta.to_radians().cos(), eta);
            let mut rng = Rng::seeded(45);
            let (mut r, mut t) = (0.0f64, 0.0f64);
            let count = 200_000;
            for _ in 0..count {
                if let Some(s) = draw(&bsdf, wo, &mut rng) {
                    let w = f64::from(s.weight().x);
                    if s.wi.dot(n) * wo.dot(n) > 0.0 {
                        r += w;
                    } else {
                        t += w * f64::from(s.eta * s.eta);
                    }
                }
            }
            let (r, t) = (r / count as f64, t / count as f64);
            eprintln!("θo {theta}°, side {side}: R {r} T {t}, Fresnel {f}");
            assert!((r - f64::from(f)).abs() < 0.01, "R {r} against {f}");
            assert!(
                (t - f64::from(1.0 - f)).abs() < 0.01,
                "T {t} against {}",
                1.0 - f
            );
        }
    }
}

/// A UV sphere of radius `radius` about `centre` in `gltf`, flat-shaded (no normals, so
/// that shading normals cannot bend energy in or out), of material `material`.
fn sphere(gltf: &mut GltfBuilder, material: usize, centre: Vec3, radius: f32) {
    let (rings, segments) = (24u32, 48u32);
    let mut positions = Vec::new();
    for i in 0..=rings {
        let theta = PI as f32 * i as f32 / rings as f32;
        for j in 0..segments {
            let phi = 2.0 * PI as f32 * j as f32 / segments as f32;
            let d = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            positions.push((centre + radius * d).to_array());
        }
    }
    let at = |i: u32, j: u32| i * segments + j % segments;
    let mut indices = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
            for [p, q, r] in [[a, b, c], [a, c, d]] {
                let [vp, vq, vr] = [p, q, r].map(|k| Vec3::from(positions[k as usize]));
                let normal = (vq - vp).cross(vr - vp);
                // Counter-clockwise seen from outside; the poles' slivers have no area.
                if normal.length() < 1e-9 {
                    continue;
                }
                let outward = normal.dot(vp + vq + vr - 3.0 * centre) > 0.0;
                indices.extend(if outward { [p, q, r] } else { [p, r, q] });
            }
        }
    }
    let mesh = gltf.mesh(&positions, None, &indices, Some(material));
    gltf.node(json!({"mesh": mesh}), true);
}

/// A clear glass material of `roughness` and index `ior` as a glTF writes it.
fn clear_glass_json(roughness: f32, ior: f32) -> serde_json::Value {
    json!({"name": "Glass",
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": roughness},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
            "KHR_materials_ior": {"ior": ior}}})
}

fn with_glass_extensions(gltf: &mut GltfBuilder) {
    gltf.uses("KHR_materials_transmission", false);
    gltf.uses("KHR_materials_ior", false);
}

fn load(gltf: &GltfBuilder) -> Built {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.gltf");
    std::fs::write(&path, gltf.to_gltf()).unwrap();
    let loaded = load_gltf(&path, &LoadOptions::default()).expect("loads");
    assert!(
        loaded.report.warnings.is_empty(),
        "{:?}",
        loaded.report.warnings
    );
    with_embree(loaded.scene)
}

/// The mean radiance of `n` paths along `ray` by `kind`, with its standard error.
fn radiance(built: &Built, kind: IntegratorKind, ray: Ray, n: u64, seed: u64) -> (DVec3, DVec3) {
    // The light BVH, which culls lights behind a receiver's normal, whatever the count.
    let (scene, accel) = (&built.scene, &built.accel);
    let tracer = PathTracer::with_light_sampler(scene, accel, 64, kind, LightSamplerKind::Bvh);
    let mut count = RayCount::default();
    let mut sums = SampleSums::default();
    for i in 0..n {
        let mut rng = Rng::for_sample(seed, 0, i);
        sums.add(tracer.radiance(ray, &mut rng, &mut count));
    }
    sums.mean_and_error()
}

/// A glass ball in a white world (a white sky, nothing else) is white: light is only
/// reflected and refracted, never absorbed. Smooth, exactly (all of it reaches the sky
/// in the end); rough, within 2% (the compensation keeps the light that single
/// scattering would lose at each of its crossings).
#[test]
fn a_clear_glass_ball_under_a_white_sky_is_white() {
    for (roughness, least) in [(0.0f32, 1.0f64), (0.3, 0.98), (0.5, 0.98)] {
        let mut gltf = GltfBuilder::default();
        with_glass_extensions(&mut gltf);
        let material = gltf.material(clear_glass_json(roughness, 1.5));
        sphere(&mut gltf, material, Vec3::ZERO, 1.0);
        let mut built = load(&gltf);
        built.scene.sky = Some(Arc::new(Environment::constant(Vec3::ONE)));
        for (i, (x, y)) in [(0.0f32, 0.0f32), (0.5, 0.2), (-0.2, -0.6)]
            .into_iter()
            .enumerate()
        {
            let ray = Ray::new(Vec3::new(x, y, 4.0), -Vec3::Z);
            for kind in [IntegratorKind::Mis, IntegratorKind::Bsdf] {
                let (mean, error) = radiance(&built, kind, ray, 40_000, i as u64);
                let label = format!("roughness {roughness}, ray at ({x}, {y}), {kind:?}");
                eprintln!("{label}: {mean} ± {error}");
                let (m, e) = (mean.min_element(), error.max_element());
                assert!(m <= 1.0 + 5.0 * e + 1e-3, "{label}: {mean} ± {error}");
                assert!(m >= least - 5.0 * e - 2e-3, "{label}: {mean} ± {error}");
            }
        }
    }
}

/// An emitter seen through a rough glass: next-event estimation alone (`light`, which
/// counts no emitter a path meets) finds what BSDF sampling alone finds, and MIS too:
/// light samples reach lights behind a surface that transmits.
#[test]
fn lights_behind_a_rough_glass_are_found_by_light_samples() {
    let mut glass = Material::metallic_roughness("glass", Vec3::new(0.9, 0.8, 0.6), 0.0, 0.5);
    if let Model::MetallicRoughness { transmission, .. } = &mut glass.model {
        *transmission = 1.0;
    }
    let lamp = Material {
        name: "lamp".into(),
        diffuse: Vec3::ZERO,
        emission: Vec3::new(4.0, 3.0, 2.0),
        ..Material::default()
    };
    let (a, b) = (Vec3::new(-3.0, 0.0, -3.0), Vec3::new(3.0, 0.0, -3.0));
    let (c, d) = (Vec3::new(3.0, 0.0, 3.0), Vec3::new(-3.0, 0.0, 3.0));
    let below = Vec3::new(0.0, -1.0, 0.0);
    let (e, f) = (Vec3::new(-0.5, -1.0, -0.5), Vec3::new(0.5, -1.0, -0.5));
    let (g, h) = (Vec3::new(0.5, -1.0, 0.5), Vec3::new(-0.5, -1.0, 0.5));
    let mut triangles = quad(a, d, c, b, 0).to_vec();
    triangles.extend(quad(e, h, g, f, 1));
    // A second lamp above, facing down, off to the side: so that a light BVH that
    // culled lights behind the glass would have one to choose instead.
    let corner = |dx: f32, dz: f32| Vec3::new(2.0 + dx, 3.0, dz);
    let (i, j) = (corner(-0.3, -0.3), corner(0.3, -0.3));
    let (k, l) = (corner(0.3, 0.3), corner(-0.3, 0.3));
    triangles.extend(quad(i, j, k, l, 1));
    let built = build(&triangles, vec![glass, lamp]);
    let hit = built
        .accel
        .intersect(&Ray::new(below + 0.5 * Vec3::Y, -Vec3::Y))
        .expect("the lamp");
    assert!(built.scene.surface(&hit).ng.y > 0.0, "the lamp faces up");
    let hit = built
        .accel
        .intersect(&Ray::new(Vec3::new(2.0, 2.0, 0.0), Vec3::Y))
        .expect("the lamp above");
    assert!(
        built.scene.surface(&hit).ng.y < 0.0,
        "the lamp above faces down"
    );
    let ray = Ray::new(
        Vec3::new(0.2, 2.0, 0.1),
        Vec3::new(-0.1, -1.0, 0.0).normalize(),
    );
    let mut estimates = Vec::new();
    for kind in [
        IntegratorKind::Light,
        IntegratorKind::Bsdf,
        IntegratorKind::Mis,
    ] {
        let (mean, error) = radiance(&built, kind, ray, 200_000, 7);
        eprintln!("{kind:?}: {mean} ± {error}");
        assert!(mean.min_element() > 0.01, "{kind:?}: {mean}");
        estimates.push((kind, mean, error));
    }
    for (kind, mean, error) in &estimates[1..] {
        let (light, light_error) = (estimates[0].1, estimates[0].2);
        let bound = 5.0 * (error.max_element().powi(2) + light_error.max_element().powi(2)).sqrt();
        assert!(
            (*mean - light).abs().max_element() <= bound + 1e-3,
            "{kind:?} {mean} against light {light}"
        );
    }
}

/// A glTF of one quad whose material is `material`, using the extensions `used`.
fn quad_with(material: serde_json::Value, used: &[&str]) -> GltfBuilder {
    let mut gltf = GltfBuilder::default();
    for name in used {
        gltf.uses(name, false);
    }
    let m = gltf.material(material);
    let (p, uv, i) = floor_quad(1.0, 0.0);
    let mesh = gltf.mesh(&p, Some(&uv), &i, Some(m));
    gltf.node(json!({"mesh": mesh}), true);
    gltf
}

/// The reader takes `KHR_materials_ior`, `KHR_materials_specular` (factors and colour
/// texture; the specular texture, a map in an alpha channel, is one warning) and
/// `KHR_materials_transmission` (factor times the red channel of its texture), and an
/// `ior` of 0 is an infinite index, which reflects everything and refracts nothing.
#[test]
fn the_reader_takes_ior_specular_and_transmission() {
    let texel = [128u8, 255, 64];
    let mut gltf = quad_with(
        json!({"name": "Frosted",
            "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.7, 1.0],
                "metallicFactor": 0.0, "roughnessFactor": 0.4},
            "extensions": {
                "KHR_materials_ior": {"ior": 1.4},
                "KHR_materials_specular": {"specularFactor": 0.7,
                    "specularColorFactor": [1.0, 0.5, 0.25],
                    "specularColorTexture": {"index": 0}, "specularTexture": {"index": 0}},
                "KHR_materials_transmission": {"transmissionFactor": 0.8,
                    "transmissionTexture": {"index": 0}}}}),
        &[
            "KHR_materials_ior",
            "KHR_materials_specular",
            "KHR_materials_transmission",
        ],
    );
    gltf.json["images"] =
        json!([{"uri": png_data_uri(image::RgbImage::from_pixel(1, 1, image::Rgb(texel)))}]);
    gltf.json["textures"] = json!([{"source": 0}]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frosted.gltf");
    std::fs::write(&path, gltf.to_gltf()).unwrap();
    let loaded = load_gltf(&path, &LoadOptions::default()).expect("loads");
    let warnings = &loaded.report.warnings;
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].contains("specularTexture") && warnings[0].contains("Frosted"));
    let material = &loaded.scene.materials[0];
    assert_eq!(
        material.model,
        Model::MetallicRoughness {
            alpha: 0.4f32 * 0.4,
            ior: 1.4,
            specular: 0.7,
            transmission: 0.8
        }
    );
    assert_eq!(material.specular, Vec3::new(1.0, 0.5, 0.25));
    assert!(material.maps.specular.is_some() && material.maps.transmission.is_some());
    let built = with_embree(loaded.scene);
    let hit = built
        .accel
        .intersect(&Ray::new(Vec3::new(0.1, 1.0, 0.2), -Vec3::Y))
        .expect("the quad");
    let p = built.scene.params(&built.scene.surface(&hit));
    let linear = |c: u8| srgb_to_linear(f32::from(c) / 255.0);
    let colour = Vec3::new(1.0, 0.5, 0.25) * Vec3::from(texel.map(linear));
    assert!(
        (p.specular - colour).abs().max_element() < 1e-3,
        "{}",
        p.specular
    );
    let transmission = 0.8 * f32::from(texel[0]) / 255.0;
    assert!(
        (p.transmission - transmission).abs() < 1e-3,
        "{}",
        p.transmission
    );

    let infinite = quad_with(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0],
                "metallicFactor": 0.0, "roughnessFactor": 0.0},
            "extensions": {"KHR_materials_ior": {"ior": 0.0},
                "KHR_materials_transmission": {"transmissionFactor": 1.0}}}),
        &["KHR_materials_ior", "KHR_materials_transmission"],
    );
    let built = load(&infinite);
    let Model::MetallicRoughness { ior, .. } = built.scene.materials[0].model else {
        panic!("a glTF material");
    };
    assert_eq!(ior, f32::INFINITY);
    let hit = built
        .accel
        .intersect(&Ray::new(Vec3::new(0.1, 1.0, 0.2), -Vec3::Y))
        .expect("the quad");
    let surface = built.scene.surface(&hit);
    let wo = Vec3::new(0.3, 1.0, 0.1).normalize();
    let bsdf = built.scene.bsdf(&surface, wo);
    assert!(!bsdf.transmits());
    let (mean, sigma) = energy_albedo(&bsdf, wo, 20_000);
    assert!(
        (mean - 1.0).abs() < 5.0 * sigma + 2e-3,
        "a black dielectric of F0 = 1: {mean}"
    );
}

/// Values the extensions do not allow are one error line naming the file and the
/// material; so is a transmission texture that does not exist.
#[test]
fn hostile_dielectric_values_are_one_error_line() {
    let glass = |extensions: serde_json::Value| {
        let used = [
            "KHR_materials_ior",
            "KHR_materials_specular",
            "KHR_materials_transmission",
        ];
        let mut material = clear_glass_json(0.2, 1.5);
        material["extensions"] = extensions;
        quad_with(material, &used).to_gltf()
    };
    let cases = [
        (
            "ior-half.gltf",
            json!({"KHR_materials_ior": {"ior": 0.5}}),
            "KHR_materials_ior ior 0.5 is out of range",
        ),
        (
            "ior-negative.gltf",
            json!({"KHR_materials_ior": {"ior": -1.5}}),
            "KHR_materials_ior ior -1.5 is out of range",
        ),
        (
            "ior-huge.gltf",
            json!({"KHR_materials_ior": {"ior": 1e39}}),
            "KHR_materials_ior ior inf is out of range",
        ),
        (
            "transmission-over.gltf",
            json!({"KHR_materials_transmission": {"transmissionFactor": 1.5}}),
            "transmissionFactor 1.5 is out of range",
        ),
        (
            "transmission-under.gltf",
            json!({"KHR_materials_transmission": {"transmissionFactor": -0.25}}),
            "transmissionFactor -0.25 is out of range",
        ),
        (
            "specular.gltf",
            json!({"KHR_materials_specular": {"specularFactor": 2.0}}),
            "specularFactor 2 is out of range",
        ),
        (
            "specular-colour.gltf",
            json!({"KHR_materials_specular": {"specularColorFactor": [1.0, -1.0, 0.0]}}),
            "specularColorFactor [1, -1, 0] is out of range",
        ),
        (
            "specular-infinite.gltf",
            json!({"KHR_materials_specular": {"specularColorFactor": [1e39, 1.0, 1.0]}}),
            "specularColorFactor [inf, 1, 1] is out of range",
        ),
    ];
    for (name, extensions, says) in cases {
        let says = format!("material \"Glass\": its {says}");
        refused(name, glass(extensions).as_bytes(), &says);
    }
    let texture = json!({"KHR_materials_transmission": {"transmissionFactor": 1.0,
        "transmissionTexture": {"index": 9}}});
    refused("texture.gltf", glass(texture).as_bytes(), "invalid glTF");
}

/// Blender's exporter's glass (tests/data/gltf/glass.glb, written by
/// scripts/make_gltf_test_scenes.py): Principled BSDF's Transmission Weight and IOR
/// arrive as the extensions say, without a warning.
#[test]
fn blenders_glass_is_read_as_written() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gltf/glass.glb");
    let loaded = load_gltf(&path, &LoadOptions::default()).expect("loads");
    assert!(
        loaded.report.warnings.is_empty(),
        "{:?}",
        loaded.report.warnings
    );
    let model = |name: &str| {
        let m = loaded.scene.materials.iter().find(|m| m.name == name);
        m.unwrap_or_else(|| panic!("no material {name}")).clone()
    };
    let read = |name: &str| match model(name).model {
        Model::MetallicRoughness {
            ior, transmission, ..
        } => (ior, transmission),
        other => panic!("{name}: {other:?}"),
    };
    assert_eq!(read("clear-r0"), (1.5, 1.0));
    assert_eq!(read("half-r0.3"), (1.5, 0.5));
    assert!((read("water-r0").0 - 1.33).abs() < 1e-6);
    assert_eq!(read("floor"), (1.5, 0.0));
    let amber = model("amber-r0.2");
    assert!(
        (amber.diffuse - Vec3::new(0.9, 0.6, 0.3))
            .abs()
            .max_element()
            < 1e-6
    );
    assert!((amber.alpha() - 0.04).abs() < 1e-6);
}
