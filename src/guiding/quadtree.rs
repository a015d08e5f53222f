//! The directional half of an SD-tree: a quadtree over the unit square of the
//! cylindrical coordinates `(u, v) = ((cos θ + 1) / 2, φ / 2π)` of world directions.
//!
//! The map from the square to the sphere is area-preserving (Archimedes: a band of
//! `cos θ` of width `dz` has area `2π dz`), with Jacobian `4π` everywhere, so a density
//! `p(u, v)` on the square is `p / 4π` per steradian and no cell needs a correction.
//!
//! Each node holds the energy (the sum of deposits) of its four quadrants, so the
//! tree is at once a histogram for sampling (descend, choosing quadrants by energy,
//! uniform within the leaf) and its density (the product of `4 · share` on the way
//! down). An empty tree is the uniform distribution.

use std::collections::VecDeque;
use std::f32::consts::{FRAC_1_PI, PI};

use glam::{Vec2, Vec3};

use crate::geometry::round_away;
use crate::sampling::ONE_BELOW;

/// Quadtrees are never deeper than this (Müller et al. 2017 use 20): cells down to
/// `2^-20` of the square's side, where `f32` sampling coordinates still resolve them.
pub const MAX_QUAD_DEPTH: u32 = 20;

/// A quadrant is subdivided when it holds more than this share of the tree's energy
/// (Müller et al.'s ρ = 0.01). At most `1/ρ` quadrants per level can, so a tree has at
/// most `1 + MAX_QUAD_DEPTH / ρ` nodes (2001): see [`max_nodes`](QuadTree::max_nodes).
pub const SUBDIVISION_SHARE: f64 = 0.01;

/// One node as sampling and the density read it, in 16 bytes (half the 32 it took
/// with `u32` children and `f32` factors, for memory: it did not make descents
/// faster, benches/results/2026-12-03-guiding-sittings-1-to-9.md): its quadrants' children/// quadrant, `y ≥ ½` bit 1; child 0: the quadrant is a leaf, the root being nobody's
/// child; a tree has at most [`max_nodes`](QuadTree::max_nodes) nodes, so 16 bits
/// index them), and each quadrant's weight, its share of the node's energy in units
/// of `1 / WEIGHT_SUM`, fixed when the tree is built by [`QuadTree::refined`].
/// The weights sum to `WEIGHT_SUM`, a power of two, so a quadrant's density factor
/// `4 · weight / WEIGHT_SUM` is exact in `f32`, and sampling's choices (ratios of
/// the same weights) draw each quadrant with the probability the density gives it.
/// Deposits add to the energies (kept apart, see [`QuadTree`]), which the next
/// refinement reads.
#[derive(Clone, Copy, Debug, PartialEq)]
struct QuadNode {
    child: [u16; 4],
    weight: [u16; 4],
}

/// What a node's quadrant weights sum to (see [`QuadNode`]): a share resolved to
/// 1/32768 of the node's energy, far below what a region's records estimate.
const WEIGHT_SUM: u32 = 1 << 15;

/// The density factor of one weight unit, `4 / WEIGHT_SUM` (exact).
const FACTOR_PER_WEIGHT: f32 = 4.0 / WEIGHT_SUM as f32;

// A child's index fits in 16 bits.
const _: () = assert!(QuadTree::max_nodes() <= u16::MAX as usize + 1);

const EMPTY_NODE: QuadNode = QuadNode {
    child: [0; 4],
    weight: [(WEIGHT_SUM / 4) as u16; 4],
};

impl QuadNode {
    /// The factor quadrant `q` multiplies the density by.
    #[inline(always)]
    fn factor(&self, q: usize) -> f32 {
        f32::from(self.weight[q]) * FACTOR_PER_WEIGHT
    }
}

/// The quadrant weights of a node with quadrant energies `e` (see [`QuadNode`]):
/// each its share rounded to the nearest unit, at least one unit where it has any
/// energy (so the guide never rules out a direction it has seen light from), the
/// largest taking what rounding left over so that they sum to `WEIGHT_SUM`. An
/// empty node is uniform.
fn weights(e: [f64; 4]) -> [u16; 4] {
    let total: f64 = e.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return EMPTY_NODE.weight;
    }
    let mut w = e.map(|q| {
        if q > 0.0 {
            ((q / total * f64::from(WEIGHT_SUM)).round() as u32).max(1)
        } else {
            0
        }
    });
    let largest = (0..4).max_by_key(|&q| w[q]).unwrap_or(0);
    let rest: u32 = (0..4).filter(|&q| q != largest).map(|q| w[q]).sum();
    // The largest holds at least a quarter, and the others were rounded up by at
    // most a unit each, so what is left is positive and at most `WEIGHT_SUM`.
    w[largest] = WEIGHT_SUM - rest;
    w.map(|q| q as u16)
}

