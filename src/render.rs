//! The render loop: image tiles spread over rayon's workers, a deterministic random
//! stream per (pixel, sample, seed), and the summary a user sees at the end.
//!
//! Rendering is progressive: passes over all tiles add samples to per-pixel sums, so a
//! render can be stopped (Ctrl-C), snapshotted (checkpoints) and resumed, and the
//! result equals an uninterrupted render bit for bit.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use glam::DVec3;
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

/// The running state of a progressive render, per pixel: the sum of the finite sample
/// estimates (in `f64`, added in sample order), how many of them were finite, and how
/// many samples were taken. Sample `i` of a pixel always uses the random stream
/// `(seed, pixel, i)` and is added after samples `0..i`, so however a render is split
/// into passes, interrupted and resumed, the sums are bit for bit the same.
#[derive(Clone, Debug, PartialEq)]
pub struct Progress {
    pub width: u32,
    pub height: u32,
    pub sums: Vec<DVec3>,
    pub kept: Vec<u32>,
    pub done: Vec<u32>,
}

impl Progress {
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Progress {
            width,
            height,
            sums: vec![DVec3::ZERO; n],
            kept: vec![0; n],
            done: vec![0; n],
        }
    }

    /// Fewest samples any pixel has.
    pub fn min_done(&self) -> u32 {
        self.done.iter().copied().min().unwrap_or(0)
    }

    /// Samples taken over the whole image.
    pub fn total_done(&self) -> u64 {
        self.done.iter().map(|&d| u64::from(d)).sum()
    }

    /// The image so far: each pixel the mean of its finite samples (black without any).
    pub fn film(&self) -> Film {
        let mut film = Film::new(self.width, self.height);
        for (p, (sum, &kept)) in film.pixels.iter_mut().zip(self.sums.iter().zip(&self.kept)) {
            if kept > 0 {
                *p = (*sum / f64::from(kept)).as_vec3();
            }
        }
        film
    }
}

/// Bytes of memory a render of `width × height` pixels holds: the progress (sums,
/// counts), its tile copies, the film and the encoded output.
pub fn render_memory_bytes(width: u32, height: u32) -> u64 {
    const PER_PIXEL: u64 = 2 * (24 + 4 + 4) + 12 + 12;
    u64::from(width) * u64::from(height) * PER_PIXEL
}

/// How a progressive render is steered from outside.
pub struct RenderControl<'a> {
    /// Non-zero asks the workers to stop after the sample they are on (signal handlers
    /// store the signal number). The progress so far is returned, consistent.
    pub stop: &'a AtomicUsize,
    /// Called with the number of samples finished, from whichever worker finished them.
    pub on_samples: &'a (dyn Fn(u64) + Sync),
    /// Samples per pixel of the first pass; each later pass doubles the total, so an
    /// interrupted render has a whole-image preview early. `u32::MAX`: one pass.
    pub first_pass_spp: u32,
    /// Periodic snapshots of the progress, if wanted.
    pub checkpoint: Option<Checkpointing<'a>>,
}

/// `write` is called with a consistent snapshot of the progress every `every`, from a
/// thread of its own, while the workers go on.
#[derive(Clone, Copy)]
pub struct Checkpointing<'a> {
    pub every: Duration,
    pub write: &'a (dyn Fn(&Progress) + Sync),
}

/// One tile's share of a [`Progress`], owned by one worker at a time.
struct TileProgress {
    rect: (u32, u32, u32, u32),
    sums: Vec<DVec3>,
    kept: Vec<u32>,
    done: Vec<u32>,
}

fn split_into_tiles(progress: &Progress) -> Vec<Mutex<TileProgress>> {
    tiles(progress.width, progress.height)
        .into_iter()
        .map(|rect @ (x0, y0, w, h)| {
            let n = (w * h) as usize;
            let mut tile = TileProgress {
                rect,
                sums: Vec::with_capacity(n),
                kept: Vec::with_capacity(n),
                done: Vec::with_capacity(n),
            };
            for y in y0..y0 + h {
                let row =
                    (y * progress.width + x0) as usize..(y * progress.width + x0 + w) as usize;
                tile.sums.extend_from_slice(&progress.sums[row.clone()]);
                tile.kept.extend_from_slice(&progress.kept[row.clone()]);
                tile.done.extend_from_slice(&progress.done[row]);
            }
            Mutex::new(tile)
        })
        .collect()
}

fn gather_tiles(width: u32, height: u32, tiles: &[Mutex<TileProgress>]) -> Progress {
    let mut progress = Progress::new(width, height);
    for tile in tiles {
        let tile = tile.lock().unwrap_or_else(|p| p.into_inner());
        let (x0, y0, w, h) = tile.rect;
        for row in 0..h {
            let dst = ((y0 + row) * width + x0) as usize..((y0 + row) * width + x0 + w) as usize;
            let src = (row * w) as usize..((row + 1) * w) as usize;
            progress.sums[dst.clone()].copy_from_slice(&tile.sums[src.clone()]);
            progress.kept[dst.clone()].copy_from_slice(&tile.kept[src.clone()]);
            progress.done[dst].copy_from_slice(&tile.done[src]);
        }
    }
    progress
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
    let spp = u64::from(settings.spp.max(1));
    let control = RenderControl {
        stop: &AtomicUsize::new(0),
        on_samples: &|samples| on_tile_done(samples / spp),
        first_pass_spp: u32::MAX,
        checkpoint: None,
    };
    let progress = Progress::new(settings.width, settings.height);
    let (progress, stats) = render_progressive(scene, accel, camera, settings, progress, &control);
    (progress.film(), stats)
}

