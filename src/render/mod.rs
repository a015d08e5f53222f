//! The render loop: tiles of the [`Film`] spread over rayon's workers, a deterministic
//! random stream per (pixel, sample, seed), and what a render cost.
//!
//! Rendering is progressive: passes over all tiles add samples to the film, so a render
//! can be stopped (Ctrl-C), snapshotted (checkpoints), resumed, or split by sample
//! ranges into shards, and the result equals an uninterrupted render (see
//! [`crate::film`]).

mod identity;

pub use identity::{identity, scene_hash, ALGORITHM_VERSION};

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::accel::Accel;
use crate::film::{Film, FilmTile};
use crate::image::Image;
use crate::integrator::{IntegratorKind, PathTracer, RayCount};
use crate::light::LightSamplerKind;
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
    /// How light samples choose an emitter.
    pub light_sampler: LightSamplerKind,
}

/// What a render cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    pub seconds: f64,
    pub samples: u64,
    pub rays: u64,
    /// Samples whose estimate was NaN or infinite, left out of their pixel's mean.
    pub dropped_samples: u64,
    /// Wall time of building the distribution over emitters, and its BVH nodes (0 for
    /// the alias table).
    pub light_build_seconds: f64,
    pub light_nodes: usize,
}

impl RenderStats {
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.seconds.max(1e-9)
    }

    pub fn mrays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-9) / 1e6
    }
}

/// Bytes of memory a render of `width × height` pixels holds: the film (sums, counts),
/// its tile copies, the image and the encoded output.
pub fn render_memory_bytes(width: u32, height: u32) -> u64 {
    const PER_PIXEL: u64 = 2 * (24 + 4 + 4) + 12 + 12;
    u64::from(width) * u64::from(height) * PER_PIXEL
}

/// How a progressive render is steered from outside.
pub struct RenderControl<'a> {
    /// Non-zero asks the workers to stop after the sample they are on (signal handlers
    /// store the signal number). The film so far is returned, consistent.
    pub stop: &'a AtomicUsize,
    /// Called with the number of samples finished, from whichever worker finished them.
    pub on_samples: &'a (dyn Fn(u64) + Sync),
    /// Samples per pixel of the first pass; each later pass doubles the total, so an
    /// interrupted render has a whole-image preview early. `u32::MAX`: one pass.
    pub first_pass_spp: u32,
    /// Periodic snapshots of the film, if wanted.
    pub checkpoint: Option<Checkpointing<'a>>,
}

/// `write` is called with a consistent snapshot of the film every `every`, from a
/// thread of its own, while the workers go on.
#[derive(Clone, Copy)]
pub struct Checkpointing<'a> {
    pub every: Duration,
    pub write: &'a (dyn Fn(&Film) + Sync),
}

/// Renders the image on the current rayon pool. `on_tile_done(pixels)` is called
/// after each tile, from whichever worker finished it (for progress bars).
pub fn render<A: Accel>(
    scene: &Scene,
    accel: &A,
    camera: &Camera,
    settings: &RenderSettings,
    on_tile_done: &(dyn Fn(u64) + Sync),
) -> (Image, RenderStats) {
    let spp = u64::from(settings.spp.max(1));
    let control = RenderControl {
        stop: &AtomicUsize::new(0),
        on_samples: &|samples| on_tile_done(samples / spp),
        first_pass_spp: u32::MAX,
        checkpoint: None,
    };
    let film = Film::new(settings.width, settings.height, 0..settings.spp);
    let (film, stats) = render_progressive(scene, accel, camera, settings, film, &control);
    (film.resolve(), stats)
}

