//! The watertight ray/triangle test of Woop, Benthin and Wald, "Watertight Ray/Triangle
//! Intersection" (JCGT 2013): the ray is sheared and permuted so that it points along
//! +z from the origin, and the triangle is tested in 2D with edge functions. A ray that
//! passes exactly through a shared edge or vertex hits at least one of the triangles
//! that share it (no cracks), which the Möller–Trumbore test cannot promise.

use glam::{Vec3, Vec3A};

/// The per-ray constants of the test: the axis permutation and the shear.
#[derive(Clone, Copy, Debug)]
pub struct RayShear {
    pub origin: [f32; 3],
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    pub sx: f32,
    pub sy: f32,
    pub sz: f32,
}

impl RayShear {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        let a = dir.abs();
        // The dimension where the direction is largest becomes z; chosen with selects
        // rather than branches, which random directions would mispredict.
        let kz = if a.x > a.y {
            2 - 2 * usize::from(a.x > a.z)
        } else {
            2 - usize::from(a.y > a.z)
        };
        let d = dir.to_array();
        // Keep the winding: swapping x and y when z flips preserves the edge signs.
        let flip = usize::from(d[kz] < 0.0);
        let kx = (kz + 1 + flip) % 3;
        let ky = (kz + 2 - flip) % 3;
        // One packed division for the three quotients (each rounds as it would alone).
        let [sx, sy, sz] = (Vec3A::new(d[kx], d[ky], 1.0) / d[kz]).to_array();
        RayShear {
            origin: origin.to_array(),
            kx,
            ky,
            kz,
            sx,
            sy,
            sz,
        }
    }

    /// The hit of the ray with triangle `(v0, v1, v2)` for `t` in `[tmin, tmax]`, as
    /// `(t, u, v)` with Embree's barycentrics (`u` weighs `v1`, `v` weighs `v2`). The
    /// one-triangle form of the test, the reference the four-wide form is checked with.
    #[cfg(test)]
    pub fn intersect(&self, tri: &[[f32; 3]; 3], tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        let o = self.origin;
        let rel = |p: &[f32; 3]| [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        let (a, b, c) = (rel(&tri[0]), rel(&tri[1]), rel(&tri[2]));
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];

        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        // On an edge, f32 rounding decides the sign; redo the edge functions in f64,
        // where these products of f32 are exact, so neighbours agree on the edge.
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let (ax, ay, bx, by, cx, cy) = (
                f64::from(ax),
                f64::from(ay),
                f64::from(bx),
                f64::from(by),
                f64::from(cx),
                f64::from(cy),
            );
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        // Both faces count: the ray must see all three edges from the same side.
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t_scaled = u * az + v * bz + w * cz;
        // Compare t = t_scaled / det with the interval without dividing.
        let sign = det.signum();
        let (ts, ad) = (t_scaled * sign, det.abs());
        if !(ts >= tmin * ad && ts <= tmax * ad) {
            return None;
        }
        let inv = 1.0 / det;
        Some((t_scaled * inv, v * inv, w * inv))
    }
}

/// Four triangles side by side, `v[vertex][axis][lane]`, with their mesh indices. Unused
/// lanes have NaN vertices, which every comparison of the test rejects.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct TriBlock {
    pub v: [[[f32; 4]; 3]; 3],
    pub prim: [u32; 4],
}

impl TriBlock {
    /// Up to four triangles as a block.
    pub fn new(tris: &[([[f32; 3]; 3], u32)]) -> Self {
        debug_assert!(!tris.is_empty() && tris.len() <= 4);
        let mut block = TriBlock {
            v: [[[f32::NAN; 4]; 3]; 3],
            prim: [u32::MAX; 4],
        };
        for (lane, (corners, prim)) in tris.iter().enumerate() {
            for (vertex, p) in corners.iter().enumerate() {
                for (axis, &c) in p.iter().enumerate() {
                    block.v[vertex][axis][lane] = c;
                }
            }
            block.prim[lane] = *prim;
        }
        block
    }

