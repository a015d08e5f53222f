//! Directions towards a triangle drawn uniformly in solid angle (Arvo 1995, "Stratified
//! sampling of spherical triangles"), optionally warped towards the receiver's cosine
//! by a bilinear density over the unit square (as pbrt-v4 does), and the exact density
//! of any direction under either.
//!
//! Arvo's map takes `(u1, u2)` in the unit square to the spherical triangle `ABC`: `u1`
//! picks the point `C'` on arc `AC` for which the sub-triangle `ABC'` has area
//! `u1 · Ω`, and `u2` a point on arc `BC'` with `1 − cos` (from `B`) in proportion to
//! `u2`. It is area-preserving, so the density is `1 / Ω`. The map is inverted for
//! the density of a warped direction: `C'` is where the great circle through `B` and
//! the direction meets arc `AC`.
//!
//! Computed in `f64`: the angles of a small spherical triangle are nearly supplementary
//! and its area, `α + β + γ − π`, is a small difference of large numbers.

use glam::{DVec3, Vec3};

use std::f64::consts::PI;

/// The triangle's vertices seen from a point, as unit directions.
#[derive(Clone, Copy, Debug)]
pub struct SphericalTriangle {
    a: DVec3,
    b: DVec3,
    c: DVec3,
    /// Interior angle at `a`.
    alpha: f64,
    /// Solid angle (area on the unit sphere).
    area: f64,
}

/// Bilinear weights over the unit square of Arvo's map, at its corners (0,0), (1,0),
/// (0,1), (1,1): the map sends both corners with `u2 = 0` to `B`, `(0,1)` to `A` and
/// `(1,1)` to `C`.
pub type Warp = [f64; 4];

impl SphericalTriangle {
    /// The triangle `vertices` as seen from `p`; `None` when it is degenerate from
    /// there (a vertex at `p`, or all three on one great circle).
    #[inline]
    pub fn new(p: Vec3, vertices: [Vec3; 3]) -> Option<Self> {
        let p = p.as_dvec3();
        let [a, b, c] = vertices.map(|v| (v.as_dvec3() - p).normalize_or_zero());
        // Normals of the great circles through each side, oriented alike.
        let ab = a.cross(b).normalize_or_zero();
        let bc = b.cross(c).normalize_or_zero();
        let ca = c.cross(a).normalize_or_zero();
        if ab == DVec3::ZERO || bc == DVec3::ZERO || ca == DVec3::ZERO {
            return None;
        }
        let angle = |n1: DVec3, n2: DVec3| angle_between(n1, -n2);
        let alpha = angle(ab, ca);
        let beta = angle(bc, ab);
        let gamma = angle(ca, bc);
        let area = alpha + beta + gamma - PI;
        (area.is_finite() && area > 0.0).then_some(SphericalTriangle {
            a,
            b,
            c,
            alpha,
            area,
        })
    }

    /// Solid angle in steradians.
    #[inline]
    pub fn solid_angle(&self) -> f64 {
        self.area
    }

    /// The corner weights of the warp for a receiver with unit normal `n`: the
    /// cosine (either side) towards each corner's direction, floored at 0.01 so that
    /// no part of the triangle gets density 0.
    #[inline]
    pub fn cosine_warp(&self, n: Vec3) -> Warp {
        let n = n.as_dvec3();
        let w = |d: DVec3| n.dot(d).abs().max(0.01);
        [w(self.b), w(self.b), w(self.a), w(self.c)]
    }

    /// The direction for `u` in the unit square: uniform in solid angle (Arvo).
    #[inline]
    pub fn sample(&self, [u1, u2]: [f64; 2]) -> DVec3 {
        let (a, b, c) = (self.a, self.b, self.c);
        let (sin_alpha, cos_alpha) = self.alpha.sin_cos();
        // The sub-triangle's area, and from it the cosine of arc AC'.
        let (s, t) = (u1 * self.area - self.alpha).sin_cos();
        let u = t - cos_alpha;
        let v = s + sin_alpha * a.dot(b);
        let q = ((v * t - u * s) * cos_alpha - v) / ((v * s + u * t) * sin_alpha);
        let q = if q.is_finite() {
            q.clamp(-1.0, 1.0)
        } else {
            1.0
        };
        let c_prime = q * a + (1.0 - q * q).max(0.0).sqrt() * orthogonal(c, a);
        // A point on arc BC' with 1 − cos from B in proportion to u2.
        let z = 1.0 - u2 * (1.0 - c_prime.dot(b));
        let z = z.clamp(-1.0, 1.0);
        z * b + (1.0 - z * z).max(0.0).sqrt() * orthogonal(c_prime, b)
    }

    /// The point of the unit square that [`sample`](Self::sample) maps to unit `w`,
    /// a direction inside the triangle.
    #[inline]
    pub fn invert(&self, w: DVec3) -> [f64; 2] {
        let (a, b, c) = (self.a, self.b, self.c);
        // C': the great circle through B and w meets the one through A and C.
        let mut c_prime = b.cross(w).cross(c.cross(a)).normalize_or_zero();
        if c_prime.dot(a + c) < 0.0 {
            c_prime = -c_prime;
        }
        let u1 = unit_area(a, b, c_prime) / self.area;
        let far = 1.0 - c_prime.dot(b);
        let u2 = if far > 0.0 {
            (1.0 - w.dot(b)) / far
        } else {
            0.0
        };
        [u1.clamp(0.0, 1.0), u2.clamp(0.0, 1.0)]
    }

