//! The training pre-pass of a guided render: Müller et al.'s doubling schedule over
//! the whole image, deterministic, so that the tree it ends with is a function of the
//! scene and the settings only. A fresh render, a resumed one and every shard
//! train the same tree before they render (the cost of resuming a guided render is
//! training again, a fraction of the render, against storing the tree in every
//! checkpoint and shard).
//!
//! Training's samples are the image's first, as in Müller's "Practical Path Guiding in
//! Production" (2019): iteration `k` renders samples `2^k − 1 .. 2^(k+1) − 1` of every
//! pixel, guided by the tree of iteration `k − 1`, so samples `0 .. 2^N − 1` of a
//! guided render with `N` iterations are training's, and the render's passes take
//! the rest with the last tree. All use the render's seed, so a pixel's samples are one
//! stratified (Sobol) sequence, as an unguided render's are; with a seed of training's
//! own (`sd-tree 8`), the passes' samples were the tail of a sequence whose head was
//! never drawn (the larger loss was elsewhere: see `PathTracer::guided_step`). Each is
//! an unbiased estimate of the pixel (a guided path's weight divides by the mixture's
//! density, whatever the tree), so the pixel's mean over all of them is too. A
//! training sample `s` of a pixel enters the film only as that pixel's next sample
//! there, `samples.start + done`, within the film's range: a fresh film takes them all
//! in order, a shard those in its range, and a resumed film skips those it has, so
//! resuming and merging shards stay exact. Each tile's samples go straight to the
//! film's tile of the same rectangle (locked once, by the worker rendering it).

use std::ops::Range;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use super::{camera_ray, RenderSettings, TiledFilm, TILE_SIZE};
use crate::accel::Accel;
use crate::film::{tile_rects, FilmTile, Sample};
use crate::guiding::{
    GuidedDraw, Guiding, GuidingStats, PathRecords, Record, SdTree, MAX_ITERATIONS,
};
use crate::integrator::{PathTracer, RayCount};
use crate::scene::Camera;

/// Records of one batch of tiles, as far as there are more tiles than workers: 655k,
/// about 50 MB (40 bytes each, and 40 more while they are folded: the leaves each goes
/// to, and its direction and values copied into its leaf's group; see
/// [`SdTree::deposit_all`]). Two batches are held at once, one folded while the next
/// renders: about 100 MB.
const RECORDS_PER_BATCH: usize = 5 << 17;

// The record size the bound above is worked out with.
const _: () = assert!(std::mem::size_of::<Record>() == 40);

/// The guided draws an iteration keeps to learn the regions' shares from (see
/// [`SdTree::refined`]): about a million, 59 MB (56 bytes each). An iteration
/// expected to make more keeps a share of them ([`keep_share`]). Twice as many chose
/// the same shares within noise (per sample, seeds 11 and 12: room 2.02e-2 and 1.90e-2
/// against 1.97e-2 and 1.92e-2 with these, Cornell Original 1.07e-3 and 1.08e-3
/// against 1.09e-3 and 1.09e-3, GlossyMix 6.63e-3 and 6.64e-3 against 6.53e-3 and
/// 6.75e-3) at 60–85 MB more peak memory.
const KEPT_DRAWS: u64 = 1 << 20;

/// The share of its guided draws an iteration keeps, `expected` being how many it is
/// expected to make: all, or as many as [`KEPT_DRAWS`].
fn keep_share(expected: u64) -> f32 {
    (KEPT_DRAWS as f64 / expected.max(1) as f64).min(1.0) as f32
}

/// Tiles rendered before their records are folded in: as many as fit
/// [`RECORDS_PER_BATCH`] (a path leaves at most two records a vertex: its direction
/// and its light sample), at most 64, but at least one per worker. At the last of 10
/// iterations (512 spp, depth 8) a tile holds up to 2.1 million records, 159 MB
/// (folding them included), so two batches hold at most twice that per worker.
fn tiles_per_batch(spp: u32, max_depth: u32) -> usize {
    let per_path = 2 * max_depth.max(1) as usize;
    let per_tile = (TILE_SIZE * TILE_SIZE) as usize * spp as usize * per_path;
    let workers = rayon::current_num_threads();
    (RECORDS_PER_BATCH / per_tile).min(64).max(workers)
}

