//! The surface area heuristic's costs, which the object and the spatial splits both
//! weigh: the expected cost of a ray meeting a node is the cost of visiting it plus, per
//! child, the child's share of the surface area times the triangle blocks inside it.

use super::aabb::Aabb;

/// Cost of visiting a node relative to one test of a block of four triangles. It
/// decides only between a leaf and a split (every split pays it once): 0.5 makes
/// leaves of two blocks where the two sides' boxes would cover 1.5 times the node's
/// area. With 8-wide nodes, bvh_ab against 1: bunny diffuse 0.81 -> 0.85 of Embree,
/// Sponza and staircase shadow 2-5% slower (0.87 -> 0.85, 1.14 -> 1.09): the lowest
/// ratio 0.85 instead of 0.81. (With 4-wide nodes, 2 - leaves of two blocks wherever
/// allowed - was 2-5% slower on diffuse rays.)
pub const TRAVERSAL_COST: f32 = 0.5;
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
