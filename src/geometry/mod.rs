//! Rays, hits, and spawning rays off surfaces: the geometry every other module speaks.
//!
//! A ray leaving a surface must not hit that surface again because of rounding. Instead
//! of a fixed epsilon (wrong for millimetre scenes and for scenes far from the origin),
//! the origin is pushed along the geometric normal just past the box that bounds the
//! rounding error of the hit point, as pbrt-v4 does ("Robust spawned ray origins",
//! Pharr, Jakob & Humphreys, §6.8.6). The bound grows with the coordinates, so the
//! same scene gives the same image at any scale and any distance from the origin.

mod filter;
mod instance;
mod packet;

pub use filter::{HitFilter, Opaque};
pub use instance::{
    object_ray, object_transforms, Instance, InstanceError, MAX_RAY_COORDINATE, RAY_REACH,
};
pub use packet::{Hits16, Rays16, PACKET};

use glam::Vec3;

/// A ray segment: points `origin + t * dir` for `t` in `[tmin, tmax]`.
/// `dir` need not be normalised; `t` is measured in units of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    /// A segment that ends at `tmax`, for shadow rays towards a point.
    pub fn segment(origin: Vec3, dir: Vec3, tmax: f32) -> Self {
        Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax,
        }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// The nearest hit of a ray: distance, the triangle index in its mesh, the barycentric
/// coordinates of the hit point, `p = (1 - u - v) * v0 + u * v1 + v * v2` (Embree's
/// convention), and the instance (placement) of that mesh. Everything else (normals,
/// UVs, material) is looked up in the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
    /// Which [`Instance`] of a two-level structure was hit (its index in the list the
    /// structure was built from), so that shading can take the surface to the world;
    /// 0 in a structure of one mesh in world space.
    pub instance: u32,
}

/// A point on a surface with a bound on its rounding error, and the unit geometric
/// normal there: what a ray needs to leave the surface safely.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceOrigin {
    pub p: Vec3,
    /// Per-axis bound on `|p − exact point|`.
    pub error: Vec3,
    /// Unit geometric normal (either side).
    pub ng: Vec3,
}

/// `γ(n) = nε / (1 − nε)`: the relative error bound of `n` chained f32 operations
/// (pbrt's notation, ε = half an ulp of 1).
pub const fn gamma(n: u32) -> f32 {
    let e = n as f32 * (f32::EPSILON * 0.5);
    e / (1.0 - e)
}

/// The error bound of the point `b0·a + b1·b + b2·c` computed in f32 from barycentric
/// coordinates that sum to 1: `γ(7) · (|b0·a| + |b1·b| + |b2·c|)` per axis.
#[inline]
pub fn barycentric_error(b: [f32; 3], [a, v1, v2]: [Vec3; 3]) -> Vec3 {
    gamma(7) * ((b[0] * a).abs() + (b[1] * v1).abs() + (b[2] * v2).abs())
}

impl SurfaceOrigin {
    /// The origin of a ray leaving towards `dir`: `p` moved along the geometric normal,
    /// to the side `dir` points to, past the error box, then rounded away from the
    /// surface so the rounding of the move itself cannot bring it back.
    #[inline]
    pub fn offset_towards(&self, dir: Vec3) -> Vec3 {
        let distance = self.ng.abs().dot(self.error);
        let mut offset = self.ng * distance;
        if dir.dot(self.ng) < 0.0 {
            offset = -offset;
        }
        let moved = self.p + offset;
        Vec3::new(
            round_away(moved.x, offset.x),
            round_away(moved.y, offset.y),
            round_away(moved.z, offset.z),
        )
    }

    /// A ray leaving this surface along `dir`.
    #[inline]
    pub fn spawn(&self, dir: Vec3) -> Ray {
        Ray {
            tmin: SPAWN_TMIN,
            ..Ray::new(self.offset_towards(dir), dir)
        }
    }

