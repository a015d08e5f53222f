//! Statistical checks of densities over directions: quadrature of a density over bins
//! of (cos θ, φ), histograms of draws, and Pearson's chi-square between the two.

use std::f64::consts::PI;

use ember::sampling::{Onb, Rng};
use glam::{DVec3, Vec3};

/// Mean and standard error of `n` draws of `f`.
pub fn monte_carlo(n: usize, mut f: impl FnMut() -> f64) -> (f64, f64) {
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

/// A density over unit directions to check: its value per steradian, and a sampler
/// (`None` for a void draw).
pub struct Density<'a> {
    pub value: &'a dyn Fn(Vec3) -> f32,
    pub draw: &'a dyn Fn(&mut Rng) -> Option<Vec3>,
}

/// `∫ value dω` over each of `nz × nphi` bins of (cos θ, φ) in the frame around
/// `axis`, by the midpoint rule on `sub × sub` points per bin.
pub fn bin_integrals(
    value: &dyn Fn(Vec3) -> f32,
    axis: Vec3,
    nz: usize,
    nphi: usize,
    sub: usize,
) -> Vec<f64> {
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
                    sum += f64::from(value(frame.to_world(local)));
                }
            }
            out[iz * nphi + ip] = sum * dz * dphi / (sub * sub) as f64;
        }
    }
    out
}

/// Draws `n` directions and bins them like [`bin_integrals`]; also returns how many
/// draws were void.
pub fn histogram(
    draw: &dyn Fn(&mut Rng) -> Option<Vec3>,
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
        let Some(d) = draw(&mut rng) else {
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
pub fn chi_square(observed: &[f64], expected: &[f64]) -> (f64, usize) {
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

/// Asserts that `observed` counts fit `expected` ones: Pearson's chi-square below
/// about five standard deviations above its mean.
pub fn assert_chi_square(name: &str, observed: &[f64], expected: &[f64]) {
    let (chi2, dof) = chi_square(observed, expected);
    let limit = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
    eprintln!("{name}: chi2 {chi2:.1} dof {dof}");
    assert!(
        chi2 < limit,
        "{name}: chi-square {chi2:.1} over {dof} dof (limit {limit:.1})"
    );
}

/// How finely [`check_density`] bins and integrates.
#[derive(Clone, Copy, Debug)]
pub struct Binning {
    pub nz: usize,
    pub nphi: usize,
    /// Quadrature points per bin and axis.
    pub sub: usize,
    pub draws: usize,
}

impl Default for Binning {
    fn default() -> Self {
        Binning {
            nz: 20,
            nphi: 24,
            sub: 12,
            draws: 100_000,
        }
    }
}

/// Checks that the density integrates to `total` (within `tolerance`), that its draws
/// follow its value (chi-square), and that the void draws are the missing mass.
pub fn check_density(
    name: &str,
    density: &Density<'_>,
    axis: Vec3,
    total: f64,
    tolerance: f64,
    binning: Binning,
    seed: u64,
) {
    let Binning {
        nz,
        nphi,
        sub,
        draws: n,
    } = binning;
    let integrals = bin_integrals(density.value, axis, nz, nphi, sub);
    let integral: f64 = integrals.iter().sum();
    assert!(
        (integral - total).abs() < tolerance,
        "{name}: ∫ value dω = {integral}, expected {total}"
    );
    let (counts, void) = histogram(density.draw, axis, nz, nphi, n, seed);
    let expected: Vec<f64> = integrals.iter().map(|p| p * n as f64).collect();
    eprintln!("{name}: integral {integral:.5} void {void}");
    assert_chi_square(name, &counts, &expected);
    // The void draws are the mass missing from the integral.
    let p_void = 1.0 - total;
    let sigma = (n as f64 * p_void.max(1e-3) * (1.0 - p_void)).sqrt();
    assert!(
        (void as f64 - n as f64 * p_void).abs() < 5.0 * sigma + 0.005 * n as f64,
        "{name}: {void} void draws, expected {}",
        n as f64 * p_void
    );
}

/// The radiance along every ray in a closed furnace whose surfaces emit `le` and
/// reflect with albedo `albedo`, for paths of at most `max_depth` segments.
pub fn furnace_radiance(le: Vec3, albedo: f32, max_depth: u32) -> DVec3 {
    let terms: f64 = (0..max_depth)
        .map(|k| f64::from(albedo).powi(k as i32))
        .sum();
    le.as_dvec3() * terms
}

/// Sums of samples of a radiance, and their count.
#[derive(Default)]
pub struct SampleSums {
    pub sum: DVec3,
    pub sum_sq: DVec3,
    pub n: f64,
}

impl SampleSums {
    pub fn add(&mut self, l: Vec3) {
        let l = l.as_dvec3();
        (self.sum, self.sum_sq, self.n) = (self.sum + l, self.sum_sq + l * l, self.n + 1.0);
    }

    /// The samples' mean and its standard error.
    pub fn mean_and_error(&self) -> (DVec3, DVec3) {
        let mean = self.sum / self.n;
        let sigma = ((self.sum_sq / self.n - mean * mean).max(DVec3::ZERO) / self.n).powf(0.5);
        (mean, sigma)
    }

    /// Asserts that the samples' mean is `truth` within four standard errors, in
    /// every channel.
    pub fn assert_mean(&self, label: &str, truth: DVec3) {
        let (mean, sigma) = self.mean_and_error();
        eprintln!("{label}: {mean} ± {sigma}, expected {truth}");
        for c in 0..3 {
            assert!(
                (mean[c] - truth[c]).abs() <= 4.0 * sigma[c] + 1e-4 * truth[c],
                "{label}, channel {c}: {} ± {}, expected {}",
                mean[c],
                sigma[c],
                truth[c]
            );
        }
    }
}
