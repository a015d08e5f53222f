//! Packets: sixteen rays queried at once, in lanes (struct of arrays), as Embree's
//! `rtcIntersect16`/`rtcOccluded16` take them and as a wavefront of paths holds them.

use super::{Hit, Ray};

/// Rays per packet.
pub const PACKET: usize = 16;

/// Sixteen ray segments: lane `l` is the points `org + t·dir` for `t` in
/// `[tmin[l], tmax[l]]`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Rays16 {
    pub org: [[f32; PACKET]; 3],
    pub dir: [[f32; PACKET]; 3],
    pub tmin: [f32; PACKET],
    pub tmax: [f32; PACKET],
}

/// The nearest hits of a packet: where `found[l]`, lane `l` holds a [`Hit`]'s fields.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Hits16 {
    pub t: [f32; PACKET],
    pub u: [f32; PACKET],
    pub v: [f32; PACKET],
    pub prim: [u32; PACKET],
    pub instance: [u32; PACKET],
    pub found: [bool; PACKET],
}

impl Default for Rays16 {
    fn default() -> Self {
        Rays16 {
            org: [[0.0; PACKET]; 3],
            dir: [[0.0; PACKET]; 3],
            tmin: [0.0; PACKET],
            tmax: [0.0; PACKET],
        }
    }
}

impl Default for Hits16 {
    fn default() -> Self {
        Hits16 {
            t: [0.0; PACKET],
            u: [0.0; PACKET],
            v: [0.0; PACKET],
            prim: [0; PACKET],
            instance: [0; PACKET],
            found: [false; PACKET],
        }
    }
}

impl Rays16 {
    /// Lane `l` as one ray.
    #[inline]
    pub fn ray(&self, l: usize) -> Ray {
        let v = |a: &[[f32; PACKET]; 3]| glam::Vec3::new(a[0][l], a[1][l], a[2][l]);
        Ray {
            origin: v(&self.org),
            dir: v(&self.dir),
            tmin: self.tmin[l],
            tmax: self.tmax[l],
        }
    }

    /// Sets lane `l` to `ray`.
    #[inline]
    pub fn set(&mut self, l: usize, ray: &Ray) {
        for axis in 0..3 {
            self.org[axis][l] = ray.origin[axis];
            self.dir[axis][l] = ray.dir[axis];
        }
        self.tmin[l] = ray.tmin;
        self.tmax[l] = ray.tmax;
    }
}

impl Hits16 {
    /// Lane `l` as a hit.
    #[inline]
    pub fn hit(&self, l: usize) -> Option<Hit> {
        self.found[l].then_some(Hit {
            t: self.t[l],
            prim: self.prim[l],
            u: self.u[l],
            v: self.v[l],
            instance: self.instance[l],
        })
    }

    /// Sets lane `l` to `hit`.
    #[inline]
    pub fn set(&mut self, l: usize, hit: Option<Hit>) {
        self.found[l] = hit.is_some();
        if let Some(h) = hit {
            self.t[l] = h.t;
            self.u[l] = h.u;
            self.v[l] = h.v;
            self.prim[l] = h.prim;
            self.instance[l] = h.instance;
        }
    }
}
