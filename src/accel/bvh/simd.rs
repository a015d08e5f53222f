//! The instruction set the any-hit traversal runs with, chosen once per tree at run
//! time: the same traversal code compiled a second time with AVX2 enabled, or as the
//! portable build (SSE2 on x86-64). The AVX2 any-hit traversal is 8-12% faster than its
//! portable build on the bunny, Sponza and the staircase; the AVX2 build of the
//! closest-hit traversal was 1-18% *slower* than its portable build (LLVM spreads the
//! triangle test's lanes over 256-bit registers and pays in permutes), so closest hits
//! always run the portable build. The binary stays portable
//! (no `target-cpu=native`), and both give the same hits: the code is the same, Rust
//! never contracts `a * b + c` into an FMA, and IEEE arithmetic rounds the same at any
//! vector width.
//!
//! The BVH's only `unsafe`: calling a `#[target_feature]` function, which is sound only
//! on a processor that has the feature.

use super::traverse::Stacks;
use super::Bvh;
use crate::accel::Ray;
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
        // SAFETY: `Isa::Avx2` is only made by `Isa::detect` after the processor
        // reported AVX2.
        Isa::Avx2 => unsafe { occluded_avx2(bvh, ray, filter, stacks) },
        _ => bvh.occluded_in(ray, filter, stacks),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn occluded_avx2<F: HitFilter>(bvh: &Bvh, ray: &Ray, filter: &F, stacks: &mut Stacks) -> bool {
    bvh.occluded_in(ray, filter, stacks)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::accel::{Accel, Hit};
    use crate::sampling::Rng;

    #[test]
    fn avx2_and_portable_traversal_agree_bit_for_bit() {
        if Isa::detect() == Isa::Portable {
            eprintln!("no AVX2 here: only the portable traversal runs");
            return;
        }
        // Small triangles in a cube, some twice with opposite windings, and rays from
        // inside and outside: hits, misses, and ties between triangles.
        let mut rng = Rng::seeded(12);
        let mut p = || Vec3::new(rng.f32(), rng.f32(), rng.f32());
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..20_000u32 {
            let c = p() * 10.0;
            vertices.extend([c, c + p() * 0.3, c + p() * 0.3]);
            triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
            if i % 7 == 0 {
                triangles.push([3 * i, 3 * i + 2, 3 * i + 1]);
            }
        }
        let avx2 = Bvh::build(&vertices, &triangles).unwrap();
        let mut portable = Bvh::build(&vertices, &triangles).unwrap();
        portable.isa = Isa::Portable;
        let bits =
            |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()));
        let mut hits = 0;
        for _ in 0..50_000 {
            let origin = p() * 14.0 - Vec3::splat(2.0);
            let dir = p() * 2.0 - Vec3::ONE;
            // Some segments stop short of every triangle.
            let ray = Ray::segment(origin, dir, 8.0 / dir.length().max(1e-3));
            let a = avx2.intersect(&ray);
            hits += usize::from(a.is_some());
            assert_eq!(bits(a), bits(portable.intersect(&ray)), "{ray:?}");
            assert_eq!(avx2.occluded(&ray), portable.occluded(&ray), "{ray:?}");
        }
        assert!(hits > 10_000, "too few hits to compare: {hits}");
    }
}
