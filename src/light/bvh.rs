//! A bounding volume hierarchy over emitters for choosing one in proportion to an
//! estimate of what it contributes at a receiver (Conty Estevez & Kulla 2018, as in
//! pbrt-v4's `BVHLightSampler`): each node bounds its emitters' positions (a box),
//! their power, and their emitting directions (a cone of normals; one-sided triangles
//! emit within 90° of theirs).
//!
//! A two-sided emitter keeps its one cone and a flag that mirrors it, as pbrt-v4's
//! `LightBounds::twoSided` does: the importance measures the angle to the nearer of
//! the axis and its reverse, and the plane test that culls the back half-space is off.
//! Two one-sided entries per emitter would keep the cones tight too, but then choosing
//! the emitter has two paths through the tree, and its probability (which `pdf_hit`
//! needs for every BSDF ray that meets it) two walks; the flag keeps one trail, so the
//! probability stays a single walk and exact to the bit.
//!
//! Sampling descends from the root, choosing each child with probability proportional
//! to its [importance](LightBounds::importance) at the receiver, so that one draw
//! costs O(depth) and allocates nothing. The probability of any emitter is the product
//! of the same ratios along its path from the root, which each emitter keeps as a
//! trail ([`LightBvh::probability`]); both are computed by the same function on the
//! same values, so they agree to the bit, and they sum to 1 over the emitters at any
//! point.
//!
//! The importance is 0 only where no emitter below can light the receiver, and it
//! tests that two ways: by the bounding sphere and the cone (as pbrt-v4), and by two
//! plane tests over the box (the receiver in front of some emitter, some of the box in
//! front of the receiver), which still hold where the receiver is inside the sphere.
//! Lamps sit a few millimetres off walls, ceilings and desks: without the plane tests,
//! a point of a desk was given to the lamps just above it, which face away from it
//! (on `meshes/many-light-room.obj`, 53% of the light samples at path vertices were
//! void, 27% with them, and the variance of direct light per vertex fell 1.5–1.8×).
//!
//! Nodes are four wide, their children's bounds stored lane by lane, so that the four
//! importances of one level are one SIMD evaluation (glam's `Vec4`: SSE on x86-64).
//! That is why: on `meshes/many-light-room.obj` (1942 emitters) a binary tree took
//! about 11 levels and 23 scalar evaluations per light sample, 1900 instructions of
//! importance, 31% of the render's instructions; four wide, 5.7 levels of one
//! evaluation each, about 900 (18%), and the whole render's instructions fell by 21%
//! (callgrind, 80×45 at 8 spp: 1062M → 840M; the alias table's 554M).
//!
//! The build (once per scene) is deterministic: it depends only on the order and
//! values of the emitters. Each binary split minimises the surface area orientation
//! heuristic over 12 buckets of centroids per axis; the binary tree is then collapsed
//! into four-wide nodes by opening, under each node, the child of most power until it
//! has four.

use glam::{BVec4A, Vec3, Vec4};

use std::f32::consts::{FRAC_PI_2, PI};

/// Where a set of emitters is, how much power it has and which way it emits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    pub lo: Vec3,
    pub hi: Vec3,
    /// Axis of the cone that holds every emitter's normal.
    pub axis: Vec3,
    /// Cosine of that cone's half-angle (−1: every direction).
    pub cos_theta: f32,
    pub power: f32,
    /// Whether the emitters may emit on the back of their normals too, so that the
    /// cone holds each normal or its reverse.
    pub two_sided: bool,
}

impl LightBounds {
    /// The bounds of one one-sided emitting triangle with unit normal `normal`.
    pub fn triangle(vertices: [Vec3; 3], normal: Vec3, power: f32) -> Self {
        let [a, b, c] = vertices;
        LightBounds {
            lo: a.min(b).min(c),
            hi: a.max(b).max(c),
            axis: normal,
            cos_theta: 1.0,
            power,
            two_sided: false,
        }
    }