/// Takes every pixel of `progress` to `settings.spp` samples, in passes over all tiles
/// on the current rayon pool, until done or `control.stop` is set. Pixels that already
/// have `settings.spp` samples or more are left alone.
pub fn render_progressive<A: Accel>(
    scene: &Scene,
    accel: &A,
    camera: &Camera,
    settings: &RenderSettings,
    progress: Progress,
    control: &RenderControl<'_>,
) -> (Progress, RenderStats) {
    assert_eq!(
        (progress.width, progress.height),
        (settings.width, settings.height),
        "progress and settings describe the same image"
    );
    let start = Instant::now();
    let tracer = PathTracer::new(scene, accel, settings.max_depth, settings.integrator);
    let before = progress.total_done();
    let mut target = progress.min_done();
    let tiles = split_into_tiles(&progress);
    drop(progress);
    let rays = AtomicU64::new(0);
    let dropped = AtomicU64::new(0);
    let finished = (Mutex::new(false), Condvar::new());

    std::thread::scope(|scope| {
        if let Some(Checkpointing { every, write }) = control.checkpoint {
            let (tiles, finished) = (&tiles, &finished);
            scope.spawn(move || {
                let (lock, wake) = finished;
                let mut done = lock.lock().unwrap_or_else(|p| p.into_inner());
                // Checked before each wait: the render may finish before this starts.
                while !*done {
                    let (guard, timeout) = wake
                        .wait_timeout(done, every)
                        .unwrap_or_else(|p| p.into_inner());
                    done = guard;
                    if !*done && timeout.timed_out() {
                        write(&gather_tiles(settings.width, settings.height, tiles));
                    }
                }
            });
        }
        // Wakes the checkpoint thread to end when this scope's work ends, even by a
        // panic in a worker: otherwise the scope would wait for that thread forever.
        struct Finish<'f>(&'f (Mutex<bool>, Condvar));
        impl Drop for Finish<'_> {
            fn drop(&mut self) {
                *self.0 .0.lock().unwrap_or_else(|p| p.into_inner()) = true;
                self.0 .1.notify_all();
            }
        }
        let _finish = Finish(&finished);
        while target < settings.spp && control.stop.load(Ordering::Relaxed) == 0 {
            target = if target == 0 {
                control.first_pass_spp.clamp(1, settings.spp)
            } else {
                target.saturating_mul(2).min(settings.spp)
            };
            tiles.par_iter().for_each(|tile| {
                let mut tile = tile.lock().unwrap_or_else(|p| p.into_inner());
                let (r, d, taken) =
                    render_tile(&tracer, camera, settings, &mut tile, target, control.stop);
                rays.fetch_add(r, Ordering::Relaxed);
                dropped.fetch_add(d, Ordering::Relaxed);
                (control.on_samples)(taken);
            });
        }
    });

    let progress = gather_tiles(settings.width, settings.height, &tiles);
    let stats = RenderStats {
        seconds: start.elapsed().as_secs_f64(),
        samples: progress.total_done() - before,
        rays: rays.into_inner(),
        dropped_samples: dropped.into_inner(),
    };
    (progress, stats)
}

/// Camera sample `sample` of pixel `(x, y)` (index `pixel` in the image): the radiance
/// along a ray through a uniform point of the pixel (a box filter), with the pixel's
/// stratified random numbers (see [`Rng::for_pixel_sample`]).
#[inline]
pub fn pixel_sample<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    seed: u64,
    (x, y): (u32, u32),
    pixel: u64,
    sample: u32,
    count: &mut RayCount,
) -> glam::Vec3 {
    let mut rng = Rng::for_pixel_sample(seed, pixel, u64::from(sample));
    let (dx, dy) = rng.pair();
    let ray = camera.ray(x as f32 + dx, y as f32 + dy);
    tracer.radiance(ray, &mut rng, count)
}

/// Takes every pixel of the tile to `target` samples (or stops early when asked).
/// Returns rays traced, samples dropped as NaN/infinite, and samples taken.
fn render_tile<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    settings: &RenderSettings,
    tile: &mut TileProgress,
    target: u32,
    stop: &AtomicUsize,
) -> (u64, u64, u64) {
    let (x0, y0, w, h) = tile.rect;
    let mut count = RayCount::default();
    let mut dropped = 0;
    let mut taken = 0;
    for i in 0..(w * h) as usize {
        let (x, y) = (x0 + i as u32 % w, y0 + i as u32 / w);
        let pixel = u64::from(y) * u64::from(settings.width) + u64::from(x);
        let mut sum = tile.sums[i];
        let (mut kept, mut sample) = (tile.kept[i], tile.done[i]);
        while sample < target {
            if stop.load(Ordering::Relaxed) != 0 {
                break;
            }
            let l = pixel_sample(
                tracer,
                camera,
                settings.seed,
                (x, y),
                pixel,
                sample,
                &mut count,
            );
            if l.is_finite() {
                sum += l.as_dvec3();
                kept += 1;
            } else {
                dropped += 1;
            }
            sample += 1;
            taken += 1;
        }
        tile.sums[i] = sum;
        tile.kept[i] = kept;
        tile.done[i] = sample;
    }
    (count.rays, dropped, taken)
}
