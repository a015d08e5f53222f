//! Lanes: one value per path of a block, as fixed arrays the compiler turns into vector
//! registers.
//!
//! Every operation is a loop over [`W`] lanes with no dependence between lanes, inlined
//! into the stage that uses it; the stages are compiled once per instruction set and
//! chosen at run time (`multiversion`), so the same loop becomes one AVX-512 instruction,
//! two AVX2 ones, or four SSE ones. No `unsafe`, no intrinsics: what vectorises is checked
//! in the disassembly, not assumed.

use std::ops::{Add, AddAssign, BitAnd, BitOr, Div, Mul, MulAssign, Neg, Not, Sub};

/// Paths per block: Embree's widest packet (`rtcIntersect16`), one AVX-512 register of
/// `f32`.
pub const W: usize = 16;

/// One `f32` per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct F32s(pub [f32; W]);

/// One `u32` per lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(64))]
pub struct U32s(pub [u32; W]);

/// One condition per lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(16))]
pub struct Mask(pub [bool; W]);

/// Applies `f` lane by lane (a loop, where `array::map` may not be inlined into the
/// stage and so not compiled for its instruction set).
#[inline(always)]
pub fn map<T: Copy, U: Copy + Default>(a: [T; W], f: impl Fn(T) -> U) -> [U; W] {
    let mut out = [U::default(); W];
    for l in 0..W {
        out[l] = f(a[l]);
    }
    out
}

#[inline(always)]
fn zip<T: Copy, U: Copy, V: Copy + Default>(a: [T; W], b: [U; W], f: impl Fn(T, U) -> V) -> [V; W] {
    let mut out = [V::default(); W];
    for l in 0..W {
        out[l] = f(a[l], b[l]);
    }
    out
}

impl F32s {
    pub const ZERO: F32s = F32s([0.0; W]);
    pub const ONE: F32s = F32s([1.0; W]);

    #[inline(always)]
    pub fn splat(x: f32) -> F32s {
        F32s([x; W])
    }

    #[inline(always)]
    pub fn sqrt(self) -> F32s {
        F32s(map(self.0, f32::sqrt))
    }

    #[inline(always)]
    pub fn abs(self) -> F32s {
        F32s(map(self.0, f32::abs))
    }

    #[inline(always)]
    pub fn floor(self) -> F32s {
        F32s(map(self.0, f32::floor))
    }

    /// The magnitude of `self` with the sign of `sign`, per lane.
    #[inline(always)]
    pub fn copysign(self, sign: F32s) -> F32s {
        F32s(zip(self.0, sign.0, f32::copysign))
    }

    /// The smaller of the two per lane (the other operand where one is NaN).
    #[inline(always)]
    pub fn min(self, o: F32s) -> F32s {
        F32s(zip(self.0, o.0, |a, b| if a < b { a } else { b }))
    }

    /// The larger of the two per lane (the other operand where one is NaN).
    #[inline(always)]
    pub fn max(self, o: F32s) -> F32s {
        F32s(zip(self.0, o.0, |a, b| if a > b { a } else { b }))
    }

    #[inline(always)]
    pub fn lt(self, o: F32s) -> Mask {
        Mask(zip(self.0, o.0, |a, b| a < b))
    }

    #[inline(always)]
    pub fn le(self, o: F32s) -> Mask {
        Mask(zip(self.0, o.0, |a, b| a <= b))
    }

    #[inline(always)]
    pub fn gt(self, o: F32s) -> Mask {
        Mask(zip(self.0, o.0, |a, b| a > b))
    }

    #[inline(always)]
    pub fn ge(self, o: F32s) -> Mask {
        Mask(zip(self.0, o.0, |a, b| a >= b))
    }

    /// The integer part, towards zero, of lanes in `[0, 2^32)`.
    #[inline(always)]
    pub fn to_u32(self) -> U32s {
        U32s(map(self.0, |x| x as u32))
    }

    /// Lanes where `x` is finite.
    #[inline(always)]
    pub fn is_finite(self) -> Mask {
        Mask(map(self.0, f32::is_finite))
    }

    /// Gathers `table[index]` per lane; `index` must be in range (an index out of range
    /// is clamped to the last entry rather than panicking in the hot loop).
    #[inline(always)]
    pub fn gather(table: &[f32], index: U32s) -> F32s {
        let last = table.len() - 1;
        F32s(map(index.0, |i| table[(i as usize).min(last)]))
    }
}

impl U32s {
    #[inline(always)]
    pub fn splat(x: u32) -> U32s {
        U32s([x; W])
    }

