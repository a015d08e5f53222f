//! The native two-level structure: a top-level tree over the world boxes of placed
//! meshes ([`Instance`]s), each mesh with its own accelerator (a [`super::Bvh`], or a
//! [`super::FilteredBvh`] for cut-outs) built once in object space however often it is
//! placed. A ray goes down the top tree and into each instance it meets in that
//! instance's object space (see [`crate::geometry::object_ray`]), so memory grows with
//! the distinct meshes and the number of placements, not with the placed triangles.
//!
//! The top tree is binary, split at the median of the instance centres along their
//! widest axis: it is balanced, so its depth is at most ⌈log₂ n⌉ + 1 and a fixed stack
//! holds any traversal. Instances are few next to triangles (a thousand bunnies are a
//! thousand boxes), so the top tree's quality matters much less than the meshes'.

use glam::{Affine3A, Vec3, Vec3A};

use super::bvh::FAR_SLACK;
use super::{Accel, Hit, Ray};
use crate::geometry::{object_ray, object_transforms, Instance, InstanceError};

/// Stack depth of the top-level traversal: enough for a balanced tree over 2⁶³ leaves.
const STACK: usize = 64;

/// A placement as traversal needs it.
#[derive(Clone, Copy, Debug)]
struct Placed {
    mesh: u32,
    to_object: Affine3A,
}

/// A node of the top tree: its box, and either one instance (a leaf, `instance`) or
/// two children (`right`; the left child is the next node).
#[derive(Clone, Copy, Debug)]
struct TopNode {
    lo: Vec3A,
    hi: Vec3A,
    /// `LEAF | instance` for a leaf, else the index of the right child.
    link: u32,
}

const LEAF: u32 = 1 << 31;

/// Distinct meshes, each behind its own accelerator `A`, placed by instances.
pub struct InstancedBvh<A: Accel> {
    meshes: Vec<A>,
    placed: Vec<Placed>,
    nodes: Vec<TopNode>,
}

impl<A: Accel> InstancedBvh<A> {
    /// Places `meshes` (each an accelerator with the object-space box `[lo, hi]` of its
    /// triangles) by `instances`; a hit's `instance` is the index into `instances`.
    pub fn build(
        meshes: Vec<(A, [Vec3; 2])>,
        instances: &[Instance],
    ) -> Result<Self, InstanceError> {
        let to_object = object_transforms(instances, meshes.len())?;
        let boxes: Vec<[Vec3A; 2]> = instances
            .iter()
            .map(|i| i.world_bounds(meshes[i.mesh as usize].1))
            .collect();
        let placed = instances
            .iter()
            .zip(to_object)
            .map(|(i, to_object)| Placed {
                mesh: i.mesh,
                to_object,
            })
            .collect();
        let mut nodes = Vec::with_capacity(2 * instances.len());
        let mut ids: Vec<u32> = (0..instances.len() as u32).collect();
        if !ids.is_empty() {
            build_node(&mut nodes, &boxes, &mut ids);
        }
        Ok(InstancedBvh {
            meshes: meshes.into_iter().map(|(accel, _)| accel).collect(),
            placed,
            nodes,
        })
    }

    /// The nearest hit inside one instance, with `t` below `tmax`.
    #[inline]
    fn intersect_instance(&self, instance: u32, ray: &Ray, tmax: f32) -> Option<Hit> {
        let placed = &self.placed[instance as usize];
        let local = object_ray(&placed.to_object, ray, tmax);
        let mut hit = self.meshes[placed.mesh as usize].intersect(&local)?;
        hit.instance = instance;
        Some(hit)
    }

    fn occluded_instance(&self, instance: u32, ray: &Ray) -> bool {
        let placed = &self.placed[instance as usize];
        let local = object_ray(&placed.to_object, ray, ray.tmax);
        self.meshes[placed.mesh as usize].occluded(&local)
    }
}

