//! The render loop: image tiles spread over rayon's workers, a deterministic random
//! stream per (pixel, sample, seed), and the summary a user sees at the end.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::Accel;
use crate::film::Film;
use crate::integrator::{IntegratorKind, PathTracer, RayCount};
use crate::sampling::Rng;
use crate::scene::{Camera, Scene};

/// Edge length of the square tiles the image is split into for the workers.
pub const TILE_SIZE: u32 = 16;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub seed: u64,
    pub integrator: IntegratorKind,
}

/// What a render cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    pub seconds: f64,
    pub samples: u64,
    pub rays: u64,
    /// Samples whose estimate was NaN or infinite, left out of their pixel's mean.
    pub dropped_samples: u64,
}

impl RenderStats {
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.seconds.max(1e-9)
    }

    pub fn mrays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-9) / 1e6
    }
}

/// One tile's pixels and counts, produced by one worker.
struct TileResult {
    x0: u32,
    y0: u32,
    width: u32,
    pixels: Vec<Vec3>,
    rays: u64,
    dropped: u64,
}

/// The tiles of a `width × height` image as (x0, y0, w, h), row by row.
pub fn tiles(width: u32, height: u32) -> Vec<(u32, u32, u32, u32)> {
    let mut tiles = Vec::new();
    for y0 in (0..height).step_by(TILE_SIZE as usize) {
        for x0 in (0..width).step_by(TILE_SIZE as usize) {
            tiles.push((
                x0,
                y0,
                TILE_SIZE.min(width - x0),
                TILE_SIZE.min(height - y0),
            ));
        }
    }
    tiles
}

/// Renders the image on the current rayon pool. `on_tile_done(pixels)` is called
/// after each tile, from whichever worker finished it (for progress bars).
pub fn render<A: Accel>(
    scene: &Scene,
    accel: &A,
    camera: &Camera,
    settings: &RenderSettings,
    on_tile_done: &(dyn Fn(u64) + Sync),
) -> (Film, RenderStats) {
    let start = Instant::now();
    let tracer = PathTracer::new(scene, accel, settings.max_depth, settings.integrator);
    let results: Vec<TileResult> = tiles(settings.width, settings.height)
        .into_par_iter()
        .map(|(x0, y0, w, h)| {
            let tile = render_tile(&tracer, camera, settings, (x0, y0, w, h));
            on_tile_done(u64::from(w * h));
            tile
        })
        .collect();

    let mut film = Film::new(settings.width, settings.height);
    let mut stats = RenderStats {
        samples: u64::from(settings.width) * u64::from(settings.height) * u64::from(settings.spp),
        ..RenderStats::default()
    };
    for tile in results {
        stats.rays += tile.rays;
        stats.dropped_samples += tile.dropped;
        for (i, p) in tile.pixels.iter().enumerate() {
            let (x, y) = (
                tile.x0 + i as u32 % tile.width,
                tile.y0 + i as u32 / tile.width,
            );
            film.pixels[(y * settings.width + x) as usize] = *p;
        }
    }
    stats.seconds = start.elapsed().as_secs_f64();
    (film, stats)
}

fn render_tile<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    settings: &RenderSettings,
    (x0, y0, w, h): (u32, u32, u32, u32),
) -> TileResult {
    let mut pixels = Vec::with_capacity((w * h) as usize);
    let mut count = RayCount::default();
    let mut dropped = 0;
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let pixel = u64::from(y) * u64::from(settings.width) + u64::from(x);
            let mut sum = Vec3::ZERO;
            let mut kept = 0u32;
            for sample in 0..settings.spp {
                let mut rng = Rng::for_sample(settings.seed, pixel, u64::from(sample));
                // Box filter: a uniform position inside the pixel.
                let ray = camera.ray(x as f32 + rng.f32(), y as f32 + rng.f32());
                let l = tracer.radiance(ray, &mut rng, &mut count);
                if l.is_finite() {
                    sum += l;
                    kept += 1;
                } else {
                    dropped += 1;
                }
            }
            pixels.push(if kept > 0 {
                sum / kept as f32
            } else {
                Vec3::ZERO
            });
        }
    }
    TileResult {
        x0,
        y0,
        width: w,
        pixels,
        rays: count.rays,
        dropped,
    }
}
