//! Checks every reflective BSDF must pass, for one BSDF and one `wo` at a time: its draws
//! follow `pdf` (chi-square), `pdf` integrates to the fraction of draws that yield a
//! direction, `sample` returns exactly `eval` and `pdf`, and `f` is reciprocal.

use std::f64::consts::PI;

use ember::bsdf::{Bsdf, BsdfSample};
use ember::sampling::{uniform_sphere, Onb, Rng};
use glam::{DVec3, Vec2, Vec3};

use super::stats::{check_density, monte_carlo, Binning, Density};

/// A unit direction at polar angle `theta` (degrees) and azimuth `phi` (radians)
/// around `normal`.
pub fn direction(normal: Vec3, theta: f32, phi: f32) -> Vec3 {
    let t = theta.to_radians();
    Onb::from_w(normal).to_world(Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos()))
}

/// A tilted normal, not along any axis, so frames are exercised in general position.
pub fn tilted_normal() -> Vec3 {
    Vec3::new(0.3, 0.9, -0.2).normalize()
}

pub fn draw(bsdf: &Bsdf, wo: Vec3, rng: &mut Rng) -> Option<BsdfSample> {
    let (u1, u2) = rng.pair();
    bsdf.sample(wo, Vec2::new(u1, u2))
}

/// Directional albedo `∫ f cos dωi`, as the mean sample weight, with its standard error.
pub fn albedo(bsdf: &Bsdf, wo: Vec3, n: usize, seed: u64) -> (Vec3, f32) {
    let mut rng = Rng::seeded(seed);
    let (mut sum, mut sum2) = (DVec3::ZERO, 0.0f64);
    for _ in 0..n {
        if let Some(s) = draw(bsdf, wo, &mut rng) {
            let w = s.weight().as_dvec3();
            sum += w;
            sum2 += w.max_element().powi(2);
        }
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean.max_element().powi(2)).max(0.0);
    (mean.as_vec3(), (var / n as f64).sqrt() as f32)
}

/// Chi-square of the directions drawn for `wo` against `pdf`, whose integral (by
/// quadrature) must equal the fraction of draws that yield a direction.
pub fn assert_draws_follow_pdf(label: &str, bsdf: &Bsdf, n: Vec3, wo: Vec3, seed: u64) {
    assert_draws_follow_pdf_about(label, bsdf, n, wo, seed);
}

/// [`assert_draws_follow_pdf`] with bins of (cos θ, φ) about `axis`: about a direction
/// across the normal, the lobes near the normal and its opposite (where refraction
/// sends light seen head-on) lie where the bins are finest.
pub fn assert_draws_follow_pdf_about(label: &str, bsdf: &Bsdf, axis: Vec3, wo: Vec3, seed: u64) {
    let value = |wi: Vec3| bsdf.pdf(wo, wi);
    let sampler = |rng: &mut Rng| draw(bsdf, wo, rng).map(|s| s.wi);
    // The fraction of draws that yield a direction, measured apart.
    let mut rng = Rng::seeded(seed + 1);
    let kept = (0..200_000)
        .filter(|_| draw(bsdf, wo, &mut rng).is_some())
        .count() as f64
        / 200_000.0;
    let density = Density {
        value: &value,
        draw: &sampler,
    };
    let binning = Binning {
        nz: 40,
        nphi: 32,
        // Fine enough for the narrow grazing lobes (α = 0.1 at 85°).
        sub: 24,
        draws: 200_000,
    };
    check_density(label, &density, axis, kept, 0.01, binning, seed);
}

/// [`assert_draws_follow_pdf`] for every named lobe, at every polar angle of `wo` in
/// `thetas` (degrees), from both sides of the two-sided surface of normal `n`.
pub fn assert_every_lobe_draws_by_its_pdf(
    lobes: &[(String, Bsdf)],
    n: Vec3,
    thetas: &[f32],
    seed: u64,
) {
    let mut seed = seed;
    for (name, bsdf) in lobes {
        for &theta in thetas {
            for side in [1.0f32, -1.0] {
                let wo = side * direction(n, theta, 0.7);
                let label = format!("{name}, θo = {theta}°, side {side}");
                assert_draws_follow_pdf(&label, bsdf, n, wo, seed);
                seed += 2;
            }
        }
    }
}

/// `∫ pdf dω` by Monte Carlo over uniform directions equals the fraction of draws that
/// yield a direction; returns the fraction that fails.
pub fn assert_pdf_integrates_to_the_kept_draws(label: &str, bsdf: &Bsdf, wo: Vec3) -> f64 {
    let mut rng = Rng::seeded(7);
    let (integral, sigma) = monte_carlo(1_000_000, || {
        let (u1, u2) = rng.pair();
        f64::from(bsdf.pdf(wo, uniform_sphere(u1, u2))) * 4.0 * PI
    });
    let failed = (0..200_000)
        .filter(|_| draw(bsdf, wo, &mut rng).is_none())
        .count() as f64
        / 200_000.0;
    let expected = 1.0 - failed;
    assert!(
        (integral - expected).abs() < 5.0 * sigma + 0.005,
        "{label}: ∫ pdf = {integral} ± {sigma}, expected {expected}"
    );
    failed
}

/// What `sample` returns for `wo` is exactly what `eval` and `pdf` say of its direction.
pub fn assert_sample_agrees_with_eval_and_pdf(label: &str, bsdf: &Bsdf, wo: Vec3, rng: &mut Rng) {
    for _ in 0..2000 {
        let Some(s) = draw(bsdf, wo, rng) else {
            continue;
        };
        assert!(!s.delta, "{label}");
        assert_eq!(s.value, bsdf.eval(wo, s.wi), "{label}");
        assert_eq!(s.pdf, bsdf.pdf(wo, s.wi), "{label}");
        assert!(s.pdf > 0.0 && (s.wi.length() - 1.0).abs() < 1e-5, "{label}");
    }
}

/// `f(wo, wi) = f(wi, wo)`, where `f = eval / |cos θi|`, over random pairs of
/// directions around the normal `n`; at least 1000 of them non-zero.
pub fn assert_reciprocal(label: &str, bsdf: &Bsdf, n: Vec3, rng: &mut Rng) {
    let mut compared = 0;
    for _ in 0..5000 {
        let a = uniform_sphere(rng.f32(), rng.f32());
        let b = uniform_sphere(rng.f32(), rng.f32());
        let (ca, cb) = (a.dot(n).abs(), b.dot(n).abs());
        if ca < 1e-3 || cb < 1e-3 {
            continue;
        }
        let f_ab = bsdf.eval(a, b) / cb;
        let f_ba = bsdf.eval(b, a) / ca;
        let scale = f_ab.max_element().max(f_ba.max_element());
        assert!(
            (f_ab - f_ba).abs().max_element() <= 1e-4 * scale + 1e-7,
            "{label}: f({a}, {b}) = {f_ab} but f({b}, {a}) = {f_ba}"
        );
        compared += usize::from(scale > 0.0);
    }
    assert!(compared > 1000, "{label}: only {compared} non-zero pairs");
}