/// A leaf cell of a tree's square, as a draw found it: its lower corner, its side
/// and the tree's density on it (per unit area of the square).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SquareCell {
    origin: Vec2,
    size: f32,
    density: f32,
}

impl SquareCell {
    #[inline]
    fn contains(&self, p: Vec2) -> bool {
        let hi = self.origin + Vec2::splat(self.size);
        p.cmpge(self.origin).all() && p.cmplt(hi).all()
    }
}

/// A directional distribution over the sphere (see the module notes).
#[derive(Clone, Debug, PartialEq)]
pub struct QuadTree {
    nodes: Vec<QuadNode>,
    /// The energies of each node's quadrants, apart from the nodes: sampling and the
    /// density never read them, so a node they descend through takes 16 bytes of
    /// cache rather than 48.
    energy: Vec<[f64; 4]>,
}

impl Default for QuadTree {
    fn default() -> Self {
        QuadTree::uniform()
    }
}

/// The quadrant of `p` (in a node's unit square) and `p` in that quadrant's square.
#[inline]
fn quadrant(p: Vec2) -> (usize, Vec2) {
    let (right, top) = (p.x >= 0.5, p.y >= 0.5);
    let q = usize::from(right) | usize::from(top) << 1;
    let local = Vec2::new(
        if right { p.x - 0.5 } else { p.x },
        if top { p.y - 0.5 } else { p.y },
    ) * 2.0;
    (q, local.clamp(Vec2::ZERO, Vec2::splat(ONE_BELOW)))
}

/// The square's coordinates of a unit direction.
#[inline]
pub fn direction_to_square(d: Vec3) -> Vec2 {
    let u = ((d.z + 1.0) * 0.5).clamp(0.0, ONE_BELOW);
    let v = azimuth_turns(d.x, d.y).min(ONE_BELOW);
    Vec2::new(u, v)
}

/// `atan2(y, x)` in turns, from 0 to 1 (one turn added to negative angles), without a
/// call to `atan2f` (a tenth of a guided render's instructions with its two wrappers):
/// the octant's symmetries (exact: swaps and sign changes) bring the angle to
/// `atan(t) / 2π` with `t = min / max ≤ 1`, and that is the polynomial
/// `t · Σ c_k t^2k` (degree 15, minimax in absolute error over `[0, 1]`, fitted by
/// iteratively reweighted least squares; 6e-9 turns in exact arithmetic, 2.6e-8 in
/// `f32`). With the symmetries' own rounding the result is within 5.6e-8 turns of the
/// exact azimuth, where `atan2f` scaled to turns was within 9.1e-8 (the unit test
/// below): cells are decided as before but for directions within rounding of their
/// edges, and sampling (`sin_cos`) and the density agree as closely as they did.
#[inline]
fn azimuth_turns(x: f32, y: f32) -> f32 {
    const C: [f32; 8] = [
        0.159_154_83,
        -0.053_046_13,
        0.031_746_03,
        -0.022_136_673,
        0.015_347_017,
        -0.008_900_012,
        0.003_480_457_2,
        -0.000_645_533_6,
    ];
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let t = if hi > 0.0 { lo / hi } else { 0.0 };
    let s = t * t;
    let mut a = C[7];
    for &c in C[..7].iter().rev() {
        a = a * s + c;
    }
    let mut turns = a * t;
    if ay > ax {
        turns = 0.25 - turns;
    }
    if x < 0.0 {
        turns = 0.5 - turns;
    }
    if y < 0.0 {
        turns = 1.0 - turns;
    }
    turns
}

