//! The instruction set traversal runs with, chosen once per tree at run time: the same
//! traversal code compiled a second time with AVX2 enabled (8-wide node tests in one
//! instruction), or as the portable build (SSE2 on x86-64). The binary stays portable
//! (no `target-cpu=native`), and both give the same hits: the code is the same, Rust
//! never contracts `a * b + c` into an FMA, and IEEE arithmetic rounds the same at any
//! vector width.
//!
//! The BVH's only `unsafe`: calling a `#[target_feature]` function, which is sound only
//! on a processor that has the feature.

use super::traverse::Stacks;
use super::Bvh;
use crate::accel::{Hit, Ray};
use crate::geometry::HitFilter;

/// The instruction set a tree's traversal uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// x86-64 with AVX2; only ever made by [`Isa::detect`] on a processor that has it.
    Avx2,
    /// The baseline of the target the binary was built for.
    Portable,
}

impl Isa {
    /// The best instruction set this processor runs. Setting `EMBER_BVH_PORTABLE` in
    /// the environment picks the portable code, to compare the two.
    pub fn detect() -> Isa {
        if std::env::var_os("EMBER_BVH_PORTABLE").is_some() {
            return Isa::Portable;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Isa::Avx2;
        }
        Isa::Portable
    }
}

/// [`Bvh::intersect_in`] with the instruction set `isa`.
#[inline(always)]
pub fn intersect<F: HitFilter>(
    isa: Isa,
    bvh: &Bvh,
    ray: &Ray,
    filter: &F,
    stacks: &mut Stacks,
) -> Option<Hit> {
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Isa::Avx2` is only made by `Isa::detect` after the processor
        // reported AVX2.
        Isa::Avx2 => unsafe { intersect_avx2(bvh, ray, filter, stacks) },
        _ => bvh.intersect_in(ray, filter, stacks),
    }
}

/// [`Bvh::occluded_in`] with the instruction set `isa`.
#[inline(always)]
pub fn occluded<F: HitFilter>(
    isa: Isa,
    bvh: &Bvh,
    ray: &Ray,
    filter: &F,
    stacks: &mut Stacks,
) -> bool {
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as in `intersect`, the processor reported AVX2.
        Isa::Avx2 => unsafe { occluded_avx2(bvh, ray, filter, stacks) },
        _ => bvh.occluded_in(ray, filter, stacks),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn intersect_avx2<F: HitFilter>(
    bvh: &Bvh,
    ray: &Ray,
    filter: &F,
    stacks: &mut Stacks,
) -> Option<Hit> {
    bvh.intersect_in(ray, filter, stacks)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn occluded_avx2<F: HitFilter>(bvh: &Bvh, ray: &Ray, filter: &F, stacks: &mut Stacks) -> bool {
    bvh.occluded_in(ray, filter, stacks)
}
