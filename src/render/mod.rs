//! The render loop: tiles of the [`Film`] spread over rayon's workers, a deterministic
//! random stream per (pixel, sample, seed), and what a render cost.
//!
//! Rendering is progressive: passes over all tiles add samples to the film, so a render
//! can be stopped (Ctrl-C), snapshotted (checkpoints), resumed, or split by sample
//! ranges into shards, and the result equals an uninterrupted render (see
//! [`crate::film`]). Between passes, adaptive sampling ([`adaptive`]) may stop pixels
//! that have converged; a deadline ends the render wherever it is. A guided render
//! trains its guide first, and the training's samples are the film's first
//! ([`training`]).

pub mod adaptive;
mod guide_view;
mod identity;
mod probe;
mod training;

pub use adaptive::Adaptive;
pub use guide_view::{guide_view, GuidePicture, GuideView};
pub use identity::{
    identity, scene_hash, ResumedDefaults, ALGORITHM_VERSION, GUIDE_VERSION, GUIDING_ITERATIONS,
};
pub use probe::{probe_camera, CameraProbe};
pub use training::train_guide;

use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::accel::Accel;
use crate::film::{Film, FilmTile, PixelSums, Sample};
use crate::guiding::{Guiding, GuidingStats, SdTree};
use crate::image::Image;
use crate::integrator::{IntegratorKind, PathTracer, RayCount};
use crate::light::LightSamplerKind;
use crate::sampling::Rng;
use crate::scene::{Camera, Scene};
use crate::wavefront::{LaneScene, Wavefront};

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
    /// Adaptive sampling; `None` renders every pixel to `spp`.
    pub adaptive: Option<Adaptive>,
    /// Path guiding, trained before rendering; `None`: unguided.
    pub guiding: Option<Guiding>,
    /// Which engine traces the paths.
    pub engine: Engine,
}

/// Which engine traces a render's paths.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Engine {
    /// One path at a time, every feature.
    #[default]
    Scalar,
    /// Sixteen paths at a time in SIMD lanes ([`crate::wavefront`]); renders only what
    /// [`LaneScene::new`] accepts, which the caller checks first.
    Wavefront,
}

/// What a render cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    pub seconds: f64,
    /// Samples the film took in this run, a guide's training samples among them.
    pub samples: u64,
    /// Rays traced, a guide's training included (its samples the film did not take
    /// too).
    pub rays: u64,
    /// Samples whose estimate was NaN or infinite, left out of their pixel's mean.
    pub dropped_samples: u64,
    /// The guide's training (included in `seconds`, `rays`, and `samples` as far as
    /// the film took its samples).
    pub guiding: Option<GuidingStats>,
    /// Wall time of building the distribution over emitters, and its BVH nodes (0 for
    /// the alias table).
    pub light_build_seconds: f64,
    pub light_nodes: usize,
    /// Whether the deadline came before every pixel had a sample, and the render went
    /// on until each had one (an image of unsampled pixels would show nothing).
    pub deadline_overrun: bool,
}

impl RenderStats {
    /// The film's samples over the whole run's time: a guide's training is part of
    /// both, since its samples are the film's first (the training samples the film
    /// did not take, beyond `--spp` or outside a shard, cost time and count nothing).
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.seconds.max(1e-9)
    }

    pub fn mrays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-9) / 1e6
    }
}

