//! Adjoint-driven Russian roulette (after Vorba and Křivánek, "Adjoint-Driven Russian
//! Roulette and Splitting in Light Transport Simulation", 2016), for guided paths: a
//! path is cut where what it can still bring is small beside what its pixel gets.
//!
//! Ordinary roulette ([`ROULETTE_START_VERTEX`](super::ROULETTE_START_VERTEX)) looks at
//! the throughput alone, which says nothing about where the light is: in a room lit
//! through its windows, a path whose throughput is high may be bouncing behind the
//! sofa, and a dim one may be about to find the sunlit floor. The trained guide knows
//! roughly how much light arrives in every region (`SdTree::incident_at`), so a vertex
//! can estimate what the path will still add: its throughput, times its BSDF's albedo,
//! times the region's irradiance `∫ L |cos θ| dω` over π (the radiance a diffuse
//! surface reflects). The same estimate at the path's first non-delta vertex, plus the
//! light found before it, stands for the pixel's value. Where the ratio of the two
//! falls below [`DIM_RATIO`], the path goes on with probability [`DIM_SURVIVAL`] and
//! its weight is divided by it; elsewhere it goes on. The estimate only decides the
//! probability, and a surviving path is divided by it, so the image stays unbiased
//! however rough the estimate is. As the weight grows with each survival, so does the
//! estimate, and a path is halved only until it carries a sixth of its pixel again; but
//! where the guide saw next to no light the estimate stays near 0 whatever the weight,
//! so a path is halved at most [`MAX_HALVINGS`] times, and the ordinary roulette
//! decides after that. Without that bound, a rare firefly held much of a staircase
//! render's error (benches/results/2026-12-03-guiding-sittings-1-to-9.md).
//!
//! Training's iterations after the first play it too, with the tree of the iteration
//! before (a record divides what its path found by the path's throughput, so it stays
//! unbiased): fewer rays and no more error, a few per cent on every scene measured.
//!
//! Why a fixed survival probability, where Vorba and Křivánek survive with the ratio
//! over the window's centre: the guide's estimate is coarse (a region's average, over
//! directions and surfaces), and where it says dark wrongly, a survival of 0.05 makes
//! a path that finds light twenty times too bright; a fixed survival was the only
//! rule that helped on both the room and the staircase
//! (benches/results/2026-12-03-guiding-sittings-1-to-9.md).
//!
//! Why no splitting, the method's other half: splitting a path into `n` branches where
//! its estimate is above its pixel's (each branch its own stream and `1/n` of the
//! weight, at most 16 branches a camera sample) gained little on the room and nothing
//! elsewhere, for a path loop that recurses
//! (benches/results/2026-12-03-guiding-sittings-1-to-9.md).

use crate::color::channel_mean;

/// The ratio of a path's expected contribution from a vertex on to its pixel's
/// estimate below which roulette is played.
pub const DIM_RATIO: f32 = 1.0 / 6.0;

/// The probability that a path whose expected contribution is below [`DIM_RATIO`] of
/// its pixel's goes on: at most doubling its weight at each such vertex.
pub const DIM_SURVIVAL: f32 = 0.5;

/// The most times one path is halved by adjoint-driven roulette: its weight grows by
/// at most 8.
pub const MAX_HALVINGS: u32 = 3;

/// One path's adjoint-driven roulette: its pixel's estimate, once it has one, and the
/// times the path was halved.
#[derive(Clone, Copy, Debug, Default)]
pub struct AdjointRoulette {
    pixel: f32,
    halvings: u32,
}

impl AdjointRoulette {
    /// The probability that the path goes on from a non-delta vertex where it has
    /// found `found` so far (mean over channels) and expects `expected` more from
    /// here (see [`expected_from`]); `None` where the adjoint has nothing to go by
    /// (the path's regions learnt no light so far, or the expectation is not a
    /// finite number) or the path was halved [`MAX_HALVINGS`] times already, and the
    /// ordinary roulette decides. The first vertex with a positive expectation sets
    /// the pixel's estimate, `found + expected`, and goes on.
    #[inline]
    pub fn survival(&mut self, found: f32, expected: f32) -> Option<f32> {
        if !(expected >= 0.0 && expected.is_finite()) {
            None
        } else if self.pixel > 0.0 {
            if expected >= DIM_RATIO * self.pixel {
                Some(1.0)
            } else if self.halvings < MAX_HALVINGS {
                self.halvings += 1;
                Some(DIM_SURVIVAL)
            } else {
                None
            }
        } else if expected > 0.0 {
            self.pixel = found + expected;
            Some(1.0)
        } else {
            None
        }
    }
}

/// What a path of throughput `throughput` at a vertex whose BSDF reflects `albedo` is
/// expected to add from there on (mean over channels), where the vertex's region
/// learnt the estimate `incident` of its irradiance `∫ L |cos θ| dω`: the radiance a
/// diffuse surface of that albedo reflects, `albedo · incident / π`, times the
/// throughput.
#[inline]
pub fn expected_from(throughput: glam::Vec3, albedo: glam::Vec3, incident: f32) -> f32 {
    channel_mean(throughput * albedo) * incident * std::f32::consts::FRAC_1_PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn the_first_vertex_sets_the_pixel_and_dim_ones_are_halved() {
        let mut roulette = AdjointRoulette::default();
        // Nothing known yet: the ordinary roulette decides, and no estimate is set.
        assert_eq!(roulette.survival(0.3, 0.0), None);
        assert_eq!(roulette.survival(0.3, f32::NAN), None);
        assert_eq!(roulette.survival(0.05, 0.01), Some(1.0));
        // The pixel is 0.06 now: a sixth of it is 0.01.
        assert_eq!(roulette.survival(0.0, 0.0101), Some(1.0));
        assert_eq!(roulette.survival(5.0, 0.0099), Some(DIM_SURVIVAL));
        assert_eq!(roulette.survival(0.0, 0.0), Some(DIM_SURVIVAL));
        assert_eq!(roulette.survival(0.0, f32::INFINITY), None);
        assert_eq!(roulette.survival(0.0, f32::NAN), None);
        assert_eq!(roulette.survival(0.0, 1e9), Some(1.0));
        // Halved twice; a third time, and then the ordinary roulette decides.
        assert_eq!(MAX_HALVINGS, 3);
        assert_eq!(roulette.survival(0.0, 0.001), Some(DIM_SURVIVAL));
        assert_eq!(roulette.survival(0.0, 0.02), Some(1.0));
        assert_eq!(roulette.survival(0.0, 0.001), None);
        assert_eq!(roulette.survival(0.0, 0.02), Some(1.0));
    }

    #[test]
    fn the_expectation_is_a_diffuse_surfaces_reflection() {
        // Radiance 2 from every direction of the upper hemisphere: ∫ L cos dω = 2π,
        // and a white diffuse surface reflects 2 (that over π), which at throughput ½
        // in one channel of three is a mean of 1/3.
        let incident = 2.0 * std::f32::consts::PI;
        let e = expected_from(Vec3::new(0.5, 0.0, 0.0), Vec3::ONE, incident);
        assert!((e - 1.0 / 3.0).abs() < 1e-6, "{e}");
    }
}
