//! The spatial half of an SD-tree: a binary tree over the scene's bounding box, cut
//! at the middle along x, y, z in turn, each leaf holding a directional [`QuadTree`].

use glam::{UVec3, Vec3};
use rayon::prelude::*;

use super::quadtree::QuadTree;
use super::record::{hash, Draw, GuidedDraw, MixtureDraw, Record, Shadow};
use super::vertex::{draws_from_guide, VertexGuide};
use super::GUIDE_PROBABILITY;
use crate::sampling::mix64;

/// The selection probabilities a leaf chooses from (see [`SdTree::refined`]): none
/// (the BSDF alone, where guiding does not pay for its cost, [`GUIDED_COST`]), or
/// from 0.1 to 0.8, so that the path weight stays within 1.25× (all BSDF draws lost)
/// and 10× (all guide draws lost) of the better of the two.
pub const SELECTION_CHOICES: [f32; 9] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8];

/// What a guided choice costs against the base strategy alone, as a factor on its
/// estimated second moment when a leaf chooses a share ([`SdTree::refined`]): a
/// share above 0 must lower the second moment by more than this to be chosen over 0.
/// Efficiency is one over variance times time, and a guided vertex costs more than an
/// unguided one (the guide's lookups: a path of the room costs 1.7× with every vertex
/// guided, one of the Cornell box 2.4×, `perf`), though less than the rest of the path
/// it starts, which the draw's second moment speaks for; a region where both shares
/// are 0 is rendered unguided ([`VertexGuide::guides`]), at the cost of unguided `mis`.
/// Per sample (seed 11; room 255 spp, boxes 63 spp at 512², 3 iterations), 1.0, 1.2
/// and 1.5 gave the room 1.97e-2, 2.00e-2, 2.08e-2 (519, 520, 489 of 607 regions
/// guided), the Original 1.14e-3, 1.14e-3, 1.20e-3 (410, 84, 35 of 728), GlossyMix
/// 8.29e-3, 8.66e-3, 9.61e-3 (456, 249, 118 of 722): 1.2 keeps the quality of 1.0
/// with a fifth of the Original's regions guided.
pub const GUIDED_COST: f64 = 1.2;

/// The shares of guided sky samples a leaf chooses from (see [`SdTree::refined`]):
/// from none (where the guide does not know where the sky is seen better than the
/// sky's own distribution) to 0.9, which keeps a tenth of the sky's own sampling for
/// a sky the guide has not resolved (a sun smaller than its cells).
pub const SKY_SHARE_CHOICES: [f32; 10] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9];

/// A leaf keeps the fixed [`GUIDE_PROBABILITY`] until this many guided draws were
/// recorded in it: fewer are too noisy an estimate of the second moment.
pub const MIN_SELECTION_DRAWS: u64 = 256;

/// ... and until this many of them found light: the second moments are sums over the
/// draws that did, so without them every choice looks alike (a region that sees the
/// sky through a small window, drawing from the sky's own distribution, rarely hits
/// it; taking the first of equal choices there locked the share at 0).
pub const MIN_LIT_DRAWS: u64 = 16;

/// A leaf learns how often its emitters' light samples find them (see
/// [`SdTree::deposit`]) from at least this many; with fewer its guide learns all of
/// their light, as where they are always blocked.
pub const MIN_SHADOW_TESTS: u32 = 16;

/// The spatial tree never has more nodes than this (so at most 2048 leaves). With each
/// of a leaf's two quadtrees bounded by [`QuadTree::max_nodes`], the whole tree holds
/// at most `MAX_SPATIAL_NODES · 4 + 2048 · (2 · 2001 · 48 + 200)` bytes (≈ 394 MB)
/// while guiding a render, twice that while training (the tree being filled beside
/// the one that guides). A leaf's sky quadtree is one node where it sees no sky.
pub const MAX_SPATIAL_NODES: usize = 4095;

/// Müller et al.'s `c`: after an iteration of `spp` samples per pixel over an image of
/// [`SPLIT_REFERENCE_PIXELS`], a leaf that received more than `c · √spp` records is
/// split in two.
pub const SPLIT_RECORDS_PER_SQRT_SPP: f64 = 12_000.0;

/// The image size at which [`SPLIT_RECORDS_PER_SQRT_SPP`] holds as it is (1280×720);
/// other sizes scale `c` by the square root of their pixels over these
/// ([`split_threshold`]).
pub const SPLIT_REFERENCE_PIXELS: u64 = 1280 * 720;

