//! The spatial half of an SD-tree: a binary tree over the scene's bounding box, cut
//! at the middle along x, y, z in turn, each leaf holding a directional [`QuadTree`].

use glam::Vec3;

use super::quadtree::QuadTree;

/// The spatial tree never has more nodes than this (so at most 2048 leaves). With each
/// leaf's quadtree bounded by [`QuadTree::max_nodes`], the whole tree holds at most
/// `MAX_SPATIAL_NODES · 8 + 2048 · 2001 · 48` bytes (≈ 197 MB) while guiding a render,
/// twice that while training (the tree being filled beside the one that guides).
pub const MAX_SPATIAL_NODES: usize = 4095;

/// Müller et al.'s `c`: after an iteration of `spp` samples per pixel, a leaf that
/// received more than `c · √spp` records is split in two.
pub const SPLIT_RECORDS_PER_SQRT_SPP: f64 = 12_000.0;

/// A node: an inner node's children (the lower half first) and the axis it cuts, or
/// a leaf's index and the axis a split of it would cut (x at the root, then y, z, x…).
#[derive(Clone, Copy, Debug, PartialEq)]
enum SpatialNode {
    Inner { axis: u8, children: [u32; 2] },
    Leaf { leaf: u32, axis: u8 },
}

/// One region of space: its directional distribution and how many records fell in
/// it during the iteration that filled it.
#[derive(Clone, Debug, PartialEq)]
struct Leaf {
    directions: QuadTree,
    records: u64,
}

/// A spatial-directional tree (see [`crate::guiding`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SdTree {
    min: Vec3,
    extent: Vec3,
    nodes: Vec<SpatialNode>,
    leaves: Vec<Leaf>,
}

impl SdTree {
    /// One leaf over the box `(min, max)`, uniform in every direction. The box is
    /// widened a little so that points on its faces fall inside.
    pub fn new((min, max): (Vec3, Vec3)) -> SdTree {
        let pad = (max - min).max_element().max(1e-3) * 1e-3;
        let (min, max) = (min - Vec3::splat(pad), max + Vec3::splat(pad));
        SdTree {
            min,
            extent: (max - min).max(Vec3::splat(1e-6)),
            nodes: vec![SpatialNode::Leaf { leaf: 0, axis: 0 }],
            leaves: vec![Leaf {
                directions: QuadTree::uniform(),
                records: 0,
            }],
        }
    }

    /// The index of the leaf containing `p` (points outside the box go to the nearest).
    #[inline]
    fn leaf_of(&self, p: Vec3) -> usize {
        let mut x = ((p - self.min) / self.extent).clamp(Vec3::ZERO, Vec3::ONE);
        let mut node = 0usize;
        loop {
            match self.nodes[node] {
                SpatialNode::Leaf { leaf, .. } => return leaf as usize,
                SpatialNode::Inner { axis, children } => {
                    let a = axis as usize;
                    let upper = x[a] >= 0.5;
                    x[a] = if upper { x[a] * 2.0 - 1.0 } else { x[a] * 2.0 };
                    node = children[usize::from(upper)] as usize;
                }
            }
        }
    }

    /// The directional distribution that guides paths at `p`.
    #[inline]
    pub fn at(&self, p: Vec3) -> &QuadTree {
        &self.leaves[self.leaf_of(p)].directions
    }

    /// Adds a record: `value` (incident radiance over the density of its direction)
    /// arrived at `p` from the unit direction `d`.
    pub fn deposit(&mut self, p: Vec3, d: Vec3, value: f64) {
        let leaf = self.leaf_of(p);
        let leaf = &mut self.leaves[leaf];
        leaf.records += 1;
        if value.is_finite() && value > 0.0 {
            leaf.directions.deposit(d, value);
        }
    }

    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    /// Nodes of the spatial tree and of all its quadtrees.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
            + self
                .leaves
                .iter()
                .map(|l| l.directions.node_count())
                .sum::<usize>()
    }

    /// Bytes the tree holds.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<SpatialNode>()
            + self.leaves.capacity() * std::mem::size_of::<Leaf>()
            + self
                .leaves
                .iter()
                .map(|l| l.directions.memory_bytes())
                .sum::<usize>()
    }

    /// The same regions and cells with no records: where an iteration's records go.
    pub fn cleared(&self) -> SdTree {
        let mut tree = self.clone();
        for leaf in &mut tree.leaves {
            leaf.directions = leaf.directions.cleared();
            leaf.records = 0;
        }
        tree
    }

    /// The tree the next iteration samples from, after this one received the records
    /// of an iteration of `spp` samples per pixel: leaves with more than
    /// [`SPLIT_RECORDS_PER_SQRT_SPP`]` · √spp` records are split (both halves starting
    /// from the parent's records, half the count each, and split again while above),
    /// while the node budget allows; then every quadtree is rebuilt from its energy
    /// ([`QuadTree::refined`]). Deterministic: leaves are visited in index order.
    pub fn refined(&self, spp: u32) -> SdTree {
        let threshold = SPLIT_RECORDS_PER_SQRT_SPP * f64::from(spp.max(1)).sqrt();
        let mut tree = self.clone();
        let mut node = 0;
        while node < tree.nodes.len() {
            if let SpatialNode::Leaf { leaf, axis } = tree.nodes[node] {
                let records = tree.leaves[leaf as usize].records;
                if records as f64 > threshold && tree.nodes.len() + 2 <= MAX_SPATIAL_NODES {
                    tree.split(node, leaf as usize, axis);
                }
            }
            node += 1;
        }
        for leaf in &mut tree.leaves {
            leaf.directions = leaf.directions.refined();
            leaf.records = 0;
        }
        tree
    }

    /// Splits the leaf at `node` (index `leaf`) in two across `axis`; its children are
    /// visited later by [`refined`](Self::refined)'s loop.
    fn split(&mut self, node: usize, leaf: usize, axis: u8) {
        let next = (axis + 1) % 3;
        let mut half = self.leaves[leaf].clone();
        half.records /= 2;
        self.leaves[leaf] = half.clone();
        let upper_leaf = self.leaves.len() as u32;
        self.leaves.push(half);
        let first = self.nodes.len() as u32;
        self.nodes.push(SpatialNode::Leaf {
            leaf: leaf as u32,
            axis: next,
        });
        self.nodes.push(SpatialNode::Leaf {
            leaf: upper_leaf,
            axis: next,
        });
        self.nodes[node] = SpatialNode::Inner {
            axis,
            children: [first, first + 1],
        };
    }
}
