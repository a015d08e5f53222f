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
//! `multiversion` compiles the function twice and picks the AVX2 build at run time
//! when the processor has AVX2 (its feature check is cached by the standard library);
//! the crate holds the `unsafe` of calling a `#[target_feature]` function, so ember
//! keeps its own `unsafe` in `src/embree/`.

use multiversion::multiversion;

use super::traverse::Stacks;
use super::Bvh;
use crate::accel::Ray;
use crate::geometry::HitFilter;

/// The instruction set a tree's any-hit traversal uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// The best this processor runs: AVX2 where it has it.
    Best,
    /// The baseline of the target the binary was built for.
    Portable,
}

impl Isa {
    /// [`Isa::Best`], unless `EMBER_BVH_PORTABLE` is set in the environment, which
    /// picks the portable code, to compare the two.
    pub fn detect() -> Isa {
        if std::env::var_os("EMBER_BVH_PORTABLE").is_some() {
            Isa::Portable
        } else {
            Isa::Best
        }
    }

    /// Whether [`Isa::Best`] is more than the portable build here.
    #[cfg(test)]
    pub fn has_avx2() -> bool {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return true;
        }
        false
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
        Isa::Best => occluded_best(bvh, ray, filter, stacks),
        Isa::Portable => bvh.occluded_in(ray, filter, stacks),
    }
}

#[multiversion(targets("x86_64+avx2"))]
fn occluded_best<F: HitFilter>(bvh: &Bvh, ray: &Ray, filter: &F, stacks: &mut Stacks) -> bool {
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
        if !Isa::has_avx2() || Isa::detect() == Isa::Portable {
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
