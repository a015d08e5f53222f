//! Traversal: front-to-back descent with one slab test for all of a node's children
//! (four lanes at a time in SIMD), watertight triangle tests in
//! the leaves, and per-thread stacks that are reused instead of zeroed for every ray.

use std::cell::RefCell;

use glam::Vec4;

use super::node::{Child, Node, WIDTH};
use super::triangle::RayShear;
use super::Bvh;
use crate::accel::{Hit, Ray};
use crate::geometry::HitFilter;

/// Traversal stack depth: the builder keeps the binary depth under 48 + 27 levels, so
/// the wide tree is at most 76 levels deep, and every wide node pushes at most
/// `WIDTH - 1` children.
pub const STACK: usize = 76 * (WIDTH - 1) + WIDTH;

/// Slab-test slack: scaling the far distance by `1 + 2γ₃` keeps the box test
/// conservative under rounding (Ize 2013, pbrt-v4), so watertight triangles are not
/// culled at their boxes' edges.
pub const FAR_SLACK: f32 = 1.0 + 2.0 * 3.0 * f32::EPSILON * 0.5 / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// The pending children of a closest-hit traversal (with their entry distances) and of
/// an any-hit traversal.
pub struct Stacks {
    near: [(Child, f32); STACK],
    any: [Child; STACK],
}

impl Stacks {
    const EMPTY: Stacks = Stacks {
        near: [(Child(0), 0.0); STACK],
        any: [Child(0); STACK],
    };
}

thread_local! {
    /// Kilobytes of stack: a fresh array per ray would be zeroed every time, which costs
    /// as much as a short ray's whole traversal.
    static STACKS: RefCell<Stacks> = const { RefCell::new(Stacks::EMPTY) };
}

/// Runs `f` with this thread's stacks, or with fresh ones when they are in use (a hit
/// filter that traces rays of its own).
#[inline(always)]
pub fn with_stacks<R>(f: impl FnOnce(&mut Stacks) -> R) -> R {
    STACKS.with(|cell| match cell.try_borrow_mut() {
        Ok(mut stacks) => f(&mut stacks),
        Err(_) => with_fresh_stacks(f),
    })
}

#[cold]
#[inline(never)]
fn with_fresh_stacks<R>(f: impl FnOnce(&mut Stacks) -> R) -> R {
    let mut fresh = Stacks::EMPTY;
    f(&mut fresh)
}

/// The per-ray constants of the slab test, each in all four lanes.
struct RayBoxes {
    org: [Vec4; 3],
    inv: [Vec4; 3],
    neg: [bool; 3],
}

impl RayBoxes {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        // One packed division (each lane rounds as a scalar division would).
        let inv = glam::Vec3A::from(ray.dir).recip().to_array();
        let org = ray.origin.to_array();
        RayBoxes {
            org: org.map(Vec4::splat),
            inv: inv.map(Vec4::splat),
            neg: inv.map(f32::is_sign_negative),
        }
    }

    /// Entry distance of each lane, and a bit mask of the lanes whose box the ray meets
    /// in `[tmin, tmax]` (bit `i` for lane `i`). Written with glam's four-lane vectors
    /// rather than as loops for the compiler to vectorise, which it did in one way or
    /// another depending on how the callers used the results (it split them into pairs
    /// of lanes and scalars for a branch-free choice of the nearest child).
    #[inline(always)]
    fn test(&self, node: &Node, tmin: f32, tmax: f32) -> ([f32; WIDTH], u32) {
        let mut near = [0.0; WIDTH];
        let mut mask = 0u32;
        for quad in 0..WIDTH / 4 {
            // Children fill the lanes from the first; many nodes have four or fewer.
            if quad > 0 && node.lo[0][quad * 4] == f32::INFINITY {
                break;
            }
            let lanes = quad * 4..quad * 4 + 4;
            let (mut n4, mut f4) = (Vec4::splat(tmin), Vec4::splat(tmax));
            for axis in 0..3 {
                let (n, f) = if self.neg[axis] {
                    (&node.hi[axis], &node.lo[axis])
                } else {
                    (&node.lo[axis], &node.hi[axis])
                };
                let t0 = (Vec4::from_slice(&n[lanes.clone()]) - self.org[axis]) * self.inv[axis];
                let t1 = (Vec4::from_slice(&f[lanes.clone()]) - self.org[axis]) * self.inv[axis];
                // `max`/`min` keep their second operand where the first is NaN (0 × ∞
                // on a box face), so the interval stays as it was there.
                n4 = t0.max(n4);
                f4 = t1.min(f4);
            }
            let hit = n4.cmple(f4 * FAR_SLACK);
            mask |= hit.bitmask() << (quad * 4);
            n4.write_to_slice(&mut near[lanes]);
        }
        (near, mask)
    }
}

