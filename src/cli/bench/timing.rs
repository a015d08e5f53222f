//! Timing: the best of repeated runs, and ray throughput on a thread pool with the
//! processor time the process got meanwhile.

use std::hint::black_box;
use std::time::Instant;

use rayon::prelude::*;

/// Runs `f` once to warm up, then again until `min_seconds` have passed; returns the
/// best time of one run, in seconds, and the last result.
pub fn best_time<T>(min_seconds: f64, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = f();
    let (mut best, mut total, mut runs) = (f64::INFINITY, 0.0, 0);
    while runs < 2 || total < min_seconds {
        let start = Instant::now();
        out = black_box(f());
        let s = start.elapsed().as_secs_f64();
        best = best.min(s);
        total += s;
        runs += 1;
        if runs >= 1000 {
            break;
        }
    }
    (best, out)
}

/// Rays per work item handed to a rayon worker.
const CHUNK: usize = 512;

/// The outcome of tracing one ray set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Traced {
    /// Millions of rays per second, from the best pass.
    pub mrays_per_s: f64,
    pub rays: usize,
    pub hits: usize,
    /// Processor seconds the whole process used per wall-clock second while measuring
    /// (Linux only): near the thread count when the threads really ran in parallel,
    /// lower when other programs took the cores, which caps any speed-up.
    pub cpu_per_wall: Option<f64>,
}

/// Processor time this process has used so far, from `/proc/self/stat` (user + system
/// clock ticks, which Linux counts at 100 per second).
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are the 12th and
    // 13th of them (the 14th and 15th of the line).
    let mut fields = stat.rsplit_once(')')?.1.split_whitespace().skip(11);
    let utime: f64 = fields.next()?.parse().ok()?;
    let stime: f64 = fields.next()?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

/// Traces `rays` on `pool`; `trace(chunk)` returns how many hit.
pub fn throughput<R: Sync>(
    pool: &rayon::ThreadPool,
    rays: &[R],
    min_seconds: f64,
    trace: impl Fn(&[R]) -> usize + Sync,
) -> Traced {
    pool.install(|| {
        let (cpu, wall) = (process_cpu_seconds(), Instant::now());
        let (seconds, hits) = best_time(min_seconds, || {
            rays.par_chunks(CHUNK).map(&trace).sum::<usize>()
        });
        let wall = wall.elapsed().as_secs_f64();
        let cpu_per_wall = cpu
            .zip(process_cpu_seconds())
            .filter(|_| wall > 0.05)
            .map(|(a, b)| (b - a) / wall);
        Traced {
            mrays_per_s: rays.len() as f64 / seconds / 1e6,
            rays: rays.len(),
            hits,
            cpu_per_wall,
        }
    })
}
