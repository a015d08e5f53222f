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
//! object split's axis only, and bounded by a budget of extra references that each
//! node shares between its children in proportion to their size (so the tree does not
//! depend on the order in which workers reach the nodes).

use glam::Vec3A;

use super::aabb::{Aabb, PrimRef};
use super::clip::split_box;
use super::sah::{blocks, ObjectSplit, TRAVERSAL_COST};

/// Bins of the node's box on the split axis for the spatial sweep (16 built no better
/// trees on Sponza than 8, and clipped large triangles twice as often).
const SPATIAL_BINS: usize = 8;
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
}

/// The spatial bins of a node on one axis: planes at equal steps across its box.
#[derive(Clone, Copy)]
struct Planes {
    axis: usize,
    lo: f32,
    extent: f32,
}

impl Planes {
    /// The bin that holds coordinate `x`.
    fn bin(&self, x: f32) -> usize {
        let scale = SPATIAL_BINS as f32 / self.extent;
        (((x - self.lo) * scale).max(0.0) as usize).min(SPATIAL_BINS - 1)
    }

    /// The plane below bin `k`.
    fn plane(&self, k: usize) -> f32 {
        self.lo + k as f32 * (self.extent / SPATIAL_BINS as f32)
    }

    /// The first and last bin a reference's box touches.
    fn span(&self, r: &PrimRef) -> (usize, usize) {
        let b = r.aabb();
        (self.bin(b.lo[self.axis]), self.bin(b.hi[self.axis]))
    }
}

/// Per bin: the box of the triangles' parts inside it, and how many references start
/// (enter) and end (exit) in it.
struct SpatialBins {
    boxes: [Aabb; SPATIAL_BINS],
    enter: [u32; SPATIAL_BINS],
    exit: [u32; SPATIAL_BINS],
}

impl Spatial<'_> {
    /// If a spatial split of `refs` (in the box `bounds`) is cheaper than `object`
    /// and adds at most `budget` references, the references of its two sides. On equal
    /// costs the object split wins, and among planes the lowest, so the choice is
    /// strict and the same on every run.
    pub fn try_split(
        &self,
        refs: &[PrimRef],
        bounds: Aabb,
        object: &ObjectSplit,
        budget: usize,
    ) -> Option<(Vec<PrimRef>, Vec<PrimRef>)> {
        let axis = object.axis;
        let overlap = object.left.intersect(object.right);
        let extent = bounds.hi[axis] - bounds.lo[axis];
        if budget == 0
            || overlap.is_empty()
            || overlap.half_area() <= MIN_OVERLAP_AREA * self.root_area
            || overlap.hi[axis] - overlap.lo[axis] <= MIN_OVERLAP_EXTENT * extent
        {
            return None;
        }
        let planes = Planes {
            axis,
            lo: bounds.lo[axis],
            extent,
        };
        let bins = self.bin(refs, &planes);
        let (k, cost) = best_plane(&bins, bounds)?;
        if cost >= object.cost {
            return None;
        }
        let (left, right) = self.distribute(refs, &planes, k);
        let added = left.len() + right.len() - refs.len();
        (!left.is_empty() && !right.is_empty() && added <= budget).then_some((left, right))
    }

    /// Each reference enters the bin of its low end, leaves at the bin of its high end,
    /// and adds the box of its part in each bin between.
    fn bin(&self, refs: &[PrimRef], planes: &Planes) -> SpatialBins {
        let mut bins = SpatialBins {
            boxes: [Aabb::EMPTY; SPATIAL_BINS],
            enter: [0; SPATIAL_BINS],
            exit: [0; SPATIAL_BINS],
        };
        for r in refs {
            let rb = r.aabb();
            let (b0, b1) = planes.span(r);
            bins.enter[b0] += 1;
            bins.exit[b1] += 1;
            if b0 == b1 {
                bins.boxes[b0] = bins.boxes[b0].union(rb);
                continue;
            }
            let tri = (self.corners)(r.id());
            let mut rest = rb;
            for (b, slot) in bins.boxes.iter_mut().enumerate().take(b1).skip(b0) {
                let (part, above) = split_box(&tri, rest, planes.axis, planes.plane(b + 1));
                *slot = slot.union(part);
                rest = above;
            }
            bins.boxes[b1] = bins.boxes[b1].union(rest);
        }
        bins
    }

    /// The references below and above plane `k`; a reference that straddles it goes to
    /// both sides, each with the box of its part there.
    fn distribute(
        &self,
        refs: &[PrimRef],
        planes: &Planes,
        k: usize,
    ) -> (Vec<PrimRef>, Vec<PrimRef>) {
        let at = planes.plane(k);
        let (mut left, mut right) = (
            Vec::with_capacity(refs.len()),
            Vec::with_capacity(refs.len()),
        );
        for r in refs {
            let (b0, b1) = planes.span(r);
            if b1 < k {
                left.push(*r);
            } else if b0 >= k {
                right.push(*r);
            } else {
                let (l, h) = split_box(&(self.corners)(r.id()), r.aabb(), planes.axis, at);
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
        (left, right)
    }
}

/// The cheapest plane of the SAH sweep over `bins` (a node with box `bounds`) and its
/// cost; the lowest plane on equal costs.
fn best_plane(bins: &SpatialBins, bounds: Aabb) -> Option<(usize, f32)> {
    let inv_area = 1.0 / bounds.half_area().max(f32::MIN_POSITIVE);
    let mut right_cost = [0.0f32; SPATIAL_BINS];
    let (mut box_r, mut n_r) = (Aabb::EMPTY, 0u32);
    for b in (1..SPATIAL_BINS).rev() {
        box_r = box_r.union(bins.boxes[b]);
        n_r += bins.exit[b];
        right_cost[b] = box_r.half_area() * blocks(n_r as usize);
    }
    let mut best: Option<(usize, f32)> = None;
    let (mut box_l, mut n_l) = (Aabb::EMPTY, 0u32);
    #[allow(clippy::needless_range_loop)] // `k` indexes two arrays at offsets
    for k in 1..SPATIAL_BINS {
        box_l = box_l.union(bins.boxes[k - 1]);
        n_l += bins.enter[k - 1];
        if n_l == 0 || right_cost[k] == 0.0 {
            continue;
        }
        let cost =
            TRAVERSAL_COST + (box_l.half_area() * blocks(n_l as usize) + right_cost[k]) * inv_area;
        if best.is_none_or(|(_, c)| cost < c) {
            best = Some((k, cost));
        }
    }
    best
}
