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

pub use crate::geometry::{
    Hit, HitFilter, Hits16, Instance, InstanceError, Opaque, Ray, Rays16, PACKET,
};

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

    /// The nearest hits of the `active` lanes of a packet (the other lanes miss).
    /// `coherent` hints that the rays are alike (camera rays). By default, ray by ray.
    #[inline]
    fn intersect16(
        &self,
        active: &[bool; PACKET],
        rays: &Rays16,
        hits: &mut Hits16,
        coherent: bool,
    ) {
        let _ = coherent;
        for (l, &on) in active.iter().enumerate() {
            let hit = if on {
                self.intersect(&rays.ray(l))
            } else {
                None
            };
            hits.set(l, hit);
        }
    }

    /// Which `active` lanes of a packet are blocked (the others are not). By default,
    /// ray by ray.
    #[inline]
    fn occluded16(&self, active: &[bool; PACKET], rays: &Rays16) -> [bool; PACKET] {
        std::array::from_fn(|l| active[l] && self.occluded(&rays.ray(l)))
    }
}