    /// Lanes as `f32` (exact below 2^24).
    #[inline(always)]
    pub fn to_f32(self) -> F32s {
        F32s(map(self.0, |x| x as f32))
    }

    #[inline(always)]
    pub fn gather(table: &[u32], index: U32s) -> U32s {
        let last = table.len() - 1;
        U32s(map(index.0, |i| table[(i as usize).min(last)]))
    }

    #[inline(always)]
    pub fn eq(self, o: U32s) -> Mask {
        Mask(zip(self.0, o.0, |a, b| a == b))
    }

    #[inline(always)]
    pub fn lt(self, o: U32s) -> Mask {
        Mask(zip(self.0, o.0, |a, b| a < b))
    }

    #[inline(always)]
    pub fn ge(self, o: U32s) -> Mask {
        Mask(zip(self.0, o.0, |a, b| a >= b))
    }
}

impl Mask {
    pub const NONE: Mask = Mask([false; W]);
    pub const ALL: Mask = Mask([true; W]);

    /// The first `n` lanes.
    #[inline(always)]
    pub fn first(n: usize) -> Mask {
        let mut m = [false; W];
        for (l, set) in m.iter_mut().enumerate() {
            *set = l < n;
        }
        Mask(m)
    }

    #[inline(always)]
    pub fn any(self) -> bool {
        self.0.iter().any(|&b| b)
    }

    #[inline(always)]
    pub fn count(self) -> u32 {
        self.0.iter().map(|&b| u32::from(b)).sum()
    }

    /// `a` where set, `b` elsewhere.
    #[inline(always)]
    pub fn select(self, a: F32s, b: F32s) -> F32s {
        let mut out = [0.0; W];
        for l in 0..W {
            out[l] = if self.0[l] { a.0[l] } else { b.0[l] };
        }
        F32s(out)
    }

    #[inline(always)]
    pub fn select_u32(self, a: U32s, b: U32s) -> U32s {
        let mut out = [0; W];
        for l in 0..W {
            out[l] = if self.0[l] { a.0[l] } else { b.0[l] };
        }
        U32s(out)
    }

    /// Embree's active-lane mask: -1 where set, 0 elsewhere.
    #[inline(always)]
    pub fn to_valid(self) -> [i32; W] {
        map(self.0, |b| -i32::from(b))
    }
}

macro_rules! lane_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for F32s {
            type Output = F32s;
            #[inline(always)]
            fn $method(self, o: F32s) -> F32s {
                F32s(zip(self.0, o.0, |a, b| a $op b))
            }
        }
        impl $trait<f32> for F32s {
            type Output = F32s;
            #[inline(always)]
            fn $method(self, o: f32) -> F32s {
                F32s(map(self.0, |a| a $op o))
            }
        }
        impl $trait<F32s> for f32 {
            type Output = F32s;
            #[inline(always)]
            fn $method(self, o: F32s) -> F32s {
                F32s(map(o.0, |b| self $op b))
            }
        }
    };
}

lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

impl AddAssign for F32s {
    #[inline(always)]
    fn add_assign(&mut self, o: F32s) {
        *self = *self + o;
    }
}

impl MulAssign for F32s {
    #[inline(always)]
    fn mul_assign(&mut self, o: F32s) {
        *self = *self * o;
    }
}

impl Neg for F32s {
    type Output = F32s;
    #[inline(always)]
    fn neg(self) -> F32s {
        F32s(map(self.0, |a| -a))
    }
}

impl BitAnd for Mask {
    type Output = Mask;
    #[inline(always)]
    fn bitand(self, o: Mask) -> Mask {
        Mask(zip(self.0, o.0, |a, b| a & b))
    }
}

impl BitOr for Mask {
    type Output = Mask;
    #[inline(always)]
    fn bitor(self, o: Mask) -> Mask {
        Mask(zip(self.0, o.0, |a, b| a | b))
    }
}

impl Not for Mask {
    type Output = Mask;
    #[inline(always)]
    fn not(self) -> Mask {
        Mask(map(self.0, |a| !a))
    }
}

/// Three lanes of `f32`: a point, direction or colour per path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vec3s {
    pub x: F32s,
    pub y: F32s,
    pub z: F32s,
}

impl Vec3s {
    pub const ZERO: Vec3s = Vec3s {
        x: F32s::ZERO,
        y: F32s::ZERO,
        z: F32s::ZERO,
    };
    pub const ONE: Vec3s = Vec3s {
        x: F32s::ONE,
        y: F32s::ONE,
        z: F32s::ONE,
    };

    #[inline(always)]
    pub fn new(x: F32s, y: F32s, z: F32s) -> Vec3s {
        Vec3s { x, y, z }
    }

