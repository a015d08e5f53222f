//! The rough clear glass's directional albedo in one scattering, `E(μ, α, η)`: the
//! energy that GGX reflection and Walter et al.'s refraction through the same facets
//! (exact Fresnel, ember's separable Smith masking) send out of light arriving at
//! `cos θ = μ` on the side where the relative index across the interface is `η`
//! (`ior` entering the glass, `1/ior` leaving it), the refracted light's `1/η²` taken
//! out. What it lacks of 1 is what single scattering loses: light sent into the
//! surface, or out of its facets' view, which would leave after more bounces.
//!
//! The metallic-roughness glass divides its lobe by it, as Turquin ("Practical
//! multiple scattering compensation for microfacet models", 2019) and Cycles'
//! Principled BSDF do for glass: a clear glass then keeps all the light, from either
//! side, and the lobe's shape and density stay single scattering's.
//!
//! `scripts/glass_albedo_table.py` computes it (`glass_albedo_table.rs`) as a mean over
//! a grid of visible normals drawn as [`Ggx::sample_visible_normal`] draws them, for
//! each side on a grid of `√μ`, `√α` (α = 0 is smooth glass, which keeps everything) and
//! `(ior − 1)/(ior + 1)` from index 1 to 4; lookups interpolate linearly in the three
//! and hold the nearest value beyond (an index above 4 reads 4's).

use super::glass_albedo_table::{CELLS, IOR_STEP, N_IOR, N_MU, N_ROUGHNESS};
#[cfg(doc)]
use super::Ggx;

/// `E(μ, α, η)`: what a rough clear glass of roughness `alpha` sends out, reflected and
/// refracted, in one scattering of the light arriving at `cos θ = mu` where the relative
/// index across the interface is `eta` (> 1 entering the denser side, < 1 leaving it).
#[inline]
pub fn glass_albedo(mu: f32, alpha: f32, eta: f32) -> f32 {
    let (side, ior) = if eta >= 1.0 {
        (&CELLS[0], eta)
    } else {
        (&CELLS[1], 1.0 / eta)
    };
    let (k, tk) = node((ior - 1.0) / (ior + 1.0) / IOR_STEP, N_IOR);
    let (j, tj) = node(
        alpha.clamp(0.0, 1.0).sqrt() * (N_ROUGHNESS - 1) as f32,
        N_ROUGHNESS,
    );
    let (i, ti) = node(mu.clamp(0.0, 1.0).sqrt() * (N_MU - 1) as f32, N_MU);
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let at_row = |row: &[f32; N_MU]| lerp(row[i], row[i + 1], ti);
    let at_plane = |k: usize| lerp(at_row(&side[k][j]), at_row(&side[k][j + 1]), tj);
    lerp(at_plane(k), at_plane(k + 1), tk)
}

/// The node below the grid coordinate `s` (clamped to the grid of `n` nodes) and the
/// weight of the node above.
#[inline]
fn node(s: f32, n: usize) -> (usize, f32) {
    let s = s.clamp(0.0, (n - 1) as f32);
    let j = (s as usize).min(n - 2);
    (j, s - j as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::dielectric::{fresnel_dielectric, refract};
    use crate::bsdf::{reflect, Ggx};
    use glam::{Vec2, Vec3};

    /// `E` as the mean over an `n × n` grid of visible normals drawn by ember's own
    /// sampler, reflected and refracted by ember's own Fresnel and Snell: the table
    /// must describe the lobe ember evaluates.
    fn by_visible_normals(mu: f32, alpha: f32, eta: f32, n: usize) -> f64 {
        let ggx = Ggx::new(alpha);
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let mut sum = 0.0f64;
        for a in 0..n {
            for b in 0..n {
                let u = Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                let h = ggx.sample_visible_normal(wo, u);
                let c = wo.dot(h).max(0.0);
                let f = f64::from(fresnel_dielectric(c, eta));
                let wr = reflect(wo, h);
                if wr.z > 0.0 {
                    sum += f * f64::from(ggx.g1(wr));
                }
                if let Some(wt) = refract(wo, h, c, eta).filter(|wt| wt.z < 0.0) {
                    sum += (1.0 - f) * f64::from(ggx.g1(Vec3::new(wt.x, wt.y, -wt.z)));
                }
            }
        }
        sum / (n * n) as f64
    }

    #[test]
    fn table_matches_a_quadrature_of_embers_glass() {
        // On nodes, between them, from both sides, grazing to normal: within 0.6%, the
        // linear interpolation's error where the critical angle crosses a lobe.
        let cases = [
            (1.0f32, 0.25f32, 1.5f32),
            (0.5, 0.25, 1.0 / 1.5),
            (0.17, 0.01, 1.33),
            (0.17, 0.01, 1.0 / 1.33),
            (0.3, 1.0, 2.0),
            (0.8, 0.6, 1.0 / 2.0),
            (0.05, 0.09, 1.7),
            (0.6, 0.36, 1.0 / 2.4),
            (0.9, 0.04, 1.05),
            (0.4, 0.5, 1.0 / 1.2),
        ];
        for (mu, alpha, eta) in cases {
            let table = glass_albedo(mu, alpha, eta);
            let quadrature = by_visible_normals(mu, alpha, eta, 400);
            eprintln!("E({mu}, {alpha}, {eta}): table {table}, quadrature {quadrature}");
            assert!(
                (f64::from(table) - quadrature).abs() < 6e-3,
                "E({mu}, {alpha}, {eta}): table {table}, quadrature {quadrature}"
            );
        }
    }

    #[test]
    fn smooth_glass_keeps_everything_and_rougher_glass_loses_more() {
        for eta in [1.33f32, 1.0 / 1.33, 2.0, 0.5] {
            assert_eq!(glass_albedo(0.5, 0.0, eta), 1.0);
            let mut previous = 1.0;
            for r in 1..=10 {
                let alpha = (r as f32 / 10.0).powi(2);
                let e = glass_albedo(0.7, alpha, eta);
                assert!(e < previous && e > 0.2, "E(0.7, {alpha}, {eta}) = {e}");
                previous = e;
            }
        }
    }
}
