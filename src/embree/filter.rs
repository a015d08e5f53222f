//! Cut-outs in Embree: a [`HitFilter`] installed as the geometry's intersection and
//! occlusion filter functions. Embree calls them for every candidate hit; a rejected hit
//! makes it go on traversing, so a ray passes through the transparent parts of a
//! surface inside one `rtcIntersect`/`rtcOccluded` call, with no re-tracing in Rust.
//!
//! The callback is one `extern "C"` function per filter type `F` (monomorphised, so the
//! test inside it is a static call), and finds its `F` through the geometry's user-data
//! pointer. The [`super::Scene`] owns that `F` (an `Arc`) and releases the Embree scene
//! before dropping it.
//!
//! Embree 4 runs geometry filter functions when the query's feature mask has
//! `RTC_FEATURE_FLAG_FILTER_FUNCTION_IN_GEOMETRY`: ember passes null query arguments,
//! which Embree fills with `rtcInitIntersectArguments`' defaults (`RTC_FEATURE_FLAG_ALL`).
//! `RTC_SCENE_FLAG_FILTER_FUNCTION_IN_ARGUMENTS` concerns filters passed in the query
//! arguments, which ember does not use. The Embree 4 leg of `scripts/test.sh` runs the
//! cut-out tests to hold this.

use std::os::raw::c_void;

use super::sys;
use crate::geometry::HitFilter;

/// Lanes before `u`, `v` and `primID` in Embree's SOA hit packet (`RTCHitN`): the
/// packet is `Ng_x, Ng_y, Ng_z, u, v, primID, geomID, …`, each `N` 4-byte lanes wide.
const HIT_U: usize = 3;
const HIT_V: usize = 4;
const HIT_PRIM: usize = 5;

/// Embree's filter callback for geometries whose user data is an `F`: clears the valid
/// flag of every candidate hit `F` rejects.
unsafe extern "C" fn reject_filtered<F: HitFilter>(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes a valid argument struct that lives for the call.
    let args = unsafe { &*args };
    // SAFETY: the user data of every geometry this callback is installed on is the `F`
    // that `install` was given, which the scene owning the geometry keeps alive.
    let filter = unsafe { &*(args.geometryUserPtr as *const F) };
    let n = args.N as usize;
    let (hit_f32, hit_u32) = (args.hit as *const f32, args.hit as *const u32);
    for lane in 0..n {
        // SAFETY: `valid` points to `N` ints, one per ray of the packet.
        let valid = unsafe { args.valid.add(lane) };
        // SAFETY: as above; Embree only reads the mask after we return.
        if unsafe { *valid } == 0 {
            continue;
        }
        // SAFETY: the hit packet holds at least `primID` for its `N` lanes (SOA layout
        // above), and every lane Embree marks valid is initialised.
        let (u, v, prim) = unsafe {
            (
                *hit_f32.add(HIT_U * n + lane),
                *hit_f32.add(HIT_V * n + lane),
                *hit_u32.add(HIT_PRIM * n + lane),
            )
        };
        if !filter.accept(prim, u, v) {
            // SAFETY: as above; writing 0 is how a filter rejects a hit.
            unsafe { *valid = 0 };
        }
    }
}

/// Makes `filter` decide the hits of `geometry`, for intersection and occlusion queries.
///
/// # Safety
/// `geometry` must be live and not yet committed, and `filter` must outlive every
/// query on any scene the geometry is attached to.
pub(super) unsafe fn install<F: HitFilter>(geometry: sys::RTCGeometry, filter: &F) {
    let user = filter as *const F as *mut c_void;
    // SAFETY: per this function's contract; the callback only reads through `user`.
    unsafe {
        sys::rtcSetGeometryUserData(geometry, user);
        sys::rtcSetGeometryIntersectFilterFunction(geometry, Some(reject_filtered::<F>));
        sys::rtcSetGeometryOccludedFilterFunction(geometry, Some(reject_filtered::<F>));
    }
}
