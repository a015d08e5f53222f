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
    /// Per-vertex colours in [0, 1] (`v x y z r g b`), multiplying the diffuse colour;
    /// empty when the file had none.
    pub colours: Vec<Vec3>,
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
    /// The vertex colour here (white where the mesh has none).
    pub colour: Vec3,
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
    /// Room for one more vertex and triangle past the ends, with defined bytes: Embree
    /// reads these arrays in place, 16 bytes at a time.
    pub fn pad_for_embree(&mut self) {
        self.positions.reserve_exact(1);
        self.triangles.reserve_exact(1);
        if let Some(slot) = self.positions.spare_capacity_mut().first_mut() {
            slot.write(Vec3::ZERO);
        }
        if let Some(slot) = self.triangles.spare_capacity_mut().first_mut() {
            slot.write([0; 3]);
        }
    }

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
    #[inline]
    pub fn surface(&self, hit: &Hit) -> SurfacePoint {
        self.corners(hit.prim)
            .surface(hit.u, hit.v, self.material[hit.prim as usize])
    }

    /// Triangle `prim`'s corners with the attributes the mesh has.
    #[inline(always)]
    pub fn corners(&self, prim: u32) -> Corners {
        let [ia, ib, ic] = self.triangles[prim as usize].map(|i| i as usize);
        let corner = |values: &[Vec3]| [values[ia], values[ib], values[ic]];
        Corners {
            p: corner(&self.positions),
            n: (!self.normals.is_empty()).then(|| corner(&self.normals)),
            uv: (!self.uvs.is_empty()).then(|| [self.uvs[ia], self.uvs[ib], self.uvs[ic]]),
            colour: (!self.colours.is_empty()).then(|| corner(&self.colours)),
        }
    }
}

/// A triangle's corners as shading reads them, in winding order: positions, shading
/// normals (`None` when the mesh has none), texture coordinates (`None`: a point's
/// barycentrics are its coordinates) and vertex colours (`None`: white).
#[derive(Clone, Copy, Debug)]
pub struct Corners {
    pub p: [Vec3; 3],
    pub n: Option<[Vec3; 3]>,
    pub uv: Option<[Vec2; 3]>,
    pub colour: Option<[Vec3; 3]>,
}

impl Corners {
    /// The surface at barycentrics `(u, v)` (the weights of the second and third
    /// corners), of material `material`.
    #[inline(always)]
    pub fn surface(&self, u: f32, v: f32, material: u32) -> SurfacePoint {
        let w = 1.0 - u - v;
        let [a, b, c] = self.p;
        let p = w * a + u * b + v * c;
        let ng = (b - a).cross(c - a).normalize_or_zero();
        let mut ns = ng;
        if let Some([na, nb, nc]) = self.n {
            let n = w * na + u * nb + v * nc;
            if let Some(n) = n.try_normalize() {
                // Keep the shading normal on the geometric side, so "front" means one thing.
                ns = if n.dot(ng) < 0.0 { -n } else { n };
            }
        }
        let uv = match self.uv {
            None => Vec2::new(u, v),
            Some([ta, tb, tc]) => w * ta + u * tb + v * tc,
        };
        let colour = self
            .colour
            .map_or(Vec3::ONE, |[ca, cb, cc]| w * ca + u * cb + v * cc);
        SurfacePoint {
            p,
            error: barycentric_error([w, u, v], [a, b, c]),
            ng,
            ns,
            uv,
            colour,
            material,
        }
    }
}
