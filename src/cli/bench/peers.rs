//! Published BVH crates behind [`Accel`], so `ember bench` (with `--features peers`) runs
//! them on the same rays: `obvhs` (a compressed-wide CWBVH built by PLOC) and `bvh` (a
//! binary SAH BVH). Their hits carry barycentrics as `Hit` promises, computed by ember
//! with Möller–Trumbore (the `bvh` crate has no triangle test, `obvhs` reports only the
//! distance), so they may differ from where the crate's own test placed the hit by
//! rounding, not more.

use glam::Vec3;
use glam_obvhs::Vec3A as OVec3A;

use ember::accel::{Accel, Hit, Ray};

/// Where a ray meets a triangle's plane: distance and barycentrics `(t, u, v)` with
/// `p = (1 - u - v) a + u b + v c`; `None` for a ray parallel to the plane.
#[inline]
fn plane_hit(origin: Vec3, dir: Vec3, [a, b, c]: &[Vec3; 3]) -> Option<(f32, f32, f32)> {
    let (e1, e2) = (*b - *a, *c - *a);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - *a;
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    let t = e2.dot(q) * inv;
    Some((t, u, v))
}

/// Two-sided Möller–Trumbore: distance and barycentrics of the hit, if inside the
/// triangle and within `[tmin, tmax]`. The `bvh` crate's own test culls back faces,
/// which Embree and ember's BVH do not.
#[inline]
fn moller_trumbore(
    origin: Vec3,
    dir: Vec3,
    tri: &[Vec3; 3],
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32, f32)> {
    plane_hit(origin, dir, tri)
        .filter(|&(t, u, v)| u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= tmin && t <= tmax)
}

/// `obvhs`'s CWBVH with its medium build preset and its own triangle test.
pub struct ObvhsAccel {
    bvh: obvhs::cwbvh::CwBvh,
    /// Triangles in the BVH's primitive order, so leaves read them in sequence.
    tris: Vec<obvhs::triangle::Triangle>,
}

impl ObvhsAccel {
    pub fn build(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<Self, String> {
        if triangles.is_empty() {
            return Err("obvhs needs at least one triangle".into());
        }
        let v = |i: u32| OVec3A::from_array(vertices[i as usize].to_array());
        let tris: Vec<obvhs::triangle::Triangle> = triangles
            .iter()
            .map(|&[a, b, c]| obvhs::triangle::Triangle {
                v0: v(a),
                v1: v(b),
                v2: v(c),
            })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &tris,
            obvhs::BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&p| tris[p as usize])
            .collect();
        Ok(ObvhsAccel { bvh, tris })
    }

    fn ray(ray: &Ray) -> obvhs::ray::Ray {
        obvhs::ray::Ray::new(
            OVec3A::from_array(ray.origin.to_array()),
            OVec3A::from_array(ray.dir.to_array()),
            ray.tmin,
            ray.tmax,
        )
    }
}

impl Accel for ObvhsAccel {
    fn name(&self) -> &'static str {
        "obvhs"
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut hit = obvhs::ray::RayHit::none();
        let tris = &self.tris;
        if !self
            .bvh
            .ray_traverse(Self::ray(ray), &mut hit, |r, id| tris[id].intersect(r))
        {
            return None;
        }
        // obvhs reports the distance only: the barycentrics come from the same
        // triangle's plane, clamped into it (the hit is on the triangle).
        let tri = &tris[hit.primitive_id as usize];
        let corners = [tri.v0, tri.v1, tri.v2].map(|p| Vec3::from_array(p.to_array()));
        let (_, u, v) = plane_hit(ray.origin, ray.dir, &corners).unwrap_or((0.0, 0.0, 0.0));
        let (u, v) = (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0));
        Some(Hit {
            t: hit.t,
            prim: self.bvh.primitive_indices[hit.primitive_id as usize],
            u,
            v: v.min(1.0 - u),
            instance: 0,
        })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let tris = &self.tris;
        !self
            .bvh
            .ray_traverse_miss(Self::ray(ray), |r, id| tris[id].intersect(r))
    }

    fn memory_bytes(&self) -> usize {
        self.bvh.nodes.len() * std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>()
            + self.bvh.primitive_indices.len() * std::mem::size_of::<u32>()
            + self.tris.len() * std::mem::size_of::<obvhs::triangle::Triangle>()
    }
}

