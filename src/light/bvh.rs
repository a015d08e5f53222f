//! A bounding volume hierarchy over emitters for choosing one in proportion to an
//! estimate of what it contributes at a receiver (Conty Estevez & Kulla 2018, as in
//! pbrt-v4's `BVHLightSampler`): each node bounds its emitters' positions (a box),
//! their power, and their emitting directions (a cone of normals; one-sided triangles
//! emit within 90° of theirs).
//!
//! Sampling descends from the root, choosing each child with probability proportional
//! to its [importance](LightBounds::importance) at the receiver, so that one draw
//! costs O(depth) and allocates nothing. The probability of any emitter is the product
//! of the same ratios along its path from the root, which each emitter keeps as a bit
//! trail ([`LightBvh::probability`]); both are computed by the same function on the
//! same values, so they agree to the bit, and they sum to 1 over the emitters at any
//! point.
//!
//! The build (once per scene) is deterministic: it depends only on the order and
//! values of the emitters. Each split minimises the surface area orientation
//! heuristic over 12 buckets of centroids per axis.

use glam::Vec3;

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
        }
    }

    fn centroid(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }

    /// An estimate of the light these emitters send to a receiver at `p` with unit
    /// normal `n` (zero: no normal term): power over squared distance to the centre
    /// (at least a quarter of the bounding sphere's radius, squared), times a bound on
    /// the emitters' cosine towards `p` and on the receiver's |cosine| towards them.
    /// 0 only when no emitter inside can shine on `p`: every emitter point lies in
    /// the box's bounding sphere, which `p` sees within the angle θ_b of its centre,
    /// so the angle between an emitter normal and the direction to `p` is at least
    /// `θ_w − θ_o − θ_b` (θ_w: between the cone's axis and the direction from the
    /// centre to `p`; θ_o: the cone's half-angle), and one-sided emitters send nothing
    /// beyond 90°.
    #[inline]
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        NodeBounds::from(self).importance(p, n)
    }

    /// The surface area orientation heuristic's cost of these bounds: power, times the
    /// measure of the cone of emitted directions, times the box's surface area.
    fn cost(&self) -> f32 {
        let theta_o = self.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_w = (theta_o + FRAC_PI_2).min(PI);
        let (sin_o, cos_o) = theta_o.sin_cos();
        let m_omega = 2.0 * PI * (1.0 - cos_o)
            + FRAC_PI_2
                * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                    + cos_o);
        let d = (self.hi - self.lo).max(Vec3::ZERO);
        let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        self.power * m_omega * area
    }
}

/// `(cos, sin)` of `max(0, a − b)` for angles `a, b` in [0, π] given as `(cos, sin)`.
#[inline]
fn cos_sin_clamped_difference(
    (cos_a, sin_a): (f32, f32),
    (cos_b, sin_b): (f32, f32),
) -> (f32, f32) {
    if cos_a >= cos_b {
        (1.0, 0.0)
    } else {
        (
            cos_a * cos_b + sin_a * sin_b,
            (sin_a * cos_b - cos_a * sin_b).max(0.0),
        )
    }
}