/// The records above which a leaf is split after an iteration of `spp` samples per
/// pixel over `pixels` pixels: `c · √spp · √(pixels / SPLIT_REFERENCE_PIXELS)`.
///
/// Why the square root: a fixed `c` ties the regions' number to the image's size, and
/// `c` scaled by the pixels leaves each region too few records; the square root was
/// best on the room and at equal time (benches/results/2026-12-02-guiding-sd-tree-1-to-8.md).
pub fn split_threshold(spp: u32, pixels: u64) -> f64 {
    let scale = (pixels.max(1) as f64 / SPLIT_REFERENCE_PIXELS as f64).sqrt();
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

/// One region of space: its directional distribution of the incident light its
/// guide draws towards (see [`SdTree::deposit`]), that of the sky light it sees
/// directly (which its sky samples follow), and what the iteration that filled it
/// left besides: how many records fell in it, the sum of their values with all of
/// their direct light (for [`incident_estimate`]), and how many of its emitters'
/// light samples were tested and found clear (for [`visibility_estimate`]). The
/// shares in use are [`SdTree`]'s.
#[derive(Clone, Debug, PartialEq)]
struct Leaf {
    directions: QuadTree,
    sky: QuadTree,
    records: u64,
    irradiance: f64,
    shadow_tests: u32,
    clear: u32,
}

impl Leaf {
    /// A leaf with these distributions and no records.
    fn fresh(directions: QuadTree, sky: QuadTree) -> Leaf {
        Leaf {
            directions,
            sky,
            records: 0,
            irradiance: 0.0,
            shadow_tests: 0,
            clear: 0,
        }
    }

    /// Counts a record whose point lies in this leaf.
    fn count(&mut self, shadow: Shadow) {
        match shadow {
            Shadow::Untested => self.records += 1,
            Shadow::Clear => {
                self.records += 1;
                self.shadow_tests += 1;
                self.clear += 1;
            }
            Shadow::Blocked => self.shadow_tests += 1,
            Shadow::Delta => self.records += 1,
        }
    }

    /// Adds a record's values, its direct light times its [`direct_share`], spread
    /// over directions (see [`QuadTree::deposit_filtered`]).
    fn deposit(&mut self, dir: Vec3, values: Values, visibility: f32) {
        let Values {
            value,
            direct,
            sky,
            delta,
        } = values;
        let guided = value + direct_share(visibility) * direct;
        if positive(guided) {
            self.directions.deposit_filtered(dir, f64::from(guided));
        }
        // A delta light's, which no guided direction can find, counts here only.
        let arrived = value + direct + delta;
        if positive(arrived) {
            self.irradiance += f64::from(arrived);
        }
        if positive(sky) {
            self.sky.deposit_filtered(dir, f64::from(sky));
        }
    }
}

/// A [`Record`]'s values, as its leaf deposits them.
#[derive(Clone, Copy)]
struct Values {
    value: f32,
    direct: f32,
    sky: f32,
    delta: f32,
}

impl From<&Record> for Values {
    fn from(r: &Record) -> Values {
        let (direct, delta) = match r.shadow {
            Shadow::Delta => (0.0, r.direct),
            _ => (r.direct, 0.0),
        };
        Values {
            value: r.value,
            direct,
            sky: r.sky,
            delta,
        }
    }
}

/// Whether a record's value is deposited: finite and positive.
fn positive(value: f32) -> bool {
    value.is_finite() && value > 0.0
}

/// The shares that `draws`, made in the region `leaf`, choose with its (folded)
/// guides: the probability of drawing a scattered direction from the guide rather than
/// the BSDF, of [`SELECTION_CHOICES`], and the share of sky samples drawn from the
/// sky guide rather than the sky's own distribution, of [`SKY_SHARE_CHOICES`].
fn learnt_shares<'d>(leaf: &Leaf, draws: impl Iterator<Item = &'d GuidedDraw>) -> [f32; 2] {
    let mut selection = LearntShare::<{ SELECTION_CHOICES.len() }>::new();
    let mut sky_share = LearntShare::<{ SKY_SHARE_CHOICES.len() }>::new();
    for d in draws {
        let guide = |m: &MixtureDraw| {
            VertexGuide::new(&leaf.directions, m.normal, 0.0, 0.0).with_sky(&leaf.sky)
        };
        // A draw that found no light adds nothing but its count, whatever the density.
        let lit = |m: &MixtureDraw| m.integrand > 0.0;
        match &d.draw {
            Draw::Scattered(m) if lit(m) => {
                selection.add(m, guide(m).pdf(d.dir), &SELECTION_CHOICES)
            }
            Draw::Sky(m) if lit(m) => sky_share.add(m, guide(m).sky_pdf(d.dir), &SKY_SHARE_CHOICES),
            Draw::Scattered(m) => selection.add(m, 0.0, &SELECTION_CHOICES),
            Draw::Sky(m) => sky_share.add(m, 0.0, &SKY_SHARE_CHOICES),
        }
    }
    [
        selection.chosen(&SELECTION_CHOICES),
        sky_share.chosen(&SKY_SHARE_CHOICES),
    ]
}

/// The sums over an iteration's draws from a mixture of a base strategy and the
/// guide that choose the guide's share in the next one.
#[derive(Clone, Debug, PartialEq)]
struct LearntShare<const N: usize> {
    /// For each choice `s`, the sum over draws of `F² / (p_s · p)`: `F` the
    /// integrand's estimate, `p_s` the density of the mixture with that choice and the
    /// guide it will be used with, `p` the density the draw had.
    moments: [f64; N],
    draws: u64,
    /// Draws whose integrand was positive.
    lit: u64,
}

impl<const N: usize> LearntShare<N> {
    fn new() -> Self {
        LearntShare {
            moments: [0.0; N],
            draws: 0,
            lit: 0,
        }
    }

