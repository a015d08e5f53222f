//! Spatial splits (Stich, Friedrich and Dietrich, "Spatial Splits in Bounding Volume
//! Hierarchies", HPG 2009): where the two sides of the best object split overlap much,
//! split space instead, at a plane, and give the triangles that straddle it to both
//! sides, each with the box of its part on that side. Large triangles (floors, walls,
//! columns) then stop inflating every box they touch, which presplitting by area alone
//! only partly achieves.
//!
//! Kept cheap: tried only where the overlap is large both against the whole scene (the
//! SAH gain is proportional to it) and along the split axis (a tessellated surface has
//! thin overlaps of one triangle's width, where nothing is gained), binned on the
//! object split's axis only, and bounded by a global budget of extra references.

use std::sync::atomic::{AtomicIsize, Ordering};

use glam::Vec3A;

use super::build::{blocks, Aabb, ObjectSplit, PrimRef, TRAVERSAL_COST};

/// Bins of the node's box on the split axis for the spatial sweep (16 built no better
/// trees on Sponza than 8, and clipped large triangles twice as often).
const BINS: usize = 8;
/// Try a spatial split only where the object split's overlap has more than this
/// fraction of the root's surface area. Stich et al. suggest 1e-5; higher spends the
/// budget near the root, where it pays most, and builds faster.
const MIN_OVERLAP_AREA: f32 = 1e-3;
/// ... and more than this fraction of the node's extent along the split axis.
const MIN_OVERLAP_EXTENT: f32 = 0.05;
/// Most extra references spatial splits may add, as a fraction of the references.
pub const BUDGET: f32 = 0.3;

/// What spatial splits share across one build.
pub struct Spatial<'a> {
    /// A triangle's corners by its index.
    pub corners: &'a (dyn Fn(u32) -> [Vec3A; 3] + Sync),
    /// Half the surface area of the root's box.
    pub root_area: f32,
    /// References spatial splits may still add.
    pub budget: AtomicIsize,
}

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

impl Spatial<'_> {
    /// If a spatial split of `refs` (in the box `bounds`) is cheaper than `object`
    /// and the budget allows it, the references of its two sides.
    pub fn try_split(
        &self,
        refs: &[PrimRef],
        bounds: Aabb,
        object: &ObjectSplit,
    ) -> Option<(Vec<PrimRef>, Vec<PrimRef>)> {
        let axis = object.axis;
        let overlap = object.left.intersect(object.right);
        let extent = bounds.hi[axis] - bounds.lo[axis];
        if overlap.is_empty()
            || overlap.half_area() <= MIN_OVERLAP_AREA * self.root_area
            || overlap.hi[axis] - overlap.lo[axis] <= MIN_OVERLAP_EXTENT * extent
            || self.budget.load(Ordering::Relaxed) <= 0
        {
            return None;
        }
        let scale = BINS as f32 / extent;
        let bin = |x: f32| (((x - bounds.lo[axis]) * scale).max(0.0) as usize).min(BINS - 1);
        let plane = |k: usize| bounds.lo[axis] + k as f32 * (extent / BINS as f32);

        // Each reference enters the bin of its low end, leaves at the bin of its high
        // end, and adds the box of its part in each bin between.
        let mut boxes = [Aabb::EMPTY; BINS];
        let (mut enter, mut exit) = ([0u32; BINS], [0u32; BINS]);
        for r in refs {
            let rb = r.aabb();
            let (b0, b1) = (bin(rb.lo[axis]), bin(rb.hi[axis]));
            enter[b0] += 1;
            exit[b1] += 1;
            if b0 == b1 {
                boxes[b0] = boxes[b0].union(rb);
                continue;
            }
            let tri = (self.corners)(r.id());
            let mut rest = rb;
            for (b, slot) in boxes.iter_mut().enumerate().take(b1).skip(b0) {
                let (part, above) = split_box(&tri, rest, axis, plane(b + 1));
                *slot = slot.union(part);
                rest = above;
            }
            boxes[b1] = boxes[b1].union(rest);
        }

        let inv_area = 1.0 / bounds.half_area().max(f32::MIN_POSITIVE);
        let mut right_cost = [0.0f32; BINS];
        let (mut box_r, mut n_r) = (Aabb::EMPTY, 0u32);
        for b in (1..BINS).rev() {
            box_r = box_r.union(boxes[b]);
            n_r += exit[b];
            right_cost[b] = box_r.half_area() * blocks(n_r as usize);
        }
        let mut best: Option<(usize, f32)> = None;
        let (mut box_l, mut n_l) = (Aabb::EMPTY, 0u32);
        for k in 1..BINS {
            box_l = box_l.union(boxes[k - 1]);
            n_l += enter[k - 1];
            if n_l == 0 || right_cost[k] == 0.0 {
                continue;
            }
            let cost = TRAVERSAL_COST
                + (box_l.half_area() * blocks(n_l as usize) + right_cost[k]) * inv_area;
            if best.map_or(true, |(_, c)| cost < c) {
                best = Some((k, cost));
            }
        }
        let (k, cost) = best?;
        if cost >= object.cost {
            return None;
        }

        let at = plane(k);
        let (mut left, mut right) = (Vec::with_capacity(refs.len()), Vec::new());
        right.reserve(refs.len());
        for r in refs {
            let rb = r.aabb();
            let (b0, b1) = (bin(rb.lo[axis]), bin(rb.hi[axis]));
            if b1 < k {
                left.push(*r);
            } else if b0 >= k {
                right.push(*r);
            } else {
                let (l, h) = split_box(&(self.corners)(r.id()), rb, axis, at);
                let piece = |b: Aabb| PrimRef::new(b.lo, b.hi, r.id());
                match (l.is_empty(), h.is_empty()) {
                    (false, false) => {
                        left.push(piece(l));
                        right.push(piece(h));
                    }
                    (false, true) => left.push(piece(l)),
                    (true, false) => right.push(piece(h)),
                    // Rounding lost both parts: keep the whole reference.
                    (true, true) => left.push(*r),
                }
            }
        }
        if left.is_empty() || right.is_empty() {
            return None;
        }
        let added = (left.len() + right.len() - refs.len()) as isize;
        if self.budget.fetch_sub(added, Ordering::Relaxed) < added {
            self.budget.fetch_add(added, Ordering::Relaxed);
            return None;
        }
        Some((left, right))
    }
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
