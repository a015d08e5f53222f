//! Every BSDF lobe against mathematics: sampled directions follow `pdf` (chi-square),
//! `pdf` integrates to 1 less the draws that fail, `sample` returns exactly `eval` and
//! `pdf`, reflection is reciprocal, and white furnaces: no lobe reflects more than it
//! receives, Lambert with `Kd = 1` exactly 1, the conductor with `Ks = 1` the GGX
//! single-scattering albedo computed here by quadrature, and glass `R + T = 1`.

mod common;

use std::f64::consts::PI;

use common::bsdf::{
    albedo, assert_every_lobe_draws_by_its_pdf, assert_pdf_integrates_to_the_kept_draws,
    assert_reciprocal, assert_sample_agrees_with_eval_and_pdf, direction, draw,
    tilted_normal as normal,
};
use ember::bsdf::{fresnel_dielectric, Bsdf};
use ember::sampling::{uniform_sphere, Rng};
use glam::{DVec3, Vec2, Vec3};

const ALPHAS: [f32; 4] = [0.1, 0.25, 0.5, 0.9];
/// Polar angles of `wo`, in degrees.
const THETAS: [f32; 4] = [5.0, 40.0, 70.0, 85.0];

/// The reflective BSDFs under test, named: Lambert, GGX conductors and coated GGX at
/// every α in [`ALPHAS`].
fn reflective_lobes(n: Vec3) -> Vec<(String, Bsdf)> {
    let mut lobes = vec![(
        "lambert".to_string(),
        Bsdf::lambert(Vec3::new(0.9, 0.5, 0.2), n, n),
    )];
    for alpha in ALPHAS {
        lobes.push((
            format!("conductor α={alpha}"),
            Bsdf::glossy(Vec3::ZERO, Vec3::new(1.0, 0.8, 0.6), alpha, n, n),
        ));
        lobes.push((
            format!("coated α={alpha}"),
            Bsdf::glossy(Vec3::splat(0.5), Vec3::splat(0.3), alpha, n, n),
        ));
    }
    lobes
}

/// Chi-square of the sampled directions against `pdf`, with the integral of `pdf`
/// (by quadrature) equal to the fraction of draws that yield a direction.
#[test]
fn sampled_directions_follow_the_pdf() {
    let n = normal();
    assert_every_lobe_draws_by_its_pdf(&reflective_lobes(n), n, &THETAS, 100);
}

/// `∫ pdf dω` equals the fraction of draws that yield a direction (1 for Lambert, a
/// little less for GGX at grazing angles).
#[test]
fn pdf_integrates_to_one_less_the_failed_draws() {
    let n = normal();
    for (name, bsdf) in reflective_lobes(n) {
        for theta in THETAS {
            let wo = direction(n, theta, 2.0);
            let failed = assert_pdf_integrates_to_the_kept_draws(
                &format!("{name}, θo = {theta}°"),
                &bsdf,
                wo,
            );
            if name == "lambert" {
                assert_eq!(failed, 0.0);
            }
        }
    }
}

/// What `sample` returns is exactly what `eval` and `pdf` say of its direction.
#[test]
fn sample_agrees_exactly_with_eval_and_pdf() {
    let n = normal();
    let mut rng = Rng::seeded(3);
    for (name, bsdf) in reflective_lobes(n) {
        for theta in THETAS {
            let wo = direction(n, theta, 1.0);
            assert_sample_agrees_with_eval_and_pdf(&name, &bsdf, wo, &mut rng);
        }
    }
}

/// `f(wo, wi) = f(wi, wo)`, where `f = eval / |cos θi|`.
#[test]
fn reflection_is_reciprocal() {
    let n = normal();
    let mut rng = Rng::seeded(4);
    for (name, bsdf) in reflective_lobes(n) {
        assert_reciprocal(&name, &bsdf, n, &mut rng);
    }
}

