//! Ray/triangle-mesh acceleration structures behind one trait, so the integrator and the
//! benchmarks can run the same rays through Embree or through ember's own BVH.

pub mod bvh;
mod embree;
mod instanced;
mod scene;

pub use self::bvh::{Bvh, BvhError, FilteredBvh};
pub use self::embree::{EmbreeAccel, EmbreeBackend};
pub use self::instanced::InstancedBvh;
pub use self::scene::{instanced_bvh, instanced_embree, instanced_filtered_bvh};

pub use crate::geometry::{Hit, HitFilter, Instance, InstanceError, Opaque, Ray};

/// Which structure answers the ray queries (`ember render --accel`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