/// Trains the guide of a render with `settings` (iterations `0..guiding.iterations`,
/// at most [`MAX_ITERATIONS`], iteration `k` at `2^k` samples per pixel, each guided
/// by the tree before it), keeping only the tree.
/// `None` when `stop` was set meanwhile.
pub fn train_guide<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    settings: &RenderSettings,
    guiding: Guiding,
    stop: &AtomicUsize,
) -> Option<(SdTree, GuidingStats)> {
    train(tracer, camera, settings, guiding, None, &|| {
        stop.load(Ordering::Relaxed) != 0
    })
}

/// Trains the guide as [`train_guide`] does, adding each training sample to `film`
/// where it is the next sample of its pixel there (see the module docs). `None` when
/// the render was stopped meanwhile (or its deadline passed); the film keeps the
/// samples it took.
pub(super) fn train_in_film<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    settings: &RenderSettings,
    guiding: Guiding,
    film: &TiledFilm<'_>,
) -> Option<(SdTree, GuidingStats)> {
    train(tracer, camera, settings, guiding, Some(film), &|| {
        film.note_sampled();
        film.stopped()
    })
}

/// The training of [`train_guide`] and [`train_in_film`].
fn train<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    settings: &RenderSettings,
    guiding: Guiding,
    film: Option<&TiledFilm<'_>>,
    stopped: &(dyn Fn() -> bool + Sync),
) -> Option<(SdTree, GuidingStats)> {
    let start = Instant::now();
    let mut tree = SdTree::new(tracer.scene.bounds());
    let rects = tile_rects(settings.width, settings.height, TILE_SIZE);
    if let Some(film) = film {
        assert_eq!(
            film.tiles.len(),
            rects.len(),
            "the film's tiles are training's"
        );
    }
    // The render's own seed: training's samples are the pixel's first of the one
    // stratified sequence the passes continue (see the module notes).
    let seed = settings.seed;
    let pixels = u64::from(settings.width) * u64::from(settings.height);
    let mut first_sample = 0u32;
    let mut samples = 0u64;
    let in_film = AtomicU64::new(0);
    // The first iteration draws at most twice per vertex; each later one, at twice
    // the samples, about twice what the one before drew.
    let mut expected_draws = pixels * 2 * u64::from(settings.max_depth.max(1));
    for k in 0..guiding.iterations.min(MAX_ITERATIONS) {
        let spp = 1u32 << k;
        let keep = keep_share(expected_draws);
        let guided = PathTracer {
            guide: Some(&tree),
            lights: tracer.lights.clone(),
            ..*tracer
        };
        let samples_of_k = first_sample..first_sample + spp;
        let render = |j: usize| {
            let mut tile = film.map(|f| f.tiles[j].lock().unwrap_or_else(|p| p.into_inner()));
            let into = film.zip(tile.as_mut()).map(|(film, tile)| {
                debug_assert_eq!(tile.rect, rects[j]);
                FilmPixels {
                    tile,
                    samples: film.samples.clone(),
                }
            });
            let samples = samples_of_k.clone();
            let (tile, cost) = train_tile(
                &guided, camera, settings, seed, rects[j], samples, into, keep,
            );
            if let Some(film) = film {
                in_film.fetch_add(cost.taken, Ordering::Relaxed);
                film.count(cost.rays, cost.dropped, cost.taken);
            }
            tile
        };
        let batches = Batches {
            tiles: rects.len(),
            per_batch: tiles_per_batch(spp, settings.max_depth),
        };
        let (filling, draws) = fill(tree.cleared(), batches, &render, stopped)?;
        samples += u64::from(spp) * pixels;
        first_sample += spp;
        expected_draws = 2 * draws.made;
        tree = filling.refined(spp, pixels, &draws.kept);
    }
    let stats = GuidingStats {
        seconds: start.elapsed().as_secs_f64(),
        training_samples: samples,
        film_samples: in_film.into_inner(),
        leaves: tree.leaf_count(),
        guided_leaves: tree.guided_leaf_count(),
        nodes: tree.node_count(),
        memory_bytes: tree.memory_bytes(),
    };
    Some((tree, stats))
}

/// Tiles `0..tiles`, rendered `per_batch` at a time.
struct Batches {
    tiles: usize,
    per_batch: usize,
}

/// What rendering a training tile left: its records, and its guided draws.
struct TileRecords {
    records: Vec<Record>,
    draws: GuidedDraws,
}

