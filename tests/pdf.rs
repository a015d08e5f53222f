//! The densities of `ember::sampling` checked against mathematics: the book's worked
//! Monte Carlo examples, normalisation over the sphere, and histograms of `generate`
//! against `value` (chi-square).

mod common;

use std::f64::consts::PI;

use common::{build, diffuse, quad, Built};
use ember::sampling::{
    CosinePdf, LightPdf, LightSampler, MixturePdf, Onb, Pdf, Rng, UniformSpherePdf,
};
use glam::Vec3;

/// Mean and standard error of `n` draws of `f`.
fn monte_carlo(n: usize, mut f: impl FnMut() -> f64) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let x = f();
        sum += x;
        sum2 += x * x;
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean * mean).max(0.0);
    (mean, (var / n as f64).sqrt())
}

#[test]
fn book_x_squared_with_linear_density() {
    // ∫₀² x² dx = 8/3, sampling p(r) = r/2 by inverting its CDF: r = sqrt(4u).
    let mut rng = Rng::seeded(1);
    let (estimate, sigma) = monte_carlo(200_000, || {
        let r = (4.0 * f64::from(rng.f32())).sqrt();
        if r == 0.0 {
            return 0.0;
        }
        r * r / (r / 2.0)
    });
    assert!(
        (estimate - 8.0 / 3.0).abs() < 4.0 * sigma,
        "{estimate} ± {sigma} vs 8/3"
    );
    assert!(sigma < 0.01);
}

#[test]
fn book_cos_squared_over_the_sphere() {
    // ∫ cos²θ dω = 4π/3 with directions uniform on the sphere, density 1/4π.
    let mut rng = Rng::seeded(2);
    let pdf = UniformSpherePdf;
    let (estimate, sigma) = monte_carlo(200_000, || {
        let d = pdf.generate(&mut rng).unwrap();
        f64::from(d.z * d.z) / f64::from(pdf.value(d))
    });
    assert!(
        (estimate - 4.0 * PI / 3.0).abs() < 4.0 * sigma,
        "{estimate} ± {sigma} vs 4π/3"
    );
}

/// `∫ value dω` over each of `nz × nphi` bins of (cos θ, φ) in the frame around
/// `axis`, by the midpoint rule on `sub × sub` points per bin.
fn bin_integrals(pdf: &impl Pdf, axis: Vec3, nz: usize, nphi: usize, sub: usize) -> Vec<f64> {
    let frame = Onb::from_w(axis);
    let mut out = vec![0.0; nz * nphi];
    let (dz, dphi) = (2.0 / nz as f64, 2.0 * PI / nphi as f64);
    for iz in 0..nz {
        for ip in 0..nphi {
            let mut sum = 0.0;
            for sz in 0..sub {
                for sp in 0..sub {
                    let z = -1.0 + (iz as f64 + (sz as f64 + 0.5) / sub as f64) * dz;
                    let phi = (ip as f64 + (sp as f64 + 0.5) / sub as f64) * dphi;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    let local = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                    sum += f64::from(pdf.value(frame.to_world(local)));
                }
            }
            out[iz * nphi + ip] = sum * dz * dphi / (sub * sub) as f64;
        }
    }
    out
}

/// Draws `n` directions and bins them like [`bin_integrals`]; also returns how many
/// draws were void.
fn histogram(
    pdf: &impl Pdf,
    axis: Vec3,
    nz: usize,
    nphi: usize,
    n: usize,
    seed: u64,
) -> (Vec<f64>, usize) {
    let frame = Onb::from_w(axis);
    let mut rng = Rng::seeded(seed);
    let mut counts = vec![0.0; nz * nphi];
    let mut void = 0;
    for _ in 0..n {
        let Some(d) = pdf.generate(&mut rng) else {
            void += 1;
            continue;
        };
        let l = frame.to_local(d.normalize());
        let iz = (((l.z as f64 + 1.0) / 2.0 * nz as f64) as usize).min(nz - 1);
        let phi = (l.y as f64).atan2(l.x as f64).rem_euclid(2.0 * PI);
        let ip = ((phi / (2.0 * PI) * nphi as f64) as usize).min(nphi - 1);
        counts[iz * nphi + ip] += 1.0;
    }
    (counts, void)
}

/// Pearson's chi-square of observed counts against expected ones, bins with an
/// expectation under 5 pooled into one; returns (statistic, degrees of freedom).
fn chi_square(observed: &[f64], expected: &[f64]) -> (f64, usize) {
    let (mut chi2, mut bins) = (0.0, 0usize);
    let (mut pooled_o, mut pooled_e) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < 5.0 {
            pooled_o += o;
            pooled_e += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            bins += 1;
        }
    }
    if pooled_e >= 5.0 {
        chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
        bins += 1;
    } else {
        assert!(
            pooled_o <= pooled_e + 10.0,
            "{pooled_o} draws where the density is ~0"
        );
    }
    (chi2, bins.saturating_sub(1))
}

