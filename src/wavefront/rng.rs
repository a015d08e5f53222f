//! The random numbers of a block of paths, one stream per lane, keyed like the scalar
//! loop's on (seed, pixel, sample): the camera's draws and the first vertex's come from
//! the pixel's Owen-scrambled Sobol sequence (as [`crate::sampling::Rng`] reads it, set
//! by set), later vertices from a PCG32 stream per lane, stepped in lanes.

use super::lanes::{map, F32s, U32s, W};
use crate::sampling::mix64;

/// PCG32's multiplier (O'Neill's 64-bit LCG constant).
const PCG_MULTIPLIER: u64 = 6_364_136_223_846_793_005;

/// Points of a pixel's sequences: samples past them draw from their PCG streams.
const SOBOL_POINTS: u32 = 1 << 16;

/// One PCG32 generator per lane (XSH-RR output of a 64-bit LCG), numerically the
/// `rand_pcg::Pcg32` the scalar loop uses.
#[derive(Clone, Copy, Debug)]
pub struct Pcg32s {
    state: [u64; W],
    increment: [u64; W],
}

impl Default for Pcg32s {
    fn default() -> Self {
        Pcg32s {
            state: [0; W],
            increment: [1; W],
        }
    }
}

impl Pcg32s {
    /// Lane `l` becomes `Pcg32::new(state, stream)`.
    #[inline(always)]
    pub fn seed_lane(&mut self, l: usize, state: u64, stream: u64) {
        self.increment[l] = (stream << 1) | 1;
        self.state[l] = state
            .wrapping_add(self.increment[l])
            .wrapping_mul(PCG_MULTIPLIER)
            .wrapping_add(self.increment[l]);
    }

    /// Every lane becomes the stream of its camera sample (pixel `pixels[l]`, sample
    /// `samples[l]`) under `seed`, as [`crate::sampling::Rng::for_sample`] keys it: one
    /// loop over the lanes, so that the hashing is done in vector registers.
    #[inline(always)]
    pub fn seed_samples(&mut self, seed: u64, pixels: &[u64; W], samples: &[u64; W]) {
        let stream_key = mix64(seed.rotate_left(17));
        for l in 0..W {
            let state = mix64(seed ^ mix64(pixels[l].wrapping_add(0x9e37_79b9_7f4a_7c15)));
            let stream = mix64(samples[l] ^ stream_key);
            self.seed_lane(l, state, stream);
        }
    }

    /// Lane `l` becomes lane `k` of `from`.
    pub fn take_lane(&mut self, l: usize, from: &Pcg32s, k: usize) {
        self.state[l] = from.state[k];
        self.increment[l] = from.increment[k];
    }

    /// The next 32 random bits of every lane.
    #[inline(always)]
    pub fn next_u32(&mut self) -> U32s {
        let mut out = [0u32; W];
        for l in 0..W {
            let old = self.state[l];
            self.state[l] = old
                .wrapping_mul(PCG_MULTIPLIER)
                .wrapping_add(self.increment[l]);
            let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
            out[l] = xorshifted.rotate_right((old >> 59) as u32);
        }
        U32s(out)
    }

    /// Uniform in `[0, 1)` per lane, a multiple of 2^-23 (the scalar loop's
    /// resolution).
    #[inline(always)]
    pub fn f32(&mut self) -> F32s {
        let bits = self.next_u32();
        let mut out = [0.0f32; W];
        for l in 0..W {
            out[l] = (bits.0[l] >> 9) as f32 * (1.0 / (1u32 << 23) as f32);
        }
        F32s(out)
    }
}

/// Where each lane's sample lies in its pixel's Sobol sequence: the stratified 2-D
/// draws of the camera and the first vertex.
///
/// Each draw is its own Owen-scrambled (0, 2)-sequence in base 2, the first two Sobol
/// dimensions (Burley, "Practical Hash-based Owen Scrambling", JCGT 2020): the
/// sample index is shuffled and each coordinate scrambled by hashes of the pixel's key
/// and the draw, so that the draws of a sample are independent of each other (padding)
/// while the samples of a pixel cover each draw's square evenly: the first `2^m`
/// samples of a pixel put exactly one point in every dyadic box of area `2^-m`.
#[derive(Clone, Copy, Debug, Default)]
pub struct SobolLanes {
    /// The sample's point; [`SOBOL_POINTS`] or more: none (the sample is past the
    /// sequence and draws from its PCG stream).
    index: [u32; W],
    key: [u32; W],
}

/// The stratified draws of a camera sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Draw {
    /// The point in the pixel.
    Camera = 0,
    /// The first vertex's light sample.
    Light = 1,
    /// The first vertex's BSDF sample.
    Bsdf = 2,
}

impl SobolLanes {
    /// Every lane reads point `samples[l]` of the sequences of pixel `pixels[l]` under
    /// `seed`.
    #[inline(always)]
    pub fn seed_samples(&mut self, seed: u64, pixels: &[u64; W], samples: &[u64; W]) {
        for l in 0..W {
            self.index[l] = samples[l].min(u64::from(u32::MAX)) as u32;
            self.key[l] = mix64(seed ^ mix64(pixels[l] ^ 0x5ca1_ab1e)) as u32;
        }
    }