/// Guided draws: those kept, in tile order, and how many were made in all.
#[derive(Default)]
struct GuidedDraws {
    kept: Vec<GuidedDraw>,
    made: u64,
}

/// `filling` with the records of all tiles (`render` gives a tile's), rendered batch
/// by batch, each batch's records folded in tile order while the next batch renders
/// (the fold's order, and so the tree, does not depend on which worker rendered
/// what), and the tiles' guided draws in tile order. `None` when `stopped`.
fn fill(
    mut filling: SdTree,
    batches: Batches,
    render: &(impl Fn(usize) -> TileRecords + Sync),
    stopped: &(dyn Fn() -> bool + Sync),
) -> Option<(SdTree, GuidedDraws)> {
    let mut rendered: Option<Vec<Vec<Record>>> = None;
    let mut draws = GuidedDraws::default();
    for first in (0..batches.tiles).step_by(batches.per_batch) {
        let batch = first..(first + batches.per_batch).min(batches.tiles);
        let folding = rendered.take();
        let (tiles, ()) = rayon::join(
            || batch.into_par_iter().map(render).collect::<Vec<_>>(),
            || folding.map_or((), |records| filling.deposit_all(&records)),
        );
        if stopped() {
            return None;
        }
        let mut records = Vec::with_capacity(tiles.len());
        for tile in tiles {
            records.push(tile.records);
            draws.kept.extend(tile.draws.kept);
            draws.made += tile.draws.made;
        }
        rendered = Some(records);
    }
    if let Some(records) = rendered {
        filling.deposit_all(&records);
    }
    Some((filling, draws))
}

/// The film's tile that training adds its samples to, and the film's sample indices.
struct FilmPixels<'t> {
    tile: &'t mut FilmTile,
    samples: Range<u32>,
}

impl FilmPixels<'_> {
    /// Adds `sample`, sample index `s` of the tile's pixel `i`, when it is the next
    /// sample of that pixel in the film: `samples.start + done`, within the film's
    /// range, of a pixel adaptive sampling has not stopped. `None`: not taken;
    /// otherwise whether it was kept (finite).
    #[inline]
    fn offer(&mut self, i: usize, s: u32, sample: &Sample) -> Option<bool> {
        let p = &self.tile.pixels[i];
        let next = self.samples.start + p.done;
        let fits = s == next && s < self.samples.end && !p.converged;
        fits.then(|| {
            let (p, training) = self.tile.training_pixel(i);
            p.add_training(sample, training)
        })
    }
}

/// What rendering a training tile cost, and what of it the film took.
#[derive(Default)]
struct TileCost {
    rays: u64,
    /// Samples the film took, and of them those dropped as NaN/infinite.
    taken: u64,
    dropped: u64,
}

/// The records of samples `samples` of every pixel of the tile `(x0, y0, w, h)`, and
/// a share `keep` of its guided draws, each sample offered to `film` (its pixels,
/// when given).
#[allow(clippy::too_many_arguments)]
fn train_tile<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    settings: &RenderSettings,
    seed: u64,
    (x0, y0, w, h): (u32, u32, u32, u32),
    samples: Range<u32>,
    mut film: Option<FilmPixels<'_>>,
    keep: f32,
) -> (TileRecords, TileCost) {
    let (mut records, mut draws, mut made) = (Vec::new(), Vec::new(), 0);
    let mut count = RayCount::default();
    let mut cost = TileCost::default();
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let pixel = u64::from(y) * u64::from(settings.width) + u64::from(x);
            let i = ((y - y0) * w + (x - x0)) as usize;
            for s in samples.clone() {
                let (ray, mut rng) = camera_ray(camera, seed, (x, y), pixel, s);
                let mut recorder = PathRecords::new(&mut records, &mut draws, keep);
                let sample = tracer.sample_recorded(ray, &mut rng, &mut count, &mut recorder);
                made += recorder.drawn();
                if let Some(kept) = film.as_mut().and_then(|f| f.offer(i, s, &sample)) {
                    cost.taken += 1;
                    cost.dropped += u64::from(!kept);
                }
            }
        }
    }
    cost.rays = count.rays;
    let draws = GuidedDraws { kept: draws, made };
    (TileRecords { records, draws }, cost)
}
