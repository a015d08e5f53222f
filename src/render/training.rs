//! The training pre-pass of a guided render: Müller et al.'s doubling schedule over
//! the whole image, with seeds of its own, so that the tree it ends with is a function
//! of the scene and the settings only. A fresh render, a resumed one and every shard
//! train the same tree before they render (the cost of resuming a guided render is
//! training again, a fraction of the render, against storing the tree in every
//! checkpoint and shard).

use std::sync::atomic::AtomicUsize;
use std::sync::atomic::Ordering;
use std::time::Instant;

use rayon::prelude::*;

use super::{camera_ray, RenderSettings, TILE_SIZE};
use crate::accel::Accel;
use crate::film::tile_rects;
use crate::guiding::{Guiding, GuidingStats, PathRecords, Record, SdTree, MAX_ITERATIONS};
use crate::integrator::{PathTracer, RayCount};
use crate::scene::Camera;

/// Mixed into the render's seed so that training samples are not the render's.
const TRAINING_SEED: u64 = 0x6775_6964_696e_6721;

/// Records of one batch of tiles, as far as there are more tiles than workers: 917k,
/// about 66 MB (48 bytes each, a guided draw carrying its mixture's densities, and 24
/// more while they are folded: the leaves each goes to, and its place in each leaf's
/// group; see [`SdTree::deposit_all`]). Two batches are held at once, one folded
/// while the next renders: about 132 MB.
const RECORDS_PER_BATCH: usize = 7 << 17;

/// Tiles rendered before their records are folded in: as many as fit
/// [`RECORDS_PER_BATCH`] (a path leaves at most two records a vertex: its direction
/// and its light sample), at most 64, but at least one per worker. At the last of 10
/// iterations (512 spp, depth 8) a tile holds up to 151 MB of records (folding them
/// included), so two batches hold at most twice that per worker.
fn tiles_per_batch(spp: u32, max_depth: u32) -> usize {
    let per_path = 2 * max_depth.max(1) as usize;
    let per_tile = (TILE_SIZE * TILE_SIZE) as usize * spp as usize * per_path;
    let workers = rayon::current_num_threads();
    (RECORDS_PER_BATCH / per_tile).min(64).max(workers)
}

/// Trains the guide of a render with `settings` (iterations `0..guiding.iterations`,
/// at most [`MAX_ITERATIONS`], iteration `k` at `2^k` samples per pixel, each guided
/// by the tree before it).
/// `None` when `stop` was set meanwhile.
pub fn train_guide<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    settings: &RenderSettings,
    guiding: Guiding,
    stop: &AtomicUsize,
) -> Option<(SdTree, GuidingStats)> {
    let start = Instant::now();
    let mut tree = SdTree::new(tracer.scene.bounds());
    let rects = tile_rects(settings.width, settings.height, TILE_SIZE);
    let seed = settings.seed ^ TRAINING_SEED;
    let mut first_sample = 0u32;
    let mut samples = 0u64;
    for k in 0..guiding.iterations.min(MAX_ITERATIONS) {
        let spp = 1u32 << k;
        let guided = PathTracer {
            guide: Some(&tree),
            lights: tracer.lights.clone(),
            ..*tracer
        };
        let samples_of_k = first_sample..first_sample + spp;
        let render = |rect| train_tile(&guided, camera, settings, seed, rect, samples_of_k.clone());
        let filling = fill(
            tree.cleared(),
            &rects,
            spp,
            settings.max_depth,
            &render,
            stop,
        )?;
        samples += u64::from(spp) * u64::from(settings.width) * u64::from(settings.height);
        first_sample += spp;
        tree = filling.refined(spp, u64::from(settings.width) * u64::from(settings.height));
    }
    let stats = GuidingStats {
        seconds: start.elapsed().as_secs_f64(),
        training_samples: samples,
        leaves: tree.leaf_count(),
        nodes: tree.node_count(),
        memory_bytes: tree.memory_bytes(),
    };
    Some((tree, stats))
}

/// `filling` with the records of every tile of `rects` (`render` gives a tile's, at
/// `spp` samples per pixel), rendered batch by batch, each batch's records folded
/// in tile order while the next batch renders (the fold's order, and so the tree,
/// does not depend on which worker rendered what). `None` when `stop` was set.
fn fill(
    mut filling: SdTree,
    rects: &[(u32, u32, u32, u32)],
    spp: u32,
    max_depth: u32,
    render: &(impl Fn((u32, u32, u32, u32)) -> Vec<Record> + Sync),
    stop: &AtomicUsize,
) -> Option<SdTree> {
    let mut rendered: Option<Vec<Vec<Record>>> = None;
    for batch in rects.chunks(tiles_per_batch(spp, max_depth)) {
        let folding = rendered.take();
        let (records, ()) = rayon::join(
            || batch.par_iter().map(|&rect| render(rect)).collect(),
            || folding.map_or((), |records| filling.deposit_all(&records)),
        );
        if stop.load(Ordering::Relaxed) != 0 {
            return None;
        }
        rendered = Some(records);
    }
    if let Some(records) = rendered {
        filling.deposit_all(&records);
    }
    Some(filling)
}

/// The records of samples `samples` of every pixel of the tile `(x0, y0, w, h)`.
fn train_tile<A: Accel>(
    tracer: &PathTracer<'_, A>,
    camera: &Camera,
    settings: &RenderSettings,
    seed: u64,
    (x0, y0, w, h): (u32, u32, u32, u32),
    samples: std::ops::Range<u32>,
) -> Vec<Record> {
    let mut out = Vec::new();
    let mut count = RayCount::default();
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let pixel = u64::from(y) * u64::from(settings.width) + u64::from(x);
            for s in samples.clone() {
                let (ray, mut rng) = camera_ray(camera, seed, (x, y), pixel, s);
                let mut recorder = PathRecords::new(&mut out);
                tracer.sample_recorded(ray, &mut rng, &mut count, &mut recorder);
            }
        }
    }
    out
}