    /// The distance along `origin + t·dir` to the plane of lane `lane`'s triangle,
    /// computed in f64 (differences of f32 are exact there, and the products that
    /// follow lose ~1e-16 rather than ~1e-7), or `None`
    /// for a ray parallel to it. The sheared test's `t` is a ratio of edge functions
    /// that cancel on long slivers (a Sponza cornice: 5e-5 relative error); the hit
    /// that traversal settles on is re-measured with this, once per ray.
    pub fn plane_distance(&self, lane: usize, origin: Vec3, dir: Vec3) -> Option<f32> {
        let corner = |vertex: usize| {
            let p = &self.v[vertex];
            glam::DVec3::new(
                f64::from(p[0][lane]),
                f64::from(p[1][lane]),
                f64::from(p[2][lane]),
            )
        };
        let (a, b, c) = (corner(0), corner(1), corner(2));
        let normal = (b - a).cross(c - a);
        let facing = dir.as_dvec3().dot(normal);
        let t = (a - origin.as_dvec3()).dot(normal) / facing;
        (facing != 0.0 && t.is_finite()).then_some(t as f32)
    }
}

/// The test on four triangles at once: lanes that hit, the scaled distance and the
/// edge functions of each lane (divide by `det` for `t` and barycentrics).
struct Lanes {
    hit: [bool; 4],
    t_scaled: [f32; 4],
    det: [f32; 4],
    v: [f32; 4],
    w: [f32; 4],
}

impl RayShear {
    /// [`RayShear::intersect`] on the four triangles of `block`, written as loops over
    /// lanes that the compiler turns into SIMD.
    #[inline(always)]
    fn lanes(&self, block: &TriBlock, tmin: f32, tmax: f32) -> Lanes {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let o = self.origin;
        let (mut x, mut y, mut z) = ([[0.0f32; 4]; 3], [[0.0f32; 4]; 3], [[0.0f32; 4]; 3]);
        for vertex in 0..3 {
            let p = &block.v[vertex];
            for lane in 0..4 {
                let (px, py, pz) = (
                    p[kx][lane] - o[kx],
                    p[ky][lane] - o[ky],
                    p[kz][lane] - o[kz],
                );
                x[vertex][lane] = px - self.sx * pz;
                y[vertex][lane] = py - self.sy * pz;
                z[vertex][lane] = self.sz * pz;
            }
        }
        let (mut u, mut v, mut w) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
        let mut any_zero = false;
        for lane in 0..4 {
            let (ax, ay, bx, by, cx, cy) = (
                x[0][lane], y[0][lane], x[1][lane], y[1][lane], x[2][lane], y[2][lane],
            );
            u[lane] = cx * by - cy * bx;
            v[lane] = ax * cy - ay * cx;
            w[lane] = bx * ay - by * ax;
            // `|` and `&` rather than `||` and `&&` throughout: no branches, so SIMD.
            any_zero |= (u[lane] == 0.0) | (v[lane] == 0.0) | (w[lane] == 0.0);
        }
        if any_zero {
            // Rare: a lane on an edge; redo it exactly in f64 (see `intersect`).
            for lane in 0..4 {
                if u[lane] == 0.0 || v[lane] == 0.0 || w[lane] == 0.0 {
                    let d = |a: f32| f64::from(a);
                    let (ax, ay, bx, by, cx, cy) = (
                        d(x[0][lane]),
                        d(y[0][lane]),
                        d(x[1][lane]),
                        d(y[1][lane]),
                        d(x[2][lane]),
                        d(y[2][lane]),
                    );
                    u[lane] = (cx * by - cy * bx) as f32;
                    v[lane] = (ax * cy - ay * cx) as f32;
                    w[lane] = (bx * ay - by * ax) as f32;
                }
            }
        }
        let mut out = Lanes {
            hit: [false; 4],
            t_scaled: [0.0; 4],
            det: [0.0; 4],
            v,
            w,
        };
        for lane in 0..4 {
            let (u, v, w) = (u[lane], v[lane], w[lane]);
            let same_side =
                ((u >= 0.0) & (v >= 0.0) & (w >= 0.0)) | ((u <= 0.0) & (v <= 0.0) & (w <= 0.0));
            let det = u + v + w;
            let ts = u * z[0][lane] + v * z[1][lane] + w * z[2][lane];
            // Flip both by the sign of det so the interval test needs no division.
            let tsa = f32::from_bits(ts.to_bits() ^ (det.to_bits() & 0x8000_0000));
            let da = det.abs();
            out.hit[lane] = same_side & (det != 0.0) & (tsa >= tmin * da) & (tsa <= tmax * da);
            out.t_scaled[lane] = ts;
            out.det[lane] = det;
        }
        out
    }

