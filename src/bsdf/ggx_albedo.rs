//! GGX's directional albedo, `E(μ, α) = ∫ F D G1(wo) G1(wi) / (4 μ) dωi` for `wo` at
//! `cos θo = μ`, and its cosine-weighted mean `E_avg(α) = 2 ∫ E(μ) μ dμ`, for the two
//! Fresnel factors Schlick's approximation is made of: 1 and `(1 − wo·h)⁵`. With them the
//! albedo of a Schlick layer of any `F0` is `F0 E₁ + (1 − F0) E₅`: what single scattering
//! keeps of the light, and what energy compensation and layering need.
//!
//! The masking is ember's separable Smith `G1(wo) G1(wi)` ([`Ggx`]), so the table
//! matches the lobe it serves. `scripts/ggx_albedo_table.py` computes it
//! (`ggx_albedo_table.rs`) as the mean of `G1(wi)` (times `(1 − wo·h)⁵`) over a fine grid
//! of visible normals drawn as [`Ggx::sample_visible_normal`] draws them: a quadrature
//! accurate at grazing angles too, too slow to run at first use.
//!
//! Rows are `r = √α` from 0 to 1 (α = 0 is a mirror: `E₁ ≡ 1`, `E₅ = (1 − μ)⁵`), columns
//! `√μ` from 0 to 1 (fine near grazing, where narrow lobes change fastest); lookups
//! interpolate linearly in both. The means are exact integrals
//! of each row's interpolant, computed at first use, so a lobe shaped
//! `(1 − E(μo)) (1 − E(μi))` integrates to exactly `(1 − E(μo)) (1 − E_avg)`.

use std::sync::LazyLock;

use glam::Vec3;

use super::ggx_albedo_table::{CELLS, N_MU, N_ROUGHNESS};
#[cfg(doc)]
use super::Ggx;

/// GGX's albedos at one `μ` (or their means) for Fresnel ≡ 1 and ≡ `(1 − wo·h)⁵`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Albedo {
    /// With Fresnel 1.
    pub one: f32,
    /// With Fresnel `(1 − wo·h)⁵`.
    pub edge: f32,
}

impl Albedo {
    /// The albedo with Schlick's Fresnel from `f0`.
    #[inline]
    pub fn schlick(&self, f0: Vec3) -> Vec3 {
        f0 * self.one + (Vec3::ONE - f0) * self.edge
    }

    fn from_cell([one, edge]: [f32; 2]) -> Albedo {
        Albedo { one, edge }
    }

    #[inline]
    fn lerp(self, other: Albedo, t: f32) -> Albedo {
        Albedo {
            one: self.one + (other.one - self.one) * t,
            edge: self.edge + (other.edge - self.edge) * t,
        }
    }
}

/// The mean of each row's interpolant.
static MEANS: LazyLock<[Albedo; N_ROUGHNESS]> = LazyLock::new(row_means);

/// `E(μ, α)`: what GGX of roughness `α` reflects in one scattering of the light arriving
/// at `cos θ = μ`.
#[inline]
pub fn directional_albedo(mu: f32, alpha: f32) -> Albedo {
    let (j, t) = row(alpha);
    let at = |j: usize| row_value(&CELLS[j], mu);
    at(j).lerp(at(j + 1), t)
}

/// `E_avg(α) = 2 ∫ E(μ, α) μ dμ`: what GGX reflects in one scattering of uniform light.
#[inline]
pub fn average_albedo(alpha: f32) -> Albedo {
    let means = &*MEANS;
    let (j, t) = row(alpha);
    means[j].lerp(means[j + 1], t)
}

/// The row below `√α` and the weight of the row above.
#[inline]
fn row(alpha: f32) -> (usize, f32) {
    let s = alpha.clamp(0.0, 1.0).sqrt() * (N_ROUGHNESS - 1) as f32;
    let j = (s as usize).min(N_ROUGHNESS - 2);
    (j, s - j as f32)
}

