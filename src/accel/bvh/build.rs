//! The binned surface-area-heuristic (SAH) builder: a binary tree split by the best of
//! 32 bins on each axis (parallel over rayon's workers), then collapsed into 4-wide
//! nodes by repeatedly opening the child with the largest surface area.

use glam::Vec3;
use rayon::prelude::*;

use super::node::{Child, Node4, MAX_LEAF};

/// Bins per axis for the SAH sweep.
const BINS: usize = 32;
/// Cost of visiting a node relative to one ray/triangle test.
const TRAVERSAL_COST: f32 = 1.0;
/// Subtrees at least this large are built on two workers (`rayon::join`).
const PARALLEL_SUBTREE: usize = 2048;
/// Ranges at least this large are bounded and binned in parallel chunks.
const PARALLEL_SCAN: usize = 64 * 1024;
/// Below this binary depth splits follow the SAH; deeper, the object median, so the
/// tree depth (and the traversal stack) stays bounded whatever the mesh.
const SAH_DEPTH: u32 = 48;

/// An axis-aligned box; empty when `lo > hi`.
#[derive(Clone, Copy, Debug)]
pub struct Aabb {
    pub lo: Vec3,
    pub hi: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        lo: Vec3::splat(f32::INFINITY),
        hi: Vec3::splat(f32::NEG_INFINITY),
    };

    #[inline]
    fn union(self, o: Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    #[inline]
    fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            lo: self.lo.min(p),
            hi: self.hi.max(p),
        }
    }

    /// Half the surface area (the SAH only compares ratios); 0 for an empty box.
    #[inline]
    fn half_area(self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// A triangle as the builder sees it: its box and its index in the mesh.
#[derive(Clone, Copy, Debug)]
pub struct PrimRef {
    pub lo: Vec3,
    pub hi: Vec3,
    pub id: u32,
}

impl PrimRef {
    /// Twice the centroid (the factor cancels in binning).
    #[inline]
    fn centroid2(&self) -> Vec3 {
        self.lo + self.hi
    }

    #[inline]
    fn aabb(&self) -> Aabb {
        Aabb {
            lo: self.lo,
            hi: self.hi,
        }
    }
}

/// The binary tree the SAH produces; leaves are ranges of the reordered references.
enum BuildNode {
    Leaf {
        bounds: Aabb,
        first: usize,
        count: usize,
    },
    Inner {
        bounds: Aabb,
        children: Box<[BuildNode; 2]>,
    },
}

impl BuildNode {
    fn bounds(&self) -> Aabb {
        match self {
            BuildNode::Leaf { bounds, .. } | BuildNode::Inner { bounds, .. } => *bounds,
        }
    }
}

/// Box of the primitives and box of their (doubled) centroids.
fn bounds_of(refs: &[PrimRef]) -> (Aabb, Aabb) {
    let fold = |refs: &[PrimRef]| {
        refs.iter().fold((Aabb::EMPTY, Aabb::EMPTY), |(b, c), r| {
            (b.union(r.aabb()), c.grow(r.centroid2()))
        })
    };
    if refs.len() >= PARALLEL_SCAN {
        refs.par_chunks(PARALLEL_SCAN / 4).map(fold).reduce(
            || (Aabb::EMPTY, Aabb::EMPTY),
            |(a, b), (c, d)| (a.union(c), b.union(d)),
        )
    } else {
        fold(refs)
    }
}

/// Per axis, per bin: the box and count of the primitives whose centroid falls in it.
#[derive(Clone, Copy)]
struct Bins {
    bounds: [[Aabb; BINS]; 3],
    count: [[u32; BINS]; 3],
}

impl Bins {
    fn empty() -> Box<Bins> {
        Box::new(Bins {
            bounds: [[Aabb::EMPTY; BINS]; 3],
            count: [[0; BINS]; 3],
        })
    }

    fn merge(mut self: Box<Self>, o: Box<Bins>) -> Box<Bins> {
        for axis in 0..3 {
            for b in 0..BINS {
                self.bounds[axis][b] = self.bounds[axis][b].union(o.bounds[axis][b]);
                self.count[axis][b] += o.count[axis][b];
            }
        }
        self
    }
}

/// Maps a (doubled) centroid to its bin on each axis.
#[derive(Clone, Copy)]
struct Binner {
    origin: Vec3,
    scale: Vec3,
}

impl Binner {
    fn new(centroids: Aabb) -> Self {
        let extent = centroids.hi - centroids.lo;
        // Slightly under BINS so the largest centroid lands in the last bin, not past it.
        let k = BINS as f32 * (1.0 - 1e-5);
        let scale = Vec3::select(extent.cmpgt(Vec3::ZERO), k / extent, Vec3::ZERO);
        Binner {
            origin: centroids.lo,
            scale,
        }
    }

    #[inline]
    fn bin(&self, c: Vec3, axis: usize) -> usize {
        let f = (c[axis] - self.origin[axis]) * self.scale[axis];
        (f as usize).min(BINS - 1)
    }

    fn fill(&self, refs: &[PrimRef]) -> Box<Bins> {
        let mut bins = Bins::empty();
        for r in refs {
            let c = r.centroid2();
            for axis in 0..3 {
                let b = self.bin(c, axis);
                bins.bounds[axis][b] = bins.bounds[axis][b].union(r.aabb());
                bins.count[axis][b] += 1;
            }
        }
        bins
    }
}

/// The cheapest binned split: axis, number of bins on the left, SAH cost.
fn best_split(refs: &[PrimRef], bounds: Aabb, centroids: Aabb) -> Option<(usize, usize, f32)> {
    let binner = Binner::new(centroids);
    let bins = if refs.len() >= PARALLEL_SCAN {
        refs.par_chunks(PARALLEL_SCAN / 4)
            .map(|c| binner.fill(c))
            .reduce(Bins::empty, Bins::merge)
    } else {
        binner.fill(refs)
    };
    let inv_area = 1.0 / bounds.half_area().max(f32::MIN_POSITIVE);
    let mut best: Option<(usize, usize, f32)> = None;
    for axis in 0..3 {
        if binner.scale[axis] == 0.0 {
            continue;
        }
        // Sweep from the right, remembering area × count of every suffix.
        let mut right_cost = [0.0f32; BINS];
        let (mut box_r, mut n_r) = (Aabb::EMPTY, 0u32);
        for b in (1..BINS).rev() {
            box_r = box_r.union(bins.bounds[axis][b]);
            n_r += bins.count[axis][b];
            right_cost[b] = box_r.half_area() * n_r as f32;
        }
        let (mut box_l, mut n_l) = (Aabb::EMPTY, 0u32);
        for split in 1..BINS {
            box_l = box_l.union(bins.bounds[axis][split - 1]);
            n_l += bins.count[axis][split - 1];
            if n_l == 0 || n_l as usize == refs.len() {
                continue;
            }
            let cost =
                TRAVERSAL_COST + (box_l.half_area() * n_l as f32 + right_cost[split]) * inv_area;
            if best.is_none_or(|(_, _, c)| cost < c) {
                best = Some((axis, split, cost));
            }
        }
    }
    best
}

/// Moves the references that satisfy `left` to the front; returns how many there are.
fn partition(refs: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> usize {
    let (mut i, mut j) = (0, refs.len());
    while i < j {
        if left(&refs[i]) {
            i += 1;
        } else {
            j -= 1;
            refs.swap(i, j);
        }
    }
    i
}

fn build_node(refs: &mut [PrimRef], first: usize, depth: u32) -> BuildNode {
    let n = refs.len();
    let (bounds, centroids) = bounds_of(refs);
    let leaf = BuildNode::Leaf {
        bounds,
        first,
        count: n,
    };
    if n == 1 {
        return leaf;
    }
    let split = if depth < SAH_DEPTH {
        best_split(refs, bounds, centroids)
    } else {
        None
    };
    if n <= MAX_LEAF && split.is_none_or(|(_, _, cost)| cost >= n as f32) {
        return leaf;
    }
    let mid = match split {
        Some((axis, bins_left, _)) if depth < SAH_DEPTH => {
            let binner = Binner::new(centroids);
            partition(refs, |r| binner.bin(r.centroid2(), axis) < bins_left)
        }
        _ => {
            // Object median on the widest centroid axis: always balanced.
            let extent = centroids.hi - centroids.lo;
            let axis = extent.max_position();
            refs.select_nth_unstable_by(n / 2, |a, b| {
                a.centroid2()[axis].total_cmp(&b.centroid2()[axis])
            });
            n / 2
        }
    };
    let mid = if mid == 0 || mid == n { n / 2 } else { mid };
    let (left, right) = refs.split_at_mut(mid);
    let (a, b) = if n >= PARALLEL_SUBTREE {
        rayon::join(
            || build_node(left, first, depth + 1),
            || build_node(right, first + mid, depth + 1),
        )
    } else {
        (
            build_node(left, first, depth + 1),
            build_node(right, first + mid, depth + 1),
        )
    };
    BuildNode::Inner {
        bounds,
        children: Box::new([a, b]),
    }
}

/// Emits `node` (and its subtree) as 4-wide nodes, depth first; returns its reference.
fn flatten(node: &BuildNode, nodes: &mut Vec<Node4>) -> Child {
    let BuildNode::Inner { children, .. } = node else {
        let BuildNode::Leaf { first, count, .. } = node else {
            unreachable!()
        };
        return Child::leaf(*first, *count);
    };
    let mut kids: [&BuildNode; 4] = [&children[0], &children[1], &children[0], &children[0]];
    let mut len = 2;
    // Pull grandchildren up while there is room: open the widest inner child first.
    while len < 4 {
        let widest = (0..len)
            .filter(|&i| matches!(kids[i], BuildNode::Inner { .. }))
            .max_by(|&i, &j| {
                kids[i]
                    .bounds()
                    .half_area()
                    .total_cmp(&kids[j].bounds().half_area())
            });
        let Some(i) = widest else { break };
        let BuildNode::Inner { children, .. } = kids[i] else {
            unreachable!()
        };
        kids[i] = &children[0];
        kids[len] = &children[1];
        len += 1;
    }
    let index = nodes.len();
    nodes.push(Node4::EMPTY);
    let mut out = Node4::EMPTY;
    for (lane, kid) in kids[..len].iter().enumerate() {
        let b = kid.bounds();
        let child = flatten(kid, nodes);
        out.set(lane, b.lo.to_array(), b.hi.to_array(), child);
    }
    nodes[index] = out;
    Child::inner(index as u32)
}

/// Builds the 4-wide tree over `refs`, reordering them into leaf order. Node 0 is the
/// root. `refs` must not be empty.
pub fn build(refs: &mut [PrimRef]) -> Vec<Node4> {
    debug_assert!(!refs.is_empty());
    let tree = build_node(refs, 0, 0);
    let mut nodes = Vec::with_capacity(refs.len() / 2 + 1);
    match &tree {
        BuildNode::Leaf { bounds, .. } => {
            // A root that is a leaf still gets a node, so traversal always starts at one.
            let mut root = Node4::EMPTY;
            root.set(
                0,
                bounds.lo.to_array(),
                bounds.hi.to_array(),
                flatten(&tree, &mut nodes),
            );
            nodes.push(root);
        }
        BuildNode::Inner { .. } => {
            flatten(&tree, &mut nodes);
        }
    }
    // Freeing millions of boxes is not free either; let a worker do it.
    rayon::spawn(move || drop(tree));
    nodes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partition_splits_by_predicate() {
        let mut refs: Vec<PrimRef> = (0..100)
            .map(|i| PrimRef {
                lo: Vec3::splat(i as f32),
                hi: Vec3::splat(i as f32),
                id: i,
            })
            .collect();
        let mid = partition(&mut refs, |r| r.id % 3 == 0);
        assert_eq!(mid, 34);
        assert!(refs[..mid].iter().all(|r| r.id % 3 == 0));
        assert!(refs[mid..].iter().all(|r| r.id % 3 != 0));
    }

    #[test]
    fn every_reference_lands_in_exactly_one_leaf_inside_its_boxes() {
        // 10 000 small boxes on a jittered grid, plus many identical ones (median path).
        let mut refs: Vec<PrimRef> = (0..10_000u32)
            .map(|i| {
                let p = Vec3::new(
                    (i % 97) as f32,
                    (i / 97 % 13) as f32 * 1.7,
                    (i * 7 % 31) as f32,
                );
                PrimRef {
                    lo: p,
                    hi: p + 0.5,
                    id: i,
                }
            })
            .chain((10_000..10_500).map(|id| PrimRef {
                lo: Vec3::ZERO,
                hi: Vec3::ONE,
                id,
            }))
            .collect();
        let nodes = build(&mut refs);
        let mut seen = vec![0u32; refs.len()];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = &nodes[i];
            for lane in 0..4 {
                if node.lo[0][lane] > node.hi[0][lane] {
                    continue;
                }
                let child = node.child[lane];
                if child.is_leaf() {
                    for k in child.triangles() {
                        seen[k] += 1;
                        let r = refs[k];
                        for a in 0..3 {
                            assert!(node.lo[a][lane] <= r.lo[a] && r.hi[a] <= node.hi[a][lane]);
                        }
                    }
                } else {
                    stack.push(child.index());
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
    }
}
