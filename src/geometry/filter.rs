//! Which candidate hits count: the test both accelerators run on every triangle a ray
//! meets, so that cut-out surfaces (leaves, fences) let rays through where they are
//! transparent. Embree runs it from its geometry filter functions, the native BVH inside
//! its traversal; either way the accelerator goes on traversing past a rejected hit.

/// Decides whether a ray-triangle intersection is a hit. The decision may depend only
/// on the point of the surface (the triangle and its barycentrics), not on the ray, so
/// that every ray meeting that point (camera, bounce or shadow ray, either backend)
/// gets the same answer, and so that a filter called twice for one hit (Embree may do
/// that) answers the same twice.
pub trait HitFilter: Send + Sync + 'static {
    /// True only for a filter that accepts every intersection, so that traversal code
    /// generic over the filter can skip the test at compile time.
    const ACCEPTS_ALL: bool = false;

    /// Whether the intersection with triangle `prim` at barycentrics `(u, v)` (the
    /// weights of its second and third vertices, as in [`super::Hit`]) counts.
    fn accept(&self, prim: u32, u: f32, v: f32) -> bool;
}

/// The filter of a scene without cut-outs: every intersection is a hit.
#[derive(Clone, Copy, Debug, Default)]
pub struct Opaque;

impl HitFilter for Opaque {
    const ACCEPTS_ALL: bool = true;

    #[inline(always)]
    fn accept(&self, _prim: u32, _u: f32, _v: f32) -> bool {
        true
    }
}