    /// Adds the draw `m`, along which the guide to be used has density `guide_pdf`.
    fn add(&mut self, m: &MixtureDraw, guide_pdf: f32, choices: &[f32; N]) {
        let f = f64::from(m.integrand);
        let guide_pdf = m.guide_scale * guide_pdf;
        for (sum, &s) in self.moments.iter_mut().zip(choices) {
            let ps = f64::from((1.0 - s) * m.base_pdf + s * guide_pdf);
            if ps > 0.0 {
                *sum += f * f / (ps * f64::from(m.pdf));
            } else if f > 0.0 {
                // The choice could not have drawn a direction that carried light.
                *sum = f64::INFINITY;
            }
        }
        self.draws += 1;
        self.lit += u64::from(f > 0.0);
    }

    /// The choice of the smallest estimated second moment times its cost (1 for the
    /// base strategy alone, [`GUIDED_COST`] with the guide; the fixed default with too
    /// few draws, or too few that found light; none without any draw, as for the sky
    /// share of a scene without a sky, so that such a region can be unguided).
    fn chosen(&self, choices: &[f32; N]) -> f32 {
        if self.draws == 0 {
            return 0.0;
        }
        let few = self.draws < MIN_SELECTION_DRAWS || self.lit < MIN_LIT_DRAWS;
        if few || self.moments.iter().all(|m| !m.is_finite()) {
            return GUIDE_PROBABILITY;
        }
        let cost = |i: usize| {
            let factor = if choices[i] > 0.0 { GUIDED_COST } else { 1.0 };
            self.moments[i] * factor
        };
        let best = (0..N)
            .min_by(|&a, &b| cost(a).total_cmp(&cost(b)))
            .unwrap_or(0);
        choices[best]
    }
}

/// Levels of the spatial tree that [`SdTree`]'s table resolves in one lookup: four
/// cuts along each axis, a grid of 16³ cells (16 KiB). Nodes at depth `l` cut axis
/// `l mod 3` (x at the root, each split cutting the next axis), so the nodes at depth
/// 12 are the cells of that grid, and a cell's node is the one the descent reaches
/// there; a descent then starts from it, which on the room's 2048-leaf tree saves
/// most of its levels (about 240 instructions a lookup).
const TABLE_LEVELS: u32 = 12;
const TABLE_SIDE: u32 = 1 << (TABLE_LEVELS / 3);

/// A cell of the table: the node the descent reaches within [`TABLE_LEVELS`] (bits
/// 0–15; [`MAX_SPATIAL_NODES`] fits) and its depth (bits 16 on).
#[derive(Clone, Copy, Debug, PartialEq)]
struct TableCell(u32);

/// A spatial-directional tree (see [`crate::guiding`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SdTree {
    min: Vec3,
    extent: Vec3,
    nodes: Vec<SpatialNode>,
    leaves: Vec<Leaf>,
    /// The grid of [`TABLE_LEVELS`], x fastest, then y, then z: a function of `nodes`.
    table: Vec<TableCell>,
    /// Each leaf's selection probability and sky share in use, 8 bytes apart where a
    /// [`Leaf`] spans four cache lines: every vertex reads them, to know whether its
    /// region guides at all.
    shares: Vec<[f32; 2]>,
    /// Each leaf's estimate of the light arriving at a point in it, `∫ L |cos θ| dω`
    /// (see [`incident_estimate`]); 0 where nothing was learnt.
    incident: Vec<f32>,
    /// Each leaf's estimate of the share of its emitters' light samples that find
    /// their emitter (see [`visibility_estimate`]), learnt by the iteration before the
    /// one it deposits: 0 where nothing was learnt.
    visibility: Vec<f32>,
}