    /// The solid-angle density of `w` when `u` is drawn from the warp (uniform when
    /// `warp` is `None`) and mapped by [`sample`](Self::sample).
    #[inline]
    pub fn density(&self, w: DVec3, warp: Option<&Warp>) -> f64 {
        match warp {
            None => 1.0 / self.area,
            Some(warp) => bilinear_density(warp, self.invert(w)) / self.area,
        }
    }
}

/// The area of the spherical triangle of three unit directions (Van Oosterom and
/// Strackee's formula, stable for small and large triangles alike).
#[inline]
fn unit_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let triple = a.dot(b.cross(c)).abs();
    let denominator = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * triple.atan2(denominator)
}

/// The angle between unit vectors, accurate for nearly parallel and nearly opposite
/// ones (unlike `acos` of the dot product).
#[inline]
fn angle_between(v1: DVec3, v2: DVec3) -> f64 {
    if v1.dot(v2) < 0.0 {
        PI - 2.0 * ((v1 + v2).length() / 2.0).clamp(-1.0, 1.0).asin()
    } else {
        2.0 * ((v2 - v1).length() / 2.0).clamp(-1.0, 1.0).asin()
    }
}

/// The unit vector along the part of `v` orthogonal to unit `w`.
#[inline]
fn orthogonal(v: DVec3, w: DVec3) -> DVec3 {
    (v - v.dot(w) * w).normalize_or_zero()
}

/// Draws `u` in the unit square from the bilinear density with corner weights `warp`
/// (all positive), by inverting the marginal in `u2` and then the conditional in `u1`.
#[inline]
pub fn sample_bilinear(warp: &Warp, [u1, u2]: [f64; 2]) -> [f64; 2] {
    let [w00, w10, w01, w11] = *warp;
    let y = sample_linear(u2, w00 + w10, w01 + w11);
    let x = sample_linear(u1, w00 + (w01 - w00) * y, w10 + (w11 - w10) * y);
    [x, y]
}

/// The density of [`sample_bilinear`] at `u`.
#[inline]
pub fn bilinear_density(warp: &Warp, [x, y]: [f64; 2]) -> f64 {
    let [w00, w10, w01, w11] = *warp;
    let value =
        (1.0 - x) * (1.0 - y) * w00 + x * (1.0 - y) * w10 + (1.0 - x) * y * w01 + x * y * w11;
    4.0 * value / (w00 + w10 + w01 + w11)
}

/// Inverts the CDF of the density on [0, 1] proportional to `(1 − x)·a + x·b`
/// (`a, b > 0`), in the form `u(a + b) / (a + sqrt(lerp(u, a², b²)))`, which has no
/// cancellation and needs no special case for `a = b`.
#[inline]
fn sample_linear(u: f64, a: f64, b: f64) -> f64 {
    let root = (a * a + u * (b * b - a * a)).max(0.0).sqrt();
    (u * (a + b) / (a + root)).clamp(0.0, 1.0)
}

/// The unit square's corner weights as the warp chooses them: `None` (uniform in
/// solid angle) when they are within 10% of each other, where the warp would change
/// little and cost an inversion for every density.
#[inline]
pub fn worthwhile(warp: Warp) -> Option<Warp> {
    let lo = warp.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = warp.iter().copied().fold(0.0, f64::max);
    (hi > 1.1 * lo).then_some(warp)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle() -> SphericalTriangle {
        SphericalTriangle::new(
            Vec3::new(0.1, -0.3, 0.2),
            [
                Vec3::new(-1.0, 1.0, -0.5),
                Vec3::new(1.5, 0.8, -1.0),
                Vec3::new(0.2, 1.2, 1.3),
            ],
        )
        .unwrap()
    }

    #[test]
    fn inversion_undoes_sampling() {
        let t = triangle();
        for i in 1..20 {
            for j in 1..20 {
                let u = [f64::from(i) / 20.0, f64::from(j) / 20.0];
                let back = t.invert(t.sample(u));
                assert!((back[0] - u[0]).abs() < 1e-9 && (back[1] - u[1]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn areas_agree_between_the_two_formulas() {
        let t = triangle();
        assert!((t.area - unit_area(t.a, t.b, t.c)).abs() < 1e-12 * t.area);
    }

    #[test]
    fn bilinear_sampling_inverts_its_cdf() {
        let warp = [0.2, 0.9, 0.5, 0.05];
        // The density integrates to 1, and the marginal CDF in y at the sampled y is u2.
        let n = 200;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let u = [
                    (f64::from(i) + 0.5) / f64::from(n),
                    (f64::from(j) + 0.5) / f64::from(n),
                ];
                sum += bilinear_density(&warp, u);
            }
        }
        assert!((sum / f64::from(n * n) - 1.0).abs() < 1e-9);
        for u2 in [0.1, 0.5, 0.93] {
            let [_, y] = sample_bilinear(&warp, [0.3, u2]);
            let (a, b) = (warp[0] + warp[1], warp[2] + warp[3]);
            let cdf = (a * y + (b - a) * y * y / 2.0) / ((a + b) / 2.0);
            assert!((cdf - u2).abs() < 1e-12);
        }
    }
}