/// GGX's single-scattering albedo with Fresnel 1, `∫ D G1(wo) G1(wi) / (4 cos θo) dωi`,
/// by quadrature over the half vector `h`, independent of the sampling code. With
/// `dωi = 4 (wo·h) dωh` it is `∫ G1(wo) G1(wi) (wo·h) / (cos θo cos θh) · D cos θh dωh`,
/// and GGX's normalisation makes `D cos θh dωh = dx dφ / 2π` for
/// `x = tan²θh / (α² + tan²θh)`, over which the integrand is smooth: the midpoint
/// rule in (x, φ) converges fast even for narrow lobes at grazing angles.
fn ggx_albedo_by_quadrature(alpha: f32, theta_o: f32) -> f64 {
    let alpha = f64::from(alpha);
    let t = f64::from(theta_o).to_radians();
    let wo = DVec3::new(t.sin(), 0.0, t.cos());
    let g1 = |w: DVec3| {
        let tan2 = (w.x * w.x + w.y * w.y) / (w.z * w.z);
        2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
    };
    let (nx, nphi) = (4000, 1440);
    let mut sum = 0.0;
    for ix in 0..nx {
        let x = (ix as f64 + 0.5) / nx as f64;
        let tan_h = alpha * (x / (1.0 - x)).sqrt();
        let cos_h = 1.0 / (1.0 + tan_h * tan_h).sqrt();
        let sin_h = tan_h * cos_h;
        for ip in 0..nphi {
            let phi = (ip as f64 + 0.5) / nphi as f64 * 2.0 * PI;
            let h = DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
            let wo_h = wo.dot(h);
            let wi = 2.0 * wo_h * h - wo;
            if wo_h <= 0.0 || wi.z <= 0.0 {
                continue;
            }
            sum += g1(wo) * g1(wi) * wo_h / (wo.z * cos_h);
        }
    }
    sum / (nx * nphi) as f64
}

#[test]
fn white_furnace_lambert_reflects_exactly_everything() {
    let n = normal();
    let bsdf = Bsdf::lambert(Vec3::ONE, n, n);
    let mut rng = Rng::seeded(5);
    for theta in THETAS {
        let wo = direction(n, theta, 0.3);
        for _ in 0..10_000 {
            let s = draw(&bsdf, wo, &mut rng).expect("Lambert always samples");
            assert!((s.weight() - Vec3::ONE).abs().max_element() < 1e-5);
        }
    }
}

#[test]
fn white_furnace_conductor_matches_the_ggx_albedo() {
    for theta in [0.0f32, 40.0, 70.0, 85.0] {
        let mut previous = f64::INFINITY;
        for alpha in [0.05f32, 0.2, 0.5, 0.9] {
            let bsdf = Bsdf::glossy(Vec3::ZERO, Vec3::ONE, alpha, Vec3::Z, Vec3::Z);
            let wo = direction(Vec3::Z, theta, 0.0);
            let (mean, sigma) = albedo(&bsdf, wo, 400_000, 6);
            let truth = ggx_albedo_by_quadrature(alpha, theta);
            eprintln!(
                "α {alpha}, θo {theta}°: albedo {} ± {sigma}, quadrature {truth:.5}",
                mean.x
            );
            assert!(
                (f64::from(mean.x) - truth).abs() < 5.0 * f64::from(sigma) + 2e-4,
                "α {alpha}, θo {theta}°: albedo {} ± {sigma}, quadrature {truth}",
                mean.x
            );
            assert!(truth <= 1.0 + 1e-3);
            // Single scattering loses more energy the rougher the surface.
            assert!(
                truth <= previous + 1e-3,
                "albedo rises with α at θo {theta}"
            );
            previous = truth;
        }
    }
}

#[test]
fn no_reflective_lobe_reflects_more_than_it_receives() {
    let n = normal();
    let white = [
        ("lambert", Bsdf::lambert(Vec3::ONE, n, n)),
        ("mirror", Bsdf::glossy(Vec3::ZERO, Vec3::ONE, 1e-4, n, n)),
    ];
    let mut lobes: Vec<(String, Bsdf)> =
        white.into_iter().map(|(s, b)| (s.to_string(), b)).collect();
    for alpha in [0.01f32, 0.1, 0.3, 0.6, 1.0] {
        for ks in [0.0f32, 0.04, 0.5, 1.0] {
            lobes.push((
                format!("coated Kd=1 Ks={ks} α={alpha}"),
                Bsdf::glossy(Vec3::splat(1.0 - ks), Vec3::splat(ks), alpha, n, n),
            ));
        }
    }
    for (name, bsdf) in &lobes {
        for theta in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
            let wo = direction(n, theta, 0.4);
            let (mean, sigma) = albedo(bsdf, wo, 100_000, 8);
            assert!(
                mean.max_element() <= 1.0 + 5.0 * sigma + 1e-4,
                "{name}, θo {theta}°: albedo {mean} ± {sigma}"
            );
        }
    }
}

#[test]
fn mirror_below_the_delta_roughness_is_a_delta() {
    let n = normal();
    let bsdf = Bsdf::glossy(Vec3::ZERO, Vec3::new(0.9, 0.5, 0.1), 5e-4, n, n);
    assert!(bsdf.is_delta());
    let wo = direction(n, 30.0, 0.0);
    let s = bsdf.sample(wo, Vec2::new(0.3, 0.7)).unwrap();
    assert!(s.delta);
    assert!((s.wi - (2.0 * wo.dot(n) * n - wo)).length() < 1e-5);
    assert_eq!(s.weight(), Vec3::new(0.9, 0.5, 0.1));
    assert_eq!(bsdf.eval(wo, s.wi), Vec3::ZERO);
    assert_eq!(bsdf.pdf(wo, s.wi), 0.0);
}