    /// Every lane's 2-D draw `draw`, in `[0, 1)²`. A lane past its sequence takes two
    /// draws of its PCG stream instead, which `pcg` advances for those lanes only.
    #[inline(always)]
    pub fn pair(&self, draw: Draw, pcg: &mut Pcg32s) -> [F32s; 2] {
        let index = U32s(self.index);
        let salt = 3 * draw as u32;
        let key = |k: u32| U32s(map(self.key, |key| hash32(key ^ hash32(salt + k))));
        let (shuffle, scramble_x, scramble_y) = (key(0), key(1), key(2));
        // The point's index, Owen-scrambled within the first 2^16 (a permutation
        // of the sequence that keeps its dyadic strata).
        let shuffled = reverse_bits(laine_karras(reverse_bits(index), shuffle)) & 0xffff;
        // Both coordinates in bit-reversed form, where Owen scrambling is a hash.
        let x = laine_karras(shuffled, scramble_x);
        let y = laine_karras(sobol_1_reversed(shuffled), scramble_y);
        let mut out = [to_unit(reverse_bits(x)), to_unit(reverse_bits(y))];
        for l in 0..W {
            if self.index[l] >= SOBOL_POINTS {
                out[0].0[l] = pcg_lane_f32(pcg, l);
                out[1].0[l] = pcg_lane_f32(pcg, l);
            }
        }
        out
    }
}

/// The second Sobol dimension's direction numbers (primitive polynomial `x + 1`), bit
/// reversed: index bit `b` toggles `SOBOL_1_REVERSED[b]` of the reversed coordinate.
const SOBOL_1_REVERSED: [u32; 16] = {
    let mut v = [0u32; 16];
    let mut direction = 1u32 << 31;
    let mut b = 0;
    while b < 16 {
        v[b] = direction.reverse_bits();
        direction ^= direction >> 1;
        b += 1;
    }
    v
};

/// The second Sobol dimension of 16-bit indices, bit reversed (the first is the index
/// itself, reversed twice).
#[inline(always)]
fn sobol_1_reversed(index: U32s) -> U32s {
    let mut out = [0u32; W];
    for (b, direction) in SOBOL_1_REVERSED.iter().enumerate() {
        for l in 0..W {
            out[l] ^= direction & 0u32.wrapping_sub((index.0[l] >> b) & 1);
        }
    }
    U32s(out)
}

/// Laine and Karras's hash as Burley gives it: a permutation of 32-bit words in which
/// each bit is flipped by a function of the bits below it, so that applied to a
/// reversed coordinate it is a nested uniform (Owen) scramble.
#[inline(always)]
fn laine_karras(x: U32s, seed: U32s) -> U32s {
    let mut out = [0u32; W];
    for l in 0..W {
        let mut v = x.0[l].wrapping_add(seed.0[l]);
        v ^= v.wrapping_mul(0x6c50_b47c);
        v ^= v.wrapping_mul(0xb82f_1e52);
        v ^= v.wrapping_mul(0xc7af_e638);
        v ^= v.wrapping_mul(0x8d22_f6e6);
        out[l] = v;
    }
    U32s(out)
}

#[inline(always)]
fn reverse_bits(x: U32s) -> U32s {
    U32s(map(x.0, u32::reverse_bits))
}

/// A 32-bit fixed-point fraction as `f32` in `[0, 1)` (its top 24 bits).
#[inline(always)]
fn to_unit(x: U32s) -> F32s {
    F32s(map(x.0, |v| (v >> 8) as f32 * (1.0 / (1u32 << 24) as f32)))
}

/// A 32-bit integer hash with good avalanche (Wellons's `lowbias32`).
#[inline(always)]
fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// One draw of lane `l`'s stream alone.
fn pcg_lane_f32(pcg: &mut Pcg32s, l: usize) -> f32 {
    let old = pcg.state[l];
    pcg.state[l] = old
        .wrapping_mul(PCG_MULTIPLIER)
        .wrapping_add(pcg.increment[l]);
    let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
    (xorshifted.rotate_right((old >> 59) as u32) >> 9) as f32 * (1.0 / (1u32 << 23) as f32)
}