    /// The nearest hit in `block` with `t` in `[tmin, tmax]`: `(lane, t, u, v)`.
    #[inline(always)]
    pub fn intersect4(
        &self,
        block: &TriBlock,
        tmin: f32,
        tmax: f32,
    ) -> Option<(usize, f32, f32, f32)> {
        let l = self.lanes(block, tmin, tmax);
        if l.hit == [false; 4] {
            return None;
        }
        let mut best: Option<(usize, f32)> = None;
        for lane in 0..4 {
            if l.hit[lane] {
                let t = l.t_scaled[lane] / l.det[lane];
                if best.is_none_or(|(_, bt)| t < bt) {
                    best = Some((lane, t));
                }
            }
        }
        best.map(|(lane, t)| {
            let inv = 1.0 / l.det[lane];
            (lane, t, l.v[lane] * inv, l.w[lane] * inv)
        })
    }

    /// Whether any triangle of `block` is hit with `t` in `[tmin, tmax]`.
    #[inline(always)]
    pub fn occluded4(&self, block: &TriBlock, tmin: f32, tmax: f32) -> bool {
        self.lanes(block, tmin, tmax).hit != [false; 4]
    }

    /// [`RayShear::intersect4`] counting only the intersections `accept(lane, u, v)`
    /// takes: the nearest accepted one. `accept` is asked only about intersections
    /// nearer than the best so far.
    #[inline(always)]
    pub fn intersect4_filtered(
        &self,
        block: &TriBlock,
        tmin: f32,
        tmax: f32,
        accept: impl Fn(usize, f32, f32) -> bool,
    ) -> Option<(usize, f32, f32, f32)> {
        let l = self.lanes(block, tmin, tmax);
        if l.hit == [false; 4] {
            return None;
        }
        let mut best: Option<(usize, f32, f32, f32)> = None;
        for lane in 0..4 {
            if !l.hit[lane] {
                continue;
            }
            let t = l.t_scaled[lane] / l.det[lane];
            if best.is_some_and(|(_, bt, _, _)| t >= bt) {
                continue;
            }
            let inv = 1.0 / l.det[lane];
            let (u, v) = (l.v[lane] * inv, l.w[lane] * inv);
            if accept(lane, u, v) {
                best = Some((lane, t, u, v));
            }
        }
        best
    }

