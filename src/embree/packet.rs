//! Sixteen-ray packets (`rtcIntersect16`, `rtcOccluded16`): what a wavefront of paths
//! queries, in the lanes it holds them in.

#[cfg(embree3)]
use super::context;
use super::{sys, Scene, EMBREE_LARGE, INVALID_ID};
use crate::geometry::{Hits16, Rays16, PACKET};

/// Embree's active-lane mask: -1 active, 0 inactive, loaded with aligned vector
/// instructions, so 64-byte aligned for the 16-wide packet.
#[repr(C, align(64))]
struct Valid16([i32; PACKET]);

/// The lanes of `active` whose ray Embree accepts (finite, not huge, no NaN bounds):
/// a lane it would reject stays inactive, a miss and unoccluded, as single rays are.
#[inline(always)]
fn valid_lanes(active: &[bool; PACKET], rays: &Rays16) -> Valid16 {
    let mut valid = [0i32; PACKET];
    for l in 0..PACKET {
        let small = (0..3)
            .all(|a| rays.org[a][l].abs() <= EMBREE_LARGE && rays.dir[a][l].abs() <= EMBREE_LARGE);
        let accepted = small && !rays.tmin[l].is_nan() && !rays.tmax[l].is_nan();
        valid[l] = -i32::from(active[l] && accepted);
    }
    Valid16(valid)
}

/// The packet's rays in Embree's layout.
#[inline(always)]
fn raw_rays16(rays: &Rays16) -> sys::RTCRay16 {
    sys::RTCRay16 {
        org_x: rays.org[0],
        org_y: rays.org[1],
        org_z: rays.org[2],
        tnear: rays.tmin,
        dir_x: rays.dir[0],
        dir_y: rays.dir[1],
        dir_z: rays.dir[2],
        time: [0.0; PACKET],
        tfar: rays.tmax,
        mask: [u32::MAX; PACKET],
        id: [0; PACKET],
        flags: [0; PACKET],
    }
}

impl Scene<'_> {
    /// The nearest hits of the `active` lanes of `rays` as one packet; the other lanes
    /// of `hits` are misses. `coherent` hints that the rays are alike (camera rays).
    /// Inlined, so that its copies are compiled for the caller's instruction set.
    #[inline(always)]
    pub fn intersect16(
        &self,
        active: &[bool; PACKET],
        rays: &Rays16,
        hits: &mut Hits16,
        coherent: bool,
    ) {
        let valid = valid_lanes(active, rays);
        // SAFETY: RTCRayHit16 is plain old data (floats and integers, whatever fields
        // this Embree version adds); all-zero is valid, and the fields read are set here.
        let mut packet: sys::RTCRayHit16 = unsafe { std::mem::zeroed() };
        packet.ray = raw_rays16(rays);
        packet.hit.primID = [INVALID_ID; PACKET];
        packet.hit.geomID = [INVALID_ID; PACKET];
        packet.hit.instID[0] = [INVALID_ID; PACKET];
        #[cfg(embree3)]
        {
            let mut ctx = context(coherent);
            // SAFETY: the scene is committed; `valid` has 16 lanes and `packet` is a
            // 64-byte-aligned RTCRayHit16 (as Embree loads them), both alive for the call.
            unsafe { sys::rtcIntersect16(valid.0.as_ptr(), self.raw, &mut ctx, &mut packet) };
        }
        #[cfg(embree4)]
        {
            let _ = coherent;
            // SAFETY: as above; null arguments mean Embree's defaults.
            unsafe {
                sys::rtcIntersect16(
                    valid.0.as_ptr(),
                    self.raw,
                    &mut packet,
                    std::ptr::null_mut(),
                )
            };
        }
        for l in 0..PACKET {
            hits.found[l] = packet.hit.geomID[l] != INVALID_ID;
            hits.t[l] = packet.ray.tfar[l];
            hits.u[l] = packet.hit.u[l];
            hits.v[l] = packet.hit.v[l];
            hits.prim[l] = packet.hit.primID[l];
            let inst = packet.hit.instID[0][l];
            hits.instance[l] = if inst == INVALID_ID { 0 } else { inst };
        }
    }

    /// Which `active` lanes of `rays` are blocked, as one packet; the others are not.
    #[inline(always)]
    pub fn occluded16(&self, active: &[bool; PACKET], rays: &Rays16) -> [bool; PACKET] {
        let valid = valid_lanes(active, rays);
        let mut packet = raw_rays16(rays);
        #[cfg(embree3)]
        {
            let mut ctx = context(false);
            // SAFETY: committed scene; 16 valid lanes and an RTCRay16, both 64-byte
            // aligned, alive for the call.
            unsafe { sys::rtcOccluded16(valid.0.as_ptr(), self.raw, &mut ctx, &mut packet) };
        }
        #[cfg(embree4)]
        {
            // SAFETY: as above; null arguments mean Embree's defaults.
            unsafe {
                sys::rtcOccluded16(
                    valid.0.as_ptr(),
                    self.raw,
                    &mut packet,
                    std::ptr::null_mut(),
                )
            };
        }
        // Embree marks an occluded lane by setting its tfar to -inf.
        std::array::from_fn(|l| valid.0[l] != 0 && packet.tfar[l] == f32::NEG_INFINITY)
    }
}
