//! ember's native BVH: a 4-wide tree built with the binned SAH ([`build`]), traversed
//! front to back with four slab tests per node in one auto-vectorised loop, and
//! watertight ray/triangle tests ([`triangle`]) in the leaves. With a [`HitFilter`]
//! ([`Bvh::with_filter`]) the leaves ask it about every intersection and traversal goes
//! on past the ones it rejects (cut-outs), as Embree does with its filter functions.

mod aabb;
mod build;
mod clip;
mod node;
mod presplit;
mod sah;
mod spatial;
mod triangle;

use std::sync::Arc;

use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use thiserror::Error;

use self::aabb::PrimRef;
use self::node::{Child, Node4, MAX_BLOCKS, MAX_LEAF, WIDTH};
use self::triangle::{RayShear, TriBlock};
use super::{Accel, Hit, Ray};
use crate::geometry::{HitFilter, Opaque};

/// Why a BVH could not be built.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum BvhError {
    #[error("vertex index {index} out of range for {vertices} vertices")]
    IndexOutOfRange { index: u32, vertices: usize },
    #[error("{0} triangles is more than the native BVH can index ({MAX_BLOCKS})")]
    TooManyTriangles(usize),
}

/// Traversal stack depth: the builder keeps the binary depth under 48 + 27 levels and
/// every 4-wide node pushes at most three children.
const STACK: usize = 256;

/// Slab-test slack: scaling the far distance by `1 + 2γ₃` keeps the box test
/// conservative under rounding (Ize 2013, pbrt-v4), so watertight triangles are not
/// culled at their boxes' edges.
const FAR_SLACK: f32 = 1.0 + 2.0 * 3.0 * f32::EPSILON * 0.5 / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// A 4-wide bounding volume hierarchy over a triangle mesh.
pub struct Bvh {
    nodes: Vec<Node4>,
    /// Leaf triangles, four to a block; a leaf is a run of blocks.
    blocks: Vec<TriBlock>,
}

/// The per-ray constants of the slab test.
struct RayBoxes {
    org: [f32; 3],
    inv: [f32; 3],
    neg: [bool; 3],
}

impl RayBoxes {
    fn new(ray: &Ray) -> Self {
        let inv = ray.dir.recip().to_array();
        RayBoxes {
            org: ray.origin.to_array(),
            inv,
            neg: [
                inv[0].is_sign_negative(),
                inv[1].is_sign_negative(),
                inv[2].is_sign_negative(),
            ],
        }
    }

    /// Entry distance of each lane, and a bit mask of the lanes whose box the ray
    /// meets in `[tmin, tmax]` (bit `i` for lane `i`).
    #[inline(always)]
    fn test(&self, node: &Node4, tmin: f32, tmax: f32) -> ([f32; WIDTH], u32) {
        let mut near = [tmin; WIDTH];
        let mut far = [tmax; WIDTH];
        for axis in 0..3 {
            let (n, f) = if self.neg[axis] {
                (&node.hi[axis], &node.lo[axis])
            } else {
                (&node.lo[axis], &node.hi[axis])
            };
            let (o, inv) = (self.org[axis], self.inv[axis]);
            for lane in 0..WIDTH {
                let t0 = (n[lane] - o) * inv;
                let t1 = (f[lane] - o) * inv;
                // Written as comparisons so NaN (0 × ∞ on a box face) leaves the
                // interval as it was, and so the loop becomes packed max/min.
                near[lane] = if t0 > near[lane] { t0 } else { near[lane] };
                far[lane] = if t1 < far[lane] { t1 } else { far[lane] };
            }
        }
        let mut mask = 0u32;
        for lane in 0..WIDTH {
            mask |= u32::from(near[lane] <= far[lane] * FAR_SLACK) << lane;
        }
        (near, mask)
    }
}