/// The smallest cone (as axis and cosine of half-angle) around two cones.
fn cone_union((a, cos_a): (Vec3, f32), (b, cos_b): (Vec3, f32)) -> (Vec3, f32) {
    let theta_a = cos_a.clamp(-1.0, 1.0).acos();
    let theta_b = cos_b.clamp(-1.0, 1.0).acos();
    let theta_d = a.dot(b).clamp(-1.0, 1.0).acos();
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

/// [`LightBounds`] as the importance reads them, derived once at build time: the
/// bounding sphere of the box, and the cone's sine beside its cosine.
#[derive(Clone, Copy, Debug)]
struct NodeBounds {
    center: Vec3,
    radius_squared: f32,
    axis: Vec3,
    cos_o: f32,
    sin_o: f32,
    power: f32,
}

impl From<&LightBounds> for NodeBounds {
    fn from(b: &LightBounds) -> Self {
        NodeBounds {
            center: b.centroid(),
            radius_squared: 0.25 * (b.hi - b.lo).length_squared(),
            axis: b.axis,
            cos_o: b.cos_theta,
            sin_o: (1.0 - b.cos_theta * b.cos_theta).max(0.0).sqrt(),
            power: b.power,
        }
    }
}

impl NodeBounds {
    /// See [`LightBounds::importance`].
    #[inline]
    fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let to_p = p - self.center;
        let d2 = to_p.length_squared();
        // Inside the bounding sphere every direction is possible: no angle bound
        // applies, but the distance to the centre still tells a node around `p` from
        // one it is only inside of. (Clamped, so that the nearest nodes do not take all
        // the choices: a quarter of the radius is as near as the emitters are taken to
        // be.)
        if d2 <= self.radius_squared {
            let importance = self.power / d2.max(0.25 * self.radius_squared);
            return if importance.is_finite() {
                importance
            } else {
                0.0
            };
        }
        // θ_b, the angular radius of the bounding sphere seen from p.
        let inverse_d2 = d2.recip();
        let s2 = self.radius_squared * inverse_d2;
        let (sin_b, cos_b) = (s2.sqrt(), (1.0 - s2).sqrt());
        let wi = to_p * inverse_d2.sqrt();
        let cos_w = self.axis.dot(wi).clamp(-1.0, 1.0);
        let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
        let (cos_x, sin_x) = cos_sin_clamped_difference((cos_w, sin_w), (self.cos_o, self.sin_o));
        let (cos_emit, _) = cos_sin_clamped_difference((cos_x, sin_x), (cos_b, sin_b));
        if cos_emit.is_nan() || cos_emit <= 0.0 {
            return 0.0;
        }
        let mut importance = self.power * cos_emit * inverse_d2;
        if n != Vec3::ZERO {
            let cos_i = n.dot(wi).abs().min(1.0);
            let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
            let (cos_receive, _) = cos_sin_clamped_difference((cos_i, sin_i), (cos_b, sin_b));
            importance *= cos_receive.max(0.0);
        }
        if importance.is_finite() {
            importance.max(0.0)
        } else {
            0.0
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: NodeBounds,
    /// A leaf's emitter, or an interior node's second child (the first follows it).
    index: u32,
    leaf: bool,
}

/// The tree over a scene's emitters.
#[derive(Clone, Debug)]
pub struct LightBvh {
    /// Depth-first: a node's first child comes right after it.
    nodes: Vec<Node>,
    /// Per emitter, its path from the root (bit k set: the second child at depth k);
    /// `None` for emitters without power, which are never chosen.
    trails: Vec<Option<u64>>,
}

/// Deepest a leaf may be, so that every path fits a trail's 64 bits.
const MAX_DEPTH: u32 = 63;
const BUCKETS: usize = 12;
/// The largest `f64` below 1.
const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;

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
        let mut bvh = LightBvh {
            nodes: Vec::with_capacity(2 * items.len() - 1),
            trails: vec![None; lights.len()],
        };
        bvh.build(lights, &mut items, 0, 0);
        Some(bvh)
    }

    /// Number of nodes (for the build report).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Adds the subtree over `items` at depth `depth` reached by `trail`; returns
    /// its bounds.
    fn build(
        &mut self,
        lights: &[LightBounds],
        items: &mut [u32],
        depth: u32,
        trail: u64,
    ) -> LightBounds {
        let here = self.nodes.len();
        if let [single] = items {
            let bounds = lights[*single as usize];
            self.nodes.push(Node {
                bounds: NodeBounds::from(&bounds),
                index: *single,
                leaf: true,
            });
            self.trails[*single as usize] = Some(trail);
            return bounds;
        }
        let split = split(lights, items, depth);
        let (first, second) = items.split_at_mut(split);
        self.nodes.push(Node {
            bounds: NodeBounds::from(&lights[first[0] as usize]),
            index: 0,
            leaf: false,
        });
        let a = self.build(lights, first, depth + 1, trail);
        let second_index = self.nodes.len() as u32;
        let b = self.build(lights, second, depth + 1, trail | (1 << depth));
        let bounds = a.union(&b);
        self.nodes[here] = Node {
            bounds: NodeBounds::from(&bounds),
            index: second_index,
            leaf: false,
        };
        bounds
    }

    /// The two children of interior node `node` and the probability of choosing each
    /// at `(p, n)`: in proportion to importance, or to power where neither child's
    /// bounds admit `p`. (That happens below a node whose looser bounds did; choosing
    /// there by power, rather than giving up, keeps the probabilities of all emitters
    /// summing to 1 at every point. The emitter then chosen faces away from `p`, and
    /// its sample is void, as it would have been.)
    #[inline]
    fn children(&self, node: usize, p: Vec3, n: Vec3) -> [(usize, f32); 2] {
        let first = node + 1;
        let second = self.nodes[node].index as usize;
        let (b0, b1) = (&self.nodes[first].bounds, &self.nodes[second].bounds);
        let (mut w0, mut w1) = (b0.importance(p, n), b1.importance(p, n));
        if (w0 + w1).is_nan() || w0 + w1 <= 0.0 {
            (w0, w1) = (b0.power, b1.power);
        }
        let total = w0 + w1;
        [(first, w0 / total), (second, w1 / total)]
    }

    /// Chooses an emitter for the receiver at `p` with normal `n` (zero: none) from
    /// uniform `u`: its index, the probability of the choice, and `u` rescaled to a
    /// fresh uniform.
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, mut u: f64) -> (usize, f32, f64) {
        let mut node = 0;
        let mut probability = 1.0f32;
        loop {
            let current = &self.nodes[node];
            if current.leaf {
                return (current.index as usize, probability, u);
            }
            let [(first, p0), (second, p1)] = self.children(node, p, n);
            let p0_wide = f64::from(p0);
            if u < p0_wide {
                u = (u / p0_wide).min(ONE_BELOW);
                probability *= p0;
                node = first;
            } else {
                u = ((u - p0_wide) / (1.0 - p0_wide)).clamp(0.0, ONE_BELOW);
                probability *= p1;
                node = second;
            }
        }
    }

    /// The probability that [`sample`](Self::sample) chooses `emitter` at `(p, n)`.
    #[inline]
    pub fn probability(&self, p: Vec3, n: Vec3, emitter: usize) -> f32 {
        let Some(trail) = self.trails.get(emitter).copied().flatten() else {
            return 0.0;
        };
        let mut node = 0;
        let mut probability = 1.0f32;
        for depth in 0.. {
            if self.nodes[node].leaf {
                break;
            }
            let (next, p_next) = self.children(node, p, n)[((trail >> depth) & 1) as usize];
            probability *= p_next;
            node = next;
        }
        probability
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