/// Bytes of memory a render of `width × height` pixels holds: the film (sums, counts,
/// and a guided render's training moments), its tile copies, adaptive sampling's error
/// map, the image, its passes and the encoded output.
pub fn render_memory_bytes(width: u32, height: u32) -> u64 {
    const FILM_PIXEL: u64 = (std::mem::size_of::<crate::film::PixelSums>()
        + std::mem::size_of::<crate::film::Moments>()) as u64;
    // The film and its tiles; adaptive sampling's error map, window maxima and calm
    // flags; the image; up to 13 pass channels of f32 and their EXR encoding.
    const PER_PIXEL: u64 = 2 * FILM_PIXEL + 8 + 8 + 1 + 12 + 2 * 13 * 4;
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
    /// The render stops when this time comes (`--time-limit`), like a stop request,
    /// but not before every pixel has a sample; passes are sized to end near it, so
    /// that pixels differ little in samples.
    pub deadline: Option<Instant>,
    /// Called after each whole pass with the film's state (progress bars).
    pub on_pass: &'a (dyn Fn(&PassReport) + Sync),
    /// Called once with the trained guide of a guided render, before it renders
    /// (`--guide-image`).
    pub on_guide: Option<&'a (dyn Fn(&SdTree) + Sync)>,
}

/// The film's state after a pass: samples per pixel and how many pixels converged.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassReport {
    pub min_spp: u32,
    pub mean_spp: f64,
    pub max_spp: u32,
    pub converged: usize,
    pub pixels: usize,
    /// Samples the pixels still going would take to the end of the film's range.
    pub remaining: u64,
}

impl PassReport {
    pub fn of(film: &Film) -> PassReport {
        PassReport::of_pixels(film.pixels.iter(), film.samples.len() as u32)
    }

    /// The report of `pixels`, of a film whose range holds `len` samples.
    fn of_pixels<'p>(pixels: impl Iterator<Item = &'p PixelSums>, len: u32) -> PassReport {
        let mut report = PassReport {
            min_spp: u32::MAX,
            ..PassReport::default()
        };
        let mut total = 0u64;
        for p in pixels {
            report.min_spp = report.min_spp.min(p.done);
            report.max_spp = report.max_spp.max(p.done);
            total += u64::from(p.done);
            report.pixels += 1;
            if p.converged {
                report.converged += 1;
            } else {
                report.remaining += u64::from(len.saturating_sub(p.done));
            }
        }
        report.min_spp = report.min_spp.min(report.max_spp);
        report.mean_spp = total as f64 / report.pixels.max(1) as f64;
        report
    }

    /// Fraction of the pixels adaptive sampling has stopped.
    pub fn converged_fraction(&self) -> f64 {
        self.converged as f64 / self.pixels.max(1) as f64
    }
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
        deadline: None,
        on_pass: &|_| {},
        on_guide: None,
    };
    let film = Film::new(settings.width, settings.height, 0..settings.spp);
    let (film, stats) = render_progressive(scene, accel, camera, settings, film, &control);
    (film.resolve(), stats)
}