impl SdTree {
    /// One leaf over the box `(min, max)`, uniform in every direction. The box is
    /// widened a little so that points on its faces fall inside.
    pub fn new((min, max): (Vec3, Vec3)) -> SdTree {
        let pad = (max - min).max_element().max(1e-3) * 1e-3;
        let (min, max) = (min - Vec3::splat(pad), max + Vec3::splat(pad));
        let nodes = vec![SpatialNode::leaf(0, 0)];
        SdTree {
            min,
            extent: (max - min).max(Vec3::splat(1e-6)),
            table: table_of(&nodes),
            nodes,
            leaves: vec![Leaf::fresh(QuadTree::uniform(), QuadTree::uniform())],
            // The untrained region is not drawn from (see [`GUIDE_PROBABILITY`]).
            shares: vec![[0.0, 0.0]],
            incident: vec![0.0],
            visibility: vec![0.0],
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
    /// the half it fell in (exactly: a doubling, less one in the upper half); the
    /// table takes the first [`TABLE_LEVELS`] at once (`x · 16` less its integer part
    /// is exactly what four such steps along an axis leave, and that integer's bits,
    /// from the highest, are their choices; `x = 1` takes the upper half every time,
    /// and stays 1, as in the last cell).
    #[inline]
    fn leaf_and_size_at(&self, x: Vec3) -> (usize, Vec3) {
        let scaled = x * TABLE_SIDE as f32;
        // `x` is within [0, 1], so truncation is the floor (a conversion, where
        // `floor` is a call to libm without SSE4.1).
        let i = scaled.as_uvec3().min(UVec3::splat(TABLE_SIDE - 1));
        let cell = i.as_vec3();
        let entry = self.table[((i.z * TABLE_SIDE + i.y) * TABLE_SIDE + i.x) as usize];
        let (mut node, depth) = (self.nodes[(entry.0 & 0xffff) as usize], entry.0 >> 16);
        if depth < TABLE_LEVELS {
            // A leaf above the grid: its extent halves once per cut of each axis.
            let cuts = |a: u32| (depth + 2 - a) / 3;
            let size = Vec3::new(1.0, 1.0, 1.0)
                / UVec3::new(1 << cuts(0), 1 << cuts(1), 1 << cuts(2)).as_vec3();
            return (node.index(), size);
        }
        let mut x = (scaled - cell).to_array();
        let mut size = [1.0 / TABLE_SIDE as f32; 3];
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

    /// The distribution of the sky seen directly from the region of `p`.
    #[inline]
    pub fn sky_at(&self, p: Vec3) -> &QuadTree {
        &self.leaves[self.leaf_of(p)].sky
    }

    /// The guide of a vertex at `p` whose BSDF reflects into the side of the unit
    /// `normal`: its region's distribution folded onto that side, with its region's
    /// selection probability (see [`VertexGuide`]).
    #[inline]
    pub fn guide_at(&self, p: Vec3, normal: Vec3) -> VertexGuide<'_> {
        let leaf = self.leaf_of(p);
        let [selection, sky_share] = self.shares[leaf];
        let Leaf {
            directions, sky, ..
        } = &self.leaves[leaf];
        VertexGuide::new(directions, normal, selection, sky_share)
            .with_sky(sky)
            .with_incident(self.incident[leaf])
    }

    /// The selection probability of the region of `p`.
    pub fn selection_at(&self, p: Vec3) -> f32 {
        self.shares[self.leaf_of(p)][0]
    }

    /// The share of guided sky samples of the region of `p`.
    pub fn sky_share_at(&self, p: Vec3) -> f32 {
        self.shares[self.leaf_of(p)][1]
    }

    /// The estimate of `∫ L |cos θ| dω` at `p` its region learnt (see
    /// [`incident_estimate`]).
    pub fn incident_at(&self, p: Vec3) -> f32 {
        self.incident[self.leaf_of(p)]
    }

    /// Adds a record (incident radiance times the cosine at its vertex, over the
    /// density of its direction, arrived at `p` from the unit direction `d`; see
    /// [`Record`]). The record counts in the leaf of `p` only; its values are spread by
    /// box filters over space and direction (see [`route`](Self::route)).
    ///
    /// The leaf's guide learns the record's `value` and its `direct` light times the
    /// [`direct_share`] of the leaf's [`visibility`](visibility_estimate): the guide's
    /// draws are worth most where next-event estimation does badly, and an emitter's
    /// direct light is what it estimates well, but for the samples whose shadow ray is
    /// blocked. In a Cornell box, where the lamp is seen from almost everywhere, the
    /// guide learns the light the walls reflect; in a box lit through a hole by a lamp
    /// above it, where most light samples hit the ceiling, nearly all of the lamp's
    /// light.
    pub fn deposit(&mut self, record: &Record) {
        let route = self.route(record);
        self.leaves[route.home as usize].count(record.shadow);
        if let Some(target) = route.target {
            let visibility = self.visibility[target as usize];
            self.leaves[target as usize].deposit(record.dir, record.into(), visibility);
        }
    }

    /// Adds the records of `tiles` as [`deposit`](Self::deposit) would one by one, tile
    /// after tile, to the bit, but the leaves in parallel: each leaf's quadtree takes
    /// its records in that same order, whatever the number of threads, so the tree
    /// stays a function of the records. Each leaf's values are first copied into one
    /// run of memory (its group), so that its quadtree reads them in sequence.
    pub fn deposit_all(&mut self, tiles: &[Vec<Record>]) {
        let routes: Vec<Vec<Route>> = tiles
            .par_iter()
            .map(|tile| tile.iter().map(|r| self.route(r)).collect())
            .collect();
        let deposits = tiles.iter().flatten().zip(routes.iter().flatten());
        for (record, route) in deposits.clone() {
            self.leaves[route.home as usize].count(record.shadow);
        }
        let targets = LeafGroups::new(
            self.leaves.len(),
            deposits.filter_map(|(r, route)| Some((route.target?, (r.dir, Values::from(r))))),
        );
        drop(routes);
        let visibility = &self.visibility;
        self.leaves
            .par_iter_mut()
            .enumerate()
            .for_each(|(i, leaf)| {
                for &(dir, values) in targets.of(i) {
                    leaf.deposit(dir, values, visibility[i]);
                }
            });
    }

    /// Where a record goes: the leaf of its point, which counts it, and the leaf its
    /// value is deposited into (none when the value is not finite and positive), by
    /// Müller et al.'s spatial box filter, stochastically as they do it: the leaf at a
    /// point drawn uniformly from a box the size of the leaf of the record's point,
    /// centred on it (clamped to the tree's box); there its value is spread over
    /// directions by [`QuadTree::deposit_filtered`]. The draw comes from a hash of the
    /// record itself, so records folded in a fixed order still give the same tree at
    /// any thread count. One leaf a record, where spreading it over every leaf the box
    /// overlaps (up to 8, each a quadtree splat) took a quarter of a guided Cornell
    /// run's instructions; in expectation the two are the same filter.
    fn route(&self, record: &Record) -> Route {
        let x = ((record.p - self.min) / self.extent).clamp(Vec3::ZERO, Vec3::ONE);
        let (home, size) = self.leaf_and_size_at(x);
        let target = [record.value, record.direct, record.sky];
        let target = target.into_iter().any(positive).then(|| {
            let jitter = record_jitter(record.p, record.dir) - Vec3::splat(0.5);
            let jittered = (x + jitter * size).clamp(Vec3::ZERO, Vec3::ONE);
            self.leaf_at(jittered) as u32
        });
        Route {
            home: home as u32,
            target,
        }
    }

    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    /// The regions that draw from their guide (the others are rendered unguided).
    pub fn guided_leaf_count(&self) -> usize {
        let guides = |&&[selection, sky_share]: &&[f32; 2]| draws_from_guide(selection, sky_share);
        self.shares.iter().filter(guides).count()
    }

    /// Nodes of the spatial tree and of all its quadtrees.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
            + self
                .leaves
                .iter()
                .map(|l| l.directions.node_count() + l.sky.node_count())
                .sum::<usize>()
    }

    /// Bytes the tree holds.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<SpatialNode>()
            + self.table.capacity() * std::mem::size_of::<TableCell>()
            + self.shares.capacity() * std::mem::size_of::<[f32; 2]>()
            + self.incident.capacity() * std::mem::size_of::<f32>()
            + self.visibility.capacity() * std::mem::size_of::<f32>()
            + self.leaves.capacity() * std::mem::size_of::<Leaf>()
            + self
                .leaves
                .iter()
                .map(|l| l.directions.memory_bytes() + l.sky.memory_bytes())
                .sum::<usize>()
    }

