//! One emissive triangle, and how a direction towards it is drawn from a receiver:
//! uniformly in solid angle (warped by the receiver's cosine) where the triangle is
//! neither tiny nor huge as seen from there, else a uniform point on its area.
//!
//! A two-sided emitter (glTF's `doubleSided`) emits from both faces: a receiver behind
//! it sees the same triangle with its normal reversed, and every density below takes
//! `|cos α|`. Neither Arvo's map nor area sampling depends on the winding, so the
//! strategies serve either face unchanged.
//!
//! The rule, a pure function of the receiver and the triangle so that the density of
//! any direction is that of the strategy that would have drawn it:
//! - the receiver is behind the emitting side (of a one-sided emitter): nothing
//!   (density 0);
//! - area sampling's density, `d² / (cos α · A) = d³ / (h · A)` at distance `d` from a
//!   receiver at height `h` over the plane, varies over the triangle by less than a
//!   factor 64, by the bound `(d_max / h)³`: area sampling. It costs a fraction of
//!   Arvo's map, which pays only where the triangle spans a wide angle. Measured on
//!   the Cornell box (512², 32 spp, one thread, CPU time against the alias table and
//!   area sampling alone): solid angle wherever the bounds below allow, +44% time for
//!   −3% error; with a factor 2 here, about the same; 8, +17% for −1%; 64, +7% for
//!   −0.3%;
//! - solid angle below [`MIN_SOLID_ANGLE`]: area sampling.
//!   The triangle is small and far, so that density is nearly constant over it and
//!   Arvo's map (trigonometry, and an inversion for every density) would buy nothing.
//!   A bounding sphere settles most of these without computing the solid angle;
//! - solid angle above [`MAX_SOLID_ANGLE`]: area sampling too. Close to 2π the
//!   receiver lies almost in the triangle's plane, near it; the spherical angles are
//!   close to π and the sampled directions lose their precision;
//! - otherwise Arvo's spherical-triangle sampling, density `1 / Ω`, times the bilinear
//!   warp's density when the receiver has a normal and the cosine towards the
//!   triangle's corners varies by more than 10% (see [`super::spherical_triangle`]).

use glam::{DVec3, Vec2, Vec3};

use super::spherical_triangle::{sample_bilinear, worthwhile, SphericalTriangle, Warp};
use crate::sampling::uniform_triangle;

/// Below this solid angle (steradians) a triangle is sampled by area (pbrt-v4's bound).
pub const MIN_SOLID_ANGLE: f64 = 3e-4;
/// `64^(2/3)`: a triangle is sampled by area where area sampling's density varies
/// over it by less than a factor 64, i.e. where `d_max² ≤ 64^(2/3) h² = 16 h²`.
const AREA_RATIO_SQUARED_CUBE_ROOT: f32 = 16.0;
/// Above this solid angle (steradians) a triangle is sampled by area (pbrt-v4's bound).
pub const MAX_SOLID_ANGLE: f64 = 6.22;

/// The point a light sample is taken for: its position, and the unit shading normal
/// whose cosine the integrand carries (zero when there is none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Receiver {
    pub p: Vec3,
    /// Turned to the side the receiver takes light from: the light BVH gives nothing
    /// behind it (a reflective BSDF's integrand is 0 there). The cosine warp of
    /// solid-angle sampling takes `|cos|`, so only the BVH reads the sign.
    pub n: Vec3,
}

impl Receiver {
    /// A receiver without a normal: no cosine warp, no normal term in light choice.
    pub fn at(p: Vec3) -> Self {
        Receiver { p, n: Vec3::ZERO }
    }
}

/// One emissive triangle, copied out of the mesh so that a sample touches one record.
#[derive(Clone, Copy, Debug)]
pub struct Emitter {
    pub vertices: [Vec3; 3],
    /// Unit normal of the counter-clockwise side, the one that emits (both do where
    /// `two_sided`).
    pub normal: Vec3,
    pub two_sided: bool,
    pub emission: Vec3,
    pub area: f32,
    /// Density per unit area of the whole light sampler's area sampling on this
    /// triangle: `(1 − P_sky) · P_i / A_i` (set by the sampler; 0 until then).
    pub area_density: f32,
    /// Centre and squared radius of a sphere around the triangle (its centroid and
    /// farthest corner), to settle the small-solid-angle case cheaply.
    center: Vec3,
    radius_squared: f32,
    /// Scene texture id of the `map_Ke` that multiplies `emission`, or [`NO_MAP`].
    pub map: u32,
    /// Texture coordinates of the corners (read only with a map).
    pub uvs: [Vec2; 3],
}

/// Marks an emitter without an emission texture.
pub const NO_MAP: u32 = u32::MAX;