impl Bvh {
    /// Builds the tree on the current rayon pool. Triangles with a non-finite vertex can
    /// never be hit and are left out.
    pub fn build(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<Bvh, BvhError> {
        if triangles.len() > MAX_BLOCKS {
            return Err(BvhError::TooManyTriangles(triangles.len()));
        }
        if let Some(&index) = triangles
            .iter()
            .flatten()
            .find(|&&i| i as usize >= vertices.len())
        {
            return Err(BvhError::IndexOutOfRange {
                index,
                vertices: vertices.len(),
            });
        }
        let corners = |t: &[u32; 3]| t.map(|i| vertices[i as usize]);
        let mut refs: Vec<PrimRef> = triangles
            .par_iter()
            .enumerate()
            .filter_map(|(id, t)| {
                let [a, b, c] = corners(t);
                let finite = a.is_finite() && b.is_finite() && c.is_finite();
                let (a, b, c) = (Vec3A::from(a), Vec3A::from(b), Vec3A::from(c));
                finite.then(|| PrimRef::new(a.min(b).min(c), a.max(b).max(c), id as u32))
            })
            .collect();
        if refs.is_empty() {
            return Ok(Bvh {
                nodes: vec![Node4::EMPTY],
                blocks: Vec::new(),
            });
        }
        let corners_of = |id: u32| corners(&triangles[id as usize]).map(Vec3A::from);
        presplit::presplit(&mut refs, corners_of);
        let mut blocks = Vec::with_capacity(refs.len() / 3);
        let nodes = build::build(&mut refs, &corners_of, |leaf| {
            // Pieces of one split triangle may share a leaf: test it once.
            let mut ids = [0u32; MAX_LEAF];
            ids[..leaf.len()].copy_from_slice(leaf);
            let ids = &mut ids[..leaf.len()];
            ids.sort_unstable();
            let mut unique = 0;
            for k in 0..ids.len() {
                if unique == 0 || ids[k] != ids[unique - 1] {
                    ids[unique] = ids[k];
                    unique += 1;
                }
            }
            let first = blocks.len();
            for chunk in ids[..unique].chunks(4) {
                let mut tris = [([[0.0; 3]; 3], 0); 4];
                for (slot, &id) in tris.iter_mut().zip(chunk) {
                    *slot = (corners(&triangles[id as usize]).map(|v| v.to_array()), id);
                }
                blocks.push(TriBlock::new(&tris[..chunk.len()]));
            }
            Child::leaf(first, blocks.len() - first)
        });
        Ok(Bvh { nodes, blocks })
    }

    /// Number of 4-wide nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The tree's expected cost per random ray under the surface-area heuristic: each
    /// box's area over the root's, times one per node to test or per triangle block in
    /// a leaf. A deterministic measure of build quality, for comparing builders where
    /// timings are noisy.
    pub fn sah_cost(&self) -> f64 {
        let area = |node: &Node4, lane: usize| {
            let d = |a: usize| f64::from((node.hi[a][lane] - node.lo[a][lane]).max(0.0));
            d(0) * d(1) + d(1) * d(2) + d(2) * d(0)
        };
        let root = &self.nodes[0];
        let root_area = (0..WIDTH)
            .filter(|&l| root.lo[0][l] <= root.hi[0][l])
            .map(|l| area(root, l))
            .sum::<f64>()
            .max(f64::MIN_POSITIVE);
        let mut cost = 1.0;
        for node in &self.nodes {
            for lane in 0..WIDTH {
                if node.lo[0][lane] > node.hi[0][lane] {
                    continue;
                }
                let child = node.child[lane];
                let weight = if child.is_leaf() {
                    child.range().len() as f64
                } else {
                    1.0
                };
                cost += area(node, lane) / root_area * weight;
            }
        }
        cost
    }
}

/// A [`Bvh`] whose hits a [`HitFilter`] decides (cut-outs): [`Bvh::with_filter`].
pub struct FilteredBvh<F: HitFilter> {
    bvh: Bvh,
    filter: Arc<F>,
}

impl Bvh {
    /// This tree with `filter` deciding which intersections are hits.
    pub fn with_filter<F: HitFilter>(self, filter: Arc<F>) -> FilteredBvh<F> {
        FilteredBvh { bvh: self, filter }
    }

