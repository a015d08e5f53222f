//! The spatial half of an SD-tree: a binary tree over the scene's bounding box, cut
//! at the middle along x, y, z in turn, each leaf holding a directional [`QuadTree`].

use glam::Vec3;

use super::quadtree::QuadTree;
use super::record::{MixtureDraw, Record};
use super::vertex::VertexGuide;
use super::GUIDE_PROBABILITY;

/// The selection probabilities a leaf chooses from (see [`SdTree::refined`]): never
/// below 0.1 nor above 0.8, so that the path weight stays within 1.25× (all BSDF
/// draws lost) and 10× (all guide draws lost) of the better of the two.
pub const SELECTION_CHOICES: [f32; 8] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8];

/// A leaf keeps the fixed [`GUIDE_PROBABILITY`] until this many guided draws were
/// recorded in it: fewer are too noisy an estimate of the second moment.
pub const MIN_SELECTION_DRAWS: u64 = 256;

/// The spatial tree never has more nodes than this (so at most 2048 leaves). With each
/// leaf's quadtree bounded by [`QuadTree::max_nodes`], the whole tree holds at most
/// `MAX_SPATIAL_NODES · 4 + 2048 · (2001 · 64 + 136)` bytes (≈ 262 MB) while guiding
/// a render, twice that while training (the tree being filled beside the one that
/// guides).
pub const MAX_SPATIAL_NODES: usize = 4095;

/// Müller et al.'s `c`: after an iteration of `spp` samples per pixel over an image of
/// [`SPLIT_REFERENCE_PIXELS`], a leaf that received more than `c · √spp` records is
/// split in two.
pub const SPLIT_RECORDS_PER_SQRT_SPP: f64 = 12_000.0;

/// The image size at which [`SPLIT_RECORDS_PER_SQRT_SPP`] holds as it is (1280×720);
/// other sizes scale `c` by their pixels over these ([`split_threshold`]).
pub const SPLIT_REFERENCE_PIXELS: u64 = 1280 * 720;

/// The records above which a leaf is split after an iteration of `spp` samples per
/// pixel over `pixels` pixels: `c · √spp · pixels / SPLIT_REFERENCE_PIXELS`. A fixed
/// `c` ties the number of regions to the image's size (at 160×90 a whole room gets
/// about 30, each spanning surfaces that face different ways); scaled, the tree has
/// about as many regions at any size, each learnt from fewer records on small images.
pub fn split_threshold(spp: u32, pixels: u64) -> f64 {
    let scale = pixels.max(1) as f64 / SPLIT_REFERENCE_PIXELS as f64;
    SPLIT_RECORDS_PER_SQRT_SPP * f64::from(spp.max(1)).sqrt() * scale
}

/// A node in one `u32` (a descent reads 4 bytes a level): bit 31 says a leaf; bits 29
/// and 30 hold an inner node's axis, or the axis a split of the leaf would cut (x at
/// the root, then y, z, x…); bits 0–28 the index of an inner node's lower child (the
/// upper one follows it) or of the leaf's [`Leaf`].
#[derive(Clone, Copy, Debug, PartialEq)]
struct SpatialNode(u32);

impl SpatialNode {
    const LEAF: u32 = 1 << 31;
    const INDEX: u32 = (1 << 29) - 1;

    fn inner(axis: u8, lower_child: u32) -> Self {
        SpatialNode(u32::from(axis) << 29 | lower_child)
    }

    fn leaf(leaf: u32, axis: u8) -> Self {
        SpatialNode(Self::LEAF | u32::from(axis) << 29 | leaf)
    }

    #[inline]
    fn is_leaf(self) -> bool {
        self.0 & Self::LEAF != 0
    }

    #[inline]
    fn axis(self) -> usize {
        (self.0 >> 29 & 3) as usize
    }

    /// The leaf's index, or the inner node's lower child.
    #[inline]
    fn index(self) -> usize {
        (self.0 & Self::INDEX) as usize
    }
}

/// One region of space: its directional distribution, how many records fell in it
/// during the iteration that filled it, its probability of drawing from the guide,
/// and the sums that choose the next one.
#[derive(Clone, Debug, PartialEq)]
struct Leaf {
    directions: QuadTree,
    records: u64,
    selection: f32,
    /// For each of [`SELECTION_CHOICES`], the sum over guided draws of
    /// `F² / (p_α · p)`: `F` the integrand's estimate, `p_α` the mixture density with
    /// that choice, `p` the density the draw had.
    moments: [f64; SELECTION_CHOICES.len()],
    draws: u64,
}