/// Takes every pixel of `film` to all the samples of its range (`film.samples`, within
/// `0..settings.spp`), in passes over all tiles on the current rayon pool, until done,
/// converged (adaptive sampling), `control.stop` is set or the deadline passes. Pixels
/// that already have them are left alone.
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
    let guiding = settings.guiding;
    let before = film.total_done();
    let tiles: Vec<Mutex<FilmTile>> = film.tiles(TILE_SIZE).into_iter().map(Mutex::new).collect();
    let tiled = TiledFilm {
        tiles: &tiles,
        samples: film.samples.clone(),
        control,
        rays: AtomicU64::new(0),
        dropped: AtomicU64::new(0),
        sampled: AtomicBool::new(film.min_done() > 0),
        overrun: AtomicBool::new(false),
    };
    let finished = (Mutex::new(false), Condvar::new());
    let trained = std::thread::scope(|scope| {
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
        // Training's samples are the film's first (see [`training`]); a stop during
        // training leaves the film with those it took.
        let trained = match guiding {
            Some(guiding) => Some(training::train_in_film(
                &tracer, camera, settings, guiding, &tiled,
            )?),
            None => None,
        };
        if let (Some((tree, _)), Some(on_guide)) = (&trained, control.on_guide) {
            on_guide(tree);
        }
        let tracer = tracer.with_guide(trained.as_ref().map(|t| &t.0));
        let lanes = (settings.engine == Engine::Wavefront).then(|| {
            LaneScene::new(scene).expect("the caller checks that the wavefront renders the scene")
        });
        let wavefront = lanes.as_ref().map(|lanes| Wavefront {
            scene: lanes,
            accel,
            camera: camera.frame().expect("the wavefront's camera has no lens"),
            image_width: settings.width,
            max_depth: settings.max_depth,
            seed: settings.seed,
        });
        let passes = Passes {
            tracer: &tracer,
            wavefront,
            camera,
            settings,
            film: &tiled,
        };
        passes.run(film.samples.len() as u32);
        trained.map(|t| t.1)
    });
    let (rays, dropped) = (tiled.rays.into_inner(), tiled.dropped.into_inner());
    let film = gather(film, &tiles);
    let stats = RenderStats {
        seconds: start.elapsed().as_secs_f64(),
        samples: film.total_done() - before,
        rays,
        dropped_samples: dropped,
        guiding: trained,
        light_build_seconds: light_build.as_secs_f64(),
        light_nodes,
        deadline_overrun: tiled.overrun.into_inner(),
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

/// The tiles of a film while workers add samples to them, one worker a tile at a time
/// (a guide's training, then the passes), and what the samples cost.
struct TiledFilm<'a> {
    /// `film.tiles(TILE_SIZE)`: tile `j` has the rectangle `tile_rects(..)[j]`.
    tiles: &'a [Mutex<FilmTile>],
    /// The film's sample indices: a pixel's first sample here is `samples.start`.
    samples: Range<u32>,
    control: &'a RenderControl<'a>,
    rays: AtomicU64,
    dropped: AtomicU64,
    /// Whether every pixel has a sample: only then may the deadline end the render.
    sampled: AtomicBool,
    /// Whether the deadline passed before every pixel had a sample.
    overrun: AtomicBool,
}

impl TiledFilm<'_> {
    /// Whether a stop was asked for, or the deadline has passed once every pixel has
    /// a sample.
    #[inline]
    fn stopped(&self) -> bool {
        self.control.stop.load(Ordering::Relaxed) != 0 || self.past_deadline()
    }

    /// Whether the deadline has passed and every pixel has a sample; noting when it
    /// passed before they all had one.
    #[inline]
    fn past_deadline(&self) -> bool {
        if self.control.deadline.is_none_or(|d| Instant::now() < d) {
            return false;
        }
        let sampled = self.sampled.load(Ordering::Relaxed);
        if !sampled && !self.overrun.load(Ordering::Relaxed) {
            self.overrun.store(true, Ordering::Relaxed);
        }
        sampled
    }

    /// Notes, once the deadline has passed, whether every pixel has a sample now
    /// (between passes or training batches, when no tile is being rendered).
    fn note_sampled(&self) {
        // Only the deadline asks: before it, the pixels need not be looked at.
        let late = self.control.deadline.is_some_and(|d| Instant::now() >= d);
        if !late || self.sampled.load(Ordering::Relaxed) {
            return;
        }
        let sampled = self.tiles.iter().all(|tile| {
            let tile = tile.lock().unwrap_or_else(|p| p.into_inner());
            tile.pixels.iter().all(|p| p.done > 0)
        });
        self.sampled.store(sampled, Ordering::Relaxed);
    }

    /// Counts what a worker spent on one tile: rays traced, samples dropped as
    /// NaN/infinite, and samples the film took.
    fn count(&self, rays: u64, dropped: u64, taken: u64) {
        self.rays.fetch_add(rays, Ordering::Relaxed);
        self.dropped.fetch_add(dropped, Ordering::Relaxed);
        (self.control.on_samples)(taken);
    }
}

/// The passes of a progressive render over the tiles of one film.
struct Passes<'a, A: Accel> {
    tracer: &'a PathTracer<'a, A>,
    /// The engine that renders the passes in lanes instead, when chosen.
    wavefront: Option<Wavefront<'a, A>>,
    camera: &'a Camera,
    settings: &'a RenderSettings,
    film: &'a TiledFilm<'a>,
}

