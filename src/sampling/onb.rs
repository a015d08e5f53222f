//! Orthonormal bases: the local frame around a normal that directions are sampled in.

use glam::Vec3;

/// An orthonormal basis `(u, v, w)` with `w` the given unit normal.
#[derive(Clone, Copy, Debug)]
pub struct Onb {
    pub u: Vec3,
    pub v: Vec3,
    pub w: Vec3,
}

impl Onb {
    /// The frame around unit vector `w`, by Duff et al.'s branchless construction
    /// ("Building an Orthonormal Basis, Revisited", JCGT 2017): continuous and exact to
    /// rounding for every `w`, unlike the cross-with-an-axis method.
    pub fn from_w(w: Vec3) -> Self {
        let sign = 1.0f32.copysign(w.z);
        let a = -1.0 / (sign + w.z);
        let b = w.x * w.y * a;
        let u = Vec3::new(1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x);
        let v = Vec3::new(b, sign + w.y * w.y * a, -w.y);
        Onb { u, v, w }
    }

    /// A local direction (z along `w`) in world space.
    #[inline]
    pub fn to_world(&self, local: Vec3) -> Vec3 {
        local.x * self.u + local.y * self.v + local.z * self.w
    }

    /// A world direction in local coordinates.
    #[inline]
    pub fn to_local(&self, world: Vec3) -> Vec3 {
        Vec3::new(world.dot(self.u), world.dot(self.v), world.dot(self.w))
    }
}
