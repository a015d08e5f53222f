//! Boxes, and the builder's references to triangles: a box with a triangle's index.
//! A leaf of the module tree: the builder, spatial splits and presplitting all use it.

use glam::{Vec3A, Vec4};

/// An axis-aligned box; empty when `lo > hi`. SIMD-wide (`Vec3A`) for fast unions.
#[derive(Clone, Copy, Debug)]
pub struct Aabb {
    pub lo: Vec3A,
    pub hi: Vec3A,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        lo: Vec3A::splat(f32::INFINITY),
        hi: Vec3A::splat(f32::NEG_INFINITY),
    };

    #[inline]
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    #[inline]
    pub fn grow(self, p: Vec3A) -> Aabb {
        Aabb {
            lo: self.lo.min(p),
            hi: self.hi.max(p),
        }
    }

    #[inline]
    pub fn intersect(self, o: Aabb) -> Aabb {
        Aabb {
            lo: self.lo.max(o.lo),
            hi: self.hi.min(o.hi),
        }
    }

    #[inline]
    pub fn is_empty(self) -> bool {
        self.lo.cmpgt(self.hi).any()
    }

    /// Half the surface area (the SAH only compares ratios); 0 for an empty box.
    #[inline]
    pub fn half_area(self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3A::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// A triangle as the builder sees it: its box, with its index in the mesh stored in
/// the spare fourth lane of `hi` (32 bytes, two aligned SIMD loads).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct PrimRef {
    lo: Vec4,
    hi: Vec4,
}

impl PrimRef {
    pub fn new(lo: Vec3A, hi: Vec3A, id: u32) -> Self {
        PrimRef {
            lo: lo.extend(0.0),
            hi: hi.extend(f32::from_bits(id)),
        }
    }

    #[inline]
    pub fn id(&self) -> u32 {
        self.hi.w.to_bits()
    }

    /// Twice the centroid (the factor cancels in binning).
    #[inline]
    pub fn centroid2(&self) -> Vec3A {
        Vec3A::from_vec4(self.lo) + Vec3A::from_vec4(self.hi)
    }

    #[inline]
    pub fn aabb(&self) -> Aabb {
        Aabb {
            lo: Vec3A::from_vec4(self.lo),
            hi: Vec3A::from_vec4(self.hi),
        }
    }
}
