//! A small, fast, deterministic random number generator keyed on (seed, pixel, sample).

use rand::RngCore;
use rand_pcg::Pcg32;

/// The random stream of one camera sample. Every (seed, pixel, sample) triple gets its
/// own stream, so an image does not depend on how pixels are spread over threads.
pub struct Rng(Pcg32);

/// SplitMix64's finaliser: spreads nearby keys over the whole 64-bit range.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Rng {
    /// The stream for sample `sample` of pixel `pixel` under `seed`.
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        let state = mix64(seed ^ mix64(pixel.wrapping_add(0x9e37_79b9_7f4a_7c15)));
        let stream = mix64(sample ^ mix64(seed.rotate_left(17)));
        Rng(Pcg32::new(state, stream))
    }

    /// Any stream from one 64-bit seed (tests, benchmarks).
    pub fn seeded(seed: u64) -> Self {
        Self::for_sample(seed, 0, 0)
    }

    /// Uniform in `[0, 1)`: the top 24 bits of a 32-bit draw, so 1.0 is never returned.
    #[inline]
    pub fn f32(&mut self) -> f32 {
        (self.0.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform in `[0, n)`; `n > 0`.
    #[inline]
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.0.next_u32() as u64 * n as u64) >> 32) as u32
    }
}