/// A point drawn on an emitter, seen from the receiver.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    /// Barycentrics of the point.
    pub b: [f32; 3],
    pub point: Vec3,
    /// Unit direction from the receiver to the point, and the distance.
    pub dir: Vec3,
    pub distance: f32,
    /// Solid-angle density of the direction, given this emitter.
    pub density: f32,
}

/// A point on an emitter as seen from a receiver.
struct SeenFrom {
    point: Vec3,
    /// Unit direction from the receiver.
    dir: Vec3,
    distance_squared: f32,
    distance: f32,
    /// Cosine between the emitting face's normal and the direction back to the
    /// receiver (> 0).
    cos_light: f32,
}

/// How directions towards one emitter are drawn from one receiver.
enum Strategy {
    Area,
    SolidAngle(SphericalTriangle, Option<Warp>),
}

impl Emitter {
    /// The triangle `vertices` emitting `emission` (times texture `map` at `uvs`) from
    /// its counter-clockwise face, or from both when `two_sided`.
    pub fn new(
        vertices: [Vec3; 3],
        emission: Vec3,
        map: u32,
        uvs: [Vec2; 3],
        two_sided: bool,
    ) -> Self {
        let [a, b, c] = vertices;
        let cross = (b - a).cross(c - a);
        let center = (a + b + c) / 3.0;
        let radius_squared = vertices
            .iter()
            .map(|v| v.distance_squared(center))
            .fold(0.0, f32::max);
        Emitter {
            vertices,
            normal: cross.normalize_or_zero(),
            two_sided,
            emission,
            area: 0.5 * cross.length(),
            area_density: 0.0,
            center,
            radius_squared,
            map,
            uvs,
        }
    }

    /// Whether [`sample`](Self::sample) draws directions from `at` by solid angle
    /// (rather than by area).
    pub fn samples_by_solid_angle(&self, at: Receiver) -> bool {
        self.faces(at.p) && matches!(self.strategy(at), Strategy::SolidAngle(..))
    }

    /// Whether `p` is on an emitting side of the triangle's plane.
    #[inline]
    fn faces(&self, p: Vec3) -> bool {
        let h = (p - self.vertices[0]).dot(self.normal);
        h > 0.0 || (self.two_sided && h < 0.0)
    }

    /// The cosine between the face that unit `dir` (towards the triangle) meets and
    /// the way back, when that face emits; 0 or less where it does not.
    #[inline]
    fn cos_light(&self, dir: Vec3) -> f32 {
        let cos = -dir.dot(self.normal);
        if self.two_sided {
            cos.abs()
        } else {
            cos
        }
    }

    #[inline]
    fn strategy(&self, at: Receiver) -> Strategy {
        // Area sampling's density in solid angle, d²/(A cos α) = d³/(A h) at distance d
        // from a receiver at height h over the plane, varies over the triangle by at
        // most (d_max / h)³: where that stays under 64, Arvo's map costs more than it
        // saves.
        let h = (at.p - self.vertices[0]).dot(self.normal);
        let d_max2 = self
            .vertices
            .iter()
            .map(|v| v.distance_squared(at.p))
            .fold(0.0, f32::max);
        if d_max2 <= AREA_RATIO_SQUARED_CUBE_ROOT * h * h {
            return Strategy::Area;
        }
        // The solid angle of the bounding sphere's cap bounds the triangle's:
        // 2π(1 − cos θ) with sin²θ = r²/d², written without cancellation.
        let d2 = at.p.distance_squared(self.center);
        if d2 > self.radius_squared {
            let s2 = f64::from(self.radius_squared) / f64::from(d2);
            let cap = 2.0 * std::f64::consts::PI * s2 / (1.0 + (1.0 - s2).sqrt());
            if cap < MIN_SOLID_ANGLE {
                return Strategy::Area;
            }
        }
        let Some(triangle) = SphericalTriangle::new(at.p, self.vertices) else {
            return Strategy::Area;
        };
        if !(MIN_SOLID_ANGLE..=MAX_SOLID_ANGLE).contains(&triangle.solid_angle()) {
            return Strategy::Area;
        }
        let warp = if at.n == Vec3::ZERO {
            None
        } else {
            worthwhile(triangle.cosine_warp(at.n))
        };
        Strategy::SolidAngle(triangle, warp)
    }