impl<A: Accel> Passes<'_, A> {
    /// Passes until every pixel has `count` samples or has converged. A pass takes the
    /// pixels still going to the next sample count of a fixed schedule (the first pass
    /// `first_pass_spp`, each later one doubling it), so the passes of a resumed render
    /// end where the uninterrupted render's did: adaptive decisions, taken after each
    /// whole pass, are then the same.
    fn run(&self, count: u32) {
        let mut last_pass: Option<(u32, Duration)> = None;
        loop {
            let report = self.at_pass_end(count);
            if last_pass.is_some() {
                (self.film.control.on_pass)(&report);
            }
            self.film.note_sampled();
            if self.film.stopped() {
                break;
            }
            let Some(level) = self.fewest_samples_going() else {
                break;
            };
            if level >= count {
                break;
            }
            let control = self.film.control;
            let mut target = next_pass_target(level, control.first_pass_spp, count);
            if let (Some(deadline), Some(last)) = (control.deadline, last_pass) {
                target = target.min(fit_to_deadline(level, deadline, last));
            }
            let started = Instant::now();
            self.film.tiles.par_iter().for_each(|tile| {
                let mut tile = tile.lock().unwrap_or_else(|p| p.into_inner());
                let (r, d, taken) = self.render_tile(&mut tile, target);
                self.film.count(r, d, taken);
            });
            last_pass = Some((target - level, started.elapsed()));
        }
    }

    /// The fewest samples of any pixel that has not converged (`None`: all have).
    fn fewest_samples_going(&self) -> Option<u32> {
        self.film
            .tiles
            .iter()
            .filter_map(|tile| {
                let tile = tile.lock().unwrap_or_else(|p| p.into_inner());
                tile.pixels
                    .iter()
                    .filter(|p| !p.converged)
                    .map(|p| p.done)
                    .min()
            })
            .min()
    }

    /// The film's state, after adaptive sampling's decisions where a pass has ended:
    /// where every pixel still going has the same sample count. That is the state
    /// after each whole pass, and also that of a render stopped there or resumed from
    /// there; deciding again on it decides the same (a stopped pixel's error is below
    /// the threshold already), so a resumed render takes the decisions of an
    /// uninterrupted one. A render stopped inside a pass decides nothing until it
    /// ends that pass.
    fn at_pass_end(&self, count: u32) -> PassReport {
        let mut tiles: Vec<_> = self
            .film
            .tiles
            .iter()
            .map(|t| t.lock().unwrap_or_else(|p| p.into_inner()))
            .collect();
        let going = |tiles: &[MutexGuard<FilmTile>]| {
            let mut counts = tiles
                .iter()
                .flat_map(|t| t.pixels.iter())
                .filter(|p| !p.converged)
                .map(|p| p.done);
            let first = counts.next();
            counts.all(|d| Some(d) == first)
        };
        if let (Some(adaptive), true) = (&self.settings.adaptive, going(&tiles)) {
            self.decide(&mut tiles, adaptive);
        }
        PassReport::of_pixels(tiles.iter().flat_map(|t| t.pixels.iter()), count)
    }

    /// Stops the pixels adaptive sampling lets stop: the image's error map, its calm
    /// neighbourhoods, and each pixel's own count.
    fn decide(&self, tiles: &mut [MutexGuard<FilmTile>], adaptive: &Adaptive) {
        let (w, h) = (self.settings.width, self.settings.height);
        let at = |(x0, y0, tw, _): (u32, u32, u32, u32), i: usize| {
            let i = i as u32;
            ((y0 + i / tw) * w + x0 + i % tw) as usize
        };
        let mut error = vec![0.0f64; w as usize * h as usize];
        for tile in tiles.iter() {
            for (i, p) in tile.pixels.iter().enumerate() {
                if !p.converged {
                    error[at(tile.rect, i)] = p.relative_error();
                }
            }
        }
        let calm = adaptive::calm(&error, w, h, adaptive.threshold);
        for tile in tiles.iter_mut() {
            let rect = tile.rect;
            for (i, p) in tile.pixels.iter_mut().enumerate() {
                p.converged = adaptive.may_stop(p, calm[at(rect, i)]);
            }
        }
    }
}