/// The unit direction at square coordinates `p`.
#[inline]
pub fn square_to_direction(p: Vec2) -> Vec3 {
    let z = (2.0 * p.x - 1.0).clamp(-1.0, 1.0);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * p.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

impl QuadTree {
    /// The uniform distribution: one node, no energy.
    pub fn uniform() -> Self {
        QuadTree {
            nodes: vec![EMPTY_NODE],
            energy: vec![[0.0; 4]],
        }
    }

    /// The most nodes a tree refined by [`refined`](Self::refined) can have.
    pub const fn max_nodes() -> usize {
        1 + (MAX_QUAD_DEPTH as f64 / SUBDIVISION_SHARE) as usize
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Levels of the deepest cell (1: the root's quadrants are the leaves).
    pub fn depth(&self) -> u32 {
        let mut deepest = 0;
        let mut stack = vec![(0usize, 1u32)];
        while let Some((node, depth)) = stack.pop() {
            deepest = deepest.max(depth);
            for &c in &self.nodes[node].child {
                if c != 0 {
                    stack.push((c as usize, depth + 1));
                }
            }
        }
        deepest
    }

    /// Bytes the tree holds.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<QuadNode>()
            + self.energy.capacity() * std::mem::size_of::<[f64; 4]>()
    }

    /// The sum of all deposits.
    pub fn energy(&self) -> f64 {
        self.energy[0].iter().sum()
    }

    /// Adds `value` to the energy of every cell containing `d` (a unit direction).
    pub fn deposit(&mut self, d: Vec3, value: f64) {
        let mut p = direction_to_square(d);
        let mut node = 0usize;
        loop {
            let (q, local) = quadrant(p);
            self.energy[node][q] += value;
            match self.nodes[node].child[q] {
                0 => return,
                c => (node, p) = (c as usize, local),
            }
        }
    }

    /// Adds `value` spread by a box filter around `d`: over a square the size of the
    /// cell containing `d`, centred on it (clipped to the unit square), each cell
    /// receiving the share of the box it overlaps (Müller et al.'s directional filter,
    /// done exactly rather than by jittering, so deposits stay deterministic). The
    /// total added is `value`.
    pub fn deposit_filtered(&mut self, d: Vec3, value: f64) {
        let p = direction_to_square(d);
        let half = Vec2::splat(0.5 * self.cell_size(p));
        let lo = (p - half).max(Vec2::ZERO);
        let hi = (p + half).min(Vec2::ONE);
        let area = f64::from((hi - lo).x) * f64::from((hi - lo).y);
        if area <= 0.0 {
            self.deposit(d, value);
            return;
        }
        self.splat((lo, hi), value / area);
    }

    /// The side of the leaf cell containing `p` in the square.
    fn cell_size(&self, mut p: Vec2) -> f32 {
        let (mut node, mut size) = (0usize, 1.0f32);
        loop {
            let (q, local) = quadrant(p);
            size *= 0.5;
            match self.nodes[node].child[q] {
                0 => return size,
                c => (node, p) = (c as usize, local),
            }
        }
    }

    /// Adds `density` times the area the box `(lo, hi)`, within the unit square,
    /// shares with each cell.
    ///
    /// While the box lies within one quadrant of a node (above the level of its own
    /// cell it nearly always does), that quadrant's share is the whole box and the
    /// others' none, so the descent takes it without measuring the four: the same sums
    /// as [`splat_overlaps`](Self::splat_overlaps) from the root, to the bit (`min` and
    /// `max` return the box's own corners there), for a fraction of the work.
    fn splat(&mut self, (lo, hi): (Vec2, Vec2), density: f64) {
        let (mut node, mut origin, mut size) = (0usize, Vec2::ZERO, 1.0f32);
        let extent = (hi - lo).max(Vec2::ZERO);
        let whole = density * (f64::from(extent.x) * f64::from(extent.y));
        loop {
            let half = 0.5 * size;
            let mid = origin + Vec2::splat(half);
            // Both corners on one side of the middle along each axis (a box that ends
            // on the middle has no area beyond it).
            let (right, top) = (lo.x >= mid.x, lo.y >= mid.y);
            if !((right || hi.x <= mid.x) && (top || hi.y <= mid.y)) {
                return self.splat_overlaps(node, origin, size, (lo, hi), density);
            }
            let q = usize::from(right) | usize::from(top) << 1;
            self.energy[node][q] += whole;
            match self.nodes[node].child[q] {
                0 => return,
                c => node = c as usize,
            }
            origin += Vec2::new(f32::from(u8::from(right)), f32::from(u8::from(top))) * half;
            size = half;
        }
    }

    /// Adds `density` times the overlap area of the box `(lo, hi)` with each quadrant
    /// of `node` (covering the square at `origin` of side `size`), and below.
    fn splat_overlaps(
        &mut self,
        node: usize,
        origin: Vec2,
        size: f32,
        (lo, hi): (Vec2, Vec2),
        density: f64,
    ) {
        let half = 0.5 * size;
        for q in 0..4 {
            let at = origin + Vec2::new((q & 1) as f32, (q >> 1) as f32) * half;
            let overlap = (hi.min(at + Vec2::splat(half)) - lo.max(at)).max(Vec2::ZERO);
            let area = f64::from(overlap.x) * f64::from(overlap.y);
            if area <= 0.0 {
                continue;
            }
            self.energy[node][q] += density * area;
            if let c @ 1.. = self.nodes[node].child[q] {
                self.splat_overlaps(c as usize, at, half, (lo, hi), density);
            }
        }
    }

    /// Density per unit area of the square at `p` (of the tree as last refined:
    /// deposits since then count from the next refinement on).
    #[inline]
    pub fn square_pdf(&self, mut p: Vec2) -> f32 {
        let (mut node, mut density) = (Some(0usize), 1.0f32);
        while let Some(at) = node {
            (node, p, density) = self.density_step(at, p, density);
        }
        density
    }

    /// One level of a density's descent: from node `at`, where the point is `p` in
    /// its square and the density so far `density`, the child to go on to (none at a
    /// leaf, or once the density is 0), the point in its square, and the density.
    #[inline(always)]
    fn density_step(&self, at: usize, p: Vec2, density: f32) -> (Option<usize>, Vec2, f32) {
        let n = &self.nodes[at];
        let (q, local) = quadrant(p);
        let density = density * n.factor(q);
        let next = match n.child[q] {
            0 => None,
            _ if density == 0.0 => None,
            c => Some(c as usize),
        };
        (next, local, density)
    }

    /// [`square_pdf`](Self::square_pdf) at two points, bit for bit, in one loop: the
    /// two descents are independent, so their nodes' cache misses overlap rather
    /// than follow each other (a folded guide's density needs the tree at a direction
    /// and at its mirror image).
    #[inline]
    pub fn square_pdf_pair(&self, a: Vec2, b: Vec2) -> (f32, f32) {
        // Per point: its node (`None` once its descent ended), where it is in that
        // node's square, and the density so far.
        let mut points = [(Some(0usize), a, 1.0f32), (Some(0usize), b, 1.0f32)];
        while points.iter().any(|(node, ..)| node.is_some()) {
            for point in &mut points {
                if let (Some(at), p, density) = *point {
                    *point = self.density_step(at, p, density);
                }
            }
        }
        (points[0].2, points[1].2)
    }

    /// A point of the square drawn from the density, from two uniforms in `[0, 1)`:
    /// each level chooses the column (`x`) by `u.x` and the row by `u.y`, and rescales
    /// the uniform that chose into the part it fell in, so the draw stays stratified.
    #[inline]
    pub fn sample_square(&self, u: Vec2) -> Vec2 {
        self.sample_cell(u).0
    }

    /// [`sample_square`](Self::sample_square), and the leaf cell it chose (whose
    /// density is the product of the factors on the way down, in the order
    /// [`square_pdf`](Self::square_pdf) multiplies them).
    ///
    /// Why the arithmetic below rather than two calls to `choose_second` a level:
    /// the choices are coin flips a branch predictor cannot learn, and with branches
    /// each level paid for about one misprediction and two chained divisions (the
    /// descent was a sixth of a guided room's time). Here a level compares the
    /// uniforms, scaled by the weights' sums, with the weights themselves (a node's
    /// weights sum to `WEIGHT_SUM`, so the column's choice needs no quotient), picks
    /// the row's weights by index and each uniform's part by multiplying by 0 or 1,
    /// and rescales both uniforms with one vector division that the next level's node
    /// load does not wait for. All the sums are of integers below 2^16, exact in `f32`.
    #[inline]
    pub fn sample_cell(&self, mut u: Vec2) -> (Vec2, SquareCell) {
        const SUM: f32 = WEIGHT_SUM as f32;
        let (mut origin, mut size) = (Vec2::ZERO, 1.0f32);
        let mut density = 1.0f32;
        let mut node = 0usize;
        loop {
            let n = self.nodes[node];
            let f = n.weight.map(f32::from);
            // The left column holds quadrants 0 and 2: `left` of `SUM`.
            let left = f[0] + f[2];
            let scaled_x = u.x * SUM;
            let right = scaled_x >= left;
            let column = usize::from(right);
            let (bottom, top_weight) = (f[column], f[column + 2]);
            let scaled_y = u.y * (bottom + top_weight);
            // A `u.y` below 1 can still round up to `bottom` when the top is empty.
            let top = scaled_y >= bottom && top_weight > 0.0;
            let (r, t) = (f32::from(u8::from(right)), f32::from(u8::from(top)));
            // Each uniform within its part: (scaled − part's start) / part's weight.
            let start = Vec2::new(r * left, t * bottom);
            let weight = Vec2::new(
                left + r * (SUM - 2.0 * left),
                bottom + t * (top_weight - bottom),
            );
            u = ((Vec2::new(scaled_x, scaled_y) - start) / weight).min(Vec2::splat(ONE_BELOW));
            let q = column | usize::from(top) << 1;
            size *= 0.5;
            origin += Vec2::new(r, t) * size;
            density *= n.factor(q);
            if let c @ 1.. = n.child[q] {
                node = c as usize;
                continue;
            }
            // Within the cell: at depth 20 a cell is 64 `f32` steps wide, and
            // `origin + u · size` rounded to its upper edge for about one `u` in 128,
            // a point of the neighbouring cell, whose density (0 where the neighbour
            // has no light) is not the one the draw was made with.
            let top_corner = origin + Vec2::splat(size);
            let below = |edge: f32| round_away(edge, -1.0);
            let p = (origin + u * size).min(Vec2::new(below(top_corner.x), below(top_corner.y)));
            let cell = SquareCell {
                origin,
                size,
                density,
            };
            return (p, cell);
        }
    }

    /// The probability mass of the rectangle `(lo, hi)` of the square (exactly: the
    /// density is constant within each leaf cell, so this sums each cell's density
    /// times the area the rectangle shares with it).
    pub fn mass_in_rect(&self, (lo, hi): (Vec2, Vec2)) -> f64 {
        self.rect_mass(0, Vec2::ZERO, 1.0, 1.0, (lo, hi))
    }

    /// [`mass_in_rect`](Self::mass_in_rect) under `node` (the square at `origin` of
    /// side `size`, where the density so far is `density`).
    fn rect_mass(
        &self,
        node: usize,
        origin: Vec2,
        size: f32,
        density: f64,
        (lo, hi): (Vec2, Vec2),
    ) -> f64 {
        let half = 0.5 * size;
        let n = &self.nodes[node];
        let mut mass = 0.0;
        for q in 0..4 {
            let at = origin + Vec2::new((q & 1) as f32, (q >> 1) as f32) * half;
            let overlap = (hi.min(at + Vec2::splat(half)) - lo.max(at)).max(Vec2::ZERO);
            let area = f64::from(overlap.x) * f64::from(overlap.y);
            let d = density * f64::from(n.factor(q));
            if area <= 0.0 || d == 0.0 {
                continue;
            }
            mass += match n.child[q] {
                0 => d * area,
                c => self.rect_mass(c as usize, at, half, d, (lo, hi)),
            };
        }
        mass
    }

    /// An image of the distribution, `width × height` pixels over the square (row 0
    /// at `cos θ = 1`, the world's +z, down to −z; columns the azimuth
    /// `atan2(y, x)` from 0 to 2π, an equal-area map of the sphere): each pixel the
    /// mean density per steradian over its solid angle, computed exactly, so the
    /// pixels times their solid angle `4π / (width · height)` sum to 1.
    pub fn density_image(&self, width: u32, height: u32) -> Vec<f32> {
        let (w, h) = (width.max(1), height.max(1));
        let pixel_area = 1.0 / (f64::from(w) * f64::from(h));
        let mut out = Vec::with_capacity((w * h) as usize);
        for row in 0..h {
            // Row 0 is the top of the image: cos θ = 1, the square's u = 1.
            let u = (
                f64::from(h - row - 1) / f64::from(h),
                f64::from(h - row) / f64::from(h),
            );
            for col in 0..w {
                let v = (
                    f64::from(col) / f64::from(w),
                    f64::from(col + 1) / f64::from(w),
                );
                let lo = Vec2::new(u.0 as f32, v.0 as f32);
                let hi = Vec2::new(u.1 as f32, v.1 as f32);
                let mean = self.mass_in_rect((lo, hi)) / pixel_area;
                out.push((mean / (4.0 * std::f64::consts::PI)) as f32);
            }
        }
        out
    }

    /// Density per steradian of the unit direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.square_pdf(direction_to_square(d)) * (0.25 * FRAC_1_PI)
    }

    /// [`pdf`](Self::pdf) at two unit directions (see
    /// [`square_pdf_pair`](Self::square_pdf_pair)).
    #[inline]
    pub fn pdf_pair(&self, a: Vec3, b: Vec3) -> (f32, f32) {
        let (pa, pb) = self.square_pdf_pair(direction_to_square(a), direction_to_square(b));
        (pa * (0.25 * FRAC_1_PI), pb * (0.25 * FRAC_1_PI))
    }

    /// Density per steradian of the unit direction `d`, where `cell` is a leaf cell
    /// of this tree: its density when `d` maps into it (one descent less), the
    /// descent's otherwise. Equal to [`pdf`](Self::pdf) bit for bit: a leaf's square
    /// has dyadic corners, exact in `f32`, and the descent halves coordinates exactly,
    /// so `d` maps into `cell` exactly when the descent would end there.
    #[inline]
    pub fn pdf_knowing(&self, d: Vec3, cell: &SquareCell) -> f32 {
        let p = direction_to_square(d);
        let square = if cell.contains(p) {
            cell.density
        } else {
            self.square_pdf(p)
        };
        square * (0.25 * FRAC_1_PI)
    }

    /// A unit direction drawn from the density (see [`sample_square`](Self::sample_square)).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        square_to_direction(self.sample_square(u))
    }

    /// The same cells with no energy: where the next iteration's deposits go.
    pub fn cleared(&self) -> QuadTree {
        QuadTree {
            nodes: self.nodes.clone(),
            energy: vec![[0.0; 4]; self.energy.len()],
        }
    }

    /// A new tree over this one's energy: a quadrant holding more than
    /// [`SUBDIVISION_SHARE`] of the total is subdivided (its children taking this
    /// tree's energies where it has them, a quarter each otherwise), the others are
    /// leaves. An empty tree stays uniform. Built breadth-first in quadrant order, so
    /// the result is a function of the energies alone, and the levels every descent
    /// reads first lie side by side at the front of the nodes, where the caches keep
    /// them.
    pub fn refined(&self) -> QuadTree {
        let total = self.energy();
        if total <= 0.0 || !total.is_finite() {
            return QuadTree::uniform();
        }
        let mut out = QuadTree {
            nodes: vec![EMPTY_NODE],
            energy: vec![self.energy[0]],
        };
        // (node in `out`, node in `self` or none, depth of `out`'s node)
        let mut queue = VecDeque::from([(0usize, Some(0usize), 1u32)]);
        while let Some((new, old, depth)) = queue.pop_front() {
            for q in 0..4 {
                let e = out.energy[new][q];
                if depth >= MAX_QUAD_DEPTH || e <= total * SUBDIVISION_SHARE {
                    continue;
                }
                let old_child = old
                    .map(|o| self.nodes[o].child[q])
                    .filter(|&c| c != 0)
                    .map(|c| c as usize);
                let energy = match old_child {
                    Some(c) => self.energy[c],
                    None => [e / 4.0; 4],
                };
                let index = out.nodes.len();
                out.nodes.push(EMPTY_NODE);
                out.energy.push(energy);
                out.nodes[new].child[q] = index as u16;
                queue.push_back((index, old_child, depth + 1));
            }
        }
        for (n, &e) in out.nodes.iter_mut().zip(&out.energy) {
            n.weight = weights(e);
        }
        out
    }
}