    /// The same regions and cells with no records: where an iteration's records go.
    pub fn cleared(&self) -> SdTree {
        SdTree {
            min: self.min,
            extent: self.extent,
            nodes: self.nodes.clone(),
            table: self.table.clone(),
            leaves: self
                .leaves
                .par_iter()
                .map(|leaf| Leaf::fresh(leaf.directions.cleared(), leaf.sky.cleared()))
                .collect(),
            shares: self.shares.clone(),
            incident: self.incident.clone(),
            visibility: self.visibility.clone(),
        }
    }

    /// The tree the next iteration samples from, after this one received the records
    /// of an iteration of `spp` samples per pixel over `pixels` pixels: leaves with more
    /// than [`split_threshold`] records are split (both halves starting
    /// from the parent's records, half the count each, and split again while above),
    /// while the node budget allows; then every quadtree is rebuilt from its energy
    /// ([`QuadTree::refined`], the leaves in parallel, each a function of its own).
    /// Deterministic: leaves are visited in index order.
    ///
    /// Each leaf's selection probability becomes the one of [`SELECTION_CHOICES`]
    /// whose estimated second moment `Σ F² / (p_α · p)` over the guided `draws` of
    /// the iteration at points in the leaf is smallest (an unbiased estimate of
    /// `∫ F² / p_α`, the second moment of the estimator with that choice), `p_α` the
    /// mixture with the leaf's new guide, the one the share will be used with: the
    /// fixed [`GUIDE_PROBABILITY`] where the guide learnt well or badly alike is the
    /// weakest part of Müller et al. 2017, and their 2019 follow-up learns it per
    /// region too (by gradient descent; this is the same objective minimised over a
    /// grid). Likewise each leaf's share of guided sky samples, of
    /// [`SKY_SHARE_CHOICES`], over its sky samples' draws.
    ///
    /// Why the new guide: the draws were made with the iteration's guide, learnt from
    /// half as many samples; judged by that one, which concentrates less light, the
    /// moments were biased against guiding, and `sd-tree 7` left regions unguided
    /// that its better guide would have paid in (GlossyMix lost most:
    /// benches/results/2026-12-02-guiding-sd-tree-1-to-8.md).
    ///
    /// Each leaf also keeps its records' [`incident_estimate`], for adjoint-driven
    /// roulette (see `crate::integrator`).
    pub fn refined(&self, spp: u32, pixels: u64, draws: &[GuidedDraw]) -> SdTree {
        let threshold = split_threshold(spp, pixels);
        let mut nodes = self.nodes.clone();
        // For each leaf of the new tree, the leaf of this one it comes from and its
        // share of that leaf's records.
        let mut source: Vec<usize> = (0..self.leaves.len()).collect();
        let mut records: Vec<u64> = self.leaves.iter().map(|l| l.records).collect();
        let mut node = 0;
        while node < nodes.len() {
            let n = nodes[node];
            if n.is_leaf()
                && records[n.index()] as f64 > threshold
                && nodes.len() + 2 <= MAX_SPATIAL_NODES
            {
                // Both halves start from the parent's records; its children are
                // visited later by this loop.
                let (leaf, next) = (n.index(), (n.axis() as u8 + 1) % 3);
                records[leaf] /= 2;
                source.push(source[leaf]);
                records.push(records[leaf]);
                let first = nodes.len() as u32;
                nodes.push(SpatialNode::leaf(leaf as u32, next));
                nodes.push(SpatialNode::leaf(records.len() as u32 - 1, next));
                nodes[node] = SpatialNode::inner(n.axis() as u8, first);
            }
            node += 1;
        }
        let incident = source
            .iter()
            .map(|&s| incident_estimate(&self.leaves[s]))
            .collect();
        let visibility = source
            .iter()
            .map(|&s| visibility_estimate(&self.leaves[s]))
            .collect();
        let leaves: Vec<Leaf> = source
            .par_iter()
            .map(|&s| {
                let leaf = &self.leaves[s];
                Leaf::fresh(leaf.directions.refined(), leaf.sky.refined())
            })
            .collect();
        let mut tree = SdTree {
            min: self.min,
            extent: self.extent,
            table: table_of(&nodes),
            nodes,
            shares: vec![[0.0; 2]; leaves.len()],
            leaves,
            incident,
            visibility,
        };
        tree.learn_shares(draws);
        tree
    }

