//! The surface area heuristic's costs, which the object and the spatial splits both
//! weigh: the expected cost of a ray meeting a node is the cost of visiting it plus, per
//! child, the child's share of the surface area times the triangle blocks inside it.

use super::aabb::Aabb;

/// Cost of visiting a node relative to one ray/triangle test.
pub const TRAVERSAL_COST: f32 = 2.0;
/// Intersection cost of `n` triangles: leaves test them four at a time.
#[inline]
pub fn blocks(n: usize) -> f32 {
    n.div_ceil(4) as f32
}

/// A binned object split: axis, number of bins on the left, SAH cost, and the boxes
/// of the two sides (from the sample when the range was sampled).
#[derive(Clone, Copy)]
pub struct ObjectSplit {
    pub axis: usize,
    pub bins_left: usize,
    pub cost: f32,
    pub left: Aabb,
    pub right: Aabb,
}
