//! Path guiding after Müller, Gross and Novák, "Practical Path Guiding for Efficient
//! Light-Transport Simulation" (2017): an SD-tree, a binary tree over space whose
//! leaves are quadtrees over directions ([`SdTree`], [`QuadTree`]), learnt from the
//! radiance the path tracer itself finds, and sampled beside the BSDF.
//!
//! - Training ([`crate::render`]'s pre-pass): iteration `k` renders `2^k` samples per
//!   pixel guided by the tree of iteration `k − 1` (the first by the uniform tree), and
//!   every non-delta vertex of its paths deposits the incident radiance it found
//!   (times the cosine at the vertex, divided by the density of its direction; of an
//!   emitter's direct light, only as much as the region's light samples miss it:
//!   [`SdTree::deposit`]) into a cleared copy; that copy,
//!   refined ([`SdTree::refined`]), is the next tree. The records are folded in tile
//!   order, so the tree does not depend on the number of threads.
//!   Records are spread by Müller et al.'s box filters: in space as they do it, to
//!   the region at a point jittered within a box the size of the record's region
//!   (the jitter a hash of the record, so the tree stays a function of the records
//!   and their order), and over the neighbouring cells of that region's quadtree (a
//!   square the size of the record's cell) exactly.
//! - Sampling (at every non-delta vertex a path scatters from, in every integrator): a
//!   one-sample mixture of the integrator's own strategy (the BSDF's sampling; for
//!   `mixture`, the book's mixture of BSDF and lights) and the guide's
//!   ([`VertexGuide`]: the region's distribution
//!   folded onto the hemisphere the BSDF reflects into), drawing from the guide with
//!   the region's learnt selection probability ([`SdTree::refined`]); the mixture's
//!   density is what the path's weight divides by and (in `mis`) what multiple
//!   importance sampling weighs against next-event estimation. The other half keeps the density
//!   positive wherever the integrand is, so the estimate stays unbiased whatever the
//!   guide learnt. A guided vertex's sky light samples draw likewise from a mixture
//!   of the sky's own sampling and a second quadtree of the region, of the sky it
//!   sees directly (learnt from the sky that light samples and scattered rays found,
//!   [`Record::sky`]), rather than of all the light arriving.
//! - Determinism: the training uses its own fixed seeds and schedule, and every render
//!   (fresh, resumed, or any shard of one) trains the same tree before rendering, so
//!   guiding is a function of the scene and the settings, which the render identity
//!   carries.

mod quadtree;
mod record;
mod sdtree;
mod vertex;

pub use quadtree::{
    cosine_mass_in_cone, direction_to_square, mass_in_cone, square_to_direction, QuadTree,
    SquareCell, MAX_QUAD_DEPTH, SUBDIVISION_SHARE,
};
pub use record::{
    Draw, GuidedDraw, LightFound, MixtureDraw, MixtureTerms, NoRecords, PathRecorder, PathRecords,
    Record, Shadow,
};
pub use sdtree::{
    split_threshold, SdTree, GUIDED_COST, MAX_SPATIAL_NODES, MIN_LIT_DRAWS, MIN_SELECTION_DRAWS,
    MIN_SHADOW_TESTS, RECORDS_PER_VERTEX, SELECTION_CHOICES, SKY_SHARE_CHOICES,
    SPLIT_RECORDS_PER_SQRT_SPP, SPLIT_REFERENCE_PIXELS,
};
pub use vertex::VertexGuide;

/// Probability of drawing a direction from the guide rather than the BSDF where a
/// region has too few draws to learn its own: ½ as in Müller et al. 2017, so that the
/// path weight `f·cos / (½ p_bsdf + ½ p_guide)` is at most twice the BSDF's own. The
/// untrained tree draws nothing from its guide (uniform, it is worse than the BSDF's
/// own sampling): the first iteration renders as unguided `mis` does, while its
/// draws still measure what a guide would have done.
pub const GUIDE_PROBABILITY: f32 = 0.5;

/// How a render is guided: the number of training iterations (iteration `k` takes
/// `2^k` samples per pixel, so `2^iterations − 1` in all), at most [`MAX_ITERATIONS`];
/// [`Guiding::for_spp`] chooses it where the user does not.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Guiding {
    pub iterations: u32,
}

/// Training iterations beyond this are not run (1023 spp of training, the last
/// iteration at 512): the records of one tile of the last iteration stay under 60 MB.
pub const MAX_ITERATIONS: u32 = 10;

impl Guiding {
    /// The training for a render of `spp` samples per pixel when none is asked for:
    /// the most iterations whose samples are at most an eighth of the render's
    /// (`8 · (2^N − 1) ≤ spp`), at least one: 3 at 64 spp, 5 at 256, 7 at 1024. A
    /// training sample costs about twice a rendered one, and the guide learnt from
    /// more of them pays less than it costs: three iterations beat five on the room at
    /// 64 spp (benches/results/2026-12-02-guiding-sd-tree-1-to-8.md).
    pub fn for_spp(spp: u32) -> Guiding {
        let fits = |n: u32| 8 * ((1u64 << n) - 1) <= u64::from(spp);
        let iterations = (1..=MAX_ITERATIONS).take_while(|&n| fits(n)).last();
        Guiding {
            iterations: iterations.unwrap_or(1),
        }
    }
}

/// What training cost and what it built.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GuidingStats {
    pub seconds: f64,
    /// Samples training took over the whole image.
    pub training_samples: u64,
    /// Of them, those the render's film took (see `render::training`).
    pub film_samples: u64,
    pub leaves: usize,
    /// Of them, the regions that guide (see [`VertexGuide::guides`]).
    pub guided_leaves: usize,
    pub nodes: usize,
    pub memory_bytes: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_training_is_at_most_an_eighth_of_the_samples() {
        for (spp, n) in [
            (1, 1),
            (15, 1),
            (16, 1),
            (24, 2),
            (63, 3),
            (64, 3),
            (120, 4),
        ] {
            assert_eq!(Guiding::for_spp(spp).iterations, n, "{spp} spp");
        }
        for (spp, n) in [(255, 5), (256, 5), (1024, 7), (crate::limits::MAX_SPP, 10)] {
            assert_eq!(Guiding::for_spp(spp).iterations, n, "{spp} spp");
        }
        for spp in 8..5000 {
            let n = Guiding::for_spp(spp).iterations;
            let training = |n: u32| 8 * ((1u32 << n) - 1);
            assert!(training(n) <= spp && (n == MAX_ITERATIONS || training(n + 1) > spp));
        }
    }
}