    /// Each leaf's shares, chosen by the `draws` whose point lies in it, with its own
    /// guide (see [`refined`](Self::refined)); the leaves in parallel, each summing its
    /// draws in their order in `draws`, so the shares are a function of the draws.
    fn learn_shares(&mut self, draws: &[GuidedDraw]) {
        let homes: Vec<u32> = draws.par_iter().map(|d| self.leaf_of(d.p) as u32).collect();
        // The draws' indices, 4 bytes each where a draw takes 56.
        let indices = homes.iter().enumerate().map(|(i, &leaf)| (leaf, i as u32));
        let groups = LeafGroups::new(self.leaves.len(), indices);
        drop(homes);
        self.shares = self
            .leaves
            .par_iter()
            .enumerate()
            .map(|(i, leaf)| {
                let own = groups.of(i).iter().map(|&d| &draws[d as usize]);
                learnt_shares(leaf, own)
            })
            .collect();
    }
}

/// Records a path vertex leaves in training: the direction it scattered into and its
/// light sample (see [`crate::guiding::PathRecorder`]).
pub const RECORDS_PER_VERTEX: f64 = 2.0;

/// A leaf's estimate of `∫ L |cos θ| dω`, the irradiance of a point in it, `θ` the
/// angle to the surface's normal: the sum of the values deposited in it (each an
/// estimate of incident radiance times that cosine over the density of its direction;
/// see [`Record`]) per vertex that recorded in it, taking
/// [`RECORDS_PER_VERTEX`] records a vertex. Rough by design: the values of
/// neighbouring regions are spread into it by the spatial filter, light samples that
/// found an emitter hidden are not counted, and a vertex near the end of a path may
/// leave one; it only steers roulette, which stays unbiased whatever it says.
fn incident_estimate(leaf: &Leaf) -> f32 {
    match leaf.records {
        0 => 0.0,
        n => (RECORDS_PER_VERTEX * leaf.irradiance / n as f64) as f32,
    }
}

/// The share of an emitter's direct light a region's guide learns where a share
/// `visibility` of its light samples find their emitter: `(1 − visibility)²`, all of
/// it where they are all blocked, none where none is. Why squared: per sample it was
/// as good as or better than `1 − visibility`, `(1 − visibility)⁴`, all or none, on the
/// Cornell boxes and the staircase (benches/results/2026-12-04-guiding-sittings-10-to-13.md).
fn direct_share(visibility: f32) -> f32 {
    (1.0 - visibility) * (1.0 - visibility)
}

/// A leaf's estimate of the share of its emitters' light samples whose shadow ray is
/// clear: 0 (its guide learns all their light) below [`MIN_SHADOW_TESTS`].
fn visibility_estimate(leaf: &Leaf) -> f32 {
    match leaf.shadow_tests {
        n if n < MIN_SHADOW_TESTS => 0.0,
        n => leaf.clear as f32 / n as f32,
    }
}

/// The table of the tree of `nodes` (see [`TABLE_LEVELS`]).
fn table_of(nodes: &[SpatialNode]) -> Vec<TableCell> {
    let side = TABLE_SIDE;
    let mut table = Vec::with_capacity((side * side * side) as usize);
    for (z, y, x) in
        (0..side).flat_map(|z| (0..side).flat_map(move |y| (0..side).map(move |x| (z, y, x))))
    {
        let cell = [x, y, z];
        let (mut node, mut depth) = (0usize, 0u32);
        while depth < TABLE_LEVELS && !nodes[node].is_leaf() {
            let a = nodes[node].axis();
            debug_assert_eq!(a as u32, depth % 3);
            let bit = cell[a] >> (TABLE_LEVELS / 3 - 1 - depth / 3) & 1;
            node = nodes[node].index() + bit as usize;
            depth += 1;
        }
        table.push(TableCell(depth << 16 | node as u32));
    }
    table
}

/// Where a record goes (see [`SdTree::route`]).
#[derive(Clone, Copy)]
struct Route {
    home: u32,
    target: Option<u32>,
}