/// One row's value at `μ`, linear in `√μ` between nodes.
#[inline]
fn row_value(cells: &[[f32; 2]; N_MU], mu: f32) -> Albedo {
    let s = mu.clamp(0.0, 1.0).sqrt() * (N_MU - 1) as f32;
    let i = (s as usize).min(N_MU - 2);
    Albedo::from_cell(cells[i]).lerp(Albedo::from_cell(cells[i + 1]), s - i as f32)
}

/// `2 ∫ E(μ) μ dμ` of each row's interpolant: piecewise smooth, so a fine midpoint
/// rule is exact enough.
fn row_means() -> [Albedo; N_ROUGHNESS] {
    std::array::from_fn(|j| {
        let n = 8192;
        let (mut one, mut edge) = (0.0f64, 0.0f64);
        for k in 0..n {
            let mu = (k as f64 + 0.5) / n as f64;
            let a = row_value(&CELLS[j], mu as f32);
            one += f64::from(a.one) * mu;
            edge += f64::from(a.edge) * mu;
        }
        let mean = |sum: f64| (2.0 * sum / n as f64) as f32;
        Albedo {
            one: mean(one),
            edge: mean(edge),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{reflect, Ggx};
    use glam::Vec2;

    /// `(E₁, E₅)` as the mean over an `n × n` grid of visible normals drawn by ember's
    /// own sampler: the table must describe the lobe ember evaluates.
    fn by_visible_normals(mu: f32, alpha: f32, n: usize) -> (f64, f64) {
        let ggx = Ggx::new(alpha);
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let (mut one, mut edge) = (0.0f64, 0.0f64);
        for a in 0..n {
            for b in 0..n {
                let u = Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                let h = ggx.sample_visible_normal(wo, u);
                let wi = reflect(wo, h);
                if wi.z > 0.0 {
                    let g = f64::from(ggx.g1(wi));
                    one += g;
                    edge += g * f64::from(1.0 - wo.dot(h).clamp(0.0, 1.0)).powi(5);
                }
            }
        }
        let cells = (n * n) as f64;
        (one / cells, edge / cells)
    }

    #[test]
    fn table_matches_a_quadrature_of_embers_ggx() {
        // On nodes (row, column) and between them.
        let node = |j: usize, i: usize| {
            let r = j as f32 / (N_ROUGHNESS - 1) as f32;
            let root = i as f32 / (N_MU - 1) as f32;
            (root * root, r * r)
        };
        let cases = [
            node(3, 2),
            node(9, 8),
            node(16, 30),
            node(31, 1),
            node(31, 63),
            (0.5, 0.5),
            (0.2, 1.0),
            (0.05, 0.7),
            (0.7, 0.05),
            (0.0175, 0.09),
        ];
        for (mu, alpha) in cases {
            let table = directional_albedo(mu, alpha);
            let (one, edge) = by_visible_normals(mu, alpha, 400);
            eprintln!("E({mu}, {alpha}): table {table:?}, quadrature {one}, {edge}");
            assert!(
                (f64::from(table.one) - one).abs() < 4e-3
                    && (f64::from(table.edge) - edge).abs() < 4e-3,
                "E({mu}, {alpha}): table {table:?}, quadrature {one}, {edge}"
            );
        }
    }
    #[test]
    fn smooth_surfaces_keep_everything_and_rougher_ones_lose_more() {
        assert_eq!(directional_albedo(0.5, 0.0).one, 1.0);
        assert!((directional_albedo(0.5, 0.0).edge - 0.5f32.powi(5)).abs() < 1e-3);
        assert_eq!(average_albedo(0.0).one, 1.0);
        // Schlick's mean over the hemisphere, 2 ∫ (1 − μ)⁵ μ dμ = 1/21.
        assert!((average_albedo(0.0).edge - 1.0 / 21.0).abs() < 1e-4);
        let mut previous = 1.0;
        for r in 1..=10 {
            let alpha = (r as f32 / 10.0).powi(2);
            let avg = average_albedo(alpha).one;
            assert!(avg < previous && avg > 0.3, "E_avg({alpha}) = {avg}");
            previous = avg;
        }
    }
}