impl std::ops::BitAnd<u32> for U32s {
    type Output = U32s;
    #[inline(always)]
    fn bitand(self, mask: u32) -> U32s {
        U32s(map(self.0, |x| x & mask))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngCore;
    use rand_pcg::Pcg32;

    /// Every lane is O'Neill's PCG32, bit for bit as `rand_pcg` implements it.
    #[test]
    fn lanes_are_pcg32() {
        let mut lanes = Pcg32s::default();
        let mut reference: Vec<Pcg32> = (0..W)
            .map(|l| {
                let (state, stream) = (mix64(l as u64), mix64(100 + l as u64));
                lanes.seed_lane(l, state, stream);
                Pcg32::new(state, stream)
            })
            .collect();
        for _ in 0..100 {
            let got = lanes.next_u32();
            for (l, r) in reference.iter_mut().enumerate() {
                assert_eq!(got.0[l], r.next_u32());
            }
        }
    }

    /// Lanes keyed by (seed, pixel, sample) draw the scalar loop's unstratified
    /// stream of the same camera sample, number for number.
    #[test]
    fn lanes_are_keyed_as_the_scalar_streams() {
        let mut pcg = Pcg32s::default();
        let pixels = std::array::from_fn(|l| 1000 + 7 * l as u64);
        let samples = std::array::from_fn(|l| (l * l) as u64);
        pcg.seed_samples(42, &pixels, &samples);
        let mut scalar: Vec<_> = (0..W)
            .map(|l| crate::sampling::Rng::for_sample(42, pixels[l], samples[l]))
            .collect();
        for _ in 0..20 {
            let lanes = pcg.f32();
            for (l, rng) in scalar.iter_mut().enumerate() {
                assert_eq!(lanes.0[l], rng.f32());
            }
        }
    }

    /// The first `2^m` samples of a pixel, for every `m` up to 10, put exactly one
    /// point of each draw in every dyadic box of area `2^-m` (the (0, m, 2)-net
    /// property, which Owen scrambling and the index shuffle preserve).
    #[test]
    fn each_draw_stratifies_the_samples_of_a_pixel() {
        for (seed, pixel) in [(0, 0), (7, 12_345), (u64::MAX, 99)] {
            for draw in [Draw::Camera, Draw::Light, Draw::Bsdf] {
                let points = draw_points(seed, pixel, draw, 1 << 10);
                for m in 0..=10 {
                    assert_is_net(&points[..1 << m], m);
                }
            }
        }
    }

    /// The sequences change with the pixel and the draw.
    #[test]
    fn draws_differ_by_pixel_and_by_draw() {
        let a = draw_points(1, 5, Draw::Light, 16);
        assert_ne!(a, draw_points(1, 6, Draw::Light, 16));
        assert_ne!(a, draw_points(1, 5, Draw::Bsdf, 16));
        assert_ne!(a, draw_points(2, 5, Draw::Light, 16));
    }

    fn draw_points(seed: u64, pixel: u64, draw: Draw, n: usize) -> Vec<(f32, f32)> {
        let mut pcg = Pcg32s::default();
        let mut points = Vec::new();
        for first in (0..n).step_by(W) {
            let mut sobol = SobolLanes::default();
            let samples = std::array::from_fn(|l| (first + l) as u64);
            sobol.seed_samples(seed, &[pixel; W], &samples);
            let [x, y] = sobol.pair(draw, &mut pcg);
            points.extend((0..W).map(|l| (x.0[l], y.0[l])));
        }
        points.truncate(n);
        points
    }

    fn assert_is_net(points: &[(f32, f32)], m: u32) {
        for k in 0..=m {
            let (cols, rows) = (1usize << k, 1usize << (m - k));
            let mut count = vec![0u32; cols * rows];
            for &(x, y) in points {
                assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                let (c, r) = ((x * cols as f32) as usize, (y * rows as f32) as usize);
                count[r * cols + c] += 1;
            }
            assert!(count.iter().all(|&c| c == 1), "m {m}, boxes {cols}x{rows}");
        }
    }

    /// Past the sequence's 2^16 points, a sample's draws come from its PCG stream.
    #[test]
    fn samples_past_the_sequence_draw_from_their_stream() {
        let mut sobol = SobolLanes::default();
        let mut pcg = Pcg32s::default();
        let mut reference = Pcg32s::default();
        let past = std::array::from_fn(|l| u64::from(SOBOL_POINTS) + l as u64);
        let own = std::array::from_fn(|l| l as u64);
        sobol.seed_samples(3, &[4; W], &past);
        pcg.seed_samples(3, &[4; W], &own);
        reference.seed_samples(3, &[4; W], &own);
        let [x, y] = sobol.pair(Draw::Camera, &mut pcg);
        assert_eq!(x, reference.f32());
        assert_eq!(y, reference.f32());
    }

    /// Uniform: a chi-square test of 64 bins over 2^18 draws of all lanes.
    #[test]
    fn lane_draws_are_uniform() {
        let mut pcg = Pcg32s::default();
        pcg.seed_samples(3, &std::array::from_fn(|l| l as u64), &[0; W]);
        let bins = 64;
        let mut counts = vec![0u64; bins];
        let rounds = (1 << 18) / W;
        for _ in 0..rounds {
            for u in pcg.f32().0 {
                assert!((0.0..1.0).contains(&u));
                counts[(u * bins as f32) as usize] += 1;
            }
        }
        let expected = (rounds * W) as f64 / bins as f64;
        let chi2: f64 = counts
            .iter()
            .map(|&c| (c as f64 - expected).powi(2) / expected)
            .sum();
        // 63 degrees of freedom: the 99.9th percentile is 103.4.
        assert!(chi2 < 103.4, "chi-square {chi2}");
    }
}