/// The sample count the pass after `level` takes pixels to: the first value of the
/// schedule `first, 2·first, 4·first, …` above `level`, at most `count`.
fn next_pass_target(level: u32, first: u32, count: u32) -> u32 {
    let mut target = first.clamp(1, count);
    while target <= level && target < count {
        target = target.saturating_mul(2).min(count);
    }
    target
}

/// The largest sample count a pass from `level` can reach by `deadline`, at the pace
/// of the last pass (`samples` more per pixel in `took`); at least one more sample.
fn fit_to_deadline(level: u32, deadline: Instant, (samples, took): (u32, Duration)) -> u32 {
    let left = deadline
        .saturating_duration_since(Instant::now())
        .as_secs_f64();
    let per_sample = took.as_secs_f64() / f64::from(samples.max(1));
    let more = (left / per_sample.max(1e-9))
        .floor()
        .clamp(1.0, f64::from(u32::MAX));
    level.saturating_add(more as u32)
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
) -> Sample {
    let (ray, mut rng) = camera_ray(camera, seed, (x, y), pixel, sample);
    tracer.sample(ray, &mut rng, count)
}

/// The camera ray of sample `sample` of pixel `(x, y)` and the random stream its path
/// goes on with.
#[inline(always)]
fn camera_ray(
    camera: &Camera,
    seed: u64,
    (x, y): (u32, u32),
    pixel: u64,
    sample: u32,
) -> (crate::accel::Ray, Rng) {
    let mut rng = Rng::for_pixel_sample(seed, pixel, u64::from(sample));
    let (dx, dy) = rng.pair();
    let (px, py) = (x as f32 + dx, y as f32 + dy);
    // A lens takes the rest of the camera's stratified set (the pixel position and
    // the lens point are stratified jointly); a pinhole draws nothing more, so its
    // images are those of versions without lenses.
    let ray = if camera.has_lens() {
        camera.lens_ray(px, py, rng.pair())
    } else {
        camera.ray(px, py)
    };
    (ray, rng)
}

impl<A: Accel> Passes<'_, A> {
    /// Takes every pixel of the tile to `target` samples of the film's range (or stops
    /// early when asked). Returns rays traced, samples dropped as NaN/infinite, and
    /// samples taken.
    fn render_tile(&self, tile: &mut FilmTile, target: u32) -> (u64, u64, u64) {
        if let Some(wavefront) = &self.wavefront {
            let cost = wavefront.render_tile(tile, self.film.samples.start, target);
            return (cost.rays, cost.dropped, cost.taken);
        }
        let (x0, y0, w, _) = tile.rect;
        let mut count = RayCount::default();
        let mut dropped = 0;
        let mut taken = 0;
        for (i, p) in tile.pixels.iter_mut().enumerate() {
            if p.converged {
                continue;
            }
            let (x, y) = (x0 + i as u32 % w, y0 + i as u32 / w);
            let pixel = u64::from(y) * u64::from(self.settings.width) + u64::from(x);
            while p.done < target {
                if self.film.stopped() {
                    break;
                }
                let sample = pixel_sample(
                    self.tracer,
                    self.camera,
                    self.settings.seed,
                    (x, y),
                    pixel,
                    self.film.samples.start + p.done,
                    &mut count,
                );
                if !p.add(&sample) {
                    dropped += 1;
                }
                taken += 1;
            }
        }
        (count.rays, dropped, taken)
    }
}
