//! GGX's directional albedo with Fresnel 1, `E(μ, α) = ∫ D G1(wo) G1(wi) / (4 μ) dωi`
//! for `wo` at `cos θo = μ`, and its cosine-weighted mean `E_avg(α) = 2 ∫ E(μ) μ dμ`:
//! what single scattering keeps of the light, and what energy compensation adds back.
//!
//! The masking is ember's separable Smith `G1(wo) G1(wi)` ([`Ggx`]), so the table
//! matches the lobe it compensates. It is built at first use by the midpoint rule in
//! `(x, φ)` with `x = tan²θh / (α² + tan²θh)`, over which GGX's normalisation makes
//! `D cos θh dωh = dx dφ / 2π`: with `dωi = 4 (wo·h) dωh` the integrand becomes the smooth
//! `G1(wo) G1(wi) (wo·h) / (μ cos θh)`, zero where `wi` falls below the surface.
//!
//! Rows are `r = √α` from 0 to 1 (α = 0 is a mirror: `E ≡ 1`), columns are cells of
//! `μ` centred at `(i + ½)/N`; lookups interpolate bilinearly and clamp at the ends.
//! `E_avg` is the exact integral of each row's interpolant, so the compensation lobe
//! built from both integrates to exactly `1 − E(μ)` over the hemisphere.

use std::sync::LazyLock;

use glam::DVec3;

use super::Ggx;

/// Cells of `μ` and rows of `√α`.
const N_MU: usize = 32;
const N_ROUGHNESS: usize = 32;
/// Midpoints per axis of the quadrature in `(x, φ)` (φ over half the circle: the
/// integrand is symmetric about the plane of `wo`).
const N_X: usize = 128;
const N_PHI: usize = 48;

struct Table {
    /// `E` at row `j` (r = j / (N_ROUGHNESS − 1)), column `i` (μ = (i + ½) / N_MU).
    e: [[f32; N_MU]; N_ROUGHNESS],
    /// `E_avg` of each row's interpolant.
    e_avg: [f32; N_ROUGHNESS],
}

static TABLE: LazyLock<Table> = LazyLock::new(Table::build);

/// `E(μ, α)`: the fraction of light arriving at `cos θ = μ` that GGX of roughness `α`
/// reflects in one scattering (Fresnel 1).
#[inline]
pub fn directional_albedo(mu: f32, alpha: f32) -> f32 {
    let table = &*TABLE;
    let (j, t) = row(alpha);
    let at = |j: usize| row_value(&table.e[j], mu);
    at(j) * (1.0 - t) + at((j + 1).min(N_ROUGHNESS - 1)) * t
}

/// `E_avg(α) = 2 ∫ E(μ, α) μ dμ`: the albedo of GGX under uniform light.
#[inline]
pub fn average_albedo(alpha: f32) -> f32 {
    let table = &*TABLE;
    let (j, t) = row(alpha);
    table.e_avg[j] * (1.0 - t) + table.e_avg[(j + 1).min(N_ROUGHNESS - 1)] * t
}

/// The row below `√α` and the weight of the row above.
#[inline]
fn row(alpha: f32) -> (usize, f32) {
    let s = alpha.clamp(0.0, 1.0).sqrt() * (N_ROUGHNESS - 1) as f32;
    let j = (s as usize).min(N_ROUGHNESS - 2);
    (j, s - j as f32)
}

/// One row's value at `μ`, linear between cell centres and constant past the end ones.
#[inline]
fn row_value(e: &[f32; N_MU], mu: f32) -> f32 {
    let s = (mu * N_MU as f32 - 0.5).clamp(0.0, (N_MU - 1) as f32);
    let i = (s as usize).min(N_MU - 2);
    let t = s - i as f32;
    e[i] * (1.0 - t) + e[i + 1] * t
}

impl Table {
    fn build() -> Table {
        let mut e = [[1.0f32; N_MU]; N_ROUGHNESS];
        for (j, row) in e.iter_mut().enumerate().skip(1) {
            let r = j as f64 / (N_ROUGHNESS - 1) as f64;
            for (i, cell) in row.iter_mut().enumerate() {
                let mu = (i as f64 + 0.5) / N_MU as f64;
                *cell = albedo_by_quadrature(mu, r * r, N_X, N_PHI) as f32;
            }
        }
        let e_avg = std::array::from_fn(|j| {
            // The interpolant is piecewise linear: a fine midpoint rule is exact enough.
            let n = 4096;
            let sum: f64 = (0..n)
                .map(|k| {
                    let mu = (k as f64 + 0.5) / n as f64;
                    f64::from(row_value(&e[j], mu as f32)) * mu
                })
                .sum();
            (2.0 * sum / n as f64) as f32
        });
        Table { e, e_avg }
    }
}

/// `E(μ, α)` by the quadrature in the module documentation, on `nx × nphi` midpoints.
fn albedo_by_quadrature(mu: f64, alpha: f64, nx: usize, nphi: usize) -> f64 {
    let ggx = Ggx::new(alpha as f32);
    let g1 = |w: DVec3| f64::from(ggx.g1(w.as_vec3()));
    let wo = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let g1_wo = g1(wo);
    let mut sum = 0.0;
    for ix in 0..nx {
        let x = (ix as f64 + 0.5) / nx as f64;
        let tan_h = alpha * (x / (1.0 - x)).sqrt();
        let cos_h = 1.0 / (1.0 + tan_h * tan_h).sqrt();
        let sin_h = tan_h * cos_h;
        for ip in 0..nphi {
            let phi = (ip as f64 + 0.5) / nphi as f64 * std::f64::consts::PI;
            let h = DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
            let wo_h = wo.dot(h);
            let wi = 2.0 * wo_h * h - wo;
            if wo_h > 0.0 && wi.z > 0.0 {
                sum += g1_wo * g1(wi) * wo_h / (mu * cos_h);
            }
        }
    }
    sum / (nx * nphi) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_a_finer_quadrature_between_its_nodes() {
        for (mu, alpha) in [
            (0.9, 0.25),
            (0.5, 0.5),
            (0.2, 1.0),
            (0.05, 0.7),
            (0.7, 0.05),
        ] {
            let table = f64::from(directional_albedo(mu as f32, alpha as f32));
            // Sixteen times finer on each axis than the table was built with.
            let truth = albedo_by_quadrature(mu, alpha, 16 * N_X, 16 * N_PHI);
            assert!(
                (table - truth).abs() < 3e-3,
                "E({mu}, {alpha}): table {table}, quadrature {truth}"
            );
        }
    }

    #[test]
    fn smooth_surfaces_keep_everything_and_rougher_ones_lose_more() {
        assert_eq!(directional_albedo(0.5, 0.0), 1.0);
        assert_eq!(average_albedo(0.0), 1.0);
        let mut previous = 1.0;
        for r in 1..=10 {
            let alpha = (r as f32 / 10.0).powi(2);
            let avg = average_albedo(alpha);
            assert!(avg < previous && avg > 0.3, "E_avg({alpha}) = {avg}");
            previous = avg;
        }
    }
}