    /// These bounds for emitters that emit from both faces (`power` their power from
    /// both).
    pub fn two_sided(self) -> Self {
        LightBounds {
            two_sided: true,
            ..self
        }
    }

    fn union(&self, other: &LightBounds) -> LightBounds {
        let (axis, cos_theta) =
            cone_union((self.axis, self.cos_theta), (other.axis, other.cos_theta));
        LightBounds {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
            axis,
            cos_theta,
            power: self.power + other.power,
            two_sided: self.two_sided || other.two_sided,
        }
    }

    fn centroid(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }

    /// An estimate of the light these emitters send to a receiver at `p` with unit
    /// normal `n` (zero: no normal term; else the side it receives light on): power
    /// over squared distance to the centre (at least a quarter of the bounding
    /// sphere's radius, squared, where `p` is inside that sphere), times a bound on the
    /// emitters' cosine towards `p` and on the receiver's cosine towards them.
    /// 0 only when no emitter inside can shine on `p`:
    /// - every emitter point lies in the box's bounding sphere, which `p` sees within
    ///   the angle θ_b of its centre, so the angle between an emitter normal and the
    ///   direction to `p` is at least `θ_w − θ_o − θ_b` (θ_w: between the cone's axis
    ///   and the direction from the centre to `p`, or its reverse where that is nearer
    ///   and the emitters are two-sided; θ_o: the cone's half-angle), and emitters
    ///   send nothing beyond 90° of their emitting face; likewise the receiver takes
    ///   nothing from beyond 90° of its normal;
    /// - the plane tests, which need no sphere and so hold where `p` is inside it (a
    ///   desk's lamps seen from the desk, a wall's from the wall): an emitter at `q`
    ///   with normal `m` lights `p` only if `(p − q)·m > 0`, and over the box and the
    ///   cone that is at most `(p − c)·a + Σ|a_k| h_k + sin θ_o · (|p − c| + r)` (`c`,
    ///   `h`: the box's centre and half extent; `a`: the cone's axis; `r`: the
    ///   sphere's radius), exact for coplanar emitters (two-sided ones pass: they
    ///   light both sides of their plane); and the receiver takes light
    ///   from `q` only if `(q − p)·n > 0`, at most `(c − p)·n + Σ|n_k| h_k` over the box.
    ///
    /// Where `p` is in front of every emitter's plane but close to them, the estimate
    /// is still far above what they send (the bounds are loose at grazing angles):
    /// that costs samples, never bias.
    #[inline]
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let mut lanes = Lanes::EMPTY;
        lanes.set(0, self);
        lanes.importance(&Query::new(p, n))[0]
    }

    /// The surface area orientation heuristic's cost of these bounds: power, times the
    /// measure of the cone of emitted directions (twice it when mirrored, at most the
    /// whole sphere's), times the box's surface area.
    fn cost(&self) -> f32 {
        let theta_o = self.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_w = (theta_o + FRAC_PI_2).min(PI);
        let (sin_o, cos_o) = theta_o.sin_cos();
        let m_omega = 2.0 * PI * (1.0 - cos_o)
            + FRAC_PI_2
                * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                    + cos_o);
        let m_omega = match self.two_sided {
            true => (2.0 * m_omega).min(4.0 * PI),
            false => m_omega,
        };
        let d = (self.hi - self.lo).max(Vec3::ZERO);
        let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        self.power * m_omega * area
    }
}