    /// A shadow ray from this surface to the surface point `to`, stopping just short
    /// of it (both ends offset, so neither surface occludes the segment): `dir` is the
    /// whole segment and `tmax` is `1 − 1e-4`.
    #[inline]
    pub fn spawn_to(&self, to: &SurfaceOrigin) -> Ray {
        let from = self.offset_towards(to.p - self.p);
        let end = to.offset_towards(from - to.p);
        Ray {
            tmin: SPAWN_TMIN,
            ..Ray::segment(from, end - from, 1.0 - SHADOW_EPSILON)
        }
    }
}

/// Where spawned rays start counting hits: just above 0, because Embree's robust mode
/// reports the surface a ray leaves at exactly `t = 0` (or `-0`) when the origin lies
/// within its own, wider tolerance.
pub const SPAWN_TMIN: f32 = f32::MIN_POSITIVE;

/// Fraction of a shadow segment left out at its far end.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// `x` moved one ulp further in the direction of `offset`'s sign (unchanged for 0),
/// as `f32::next_up`/`next_down` do (not used: they need Rust 1.86).
#[inline]
pub(crate) fn round_away(x: f32, offset: f32) -> f32 {
    if offset == 0.0 || !x.is_finite() {
        return x;
    }
    if x == 0.0 {
        return f32::from_bits(1).copysign(offset);
    }
    // Away from zero is one more in the bits; towards zero, one less.
    let bits = x.to_bits();
    if (offset > 0.0) == (x > 0.0) {
        f32::from_bits(bits + 1)
    } else {
        f32::from_bits(bits - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_away_moves_one_ulp() {
        for x in [1.0f32, -1.0, 3.5e4, -2.5e-3, 1e-30] {
            let up = round_away(x, 1.0);
            let down = round_away(x, -1.0);
            assert!(up > x && down < x, "{x}");
            // One ulp: no f32 lies strictly between.
            let ulp = f64::from(x).abs() * f64::from(f32::EPSILON);
            assert!(f64::from(up) - f64::from(x) <= ulp && f64::from(x) - f64::from(down) <= ulp);
            assert_eq!(round_away(x, 0.0), x);
        }
        assert!(round_away(0.0, 1.0) > 0.0 && round_away(0.0, -1.0) < 0.0);
    }

    /// A point on a tilted triangle far from the origin: rays spawned off it, either
    /// way, start strictly on their own side of the exact plane, however far out.
    #[test]
    fn spawned_origins_leave_the_plane_at_every_scale() {
        for scale in [1e-3f32, 1.0, 1e3, 1e5] {
            for shift in [0.0f32, 1e4] {
                let v = [
                    Vec3::new(0.1, 0.2, 0.3) * scale + shift,
                    Vec3::new(1.3, 0.1, -0.2) * scale + shift,
                    Vec3::new(0.4, 1.1, 0.9) * scale + shift,
                ];
                let ng = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                for (i, b) in [[0.2f32, 0.3, 0.5], [0.9, 0.05, 0.05], [1.0 / 3.0; 3]]
                    .into_iter()
                    .enumerate()
                {
                    let p = b[0] * v[0] + b[1] * v[1] + b[2] * v[2];
                    let origin = SurfaceOrigin {
                        p,
                        error: barycentric_error(b, v),
                        ng,
                    };
                    for dir in [ng, -ng, (ng + Vec3::X).normalize()] {
                        let o = origin.offset_towards(dir);
                        // Signed distance to the exact plane, in f64.
                        let d = (o.as_dvec3() - v[0].as_dvec3()).dot(ng.as_dvec3());
                        let side = dir.dot(ng).signum() as f64;
                        assert!(
                            d * side > 0.0,
                            "scale {scale}, shift {shift}, point {i}: {d}"
                        );
                        // And not absurdly far: within a few thousand ulps of the coordinates.
                        let ulp = f64::from(p.abs().max_element().max(1e-30)) * 1.2e-7;
                        assert!(d.abs() < 1e3 * ulp, "offset {d} vs ulp {ulp}");
                    }
                }
            }
        }
    }
}
