//! ember's native BVH: an 8-wide tree built with the binned SAH ([`build`]), traversed
//! front to back with the slab tests of a node's children four at a time in SIMD
//! ([`traverse`]), and watertight ray/triangle tests ([`triangle`]) in the leaves.
//! Any-hit traversal runs as AVX2 code where the processor has it, chosen at run time
//! ([`simd`]). With a [`HitFilter`] ([`Bvh::with_filter`]) the leaves ask it about
//! every intersection and traversal goes on past the ones it rejects (cut-outs), as
//! Embree does with its filter functions.
//!
//! Nodes are 8 wide ([`node::WIDTH`], a multiple of 4; 4 builds and passes the tests
//! too). Traversal waits on memory more than it computes, and an 8-wide tree is about
//! half as deep: against 4-wide nodes, bvh_ab measured 8-wide 9-15% faster on shadow
//! rays and on the bunny's diffuse rays, 8-15% slower on the short diffuse rays of
//! Sponza and the staircase, which meet few nodes and pay for each node's eight boxes.
//! (Before the slab test was written with explicit four-lane vectors, 8-wide nodes
//! had measured 3-20% slower everywhere.)

mod aabb;
mod build;
mod clip;
mod node;
mod presplit;
mod sah;
mod simd;
mod spatial;
mod traverse;
mod triangle;

use std::sync::Arc;

use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use thiserror::Error;

use self::aabb::PrimRef;
use self::node::{Child, Node, MAX_BLOCKS, MAX_LEAF, WIDTH};
use self::simd::Isa;
use self::traverse::with_stacks;
pub(crate) use self::traverse::FAR_SLACK;
use self::triangle::TriBlock;
use super::{Accel, Hit, Ray};
use crate::geometry::{HitFilter, Opaque};

/// Why a BVH could not be built.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum BvhError {
    #[error("vertex index {index} out of range for {vertices} vertices")]
    IndexOutOfRange { index: u32, vertices: usize },
    #[error("{0} triangles is more than the native BVH can index ({MAX_BLOCKS})")]
    TooManyTriangles(usize),
    #[error(transparent)]
    Instance(#[from] crate::geometry::InstanceError),
}

/// A wide bounding volume hierarchy over a triangle mesh.
pub struct Bvh {
    nodes: Vec<Node>,
    /// Leaf triangles, four to a block; a leaf is a run of blocks.
    blocks: Vec<TriBlock>,
    /// The instruction set traversal runs with.
    isa: Isa,
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
                nodes: vec![Node::EMPTY],
                blocks: Vec::new(),
                isa: Isa::detect(),
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
        Ok(Bvh {
            nodes,
            blocks,
            isa: Isa::detect(),
        })
    }

    /// Number of wide nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The tree's expected cost per random ray under the surface-area heuristic: each
    /// box's area over the root's, times one per node to test or per triangle block in
    /// a leaf. A deterministic measure of build quality, for comparing builders where
    /// timings are noisy.
    pub fn sah_cost(&self) -> f64 {
        let area = |node: &Node, lane: usize| {
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
}

impl Accel for Bvh {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        // The portable build: see `simd` for why closest hits do not use AVX2.
        with_stacks(|stacks| self.intersect_in(ray, &Opaque, stacks))
    }

    fn occluded(&self, ray: &Ray) -> bool {
        with_stacks(|stacks| simd::occluded(self.isa, self, ray, &Opaque, stacks))
    }

    fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
            + self.blocks.len() * std::mem::size_of::<TriBlock>()
    }
}

impl<F: HitFilter> Accel for FilteredBvh<F> {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        with_stacks(|stacks| self.bvh.intersect_in(ray, &*self.filter, stacks))
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let (bvh, filter) = (&self.bvh, &*self.filter);
        with_stacks(|stacks| simd::occluded(bvh.isa, bvh, ray, filter, stacks))
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
}