/// A triangle as the `bvh` crate sees it.
struct BvhShape {
    prim: u32,
    corners: [Vec3; 3],
    lo: Vec3,
    hi: Vec3,
    node: usize,
}

impl bvh::aabb::Bounded<f32, 3> for BvhShape {
    fn aabb(&self) -> bvh::aabb::Aabb<f32, 3> {
        let p = |v: Vec3| nalgebra::Point3::new(v.x, v.y, v.z);
        bvh::aabb::Aabb::with_bounds(p(self.lo), p(self.hi))
    }
}

impl bvh::bounding_hierarchy::BHShape<f32, 3> for BvhShape {
    fn set_bh_node_index(&mut self, index: usize) {
        self.node = index;
    }

    fn bh_node_index(&self) -> usize {
        self.node
    }
}

/// The `bvh` crate's SAH BVH; closest hits walk its nearest-first iterator (which keeps
/// a heap per ray) until the next box starts beyond the nearest hit.
pub struct BvhCrateAccel {
    bvh: bvh::bvh::Bvh<f32, 3>,
    shapes: Vec<BvhShape>,
}

impl BvhCrateAccel {
    pub fn build(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<Self, String> {
        let mut shapes: Vec<BvhShape> = triangles
            .iter()
            .zip(0..)
            .map(|(t, prim)| {
                let corners = t.map(|i| vertices[i as usize]);
                BvhShape {
                    prim,
                    corners,
                    lo: corners[0].min(corners[1]).min(corners[2]),
                    hi: corners[0].max(corners[1]).max(corners[2]),
                    node: 0,
                }
            })
            .collect();
        if shapes.is_empty() {
            return Err("bvh needs at least one triangle".into());
        }
        let bvh = bvh::bvh::Bvh::build_with_executor(&mut shapes, bvh::bvh::rayon_executor);
        Ok(BvhCrateAccel { bvh, shapes })
    }

    fn ray(ray: &Ray) -> bvh::ray::Ray<f32, 3> {
        bvh::ray::Ray::new(
            nalgebra::Point3::new(ray.origin.x, ray.origin.y, ray.origin.z),
            nalgebra::Vector3::new(ray.dir.x, ray.dir.y, ray.dir.z),
        )
    }
}

/// Where `ray` enters the box `lo..hi`.
fn box_entry(ray: &Ray, lo: Vec3, hi: Vec3) -> f32 {
    let inv = ray.dir.recip();
    let (t0, t1) = ((lo - ray.origin) * inv, (hi - ray.origin) * inv);
    t0.min(t1).max_element()
}

impl Accel for BvhCrateAccel {
    fn name(&self) -> &'static str {
        "bvh-crate"
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let query = Self::ray(ray);
        let mut best: Option<Hit> = None;
        for shape in self.bvh.nearest_traverse_iterator(&query, &self.shapes) {
            let tmax = best.map_or(ray.tmax, |b| b.t);
            if box_entry(ray, shape.lo, shape.hi) > tmax {
                break;
            }
            if let Some((t, u, v)) =
                moller_trumbore(ray.origin, ray.dir, &shape.corners, ray.tmin, tmax)
            {
                let prim = shape.prim;
                best = Some(Hit {
                    t,
                    prim,
                    u,
                    v,
                    instance: 0,
                });
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let query = Self::ray(ray);
        self.bvh
            .traverse_iterator(&query, &self.shapes)
            .any(|s| moller_trumbore(ray.origin, ray.dir, &s.corners, ray.tmin, ray.tmax).is_some())
    }

    fn memory_bytes(&self) -> usize {
        self.bvh.nodes.len() * std::mem::size_of::<bvh::bvh::BvhNode<f32, 3>>()
            + self.shapes.len() * std::mem::size_of::<BvhShape>()
    }
}