/// Items grouped by leaf, in their order within each leaf (a counting sort).
struct LeafGroups<T> {
    /// Leaf `i`'s items are `items[start[i]..start[i + 1]]`.
    start: Vec<usize>,
    items: Vec<T>,
}

impl<T: Copy> LeafGroups<T> {
    /// The `items`, each with the index of its leaf, grouped by leaf.
    fn new(leaves: usize, items: impl Iterator<Item = (u32, T)> + Clone) -> Self {
        let mut start = vec![0usize; leaves + 1];
        for (leaf, _) in items.clone() {
            start[leaf as usize + 1] += 1;
        }
        for i in 0..leaves {
            start[i + 1] += start[i];
        }
        let mut next = start.clone();
        // Every slot is written once below; the first item only fills them till then.
        let mut grouped = match items.clone().next() {
            Some((_, first)) => vec![first; start[leaves]],
            None => Vec::new(),
        };
        for (leaf, item) in items {
            grouped[next[leaf as usize]] = item;
            next[leaf as usize] += 1;
        }
        LeafGroups {
            start,
            items: grouped,
        }
    }

    fn of(&self, leaf: usize) -> &[T] {
        &self.items[self.start[leaf]..self.start[leaf + 1]]
    }
}

/// Three uniforms in `[0, 1)` from the bits of a record's point and direction: the
/// spatial filter's jitter.
fn record_jitter(p: Vec3, d: Vec3) -> Vec3 {
    let h = hash(p, d);
    let h2 = mix64(h ^ 0x9e37_79b9_7f4a_7c15);
    // 24 bits each, so that every value is exact in f32 and below 1.
    let unit = |v: u64| (v & 0xff_ffff) as f32 / (1u32 << 24) as f32;
    Vec3::new(unit(h >> 40), unit(h >> 16), unit(h2 >> 40))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Records at random points and directions, some with values that are not
    /// deposited (zero, infinite), a third of them emitters' light samples (half of
    /// those blocked, with no light).
    fn records(rng: &mut Rng, n: usize) -> Vec<Record> {
        (0..n)
            .map(|i| {
                let p = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - Vec3::ONE;
                let dir = (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - Vec3::splat(0.5))
                    .normalize_or(Vec3::Z);
                let value = match i % 50 {
                    0 => 0.0,
                    1 => f32::INFINITY,
                    _ => rng.f32() * 3.0,
                };
                let (direct, shadow) = match i % 6 {
                    0 => (rng.f32(), Shadow::Clear),
                    1 => (0.0, Shadow::Blocked),
                    2 => (rng.f32() * 2.0, Shadow::Untested),
                    _ => (0.0, Shadow::Untested),
                };
                Record {
                    p,
                    dir,
                    value,
                    direct,
                    sky: 0.0,
                    shadow,
                }
            })
            .collect()
    }

    /// A record at the origin of `value`, `direct` light and `shadow`.
    fn at_origin(value: f32, direct: f32, shadow: Shadow) -> Record {
        Record {
            p: Vec3::ZERO,
            dir: Vec3::Y,
            value,
            direct,
            sky: 0.0,
            shadow,
        }
    }

    /// A region learns how often its emitters' light samples find them, and its guide
    /// learns their direct light times `(1 − visibility)²`; the irradiance that
    /// roulette goes by keeps all of it. Before anything is learnt, and where fewer
    /// than [`MIN_SHADOW_TESTS`] were tested, the guide learns all of it.
    #[test]
    fn a_region_guides_towards_the_direct_light_its_light_samples_miss() {
        let fill = |tree: &SdTree, clear: u32, blocked: u32| {
            let mut tree = tree.cleared();
            for _ in 0..clear {
                tree.deposit(&at_origin(0.0, 1.0, Shadow::Clear));
            }
            for _ in 0..blocked {
                tree.deposit(&at_origin(0.0, 0.0, Shadow::Blocked));
            }
            tree
        };
        // What a vertex's record of 2 of other light and 4 of direct light adds.
        let learns = |tree: &SdTree| {
            let mut filled = tree.cleared();
            filled.deposit(&at_origin(2.0, 4.0, Shadow::Untested));
            let leaf = &filled.leaves[0];
            let micro = |x: f64| (x * 1e6).round() / 1e6;
            (
                micro(leaf.directions.energy()),
                micro(leaf.irradiance),
                leaf.records,
            )
        };
        let untrained = SdTree::new((Vec3::splat(-1.0), Vec3::splat(1.0)));
        assert_eq!(learns(&untrained), (6.0, 6.0, 1));
        // A quarter of 64 light samples found their emitter: the guide learns
        // 0.75² of its light.
        let trained = fill(&untrained, 16, 48);
        assert_eq!(
            (trained.leaves[0].records, trained.leaves[0].shadow_tests),
            (16, 64)
        );
        let trained = trained.refined(1, SPLIT_REFERENCE_PIXELS, &[]);
        assert_eq!((trained.leaf_count(), trained.visibility[0]), (1, 0.25));
        assert_eq!(learns(&trained), (2.0 + 0.5625 * 4.0, 6.0, 1));
        // All found it: the guide learns none of it.
        let clear = fill(&untrained, 64, 0).refined(1, SPLIT_REFERENCE_PIXELS, &[]);
        assert_eq!(learns(&clear), (2.0, 6.0, 1));
        // Too few to tell: all of it.
        let few = fill(&untrained, MIN_SHADOW_TESTS - 1, 0);
        assert_eq!(
            learns(&few.refined(1, SPLIT_REFERENCE_PIXELS, &[])),
            (6.0, 6.0, 1)
        );
    }

    /// Guided draws at the records' points and directions, of scattered directions and
    /// of sky samples alternately.
    fn draws(rng: &mut Rng, records: &[Record]) -> Vec<GuidedDraw> {
        let draw = |(i, r): (usize, &Record)| {
            let m = MixtureDraw {
                integrand: rng.f32() * f32::from(u8::from(i % 3 != 0)),
                base_pdf: rng.f32(),
                guide_scale: 1.0,
                pdf: 0.1 + rng.f32(),
                normal: Vec3::new(rng.f32(), rng.f32(), 1.0).normalize(),
            };
            let draw = if i % 2 == 0 {
                Draw::Sky(m)
            } else {
                Draw::Scattered(m)
            };
            GuidedDraw {
                p: r.p,
                dir: r.dir,
                draw,
            }
        };
        records.iter().enumerate().map(draw).collect()
    }

    /// The leaf and extent a descent from the root finds, one level at a time.
    fn descend(tree: &SdTree, x: Vec3) -> (usize, Vec3) {
        let (mut x, mut size) = (x.to_array(), [1.0f32; 3]);
        let mut node = tree.nodes[0];
        while !node.is_leaf() {
            let a = node.axis();
            let upper = x[a] >= 0.5;
            x[a] = if upper { x[a] * 2.0 - 1.0 } else { x[a] * 2.0 };
            size[a] *= 0.5;
            node = tree.nodes[node.index() + usize::from(upper)];
        }
        (node.index(), Vec3::from_array(size))
    }

    /// The table's lookup finds the leaf and extent of the descent from the root, on
    /// trees of one leaf, a few and hundreds (leaves above and below the table's
    /// depth), at random points and on a grid of dyadic points (the cuts, 0 and 1).
    #[test]
    fn table_lookup_is_the_descent() {
        let mut rng = Rng::seeded(4);
        let mut tree = SdTree::new((Vec3::splat(-1.0), Vec3::splat(1.0)));
        let grid = (0..=64).flat_map(|i| {
            (0..=64).flat_map(move |j| {
                (0..=8).map(move |k| Vec3::new(i as f32, j as f32, k as f32 * 8.0) / 64.0)
            })
        });
        let points: Vec<Vec3> = grid
            .chain((0..20_000).map(|_| Vec3::new(rng.f32(), rng.f32(), rng.f32())))
            .collect();
        let check = |tree: &SdTree| {
            for x in &points {
                assert_eq!(tree.leaf_and_size_at(*x), descend(tree, *x), "at {x}");
            }
        };
        check(&tree);
        // The last round's records gather near the centre, where leaves get deeper
        // than the table.
        for (divisor, spread) in [(1, 1.0), (30, 1.0), (300, 0.02), (1200, 0.02)] {
            for r in &records(&mut rng, 20_000) {
                tree.deposit(&Record {
                    p: r.p * spread,
                    ..*r
                });
            }
            tree = tree.refined(1, SPLIT_REFERENCE_PIXELS / (divisor * divisor), &[]);
            check(&tree);
        }
        let finest = points.iter().map(|x| descend(&tree, *x).1.min_element());
        assert!(finest.fold(1.0, f32::min) < 1.0 / TABLE_SIDE as f32);
        assert!(tree.leaf_count() > 500, "{} leaves", tree.leaf_count());
    }

    /// Folding tiles of records leaf by leaf in parallel gives the tree depositing them
    /// one by one does, to the bit (every sum taken in the same order), on a tree split
    /// into many regions; and so do the shares its draws choose, which are not all
    /// alike.
    #[test]
    fn parallel_fold_is_the_sequential_fold() {
        let mut rng = Rng::seeded(3);
        let mut tree = SdTree::new((Vec3::splat(-1.0), Vec3::splat(1.0)));
        for r in &records(&mut rng, 20_000) {
            tree.deposit(r);
        }
        // A one-pixel image: regions with more than 12.5 records are split.
        let tree = tree.refined(1, 1, &[]);
        assert!(tree.leaf_count() > 500, "{} leaves", tree.leaf_count());
        let tiles: Vec<Vec<Record>> = (0..7).map(|t| records(&mut rng, 1000 * t)).collect();
        let mut one_by_one = tree.cleared();
        for r in tiles.iter().flatten() {
            one_by_one.deposit(r);
        }
        let mut folded = tree.cleared();
        folded.deposit_all(&tiles);
        assert!(one_by_one == folded);
        let draws = draws(&mut rng, tiles.concat().as_slice());
        let refined = folded.refined(4, 1000, &draws);
        assert!(one_by_one.refined(4, 1000, &draws) == refined);
        let mut shares: Vec<[u32; 2]> =
            refined.shares.iter().map(|s| s.map(f32::to_bits)).collect();
        shares.sort_unstable();
        shares.dedup();
        assert!(shares.len() > 2, "{shares:?}");
    }
}
