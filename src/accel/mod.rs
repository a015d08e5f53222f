//! Ray/triangle-mesh acceleration structures behind one trait, so the integrator and the
//! benchmarks can run the same rays through Embree or through ember's own BVH.

pub mod bvh;
mod embree;

pub use self::bvh::{Bvh, BvhError};
pub use self::embree::EmbreeAccel;

use glam::Vec3;

/// A ray segment: points `origin + t * dir` for `t` in `[tmin, tmax]`.
/// `dir` need not be normalised; `t` is measured in units of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    /// A segment that ends just short of `tmax`, for shadow rays towards a point.
    pub fn segment(origin: Vec3, dir: Vec3, tmax: f32) -> Self {
        Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax,
        }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// The nearest hit of a ray: distance, the scene's triangle index and the barycentric
/// coordinates of the hit point, `p = (1 - u - v) * v0 + u * v1 + v * v2` (Embree's
/// convention). Everything else (normals, UVs, material) is looked up in the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

/// Which structure answers the ray queries (`ember render --accel`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum AccelKind {
    /// Intel Embree through FFI.
    Embree,
    /// ember's native Rust BVH.
    Bvh,
}

/// A structure that answers ray queries against a fixed triangle mesh. Implementations
/// are immutable once built and are queried from all rayon workers at once.
///
/// The integrator is generic over `A: Accel`, so these calls are static, not virtual.
pub trait Accel: Sync + Send {
    /// Short name for tables and JSON (`embree`, `bvh`, …).
    fn name(&self) -> &'static str;
    /// Nearest hit with `t` in `[tmin, tmax]`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether anything is hit with `t` in `[tmin, tmax]`; may stop at the first hit.
    fn occluded(&self, ray: &Ray) -> bool;
    /// Bytes the structure holds (nodes, triangle copies), for the benchmark.
    fn memory_bytes(&self) -> usize;
}