impl Leaf {
    fn uniform() -> Leaf {
        Leaf {
            directions: QuadTree::uniform(),
            records: 0,
            selection: GUIDE_PROBABILITY,
            moments: [0.0; SELECTION_CHOICES.len()],
            draws: 0,
        }
    }

    fn add_draw(&mut self, m: &MixtureDraw) {
        let f = f64::from(m.integrand);
        for (sum, &a) in self.moments.iter_mut().zip(&SELECTION_CHOICES) {
            let pa = f64::from((1.0 - a) * m.bsdf_pdf + a * m.guide_pdf);
            if pa > 0.0 {
                *sum += f * f / (pa * f64::from(m.pdf));
            }
        }
        self.draws += 1;
    }

    /// The choice of the smallest estimated second moment, or the fixed default
    /// with too few draws.
    fn best_selection(&self) -> f32 {
        if self.draws < MIN_SELECTION_DRAWS || !self.moments.iter().all(|m| m.is_finite()) {
            return GUIDE_PROBABILITY;
        }
        let best = (0..SELECTION_CHOICES.len())
            .min_by(|&a, &b| self.moments[a].total_cmp(&self.moments[b]))
            .unwrap_or(4);
        SELECTION_CHOICES[best]
    }
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
            nodes: vec![SpatialNode::leaf(0, 0)],
            leaves: vec![Leaf::uniform()],
        }
    }

    /// The index of the leaf containing `p` (points outside the box go to the nearest).
    #[inline]
    fn leaf_of(&self, p: Vec3) -> usize {
        self.leaf_at(((p - self.min) / self.extent).clamp(Vec3::ZERO, Vec3::ONE))
    }

    /// The index of the leaf containing `x`, in the unit cube of the tree's box.
    #[inline]
    fn leaf_at(&self, x: Vec3) -> usize {
        self.leaf_and_size_at(x).0
    }

    /// The index of the leaf containing `x` (in the unit cube of the tree's box) and
    /// its extent there. Each level halves the coordinate it cuts and rescales it to
    /// the half it fell in (exactly: a doubling, less one in the upper half).
    #[inline]
    fn leaf_and_size_at(&self, x: Vec3) -> (usize, Vec3) {
        let (mut x, mut size) = (x.to_array(), [1.0f32; 3]);
        let mut node = self.nodes[0];
        while !node.is_leaf() {
            let a = node.axis();
            let upper = x[a] >= 0.5;
            x[a] = if upper { x[a] * 2.0 - 1.0 } else { x[a] * 2.0 };
            size[a] *= 0.5;
            node = self.nodes[node.index() + usize::from(upper)];
        }
        (node.index(), Vec3::from_array(size))
    }

    /// The directional distribution of the region of `p`.
    #[inline]
    pub fn at(&self, p: Vec3) -> &QuadTree {
        &self.leaves[self.leaf_of(p)].directions
    }

    /// The guide of a vertex at `p` whose BSDF reflects into the side of the unit
    /// `normal`: its region's distribution folded onto that side, with its region's
    /// selection probability (see [`VertexGuide`]).
    #[inline]
    pub fn guide_at(&self, p: Vec3, normal: Vec3) -> VertexGuide<'_> {
        let leaf = &self.leaves[self.leaf_of(p)];
        VertexGuide::new(&leaf.directions, normal, leaf.selection)
    }

    /// The selection probability of the region of `p`.
    pub fn selection_at(&self, p: Vec3) -> f32 {
        self.leaves[self.leaf_of(p)].selection
    }

    /// Adds a record: `value` (incident radiance over the density of its direction)
    /// arrived at `p` from the unit direction `d`. The record counts in the leaf of
    /// `p` only; its value is spread by box filters over space and direction (see
    /// [`deposit_filtered`](Self::deposit_filtered)).
    pub fn deposit(&mut self, record: &Record) {
        let x = ((record.p - self.min) / self.extent).clamp(Vec3::ZERO, Vec3::ONE);
        let (leaf, size) = self.leaf_and_size_at(x);
        let leaf_data = &mut self.leaves[leaf];
        leaf_data.records += 1;
        if let Some(m) = &record.mixture {
            leaf_data.add_draw(m);
        }
        let value = f64::from(record.value);
        if value.is_finite() && value > 0.0 {
            self.deposit_filtered(record, x, size, value);
        }
    }

    /// Müller et al.'s spatial box filter, stochastically as they do it: the record
    /// goes to the leaf at a point drawn uniformly from a box of `size` (the extent of
    /// the leaf of the record's point, `x` in the unit cube of the tree's box), centred
    /// on `x` (clamped to the tree's box), and is spread over directions there by
    /// [`QuadTree::deposit_filtered`]. The draw comes from a hash of the
    /// record itself, so records folded in a fixed order still give the same tree at
    /// any thread count. One leaf a record, where spreading it over every leaf the box
    /// overlaps (up to 8, each a quadtree splat) took a quarter of a guided Cornell
    /// run's instructions; in expectation the two are the same filter.
    fn deposit_filtered(&mut self, record: &Record, x: Vec3, size: Vec3, value: f64) {
        let jitter = record_jitter(record.p, record.dir) - Vec3::splat(0.5);
        let jittered = (x + jitter * size).clamp(Vec3::ZERO, Vec3::ONE);
        let leaf = self.leaf_at(jittered);
        self.leaves[leaf]
            .directions
            .deposit_filtered(record.dir, value);
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
            leaf.moments = [0.0; SELECTION_CHOICES.len()];
            leaf.draws = 0;
        }
        tree
    }

    /// The tree the next iteration samples from, after this one received the records
    /// of an iteration of `spp` samples per pixel over `pixels` pixels: leaves with more
    /// than [`split_threshold`] records are split (both halves starting
    /// from the parent's records, half the count each, and split again while above),
    /// while the node budget allows; then every quadtree is rebuilt from its energy
    /// ([`QuadTree::refined`]). Deterministic: leaves are visited in index order.
    ///
    /// Each leaf's selection probability becomes the one of [`SELECTION_CHOICES`]
    /// whose estimated second moment `Σ F² / (p_α · p)` over the leaf's guided draws
    /// is smallest (an unbiased estimate of `∫ F² / p_α`, the second moment of the
    /// estimator with that choice): the fixed [`GUIDE_PROBABILITY`] where the guide
    /// learnt well or badly alike is the weakest part of Müller et al. 2017, and their
    /// 2019 follow-up learns it per region too (by gradient descent; this is the same
    /// objective minimised over a grid). Split leaves keep their parent's.
    pub fn refined(&self, spp: u32, pixels: u64) -> SdTree {
        let threshold = split_threshold(spp, pixels);
        let mut tree = self.clone();
        for leaf in &mut tree.leaves {
            leaf.selection = leaf.best_selection();
        }
        let mut node = 0;
        while node < tree.nodes.len() {
            let n = tree.nodes[node];
            if n.is_leaf() {
                let records = tree.leaves[n.index()].records;
                if records as f64 > threshold && tree.nodes.len() + 2 <= MAX_SPATIAL_NODES {
                    tree.split(node, n.index(), n.axis() as u8);
                }
            }
            node += 1;
        }
        for leaf in &mut tree.leaves {
            leaf.directions = leaf.directions.refined();
            leaf.records = 0;
            leaf.moments = [0.0; SELECTION_CHOICES.len()];
            leaf.draws = 0;
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
        self.nodes.push(SpatialNode::leaf(leaf as u32, next));
        self.nodes.push(SpatialNode::leaf(upper_leaf, next));
        self.nodes[node] = SpatialNode::inner(axis, first);
    }
}

/// Three uniforms in `[0, 1)` from the bits of a record's point and direction
/// (SplitMix64's finaliser over them): the spatial filter's jitter.
fn record_jitter(p: Vec3, d: Vec3) -> Vec3 {
    fn mix(mut z: u64) -> u64 {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    let bits = |v: Vec3| {
        (
            u64::from(v.x.to_bits()) << 32 | u64::from(v.y.to_bits()),
            v.z.to_bits(),
        )
    };
    let (a, b) = bits(p);
    let (c, e) = bits(d);
    let h = mix(a ^ mix(c ^ mix(u64::from(b) << 32 | u64::from(e))));
    let h2 = mix(h ^ 0x9e37_79b9_7f4a_7c15);
    // 24 bits each, so that every value is exact in f32 and below 1.
    let unit = |v: u64| (v & 0xff_ffff) as f32 / (1u32 << 24) as f32;
    Vec3::new(unit(h >> 40), unit(h >> 16), unit(h2 >> 40))
}