    /// The nearest intersection that `filter` accepts. Monomorphised per filter, so
    /// [`Opaque`] (a compile-time `true`) costs nothing.
    #[inline(always)]
    fn intersect_with<F: HitFilter>(&self, ray: &Ray, filter: &F) -> Option<Hit> {
        let boxes = RayBoxes::new(ray);
        let shear = RayShear::new(ray.origin, ray.dir);
        let (tmin, mut tmax) = (ray.tmin, ray.tmax);
        // The block and lane of the nearest hit so far, and its barycentrics.
        let mut best: Option<(usize, usize, f32, f32)> = None;
        let mut stack = [(Child(0), 0.0f32); STACK];
        let mut sp = 0;
        let mut cur = Child::inner(0);
        loop {
            if cur.is_leaf() {
                for index in cur.range() {
                    let block = &self.blocks[index];
                    let found = if F::ACCEPTS_ALL {
                        shear.intersect4(block, tmin, tmax)
                    } else {
                        shear.intersect4_filtered(block, tmin, tmax, |lane, u, v| {
                            filter.accept(block.prim[lane], u, v)
                        })
                    };
                    if let Some((lane, t, u, v)) = found {
                        tmax = t;
                        best = Some((index, lane, u, v));
                    }
                }
            } else {
                let node = &self.nodes[cur.index()];
                let (near, mut mask) = boxes.test(node, tmin, tmax);
                if mask != 0 {
                    let first = mask.trailing_zeros() as usize;
                    if mask & (mask - 1) == 0 {
                        // One child hit, the common case deep in the tree.
                        cur = node.child[first];
                        continue;
                    }
                    // Several: farthest first onto the stack, nearest visited next.
                    let mut kids = [(Child(0), 0.0f32); WIDTH];
                    let mut n = 0;
                    while mask != 0 {
                        let lane = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let kid = (node.child[lane], near[lane]);
                        let mut j = n;
                        while j > 0 && kids[j - 1].1 < kid.1 {
                            kids[j] = kids[j - 1];
                            j -= 1;
                        }
                        kids[j] = kid;
                        n += 1;
                    }
                    // A fixed-size copy (the stack has room): no call to memcpy.
                    stack[sp..sp + WIDTH - 1].copy_from_slice(&kids[..WIDTH - 1]);
                    sp += n - 1;
                    cur = kids[n - 1].0;
                    continue;
                }
            }
            // Pop the nearest pending child that could still be closer than the hit.
            loop {
                if sp == 0 {
                    return best.map(|(index, lane, u, v)| {
                        let block = &self.blocks[index];
                        let t = block
                            .plane_distance(lane, ray.origin, ray.dir)
                            .map_or(tmax, |t| t.clamp(tmin, ray.tmax));
                        Hit {
                            t,
                            prim: block.prim[lane],
                            u,
                            v,
                        }
                    });
                }
                sp -= 1;
                let (child, near) = stack[sp];
                if near <= tmax {
                    cur = child;
                    break;
                }
            }
        }
    }

    /// Whether `filter` accepts any intersection with the segment.
    #[inline(always)]
    fn occluded_with<F: HitFilter>(&self, ray: &Ray, filter: &F) -> bool {
        let boxes = RayBoxes::new(ray);
        let shear = RayShear::new(ray.origin, ray.dir);
        let (tmin, tmax) = (ray.tmin, ray.tmax);
        let mut stack = [Child(0); STACK];
        let mut sp = 0;
        let mut cur = Child::inner(0);
        loop {
            if cur.is_leaf() {
                for block in &self.blocks[cur.range()] {
                    let blocked = if F::ACCEPTS_ALL {
                        shear.occluded4(block, tmin, tmax)
                    } else {
                        shear.occluded4_filtered(block, tmin, tmax, |lane, u, v| {
                            filter.accept(block.prim[lane], u, v)
                        })
                    };
                    if blocked {
                        return true;
                    }
                }
            } else {
                let node = &self.nodes[cur.index()];
                let (near, mask) = boxes.test(node, tmin, tmax);
                if mask != 0 {
                    // Any hit will do, but the nearest child is the likeliest blocker:
                    // visit it next, push the others.
                    let mut nearest = mask.trailing_zeros() as usize;
                    let mut rest = mask & (mask - 1);
                    while rest != 0 {
                        let lane = rest.trailing_zeros() as usize;
                        rest &= rest - 1;
                        let far = if near[lane] < near[nearest] {
                            std::mem::replace(&mut nearest, lane)
                        } else {
                            lane
                        };
                        stack[sp] = node.child[far];
                        sp += 1;
                    }
                    cur = node.child[nearest];
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            cur = stack[sp];
        }
    }
}

impl Accel for Bvh {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_with(ray, &Opaque)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, &Opaque)
    }

    fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node4>()
            + self.blocks.len() * std::mem::size_of::<TriBlock>()
    }
}

