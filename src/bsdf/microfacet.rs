//! The GGX (Trowbridge–Reitz) microfacet distribution with Smith's separable
//! masking-shadowing, sampled through its visible normals.
//!
//! All directions are in the local shading frame (z = the normal) and point away from
//! the surface, `wo` above it. In reflection `h` is the half vector of `wo` and `wi`.
//!
//! - `D(h) = α² / (π (α² cos²θh + sin²θh)²)` (written with sin² rather than
//!   `(α² − 1) cos² + 1`, which cancels catastrophically for small α);
//! - `G1(ω) = 2 / (1 + √(1 + α² tan²θ))`, and `G = G1(wo) G1(wi)` (separable);
//! - visible normals are sampled by the spherical-cap method of Dupuy & Benyoub
//!   ("Sampling Visible GGX Normals with Spherical Caps", 2023), with density
//!   `D_wo(h) = G1(wo) max(0, wo·h) D(h) / cos θo`; reflecting `wo` about `h` turns it
//!   into `D_wo(h) / (4 wo·h) = G1(wo) D(h) / (4 cos θo)` per steradian of `wi`.
//!
//! Refraction into the side below, of relative index `η` (Walter, Marschner, Li and
//! Torrance, "Microfacet Models for Refraction through Rough Surfaces", 2007): the facet
//! is the generalised half vector `h ∝ ±(wo + η wi)` (turned up), both directions must
//! face it from their own sides (`wo·h > 0 > wi·h`), and
//!
//! - `f cos θi = |wo·h| |wi·h| D G1(wo) G1(wi) / (cos θo (wo·h + η wi·h)²)` without the
//!   Fresnel factor, in the radiance convention: across a smooth interface it carries
//!   `(1 − F) / η²`, the `1/η²` of radiance squeezed into a denser medium, as ember's
//!   smooth glass does;
//! - refracting `wo` through a visible normal draws `wi` with density
//!   `D_wo(h) |dh/dwi| = G1(wo) D(h) (wo·h) / cos θo · η² |wi·h| / (wo·h + η wi·h)²`.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// An isotropic GGX distribution of roughness `alpha` (> 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    alpha: f32,
}

impl Ggx {
    pub fn new(alpha: f32) -> Self {
        Ggx { alpha }
    }

    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// The normal distribution `D(h)` for a unit half vector (0 below the surface).
    #[inline]
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let t = a2 * h.z * h.z + (h.x * h.x + h.y * h.y);
        a2 * FRAC_1_PI / (t * t)
    }

    /// Smith's masking `G1(ω)` of one direction above the surface (0 at or below it).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        if w.z <= 0.0 {
            return 0.0;
        }
        let tan2 = (w.x * w.x + w.y * w.y) / (w.z * w.z);
        2.0 / (1.0 + (1.0 + self.alpha * self.alpha * tan2).sqrt())
    }

    /// A microfacet normal visible from `wo` (`wo.z > 0`), drawn with density
    /// `D_wo(h)` from two uniforms.
    #[inline]
    pub fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        // Stretch to the configuration where α = 1 and the visible normals are a
        // spherical cap around `wo` ...
        let wo_std = Vec3::new(wo.x * self.alpha, wo.y * self.alpha, wo.z).normalize();
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z;
        let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
        let cap = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), z);
        let h_std = cap + wo_std;
        // ... and unstretch the normal.
        Vec3::new(h_std.x * self.alpha, h_std.y * self.alpha, h_std.z.max(0.0)).normalize()
    }

    /// `D G1(wo) G1(wi) / (4 cos θo)`: the reflection BRDF times `cos θi`, without its
    /// Fresnel factor. Zero unless both directions are above the surface.
    #[inline]
    pub fn reflectance_cos(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        self.d(h) * self.g1(wo) * self.g1(wi) / (4.0 * wo.z)
    }

    /// Density per steradian of `wi` when it is `wo` reflected about a visible normal:
    /// `G1(wo) D(h) / (4 cos θo)`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        self.g1(wo) * self.d(h) / (4.0 * wo.z)
    }
}

/// `wo` refracted into `wi` below the surface through one facet (see the module notes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refraction {
    /// `wo·h` (> 0) and `−wi·h` (> 0), the cosines the facet's Fresnel factor is read
    /// at.
    pub cos_o: f32,
    pub cos_i: f32,
    /// `f cos θi` without the Fresnel factor.
    pub value: f32,
    /// Density per steradian of `wi` when `wo` is refracted through a visible normal.
    pub pdf: f32,
}

impl Ggx {
    /// The refraction of `wo` (above) into `wi` (below) across relative index `eta`;
    /// `None` where no facet refracts one into the other.
    #[inline]
    pub fn refraction(&self, wo: Vec3, wi: Vec3, eta: f32) -> Option<Refraction> {
        if wo.z <= 0.0 || wi.z >= 0.0 {
            return None;
        }
        let h = (wo + eta * wi).try_normalize()?;
        let h = if h.z < 0.0 { -h } else { h };
        let (cos_o, cos_i) = (wo.dot(h), wi.dot(h));
        let denominator = cos_o + eta * cos_i;
        if cos_o <= 0.0 || cos_i >= 0.0 || denominator == 0.0 {
            return None;
        }
        let below = Vec3::new(wi.x, wi.y, -wi.z);
        let d = self.d(h);
        let g1_o = self.g1(wo);
        let jacobian = -cos_i / (denominator * denominator);
        Some(Refraction {
            cos_o,
            cos_i: -cos_i,
            value: d * g1_o * self.g1(below) * cos_o * jacobian / wo.z,
            pdf: g1_o * d * cos_o / wo.z * eta * eta * jacobian,
        })
    }
}

/// `w` mirrored about the unit normal `n` (both pointing away from the surface).
#[inline]
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    2.0 * w.dot(n) * n - w
}