/// Reflection is chosen with probability F, refraction with 1 − F; undoing the 1/η²
/// radiance scaling, `R + T = 1`; refraction obeys Snell's law; past the critical
/// angle everything reflects.
#[test]
fn glass_reflects_and_transmits_everything() {
    let n = normal();
    for ior in [1.33f32, 1.5, 2.5] {
        let glass = Bsdf::dielectric(ior, n, n);
        assert!(glass.is_delta());
        for theta in [0.0f32, 30.0, 60.0, 85.0] {
            for entering in [true, false] {
                let wo = if entering {
                    direction(n, theta, 0.2)
                } else {
                    -direction(n, theta, 0.2)
                };
                let eta = if entering { ior } else { 1.0 / ior };
                let f = fresnel_dielectric(theta.to_radians().cos(), eta);
                let (mut reflected, mut energy) = (0usize, 0.0f64);
                let mut rng = Rng::seeded(9);
                let draws = 100_000;
                for _ in 0..draws {
                    let s = draw(&glass, wo, &mut rng).unwrap();
                    assert!(s.delta);
                    let cos_i = s.wi.dot(n);
                    if cos_i * wo.dot(n) > 0.0 {
                        reflected += 1;
                        assert!((s.weight() - Vec3::ONE).abs().max_element() < 1e-5);
                        energy += 1.0;
                    } else {
                        // Snell: η_i sin θi = η_t sin θt.
                        let sin_t = (1.0 - cos_i * cos_i).max(0.0).sqrt();
                        let sin_o = theta.to_radians().sin();
                        assert!((sin_o - eta * sin_t).abs() < 1e-4, "Snell at {theta}°");
                        assert!((s.eta - eta).abs() < 1e-6);
                        // The path weight is 1/η²; times η² it is the energy moved.
                        let w = s.weight().x * eta * eta;
                        assert!((w - 1.0).abs() < 1e-4, "refraction weight {w}");
                        energy += f64::from(w);
                    }
                }
                assert!((energy / draws as f64 - 1.0).abs() < 1e-4, "R + T");
                let r = reflected as f64 / draws as f64;
                let sigma = (f64::from(f) * (1.0 - f64::from(f)) / draws as f64).sqrt();
                assert!(
                    (r - f64::from(f)).abs() <= 5.0 * sigma + 1e-4,
                    "η {ior}, θ {theta}°, entering {entering}: reflected {r}, F = {f}"
                );
            }
        }
    }
    // Known values of the exact Fresnel equations.
    assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
    assert_eq!(fresnel_dielectric(0.5, 1.0), 0.0);
    // From inside glass of 1.5 the critical angle is asin(1/1.5) = 41.8°.
    assert_eq!(fresnel_dielectric(45f32.to_radians().cos(), 1.0 / 1.5), 1.0);
    assert!(fresnel_dielectric(40f32.to_radians().cos(), 1.0 / 1.5) < 1.0);
    // Brewster's angle, atan(1.5): r_p vanishes, F = r_s²/2.
    let brewster = 1.5f32.atan();
    let (ci, ct) = (
        brewster.cos(),
        (1.0 - (brewster.sin() / 1.5).powi(2)).sqrt(),
    );
    let rs = (ci - 1.5 * ct) / (ci + 1.5 * ct);
    assert!((fresnel_dielectric(ci, 1.5) - 0.5 * rs * rs).abs() < 1e-6);
}

/// Shading normals bent away from the geometric normal never let a reflective
/// surface send light through to its other side.
#[test]
fn bent_shading_normals_do_not_leak() {
    let ng = Vec3::Y;
    let ns = Vec3::new(0.7, 0.5, 0.0).normalize();
    let mut rng = Rng::seeded(10);
    for bsdf in [
        Bsdf::lambert(Vec3::ONE, ns, ng),
        Bsdf::glossy(Vec3::splat(0.5), Vec3::splat(0.5), 0.3, ns, ng),
    ] {
        for _ in 0..20_000 {
            let wo = uniform_sphere(rng.f32(), rng.f32());
            if let Some(s) = draw(&bsdf, wo, &mut rng) {
                assert!(
                    s.wi.dot(ng) * wo.dot(ng) > 0.0,
                    "sample crossed the surface"
                );
            }
            let wi = uniform_sphere(rng.f32(), rng.f32());
            if wi.dot(ng) * wo.dot(ng) < 0.0 {
                assert_eq!(bsdf.eval(wo, wi), Vec3::ZERO);
                assert_eq!(bsdf.pdf(wo, wi), 0.0);
            }
        }
    }
}