impl<F: HitFilter> Accel for FilteredBvh<F> {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.bvh.intersect_with(ray, &*self.filter)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.bvh.occluded_with(ray, &*self.filter)
    }

    fn memory_bytes(&self) -> usize {
        self.bvh.memory_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube of 12 triangles.
    fn cube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let v = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let quads = [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (v, t)
    }

    #[test]
    fn ray_through_cube_hits_the_near_face() {
        let (v, t) = cube();
        let bvh = Bvh::build(&v, &t).unwrap();
        let ray = Ray::new(Vec3::new(0.3, 0.4, -2.0), Vec3::Z);
        let hit = bvh.intersect(&ray).unwrap();
        assert!((hit.t - 2.0).abs() < 1e-6);
        // The face z = 0 is made of triangles 0 and 1.
        assert!(hit.prim < 2, "prim {}", hit.prim);
        let [a, b, c] = t[hit.prim as usize].map(|i| v[i as usize]);
        let p = (1.0 - hit.u - hit.v) * a + hit.u * b + hit.v * c;
        assert!((p - ray.at(hit.t)).length() < 1e-5);
        // From inside, the far face at z = 1.
        let inside = Ray::new(Vec3::splat(0.5), Vec3::Z);
        assert!((bvh.intersect(&inside).unwrap().t - 0.5).abs() < 1e-6);
        assert!(bvh.occluded(&inside));
        assert!(!bvh.occluded(&Ray::segment(Vec3::splat(0.5), Vec3::Z, 0.4)));
        assert!(bvh
            .intersect(&Ray::new(Vec3::new(2.0, 0.5, 0.5), Vec3::Y))
            .is_none());
    }

    #[test]
    fn sah_cost_counts_the_root_and_every_block() {
        let (v, t) = cube();
        let bvh = Bvh::build(&v, &t).unwrap();
        // At least the root test plus one block test per ray; at most every box tested.
        let cost = bvh.sah_cost();
        assert!(cost >= 2.0 && cost <= 1.0 + 4.0 * t.len() as f64, "{cost}");
    }

    #[test]
    fn bad_indices_and_empty_meshes() {
        let (v, _) = cube();
        assert_eq!(
            Bvh::build(&v, &[[0, 1, 8]]).err(),
            Some(BvhError::IndexOutOfRange {
                index: 8,
                vertices: 8
            })
        );
        let empty = Bvh::build(&v, &[]).unwrap();
        assert!(empty.intersect(&Ray::new(Vec3::ZERO, Vec3::X)).is_none());
        assert!(!empty.occluded(&Ray::new(Vec3::ZERO, Vec3::X)));
    }

    /// Every bit of the tree: node boxes and children, leaf triangles and their ids.
    fn tree_bits(bvh: &Bvh) -> Vec<u32> {
        let mut bits = Vec::new();
        for node in &bvh.nodes {
            bits.extend(
                node.lo
                    .iter()
                    .chain(&node.hi)
                    .flatten()
                    .map(|x| x.to_bits()),
            );
            bits.extend(node.child.iter().map(|c| c.0));
        }
        for block in &bvh.blocks {
            bits.extend(block.v.iter().flatten().flatten().map(|x| x.to_bits()));
            bits.extend(block.prim);
        }
        bits
    }

    #[test]
    fn the_tree_is_the_same_on_one_and_two_threads() {
        // 80 000 triangles, large enough for parallel binning and parallel subtrees: a
        // floor of small quads, each quad twice (coplanar duplicates), crossed by long
        // thin triangles that ask for spatial splits (and exhaust their budget).
        let mut rng = crate::sampling::Rng::seeded(8);
        let mut v = Vec::new();
        let mut t = Vec::new();
        for i in 0..20_000u32 {
            let p = Vec3::new((i % 200) as f32, 0.0, (i / 200) as f32);
            let k = v.len() as u32;
            v.extend([p, p + Vec3::X, p + Vec3::Z, p + Vec3::X + Vec3::Z]);
            for _ in 0..2 {
                t.extend([[k, k + 1, k + 3], [k, k + 3, k + 2]]);
            }
        }
        for _ in 0..2_000 {
            let mut p = || Vec3::new(rng.f32() * 200.0, rng.f32() * 5.0, rng.f32() * 100.0);
            let (a, b) = (p(), p());
            let k = v.len() as u32;
            v.extend([a, b, b + Vec3::new(0.1, 0.5, 0.0)]);
            t.push([k, k + 1, k + 2]);
        }
        let on = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| Bvh::build(&v, &t).unwrap())
        };
        let one = tree_bits(&on(1));
        for _ in 0..3 {
            assert!(
                one == tree_bits(&on(2)),
                "the tree changed with the thread count"
            );
        }
        let refs: usize = on(1)
            .blocks
            .iter()
            .map(|b| b.prim.iter().filter(|&&p| p != u32::MAX).count())
            .sum();
        assert!(
            refs > t.len(),
            "no triangle was split: the budget was not exercised"
        );
    }

    #[test]
    fn far_slack_is_a_tiny_enlargement() {
        let slack = std::hint::black_box(FAR_SLACK);
        assert!(slack > 1.0 && slack < 1.0 + 1e-6);
    }
}