/// Takes every pixel of `film` to all the samples of its range (`film.samples`, within
/// `0..settings.spp`), in passes over all tiles on the current rayon pool, until done
/// or `control.stop` is set. Pixels that already have them are left alone.
pub fn render_progressive<A: Accel>(
    scene: &Scene,
    accel: &A,
    camera: &Camera,
    settings: &RenderSettings,
    film: Film,
    control: &RenderControl<'_>,
) -> (Film, RenderStats) {
    assert_eq!(
        (film.width, film.height),
        (settings.width, settings.height),
        "film and settings describe the same image"
    );
    assert!(
        film.samples.end <= settings.spp,
        "the film's samples are the render's"
    );
    let start = Instant::now();
    let tracer = PathTracer::with_light_sampler(
        scene,
        accel,
        settings.max_depth,
        settings.integrator,
        settings.light_sampler,
    );
    let (light_build, light_nodes) = tracer.lights.build_cost();
    let before = film.total_done();
    let tiles: Vec<Mutex<FilmTile>> = film.tiles(TILE_SIZE).into_iter().map(Mutex::new).collect();
    let passes = Passes {
        tracer: &tracer,
        camera,
        settings,
        first_sample: film.samples.start,
        tiles: &tiles,
        control,
        rays: AtomicU64::new(0),
        dropped: AtomicU64::new(0),
    };
    let finished = (Mutex::new(false), Condvar::new());
    std::thread::scope(|scope| {
        if let Some(checkpointing) = control.checkpoint {
            let (film, tiles, finished) = (&film, &tiles, &finished);
            scope.spawn(move || checkpoint_thread(film, tiles, checkpointing, finished));
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
        passes.run(film.min_done(), film.samples.len() as u32);
    });
    let (rays, dropped) = (passes.rays.into_inner(), passes.dropped.into_inner());
    let film = gather(film, &tiles);
    let stats = RenderStats {
        seconds: start.elapsed().as_secs_f64(),
        samples: film.total_done() - before,
        rays,
        dropped_samples: dropped,
        light_build_seconds: light_build.as_secs_f64(),
        light_nodes,
    };
    (film, stats)
}

/// The film with the tiles' current state written back.
fn gather(mut film: Film, tiles: &[Mutex<FilmTile>]) -> Film {
    for tile in tiles {
        film.write_tile(&tile.lock().unwrap_or_else(|p| p.into_inner()));
    }
    film
}

/// Writes a snapshot of the film every `every` until `finished` is set.
fn checkpoint_thread(
    film: &Film,
    tiles: &[Mutex<FilmTile>],
    Checkpointing { every, write }: Checkpointing<'_>,
    (lock, wake): &(Mutex<bool>, Condvar),
) {
    let mut done = lock.lock().unwrap_or_else(|p| p.into_inner());
    // Checked before each wait: the render may finish before this starts.
    while !*done {
        let (guard, timeout) = wake
            .wait_timeout(done, every)
            .unwrap_or_else(|p| p.into_inner());
        done = guard;
        if !*done && timeout.timed_out() {
            write(&gather(film.clone(), tiles));
        }
    }
}

/// The passes of a progressive render over the tiles of one film.
struct Passes<'a, A: Accel> {
    tracer: &'a PathTracer<'a, A>,
    camera: &'a Camera,
    settings: &'a RenderSettings,
    /// The sample index of a pixel's first sample in this film.
    first_sample: u32,
    tiles: &'a [Mutex<FilmTile>],
    control: &'a RenderControl<'a>,
    rays: AtomicU64,
    dropped: AtomicU64,
}

impl<A: Accel> Passes<'_, A> {
    /// Passes from `done` to `count` samples per pixel: the first of
    /// `first_pass_spp`, each later one doubling the count.
    fn run(&self, mut done: u32, count: u32) {
        while done < count && self.control.stop.load(Ordering::Relaxed) == 0 {
            done = if done == 0 {
                self.control.first_pass_spp.clamp(1, count)
            } else {
                done.saturating_mul(2).min(count)
            };
            self.tiles.par_iter().for_each(|tile| {
                let mut tile = tile.lock().unwrap_or_else(|p| p.into_inner());
                let (r, d, taken) = self.render_tile(&mut tile, done);
                self.rays.fetch_add(r, Ordering::Relaxed);
                self.dropped.fetch_add(d, Ordering::Relaxed);
                (self.control.on_samples)(taken);
            });
        }
    }
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

impl<A: Accel> Passes<'_, A> {
    /// Takes every pixel of the tile to `target` samples of the film's range (or stops
    /// early when asked). Returns rays traced, samples dropped as NaN/infinite, and
    /// samples taken.
    fn render_tile(&self, tile: &mut FilmTile, target: u32) -> (u64, u64, u64) {
        let (x0, y0, w, h) = tile.rect;
        let mut count = RayCount::default();
        let mut dropped = 0;
        let mut taken = 0;
        for i in 0..(w * h) as usize {
            let (x, y) = (x0 + i as u32 % w, y0 + i as u32 / w);
            let pixel = u64::from(y) * u64::from(self.settings.width) + u64::from(x);
            let mut sum = tile.sums[i];
            let (mut kept, mut done) = (tile.kept[i], tile.done[i]);
            while done < target {
                if self.control.stop.load(Ordering::Relaxed) != 0 {
                    break;
                }
                let l = pixel_sample(
                    self.tracer,
                    self.camera,
                    self.settings.seed,
                    (x, y),
                    pixel,
                    self.first_sample + done,
                    &mut count,
                );
                if l.is_finite() {
                    sum += l.as_dvec3();
                    kept += 1;
                } else {
                    dropped += 1;
                }
                done += 1;
                taken += 1;
            }
            tile.sums[i] = sum;
            tile.kept[i] = kept;
            tile.done[i] = done;
        }
        (count.rays, dropped, taken)
    }
}
