//! Embree called the way a C program calls it, for the benchmark's baseline: rays held
//! in Embree's own `RTCRayHit` layout and traced with bare `rtcIntersect1` /
//! `rtcOccluded1` calls in a loop, with one query context per batch. The difference
//! from [`Scene::intersect`] / [`Scene::occluded`] on the same rays is what the safe
//! wrapper costs per ray (conversion, the validity check, building the `Hit`).

use super::{embree_accepts, empty_hit, raw_ray, sys, Scene, INVALID_ID};
use crate::geometry::Ray;

/// One ray in Embree's layout, ready to be copied into a query.
#[derive(Clone, Copy)]
pub struct RawRay(sys::RTCRayHit);

/// Rays as a program calling Embree directly would hold them. Rays Embree would reject
/// (see `embree_accepts`) are left out, as such a program would have to.
pub fn raw_rays(rays: &[Ray]) -> Vec<RawRay> {
    rays.iter()
        .filter(|r| embree_accepts(r))
        .map(|r| {
            RawRay(sys::RTCRayHit {
                ray: raw_ray(r),
                hit: empty_hit(),
            })
        })
        .collect()
}

impl Scene<'_> {
    /// How many of `rays` hit anything, each traced by one bare `rtcIntersect1`.
    pub fn count_hits_direct(&self, rays: &[RawRay]) -> usize {
        #[cfg(embree3)]
        let mut ctx = super::context(false);
        let mut hits = 0;
        for ray in rays {
            let mut rayhit = ray.0;
            #[cfg(embree3)]
            // SAFETY: the scene is committed; `ctx` and `rayhit` are valid and aligned
            // (RTCRayHit keeps its 16-byte alignment) and live for the call.
            unsafe {
                sys::rtcIntersect1(self.raw, &mut ctx, &mut rayhit)
            };
            #[cfg(embree4)]
            // SAFETY: as above; a null argument struct means Embree's defaults.
            unsafe {
                sys::rtcIntersect1(self.raw, &mut rayhit, std::ptr::null_mut())
            };
            hits += usize::from(rayhit.hit.geomID != INVALID_ID);
        }
        hits
    }

    /// How many of `rays` are blocked, each traced by one bare `rtcOccluded1`.
    pub fn count_occluded_direct(&self, rays: &[RawRay]) -> usize {
        #[cfg(embree3)]
        let mut ctx = super::context(false);
        let mut blocked = 0;
        for ray in rays {
            let mut raw = ray.0.ray;
            #[cfg(embree3)]
            // SAFETY: committed scene; `ctx` and `raw` are valid for the call.
            unsafe {
                sys::rtcOccluded1(self.raw, &mut ctx, &mut raw)
            };
            #[cfg(embree4)]
            // SAFETY: committed scene; `raw` is valid; null arguments mean defaults.
            unsafe {
                sys::rtcOccluded1(self.raw, &mut raw, std::ptr::null_mut())
            };
            blocked += usize::from(raw.tfar == f32::NEG_INFINITY);
        }
        blocked
    }
}
