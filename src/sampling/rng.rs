//! The random numbers of one camera sample: deterministic, keyed on (seed, pixel,
//! sample), and stratified across the samples of a pixel where that pays.
//!
//! The camera's draws (the position in the pixel) and those of the path's first vertex
//! (a light sample, a direction, a material choice) come from an Owen-scrambled Sobol
//! sequence (Burley, "Practical Hash-based Owen Scrambling", JCGT 2020, through the
//! `sobol_burley` crate): sample `i` of a pixel takes point `i` of that pixel's
//! sequence, so the samples of a pixel cover the pixel, the light and the hemisphere
//! far more evenly than independent draws and direct light converges faster than
//! 1/spp. Every point of an Owen-scrambled sequence is uniform on the unit cube, so
//! each sample on its own is still an unbiased estimate. The sequence is read in 4-D
//! sets, each with its own scramble ("padding"), because low Sobol dimensions are the
//! well-stratified ones. Deeper vertices, and samples past the sequence's 2^16
//! points, draw from a PCG stream: on the Cornell box stratifying the second and
//! third vertices too gained 1.5% in error for 12% more time.

use rand::RngCore;
use rand_pcg::Pcg32;

/// Stratified 4-D sets per camera sample: one for the position in the pixel, two for
/// the first vertex (a material coin, a light sample, a direction; usually only one
/// set is read, as sets are computed when first needed).
const STRATIFIED_SETS: u32 = 3;

/// Points in one Sobol sequence of `sobol_burley`.
const SOBOL_POINTS: u64 = 1 << 16;

/// The random stream of one camera sample. Every (seed, pixel, sample) triple gets its
/// own stream, so an image does not depend on how pixels are spread over threads.
#[derive(Clone)]
pub struct Rng {
    pcg: Pcg32,
    /// Stratified values not yet used, `strata[next..4]`.
    strata: [f32; 4],
    next: usize,
    /// The next 4-D set to read, and the first one past this vertex's sets.
    set: u32,
    set_end: u32,
    /// This pixel's sequence and this sample's point in it; `None` for plain streams.
    sobol: Option<SobolPoint>,
}

#[derive(Clone, Copy)]
struct SobolPoint {
    index: u32,
    scramble: u32,
}

/// SplitMix64's finaliser: spreads nearby keys over the whole 64-bit range.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Rng {
    /// An unstratified stream for sample `sample` of pixel `pixel` under `seed`.
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        let state = mix64(seed ^ mix64(pixel.wrapping_add(0x9e37_79b9_7f4a_7c15)));
        let stream = mix64(sample ^ mix64(seed.rotate_left(17)));
        Rng {
            pcg: Pcg32::new(state, stream),
            strata: [0.0; 4],
            next: 4,
            set: 0,
            set_end: 0,
            sobol: None,
        }
    }

    /// The stream of camera sample `sample` of pixel `pixel`: the camera's draws (the
    /// position in the pixel) and those of the first vertex are stratified over the
    /// pixel's samples; see the module notes. Call [`start_vertex`](Self::start_vertex)
    /// at each path vertex so that samples line up dimension by dimension.
    pub fn for_pixel_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        let mut rng = Self::for_sample(seed, pixel, sample);
        if sample < SOBOL_POINTS {
            rng.sobol = Some(SobolPoint {
                index: sample as u32,
                scramble: mix64(seed ^ mix64(pixel ^ 0x5ca1_ab1e)) as u32,
            });
            rng.set_end = STRATIFIED_SETS;
        }
        rng
    }

    /// Any stream from one 64-bit seed (tests, benchmarks).
    pub fn seeded(seed: u64) -> Self {
        Self::for_sample(seed, 0, 0)
    }

    /// Marks the start of the draws of path vertex `vertex` (1 = the camera ray's
    /// hit). The first vertex reads the stratified sets after the camera's, from a
    /// fresh set so that its first four draws (say, a light sample and a direction)
    /// are stratified jointly; later vertices draw independent numbers.
    #[inline]
    pub fn start_vertex(&mut self, vertex: u32) {
        if vertex > 1 {
            self.set_end = self.set;
        }
        self.next = 4;
    }

    /// Whether the next draw comes from the stratified sets (the camera's and the
    /// first vertex's), rather than the independent stream of later vertices.
    #[inline]
    pub fn stratified_ahead(&self) -> bool {
        self.next < 4 || self.set < self.set_end
    }

    /// Uniform in `[0, 1)`, a multiple of 2^-23.
    #[inline]
    pub fn f32(&mut self) -> f32 {
        if self.next < 4 {
            self.next += 1;
            return self.strata[self.next - 1];
        }
        if self.set < self.set_end {
            return self.refill();
        }
        // The top 23 bits of a 32-bit draw (1.0 is never returned), the resolution
        // of the stratified values, so that `refine` treats both alike.
        (self.pcg.next_u32() >> 9) as f32 * (1.0 / (1u32 << 23) as f32)
    }

    /// Reads the next stratified set and returns its first value.
    #[cold]
    fn refill(&mut self) -> f32 {
        let point = self.sobol.expect("sets are only open with a Sobol point");
        let scramble = mix64(u64::from(point.scramble) ^ (u64::from(self.set) << 32)) as u32;
        self.strata = sobol_burley::sample_4d(point.index, 0, scramble);
        self.set += 1;
        self.next = 1;
        self.strata[0]
    }

    /// Two uniforms in `[0, 1)` for one 2-D draw (a direction, a point on a
    /// triangle): both come from the same stratified set, so the pair is stratified
    /// jointly and not only each coordinate.
    #[inline]
    pub fn pair(&mut self) -> (f32, f32) {
        if self.next == 3 && self.set < self.set_end {
            self.next = 4;
        }
        (self.f32(), self.f32())
    }

    /// `coarse`, a draw of this stream (a multiple of 2^-23), refined by random bits
    /// within its cell: uniform in `[0, 1)` to the 53 bits an `f64` holds (23 coarse bits
    /// and 32 random ones below them, rounded to the mantissa), so that cutting it into
    /// millions of cells (an index, then a fraction) stays uniform.
    #[inline]
    pub fn refine(&mut self, coarse: f32) -> f64 {
        f64::from(coarse) + f64::from(self.pcg.next_u32()) * (1.0 / (1u64 << 55) as f64)
    }

    /// Uniform in `[0, 1)` to 53 bits.
    #[inline]
    pub fn f64(&mut self) -> f64 {
        let coarse = self.f32();
        self.refine(coarse)
    }

    /// Uniform in `[0, n)`; `n > 0`.
    #[inline]
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.f64() * f64::from(n)) as u32).min(n - 1)
    }
}