    #[inline(always)]
    pub fn splat(v: glam::Vec3) -> Vec3s {
        Vec3s::new(F32s::splat(v.x), F32s::splat(v.y), F32s::splat(v.z))
    }

    #[inline(always)]
    pub fn dot(self, o: Vec3s) -> F32s {
        // In glam's order, so that lanes and `Vec3` round alike.
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    pub fn length_squared(self) -> F32s {
        self.dot(self)
    }

    #[inline(always)]
    pub fn scale(self, s: F32s) -> Vec3s {
        Vec3s::new(self.x * s, self.y * s, self.z * s)
    }

    #[inline(always)]
    pub fn abs(self) -> Vec3s {
        Vec3s::new(self.x.abs(), self.y.abs(), self.z.abs())
    }

    #[inline(always)]
    pub fn max_element(self) -> F32s {
        self.x.max(self.y).max(self.z)
    }

    /// `a` where set, `b` elsewhere.
    #[inline(always)]
    pub fn select(m: Mask, a: Vec3s, b: Vec3s) -> Vec3s {
        Vec3s::new(m.select(a.x, b.x), m.select(a.y, b.y), m.select(a.z, b.z))
    }

    /// Gathers rows of a table held as three columns.
    #[inline(always)]
    pub fn gather(table: &[[f32; 3]], index: U32s) -> Vec3s {
        let last = table.len() - 1;
        let row = |l: usize| table[(index.0[l] as usize).min(last)];
        let mut out = Vec3s::ZERO;
        for l in 0..W {
            let [x, y, z] = row(l);
            out.x.0[l] = x;
            out.y.0[l] = y;
            out.z.0[l] = z;
        }
        out
    }

    /// Lane `l` as a vector.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> glam::Vec3 {
        glam::Vec3::new(self.x.0[l], self.y.0[l], self.z.0[l])
    }
}

impl Add for Vec3s {
    type Output = Vec3s;
    #[inline(always)]
    fn add(self, o: Vec3s) -> Vec3s {
        Vec3s::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl AddAssign for Vec3s {
    #[inline(always)]
    fn add_assign(&mut self, o: Vec3s) {
        *self = *self + o;
    }
}

impl Sub for Vec3s {
    type Output = Vec3s;
    #[inline(always)]
    fn sub(self, o: Vec3s) -> Vec3s {
        Vec3s::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul for Vec3s {
    type Output = Vec3s;
    #[inline(always)]
    fn mul(self, o: Vec3s) -> Vec3s {
        Vec3s::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}

impl MulAssign for Vec3s {
    #[inline(always)]
    fn mul_assign(&mut self, o: Vec3s) {
        *self = *self * o;
    }
}

impl Neg for Vec3s {
    type Output = Vec3s;
    #[inline(always)]
    fn neg(self) -> Vec3s {
        Vec3s::new(-self.x, -self.y, -self.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_compute_what_scalars_do() {
        let a = F32s(std::array::from_fn(|l| l as f32 - 7.5));
        let b = F32s(std::array::from_fn(|l| (l as f32 * 0.37).sin()));
        for l in 0..W {
            let (x, y) = (a.0[l], b.0[l]);
            assert_eq!((a + b).0[l], x + y);
            assert_eq!((a * b).0[l], x * y);
            assert_eq!((a / b).0[l], x / y);
            assert_eq!(a.min(b).0[l], x.min(y));
            assert_eq!(a.max(b).0[l], x.max(y));
            assert_eq!(a.abs().sqrt().0[l], x.abs().sqrt());
            assert_eq!(a.lt(b).0[l], x < y);
            assert_eq!(a.lt(b).select(a, b).0[l], if x < y { x } else { y });
        }
        let m = a.gt(F32s::ZERO);
        assert_eq!(m.count(), 8);
        assert_eq!(m.to_valid()[15], -1);
        assert_eq!(m.to_valid()[0], 0);
        let table = [10.0, 20.0, 30.0];
        let got = F32s::gather(&table, U32s(std::array::from_fn(|l| (l % 3) as u32)));
        assert_eq!(got.0[4], 20.0);
    }

    #[test]
    fn vectors_compute_what_glam_does() {
        let a = Vec3s::new(
            F32s(std::array::from_fn(|l| l as f32)),
            F32s::splat(2.0),
            F32s(std::array::from_fn(|l| -(l as f32))),
        );
        let b = Vec3s::splat(glam::Vec3::new(0.5, -1.0, 3.0));
        for l in 0..W {
            let (x, y) = (a.lane(l), b.lane(l));
            assert!((a.dot(b).0[l] - x.dot(y)).abs() < 1e-5);
        }
    }
}
