//! The scene's triangles, flattened into one indexed mesh: triangle `i` of the mesh is
//! primitive `i` for every accelerator.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::geometry::{barycentric_error, Hit, SurfaceOrigin};

/// All triangles of a scene with their per-vertex attributes.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals, or empty when the file had none. A zero normal
    /// means "none for this vertex": shading falls back to the geometric normal.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, or empty when the file had none.
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
    /// Material index of each triangle.
    pub material: Vec<u32>,
}

/// Lower and upper corners of the box around the vertices that `triangles` use, on
/// all threads (min and max are exact, so the box does not depend on their number).
pub fn triangle_bounds(positions: &[Vec3], triangles: &[[u32; 3]]) -> (Vec3, Vec3) {
    let empty = || (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    triangles
        .par_iter()
        .with_min_len(1 << 16)
        .fold(empty, |(lo, hi), triangle| {
            triangle.iter().fold((lo, hi), |(lo, hi), &i| {
                let p = positions[i as usize];
                (lo.min(p), hi.max(p))
            })
        })
        .reduce(empty, |(lo, hi), (l, h)| (lo.min(l), hi.max(h)))
}

/// What the integrator needs to know about the point a ray hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Per-axis bound on the rounding error of `p`.
    pub error: Vec3,
    /// Unit geometric normal from the counter-clockwise winding (the emitting side).
    pub ng: Vec3,
    /// Unit shading normal, on the same side of the surface as `ng`.
    pub ns: Vec3,
    pub uv: Vec2,
    pub material: u32,
}

impl SurfacePoint {
    /// Where rays leaving this point start from (see [`SurfaceOrigin`]).
    #[inline]
    pub fn origin(&self) -> SurfaceOrigin {
        SurfaceOrigin {
            p: self.p,
            error: self.error,
            ng: self.ng,
        }
    }
}

impl TriangleMesh {
    pub fn vertices(&self, prim: u32) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[prim as usize];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// The texture coordinates of triangle `prim`'s corners; without any, the corners'
    /// barycentrics, so that interpolating them gives the hit's `(u, v)` as
    /// [`surface`](Self::surface) does.
    pub fn corner_uvs(&self, prim: u32) -> [Vec2; 3] {
        if self.uvs.is_empty() {
            return [Vec2::ZERO, Vec2::X, Vec2::Y];
        }
        self.triangles[prim as usize].map(|i| self.uvs[i as usize])
    }

    /// `(v1 - v0) × (v2 - v0)`: twice the area, pointing to the counter-clockwise side.
    pub fn area_normal(&self, prim: u32) -> Vec3 {
        let [a, b, c] = self.vertices(prim);
        (b - a).cross(c - a)
    }

    pub fn area(&self, prim: u32) -> f32 {
        0.5 * self.area_normal(prim).length()
    }

    /// Lower and upper corners of the bounding box of all vertices that triangles use.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        triangle_bounds(&self.positions, &self.triangles)
    }

    /// The surface at a hit: position, normals, texture coordinates and material.
    pub fn surface(&self, hit: &Hit) -> SurfacePoint {
        let [ia, ib, ic] = self.triangles[hit.prim as usize].map(|i| i as usize);
        let (u, v) = (hit.u, hit.v);
        let w = 1.0 - u - v;
        let [a, b, c] = [self.positions[ia], self.positions[ib], self.positions[ic]];
        let p = w * a + u * b + v * c;
        let ng = (b - a).cross(c - a).normalize_or_zero();
        let mut ns = ng;
        if !self.normals.is_empty() {
            let n = w * self.normals[ia] + u * self.normals[ib] + v * self.normals[ic];
            if let Some(n) = n.try_normalize() {
                // Keep the shading normal on the geometric side, so "front" means one thing.
                ns = if n.dot(ng) < 0.0 { -n } else { n };
            }
        }
        let uv = if self.uvs.is_empty() {
            Vec2::new(u, v)
        } else {
            w * self.uvs[ia] + u * self.uvs[ib] + v * self.uvs[ic]
        };
        SurfacePoint {
            p,
            error: barycentric_error([w, u, v], [a, b, c]),
            ng,
            ns,
            uv,
            material: self.material[hit.prim as usize],
        }
    }
}