    /// A point on the triangle for the receiver `at`, drawn with `u` in the unit
    /// square; `None` when the receiver is behind the triangle or the draw degenerates.
    #[inline]
    pub fn sample(&self, at: Receiver, u: [f32; 2]) -> Option<EmitterSample> {
        if !self.faces(at.p) {
            return None;
        }
        let (b, density) = match self.strategy(at) {
            Strategy::Area => {
                let (b1, b2) = uniform_triangle(u[0], u[1]);
                ([1.0 - b1 - b2, b1, b2], None)
            }
            Strategy::SolidAngle(triangle, warp) => {
                let u = [f64::from(u[0]), f64::from(u[1])];
                let (u, warp_density) = match &warp {
                    None => (u, 1.0),
                    Some(warp) => {
                        let warped = sample_bilinear(warp, u);
                        (
                            warped,
                            super::spherical_triangle::bilinear_density(warp, warped),
                        )
                    }
                };
                let w = triangle.sample(u);
                let b = self.barycentrics_along(at.p, w)?;
                (b, Some((warp_density / triangle.solid_angle()) as f32))
            }
        };
        let seen = self.seen_from(at.p, b)?;
        let distance = seen.distance;
        let density = density.unwrap_or(distance * distance / (seen.cos_light * self.area));
        (density.is_finite() && density > 0.0).then_some(EmitterSample {
            b,
            point: seen.point,
            dir: seen.dir,
            distance,
            density,
        })
    }

    /// The point at barycentrics `b` as seen from `origin`; `None` where it is at
    /// `origin` or faces away from it.
    #[inline]
    fn seen_from(&self, origin: Vec3, b: [f32; 3]) -> Option<SeenFrom> {
        let [v0, v1, v2] = self.vertices;
        let point = b[0] * v0 + b[1] * v1 + b[2] * v2;
        let to_light = point - origin;
        let distance_squared = to_light.length_squared();
        let distance = distance_squared.sqrt();
        if distance.is_nan() || distance <= 0.0 {
            return None;
        }
        let dir = to_light / distance;
        let cos_light = self.cos_light(dir);
        if cos_light.is_nan() || cos_light <= 0.0 {
            return None;
        }
        Some(SeenFrom {
            point,
            dir,
            distance_squared,
            distance,
            cos_light,
        })
    }

    /// A uniform point on the triangle's area from `u`, seen from `origin`, with
    /// `area_density` turned into the whole sampler's solid-angle density: the
    /// default strategy, with no solid-angle test on its path.
    #[inline]
    pub fn sample_area(&self, origin: Vec3, u: [f32; 2]) -> Option<EmitterSample> {
        let (b1, b2) = uniform_triangle(u[0], u[1]);
        let b = [1.0 - b1 - b2, b1, b2];
        let seen = self.seen_from(origin, b)?;
        Some(EmitterSample {
            b,
            point: seen.point,
            dir: seen.dir,
            distance: seen.distance,
            density: self.area_density * seen.distance_squared / seen.cos_light,
        })
    }

    /// The whole sampler's solid-angle density of area sampling along unit `dir`,
    /// whose ray meets the triangle at `distance` (0 from behind a one-sided one).
    #[inline]
    pub fn area_pdf(&self, dir: Vec3, distance: f32) -> f32 {
        let cos_light = self.cos_light(dir);
        if cos_light > 0.0 {
            self.area_density * distance * distance / cos_light
        } else {
            0.0
        }
    }

    /// The solid-angle density with which [`sample`](Self::sample) draws unit `dir`
    /// from `at`, whose ray meets the triangle at `distance` (0 from behind a
    /// one-sided one).
    #[inline]
    pub fn density(&self, at: Receiver, dir: Vec3, distance: f32) -> f32 {
        let cos_light = self.cos_light(dir);
        if cos_light.is_nan() || cos_light <= 0.0 || !self.faces(at.p) {
            return 0.0;
        }
        match self.strategy(at) {
            Strategy::Area => distance * distance / (cos_light * self.area),
            Strategy::SolidAngle(triangle, warp) => {
                triangle.density(dir.as_dvec3().normalize(), warp.as_ref()) as f32
            }
        }
    }

    /// Barycentrics of the point where the ray from `p` along unit `w` meets the
    /// triangle's plane (Möller–Trumbore in `f64`), clamped into the triangle: `w`
    /// comes from the spherical triangle, so it hits up to rounding.
    #[inline]
    fn barycentrics_along(&self, p: Vec3, w: DVec3) -> Option<[f32; 3]> {
        let [v0, v1, v2] = self.vertices.map(|v| v.as_dvec3());
        let (e1, e2) = (v1 - v0, v2 - v0);
        let pvec = w.cross(e2);
        let det = e1.dot(pvec);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let tvec = p.as_dvec3() - v0;
        let b1 = (tvec.dot(pvec) / det).max(0.0);
        let b2 = (w.dot(tvec.cross(e1)) / det).max(0.0);
        let sum = b1 + b2;
        let (b1, b2) = if sum > 1.0 {
            (b1 / sum, b2 / sum)
        } else {
            (b1, b2)
        };
        Some([(1.0 - b1 - b2).max(0.0) as f32, b1 as f32, b2 as f32])
    }
}
