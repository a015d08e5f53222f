//! Probability densities over directions, as plain values: each can say how likely a
//! direction is (`value`, per steradian) and draw one (`generate`). Combining them is
//! static ([`MixturePdf`] is generic), so nothing is boxed or allocated per sample.
//!
//! `generate` may return `None`: a draw that produces no direction (a light point
//! facing away, or hidden behind something). Such a draw counts as a sample worth zero,
//! so `value` is the density of the directions that *are* produced, and it integrates
//! to at most 1; an estimator `f(ω) / value(ω)` stays unbiased wherever `value > 0`.

use glam::Vec3;

use super::{cosine_hemisphere, LightSampler, Onb, Rng};
use crate::accel::{Accel, Ray};
use crate::scene::Scene;
use std::f32::consts::FRAC_1_PI;

/// A density over unit directions.
pub trait Pdf {
    /// Density (per steradian) of generating the unit direction `dir`.
    fn value(&self, dir: Vec3) -> f32;
    /// A unit direction drawn from this density, or `None` for a void draw.
    fn generate(&self, rng: &mut Rng) -> Option<Vec3>;
}

/// `cos θ / π` over the hemisphere around a unit normal; 0 below it.
#[derive(Clone, Copy, Debug)]
pub struct CosinePdf {
    frame: Onb,
}

impl CosinePdf {
    pub fn new(normal: Vec3) -> Self {
        CosinePdf {
            frame: Onb::from_w(normal),
        }
    }

    pub fn normal(&self) -> Vec3 {
        self.frame.w
    }
}

impl Pdf for CosinePdf {
    #[inline]
    fn value(&self, dir: Vec3) -> f32 {
        dir.dot(self.frame.w).max(0.0) * FRAC_1_PI
    }

    #[inline]
    fn generate(&self, rng: &mut Rng) -> Option<Vec3> {
        let (u1, u2) = rng.pair();
        Some(self.frame.to_world(cosine_hemisphere(u1, u2)))
    }
}

/// Directions towards points on the scene's lights, as seen from `origin` (see
/// [`LightSampler`]). A direction counts only if the light point it was aimed at is
/// the first thing the ray meets: `value` traces the direction through the accelerator
/// and asks whether the triangle hit is an emitter facing `origin`; `generate` checks
/// that the chosen point is not hidden. The two therefore describe one density even in
/// scenes where lights are partly occluded or lie behind one another.
pub struct LightPdf<'a, A: Accel> {
    pub origin: Vec3,
    pub lights: &'a LightSampler,
    pub scene: &'a Scene,
    pub accel: &'a A,
}

impl<A: Accel> LightPdf<'_, A> {
    /// A direction with the density the sampler used for it, or `None` for a void draw.
    pub fn generate_with_pdf(&self, rng: &mut Rng) -> Option<(Vec3, f32)> {
        let sample = self.lights.sample(self.origin, rng)?;
        let hit = self.accel.intersect(&Ray::new(self.origin, sample.dir))?;
        (hit.prim == sample.prim).then_some((sample.dir, sample.pdf))
    }
}

impl<A: Accel> Pdf for LightPdf<'_, A> {
    fn value(&self, dir: Vec3) -> f32 {
        let dir = dir.normalize_or_zero();
        match self.accel.intersect(&Ray::new(self.origin, dir)) {
            Some(hit) => self.lights.pdf_hit(hit.prim, dir, hit.t),
            None => 0.0,
        }
    }

    fn generate(&self, rng: &mut Rng) -> Option<Vec3> {
        self.generate_with_pdf(rng).map(|(dir, _)| dir)
    }
}

/// `weight · first + (1 − weight) · second`: draw from one or the other.
#[derive(Clone, Copy, Debug)]
pub struct MixturePdf<P, Q> {
    pub first: P,
    pub second: Q,
    /// Probability of drawing from `first`, in [0, 1].
    pub weight: f32,
}

impl<P, Q> MixturePdf<P, Q> {
    /// The book's even mixture.
    pub fn even(first: P, second: Q) -> Self {
        MixturePdf {
            first,
            second,
            weight: 0.5,
        }
    }
}

impl<P: Pdf, Q: Pdf> Pdf for MixturePdf<P, Q> {
    #[inline]
    fn value(&self, dir: Vec3) -> f32 {
        self.weight * self.first.value(dir) + (1.0 - self.weight) * self.second.value(dir)
    }

    #[inline]
    fn generate(&self, rng: &mut Rng) -> Option<Vec3> {
        if rng.f32() < self.weight {
            self.first.generate(rng)
        } else {
            self.second.generate(rng)
        }
    }
}

/// The uniform density `1 / 4π` over the whole sphere (for tests and comparisons).
#[derive(Clone, Copy, Debug, Default)]
pub struct UniformSpherePdf;

impl Pdf for UniformSpherePdf {
    #[inline]
    fn value(&self, _dir: Vec3) -> f32 {
        0.25 * FRAC_1_PI
    }

    #[inline]
    fn generate(&self, rng: &mut Rng) -> Option<Vec3> {
        let (u1, u2) = rng.pair();
        Some(super::uniform_sphere(u1, u2))
    }
}