/// The smallest cone (as axis and cosine of half-angle) around two cones.
fn cone_union((a, cos_a): (Vec3, f32), (b, cos_b): (Vec3, f32)) -> (Vec3, f32) {
    let theta_a = cos_a.clamp(-1.0, 1.0).acos();
    let theta_b = cos_b.clamp(-1.0, 1.0).acos();
    // From the sine and cosine: `acos` of a dot product near 1 is off by up to 3e-4
    // for equal normals, which would open their cone and blunt the plane tests.
    let theta_d = a.cross(b).length().atan2(a.dot(b));
    if (theta_d + theta_b).min(PI) <= theta_a {
        return (a, cos_a);
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return (b, cos_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    let toward_b = (b - a.dot(b) * a).normalize_or_zero();
    if theta_o >= PI || toward_b == Vec3::ZERO {
        return (a, -1.0);
    }
    let (sin_r, cos_r) = (theta_o - theta_a).sin_cos();
    ((a * cos_r + toward_b * sin_r).normalize(), theta_o.cos())
}

/// Four children's [`LightBounds`] as the importance reads them, one lane each (struct
/// of arrays, so that one evaluation computes all four with SIMD): the bounding
/// sphere of each box, and each cone's sine beside its cosine. A lane without a
/// child has no power, and so importance 0.
#[derive(Clone, Copy, Debug)]
struct Lanes {
    center: [Vec4; 3],
    /// Half the box's extent along x, y, z.
    half: [Vec4; 3],
    radius: Vec4,
    radius_squared: Vec4,
    axis: [Vec4; 3],
    /// How far the box reaches along the cone's axis from its centre: `Σ |a_k| half_k`.
    axis_reach: Vec4,
    cos_o: Vec4,
    sin_o: Vec4,
    /// The lanes of two-sided bounds (their cone mirrored).
    two_sided: BVec4A,
    /// The lanes that the plane test passes wherever the receiver is: their cone is a
    /// hemisphere or more, or they are two-sided.
    emits_everywhere: BVec4A,
    power: Vec4,
    /// Rounding allowance of the plane tests: a few ulps of the box's coordinates.
    slack: Vec4,
}

/// `√x` in each lane.
#[inline]
fn sqrt4(x: Vec4) -> Vec4 {
    Vec4::from_array(x.to_array().map(f32::sqrt))
}

/// `(cos, sin)` of `max(0, a − b)` for angles `a, b` in [0, π] given as `(cos, sin)`,
/// in each lane.
#[inline]
fn cos_sin_clamped_difference(
    (cos_a, sin_a): (Vec4, Vec4),
    (cos_b, sin_b): (Vec4, Vec4),
) -> (Vec4, Vec4) {
    let within = cos_a.cmpge(cos_b);
    (
        Vec4::select(within, Vec4::ONE, cos_a * cos_b + sin_a * sin_b),
        Vec4::select(
            within,
            Vec4::ZERO,
            (sin_a * cos_b - cos_a * sin_b).max(Vec4::ZERO),
        ),
    )
}

impl Lanes {
    /// No children: every lane empty.
    const EMPTY: Lanes = Lanes {
        center: [Vec4::ZERO; 3],
        half: [Vec4::ZERO; 3],
        radius: Vec4::ZERO,
        radius_squared: Vec4::ZERO,
        axis: [Vec4::ZERO, Vec4::ZERO, Vec4::ONE],
        axis_reach: Vec4::ZERO,
        cos_o: Vec4::ONE,
        sin_o: Vec4::ZERO,
        two_sided: BVec4A::FALSE,
        emits_everywhere: BVec4A::FALSE,
        power: Vec4::ZERO,
        slack: Vec4::ZERO,
    };

    /// Puts `b` in lane `lane`.
    fn set(&mut self, lane: usize, b: &LightBounds) {
        let center = b.centroid();
        let half = 0.5 * (b.hi - b.lo);
        for k in 0..3 {
            self.center[k][lane] = center[k];
            self.half[k][lane] = half[k];
            self.axis[k][lane] = b.axis[k];
        }
        self.axis_reach[lane] = b.axis.abs().dot(half);
        self.slack[lane] = PLANE_SLACK * (b.lo.abs().max(b.hi.abs())).max_element();
        self.radius_squared[lane] = 0.25 * (b.hi - b.lo).length_squared();
        self.radius[lane] = self.radius_squared[lane].sqrt();
        self.cos_o[lane] = b.cos_theta;
        self.sin_o[lane] = (1.0 - b.cos_theta * b.cos_theta).max(0.0).sqrt();
        self.two_sided.set(lane, b.two_sided);
        self.emits_everywhere
            .set(lane, b.cos_theta <= 0.0 || b.two_sided);
        self.power[lane] = b.power;
    }

    /// [`LightBounds::importance`] of each lane, all four at once, branch-free.
    #[inline(always)]
    fn importance(&self, q: &Query) -> Vec4 {
        let (p, n) = (q.p, q.n);
        let to_p = [
            Vec4::splat(p.x) - self.center[0],
            Vec4::splat(p.y) - self.center[1],
            Vec4::splat(p.z) - self.center[2],
        ];
        let d2 = to_p[0] * to_p[0] + to_p[1] * to_p[1] + to_p[2] * to_p[2];
        // Inside the bounding sphere every direction is possible: no angle bound
        // applies, but the distance to the centre still tells a node around `p` from
        // one it is only inside of. (Clamped, so that the nearest nodes do not take all
        // the choices: a quarter of the radius is as near as the emitters are taken to
        // be.)
        let inside = d2.cmple(self.radius_squared);
        let near = self.power / d2.max(0.25 * self.radius_squared);
        // θ_b, the angular radius of the bounding sphere seen from p.
        let inverse_d2 = d2.recip();
        let inverse_d = sqrt4(inverse_d2);
        let sin_b = (self.radius * inverse_d).min(Vec4::ONE);
        let cos_b = sqrt4(Vec4::ONE - sin_b * sin_b);
        // (p − c)·a, and (p − c)·n: the cosines θ_w and θ_i come from them, and so do
        // the plane tests.
        let along = self.axis[0] * to_p[0] + self.axis[1] * to_p[1] + self.axis[2] * to_p[2];
        let facing = to_p[0] * n.x + to_p[1] * n.y + to_p[2] * n.z;
        // A mirrored cone: θ_w from the nearer of the axis and its reverse.
        let cone_along = Vec4::select(self.two_sided, along.abs(), along);
        let cos_w = (cone_along * inverse_d).clamp(-Vec4::ONE, Vec4::ONE);
        let sin_w = sqrt4((Vec4::ONE - cos_w * cos_w).max(Vec4::ZERO));
        let x = cos_sin_clamped_difference((cos_w, sin_w), (self.cos_o, self.sin_o));
        let (cos_emit, _) = cos_sin_clamped_difference(x, (cos_b, sin_b));
        let mut far = self.power * cos_emit.max(Vec4::ZERO) * inverse_d2;
        if q.has_normal {
            // θ_i: between n and the direction from p to the centre. One-sided: the
            // receiver takes no light from behind its normal.
            let cos_i = (-facing * inverse_d).clamp(-Vec4::ONE, Vec4::ONE);
            let sin_i = sqrt4((Vec4::ONE - cos_i * cos_i).max(Vec4::ZERO));
            let (cos_receive, _) = cos_sin_clamped_difference((cos_i, sin_i), (cos_b, sin_b));
            far *= cos_receive.max(Vec4::ZERO);
        }
        let importance = Vec4::select(inside, near, far);
        // The plane tests, which hold inside the bounding sphere too (see
        // `LightBounds::importance`), with a few ulps of the coordinates to spare. A
        // receiver without a normal has `n_abs = 0`, `facing = 0`: it passes.
        let slack = self.slack + Vec4::splat(q.slack);
        let reach = self.sin_o * (d2 * inverse_d + self.radius);
        // Two-sided emitters light both half-spaces: only their plane is dark, and the
        // slack admits it anyway.
        let emits = (along + self.axis_reach + reach).cmpgt(-slack) | self.emits_everywhere;
        let above =
            self.half[0] * q.n_abs.x + self.half[1] * q.n_abs.y + self.half[2] * q.n_abs.z - facing;
        // NaN (an empty lane at its own centre) and ∞ (p on a point light) say nothing.
        let possible = emits
            & above.cmpgt(-slack)
            & importance.is_finite_mask()
            & importance.cmpgt(Vec4::ZERO);
        Vec4::select(possible, importance, Vec4::ZERO)
    }
}

/// A receiver as the importance reads it, prepared once per light choice.
#[derive(Clone, Copy, Debug)]
struct Query {
    p: Vec3,
    n: Vec3,
    has_normal: bool,
    /// `|n|` per axis.
    n_abs: Vec3,
    /// The plane tests' rounding allowance for `p`'s coordinates.
    slack: f32,
}

impl Query {
    #[inline(always)]
    fn new(p: Vec3, n: Vec3) -> Self {
        Query {
            p,
            n,
            has_normal: n != Vec3::ZERO,
            n_abs: n.abs(),
            slack: PLANE_SLACK * p.abs().max_element(),
        }
    }
}

/// Relative rounding allowance of the plane tests (about 32 ulps of f32).
const PLANE_SLACK: f32 = 4e-6;

/// A node of the tree: up to four children, each an emitter or another node.
#[derive(Clone, Copy, Debug)]
struct Node {
    lanes: Lanes,
    /// Per lane, the child: a node index, or an emitter index with [`EMITTER`] set.
    /// Lanes past the node's children have no power, so they are never chosen.
    children: [u32; 4],
}

/// Marks a child that is an emitter.
const EMITTER: u32 = 1 << 31;

/// The tree over a scene's emitters.
#[derive(Clone, Debug)]
pub struct LightBvh {
    /// The root first.
    nodes: Vec<Node>,
    /// Per emitter, its path from the root (bits 2k, 2k+1: the lane taken at depth
    /// k); `None` for emitters without power, which are never chosen.
    trails: Vec<Option<u64>>,
}

/// Deepest a binary split may go. Collapsing keeps at least one binary level per
/// node, so the tree's paths are at most this long too, and a trail of 2 bits per
/// level fits in 64.
const MAX_DEPTH: u32 = 32;
const BUCKETS: usize = 12;
/// The largest `f64` below 1.
const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;

/// The binary tree the splits make, before it is collapsed into four-wide nodes.
struct Binary {
    bounds: LightBounds,
    /// An emitter (a leaf) or two subtrees.
    content: Content,
}

enum Content {
    Emitter(u32),
    Split(Box<(Binary, Binary)>),
}

impl LightBvh {
    /// Builds the tree over `lights` (indexed as the emitters are); `None` when no
    /// light has positive power.
    pub fn new(lights: &[LightBounds]) -> Option<Self> {
        let mut items: Vec<u32> = (0..lights.len() as u32)
            .filter(|&i| {
                let b = &lights[i as usize];
                b.power > 0.0 && b.power.is_finite() && b.axis != Vec3::ZERO
            })
            .collect();
        if items.is_empty() {
            return None;
        }
        let root = build_binary(lights, &mut items, 0);
        let mut bvh = LightBvh {
            nodes: Vec::with_capacity(items.len() / 2 + 1),
            trails: vec![None; lights.len()],
        };
        let children = match root.content {
            Content::Emitter(_) => vec![root],
            Content::Split(pair) => widen(*pair),
        };
        bvh.add_node(children, 0, 0);
        Some(bvh)
    }

    /// Number of nodes (for the build report).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Adds the node over `children`, reached by `trail` at depth `depth`, and the
    /// nodes below it (depth first).
    fn add_node(&mut self, children: Vec<Binary>, depth: u32, trail: u64) {
        let here = self.nodes.len();
        self.nodes.push(Node {
            lanes: Lanes::EMPTY,
            children: [0; 4],
        });
        for (lane, child) in children.into_iter().enumerate() {
            self.nodes[here].lanes.set(lane, &child.bounds);
            let child_trail = trail | (lane as u64) << (2 * depth);
            self.nodes[here].children[lane] = match child.content {
                Content::Emitter(emitter) => {
                    self.trails[emitter as usize] = Some(child_trail);
                    emitter | EMITTER
                }
                Content::Split(pair) => {
                    let index = self.nodes.len() as u32;
                    self.add_node(widen(*pair), depth + 1, child_trail);
                    index
                }
            };
        }
    }

    /// The probability of choosing each child of `node` at `(p, n)`: in proportion to
    /// importance, or to power where no child's bounds admit `p`. (That happens below
    /// a node whose looser bounds did; choosing there by power, rather than giving up,
    /// keeps the probabilities of all emitters summing to 1 at every point. The
    /// emitter then chosen faces away from `p`, and its sample is void, as it would
    /// have been.)
    #[inline(always)]
    fn child_probabilities(node: &Node, q: &Query) -> Vec4 {
        let mut weights = node.lanes.importance(q);
        let mut total = weights.element_sum();
        if total.is_nan() || total <= 0.0 || total.is_infinite() {
            weights = node.lanes.power;
            total = weights.element_sum();
        }
        weights / total
    }

    /// Chooses an emitter for the receiver at `p` with normal `n` (zero: none) from
    /// uniform `u`: its index, the probability of the choice, and `u` rescaled to a
    /// fresh uniform.
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, mut u: f64) -> (usize, f32, f64) {
        let q = Query::new(p, n);
        let mut node = &self.nodes[0];
        let mut probability = 1.0f32;
        loop {
            let chances = Self::child_probabilities(node, &q).to_array();
            // Lane k takes u in [below[k], below[k + 1]), without branches (the choice
            // is as unpredictable as u): u passes every boundary below its lane. A lane
            // without a chance spans nothing, so u passes its end with its start; the
            // last lane with a chance takes what rounding leaves above the sum.
            let c = chances.map(f64::from);
            let below = [0.0, c[0], c[0] + c[1], c[0] + c[1] + c[2]];
            let passed = usize::from(u >= below[1])
                + usize::from(u >= below[2])
                + usize::from(u >= below[3]);
            let with_chance = (0..4).fold(0u32, |bits, k| bits | u32::from(chances[k] > 0.0) << k);
            let last = (u32::BITS - 1 - with_chance.max(1).leading_zeros()) as usize;
            let lane = passed.min(last);
            let below = below[lane];
            let chance = chances[lane];
            u = ((u - below) / f64::from(chance)).clamp(0.0, ONE_BELOW);
            probability *= chance;
            let child = node.children[lane];
            if child & EMITTER != 0 {
                return ((child & !EMITTER) as usize, probability, u);
            }
            node = &self.nodes[child as usize];
        }
    }

    /// The probability that [`sample`](Self::sample) chooses `emitter` at `(p, n)`.
    #[inline]
    pub fn probability(&self, p: Vec3, n: Vec3, emitter: usize) -> f32 {
        let Some(mut trail) = self.trails.get(emitter).copied().flatten() else {
            return 0.0;
        };
        let q = Query::new(p, n);
        let mut node = &self.nodes[0];
        let mut probability = 1.0f32;
        loop {
            let lane = (trail & 3) as usize;
            trail >>= 2;
            probability *= Self::child_probabilities(node, &q)[lane];
            let child = node.children[lane];
            if child & EMITTER != 0 || probability == 0.0 {
                return probability;
            }
            node = &self.nodes[child as usize];
        }
    }
}

/// The up to four subtrees that replace a split binary node: its two children, then
/// repeatedly the split one of most power replaced by its own two (the first such in
/// order on ties, so that the result depends on the input alone).
fn widen((a, b): (Binary, Binary)) -> Vec<Binary> {
    let mut children = vec![a, b];
    while children.len() < 4 {
        let mut widest: Option<usize> = None;
        for (k, child) in children.iter().enumerate() {
            let split = matches!(child.content, Content::Split(_));
            if split && widest.is_none_or(|w| child.bounds.power > children[w].bounds.power) {
                widest = Some(k);
            }
        }
        let Some(k) = widest else {
            break;
        };
        let Content::Split(pair) = children.remove(k).content else {
            unreachable!("chosen among split nodes");
        };
        let (first, second) = *pair;
        children.insert(k, second);
        children.insert(k, first);
    }
    children
}

/// The binary tree over `items` at depth `depth`, by surface area orientation
/// heuristic splits.
fn build_binary(lights: &[LightBounds], items: &mut [u32], depth: u32) -> Binary {
    if let [single] = items {
        return Binary {
            bounds: lights[*single as usize],
            content: Content::Emitter(*single),
        };
    }
    let cut = split(lights, items, depth);
    let (first, second) = items.split_at_mut(cut);
    let a = build_binary(lights, first, depth + 1);
    let b = build_binary(lights, second, depth + 1);
    Binary {
        bounds: a.bounds.union(&b.bounds),
        content: Content::Split(Box::new((a, b))),
    }
}

/// Where to cut `items` (reordered in place) into two non-empty halves: the bucket
/// boundary of least cost, or the middle when nothing separates the centroids or the
/// tree would grow too deep for the trails.
fn split(lights: &[LightBounds], items: &mut [u32], depth: u32) -> usize {
    let n = items.len();
    let centroid = |i: u32| lights[i as usize].centroid();
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let mut total = lights[items[0] as usize];
    for &i in items.iter() {
        lo = lo.min(centroid(i));
        hi = hi.max(centroid(i));
        total = total.union(&lights[i as usize]);
    }
    let balanced_depth = usize::BITS - (n - 1).leading_zeros();
    let extent = hi - lo;
    let mut best: Option<(f32, usize, usize)> = None;
    if depth + balanced_depth < MAX_DEPTH {
        let diagonal = total.hi - total.lo;
        for axis in 0..3 {
            if extent[axis].is_nan() || extent[axis] <= 0.0 {
                continue;
            }
            let bucket_of = |i: u32| {
                let t = (centroid(i)[axis] - lo[axis]) / extent[axis];
                ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
            };
            let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
            for &i in items.iter() {
                let slot = &mut buckets[bucket_of(i)];
                let b = lights[i as usize];
                *slot = Some(slot.map_or(b, |s| s.union(&b)));
            }
            // Regularises long, thin boxes, as in pbrt-v4.
            let k_r = diagonal.max_element() / diagonal[axis].max(f32::MIN_POSITIVE);
            for cut in 1..BUCKETS {
                let merge = |range: &[Option<LightBounds>]| {
                    range
                        .iter()
                        .flatten()
                        .fold(None, |acc: Option<LightBounds>, b| {
                            Some(acc.map_or(*b, |a| a.union(b)))
                        })
                };
                let (Some(below), Some(above)) = (merge(&buckets[..cut]), merge(&buckets[cut..]))
                else {
                    continue;
                };
                let cost = k_r * (below.cost() + above.cost());
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, cut));
                }
            }
        }
    }
    let Some((_, axis, cut)) = best else {
        // No split separates them: halve in their (deterministic) order.
        return n / 2;
    };
    let bucket_of = |i: u32| {
        let t = (centroid(i)[axis] - lo[axis]) / extent[axis];
        ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
    };
    // A stable partition keeps the build a function of the input order alone.
    let (below, above): (Vec<u32>, Vec<u32>) = items.iter().partition(|&&i| bucket_of(i) < cut);
    let mid = below.len();
    items[..mid].copy_from_slice(&below);
    items[mid..].copy_from_slice(&above);
    mid
}
