//! Random numbers, local frames, discrete distributions and the warps from uniform
//! numbers to directions and points: the leaf every sampler builds on.

mod distribution;
mod onb;
mod rng;

pub use distribution::{alias_bin, alias_draw, AliasEntry, AliasTable};
pub use onb::Onb;
pub use rng::{mix64, Rng};

use glam::Vec3;
use std::f32::consts::PI;

/// The largest `f32` below 1: where a uniform number stretched back to `[0, 1)` (after
/// a choice made with part of it) is clamped, as rounding can carry it to 1.
pub const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// Whether the uniform `u` chooses the second of two parts, the first having
/// probability `p_first`; `u` is rescaled to a uniform within the part chosen, at
/// most [`ONE_BELOW`], so one number both chooses and draws.
#[inline]
pub fn choose_second(u: &mut f32, p_first: f32) -> bool {
    let second = *u >= p_first;
    let rescaled = if second {
        (*u - p_first) / (1.0 - p_first)
    } else {
        *u / p_first
    };
    *u = rescaled.min(ONE_BELOW);
    second
}

/// A cosine-weighted direction in the local frame (z up): density `cos θ / π`.
/// `u1`, `u2` are uniform in `[0, 1)`.
#[inline]
pub fn cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let phi = 2.0 * PI * u1;
    let r = u2.sqrt();
    let z = (1.0 - u2).max(0.0).sqrt();
    Vec3::new(phi.cos() * r, phi.sin() * r, z)
}

/// A uniformly distributed direction on the unit sphere: density `1 / 4π`.
#[inline]
pub fn uniform_sphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A uniform point on a triangle, as barycentrics `(b1, b2)` of its second and third
/// vertex (the square-root parameterisation).
#[inline]
pub fn uniform_triangle(u1: f32, u2: f32) -> (f32, f32) {
    let s = u1.sqrt();
    (s * (1.0 - u2), s * u2)
}

/// A uniform point on the unit disk (Shirley and Chiu's concentric map, which keeps
/// strata of the square as compact regions of the disk): density `1 / π`.
#[inline]
pub fn concentric_disk(u1: f32, u2: f32) -> (f32, f32) {
    let (a, b) = (2.0 * u1 - 1.0, 2.0 * u2 - 1.0);
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, std::f32::consts::FRAC_PI_4 * (b / a))
    } else {
        (
            b,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (a / b),
        )
    };
    (r * phi.cos(), r * phi.sin())
}