/// Appends the subtree over `ids` to `nodes`, its root first.
fn build_node(nodes: &mut Vec<TopNode>, boxes: &[[Vec3A; 2]], ids: &mut [u32]) {
    let [lo, hi] = ids
        .iter()
        .fold([Vec3A::INFINITY, Vec3A::NEG_INFINITY], |b, &i| {
            let [l, h] = boxes[i as usize];
            [b[0].min(l), b[1].max(h)]
        });
    let index = nodes.len();
    nodes.push(TopNode {
        lo,
        hi,
        link: LEAF | ids[0],
    });
    if ids.len() == 1 {
        return;
    }
    let centre = |i: u32| boxes[i as usize][0] + boxes[i as usize][1];
    let (clo, chi) = ids
        .iter()
        .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(l, h), &i| {
            (l.min(centre(i)), h.max(centre(i)))
        });
    let extent = (chi - clo).to_array();
    let axis = (0..3).fold(0, |a, b| if extent[b] > extent[a] { b } else { a });
    let mid = ids.len() / 2;
    ids.select_nth_unstable_by(mid, |&a, &b| {
        centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b))
    });
    let (left, right) = ids.split_at_mut(mid);
    build_node(nodes, boxes, left);
    nodes[index].link = nodes.len() as u32;
    build_node(nodes, boxes, right);
}

/// The per-ray constants of the box test.
struct RayBox {
    org: Vec3A,
    inv: Vec3A,
}

impl RayBox {
    fn new(ray: &Ray) -> Self {
        RayBox {
            org: ray.origin.into(),
            inv: Vec3A::from(ray.dir).recip(),
        }
    }

    /// The distance at which the ray enters the node's box within `[tmin, tmax]`, if it
    /// meets it. An axis whose test is NaN (0 × ∞ on a face) leaves the interval as it
    /// was, which keeps the test conservative.
    #[inline]
    fn enter(&self, node: &TopNode, tmin: f32, tmax: f32) -> Option<f32> {
        let t0 = ((node.lo - self.org) * self.inv).to_array();
        let t1 = ((node.hi - self.org) * self.inv).to_array();
        let (mut near, mut far) = (tmin, tmax);
        for axis in 0..3 {
            let (a, b) = if t0[axis] <= t1[axis] {
                (t0[axis], t1[axis])
            } else {
                (t1[axis], t0[axis])
            };
            if a > near {
                near = a;
            }
            if b < far {
                far = b;
            }
        }
        (near <= far * FAR_SLACK).then_some(near)
    }
}

impl<A: Accel> Accel for InstancedBvh<A> {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let boxes = RayBox::new(ray);
        let mut best: Option<Hit> = None;
        let mut tmax = ray.tmax;
        let mut stack = [(0u32, 0f32); STACK];
        let mut sp = 0;
        let mut current = self
            .nodes
            .first()
            .map(|root| (0, boxes.enter(root, ray.tmin, tmax)));
        while let Some((index, entry)) = current.take() {
            let node = &self.nodes[index as usize];
            if entry.is_some_and(|t| t <= tmax) {
                if node.link & LEAF != 0 {
                    if let Some(hit) = self.intersect_instance(node.link & !LEAF, ray, tmax) {
                        tmax = hit.t;
                        best = Some(hit);
                    }
                } else {
                    let (left, right) = (index + 1, node.link);
                    let tl = boxes.enter(&self.nodes[left as usize], ray.tmin, tmax);
                    let tr = boxes.enter(&self.nodes[right as usize], ray.tmin, tmax);
                    // The nearer child first, the other onto the stack.
                    let (first, second) = match (tl, tr) {
                        (Some(a), Some(b)) if b < a => ((right, tr), (left, tl)),
                        _ => ((left, tl), (right, tr)),
                    };
                    if let (_, Some(t)) = second {
                        stack[sp] = (second.0, t);
                        sp += 1;
                    }
                    if first.1.is_some() {
                        current = Some(first);
                        continue;
                    }
                }
            }
            while sp > 0 {
                sp -= 1;
                let (index, t) = stack[sp];
                if t <= tmax {
                    current = Some((index, Some(t)));
                    break;
                }
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let boxes = RayBox::new(ray);
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        if self.nodes.is_empty() {
            return false;
        }
        let mut index = 0u32;
        loop {
            let node = &self.nodes[index as usize];
            if boxes.enter(node, ray.tmin, ray.tmax).is_some() {
                if node.link & LEAF == 0 {
                    stack[sp] = node.link;
                    sp += 1;
                    index += 1;
                    continue;
                }
                if self.occluded_instance(node.link & !LEAF, ray) {
                    return true;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            index = stack[sp];
        }
    }

    fn memory_bytes(&self) -> usize {
        self.meshes.iter().map(Accel::memory_bytes).sum::<usize>()
            + self.placed.len() * std::mem::size_of::<Placed>()
            + self.nodes.len() * std::mem::size_of::<TopNode>()
    }
}
