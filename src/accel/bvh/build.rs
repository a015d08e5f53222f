//! The binned surface-area-heuristic (SAH) builder: a binary tree split by the best of
//! 32 bins on each axis (parallel over rayon's workers), or where that split's sides
//! overlap much, a spatial split ([`spatial`]); then collapsed into wide nodes by
//! repeatedly opening the child with the largest surface area.
//!
//! The tree is a function of the mesh alone, not of the thread count: parallel binning
//! merges boxes (min/max) and counts (integers), which is exact in any order; every
//! choice between equal costs is strict (the first axis, the lowest bin, the object
//! split over the spatial one); and spatial splits draw on a budget that each node
//! shares between its children by size.

use glam::{BVec3A, UVec3, Vec3A};
use rayon::prelude::*;

use super::aabb::{Aabb, PrimRef};
use super::node::{Child, Node, MAX_BLOCKS, MAX_LEAF, WIDTH};
use super::sah::{blocks, ObjectSplit, TRAVERSAL_COST};
use super::spatial::{self, Spatial};

/// Most bins per axis for the object split's SAH sweep (fewer for small ranges, see
/// [`bin_count`]).
const OBJECT_BINS: usize = 32;
/// Subtrees at least this large are built on two workers (`rayon::join`).
const PARALLEL_SUBTREE: usize = 2048;
/// Ranges at least this large are binned in parallel chunks.
const PARALLEL_SCAN: usize = 64 * 1024;
/// Below this binary depth splits follow the SAH; deeper, the object median, so the
/// tree depth (and the traversal stack) stays bounded whatever the mesh.
const SAH_DEPTH: u32 = 48;

