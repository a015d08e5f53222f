//! The wavefront engine: paths traced [`W`] at a time, their state in lanes from the
//! camera ray to the film, the rays of a bounce queried as one Embree packet.
//!
//! A tile's camera samples are cut into blocks of [`W`] consecutive samples (the
//! samples of one pixel, or a row of pixels), which [`path`] traces together; each
//! finished sample's radiance is kept in its slot and added to its pixel in sample
//! order, so the film is the same however the blocks ran. The stages are compiled
//! once per instruction set and chosen at run time ([`trace_blocks`]).
//!
//! This is the first stage of the engine: it renders what the Cornell box needs
//! (untextured Lambert, triangle emitters, a pinhole or orthographic camera, `mis`) and says what else a
//! scene has that it does not render yet ([`LaneScene::new`]).

// Lane loops index several arrays by the same lane; iterator chains would hide the
// lane structure the vectoriser and the reader both need.
#![allow(clippy::needless_range_loop)]

mod lanes;
mod math;
mod path;
mod rng;
mod scene;

pub use lanes::W;
pub use math::{sincos_turns, SINCOS_MAX_ERROR};
pub use scene::LaneScene;

use glam::Vec3;
use multiversion::multiversion;

use crate::accel::Accel;
use crate::film::{FilmTile, Sample};
use crate::scene::CameraFrame;
use path::CameraSample;

/// What the engine renders with: the scene's lanes, the accelerator, the camera.
#[derive(Clone, Copy, Debug)]
pub struct Wavefront<'a, A: Accel> {
    pub scene: &'a LaneScene,
    pub accel: &'a A,
    pub camera: CameraFrame,
    pub image_width: u32,
    pub max_depth: u32,
    pub seed: u64,
}

impl<A: Accel> Wavefront<'_, A> {
    /// Takes every pixel of `tile` still going to `target` samples, the film's sample
    /// indices starting at `first`. Returns the rays traced and the samples taken and
    /// dropped (not finite).
    pub fn render_tile(&self, tile: &mut FilmTile, first: u32, target: u32) -> TileCost {
        let work = samples_of(tile, first, target);
        let mut radiance = vec![Vec3::ZERO; work.len()];
        let rays = trace_samples(self, &work, &mut radiance);
        let mut cost = TileCost {
            rays,
            taken: radiance.len() as u64,
            dropped: 0,
        };
        // The slots are the samples in pixel order, each pixel's in sample order: the
        // order the scalar loop adds them in.
        let mut slots = radiance.into_iter();
        for p in tile.pixels.iter_mut().filter(|p| !p.converged) {
            for radiance in slots.by_ref().take((target - p.done.min(target)) as usize) {
                let sample = Sample {
                    radiance,
                    ..Sample::default()
                };
                if !p.add(&sample) {
                    cost.dropped += 1;
                }
            }
        }
        cost
    }
}

/// What a tile cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TileCost {
    pub rays: u64,
    pub taken: u64,
    pub dropped: u64,
}

/// The tile's camera samples still to take, in pixel order and each pixel's in sample
/// order.
fn samples_of(tile: &FilmTile, first: u32, target: u32) -> Vec<CameraSample> {
    let (x0, y0, w, _) = tile.rect;
    let mut samples = Vec::new();
    for (i, p) in tile.pixels.iter().enumerate() {
        if p.converged {
            continue;
        }
        let (x, y) = (x0 + i as u32 % w, y0 + i as u32 / w);
        samples.extend((p.done..target).map(|done| CameraSample {
            x,
            y,
            sample: first + done,
        }));
    }
    samples
}

/// Traces every camera sample of `work`, its radiance into the same place of `out`;
/// the rays traced. Compiled for AVX-512, AVX2 and the baseline, the best the processor
/// runs chosen at run time: every lane operation of the stages is inlined here and
/// vectorised by the compiler for that instruction set. The results are the same on
/// each, since Rust never fuses a multiply and an add and IEEE arithmetic rounds alike
/// at any width.
#[multiversion(targets(
    "x86_64+avx512f+avx512vl+avx512dq+avx512bw+avx512cd+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+sse4.1"
))]
fn trace_samples<A: Accel>(
    engine: &Wavefront<'_, A>,
    work: &[CameraSample],
    out: &mut [Vec3],
) -> u64 {
    engine.trace(work, out)
}
