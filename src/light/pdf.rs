//! Probability densities over directions, as plain values: the book's `pdf` objects
//! (`value`, `generate`) made cheap. Each can say how likely a direction is and draw
//! one; combining them is static ([`MixturePdf`] is generic), so nothing is boxed or
//! allocated per sample. The `mixture` integrator samples with exactly these.
//!
//! A density over directions from a surface point can depend on what a direction hits
//! first: the light density of a direction is that of the light point it reaches,
//! unless something is in the way. So `value` is told the direction's first hit, which
//! the caller traces once and reuses for the path, and `generate` says which light
//! triangle a direction was aimed at. A draw whose aimed-at triangle is not the first
//! hit is *void*: it counts as a sample worth zero. `value` is then the density of the
//! directions that are not void, and integrates to at most 1; an estimator
//! `f(ω) / value(ω)` stays unbiased wherever `value > 0`. A draw aimed at a delta light
//! (a point, a spot, a sun without a disc) is void too: no density over directions
//! holds it, and the integrators take those lights by next-event estimation instead.

use glam::{Vec2, Vec3};

use super::{GuidedLightDraw, LightSampler, LightTarget, Receiver, SkyGuide};
use crate::bsdf::Bsdf;
use crate::geometry::Hit;
use crate::sampling::Rng;

/// A direction drawn from a [`Pdf`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Direction {
    /// Unit direction.
    pub dir: Vec3,
    /// What the direction was aimed at, when it must reach it for the draw to count:
    /// an emitter that must be the first hit, or the sky (nothing may be hit).
    pub aimed_at: Option<LightTarget>,
}

impl Direction {
    /// Whether the draw counts, given the direction's first hit.
    #[inline]
    pub fn reached(&self, first_hit: Option<&Hit>) -> bool {
        match self.aimed_at {
            None => true,
            Some(LightTarget::Emitter(prim)) => first_hit.is_some_and(|h| h.prim == prim),
            Some(LightTarget::Sky | LightTarget::Light(_)) => first_hit.is_none(),
            // Void before it gets here (see `generate`).
            Some(LightTarget::Delta(_)) => false,
        }
    }
}

/// A density over unit directions from one point.
pub trait Pdf {
    /// Density (per steradian) of generating unit direction `dir`, whose first hit
    /// from the point is `first_hit` (`None`: the ray leaves the scene).
    fn value(&self, dir: Vec3, first_hit: Option<&Hit>) -> f32;
    /// A direction drawn from this density, or `None` for a void draw.
    fn generate(&self, rng: &mut Rng) -> Option<Direction>;
}

/// The density with which a (non-delta) BSDF samples directions for light leaving
/// towards `wo`.
#[derive(Clone, Copy, Debug)]
pub struct BsdfPdf<'a> {
    pub bsdf: &'a Bsdf,
    pub wo: Vec3,
}

impl Pdf for BsdfPdf<'_> {
    #[inline]
    fn value(&self, dir: Vec3, _first_hit: Option<&Hit>) -> f32 {
        self.bsdf.pdf(self.wo, dir)
    }

    #[inline]
    fn generate(&self, rng: &mut Rng) -> Option<Direction> {
        let (u1, u2) = rng.pair();
        let sample = self.bsdf.sample(self.wo, Vec2::new(u1, u2))?;
        Some(Direction {
            dir: sample.wi,
            aimed_at: None,
        })
    }
}

/// Directions towards points on the scene's lights and its sky, as seen from the
/// receiver `at` (see [`LightSampler`]): a direction has the density of the light
/// point it first hits, or of the sky where it leaves the scene.
#[derive(Clone, Copy, Debug)]
pub struct LightPdf<'a> {
    pub at: Receiver,
    pub lights: &'a LightSampler,
}

impl Pdf for LightPdf<'_> {
    #[inline]
    fn value(&self, dir: Vec3, first_hit: Option<&Hit>) -> f32 {
        match first_hit {
            Some(hit) => self.lights.pdf_hit(self.at, hit.prim, dir, hit.t),
            None => self.lights.pdf_far(dir),
        }
    }

    #[inline]
    fn generate(&self, rng: &mut Rng) -> Option<Direction> {
        let sample = self.lights.sample(self.at, rng).filter(|s| !s.is_delta())?;
        Some(Direction {
            dir: sample.dir,
            aimed_at: Some(sample.target),
        })
    }
}

/// [`LightPdf`] at a guided vertex: where it picks the sky, the direction comes with
/// probability `share` from the vertex's sky guide and otherwise from the sky's own
/// distribution ([`LightSampler::draw_with_sky_guide`]); emitters as [`LightPdf`].
#[derive(Clone, Copy, Debug)]
pub struct GuidedLightPdf<'a, G> {
    pub at: Receiver,
    pub lights: &'a LightSampler,
    pub share: f32,
    pub guide: &'a G,
}

impl<G: SkyGuide> Pdf for GuidedLightPdf<'_, G> {
    #[inline]
    fn value(&self, dir: Vec3, first_hit: Option<&Hit>) -> f32 {
        match first_hit {
            Some(hit) => self.lights.pdf_hit(self.at, hit.prim, dir, hit.t),
            None => {
                let sky = self
                    .lights
                    .pdf_sky_guided(dir, self.share, self.guide.pdf(dir));
                match self.lights.has_sun_discs() {
                    false => sky,
                    true => sky + self.lights.pdf_suns(dir),
                }
            }
        }
    }

    #[inline]
    fn generate(&self, rng: &mut Rng) -> Option<Direction> {
        let drawn = self
            .lights
            .draw_with_sky_guide(self.at, rng, self.share, self.guide)?;
        let aimed_at = match drawn {
            GuidedLightDraw::Complete(sample) if sample.is_delta() => return None,
            GuidedLightDraw::Complete(sample) => sample.target,
            GuidedLightDraw::Sky(_) => LightTarget::Sky,
        };
        Some(Direction {
            dir: drawn.dir(),
            aimed_at: Some(aimed_at),
        })
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
    fn value(&self, dir: Vec3, first_hit: Option<&Hit>) -> f32 {
        self.weight * self.first.value(dir, first_hit)
            + (1.0 - self.weight) * self.second.value(dir, first_hit)
    }

    #[inline]
    fn generate(&self, rng: &mut Rng) -> Option<Direction> {
        if rng.f32() < self.weight {
            self.first.generate(rng)
        } else {
            self.second.generate(rng)
        }
    }
}