    /// [`RayShear::occluded4`] counting only the intersections `accept(lane, u, v)` takes.
    #[inline(always)]
    pub fn occluded4_filtered(
        &self,
        block: &TriBlock,
        tmin: f32,
        tmax: f32,
        accept: impl Fn(usize, f32, f32) -> bool,
    ) -> bool {
        let l = self.lanes(block, tmin, tmax);
        (0..4).any(|lane| {
            l.hit[lane] && {
                let inv = 1.0 / l.det[lane];
                accept(lane, l.v[lane] * inv, l.w[lane] * inv)
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    #[test]
    fn hits_with_embree_barycentrics() {
        // Aim at p = 0.5 v0 + 0.2 v1 + 0.3 v2 = (0.2, 0.3, 0) from above.
        let s = RayShear::new(Vec3::new(0.2, 0.3, 2.0), Vec3::new(0.0, 0.0, -0.5));
        let (t, u, v) = s.intersect(&TRI, 0.0, f32::INFINITY).unwrap();
        assert!((t - 4.0).abs() < 1e-6, "t = {t}");
        assert!((u - 0.2).abs() < 1e-6 && (v - 0.3).abs() < 1e-6, "{u} {v}");
        // From below (back face) too, with the same barycentrics.
        let s = RayShear::new(Vec3::new(0.2, 0.3, -1.0), Vec3::Z);
        let (t, u, v) = s.intersect(&TRI, 0.0, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-6 && (u - 0.2).abs() < 1e-6 && (v - 0.3).abs() < 1e-6);
    }

    #[test]
    fn respects_the_interval_and_misses_outside() {
        let s = RayShear::new(Vec3::new(0.2, 0.3, 2.0), -Vec3::Z);
        assert!(s.intersect(&TRI, 0.0, 1.9).is_none());
        assert!(s.intersect(&TRI, 2.1, 5.0).is_none());
        let s = RayShear::new(Vec3::new(0.8, 0.8, 2.0), -Vec3::Z);
        assert!(s.intersect(&TRI, 0.0, f32::INFINITY).is_none());
        // Parallel to the plane.
        let s = RayShear::new(Vec3::new(-1.0, 0.2, 0.0), Vec3::X);
        assert!(s.intersect(&TRI, 0.0, f32::INFINITY).is_none());
    }

    #[test]
    fn four_wide_test_matches_the_single_test() {
        let mut rng = crate::sampling::Rng::seeded(5);
        let mut p = || {
            [
                rng.f32() * 2.0 - 1.0,
                rng.f32() * 2.0 - 1.0,
                rng.f32() * 2.0 - 1.0,
            ]
        };
        for round in 0..2000 {
            let n = 1 + round % 4;
            let tris: Vec<([[f32; 3]; 3], u32)> =
                (0..n).map(|i| ([p(), p(), p()], i as u32)).collect();
            let block = TriBlock::new(&tris);
            let origin = Vec3::from_array(p()) * 2.0;
            let dir = Vec3::from_array(p());
            let s = RayShear::new(origin, dir);
            let single = tris
                .iter()
                .enumerate()
                .filter_map(|(i, (t, _))| s.intersect(t, 0.0, 10.0).map(|h| (i, h)))
                .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0));
            let four = s.intersect4(&block, 0.0, 10.0);
            match (single, four) {
                (None, None) => assert!(!s.occluded4(&block, 0.0, 10.0)),
                (Some((i, (t, u, v))), Some((lane, t4, u4, v4))) => {
                    assert_eq!(i, lane);
                    assert!((t - t4).abs() <= 1e-6 * t.abs().max(1.0));
                    assert!((u - u4).abs() < 1e-5 && (v - v4).abs() < 1e-5);
                    assert!(s.occluded4(&block, 0.0, 10.0));
                }
                other => panic!("round {round}: {other:?}"),
            }
        }
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of the unit square; rays through points on
        // the diagonal from awkward directions must hit at least one of them.
        let a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
        let b = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        for i in 1..1000 {
            let f = i as f32 / 1000.0 * 0.731;
            let target = Vec3::new(f, f, 0.0);
            let origin = Vec3::new(0.3 + f * 0.17, -0.77 + f, 1.3 - f * 0.4);
            let s = RayShear::new(origin, target - origin);
            let hit_a = s.intersect(&a, 0.0, f32::INFINITY).is_some();
            let hit_b = s.intersect(&b, 0.0, f32::INFINITY).is_some();
            assert!(hit_a || hit_b, "crack at {target}");
        }
    }
}