/// Checks that `pdf` integrates to `total` and that its draws follow `value`.
fn check_density(name: &str, pdf: &impl Pdf, axis: Vec3, total: f64, seed: u64) {
    let (nz, nphi, n) = (20, 24, 100_000);
    let integrals = bin_integrals(pdf, axis, nz, nphi, 12);
    let integral: f64 = integrals.iter().sum();
    assert!(
        (integral - total).abs() < 0.01,
        "{name}: ∫ value dω = {integral}, expected {total}"
    );
    let (counts, void) = histogram(pdf, axis, nz, nphi, n, seed);
    let expected: Vec<f64> = integrals.iter().map(|p| p * n as f64).collect();
    let (chi2, dof) = chi_square(&counts, &expected);
    // About five standard deviations above the mean of the chi-square distribution.
    let limit = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
    eprintln!("{name}: chi2 {chi2:.1} dof {dof} integral {integral:.5} void {void}");
    assert!(
        chi2 < limit,
        "{name}: chi-square {chi2:.1} over {dof} dof (limit {limit:.1})"
    );
    // The void draws are the mass missing from the integral.
    let p_void = 1.0 - total;
    let sigma = (n as f64 * p_void.max(1e-3) * (1.0 - p_void)).sqrt();
    assert!(
        (void as f64 - n as f64 * p_void).abs() < 5.0 * sigma + 0.005 * n as f64,
        "{name}: {void} void draws, expected {}",
        n as f64 * p_void
    );
}

/// A shading point at the origin under a big emissive quad (facing down, Ke 1) and
/// beside a brighter emissive triangle (facing −x, Ke 4); optionally an occluder
/// between the point and the quad and a light that faces away.
fn light_scene(occluded: bool) -> Built {
    let y = 0.6;
    let mut tris: Vec<([Vec3; 3], u32)> = quad(
        Vec3::new(-1.0, y, -1.0),
        Vec3::new(1.0, y, -1.0),
        Vec3::new(1.0, y, 1.0),
        Vec3::new(-1.0, y, 1.0),
        0,
    )
    .to_vec();
    tris.push((
        [
            Vec3::new(0.8, -0.5, -0.5),
            Vec3::new(0.8, -0.5, 0.5),
            Vec3::new(0.8, 0.5, 0.0),
        ],
        1,
    ));
    if occluded {
        // A grey square half way to the quad, and a light below facing away.
        tris.extend(quad(
            Vec3::new(-0.2, 0.3, -0.2),
            Vec3::new(-0.2, 0.3, 0.2),
            Vec3::new(0.2, 0.3, 0.2),
            Vec3::new(0.2, 0.3, -0.2),
            2,
        ));
        tris.push((
            [
                Vec3::new(-0.5, -0.7, -0.5),
                Vec3::new(0.5, -0.7, -0.5),
                Vec3::new(0.0, -0.7, 0.5),
            ],
            1,
        ));
    }
    build(
        &tris,
        vec![
            diffuse(Vec3::splat(0.5), Vec3::ONE),
            diffuse(Vec3::splat(0.5), Vec3::splat(4.0)),
            diffuse(Vec3::splat(0.5), Vec3::ZERO),
        ],
    )
}

fn light_pdf<'a>(
    built: &'a Built,
    lights: &'a LightSampler,
) -> LightPdf<'a, ember::accel::EmbreeAccel> {
    LightPdf {
        origin: Vec3::ZERO,
        lights,
        scene: &built.scene,
        accel: &built.accel,
    }
}

#[test]
fn cosine_density_is_normalised_and_matches_its_draws() {
    let normal = Vec3::new(0.3, 0.5, -0.8).normalize();
    check_density("cosine", &CosinePdf::new(normal), Vec3::Y, 1.0, 10);
    // Binned around its own normal, the histogram is the textbook cos θ / π one.
    check_density(
        "cosine (own frame)",
        &CosinePdf::new(normal),
        normal,
        1.0,
        11,
    );
}

#[test]
fn uniform_sphere_density_is_normalised_and_matches_its_draws() {
    check_density("uniform", &UniformSpherePdf, Vec3::Z, 1.0, 12);
}

#[test]
fn light_density_is_normalised_and_matches_its_draws() {
    let built = light_scene(false);
    let lights = LightSampler::new(&built.scene);
    assert_eq!(lights.len(), 3);
    check_density("light", &light_pdf(&built, &lights), Vec3::Y, 1.0, 13);
}