/// The child of `node` to visit next among those in `mask` (not empty), the nearest;
/// the others go onto `stack` above `sp` (with two, the farther deepest).
#[inline(always)]
fn descend(
    node: &Node,
    near: &[f32; WIDTH],
    mask: u32,
    stack: &mut [(Child, f32); STACK],
    sp: &mut usize,
) -> Child {
    let first = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    if rest == 0 {
        // One child hit, the common case deep in the tree.
        return node.child[first];
    }
    if rest & (rest - 1) == 0 {
        // Two, the common case above the leaves: a compare and two selects instead of
        // a sort, whose branches mispredict.
        let second = rest.trailing_zeros() as usize;
        let (a, b) = if near[second] < near[first] {
            (second, first)
        } else {
            (first, second)
        };
        stack[*sp] = (node.child[b], near[b]);
        *sp += 1;
        return node.child[a];
    }
    // More: the nearest visited next, the others pushed in lane order. (Sorting them
    // all, farthest deepest, cost more than it saved: most diffuse rays hit nothing,
    // and for those the order is of no use.)
    let nearest = nearest_lane(near, mask, |far| {
        stack[*sp] = (node.child[far], near[far]);
        *sp += 1;
    });
    node.child[nearest]
}

/// The lane of `mask` (not empty) whose child is entered nearest; every other lane
/// of `mask` is handed to `push`, in lane order.
#[inline(always)]
fn nearest_lane(near: &[f32; WIDTH], mask: u32, mut push: impl FnMut(usize)) -> usize {
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
        push(far);
    }
    nearest
}

impl Bvh {
    /// The nearest intersection that `filter` accepts. Monomorphised per filter, so
    /// [`crate::geometry::Opaque`] (a compile-time `true`) costs nothing.
    #[inline(always)]
    pub(super) fn intersect_in<F: HitFilter>(
        &self,
        ray: &Ray,
        filter: &F,
        stacks: &mut Stacks,
    ) -> Option<Hit> {
        let stack = &mut stacks.near;
        let boxes = RayBoxes::new(ray);
        // Made at the first leaf: many rays leave the tree without reaching one.
        let mut shear = None;
        let (tmin, mut tmax) = (ray.tmin, ray.tmax);
        // The block and lane of the nearest hit so far, and its barycentrics.
        let mut best: Option<(usize, usize, f32, f32)> = None;
        let mut sp = 0;
        let mut cur = Child::inner(0);
        loop {
            if cur.is_leaf() {
                let shear = &*shear.get_or_insert_with(|| RayShear::new(ray.origin, ray.dir));
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
                let (near, mask) = boxes.test(node, tmin, tmax);
                if mask != 0 {
                    cur = descend(node, &near, mask, stack, &mut sp);
                    continue;
                }
            }
            // Pop the nearest pending child that could still be closer than the hit.
            loop {
                if sp == 0 {
                    return best.map(|(index, lane, u, v)| self.hit(ray, tmax, index, lane, u, v));
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

    /// The hit on lane `lane` of block `index`, its distance re-measured precisely
    /// (see [`super::triangle::TriBlock::plane_distance`]).
    fn hit(&self, ray: &Ray, t: f32, index: usize, lane: usize, u: f32, v: f32) -> Hit {
        let block = &self.blocks[index];
        let t = block
            .plane_distance(lane, ray.origin, ray.dir)
            .map_or(t, |t| t.clamp(ray.tmin, ray.tmax));
        Hit {
            t,
            prim: block.prim[lane],
            u,
            v,
            instance: 0,
        }
    }

    /// Whether `filter` accepts any intersection with the segment.
    #[inline(always)]
    pub(super) fn occluded_in<F: HitFilter>(
        &self,
        ray: &Ray,
        filter: &F,
        stacks: &mut Stacks,
    ) -> bool {
        let stack = &mut stacks.any;
        let boxes = RayBoxes::new(ray);
        // Made at the first leaf: many rays leave the tree without reaching one.
        let mut shear = None;
        let (tmin, tmax) = (ray.tmin, ray.tmax);
        let mut sp = 0;
        let mut cur = Child::inner(0);
        loop {
            if cur.is_leaf() {
                let shear = &*shear.get_or_insert_with(|| RayShear::new(ray.origin, ray.dir));
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
                    // visit it next, push the others. (Pushing them in order too, as
                    // for the nearest hit, was 5% slower on Sponza; visiting the first
                    // child instead of the nearest, 40% slower.)
                    let nearest = nearest_lane(&near, mask, |far| {
                        stack[sp] = node.child[far];
                        sp += 1;
                    });
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn far_slack_is_a_tiny_enlargement() {
        let slack = std::hint::black_box(FAR_SLACK);
        assert!(slack > 1.0 && slack < 1.0 + 1e-6);
    }
}