/// Cosine-weighted mass of the sphere cap of half-angle `half_angle` around `axis`,
/// for a surface whose normal is `normal`: used by tests; here because it is the
/// comparison the guide is meant to win (`∫_cap max(0, cos) / π dω`, by quadrature).
pub fn cosine_mass_in_cone(normal: Vec3, axis: Vec3, half_angle: f32) -> f64 {
    mass_in_cone(&|d| normal.dot(d).max(0.0) * FRAC_1_PI, axis, half_angle)
}

/// `∫ density dω` over the cap of half-angle `half_angle` around the unit `axis`, by
/// the midpoint rule on 256 × 256 points of (cos, φ) in the cap.
pub fn mass_in_cone(density: &dyn Fn(Vec3) -> f32, axis: Vec3, half_angle: f32) -> f64 {
    let (t, b) = axis.any_orthonormal_pair();
    let n = 256;
    let z_min = f64::from(half_angle.cos());
    let (dz, dphi) = (
        (1.0 - z_min) / n as f64,
        2.0 * std::f64::consts::PI / n as f64,
    );
    let mut sum = 0.0;
    for i in 0..n {
        let z = z_min + (i as f64 + 0.5) * dz;
        let r = (1.0 - z * z).max(0.0).sqrt();
        for j in 0..n {
            let phi = (j as f64 + 0.5) * dphi;
            let local = (r * phi.cos(), r * phi.sin(), z);
            let d = t * local.0 as f32 + b * local.1 as f32 + axis * local.2 as f32;
            sum += f64::from(density(d.normalize()));
        }
    }
    sum * dz * dphi
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The splat's descent through the quadrants that hold the whole box gives the
    /// energies of measuring every quadrant's overlap from the root, to the bit, for
    /// boxes around directions all over a tree refined around a few lobes, small and
    /// large, clipped at the square's edges or not.
    #[test]
    fn splat_descends_to_the_exact_overlaps() {
        let mut tree = QuadTree::uniform();
        let lobes = [
            Vec2::new(0.3, 0.7),
            Vec2::new(0.9, 0.05),
            Vec2::new(0.5, 0.5),
        ];
        for _ in 0..6 {
            let mut filling = tree.cleared();
            for (i, &lobe) in lobes.iter().enumerate() {
                filling.deposit(square_to_direction(lobe), 1.0 + i as f64);
            }
            filling.deposit(Vec3::Z, 0.5);
            tree = filling.refined();
        }
        assert!(tree.depth() >= 6);
        let mut rng = crate::sampling::Rng::seeded(5);
        for i in 0..2000 {
            let (u1, u2) = rng.pair();
            let p = Vec2::new(u1, u2);
            let half = Vec2::splat(0.5 * tree.cell_size(p) * [0.3, 1.0, 2.5][i % 3]);
            let boxed = ((p - half).max(Vec2::ZERO), (p + half).min(Vec2::ONE));
            let (mut fast, mut exact) = (tree.cleared(), tree.cleared());
            fast.splat(boxed, 1.7);
            exact.splat_overlaps(0, Vec2::ZERO, 1.0, boxed, 1.7);
            assert_eq!(fast.energy, exact.energy, "box {boxed:?}");
        }
    }

    /// A node's weights sum to `WEIGHT_SUM` whatever the energies (so the density's
    /// factors are the choices' probabilities times 4), keep every quadrant that has
    /// energy and none that has not, and are the shares to within rounding.
    #[test]
    fn weights_are_the_shares_summing_to_a_power_of_two() {
        let mut rng = crate::sampling::Rng::seeded(9);
        for i in 0..20_000 {
            // Shares from even to extreme (one quadrant 1e-12 of another), some empty.
            let e: [f64; 4] = std::array::from_fn(|q| {
                let (u, v) = rng.pair();
                if (i + q) % 7 == 0 {
                    0.0
                } else {
                    f64::from(u) * 10f64.powf(-12.0 * f64::from(v) * f64::from(i % 3 == 0))
                }
            });
            let w = weights(e);
            let total: f64 = e.iter().sum();
            assert_eq!(
                w.iter().map(|&x| u32::from(x)).sum::<u32>(),
                WEIGHT_SUM,
                "{e:?}"
            );
            for q in 0..4 {
                assert_eq!(w[q] > 0, e[q] > 0.0 || total == 0.0, "{e:?} → {w:?}");
                if total > 0.0 {
                    let share = f64::from(w[q]) / f64::from(WEIGHT_SUM);
                    assert!((share - e[q] / total).abs() <= 4.0 / f64::from(WEIGHT_SUM));
                }
            }
        }
        assert_eq!(weights([0.0; 4]), EMPTY_NODE.weight);
        assert_eq!(weights([f64::INFINITY, 1.0, 0.0, 0.0]), EMPTY_NODE.weight);
    }

    /// Draws never land where the density is 0, even from uniforms at the ends of
    /// `[0, 1)` and next to a choice's boundary (where rounding could tip a choice
    /// into an empty quadrant), and a draw lies in the cell it reports, whose density
    /// is the one `square_pdf` finds there: a tree whose light comes from two points
    /// only, refined to depth 20, so most nodes have empty quadrants, some a whole
    /// empty column or row. (A draw at a cell's upper edge once rounded into its
    /// neighbour, of density 0 here: `(0, 0.49999997)` did.)
    #[test]
    fn draws_never_land_where_the_density_is_zero() {
        let mut tree = QuadTree::uniform();
        let lights = [Vec2::new(0.3, 0.7), Vec2::new(0.30001, 0.2)];
        for _ in 0..8 {
            let mut filling = tree.cleared();
            for &light in &lights {
                filling.deposit(square_to_direction(light), 1.0);
            }
            tree = filling.refined();
        }
        assert_eq!(tree.depth(), MAX_QUAD_DEPTH);
        let ends = [
            0.0,
            1e-7,
            0.25,
            0.5 - 3e-8,
            0.5,
            0.5 + 3e-8,
            0.75,
            ONE_BELOW,
        ];
        let mut rng = crate::sampling::Rng::seeded(3);
        let random = (0..2000).map(|_| rng.pair());
        let at_ends = ends.iter().flat_map(|&a| ends.iter().map(move |&b| (a, b)));
        for (u1, u2) in at_ends.chain(random) {
            let (p, cell) = tree.sample_cell(Vec2::new(u1, u2));
            let density = tree.square_pdf(p);
            assert!(cell.contains(p), "({u1}, {u2}) → {p}, outside {cell:?}");
            assert!(density > 0.0, "({u1}, {u2}) → {p}: density 0");
            assert_eq!(cell.density, density, "({u1}, {u2}) → {p}");
        }
    }

    #[test]
    fn square_and_sphere_round_trip() {
        for &(u, v) in &[(0.1f32, 0.2f32), (0.5, 0.5), (0.9, 0.99), (0.01, 0.7)] {
            let d = square_to_direction(Vec2::new(u, v));
            let p = direction_to_square(d);
            assert!(
                (p.x - u).abs() < 1e-5 && (p.y - v).abs() < 1e-5,
                "{u} {v} → {p}"
            );
        }
    }

    /// The azimuth in turns is `f64`'s `atan2` to within an `f32` ulp below 1 (6e-8
    /// turns; 5.6e-8 measured, where `atan2f` scaled to turns was off by up to 9.1e-8
    /// on the same directions), around the circle, near the axes and near the
    /// octants' edges, and exact on the axes.
    #[test]
    fn azimuth_turns_is_atan2() {
        let mut worst = 0.0f64;
        let n = 100_000;
        for i in 0..n {
            let phi = i as f64 / n as f64 * std::f64::consts::TAU;
            for (x, y) in [
                (phi.cos(), phi.sin()),
                (1.0, phi.sin() * 1e-3),
                (phi.sin() * 1e-3, -1.0),
                (1.0, 1.0 + phi.sin() * 1e-4),
            ] {
                let (x, y) = (x as f32, y as f32);
                let exact = f64::from(y)
                    .atan2(f64::from(x))
                    .rem_euclid(std::f64::consts::TAU)
                    / std::f64::consts::TAU;
                let turns = f64::from(azimuth_turns(x, y));
                // 0 and 1 are the same azimuth.
                let error = (turns - exact).abs().min(1.0 - (turns - exact).abs());
                worst = worst.max(error);
            }
        }
        assert!(worst < 6e-8, "worst error {worst} turns");
        assert_eq!(azimuth_turns(1.0, 0.0), 0.0);
        assert_eq!(azimuth_turns(0.0, 1.0), 0.25);
        assert_eq!(azimuth_turns(-1.0, 0.0), 0.5);
        assert_eq!(azimuth_turns(0.0, -1.0), 0.75);
        assert_eq!(azimuth_turns(0.0, 0.0), 0.0);
    }

    /// The paired descent gives each point's density bit for bit, on a tree with
    /// cells of many depths and with empty cells (density 0).
    #[test]
    fn paired_density_is_each_density() {
        let mut tree = QuadTree::uniform();
        let spikes = [Vec3::new(0.3, 0.4, 0.866), Vec3::new(-0.8, 0.1, -0.3)];
        for _ in 0..6 {
            tree = tree.cleared();
            for (i, d) in spikes.iter().enumerate() {
                tree.deposit(d.normalize(), 1.0 + i as f64);
            }
            tree = tree.refined();
        }
        let mut rng = crate::sampling::Rng::seeded(3);
        for i in 0..10_000 {
            let a = square_to_direction(Vec2::new(rng.f32(), rng.f32()));
            // Every other pair draws from the tree, so that deep cells are met.
            let b = if i % 2 == 0 {
                tree.sample(Vec2::new(rng.f32(), rng.f32()))
            } else {
                -a
            };
            let (pa, pb) = tree.pdf_pair(a, b);
            assert_eq!(pa.to_bits(), tree.pdf(a).to_bits());
            assert_eq!(pb.to_bits(), tree.pdf(b).to_bits());
        }
    }

    #[test]
    fn refinement_follows_energy_and_keeps_it() {
        let mut tree = QuadTree::uniform();
        let d = Vec3::new(0.3, 0.4, 0.866).normalize();
        for _ in 0..4 {
            tree = tree.cleared();
            tree.deposit(d, 1.0);
            tree.deposit(-d, 1.0);
            tree = tree.refined();
        }
        assert_eq!(tree.energy(), 2.0);
        // Each spike's cell is refined to the depth limit, and its density grows.
        assert!(tree.node_count() > 4 && tree.node_count() <= QuadTree::max_nodes());
        assert!(tree.pdf(d) > 100.0 && tree.pdf(-d) > 100.0);
        assert_eq!(tree.pdf(Vec3::X), 0.0);
    }
}