/// The binary tree the SAH produces; leaves hold the indices of their triangles.
enum BuildNode {
    Leaf {
        bounds: Aabb,
        ids: [u32; MAX_LEAF],
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
struct Bins<const N: usize> {
    bounds: [[Aabb; N]; 3],
    count: [[u32; N]; 3],
}

impl<const N: usize> Bins<N> {
    fn empty() -> Self {
        Bins {
            bounds: [[Aabb::EMPTY; N]; 3],
            count: [[0; N]; 3],
        }
    }

    fn merge(mut self, o: Self) -> Self {
        for axis in 0..3 {
            for b in 0..N {
                self.bounds[axis][b] = self.bounds[axis][b].union(o.bounds[axis][b]);
                self.count[axis][b] += o.count[axis][b];
            }
        }
        self
    }
}

/// Bins worth sweeping for `n` primitives: the sweep costs per bin, the binning per
/// primitive, and small ranges gain little from fine bins.
fn bin_count(n: usize) -> usize {
    match n {
        0..64 => 8,
        64..1024 => 16,
        _ => OBJECT_BINS,
    }
}

/// Maps a (doubled) centroid to its bin on each axis.
#[derive(Clone, Copy)]
struct Binner {
    origin: Vec3A,
    scale: Vec3A,
    bins: usize,
}

/// Adding 2²³ to a float in `[0, 2²³)` leaves its value, rounded to an integer, in the
/// low mantissa bits: a float-to-integer conversion without the range checks of `as`.
const ROUND_MAGIC: f32 = 8_388_608.0;

impl Binner {
    fn new(centroids: Aabb, bins: usize) -> Self {
        let extent = centroids.hi - centroids.lo;
        // Centroids map to [0, bins - 0.5], which rounds to 0..bins-1.
        let k = (bins as f32 - 0.5) * (1.0 - 1e-5);
        let scale = Vec3A::select(extent.cmpgt(Vec3A::ZERO), k / extent, Vec3A::ZERO);
        Binner {
            origin: centroids.lo,
            scale,
            bins,
        }
    }

    /// The bin on every axis at once.
    #[inline]
    fn bins(&self, c: Vec3A) -> UVec3 {
        let f = ((c - self.origin) * self.scale).max(Vec3A::ZERO) + ROUND_MAGIC;
        let b = UVec3::new(f.x.to_bits(), f.y.to_bits(), f.z.to_bits()) & 0xff;
        b.min(UVec3::splat(self.bins as u32 - 1))
    }

    fn fill<const N: usize>(&self, refs: &[PrimRef], bins: &mut Bins<N>) {
        for r in refs {
            let b = self.bins(r.centroid2());
            let aabb = r.aabb();
            for axis in 0..3 {
                // Already below N; saying so again lets the compiler drop bounds checks.
                let i = (b[axis] as usize).min(N - 1);
                bins.bounds[axis][i] = bins.bounds[axis][i].union(aabb);
                bins.count[axis][i] += 1;
            }
        }
    }

    /// Bins every `stride`-th run of [`SAMPLE_RUN`] references of `refs`.
    fn fill_sampled<const N: usize>(&self, refs: &[PrimRef], stride: usize, bins: &mut Bins<N>) {
        for run in refs.chunks(SAMPLE_RUN).step_by(stride) {
            self.fill(run, bins);
        }
    }
}

/// Ranges larger than this are binned from a sample: at the top of the tree thousands
/// of references per bin locate the best plane as well as millions do, and binning
/// every reference there is the builder's largest cost (it streams the whole array).
const SAMPLE_FROM: usize = 16 * 1024;
/// Most references skipped per one binned: every `stride`-th run is binned.
const MAX_SAMPLE_STRIDE: usize = 8;
/// Contiguous references binned together, so skipped memory is skipped in whole lines.
const SAMPLE_RUN: usize = 64;

/// Bin every `sample_stride(n)`-th run of references of a range of `n`.
fn sample_stride(n: usize) -> usize {
    (n / SAMPLE_FROM).clamp(1, MAX_SAMPLE_STRIDE)
}

/// The cheapest binned split with `N` bins per axis (`binner` must have `N` bins).
fn best_split<const N: usize>(
    refs: &[PrimRef],
    bounds: Aabb,
    binner: &Binner,
) -> Option<ObjectSplit> {
    debug_assert_eq!(binner.bins, N);
    let nb = N;
    let stride = sample_stride(refs.len());
    let mut bins = Bins::<N>::empty();
    if refs.len() >= PARALLEL_SCAN {
        bins = *refs
            .par_chunks(PARALLEL_SCAN / 4)
            .map(|c| {
                let mut bins = Box::new(Bins::empty());
                binner.fill_sampled(c, stride, &mut bins);
                bins
            })
            .reduce(
                || Box::new(Bins::empty()),
                |mut a, b| {
                    *a = a.merge(*b);
                    a
                },
            );
    } else {
        binner.fill_sampled(refs, stride, &mut bins);
    }
    // Every sampled reference stands for `stride` of them.
    let binned: u32 = bins.count[0].iter().sum();
    let inv_area = 1.0 / bounds.half_area().max(f32::MIN_POSITIVE);
    let mut best: Option<ObjectSplit> = None;
    for axis in 0..3 {
        if binner.scale[axis] == 0.0 {
            continue;
        }
        // Sweep from the right, remembering area × count and the box of every suffix.
        let mut right_cost = [0.0f32; N];
        let mut right_box = [Aabb::EMPTY; N];
        let (mut box_r, mut n_r) = (Aabb::EMPTY, 0u32);
        for b in (1..nb).rev() {
            box_r = box_r.union(bins.bounds[axis][b]);
            n_r += bins.count[axis][b];
            right_cost[b] = box_r.half_area() * blocks(n_r as usize * stride);
            right_box[b] = box_r;
        }
        let (mut box_l, mut n_l) = (Aabb::EMPTY, 0u32);
        #[allow(clippy::needless_range_loop)] // `split` indexes two arrays at offsets
        for split in 1..nb {
            box_l = box_l.union(bins.bounds[axis][split - 1]);
            n_l += bins.count[axis][split - 1];
            if n_l == 0 || n_l == binned {
                continue;
            }
            let cost = TRAVERSAL_COST
                + (box_l.half_area() * blocks(n_l as usize * stride) + right_cost[split])
                    * inv_area;
            // Strictly cheaper: on equal costs the first axis and lowest bin stay.
            if best.is_none_or(|b| cost < b.cost) {
                best = Some(ObjectSplit {
                    axis,
                    bins_left: split,
                    cost,
                    left: box_l,
                    right: right_box[split],
                });
            }
        }
    }
    best
}

/// Moves the references that satisfy `left` to the front; returns how many there are
/// and the (box, centroid box) of each side, gathered in the same pass. Branch-free
/// (Lomuto's scheme with a swap every step): at the top of the tree the side of each
/// reference is a coin toss the branch predictor would lose.
fn partition(
    refs: &mut [PrimRef],
    left: impl Fn(&PrimRef) -> bool,
) -> (usize, (Aabb, Aabb), (Aabb, Aabb)) {
    let mut k = 0;
    let (mut lb, mut lc, mut rb, mut rc) = (Aabb::EMPTY, Aabb::EMPTY, Aabb::EMPTY, Aabb::EMPTY);
    for i in 0..refs.len() {
        let r = refs[i];
        let is_left = left(&r);
        let (b, c) = (r.aabb(), r.centroid2());
        let go_left = BVec3A::splat(is_left);
        let go_right = BVec3A::splat(!is_left);
        lb = select(go_left, lb.union(b), lb);
        lc = select(go_left, lc.grow(c), lc);
        rb = select(go_right, rb.union(b), rb);
        rc = select(go_right, rc.grow(c), rc);
        refs.swap(k, i);
        k += usize::from(is_left);
    }
    (k, (lb, lc), (rb, rc))
}

/// `a` where `mask` is set, else `b`, per lane of both corners.
#[inline]
fn select(mask: BVec3A, a: Aabb, b: Aabb) -> Aabb {
    Aabb {
        lo: Vec3A::select(mask, a.lo, b.lo),
        hi: Vec3A::select(mask, a.hi, b.hi),
    }
}

fn leaf_of(refs: &[PrimRef], bounds: Aabb) -> BuildNode {
    debug_assert!(refs.len() <= MAX_LEAF);
    let mut ids = [0u32; MAX_LEAF];
    for (slot, r) in ids.iter_mut().zip(refs) {
        *slot = r.id();
    }
    BuildNode::Leaf {
        bounds,
        ids,
        count: refs.len(),
    }
}

/// The subtree over `refs`, whose box and centroid box are `bounds` and `centroids`;
/// spatial splits in it may add up to `budget` references.
fn build_node(
    refs: &mut [PrimRef],
    depth: u32,
    (bounds, centroids): (Aabb, Aabb),
    budget: usize,
    spatial: &Spatial,
) -> BuildNode {
    let n = refs.len();
    // A leaf's triangles are tested four at a time, as one block: splitting four or
    // fewer gains nothing the leaf test would not give.
    if n <= 4 {
        return leaf_of(refs, bounds);
    }
    let binner = Binner::new(centroids, bin_count(n));
    let split = if depth >= SAH_DEPTH {
        None
    } else {
        match binner.bins {
            8 => best_split::<8>(refs, bounds, &binner),
            16 => best_split::<16>(refs, bounds, &binner),
            _ => best_split::<OBJECT_BINS>(refs, bounds, &binner),
        }
    };
    // Up to two blocks stay a leaf where the SAH finds no split cheaper: there a
    // descent one level further costs a shadow ray more than a second block test.
    if n <= MAX_LEAF && split.is_none_or(|s| s.cost >= blocks(n)) {
        return leaf_of(refs, bounds);
    }
    // Spatial splits copy the references of the two sides; object splits reorder them
    // in place.
    if let Some((mut left, mut right)) =
        split.and_then(|object| spatial.try_split(refs, bounds, &object, budget))
    {
        let added = left.len() + right.len() - n;
        let budgets = share(budget - added, left.len(), right.len());
        let (lb, rb) = (bounds_of(&left), bounds_of(&right));
        return inner(
            bounds,
            depth,
            (&mut left, lb),
            (&mut right, rb),
            budgets,
            spatial,
        );
    }
    let (mid, left_bounds, right_bounds) = match split {
        Some(ObjectSplit {
            axis, bins_left, ..
        }) => partition(refs, |r| {
            (binner.bins(r.centroid2())[axis] as usize) < bins_left
        }),
        None => median_split(refs, centroids),
    };
    let budgets = share(budget, mid, n - mid);
    let (left, right) = refs.split_at_mut(mid);
    inner(
        bounds,
        depth,
        (left, left_bounds),
        (right, right_bounds),
        budgets,
        spatial,
    )
}

/// The object median on the widest centroid axis: always balanced. Returns where the
/// right side starts and the (box, centroid box) of each side.
fn median_split(refs: &mut [PrimRef], centroids: Aabb) -> (usize, (Aabb, Aabb), (Aabb, Aabb)) {
    let n = refs.len();
    let axis = (centroids.hi - centroids.lo).max_position();
    refs.select_nth_unstable_by(n / 2, |a, b| {
        a.centroid2()[axis].total_cmp(&b.centroid2()[axis])
    });
    let (l, r) = refs.split_at(n / 2);
    (n / 2, bounds_of(l), bounds_of(r))
}

/// Shares a spatial-split budget between two sides in proportion to their references
/// (as Embree's SBVH builder does). Each subtree's budget then follows from the tree
/// above it alone, never from which worker got to a shared counter first, so the tree
/// is the same at any thread count.
fn share(budget: usize, left: usize, right: usize) -> (usize, usize) {
    let l = (budget as u128 * left as u128 / (left + right).max(1) as u128) as usize;
    (l, budget - l)
}

/// The inner node over two sides, each with its (box, centroid box) and budget; built
/// on two workers when large.
fn inner(
    bounds: Aabb,
    depth: u32,
    (left, lb): (&mut [PrimRef], (Aabb, Aabb)),
    (right, rb): (&mut [PrimRef], (Aabb, Aabb)),
    (l_budget, r_budget): (usize, usize),
    spatial: &Spatial,
) -> BuildNode {
    let (a, b) = if left.len() + right.len() >= PARALLEL_SUBTREE {
        rayon::join(
            || build_node(left, depth + 1, lb, l_budget, spatial),
            || build_node(right, depth + 1, rb, r_budget, spatial),
        )
    } else {
        (
            build_node(left, depth + 1, lb, l_budget, spatial),
            build_node(right, depth + 1, rb, r_budget, spatial),
        )
    };
    BuildNode::Inner {
        bounds,
        children: Box::new([a, b]),
    }
}

/// Emits `node` (and its subtree) as wide nodes, depth first; returns its reference.
/// `leaf(ids)` stores a leaf's triangles and returns the leaf's `Child`.
fn flatten(
    node: &BuildNode,
    nodes: &mut Vec<Node>,
    leaf: &mut impl FnMut(&[u32]) -> Child,
) -> Child {
    let BuildNode::Inner { children, .. } = node else {
        let BuildNode::Leaf { ids, count, .. } = node else {
            unreachable!()
        };
        return leaf(&ids[..*count]);
    };
    let mut kids: [&BuildNode; WIDTH] = [&children[0]; WIDTH];
    kids[1] = &children[1];
    let mut len = 2;
    // Pull grandchildren up while there is room: open the widest inner child first.
    while len < WIDTH {
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
    nodes.push(Node::EMPTY);
    let mut out = Node::EMPTY;
    for (lane, kid) in kids[..len].iter().enumerate() {
        let b = kid.bounds();
        let child = flatten(kid, nodes, leaf);
        out.set(lane, b.lo.to_array(), b.hi.to_array(), child);
    }
    nodes[index] = out;
    Child::inner(index as u32)
}

/// Builds the wide tree over `refs` (reordering them); `corners(id)` gives a
/// triangle's corners, for spatial splits; `leaf(ids)` stores each leaf's triangles (in
/// depth-first order) and returns its `Child`. Node 0 is the root. `refs` must not be
/// empty.
pub fn build(
    refs: &mut [PrimRef],
    corners: &(dyn Fn(u32) -> [Vec3A; 3] + Sync),
    mut leaf: impl FnMut(&[u32]) -> Child,
) -> Vec<Node> {
    debug_assert!(!refs.is_empty());
    let bounds = bounds_of(refs);
    let spatial = Spatial {
        corners,
        root_area: bounds.0.half_area(),
    };
    // Leaves address blocks with 27 bits: never more references than that.
    let budget =
        ((refs.len() as f32 * spatial::BUDGET) as usize).min(MAX_BLOCKS.saturating_sub(refs.len()));
    let tree = build_node(refs, 0, bounds, budget, &spatial);
    let mut nodes = Vec::with_capacity(refs.len() / 4 + 1);
    match &tree {
        BuildNode::Leaf { bounds, .. } => {
            // A root that is a leaf still gets a node, so traversal always starts at one.
            let mut root = Node::EMPTY;
            root.set(
                0,
                bounds.lo.to_array(),
                bounds.hi.to_array(),
                flatten(&tree, &mut nodes, &mut leaf),
            );
            nodes.push(root);
        }
        BuildNode::Inner { .. } => {
            flatten(&tree, &mut nodes, &mut leaf);
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
            .map(|i| PrimRef::new(Vec3A::splat(i as f32), Vec3A::splat(i as f32), i))
            .collect();
        let (mid, (lb, lc), (rb, _)) = partition(&mut refs, |r| r.id() % 3 == 0);
        assert_eq!(mid, 34);
        assert!(refs[..mid].iter().all(|r| r.id() % 3 == 0));
        assert!(refs[mid..].iter().all(|r| r.id() % 3 != 0));
        assert_eq!((lb.lo.x, lb.hi.x, lc.hi.x), (0.0, 99.0, 198.0));
        assert_eq!((rb.lo.x, rb.hi.x), (1.0, 98.0));
    }

    /// Builds over `tris` (with their boxes as references) and returns, per triangle,
    /// the boxes of the leaves that hold it.
    fn leaf_boxes(tris: &[[Vec3A; 3]]) -> Vec<Vec<Aabb>> {
        let mut refs: Vec<PrimRef> = tris
            .iter()
            .enumerate()
            .map(|(id, [a, b, c])| PrimRef::new(a.min(*b).min(*c), a.max(*b).max(*c), id as u32))
            .collect();
        let corners = |id: u32| tris[id as usize];
        let mut order = Vec::new();
        let nodes = build(&mut refs, &corners, |ids| {
            let first = order.len();
            order.extend_from_slice(ids);
            Child::leaf(first, ids.len())
        });
        let mut boxes = vec![Vec::new(); tris.len()];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = &nodes[i];
            for lane in 0..WIDTH {
                if node.lo[0][lane] > node.hi[0][lane] {
                    continue;
                }
                let child = node.child[lane];
                if child.is_leaf() {
                    let lo = Vec3A::new(node.lo[0][lane], node.lo[1][lane], node.lo[2][lane]);
                    let hi = Vec3A::new(node.hi[0][lane], node.hi[1][lane], node.hi[2][lane]);
                    for k in child.range() {
                        boxes[order[k] as usize].push(Aabb { lo, hi });
                    }
                } else {
                    stack.push(child.index());
                }
            }
        }
        boxes
    }

    /// Every point of every triangle must be inside the box of a leaf that holds it.
    fn assert_covered(tris: &[[Vec3A; 3]], boxes: &[Vec<Aabb>]) {
        let mut rng = crate::sampling::Rng::seeded(9);
        for (id, [a, b, c]) in tris.iter().enumerate() {
            for _ in 0..16 {
                let (u, v) = crate::sampling::uniform_triangle(rng.f32(), rng.f32());
                let p = (1.0 - u - v) * *a + u * *b + v * *c;
                assert!(
                    boxes[id]
                        .iter()
                        .any(|bx| p.cmpge(bx.lo).all() && p.cmple(bx.hi).all()),
                    "triangle {id}: {p} in no leaf box"
                );
            }
        }
    }

    #[test]
    fn every_triangle_lands_in_exactly_one_leaf_inside_its_box() {
        // 40 000 small triangles on a jittered grid (enough for sampled binning at the
        // top), plus many identical ones (median path).
        let tri = |p: Vec3A, s: f32| [p, p + Vec3A::new(s, 0.0, s), p + Vec3A::new(0.0, s, s)];
        let tris: Vec<[Vec3A; 3]> = (0..40_000u32)
            .map(|i| {
                let p = Vec3A::new(
                    (i % 97) as f32,
                    (i / 97 % 13) as f32 * 1.7,
                    (i * 7 % 31) as f32,
                );
                tri(p, 0.5)
            })
            .chain((0..500).map(|_| tri(Vec3A::ZERO, 1.0)))
            .collect();
        let boxes = leaf_boxes(&tris);
        assert!(boxes.iter().all(|b| b.len() == 1));
        assert_covered(&tris, &boxes);
    }

    #[test]
    fn spatial_splits_keep_every_triangle_covered() {
        // Small triangles in a cube, crossed by long thin ones (planks of a floor, the
        // columns of a hall): the long ones are split across leaves.
        let mut rng = crate::sampling::Rng::seeded(4);
        let mut p = || Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 10.0;
        let mut tris: Vec<[Vec3A; 3]> = (0..3000)
            .map(|_| {
                let c = p();
                [
                    c,
                    c + Vec3A::new(0.2, 0.0, 0.1),
                    c + Vec3A::new(0.0, 0.2, -0.1),
                ]
            })
            .collect();
        for _ in 0..60 {
            let (a, b) = (p(), p());
            tris.push([a, b, b + Vec3A::new(0.05, 0.3, 0.02)]);
        }
        let boxes = leaf_boxes(&tris);
        assert!(boxes.iter().all(|b| !b.is_empty()));
        let refs: usize = boxes.iter().map(Vec::len).sum();
        assert!(refs > tris.len(), "no spatial split happened");
        assert_covered(&tris, &boxes);
    }
}