#[test]
fn mixture_density_is_normalised_and_matches_its_draws() {
    let built = light_scene(false);
    let lights = LightSampler::new(&built.scene);
    let mixture = MixturePdf::even(
        CosinePdf::new(Vec3::new(0.2, 1.0, 0.1).normalize()),
        light_pdf(&built, &lights),
    );
    check_density("mixture", &mixture, Vec3::Y, 1.0, 14);
    let uneven = MixturePdf {
        first: CosinePdf::new(-Vec3::X),
        second: light_pdf(&built, &lights),
        weight: 0.2,
    };
    check_density("mixture 0.2/0.8", &uneven, Vec3::Y, 1.0, 15);
}

#[test]
fn light_power_weighting_is_area_times_luminance() {
    let built = light_scene(false);
    let lights = LightSampler::new(&built.scene);
    // Quad: area 4, Ke 1 → 4; triangle: area 0.5, Ke 4 → 2. Densities per unit area:
    // P / A = (4/6)/4 and (2/6)/0.5.
    let quad_density = lights.area_density(0);
    let tri_density = lights.area_density(2);
    assert!((quad_density - 1.0 / 6.0).abs() < 1e-5, "{quad_density}");
    assert!((tri_density - 2.0 / 3.0).abs() < 1e-5, "{tri_density}");
    assert_eq!(lights.area_density(7), 0.0);
}

#[test]
fn hidden_lights_make_void_draws_and_value_still_matches() {
    let built = light_scene(true);
    let lights = LightSampler::new(&built.scene);
    let pdf = light_pdf(&built, &lights);
    // Integral = 1 − P(void); estimate it by quadrature, then check draws against it.
    let integral: f64 = bin_integrals(&pdf, Vec3::Y, 20, 24, 12).iter().sum();
    assert!(
        integral < 0.95,
        "occluder and back-facing light should hide mass"
    );
    check_density("light (occluded)", &pdf, Vec3::Y, integral, 16);
}

#[test]
fn light_value_equals_the_density_of_the_draw() {
    for occluded in [false, true] {
        let built = light_scene(occluded);
        let lights = LightSampler::new(&built.scene);
        let pdf = light_pdf(&built, &lights);
        let mut rng = Rng::seeded(17);
        let mut produced = 0;
        for _ in 0..20_000 {
            if let Some((dir, p)) = pdf.generate_with_pdf(&mut rng) {
                let v = pdf.value(dir);
                assert!(
                    (v - p).abs() <= 1e-3 * p,
                    "value {v} vs generator density {p}"
                );
                produced += 1;
            }
        }
        assert!(produced > 10_000);
    }
}

/// `may_light` may only say "no" for points behind every emitter: for random emitters
/// whose normals lie in a cone, and random points, a point it culls has
/// `(p − q) · n ≤ 0` for every vertex `q` of every emitter (and so, by linearity, for
/// every point of every emitter).
#[test]
fn light_culling_never_skips_a_lit_point() {
    let mut rng = Rng::seeded(77);
    for spread in [0.0f32, 0.3, 0.9] {
        let mut triangles = Vec::new();
        for _ in 0..6 {
            let center = Vec3::new(rng.f32(), 2.0 + rng.f32(), rng.f32());
            // A normal near -y, tilted by up to `spread` radians.
            let tilt = Vec3::new(rng.f32() - 0.5, 0.0, rng.f32() - 0.5) * 2.0 * spread.tan();
            let n = (-Vec3::Y + tilt).normalize();
            let onb = ember::sampling::Onb::from_w(n);
            // Counter-clockwise around n.
            let verts =
                [0.0f32, 2.1, 4.2].map(|a| center + 0.2 * (a.cos() * onb.u + a.sin() * onb.v));
            triangles.push((verts, 0));
        }
        let built = build(&triangles, vec![diffuse(Vec3::splat(0.5), Vec3::ONE)]);
        let lights = LightSampler::new(&built.scene);
        let mut culled = 0;
        for _ in 0..20_000 {
            let p = Vec3::new(
                rng.f32() * 6.0 - 3.0,
                rng.f32() * 6.0 - 1.0,
                rng.f32() * 6.0 - 3.0,
            );
            if lights.may_light(p) {
                continue;
            }
            culled += 1;
            for (verts, _) in &triangles {
                let n = (verts[1] - verts[0]).cross(verts[2] - verts[0]).normalize();
                for q in verts {
                    assert!(
                        (p - *q).dot(n) <= 1e-5,
                        "culled {p} is in front of an emitter"
                    );
                }
            }
        }
        // The test is not vacuous: points above the lights are culled (fewer as the
        // normals spread and the cone widens).
        let expected = if spread < 0.5 { 1000 } else { 1 };
        assert!(
            culled >= expected,
            "only {culled} points culled with spread {spread}"
        );
        assert!(!lights.may_light(Vec3::new(0.5, 10.0, 0.5)));
        assert!(lights.may_light(Vec3::new(0.5, -1.0, 0.5)));
    }
}
