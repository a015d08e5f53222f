//! Clipping a triangle at an axis-aligned plane, for the builder's references: the boxes
//! of its parts on either side. Spatial splits and presplitting both cut triangles with
//! it. The crossing points are widened by a few ulps, so the boxes surely hold the
//! exact triangle despite the rounding of the crossing.

use glam::Vec3A;

use super::aabb::Aabb;

/// The boxes of the parts of triangle `tri` inside `b` below and above `at` on `axis`
/// (either may be empty).
pub fn split_box(tri: &[Vec3A; 3], b: Aabb, axis: usize, at: f32) -> (Aabb, Aabb) {
    let (mut lo_side, mut hi_side) = (Aabb::EMPTY, Aabb::EMPTY);
    for i in 0..3 {
        let (p, q) = (tri[i], tri[(i + 1) % 3]);
        let (dp, dq) = (p[axis], q[axis]);
        if dp <= at {
            lo_side = lo_side.grow(p);
        }
        if dp >= at {
            hi_side = hi_side.grow(p);
        }
        if (dp < at && at < dq) || (dq < at && at < dp) {
            let x = p + (q - p) * ((at - dp) / (dq - dp));
            // The crossing is rounded: widen it by a few ulps across the plane's axes,
            // so the boxes still hold the exact triangle.
            let mut e = x.abs() * (4.0 * f32::EPSILON);
            e[axis] = 0.0;
            let (mut a, mut c) = (x - e, x + e);
            a[axis] = at;
            c[axis] = at;
            lo_side = lo_side.grow(a).grow(c);
            hi_side = hi_side.grow(a).grow(c);
        }
    }
    (lo_side.intersect(b), hi_side.intersect(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_box_bounds_each_side_of_the_plane() {
        let tri = [
            Vec3A::new(0.0, 0.0, 0.0),
            Vec3A::new(4.0, 1.0, 0.5),
            Vec3A::new(1.0, 3.0, -0.5),
        ];
        let whole = Aabb::EMPTY.grow(tri[0]).grow(tri[1]).grow(tri[2]);
        let at = 1.7;
        let (lo, hi) = split_box(&tri, whole, 0, at);
        assert!(lo.hi.x <= at && hi.lo.x >= at);
        // Points of the triangle lie in the box of their side.
        let mut rng = crate::sampling::Rng::seeded(3);
        for _ in 0..10_000 {
            let (u, v) = crate::sampling::uniform_triangle(rng.f32(), rng.f32());
            let p = (1.0 - u - v) * tri[0] + u * tri[1] + v * tri[2];
            let side = if p.x <= at { lo } else { hi };
            assert!(p.cmpge(side.lo).all() && p.cmple(side.hi).all(), "{p}");
        }
        // Clipped to a box that holds only part of the triangle.
        let part = Aabb {
            lo: Vec3A::new(0.0, 0.0, -1.0),
            hi: Vec3A::new(1.0, 1.0, 1.0),
        };
        let (lo, hi) = split_box(&tri, part, 0, at);
        assert!(!lo.is_empty() && hi.is_empty());
    }
}
